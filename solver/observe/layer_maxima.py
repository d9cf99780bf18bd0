r"""The largest force on the body and the largest compression of the layer, located inside the
steps (docs/model.md, "Maxima of the force and the compression").

Both are sampled at every step's end: the force F(t) the step returns, and the compression
delta_max(t) = max_x delta(x, t) over the continuous plate (solver.model.contact.gap_peak). Where
a step end is a local maximum of these samples, F(t_{n-1}) <= F(t_n) > F(t_{n+1}), the maximum lies
between the neighbours, and it is located there on true sub-steps of the integrator: from the
state at t_{n-1} left of t_n, from the state at t_n right of it (the first kept for one step for
this). The search is successive parabolic interpolation in the bracket (t_{n-1}, t_n, t_{n+1}),
a golden section where the parabola's vertex falls outside it, until the parabola through the
best three points rises less than VALUE_TOLERANCE above the best: the value is then exact to the
integrator's own error, where a step end misses it by about F'' h^2 / 8.

A search costs a few sub-steps, and a force that grows with wiggles has a new local maximum
every few steps. So a candidate waits: its bound is its sample plus twice the rise of the
parabola through its neighbours. It is dropped once the running maximum passes its bound, it is
searched when a later candidate may beat it (the later one then waits), and the last one is
searched at the run's end; the two starting states of the waiting candidate are kept for that.
A run searches once or twice for each quantity.

Benchmark (tests/test_layer_maxima.py): against DOP853, which locates both on its dense output,
and on rigid ice, where the paper's body has F = K (2/3) b(t)^3 / (R he) analytically for the
linear law, at most at the end of the run.
"""
import math
from collections import namedtuple

import numpy as np

from ..arrays import copy_into
from ..compile.jit import kernel
from ..layout import D_MAX_DELTA, D_MAX_DELTA_T, D_MAX_FORCE, D_MAX_FORCE_T
from ..model.body import body_position, body_speed
from ..model.contact import gap_peak
from ..step import Carried, Start, substep

#: the search stops when the parabola through its best three points rises less than this (relative)
#: above the best, or its vertex is closer to the best than TIME_TOLERANCE of the bracket
VALUE_TOLERANCE = 1e-14
TIME_TOLERANCE = 1e-9
#: at most this many sub-steps a search
MAX_EVALUATIONS = 12
GOLDEN = 0.3819660112501051
#: rows of MaximaWork's start arrays: the previous step's start, and each quantity's waiting
#: candidate's two starts (left of its sample, at its sample): LEFT + 2 kind, RIGHT + 2 kind
PREV, LEFT, RIGHT = 0, 1, 2
#: columns of MaximaWork.scalars (a row per start): its time and the carried scalars there
#: (force, work, dissipated energy, layer power, contacts), and the largest delta there
S_T, S_FORCE, S_WORK, S_DISS, S_POWER, S_CONTACTS, S_DELTA = range(7)
#: columns of MaximaWork.waiting (a row per quantity) after the candidate's bracket (a, b, c, fa,
#: fb, fc): its bound, and whether one waits (1) or not (0)
W_BOUND, W_WAITS = 6, 7

#: the observer's state: starts (5 rows: z, forcing, yb, scalars), each quantity's waiting
#: candidate (2, 8), and held (1,): 1 once the previous step's start is kept
MaximaWork = namedtuple("MaximaWork", "z forcing yb scalars waiting held")
#: a kept start: its time, Start and Carried
Kept = namedtuple("Kept", "t start carried")
#: three samples of a quantity at a < b < c, fa <= fb >= fc
Bracket = namedtuple("Bracket", "a b c fa fb fc")
#: what the observer reads of a step's ends: the force and the largest delta at t + h, the
#: largest delta at t
LayerEnds = namedtuple("LayerEnds", "force1 delta1 delta0")


