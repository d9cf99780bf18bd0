r"""The cosine basis on the quadrature nodes: sums of modes, exact segment integrals, peaks.

The plate's deflection is w(x, t) = sum_n a_n(t) cos(lambda_n x), lambda_n = n lambda_1, on the
nodes x_j = j dx of [0, L] (the symmetric half plate, mirror = 2: its integrals stand for -L..L)
or of [0, 2L] (the full plate of an off-centre impact, kernel coordinate xi = x + L, mirror = 1;
docs/model.md, "Off-centre impact"). The :data:`Basis` tuple holds lambda_1, dx, the node table
cosq[n, j] = cos(lambda_n x_j) and the hat weights of the paper's quadrature:

    int hat_j(x) cos(lambda x) dx = c_j dx cos(lambda x_j) sinc^2(lambda dx / 2),

c_j = 1/2 at the ends, 1 inside (wq_n = dx sinc^2(lambda_n dx / 2)); and the exact integral of a
linear function against cos(lambda_n x) on a segment (``add_segment``). Everything that knows
the basis is a cosine series is here: another basis replaces this module.

Peaks: the largest value of a modal field over continuous x near a node (``continuous_peak``,
Newton on the modal sum) and over the plate (``global_peak``).

Benchmarks (tests/test_kernel_pieces.py, test_forcing_projection_equals_hat_weight_matrix; and
tests/test_energy_and_forcing.py, test_forcing_matches_brute_force_integral): the projection on
the hat weights plus the split segments equals the explicit hat-weight matrix, and the forcing
equals a brute-force integral of the linearly interpolated f against cos(lambda_n x).
"""
import math
from collections import namedtuple

import numpy as np

from .floe import BREAK_COUNT, CRACK_BAND, FIRST_BREAK, HEADER, HIGH_CUT, LOW_CUT, TABLE_STRAIN, floe_dry, floe_plane
from .peak_margin import PEAK_MARGIN, competing, curvature_bound
from .points import floe_dry_sums, floe_sums
from ..compile.jit import kernel

#: the basis on the nodes: lam1 = lambda_1 [m-1], dx [m], cosq (N, J) cos(lambda_n x_j), wq (N,)
#: the hat weights dx sinc^2(lambda_n dx / 2) [m], mirror (2: the symmetric half plate, whose
#: integrals over 0..L are doubled; 1: the full plate), length = dx (J - 1) [m] (L, or 2L); the
#: forcing's rule (QUADRATURE_CODES: 0 the paper's, 1 the contact-resolving one) with, for the
#: latter, its Gauss-Legendre nodes gauss_x and weights gauss_w on [-1, 1] and the widest panel [m];
#: kind (0: these cosines; 1: a free floe's wet modes, solver.model.floe, whose node table is cosq
#: and whose other tables and shapes are packed in floe; empty on the cosines); dry (N,), on a
#: floe's wet modes, a state's dry coefficients for the Newton searches on the modes (load_dry,
#: point_sums: each search loads its state once and holds it only while it runs; empty on the cosines);
#: reach, the most a peak between nodes stands above its nearest node, as a fraction of the largest
#: |field| ((k dx)^2 / 8, k the largest wavenumber: peak_reach)
Basis = namedtuple("Basis", "lam1 dx cosq wq mirror length rule gauss_x gauss_w panel kind floe dry reach")
#: a modal field: its weights on the cosines (sum_n w_n c_n cos(lambda_n x)) and, on a floe's wet
#: modes, its code instead (0 the deflection, 1 the upper-surface strain; solver.model.floe)
Field = namedtuple("Field", "weights code")


#: Settings.quadrature -> Basis.rule
QUADRATURE_CODES = {"paper": 0, "gauss": 1}


#: Newton on a peak's position stops when its step is below this fraction of the bracket: the
#: iteration converges quadratically (the error after a step d is ~ lambda_N d^2), so the
#: position is then exact to ~1e-16 m for any bracket of a few subintervals
NEWTON_STOP = 1e-7


