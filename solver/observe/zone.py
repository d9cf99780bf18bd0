r"""The impact zone's tension maxima and records (docs/model.md, "Maxima of the impact zone",
"Crack onset").

The impact zone at time t is the part of the plate within r(t) = c(t) + m of the body's centre
x_c: c(t) the largest distance from x_c that any point in contact (delta > 0) has reached up to
t, m the margin beyond it (Settings.impact_zone_margin, default 1 m). On a walled plate the zone
stops m short of each wall: the wall's tension is the confinement's, and the wall's peak moves
off it and back (the sliding wall is a mirror) within a short distance. The zone only grows.
Its peak tension is the largest sign * eps over the zone (sign +1: the upper surface's tension,
-1: the lower's), a continuous function of time: its running maximum over time is recorded,
as the plate-wide one is (solver.observe.tension), and gives crack onset in the zone for any
eps_Y; its largest value is the zone's maximum. Where the peak sits at an end of the zone the
tension was still rising outward: read it with the plate-wide one.

At the end of every accepted step the contact's extent is read from delta at the nodes (the
outermost contact node plus the zero of the parabola of delta through it and its neighbours),
and the zone's two ends and the local peaks of the nodes in it (refined on the modes by Newton
within their neighbours) compete. Between the ends of a step that resolves every mode
(omega_N h <= 0.4) the peak is the cubic Hermite of its values and rates when both ends hold
the same peak or end: eps_t at a peak (envelope theorem), eps_t + eps_x r' at an end moving at
r'. In a step that does not resolve the modes (a Hermite across modes that oscillate within
it overshoots: 5e-3 on a 0.5 m floe), or in which the peak changes, and that may raise the
record, the peak is sampled at the dense output's TENSION_SAMPLES - 1 points inside the step,
Hermite between samples; there the contact's extent is evaluated at each sample from delta at
the nodes around its front (zone_track), and where it peaks between samples, at the vertex of
its parabola. A step whose samples or ends rise above the running maximum is stored (rows as
the plate-wide records'). Where the plate-wide maximum of the step (the tension observer's)
lay in the zone, it is the zone's maximum too. Each surface's largest value, its place and
time go to the diagnostics (D_ZONE_*; -inf for an empty zone), and whether it sits at the
zone's edge (D_ZONE_*_EDGE), with the contact's largest extent c (D_CONTACT_EXTENT).

Benchmark (tests/test_impact_zone.py): with a margin that covers a floe the zone's maxima and
crack onsets are the plate-wide ones; the contact's extent on rigid ice is the body's
geometry; against DOP853, which observes the zone at its own dense output's samples; crack
onset in the zone against etd34 at tolerance 1e-12; mirroring an off-centre body mirrors the
zone's maxima.
"""
import math
from collections import namedtuple

import numpy as np

from ..cubic import cubic_max, hermite
from ..compile.jit import kernel
from ..layout import D_CONTACT_EXTENT, D_ZONE_UPPER, D_ZONE_UPPER_EDGE, D_ZONE_UPPER_T, D_ZONE_UPPER_X
from ..model.basis import Field, dry_newton_peak, field_sum, field_sums, newton_peak, node_strain
from ..model.points import floe_dry_sums
from ..model.plate import OMEGA, STRAIN
from .reach import Reach, Span, contact_extent, reach_after_step, zone_ends, zone_track
from .record import SurfaceRows
from .tension import RESOLVED, RIPPLE, TENSION_SAMPLES, append_chain, ensure_dense, fill_dry

