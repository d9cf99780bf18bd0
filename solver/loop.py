r"""The integration loop: step, judge, locate, observe, shift (docs/model.md, "Numerics").

Each pass of :func:`integrate` records the outputs due at the current time, tries one step
(solver.step) of the size the step policy chooses (solver.control), judges it (finite, its local
error, the energy identity), locates an event that ends the run inside it on true sub-steps
(bottoming; a break, where the run breaks the plate: solver.ending), and then calls the
observers at one fixed point, on the step's two end states and its dense output: the tension
records, the impact zone's maxima, levels of tension located for verification, the contact
intervals, a free body's stop and separation (solver.observe). The two states swap roles at the
end of a step.

What crosses: the Model (solver.model.assemble), the run's Control, the output times, the
initial modal state, tension levels to locate, and the Outputs to fill (solver.diagnostics).
"""
import math
from collections import namedtuple

import numpy as np

from .arrays import copy_into
from .control import (SMOOTH_EXPONENT, History, Samples, energy_allowance, error_ratio, grown_step, next_step,
                      remember_step, smoothness_ratio)
from .diagnostics import (Counts, Records, Residuals, bottomed_at, failed_at, finish_diagnostics, record_output,
                          running_maxima, start_diagnostics)
from .ending import BOTTOMING, BREAK, NO_EVENT, arm_breaks, break_inside_step, ending_event, gap_at
from .compile.jit import kernel
from .layout import (B_D, B_U, D_ANSWERED_T, D_BODY_RESIDUAL, D_DISSIPATED, D_ENERGY_JUMPS, D_H_MAX, D_H_MIN, D_MAX_CONTACTS,
                     D_MAX_DELTA, D_MAX_DELTA_T, D_MAX_UPPER, D_MAX_UPPER_T, D_MAX_UPPER_X, D_STOP_T,
                     D_T_REACHED, ENERGY_VIOLATION, ETD34, FAIL_BOTTOMED, FAIL_ENERGY_JUMP, FAIL_FIXED_STEP,
                     FAIL_MAX_STEPS, FAIL_NONFINITE, FAIL_STEP_UNDERFLOW, LAYER_BOTTOMED_OUT, N_REC, NONFINITE,
                     OK, SEPARATED, STEP_LIMIT, STOPPED)
from .model.basis import node_strain
from .model.body import body_coefficients, body_position, body_residual, body_speed, start_body
from .model.contact import count_contacts, gap_peak
from .model.crack import add_crack_forcing
from .model.layer import layer_energy, layer_forcing_at, node_energy
from .model.plate import OMEGA, STRAIN, plus_plate_energy, mode_a, mode_adot, mode_z, plate_damped
from .observe.asked import CONTACTS, FLOE_MAXIMA, LAYER_MAXIMA, TENSION, ZONE, answered, asks
from .observe.body import observe_body
from .observe.contacts import Snapshot, contact_work, observe_contacts
from .observe.dense_maxima import dense_maxima_work, finish_dense_maxima, observe_candidates
from .observe.events import from_start, locate_event
from .observe.layer_maxima import LayerEnds, finish_layer_maxima, maxima_work, observe_layer_maxima
from .observe.record import Rows, SurfaceRows, append_row
from .observe.tension import (PEAKS, RUN_MAX, STEP_BEST, Dense, DenseStates, StepStrains, dense_due, global_state,
                              observe_tensions, tension_work, watch_level)
from .observe.reach import Span
from .observe.zone import ZoneEnds, observe_zone, zone_work
from .step import G_ROW, Carried, Coefficients, Start, State, StepWork, Stepper, etd_coefficients, take_step

#: the loop's work space besides its two states: the step's scratch, the sub-steps' state and
#: their stepper (its own coefficients and scratch: a search inside a step leaves the step's
#: buffers as they were), the observers' work (tension, contacts, impact zone), the gap (largest
#: delta, its rate and place) at the step's two ends, an event's value (3,), the tension peaks at
#: the step's start (2, 4), the fixed step's [target, step], the force's and compression's maxima
#: (observe.layer_maxima), a floe's tension maxima's candidate steps (observe.dense_maxima) and the
#: records' row counts when their running maxima passed the levels asked (observe.asked, 4), and
#: the last accepted step's forcing (control.History)
Workspace = namedtuple("Workspace", "work sub stepper tension contact zone gap0 gap1 value peaks0 fixed maxima dense "
                                    "crossed history armed")
