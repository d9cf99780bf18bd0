"""scipy's DOP853 on the same right-hand side: the outside reference users would reach for.

Same equations and the same model functions as the kernels (solver.model: the layer's forcing,
the modes' acceleration and damping, the body's deceleration), written as a first-order system
y = (a_n, da_n/dt, W), and a free body's penetration s and speed U (for the paper's body s = V t)
and stepped with :class:`scipy.integrate.DOP853` at rtol = tolerance,
atol = tolerance * 1e-3, first step that of etd34 (scipy's own guess can jump from first
touch straight into delta >= 1). Outputs come from its 7th-order dense output. Bottoming out is a
located event, as in the kernels: the first time the largest delta on the continuous plate
reaches 1 - bottoming_gap, found by brentq on the dense output. DOP853 has no step rejection
on delta >= 1: a stage there ends the run, with the time and scipy's step in the message,
and so does a step failure, with scipy's own reason.

One set of observers: after each DOP853 step the kernels' own (solver.loop.observe_step: the
tension records, so crack onset for any eps_Y; the contact intervals; the impact zone; a free
body's stops and separation) run on its two ends, sampling inside it on DOP853's dense output
where they would sample the exponential one. DOP853 stays an independent check of the time
integration: its steps, its error control and its dense output are scipy's. The largest force
and compression are observed at SAMPLES points a step and located between the neighbours of a
local maximum on the dense output (scipy's bounded Brent), where the kernels locate them on their
own sub-steps (solver.observe.layer_maxima). scipy is imported here only.
"""
from __future__ import annotations


from collections import namedtuple
from types import SimpleNamespace

import numpy as np

from . import layout as kn
from .diagnostics import Run, largest_tension
from .keys import ParameterError
from .ending import arm_breaks, break_value
from .loop import (Observers, StepEnds, initial_state, new_records, new_state, new_workspace, observe_step,
                   state_at)
from .model.body import body_accel, body_residual, start_body
from .model.contact import count_contacts, gap_peak
from .model.layer import layer_energy, layer_forcing_at
from .model.plate import mode_acceleration
from .observe.tension import Dense, dense_given
from .step import Carried


class _StageDeltaOne(Exception):
    """A stage evaluated delta >= 1 (the forcing is undefined there)."""


#: dense-output samples per DOP853 step at which the force and the compression are observed
SAMPLES = 8


