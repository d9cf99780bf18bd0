r"""A floe in open water: free edges, its dry modes, the water's added mass and its wet modes
(docs/model.md, "A free floe").

**Plate.** An Euler beam on -L <= x <= L with free edges, w_xx = w_xxx = 0 at x = +-L. Its dry
modes are orthogonal on the floe: heave 1, pitch x / L, and the elastic modes

    symmetric      cos(beta x) / cos(beta L) + cosh(beta x) / cosh(beta L),   tan(beta L) + tanh(beta L) = 0,
    antisymmetric  sin(beta x) / sin(beta L) + sinh(beta x) / sinh(beta L),   tan(beta L) - tanh(beta L) = 0,

so beta 2L = 4.7300, 7.8532, 10.9956, ... (symmetric and antisymmetric in turn). Each is 2 at
x = L. The hyperbolic ratios are evaluated as decaying exponentials (no overflow at any beta).

**Water.** Deep, with phi = 0 on the free surface |x| > L (impact theory's short-time
approximation: the surface outside the floe has no time to rise; it holds for t << sqrt(L/g))
and phi_y = w_t on the floe. With xi = x / L the potential of the normal velocity U_{k-1}(xi)
(Chebyshev, second kind) is L sqrt(1 - xi^2) U_{k-1}(xi) / k on the floe (the half-space's
Dirichlet-to-Neumann map has these eigenfunctions), so shapes psi_m, psi_n have the added mass

    A_mn = rho_w L^2 (pi/2) sum_k p_mk p_nk / k,   p_mk = (2/pi) int_0^pi psi_m(L cos t) sin t sin(k t) dt

[kg m-1] (the sine coefficients of psi(L cos t) sin t, by the trapezoid rule, exact for their
trigonometric degree). Benchmarks: heave rho_w pi L^2 / 2 and pitch rho_w pi L^4 / 16 of a rigid
strip (in units of x / L: rho_w pi L^2 / 16), tests/test_floe.py. On water of depth H the same
basis gives a Galerkin matrix, the deep one less an exponentially convergent k-integral
(added_mass, solver.model.depth): checked against the deep and the shallow limits and a
finite-difference solve (tests/test_floe.py::test_added_mass_on_finite_depth).

**Wet modes.** With G_m = int psi_m^2 dx, the equations of the dry amplitudes q are

    (m G + A) q'' + (D beta^4 + rho_w g) G q = -int p psi dx        (G, beta^4 diagonal)

diagonalised once per case: K Q = M Q diag(omega^2), Q^T M Q = I (scipy.linalg.eigh of
K^-1/2 M K^-1/2, whose eigenvalues 1 / omega^2 keep the slow heave and pitch exact). Each wet
mode Psi_k = sum_m Q_mk psi_m is scaled to max |Psi_k| = 1 over the floe (the kernels' bounds on
w take |mode| <= 1, as for cosines), so its generalised mass is 1 / s_k^2. The kernels then see
one exact oscillator per wet mode, as for the walled plate.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..compile.jit import kernel
from .depth import depth_correction

#: a piece [alpha, beta] of a subinterval on which g runs linearly from ga to gb (the paper's
#: split subintervals: solver.model.layer.split_segments)
Segment = namedtuple("Segment", "alpha beta ga gb")

#: A floe's Basis.floe is one 1-D array (fewer arrays in the Basis tuple: numba counts a reference
#: to each at every call that takes it): the four tables TABLE_* (N, J) one after the other, the
#: shapes table (SHAPE_ROWS + 2N, N), then the HEADER numbers (floe_plane, floe_shapes and
#: floe_header view them). On the cosines it is empty. Rows of the shapes table: KINDS per dry
#: mode (0 heave, 1 pitch, 2 symmetric, 3 antisymmetric), BETAS (beta [m-1]), NORMS (factor of
#: the raw shape), TRIG and HYP the elastic modes' 1 / cos(beta L) (symmetric) or 1 / sin(beta L)
#: and 1 / (1 +- exp(-2 beta L)) (solver.model.points), CENTRES and HALVES the centre c and
#: half-length l of the free-free beam the mode belongs to (a floe's: 0 and L), LOWS and HIGHS
#: the part of the plate it lives on, zero elsewhere (a floe's: -inf, inf; a broken plate's,
#: solver.model.parts, the parts' ends), RUNS the spacing by which a mode's wavenumber continues
#: its predecessor's run of evenly spaced ones on the same part, or 0 (run_spacings); rows
#: SHAPE_ROWS.. the scaled wet-mode matrix Q (row m: dry mode m), then its transpose (row k: wet
#: mode k; floe_dry's sums run along rows)
KINDS, BETAS, NORMS, TRIG, HYP, CENTRES, HALVES, LOWS, HIGHS, RUNS = range(10)
SHAPE_ROWS = 10
#: the header: the strain factor -hi/2, L, x at the kernel's 0 (-L on the full floe, 0 on the
#: half floe of a centred impact), the first dry mode m0 from which the wavenumbers are evenly
#: spaced (to round-off: beta L > ASYMPTOTIC) and that spacing (pi / L on the half floe, pi / 2L
#: on the full: dry_table)
STRAIN_FACTOR, HALF_LENGTH, ORIGIN, FIRST_EVEN, SPACING = range(5)
#: then the number of breaks and their places (kernel coordinates, ascending; a broken plate's,
#: solver.model.parts: the contact-resolving rule cuts its panels there), at most MAX_BREAKS
BREAK_COUNT, FIRST_BREAK, MAX_BREAKS = 5, 6, 16
#: then the crack spacing [m] (no tension is read within it of a break: solver.model.basis.read_interval;
#: 0, a floe's and an unbroken plate's: read everywhere), 1 where the domain's low end x = 0 (the
#: half plate's symmetry plane, the whole plate's left wall) is a break, and the domain's high end
#: (a wall) where it is a break, else 0 (neither is in the list: they are no part's end)
CRACK_BAND, LOW_CUT, HIGH_CUT = FIRST_BREAK + MAX_BREAKS, FIRST_BREAK + MAX_BREAKS + 1, FIRST_BREAK + MAX_BREAKS + 2
HEADER = FIRST_BREAK + MAX_BREAKS + 3
#: exp(-HYP_NEGLIGIBLE) = 4e-18: a hyperbolic part that small is below the rounding of the
#: trigonometric part (of order 1) and is not computed (solver.model.points)
HYP_NEGLIGIBLE = 40.0
#: beyond beta L = ASYMPTOTIC the roots of tan(beta L) = -+tanh(beta L) are (k + 3/4) pi and
#: (k + 5/4) pi to 2 exp(-2 beta L) < 1e-17
ASYMPTOTIC = 20.0
HEAVE, PITCH, SYMMETRIC, ANTISYMMETRIC = range(4)
#: the rows of a floe's Basis.tables (4, N, J): the upper-surface strain -hi/2 Psi_n'' of each wet
#: mode at the nodes, the hat weights int hat_j Psi_n dx [m] (half hats at the floe's edges), and
#: Psi_n' [m-1] and Psi_n'' [m-2] at the nodes
TABLE_STRAIN, TABLE_HAT, TABLE_SLOPE, TABLE_CURVATURE = range(4)
#: Gauss-Legendre rule of 4 nodes on [-1, 1] (floe_segment)
GAUSS4_X, GAUSS4_W = (np.ascontiguousarray(v) for v in np.polynomial.legendre.leggauss(4))


#: the roots free_free_roots has found, symmetric (True) and antisymmetric (False), kept for the
#: process: each root is the same number whatever count asks for it (a broken plate's parts ask
#: again at every break)
_ROOTS = {True: np.empty(0), False: np.empty(0)}


def free_free_roots(count: int, symmetric: bool) -> np.ndarray:
    """beta L of the first ``count`` symmetric (tan + tanh = 0) or antisymmetric (tan = tanh)
    elastic modes of a free-free beam of half-length L (brentq on each branch of tan; found once
    a process: _ROOTS)."""
    known = _ROOTS[symmetric]
    if known.size < count:
        _ROOTS[symmetric] = known = np.concatenate([known, _find_roots(known.size, count, symmetric)])
    return known[:count].copy()


def _find_roots(first: int, count: int, symmetric: bool) -> np.ndarray:
    """free_free_roots' roots first .. count - 1."""
    from scipy.optimize import brentq        # (here, not at the top: 0.3 s of every import of solver)
    roots = np.empty(count - first)
    for i, k in enumerate(range(first, count)):
        if symmetric:       # tan y = -tanh y: one root in ((k + 1/2) pi, (k + 1) pi)
            lo, hi = (k + 0.5) * math.pi + 1e-12, (k + 1.0) * math.pi
            roots[i] = brentq(lambda y: math.sin(y) * math.cosh(y) + math.cos(y) * math.sinh(y), lo, hi,
                              xtol=1e-15, rtol=1e-15) if k < 40 else (k + 0.75) * math.pi
        else:               # tan y = tanh y: one root in ((k + 1) pi, (k + 3/2) pi)
            lo, hi = (k + 1.0) * math.pi, (k + 1.5) * math.pi - 1e-12
            roots[i] = brentq(lambda y: math.sin(y) - math.cos(y) * math.tanh(y), lo, hi,
                              xtol=1e-15, rtol=1e-15) if k < 40 else (k + 1.25) * math.pi
    return roots


