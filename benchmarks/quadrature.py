"""Accuracy per cost of the two forcing quadratures against the continuous-x N-mode model
(docs/numerics.md, "The quadrature"): python benchmarks/quadrature.py [--nmod 20 60 120] [--quick]

For each case and N, every run's strain (24 snapshots over the stage, 601 points) is compared
with a reference: the Gauss rule at density 24 and tolerance 1e-12, whose own uncertainty is
printed (its distance from a density-16 run at the same tolerance). The runs:
  paper: subintervals 1000..8000 x tolerance 1e-6..1e-11 (two a decade);
  gauss: density 4, 6 x subintervals 250, 500 x tolerance 1e-6..1e-11 (two a decade).
Each run's wall time is the smaller of two (the machine is noisy: only ratios in one run count).
For each error target the cheapest run of each rule that meets it, and the ratio, and for each
case today's default (paper, 1000 subintervals, tolerance 1e-8) beside the cheapest Gauss run
within 2e-6, go to results/bench/quadrature.md; every run to results/bench/quadrature.csv; error against time to
results/bench/quadrature.png.

--loose (about 4 min): the targets 1e-3, 1e-4, 1e-5 with each rule on its cheapest tables too,
the paper's at 500 and 1000 subintervals, the Gauss rule at 125 and 250 and density 3 and 4, at
tolerances 1e-5..1e-8, to results/bench/quadrature_loose.md (docs/numerics.md, "Loose targets").
"""
import argparse
import csv
import time
from pathlib import Path

import numpy as np

from solver import Parameters, Settings, solve
from solver.settings import PAPER_NUMERICS

#: name -> (parameters, the part of the stage compared: the fast impact bottoms out at 0.86..0.94
#: of it, by N, so its runs stop at 0.8)
CASES = {
    "reference": ({}, 0.97),
    "thin ice (hi = 0.2 m)": ({"hi": 0.2}, 0.97),
    "stiff layer (K = 8e7 Pa)": ({"K": 8e7}, 0.97),
    "fast on thick ice (V = 10 m/s, hi = 1 m)": ({"V": 10.0, "hi": 1.0}, 0.8),
}
TOLERANCES = [1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 3e-9, 1e-9, 3e-10, 1e-10, 1e-11]
#: the issue's target for the default settings: this error at no more wall time than the paper's
#: default (1000 subintervals, tolerance 1e-8)
DEFAULT_TARGET = 2e-6
TARGETS = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7]
LOOSE_TOLERANCES = [1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8]
LOOSE_TARGETS = [1e-3, 1e-4, 1e-5]
OUT = Path("results/bench")


def loose_runs():
    """Each rule on its cheapest tables at loose tolerances (--loose)."""
    for sub in (500, 1000):
        for tol in LOOSE_TOLERANCES:
            yield "paper", dict(subintervals=sub, tolerance=tol)
    for dens in (3.0, 4.0):
        for sub in (125, 250):
            for tol in LOOSE_TOLERANCES:
                yield "gauss", dict(quadrature="gauss", quadrature_density=dens, subintervals=sub, tolerance=tol)


def runs(quick: bool, defaults_only: bool = False, loose: bool = False):
    if loose:
        yield from loose_runs()
        return
    yield "paper default", PAPER_NUMERICS
    default = Settings()
    yield "default", dict(quadrature=default.quadrature, quadrature_density=default.quadrature_density,
                          subintervals=default.subintervals, tolerance=default.tolerance)
    if defaults_only:
        return
    tols = TOLERANCES[::4] if quick else TOLERANCES
    for sub in ((1000, 4000) if quick else (1000, 2000, 4000, 8000)):
        for tol in tols:
            yield "paper", dict(subintervals=sub, tolerance=tol)
    for dens in ((4.0,) if quick else (4.0, 6.0)):
        for sub in ((250,) if quick else (250, 500)):
            for tol in tols:
                yield "gauss", dict(quadrature="gauss", quadrature_density=dens, subintervals=sub, tolerance=tol)