class _Observers:
    """The kernels' own observers (solver.loop.observe_step) on each DOP853 step: the tension
    records and largest tensions (so crack onset for any eps_Y, solver.fracture), the contact
    intervals and their record, the impact zone's maxima, a free body's stops and separation. The
    dense states they sample inside a step (TensionWork A, AD, A2, AD2) are DOP853's own 7th-order
    dense output at those times, not the exponential one: what the observers see between the step
    ends is this integrator's. A DOP853 step is observed as SAMPLES consecutive pieces. A floe's plate-wide maxima are the records' (the kernels refine
    them on their own dense output at the run's end, solver.observe.dense_maxima)."""

    def __init__(self, tab, control, t, y0, system, diag):
        model, N, J = tab.model, tab.lam.size, tab.xq.size
        self.model, self.system, self.diag, self.N = model, system, diag, N
        self.ws = new_workspace(kn.ETD34, model, N, J, control.zone_margin)
        tw = self.ws.tension
        self.observers = Observers(tw, self.ws.contact, self.ws.peaks0, self.ws.zone, self.ws.dense, control.observers)
        self.fractions = [np.arange(1, A.shape[0] + 1) / (A.shape[0] + 1) for A in (tw.A, tw.A2)]
        self.cur, self.new = new_state(N, J), new_state(N, J)
        self.no_dense = Dense(np.empty(0, np.complex128), np.empty(0), np.empty(0), np.empty(0))
        records = new_records(kn.N_REC)
        self._body(t, y0, self.cur)
        a0, v0 = np.ascontiguousarray(y0[:N]), np.ascontiguousarray(y0[N:2 * N])
        _, self.force, self.jmax, _, self.contacts, self.records = initial_state(model, self.ws, self.cur, t, a0, v0,
                                                                                 records, diag)

    def _body(self, t, y, state):
        """The body's deficits (d, u) = (V t - s, V - U) of the state y into state.yb."""
        V = self.model.body.V
        state.yb[kn.B_D] = V * t - self.system.position(t, y)
        state.yb[kn.B_U] = V - self.system.speed(y)

    def step(self, t, h, dense):
        """The observers on the DOP853 step [t, t + h] (dense: its dense output), as SAMPLES
        consecutive pieces: the kernels' steps resolve the contact's changes, a DOP853 step of
        the 7th order spans more of them. Returns True where a free body left the ice in it."""
        N, tw = self.N, self.ws.tension
        left = False
        for k in range(SAMPLES):
            t0, hk = t + k * h / SAMPLES, h / SAMPLES
            for (A, AD), fractions in zip(((tw.A, tw.AD), (tw.A2, tw.AD2)), self.fractions):
                ys = dense(t0 + hk * fractions)
                A[:] = ys[:N].T
                AD[:] = ys[N:2 * N].T
            dense_given(tw.marks)                          # given: not computed from a Dense
            y1 = dense(t0 + hk)
            self._body(t0 + hk, y1, self.new)
            _, F1, j1, _ = state_at(self.model, t0 + hk, np.ascontiguousarray(y1[:N]),
                                    np.ascontiguousarray(y1[N:2 * N]), self.ws.work.fvals, self.new)
            carried = Carried(self.force, 0.0, 0.0, 0.0, self.contacts)
            self.contacts, self.records, piece_left = observe_step(
                self.model, self.observers, self.cur, self.new, carried, t0, hk, StepEnds(self.jmax, j1, F1, self.no_dense),
                self.records, self.diag)
            left = left or piece_left
            self.cur, self.new = self.new, self.cur
            self.force, self.jmax = F1, j1
        return left

    def finish(self):
        """The records (solver.loop.integrate's), and the largest tension of either surface into
        diag."""
        largest_tension(self.diag)
        return self.records


class _LayerMaxima:
    """The largest force and compression (largest delta), observed on DOP853's dense output at
    SAMPLES points a step and located between the neighbours of a sample that is a local maximum
    by scipy's bounded Brent (the kernels locate them on their own sub-steps,
    solver.observe.layer_maxima); and a free body's energy balance at the samples."""

    def __init__(self, body):
        self.body = body
        self.free = body.inv_mass > 0.0
        self.max_force = self.max_delta = 0.0
        self.max_force_t = self.max_delta_t = np.nan
        self.body_residual = self.peak_work = 0.0
        self.body_start = None                 # the body's energy balance at the run's start (0 at first touch)
        self.history = []                      # the last three samples (t, force, largest delta)
        self.value_at = None                   # (kind, t) -> force (kind 0) or largest delta, dense output

    def _locate(self, t, force, delta_max):
        """Where the previous sample is a local maximum of the force or the largest delta, the
        maximum between its neighbours, on the dense output."""
        self.history = (self.history + [(t, force, delta_max)])[-3:]
        if len(self.history) < 3 or self.value_at is None:
            return
        (a, *fa), (b, *fb), (c, *fc) = self.history
        for kind, attr in enumerate(("max_force", "max_delta")):
            if not (fb[kind] >= fa[kind] and fb[kind] > fc[kind]) or fb[kind] < (1 - 1e-2) * getattr(self, attr):
                continue
            from scipy.optimize import minimize_scalar     # (only where a sample is a candidate)
            res = minimize_scalar(lambda tt: -self.value_at(kind, tt), bounds=(a, c), method="bounded",
                                  options={"xatol": 1e-10 * (c - a), "maxiter": 200})
            value, when = (-res.fun, res.x) if -res.fun > fb[kind] else (fb[kind], b)
            if value > getattr(self, attr):
                setattr(self, attr, value)
                setattr(self, attr + "_t", when)

    def sample(self, t, force, delta_max, work, deficits):
        if force > self.max_force:
            self.max_force, self.max_force_t = force, t
        if delta_max > self.max_delta:
            self.max_delta, self.max_delta_t = delta_max, t
        self._locate(t, force, delta_max)
        self.peak_work = max(self.peak_work, work)
        if self.free:
            value = body_residual(self.body, t, deficits, work)
            self.body_start = value if self.body_start is None else self.body_start
            self.body_residual = max(self.body_residual, abs(value - self.body_start))

    def finish(self, diag):
        if not np.isinf(diag[kn.D_MAX_FORCE]):        # +inf: bottomed out, set by the caller
            diag[kn.D_MAX_FORCE], diag[kn.D_MAX_FORCE_T] = self.max_force, self.max_force_t
        diag[kn.D_MAX_DELTA], diag[kn.D_MAX_DELTA_T] = self.max_delta, self.max_delta_t
        diag[kn.D_ENERGY_JUMPS] = 0.0                 # DOP853 has no energy guard
        if self.free:
            diag[kn.D_BODY_RESIDUAL] = self.body_residual / self.peak_work if self.peak_work > 0 else 0.0


