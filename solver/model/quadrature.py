r"""The contact-resolving quadrature of the layer's forcing, its force and its energy
(docs/model.md, "Numerics": ``quadrature = "gauss"``).

The paper's rule (solver.model.layer) takes f(delta) linear between fixed nodes; its error,
O(dx^2), sets the solver's accuracy against the continuous model. This rule integrates the
layer's reaction where it is: over each contact interval, the x where delta > 0, with
Gauss-Legendre panels.

    P_n = int_I f(delta(x)) cos(lambda_n x) dx,   F = int_I f dx,   E = he int_I G(delta) dx

over the union I of the contact intervals (the caller scales them: K coef_n, mirror K).

1. The nodes x_j (the basis's table, which the events read anyway) give delta_j; a run of
   compressed nodes is a contact interval. Its ends are the roots of
   delta(x) = (sum_n a_n cos(lambda_n x) + s - b(x)) / he between a compressed node and its
   uncompressed neighbour, found by safeguarded Newton on the modes to 1e-10 of dx. An interval
   that runs into x = 0 or the far end is cut there (the symmetry line, the wall).
2. Each interval is cut at the body's corners (x_c, x_c -+ c: a wedge's apex, a flat
   bottom's edges), where b is not smooth, and each piece into equal panels no wider than
   ``panel`` = PANEL_POINTS / quadrature_density * (2 pi / lambda_N), with PANEL_POINTS
   Gauss-Legendre nodes each (quadrature_density nodes per wavelength of the last mode). Inside a piece f(delta(x)) cos(lambda_n x) is smooth (delta is a trigonometric
   polynomial of degree lambda_N, b is smooth), and f vanishes at the interval's ends, so the
   rule converges spectrally in the number of nodes and the root's error enters only at
   second order.
3. At the Gauss nodes: cos(lambda_n x_k) into a table (N, K) by the Chebyshev recurrence,
   vectorised over k;
   delta_k from it (basis.modal_sum_range), f_k (and a viscoelastic layer's
   f max(1 + tau delta', 0)), then P = table . (w f) (basis.modal_projection).

On a free floe the rule runs on the raw dry modes (solver.model.floe) instead of the cosines:
the wet amplitudes become dry coefficients once (floe_dry), the table at the Gauss nodes is
dry_table, the contact edges are Newton on floe_dry_sums, and the projections come back to the
wet modes (floe_wet).

A node of the rule with delta >= 1 is bottoming, as a node of the table is (status 1).

Benchmarks (tests/test_quadrature.py): on a given delta(x) the rule converges spectrally to
the exact integrals and the paper's rule as dx^2; the energy identity holds to the time
integration's error; against DOP853 on the same right-hand side the run agrees to 1e-7.
"""
import cmath
import functools
import math
from collections import namedtuple

import numpy as np

from .basis import modal_projection, modal_sum_range
from .body import body_corners, body_profile
from .contact_edges import EDGE_STOP, break_count, broken_intervals, contact_edge, gap_and_slope
from .floe import BREAK_COUNT, FIRST_BREAK, MAX_BREAKS, floe_dry, floe_header, floe_wet
from .points import dry_table
from ..compile.jit import kernel
from .law import law_energy, law_pressure
from .plate import Modes

#: what gauss_sums is asked: the projections P (project), the layer's energy (energy)
Wanted = namedtuple("Wanted", "project energy")
#: what a round adds to: sums (3,) [int f dx, the viscoelastic power, he int G dx], P (N,) the
#: projections, Q (N,) scratch
RoundOut = namedtuple("RoundOut", "sums P Q")
#: what a round is asked: the projections, the energy, and whether it is the last round
RoundFlags = namedtuple("RoundFlags", "project energy last")

#: Gauss-Legendre nodes in a panel of the rule
PANEL_POINTS = 8

