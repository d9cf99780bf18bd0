"""The solver against an independent discretisation through the reference case's first two
breaks (docs/model.md, "An independent check through a break"): Hermite cubic finite elements
of the same plate, water, layer and body (tests/fe_reference.py), broken at the solver's own
located times and places, and compared over WINDOW after each break: the upper-surface strain
at least AWAY from the breaks, and the force on the body; before the first break too.

    python benchmarks/fe_breaks.py [--modes 60 120] [--spacing 0.02 0.01]

For each N: the solver's first two breaks (its breaking run's, located on its own sub-steps),
then three comparisons, each from first touch: unbroken to the first break, broken at the first
break for WINDOW, broken at both for WINDOW after the second. The finite elements run at each
spacing (and steps of DT, exact for their linear part: tests/fe_reference._exponential_step);
their own uncertainty is the difference between the two finest, over 3 (their strain converges
as h^2). Writes results/bench/fe_breaks.md.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import fe_reference as fe  # noqa: E402
from report import write_report  # noqa: E402

from solver import Parameters, Settings, solve  # noqa: E402

EPS_Y = 8e-5
#: how long each comparison runs after its break [s]
WINDOW = 1e-3
#: the strain is compared at least this far from a break [m]
AWAY = 0.1
#: the finite elements' step [s]
DT = 4e-7


def solver_runs(N, times_count=21, x=None):
    """The solver's first two breaks and its three runs: {window name: (breaks [(t, x)], times, Result)}."""
    p, s = Parameters(Nmod=N), Settings(quadrature="gauss", tolerance=1e-10)
    first = solve(p, s, fields=(), t_end=2e-3, times=[0.0, 2e-3], break_strain=EPS_Y)
    b1 = first.end.broke
    second = solve(p, s, fields=(), start=first.end.state, breaks=[b1.x], t_end=b1.time + 2e-3,
                   times=[b1.time, b1.time + 2e-3], break_strain=EPS_Y)
    b2 = second.end.broke
    runs = {}
    before = np.linspace(0.0, b1.time, times_count)
    runs["before the first break"] = ([], before, solve(p, s, times=before, x=x, fields=("strain",), t_end=b1.time))
    after1 = np.linspace(b1.time, b1.time + WINDOW, times_count)
    runs["after the first break"] = ([(b1.time, b1.x)], after1,
                                     solve(p, s, start=first.end.state, breaks=[b1.x], times=after1, x=x,
                                           fields=("strain",), t_end=after1[-1]))
    after2 = np.linspace(b2.time, b2.time + WINDOW, times_count)
    runs["after the second break"] = ([(b1.time, b1.x), (b2.time, b2.x)], after2,
                                      solve(p, s, start=second.end.state, breaks=[b1.x, b2.x], times=after2, x=x,
                                            fields=("strain",), t_end=after2[-1]))
    return p, (b1, b2), runs


def _away(x, breaks):
    """Where x [m] is at least AWAY from every break [(time, place)]."""
    return np.all([np.abs(x - b) >= AWAY for _, b in breaks], axis=0) if breaks else np.ones(x.size, bool)


def agreement(strain, force, result, breaks, x):
    """(largest strain difference at least AWAY from the breaks over the largest strain there,
    largest force difference over the largest force)."""
    keep = _away(x, breaks)
    ours = result.fields["strain"][:, keep]
    scale = np.max(np.abs(ours))
    return (float(np.nanmax(np.abs(strain[:, keep] - ours)) / scale),
            float(np.max(np.abs(force - result.force)) / np.max(np.abs(result.force))))


def own_uncertainty(strains, result, breaks, x):
    """(the finest spacing [m], the elements' own uncertainty there): the two finest spacings'
    strains {spacing: (T, X)} apart at least AWAY from the breaks, over 3 (their strain converges
    as h^2), over the solver's largest strain there."""
    fine, coarse = sorted(strains)[:2]
    keep = _away(x, breaks)
    scale = np.max(np.abs(result.fields["strain"][:, keep]))
    return fine, float(np.nanmax(np.abs(strains[fine][:, keep] - strains[coarse][:, keep])) / 3 / scale)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, nargs="+", default=[60])
    parser.add_argument("--spacing", type=float, nargs="+", default=[0.02, 0.01])
    args = parser.parse_args()
    x = np.linspace(0.0, 3.0, 301)
    lines = ["# The solver against Hermite finite elements through two breaks", "",
             f"Reference case, the solver at tolerance 1e-10, eps_Y {EPS_Y:g}; the elements' steps {DT:g} s (exponential); the "
             f"strain compared at x = 0..3 m at least {AWAY:g} m from a break, over the largest strain there; the "
             f"force over the largest force; {WINDOW * 1e3:g} ms after each break.", "",
             "| N | window | breaks [ms, m] | spacing [m] | strain | force | elements' energy residual | "
             "elements' time [s] |", "|" + "---|" * 8]
    for N in args.modes:
        p, (b1, b2), runs = solver_runs(N, x=x)
        for name, (breaks, times, result) in runs.items():
            lines += spacing_rows(f"{N} | {name}", p, breaks, times, x, result, args.spacing)
    write_report("fe_breaks", lines)


def spacing_rows(first, p, breaks, times, x, result, spacings, opening_time=0.0) -> list:
    """The report's rows of the elements at each spacing through ``breaks`` (cracks opening over
    opening_time [s]) against the solver's Result: '| first | breaks | spacing | strain | force |
    residual | seconds |', then the elements' own uncertainty where there are two spacings or more
    (each row printed as it comes)."""
    rows, strains = [], {}
    where = ", ".join(f"{1e3 * t:.5f}, {b:.4f}" for t, b in breaks) or "none"
    for spacing in spacings:
        started = time.perf_counter()
        strain, force, residual = fe.run(p, breaks, times, x, spacing=spacing, dt=DT, opening_time=opening_time)
        strains[spacing] = strain
        s_diff, f_diff = agreement(strain, force, result, breaks, x)
        rows.append(f"| {first} | {where} | {spacing:g} | {s_diff:.2e} | {f_diff:.2e} | {residual:.1e} "
                    f"| {time.perf_counter() - started:.1f} |")
        print(rows[-1], flush=True)
    if len(strains) > 1:
        fine, own = own_uncertainty(strains, result, breaks, x)
        rows.append(f"| {first} | | own uncertainty at {fine:g} m | {own:.2e} | | | |")
        print(rows[-1], flush=True)
    return rows


if __name__ == "__main__":
    main()
