r"""A sparse polynomial-chaos surrogate of one output over a box of inputs, and the Sobol' indices
it gives, with intervals that include its own truncation error (issue 39; OpenTURNS, chosen by
measurement: benchmarks/pce_libraries.py).

Plain functions on arrays, as SALib's: ``fit(X, y, bounds)`` then ``indices(X, y, bounds)``.

- **The expansion.** The inputs are uniform on the box; y is expanded on tensor Legendre
  polynomials of total degree <= d, the terms chosen by LARS with the corrected leave-one-out
  error (OpenTURNS' LeastSquaresMetaModelSelectionFactory). The degree d is the one with the
  best K-fold cross-validated predictivity

      Q2 = 1 - sum_i (y_i - yhat_{-k(i)}(x_i))^2 / sum_i (y_i - mean y)^2,

  yhat_{-k} the expansion fitted without fold k (OpenTURNS' fast leave-one-out does not hold
  after a model selection). The first-order and total indices S1, ST are sums of the squared
  coefficients (FunctionalChaosSobolIndices).
- **Honest intervals.** Each index's interval is the bootstrap's (the expansion at degree d
  refitted on runs drawn with replacement; 2.5 and 97.5 percentiles) widened on both sides by
  the truncation's own measure: how far the index moves between degree d and the degrees d - 1
  and d + 1 fitted on all runs. A bootstrap alone ignores the truncation and can be too narrow
  (openturns issue 2380).
- **Refusal.** Below ``q2_min`` (default 0.9) the expansion does not predict y well enough for
  its variance to be split: ``indices`` raises SurrogateError with Q2 and what would help (more
  runs; a transform of the output, such as its logarithm; fewer inputs).

Benchmark (tests/test_surrogate.py): on the Ishigami function at 128 runs the indices lie
within their intervals of the exact values; on a kinked function (max(0, x1 + x2) + x3 / 2) the
intervals cover the exact values, computed by quadrature.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the degrees tried; the cross-validation's folds; the bootstrap's resamples
DEGREES = tuple(range(1, 13))
FOLDS = 5
BOOTSTRAP = 100
#: below this cross-validated Q2 the indices are refused
Q2_MIN = 0.9


class SurrogateError(ValueError):
    """The surrogate cannot answer: its one line says why and what would help."""


@dataclass
class Surrogate:
    """A fitted expansion: its degree, cross-validated Q2 and RMSE (the error estimate of a
    prediction), the box, and OpenTURNS' result (its metamodel, its coefficients)."""
    degree: int
    q2: float
    rmse: float
    bounds: np.ndarray
    result: object

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
    selection = ot.LeastSquaresMetaModelSelectionFactory(ot.LARS(), ot.CorrectedLeaveOneOut())
    algo = ot.FunctionalChaosAlgorithm(ot.Sample(U), ot.Sample(y[:, None]), dist,
                                       ot.FixedStrategy(basis, enum.getStrataCumulatedCardinal(degree)),
                                       ot.LeastSquaresStrategy(selection))
    algo.run()
    return algo.getResult()


def _cross_validated(U, y, degree, folds):
    """(Q2, RMSE) of the expansion at degree by K-fold cross-validation (folds interleaved)."""
    import openturns as ot
    k = np.arange(y.size) % folds
    pred = np.empty_like(y)
    for f in range(folds):
        train, test = k != f, k == f
        pred[test] = np.asarray(_expansion(U[train], y[train], degree).getMetaModel()(ot.Sample(U[test])))[:, 0]
    err = y - pred
    return 1.0 - np.mean(err**2) / np.var(y), float(np.sqrt(np.mean(err**2)))


def fit(X, y, bounds, degrees=DEGREES, folds=FOLDS) -> Surrogate:
    """The sparse expansion of y over the box, its degree the one of the best cross-validated Q2
    among ``degrees`` (LARS keeps a sparse basis where the full one outgrows the runs)."""
    X, y, bounds = _checked(X, y, bounds)
    U = _unit(X, bounds)
    if np.var(y) == 0.0:
        raise SurrogateError("the output is constant over the runs: it has no variance to split")
    best = None
    for degree in degrees:
        q2, rmse = _cross_validated(U, y, degree, folds)
        if best is None or q2 > best[0]:
            best = (q2, rmse, degree)
    q2, rmse, degree = best
    return Surrogate(degree, float(q2), rmse, bounds, _expansion(U, y, degree))


def _sobol(result, d):
    import openturns as ot
    s = ot.FunctionalChaosSobolIndices(result)
    return (np.array([s.getSobolIndex(i) for i in range(d)]), np.array([s.getSobolTotalIndex(i) for i in range(d)]))


def indices(X, y, bounds, q2_min=Q2_MIN, bootstrap=BOOTSTRAP, seed=0, degrees=DEGREES, folds=FOLDS) -> dict:
    """S1 and ST of y over the box from its sparse expansion, each with a 95% interval of the
    runs' sampling and the truncation (module docstring). Returns {"S1", "ST", "S1_low", "S1_high",
    "ST_low", "ST_high": arrays over the inputs; "q2", "degree", "rmse", "surrogate"}. Raises
    SurrogateError where the cross-validated Q2 is below q2_min."""
    X, y, bounds = _checked(X, y, bounds)
    sur = fit(X, y, bounds, degrees, folds)
    if not sur.q2 >= q2_min:
        raise SurrogateError(f"the expansion predicts this output with Q2 = {sur.q2:.3f} (cross-validated, degree "
                             f"{sur.degree}), below {q2_min:g}: its indices would not be trustworthy; more runs, a "
                             f"transform of the output (its logarithm) or fewer inputs would help")
    d = X.shape[1]
    U = _unit(X, bounds)
    S1, ST = _sobol(sur.result, d)
    rng = np.random.default_rng(seed)
    draws = np.empty((bootstrap, 2, d))
    for b in range(bootstrap):
        pick = rng.integers(0, y.size, y.size)
        draws[b] = _sobol(_expansion(U[pick], y[pick], sur.degree), d)
    low, high = np.percentile(draws, 2.5, axis=0), np.percentile(draws, 97.5, axis=0)
    spread = np.zeros((2, d))                   # the truncation: the indices at the neighbouring degrees
    for degree in (sur.degree - 1, sur.degree + 1):
        if degree >= 1:
            spread = np.maximum(spread, np.abs(np.array(_sobol(_expansion(U, y, degree), d)) - (S1, ST)))
    low, high = np.minimum(low, (S1, ST)) - spread, np.maximum(high, (S1, ST)) + spread
    return {"S1": S1, "ST": ST, "S1_low": low[0], "S1_high": high[0], "ST_low": low[1], "ST_high": high[1],
            "q2": sur.q2, "degree": sur.degree, "rmse": sur.rmse, "surrogate": sur}
