"""Batch files: the arrays of a batch of cases, written as one file and read back by checksum.

A batch file ``batches/<sha256>.nc`` holds the cases of one task along a ``case`` dimension
(coordinate: the case ids), each with everything a case produces:

- the requested fields over (case, t, x), x as a fraction of the case's L;
- the series over (case, t): ``time``, ``contact_intervals``, ``force``, and in a study with a
  free body (a finite ``body_mass``) ``body_position`` and ``body_speed``;
- per case: the diagnostics, the run records (t_sc, steps, run_time, ...), ``status`` and
  ``message``, its parameters and ``solver_settings`` (JSON);
- in a study where some case breaks (fracture = "break"): what a run that breaks reports
  (solver.outputs.BREAKING_OUTPUTS) per case, per case and break (along ``break_number``) and
  per case and output time;
- the event records as contiguous ragged arrays: ``tension_record_count`` (case, surface)
  nodes of each case and surface, in that order, along ``tension_node``; and
  ``contact_change_entries`` (case) along ``contact_change``.

The file is named by the SHA-256 of its bytes and written atomically (temporary file in the
same directory, fsync, ``os.replace``, fsync of the directory). Its name is therefore its
checksum: a reader hashes the bytes before it opens anything (:func:`read_batch`), so a
damaged file is recognised without being parsed, and no netCDF library ever sees one.
"""
from __future__ import annotations

import hashlib
import json
import os
import time
from pathlib import Path

import numpy as np

from solver import DIAGNOSTIC_INFO, FIELD_INFO, PARAMETER_INFO
from solver.outputs import breaking_values
from solver.outputs import BREAKING_INFO
from solver.parameters import CHOICES

from ..common import provenance
from ..study.case import Case, x_fractions
from ..study.identity import SCHEMA_VERSION
from ..common.tables import (BODY_SERIES_INFO, BREAKING_DIMS, CONTACT_RECORD_INFO, RECORD_INFO, SERIES_INFO,
                             RECORD_LONG_NAME, RECORD_NAMES, TENSION_RECORD_INFO, TEXT_INFO,
                             diagnostic_values, run_records)

class CaseWriteError(OSError):
    """A batch file could not be written (disk full, permissions): the study stops (exit 74)."""


BATCH_TITLE = "floe-impact batch"


def _or_nan(compute, size=None):
    """compute(), or NaN (an array of size NaN) if it raises: for the record of a failed case."""
    try:
        with np.errstate(all="ignore"):
            return compute()
    except Exception:
        return np.nan if size is None else np.full(size, np.nan)


def case_arrays(case: Case, result=None, status=None, message="") -> dict:
    """One case's data as plain arrays (no case dimension), from a solver Result or, with
    result=None, all NaN with the given status and message."""
    p = case.parameters
    # a case that failed: its record must not fail in turn (NaN for what cannot be computed)
    t_sec = case.times_seconds() if result is not None else _or_nan(case.times_seconds,
                                                                      case.requested_times().size)
    with np.errstate(invalid="ignore"):
        inside = t_sec <= (case.t_end if result is not None else _or_nan(lambda: case.t_end)) * (1 + 1e-12)
    T = t_sec.size
    out = {}
    for name in case.fields:
        arr = np.full((T, case.x_points), np.nan)
        if result is not None:
            arr[inside] = result.fields[name]
        out[name] = arr

    def series(values):
        arr = np.full(T, np.nan)
        if values is not None:
            arr[inside] = values
        return arr

    out["time"] = np.where(inside, t_sec, np.nan)
    for name in ("contact_intervals", "force", *(BODY_SERIES_INFO if case.body else ())):
        out[name] = series(None if result is None else getattr(result, name))
    out.update(diagnostic_values(result))
    if case.break_slots:
        out.update(_breaking_arrays(case, result, inside))
    out.update(run_records(result, _or_nan(lambda: p.time_scale), _or_nan(lambda: p.stage_duration)))
    none = result is None
    out["status"] = status or result.status
    out["message"] = message if none else result.message
    for key, value in p.as_dict().items():
        out[key] = value
    out["solver_settings"] = json.dumps(case.settings.as_dict())
    out["tension_records"] = [np.empty((0, 5)) if none else np.asarray(result.tension_record[s]) for s in RECORD_NAMES]
    contacts = None if none else result.contact_record
    out["contact_record"] = np.empty((0, 2)) if contacts is None else np.asarray(contacts)
    return out


def _breaking_arrays(case: Case, result, inside) -> dict:
    """What a run that breaks reports, over the case's output times (NaN past its run, and all
    NaN for a case with no result)."""
    values = breaking_values(result, case.break_slots) if result is not None else None
    out = {}
    for name, (_, _, along) in BREAKING_INFO.items():
        shape = {"case": (), "break": (case.break_slots,), "t": (inside.size,)}[along]
        arr = np.full(shape, np.nan)
        if values is not None:
            if along == "t":
                arr[inside] = values[name]
            else:
                arr[...] = values[name]
        out[name] = arr
    return out


