"""scipy's DOP853 on the same right-hand side: the outside reference users would reach for.

Same equations and forcing kernel as :mod:`solver.kernels`, written as a first-order system
y = (a_n, da_n/dt, W) for :func:`scipy.integrate.solve_ivp`. It has no step rejection on
delta >= 1 and no in-loop diagnostics: max strain and crack onset stay NaN; contact intervals,
force and the energy identity are evaluated at the output times. scipy is imported here only.
"""
from __future__ import annotations

import numpy as np

from . import kernels as kn


class _Bottomed(Exception):
    pass


def integrate_dop853(p, tolerance, tab, times, t_start, t_end, a0, v0, max_steps):
    """Returns (status, n_out, out_a, out_adot, out_contacts, out_force, out_energy, out_err,
    diag) with the meaning of :func:`solver.kernels.integrate` (out_err all NaN: DOP853 gives
    no local error estimates back)."""
    try:
        from scipy.integrate import solve_ivp
    except ImportError:                                      # pragma: no cover
        from .parameters import ParameterError
        raise ParameterError("integrator dop853 needs scipy: pip install scipy") from None
    N = p.Nmod
    J = tab.xq.size
    delta, fvals, P = np.empty(J), np.empty(J), np.empty(N)
    om2 = tab.omega**2
    nfev = [0]

    def forcing(t, a):
        st, F, jmax = kn.layer_forcing(t, a, tab.lam[0], tab.coef, tab.cosq, tab.wq, tab.dx,
                                       p.V, p.R, p.he, p.K, delta, fvals, P)
        return st, F, jmax

    def rhs(t, y):
        nfev[0] += 1
        if nfev[0] > max_steps * 12:
            raise _Bottomed("max_steps")
        st, F, _ = forcing(t, y[:N])
        if st != 0:
            raise _Bottomed(t)
        return np.concatenate([y[N:2 * N], -om2 * y[:N] + P, [p.V * F]])

    T = times.size
    out_a, out_v = np.full((T, N), np.nan), np.full((T, N), np.nan)
    out_c, out_f, out_e = np.full(T, np.nan), np.full(T, np.nan), np.full((T, 3), np.nan)
    diag = np.full(kn.N_DIAG, np.nan)
    diag[kn.D_FAIL_KIND] = kn.FAIL_NONE
    status, reason = kn.OK, None
    y0 = np.concatenate([a0, v0, [0.0]])
    try:
        sol = solve_ivp(rhs, (t_start, t_end), y0, method="DOP853", rtol=tolerance,
                        atol=tolerance * 1e-3, t_eval=times)
        ys, ts = sol.y.T, sol.t
        if not sol.success:
            status, reason = kn.NONFINITE, kn.FAIL_NONFINITE
    except _Bottomed as stop:
        ys, ts = np.empty((0, 2 * N + 1)), np.empty(0)
        status = kn.STEP_LIMIT if str(stop) == "max_steps" else kn.NONFINITE
        reason = kn.FAIL_MAX_STEPS if status == kn.STEP_LIMIT else kn.FAIL_FIXED_STEP
    n_out = ts.size
    for k in range(n_out):
        a, v, work = ys[k, :N], ys[k, N:2 * N], ys[k, 2 * N]
        st, F, jmax = forcing(ts[k], a)
        out_a[k], out_v[k] = a, v
        out_c[k] = kn.count_contacts(delta, jmax)
        out_f[k] = F
        out_e[k] = (0.5 * np.sum(tab.LM * (v**2 + om2 * a**2)),
                    kn.layer_energy(delta, jmax, tab.dx, p.K, p.he), work)
    t_reached = ts[-1] if n_out else t_start
    if status != kn.OK:
        diag[kn.D_FAIL_T] = t_reached
        diag[kn.D_FAIL_KIND] = reason
    diag[kn.D_T_REACHED] = t_end if status == kn.OK else t_reached
    if n_out:
        work = out_e[n_out - 1, 2]
        diag[kn.D_WORK] = work
        residual = np.abs(out_e[:n_out, 0] + out_e[:n_out, 1] - out_e[:n_out, 2])
        diag[kn.D_ENERGY_RESIDUAL] = residual.max() / work if work > 0 else 0.0
    diag[kn.D_RHS] = nfev[0]
    diag[kn.D_STEPS] = nfev[0] / 12            # DOP853 evaluates 12 stages a step
    diag[kn.D_REJECTED] = 0
    return status, n_out, out_a, out_v, out_c, out_f, out_e, np.full(T, np.nan), diag
