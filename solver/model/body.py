r"""The body: its shape, its motion, and the work it does (docs/model.md, "Equations", "A body of
finite mass", "Body shapes", "Off-centre impact").

Shape: b(x) >= 0, b = 0 at the body's centre x_c, even about it and non-decreasing away from it;
the body's lowest point is at y = he - s (penetration s). With u = max(|x - x_c| - c, 0) (c the
half-width of a flat bottom), b = u tan(beta) for a wedge of deadrise beta, else the power law
u^p / (p R^(p-1)) (p = 2: the paper's parabola x^2 / 2R).

Motion: the paper's body moves down at the constant speed V (s = V t). A body of finite mass M
per unit width obeys M s'' = M g_b - F. Its state is kept as deficits against the prescribed
motion, d = V t - s and u = V - U, so that u' = G = F / M - g_b and d' = u: the paper's body is
d = u = 0 exactly, and 1/M = 0 selects it with no special case. The work is W = int F U dt.

Analytic benchmarks: the body's update is RK4's for u and its Nystrom form for d, and a body
of mass M approaches the paper's body as 1/M (tests/test_body_mass.py); along an exact motion
M (U^2 - V^2)/2 - M g_b s + W = 0 (``body_residual``, the free body's energy balance).
"""
import math
from collections import namedtuple

from ..compile.jit import kernel
from ..layout import B_D, B_U, D_MAX_PENETRATION, D_STOP_T

#: the body: V [m s-1], inv_mass = 1/M [m kg-1] (0: the paper's body at constant speed), g = g_b
#: [m s-2] (0 with 1/M = 0), the shape's R [m], p, flat = c [m], tanb = tan(deadrise), xc, the
#: centre in kernel coordinates [m], and profile (J,), b(x_j) at the quadrature nodes [m]
Body = namedtuple("Body", "V inv_mass g R p flat tanb xc profile")
#: a quantity's values at a step's four stages (weights 1/6, 1/3, 1/3, 1/6)
Stages = namedtuple("Stages", "first second third fourth")


@kernel
def is_parabola(body):
    """The paper's parabola x^2 / 2R, centred at the kernel's x = 0."""
    return body.p == 2.0 and body.flat == 0.0 and body.tanb == 0.0 and body.xc == 0.0


@kernel
def body_profile(x, body):
    """b(x) [m]: with u = max(|x - x_c| - c, 0) (x_c: the body's centre in kernel
    coordinates, 0 but for an off-centre impact; c: half-width of a flat bottom), u tan(beta)
    for a wedge of deadrise beta, else the power law u^p / (p R^(p-1)) (p = 2: the paper's
    parabola u^2 / 2R, exactly x * x * (0.5 / R) at c = 0 and x_c = 0)."""
    u = max(abs(x - body.xc) - body.flat, 0.0)
    if body.tanb > 0.0:
        return u * body.tanb
    p = body.p
    R = body.R
    if p == 2.0:
        return u * u * (0.5 / R)
    return u ** p / (p * R ** (p - 1.0))


@kernel
def body_corners(body):
    """Where b may not be smooth, in kernel coordinates: x_c - c, x_c, x_c + c (a wedge's apex, a
    flat bottom's edges; the same point three times for a pointed body)."""
    return body.xc - body.flat, body.xc, body.xc + body.flat


@kernel
def body_slope_curvature(x, body):
    """(b'(x), b''(x)) (at a wedge's or a flat bottom's corner: the values on the side away
    from the centre x_c)."""
    r = x - body.xc
    side = 1.0 if r >= 0.0 else -1.0
    u = abs(r) - body.flat
    if u <= 0.0:
        return 0.0, 0.0
    if body.tanb > 0.0:
        return side * body.tanb, 0.0
    p = body.p
    R = body.R
    return side * (u ** (p - 1.0) / R ** (p - 1.0)), (p - 1.0) * u ** (p - 2.0) / R ** (p - 1.0)


@kernel
def body_extent(reach, body):
    """The largest x with b(x) <= reach (reach > 0): x_c plus b's inverse."""
    xc = body.xc
    if body.tanb > 0.0:
        return xc + (body.flat + reach / body.tanb)
    p = body.p
    R = body.R
    if p == 2.0:
        return xc + (body.flat + math.sqrt(2.0 * R * reach))
    return xc + (body.flat + (p * R ** (p - 1.0) * reach) ** (1.0 / p))


