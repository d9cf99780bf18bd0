"""Study files: read, validate and expand into cases (study file -> cases).

A study file ``studies/<name>.toml`` (read with :mod:`tomllib`)::

    description = "..."
    [base]        # overrides of the reference case; keys of solver.PARAMETER_INFO
    [grid]        # full factorial: key = [values]; every key becomes a dimension
                  # (parameters, or solver settings such as tolerance or integrator)
    [[cases]]     # or: an explicit list of cases (parameters and solver settings;
                  # reference = {...} overrides the study's [reference] for that case;
                  # group = "..." labels it, e.g. the sweep it belongs to)
    [reference]   # optional: Nmod and solver settings of a converged run; every case is also
                  # run with these overrides and stored with its error against that run
    [output]      # times = {unit = "t_sc", step, stop} | {unit = "s", step, stop} | {unit = "stage", count}
                  # fields = [...], x_points = 241
                  # eps_Y = [...] | {min, max, count} (log range): the yield strains at which
                  # crack onset is reported (post-processing: not part of a case's identity)
    [solver]      # keys of solver.SETTING_INFO
    [plots]       # kinds = ["diagnostics", "paper_fig2"]

Everything is validated here, before any case runs or anything is written; a problem raises
:class:`StudyError` with one line naming it.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from solver import (FIELDS, PARAMETER_INFO, SETTING_INFO, ParameterError, Parameters, Settings,
                    default_eps_Y)
from solver.parameters import CHOICES, NAMED_SETTINGS, check_combination
from solver.revision import RESULTS_REVISION
from solver.axes import linear_axis, log_axis, round_significant

from .errors import StudyError

#: bump when the layout of a batch file changes: cases stored under an older one are recomputed
#: (9, 2026-11-25: the parameters edges and duration, the diagnostic gravity_time_ratio; 10: the
#: impact zone's maxima and contact_extent, the setting impact_zone_margin)
SCHEMA_VERSION = 10

SECTIONS = {"description", "base", "grid", "cases", "design", "analysis", "search", "output", "solver", "plots",
            "reference",
            "accept_extreme_values"}
#: keys a [reference] may override: the same physical case, computed more accurately
REFERENCE_KEYS = {"Nmod", *SETTING_INFO}
OUTPUT_KEYS = {"times", "fields", "x_points", "eps_Y", "end", "records"}
#: grid keys whose study.nc dimension has another name (the key is also a result's name)
DIM_NAMES = {"error_estimate": "error_estimate_on"}
#: [output] end: "stage" integrates every case over its impact stage (diagnostics cover the
#: stage); "last_output" stops at the last output time (diagnostics cover 0..that time);
#: "separation" (a free body in every case) runs until the body leaves the ice, at the latest
#: to the last output time
ENDS = ("stage", "last_output", "separation")
PLOT_KINDS = ("diagnostics", "crack_onset", "paper_fig2", "work_precision", "extremes", "drop", "design",
              "sensitivity")
#: the files each plot kind writes
PLOT_FILES = {"diagnostics": ("diagnostics.png",), "crack_onset": ("crack_onset.png",),
              "paper_fig2": ("paper_fig2.png",), "work_precision": ("work_precision.png", "work_precision.md"),
              "extremes": ("extremes.md",), "drop": ("drop.png",), "design": ("design.png",),
              "sensitivity": ("sensitivity.png",)}
#: the one-line answer to eps_Y given as a parameter (it was one before schema 5)
EPS_Y_AS_PARAMETER = ("eps_Y is not a solver input: crack onset is computed after the run for any "
                      "yield strain; give the values as [output] eps_Y = [...] or {min, max, count}")
DEFAULT_OUTPUT = {"times": {"unit": "t_sc", "step": 0.2, "stop": 4.6},
                  "fields": ["deflection", "strain", "layer_pressure"], "x_points": 241,
                  "end": "stage", "records": True}


@dataclass(frozen=True)
class Case:
    """One run of the solver: its parameters, settings and output request."""

    case_id: str
    index: tuple                    # position in the grid (or (i,) in a case list)
    parameters: Parameters
    settings: Settings
    times_spec: dict                # the [output] times table
    fields: tuple
    x_points: int
    end: str = "stage"              # [output] end
    body: bool = False              # store the body's position and speed (a study with a free body)

    @property
    def t_end(self) -> float:
        """End of the run [s]: the impact stage, or the last output time inside it; for a free
        body (finite body_mass) "last_output" is the last output time itself, and so is
        "separation" (the run may end earlier, at separation). The stage bounds the paper's
        body, which pushes on at V until the layer bottoms out; a free body has no such end."""
        stage = self.parameters.stage_duration
        last = float(self.times_seconds()[-1])
        if self.end == "separation" or (self.end == "last_output" and self.parameters.free_body):
            return last
        if self.end == "last_output":
            return min(stage, last)
        return stage

    def value(self, key):
        """A parameter or a solver setting of the case, by its study-file key."""
        if key in PARAMETER_INFO:
            return getattr(self.parameters, key)
        return getattr(self.settings, key)

    def requested_times(self) -> np.ndarray:
        """Output times in units of the study's time coordinate (t_sc or stage fraction)."""
        return coordinate_times(self.times_spec)

    def times_seconds(self) -> np.ndarray:
        """Requested times in seconds for this case (some may lie past its stage)."""
        t = coordinate_times(self.times_spec)
        p = self.parameters
        unit = self.times_spec["unit"]
        scale = p.time_scale if unit == "t_sc" else 1.0 if unit == "s" else p.stage_duration
        return t * scale

    def to_dict(self) -> dict:
        """Plain data for a worker (no numpy, no classes)."""
        return {"case_id": self.case_id, "index": list(self.index),
                "parameters": self.parameters.as_dict(), "settings": self.settings.as_dict(),
                "times_spec": self.times_spec, "fields": list(self.fields), "x_points": self.x_points,
                "end": self.end, "body": self.body}

    @staticmethod
    def from_dict(d: dict) -> "Case":
        return Case(d["case_id"], tuple(d["index"]), Parameters(**d["parameters"]),
                    Settings(**d["settings"]), d["times_spec"], tuple(d["fields"]), d["x_points"],
                    d.get("end", "stage"), d.get("body", False))


