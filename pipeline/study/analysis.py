"""Global sensitivity of a design's outputs to its keys: Sobol' indices or Morris elementary
effects computed with SALib (``floe-impact[sensitivity]``), or Sobol' indices from a sparse
polynomial-chaos surrogate (``floe-impact[surrogate]``), after the combine (the computation is
pipeline.analyse.sensitivity, this module the [analysis] table and its rules).

A study asks for them with an ``[analysis]`` table beside its ``[design]``::

    [design]
    method = "saltelli"       # Sobol' indices need Saltelli's design: samples x (keys + 2) cases
    samples = 512             # a power of 2
    [design.keys] ...
    [analysis]
    method = "sobol"          # or "morris" (with [design] method = "morris": samples x (keys + 1) cases)
    outputs = ["max_strain", "crack_onset_time", "bottoming_time", "max_force"]
    eps_Y = [8e-5]            # the yield strains of crack_onset_time / crack_onset_time_lower

Sobol' indices: first order S1 and total ST with their bootstrap confidence intervals
(``conf_level``, default 0.95; ``resamples``, default 1000), SALib's estimators (Saltelli 2010,
Jansen 1999). Morris: mu* (the mean absolute elementary effect) with its interval, and sigma.

**Polynomial chaos** (``method = "pce"``, on a space-filling design: ``sobol``,
``latin_hypercube`` or ``halton``, from a few hundred runs where Saltelli's estimators need tens
of thousands)::

    [design]
    method = "sobol"
    samples = 256
    [analysis]
    method = "pce"
    outputs = ["crack_onset_time", "max_strain"]
    q2_min = 0.9              # below this cross-validated predictivity an output's indices are refused
    degree = 12               # the highest total degree tried (default: 12, or what the runs can fit)
    resamples = 100           # bootstrap refits of the expansion (default 100 for pce)
    log = ["max_strain"]      # outputs whose logarithm is expanded (positive outputs)

Each output's expansion, its indices with intervals that cover sampling and truncation, its Q2,
and its terms are pipeline.analyse.surrogate's; an output whose Q2 is below ``q2_min`` gets no indices
(NaN, ``refused`` = 1, and the reason in the file and on the terminal), the others are kept.

**Outputs that are not finite for some samples.** An event time is NaN when the event did not
happen within the run (never cracked, never bottomed out); ``max_force`` is inf where the layer
bottomed out (the model's force is unbounded there). The estimators need a number for every
sample, so such values are *censored* (by every method): an event time that did not happen enters as the time the
run reached (the event comes, if at all, later than that), an infinite force as the largest
finite force of the design (a lower bound). The censored fraction of each output is stored
beside its indices (``censored``); where it is large the indices describe the censored
quantity; for the expansion a censored output has a kink where the censoring starts, which
its cross-validated Q2 and the truncation part of its intervals measure. Samples that failed numerically (``nonfinite``, ``step_limit``, ...) have no output
at all: the analysis is refused for them, with their number, rather than computed on a hole.
"""
from __future__ import annotations

import importlib.util
import math
from dataclasses import dataclass

from solver import DIAGNOSTIC_INFO
from solver.outputs import CRACK_ONSET_TIMES

from ..common.errors import StudyError, check_table

#: what a pce analysis can ask for, and its defaults (pipeline.analyse.surrogate works within
#: them): the highest total degree tried; the largest candidate basis LARS searches
#: (C(d + degree, d) terms: 6188 at degree 12 over 5 inputs); the cross-validation's folds;
#: the cross-validated Q2 below which indices are refused
MAX_DEGREE = 12
MAX_TERMS = 20_000
FOLDS = 5
Q2_MIN = 0.9

#: analysis -> the designs it takes
METHODS = {"sobol": ("saltelli",), "morris": ("morris",), "pce": ("sobol", "latin_hypercube", "halton")}
ANALYSIS_KEYS = {"method", "outputs", "eps_Y", "conf_level", "resamples", "seed", "log", "q2_min", "degree"}
#: the keys only the expansion takes
PCE_KEYS = ("q2_min", "degree")
#: outputs that take a yield strain
CRACK_OUTPUTS = CRACK_ONSET_TIMES
#: event times: NaN means the event did not happen within the run
EVENT_TIMES = (*CRACK_OUTPUTS, "bottoming_time", "stop_time", "separation_time",
               "max_strain_time", "max_strain_lower_time", "max_force_time")