#: the observers' work and which of them run: TensionWork, ContactWork, the tension peaks at the
#: step's start, ZoneWork, DenseMaxima, and the observers asked (Control.observers, observe.asked)
Observers = namedtuple("Observers", "tension contact peaks0 zone dense asked")
#: what the observers read of an accepted step besides its states: jmax at t, jmax and the force at
#: t + h, the step's Dense
StepEnds = namedtuple("StepEnds", "jmax jmax1 force1 dense")
#: a trial step: its status, the work W(t + h), jmax at t + h, t, h, the error's exponent, the
#: smoothness estimate over the tolerance (control.smoothness_ratio; 0 where it does not judge)
Trial = namedtuple("Trial", "status work1 jmax1 t h exponent smooth")
#: the energy identity's terms at t: E(t_start), the residual at t, W(t)
Energies = namedtuple("Energies", "start residual work")

#: a trial step's verdict
ACCEPT, RETRY, STOP = 0, 1, 2


@kernel(nrt=True)
def new_records(N_REC):
    """Empty Records (diagnostics.Records) of a run: rows of N_REC columns, the contacts' of 2."""
    none = np.int64(0)                  # (not a literal 0: numba would compile the observers twice)
    return Records(np.empty((256, N_REC)), none, np.empty((256, N_REC)), none, np.empty((64, 2)), none,
                   np.empty((256, N_REC)), none, np.empty((256, N_REC)), none)


@kernel(nrt=True)
def new_state(N, J):
    """A State for N modes and J nodes (the body at d = u = 0)."""
    return State(np.empty(N, np.complex128), np.empty(N), np.empty(N), np.empty(N), np.empty(J), np.empty(J),
                 np.zeros(2), np.empty(N, np.complex128), np.zeros(2), np.zeros(3))


@kernel(nrt=True)
def _step_work(N, J):
    return StepWork(np.empty((2, N), np.complex128), np.empty((5, N)), np.empty(J), np.zeros((6, 6)))


@kernel(nrt=True)
def new_workspace(method, model, N, J, margin):
    stepper = Stepper(method, model, Coefficients(np.empty((9, N), np.complex128), np.empty((9, 2))),
                      _step_work(N, J))
    return Workspace(_step_work(N, J), new_state(N, J), stepper, tension_work(N, J), contact_work(J),
                     zone_work(margin), np.empty(3), np.empty(3), np.empty(3), np.empty((2, 4)),
                     np.array([-1.0, 0.0]), maxima_work(N), dense_maxima_work(N), np.full(4, np.nan),
                     History(np.zeros((2, N)), np.zeros(2), np.zeros(2)), np.zeros(2))


@kernel(nrt=True)
def state_at(model, t, a, adot, fvals, state):
    """state's z, a, a', forcing, delta and eps from the modes' a, a' at t (its yb given): (status,
    force, jmax, the layer's power); fvals (J,) scratch. status 1 where the layer is bottomed out
    (delta >= 1 at a node)."""
    plate = model.plate
    for n in range(a.shape[0]):
        state.z[n] = mode_z(a[n], adot[n], n, plate)
        state.a[n] = a[n]
        state.adot[n] = adot[n]
    s, U = body_position(model.body, t, state.yb), body_speed(model.body, state.yb)
    st, force, jmax, lp = layer_forcing_at(model, s, U, state.a, state.adot, state.delta, fvals, state.forcing)
    add_crack_forcing(model.cracks, t, state.forcing)
    if st == 0:
        node_strain(model.basis.cosq, model.basis.floe, plate.modes[STRAIN], state.a, state.eps)
    return st, force, jmax, lp


