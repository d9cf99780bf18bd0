r"""Crack onset for any yield strain from one run: the running-maximum tension record.

A run stores, for each surface, the record of the running maximum over time of the peak
tension, m(t) = max_x (+eps) on the upper surface and max_x (-eps) on the lower one
(docs/model.md, "Crack onset"). Each accepted step in which the running maximum rose adds a
*piece*: the cubic Hermite interpolant of the peak between the two step ends, from its value
and its exact time derivative d/dt max_x eps = eps_t(x*) at both ends. Rows of a record::

    (t [s], value [1], rate [s-1], x [m], join)      join = 1: a piece from the previous row

The first time the tension reaches a yield strain eps_Y is then the first root of
piece(t) = eps_Y in the first piece whose maximum reaches eps_Y; its place is x interpolated
linearly along the piece. This answers any list of eps_Y with no solver run, to the accuracy
of the in-loop located crossing (tests/test_fracture.py: <= 1e-6 relative against crossings
located on true sub-steps of the integrator).
"""
import numpy as np

from .axes import log_axis
from .cubic import cubic_first_reach, cubic_max, hermite
from .compile.jit import kernel
from .keys import ParameterError
from .layout import R_JOIN, R_RATE, R_T, R_VALUE, R_X

#: record nodes whose places differ by more than this [m] belong to two different peaks
PEAK_JUMP = 0.05

#: key -> (long_name, units) of the yield strain, a post-processing axis (not a solver input)
EPS_Y_INFO = ("yield strain of ice: tension above it is expected to crack the ice", "1")
#: the paper's yield strain
PAPER_EPS_Y = 8e-5


def default_eps_Y() -> np.ndarray:
    """The default axis of yield strains crack onset is given for.

    Returns
    -------
    numpy.ndarray
        10 values a decade from 1e-5 to 1e-1 (decades exact, every value the same on any CPU:
        solver.axes), and the paper's 8e-5: 42 values, sorted.

    Examples
    --------
    >>> from solver import default_eps_Y
    >>> axis = default_eps_Y()
    >>> len(axis), float(axis[0]), float(axis[-1]), bool(8e-5 in axis)
    (42, 1e-05, 0.1, True)
    """
    return np.unique(np.r_[log_axis(1e-5, 1e-1, 41), PAPER_EPS_Y])


@kernel
def _first_reach(rec, levels, out_t, out_x):
    n = rec.shape[0]
    starts = np.empty(n, np.int64)
    n_pieces = 0
    for i in range(1, n):
        if rec[i, R_JOIN] == 1.0:
            starts[n_pieces] = i - 1
            n_pieces += 1
    starts = starts[:n_pieces]
    t0s = np.empty(n_pieces)
    for p in range(n_pieces):
        t0s[p] = rec[starts[p], R_T]
    order = np.argsort(t0s, kind="mergesort")
    maxima = np.empty(n_pieces)
    running = -np.inf
    for q in range(n_pieces):
        i = starts[order[q]]
        h = rec[i + 1, R_T] - rec[i, R_T]
        c0, c1, c2, c3 = hermite(rec[i, R_VALUE], rec[i + 1, R_VALUE], rec[i, R_RATE],
                                 rec[i + 1, R_RATE], h)
        v, _ = cubic_max(c0, c1, c2, c3)
        running = max(running, v, rec[i + 1, R_VALUE])     # (the end's value exactly: a break's level)
        maxima[q] = running
    for k in range(levels.shape[0]):
        out_t[k] = np.nan
        out_x[k] = np.nan
        level = levels[k]
        q = np.searchsorted(maxima, level)          # first piece whose running max reaches it
        if q >= n_pieces:
            continue
        t_first = t0s[order[q]]
        best = np.inf
        # pieces that start together (the two tracks of a step where the peak switched)
        while q < n_pieces and t0s[order[q]] == t_first:
            i = starts[order[q]]
            h = rec[i + 1, R_T] - rec[i, R_T]
            c0, c1, c2, c3 = hermite(rec[i, R_VALUE], rec[i + 1, R_VALUE], rec[i, R_RATE],
                                     rec[i + 1, R_RATE], h)
            th = cubic_first_reach(c0, c1, c2, c3, level)
            if th < 0.0 and rec[i + 1, R_VALUE] >= level:    # the cubic's end a rounding below its value
                th = 1.0
            if th >= 0.0 and rec[i, R_T] + th * h < best:
                best = rec[i, R_T] + th * h
                x0, x1 = rec[i, R_X], rec[i + 1, R_X]
                # one peak moving: interpolate its place; two peaks (the global peak passed from
                # one to another between the nodes): the place of the one that reaches the level
                out_x[k] = x0 + th * (x1 - x0) if abs(x1 - x0) <= PEAK_JUMP else x1
            q += 1
        if best < np.inf:
            out_t[k] = best


#: a node is dropped from a record when the merged Hermite piece reproduces the dropped nodes
#: and the midpoints of the original pieces to THIN_TIME (relative) of their time, in value
#: over rate, and to THIN_VALUE (relative) of their value
THIN_TIME = 1e-7
THIN_VALUE = 1e-10
#: a merged piece spans at most this many original rows (keeps thinning linear in the rows)
THIN_SPAN = 64


