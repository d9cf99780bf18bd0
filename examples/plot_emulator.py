"""
Sobol' indices from a surrogate, and an emulator to query
=========================================================

The question of the Sobol' example (which of K, he, R, V, hi matters for crack onset?) asked of
a sparse polynomial-chaos expansion fitted to a space-filling design: ``[analysis] method =
"pce"`` on a scrambled Sobol' design. Each index comes with an interval that covers the runs'
sampling *and* the expansion's truncation, and the expansion is kept as an emulator:
``pipeline.open_emulator`` predicts the output anywhere in the design's box, with its
cross-validated error estimate. Here 128 runs at 12 modes (6 in the tests); ``studies/sensitivity_pce.toml``
is the full version (256 runs at 20 modes), set beside Saltelli's 28 672 in the user guide.
The right panel checks the emulator against the solver at speeds it never ran.
"""
import os

import matplotlib.pyplot as plt
import numpy as np

import pipeline

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
KEYS = {"K": {"min": 1e6, "max": 1e8, "log": True}, "he": {"min": 0.01, "max": 0.05}, "R": {"min": 5.0, "max": 20.0},
        "V": {"min": 1.0, "max": 10.0, "log": True}, "hi": {"min": 0.3, "max": 1.0}}
NMOD = 6 if FAST else 12
SETTINGS = {"output": {"times": {"unit": "stage", "count": 3}, "fields": [], "records": False, "eps_Y": [8e-5]},
            "solver": {"error_estimate": False}}
study = {
    "description": "Sobol' indices of crack onset from a polynomial-chaos surrogate, and its emulator",
    "base": {"Nmod": NMOD},
    "design": {"method": "sobol", "samples": 128, "seed": 7, "keys": KEYS},
    "analysis": {"method": "pce", "outputs": ["crack_onset_time"], "eps_Y": [8e-5], "resamples": 50},
    **SETTINGS,
}
#: the point the emulator is asked about: the middle of the box, speed varied
POINT = {"K": 1e7, "he": 0.03, "R": 12.5, "hi": 0.65}
CHECK_V = [1.5, 3.0, 6.0]
# dask starts its worker processes by importing this file again: the studies run only in the
# main process (a notebook needs no such guard)
if __name__ == "__main__":
    ds = pipeline.run_study(study, out="results/gallery/emulator", name="emulator", workers=2, plots=False)
    indices = pipeline.open_sensitivity("results/gallery/emulator")
    emulator = pipeline.open_emulator("results/gallery/emulator")
    output = emulator.outputs[0]                                   # crack_onset_time@8e-05

    speeds = np.geomspace(1.0, 10.0, 60)
    predicted = emulator.predict(output, V=speeds, **POINT)
    check = pipeline.run_study({"description": "the emulator's point, run by the solver", "base": {"Nmod": NMOD, **POINT},
                                "grid": {"V": CHECK_V}, **SETTINGS}, out="results/gallery/emulator_check",
                               name="emulator_check", workers=2, plots=False)
    computed = check["crack_onset_time"].sel(eps_Y=8e-5).values

    fig, (left, right) = plt.subplots(1, 2, figsize=(10.5, 3.9), constrained_layout=True)
    sel = indices.sel(output=output)
    x = np.arange(indices.sizes["key"])
    for shift, name, label in ((-0.2, "S1", "S1, first order"), (0.2, "ST", "ST, total")):
        value = sel[name].values
        left.bar(x + shift, value, 0.4, yerr=[value - sel[f"{name}_low"].values, sel[f"{name}_high"].values - value],
                 capsize=3, label=label)
    left.set_xticks(x, indices["key"].values)
    left.set_title(f"{output}: {ds.sizes['sample']} runs, Q2 = {float(sel['q2']):.3f}", fontsize=10)
    left.axhline(0.0, color="k", lw=0.6)
    left.set_ylabel("Sobol' index (95% interval: sampling and truncation)")
    left.legend()
    right.plot(speeds, 1e3 * predicted.value, label="emulator")
    right.fill_between(speeds, 1e3 * (predicted.value - 2 * predicted.error), 1e3 * (predicted.value + 2 * predicted.error),
                       alpha=0.3, label="± 2 error estimates")
    right.plot(CHECK_V, 1e3 * computed, "o", color="k", label="solver, not in the design")
    right.set(xscale="log", xlabel="V [m/s]", ylabel="crack onset at εY = 8e-5 [ms]",
              title="K = 1e7 Pa, he = 3 cm, R = 12.5 m, hi = 0.65 m")
    right.legend()
    print(indices[["S1", "ST", "ST_low", "ST_high"]].to_dataframe())
    print("emulator at the solver's speeds:", emulator.predict(output, V=CHECK_V, **POINT).value, "solver:", computed)
