"""Cubic Hermite interpolants on a step, p(th) with th = (t - t0) / h in [0, 1]: their maxima,
first crossings of a level and sign changes, to round-off (docs/model.md, "Events").

An event is located inside a step from the cubic Hermite of a quantity whose value and time
derivative are both known exactly at the step's two ends (the tension peak, delta at a node,
the gap, a free body's speed). Benchmark (tests/test_kernel_pieces.py, test_cubic_pieces): a
cubic with known roots and extrema is reproduced to round-off.
"""
import math

import numpy as np

from .compile.jit import kernel


@kernel
def hermite(p0, p1, r0, r1, h):
    """Power-basis coefficients of the cubic with p(0) = p0, p(1) = p1 and time derivatives
    r0, r1 at the ends of a step of length h."""
    c2 = 3.0 * (p1 - p0) - h * (2.0 * r0 + r1)
    c3 = 2.0 * (p0 - p1) + h * (r0 + r1)
    return p0, h * r0, c2, c3


@kernel
def cubic(c0, c1, c2, c3, th):
    return c0 + th * (c1 + th * (c2 + th * c3))


@kernel
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


@kernel
def _break(k, n, b1, b2):
    """The k-th of the breaks 0, (b1, b2 up to n), 1."""
    if k == 0:
        return 0.0
    if k == n + 1:
        return 1.0
    return b1 if k == 1 else b2


@kernel
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


@kernel
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


@kernel
def cubic_first_reach(c0, c1, c2, c3, level):
    """Smallest th in [0, 1] with p(th) >= level, or -1 if the cubic stays below level."""
    if c0 >= level:
        return 0.0
    nc, b1, b2 = cubic_breaks(c1, c2, c3)
    for i in range(nc + 1):
        hi = _break(i + 1, nc, b1, b2)
        if cubic(c0, c1, c2, c3, hi) >= level:
            return _bisect_reach(c0, c1, c2, c3, level, _break(i, nc, b1, b2), hi)
    return -1.0


@kernel
def _bisect_reach(c0, c1, c2, c3, level, lo, hi):
    """The smallest th in [lo, hi] with p(th) >= level, p(lo) < level <= p(hi) (to round-off;
    p(hi) == level, a record ending at a break's level, is reached at hi)."""
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if cubic(c0, c1, c2, c3, mid) >= level:
            hi = mid
        else:
            lo = mid
    return hi


@kernel
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
