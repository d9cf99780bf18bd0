r"""A floe-form basis's raw dry modes at points (the free floe's, solver.model.floe, and a broken
plate's parts', solver.model.parts): each mode's value and two derivatives at one point (_raw3),
the sums of the dry coefficients against them at one point (floe_dry_sums, floe_sums: O(N) per
point), and a table of the modes at many points (dry_table), each mode 0 off its part.

On the free floe the wavenumbers from the header's FIRST_EVEN on are evenly spaced, and
exp(i beta_m x) goes by rotation, one complex product a mode. On a broken plate's parts
(FIRST_EVEN = N) each mode is computed on its own part only, and a part's modes beyond beta l =
ASYMPTOTIC, evenly spaced to round-off, take exp(i beta y) and their two exponentials from their
predecessor's by a product each (_part_sums; docs/model.md, "Cost").

Benchmark (tests/test_floe_gauss.py, tests/test_parts.py): the sums and the table against the
modes in numpy (solver.model.floe.dry_mode, solver.model.parts.part_values).
"""
import math

import numpy as np

from ..compile.jit import kernel
from .floe import (BETAS, CENTRES, FIRST_EVEN, HALF_LENGTH, HALVES, HIGHS, HYP, HYP_NEGLIGIBLE, KINDS,
                   LOWS, ORIGIN, RUNS, SPACING, STRAIN_FACTOR, TRIG, floe_dry, floe_header, floe_shapes)


@kernel(inline="always")
def _turn(c, s, k):
    """cos(y + k pi / 2) from c = cos y and s = sin y."""
    k = k % 4
    return c if k == 0 else (-s if k == 1 else (-c if k == 2 else s))


@kernel(inline="always")
def _hyperbolic_parts(beta, L, x):
    """(exp(beta (x - L)), exp(-beta (x + L))), each 0 where below exp(-HYP_NEGLIGIBLE)."""
    up = beta * (x - L)
    down = -beta * (x + L)
    return (math.exp(up) if up > -HYP_NEGLIGIBLE else 0.0), (math.exp(down) if down > -HYP_NEGLIGIBLE else 0.0)


@kernel
def _raw3(shapes, m, x, order):
    """Dry mode m's raw derivatives of orders order, order + 1 and order + 2 at one x (the floe's
    coordinate), from one cosine, one sine and the exponentials that are not negligible
    (dry_mode's values to round-off; the factors 1 / cos(beta l) and 1 / cosh(beta l) from the
    shapes table), about the mode's centre, and 0 off its part."""
    if not shapes[LOWS, m] <= x < shapes[HIGHS, m]:
        return 0.0, 0.0, 0.0
    kind, L = shapes[KINDS, m], shapes[HALVES, m]
    x = x - shapes[CENTRES, m]
    if kind == 0.0:
        return (1.0 if order == 0 else 0.0), 0.0, 0.0
    if kind == 1.0:
        if order == 0:
            return x / L, 1.0 / L, 0.0
        return (1.0 / L if order == 1 else 0.0), 0.0, 0.0
    beta = shapes[BETAS, m]
    return _elastic3(shapes, m, math.cos(beta * x), math.sin(beta * x), L, x, order)


@kernel(inline="always")
def _elastic3(shapes, m, c, s, L, x, order):
    """_raw3 of elastic dry mode m given c = cos(beta x) and s = sin(beta x)."""
    ep, em = _hyperbolic_parts(shapes[BETAS, m], L, x)
    return _elastic_parts(shapes, m, c, s, ep, em, order)


