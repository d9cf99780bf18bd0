"""
A floe in open water: its size decides how hard it bends
=========================================================

With ``edges = "free"`` the ice is a floe of half-length L with free edges on open water
(phi = 0 outside it, impact theory's short-time approximation): it heaves and pitches as well
as bends, and its run lasts a given ``duration``. Left: a 6 m floe and the walled plate of the
same L, 10 ms after first touch: with no walls to hold its edges (and no int w dx = 0) the floe
sits lower as a whole. Middle: the largest tension of each surface over 20 ms against the
floe's half-length, in the impact zone (the contact's reach plus 1 m) and plate-wide: a small
floe moves almost rigidly and bends little (below the paper's yield strain on the upper
surface), and from a few metres on the impact no longer feels the floe's size. Right: when
each surface first reaches the paper's yield strain 8e-5, in the impact zone and anywhere on
the floe (``make study STUDY=floe_size`` sweeps L at two speeds; ``make study
STUDY=floe_crack_speed`` finds the speed at which a floe first cracks in the zone).
"""
import os

import matplotlib.pyplot as plt
import numpy as np

from solver import Parameters, Settings, solve

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
fig, (left, middle, right) = plt.subplots(1, 3, figsize=(14, 3.8), constrained_layout=True)
walls = Parameters(Nmod=12 if FAST else 30, duration=0.01)
for p in (walls, walls.replace(edges="free")):
    r = solve(p, Settings(), times=[0.01], fields=("deflection",))
    left.plot(r.x, 1e3 * r.fields["deflection"][0], label=p.edges)
left.set(xlabel="x [m]", ylabel="deflection [mm]", title="L = 6 m, t = 10 ms, V = 5 m/s")
left.legend(fontsize=8)

lengths = [0.5, 2.0, 8.0] if FAST else [0.5, 1.0, 2.0, 4.0, 8.0, 16.0]
tension = {"upper": [], "lower": []}
zone = {"upper": [], "lower": []}
onset = {"upper": [], "lower": []}
zone_onset = {"upper": [], "lower": []}
for L in lengths:
    p = Parameters(L=L, Nmod=max(8, int(3.5 * L)), edges="free", duration=0.02)
    r = solve(p, Settings(subintervals=max(250, int(40 * L))), fields=())
    for surface, suffix in (("upper", ""), ("lower", "_lower")):
        tension[surface].append(r.diagnostics["max_strain" + suffix])
        zone[surface].append(r.diagnostics["impact_zone_max_strain" + suffix])
        onset[surface].append(1e3 * r.crack_onset(8e-5, surface)[0])
        zone_onset[surface].append(1e3 * r.crack_onset(8e-5, surface, region="impact_zone")[0])
for (surface, values), color in zip(zone.items(), ("C0", "C1")):
    middle.loglog(lengths, values, "o-", color=color, label=f"{surface}, impact zone")
    middle.loglog(lengths, tension[surface], "x--", color=color, label=f"{surface}, plate-wide")
    right.semilogx(lengths, zone_onset[surface], "o-", color=color, label=f"{surface}, impact zone")
    right.semilogx(lengths, onset[surface], "x--", color=color, label=f"{surface}, plate-wide")
middle.axhline(8e-5, color="k", ls=":", lw=0.8, label="the paper's yield strain 8e-5")
middle.set(xlabel="floe half-length L [m]", ylabel="largest tension", title="over the first 20 ms, V = 5 m/s")
middle.legend(fontsize=7)
right.set(xlabel="floe half-length L [m]", ylabel="crack onset at εY = 8e-5 [ms]",
          title="first reach of the yield strain (none: not drawn)")
right.legend(fontsize=8)
