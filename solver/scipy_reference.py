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
and so does a step failure, with scipy's own reason. The kernels' in-loop diagnostics (largest
tensions and their records, so crack onset; contacts, force, compression; a free body's
balance) are observed on the dense output at SAMPLES points a step, not located inside steps,
but for the largest force and compression: where a sample is a local maximum of its neighbours,
the maximum between them is located on the dense output (scipy's bounded Brent), as the kernels
locate it on sub-steps (solver.observe.layer_maxima). Between samples, the kernels' own
observers of the impact zone (solver.observe.zone) and of a free body's stop and separation
(solver.observe.body) run on them as on step ends. The contact record stays empty. scipy is
imported here only.
"""
from __future__ import annotations


import numpy as np

from . import layout as kn
from .cubic import cubic_max, hermite
from .model.body import body_accel, body_residual
from .model.basis import field_sum, global_peak, node_strain
from .model.contact import count_contacts, gap_peak
from .model.layer import layer_energy, layer_forcing_at
from .model.plate import mode_acceleration
from .observe.body import observe_body
from .observe.tension import Dense
from .observe.zone import observe_zone, zone_work


class _StageDeltaOne(Exception):
    """A stage evaluated delta >= 1 (the forcing is undefined there)."""


#: dense-output samples per DOP853 step at which the diagnostics are observed
SAMPLES = 8


def _peak(coef, lam, xq, eps, sign):
    """The largest sign * eps(x), eps = sum_n coef_n cos(lam_n x) given at the nodes xq, refined
    by two Newton steps on the modal sum: (value, x)."""
    j = int(np.argmax(sign * eps))
    x, value = xq[j], sign * eps[j]
    for _ in range(2):
        d1 = -sign * np.sum(coef * lam * np.sin(lam * x))
        d2 = -sign * np.sum(coef * lam**2 * np.cos(lam * x))
        if not d2 < 0.0:
            break
        trial = min(max(x - d1 / d2, xq[0]), xq[-1])
        if abs(trial - x) > xq[1] - xq[0]:
            break
        trial_value = sign * np.sum(coef * np.cos(lam * trial))
        if trial_value < value:
            break
        x, value = trial, trial_value
    return value, x


def _record_max(rec):
    """(value, t, x) of the largest tension of a record: its nodes, and the maxima of its cubic
    Hermite pieces between samples (so the peak's time is not that of a sample)."""
    i = int(np.argmax(rec[:, kn.R_VALUE]))
    best = (rec[i, kn.R_VALUE], rec[i, kn.R_T], rec[i, kn.R_X])
    for i in np.flatnonzero(rec[1:, kn.R_JOIN] == 1.0):
        a, b = rec[i], rec[i + 1]
        h = b[kn.R_T] - a[kn.R_T]
        value, th = cubic_max(*hermite(a[kn.R_VALUE], b[kn.R_VALUE], a[kn.R_RATE], b[kn.R_RATE], h))
        if value > best[0]:
            best = (value, a[kn.R_T] + th * h, a[kn.R_X] + th * (b[kn.R_X] - a[kn.R_X]))
    return best


class _Observer:
    """The in-loop diagnostics of the kernels, observed on DOP853's dense output at SAMPLES
    points a step: the largest tensions with their places and times and their running-maximum
    records (so crack onset for any eps_Y, solver.fracture), contacts, the force and compression
    (located around their largest samples), a free body's energy balance; and by the kernels'
    own observers between samples, the impact zone's maxima (solver.observe.zone) and a free
    body's stop and separation (solver.observe.body)."""

    def __init__(self, tab, zone_margin):
        self.tab, self.body = tab, tab.model.body
        self.free = self.body.inv_mass > 0.0
        N, J = tab.omega.size, tab.xq.size
        self.zone, self.zone_diag, self.zone_t = zone_work(float(zone_margin), N), np.full(kn.N_DIAG, np.nan), None
        self.no_best = np.full((2, 4), -np.inf)     # (the kernels' plate-wide step maxima: not here)
        self.no_body = np.zeros(2)                  # (the body between samples: not needed without them)
        # no dense states between two samples (the zone is sampled at DOP853's own samples)
        self.no_inside = (np.empty((0, N)), np.empty((0, N)), np.empty(J),
                          Dense(np.zeros(N, np.complex128), np.zeros(N), np.zeros(N), np.zeros(N)), np.ones(5))
        self.records = ([], [])
        self.zone_records = [np.empty((64, kn.N_REC)), np.int64(0), np.empty((64, kn.N_REC)), np.int64(0)]
        self.running = [-np.inf, -np.inf]
        self.last = [None, None]               # each surface's previous sample row
        self.max_contacts = self.max_force = self.max_delta = 0.0
        self.max_force_t = self.max_delta_t = np.nan
        self.body_diag = np.full(kn.N_DIAG, np.nan)   # a free body's ends, by the kernels' observer
        self.body_last = None                          # the previous sample's (t, yb, force)
        self.no_record = (np.empty((0, 2)), np.int64(0))
        self.body_residual = 0.0
        self.peak_work = 0.0
        self.history = []                      # the last three samples (t, force, largest delta)
        self.value_at = None                   # (kind, t) -> force (kind 0) or largest delta, dense output

    def _locate_maxima(self, t, force, delta_max):
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

    def sample(self, t, a, v, work, contacts, force, delta_max, s, U, delta, jmax):
        tab, V = self.tab, self.body.V
        if tab.floe is None:
            coef = a * tab.strain_coef
            eps = coef @ tab.cosq
        else:                                  # a floe's wet modes: the kernels' strain and peaks
            basis, eps = tab.model.basis, np.empty(tab.xq.size)
            a, v = np.ascontiguousarray(a), np.ascontiguousarray(v)
            node_strain(basis.cosq, basis.floe, tab.strain_coef, a, eps)
        for k, sign in enumerate((1.0, -1.0)):
            if tab.floe is None:
                value, x = _peak(coef, tab.lam, tab.xq, eps, sign)
                rate = sign * np.sum(v * tab.strain_coef * np.cos(tab.lam * x))
            else:
                value, x, _ = global_peak(eps, sign, basis, tab.strain_coef, a)
                rate = sign * field_sum(basis.lam1, basis.floe, (tab.strain_coef, 1), v, x)
            row = [t, value, rate, x, 0.0]
            previous = self.last[k]
            if value > self.running[k]:            # a piece from the previous sample to this one
                rec = self.records[k]
                if previous is not None:
                    if not rec or rec[-1] is not previous:
                        rec.append(previous)
                    row[kn.R_JOIN] = 1.0
                rec.append(row)
                self.running[k] = value
            self.last[k] = row
        h = 0.0 if self.zone_t is None else t - self.zone_t
        self.zone_records = list(observe_zone(self.tab.model, self.zone, t - h, h,
                                              (np.ascontiguousarray(eps), delta, np.ascontiguousarray(a),
                                               np.ascontiguousarray(v), jmax, self.no_best, self.no_body,
                                               self.no_body),
                                              self.no_inside, tuple(self.zone_records), self.zone_diag))
        self.zone_t = t
        self.max_contacts = max(self.max_contacts, contacts)
        if force > self.max_force:
            self.max_force, self.max_force_t = force, t
        if delta_max > self.max_delta:
            self.max_delta, self.max_delta_t = delta_max, t
        self._locate_maxima(t, force, delta_max)
        self.peak_work = max(self.peak_work, work)
        if self.free:
            deficits = np.array([V * t - s, V - U])             # the kernels' body state (d, u)
            if self.body_last is not None:            # its stops and separation between the samples
                t0, yb0, F0 = self.body_last
                observe_body(self.body, t0, t - t0, yb0, deficits, F0, force, np.int64(contacts), self.no_record,
                             self.body_diag)
            self.body_last = (t, deficits, force)
            self.body_residual = max(self.body_residual, abs(body_residual(tab.model.body, t, deficits, work)))

    def finish(self, diag):
        """The diagnostics into diag (the kernels' slots); returns the records (upper, lower, the
        impact zone's upper, lower)."""
        records = []
        for k in range(2):
            rec = np.asarray(self.records[k], dtype=float).reshape(-1, kn.N_REC)
            if rec.shape[0]:
                diag[kn.D_MAX_UPPER + 3 * k], diag[kn.D_MAX_UPPER_T + 3 * k], diag[kn.D_MAX_UPPER_X + 3 * k] = \
                    _record_max(rec)
            records.append(rec)
        up, lo = diag[kn.D_MAX_UPPER], diag[kn.D_MAX_LOWER]
        top = 0 if up >= lo else 1
        diag[kn.D_MAX_ABS], diag[kn.D_MAX_ABS_X], diag[kn.D_MAX_ABS_T] = (
            diag[kn.D_MAX_UPPER + 3 * top], diag[kn.D_MAX_UPPER_X + 3 * top], diag[kn.D_MAX_UPPER_T + 3 * top])
        diag[kn.D_MAX_CONTACTS] = self.max_contacts
        if not np.isinf(diag[kn.D_MAX_FORCE]):        # +inf: bottomed out, set by the caller
            diag[kn.D_MAX_FORCE], diag[kn.D_MAX_FORCE_T] = self.max_force, self.max_force_t
        diag[kn.D_MAX_DELTA], diag[kn.D_MAX_DELTA_T] = self.max_delta, self.max_delta_t
        zone = [kn.D_ZONE_UPPER + i for i in range(6)] + [kn.D_ZONE_UPPER_EDGE, kn.D_ZONE_LOWER_EDGE,
                                                           kn.D_CONTACT_EXTENT]
        diag[zone] = self.zone_diag[zone]
        diag[kn.D_ENERGY_JUMPS] = 0.0                 # DOP853 has no energy guard
        if self.free:
            ends = [kn.D_STOP_T, kn.D_MAX_PENETRATION, kn.D_SEPARATION_T, kn.D_SEPARATION_SPEED]
            diag[ends] = self.body_diag[ends]
            diag[kn.D_BODY_RESIDUAL] = self.body_residual / self.peak_work if self.peak_work > 0 else 0.0
        zu, n_zu, zl, n_zl = self.zone_records
        return records[0], records[1], zu[:n_zu].copy(), zl[:n_zl].copy()


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

    def initial(self, t_start, a0, v0):
        return np.concatenate([a0, v0, [0.0, self.V * t_start, self.V] if self.free else [0.0],
                               [0.0] if self.damped else []])

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

    def observe(self, observer, t, y):
        """The observer's sample at t."""
        N = self.N
        st, F, jmax, _ = self.forcing(t, y)
        contacts = count_contacts(self.delta, jmax, self.model.basis.mirror)
        dmax = self.largest_delta(t, y)              # (it recomputes delta: the same values)
        observer.sample(t, y[:N], y[N:2 * N], y[2 * N], contacts, F, dmax, self.position(t, y), self.speed(y),
                        self.delta, jmax)


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


def _summary(out, n_out, status, reason, t_reached, counts):
    """The diagnostics at the end of the run from the output rows: work, dissipated energy and the
    energy residual; counts = (forcing evaluations, steps)."""
    diag, series = out.diag, out.series
    if status not in (kn.OK, kn.SEPARATED):
        diag[kn.D_FAIL_T] = t_reached
        diag[kn.D_FAIL_KIND] = reason
    diag[kn.D_T_REACHED] = t_reached
    if n_out:
        e = series[:n_out]
        work = e[-1, kn.S_WORK]
        peak = e[:, kn.S_WORK].max()
        diag[kn.D_WORK] = work
        residual = np.abs(e[:, kn.S_E_PLATE] + e[:, kn.S_E_LAYER] + e[:, kn.S_DISSIPATED] - e[:, kn.S_WORK]
                          - e[0, kn.S_E_PLATE] - e[0, kn.S_E_LAYER])
        diag[kn.D_DISSIPATED] = e[-1, kn.S_DISSIPATED]
        diag[kn.D_ENERGY_RESIDUAL] = residual.max() / peak if peak > 0 else 0.0
    diag[kn.D_RHS], diag[kn.D_STEPS] = counts
    diag[kn.D_REJECTED] = 0


def integrate_dop853(tab, control, t_out, a0, adot0, levels, out, coupled_damping=False):
    """The interface of :func:`solver.loop.integrate` on DOP853: fills out (Outputs; the error
    column NaN: DOP853 gives no local error estimates back; levels are not located: level_t stays
    NaN) and returns (status, n_out, records, failure), records = (upper, n, lower, n, contacts, 0,
    zone upper, n, zone lower, n) (no contact record), failure what stopped it or "". A free body's run that asks to end at
    separation ends at the first step after which it is off the ice, moving up. coupled_damping:
    see _System (to measure what the kernels' diagonal damping of a floe leaves out)."""
    try:
        from scipy.integrate import DOP853
    except ImportError:                                      # pragma: no cover
        from .parameters import ParameterError
        raise ParameterError("integrator dop853 needs scipy: pip install scipy") from None
    system = _System(tab, coupled_damping)
    N, T, diag = system.N, t_out.size, out.diag
    level = 1.0 - control.bottom_gap
    diag[kn.D_FAIL_KIND] = kn.FAIL_NONE
    status, reason, failure = kn.OK, kn.FAIL_NONE, ""
    t_start, t_end = control.t_start, control.t_end
    y0 = system.initial(t_start, a0, adot0)
    k = 0
    observer = _Observer(tab, control.zone_margin)
    system.observe(observer, t_start, y0)
    while k < T and t_out[k] <= t_start:
        system.record(out, k, t_start, y0)
        k += 1
    solver = DOP853(system.rhs, t_start, y0, t_end, rtol=control.tolerance, atol=control.tolerance * 1e-3,
                    first_step=control.h_init)
    t_reached, steps, dense = t_start, 0, None
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
        observer.value_at = value_at
        t_bottom = _bottoming(system, level, t_old, solver.t, solver.y, dense)
        t_stop = solver.t if t_bottom is None else t_bottom
        for tp in np.linspace(t_old, t_stop, SAMPLES + 1)[1:]:
            system.observe(observer, tp, dense(tp))
        if control.until_separation and t_bottom is None and system.free and solver.y[2 * N + 2] < 0.0:
            st, F, jmax, _ = system.forcing(solver.t, solver.y)
            if count_contacts(system.delta, jmax, tab.model.basis.mirror) == 0:
                while k < T and t_out[k] <= t_stop:
                    system.record(out, k, t_out[k], dense(t_out[k]))
                    k += 1
                t_reached = t_stop
                status, reason = kn.SEPARATED, kn.FAIL_NONE
                break
        while k < T and t_out[k] <= t_stop:
            system.record(out, k, t_out[k], dense(t_out[k]))
            k += 1
        t_reached = t_stop
        if t_bottom is not None:
            system.largest_delta(t_bottom, dense(t_bottom))
            gap = system.gap
            status, reason = kn.LAYER_BOTTOMED_OUT, kn.FAIL_LOCATED
            diag[kn.D_BOTTOM_T], diag[kn.D_BOTTOM_X] = t_bottom, gap[2]
            diag[kn.D_BOTTOM_SPEED] = tab.model.layer.he * gap[1]
            diag[kn.D_MAX_FORCE], diag[kn.D_MAX_FORCE_T] = np.inf, t_bottom
            break
    up, lo, zu, zl = observer.finish(diag)
    _summary(out, k, status, reason, t_reached, (system.nfev, steps))
    return status, k, (up, up.shape[0], lo, lo.shape[0], np.empty((0, 2)), 0, zu, zu.shape[0], zl, zl.shape[0]), \
        failure
