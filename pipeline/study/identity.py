"""Case identity: the id a case is stored and reused under (a contract: an id must change
when, and only when, the case's results would).

A case id hashes the canonical JSON of the parameters (those beyond the paper's model left out
at the paper's value, so older ids hold), the settings its integrator reads, the output request
and the results revision (solver/revision.py) with the schema of the result files. A grid's ids
come from one fast pass (``grid_case_ids``, of a pipeline.study.definition.Study), without building its
cases.
"""
from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import replace

from solver import PARAMETER_INFO, SETTING_INFO, ParameterError, Parameters, Settings
from solver.keys import BREAKING_KEYS
from solver.parameters import PAPER_DEFAULTS
from solver.revision import RESULTS_REVISION
from solver.settings import check_combination

from ..common.errors import StudyError
from .case import Case

#: bump when the layout of a batch file changes: cases stored under an older one are recomputed
#: (9, 2026-11-25: the parameters edges and duration, the diagnostic gravity_time_ratio; 10: the
#: impact zone's maxima and contact_extent, the setting impact_zone_margin; 11, 2026-11-27: the
#: impact zone's tension records beside the plate-wide ones, along the tension_record dimension)
SCHEMA_VERSION = 11


#: [solver] error_estimate = "sample": the companion run of the error estimate (0.79x the
#: integration, measured on benchmarks/scale_1000.toml) on about one case in SAMPLE_EVERY,
#: chosen by a hash of the case's parameters (spread over the grid, the same in every study)
SAMPLE = "sample"


SAMPLE_EVERY = 10


def id_value(name: str, value):
    """A parameter's value as a case id hashes it: a free floe's edges carry the revision of the
    floe's results (solver/revision.py), so that a change of the floe's numerics recomputes the
    floe's cases and no other; and ice that breaks carries the revision of breaking's results."""
    if name == "edges" and value == "free" and RESULTS_REVISION["floe"] > 0:
        return f"free, results revision {RESULTS_REVISION['floe']}"
    if name == "fracture" and value == "break" and RESULTS_REVISION["breaking"] > 0:
        return f"break, results revision {RESULTS_REVISION['breaking']}"
    return value


def id_parameters(parameters: dict) -> dict:
    """The parameters a case id hashes: those beyond the paper's model are left out at the
    value that is the paper's (H = inf), so ids from before they existed still hold, and those
    only breaking reads are left out where the ice does not break."""
    unread = BREAKING_KEYS if parameters.get("fracture", "none") == "none" else ()
    return {k: id_value(k, v) for k, v in parameters.items() if not _at_paper_value(k, v) and k not in unread}


def _at_paper_value(key: str, value) -> bool:
    """Whether a parameter beyond the paper's model is at the paper's value (a case id leaves it out)."""
    return key in PAPER_DEFAULTS and value == PAPER_DEFAULTS[key]


def _parameter_text(parameters: dict) -> str:
    """'"name":value,...' in sorted order: the parameters part of a case id's JSON."""
    return ",".join(f'"{n}":' + json.dumps(parameters[n]) for n in sorted(parameters))


def _sampled(parameter_text: str) -> bool:
    return int(hashlib.sha256(parameter_text.encode()).hexdigest()[:8], 16) % SAMPLE_EVERY == 0


def resolve_sample(values: dict) -> dict:
    """values with error_estimate = "sample" replaced by whether this case is in the sample."""
    if values.get("error_estimate") != SAMPLE:
        return values
    params = id_parameters(Parameters(**{k: v for k, v in values.items() if k in PARAMETER_INFO}).as_dict())
    return {**values, "error_estimate": _sampled(_parameter_text(params))}


#: the settings each integrator reads; the others do not change its result
RELEVANT_SETTINGS = {
    "etd34": ("integrator", "tolerance", "subintervals", "fixed_step", "max_steps", "error_estimate",
              "bottoming_gap", "impact_zone_margin", "error_control"),
    "rk4": ("integrator", "subintervals", "rk4_step_fraction", "max_steps", "error_estimate", "bottoming_gap",
            "impact_zone_margin"),
    "dop853": ("integrator", "tolerance", "subintervals", "max_steps", "error_estimate", "bottoming_gap",
               "impact_zone_margin"),
}


def _payload_text(parameters: dict, settings: dict, output: dict) -> str:
    """The canonical JSON a case id hashes (sorted keys, no spaces)."""
    request = {"times": output.times, "fields": sorted(output.fields), "x_points": output.x_points, "end": output.end}
    if output.outputs is not None:          # a run that computes less: what it holds (ids before it unchanged)
        request["outputs"] = list(output.outputs)
        if output.end == "answered":
            request["answer_eps_Y"] = output.answer_eps_Y
    payload = {"schema": SCHEMA_VERSION, "parameters": parameters, "settings": settings, "output": request}
    return json.dumps(payload, sort_keys=True, separators=(",", ":"))