def hyperbolic(beta, x, L, order, symmetric):
    """d^order/dx^order of cosh(beta x)/cosh(beta L) (symmetric) or sinh(beta x)/sinh(beta L),
    as decaying exponentials (numpy)."""
    ep = np.exp(beta * (x - L))
    em = np.exp(-beta * (x + L))
    even = (order % 2 == 0) == symmetric          # cosh-like after differentiating
    num = ep + em if even else ep - em
    den = 1.0 + np.exp(-2.0 * beta * L) if symmetric else 1.0 - np.exp(-2.0 * beta * L)
    return beta**order * num / den


def dry_mode(kind, beta, L, x, order=0):
    """The raw dry mode (heave, pitch, symmetric or antisymmetric elastic) or its derivative
    of the given order at positions x in -L..L [m] (numpy)."""
    x = np.asarray(x, dtype=float)
    if kind == HEAVE:
        return np.ones_like(x) if order == 0 else np.zeros_like(x)
    if kind == PITCH:
        return x / L if order == 0 else (np.full_like(x, 1.0 / L) if order == 1 else np.zeros_like(x))
    symmetric = kind == SYMMETRIC
    shift = order * math.pi / 2
    if symmetric:
        trig = beta**order * np.cos(beta * x + shift) / math.cos(beta * L)
    else:
        trig = beta**order * np.sin(beta * x + shift) / math.sin(beta * L)
    return trig + hyperbolic(beta, x, L, order, symmetric)


