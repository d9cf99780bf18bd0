r"""A floe's tension maxima located in time on the dense output (docs/model.md, "Maxima of the
impact zone").

On a floe the steps outlast the highest modes' periods by far (omega_N h ~ 10-100: the floe's
heave sets the step), so the tension observer and the impact zone's sample each such step at
TENSION_SAMPLES points of its exponential dense output and join the samples by the cubic
Hermite of their values and rates. That is good to ~1e-5 of the largest strain where the
modes oscillate between samples. The run's maxima (the plate-wide `max_strain`, its lower
surface, and the impact zone's two) are then located exactly:

1. Every accepted step whose sampled maximum of quantity q ranks among the SLOTS largest so far
   is kept as a candidate: its dense output's inputs (z at its start; the forcing at its start,
   mid stage and end), and the estimate's time and place, the zone's ends and whether the
   estimate sat at the zone's edge.
2. At the run's end each candidate's maximum is found on its dense output (solver.step.
   dense_state_at, exact for the step's quadratic forcing, as the samples): golden section in
   time over one sample spacing either side of the estimate, the value at each time the peak
   followed by Newton from the estimate's place (O(N) an iteration on the floe's dry
   coefficients), or the value at the zone's edge.
3. The largest located value replaces the run's maximum of q, its time and place.

Benchmark (tests/test_floe_gauss.py, test_maxima_on_a_floe_agree_with_dop853): on floes of
0.5, 2 and 6 m the four maxima agree with DOP853 at rtol 1e-12 (whose steps resolve the modes)
to 1e-6 and better. Walls are not touched (their steps resolve the modes near the maxima).
"""
from collections import namedtuple

import numpy as np

from ..compile.jit import kernel
from ..layout import D_MAX_UPPER, D_MAX_UPPER_T, D_MAX_UPPER_X, D_ZONE_UPPER, D_ZONE_UPPER_T, D_ZONE_UPPER_X
from ..model.basis import dry_newton_peak
from ..model.floe import floe_dry
from ..model.points import floe_dry_sums
from ..step import dense_state_at
from .tension import TENSION_SAMPLES

#: candidate steps kept per quantity
SLOTS = 2
#: quantities: the plate-wide upper and lower surfaces' tension maxima, the impact zone's
QUANTITIES = 4
#: columns of DenseMaxima.scalars: the estimate, the step's t0 and h, the estimate's time and
#: place, the zone's ends at the step's end, where the estimate sat (0 inside the zone, 1 its
#: upper end, 2 its lower end) and that end's speed
ESTIMATE, T0, H, TB, XB, LO, HI, EDGE, SPEED = range(9)
SCALARS = 9
#: golden-section iterations: the bracket shrinks to 0.618^48 = 1e-10 of two sample spacings
GOLDEN_STEPS = 48
GOLDEN = 0.5 * (5.0 ** 0.5 - 1.0)

#: candidates (QUANTITIES, SLOTS, ...): z0 (N,) complex, forcing (3, N) (N1, Nm, N5), scalars
#: (ESTIMATE..SPEED); a, adot, dry (N,) and values (SCALARS,) scratch
DenseMaxima = namedtuple("DenseMaxima", "z0 forcing scalars a adot dry values")


@kernel(nrt=True)
def dense_maxima_work(N):
    """A DenseMaxima for N modes with no candidates."""
    scalars = np.full((QUANTITIES, SLOTS, SCALARS), np.nan)
    scalars[:, :, ESTIMATE] = -np.inf
    return DenseMaxima(np.zeros((QUANTITIES, SLOTS, N), np.complex128), np.zeros((QUANTITIES, SLOTS, 3, N)),
                       scalars, np.empty(N), np.empty(N), np.empty(N), np.empty(SCALARS))


@kernel
def _store(dm, q, slot, dz, values):
    """A step's dense inputs dz and its scalars values (SCALARS,) into candidate slot of q."""
    for n in range(dz.z0.shape[0]):
        dm.z0[q, slot, n] = dz.z0[n]
        dm.forcing[q, slot, 0, n] = dz.N1[n]
        dm.forcing[q, slot, 1, n] = dz.Nm[n]
        dm.forcing[q, slot, 2, n] = dz.N5[n]
    for i in range(SCALARS):
        dm.scalars[q, slot, i] = values[i]


@kernel
def _shift(dm, q, source, target):
    """Candidate slot source of q into slot target."""
    for n in range(dm.z0.shape[2]):
        dm.z0[q, target, n] = dm.z0[q, source, n]
        for r in range(3):
            dm.forcing[q, target, r, n] = dm.forcing[q, source, r, n]
    for i in range(SCALARS):
        dm.scalars[q, target, i] = dm.scalars[q, source, i]