class _System:
    """DOP853's first-order system y = (a_n, da_n/dt, W), then a free body's (s, U), then the
    dissipated energy D where the ice or the layer is viscoelastic; on the kernels' model
    functions. coupled_damping: a viscoelastic floe's whole damping matrix (its off-diagonal part
    here; the kernels keep the diagonal)."""

    def __init__(self, tab, coupled_damping=False):
        self.tab, self.model = tab, tab.model
        N, J = tab.lam.size, tab.xq.size               # 2 Nmod on the full plate of an off-centre body
        self.N = N
        self.delta, self.fvals, self.P, self.accel, self.gap = (np.empty(J), np.empty(J), np.empty(N), np.empty(N),
                                                                np.empty(3))
        self.om2 = tab.omega**2
        self.nfev = 0
        viscous_ice = bool(np.any(tab.damping > 0))
        self.coupling = None
        if coupled_damping and tab.floe is not None and viscous_ice:
            self.coupling = tab.floe["damping_matrix"] - np.diag(np.diag(tab.floe["damping_matrix"]))
        self.V = self.model.body.V
        self.free = self.model.body.inv_mass > 0.0
        self.damped = viscous_ice or self.model.layer.tau > 0   # D: the plate's and the layer's dissipation
        self.n_extra = 3 if self.free else 1

    def initial(self, t_start, a0, v0, body_start=(np.nan, np.nan)):
        """y at t_start from the plate's a0, v0 and a free body's s, U (body_start; NaN: V t_start
        and V, as at first touch)."""
        s0, U0 = (self.V * t_start, self.V) if np.isnan(body_start[0]) else body_start[:2]
        return np.concatenate([a0, v0, [0.0, s0, U0] if self.free else [0.0], [0.0] if self.damped else []])

    def position(self, t, y):
        return y[2 * self.N + 1] if self.free else self.V * t

    def speed(self, y):
        return y[2 * self.N + 2] if self.free else self.V

    def forcing(self, t, y):
        N = self.N
        return layer_forcing_at(self.model, self.position(t, y), self.speed(y), np.ascontiguousarray(y[:N]),
                                np.ascontiguousarray(y[N:2 * N]), self.delta, self.fvals, self.P)

    def rhs(self, t, y):
        N, model, accel = self.N, self.model, self.accel
        self.nfev += 1
        st, F, _, layer_power = self.forcing(t, y)
        if st != 0:
            raise _StageDeltaOne(t)
        v = np.ascontiguousarray(y[N:2 * N])
        power = mode_acceleration(model.plate, np.ascontiguousarray(y[:N]), v, self.P, accel)
        if self.coupling is not None:                # the off-diagonal damping, and its power
            extra = self.coupling @ v
            np.subtract(accel, extra, out=accel)
            power += float(np.sum(self.tab.LM * v * extra))
        tail = [power + layer_power] if self.damped else []
        if self.free:
            U = y[2 * N + 2]
            return np.concatenate([v, accel, [F * U, U, -body_accel(model.body, F)], tail])
        return np.concatenate([v, accel, [self.V * F], tail])

    def largest_delta(self, t, y):
        """The gap (largest delta, its rate and place) into self.gap; returns the largest delta."""
        st, _, jmax, _ = self.forcing(t, y)
        if st != 0:
            return np.inf
        N = self.N
        gap_peak(self.model, self.position(t, y), self.speed(y), self.delta, jmax, np.ascontiguousarray(y[:N]),
                 np.ascontiguousarray(y[N:2 * N]), self.gap)
        return self.gap[0]

    def record(self, out, k, t, y):
        """Row k of the outputs at t."""
        N, model = self.N, self.model
        a, v, work = y[:N], y[N:2 * N], y[2 * N]
        st, F, jmax, _ = self.forcing(t, y)
        out.a[k], out.adot[k] = a, v
        series = out.series
        series[k, kn.S_CONTACTS] = count_contacts(self.delta, jmax, model.basis.mirror)
        series[k, kn.S_FORCE] = F
        series[k, kn.S_E_PLATE] = 0.5 * np.sum(self.tab.LM * (v**2 + self.om2 * a**2))
        series[k, kn.S_E_LAYER] = layer_energy(model, np.ascontiguousarray(a), self.position(t, y), self.delta, jmax)
        series[k, kn.S_WORK] = work
        series[k, kn.S_BODY_POSITION] = self.position(t, y)
        series[k, kn.S_BODY_SPEED] = self.speed(y)
        series[k, kn.S_DISSIPATED] = y[2 * N + self.n_extra] if self.damped else 0.0

    def balance(self, t, y):
        """(E_plate + E_layer + D - W, W) at t: the energy identity's left side less its right,
        which stays at the energy the run starts with [J m-1]."""
        N = self.N
        a = np.ascontiguousarray(y[:N])
        _, _, jmax, _ = self.forcing(t, y)
        plate = 0.5 * np.sum(self.tab.LM * (y[N:2 * N]**2 + self.om2 * a**2))
        dissipated = y[2 * N + self.n_extra] if self.damped else 0.0
        return plate + layer_energy(self.model, a, self.position(t, y), self.delta, jmax) + dissipated - y[2 * N], \
            y[2 * N]

    def sample(self, maxima, t, y):
        """The force, the largest delta, the work and the body's deficits at t into maxima."""
        N = self.N
        _, F, _, _ = self.forcing(t, y)
        dmax = self.largest_delta(t, y)
        maxima.sample(t, F, dmax, y[2 * N], np.array([self.V * t - self.position(t, y), self.V - self.speed(y)]))


