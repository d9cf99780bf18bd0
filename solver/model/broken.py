r"""A plate (walled, or a floe) broken into parts: its wet modes over the water its parts share, and
the state carried across a break (docs/model.md, "Breaking into parts", "A floe breaks"). The
parts' dry modes and the channel's added mass are solver.model.parts's, a floe's water
solver.model.floe_parts's; the formulas are in solver.model.parts's docstring ("Wet modes", "The
state across a break").

Benchmarks (tests/test_parts.py, tests/test_floe_parts.py): the unbroken plate as one sliding part,
whose wet modes are the walled plate's cosines to round-off; a carry from a plate to itself is the
identity, to more breaks it keeps each energy or less.
"""
from __future__ import annotations

import math

import numpy as np

from ..blas import blas_alone
from .floe_parts import floe_added_mass
from .parts import (CARRY_TERMS, SPAN_TOLERANCE, PartModes, WetParts, channel_added_mass, cosine_integrals,
                    edge_shaped, end_values, gauss_rule, gram, mode_block, mode_means, part_lengths, part_modes,
                    part_values)


def water(p, modes: PartModes, domain: float, mirror: float, other: PartModes | None = None) -> np.ndarray:
    """The added mass [kg m-1] of the dry modes (with ``other``, between them and other's): the
    walls' channel (channel_added_mass), or a floe's half-plane (solver.model.floe_parts)."""
    if p.edges == "free":
        return floe_added_mass(modes, p.L, mirror == 1.0, p.rho_w, p.H, other)
    return channel_added_mass(modes, domain, mirror, p.rho_w, p.H, 0 if other is None else CARRY_TERMS, other)


def wet_parts(p, domain: float, mirror: float, breaks, beta_max: float, springs=None) -> WetParts:
    """The wet modes of the plate (or floe) of parameters p broken at ``breaks`` on the kernel's
    domain [0, domain] (module docstring); ``springs`` {b: k}: the breaks b that are cracks only
    part through the thickness, each a rotational spring of stiffness k [N m rad-1 m-1]
    (crack_springs)."""
    from scipy.linalg import cholesky, eigh, null_space, solve_triangular      # (a broken plate's tables only)
    floe = p.edges == "free"
    modes = part_modes(domain, breaks, beta_max, p.edge_shapes, (mirror == 2.0 or not floe, not floe))
    held, K_springs = crack_springs(modes, mirror, springs or {})
    # q = Z r keeps int w dx = 0 between walls (a floe's volume is free) and w continuous at a crack
    rows = held if floe else np.vstack([mode_means(modes)[None, :], held])
    A = water(p, modes, domain, mirror)
    if np.any(edge_shaped(modes)):
        G0 = gram(modes, 0)
        T = shaped_span(modes, G0)                         # the dry modes kept, each at unit mass
        Z = T @ eliminated(rows @ T) if rows.shape[0] else T
        M = mirror * p.plate_mass * G0 + A
        Kr = Z.T @ (mirror * (p.rigidity * gram(modes, 2) + p.rho_w * p.g * G0) + K_springs) @ Z
    else:
        Z = null_space(rows) if rows.shape[0] else np.eye(modes.kinds.size)
        G = part_lengths(modes)
        M = mirror * p.plate_mass * np.diag(G) + A
        K = mirror * (p.rigidity * modes.betas**4 + p.rho_w * p.g) * G
        Kr = Z.T @ (K[:, None] * Z) + (Z.T @ K_springs @ Z if springs else 0.0)
    Mr = Z.T @ M @ Z
    R = cholesky(0.5 * (Kr + Kr.T))                       # Kr = R^T R
    S = solve_triangular(R, solve_triangular(R, Mr, trans="T").T, trans="T")      # R^-T Mr R^-1
    mu, V = eigh(0.5 * (S + S.T))                         # mu = 1 / omega^2
    order = np.argsort(-mu)
    mu, V = mu[order], V[:, order]
    Q = Z @ solve_triangular(R, V) / np.sqrt(mu)[None, :]     # Q^T M Q = I, Q^T K Q = diag(1 / mu)
    return WetParts(1.0 / np.sqrt(mu), Q, modes, float(domain), float(mirror))


