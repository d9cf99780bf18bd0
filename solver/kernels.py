r"""Numba kernels of the normal-mode impact model (docs/model.md, "Equations" and "Numerics").

Only scalars and float/int arrays cross the kernel boundary; kernels return status codes and
never raise. :mod:`solver.core` is the one Python adapter that prepares their inputs. The
module is split by what the model is made of, each piece readable and changeable alone:

- plate and water, the per-mode linear part: the ``modes`` table (omega_n, 1/(L M_n), the strain
  factor, L M_n, and the Kelvin-Voigt damping), ``mode_a``/``mode_z``/``emul`` and the phi
  functions (``phi_from``, ``phi_complex``, ``mode_phis``);
- body shape: ``body_profile`` (tabulated at the nodes in ``lay``), ``body_extent``,
  ``body_slope_curvature``;
- body motion: ``body_coefficients``, ``body_accel``, ``body_position``/``body_speed`` (the
  paper's body is the free body's d = u = 0);
- layer law: ``layer_forcing_at``, ``layer_reaction``, ``layer_energy``, ``count_contacts``;
- the integrator step: ``etd_coefficients``, ``take_step``, ``dense_states``;
- observers (diagnostics and events): ``observe_tension``, ``observe_contacts``,
  ``observe_body``, ``gap_peak``, and ``locate_event`` on true sub-steps;
- the loop: ``integrate`` and its named pieces (``_record_output``, ``_next_step``,
  ``_error_ratio``, ``_energy_allowance``, ``_observe_tensions``, ``_finish_diagnostics``).

Model, SI units, symmetric half plate 0 <= x <= L (the paper's body, elastic ice; the
additions beyond the paper are in docs/model.md and at their functions). An off-centre body is
solved on the full plate in the coordinate xi = x + L, 0 <= xi <= 2L, modes cos(k pi xi / 2L):
the same form, with lay[L_MIRROR] = 1 where the half plate's integrals over 0..L are doubled
(2), and the body's centre at lay[L_XC] = L + x0 (docs/model.md, "Off-centre impact")::

    w(x, t)   = sum_n a_n(t) cos(lambda_n x),        lambda_n = pi n / L
    delta     = (w + V t - x^2 / (2 R)) / he           relative compression of the layer
    f(delta)  = delta / (1 - delta) for 0 < delta < 1, 0 for delta <= 0
    a_n'' + omega_n^2 a_n = P_n,  P_n = coef_n * int_0^L f(delta) cos(lambda_n x) dx,
    coef_n    = -2 K / (L M_n)                          (mode equation, factor 2 by symmetry)
    F(t)      = 2 K int_0^L f(delta) dx                 body force per unit width [N m-1]
    eps(x, t) = (hi/2) sum_n lambda_n^2 a_n cos(lambda_n x)   upper-surface strain

Modal variables: z_n = a_n' + i omega_n a_n, so that z_n' = i omega_n z_n + P_n(t, a) exactly,
and a_n = Im(z_n) / omega_n.  The plate energy is E_plate = sum_n L M_n |z_n|^2 / 2, so |z|
weighted by L M_n is the energy norm used for error control. The work of the body
W = int_0^t V F ds is integrated as one more component.

Forcing quadrature (the paper's): [0, L] cut into J subintervals of width dx, f taken linear
on each, products with cos(lambda_n x) integrated exactly. Node weights of the hat functions:
    int hat_j(x) cos(lambda x) dx = c_j dx cos(lambda x_j) sinc^2(lambda dx / 2),
c_j = 1/2 at x = 0 and x = L, 1 inside.  A subinterval where delta changes sign is split
and only its compressed part is integrated: f is continued by f(delta) = delta for
delta <= 0 (C1 at 0), interpolated linearly between the nodes, and cut at its zero xs.
With the continuation P is C1 in the state.

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
    when the error exceeds the tolerance, is not finite, any stage reaches delta >= 1, or the
    energy identity jumps (see ``ENERGY_JUMP``).
  * ``RK4``: the paper's classical Runge-Kutta on the same equations (fixed step).

Events, located inside the step from cubic Hermite interpolants of quantities whose value
and time derivative are both known exactly at the two ends of an accepted step:
  * tension: the peak of +eps (upper surface) and of -eps (lower surface) over x, with
    d/dt max_x eps = eps_t at the peak (envelope theorem), eps_t from a_n' = Re z_n;
  * contacts: delta at each quadrature node near the contact boundary, delta_t = (w_t + V)/he;
  * bottoming: the largest delta over the continuous plate (parabola through the three
    nodes around the largest node), located to the threshold 1 - bottom_gap by root finding
    on true sub-steps of the integrator, so the run ends on a state the integrator computed.

Analytic benchmark used by the tests: with K = 0 (layer off) and z_n(0) = i omega_n
(a_n(0) = 1), both integrators must return a_n(t) = cos(omega_n t); ETD34 to round-off.
"""
import cmath
import math

import numpy as np
from numba import njit

# status codes returned by :func:`integrate`
OK = 0
LAYER_BOTTOMED_OUT = 1
NONFINITE = 2
STEP_LIMIT = 3
ENERGY_VIOLATION = 4
SEPARATED = 5               # a free body left the ice, moving up (run asked to end there)
STOPPED = 6                 # a free body stopped and had not separated at the end of the window
STATUS_NAMES = ("ok", "layer_bottomed_out", "nonfinite", "step_limit", "energy_violation",
                "separated", "stopped")

# integrator codes
ETD34 = 0
RK4 = 1

# layout of the diagnostics vector filled by :func:`integrate`
D_MAX_UPPER, D_MAX_UPPER_X, D_MAX_UPPER_T = 0, 1, 2      # max eps (tension, upper surface)
D_MAX_LOWER, D_MAX_LOWER_X, D_MAX_LOWER_T = 3, 4, 5      # max -eps (tension, lower surface)
D_MAX_ABS, D_MAX_ABS_X, D_MAX_ABS_T = 6, 7, 8            # max |eps|
D_BOTTOM_T, D_BOTTOM_X, D_BOTTOM_SPEED = 9, 10, 11       # located bottoming event
D_ENERGY_JUMPS = 12        # steps rejected because the energy identity jumped
D_MAX_CONTACTS = 13        # max number of contact intervals (events inside steps counted)
D_MAX_FORCE, D_MAX_FORCE_T = 14, 15
D_MAX_DELTA, D_MAX_DELTA_T = 16, 17
D_ENERGY_RESIDUAL = 18     # max_t |E_plate + E_layer - W| / max_t W (= W(t_reached) for the paper's body)
D_WORK = 19                # W(t_reached) [J m-1]
D_T_REACHED = 20
D_STEPS = 21               # accepted steps
D_REJECTED = 22            # rejected steps
D_H_MIN = 23               # smallest accepted step [s]
D_H_MAX = 24               # largest accepted step [s]
D_RHS = 25                 # forcing evaluations
D_FAIL_T = 26              # time of the step that failed (NaN if none)
D_FAIL_KIND = 27           # why the run stopped early: one of the FAIL_* codes
# a body of finite mass (NaN for the prescribed motion)
D_STOP_T = 28              # first time the body's speed reached zero
D_MAX_PENETRATION = 29     # largest penetration s of the body [m] (at a zero of its speed)
D_SEPARATION_T = 30        # time the body left the ice moving up (after it had stopped)
D_SEPARATION_SPEED = 31    # the body's upward speed then [m s-1]
D_BODY_RESIDUAL = 32       # max_t |M (U^2 - V^2)/2 - M g_b s + W| / max_t W
D_DISSIPATED = 33          # energy dissipated in the viscoelastic ice up to the time reached [J m-1]
N_DIAG = 34

FAIL_NONE = 0
FAIL_MAX_STEPS = 1         # max_steps attempted
FAIL_STEP_UNDERFLOW = 2    # error control drove the step below h_min
FAIL_BOTTOMED = 3          # every retry down to h_min had a stage with delta >= 1
FAIL_FIXED_STEP = 4        # a fixed-step run met delta >= 1 or a non-finite state
FAIL_NONFINITE = 5         # non-finite state with the adaptive step at h_min
FAIL_LOCATED = 6           # the gap closed to bottom_gap: located bottoming event
FAIL_ENERGY_JUMP = 7       # the energy identity jumped and no smaller step mended it
FAIL_ENERGY_BOUND = 8      # the run ended with its energy residual above ENERGY_BOUND

#: default bottoming threshold (Settings.bottoming_gap): the layer has bottomed out when its
#: gap he (1 - delta) closes to bottom_gap he anywhere on the plate; the pressure there is
#: K / bottom_gap = 1000 K (8 GPa for the paper's layer: crushed). A larger threshold is less
#: sensitive to grazing approaches: with 1e-6 a bounce whose smallest gap was 1.05e-6 at
#: tolerance 1e-8 crossed it at 1e-9 (N = 40, V = 10 m/s, hi = 1 m)
BOTTOM_GAP = 1e-3
#: energy guard: a step may change the residual E_plate + E_layer - W by at most
#:     ENERGY_JUMP max(W, E_plate + E_layer) + min(1, (RESOLVED_NODES / n_c)^2) |dW|,
#: n_c the compressed nodes: the quadrature's own mismatch is about |dW| (dx / width)^2, O(1)
#: of the tiny energies of first touch. Normal runs (reference case, thin and thick ice, stiff
#: and thin layers, fast impacts; etd34 and rk4) use at most 10% of this allowance.
ENERGY_JUMP = 1e-3
RESOLVED_NODES = 4
#: an adaptive step is at most GROWTH (t - t_start) (after a first step h_init): the tension
#: grows like t^3.5 from first touch, and a cubic Hermite interpolant of t^a over a step h at
#: time t misplaces a level by about 0.005 (h/t)^4 of t, 5e-7 at GROWTH = 0.1
GROWTH = 0.1
#: the peak tension is sampled at TENSION_SAMPLES - 1 points inside each step, from the
#: exponential dense output: modes that oscillate within a step (omega h ~ 5 at N = 60) give
#: the peak a 3e-4 wobble inside the step that the step ends alone cannot see (a step with
#: omega_N h <= 0.4, such as rk4's, resolves every mode and is not sampled)
TENSION_SAMPLES = 8
#: Newton on a peak's position stops when its step is below this fraction of the bracket: the
#: iteration converges quadratically (the error after a step d is ~ lambda_N d^2), so the
#: position is then exact to ~1e-16 m for any bracket of a few subintervals
NEWTON_STOP = 1e-7
#: a step whose end interpolant stays RIPPLE (relative) below the running maximum cannot raise
#: it (the wobble inside a step is ~3e-4): it is not sampled
RIPPLE = 1e-2
#: when the layer is within GAP_WATCH of bottoming, a step's local error of delta at the gap
#: must stay below GAP_ACCURACY times the gap 1 - delta
GAP_WATCH = 1e-2
GAP_ACCURACY = 0.1
#: samples of the global peak in a step where it passes from one local peak to another
SWITCH_SAMPLES = 32
#: a peak that moves more than SWITCH_DISTANCE nodes within one step is taken for a switch
SWITCH_DISTANCE = 10
#: local peaks within PEAK_MARGIN (relative) of the largest node compete for the global peak
PEAK_MARGIN = 0.02
#: an event is bracketed by scanning its step at SCAN sub-steps, so the first crossing is found
SCAN = 8
#: a run whose energy residual ends above this fraction of the work ends energy_violation
ENERGY_BOUND = 1e-3

# columns of a tension record row (see observe_tension)
R_T, R_VALUE, R_RATE, R_X, R_JOIN = 0, 1, 2, 3, 4
N_REC = 5

# rows of the packed per-mode table ``modes`` (plate and water: the per-mode linear part):
# omega_n, -2/(L M_n), (hi/2) lambda_n^2, L M_n, then the Kelvin-Voigt damping: c_n / 2, and
# omega_d = sqrt(omega^2 - c^2/4) of an oscillating mode (kind 0; omega itself when c = 0) or
# kappa = sqrt(c^2/4 - omega^2) of an overdamped one (kind 1), see mode_a and mode_z
M_OMEGA, M_COEF, M_STRAIN, M_LM, M_HALF_C, M_WD, M_KIND = range(7)
N_MODE_ROWS = 7
# entries of ``lay``: quadrature (lambda_1, dx), body motion (V, 1/M, g_b), body shape (R, p,
# flat half-width c, tan of the deadrise), layer law (he, K, tau_l), the plate's geometry (the
# mirror factor: 2 on the symmetric half plate 0..L, whose integrals stand for -L..L; 1 on the
# full plate of an off-centre impact, kernel coordinate xi = x + L in 0..2L; the body's centre
# in kernel coordinates: 0, or L + x0), and L M of the first symmetric mode (the floor of the
# error norm); then lay[N_LAY + j] is the body's profile b(x_j) at the J quadrature nodes
# (computed once per run, see body_profile)
(L_LAM1, L_DX, L_V, L_R, L_HE, L_K, L_INV_MASS, L_BODY_G, L_BODY_P, L_FLAT, L_TANB, L_LAYER_TAU, L_MIRROR,
 L_XC, L_LM_FLOOR) = range(15)
N_LAY = 15
# entries of the run control vector ``ctrl`` of integrate
(C_T_START, C_T_END, C_TOLERANCE, C_FIXED_STEP, C_H_INIT, C_H_MIN, C_H_MAX, C_MAX_STEPS,
 C_BOTTOM_GAP, C_UNTIL_SEPARATION) = range(10)
N_CTRL = 10
# columns of integrate's per-output-time series ``out_series``
(S_CONTACTS, S_FORCE, S_E_PLATE, S_E_LAYER, S_WORK, S_ERR, S_BODY_POSITION, S_BODY_SPEED,
 S_DISSIPATED) = range(9)
N_SERIES = 9
# the body's state: deficits against the prescribed motion, d = V t - s and u = V - U
B_D, B_U = 0, 1


def make_control(t_start, t_end, tolerance, fixed_step, h_init, h_min, h_max, max_steps, bottom_gap,
                 until_separation=False):
    """The ``ctrl`` vector of :func:`integrate` (plain Python: built once per run)."""
    ctrl = np.zeros(N_CTRL)
    ctrl[C_T_START], ctrl[C_T_END], ctrl[C_TOLERANCE], ctrl[C_FIXED_STEP] = t_start, t_end, tolerance, fixed_step
    ctrl[C_H_INIT], ctrl[C_H_MIN], ctrl[C_H_MAX], ctrl[C_MAX_STEPS] = h_init, h_min, h_max, max_steps
    ctrl[C_BOTTOM_GAP] = bottom_gap
    ctrl[C_UNTIL_SEPARATION] = 1.0 if until_separation else 0.0
    return ctrl


# ---------------------------------------------------------------------------------------
# elementary functions
# ---------------------------------------------------------------------------------------
#: Taylor coefficients of phi_3(i y) in u = y^2: real part sum_k (-u)^k / (2k + 3)!, imaginary
#: part y sum_k (-u)^k / (2k + 4)!, k = 0..8 (for |y| < 1 the first omitted terms are below 1e-17)
PHI3_RE = np.array([1.0 / math.factorial(2 * k + 3) for k in range(9)])
PHI3_IM = np.array([1.0 / math.factorial(2 * k + 4) for k in range(9)])


