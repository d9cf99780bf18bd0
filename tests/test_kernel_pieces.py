"""The solver's elementary pieces against independent evaluations (docs/model.md, "Numerics").

- phi_1..phi_3 of i y against their Taylor series summed exactly in rational arithmetic;
- the dense output (exact sub-steps of a quadratic forcing) against the direct formula
  z(s) = e^{i w s} z0 + s phi1 P0 + b1 s^2 phi2 + 2 b2 s^3 phi3 and against scipy's DOP853;
- the fused deflection + strain pass against the two sums it replaces;
- the forcing's projection on the modes against the hat-function weights written out as a
  (J, N) matrix, the form the forcing used before it was folded into per-mode weights.
"""
from fractions import Fraction
from math import factorial

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from solver import Parameters, Settings, kernels as kn, solve
from solver.core import _Tables


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
    got = kn.phi_functions(y)
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
            p1, p2, p3 = kn.phi_functions(w * s)
            z = np.exp(1j * w * s) * z0[n] + s * p1 * N1[n] + b1 * s**2 * p2 + 2 * b2 * s**3 * p3
            A[k - 1, n] = z.imag / w
    return A


def test_dense_output_matches_direct_formula_and_dop853():
    rng = np.random.default_rng(3)
    omega = np.array([0.3, 2.0, 40.0, 900.0, 3.1e5])          # from resolved to ~90 turns a step
    h = 1e-3 * 7
    z0 = rng.normal(size=5) + 1j * rng.normal(size=5)
    N1, Nm, N5 = (rng.normal(size=5) + 0j for _ in range(3))
    K = kn.TENSION_SAMPLES
    A, AD = np.empty((K - 1, 5)), np.empty((K - 1, 5))
    modes = np.zeros((kn.N_MODE_ROWS, 5))                        # undamped modes
    modes[kn.M_OMEGA] = modes[kn.M_WD] = omega
    kn.dense_states(z0, N1, Nm, N5, modes, h, A, AD)
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


def test_fused_deflection_and_strain_pass_equals_the_separate_sums():
    p = Parameters(Nmod=61)                                     # not a multiple of 4: the tail loop too
    tab = _Tables(p, 1000)
    a = np.random.default_rng(5).normal(size=61) * 1e-3
    J = tab.xq.size
    out, eps, out2, eps2 = np.empty(J), np.empty(J), np.empty(J), np.empty(J)
    kn.modal_sum_strain(a, tab.strain_coef, tab.cosq, out, eps, 700)
    kn.modal_sum(a, tab.cosq, out2, 700)
    kn.strain_nodes(a, tab.strain_coef, tab.cosq, eps2)
    assert np.array_equal(out[:700], out2[:700]) and np.array_equal(eps, eps2)
    assert np.allclose(out2[:700], a @ tab.cosq[:, :700], rtol=0, atol=1e-15 * np.abs(a).sum())
    assert np.allclose(eps2, (tab.strain_coef * a) @ tab.cosq, rtol=0,
                       atol=1e-15 * np.abs(tab.strain_coef * a).sum())


@pytest.mark.parametrize("t_tilde", [0.3, 2.8, 4.4])   # 1, 2 and 3 contact intervals
def test_forcing_projection_equals_hat_weight_matrix(t_tilde):
    """P from per-mode weights and the node projection = P from the (J, N) matrix of hat
    weights ends_j dx cos(lambda_n x_j) sinc^2(lambda_n dx / 2), to round-off."""
    p = Parameters(Nmod=60)
    tab = _Tables(p, 1000)
    r = solve(p, Settings(tolerance=1e-10, error_estimate=False), times=[t_tilde * p.time_scale], fields=())
    a, t = r.amplitudes[0], r.times[0]
    J = tab.xq.size
    delta, fvals, P = np.empty(J), np.empty(J), np.empty(60)
    st, force, jmax = kn.layer_forcing(t, a, tab.coef, tab.cosq, tab.wq, tab.lay, delta, fvals, P)
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
                kn._add_segment(extra, tab.lam[0], x0, x1, fvals[j], 0.0, -1.0)
                kn._add_segment(extra, tab.lam[0], x0, xs, fvals[j], 0.0, 1.0)
            else:
                xs = x0 + tab.dx * (-d0) / (fvals[j + 1] - d0)
                kn._add_segment(extra, tab.lam[0], x0, x1, 0.0, fvals[j + 1], -1.0)
                kn._add_segment(extra, tab.lam[0], xs, x1, 0.0, fvals[j + 1], 1.0)
    assert np.allclose(P, nodal + p.K * tab.coef * extra, rtol=1e-12, atol=1e-12 * np.abs(P).max())