@kernel
def add_segment(P, lam1, alpha, beta, ga, gb, sign):
    """P_n += sign * int_alpha^beta g(x) cos(lambda_n x) dx, g linear from ga to gb (exact).

    With c = (alpha + beta)/2, r = (beta - alpha)/2, gbar = (ga + gb)/2:
        int = 2 r gbar cos(lam c) sinc(lam r) - (gb - ga) sin(lam c) lam r^2 q(lam r).
    cos/sin(n lam_1 c) and (n lam_1 r) follow by rotation, n = 1..N.
    """
    r = 0.5 * (beta - alpha)
    if r <= 0.0:
        return
    c = 0.5 * (alpha + beta)
    gbar = 0.5 * (ga + gb)
    dg = gb - ga
    rot_c = complex(math.cos(lam1 * c), math.sin(lam1 * c))
    cur_c = rot_c
    rot_r = complex(math.cos(lam1 * r), math.sin(lam1 * r))
    cur_r = rot_r
    for n in range(P.shape[0]):
        lam = lam1 * (n + 1)
        y = lam * r
        if y < 1e-4:
            sinc = 1.0 - y * y / 6.0
        else:
            sinc = cur_r.imag / y
        if y < 0.1:
            y2 = y * y
            q = 1.0 / 3.0 - y2 / 30.0 + y2 * y2 / 840.0 - y2 * y2 * y2 / 45360.0
        else:
            q = (cur_r.imag - y * cur_r.real) / (y * y * y)
        P[n] += sign * (2.0 * r * gbar * cur_c.real * sinc - dg * cur_c.imag * lam * r * r * q)
        cur_c *= rot_c
        cur_r *= rot_r


@kernel
def modal_sum(a, cosq, out, jmax):
    """out[j] = sum_n a_n cos(lambda_n x_j) for the nodes j < jmax (a deflection, in a's units).

    Four modes per pass over ``out``: the table rows stream from cache once per four modes,
    which is what bounds this loop (it reads N jmax doubles for 2 flops each).
    """
    modal_sum_range(a, cosq, out, 0, jmax)


@kernel
def modal_sum_range(a, cosq, out, j0, j1):
    """modal_sum on the nodes j0 <= j < j1 (the same arithmetic at each node)."""
    N = a.shape[0]
    for j in range(j0, j1):
        out[j] = 0.0
    n = 0
    while n + 4 <= N:
        a0 = a[n]
        a1 = a[n + 1]
        a2 = a[n + 2]
        a3 = a[n + 3]
        c0 = cosq[n]
        c1 = cosq[n + 1]
        c2 = cosq[n + 2]
        c3 = cosq[n + 3]
        for j in range(j0, j1):
            out[j] += (a0 * c0[j] + a1 * c1[j]) + (a2 * c2[j] + a3 * c3[j])
        n += 4
    while n < N:
        an = a[n]
        c0 = cosq[n]
        for j in range(j0, j1):
            out[j] += an * c0[j]
        n += 1


@kernel
def modal_sum_strain(a, strain_coef, cosq, out, eps, jmax):
    """modal_sum into out (j < jmax) and strain_nodes into eps (every node).

    Two passes over the table, not one: a fused loop writing both outputs is not vectorised
    and took 25.5 us against 15.7 us for the two (N = 60, J = 1001; the same values).
    """
    modal_sum(a, cosq, out, jmax)
    strain_nodes(a, strain_coef, cosq, eps)


@kernel(fastmath={"reassoc", "contract"})
def modal_projection(f, cosq, P, jmax):
    """P[n] = sum_{j < jmax} f_j cos(lambda_n x_j): four rows per pass over f.

    The sums may be reassociated (vectorised); nothing else is relaxed (no fast inf/NaN).
    """
    N = P.shape[0]
    n = 0
    while n + 4 <= N:
        r0 = cosq[n]
        r1 = cosq[n + 1]
        r2 = cosq[n + 2]
        r3 = cosq[n + 3]
        s0 = s1 = s2 = s3 = 0.0
        for j in range(jmax):
            fj = f[j]
            s0 += fj * r0[j]
            s1 += fj * r1[j]
            s2 += fj * r2[j]
            s3 += fj * r3[j]
        P[n] = s0
        P[n + 1] = s1
        P[n + 2] = s2
        P[n + 3] = s3
        n += 4
    while n < N:
        row = cosq[n]
        s = 0.0
        for j in range(jmax):
            s += f[j] * row[j]
        P[n] = s
        n += 1


@kernel(nrt=True)
def strain_nodes(a, strain_coef, cosq, eps):
    """eps_j = sum_n (hi/2) lambda_n^2 a_n cos(lambda_n x_j) at every node (eps: (J,) scratch):
    modal_sum of the products strain_coef_n a_n (the same arithmetic as modal_sum_strain)."""
    c = np.empty(a.shape[0])
    for n in range(a.shape[0]):
        c[n] = strain_coef[n] * a[n]
    modal_sum(c, cosq, eps, eps.shape[0])


