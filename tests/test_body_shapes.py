"""Body shapes (docs/model.md, "Beyond the paper: body shapes"): the paper's parabola bit for
bit, each profile, its inverse and derivatives against independent evaluations, the stage end
that mass conservation imposes, continuity between code paths, the energy identity and its dx^2
convergence on a wedge, DOP853 on a wedge, and a study that sweeps the deadrise."""
import math

import numpy as np
import pytest

from pipeline.study.definition import load_study_text
from solver import Parameters, Settings, solve
from solver.model.assemble import Tables
from solver.model.body import body_extent, body_profile, body_slope_curvature
from solver.model.contact import contact_bound
from dop853_check import against_dop853
from helpers import run_cli

SHAPES = [{"body_p": 1.5}, {"body_p": 4.0}, {"deadrise": 10.0}, {"flat_width": 0.5},
          {"flat_width": 1.0, "deadrise": 5.0}, {"flat_width": 0.7, "body_p": 3.0, "R": 4.0}]


def test_the_parabola_is_the_papers_body_bit_for_bit():
    p = Parameters(Nmod=20)
    assert p.parabola and (p.body_p, p.flat_width, p.deadrise) == (2.0, 0.0, 0.0)
    tab = Tables(p, 1000)
    x = tab.dx * np.arange(1001)
    assert np.array_equal(tab.model.body.profile, x * x * (0.5 / p.R))       # the kernel's old expression
    assert np.array_equal(p.body_profile(x), x**2 / (2 * p.R))
    assert p.stage_duration == p.L**2 / (6.0 * p.R * p.V)
    a = solve(p, Settings(error_estimate=False), fields=("compression",))
    b = solve(p.replace(body_p=2.0, flat_width=0.0, deadrise=0.0), Settings(error_estimate=False),
              fields=("compression",))
    assert np.array_equal(a.fields["compression"], b.fields["compression"]) and a.steps == b.steps


@pytest.mark.parametrize("shape", SHAPES)
def test_profile_inverse_and_derivatives(shape):
    p = Parameters(Nmod=4, **shape)
    body = Tables(p, 64).model.body
    x = np.linspace(0.0, p.L, 301)
    kernel = np.array([body_profile(v, body) for v in x])
    np.testing.assert_allclose(kernel, p.body_profile(x), rtol=1e-14, atol=1e-300)
    c = p.flat_width
    # written out independently of both
    u = np.maximum(x - c, 0.0)
    by_hand = u * math.tan(math.radians(p.deadrise)) if p.deadrise else u**p.body_p / (p.body_p * p.R ** (p.body_p - 1))
    np.testing.assert_allclose(kernel, by_hand, rtol=1e-13, atol=1e-300)
    beyond = x[x > c + 1e-3]
    back = np.array([body_extent(body_profile(v, body), body) for v in beyond])
    np.testing.assert_allclose(back, beyond, rtol=1e-12)
    h = 1e-4
    for v in beyond[beyond > c + 0.1][::25]:
        slope, curv = body_slope_curvature(v, body)
        fd1 = (body_profile(v + h, body) - body_profile(v - h, body)) / (2 * h)
        fd2 = (body_profile(v + h, body) - 2 * body_profile(v, body) + body_profile(v - h, body)) / h**2
        assert slope == pytest.approx(fd1, rel=2e-6, abs=1e-12)
        assert curv == pytest.approx(fd2, rel=1e-5, abs=1e-7)


@pytest.mark.parametrize("shape", [{}, *SHAPES])
def test_stage_end_is_the_mean_profile_over_V(shape):
    """T = (1/(L V)) int_0^L b dx: with int w dx = 0 the layer's mean compression is
    (V t - b_mean)/he, so every run bottoms out before T + he/V."""
    p = Parameters(Nmod=20, **shape)
    x = np.linspace(0.0, p.L, 200_001)
    b_mean = np.trapezoid(p.body_profile(x), x) / p.L
    assert p.stage_duration == pytest.approx(b_mean / p.V, rel=1e-8)
    late = p.stage_duration + 1.01 * p.he / p.V
    r = solve(p, Settings(error_estimate=False), fields=(), t_end=late)
    assert r.status == "layer_bottomed_out", (shape, r.status, r.message)
    assert r.diagnostics["bottoming_time"] <= p.stage_duration + p.he / p.V


