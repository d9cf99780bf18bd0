r"""A plate broken into parts: their dry modes and the walls' channel's water they share; their wet
modes and the state carried across a break are built on these in solver.model.broken (a floe's
water: solver.model.floe_parts), their tables for the kernels in solver.model.part_tables
(docs/model.md, "Breaking into parts").

**Parts.** On the kernel's domain 0 <= x <= Lambda (the half plate of a centred impact, Lambda = L,
whose x = 0 is the symmetry plane; or the whole plate, Lambda = 2L) breaks at 0 < b_1 < ... cut the
plate into parts. The domain's ends are sliding (w_x = w_xxx = 0: a wall, or the symmetry plane);
a break is a free edge on both sides (w_xx = w_xxx = 0). A break at an end of the domain (x = 0,
the half plate's centre or the whole plate's left wall; x = Lambda, a wall) cuts no part off: it
makes that end free, the ice broken off the wall (or at its centre) with one face. Each part is
an Euler beam with its own dry modes, each a free-free beam's mode of some half-length l about some centre c, kept on the
part only (zero elsewhere):

    sliding-free   heave and the symmetric modes of half-length l = the part's length, centred
                   on its sliding end (a free-free beam's symmetric mode has w_x = w_xxx = 0 at
                   its centre);
    free-free      heave, pitch, the symmetric and antisymmetric modes about the part's middle;
    sliding-sliding (an unbroken plate) heave and cos(n pi (x - lo) / l).

Every mode psi obeys psi'''' = beta^4 psi on its part, and the modes of a part are orthogonal
there in int psi psi dx and in int psi'' psi'' dx. Each is scaled to mean square 1 on its part,
so int psi_m^2 dx is the part's length.

**Edge shapes** (``edge_shapes`` > 0). Every free-free mode has psi'' = psi''' = 0 at a free edge,
where the state a break leaves still bends: the carry then converges only as 1 / beta_max. Each
part may take, at each free end, boundary layers that obey the same beam equation,

    sliding-free   cosh(beta (x - c)) / cosh(beta l) about the sliding end (flat there),
    free-free      that and sinh(beta (x - c)) / sinh(beta l) about the middle,

at beta = EDGE_FACTORS beta_max (those with beta l >= EDGE_LENGTH); a part too short for one
of them takes in its place the same at beta l = EDGE_WHOLE, a shape of the whole part whose
curvature at a face is not zero (its boundary layers are too steep to hold a curvature that
varies slowly along it, as an opening crack's held moment makes). They are not
orthogonal to the part's modes: the mass and bending Gram matrices take their rows by
Gauss-Legendre (gram).

**Water.** The channel between the walls, deep or of depth H, is the unbroken plate's: a normal
velocity cos(mu_k x), mu_k = k pi / Lambda, has the added mass rho_w coth(mu_k H) / mu_k (as
for the walled plate's modes), the water cannot be compressed (int w dx = 0 over the domain) and
the cracks are too narrow to let it out. With c_mk = (2 / Lambda) int psi_m cos(mu_k x) dx,

    A_mn = mirror (Lambda / 2) sum_k rho_w coth(mu_k H) / mu_k c_mk c_nk,

(mirror 2 on the half plate, 1 on the whole). Because psi'''' = beta^4 psi on the part [a, b],
integrating by parts four times gives each coefficient in closed form,

    (beta^4 - mu^4) int_a^b psi cos(mu x) dx = [psi''' cos + mu psi'' sin - mu^2 psi' cos - mu^3 psi sin]_a^b,

used away from resonance (Gauss-Legendre on the part where mu is near beta). A part's mode jumps to zero at a
break, so c_mk falls only as 1 / k and A's series as k^-3: it is summed to K terms and the rest
is added in closed form to its second order, from the jumps of each mode's value and slope at
its part's ends (jump_tail).

**Wet modes.** With the dry amplitudes q (w = sum_m q_m psi_m), the part's mass and the added mass
M = mirror m G + A, the stiffness K = mirror (D beta^4 + rho_w g) G (G = diag(int psi^2 dx); with
edge shapes K = mirror (D G2 + rho_w g G), G and G2 the Gram matrices of psi and psi'', q kept to
the modes and the edge shapes they do not nearly span, each at unit mass, and the constraint taken
by eliminating amplitudes: solver.model.broken.shaped_span, eliminated), and
the constraint sum_m q_m int psi_m dx = 0 (q = Z r, Z a basis of its null space):
K_r V = M_r V diag(omega^2), V^T M_r V = I, Q = Z V; the wet mode Psi_k = sum_m Q_mk psi_m. The
eigenvalues come from K_r^-1/2 M_r K_r^-1/2 (1 / omega^2, which keeps the slow modes to full
relative accuracy, as on the floe).

**The state across a break.** w and w_t are continuous at the instant of breaking. In a finite
basis they are carried by Galerkin projection in the energies' own inner products: the
displacement in the stiffness (b_k = <Psi_k, w>_K / omega_k^2), the velocity in the mass
(b_k' = <Psi_k, w_t>_M, the water's kinetic energy included). Each energy after the break is then
at most the one before (Bessel's inequality in each inner product), and what the projection
leaves out, the energy the break removes, goes to zero as the parts' modes are refined.

Benchmarks (tests/test_parts.py): the end conditions and orthogonality of the dry modes; the
closed-form coefficients against quadrature; two rigid parts of a half plate broken at L/2, whose
added mass is 2 mirror rho_w (h_1 - h_2)^2 (L / pi)^3 (7/8) zeta(3) / L, and a break
elsewhere against a finite-difference solve of the channel's potential; the unbroken plate as
one sliding part, whose wet modes are the walled plate's cosines to round-off.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from . import floe as fl, points
from .floe import ANTISYMMETRIC, HEAVE, PITCH, SYMMETRIC, dry_mode, free_free_roots
from .resonance import near_resonance
from .tails import cosine_tail, power_tail
from ..compile.jit import kernel

#: the end conditions of a part: a wall or the symmetry plane (w_x = w_xxx = 0), a break (w_xx =
#: w_xxx = 0)
SLIDING, FREE = 0, 1
#: the dry modes' kinds beyond the floe's HEAVE, PITCH, SYMMETRIC, ANTISYMMETRIC: cos(beta (x - c))
#: on a sliding-sliding part; and the edge shapes cosh(beta (x - c)) / cosh(beta l) and
#: sinh(beta (x - c)) / sinh(beta l), boundary layers at a part's free ends (module docstring)
COSINE, EDGE_SYMMETRIC, EDGE_ANTISYMMETRIC = 4, 5, 6
#: the edge shapes' wavenumbers as fractions of the parts' beta_max (Parameters.edge_shapes: how
#: many of them, from the largest): every free-free mode has psi'' = psi''' = 0 at a free edge,
#: where the state carried across a break still bends
EDGE_FACTORS = (1.0, 0.5, 0.25, 0.125)
#: an edge shape is kept where beta l >= EDGE_LENGTH (l the part's length, or its half on a
#: free-free part): shorter, it is nearly a part's heave or pitch (1 / cosh(3) = 0.1)
EDGE_LENGTH = 3.0
#: a part too short for one of the edge shapes asked (beta l < EDGE_LENGTH) takes in its place a
#: whole-part shape (both parities on a free-free part) at beta l = EDGE_WHOLE (none where that beta
#: is beyond beta_max, as the part's own modes are): w'' != 0 at its
#: free ends and across it, which its boundary layers, too steep for it, cannot give to a slowly
#: varying curvature that does not vanish at a face (an opening crack's held moment,
#: docs/model.md, "Edge shapes")
EDGE_WHOLE = 1.5
#: an edge shape is kept where the share of its mass that its part's modes and the shapes kept
#: before it leave out is at least SPAN_TOLERANCE (solver.model.broken.shaped_span): the kernels
#: take a null wet mode for each shape left out (wet_parts)
SPAN_TOLERANCE = 1e-12
#: cosine_integrals' closed form divides by beta^4 - mu^4: below RESONANCE mu^4 (|beta - mu| < 1.2 %
#: of mu) it integrates by Gauss-Legendre instead (the closed form's rounding is then below
#: eps mu / (4 |beta - mu|) of its terms, about 20 eps)
RESONANCE = 0.05
#: cosines of the added mass between the old and the new modes in carry_parts (the jumps' tail
#: after them): the velocity carried then moves by < 1e-9 of itself (tests/test_parts.py), far
#: below what the projection leaves out
CARRY_TERMS = 2048
#: cosines of a broken plate's added mass (channel_added_mass), the jumps' tail after them: 1e-12 of
#: the largest entry (tests/test_parts.py)
ADDED_MASS_TERMS = 2048
#: the dry modes of a broken plate, each (Nd,): kind, wavenumber beta [m-1], centre c and
#: half-length l [m] of the free-free beam it is a mode of (the cosine's: c the part's low end),
#: the part [low, high] it lives on [m], the factor that gives it mean square 1 there, and the
#: index of its part
PartModes = namedtuple("PartModes", "kinds betas centres halves lows highs norms parts")
#: the wet modes of a broken plate: omega (Nw,) [rad s-1], Q (Nd, Nw) (Q^T M Q = I, Q^T K Q =
#: diag(omega^2)), the dry modes, the domain Lambda [m] and the mirror (2 on the half plate)
WetParts = namedtuple("WetParts", "omega Q modes domain mirror")
#: the bytes _PART_ROWS may hold (the oldest entries go first)
PART_ROWS_BYTES = 256 * 2**20


class _PartRows(dict):
    """Each part's rows by their key, and the bytes they hold (held): beyond PART_ROWS_BYTES the
    oldest go first."""
    held = 0

    def keep(self, key, rows):
        self[key] = rows
        self.held += rows.nbytes
        while self.held > PART_ROWS_BYTES and len(self) > 1:
            self.held -= self.pop(next(iter(self))).nbytes
        return rows

    def clear(self):
        super().clear()
        self.held = 0


#: each part's rows of the tables whose rows depend on a mode's own part only (its cosine integrals,
#: its values on a grid), kept across a run's stages: a new break changes one or two parts, the
#: others' rows are the same numbers (the same operations on the same inputs: bit for bit)
_PART_ROWS = _PartRows()


def by_part(modes: PartModes, what: tuple, compute, columns: int) -> np.ndarray:
    """(Nd, columns): a table whose rows depend on each mode's own part and on ``what`` only,
    compute(modes of one part) -> its rows, each part's computed once and kept (_PART_ROWS)."""
    out = np.empty((modes.kinds.size, columns))
    for on, sub, key in _split(modes):
        rows = _PART_ROWS.get((what, key))
        if rows is None:
            rows = _PART_ROWS.keep((what, key), compute(sub))
        out[on] = rows
    return out


