r"""The plate and the water: the per-mode linear part of the model (docs/model.md, "Equations").

Each mode n is a damped oscillator a_n'' + c_n a_n' + omega_n^2 a_n = P_n (c_n = 0: the paper's
elastic ice; c_n = tau D lambda_n^4 / M_n for Kelvin-Voigt ice). With mu_+- the roots of
mu^2 + c mu + omega^2 = 0, the modal variable z_n = a_n' - mu_- a_n obeys z_n' = mu_+ z_n + P_n
exactly: for the elastic plate z_n = a_n' + i omega_n a_n, and the plate energy is
E_plate = sum_n L M_n |z_n|^2 / 2. This module holds the :data:`Plate` table, the maps between
(a, a') and z (``mode_a``, ``mode_adot``, ``mode_z``), the exact propagators e^{zeta} and the phi
functions of zeta = mu_+ h (``phi_from``, ``phi_complex``, ``mode_phis``, ``emul``), the plate
energy and the power the damping dissipates.

Analytic benchmarks: phi_k(zeta) = sum_m zeta^m / (m + k)! to two ulps on both sides of the
switch to the series at |y| = 1 (tests/test_kernel_pieces.py, test_phi_functions_to_two_ulps);
with the layer off and a_n(0) = 1 every integrator returns a_n(t) = cos(omega_n t), ETD34 to
round-off (tests/test_integrators.py, test_layer_off_free_oscillation_is_cos_omega_t).
"""
import cmath
import math
from collections import namedtuple

import numpy as np

from ..compile.jit import kernel

#: the plate: modes (8, N), its per-mode constants over the kernel's modes n in the rows below,
#: and lm_floor, L M of the first symmetric mode (the floor of the error norm) [kg m-1]. One
#: table, not eight arrays: numba counts a reference to every array a tuple holds each time the
#: tuple is bound to a name, and the Plate is bound in every stage (docs/architecture.md)
Plate = namedtuple("Plate", "modes lm_floor")
#: the modes' amplitudes a_n [m] and rates a_n' [m s-1] (or a floe's dry coefficients and theirs)
Modes = namedtuple("Modes", "a adot")
#: rows of Plate.modes: omega_n [s-1]; coef = -2/(L M_n) (-1/(L M_n) on the full plate); strain =
#: (hi/2) lambda_n^2 [m-1]; MASS = L M_n [kg m-1]; the Kelvin-Voigt damping HALF_C = c_n/2 [s-1];
#: OMEGA_D = sqrt(omega^2 - c^2/4) of an oscillating mode (KIND 0; omega itself when c = 0) or
#: kappa = sqrt(c^2/4 - omega^2) of an overdamped one (KIND 1); ONES (unit weights for sums of modes)
OMEGA, COEF, STRAIN, MASS, HALF_C, OMEGA_D, KIND, ONES = range(8)


def make_plate(omega, coef, strain, mass, half_c, omega_d, kind, lm_floor):
    """A Plate from its per-mode arrays (each (N,)) and lm_floor (plain Python, once per case)."""
    modes = np.zeros((8, np.size(omega)))
    for row, values in ((OMEGA, omega), (COEF, coef), (STRAIN, strain), (MASS, mass), (HALF_C, half_c),
                        (OMEGA_D, omega_d), (KIND, kind), (ONES, 1.0)):
        modes[row] = values
    return Plate(modes, float(lm_floor))


#: Taylor coefficients of phi_3(i y) in u = y^2: real part sum_k (-u)^k / (2k + 3)!, imaginary
#: part y sum_k (-u)^k / (2k + 4)!, k = 0..8 (for |y| < 1 the first omitted terms are below 1e-17)
PHI3_RE = np.array([1.0 / math.factorial(2 * k + 3) for k in range(9)])


PHI3_IM = np.array([1.0 / math.factorial(2 * k + 4) for k in range(9)])


@kernel
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


@kernel
def phi_functions(y):
    """phi_1, phi_2, phi_3 of zeta = i y (see phi_from)."""
    return phi_from(y, complex(math.cos(y), math.sin(y)))


#: Taylor coefficients 1/(m + 3)! of phi_3(zeta), m = 0..17 (|zeta| < 1: the first omitted term
#: is below 1e-19)
PHI3_SERIES = np.array([1.0 / math.factorial(m + 3) for m in range(18)])


@kernel
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


