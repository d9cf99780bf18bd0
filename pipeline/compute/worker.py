"""The worker: run a batch of cases with the solver, write their batch file, and return its ledger
entry (and, when the study.nc streams, what study.nc stores for them). Called on dask workers
by pipeline.compute.engine; a numerical failure is a case's status, an exception in the solver too."""
from __future__ import annotations

import shutil
from functools import lru_cache
from pathlib import Path

import numpy as np

from solver import solve

from ..common.tables import WRITE_FAILED
from ..store.casefile import batch_dataset, case_arrays, write_batch
from ..store.reduce import reduce_arrays
from ..study.case import Case, x_positions
from ..study.definition import load_study_text

#: the environment every worker runs in (local processes, and each batch job's script): one
#: thread for numba, OpenMP and the BLAS, as the runner schedules one case per worker
SINGLE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                     "NUMBA_NUM_THREADS": "1"}


def compute_case(case: Case):
    """Run the solver on one case; times past the end of its run are not integrated."""
    t_sec = case.times_seconds()
    inside = t_sec <= case.t_end * (1 + 1e-12)
    times = np.minimum(t_sec[inside], case.t_end)
    x = x_positions(case.x_points, case.parameters.L)
    return solve(case.parameters, case.settings, times=times, fields=case.fields, x=x, t_end=case.t_end,
                 **case.run_options())


@lru_cache(maxsize=4)
def _worker_study(text: str, name: str):
    """The study on a worker, parsed once per study text (a grid's cases are built on demand)."""
    return load_study_text(text, name)


def run_batch(study_text: str, study_name: str, items: list, batches_dir: str, reduce=None) -> dict:
    """Worker entry point: run the cases ``items`` ([case_id, position or -1]) of a study,
    write their batch file, return its ledger entry; with ``reduce`` (combine.stream_spec),
    also what study.nc stores for them, under "reduced".

    A numerical failure is a status, and so is an exception in the solver ('error'); every
    case is written. A failure to write the file returns status WRITE_FAILED, on which the
    runner stops the study.
    """
    study = _worker_study(study_text, study_name)
    cases, arrays = [], []
    for case_id, position in items:
        case = study.case(position) if position >= 0 else study.run(case_id)
        if case.case_id != case_id:
            raise RuntimeError(f"case {case_id}: the worker's study gives id {case.case_id}")
        try:
            result = compute_case(case)
            values = case_arrays(case, result)
        except Exception as err:                   # a bug in one case must not stop the study
            values = case_arrays(case, None, status="error", message=f"{type(err).__name__}: {err}")
        cases.append(case)
        arrays.append(values)
    spec = batch_dataset(cases, arrays)
    try:
        entry = write_batch(spec, Path(batches_dir))
    except Exception as err:                       # netCDF reports a full disk as "HDF error"
        try:
            free = f"{shutil.disk_usage(batches_dir).free // 2**20} MiB free"
        except OSError:
            free = "free space unknown"
        # returned, not raised: the runner stops the study (a raised error would be logged by
        # the dask worker with its traceback)
        return {"status": WRITE_FAILED, "message": f"cannot write a batch file in {batches_dir} ({free}): "
                                                   f"{type(err).__name__}: {err}"}
    entry["cases"] = [[c.case_id, a["status"], a["message"], float(a["run_time"])] for c, a in zip(cases, arrays)]
    if reduce is not None:                         # study.nc's slice, from memory (no re-read)
        data = {name: np.asarray(arr) for name, (_, arr, _) in spec["data"].items()}
        entry["reduced"] = reduce_arrays(data, np.arange(len(cases)), *reduce)
    return entry
