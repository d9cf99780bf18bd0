"""Batch files -> study.nc, in a stream: one dimension per grid key (or ``case``), then ``t``,
``x``, ``surface``, ``eps_Y`` and the ragged record dimensions.

Each batch file is read where the cases ran (on the workers when a cluster is up, else in
the runner): its bytes are checked against the ledger's SHA-256 before it is opened, and the
task returns only what study.nc stores for its cases (crack onset along the study's eps_Y is
computed there from the tension records). The runner writes each batch's slice into a
study.nc opened with netCDF4, as hyperslabs of the grid (a batch is a contiguous run of grid
positions, so a few slabs per variable), then moves the finished file into place
atomically. Memory is O(one batch) plus O(cases) for the ids; nothing of the study is held
whole.

Ragged records follow the CF contiguous ragged array layout: ``tension_record_count``
(grid..., surface) nodes along ``tension_node``, ``contact_change_entries`` (grid...) along
``contact_change``, plus the start of each in ``*_start`` for direct access. Missing cases
appear as NaN with status ``missing``.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import asdict
from pathlib import Path

import numpy as np

from solver import DIAGNOSTIC_INFO, EPS_Y_INFO, FIELD_INFO, PARAMETER_INFO, SETTING_INFO
from solver.outputs import break_table
from solver.outputs import BREAKING_INFO
from solver.parameters import CHOICES, INTEGER_PARAMETERS
from solver.settings import NAMED_SETTINGS

from ..common import provenance
from ..study.case import x_fractions, x_positions
from .casefile import time_coordinate_attrs
from .fracture import CRACK_INFO
from ..study.identity import SCHEMA_VERSION
from .ledger import BATCHES, write_sidecar
from .reduce import ERROR_INFO, reduce_batch
from ..study.definition import Study
from ..common.tables import (BODY_SERIES_INFO, BREAK_DIMENSION, BREAKING_DIMS, COMPLETE, CONTACT_RECORD_INFO, RECORD_INFO, SERIES_INFO,
                             RECORD_LONG_NAME, RECORD_NAMES, TENSION_RECORD_INFO, TEXT_INFO, asked_attributes)

#: the runner writes study.nc's per-case variables in slabs of about this many bytes
FLUSH_BYTES = 16 * 2**20
#: ragged records put into grid order at the end (StudyWriter._move_records) this many at a time
RECORD_CHUNK = 2**21


def parameter_coord(key, values):
    long_name, units = PARAMETER_INFO[key] if key in PARAMETER_INFO else SETTING_INFO[key]
    if key in NAMED_SETTINGS or key in CHOICES:          # names, not numbers
        return np.asarray(values, dtype=object), {"long_name": long_name}
    if key == "error_estimate":
        return np.asarray(values, dtype=np.int8), {"long_name": long_name, "units": "1"}
    dtype = np.int64 if key in (*INTEGER_PARAMETERS, "subintervals", "max_steps") else np.float64
    return np.asarray(values, dtype=dtype), {"long_name": long_name, "units": units}


def per_case_variables(study: Study) -> list:
    """(name, tail dims, kind, attrs) of every study.nc variable stored per case."""
    answered = study.output.answer_eps_Y if study.output.end == "answered" else None
    return [(name, dims, kind, {**attrs, **asked_attributes(name, study.output.outputs, answered)})
            for name, dims, kind, attrs in _per_case_variables(study)]


def _per_case_variables(study: Study) -> list:
    out = []
    for name in study.output.fields:
        long_name, units = FIELD_INFO[name]
        out.append((name, ("t", "x"), "f", {"long_name": long_name, "units": units}))
    for name, (long_name, units) in {**SERIES_INFO, **(BODY_SERIES_INFO if study.output.body else {})}.items():
        out.append((name, ("t",), "f", {"long_name": long_name, "units": units}))
    for name, (long_name, units, _) in DIAGNOSTIC_INFO.items():
        out.append((name, (), "f", {"long_name": long_name, "units": units}))
    if study.output.break_slots:
        for name, (long_name, units, along) in BREAKING_INFO.items():
            out.append((name, BREAKING_DIMS[along], "f", {"long_name": long_name, "units": units}))
    for name, (long_name, units) in RECORD_INFO.items():
        out.append((name, (), "f", {"long_name": long_name, "units": units}))
    for name, long_name in TEXT_INFO.items():
        out.append((name, (), "s", {"long_name": long_name}))
    for name, (long_name, units) in CRACK_INFO.items():
        out.append((name, ("eps_Y",), "f", {"long_name": long_name, "units": units}))
    if study.references:
        for name, (long_name, units) in ERROR_INFO.items():
            out.append((name, (), "f", {"long_name": long_name, "units": units}))
        out.append(("reference_case_id", (), "s", {"long_name": "id of the reference run"}))
    if study.output.records:
        out.append(("tension_record_count", ("tension_record",), "i",
                    {"long_name": "nodes of the case's tension record", "units": "1",
                     "sample_dimension": "tension_node"}))
        out.append(("tension_record_start", ("tension_record",), "i",
                    {"long_name": "index along tension_node of the first of those nodes", "units": "1"}))
        out.append(("contact_change_entries", (), "i",
                    {"long_name": "entries of the case's contact record", "units": "1",
                     "sample_dimension": "contact_change"}))
        out.append(("contact_change_start", (), "i",
                    {"long_name": "index along contact_change of the first of those entries", "units": "1"}))
    return out


def _boxes(a: int, b: int, shape: tuple):
    """Split the flat C-order range [a, b) of an array of ``shape`` into hyperslabs: yields
    (flat start, tuple of slices) in order."""
    if a >= b:
        return
    if len(shape) == 1:
        yield a, (slice(a, b),)
        return
    inner = math.prod(shape[1:])
    i0, r0 = divmod(a, inner)
    i1, r1 = divmod(b, inner)
    if i0 == i1:
        for f, sl in _boxes(r0, r1, shape[1:]):
            yield i0 * inner + f, (slice(i0, i0 + 1),) + sl
        return
    if r0:
        for f, sl in _boxes(r0, inner, shape[1:]):
            yield i0 * inner + f, (slice(i0, i0 + 1),) + sl
        i0 += 1
    if i1 > i0:
        yield i0 * inner, (slice(i0, i1),) + tuple(slice(None) for _ in shape[1:])
    if r1:
        for f, sl in _boxes(0, r1, shape[1:]):
            yield i1 * inner + f, (slice(i1, i1 + 1),) + sl


def _runs(flat: np.ndarray):
    """(start index into flat, stop) of each run of consecutive values in sorted ``flat``."""
    breaks = np.flatnonzero(np.diff(flat) != 1) + 1
    edges = np.r_[0, breaks, flat.size]
    return list(zip(edges[:-1], edges[1:]))


def _groups(study: Study) -> list:
    """The group labels of a [[cases]] study's cases, or [] when none has one (a grid: [])."""
    if study.grid:
        return []
    groups = [c.get("group", "") for c in study.case_list]
    return groups if any(groups) else []


