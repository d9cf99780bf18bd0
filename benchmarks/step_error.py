"""How well does each error control see a step's local error? (issue 56)
python benchmarks/step_error.py [--cases NAME ...] [--steps 5e-5 1e-4 2e-4 4e-4] [--points 40]

At points t of a case's trajectory (etd34 at tolerance 1e-13), one etd34 step of length h is
taken from the trajectory's state at t with the solver's own kernel (solver.step.take_step),
after one of the same length from the trajectory's state at t - h (the smoothness estimate's
first half). The step's true local error is its difference from 16 sub-steps of h/16 from the
same state, in the energy norm (solver.control.error_ratio's); beside it the embedded estimate
(Settings.error_control = "embedded") and the smoothness estimate
(solver.control.smoothness_ratio, "smoothness"), each as a ratio to the same tolerance. Steps
across a change of the contact count, and in free flight (no forcing: every estimate 0), are left
out.

Per case and h: the median and 90th percentile of true / estimate for each (1: the estimate is
the error; above: it understates it), the correlation of their logarithms over the steps, and
the median omega_n h of the mode that carries most of the true error. Writes
results/bench/step_error.md.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from solver import Parameters, Settings, solve  # noqa: E402
from solver.control import History, Samples, error_ratio, make_control, smoothness_ratio  # noqa: E402
from solver.layout import ETD34  # noqa: E402
from solver.loop import new_state, state_at  # noqa: E402
from solver.model.assemble import Tables  # noqa: E402
from solver.model.body import body_coefficients  # noqa: E402
from solver.model.contact import count_contacts  # noqa: E402
from solver.model.plate import MASS, OMEGA  # noqa: E402
from solver.step import Carried, Coefficients, Start, StepWork, etd_coefficients, take_step  # noqa: E402

#: name -> parameters (the reference case and thin ice hit fast, as benchmarks/time_integrator.py)
CASES = {"reference": {"Nmod": 60}, "thin, fast, stiff layer": {"Nmod": 60, "hi": 0.3, "V": 10.0, "K": 8e7}}
SUBSTEPS = 16
TOLERANCE = 1e-9
OUT = Path("results/bench")


class Stepper:
    """One case's model, and etd34 steps of the solver's kernels from given modal states."""

    def __init__(self, p):
        self.model = Tables(p, Settings().subintervals, False, "gauss", Settings().quadrature_density).model
        self.N, self.J = self.model.plate.modes.shape[1], self.model.basis.cosq.shape[1]
        self.control = make_control(0.0, 1.0, TOLERANCE, 0.0, 1e-8, 0.0, 1.0, 10, 1e-3, smoothness=True)

    def state(self, t, a, adot):
        """The State at t from a, a' (its forcing, delta, eps) and its Carried."""
        s = new_state(self.N, self.J)
        st, force, jmax, power = state_at(self.model, t, np.ascontiguousarray(a), np.ascontiguousarray(adot),
                                          np.empty(self.J), s)
        assert st == 0
        return s, Carried(force, 0.0, 0.0, power, count_contacts(s.delta, jmax, self.model.basis.mirror))

    def step(self, state, carried, t, h):
        """(status, the State at t + h, its Carried, event, the mid-stage forcing N3) of one etd34 step."""
        N, J = self.N, self.J
        coeffs = Coefficients(np.empty((9, N), complex), np.empty((9, 2)))
        etd_coefficients(self.model.plate, h, coeffs.C)
        body_coefficients(h, coeffs.Cb)
        work = StepWork(np.empty((2, N), complex), np.empty((5, N)), np.empty(J), np.zeros((6, 6)))
        out = new_state(N, J)
        st, force, jmax, w_new, event = take_step(ETD34, self.model, coeffs, work,
                                                  Start(state.z, state.forcing, state.yb), carried, t, t + h, h, out)
        after = Carried(force, w_new, out.acc[0], out.acc[1], count_contacts(out.delta, jmax, self.model.basis.mirror))
        return st, out, after, event, work.rows[2].copy()

    def substeps(self, state, carried, t, h):
        """The state after SUBSTEPS steps of h / SUBSTEPS from state (the true solution's stand-in)."""
        for k in range(SUBSTEPS):
            st, state, carried, _, _ = self.step(state, carried, t + k * h / SUBSTEPS, h / SUBSTEPS)
            assert st == 0
        return state

    def ratios(self, a, adot, t, h):
        """(true, embedded, smoothness ratios, omega h of the mode with the most true error) of the
        step from t to t + h after one from t - h, from the trajectory's a, a' at t - h and t;
        None across a change of contact."""
        s0, c0 = self.state(t - h, a[0], adot[0])
        st, _, _, event0, mid0 = self.step(s0, c0, t - h, h)
        s1, c1 = self.state(t, a[1], adot[1])
        st1, end, _, event1, mid1 = self.step(s1, c1, t, h)
        if st or st1 or event0 or event1:
            return None
        exact = self.substeps(s1, c1, t, h)
        plate = self.model.plate
        gap = np.zeros(3)
        embedded = error_ratio(self.model, self.control, s1.z, end.z, end.err, end.errb, gap, np.empty(self.N))
        # (the paper's prescribed body: no body term)
        history = History(np.ascontiguousarray(np.vstack([s0.forcing, mid0])), np.array([h, 1.0]), np.zeros(2))
        smooth = smoothness_ratio(self.model, self.control, history, Samples(s1.forcing, mid1, end.forcing, np.zeros(3)),
                                  h, s1.z, end.z)
        diff = end.z - exact.z
        true = error_ratio(self.model, self.control, s1.z, end.z, diff, np.zeros(2), gap, np.empty(self.N))
        worst = int(np.argmax(plate.modes[MASS] * np.abs(diff) ** 2))
        return true, embedded, smooth, plate.modes[OMEGA, worst] * h