@kernel(inline="always")
def _elastic_parts(shapes, m, c, s, ep, em, order):
    """_elastic3 given its exponentials ep, em (_hyperbolic_parts) too. The orders the fields ask,
    0 (deflection) and 2 (strain), with their signs written out (_even_orders); others by _turn."""
    beta = shapes[BETAS, m]
    trig, hyp = shapes[TRIG, m], shapes[HYP, m]
    if order == 0 or order == 2:
        return _even_orders(shapes[KINDS, m] == 2.0, c * trig, s * trig, ep, em, hyp, beta, order)
    b0 = beta**order
    b1 = b0 * beta
    b2 = b1 * beta
    if shapes[KINDS, m] == 2.0:       # cos(beta x) / cos(beta L) + cosh(beta x) / cosh(beta L)
        even, odd = (ep + em) * hyp, (ep - em) * hyp
        return (b0 * (_turn(c, s, order) * trig + (even if order % 2 == 0 else odd)),
                b1 * (_turn(c, s, order + 1) * trig + (odd if order % 2 == 0 else even)),
                b2 * (_turn(c, s, order + 2) * trig + (even if order % 2 == 0 else odd)))
    even, odd = (ep - em) * hyp, (ep + em) * hyp   # sin(beta x) / sin(beta L) + sinh(beta x) / sinh(beta L)
    return (b0 * (_turn(s, -c, order) * trig + (even if order % 2 == 0 else odd)),
            b1 * (_turn(s, -c, order + 1) * trig + (odd if order % 2 == 0 else even)),
            b2 * (_turn(s, -c, order + 2) * trig + (even if order % 2 == 0 else odd)))


@kernel(inline="always")
def _even_orders(symmetric, ct, st, ep, em, hyp, beta, order):
    """_elastic_parts of order 0 or 2, ct = c trig and st = s trig: the same operations, the
    quarter turns' signs written out (a negation is exact) and beta^2 = beta beta (numba's power)."""
    b0 = 1.0 if order == 0 else beta * beta
    b1 = b0 * beta
    b2 = b1 * beta
    sign = 1.0 if order == 0 else -1.0
    if symmetric:
        even, odd = (ep + em) * hyp, (ep - em) * hyp
        return b0 * (sign * ct + even), b1 * (-sign * st + odd), b2 * (-sign * ct + even)
    even, odd = (ep - em) * hyp, (ep + em) * hyp
    return b0 * (sign * st + even), b1 * (sign * ct + odd), b2 * (-sign * st + even)


@kernel(nrt=True)
def floe_dry_sums(floe, d, x, field):
    """floe_sums from the dry coefficients d (floe_dry): O(N) per point; from the header's
    FIRST_EVEN on (modes of the whole floe: a broken plate's FIRST_EVEN is N), exp(i beta_m x)
    by rotation (as dry_table)."""
    N = d.shape[0]
    shapes = floe_shapes(floe, N)
    header = floe_header(floe)
    L = header[HALF_LENGTH]
    factor = 1.0 if field == 0 else header[STRAIN_FACTOR]
    order = 0 if field == 0 else 2
    xp = x + header[ORIGIN]
    m0 = min(int(header[FIRST_EVEN]), N)
    v0, v1, v2 = _part_sums(shapes, m0, xp, order, d)
    if m0 < N:
        b = shapes[BETAS, m0]
        cur = complex(math.cos(b * xp), math.sin(b * xp))
        rot = complex(math.cos(header[SPACING] * xp), math.sin(header[SPACING] * xp))
        for m in range(m0, N):
            r0, r1, r2 = _elastic3(shapes, m, cur.real, cur.imag, L, xp, order)
            cur *= rot
            v0 += d[m] * r0
            v1 += d[m] * r1
            v2 += d[m] * r2
    return factor * v0, factor * v1, factor * v2


@kernel
def _part_sums(shapes, m0, xp, order, d):
    """Over the dry modes m < m0 at one point xp (the floe's coordinate): sum_m d_m r_m of _raw3's
    three orders, each mode on its own part only (0 elsewhere). A
    mode that continues its predecessor's run of evenly spaced wavenumbers (the shapes row RUNS: a broken
    plate's parts beyond beta l = floe.ASYMPTOTIC; none of a floe's modes below FIRST_EVEN) takes
    exp(i beta y) and its two exponentials from the predecessor's by one product each (the
    rounding grows as the run's length times eps); every other mode as _raw3."""
    v0 = v1 = v2 = 0.0
    cur, rot = complex(1.0, 0.0), complex(1.0, 0.0)
    ep = em = fp = fm = 0.0
    along = 0.0                  # the spacing rot, fp and fm are for (0: none yet)
    previous = False             # mode m - 1 elastic and computed at xp
    for m in range(m0):
        if not shapes[LOWS, m] <= xp < shapes[HIGHS, m]:      # (off its part: adds nothing)
            previous = False
            continue
        if shapes[KINDS, m] < 2.0:
            r0, r1, r2 = _raw3(shapes, m, xp, order)
            previous = False
        else:
            L, y, beta = shapes[HALVES, m], xp - shapes[CENTRES, m], shapes[BETAS, m]
            spacing = shapes[RUNS, m] if previous else 0.0
            if spacing > 0.0:
                if spacing != along:
                    rot = complex(math.cos(spacing * y), math.sin(spacing * y))
                    fp, fm = math.exp(spacing * (y - L)), math.exp(-spacing * (y + L))
                    along = spacing
                cur *= rot
                ep *= fp
                em *= fm
            else:
                cur = complex(math.cos(beta * y), math.sin(beta * y))
                ep, em = _hyperbolic_parts(beta, L, y)
                along = 0.0
            r0, r1, r2 = _elastic_parts(shapes, m, cur.real, cur.imag, ep, em, order)
            previous = True
        v0 += d[m] * r0
        v1 += d[m] * r1
        v2 += d[m] * r2
    return v0, v1, v2


