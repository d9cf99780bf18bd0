"""What edge shapes (``edge_shapes``) do for a break (issue 76, items 1 and 2; docs/model.md, "Edge
shapes"): the state the reference case's first break carries (the centre, N modes, the state
where the unbroken run first reaches eps_Y = 8e-5), and the breakthrough of the runs that break.

    python benchmarks/edge_shapes.py carry [--modes 20 30 40 60 80 120]
    python benchmarks/edge_shapes.py breakthrough [--modes 40 60 80 120] [--shapes 0 2 3]
        [--crack-spacing 1] [--crack-speed inf] [--t-end 0.002]

``carry``: for 0 to 4 edge shapes, the plate's energy the carry leaves out (of what it held), the
largest error of the carried strain against the unbroken plate's (over eps_Y) and the largest wet
frequency over the cosines' omega_N. ``breakthrough``: each run's breaks (time, place, surface,
the plate's energy each removed), its breakthrough, status and energy residual.
"""
from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from solver import Parameters, Settings, solve
from solver.model import broken

EPS_Y = 8e-5


def carried(N: int) -> tuple[list, list, float]:
    """(the plate's energy left out, the largest strain error over eps_Y) for 0..4 edge shapes,
    and the largest wet omega over omega_N with 3, at the reference case's first break (N modes)."""
    p = Parameters(Nmod=N)
    first = solve(p, Settings(tolerance=1e-10), fields=(), t_end=2e-3, times=[0.0, 2e-3], break_strain=EPS_Y)
    a, adot = np.asarray(first.end.state.amplitudes), np.asarray(first.end.state.velocities)
    before = sum(broken.cosine_state_energy(p, p.L, 2.0, a, adot))
    x = np.linspace(0.0, p.L, 6001)
    lam = math.pi * np.arange(1, N + 1) / p.L
    unbroken = 0.5 * p.hi * (-(lam**2)[:, None] * np.cos(np.outer(lam, x))).T @ a      # the lower surface's
    omega_N = p.mode_constants(np.array([lam[-1]]))[1][0]
    left, error, fastest = [], [], math.nan
    for count in range(5):
        q = replace(p, fracture="break", edge_shapes=count, crack_spacing=1.0 if count else 0.0)
        wet = broken.wet_parts(q, p.L, 2.0, [0.0], lam[-1])
        b, bdot = broken.carry_state(q, wet, a, adot)
        left.append(1.0 - sum(broken.wet_energy(wet, b, bdot)) / before)
        error.append(np.max(np.abs(0.5 * p.hi * broken.wet_values(wet, x, 2).T @ b - unbroken)) / EPS_Y)
        fastest = np.max(wet.omega) / omega_N if count == 3 else fastest
    return left, error, fastest


def carry_table(modes) -> None:
    print("| N | plate's energy left out, 0 edge shapes | 1 | 2 | 3 | 4 | largest strain error / eps_Y, 0 | 1 | 2 | 3 | 4 "
          "| largest wet omega / omega_N, 3 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for N in modes:
        left, error, fastest = carried(N)
        print(f"| {N} | " + " | ".join(f"{v:.1e}" for v in left) + " | " + " | ".join(f"{v:.1e}" for v in error)
              + f" | {fastest:.1f} |", flush=True)


def breakthrough_table(modes, shapes, crack_spacing, crack_speed, t_end) -> None:
    print(f"crack spacing {crack_spacing:g} hi, crack speed {crack_speed:g} m/s, to {t_end * 1e3:g} ms\n")
    print("| N | edge shapes | breakthrough [ms] | at [m] | breaks | status | energy residual | the plate's energy "
          "each break removed [J/m] |")
    print("|---|---|---|---|---|---|---|---|")
    for N in modes:
        for count in shapes:
            p = Parameters(Nmod=N, fracture="break", yield_strain=EPS_Y, edge_shapes=count,
                           crack_spacing=crack_spacing, crack_speed=crack_speed)
            r = solve(p, Settings(), fields=(), times=np.linspace(0.0, t_end, 21), t_end=t_end)
            breaks = r.breaking.breaks
            through = [b for b in breaks if b.broken_through]
            place = f"{through[0].x:.4f}" if through else "-"
            print(f"| {N} | {count} | {r.breaking.breakthrough_time * 1e3:.5f} | {place} | {len(breaks)} | {r.status} | "
                  f"{r.diagnostics['energy_residual']:.1e} | "
                  + ", ".join(f"{b.removed_plate_energy:.1e}" for b in breaks) + " |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("carry", "breakthrough"))
    parser.add_argument("--modes", type=int, nargs="+")
    parser.add_argument("--shapes", type=int, nargs="+", default=[0, 2, 3])
    parser.add_argument("--crack-spacing", type=float, default=1.0)
    parser.add_argument("--crack-speed", type=float, default=math.inf)
    parser.add_argument("--t-end", type=float, default=2e-3)
    args = parser.parse_args()
    if args.what == "carry":
        carry_table(args.modes or [20, 30, 40, 60, 80, 120])
    else:
        breakthrough_table(args.modes or [40, 60, 80, 120], args.shapes, args.crack_spacing, args.crack_speed,
                           args.t_end)


if __name__ == "__main__":
    main()