def state_series(tab, t, a, adot, body=(np.nan, np.nan)) -> np.ndarray:
    """The series row (solver.layout's S_*: contacts, force, the plate's and the layer's energy,
    the body's position, ...) of the kernel's state a, adot of the plate of tab at t, a free body
    at body = (s, U) (NaN: V t, V) (the energies a break carries across, solver.run._across_break)."""
    system = _System(tab)
    N = system.N
    row = SimpleNamespace(a=np.empty((1, N)), adot=np.empty((1, N)), series=np.full((1, kn.N_SERIES), np.nan))
    system.record(row, 0, t, system.initial(t, np.asarray(a, float), np.asarray(adot, float), body))
    return row.series[0]


def _break(system, armed, level, t_old, t_new, dense, end):
    """The first time in the step at which an armed surface's (armed[s] 1) peak tension over x
    reaches the break level (brentq on the dense output, bracketed on 8 points), as (t, x,
    surface), or None; the surfaces still unarmed are armed at the step's end (end: the state
    there, its node strains computed by the observers) by the kernels' rule where it has none."""
    from scipy.optimize import brentq
    model, N, found = system.model, system.N, None
    state, value = new_state(N, system.tab.xq.size), np.empty(3)

    def peak(tt, sign):                      # the kernels' own event value: (peak, place)
        state.a[:] = dense(tt)[:N]
        return break_value(model, sign, tt, state, value), value[2]
    for surface, sign in ((0, 1.0), (1, -1.0)):
        if armed[surface] == 0.0:
            continue
        below = t_old
        for tp in np.linspace(t_old, t_new, 9)[1:]:
            if peak(tp, sign)[0] >= level:
                tb = brentq(lambda tt: peak(tt, sign)[0] - level, below, tp, xtol=1e-16, rtol=1e-15)
                if found is None or tb < found[0]:
                    found = (tb, peak(tb, sign)[1], surface)
                break
            below = tp
    if found is None:
        arm_breaks(model, armed, end.eps, end.a, level)
    return found