@kernel
def mode_sum(w, c, lam1, x):
    """sum_n w_n c_n cos(lambda_n x), lambda_n = n lam1 (the cosines by rotation: odd and even
    modes on two interleaved chains, which halves the latency of the recurrence)."""
    rot = complex(math.cos(lam1 * x), math.sin(lam1 * x))
    rot2 = rot * rot
    cur_a = rot
    cur_b = rot2
    ta = 0.0
    tb = 0.0
    N = c.shape[0]
    for n in range(0, N - 1, 2):
        ta += w[n] * c[n] * cur_a.real
        tb += w[n + 1] * c[n + 1] * cur_b.real
        cur_a *= rot2
        cur_b *= rot2
    if N % 2 == 1:
        ta += w[N - 1] * c[N - 1] * cur_a.real
    return ta + tb


@kernel
def argmax_node(vals, sign, n):
    """Node j < n of the largest sign * vals[j] (the first one on ties)."""
    jbest = 0
    best = sign * vals[0]
    for j in range(1, n):
        v = sign * vals[j]
        if v > best:
            best = v
            jbest = j
    return jbest


@kernel
def climb(vals, sign, j, n):
    """From node j, move to the larger neighbour while sign * vals grows: a local peak."""
    while True:
        best = j
        v = sign * vals[j]
        if j > 0 and sign * vals[j - 1] > v:
            best = j - 1
            v = sign * vals[j - 1]
        if j < n - 1 and sign * vals[j + 1] > v:
            best = j + 1
        if best == j:
            return j
        j = best


@kernel
def refine(vals, sign, j, n, dx):
    """sign * vals at the peak near node j over continuous x: a parabola through j - 1, j,
    j + 1. On an end node (x = 0, the symmetry line; x = L, the wall) the node value.
    Returns (value, x)."""
    best = sign * vals[j]
    if j == 0 or j == n - 1:
        return best, j * dx
    em = sign * vals[j - 1]
    ep = sign * vals[j + 1]
    curv = em - 2.0 * best + ep
    if curv >= 0.0:
        return best, j * dx
    off = 0.5 * (em - ep) / curv
    return best - 0.25 * (em - ep) * off, (j + off) * dx


@kernel
def mode_sums(w, c, lam1, x):
    """sum_n w_n c_n (cos, -lambda_n sin, -lambda_n^2 cos)(lambda_n x): a modal field and its
    first two x-derivatives at one point (two interleaved rotation chains, as in mode_sum)."""
    rot = complex(math.cos(lam1 * x), math.sin(lam1 * x))
    rot2 = rot * rot
    cur_a = rot
    cur_b = rot2
    a0 = a1 = a2 = 0.0
    b0 = b1 = b2 = 0.0
    N = c.shape[0]
    for n in range(0, N - 1, 2):
        lam = lam1 * (n + 1)
        wc = w[n] * c[n]
        a0 += wc * cur_a.real
        a1 -= wc * lam * cur_a.imag
        a2 -= wc * lam * lam * cur_a.real
        lam = lam1 * (n + 2)
        wc = w[n + 1] * c[n + 1]
        b0 += wc * cur_b.real
        b1 -= wc * lam * cur_b.imag
        b2 -= wc * lam * lam * cur_b.real
        cur_a *= rot2
        cur_b *= rot2
    if N % 2 == 1:
        lam = lam1 * N
        wc = w[N - 1] * c[N - 1]
        a0 += wc * cur_a.real
        a1 -= wc * lam * cur_a.imag
        a2 -= wc * lam * lam * cur_a.real
    return a0 + b0, a1 + b1, a2 + b2


@kernel
def newton_move(x, d1, d2, xlo, xhi, stop):
    """One safeguarded Newton step towards a maximum, from the first and second derivative d1,
    d2 at x, kept in [xlo, xhi]: (new x, done); done when the move is below stop, or at once
    (x kept) when the curvature does not point to a maximum."""
    if not d2 < 0.0:
        return x, True
    xn = min(max(x - d1 / d2, xlo), xhi)
    return xn, abs(xn - x) <= stop


