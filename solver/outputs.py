"""What a run reports, declared once: one row per diagnostic, per series over the output times,
per column of the tension record, and the fields.

``DIAGNOSTICS`` is the diagnostics vector of the kernels (solver.layout generates its slots
``D_<slot>`` from the rows that have one, in this order) and the diagnostics a Result, a batch
file, a case's Dataset and study.nc hold (the rows that have a name, in this order). A row gives
the kernel's slot (None: computed by solve after the run), the stored name (None: the kernel's own
bookkeeping, read into the Result's attributes), units, long name, and whether the value is a
position on the plate (solve moves it from the kernel's coordinates to x). The triples of the
strain maxima (value, x, time) are consecutive, each surface's after the upper's: the kernels
reach the lower surface's at the upper's slot + 3, and its zone edge flag at the upper's + 1.
"""
import math
from collections import namedtuple
from pathlib import Path

import numpy as np

from .spec import Breaking

#: one diagnostic: the kernel's slot name, the stored name, units, long name, a position on the plate,
#: and how a run in stages (one that breaks: solver.breaking) joins its stages' values into the
#: run's: one of JOINS (a stored diagnostic must say; tests/test_outputs.py holds it)
Diagnostic = namedtuple("Diagnostic", "slot name units long_name position join", defaults=(False, None))

#: how a diagnostic of a run in stages is joined from its stages' (solver.breaking.joined_diagnostics):
#: kind -> what it means; a join is (kind, *arguments)
JOINS = {
    "record": "from the stages' tension records joined as one running maximum (record name, column "
              "'value', 'x' or 'time' of its last row); the last stage's where the record is empty",
    "larger": "of the larger of two diagnostics already joined (their names, and the suffix of this one: '', "
              "'_x' or '_time')",
    "largest": "the largest over the stages (NaN counts as none; the first stage of equal ones)",
    "with": "the value of the stage where the named diagnostic is largest (its place, time or flag)",
    "sum": "summed over the stages",
    "first": "of the first stage where the named diagnostic is finite; the last stage's where none is",
    "last": "the last stage's: carried from stage to stage, or only a run's last stage can have it",
    "residual": "each stage's residual times its energy scale, summed, over the whole run's scale (the "
                "largest of the energy each stage starts with plus the work before it and its own)",
}