#: the parts of the PartModes last split (_split), by identity: {id: (the PartModes, its parts)},
#: at most SPLITS_KEPT, the oldest dropped first (each held, so no other takes its id meanwhile)
SPLITS_KEPT = 16
_SPLITS = {}


def _split(modes: PartModes) -> list:
    """[(indices, the part's PartModes, its key)] for each part of modes, in the order of their
    index: a broken plate's tables and carries ask for them some fifty times each (by_part)."""
    kept = _SPLITS.get(id(modes))
    if kept is not None and kept[0] is modes:
        return kept[1]
    parts = []
    for part in np.unique(modes.parts):
        on = np.flatnonzero(modes.parts == part)
        sub = PartModes(*(field[on] for field in modes))
        parts.append((on, sub, tuple(field.tobytes() for field in sub[:7])))
    _SPLITS[id(modes)] = (modes, parts)
    while len(_SPLITS) > SPLITS_KEPT:
        _SPLITS.pop(next(iter(_SPLITS)))
    return parts


def part_edges(domain: float, breaks) -> np.ndarray:
    """The parts' ends [0, b_1, ..., Lambda] (a break at 0 or at Lambda, an end of the domain
    broken, is not an end of its own: free_ends); refuses a break outside [0, Lambda] or two at
    one place."""
    b = np.sort(np.asarray(breaks, dtype=float).ravel())
    if b.size and (b[0] < 0.0 or b[-1] > domain or np.any(np.diff(b) <= 0.0)):
        raise ValueError(f"breaks {b.tolist()} must lie in [0, {domain}] and apart")
    return np.concatenate([[0.0], b[(b > 0.0) & (b < domain)], [float(domain)]])


