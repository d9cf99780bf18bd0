"""The study file's tables, each checked alone: [base], [[cases]], [reference], [output] and
[solver] (what a value must be, one line naming the table and key when it is not). How the
tables combine into cases is pipeline.study.definition's; whether those cases hold together is
pipeline.study.consistency's."""
from __future__ import annotations

import math
from dataclasses import dataclass

from solver import FIELDS, PARAMETER_INFO, SETTING_INFO, ParameterError, Settings, default_eps_Y
from solver.axes import log_axis
from solver.parameters import CHOICES, INTEGER_PARAMETERS
from solver.outputs import ONSET_RECORD, OUTPUT_NAMES
from solver.settings import NAMED_SETTINGS

from ..common.errors import StudyError
from .identity import SAMPLE

SECTIONS = {"description", "base", "grid", "cases", "design", "analysis", "search", "output", "solver", "plots",
            "reference",
            "accept_extreme_values"}


#: keys a [reference] may override: the same physical case, computed more accurately
REFERENCE_KEYS = {"Nmod", *SETTING_INFO}


OUTPUT_KEYS = {"times", "fields", "x_points", "eps_Y", "end", "records", "outputs"}


#: [output] end: "stage" integrates every case over its impact stage (diagnostics cover the
#: stage); "last_output" stops at the last output time (diagnostics cover 0..that time);
#: "separation" (a free body in every case) runs until the body leaves the ice, at the latest
#: to the last output time; "answered" (with [output] outputs that are crack onsets only) ends each
#: run when its crack onsets up to the study's largest eps_Y are final (solver.observe.asked): the
#: default where [output] outputs (listed, or "read") are crack onsets only and end is not given
ENDS = ("stage", "last_output", "separation", "answered")


#: the one-line answer to eps_Y given as a parameter (it was one before schema 5)
EPS_Y_AS_PARAMETER = ("eps_Y is not a solver input: crack onset is computed after the run for any "
                      "yield strain; give the values as [output] eps_Y = [...] or {min, max, count}")


DEFAULT_OUTPUT = {"times": {"unit": "t_sc", "step": 0.2, "stop": 4.6},
                  "fields": ["deflection", "strain", "layer_pressure"], "x_points": 241,
                  "end": "stage", "records": True}


#: the keys that take one of a few names: parameters (layer_law) and settings (integrator,
#: quadrature)
NAMES = {**CHOICES, **NAMED_SETTINGS}


def check_choice(where: str, key: str, value):
    """A key that takes one of a few names (NAMES)."""
    if not isinstance(value, str) or value not in NAMES[key]:
        raise StudyError(f"{where} must be one of {', '.join(NAMES[key])}, got {value!r}")
    return value