def shaped_span(modes: PartModes, G0) -> np.ndarray:
    """(Nd, Nk): the dry modes a plate with edge shapes keeps, each scaled to a unit int psi^2 dx
    (columns of the identity over the square roots of G0's diagonal). A part's modes are kept; its
    edge shapes one by one in their order (EDGE_FACTORS, the whole part's last), each where the
    share of its mass that the part's modes and the shapes kept before it leave out (its Schur
    complement at unit mass) is at least SPAN_TOLERANCE. A shape dropped is one the others nearly
    span. Rotating to the mass's eigenvectors and dropping the smallest, as wet_parts did until
    breaking 13, let round-off into the parts' heave and pitch (their wet frequencies 2.5 % off
    at N = 240 with 4 shapes: docs/model.md, "Edge shapes")."""
    scale = 1.0 / np.sqrt(np.diag(G0))
    unit = scale[:, None] * G0 * scale[None, :]
    edge, keep = edge_shaped(modes), ~edge_shaped(modes)
    for m in np.flatnonzero(edge):
        on = np.flatnonzero(keep & (modes.parts == modes.parts[m]))
        g = unit[on, m]
        if unit[m, m] - g @ np.linalg.solve(unit[np.ix_(on, on)], g) >= SPAN_TOLERANCE:
            keep[m] = True
    kept = np.flatnonzero(keep)
    T = np.zeros((modes.kinds.size, kept.size))
    T[kept, np.arange(kept.size)] = scale[kept]
    return T


def eliminated(rows) -> np.ndarray:
    """(k, k - C): a basis of the null space of rows (C, k) that eliminates C of the k amplitudes
    (chosen by QR with column pivoting) and leaves the others as they are: an orthonormal basis
    (null_space) mixes every amplitude into each column, and the parts' heave and pitch, whose
    stiffness is rho_w g beside the boundary layers' D beta_max^4, would take its round-off."""
    from scipy.linalg import qr
    _, order = qr(rows, mode="r", pivoting=True)
    pivots, free = order[:rows.shape[0]], np.sort(order[rows.shape[0]:])
    Z = np.zeros((rows.shape[1], free.size))
    Z[free, np.arange(free.size)] = 1.0
    Z[pivots] = -np.linalg.solve(rows[:, pivots], rows[:, free])
    return Z


def crack_springs(modes: PartModes, mirror: float, springs: dict):
    """(rows (C, Nd), K (Nd, Nd)) of cracks that hold the parts together as rotational springs
    (the line-spring model of a part-through crack; docs/model.md, "A crack as a spring"): at each
    crack b (a break of the parts) w is continuous, rows . q = 0 (w(b-) - w(b+); none at the half
    plate's centre, continuous by symmetry), and the spring's energy k (w'(b+) - w'(b-))^2 / 2 adds
    mirror k d d^T to the stiffness, d the slope jump of each dry mode; at the half plate's centre
    the jump is 2 w'(0+), mirror 2 k d d^T."""
    value, slope = end_values(modes, 0), end_values(modes, 1)
    rows, K = [], np.zeros((modes.kinds.size, modes.kinds.size))
    for b, k in sorted(springs.items()):
        above, below = modes.lows == b, modes.highs == b
        if not np.any(above) or not (np.any(below) or mirror == 2.0):
            raise ValueError(f"a crack spring at {b} m needs a break inside the plate there (or at the half "
                             f"plate's centre)")
        d = np.where(above, slope[:, 0], 0.0) - np.where(below, slope[:, 1], 0.0)
        if np.any(below):
            rows.append(np.where(below, value[:, 1], 0.0) - np.where(above, value[:, 0], 0.0))
            K += mirror * k * np.outer(d, d)
        else:                                             # the half plate's centre
            K += mirror * 2.0 * k * np.outer(d, d)
    return (np.array(rows) if rows else np.zeros((0, modes.kinds.size))), K