def free_ends(domain: float, breaks) -> tuple[bool, bool]:
    """Whether the domain's low end x = 0 (the half plate's symmetry plane, or the whole plate's
    left wall) and its high end x = domain (a wall) are breaks, hence free, not sliding."""
    b = np.asarray(breaks, dtype=float)
    return bool(np.any(b == 0.0)), bool(np.any(b == float(domain)))


def _part(lo, hi, sliding_lo, sliding_hi, beta_max, edges=0):
    """[(kind, beta, centre, half, norm)] of one part's dry modes, wavenumbers up to beta_max, and
    ``edges`` edge shapes at each free end (EDGE_FACTORS)."""
    length = hi - lo
    if sliding_lo and sliding_hi:
        count = int(beta_max * length / math.pi * (1.0 + 1e-12))
        return [(HEAVE, 0.0, lo, length, 1.0)] + [(COSINE, n * math.pi / length, lo, length, math.sqrt(2.0))
                                                 for n in range(1, count + 1)]
    if sliding_lo or sliding_hi:
        centre = lo if sliding_lo else hi
        roots = free_free_roots(int(beta_max * length / math.pi) + 1, True) / length
        return [(HEAVE, 0.0, centre, length, 1.0)] + [(SYMMETRIC, b, centre, length, 1.0)
                                                     for b in roots if b <= beta_max] + \
            [(EDGE_SYMMETRIC, b, centre, length, 1.0) for b in _edge_betas(beta_max, length, edges)]
    half, centre = 0.5 * length, 0.5 * (lo + hi)
    count = int(beta_max * half / math.pi) + 1
    modes = [(HEAVE, 0.0, centre, half, 1.0), (PITCH, 0.0, centre, half, math.sqrt(3.0))]
    for b_sym, b_anti in zip(free_free_roots(count, True) / half, free_free_roots(count, False) / half):
        modes += [(kind, b, centre, half, 1.0) for kind, b in ((SYMMETRIC, b_sym), (ANTISYMMETRIC, b_anti))
                  if b <= beta_max]
    return modes + [(kind, b, centre, half, 1.0) for b in _edge_betas(beta_max, half, edges)
                    for kind in (EDGE_SYMMETRIC, EDGE_ANTISYMMETRIC)]


