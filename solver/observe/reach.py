r"""The contact's reach over time, the impact zone's extent (docs/model.md, "Maxima of the impact
zone"): c(t), the largest distance from the body's centre x_c that a point in contact (delta >
0) has reached up to t, and the zone's ends [x_c - c - m, x_c + c + m] (m the margin; on walls
m short of each wall).

At a step's end the contact's extent comes from delta at every node (contact_extent: the
outermost contact node moved to the zero of the parabola of delta through it and its
neighbours, exact for a parabolic delta). Inside a step, at the dense output's samples, only
the nodes around the front are evaluated (reach_at), with the body's penetration from the cubic
Hermite of its deficits; where the extent peaks at a sample (the contact stops spreading and
recedes), the reach from then on is the vertex of the parabola through that sample and its
neighbours (zone_track). Between the ends of steps that resolve the modes, where the zone is not
sampled inside, a peak at a step's end is the vertex of the parabola through it and the ends
around it (peak_at_end).

Benchmark (tests/test_impact_zone.py): the extent on rigid ice is the body's geometry; against
DOP853, whose samples resolve the front (a 6 m floe's reach, 0.5716 m, to 2e-9 m at tolerance
1e-10, where step ends alone left it 2.6e-6 m short).
"""
import math
from collections import namedtuple

from ..cubic import hermite
from ..compile.jit import kernel
from ..layout import B_D, B_U
from ..model.contact import node_deltas

#: the zone's ends [lo, hi] [m] (kernel coordinates)
Span = namedtuple("Span", "lo hi")
#: what zone_track starts from: the contact's reach c at a step's start, its extent at the
#: step's start and end (from every node), the margin [m]
Reach = namedtuple("Reach", "c0 extent0 extent1 margin")


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
def zone_ends(model, c, margin):
    """The zone's ends [lo, hi] (kernel coordinates) for the contact's reach c and the margin."""
    basis, xc = model.basis, model.body.xc
    r = c + margin
    lo, hi = max(0.0, xc - r), min(basis.length, xc + r)
    if basis.kind == 0:                             # walls: their own neighbourhood is not the zone's
        hi = min(hi, basis.length - margin)
        if basis.mirror == 1.0:
            lo = max(lo, margin)
    return lo, hi


@kernel
def _side_reach(model, a, s, c, side, delta):
    """The contact's farthest distance from the body's centre x_c on one side (side 1: x > x_c,
    -1: x < x_c) at the state a with the body at s, where it lies beyond c - 2 dx (else -1):
    delta at the nodes from two inside x_c + side c outward while in contact (node_deltas), and
    as contact_extent, the outermost contact node moved to the zero of delta's parabola."""
    basis, body = model.basis, model.body
    dx, xc, J, he = basis.dx, body.xc, delta.shape[0], model.layer.he
    j = min(max(int(round((xc + side * c) / dx)) - 2 * side, 0), J - 1)
    first, last = j, -1                             # nodes computed: first .. j (outward)
    while 0 <= j < J:
        node_deltas(he, body, basis, a, s, delta, j, j + 1)
        if delta[j] > 0.0:
            last = j
        elif side * (j * dx - xc) > c:               # out of contact beyond the reach: done
            break
        j += side
    if last < 0:
        return -1.0
    far = side * (last * dx - xc)
    out = last + side
    if 0 <= out < J and (last - side - first) * side >= 0:
        far += dx * _to_zero(delta[last - side], delta[last], delta[out])
    elif 0 <= out < J:
        far += dx * delta[last] / (delta[last] - delta[out])
    return far


@kernel
def reach_at(model, a, s, c, delta):
    """The contact's extent (contact_extent's, its distance from the body's centre) at a state
    inside a step where it lies beyond c - 2 dx, c the reach so far (else -1): only the nodes
    around its front are evaluated (_side_reach, both sides of an off-centre body). A contact
    that appears beyond a gap is seen at the step's end."""
    far = _side_reach(model, a, s, c, 1, delta)
    if model.body.xc - c > model.basis.dx:        # the full plate: the other side too
        far = max(far, _side_reach(model, a, s, c, -1, delta))
    return far


