r"""Events located on true sub-steps of the integrator (docs/model.md, "Events"): bottoming, the
first time the gap closes to bottom_gap of the layer's thickness anywhere on the continuous
plate, and (for verification) the first time the peak tension reaches a level. The run ends on
a state the integrator computed, with delta < 1 everywhere.

Benchmark (tests/test_events.py): the bottoming time converges with the tolerance and agrees
with DOP853's (test_bottoming_time_agrees_with_dop853); bottomed-out data never reaches delta = 1.
"""
import math
from collections import namedtuple

import numpy as np

from ..compile.jit import kernel
from ..model.basis import global_peak, node_strain
from ..model.body import body_position, body_speed
from ..model.contact import gap_peak
from ..model.plate import STRAIN
from ..step import substep

#: an event is bracketed by scanning its step at SCAN sub-steps, so the first crossing is found
SCAN = 8
#: where locate_event's scan starts and what it looks at: p0 the (value, rate) at the step's
#: start; rearm: a value that starts at or above the level reaches it only after the scan found
#: it below (a surface that breaks once its tension fell below the break level,
#: solver.ending.arm_breaks); hint: a sub-step in (0, h) where the value is largest (an
#: observer's sample, scanned in its turn: a crossing shorter than the scan's spacing is found
#: there), or -1
Scan = namedtuple("Scan", "p0 rearm hint")


@kernel(inline="always")
def from_start(p0):
    """The Scan of a value that counts as soon as it reaches the level, with no hint: p0 its
    (value, rate) at the step's start."""
    return Scan(p0, False, -1.0)


@kernel(nrt=True)
def event_value(model, kind, t, jm, state, out):
    """The quantity an event is defined on, at a state: kind 0, the largest delta on the plate
    (gap_peak); kind +1 / -1, the peak of +eps / -eps over x. out[:] = (value, rate, x). (kind
    is a float: numba would compile a copy of the search for each literal integer.)"""
    if kind == 0:
        gap_peak(model, body_position(model.body, t, state.yb), body_speed(model.body, state.yb), state.delta,
                 jm, state.a, state.adot, out)
        return out[0]
    sign = float(kind)
    node_strain(model.basis.cosq, model.basis.floe, model.plate.modes[STRAIN], state.a, state.eps)
    v, x, j = global_peak(state.eps, sign, model.basis, model.plate.modes[STRAIN], state.a, True)
    out[0] = v
    out[2] = x
    return v


@kernel
def value_after(stepper, kind, level, start, carried, t, s, out, value):
    """A sub-step of length s and the event's value minus level there (inf where a stage failed:
    past the level). Returns (f, F, jmax, W)."""
    st, F, jm, w, ev = substep(stepper, start, carried, t, s, out)
    if st != 0:
        return np.inf, F, jm, w
    return event_value(stepper.model, kind, t + s, jm, out, value) - level, F, jm, w


@kernel
def locate_event(stepper, kind, level, start, carried, t, h, scan, out, value):
    """First time in the accepted step [t, t + h] at which event_value(kind) reaches level,
    found on true sub-steps of the integrator from (t, start): Illinois regula falsi, bisection
    where a sub-step fails (a stage with delta >= 1 counts as past the level). The step is
    scanned at SCAN points first, from scan.p0, the (value, rate) at t (a Scan; unless
    scan.rearm, the first scan point at or above the level brackets the event).

    On return out holds the state at t + s_lo, the last sub-step still below the level (so a
    located bottoming ends on a state with delta < 1 everywhere), value its event value.
    Returns (s_lo, s_hi, F, jmax, W, found).
    """
    # the first crossing: scan the step forward on sub-steps to the first point past the level
    # (the value may cross the level more than once within a step, as two peaks take turns)
    lo, f_lo, rearm, hint = 0.0, scan.p0[0] - level, scan.rearm, scan.hint
    hi, f_hi = -1.0, 0.0
    k, hinted = 1, not 0.0 < hint < h
    while k <= SCAN:
        sk = h * k / SCAN
        if not hinted and hint < sk:
            sk, hinted = hint, True
        else:
            k += 1
        f, F, jm, w = value_after(stepper, kind, level, start, carried, t, sk, out, value)
        if f >= 0.0 and not (rearm and f_lo >= 0.0):
            hi, f_hi = sk, f
            break
        lo, f_lo = sk, f
    if hi < 0.0:
        return 0.0, 0.0, 0.0, 0, 0.0, False
    s = 0.5 * (lo + hi)
    side = 0
    for _ in range(100):
        f, F, jm, w = value_after(stepper, kind, level, start, carried, t, s, out, value)
        if f >= 0.0:
            hi, f_hi = s, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            lo, f_lo = s, f
            if side == -1 and math.isfinite(f_hi):
                f_hi *= 0.5
            side = -1
        if hi - lo <= 1e-13 * (t + hi):
            break
        if math.isfinite(f_hi) and f_hi > f_lo:
            s = lo + (hi - lo) * (-f_lo) / (f_hi - f_lo)
        else:
            s = 0.5 * (lo + hi)
        if not (lo < s < hi):
            s = 0.5 * (lo + hi)
    st, F, jm, w, ev = substep(stepper, start, carried, t, lo, out)
    event_value(stepper.model, kind, t + lo, jm, out, value)
    return lo, hi, F, jm, w, True