def _bottoming(system, level, t_old, t_new, y_new, dense):
    """The first time in the step at which the largest delta reaches level (brentq on the dense
    output; the step's end, and 8 points inside where the gap is already small), or None."""
    from scipy.optimize import brentq
    probe = [t_new]
    if system.largest_delta(t_new, y_new) > 0.9 or system.largest_delta(t_old, dense(t_old)) > 0.9:
        probe = list(np.linspace(t_old, t_new, 9)[1:])
    below = t_old
    for tp in probe:
        if system.largest_delta(tp, dense(tp)) >= level:
            if system.largest_delta(below, dense(below)) >= level:
                return below
            return brentq(lambda tt: min(system.largest_delta(tt, dense(tt)), 2.0) - level, below, tp,
                          xtol=1e-16, rtol=1e-15)
        below = tp
    return None


#: a run's energy identity over its accepted steps: the energy it starts with E0 (the plate's and
#: the layer's), the largest work so far and the largest |E_plate + E_layer + D - W - E0| [J m-1]
Balance = namedtuple("Balance", "start peak_work residual")


def _balanced(system, balance, t, y):
    """The Balance with the state y at t (an accepted step's end) taken in."""
    left, work = system.balance(t, y)
    return Balance(balance.start, max(balance.peak_work, work), max(balance.residual, abs(left - balance.start)))


def _summary(out, n_out, status, reason, t_reached, counts, balance):
    """The diagnostics at the end of the run: the energy residuals from the identity at every
    accepted step's end (balance), relative to the largest work plus the energy the run started
    with (as the kernels' finish_diagnostics; not from the output rows, which a later stage does
    not start with and whose number would change it); counts = (forcing evaluations, steps)."""
    diag = out.diag
    if status not in (kn.OK, kn.SEPARATED):
        diag[kn.D_FAIL_T] = t_reached
        diag[kn.D_FAIL_KIND] = reason
    diag[kn.D_T_REACHED] = t_reached
    scale = balance.peak_work + balance.start
    diag[kn.D_ENERGY_SCALE] = scale
    diag[kn.D_ENERGY_RESIDUAL] = balance.residual / scale if scale > 0 else 0.0
    if np.isfinite(diag[kn.D_BODY_RESIDUAL]) and scale > 0 and balance.peak_work > 0:   # (maxima.finish: over peak)
        diag[kn.D_BODY_RESIDUAL] *= balance.peak_work / scale
    diag[kn.D_RHS], diag[kn.D_STEPS] = counts
    diag[kn.D_REJECTED] = 0


