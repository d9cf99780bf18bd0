r"""The impact zone's tension maxima (docs/model.md, "Maxima of the impact zone").

The impact zone at time t is the part of the plate within r(t) = c(t) + m of the body's centre
x_c: c(t) the largest distance from x_c that any point in contact (delta > 0) has reached up to
t, m the margin beyond it (Settings.impact_zone_margin, default 1 m). On a walled plate the zone
stops m short of each wall: the wall's tension is the confinement's, and the wall's peak moves
off it and back (the sliding wall is a mirror) within a short distance. The zone only grows.
Its tension maximum is the largest sign * eps over the zone (sign +1: the upper surface's
tension, -1: the lower's), a continuous function of time whose maximum is well posed. Where it
sits at the zone's edge the tension was still rising outward: read it with the plate-wide one.

At the end of every accepted step the contact's extent is read from delta at the nodes (the
outermost contact node plus the zero of the parabola of delta through it and its neighbours),
and the zone's two ends and the local peaks of the nodes in it (refined on the modes by Newton
within their neighbours) compete. Between the ends of a step that resolves every mode
(omega_N h <= 0.4) the maximum is the cubic Hermite of its values and rates (eps_t, the
envelope theorem at a peak, the rate at an end that did not move) when both ends hold the same
peak or end; otherwise the larger end (a Hermite across modes that oscillate within the step
overshoots: 5e-3 on a 0.5 m floe). Where the plate-wide maximum of the step (the tension
observer's, sampled inside the step on the dense output) lies in the zone, it is the zone's
maximum too (the zone at the step's end). Each surface's largest
value, its place and time go to the diagnostics (D_ZONE_*; -inf for an empty zone), and whether
it sits at the zone's edge (D_ZONE_*_EDGE), with the contact's largest extent c
(D_CONTACT_EXTENT).

Benchmark (tests/test_impact_zone.py): with a margin that covers a floe the zone's maxima are
the plate-wide ones; the contact's extent on rigid ice is the body's geometry; against
DOP853, which samples the zone on its own dense output; mirroring an off-centre body mirrors
the zone's maxima.
"""
import math
from collections import namedtuple

import numpy as np

from ..cubic import cubic_max, hermite
from ..jit import kernel
from ..layout import D_CONTACT_EXTENT, D_ZONE_UPPER, D_ZONE_UPPER_EDGE, D_ZONE_UPPER_T, D_ZONE_UPPER_X
from ..model.basis import dry_newton_peak, field_sum, newton_peak, node_strain
from ..model.floe import floe_dry, floe_dry_sums
from ..model.plate import OMEGA, STRAIN
from ..step import dense_states
from .tension import DENSE, RESOLVED, RIPPLE

#: the observer's state: peaks (2, 4) each surface's (value, rate, x, node) of the zone's peak at
#: the current time (node -1: an end of the zone); reach (4,) the contact's largest extent c [m] so
#: far, the margin m [m] and the zone's ends [lo, hi] at the last step; best (2, 4) each
#: surface's (max, time, x, at the edge) over the last step (the located maxima read them);
#: dry (2, N) scratch for a floe's dry coefficients
ZoneWork = namedtuple("ZoneWork", "peaks reach best dry")


@kernel
def zone_work(margin, N):
    """A ZoneWork for N modes before the first contact (c = 0) and before the first peak."""
    peaks = np.zeros((2, 4))
    peaks[:, 0] = -np.inf
    peaks[:, 3] = -1.0
    return ZoneWork(peaks, np.array([0.0, margin, -1.0, -1.0]), np.full((2, 4), -np.inf), np.empty((2, N)))


@kernel
def _to_zero(d_in, d0, d_out):
    """Where, in node spacings beyond a node with delta = d0 > 0, delta reaches 0 before the
    outer neighbour (d_out <= 0): the root of the parabola through the inner neighbour, the node
    and the outer one (exact for a parabolic delta), else of the line to the outer one."""
    lin = d0 / (d0 - d_out)
    b = 0.5 * (d_out - d_in)
    a = 0.5 * (d_out - 2.0 * d0 + d_in)
    if a == 0.0:
        return lin
    disc = b * b - 4.0 * a * d0
    if disc < 0.0:
        return lin
    q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
    for r in (q / a, d0 / q if q != 0.0 else -1.0):
        if 0.0 <= r <= 1.0:
            return r
    return lin