@njit(cache=True, nogil=True)
def phi_from(y, e):
    """phi_1, phi_2, phi_3 of zeta = i y, given e = e^{i y} (phi_k(z) = sum_m z^m / (m + k)!).

    |y| >= 1: closed forms, with 1/(i y) = -i/y (no complex division). |y| < 1: phi_3 by its
    Taylor series (Horner in y^2, real and imaginary parts apart), then phi_2 = i y phi_3 + 1/2
    and phi_1 = i y phi_2 + 1 (exact identities; multiplying by a small i y loses nothing).
    """
    if abs(y) >= 1.0:
        inv = -1j / y
        inv2 = inv * inv
        p1 = (e - 1.0) * inv
        p2 = (e - 1.0 - 1j * y) * inv2
        p3 = (e - 1.0 - 1j * y + 0.5 * y * y) * inv2 * inv
        return p1, p2, p3
    mu = -y * y
    re = PHI3_RE[8]
    im = PHI3_IM[8]
    for k in range(7, -1, -1):
        re = re * mu + PHI3_RE[k]
        im = im * mu + PHI3_IM[k]
    im *= y
    # i y (re + i im) = -y im + i y re
    r2 = 0.5 - y * im
    i2 = y * re
    r1 = 1.0 - y * i2
    i1 = y * r2
    return complex(r1, i1), complex(r2, i2), complex(re, im)


@njit(cache=True, nogil=True)
def phi_functions(y):
    """phi_1, phi_2, phi_3 of zeta = i y (see phi_from)."""
    return phi_from(y, complex(math.cos(y), math.sin(y)))


#: Taylor coefficients 1/(m + 3)! of phi_3(zeta), m = 0..17 (|zeta| < 1: the first omitted term
#: is below 1e-19)
PHI3_SERIES = np.array([1.0 / math.factorial(m + 3) for m in range(18)])


@njit(cache=True, nogil=True)
def phi_complex(zeta):
    """e^zeta, phi_1, phi_2, phi_3 of any complex zeta (a damped mode: Re zeta < 0).

    |zeta| >= 1: closed forms. |zeta| < 1: phi_3 by its Taylor series (Horner), then the exact
    recurrences phi_2 = zeta phi_3 + 1/2, phi_1 = zeta phi_2 + 1, e^zeta = zeta phi_1 + 1.
    """
    if abs(zeta) >= 1.0:
        e = cmath.exp(zeta)
        inv = 1.0 / zeta
        p1 = (e - 1.0) * inv
        p2 = (e - 1.0 - zeta) * inv * inv
        p3 = (e - 1.0 - zeta - 0.5 * zeta * zeta) * inv * inv * inv
        return e, p1, p2, p3
    p3 = complex(PHI3_SERIES[17], 0.0)
    for m in range(16, -1, -1):
        p3 = p3 * zeta + PHI3_SERIES[m]
    p2 = zeta * p3 + 0.5
    p1 = zeta * p2 + 1.0
    return zeta * p1 + 1.0, p1, p2, p3


@njit(cache=True, nogil=True)
def mode_phis(modes, n, d):
    """(e, phi_1, phi_2, phi_3) of the damped mode n over a time d, packed as complex numbers
    that act on its z as emul does: an oscillating mode's of zeta = mu_+ d, mu_+ = -c/2 + i
    omega_d; an overdamped mode's of its two real rates mu_+- = -c/2 +- kappa, as (value at
    mu_+) + i (value at mu_-)."""
    hc = modes[M_HALF_C, n]
    wd = modes[M_WD, n]
    if modes[M_KIND, n] == 0.0:
        return phi_complex(complex(-hc * d, wd * d))
    ep, p1p, p2p, p3p = phi_complex(complex((-hc + wd) * d, 0.0))
    em, p1m, p2m, p3m = phi_complex(complex((-hc - wd) * d, 0.0))
    return (complex(ep.real, em.real), complex(p1p.real, p1m.real), complex(p2p.real, p2m.real),
            complex(p3p.real, p3m.real))


@njit(cache=True, nogil=True)
def emul(e, z, kind):
    """e^{zeta} z for a mode's z: a complex product (kind 0), or component by component for an
    overdamped mode (kind 1: z = y_+ + i y_-, two real decaying components)."""
    if kind == 0.0:
        return e * z
    return complex(e.real * z.real, e.imag * z.imag)


@njit(cache=True, nogil=True)
def plate_damped(modes):
    """True for viscoelastic ice (c_n grows with n: the last mode is damped if any is)."""
    return modes[M_HALF_C, modes.shape[1] - 1] > 0.0


@njit(cache=True, nogil=True)
def mode_a(z, n, modes):
    """a_n from z_n. With mu_+- the roots of mu^2 + c mu + omega^2 = 0, z = a' - mu_- a obeys
    z' = mu_+ z + P: for c = 0, z = a' + i omega a. Oscillating: z = a' + (c/2) a + i omega_d a;
    overdamped: z = y_+ + i y_-, y_+- = a' - mu_-+ a."""
    if modes[M_KIND, n] == 0.0:
        return z.imag / modes[M_WD, n]
    return (z.real - z.imag) / (2.0 * modes[M_WD, n])


@njit(cache=True, nogil=True)
def mode_adot(z, a, n, modes):
    """a_n' from z_n and a_n (see mode_a)."""
    if modes[M_KIND, n] == 0.0:
        return z.real - modes[M_HALF_C, n] * a
    return z.real - (modes[M_HALF_C, n] + modes[M_WD, n]) * a


@njit(cache=True, nogil=True)
def mode_z(a, adot, n, modes):
    """z_n from a_n and a_n' (see mode_a); exactly a' + i omega a for an undamped mode."""
    hc = modes[M_HALF_C, n]
    wd = modes[M_WD, n]
    if modes[M_KIND, n] == 0.0:
        if hc == 0.0:
            return complex(adot, wd * a)
        return complex(adot + hc * a, wd * a)
    return complex(adot + (hc + wd) * a, adot + (hc - wd) * a)


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
def modal_sum(a, cosq, out, jmax):
    """out[j] = sum_n a_n cos(lambda_n x_j) for the nodes j < jmax (a deflection, in a's units).

    Four modes per pass over ``out``: the table rows stream from cache once per four modes,
    which is what bounds this loop (it reads N jmax doubles for 2 flops each).
    """
    modal_sum_range(a, cosq, out, 0, jmax)


@njit(cache=True, nogil=True)
def modal_sum_range(a, cosq, out, j0, j1):
    """modal_sum on the nodes j0 <= j < j1 (the same arithmetic at each node)."""
    N = a.shape[0]
    for j in range(j0, j1):
        out[j] = 0.0
    n = 0
    while n + 4 <= N:
        a0 = a[n]
        a1 = a[n + 1]
        a2 = a[n + 2]
        a3 = a[n + 3]
        c0 = cosq[n]
        c1 = cosq[n + 1]
        c2 = cosq[n + 2]
        c3 = cosq[n + 3]
        for j in range(j0, j1):
            out[j] += (a0 * c0[j] + a1 * c1[j]) + (a2 * c2[j] + a3 * c3[j])
        n += 4
    while n < N:
        an = a[n]
        c0 = cosq[n]
        for j in range(j0, j1):
            out[j] += an * c0[j]
        n += 1


@njit(cache=True, nogil=True)
def modal_sum_strain(a, strain_coef, cosq, out, eps, jmax):
    """modal_sum into out (j < jmax) and strain_nodes into eps (every node).

    Two passes over the table, not one: a fused loop writing both outputs is not vectorised
    and took 25.5 us against 15.7 us for the two (N = 60, J = 1001; the same values).
    """
    modal_sum(a, cosq, out, jmax)
    strain_nodes(a, strain_coef, cosq, eps)


@njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def modal_projection(f, cosq, P, jmax):
    """P[n] = sum_{j < jmax} f_j cos(lambda_n x_j): four rows per pass over f.

    The sums may be reassociated (vectorised); nothing else is relaxed (no fast inf/NaN).
    """
    N = P.shape[0]
    n = 0
    while n + 4 <= N:
        r0 = cosq[n]
        r1 = cosq[n + 1]
        r2 = cosq[n + 2]
        r3 = cosq[n + 3]
        s0 = s1 = s2 = s3 = 0.0
        for j in range(jmax):
            fj = f[j]
            s0 += fj * r0[j]
            s1 += fj * r1[j]
            s2 += fj * r2[j]
            s3 += fj * r3[j]
        P[n] = s0
        P[n + 1] = s1
        P[n + 2] = s2
        P[n + 3] = s3
        n += 4
    while n < N:
        row = cosq[n]
        s = 0.0
        for j in range(jmax):
            s += f[j] * row[j]
        P[n] = s
        n += 1


# ---------------------------------------------------------------------------------------
# body shape: b(x) >= 0, b(0) = 0, even, non-decreasing in |x|; the body is y = b(x) + he - s
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def is_parabola(lay):
    """The paper's parabola x^2 / 2R, centred at the kernel's x = 0."""
    return lay[L_BODY_P] == 2.0 and lay[L_FLAT] == 0.0 and lay[L_TANB] == 0.0 and lay[L_XC] == 0.0


@njit(cache=True, nogil=True)
def body_profile(x, lay):
    """b(x) [m]: with u = max(|x - x_c| - c, 0) (x_c: the body's centre in kernel
    coordinates, 0 but for an off-centre impact; c: half-width of a flat bottom), u tan(beta)
    for a wedge of deadrise beta, else the power law u^p / (p R^(p-1)) (p = 2: the paper's
    parabola u^2 / 2R, exactly x * x * (0.5 / R) at c = 0 and x_c = 0)."""
    u = max(abs(x - lay[L_XC]) - lay[L_FLAT], 0.0)
    if lay[L_TANB] > 0.0:
        return u * lay[L_TANB]
    p = lay[L_BODY_P]
    R = lay[L_R]
    if p == 2.0:
        return u * u * (0.5 / R)
    return u ** p / (p * R ** (p - 1.0))


@njit(cache=True, nogil=True)
def body_slope_curvature(x, lay):
    """(b'(x), b''(x)) (at a wedge's or a flat bottom's corner: the values on the side away
    from the centre x_c)."""
    r = x - lay[L_XC]
    side = 1.0 if r >= 0.0 else -1.0
    u = abs(r) - lay[L_FLAT]
    if u <= 0.0:
        return 0.0, 0.0
    if lay[L_TANB] > 0.0:
        return side * lay[L_TANB], 0.0
    p = lay[L_BODY_P]
    R = lay[L_R]
    return side * (u ** (p - 1.0) / R ** (p - 1.0)), (p - 1.0) * u ** (p - 2.0) / R ** (p - 1.0)


@njit(cache=True, nogil=True)
def body_extent(reach, lay):
    """The largest x with b(x) <= reach (reach > 0): x_c plus b's inverse."""
    xc = lay[L_XC]
    if lay[L_TANB] > 0.0:
        return xc + (lay[L_FLAT] + reach / lay[L_TANB])
    p = lay[L_BODY_P]
    R = lay[L_R]
    if p == 2.0:
        return xc + (lay[L_FLAT] + math.sqrt(2.0 * R * reach))
    return xc + (lay[L_FLAT] + (p * R ** (p - 1.0) * reach) ** (1.0 / p))


# ---------------------------------------------------------------------------------------
# layer law: the reaction K f(delta) and what it does to the modes and the body
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def layer_forcing(t, a, coef, cosq, wq, lay, delta, fvals, P):
    """layer_forcing_at for the body at the paper's constant speed (penetration s = V t) and the
    paper's elastic layer: (status, force, jmax)."""
    st, force, jmax, _ = layer_forcing_at(lay[L_V] * t, lay[L_V], a, a, coef, cosq, wq, lay, delta, fvals, P)
    return st, force, jmax


@njit(cache=True, nogil=True)
def layer_forcing_at(s, U, a, adot, coef, cosq, wq, lay, delta, fvals, P):
    """Modal forcing P_n(s, a) and body force F from the layer reaction, the body's lowest point
    at y = he - s (penetration s: V t for the paper's body), its profile b(x_j) in lay[N_LAY:].

    P_n = (2 K / (L M_n)) int_0^L -f(delta) cos(lambda_n x) dx on the hat functions of the
    nodes: int hat_j cos(lambda_n x) dx = w_j dx sinc^2(lambda_n dx / 2) cos(lambda_n x_j),
    w_j = 1/2 at x = 0 and x = L, else 1; a subinterval where delta changes sign is integrated
    exactly on its compressed part (below).

    Parameters
    ----------
    s : penetration of the body [m].  a : modal amplitudes a_n [m].
    coef : -2 K / (L M_n) divided by K, i.e. -2 / (L M_n) [m kg-1 ... per Pa].
    cosq : cos(lambda_n x_j), shape (N, J).  wq : mode weights dx sinc^2(lambda_n dx / 2),
    shape (N,) [m].  lay : see L_* (lambda_1, dx, he, K, the body's shape and profile).
    delta, fvals : work arrays (J,) receiving delta and f at the nodes j < jmax.
    P : output (N,), the forcing P_n [m s-2].

    Returns
    -------
    status : 0, or 1 if some node has delta >= 1 (P is then meaningless).
    force : F(t) [N m-1].
    jmax : nodes j >= jmax cannot be in contact (delta < 0 there); delta, fvals are set below it.
    power : the power the viscoelastic layer dissipates [W m-1] (0 for the elastic layer).

    A viscoelastic layer (lay[L_LAYER_TAU] = tau_l > 0) presses with K f max(1 + tau_l delta', 0)
    where compressed (layer_damping), delta' = (w' + U) / he from the modal velocities adot and the body's
    downward speed U (both unused for the elastic layer).
    """
    N = a.shape[0]
    J = delta.shape[0]
    if lay[L_K] == 0.0:              # layer switched off (kernel-level tests): no contact at all
        for n in range(N):
            P[n] = 0.0
        return 0, 0.0, 0, 0.0
    jmax = contact_bound(s, a, cosq, lay, delta)
    modal_sum(a, cosq, delta, jmax)
    return layer_reaction(s, U, adot, coef, cosq, wq, lay, jmax, delta, fvals, P)


@njit(cache=True, nogil=True)
def layer_forcing_strain(s, U, a, adot, coef, cosq, wq, lay, delta, fvals, P, strain_coef, eps):
    """layer_forcing, and the strain at every node into eps (strain_nodes), from one pass over
    the table where both are needed."""
    N = a.shape[0]
    J = delta.shape[0]
    if lay[L_K] == 0.0:
        strain_nodes(a, strain_coef, cosq, eps)
        for n in range(N):
            P[n] = 0.0
        return 0, 0.0, 0, 0.0
    jmax = contact_bound(s, a, cosq, lay, delta)
    modal_sum_strain(a, strain_coef, cosq, delta, eps, jmax)
    return layer_reaction(s, U, adot, coef, cosq, wq, lay, jmax, delta, fvals, P)


#: modes taken exactly in contact_bound's node-by-node bound on the deflection
BOUND_MODES = 4


@njit(cache=True, nogil=True)
def contact_bound(s, a, cosq, lay, work):
    """jmax such that no node j >= jmax - 1 touches: delta_j < 0 there.

    Two bounds on the deflection w = sum_n a_n cos(lambda_n x). The coarse one, w <= sum |a_n|,
    limits contact to the nodes j < jc with b(x) <= s + sum |a_n|. On those, each node's own
        w_j <= sum_{n < 4} a_n cos(lambda_n x_j) + sum_{n >= 4} |a_n|
    (last_reachable): scanning from the last node down, the first where b(x_j) - s is within
    it is the last that can touch, j*, and jmax = j* + 2 (the pair (j*, j* + 1) is where the
    layer's split subinterval can lie). The amplitudes fall fast with n, so j* is close to the
    true contact edge: on the reference case jmax is 3.5 nodes beyond it on average, where
    the coarse bound left 295, and the forcing's passes over the table shrink with it. A
    relative 1e-9 of sum |a_n| is added to the bound against rounding. work (J,) is scratch
    (the caller's delta, which the forcing overwrites below jmax); J = work.shape[0].
    """
    J = work.shape[0]
    N = a.shape[0]
    m = min(BOUND_MODES, N)
    head = 0.0
    tail = 0.0
    for n in range(N):
        if n < m:
            head += abs(a[n])
        else:
            tail += abs(a[n])
    reach = s + head + tail
    if reach <= 0.0:
        return 1
    jc = min(J, int(body_extent(reach, lay) / lay[L_DX]) + 2)
    j = last_reachable(a, m, cosq, lay, s + tail + 1e-9 * (head + tail), work, 0, jc)
    return min(J, j + 2)


