"""Sensitivity indices of a design's outputs, computed after the combine with SALib (sobol,
morris) or from a polynomial-chaos surrogate (pce, pipeline.analyse.surrogate); the [analysis] table and
its rules, the censoring of outputs that are not finite among them, are pipeline.study.analysis's:
``analyze(study.nc, design, analysis)`` -> a Dataset along (output, key). With pce it holds
each output's expansion too (its terms, Q2, error estimate and held-out predictions), which
pipeline.analyse.emulator reads."""
from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np

from ..common import provenance
from ..common.errors import StudyError
from ..common.tables import COMPLETE
from ..study.analysis import CRACK_OUTPUTS, EVENT_TIMES, MORRIS_LEVELS
from . import surrogate


def problem(design: dict) -> dict:
    """SALib's problem on the unit cube (the keys' own scales are mapped by pipeline.study.design)."""
    keys = list(design.keys)
    return {"num_vars": len(keys), "names": keys, "bounds": [[0.0, 1.0]] * len(keys)}


def output_values(ds, name: str, eps_Y: float | None = None) -> tuple:
    """(values along sample, censored mask, label) of one output, non-finite values censored as
    the module says."""
    if name in CRACK_OUTPUTS:
        from ..store.fracture import crack_onset
        onset = crack_onset(ds, eps_Y=[eps_Y]) if "tension_record_count" in ds else ds.sel(eps_Y=[eps_Y])
        values = np.asarray(onset[name].values, dtype=float).reshape(-1)
        label = f"{name}@{eps_Y:g}"
    else:
        values = np.asarray(ds[name].values, dtype=float).reshape(-1)
        label = name
    censored = ~np.isfinite(values)
    if censored.any():
        if name in EVENT_TIMES:
            values = np.where(censored, np.asarray(ds["time_reached"].values, dtype=float), values)
        else:
            finite = values[~censored]
            values = np.where(censored, finite.max() if finite.size else 0.0, values)
    return values, censored, label


def analyze(ds, design: dict, analysis: dict):
    """The indices of each requested output (and yield strain) over the design's keys, as a
    labelled Dataset along (output, key)."""
    import xarray as xr
    status = np.asarray(ds["status"].values).reshape(-1)
    broken = ~np.isin(status, [*COMPLETE, "layer_bottomed_out"])
    if broken.any():
        raise StudyError(f"{int(broken.sum())} of {status.size} samples failed or are missing "
                         f"({', '.join(sorted(set(status[broken])))}): no sensitivity indices (run again, or "
                         f"with --rerun-failed)")
    keys = list(design.keys)
    X = np.column_stack([unit_scale(np.asarray(ds[k].values, dtype=float), *design.keys[k]) for k in keys])
    rows, labels, censored = [], [], []
    for name in analysis.outputs:
        for eps in (analysis.eps_Y if name in CRACK_OUTPUTS else [None]):
            Y, cens, label = output_values(ds, name, eps)
            refusal = ""
            if cens.all():                  # censored whole: indices of the stand-in, not of the output
                refusal = (f"{label}: no sample produced it (all {Y.size} values NaN: an event no run reached, "
                           f"or an output these settings do not compute)")
                if analysis.method != "pce":
                    raise StudyError(f"[analysis] outputs: {refusal}")
            if name in analysis.log:
                label = f"log({label})"
                if np.any(Y <= 0) and not refusal:
                    refusal = f"{label}: {int(np.sum(Y <= 0))} of {Y.size} values are not positive"
                    if analysis.method != "pce":
                        raise StudyError(f"[analysis] log: {refusal}")
                Y = np.log(np.where(Y > 0, Y, 1.0))
            if analysis.method == "pce":
                rows.append(_expansion(analysis, X, Y, refusal))
            else:
                rows.append(_indices(analysis, design, X, Y))
            labels.append(label)
            censored.append(float(cens.mean()))
    if analysis.method == "pce":
        return _pce_dataset(xr, rows, labels, censored, keys, design, analysis, ds)
    return _dataset(xr, rows, labels, censored, keys, design, analysis, ds)


def outside_unit_interval(row: dict) -> bool:
    """Whether a Sobol' index lies outside [0, 1] by more than its interval's half-width: an
    estimate the samples cannot support (too few of them for this output)."""
    return any(np.any((row[k] - row[f"{k}_conf"] > 1.0) | (row[k] + row[f"{k}_conf"] < 0.0))
               for k in ("S1", "ST") if k in row)


def doubtful_outputs(indices) -> list:
    """The outputs whose indices are flagged outside [0, 1] (the ``outside_unit_interval`` variable)."""
    if "outside_unit_interval" not in indices:
        return []
    flags = np.asarray(indices["outside_unit_interval"].values, dtype=bool)
    return [str(o) for o, f in zip(indices["output"].values, flags) if f]


def unit_scale(values: np.ndarray, lo: float, hi: float, log: bool) -> np.ndarray:
    """A key's values back on [0, 1] (Morris reads its trajectories' steps from them; the
    expansion is fitted and the emulator evaluated on them)."""
    return (np.log(values / lo) / np.log(hi / lo)) if log else (values - lo) / (hi - lo)


