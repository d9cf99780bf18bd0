"""A study's polynomial-chaos emulator: each output of a pce [analysis] predicted anywhere in
the design's box, with its error estimate, from the expansion stored in ``sensitivity.nc``
(its terms and coefficients; evaluated with numpy alone, pipeline.analyse.surrogate.evaluate).

    >>> emulator = pipeline.open_emulator("results/sensitivity_pce")
    >>> emulator.outputs
    ['crack_onset_time@8e-05', 'max_strain', 'impact_zone_max_strain']
    >>> p = emulator.predict("max_strain", K=3e6, he=0.02, R=10.0, V=[2.0, 4.0], hi=0.5)
    >>> p.value, p.error             # the prediction and the cross-validated RMSE

The keys broadcast as numpy arrays do. A point outside the box, a missing or unknown key, an
unknown output and an output whose expansion was refused (Q2 below the analysis's q2_min) are
refused in one line (EmulatorError). The error estimate is the expansion's 5-fold
cross-validated RMSE: the typical error at a point it did not see, not a bound.
"""
from __future__ import annotations

import json
from typing import NamedTuple

import numpy as np

from ..common.errors import EmulatorError
from .sensitivity import unit_scale
from .surrogate import evaluate


class Prediction(NamedTuple):
    """Predicted values at the points, and the error estimate (cross-validated RMSE, in the
    output's units; of its logarithm for a log(...) output), broadcast to their shape."""
    value: np.ndarray
    error: np.ndarray


class Emulator:
    """The expansions of a pce analysis (``sensitivity.nc``) over the design's box."""

    def __init__(self, indices):
        analysis = json.loads(indices.attrs.get("analysis", "{}"))
        if analysis.get("method") != "pce" or "coefficient" not in indices:
            raise EmulatorError(f"the study's [analysis] is method = {analysis.get('method')!r}: an emulator needs "
                                f"method = \"pce\"")
        design = json.loads(indices.attrs["design"])
        self.box = {k: tuple(v) for k, v in design["keys"].items()}       # key -> (min, max, log)
        self.keys = list(self.box)
        self.outputs = [str(o) for o in indices["output"].values]
        self.q2 = {o: float(v) for o, v in zip(self.outputs, indices["q2"].values)}
        self.error = {o: float(v) for o, v in zip(self.outputs, indices["rmse"].values)}
        self.refusals = json.loads(indices.attrs.get("refusals", "{}"))
        self._terms = {}
        for i, o in enumerate(self.outputs):
            coefficient = np.asarray(indices["coefficient"].values[i], dtype=float)
            used = np.isfinite(coefficient)
            self._terms[o] = (np.asarray(indices["multi_index"].values[i])[used], coefficient[used])

    def predict(self, output: str, **values) -> Prediction:
        """The output at the points given by each key's values (scalars or arrays that broadcast)."""
        if output not in self.outputs:
            raise EmulatorError(f"no output {output!r} in this emulator; it has {', '.join(self.outputs)}")
        if output in self.refusals:
            raise EmulatorError(f"{output}: {self.refusals[output]}")
        missing, unknown = [k for k in self.keys if k not in values], [k for k in values if k not in self.box]
        if missing or unknown:
            raise EmulatorError(f"give each key of the design ({', '.join(self.keys)}) and no other"
                                + (f"; missing {', '.join(missing)}" if missing else "")
                                + (f"; unknown {', '.join(unknown)}" if unknown else ""))
        arrays = []
        for k in self.keys:
            try:       # (text is not a number, though numpy would read "0.3" as one)
                a = np.array([np.nan]) if np.asarray(values[k]).dtype.kind in "USO" else \
                    np.asarray(values[k], dtype=float)
            except (TypeError, ValueError):
                a = np.array([np.nan])
            if np.isnan(a).any():         # (an empty array is no points: an empty prediction)
                raise EmulatorError(f"{k} = {values[k]!r}: give numbers (a scalar or an array of them)")
            arrays.append(a)
        try:
            arrays = np.broadcast_arrays(*arrays)
        except ValueError:
            raise EmulatorError("the keys' values do not broadcast to one shape: " + ", ".join(
                f"{k} {np.shape(a)}" for k, a in zip(self.keys, arrays))) from None
        shape = arrays[0].shape
        U = np.empty((arrays[0].size, len(self.keys)))
        for j, (k, a) in enumerate(zip(self.keys, arrays)):
            lo, hi, log = self.box[k]
            a = a.reshape(-1)
            outside = ~((a >= lo) & (a <= hi))
            if outside.any():
                raise EmulatorError(f"{k} = {a[outside][0]:g} is outside the design's box [{lo:g}, {hi:g}]: the "
                                    f"expansion is valid only where it was fitted")
            U[:, j] = 2.0 * unit_scale(a, lo, hi, log) - 1.0
        multi, coefficient = self._terms[output]
        value = evaluate(multi, coefficient, U).reshape(shape)
        return Prediction(value, np.full(shape, self.error[output]))
