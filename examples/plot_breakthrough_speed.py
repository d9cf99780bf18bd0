"""
A dropped body: the speed at which it breaks through
====================================================

The ice breaks into parts where its tension reaches the paper's yield strain 8e-5
(``fracture = "break"``), and a body of 1 t per metre of width whose weight is carried
(``body_g = 0``) strikes it: the body slows on the ice, and either breaks through (a break inside
the ice on each side of it cuts the ice under it off the rest) or stops and leaves the ice first.
A ``[search]`` finds, for each ice thickness, the impact speed V above which it breaks through
(``event = "breakthrough"``), in a basin 24 m wide (``edges = "walls"``) and on a floe 24 m long
(``edges = "free"``, docs/model.md, "A floe breaks"). The bars are the final bracket of each
search. ``make study STUDY=breakthrough_speed`` runs the basin on four thicknesses with 80 modes,
``make study STUDY=floe_breakthrough_speed`` floes of 6 and 12 m.
"""
import os

import matplotlib.pyplot as plt

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
study = {
    "description": "the impact speed at which a dropped body breaks through the ice, in a basin and on a floe",
    "base": {"fracture": "break", "body_mass": 1000.0, "body_g": 0.0, "duration": 0.05, "L": 12.0,
             "Nmod": 20 if FAST else 80},
    "grid": {"hi": [0.3, 1.0] if FAST else [0.3, 0.5, 0.75, 1.0], "edges": ["walls", "free"]},
    "search": {"key": "V", "bracket": [0.05, 5.0], "log": True, "event": "breakthrough",
               "tolerance": 0.2 if FAST else 0.05},
    "output": {"times": {"unit": "stage", "count": 3}, "fields": [], "end": "separation"},
    "solver": {"error_estimate": False},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    found = pipeline.run_study(study, out="results/gallery/breakthrough_speed", name="breakthrough_speed", workers=2)

    fig, ax = plt.subplots(figsize=(6.0, 3.8), constrained_layout=True)
    for edges, label in (("walls", "a basin 24 m wide"), ("free", "a floe 24 m long")):
        one = found.sel(edges=edges)
        v, lo, up = one["critical_V"], one["critical_V_lower"], one["critical_V_upper"]
        ax.errorbar(one["hi"], v, yerr=[v - lo, up - v], fmt="o-", capsize=3, label=label)
    ax.legend()
    ax.set(xlabel="ice thickness hi [m]", ylabel="critical impact speed V [m/s]",
           title=f"a body of 1 t/m breaks through above this speed ({int(found['solves'].sum())} runs)")
    print(found[["critical_V", "critical_V_lower", "critical_V_upper", "solves"]].to_dataframe())