#: a panel of the paper's law is cut while the Bernstein ellipse through the pole of f is below
#: RHO_MIN (near_pole: 8 Gauss nodes then integrate f to ~RHO_MIN^-16 = 1e-12), into at most
#: MAX_PIECES pieces a round, in at most MAX_ROUNDS rounds
RHO_MIN = 10.0 ** (12.0 / 16.0)
MAX_PIECES = 64
MAX_ROUNDS = 12
#: rows of the panels' ends (2, panels) and of the rule's nodes (NODE_ROWS, K): place, weight,
#: delta, a viscoelastic layer's rate (sum_n a_n' cos(lambda_n x)), the weighted pressure, and
#: 2 cos(lambda_1 x) for the cosine table
LO, HI = 0, 1
X, W, DELTA, RATE, G, C2 = range(6)
NODE_ROWS = 6
#: a panel is halved where the quadratic fit of delta misses a node by more than this fraction of
#: the distance 1 - max delta to the pole
FIT_MISS = 0.1
#: the largest |t| on the Bernstein ellipse rho = RHO_MIN (its half major axis)
ELLIPSE_T = 0.5 * (RHO_MIN + 1.0 / RHO_MIN)
#: no panel narrower than this fraction of the plate's length is cut
NARROWEST = 1e-12

@kernel
def contact_intervals(body, basis, s, a, he, delta, jmax, edges):
    """The contact intervals from delta at the nodes j < jmax (delta < 0 beyond): their ends
    into edges (2 per interval, kernel coordinates [m]); returns their number. A broken plate's
    part by part (broken_intervals)."""
    if break_count(basis) > 0:
        count = broken_intervals(body, basis, s, a, he, delta, jmax, edges)
        return count + corner_contacts(body, basis, s, a, he, delta, jmax, edges[2 * count:])
    J = delta.shape[0]
    dx = basis.dx
    lam1 = basis.lam1
    floe = basis.floe
    stop = EDGE_STOP * dx
    count = 0
    j = 0
    while j < jmax:
        if not delta[j] > 0.0:
            j += 1
            continue
        if j == 0:
            xa = 0.0
        else:
            xa = contact_edge(a, lam1, floe, s, body, (j - 1) * dx, he * delta[j - 1], j * dx, he * delta[j], stop)
        k = j
        while k + 1 < jmax and delta[k + 1] > 0.0:
            k += 1
        if k == J - 1:
            xb = basis.length
        else:
            dn = delta[k + 1] if k + 1 < jmax else -1.0
            if k + 1 >= jmax:      # beyond the bound delta < 0: take its value on the modes
                dn, _ = gap_and_slope(a, lam1, floe, (k + 1) * dx, s, body)
                dn /= he
            xb = contact_edge(a, lam1, floe, s, body, k * dx, he * delta[k], (k + 1) * dx, he * dn, stop)
        edges[2 * count] = xa
        edges[2 * count + 1] = xb
        count += 1
        j = k + 1
    return count + corner_contacts(body, basis, s, a, he, delta, jmax, edges[2 * count:])


@kernel
def corner_contacts(body, basis, s, a, he, delta, jmax, edges):
    """Contact at a corner of the body (a wedge's apex, a flat bottom's edge) between two
    uncompressed nodes: there delta has a kink and grows linearly in time from first touch, and
    an interval found only once a node is compressed would enter the integrals with a jump of
    the force and the energy. Each corner x_c of the plate with delta(x_c) > 0 and neither
    neighbouring node compressed adds [root, root] around it to edges (2 per interval); returns
    their number."""
    dx = basis.dx
    count = 0
    last = -1.0
    for c in body_corners(body):
        if not (0.0 < c < basis.length) or c == last:
            continue
        last = c
        j = int(c / dx)
        if j * dx == c:
            continue
        g, _ = gap_and_slope(a, basis.lam1, basis.floe, c, s, body)
        if not g > 0.0:
            continue
        # the nodes' compressions (beyond jmax, where delta is not computed, on the modes)
        gl = he * delta[j] if j < jmax else gap_and_slope(a, basis.lam1, basis.floe, j * dx, s, body)[0]
        gr = he * delta[j + 1] if j + 1 < jmax else gap_and_slope(a, basis.lam1, basis.floe, (j + 1) * dx, s,
                                                                     body)[0]
        if gl > 0.0 or gr > 0.0:
            continue
        stop = EDGE_STOP * dx
        edges[2 * count] = contact_edge(a, basis.lam1, basis.floe, s, body, j * dx, gl, c, g, stop)
        edges[2 * count + 1] = contact_edge(a, basis.lam1, basis.floe, s, body, c, g, (j + 1) * dx, gr, stop)
        count += 1
    return count


