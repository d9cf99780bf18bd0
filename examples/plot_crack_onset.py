"""
Crack onset against the yield strain
====================================

Crack onset is not a solver input: each run stores the running maximum of the tension on both
surfaces, so one run answers "when does the ice first reach εY?" for every εY. Here the
speed-sweep study's records answer it along 41 yield strains; any other list is
:func:`pipeline.store.fracture.crack_onset` away, without a rerun.
"""
import os

import matplotlib.pyplot as plt

import pipeline
from pipeline.store.fracture import crack_onset

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
study = {
    "description": "crack onset against the yield strain at several impact speeds",
    "base": {"Nmod": 12 if FAST else 40, "hi": 0.5},
    "grid": {"V": [1.0, 5.0] if FAST else [1.0, 2.0, 5.0, 10.0]},
    "output": {"times": {"unit": "stage", "count": 5}, "fields": [],
               "eps_Y": {"min": 1e-5, "max": 1e-1, "count": 41}},
}
# dask starts its worker processes by importing this file again: the study runs only in
# the main process (a notebook needs no such guard)
if __name__ == "__main__":
    ds = pipeline.run_study(study, out="results/gallery/crack_onset", name="crack_onset", workers=2, plots=False)

    fig, ax = plt.subplots(figsize=(6.5, 4.2), constrained_layout=True)
    for i, V in enumerate(ds["V"].values):
        case = ds.sel(V=V)
        ax.plot(case["eps_Y"], 1e3 * case["crack_onset_time"], color=f"C{i}", label=f"V = {V:g} m/s, upper")
        ax.plot(case["eps_Y"], 1e3 * case["crack_onset_time_lower"], "--", color=f"C{i}", label="lower")
    ax.axvline(8e-5, color="0.6", lw=0.8)
    ax.set(xscale="log", yscale="log", xlabel="yield strain εY", ylabel="crack onset [ms]",
           title="first time the tension reaches εY (hi = 0.5 m)")
    ax.legend(fontsize=7, ncol=2)

    # other yield strains from the same records, no rerun
    more = crack_onset(ds, eps_Y=[3e-5, 6e-4])
    print(more["crack_onset_time"].to_series())