@kernel
def contact_extent(delta, jmax, dx, xc):
    """The largest distance from xc of a point with delta > 0 (-1: none), from the nodes j <
    jmax (where delta is computed): the outermost contact nodes, moved to delta's zero between
    them and their outer neighbour (_to_zero)."""
    far = -1.0
    for j in range(jmax):
        d = delta[j]
        if not d > 0.0:
            continue
        x = j * dx
        if x >= xc and j + 1 < jmax and delta[j + 1] <= 0.0:
            x += dx * _to_zero(delta[j - 1] if j > 0 else delta[j + 1], d, delta[j + 1])
        elif x < xc and j > 0 and delta[j - 1] <= 0.0:
            x -= dx * _to_zero(delta[j + 1], d, delta[j - 1])
        far = max(far, abs(x - xc))
    return far


@kernel
def zone_peak(eps, sign, basis, strain, a, lo, hi):
    """The largest sign * eps over continuous x in the zone [lo, hi] (kernel coordinates, inside
    the plate): the zone's two ends, and each local peak of the nodes refined on the modes within
    its two neighbours. Returns (value, x, node; the node -1: an end of the zone inside the
    plate), value -inf for an empty zone."""
    dx, J, field = basis.dx, eps.shape[0], (strain, 1)
    lam1, floe = basis.lam1, basis.floe
    bv, bx, bj = -np.inf, lo, -1
    if not lo <= hi:
        return bv, bx, bj
    length = dx * (J - 1)
    for x in (lo, hi):
        v = sign * field_sum(lam1, floe, field, a, x)
        if v > bv:                                  # an end on the plate's end (the symmetry line of
            bv, bx = v, x                           # the half plate, a free edge) is not the zone's edge
            bj = -1 if 0.0 < x < length else (0 if x <= 0.0 else J - 1)
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
def _zone_inside(model, sign, t0, h, zone, inside, ends, best):
    """A floe's zone peak at the dense-output states inside the step [t0, t0 + h] (computed from
    the step's Dense unless marks says they are), the Hermite of values and rates between
    consecutive samples on the same peak or end; best = (value, time, x, edge) of the ends,
    returned raised by the samples. zone = (lo, hi) at the step's end; inside = (A, AD, eps
    scratch, Dense, marks, dry (2, N) scratch); ends = the peak at t0 and at t0 + h, each
    (value, rate, x, node). As the ends say, the peak stays at the zone's edge, or on one peak
    followed by Newton, each sample's wet amplitudes turned into dry coefficients once (O(N) a
    point); else the zone is searched afresh at each sample."""
    A, AD, eps, dz, marks, dry = inside
    K = A.shape[0] + 1
    if marks[DENSE] == 0.0:
        dense_states(dz.z0, dz.N1, dz.Nm, dz.N5, model.plate, h, A, AD)
        marks[DENSE] = 1.0
    basis, strain = model.basis, model.plate.modes[STRAIN]
    floe, dx = basis.floe, basis.dx
    lo, hi = zone
    bv, bt, bx, bedge = best
    p0, p1 = ends
    v0, r0, x0, j0 = p0
    edge_both = j0 < 0 and p1[3] < 0
    peak_both = j0 >= 0 and p1[3] >= 0 and abs(p1[2] - x0) <= 3.0 * dx
    hk = h / K
    x = x0
    for k in range(1, K + 1):
        if k < K:
            floe_dry(floe, A[k - 1], dry[0])
            floe_dry(floe, AD[k - 1], dry[1])
            if edge_both:
                x, j = p1[2], -1.0
            elif peak_both:
                x, j = dry_newton_peak(floe, dry[0], x, max(lo, x - 3.0 * dx), min(hi, x + 3.0 * dx), sign, 1), p1[3]
            else:
                node_strain(basis.cosq, floe, strain, A[k - 1], eps)
                v, x, jn = zone_peak(eps, sign, basis, strain, A[k - 1], lo, hi)
                j = float(jn)
            v = sign * floe_dry_sums(floe, dry[0], x, 1)[0]
            r = sign * floe_dry_sums(floe, dry[1], x, 1)[0]
        else:
            v, r, x, j = p1
        if v > bv:
            bv, bt, bx, bedge = v, t0 + k * hk, x, j < 0
        same_peak = j >= 0 and j0 >= 0 and abs(x - x0) <= 3.0 * dx
        if same_peak or (j < 0 and j0 < 0 and x == x0):     # the same peak or end: between them
            c0, c1, c2, c3 = hermite(v0, v, r0, r, hk)
            vmax, th = cubic_max(c0, c1, c2, c3)
            if vmax > bv:
                bv, bt, bx, bedge = vmax, t0 + (k - 1 + th) * hk, x0 + th * (x - x0), not same_peak
        v0, r0, x0, j0 = v, r, x, j
    return bv, bt, bx, bedge