@kernel(nrt=True)
def _pieces(body, basis, xa, xb, cuts):
    """The breakpoints of [xa, xb] at the body's corners and the plate's breaks inside it (a
    broken plate's, in its floe header): cuts[0..m] ascending, each once; returns m + 1."""
    m = 0
    cuts[0] = xa
    for c in body_corners(body):
        if xa < c < xb:
            m += 1
            cuts[m] = c
    if basis.kind != 0.0:
        header = floe_header(basis.floe)
        for i in range(int(header[BREAK_COUNT])):
            c = header[FIRST_BREAK + i]
            if xa < c < xb:
                m += 1
                cuts[m] = c
    for i in range(2, m + 1):                       # in order (insertion: a few points)
        c = cuts[i]
        k = i - 1
        while k > 0 and cuts[k] > c:
            cuts[k + 1] = cuts[k]
            k -= 1
        cuts[k + 1] = c
    kept = 0
    for i in range(1, m + 1):                       # each once
        if cuts[i] > cuts[kept]:
            kept += 1
            cuts[kept] = cuts[i]
    cuts[kept + 1] = xb
    return kept + 2


@kernel(nrt=True)
def first_panels(body, basis, edges, count):
    """The panels of the contact intervals: each cut at the body's corners, each piece into equal
    panels no wider than basis.panel. Returns the panels' ends [m], rows LO and HI."""
    cuts = np.empty(5 + MAX_BREAKS)
    total = 0
    for i in range(count):
        p = _pieces(body, basis, edges[2 * i], edges[2 * i + 1], cuts)
        for q in range(p - 1):
            total += max(1, int(math.ceil((cuts[q + 1] - cuts[q]) / basis.panel)))
    panels = np.empty((2, total))
    lo, hi = panels[LO], panels[HI]
    k = 0
    for i in range(count):
        p = _pieces(body, basis, edges[2 * i], edges[2 * i + 1], cuts)
        for q in range(p - 1):
            npan = max(1, int(math.ceil((cuts[q + 1] - cuts[q]) / basis.panel)))
            h = (cuts[q + 1] - cuts[q]) / npan
            for r in range(npan):
                lo[k] = cuts[q] + r * h
                hi[k] = cuts[q] + (r + 1) * h if r < npan - 1 else cuts[q + 1]
                k += 1
    return panels


@kernel
def gauss_nodes(basis, panels, nodes):
    """The rule's nodes and weights on the panels [lo_i, hi_i] (rows LO, HI) into the rows X and
    W of nodes (NODE_ROWS, K), m = len(gauss_x) a panel."""
    gx = basis.gauss_x
    gw = basis.gauss_w
    m = gx.shape[0]
    lo, hi = panels[LO], panels[HI]
    xk, wk = nodes[X], nodes[W]
    for i in range(lo.shape[0]):
        c = 0.5 * (lo[i] + hi[i])
        r = 0.5 * (hi[i] - lo[i])
        for g in range(m):
            xk[m * i + g] = c + r * gx[g]
            wk[m * i + g] = r * gw[g]


@kernel
def _ellipse(t):
    """rho of the Bernstein ellipse of [-1, 1] through the complex point t: |t + sqrt(t^2 - 1)|,
    the branch with rho >= 1."""
    r = t + cmath.sqrt(t - 1.0) * cmath.sqrt(t + 1.0)
    return max(abs(r), 1.0 / max(abs(r), 1e-300))


