"""What it costs to put study.nc's ragged records in grid order when the batches arrive out of it
(pipeline.store.combine.StudyWriter._records_in_grid_order): a synthetic study of N cases, each with
four tension records of 300-349 nodes and a few contact changes, combined from its batch files
with the batches arriving in grid order and reversed (each flush then out of order), the combine
timed (median of 3) and the file checked as a CF contiguous ragged array reader reads it.

    python benchmarks/combine_order.py [--cases 2000] [--per-batch 50]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

from pipeline.store.combine import write_study
from pipeline.study.study_files import load_study

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from helpers import write_fake_batches  # noqa: E402

STUDY = """description = "records order benchmark"
[base]
Nmod = 6
[grid]
V = {V}
hi = [0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2]
[output]
times = {{ unit = "stage", count = 4 }}
fields = []
"""


def fake_study(directory: Path, cases: int, per_batch: int):
    n_V = max(1, cases // 10)
    path = directory / "order.toml"
    path.write_text(STUDY.format(V=[1.0 + 0.01 * i for i in range(n_V)]))
    study = load_study(path)
    out = directory / "order"
    return study, out, write_fake_batches(study, out, per_batch)


def combine(study, out, ledger, reverse: bool) -> float:
    def mapper(function, tasks):
        tasks = list(tasks)
        for key, args in (tasks[::-1] if reverse else tasks):
            yield key, function(*args)
    started = time.perf_counter()
    path, damaged = write_study(study, out, ledger.index(), ledger.states(), mapper=mapper)
    elapsed = time.perf_counter() - started
    assert not damaged
    with xr.open_dataset(path) as ds:
        counts = ds["tension_record_count"].values.astype(np.int64).ravel()
        assert np.array_equal(ds["tension_record_start"].values.ravel(), np.cumsum(counts) - counts)
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=2000)
    parser.add_argument("--per-batch", type=int, default=50)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        study, out, ledger = fake_study(Path(tmp), args.cases, args.per_batch)
        nodes = None
        times = {}
        for order in ("grid order", "reversed"):
            times[order] = statistics.median(combine(study, out, ledger, order == "reversed") for _ in range(3))
        with xr.open_dataset(out / "study.nc") as ds:
            nodes = ds.sizes["tension_node"]
        size = (out / "study.nc").stat().st_size / 2**20
    print(f"{study.n_cases} cases, {nodes} tension record nodes, study.nc {size:.0f} MiB")
    for order, seconds in times.items():
        print(f"  batches in {order}: combine {seconds:.2f} s (median of 3)")
    print(f"  ratio {times['reversed'] / times['grid order']:.2f}")


if __name__ == "__main__":
    main()