def case_rows(name, kw, steps, points):
    p = Parameters(**kw)
    stepper = Stepper(p)
    t_lo, t_hi = 2e-3, 0.95 * p.stage_duration
    rows = []
    for h in steps:
        centres = np.linspace(t_lo + h, t_hi, points)
        times = np.sort(np.concatenate([centres - h, centres]))
        ref = solve(p, Settings(error_estimate=False, tolerance=1e-13, error_control="embedded"), times=times, fields=(), t_end=times[-1])
        a, adot = np.asarray(ref.amplitudes), np.asarray(ref.velocities)
        found = []
        for i, t in enumerate(centres):
            r = stepper.ratios(a[2 * i:2 * i + 2], adot[2 * i:2 * i + 2], t, h)
            if r is not None and min(r[:3]) > 0.0:          # (in contact: in free flight both read 0)
                found.append(r)
        true, embedded, smooth, omega_h = (np.array(column) for column in zip(*found))
        row = dict(case=name, h=h, steps=len(found), omega_h=float(np.median(omega_h)))
        for label, estimate in (("embedded", embedded), ("smoothness", smooth)):
            q = true / estimate
            row[label] = (float(np.median(q)), float(np.percentile(q, 90)),
                          float(np.corrcoef(np.log(true), np.log(estimate))[0, 1]))
        print(row, flush=True)
        rows.append(row)
    return rows


def report(rows) -> str:
    md = ["# Each error control against a step's true local error", "",
          "Generated by `python benchmarks/step_error.py` (issue 56). One etd34 step of length h from the "
          f"trajectory (etd34 at 1e-13) at evenly spaced times from 2 ms to 0.95 of the stage, its true local "
          f"error from {SUBSTEPS} sub-steps; steps across a change of the contact count or in free flight left "
          "out. true / "
          "estimate: 1 when the estimate is the error, above 1 where it understates it.", "",
          "| case | h [us] | steps | embedded: true / estimate, median (90th percentile) | correlation of logs | "
          "smoothness: true / estimate, median (90th percentile) | correlation of logs | omega h of the mode "
          "with the most error (median) |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        e, s = r["embedded"], r["smoothness"]
        md.append(f"| {r['case']} | {r['h'] * 1e6:.0f} | {r['steps']} | {e[0]:.2g} ({e[1]:.2g}) | {e[2]:.2f} | "
                  f"{s[0]:.2g} ({s[1]:.2g}) | {s[2]:.2f} | {r['omega_h']:.1f} |")
    return "\n".join(md) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--steps", type=float, nargs="+", default=[5e-5, 1e-4, 2e-4, 4e-4], help="step lengths h [s]")
    ap.add_argument("--points", type=int, default=40, help="steps taken per case and h")
    args = ap.parse_args()
    rows = []
    for name in args.cases:
        rows += case_rows(name, CASES[name], args.steps, args.points)
    OUT.mkdir(parents=True, exist_ok=True)
    text = report(rows)
    (OUT / "step_error.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
