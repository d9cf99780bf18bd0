r"""Numba kernels of the normal-mode impact model (MODEL_NOTES.md, "Equations").

Only scalars and float/int arrays cross the kernel boundary; kernels return status codes and
never raise. :mod:`solver.core` is the one Python adapter that prepares their inputs.

Model, SI units, symmetric half plate 0 <= x <= L::

    w(x, t)   = sum_n a_n(t) cos(lambda_n x),        lambda_n = pi n / L
    delta     = (w + V t - x^2 / (2 R)) / he           relative compression of the layer
    f(delta)  = delta / (1 - delta) for 0 < delta < 1, 0 for delta <= 0
    a_n'' + omega_n^2 a_n = P_n,  P_n = coef_n * int_0^L f(delta) cos(lambda_n x) dx,
    coef_n    = -2 K / (L M_n)                          (mode equation, factor 2 by symmetry)
    F(t)      = 2 K int_0^L f(delta) dx                 body force per unit width [N m-1]
    eps(x, t) = (hi/2) sum_n lambda_n^2 a_n cos(lambda_n x)   upper-surface strain

Modal variables: z_n = a_n' + i omega_n a_n, so that z_n' = i omega_n z_n + P_n(t, a) exactly
(MODEL_NOTES, "Numerical method"), and a_n = Im(z_n) / omega_n.  The plate energy is
E_plate = sum_n L M_n |z_n|^2 / 2, so |z| weighted by L M_n is the energy norm used for error
control. The work of the body W = int_0^t V F ds is integrated as one more component.

Forcing quadrature (the seed's): [0, L] cut into J subintervals of width dx, f taken linear
on each, products with cos(lambda_n x) integrated exactly. Node weights of the hat functions:
    int hat_j(x) cos(lambda x) dx = c_j dx cos(lambda x_j) sinc^2(lambda dx / 2),
c_j = 1/2 at x = 0 and x = L, 1 inside.  A subinterval where delta changes sign is split
and only its compressed part is integrated: f is continued by f(delta) = delta for
delta <= 0 (C1 at 0), interpolated linearly between the nodes, and cut at its zero xs.
Splitting at the zero of the interpolated delta instead (the obvious choice) leaves a jump
of (dx/2) f_j in dP/d(delta_j+1) each time a node changes sign, which happens about once
a step and cost the adaptive integrator an order of accuracy; with the continuation P is
C1 in the state.

Integrators (both land exactly on every requested output time):
  * ``ETD34``: exponential Runge-Kutta with Krogstad's fourth-order stages and an embedded
    third-order solution sharing the first-same-as-last stage (the ETD(3,4) pair of Whalen,
    Brio & Moloney, J. Comput. Phys. 280, 2015).  With phi_k the usual phi functions of
    zeta = i omega h and N_k = P(t_k, U_k):
        U2 = e^{zeta/2} z + (h/2) phi1(zeta/2) N1
        U3 = U2 + h phi2(zeta/2) (N2 - N1)
        U4 = e^{zeta} z + h phi1(zeta) N1 + 2 h phi2(zeta) (N3 - N1)
        z+ = e^{zeta} z + h[(phi1 - 3 phi2 + 4 phi3) N1 + (2 phi2 - 4 phi3)(N2 + N3)
                            + (4 phi3 - phi2) N4]
        err = h (4 phi3 - phi2) (N4 - N5),  N5 = P(t + h, z+)  (reused as N1 of the next step)
    The modal oscillation is exact, so the step is limited only by how fast the forcing
    changes (the contact stiffness), not by omega_N.  A step is rejected and retried smaller
    when the error exceeds the tolerance, is not finite, or any stage reaches delta >= 1.
  * ``RK4``: the seed's classical Runge-Kutta on the same equations (fixed step).

Analytic benchmark used by the tests: with K = 0 (layer off) and z_n(0) = i omega_n
(a_n(0) = 1), both integrators must return a_n(t) = cos(omega_n t); ETD34 to round-off.
"""
import math

import numpy as np
from numba import njit

# status codes returned by :func:`integrate`
OK = 0
LAYER_BOTTOMED_OUT = 1
NONFINITE = 2
STEP_LIMIT = 3
STATUS_NAMES = ("ok", "layer_bottomed_out", "nonfinite", "step_limit")

# integrator codes
ETD34 = 0
RK4 = 1

