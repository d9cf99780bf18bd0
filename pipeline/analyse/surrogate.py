r"""A sparse polynomial-chaos surrogate of one output over a box of inputs, and the Sobol' indices
it gives, with intervals that include its own truncation error (issue 39; OpenTURNS, chosen by
measurement: benchmarks/pce_libraries.py).

Plain functions on arrays, as SALib's: ``fit(X, y, bounds)`` then ``indices(X, y, bounds)``;
``evaluate(multi_index, coefficients, U)`` evaluates a stored expansion with numpy alone (the
emulator, pipeline.analyse.emulator, needs no OpenTURNS to answer).

- **The expansion.** The inputs are uniform on the box; y is expanded on tensor Legendre
  polynomials of total degree <= d, the terms chosen by LARS with the corrected leave-one-out
  error (OpenTURNS' LeastSquaresMetaModelSelectionFactory). The degree d is the one with the
  best K-fold cross-validated predictivity

      Q2 = 1 - sum_i (y_i - yhat_{-k(i)}(x_i))^2 / sum_i (y_i - mean y)^2,

  yhat_{-k} the expansion fitted without fold k (OpenTURNS' fast leave-one-out does not hold
  after a model selection). The first-order and total indices S1, ST are sums of the squared
  coefficients (FunctionalChaosSobolIndices). The degrees are tried upwards from 1 and the search
  stops after ``PATIENCE`` degrees without a better Q2, or where the candidate basis,
  C(d + degree, d) terms, would exceed ``MAX_TERMS``.
- **Its terms.** The expansion is sum_k c_k prod_j phi_{a_kj}(u_j), u the point mapped onto
  [-1, 1]^d and phi_n = sqrt(2n + 1) P_n the orthonormal Legendre polynomials (OpenTURNS'
  LegendreFactory): ``Surrogate.terms()`` gives the multi-indices a and the coefficients c.
- **Honest intervals.** Each index's interval holds three parts, added:

  1. *sampling*: the bootstrap of the expansion (Marelli and Sudret's bootstrap PCE, 2018): its
     selected terms refitted by least squares on runs drawn with replacement, the
     (1 - conf_level) / 2 percentiles of the indices they give;
  2. *the degree*: how far the index moves between degree d and the degrees d - 1 and d + 1
     fitted on all runs;
  3. *the variance the expansion misses*: the cross-validated 1 - Q2 = e of the output's
     variance lies outside its terms and, orthogonal to them, could belong to any input, so the
     output's own index lies in [S (1 - e), S (1 - e) + e].

  A bootstrap alone ignores the truncation and can be too narrow (openturns issue 2380); with
  part 3 an output predicted at Q2 = 0.9 gets intervals about 0.1 wide whatever its runs say.
- **Refusal.** Below ``q2_min`` (default 0.9) the expansion does not predict y well enough for
  its variance to be split: ``indices`` raises SurrogateError with Q2 and what would help (more
  runs; a transform of the output, such as its logarithm; fewer inputs).

Benchmarks (tests/test_surrogate.py, tests/test_pce_analysis.py): on the Ishigami function at
128 runs the indices lie within their intervals of the exact values; on a kinked function
(max(0, x1 + x2) + x3 / 2) and on a censored one with a jump, the intervals cover the exact
values or the output is refused.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..study.analysis import FOLDS, MAX_DEGREE, MAX_TERMS, Q2_MIN, basis_size

#: degrees tried past the best Q2 before the search stops; the bootstrap's resamples (the
#: limits a study can ask for, the degrees, terms and folds, are [analysis]'s: pipeline.study.analysis)
PATIENCE = 2
BOOTSTRAP = 100


class SurrogateError(ValueError):
    """The surrogate cannot answer: its one line says why and what would help."""


@dataclass
class Surrogate:
    """A fitted expansion: its degree, cross-validated Q2 and RMSE (the error estimate of a
    prediction), each run's held-out prediction (by the fold's expansion fitted without it), the
    box, and OpenTURNS' result (its metamodel, its coefficients)."""
    degree: int
    q2: float
    rmse: float
    bounds: np.ndarray
    result: object
    held_out: np.ndarray

    def terms(self) -> tuple:
        """(multi_index (terms, inputs) of integers, coefficients (terms,)) of the expansion."""
        return _terms(self.result, self.bounds.shape[0])

    def predict(self, X) -> np.ndarray:
        """Values at the points X (n, d) inside the box; a point outside it is refused."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        lo, hi = self.bounds[:, 0], self.bounds[:, 1]
        outside = np.any((X < lo) | (X > hi), axis=1)
        if outside.any():
            raise SurrogateError(f"{int(outside.sum())} point(s) outside the design's box "
                                 f"({', '.join(f'[{a:g}, {b:g}]' for a, b in self.bounds)}): the expansion "
                                 f"is valid only where it was fitted")
        import openturns as ot
        return np.asarray(self.result.getMetaModel()(ot.Sample(_unit(X, self.bounds))))[:, 0]


def _terms(result, d):
    import openturns as ot
    enum = ot.LinearEnumerateFunction(d)
    multi = np.array([list(enum(int(i))) for i in result.getIndices()], dtype=np.int64).reshape(-1, d)
    return multi, np.asarray(result.getCoefficients(), dtype=float)[:, 0]


def _unit(X, bounds):
    """X mapped from the box onto [-1, 1]^d."""
    return 2.0 * (X - bounds[:, 0]) / (bounds[:, 1] - bounds[:, 0]) - 1.0


def _checked(X, y, bounds):
    X, y, bounds = (np.asarray(v, dtype=float) for v in (X, y, bounds))
    if X.ndim != 2 or y.shape != (X.shape[0],) or bounds.shape != (X.shape[1], 2):
        raise SurrogateError(f"X must be (runs, inputs), y (runs,) and bounds (inputs, 2); got {X.shape}, "
                             f"{y.shape}, {bounds.shape}")
    if not np.all(bounds[:, 1] > bounds[:, 0]):
        raise SurrogateError("each input's bounds must be [low, high] with low < high")
    bad = ~np.isfinite(y)
    if bad.any():
        raise SurrogateError(f"{int(bad.sum())} of {y.size} outputs are not finite: censor them first (as the "
                             f"Sobol' analysis does) or choose another output")
    return X, y, bounds


def _expansion(U, y, degree):
    """OpenTURNS' sparse expansion of y over U in [-1, 1]^d at total degree <= degree."""
    import openturns as ot
    ot.Log.Show(ot.Log.NONE)
    d = U.shape[1]
    dist = ot.JointDistribution([ot.Uniform(-1.0, 1.0)] * d)
    enum = ot.LinearEnumerateFunction(d)
    basis = ot.OrthogonalProductPolynomialFactory([ot.LegendreFactory()] * d, enum)
    # QR rather than OpenTURNS' default SVD in the selection's least squares: the same expansion to
    # round-off, 2.5x faster (82 terms of 126 from 256 runs: 0.39 s against 1.0 s)
    ot.ResourceMap.SetAsString("LeastSquaresMetaModelSelection-DecompositionMethod", "QR")
    selection = ot.LeastSquaresMetaModelSelectionFactory(ot.LARS(), ot.CorrectedLeaveOneOut())
    algo = ot.FunctionalChaosAlgorithm(ot.Sample(U), ot.Sample(y[:, None]), dist,
                                       ot.FixedStrategy(basis, enum.getStrataCumulatedCardinal(degree)),
                                       ot.LeastSquaresStrategy(selection))
    algo.run()
    return algo.getResult()


