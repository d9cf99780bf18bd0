"""
A floe in open water: its size decides how hard it bends
=========================================================

With ``edges = "free"`` the ice is a floe of half-length L with free edges on open water
(phi = 0 outside it, impact theory's short-time approximation): it heaves and pitches as well
as bends, and its run lasts a given ``duration``. Left: a 6 m floe and the walled plate of the
same L, 10 ms after first touch: with no walls to hold its edges (and no int w dx = 0) the floe
sits lower as a whole. Right: the largest tension of each surface over 20 ms against the
floe's half-length: a small floe moves almost rigidly and bends little (below the paper's
yield strain on the upper surface), and from a few metres on the impact no longer feels the
floe's size (``make study STUDY=floe_size`` sweeps it at two speeds).
"""
import os

import matplotlib.pyplot as plt
import numpy as np

from solver import Parameters, Settings, solve

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
walls = Parameters(Nmod=12 if FAST else 30, duration=0.01)
for p in (walls, walls.replace(edges="free")):
    r = solve(p, Settings(quadrature="paper"), times=[0.01], fields=("deflection",))
    left.plot(r.x, 1e3 * r.fields["deflection"][0], label=p.edges)
left.set(xlabel="x [m]", ylabel="deflection [mm]", title="L = 6 m, t = 10 ms, V = 5 m/s")
left.legend(fontsize=8)

lengths = [0.5, 2.0, 8.0] if FAST else [0.5, 1.0, 2.0, 4.0, 8.0, 16.0]
tension = {"upper": [], "lower": []}
for L in lengths:
    p = Parameters(L=L, Nmod=max(8, int(3.5 * L)), edges="free", duration=0.02)
    r = solve(p, Settings(quadrature="paper", subintervals=max(200, int(170 * L))), fields=())
    tension["upper"].append(r.diagnostics["max_strain"])
    tension["lower"].append(r.diagnostics["max_strain_lower"])
for surface, values in tension.items():
    right.semilogx(lengths, values, "o-", label=f"{surface} surface")
right.axhline(8e-5, color="k", ls=":", lw=0.8, label="the paper's yield strain 8e-5")
right.set(xlabel="floe half-length L [m]", ylabel="largest tension",
          title="over the first 20 ms, V = 5 m/s", yscale="log")
right.legend(fontsize=8)
