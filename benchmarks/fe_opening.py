"""The solver against the finite elements through breaks whose cracks open over a time
(docs/model.md, "A crack that opens over a time"): the reference case breaking with
``crack_speed`` (its own breaks, located on its sub-steps), and the elements broken at the same
times and places, each crack opening over the same time (tests/fe_reference.run); the
upper-surface strain at least AWAY from the breaks over the largest strain there, and the force on
the body over the largest force, from the first break for WINDOW; the elements at each spacing,
their own uncertainty the two finest's difference over 3. Writes results/bench/fe_opening.md.

    python benchmarks/fe_opening.py [--modes 60 120] [--spacing 0.02 0.01] [--crack-speed 2e4]
                                    [--edge-shapes 0] [--crack-spacing 0]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT.parent / "tests"))
sys.path.insert(0, str(ROOT))
from fe_breaks import AWAY, DT, EPS_Y, WINDOW, spacing_rows  # noqa: E402
from report import write_report  # noqa: E402

from solver import Parameters, Settings, solve  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, nargs="+", default=[60, 120])
    parser.add_argument("--spacing", type=float, nargs="+", default=[0.02, 0.01])
    parser.add_argument("--crack-speed", type=float, default=2e4)
    parser.add_argument("--edge-shapes", type=int, default=0, help="the solver's edge shapes (needs --crack-spacing)")
    parser.add_argument("--crack-spacing", type=float, default=0.0, help="in ice thicknesses (0: none)")
    args = parser.parse_args()
    x = np.linspace(0.0, 3.0, 301)
    lines = ["# The solver against Hermite finite elements through cracks that open over a time", "",
             f"Reference case, the solver at tolerance 1e-10, eps_Y {EPS_Y:g}, crack speed {args.crack_speed:g} m/s, "
             f"edge shapes {args.edge_shapes}, crack spacing {args.crack_spacing:g} hi; "
             f"the elements' steps {DT:g} s; the strain at x = 0..3 m at least {AWAY:g} m from a break, over the "
             f"largest strain there; the force over the largest force; {WINDOW * 1e3:g} ms from the first break.", "",
             "| N | breaks [ms, m] | spacing [m] | strain | force | elements' energy residual | elements' time [s] |",
             "|" + "---|" * 7]
    for N in args.modes:
        p = Parameters(Nmod=N, fracture="break", yield_strain=EPS_Y, crack_speed=args.crack_speed,
                       edge_shapes=args.edge_shapes, crack_spacing=args.crack_spacing)
        probe = solve(p, Settings(quadrature="gauss", tolerance=1e-10), fields=(), times=[0.0, 2e-3], t_end=2e-3)
        first = probe.breaking.first_break_time
        times = np.linspace(first, first + WINDOW, 21)
        ours = solve(p, Settings(quadrature="gauss", tolerance=1e-10), fields=("strain",), x=x, times=times,
                     t_end=times[-1])
        breaks = [(e.time, e.x) for e in ours.breaking.breaks]
        lines += spacing_rows(f"{N}", p, breaks, times, x, ours, args.spacing, p.crack_opening_time)
    write_report("fe_opening", lines)


if __name__ == "__main__":
    main()
