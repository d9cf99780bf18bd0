"""The impact zone's tension maxima and crack onset (docs/model.md, "Maxima of the impact zone",
"Crack onset"; solver.observe.zone, solver.observe.reach): the contact's extent against its
rigid-plate geometry, the zone's maxima and crack onsets against the plate-wide ones, against
DOP853 and a tight run, and under mirroring."""
import math

import numpy as np
import pytest

from solver import Parameters, ParameterError, Settings, default_eps_Y, solve

ZONE = ("impact_zone_max_strain", "impact_zone_max_strain_lower")
FLOE = dict(quadrature="paper", subintervals=500, tolerance=1e-10, error_estimate=False)


def test_contact_extent_of_a_rigid_plate_is_the_bodys_geometry():
    """Ice 1e6 times stiffer barely moves (walls: no heave): delta > 0 where x^2 < 2 R V t, so
    the contact reaches sqrt(2 R V t) at the end of the run."""
    p = Parameters(Nmod=20, E=4.2e15)
    t_end = 0.002
    r = solve(p, Settings(error_estimate=False), times=[0.0, t_end], fields=(), t_end=t_end)
    assert r.status == "ok"
    assert r.diagnostics["contact_extent"] == pytest.approx(math.sqrt(2 * p.R * p.V * t_end), rel=2e-4)


def test_the_zone_keeps_the_plate_wide_maximum_when_it_is_an_inner_peak_of_the_zone():
    """On a free floe the largest tension is a peak inside the plate: with a margin covering the
    floe the zone's maxima are the plate-wide ones; with the default margin the zone's upper
    maximum is smaller and lies within the contact's reach plus the margin. The same peak is
    located by two searches (solver.observe.dense_maxima): on this machine they agree bit for bit;
    under numba's haswell target (2026-11-28, the default smoothness control) the value was 1 ulp
    apart, the place 1.4e-10 and the time 9.4e-10 relative: a flat maximum's place and time are
    known to about sqrt(eps)."""
    p = Parameters(Nmod=20, edges="free", duration=0.12)
    wide = solve(p, Settings(**FLOE, impact_zone_margin=100.0), fields=())
    for zone, plate in zip(ZONE, ("max_strain", "max_strain_lower")):
        assert wide.diagnostics[zone] == pytest.approx(wide.diagnostics[plate], rel=1e-14, abs=0.0)
        for end in ("_x", "_time"):
            assert wide.diagnostics[zone + end] == pytest.approx(wide.diagnostics[plate + end], rel=1e-7, abs=1e-12)
        assert wide.diagnostics[zone + "_at_edge"] == 0.0
    near = solve(p, Settings(**FLOE), fields=())
    d = near.diagnostics
    assert 0 < d["impact_zone_max_strain"] < 0.6 * d["max_strain"]
    assert d["impact_zone_max_strain_x"] == pytest.approx(d["contact_extent"] + 1.0, rel=1e-12)
    assert d["impact_zone_max_strain_at_edge"] == 1.0           # the tension still rose outward
    assert near.diagnostics["max_strain"] == wide.diagnostics["max_strain"]      # an observer only


def test_a_walled_plates_zone_leaves_out_the_wall():
    """On the paper's plate the plate-wide upper maximum sits at the wall at the end of the
    stage; the zone stops a margin short of the wall, and its maximum is smaller."""
    for margin in (1.0, 2.0):
        r = solve(Parameters(Nmod=20), Settings(error_estimate=False, impact_zone_margin=margin), fields=())
        d = r.diagnostics
        assert d["max_strain_x"] == 6.0
        assert d["impact_zone_max_strain"] < 0.5 * d["max_strain"]
        assert d["impact_zone_max_strain_x"] == 6.0 - margin and d["impact_zone_max_strain_at_edge"] == 1.0
        assert d["impact_zone_max_strain_lower_x"] == d["max_strain_lower_x"] == 0.0   # under the body
        assert d["impact_zone_max_strain_lower_at_edge"] == 0.0
        assert d["contact_extent"] > 5.0                    # the contact nearly reaches the walls


@pytest.mark.parametrize("x0, integrator", [(0.0, "etd34"), (2.0, "etd34"), (0.0, "dop853"),
                                           pytest.param(2.0, "dop853", marks=pytest.mark.heavy)])
def test_a_margin_that_covers_a_walled_plate_leaves_the_zone_empty(x0, integrator):
    """impact_zone_margin >= L on walls: no zone (it stops the margin short of each wall), so
    every impact_zone_* value is NaN and its records are empty. (They were finite: the value at
    x = 0 at margin = L, the zone's end beyond the plate at margin > L.) DOP853 (its Python
    right-hand side) over the stage's first fifth, where the contact has spread well past x0."""
    p = Parameters(Nmod=12, x0=x0)
    for margin in (6.0, 7.0):
        r = solve(p, Settings(error_estimate=False, impact_zone_margin=margin, integrator=integrator), fields=(),
                  t_end=0.2 * p.stage_duration if integrator == "dop853" else None)
        zone = {k: v for k, v in r.diagnostics.items() if k.startswith("impact_zone")}
        assert len(zone) == 8 and all(np.isnan(v) for v in zone.values()), (margin, zone)
        assert r.tension_record["impact_zone_upper"].shape[0] == r.tension_record["impact_zone_lower"].shape[0] == 0
        assert np.isnan(r.crack_onset(1e-6, region="impact_zone")[0])
        assert np.isfinite(r.diagnostics["max_strain"])


