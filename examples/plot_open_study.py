"""
Opening a study in xarray
=========================

A finished study is one netCDF file, ``study.nc``: open it with :func:`pipeline.open_study`
(which checks it against the checksum recorded when it was written) or with plain
``xarray.open_dataset``. Every variable has units and a long name; there is one dimension per
swept key, then ``t``, ``x`` and ``eps_Y``. Here: a map of the largest tension over the two
swept keys, and a field at one case.
"""
import os

import matplotlib.pyplot as plt

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
study = {
    "description": "strain over speed and ice thickness",
    "base": {"Nmod": 12 if FAST else 40},
    "grid": {"V": [1.0, 5.0] if FAST else [1.0, 2.0, 3.0, 5.0, 7.5, 10.0],
             "hi": [0.3, 1.0] if FAST else [0.3, 0.5, 0.75, 1.0]},
    "output": {"times": {"unit": "stage", "count": 5 if FAST else 11}, "fields": ["strain"], "x_points": 121},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    pipeline.run_study(study, out="results/gallery/open_study", name="open_study", workers=2, plots=False)

    ds = pipeline.open_study("results/gallery/open_study")
    print(ds["max_strain"].attrs)                     # {'long_name': ..., 'units': '1'}
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    ds["max_strain"].plot(ax=left, x="V", y="hi", cmap="viridis")
    left.set(title="largest tension over the grid")
    ds["strain"].sel(V=5.0, hi=0.3).plot(ax=right, x="x", y="t", cmap="RdBu_r", center=0.0)
    right.set(title="strain at V = 5 m/s, hi = 0.3 m")
