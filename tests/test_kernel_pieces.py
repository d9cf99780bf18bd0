"""The solver's elementary pieces against independent evaluations (docs/model.md, "Numerics").

- phi_1..phi_3 of i y against their Taylor series summed exactly in rational arithmetic;
- the dense output (exact sub-steps of a quadratic forcing) against the direct formula
  z(s) = e^{i w s} z0 + s phi1 P0 + b1 s^2 phi2 + 2 b2 s^3 phi3 and against scipy's DOP853;
- the deflection + strain pass against the two sums it is made of;
- the contact bound (the nodes the forcing sums over) against the contact edge of a run,
  and the contact observer on those nodes against the observer on every node;
- the forcing's projection on the modes against the hat-function weights written out as a
  (J, N) matrix, the form the forcing used before it was folded into per-mode weights.
"""
from fractions import Fraction
from math import factorial

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from solver import Parameters, Settings, solve
from solver.cubic import cubic_first_reach, cubic_max, cubic_sign_changes, hermite
from solver.model.assemble import Tables
from solver.model.basis import add_segment, modal_sum, modal_sum_strain, strain_nodes
from solver.model.body import body_extent
from solver.model.contact import contact_bound, count_contacts, reach_in_step
from solver.model.layer import layer_forcing, layer_forcing_at
from solver.model.plate import make_plate, phi_functions
from solver.observe.contacts import Snapshot, contact_work, observe_contacts
from solver.observe.record import Rows
from solver.observe.tension import TENSION_SAMPLES
from solver.step import State, dense_states


def _phi_exact(y, k):
    """phi_k(i y) = sum_m (i y)^m / (m + k)!, summed exactly (60 terms: |y| <= 4 to 1e-30)."""
    Y = Fraction(float(y))
    re = im = Fraction(0)
    for m in range(60):
        term = Y**m / factorial(m + k)
        re, im = {0: (re + term, im), 1: (re, im + term), 2: (re - term, im), 3: (re, im - term)}[m % 4]
    return complex(float(re), float(im))


@pytest.mark.parametrize("y", [0.0, 1e-12, 1e-6, -3e-3, 0.1, -0.5, 0.77, 0.999, -0.999, 1.0, 1.5, -2.7, 4.0])
def test_phi_functions_to_two_ulps(y):
    got = phi_functions(y)
    for k in (1, 2, 3):
        exact = _phi_exact(y, k)
        assert abs(got[k - 1] - exact) <= 4e-16 * abs(exact), (y, k, got[k - 1], exact)


def _dense_direct(z0, N1, Nm, N5, omega, h, K):
    A = np.empty((K - 1, omega.size))
    for n, w in enumerate(omega):
        b1 = (4 * Nm[n] - 3 * N1[n] - N5[n]) / h
        b2 = 2 * (N1[n] - 2 * Nm[n] + N5[n]) / h**2
        for k in range(1, K):
            s = k * h / K
            p1, p2, p3 = phi_functions(w * s)
            z = np.exp(1j * w * s) * z0[n] + s * p1 * N1[n] + b1 * s**2 * p2 + 2 * b2 * s**3 * p3
            A[k - 1, n] = z.imag / w
    return A


def test_dense_output_matches_direct_formula_and_dop853():
    rng = np.random.default_rng(3)
    omega = np.array([0.3, 2.0, 40.0, 900.0, 3.1e5])          # from resolved to ~90 turns a step
    h = 1e-3 * 7
    z0 = rng.normal(size=5) + 1j * rng.normal(size=5)
    N1, Nm, N5 = (rng.normal(size=5) + 0j for _ in range(3))
    K = TENSION_SAMPLES
    A, AD = np.empty((K - 1, 5)), np.empty((K - 1, 5))
    zero = np.zeros(5)
    plate = make_plate(omega, zero, zero, zero, zero, omega, zero, 0.0)     # undamped modes
    dense_states(z0, N1, Nm, N5, plate, h, A, AD)
    direct = _dense_direct(z0, N1, Nm, N5, omega, h, K)
    scale = np.abs(direct).max(axis=0)
    assert np.all(np.abs(A - direct) <= 1e-12 * scale), np.abs(A - direct).max(axis=0) / scale
    # the ODE itself for the resolved modes: z' = i w z + P(s), P quadratic through N1, Nm, N5
    for n in range(3):
        b1 = (4 * Nm[n] - 3 * N1[n] - N5[n]) / h
        b2 = 2 * (N1[n] - 2 * Nm[n] + N5[n]) / h**2

        def rhs(s, y, n=n, b1=b1, b2=b2):
            z = y[0] + 1j * y[1]
            dz = 1j * omega[n] * z + N1[n] + b1 * s + b2 * s * s
            return [dz.real, dz.imag]
        sol = solve_ivp(rhs, (0, h), [z0[n].real, z0[n].imag], method="DOP853", rtol=1e-13, atol=1e-16,
                        t_eval=np.arange(1, K) * h / K)
        assert np.allclose(A[:, n], sol.y[1] / omega[n], rtol=1e-10, atol=1e-14 * scale[n])


