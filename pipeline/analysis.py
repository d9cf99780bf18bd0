"""Global sensitivity of a design's outputs to its keys: Sobol' indices or Morris elementary
effects, computed with SALib after the combine (``floe-impact[sensitivity]``; the computation is
pipeline.sensitivity, this module the [analysis] table and its rules).

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

**Outputs that are not finite for some samples.** An event time is NaN when the event did not
happen within the run (never cracked, never bottomed out); ``max_force`` is inf where the layer
bottomed out (the model's force is unbounded there). The estimators need a number for every
sample, so such values are *censored*: an event time that did not happen enters as the time the
run reached (the event comes, if at all, later than that), an infinite force as the largest
finite force of the design (a lower bound). The censored fraction of each output is stored
beside its indices (``censored``); where it is large the indices describe the censored
quantity. Samples that failed numerically (``nonfinite``, ``step_limit``, ...) have no output
at all: the analysis is refused for them, with their number, rather than computed on a hole.
"""
from __future__ import annotations

from solver.outputs import CRACK_ONSET_TIMES

from .errors import StudyError, check_table

METHODS = {"sobol": "saltelli", "morris": "morris"}       # analysis -> the design it needs
ANALYSIS_KEYS = {"method", "outputs", "eps_Y", "conf_level", "resamples", "seed"}
#: outputs that take a yield strain
CRACK_OUTPUTS = CRACK_ONSET_TIMES
#: event times: NaN means the event did not happen within the run
EVENT_TIMES = (*CRACK_OUTPUTS, "bottoming_time", "stop_time", "separation_time",
               "max_strain_time", "max_strain_lower_time", "max_force_time")


def outputs_known() -> list:
    """The per-case numbers an analysis can take: the diagnostics and crack onset."""
    from solver import DIAGNOSTIC_INFO
    return sorted({*DIAGNOSTIC_INFO, *CRACK_OUTPUTS} - {"error_estimate_time", "error_estimate_modes",
                                                         "error_estimate_quadrature"})


def check_analysis(table, design: dict, output: dict) -> dict:
    """Validate an [analysis] table against the study's design and output; one line if bad."""
    check_table("[analysis]", table, ANALYSIS_KEYS)
    method = table.get("method")
    if method not in METHODS:
        raise StudyError(f"[analysis] method must be one of {', '.join(METHODS)}, got {method!r}")
    if not design:
        raise StudyError(f"[analysis] needs a [design] with method = \"{METHODS[method]}\"")
    if design["method"] != METHODS[method]:
        raise StudyError(f"[analysis] method = \"{method}\" needs [design] method = \"{METHODS[method]}\", "
                         f"got \"{design['method']}\"")
    if len(design["keys"]) < 2:
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
        if not output.get("records", True) and not all(any(abs(e / v - 1) < 1e-12 for v in output["eps_Y"])
                                                       for e in eps):
            raise StudyError("[analysis] eps_Y must be among [output] eps_Y when records = false")
    smallest = MIN_SAMPLES[method]
    if design["samples"] < smallest:
        raise StudyError(f"[analysis] method = \"{method}\" needs [design] samples >= {smallest}, got "
                         f"{design['samples']}: fewer give indices and intervals that mean nothing (Sobol' "
                         f"indices outside [0, 1] with intervals of width 0)")
    conf = table.get("conf_level", 0.95)
    if isinstance(conf, bool) or not isinstance(conf, float) or not 0.5 <= conf < 1:
        raise StudyError(f"[analysis] conf_level must be in [0.5, 1), got {conf!r}")
    resamples = table.get("resamples", 1000)
    if isinstance(resamples, bool) or not isinstance(resamples, int) or not 10 <= resamples <= 100_000:
        raise StudyError(f"[analysis] resamples must be an integer from 10 to 100000, got {resamples!r}")
    seed = table.get("seed", design["seed"])
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise StudyError(f"[analysis] seed must be a non-negative integer, got {seed!r}")
    return {"method": method, "outputs": list(outputs), "eps_Y": [float(e) for e in eps],
            "conf_level": conf, "resamples": resamples, "seed": seed}


def _repeated(values: list):
    return next(v for i, v in enumerate(values) if v in values[:i])


#: the fewest base samples (Sobol') or trajectories (Morris) an analysis takes: its bootstrap
#: resamples them, and with fewer the intervals are not estimates of anything
MIN_SAMPLES = {"sobol": 16, "morris": 4}
#: levels of the Morris grid (SALib's default)
MORRIS_LEVELS = 4