#: the observer's state: peaks (2, 5) each surface's (value, rate, x, node, slope) of the zone's
#: peak at the current time (node -1: the zone's upper end, -2 its lower end); reach (7,) the
#: contact's largest extent c [m] so far, the margin m [m], the zone's ends [lo, hi], the
#: contact's extent at the last step's end and at the end before it, and the last step's length
#: where its extent was not sampled inside it (0: it was, or none); best (2, 5) each surface's
#: (max, time, x, edge: 0 inside the zone, 1 its upper end, 2 its lower end; the end's speed) over
#: the last step (the located maxima read them); pair (2, 5) a step's two ends and chain
#: (TENSION_SAMPLES + 1, 5) the peaks sampled inside it, each row (value, rate, x, node, slope:
#: sign * eps_x at an end of the zone); track (TENSION_SAMPLES + 1, 6) the zone at the samples
#: (zone_track); marks (4,): each surface's record's running maximum, then 1 where its last step
#: was stored
ZoneWork = namedtuple("ZoneWork", "peaks reach best pair chain track marks")
#: what the zone's observer reads of a step's end: eps at the nodes, delta, a, a' at t0 + h, the
#: jmax below which delta is computed, each surface's plate-wide (max, time, x) over the step
#: (rows 0 and 1 of an array; -inf: none), the body's deficits yb at t0 and at t0 + h
ZoneEnds = namedtuple("ZoneEnds", "eps1 delta1 a1 adot1 jmax1 plate_best yb0 yb1")
#: a surface's largest zone value over a step: (value, time, x, edge: 0 a peak inside the zone,
#: 1 its upper end, 2 its lower end; speed: the end's)
Best = namedtuple("Best", "value t x edge speed")
#: what _track reads: the step [t0, t0 + h], its Reach, the body's deficits at both ends, the
#: step's DenseStates, the track (TENSION_SAMPLES + 1, 6) it fills
ZoneTrack = namedtuple("ZoneTrack", "model t0 h reach yb0 yb1 inside track")
#: the zone's ends [lo0, hi0] at a step's start and [lo1, hi1] at its end [m]
ZoneMotion = namedtuple("ZoneMotion", "lo0 hi0 lo1 hi1")


@kernel(nrt=True)
def zone_work(margin):
    """A ZoneWork before the first contact (c = 0) and before the first peak."""
    peaks = np.zeros((2, 5))
    peaks[:, 0] = -np.inf
    peaks[:, 3] = -1.0
    marks = np.array([-np.inf, -np.inf, 0.0, 0.0])
    return ZoneWork(peaks, np.array([0.0, margin, -1.0, -1.0, -1.0, -1.0, 0.0]), np.full((2, 5), -np.inf),
                    np.empty((2, 5)), np.empty((TENSION_SAMPLES + 1, 5)), np.empty((TENSION_SAMPLES + 1, 6)), marks)


@kernel
def zone_peak(eps, sign, basis, strain, a, lo, hi):
    """The largest sign * eps over continuous x in the zone [lo, hi] (kernel coordinates, inside
    the plate): the zone's two ends, and each local peak of the nodes refined on the modes within
    its two neighbours. Returns (value, x, node; the node -1: the zone's upper end inside the
    plate, -2: its lower end), value -inf for an empty zone."""
    dx, J, field = basis.dx, eps.shape[0], Field(strain, 1)
    lam1, floe = basis.lam1, basis.floe
    bv, bx, bj = -np.inf, lo, -1
    if not lo <= hi:
        return bv, bx, bj
    length = dx * (J - 1)
    for end, x in ((-2, lo), (-1, hi)):
        v = sign * field_sum(lam1, floe, field, a, x)
        if v > bv:                                  # an end on the plate's end (the symmetry line of
            bv, bx = v, x                           # the half plate, a free edge) is not the zone's edge
            bj = end if 0.0 < x < length else (0 if x <= 0.0 else J - 1)
    j0 = max(0, int(math.ceil(lo / dx - 1e-9)))
    j1 = min(J - 1, int(math.floor(hi / dx + 1e-9)))
    for j in range(j0, j1 + 1):
        v = sign * eps[j]
        if (j > 0 and sign * eps[j - 1] > v) or (j < J - 1 and sign * eps[j + 1] > v):
            continue                                # not a local peak of the nodes
        if v + 0.02 * abs(v) < bv:                  # (a refinement gains ~0.4% at most)
            continue
        cx = newton_peak(j * dx, max(lo, (j - 1) * dx), min(hi, (j + 1) * dx), sign, field, a, lam1, floe)
        cv = sign * field_sum(lam1, floe, field, a, cx)
        if cv > bv:
            bv, bx, bj = cv, cx, j
    return bv, bx, bj