def used_settings(settings: Settings) -> dict:
    """The settings the run reads, and the revision of its rule's results (solver.revision). The
    quadrature enters only when it is not the paper's, so that the ids of the cases run before it
    was a setting stay what they were; with it the revision of its results. The paper rule's
    revision enters once it is above 0 (its ids carried none before); a DOP853 run's carries the
    revision of the reference's own results too. etd34's error_control enters where it is not
    "embedded" (the control before it was a setting: its ids hold) and the step is adaptive, with
    the revision of the smoothness control's own results."""
    used = {k: v for k, v in settings.as_dict().items() if k in RELEVANT_SETTINGS[settings.integrator]}
    if used.get("error_control") == "embedded" or settings.fixed_step > 0.0:
        used.pop("error_control", None)  # ids from before it was a setting hold; none for a fixed step
    elif "error_control" in used:
        used["error_control_revision"] = RESULTS_REVISION["smoothness"]
    if settings.quadrature != "paper":
        used["quadrature"] = settings.quadrature
        used["quadrature_density"] = settings.quadrature_density
        used["quadrature_revision"] = RESULTS_REVISION[settings.quadrature]
    elif RESULTS_REVISION["paper"] > 0:
        used["results_revision"] = RESULTS_REVISION["paper"]
    if settings.integrator == "dop853":
        used["integrator_revision"] = RESULTS_REVISION["dop853"]
    return used


def case_id(parameters: Parameters, settings: Settings, output: dict) -> str:
    """Stable id: hash of the normalised parameters, the settings the integrator reads, the
    output request (not eps_Y, not records; with [output] outputs, those, and for an "answered"
    end the largest eps_Y it answers) and the schema version (two runs with the same id give
    the same data)."""
    text = _payload_text(id_parameters(parameters.as_dict()), used_settings(settings), output)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def wider_output(output):
    """The [output] of the run that computes everything over the same times and fields, and at
    least as far, as a run asked for ``output``: every output (outputs None), to the stage's end
    where ``output`` ends at its answer. Its stored result holds every value a run asked for
    ``output`` reads, bit for bit (solver.observe.asked: an observer switched off changes no
    step), so a study that narrowed its [output] reuses it (``Study.wider_ids``). None where
    ``output`` asks for everything already."""
    if output.outputs is None:                  # (an answered end needs outputs: sections._check_outputs)
        return None
    return replace(output, outputs=None, answer_eps_Y=None, end="stage" if output.end == "answered" else output.end)


def make_case(index, values: dict, output: dict, label: str) -> Case:
    """A validated Case from merged parameter and setting values."""
    params = {k: v for k, v in values.items() if k in PARAMETER_INFO}
    settings = {k: v for k, v in values.items() if k in SETTING_INFO}
    try:
        p = Parameters(**params)
        s = Settings(**settings)
        check_combination(p, s)
    except ParameterError as err:
        raise StudyError(f"{label if label.startswith('[') else 'case ' + label}: {err}") from None
    return Case(case_id(p, s, output), tuple(index), p, s, output.times, tuple(output.fields),
                output.x_points, output.end, output.body, output.outputs, output.answer_eps_Y, output.break_slots)


def grid_label(grid: dict, idx: tuple) -> str:
    return ", ".join(f"{k}={v[j]}" for (k, v), j in zip(grid.items(), idx)) or "base"


def grid_case_ids(study) -> list:
    """case_id of every grid case in one pass: the canonical JSON is put together from
    per-value fragments (each value validated and normalised once), then hashed."""
    keys = list(study.grid)
    pkeys = [k for k in keys if k in PARAMETER_INFO]
    skeys = [k for k in keys if k not in PARAMETER_INFO]
    base_p = {k: v for k, v in study.base.items()}
    normal = Parameters(**base_p).as_dict()
    # parameter fragments: '"name":value' in sorted order; grid keys vary; a value an id leaves
    # out (id_parameters: H = inf) has no fragment (None)
    frag = {k: [('"%s":' % k + json.dumps(id_value(k, Parameters(**{**base_p, k: v}).as_dict()[k])))
                if not _at_paper_value(k, Parameters(**{**base_p, k: v}).as_dict()[k]) else None
                for v in study.grid[k]] for k in pkeys}
    kept = {k for k, v in normal.items() if not _at_paper_value(k, v)}
    names = sorted(n for n in normal if n in kept or n in frag)
    consts = {n: f'"{n}":' + json.dumps(id_value(n, normal[n])) for n in names if n not in frag}
    output_text = _payload_text({}, {}, study.output)
    head, tail = output_text.split('"parameters":{}', 1)
    settings_split = tail.split('"settings":{}', 1)
    settings_cache = {}
    positions = {k: keys.index(k) for k in keys}
    ids = []
    sha = hashlib.sha256
    # where the ice does not break (fracture "none": no fragment) the breaking keys' fragments go
    breaking = [i for i, n in enumerate(names) if n in BREAKING_KEYS]
    sample = study.solver.get("error_estimate") == SAMPLE
    for idx in itertools.product(*(range(len(v)) for v in study.grid.values())):
        parts = [consts[n] if n in consts else frag[n][idx[positions[n]]] for n in names]
        if breaking and (frag["fracture"][idx[positions["fracture"]]] if "fracture" in frag else
                         consts.get("fracture")) is None:
            parts = [None if i in breaking else part for i, part in enumerate(parts)]
        ptext = ",".join(p for p in parts if p is not None)
        skey = tuple(idx[positions[k]] for k in skeys) + ((_sampled(ptext),) if sample else ())
        stext = settings_cache.get(skey)
        if stext is None:
            values = {**study.solver, **{k: study.grid[k][j] for k, j in zip(skeys, skey)}}
            if sample:
                values["error_estimate"] = skey[-1]
            s = Settings(**values)
            stext = settings_cache[skey] = json.dumps(used_settings(s), sort_keys=True, separators=(",", ":"))
        text = head + '"parameters":{' + ptext + "}" + settings_split[0] + '"settings":' + stext + settings_split[1]
        ids.append(sha(text.encode()).hexdigest()[:16])
    return ids