# layout of the diagnostics vector filled by :func:`integrate`
D_MAX_UPPER, D_MAX_UPPER_X, D_MAX_UPPER_T = 0, 1, 2      # max eps (tension, upper surface)
D_MAX_LOWER, D_MAX_LOWER_X, D_MAX_LOWER_T = 3, 4, 5      # max -eps (tension, lower surface)
D_MAX_ABS, D_MAX_ABS_X, D_MAX_ABS_T = 6, 7, 8            # max |eps|
D_CRACK_UPPER_T, D_CRACK_UPPER_X = 9, 10                 # first time max eps > eps_Y
D_CRACK_LOWER_T, D_CRACK_LOWER_X = 11, 12                # first time max -eps > eps_Y
D_MAX_CONTACTS = 13                                      # max number of contact intervals
D_MAX_FORCE, D_MAX_FORCE_T = 14, 15
D_MAX_DELTA, D_MAX_DELTA_T = 16, 17
D_ENERGY_RESIDUAL = 18     # max_t |E_plate + E_layer - W| / W(t_reached)
D_WORK = 19                # W(t_reached) [J m-1]
D_T_REACHED = 20
D_STEPS = 21               # accepted steps
D_REJECTED = 22            # rejected steps
D_H_MIN = 23               # smallest accepted step [s]
D_H_MAX = 24               # largest accepted step [s]
D_RHS = 25                 # forcing evaluations
D_FAIL_T = 26              # time of the step that failed (NaN if none)
D_FAIL_KIND = 27           # why the run stopped early: one of the FAIL_* codes
N_DIAG = 28

FAIL_NONE = 0
FAIL_MAX_STEPS = 1         # max_steps attempted
FAIL_STEP_UNDERFLOW = 2    # error control drove the step below h_min
FAIL_BOTTOMED = 3          # every retry down to h_min had a stage with delta >= 1
FAIL_FIXED_STEP = 4        # a fixed-step run met delta >= 1 or a non-finite state
FAIL_NONFINITE = 5         # non-finite state with the adaptive step at h_min

#: a step underflow with delta above this is the layer bottoming out, not an integrator failure
BOTTOM_DELTA = 1.0 - 1e-6

_BISECTIONS = 40


# ---------------------------------------------------------------------------------------
# elementary functions
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def phi_functions(y):
    """phi_1, phi_2, phi_3 of zeta = i y (phi_k(z) = sum_m z^m / (m + k)!)."""
    z = 1j * y
    if abs(y) < 1.0:
        p1 = 1.0 + 0j
        p2 = 1.0 + 0j
        p3 = 1.0 + 0j
        for m in range(20, 0, -1):
            p1 = 1.0 + p1 * z / (1 + m)
            p2 = 1.0 + p2 * z / (2 + m)
            p3 = 1.0 + p3 * z / (3 + m)
        return p1, p2 / 2.0, p3 / 6.0
    e = complex(math.cos(y), math.sin(y))
    p1 = (e - 1.0) / z
    p2 = (e - 1.0 - z) / (z * z)
    p3 = (e - 1.0 - z - 0.5 * z * z) / (z * z * z)
    return p1, p2, p3


# ---------------------------------------------------------------------------------------
# forcing
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _add_segment(P, lam1, alpha, beta, ga, gb, sign):
    """P_n += sign * int_alpha^beta g(x) cos(lambda_n x) dx, g linear from ga to gb (exact).

    With c = (alpha + beta)/2, r = (beta - alpha)/2, gbar = (ga + gb)/2:
        int = 2 r gbar cos(lam c) sinc(lam r) - (gb - ga) sin(lam c) lam r^2 q(lam r).
    cos/sin(n lam_1 c) and (n lam_1 r) follow by rotation, n = 1..N.
    """
    r = 0.5 * (beta - alpha)
    if r <= 0.0:
        return
    c = 0.5 * (alpha + beta)
    gbar = 0.5 * (ga + gb)
    dg = gb - ga
    rot_c = complex(math.cos(lam1 * c), math.sin(lam1 * c))
    cur_c = rot_c
    rot_r = complex(math.cos(lam1 * r), math.sin(lam1 * r))
    cur_r = rot_r
    for n in range(P.shape[0]):
        lam = lam1 * (n + 1)
        y = lam * r
        if y < 1e-4:
            sinc = 1.0 - y * y / 6.0
        else:
            sinc = cur_r.imag / y
        if y < 0.1:
            y2 = y * y
            q = 1.0 / 3.0 - y2 / 30.0 + y2 * y2 / 840.0 - y2 * y2 * y2 / 45360.0
        else:
            q = (cur_r.imag - y * cur_r.real) / (y * y * y)
        P[n] += sign * (2.0 * r * gbar * cur_c.real * sinc - dg * cur_c.imag * lam * r * r * q)
        cur_c *= rot_c
        cur_r *= rot_r


