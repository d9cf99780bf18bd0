"""Case files -> study.nc: one dimension per grid key (or ``case``), then ``t`` and ``x``.

Run by the driver alone, after the workers. Missing and failed cases appear as NaN with their
``status`` and ``message``. The file is written atomically, so an interrupted combine never
leaves a half-written study.nc; rerunning rebuilds it from the case files.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from solver import PARAMETER_INFO, SETTING_INFO

from . import provenance
from .casefile import case_path, read_case, tension_records, write_atomic
from .fracture import CRACK_INFO, eps_Y_coord, onset_from_records
from .study import SCHEMA_VERSION, Study


ERROR_INFO = {
    "error_strain": ("relative L2 difference of the strain from the reference run over the snapshots "
                     "both reached", "1"),
    "error_max_strain": ("relative difference of max_strain from the reference run", "1"),
    "error_crack_onset_time": ("largest relative difference over eps_Y of crack_onset_time from the "
                               "reference run", "1"),
    "error_contact_intervals": ("largest difference of contact_intervals from the reference run "
                                "over the snapshots", "1"),
}


def _parameter_coord(key, values):
    if key == "integrator":
        return (key, np.asarray(values, dtype=object), {"long_name": SETTING_INFO[key][0]})
    long_name, units = PARAMETER_INFO[key] if key in PARAMETER_INFO else SETTING_INFO[key]
    dtype = np.int64 if key in ("Nmod", "subintervals", "max_steps") else np.float64
    return (key, np.asarray(values, dtype=dtype), {"long_name": long_name, "units": units})


def errors_against(ds, ref, eps_Y) -> dict:
    """Errors of one case file's data against its reference run (both loaded datasets)."""
    out = {name: np.nan for name in ERROR_INFO}
    if ds is None or ref is None:
        return out
    a, b = ds["strain"].values[0], ref["strain"].values[0]
    both = np.all(np.isfinite(a), axis=-1) & np.all(np.isfinite(b), axis=-1)
    if both.any() and np.linalg.norm(b[both]) > 0:
        out["error_strain"] = float(np.linalg.norm(a[both] - b[both]) / np.linalg.norm(b[both]))
    m, mr = float(ds["max_strain"].values[0]), float(ref["max_strain"].values[0])
    out["error_max_strain"] = abs(m - mr) / abs(mr) if mr else np.nan
    tc = onset_from_records(tension_records(ds), eps_Y)["crack_onset_time"]
    tr = onset_from_records(tension_records(ref), eps_Y)["crack_onset_time"]
    both = np.isfinite(tc) & np.isfinite(tr)
    if both.any():
        out["error_crack_onset_time"] = float(np.max(np.abs(tc[both] / tr[both] - 1)))
    c, cr = ds["contact_intervals"].values[0], ref["contact_intervals"].values[0]
    ok = np.isfinite(c) & np.isfinite(cr)
    out["error_contact_intervals"] = float(np.max(np.abs(c[ok] - cr[ok]))) if ok.any() else np.nan
    return out