DIAGNOSTICS = (
    Diagnostic("MAX_UPPER", "max_strain", "1", "largest tensile strain on the upper surface, plate-wide (at a wall, "
               "a walled plate's confinement; impact_zone_max_strain is the impact's own)",
               join=("record", "upper", "value")),
    Diagnostic("MAX_UPPER_X", "max_strain_x", "m", "position of max_strain (centred impact: x >= 0, mirrored at -x; "
               "off centre: signed)", position=True, join=("record", "upper", "x")),
    Diagnostic("MAX_UPPER_T", "max_strain_time", "s", "time of max_strain", join=("record", "upper", "time")),
    Diagnostic("MAX_LOWER", "max_strain_lower", "1", "largest tensile strain on the lower surface (max of -strain), "
               "plate-wide", join=("record", "lower", "value")),
    Diagnostic("MAX_LOWER_X", "max_strain_lower_x", "m", "position of max_strain_lower (centred impact: x >= 0; off "
               "centre: signed)", position=True, join=("record", "lower", "x")),
    Diagnostic("MAX_LOWER_T", "max_strain_lower_time", "s", "time of max_strain_lower",
               join=("record", "lower", "time")),
    Diagnostic("MAX_ABS", "max_abs_strain", "1", "largest strain magnitude, plate-wide",
               join=("larger", "max_strain", "max_strain_lower", "")),
    Diagnostic("MAX_ABS_X", "max_abs_strain_x", "m", "position of max_abs_strain (centred impact: x >= 0; off "
               "centre: signed)", position=True, join=("larger", "max_strain", "max_strain_lower", "_x")),
    Diagnostic("MAX_ABS_T", "max_abs_strain_time", "s", "time of max_abs_strain",
               join=("larger", "max_strain", "max_strain_lower", "_time")),
    Diagnostic("ZONE_UPPER", "impact_zone_max_strain", "1", "largest tensile strain on the upper surface within the "
               "impact zone (the contact's farthest reach from the body's centre so far plus impact_zone_margin)",
               join=("record", "impact_zone_upper", "value")),
    Diagnostic("ZONE_UPPER_X", "impact_zone_max_strain_x", "m", "position of impact_zone_max_strain (centred impact: "
               "x >= 0; off centre: signed)", position=True, join=("record", "impact_zone_upper", "x")),
    Diagnostic("ZONE_UPPER_T", "impact_zone_max_strain_time", "s", "time of impact_zone_max_strain",
               join=("record", "impact_zone_upper", "time")),
    Diagnostic("ZONE_LOWER", "impact_zone_max_strain_lower", "1", "largest tensile strain on the lower surface "
               "within the impact zone", join=("record", "impact_zone_lower", "value")),
    Diagnostic("ZONE_LOWER_X", "impact_zone_max_strain_lower_x", "m", "position of impact_zone_max_strain_lower "
               "(centred impact: x >= 0; off centre: signed)", position=True,
               join=("record", "impact_zone_lower", "x")),
    Diagnostic("ZONE_LOWER_T", "impact_zone_max_strain_lower_time", "s", "time of impact_zone_max_strain_lower",
               join=("record", "impact_zone_lower", "time")),
    Diagnostic("ZONE_UPPER_EDGE", "impact_zone_max_strain_at_edge", "1", "1 where impact_zone_max_strain sits at the "
               "impact zone's edge (the tension still rose outward), 0 where it is a peak inside the zone",
               join=("with", "impact_zone_max_strain")),
    Diagnostic("ZONE_LOWER_EDGE", "impact_zone_max_strain_lower_at_edge", "1", "1 where impact_zone_max_strain_lower "
               "sits at the impact zone's edge, 0 where it is a peak inside the zone",
               join=("with", "impact_zone_max_strain_lower")),
    Diagnostic("CONTACT_EXTENT", "contact_extent", "m", "farthest distance from the body's centre that a point in "
               "contact (delta > 0) reached over the run", join=("largest",)),
    Diagnostic("MAX_CONTACTS", "max_contact_intervals", "1", "largest number of disjoint contact intervals on -L..L, "
               "intervals that open and close within a step included", join=("largest",)),
    Diagnostic("MAX_FORCE", "max_force", "N m-1", "largest force on the body per unit width, located inside the steps "
               "(inf: the layer bottomed out, where the model's force is unbounded)", join=("largest",)),
    Diagnostic("MAX_FORCE_T", "max_force_time", "s", "time of max_force", join=("with", "max_force")),
    Diagnostic("MAX_DELTA", "max_compression", "1", "largest relative compression delta of the layer over the "
               "continuous plate, located inside the steps", join=("largest",)),
    Diagnostic("MAX_DELTA_T", "max_compression_time", "s", "time of max_compression", join=("with", "max_compression")),
    Diagnostic("BOTTOM_T", "bottoming_time", "s", "time at which the layer's gap first closed to bottoming_gap "
               "(default 1e-3) of its thickness, anywhere on the plate (NaN: it never did)", join=("last",)),
    Diagnostic("BOTTOM_X", "bottoming_x", "m", "position where the gap first closed (centred impact: x >= 0, "
               "mirrored at -x; off centre: signed)", position=True, join=("last",)),
    Diagnostic("BOTTOM_SPEED", "bottoming_closing_speed", "m s-1", "speed at which the gap was closing at bottoming, "
               "he d(delta)/dt", join=("last",)),
    Diagnostic("ENERGY_JUMPS", "energy_rejections", "1", "steps rejected because the energy identity jumped",
               join=("sum",)),
    Diagnostic("ENERGY_RESIDUAL", "energy_residual", "1", "max over time of |E_plate + E_layer + D - W| divided by "
               "the largest work W over the run (the final work for the paper's body)", join=("residual",)),
    Diagnostic("WORK", "work", "J m-1", "work done by the body on the ice up to the time reached, int F U dt",
               join=("sum",)),
    Diagnostic("DISSIPATED", "dissipated_energy", "J m-1", "energy dissipated in the viscoelastic ice and "
               "layer, and taken by cracks that open over a time, up to the time reached (0: elastic, cracks at "
               "once)", join=("sum",)),
    Diagnostic("STOP_T", "stop_time", "s", "first time a free body's speed reached zero (NaN: never, or the paper's "
               "body at constant speed)", join=("last",)),
    Diagnostic("MAX_PENETRATION", "max_penetration", "m", "deepest penetration s of a free body, at a zero of its "
               "speed", join=("last",)),
    Diagnostic("SEPARATION_T", "separation_time", "s", "time a free body left the ice moving up after it had stopped "
               "(NaN: it did not)", join=("first", "separation_time")),
    Diagnostic("SEPARATION_SPEED", "separation_speed", "m s-1", "upward speed of a free body when it left the ice "
               "(rebound speed)", join=("first", "separation_time")),
    Diagnostic("BODY_RESIDUAL", "body_energy_residual", "1", "max over time of |M (U^2 - V^2)/2 - M body_g s + W| "
               "divided by the largest work W: the free body's own energy balance (NaN for the paper's body)",
               join=("residual",)),
    # computed by solve() from the outputs (no slot): how short a free floe's run is against the time
    # the open water needs to respond, and estimates of the relative L2 strain error
    Diagnostic(None, "gravity_time_ratio", "1", "time reached over sqrt(L/g), the gravity-wave time of a free floe: "
               "phi = 0 on the open water outside it holds for values << 1 (NaN: the walled plate)", join=("last",)),
    Diagnostic(None, "error_estimate", "1", "estimated relative L2 strain error over the output times: "
               "error_estimate_time + error_estimate_modes + error_estimate_quadrature", join=("largest",)),
    Diagnostic(None, "error_estimate_time", "1", "time-integration part (etd34: difference from a companion run at "
               "10x the tolerance / (10^0.6 - 1); rk4: summed local error estimates; dop853: NaN, it returns no "
               "error estimates, and so is error_estimate)", join=("largest",)),
    Diagnostic(None, "error_estimate_modes", "1", "modal part: strain carried by the top quarter of the retained "
               "modes", join=("largest",)),
    Diagnostic(None, "error_estimate_quadrature", "1", "quadrature part: 4 x energy_residual (the paper's rule: both "
               "are the O(dx^2) interpolation error of f; the Gauss rule keeps the energy identity to the time "
               "error, so there it is a second measure of the time part)", join=("largest",)),
    # the kernel's own bookkeeping (no stored name): the Result's time_reached, steps, ... and its
    # status message
    Diagnostic("T_REACHED", None, "s", "time the integration reached"),
    Diagnostic("STEPS", None, "1", "accepted steps"),
    Diagnostic("REJECTED", None, "1", "rejected steps"),
    Diagnostic("H_MIN", None, "s", "smallest accepted step"),
    Diagnostic("H_MAX", None, "s", "largest accepted step"),
    Diagnostic("RHS", None, "1", "forcing evaluations"),
    Diagnostic("FAIL_T", None, "s", "time of the step that failed (NaN if none)"),
    Diagnostic("FAIL_KIND", None, "1", "why the run stopped early: one of solver.layout's FAIL_* codes"),
    Diagnostic("ANSWERED_T", None, "s", "time at which the crack onsets asked were final and the run ended "
               "(solver.observe.asked; NaN: it did not end by them)"),
    Diagnostic("BREAK_T", None, "s", "time at which the tension first reached the break level and the run ended "
               "there, to break the plate (solver.breaking; NaN: it did not)"),
    Diagnostic("BREAK_X", None, "m", "place of that break", position=True),
    Diagnostic("BREAK_SURFACE", None, "1", "surface whose tension reached the break level: 0 upper, 1 lower"),
    Diagnostic("ENERGY_SCALE", None, "J m-1", "what the energy residuals are relative to: the plate's and the "
               "layer's energy at the run's start (0 from rest) plus the largest work over the run"),
)

