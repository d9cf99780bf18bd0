"""
Viscoelastic ice: damping the bending
=====================================

Kelvin–Voigt ice (``tau``, the retardation time) damps each mode n at a rate proportional to
λ_n⁴: the short waves are damped first, the largest strain falls once tau reaches the period of
the modes that carry it, and the dissipated energy closes the energy identity
E_plate + E_layer + D = W.
"""
import os

import matplotlib.pyplot as plt
import numpy as np

from solver import Parameters, solve

FAST = os.environ.get("FLOE_GALLERY_FAST") == "1"
taus = [0.0, 1e-4, 1e-2] if FAST else [0.0, 1e-6, 1e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2]
strain, dissipated = [], []
for tau in taus:
    p = Parameters(Nmod=16 if FAST else 40, V=2.0, tau=tau)
    r = solve(p, times=[0.0, p.stage_duration])
    strain.append(r.diagnostics["max_strain"])
    dissipated.append(r.diagnostics["dissipated_energy"] / r.diagnostics["work"])
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.6), constrained_layout=True)
shown = np.where(np.asarray(taus) > 0, taus, taus[1] / 10)      # tau = 0 drawn a decade below
left.semilogx(shown, strain, "o-")
right.semilogx(shown, dissipated, "o-")
left.set(xlabel="tau [s] (leftmost: elastic ice, tau = 0)", ylabel="max tensile strain", title="largest tension")
right.set(xlabel="tau [s] (leftmost: tau = 0)", ylabel="dissipated / work", title="energy dissipated in the ice")
