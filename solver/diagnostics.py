r"""What a run reports: the rows at the output times, and the diagnostics vector from its start to
its summary at the end (layout D_*, S_*; their names and units are solver.outputs.DIAGNOSTICS).

The energy identity E_plate + E_layer + D - W = E(t_start) is tracked step by step by the loop; a
run that ended well but whose residual ends above ENERGY_BOUND of the largest work is reported
energy_violation here, never ok (docs/model.md, "Statuses").
"""
import math
from collections import namedtuple

import numpy as np

from .control import ENERGY_BOUND
from .compile.jit import kernel
from .layout import (D_BODY_RESIDUAL, D_BOTTOM_SPEED, D_BOTTOM_T, D_BOTTOM_X, D_ENERGY_JUMPS, D_ENERGY_SCALE,
                     D_ENERGY_RESIDUAL, D_FAIL_KIND, D_FAIL_T, D_H_MAX, D_H_MIN, D_MAX_ABS, D_MAX_ABS_T,
                     D_MAX_ABS_X, D_MAX_CONTACTS, D_MAX_DELTA, D_MAX_DELTA_T, D_MAX_FORCE, D_MAX_FORCE_T,
                     D_MAX_LOWER, D_MAX_LOWER_T, D_MAX_LOWER_X, D_MAX_UPPER, D_MAX_UPPER_T, D_MAX_UPPER_X,
                     D_REJECTED, D_RHS, D_STEPS, D_T_REACHED, D_WORK, ENERGY_VIOLATION, FAIL_ENERGY_BOUND,
                     FAIL_LOCATED, FAIL_NONE, LAYER_BOTTOMED_OUT, N_DIAG, OK, S_BODY_POSITION, S_BODY_SPEED,
                     S_CONTACTS, S_DISSIPATED, S_ERR, S_E_LAYER, S_E_PLATE, S_FORCE, S_WORK, SEPARATED, STOPPED)
from .model.body import body_position, body_speed
from .model.contact import count_contacts
from .model.layer import layer_energy
from .model.plate import plus_plate_energy

#: what a run fills (arrays made by the caller): a, adot (T, N) and series (T, N_SERIES) at the
#: output times reached; diag (N_DIAG,); level_t, level_x (2, levels) NaN on entry, the located
#: time and place at which the upper (row 0) and lower (row 1) tension first reaches each level;
#: final (2, N + 1): a and adot at the time reached (the state a restart, or a break, starts from),
#: and in column N the body's penetration s and speed U there
Outputs = namedtuple("Outputs", "a adot series diag level_t level_x final")
#: the records of a run: the tension records of both surfaces, plate-wide and in the impact zone
#: (rows R_T..R_JOIN), and the contact record (rows (t, count)), each with its count of valid rows
Records = namedtuple("Records", "upper n_upper lower n_lower contacts n_contacts zone_upper n_zone_upper "
                                "zone_lower n_zone_lower")
#: what an integrator returns: its status code, the number of output times filled, its Records,
#: and what stopped it ("" where it ran to its end or its own status says why)
Run = namedtuple("Run", "status n_out records failure")
#: the energy identity's largest terms over a run: the work, the energy residual, the body's residual
Residuals = namedtuple("Residuals", "peak_work max_residual max_body_residual start_energy")
#: a run's counts: accepted steps, rejected steps, forcing evaluations
Counts = namedtuple("Counts", "steps rejected rhs")


@kernel
def start_diagnostics(diag, t_start):
    """The diagnostics before the first step: NaN but for the counts and running maxima."""
    for i in range(N_DIAG):
        diag[i] = np.nan
    diag[D_MAX_CONTACTS] = 0.0
    diag[D_MAX_FORCE] = 0.0
    diag[D_MAX_FORCE_T] = t_start
    diag[D_H_MIN] = np.inf
    diag[D_H_MAX] = 0.0
    diag[D_FAIL_KIND] = FAIL_NONE
    diag[D_ENERGY_JUMPS] = 0.0