def test_shapes_meet_where_their_code_paths_meet():
    """The parabola's own expressions against the general power law just beside it; the
    power law with p = 1 against a 45-degree wedge; a vanishing flat bottom. At a fixed step the
    step sequences are the same, so the paths meet to round-off plus the physical difference
    (body_p + 1e-9 moves the peak by 3.3e-9; tan(45 degrees) is 1 - 1.1e-16 in floating point).
    Adaptive runs would differ by their own error (1e-6 on another CPU)."""
    base = Parameters(Nmod=30)
    s = Settings(fixed_step=0.005, error_estimate=False)

    def peak(p):
        return solve(p, s, fields=()).diagnostics["max_strain"]
    ref = peak(base)
    assert peak(base.replace(body_p=2.0 + 1e-9)) == pytest.approx(ref, rel=1e-8)
    assert peak(base.replace(flat_width=1e-12)) == pytest.approx(ref, rel=1e-10)
    assert peak(base.replace(body_p=1.0)) == pytest.approx(peak(base.replace(deadrise=45.0)), rel=1e-12)


def test_energy_identity_on_a_wedge_falls_as_dx_squared():
    """The paper's rule: its residual on a wedge is its O(dx^2) quadrature error. The Gauss rule
    cuts its panels at the apex: its residual is the time integration's, whatever the table."""
    p = Parameters(Nmod=30, deadrise=10.0)
    t_end = 0.5 * p.stage_duration
    res = [solve(p, Settings(quadrature="paper", tolerance=1e-8, error_estimate=False, subintervals=n), fields=(),
                 t_end=t_end).diagnostics["energy_residual"] for n in (500, 1000, 2000)]
    order = np.polyfit(np.log([500, 1000, 2000]), np.log(res), 1)[0]
    assert res[1] < 1e-4 and -2.6 < order < -1.5, (res, order)
    gauss = [solve(p, Settings(error_estimate=False, subintervals=n), fields=(), t_end=t_end)
             .diagnostics["energy_residual"] for n in (250, 500)]
    assert max(gauss) < 1e-6 and max(gauss) < 0.1 * res[-1], (gauss, res)


@pytest.mark.heavy
def test_wedge_agrees_with_dop853():
    """The Gauss rule (the default) resolves the apex: the 10-degree wedge bottoms out at
    0.1785 t_sc, and the two integrators agree up to just before it. The paper's rule at 1000
    subintervals does not see the apex press into the layer and runs on; they agree there too."""
    p = Parameters(Nmod=20, deadrise=10.0)
    bottomed = solve(p, Settings(error_estimate=False), fields=())
    assert bottomed.status == "layer_bottomed_out"
    against_dop853(p, 0.9 * bottomed.time_reached)
    against_dop853(p, 0.3 * p.stage_duration, quadrature="paper", subintervals=1000)


@pytest.mark.parametrize("shape", [{}, *SHAPES])
def test_no_node_beyond_the_contact_bound_touches(shape):
    p = Parameters(Nmod=12, **shape)
    tab = Tables(p, 400)
    rng = np.random.default_rng(7)
    for _ in range(20):
        a = rng.normal(scale=0.01, size=12)
        s = rng.uniform(0.0, 0.3)
        jmax = contact_bound(tab.model.body, tab.model.basis, s, a, np.empty(tab.xq.size))
        delta = (a @ tab.cosq + s - p.body_profile(tab.xq)) / p.he
        assert np.all(delta[jmax:] < 0)


STUDY = """
description = "wedges"
[base]
Nmod = 12
[grid]
deadrise = {values}
[output]
times = {{ unit = "stage", count = 5 }}
fields = []
"""


def test_wedge_study_runs_and_keeps_the_papers_ids(tmp_path):
    import xarray as xr
    paper = load_study_text(STUDY.format(values="[0.0]"), "s")
    plain = load_study_text(STUDY.format(values="[0.0]").replace("deadrise = [0.0]", "V = [5.0]"), "s")
    assert paper.case_ids == plain.case_ids
    path = tmp_path / "wedges.toml"
    path.write_text(STUDY.format(values="[0.0, 10.0]"))
    code, _, err = run_cli("run", path, "--out", tmp_path / "o", "--no-plots")
    assert code == 0, err
    with xr.open_dataset(tmp_path / "o" / "study.nc") as ds:
        assert ds["deadrise"].attrs["units"] == "degree"
        assert ds["stage_duration"].sel(deadrise=10.0) < ds["stage_duration"].sel(deadrise=0.0)
        assert list(ds["status"].values) == ["ok", "layer_bottomed_out"]