def _edge_betas(beta_max, length, edges):
    """The wavenumbers [m-1] of a part's edge shapes: the first ``edges`` of EDGE_FACTORS beta_max,
    those with beta length >= EDGE_LENGTH, and where one is left out the whole part's
    EDGE_WHOLE / length in its place, unless that is beyond beta_max."""
    layers = [f * beta_max for f in EDGE_FACTORS[:edges] if f * beta_max * length >= EDGE_LENGTH]
    return layers + [EDGE_WHOLE / length] if len(layers) < edges and EDGE_WHOLE <= beta_max * length else layers


def part_modes(domain: float, breaks, beta_max: float, edges: int = 0, sliding=(True, True)) -> PartModes:
    """The dry modes of the parts between ``breaks`` on [0, domain] (whose ends slide where
    ``sliding`` says, a floe's high end never, but not where an end is a break), each part's
    with wavenumbers up to beta_max [m-1], and ``edges`` edge shapes at each free end (module
    docstring)."""
    ends = part_edges(domain, breaks)
    low_free, high_free = free_ends(domain, breaks)
    rows, last = [], ends.size - 2
    for i, (lo, hi) in enumerate(zip(ends[:-1], ends[1:])):
        sliding_lo, sliding_hi = i == 0 and sliding[0] and not low_free, i == last and sliding[1] and not high_free
        rows += [(*mode, lo, hi, i) for mode in _part(lo, hi, sliding_lo, sliding_hi, beta_max, edges)]
    kinds, betas, centres, halves, norms, lows, highs, parts = (np.array(c, dtype=float) for c in zip(*rows))
    return PartModes(kinds, betas, centres, halves, lows, highs, norms, parts.astype(int))


def raw_mode(kind, beta, centre, half, x, order=0):
    """A dry mode's shape (unscaled, not cut to its part) or its derivative of the given order."""
    x = np.asarray(x, dtype=float)
    if kind == COSINE:
        return beta**order * np.cos(beta * (x - centre) + order * math.pi / 2.0)
    if kind in (EDGE_SYMMETRIC, EDGE_ANTISYMMETRIC):
        return fl.hyperbolic(beta, x - centre, half, order, kind == EDGE_SYMMETRIC)
    return dry_mode(int(kind), beta, half, x - centre, order)


def part_values(modes: PartModes, x, order=0) -> np.ndarray:
    """(Nd, X): the scaled dry modes' derivatives of the given order at x [m], zero off their
    parts (a break belongs to the part above it; the domain's end to the last part)."""
    x = np.asarray(x, dtype=float)
    last = np.max(modes.highs)

    def rows(sub):                   # (the modes of one part: one interval)
        out = np.zeros((sub.kinds.size, x.size))
        on = (x >= sub.lows[0]) & ((x < sub.highs[0]) | (sub.highs[0] == last))
        if np.any(on):
            out[:, on] = values_at(sub, x[on], order, last)
        return out
    return by_part(modes, ("values", x.tobytes(), order, float(last)), rows, x.size)


def values_at(modes: PartModes, x, order=0, high_end=np.inf) -> np.ndarray:
    """(Nd, X): the scaled modes of one part (or its derivative of the given order) at points x on
    it, from the kernels' table (solver.model.points.parts_table; mode_block on a sliding-sliding
    part, whose cosines the kernels do not have), the part's upper end included where it is at or
    beyond high_end [m]. Not kept (part_values keeps each part's rows)."""
    if np.any(modes.kinds == COSINE):
        return modes.norms[:, None] * mode_block(modes, x, order)
    block = np.empty((modes.kinds.size, np.size(x)))
    key = (float(high_end),) + tuple(field.tobytes() for field in modes[:7])
    shapes = _SHAPES.get(key)
    if shapes is None:                # (a part's tables ask for its shapes some thirty times)
        shapes = _SHAPES[key] = kernel_shapes(modes, -np.inf, high_end)
        while len(_SHAPES) > SHAPES_KEPT:
            _SHAPES.pop(next(iter(_SHAPES)))
    points.parts_table(shapes, 0.0, np.ascontiguousarray(x, dtype=float), order, block)
    return modes.norms[:, None] * block