@njit(cache=True, nogil=True)
def last_reachable(c, m, cosq, lay, lift, work, j0, j1):
    """The last node j0 <= j < j1 with b(x_j) <= lift + sum_{n < m} c_n cos(lambda_n x_j), or
    j0 - 1 if there is none: m + 1 vectorised passes over work (scratch), then a scan down."""
    for j in range(j0, j1):
        work[j] = lay[N_LAY + j] - lift
    for n in range(m):
        cn = c[n]
        row = cosq[n]
        for j in range(j0, j1):
            work[j] -= cn * row[j]
    for j in range(j1 - 1, j0 - 1, -1):
        if work[j] <= 0.0:
            return j
    return j0 - 1


@njit(cache=True, nogil=True)
def layer_damping(U, adot, cosq, lay, jmax, jc, delta, fvals):
    """The viscoelastic layer (tau_l = lay[L_LAYER_TAU] > 0): at each compressed node f becomes
    f max(1 + tau_l delta', 0), delta' = (w' + U) / he, w' = sum_n adot_n cos(lambda_n x_j) (one
    more pass over the table, on the compressed nodes only). The damping is proportional to the
    elastic reaction (Hunt-Crossley), so the pressure stays continuous as a node enters contact,
    as the forcing's C1 continuation needs; the layer never pulls. Returns the new sum of fvals over
    j < jmax (layer_reaction's force before its end weights) and the power the damping part
    dissipates, 2 K sum_j w_j (p_d / K) he delta' [W m-1], each node weighted by the length the
    force's quadrature gives it (dx/2 on each side towards a compressed neighbour, the compressed
    part of a split subinterval towards an uncompressed one, nothing beyond x = 0 and x = L), so
    that a contact patch narrower than dx is not over-counted."""
    J = delta.shape[0]
    tau_l = lay[L_LAYER_TAU]
    he = lay[L_HE]
    wdot = np.empty(jc)
    modal_sum(adot, cosq, wdot, jc)
    power = 0.0
    for j in range(jc):
        if delta[j] > 0.0:
            rate = (wdot[j] + U) / he
            f = fvals[j]
            g = f * max(1.0 + tau_l * rate, 0.0)
            fvals[j] = g
            weight = 0.0
            if j > 0:
                dl = delta[j - 1]
                weight += 0.5 if dl > 0.0 else 0.5 * g / (g - dl) if g > 0.0 else 0.0
            if j < J - 1:
                dr = delta[j + 1] if j + 1 < jmax else -1.0
                weight += 0.5 if dr > 0.0 else 0.5 * g / (g - dr) if g > 0.0 else 0.0
            power += weight * (g - f) * he * rate
    force = 0.0
    for j in range(jmax):
        force += fvals[j]
    return force, lay[L_MIRROR] * lay[L_K] * lay[L_DX] * power


@njit(cache=True, nogil=True)
def layer_reaction(s, U, adot, coef, cosq, wq, lay, jmax, delta, fvals, P):
    """The rest of layer_forcing, given the deflection sum_n a_n cos(lambda_n x_j) in delta
    (j < jmax): delta and f at the nodes (with the viscoelastic layer's part, layer_damping),
    then P and F (see layer_forcing_at)."""
    N = P.shape[0]
    J = delta.shape[0]
    lam1 = lay[L_LAM1]
    dx = lay[L_DX]
    he = lay[L_HE]
    K = lay[L_K]
    force = 0.0
    jc = 0                           # nodes j >= jc are not compressed
    for j in range(jmax):
        d = (delta[j] + s - lay[N_LAY + j]) / he
        delta[j] = d
        f = 0.0
        if d > 0.0:
            if not d < 1.0:          # also catches NaN
                return 1, 0.0, jmax, 0.0
            f = d / (1.0 - d)
            jc = j + 1
        fvals[j] = f
        force += f
    power = 0.0
    if lay[L_LAYER_TAU] > 0.0 and jc > 0:
        force, power = layer_damping(U, adot, cosq, lay, jmax, jc, delta, fvals)
    if jc > 0:
        modal_projection(fvals, cosq, P, jc)
        f0 = 0.5 * fvals[0]          # trapezoid ends: half weight at x = 0 and x = L
        force -= f0
        for n in range(N):
            P[n] -= f0 * cosq[n, 0]
        if jc == J:
            f1 = 0.5 * fvals[J - 1]
            force -= f1
            for n in range(N):
                P[n] -= f1 * cosq[n, J - 1]
        for n in range(N):
            P[n] *= wq[n]
    else:
        for n in range(N):
            P[n] = 0.0
    force *= dx
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
    return 0, lay[L_MIRROR] * K * force, jmax, power