@kernel
def edge_speed(node, zone, h):
    """The speed of the zone's end node (-1: upper, -2: lower) over a step h in which it moved as
    its ZoneMotion says (0: a peak inside the zone, or no step)."""
    if not h > 0.0:
        return 0.0
    if node == -2.0:
        return (zone.lo1 - zone.lo0) / h
    if node == -1.0:
        return (zone.hi1 - zone.hi0) / h
    return 0.0


@kernel(nrt=True)
def _sample_peak(model, sign, inside, k, x, mode, zone):
    """The zone's peak at the dense state k inside a step (inside: the step's DenseStates, their
    dry coefficients computed on a floe-form basis, tension.fill_dry): (value, rate, x, node,
    slope), slope = sign * eps_x at x (for the rate of a moving end). mode 0: at the zone's end x;
    1: the peak near x, followed by Newton within 3 nodes; 2: the zone (a Span) searched afresh
    (node strains, zone_peak). A floe's peak is searched on the dry coefficients; the walls'
    cosines are summed directly."""
    basis, strain = model.basis, model.plate.modes[STRAIN]
    floe, dx, lam1 = basis.floe, basis.dx, basis.lam1
    a, adot, eps = inside.A[k], inside.AD[k], inside.eps
    lo, hi = zone.lo, zone.hi
    j = -1.0
    if mode == 2:
        node_strain(basis.cosq, floe, strain, a, eps)
        v, x, jn = zone_peak(eps, sign, basis, strain, a, lo, hi)
        j = float(jn)
    if basis.kind != 0:
        dry_a, dry_adot = inside.dry[0, k], inside.dry[1, k]
        if mode == 1:
            x = dry_newton_peak(floe, dry_a, x, max(lo, x - 3.0 * dx), min(hi, x + 3.0 * dx), sign, 1)
        v0, v1, _ = floe_dry_sums(floe, dry_a, x, 1)
        return sign * v0, sign * floe_dry_sums(floe, dry_adot, x, 1)[0], x, j, sign * v1
    if mode == 1:
        x = newton_peak(x, max(lo, x - 3.0 * dx), min(hi, x + 3.0 * dx), sign, Field(strain, 1), a, lam1, floe)
    v0, v1, _ = field_sums(lam1, floe, Field(strain, 1), a, x)
    return sign * v0, sign * field_sum(lam1, floe, Field(strain, 1), adot, x), x, j, sign * v1


@kernel
def _zone_samples(model, sign, h, track, inside, p0, p1, samples):
    """The zone's peak at the dense-output states inside the step of length h into samples[k] =
    (value, rate, x, node, slope) at t0 + k h / K, k = 0..K, the ends given: p0, p1 the peaks at
    t0 and t0 + h (rows as samples', their rates at a fixed place); track (K + 1, 4): the zone at
    those times and its ends' speeds (zone_track); inside: the DenseStates, computed (on a
    floe-form basis with their dry coefficients, tension.fill_dry). As the ends say, the peak
    stays at one end of the zone, or on one peak followed by Newton; else the zone is searched afresh at each sample
    (_sample_peak). At an end the rate is d/dt of eps at the moving end: eps_t + eps_x times the
    end's speed."""
    fill_dry(model, inside)
    K = inside.A.shape[0] + 1
    dx = model.basis.dx
    end_both = p0[3] < 0 and p0[3] == p1[3]
    peak_both = p0[3] >= 0 and p1[3] >= 0 and abs(p1[2] - p0[2]) <= 3.0 * dx
    mode = 0 if end_both else (1 if peak_both else 2)
    x = p0[2]
    for c in range(5):
        samples[0, c] = p0[c]
        samples[K, c] = p1[c]
    for k in range(K + 1):
        lo, hi = track[k, 0], track[k, 1]
        if 0 < k < K:
            if end_both:
                x = hi if p1[3] == -1.0 else lo
            v, r, x, jn, slope = _sample_peak(model, sign, inside, k - 1, x, mode, Span(lo, hi))
            samples[k, 0], samples[k, 1], samples[k, 2], samples[k, 4] = v, r, x, slope
            samples[k, 3] = jn if mode == 2 else p1[3]
        j = samples[k, 3]
        if j < 0 and samples[k, 0] > -np.inf:
            samples[k, 1] += samples[k, 4] * (track[k, 3] if j == -1.0 else track[k, 2])