def dry_modes(L: float, count: int, antisymmetric: bool = True):
    """(kinds, betas) of heave, pitch and ``count`` symmetric and ``count`` antisymmetric
    elastic modes, in the order heave, pitch, then by wavenumber; without the antisymmetric
    ones (pitch included), heave and the symmetric modes."""
    sym = free_free_roots(count, True) / L
    if not antisymmetric:
        return np.array([HEAVE] + [SYMMETRIC] * count, dtype=float), np.concatenate([[0.0], sym])
    anti = free_free_roots(count, False) / L
    kinds = [HEAVE, PITCH] + [SYMMETRIC, ANTISYMMETRIC] * count
    betas = [0.0, 0.0] + [b for pair in zip(sym, anti) for b in pair]
    return np.array(kinds, dtype=float), np.array(betas)


def sine_coefficients(kinds, betas, L, norms=None):
    """p_mk = (2/pi) int_0^pi psi_m(L cos t) sin t sin(k t) dt, k = 1..K (shape (Nd, K)), with K
    beyond the bandwidth of the fastest mode (its coefficients have fallen below 1e-16)."""
    K = int(1.5 * np.max(betas) * L) + 64 if np.size(betas) else 64
    T = 2 * K + 2
    t = np.pi * np.arange(1, T) / T                  # trapezoid on (0, pi); the ends contribute 0
    x = L * np.cos(t)
    values = np.array([dry_mode(int(k), b, L, x) for k, b in zip(kinds, betas)])     # (Nd, T - 1)
    if norms is not None:
        values = values * np.asarray(norms)[:, None]
    k = np.arange(1, K + 1)
    sines = np.sin(np.outer(t, k))                   # (T - 1, K)
    return (2.0 / T) * (values * np.sin(t)) @ sines  # (2/pi) (pi/T) sum