def cosine_state_energy(p, domain: float, mirror: float, a, adot) -> tuple[float, float]:
    """(kinetic, potential) energy [J m-1] of the unbroken plate's state a, a' on the cosines
    cos(n pi x / domain), n = 1..N: sum_n mirror (domain / 2) M_n (a_n'^2, omega_n^2 a_n^2) / 2."""
    lam = math.pi * np.arange(1, np.size(a) + 1) / domain
    M, omega, _ = p.mode_constants(lam)
    weight = mirror * 0.5 * domain * M
    return 0.5 * float(np.sum(weight * np.asarray(adot) ** 2)), 0.5 * float(np.sum(weight * omega**2 * np.asarray(a) ** 2))


@blas_alone
def carry_state(p, wet: WetParts, a, adot):
    """The wet amplitudes (b, b') of the broken plate that carry the unbroken plate's state a, a'
    (on the cosines cos(n pi x / domain), n = 1..N) across the break: the displacement projected
    in the stiffness, the velocity in the mass (module docstring)."""
    lam = math.pi * np.arange(1, np.size(a) + 1) / wet.domain
    M, omega, _ = p.mode_constants(lam)
    X = wet.mirror * cosine_integrals(wet.modes, lam)                 # <psi_m, cos_n>
    bending = np.zeros_like(X)                                         # <psi_m'', cos_n''>
    for part in np.unique(wet.modes.parts):
        on = np.flatnonzero(wet.modes.parts == part)
        # one rule for the part: panels for its fastest mode against the fastest cosine
        x, w = gauss_rule(wet.modes, on[np.argmax(wet.modes.betas[on])], np.max(lam))
        sub = PartModes(*(field[on] for field in wet.modes))
        curvature = sub.norms[:, None] * mode_block(sub, x, 2)
        bending[on] = -wet.mirror * lam**2 * ((curvature * w) @ np.cos(np.outer(x, lam)))
    stiffness = p.rigidity * bending + p.rho_w * p.g * X
    b = (wet.Q.T @ (stiffness @ np.asarray(a))) / wet.omega**2
    bdot = wet.Q.T @ ((X * M[None, :]) @ np.asarray(adot))
    return b, bdot


@blas_alone
def carry_parts(p, old: WetParts, new: WetParts, b, bdot):
    """The wet amplitudes (b, b') of a plate broken further (new: its parts refine old's) that
    carry the state b, b' of the plate broken at fewer places across the new breaks: as
    carry_state, the displacement projected in the stiffness and the velocity in the mass, here
    with the cross integrals of the new dry modes and the old (each new part lies in one old
    part, where the old modes are smooth) and the water's added mass between them."""
    added = water(p, new.modes, new.domain, new.mirror, other=old.modes)
    G = np.empty((new.modes.kinds.size, old.modes.kinds.size))    # <psi_m, phi_j>
    bending = np.empty_like(G)                                      # <psi_m'', phi_j''>
    for part in np.unique(new.modes.parts):
        on = np.flatnonzero(new.modes.parts == part)
        # one rule for the part: panels for its fastest mode against the old fastest
        x, w = gauss_rule(new.modes, on[np.argmax(new.modes.betas[on])], np.max(old.modes.betas))
        sub = PartModes(*(field[on] for field in new.modes))
        G[on] = (part_values(sub, x) * w) @ part_values(old.modes, x).T
        bending[on] = (part_values(sub, x, 2) * w) @ part_values(old.modes, x, 2).T
    stiffness = new.mirror * (p.rigidity * bending + p.rho_w * p.g * G)
    mass = new.mirror * p.plate_mass * G + added
    b_new = (new.Q.T @ (stiffness @ (old.Q @ np.asarray(b)))) / new.omega**2
    bdot_new = new.Q.T @ (mass @ (old.Q @ np.asarray(bdot)))
    return b_new, bdot_new


def wet_energy(wet: WetParts, b, bdot) -> tuple[float, float]:
    """(kinetic, potential) energy [J m-1] of the broken plate's wet amplitudes."""
    return 0.5 * float(np.sum(np.asarray(bdot) ** 2)), 0.5 * float(np.sum(wet.omega**2 * np.asarray(b) ** 2))


def wet_values(wet: WetParts, x, order=0) -> np.ndarray:
    """(Nw, X): the wet modes Psi_k (or a derivative) at x [m]."""
    return wet.Q.T @ part_values(wet.modes, x, order)