@kernel
def _samples_best(t0, h, dx, samples, best):
    """The Best of the ends, raised by the samples (rows (value, rate, x, node, slope) at
    t0 + k h / K) and by the Hermite of values and rates between consecutive samples on the same
    peak (within 3 nodes) or the same end of the zone (a Hermite across two peaks bounds
    neither); the speed of an end between two samples is their secant's."""
    bv, bt, bx, bedge, bspeed = best.value, best.t, best.x, best.edge, best.speed
    K = samples.shape[0] - 1
    hk = h / K
    v0, r0, x0, j0 = samples[0, 0], samples[0, 1], samples[0, 2], samples[0, 3]
    for k in range(1, K + 1):
        v, r, x, j = samples[k, 0], samples[k, 1], samples[k, 2], samples[k, 3]
        end = j < 0 and j == j0
        if v > bv:
            bv, bt, bx, bedge, bspeed = v, t0 + k * hk, x, max(0.0, -j), (x - x0) / hk if end else 0.0
        same_peak = j >= 0 and j0 >= 0 and abs(x - x0) <= 3.0 * dx
        if same_peak or end:                        # the same peak or end: between them
            c0, c1, c2, c3 = hermite(v0, v, r0, r, hk)
            vmax, th = cubic_max(c0, c1, c2, c3)
            if vmax > bv:
                bv, bt, bx = vmax, t0 + (k - 1 + th) * hk, x0 + th * (x - x0)
                bedge, bspeed = max(0.0, -j), (x - x0) / hk if end else 0.0
        v0, r0, x0, j0 = v, r, x, j
    return Best(bv, bt, bx, bedge, bspeed)


@kernel(nrt=True)
def _store_chain(t0, h, chain, rec, n, marks, s):
    """The zone's running-maximum record of surface s over the step: the chain of peaks (rows
    (value, rate, x, node) at t0 + k h / K, k = 0..K) is stored as consecutive record rows
    (t, value, rate, x, join) when a node or the Hermite between two nodes rises above the
    record's running maximum marks[s]; the first row joins the previous step's last when that
    step was stored (marks[2 + s]). Returns (rec, n)."""
    K = chain.shape[0] - 1
    hk = h / K
    top = chain[0, 0]
    for k in range(K):
        c0, c1, c2, c3 = hermite(chain[k, 0], chain[k + 1, 0], chain[k, 1], chain[k + 1, 1], hk)
        top = max(top, chain[k + 1, 0], cubic_max(c0, c1, c2, c3)[0])
    if not top > marks[s]:
        marks[2 + s] = 0.0
        return rec, n
    rec, n = append_chain(t0, h, chain, rec, n, marks[2 + s] == 1.0)
    marks[s] = top
    marks[2 + s] = 1.0
    return rec, n


@kernel
def _end_peak(model, sign, a, adot, zone, eps, p):
    """The zone's peak at a step's end into p = (value, rate, x, node, slope): zone_peak on the
    node strains eps within the zone's Span, eps_t at the peak (fixed x), and at an end of the
    zone sign * eps_x."""
    basis, strain = model.basis, model.plate.modes[STRAIN]
    v, x, j = zone_peak(eps, sign, basis, strain, a, zone.lo, zone.hi)
    p[0], p[2], p[3] = v, x, float(j)
    p[1] = sign * field_sum(basis.lam1, basis.floe, Field(strain, 1), adot, x)
    p[4] = sign * field_sums(basis.lam1, basis.floe, Field(strain, 1), a, x)[1] if j < 0 and v > -np.inf else 0.0


@kernel
def _moving(p, zone, h, row):
    """row = p with the rate of an end of the zone that moves over the step (its ZoneMotion): +
    eps_x times the end's speed (edge_speed); a peak's as it is."""
    for c in range(5):
        row[c] = p[c]
    if p[3] < 0 and h > 0.0 and p[0] > -np.inf:
        row[1] = p[1] + p[4] * edge_speed(p[3], zone, h)