#: the kernel's slots in order (D_<slot> = the index), and the slots that hold positions on the plate
SLOTS = tuple(row.slot for row in DIAGNOSTICS if row.slot is not None)
POSITION_SLOTS = tuple(SLOTS.index(row.slot) for row in DIAGNOSTICS if row.position)

#: diagnostic name -> its join across a run's stages (JOINS), in the order they are stored
DIAGNOSTIC_JOINS = {row.name: row.join for row in DIAGNOSTICS if row.name is not None}

#: diagnostic name -> (long_name, units, kernel slot or None), in the order they are stored
DIAGNOSTIC_INFO = {row.name: (row.long_name, row.units, None if row.slot is None else SLOTS.index(row.slot))
                   for row in DIAGNOSTICS if row.name is not None}

#: one series over the output times: the kernel's slot (S_<slot> in solver.layout), the stored
#: name (None: the kernel's own), the Result's attribute, units, long name, and where it is
#: stored: "study" (batch files and study.nc), "body" (there too, in a study with a free body),
#: "case" (a case's Dataset only: pipeline.case_dataset)
Series = namedtuple("Series", "slot name attribute units long_name stored")

SERIES = (
    Series("CONTACTS", "contact_intervals", "contact_intervals", "1", "number of disjoint contact intervals on -L..L",
           "study"),
    Series("FORCE", "force", "force", "N m-1", "force on the body per unit width", "study"),
    Series("E_PLATE", "plate_energy", "plate_energy", "J m-1", "kinetic + elastic energy of the plate per unit width",
           "case"),
    Series("E_LAYER", "layer_energy", "layer_energy", "J m-1", "energy stored in the layer per unit width", "case"),
    Series("WORK", "work_over_time", "work", "J m-1", "work done by the body on the ice up to each time, int F U dt",
           "case"),
    Series("ERR", None, None, "1", "summed local strain error estimates up to each time (the rk4 error estimate)",
           None),
    Series("BODY_POSITION", "body_position", "body_position", "m", "penetration s of the body below first touch: "
           "its lowest point is at he - s (V t for the paper's body at constant speed)", "body"),
    Series("BODY_SPEED", "body_speed", "body_speed", "m s-1", "downward speed U of the body (V for the paper's body)",
           "body"),
    Series("DISSIPATED", "dissipated_energy_over_time", "dissipated_energy", "J m-1", "energy dissipated in "
           "viscoelastic ice and layer, and taken by cracks that open over a time, up to each time (0: elastic, cracks "
           "at once)", "case"),
)
SERIES_SLOTS = tuple(row.slot for row in SERIES)

