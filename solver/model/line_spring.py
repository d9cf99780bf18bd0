r"""A crack part through the ice's thickness as a rotational spring: the line-spring model (Rice and
Levy 1972, J. Appl. Mech. 39, 185; as Korobkin and Khabakhpasheva model floating ice after it
cracks, J. Mar. Sci. Eng. 10, 833, 2022). docs/model.md, "A crack as a spring".

A surface crack of depth a in ice of thickness h, under a bending moment M per unit width, has the
stress intensity factor

    K_I = sigma sqrt(pi a) F(a / h),   sigma = 6 M / h^2,

F the edge-cracked strip's in pure bending (Tada, Paris and Irwin, The Stress Analysis of Cracks
Handbook, 3rd ed., 2000, 2.13: within 0.5 % for any a / h),

    F(s) = sqrt(2 tan(pi s / 2) / (pi s)) [0.923 + 0.199 (1 - sin(pi s / 2))^4] / cos(pi s / 2).

The energy it releases as it grows, G = K_I^2 (1 - nu^2) / E (plane strain) = M^2 C'(a) / 2, makes
the crack a hinge with a rotational spring: the slopes on its two sides differ by C(a) M,

    C(a) = 72 pi (1 - nu^2) / (E h^2) int_0^(a/h) s F(s)^2 ds   [rad m N-1 per metre of width],

its stiffness k = 1 / C(a) [N m rad-1 m-1]: infinite for no crack (a = 0: the ice whole), zero
through the thickness (a = h: a hinge that holds w continuous; a break, solver.breaking, also lets
w jump). The broken plate's wet modes with such springs: solver.model.broken.wet_parts(springs=).

Benchmarks (tests/test_crack_spring.py): F against Tada's table (F(0.5) = 1.50 there), C's small-
crack limit, and the spring's two limits on the plate's wet frequencies (the whole plate, and the
finite elements' hinge).
"""
import math

import numpy as np

from .quadrature import legendre_rule

#: Gauss-Legendre nodes of crack_compliance's integral (its integrand is smooth on [0, a/h] < 1)
COMPLIANCE_NODES = 64


def bending_factor(s):
    """F(s) of the edge-cracked strip in pure bending, s = a / h in [0, 1) (module docstring)."""
    s = np.asarray(s, dtype=float)
    half = 0.5 * math.pi * s
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(s > 0.0, np.tan(half) / np.where(s > 0.0, half, 1.0), 1.0)
    return np.sqrt(ratio) * (0.923 + 0.199 * (1.0 - np.sin(half)) ** 4) / np.cos(half)


def crack_compliance(p, depth: float) -> float:
    """C(a) [rad m N-1 per metre of width] of a surface crack of depth a = ``depth`` [m] in the ice of
    parameters p (E, nu, hi): module docstring, by Gauss-Legendre."""
    s_max = depth / p.hi
    if not 0.0 <= s_max < 1.0:
        raise ValueError(f"a crack's depth must lie in [0, hi), got {depth} m in {p.hi} m ice")
    x, w = legendre_rule(COMPLIANCE_NODES)
    s = 0.5 * s_max * (x + 1.0)
    integral = 0.5 * s_max * float(np.sum(w * s * bending_factor(s) ** 2))
    return 72.0 * math.pi * (1.0 - p.nu**2) / (p.E * p.hi**2) * integral


def crack_stiffness(p, depth: float) -> float:
    """k = 1 / C(a) [N m rad-1 m-1] of a crack of depth ``depth`` [m] (inf with no crack)."""
    compliance = crack_compliance(p, depth)
    return math.inf if compliance == 0.0 else 1.0 / compliance


def stress_intensity(p, depth: float, moment: float) -> float:
    """K_I [Pa m^1/2] of a crack of depth ``depth`` [m] under the moment ``moment`` [N m m-1]."""
    return 6.0 * moment / p.hi**2 * math.sqrt(math.pi * depth) * float(bending_factor(depth / p.hi))