@kernel(nrt=True)
def dry_table(floe, xk, table):
    """table[m, k] = psi_m(x_k) (N, K): the raw dry modes at the points xk (kernel coordinates),
    whose sums against floe_dry's coefficients are the wet modes' (modal_sum_range) and whose
    projections floe_wet turns into the wet modes' (the contact-resolving rule on a floe). The
    modes below m0 (the header's FIRST_EVEN) directly; from m0 on, whose wavenumbers are evenly spaced,
    exp(i beta_m x) by rotation, one complex product an entry (its rounding grows as m eps)."""
    N, K = table.shape
    shapes = floe_shapes(floe, N)
    header = floe_header(floe)
    L = header[HALF_LENGTH]
    origin = header[ORIGIN]
    m0 = int(header[FIRST_EVEN])
    if m0 >= N:                  # a broken plate's parts: each part's modes over its points
        parts_table(shapes, origin, xk, 0, table)
        return
    for m in range(m0):
        _dry_row(shapes, m, origin, xk, table[m])
    spacing = header[SPACING]
    cur = np.empty(K, np.complex128)
    rot = np.empty(K, np.complex128)
    for k in range(K):
        x = xk[k] + origin
        cur[k] = complex(math.cos(shapes[BETAS, m0] * x), math.sin(shapes[BETAS, m0] * x))
        rot[k] = complex(math.cos(spacing * x), math.sin(spacing * x))
    for m in range(m0, N):
        beta, trig, hyp = shapes[BETAS, m], shapes[TRIG, m], shapes[HYP, m]
        row = table[m]
        if shapes[KINDS, m] == 2.0:
            for k in range(K):
                row[k] = cur[k].real * trig
        else:
            for k in range(K):
                row[k] = cur[k].imag * trig
        for k in range(K):
            cur[k] *= rot[k]
        sign = 1.0 if shapes[KINDS, m] == 2.0 else -1.0
        for k in range(K):
            x = xk[k] + origin
            if beta * (L - abs(x)) < HYP_NEGLIGIBLE:
                ep, em = _hyperbolic_parts(beta, L, x)
                row[k] += (ep + sign * em) * hyp


@kernel(nrt=True)
def parts_table(shapes, origin, xk, order, table):
    """table[m, k]: the raw dry mode m's derivative of the given order at x_k + origin (the floe's
    coordinate), 0 off its part: dry_table on a broken plate's parts (order 0; the header's
    FIRST_EVEN = N), and the parts' mode values (solver.model.parts.part_values). Each part's
    modes, which follow one another in the shapes table with one [LOWS, HIGHS), over the points on
    that part, a mode at a time (_part_rows)."""
    N, K = table.shape
    table[:, :] = 0.0
    idx = np.empty(K, np.int64)
    xp = np.empty(K)
    turns = np.empty((2, K), np.complex128)
    work = np.empty((4, K))
    m = 0
    while m < N:
        low, high = shapes[LOWS, m], shapes[HIGHS, m]
        end = m + 1
        while end < N and shapes[LOWS, end] == low and shapes[HIGHS, end] == high:
            end += 1
        n = 0
        for k in range(K):
            if low <= xk[k] + origin < high:
                idx[n] = k
                xp[n] = xk[k] + origin
                n += 1
        if n > 0:
            _part_rows(shapes, m, end, xp[:n], idx[:n], table, turns[:, :n], work[:, :n], order)
        m = end


