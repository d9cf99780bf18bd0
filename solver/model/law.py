r"""The layer's law: the pressure f(delta) / K and the stored energy G(delta) (docs/model.md, "Layer law").

    paper  (law 0):  f(delta) = delta / (1 - delta),  G(delta) = -delta - ln(1 - delta)
    linear (law 1):  f(delta) = delta,                G(delta) = delta^2 / 2

for 0 < delta < 1; G' = f, G(0) = 0. Both quadratures (solver.model.layer, solver.model.quadrature)
evaluate the law here.
"""
import math

from ..compile.jit import kernel


@kernel
def law_pressure(law, d):
    """f(delta) for 0 < delta < 1 (the paper's delta / (1 - delta), or the linear delta). Plain
    arithmetic, so that its ``py_func`` also takes numpy arrays (the field reconstruction)."""
    if law == 1:
        return d
    return d / (1.0 - d)


@kernel
def law_energy(law, d):
    """G(delta) for 0 < delta < 1, the energy stored per unit volume over K: G' = f, G(0) = 0."""
    if law == 1:
        return 0.5 * d * d
    return -d - math.log1p(-d)
