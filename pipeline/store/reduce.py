"""What study.nc stores of a batch file, computed where the batch is (a worker, or the runner
without a cluster): the per-case variables of the cases asked for, crack onset along the study's
eps_Y from the tension records, the ragged records, and the errors against each case's reference
run. pipeline/store/combine.py writes the result into study.nc."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from solver.outputs import records_kept

from .casefile import DamagedFile, read_batch_arrays, tension_records
from .fracture import CRACK_INFO, onset_from_records
from ..common.tables import CONTACT_RECORD_INFO, RECORD_NAMES, TENSION_RECORD_INFO, computes

ERROR_INFO = {
    "error_strain": ("relative L2 difference of the strain from the reference run over the snapshots "
                     "both reached", "1"),
    "error_max_strain": ("relative difference of max_strain from the reference run", "1"),
    "error_crack_onset_time": ("largest relative difference over eps_Y of crack_onset_time from the "
                               "reference run", "1"),
    "error_contact_intervals": ("largest difference of contact_intervals from the reference run "
                                "over the snapshots", "1"),
}


def errors_against(case: dict, ref: dict, eps_Y) -> dict:
    """Errors of one case against its reference run; each a dict with strain (t, x),
    max_strain, contact_intervals (t) and records (surface -> rows)."""
    out = {name: np.nan for name in ERROR_INFO}
    a, b = case["strain"], ref["strain"]
    both = np.all(np.isfinite(a), axis=-1) & np.all(np.isfinite(b), axis=-1)
    if both.any() and np.linalg.norm(b[both]) > 0:
        out["error_strain"] = float(np.linalg.norm(a[both] - b[both]) / np.linalg.norm(b[both]))
    m, mr = float(case["max_strain"]), float(ref["max_strain"])
    out["error_max_strain"] = abs(m - mr) / abs(mr) if mr else np.nan
    tc = onset_from_records(case["records"], eps_Y)["crack_onset_time"]
    tr = onset_from_records(ref["records"], eps_Y)["crack_onset_time"]
    both = np.isfinite(tc) & np.isfinite(tr)
    if both.any():
        out["error_crack_onset_time"] = float(np.max(np.abs(tc[both] / tr[both] - 1)))
    c, cr = case["contact_intervals"], ref["contact_intervals"]
    ok = np.isfinite(c) & np.isfinite(cr)
    out["error_contact_intervals"] = float(np.max(np.abs(c[ok] - cr[ok]))) if ok.any() else np.nan
    return out


def _for_errors(ds: dict, position) -> dict:
    return {"strain": ds["strain"][position], "max_strain": ds["max_strain"][position],
            "contact_intervals": ds["contact_intervals"][position],
            "records": tension_records(ds, (position,))}


def reduce_arrays(ds: dict, positions: np.ndarray, eps_Y: list, names: list, records: bool,
                  outputs=None) -> dict:
    """What study.nc stores for the cases at ``positions`` of a batch (its variables as
    arrays, from the file or still in the worker's memory): the per-case variables, crack
    onset along eps_Y from the tension records, and (records) the ragged records. ``outputs``:
    the study's [output] outputs (None: every one); an observed output not among them is left
    out (NaN in study.nc) and so is a record not among them (no rows), also where the stored
    run computed it (a run that computed everything, serving a study that asks for less)."""
    out = {}
    for name in names:
        if name in ds and name not in ("tension_record_count", "contact_change_entries") and computes(outputs, name):
            out[name] = ds[name][positions]
    crack = {name: [] for name in CRACK_INFO}
    for p in positions:
        for name, values in onset_from_records(tension_records(ds, (int(p),)), eps_Y).items():
            crack[name].append(values)
    for name in CRACK_INFO:
        if computes(outputs, name):
            out[name] = np.array(crack[name]).reshape(len(positions), len(eps_Y))
    if records:
        out.update(_records(ds, positions, outputs))
    return out


def _records(ds: dict, positions: np.ndarray, outputs) -> dict:
    """The ragged records of the cases at ``positions``: the tension records' rows and the
    contact record's entries, each a record the study computes (``outputs``)."""
    out = {}
    counts = ds["tension_record_count"]
    starts = (np.cumsum(counts.ravel()) - counts.ravel()).reshape(counts.shape)
    names = records_kept(outputs)
    kept = np.array([record in names for record in RECORD_NAMES])
    pieces = [(int(starts[p, s]), int(counts[p, s])) for p in positions for s in range(len(RECORD_NAMES)) if kept[s]]
    out["tension_record_count"] = np.where(kept, counts[positions], 0)
    for name in TENSION_RECORD_INFO:
        col = ds[name]
        out[name] = np.concatenate([col[a:a + n] for a, n in pieces] or [np.empty(0)])
    entries = ds["contact_change_entries"]
    cstart = np.cumsum(entries) - entries
    contacts = computes(outputs, "contact_record")
    out["contact_change_entries"] = entries[positions] if contacts else np.zeros(len(positions), dtype=entries.dtype)
    for name in CONTACT_RECORD_INFO:
        col = ds[name]
        out[name] = np.concatenate([col[cstart[p]:cstart[p] + entries[p]] for p in positions if contacts]
                                   or [np.empty(0)])
    return out


def reduce_batch(path: str, sha256: str, rows: list, eps_Y: list, names: list, records: bool,
                 refs: dict, outputs=None) -> dict:
    """Read one batch file (checked against its checksum) and return what study.nc stores for
    the cases ``rows`` ([position in the batch, reference key or None]); ``refs``: reference
    key -> [path, sha256, position]. A damaged file returns {"damaged": [file names], ...}."""
    wanted = [*names, "tension_record_count", *TENSION_RECORD_INFO, "contact_change_entries",
              *CONTACT_RECORD_INFO, "strain", "max_strain", "contact_intervals"]
    try:
        ds = read_batch_arrays(Path(path), sha256, wanted)
    except DamagedFile as err:
        return {"damaged": [Path(path).name], "message": str(err)}
    positions = np.array([r[0] for r in rows], dtype=np.int64)
    out = reduce_arrays(ds, positions, eps_Y, names, records, outputs)
    if any(r[1] is not None for r in rows):
        cache, damaged = {}, []
        errors = {name: np.full(len(rows), np.nan) for name in ERROR_INFO}
        for k, (p, key) in enumerate(rows):
            if key is None:
                continue
            ref_path, ref_sha, ref_pos = refs[key]
            if ref_path not in cache:
                try:
                    cache[ref_path] = read_batch_arrays(Path(ref_path), ref_sha, wanted)
                except DamagedFile:
                    cache[ref_path] = None
                    damaged.append(Path(ref_path).name)
            if cache[ref_path] is None:
                continue
            for name, value in errors_against(_for_errors(ds, int(p)), _for_errors(cache[ref_path], ref_pos),
                                              eps_Y).items():
                errors[name][k] = value
        if damaged:
            return {"damaged": damaged, "message": "a reference run's batch file is damaged"}
        out.update(errors)
        out["reference_case_id"] = np.array([key or "" for _, key in rows], dtype=object)
    return out