#: values_at's shapes tables by part and upper end: at most SHAPES_KEPT, the oldest dropped first
#: (read only)
SHAPES_KEPT = 64
_SHAPES = {}


def kernel_shapes(modes: PartModes, low_end: float, high_end: float, rows: int = fl.SHAPE_ROWS) -> np.ndarray:
    """(rows, Nd): the shapes table the kernels read the dry modes from (solver.model.floe): an
    edge shape as an elastic mode with no trigonometric part, each mode's part [LOWS, HIGHS), open
    below where it starts at or below low_end and above where it ends at or beyond high_end, and
    the runs of evenly spaced wavenumbers (floe.run_spacings); the rows beyond SHAPE_ROWS 0."""
    N = modes.kinds.size
    shapes = np.zeros((rows, N))
    edge = edge_shaped(modes)
    kinds = np.where(edge, modes.kinds - (EDGE_SYMMETRIC - SYMMETRIC), modes.kinds)
    shapes[fl.KINDS], shapes[fl.BETAS], shapes[fl.NORMS] = kinds, modes.betas, modes.norms
    shapes[fl.TRIG], shapes[fl.HYP] = fl.edge_factors(kinds, modes.betas * modes.halves)
    shapes[fl.TRIG, edge] = 0.0
    shapes[fl.CENTRES], shapes[fl.HALVES] = modes.centres, modes.halves
    shapes[fl.LOWS] = np.where(modes.lows <= low_end, -np.inf, modes.lows)
    shapes[fl.HIGHS] = np.where(modes.highs >= high_end, np.inf, modes.highs)
    fl.run_spacings(shapes, N)
    return shapes


def mode_block(modes: PartModes, x, order=0) -> np.ndarray:
    """(Nd, X): raw_mode of every mode at x at once (unscaled): the elastic modes' trigonometric
    and hyperbolic parts as floe.dry_mode's, broadcast over the modes (their end values by math,
    as dry_mode's); a kind this does not know by raw_mode."""
    xs = x[None, :] - modes.centres[:, None]
    out = np.zeros((modes.kinds.size, x.size))
    kinds, betas, halves = modes.kinds, modes.betas[:, None], modes.halves[:, None]
    out[kinds == HEAVE] = 1.0 if order == 0 else 0.0
    pitch = kinds == PITCH
    if order < 2 and np.any(pitch):
        out[pitch] = xs[pitch] / halves[pitch] if order == 0 else 1.0 / halves[pitch]
    cosine = kinds == COSINE
    if np.any(cosine):
        out[cosine] = betas[cosine] ** order * np.cos(betas[cosine] * xs[cosine] + order * math.pi / 2.0)
    for kind, trig, symmetric in ((SYMMETRIC, np.cos, True), (ANTISYMMETRIC, np.sin, False)):
        on = kinds == kind
        if not np.any(on):
            continue
        b, L, y = betas[on], halves[on], xs[on]
        end = np.array([[(math.cos if symmetric else math.sin)(beta * half)] for beta, half in zip(b[:, 0], L[:, 0])])
        ep, em = np.exp(b * (y - L)), np.exp(-b * (y + L))
        even = (order % 2 == 0) == symmetric
        den = 1.0 + np.exp(-2.0 * b * L) if symmetric else 1.0 - np.exp(-2.0 * b * L)
        out[on] = b**order * trig(b * y + order * math.pi / 2) / end + b**order * (ep + em if even else ep - em) / den
    for kind, symmetric in ((EDGE_SYMMETRIC, True), (EDGE_ANTISYMMETRIC, False)):
        on = kinds == kind
        if np.any(on):
            out[on] = fl.hyperbolic(betas[on], xs[on], halves[on], order, symmetric)
    for m in np.flatnonzero(~np.isin(kinds, (HEAVE, PITCH, COSINE, SYMMETRIC, ANTISYMMETRIC, EDGE_SYMMETRIC,
                                             EDGE_ANTISYMMETRIC))):
        out[m] = raw_mode(kinds[m], modes.betas[m], modes.centres[m], modes.halves[m], x, order)
    return out


#: Gauss-Legendre rule of 32 nodes on [-1, 1] (gauss_rule's panels)
GAUSS32_X, GAUSS32_W = np.polynomial.legendre.leggauss(32)