@njit(cache=True, nogil=True)
def layer_forcing(t, a, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, P):
    """Modal forcing P_n(t, a) and body force F(t) from the layer reaction.

    Parameters
    ----------
    t : time [s].  a : modal amplitudes a_n [m].  lam1 : lambda_1 [m-1].
    coef : -2 K / (L M_n) divided by K, i.e. -2 / (L M_n) [m kg-1 ... per Pa].
    cosq : cos(lambda_n x_j), shape (N, J).  wq : hat weights, shape (J, N) [m].
    dx : subinterval width [m].  V, R, he, K : see Parameters.
    delta, fvals : work arrays (J,) receiving delta and f at the nodes j < jmax.
    P : output (N,), the forcing P_n [m s-2].

    Returns
    -------
    status : 0, or 1 if some node has delta >= 1 (P is then meaningless).
    force : F(t) [N m-1].
    jmax : nodes j >= jmax cannot be in contact (delta < 0 there); delta, fvals are set below it.
    """
    N = a.shape[0]
    J = delta.shape[0]
    if K == 0.0:                     # layer switched off (kernel-level tests): no contact at all
        for n in range(N):
            P[n] = 0.0
        return 0, 0.0, 0
    bound = 0.0
    for n in range(N):
        bound += abs(a[n])
    s = V * t + bound
    if s <= 0.0:
        jmax = 1
    else:
        jmax = min(J, int(math.sqrt(2.0 * R * s) / dx) + 2)
    for j in range(jmax):
        delta[j] = 0.0
    for n in range(N):
        an = a[n]
        if an != 0.0:
            for j in range(jmax):
                delta[j] += an * cosq[n, j]
    inv2R = 0.5 / R
    for n in range(N):
        P[n] = 0.0
    force = 0.0
    for j in range(jmax):
        x = j * dx
        d = (delta[j] + V * t - x * x * inv2R) / he
        delta[j] = d
        if d > 0.0:
            if not d < 1.0:          # also catches NaN
                return 1, 0.0, jmax
            f = d / (1.0 - d)
            fvals[j] = f
            for n in range(N):
                P[n] += f * wq[j, n]
            if j == 0 or j == J - 1:
                force += 0.5 * dx * f
            else:
                force += dx * f
        else:
            fvals[j] = 0.0
    # subintervals where delta changes sign: f is continued by f(delta) = delta for delta <= 0
    # (C1 at 0, since f'(0) = 1), interpolated linearly, and only its positive part kept; the
    # split point xs then moves smoothly and P stays C1 when a node changes sign
    for j in range(jmax - 1):
        d0 = delta[j]
        d1 = delta[j + 1]
        if (d0 > 0.0) != (d1 > 0.0):
            x0 = j * dx
            x1 = x0 + dx
            if d0 > 0.0:
                f0 = fvals[j]
                xs = x0 + dx * f0 / (f0 - d1)
                _add_segment(P, lam1, x0, x1, f0, 0.0, -1.0)
                _add_segment(P, lam1, x0, xs, f0, 0.0, 1.0)
                force += 0.5 * f0 * (xs - x0 - dx)
            else:
                f1 = fvals[j + 1]
                xs = x0 + dx * (-d0) / (f1 - d0)
                _add_segment(P, lam1, x0, x1, 0.0, f1, -1.0)
                _add_segment(P, lam1, xs, x1, 0.0, f1, 1.0)
                force += 0.5 * f1 * (x1 - xs - dx)
    for n in range(N):
        P[n] *= K * coef[n]
    return 0, 2.0 * K * force, jmax


@njit(cache=True, nogil=True)
def layer_energy(delta, jmax, dx, K, he):
    """E_layer = 2 K he int_0^L G(delta) dx, G = -delta - ln(1 - delta) (delta > 0).

    Trapezoid on the nodes; on a subinterval where delta changes sign, G is taken linear from
    0 at the split point of the forcing quadrature to the compressed node.
    """
    J = delta.shape[0]
    total = 0.0
    for j in range(jmax):
        d = delta[j]
        if d > 0.0:
            G = -d - math.log1p(-d)
            wl = 0.5 * dx if j > 0 else 0.0
            wr = 0.5 * dx if j < J - 1 else 0.0
            f = d / (1.0 - d)
            if j > 0 and not delta[j - 1] > 0.0:
                wl = 0.5 * dx * f / (f - delta[j - 1])
            if j < J - 1 and j + 1 < jmax and not delta[j + 1] > 0.0:
                wr = 0.5 * dx * f / (f - delta[j + 1])
            total += (wl + wr) * G
    return 2.0 * K * he * total