def test_deflection_and_strain_pass_equals_the_separate_sums():
    p = Parameters(Nmod=61)                                     # not a multiple of 4: the tail loop too
    tab = Tables(p, 1000)
    a = np.random.default_rng(5).normal(size=61) * 1e-3
    J = tab.xq.size
    out, eps, out2, eps2 = np.empty(J), np.empty(J), np.empty(J), np.empty(J)
    modal_sum_strain(a, tab.strain_coef, tab.cosq, out, eps, 700)
    modal_sum(a, tab.cosq, out2, 700)
    strain_nodes(a, tab.strain_coef, tab.cosq, eps2)
    assert np.array_equal(out[:700], out2[:700]) and np.array_equal(eps, eps2)
    assert np.allclose(out2[:700], a @ tab.cosq[:, :700], rtol=0, atol=1e-15 * np.abs(a).sum())
    assert np.allclose(eps2, (tab.strain_coef * a) @ tab.cosq, rtol=0,
                       atol=1e-15 * np.abs(tab.strain_coef * a).sum())


@pytest.mark.parametrize("t_tilde", [0.3, 2.8, 4.4])   # 1, 2 and 3 contact intervals
def test_forcing_projection_equals_hat_weight_matrix(t_tilde):
    """P from per-mode weights and the node projection = P from the (J, N) matrix of hat
    weights ends_j dx cos(lambda_n x_j) sinc^2(lambda_n dx / 2), to round-off."""
    p = Parameters(Nmod=60)
    tab = Tables(p, 1000)
    r = solve(p, Settings(tolerance=1e-10, error_estimate=False), times=[t_tilde * p.time_scale], fields=())
    a, t = r.amplitudes[0], r.times[0]
    J = tab.xq.size
    delta, fvals, P = np.empty(J), np.empty(J), np.empty(60)
    st, force, jmax = layer_forcing(tab.model, t, a, delta, fvals, P)
    assert st == 0 and np.any(fvals[:jmax] > 0)
    ends = np.ones(J)
    ends[0] = ends[-1] = 0.5
    W = (ends * tab.dx)[:, None] * tab.cosq.T * (tab.wq / tab.dx)[None, :]      # (J, N)
    f = np.where(np.arange(J) < jmax, fvals, 0.0)
    nodal = p.K * tab.coef * (f @ W)
    # plus the exact integrals on the subintervals where delta changes sign, added separately
    extra = np.zeros(60)
    for j in range(jmax - 1):
        d0, d1 = delta[j], delta[j + 1]
        if (d0 > 0) != (d1 > 0):
            x0, x1 = j * tab.dx, (j + 1) * tab.dx
            if d0 > 0:
                xs = x0 + tab.dx * fvals[j] / (fvals[j] - d1)
                add_segment(extra, tab.lam[0], x0, x1, fvals[j], 0.0, -1.0)
                add_segment(extra, tab.lam[0], x0, xs, fvals[j], 0.0, 1.0)
            else:
                xs = x0 + tab.dx * (-d0) / (fvals[j + 1] - d0)
                add_segment(extra, tab.lam[0], x0, x1, 0.0, fvals[j + 1], -1.0)
                add_segment(extra, tab.lam[0], xs, x1, 0.0, fvals[j + 1], 1.0)
    assert np.allclose(P, nodal + p.K * tab.coef * extra, rtol=1e-12, atol=1e-12 * np.abs(P).max())