def _cross_validated(U, y, degree, folds):
    """(Q2, RMSE, held-out predictions) of the expansion at degree by K-fold cross-validation
    (folds interleaved)."""
    import openturns as ot
    k = np.arange(y.size) % folds
    pred = np.empty_like(y)
    for f in range(folds):
        train, test = k != f, k == f
        pred[test] = np.asarray(_expansion(U[train], y[train], degree).getMetaModel()(ot.Sample(U[test])))[:, 0]
    err = y - pred
    return 1.0 - np.mean(err**2) / np.var(y), float(np.sqrt(np.mean(err**2))), pred


def fit(X, y, bounds, max_degree=MAX_DEGREE, folds=FOLDS) -> Surrogate:
    """The sparse expansion of y over the box, its degree the one of the best cross-validated Q2
    among 1..max_degree (LARS keeps a sparse basis where the full one outgrows the runs; the
    search stops as the module says)."""
    X, y, bounds = _checked(X, y, bounds)
    U = _unit(X, bounds)
    if np.var(y) == 0.0:
        raise SurrogateError("the output is constant over the runs: it has no variance to split")
    best, since = None, 0
    for degree in range(1, max_degree + 1):
        if degree > 1 and basis_size(X.shape[1], degree) > MAX_TERMS:
            break
        q2, rmse, held_out = _cross_validated(U, y, degree, folds)
        if best is None or q2 > best[0]:
            best, since = (q2, rmse, degree, held_out), 0
        else:
            since += 1
            if since >= PATIENCE:
                break
    q2, rmse, degree, held_out = best
    return Surrogate(degree, float(q2), rmse, bounds, _expansion(U, y, degree), held_out)


