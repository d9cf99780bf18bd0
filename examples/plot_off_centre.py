"""
Off-centre impact: the strain is no longer symmetric
====================================================

With ``x0`` the body strikes at x0 instead of the plate's centre: the antisymmetric modes are
excited, and the largest tension moves with the body and towards the nearer wall. The figure
shows the upper-surface strain at the end of the impact stage for a few positions.
"""
import os

import matplotlib.pyplot as plt

from solver import Parameters, solve

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
fig, ax = plt.subplots(figsize=(7, 3.8), constrained_layout=True)
for x0 in ([0.0, 2.0] if FAST else [0.0, 1.0, 2.0, 3.0]):
    p = Parameters(Nmod=16 if FAST else 40, V=2.0, x0=x0)
    r = solve(p, times=[0.5 * p.stage_duration], fields=("strain",))
    line, = ax.plot(r.x, r.fields["strain"][0], label=f"x0 = {x0:g} m: max {r.diagnostics['max_strain']:.3f}")
    ax.axvline(x0, color=line.get_color(), ls=":", lw=0.8)
ax.set(xlabel="x [m]", ylabel="strain (upper surface)", title="strain at half the impact stage, V = 2 m/s")
ax.legend(fontsize=8)