@kernel
def _track(args, lo, hi):
    """The step's dense states (once a step) and the zone at its samples (zone_track) into
    args.track, its ends kept within [lo, hi]; args: a ZoneTrack."""
    model, h, inside, track = args.model, args.h, args.inside, args.track
    A = inside.A
    ensure_dense(model, h, inside.dense, A, inside.AD, inside.marks)
    zone_track(model, args.t0, h, args.reach, args.yb0, args.yb1, A, inside.eps, track)
    for k in range(A.shape[0] + 2):
        track[k, 0], track[k, 1] = max(track[k, 0], lo), min(track[k, 1], hi)


@kernel
def _with_plate_best(pb, t0, h, zone, found):
    """The step's zone maximum ``found`` (a Best), or the plate-wide one ``pb`` (rows of
    plate_best: value, t, x) where it is larger and was in the zone, its ends moving linearly over
    the step as their ZoneMotion says."""
    if pb[0] > found.value and h > 0.0:
        th = (pb[1] - t0) / h
        if zone.lo0 + th * (zone.lo1 - zone.lo0) <= pb[2] <= zone.hi0 + th * (zone.hi1 - zone.hi0):
            return Best(pb[0], pb[1], pb[2], 0.0, 0.0)
    return found


@kernel
def _report(zw, s, diag, best, tb, xb, edge, speed):
    """Surface s's maximum over the step: into the diagnostics where it raises them (NaN before
    the first value), and kept as the step's best."""
    if not best <= diag[D_ZONE_UPPER + 3 * s]:
        diag[D_ZONE_UPPER + 3 * s] = best
        diag[D_ZONE_UPPER_T + 3 * s] = tb
        diag[D_ZONE_UPPER_X + 3 * s] = xb
        diag[D_ZONE_UPPER_EDGE + s] = 1.0 if edge > 0.0 else 0.0
    zw.best[s, 0], zw.best[s, 1], zw.best[s, 2], zw.best[s, 3], zw.best[s, 4] = best, tb, xb, edge, speed


@kernel
def _shift(p0, p1, fixed_rate):
    """The step's end peak becomes the next step's start, with its rate at a fixed place."""
    for col in range(5):
        p0[col] = p1[col]
    p0[1] = fixed_rate