@dataclass
class Study:
    """A validated study. A [grid] is not expanded up front: its size is known at once
    (``n_cases``), its case ids come from one fast pass (``case_ids``), and a Case is built
    only when asked for (``case(i)``); 10^5 cases cost well under a second."""

    name: str
    path: Path
    text: str
    description: str
    base: dict
    grid: dict                      # key -> list of values, in file order
    case_list: list                 # explicit [[cases]] (overrides), or []
    output: dict
    solver: dict
    plots: list
    reference: dict = field(default_factory=dict)
    design: dict = field(default_factory=dict)          # a checked [design] (pipeline.design), or {}
    analysis: dict = field(default_factory=dict)        # a checked [analysis] (pipeline.analysis), or {}
    search: dict = field(default_factory=dict)          # a checked [search] (pipeline.search), or {}
    references: dict = field(default_factory=dict)     # position in cases -> its reference Case
    _listed: list = field(default_factory=list, repr=False)   # [[cases]] (or referenced) Cases

    @property
    def n_cases(self) -> int:
        return math.prod(self.shape)

    @property
    def dims(self) -> list:
        """study.nc's case dimensions: the grid keys (error_estimate, also the name of a result,
        becomes error_estimate_on), ["sample"] for a [design], or ["case"]."""
        if self.grid:
            return [DIM_NAMES.get(k, k) for k in self.grid]
        return ["sample"] if self.design else ["case"]

    @property
    def shape(self) -> tuple:
        return tuple(len(v) for v in self.grid.values()) if self.grid else (len(self.case_list),)

    def case(self, i: int) -> Case:
        """The i-th case in grid (C) order, built and validated on demand."""
        if self._listed:
            return self._listed[i]
        idx = tuple(int(j) for j in np.unravel_index(i, self.shape))
        values = {**self.base, **self.solver,
                  **{k: v[j] for (k, v), j in zip(self.grid.items(), idx)}}
        label = _grid_label(self.grid, idx)
        try:
            values = _resolve_sample(values)
        except ParameterError as err:
            raise StudyError(f"case {label}: {err}") from None
        return _make_case(idx, values, self.output, label)

    @cached_property
    def cases(self) -> list:
        """Every case as a Case (builds them all: use case_ids and case(i) for large grids)."""
        return [self.case(i) for i in range(self.n_cases)]

    @cached_property
    def case_ids(self) -> list:
        """The case ids in grid order (one fast pass for a grid; equal to case(i).case_id)."""
        if self._listed:
            return [c.case_id for c in self._listed]
        return _grid_case_ids(self)

    @cached_property
    def case_id_set(self) -> frozenset:
        return frozenset(self.case_ids)

    def is_reference(self, case: Case) -> bool:
        """True for a reference run that is not itself one of the study's cases."""
        return case.case_id not in self.case_id_set

    @cached_property
    def run_ids(self) -> list:
        """Every distinct run's id: the study's cases, then the reference runs not among them."""
        seen = dict.fromkeys(self.case_ids)
        for ref in self.references.values():
            seen.setdefault(ref.case_id, None)
        return list(seen)

    @cached_property
    def _extra_runs(self) -> dict:
        return {ref.case_id: ref for ref in self.references.values() if ref.case_id not in self.case_id_set}

    @cached_property
    def first_position(self) -> dict:
        """case id -> its first position in grid order (reference runs not among the cases:
        absent)."""
        first = {}
        for i, cid in enumerate(self.case_ids):
            first.setdefault(cid, i)
        return first

    @cached_property
    def varying_keys(self) -> list:
        """The keys whose values differ between cases: the grid's, or those a [[cases]] list
        varies (parameters and solver settings)."""
        if self.grid:
            return list(self.grid)
        return [k for k in [*PARAMETER_INFO, *SETTING_INFO] if len({c.value(k) for c in self._listed}) > 1]

    def run(self, case_id: str) -> Case:
        """The run with this id (a case or a reference run)."""
        if case_id in self._extra_runs:
            return self._extra_runs[case_id]
        return self.case(self.first_position[case_id])

    def all_cases(self) -> list:
        """Every distinct run as a Case (small studies; large ones go through run_ids)."""
        return [self.run(cid) for cid in self.run_ids]


def _grid_label(grid: dict, idx: tuple) -> str:
    return ", ".join(f"{k}={v[j]}" for (k, v), j in zip(grid.items(), idx)) or "base"


def coordinate_times(spec: dict) -> np.ndarray:
    """The output times in the unit of the request, rounded to 12 significant digits (the same
    on every CPU, and 0.6 rather than 0.6000000000000001: solver.axes)."""
    if spec["unit"] in ("t_sc", "s"):
        n = int(math.floor(spec["stop"] / spec["step"] + 1e-9))
        return round_significant(np.round(np.arange(n + 1) * spec["step"], 12))
    return linear_axis(0.0, 1.0, spec["count"])


def x_fractions(x_points: int) -> np.ndarray:
    """The positions of the fields as fractions of L, -1..1 (the study's x coordinate where L
    varies between cases)."""
    return linear_axis(-1.0, 1.0, x_points)


def x_positions(x_points: int, L: float) -> np.ndarray:
    """The positions of the fields [m], -L..L, rounded to 12 significant digits (0.5, not
    0.49999999999999994: solver.axes): where the fields are evaluated, and the study's x
    coordinate where all cases share L."""
    return round_significant(x_fractions(x_points) * L)


#: the keys that take one of a few names: parameters (layer_law) and settings (integrator,
#: quadrature)
NAMES = {**CHOICES, **NAMED_SETTINGS}


def _choice(where: str, key: str, value):
    """A key that takes one of a few names (NAMES)."""
    if not isinstance(value, str) or value not in NAMES[key]:
        raise StudyError(f"{where} must be one of {', '.join(NAMES[key])}, got {value!r}")
    return value