@kernel
def final_state(model, t, state, final):
    """The state reached at t into final (2, N + 1), where a restart or a break starts from: a
    and adot, and the body's penetration s and speed U in column N."""
    N = state.a.shape[0]
    for n in range(N):
        final[0, n] = state.a[n]
        final[1, n] = state.adot[n]
    final[0, N] = body_position(model.body, t, state.yb)
    final[1, N] = body_speed(model.body, state.yb)


@kernel(nrt=True)
def initial_state(model, ws, cur, t, a0, adot0, records, diag):
    """The state at t_start and its observers: (status, force, jmax, layer power, contacts,
    Records); status 1 if the layer is bottomed out already."""
    st, force, jmax, lp = state_at(model, t, a0, adot0, ws.work.fvals, cur)
    if st != 0:
        return st, force, jmax, lp, 0, records
    s = body_position(model.body, t, cur.yb)
    contacts = count_contacts(cur.delta, jmax, model.basis.mirror)
    cur.acc[2] = layer_energy(model, cur.a, s, cur.delta, jmax) if model.basis.rule == 1 else math.nan
    rec_c, n_c = append_row(records.contacts, records.n_contacts, t, float(contacts), 0.0, 0.0, 0.0)
    diag[D_MAX_CONTACTS] = contacts
    tw = ws.tension
    for s_ in range(2):
        peak = tw.track[PEAKS + s_]
        global_state(model, cur.eps, 1.0 - 2.0 * s_, cur.a, cur.adot, peak)
        tw.marks[RUN_MAX + s_] = peak[0]
        diag[D_MAX_UPPER + 3 * s_] = peak[0]
        diag[D_MAX_UPPER_X + 3 * s_] = peak[2]
        diag[D_MAX_UPPER_T + 3 * s_] = t
    zone = observe_zone(model, ws.zone, t, 0.0, ZoneEnds(cur.eps, cur.delta, cur.a, cur.adot, jmax,
                                                         np.full((2, 4), -np.inf), cur.yb, cur.yb),
                        DenseStates(tw.A, tw.AD, tw.eps, Dense(cur.z, cur.forcing, cur.forcing, cur.forcing),
                                    tw.marks, tw.dry),
                        SurfaceRows(records.zone_upper, records.n_zone_upper, records.zone_lower,
                                    records.n_zone_lower), diag)
    gap_peak(model, s, body_speed(model.body, cur.yb), cur.delta, jmax, cur.a, cur.adot, ws.gap0)
    diag[D_MAX_DELTA] = ws.gap0[0]
    diag[D_MAX_DELTA_T] = t
    return 0, force, jmax, lp, contacts, Records(records.upper, records.n_upper, records.lower, records.n_lower, rec_c,
                                                 n_c, zone.upper, zone.n_upper, zone.lower, zone.n_lower)


@kernel(inline="llvm")
def _finite_state(st, w_new, z, yb):
    if not (st == 0 and math.isfinite(w_new)):
        return False
    for n in range(z.shape[0]):
        if not (math.isfinite(z[n].real) and math.isfinite(z[n].imag)):
            return False
    return math.isfinite(yb[B_D]) and math.isfinite(yb[B_U])


@kernel(inline="llvm")
def _residual(model, z, delta, acc, jm, w_new, e0):
    """(E_plate + E_layer, the energy residual E_plate + E_layer + D - W - E(t_start)) at a state
    (its z, delta and acc: the arrays it reads, not the State, whose every array numba would
    count a reference to). The contact-resolving rule's E_layer is the one its last stage
    computed (acc[2]); the paper's, from delta."""
    if model.basis.rule == 1:
        e_layer = acc[2]
    else:
        e_layer = node_energy(model, delta, jm)
    e_new = plus_plate_energy(e_layer, model.plate, z)
    return e_new, e_new + acc[0] - w_new - e0