def time_coordinate_attrs(unit: str) -> tuple:
    """(long_name, units) of the t coordinate for an [output] times unit."""
    if unit == "t_sc":
        return "time in units of the case's t_sc", "1"
    if unit == "s":
        return "time since first touch", "s"
    return "time as a fraction of the case's impact stage (stage_duration)", "1"


def _attrs(long_name, units=None):
    return {"long_name": long_name, **({"units": units} if units is not None else {})}


def batch_dataset(cases: list, arrays: list) -> dict:
    """One batch as {"data", "coords": name -> (dims, array, attrs), "attrs"} from its cases
    (same output request) and their arrays; written with netCDF4 by write_batch, opened by
    anyone with xarray.open_dataset."""
    first = cases[0]
    n = len(cases)
    data = {}
    for name in first.fields:
        long_name, units = FIELD_INFO[name]
        data[name] = (("case", "t", "x"), np.stack([a[name] for a in arrays]), _attrs(long_name, units))
    for name, (long_name, units) in {**SERIES_INFO, **(BODY_SERIES_INFO if first.body else {})}.items():
        data[name] = (("case", "t"), np.stack([a[name] for a in arrays]), _attrs(long_name, units))
    for name, (long_name, units, _) in DIAGNOSTIC_INFO.items():
        data[name] = (("case",), np.array([a[name] for a in arrays], dtype=float), _attrs(long_name, units))
    if first.break_slots:
        for name, (long_name, units, along) in BREAKING_INFO.items():
            dims = ("case",) + BREAKING_DIMS[along]
            data[name] = (dims, np.array([a[name] for a in arrays], dtype=float), _attrs(long_name, units))
    for name, (long_name, units) in RECORD_INFO.items():
        data[name] = (("case",), np.array([a[name] for a in arrays], dtype=float), _attrs(long_name, units))
    for name, long_name in TEXT_INFO.items():
        data[name] = (("case",), np.array([a[name] for a in arrays], dtype=object), _attrs(long_name))
    data["solver_settings"] = (("case",), np.array([a["solver_settings"] for a in arrays], dtype=object),
                               _attrs("solver settings of the case (JSON)"))
    for key, (long_name, units) in PARAMETER_INFO.items():
        values = np.array([a[key] for a in arrays], dtype=object if key in CHOICES else None)
        data[key] = (("case",), values, _attrs(long_name, None if key in CHOICES else units))
    counts = np.array([[r.shape[0] for r in a["tension_records"]] for a in arrays],
                      dtype=np.int64).reshape(n, len(RECORD_NAMES))
    data["tension_record_count"] = (("case", "tension_record"), counts,
                                    {**_attrs("nodes of the case's tension record", "1"),
                                     "sample_dimension": "tension_node"})
    rows = np.concatenate([r for a in arrays for r in a["tension_records"]] or [np.empty((0, 5))])
    for col, (name, (long_name, units)) in enumerate(TENSION_RECORD_INFO.items()):
        data[name] = (("tension_node",), rows[:, col], _attrs(long_name, units))
    entries = np.array([a["contact_record"].shape[0] for a in arrays], dtype=np.int64)
    data["contact_change_entries"] = (("case",), entries,
                                      {**_attrs("entries of the case's contact record", "1"),
                                       "sample_dimension": "contact_change"})
    rows = np.concatenate([a["contact_record"] for a in arrays] or [np.empty((0, 2))])
    for col, (name, (long_name, units)) in enumerate(CONTACT_RECORD_INFO.items()):
        data[name] = (("contact_change",), rows[:, col], _attrs(long_name, units))
    t_long, t_units = time_coordinate_attrs(first.times_spec["unit"])
    coords = {"case": ("case", np.array([c.case_id for c in cases], dtype=object), _attrs("case id")),
              "tension_record": ("tension_record", np.array(RECORD_NAMES, dtype=object), _attrs(RECORD_LONG_NAME)),
              "t": ("t", first.requested_times(), _attrs(t_long, t_units)),
              "x": ("x", x_fractions(first.x_points),
                    _attrs("position along the plate as a fraction of the case's half-length L", "1"))}
    attrs = {"title": BATCH_TITLE, "schema_version": SCHEMA_VERSION,
             "output_times": json.dumps(first.times_spec), "fields": json.dumps(list(first.fields)),
             "end": first.end, **provenance.attributes(f"ran {n} case(s) as one batch")}
    if first.outputs is not None:              # computed only these (solver.observe.asked)
        attrs["outputs"] = json.dumps(list(first.outputs))
    if first.end == "answered":
        attrs["answered_eps_Y"] = first.answer_eps_Y
    return {"data": data, "coords": coords, "attrs": attrs}


