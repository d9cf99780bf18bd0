"""The largest force and compression, located inside the steps (solver.observe.layer_maxima;
docs/model.md, "Maxima of the force and the compression"): against DOP853, which locates them on
its own dense output, and converged over the tolerance where step ends were 1e-4 apart."""
from dataclasses import replace

import numpy as np
import pytest

from solver import Parameters, Settings, solve
from solver.observe.layer_maxima import _vertex

FREE_BODY = (Parameters(Nmod=20, body_mass=200.0), {"until_separation": True})
PAPER = (Parameters(Nmod=20, V=5.0), {})
NAMES = ("max_force", "max_compression")


def _pair(case, tolerance, quadrature="gauss"):
    p, kw = case
    s = Settings(error_estimate=False, quadrature=quadrature)
    etd = solve(p, replace(s, tolerance=tolerance), fields=(), **kw)
    ref = solve(p, replace(s, integrator="dop853", tolerance=1e-12), fields=(), **kw)
    return etd, ref


@pytest.mark.parametrize("case, bound", [(FREE_BODY, 1e-7),
                                         pytest.param(PAPER, 1e-6, marks=pytest.mark.slow)],   # (DOP853: 25 s)
                         ids=["free body", "paper V=5"])
def test_located_maxima_agree_with_dop853(case, bound):
    """etd34 at 1e-9 against DOP853 at 1e-12 (measured: free body 6.6e-10 and 3.7e-10 of the
    force and compression, 1.6e-9 and 2.2e-9 of their times; paper V = 5 1.6e-7 and 1.0e-7).
    At the step ends the free body's force was 1.5e-4 below DOP853's."""
    etd, ref = _pair(case, 1e-9)
    for name in NAMES:
        value, reference = etd.diagnostics[name], ref.diagnostics[name]
        assert abs(value - reference) <= bound * reference, (name, value, reference)
        when, ref_when = etd.diagnostics[name + "_time"], ref.diagnostics[name + "_time"]
        assert abs(when - ref_when) <= 1e-5 * ref.time_reached, (name, when, ref_when)


def test_located_maxima_converge_with_the_tolerance():
    """The free body's maxima at tolerance 1e-7 and 1e-9 agree to their error (measured 5e-8),
    far inside a step: the steps at 1e-7 are about twice as long."""
    p, kw = FREE_BODY
    s = Settings(error_estimate=False)
    loose, tight = (solve(p, replace(s, tolerance=tol), fields=(), **kw) for tol in (1e-7, 1e-9))
    assert loose.steps < 0.7 * tight.steps
    for name in NAMES:
        assert abs(loose.diagnostics[name] / tight.diagnostics[name] - 1) < 1e-6, name


def test_the_located_force_is_above_every_output_sample():
    """The located maximum is at least the force at every output time, and at a time inside the
    run where the force series has its largest values."""
    p, kw = FREE_BODY
    times = np.linspace(0, 0.05, 401)
    r = solve(p, Settings(error_estimate=False), times=times, fields=(), t_end=0.05)
    force = r.force[r.valid]
    assert r.diagnostics["max_force"] >= force.max()
    k = int(np.argmax(force))
    assert times[max(k - 1, 0)] <= r.diagnostics["max_force_time"] <= times[min(k + 1, times.size - 1)]


@pytest.mark.heavy
def test_the_paper_rule_and_the_floe_locate_too():
    """Under the paper's quadrature on a free floe (its own stepping): against DOP853 (measured
    5.0e-8 and 6.6e-9)."""
    case = (Parameters(Nmod=20, edges="free", L=6.0, duration=0.03), {})
    etd, ref = _pair(case, 1e-9, quadrature="paper")
    for name in NAMES:
        assert abs(etd.diagnostics[name] / ref.diagnostics[name] - 1) <= 1e-6, name


def test_the_vertex_of_a_parabola():
    """The search's parabolic step is exact on a parabola, NaN on a line."""
    f = lambda t: 3.0 - 2.0 * (t - 0.37) ** 2                       # noqa: E731
    assert _vertex.py_func(0.0, 0.5, 1.2, f(0.0), f(0.5), f(1.2)) == pytest.approx(0.37, abs=1e-15)
    assert np.isnan(_vertex.py_func(0.0, 1.0, 2.0, 0.0, 1.0, 2.0))


def test_a_candidate_is_bounded_by_its_parabola():
    """A candidate's bound is its sample plus twice its parabola's rise; no bound (-inf) where the
    middle sample is no local maximum."""
    from solver.observe.layer_maxima import _bound
    f = lambda t: 3.0 - 2.0 * (t - 0.37) ** 2                       # noqa: E731
    assert _bound.py_func(0.0, 0.5, 1.2, f(0.0), f(0.5), f(1.2)) == pytest.approx(f(0.5) + 2 * (3.0 - f(0.5)))
    assert _bound.py_func(0.0, 1.0, 2.0, 0.0, 1.0, 2.0) == -np.inf