@kernel
def near_pole(dk, gx, gw, i):
    """The pieces panel i must be cut into for the paper's f = delta / (1 - delta), whose pole is
    at delta = 1 (1: resolved), from its nodes' deltas dk[m i .. m i + m - 1].

    delta over the panel, t in [-1, 1], is fitted by its Legendre series to second order from the
    nodes (delta ~ c0 + c1 t + c2 P2(t)); the roots t* of delta(t*) = 1 are where f has its
    poles. m Gauss nodes integrate f with an error ~ rho^(-2m), rho the Bernstein ellipse through
    the nearest pole: the panel is resolved when rho >= RHO_MIN (1e-12 for m = 8), otherwise cut
    into about 2 RHO_MIN / rho pieces (the next round checks them again), at most MAX_PIECES."""
    m = gx.shape[0]
    c0 = c1 = c2 = 0.0
    dmax = -1.0
    for g in range(m):
        d = dk[m * i + g]
        dmax = max(dmax, d)
        x = gx[g]
        c0 += 0.5 * gw[g] * d
        c1 += 1.5 * gw[g] * x * d
        c2 += 2.5 * gw[g] * 0.5 * (3.0 * x * x - 1.0) * d
    # (delta >= 1 at a node: bottomed, which the caller reports; nothing to resolve)
    if not (0.0 < dmax < 1.0):
        return 1
    # a fit that misses the nodes by a tenth of the distance to the pole cannot place it: halve
    # the panel (a wide panel of few modes, where the body's profile dominates delta)
    miss = 0.0
    for g in range(m):
        x = gx[g]
        miss = max(miss, abs(dk[m * i + g] - (c0 + c1 * x + c2 * 0.5 * (3.0 * x * x - 1.0))))
    if miss > FIT_MISS * (1.0 - dmax):
        return 2
    # no root inside the ellipse rho = RHO_MIN, where |t| <= ELLIPSE_T: |delta - c0| stays below
    # |c1| |t| + |c2| |P2(t)| there (most panels: no complex roots to take)
    if c0 + abs(c1) * ELLIPSE_T + abs(c2) * (1.5 * ELLIPSE_T * ELLIPSE_T + 0.5) < 1.0:
        return 1
    A = 1.5 * c2
    B = c1
    C = c0 - 0.5 * c2 - 1.0
    rho = np.inf
    if abs(A) > 1e-12 * (abs(B) + abs(C)):
        root = cmath.sqrt(complex(B * B - 4.0 * A * C, 0.0))
        rho = min(_ellipse((-B + root) / (2.0 * A)), _ellipse((-B - root) / (2.0 * A)))
    elif B != 0.0:
        rho = _ellipse(complex(-C / B, 0.0))
    if rho >= RHO_MIN:
        return 1
    return min(MAX_PIECES, max(2, int(math.ceil(2.0 * RHO_MIN / rho))))


@kernel
def cosine_table(lam1, xk, c2, table):
    """table[n, k] = cos(lambda_n x_k) (N, K), lambda_n = (n + 1) lam1, by the Chebyshev
    recurrence cos((n + 1) t) = 2 cos t cos(n t) - cos((n - 1) t), t = lam1 x_k: one
    multiply-add an entry, each row a vectorised pass over the nodes (its rounding grows as n^2
    eps near x = 0: 7e-13 at n = 120, 3e-12 at 240, far below the rule's own error); c2 (K,):
    scratch."""
    K = xk.shape[0]
    N = table.shape[0]
    if N == 0:
        return
    first = table[0]
    for k in range(K):
        c = math.cos(lam1 * xk[k])
        first[k] = c
        c2[k] = 2.0 * c
    if N > 1:
        second = table[1]
        for k in range(K):
            second[k] = c2[k] * first[k] - 1.0
    for n in range(2, N):
        row = table[n]
        r1 = table[n - 1]
        r2 = table[n - 2]
        for k in range(K):
            row[k] = c2[k] * r1[k] - r2[k]