def added_mass(kinds, betas, L, rho_w, norms=None, H=math.inf):
    """A_mn [kg m-1] of the dry modes (module docstring), on water of depth H [m].

    Deep water: the half-plane's map is diagonal on b_j = sqrt(1 - xi^2) U_{j-1}(xi), <b_i, D b_j>
    = pi j / 2. On depth H the map's symbol k tanh(kH) = |k| - |k| (1 - tanh |k|H): the Galerkin
    matrix on the same b_j is diag(pi j / 2) - depth_correction (a fast k-integral), and with
    <b_j, psi_m> = L (pi / 2) p_mj, A = rho_w (L pi / 2)^2 P G^-1 P^T."""
    P = sine_coefficients(kinds, betas, L, norms)
    k = np.arange(1, P.shape[1] + 1)
    if not math.isfinite(H):
        return rho_w * L * L * (np.pi / 2.0) * (P / k) @ P.T
    G = np.diag(np.pi * k / 2.0) - depth_correction(k.size, L, H)
    return rho_w * (L * np.pi / 2.0) ** 2 * P @ np.linalg.solve(G, P.T)


def mode_norms(kinds, betas, L, points: int = 0):
    """G_m = int_-L^L psi_m^2 dx [m] of the raw dry modes (Gauss-Legendre, spectrally exact)."""
    points = points or int(4 * np.max(betas) * L) + 200
    xg, wg = np.polynomial.legendre.leggauss(points)
    x = L * xg
    return np.array([L * np.sum(wg * dry_mode(int(k), b, L, x) ** 2) for k, b in zip(kinds, betas)])


def exact_norms(kinds, L):
    """G_m = int_-L^L psi_m^2 dx [m] in closed form: 2L for heave, 2L / 3 for pitch, and 2L for
    every elastic mode, the free-free beam's identity int psi^2 dx = (2L) psi(L)^2 / 4 with
    psi(L) = 2 (tests/test_floe.py checks it against mode_norms' quadrature)."""
    return np.where(np.asarray(kinds) == PITCH, 2.0 * L / 3.0, 2.0 * L)


def wet_modes(p, count: int, antisymmetric: bool = True):
    """The wet modes of the floe of parameters p (Parameters: L, hi, rho_i, rho_w, g, rigidity)
    from heave, pitch and ``count`` symmetric and antisymmetric dry modes (without the
    antisymmetric ones: the symmetric wet modes, the added mass having no term between the two
    parities): (omega [rad s-1], Q (Nd, N): the M-orthonormal eigenvectors, kinds, betas, norms)."""
    from scipy.linalg import eigh            # (here: a floe's tables only)
    kinds, betas = dry_modes(p.L, count, antisymmetric)
    G = exact_norms(kinds, p.L)
    norms = 1.0 / np.sqrt(G / (2.0 * p.L))          # each dry mode of mean square 1 on the floe
    A = added_mass(kinds, betas, p.L, p.rho_w, norms, p.H)
    M = np.diag(np.full(kinds.size, p.plate_mass * 2.0 * p.L)) + A
    root = np.sqrt((p.rigidity * betas**4 + p.rho_w * p.g) * 2.0 * p.L)      # K^(1/2), K diagonal
    S = M / root[:, None] / root[None, :]
    mu, V = eigh(0.5 * (S + S.T))                     # mu = 1 / omega^2: the slow modes to full
    order = np.argsort(-mu)                           # relative accuracy (eigh(K, M) lost 1e-6
    mu, V = mu[order], V[:, order]                    # of pitch's omega at 80 modes)
    Q = V / root[:, None] / np.sqrt(mu)[None, :]      # Q^T M Q = I, Q^T K Q = diag(1 / mu)
    return 1.0 / np.sqrt(mu), Q, kinds, betas, norms