@kernel(inline="llvm")
def judge_step(adaptive, model, control, z0, new, gap0, scratch, trial, energies, diag):
    """The verdict on a Trial step from t (z0 at t) to new, energies the Energies at t, gap0 the gap
    at t and scratch (N,): (verdict, h to retry with, error ratio, residual at t_new, run status,
    rejections counted). A non-finite state or a stage at delta >= 1 retries at h/4, an error
    above the tolerance at the controller's h, a jump of the energy identity at h/4; below h_min,
    or for a fixed step, the run stops with its reason."""
    st, w_new, jm5, t, h_step, expo = trial.status, trial.work1, trial.jmax1, trial.t, trial.h, trial.exponent
    e0, resid, work = energies.start, energies.residual, energies.work
    if not _finite_state(st, w_new, new.z, new.yb):
        if not adaptive:
            failed_at(diag, t, float(FAIL_FIXED_STEP))
            return STOP, h_step, 0.0, 0.0, NONFINITE, 0
        h = 0.25 * h_step
        if h < control.h_min:
            failed_at(diag, t, float(FAIL_BOTTOMED if st != 0 else FAIL_NONFINITE))
            return STOP, h, 0.0, 0.0, LAYER_BOTTOMED_OUT if st != 0 else NONFINITE, 1
        return RETRY, h, 0.0, 0.0, OK, 1
    ratio = 0.0
    if adaptive:
        ratio = error_ratio(model, control, z0, new.z, new.err, new.errb, gap0, scratch)
        if trial.smooth > 0.0:           # in the embedded estimate's units (its exponent)
            ratio = max(ratio, trial.smooth ** (SMOOTH_EXPONENT / expo))
        if ratio > 1.0:
            h = h_step * max(0.2, 0.9 * ratio ** -expo)
            if h < control.h_min:
                if gap0[0] > 1.0 - 10.0 * control.bottom_gap:
                    failed_at(diag, t, float(FAIL_BOTTOMED))
                    return STOP, h, ratio, 0.0, LAYER_BOTTOMED_OUT, 1
                failed_at(diag, t, float(FAIL_STEP_UNDERFLOW))
                return STOP, h, ratio, 0.0, STEP_LIMIT, 1
            return RETRY, h, ratio, 0.0, OK, 1
    e_new, resid_new = _residual(model, new.z, new.delta, new.acc, jm5, w_new, e0)
    if not abs(resid_new - resid) <= energy_allowance(new.delta, jm5, e_new, w_new, e0, work, model.basis):
        diag[D_ENERGY_JUMPS] += 1.0
        h = 0.25 * h_step
        if not adaptive or h < control.h_min:
            failed_at(diag, t, float(FAIL_ENERGY_JUMP))
            return STOP, h, ratio, resid_new, ENERGY_VIOLATION, 1
        return RETRY, h, ratio, resid_new, OK, 1
    return ACCEPT, h_step, ratio, resid_new, OK, 0


@kernel(inline="llvm", nrt=True)
def _cut_step(model, cut, t, new, e0, rows):
    """An accepted step cut at an event (an EventCut, solver.ending): its length, end time, force,
    jmax and work there, its dense output's rows (the sub-step's) and the energy residual there."""
    return cut.s, t + cut.s, cut.F, cut.jmax, cut.W, rows, _residual(model, new.z, new.delta, new.acc, cut.jmax,
                                                                     cut.W, e0)[1]


@kernel(inline="llvm")
def _strain_error(model, err):
    """The local error of a step in strain amplitude (the error of a and of a' / omega)."""
    plate = model.plate
    e_step = 0.0
    if plate_damped(plate):
        for n in range(err.shape[0]):
            ea = mode_a(err[n], n, plate)
            ev = mode_adot(err[n], ea, n, plate) / plate.modes[OMEGA, n]
            e_step += plate.modes[STRAIN, n] ** 2 * (ea * ea + ev * ev)
    else:
        for n in range(err.shape[0]):
            e_step += (plate.modes[STRAIN, n] / plate.modes[OMEGA, n]) ** 2 * (err[n].real ** 2 + err[n].imag ** 2)
    return math.sqrt(e_step)


