"""Energy identity (docs/model.md) and the forcing quadrature."""
import numpy as np
import pytest

from solver import Parameters, Settings, solve
from solver.run import layer_pressure
from solver.model.assemble import Tables
from solver.model.layer import layer_forcing


def test_energy_residual_small_at_default_settings(reference60):
    assert reference60.diagnostics["energy_residual"] < 1e-3


def test_energy_residual_small_for_rk4_at_paper_rule():
    r = solve(Parameters(Nmod=20), Settings(integrator="rk4"), fields=())
    assert r.status == "ok"
    assert r.diagnostics["energy_residual"] < 1e-3


@pytest.mark.heavy
def test_energy_residual_second_order_in_subintervals():
    """The paper's rule (f linear between the nodes): its residual is its O(dx^2) quadrature
    error. The Gauss rule's is the time integration's (tests/test_quadrature.py)."""
    p = Parameters(Nmod=20)
    J = np.array([250, 500, 1000, 2000])
    res = np.array([solve(p, Settings(quadrature="paper", subintervals=int(j), tolerance=1e-11), fields=())
                    .diagnostics["energy_residual"] for j in J])
    order = -np.polyfit(np.log(J), np.log(res), 1)[0]
    print("residuals", res, "order in dx", order)
    assert np.all(np.diff(res) < 0)
    assert 1.7 < order < 2.3


@pytest.mark.parametrize("control, tolerances", [("embedded", (1e-4, 1e-6, 1e-8)),
                                                  ("smoothness", (1e-2, 1e-4, 1e-6))])
def test_energy_residual_shrinks_with_tolerance(control, tolerances):
    """Down to the quadrature's floor (about 2e-7 at 4000 subintervals, N = 20: reached at 1e-6
    under the smoothness control, whose error follows the tolerance). Measured (2026-11-28):
    embedded 8.7e-5, 5.3e-6, 2.3e-7; smoothness 5.7e-4, 1.9e-5, 4.0e-7."""
    p = Parameters(Nmod=20)
    res = [solve(p, Settings(subintervals=4000, tolerance=tol, error_control=control, error_estimate=False),
                 fields=()).diagnostics["energy_residual"] for tol in tolerances]
    print(f"residuals at tol {tolerances}:", res)
    assert res[0] > 3 * res[1] > 9 * res[2]


def test_energy_identity_at_output_times(reference60):
    r = reference60
    v = r.valid
    residual = np.abs(r.plate_energy[v] + r.layer_energy[v] - r.work[v])
    assert np.all(residual <= r.diagnostics["energy_residual"] * r.diagnostics["work"] * (1 + 1e-9))
    assert np.all(np.diff(r.work[v]) >= 0), "the body only pushes: work never decreases"


def _state(p, t_tilde):
    r = solve(p, Settings(tolerance=1e-10), times=[t_tilde * p.time_scale], fields=())
    return r.amplitudes[0], r.times[0]


@pytest.mark.parametrize("t_tilde", [0.5, 3.8])
def test_forcing_matches_brute_force_integral(t_tilde):
    """P_n from exact segment integrals equals a fine numerical integral of the same f."""
    p = Parameters(Nmod=20)
    tab = Tables(p, 1000)
    a, t = _state(p, t_tilde)
    delta, fvals, P = np.empty(1001), np.empty(1001), np.empty(20)
    st, force, jmax = layer_forcing(tab.model, t, a, delta, fvals, P)
    assert st == 0
    x = np.linspace(0, p.L, 600_001)
    pressure = layer_pressure(p, tab, a, p.V * t, x)    # K f on the half plate, numpy
    brute = np.array([np.trapezoid(pressure * np.cos(lam * x), x) for lam in tab.lam])
    brute *= 2.0 / (p.L * p.added_masses) * -1.0
    np.testing.assert_allclose(P, brute, rtol=1e-6, atol=1e-9 * np.max(np.abs(brute)))
    assert force == pytest.approx(2 * np.trapezoid(pressure, x), rel=1e-8)


def test_forcing_is_C1_when_contact_boundaries_cross_nodes():
    """Second differences of P(t) at fixed a shrink like step^2 (a C0 kink would give step^1)."""
    p = Parameters(Nmod=20)
    tab = Tables(p, 200)                                  # coarse: boundaries cross nodes often
    a, t0 = _state(p, 0.5)
    delta, fvals, P = np.empty(201), np.empty(201), np.empty(20)
    span = 0.3 * p.he / p.V                                # the body presses 0.3 he further

    def sweep(n):
        values, in_contact = [], []
        for t in t0 + np.linspace(0, span, n + 1):
            st, _, jmax = layer_forcing(tab.model, t, a, delta, fvals, P)
            assert st == 0
            values.append(P.copy())
            in_contact.append(int(np.sum(delta[:jmax] > 0)))
        values = np.array(values)
        return np.max(np.abs(values[2:] - 2 * values[1:-1] + values[:-2])), in_contact

    # fine enough that a kink (second difference ~ step) would outgrow the curvature (~ step^2)
    d1, nodes = sweep(32000)
    d2, _ = sweep(64000)
    print("max second differences", d1, d2, "ratio", d1 / d2, "nodes in contact", nodes[0], nodes[-1])
    assert nodes[-1] - nodes[0] >= 2, "the sweep must move a contact boundary across nodes"
    assert d1 / d2 > 3.0