@kernel
def mode_phis(plate, n, d):
    """(e, phi_1, phi_2, phi_3) of the damped mode n over a time d, packed as complex numbers
    that act on its z as emul does: an oscillating mode's of zeta = mu_+ d, mu_+ = -c/2 + i
    omega_d; an overdamped mode's of its two real rates mu_+- = -c/2 +- kappa, as (value at
    mu_+) + i (value at mu_-)."""
    hc = plate.modes[HALF_C, n]
    wd = plate.modes[OMEGA_D, n]
    if plate.modes[KIND, n] == 0.0:
        return phi_complex(complex(-hc * d, wd * d))
    ep, p1p, p2p, p3p = phi_complex(complex((-hc + wd) * d, 0.0))
    em, p1m, p2m, p3m = phi_complex(complex((-hc - wd) * d, 0.0))
    return (complex(ep.real, em.real), complex(p1p.real, p1m.real), complex(p2p.real, p2m.real),
            complex(p3p.real, p3m.real))


@kernel
def emul(e, z, kind):
    """e^{zeta} z for a mode's z: a complex product (kind 0), or component by component for an
    overdamped mode (kind 1: z = y_+ + i y_-, two real decaying components)."""
    if kind == 0.0:
        return e * z
    return complex(e.real * z.real, e.imag * z.imag)


@kernel
def plate_damped(plate):
    """True for viscoelastic ice (c_n grows with n: the last mode is damped if any is)."""
    return plate.modes[HALF_C, plate.modes.shape[1] - 1] > 0.0


@kernel
def mode_a(z, n, plate):
    """a_n from z_n. With mu_+- the roots of mu^2 + c mu + omega^2 = 0, z = a' - mu_- a obeys
    z' = mu_+ z + P: for c = 0, z = a' + i omega a. Oscillating: z = a' + (c/2) a + i omega_d a;
    overdamped: z = y_+ + i y_-, y_+- = a' - mu_-+ a."""
    if plate.modes[KIND, n] == 0.0:
        return z.imag / plate.modes[OMEGA_D, n]
    return (z.real - z.imag) / (2.0 * plate.modes[OMEGA_D, n])


@kernel
def mode_adot(z, a, n, plate):
    """a_n' from z_n and a_n (see mode_a)."""
    if plate.modes[KIND, n] == 0.0:
        return z.real - plate.modes[HALF_C, n] * a
    return z.real - (plate.modes[HALF_C, n] + plate.modes[OMEGA_D, n]) * a


@kernel
def mode_z(a, adot, n, plate):
    """z_n from a_n and a_n' (see mode_a); exactly a' + i omega a for an undamped mode."""
    hc = plate.modes[HALF_C, n]
    wd = plate.modes[OMEGA_D, n]
    if plate.modes[KIND, n] == 0.0:
        if hc == 0.0:
            return complex(adot, wd * a)
        return complex(adot + hc * a, wd * a)
    return complex(adot + (hc + wd) * a, adot + (hc - wd) * a)


@kernel
def damping_power(plate, n, v):
    """L M_n c_n a_n'^2 [W m-1]: the power the Kelvin-Voigt damping takes from mode n at a_n' = v."""
    return 2.0 * plate.modes[HALF_C, n] * plate.modes[MASS, n] * v * v


@kernel
def dissipation_rate(z, plate):
    """sum_n L M_n c_n a_n'^2 [W m-1]: the power the Kelvin-Voigt damping takes from the plate."""
    r = 0.0
    for n in range(z.shape[0]):
        hc = plate.modes[HALF_C, n]
        if hc > 0.0:
            a = mode_a(z[n], n, plate)
            v = mode_adot(z[n], a, n, plate)
            r += damping_power(plate, n, v)
    return r


@kernel
def mode_acceleration(plate, a, v, P, out):
    """The mode equations in (a, a') form, a_n'' = P_n - omega_n^2 a_n - c_n a_n', into out (for
    an integrator of first-order systems, solver.scipy_reference); returns the power the damping
    takes, sum_n damping_power."""
    power = 0.0
    for n in range(a.shape[0]):
        out[n] = -plate.modes[OMEGA, n] ** 2 * a[n] + P[n]
        if plate.modes[HALF_C, n] > 0.0:
            out[n] -= 2.0 * plate.modes[HALF_C, n] * v[n]
            power += damping_power(plate, n, v[n])
    return power


@kernel
def plus_plate_energy(e, plate, z):
    """e + E_plate, E_plate = sum_n L M_n (a_n'^2 + omega_n^2 a_n^2) / 2 [J m-1] (added term by
    term to e): L M_n |z_n|^2 / 2 for the undamped plate."""
    LM = plate.modes[MASS]
    if not plate_damped(plate):
        for n in range(z.shape[0]):
            e += 0.5 * LM[n] * (z[n].real ** 2 + z[n].imag ** 2)
        return e
    omega = plate.modes[OMEGA]
    for n in range(z.shape[0]):
        a = mode_a(z[n], n, plate)
        v = mode_adot(z[n], a, n, plate)
        e += 0.5 * LM[n] * (v * v + omega[n] ** 2 * a * a)
    return e