def fit_breaks(values, slots: int) -> np.ndarray:
    """Per-break values (cases, stored slots) as ``slots`` columns: NaN after the stored ones, and
    cut where a case was stored by a study that kept more (those columns are NaN: this study's
    max_parts bounds its cases' breaks)."""
    values = np.asarray(values, dtype=float)
    out = np.full((values.shape[0], slots), np.nan)
    n = min(slots, values.shape[1])
    out[:, :n] = values[:, :n]
    return out


def unbroken(time, slots: int) -> dict:
    """The breaking outputs of cases that did not break (solver.outputs.break_table without
    breaks) from their series ``time`` (cases, t): NaN where it is."""
    rows = [break_table((), row, np.isfinite(row), slots) for row in np.asarray(time, dtype=float)]
    return {name: np.array([row[name] for row in rows]) for name in BREAKING_INFO}


class StudyWriter:
    """study.nc opened with netCDF4; filled slice by slice; finished atomically."""

    def __init__(self, study: Study, path: Path, t_coord, x_fraction):
        import netCDF4
        self.study, self.path = study, Path(path)
        self.tmp = self.path.with_name(f".{self.path.name}.tmp-{os.getpid()}-{os.urandom(4).hex()}")
        self.shape, self.dims = study.shape, tuple(study.dims)
        self.variables = per_case_variables(study)
        nc = self.nc = netCDF4.Dataset(self.tmp, "w", format="NETCDF4")
        for d, n in zip(self.dims, self.shape):
            nc.createDimension(d, n)
        nc.createDimension("t", len(t_coord))
        if study.output.fields:
            nc.createDimension("x", len(x_fraction))
        nc.createDimension("tension_record", len(RECORD_NAMES))
        nc.createDimension("eps_Y", len(study.output.eps_Y))
        if study.output.break_slots:
            nc.createDimension(BREAK_DIMENSION, study.output.break_slots)
        if study.output.records:
            nc.createDimension("tension_node", None)
            nc.createDimension("contact_change", None)
        # a [[cases]] or [design] study's variables name their per-case coordinates (CF): the
        # keys that vary, and the group labels (work_precision and extremes select by them)
        groups = _groups(study)
        coordinates = "" if study.grid else " ".join([*study.varying_keys, *(["group"] if groups else [])])
        self._coords(t_coord, x_fraction, groups, coordinates)
        for name, tail, kind, attrs in self.variables:
            dims = self.dims + tail
            if kind == "f":
                var = nc.createVariable(name, "f8", dims, fill_value=np.nan)
            elif kind == "i":
                var = nc.createVariable(name, "i8", dims, fill_value=False)
            else:
                var = nc.createVariable(name, str, dims)
            var.setncatts({**attrs, "coordinates": coordinates} if coordinates else attrs)
        if study.output.records:
            for name, (long_name, units) in {**TENSION_RECORD_INFO, **CONTACT_RECORD_INFO}.items():
                dim = "tension_node" if name in TENSION_RECORD_INFO else "contact_change"
                nc.createVariable(name, "f8", (dim,), fill_value=np.nan).setncatts(
                    {"long_name": long_name, "units": units})
        self.n_nodes = self.n_changes = 0
        self.seen = np.zeros(study.n_cases, dtype=bool)
        self.buffer, self.buffered = [], 0
        #: the last grid position whose records were appended, and whether any came before it
        self.records_upto, self.records_in_order = -1, True

    def _coords(self, t_coord, x_fraction, groups: list, coordinates: str):
        nc, study = self.nc, self.study
        first = study.case(0)
        t = nc.createVariable("t", "f8", ("t",))
        t[:] = t_coord
        long_name, units = time_coordinate_attrs(study.output.times["unit"])
        t.setncatts({"long_name": long_name, "units": units})
        if study.output.fields:
            x = nc.createVariable("x", "f8", ("x",))
            L_values = {v for v in study.grid.get("L", [])} or {c.parameters.L for c in
                                                                (study._listed or [first])}
            if len(L_values) == 1:
                x[:] = x_positions(len(x_fraction), first.parameters.L)
                x.setncatts({"long_name": "position along the plate", "units": "m"})
            else:
                x[:] = x_fraction
                x.setncatts({"long_name": "position as a fraction of the case's L (L varies)", "units": "1"})
        record = nc.createVariable("tension_record", str, ("tension_record",))
        record[:] = np.array(RECORD_NAMES, dtype=object)
        record.long_name = RECORD_LONG_NAME
        eps = nc.createVariable("eps_Y", "f8", ("eps_Y",))
        eps[:] = study.output.eps_Y
        eps.setncatts({"long_name": EPS_Y_INFO[0], "units": EPS_Y_INFO[1]})
        if study.output.break_slots:
            number = nc.createVariable(BREAK_DIMENSION, "i8", (BREAK_DIMENSION,))
            number[:] = np.arange(study.output.break_slots)
            number.setncatts({"long_name": "number of a break of the case, in the order they happened (0: the "
                                           "first)", "units": "1"})
        if study.grid:
            for (key, values), dim in zip(study.grid.items(), study.dims):
                data, attrs = parameter_coord(key, values)
                var = nc.createVariable(dim, str if data.dtype == object else data.dtype, (dim,))
                var[:] = data
                var.setncatts(attrs)
            constant = [k for k in PARAMETER_INFO if k not in study.grid]
        else:
            dim = self.dims[0]                     # case ([[cases]]) or sample ([design])
            var = nc.createVariable(dim, "i4", (dim,))
            var[:] = np.arange(study.n_cases)
            var.long_name = "sample number of the design" if study.design else "case number in [[cases]]"
            varying = list(study.design.keys) if study.design else study.varying_keys
            for key in varying:
                data, attrs = parameter_coord(key, [c.value(key) for c in study._listed])
                v = nc.createVariable(key, str if data.dtype == object else data.dtype, (dim,))
                v[:] = data
                v.setncatts(attrs)
            if groups:
                v = nc.createVariable("group", str, (dim,))
                v[:] = np.array(groups, dtype=object)
                v.long_name = "label of the case in the study file"
            constant = [k for k in PARAMETER_INFO if k not in varying]
        for key in constant:                        # constant over the study: 0-d, with units
            long_name, units = PARAMETER_INFO[key]
            if key in CHOICES:                      # a name: a string, with no units
                var = nc.createVariable(key, str, ())
                var[...] = np.array(getattr(first.parameters, key), dtype=object)
                var.setncatts({"long_name": long_name})
                continue
            var = nc.createVariable(key, "i8" if key in INTEGER_PARAMETERS else "f8", ())
            var.assignValue(getattr(first.parameters, key))
            var.setncatts({"long_name": long_name, "units": units})
        ids = nc.createVariable("case_id", str, self.dims)
        ids[...] = np.array(study.case_ids, dtype=object).reshape(self.shape)
        ids.long_name = "id of the case (its row in ledger.jsonl names its batch file)"
        if coordinates:
            ids.coordinates = coordinates

    def _put(self, name, flat, values):
        """values[k] belongs at flat grid index flat[k] (flat sorted)."""
        var = self.nc[name]
        for a, b in _runs(flat):
            for start, slices in _boxes(int(flat[a]), int(flat[b - 1]) + 1, self.shape):
                n = math.prod(len(range(*s.indices(dim))) for s, dim in zip(slices, self.shape))
                k = a + (start - int(flat[a]))
                block = values[k:k + n]
                box = tuple(len(range(*s.indices(dim))) for s, dim in zip(slices, self.shape))
                var[slices] = np.asarray(block).reshape(box + np.shape(block)[1:])

    def write(self, flat: np.ndarray, data: dict) -> None:
        """Store the reduced data of cases at the sorted flat grid indices ``flat``. Batches
        wait in a buffer of at most FLUSH_BYTES and are written in grid order as few large
        hyperslabs (consecutive batches are contiguous); the ragged records are appended in
        the same order."""
        if self.seen[np.asarray(flat, dtype=np.int64)].all():
            return                                  # (a batch delivered twice: stored once)
        self.buffer.append((np.asarray(flat, dtype=np.int64), data))
        self.buffered += sum(np.asarray(v).nbytes for v in data.values())
        self.seen[flat] = True
        if self.buffered >= FLUSH_BYTES:
            self.flush()

    def _append_records(self, data: dict) -> None:
        counts = np.asarray(data["tension_record_count"], dtype=np.int64)
        total = int(counts.sum())
        data["tension_record_start"] = (self.n_nodes + np.cumsum(counts.ravel()) - counts.ravel()).reshape(counts.shape)
        for name in TENSION_RECORD_INFO:
            if total:
                self.nc[name][self.n_nodes:self.n_nodes + total] = data[name]
        self.n_nodes += total
        entries = np.asarray(data["contact_change_entries"], dtype=np.int64)
        total = int(entries.sum())
        data["contact_change_start"] = self.n_changes + np.cumsum(entries) - entries
        for name in CONTACT_RECORD_INFO:
            if total:
                self.nc[name][self.n_changes:self.n_changes + total] = data[name]
        self.n_changes += total

    def flush(self) -> None:
        if not self.buffer:
            return
        self.buffer.sort(key=lambda item: int(item[0][0]) if item[0].size else -1)
        if self.study.output.records:
            for flat, data in self.buffer:
                self._append_records(data)
                if flat.size:
                    self.records_in_order &= int(flat[0]) > self.records_upto
                    self.records_upto = max(self.records_upto, int(flat[-1]))
        if self.study.output.break_slots:
            for _, data in self.buffer:
                if "break_count" not in data:     # stored by a study where no case broke
                    data.update(unbroken(data["time"], self.study.output.break_slots))
        flat = np.concatenate([f for f, _ in self.buffer])
        order = np.argsort(flat, kind="stable")
        for name, tail, kind, _ in self.variables:
            parts = [d[name] for _, d in self.buffer if name in d]
            if len(parts) != len(self.buffer):
                continue
            if tail == (BREAK_DIMENSION,):       # a case stored by a study that kept more or fewer breaks
                parts = [fit_breaks(p, self.study.output.break_slots) for p in parts]
            values = np.concatenate([np.asarray(p, dtype=object) if kind == "s" else np.asarray(p) for p in parts])
            self._put(name, flat[order], values[order])
        self.buffer, self.buffered = [], 0

    def finish(self, attrs: dict) -> Path:
        self.flush()
        missing = np.flatnonzero(~self.seen)
        if missing.size:
            k = missing.size
            filler = {"status": np.full(k, "missing", dtype=object),
                      "message": np.full(k, "no valid result", dtype=object)}
            for name, tail, kind, _ in self.variables:
                if kind == "i":
                    filler[name] = np.zeros((k,) + (len(RECORD_NAMES),) * len(tail), dtype=np.int64)
                elif kind == "s" and name not in filler:
                    filler[name] = np.full(k, "", dtype=object)
            for name, values in filler.items():
                self._put(name, missing, values)
        if self.study.output.records:
            self._records_in_grid_order()
        self.nc.setncatts(attrs)
        self.nc.close()
        fd = os.open(self.tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(self.tmp, self.path)
        return self.path

    def _records_in_grid_order(self) -> None:
        """The ragged records in the cases' grid order, each case's starting where the counts
        before it end (CF's contiguous ragged array: a reader may derive the starts from the
        counts alone). Batches arrive in any order across flushes (two workers racing, a batch
        run again, a resumed study's older files), and are appended as they arrive; when one
        came before a grid position already written, every record is moved into place here,
        through a scratch copy beside the file, a chunk at a time."""
        for start, count, names, appended in (
                ("tension_record_start", "tension_record_count", TENSION_RECORD_INFO, self.n_nodes),
                ("contact_change_start", "contact_change_entries", CONTACT_RECORD_INFO, self.n_changes)):
            counts = np.asarray(self.nc[count][...], dtype=np.int64).ravel()
            shape = self.nc[start].shape
            old = np.asarray(self.nc[start][...], dtype=np.int64).ravel()
            new = np.cumsum(counts) - counts
            if not self.records_in_order or appended != counts.sum():     # (a case written twice)
                for name in names:
                    self._move_records(self.nc[name], old, counts)
            self.nc[start][...] = new.reshape(shape)

    def _move_records(self, var, old: np.ndarray, counts: np.ndarray) -> None:
        """var[new order] = var[old starts, counts] for the cases in grid order."""
        length = int(var.shape[0])               # all appended, a case written twice included
        if int(counts.sum()) == 0:
            return
        scratch = self.tmp.with_name(self.tmp.name + ".records")
        try:
            copy = np.lib.format.open_memmap(scratch, mode="w+", dtype=var.dtype, shape=(length,))
            for a in range(0, length, RECORD_CHUNK):
                copy[a:a + RECORD_CHUNK] = var[a:min(a + RECORD_CHUNK, length)]
            keep = counts > 0
            starts, counts = old[keep], counts[keep]
            ends = np.cumsum(counts)
            i = written = 0
            while i < counts.size:                    # whole cases, about RECORD_CHUNK nodes at a time
                j = max(i + 1, int(np.searchsorted(ends, written + RECORD_CHUNK, side="right")))
                n = int(ends[j - 1]) - written
                shift = np.repeat(starts[i:j] - (ends[i:j] - counts[i:j]), counts[i:j])   # old - new
                var[written:written + n] = copy[shift + np.arange(written, written + n)]
                written, i = written + n, j
            del copy
        finally:
            scratch.unlink(missing_ok=True)

    def abandon(self) -> None:
        try:
            self.nc.close()
        except Exception:
            pass
        self.tmp.unlink(missing_ok=True)


def plan(study: Study, index: dict, out_dir: Path) -> dict:
    """file -> [sha256, flat indices, rows, refs] for the combine's tasks (from the ledger)."""
    batches = Path(out_dir) / BATCHES
    groups = {}
    ref_of = study.references
    for flat, cid in enumerate(study.case_ids):
        if cid not in index:
            continue
        entry, position = index[cid]
        group = groups.setdefault(entry["file"], [entry["sha256"], [], [], {}])
        key = None
        ref = ref_of.get(flat)
        if ref is not None and ref.case_id in index:
            ref_entry, ref_pos = index[ref.case_id]
            key = ref.case_id
            group[3][key] = [str(batches / ref_entry["file"]), ref_entry["sha256"], ref_pos]
        group[1].append(flat)
        group[2].append([position, key])
    return groups


def open_writer(study: Study, out_dir: Path) -> StudyWriter:
    first = study.case(0)
    return StudyWriter(study, Path(out_dir) / "study.nc", first.requested_times(), x_fractions(first.x_points))


def stream_spec(study: Study):
    """What a worker needs to reduce its batch right after running it (the combine then reads
    no file for it), or None when the study measures errors against reference runs (those
    come from other batches)."""
    if study.references:
        return None
    return [study.output.eps_Y, [v[0] for v in per_case_variables(study)], study.output.records, study.output.outputs]


def write_study(study: Study, out_dir: Path, index: dict, states: dict, mapper=None,
                fingerprint: str | None = None, writer: StudyWriter | None = None) -> tuple:
    """Combine the batch files into study.nc; returns (path, damaged batch file names).

    ``writer``: a StudyWriter that already holds the cases streamed from this run's batches;
    only the others are read. ``mapper(function, list of (key, args))`` yields (key, result)
    pairs in task order, a few at a time (the workers'); default: in this process. Nothing
    is written if a batch file turns out to be damaged (the runner recomputes it)."""
    out_dir = Path(out_dir)
    groups = plan(study, index, out_dir)
    names = [v[0] for v in per_case_variables(study)]
    first = study.case(0)
    writer = writer or open_writer(study, out_dir)
    for file in list(groups):                              # streamed already: nothing to read
        unseen = ~writer.seen[np.asarray(groups[file][1], dtype=np.int64)]
        if not unseen.any():
            del groups[file]
        elif not unseen.all():      # some positions streamed (a Morris design's repeated point): the others
            groups[file][1] = [f for f, u in zip(groups[file][1], unseen) if u]
            groups[file][2] = [r for r, u in zip(groups[file][2], unseen) if u]
    tasks = [(file, (str(out_dir / BATCHES / file), sha, rows, study.output.eps_Y, names,
                     study.output.records, refs, study.output.outputs))
             for file, (sha, flat, rows, refs) in groups.items()]
    mapper = mapper or _serial
    damaged = set()
    try:
        for file, result in mapper(reduce_batch, tasks):
            if "damaged" in result:
                damaged.update(result["damaged"])
                continue
            writer.write(np.asarray(groups[file][1], dtype=np.int64), result)   # sorted by plan()
        if damaged:
            writer.abandon()
            return None, sorted(damaged)
        statuses = [states.get(cid, "missing") for cid in study.case_ids]
        complete = sum(1 for s in statuses if s in COMPLETE)     # ok, or a free body's end
        attrs = {"title": f"floe-impact study {study.name}", "description": study.description,
                 "study_name": study.name, "study_file": study.text, "schema_version": SCHEMA_VERSION,
                 "solver_settings": json.dumps(first.settings.as_dict()),
                 "base_parameters": json.dumps(study.base), "cases": study.n_cases,
                 "cases_ok": complete, "cases_missing": statuses.count("missing"),
                 "cases_failed": len(statuses) - complete - statuses.count("missing"),
                 **provenance.attributes(f"combined study {study.name} from its batch files")}
        if study.references:
            attrs["reference"] = json.dumps(study.reference)
        if study.design:
            attrs["design"] = json.dumps(asdict(study.design))
        if study.output.outputs is not None:
            attrs["outputs"] = json.dumps(list(study.output.outputs))
            attrs["end"] = study.output.end
        if study.output.end == "answered":
            attrs["answered_eps_Y"] = study.output.answer_eps_Y
        path = writer.finish(attrs)
    except BaseException:
        writer.abandon()
        raise
    if fingerprint is not None:
        write_sidecar(out_dir, fingerprint)
    return path, []


def _serial(function, tasks):
    for key, args in tasks:
        yield key, function(*args)