def integrate_dop853(tab, control, t_out, a0, adot0, levels, out, coupled_damping=False):
    """The interface of :func:`solver.loop.integrate` on DOP853: fills out (Outputs; the error
    column NaN: DOP853 gives no local error estimates back; levels are not located: level_t stays
    NaN) and returns a Run (solver.diagnostics), its failure what stopped it or "". A free body's
    run that asks to end at separation ends at the step in which the kernels' observer finds it
    off the ice, moving up. coupled_damping: see _System (to measure what the kernels' diagonal
    damping of a floe leaves out)."""
    try:
        from scipy.integrate import DOP853
    except ImportError:                                      # pragma: no cover
        raise ParameterError("integrator dop853 needs scipy: pip install scipy") from None
    system = _System(tab, coupled_damping)
    T, diag = t_out.size, out.diag
    level = 1.0 - control.bottom_gap
    diag[kn.D_FAIL_KIND] = kn.FAIL_NONE
    status, reason, failure = kn.OK, kn.FAIL_NONE, ""
    t_start, t_end = control.t_start, control.t_end
    y0 = system.initial(t_start, a0, adot0, control.body_start)
    start_body(tab.model.body, t_start, control.body_start, np.zeros(2), diag)   # (its stop before t_start)
    k = 0
    observers = _Observers(tab, control, t_start, y0, system, diag)
    maxima = _LayerMaxima(tab.model.body)
    system.sample(maxima, t_start, y0)
    balance = Balance(system.balance(t_start, y0)[0], 0.0, 0.0)
    while k < T and t_out[k] <= t_start:
        system.record(out, k, t_start, y0)
        k += 1
    solver = DOP853(system.rhs, t_start, y0, t_end, rtol=control.tolerance, atol=control.tolerance * 1e-3,
                    first_step=control.h_init)
    t_reached, steps, dense, broke = t_start, 0, None, None
    armed = np.zeros(2)                    # the surfaces armed to break (solver.ending.arm_breaks)
    if control.break_level < np.inf:
        arm_breaks(tab.model, armed, observers.cur.eps, observers.cur.a, control.break_level)
    while solver.status == "running":
        if steps >= control.max_steps:
            status, reason = kn.STEP_LIMIT, kn.FAIL_MAX_STEPS
            break
        t_old = solver.t
        try:
            message = solver.step()
        except _StageDeltaOne as stage:
            status, reason = kn.NONFINITE, kn.FAIL_FIXED_STEP
            failure = (f"evaluated a stage with delta >= 1 at t = {float(str(stage)):.9g} s (scipy's step "
                       f"{solver.h_abs:.3g} s) and cannot retry such a stage;")
            break
        if solver.status == "failed":
            status, reason = kn.NONFINITE, kn.FAIL_NONFINITE
            failure = f"{message} (scipy's step {solver.h_abs:.3g} s)"
            break
        steps += 1
        previous_dense, dense = dense, solver.dense_output()

        def value_at(kind, tt, boundary=t_old, here=dense, before=previous_dense):
            y = here(tt) if tt >= boundary or before is None else before(tt)
            return system.forcing(tt, y)[1] if kind == 0 else system.largest_delta(tt, y)
        maxima.value_at = value_at
        t_bottom = _bottoming(system, level, t_old, solver.t, solver.y, dense)
        t_stop = solver.t if t_bottom is None else t_bottom
        left = observers.step(t_old, t_stop - t_old, dense)
        broke = None
        if control.break_level < np.inf and t_bottom is None:     # a break ends the run where it is
            broke = _break(system, armed, control.break_level, t_old, t_stop, dense, observers.cur)
            if broke is not None:
                t_stop = broke[0]
                diag[kn.D_BREAK_T], diag[kn.D_BREAK_X], diag[kn.D_BREAK_SURFACE] = broke[0], broke[1], broke[2]
        for tp in np.linspace(t_old, t_stop, SAMPLES + 1)[1:]:
            system.sample(maxima, tp, dense(tp))
        while k < T and t_out[k] <= t_stop:
            system.record(out, k, t_out[k], dense(t_out[k]))
            k += 1
        t_reached = t_stop
        balance = _balanced(system, balance, t_stop, solver.y if t_stop == solver.t else dense(t_stop))
        if t_bottom is not None:
            system.largest_delta(t_bottom, dense(t_bottom))
            gap = system.gap
            status, reason = kn.LAYER_BOTTOMED_OUT, kn.FAIL_LOCATED
            diag[kn.D_BOTTOM_T], diag[kn.D_BOTTOM_X] = t_bottom, gap[2]
            diag[kn.D_BOTTOM_SPEED] = tab.model.layer.he * gap[1]
            diag[kn.D_MAX_FORCE], diag[kn.D_MAX_FORCE_T] = np.inf, t_bottom
            break
        if left and control.until_separation:
            status, reason = kn.SEPARATED, kn.FAIL_NONE
            break
        if broke is not None:
            break
    if status == kn.OK and broke is None and system.free and control.until_separation and \
            not np.isnan(diag[kn.D_STOP_T]):
        status = kn.STOPPED                  # stopped, and still on the ice at the window's end (not at a break)
    records = observers.finish()
    maxima.finish(diag)
    y_end = solver.y if dense is None or t_reached == solver.t else dense(t_reached)
    if t_reached == t_start:
        y_end = y0
    out.final[0, :system.N], out.final[1, :system.N] = y_end[:system.N], y_end[system.N:2 * system.N]
    out.final[0, system.N], out.final[1, system.N] = system.position(t_reached, y_end), system.speed(y_end)
    _summary(out, k, status, reason, t_reached, (system.nfev, steps), balance)
    diag[kn.D_WORK] = y_end[2 * system.N]               # at the time reached, as the kernels' (a break's)
    diag[kn.D_DISSIPATED] = y_end[2 * system.N + system.n_extra] if system.damped else 0.0
    return Run(status, k, records, failure)
