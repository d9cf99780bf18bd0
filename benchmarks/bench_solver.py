"""Solver benchmark: speed and accuracy of the integrators on the paper's case (make bench).

All runs are timed side by side in one process, interleaved round-robin over several repeats
(the machine is shared and noisy), and the medians are reported. Errors are relative L2 of the
strain over the paper's snapshots (t~ = 0, 0.2, ..., 4.6) against a tight etd34 run of the same
discretisation (same Nmod, same subintervals). Writes results/bench/solver.md.

    python benchmarks/bench_solver.py [--repeats 5] [--out results/bench/solver.md]
"""
from __future__ import annotations

import argparse
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from solver import Parameters, Settings, compile_kernels, solve
from solver.model.basis import strain_nodes
from solver.model.contact import count_contacts
from solver.model.layer import layer_energy, layer_forcing
from solver.model.assemble import Tables


#: the integrators are compared on the paper's rule at 1000 subintervals, pinned by value (the
#: default before issue 24), so that the table stays comparable with its history
PAPER = dict(quadrature="paper", subintervals=1000, error_control="embedded")
#: today's default, compared with the paper's default against the continuous-x model
DEFAULT = Settings()


def snapshots(p):
    return np.round(np.arange(0.0, 4.6 + 1e-9, 0.2), 10) * p.time_scale