def check_number(where: str, value, integer=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise StudyError(f"{where} must be a number, got {value!r}")
    if integer and (not float(value).is_integer()):
        raise StudyError(f"{where} must be an integer, got {value!r}")
    return value


def check_value(where: str, key: str, value, integer: bool = False):
    """One value of a parameter or a setting, whatever table it is in: a name from NAMES, true
    or false (error_estimate), or a number (an integer where ``integer``)."""
    if key in NAMES:
        return check_choice(where, key, value)
    if key == "error_estimate":
        if not isinstance(value, bool):
            raise StudyError(f"{where} must be true or false, got {value!r}")
        return value
    return check_number(where, value, integer)


def check_parameters(where: str, table: dict, settings=False, reference=False) -> dict:
    """Validate a table of parameter keys (and solver settings where ``settings``)."""
    if not isinstance(table, dict):
        raise StudyError(f"{where} must be a table of parameters")
    for key, value in table.items():
        if reference and key == "reference":
            check_reference(f"{where}.reference", value)
            continue
        if reference and key == "group":
            if not isinstance(value, str):
                raise StudyError(f"{where}.group must be a string label")
            continue
        if key in PARAMETER_INFO or (settings and key in SETTING_INFO):
            check_value(f"{where}.{key}", key, value)
        elif key == "eps_Y":
            raise StudyError(f"{where}: {EPS_Y_AS_PARAMETER}")
        else:
            known = ", ".join([*PARAMETER_INFO, *(SETTING_INFO if settings else ())])
            raise StudyError(f"{where}: unknown parameter {key!r}; known: {known}")
    return dict(table)


def check_reference(where: str, table) -> dict:
    if not isinstance(table, dict) or not table:
        raise StudyError(f"{where} must be a non-empty table of Nmod and solver settings")
    for key in table:
        if key not in REFERENCE_KEYS:
            raise StudyError(f"{where}: {key!r} cannot be overridden in a reference (it must be the same "
                             f"physical case); allowed: {', '.join(sorted(REFERENCE_KEYS))}")
    return check_parameters(where, table, settings=True)


def check_grid(table, base: dict, solver: dict) -> dict:
    """[grid]: each key a parameter or setting with a non-empty list of distinct valid values,
    none also in [base] or [solver]; key -> its values, in file order."""
    if not isinstance(table, dict):
        raise StudyError("[grid] must be a table of lists")
    grid = {}
    for key, values in table.items():
        if key == "eps_Y":
            raise StudyError(f"[grid]: {EPS_Y_AS_PARAMETER}")
        if key not in PARAMETER_INFO and key not in SETTING_INFO:
            raise StudyError(f"[grid]: unknown parameter {key!r}; known: "
                             f"{', '.join([*PARAMETER_INFO, *SETTING_INFO])}")
        if not isinstance(values, list) or not values:
            raise StudyError(f"[grid] {key} must be a non-empty list of values")
        for v in values:
            check_value(f"[grid] {key} value", key, v, integer=key in (*INTEGER_PARAMETERS, "subintervals", "max_steps"))
        if len(set(values)) != len(values):
            raise StudyError(f"[grid] {key} has duplicate values")
        if key in base or key in solver:
            raise StudyError(f"{key} is both in [base] or [solver] and in [grid]")
        grid[key] = list(values)
    return grid


@dataclass(frozen=True)
class Output:
    """[output], checked: what every case stores and over what time (docs/user_guide.md).

    times: the output times, {"unit": "t_sc" or "s", "step", "stop"} or {"unit": "stage",
    "count"}; fields: the fields stored on the x grid, of solver.FIELDS; x_points: that grid's
    points; eps_Y: the yield strains crack onset is given for (sorted); end: how far a case runs
    ("stage", "last_output", "separation"); records: whether the tension records are stored
    (crack onset for any eps_Y afterwards); body: whether some case has a free body (its series
    are stored), set by the study from its cases, not by the table; outputs: the outputs each
    case computes (names of solver.outputs.OUTPUT_NAMES, sorted; None: every one, the default), the
    others stored as NaN (solver.observe.asked); answer_eps_Y: with end "answered", the largest
    eps_Y the study reads (of [output], [analysis] and [search]), set by the study; end_given:
    whether the table says how far a case runs (without it, a study whose outputs are crack onsets
    only ends each run at its answer: load_study_text); break_slots: the breaks stored per case
    along break_number, max_parts - 1 of the largest max_parts of a case that breaks (0: none
    breaks, the breaking outputs are not stored), set by the study from its cases; eps_Y_given:
    whether the table lists eps_Y (the default list stops at the smallest yield_strain of ice
    that breaks: load_study_text)."""

    times: dict
    fields: tuple
    x_points: int
    eps_Y: tuple
    end: str
    records: bool
    body: bool = False
    outputs: tuple | None = None
    answer_eps_Y: float | None = None
    end_given: bool = True
    break_slots: int = 0
    eps_Y_given: bool = True


def check_output(out) -> Output:
    if not isinstance(out, dict):
        raise StudyError("[output] must be a table")
    unknown = set(out) - OUTPUT_KEYS
    if unknown:
        raise StudyError(f"[output]: unknown key {sorted(unknown)[0]!r}; known: {', '.join(sorted(OUTPUT_KEYS))}")
    result = {**DEFAULT_OUTPUT, **out}
    spec = result["times"]
    if not isinstance(spec, dict) or spec.get("unit") not in ("t_sc", "s", "stage"):
        raise StudyError("[output] times must be {unit = \"t_sc\" or \"s\", step = ..., stop = ...} "
                         "or {unit = \"stage\", count = ...}")
    if spec["unit"] in ("t_sc", "s"):
        extra = set(spec) - {"unit", "step", "stop"}
        if extra or "step" not in spec or "stop" not in spec:
            raise StudyError(f"[output] times with unit = \"{spec['unit']}\" takes exactly step and stop")
        for k in ("step", "stop"):
            v = check_number(f"[output] times.{k}", spec[k])
            if not (math.isfinite(v) and v > 0):
                raise StudyError(f"[output] times.{k} must be finite and > 0, got {v!r}")
        if spec["stop"] / spec["step"] > 100_000:
            raise StudyError("[output] times: more than 100000 output times")
    else:
        extra = set(spec) - {"unit", "count"}
        if extra or "count" not in spec:
            raise StudyError("[output] times with unit = \"stage\" takes exactly count")
        c = check_number("[output] times.count", spec["count"], integer=True)
        if not 2 <= c <= 100_000:
            raise StudyError(f"[output] times.count must be between 2 and 100000, got {c!r}")
        result["times"] = spec = {**spec, "count": int(c)}
    fields = result["fields"]
    if not isinstance(fields, list) or not all(isinstance(f, str) for f in fields):
        raise StudyError("[output] fields must be a list of names")
    for f in fields:
        if f not in FIELDS:
            raise StudyError(f"[output] fields: unknown field {f!r}; known: {', '.join(FIELDS)}")
    if len(set(fields)) != len(fields):
        raise StudyError("[output] fields: a field is listed twice")
    xp = check_number("[output] x_points", result["x_points"], integer=True)
    if not 2 <= xp <= 100_001:
        raise StudyError(f"[output] x_points must be between 2 and 100001, got {xp!r}")
    result["x_points"] = int(xp)
    result["eps_Y"] = check_eps_Y(out.get("eps_Y"))
    if result["end"] not in ENDS:
        raise StudyError(f"[output] end must be one of {', '.join(repr(e) for e in ENDS)}, got {result['end']!r}")
    if not isinstance(result["records"], bool):
        raise StudyError(f"[output] records must be true or false, got {result['records']!r}")
    outputs = _check_outputs(out.get("outputs"), result["end"])
    return Output(times=result["times"], fields=tuple(fields), x_points=result["x_points"],
                  eps_Y=tuple(result["eps_Y"]), end=result["end"], records=result["records"], outputs=outputs,
                  end_given="end" in out, eps_Y_given="eps_Y" in out)


#: [output] outputs = "read": each case computes what the study reads (Study.outputs_read)
READ = "read"


def _check_outputs(asked, end):
    """[output] outputs: the names each case computes (sorted), "read" (what the study reads, known
    once its other sections are: load_study_text), or None (every one); an "answered" end needs
    them, and a crack onset among them."""
    if asked == READ:
        return READ
    if asked is None:
        if end == "answered":
            raise StudyError('[output] end = "answered" needs [output] outputs: the crack onsets the runs answer, '
                             'for example outputs = ["crack_onset_time", "crack_onset_time_lower"]')
        return None
    if not isinstance(asked, list) or not asked or not all(isinstance(o, str) for o in asked):
        raise StudyError(f'[output] outputs must be a non-empty list of output names, or "read", got {asked!r}')
    for name in asked:
        if name not in OUTPUT_NAMES:
            raise StudyError(f"[output] outputs: unknown output {name!r}; known: {', '.join(OUTPUT_NAMES)}")
    if len(set(asked)) != len(asked):
        raise StudyError("[output] outputs: an output is listed twice")
    check_answerable(asked, end)
    return tuple(sorted(asked))


def check_answerable(outputs, end) -> None:
    """An "answered" end needs a crack onset among the outputs."""
    if end == "answered" and not set(outputs) & set(ONSET_RECORD):
        raise StudyError('[output] end = "answered" with no crack onset among [output] outputs: nothing ends a '
                         'run early')


def check_eps_Y(spec) -> list:
    """[output] eps_Y: a list of yield strains, or a log range {min, max, count}; default: 10 a
    decade from 1e-5 to 1e-1 and the paper's 8e-5. Returned sorted, as floats."""
    if spec is None:
        return [float(v) for v in default_eps_Y()]
    if isinstance(spec, dict):
        if set(spec) != {"min", "max", "count"}:
            raise StudyError("[output] eps_Y as a log range takes exactly min, max and count")
        lo, hi = check_number("[output] eps_Y.min", spec["min"]), check_number("[output] eps_Y.max", spec["max"])
        count = check_number("[output] eps_Y.count", spec["count"], integer=True)
        if not (0 < lo < hi < 1 and math.isfinite(hi)):
            raise StudyError(f"[output] eps_Y needs 0 < min < max < 1, got min = {lo!r}, max = {hi!r}")
        if not 2 <= count <= 10_000:
            raise StudyError(f"[output] eps_Y.count must be between 2 and 10000, got {count!r}")
        return [float(v) for v in log_axis(lo, hi, int(count))]
    if not isinstance(spec, list) or not spec:
        raise StudyError("[output] eps_Y must be a non-empty list of yield strains or {min, max, count}")
    values = [check_number("[output] eps_Y value", v) for v in spec]
    if not all(0 < v < 1 and math.isfinite(v) for v in values):
        raise StudyError("[output] eps_Y values must lie in (0, 1)")
    if len(set(values)) != len(values):
        raise StudyError("[output] eps_Y has duplicate values")
    if len(values) > 10_000:
        raise StudyError("[output] eps_Y: more than 10000 values")
    return sorted(float(v) for v in values)


def check_solver(table) -> dict:
    if not isinstance(table, dict):
        raise StudyError("[solver] must be a table")
    for key in table:
        if key not in SETTING_INFO:
            raise StudyError(f"[solver]: unknown setting {key!r}; known: {', '.join(SETTING_INFO)}")
    try:
        Settings(**{k: (True if k == "error_estimate" and v == SAMPLE else v) for k, v in table.items()})
    except ParameterError as err:
        raise StudyError(f"[solver]: {err} (or \"{SAMPLE}\" for error_estimate)" if "error_estimate" in str(err)
                         else f"[solver]: {err}") from None
    return dict(table)