def _state(a, adot, delta, yb):
    """A State with the modes, nodes and body the contact observer reads (the rest zero)."""
    N, J = a.size, delta.size
    return State(np.zeros(N, complex), np.zeros(N), a, adot, delta, np.zeros(J), yb, np.zeros(N, complex),
                 np.zeros(2), np.zeros(2))


def _reference_run_states(count):
    p = Parameters(Nmod=60)
    tab = Tables(p, 1000)
    times = np.linspace(0.05, 4.6, count) * p.time_scale
    r = solve(p, Settings(error_estimate=False), times=times, fields=())
    return p, tab, r


def test_contact_bound_is_close_to_the_contact_edge():
    """contact_bound's node-by-node bound (its first four modes exact) leaves at most a few
    nodes beyond the last compressed one, where the coarse bound sum |a_n| left hundreds; no
    node at or beyond jmax - 1 is compressed (safety on random amplitudes and every body
    shape: test_body_shapes)."""
    p, tab, r = _reference_run_states(60)
    J = tab.xq.size
    work, delta, fvals, P = np.empty(J), np.empty(J), np.empty(J), np.empty(p.Nmod)
    slack, coarse_slack = [], []
    for a, s in zip(r.amplitudes, r.body_position):
        jmax = contact_bound(tab.model.body, tab.model.basis, s, a, work)
        exact = (a @ tab.cosq + s - tab.model.body.profile) / p.he
        compressed = np.nonzero(exact > 0)[0]
        edge = compressed[-1] + 1 if compressed.size else 0
        assert not np.any(exact[jmax - 1:] > 0)
        slack.append(jmax - edge)
        coarse = min(J, int(body_extent(s + np.abs(a).sum(), tab.model.body) / tab.dx) + 2)
        coarse_slack.append(coarse - edge)
        st, force, jm, _ = layer_forcing_at(tab.model, s, p.V, a, a, delta, fvals, P)
        assert st == 0 and jm == jmax
        assert np.allclose(delta[:jm], exact[:jm], rtol=0, atol=1e-12)
    slack, coarse_slack = np.array(slack), np.array(coarse_slack)
    print(f"nodes beyond the contact edge: mean {slack.mean():.1f}, max {slack.max()} "
          f"(coarse bound: mean {coarse_slack.mean():.1f})")
    assert slack.min() >= 1 and slack.max() <= 0.03 * J and slack.mean() <= 6
    assert coarse_slack.mean() > 20 * slack.mean()


def test_reach_in_step_bounds_every_node_beyond_it():
    """No node at or beyond reach_in_step's jm' has (delta_0 + delta_1) / 2 + drift / he > 0,
    the condition for a sign change inside the step; drifts from 0 to large."""
    p, tab, r = _reference_run_states(40)
    J = tab.xq.size
    work = np.empty(J)
    b = tab.model.body.profile
    rng = np.random.default_rng(11)
    for i in range(len(r.times) - 1):
        a0, a1 = r.amplitudes[i], r.amplitudes[i + 1]
        s0, s1 = r.body_position[i], r.body_position[i + 1]
        jm = max(contact_bound(tab.model.body, tab.model.basis, s0, a0, work), contact_bound(tab.model.body, tab.model.basis, s1, a1, work))
        d0 = (a0 @ tab.cosq + s0 - b) / p.he
        d1 = (a1 @ tab.cosq + s1 - b) / p.he
        for drift in (0.0, *(10.0 ** rng.uniform(-6, -2, size=3))):
            jx = reach_in_step(tab.model.body, tab.model.basis, jm, a0, a1, s0, s1, drift, work)
            assert jx >= jm
            assert not np.any(0.5 * (d0[jx:] + d1[jx:]) + drift / p.he > 0), (i, drift)