def _number(where: str, value, integer=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise StudyError(f"{where} must be a number, got {value!r}")
    if integer and (not float(value).is_integer()):
        raise StudyError(f"{where} must be an integer, got {value!r}")
    return value


def _check_parameters(where: str, table: dict, settings=False, reference=False) -> dict:
    """Validate a table of parameter keys (and solver settings where ``settings``)."""
    if not isinstance(table, dict):
        raise StudyError(f"{where} must be a table of parameters")
    for key, value in table.items():
        if reference and key == "reference":
            _check_reference(f"{where}.reference", value)
            continue
        if reference and key == "group":
            if not isinstance(value, str):
                raise StudyError(f"{where}.group must be a string label")
            continue
        if key in CHOICES:
            _choice(f"{where}.{key}", key, value)
        elif key in PARAMETER_INFO:
            _number(f"{where}.{key}", value)
        elif settings and key in SETTING_INFO:
            if key in NAMED_SETTINGS:
                _choice(f"{where}.{key}", key, value)
            elif key == "error_estimate":
                if not isinstance(value, bool):
                    raise StudyError(f"{where}.error_estimate must be true or false, got {value!r}")
            else:
                _number(f"{where}.{key}", value)
        elif key == "eps_Y":
            raise StudyError(f"{where}: {EPS_Y_AS_PARAMETER}")
        else:
            known = ", ".join([*PARAMETER_INFO, *(SETTING_INFO if settings else ())])
            raise StudyError(f"{where}: unknown parameter {key!r}; known: {known}")
    return dict(table)


def _check_reference(where: str, table) -> dict:
    if not isinstance(table, dict) or not table:
        raise StudyError(f"{where} must be a non-empty table of Nmod and solver settings")
    for key in table:
        if key not in REFERENCE_KEYS:
            raise StudyError(f"{where}: {key!r} cannot be overridden in a reference (it must be the same "
                             f"physical case); allowed: {', '.join(sorted(REFERENCE_KEYS))}")
    return _check_parameters(where, table, settings=True)


def _check_output(out) -> dict:
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
            v = _number(f"[output] times.{k}", spec[k])
            if not (math.isfinite(v) and v > 0):
                raise StudyError(f"[output] times.{k} must be finite and > 0, got {v!r}")
        if spec["stop"] / spec["step"] > 100_000:
            raise StudyError("[output] times: more than 100000 output times")
    else:
        extra = set(spec) - {"unit", "count"}
        if extra or "count" not in spec:
            raise StudyError("[output] times with unit = \"stage\" takes exactly count")
        c = _number("[output] times.count", spec["count"], integer=True)
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
    xp = _number("[output] x_points", result["x_points"], integer=True)
    if not 2 <= xp <= 100_001:
        raise StudyError(f"[output] x_points must be between 2 and 100001, got {xp!r}")
    result["x_points"] = int(xp)
    result["eps_Y"] = _check_eps_Y(out.get("eps_Y"))
    if result["end"] not in ENDS:
        raise StudyError(f"[output] end must be one of {', '.join(repr(e) for e in ENDS)}, got {result['end']!r}")
    if not isinstance(result["records"], bool):
        raise StudyError(f"[output] records must be true or false, got {result['records']!r}")
    return result


def _check_eps_Y(spec) -> list:
    """[output] eps_Y: a list of yield strains, or a log range {min, max, count}; default: 10 a
    decade from 1e-5 to 1e-1 and the paper's 8e-5. Returned sorted, as floats."""
    if spec is None:
        return [float(v) for v in default_eps_Y()]
    if isinstance(spec, dict):
        if set(spec) != {"min", "max", "count"}:
            raise StudyError("[output] eps_Y as a log range takes exactly min, max and count")
        lo, hi = _number("[output] eps_Y.min", spec["min"]), _number("[output] eps_Y.max", spec["max"])
        count = _number("[output] eps_Y.count", spec["count"], integer=True)
        if not (0 < lo < hi < 1 and math.isfinite(hi)):
            raise StudyError(f"[output] eps_Y needs 0 < min < max < 1, got min = {lo!r}, max = {hi!r}")
        if not 2 <= count <= 10_000:
            raise StudyError(f"[output] eps_Y.count must be between 2 and 10000, got {count!r}")
        return [float(v) for v in log_axis(lo, hi, int(count))]
    if not isinstance(spec, list) or not spec:
        raise StudyError("[output] eps_Y must be a non-empty list of yield strains or {min, max, count}")
    values = [_number("[output] eps_Y value", v) for v in spec]
    if not all(0 < v < 1 and math.isfinite(v) for v in values):
        raise StudyError("[output] eps_Y values must lie in (0, 1)")
    if len(set(values)) != len(values):
        raise StudyError("[output] eps_Y has duplicate values")
    if len(values) > 10_000:
        raise StudyError("[output] eps_Y: more than 10000 values")
    return sorted(float(v) for v in values)


def _check_solver(table) -> dict:
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


#: [solver] error_estimate = "sample": the companion run of the error estimate (0.79x the
#: integration, measured on benchmarks/scale_1000.toml) on about one case in SAMPLE_EVERY,
#: chosen by a hash of the case's parameters (spread over the grid, the same in every study)
SAMPLE = "sample"
SAMPLE_EVERY = 10


def id_parameters(parameters: dict) -> dict:
    """The parameters a case id hashes: those beyond the paper's model are left out at the
    value that is the paper's (H = inf), so ids from before they existed still hold."""
    from solver.parameters import PAPER_DEFAULTS
    return {k: v for k, v in parameters.items() if not (k in PAPER_DEFAULTS and v == PAPER_DEFAULTS[k])}


def _parameter_text(parameters: dict) -> str:
    """'"name":value,...' in sorted order: the parameters part of a case id's JSON."""
    return ",".join(f'"{n}":' + json.dumps(parameters[n]) for n in sorted(parameters))


def _sampled(parameter_text: str) -> bool:
    return int(hashlib.sha256(parameter_text.encode()).hexdigest()[:8], 16) % SAMPLE_EVERY == 0


def _resolve_sample(values: dict) -> dict:
    """values with error_estimate = "sample" replaced by whether this case is in the sample."""
    if values.get("error_estimate") != SAMPLE:
        return values
    params = id_parameters(Parameters(**{k: v for k, v in values.items() if k in PARAMETER_INFO}).as_dict())
    return {**values, "error_estimate": _sampled(_parameter_text(params))}


def _toml_value(value, where: str) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(v, f'{where}.{k}')}" for k, v in value.items()) + " }"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v, where) for v in value) + "]"
    if hasattr(value, "item") and getattr(value, "ndim", None) == 0:      # a numpy scalar
        return _toml_value(value.item(), where)
    if hasattr(value, "tolist"):                                          # a numpy array
        return _toml_value(value.tolist(), where)
    raise StudyError(f"{where}: cannot write a {type(value).__name__} into a study file")


