"""
A dropped body: penetration, rebound and contact time against its mass
=======================================================================

A body of finite mass per metre of width, ``body_mass``, meets the ice at V and obeys
M s'' = M g − F. Light bodies stop quickly and rebound; heavy ones approach the paper's body
driven at constant speed. ``end = "separation"`` runs each case until the body leaves the
ice (or stops), so the rebound speed and the contact time are measured, not cut off at the
paper's stage end.
"""
import os

import matplotlib.pyplot as plt

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
masses = [300.0, 3000.0] if FAST else [100.0, 300.0, 1000.0, 3000.0, 10000.0, 30000.0]
study = {
    "description": "a dropped body against its mass per metre of width",
    "base": {"Nmod": 12 if FAST else 40, "V": 2.0},
    "grid": {"body_mass": masses},
    "output": {"times": {"unit": "stage", "count": 5}, "fields": [], "end": "separation"},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    ds = pipeline.run_study(study, out="results/gallery/drop", name="drop", workers=2, plots=False)

    M = ds["body_mass"]
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.5), constrained_layout=True)
    axes[0].plot(M, 1e3 * ds["max_penetration"], "o-")
    axes[0].set(ylabel="largest penetration [mm]")
    axes[1].plot(M, ds["separation_speed"] / ds["V"], "o-")
    axes[1].set(ylabel="rebound speed / V")
    axes[2].plot(M, 1e3 * ds["separation_time"], "o-")
    axes[2].set(ylabel="contact time [ms]")
    for ax in axes:
        ax.set(xscale="log", xlabel="body mass [kg/m]")
    fig.suptitle("a body dropped at 2 m/s on 0.5 m ice")
    print(ds[["separation_speed", "separation_time", "status"]].to_dataframe())