def test_contact_observer_on_the_bounded_nodes_equals_the_observer_on_every_node():
    """observe_contacts given delta only on contact_bound's nodes (NaN beyond) records the same
    changes as given delta at every node. The rates are scaled up so that nodes beyond both
    ends' bounds do cross inside the step (checked), which only reach_in_step lets it see."""
    p, tab, r = _reference_run_states(120)
    J = tab.xq.size
    b = tab.model.body.profile
    work = np.empty(J)
    outside = 0
    h = np.diff(r.times).mean()
    for scale in (1.0, 30.0):
        for i in range(len(r.times) - 1):
            a0, a1 = r.amplitudes[i], r.amplitudes[i + 1]
            v0, v1 = scale * r.velocities[i], scale * r.velocities[i + 1]
            # the body at the step's ends t = 0 and h, as deficits d = V t - s against V t
            yb0 = np.array([-r.body_position[i], 0.0])
            yb1 = np.array([p.V * h - r.body_position[i + 1], 0.0])
            body0, body1 = -yb0[0], p.V * h - yb1[0]                  # s as the observer computes it
            full0 = (a0 @ tab.cosq + body0 - b) / p.he
            full1 = (a1 @ tab.cosq + body1 - b) / p.he
            jm0 = contact_bound(tab.model.body, tab.model.basis, body0, a0, work)
            jm1 = contact_bound(tab.model.body, tab.model.basis, body1, a1, work)
            part0, part1 = np.full(J, np.nan), np.full(J, np.nan)
            part0[:jm0], part1[:jm1] = full0[:jm0], full1[:jm1]
            contacts = count_contacts(full0, J, 2.0)
            runs = []
            for d0, j0, d1, j1 in ((full0, J, full1, J), (part0, jm0, part1, jm1)):
                s0, s1 = _state(a0, v0, d0.copy(), yb0), _state(a1, v1, d1.copy(), yb1)
                work_c = contact_work(J)
                end0, end1 = Snapshot(s0.a, s0.adot, s0.delta, s0.yb), Snapshot(s1.a, s1.adot, s1.delta, s1.yb)
                count, (rec, n), largest = observe_contacts(tab.model, work_c, 0.0, h, end0, j0, end1, j1, contacts,
                                                            Rows(np.empty((64, 2)), 0))
                runs.append((count, largest, rec[:n].copy()))
            assert runs[0][0] == runs[1][0] and runs[0][1] == runs[1][1], i
            np.testing.assert_allclose(runs[1][2], runs[0][2], rtol=1e-12, atol=1e-12 * h)
            # does a node beyond both bounds change sign inside the step (Hermite of its ends)?
            jm = max(jm0, jm1)
            rate0 = (v0 @ tab.cosq + p.V) / p.he
            rate1 = (v1 @ tab.cosq + p.V) / p.he
            roots = np.empty(3)
            for j in range(jm, J):
                c = hermite(full0[j], full1[j], rate0[j], rate1[j], h)
                if cubic_sign_changes(*c, roots):
                    outside += 1
    print(f"nodes beyond both ends' bounds that change sign inside a step: {outside}")
    assert outside > 0


def test_cubic_pieces():
    """The Hermite cubic's maximum, first reach of a level and sign changes on a cubic with known
    roots 0.2, 0.5 (and 1.1, beyond the step) and known extrema, to round-off (solver.cubic)."""
    c0, c1, c2, c3 = -0.11, 0.87, -1.8, 1.0             # (th - 0.2)(th - 0.5)(th - 1.1)
    p = np.polynomial.Polynomial([c0, c1, c2, c3])
    roots = np.empty(3)
    assert cubic_sign_changes(c0, c1, c2, c3, roots) == 2
    np.testing.assert_allclose(roots[:2], [0.2, 0.5], rtol=0, atol=1e-15)
    crit = np.sort(p.deriv().roots().real)
    value, th = cubic_max(c0, c1, c2, c3)
    assert th == pytest.approx(crit[0], abs=1e-15) and value == pytest.approx(p(crit[0]), abs=1e-16)
    assert cubic_first_reach(c0, c1, c2, c3, 0.0) == pytest.approx(0.2, abs=1e-15)
    assert cubic_first_reach(c0, c1, c2, c3, 1.0) == -1.0                   # never reached on [0, 1]
    # Hermite data from the cubic's own values and slopes at the ends give back the cubic
    h = 0.7
    d = p.deriv()
    np.testing.assert_allclose(hermite(p(0.0), p(1.0), d(0.0) / h, d(1.0) / h, h), [c0, c1, c2, c3], atol=1e-15)