@kernel(nrt=True)
def floe_plane(floe, N, J, k):
    """Table k (TABLE_*) of a floe's packed array, (N, J) (a view)."""
    return floe[k * N * J:(k + 1) * N * J].reshape((N, J))


@kernel(nrt=True)
def floe_shapes(floe, N):
    """The shapes table (SHAPE_ROWS + 2N, N) of a floe's packed array (a view)."""
    end = floe.shape[0] - HEADER
    return floe[end - (SHAPE_ROWS + 2 * N) * N:end].reshape((SHAPE_ROWS + 2 * N, N))


@kernel(nrt=True)
def floe_header(floe):
    """The HEADER numbers of a floe's packed array (a view)."""
    return floe[floe.shape[0] - HEADER:]


@kernel
def run_spacings(shapes, N):
    """shapes[RUNS, m] = the spacing by which dry mode m's wavenumber continues mode m - 1's on the
    same part, or 0 (solver.model.points: such a mode's exponentials come from its predecessor's by
    a product each): both elastic with a trigonometric part (not edge shapes), about the same
    centre and half-length l, beyond beta l = ASYMPTOTIC (their roots (k + 3/4) pi and (k + 5/4)
    pi to round-off), beta_m - beta_(m-1) within 1e-12 of the spacing: pi / l between two
    symmetric modes (a sliding-free part), pi / 2l where the parities alternate (a free-free
    part)."""
    shapes[RUNS, 0] = 0.0
    for m in range(1, N):
        shapes[RUNS, m] = 0.0
        if shapes[KINDS, m - 1] < 2.0 or shapes[TRIG, m - 1] == 0.0 or shapes[TRIG, m] == 0.0:
            continue
        L = shapes[HALVES, m]
        if shapes[HALVES, m - 1] != L or shapes[CENTRES, m - 1] != shapes[CENTRES, m] or \
                shapes[LOWS, m - 1] != shapes[LOWS, m] or not shapes[BETAS, m - 1] * L > ASYMPTOTIC:
            continue
        spacing = math.pi / L if shapes[KINDS, m - 1] == shapes[KINDS, m] else 0.5 * math.pi / L
        if abs(shapes[BETAS, m] - shapes[BETAS, m - 1] - spacing) <= 1e-12 * spacing:
            shapes[RUNS, m] = spacing


def pack_floe(tables, shapes, header):
    """The packed 1-D array of the tables (4, N, J), shapes (SHAPE_ROWS + 2N, N) and header."""
    return np.ascontiguousarray(np.concatenate([tables.ravel(), shapes.ravel(), header]))


@kernel(nrt=True)
def floe_dry(floe, c, d):
    """The wet amplitudes c (N,) as the raw dry modes' coefficients d_m = norm_m sum_k Q_mk c_k
    (O(N^2), once per state; then each point is O(N): floe_dry_sums, dry_table). The sums run
    along the rows of Q^T, k in order, the same bits wherever it is called."""
    N = c.shape[0]
    shapes = floe_shapes(floe, N)
    for m in range(N):
        d[m] = 0.0
    for k in range(N):
        ck = c[k]
        row = shapes[SHAPE_ROWS + N + k]
        for m in range(N):
            d[m] += row[m] * ck
    for m in range(N):
        d[m] *= shapes[NORMS, m]


@kernel(nrt=True)
def floe_wet(floe, p, P):
    """P_k = sum_m Q_mk norm_m p_m: integrals against the raw dry modes p (N,) as integrals
    against the wet modes P (N,) (the transpose of floe_dry)."""
    N = p.shape[0]
    shapes = floe_shapes(floe, N)
    for k in range(N):
        P[k] = 0.0
    for m in range(N):
        pm = p[m] * shapes[NORMS, m]
        row = shapes[SHAPE_ROWS + m]
        for k in range(N):
            P[k] += row[k] * pm