def _indices(analysis: dict, design: dict, X: np.ndarray, Y: np.ndarray) -> dict:
    prob = problem(design)
    # a Generator, not the seed: SALib seeds its bootstrap only from a truthy seed, so seed = 0
    # drew other intervals each run (a Generator from the same seed draws what the int did)
    rng = np.random.default_rng(analysis.seed)
    if np.ptp(Y) == 0:                                     # a constant output depends on nothing
        zero = np.zeros(prob["num_vars"])
        if analysis.method == "sobol":
            return {"S1": zero, "S1_conf": zero, "ST": zero, "ST_conf": zero}
        return {"mu_star": zero, "mu_star_conf": zero, "sigma": zero}
    if analysis.method == "sobol":
        from SALib.analyze import sobol
        r = sobol.analyze(prob, Y, calc_second_order=False, num_resamples=analysis.resamples,
                          conf_level=analysis.conf_level, seed=rng)
        return {k: np.asarray(r[k], dtype=float) for k in ("S1", "S1_conf", "ST", "ST_conf")}
    from SALib.analyze import morris
    r = morris.analyze(prob, X, Y, num_resamples=analysis.resamples, conf_level=analysis.conf_level,
                       num_levels=MORRIS_LEVELS, seed=rng)
    return {k: np.asarray(r[k], dtype=float) for k in ("mu_star", "mu_star_conf", "sigma")}


PCE_INDICES = ("S1", "S1_low", "S1_high", "ST", "ST_low", "ST_high")


def _expansion(analysis: dict, X: np.ndarray, Y: np.ndarray, refusal: str) -> dict:
    """One output's expansion over the unit box and its indices, or the reason it has none."""
    d = X.shape[1]
    nan = np.full(d, np.nan)
    row = {**{k: nan for k in PCE_INDICES}, "q2": np.nan, "rmse": np.nan, "degree": -1, "refused": refusal,
           "held_out": np.full(Y.size, np.nan), "value": Y, "multi_index": np.zeros((0, d), dtype=np.int64),
           "coefficient": np.zeros(0)}
    if refusal:
        return row
    if np.ptp(Y) == 0:                                     # a constant output depends on nothing
        zero = np.zeros(d)
        return {**row, **{k: zero for k in PCE_INDICES}, "q2": 1.0, "rmse": 0.0, "degree": 0, "held_out": Y,
                "multi_index": np.zeros((1, d), dtype=np.int64), "coefficient": Y[:1].astype(float)}
    bounds = np.array([[0.0, 1.0]] * d)
    sur = surrogate.fit(X, Y, bounds, max_degree=analysis.degree)
    multi, coefficient = sur.terms()
    row.update(q2=sur.q2, rmse=sur.rmse, degree=sur.degree, held_out=sur.held_out, multi_index=multi,
               coefficient=coefficient)
    try:
        r = surrogate.indices(X, Y, bounds, q2_min=analysis.q2_min, bootstrap=analysis.resamples,
                              seed=analysis.seed, conf_level=analysis.conf_level, surrogate=sur)
    except surrogate.SurrogateError as err:
        row["refused"] = str(err)
        return row
    row.update({k: r[k] for k in PCE_INDICES})
    return row



INDEX_INFO = {
    "S1": "first-order Sobol' index: the share of the output's variance due to the key alone",
    "S1_conf": "half-width of the confidence interval of S1 (bootstrap)",
    "ST": "total Sobol' index: the share of the output's variance in which the key takes part",
    "ST_conf": "half-width of the confidence interval of ST (bootstrap)",
    "mu_star": "Morris mu*: mean absolute elementary effect of the key (output units per unit of the key's "
               "sampled range, log where sampled on a log scale)",
    "mu_star_conf": "half-width of the confidence interval of mu* (bootstrap)",
    "sigma": "Morris sigma: standard deviation of the elementary effects (non-linearity and interactions)",
}


def _dataset(xr, rows, labels, censored, keys, design, analysis, ds):
    data = {}
    for name in rows[0]:
        data[name] = (("output", "key"), np.array([r[name] for r in rows]),
                      {"long_name": INDEX_INFO[name], "units": "1" if name.startswith(("S", "ST")) else ""})
    for name in ("mu_star", "mu_star_conf", "sigma"):
        if name in data:
            data[name][2].pop("units")
    if "S1" in data:
        data["outside_unit_interval"] = (("output",), np.array([outside_unit_interval(r) for r in rows], dtype=np.int8),
                                         {"long_name": "1 where an index of the output lies outside [0, 1] by more than "
                                                       "its interval's half-width (too few samples: not an estimate)",
                                          "units": "1", "flag_values": np.array([0, 1], dtype=np.int8),
                                          "flag_meanings": "within_interval outside_unit_interval"})
    data["censored"] = (("output",), np.array(censored),
                        {"long_name": "fraction of samples whose output was not finite and entered censored "
                                      "(see the analysis attribute)", "units": "1"})
    coords = _coordinates(labels, keys)
    return _finish(xr.Dataset(data, coords=coords, attrs=_attributes(design, analysis, ds)))


