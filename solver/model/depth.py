r"""Finite depth under a floe: what a bottom at depth H takes from the deep water's map
(docs/model.md, "A free floe"). On depth H the Dirichlet-to-Neumann symbol k tanh(kH) =
|k| - |k| (1 - tanh |k|H), so on the floe's basis b_j = sqrt(1 - xi^2) U_{j-1}(xi) the Galerkin
matrix is the deep one, diag(pi j / 2), less

    C_ij = pi i j (-1)^((j - i)/2) int_0^inf (1 - tanh kH) J_i(kL) J_j(kL) / k dk   (i + j even),

an exponentially convergent k-integral over a table of Bessel functions (solver.model.floe's
added_mass uses it). Benchmarks: the deep and the shallow limits and a finite-difference solve
(tests/test_floe.py::test_added_mass_on_finite_depth); the Bessel table against scipy's.
"""
from __future__ import annotations

import math

import numpy as np


def bessel_table(n_max, x):
    """J_n(x) for n = 0..n_max at every x > 0, (n_max + 1, x.size): by the recurrence
    J_{n-1} + J_{n+1} = (2n / x) J_n, forward from scipy's J_0 and J_1 where x >= n_max (stable
    for n < x), and backward (Miller's algorithm, normalised by J_0 + 2 sum J_2k = 1) from
    n_max + 16 + sqrt(40 n_max) above elsewhere. 40 times faster than scipy.special.jv on the
    depth correction's table and within 1e-14 of it (tests/test_floe.py)."""
    from scipy import special          # (here: a floe on finite depth only)
    x = np.asarray(x, dtype=float)
    out = np.zeros((n_max + 1, x.size))
    big = x >= n_max
    if big.any():
        xb = x[big]
        rows = out[:, big]
        rows[0] = special.j0(xb)
        if n_max >= 1:
            rows[1] = special.j1(xb)
        for n in range(1, n_max):
            rows[n + 1] = (2.0 * n / xb) * rows[n] - rows[n - 1]
        out[:, big] = rows
    small = ~big
    if small.any():
        xs = x[small]
        start = 2 * ((max(n_max, int(xs.max())) + 16 + int(math.sqrt(40.0 * max(n_max, xs.max())))) // 2)
        rows = np.zeros((n_max + 1, xs.size))
        above, here = np.zeros(xs.size), np.full(xs.size, 1e-30)
        total = np.zeros(xs.size)
        for n in range(start, 0, -1):
            below = (2.0 * n / xs) * here - above
            above, here = here, below
            if n - 1 <= n_max:
                rows[n - 1] = here
            if (n - 1) % 2 == 0:
                total += (2.0 if n - 1 > 0 else 1.0) * here
            huge = np.abs(here) > 1e250
            if huge.any():                 # rescale those columns, and what they stored
                above[huge] *= 1e-250
                here[huge] *= 1e-250
                total[huge] *= 1e-250
                rows[:, huge] *= 1e-250
        out[:, small] = rows / total
    return out


#: the depth correction integrates this many k-nodes at a time (its memory: J of them in floats)
DEPTH_NODES_AT_ONCE = 2**16
#: beyond this depth over half-length the correction, O((L / H)^2), is below round-off: zero
DEEP_ENOUGH = 1e8


def depth_correction(J, L, H):
    """C_ij = pi i j (-1)^((j - i)/2) int_0^inf (1 - tanh kH) J_i(kL) J_j(kL) / k dk for i + j even
    (0 otherwise), i, j = 1..J: what the bottom at depth H takes from the deep water's map on
    b_j, whose Fourier transform is pi j (-i)^(j-1) J_j(kL) / k. 1 - tanh kH = 2 / (e^{2kH} + 1)
    falls below 1e-17 at kH = 20, where the integral stops: Gauss-Legendre, 16 nodes on each
    half period pi / L of the Bessel functions (bessel_table). Its cost grows as L / H, its memory
    does not (DEPTH_NODES_AT_ONCE nodes at a time); past H = DEEP_ENOUGH L it is zero (O((L/H)^2))."""
    if H > DEEP_ENOUGH * L:
        return np.zeros((J, J))
    kmax = 20.0 / H
    panels = max(1, int(math.ceil(kmax * L / math.pi)))
    gx, gw = np.polynomial.legendre.leggauss(16)
    j = np.arange(1, J + 1)
    total = np.zeros((J, J))
    every = np.linspace(0.0, kmax, panels + 1)
    step = max(1, DEPTH_NODES_AT_ONCE // 16)
    for first in range(0, panels, step):                 # panels [first, last): their nodes at once
        last = min(panels, first + step)
        edges = every[first:last + 1]
        half = 0.5 * np.diff(edges)[:, None]
        kk = (0.5 * (edges[:-1, None] + edges[1:, None]) + half * gx[None, :]).ravel()
        weight = (half * gw[None, :]).ravel() * 2.0 / (np.exp(2.0 * kk * H) + 1.0) / kk
        B = bessel_table(J, kk * L)[1:]
        total += (B * weight) @ B.T
    sign = np.where((j[:, None] + j[None, :]) % 2 == 0, (-1.0) ** ((j[None, :] - j[:, None]) // 2), 0.0)
    return np.pi * np.outer(j, j) * sign * total
