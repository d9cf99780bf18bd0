r"""Where body and ice touch: bounds on the contact region, the contact intervals, and the gap
(docs/model.md, "Events": contacts and bottoming).

Geometry only, the same for every layer law: the layer is compressed where delta =
(w + s - b(x)) / he > 0 (the body at penetration s, its profile b, the ice at w). The forcing's
passes over the node table stop at a bound ``contact_bound`` proves no node beyond can touch
(its bound on w from the first four modes exactly and the rest by their sum of |a_n|); the
observers' bound over a whole step is ``reach_in_step``. The gap between body and ice is
he (1 - delta), smallest where delta is largest over the continuous plate (``gap_peak``: a
parabola through the nodes refined by Newton on the modes and the body's profile).

Hot kernels take the narrow tuples they read (Body, Basis), not the Model: numba counts the
references of every array a tuple argument holds at each call (docs/architecture.md).

Benchmarks (tests/test_kernel_pieces.py): contact_bound is within a few nodes of the true
contact edge and never inside it; reach_in_step bounds every node that changes sign within a
step; the contact observer on the bounded nodes equals the observer on every node.
"""
import numpy as np

from .basis import (NEWTON_STOP, Field, newton_move, argmax_node, continuous_peak, field_sum, load_dry,
                    modal_sum_range, point_sums, refine)
from .body import body_corners, body_extent, body_profile, body_slope_curvature, is_parabola
from ..compile.jit import kernel
from .floe import BREAK_COUNT, FIRST_BREAK, floe_header
from .plate import ONES

#: modes taken exactly in contact_bound's node-by-node bound on the deflection
BOUND_MODES = 4


@kernel
def contact_bound(body, basis, s, a, work):
    """jmax such that no node j >= jmax - 1 touches: delta_j < 0 there.

    Two bounds on the deflection w = sum_n a_n cos(lambda_n x). The coarse one, w <= sum |a_n|,
    limits contact to the nodes j < jc with b(x) <= s + sum |a_n|. On those, each node's own
        w_j <= sum_{n < 4} a_n cos(lambda_n x_j) + sum_{n >= 4} |a_n|
    (last_reachable): scanning from the last node down, the first where b(x_j) - s is within
    it is the last that can touch, j*, and jmax = j* + 2 (the pair (j*, j* + 1) is where the
    layer's split subinterval can lie). The amplitudes fall fast with n, so j* is close to the
    true contact edge: on the reference case jmax is 3.5 nodes beyond it on average, where
    the coarse bound left 295, and the forcing's passes over the table shrink with it. A
    relative 1e-9 of sum |a_n| is added to the bound against rounding. work (J,) is scratch
    (the caller's delta, which the forcing overwrites below jmax); J = work.shape[0].
    """
    J = work.shape[0]
    N = a.shape[0]
    m = min(BOUND_MODES, N)
    head = 0.0
    tail = 0.0
    for n in range(N):
        if n < m:
            head += abs(a[n])
        else:
            tail += abs(a[n])
    reach = s + head + tail
    if reach <= 0.0:
        return 1
    jc = min(J, int(body_extent(reach, body) / basis.dx) + 2)
    j = last_reachable(body.profile, basis.cosq, a, m, s + tail + 1e-9 * (head + tail), work, 0, jc)
    return min(J, edges_reachable(body, basis, reach + 1e-9 * (head + tail), j) + 2)


@kernel(nrt=True)
def edges_reachable(body, basis, reach, j):
    """j raised so that jmax = j + 2 takes in each break of a broken plate that the coarse bound
    lets touch (b(x_b) <= reach = s + sum |a_n|, the kernel's modes being at most 1 in size): a
    part's free edge, where the deflection jumps, can stand between two nodes higher than both, and
    its contact found only once a node touches would enter the forcing with a jump of the force
    and the energy (seen as energy_violation after a breakthrough, the outer part's edge rising
    into the layer)."""
    if basis.kind == 0.0:
        return j
    header = floe_header(basis.floe)
    for k in range(int(header[BREAK_COUNT])):
        x_b = header[FIRST_BREAK + k]
        if body_profile(x_b, body) <= reach:
            j = max(j, int(x_b / basis.dx) + 1)
    return j


@kernel
def last_reachable(profile, cosq, c, m, lift, work, j0, j1):
    """The last node j0 <= j < j1 with b(x_j) <= lift + sum_{n < m} c_n cos(lambda_n x_j), or
    j0 - 1 if there is none: m + 1 vectorised passes over work (scratch), then a scan down."""
    for j in range(j0, j1):
        work[j] = profile[j] - lift
    for n in range(m):
        cn = c[n]
        row = cosq[n]
        for j in range(j0, j1):
            work[j] -= cn * row[j]
    for j in range(j1 - 1, j0 - 1, -1):
        if work[j] <= 0.0:
            return j
    return j0 - 1


@kernel
def count_contacts(delta, jmax, mirror):
    """Disjoint intervals of delta > 0 on -L..L from the nodes of 0..L (central one once;
    mirror = 2), or from the nodes of the full plate (mirror = 1: each once)."""
    count = 0
    inside = False
    away = 2 if mirror == 2.0 else 1
    for j in range(jmax):
        if delta[j] > 0.0:
            if not inside:
                count += 1 if j == 0 else away
                inside = True
        else:
            inside = False
    return count