@kernel
def _part_rows(shapes, first, end, xp, idx, table, turns, work, order):
    """table[m, idx[i]] for the modes first <= m < end of one part at its points xp (the floe's
    coordinate), their derivative of the given order: _part_sums' arithmetic, point for point
    (the same numbers), each mode a pass over the points; turns (2, n) complex and work (4, n):
    scratch for exp(i beta y) and its rotation, and the exponentials and their factors."""
    cur, rot = turns[0], turns[1]
    ep, em, fp, fm = work[0], work[1], work[2], work[3]
    n = xp.shape[0]
    along = 0.0                  # the spacing rot, fp and fm are for (0: none yet)
    previous = False             # mode m - 1 elastic
    for m in range(first, end):
        row = table[m]
        if shapes[KINDS, m] < 2.0:
            for i in range(n):
                row[idx[i]] = _raw3(shapes, m, xp[i], order)[0]
            previous = False
            continue
        L, centre, beta = shapes[HALVES, m], shapes[CENTRES, m], shapes[BETAS, m]
        spacing = shapes[RUNS, m] if previous else 0.0
        if spacing > 0.0:
            if spacing != along:
                for i in range(n):
                    y = xp[i] - centre
                    rot[i] = complex(math.cos(spacing * y), math.sin(spacing * y))
                    fp[i], fm[i] = math.exp(spacing * (y - L)), math.exp(-spacing * (y + L))
                along = spacing
            for i in range(n):
                cur[i] *= rot[i]
                ep[i] *= fp[i]
                em[i] *= fm[i]
        else:
            for i in range(n):
                y = xp[i] - centre
                cur[i] = complex(math.cos(beta * y), math.sin(beta * y))
                ep[i], em[i] = _hyperbolic_parts(beta, L, y)
            along = 0.0
        trig, hyp = shapes[TRIG, m], shapes[HYP, m]          # (_elastic_parts' value, order 0)
        if order != 0:
            for i in range(n):
                row[idx[i]] = _elastic_parts(shapes, m, cur[i].real, cur[i].imag, ep[i], em[i], order)[0]
        elif shapes[KINDS, m] == 2.0:
            for i in range(n):
                row[idx[i]] = cur[i].real * trig + (ep[i] + em[i]) * hyp
        else:
            for i in range(n):
                row[idx[i]] = cur[i].imag * trig + (ep[i] - em[i]) * hyp
        previous = True


@kernel
def _dry_row(shapes, m, origin, xk, row):
    """Dry mode m's raw values at the points xk into row (dry_table, directly), about the mode's
    centre, 0 off its part."""
    kind, beta = shapes[KINDS, m], shapes[BETAS, m]
    trig, hyp = shapes[TRIG, m], shapes[HYP, m]
    L, centre, low, high = shapes[HALVES, m], shapes[CENTRES, m], shapes[LOWS, m], shapes[HIGHS, m]
    K = xk.shape[0]
    if kind == 0.0:
        row[:] = 1.0
    elif kind == 1.0:
        for k in range(K):
            row[k] = (xk[k] + origin - centre) / L
    else:
        sym = kind == 2.0
        for k in range(K):
            if not low <= xk[k] + origin < high:          # (off its part: 0 below, not computed)
                continue
            x = xk[k] + origin - centre
            ep, em = _hyperbolic_parts(beta, L, x)
            if sym:
                row[k] = math.cos(beta * x) * trig + (ep + em) * hyp
            else:
                row[k] = math.sin(beta * x) * trig + (ep - em) * hyp
    for k in range(K):
        if not low <= xk[k] + origin < high:
            row[k] = 0.0


@kernel(nrt=True)
def floe_sums(floe, c, x, field):
    """sum_k c_k F_k(x) and its first two x-derivatives, F_k the wet mode k's deflection (field
    0) or upper-surface strain -hi/2 Psi_k'' (field 1), at x in kernel coordinates: the dry
    coefficients of c (floe_dry, O(N^2)) then floe_dry_sums (O(N)); a caller with many points at
    one state computes the dry coefficients once."""
    d = np.empty(c.shape[0])
    floe_dry(floe, c, d)
    return floe_dry_sums(floe, d, x, field)
