"""The coupled stress and energy criterion of finite fracture mechanics on the ice's bending
(solver.model.coupled_criterion; docs/model.md, "The coupled stress and energy criterion")."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from solver.model.coupled_criterion import coupled_break, short_crack_depth
from solver.model.line_spring import crack_compliance

#: the reference ice (E, nu) with a sea ice's tensile strength and fracture toughness
E, NU, STRENGTH, TOUGHNESS = 4.2e9, 0.33, 5e5, 1.5e5


@pytest.mark.parametrize("hi", [0.02, 0.1, 0.5, 2.0])
def test_the_crack_forms_where_the_stress_and_the_energy_conditions_meet(hi):
    """eps_c against the least over a fine grid of crack depths l of max(M_s(l), M_e(l)): the
    grid's minimum lies above the criterion's by less than its spacing allows (2e-4 here), never below."""
    eps, depth = coupled_break(E, NU, hi, STRENGTH, TOUGHNESS)
    assert 0.0 < depth < 0.5 * hi
    ice = SimpleNamespace(E=E, nu=NU, hi=hi)
    energy = TOUGHNESS**2 * (1.0 - NU**2) / E
    lengths = np.linspace(0.5 * depth, min(2.0 * depth, 0.499 * hi), 4001)
    m_stress = STRENGTH * hi**2 / (6.0 * (1.0 - 2.0 * lengths / hi))
    m_energy = np.sqrt([2.0 * energy * length / crack_compliance(ice, length) for length in lengths])
    grid = 6.0 * np.min(np.maximum(m_stress, m_energy)) * (1.0 - NU**2) / (E * hi**2)
    assert 0.0 <= grid / eps - 1.0 < 2e-4           # (the kink between grid points: ~dl / 4 l*)
    at = 6.0 * STRENGTH * hi**2 / (6.0 * (1.0 - 2.0 * depth / hi)) * (1.0 - NU**2) / (E * hi**2)
    assert at == pytest.approx(eps, rel=1e-13)          # eps_c is the stress condition at l*


def test_thick_ice_breaks_at_its_tensile_strength_and_thin_ice_needs_more():
    """h >> l*: eps_c -> sigma_c (1 - nu^2) / E and l* -> 2 K_IC^2 / (pi F(0)^2 sigma_c^2), both
    within 1e-3 at h = 10^4 l* (they approach as 2 l* / h); eps_c falls as h grows (the size effect
    of flexural strength)
    and l* / h rises towards 1/2 as h falls."""
    short = short_crack_depth(STRENGTH, TOUGHNESS)
    eps, depth = coupled_break(E, NU, 1e4 * short, STRENGTH, TOUGHNESS)
    assert eps == pytest.approx(STRENGTH * (1.0 - NU**2) / E, rel=1e-3)
    assert depth == pytest.approx(short, rel=1e-3)
    thicknesses = np.geomspace(1e-3, 100.0, 25)
    results = np.array([coupled_break(E, NU, hi, STRENGTH, TOUGHNESS) for hi in thicknesses])
    assert np.all(np.diff(results[:, 0]) < 0.0)
    assert np.all(np.diff(results[:, 1] / thicknesses) < 0.0)
    assert results[0, 1] / thicknesses[0] > 0.4           # (0.449 at 1 mm)


def test_without_toughness_to_pay_the_ice_breaks_at_its_strength():
    """A toughness far below sigma_c sqrt(h) leaves the stress condition alone: l* -> 0, eps_c ->
    sigma_c (1 - nu^2) / E (within 1e-6 at K_IC = 1e-4 sigma_c sqrt(h))."""
    hi = 0.5
    eps, depth = coupled_break(E, NU, hi, STRENGTH, 1e-4 * STRENGTH * math.sqrt(hi))
    assert depth < 1e-6 * hi
    assert eps == pytest.approx(STRENGTH * (1.0 - NU**2) / E, rel=1e-6)