@kernel
def continuous_peak(vals, sign, j, n, basis, field, c, scale, q2, q0):
    """Largest value over continuous x near node j of the field
        v(x) = sign * scale * sum_n w_n c_n cos(lambda_n x) + q2 x^2 + q0
    (field: a Field, see field_sums),
    whose node values are sign * vals: Newton on v' from the parabola through j - 1, j, j + 1,
    kept within [x_{j-1}, x_{j+1}]. On an end node (x = 0, the symmetry line; x = L, the wall)
    the node. Returns (value, x). Refining on the modes, not on the node values, keeps the
    peak a smooth function of time (a parabola through nodes wobbles by ~1e-4 of a sharp peak
    each time the peak crosses a node)."""
    if not (j == 0 or j == n - 1):
        load_dry(basis, c)
    return loaded_peak(vals, sign, j, n, basis, field, c, scale, q2, q0)


@kernel
def loaded_peak(vals, sign, j, n, basis, field, c, scale, q2, q0):
    """continuous_peak with the state's dry coefficients already loaded (load_dry; nothing on the
    cosines): a search over many nodes loads them once."""
    dx = basis.dx
    if j == 0 or j == n - 1:
        return sign * vals[j], j * dx
    v, x = refine(vals, sign, j, n, dx)
    xlo = (j - 1) * dx
    xhi = (j + 1) * dx
    for _ in range(8):
        s0, s1, s2 = point_sums(basis, field, c, x)
        x, done = newton_move(x, sign * scale * s1 + 2.0 * q2 * x, sign * scale * s2 + 2.0 * q2, xlo, xhi,
                               NEWTON_STOP * dx)
        if done:
            break
    s0, s1, s2 = point_sums(basis, field, c, x)
    return sign * scale * s0 + q2 * x * x + q0, x


@kernel
def read_interval(floe, x, lo, hi):
    """[lo, hi] cut to the stretch around x where a broken plate's tension is read: beyond its
    crack spacing (the header's CRACK_BAND) from every break, and from the domain's ends where they
    are breaks (LOW_CUT: x = 0, the half plate's symmetry plane or the whole plate's left wall;
    HIGH_CUT: a wall). Within it of a free edge a beam's strain is not the ice's
    (Saint-Venant) and no crack forms (docs/model.md, "The crack spacing"). Unchanged on the
    cosines and without a band. Returns (lo, hi), which leaves x out where x itself is within
    the band."""
    if floe.shape[0] == 0:
        return lo, hi
    head = floe.shape[0] - HEADER                    # (the header's place: floe_header, without a view)
    band = floe[head + CRACK_BAND]
    if not band > 0.0:
        return lo, hi
    if floe[head + LOW_CUT] > 0.0:
        lo = max(lo, band)
    if floe[head + HIGH_CUT] > 0.0:
        hi = min(hi, floe[head + HIGH_CUT] - band)
    for k in range(int(floe[head + BREAK_COUNT])):
        b = floe[head + FIRST_BREAK + k]
        if b <= x:
            lo = max(lo, b + band)
        else:
            hi = min(hi, b - band)
    return lo, hi


@kernel
def readable(floe, x):
    """Whether the tension is read at x (read_interval): everywhere on the cosines and without a
    band; beyond the crack spacing from every break on a plate broken with one. A break needs its
    place read: where a plate is broken everywhere within its spacing, its tension is still
    followed (global_peak reads everywhere) but it breaks no more."""
    lo, hi = read_interval(floe, x, -np.inf, np.inf)
    return lo <= x <= hi


@kernel
def banded(basis):
    """Whether the tension is read only beyond a crack spacing from the breaks (read_interval)."""
    floe = basis.floe
    return floe.shape[0] != 0 and floe[floe.shape[0] - HEADER + CRACK_BAND] > 0.0


@kernel
def read_peak(vals, sign, j, n, basis, field, c):
    """continuous_peak of sign * the modal field near node j, kept where the tension is read
    (read_interval of [x_{j-1}, x_{j+1}]): Newton from node j, and the bracket's ends where the
    band cuts it (the peak may lie on the band's edge). Returns (value, x)."""
    dx = basis.dx
    x0 = j * dx
    if j == 0 or j == n - 1:
        return sign * vals[j], x0                      # (an end of the plate: the node, as continuous_peak)
    lo, hi = read_interval(basis.floe, x0, x0 - dx, x0 + dx)
    x = min(max(refine(vals, sign, j, n, dx)[1], lo), hi)
    load_dry(basis, c)
    for _ in range(8):
        s0, s1, s2 = point_sums(basis, field, c, x)
        x, done = newton_move(x, sign * s1, sign * s2, lo, hi, NEWTON_STOP * dx)
        if done:
            break
    best, bx = sign * point_sums(basis, field, c, x)[0], x
    for edge in (lo, hi):
        if abs(edge - x0) < dx and edge != x:        # an end the band sets
            v = sign * point_sums(basis, field, c, edge)[0]
            if v > best:
                best, bx = v, edge
    return best, bx


