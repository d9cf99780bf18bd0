"""The global peak's search over the continuous plate (solver.model.basis.global_peak): a peak
between nodes may stand above the nodes by more than PEAK_MARGIN, and the search refines every
local peak the grid's bound (competing) leaves in the race (docs/model.md, "Crack onset (the
tension record)": "The competing peaks' margin")."""
import math

import numpy as np

from solver import Parameters, Settings
from solver.model.assemble import Tables
from solver.model.basis import global_peak, load_dry
from solver.model.peak_margin import PEAK_MARGIN, competing, curvature_bound, peak_reach
from solver.model.plate import STRAIN


def _cosines(N=60):
    p, s = Parameters(Nmod=N), Settings(quadrature="gauss")
    return Tables(p, s.subintervals, False, s.quadrature, s.quadrature_density)


def _strain(tab, c, x):
    """sum_n c_n cos(lambda_n x): the upper surface's strain whose modal coefficients are c."""
    return np.cos(np.outer(np.atleast_1d(x), tab.lam)) @ c


def test_a_sharp_peak_between_nodes_beats_a_broad_one_at_a_node():
    """A sharp peak (every mode in phase) midway between two nodes, 1.14 times a broad one (the
    first 8 modes) at a node: its nodes stand 2.2 % below the broad peak's node, out of a race of
    PEAK_MARGIN, yet it is the global peak, 0.3 % above the broad one. The search finds it: at or
    above the peak on a grid 256 times finer (by less than that grid's own error)."""
    tab = _cosines()
    dx, lam = tab.dx, tab.lam
    n = np.arange(1, lam.size + 1)
    sharp_at, broad_at = 40.5 * dx, 150 * dx
    fine = np.linspace(0.0, tab.xq[-1], 256 * (tab.xq.size - 1) + 1)
    sharp = np.cos(lam * sharp_at)
    broad = np.where(n <= 8, np.cos(lam * broad_at), 0.0)
    c = 1.14 * sharp / _strain(tab, sharp, fine).max() + broad / _strain(tab, broad, fine).max()
    nodes, values = _strain(tab, c, tab.xq), _strain(tab, c, fine)
    top = values.max()
    assert nodes[40:42].max() < nodes.max() - PEAK_MARGIN * abs(nodes.max())   # out of the old race
    assert abs(fine[values.argmax()] - sharp_at) < 0.05 * dx and top > 1.003 * nodes.max()
    w = tab.model.plate.modes[STRAIN]
    value, x, node = global_peak(np.ascontiguousarray(nodes), 1.0, tab.model.basis, w, np.ascontiguousarray(c / w), True)
    assert top * (1.0 - 1e-12) <= value <= top * (1.0 + 1e-6)        # (the fine grid's own error: 3.5e-7)
    assert abs(value - _strain(tab, c, x)[0]) <= 1e-12 * top
    assert abs(x - sharp_at) < 0.05 * dx and node in (40, 41)


def test_the_margin_is_the_grids_bound():
    """competing: PEAK_MARGIN of the top at least; the reach (k dx)^2 / 8 of the largest |eps| over
    the plate (bounded from the nodes'), or the curvature bound times dx^2 / 8, whichever is less;
    on the cosines the curvature bound is sum |c_n| lambda_n^2, and no peak on a fine grid stands
    above its nearest node by more than it times dx^2 / 8."""
    tab = _cosines()
    reach = tab.model.basis.reach
    assert math.isclose(reach, peak_reach(tab.lam[-1], tab.dx)) and math.isclose(reach, (tab.lam[-1] * tab.dx) ** 2 / 8)
    eps = np.array([0.5, -2.0, 1.0])
    assert competing(eps, 1.0, reach, math.inf) == reach * 2.0 / (1.0 - reach)
    assert competing(eps, 1.0, reach, 1e-3) == PEAK_MARGIN
    assert competing(eps, 1.0, 1.5, 0.3) == 0.3                     # a reach of 1 or more bounds nothing
    rng = np.random.default_rng(7)
    w = tab.model.plate.modes[STRAIN]
    for _ in range(5):
        c = rng.standard_normal(tab.lam.size) / (1.0 + np.arange(tab.lam.size)) ** 1.5
        a = np.ascontiguousarray(c / w)
        load_dry(tab.model.basis, a)
        bend = curvature_bound(tab.model.basis, w, a)
        assert math.isclose(bend, np.sum(np.abs(c) * tab.lam**2), rel_tol=1e-10)
        fine = np.linspace(0.0, tab.xq[-1], 64 * (tab.xq.size - 1) + 1)
        values = _strain(tab, c, fine)
        peaks = np.flatnonzero((values[1:-1] > values[:-2]) & (values[1:-1] >= values[2:])) + 1
        nearest = _strain(tab, c, tab.dx * np.round(fine[peaks] / tab.dx))
        assert peaks.size > 3 and np.max(values[peaks] - nearest) <= bend * tab.dx**2 / 8