@kernel
def observe_zone(model, zw, t0, h, ends, inside, diag):
    """The zone's peaks of both surfaces at the end of the accepted step [t0, t0 + h] and their
    largest values over it (module docstring); ends = (eps at the nodes, delta, a, a' at t0 + h,
    the jmax below which delta is computed, and each surface's plate-wide (max, time, x) over the
    step, rows 0 and 1 of an array; -inf: none); inside = (A, AD (K - 1, N): the dense-output
    states at t0 + k h / K, computed on demand from the Dense unless the marks (tension.DENSE)
    say they are, an eps scratch (J,), the Dense, the marks), which a floe's zone samples in a
    step that does not resolve its modes (K = 1, no rows: none)."""
    eps1, delta1, a1, adot1, jmax1, plate_best = ends
    A, AD, eps, dz, marks = inside
    basis = model.basis
    xc = model.body.xc
    c = contact_extent(delta1, jmax1, basis.dx, xc)
    if c > zw.reach[0]:
        zw.reach[0] = c
    diag[D_CONTACT_EXTENT] = zw.reach[0]
    r = zw.reach[0] + zw.reach[1]
    lo, hi = max(0.0, xc - r), min(basis.length, xc + r)
    if basis.kind == 0:                             # walls: their own neighbourhood is not the zone's
        hi = min(hi, basis.length - zw.reach[1])
        if basis.mirror == 1.0:
            lo = max(lo, zw.reach[1])
    strain = model.plate.modes[STRAIN]
    omega = model.plate.modes[OMEGA]
    # a step that resolves every mode (as the tension observer's criterion): the Hermite of the
    # ends holds between them; in a longer one the modes oscillate within the step and the
    # Hermite could overshoot, so the ends and the plate-wide samples inside it stand
    resolved = 0.0 < h and omega[omega.shape[0] - 1] * h <= RESOLVED
    for s in range(2):
        sign = 1.0 - 2.0 * s
        v1, x1, j1 = zone_peak(eps1, sign, basis, strain, a1, lo, hi)
        r1 = sign * field_sum(basis.lam1, basis.floe, (strain, 1), adot1, x1)
        p0 = zw.peaks[s]
        best, tb, xb, edge = v1, t0 + h, x1, j1 < 0
        if p0[0] > best and h > 0.0:
            best, tb, xb, edge = p0[0], t0, p0[2], p0[3] < 0
        # the Hermite of the peak's values and rates: both ends on the same peak of the field, or
        # on the same end of a zone that did not move (eps_t is then the rate of either)
        same_end = j1 < 0 and p0[3] < 0 and (x1 == p0[2]) and lo == zw.reach[2] and hi == zw.reach[3]
        same_peak = j1 >= 0 and p0[3] >= 0 and abs(x1 - p0[2]) <= 3.0 * basis.dx
        if resolved and (same_peak or same_end):
            c0, c1, c2, c3 = hermite(p0[0], v1, p0[1], r1, h)
            vmax, th = cubic_max(c0, c1, c2, c3)
            if vmax > best:
                best, tb, xb, edge = vmax, t0 + th * h, p0[2] + th * (x1 - p0[2]), j1 < 0
        # a floe's steps outlast its modes' periods: in a step that does not resolve them and
        # may raise the zone's maximum, the zone on the dense output (walls: their ends)
        zone_max = diag[D_ZONE_UPPER + 3 * s]
        if (basis.kind != 0 and not resolved and h > 0.0 and A.shape[0] > 0
                and not max(p0[0], v1) < zone_max - RIPPLE * abs(zone_max)):
            best, tb, xb, edge = _zone_inside(model, sign, t0, h, (lo, hi), (A, AD, eps, dz, marks, zw.dry),
                                              ((p0[0], p0[1], p0[2], p0[3]), (v1, r1, x1, float(j1))),
                                              (best, tb, xb, edge))
        pb = plate_best[s]
        if pb[0] > best and lo <= pb[2] <= hi:
            best, tb, xb, edge = pb[0], pb[1], pb[2], False
        if not best <= diag[D_ZONE_UPPER + 3 * s]:  # (NaN before the first value)
            diag[D_ZONE_UPPER + 3 * s] = best
            diag[D_ZONE_UPPER_T + 3 * s] = tb
            diag[D_ZONE_UPPER_X + 3 * s] = xb
            diag[D_ZONE_UPPER_EDGE + s] = 1.0 if edge else 0.0
        zw.best[s, 0], zw.best[s, 1], zw.best[s, 2], zw.best[s, 3] = best, tb, xb, 1.0 if edge else 0.0
        p0[0], p0[1], p0[2], p0[3] = v1, r1, x1, j1
    zw.reach[2] = lo
    zw.reach[3] = hi