@kernel(inline="always")
def _margin(eps, top, basis, w, a, sure):
    """How far below the largest node top a local peak competes: competing's where sure (the
    state's dry coefficients loaded), else PEAK_MARGIN of |top|."""
    if not sure:
        return PEAK_MARGIN * abs(top)
    return competing(eps, top, basis.reach, curvature_bound(basis, w, a) * basis.dx**2 / 8.0)


@kernel
def banded_peak(eps, sign, basis, w, a, sure):
    """global_peak where the tension is read only beyond the crack spacing from the breaks: the
    local maxima among the nodes read (read_interval), each refined within the stretch read
    (read_peak). A plate broken everywhere within its spacing reads everywhere (global_peak's
    search). Returns (value, x, node)."""
    J, dx, floe = eps.shape[0], basis.dx, basis.floe
    jtop, top = -1, -np.inf
    for j in range(J):
        lo, hi = read_interval(floe, j * dx, -np.inf, np.inf)
        if lo <= j * dx <= hi and sign * eps[j] > top:
            jtop, top = j, sign * eps[j]
    if jtop < 0:
        return -np.inf, 0.0, -1
    if sure:                      # (curvature_bound reads the dry coefficients; read_peak loads its own)
        load_dry(basis, a)
    floor = top - _margin(eps, top, basis, w, a, sure)
    field = Field(w, 1)
    bv, bx = read_peak(eps, sign, jtop, J, basis, field, a)
    bj = jtop
    for j in range(J):
        v = sign * eps[j]
        if j == jtop or v < floor:
            continue
        lo, hi = read_interval(floe, j * dx, -np.inf, np.inf)
        if not lo <= j * dx <= hi:
            continue
        if (j > 0 and lo <= (j - 1) * dx and sign * eps[j - 1] > v) or \
                (j < J - 1 and (j + 1) * dx <= hi and sign * eps[j + 1] > v):
            continue
        cv, cx = read_peak(eps, sign, j, J, basis, field, a)
        if cv > bv:
            bv, bx, bj = cv, cx, j
    return bv, bx, bj


@kernel
def global_peak(eps, sign, basis, w, a, sure):
    """The global peak of sign * eps over continuous x: every local maximum of the nodes within
    PEAK_MARGIN of the largest node is refined on the modes, and, where sure is True, every one
    within the most a peak between nodes can stand above its nearest node where that is more
    (competing: up to (lambda_N dx)^2 / 8 of the largest |tension|, 7.1 % at N = 60 on the default
    250 subintervals; the state's curvature bound where less). A step's ends and a break's scan
    are sure; the samples inside a step are not (docs/model.md, "The competing peaks' margin").
    Returns (value, x, node). On a plate broken with a crack spacing, banded_peak: the peak
    where the tension is read (where none is, every piece within the spacing of its ends, the
    peak over the plate, which breaks it no more: readable)."""
    if banded(basis):             # (its own search: the unbanded one below is hot and stays bit for bit)
        v, x, j = banded_peak(eps, sign, basis, w, a, sure)
        if j >= 0:
            return v, x, j
    J = eps.shape[0]
    jtop = argmax_node(eps, sign, J)
    top = sign * eps[jtop]
    load_dry(basis, a)
    floor = top - _margin(eps, top, basis, w, a, sure)
    field = Field(w, 1)
    bv, bx = loaded_peak(eps, sign, jtop, J, basis, field, a, 1.0, 0.0, 0.0)
    bj = jtop
    for j in range(J):
        v = sign * eps[j]
        if j == jtop or v < floor:
            continue
        if (j > 0 and sign * eps[j - 1] > v) or (j < J - 1 and sign * eps[j + 1] > v):
            continue
        cv, cx = loaded_peak(eps, sign, j, J, basis, field, a, 1.0, 0.0, 0.0)
        if cv > bv:
            bv, bx, bj = cv, cx, j
    return bv, bx, bj