def _basis(multi_index, U) -> np.ndarray:
    """The expansion's terms at the points U in [-1, 1]^d: (points, terms), prod_j phi_{a_kj}(u_j)."""
    U = np.atleast_2d(np.asarray(U, dtype=float))
    multi_index = np.asarray(multi_index)
    top = int(multi_index.max(initial=0))
    phi = np.empty((top + 1, *U.shape))              # phi[n] = sqrt(2n + 1) P_n(U), by the recurrence
    p_prev, p = np.ones_like(U), U.copy()
    phi[0] = 1.0
    if top >= 1:
        phi[1] = np.sqrt(3.0) * p
    for n in range(1, top):
        p_prev, p = p, ((2 * n + 1) * U * p - n * p_prev) / (n + 1)
        phi[n + 1] = np.sqrt(2 * n + 3) * p
    cols = np.arange(U.shape[1])
    return np.stack([np.prod(phi[a, :, cols], axis=0) for a in multi_index], axis=1)


def evaluate(multi_index, coefficients, U) -> np.ndarray:
    """The expansion sum_k c_k prod_j phi_{a_kj}(u_j) at the points U (n, d) in [-1, 1]^d, with
    numpy alone (phi_n = sqrt(2n + 1) P_n by the three-term recurrence)."""
    return _basis(multi_index, U) @ np.asarray(coefficients, dtype=float)


def sobol_indices(multi_index, coefficients) -> tuple:
    """(S1, ST) from an orthonormal expansion: the variance is the sum of the squared coefficients
    of the non-constant terms; S1_j takes the terms in u_j alone, ST_j every term with u_j."""
    multi_index, c2 = np.asarray(multi_index), np.asarray(coefficients, dtype=float) ** 2
    used = multi_index > 0
    variance = c2[used.any(axis=1)].sum()
    alone = used & (used.sum(axis=1) == 1)[:, None]
    return (c2 @ alone) / variance, (c2 @ used) / variance


def indices(X, y, bounds, q2_min=Q2_MIN, bootstrap=BOOTSTRAP, seed=0, max_degree=MAX_DEGREE, folds=FOLDS,
            conf_level=0.95, surrogate=None) -> dict:
    """S1 and ST of y over the box from its sparse expansion, each with a ``conf_level`` interval
    of the runs' sampling and the truncation (module docstring). Returns {"S1", "ST", "S1_low",
    "S1_high", "ST_low", "ST_high": arrays over the inputs; "q2", "degree", "rmse", "surrogate"}.
    Raises SurrogateError where the cross-validated Q2 is below q2_min. ``surrogate``: the fit of
    these runs, if made already."""
    X, y, bounds = _checked(X, y, bounds)
    sur = surrogate or fit(X, y, bounds, max_degree, folds)
    if not sur.q2 >= q2_min:
        raise SurrogateError(f"the expansion predicts this output with Q2 = {sur.q2:.3f} (cross-validated, degree "
                             f"{sur.degree}), below {q2_min:g}: its indices would not be trustworthy; more runs, a "
                             f"transform of the output (its logarithm) or fewer inputs would help")
    d = X.shape[1]
    U = _unit(X, bounds)
    multi, coefficients = sur.terms()
    S1, ST = sobol_indices(multi, coefficients)
    psi = _basis(multi, U)
    rng = np.random.default_rng(seed)
    draws = np.empty((bootstrap, 2, d))
    for b in range(bootstrap):                  # the selected terms refitted on resampled runs
        pick = rng.integers(0, y.size, y.size)
        draws[b] = sobol_indices(multi, np.linalg.lstsq(psi[pick], y[pick], rcond=None)[0])
    tail = 50.0 * (1.0 - conf_level)
    low, high = np.percentile(draws, tail, axis=0), np.percentile(draws, 100.0 - tail, axis=0)
    spread = np.zeros((2, d))                   # the truncation: the indices at the neighbouring degrees
    for degree in (sur.degree - 1, sur.degree + 1):
        if degree >= 1 and (degree == 1 or basis_size(d, degree) <= MAX_TERMS):
            spread = np.maximum(spread, np.abs(np.array(sobol_indices(*_terms(_expansion(U, y, degree), d)))
                                               - (S1, ST)))
    # the variance the expansion misses, 1 - Q2 of the output's, is orthogonal to its terms and
    # could belong to any key: the output's own index lies in [S (1 - e), S (1 - e) + e]
    missed = max(0.0, 1.0 - sur.q2)
    index = np.array((S1, ST))
    low = np.minimum(low, index) - spread - missed * index
    high = np.maximum(high, index) + spread + missed * (1.0 - index)
    return {"S1": S1, "ST": ST, "S1_low": low[0], "S1_high": high[0], "ST_low": low[1], "ST_high": high[1],
            "q2": sur.q2, "degree": sur.degree, "rmse": sur.rmse, "surrogate": sur}
