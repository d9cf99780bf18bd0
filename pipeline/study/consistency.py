"""Whether a study's cases hold together, checked before any runs: every value within the
physical ranges, every combination of a grid's coupled keys a valid case, the integrator, the
quadrature and the edges with the ice they meet; the cases whose output times lie past their
impact stage; and what the model answers only in part (validity_warnings). Each function takes
a pipeline.study.definition.Study (not imported: the study calls these while it is built)."""
from __future__ import annotations

import itertools
import math

import numpy as np

from solver import PARAMETER_INFO, SETTING_INFO, ParameterError, Parameters, Settings
from solver.outputs import OBSERVED
from solver.parameters import (CHOICES, COUPLED_KEYS, MAX_PARTS, NOT_MONOTONE, TIME_SCALE_KEYS,
                               outside_physical_range, time_scale_of)
from solver.keys import BREAKING_KEYS
from solver.settings import NAMED_SETTINGS, check_combination

from ..common.errors import StudyError
from .case import coordinate_times
from .identity import SAMPLE
from .search import EVENTS

def key_values(study, key: str) -> list:
    """Every value a parameter takes in the study's cases (its default where none sets it)."""
    base = study.base.get(key, getattr(Parameters(), key))
    if key in study.grid:
        return list(study.grid[key])
    if study.case_list:
        return [entry.get(key, base) for entry in study.case_list]
    return [base]


def body_masses(study) -> list:
    """Every body_mass value the study's cases take (inf: the paper's body)."""
    return key_values(study, "body_mass")


def break_slots(study) -> int:
    """The breaks a study stores per case (Output.break_slots): max_parts - 1 of the largest
    max_parts, where some case breaks; 0 where none does (and then a study that sets what only
    breaking reads is refused: it would change nothing)."""
    if "break" not in key_values(study, "fracture"):
        for key in BREAKING_KEYS:
            if any(v != getattr(Parameters(), key) for v in key_values(study, key)):
                raise StudyError(f"{key} is read only by a run that breaks, and no case of the study does: "
                                 f"give fracture = \"break\" in [base], [grid] or [[cases]]")
        return 0
    # (a value that is no whole number in 2..MAX_PARTS is refused with its case: solver.parameters)
    sizes = [min(int(m), MAX_PARTS) for m in key_values(study, "max_parts")
             if isinstance(m, (int, float)) and not isinstance(m, bool) and math.isfinite(m) and m >= 2]
    return max(sizes, default=2) - 1


def breaking_yield_strain(study) -> float | None:
    """The smallest yield_strain of a case whose ice breaks (None: no case breaks): its tension
    never passes it, so the study's crack onsets are defined up to it."""
    base_fracture = study.base.get("fracture", Parameters().fracture)
    base_strain = study.base.get("yield_strain", Parameters().yield_strain)
    if study.case_list and study.case_list != [{}]:
        pairs = [(entry.get("fracture", base_fracture), entry.get("yield_strain", base_strain))
                 for entry in study.case_list]
    else:
        pairs = [(f, y) for f in study.grid.get("fracture", [base_fracture])
                 for y in study.grid.get("yield_strain", [base_strain])]
    strains = [float(y) for f, y in pairs if f == "break" and isinstance(y, (int, float)) and not isinstance(y, bool)]
    return min(strains) if strains else None


def check_ranges(study) -> None:
    """Every parameter value within solver.parameters.PHYSICAL_RANGES (each grid value once;
    hi <= L at the grid's extremes; each [[cases]] entry), before anything is computed from
    them."""
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


def check_grid_values(study) -> None:
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


#: at most this many combinations of the grid's coupled keys (solver.parameters.COUPLED_KEYS)
#: are checked one by one; beyond, every value of the keys the checks are not monotone in
#: (NOT_MONOTONE) with the lowest and highest of each other key
MAX_COMBINATIONS = 20_000


#: the keys solver.settings.check_combination reads
COMBINED_KEYS = ("edges", "quadrature", "integrator", "tau", "layer_tau", "duration")


def _check_setting_combinations(study, params: dict, settings: dict) -> None:
    """Every combination of the grid's values of the keys solver.settings.check_combination
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


def _check_grid_combinations(study, params: dict) -> None:
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


def stage_in_t_sc(study) -> np.ndarray:
    """stage / t_sc of every case, as an array that broadcasts to the grid's shape."""
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


def longest_stage_in_t_sc(study) -> float:
    return float(np.max(stage_in_t_sc(study)))


#: a free floe's run longer than this fraction of its gravity-wave time sqrt(L/g) is said to be
#: outside the short-time model (phi = 0 on the open water holds for ratios well below 1)
GRAVITY_TIME_WARNING = 0.5


#: the keys validity_warnings reads
VALIDITY_KEYS = ("edges", "L", "g", "duration", "impact_zone_margin")


def validity_warnings(study) -> list:
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
        lines.append(f"warning: a free floe's duration is {max(ratios):.3g} times its gravity-wave time sqrt(L/g): "
                     f"phi = 0 on the open water, the model's short-time approximation, holds only well below 1 "
                     f"(docs/model.md, \"a free floe\"); gravity_time_ratio in study.nc says it per case")
    given = {k: v for k, v in {**study.base, **study.solver}.items() if k == "subintervals"}
    largest = max([Settings(**given).subintervals, *study.grid.get("subintervals", []),
                   *(c.get("subintervals", 0) for c in study.case_list)])
    if largest > SLOW_SUBINTERVALS:
        lines.append(f"warning: subintervals = {largest}: every step sums the quadrature over them; a case of "
                     f"8 modes took 2.2 s at 25 000 and 11.9 s at 100 000 here (measured), more with more modes; "
                     f"the default is 250")
    return lines


#: subintervals above which a run is said to be slow (etd34 at 8 modes over the reference case's
#: stage: 0.2 s at 2 500, 1.9-2.2 s at 25 000 for either rule, 11.9 s at 100 000, the maximum)
SLOW_SUBINTERVALS = 20_000


def cases_past_their_stage(study) -> int:
    """How many cases have output times past their impact stage (those are not integrated)."""
    if study.output.times["unit"] != "t_sc":
        return 0
    last = float(coordinate_times(study.output.times)[-1])
    ratio = np.broadcast_to(stage_in_t_sc(study), study.shape)
    return int(np.sum(last > ratio * (1 + 1e-12)))


def check_outputs_read(study) -> None:
    """With [output] outputs, every output the study reads is among them: its [analysis]
    outputs and its [search] event (the outputs every run computes, such as bottoming_time,
    need not be listed)."""
    asked = study.output.outputs
    if asked is None:
        return
    read = [("[analysis] outputs", name) for name in (study.analysis.outputs if study.analysis else ())]
    read += [("[search] event", EVENTS[study.search.event])] if study.search else []
    for where, name in read:
        if name in OBSERVED and name not in asked:
            raise StudyError(f"{where}: {name} is not among [output] outputs: add it there, or drop [output] "
                             f"outputs to compute every output")
