r"""A floe broken into parts: the water its parts share (docs/model.md, "A floe breaks"). The parts,
their wet modes, the carry and the tables are the walled plate's (solver.model.parts,
solver.model.broken, solver.model.part_tables); what differs is the water, the half-plane's with
phi = 0 on the open surface (solver.model.floe), and that a floe's ends are free and its volume
not fixed.

**The added mass of the parts' modes.** With x = L cos t on the floe (plate coordinates), the floe's
added mass of shapes psi_m, psi_n is

    A_mn = rho_w L^2 (pi/2) sum_k p_mk p_nk / k,   p_mk = (2/pi) int_0^pi f_m(t) sin(k t) dt,

f_m(t) = psi_m(L cos t) sin t (solver.model.floe). A part's mode lives on one interval of t (two
on the half floe of a centred impact, whose modes stand for their mirror psi(|x|) too) and jumps
to zero at its ends, so p_mk falls as 1 / k only: each p_mk, k <= K, is taken by Gauss-Legendre
on the mode's intervals (panels of at most FLOE_PANEL / (k_max + beta L) in t, _t_rule), and the
sum beyond K in closed form to its second order. Integrating by parts twice,

    p_mk = (2/pi) sum_tau [J_m(tau) cos(k tau) / k - J'_m(tau) sin(k tau) / k^2] + O(k^-3),

J_m(tau) and J'_m(tau) the jumps of f_m and f_m' across the interval ends tau (0 at t = 0 and pi,
where sin t = 0), so that sum_{k > K} p_mk p_nk / k is the walls' tail (parts.jump_tail) with
cos(k tau) for sin(k e): the sums sum_{k > K} cos(k theta) / k^3, sin(k theta) / k^4 and
cos(k theta) / k^5 over the pairs tau +- sigma (solver.model.tails). On depth H the sum to K
takes the floe's depth-corrected Galerkin matrix (solver.model.depth), the tail the deep one
(the correction falls exponentially in k).

Benchmarks (tests/test_floe_parts.py): the unbroken floe as one part gives the floe's added mass
(solver.model.floe.added_mass, by the trapezoid rule); a part's coefficients against a brute-force
sum to many more terms; a floe broken at its centre on the half and the whole floe.
"""
from __future__ import annotations

import math

import numpy as np

from .depth import depth_correction
from .parts import GAUSS32_W, GAUSS32_X, PartModes, WetParts, by_part, end_values, values_at
from .tails import cosine_tail, power_tail

#: a Gauss-Legendre panel of 32 nodes in t spans at most FLOE_PANEL / k_max: about 3.8 periods
#: of the fastest sine, whose rule's error is then below 1e-18 (the same matrix as at 8 to 5e-15)
FLOE_PANEL = 24.0
#: the terms of the added mass's series summed before its tail: at least FLOE_TERMS, and
#: TERMS_PER_BETA beta_max L where that is more (the tail's expansion in 1 / k holds beyond the
#: modes' own oscillation in t, beta L)
FLOE_TERMS, TERMS_PER_BETA = 1024, 4.0


def floe_terms(modes: PartModes, L: float) -> int:
    """The terms K summed before the tail (FLOE_TERMS, TERMS_PER_BETA)."""
    return max(FLOE_TERMS, int(TERMS_PER_BETA * float(np.max(modes.betas)) * L) + 1)


def _intervals(lo, hi, L, full):
    """The t-intervals [(t0, t1, sign_of_x)] of the plate part [lo, hi] (kernel coordinates: x =
    lo - L on the whole floe, x = lo on the half floe, which adds its mirror [-hi, -lo])."""
    if full:
        return [(math.acos(min(1.0, (hi - L) / L)), math.acos(max(-1.0, (lo - L) / L)), 1.0)]
    out = [(math.acos(min(1.0, hi / L)), math.acos(max(-1.0, lo / L)), 1.0)]
    return out + [(math.acos(max(-1.0, -lo / L)), math.acos(max(-1.0, -hi / L)), -1.0)]


def _t_rule(t0, t1, frequency):
    """Gauss-Legendre of 32 nodes on panels of [t0, t1] at most FLOE_PANEL / frequency long."""
    panels = int(frequency * (t1 - t0) / FLOE_PANEL) + 1
    edges = np.linspace(t0, t1, panels + 1)
    half = 0.5 * np.diff(edges)
    t = (edges[:-1] + half)[:, None] + half[:, None] * GAUSS32_X[None, :]
    return t.ravel(), (half[:, None] * GAUSS32_W[None, :]).ravel()


def _kernel_x(t, L, full, sign):
    """Kernel coordinates of the points L cos t (on the half floe, of |x|: the mirror's)."""
    x = L * np.cos(t)
    return x + L if full else sign * x


def sine_rows(modes: PartModes, L: float, full: bool, K: int) -> np.ndarray:
    """(Nd, K): p_mk of the module docstring, k = 1..K, each part's rows once (parts.by_part)."""
    def rows(sub):
        out = np.zeros((sub.kinds.size, K))
        frequency = K + float(np.max(sub.betas)) * L + 1.0
        k = np.arange(1, K + 1)
        for t0, t1, sign in _intervals(sub.lows[0], sub.highs[0], L, full):
            if t1 <= t0:
                continue
            t, w = _t_rule(t0, t1, frequency)
            x = np.clip(_kernel_x(t, L, full, sign), sub.lows[0], sub.highs[0])
            f = values_at(sub, x, 0, sub.highs[0]) * np.sin(t)[None, :]
            out += (f * w) @ np.sin(np.outer(t, k))
        return (2.0 / math.pi) * out
    return by_part(modes, ("floe sines", float(L), bool(full), int(K)), rows, K)


