"""The time integrators' work against precision on the continuous-x model (issue 56's measure):
python benchmarks/time_integrator.py [--quick] [--cases NAME ...]

Six cases at N = 60 that differ in hi, V, K, he and body (the paper's body, a free body, a
wedge, viscoelastic ice), and a 6 m floe at N = 20 over 10 ms. Each run's strain (24 snapshots
over the stage, or up to where the layer bottoms out, 401 points) is compared with two
references:

* the continuous model: the Gauss rule at density 16 on 1000 subintervals, etd34 at tolerance
  1e-12 (what the issue's targets are measured against; its own uncertainty, against density 12,
  is printed);
* the time integration alone: the run's own quadrature (today's default: density 4, 250
  subintervals) at etd34 tolerance 1e-12, so that the error of the steps is seen below the
  quadrature's floor.

The runs: etd34 at tolerances 1e-3 .. 1e-11 and each control's default under both error controls
(``error_control``: "smoothness", the default at 3e-7, and "embedded", the default before it at 1e-9) and rk4 (the paper's integrator)
at step fractions 0.2, 0.1, 0.05 of the last mode's period (the paper's), on today's default
quadrature, error estimate off (each run's wall time the smaller of two; the machine is noisy:
compare ratios within one run); and today's default and the one before (each control's run at its
default tolerance) with
the estimate of a run with its error estimate on, set beside the measured error (the issue asks
for it within 3x): its time part beside the error of the steps alone, its time and quadrature
parts beside the error from the continuous model (its modes' part estimates the truncation at N,
which no run here measures).

Under the smoothness control, the runs at 1e-6 and 1e-7 with their error estimate too. Each run's
crack onsets (upper surface, plate-wide, eps_Y 2e-5, 8e-5, 3e-4, 1e-3 where reached in the window)
against the continuous reference's: the issue's events target.

Writes results/bench/time_integrator.md (per case: today's default beside the one before; the cheapest run of each
integrator that meets each error target 1e-4 .. 1e-7; each error control's time at each target,
interpolated on its work-precision line, and their ratio) and results/bench/time_integrator.csv
(every run).
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from solver import Parameters, Settings, solve  # noqa: E402
from solver.keys import ParameterError  # noqa: E402

#: name -> (parameters, the part of the run compared [s], or None: the stage, or up to 0.95 of the
#: time the continuous reference reached where its layer bottoms out first)
CASES = {
    "reference": ({"Nmod": 60}, None),
    "thin, fast, stiff layer (hi 0.3, V 10, K 8e7)": ({"Nmod": 60, "hi": 0.3, "V": 10.0, "K": 8e7}, None),
    "thick, slow, thick layer (hi 1, V 2, he 0.05)": ({"Nmod": 60, "hi": 1.0, "V": 2.0, "he": 0.05}, None),
    "free body (500 kg/m)": ({"Nmod": 60, "body_mass": 500.0}, None),
    "wedge (deadrise 10 deg)": ({"Nmod": 60, "deadrise": 10.0}, None),
    "viscoelastic ice (tau 1e-4 s)": ({"Nmod": 60, "tau": 1e-4}, None),
    "6 m floe": ({"Nmod": 20, "edges": "free", "L": 3.0, "duration": 0.01}, 0.01),
}
TOLERANCES = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]
#: the yield strains whose crack onset each run is compared on (the paper's is 8e-5), and the
#: tolerances the report shows them at
ONSET_EPS_Y = np.array([2e-5, 8e-5, 3e-4, 1e-3])
ONSET_TOLERANCES = [1e-6, 3e-7, 1e-7, 1e-8, 1e-9]
#: the smoothness control's runs whose error estimate (the companion run's) is set beside their error
ESTIMATED_SMOOTHNESS = [1e-6, 1e-7]
#: the error controls compared: integrator name in the rows -> Settings.error_control
CONTROLS = {"etd34": "embedded", "etd34 smoothness": "smoothness"}
#: today's default and the default before it (to 2026-11-28: the embedded control at 1e-9)
DEFAULTS = {"default": Settings(), "previous default": Settings(error_control="embedded")}
FRACTIONS = [0.2, 0.1, 0.05]
TARGETS = [1e-4, 1e-5, 1e-6, 1e-7]
#: the references run under the embedded control, as before it was the default
CONTINUOUS = dict(quadrature="gauss", quadrature_density=16, subintervals=1000, tolerance=1e-12, error_control="embedded")
OUT = Path("results/bench")


def _window(p, end, x):
    """The output times compared: 24 over [0, end] s, or over the stage (up to 0.95 of where the
    continuous reference ended, if it bottomed out first)."""
    if end is None:
        r = solve(p, Settings(error_estimate=False, **CONTINUOUS), times=[0.0], x=x, fields=())
        end = min(p.stage_duration, 0.95 * r.time_reached)
    return np.linspace(end / 24, end, 24)


def _strain(p, settings, times, x, repeats=2):
    best, r = np.inf, None
    for _ in range(repeats):
        started = time.perf_counter()
        r = solve(p, settings, times=times, x=x, fields=("strain",), t_end=times[-1])
        best = min(best, time.perf_counter() - started)
    return r, best


def _onsets(r):
    """Crack onset [s] on the upper surface, plate-wide, at each ONSET_EPS_Y (NaN: not within the run)."""
    return r.crack_onset(ONSET_EPS_Y)[0]


def _onset_error(r, ref):
    """The largest relative error of a run's crack onsets against the reference's, over the
    ONSET_EPS_Y both reach (NaN where they reach none)."""
    both = np.isfinite(ref) & np.isfinite(_onsets(r))
    return float(np.max(np.abs(_onsets(r)[both] - ref[both]) / ref[both])) if both.any() else np.nan


def _error(r, ref, norm):
    return float(np.linalg.norm(r.fields["strain"] - ref) / norm) if r.valid.all() else np.inf


def _runs(quick):
    """(integrator, knob, settings) of each run; etd34's include each control's default tolerance."""
    for name, control in CONTROLS.items():
        default = Settings(error_control=control).tolerance
        for tol in sorted({*(TOLERANCES[::2] if quick else TOLERANCES), default}, reverse=True):
            yield name, tol, dict(tolerance=tol, error_control=control)
    for fraction in (FRACTIONS[::2] if quick else FRACTIONS):
        yield "rk4", fraction, dict(integrator="rk4", rk4_step_fraction=fraction)


def case_rows(name, kw, end, quick):
    p = Parameters(**kw)
    x = np.linspace(-p.L, p.L, 401)
    times = _window(p, end, x)
    cont, _ = _strain(p, Settings(error_estimate=False, **CONTINUOUS), times, x, repeats=1)
    check, _ = _strain(p, Settings(error_estimate=False, **dict(CONTINUOUS, quadrature_density=12)), times, x,
                       repeats=1)
    own, _ = _strain(p, Settings(error_estimate=False, tolerance=1e-12, error_control="embedded"), times, x,
                     repeats=1)
    norm = np.linalg.norm(cont.fields["strain"])
    onsets = _onsets(cont)
    note = (f"- {name}: compared over [0, {times[-1] * 1e3:.2f} ms]; the continuous reference's uncertainty "
            f"(density 12 against 16) {_error(check, cont.fields['strain'], norm):.1e}, of its crack onsets "
            f"{_onset_error(check, onsets):.1e}; today's quadrature at tolerance 1e-12 is "
            f"{_error(own, cont.fields['strain'], norm):.1e} from it (the quadrature's floor), its crack onsets "
            f"{_onset_error(own, onsets):.1e}")
    print(note, flush=True)
    rows = []
    for integrator, knob, settings in _runs(quick):
        try:
            r, wall = _strain(p, Settings(error_estimate=False, **settings), times, x)
        except ParameterError as err:                # rk4 integrates the elastic plate only
            print(f"  {integrator} {knob:g}: not run ({err})", flush=True)
            continue
        row = dict(case=name, integrator=integrator, knob=knob, time=wall, steps=r.steps,
                   rejected=r.rejected_steps, error=_error(r, cont.fields["strain"], norm),
                   time_error=_error(r, own.fields["strain"], norm), status=r.status, estimate_time="",
                   estimate_quadrature="", onset_error=_onset_error(r, onsets))
        rows.append(row)
        print(f"  {integrator} {knob:g}: {row['error']:.2e} (steps alone {row['time_error']:.2e}) in {wall:.4f} s, "
              f"{r.steps} steps, {r.rejected_steps} rejected", flush=True)
    # today's default and the one before (the embedded control at its default tolerance): the run at
    # its tolerance, and its estimate of the error of the steps and of the quadrature
    for label, default in DEFAULTS.items():
        name = next(n for n, control in CONTROLS.items() if control == default.error_control)
        row = next(r for r in rows if r["integrator"] == name and r["knob"] == default.tolerance)
        estimated, _ = _strain(p, default, times, x, repeats=1)
        rows.append(dict(row, integrator=label, estimate_time=estimated.diagnostics["error_estimate_time"],
                         estimate_quadrature=estimated.diagnostics["error_estimate_quadrature"]))
    # the same estimate of runs under the smoothness control
    for tol in ESTIMATED_SMOOTHNESS:
        row = next((r for r in rows if r["integrator"] == "etd34 smoothness" and r["knob"] == tol), None)
        if row is not None:
            estimated, _ = _strain(p, Settings(tolerance=tol, error_control="smoothness"), times, x, repeats=1)
            rows.append(dict(row, integrator="estimated smoothness",
                             estimate_time=estimated.diagnostics["error_estimate_time"],
                             estimate_quadrature=estimated.diagnostics["error_estimate_quadrature"]))
    return note, rows


def _cheapest(rows, integrator, target, key):
    meets = [r for r in rows if r["integrator"] == integrator and r[key] <= target]
    return min(meets, key=lambda r: r["time"]) if meets else None


def time_at(rows, integrator, target):
    """The integrator's wall time at strain error ``target`` on its work-precision line: the
    cheapest runs at each error (the lower envelope), log-linear between the two around the
    target; None where no run reaches it (or none is above it: the cheapest that meets it)."""
    runs = sorted(((r["error"], r["time"]) for r in rows if r["integrator"] == integrator and np.isfinite(r["error"])),
                  key=lambda run: run[0])
    envelope = []                       # errors ascending, times descending: no run both better and cheaper
    for error, time_ in runs:
        if not envelope or time_ < envelope[-1][1]:
            envelope.append((error, time_))
    below = [run for run in envelope if run[0] <= target]
    above = [run for run in envelope if run[0] > target]
    if not below:
        return None
    if not above:
        return below[-1][1]
    (e0, t0), (e1, t1) = below[-1], above[0]
    w = np.log(target / e0) / np.log(e1 / e0)
    return float(np.exp((1 - w) * np.log(t0) + w * np.log(t1)))


def _run(rows, case, integrator, knob):
    """The row of one run (None: not run)."""
    return next((r for r in rows if r["case"] == case and r["integrator"] == integrator and r["knob"] == knob), None)


def _default_table(rows, cases):
    md = [f"Today's default ({DEFAULTS['default'].error_control}, tolerance {DEFAULTS['default'].tolerance:g}) "
          f"and the default before it ({DEFAULTS['previous default'].error_control}, tolerance "
          f"{DEFAULTS['previous default'].tolerance:g}):", "",
          "| case | default | error | steps alone | time [s] | steps (rejected) | its estimate: time / "
          "steps alone | time + quadrature / error | time / previous default's |", "|---|---|---|---|---|---|---|---|---|"]
    for case in cases:
        before = next(r for r in rows if r["case"] == case and r["integrator"] == "previous default")
        for label in DEFAULTS:
            d = next(r for r in rows if r["case"] == case and r["integrator"] == label)
            steps = d["estimate_time"] / d["time_error"]
            whole = (d["estimate_time"] + d["estimate_quadrature"]) / d["error"]
            md.append(f"| {case} | {label} | {d['error']:.2e} | {d['time_error']:.2e} | {d['time']:.4f} | {d['steps']} "
                      f"({d['rejected']}) | {steps:.2f} | {whole:.2f} | {d['time'] / before['time']:.2f} |")
    return md


def _estimate_table(rows, cases):
    md = ["The per-case estimate of the time integration's error (the companion run at 10x the tolerance) "
          "over the error of the steps alone, under the smoothness control:", "",
          "| case | " + " | ".join(f"smoothness {tol:g}: error | estimate / error" for tol in ESTIMATED_SMOOTHNESS)
          + " |", "|---|" + "---|---|" * len(ESTIMATED_SMOOTHNESS)]
    for case in cases:
        cells = []
        for tol in ESTIMATED_SMOOTHNESS:
            r = _run(rows, case, "estimated smoothness", tol)
            cells += [f"{r['time_error']:.2e}", f"{r['estimate_time'] / r['time_error']:.2f}"] if r else ["-", "-"]
        md.append(f"| {case} | " + " | ".join(cells) + " |")
    return md


def _onset_table(rows, cases):
    md = ["Crack onset (upper surface, plate-wide, eps_Y = " + ", ".join(f"{e:g}" for e in ONSET_EPS_Y)
          + " where reached in the window): the largest relative error against the continuous reference, by "
          "error control and tolerance:", "",
          "| case | control | " + " | ".join(f"{tol:g}" for tol in ONSET_TOLERANCES) + " |",
          "|---|---|" + "---|" * len(ONSET_TOLERANCES)]
    for case in cases:
        for name, control in CONTROLS.items():
            runs = [_run(rows, case, name, tol) for tol in ONSET_TOLERANCES]
            cells = [f"{r['onset_error']:.1e}" if r and np.isfinite(r["onset_error"]) else "-" for r in runs]
            md.append(f"| {case} | {control} | " + " | ".join(cells) + " |")
    return md


def _target_cells(mine, target):
    """The cheapest-run table's cells at one target: etd34's and rk4's knob and time."""
    e, k = _cheapest(mine, "etd34", target, "error"), _cheapest(mine, "rk4", target, "error")
    return (f" {e['knob']:g} | {e['time']:.4f} |" if e else " - | - |") + (
        f" {k['knob']:g} | {k['time']:.4f} |" if k else " - | - |")