def rel(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def dop853_run(p, times, x, rtol):
    """scipy DOP853 on the same right-hand side (numba forcing, Python callback)."""
    from scipy.integrate import solve_ivp
    tab = Tables(p, 1000)
    N = p.Nmod
    J = tab.xq.size
    delta, fvals, P = np.empty(J), np.empty(J), np.empty(N)
    om2 = tab.omega**2

    def rhs(t, y):
        layer_forcing(tab.model, t, np.ascontiguousarray(y[:N]), delta, fvals, P)
        return np.concatenate([y[N:], -om2 * y[:N] + P])

    start = time.perf_counter()
    sol = solve_ivp(rhs, (0, p.stage_duration), np.zeros(2 * N), method="DOP853",
                    rtol=rtol, atol=rtol * 1e-4, t_eval=times)
    wall = time.perf_counter() - start
    strain = (sol.y[:N].T * tab.strain_coef) @ np.cos(np.outer(x, tab.lam)).T
    return wall, strain, sol.nfev


def interleaved(p, runs: dict, repeats: int, times, fields):
    """Each named Settings solved once a round, round-robin over repeats (the machine's drift
    falls on all alike): ({name: wall times}, {name: the last Result})."""
    walls, results = {k: [] for k in runs}, {}
    for rep in range(repeats):
        for name, s in runs.items():
            r = solve(p, s, times=times, fields=fields)
            walls[name].append(r.wall_time)
            results[name] = r
        print(f"  repeat {rep + 1}/{repeats} done", flush=True)
    return walls, results


def profile_step(p, repeats=2000):
    """Microseconds per call of the pieces of one etd34 step, on a late state (t~ = 3.8)."""
    tab = Tables(p, 1000)
    r = solve(p, Settings(tolerance=1e-10, **PAPER), times=[3.8 * p.time_scale], fields=())
    a, t = r.amplitudes[0], r.times[0]
    J = tab.xq.size
    delta, fvals, P, eps = np.empty(J), np.empty(J), np.empty(p.Nmod), np.empty(J)
    args = (tab.model, t, a, delta, fvals, P)
    _, _, jmax = layer_forcing(*args)
    out = {}
    s = p.V * t
    gauss = Tables(p, DEFAULT.subintervals, quadrature=DEFAULT.quadrature, quadrature_density=DEFAULT.quadrature_density)
    g_delta, g_fvals = np.empty(gauss.xq.size), np.empty(gauss.xq.size)
    g_args = (gauss.model, t, a, g_delta, g_fvals, np.empty(p.Nmod))
    for name, fn in [("forcing (one stage)", lambda: layer_forcing(*args)),
                     ("forcing (one stage), the default Gauss rule", lambda: layer_forcing(*g_args)),
                     ("strain at the nodes (in the loop: the last stage's second pass over the table)", lambda: strain_nodes(a, tab.strain_coef, tab.cosq, eps)),
                     ("layer energy (diagnostics)", lambda: layer_energy(tab.model, a, s, delta, jmax)),
                     ("contact intervals", lambda: count_contacts(delta, jmax, 2.0))]:
        fn()
        t0 = time.perf_counter()
        for _ in range(repeats):
            fn()
        out[name] = (time.perf_counter() - t0) / repeats * 1e6
    return out, int(jmax), int(np.sum(delta[:jmax] > 0))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default="results/bench/solver.md")
    args = ap.parse_args(argv)
    compile_kernels()
    p60 = Parameters(Nmod=60)
    times = snapshots(p60)
    fields = ("strain",)

    print("tight reference (etd34, tolerance 1e-13) ...", flush=True)
    ref = solve(p60, Settings(tolerance=1e-13, error_estimate=False, **PAPER), times=times, fields=fields)
    ref_strain = ref.fields["strain"]

    # the integrators alone: the error estimate's companion run is switched off
    candidates = {
        "rk4, paper's rule (step = period of mode N / 20)": Settings(integrator="rk4", error_estimate=False, **PAPER),
        "etd34, tolerance 1e-8 (the default before issue 24)": Settings(tolerance=1e-8, error_estimate=False, **PAPER),
        "etd34, tolerance 1e-10": Settings(tolerance=1e-10, error_estimate=False, **PAPER),
        "etd34, tolerance 3e-11": Settings(tolerance=3e-11, error_estimate=False, **PAPER),
        "etd34, tolerance 1e-11": Settings(tolerance=1e-11, error_estimate=False, **PAPER),
    }
    walls, results = interleaved(p60, candidates, args.repeats, times, fields)
    dop_walls = []
    for rep in range(max(1, args.repeats // 2)):
        w, dop_strain, nfev = dop853_run(p60, times, ref.x, rtol=1e-9)
        dop_walls.append(w)

    rows = []
    paper = "rk4, paper's rule (step = period of mode N / 20)"
    t_paper = statistics.median(walls[paper])
    e_paper = rel(results[paper].fields["strain"], ref_strain)
    for name in candidates:
        r = results[name]
        med = statistics.median(walls[name])
        rows.append((name, med, rel(r.fields["strain"], ref_strain), r.steps, r.rejected_steps,
                     r.forcing_evaluations, t_paper / med))
    t_dop = statistics.median(dop_walls)
    rows.append(("scipy DOP853, rtol 1e-9 (same right-hand side, Python callback)", t_dop,
                 rel(dop_strain, ref_strain), None, None, nfev, t_paper / t_dop))

    # cost against Nmod at the default tolerance and at 1e-10
    scaling = []
    for tol in (1e-8, 1e-10):
        per_n = {N: [] for N in (20, 60, 120, 240)}
        steps = {}
        for rep in range(args.repeats):
            for N in per_n:
                p = Parameters(Nmod=N)
                r = solve(p, Settings(tolerance=tol, error_estimate=False, **PAPER), times=snapshots(p), fields=fields)
                per_n[N].append(r.wall_time)
                steps[N] = r.steps
        scaling.append((tol, {N: statistics.median(v) for N, v in per_n.items()}, steps))

    prof, jmax, ncontact = profile_step(p60)

    # today's default beside the paper's, against the continuous-x model (a Gauss run at density 24,
    # tolerance 1e-12: docs/numerics.md, "The quadrature")
    continuous = solve(p60, Settings(quadrature="gauss", quadrature_density=24, tolerance=1e-12, error_estimate=False,
                                         error_control="embedded"),
                       times=times, fields=fields).fields["strain"]
    defaults = {"the paper's rule, 1000 subintervals, tolerance 1e-8 (the default before issue 24)":
                Settings(tolerance=1e-8, error_estimate=False, **PAPER),
                f"the Gauss rule, {DEFAULT.subintervals} subintervals, density {DEFAULT.quadrature_density:g}, "
                f"tolerance {DEFAULT.tolerance:g} (the default)": Settings(error_estimate=False)}
    default_walls, default_results = interleaved(p60, defaults, args.repeats, times, fields)

    # the smallest etd34 tolerance cost at an error no larger than rk4's
    better = [row for row in rows if row[0].startswith("etd34") and row[2] <= e_paper]
    best = min(better, key=lambda row: row[1]) if better else None
    under_1e6 = [row for row in rows if row[0].startswith("etd34") and row[2] <= 1e-6]
    best6 = min(under_1e6, key=lambda row: row[1]) if under_1e6 else None

    lines = [
        "# Solver benchmark",
        "",
        f"Generated by `make bench` ({Path(__file__).name}) on {time.strftime('%Y-%m-%d')}, "
        f"{platform.machine()}, Python {platform.python_version()}; {args.repeats} interleaved repeats, "
        "medians. Reference case (K = 8 MPa, he = 2 cm, R = 10 m, V = 5 m/s, hi = 0.5 m), "
        "Nmod = 60, the paper's rule at 1000 subintervals, 0 < t < L^2/(6RV).",
        "Error: relative L2 of the strain at the 24 snapshots t~ = 0, 0.2, ..., 4.6 (241 points on -L..L) "
        "against etd34 at tolerance 1e-13 with the same Nmod and subintervals.",
        "",
        "| run | wall time [s] | strain error | accepted steps | rejected | forcing evaluations | speed-up vs the paper's rk4 |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, med, err, st, rj, nf, sp in rows:
        lines.append(f"| {name} | {med:.3f} | {err:.1e} | {st if st is not None else '-'} | "
                     f"{rj if rj is not None else '-'} | {nf} | {sp:.1f}x |")
    lines += ["", "## The default against the continuous-x model (etd34, N = 60, same snapshots)", "",
              "Error against a Gauss run at density 24 and tolerance 1e-12, which resolves the continuous-x "
              "N-mode model (docs/numerics.md, \"The quadrature\").", "",
              "| settings | wall time [s] | strain error | accepted steps | energy residual |", "|---|---|---|---|---|"]
    for name, r in default_results.items():
        lines.append(f"| {name} | {statistics.median(default_walls[name]):.3f} | "
                     f"{rel(r.fields['strain'], continuous):.1e} | {r.steps} | "
                     f"{r.diagnostics['energy_residual']:.1e} |")
    lines += ["", "## Cost against Nmod (etd34, same snapshots)", "",
              "| tolerance | " + " | ".join(f"N = {N} [s]" for N in (20, 60, 120, 240)) + " | N=240 / N=60 | accepted steps N=60, N=240 |",
              "|---|---|---|---|---|---|---|"]
    for tol, med, steps in scaling:
        lines.append(f"| {tol:.0e} | " + " | ".join(f"{med[N]:.3f}" for N in (20, 60, 120, 240))
                     + f" | {med[240] / med[60]:.2f} | {steps[60]}, {steps[240]} |")
    lines += ["", "## Where an etd34 step goes (Nmod = 60, state at t~ = 3.8)", "",
              f"{jmax} of 1001 nodes can touch the body (contact_bound: four modes exact, the rest by sum |a_n|), {ncontact} are in contact.",
              "", "| piece | microseconds per call | calls per accepted step |", "|---|---|---|"]
    calls = {"forcing (one stage)": "4", "forcing (one stage), the default Gauss rule": "4",
             "strain at the nodes (in the loop: the last stage's second pass over the table)": "1",
             "layer energy (diagnostics)": "1", "contact intervals": "5"}
    for name, us in prof.items():
        lines.append(f"| {name} | {us:.1f} | {calls[name]} |")
    lines.append("")
    if best is not None:
        lines.append(f"At an error no larger than the paper's rk4 ({e_paper:.1e}) the cheapest etd34 run here is "
                     f"'{best[0]}': {best[6]:.1f}x faster.")
    if best6 is not None:
        lines.append(f"The cheapest etd34 run with error <= 1e-6 is '{best6[0]}': {best6[1]:.3f} s, "
                     f"{best6[6]:.1f}x faster than the paper's rk4.")
    text = "\n".join(lines) + "\n"
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