def _coordinates(labels, keys) -> dict:
    return {"output": ("output", np.array(labels, dtype=object), {"long_name": "output (name@eps_Y for crack onset; "
                                                                               "log(...) where its logarithm is analysed)"}),
            "key": ("key", np.array(keys, dtype=object), {"long_name": "sampled key"})}


def _attributes(design: dict, analysis: dict, ds) -> dict:
    return {"title": f"floe-impact sensitivity of study {ds.attrs.get('study_name', '')}",
            "analysis": json.dumps(analysis.stored()), "design": json.dumps(asdict(design)),
            "samples": int(ds.sizes["sample"]), "base_samples": int(design.samples),
            "conf_level": analysis.conf_level,
            "solver_time_total": float(np.nansum(np.asarray(ds["run_time"].values, dtype=float))),
            "censoring": "event times that did not happen enter as time_reached; infinite values as the "
                         "design's largest finite value",
            **provenance.attributes(f"computed {analysis.method} sensitivity indices")}


def _finish(out):
    for name in out.coords:
        out[name].encoding["_FillValue"] = None
    return out


PCE_INFO = {
    "S1": ("first-order Sobol' index from the polynomial-chaos expansion", "1"),
    "S1_low": ("lower end of S1's interval (bootstrap over runs, widened by the index's change to the "
               "neighbouring degrees: sampling and truncation)", "1"),
    "S1_high": ("upper end of S1's interval (as S1_low)", "1"),
    "ST": ("total Sobol' index from the polynomial-chaos expansion", "1"),
    "ST_low": ("lower end of ST's interval (as S1_low)", "1"),
    "ST_high": ("upper end of ST's interval (as S1_low)", "1"),
    "q2": ("cross-validated predictivity Q2 of the expansion (5-fold; 1 is exact)", "1"),
    "rmse": ("cross-validated root-mean-square error of the expansion: the error estimate of a prediction "
             "(in the output's units, or of its logarithm)", ""),
    "degree": ("total degree of the expansion, chosen by cross-validated Q2 (-1: not fitted)", "1"),
    "refused": ("1 where the output's indices were refused (Q2 below q2_min, or its values cannot be analysed; "
                "the reason in the refusals attribute)", "1"),
    "value": ("the output as analysed: censored as the censoring attribute says, its logarithm where asked", ""),
    "held_out": ("each run's prediction by the expansion fitted without its fold (cross-validation)", ""),
    "coefficient": ("coefficient of the expansion's term (orthonormal Legendre polynomials on the key's range "
                    "mapped onto [-1, 1], on a log scale where sampled so)", ""),
    "multi_index": ("degree of the term's Legendre polynomial in each key (-1: no term)", "1"),
}


def _pce_dataset(xr, rows, labels, censored, keys, design, analysis, ds):
    """The indices along (output, key), each output's Q2, degree and error estimate, its values and
    held-out predictions along sample, and its expansion's terms along term."""
    terms = max(1, max(r["coefficient"].size for r in rows))
    multi = np.full((len(rows), terms, len(keys)), -1, dtype=np.int32)
    coefficient = np.full((len(rows), terms), np.nan)
    for i, r in enumerate(rows):
        multi[i, :r["coefficient"].size] = r["multi_index"]
        coefficient[i, :r["coefficient"].size] = r["coefficient"]
    stack = {name: np.array([r[name] for r in rows]) for name in (*PCE_INDICES, "q2", "rmse", "held_out", "value")}
    dims = {**{k: ("output", "key") for k in PCE_INDICES}, "q2": ("output",), "rmse": ("output",),
            "held_out": ("output", "sample"), "value": ("output", "sample")}
    data = {name: (dims[name], stack[name]) for name in stack}
    data["degree"] = (("output",), np.array([r["degree"] for r in rows], dtype=np.int32))
    data["refused"] = (("output",), np.array([bool(r["refused"]) for r in rows], dtype=np.int8))
    data["coefficient"] = (("output", "term"), coefficient)
    data["multi_index"] = (("output", "term", "key"), multi)
    data["censored"] = (("output",), np.array(censored))
    coords = _coordinates(labels, keys)
    coords["sample"] = ("sample", np.arange(ds.sizes["sample"]), {"long_name": "sample of the design (study.nc's order)"})
    out = xr.Dataset(data, coords=coords, attrs=_attributes(design, analysis, ds))
    for name, (long_name, units) in PCE_INFO.items():
        out[name].attrs.update(long_name=long_name, units=units)
    out["censored"].attrs.update(long_name="fraction of samples whose output was not finite and entered censored "
                                           "(see the censoring attribute)", units="1")
    out["refused"].attrs.update(flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="indices_reported refused")
    out["multi_index"].encoding["_FillValue"] = None
    out.attrs["refusals"] = json.dumps({label: r["refused"] for label, r in zip(labels, rows) if r["refused"]})
    out.attrs["interval"] = (f"{100 * analysis.conf_level:g}% bootstrap percentiles over {analysis.resamples} "
                             f"refits, widened by each index's change to the neighbouring degrees")
    return _finish(out)
