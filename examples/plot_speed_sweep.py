"""
The speed sweep: how strongly the ice bends, against impact speed
==================================================================

A study of impact speed V and ice thickness hi, run from Python with :func:`pipeline.run_study`:
the same run as ``floe-impact run studies/speed_sweep.toml`` (ledger, resume, lock), returning
the combined ``study.nc`` as an ``xarray.Dataset`` with one dimension per swept key.
"""
import os

import matplotlib.pyplot as plt

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
study = {
    "description": "max strain and force against impact speed, three ice thicknesses",
    "base": {"Nmod": 12 if FAST else 40},
    "grid": {"V": [1.0, 5.0] if FAST else [1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0],
             "hi": [0.3, 1.0] if FAST else [0.3, 0.5, 1.0]},
    "output": {"times": {"unit": "stage", "count": 5 if FAST else 24}, "fields": []},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    ds = pipeline.run_study(study, out="results/gallery/speed_sweep", name="speed_sweep", workers=2, plots=False)

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for hi in ds["hi"].values:
        case = ds.sel(hi=hi)
        left.plot(case["V"], case["max_strain"], "o-", label=f"hi = {hi:g} m")
        ok = case["status"] == "ok"            # a bottomed-out layer: force unbounded, drawn open
        right.plot(case["V"].where(ok), 1e-6 * case["max_force"].where(ok), "o-", label=f"hi = {hi:g} m")
    left.set(xscale="log", yscale="log", xlabel="V [m/s]", ylabel="max tensile strain (plate-wide)",
             title="largest upper-surface tension")
    right.set(xscale="log", yscale="log", xlabel="V [m/s]", ylabel="max force [MN/m]",
              title="largest force (cases whose layer held)")
    left.legend()
    print(ds["status"].to_series().value_counts().to_dict())
