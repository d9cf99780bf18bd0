"""
The ice breaks: breakthrough against ice thickness
==================================================

With ``fracture = "break"`` the plate breaks through its thickness where its tension first
reaches ``yield_strain`` (the paper's 8e-5), and the run goes on on the parts, which break
again. The body has broken through when a break on each side of it cuts the ice under it from
the walls (docs/model.md, "Breaking into parts"). Thicker ice breaks later and lets the body
in deeper first; a faster body breaks it sooner but deeper. The right panel is one case's
cascade: the number of parts over time. The breakthrough is the answer of the Nmod the study
runs at: a break that releases its moment at once breaks the ice again beside it as finely as
the plate is resolved (docs/model.md, "An independent check through a break").
"""
import os

import matplotlib.pyplot as plt

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
study = {
    "description": "breakthrough against ice thickness for three impact speeds",
    "base": {"Nmod": 12 if FAST else 40, "fracture": "break", "duration": 2e-3 if FAST else 3e-3},
    "grid": {"hi": [0.3, 1.0] if FAST else [0.1, 0.2, 0.3, 0.5, 0.75, 1.0], "V": [5.0] if FAST else [2.0, 5.0, 10.0]},
    "output": {"times": {"unit": "s", "step": 5e-5, "stop": 2e-3 if FAST else 3e-3}, "fields": []},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    ds = pipeline.run_study(study, out="results/gallery/breakthrough", name="breakthrough", workers=2, plots=False)

    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), constrained_layout=True)
    for V in ds["V"].values:
        case = ds.sel(V=V)
        axes[0].plot(case["hi"], 1e3 * case["breakthrough_time"], "o-", label=f"V = {V:g} m/s")
        axes[0].plot(case["hi"], 1e3 * case["first_break_time"], "x:", color=axes[0].lines[-1].get_color())
        axes[1].plot(case["hi"], 1e3 * case["breakthrough_penetration"], "o-")
    axes[0].set(xlabel="ice thickness hi [m]", ylabel="time [ms]", title="breakthrough (o) and first break (x)")
    axes[0].legend()
    axes[1].set(xlabel="ice thickness hi [m]", ylabel="penetration at breakthrough [mm]")
    one = ds.sel(V=5.0, hi=ds["hi"].values[-1])
    axes[2].step(1e3 * one["time"], one["part_count_over_time"], where="post")
    axes[2].set(xlabel="t [ms]", ylabel="parts of the plate", title=f"hi = {float(one['hi']):g} m, V = 5 m/s")
    fig.suptitle("the paper's body on the walled plate, breaking at yield_strain = 8e-5")
    print(ds[["first_break_time", "breakthrough_time", "breakthrough_penetration", "break_count",
              "status"]].to_dataframe())