@kernel
def _deltas(body, s, he, a, lam1, floe, nodes, table):
    """The cosine table at the nodes (row X of nodes) into table (N, K), on a floe the raw dry
    modes' (a: their coefficients), and delta there into row DELTA."""
    xk, dk = nodes[X], nodes[DELTA]
    if floe.shape[0] == 0:
        cosine_table(lam1, xk, nodes[C2], table)
    else:
        dry_table(floe, xk, table)
    modal_sum_range(a, table, dk, 0, xk.shape[0])
    for k in range(xk.shape[0]):
        dk[k] = (dk[k] + s - body_profile(xk[k], body)) / he


@kernel(nrt=True)
def _split(panels, pieces):
    """The panels of the next round: panel i cut into pieces[i] equal parts where pieces[i] > 1
    (a panel with pieces[i] == 1 is resolved and not carried)."""
    lo, hi = panels[LO], panels[HI]
    n = 0
    for i in range(lo.shape[0]):
        if pieces[i] > 1:
            n += pieces[i]
    cut = np.empty((2, n))
    lo2, hi2 = cut[LO], cut[HI]
    k = 0
    for i in range(lo.shape[0]):
        q = pieces[i]
        if q > 1:
            h = (hi[i] - lo[i]) / q
            for r in range(q):
                lo2[k] = lo[i] + r * h
                hi2[k] = lo[i] + (r + 1) * h if r < q - 1 else hi[i]
                k += 1
    return cut


@kernel(nrt=True)
def _round(layer, body, basis, s, U, modes, panels, out, flags):
    """One round of the rule on the panels [lo_i, hi_i] (rows LO, HI): the panels resolved (for
    the paper's law, not near its pole, near_pole; in the last round, or at NARROWEST, all) add
    to the RoundOut's sums, and to its P if the RoundFlags ask (he int G dx only with energy);
    returns (status, pieces), pieces[i] > 1 for the panels to cut. status 1: delta >= 1 at a
    node."""
    a, adot = modes.a, modes.adot
    lo, hi = panels[LO], panels[HI]
    sums, P, Q = out.sums, out.P, out.Q
    project, energy, last = flags.project, flags.energy, flags.last
    he = layer.he
    m = basis.gauss_x.shape[0]
    K = m * lo.shape[0]
    nodes = np.empty((NODE_ROWS, K))
    table = np.empty((a.shape[0], K))
    gauss_nodes(basis, panels, nodes)
    _deltas(body, s, he, a, basis.lam1, basis.floe, nodes, table)
    wk, dk, rate, g = nodes[W], nodes[DELTA], nodes[RATE], nodes[G]
    if layer.tau > 0.0:
        modal_sum_range(adot, table, rate, 0, K)
    pieces = np.ones(lo.shape[0], np.int64)
    g[:] = 0.0
    for i in range(lo.shape[0]):
        if layer.law == 0 and not last and hi[i] - lo[i] > NARROWEST * basis.length:
            pieces[i] = near_pole(dk, basis.gauss_x, basis.gauss_w, i)
            if pieces[i] > 1:
                continue
        for k in range(m * i, m * i + m):
            d = dk[k]
            if d > 0.0:
                if not d < 1.0:
                    return 1, pieces
                f = law_pressure(layer.law, d)
                if energy:
                    sums[2] += wk[k] * he * law_energy(layer.law, d)
                if layer.tau > 0.0:
                    r = (rate[k] + U) / he
                    gk = f * max(1.0 + layer.tau * r, 0.0)
                    sums[1] += wk[k] * (gk - f) * he * r
                    f = gk
                g[k] = wk[k] * f
                sums[0] += g[k]
    if project and K > 0:
        modal_projection(g, table, Q, K)
        for n in range(P.shape[0]):
            P[n] += Q[n]
    return 0, pieces