def outputs_known() -> list:
    """The per-case numbers an analysis can take: the diagnostics and crack onset."""
    return sorted({*DIAGNOSTIC_INFO, *CRACK_OUTPUTS} - {"error_estimate_time", "error_estimate_modes",
                                                         "error_estimate_quadrature"})


@dataclass(frozen=True)
class Analysis:
    """[analysis], checked: ``method`` (of METHODS), the ``outputs`` analysed, the yield strains
    ``eps_Y`` of the crack-onset outputs among them, the intervals' ``conf_level``, the bootstrap's
    ``resamples`` and ``seed``, the outputs whose logarithm is analysed (``log``); for "pce" its
    ``q2_min`` and highest ``degree`` (None otherwise)."""

    method: str
    outputs: tuple
    eps_Y: tuple = ()
    conf_level: float = 0.95
    resamples: int = 1000
    seed: int = 0
    log: tuple = ()
    q2_min: float | None = None
    degree: int | None = None

    def stored(self) -> dict:
        """What sensitivity.nc's ``analysis`` attribute holds (JSON): the pce keys only for pce."""
        keys = ["method", "outputs", "eps_Y", "conf_level", "resamples", "seed", "log"]
        keys += ["q2_min", "degree"] if self.method == "pce" else []
        return {key: list(v) if isinstance(v := getattr(self, key), tuple) else v for key in keys}


def check_analysis(table, design, output) -> Analysis:
    """Validate an [analysis] table against the study's design and output; one line if bad."""
    check_table("[analysis]", table, ANALYSIS_KEYS)
    method = table.get("method")
    if method not in METHODS:
        raise StudyError(f"[analysis] method must be one of {', '.join(METHODS)}, got {method!r}")
    designs = " or ".join(f'"{m}"' for m in METHODS[method])
    if not design:
        raise StudyError(f"[analysis] needs a [design] (method = {designs} for method = \"{method}\"): it analyses "
                         f"a design's samples, not a grid, a list of cases or a search")
    if design.method not in METHODS[method]:
        raise StudyError(f"[analysis] method = \"{method}\" needs [design] method = {designs}, "
                         f"got \"{design.method}\"")
    for key in PCE_KEYS:
        if key in table and method != "pce":
            raise StudyError(f"[analysis] {key} is a setting of method = \"pce\", not of \"{method}\"")
    if method == "pce":
        if importlib.util.find_spec("openturns") is None:
            raise StudyError("[analysis] method = \"pce\" needs OpenTURNS: pip install 'floe-impact[surrogate]'")
    if len(design.keys) < 2:
        raise StudyError("[analysis] needs at least two sampled keys in [design.keys]")
    outputs = table.get("outputs")
    known = outputs_known()
    if not isinstance(outputs, list) or not outputs or not all(isinstance(o, str) for o in outputs):
        raise StudyError(f"[analysis] outputs must be a non-empty list of names from {', '.join(known)}")
    for name in outputs:
        if name not in known:
            raise StudyError(f"[analysis] outputs: unknown output {name!r}; known: {', '.join(known)}")
    if len(set(outputs)) != len(outputs):
        raise StudyError(f"[analysis] outputs: {_repeated(outputs)!r} is listed twice")
    eps = table.get("eps_Y", [8e-5])
    if (not isinstance(eps, list) or not eps
            or not all(isinstance(e, (int, float)) and not isinstance(e, bool) and 0 < e < 1 for e in eps)):
        raise StudyError(f"[analysis] eps_Y must be a list of yield strains in (0, 1), got {eps!r}")
    if len({float(e) for e in eps}) != len(eps):
        raise StudyError(f"[analysis] eps_Y: {_repeated([float(e) for e in eps])!r} is listed twice")
    if "eps_Y" in table and not any(o in CRACK_OUTPUTS for o in outputs):
        raise StudyError(f"[analysis] eps_Y is the yield strain of {' and '.join(CRACK_OUTPUTS)}, and no "
                         f"output asked for takes it: remove it, or add one of those outputs")
    if any(o in CRACK_OUTPUTS for o in outputs):
        if not output.records and not all(any(abs(e / v - 1) < 1e-12 for v in output.eps_Y) for e in eps):
            raise StudyError("[analysis] eps_Y must be among [output] eps_Y when records = false")
    logs = table.get("log", [])
    if not isinstance(logs, list) or not all(isinstance(o, str) for o in logs):
        raise StudyError(f"[analysis] log must be a list of outputs whose logarithm is analysed, got {logs!r}")
    for name in logs:
        if name not in outputs:
            raise StudyError(f"[analysis] log: {name!r} is not among [analysis] outputs")
    if len(set(logs)) != len(logs):
        raise StudyError(f"[analysis] log: {_repeated(logs)!r} is listed twice")
    smallest = MIN_SAMPLES[method] if method != "pce" else pce_min_samples(len(design.keys))
    if design.samples < smallest:
        raise StudyError(f"[analysis] method = \"{method}\" needs [design] samples >= {smallest}, got "
                         f"{design.samples}: fewer give indices and intervals that mean nothing (Sobol' "
                         f"indices outside [0, 1] with intervals of width 0)")
    conf = table.get("conf_level", 0.95)
    if isinstance(conf, bool) or not isinstance(conf, float) or not 0.5 <= conf < 1:
        raise StudyError(f"[analysis] conf_level must be in [0.5, 1), got {conf!r}")
    resamples = table.get("resamples", 100 if method == "pce" else 1000)
    if isinstance(resamples, bool) or not isinstance(resamples, int) or not 10 <= resamples <= 100_000:
        raise StudyError(f"[analysis] resamples must be an integer from 10 to 100000, got {resamples!r}")
    if method == "pce" and not 20 <= resamples <= 2000:
        raise StudyError(f"[analysis] resamples (the expansion's bootstrap refits) must be from 20 to 2000 with "
                         f"method = \"pce\", got {resamples}")
    seed = table.get("seed", design.seed)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise StudyError(f"[analysis] seed must be a non-negative integer, got {seed!r}")
    pce = _check_pce(table, design) if method == "pce" else {}
    return Analysis(method=method, outputs=tuple(outputs), eps_Y=tuple(float(e) for e in eps), conf_level=conf,
                    resamples=resamples, seed=seed, log=tuple(logs), **pce)