@kernel
def keep_candidate(dm, q, dz, values):
    """The step of dense inputs dz and scalars values = (estimate, t0, h, time, x, lo, hi, edge,
    speed) as a candidate of q where its estimate ranks among the SLOTS largest."""
    e = values[ESTIMATE]
    if not e > dm.scalars[q, SLOTS - 1, ESTIMATE]:
        return
    slot = SLOTS - 1
    while slot > 0 and e > dm.scalars[q, slot - 1, ESTIMATE]:
        _shift(dm, q, slot - 1, slot)
        slot -= 1
    _store(dm, q, slot, dz, values)


@kernel
def observe_candidates(model, dm, t0, h, dz, plate_best, zone_best, zone):
    """A floe's accepted step [t0, t0 + h] as a candidate of each quantity: plate_best (2, 3)
    each surface's plate-wide (max, time, x) over it, zone_best (2, 5) the zone's (max, time, x,
    edge, speed), zone its Span at the step's end."""
    lo, hi = zone.lo, zone.hi
    values = dm.values
    for q in range(QUANTITIES):
        s = q % 2
        if q < 2:
            e, tb, xb, edge, ql, qh = plate_best[s, 0], plate_best[s, 1], plate_best[s, 2], 0.0, 0.0, model.basis.length
        else:
            e, tb, xb, edge, ql, qh = zone_best[s, 0], zone_best[s, 1], zone_best[s, 2], zone_best[s, 3], lo, hi
        values[0], values[1], values[2], values[3] = e, t0, h, tb
        values[4], values[5], values[6], values[7] = xb, ql, qh, edge
        values[8] = 0.0 if q < 2 else zone_best[s, 4]
        keep_candidate(dm, q, dz, values)


@kernel
def _value_at(model, dm, q, slot, s):
    """sign * the upper-surface strain's peak of candidate slot of q at t0 + s: (value, x)."""
    sc = dm.scalars[q, slot]
    floe, dx = model.basis.floe, model.basis.dx
    sign = 1.0 - 2.0 * (q % 2)
    f = dm.forcing[q, slot]
    dense_state_at(dm.z0[q, slot], f[0], f[1], f[2], model.plate, sc[H], s, dm.a, dm.adot)
    floe_dry(floe, dm.a, dm.dry)
    x = sc[XB]
    if sc[EDGE] == 0.0:
        x = dry_newton_peak(floe, dm.dry, x, max(sc[LO], x - 3.0 * dx), min(sc[HI], x + 3.0 * dx), sign, 1)
    else:                                # an end of the zone, moving at its speed then (the zone
        x += sc[SPEED] * (s - (sc[TB] - sc[T0]))    # at the step's end bounds it)
        x = min(x, sc[HI]) if sc[EDGE] == 1.0 else max(x, sc[LO])
    return sign * floe_dry_sums(floe, dm.dry, x, 1)[0], x


@kernel
def _locate(model, dm, q, slot):
    """The maximum of candidate slot of q over one sample spacing either side of its estimate
    (golden section): (value, time, x)."""
    sc = dm.scalars[q, slot]
    h = sc[H]
    w = h / TENSION_SAMPLES
    a = max(0.0, sc[TB] - sc[T0] - w)
    b = min(h, sc[TB] - sc[T0] + w)
    c = b - GOLDEN * (b - a)
    d = a + GOLDEN * (b - a)
    fc, xc = _value_at(model, dm, q, slot, c)
    fd, xd = _value_at(model, dm, q, slot, d)
    for _ in range(GOLDEN_STEPS):
        if fc >= fd:
            b, d, fd, xd = d, c, fc, xc
            c = b - GOLDEN * (b - a)
            fc, xc = _value_at(model, dm, q, slot, c)
        else:
            a, c, fc, xc = c, d, fd, xd
            d = a + GOLDEN * (b - a)
            fd, xd = _value_at(model, dm, q, slot, d)
    if fc >= fd:
        return fc, sc[T0] + c, xc
    return fd, sc[T0] + d, xd


@kernel
def finish_dense_maxima(model, dm, diag):
    """Each quantity's candidates located (_locate); the largest replaces the run's maximum, its
    time and place (diag). The sampled estimate it replaces is the top candidate's."""
    for q in range(QUANTITIES):
        s = q % 2
        if q < 2:
            slot_v, slot_t, slot_x = D_MAX_UPPER + 3 * s, D_MAX_UPPER_T + 3 * s, D_MAX_UPPER_X + 3 * s
        else:
            slot_v, slot_t, slot_x = D_ZONE_UPPER + 3 * s, D_ZONE_UPPER_T + 3 * s, D_ZONE_UPPER_X + 3 * s
        bv, bt, bx = -np.inf, 0.0, 0.0
        for slot in range(SLOTS):
            if not dm.scalars[q, slot, ESTIMATE] > -np.inf or not dm.scalars[q, slot, H] > 0.0:
                continue
            v, t, x = _locate(model, dm, q, slot)
            if v > bv:
                bv, bt, bx = v, t, x
        if bv > -np.inf and dm.scalars[q, 0, ESTIMATE] == diag[slot_v]:
            diag[slot_v], diag[slot_t], diag[slot_x] = bv, bt, bx
