r"""The events that end a run inside an accepted step (docs/model.md, "Events"; "The run that
breaks"): the layer bottoming out, and a break, where a surface's tension reaches the run's break
level (solver.breaking). Each is located on true sub-steps of the integrator (observe.events), and
the step is cut there: the loop (solver.loop.integrate) calls :func:`ending_event` once a step
before the observers see it, and, in a run that breaks, :func:`break_inside_step` after them (a
peak the step's end did not show, which only the tension observer's samples inside the step
found), which also arms the surfaces: a surface breaks only once its tension has been below the
level since its stage began (the state carried across a break overshoots next to the new edge).
"""
import math
from collections import namedtuple

from .arrays import copy_into
from .compile.jit import kernel
from .cubic import cubic_max, hermite
from .layout import D_BREAK_SURFACE, D_BREAK_T, D_BREAK_X
from .model.basis import global_peak, node_strain, readable
from .model.body import body_position, body_speed
from .model.contact import gap_peak
from .model.plate import STRAIN, mode_a, mode_adot
from .observe.events import Scan, event_value, from_start, locate_event, value_after
from .observe.tension import PEAKS, STEP_BEST

#: an event that ends the run inside an accepted step: its kind (NO_EVENT, BOTTOMING, BREAK), and
#: the cut step s with the force F, jmax and the work W at its end
EventCut = namedtuple("EventCut", "kind s F jmax W")
NO_EVENT, BOTTOMING, BREAK = 0, 1, 2
#: where a break was located in a step: the cut step s, the force F, jmax and the work W at its end,
#: the place x [kernel coordinates] and the surface (0 upper, 1 lower; -1: none reached the level)
Located = namedtuple("Located", "s F jmax W x surface")


@kernel
def copy_state(source, target):
    """target's arrays = source's (all but eps, which the caller recomputes)."""
    for to, of in ((target.forcing, source.forcing), (target.a, source.a), (target.adot, source.adot),
                   (target.delta, source.delta), (target.yb, source.yb), (target.errb, source.errb),
                   (target.acc, source.acc)):
        copy_into(to, of, of.shape[0])
    for n in range(source.z.shape[0]):
        target.z[n] = source.z[n]
        target.err[n] = source.err[n]


@kernel(inline="llvm")
def gap_at(model, t, z, a, adot, yb, delta, jm, gap):
    """a, a' of a state (its arrays z, a, adot, yb, delta) from its z, and its gap (gap_peak) into
    gap."""
    plate = model.plate
    for n in range(z.shape[0]):
        a[n] = mode_a(z[n], n, plate)
        adot[n] = mode_adot(z[n], a[n], n, plate)
    gap_peak(model, body_position(model.body, t, yb), body_speed(model.body, yb), delta, jm, a, adot, gap)


@kernel(inline="llvm")
def _may_bottom(model, control, gap0, gap1, h):
    """The gap may close to bottom_gap inside the step: at its end, or by the cubic Hermite of the
    largest delta and its rate between the ends."""
    level = 1.0 - control.bottom_gap
    c0, c1, c2, c3 = hermite(gap0[0], gap1[0], gap0[1], gap1[1], h)
    return model.layer.K > 0.0 and (gap1[0] >= level or cubic_max(c0, c1, c2, c3)[0] >= level)


@kernel(inline="llvm", nrt=True)
def _locate_break(ws, level, start, carried, t, h, upper, lower, observed):
    """The first time in the accepted step [t, t + h] at which the tension of a surface that may
    reach the break level in it (upper, lower) does, located on true sub-steps as the levels are
    (from each surface's peak at t, ws.peaks0; a surface not yet armed, ws.armed, from the first
    sub-step below the level: locate_event's rearm; observed: the tension observer saw the step,
    and the scan takes in the time of its largest tension after its first sample below the
    level, tension.STEP_BEST's fourth entry): (s, F, jmax, W, place, surface),
    surface -1 where neither did, as a Located; ws.sub then holds the state at t + s (the last
    sub-step below the level)."""
    first, surface = h, -1
    for s in range(2):
        if upper if s == 0 else lower:
            hint = ws.tension.track[STEP_BEST + s, 3] - t if observed else -1.0
            lo, hi, F, jm, w, found = locate_event(ws.stepper, 1.0 - 2.0 * s, level, start, carried, t, h,
                                                   Scan(ws.peaks0[s], ws.armed[s] == 0.0, hint), ws.sub, ws.value)
            if found and (surface < 0 or lo < first):
                first, surface = lo, s
    F, jm, w = 0.0, 0, 0.0
    if surface >= 0:             # the earlier surface's state, again (the other's search may have run last)
        _, F, jm, w = value_after(ws.stepper, 1.0 - 2.0 * surface, level, start, carried, t, first, ws.sub, ws.value)
    return Located(first, F, jm, w, ws.value[2], surface)


