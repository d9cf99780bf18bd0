"""One case: run it (on a worker) and write its file; read a case file back, validated.

Each case file ``cases/<case_id>.nc`` holds one case along a ``case`` dimension of length 1,
with the requested fields over (t, x), the per-time series, the in-loop diagnostics, the
event records (the running-maximum tension record of each surface, from which crack onset
follows for any yield strain, and every change of the contact-interval count), the status
and message, and the case's parameters and settings. It is written by the worker that
ran it, atomically: temporary file in the same directory, fsync, ``os.replace``, fsync of the
directory. A reader accepts a file only if it opens, carries this schema and case id, and has
every variable with the expected shape; anything else is not "done".
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

import dask
import numpy as np
import xarray as xr

from solver import DIAGNOSTIC_INFO, FIELD_INFO, PARAMETER_INFO, STATUS_INFO, solve

from . import provenance
from .study import SCHEMA_VERSION, Case

#: variable name -> (long_name, units) for the per-case series and run records
SERIES_INFO = {
    "time": ("time since first touch", "s"),
    "contact_intervals": ("number of disjoint contact intervals on -L..L", "1"),
    "force": ("force on the body per unit width", "N m-1"),
}
RECORD_INFO = {
    "t_sc": ("time scale 1/omega_1 of the case", "s"),
    "stage_duration": ("impact stage L^2/(6 R V) of the case", "s"),
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
#: the running-maximum tension record of each surface (solver.fracture): node variables along
#: ("surface", "tension_node"), NaN-padded; crack onset for any eps_Y follows from it
TENSION_RECORD_INFO = {
    "tension_record_time": ("time of a node of the running-maximum tension record", "s"),
    "tension_record_value": ("peak tension over x at the node (upper: +strain, lower: -strain)", "1"),
    "tension_record_rate": ("time derivative of the peak tension at the node", "s-1"),
    "tension_record_x": ("position of the peak at the node (x >= 0; mirrored at -x)", "m"),
    "tension_record_join": ("1: the node continues the previous one (a Hermite piece between them)", "1"),
}
CONTACT_RECORD_INFO = {
    "contact_change_time": ("time at which the number of contact intervals changed (first entry: "
                            "first touch)", "s"),
    "contact_change_count": ("number of contact intervals on -L..L from that time on", "1"),
}
SURFACES = ("upper", "lower")
#: statuses of a case that did not end ok: the model's own end, and numerical failures
ENDED_EARLY = ("layer_bottomed_out",)
NUMERICAL_FAILURES = ("nonfinite", "step_limit", "energy_violation", "error")
FAILED = ENDED_EARLY + NUMERICAL_FAILURES


class CaseWriteError(OSError):
    """A case file could not be written (disk full, permissions): the study stops (exit 74)."""


#: record status of a case whose file could not be written (not a case status: no file exists)
WRITE_FAILED = "write_failed"


def case_path(cases_dir: Path, case_id: str) -> Path:
    return Path(cases_dir) / f"{case_id}.nc"


def _x_positions(case: Case) -> np.ndarray:
    L = case.parameters.L
    return np.linspace(-L, L, case.x_points)


def case_dataset(case: Case, result=None, status=None, message="") -> xr.Dataset:
    """The dataset of one case from a solver Result (or all-NaN with a status, result=None)."""
    p = case.parameters
    t_coord = case.requested_times()
    t_sec = case.times_seconds()
    inside = t_sec <= p.stage_duration * (1 + 1e-12)
    T, X = t_coord.size, case.x_points
    x = _x_positions(case)

    def series(values):
        out = np.full(T, np.nan)
        if values is not None:
            out[inside] = values
        return out[None, :]

    data = {}
    for name in case.fields:
        arr = np.full((T, X), np.nan)
        if result is not None:
            arr[inside] = result.fields[name]
        long_name, units = FIELD_INFO[name]
        data[name] = (("case", "t", "x"), arr[None], {"long_name": long_name, "units": units})
    data["time"] = (("case", "t"), np.where(inside, t_sec, np.nan)[None], dict(zip(("long_name", "units"), SERIES_INFO["time"])))
    for name in ("contact_intervals", "force"):
        values = None if result is None else getattr(result, name)
        data[name] = (("case", "t"), series(values), dict(zip(("long_name", "units"), SERIES_INFO[name])))
    for name, (long_name, units, _) in DIAGNOSTIC_INFO.items():
        value = np.nan if result is None else result.diagnostics[name]
        if not value < np.inf:              # NaN stays NaN; +inf (max_force of a bottomed-out case) is
            value = np.nan if np.isnan(value) else value   # kept: the model's force is unbounded there
        elif value == -np.inf:              # nothing measured
            value = np.nan
        data[name] = (("case",), [value], {"long_name": long_name, "units": units})
    _event_records(data, result)
    records = {"t_sc": p.time_scale, "stage_duration": p.stage_duration,
               "time_reached": np.nan if result is None else result.time_reached,
               "run_time": np.nan if result is None else result.wall_time,
               "error_estimate_run_time": np.nan if result is None else
               result.extra.get("error_estimate_wall_time", 0.0),
               "steps": np.nan if result is None else result.steps,
               "rejected_steps": np.nan if result is None else result.rejected_steps,
               "smallest_step": np.nan if result is None else result.smallest_step}
    for name, value in records.items():
        long_name, units = RECORD_INFO[name]
        data[name] = (("case",), [float(value)], {"long_name": long_name, "units": units})
    status = status or result.status
    message = message if result is None else result.message
    data["status"] = (("case",), np.array([status], dtype=object), {"long_name": TEXT_INFO["status"]})
    data["message"] = (("case",), np.array([message], dtype=object), {"long_name": TEXT_INFO["message"]})
    for key, value in p.as_dict().items():
        long_name, units = PARAMETER_INFO[key]
        data[key] = (("case",), [value], {"long_name": long_name, "units": units})
    t_long = "time in units of the case's t_sc" if case.times_spec["unit"] == "t_sc" \
        else "time as a fraction of the case's impact stage L^2/(6RV)"
    coords = {"case": ("case", np.array([case.case_id], dtype=object), {"long_name": "case id"}),
              "surface": ("surface", np.array(SURFACES, dtype=object),
                          {"long_name": "ice surface: upper (tension = +strain), lower (tension = -strain)"}),
              "t": ("t", t_coord, {"long_name": t_long, "units": "1"}),
              "x": ("x", x, {"long_name": "position along the plate", "units": "m"})}
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "title": "floe-impact case",
        "schema_version": SCHEMA_VERSION,
        "case_id": case.case_id,
        "case_index": json.dumps(list(case.index)),
        "parameters": json.dumps(p.as_dict()),
        "solver_settings": json.dumps(case.settings.as_dict()),
        "output_times": json.dumps(case.times_spec),
        "fields": json.dumps(list(case.fields)),
        "status": status,
        **provenance.attributes(),
    })
    return ds


def _event_records(data: dict, result) -> None:
    """The tension records of both surfaces and the contact record, NaN-padded, into data."""
    recs = [np.empty((0, 5)) if result is None else result.tension_record[s] for s in SURFACES]
    nodes = max(1, max(r.shape[0] for r in recs))
    for col, (name, (long_name, units)) in enumerate(TENSION_RECORD_INFO.items()):
        arr = np.full((1, 2, nodes), np.nan)
        for i, r in enumerate(recs):
            arr[0, i, :r.shape[0]] = r[:, col]
        data[name] = (("case", "surface", "tension_node"), arr, {"long_name": long_name, "units": units})
    contacts = np.empty((0, 2)) if result is None or result.contact_record is None else result.contact_record
    n = max(1, contacts.shape[0])
    for col, (name, (long_name, units)) in enumerate(CONTACT_RECORD_INFO.items()):
        arr = np.full((1, n), np.nan)
        arr[0, :contacts.shape[0]] = contacts[:, col]
        data[name] = (("case", "contact_change"), arr, {"long_name": long_name, "units": units})


def tension_records(ds: xr.Dataset, index=()) -> dict:
    """surface -> (n, 5) record rows of one case in a case file or study.nc dataset (index:
    the case's position along the leading dimensions of study.nc; () for a case file)."""
    out = {}
    for i, surface in enumerate(SURFACES):
        cols = [np.asarray(ds[name].values)[(0,) if not index else tuple(index)][i]
                for name in TENSION_RECORD_INFO]
        rows = np.stack(cols, axis=-1)
        out[surface] = rows[np.isfinite(rows[:, 0])]
    return out


def compute_case(case: Case):
    """Run the solver on one case; times past the impact stage are not integrated."""
    t_sec = case.times_seconds()
    inside = t_sec <= case.t_end * (1 + 1e-12)
    times = np.minimum(t_sec[inside], case.t_end)
    return solve(case.parameters, case.settings, times=times, fields=case.fields, x=_x_positions(case))


def write_atomic(ds: xr.Dataset, path: Path) -> None:
    """Write ds to path so that path is either absent or complete (temp, fsync, replace, fsync dir)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}-{time.monotonic_ns()}")
    try:
        # each worker writes only its own file: no need for the scheduler-wide lock xarray takes
        # under dask.distributed (it cost 0.5 s a case); the data are numpy, nothing to compute
        with dask.config.set(scheduler="synchronous"):
            ds.to_netcdf(tmp, engine="netcdf4")
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    dfd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dfd)
    finally:
        os.close(dfd)


def run_case(case_dict: dict, cases_dir: str) -> dict:
    """Worker entry point: run one case, write its file, return a small record (no arrays).

    A numerical failure is a status, and so is an exception in the solver ('error'); the case
    file is written in both cases. A failure to write the file returns status WRITE_FAILED, on
    which the runner stops the study.
    """
    case = Case.from_dict(case_dict)
    started = time.perf_counter()
    try:
        result = compute_case(case)
        ds = case_dataset(case, result)
    except Exception as err:                       # a bug in one case must not stop the study
        ds = case_dataset(case, None, status="error", message=f"{type(err).__name__}: {err}")
    path = case_path(Path(cases_dir), case.case_id)
    try:
        write_atomic(ds, path)
    except Exception as err:                       # netCDF reports a full disk as "HDF error"
        import shutil
        try:
            free = f"{shutil.disk_usage(path.parent).free // 2**20} MiB free"
        except OSError:
            free = "free space unknown"
        # returned, not raised: the runner stops the study (a raised error would be logged by
        # the dask worker with its traceback)
        return {"case_id": case.case_id, "status": WRITE_FAILED, "run_time": float("nan"),
                "message": f"cannot write {path} ({free}): {type(err).__name__}: {err}"}
    return {"case_id": case.case_id, "status": str(ds["status"].values[0]),
            "message": str(ds["message"].values[0]), "run_time": time.perf_counter() - started}


def read_case(path: Path, case: Case):
    """The case file's dataset, loaded and closed, or None if it is missing or not valid."""
    path = Path(path)
    if not path.is_file():
        return None
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            ds = ds.load()
    except Exception:
        return None
    expected = {name: ("case", "t", "x") for name in case.fields}
    expected.update({name: ("case", "t") for name in SERIES_INFO})
    expected.update({name: ("case", "surface", "tension_node") for name in TENSION_RECORD_INFO})
    expected.update({name: ("case", "contact_change") for name in CONTACT_RECORD_INFO})
    expected.update({name: ("case",) for name in (*DIAGNOSTIC_INFO, *RECORD_INFO, *TEXT_INFO)})
    try:
        if ds.attrs.get("schema_version") != SCHEMA_VERSION or ds.attrs.get("case_id") != case.case_id:
            return None
        if ds.sizes.get("case") != 1 or ds.sizes.get("t") != case.requested_times().size \
                or (case.fields and ds.sizes.get("x") != case.x_points):
            return None
        for name, dims in expected.items():
            if name not in ds or ds[name].dims != dims:
                return None
        if str(ds["status"].values[0]) not in ("ok", *FAILED):
            return None
    except Exception:
        return None
    return ds