@njit(cache=True, nogil=True)
def count_contacts(delta, jmax):
    """Disjoint intervals of delta > 0 on -L..L from the nodes of 0..L (central one once)."""
    count = 0
    inside = False
    for j in range(jmax):
        if delta[j] > 0.0:
            if not inside:
                count += 1 if j == 0 else 2
                inside = True
        else:
            inside = False
    return count


# ---------------------------------------------------------------------------------------
# strain diagnostics
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _strain_nodes(a, strain_coef, cosq, eps):
    J = eps.shape[0]
    for j in range(J):
        eps[j] = 0.0
    for n in range(a.shape[0]):
        c = strain_coef[n] * a[n]
        if c != 0.0:
            for j in range(J):
                eps[j] += c * cosq[n, j]


@njit(cache=True, nogil=True)
def _peak(eps, sign, dx):
    """Largest sign*eps over the nodes, refined by a parabola through three nodes.

    The strain is even about x = 0 and about x = L, so a peak on an end node is exact.
    Returns (value, x).
    """
    J = eps.shape[0]
    jbest = 0
    best = sign * eps[0]
    for j in range(1, J):
        v = sign * eps[j]
        if v > best:
            best = v
            jbest = j
    if jbest == 0 or jbest == J - 1:
        return best, jbest * dx
    em = sign * eps[jbest - 1]
    ep = sign * eps[jbest + 1]
    curv = em - 2.0 * best + ep
    if curv >= 0.0:
        return best, jbest * dx
    off = 0.5 * (em - ep) / curv
    return best - 0.25 * (em - ep) * off, (jbest + off) * dx


@njit(cache=True, nogil=True)
def _dense_a(z0, N0, N1, omega, h, s, a):
    """a(t0 + s) from z(t0 + s) = e^{i w s} z0 + s phi1 N0 + (s^2/h) phi2 (N1 - N0).

    Exact solution of z' = i w z + P with P linear in time between the step's end values.
    """
    for n in range(z0.shape[0]):
        y = omega[n] * s
        p1, p2, p3 = phi_functions(y)
        e = complex(math.cos(y), math.sin(y))
        z = e * z0[n] + s * p1 * N0[n] + (s * s / h) * p2 * (N1[n] - N0[n])
        a[n] = z.imag / omega[n]


@njit(cache=True, nogil=True)
def _locate_crossing(z0, N0, N1, omega, h, t0, sign, eps_Y, strain_coef, cosq, dx, a, eps):
    """Bisection in the step (t0, t0 + h] for the first time max(sign * eps) = eps_Y."""
    lo = 0.0
    hi = h
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        _dense_a(z0, N0, N1, omega, h, mid, a)
        _strain_nodes(a, strain_coef, cosq, eps)
        v, x = _peak(eps, sign, dx)
        if v > eps_Y:
            hi = mid
        else:
            lo = mid
    _dense_a(z0, N0, N1, omega, h, hi, a)
    _strain_nodes(a, strain_coef, cosq, eps)
    v, x = _peak(eps, sign, dx)
    return t0 + hi, x


