"""The a posteriori estimate of a run's strain error (docs/numerics.md, "Per-case error
estimate"): the time integration's part, from a companion run at 10x the tolerance (etd34) or
from the summed local error estimates (rk4); the omitted modes' part, from the top quarter of
the retained ones; the quadrature's part, from the energy identity's residual. Each part's factor
was measured against converged runs (error_estimates' docstring); tests/test_error_estimate.py
checks the estimates against true errors."""
from __future__ import annotations

import numpy as np


#: error of etd34 against its tolerance, e ~ tol^p, by error control: under "embedded" measured
#: p = 0.45..0.71 over the work_precision study (tolerances 1e-11..1e-6, three cases), 10^0.6 - 1
#: = 2.98; under "smoothness" p = 0.42..1.04, median 0.82, from 1e-6 to 1e-7 on the seven cases of
#: benchmarks/time_integrator.py (2026-11-28), 10^0.8 - 1 = 5.3
TOLERANCE_EXPONENT = {"embedded": 0.6, "smoothness": 0.8}
#: strain quadrature error / energy residual: measured 1.8..9.9 over the work_precision study
#: (250..4000 subintervals, three cases); both fall as dx^2
QUADRATURE_FACTOR = 4.0


def error_estimates(amplitudes, strain_coef, energy_residual, accumulated=None, companion=None,
                    exponent=TOLERANCE_EXPONENT["embedded"]) -> dict:
    """Relative L2 strain-error estimates over the output times (see DIAGNOSTIC_INFO).

    With s_n = (hi/2) lambda_n^2 the strain at t_k is sum_n s_n a_n cos(lambda_n x); by
    orthogonality its L2 norm over an even grid on -L..L is proportional to |s a(t_k)|, so
    every part is a ratio of modal norms over the output times:
      modes: |s a| over n > 3N/4 divided by |s a|: the omitted modes are taken to be as large
             as the top quarter of the retained ones (measured 0.8..18 x the true error, Nmod
             10..120, against 240 modes);
      time, from a companion run at 10x the tolerance: |s (a - a_c)| / |s a| / (10^p - 1),
             p = exponent, TOLERANCE_EXPONENT of the run's error control (embedded: measured
             0.33..2.2 x the true error, tolerances 1e-5..1e-11);
      time, from ``accumulated`` local error estimates E_k summed up to t_k (rk4; no
             cancellation): sqrt(sum_k E_k^2) / |s a| (measured 1.3..4.5 x the true error);
      quadrature: QUADRATURE_FACTOR x the energy-identity residual. Under the paper's rule the
             residual comes from the same O(dx^2) interpolation of f (measured 0.41..2.3 x the
             true error). The Gauss rule's energy and power use one rule, so its residual is the
             time integration's and this part does not see its quadrature error, which falls
             spectrally with quadrature_density: at density >= 4 time + quadrature measured
             0.28..4.0 x the true error, at density 3 down to 0.02 x
             (benchmarks/gauss_error_estimate.py; docs/numerics.md).
    """
    nan = {name: np.nan for name in ("error_estimate", "error_estimate_time", "error_estimate_modes",
                                     "error_estimate_quadrature")}
    coeffs = amplitudes * strain_coef
    total = np.sqrt(np.sum(coeffs**2))
    if not total > 0:
        return nan
    N = coeffs.shape[1]
    modes = float(np.sqrt(np.sum(coeffs[:, (3 * N) // 4:] ** 2)) / total)
    time = np.nan
    if companion is not None:
        both = np.all(np.isfinite(companion), axis=1)
        if both.all():
            diff = np.sqrt(np.sum(((amplitudes - companion) * strain_coef) ** 2))
            time = float(diff / total / (10**exponent - 1))
    elif accumulated is not None and np.all(np.isfinite(accumulated)):
        time = float(np.sqrt(np.sum(accumulated**2)) / total)
    quadrature = QUADRATURE_FACTOR * float(energy_residual)
    return {"error_estimate": time + modes + quadrature, "error_estimate_time": time,
            "error_estimate_modes": modes, "error_estimate_quadrature": quadrature}
