r"""The gap between the plate and the body at any x, g = w + s - b (the layer's compression times
he), its roots, which are the contact's edges, and a broken plate's contact intervals part by
part (docs/model.md, "Breaking into parts"): the pieces of the contact-resolving quadrature
(solver.model.quadrature) that find where the layer is compressed between the nodes.

Benchmarks: the roots to EDGE_STOP of dx (tests/test_quadrature.py); a part's edge pressed into
the layer between two nodes, and a contact strictly between two points out of contact, are seen
(tests/test_breaking.py, test_a_part_edge_rising_into_the_layer_is_seen and
test_a_contact_between_two_nodes_of_a_part_is_seen: the energy identity to the time integration's
error).
"""
import math

from ..compile.jit import kernel
from .body import body_profile, body_slope_curvature
from .floe import BREAK_COUNT, FIRST_BREAK, floe_header
from .points import floe_dry_sums

#: the roots of delta at the contact edges are refined until their step is below this fraction
#: of dx (their error enters the integrals at second order, f vanishing there: 1e-10 dx moves
#: them by ~1e-20 relative; a smaller stop would ask for less than the rounding of x itself)
EDGE_STOP = 1e-10


@kernel
def gap_and_slope(a, lam1, floe, x, s, body):
    """(w + s - b, w' - b') at x [m]: the layer's compression times he and its slope; on a
    floe (floe not empty) a holds the dry modes' coefficients (solver.model.floe.floe_dry)."""
    if floe.shape[0] != 0:
        w, dw, _ = floe_dry_sums(floe, a, x, 0)
        b1, _ = body_slope_curvature(x, body)
        return w + s - body_profile(x, body), dw - b1
    rot = complex(math.cos(lam1 * x), math.sin(lam1 * x))
    cur = rot
    w = 0.0
    dw = 0.0
    for n in range(a.shape[0]):
        w += a[n] * cur.real
        dw -= a[n] * lam1 * (n + 1) * cur.imag
        cur *= rot
    b1, _ = body_slope_curvature(x, body)
    return w + s - body_profile(x, body), dw - b1


@kernel
def contact_edge(a, lam1, floe, s, body, x0, g0, x1, g1, stop):
    """The root of g = w + s - b in [x0, x1], g0 = g(x0) and g1 = g(x1) of opposite signs:
    Newton from the linear interpolant, a bisection of the bracket where Newton leaves it."""
    x = x0 + (x1 - x0) * g0 / (g0 - g1)
    for _ in range(60):
        g, dg = gap_and_slope(a, lam1, floe, x, s, body)
        if g == 0.0:
            return x
        if (g > 0.0) == (g0 > 0.0):
            x0, g0 = x, g
        else:
            x1 = x
        xn = x - g / dg if dg != 0.0 else 0.5 * (x0 + x1)
        if not (min(x0, x1) < xn < max(x0, x1)):
            xn = 0.5 * (x0 + x1)
        if abs(xn - x) <= stop:
            return xn
        x = xn
    return x


@kernel(nrt=True)
def break_count(basis):
    """The number of the plate's breaks (0 on the cosines and on a floe)."""
    return 0 if basis.kind == 0.0 else int(floe_header(basis.floe)[BREAK_COUNT])


@kernel(nrt=True)
def broken_intervals(body, basis, s, a, he, delta, jmax, edges):
    """contact_intervals on a broken plate, part by part: a part's nodes and its two ends, where
    the gap is taken on the part's own modes (it jumps at a break), so that no interval crosses a
    break and a part's edge pressed into the layer between two nodes is seen. Parts beyond the
    node jmax (the bound: delta < 0 there) have none."""
    header = floe_header(basis.floe)
    breaks = int(header[BREAK_COUNT])
    dx, floe = basis.dx, basis.floe
    stop = EDGE_STOP * dx
    count = 0
    for part in range(breaks + 1):
        lo = 0.0 if part == 0 else header[FIRST_BREAK + part - 1]
        hi = basis.length if part == breaks else header[FIRST_BREAK + part]
        if lo >= jmax * dx:
            break
        x0 = lo
        g0 = gap_and_slope(a, 0.0, floe, lo, s, body)[0]
        start = lo
        j = int(math.ceil(lo / dx))
        if j * dx <= lo:
            j += 1
        while True:
            if j * dx < hi:
                x1 = j * dx
                g1 = he * delta[j] if j < jmax else gap_and_slope(a, 0.0, floe, x1, s, body)[0]
            else:
                x1 = hi
                g1 = gap_and_slope(a, 0.0, floe, hi - 1e-12 * dx, s, body)[0]
            if g0 > 0.0 and not g1 > 0.0:
                edges[2 * count] = start
                edges[2 * count + 1] = contact_edge(a, 0.0, floe, s, body, x0, g0, x1, g1, stop)
                count += 1
            elif g1 > 0.0 and not g0 > 0.0:
                start = contact_edge(a, 0.0, floe, s, body, x0, g0, x1, g1, stop)
            elif not g0 > 0.0 and max(g0, g1) > -ISLAND_WATCH * he:
                count += _island(a, floe, s, body, x0, x1, stop, edges[2 * count:])
            if x1 >= hi:
                if g1 > 0.0:
                    edges[2 * count] = start
                    edges[2 * count + 1] = hi
                    count += 1
                break
            if j >= jmax and not g1 > 0.0:       # beyond the bound, out of contact
                break
            x0, g0 = x1, g1
            j += 1
    return count


#: a broken plate's stretch between two points (nodes, or a node and a part's edge) where both
#: are out of contact, but one within this fraction of he: the gap's slopes at its ends are
#: taken, and a peak of the gap between them that is in contact is an interval of its own
ISLAND_WATCH = 0.1


@kernel
def _island(a, floe, s, body, x0, x1, stop, edges):
    """A contact interval strictly inside [x0, x1], out of contact at both ends (a contact
    shrinking between two nodes as it lets go, or one growing next to a part's edge before
    either point touches): where the gap rises from x0 and falls to x1, its peak found by
    bisection of the slope, and if in contact the two roots around it into edges. Returns 1 or
    0. Missed, such an interval entered or left the forcing with a jump of the force and the
    energy (1.6e-4 of the work in a dropped body's run, tests/test_breaking.py)."""
    g0, d0 = gap_and_slope(a, 0.0, floe, x0 + 1e-9 * (x1 - x0), s, body)
    g1, d1 = gap_and_slope(a, 0.0, floe, x1 - 1e-9 * (x1 - x0), s, body)
    if not (d0 > 0.0 and d1 < 0.0):
        return 0
    lo, hi = x0, x1
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if gap_and_slope(a, 0.0, floe, mid, s, body)[1] > 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo <= stop:
            break
    xm = 0.5 * (lo + hi)
    gm = gap_and_slope(a, 0.0, floe, xm, s, body)[0]
    if not gm > 0.0:
        return 0
    edges[0] = contact_edge(a, 0.0, floe, s, body, x0, g0, xm, gm, stop)
    edges[1] = contact_edge(a, 0.0, floe, s, body, xm, gm, x1, g1, stop)
    return 1
