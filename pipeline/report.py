"""What a study has done, as a table: its cases, the keys that vary, each case's state (from the
ledger alone), and one-line summaries. Used by ``status``, by a dry run and by a run's report."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from .store.ledger import Ledger


def ledger_states(study, out_dir: Path, ledger=None) -> dict:
    """case_id -> 'ok' | failed status | 'pending', from the study's ledger alone (no result
    file is opened)."""
    ledger = ledger if ledger is not None else Ledger.load(out_dir)
    recorded = ledger.states(study.wider_ids)
    return {cid: recorded.get(cid, "pending") for cid in study.run_ids}


#: the case table lists at most this many rows unless --all
TABLE_ROWS = 200


def _row_values(study, cid: str, flat: int | None, keys: list) -> list:
    if flat is not None and study.grid:
        idx = np.unravel_index(flat, study.shape)
        return [_fmt(study.grid[k][int(j)]) for k, j in zip(keys, idx)]
    case = study.run(cid)
    return [_fmt(case.value(k)) for k in keys]


def print_table(study, states: dict, stream=None, all_rows: bool = False, only=None,
                summary: bool = True) -> None:
    """The case table (case_id, the keys that vary, state, and a role column when the study
    has reference runs) and a one-line summary. only: the run ids to list (default all)."""
    stream = stream or sys.stdout                       # as it is now (a notebook may replace it)
    keys = study.varying_keys
    first = study.first_position
    with_role = len(study.run_ids) > len(study.case_id_set)
    header = ["case_id", *keys, "state", *(["role"] if with_role else [])]
    listed = study.run_ids if only is None else only
    ids = listed if all_rows else listed[:TABLE_ROWS]
    rows = []
    for cid in ids:
        flat = first.get(cid)
        role = ["reference" if flat is None else "case"] if with_role else []
        rows.append([cid, *_row_values(study, cid, flat, keys), states[cid], *role])
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    for r in [header, *rows]:
        stream.write("  ".join(str(v).ljust(w) for v, w in zip(r, widths)).rstrip() + "\n")
    if len(ids) < len(listed):
        stream.write(f"... {len(listed) - len(ids)} more rows (--all lists them)\n")
    if with_role:
        stream.write("role: case = a point of the study; reference = a converged run ([reference]) that "
                     "the cases' errors are measured against\n")
    if summary:
        counts = {}
        for s in states.values():
            counts[s] = counts.get(s, 0) + 1
        text = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
        computes = what_a_case_computes(study)
        if computes:
            stream.write(computes + "\n")
        stream.write(f"{study.name}: {study_size(study)}: {text}\n")


def what_a_case_computes(study) -> str | None:
    """One line: the outputs each case computes ([output] outputs, solver.observe.asked) and
    when its run ends; for a study whose cases compute every output, the outputs an observer
    makes that it reads ([output] outputs = "read" would compute only those), None where it
    reads them all or none."""
    from solver.outputs import OBSERVED          # (the solver's package loads numba: the doors do not)
    out = study.output
    if out.outputs is None:
        read = study.outputs_read()
        if not read or len(read) >= len(OBSERVED):
            return None
        named = ", ".join(read) if len(read) <= 6 else f"{len(read)} of the {len(OBSERVED)}"
        return (f"each case computes every output; the study reads {named} that observers make "
                f'([output] outputs = "read" computes only those)')
    text = f"each case computes {', '.join(out.outputs)} (the others are NaN)"
    if out.end == "answered":
        text += f"; its run ends when its crack onsets up to eps_Y = {out.answer_eps_Y:g} are final"
    return text


def study_size(study) -> str:
    """'N cases' with the distinct runs and reference runs where they differ."""
    n_ref = len(study.run_ids) - len(study.case_id_set)
    distinct = len(study.case_id_set)
    text = f"{study.n_cases} cases"
    if distinct != study.n_cases:
        text += f" ({distinct} distinct runs)"
    if n_ref:
        text += f" and {n_ref} reference runs"
    return text


def _fmt(value) -> str:
    return value if isinstance(value, str) else f"{value:g}"


def case_label(study, cid: str) -> str:
    if cid not in study.case_id_set:
        return "reference run"
    flat = study.first_position[cid]
    keys = list(study.grid) if study.grid else [k for k in study.case_list[flat] if k not in ("reference", "group")]
    return ", ".join(f"{k}={v}" for k, v in zip(keys, _row_values(study, cid, flat, keys))) or f"case {flat}"