@kernel(nrt=True)
def observe_zone(model, zw, t0, h, ends, inside, records, diag):
    """The zone's peaks of both surfaces at the end of the accepted step [t0, t0 + h], their
    largest values over it and their running-maximum records (module docstring); ends: the step
    end's ZoneEnds; inside: the step's DenseStates, computed on demand from its Dense unless the
    marks (tension.DENSE) say they are, at which the zone is sampled in a step that does not
    resolve the modes or in which the peak changes (no rows: none, the ends only); records: the
    zone's tension records, a SurfaceRows (rows as the plate-wide ones, solver.fracture).
    Returns the records."""
    a1, adot1, eps1, plate_best = ends.a1, ends.adot1, ends.eps1, ends.plate_best
    A = inside.A
    rec_up, n_up, rec_lo, n_lo = records.upper, records.n_upper, records.lower, records.n_lower
    basis = model.basis
    reach0 = zw.reach[0]
    c = contact_extent(ends.delta1, ends.jmax1, basis.dx, model.body.xc)
    track = ZoneTrack(model, t0, h, Reach(reach0, zw.reach[4], c, zw.reach[1]), ends.yb0, ends.yb1, inside, zw.track)
    omega = model.plate.modes[OMEGA]
    # a step that resolves every mode (as the tension observer's criterion): the Hermite of the
    # ends holds between them; in a longer one the modes oscillate within the step and the
    # Hermite could overshoot, so the zone is sampled on the dense output inside it, and the
    # contact's reach too (its peaks between samples located: zone_track)
    resolved = 0.0 < h and omega[omega.shape[0] - 1] * h <= RESOLVED
    K = A.shape[0] + 1
    # (only while the contact's front is near its reach: a receded one cannot raise it)
    tracked = h > 0.0 and K > 1 and not resolved and max(c, zw.reach[4]) >= reach0 - 2.0 * basis.dx
    if tracked:
        _track(track, -basis.length, 2.0 * basis.length)        # (unbounded: the zone may grow)
    reach_after_step(zw.reach, zw.track[K, 5] if tracked else -1.0, c, h, basis.dx)
    diag[D_CONTACT_EXTENT] = zw.reach[0]
    lo, hi = zone_ends(model, zw.reach[0], zw.reach[1])
    if not lo < hi:         # no zone (walls whose margins cover the plate): nothing in it, its values NaN
        zw.reach[2], zw.reach[3], zw.reach[4] = lo, hi, c
        return SurfaceRows(rec_up, n_up, rec_lo, n_lo)
    zone = ZoneMotion(zw.reach[2] if h > 0.0 else lo, zw.reach[3] if h > 0.0 else hi, lo, hi)
    for s in range(2):
        sign = 1.0 - 2.0 * s
        p0, p1 = zw.peaks[s], zw.pair[1]
        _end_peak(model, sign, a1, adot1, Span(lo, hi), eps1, p1)
        fixed_rate = p1[1]                          # (at a fixed place: the next step adds its motion)
        _moving(p0, zone, h, zw.pair[0])
        _moving(p1, zone, h, p1)
        best, tb, xb, edge, speed = p1[0], t0 + h, p1[2], max(0.0, -p1[3]), edge_speed(p1[3], zone, h)
        if p0[0] > best and h > 0.0:
            best, tb, xb, edge, speed = p0[0], t0, p0[2], max(0.0, -p0[3]), edge_speed(p0[3], zone, h)
        # the Hermite of the peak's values and rates: both ends on the same peak of the field, or
        # on the same end of the zone (its rate with the end's motion)
        same_end = p1[3] < 0 and p0[3] == p1[3]
        same_peak = p1[3] >= 0 and p0[3] >= 0 and abs(p1[2] - p0[2]) <= 3.0 * basis.dx
        chain = zw.pair                             # the ends, unless the zone is sampled between
        if resolved and (same_peak or same_end):
            c0, c1, c2, c3 = hermite(p0[0], p1[0], zw.pair[0, 1], p1[1], h)
            vmax, th = cubic_max(c0, c1, c2, c3)
            if vmax > best:
                best, tb, xb = vmax, t0 + th * h, p0[2] + th * (p1[2] - p0[2])
                edge, speed = max(0.0, -p1[3]), edge_speed(p1[3], zone, h)
        elif h > 0.0 and K > 1 and not max(p0[0], p1[0]) < zw.marks[s] - RIPPLE * abs(zw.marks[s]):
            # a step that does not resolve the modes (a floe's outlast their periods), or in which
            # the peak changes, and that may raise the record: the zone on the dense output
            if not tracked:                         # the zone at the samples, once a step (within
                _track(track, lo, hi)               # the zone at the step's end, already used)
                tracked = True
            chain = zw.chain[:K + 1]
            p1[1] = fixed_rate
            _zone_samples(model, sign, h, zw.track[:K + 1], inside, p0, p1, chain)
            best, tb, xb, edge, speed = _samples_best(t0, h, basis.dx, chain, Best(best, tb, xb, edge, speed))
        if h > 0.0:
            if s == 0:
                rec_up, n_up = _store_chain(t0, h, chain, rec_up, n_up, zw.marks, s)
            else:
                rec_lo, n_lo = _store_chain(t0, h, chain, rec_lo, n_lo, zw.marks, s)
        best, tb, xb, edge, speed = _with_plate_best(plate_best[s], t0, h, zone, Best(best, tb, xb, edge, speed))
        _report(zw, s, diag, best, tb, xb, edge, speed)
        _shift(p0, p1, fixed_rate)
    zw.reach[2], zw.reach[3], zw.reach[4] = lo, hi, c
    return SurfaceRows(rec_up, n_up, rec_lo, n_lo)