@pytest.mark.parametrize("changes", [pytest.param(dict(), marks=pytest.mark.heavy), dict(edges="free", duration=0.06)])
def test_zone_maxima_agree_with_dop853(changes):
    """DOP853 observes the zone on its own dense output (8 samples a step, Hermite between);
    the kernels at their step ends and on the dense output inside the steps that do not resolve
    the modes, the contact's reach located there too; on a floe the maxima are located (tight:
    tests/test_floe_gauss.py). Measured: the maxima within 1.9e-7 (upper, at the zone's end on
    the walls: it was 2e-4 with the reach read at step ends) and 2.0e-6 (lower, where DOP853's
    own zone maximum lies 1.2e-6 above its plate-wide one: its Hermite between samples); crack
    onset in the zone within 9.4e-7 (walls) and 1.1e-6 (floe) for the 42 yield strains."""
    p = Parameters(Nmod=10, **changes)
    runs = [solve(p, Settings(**dict(FLOE, integrator=integrator, tolerance=1e-10)), fields=())
            for integrator in ("etd34", "dop853")]
    for name in ZONE:
        a, b = (r.diagnostics[name] for r in runs)
        assert a == pytest.approx(b, rel=3e-6)
        a, b = (r.diagnostics[name + "_time"] for r in runs)
        # (a maximum's time is ill-conditioned, and on the floe the steps that hold it are longer
        # than the modes' periods, sampled at their ends: 2.5e-5 s apart over 60 ms there)
        assert a == pytest.approx(b, abs=1e-3 * runs[0].time_reached)
    assert runs[0].diagnostics["contact_extent"] == pytest.approx(runs[1].diagnostics["contact_extent"], rel=1e-5)
    # crack onset in the zone from each run's record, for all 42 yield strains of the default axis
    for surface in ("upper", "lower"):
        (a, xa), (b, xb) = (r.crack_onset(default_eps_Y(), surface, "impact_zone") for r in runs)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        rel = np.nanmax(np.abs(a / b - 1))
        print(surface, f"crack onset in the zone: largest relative difference {rel:.1e}, place "
                       f"{np.nanmax(np.abs(xa - xb)):.1e} m")
        assert rel < 3e-6 and np.nanmax(np.abs(xa - xb)) < 1e-3


@pytest.mark.parametrize("changes", [pytest.param(dict(V=1.0, Nmod=40), marks=pytest.mark.heavy), dict(hi=0.2, Nmod=40),
                                     dict(edges="free", L=2.0, duration=0.01, Nmod=40)])
def test_zone_crack_onset_at_default_tolerance_matches_tight_run(changes):
    """All 42 yield strains of the default axis, both surfaces: crack onset in the zone at the
    default tolerance within 1e-5 of etd34 at 1e-12, as the plate-wide one (tests/test_events.py).
    Measured: 8.5e-7 and 3.1e-6 (slow impact), 3.5e-7 and 1.8e-6 (thin ice), 3.9e-6 and 2.7e-6
    (a 2 m floe). The slow impact's upper onset sits at the zone's end while the contact spreads:
    1.2e-4 when the contact's extent was read at step ends and linear between them."""
    p = Parameters(**changes)
    r = solve(p, Settings(error_estimate=False), fields=())
    tight = solve(p, Settings(tolerance=1e-12, error_estimate=False), fields=())
    for surface in ("upper", "lower"):
        t, _ = r.crack_onset(default_eps_Y(), surface, "impact_zone")
        ref, _ = tight.crack_onset(default_eps_Y(), surface, "impact_zone")
        np.testing.assert_array_equal(np.isnan(t), np.isnan(ref))
        assert np.isfinite(ref).sum() >= 20
        rel = np.nanmax(np.abs(t / ref - 1))
        print(changes, surface, f"largest relative difference {rel:.1e}")
        assert rel <= 1e-5


def test_crack_onset_in_the_zone_is_the_plate_wide_one_when_the_zone_covers_the_floe():
    """A margin that covers the floe: the zone's record follows the plate-wide peak (sampled on
    the same dense output, searched by another route), so its crack onsets are the plate-wide
    ones for every yield strain."""
    p = Parameters(Nmod=20, edges="free", duration=0.12)
    r = solve(p, Settings(**FLOE, impact_zone_margin=100.0), fields=())
    for surface in ("upper", "lower"):
        tz, xz = r.crack_onset(default_eps_Y(), surface, "impact_zone")
        tp, xp = r.crack_onset(default_eps_Y(), surface)
        np.testing.assert_array_equal(np.isnan(tz), np.isnan(tp))
        assert np.isfinite(tp).sum() >= 20
        np.testing.assert_allclose(tz, tp, rtol=1e-7)
        np.testing.assert_allclose(xz, xp, atol=1e-6)


