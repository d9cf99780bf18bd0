r"""How far below the largest node a local peak of the tension still competes for the global peak
(solver.model.basis.global_peak; docs/model.md, "Crack onset (the tension record)": "The
competing peaks' margin"): a peak between nodes stands above its nearest node by at most dx^2 / 8
times a bound on the field's curvature, from the grid (peak_reach) or from the state's own modes
(curvature_bound).

Benchmark (tests/test_peak_search.py, benchmarks/peak_margin.py): a sharp peak between nodes
2.2 % above them found against a broad one at a node; on the cosines no peak of a fine grid stands
above its nearest node by more than curvature_bound dx^2 / 8.
"""
from ..compile.jit import kernel
from .floe import BETAS, HYP, KINDS, STRAIN_FACTOR, TRIG, floe_header, floe_shapes


#: local peaks within PEAK_MARGIN (relative) of the largest node compete for the global peak, and
#: further where the grid says a peak between nodes may stand higher (competing)
PEAK_MARGIN = 0.02


def peak_reach(k, dx):
    """Basis.reach: the most a peak between nodes dx apart stands above its nearest node, as a
    fraction of the largest |field| over the plate, for a field of wavenumbers up to k [m-1]:
    |f''| <= k^2 max|f| (Bernstein's inequality for a sum of cosines) over half a node's
    spacing, (k dx)^2 / 8 (0.4 % at N = 60 on the paper's 1000 subintervals of L = 6 m, 7.1 % on
    the default 250; benchmarks/peak_margin.py). On a broken plate or a floe k is the largest
    wavenumber of the parts' modes, where the bound is the same on each part's trigonometric
    terms."""
    return (k * dx) ** 2 / 8.0


@kernel
def competing(eps, top, reach, bend):
    """How far below the largest node's value top a node's local peak still competes for the
    global peak: PEAK_MARGIN of |top|, or, where more, the most a peak between nodes can stand
    above its nearest node (half a spacing away, where its slope is 0): the less of the reach
    (Basis.reach) of the largest |eps| over the continuous plate (at most max_j |eps_j| / (1 -
    reach); no bound where the reach is 1 or more) and bend, a bound on |eps''| over the plate
    times dx^2 / 8 (curvature_bound; inf: none)."""
    margin = bend
    if reach < 1.0:
        largest = 0.0
        for j in range(eps.shape[0]):
            largest = max(largest, abs(eps[j]))
        margin = min(margin, reach * largest / (1.0 - reach))
    return max(PEAK_MARGIN * abs(top), margin)


@kernel(nrt=True)
def curvature_bound(basis, w, a):
    """A bound on |f''| over the plate, f the strain field of the state a (its weights w on the
    cosines): sum_n |w_n a_n| lambda_n^2 on the cosines (lambda_n = n lambda_1); on a floe-form
    basis, from the dry coefficients d load_dry loaded, |STRAIN_FACTOR| sum_m |d_m| beta_m^4
    (|TRIG_m| + 2 |HYP_m|) over the elastic modes (the fourth derivative of each term of psi is
    beta^4 times it, and each exponential is at most 1 on its part; a rigid mode's psi'' is 0).
    Widened by 1e-12 of itself for the sum's rounding."""
    total = 0.0
    if basis.floe.shape[0] == 0:
        for n in range(a.shape[0]):
            lam = (n + 1) * basis.lam1
            total += abs(w[n] * a[n]) * lam * lam
        return total * (1.0 + 1e-12)
    N = a.shape[0]
    shapes = floe_shapes(basis.floe, N)
    for m in range(N):
        if shapes[KINDS, m] >= 2.0:
            beta = shapes[BETAS, m]
            total += abs(basis.dry[m]) * beta**4 * (abs(shapes[TRIG, m]) + 2.0 * abs(shapes[HYP, m]))
    return abs(floe_header(basis.floe)[STRAIN_FACTOR]) * total * (1.0 + 1e-12)