def gauss_rule(modes, m, frequency):
    """(x, w): Gauss-Legendre of 32 nodes on panels of mode m's part, each panel at most 8 / (beta
    + frequency) long: exact to round-off for its shape times a cosine of wavenumber up to
    ``frequency`` [m-1] (tests/test_parts.py)."""
    lo, hi = modes.lows[m], modes.highs[m]
    panels = int((frequency + modes.betas[m]) * (hi - lo) / 8.0) + 1
    edges = np.linspace(lo, hi, panels + 1)
    half = 0.5 * np.diff(edges)
    x = (edges[:-1] + half)[:, None] + half[:, None] * GAUSS32_X[None, :]
    return x.ravel(), (half[:, None] * GAUSS32_W[None, :]).ravel()


def cosine_integrals(modes: PartModes, mu) -> np.ndarray:
    """(Nd, K): int psi_m cos(mu_k x) dx over each mode's part, for wavenumbers mu (K,) [m-1] > 0:
    the closed form of the module docstring, and Gauss-Legendre near resonance, |beta^4 - mu^4| <
    RESONANCE mu^4, where the closed form would divide a difference by a small number."""
    mu = np.asarray(mu, dtype=float)
    return by_part(modes, ("cosines", mu.tobytes()), lambda sub: _cosine_rows(sub, mu), mu.size)


def _cosine_rows(modes: PartModes, mu) -> np.ndarray:
    """cosine_integrals of the modes of one part."""
    ends = np.array([modes.lows[0], modes.highs[0]])                               # (one part's)
    cos_e, sin_e = np.cos(np.outer(ends, mu)), np.sin(np.outer(ends, mu))       # (2, K)
    d = np.stack([end_values(modes, j) for j in range(4)], axis=2)              # (Nd, 2 ends, 4 orders)
    out = np.empty((modes.kinds.size, mu.size))
    _closed_form(d, np.array([mu, mu**2, mu**3, mu**4]), cos_e, sin_e, modes.betas**4, out)
    b4, mu4 = modes.betas ** 4, mu ** 4           # (the same powers once each, not per pair)
    m, k = np.nonzero(np.abs(b4[:, None] - mu4[None, :]) < RESONANCE * mu4[None, :])
    if m.size:            # (never heave nor pitch: beta = 0 < mu) the closed form that keeps its digits
        kinds, betas, centres, halves = modes.kinds[m], modes.betas[m], modes.centres[m], modes.halves[m]
        anti = kinds == ANTISYMMETRIC
        amplitude = np.where(kinds == COSINE, 1.0, np.where(kinds == SYMMETRIC, 1.0 / np.cos(betas * halves),
                                                            np.where(anti, 1.0 / np.sin(betas * halves), 0.0)))
        hyperbolic = np.where(np.isin(kinds, (SYMMETRIC, EDGE_SYMMETRIC)), 1.0,
                              np.where(np.isin(kinds, (ANTISYMMETRIC, EDGE_ANTISYMMETRIC)), -1.0, 0.0))
        out[m, k] = modes.norms[m] * near_resonance(amplitude, np.where(anti, -0.5 * math.pi, 0.0), hyperbolic, betas,
                                                    centres, halves, modes.lows[m] - centres, modes.highs[m] - centres,
                                                    mu[k])
    return out


@kernel
def _closed_form(d, powers, cos_e, sin_e, b4, out):
    """_cosine_rows' closed form on one part [x_0, x_1], numpy's operations element by element:
    out[m, k] = the upper end's (+) then the lower end's (-) (d3 - mu^2 d1) cos(mu_k x_e) + (mu d2
    - mu^3 d0) sin(mu_k x_e), over beta_m^4 - mu_k^4 (NaN where they are equal: Gauss-Legendre
    replaces it). d (Nd, 2, 4) each mode's four derivatives at the ends x_0, x_1, cos_e and sin_e
    (2, K) at them, powers (4, K) the rows mu, mu^2, mu^3, mu^4, b4 (Nd,) beta^4."""
    mu, mu2, mu3, mu4 = powers[0], powers[1], powers[2], powers[3]
    for m in range(out.shape[0]):
        for k in range(out.shape[1]):
            acc = 0.0
            for end in (1, 0):
                term = (d[m, end, 3] - mu2[k] * d[m, end, 1]) * cos_e[end, k] + \
                    (mu[k] * d[m, end, 2] - mu3[k] * d[m, end, 0]) * sin_e[end, k]
                acc += term if end == 1 else -term
            den = b4[m] - mu4[k]
            out[m, k] = acc / den if den != 0.0 else math.nan


def _coth_over(mu, H):
    """coth(mu H) / mu [m] (1 / mu in deep water)."""
    return 1.0 / mu if not math.isfinite(H) else 1.0 / (mu * np.tanh(mu * H))


