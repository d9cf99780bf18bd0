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

import json
import math
import tomllib
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from solver import PARAMETER_INFO, SETTING_INFO, ParameterError
from solver.fracture import above_yield_strain_message, up_to_yield_strain
from solver.outputs import BREAKING_INFO, CRACK_ONSET_TIMES, OBSERVED, ONSET_RECORD, RECORDS

from ..common.errors import StudyError
from .analysis import Analysis, check_analysis
from .case import Case, coordinate_times
from .consistency import body_masses, break_slots, breaking_yield_strain, check_grid_values, key_values, check_outputs_read, check_ranges, longest_stage_in_t_sc
from .design import Design, check_design, design_cases, design_size
from .identity import case_id, grid_case_ids, grid_label, make_case, resolve_sample, wider_output
from .search import EVENTS, Search, check_bracket, check_search, search_points
from .sections import (EPS_Y_AS_PARAMETER, READ, SECTIONS, Output, check_answerable, check_grid, check_output,
                       check_parameters, check_reference, check_solver)

#: the plot kinds a study can ask for ([plots]); pipeline.figures.KINDS draws each, one entry
#: per name (tests/test_architecture.py holds the two together)
PLOT_KINDS = ("diagnostics", "crack_onset", "paper_fig2", "work_precision", "extremes", "drop", "design",
              "sensitivity", "emulator")
#: the outputs an observer makes (solver.outputs.OBSERVED) that each plot kind reads; the others
#: read none (sensitivity and emulator draw the [analysis] outputs). tests/test_frictions.py draws
#: the sweep figures from a study.nc that holds no other observed output
PLOT_READS = {
    "diagnostics": ("max_strain", "max_strain_lower", "max_strain_x", "max_strain_lower_x", "impact_zone_max_strain",
                    "impact_zone_max_strain_lower", *CRACK_ONSET_TIMES, "max_contact_intervals", "max_force",
                    "max_compression"),
    "crack_onset": CRACK_ONSET_TIMES,
    "extremes": ("max_compression",),
    "drop": ("max_strain", "max_force", "crack_onset_time"),
    "design": ("max_strain", "max_force", "crack_onset_time"),
}
#: grid keys whose study.nc dimension has another name (the key is also a result's name)
DIM_NAMES = {"error_estimate": "error_estimate_on"}


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
    output: Output
    solver: dict
    plots: list
    reference: dict = field(default_factory=dict)
    design: Design | None = None                        # a checked [design] (pipeline.study.design)
    analysis: Analysis | None = None                    # a checked [analysis] (pipeline.study.analysis)
    search: Search | None = None                        # a checked [search] (pipeline.study.search)
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
        label = grid_label(self.grid, idx)
        try:
            values = resolve_sample(values)
        except ParameterError as err:
            raise StudyError(f"case {label}: {err}") from None
        return make_case(idx, values, self.output, label)

    @cached_property
    def cases(self) -> list:
        """Every case as a Case (builds them all: use case_ids and case(i) for large grids)."""
        return [self.case(i) for i in range(self.n_cases)]

    @cached_property
    def case_ids(self) -> list:
        """The case ids in grid order (one fast pass for a grid; equal to case(i).case_id)."""
        if self._listed:
            return [c.case_id for c in self._listed]
        return grid_case_ids(self)

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
    def wider_ids(self) -> dict:
        """case id -> the id of the run that computes every output over the same times and at
        least as far (identity.wider_output), for a study whose [output] computes less: a stored
        complete result under that id serves the case, its values the study reads bit for bit
        (pipeline.store.ledger.Ledger.index). Empty where the study computes everything."""
        wide = wider_output(self.output)
        if wide is None:
            return {}
        if self._listed:
            wider = [case_id(c.parameters, c.settings, wide) for c in self._listed]
        else:
            wider = grid_case_ids(replace(self, output=wide))
        return dict(zip(self.case_ids, wider))

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

    def eps_Y_read(self) -> list:
        """Every yield strain the study reads crack onset at: [output]'s, [analysis]'s and
        [search]'s."""
        return [*self.output.eps_Y, *(self.analysis.eps_Y if self.analysis else ()),
                *(self.search.eps_Y if self.search else ())]

    def outputs_read(self) -> tuple:
        """The outputs an observer makes (solver.outputs.OBSERVED) that the study reads: its
        [analysis] outputs, its [search] event, its plots' (PLOT_READS), and the tension records
        where [output] records = true. Sorted."""
        read = set(self.analysis.outputs if self.analysis else ())
        read |= {EVENTS[self.search.event]} if self.search else set()
        read |= {name for kind in self.plots for name in PLOT_READS.get(kind, ())}
        read |= {f"tension_record_{record}" for record in RECORDS} if self.output.records else set()
        return tuple(sorted(read & OBSERVED))

    def all_cases(self) -> list:
        """Every distinct run as a Case (small studies; large ones go through run_ids)."""
        return [self.run(cid) for cid in self.run_ids]