@kernel(nrt=True)
def reach_in_step(body, basis, jm, a0, a1, s0, s1, drift, work):
    """jm' >= jm such that no node j >= jm' can be in contact at any time of a step.

    Given: at both ends delta < 0 at the nodes j >= jm (contact_bound), and delta moves at most
    drift / he over half the step, so delta(t) <= (delta_0 + delta_1) / 2 + drift / he at every
    t in it. Each end's delta is bounded as in contact_bound, w_j <= sum_{n < 4} a_n
    cos(lambda_n x_j) + sum_{n >= 4} |a_n| (last_reachable on the mean of the ends' first
    modes), on the nodes up to the coarse limit
    b(x_j) <= max(s0, s1) + max(sum |a0_n|, sum |a1_n|) + drift. work (J,) is scratch.
    """
    N = a0.shape[0]
    J = work.shape[0]
    m = min(BOUND_MODES, N)
    A0 = 0.0
    A1 = 0.0
    T = 0.0
    for n in range(N):
        A0 += abs(a0[n])
        A1 += abs(a1[n])
        if n >= m:
            T += abs(a0[n]) + abs(a1[n])
    reach = max(s0, s1) + max(A0, A1) + drift
    if reach <= 0.0:
        return jm
    jc = min(J, int(body_extent(reach, body) / basis.dx) + 2)
    if jc <= jm:
        return jm
    mean = np.empty(m)
    for n in range(m):
        mean[n] = 0.5 * (a0[n] + a1[n])
    lift = 0.5 * (s0 + s1 + T) + drift + 1e-9 * (A0 + A1)
    return max(jm, last_reachable(body.profile, basis.cosq, mean, m, lift, work, jm, jc) + 1)


@kernel
def node_deltas(he, body, basis, a, s, delta, j0, j1):
    """delta = (w + s - b(x_j)) / he at the nodes j0 <= j < j1 (as node_reaction has it)."""
    if j1 <= j0:
        return
    modal_sum_range(a, basis.cosq, delta, j0, j1)
    for j in range(j0, j1):
        delta[j] = (delta[j] + s - body.profile[j]) / he


@kernel
def shape_peak(model, delta, j, n, a, s):
    """continuous_peak of delta = (w + s - b(x)) / he for any body shape: Newton on delta'
    with b', b'' from body_slope_curvature, kept within [x_{j-1}, x_{j+1}]. Returns (value, x)."""
    dx = model.basis.dx
    he = model.layer.he
    deflection = Field(model.plate.modes[ONES], 0)
    if j == 0 or j == n - 1:
        return delta[j], j * dx
    v, x = refine(delta, 1.0, j, n, dx)
    xlo = (j - 1) * dx
    xhi = (j + 1) * dx
    load_dry(model.basis, a)
    for _ in range(8):
        s0, s1, s2 = point_sums(model.basis, deflection, a, x)
        b1, b2 = body_slope_curvature(x, model.body)
        x, done = newton_move(x, s1 - b1, s2 - b2, xlo, xhi, NEWTON_STOP * dx)
        if done:
            break
    s0, s1, s2 = point_sums(model.basis, deflection, a, x)
    value = (s0 + s - body_profile(x, model.body)) / he
    if value < delta[j]:                 # a corner the iteration could not settle on: the node
        return delta[j], j * dx
    return value, x


@kernel
def _corner_peak(model, a, s, v, x):
    """The larger of (v, x) and delta at the body's corners on the plate (a wedge's apex, a flat
    bottom's edges), where delta has a kink that Newton on delta' cannot settle on: (value, x)."""
    body = model.body
    deflection = Field(model.plate.modes[ONES], 0)
    for c in body_corners(body):
        if 0.0 <= c <= model.basis.length:
            d = (field_sum(model.basis.lam1, model.basis.floe, deflection, a, c) + s - body_profile(c, body)) / model.layer.he
            if d > v:
                v, x = d, c
    return v, x


@kernel
def gap_peak(model, s, U, delta, jm, a, adot, out):
    """Largest delta over the continuous plate and its rate: out[:] = (delta, rate, x), the
    body at penetration s moving down at U.

    delta holds the nodes j < jm (beyond them delta < 0); the peak is refined on the modes.
    """
    he = model.layer.he
    deflection = Field(model.plate.modes[ONES], 0)
    n = jm if jm < delta.shape[0] else delta.shape[0]
    j = argmax_node(delta, 1.0, n)
    if j == n - 1 and n < delta.shape[0]:
        v, x = delta[j], j * model.basis.dx     # the next node is outside the computed range
    elif is_parabola(model.body):
        v, x = continuous_peak(delta, 1.0, j, n, model.basis, deflection, a, 1.0 / he,
                               -0.5 / (model.body.R * he), s / he)
    else:
        v, x = shape_peak(model, delta, j, n, a, s)
        if model.basis.rule == 1:        # the contact-resolving rule integrates up to the corners
            v, x = _corner_peak(model, a, s, v, x)
    out[0] = v
    out[1] = (field_sum(model.basis.lam1, model.basis.floe, deflection, adot, x) + U) / he
    out[2] = x
