"""
Water depth: shallow water under the ice
========================================

Finite depth ``H`` changes the water's added mass to ρ coth(λ_n H)/λ_n: the modes slow down, the
time scale t_sc grows, and the lower surface is pulled harder. Deep water (the paper's) is
reached once H is about the plate's half-length.
"""
import os

import matplotlib.pyplot as plt
import numpy as np

from solver import Parameters, solve

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
depths = [0.25, 2.0, np.inf] if FAST else [0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, np.inf]
upper, lower, t_sc = [], [], []
for H in depths:
    p = Parameters(Nmod=16 if FAST else 40, V=2.0, H=H)
    r = solve(p, times=[0.0, p.stage_duration])
    upper.append(r.diagnostics["max_strain"])
    lower.append(r.diagnostics["max_strain_lower"])
    t_sc.append(1e3 * p.time_scale)
finite = np.isfinite(depths)
H = np.asarray(depths)[finite]
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.6), constrained_layout=True)
left.semilogx(H, np.asarray(upper)[finite], "o-", label="upper surface")
left.semilogx(H, np.asarray(lower)[finite], "s-", label="lower surface")
left.axhline(upper[-1], color="C0", ls=":", lw=0.8, label="deep water")
left.axhline(lower[-1], color="C1", ls=":", lw=0.8)
left.set(xlabel="water depth H [m]", ylabel="max tensile strain", title="largest tension, V = 2 m/s")
left.legend(fontsize=8)
right.semilogx(H, np.asarray(t_sc)[finite], "o-")
right.axhline(t_sc[-1], color="C0", ls=":", lw=0.8)
right.set(xlabel="water depth H [m]", ylabel="t_sc [ms]", title="time scale 1/ω₁")