def load_study_text(text: str, name: str, path: Path | None = None, max_cases: int | None = None) -> Study:
    """Validate a study from its text (what a worker receives); expand its cases. Each table is
    checked by its own checker, in this order (the first problem found is the one line said)."""
    path = Path(path) if path is not None else Path(f"{name}.toml")
    data = _tables(text, path)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise StudyError(f"{path}: description must be a string")
    base = check_parameters("[base]", data.get("base", {}))
    grid = check_grid(data.get("grid", {}), base, data.get("solver", {}))
    case_list = _case_list(data, base, grid)
    output = check_output(data.get("output", {}))
    design, case_list = _design(data, base, case_list, max_cases)
    analysis = check_analysis(data["analysis"], design, output) if "analysis" in data else None
    solver = check_solver(data.get("solver", {}))
    extreme = data.get("accept_extreme_values", False)
    if not isinstance(extreme, bool):
        raise StudyError(f"{path}: accept_extreme_values must be true or false")
    search, base = _search(data, base, grid, case_list, design, analysis, {**base, **solver}, extreme)
    reference = check_reference("[reference]", data["reference"]) if "reference" in data else {}
    plots = _plots(data.get("plots", {}), design, analysis, search, output)
    study = Study(name=name, path=path, text=text, description=description, base=base,
                  grid=grid, case_list=case_list, output=output, solver=solver, plots=plots,
                  reference=reference, design=design, analysis=analysis, search=search)
    if output.outputs == READ:
        study.output = output = replace(output, outputs=_read(study))
    study.output = output = replace(output, break_slots=break_slots(study))
    study.output = output = _eps_Y_of_breaking_ice(study, output)
    breaking = sorted(set(output.outputs or ()) & set(BREAKING_INFO))
    if breaking and not output.break_slots:
        raise StudyError(f"[output] outputs: {breaking[0]} is an output of ice that breaks, and no case of the study "
                         f"does: give fracture = \"break\" in [base], [grid] or [[cases]]")
    if (not output.end_given and output.outputs is not None and set(output.outputs) <= set(ONSET_RECORD)
            and not output.break_slots):               # (a run that breaks runs to its end)
        study.output = output = replace(output, end="answered")     # the answers: nothing read changes
    masses = body_masses(study)
    study.output = replace(study.output, body=any(math.isfinite(m) for m in masses if isinstance(m, (int, float))))
    if study.output.break_slots and study.output.end == "answered":
        raise StudyError('[output] end = "answered" ends a run at its crack onsets, and a run that breaks '
                         '(fracture = "break") runs to its end: give end = "stage", "last_output" or "separation"')
    if study.search and study.search.event == "breakthrough" and set(key_values(study, "fracture")) != {"break"}:
        raise StudyError('[search] event = "breakthrough" needs ice that breaks in every case: give fracture = '
                         '"break" in [base]')
    if output.end == "answered":
        study.output = replace(study.output, answer_eps_Y=max(study.eps_Y_read()))
    check_outputs_read(study)
    if output.end == "separation" and not all(isinstance(m, (int, float)) and math.isfinite(m) for m in masses):
        raise StudyError('[output] end = "separation" needs a free body in every case: give body_mass a '
                         'finite value in [base], or finite values in [grid] or in every [[cases]] entry')
    if not extreme:
        check_ranges(study)
    expand(study)
    return study


