"""
Which parameter matters most? Sobol' indices of crack onset and strain
======================================================================

A Saltelli design over five keys (layer rigidity K, layer thickness he, body radius R, speed V,
ice thickness hi) and an ``[analysis]`` of Sobol' indices: the first-order index S1 is the
share of an output's variance due to one key alone, the total index ST the share in which the
key takes part at all. Here a small design (64 base samples, 448 cases, 12 modes), so that the
gallery builds in a minute: its intervals are wide. ``studies/sensitivity.toml`` is the full
version (4096 base samples, 28 672 cases, about 68 min on 2 workers here); the user guide gives
its indices and their cost, beside the same indices from a polynomial chaos of 256 runs.
"""
import os

import matplotlib.pyplot as plt
import numpy as np

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
study = {
    "description": "Sobol' indices of crack onset and max strain over five keys",
    "base": {"Nmod": 6 if FAST else 12},
    "design": {"method": "saltelli", "samples": 16 if FAST else 64, "seed": 7,
               "keys": {"K": {"min": 1e6, "max": 1e8, "log": True}, "he": {"min": 0.01, "max": 0.05},
                        "R": {"min": 5.0, "max": 20.0}, "V": {"min": 1.0, "max": 10.0, "log": True},
                        "hi": {"min": 0.3, "max": 1.0}}},
    "analysis": {"method": "sobol", "outputs": ["crack_onset_time", "max_strain"], "eps_Y": [8e-5],
                 "resamples": 200},
    "output": {"times": {"unit": "stage", "count": 3}, "fields": [], "records": False, "eps_Y": [8e-5]},
    "solver": {"error_estimate": False},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    ds = pipeline.run_study(study, out="results/gallery/sensitivity", name="sensitivity", workers=2, plots=False)
    indices = pipeline.open_sensitivity("results/gallery/sensitivity")

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True, sharey=True)
    x = np.arange(indices.sizes["key"])
    for ax, output in zip(axes, indices["output"].values):
        sel = indices.sel(output=output)
        ax.bar(x - 0.2, sel["S1"], 0.4, yerr=sel["S1_conf"], capsize=3, label="S1, first order")
        ax.bar(x + 0.2, sel["ST"], 0.4, yerr=sel["ST_conf"], capsize=3, label="ST, total")
        ax.set_xticks(x, indices["key"].values)
        ax.set_title(f"{output} ({ds.sizes['sample']} cases)")
        ax.axhline(0.0, color="k", lw=0.6)
    axes[0].set_ylabel("Sobol' index")
    axes[0].legend()
    print(indices[["S1", "ST"]].to_dataframe())