def _control_cells(mine, target):
    """The controls' table's cells at one target: each control's time and their ratio."""
    a, b = time_at(mine, "etd34", target), time_at(mine, "etd34 smoothness", target)
    ratio = f"{b / a:.2f}" if a and b else "-"
    return (f" {a:.4f} |" if a else " - |") + (f" {b:.4f} | {ratio} |" if b else f" - | {ratio} |")


def _per_target(rows, cases, cells):
    """A row per case and error target: its cells from cells(the case's rows, target)."""
    md = []
    for case in cases:
        mine = [r for r in rows if r["case"] == case]
        md += [f"| {case} | {target:g} |" + cells(mine, target) for target in TARGETS]
    return md


def report(notes, rows) -> str:
    cases = list(dict.fromkeys(r["case"] for r in rows))
    md = ["# The time integrators against the continuous-x model", "",
          "Generated by `python benchmarks/time_integrator.py` (issue 56's measure). Strain error: relative L2 "
          "over 24 snapshots and 401 points against the continuous reference (Gauss density 16, 1000 "
          "subintervals, etd34 1e-12); 'steps alone': against today's quadrature at tolerance 1e-12. Wall "
          "times: the smaller of two, one process; compare ratios.", "", *notes, "",
          *_default_table(rows, cases), "", *_estimate_table(rows, cases), "", *_onset_table(rows, cases), "",
          "The cheapest run of each integrator that meets each target (against the continuous reference; "
          "'-': none of its runs does):", "",
          "| case | target | etd34: tolerance | time [s] | rk4: step fraction | time [s] |", "|---|---|---|---|---|---|",
          *_per_target(rows, cases, _target_cells), "",
          "The two error controls at each target: etd34's wall time on its work-precision line (log-linear "
          "between the runs around the target), and their ratio (below 1: smoothness is faster):", "",
          "| case | target | embedded [s] | smoothness [s] | smoothness / embedded |", "|---|---|---|---|---|",
          *_per_target(rows, cases, _control_cells)]
    return "\n".join(md) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="every other run (a smoke test)")
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    notes, rows = [], []
    for name in args.cases:
        note, more = case_rows(name, *CASES[name], args.quick)
        notes.append(note)
        rows += more
    with open(OUT / "time_integrator.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    text = report(notes, rows)
    (OUT / "time_integrator.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
