"""Axes the code generates (yield strains, output times, positions), the same on every CPU.

A generated value is rounded to 12 significant digits: the double nearest to its short decimal
form, so that ``ds.sel(eps_Y=1e-5)`` or ``ds.sel(t=0.6)`` finds it. Rounding is needed because
transcendental functions differ in their last bit between CPUs (numpy's AVX-512 ``power`` gives
``np.logspace(-5, -1, 41)[0] == 9.999999999999999e-06``), and even exact arithmetic lands off the
decimal (``np.linspace(0, 1, 6)[3] == 0.6000000000000001``). The generated values are a few ulps
from their decimals, so the rounding lands on the decimal itself (tests/test_axes.py).
"""
import math

import numpy as np

#: significant digits a generated axis keeps
DIGITS = 12


def round_significant(values, digits: int = DIGITS) -> np.ndarray:
    """Each value rounded to ``digits`` significant digits, through its decimal text (exact:
    the nearest double to the rounded decimal); 0, inf and NaN are kept."""
    flat = np.asarray(values, dtype=float)
    return np.array([float(f"{v:.{digits}g}") for v in flat.ravel()]).reshape(flat.shape)


def log_axis(lowest: float, highest: float, count: int) -> np.ndarray:
    """``count`` values evenly spaced in log10 from ``lowest`` to ``highest`` (both kept
    exactly), rounded to 12 significant digits: whole decades are exact (1e-5, not
    9.999999999999999e-06)."""
    lo, hi = math.log10(lowest), math.log10(highest)
    exponents = [lo + (hi - lo) * k / (count - 1) for k in range(count)]
    out = round_significant([10.0 ** e for e in exponents])
    out[0], out[-1] = float(lowest), float(highest)
    return out


def linear_axis(first: float, last: float, count: int) -> np.ndarray:
    """``count`` evenly spaced values from ``first`` to ``last``, rounded to 12 significant
    digits (0.6, not 0.6000000000000001)."""
    return round_significant(np.linspace(first, last, count))