@kernel
def body_coefficients(h, Cb):
    """The rows of etd_coefficients in the limit omega -> 0, for the body (Cb (9, 2)).

    The body is one more degree of freedom, M s'' = M g_b - F, with no linear part. Its state
    is kept as deficits against the prescribed motion, d = V t - s and u = V - U, so that
    u' = G = F / M - g_b and d' = u: a "mode" with omega = 0. A scheme row C(zeta), zeta = i
    omega h, then acts on u as C(0) and on d as h C'(0) (the limit of Im(C z) / omega), with
    phi_k(0) = 1/k!, phi_k'(0) = 1/(k+1)!. Column 0 holds C(0), column 1 h C'(0); rows 0 and 1
    (e^zeta, e^{zeta/2}) are d + h u and d + h u / 2, applied directly. The update is then RK4's
    for u and its Nystrom form for d: d+ = d + h u + h^2 (G1 + G2 + G3) / 6.
    """
    h2 = h * h
    Cb[0, 0] = 1.0
    Cb[0, 1] = h
    Cb[1, 0] = 1.0
    Cb[1, 1] = 0.5 * h
    Cb[2, 0] = 0.5 * h             # (h/2) phi1(zeta/2)
    Cb[2, 1] = h2 / 8.0
    Cb[3, 0] = 0.5 * h             # h phi2(zeta/2)
    Cb[3, 1] = h2 / 12.0
    Cb[4, 0] = h                   # h phi1
    Cb[4, 1] = 0.5 * h2
    Cb[5, 0] = h                   # 2 h phi2
    Cb[5, 1] = h2 / 3.0
    Cb[6, 0] = h / 6.0             # h (phi1 - 3 phi2 + 4 phi3)
    Cb[6, 1] = h2 / 6.0
    Cb[7, 0] = h / 3.0             # h (2 phi2 - 4 phi3)
    Cb[7, 1] = h2 / 6.0
    Cb[8, 0] = h / 6.0             # h (4 phi3 - phi2)
    Cb[8, 1] = 0.0


@kernel
def body_error(h, G1, G2, G3, G4, G5, errb):
    """A free body's local error against genuine third-order companions (docs/model.md, "A
    body of finite mass"). The modes' embedded estimate h (4 phi3 - phi2)(G4 - G5) reads ~ h^6
    on the body: its acceleration depends on its position, and stage 4's position differs from
    the step's by h^2 (G2 - G3)/6 = O(h^5). The companions are Simpson's rule on (G1, G2, G5)
    for u, err = h/3 (G3 - G2) + h/6 (G4 - G5), and d + h u + h^2 (2 G1 + G5)/6 for d, err =
    h^2 (G2 + G3 - G1 - G5)/6, both O(h^4)."""
    errb[B_U] = h / 3.0 * (G3 - G2) + h / 6.0 * (G4 - G5)
    errb[B_D] = h * h / 6.0 * (G2 + G3 - G1 - G5)


@kernel
def body_accel(body, F):
    """G = u' = F / M - g_b: the body's deceleration (0 for the paper's prescribed body)."""
    return body.inv_mass * F - body.g


@kernel
def body_position(body, t, yb):
    """Penetration s = V t - d of the body [m] (exactly V t for the prescribed body)."""
    return body.V * t - yb[B_D]


@kernel
def body_speed(body, yb):
    """Downward speed U = V - u of the body [m s-1]."""
    return body.V - yb[B_U]


@kernel
def body_residual(body, t, yb, work):
    """M (U^2 - V^2) / 2 - M g_b s + W: zero along an exact motion (0 for the prescribed body)."""
    im = body.inv_mass
    if im == 0.0:
        return 0.0
    u = yb[B_U]
    return (0.5 * u * u - body.V * u - body.g * body_position(body, t, yb)) / im + work


@kernel
def body_step_work(body, h, work, F, U):
    """W(t + h) = W + int F U dt by the step's weights (1, 2, 2, 1)/6 over its stages: F and U
    are the Stages of the force and of the body's speed."""
    F1, F2, F3, F4 = F.first, F.second, F.third, F.fourth
    U1, U2, U3, U4 = U.first, U.second, U.third, U.fourth
    if body.inv_mass == 0.0:
        return work + h * body.V * (F1 / 6.0 + (F2 + F3) / 3.0 + F4 / 6.0)
    return work + h * (F1 * U1 / 6.0 + (F2 * U2 + F3 * U3) / 3.0 + F4 * U4 / 6.0)


@kernel
def start_body(body, t, start, yb, diag):
    """A free body's state at t from start (solver.control.Control.body_start: s, U, and the stop
    and deepest penetration before t; NaN: at first touch, yb as it is) into its deficits yb and
    the diagnostics its observer carries on from."""
    if body.inv_mass == 0.0 or math.isnan(start[0]):
        return
    yb[B_D] = body.V * t - start[0]
    yb[B_U] = body.V - start[1]
    diag[D_STOP_T] = start[2]
    diag[D_MAX_PENETRATION] = start[3]