def test_crack_onset_in_the_zone_follows_its_maximum_and_leaves_out_the_walls():
    """On the paper's plate: the zone's tension reaches a yield strain no earlier than the
    plate's, its onset is finite exactly up to impact_zone_max_strain, and at the large yield
    strains the plate reaches only at the wall (the confinement) the zone never cracks."""
    r = solve(Parameters(Nmod=20), Settings(error_estimate=False), fields=())
    d = r.diagnostics
    eps = default_eps_Y()
    for surface, suffix in (("upper", ""), ("lower", "_lower")):
        tz, xz = r.crack_onset(eps, surface, "impact_zone")
        tp, _ = r.crack_onset(eps, surface)
        both = np.isfinite(tz)
        assert np.all(tz[both] >= tp[both] * (1 - 1e-12))
        top = d["impact_zone_max_strain" + suffix]
        assert np.all(np.isfinite(tz[eps < top * (1 - 1e-7)])) and np.all(np.isnan(tz[eps > top * (1 + 1e-7)]))
        assert np.all(np.abs(xz[both]) <= d["contact_extent"] + 1.0 + 1e-9)
    tz, _ = r.crack_onset(0.1, "upper", "impact_zone")
    tp, xp = r.crack_onset(0.1, "upper")
    assert np.isnan(tz) and np.isfinite(tp) and xp == 6.0     # at the wall only
    with pytest.raises(ParameterError, match="region"):
        r.crack_onset(8e-5, "upper", "zone")


def test_mirroring_the_body_mirrors_the_zone():
    """x0 -> -x0 at a fixed step: the same zone maxima at mirrored places."""
    runs = [solve(Parameters(Nmod=10, x0=x0), Settings(**FLOE, fixed_step=0.002), fields=()) for x0 in (1.5, -1.5)]
    a, b = runs[0].diagnostics, runs[1].diagnostics
    for name in ZONE:
        assert a[name] == pytest.approx(b[name], rel=1e-10)
        assert a[name + "_x"] == pytest.approx(-b[name + "_x"], abs=1e-9)
        assert a[name + "_time"] == pytest.approx(b[name + "_time"], rel=1e-9)
    assert a["contact_extent"] == pytest.approx(b["contact_extent"], rel=1e-10)


@pytest.mark.parametrize("value", [-1.0, math.inf, math.nan, "wide", True])
def test_impact_zone_margin_is_checked(value):
    with pytest.raises(ParameterError, match="impact_zone_margin"):
        Settings(impact_zone_margin=value)


def test_peak_at_end_is_the_vertex_of_a_parabola_and_refuses_a_jump():
    """peak_at_end (solver/observe/reach.py) on a parabola sampled at three unequal times: its
    vertex exactly; no peak where the middle is not the largest or the vertex would stand a node
    spacing above it (a contact appearing beyond a gap, not one front)."""
    from solver.observe.reach import peak_at_end
    top, t_top = 0.57, 2e-6
    def c(t):
        return top - 3e4 * (t - t_top) ** 2
    h_prev, h = 7e-6, 4e-6
    assert peak_at_end(c(-h_prev), c(0.0), c(h), h_prev, h, 0.024) == pytest.approx(top, rel=1e-13)
    assert peak_at_end(c(-2 * h_prev), c(-h_prev), c(0.0), h_prev, h_prev, 0.024) == -1.0  # still spreading
    assert peak_at_end(0.1, 0.5, 0.45, 1e-6, 1e-6, 0.024) == -1.0     # a jump: its vertex 0.034 m above


@pytest.mark.heavy
@pytest.mark.parametrize("settings", [dict(fixed_step=2.5e-4), dict(error_control="smoothness", tolerance=1e-10),
                                      dict(error_control="smoothness", tolerance=3e-11)])
def test_the_contact_reach_between_steps_that_resolve_the_modes(settings):
    """A 6 m floe (N = 20, 10 ms): in steps that resolve every mode the zone is not sampled inside,
    and the reach's peak between step ends is the vertex through them (peak_at_end). Against
    DOP853 at 1e-12. Measured (2026-11-28): 7.7e-11, 4.9e-12 and 2.3e-10; with the step ends'
    largest extent alone it was 1.9e-8, 3.1e-10 and 1.1e-8 (and 9.6e-8 at 1e-10 with the smoothness
    control's floor at 0.1, the step sequence deciding how far the peak falls from a step end)."""
    p = Parameters(edges="free", L=6.0, duration=0.01, Nmod=20)
    d = solve(p, Settings(integrator="dop853", tolerance=1e-12, error_estimate=False), fields=())
    r = solve(p, Settings(error_estimate=False, **settings), fields=())
    assert r.diagnostics["contact_extent"] == pytest.approx(d.diagnostics["contact_extent"], rel=5e-9)
