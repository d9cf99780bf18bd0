r"""The tension at which the ice breaks by finite fracture mechanics: the coupled stress and energy
criterion (Leguillon 2002, Eur. J. Mech. A/Solids 21, 61) on the ice's bending (docs/model.md,
"The coupled stress and energy criterion"; not yet an option of a run: issue 77).

A crack of depth l forms at once at the surface in tension, under the bending moment M per unit
width, where both hold:

- **stress**: the uncracked ice's stress reaches the tensile strength sigma_c all along its path,
  sigma_s (1 - 2 y / h) >= sigma_c for 0 <= y <= l (sigma_s = 6 M / h^2 at the surface): M >=
  M_s(l) = sigma_c h^2 / (6 (1 - 2 l / h));
- **energy**: the energy it releases at the moment held pays for its faces, the incremental energy
  release rate G_inc(l) = (1 / l) int_0^l G(a) da = M^2 C(l) / (2 l) >= G_c = K_IC^2 (1 - nu^2) / E
  (C the line spring's compliance, solver.model.line_spring, whose C' / 2 M^2 is G): M >= M_e(l) =
  sqrt(2 G_c l / C(l)).

M_s grows with l and M_e falls (C grows as l^2 for a short crack), so the least moment at which a
crack forms is where they meet: M_c = M_s(l*) = M_e(l*). In bending K_I grows with a at a given
moment, so that crack runs through: M_c breaks the ice. As the run's break level (the surface
strain eps = 6 M (1 - nu^2) / (E h^2), as solver.breaking reads it):

    eps_c = sigma_c (1 - nu^2) / (E (1 - 2 l* / h)).

Ice much thicker than l* breaks at its tensile strength, eps_c -> sigma_c (1 - nu^2) / E, l* ->
2 K_IC^2 / (pi F(0)^2 sigma_c^2) (F(0) = 1.122); thinner ice needs more (the size effect of
flexural strength), l* -> h / 2 as h -> 0.

Benchmarks (tests/test_coupled_criterion.py): both limits; the meeting point against a
brute-force minimum over l of max(M_s, M_e); the size effect.
"""
import math
from types import SimpleNamespace

from scipy.optimize import brentq

from .line_spring import bending_factor, crack_compliance


def coupled_break(E: float, nu: float, hi: float, tensile_strength: float, toughness: float) -> tuple[float, float]:
    """(eps_c [1], l* [m]): the surface strain at which ice of Young's modulus E [Pa], Poisson's
    ratio nu, thickness hi [m], tensile strength sigma_c [Pa] and fracture toughness K_IC
    [Pa m^1/2] breaks, and the depth of the crack that forms (module docstring)."""
    ice = SimpleNamespace(E=E, nu=nu, hi=hi)
    energy = toughness**2 * (1.0 - nu**2) / E                 # G_c [J m-2]

    def excess(depth):                                        # log(M_e / M_s): falls through 0 at l*
        m_stress = tensile_strength * hi**2 / (6.0 * (1.0 - 2.0 * depth / hi))
        return 0.5 * math.log(2.0 * energy * depth / crack_compliance(ice, depth)) - math.log(m_stress)
    low, high = 1e-12 * hi, 0.5 * hi * (1.0 - 1e-12)
    if excess(high) >= 0.0:          # (not for any finite sigma_c and K_IC: M_s -> inf at h / 2)
        raise ValueError("the coupled criterion has no crack shorter than half the ice's thickness")
    depth = low if excess(low) <= 0.0 else brentq(excess, low, high, xtol=1e-15 * hi, rtol=1e-14)
    return tensile_strength * (1.0 - nu**2) / (E * (1.0 - 2.0 * depth / hi)), depth


def short_crack_depth(tensile_strength: float, toughness: float) -> float:
    """l* [m] in ice much thicker than it: 2 K_IC^2 / (pi F(0)^2 sigma_c^2) (module docstring)."""
    return 2.0 * toughness**2 / (math.pi * float(bending_factor(0.0)) ** 2 * tensile_strength**2)