def write_netcdf(spec: dict, path: Path) -> None:
    """Write {"data", "coords", "attrs"} (name -> (dims, array, attrs)) with netCDF4 directly:
    floats with a NaN fill value, strings as variable-length strings."""
    import netCDF4
    variables = {**spec["coords"], **spec["data"]}
    coordinates = set(spec["coords"])                # CF 2.5.1: a coordinate variable has no _FillValue
    with netCDF4.Dataset(path, "w", format="NETCDF4") as nc:
        sizes = {}
        for dims, arr, _ in variables.values():
            sizes.update(zip(dims, np.shape(arr)))
        for dim, n in sizes.items():
            nc.createDimension(dim, n if n else None)
        for name, (dims, arr, attrs) in variables.items():
            arr = np.asarray(arr)
            if arr.dtype.kind in "OUS":
                var = nc.createVariable(name, str, dims)
                arr = arr.astype(object)
            elif arr.dtype.kind == "f":
                var = nc.createVariable(name, "f8", dims, fill_value=False if name in coordinates else np.nan)
            else:
                var = nc.createVariable(name, arr.dtype, dims)
            var.setncatts(attrs)
            if arr.size:
                var[...] = arr
        nc.setncatts(spec["attrs"])


def _fsync_dir(directory: Path) -> None:
    dfd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(dfd)
    finally:
        os.close(dfd)


def temporary_path(path: Path) -> Path:
    """A hidden temporary name beside path, unique to this process and moment."""
    return path.with_name(f".{path.name}.tmp-{os.getpid()}-{time.monotonic_ns()}")


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def write_batch(ds: dict, batches_dir: Path) -> dict:
    """Write a batch (batch_dataset) atomically under the name of its checksum; returns its
    ledger fields."""
    batches_dir = Path(batches_dir)
    tmp = temporary_path(batches_dir / "batch.nc")
    try:
        write_netcdf(ds, tmp)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        sha = file_sha256(tmp)
        path = batches_dir / f"{sha[:32]}.nc"
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(batches_dir)
    st = path.stat()
    return {"file": path.name, "sha256": sha, "size": st.st_size, "mtime_ns": st.st_mtime_ns}


class DamagedFile(Exception):
    """A result file whose bytes do not match its checksum (or that cannot be read)."""


def read_batch(path: Path, sha256: str | None = None):
    """A batch file's dataset, loaded and closed, after its bytes are checked against its
    checksum (the ledger's, or the one in its name). Raises DamagedFile otherwise."""
    import xarray as xr
    path = Path(path)
    _verify(path, sha256)
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            ds = ds.load()
    except Exception as err:
        raise DamagedFile(f"{path.name}: {type(err).__name__}: {err}") from None
    if ds.attrs.get("title") != BATCH_TITLE or ds.attrs.get("schema_version") != SCHEMA_VERSION:
        raise DamagedFile(f"{path.name}: not a batch file of schema {SCHEMA_VERSION}")
    return ds


def _verify(path: Path, sha256: str | None) -> None:
    expected = sha256 or path.stem
    try:
        actual = file_sha256(path)
    except OSError as err:
        raise DamagedFile(f"{path.name}: {err.strerror or err}") from None
    if not actual.startswith(expected) or not actual.startswith(path.stem):
        raise DamagedFile(f"{path.name}: its bytes do not match its checksum")


def read_batch_arrays(path: Path, sha256: str | None, names) -> dict:
    """Variables of a batch file as numpy arrays (NaN where nothing was stored), after its
    bytes are checked against its checksum; the names it lacks are left out. Raises
    DamagedFile. netCDF4 directly: a tenth of the time xarray takes for the same read."""
    import netCDF4
    path = Path(path)
    _verify(path, sha256)
    try:
        with netCDF4.Dataset(path, "r") as nc:
            if getattr(nc, "title", None) != BATCH_TITLE or getattr(nc, "schema_version", None) != SCHEMA_VERSION:
                raise DamagedFile(f"{path.name}: not a batch file of schema {SCHEMA_VERSION}")
            nc.set_auto_mask(False)
            return {name: np.asarray(nc[name][...]) for name in names if name in nc.variables}
    except DamagedFile:
        raise
    except Exception as err:
        raise DamagedFile(f"{path.name}: {type(err).__name__}: {err}") from None


def ragged_offsets(counts: np.ndarray) -> np.ndarray:
    """Start of each entry in its sample dimension, from the counts in storage order."""
    flat = np.asarray(counts, dtype=np.int64).ravel()
    return (np.cumsum(flat) - flat).reshape(np.shape(counts))


def tension_records(ds, index=(), starts=None) -> dict:
    """record name (solver.outputs.RECORDS) -> (n, 5) record rows of one case of a batch file or study.nc.

    index: the case's position along the case dimensions (a batch's (i,), or study.nc's grid
    index); starts: the offsets of every (case..., surface) entry (default: from the counts,
    or study.nc's tension_record_start)."""
    counts = _values(ds["tension_record_count"])
    if starts is None:
        starts = _values(ds["tension_record_start"]) if "tension_record_start" in ds else ragged_offsets(counts)
    out = {}
    for i, surface in enumerate(RECORD_NAMES):
        n, s = int(counts[tuple(index) + (i,)]), int(starts[tuple(index) + (i,)])
        if n <= 0:
            out[surface] = np.empty((0, 5))
            continue
        out[surface] = np.stack([_values(ds[name][s:s + n]) for name in TENSION_RECORD_INFO], axis=-1)
    return out


def _values(v) -> np.ndarray:
    """numpy data of an xarray variable or of a plain array."""
    return np.asarray(v.values if hasattr(v, "dims") else v)
