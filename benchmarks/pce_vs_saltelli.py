"""Sobol' indices from a polynomial-chaos surrogate of 256 runs against Saltelli's estimates from
28 672 (issue 39): the table and the figure of docs/user_guide.md, "Sobol' indices from a
surrogate".

    make study STUDY=sensitivity ARGS="--yes"     # Saltelli, 4096 base samples x (5 + 2) cases
    make study STUDY=sensitivity_pce              # a scrambled Sobol' design of 256 cases
    python benchmarks/pce_vs_saltelli.py [--saltelli results/sensitivity] [--pce results/sensitivity_pce]

For each output both analyses have, and each key: ST and S1 from each method, the PCE's
interval and Saltelli's 95% bootstrap interval, |ST_pce - ST_saltelli|, whether the PCE's
interval covers Saltelli's value and whether the two intervals overlap; then each study's cost
(cases and solver time; the wall times are the runs' own, in the user guide). Writes
docs/sensitivity_pce.png.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]


def compare(saltelli: xr.Dataset, pce: xr.Dataset) -> list:
    rows = []
    for output in [o for o in pce["output"].values if o in saltelli["output"].values]:
        s, p = saltelli.sel(output=output), pce.sel(output=output)
        for key in pce["key"].values:
            row = {"output": str(output), "key": str(key)}
            for name in ("S1", "ST"):
                sv, sc = float(s[name].sel(key=key)), float(s[f"{name}_conf"].sel(key=key))
                pv, lo, hi = (float(p[v].sel(key=key)) for v in (name, f"{name}_low", f"{name}_high"))
                row.update({f"{name}_saltelli": sv, f"{name}_saltelli_conf": sc, f"{name}_pce": pv,
                            f"{name}_low": lo, f"{name}_high": hi, f"{name}_difference": abs(pv - sv),
                            f"{name}_covers": lo <= sv <= hi, f"{name}_overlap": lo <= sv + sc and sv - sc <= hi})
            rows.append(row)
    return rows


def figure(rows: list, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    outputs = list(dict.fromkeys(r["output"] for r in rows))
    fig, axes = plt.subplots(1, len(outputs), figsize=(3.6 * len(outputs) + 0.6, 3.8), squeeze=False,
                             constrained_layout=True, sharey=True)
    for ax, output in zip(axes[0], outputs):
        sel = [r for r in rows if r["output"] == output]
        x = np.arange(len(sel))
        st = np.array([r["ST_saltelli"] for r in sel])
        ax.bar(x - 0.2, st, 0.4, yerr=[r["ST_saltelli_conf"] for r in sel], capsize=3, color="#999999",
               label="Saltelli, 28 672 runs (95% bootstrap)")
        pv = np.array([r["ST_pce"] for r in sel])
        ax.bar(x + 0.2, pv, 0.4, yerr=[pv - [r["ST_low"] for r in sel], [r["ST_high"] for r in sel] - pv], capsize=3,
               color="#D55E00", label="polynomial chaos, 256 runs (sampling + truncation)")
        ax.set_xticks(x, [r["key"] for r in sel])
        ax.set_title(f"ST of {output}", fontsize=10)
        ax.grid(alpha=0.3, axis="y")
    axes[0, 0].set_ylabel("total Sobol' index ST")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=9)
    fig.savefig(path, dpi=110)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--saltelli", type=Path, default=ROOT / "results" / "sensitivity")
    parser.add_argument("--pce", type=Path, default=ROOT / "results" / "sensitivity_pce")
    parser.add_argument("--figure", type=Path, default=ROOT / "docs" / "sensitivity_pce.png")
    args = parser.parse_args(argv)
    with xr.open_dataset(args.saltelli / "sensitivity.nc") as s, xr.open_dataset(args.pce / "sensitivity.nc") as p:
        rows = compare(s.load(), p.load())
        q2 = {str(o): (float(p["q2"].sel(output=o)), int(p["degree"].sel(output=o))) for o in p["output"].values}
        costs = {name: (int(d.attrs["samples"]), float(d.attrs["solver_time_total"]))
                 for name, d in (("saltelli", s), ("pce", p))}
    print("| output | key | ST Saltelli | ST pce [interval] | abs diff | covers | S1 Saltelli | S1 pce [interval] |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['output']} | {r['key']} | {r['ST_saltelli']:.3f} ± {r['ST_saltelli_conf']:.3f} | "
              f"{r['ST_pce']:.3f} [{r['ST_low']:.3f}, {r['ST_high']:.3f}] | {r['ST_difference']:.3f} | "
              f"{'yes' if r['ST_covers'] else 'no' + (' (overlap)' if r['ST_overlap'] else '')} | "
              f"{r['S1_saltelli']:.3f} ± {r['S1_saltelli_conf']:.3f} | {r['S1_pce']:.3f} [{r['S1_low']:.3f}, "
              f"{r['S1_high']:.3f}] |")
    print()
    for output, (value, degree) in q2.items():
        print(f"{output}: Q2 = {value:.4f} at degree {degree}")
    print(f"largest |ST_pce - ST_saltelli|: {max(r['ST_difference'] for r in rows):.4f}; "
          f"ST intervals covering Saltelli's value: {sum(r['ST_covers'] for r in rows)} of {len(rows)}; "
          f"S1: {sum(r['S1_covers'] for r in rows)} of {len(rows)}")
    for name, (cases, solver_time) in costs.items():
        print(f"{name}: {cases} cases, {solver_time:.0f} s of solver time")
    figure(rows, args.figure)
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
