"""The solver against the finite elements through breaks whose cracks open over a time
(docs/model.md, "A crack that opens over a time"): the reference case breaking with
``crack_speed`` (its own breaks, located on its sub-steps), and the elements broken at the same
times and places, each crack opening over the same time (tests/fe_reference.run); the
upper-surface strain at least AWAY from the breaks over the largest strain there, and the force on
the body over the largest force, for WINDOW from the first break (or the one --after-break names).
The elements run at each spacing (at the first step) and at each step (at the finest spacing):
their own uncertainty in space is the
two finest spacings' difference over 3 (their strain converges as h^2), in time the two shortest
steps' difference. Their step is the exponential one by default (exact for the plate's and the
water's linear part: tests/fe_reference._exponential_step; its difference between 8e-7 and 4e-7 s
is about 1e-6); ``--scheme trapezoid`` takes the trapezoidal rule, whose phase error on the
release's short waves is 5e-2 at 4e-7 s. With two spacings or more the elements' strain is also
extrapolated (h^2, Richardson) from the finest two, its own uncertainty (with three) the
extrapolations from the finest two and from the next two apart. The last row of each N gives the
difference at each of the 21 times against the extrapolated elements (or the finest spacing's at
the shortest step). Writes results/bench/fe_opening.md.

    python benchmarks/fe_opening.py [--modes 60 120] [--spacing 0.02 0.01] [--dt 8e-7 4e-7]
                                    [--crack-speed 2e4] [--edge-shapes 0] [--crack-spacing 0]
                                    [--scheme exponential] [--after-break 1]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT.parent / "tests"))
sys.path.insert(0, str(ROOT))
import fe_reference as fe  # noqa: E402
from fe_breaks import AWAY, EPS_Y, WINDOW, agreement, own_uncertainty  # noqa: E402
from report import write_report  # noqa: E402

from solver import Parameters, Settings, solve  # noqa: E402


def elements_rows(N, p, breaks, times, x, ours, spacings, steps, scheme="exponential") -> list:
    """The report's rows for N: the elements at each spacing at the longest step, and at each
    shorter step at the finest spacing ('| N | breaks | spacing, step | strain | force | residual
    | seconds |'); their own uncertainty in space (fe_breaks.own_uncertainty) and in time (the two
    shortest steps apart), over the solver's largest strain; the solver against the elements'
    h^2 extrapolation from the finest two spacings (and, with three, that extrapolation's own
    uncertainty); and the strain difference at each time against the extrapolated elements (the
    finest spacing's at the shortest step with one spacing). Each row printed as it comes."""
    rows, runs = [], {}
    where = ", ".join(f"{1e3 * t:.5f}, {b:.4f}" for t, b in breaks)
    keep = np.all([np.abs(x - b) >= AWAY for _, b in breaks], axis=0)
    scale = np.max(np.abs(ours.fields["strain"][:, keep]))
    finest, longest = min(spacings), max(steps)
    for spacing, dt in [(h, longest) for h in sorted(spacings, reverse=True)] + [(finest, dt) for dt in steps
                                                                                 if dt != longest]:
        started = time.perf_counter()
        strain, force, residual = fe.run(p, breaks, times, x, spacing=spacing, dt=dt, opening_time=p.crack_opening_time,
                                         scheme=scheme)
        runs[spacing, dt] = strain
        s_diff, f_diff = agreement(strain, force, ours, breaks, x)
        rows.append(f"| {N} | {where} | {spacing:g} m, {dt:g} s | {s_diff:.2e} | {f_diff:.2e} | {residual:.1e} "
                    f"| {time.perf_counter() - started:.1f} |")
        print(rows[-1], flush=True)

    def apart(one, other):
        return np.nanmax(np.abs(runs[one] - runs[other])[:, keep]) / scale

    by_size, by_step, summary = sorted(spacings), sorted(steps), []
    if len(by_size) > 1:
        _, own_space = own_uncertainty({h: runs[h, longest] for h in spacings}, ours, breaks, x)
        summary.append(f"| {N} | | own uncertainty in space at {finest:g} m | {own_space:.2e} | | | |")
        extrapolated = {}
        for fine, coarse in zip(by_size[:-1], by_size[1:]):
            extrapolated[fine] = runs[fine, longest] + (runs[fine, longest] - runs[coarse, longest]) / 3.0
        best = extrapolated[finest]
        own = (f"{np.nanmax(np.abs(best - extrapolated[by_size[1]])[:, keep]) / scale:.2e}"
               if len(by_size) > 2 else "")
        summary.append(f"| {N} | | extrapolated (h^2) from {by_size[1]:g} and {finest:g} m; its own uncertainty: "
                       f"the extrapolations from the finest two and the next two apart | "
                       f"{np.nanmax(np.abs(best - ours.fields['strain'])[:, keep]) / scale:.2e} | | {own} | |")
    if len(by_step) > 1:
        summary.append(f"| {N} | | own uncertainty in time at {by_step[0]:g} s | "
                       f"{apart((finest, by_step[0]), (finest, by_step[1])):.2e} | | | |")
    reference = best if len(by_size) > 1 else runs[finest, by_step[0]]
    each = np.nanmax(np.abs(reference - ours.fields["strain"])[:, keep], axis=1) / scale
    summary.append(f"| {N} | | strain at each time [ms: difference{', extrapolated' if len(by_size) > 1 else ''}] | "
                   + ", ".join(f"{1e3 * t:.4f}: {d:.1e}" for t, d in zip(times, each)) + " | | | |")
    print(*summary, sep="\n", flush=True)
    rows += summary
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, nargs="+", default=[60, 120])
    parser.add_argument("--spacing", type=float, nargs="+", default=[0.02, 0.01])
    parser.add_argument("--dt", type=float, nargs="+", default=[8e-7, 4e-7], help="the elements' steps [s]")
    parser.add_argument("--scheme", choices=sorted(fe.STEPS), default="exponential", help="the elements' time step")
    parser.add_argument("--crack-speed", type=float, default=2e4)
    parser.add_argument("--edge-shapes", type=int, default=0, help="the solver's edge shapes")
    parser.add_argument("--crack-spacing", type=float, default=0.0, help="in ice thicknesses (0: none)")
    parser.add_argument("--after-break", type=int, default=1, help="the window starts at this break (1: the first)")
    args = parser.parse_args()
    x = np.linspace(0.0, 3.0, 301)
    lines = ["# The solver against Hermite finite elements through cracks that open over a time", "",
             f"Reference case, the solver at tolerance 1e-10, eps_Y {EPS_Y:g}, crack speed {args.crack_speed:g} m/s, "
             f"edge shapes {args.edge_shapes}, crack spacing {args.crack_spacing:g} hi; the elements at each spacing "
             f"at steps of {max(args.dt):g} s ({args.scheme}), and at each step at {min(args.spacing):g} m; the strain at x = 0..3 m at "
             f"least {AWAY:g} m from a break, over the largest strain there; the force over the largest force; "
             f"{WINDOW * 1e3:g} ms from break {args.after_break}.", "",
             "| N | breaks [ms, m] | elements | strain | force | elements' energy residual | elements' time [s] |",
             "|" + "---|" * 7]
    for N in args.modes:
        p = Parameters(Nmod=N, fracture="break", yield_strain=EPS_Y, crack_speed=args.crack_speed,
                       edge_shapes=args.edge_shapes, crack_spacing=args.crack_spacing)
        probe = solve(p, Settings(quadrature="gauss", tolerance=1e-10), fields=(), times=[0.0, 2e-3], t_end=2e-3)
        first = probe.breaking.breaks[args.after_break - 1].time
        times = np.linspace(first, first + WINDOW, 21)
        ours = solve(p, Settings(quadrature="gauss", tolerance=1e-10), fields=("strain",), x=x, times=times,
                     t_end=times[-1])
        breaks = [(e.time, e.x) for e in ours.breaking.breaks]
        lines += elements_rows(N, p, breaks, times, x, ours, args.spacing, args.dt, args.scheme)
    write_report("fe_opening", lines)


if __name__ == "__main__":
    main()
