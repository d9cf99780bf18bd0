"""Parameters: the paper's scales, derived quantities and validation of bad values."""
import math

import numpy as np
import pytest

from solver import ParameterError, Parameters, Settings


def test_paper_time_scale_and_stage():
    p = Parameters()
    assert p.time_scale == pytest.approx(0.0253, rel=0.01)
    assert p.stage_duration / p.time_scale == pytest.approx(4.74, abs=0.01)


def test_derived_quantities_match_their_formulas():
    p = Parameters(Nmod=3)
    m = 917 * 0.5
    D = 4.2e9 * 0.5**3 / (12 * (1 - 0.33**2))
    lam = np.pi * np.arange(1, 4) / 6.0
    M = m + 1000 / lam
    assert p.plate_mass == pytest.approx(m)
    assert p.rigidity == pytest.approx(D)
    np.testing.assert_allclose(p.frequencies, np.sqrt((D * lam**4 + 1000 * 9.81) / M))
    assert p.deflection_scale == pytest.approx(8e6 / (p.frequencies[0] ** 2 * M[0]))
    assert p.d2 == pytest.approx(5 / (p.frequencies[0] * 0.02))
    assert p.d3 == pytest.approx(36 / (2 * 10 * 0.02))


def test_nu_zero_gives_the_paper_typo_scales():
    # docs/model.md, correction 1: with nu = 0 the stage ends at 4.48 t_sc and t_sc = 0.0268 s
    p = Parameters(nu=0.0)
    assert p.time_scale == pytest.approx(0.0268, rel=0.01)
    assert p.stage_duration / p.time_scale == pytest.approx(4.48, abs=0.01)


@pytest.mark.parametrize("key, value, words", [
    ("K", 0.0, "K must be finite and > 0"),
    ("he", -0.01, "he must be finite and > 0"),
    ("R", math.inf, "R must be finite and > 0"),
    ("V", math.nan, "V must be finite and > 0"),
    ("hi", "thick", "hi must be a number"),
    ("Nmod", 0, "Nmod must be a positive integer"),
    ("Nmod", 1.5, "Nmod must be a positive integer"),
    ("Nmod", True, "Nmod must be a number"),
    ("Nmod", 10**7, "Nmod must be at most 4096"),
    ("nu", 0.5, "nu must be in [0, 0.5)"),
    ("nu", -0.1, "nu must be in [0, 0.5)"),
    ("rho_w", None, "rho_w must be a number"),
])
def test_bad_parameter_names_key_and_range(key, value, words):
    with pytest.raises(ParameterError) as err:
        Parameters(**{key: value})
    assert words in str(err.value)
    assert "\n" not in str(err.value)


def test_unknown_key_in_replace():
    with pytest.raises(ParameterError, match="unknown parameter 'Vel'"):
        Parameters().replace(Vel=3.0)


@pytest.mark.parametrize("kwargs, words", [
    ({"integrator": "euler"}, "integrator must be one of etd34, rk4"),
    ({"tolerance": 0.0}, "tolerance must be finite and > 0"),
    ({"tolerance": 2.0}, "tolerance must be < 1"),
    ({"subintervals": 4}, "subintervals must be between 8 and"),
    ({"subintervals": 100.5}, "subintervals must be a positive integer"),
    ({"rk4_step_fraction": -1.0}, "rk4_step_fraction must be finite and > 0"),
    ({"fixed_step": -0.1}, "fixed_step must be finite and >= 0"),
    ({"max_steps": 0}, "max_steps must be a positive integer"),
])
def test_bad_settings(kwargs, words):
    with pytest.raises(ParameterError) as err:
        Settings(**kwargs)
    assert words in str(err.value)


def test_parameters_are_immutable():
    p = Parameters()
    with pytest.raises(Exception):
        p.V = 3.0


@pytest.mark.parametrize("key, bad, message", [
    ("body_mass", 0.0, r"body_mass must be > 0 \(inf: the paper's body at constant speed\), got 0.0"),
    ("body_mass", float("nan"), "body_mass must be > 0"),
    ("body_g", -1.0, "body_g must be finite and >= 0, got -1.0"),
    ("body_g", float("inf"), "body_g must be finite and >= 0"),
    ("body_p", 0.5, r"body_p must be finite and >= 1 \(a convex body\)"),
    ("flat_width", -1.0, "flat_width must be finite and >= 0"),
    ("deadrise", 90.0, "deadrise must be in"), ("deadrise", -3.0, "deadrise must be in"),
    ("tau", -1e-3, r"tau must be finite and >= 0 \(0: elastic ice\)"), ("tau", float("inf"), "tau must be finite"),
    ("H", -1.0, "H must be > 0"), ("body_mass", "heavy", "body_mass must be > 0"), ("tau", True, "tau must be")])
def test_bad_values_beyond_the_paper_are_one_line(key, bad, message):
    with pytest.raises(ParameterError, match=message) as err:
        Parameters(**{key: bad})
    assert "\n" not in str(err.value)
