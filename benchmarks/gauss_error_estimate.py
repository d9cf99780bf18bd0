"""The per-case error estimate of the Gauss rule against its true error (docs/numerics.md,
"Per-case error estimate"): python benchmarks/gauss_error_estimate.py [--nmod 20 60]

For six cases, N = 20 and 60, densities 3, 4, 6 and tolerances 1e-8, 1e-9, 1e-11, each run's
strain error over 24 snapshots (relative L2 over the modes, as error_estimate) against the Gauss
rule at density 24 and tolerance 1e-12, beside its estimate error_estimate_time +
error_estimate_quadrature (the reference has the same modes, so the modal part is left out).
Every run to results/bench/gauss_error_estimate.csv; the range of estimate / true error per
density, and the runs it understates more than 2x, to results/bench/gauss_error_estimate.md.
"""
import argparse
import csv
from pathlib import Path

import numpy as np

from solver import Parameters, Settings, solve
from solver.model.assemble import Tables

#: name -> (parameters, the part of the stage compared)
CASES = {
    "reference": ({}, 0.97),
    "thin ice (hi = 0.2 m)": ({"hi": 0.2}, 0.97),
    "stiff layer (K = 8e7 Pa)": ({"K": 8e7}, 0.97),
    "fast on thick ice (V = 10 m/s, hi = 1 m)": ({"V": 10.0, "hi": 1.0}, 0.8),
    "off centre (x0 = 3 m)": ({"x0": 3.0}, 0.9),
    "viscoelastic layer (layer_tau = 1e-3 s)": ({"layer_tau": 1e-3}, 0.9),
}
DENSITIES = (3.0, 4.0, 6.0)
TOLERANCES = (1e-8, 1e-9, 1e-11)
OUT = Path("results/bench")


def modal_error(run, reference, tables):
    """Relative L2 strain error over the snapshots, from the amplitudes (as error_estimate)."""
    a = tables.to_kernel(run.amplitudes, run.antisymmetric_amplitudes) * tables.strain_coef
    b = tables.to_kernel(reference.amplitudes, reference.antisymmetric_amplitudes) * tables.strain_coef
    return float(np.sqrt(np.sum((a - b) ** 2) / np.sum(b**2)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nmod", type=int, nargs="+", default=[20, 60])
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, (kw, end) in CASES.items():
        for N in args.nmod:
            p = Parameters(Nmod=N, **kw)
            times = np.linspace(0.05, end, 24) * p.stage_duration
            ref = solve(p, Settings(quadrature_density=24, tolerance=1e-12, error_estimate=False, error_control="embedded"), times=times,
                        fields=(), t_end=times[-1])
            tables = Tables(p, Settings().subintervals, None, "gauss")
            for density in DENSITIES:
                for tol in TOLERANCES:
                    r = solve(p, Settings(quadrature_density=density, tolerance=tol), times=times, fields=(),
                              t_end=times[-1])
                    g = r.diagnostics
                    true = modal_error(r, ref, tables)
                    est = g["error_estimate_time"] + g["error_estimate_quadrature"]
                    rows.append(dict(case=name, N=N, density=density, tolerance=tol, status=r.status, true=true,
                                     time_part=g["error_estimate_time"], quadrature_part=g["error_estimate_quadrature"],
                                     ratio=est / true))
                    print(f"{name}, N = {N}, density {density:g}, tol {tol:g}: true {true:.2e}, estimate {est:.2e} "
                          f"({est / true:.2f}x)", flush=True)
    with open(OUT / "gauss_error_estimate.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = ["| density | runs | estimate / true error | understated > 2x |", "|---|---|---|---|"]
    for density in DENSITIES:
        some = [r for r in rows if r["density"] == density and r["status"] == "ok"]
        ratios = [r["ratio"] for r in some]
        low = "; ".join(f"{r['case']} N = {r['N']} tol {r['tolerance']:g} ({r['ratio']:.2f})"
                        for r in some if r["ratio"] < 0.5) or "none"
        lines.append(f"| {density:g} | {len(some)} | {min(ratios):.2f}-{max(ratios):.2f} | {low} |")
    (OUT / "gauss_error_estimate.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