@kernel
def _quintic(t):
    """The quintic Hermite basis on [0, 1]: weights of (p0, p0', p0'', p1, p1', p1'') (the
    derivatives in units of the interval)."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    return (1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5, t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5,
            0.5 * (t2 - 3.0 * t3 + 3.0 * t4 - t5), 10.0 * t3 - 15.0 * t4 + 6.0 * t5,
            -4.0 * t3 + 7.0 * t4 - 3.0 * t5, 0.5 * (t3 - 2.0 * t4 + t5))


@kernel(nrt=True)
def floe_segment(P, cosq, floe, dx, j, segment, sign):
    """P_n += sign * int_alpha^beta g(x) Psi_n(x) dx for g linear from ga to gb over the Segment
    inside the subinterval [x_j, x_j+1]: Psi_n there is the quintic Hermite of its
    values, slopes and curvatures at the two nodes (error ~ (beta_N dx)^6 / 46080: 1e-9 at
    beta_N dx = 0.2), times g by the 4-node Gauss rule (exact for the product): the split
    subintervals of the paper's rule on a floe's wet modes (the cosines' add_segment)."""
    alpha, beta, ga, gb = segment.alpha, segment.beta, segment.ga, segment.gb
    r = 0.5 * (beta - alpha)
    if r <= 0.0:
        return
    c = 0.5 * (alpha + beta)
    N, J = cosq.shape
    slope = floe_plane(floe, N, J, TABLE_SLOPE)
    curv = floe_plane(floe, N, J, TABLE_CURVATURE)
    for q in range(4):
        x = c + r * GAUSS4_X[q]
        g = ga + (gb - ga) * (x - alpha) / (beta - alpha)
        weight = sign * r * GAUSS4_W[q] * g
        h0, h1, h2, h3, h4, h5 = _quintic((x - j * dx) / dx)
        h1 *= dx
        h4 *= dx
        h2 *= dx * dx
        h5 *= dx * dx
        for n in range(P.shape[0]):
            P[n] += weight * (h0 * cosq[n, j] + h1 * slope[n, j] + h2 * curv[n, j]
                              + h3 * cosq[n, j + 1] + h4 * slope[n, j + 1] + h5 * curv[n, j + 1])


def dry_values(kinds, betas, norms, L, x, order):
    """(Nd, X): the normalised dry modes' derivatives of the given order at x in -L..L."""
    return np.array([n * dry_mode(int(k), b, L, x, order) for k, b, n in zip(kinds, betas, norms)])


def floe_tables(p, xq, full: bool):
    """Everything the kernels need of the floe of parameters p on the nodes xq (kernel
    coordinates: 0..2L on the full floe, 0..L on the half floe of a centred impact, whose wet
    modes are the symmetric ones): a dict with omega (N,), mass (N,) the generalised masses 1 / s_k^2
    [kg m-1], damping (N,) each wet mode's Kelvin-Voigt c_k [s-1] and damping_matrix (N, N) the
    whole of it in the kernel's amplitudes (solver.scipy_reference's coupled check), cosq (N, J)
    the wet modes at the nodes, packed: the tables (4, N, J) (TABLE_*), shapes (SHAPE_ROWS + 2N,
    N) and header in one array (floe_sums), strain_scale (N,) the largest strain of each mode per unit amplitude, and
    the dry modes' kinds, betas and norms."""
    omega, Q, kinds, betas, norms = wet_modes(p, p.Nmod, full)
    L = p.L
    origin = -L if full else 0.0
    x = np.asarray(xq, dtype=float) + origin
    fine = np.linspace(origin, L, 8 * (x.size - 1) + 1)
    scale = np.max(np.abs(Q.T @ dry_values(kinds, betas, norms, L, fine, 0)), axis=1)
    Qs = Q / scale                                   # each wet mode of largest |Psi_k| = 1
    values = [Qs.T @ dry_values(kinds, betas, norms, L, x, order) for order in range(3)]
    tables = np.empty((4,) + values[0].shape)
    tables[TABLE_STRAIN] = -0.5 * p.hi * values[2]
    tables[TABLE_SLOPE] = values[1]
    tables[TABLE_CURVATURE] = values[2]
    tables[TABLE_HAT] = _hat_weights(Qs, kinds, betas, norms, L, x)
    N = kinds.size
    shapes = np.zeros((SHAPE_ROWS + 2 * N, N))
    shapes[KINDS], shapes[BETAS], shapes[NORMS] = kinds, betas, norms
    shapes[HALVES], shapes[LOWS], shapes[HIGHS] = L, -np.inf, np.inf
    header = np.zeros(HEADER)
    header[STRAIN_FACTOR], header[HALF_LENGTH], header[ORIGIN] = -0.5 * p.hi, L, origin
    late = np.flatnonzero((kinds >= SYMMETRIC) & (betas * L > ASYMPTOTIC))
    header[FIRST_EVEN] = late[0] if late.size else kinds.size
    header[SPACING] = math.pi / (2.0 * L) if full else math.pi / L
    shapes[TRIG], shapes[HYP] = edge_factors(kinds, betas * L)
    run_spacings(shapes, N)
    shapes[SHAPE_ROWS:SHAPE_ROWS + N] = Qs
    shapes[SHAPE_ROWS + N:] = Qs.T
    # Kelvin-Voigt ice, D -> D (1 + tau d/dt): the damping tau Q^T K_b Q of the bending stiffness
    # K_b = diag(D beta_m^4 2L) in the wet modes; mass-normalised (Q^T M Q = I) its diagonal is each
    # wet mode's c_k, and in the kernel's amplitudes a_k = b_k scale_k the whole matrix S C S^-1
    bending = Q.T @ (Q * (p.rigidity * betas**4 * 2.0 * L)[:, None])
    coupling = p.tau * bending * scale[:, None] / scale[None, :]
    return {"omega": omega, "mass": 1.0 / scale**2, "cosq": np.ascontiguousarray(values[0]),
            "damping": p.tau * np.diag(bending).copy(), "damping_matrix": coupling,
            "packed": pack_floe(tables, shapes, header),
            "strain_scale": np.max(np.abs(tables[TABLE_STRAIN]), axis=1), "kinds": kinds, "betas": betas,
            "norms": norms, "Q": Qs}


def edge_factors(kinds, bl):
    """The shapes table's TRIG and HYP rows of dry modes of these kinds with beta l = bl: 1 / cos(bl)
    (symmetric) or 1 / sin(bl) (antisymmetric), and 1 / (1 +- exp(-2 bl)); 0 for heave and pitch
    (their TRIG is 1 / cos(0) on the symmetric branch's formula, unused)."""
    elastic = kinds >= SYMMETRIC
    trig = np.where(kinds == SYMMETRIC, 1.0 / np.cos(bl), np.where(elastic, 1.0 / np.sin(np.where(elastic, bl, 1.0)), 0.0))
    hyp = np.where(kinds == SYMMETRIC, 1.0 / (1.0 + np.exp(-2.0 * bl)),
                   np.where(elastic, 1.0 / -np.expm1(-2.0 * np.where(elastic, bl, 1.0)), 0.0))
    return trig, hyp


def _hat_weights(Qs, kinds, betas, norms, L, x):
    """int hat_j Psi_k dx [m] (N, J) on the nodes x (evenly spaced in -L..L): 8 Gauss-Legendre
    nodes on each subinterval (the modes are smooth there: exact to round-off)."""
    gx, gw = np.polynomial.legendre.leggauss(8)
    dx = x[1] - x[0]
    t = 0.5 * (gx + 1.0)                              # in [0, 1] along a subinterval
    pts = (x[:-1, None] + dx * t[None, :]).ravel()
    vals = (Qs.T @ dry_values(kinds, betas, norms, L, pts, 0)).reshape(Qs.shape[1], x.size - 1, 8)
    w = 0.5 * dx * gw
    hat = np.zeros((Qs.shape[1], x.size))
    hat[:, :-1] += vals @ (w * (1.0 - t))             # the falling half of hat_j on [x_j, x_j+1]
    hat[:, 1:] += vals @ (w * t)                      # the rising half of hat_j+1
    return hat