def _jumps(modes: PartModes, L: float, full: bool):
    """(taus (E,), J (E, Nd), J' (E, Nd)): the interval ends tau in (0, pi) and each mode's jump of
    f = psi(L cos t) sin t and of f' = -L sin^2 t psi'(x) + cos t psi(x) across them (the value
    above tau less the value below; a mode is 0 outside its intervals)."""
    value, slope = end_values(modes, 0), end_values(modes, 1)        # (Nd, 2): at lo, hi (kernel)
    entries = []
    for m in range(modes.kinds.size):
        lo, hi = modes.lows[m], modes.highs[m]
        for t0, t1, sign in _intervals(lo, hi, L, full):
            # t0 is x's upper end (hi on the plate, -lo on the mirror), t1 its lower end
            for tau, end, side in ((t0, 1 if sign > 0 else 0, 1.0), (t1, 0 if sign > 0 else 1, -1.0)):
                if not 0.0 < tau < math.pi:
                    continue
                s, c = math.sin(tau), math.cos(tau)
                v, d = value[m, end], sign * slope[m, end]        # psi and d psi / dx at x = L cos tau
                entries.append((tau, m, side * v * s, side * (-L * s * s * d + c * v)))
    taus = np.unique([e[0] for e in entries]) if entries else np.zeros(0)
    J, Jp = np.zeros((taus.size, modes.kinds.size)), np.zeros((taus.size, modes.kinds.size))
    for tau, m, j, jp in entries:
        i = np.searchsorted(taus, tau)
        J[i, m] += j
        Jp[i, m] += jp
    return taus, J, Jp


def floe_tail(modes: PartModes, other: PartModes, L: float, full: bool, K: int) -> np.ndarray:
    """(Nd, No): sum_{k > K} p_mk p_nk / k to the tail's second order (module docstring)."""
    tm, J, Jp = _jumps(modes, L, full)
    to, Jo, Jpo = (tm, J, Jp) if other is modes else _jumps(other, L, full)
    if tm.size == 0 or to.size == 0:
        return np.zeros((modes.kinds.size, other.kinds.size))
    minus, plus = tm[:, None] - to[None, :], tm[:, None] + to[None, :]
    C3 = 0.5 * (cosine_tail(minus, K) + cosine_tail(plus, K))              # cos(k tau) cos(k sigma)
    s_plus, s_minus = np.imag(power_tail(plus, K, 4)), np.imag(power_tail(minus, K, 4))
    CS, SC = 0.5 * (s_plus - s_minus), 0.5 * (s_plus + s_minus)             # cos sin, sin cos
    C5 = 0.5 * (np.real(power_tail(minus, K, 5)) - np.real(power_tail(plus, K, 5)))   # sin sin
    out = J.T @ C3 @ Jo - J.T @ CS @ Jpo - Jp.T @ SC @ Jo + Jp.T @ C5 @ Jpo
    return (4.0 / math.pi**2) * out


def floe_added_mass(modes: PartModes, L: float, full: bool, rho_w: float, H: float = math.inf,
                    other: PartModes | None = None) -> np.ndarray:
    """A_mn [kg m-1] of the parts' dry modes under a floe of half-length L (module docstring): on the
    whole floe (full, kernel coordinates 0..2L) or the half floe of a centred impact (0..L, each
    mode standing for its mirror too); with ``other``, between modes (rows) and other's modes."""
    other = modes if other is None else other
    K = max(floe_terms(modes, L), floe_terms(other, L))
    P = sine_rows(modes, L, full, K)
    P_other = P if other is modes else sine_rows(other, L, full, K)
    k = np.arange(1, K + 1)
    if math.isfinite(H):
        G = np.diag(np.pi * k / 2.0) - depth_correction(K, L, H)
        head = (L * np.pi / 2.0) ** 2 * P @ np.linalg.solve(G, P_other.T)
    else:
        head = L * L * (np.pi / 2.0) * (P / k) @ P_other.T
    return rho_w * (head + L * L * (np.pi / 2.0) * floe_tail(modes, other, L, full, K))


def unbroken_floe(tables: dict, L: float, full: bool):
    """(WetParts, scale): the unbroken floe's wet modes (solver.model.floe.floe_tables' dict) as a
    broken plate's with one part, in kernel coordinates (the whole floe 0..2L about L, or the
    half floe 0..L about 0), so that a state on them carries across a break as between parts
    (broken.carry_parts); scale: the kernel's amplitude of wet mode k is b_k scale_k."""
    kinds, betas, norms = tables["kinds"], tables["betas"], tables["norms"]
    n, domain = kinds.size, (2.0 if full else 1.0) * L
    scale = 1.0 / np.sqrt(tables["mass"])
    modes = PartModes(kinds, betas, np.full(n, L if full else 0.0), np.full(n, L), np.zeros(n), np.full(n, domain),
                      norms, np.zeros(n, dtype=int))
    return WetParts(tables["omega"], tables["Q"] * scale[None, :], modes, domain, 1.0 if full else 2.0), scale
