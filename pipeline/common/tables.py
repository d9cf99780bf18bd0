"""The variables a case and a study store, declared once: name -> (long_name, units) of the series,
run records and event records, the text variables, and the statuses grouped by what they mean
to the runner; and the one mapping of a solver Result to the diagnostics and run records they
store (``diagnostic_values``, ``run_records``). Imported by the batch files (casefile), a case's
Dataset (dataset), study.nc (combine), the figures and the runner; it imports nothing of the
pipeline."""
import math

from solver import DIAGNOSTIC_INFO, STATUS_INFO
from solver.outputs import OBSERVED, ONSET_RECORD, RECORDS, SERIES, TENSION_RECORD

#: variable name -> (long_name, units) for the per-case series (the solver's table
#: solver.outputs.SERIES, and the time) and run records
SERIES_INFO = {
    "time": ("time since first touch", "s"),
    **{row.name: (row.long_name, row.units) for row in SERIES if row.stored == "study"},
}
#: series of a study with a free body (finite body_mass in some case): left out otherwise
BODY_SERIES_INFO = {row.name: (row.long_name, row.units) for row in SERIES if row.stored == "body"}
#: the dimension along which a study where some case breaks stores each break of a case
#: (solver.outputs.BREAKING_INFO's "break" rows), in the order they happened
BREAK_DIMENSION = "break_number"
#: the dimensions (after a case's) of a breaking output, by what it runs along
BREAKING_DIMS = {"case": (), "break": (BREAK_DIMENSION,), "t": ("t",)}
RECORD_INFO = {
    "t_sc": ("time scale 1/omega_1 of the case", "s"),
    "stage_duration": ("impact stage of the case, b_mean / V (L^2/(6 R V) for the paper's parabola)", "s"),
    "time_reached": ("time the integration reached", "s"),
    "run_time": ("wall time of the solver for this case (the integration alone)", "s"),
    "error_estimate_run_time": ("wall time of the error estimate's companion run (0: none)", "s"),
    "steps": ("accepted time steps", "1"),
    "rejected_steps": ("rejected time steps", "1"),
    "smallest_step": ("smallest accepted time step", "s"),
}
TEXT_INFO = {
    "status": " | ".join([*STATUS_INFO, "error"]),
    "message": "what went wrong, empty when status is ok",
}
#: the running-maximum tension record of each surface (solver.fracture), ragged along
#: tension_node; crack onset for any eps_Y follows from it (solver.outputs.TENSION_RECORD)
TENSION_RECORD_INFO = {row.name: (row.long_name, row.units) for row in TENSION_RECORD}
CONTACT_RECORD_INFO = {
    "contact_change_time": ("time at which the number of contact intervals changed (first entry: "
                            "first touch)", "s"),
    "contact_change_count": ("number of contact intervals on -L..L from that time on", "1"),
}
#: the tension records of a case, the labels of the tension_record dimension (solver.outputs.TENSION_RECORDS)
RECORD_NAMES = RECORDS
RECORD_LONG_NAME = ("tension record: the peak tension of the upper surface (+strain) or the lower (-strain), over "
                    "the whole plate (upper, lower) or within the impact zone (impact_zone_upper, impact_zone_lower)")
#: statuses of a run that covered what it was asked to: ok, and a free body's ends
COMPLETE = ("ok", "separated", "stopped")
#: statuses of a case that ended by the model itself (not ok), and numerical failures
ENDED_EARLY = ("layer_bottomed_out", "separated", "stopped", "parts_limit", "edge_break")
NUMERICAL_FAILURES = ("nonfinite", "step_limit", "energy_violation", "error")
#: what --rerun-failed computes again (a free body's end is a result, not a failure)
FAILED = ("layer_bottomed_out",) + NUMERICAL_FAILURES

#: record status of a batch whose file could not be written (not a case status: no file exists)
WRITE_FAILED = "write_failed"


def diagnostic_values(result) -> dict:
    """Each diagnostic of a Result (all NaN for a case with none) as stored: -inf, the kernels'
    "nothing measured", is NaN; +inf is kept (max_force of a bottomed-out case: the model's
    force is unbounded there)."""
    values = {}
    for name in DIAGNOSTIC_INFO:
        value = math.nan if result is None else float(result.diagnostics[name])
        values[name] = math.nan if value == -math.inf else value
    return values


def run_records(result, time_scale, stage_duration) -> dict:
    """The run records (RECORD_INFO) of a Result, NaN but the case's own scales for a case with
    none."""
    none = result is None
    return {"t_sc": time_scale, "stage_duration": stage_duration,
            "time_reached": math.nan if none else result.time_reached,
            "run_time": math.nan if none else result.wall_time,
            "error_estimate_run_time": math.nan if none else result.extra.get("error_estimate_wall_time", 0.0),
            "steps": math.nan if none else result.steps,
            "rejected_steps": math.nan if none else result.rejected_steps,
            "smallest_step": math.nan if none else result.smallest_step}


def computes(outputs, name: str) -> bool:
    """Whether a study (or a case) whose [output] outputs are ``outputs`` (None: every one)
    computes ``name``: every name but an observed output left out of them."""
    return outputs is None or name not in OBSERVED or name in outputs


def asked_attributes(name: str, outputs, answered_eps_Y=None) -> dict:
    """What a variable of a study (or a case) that computed only some outputs says of itself:
    outputs, the outputs computed ([output] outputs; None: every one); answered_eps_Y, where the
    runs ended at their crack onsets ([output] end = "answered"), the largest eps_Y they answer.
    An output not computed is NaN and says so; a crack onset of an answered run is final up to
    answered_eps_Y, and every other value but the run records covers the run up to time_reached."""
    if outputs is None:
        return {}
    if not computes(outputs, name):
        return {"computed": "no: not among [output] outputs, NaN (solver.observe.asked)"}
    if answered_eps_Y is None or name in RECORD_INFO:
        return {}
    if name in ONSET_RECORD:
        return {"final_up_to_eps_Y": answered_eps_Y,
                "computed": "each run ended when its crack onsets up to final_up_to_eps_Y were final"}
    return {"covers": "the run up to time_reached: it ended when its crack onsets were final ([output] end = "
                      "\"answered\")"}
