"""Sampled designs: a study's ``[design]`` table -> the points it samples, one case each.

A full grid of six keys at ten values is 10^6 cases; a sampled design spreads a chosen number
of points over the box the keys' bounds span::

    [design]
    method = "sobol"          # sobol (scrambled, base-2 balanced) | latin_hypercube | halton | random
                              # | saltelli, morris: the designs of a sensitivity [analysis]
    samples = 64              # sobol, saltelli: a power of 2 (saltelli: base samples, x (keys + 2) cases)
    seed = 1
    [design.keys]
    V = { min = 1.0, max = 20.0, log = true }
    hi = { min = 0.3, max = 1.0 }

The points come from ``scipy.stats.qmc`` (or numpy's PCG64 for ``random``), seeded, in [0, 1)^d,
mapped onto each key's bounds (on a log scale where asked) and rounded to 12 significant digits,
so that a point, and so its case id, is the same on every CPU. ``study.nc`` holds them along a
``sample`` dimension, each key a coordinate along it. Sobol', Halton and random designs are
sequences: asking for more samples later keeps the first ones, and a run reuses every finished
case; a Latin hypercube is not (another size draws other points).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from solver import PARAMETER_INFO, Parameters
from solver.parameters import CHOICES, INTEGER_PARAMETERS, ParameterError

from ..common.errors import StudyError, check_table
from .analysis import MORRIS_LEVELS

METHODS = ("sobol", "latin_hypercube", "halton", "random", "saltelli", "morris")
#: designs made for an [analysis] (pipeline.study.analysis): cases per base sample, given d keys
ANALYSIS_DESIGNS = {"saltelli": lambda d: d + 2, "morris": lambda d: d + 1}
#: the keys a design may sample: continuous parameters (not Nmod or max_parts, not named choices)
SAMPLED = tuple(k for k in PARAMETER_INFO if k not in INTEGER_PARAMETERS and k not in CHOICES)
#: at most this many cases in a design (samples x (keys + 2) for saltelli): its cases are built and
#: checked one by one (about 85 us and 2 kB each, measured: 11 s and 300 MB at this size); a
#: larger design is several studies
MAX_CASES = 2**17
MAX_SAMPLES = MAX_CASES
DESIGN_KEYS = {"method", "samples", "seed", "keys"}


def _bound(where: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise StudyError(f"{where} must be a finite number, got {value!r}")
    return float(value)


def _check_bound(where: str, key: str, bound: float, base: dict) -> None:
    """A key's bound on the [base] case (with the other sampled keys at their midpoints: a free
    floe's sampled duration, say) is a valid parameter (nu < 0.5, hi <= L, ...): named here
    rather than at the first sample past it."""
    try:
        Parameters(**{**{k: v for k, v in base.items() if k in PARAMETER_INFO}, key: bound})
    except ParameterError as err:
        if key in str(err):                  # about this key, not a [base] that is wrong alone
            raise StudyError(f"{where} = {bound:g}: {err}") from None


@dataclass(frozen=True)
class Design:
    """[design], checked: ``method`` (of METHODS), ``samples`` (base samples: saltelli makes
    samples x (keys + 2) cases, morris samples x (keys + 1)), ``seed``, and ``keys``: each sampled
    key -> (min, max, log), in file order. Stored as JSON in study.nc's ``design`` attribute
    (dataclasses.asdict, these fields in this order)."""

    method: str
    samples: int
    seed: int
    keys: dict


def check_design(table, base: dict) -> Design:
    """Validate a [design] table; one line naming the key if bad."""
    check_table("[design]", table, DESIGN_KEYS)
    method = table.get("method", "sobol")
    if method not in METHODS:
        raise StudyError(f"[design] method must be one of {', '.join(METHODS)}, got {method!r}")
    samples, seed = table.get("samples"), table.get("seed", 0)
    if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= MAX_SAMPLES:
        raise StudyError(f"[design] samples must be an integer from 1 to {MAX_SAMPLES}, got {samples!r}")
    if method in ("sobol", "saltelli") and samples & (samples - 1):
        raise StudyError(f"[design] samples = {samples}: a Sobol' design is balanced only at a power of 2 "
                         f"(e.g. {1 << (samples.bit_length() - 1)} or {1 << samples.bit_length()})")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise StudyError(f"[design] seed must be a non-negative integer, got {seed!r}")
    if method in ANALYSIS_DESIGNS:
        try:
            import SALib  # noqa: F401
        except ImportError:
            raise StudyError(f"[design] method = \"{method}\" needs SALib: pip install "
                             f"'floe-impact[sensitivity]'") from None
    keys = table.get("keys")
    if not isinstance(keys, dict) or not keys:
        raise StudyError("[design] needs [design.keys]: each sampled key with its bounds, "
                         "e.g. V = { min = 1.0, max = 20.0, log = true }")
    checked = {}
    for key, spec in keys.items():
        where = f"[design.keys] {key}"
        if key not in SAMPLED:
            raise StudyError(f"{where}: not a parameter a design can sample; these can: {', '.join(SAMPLED)}")
        if key in base:
            raise StudyError(f"{key} is both in [base] and in [design.keys]")
        if not isinstance(spec, dict) or set(spec) - {"min", "max", "log"} or not {"min", "max"} <= set(spec):
            raise StudyError(f"{where} must be {{ min = ..., max = ... }}, optionally with log = true")
        lo, hi = _bound(f"{where}.min", spec["min"]), _bound(f"{where}.max", spec["max"])
        log = spec.get("log", False)
        if not isinstance(log, bool):
            raise StudyError(f"{where}.log must be true or false")
        if not lo < hi:
            raise StudyError(f"{where}: min = {lo:g} must be below max = {hi:g}")
        if log and lo <= 0:
            raise StudyError(f"{where}: a log scale needs min > 0, got min = {lo:g}")
        checked[key] = (lo, hi, log)
    for key, (lo, hi, _) in checked.items():        # each bound beside the other keys' midpoints
        others = {k: 0.5 * (a + b) for k, (a, b, _) in checked.items() if k != key}
        for end, bound in (("min", lo), ("max", hi)):
            _check_bound(f"[design.keys] {key}.{end}", key, bound, {**base, **others})
    cases = design_size(Design(method, samples, seed, checked))
    if cases > MAX_CASES:
        raise StudyError(f"[design] samples = {samples} of {method} over {len(checked)} keys is {cases} cases, more "
                         f"than the {MAX_CASES} a design holds: split it into several studies")
    return Design(method, samples, seed, checked)


def design_size(design: Design) -> int:
    """The cases a design makes (samples, or samples x (keys + 2) for saltelli, x (keys + 1) for
    morris), known before they are built."""
    method, samples = design.method, design.samples
    return samples * ANALYSIS_DESIGNS[method](len(design.keys)) if method in ANALYSIS_DESIGNS else samples


def unit_points(method: str, samples: int, dimensions: int, seed: int) -> np.ndarray:
    """(samples, dimensions) points in [0, 1), the first n the same for any larger n (but for a
    Latin hypercube). Saltelli's design (for Sobol' indices) has samples x (dimensions + 2)
    rows, Morris's samples trajectories of dimensions + 1 points (SALib's samplers)."""
    from scipy.stats import qmc
    if method in ANALYSIS_DESIGNS:
        problem = {"num_vars": dimensions, "names": [f"x{i}" for i in range(dimensions)],
                   "bounds": [[0.0, 1.0]] * dimensions}
        if method == "saltelli":
            from SALib.sample import sobol
            return sobol.sample(problem, samples, calc_second_order=False, scramble=True, seed=seed)
        from SALib.sample import morris
        return morris.sample(problem, samples, num_levels=MORRIS_LEVELS, seed=seed)
    if method == "sobol":
        return qmc.Sobol(dimensions, scramble=True, seed=seed).random_base2(int(math.log2(samples)))
    if method == "halton":
        return qmc.Halton(dimensions, scramble=True, seed=seed).random(samples)
    if method == "latin_hypercube":
        return qmc.LatinHypercube(dimensions, seed=seed).random(samples)
    return np.random.default_rng(seed).random((samples, dimensions))


def _round(values: np.ndarray) -> list:
    """Each value to 12 significant digits: the same double on every CPU (a libm's last bit of
    exp or log cannot move it), and so the same case id."""
    return [float(f"{v:.12g}") for v in values]


def design_points(design: Design) -> dict:
    """key -> the sampled values (lists of floats, one per sample)."""
    keys = design.keys
    u = unit_points(design.method, design.samples, len(keys), design.seed)
    out = {}
    for j, (key, (lo, hi, log)) in enumerate(keys.items()):
        if log:
            values = np.exp(np.log(lo) + u[:, j] * (np.log(hi) - np.log(lo)))
        else:
            values = lo + u[:, j] * (hi - lo)
        out[key] = _round(np.clip(values, lo, hi))
    return out


def design_cases(design: Design) -> list:
    """The design as a [[cases]] list: one table of overrides a sample."""
    points = design_points(design)
    n = len(next(iter(points.values())))         # samples, or samples x (keys + 2) for saltelli
    return [{key: values[i] for key, values in points.items()} for i in range(n)]
