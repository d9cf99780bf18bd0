"""
One case: strain along the ice, and the force on the body
=========================================================

The paper's reference case (a body of radius 10 m at 5 m/s on 0.5 m ice through a 2 cm layer),
solved once with :func:`solver.solve` and turned into a labelled dataset with
:func:`pipeline.case_dataset`. Left: the strain of the upper surface along the plate at a
few times. Right: the force on the body, with crack onset at the paper's yield strain.
"""
import os

import matplotlib.pyplot as plt
import numpy as np

from pipeline import case_dataset
from solver import Parameters, solve

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
p = Parameters(Nmod=20 if FAST else 60)
times = np.linspace(0.0, 4.0, 9 if FAST else 201) * p.time_scale
case = case_dataset(solve(p, times=times, fields=("strain",)), eps_Y=[8e-5])

fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
for k in np.linspace(0, case.sizes["t"] - 1, 5).astype(int):
    snapshot = case["strain"].isel(t=k)
    left.plot(case["x"], snapshot, label=f"t = {1e3 * float(case['t'][k]):.0f} ms")
left.set(xlabel="x [m]", ylabel="strain (upper surface)", title="strain along the ice")
left.legend(fontsize=8)
right.plot(1e3 * case["t"], 1e-6 * case["force"], color="k")
onset = float(case["crack_onset_time"].sel(eps_Y=8e-5))
right.axvline(1e3 * onset, ls="--", color="C3", label=f"crack onset at εY = 8e-5: {1e3 * onset:.2f} ms")
right.set(xlabel="t [ms]", ylabel="force [MN/m]", title="force on the body")
right.legend(fontsize=8)
max_strain = float(case["max_strain"])
print(f"status {case['status'].item()}, max strain {max_strain:.3g} at x = {float(case['max_strain_x']):.2f} m")
