"""Where the breakthrough of the reference case is, by the finite elements' own breaks
(tests/fe_reference.py, breaking_run), against how near a fresh free edge the ice may break again
(docs/model.md, "An independent check through a break"): for each band [m] and element spacing,
the elements' breaks (time, place, surface) to the breakthrough, the first break off the centre.

    python benchmarks/fe_breakthrough.py [--bands 0.1 0.25 0.5] [--spacing 0.02 0.01] [--opening-times 0 1e-4]
                                         [--dt 4e-7] [--scheme exponential]

The elements break at a node where an armed surface's tension first reaches the yield strain
(armed as the solver's: once its peak is below it), skipping the nodes closer than the band to a
break, as the solver's crack spacing does (with no band, the break's node and the next: a free
edge's own tension is 0 only weakly in the elements). Each crack opens at once, or over an
opening time (its moment and shear released linearly: tests/fe_reference._break). The elements
step exactly for their linear part by default (tests/fe_reference._exponential_step).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import fe_reference as fe  # noqa: E402

from solver import Parameters  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bands", type=float, nargs="+", default=[0.0, 0.1, 0.25, 0.5])
    parser.add_argument("--spacing", type=float, nargs="+", default=[0.02, 0.01])
    parser.add_argument("--dt", type=float, default=4e-7)
    parser.add_argument("--scheme", choices=sorted(fe.STEPS), default="exponential", help="the elements' time step")
    parser.add_argument("--opening-times", type=float, nargs="+", default=[0.0], help="[s] (0: at once)")
    args = parser.parse_args()
    p = Parameters(fracture="break")
    print(f"Reference case, yield strain {p.yield_strain:g}, the elements' steps {args.dt:g} s ({args.scheme}).\n")
    print("| opening time [s] | band [m] | spacing [m] | first break [ms, m, surface] | breakthrough [ms, m, surface] "
          "| time [s] |")
    print("|---|---|---|---|---|---|")
    for opening, band, spacing in ((o, b, s) for o in args.opening_times for b in args.bands for s in args.spacing):
        started = time.perf_counter()
        breaks = fe.breaking_run(p, spacing=spacing, dt=args.dt, t_end=1.5e-3, band=band, opening_time=opening,
                                  scheme=args.scheme)
        cells = [f"{1e3 * t:.5f}, {x:.3f}, {s}" for t, x, s in breaks]
        first, through = cells[0], (cells[-1] if len(breaks) > 1 and breaks[-1][1] > 0 else "none by 1.5 ms")
        print(f"| {opening:g} | {band:g} | {spacing:g} | {first} | {through} | {time.perf_counter() - started:.0f} |",
              flush=True)

if __name__ == "__main__":
    main()