@kernel
def _fits(rec, a, b):
    h = rec[b, R_T] - rec[a, R_T]
    if not h > 0.0:
        return False
    c0, c1, c2, c3 = hermite(rec[a, R_VALUE], rec[b, R_VALUE], rec[a, R_RATE], rec[b, R_RATE], h)
    for k in range(a, b):
        tk = rec[k, R_T]
        hk = rec[k + 1, R_T] - tk
        o0, o1, o2, o3 = hermite(rec[k, R_VALUE], rec[k + 1, R_VALUE], rec[k, R_RATE], rec[k + 1, R_RATE], hk)
        for frac in (0.0, 0.5):
            if k == a and frac == 0.0:
                continue
            t = tk + frac * hk
            orig = o0 + frac * (o1 + frac * (o2 + frac * o3))
            th = (t - rec[a, R_T]) / h
            merged = c0 + th * (c1 + th * (c2 + th * c3))
            rate = abs(rec[k, R_RATE]) if frac == 0.0 else 0.5 * (abs(rec[k, R_RATE]) + abs(rec[k + 1, R_RATE]))
            tol = max(THIN_TIME * abs(t) * rate, THIN_VALUE * abs(orig))
            if abs(merged - orig) > tol:
                return False
    return True


@kernel
def thin_record(rec):
    """Rows of a tension record to keep (bool mask): the first and last row of every chain, and
    as few in between as keep the piecewise Hermite within THIN_TIME / THIN_VALUE of itself."""
    n = rec.shape[0]
    keep = np.zeros(n, np.bool_)
    i = 0
    while i < n:
        end = i + 1
        while end < n and rec[end, R_JOIN] == 1.0:
            end += 1
        keep[i] = True
        a = i
        while a < end - 1:
            b = a + 1
            while b + 1 < end and b + 1 - a <= THIN_SPAN and _fits(rec, a, b + 1):
                b += 1
            keep[b] = True
            a = b
        i = end
    return keep


def _has_text(values) -> bool:
    """Whether values is or holds text ("8e-5" is not a yield strain: numpy would read it as one)."""
    try:
        kind = np.asarray(values).dtype.kind
    except (TypeError, ValueError):
        return False
    return kind in "US" or (kind == "O" and any(isinstance(v, (str, bytes)) for v in np.ravel(values)))


def yield_strains(eps_Y) -> np.ndarray:
    """eps_Y as an array of yield strains: numbers, finite and > 0, or ParameterError naming it."""
    try:
        levels = None if _has_text(eps_Y) else np.atleast_1d(np.asarray(eps_Y, dtype=float))
    except (TypeError, ValueError):
        levels = None
    if levels is None or levels.size == 0 or not np.all(np.isfinite(levels) & (levels > 0)):
        raise ParameterError(f"eps_Y must be one or more yield strains, finite numbers > 0 [1]; got {eps_Y!r}")
    return levels


def above_yield_strain_message(largest: float, yield_strain: float) -> str:
    """The one line refusing crack onset at eps_Y = ``largest`` above the ``yield_strain`` of ice
    that breaks (solve, Result, a study, the stored records say the same)."""
    return (f"eps_Y = {largest:g} is above yield_strain = {yield_strain:g}, where the ice breaks (fracture = "
            f"'break'): its tension never passes it, so crack onset is defined for eps_Y <= {yield_strain:g}")


def up_to_yield_strain(eps_Y, yield_strain: float) -> np.ndarray:
    """A default eps_Y axis for ice that breaks at ``yield_strain``: its values up to it, and it
    (crack onset there is the first break on its surface), sorted."""
    eps = np.asarray(eps_Y, dtype=float)
    return np.unique(np.r_[eps[eps <= yield_strain], yield_strain])


def above_yield_strain(p, levels) -> None:
    """ParameterError where crack onset is asked above the yield strain of ice that breaks
    (Parameters p, fracture = "break"): the plate breaks where its tension reaches
    p.yield_strain, so its tension never passes it and crack onset is defined up to it."""
    levels = np.asarray(levels, dtype=float)
    if p.fracture == "break" and levels.size and np.max(levels) > p.yield_strain:
        raise ParameterError(above_yield_strain_message(float(np.max(levels)), p.yield_strain))


def crack_onset(record, eps_Y):
    """First time and place at which the tension of a record reaches each yield strain.

    Parameters
    ----------
    record : (n, 5) array, a tension record (``Result.tension_record["upper"]`` or
        ``["lower"]``, or the rows of a case file's ``tension_record``); NaN rows are ignored.
    eps_Y : yield strain(s) [1], any order.

    Returns
    -------
    time : array like eps_Y [s]; NaN where the tension never reaches it in the run.
    x : array like eps_Y [m], x >= 0 for a centred impact (the field is mirrored at -x), signed off centre.

    Raises
    ------
    ParameterError
        A yield strain that is not a finite number > 0.

    Examples
    --------
    >>> from solver import Parameters, crack_onset, solve
    >>> record = solve(Parameters(Nmod=20), fields=()).tension_record["upper"]
    >>> time, x = crack_onset(record, [8e-5, 1.0])
    >>> bool(time[0] > 0.0), bool(x[0] >= 0.0), bool(time[1] != time[1])     # never reaches 1
    (True, True, True)
    """
    levels = yield_strains(eps_Y)
    rec = np.asarray(record, dtype=float)
    rec = rec[np.isfinite(rec[:, R_T])] if rec.size else np.empty((0, 5))
    out_t = np.full(levels.shape, np.nan)
    out_x = np.full(levels.shape, np.nan)
    if rec.shape[0] >= 2:
        _first_reach(np.ascontiguousarray(rec), levels.ravel(), out_t.reshape(-1), out_x.reshape(-1))
    if np.ndim(eps_Y) == 0:
        return float(out_t[0]), float(out_x[0])
    return out_t, out_x


def compile_crack_onset() -> None:
    """Compile (or load from numba's cache) the crack-onset kernels on a two-row tension record
    (solver.compile_kernels; its helper process, solver/compile/parallel_compile.py)."""
    rec = np.array([[0.0, 0.0, 1.0, 0.0, 0.0], [1.0, 1.0, 1.0, 0.0, 1.0]])
    crack_onset(rec[thin_record(rec)], [0.5])