@kernel
def peak_at_end(e_prev, e0, e1, h_prev, h, dx):
    """The contact's farthest reach around a step end where its extent peaks there (e_prev < e0
    >= e1, the extents at the ends of two steps of lengths h_prev and h that resolve the modes,
    so not sampled inside): the vertex of the parabola through the three; -1 where it does not
    peak there, or where the vertex lies a node spacing or more above e0 (a contact that appeared
    or left beyond a gap: not one smooth front)."""
    if not (e_prev > 0.0 and e1 > 0.0 and e_prev < e0 and e0 >= e1):
        return -1.0
    d_prev, d_next = (e0 - e_prev) / h_prev, (e1 - e0) / h
    a = (d_next - d_prev) / (h + h_prev)
    if not a < 0.0:
        return -1.0
    b = d_prev + a * h_prev
    top = e0 - b * b / (4.0 * a)
    return top if top - e0 < dx else -1.0


@kernel
def reach_after_step(reach, sampled, c, h, dx):
    """The contact's reach so far (reach[0], ZoneWork.reach) after a step of length h whose end
    has the extent c: with the largest of its samples inside the step (sampled; -1: the step was
    not sampled), or with the peak at the last step's end where neither step was (peak_at_end);
    and the extent and step length the next step's peak_at_end reads (reach[5], reach[6])."""
    if sampled >= 0.0:
        reach[0] = max(reach[0], sampled)
    elif h > 0.0 and reach[6] > 0.0:
        reach[0] = max(reach[0], peak_at_end(reach[5], reach[4], c, reach[6], h, dx))
    if h > 0.0:
        reach[5], reach[6] = reach[4], 0.0 if sampled >= 0.0 else h
    reach[0] = max(reach[0], c)


@kernel
def zone_track(model, t0, h, reach, yb0, yb1, A, delta, track):
    """The zone at the dense-output times t0 + k h / K, k = 0..K, into track[k] = (lo, hi, dlo/dt,
    dhi/dt, the contact's extent, its reach so far): reach, a Reach; inside, the extent at the
    states A (reach_at, the body's penetration from the cubic Hermite of its deficits at t0, yb0,
    and at t0 + h, yb1). Where the extent peaks at a sample, the reach from then on is the peak
    of its parabola through that sample and its neighbours (the contact's farthest reach between
    samples). The ends' speeds are differences of the samples."""
    c0, e0, e1, margin = reach.c0, reach.extent0, reach.extent1, reach.margin
    body = model.body
    K = A.shape[0] + 1
    hk = h / K
    track[0, 4], track[K, 4] = e0, e1
    d = hermite(yb0[B_D], yb1[B_D], yb0[B_U], yb1[B_U], h)
    c = c0
    for k in range(1, K):
        th = k / K
        deficit = d[0] + th * (d[1] + th * (d[2] + th * d[3]))
        track[k, 4] = reach_at(model, A[k - 1], body.V * (t0 + k * hk) - deficit, c, delta)
        c = max(c, track[k, 4])
    track[0, 5] = c0
    for k in range(1, K + 1):
        track[k, 5] = max(track[k - 1, 5], track[k, 4])
    for k in range(1, K):                           # the extent's peaks between samples
        f0, f1, f2 = track[k - 1, 4], track[k, 4], track[k + 1, 4]
        curv = f0 - 2.0 * f1 + f2
        if f0 > 0.0 and f2 > 0.0 and f0 < f1 and f1 >= f2 and curv < 0.0:
            top = f1 - (f2 - f0) * (f2 - f0) / (8.0 * curv)
            after = k if (f0 - f2) / (2.0 * curv) <= 0.0 else k + 1
            for j in range(after, K + 1):
                track[j, 5] = max(track[j, 5], top)
    for k in range(K + 1):
        track[k, 0], track[k, 1] = zone_ends(model, track[k, 5], margin)
    for k in range(K + 1):
        a, b = max(k - 1, 0), min(k + 1, K)
        track[k, 2] = (track[b, 0] - track[a, 0]) / ((b - a) * hk)
        track[k, 3] = (track[b, 1] - track[a, 1]) / ((b - a) * hk)