@kernel(inline="llvm")
def _peak_reaches(model, eps, a, sign, level):
    """Whether the tension sign * eps, at its peak over the continuous plate, reaches level where
    the tension is read (basis.readable: beyond a crack spacing from the breaks)."""
    v, x, _ = global_peak(eps, sign, model.basis, model.plate.modes[STRAIN], a, True)
    return v >= level and readable(model.basis.floe, x)


@kernel(nrt=True)
def ending_event(model, ws, control, start, carried, t, h, new, diag):
    """An event that ends the run inside the accepted step [t, t + h], before the observers see
    it, located on true sub-steps: the layer bottoming out, else a break where an armed surface's
    peak tension reaches control.break_level at the step's end. Where one is, new holds the state
    at the cut step's end, its strain, and ws.gap1 its gap. Returns an EventCut."""
    level, tw, armed = control.break_level, ws.tension, ws.armed
    if _may_bottom(model, control, ws.gap0, ws.gap1, h):
        s_b, _, F, jm, w, found = locate_event(ws.stepper, 0.0, 1.0 - control.bottom_gap, start, carried, t, h,
                                               from_start(ws.gap0), ws.sub, ws.value)
        if found:                    # (where the interpolant's crossing was not real, the step stays)
            copy_into(ws.gap1, ws.value, 3)
            copy_state(ws.sub, new)
            node_strain(model.basis.cosq, model.basis.floe, model.plate.modes[STRAIN], new.a, new.eps)
            return EventCut(BOTTOMING, s_b, F, jm, w)
    if level == math.inf:
        return EventCut(NO_EVENT, h, 0.0, 0, 0.0)
    upper = armed[0] > 0.0 and _peak_reaches(model, new.eps, new.a, 1.0, level)
    lower = armed[1] > 0.0 and _peak_reaches(model, new.eps, new.a, -1.0, level)
    for s in range(2):
        copy_into(ws.peaks0[s], tw.track[PEAKS + s], 4)
    return _cut_at_break(model, ws, _locate_break(ws, level, start, carried, t, h, upper, lower, False), t, h,
                         new, diag)


@kernel(nrt=True)
def break_inside_step(model, ws, control, start, carried, t, h, new, diag):
    """After the observers saw the accepted step [t, t + h] (the run breaks, control.break_level
    finite, and no event cut it): a break an armed surface's peak tension reached only inside the
    step (the tension observer's largest over it), or a surface not yet armed whose peak fell
    below the level at one of the observer's samples inside the step and may reach it again,
    located on true sub-steps (the adapter then drops the tension records' rows past it); else
    each surface is armed once its peak at the step's end is below the level. Returns an
    EventCut."""
    level, tw, armed = control.break_level, ws.tension, ws.armed
    floe = model.basis.floe
    upper = tw.track[STEP_BEST, 0] >= level and (armed[0] > 0.0 or tw.track[STEP_BEST, 3] >= 0.0) and \
        readable(floe, tw.track[STEP_BEST, 2])
    lower = tw.track[STEP_BEST + 1, 0] >= level and (armed[1] > 0.0 or tw.track[STEP_BEST + 1, 3] >= 0.0) and \
        readable(floe, tw.track[STEP_BEST + 1, 2])
    cut = _cut_at_break(model, ws, _locate_break(ws, level, start, carried, t, h, upper, lower, True), t, h, new,
                        diag)
    if cut.kind == NO_EVENT:
        arm_breaks(model, armed, new.eps, new.a, level)
    return cut


@kernel(inline="llvm", nrt=True)
def _cut_at_break(model, ws, located, t, h, new, diag):
    """The step cut where a break was located (a Located; NO_EVENT where none was): new the state
    there (ws.sub), its strain and ws.gap1 its gap, the break's time, place and surface in diag.
    Returns an EventCut."""
    if located.surface < 0:
        return EventCut(NO_EVENT, h, 0.0, 0, 0.0)
    copy_state(ws.sub, new)
    node_strain(model.basis.cosq, model.basis.floe, model.plate.modes[STRAIN], new.a, new.eps)
    gap_at(model, t + located.s, new.z, new.a, new.adot, new.yb, new.delta, located.jmax, ws.gap1)
    diag[D_BREAK_T], diag[D_BREAK_X], diag[D_BREAK_SURFACE] = t + located.s, located.x, float(located.surface)
    return EventCut(BREAK, located.s, located.F, located.jmax, located.W)


@kernel(nrt=True)
def break_value(model, sign, t, state, out):
    """A break's event value at a state: the peak of sign * eps over the continuous plate, out[:]
    = (value, rate, x) (observe.events.event_value: what _locate_break locates, for the DOP853
    reference's own search on its dense output)."""
    return event_value(model, sign, t, 0, state, out)


@kernel(inline="llvm")
def arm_breaks(model, armed, eps, a, level):
    """A surface is armed to break (armed[s] 1, from 0 in a new workspace) once its peak tension
    is below the break level: the state carried across a break overshoots next to the new free
    edge (solver.breaking)."""
    for s in range(2):
        if not _peak_reaches(model, eps, a, 1.0 - 2.0 * s, level):
            armed[s] = 1.0
