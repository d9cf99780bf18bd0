"""A crack part through the thickness as a rotational spring (solver/model/line_spring.py, and the
broken plate's wet modes with such springs, solver.model.broken.wet_parts(springs=); docs/model.md,
"A crack as a spring"): the line-spring model's factors against the literature's other fit and
its own energy balance, and the spring's two limits on the plate: no crack (the whole plate) and
a crack through (a hinge, against the finite elements)."""
import math

import numpy as np
import pytest

from fe_reference import Plate, mesh
from solver import Parameters
from solver.model import broken
from solver.model.line_spring import bending_factor, crack_compliance, crack_stiffness, stress_intensity


def test_the_bending_factor_is_the_literatures():
    """Tada's closed form of F(a / h) in pure bending against Brown and Srawley's polynomial
    1.122 - 1.40 s + 7.33 s^2 - 13.08 s^3 + 14.0 s^4 (s <= 0.6): the same 1.122 at s = 0 (the edge
    crack's), within 2.5 % up to 0.6 (2.2 % measured: the two fits' own spread)."""
    s = np.linspace(0.0, 0.6, 61)
    polynomial = 1.122 - 1.40 * s + 7.33 * s**2 - 13.08 * s**3 + 14.0 * s**4
    assert bending_factor(0.0) == pytest.approx(1.122, abs=1e-12)
    assert np.max(np.abs(bending_factor(s) / polynomial - 1.0)) < 0.025


@pytest.mark.parametrize("depth", [0.05, 0.25, 0.45])
def test_the_spring_releases_the_cracks_energy(depth):
    """The compliance's growth is the energy the crack releases: M^2 C'(a) / 2 = K_I^2 (1 - nu^2)
    / E within 1e-7 (central differences; 4e-9 measured), and C(a) of a shallow crack is its
    leading term 72 pi (1 - nu^2) / (E h^2) 1.122^2 (a/h)^2 / 2 (within 1e-3 at a = 1e-4 m)."""
    p = Parameters()
    step, moment = 1e-6 * p.hi, 1e3
    growth = (crack_compliance(p, depth + step) - crack_compliance(p, depth - step)) / (2 * step)
    released = stress_intensity(p, depth, moment) ** 2 * (1.0 - p.nu**2) / p.E
    assert 0.5 * moment**2 * growth == pytest.approx(released, rel=1e-7)
    shallow = 1e-4
    leading = 72 * math.pi * (1 - p.nu**2) / (p.E * p.hi**2) * 1.122**2 * (shallow / p.hi) ** 2 / 2
    assert crack_compliance(p, shallow) == pytest.approx(leading, rel=1e-3)
    assert crack_stiffness(p, 0.0) == math.inf
    with pytest.raises(ValueError, match="depth"):
        crack_compliance(p, p.hi)


def _frequencies(p, place, k, count=15):
    """The first wet frequencies [rad s-1] of the half plate with a crack spring k at ``place``
    (2 edge shapes at each free end: the parts' modes alone have w'' = w''' = 0 there)."""
    q = Parameters(Nmod=p.Nmod, edge_shapes=2, fracture="break", crack_spacing=1.0)
    return broken.wet_parts(q, p.L, 2.0, [place], math.pi * p.Nmod / p.L, springs={place: k}).omega[:count]


def test_a_crack_spring_stiffens_from_a_hinge_to_the_whole_plate():
    """At the centre and at 1.5 m (N = 40): the wet frequencies grow with the spring's stiffness k,
    from a hinge's (k = 0) to the whole plate's: at 1e4 times k of a half-depth crack
    (0.296 D / hi) the first 15 are the unbroken plate's cosines within 5e-5 (7.7e-6 and 1.7e-5
    measured), and at k = 0 the slowest is 43 % (centre) and 29 % (1.5 m) below the whole
    plate's."""
    p = Parameters(Nmod=40)
    k_half = crack_stiffness(p, 0.5 * p.hi)
    assert k_half == pytest.approx(0.296 * p.rigidity / p.hi, rel=0.01)
    whole = p.frequencies[:15]
    for place, drop in ((0.0, 0.43), (1.5, 0.29)):
        runs = [_frequencies(p, place, k) for k in (0.0, 0.01 * k_half, k_half, 1e4 * k_half)]
        for softer, stiffer in zip(runs[:-1], runs[1:]):
            # (each omega^2 from the inverse problem to about eps (omega / omega_1)^2 of itself:
            # the frequencies the spring leaves as they were may move by that, up to 3e-12 on haswell)
            assert np.all(softer <= stiffer * (1.0 + 1e-13 * (stiffer / stiffer[0]) ** 2))
        assert np.max(np.abs(runs[-1] / whole - 1.0)) < 5e-5
        assert 1.0 - runs[0][0] / whole[0] == pytest.approx(drop, abs=0.01)
    with pytest.raises(ValueError, match="needs a break"):
        broken.wet_parts(p, p.L, 2.0, [1.5], math.pi * p.Nmod / p.L, springs={2.0: k_half})


@pytest.mark.slow   # the finite elements' wet modes, 6 plates at 4 cm: about 8 s
@pytest.mark.parametrize("place", [0.0, 1.5])
def test_a_crack_spring_has_the_elements_wet_frequencies(place):
    """The same spring crack in the finite elements (tests/fe_reference.Plate(springs=): w held
    continuous at the crack's node, a spring between its two slopes; 4 cm): the first 15 wet
    frequencies agree within 5e-5 for a hinge, a half-depth crack and a nearly whole plate (6e-6
    to 1.8e-5 measured; at 2 cm 4e-7 to 2e-5)."""
    p = Parameters(Nmod=40)
    k_half = crack_stiffness(p, 0.5 * p.hi)
    nodes = mesh(p.L, [place], 0.04)
    j = int(np.argmin(np.abs(nodes - place)))
    for k in (0.0, k_half, 1e4 * k_half):
        elements = Plate(p, nodes, {j}, springs={j: k}).modes()[1][:15]
        assert np.max(np.abs(_frequencies(p, nodes[j], k) / elements - 1.0)) < 5e-5, k