#: the columns of a tension record's rows (R_<slot> in solver.layout; solver.fracture): the stored
#: name (with _upper or _lower), units, long name
RecordColumn = namedtuple("RecordColumn", "slot name units long_name")

TENSION_RECORD = (
    RecordColumn("T", "tension_record_time", "s", "time of a node of the running-maximum tension record"),
    RecordColumn("VALUE", "tension_record_value", "1", "peak tension over x at the node (upper: +strain, lower: "
                 "-strain)"),
    RecordColumn("RATE", "tension_record_rate", "s-1", "time derivative of the peak tension at the node"),
    RecordColumn("X", "tension_record_x", "m", "position of the peak at the node (centred impact: x >= 0, mirrored "
                 "at -x; off centre: signed)"),
    RecordColumn("JOIN", "tension_record_join", "1", "1: the node continues the previous one (a Hermite piece "
                 "between them)"),
)
RECORD_SLOTS = tuple(row.slot for row in TENSION_RECORD)

#: the running-maximum tension records a run keeps (docs/model.md, "Crack onset"): name ->
#: (surface, region, what it follows); each gives crack onset for any eps_Y (solver.fracture), as
#: crack_onset_time / _x with the surface's suffix ("", "_lower") and the region's prefix ("",
#: "impact_zone_")
TENSION_RECORDS = {
    "upper": ("upper", "plate", "peak tension (+strain) of the upper surface over the whole plate (at a wall, a "
              "walled plate's confinement)"),
    "lower": ("lower", "plate", "peak tension (-strain) of the lower surface over the whole plate"),
    "impact_zone_upper": ("upper", "impact_zone", "peak tension of the upper surface within the impact zone (the "
                          "contact's farthest reach so far plus impact_zone_margin)"),
    "impact_zone_lower": ("lower", "impact_zone", "peak tension of the lower surface within the impact zone"),
}
RECORDS = tuple(TENSION_RECORDS)


def onset_names(record: str) -> tuple:
    """(time, place) names of the crack onset a record of TENSION_RECORDS gives."""
    surface, region, _ = TENSION_RECORDS[record]
    prefix, suffix = ("" if region == "plate" else "impact_zone_"), ("" if surface == "upper" else "_lower")
    return f"{prefix}crack_onset_time{suffix}", f"{prefix}crack_onset_x{suffix}"


#: the crack-onset times, one per record (each along eps_Y)
CRACK_ONSET_TIMES = tuple(onset_names(record)[0] for record in RECORDS)

