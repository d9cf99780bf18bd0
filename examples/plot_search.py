"""
A threshold search: the speed at which the layer bottoms out
============================================================

A ``[search]`` asks, for every point of a grid, for the value of one key at which an event first
happens: here the impact speed V at which the 2 cm layer bottoms out before the end of the
impact stage, for each ice thickness. The search scans V over the bracket, then bisects the
first interval where the layer starts to bottom out, to 2%: a dozen runs a point, where a sweep
at that resolution would take a couple of hundred. Every run is a case of the runner (in
``evaluations/``): checksummed and resumable.
"""
import os

import matplotlib.pyplot as plt

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
study = {
    "description": "the speed at which the layer bottoms out, against ice thickness",
    "base": {"Nmod": 6 if FAST else 12},
    "grid": {"hi": [0.5, 1.0] if FAST else [0.3, 0.4, 0.5, 0.75, 1.0]},
    "search": {"key": "V", "bracket": [1.0, 10.0] if FAST else [0.5, 20.0], "log": True, "event": "bottoming",
               "tolerance": 0.05 if FAST else 0.02},
    "output": {"times": {"unit": "stage", "count": 3}, "fields": []},
    "solver": {"error_estimate": False},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    found = pipeline.run_study(study, out="results/gallery/search", name="search", workers=2)

    fig, ax = plt.subplots(figsize=(6.5, 4.0), constrained_layout=True)
    v, lo, up = found["critical_V"], found["critical_V_lower"], found["critical_V_upper"]
    ax.errorbar(found["hi"], v, yerr=[v - lo, up - v], fmt="o-", capsize=3)
    ax.set(xlabel="ice thickness hi [m]", ylabel="critical V [m/s]", yscale="log",
           title=f"the layer bottoms out above this speed ({int(found['solves'].sum())} runs)")
    for hi, changes in zip(found["hi"].values, found["scan_changes"].values):
        if changes > 1:                           # the event came and went along the scan
            ax.annotate("non-monotone", (hi, float(v.sel(hi=hi))), fontsize=7, xytext=(4, 4),
                        textcoords="offset points")
    print(found[["critical_V", "solves", "scan_changes"]].to_dataframe())