def strain(p, settings, times, x, repeats=2):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = solve(p, settings, times=times, x=x, fields=("strain",), t_end=times[-1])
        best = min(best, time.perf_counter() - t0)
    return r, best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nmod", type=int, nargs="+", default=[20, 60, 120])
    ap.add_argument("--quick", action="store_true", help="a few runs a case (a smoke test)")
    ap.add_argument("--defaults-only", action="store_true",
                    help="only the paper's old default beside today's (3 min): results/bench/quadrature_defaults.md")
    ap.add_argument("--loose", action="store_true",
                    help="targets 1e-3..1e-5, each rule on its cheapest tables: results/bench/quadrature_loose.md")
    ap.add_argument("--plot-only", action="store_true", help="redraw the figure from results/bench/quadrature.csv")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    if args.plot_only:
        with open(OUT / "quadrature.csv") as fh:
            rows = [dict(r, N=int(r["N"]), error=float(r["error"]), time=float(r["time"])) for r in csv.DictReader(fh)]
        figure(rows, sorted({r["N"] for r in rows}), OUT / "quadrature.png")
        return
    rows, md = [], ["| case | N | target | paper: cheapest run | time [s] | gauss: cheapest run | time [s] | "
                    "paper / gauss |", "|---|---|---|---|---|---|---|---|"]
    notes = []
    for name, (kw, end) in CASES.items():
        for N in args.nmod:
            p = Parameters(Nmod=N, **kw)
            times = np.linspace(0.04, end, 24) * p.stage_duration
            x = np.linspace(-p.L, p.L, 601)
            ref, _ = strain(p, Settings(quadrature="gauss", quadrature_density=24, tolerance=1e-12, error_control="embedded",
                                        error_estimate=False), times, x, repeats=1)
            check, _ = strain(p, Settings(quadrature="gauss", quadrature_density=16, tolerance=1e-12, error_control="embedded",
                                          error_estimate=False), times, x, repeats=1)
            valid = ref.valid & check.valid
            e_ref = ref.fields["strain"][valid]
            norm = np.linalg.norm(e_ref)
            own = np.linalg.norm(check.fields["strain"][valid] - e_ref) / norm
            notes.append(f"- {name}, N = {N}: reference {ref.status} to {ref.time_reached / p.stage_duration:.3f} "
                         f"of the stage; its uncertainty (density 16 against 24) {own:.1e}")
            print(notes[-1], flush=True)
            case_rows = []
            for rule, kws in runs(args.quick, args.defaults_only, args.loose):
                r, wall = strain(p, Settings(error_estimate=False, **kws), times, x, repeats=3 if "default" in rule else 2)
                ok = r.valid[valid]
                err = (np.linalg.norm(r.fields["strain"][valid] - e_ref) / norm) if ok.all() else np.inf
                row = dict(case=name, N=N, rule=rule, subintervals=kws["subintervals"],
                           density=kws.get("quadrature_density", ""), tolerance=kws["tolerance"], error=err,
                           time=wall, energy_residual=r.diagnostics["energy_residual"], status=r.status)
                rows.append(row)
                case_rows.append(row)
            if args.loose:
                md.extend(_target_rows(name, N, case_rows, LOOSE_TARGETS))
                print("\n".join(md[-len(LOOSE_TARGETS):]), flush=True)
                continue
            old, new = case_rows[0], case_rows[1]
            notes.append(f"- {name}, N = {N}: the paper's default (1000 subintervals, tol 1e-8) {old['error']:.1e} in "
                         f"{old['time']:.3f} s, energy residual {old['energy_residual']:.1e}; today's default "
                         f"({new['subintervals']} subintervals, density {new['density']:g}, tol {new['tolerance']:g}) "
                         f"{new['error']:.1e} in {new['time']:.3f} s ({new['time'] / old['time']:.2f} of the time), "
                         f"energy residual {new['energy_residual']:.1e}")
            print(notes[-1], flush=True)
            if args.defaults_only:
                continue
            md.extend(_target_rows(name, N, case_rows, TARGETS))
            print("\n".join(md[-len(TARGETS):]), flush=True)
            default = [r for r in case_rows if r["rule"] == "paper" and r["subintervals"] == 1000
                       and r["tolerance"] == 1e-8]
            within = [r for r in case_rows if r["rule"] == "gauss" and r["error"] <= DEFAULT_TARGET]
            if default and within:
                d, g = default[0], min(within, key=lambda r: r["time"])
                notes.append(f"- {name}, N = {N}: today's default {d['error']:.1e} in {d['time']:.3f} s; the "
                             f"cheapest Gauss run within {DEFAULT_TARGET:g}: {g['subintervals']} subintervals, "
                             f"density {g['density']:g}, tol {g['tolerance']:g}, {g['error']:.1e} in "
                             f"{g['time']:.3f} s ({g['time'] / d['time']:.2f} of the default's time)")
                print(notes[-1], flush=True)
    if args.loose:
        (OUT / "quadrature_loose.md").write_text("\n".join(notes + [""] + md) + "\n")
        print(f"wrote {OUT / 'quadrature_loose.md'}")
        return
    if args.defaults_only:
        (OUT / "quadrature_defaults.md").write_text("\n".join(notes) + "\n")
        print(f"wrote {OUT / 'quadrature_defaults.md'}")
        return
    with open(OUT / "quadrature.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    (OUT / "quadrature.md").write_text("\n".join(notes + [""] + md) + "\n")
    figure(rows, args.nmod, OUT / "quadrature.png")
    print(f"wrote {OUT / 'quadrature.md'}, {OUT / 'quadrature.csv'}, {OUT / 'quadrature.png'}")


def _target_rows(name, N, case_rows, targets):
    """A table row per target: the cheapest run of each rule that reaches it, and their ratio."""
    out = []
    for target in targets:
        best = {}
        for rule in ("paper", "gauss"):
            ok = [r for r in case_rows if r["rule"] == rule and r["error"] <= target]
            best[rule] = min(ok, key=lambda r: r["time"]) if ok else None

        def label(r):
            if r is None:
                return "none reaches it", "—"
            dens = f", density {r['density']:g}" if r["rule"] == "gauss" else ""
            return (f"{r['subintervals']} subintervals{dens}, tol {r['tolerance']:g} "
                    f"(error {r['error']:.1e})", f"{r['time']:.3f}")
        ratio = f"{best['paper']['time'] / best['gauss']['time']:.2f}" if best["paper"] and best["gauss"] else "—"
        out.append(f"| {name} | {N} | {target:g} | {' | '.join(label(best['paper']))} | "
                   f"{' | '.join(label(best['gauss']))} | {ratio} |")
    return out


def figure(rows, nmods, path):
    import matplotlib
    import matplotlib.ticker
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(len(nmods), len(CASES), figsize=(4 * len(CASES), 3.3 * len(nmods)), squeeze=False,
                             sharey=True)
    for i, N in enumerate(nmods):
        for j, name in enumerate(CASES):
            ax = axes[i, j]
            for rule, colour in (("paper", "tab:blue"), ("gauss", "tab:red")):
                sel = [r for r in rows if r["case"] == name and r["N"] == N and r["rule"] == rule
                       and np.isfinite(r["error"])]
                ax.loglog([r["time"] for r in sel], [max(r["error"], 1e-10) for r in sel], "o", ms=3,
                          color=colour, label=f"{rule}")
            ax.set_title(f"{name}, N = {N}", fontsize=8)
            ax.grid(True, which="major", alpha=0.3)
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            if i == len(nmods) - 1:
                ax.set_xlabel("wall time [s]")
            if j == 0:
                ax.set_ylabel("relative L2 strain error")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Error against the continuous-x model, against wall time: the paper's rule and the Gauss rule")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