#: the observers (solver.observe.asked) an output needs beyond the run itself, by name: a tension
#: record and its crack onset, a diagnostic, the contact record; every other output (the series,
#: the fields, bottoming, the energy identity, a free body's ends) comes from every run
OBSERVED_BY = {
    "tension": ("max_strain", "max_strain_x", "max_strain_time", "max_strain_lower", "max_strain_lower_x",
                "max_strain_lower_time", "max_abs_strain", "max_abs_strain_x", "max_abs_strain_time",
                "tension_record_upper", "tension_record_lower", *onset_names("upper"), *onset_names("lower")),
    # the zone's records and crack onsets (its own observer), and its maxima, which also take the
    # plate-wide peak of a step where it lies in the zone (so they need the tension observer too)
    "zone": ("contact_extent", "tension_record_impact_zone_upper", "tension_record_impact_zone_lower",
             *onset_names("impact_zone_upper"), *onset_names("impact_zone_lower")),
    "zone_maxima": ("impact_zone_max_strain", "impact_zone_max_strain_x", "impact_zone_max_strain_time",
                    "impact_zone_max_strain_lower", "impact_zone_max_strain_lower_x",
                    "impact_zone_max_strain_lower_time", "impact_zone_max_strain_at_edge",
                    "impact_zone_max_strain_lower_at_edge"),
    "contacts": ("max_contact_intervals", "contact_record"),
    "layer_maxima": ("max_force", "max_force_time", "max_compression", "max_compression_time"),
    # a floe's maxima, located on the dense output at the run's end (the walls' need nothing more)
    "floe_maxima": ("max_strain", "max_strain_x", "max_strain_time", "max_strain_lower", "max_strain_lower_x",
                    "max_strain_lower_time", "max_abs_strain", "max_abs_strain_x", "max_abs_strain_time",
                    "impact_zone_max_strain", "impact_zone_max_strain_x", "impact_zone_max_strain_time",
                    "impact_zone_max_strain_lower", "impact_zone_max_strain_lower_x",
                    "impact_zone_max_strain_lower_time", "impact_zone_max_strain_at_edge",
                    "impact_zone_max_strain_lower_at_edge"),
}
#: every output some observer produces (the others come from every run)
OBSERVED = frozenset(name for names in OBSERVED_BY.values() for name in names)
#: the record whose crossings answer each crack-onset output (time and place)
ONSET_RECORD = {name: record for record in RECORDS for name in onset_names(record)}


def records_kept(asked) -> frozenset:
    """The tension records (of RECORDS) a run asked for ``asked`` (names of OUTPUT_NAMES; None:
    every one) reports: those asked by name, and those whose crack onsets are asked."""
    if asked is None:
        return frozenset(RECORDS)
    return frozenset(record for record in RECORDS if f"tension_record_{record}" in asked
                     or any(ONSET_RECORD[name] == record for name in asked if name in ONSET_RECORD))


#: what a run that breaks reports beyond every run's outputs (breaking_values below;
#: docs/model.md, "Breaking into parts"): the stored name, units, long name, and along what:
#: "case" one value, "break" one per break in the order they happened (NaN past the run's
#: breaks), "t" one per output time. Stored in a study where some case has fracture = "break".
BreakingOutput = namedtuple("BreakingOutput", "name units long_name along")

BREAKING_OUTPUTS = (
    BreakingOutput("first_break_time", "s", "time of the first break of the ice (NaN: it did not break)", "case"),
    BreakingOutput("break_count", "1", "breaks of the ice over the run (on the half plate of a centred impact, a "
                   "break at x > 0 stands for the one at -x too)", "case"),
    BreakingOutput("part_count", "1", "parts of the whole plate at the end of the run (1: unbroken)", "case"),
    BreakingOutput("breakthrough_time", "s", "time the body broke through the ice: a break on each side of the "
                   "body's centre, cutting the ice under it from the walls (NaN: it did not)", "case"),
    BreakingOutput("breakthrough_penetration", "m", "penetration of the body below first touch at "
                   "breakthrough_time", "case"),
    BreakingOutput("removed_energy", "J m-1", "energy the breaks removed over the run: what the state carried "
                   "onto the parts' modes leaves out (E_plate + E_layer + D + removed_energy = work)", "case"),
    BreakingOutput("break_time", "s", "time of each break", "break"),
    BreakingOutput("break_x", "m", "place of each break (centred impact: x >= 0, with its mirror at -x)", "break"),
    BreakingOutput("break_surface", "1", "surface whose tension reached yield_strain at each break: 0 upper, "
                   "1 lower", "break"),
    BreakingOutput("break_part_count", "1", "parts of the whole plate after each break", "break"),
    BreakingOutput("break_removed_energy", "J m-1", "energy each break removed", "break"),
    BreakingOutput("part_count_over_time", "1", "parts of the whole plate at each output time", "t"),
)
BREAKING_INFO = {row.name: (row.long_name, row.units, row.along) for row in BREAKING_OUTPUTS}