@kernel
def record_output(model, out, k, t, state, jmax, carried, err_sum):
    """Row k of the outputs: the state at t (an output time the steps have landed on), with the
    carried force, work and dissipated energy and the summed local error err_sum."""
    for n in range(state.z.shape[0]):
        out.a[k, n] = state.a[n]
        out.adot[k, n] = state.adot[n]
    series = out.series
    series[k, S_CONTACTS] = count_contacts(state.delta, jmax, model.basis.mirror)
    series[k, S_FORCE] = carried.force
    series[k, S_E_PLATE] = plus_plate_energy(0.0, model.plate, state.z)
    series[k, S_DISSIPATED] = carried.dissipated
    series[k, S_E_LAYER] = layer_energy(model, state.a, body_position(model.body, t, state.yb), state.delta, jmax)
    series[k, S_WORK] = carried.work
    series[k, S_ERR] = err_sum
    series[k, S_BODY_POSITION] = body_position(model.body, t, state.yb)
    series[k, S_BODY_SPEED] = body_speed(model.body, state.yb)


@kernel
def running_maxima(diag, t, force, gap):
    """The largest force and compression so far, after an accepted step."""
    if force > diag[D_MAX_FORCE]:
        diag[D_MAX_FORCE] = force
        diag[D_MAX_FORCE_T] = t
    if gap[0] > diag[D_MAX_DELTA]:
        diag[D_MAX_DELTA] = gap[0]
        diag[D_MAX_DELTA_T] = t


@kernel
def bottomed_at(diag, t, gap, he):
    """The located bottoming event at t (gap: the largest delta, its rate and place)."""
    diag[D_FAIL_T] = t
    diag[D_FAIL_KIND] = FAIL_LOCATED
    diag[D_BOTTOM_T] = t
    diag[D_BOTTOM_X] = gap[2]
    diag[D_BOTTOM_SPEED] = he * gap[1]
    diag[D_MAX_FORCE] = np.inf      # K f(delta) is unbounded as the gap closes
    diag[D_MAX_FORCE_T] = t


@kernel
def failed_at(diag, t, kind):
    """The run stopped early at t for the reason kind (a FAIL_* code, as a float: numba would
    compile a copy for each literal integer)."""
    diag[D_FAIL_T] = t
    diag[D_FAIL_KIND] = kind


@kernel
def largest_tension(diag):
    """The larger of both surfaces' largest tensions, with its place and time, as max_abs_strain."""
    up, lo = diag[D_MAX_UPPER], diag[D_MAX_LOWER]
    diag[D_MAX_ABS] = max(up, lo)
    diag[D_MAX_ABS_X] = diag[D_MAX_UPPER_X] if up >= lo else diag[D_MAX_LOWER_X]
    diag[D_MAX_ABS_T] = diag[D_MAX_UPPER_T] if up >= lo else diag[D_MAX_LOWER_T]


@kernel
def finish_diagnostics(diag, status, t, work, residuals, gap, he, counts):
    """The run's summary diagnostics at its end; returns the final status. residuals: the run's
    Residuals, reported relative to its largest work (the final work for the paper's body, W only
    grows; the work at the deepest point for a body that rebounds and takes its energy back) plus
    the plate's and the layer's energy at its start (0 for a run from rest; a run restarted from a
    state, a break's next stage, does little work against the energy it holds). counts: the run's
    Counts."""
    max_residual, max_body_residual = residuals.max_residual, residuals.max_body_residual
    peak_work = residuals.peak_work + residuals.start_energy
    diag[D_ENERGY_SCALE] = peak_work
    if status == LAYER_BOTTOMED_OUT and math.isnan(diag[D_BOTTOM_T]):
        diag[D_BOTTOM_T] = t                # not located: the last state the steps reached
        diag[D_BOTTOM_X] = gap[2]
        diag[D_BOTTOM_SPEED] = he * gap[1]
    diag[D_T_REACHED] = t
    diag[D_WORK] = work
    diag[D_ENERGY_RESIDUAL] = max_residual / peak_work if peak_work > 0.0 else 0.0
    if not math.isnan(diag[D_BODY_RESIDUAL]):
        diag[D_BODY_RESIDUAL] = max_body_residual / peak_work if peak_work > 0.0 else 0.0
    ended_well = status == OK or status == LAYER_BOTTOMED_OUT or status == SEPARATED or status == STOPPED
    if ended_well and max(diag[D_ENERGY_RESIDUAL], diag[D_BODY_RESIDUAL] if not math.isnan(
            diag[D_BODY_RESIDUAL]) else 0.0) > ENERGY_BOUND:
        status = ENERGY_VIOLATION
        diag[D_FAIL_T] = t
        diag[D_FAIL_KIND] = FAIL_ENERGY_BOUND
    largest_tension(diag)
    diag[D_STEPS] = counts.steps
    diag[D_REJECTED] = counts.rejected
    diag[D_RHS] = counts.rhs
    return status