@njit(cache=True, nogil=True)
def layer_energy(delta, jmax, dx, K, he, mirror):
    """E_layer = 2 K he int_0^L G(delta) dx, G = -delta - ln(1 - delta) (delta > 0); on the
    full plate of an off-centre impact (mirror = 1) K he int_0^2L G dx.

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
    return mirror * K * he * total


@njit(cache=True, nogil=True)
def count_contacts(delta, jmax, mirror):
    """Disjoint intervals of delta > 0 on -L..L from the nodes of 0..L (central one once;
    mirror = 2), or from the nodes of the full plate (mirror = 1: each once)."""
    count = 0
    inside = False
    away = 2 if mirror == 2.0 else 1
    for j in range(jmax):
        if delta[j] > 0.0:
            if not inside:
                count += 1 if j == 0 else away
                inside = True
        else:
            inside = False
    return count


# ---------------------------------------------------------------------------------------
# plate: strain at the nodes, peaks over x, a sum of modes at one point
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def strain_nodes(a, strain_coef, cosq, eps):
    """eps_j = sum_n (hi/2) lambda_n^2 a_n cos(lambda_n x_j) at every node (eps: (J,) scratch):
    modal_sum of the products strain_coef_n a_n (the same arithmetic as modal_sum_strain)."""
    c = np.empty(a.shape[0])
    for n in range(a.shape[0]):
        c[n] = strain_coef[n] * a[n]
    modal_sum(c, cosq, eps, eps.shape[0])


@njit(cache=True, nogil=True)
def mode_sum(w, c, lam1, x):
    """sum_n w_n c_n cos(lambda_n x), lambda_n = n lam1 (the cosines by rotation: odd and even
    modes on two interleaved chains, which halves the latency of the recurrence)."""
    rot = complex(math.cos(lam1 * x), math.sin(lam1 * x))
    rot2 = rot * rot
    cur_a = rot
    cur_b = rot2
    ta = 0.0
    tb = 0.0
    N = c.shape[0]
    for n in range(0, N - 1, 2):
        ta += w[n] * c[n] * cur_a.real
        tb += w[n + 1] * c[n + 1] * cur_b.real
        cur_a *= rot2
        cur_b *= rot2
    if N % 2 == 1:
        ta += w[N - 1] * c[N - 1] * cur_a.real
    return ta + tb


@njit(cache=True, nogil=True)
def argmax_node(vals, sign, n):
    """Node j < n of the largest sign * vals[j] (the first one on ties)."""
    jbest = 0
    best = sign * vals[0]
    for j in range(1, n):
        v = sign * vals[j]
        if v > best:
            best = v
            jbest = j
    return jbest


@njit(cache=True, nogil=True)
def climb(vals, sign, j, n):
    """From node j, move to the larger neighbour while sign * vals grows: a local peak."""
    while True:
        best = j
        v = sign * vals[j]
        if j > 0 and sign * vals[j - 1] > v:
            best = j - 1
            v = sign * vals[j - 1]
        if j < n - 1 and sign * vals[j + 1] > v:
            best = j + 1
        if best == j:
            return j
        j = best


@njit(cache=True, nogil=True)
def refine(vals, sign, j, n, dx):
    """sign * vals at the peak near node j over continuous x: a parabola through j - 1, j,
    j + 1. On an end node (x = 0, the symmetry line; x = L, the wall) the node value.
    Returns (value, x)."""
    best = sign * vals[j]
    if j == 0 or j == n - 1:
        return best, j * dx
    em = sign * vals[j - 1]
    ep = sign * vals[j + 1]
    curv = em - 2.0 * best + ep
    if curv >= 0.0:
        return best, j * dx
    off = 0.5 * (em - ep) / curv
    return best - 0.25 * (em - ep) * off, (j + off) * dx


@njit(cache=True, nogil=True)
def mode_sums(w, c, lam1, x):
    """sum_n w_n c_n (cos, -lambda_n sin, -lambda_n^2 cos)(lambda_n x): a modal field and its
    first two x-derivatives at one point (two interleaved rotation chains, as in mode_sum)."""
    rot = complex(math.cos(lam1 * x), math.sin(lam1 * x))
    rot2 = rot * rot
    cur_a = rot
    cur_b = rot2
    a0 = a1 = a2 = 0.0
    b0 = b1 = b2 = 0.0
    N = c.shape[0]
    for n in range(0, N - 1, 2):
        lam = lam1 * (n + 1)
        wc = w[n] * c[n]
        a0 += wc * cur_a.real
        a1 -= wc * lam * cur_a.imag
        a2 -= wc * lam * lam * cur_a.real
        lam = lam1 * (n + 2)
        wc = w[n + 1] * c[n + 1]
        b0 += wc * cur_b.real
        b1 -= wc * lam * cur_b.imag
        b2 -= wc * lam * lam * cur_b.real
        cur_a *= rot2
        cur_b *= rot2
    if N % 2 == 1:
        lam = lam1 * N
        wc = w[N - 1] * c[N - 1]
        a0 += wc * cur_a.real
        a1 -= wc * lam * cur_a.imag
        a2 -= wc * lam * lam * cur_a.real
    return a0 + b0, a1 + b1, a2 + b2


@njit(cache=True, nogil=True)
def _newton_move(x, d1, d2, xlo, xhi, stop):
    """One safeguarded Newton step towards a maximum, from the first and second derivative d1,
    d2 at x, kept in [xlo, xhi]: (new x, done); done when the move is below stop, or at once
    (x kept) when the curvature does not point to a maximum."""
    if not d2 < 0.0:
        return x, True
    xn = min(max(x - d1 / d2, xlo), xhi)
    return xn, abs(xn - x) <= stop


@njit(cache=True, nogil=True)
def continuous_peak(vals, sign, j, n, dx, w, c, lam1, scale, q2, q0):
    """Largest value over continuous x near node j of the field
        v(x) = sign * scale * sum_n w_n c_n cos(lambda_n x) + q2 x^2 + q0,
    whose node values are sign * vals: Newton on v' from the parabola through j - 1, j, j + 1,
    kept within [x_{j-1}, x_{j+1}]. On an end node (x = 0, the symmetry line; x = L, the wall)
    the node. Returns (value, x). Refining on the modes, not on the node values, keeps the
    peak a smooth function of time (a parabola through nodes wobbles by ~1e-4 of a sharp peak
    each time the peak crosses a node)."""
    if j == 0 or j == n - 1:
        return sign * vals[j], j * dx
    v, x = refine(vals, sign, j, n, dx)
    xlo = (j - 1) * dx
    xhi = (j + 1) * dx
    for _ in range(8):
        s0, s1, s2 = mode_sums(w, c, lam1, x)
        x, done = _newton_move(x, sign * scale * s1 + 2.0 * q2 * x, sign * scale * s2 + 2.0 * q2, xlo, xhi,
                               NEWTON_STOP * dx)
        if done:
            break
    s0, s1, s2 = mode_sums(w, c, lam1, x)
    return sign * scale * s0 + q2 * x * x + q0, x


@njit(cache=True, nogil=True)
def global_peak(eps, sign, dx, w, a, lam1):
    """The global peak of sign * eps over continuous x: every local maximum of the nodes within
    PEAK_MARGIN of the largest node is refined on the modes (a sharp peak between nodes can
    rise above a larger node elsewhere by up to (lambda_N dx)^2 / 8 of itself, 0.4% at N = 60).
    Returns (value, x, node)."""
    J = eps.shape[0]
    jtop = argmax_node(eps, sign, J)
    top = sign * eps[jtop]
    floor = top - PEAK_MARGIN * abs(top)
    bv, bx = continuous_peak(eps, sign, jtop, J, dx, w, a, lam1, 1.0, 0.0, 0.0)
    bj = jtop
    for j in range(J):
        v = sign * eps[j]
        if j == jtop or v < floor:
            continue
        if (j > 0 and sign * eps[j - 1] > v) or (j < J - 1 and sign * eps[j + 1] > v):
            continue
        cv, cx = continuous_peak(eps, sign, j, J, dx, w, a, lam1, 1.0, 0.0, 0.0)
        if cv > bv:
            bv, bx, bj = cv, cx, j
    return bv, bx, bj


# ---------------------------------------------------------------------------------------
# cubic Hermite interpolants on a step: p(th), th = (t - t0) / h in [0, 1]
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def hermite(p0, p1, r0, r1, h):
    """Power-basis coefficients of the cubic with p(0) = p0, p(1) = p1 and time derivatives
    r0, r1 at the ends of a step of length h."""
    c2 = 3.0 * (p1 - p0) - h * (2.0 * r0 + r1)
    c3 = 2.0 * (p0 - p1) + h * (r0 + r1)
    return p0, h * r0, c2, c3


@njit(cache=True, nogil=True)
def cubic(c0, c1, c2, c3, th):
    return c0 + th * (c1 + th * (c2 + th * c3))


@njit(cache=True, nogil=True)
def cubic_breaks(c1, c2, c3):
    """The critical points of the cubic in (0, 1), increasing: (count, r1, r2), count 0 to 2
    (r1, r2 meaningful up to count). With 0 and 1 they split [0, 1] into monotone pieces."""
    A = 3.0 * c3
    B = 2.0 * c2
    r1 = -1.0
    r2 = -1.0
    if abs(A) <= 1e-14 * (abs(B) + abs(c1)):
        if B != 0.0:
            r1 = -c1 / B
    else:
        disc = B * B - 4.0 * A * c1
        if disc >= 0.0:
            q = -0.5 * (B + math.copysign(math.sqrt(disc), B))
            r1 = q / A
            if q != 0.0:
                r2 = c1 / q
    if r2 < r1:
        r1, r2 = r2, r1
    n = 0
    b1 = 1.0
    b2 = 1.0
    if 0.0 < r1 < 1.0:
        b1 = r1
        n = 1
    if 0.0 < r2 < 1.0 and r2 != r1:
        if n == 0:
            b1 = r2
        else:
            b2 = r2
        n += 1
    return n, b1, b2


@njit(cache=True, nogil=True)
def _break(k, n, b1, b2):
    """The k-th of the breaks 0, (b1, b2 up to n), 1."""
    if k == 0:
        return 0.0
    if k == n + 1:
        return 1.0
    return b1 if k == 1 else b2


@njit(cache=True, nogil=True)
def cubic_max(c0, c1, c2, c3):
    """(max, argmax) of the cubic over [0, 1]."""
    nc, b1, b2 = cubic_breaks(c1, c2, c3)
    best = -np.inf
    tb = 0.0
    for i in range(nc + 2):
        th = _break(i, nc, b1, b2)
        v = cubic(c0, c1, c2, c3, th)
        if v > best:
            best = v
            tb = th
    return best, tb


@njit(cache=True, nogil=True)
def _bisect(c0, c1, c2, c3, level, lo, hi):
    """th in [lo, hi] where the monotone cubic crosses level (to round-off)."""
    above_hi = cubic(c0, c1, c2, c3, hi) > level
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if (cubic(c0, c1, c2, c3, mid) > level) == above_hi:
            hi = mid
        else:
            lo = mid
    return hi


@njit(cache=True, nogil=True)
def cubic_first_reach(c0, c1, c2, c3, level):
    """Smallest th in [0, 1] with p(th) >= level, or -1 if the cubic stays below level."""
    if c0 >= level:
        return 0.0
    nc, b1, b2 = cubic_breaks(c1, c2, c3)
    for i in range(nc + 1):
        hi = _break(i + 1, nc, b1, b2)
        if cubic(c0, c1, c2, c3, hi) >= level:
            return _bisect(c0, c1, c2, c3, level, _break(i, nc, b1, b2), hi)
    return -1.0


@njit(cache=True, nogil=True)
def cubic_sign_changes(c0, c1, c2, c3, out):
    """The th in (0, 1] where p changes between > 0 and <= 0, increasing; returns the count."""
    nc, b1, b2 = cubic_breaks(c1, c2, c3)
    n = 0
    for i in range(nc + 1):
        lo = _break(i, nc, b1, b2)
        hi = _break(i + 1, nc, b1, b2)
        if (cubic(c0, c1, c2, c3, lo) > 0.0) != (cubic(c0, c1, c2, c3, hi) > 0.0):
            out[n] = _bisect(c0, c1, c2, c3, 0.0, lo, hi)
            n += 1
    return n


# ---------------------------------------------------------------------------------------
# one step of the integrator
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def etd_coefficients(modes, h, C):
    """ETD34 coefficients of a step h for every mode, rows of C (9, N): e^{zeta}, e^{zeta/2},
    then the stage and update weights of the scheme in the module docstring (a damped mode's
    packed as mode_phis packs them)."""
    omega = modes[M_OMEGA]
    for n in range(omega.shape[0]):
        if modes[M_HALF_C, n] == 0.0:
            y = omega[n] * h
            e2 = complex(math.cos(0.5 * y), math.sin(0.5 * y))
            e = e2 * e2                          # one sin/cos for both
            p1, p2, p3 = phi_from(y, e)
            q1, q2, q3 = phi_from(0.5 * y, e2)
        else:
            e, p1, p2, p3 = mode_phis(modes, n, h)
            e2, q1, q2, q3 = mode_phis(modes, n, 0.5 * h)
        C[0, n] = e
        C[1, n] = e2
        C[2, n] = 0.5 * h * q1
        C[3, n] = h * q2
        C[4, n] = h * p1
        C[5, n] = 2.0 * h * p2
        C[6, n] = h * (p1 - 3.0 * p2 + 4.0 * p3)
        C[7, n] = h * (2.0 * p2 - 4.0 * p3)
        C[8, n] = h * (4.0 * p3 - p2)


# ---------------------------------------------------------------------------------------
# body motion: the paper's constant speed, or a free body of mass M
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def body_coefficients(h, Cb):
    """The rows of etd_coefficients in the limit omega -> 0, for the body (Cb (9, 2)).

    The body is one more degree of freedom, M s'' = M g_b - F, with no linear part. Its state
    is kept as deficits against the prescribed motion, d = V t - s and u = V - U, so that
    u' = G = F / M - g_b and d' = u: a "mode" with omega = 0. A scheme row C(zeta), zeta = i
    omega h, then acts on u as C(0) and on d as h C'(0) (the limit of Im(C z) / omega), with
    phi_k(0) = 1/k!, phi_k'(0) = 1/(k+1)!. Column 0 holds C(0), column 1 h C'(0); rows 0 and 1
    (e^zeta, e^{zeta/2}) are d + h u and d + h u / 2, applied directly. The update is then RK4's
    for u and its Nystrom form for d: d+ = d + h u + h^2 (G1 + G2 + G3) / 6.
    """
    h2 = h * h
    Cb[0, 0] = 1.0
    Cb[0, 1] = h
    Cb[1, 0] = 1.0
    Cb[1, 1] = 0.5 * h
    Cb[2, 0] = 0.5 * h             # (h/2) phi1(zeta/2)
    Cb[2, 1] = h2 / 8.0
    Cb[3, 0] = 0.5 * h             # h phi2(zeta/2)
    Cb[3, 1] = h2 / 12.0
    Cb[4, 0] = h                   # h phi1
    Cb[4, 1] = 0.5 * h2
    Cb[5, 0] = h                   # 2 h phi2
    Cb[5, 1] = h2 / 3.0
    Cb[6, 0] = h / 6.0             # h (phi1 - 3 phi2 + 4 phi3)
    Cb[6, 1] = h2 / 6.0
    Cb[7, 0] = h / 3.0             # h (2 phi2 - 4 phi3)
    Cb[7, 1] = h2 / 6.0
    Cb[8, 0] = h / 6.0             # h (4 phi3 - phi2)
    Cb[8, 1] = 0.0


@njit(cache=True, nogil=True)
def _body_error(h, G1, G2, G3, G4, G5, errb):
    """A free body's local error against genuine third-order companions (docs/model.md, "A
    body of finite mass"). The modes' embedded estimate h (4 phi3 - phi2)(G4 - G5) reads ~ h^6
    on the body: its acceleration depends on its position, and stage 4's position differs from
    the step's by h^2 (G2 - G3)/6 = O(h^5). The companions are Simpson's rule on (G1, G2, G5)
    for u, err = h/3 (G3 - G2) + h/6 (G4 - G5), and d + h u + h^2 (2 G1 + G5)/6 for d, err =
    h^2 (G2 + G3 - G1 - G5)/6, both O(h^4)."""
    errb[B_U] = h / 3.0 * (G3 - G2) + h / 6.0 * (G4 - G5)
    errb[B_D] = h * h / 6.0 * (G2 + G3 - G1 - G5)


@njit(cache=True, nogil=True)
def body_accel(lay, F):
    """G = u' = F / M - g_b: the body's deceleration (0 for the paper's prescribed body)."""
    return lay[L_INV_MASS] * F - lay[L_BODY_G]


@njit(cache=True, nogil=True)
def body_position(lay, t, yb):
    """Penetration s = V t - d of the body [m] (exactly V t for the prescribed body)."""
    return lay[L_V] * t - yb[B_D]


@njit(cache=True, nogil=True)
def body_speed(lay, yb):
    """Downward speed U = V - u of the body [m s-1]."""
    return lay[L_V] - yb[B_U]


@njit(cache=True, nogil=True)
def body_residual(lay, t, yb, work):
    """M (U^2 - V^2) / 2 - M g_b s + W: zero along an exact motion (0 for the prescribed body)."""
    im = lay[L_INV_MASS]
    if im == 0.0:
        return 0.0
    u = yb[B_U]
    return (0.5 * u * u - lay[L_V] * u - lay[L_BODY_G] * body_position(lay, t, yb)) / im + work


# ---------------------------------------------------------------------------------------
# the step: its stages, the body alongside the modes
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _stage(s, U, zs, modes, a_work, adot_work, lay, coef, cosq, wq, delta, fvals, P):
    """layer_forcing_at at a stage state zs, the body at (s, U); a' is needed (adot_work) only
    by a viscoelastic layer."""
    for n in range(zs.shape[0]):
        a_work[n] = mode_a(zs[n], n, modes)
    if lay[L_LAYER_TAU] > 0.0:
        for n in range(zs.shape[0]):
            adot_work[n] = mode_adot(zs[n], a_work[n], n, modes)
    return layer_forcing_at(s, U, a_work, adot_work, coef, cosq, wq, lay, delta, fvals, P)


@njit(cache=True, nogil=True)
def _last_stage(s, U, zs, modes, a_work, adot_work, lay, cosq, wq, delta, fvals, P, eps):
    """_stage at the step's end, with the strain at every node into eps."""
    for n in range(zs.shape[0]):
        a_work[n] = mode_a(zs[n], n, modes)
    if lay[L_LAYER_TAU] > 0.0:
        for n in range(zs.shape[0]):
            adot_work[n] = mode_adot(zs[n], a_work[n], n, modes)
    return layer_forcing_strain(s, U, a_work, adot_work, modes[M_COEF], cosq, wq, lay, delta, fvals, P,
                                modes[M_STRAIN], eps)


@njit(cache=True, nogil=True)
def _step_work(lay, h, work, F1, F2, F3, F4, U1, U2, U3, U4):
    """W(t + h) = W + int F U dt by the step's weights (1, 2, 2, 1)/6 over its stages."""
    if lay[L_INV_MASS] == 0.0:
        return work + h * lay[L_V] * (F1 / 6.0 + (F2 + F3) / 3.0 + F4 / 6.0)
    return work + h * (F1 * U1 / 6.0 + (F2 * U2 + F3 * U3) / 3.0 + F4 * U4 / 6.0)


@njit(cache=True, nogil=True)
def dissipation_rate(z, modes):
    """sum_n L M_n c_n a_n'^2 [W m-1]: the power the Kelvin-Voigt damping takes from the plate."""
    r = 0.0
    for n in range(z.shape[0]):
        hc = modes[M_HALF_C, n]
        if hc > 0.0:
            a = mode_a(z[n], n, modes)
            v = mode_adot(z[n], a, n, modes)
            r += 2.0 * hc * modes[M_LM, n] * v * v
    return r


@njit(cache=True, nogil=True)
def take_step(method, t, t_new, h, z, N1, F1, work, contacts, C, modes, lay, cosq, wq, cw, rw,
              fvals, delta, z_out, N_out, err, eps_out, yb, Cb, yb_out, errb, diss, acc, lp1):
    """One step from (t, z) to t_new = t + h with N1 = P(t, z), F1 = F(t), W(t) = work.

    C holds etd_coefficients(omega, h) (RK4 uses them for its error estimate); cw (2, N)
    and rw (4, N) are scratch. Fills z_out = z(t_new), N_out = P(t_new, z_out), delta (the
    nodes at t_new) and err (the local error estimate). Returns (status, F(t_new),
    jmax(t_new), W(t_new), event): status 1 if a stage reached delta >= 1 (outputs then
    meaningless); event if the number of contact intervals changed among the stages.
    eps_out receives the strain at every node at t_new (strain_nodes) from the last stage's pass.
    The body: yb = (d, u) at t, Cb = body_coefficients(h); yb_out and errb receive its state at
    t_new and its error estimate (the prescribed body stays at d = u = 0 exactly). acc[0]
    receives the energy dissipated by t_new, given diss at t: the step's weights on the damped
    plate's dissipation_rate plus the viscoelastic layer's power (lp1 at t) at its stages; 0 for
    the paper's elastic ice and layer. acc[1] receives the layer's power at t_new.
    """
    omega = modes[M_OMEGA]
    coef = modes[M_COEF]
    kind = modes[M_KIND]
    ice_damped = plate_damped(modes)
    damped = ice_damped or lay[L_LAYER_TAU] > 0.0
    D1 = D2 = D3 = D4 = 0.0
    L2 = L3 = L4 = L5 = 0.0
    adot_work = rw[4]
    zs = cw[0]
    incr = cw[1]
    a_work = rw[0]
    N2 = rw[1]
    N3 = rw[2]
    N4 = rw[3]
    N = z.shape[0]
    V = lay[L_V]
    th = t + 0.5 * h
    event = False
    F2 = F3 = F4 = F5 = 0.0
    jm = 0
    # the body's stages (the same for both methods, see body_coefficients)
    d = yb[B_D]
    u = yb[B_U]
    G1 = body_accel(lay, F1)
    d2 = d + Cb[1, 1] * u + Cb[2, 1] * G1
    u2 = u + Cb[2, 0] * G1
    d3 = u3 = d4 = u4 = 0.0
    G2 = G3 = G4 = 0.0
    if ice_damped:
        D1 = dissipation_rate(z, modes)
    if method == ETD34:
        for n in range(N):
            zs[n] = emul(C[1, n], z[n], kind[n]) + C[2, n] * N1[n]
        if ice_damped:
            D2 = dissipation_rate(zs, modes)
        st, F2, jm, L2 = _stage(V * th - d2, V - u2, zs, modes, a_work, adot_work, lay, coef, cosq, wq, delta,
                                fvals, N2)
        G2 = body_accel(lay, F2)
        event = st == 0 and count_contacts(delta, jm, lay[L_MIRROR]) != contacts
        if st == 0:
            for n in range(N):
                zs[n] = zs[n] + C[3, n] * (N2[n] - N1[n])
            d3 = d2 + Cb[3, 1] * (G2 - G1)
            u3 = u2 + Cb[3, 0] * (G2 - G1)
            if ice_damped:
                D3 = dissipation_rate(zs, modes)
            st, F3, jm, L3 = _stage(V * th - d3, V - u3, zs, modes, a_work, adot_work, lay, coef, cosq, wq,
                                    delta, fvals, N3)
            G3 = body_accel(lay, F3)
            event = event or (st == 0 and count_contacts(delta, jm, lay[L_MIRROR]) != contacts)
        if st == 0:
            for n in range(N):
                zs[n] = emul(C[0, n], z[n], kind[n]) + C[4, n] * N1[n] + C[5, n] * (N3[n] - N1[n])
            if ice_damped:
                D4 = dissipation_rate(zs, modes)
            d4 = d + Cb[0, 1] * u + Cb[4, 1] * G1 + Cb[5, 1] * (G3 - G1)
            u4 = u + Cb[4, 0] * G1 + Cb[5, 0] * (G3 - G1)
            st, F4, jm, L4 = _stage(V * t_new - d4, V - u4, zs, modes, a_work, adot_work, lay, coef, cosq, wq,
                                    delta, fvals, N4)
            G4 = body_accel(lay, F4)
            event = event or (st == 0 and count_contacts(delta, jm, lay[L_MIRROR]) != contacts)
    else:
        # classical RK4 on z' = i w z + P
        for n in range(N):
            k1 = 1j * omega[n] * z[n] + N1[n]
            incr[n] = k1                     # accumulates k1 + 2 k2 + 2 k3
            zs[n] = z[n] + 0.5 * h * k1
        st, F2, jm, L2 = _stage(V * th - d2, V - u2, zs, modes, a_work, adot_work, lay, coef, cosq, wq, delta,
                                fvals, N2)
        G2 = body_accel(lay, F2)
        if st == 0:
            for n in range(N):
                k2 = 1j * omega[n] * zs[n] + N2[n]
                incr[n] += 2.0 * k2
                zs[n] = z[n] + 0.5 * h * k2
            d3 = d2 + Cb[3, 1] * (G2 - G1)
            u3 = u2 + Cb[3, 0] * (G2 - G1)
            st, F3, jm, L3 = _stage(V * th - d3, V - u3, zs, modes, a_work, adot_work, lay, coef, cosq, wq,
                                    delta, fvals, N3)
            G3 = body_accel(lay, F3)
        if st == 0:
            for n in range(N):
                k3 = 1j * omega[n] * zs[n] + N3[n]
                incr[n] += 2.0 * k3
                zs[n] = z[n] + h * k3
            d4 = d + Cb[0, 1] * u + Cb[4, 1] * G1 + Cb[5, 1] * (G3 - G1)
            u4 = u + Cb[4, 0] * G1 + Cb[5, 0] * (G3 - G1)
            st, F4, jm, L4 = _stage(V * t_new - d4, V - u4, zs, modes, a_work, adot_work, lay, coef, cosq, wq,
                                    delta, fvals, N4)
            G4 = body_accel(lay, F4)
    if st == 0:
        yb_out[B_D] = d + Cb[0, 1] * u + Cb[6, 1] * G1 + Cb[7, 1] * (G2 + G3) + Cb[8, 1] * G4
        yb_out[B_U] = u + Cb[6, 0] * G1 + Cb[7, 0] * (G2 + G3) + Cb[8, 0] * G4
        if method == ETD34:
            for n in range(N):
                z_out[n] = (emul(C[0, n], z[n], kind[n]) + C[6, n] * N1[n] + C[7, n] * (N2[n] + N3[n])
                            + C[8, n] * N4[n])
        else:
            for n in range(N):
                k4 = 1j * omega[n] * zs[n] + N4[n]
                z_out[n] = z[n] + h / 6.0 * (incr[n] + k4)
        st, F5, jm, L5 = _last_stage(V * t_new - yb_out[B_D], V - yb_out[B_U], z_out, modes, a_work, adot_work,
                                     lay, cosq, wq, delta, fvals, N_out, eps_out)
    if st != 0:
        return 1, 0.0, jm, work, event
    G5 = body_accel(lay, F5)
    if method == ETD34:
        event = event or count_contacts(delta, jm, lay[L_MIRROR]) != contacts
        if event:
            # z+ minus the exponential trapezoid e^{zeta} z + h(phi1 - phi2) N1 + h phi2 N5: the
            # embedded estimate reads zero where the forcing is only (t - t*)^{3/2} smooth
            for n in range(N):
                err[n] = z_out[n] - (emul(C[0, n], z[n], kind[n]) + (C[4, n] - 0.5 * C[5, n]) * N1[n]
                                     + 0.5 * C[5, n] * N_out[n])
            errb[B_D] = yb_out[B_D] - (d + Cb[0, 1] * u + (Cb[4, 1] - 0.5 * Cb[5, 1]) * G1 + 0.5 * Cb[5, 1] * G5)
            errb[B_U] = yb_out[B_U] - (u + (Cb[4, 0] - 0.5 * Cb[5, 0]) * G1 + 0.5 * Cb[5, 0] * G5)
        else:
            for n in range(N):
                err[n] = C[8, n] * (N4[n] - N_out[n])
            _body_error(h, G1, G2, G3, G4, G5, errb)      # 0 exactly for the prescribed body
    else:
        event = count_contacts(delta, jm, lay[L_MIRROR]) != contacts
        # error estimate: RK4 against the exponential (Krogstad) update from the same stage
        # values; RK4's Taylor approximation of e^{i w h} dominates its error
        for n in range(N):
            err[n] = z_out[n] - (C[0, n] * z[n] + C[6, n] * N1[n] + C[7, n] * (N2[n] + N3[n])
                                 + C[8, n] * N4[n])
        errb[B_D] = 0.0                      # the body's update is the same in both
        errb[B_U] = 0.0
    w_new = _step_work(lay, h, work, F1, F2, F3, F4, V - u, V - u2, V - u3, V - u4)
    acc[0] = diss + h * ((D1 + lp1) / 6.0 + (D2 + L2 + D3 + L3) / 3.0 + (D4 + L4) / 6.0) if damped else diss
    acc[1] = L5
    return 0, F5, jm, w_new, event


@njit(cache=True, nogil=True)
def dense_states(z0, N1, Nm, N5, modes, h, A, AD):
    """a_n and a_n' at t0 + k h / K, k = 1..K-1 (K = A.shape[0] + 1), inside an accepted step.

    Exponential dense output: the modal oscillation exact, the forcing quadratic in time
    through P(t0) = N1, the mid stage Nm ~ P(t0 + h/2) and P(t0 + h) = N5:
        P(t0 + s) = N1 + b1 s + b2 s^2.
    For such a forcing, z' = i w z + P has the exact sub-step of length d = h / K
        z(s + d) = e^{i w d} z(s) + d phi1 P(s) + d^2 phi2 P'(s) + d^3 phi3 P''   (phi_k of i w d),
    so one set of phi functions per mode serves every sample. It resolves modes that oscillate
    within the step, which a polynomial through the step ends cannot.
    """
    K = A.shape[0] + 1
    d = h / K
    omega = modes[M_OMEGA]
    for n in range(z0.shape[0]):
        w = omega[n]
        b1 = (4.0 * Nm[n] - 3.0 * N1[n] - N5[n]) / h
        b2 = 2.0 * (N1[n] - 2.0 * Nm[n] + N5[n]) / (h * h)
        kind = modes[M_KIND, n]
        if modes[M_HALF_C, n] == 0.0:
            y = w * d
            e = complex(math.cos(y), math.sin(y))
            p1, p2, p3 = phi_from(y, e)
        else:
            e, p1, p2, p3 = mode_phis(modes, n, d)
        c1 = d * p1
        c2 = d * d * p2
        c3 = 2.0 * b2 * d * d * d * p3
        z = z0[n]
        for k in range(1, K):
            sk = (k - 1) * d
            z = emul(e, z, kind) + c1 * (N1[n] + sk * (b1 + b2 * sk)) + c2 * (b1 + 2.0 * b2 * sk) + c3
            a = mode_a(z, n, modes)
            A[k - 1, n] = a
            AD[k - 1, n] = mode_adot(z, a, n, modes)


@njit(cache=True, nogil=True)
def peak_near(x, xlo, xhi, sign, w, a, adot, lam1, track):
    """Peak of sign * sum_n w_n a_n cos(lambda_n x) near x (Newton, kept in [xlo, xhi]) and its
    rate sign * sum_n w_n a_n' cos(lambda_n x*): track[:3] = (value, rate, x)."""
    for _ in range(8):
        s0, s1, s2 = mode_sums(w, a, lam1, x)
        x, done = _newton_move(x, sign * s1, sign * s2, xlo, xhi, NEWTON_STOP * (xhi - xlo))
        if done:
            break
    s0, s1, s2 = mode_sums(w, a, lam1, x)
    track[0] = sign * s0
    track[1] = sign * mode_sum(w, adot, lam1, x)
    track[2] = x


# ---------------------------------------------------------------------------------------
# observers: tension record, contact events, the gap
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _append(buf, n, row0, row1, row2, row3, row4):
    """Append a row (the first columns of it) to a growable record; returns (buf, n)."""
    if n == buf.shape[0]:
        bigger = np.empty((2 * buf.shape[0], buf.shape[1]))
        bigger[:n] = buf[:n]
        buf = bigger
    buf[n, 0] = row0
    buf[n, 1] = row1
    if buf.shape[1] > 2:
        buf[n, 2] = row2
        buf[n, 3] = row3
        buf[n, 4] = row4
    return buf, n + 1


@njit(cache=True, nogil=True)
def peak_state(eps, sign, j, a, adot, strain_coef, lam1, dx, track):
    """Peak of sign * eps over continuous x near node j (climbing to the local peak) and its
    time derivative d/dt = sign * eps_t at the peak (envelope theorem):
    track[:] = (value, rate, x, node)."""
    J = eps.shape[0]
    jp = climb(eps, sign, j, J)
    v, x = continuous_peak(eps, sign, jp, J, dx, strain_coef, a, lam1, 1.0, 0.0, 0.0)
    track[0] = v
    track[1] = sign * mode_sum(strain_coef, adot, lam1, x)
    track[2] = x
    track[3] = jp


@njit(cache=True, nogil=True)
def global_state(eps, sign, a, adot, strain_coef, lam1, dx, track):
    """peak_state of the global peak (global_peak): its node is a local peak of the nodes
    already, so the refined value and position are global_peak's own."""
    v, x, j = global_peak(eps, sign, dx, strain_coef, a, lam1)
    track[0] = v
    track[1] = sign * mode_sum(strain_coef, adot, lam1, x)
    track[2] = x
    track[3] = j


@njit(cache=True, nogil=True)
def _store_samples(t0, h, K, p0, samples, rec, n, joinable, run_max, best):
    """The peak sampled at t0 + k h / K, k = 0..K (rows of samples: value, rate, x): best
    receives the (max, time, x) of the Hermite pieces between samples; the samples are stored
    as consecutive record rows when that maximum rises above run_max. Returns (rec, n, stored)."""
    hk = h / K
    best[0] = -np.inf
    for k in range(K):
        c0, c1, c2, c3 = hermite(samples[k, 0], samples[k + 1, 0], samples[k, 1], samples[k + 1, 1], hk)
        vmax, th = cubic_max(c0, c1, c2, c3)
        if vmax > best[0]:
            best[0] = vmax
            best[1] = t0 + (k + th) * hk
            best[2] = samples[k, 2] + th * (samples[k + 1, 2] - samples[k, 2])
    if not best[0] > run_max:
        return rec, n, False
    if not joinable:
        rec, n = _append(rec, n, t0, p0[0], p0[1], p0[2], 0.0)
    for k in range(1, K + 1):
        rec, n = _append(rec, n, t0 + k * hk, samples[k, 0], samples[k, 1], samples[k, 2], 1.0)
    return rec, n, True


@njit(cache=True, nogil=True)
def _tension_piece(sign, t0, h, p0, p1, dz, A, AD, dense, strain_coef, lam1, dx, L, samples, rec, n,
                   joinable, run_max, best):
    """The peak of one track over the step: from p0 (t0) to p1 (t0 + h), each (value, rate,
    x), through the dense-output states A, AD inside the step (computed from dz = (z0, N1,
    N_mid, N5, omega) when dense[0] is False; samples[k] receives the larger of the peaks
    followed forward from x0 and backward from x1). Stored as consecutive record rows when it
    rises above run_max; best receives (max, time, x) of the piece. Returns (rec, n, stored).
    """
    K = A.shape[0] + 1
    c0, c1, c2, c3 = hermite(p0[0], p1[0], p0[1], p1[1], h)
    vmax, th = cubic_max(c0, c1, c2, c3)
    best[0] = vmax                               # from the ends; refined by the samples below
    best[1] = t0 + th * h
    best[2] = p0[2] + th * (p1[2] - p0[2])
    if vmax < run_max - RIPPLE * abs(run_max):   # cannot raise the record: no samples needed
        return rec, n, False
    if dz[4][M_OMEGA, dz[4].shape[1] - 1] * h <= 0.4:   # every mode resolved by the step: its ends suffice
        if not vmax > run_max:
            return rec, n, False
        if not joinable:
            rec, n = _append(rec, n, t0, p0[0], p0[1], p0[2], 0.0)
        rec, n = _append(rec, n, t0 + h, p1[0], p1[1], p1[2], 1.0)
        return rec, n, True
    if not dense[0]:                             # the step's dense states, once per step
        dense_states(dz[0], dz[1], dz[2], dz[3], dz[4], h, A, AD)
        dense[0] = True
    # follow the peak forward from p0 and backward from p1, each sample by Newton near the
    # previous one; keep the larger (the global peak may pass from one local peak to another)
    xf = p0[2]
    for k in range(1, K):
        peak_near(xf, max(0.0, xf - 3.0 * dx), min(L, xf + 3.0 * dx), sign, strain_coef, A[k - 1],
                  AD[k - 1], lam1, samples[k])
        xf = samples[k, 2]
    xb = p1[2]
    back = np.empty(3)
    for k in range(K - 1, 0, -1):
        peak_near(xb, max(0.0, xb - 3.0 * dx), min(L, xb + 3.0 * dx), sign, strain_coef, A[k - 1],
                  AD[k - 1], lam1, back)
        xb = back[2]
        if back[0] > samples[k, 0]:
            samples[k, :3] = back
    samples[0, :3] = p0[:3]
    samples[K, :3] = p1[:3]
    return _store_samples(t0, h, K, p0, samples, rec, n, joinable, run_max, best)


@njit(cache=True, nogil=True)
def _global_piece(sign, t0, h, p0, p1, dz, A, AD, eps, cosq, strain_coef, lam1, dx, samples, rec, n,
                  joinable, run_max, best):
    """The global peak over a step in which it passes from one local peak to another (a new
    peak may emerge inside the step, where no track can follow it): at SWITCH_SAMPLES - 1
    points of the dense output the strain is evaluated at every node and the global peak
    searched among all local peaks (global_peak). Stored like _tension_piece."""
    K = SWITCH_SAMPLES
    if max(p0[0], p1[0]) < run_max - RIPPLE * abs(run_max):   # far below the record: not needed
        best[0] = max(p0[0], p1[0])
        best[1] = t0 if p0[0] >= p1[0] else t0 + h
        best[2] = p0[2] if p0[0] >= p1[0] else p1[2]
        return rec, n, False
    dense_states(dz[0], dz[1], dz[2], dz[3], dz[4], h, A, AD)
    samples[0, :3] = p0[:3]
    samples[K, :3] = p1[:3]
    for k in range(1, K):
        strain_nodes(A[k - 1], strain_coef, cosq, eps)
        v, x, j = global_peak(eps, sign, dx, strain_coef, A[k - 1], lam1)
        samples[k, 0] = v
        samples[k, 1] = sign * mode_sum(strain_coef, AD[k - 1], lam1, x)
        samples[k, 2] = x
    return _store_samples(t0, h, K, p0, samples, rec, n, joinable, run_max, best)


@njit(cache=True, nogil=True)
def observe_tension(sign, t0, h, eps0, eps1, a0, a1, adot0, adot1, dz, A, AD, dense, strain_coef, lam1,
                    dx, L, state, scratch, samples, rec, n, joinable, run_max, best, A2, AD2, eps_s, cosq,
                    samples2):
    """Running-maximum record of the tension sign * eps over the step [t0, t0 + h].

    ``state`` holds (value, rate, x, node) of the global peak at t0 and receives it at t1.
    The peak is followed from the step's start to its end through TENSION_SAMPLES - 1 samples
    of the dense output inside the step (see _tension_piece); between consecutive samples the
    record is the cubic Hermite interpolant of (value, rate). A step is stored when it rises
    above ``run_max``, the running maximum so far. Where the global peak passes from one local
    peak to another within the step, the global peak itself is sampled (_global_piece). Rows of rec: (t, value, rate, x, join), join = 1 when the
    row continues the previous one. Returns (rec, n, joinable, run_max); best receives the
    (max, time, x) of the step.
    """
    J = eps1.shape[0]
    p0 = scratch[4]
    p0[:] = state[:4]
    j0 = int(p0[3])
    p1 = scratch[0]
    global_state(eps1, sign, a1, adot1, strain_coef, lam1, dx, p1)
    jb0 = climb(eps0, sign, int(p1[3]), J)
    best[0] = -np.inf
    piece = scratch[2]
    # one track through the step, unless the peak at t1 climbs back to another local peak at t0
    # or jumped too far for one track (a peak that emerged inside the step)
    if jb0 == j0 and abs(p1[2] - p0[2]) <= SWITCH_DISTANCE * dx:
        rec, n, stored = _tension_piece(sign, t0, h, p0, p1, dz, A, AD, dense, strain_coef, lam1, dx, L, samples,
                                        rec, n, joinable, run_max, piece)
        joinable = stored
        if piece[0] > best[0]:
            best[:3] = piece[:3]
    else:                                           # the global peak moved to another local peak
        rec, n, stored = _global_piece(sign, t0, h, p0, p1, dz, A2, AD2, eps_s, cosq, strain_coef, lam1,
                                       dx, samples2, rec, n, joinable, run_max, piece)
        joinable = stored
        if piece[0] > best[0]:
            best[:3] = piece[:3]
    if best[0] > run_max:
        run_max = best[0]
    state[:4] = p1[:4]
    return rec, n, joinable, run_max


@njit(cache=True, nogil=True)
def reach_in_step(jm, a0, a1, s0, s1, drift, cosq, lay, work):
    """jm' >= jm such that no node j >= jm' can be in contact at any time of a step.

    Given: at both ends delta < 0 at the nodes j >= jm (contact_bound), and delta moves at most
    drift / he over half the step, so delta(t) <= (delta_0 + delta_1) / 2 + drift / he at every
    t in it. Each end's delta is bounded as in contact_bound, w_j <= sum_{n < 4} a_n
    cos(lambda_n x_j) + sum_{n >= 4} |a_n| (last_reachable on the mean of the ends' first
    modes), on the nodes up to the coarse limit
    b(x_j) <= max(s0, s1) + max(sum |a0_n|, sum |a1_n|) + drift. work (J,) is scratch.
    """
    N = a0.shape[0]
    J = work.shape[0]
    m = min(BOUND_MODES, N)
    A0 = 0.0
    A1 = 0.0
    T = 0.0
    for n in range(N):
        A0 += abs(a0[n])
        A1 += abs(a1[n])
        if n >= m:
            T += abs(a0[n]) + abs(a1[n])
    reach = max(s0, s1) + max(A0, A1) + drift
    if reach <= 0.0:
        return jm
    jc = min(J, int(body_extent(reach, lay) / lay[L_DX]) + 2)
    if jc <= jm:
        return jm
    mean = np.empty(m)
    for n in range(m):
        mean[n] = 0.5 * (a0[n] + a1[n])
    lift = 0.5 * (s0 + s1 + T) + drift + 1e-9 * (A0 + A1)
    return max(jm, last_reachable(mean, m, cosq, lay, lift, work, jm, jc) + 1)


@njit(cache=True, nogil=True)
def _deltas(a, cosq, s, lay, delta, j0, j1):
    """delta = (w + s - b(x_j)) / he at the nodes j0 <= j < j1 (as layer_reaction has it)."""
    if j1 <= j0:
        return
    modal_sum_range(a, cosq, delta, j0, j1)
    for j in range(j0, j1):
        delta[j] = (delta[j] + s - lay[N_LAY + j]) / lay[L_HE]


#: candidate nodes at most this far apart share one pass over the table rows (observe_contacts)
RUN_GAP = 4


@njit(cache=True, nogil=True)
def observe_contacts(t0, h, delta0, jm0, delta1, jm1, a0, adot0, a1, adot1, body0, body1, cosq, lay,
                     sgn, ev_th, ev_j, contacts, rec, n):
    """Changes of the number of contact intervals inside the step [t0, t0 + h].

    delta at a node near the contact boundary is interpolated by the cubic Hermite of its
    end values and rates; every sign change is an event, applied in time order to the sign
    pattern, which is recounted. A node whose interval opens and closes within the step is
    seen too. Tested: every node that can change sign in the step, also beyond both ends'
    computed ranges jm0, jm1 (reach_in_step; delta0, delta1 are filled up to that range).
    Rows of rec: (t, count after the change). body0, body1: the body's (s, U) at t0 and t1.
    sgn (J,) is scratch. Returns (contacts at t1, rec, n, largest count in the step).
    """
    he = lay[L_HE]
    U0 = body0[1]
    U1 = body1[1]
    Ub = max(abs(U0), abs(U1))
    if lay[L_INV_MASS] > 0.0:
        Ub *= 2.0                       # a free body's speed may swing between the step's ends
    s0 = 0.0
    s1 = 0.0
    for k in range(adot0.shape[0]):
        s0 += abs(adot0[k])
        s1 += abs(adot1[k])
    speed = (2.0 * max(s0, s1) + Ub) / he   # a bound on |d delta / dt| within the step
    # nodes beyond both ends' computed ranges are < 0 at both ends but may cross inside
    jm = reach_in_step(max(jm0, jm1), a0, a1, body0[0], body1[0], 0.5 * speed * h * he, cosq, lay, sgn)
    _deltas(a0, cosq, body0[0], lay, delta0, jm0, jm)     # nodes outside an end's computed range
    _deltas(a1, cosq, body1[0], lay, delta1, jm1, jm)
    # the nodes whose delta may change sign in the step (the others cannot reach 0 at |delta'|
    # <= speed); their end rates come from passes over the table rows on runs of such nodes
    cand = np.empty(jm, dtype=np.int64)
    nc = 0
    for j in range(jm):
        d0 = delta0[j]
        d1 = delta1[j]
        sgn[j] = 1.0 if d0 > 0.0 else -1.0
        mid = 0.5 * (d0 + d1)
        if (d0 > 0.0) == (d1 > 0.0):
            if d0 > 0.0 and mid - 0.5 * speed * h > 0.0:
                continue
            if not d0 > 0.0 and mid + 0.5 * speed * h <= 0.0:
                continue
        cand[nc] = j
        nc += 1
    rate0 = np.empty(jm)
    rate1 = np.empty(jm)
    i = 0
    while i < nc:
        lo = cand[i]
        while i + 1 < nc and cand[i + 1] <= cand[i] + RUN_GAP:
            i += 1
        hi = cand[i] + 1
        modal_sum_range(adot0, cosq, rate0, lo, hi)
        modal_sum_range(adot1, cosq, rate1, lo, hi)
        i += 1
    n_ev = 0
    roots = np.empty(3)
    for i in range(nc):
        j = cand[i]
        c0, c1, c2, c3 = hermite(delta0[j], delta1[j], (rate0[j] + U0) / he, (rate1[j] + U1) / he, h)
        k = cubic_sign_changes(c0, c1, c2, c3, roots)
        for r in range(k):
            if n_ev < ev_th.shape[0]:
                ev_th[n_ev] = roots[r]
                ev_j[n_ev] = j
                n_ev += 1
    largest = contacts
    if n_ev == 0:
        return contacts, rec, n, largest
    for i in range(1, n_ev):            # insertion sort by time
        th = ev_th[i]
        jj = ev_j[i]
        m = i - 1
        while m >= 0 and ev_th[m] > th:
            ev_th[m + 1] = ev_th[m]
            ev_j[m + 1] = ev_j[m]
            m -= 1
        ev_th[m + 1] = th
        ev_j[m + 1] = jj
    for i in range(n_ev):
        j = int(ev_j[i])
        sgn[j] = -sgn[j]
        c = count_contacts(sgn, jm, lay[L_MIRROR])
        if c != contacts:
            rec, n = _append(rec, n, t0 + ev_th[i] * h, c, 0.0, 0.0, 0.0)
            contacts = c
            if c > largest:
                largest = c
    final = count_contacts(delta1, jm, lay[L_MIRROR])
    if final != contacts:               # the end pattern is exact: it wins
        rec, n = _append(rec, n, t0 + h, final, 0.0, 0.0, 0.0)
        contacts = final
        if final > largest:
            largest = final
    return contacts, rec, n, largest


@njit(cache=True, nogil=True)
def shape_peak(delta, j, n, a, ones, s, lay):
    """continuous_peak of delta = (w + s - b(x)) / he for any body shape: Newton on delta'
    with b', b'' from body_slope_curvature, kept within [x_{j-1}, x_{j+1}]. Returns (value, x)."""
    dx = lay[L_DX]
    he = lay[L_HE]
    if j == 0 or j == n - 1:
        return delta[j], j * dx
    v, x = refine(delta, 1.0, j, n, dx)
    xlo = (j - 1) * dx
    xhi = (j + 1) * dx
    for _ in range(8):
        s0, s1, s2 = mode_sums(ones, a, lay[L_LAM1], x)
        b1, b2 = body_slope_curvature(x, lay)
        x, done = _newton_move(x, s1 - b1, s2 - b2, xlo, xhi, NEWTON_STOP * dx)
        if done:
            break
    s0, s1, s2 = mode_sums(ones, a, lay[L_LAM1], x)
    value = (s0 + s - body_profile(x, lay)) / he
    if value < delta[j]:                 # a corner the iteration could not settle on: the node
        return delta[j], j * dx
    return value, x


@njit(cache=True, nogil=True)
def gap_peak(s, U, delta, jm, a, adot, ones, lay, out):
    """Largest delta over the continuous plate and its rate: out[:] = (delta, rate, x), the
    body at penetration s moving down at U.

    delta holds the nodes j < jm (beyond them delta < 0); the peak is refined on the modes.
    """
    he = lay[L_HE]
    n = jm if jm < delta.shape[0] else delta.shape[0]
    j = argmax_node(delta, 1.0, n)
    if j == n - 1 and n < delta.shape[0]:
        v, x = delta[j], j * lay[L_DX]     # the next node is outside the computed range
    elif is_parabola(lay):
        v, x = continuous_peak(delta, 1.0, j, n, lay[L_DX], ones, a, lay[L_LAM1], 1.0 / he,
                               -0.5 / (lay[L_R] * he), s / he)
    else:
        v, x = shape_peak(delta, j, n, a, ones, s, lay)
    out[0] = v
    out[1] = (mode_sum(ones, adot, lay[L_LAM1], x) + U) / he
    out[2] = x


@njit(cache=True, nogil=True)
def substep(method, t, s, z, N1, F1, work, contacts, Cs, modes, lay, cosq, wq, cw, rw, fvals,
            delta, z_out, N_out, err, a_out, adot_out, eps, yb, Cbs, yb_out, errb, diss, acc, lp1):
    """A step of length s from (t, z) (the body at yb) into the given buffers, its own
    coefficients in Cs and Cbs; a_out, adot_out receive a_n and a_n' at t + s, eps the strain at
    the nodes, yb_out the body. Returns take_step's tuple."""
    etd_coefficients(modes, s, Cs)
    body_coefficients(s, Cbs)
    res = take_step(method, t, t + s, s, z, N1, F1, work, contacts, Cs, modes, lay, cosq, wq, cw,
                    rw, fvals, delta, z_out, N_out, err, eps, yb, Cbs, yb_out, errb, diss, acc, lp1)
    for k in range(z.shape[0]):
        a_out[k] = mode_a(z_out[k], k, modes)
        adot_out[k] = mode_adot(z_out[k], a_out[k], k, modes)
    return res


@njit(cache=True, nogil=True)
def event_value(kind, t, jm, delta, a, adot, yb, modes, lay, cosq, eps, ones, out):
    """The quantity an event is defined on, at a state: kind 0, the largest delta on the plate
    (gap_peak); kind +1 / -1, the peak of +eps / -eps over x. out[:] = (value, rate, x)."""
    if kind == 0:
        gap_peak(body_position(lay, t, yb), body_speed(lay, yb), delta, jm, a, adot, ones, lay, out)
        return out[0]
    sign = float(kind)
    strain_nodes(a, modes[M_STRAIN], cosq, eps)
    v, x, j = global_peak(eps, sign, lay[L_DX], modes[M_STRAIN], a, lay[L_LAM1])
    out[0] = v
    out[2] = x
    return v


@njit(cache=True, nogil=True)
def locate_event(kind, level, method, t, h, p0, p1, z, N1, F1, work, contacts, Cs, modes, lay,
                 cosq, wq, cw, rw, fvals, delta, z_out, N_out, err, a_out, adot_out, eps, ones, out,
                 yb, Cbs, yb_out, errb, diss, acc, lp1):
    """First time in the accepted step [t, t + h] at which event_value(kind) reaches level,
    found on true sub-steps of the integrator from (t, z): Illinois regula falsi, bisection
    where a sub-step fails (a stage with delta >= 1 counts as past the level). p0, p1:
    (value, rate) at the two ends (p1 unused: the step is scanned at SCAN points first).

    On return the buffers hold the state at t + s_lo, the last sub-step still below the level
    (so a located bottoming ends on a state with delta < 1 everywhere), out its event value;
    yb is the body at t, yb_out receives it at t + s_lo.
    Returns (s_lo, s_hi, F, jmax, W, found).
    """
    # the first crossing: scan the step forward on sub-steps to the first point past the level
    # (the value may cross the level more than once within a step, as two peaks take turns)
    lo, f_lo = 0.0, p0[0] - level
    hi, f_hi = -1.0, 0.0
    for k in range(1, SCAN + 1):
        sk = h * k / SCAN
        st, F, jm, w, ev = substep(method, t, sk, z, N1, F1, work, contacts, Cs, modes, lay, cosq,
                                   wq, cw, rw, fvals, delta, z_out, N_out, err, a_out, adot_out, eps, yb, Cbs,
                                   yb_out, errb, diss, acc, lp1)
        f = np.inf if st != 0 else event_value(kind, t + sk, jm, delta, a_out, adot_out, yb_out, modes, lay,
                                                cosq, eps, ones, out) - level
        if f >= 0.0:
            hi, f_hi = sk, f
            break
        lo, f_lo = sk, f
    if hi < 0.0:
        return 0.0, 0.0, 0.0, 0, 0.0, False
    s = 0.5 * (lo + hi)
    side = 0
    for _ in range(100):
        st, F, jm, w, ev = substep(method, t, s, z, N1, F1, work, contacts, Cs, modes, lay, cosq,
                                   wq, cw, rw, fvals, delta, z_out, N_out, err, a_out, adot_out, eps, yb, Cbs,
                                   yb_out, errb, diss, acc, lp1)
        f = np.inf if st != 0 else event_value(kind, t + s, jm, delta, a_out, adot_out, yb_out, modes, lay,
                                                cosq, eps, ones, out) - level
        if f >= 0.0:
            hi, f_hi = s, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            lo, f_lo = s, f
            if side == -1 and math.isfinite(f_hi):
                f_hi *= 0.5
            side = -1
        if hi - lo <= 1e-13 * (t + hi):
            break
        if math.isfinite(f_hi) and f_hi > f_lo:
            s = lo + (hi - lo) * (-f_lo) / (f_hi - f_lo)
        else:
            s = 0.5 * (lo + hi)
        if not (lo < s < hi):
            s = 0.5 * (lo + hi)
    st, F, jm, w, ev = substep(method, t, lo, z, N1, F1, work, contacts, Cs, modes, lay, cosq, wq,
                               cw, rw, fvals, delta, z_out, N_out, err, a_out, adot_out, eps, yb, Cbs,
                               yb_out, errb, diss, acc, lp1)
    event_value(kind, t + lo, jm, delta, a_out, adot_out, yb_out, modes, lay, cosq, eps, ones, out)
    return lo, hi, F, jm, w, True


# ---------------------------------------------------------------------------------------
# main loop and its pieces: outputs, step size, error control, energy guard, observers
# ---------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _start_diagnostics(diag, t_start):
    for i in range(N_DIAG):
        diag[i] = np.nan
    diag[D_MAX_CONTACTS] = 0.0
    diag[D_MAX_FORCE] = 0.0
    diag[D_MAX_FORCE_T] = t_start
    diag[D_H_MIN] = np.inf
    diag[D_H_MAX] = 0.0
    diag[D_FAIL_KIND] = FAIL_NONE
    diag[D_ENERGY_JUMPS] = 0.0


@njit(cache=True, nogil=True)
def _plus_plate_energy(e, modes, z):
    """e + E_plate, E_plate = sum_n L M_n (a_n'^2 + omega_n^2 a_n^2) / 2 [J m-1] (added term by
    term to e): L M_n |z_n|^2 / 2 for the undamped plate."""
    LM = modes[M_LM]
    if not plate_damped(modes):
        for n in range(z.shape[0]):
            e += 0.5 * LM[n] * (z[n].real ** 2 + z[n].imag ** 2)
        return e
    omega = modes[M_OMEGA]
    for n in range(z.shape[0]):
        a = mode_a(z[n], n, modes)
        v = mode_adot(z[n], a, n, modes)
        e += 0.5 * LM[n] * (v * v + omega[n] ** 2 * a * a)
    return e


@njit(cache=True, nogil=True)
def _record_output(k, t, z, a, adot, yb, delta, jmax, force, work, err_sum, diss, modes, lay, out_a,
                   out_adot, out_series):
    """Row k of the outputs: the state at t (an output time the steps have landed on)."""
    for n in range(z.shape[0]):
        out_a[k, n] = a[n]
        out_adot[k, n] = adot[n]
    out_series[k, S_CONTACTS] = count_contacts(delta, jmax, lay[L_MIRROR])
    out_series[k, S_FORCE] = force
    out_series[k, S_E_PLATE] = _plus_plate_energy(0.0, modes, z)
    out_series[k, S_DISSIPATED] = diss
    out_series[k, S_E_LAYER] = layer_energy(delta, jmax, lay[L_DX], lay[L_K], lay[L_HE], lay[L_MIRROR])
    out_series[k, S_WORK] = work
    out_series[k, S_ERR] = err_sum
    out_series[k, S_BODY_POSITION] = body_position(lay, t, yb)
    out_series[k, S_BODY_SPEED] = body_speed(lay, yb)


@njit(cache=True, nogil=True)
def _error_ratio(err, errb, z, znew, modes, lay, tolerance, gap, bottom_gap, ones, scratch):
    """Local error over tolerance in the energy norm: the plate's error and a free body's
    velocity error M err_U^2, against the plate's energy (docs/model.md, "A body of finite
    mass"); near bottoming also the error of delta at the gap against the gap itself."""
    LM = modes[M_LM]
    num = 0.0
    den_old = 0.0
    den_new = 0.0
    for n in range(z.shape[0]):
        num += LM[n] * (err[n].real ** 2 + err[n].imag ** 2)
        den_old += LM[n] * (z[n].real ** 2 + z[n].imag ** 2)
        den_new += LM[n] * (znew[n].real ** 2 + znew[n].imag ** 2)
    im = lay[L_INV_MASS]
    if im > 0.0:
        # the body's error in the same energy units, measured against the plate's energy,
        # not against the body's own kinetic energy M U^2 / 2: that grows with M and would
        # loosen the plate's control as M -> inf, where the paper's body is the limit
        num += errb[B_U] ** 2 / im
    floor = lay[L_V] * math.sqrt(lay[L_LM_FLOOR])
    ratio = math.sqrt(num) / (tolerance * max(math.sqrt(max(den_old, den_new)), floor))
    he = lay[L_HE]
    if lay[L_K] > 0.0 and gap[0] > 1.0 - max(GAP_WATCH, 10.0 * bottom_gap):
        # near bottoming the local error of delta at the gap must be small against the
        # gap itself, or a grazing approach crosses the threshold in one run and not in
        # another: |err(delta)| <= GAP_ACCURACY (1 - delta)
        for n in range(z.shape[0]):
            scratch[n] = mode_a(err[n], n, modes)
        e_delta = abs(mode_sum(ones, scratch, lay[L_LAM1], gap[2]) - errb[B_D]) / he
        ratio = max(ratio, e_delta / (GAP_ACCURACY * (1.0 - gap[0])))
    if not math.isfinite(ratio):
        ratio = 1e10
    return ratio


@njit(cache=True, nogil=True)
def _energy_allowance(delta_new, jm5, e_new, w_new, e0, work, mirror):
    """How much one step may change the residual E_plate + E_layer - W (see ENERGY_JUMP); the
    compressed nodes counted as on the half plate (mirror / 2 of them on the full plate)."""
    compressed = 0
    for j in range(jm5):
        if delta_new[j] > 0.0:
            compressed += 1
    under = min(1.0, (RESOLVED_NODES / max(compressed * (0.5 * mirror), 1.0)) ** 2)
    return ENERGY_JUMP * max(e_new, w_new, e0) + under * abs(w_new - work)


@njit(cache=True, nogil=True)
def _next_step(t, t_start, target, h, h_init, fixed_step, fixed):
    """The step to try from t towards the next output time: (h_step, t_new, landing).
    fixed = [target the fixed step was chosen for, that step] (updated)."""
    remaining = target - t
    if fixed_step > 0.0:
        # one step size per output interval, fixed for the whole interval (the ETD
        # coefficients are then computed once per interval); the last step lands on target
        if target != fixed[0]:
            fixed[0] = target
            n_sub = math.ceil(remaining / fixed_step * (1.0 - 1e-12))
            fixed[1] = remaining / max(n_sub, 1)
        landing = remaining <= 1.5 * fixed[1]
        h_step = remaining if landing else fixed[1]
    else:
        h_step = min(h, max(h_init, GROWTH * (t - t_start)))
        if h_step >= remaining * (1.0 - 1e-12) or remaining - h_step < 0.01 * h_step:
            h_step = remaining
        landing = h_step >= remaining * (1.0 - 1e-12)
    t_new = target if landing else t + h_step
    return h_step, t_new, landing


@njit(cache=True, nogil=True)
def _finite_state(st, w_new, znew, yb_new):
    if not (st == 0 and math.isfinite(w_new)):
        return False
    for n in range(znew.shape[0]):
        if not (math.isfinite(znew[n].real) and math.isfinite(znew[n].imag)):
            return False
    return math.isfinite(yb_new[B_D]) and math.isfinite(yb_new[B_U])


@njit(cache=True, nogil=True)
def observe_body(t, h, yb0, yb1, F0, F1, contacts, rec_c, n_c, lay, diag):
    """A free body's ends within the step [t, t + h]: the zeros of its speed U (it stops; the
    deepest penetration is taken there) from the cubic Hermite of U (U' = g_b - F / M at the
    ends), and its separation: no contact at t + h while moving up after having stopped, at
    the last time the contact record went to 0 (located by observe_contacts). Returns True
    at the first separation."""
    if lay[L_INV_MASS] == 0.0:
        return False
    U0 = body_speed(lay, yb0)
    U1 = body_speed(lay, yb1)
    r0 = -body_accel(lay, F0)
    r1 = -body_accel(lay, F1)
    s0 = body_position(lay, t, yb0)
    s1 = body_position(lay, t + h, yb1)
    roots = np.empty(3)
    c0, c1, c2, c3 = hermite(U0, U1, r0, r1, h)
    k = cubic_sign_changes(c0, c1, c2, c3, roots)
    for i in range(k):
        th = roots[i]
        if cubic(c0, c1, c2, c3, th + 1e-9) > 0.0:
            continue                                    # U rising through 0: not a stop
        q0, q1, q2, q3 = hermite(s0, s1, U0, U1, h)
        depth = cubic(q0, q1, q2, q3, th)
        if math.isnan(diag[D_STOP_T]):
            diag[D_STOP_T] = t + th * h
        if not depth <= diag[D_MAX_PENETRATION]:        # also when NaN (the first stop)
            diag[D_MAX_PENETRATION] = depth
    if math.isnan(diag[D_STOP_T]) or not math.isnan(diag[D_SEPARATION_T]):
        return False
    if contacts != 0 or not U1 < 0.0:
        return False
    t_sep = t + h
    if n_c > 0 and rec_c[n_c - 1, 1] == 0.0:
        t_sep = max(rec_c[n_c - 1, 0], diag[D_STOP_T])
    th = min(max((t_sep - t) / h, 0.0), 1.0)
    diag[D_SEPARATION_T] = t_sep
    diag[D_SEPARATION_SPEED] = -cubic(c0, c1, c2, c3, th)
    return True


@njit(cache=True, nogil=True)
def _observe_tensions(t, h_eff, eps, eps_new, a, a_new, adot, adot_new, dz, A, AD, dense, modes, lay,
                      L, tension, scratch, samples, rec_up, n_up, rec_lo, n_lo, joinable, run_max, best,
                      A2, AD2, eps_sub, cosq, samples2, diag):
    """The tension records of both surfaces over the accepted step (observe_tension)."""
    strain_coef = modes[M_STRAIN]
    lam1 = lay[L_LAM1]
    dx = lay[L_DX]
    for s in range(2):
        sign = 1.0 - 2.0 * s
        if s == 0:
            rec_up, n_up, jn, rm = observe_tension(sign, t, h_eff, eps, eps_new, a, a_new, adot, adot_new,
                                                  dz, A, AD, dense, strain_coef, lam1, dx, L, tension[0], scratch,
                                                  samples, rec_up, n_up, joinable[0], run_max[0], best,
                                                  A2, AD2, eps_sub, cosq, samples2)
        else:
            rec_lo, n_lo, jn, rm = observe_tension(sign, t, h_eff, eps, eps_new, a, a_new, adot, adot_new,
                                                  dz, A, AD, dense, strain_coef, lam1, dx, L, tension[1], scratch,
                                                  samples, rec_lo, n_lo, joinable[1], run_max[1], best,
                                                  A2, AD2, eps_sub, cosq, samples2)
        joinable[s] = jn
        run_max[s] = rm
        if best[0] > diag[D_MAX_UPPER + 3 * s]:
            diag[D_MAX_UPPER + 3 * s] = best[0]
            diag[D_MAX_UPPER_T + 3 * s] = best[1]
            diag[D_MAX_UPPER_X + 3 * s] = best[2]
    return rec_up, n_up, rec_lo, n_lo


@njit(cache=True, nogil=True)
def _finish_diagnostics(diag, status, t, work, peak_work, max_residual, max_body_residual, gap, he, steps,
                        rejected, rhs_count):
    """The run's summary diagnostics at its end; returns the final status. The residuals are
    relative to the largest work over the run: the final work for the paper's body (W only
    grows), the work at the deepest point for a body that rebounds and takes its energy back."""
    if status == LAYER_BOTTOMED_OUT and math.isnan(diag[D_BOTTOM_T]):
        diag[D_BOTTOM_T] = t                # not located: the last state the steps reached
        diag[D_BOTTOM_X] = gap[2]
        diag[D_BOTTOM_SPEED] = he * gap[1]
    diag[D_T_REACHED] = t
    diag[D_WORK] = work
    diag[D_ENERGY_RESIDUAL] = max_residual / peak_work if peak_work > 0.0 else 0.0
    if not math.isnan(diag[D_BODY_RESIDUAL]):
        diag[D_BODY_RESIDUAL] = max_body_residual / peak_work if peak_work > 0.0 else 0.0
    ended_well = status == OK or status == LAYER_BOTTOMED_OUT or status == SEPARATED or status == STOPPED
    if ended_well and max(diag[D_ENERGY_RESIDUAL], diag[D_BODY_RESIDUAL] if not math.isnan(
            diag[D_BODY_RESIDUAL]) else 0.0) > ENERGY_BOUND:
        status = ENERGY_VIOLATION
        diag[D_FAIL_T] = t
        diag[D_FAIL_KIND] = FAIL_ENERGY_BOUND
    up, lo = diag[D_MAX_UPPER], diag[D_MAX_LOWER]
    diag[D_MAX_ABS] = max(up, lo)
    diag[D_MAX_ABS_X] = diag[D_MAX_UPPER_X] if up >= lo else diag[D_MAX_LOWER_X]
    diag[D_MAX_ABS_T] = diag[D_MAX_UPPER_T] if up >= lo else diag[D_MAX_LOWER_T]
    diag[D_STEPS] = steps
    diag[D_REJECTED] = rejected
    diag[D_RHS] = rhs_count
    return status


@njit(cache=True, nogil=True)
def integrate(method, modes, lay, cosq, wq, ctrl, t_out, a0, adot0, levels, out_a, out_adot, out_series,
              diag, level_t, level_x):
    """Integrate the mode equations (and a free body's motion) from t_start to t_end, landing on
    every t_out.

    Parameters
    ----------
    method : ETD34 or RK4.
    modes : (4, N) rows omega_n [s-1], -2/(L M_n), (hi/2) lambda_n^2 [m-1], L M_n [kg m-1].
    lay : (N_LAY + J,) lambda_1 [m-1], dx [m], V [m s-1], R [m], he [m], K [Pa], 1/M [m kg-1]
        (0: the body moves at V, the paper's), g_b [m s-2] (0 with 1/M = 0), the shape's p,
        c [m] and tan(deadrise) (see body_profile), then the profile b(x_j) [m] at the J
        nodes; see L_*.
    cosq (N, J), wq (N,) : quadrature nodes and mode weights, see :func:`layer_forcing`.
    ctrl : (N_CTRL,) the run's control, see C_*: t_start, t_end [s] (the body's lowest point at
        he - s, s = V t for the paper's body); tolerance (relative error per step in the energy
        norm, ETD34 adaptive); fixed_step [s] (> 0: RK4 always, ETD34 without error control);
        h_init, h_min, h_max [s] (first trial, smallest and largest step; h_max must resolve
        the contact oscillation: in free flight the forcing and hence the error estimate
        vanish, and only h_max stops a step from jumping deep into a new contact); max_steps
        (attempted steps before STEP_LIMIT); bottom_gap (the layer bottoms out when its gap
        closes to this fraction of he); until_separation (1: a free body's run ends when it
        separates).
    t_out : sorted output times in [t_start, t_end] [s].
    a0, adot0 : a_n [m] and a_n' [m s-1] at t_start (the body at s = V t_start, speed V).
    levels : tension levels to locate exactly on sub-steps (verification; usually empty).
    out_a, out_adot (T, N), out_series (T, N_SERIES): filled at each output time reached: a,
        a', and (S_*) contact intervals, F, E_plate, E_layer, W, the sum over accepted steps of
        the local error estimate in strain amplitude, the body's penetration s and speed U.
    diag : (N_DIAG,) diagnostics, see the D_* indices.
    level_t, level_x : (2, len(levels)) NaN on entry; the located time [s] and place [m] at
        which the upper (row 0) and lower (row 1) tension first reaches each level.

    Returns
    -------
    (status, n_out, upper, n_upper, lower, n_lower, contacts, n_contacts): status (see
    STATUS_NAMES); the number of output times filled; the tension records of both surfaces
    (rows R_T..R_JOIN, first n valid) and the contact record (rows (t, count)).
    """
    omega = modes[M_OMEGA]
    strain_coef = modes[M_STRAIN]
    lam1 = lay[L_LAM1]
    dx = lay[L_DX]
    K = lay[L_K]
    he = lay[L_HE]
    mirror = lay[L_MIRROR]
    t_start = ctrl[C_T_START]
    t_end = ctrl[C_T_END]
    tolerance = ctrl[C_TOLERANCE]
    fixed_step = ctrl[C_FIXED_STEP]
    h_init = ctrl[C_H_INIT]
    h_min = ctrl[C_H_MIN]
    h_max = ctrl[C_H_MAX]
    max_steps = ctrl[C_MAX_STEPS]
    bottom_gap = ctrl[C_BOTTOM_GAP]
    until_separation = ctrl[C_UNTIL_SEPARATION] > 0.0
    free_body = lay[L_INV_MASS] > 0.0
    N = omega.shape[0]
    J = cosq.shape[1]
    T = t_out.shape[0]
    _start_diagnostics(diag, t_start)

    # ----- work space: the state at t, the step's result, a sub-step's, and observer scratch
    z = np.empty(N, np.complex128)
    znew = np.empty(N, np.complex128)
    zsub = np.empty(N, np.complex128)
    err = np.empty(N, np.complex128)
    errsub = np.empty(N, np.complex128)
    cw = np.empty((2, N), np.complex128)
    rw = np.empty((5, N))
    C = np.empty((9, N), np.complex128)
    Cs = np.empty((9, N), np.complex128)
    Cb = np.empty((9, 2))
    Cbs = np.empty((9, 2))
    yb = np.zeros(2)                          # the body: (d, u), see B_D, B_U
    yb_new = np.zeros(2)
    yb_sub = np.zeros(2)
    errb = np.zeros(2)
    errb_sub = np.zeros(2)
    body0 = np.empty(2)                       # (s, U) at the step's ends, for the observers
    body1 = np.empty(2)
    N1 = np.empty(N)
    N5 = np.empty(N)
    Nsub = np.empty(N)
    a = np.empty(N)
    adot = np.empty(N)
    a_new = np.empty(N)
    adot_new = np.empty(N)
    a_sub = np.empty(N)
    adot_sub = np.empty(N)
    ones = np.ones(N)
    acc = np.zeros(2)                         # dissipated energy and layer power at a step's end
    acc_sub = np.zeros(2)
    damped = plate_damped(modes)
    delta = np.empty(J)
    delta_new = np.empty(J)
    delta_sub = np.empty(J)
    fvals = np.empty(J)
    eps = np.empty(J)
    eps_new = np.empty(J)
    eps_sub = np.empty(J)
    sgn = np.empty(J)
    ev_th = np.empty(4 * J + 16)
    ev_j = np.empty(4 * J + 16)
    rec_up = np.empty((256, N_REC))
    rec_lo = np.empty((256, N_REC))
    rec_c = np.empty((64, 2))
    n_up = 0
    n_lo = 0
    n_c = 0
    tension = np.empty((2, 4))
    tension0 = np.empty((2, 4))
    scratch = np.empty((5, 4))
    samples = np.empty((TENSION_SAMPLES + 1, 3))
    A = np.empty((TENSION_SAMPLES - 1, N))
    AD = np.empty((TENSION_SAMPLES - 1, N))
    A2 = np.empty((SWITCH_SAMPLES - 1, N))
    AD2 = np.empty((SWITCH_SAMPLES - 1, N))
    samples2 = np.empty((SWITCH_SAMPLES + 1, 3))
    L = dx * (J - 1)
    dense = np.zeros(1, np.bool_)
    best = np.empty(3)
    gap0 = np.empty(3)
    gap1 = np.empty(3)
    out3 = np.empty(3)
    joinable = np.zeros(2, np.bool_)
    run_max = np.empty(2)
    fixed = np.array([-1.0, 0.0])
    bottom_level = 1.0 - bottom_gap

    # ----- the initial state and its observers
    for n in range(N):
        z[n] = mode_z(a0[n], adot0[n], n, modes)
        a[n] = a0[n]
        adot[n] = adot0[n]
    t = t_start
    work = 0.0
    diss = 0.0                  # energy dissipated in the damped plate
    err_sum = 0.0
    rhs_count = 1
    st, force, jmax, lp = layer_forcing_at(body_position(lay, t, yb), body_speed(lay, yb), a, adot,
                                           modes[M_COEF], cosq, wq, lay, delta, fvals, N1)
    if st != 0:
        diag[D_T_REACHED] = t
        diag[D_FAIL_T] = t
        diag[D_FAIL_KIND] = FAIL_BOTTOMED
        return LAYER_BOTTOMED_OUT, 0, rec_up, 0, rec_lo, 0, rec_c, 0
    contacts = count_contacts(delta, jmax, mirror)
    rec_c, n_c = _append(rec_c, n_c, t, contacts, 0.0, 0.0, 0.0)
    diag[D_MAX_CONTACTS] = contacts
    strain_nodes(a, strain_coef, cosq, eps)
    for s in range(2):
        sign = 1.0 - 2.0 * s
        global_state(eps, sign, a, adot, strain_coef, lam1, dx, tension[s])
        run_max[s] = tension[s, 0]
        diag[D_MAX_UPPER + 3 * s] = tension[s, 0]
        diag[D_MAX_UPPER_X + 3 * s] = tension[s, 2]
        diag[D_MAX_UPPER_T + 3 * s] = t
    gap_peak(body_position(lay, t, yb), body_speed(lay, yb), delta, jmax, a, adot, ones, lay, gap0)
    diag[D_MAX_DELTA] = gap0[0]
    diag[D_MAX_DELTA_T] = t
    e0 = _plus_plate_energy(layer_energy(delta, jmax, dx, K, he, mirror), modes, z)
    resid = 0.0                 # E_plate + E_layer + D - W - E(t_start)
    max_residual = 0.0
    body_resid0 = body_residual(lay, t, yb, work)
    max_body_residual = 0.0
    peak_work = work
    if free_body:
        diag[D_BODY_RESIDUAL] = 0.0

    k = 0
    status = OK
    steps = 0
    rejected = 0
    h = min(h_init, h_max)
    h_coeffs = -1.0
    prev_ratio = 1.0
    bottomed = False
    separated = False
    eps_ready = False
    adaptive = method == ETD34 and fixed_step <= 0.0
    while True:
        # ----- record outputs due at the current time
        while k < T and t_out[k] <= t:
            _record_output(k, t, z, a, adot, yb, delta, jmax, force, work, err_sum, diss, modes, lay, out_a,
                           out_adot, out_series)
            k += 1
        if bottomed or separated or t >= t_end:
            break
        if steps + rejected >= max_steps:
            status = STEP_LIMIT
            diag[D_FAIL_T] = t
            diag[D_FAIL_KIND] = FAIL_MAX_STEPS
            break
        target = t_out[k] if k < T else t_end
        # ----- choose the step
        h_step, t_new, landing = _next_step(t, t_start, target, h, h_init, fixed_step, fixed)
        if h_step != h_coeffs:
            etd_coefficients(modes, h_step, C)
            body_coefficients(h_step, Cb)
            h_coeffs = h_step

        # ----- one step
        st, F5, jm5, w_new, event = take_step(method, t, t_new, h_step, z, N1, force, work, contacts,
                                              C, modes, lay, cosq, wq, cw, rw, fvals, delta_new,
                                              znew, N5, err, eps_new, yb, Cb, yb_new, errb, diss, acc, lp)
        eps_ready = True                     # eps_new: the strain at the nodes at t_new
        rhs_count += 4
        if not _finite_state(st, w_new, znew, yb_new):
            if not adaptive:
                diag[D_FAIL_T] = t
                diag[D_FAIL_KIND] = FAIL_FIXED_STEP
                status = NONFINITE
                break
            rejected += 1
            h = 0.25 * h_step
            if h < h_min:
                diag[D_FAIL_T] = t
                if st != 0:
                    status = LAYER_BOTTOMED_OUT
                    diag[D_FAIL_KIND] = FAIL_BOTTOMED
                else:
                    status = NONFINITE
                    diag[D_FAIL_KIND] = FAIL_NONFINITE
                break
            continue
        ratio = 0.0
        expo = 1.0 / 3.0 if event else 0.25
        if adaptive:
            ratio = _error_ratio(err, errb, z, znew, modes, lay, tolerance, gap0, bottom_gap,
                                 ones, rw[0])
            if ratio > 1.0:
                rejected += 1
                h = h_step * max(0.2, 0.9 * ratio ** -expo)
                if h < h_min:
                    diag[D_FAIL_T] = t
                    if gap0[0] > 1.0 - 10.0 * bottom_gap:
                        status = LAYER_BOTTOMED_OUT
                        diag[D_FAIL_KIND] = FAIL_BOTTOMED
                    else:
                        status = STEP_LIMIT
                        diag[D_FAIL_KIND] = FAIL_STEP_UNDERFLOW
                    break
                continue

        # ----- the energy identity may not jump (a step that breaks it is rejected)
        e_new = _plus_plate_energy(layer_energy(delta_new, jm5, dx, K, he, mirror), modes, znew)
        resid_new = e_new + acc[0] - w_new - e0
        if not abs(resid_new - resid) <= _energy_allowance(delta_new, jm5, e_new, w_new, e0, work, mirror):
            diag[D_ENERGY_JUMPS] += 1.0
            rejected += 1
            h = 0.25 * h_step
            if not adaptive or h < h_min:
                status = ENERGY_VIOLATION
                diag[D_FAIL_T] = t
                diag[D_FAIL_KIND] = FAIL_ENERGY_JUMP
                break
            continue

        # ----- bottoming: the gap closes to bottom_gap inside the step
        for n in range(N):
            a_new[n] = mode_a(znew[n], n, modes)
            adot_new[n] = mode_adot(znew[n], a_new[n], n, modes)
        gap_peak(body_position(lay, t_new, yb_new), body_speed(lay, yb_new), delta_new, jm5, a_new,
                 adot_new, ones, lay, gap1)
        h_eff = h_step
        c0, c1, c2, c3 = hermite(gap0[0], gap1[0], gap0[1], gap1[1], h_step)
        if K > 0.0 and (gap1[0] >= bottom_level or cubic_max(c0, c1, c2, c3)[0] >= bottom_level):
            s_lo, s_hi, F_b, jm_b, w_b, found = locate_event(
                0, bottom_level, method, t, h_step, gap0, gap1, z, N1, force, work, contacts, Cs,
                modes, lay, cosq, wq, cw, rw, fvals, delta_new, znew, N5, err, a_new, adot_new,
                eps_sub, ones, gap1, yb, Cbs, yb_new, errb, diss, acc, lp)
            if found:
                bottomed = True
                eps_ready = False            # the state is the search's last sub-step
                h_eff = s_lo
                t_new = t + s_lo
                F5, jm5, w_new = F_b, jm_b, w_b
                e_new = _plus_plate_energy(layer_energy(delta_new, jm5, dx, K, he, mirror), modes, znew)
                resid_new = e_new + acc[0] - w_new - e0
            else:
                # the interpolant's crossing was not real: the search overwrote the step's
                # buffers, so take the accepted step again (same size and coefficients, same result)
                st, F5, jm5, w_new, event = take_step(method, t, t_new, h_step, z, N1, force, work,
                                                      contacts, C, modes, lay, cosq, wq, cw, rw, fvals,
                                                      delta_new, znew, N5, err, eps_new, yb, Cb, yb_new,
                                                      errb, diss, acc, lp)
                for n in range(N):
                    a_new[n] = mode_a(znew[n], n, modes)
                    adot_new[n] = mode_adot(znew[n], a_new[n], n, modes)
                gap_peak(body_position(lay, t_new, yb_new), body_speed(lay, yb_new), delta_new, jm5,
                         a_new, adot_new, ones, lay, gap1)

        # ----- accepted: observers on [t, t_new], then shift the state
        steps += 1
        if not bottomed:
            e_step = 0.0
            if damped:                       # the error of a and of a' / omega, in strain
                for n in range(N):
                    ea = mode_a(err[n], n, modes)
                    ev = mode_adot(err[n], ea, n, modes) / omega[n]
                    e_step += strain_coef[n] ** 2 * (ea * ea + ev * ev)
            else:
                for n in range(N):
                    e_step += (strain_coef[n] / omega[n]) ** 2 * (err[n].real ** 2 + err[n].imag ** 2)
            err_sum += math.sqrt(e_step)
            diag[D_H_MIN] = min(diag[D_H_MIN], h_step)
            diag[D_H_MAX] = max(diag[D_H_MAX], h_step)
        if not eps_ready:
            strain_nodes(a_new, strain_coef, cosq, eps_new)
        tension0[:, :] = tension
        dense[0] = not h_eff > 0.0           # computed on demand by the tension observer
        dz = (z, N1, rw[2], N5, modes)
        rec_up, n_up, rec_lo, n_lo = _observe_tensions(
            t, h_eff, eps, eps_new, a, a_new, adot, adot_new, dz, A, AD, dense, modes, lay, L, tension,
            scratch, samples, rec_up, n_up, rec_lo, n_lo, joinable, run_max, best, A2, AD2, eps_sub, cosq,
            samples2, diag)
        # exact crossings, for verification: after both surfaces are observed (the search's
        # sub-steps overwrite the scratch the dense output reads)
        for s in range(2):
            sign = 1.0 - 2.0 * s
            rm = run_max[s]
            for i in range(levels.shape[0]):
                if math.isnan(level_t[s, i]) and levels[i] <= rm:
                    lo_, hi_, _, _, _, found = locate_event(
                        int(sign), levels[i], method, t, h_eff, tension0[s], tension[s], z, N1,
                        force, work, contacts, Cs, modes, lay, cosq, wq, cw, rw, fvals, delta_sub,
                        zsub, Nsub, errsub, a_sub, adot_sub, eps_sub, ones, out3, yb, Cbs, yb_sub,
                        errb_sub, diss, acc_sub, lp)
                    if found:
                        level_t[s, i] = t + 0.5 * (lo_ + hi_)
                        level_x[s, i] = out3[2]
        # (t + h_eff, not t_new: the same time in every sense but its last bit on a landing step)
        body0[0] = body_position(lay, t, yb)
        body0[1] = body_speed(lay, yb)
        body1[0] = body_position(lay, t + h_eff, yb_new)
        body1[1] = body_speed(lay, yb_new)
        contacts, rec_c, n_c, largest = observe_contacts(t, h_eff, delta, jmax, delta_new, jm5, a,
                                                         adot, a_new, adot_new, body0, body1, cosq, lay,
                                                         sgn, ev_th, ev_j, contacts, rec_c, n_c)
        if largest > diag[D_MAX_CONTACTS]:
            diag[D_MAX_CONTACTS] = largest
        if observe_body(t, h_eff, yb, yb_new, force, F5, contacts, rec_c, n_c, lay, diag) and until_separation:
            separated = True
        for n in range(N):
            z[n] = znew[n]
            N1[n] = N5[n]
            a[n] = a_new[n]
            adot[n] = adot_new[n]
        yb[:] = yb_new
        delta, delta_new = delta_new, delta
        eps, eps_new = eps_new, eps
        gap0[:] = gap1
        t = t_new
        work = w_new
        diss = acc[0]
        lp = acc[1]
        force = F5
        jmax = jm5
        resid = resid_new
        max_residual = max(max_residual, abs(resid))
        peak_work = max(peak_work, work)
        if free_body:
            max_body_residual = max(max_body_residual, abs(body_residual(lay, t, yb, work) - body_resid0))
        if force > diag[D_MAX_FORCE]:
            diag[D_MAX_FORCE] = force
            diag[D_MAX_FORCE_T] = t
        if gap0[0] > diag[D_MAX_DELTA]:
            diag[D_MAX_DELTA] = gap0[0]
            diag[D_MAX_DELTA_T] = t
        if bottomed:
            status = LAYER_BOTTOMED_OUT
            diag[D_FAIL_T] = t
            diag[D_FAIL_KIND] = FAIL_LOCATED
            diag[D_BOTTOM_T] = t
            diag[D_BOTTOM_X] = gap0[2]
            diag[D_BOTTOM_SPEED] = he * gap0[1]
            diag[D_MAX_FORCE] = np.inf      # K f(delta) is unbounded as the gap closes
            diag[D_MAX_FORCE_T] = t
            continue
        if separated:
            status = SEPARATED
            continue

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

    if status == OK and free_body and until_separation and not math.isnan(diag[D_STOP_T]):
        status = STOPPED                     # stopped, and still on the ice at the window's end
    diag[D_DISSIPATED] = diss
    status = _finish_diagnostics(diag, status, t, work, peak_work, max_residual, max_body_residual, gap0, he,
                                 steps, rejected, rhs_count)
    return status, k, rec_up, n_up, rec_lo, n_lo, rec_c, n_c
