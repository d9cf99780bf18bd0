"""The table of what a run reports (solver.outputs): the kernels' layout is generated from it, in
the shape the kernels assume, and every stored diagnostic is described once."""
import numpy as np

import solver.layout as kn
from solver import DIAGNOSTIC_INFO, Parameters, Settings, solve
from solver.outputs import DIAGNOSTIC_JOINS, DIAGNOSTICS, JOINS, POSITION_SLOTS, RECORDS, SLOTS


def test_the_layout_is_the_table():
    """D_<slot> is the slot's row among the rows with a slot; names and slots are unique."""
    assert len(set(SLOTS)) == len(SLOTS) == kn.N_DIAG
    for index, slot in enumerate(SLOTS):
        assert getattr(kn, f"D_{slot}") == index
    names = [row.name for row in DIAGNOSTICS if row.name is not None]
    assert len(set(names)) == len(names) == len(DIAGNOSTIC_INFO)
    assert list(DIAGNOSTIC_INFO) == names


def test_the_triples_are_where_the_kernels_reach_them():
    """Each surface's (value, x, time) at the upper's slot + 3 (plate-wide and impact zone), its
    zone edge flag at + 1: the kernels index them so."""
    for upper, lower in (("MAX_UPPER", "MAX_LOWER"), ("ZONE_UPPER", "ZONE_LOWER")):
        for tail in ("", "_X", "_T"):
            assert getattr(kn, f"D_{lower}{tail}") == getattr(kn, f"D_{upper}{tail}") + 3
    assert kn.D_MAX_UPPER_X == kn.D_MAX_UPPER + 1 and kn.D_MAX_UPPER_T == kn.D_MAX_UPPER + 2
    assert kn.D_ZONE_UPPER_X == kn.D_ZONE_UPPER + 1 and kn.D_ZONE_UPPER_T == kn.D_ZONE_UPPER + 2
    assert kn.D_ZONE_LOWER_EDGE == kn.D_ZONE_UPPER_EDGE + 1


def test_every_row_is_described():
    for row in DIAGNOSTICS:
        assert row.long_name and row.units, row
        assert row.slot is not None or row.name is not None, row
    assert {SLOTS[i] for i in POSITION_SLOTS} == {"MAX_UPPER_X", "MAX_LOWER_X", "MAX_ABS_X", "ZONE_UPPER_X",
                                                  "ZONE_LOWER_X", "BOTTOM_X", "BREAK_X"}
    assert all(DIAGNOSTICS[[r.slot for r in DIAGNOSTICS].index(SLOTS[i])].units == "m" for i in POSITION_SLOTS)


def test_positions_are_on_the_plate():
    """An off-centre body's positions are moved from the kernel's coordinates (0 at -L) to x:
    mirroring the body mirrors them (a fixed step: the mirror image is exact to round-off)."""
    s = Settings(error_estimate=False, fixed_step=0.05)
    right, left = (solve(Parameters(Nmod=10, x0=x0), s, fields=(), t_end=0.05) for x0 in (1.0, -1.0))
    for i in POSITION_SLOTS:
        name = next((n for n, (_, _, slot) in DIAGNOSTIC_INFO.items() if slot == i), None)
        if name is not None and np.isfinite(right.diagnostics[name]):       # (a break's: not stored)
            assert abs(right.diagnostics[name] + left.diagnostics[name]) < 1e-6 * right.parameters.L, name


def test_the_series_and_record_layouts_are_their_tables():
    """S_<slot> and R_<slot> are the rows of solver.outputs.SERIES and TENSION_RECORD; every
    series a Result carries is a row, and the study's and a case's variables take their names
    and units from there."""
    from pipeline.store.dataset import ENERGY_INFO
    from pipeline.common.tables import BODY_SERIES_INFO, SERIES_INFO, TENSION_RECORD_INFO
    from solver.outputs import SERIES, TENSION_RECORD
    for index, row in enumerate(SERIES):
        assert getattr(kn, f"S_{row.slot}") == index and row.units and row.long_name
    assert kn.N_SERIES == len(SERIES) and kn.N_REC == len(TENSION_RECORD)
    for index, row in enumerate(TENSION_RECORD):
        assert getattr(kn, f"R_{row.slot}") == index
    stored = {**SERIES_INFO, **BODY_SERIES_INFO, **{k: v[1:] for k, v in ENERGY_INFO.items()}}
    assert {row.name for row in SERIES if row.name} == set(stored) - {"time"}
    assert list(TENSION_RECORD_INFO) == [row.name for row in TENSION_RECORD]
    r = solve(Parameters(Nmod=6), Settings(error_estimate=False), fields=(), t_end=0.01)
    for row in SERIES:
        if row.attribute:
            assert getattr(r, row.attribute).shape == r.times.shape


def test_every_stored_diagnostic_declares_its_join_across_stages():
    """A run in stages (one that breaks) joins each stored diagnostic by the rule its row declares
    (solver.outputs.JOINS): a new diagnostic without one fails here, not silently as the last
    stage's value. Each join names what it reads: a record and its column, diagnostics declared
    before it ("larger"), or a diagnostic ("with", "first")."""
    names = [row.name for row in DIAGNOSTICS if row.name is not None]
    assert list(DIAGNOSTIC_JOINS) == names
    for position, (name, join) in enumerate(DIAGNOSTIC_JOINS.items()):
        assert join is not None and join[0] in JOINS, name
        kind, *args = join
        if kind == "record":
            assert args[0] in RECORDS and args[1] in ("value", "x", "time"), name
        elif kind == "larger":
            assert all(a in names[:position] for a in args[:2]) and args[2] in ("", "_x", "_time"), name
            assert all(a + args[2] in names[:position] for a in args[:2]), name
        elif kind in ("with", "first"):
            assert len(args) == 1 and args[0] in names, name
        else:
            assert not args, name
    # a maximum's place, time and flags go with it: "with" names a maximum (the largest over the
    # stages, or a record's value), and a record's place and time come from its value's record
    for name, (kind, *args) in DIAGNOSTIC_JOINS.items():
        if kind == "with":
            assert DIAGNOSTIC_JOINS[args[0]][0] == "largest" or DIAGNOSTIC_JOINS[args[0]][-1] == "value", name
        if kind in ("record", "larger") and name.endswith(("_x", "_time")):
            tail = "_x" if name.endswith("_x") else "_time"
            base = DIAGNOSTIC_JOINS[name[:-len(tail)]]
            assert (kind, *args) == ((*base[:2], tail[1:]) if kind == "record" else (*base[:3], tail)), name