@kernel(inline="always")
def field_sums(lam1, floe, field, c, x):
    """A modal field and its first two x-derivatives at one point x (kernel coordinates), from
    a Basis's lam1 and floe (not the Basis: numba counts a reference to each of its arrays at
    every call): field a Field, on the cosines (floe empty) sum_n w_n c_n cos(lambda_n x)
    (mode_sums), on a floe's wet modes the field of that code, 0 the deflection and 1 the
    upper-surface strain (solver.model.points.floe_sums)."""
    w, code = field.weights, field.code
    if floe.shape[0] == 0:
        return mode_sums(w, c, lam1, x)
    return floe_sums(floe, c, x, code)


@kernel(inline="always")
def load_dry(basis, c):
    """On a floe's wet modes basis.dry = the dry coefficients of the wet amplitudes c (floe_dry,
    O(N^2)), once for the many points of a search (point_sums); nothing on the cosines."""
    if basis.floe.shape[0] != 0:
        floe_dry(basis.floe, c, basis.dry)


@kernel(inline="always")
def point_sums(basis, field, c, x):
    """field_sums at x of the state c whose dry coefficients load_dry loaded: O(N) on a floe as on
    the cosines."""
    if basis.floe.shape[0] == 0:
        return mode_sums(field.weights, c, basis.lam1, x)
    return floe_dry_sums(basis.floe, basis.dry, x, field.code)


@kernel(inline="always")
def field_sum(lam1, floe, field, c, x):
    """The value of field_sums alone (on the cosines, mode_sum)."""
    w, code = field.weights, field.code
    if floe.shape[0] == 0:
        return mode_sum(w, c, lam1, x)
    return floe_sums(floe, c, x, code)[0]


@kernel(nrt=True)
def newton_peak(x, xlo, xhi, sign, field, c, lam1, floe):
    """The position of the peak of sign * a modal field (field_sums) near x: safeguarded Newton,
    kept in [xlo, xhi], stopping at NEWTON_STOP of the bracket (at most 8 steps). On a floe the
    dry coefficients of c once for all the steps (dry_newton_peak)."""
    if floe.shape[0] != 0:
        d = np.empty(c.shape[0])
        floe_dry(floe, c, d)
        return dry_newton_peak(floe, d, x, xlo, xhi, sign, field.code)
    for _ in range(8):
        s0, s1, s2 = field_sums(lam1, floe, field, c, x)
        x, done = newton_move(x, sign * s1, sign * s2, xlo, xhi, NEWTON_STOP * (xhi - xlo))
        if done:
            break
    return x


@kernel
def peak_and_rate(x, xlo, xhi, sign, field, c, cdot, lam1, floe):
    """(sign * the modal field, sign * that field of cdot, x*) at the peak x* of sign * the field
    of c near x (newton_peak). On a floe c and cdot are the dry coefficients (floe_dry) of the
    state and its rate: O(N) a point."""
    if floe.shape[0] == 0:
        x = newton_peak(x, xlo, xhi, sign, field, c, lam1, floe)
        return sign * field_sums(lam1, floe, field, c, x)[0], sign * field_sum(lam1, floe, field, cdot, x), x
    x = dry_newton_peak(floe, c, x, xlo, xhi, sign, field.code)
    return sign * floe_dry_sums(floe, c, x, field.code)[0], sign * floe_dry_sums(floe, cdot, x, field.code)[0], x


@kernel
def dry_newton_peak(floe, d, x, xlo, xhi, sign, code):
    """newton_peak of a floe's field of that code (0 deflection, 1 upper-surface strain) from
    its dry coefficients d (floe_dry): O(N) a step."""
    for _ in range(8):
        s0, s1, s2 = floe_dry_sums(floe, d, x, code)
        x, done = newton_move(x, sign * s1, sign * s2, xlo, xhi, NEWTON_STOP * (xhi - xlo))
        if done:
            break
    return x


@kernel(inline="always")
def node_strain(cosq, floe, strain, a, eps):
    """The upper-surface strain at every node into eps, from a Basis's cosq and floe (see
    field_sums): strain_nodes on the cosines (weights strain = (hi/2) lambda_n^2), the strain
    table on a floe's wet modes."""
    if floe.shape[0] == 0:
        strain_nodes(a, strain, cosq, eps)
    else:
        modal_sum(a, floe_plane(floe, cosq.shape[0], cosq.shape[1], TABLE_STRAIN), eps, eps.shape[0])