@kernel(nrt=True)
def gauss_sums(layer, body, basis, s, U, modes, jmax, delta, P, wanted):
    """The rule over the contact intervals found from delta at the nodes j < jmax, the Modes:
    (status, int f dx, the viscoelastic layer's power, he int G dx) without their factors
    mirror K, as Wanted: P_n = int f cos(lambda_n x) dx unscaled (on a floe,
    int f Psi_n dx), as layer_reaction leaves it, if project; the energy (else 0) if energy.
    On a floe the rule runs on the raw dry modes: their coefficients d = Q a once (floe_dry),
    then every point is O(N), and the projections come back to the wet modes (floe_wet)."""
    floe = basis.floe
    if floe.shape[0] == 0:
        return _gauss_sums(layer, body, basis, s, U, modes, jmax, delta, P, wanted)
    a, adot = modes.a, modes.adot
    N = a.shape[0]
    d = np.empty(N)
    floe_dry(floe, a, d)
    ddot = np.zeros(N)
    if layer.tau > 0.0:
        floe_dry(floe, adot, ddot)
    Pd = np.empty(N)
    st, force, power, stored = _gauss_sums(layer, body, basis, s, U, Modes(d, ddot), jmax, delta, Pd, wanted)
    if wanted.project:
        floe_wet(floe, Pd, P)
    return st, force, power, stored


@kernel(nrt=True)
def _gauss_sums(layer, body, basis, s, U, modes, jmax, delta, P, wanted):
    """gauss_sums on the basis's own table (the cosines; a floe's raw dry modes). Rounds of
    panels: the first panels, then the pieces of those near the paper law's pole."""
    project, energy = wanted.project, wanted.energy
    a = modes.a
    edges = np.empty(jmax + 8 + 4 * MAX_BREAKS)
    count = contact_intervals(body, basis, s, a, layer.he, delta, jmax, edges)
    panels = first_panels(body, basis, edges, count)
    for n in range(P.shape[0]):
        P[n] = 0.0
    sums = np.zeros(3)
    Q = np.empty(P.shape[0])
    for r in range(MAX_ROUNDS):
        st, pieces = _round(layer, body, basis, s, U, modes, panels, RoundOut(sums, P, Q),
                            RoundFlags(project, energy, r == MAX_ROUNDS - 1))
        if st != 0:
            return 1, 0.0, 0.0, 0.0
        panels = _split(panels, pieces)
        if panels.shape[1] == 0:
            break
    return 0, sums[0], sums[1], sums[2]


@kernel
def gauss_reaction(layer, body, basis, s, U, modes, jmax, delta, P, energy):
    """P_n = int f cos(lambda_n x) dx over the contact intervals (unscaled, as layer_reaction
    leaves it), given delta at the nodes j < jmax and the Modes: (status, int f dx, the viscoelastic layer's
    power without its factor mirror K, he int G dx if energy else 0). status 1: delta >= 1 at a
    node of the rule."""
    return gauss_sums(layer, body, basis, s, U, modes, jmax, delta, P, Wanted(np.bool_(True), energy))


@kernel(nrt=True)
def gauss_energy(layer, body, basis, s, a, delta, jmax):
    """he int G(delta) dx over the contact intervals on the rule's nodes (the caller's factor
    mirror K), delta at the nodes j < jmax."""
    P = np.empty(a.shape[0])
    st, _, _, energy = gauss_sums(layer, body, basis, s, 0.0, Modes(a, a), jmax, delta, P,
                                  Wanted(np.bool_(False), np.bool_(True)))
    return energy if st == 0 else np.inf


def legendre_rule(points: int):
    """Gauss-Legendre nodes and weights on [-1, 1] (numpy's), fresh arrays of numbers computed once
    per number of points (numpy's leggauss takes ~0.3 ms; a run that breaks asks for a few rules at
    each break)."""
    x, w = _legendre_rule(int(points))
    return x.copy(), w.copy()


@functools.lru_cache(maxsize=None)
def _legendre_rule(points: int):
    """legendre_rule's numbers (kept: not to be changed)."""
    x, w = np.polynomial.legendre.leggauss(points)
    return np.ascontiguousarray(x), np.ascontiguousarray(w)
