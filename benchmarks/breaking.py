"""What a run that breaks costs beside the unbroken run of the same case, and how its breaks
converge in N (docs/model.md, "The run that breaks").

The reference case with the contact-resolving rule to t_end, breaking at eps_Y = 8e-5: for each
N, the unbroken run and the breaking run, each with its error estimate's companion, solved
alternately over ROUNDS rounds in one process after a warm-up (medians of the whole call's wall
time, and of the integration's), the broken plates' tables rebuilt each time (their cache
cleared); and the breaks' times, places and surfaces, the first break and the breakthrough.
Writes results/bench/breaking.md.

    python benchmarks/breaking.py [--modes 30 60] [--t-end 0.005] [--rounds 3]
"""
from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from solver import Parameters, Settings, solve
from solver.model import assemble

ROOT = Path(__file__).resolve().parents[1]
EPS_Y = 8e-5


def _timed(run):
    assemble._PARTS_TABLES.clear()                   # each broken plate's tables built again
    started = time.perf_counter()
    result = run()
    return time.perf_counter() - started, result


def measure(N, t_end, rounds):
    """Medians (call, integration) of the unbroken and the breaking run, and the breaking run."""
    p, s = Parameters(Nmod=N), Settings(quadrature="gauss")
    broken = replace(p, fracture="break", yield_strain=EPS_Y)
    times = np.linspace(0.0, t_end, 51)
    runs = {"unbroken": lambda: solve(p, s, fields=(), times=times, t_end=t_end),
            "breaking": lambda: solve(broken, s, fields=(), times=times, t_end=t_end)}
    for run in runs.values():
        run()                                         # (kernels loaded or compiled)
    samples = {name: [] for name in runs}
    for _ in range(rounds):
        for name, run in runs.items():
            wall, result = _timed(run)
            integration = result.wall_time + sum(r.extra.get("error_estimate_wall_time", 0.0)
                                                 for r in (result.breaking.stages if result.breaking else [result]))
            samples[name].append((wall, integration, result))
    medians = {name: (statistics.median(w for w, _, _ in v), statistics.median(i for _, i, _ in v))
               for name, v in samples.items()}
    return medians, samples["breaking"][-1][2]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, nargs="+", default=[30, 60])
    parser.add_argument("--t-end", type=float, default=0.005)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    lines = ["# A run that breaks against the unbroken run", "",
             f"Reference case, contact-resolving rule, t_end {args.t_end:g} s, eps_Y {EPS_Y:g}, medians of "
             f"{args.rounds} rounds.", "",
             "| N | unbroken call [s] | breaking call [s] | ratio | unbroken integration [s] | breaking integration [s] "
             "| ratio | breaks | first break [ms] | breakthrough [ms] | status |", "|" + "---|" * 11]
    for N in args.modes:
        medians, result = measure(N, args.t_end, args.rounds)
        (un, un_int), (br, br_int) = medians["unbroken"], medians["breaking"]
        summary = result.breaking
        lines.append(f"| {N} | {un:.3f} | {br:.3f} | {br / un:.1f} | {un_int:.3f} | {br_int:.3f} | {br_int / un_int:.1f} "
                     f"| {summary.break_count} | {1e3 * summary.first_break_time:.5f} "
                     f"| {1e3 * summary.breakthrough_time:.5f} | {result.status} |")
        lines.append("")
        for event in result.breaking.breaks:
            lines.append(f"    N = {N}: {1e3 * event.time:.5f} ms at x = {event.x:.4f} m, {event.surface}, "
                         f"{event.parts} parts, removed {event.removed_energy:.4g} J/m")
        lines.append("")
    text = "\n".join(lines) + "\n"
    out = ROOT / "results" / "bench" / "breaking.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