# ---------------------------------------------------------------------------------------
# main loop
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def integrate(method, omega, coef, strain_coef, LM, lam1, cosq, wq, dx,
              V, R, he, K, eps_Y, t_start, t_end, t_out, tolerance, fixed_step, h_init, h_min,
              h_max, max_steps, a0, adot0, out_a, out_adot, out_contacts, out_force, out_energy,
              out_err, diag):
    """Integrate the mode equations from t_start to t_end, landing on every t_out.

    Parameters
    ----------
    method : ETD34 or RK4.  omega, coef, strain_coef, LM : per-mode omega_n [s-1],
        -2/(L M_n), (hi/2) lambda_n^2 [m-1], L M_n [kg m-1].  lam1 : lambda_1 [m-1].
    cosq (N, J), wq (J, N), dx : quadrature nodes, see :func:`layer_forcing`.
    V, R, he, K, eps_Y : case parameters (SI).
    t_start, t_end : start and end of the run [s] (the body is at y = x^2/2R + he - V t).
    t_out : sorted output times in [t_start, t_end] [s].
    tolerance : relative error per step in the energy norm (ETD34 adaptive).
    fixed_step : > 0 for a fixed step [s] (RK4 always; ETD34 without error control).
    h_init, h_min, h_max : first trial, smallest and largest step [s] (adaptive). h_max must
        resolve the contact oscillation: in free flight the forcing and hence the error
        estimate vanish, and only h_max stops a step from jumping deep into a new contact.
    max_steps : attempted steps before STEP_LIMIT.
    a0, adot0 : a_n [m] and a_n' [m s-1] at t_start.
    out_a, out_adot (T, N), out_contacts (T,), out_force (T,), out_energy (T, 3), out_err (T,):
        filled at each output time reached: a, a', contact intervals, F, (E_plate, E_layer, W),
        and the sum over accepted steps of the local error estimate in strain amplitude,
        sqrt(sum_n ((hi/2) lambda_n^2 |err_n| / omega_n)^2) (an estimate of the time-integration
        error of the strain, without cancellation).
    diag : (N_DIAG,) diagnostics, see the D_* indices.

    Returns
    -------
    status : OK, LAYER_BOTTOMED_OUT, NONFINITE or STEP_LIMIT.
    n_out : number of output times filled.
    """
    N = omega.shape[0]
    J = cosq.shape[1]
    T = t_out.shape[0]
    nan = np.nan
    for i in range(N_DIAG):
        diag[i] = nan
    diag[D_MAX_UPPER] = -np.inf
    diag[D_MAX_LOWER] = -np.inf
    diag[D_MAX_ABS] = -np.inf
    diag[D_MAX_CONTACTS] = 0.0
    diag[D_MAX_FORCE] = 0.0
    diag[D_MAX_FORCE_T] = 0.0
    diag[D_MAX_DELTA] = -np.inf
    diag[D_H_MIN] = np.inf
    diag[D_H_MAX] = 0.0
    diag[D_FAIL_KIND] = FAIL_NONE

    # work arrays
    z = np.empty(N, np.complex128)
    z_prev = np.empty(N, np.complex128)
    zs = np.empty(N, np.complex128)
    znew = np.empty(N, np.complex128)
    err = np.empty(N, np.complex128)
    incr = np.empty(N, np.complex128)
    N1 = np.empty(N)
    N2 = np.empty(N)
    N3 = np.empty(N)
    N4 = np.empty(N)
    N5 = np.empty(N)
    N_prev = np.empty(N)
    a = np.empty(N)
    a_work = np.empty(N)
    delta = np.empty(J)
    fvals = np.empty(J)
    eps = np.empty(J)
    cE = np.empty(N, np.complex128)
    cE2 = np.empty(N, np.complex128)
    cA2 = np.empty(N, np.complex128)
    cA3 = np.empty(N, np.complex128)
    cA4a = np.empty(N, np.complex128)
    cA4b = np.empty(N, np.complex128)
    cB1 = np.empty(N, np.complex128)
    cB23 = np.empty(N, np.complex128)
    cB4 = np.empty(N, np.complex128)
    h_coeffs = -1.0

    for n in range(N):
        z[n] = complex(adot0[n], omega[n] * a0[n])
        a[n] = a0[n]
    t = t_start
    work = 0.0
    err_sum = 0.0
    rhs_count = 1
    st, force, jmax = layer_forcing(t, a, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N1)
    if st != 0:
        diag[D_T_REACHED] = t
        diag[D_FAIL_T] = t
        diag[D_FAIL_KIND] = FAIL_BOTTOMED
        return LAYER_BOTTOMED_OUT, 0
    contacts = count_contacts(delta, jmax)
    energy_norm_floor = V * math.sqrt(LM[0])
    max_residual = 0.0

    k = 0
    status = OK
    steps = 0
    rejected = 0
    h = min(h_init, h_max)
    fixed_target = -1.0
    fixed_h = 0.0
    t_prev = t_start
    dmax_now = 0.0
    prev_ratio = 1.0
    while True:
        # ----- record outputs due at the current time
        while k < T and t_out[k] <= t:
            e_plate = 0.0
            for n in range(N):
                out_a[k, n] = z[n].imag / omega[n]
                out_adot[k, n] = z[n].real
                e_plate += 0.5 * LM[n] * (z[n].real ** 2 + z[n].imag ** 2)
            out_contacts[k] = count_contacts(delta, jmax)
            out_force[k] = force
            out_energy[k, 0] = e_plate
            out_energy[k, 1] = layer_energy(delta, jmax, dx, K, he)
            out_energy[k, 2] = work
            out_err[k] = err_sum
            k += 1
        if t >= t_end:
            break
        if steps + rejected >= max_steps:
            status = STEP_LIMIT
            diag[D_FAIL_T] = t
            diag[D_FAIL_KIND] = FAIL_MAX_STEPS
            break
        target = t_out[k] if k < T else t_end
        # ----- choose the step
        remaining = target - t
        if fixed_step > 0.0:
            # one step size per output interval, fixed for the whole interval (the ETD
            # coefficients are then computed once per interval); the last step lands on target
            if target != fixed_target:
                fixed_target = target
                n_sub = math.ceil(remaining / fixed_step * (1.0 - 1e-12))
                fixed_h = remaining / max(n_sub, 1)
            # the last step takes exactly what remains (it differs from fixed_h by rounding)
            landing = remaining <= 1.5 * fixed_h
            h_step = remaining if landing else fixed_h
        else:
            h_step = h
            if h_step >= remaining * (1.0 - 1e-12) or remaining - h_step < 0.01 * h_step:
                h_step = remaining
            landing = h_step >= remaining * (1.0 - 1e-12)
        t_new = target if landing else t + h_step

        # ----- one step
        bottom = False
        w_new = 0.0
        F2 = F3 = F4 = F5 = 0.0
        jm5 = jmax
        event = False      # the number of contact intervals changes within the step
        expo = 0.25
        if h_step != h_coeffs:          # ETD coefficients (rk4 uses them for its error estimate)
            for n in range(N):
                y = omega[n] * h_step
                p1, p2, p3 = phi_functions(y)
                q1, q2, q3 = phi_functions(0.5 * y)
                cE[n] = complex(math.cos(y), math.sin(y))
                cE2[n] = complex(math.cos(0.5 * y), math.sin(0.5 * y))
                cA2[n] = 0.5 * h_step * q1
                cA3[n] = h_step * q2
                cA4a[n] = h_step * p1
                cA4b[n] = 2.0 * h_step * p2
                cB1[n] = h_step * (p1 - 3.0 * p2 + 4.0 * p3)
                cB23[n] = h_step * (2.0 * p2 - 4.0 * p3)
                cB4[n] = h_step * (4.0 * p3 - p2)
            h_coeffs = h_step
        if method == ETD34:
            th = t + 0.5 * h_step
            # stage 2
            for n in range(N):
                zs[n] = cE2[n] * z[n] + cA2[n] * N1[n]
                a_work[n] = zs[n].imag / omega[n]
            st, F2, jm = layer_forcing(th, a_work, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N2)
            rhs_count += 1
            if st == 0 and count_contacts(delta, jm) != contacts:
                event = True
            if st == 0:
                for n in range(N):
                    zs[n] = zs[n] + cA3[n] * (N2[n] - N1[n])
                    a_work[n] = zs[n].imag / omega[n]
                st, F3, jm = layer_forcing(th, a_work, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N3)
                rhs_count += 1
                if st == 0 and count_contacts(delta, jm) != contacts:
                    event = True
            if st == 0:
                for n in range(N):
                    zs[n] = cE[n] * z[n] + cA4a[n] * N1[n] + cA4b[n] * (N3[n] - N1[n])
                    a_work[n] = zs[n].imag / omega[n]
                st, F4, jm = layer_forcing(t_new, a_work, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N4)
                rhs_count += 1
                if st == 0 and count_contacts(delta, jm) != contacts:
                    event = True
            if st == 0:
                for n in range(N):
                    znew[n] = cE[n] * z[n] + cB1[n] * N1[n] + cB23[n] * (N2[n] + N3[n]) + cB4[n] * N4[n]
                    a_work[n] = znew[n].imag / omega[n]
                st, F5, jm5 = layer_forcing(t_new, a_work, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N5)
                rhs_count += 1
            if st != 0:
                bottom = True
            else:
                w_new = work + h_step * V * (force / 6.0 + (F2 + F3) / 3.0 + F4 / 6.0)
                if count_contacts(delta, jm5) != contacts:
                    event = True
                if event:
                    # z+ minus the exponential trapezoid e^{zeta} z + h(phi1 - phi2) N1 + h phi2 N5
                    for n in range(N):
                        err[n] = znew[n] - (cE[n] * z[n] + (cA4a[n] - 0.5 * cA4b[n]) * N1[n]
                                            + 0.5 * cA4b[n] * N5[n])
                else:
                    for n in range(N):
                        err[n] = cB4[n] * (N4[n] - N5[n])
        else:
            # classical RK4 on z' = i w z + P
            for n in range(N):
                k1 = 1j * omega[n] * z[n] + N1[n]
                incr[n] = k1                     # accumulates k1 + 2 k2 + 2 k3
                zs[n] = z[n] + 0.5 * h_step * k1
                a_work[n] = zs[n].imag / omega[n]
            th = t + 0.5 * h_step
            st, F2, jm = layer_forcing(th, a_work, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N2)
            rhs_count += 1
            if st == 0:
                for n in range(N):
                    k2 = 1j * omega[n] * zs[n] + N2[n]
                    incr[n] += 2.0 * k2
                    zs[n] = z[n] + 0.5 * h_step * k2
                    a_work[n] = zs[n].imag / omega[n]
                st, F3, jm = layer_forcing(th, a_work, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N3)
                rhs_count += 1
            if st == 0:
                for n in range(N):
                    k3 = 1j * omega[n] * zs[n] + N3[n]
                    incr[n] += 2.0 * k3
                    zs[n] = z[n] + h_step * k3
                    a_work[n] = zs[n].imag / omega[n]
                st, F4, jm = layer_forcing(t_new, a_work, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N4)
                rhs_count += 1
            if st == 0:
                for n in range(N):
                    k4 = 1j * omega[n] * zs[n] + N4[n]
                    znew[n] = z[n] + h_step / 6.0 * (incr[n] + k4)
                    a_work[n] = znew[n].imag / omega[n]
                st, F5, jm5 = layer_forcing(t_new, a_work, lam1, coef, cosq, wq, dx, V, R, he, K, delta, fvals, N5)
                rhs_count += 1
            if st != 0:
                bottom = True
            else:
                w_new = work + h_step * V * (force / 6.0 + (F2 + F3) / 3.0 + F4 / 6.0)
                # error estimate: RK4 against the exponential (Krogstad) update from the same
                # stage values; RK4's Taylor approximation of e^{i w h} dominates its error
                for n in range(N):
                    err[n] = znew[n] - (cE[n] * z[n] + cB1[n] * N1[n] + cB23[n] * (N2[n] + N3[n])
                                        + cB4[n] * N4[n])

        # ----- accept or reject
        finite = not bottom
        if finite:
            for n in range(N):
                if not (math.isfinite(znew[n].real) and math.isfinite(znew[n].imag)):
                    finite = False
                    break
            if not math.isfinite(w_new):
                finite = False
        adaptive = method == ETD34 and fixed_step <= 0.0
        if not finite:
            if not adaptive:
                diag[D_FAIL_T] = t
                diag[D_FAIL_KIND] = FAIL_FIXED_STEP
                status = NONFINITE
                break
            rejected += 1
            h = 0.25 * h_step
            if h < h_min:
                diag[D_FAIL_T] = t
                if bottom:
                    status = LAYER_BOTTOMED_OUT
                    diag[D_FAIL_KIND] = FAIL_BOTTOMED
                else:
                    status = NONFINITE
                    diag[D_FAIL_KIND] = FAIL_NONFINITE
                break
            continue
        ratio = 0.0
        if adaptive:
            num = 0.0
            den_old = 0.0
            den_new = 0.0
            for n in range(N):
                num += LM[n] * (err[n].real ** 2 + err[n].imag ** 2)
                den_old += LM[n] * (z[n].real ** 2 + z[n].imag ** 2)
                den_new += LM[n] * (znew[n].real ** 2 + znew[n].imag ** 2)
            scale = tolerance * max(math.sqrt(max(den_old, den_new)), energy_norm_floor)
            ratio = math.sqrt(num) / scale
            if not math.isfinite(ratio):
                ratio = 1e10
            expo = 1.0 / 3.0 if event else 0.25
            if ratio > 1.0:
                rejected += 1
                h = h_step * max(0.2, 0.9 * ratio ** -expo)
                if h < h_min:
                    diag[D_FAIL_T] = t
                    if dmax_now > BOTTOM_DELTA:
                        status = LAYER_BOTTOMED_OUT
                        diag[D_FAIL_KIND] = FAIL_BOTTOMED
                    else:
                        status = STEP_LIMIT
                        diag[D_FAIL_KIND] = FAIL_STEP_UNDERFLOW
                    break
                continue

        # ----- accepted: accumulate the error estimate in strain amplitude, shift the state
        e_step = 0.0
        for n in range(N):
            e_step += (strain_coef[n] / omega[n]) ** 2 * (err[n].real ** 2 + err[n].imag ** 2)
        err_sum += math.sqrt(e_step)
        steps += 1
        for n in range(N):
            z_prev[n] = z[n]
            N_prev[n] = N1[n]
            z[n] = znew[n]
            N1[n] = N5[n]
            a[n] = z[n].imag / omega[n]
        t_prev = t
        t = t_new
        work = w_new
        force = F5
        jmax = jm5
        if h_step < diag[D_H_MIN]:
            diag[D_H_MIN] = h_step
        if h_step > diag[D_H_MAX]:
            diag[D_H_MAX] = h_step

        # ----- diagnostics at the new state (delta, fvals hold the N5 evaluation)
        _strain_nodes(a, strain_coef, cosq, eps)
        up, up_x = _peak(eps, 1.0, dx)
        lo, lo_x = _peak(eps, -1.0, dx)
        if up > diag[D_MAX_UPPER]:
            diag[D_MAX_UPPER] = up
            diag[D_MAX_UPPER_X] = up_x
            diag[D_MAX_UPPER_T] = t
        if lo > diag[D_MAX_LOWER]:
            diag[D_MAX_LOWER] = lo
            diag[D_MAX_LOWER_X] = lo_x
            diag[D_MAX_LOWER_T] = t
        if max(up, lo) > diag[D_MAX_ABS]:
            diag[D_MAX_ABS] = max(up, lo)
            diag[D_MAX_ABS_X] = up_x if up >= lo else lo_x
            diag[D_MAX_ABS_T] = t
        if math.isnan(diag[D_CRACK_UPPER_T]) and up > eps_Y:
            tc, xc = _locate_crossing(z_prev, N_prev, N1, omega, h_step, t_prev, 1.0, eps_Y,
                                      strain_coef, cosq, dx, a_work, eps)
            diag[D_CRACK_UPPER_T] = tc
            diag[D_CRACK_UPPER_X] = xc
        if math.isnan(diag[D_CRACK_LOWER_T]) and lo > eps_Y:
            tc, xc = _locate_crossing(z_prev, N_prev, N1, omega, h_step, t_prev, -1.0, eps_Y,
                                      strain_coef, cosq, dx, a_work, eps)
            diag[D_CRACK_LOWER_T] = tc
            diag[D_CRACK_LOWER_X] = xc
        contacts = count_contacts(delta, jmax)
        if contacts > diag[D_MAX_CONTACTS]:
            diag[D_MAX_CONTACTS] = contacts
        if force > diag[D_MAX_FORCE]:
            diag[D_MAX_FORCE] = force
            diag[D_MAX_FORCE_T] = t
        dmax = -np.inf
        for j in range(jmax):
            if delta[j] > dmax:
                dmax = delta[j]
        dmax_now = dmax
        if dmax > diag[D_MAX_DELTA]:
            diag[D_MAX_DELTA] = dmax
            diag[D_MAX_DELTA_T] = t
        e_plate = 0.0
        for n in range(N):
            e_plate += 0.5 * LM[n] * (z[n].real ** 2 + z[n].imag ** 2)
        residual = abs(e_plate + layer_energy(delta, jmax, dx, K, he) - work)
        if residual > max_residual:
            max_residual = residual

        # ----- next step size
        if adaptive:
            # PI control (Gustafsson): damps the accept/reject oscillation of a plain I step
            r_now = max(ratio, 1e-10)
            fac = 0.9 * r_now ** (-0.7 * expo) * prev_ratio ** (0.4 * expo)
            fac = min(5.0, max(0.2, fac))
            prev_ratio = r_now
            h_next = h_step * fac
            if landing and h_step < h:
                h_next = max(h_next, h)   # a step shortened to land keeps the old proposal
            h = min(h_next, h_max)

    diag[D_T_REACHED] = t
    diag[D_WORK] = work
    diag[D_ENERGY_RESIDUAL] = max_residual / work if work > 0.0 else 0.0
    diag[D_STEPS] = steps
    diag[D_REJECTED] = rejected
    diag[D_RHS] = rhs_count
    return status, k
