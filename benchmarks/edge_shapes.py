"""What edge shapes would do for the state carried across a break (issue 76, item 1; docs/model.md,
"The run that breaks"): the reference case's first break (the centre, N modes, its state at the
located break) carried onto the broken plate's dry modes as the solver builds them, and onto the
same modes with edge shapes added at the free edge: cosh(beta (x - c)) / cosh(beta l) about the
part's sliding end (a boundary layer at the break, with w'' and w''' not 0 there, which every
free-free mode has 0), beta a fraction of the parts' beta_max. For each: the energy the carry
leaves out (potential, kinetic, and of the plate's), and the largest wet frequency beside the
cosines' omega_N.

    python benchmarks/edge_shapes.py [--modes 20 30 60 120]

The carry is the solver's (solver.model.parts.carry_state's projection, the displacement in the
stiffness and the velocity in the mass), on the full mass and stiffness matrices of the enriched
modes (the edge shapes are not orthogonal to the others). The solver itself does not have them
yet: with them, a free edge's curvature is no longer 0 in the basis, and where its tension is
looked for at the edge (a run breaks there again, or ends wall_break) is still to be decided.
"""
from __future__ import annotations

import argparse
import contextlib
import math

import numpy as np
from scipy.linalg import eigh, null_space

from solver import Parameters, Settings, solve
from solver.model import floe as fl
from solver.model import parts

#: the kind this script gives an edge shape (the solver's kinds stop at parts.COSINE)
EDGE = 5.0
#: the sets of edge shapes measured: their wavenumbers as fractions of beta_max
FACTORS = ((), (1.0,), (0.5, 1.0), (0.25, 0.5, 1.0))


@contextlib.contextmanager
def edge_kind():
    """parts.raw_mode knowing EDGE (cosh(beta x) / cosh(beta l) about the centre) while inside:
    the closed-form cosine integrals, the means and the Gauss rules of solver.model.parts then
    take the edge shapes as they are (the fourth derivative is beta^4 times the shape for them too)."""
    original = parts.raw_mode

    def raw_mode(kind, beta, centre, half, x, order=0):
        if kind == EDGE:
            return fl._hyperbolic(beta, np.asarray(x, float) - centre, half, order, True)
        return original(kind, beta, centre, half, x, order)
    parts.raw_mode = raw_mode
    try:
        yield
    finally:
        parts.raw_mode = original


def with_edges(modes, factors):
    """The modes of the plate broken at its centre (one part, free at 0, sliding at the wall) and
    an edge shape about the sliding end for each factor."""
    lo, hi, part = modes.lows[0], modes.highs[0], modes.parts[0]
    beta_max = np.max(modes.betas)
    rows = [tuple(field[m] for field in modes) for m in range(modes.kinds.size)]
    rows += [(EDGE, f * beta_max, hi, hi - lo, lo, hi, 1.0, part) for f in factors]
    columns = list(zip(*rows))
    return parts.PartModes(*(np.array(c, dtype=float) for c in columns[:-1]), np.array(columns[-1], int))


def gram(modes, order):
    """int psi_m^(order) psi_n^(order) dx over the part (Gauss-Legendre, exact to round-off)."""
    x, w = parts._gauss(modes, int(np.argmax(modes.betas)), np.max(modes.betas))
    values = parts.part_values(modes, x, order)
    return (values * w) @ values.T


def carried(p, modes, a, adot):
    """(energy left out of the potential, of the kinetic, of the plate's; largest wet omega) of
    the unbroken plate's state (a, adot on the cosines) carried onto modes."""
    domain, mirror = p.L, 2.0
    G0, G2 = gram(modes, 0), gram(modes, 2)
    M = mirror * p.plate_mass * G0 + parts.channel_added_mass(modes, domain, mirror, p.rho_w, p.H)
    K = mirror * (p.rigidity * G2 + p.rho_w * p.g * G0)
    Z = null_space(parts.mode_means(modes)[None, :])
    omega2, V = eigh(Z.T @ K @ Z, Z.T @ M @ Z)
    Q = Z @ V                                                    # Q^T M Q = I
    lam = math.pi * np.arange(1, a.size + 1) / domain
    Mn, _, _ = p.mode_constants(lam)
    X = mirror * parts.cosine_integrals(modes, lam)               # <psi_m, cos_n>
    x, w = parts._gauss(modes, int(np.argmax(modes.betas)), np.max(lam))
    bending = -mirror * lam**2 * ((parts.part_values(modes, x, 2) * w) @ np.cos(np.outer(x, lam)))
    b = (Q.T @ ((p.rigidity * bending + p.rho_w * p.g * X) @ a)) / omega2
    bdot = Q.T @ ((X * Mn[None, :]) @ adot)
    kinetic, potential = parts.cosine_state_energy(p, domain, mirror, a, adot)
    k2, p2 = 0.5 * np.sum(bdot**2), 0.5 * np.sum(omega2 * b**2)
    return ((potential - p2) / potential, (kinetic - k2) / kinetic,
            (kinetic + potential - k2 - p2) / (kinetic + potential), math.sqrt(np.max(omega2)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, nargs="+", default=[20, 30, 60, 120])
    args = parser.parse_args()
    print("| N | edge shapes (beta / beta_max) | dry modes | potential left out | kinetic left out | "
          "plate's left out | largest omega / omega_N |")
    print("|---|---|---|---|---|---|---|")
    for N in args.modes:
        p = Parameters(Nmod=N)
        first = solve(p, Settings(quadrature="gauss", tolerance=1e-10), fields=(), t_end=2e-3, times=[0.0, 2e-3],
                      break_strain=8e-5)
        state = first.end.state
        base = parts.part_modes(p.L, [0.0], math.pi * N / p.L)
        omega_N = p.mode_constants(np.array([math.pi * N / p.L]))[1][0]
        for factors in FACTORS:
            modes = with_edges(base, factors)
            parts._PART_ROWS.clear()
            with edge_kind():
                left_p, left_k, left, omega = carried(p, modes, np.asarray(state.amplitudes),
                                                      np.asarray(state.velocities))
            print(f"| {N} | {', '.join(f'{f:g}' for f in factors) or 'none'} | {modes.kinds.size} | {left_p:.2e} | "
                  f"{left_k:.2e} | {left:.2e} | {omega / omega_N:.1f} |", flush=True)


if __name__ == "__main__":
    main()