def study_text(study: dict) -> str:
    """The TOML text of a study given as a dict with the study file's sections, e.g.
    ``{"base": {"Nmod": 20}, "grid": {"V": [2.0, 5.0]}, "output": {"fields": []}}``
    ([[cases]] is a list of dicts under ``"cases"``)."""
    if not isinstance(study, dict):
        raise StudyError(f"a study is a dict of its sections, got {type(study).__name__}")
    lines = []
    for key, value in study.items():                         # top-level keys before any table
        if not isinstance(value, dict) and not (key == "cases" and isinstance(value, list)):
            lines.append(f"{key} = {_toml_value(value, key)}")
    for key, value in study.items():
        if isinstance(value, dict):
            lines += ["", f"[{key}]"] + [f"{k} = {_toml_value(v, f'[{key}] {k}')}" for k, v in value.items()]
        elif key == "cases" and isinstance(value, list):
            for i, case in enumerate(value):
                if not isinstance(case, dict):
                    raise StudyError(f"[[cases]] #{i + 1} must be a dict of parameters")
                lines += ["", "[[cases]]"] + [f"{k} = {_toml_value(v, f'[[cases]] #{i + 1} {k}')}"
                                               for k, v in case.items()]
    return "\n".join(lines) + "\n"


def find_study(name_or_path: str, studies_dir: Path = Path("studies")) -> Path:
    """studies/<name>.toml from a name, or the path itself."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or "/" in name_or_path:
        if not path.is_file():
            raise StudyError(f"no study file {name_or_path!r}")
        return path
    path = studies_dir / f"{name_or_path}.toml"
    if not path.is_file():
        known = sorted(p.stem for p in studies_dir.glob("*.toml"))
        raise StudyError(f"unknown study {name_or_path!r}: no {path}; known: {', '.join(known) or 'none'}")
    return path


def load_study(path: Path, max_cases: int | None = None) -> Study:
    """Read and validate a study file; expand its cases. ``max_cases``: refuse a design of
    more cases before building them (the command line's --yes limit)."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as err:
        raise StudyError(f"cannot read {path}: {err.strerror}") from None
    except UnicodeDecodeError as err:
        raise StudyError(f"{path}: not UTF-8 text (byte {err.start}); a study file is TOML") from None
    return load_study_text(text, path.stem, path, max_cases)


#: the copy of its study a run keeps in the results directory (status and show read it)
STUDY_COPY = "study.toml"
_COPY_HEADER = "# floe-impact keeps this copy of the study it ran here: name = "


def keep_study_copy(study: Study, out_dir: Path) -> None:
    """Write out_dir/study.toml (a header line naming the study, then its text byte for byte)
    unless it holds that already; atomically, never through a symbolic link."""
    import os
    import time
    target = Path(out_dir) / STUDY_COPY
    data = (f"{_COPY_HEADER}{study.name!r}, from {study.path}\n" + study.text).encode()
    try:
        if not target.is_symlink() and target.is_file() and target.read_bytes() == data:
            return
    except OSError:
        pass
    tmp = target.with_name(f".{STUDY_COPY}.tmp-{os.getpid()}-{time.monotonic_ns()}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
    try:
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def load_study_copy(out_dir: Path) -> Study:
    """The study a results directory was run with, from its copy (see keep_study_copy)."""
    path = Path(out_dir) / STUDY_COPY
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as err:
        raise StudyError(f"cannot read {path}: {err.strerror}") from None
    except UnicodeDecodeError:
        raise StudyError(f"{path}: not UTF-8 text") from None
    name = Path(out_dir).name
    if text.startswith(_COPY_HEADER):
        header, _, text = text.partition("\n")
        quoted = header[len(_COPY_HEADER):].split(", from ", 1)[0]
        if len(quoted) >= 2 and quoted[0] == quoted[-1] and quoted[0] in "'\"":
            name = quoted[1:-1]
    return load_study_text(text, name, path)


def load_study_text(text: str, name: str, path: Path | None = None, max_cases: int | None = None) -> Study:
    """Validate a study from its text (what a worker receives); expand its cases."""
    path = Path(path) if path is not None else Path(f"{name}.toml")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise StudyError(f"{path}: TOML syntax error: {err}") from None
    unknown = set(data) - SECTIONS
    if unknown:
        if "eps_Y" in unknown:
            raise StudyError(f"{path}: {EPS_Y_AS_PARAMETER}")
        raise StudyError(f"{path}: unknown section or key {sorted(unknown)[0]!r}; known: {', '.join(sorted(SECTIONS))}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise StudyError(f"{path}: description must be a string")
    base = _check_parameters("[base]", data.get("base", {}))
    grid_raw = data.get("grid", {})
    if not isinstance(grid_raw, dict):
        raise StudyError("[grid] must be a table of lists")
    grid = {}
    for key, values in grid_raw.items():
        if key == "eps_Y":
            raise StudyError(f"[grid]: {EPS_Y_AS_PARAMETER}")
        if key not in PARAMETER_INFO and key not in SETTING_INFO:
            raise StudyError(f"[grid]: unknown parameter {key!r}; known: "
                             f"{', '.join([*PARAMETER_INFO, *SETTING_INFO])}")
        if not isinstance(values, list) or not values:
            raise StudyError(f"[grid] {key} must be a non-empty list of values")
        for v in values:
            if key in CHOICES:
                _choice(f"[grid] {key} value", key, v)
            elif key in NAMED_SETTINGS:
                _choice(f"[grid] {key}", key, v)
            elif key == "error_estimate":
                if not isinstance(v, bool):
                    raise StudyError(f"[grid] error_estimate values must be true or false, got {v!r}")
            else:
                _number(f"[grid] {key} value", v, integer=(key in ("Nmod", "subintervals", "max_steps")))
        if len(set(values)) != len(values):
            raise StudyError(f"[grid] {key} has duplicate values")
        if key in base or key in data.get("solver", {}):
            raise StudyError(f"{key} is both in [base] or [solver] and in [grid]")
        grid[key] = list(values)
    case_list = data.get("cases", [])
    if not isinstance(case_list, list):
        raise StudyError("[[cases]] must be an array of tables")
    case_list = [_check_parameters(f"[[cases]] #{i + 1}", c, settings=True, reference=True)
                 for i, c in enumerate(case_list)]
    if grid and case_list:
        raise StudyError("a study has either [grid] or [[cases]], not both")
    design, analysis = {}, {}
    if "design" in data and (grid or case_list):
        raise StudyError("a study has one of [grid], [[cases]] and [design], not two")
    if grid_raw == {} and "grid" in data:
        raise StudyError("[grid] is empty")
    if "cases" in data and not case_list:
        raise StudyError("[[cases]] is empty")
    if not grid and not case_list:                 # [base] alone: one case, the base itself
        case_list = [{}]
    if case_list:
        seen = set()
        for i, c in enumerate(case_list):
            key = json.dumps({**base, **{k: v for k, v in c.items() if k != "group"}}, sort_keys=True)
            if key in seen:
                raise StudyError(f"[[cases]] #{i + 1} repeats an earlier case")
            seen.add(key)
    output = _check_output(data.get("output", {}))
    if "design" in data:                           # its samples may repeat a point (Morris's grid)
        from .design import check_design, design_cases, design_size
        design = check_design(data["design"], base)
        n = design_size(design)
        if max_cases is not None and n > max_cases:
            raise StudyError(f"the study has {n} cases (more than {max_cases}); add --yes to run it")
        case_list = design_cases(design)
    if "analysis" in data:
        from .analysis import check_analysis
        analysis = check_analysis(data["analysis"], design, output)
    search = {}
    if "search" in data:
        from .search import check_search
        if case_list and not design and case_list != [{}]:
            raise StudyError("[search] runs over a [grid], a [design] or [base] alone, not [[cases]]")
        search = check_search(data["search"], {*base, *grid, *(design.get("keys", {}))})
        if analysis:
            raise StudyError("[analysis] is computed over a [design]'s samples, not a [search]'s runs: a study has "
                             "one of them")
        if "reference" in data:
            raise StudyError("[reference] is not run by a [search] (its runs are the bisection's): remove it")
        from .search import check_bracket, search_points
        extreme = data.get("accept_extreme_values", False)
        check_bracket(search, {**base, **_check_solver(data.get("solver", {}))}, search_points(grid, case_list),
                      extreme is True)
        # the study's own cases are the points searched, at the bracket's low end (the key may
        # have no default: a free floe's duration)
        base = {**base, search["key"]: search["bracket"][0]}
    solver = _check_solver(data.get("solver", {}))
    reference = _check_reference("[reference]", data["reference"]) if "reference" in data else {}
    plots_table = data.get("plots", {})
    if not isinstance(plots_table, dict) or set(plots_table) - {"kinds"}:
        raise StudyError("[plots] takes one key: kinds = [...]")
    plots = plots_table.get("kinds", ["diagnostics", "crack_onset"])
    if not isinstance(plots, list) or any(k not in PLOT_KINDS for k in plots):
        raise StudyError(f"[plots] kinds must be a list from {', '.join(PLOT_KINDS)}")
    if design and "kinds" not in plots_table:
        plots = ["design"] + (["sensitivity"] if analysis else [])
    if search and "kinds" not in plots_table:
        plots = []                                 # the search draws search.png itself
    study = Study(name=name, path=path, text=text, description=description, base=base,
                  grid=grid, case_list=case_list, output=output, solver=solver, plots=plots,
                  reference=reference, design=design, analysis=analysis, search=search)
    extreme = data.get("accept_extreme_values", False)
    if not isinstance(extreme, bool):
        raise StudyError(f"{path}: accept_extreme_values must be true or false")
    masses = _body_masses(study)
    study.output["body"] = any(math.isfinite(m) for m in masses if isinstance(m, (int, float)))
    if output["end"] == "separation" and not all(isinstance(m, (int, float)) and math.isfinite(m) for m in masses):
        raise StudyError('[output] end = "separation" needs a free body in every case: give body_mass a '
                         'finite value in [base], or finite values in [grid] or in every [[cases]] entry')
    if not extreme:
        _check_ranges(study)
    expand(study)
    return study


#: the settings each integrator reads; the others do not change its result
RELEVANT_SETTINGS = {
    "etd34": ("integrator", "tolerance", "subintervals", "fixed_step", "max_steps", "error_estimate",
              "bottoming_gap", "impact_zone_margin"),
    "rk4": ("integrator", "subintervals", "rk4_step_fraction", "max_steps", "error_estimate", "bottoming_gap",
            "impact_zone_margin"),
    "dop853": ("integrator", "tolerance", "subintervals", "max_steps", "error_estimate", "bottoming_gap",
               "impact_zone_margin"),
}


def _payload_text(parameters: dict, settings: dict, output: dict) -> str:
    """The canonical JSON a case id hashes (sorted keys, no spaces)."""
    payload = {"schema": SCHEMA_VERSION, "parameters": parameters, "settings": settings,
               "output": {"times": output["times"], "fields": sorted(output["fields"]),
                          "x_points": output["x_points"], "end": output["end"]}}
    return json.dumps(payload, sort_keys=True, separators=(",", ":"))


def _used_settings(settings: Settings) -> dict:
    """The settings the run reads, and the revision of its rule's results (solver.revision). The
    quadrature enters only when it is not the paper's, so that the ids of the cases run before it
    was a setting stay what they were; with it the revision of its results. The paper rule's
    revision enters once it is above 0 (its ids carried none before)."""
    used = {k: v for k, v in settings.as_dict().items() if k in RELEVANT_SETTINGS[settings.integrator]}
    if settings.quadrature != "paper":
        used["quadrature"] = settings.quadrature
        used["quadrature_density"] = settings.quadrature_density
        used["quadrature_revision"] = RESULTS_REVISION[settings.quadrature]
    elif RESULTS_REVISION["paper"] > 0:
        used["results_revision"] = RESULTS_REVISION["paper"]
    return used


def case_id(parameters: Parameters, settings: Settings, output: dict) -> str:
    """Stable id: hash of the normalised parameters, the settings the integrator reads, the
    output request (not eps_Y, not records) and the schema version (two runs with the same id
    give the same data)."""
    text = _payload_text(id_parameters(parameters.as_dict()), _used_settings(settings), output)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _make_case(index, values: dict, output: dict, label: str) -> Case:
    """A validated Case from merged parameter and setting values."""
    params = {k: v for k, v in values.items() if k in PARAMETER_INFO}
    settings = {k: v for k, v in values.items() if k in SETTING_INFO}
    try:
        p = Parameters(**params)
        s = Settings(**settings)
        check_combination(p, s)
    except ParameterError as err:
        raise StudyError(f"{label if label.startswith('[') else 'case ' + label}: {err}") from None
    return Case(case_id(p, s, output), tuple(index), p, s, output["times"], tuple(output["fields"]),
                output["x_points"], output["end"], output.get("body", False))


def _grid_case_ids(study: Study) -> list:
    """case_id of every grid case in one pass: the canonical JSON is put together from
    per-value fragments (each value validated and normalised once), then hashed."""
    keys = list(study.grid)
    pkeys = [k for k in keys if k in PARAMETER_INFO]
    skeys = [k for k in keys if k not in PARAMETER_INFO]
    base_p = {k: v for k, v in study.base.items()}
    normal = Parameters(**base_p).as_dict()
    # parameter fragments: '"name":value' in sorted order; grid keys vary; a value an id leaves
    # out (id_parameters: H = inf) has no fragment (None)
    frag = {k: [('"%s":' % k + json.dumps(Parameters(**{**base_p, k: v}).as_dict()[k]))
                if id_parameters({k: Parameters(**{**base_p, k: v}).as_dict()[k]}) else None
                for v in study.grid[k]] for k in pkeys}
    kept = id_parameters(normal)
    names = sorted(n for n in normal if n in kept or n in frag)
    consts = {n: f'"{n}":' + json.dumps(normal[n]) for n in names if n not in frag}
    output_text = _payload_text({}, {}, study.output)
    head, tail = output_text.split('"parameters":{}', 1)
    settings_split = tail.split('"settings":{}', 1)
    settings_cache = {}
    positions = {k: keys.index(k) for k in keys}
    ids = []
    sha = hashlib.sha256
    sample = study.solver.get("error_estimate") == SAMPLE
    for idx in itertools.product(*(range(len(v)) for v in study.grid.values())):
        parts = [consts[n] if n in consts else frag[n][idx[positions[n]]] for n in names]
        ptext = ",".join(p for p in parts if p is not None)
        skey = tuple(idx[positions[k]] for k in skeys) + ((_sampled(ptext),) if sample else ())
        stext = settings_cache.get(skey)
        if stext is None:
            values = {**study.solver, **{k: study.grid[k][j] for k, j in zip(skeys, skey)}}
            if sample:
                values["error_estimate"] = skey[-1]
            s = Settings(**values)
            stext = settings_cache[skey] = json.dumps(_used_settings(s), sort_keys=True, separators=(",", ":"))
        text = head + '"parameters":{' + ptext + "}" + settings_split[0] + '"settings":' + stext + settings_split[1]
        ids.append(sha(text.encode()).hexdigest()[:16])
    return ids


def _body_masses(study: Study) -> list:
    """Every body_mass value the study's cases take (inf: the paper's body)."""
    base = study.base.get("body_mass", math.inf)
    if "body_mass" in study.grid:
        return list(study.grid["body_mass"])
    if study.case_list:
        return [entry.get("body_mass", base) for entry in study.case_list]
    return [base]


def _check_ranges(study: Study) -> None:
    """Every parameter value within solver.parameters.PHYSICAL_RANGES (each grid value once;
    hi <= L at the grid's extremes; each [[cases]] entry), before anything is computed from
    them."""
    from solver.parameters import outside_physical_range
    defaults = Parameters().as_dict()
    base = {**defaults, **study.base}
    tables = [("[base]", study.base)]
    for key, values in study.grid.items():
        if key in PARAMETER_INFO:
            tables += [(f"[grid] {key}", {key: v}) for v in values if isinstance(v, (int, float))]
    if study.grid:
        extremes = {k: (max(study.grid[k]) if k == "hi" else min(study.grid[k])) if k in study.grid else base[k]
                    for k in ("hi", "L")}
        tables.append(("[grid]", extremes))
    for i, entry in enumerate(study.case_list):
        where = (f"[design] sample {i} ({', '.join(f'{k}={v:g}' for k, v in entry.items())}, within [design.keys])"
                 if study.design else f"[[cases]] #{i + 1}")
        tables.append((where, {**base, **{k: v for k, v in entry.items() if k in PARAMETER_INFO}}))
    for where, table in tables:
        # what is not a finite positive number is expand()'s to refuse, with its own message
        valid = {k: v for k, v in table.items() if k in PARAMETER_INFO and isinstance(v, (int, float))
                 and not isinstance(v, bool) and math.isfinite(v) and (v > 0 or k == "nu")}
        reason = outside_physical_range(valid)
        if reason:
            raise StudyError(f"{where}: {reason}; add accept_extreme_values = true at the top of the study "
                             f"file to run it anyway")


def _check_grid_values(study: Study) -> None:
    """Each grid value, validated once against the base and solver tables (every check on a
    parameter or setting involves that key alone, so this covers every case)."""
    params = {k: v for k, v in {**study.base, **study.solver}.items() if k in PARAMETER_INFO}
    settings = {k: (True if k == "error_estimate" and v == SAMPLE else v)
                for k, v in {**study.base, **study.solver}.items() if k in SETTING_INFO}
    try:
        Parameters(**params)
    except ParameterError as err:
        blamed = str(err).split()[0]          # a message starts with the key it is about
        if blamed in study.base and blamed not in study.grid and not (blamed == "x0" and "L" in study.grid):
            raise StudyError(f"[base] {err}") from None
    for key, values in study.grid.items():
        for v in values:
            try:
                if key in PARAMETER_INFO:
                    Parameters(**{**params, key: v})
                else:
                    Settings(**{**settings, key: v})
            except ParameterError as err:
                raise StudyError(f"[grid] {key} = {v!r}: {err}") from None
    _check_grid_combinations(study, params)
    _check_setting_combinations(study, params, settings)


#: the keys that are checked together (Parameters._check_scales: the time scale, the impact
#: stage against the layer's response time, flat_width against L + |x0|, x0 against L)
COUPLED_KEYS = ("hi", "L", "E", "nu", "rho_i", "rho_w", "g", "H", "R", "V", "body_p", "flat_width",
                "deadrise", "x0", "K", "he")
#: at most this many combinations of the grid's coupled keys are checked one by one; beyond,
#: every value of the keys the checks are not monotone in (NOT_MONOTONE: the stage against
#: body_p, and against |x0|) with the lowest and highest of each other key
MAX_COMBINATIONS = 20_000
NOT_MONOTONE = ("body_p", "x0")
#: the keys solver.parameters.check_combination reads
COMBINED_KEYS = ("edges", "quadrature", "integrator", "tau", "layer_tau", "duration")


def _check_setting_combinations(study: Study, params: dict, settings: dict) -> None:
    """Every combination of the grid's values of the keys solver.parameters.check_combination
    reads (the integrator and the quadrature against the ice, the layer, the edges and L) goes
    together, so that no case is refused only when a worker runs it."""
    keys = [k for k in study.grid if k in COMBINED_KEYS]
    choices = [study.grid[k] for k in keys]
    if math.prod(len(c) for c in choices) > MAX_COMBINATIONS:
        choices = [c if k in CHOICES or k in NAMED_SETTINGS else sorted({min(c), max(c)})
                   for k, c in zip(keys, choices)]
    for combo in itertools.product(*choices):
        values = dict(zip(keys, combo))
        try:
            check_combination(Parameters(**{**params, **{k: v for k, v in values.items() if k in PARAMETER_INFO}}),
                              Settings(**{**settings, **{k: v for k, v in values.items() if k in SETTING_INFO}}))
        except ParameterError as err:
            named = [f"[{table}] {k} = {v!r}" for table, given in (("base", study.base), ("solver", study.solver))
                     for k, v in given.items() if k in COMBINED_KEYS]
            where = ", ".join([*named, *(f"[grid] {k} = {v!r}" for k, v in values.items())]) or "[base]"
            raise StudyError(f"{where}: {err}") from None


def _check_grid_combinations(study: Study, params: dict) -> None:
    """Every combination of the grid's values of COUPLED_KEYS gives valid Parameters, so that
    no case is refused only when a worker builds it."""
    keys = [k for k in study.grid if k in COUPLED_KEYS]
    if len(keys) < 2:
        return
    choices = [study.grid[k] for k in keys]
    if math.prod(len(c) for c in choices) > MAX_COMBINATIONS:
        choices = [c if k in NOT_MONOTONE else sorted({min(c), max(c)}) for k, c in zip(keys, choices)]
    for combo in itertools.product(*choices):
        values = dict(zip(keys, combo))
        try:
            Parameters(**{**params, **values})
        except ParameterError as err:
            where = ", ".join(f"{k} = {v!r}" for k, v in values.items())
            raise StudyError(f"[grid] {where}: {err}") from None


def _stage_in_t_sc(study: Study) -> np.ndarray:
    """stage / t_sc of every case, as an array that broadcasts to the grid's shape."""
    from solver.parameters import TIME_SCALE_KEYS, time_scale_of
    if study._listed:
        return np.array([c.parameters.stage_duration / c.parameters.time_scale for c in study._listed])
    default = Parameters(**{k: v for k, v in study.base.items()}).as_dict()
    keys = list(study.grid)

    def along(names):                      # the grid's shape, 1 but along the grid keys among names
        return [len(study.grid[k]) if k in names else 1 for k in keys]
    arrays = {}
    for name in (*TIME_SCALE_KEYS, "V"):
        if name in study.grid:
            arrays[name] = np.asarray(study.grid[name], dtype=float).reshape(along([name]))
        else:
            arrays[name] = default[name]
    # the body's mean height over the plate, b_mean (stage = b_mean / V), over the grid's shape keys
    shape_keys = [k for k in keys if k in ("L", "R", "body_p", "flat_width", "deadrise", "x0")]
    profile = np.empty(along(shape_keys))
    for idx in np.ndindex(profile.shape):
        values = {k: study.grid[k][i] for k, i in zip(keys, idx) if k in shape_keys}
        profile[idx] = Parameters(**{**study.base, **values}).profile_mean()
    return profile / arrays["V"] / time_scale_of(**{k: arrays[k] for k in TIME_SCALE_KEYS})


def _longest_stage_in_t_sc(study: Study) -> float:
    return float(np.max(_stage_in_t_sc(study)))


#: a free floe's run longer than this fraction of its gravity-wave time sqrt(L/g) is said to be
#: outside the short-time model (phi = 0 on the open water holds for ratios well below 1)
GRAVITY_TIME_WARNING = 0.5
#: the keys validity_warnings reads
VALIDITY_KEYS = ("edges", "L", "g", "duration", "impact_zone_margin")


def validity_warnings(study: Study) -> list:
    """What the study asks that the model answers only in part: a walled plate whose impact
    zone its margin leaves empty (its impact_zone_* are NaN), a free floe run past the
    short-time approximation (docs/model.md, "a free floe"). One line each."""
    defaults = {**Parameters().as_dict(), **Settings().as_dict()}
    fixed = {k: v for k, v in {**defaults, **study.base, **study.solver}.items() if k in VALIDITY_KEYS}
    if study._listed:
        combos = [{**{k: c.value(k) for k in VALIDITY_KEYS if k in PARAMETER_INFO},
                   "impact_zone_margin": c.settings.impact_zone_margin} for c in study._listed]
    else:
        keys = [k for k in study.grid if k in VALIDITY_KEYS]
        choices = [study.grid[k] if k == "edges" else sorted({min(study.grid[k]), max(study.grid[k])}) for k in keys]
        combos = [{**fixed, **dict(zip(keys, combo))} for combo in itertools.product(*choices)]
    lines = []
    empty = [c for c in combos if c["edges"] == "walls" and c["impact_zone_margin"] >= c["L"]]
    if empty:
        c = empty[0]
        lines.append(f"warning: impact_zone_margin = {c['impact_zone_margin']:g} m leaves no impact zone on a walled "
                     f"plate of L = {c['L']:g} m (the zone stops the margin short of each wall): impact_zone_* are "
                     f"NaN there; set [solver] impact_zone_margin below L")
    ratios = [c["duration"] / math.sqrt(c["L"] / c["g"]) for c in combos if c["edges"] == "free"]
    if ratios and max(ratios) > GRAVITY_TIME_WARNING:
        lines.append(f"warning: a free floe's duration is {max(ratios):.3g} times its gravity-wave time sqrt(L/g): phi = 0 on the open water, the model's short-time approximation, holds only well "
                     f"below 1 (docs/model.md, \"a free floe\"); gravity_time_ratio in study.nc says it per case")
    largest = max([Settings(**{k: v for k, v in {**study.base, **study.solver}.items() if k == "subintervals"}).subintervals,
                   *study.grid.get("subintervals", []), *(c.get("subintervals", 0) for c in study.case_list)])
    if largest > SLOW_SUBINTERVALS:
        lines.append(f"warning: subintervals = {largest}: every step sums the quadrature over them, about "
                     f"{SECONDS_PER_SUBINTERVAL * largest:.0f} s a case at 8 modes (measured: "
                     f"{SECONDS_PER_SUBINTERVAL:.0e} s per subinterval), more with more modes; the default is 250")
    return lines


#: subintervals above which a run is said to be slow, and the cost of one (etd34 at 8 modes over
#: the reference case's stage, either rule: 1.9-2.2 s at 25 000, linear from 2 500)
SLOW_SUBINTERVALS = 20_000
SECONDS_PER_SUBINTERVAL = 8e-5


def cases_past_their_stage(study: Study) -> int:
    """How many cases have output times past their impact stage (those are not integrated)."""
    if study.output["times"]["unit"] != "t_sc":
        return 0
    last = float(coordinate_times(study.output["times"])[-1])
    ratio = np.broadcast_to(_stage_in_t_sc(study), study.shape)
    return int(np.sum(last > ratio * (1 + 1e-12)))


def expand(study: Study) -> None:
    """Validate the cases of a study (each grid value once, each [[cases]] entry) and build
    the reference runs; a grid's cases are built on demand (Study.case)."""
    if study.grid:
        _check_grid_values(study)
    else:
        listed = []
        for i, overrides in enumerate(study.case_list):
            overrides = {k: v for k, v in overrides.items() if k not in ("reference", "group")}
            label = ", ".join(f"{k}={v}" for k, v in overrides.items()) or "[base]"
            if study.design:
                label = f"[design] sample {i} ({label}, within [design.keys])"
            values = {**study.base, **study.solver, **overrides}
            try:
                values = _resolve_sample(values)
            except ParameterError as err:
                raise StudyError(f"{label if label.startswith('[') else 'case ' + label}: {err}") from None
            listed.append(_make_case((i,), values, study.output, label))
        study._listed = listed
    if study.n_cases == 0:
        raise StudyError("the study has no cases")
    ref_output = {**study.output, "fields": sorted(set(study.output["fields"]) | {"strain"})}
    if study.reference or any("reference" in c for c in study.case_list):
        if "strain" not in study.output["fields"]:
            raise StudyError("a study with a [reference] must store the strain field (errors are "
                             "measured on it): add \"strain\" to [output] fields")
        for i in range(study.n_cases):
            own = study.case_list[i].get("reference", {}) if study.case_list else {}
            ref_overrides = {**study.reference, **own}
            if not ref_overrides:
                continue
            case = study.case(i)
            values = {**{k: case.value(k) for k in PARAMETER_INFO}, **case.settings.as_dict(), **ref_overrides}
            study.references[i] = _make_case((), values, ref_output, f"reference of case {i}")
    # outputs past every case's stage are outside the model: refuse a study that asks only those
    if study.output["times"]["unit"] == "t_sc":
        first = coordinate_times(study.output["times"])
        longest = _longest_stage_in_t_sc(study)
        if first.size > 1 and np.all(first[1:] > longest * (1 + 1e-12)):
            raise StudyError(f"[output] times: every output time after 0 lies past every case's impact "
                             f"stage (the longest is {longest:.4g} t_sc)")
    # the same run may serve in several sweeps when its references differ (one file, several
    # rows); a grid's cases differ by construction (its values are distinct), so a large grid
    # is counted, not expanded, here
    # a design's samples may repeat a point (Morris's trajectories share points of their grid):
    # a repeated point is one run, computed once and stored at each of its samples
    if (study._listed or study.references) and not study.design:
        keyed = [(cid, study.references[i].case_id if i in study.references else None)
                 for i, cid in enumerate(study.case_ids)]
        if len(set(keyed)) != len(keyed):
            raise StudyError("two cases of the study are identical")