def pce_min_samples(keys: int) -> int:
    """The fewest runs an expansion over ``keys`` inputs takes: each fold of the cross-validation
    trains on (FOLDS - 1) / FOLDS of them, and needs more than the keys + 1 terms of degree 1."""
    return max(16, -(-(keys + 2) * FOLDS // (FOLDS - 1)))


def _training_runs(samples: int) -> int:
    return samples * (FOLDS - 1) // FOLDS


def _check_pce(table, design) -> dict:
    """q2_min and the highest degree tried: a degree the runs cannot fit is refused."""
    q2_min = table.get("q2_min", Q2_MIN)
    if isinstance(q2_min, bool) or not isinstance(q2_min, (int, float)) or not 0 < q2_min < 1:
        raise StudyError(f"[analysis] q2_min must be a number in (0, 1), got {q2_min!r}")
    keys, runs = len(design.keys), _training_runs(design.samples)
    fittable = max((p for p in range(1, MAX_DEGREE + 1) if p < runs and (p == 1 or basis_size(keys, p) <= MAX_TERMS)),
                   default=1)
    degree = table.get("degree", fittable)
    if isinstance(degree, bool) or not isinstance(degree, int) or not 1 <= degree <= MAX_DEGREE:
        raise StudyError(f"[analysis] degree must be an integer from 1 to {MAX_DEGREE}, got {degree!r}")
    if degree >= runs:
        raise StudyError(f"[analysis] degree = {degree} cannot be fitted from {design.samples} runs: each fold of the "
                         f"cross-validation trains on {runs}, and a polynomial of degree {degree} in one key needs "
                         f"{degree + 1} of them; raise [design] samples or lower degree (at most {fittable})")
    if degree > 1 and basis_size(keys, degree) > MAX_TERMS:
        raise StudyError(f"[analysis] degree = {degree} over {keys} keys is a candidate basis of "
                         f"{basis_size(keys, degree)} terms, more than the {MAX_TERMS} the selection searches: "
                         f"lower degree (at most {fittable})")
    return {"q2_min": float(q2_min), "degree": degree}


def _repeated(values: list):
    return next(v for i, v in enumerate(values) if v in values[:i])


#: the fewest base samples (Sobol') or trajectories (Morris) an analysis takes: its bootstrap
#: resamples them, and with fewer the intervals are not estimates of anything
MIN_SAMPLES = {"sobol": 16, "morris": 4}       # pce: pce_min_samples(keys)
#: levels of the Morris grid (SALib's default)
MORRIS_LEVELS = 4


def basis_size(inputs: int, degree: int) -> int:
    """The terms of the full basis of total degree <= degree over the inputs."""
    return math.comb(inputs + degree, inputs)
