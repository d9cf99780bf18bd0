"""In-loop diagnostics (crack onset, maxima, contact intervals) and failure statuses."""
import numpy as np
import pytest

from solver import FIELDS, ParameterError, Parameters, Settings, solve
from solver.model.contact import count_contacts


@pytest.mark.parametrize("delta, expected", [
    ([-1, -1, -1, -1], 0),
    ([1, 1, 1, 1], 1),          # one interval through the centre, reaching both walls
    ([1, -1, -1, -1], 1),
    ([-1, 1, -1, -1], 2),       # a pair of side intervals, mirrored at -x
    ([1, 1, -1, 1, -1], 3),
    ([-1, -1, -1, 1], 2),       # touching the walls at x = -L and x = L
    ([1, -1, 1, -1, 1], 5),
])
def test_contact_interval_count(delta, expected):
    d = np.array(delta, dtype=float)
    assert count_contacts(d, d.size, 2.0) == expected


@pytest.mark.parametrize("delta, expected", [([1, 1, 1, 1], 1), ([-1, 1, -1, -1], 1), ([1, -1, 1, -1, 1], 3),
                                             ([-1, -1, -1, -1], 0), ([-1, 1, 1, -1, 1], 2)])
def test_contact_interval_count_on_the_full_plate(delta, expected):
    """An off-centre run's nodes cover -L..L: every interval counts once, the end nodes too."""
    d = np.array(delta, dtype=float)
    assert count_contacts(d, d.size, 1.0) == expected


@pytest.fixture(scope="module")
def run20():
    p = Parameters(Nmod=20)
    return solve(p, Settings(tolerance=1e-10), times=np.linspace(0, p.stage_duration, 60),
                 fields=("strain",), x=np.linspace(-p.L, p.L, 2001))


def test_maxima_tracked_between_snapshots(run20):
    d = run20.diagnostics
    eps = run20.fields["strain"][run20.valid]
    assert d["max_strain"] >= eps.max() * (1 - 1e-6)
    assert d["max_strain_lower"] >= (-eps).max() * (1 - 1e-6)
    assert d["max_abs_strain"] == pytest.approx(max(d["max_strain"], d["max_strain_lower"]))
    assert d["max_contact_intervals"] >= np.nanmax(run20.contact_intervals)
    assert d["max_force"] >= np.nanmax(run20.force)
    assert 0 < d["max_compression"] < 1
    assert 0 <= d["max_strain_x"] <= run20.parameters.L


def test_only_requested_fields_on_requested_points():
    p = Parameters(Nmod=10)
    x = np.array([-1.0, 0.0, 2.5])
    r = solve(p, times=[0.0, 0.01], fields=("compression",), x=x)
    assert set(r.fields) == {"compression"}
    assert r.fields["compression"].shape == (2, 3)
    r = solve(p, times=[0.0, 0.01], fields=())
    assert r.fields == {} and r.status == "ok"
    assert set(FIELDS) == {"deflection", "strain", "layer_pressure", "compression"}


@pytest.mark.parametrize("kwargs, words", [
    ({"times": [0.0, 1.0]}, "times must lie in"),
    ({"times": [0.02, 0.01]}, "sorted"),
    ({"times": [np.nan]}, "finite"),
    ({"fields": ("stress",)}, "unknown field 'stress'"),
    ({"x": [7.0]}, "x must be"),
])
def test_bad_solve_arguments(kwargs, words):
    with pytest.raises(ParameterError, match=words):
        solve(Parameters(Nmod=4), **kwargs)


def _assert_valid_data_finite(r):
    v = r.valid
    for name, f in r.fields.items():
        assert np.all(np.isfinite(f[v])), name
        assert np.all(np.isnan(f[~v])), name
    for arr in (r.amplitudes, r.velocities, r.contact_intervals, r.force, r.work):
        assert np.all(np.isfinite(arr[v]))
        assert np.all(np.isnan(arr[~v]))


def test_step_limit_returns_what_was_computed():
    p = Parameters(Nmod=10)
    r = solve(p, Settings(max_steps=40), times=np.linspace(0, p.stage_duration, 11))
    assert r.status == "step_limit"
    assert "max_steps = 40" in r.message
    assert 0 < r.time_reached < p.stage_duration
    assert r.valid[0] and not r.valid[-1]
    _assert_valid_data_finite(r)


def test_thin_layer_never_returns_nan_as_valid():
    """he = 5 mm: the paper's RK4 fails by name; the adaptive default rejects and retries."""
    p = Parameters(he=0.005, Nmod=20)
    times = np.linspace(0, p.stage_duration, 25)
    rk4 = solve(p, Settings(integrator="rk4"), times=times, fields=FIELDS)
    etd = solve(p, Settings(), times=times, fields=FIELDS)
    assert rk4.status == "nonfinite" and "fixed step" in rk4.message
    assert etd.rejected_steps > 0
    assert etd.status in ("ok", "layer_bottomed_out")
    if etd.status != "ok":
        assert "t_sc" in etd.message and etd.time_reached < p.stage_duration
        assert etd.time_reached >= rk4.time_reached * (1 - 1e-3)
    for r in (rk4, etd):
        _assert_valid_data_finite(r)
        assert np.isfinite(r.diagnostics["max_strain"])