@kernel(nrt=True)
def maxima_work(N):
    """A MaximaWork for N modes, before the first step."""
    return MaximaWork(np.empty((5, N), np.complex128), np.empty((5, N)), np.zeros((5, 2)), np.zeros((5, 7)),
                      np.zeros((2, 8)), np.zeros(1))


@kernel
def _store(mw, row, z, forcing, yb):
    """A state's z, forcing and body into a row of the kept starts."""
    copy_into(mw.forcing[row], forcing, mw.forcing.shape[1])
    copy_into(mw.yb[row], yb, 2)
    for n in range(mw.z.shape[1]):
        mw.z[row, n] = z[n]


@kernel
def _keep(mw, row, t, start, carried, delta):
    """A start (at t, its carried scalars and largest delta) into row."""
    _store(mw, row, start.z, start.forcing, start.yb)
    sc = mw.scalars[row]
    sc[S_T], sc[S_FORCE], sc[S_WORK], sc[S_DISS] = t, carried.force, carried.work, carried.dissipated
    sc[S_POWER], sc[S_CONTACTS], sc[S_DELTA] = carried.power, float(carried.contacts), delta


@kernel
def _copy_row(mw, source, target):
    """Row source of the kept starts into row target."""
    _store(mw, target, mw.z[source], mw.forcing[source], mw.yb[source])
    copy_into(mw.scalars[target], mw.scalars[source], mw.scalars.shape[1])


@kernel(nrt=True)
def _kept(mw, row):
    """The Kept start of a row."""
    sc = mw.scalars[row]
    return Kept(sc[S_T], Start(mw.z[row], mw.forcing[row], mw.yb[row]),
                Carried(sc[S_FORCE], sc[S_WORK], sc[S_DISS], sc[S_POWER], np.int64(sc[S_CONTACTS])))


@kernel
def _value_at(stepper, kind, start, carried, t, s, out, gap):
    """The force (kind 0) or the largest delta (kind 1) after a true sub-step of length s from
    (t, start) into out; -inf where a stage reached delta >= 1."""
    st, F, jm, w, ev = substep(stepper, start, carried, t, s, out)
    if st != 0:
        return -np.inf
    if kind == 0:
        return F
    model = stepper.model
    gap_peak(model, body_position(model.body, t + s, out.yb), body_speed(model.body, out.yb), out.delta, jm,
             out.a, out.adot, gap)
    return gap[0]


@kernel
def _vertex(a, b, c, fa, fb, fc):
    """The vertex of the parabola through (a, fa), (b, fb), (c, fc); NaN if it has none."""
    p = (b - a) * (fb - fc)
    q = (b - c) * (fb - fa)
    den = p - q
    if den == 0.0:
        return math.nan
    return b - 0.5 * ((b - a) * p - (b - c) * q) / den


@kernel
def _lagrange(a, b, c, fa, fb, fc, u):
    """The parabola through (a, fa), (b, fb), (c, fc) at u."""
    return (fa * (u - b) * (u - c) / ((a - b) * (a - c)) + fb * (u - a) * (u - c) / ((b - a) * (b - c))
            + fc * (u - a) * (u - b) / ((c - a) * (c - b)))


@kernel
def _search(stepper, kind, left, right, bracket, out, gap):
    """The maximum of the quantity (kind) in the Bracket, b the boundary between the steps of
    the two Kept starts left and right of b. Returns (value, time)."""
    a, b, c, fa, fb, fc = bracket.a, bracket.b, bracket.c, bracket.fa, bracket.fb, bracket.fc
    t_b = b
    width = c - a
    for _ in range(MAX_EVALUATIONS):
        u = _vertex(a, b, c, fa, fb, fc)
        if a < u < c:
            if _lagrange(a, b, c, fa, fb, fc, u) - fb <= VALUE_TOLERANCE * abs(fb):
                break                               # the parabola's top is fb to the tolerance
        else:
            u = b + GOLDEN * (c - b) if c - b > b - a else b - GOLDEN * (b - a)
        if abs(u - b) < TIME_TOLERANCE * width:
            break
        if u <= t_b:
            fu = _value_at(stepper, kind, left.start, left.carried, left.t, u - left.t, out, gap)
        else:
            fu = _value_at(stepper, kind, right.start, right.carried, t_b, u - t_b, out, gap)
        if fu > fb:
            if u < b:
                c, fc = b, fb
            else:
                a, fa = b, fb
            b, fb = u, fu
        elif u < b:
            a, fa = u, fu
        else:
            c, fc = u, fu
    return fb, b


