"""A free floe under the default numerics against the paper's rule at the 2000 subintervals that
studies/floe_size.toml used (docs/model.md, "Beyond the paper: a free floe"): side by side in one
process, the wall time of a run (median of 3, after a warm-up) and the relative error of its
max_strain and of its strain field against the continuous floe model (the contact-resolving rule
at 16 nodes a wavelength on 1000 subintervals, tolerance 1e-12). The floe_size cases: Nmod = 100,
20 ms, L = 0.5 ... 16 m, V = 2 and 5 m/s.

Then the reference case (N = 60, run to the walls' stage end 0.12 s) on the walled plate and the
floe, centred and off centre, under the default numerics and the paper's rule at 1000
subintervals and 1e-8: medians of 5. Then the four tension maxima of two floes (6 m, N = 20; 2
m, N = 16; 10 ms), etd34 at 1e-9 and 1e-10 against DOP853 at 1e-12 (docs/model.md, "Maxima of
the impact zone").

    python benchmarks/floe.py          (about 4 min) -> three markdown tables on stdout
"""
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from solver import Parameters, Settings, solve  # noqa: E402

RULES = {"default (gauss, 250)": Settings(error_estimate=False),
         "paper, 2000": Settings(quadrature="paper", subintervals=2000, error_estimate=False)}
REFERENCE = Settings(quadrature_density=16, subintervals=1000, tolerance=1e-12, error_estimate=False,
                     error_control="embedded")
TIMES = np.linspace(0.0, 0.02, 21)


def _run(p, s):
    return solve(p, s, fields=("strain",), times=TIMES)


def _timed(p, s, repeats=3):
    _run(p, s)
    walls = []
    for _ in range(repeats):
        started = time.perf_counter()
        r = _run(p, s)
        walls.append(time.perf_counter() - started)
    return r, float(np.median(walls))


def main():
    print("| L [m] | V [m/s] | " + " | ".join(f"{n}: wall [s] | max_strain | strain field" for n in RULES) + " |")
    print("|---" * (2 + 3 * len(RULES)) + "|")
    for L in (0.5, 1.0, 2.0, 4.0, 8.0, 16.0):
        for V in (2.0, 5.0):
            p = Parameters(Nmod=100, edges="free", duration=0.02, L=L, V=V)
            ref = _run(p, REFERENCE)
            top = np.max(np.abs(ref.fields["strain"]))
            cells = []
            for s in RULES.values():
                r, wall = _timed(p, s)
                err = r.diagnostics["max_strain"] / ref.diagnostics["max_strain"] - 1
                field = np.max(np.abs(r.fields["strain"] - ref.fields["strain"])) / top
                cells.append(f"{wall:.3f} | {err:+.1e} | {field:.1e}")
            print(f"| {L:g} | {V:g} | " + " | ".join(cells) + " |", flush=True)


def reference_cost():
    walls = Parameters(Nmod=60)
    stage = walls.L**2 / (6 * walls.R * walls.V)
    rules = {"default": Settings(error_estimate=False),
             "paper, 1000, 1e-8": Settings(quadrature="paper", subintervals=1000, tolerance=1e-8, error_estimate=False)}
    print("\n| case | " + " | ".join(f"{n}: wall [s] | steps" for n in rules) + " |")
    print("|---" * (1 + 2 * len(rules)) + "|")
    for label, p in (("walls", walls), ("floe", walls.replace(edges="free", duration=stage)),
                     ("walls, x0 = 1 m", walls.replace(x0=1.0)),
                     ("floe, x0 = 1 m", walls.replace(edges="free", duration=stage, x0=1.0))):
        cells = []
        for s in rules.values():
            solve(p, s, fields=())
            walls_ = []
            for _ in range(5):
                started = time.perf_counter()
                r = solve(p, s, fields=())
                walls_.append(time.perf_counter() - started)
            cells.append(f"{np.median(walls_):.3f} | {r.steps}")
        print(f"| {label} | " + " | ".join(cells) + " |", flush=True)


def maxima():
    names = ("max_strain", "max_strain_lower", "impact_zone_max_strain", "impact_zone_max_strain_lower")
    print("\n| floe | tolerance | " + " | ".join(names) + " |")
    print("|---" * (2 + len(names)) + "|")
    for label, p in (("6 m, N = 20", Parameters(Nmod=20, edges="free", L=6.0, duration=0.01)),
                     ("2 m, N = 16, V = 2", Parameters(Nmod=16, edges="free", L=2.0, duration=0.01, V=2.0))):
        ref = solve(p, Settings(integrator="dop853", tolerance=1e-12, error_estimate=False), fields=())
        for tol in (1e-9, 1e-10):
            r = solve(p, Settings(tolerance=tol, error_estimate=False), fields=())
            print(f"| {label} | {tol:.0e} | " + " | ".join(f"{r.diagnostics[k] / ref.diagnostics[k] - 1:+.1e}"
                                                          for k in names) + " |", flush=True)


if __name__ == "__main__":
    main()
    reference_cost()
    maxima()