def channel_added_mass(modes: PartModes, domain: float, mirror: float, rho_w: float, H: float = math.inf,
                       terms: int = 0, other: PartModes | None = None) -> np.ndarray:
    """A_mn [kg m-1] of the dry modes in the walls' channel (module docstring): ``terms`` cosines
    (0: ADDED_MASS_TERMS, or 8 beta_max Lambda / pi if more, enough for 1e-12 of the largest entry,
    tests/test_parts.py), then the jumps' tail (jump_tail); with ``other``, the added mass between
    modes (rows) and other's modes (columns)."""
    other = modes if other is None else other
    K = terms or max(ADDED_MASS_TERMS, int(8 * max(np.max(modes.betas), np.max(other.betas)) * domain / math.pi))
    mu = math.pi * np.arange(1, K + 1) / domain
    c = (2.0 / domain) * cosine_integrals(modes, mu)
    c_other = c if other is modes else (2.0 / domain) * cosine_integrals(other, mu)
    A = mirror * (domain / 2.0) * rho_w * (c * _coth_over(mu, H)) @ c_other.T
    return A + mirror * rho_w * jump_tail(modes, other, domain, K)


def jump_tail(modes: PartModes, other: PartModes, domain: float, K: int) -> np.ndarray:
    """(Nd, No) [m2]: the added mass's cosines beyond the K-th over mirror rho_w. Integrating by parts,
    a mode's cosine integral falls as its jumps at the part's ends e, of its value J_m(e) and of its
    slope P_m(e) (the value at a part's upper end, minus at its lower; 0 at a sliding end):
    I_mk = sum_e [J_m(e) sin(mu_k e) / mu_k + P_m(e) cos(mu_k e) / mu_k^2] + O(mu_k^-3). With
    coth(mu_k H) = 1 there, mu_k = k pi / Lambda and the products of sines and cosines as sums,
    the tail sum_{k > K} I_mk I_nk / mu_k is

        (Lambda / pi)^3 sum_{e, f} J_m(e) J_n(f) [C3(e - f) - C3(e + f)] / 2
      + (Lambda / pi)^4 sum_{e, f} (J_m(e) P_n(f) + P_m(f) J_n(e)) [S4(e + f) + S4(e - f)] / 2
      + (Lambda / pi)^5 sum_{e, f} P_m(e) P_n(f) [C5(e - f) + C5(e + f)] / 2,

    C_p, S_p(d) = sum_{k > K} (cos, sin)(k pi d / Lambda) / k^p (power_tail), times 2 / Lambda:
    every pair of ends, the oscillating sums included, 1e-12 of the largest entry at 2048 terms
    (tests/test_parts.py)."""
    e = np.unique(np.concatenate([modes.lows, modes.highs, other.lows, other.highs]))
    J, P = (_jumps(modes, e, order) for order in (0, 1))         # (E, Nd)
    J_o, P_o = (J, P) if other is modes else (_jumps(other, e, order) for order in (0, 1))
    minus, plus = (math.pi * (e[:, None] - e[None, :]) / domain, math.pi * (e[:, None] + e[None, :]) / domain)
    C3 = 0.5 * (cosine_tail(minus, K) - cosine_tail(plus, K))
    S4 = 0.5 * (np.imag(power_tail(plus, K, 4)) + np.imag(power_tail(minus, K, 4)))      # [e, f]: sin(e) cos(f)
    C5 = 0.5 * (np.real(power_tail(minus, K, 5)) + np.real(power_tail(plus, K, 5)))
    r = domain / math.pi
    out = r**3 * (J.T @ C3 @ J_o) + r**4 * (J.T @ S4 @ P_o + P.T @ S4.T @ J_o) + r**5 * (P.T @ C5 @ P_o)
    return (2.0 / domain) * out


def _jumps(modes: PartModes, ends, order: int = 0) -> np.ndarray:
    """(E, Nd): each mode's jump at each of the sorted ``ends`` (which hold its part's), of its
    value (order 0) or a derivative: its value at its part's upper end, minus at its lower, 0 at
    the other ends (each part's end values computed once, by_part)."""
    values = end_values(modes, order)
    jump = np.zeros((np.size(ends), modes.kinds.size))
    m = np.arange(modes.kinds.size)
    jump[np.searchsorted(ends, modes.highs), m] = values[:, 1]
    jump[np.searchsorted(ends, modes.lows), m] = -values[:, 0]
    return jump


def end_values(modes: PartModes, order: int) -> np.ndarray:
    """(Nd, 2): each scaled mode's derivative of the given order at its part's lower and upper end
    (each part's computed once, by_part)."""
    def at_ends(sub):            # (the modes of one part: its two ends)
        return sub.norms[:, None] * mode_block(sub, np.array([sub.lows[0], sub.highs[0]]), order)
    return by_part(modes, ("ends", order), at_ends, 2)