@kernel(inline="llvm")
def _locate_levels(ws, levels, out, start, carried, t, h):
    """Tension levels first reached in the accepted step, located on true sub-steps (for
    verification): their time and place into out.level_t, out.level_x. (Runs only where levels
    are asked for: the loop binds the Workspace here and nowhere else in a step.)"""
    for s in range(2):
        rm = ws.tension.marks[RUN_MAX + s]
        for i in range(levels.shape[0]):
            if math.isnan(out.level_t[s, i]) and levels[i] <= rm:
                lo, hi, _, _, _, found = locate_event(ws.stepper, 1.0 - 2.0 * s, levels[i], start, carried, t, h,
                                                      from_start(ws.peaks0[s]), ws.sub, ws.value)
                if found:
                    out.level_t[s, i] = t + 0.5 * (lo + hi)
                    out.level_x[s, i] = ws.value[2]


@kernel(inline="llvm", nrt=True)
def observe_step(model, observers, cur, new, carried, t, h, ends, records, diag):
    """The Observers on the accepted step [t, t + h] from cur to new, at one fixed point, with the
    step's StepEnds. The step's dense states are computed on demand from its Dense
    (tension.dense_due), or were given by an integrator with a dense output of its own (the DOP853
    reference: its Dense empty; a floe's maxima are then not located on it). Returns (contacts at
    t + h, the Records, a free body left the ice)."""
    tw, zw, asked, dz = observers.tension, observers.zone, observers.asked, ends.dense
    jm5 = ends.jmax1
    plate_wide = SurfaceRows(records.upper, records.n_upper, records.lower, records.n_lower)
    contact = Rows(records.contacts, records.n_contacts)
    zone = SurfaceRows(records.zone_upper, records.n_zone_upper, records.zone_lower, records.n_zone_lower)
    if asks(asked, TENSION):
        for s in range(2):
            copy_into(observers.peaks0[s], tw.track[PEAKS + s], 4)
        plate_wide = observe_tensions(model, tw, t, h, StepStrains(cur.eps, new.eps, new.a, new.adot), dz, plate_wide,
                                      diag)
    if asks(asked, CONTACTS):
        contacts, contact, largest = observe_contacts(model, observers.contact, t, h,
                                                      Snapshot(cur.a, cur.adot, cur.delta, cur.yb), ends.jmax,
                                                      Snapshot(new.a, new.adot, new.delta, new.yb), jm5,
                                                      carried.contacts, contact)
        if largest > diag[D_MAX_CONTACTS]:
            diag[D_MAX_CONTACTS] = largest
    else:                                        # the count the next step compares with
        contacts = count_contacts(new.delta, jm5, model.basis.mirror)
    if asks(asked, ZONE):
        zone = observe_zone(model, zw, t, h, ZoneEnds(new.eps, new.delta, new.a, new.adot, jm5,
                                                      tw.track[STEP_BEST:STEP_BEST + 2], cur.yb, new.yb),
                            DenseStates(tw.A, tw.AD, tw.eps, dz, tw.marks, tw.dry), zone, diag)
    if model.basis.kind != 0.0 and h > 0.0 and dz.z0.shape[0] > 0 and asks(asked, FLOE_MAXIMA):
        # a floe: its maxima located at the run's end
        observe_candidates(model, observers.dense, t, h, dz, tw.track[STEP_BEST:STEP_BEST + 2], zw.best,
                           Span(zw.reach[2], zw.reach[3]))
    left = observe_body(model.body, t, h, cur.yb, new.yb, carried.force, ends.force1, contacts, contact, diag)
    return contacts, Records(plate_wide.upper, plate_wide.n_upper, plate_wide.lower, plate_wide.n_lower, contact.rows,
                             contact.n, zone.upper, zone.n_upper, zone.lower, zone.n_lower), left


@kernel
def finish_maxima(model, ws, asked, diag):
    """At the run's end, the maxima located from the candidates kept: the force and compression
    (observe.layer_maxima), a floe's tension maxima (observe.dense_maxima), where asked."""
    if asks(asked, LAYER_MAXIMA):
        finish_layer_maxima(ws.stepper, ws.maxima, ws.sub, ws.value, diag)
    if model.basis.kind != 0.0 and asks(asked, FLOE_MAXIMA):
        finish_dense_maxima(model, ws.dense, diag)


