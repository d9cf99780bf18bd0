"""What a run that breaks costs beside the unbroken run of the same case, and how its breaks
converge in N (docs/model.md, "The run that breaks").

The reference case with the contact-resolving rule to t_end, breaking at eps_Y = 8e-5: for each
N, the unbroken run and the breaking run, each with its error estimate's companion, solved
alternately over ROUNDS rounds in one process after a warm-up (medians of the whole call's wall
time, and of the integration's), the broken plates' tables rebuilt each time (their caches
cleared: a study's case builds its own); where the breaking run's time goes (the broken plates'
tables, the carries across the breaks, the integration, its steps and their cost beside the
unbroken run's); and the breaks' times, places and surfaces, the first break and the breakthrough.
Writes results/bench/breaking.md.

    python benchmarks/breaking.py [--modes 30 60] [--t-end 0.005] [--rounds 3] [--crack-spacing 0] [--crack-speed inf]
                                  [--edge-shapes 0]
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from solver import Parameters, Settings, solve
from solver.model import assemble, broken, parts

sys.path.insert(0, str(Path(__file__).resolve().parent))
from report import write_report  # noqa: E402

EPS_Y = 8e-5


#: the pieces of a breaking run timed apart: (module, function name, what it is)
PIECES = ((assemble, "parts_tables", "tables"), (broken, "carry_state", "carry"), (broken, "carry_parts", "carry"))


def _timed(run):
    """(wall time [s], the Result, {piece: seconds}) of one call, the broken plates' tables built
    afresh (their caches cleared)."""
    assemble._PARTS_TABLES.clear()                   # each broken plate's tables built again
    getattr(parts, "_PART_ROWS", {}).clear()          # (and each part's rows)
    spent = {"tables": 0.0, "carry": 0.0}
    originals = [(module, name, getattr(module, name)) for module, name, _ in PIECES]

    def clocked(function, piece):
        def call(*args, **kwargs):
            started = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                spent[piece] += time.perf_counter() - started
        return call
    for (module, name, function), (_, _, piece) in zip(originals, PIECES):
        setattr(module, name, clocked(function, piece))
    try:
        started = time.perf_counter()
        result = run()
        return time.perf_counter() - started, result, spent
    finally:
        for module, name, function in originals:
            setattr(module, name, function)


def measure(N, t_end, rounds, crack_spacing=0.0, crack_speed=math.inf, edge_shapes=0):
    """Medians (call, integration) of the unbroken and the breaking run, and the breaking run."""
    p, s = Parameters(Nmod=N), Settings(quadrature="gauss")
    broken = replace(p, fracture="break", yield_strain=EPS_Y, crack_spacing=crack_spacing, crack_speed=crack_speed,
                     edge_shapes=edge_shapes)
    times = np.linspace(0.0, t_end, 51)
    runs = {"unbroken": lambda: solve(p, s, fields=(), times=times, t_end=t_end),
            "breaking": lambda: solve(broken, s, fields=(), times=times, t_end=t_end)}
    for run in runs.values():
        run()                                         # (kernels loaded or compiled)
    samples = {name: [] for name in runs}
    for _ in range(rounds):
        for name, run in runs.items():
            wall, result, spent = _timed(run)
            stages = result.breaking.stages if result.breaking else [result]
            integration = sum(r.wall_time + r.extra.get("error_estimate_wall_time", 0.0) for r in stages)
            kernels = sum(r.wall_time for r in stages)
            samples[name].append((wall, integration, result, spent, kernels))
    medians = {name: (statistics.median(w for w, *_ in v), statistics.median(i for _, i, *_ in v))
               for name, v in samples.items()}
    pieces = {name: {piece: statistics.median(s[3][piece] for s in v) for piece in ("tables", "carry")}
              for name, v in samples.items()}
    per_step = {name: statistics.median(s[4] for s in v) / v[-1][2].steps for name, v in samples.items()}
    return medians, samples["breaking"][-1][2], pieces["breaking"], per_step, samples["unbroken"][-1][2]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, nargs="+", default=[30, 60])
    parser.add_argument("--t-end", type=float, default=0.005)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--crack-spacing", type=float, default=0.0, help="in ice thicknesses (0: none)")
    parser.add_argument("--crack-speed", type=float, default=math.inf, help="[m s-1] (inf: a crack opens at once)")
    parser.add_argument("--edge-shapes", type=int, default=0, help="at each free end (needs a crack spacing)")
    args = parser.parse_args()
    lines = ["# A run that breaks against the unbroken run", "",
             f"Reference case, contact-resolving rule, t_end {args.t_end:g} s, eps_Y {EPS_Y:g}, crack spacing "
             f"{args.crack_spacing:g} hi, crack speed {args.crack_speed:g} m/s, {args.edge_shapes} edge shapes, "
             f"medians of "
             f"{args.rounds} rounds.", "",
             "| N | unbroken call [s] | breaking call [s] | ratio | unbroken integration [s] | breaking integration [s] "
             "| ratio | breaks | first break [ms] | breakthrough [ms] | status |", "|" + "---|" * 11]
    where = ["", "Where the breaking run's time goes (medians): the broken plates' tables, the carries across "
             "the breaks, the integration (with the error estimate's companions), the rest (Results, records, "
             "checks); the steps of the integration alone and their cost beside the unbroken run's.", "",
             "| N | tables [s] | carries [s] | integration [s] | rest [s] | steps, unbroken -> breaking "
             "| per step, unbroken -> breaking [us] |", "|" + "---|" * 7]
    for N in args.modes:
        medians, result, pieces, per_step, unbroken = measure(N, args.t_end, args.rounds, args.crack_spacing,
                                                                args.crack_speed, args.edge_shapes)
        (un, un_int), (br, br_int) = medians["unbroken"], medians["breaking"]
        rest = br - br_int - pieces["tables"] - pieces["carry"]
        where.append(f"| {N} | {pieces['tables']:.3f} | {pieces['carry']:.3f} | {br_int:.3f} | {rest:.3f} "
                     f"| {unbroken.steps} -> {result.steps} | {1e6 * per_step['unbroken']:.0f} -> "
                     f"{1e6 * per_step['breaking']:.0f} |")
        summary = result.breaking
        lines.append(f"| {N} | {un:.3f} | {br:.3f} | {br / un:.1f} | {un_int:.3f} | {br_int:.3f} | {br_int / un_int:.1f} "
                     f"| {summary.break_count} | {1e3 * summary.first_break_time:.5f} "
                     f"| {1e3 * summary.breakthrough_time:.5f} | {result.status} |")
        lines.append("")
        for event in result.breaking.breaks:
            lines.append(f"    N = {N}: {1e3 * event.time:.5f} ms at x = {event.x:.4f} m, {event.surface}, "
                         f"{event.parts} parts, removed {event.removed_energy:.4g} J/m")
        lines.append(f"    N = {N}: energy residual {result.diagnostics['energy_residual']:.2e}, dissipated "
                     f"{result.diagnostics['dissipated_energy']:.4g} J/m")
        lines.append("")
    write_report("breaking", lines + where)


if __name__ == "__main__":
    main()