@kernel(inline="llvm")
def _bound(a, b, c, fa, fb, fc):
    """The most a maximum between a and c can be, from the samples (fa <= fb >= fc): fb plus twice
    the rise of their parabola above fb (for safety); -inf if b is no local maximum."""
    if not (fb >= fa and fb > fc and c > b > a):
        return -np.inf
    u = _vertex(a, b, c, fa, fb, fc)
    if not a < u < c:
        return fb
    return fb + 2.0 * (_lagrange(a, b, c, fa, fb, fc, u) - fb)


@kernel(nrt=True)
def _search_waiting(stepper, mw, kind, out, gap, diag):
    """Search the quantity's waiting candidate, the running maximum into diag; none waits after."""
    w = mw.waiting[kind]
    w[W_WAITS] = 0.0
    slot, slot_t = (D_MAX_FORCE, D_MAX_FORCE_T) if kind == 0 else (D_MAX_DELTA, D_MAX_DELTA_T)
    if not w[W_BOUND] > diag[slot]:
        return
    v, tv = _search(stepper, float(kind), _kept(mw, LEFT + 2 * kind), _kept(mw, RIGHT + 2 * kind),
                    Bracket(w[0], w[1], w[2], w[3], w[4], w[5]), out, gap)
    if v > diag[slot]:
        diag[slot] = v
        diag[slot_t] = tv


@kernel
def observe_layer_maxima(stepper, mw, start, carried, t, h, ends, out, gap, diag):
    """After the accepted step [t, t + h] from start (its carried scalars at t): where t is a
    local maximum of the step-end samples of the force or the largest delta, a candidate for the
    run's maximum between t - h_prev and t + h, which waits or is searched (module docstring).
    ends: the step's LayerEnds. Then the step's start becomes the previous one."""
    F1, d1, d0 = ends.force1, ends.delta1, ends.delta0
    held = mw.held[0] == 1.0 and h > 0.0
    for kind in range(2):
        w = mw.waiting[kind]
        slot = D_MAX_FORCE if kind == 0 else D_MAX_DELTA
        if w[W_WAITS] == 1.0 and not w[W_BOUND] > diag[slot]:
            w[W_WAITS] = 0.0                     # the running maximum passed it
        if not held:
            continue
        pv = mw.scalars[PREV]
        a, c = pv[S_T], t + h
        fa, fb, fc = (pv[S_FORCE], carried.force, F1) if kind == 0 else (pv[S_DELTA], d0, d1)
        bound = _bound(a, t, c, fa, fb, fc)
        if not bound >= diag[slot]:
            continue
        if w[W_WAITS] == 1.0:
            if not bound >= w[4]:
                continue                         # it cannot beat the waiting one
            _search_waiting(stepper, mw, kind, out, gap, diag)
            if not bound >= diag[slot]:
                continue
        _copy_row(mw, PREV, LEFT + 2 * kind)
        _keep(mw, RIGHT + 2 * kind, t, start, carried, d0)
        w[0], w[1], w[2], w[3], w[4], w[5], w[W_BOUND], w[W_WAITS] = a, t, c, fa, fb, fc, bound, 1.0
    _keep(mw, PREV, t, start, carried, d0)
    mw.held[0] = 1.0


@kernel
def finish_layer_maxima(stepper, mw, out, gap, diag):
    """At the run's end: the waiting candidates searched."""
    for kind in range(2):
        if mw.waiting[kind, W_WAITS] == 1.0:
            _search_waiting(stepper, mw, kind, out, gap, diag)
