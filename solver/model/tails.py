r"""The tails of the cosine series of a broken plate's added mass (solver.model.parts.jump_tail;
docs/model.md, "Breaking into parts"): sum_{k > K} cos(k theta) / k^3 and sum_{k > K} e^(i k
theta) / k^p, by Gauss-Laguerre on their integrals k^-p = int t^(p-1) e^(-kt) dt / Gamma(p), and
the whole sum sum_{k >= 1} cos(k theta) / k^3 in closed form where (K + 1) theta is small.

Benchmark (tests/test_parts.py): each against its brute-force sum.
"""
import math

import numpy as np

#: Gauss-Laguerre nodes and weights (weight e^-u) of cosine_tail, and the (K + 1) theta below which it
#: takes the whole sum less the first K terms instead (the integrand's pole at u = i (K + 1) theta is
#: then near the nodes): within 3e-15, the round-off of the whole sum (tests/test_parts.py)
LAGUERRE_U, LAGUERRE_W = np.polynomial.laguerre.laggauss(40)
LAGUERRE_FROM = 20.0


def cosine_tail(theta, K: int) -> np.ndarray:
    """sum_{k > K} cos(k theta) / k^3 for each theta [rad]. With k^-3 = int t^2 e^-kt dt / 2 and
    the geometric sum under the integral, it is Re z^(K+1) int_0^inf u^2 e^-u / (1 - z e^(-u / (K
    + 1))) du / (2 (K + 1)^3), z = e^(i theta), taken by Gauss-Laguerre (the denominator as 2 e^-s
    sin^2(theta / 2) - expm1(-s) - i e^-s sin(theta): no cancellation); where (K + 1) theta (theta
    taken to [0, pi]) is below LAGUERRE_FROM, as clausen_cosine(theta) less the first K terms
    (zeta(3, K + 1) at theta = 0)."""
    from scipy.special import zeta
    theta = np.asarray(theta, dtype=float)
    reduced = np.abs(np.remainder(theta.ravel() + math.pi, 2.0 * math.pi) - math.pi)    # cos(k theta): even, 2 pi periodic
    n = K + 1.0
    s = LAGUERRE_U / n
    decay = np.exp(-s)
    denominator = (2.0 * decay * np.sin(0.5 * reduced[:, None]) ** 2 - np.expm1(-s)) - 1j * decay * np.sin(reduced[:, None])
    integral = (LAGUERRE_U**2 / denominator) @ LAGUERRE_W
    out = np.real(np.exp(1j * n * reduced) * integral) / (2.0 * n**3)
    near = (n * reduced < LAGUERRE_FROM) & (reduced > 0.0)
    if np.any(near):
        k = np.arange(1.0, n)
        out[near] = clausen_cosine(reduced[near]) - np.cos(np.outer(reduced[near], k)) @ k**-3.0
    out[reduced == 0.0] = zeta(3.0, n)
    return out.reshape(theta.shape)


def power_tail(theta, K: int, p: int) -> np.ndarray:
    """sum_{k > K} e^(i k theta) / k^p for each theta [rad], by cosine_tail's Gauss-Laguerre alone
    (within 1e-4 of the sum's largest, zeta(p, K + 1), where (K + 1) theta is small: enough for the
    tail's second order, p = 4 and 5)."""
    theta = np.asarray(theta, dtype=float)[..., None]
    n = K + 1.0
    s = LAGUERRE_U / n
    decay = np.exp(-s)
    denominator = (2.0 * decay * np.sin(0.5 * theta) ** 2 - np.expm1(-s)) - 1j * decay * np.sin(theta)
    integral = np.sum(LAGUERRE_W * LAGUERRE_U ** (p - 1) / denominator, axis=-1)
    return np.exp(1j * n * theta[..., 0]) * integral / (math.gamma(p) * n**p)


def clausen_cosine(theta) -> np.ndarray:
    """sum_{k >= 1} cos(k theta) / k^3 for 0 <= theta <= pi: zeta(3) - 3 theta^2 / 4 + theta^2
    ln(theta) / 2 - sum_{n >= 1} zeta(2n) theta^(2n+2) / (n (2n+1) (2n+2) (2 pi)^(2n)) (twice
    integrated from the Clausen function's series; 30 terms: 4^-30 at theta = pi)."""
    from scipy.special import zeta
    theta = np.asarray(theta, dtype=float)
    n = np.arange(1, 31, dtype=float)
    series = (zeta(2.0 * n) / (n * (2 * n + 1) * (2 * n + 2) * (2.0 * math.pi) ** (2 * n))) @ \
        (theta[None, :] ** (2 * n[:, None] + 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        log_term = np.where(theta > 0.0, 0.5 * theta**2 * np.log(np.where(theta > 0.0, theta, 1.0)), 0.0)
    return zeta(3.0) - 0.75 * theta**2 + log_term - series