def _eps_Y_of_breaking_ice(study, output):
    """Where some case's ice breaks, its tension never passes its yield_strain, so crack onset is
    defined up to the smallest (breaking_yield_strain): the default [output] eps_Y stops there
    (and holds it: crack onset at it is the first break on its surface); an eps_Y the study reads
    above it is refused in one line. Returns the Output."""
    top = breaking_yield_strain(study)
    if top is None:
        return output
    if not output.eps_Y_given:
        output = replace(output, eps_Y=tuple(up_to_yield_strain(output.eps_Y, top).tolist()))
        study.output = output
    above = [e for e in study.eps_Y_read() if e > top]
    if above:
        raise StudyError(above_yield_strain_message(max(above), top))
    return output


def _tables(text: str, path: Path) -> dict:
    """The study file's tables, its sections all known."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise StudyError(f"{path}: TOML syntax error: {err}") from None
    unknown = set(data) - SECTIONS
    if unknown:
        if "eps_Y" in unknown:
            raise StudyError(f"{path}: {EPS_Y_AS_PARAMETER}")
        raise StudyError(f"{path}: unknown section or key {sorted(unknown)[0]!r}; known: {', '.join(sorted(SECTIONS))}")
    return data


def _case_list(data: dict, base: dict, grid: dict) -> list:
    """[[cases]] checked, each a distinct case; [base] alone is one case, the base itself."""
    case_list = data.get("cases", [])
    if not isinstance(case_list, list):
        raise StudyError("[[cases]] must be an array of tables")
    case_list = [check_parameters(f"[[cases]] #{i + 1}", c, settings=True, reference=True)
                 for i, c in enumerate(case_list)]
    if grid and case_list:
        raise StudyError("a study has either [grid] or [[cases]], not both")
    if "design" in data and (grid or case_list):
        raise StudyError("a study has one of [grid], [[cases]] and [design], not two")
    if "grid" in data and not grid:
        raise StudyError("[grid] is empty")
    if "cases" in data and not case_list:
        raise StudyError("[[cases]] is empty")
    if not grid and not case_list:
        return [{}]
    seen = set()
    for i, c in enumerate(case_list):
        key = json.dumps({**base, **{k: v for k, v in c.items() if k != "group"}}, sort_keys=True)
        if key in seen:
            raise StudyError(f"[[cases]] #{i + 1} repeats an earlier case")
        seen.add(key)
    return case_list


def _design(data: dict, base: dict, case_list: list, max_cases: int | None) -> tuple:
    """(the checked [design] or None, the cases: its samples, which may repeat a point (Morris's
    grid), or case_list)."""
    if "design" not in data:
        return None, case_list
    design = check_design(data["design"], base)
    n = design_size(design)
    if max_cases is not None and n > max_cases:
        raise StudyError(f"the study has {n} cases (more than {max_cases}); add --yes to run it")
    return design, design_cases(design)


def _search(data, base, grid, case_list, design, analysis, values, extreme) -> tuple:
    """(the checked [search] or None, [base] with the searched key at the bracket's low end: the
    study's own cases are the points searched, and the key may have no default, a free floe's
    duration). ``values``: [base] and [solver], which every run of the first round takes."""
    if "search" not in data:
        return None, base
    if case_list and not design and case_list != [{}]:
        raise StudyError("[search] runs over a [grid], a [design] or [base] alone, not [[cases]]")
    search = check_search(data["search"], {*base, *grid, *(design.keys if design else ())})
    if analysis:
        raise StudyError("[analysis] is computed over a [design]'s samples, not a [search]'s runs: a study has "
                         "one of them")
    if "reference" in data:
        raise StudyError("[reference] is not run by a [search] (its runs are the bisection's): remove it")
    check_bracket(search, values, search_points(grid, case_list), extreme)
    return search, {**base, search.key: search.bracket[0]}


def _read(study) -> tuple:
    """[output] outputs = "read", resolved: what the study reads (Study.outputs_read)."""
    read = study.outputs_read()
    if not read:
        raise StudyError('[output] outputs = "read": the study reads no output an observer computes (its [plots] '
                         'kinds, [analysis] and [search] read none): list the outputs instead')
    check_answerable(read, study.output.end)
    return read


def _plots(table, design, analysis, search, output) -> list:
    """[plots] kinds, or the defaults: a design's figures, none for a search (it draws
    search.png itself), the diagnostics and crack onset otherwise. A study that computes only
    some outputs ([output] outputs) draws a figure only where they hold what it reads
    (PLOT_READS); by default, the figures of its analysis."""
    if not isinstance(table, dict) or set(table) - {"kinds"}:
        raise StudyError("[plots] takes one key: kinds = [...]")
    plots = table.get("kinds", ["diagnostics", "crack_onset"])
    if not isinstance(plots, list) or any(k not in PLOT_KINDS for k in plots):
        raise StudyError(f"[plots] kinds must be a list from {', '.join(PLOT_KINDS)}")
    if output.outputs is not None:
        drawn = ["sensitivity"] + (["emulator"] if analysis and analysis.method == "pce" else [])
        if "kinds" not in table:
            return [k for k in drawn if analysis]
        for kind in plots if output.outputs != READ else ():
            missing = [name for name in PLOT_READS.get(kind, ()) if name not in output.outputs]
            if missing:
                raise StudyError(f"[plots] {kind!r} reads {missing[0]}, which is not among [output] outputs: add "
                                 f"it there, drop the plot, or drop [output] outputs to compute every output")
        return plots
    if "kinds" in table:
        return plots
    if search:
        return []
    if design:
        return ["design"] + (["sensitivity"] if analysis else []) + \
            (["emulator"] if analysis and analysis.method == "pce" else [])
    return plots


def expand(study: Study) -> None:
    """Validate the cases of a study (each grid value once, each [[cases]] entry) and build
    the reference runs; a grid's cases are built on demand (Study.case)."""
    if study.grid:
        check_grid_values(study)
    else:
        listed = []
        for i, overrides in enumerate(study.case_list):
            overrides = {k: v for k, v in overrides.items() if k not in ("reference", "group")}
            label = ", ".join(f"{k}={v}" for k, v in overrides.items()) or "[base]"
            if study.design:
                label = f"[design] sample {i} ({label}, within [design.keys])"
            values = {**study.base, **study.solver, **overrides}
            try:
                values = resolve_sample(values)
            except ParameterError as err:
                raise StudyError(f"{label if label.startswith('[') else 'case ' + label}: {err}") from None
            listed.append(make_case((i,), values, study.output, label))
        study._listed = listed
    if study.n_cases == 0:
        raise StudyError("the study has no cases")
    ref_output = replace(study.output, fields=tuple(sorted(set(study.output.fields) | {"strain"})))
    if study.reference or any("reference" in c for c in study.case_list):
        if "strain" not in study.output.fields:
            raise StudyError("a study with a [reference] must store the strain field (errors are "
                             "measured on it): add \"strain\" to [output] fields")
        for i in range(study.n_cases):
            own = study.case_list[i].get("reference", {}) if study.case_list else {}
            ref_overrides = {**study.reference, **own}
            if not ref_overrides:
                continue
            case = study.case(i)
            values = {**{k: case.value(k) for k in PARAMETER_INFO}, **case.settings.as_dict(), **ref_overrides}
            study.references[i] = make_case((), values, ref_output, f"reference of case {i}")
    # outputs past every case's stage are outside the model: refuse a study that asks only those
    if study.output.times["unit"] == "t_sc":
        first = coordinate_times(study.output.times)
        longest = longest_stage_in_t_sc(study)
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
