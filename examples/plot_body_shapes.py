"""
Body shapes: a parabola, blunter power laws, a flat bottom and a wedge
======================================================================

Beyond the paper's parabola x²/2R the body may be a power law ``|x|^p / (p R^(p-1))``, have a flat
bottom of half-width ``flat_width``, or be a wedge of deadrise angle ``deadrise``. A blunter
body meets more ice at once: the force rises faster and the impact stage is shorter. Each case
is solved directly with :func:`solver.solve`; the time axis is each case's own stage.
"""
import os

import matplotlib.pyplot as plt
import numpy as np

from solver import Parameters, solve

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
shapes = {"parabola (p = 2)": {}, "p = 4": {"body_p": 4.0}, "flat bottom 0.5 m": {"flat_width": 0.5},
          "wedge, 10° deadrise": {"deadrise": 10.0}}
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
summary = {}
for label, shape in shapes.items():
    p = Parameters(Nmod=16 if FAST else 40, V=2.0, **shape)
    times = np.linspace(0.0, 1.0, 11 if FAST else 101) * p.stage_duration
    r = solve(p, times=times)
    ok = r.valid
    left.plot(1e3 * r.times[ok], 1e-6 * r.force[ok], label=label)
    right.plot(r.times[ok] / p.stage_duration, r.contact_intervals[ok], label=label)
    summary[label] = (r.diagnostics["max_strain"], 1e3 * p.stage_duration, r.status)
left.set(xlabel="t [ms]", ylabel="force [MN/m]", title="force on the body (V = 2 m/s)")
right.set(xlabel="t / stage duration", ylabel="contact intervals", title="disjoint contact intervals")
left.legend(fontsize=8)
for label, (strain, stage, status) in summary.items():
    print(f"{label:22s} max strain {strain:.3g}, stage {stage:.1f} ms, {status}")
