"""Finite water depth H (docs/model.md, "Beyond the paper: finite water depth"): opt-in, the
paper's model bit for bit at H = inf, the dispersion relation, the deep limit, the energy
identity, convergence to deep water, and case ids that hold for studies from before H."""
import math

import numpy as np
import pytest

from neutral_ids import assert_ids_hold_at_neutral, run_swept_study, study
from solver import ParameterError, Parameters, Settings, solve
from helpers import run_cli


def test_deep_water_is_the_papers_model_bit_for_bit():
    p = Parameters()
    assert p.H == math.inf
    lam = np.pi * np.arange(1, 61) / 6.0
    assert np.array_equal(p.added_masses, 917.0 * 0.5 + 1000.0 / lam)


def test_frequencies_follow_the_finite_depth_dispersion_relation():
    for H in (0.05, 0.5, 3.0, 40.0):
        p = Parameters(H=H, Nmod=30)
        lam = np.pi * np.arange(1, 31) / p.L
        D = p.E * p.hi**3 / (12 * (1 - p.nu**2))
        M = p.rho_i * p.hi + p.rho_w * np.cosh(lam * H) / np.sinh(lam * H) / lam
        np.testing.assert_allclose(p.frequencies, np.sqrt((D * lam**4 + p.rho_w * p.g) / M), rtol=1e-13)
        deep = Parameters(Nmod=30).frequencies                      # heavier: slower (high modes
        assert np.all(p.frequencies <= deep) and (H > 10 or p.frequencies[0] < deep[0])   # feel no bottom)
    # deep limit: at H = 50 L every mode's coth is 1 to round-off
    np.testing.assert_allclose(Parameters(H=300.0).added_masses, Parameters().added_masses, rtol=1e-15)
    # shallow limit: rho / (lambda^2 H)
    p = Parameters(H=1e-3, Nmod=4)
    lam = p.wavenumbers
    np.testing.assert_allclose(p.added_masses - p.plate_mass, p.rho_w / (lam**2 * 1e-3), rtol=1e-5)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), True, "deep"])
def test_bad_depths_are_refused(bad):
    with pytest.raises(ParameterError, match="H must be > 0"):
        Parameters(H=bad)


def test_energy_identity_holds_in_shallow_water():
    p = Parameters(H=0.5, Nmod=40)
    r = solve(p, Settings(error_estimate=False), times=np.linspace(0, p.stage_duration, 7), fields=("strain",))
    assert r.status in ("ok", "layer_bottomed_out"), r.message
    assert r.diagnostics["energy_residual"] < 1e-4
    deep = solve(Parameters(Nmod=40), Settings(error_estimate=False), times=[r.times[3]], fields=("strain",))
    assert not np.allclose(r.fields["strain"][3], deep.fields["strain"][0], rtol=1e-2)   # it matters


@pytest.mark.heavy
def test_strain_converges_to_deep_water_as_exp_minus_2_lambda1_H():
    times = np.linspace(0.0, 1.5, 7) * Parameters().time_scale
    settings = Settings(tolerance=1e-12, error_estimate=False)
    deep = solve(Parameters(Nmod=20), settings, times=times, fields=("strain",)).fields["strain"]
    depths = np.array([1.5, 2.5, 3.5])
    diffs = []
    for H in depths:
        s = solve(Parameters(Nmod=20, H=H), settings, times=times, fields=("strain",)).fields["strain"]
        diffs.append(np.linalg.norm(s - deep) / np.linalg.norm(deep))
    rate = -np.polyfit(depths, np.log(diffs), 1)[0]
    lam1 = np.pi / 6.0
    print(f"differences {diffs}, observed decay rate {rate:.3f} /m, 2 lambda_1 = {2 * lam1:.3f} /m")
    assert abs(rate / (2 * lam1) - 1) < 0.15


def test_case_ids_hold_for_deep_water_and_change_with_depth():
    assert_ids_hold_at_neutral("H", "inf", "2.0")


def test_depth_out_of_range_is_one_line(tmp_path):
    path = tmp_path / "too_shallow.toml"
    path.write_text(study("H = 1e-4"))
    code, _, err = run_cli("run", path, "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and "H = 0.0001 lies outside the range" in err, err


def test_water_depth_study_runs_and_stores_H(tmp_path):
    import xarray as xr
    with xr.open_dataset(run_swept_study(tmp_path, "H", [0.5, np.inf], "m")) as ds:
        assert ds["max_strain"].sel(H=0.5).item() != ds["max_strain"].sel(H=np.inf).item()
