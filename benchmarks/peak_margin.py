"""How far the tension's peak over the continuous plate stands above the nodes, and whether the
global peak's search (solver.model.basis.global_peak: every local maximum of the nodes within
solver.model.peak_margin.competing of the largest node refined on the modes) can miss it.

The reference case that breaks (N modes, eps_Y 8e-5, to t_end) is run once and each of its stages
(the unbroken plate, then the plate broken at the breaks so far) is run again, from the state it
began with, to the time it broke, with its modes at --samples output times. At each time and
for each surface: the largest tension at the nodes, at a grid --fine times finer (the peak over
the continuous plate to within (dx / fine)^2), and at the candidates the search refines (the
kernels' own search, solver.model.basis.global_peak, at the nodes' strains; --margin-only: the best
of the nodes' local maxima within PEAK_MARGIN of the largest, the search before 2026-12-07, each
peak taken on the fine grid within a node of it). It prints, stage by stage, the largest excess of the fine grid's peak
over the largest node (relative), and the samples at which the candidates' best stands below the
fine grid's peak by more than 1e-6 of it (the search would miss the global peak there).

A peak between nodes stands above its nearest node by at most (k dx)^2 / 8 of the largest
|tension|, k the largest wavenumber (Bernstein's inequality for a sum of cosines): at the
default 250 subintervals of the reference L = 6 m, 7.1 % at N = 60, 28 % at N = 120; and by at
most dx^2 / 8 times a bound on |eps''| from the state's own modes (solver.model.peak_margin.curvature_bound).

    python benchmarks/peak_margin.py [--modes 60] [--t-end 0.005] [--samples 400] [--fine 64] [--margin-only]

Writes results/bench/peak_margin.md.
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from solver import Parameters, Settings, solve
from solver import breaking as solver_breaking
from solver import run as solver_run
from solver.model.assemble import Tables
from solver.model.basis import global_peak
from solver.model.peak_margin import PEAK_MARGIN
from solver.model.plate import STRAIN

sys.path.insert(0, str(Path(__file__).resolve().parent))
from report import write_report  # noqa: E402


def stages_of(p, s, t_end):
    """The (parameters, settings, RunSpec) of each stage of the breaking run, in order."""
    captured, run_case = [], solver_breaking.run_case

    def capture(pp, ss, spec):
        captured.append((pp, ss, spec))
        return run_case(pp, ss, spec)
    solver_breaking.run_case = capture
    try:
        solve(p, s, fields=(), times=np.linspace(0.0, t_end, 51), t_end=t_end)
    finally:
        solver_breaking.run_case = run_case
    return captured


def stage_modes(p, s, spec, t_until, samples):
    """The stage's Tables and its kernel amplitudes at `samples` times from its start to t_until."""
    tab = Tables(p, s.subintervals, spec.full_plate, s.quadrature, s.quadrature_density, breaks=spec.breaks)
    a0, v0, _ = solver_run._begun(p, s, tab, spec)
    times = np.linspace(spec.window.t_start, t_until, samples)
    run = replace(spec, window=replace(spec.window, times=times, t_end=t_until), break_level=math.inf)
    integrator = solver_run.INTEGRATORS[s.integrator]
    observers, answer, _ = solver_run._plan(p, run)
    control = solver_run._control(p, s, run, tab, integrator, observers, answer)
    ran = solver_run._kernels(integrator, tab, control, run, a0, v0)
    return tab, ran.outputs.a[:ran.n_out]


def margins(tab, amplitudes, fine, hi, margin_only=False):
    """(largest excess of the fine grid's peak over the nodes', samples missed, largest miss), each
    relative to the fine grid's peak, over the amplitudes' times and both surfaces (ice hi thick): the kernels'
    global_peak's value against the fine grid's peak (--margin-only: the best of the nodes' local
    maxima within PEAK_MARGIN, each peak taken on the fine grid within a node of it)."""
    nodes = tab.xq
    J = nodes.size
    grid = np.linspace(nodes[0], nodes[-1], (J - 1) * fine + 1)
    basis, weights = tab.model.basis, tab.model.plate.modes[STRAIN]
    worst, missed, worst_miss = 0.0, 0, 0.0
    for a in amplitudes:
        a = np.ascontiguousarray(a)
        eps = np.ascontiguousarray(-0.5 * hi * tab.derivative(a, nodes, 2))   # the upper surface's strain
        eps_grid = -0.5 * hi * tab.derivative(a, grid, 2)
        for sign in (1.0, -1.0):
            vn, vf = sign * eps, sign * eps_grid
            top_node, top = vn.max(), vf.max()
            if not top > 0.0:
                continue
            worst = max(worst, (top - top_node) / top)
            if margin_only:
                floor = top_node - PEAK_MARGIN * abs(top_node)
                best = max(vf[max(0, (j - 1) * fine):(j + 1) * fine + 1].max() for j in range(J)
                           if vn[j] >= floor and (j == 0 or vn[j - 1] <= vn[j]) and (j == J - 1 or vn[j + 1] <= vn[j]))
            else:
                best = global_peak(eps, sign, basis, weights, a, True)[0]
            if top > best * (1.0 + 1e-6):
                missed += 1
                worst_miss = max(worst_miss, (top - best) / top)
    return worst, missed, worst_miss


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, default=60)
    parser.add_argument("--t-end", type=float, default=0.005)
    parser.add_argument("--samples", type=int, default=400)
    parser.add_argument("--fine", type=int, default=64)
    parser.add_argument("--margin-only", action="store_true", help="the candidates within PEAK_MARGIN only")
    args = parser.parse_args(argv)
    p = replace(Parameters(Nmod=args.modes), fracture="break", yield_strain=8e-5)
    s = Settings(quadrature="gauss")
    stages = stages_of(p, s, args.t_end)
    lines = [f"# How far the peak stands above the nodes (N = {args.modes}, {s.subintervals} subintervals, "
             f"candidates within {'PEAK_MARGIN' if args.margin_only else 'competing'})", "",
             "| stage | breaks | from [ms] | to [ms] | largest excess over the nodes | samples missed | largest miss |",
             "|---|---|---|---|---|---|---|"]
    for i, (pp, ss, spec) in enumerate(stages):
        t_until = stages[i + 1][2].window.t_start if i + 1 < len(stages) else spec.window.t_end
        tab, amplitudes = stage_modes(pp, ss, spec, t_until, args.samples)
        worst, missed, worst_miss = margins(tab, amplitudes, args.fine, p.hi, args.margin_only)
        breaks = 0 if spec.breaks is None else len(spec.breaks)
        lines.append(f"| {i} | {breaks} | {spec.window.t_start * 1e3:.4f} | {t_until * 1e3:.4f} | {worst:.2%} | "
                     f"{missed} of {2 * len(amplitudes)} | {worst_miss:.2%} |")
    write_report("peak_margin", lines)


if __name__ == "__main__":
    main()
