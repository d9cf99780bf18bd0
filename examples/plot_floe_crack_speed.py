"""
Where a floe is struck: the speed at which it first cracks
==========================================================

A floe in open water (``edges = "free"``) struck by a body of 1 t per metre of width whose
weight is carried (``body_g = 0``): the body slows on the ice, stops and leaves it, so each
impact ends on its own. A ``[search]`` finds, for each ice thickness and floe half-length, the
impact speed V above which the tension **within the impact zone** (the contact's reach plus
1 m) first reaches the paper's yield strain 8e-5 (``event = "impact_zone_crack_onset_lower"``:
under the body the floe bends down and its lower surface cracks first). Thicker ice needs a
faster impact; from a few metres on the floe's size hardly matters. The bars are the final
bracket of each search. ``make study STUDY=floe_crack_speed`` runs the full grid (3 thicknesses
x 3 lengths, 60 modes).
"""
import os

import matplotlib.pyplot as plt

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
study = {
    "description": "the impact speed at which a floe first cracks in the impact zone (eps_Y = 8e-5)",
    "base": {"edges": "free", "duration": 0.1, "body_mass": 1000.0, "body_g": 0.0, "Nmod": 16 if FAST else 40},
    "grid": {"hi": [0.3, 1.0] if FAST else [0.3, 0.5, 0.75, 1.0], "L": [2.0, 8.0] if FAST else [2.0, 4.0, 8.0]},
    "search": {"key": "V", "bracket": [0.02, 5.0], "log": True, "event": "impact_zone_crack_onset_lower",
               "eps_Y": [8e-5], "tolerance": 0.05 if FAST else 0.02},
    "output": {"times": {"unit": "stage", "count": 3}, "fields": [], "end": "separation"},
    "solver": {"error_estimate": False},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    found = pipeline.run_study(study, out="results/gallery/floe_crack_speed", name="floe_crack_speed", workers=2)
    found = found.squeeze("eps_Y", drop=True) if "eps_Y" in found.dims else found

    fig, ax = plt.subplots(figsize=(6.5, 4.0), constrained_layout=True)
    for L in found["L"].values:
        at = found.sel(L=L)
        v, lo, up = at["critical_V"], at["critical_V_lower"], at["critical_V_upper"]
        ax.errorbar(at["hi"], v, yerr=[v - lo, up - v], fmt="o-", capsize=3, label=f"L = {L:g} m")
    ax.set(xlabel="ice thickness hi [m]", ylabel="critical impact speed V [m/s]", yscale="log",
           title=f"the impact zone cracks (εY = 8e-5) above this speed ({int(found['solves'].sum())} runs)")
    ax.legend(fontsize=8, title="floe half-length")
    print(found[["critical_V", "solves", "scan_changes"]].to_dataframe())