@kernel(nrt=True)
def integrate(method, model, control, t_out, a0, adot0, levels, out):
    """Integrate the mode equations (and a free body's motion) from control.t_start to t_end,
    landing on every t_out (sorted, in [t_start, t_end]); a0, adot0: a_n [m] and a_n' [m s-1] at
    t_start; levels: tension levels to locate exactly on sub-steps (verification; usually
    empty); out: the Outputs to fill. Returns (status, the number of output times filled, the
    Records: the tension records of both surfaces plate-wide and in the impact zone (rows
    R_T..R_JOIN, first n valid) and the contact record (rows (t, count))."""
    N, J, T, diag = a0.shape[0], model.basis.cosq.shape[1], t_out.shape[0], out.diag
    start_diagnostics(diag, control.t_start)
    ws = new_workspace(method, model, N, J, control.zone_margin)
    watch_level(ws.tension, control.break_level)
    # what a step reads of the work space, bound once (numba counts a reference to every array
    # of a tuple each time the tuple is bound to a name: the Workspace holds some sixty)
    step_work, stepper, sub, value, gap0, gap1 = ws.work, ws.stepper, ws.sub, ws.value, ws.gap0, ws.gap1
    observers = Observers(ws.tension, ws.contact, ws.peaks0, ws.zone, ws.dense, control.observers)
    fixed, maxima, crossed, asked, history = ws.fixed, ws.maxima, ws.crossed, control.observers, ws.history
    asks_levels = levels.shape[0] > 0
    cur, new = new_state(N, J), new_state(N, J)
    start_body(model.body, control.t_start, control.body_start, cur.yb, diag)
    coeffs = Coefficients(np.empty((9, N), np.complex128), np.empty((9, 2)))
    t = control.t_start
    st, force, jmax, lp, contacts, records = initial_state(model, ws, cur, t, a0, adot0, new_records(N_REC), diag)
    if st != 0:
        diag[D_T_REACHED] = t
        failed_at(diag, t, float(FAIL_BOTTOMED))
        return LAYER_BOTTOMED_OUT, 0, records
    e0 = _residual(model, cur.z, cur.delta, cur.acc, jmax, 0.0, 0.0)[0]
    arm_breaks(model, ws.armed, cur.eps, cur.a, control.break_level)
    work = diss = err_sum = resid = max_residual = max_body_residual = peak_work = 0.0
    free_body = model.body.inv_mass > 0.0
    body_resid0 = body_residual(model.body, t, cur.yb, work)
    if free_body:
        diag[D_BODY_RESIDUAL] = 0.0
    k, status, steps, rejected, rhs_count = 0, OK, 0, 0, 1
    h, h_coeffs, prev_ratio = min(control.h_init, control.h_max), -1.0, 1.0
    bottomed = separated = done = broke = False
    adaptive = method == ETD34 and control.fixed_step <= 0.0
    while True:
        carried = Carried(force, work, diss, lp, contacts)
        start = Start(cur.z, cur.forcing, cur.yb)      # (three arrays cross into a step, not ten)
        while k < T and t_out[k] <= t:                       # outputs due at the current time
            record_output(model, out, k, t, cur, jmax, carried, err_sum)
            k += 1
        if bottomed or separated or done or broke or t >= control.t_end:
            break
        if steps + rejected >= control.max_steps:
            status = STEP_LIMIT
            failed_at(diag, t, float(FAIL_MAX_STEPS))
            break
        h_step, t_new, landing = next_step(control, t, t_out[k] if k < T else control.t_end, h, fixed)
        if h_step != h_coeffs:
            etd_coefficients(model.plate, h_step, coeffs.C)
            body_coefficients(h_step, coeffs.Cb)
            h_coeffs = h_step
        st, F5, jm5, w_new, event = take_step(method, model, coeffs, step_work, start, carried, t, t_new, h_step,
                                              new)
        rhs_count += 4
        expo = 1.0 / 3.0 if event else 0.25
        smooth = 0.0
        if adaptive and st == 0 and not event:
            smooth = smoothness_ratio(model, control, history, Samples(cur.forcing, step_work.rows[2], new.forcing,
                                                                       step_work.table[G_ROW, 1::2]), h_step, cur.z, new.z)
        verdict, h_try, ratio, resid_new, status, counted = judge_step(adaptive, model, control, cur.z, new, gap0,
                                                                   step_work.rows[0],
                                                                   Trial(st, w_new, jm5, t, h_step, expo, smooth),
                                                                   Energies(e0, resid, work), diag)
        rejected += counted
        if verdict != ACCEPT:
            h = h_try
            if verdict == STOP:
                break
            continue
        # ----- an event ends the run inside the step: the layer bottoming out, or a break
        gap_at(model, t_new, new.z, new.a, new.adot, new.yb, new.delta, jm5, gap1)
        h_eff, reached = h_step, step_work.rows
        cut = ending_event(model, ws, control, start, carried, t, h_step, new, diag)
        if cut.kind != NO_EVENT:              # the state is the search's last sub-step
            bottomed, broke = cut.kind == BOTTOMING, cut.kind == BREAK
            h_eff, t_new, F5, jm5, w_new, reached, resid_new = _cut_step(model, cut, t, new, e0, stepper.work.rows)
        # ----- accepted: observers on [t, t + h_eff], then the states swap
        steps += 1
        if not bottomed:
            err_sum += _strain_error(model, new.err)
            diag[D_H_MIN] = min(diag[D_H_MIN], h_step)
            diag[D_H_MAX] = max(diag[D_H_MAX], h_step)
        dense_due(observers.tension.marks, h_eff)
        contacts, records, left = observe_step(model, observers, cur, new, carried, t, h_eff,
                                               StepEnds(jmax, jm5, F5, Dense(cur.z, cur.forcing, reached[2], new.forcing)),
                                               records, diag)
        if not (bottomed or broke or control.break_level == math.inf):   # a break the peak reached only inside the step
            cut = break_inside_step(model, ws, control, start, carried, t, h_eff, new, diag)
            if cut.kind == BREAK:
                broke = True
                h_eff, t_new, F5, jm5, w_new, reached, resid_new = _cut_step(model, cut, t, new, e0, stepper.work.rows)
        # exact crossings of the levels, for verification: after the observers (the search's
        # sub-steps overwrite the scratch the dense output reads)
        if asks_levels:
            _locate_levels(ws, levels, out, start, carried, t, h_eff)
        if not bottomed and asks(asked, LAYER_MAXIMA):     # the force and compression located (on sub-steps)
            observe_layer_maxima(stepper, maxima, start, carried, t, h_eff, LayerEnds(F5, gap1[0], gap0[0]), sub, value,
                                 diag)
        remember_step(history, cur.forcing, reached[2], step_work.table[G_ROW, 1::2], h_eff, not (event or bottomed))
        separated = left and control.until_separation
        done = answered(control.answer, ws.tension.marks, ws.zone.marks, records, crossed)
        cur, new = new, cur
        copy_into(gap0, gap1, 3)
        t, work, diss, lp, force, jmax, resid = t_new, w_new, cur.acc[0], cur.acc[1], F5, jm5, resid_new
        max_residual = max(max_residual, abs(resid))
        peak_work = max(peak_work, work)
        if free_body:
            max_body_residual = max(max_body_residual, abs(body_residual(model.body, t, cur.yb, work) - body_resid0))
        running_maxima(diag, t, force, gap0)
        if bottomed:
            status = LAYER_BOTTOMED_OUT
            bottomed_at(diag, t, gap0, model.layer.he)
        elif separated:
            status = SEPARATED
        elif done:
            diag[D_ANSWERED_T] = t
        elif adaptive:
            h, prev_ratio = grown_step(control, ratio, expo, prev_ratio, h_step, h, landing)
    if status == OK and not (done or broke) and free_body and control.until_separation and \
            not math.isnan(diag[D_STOP_T]):
        status = STOPPED                     # stopped, and still on the ice at the window's end (not at a break)
    finish_maxima(model, ws, asked, diag)
    final_state(model, t, cur, out.final)
    out.diag[D_DISSIPATED] = diss
    status = finish_diagnostics(diag, status, t, work, Residuals(peak_work, max_residual, max_body_residual, e0), gap0,
                                model.layer.he, Counts(steps, rejected, rhs_count))
    return status, k, records