def combine(study: Study, out_dir: Path) -> xr.Dataset:
    """Assemble the study dataset from its case files (validated on read)."""
    cases_dir = Path(out_dir) / "cases"
    dims, shape = study.dims, study.shape
    per_case = [read_case(case_path(cases_dir, c.case_id), c) for c in study.cases]
    template = next((ds for ds in per_case if ds is not None), None)
    if template is None:
        raise RuntimeError("no case file of the study could be read")
    first = study.cases[0]
    L_values = {c.parameters.L for c in study.cases}
    data = {}
    # record dimensions differ in length from case to case: the study's is the longest
    sizes = {d: max(ds.sizes[d] for ds in per_case if ds is not None) for d in template.dims}
    for name, var in template.data_vars.items():
        if name in PARAMETER_INFO:
            continue
        tail = var.dims[1:]
        full_shape = shape + tuple(sizes[d] for d in tail)
        if var.dtype.kind in "OUS":
            arr = np.full(full_shape, "missing", dtype=object)
        else:
            arr = np.full(full_shape, np.nan)
        for case, ds in zip(study.cases, per_case):
            if ds is None:
                if name == "message":
                    arr[case.index] = "no valid case file"
                continue
            values = ds[name].values[0]
            arr[case.index + tuple(slice(0, n) for n in values.shape)] = values
        data[name] = (tuple(dims) + tail, arr, dict(var.attrs))
    # crack onset along the study's eps_Y, from each case's tension records
    eps_Y = study.output["eps_Y"]
    onset = {name: np.full(shape + (len(eps_Y),), np.nan) for name in CRACK_INFO}
    for case, ds in zip(study.cases, per_case):
        if ds is not None:
            for name, values in onset_from_records(tension_records(ds), eps_Y).items():
                onset[name][case.index] = values
    for name, (long_name, units) in CRACK_INFO.items():
        data[name] = (tuple(dims) + ("eps_Y",), onset[name], {"long_name": long_name, "units": units})
    data["case_id"] = (tuple(dims), np.array([c.case_id for c in study.cases], dtype=object).reshape(shape),
                       {"long_name": "id of the case file in cases/"})
    if study.references:
        errors = {name: np.full(shape, np.nan) for name in ERROR_INFO}
        ref_ids = np.full(shape, "", dtype=object)
        ref_data = {ref.case_id: read_case(case_path(cases_dir, ref.case_id), ref)
                    for ref in study.references.values()}
        for i, (case, ds_case) in enumerate(zip(study.cases, per_case)):
            ref = study.references.get(i)
            if ref is None:
                continue
            ref_ids[case.index] = ref.case_id
            for name, value in errors_against(ds_case, ref_data[ref.case_id], study.output["eps_Y"]).items():
                errors[name][case.index] = value
        for name, (long_name, units) in ERROR_INFO.items():
            data[name] = (tuple(dims), errors[name], {"long_name": long_name, "units": units})
        data["reference_case_id"] = (tuple(dims), ref_ids, {"long_name": "case file of the reference run"})
    coords = {"t": template["t"].copy(), "surface": template["surface"].copy(), "eps_Y": eps_Y_coord(eps_Y)}
    if "x" in template.dims:
        if len(L_values) == 1:
            coords["x"] = template["x"].copy()
        else:
            coords["x"] = ("x", template["x"].values / first.parameters.L,
                           {"long_name": "position as a fraction of the case's L (L varies)", "units": "1"})
    if study.grid:
        for key, values in study.grid.items():
            coords[key] = _parameter_coord(key, values)
    else:
        coords["case"] = ("case", np.arange(len(study.cases)), {"long_name": "case number in [[cases]]"})
        varying = [k for k in [*PARAMETER_INFO, *SETTING_INFO] if len({c.value(k) for c in study.cases}) > 1]
        for key in varying:
            coords[key] = ("case",) + _parameter_coord(key, [c.value(key) for c in study.cases])[1:]
        groups = [c.get("group", "") for c in study.case_list]
        if any(groups):
            coords["group"] = ("case", np.array(groups, dtype=object), {"long_name": "label of the case in the study file"})
    # parameters constant over the study: 0-d variables with units
    varying_keys = set(study.grid) if study.grid else set(varying)
    for key in PARAMETER_INFO:
        if key not in varying_keys:
            long_name, units = PARAMETER_INFO[key]
            data[key] = ((), getattr(first.parameters, key), {"long_name": long_name, "units": units})
    ds = xr.Dataset(data, coords=coords)
    statuses = [str(s) for s in np.ravel(ds["status"].values)]
    if study.references:
        ds.attrs["reference"] = json.dumps(study.reference)
    ds.attrs.update({
        "title": f"floe-impact study {study.name}",
        "description": study.description,
        "study_name": study.name,
        "study_file": study.text,
        "schema_version": SCHEMA_VERSION,
        "solver_settings": json.dumps(first.settings.as_dict()),
        "base_parameters": json.dumps(study.base),
        "cases": len(study.cases),
        "cases_ok": statuses.count("ok"),
        "cases_failed": len(statuses) - statuses.count("ok") - statuses.count("missing"),
        "cases_missing": statuses.count("missing"),
        **provenance.attributes(),
    })
    return ds


def inputs_fingerprint(study: Study, out_dir: Path) -> str:
    """A hash of what study.nc is made from: the study file, the schema, the code (version,
    commit, dirty) and each run's case file (size and mtime; missing files count too)."""
    import hashlib
    cases_dir = Path(out_dir) / "cases"
    files = []
    for case in study.all_cases():
        try:
            st = case_path(cases_dir, case.case_id).stat()
            files.append([case.case_id, st.st_size, st.st_mtime_ns])
        except FileNotFoundError:
            files.append([case.case_id, None, None])
    commit, dirty = provenance.git_state()
    blob = json.dumps({"study": study.text, "schema": SCHEMA_VERSION, "files": files,
                       "code": [provenance.package_version(), commit, dirty]}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def _sidecar(out_dir: Path) -> Path:
    return Path(out_dir) / ".study.nc.inputs"


def is_up_to_date(study: Study, out_dir: Path, fingerprint: str) -> bool:
    """True if study.nc was built from exactly these inputs and has not been touched since:
    the sidecar written with it records the fingerprint and study.nc's size and mtime (no
    netCDF file is opened)."""
    path = Path(out_dir) / "study.nc"
    try:
        record = json.loads(_sidecar(out_dir).read_text())
        st = path.stat()
    except (OSError, ValueError):
        return False
    return record == {"fingerprint": fingerprint, "size": st.st_size, "mtime_ns": st.st_mtime_ns}


def write_study(study: Study, out_dir: Path, fingerprint: str | None = None) -> Path:
    """Combine and write study.nc atomically; with a fingerprint, also its sidecar."""
    ds = combine(study, out_dir)
    path = Path(out_dir) / "study.nc"
    write_atomic(ds, path)
    if fingerprint is not None:
        import os
        st = path.stat()
        side = _sidecar(out_dir)
        tmp = side.with_name(f"{side.name}.tmp-{os.getpid()}")
        tmp.write_text(json.dumps({"fingerprint": fingerprint, "size": st.st_size, "mtime_ns": st.st_mtime_ns}))
        os.replace(tmp, side)
    return path