def part_lengths(modes: PartModes) -> np.ndarray:
    """int psi_m^2 dx of the scaled dry modes but the edge shapes: their parts' lengths [m]."""
    return modes.highs - modes.lows


def edge_shaped(modes: PartModes) -> np.ndarray:
    """(Nd,) bool: which dry modes are edge shapes."""
    return modes.kinds >= EDGE_SYMMETRIC


def gram(modes: PartModes, order: int) -> np.ndarray:
    """(Nd, Nd): int psi_m^(order) psi_n^(order) dx, of order 0 (mass) or 2 (bending) [m, m-3]. A
    part's modes but its edge shapes are orthogonal, int psi^2 dx the part's length and int
    psi''^2 dx beta^4 times it; the edge shapes' rows and columns in closed form (_edge_rows)."""
    edge = edge_shaped(modes)
    out = np.diag(part_lengths(modes) * (modes.betas**4 if order == 2 else 1.0))
    for part in np.unique(modes.parts[edge]):
        on = np.flatnonzero(modes.parts == part)
        rows = on[edge[on]]
        block = _edge_rows(modes, rows, on, order)
        out[rows[:, None], on[None, :]] = block
        out[on[:, None], rows[None, :]] = block.T
    return out


def _edge_rows(modes: PartModes, rows, on, order: int) -> np.ndarray:
    """(R, P): int psi_r^(order) psi_p^(order) dx of the edge shapes ``rows`` and the modes ``on``
    of their part [a, b]. Each obeys psi'''' = beta^4 psi there, so with W = psi_r''' psi_p -
    psi_r'' psi_p' + psi_r' psi_p'' - psi_r psi_p''' (W' = (beta_r^4 - beta_p^4) psi_r psi_p),

        (beta_r^4 - beta_p^4) int psi_r psi_p dx = [W]_a^b,
        int psi_r'' psi_p'' dx = [psi_r'' psi_p' - psi_r''' psi_p]_a^b + beta_r^4 int psi_r psi_p dx,

    from the modes' end values. Where |beta_r - beta_p| l < 1 (a shape with itself or its other
    parity, a mode of nearly its wavenumber: the bracket's rounding over a small difference) the
    pair is integrated by Gauss-Legendre (gauss_rule) instead. Benchmark (tests/test_edge_shapes.py):
    a composite Gauss-Legendre rule on each part."""
    ends = [end_values(modes, k) for k in range(4)]                     # (Nd, 2) each: at a and b
    r, p = [v[rows][:, None, :] for v in ends], [v[on][None, :, :] for v in ends]
    wronskian = r[3] * p[0] - r[2] * p[1] + r[1] * p[2] - r[0] * p[3]
    b_r, b_p = modes.betas[rows][:, None], modes.betas[on][None, :]
    near = np.abs(b_r - b_p) * (modes.highs[rows[0]] - modes.lows[rows[0]]) < 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        block = (wronskian[..., 1] - wronskian[..., 0]) / (b_r**4 - b_p**4)
    if order == 2:
        ends_term = r[2] * p[1] - r[3] * p[0]
        block = np.where(b_p == 0.0, 0.0, ends_term[..., 1] - ends_term[..., 0] + b_r**4 * block)   # (heave, pitch)
    for i, k in zip(*np.nonzero(near)):
        pair = np.array([rows[i], on[k]])
        x, w = gauss_rule(modes, pair[np.argmax(modes.betas[pair])], float(np.max(modes.betas[pair])))
        values = modes.norms[pair, None] * mode_block(PartModes(*(field[pair] for field in modes)), x, order)
        block[i, k] = np.sum(values[0] * values[1] * w)
    return block


def mode_means(modes: PartModes) -> np.ndarray:
    """int psi_m dx over each mode's part [lo, hi] [m], in closed form: the part's length for heave,
    ((hi - c)^2 - (lo - c)^2) / 2l for pitch, and the jump of psi''' over the part over beta^4 for
    every other mode (psi'''' = beta^4 psi; 0 to round-off for a part's elastic modes, orthogonal
    to its heave). Benchmark (tests/test_parts.py): Gauss-Legendre on each mode."""
    out = np.empty(modes.kinds.size)
    heave, pitch = modes.kinds == HEAVE, modes.kinds == PITCH
    out[heave] = modes.norms[heave] * (modes.highs[heave] - modes.lows[heave])
    hi, lo = modes.highs[pitch] - modes.centres[pitch], modes.lows[pitch] - modes.centres[pitch]
    out[pitch] = modes.norms[pitch] * (hi * hi - lo * lo) / (2.0 * modes.halves[pitch])
    rest = ~(heave | pitch)
    third = end_values(modes, 3)
    out[rest] = (third[rest, 1] - third[rest, 0]) / modes.betas[rest] ** 4
    return out