def breaking_values(result, slots: int) -> dict:
    """What a run reports of its breaking (BREAKING_OUTPUTS): :func:`break_table` of its breaks
    (Result.breaking; a run that does not break has none) over its output times."""
    return break_table(result.breaking.breaks if result.breaking is not None else (), result.times, result.valid,
                       slots)


def break_table(events, times, valid, slots: int) -> dict:
    """The breaking outputs as arrays from a run's breaks (solver.spec.BreakEvent, in the order they
    happened): name -> a float (along "case"), an array of ``slots`` floats (along "break": the
    breaks in order, NaN after them; breaks beyond ``slots`` are counted but not listed) or one
    value per output time (along "t": NaN where ``valid`` is not). Without breaks: no break, one
    part, no breakthrough."""
    summary = Breaking(tuple(events), None, (), False)
    out = {"first_break_time": summary.first_break_time, "break_count": float(summary.break_count),
           "part_count": float(summary.parts), "breakthrough_time": summary.breakthrough_time,
           "breakthrough_penetration": summary.breakthrough_penetration,
           "removed_energy": float(sum(e.removed_energy for e in events if not math.isnan(e.removed_energy)))}
    columns = {"break_time": "time", "break_x": "x", "break_surface": "surface", "break_part_count": "parts",
               "break_removed_energy": "removed_energy"}
    for name, key in columns.items():
        values = np.full(slots, np.nan)
        for k, event in enumerate(events[:slots]):
            value = getattr(event, key)
            values[k] = ("upper", "lower").index(value) if key == "surface" else value
        out[name] = values
    times = np.asarray(times, dtype=float)
    parts = np.ones(times.size)
    for event in events:                              # an output at a break's time is still before it
        parts[times > event.time] = event.parts
    out["part_count_over_time"] = np.where(valid, parts, np.nan)
    return out


#: every output a run can be asked for by name (the fields have solve's own argument)
OUTPUT_NAMES = (*DIAGNOSTIC_INFO, *(f"tension_record_{r}" for r in RECORDS), "contact_record", *ONSET_RECORD,
                *(row.name for row in SERIES if row.name), *BREAKING_INFO)

#: field name -> (long_name, units)
FIELD_INFO = {
    "deflection": ("ice deflection w, positive upwards", "m"),
    "strain": ("bending strain on the upper ice surface (positive: tension)", "1"),
    "layer_pressure": ("reaction pressure of the elastic layer K f(delta)", "Pa"),
    "compression": ("relative compression delta of the elastic layer", "1"),
}
FIELDS = tuple(FIELD_INFO)


#: the slot constants of solver.layout, generated from the tables above: prefix, slots, count name
LAYOUT_TABLES = (("D", SLOTS, "N_DIAG"), ("R", RECORD_SLOTS, "N_REC"), ("S", SERIES_SLOTS, "N_SERIES"))
LAYOUT_BEGIN = "# -- generated from solver.outputs (make layout-slots; tests/test_architecture.py checks it) --"
LAYOUT_END = "# -- end of the generated slots --"


def layout_slots() -> str:
    """solver.layout's block of slot constants, D_<slot>, R_<slot>, S_<slot> = their index in
    DIAGNOSTICS, TENSION_RECORD and SERIES, as literal names (a grep or an editor finds them)."""
    lines = [LAYOUT_BEGIN]
    for prefix, slots, count in LAYOUT_TABLES:
        lines += [f"{prefix}_{slot} = {index}" for index, slot in enumerate(slots)]
        lines.append(f"{count} = {len(slots)}")
    return "\n".join([*lines, LAYOUT_END]) + "\n"


def write_layout_slots(path) -> bool:
    """Rewrite the generated block of solver/layout.py at ``path``; returns whether it changed."""
    text = Path(path).read_text()
    start, end = text.index(LAYOUT_BEGIN), text.index(LAYOUT_END) + len(LAYOUT_END) + 1
    new = text[:start] + layout_slots() + text[end:]
    if new != text:
        Path(path).write_text(new)
    return new != text


if __name__ == "__main__":
    print("solver/layout.py", "rewritten" if write_layout_slots(Path(__file__).with_name("layout.py")) else "unchanged")
