"""Sensitivity indices of a design's outputs, computed with SALib after the combine (the
[analysis] table and its rules, the censoring of outputs that are not finite among them, are
pipeline.analysis's): ``analyze(study.nc, design, analysis)`` -> a Dataset along (output, key)."""
from __future__ import annotations

import json

import numpy as np

from .analysis import CRACK_OUTPUTS, EVENT_TIMES, MORRIS_LEVELS
from .errors import StudyError


def problem(design: dict) -> dict:
    """SALib's problem on the unit cube (the keys' own scales are mapped by pipeline.design)."""
    keys = list(design["keys"])
    return {"num_vars": len(keys), "names": keys, "bounds": [[0.0, 1.0]] * len(keys)}


def output_values(ds, name: str, eps_Y: float | None = None) -> tuple:
    """(values along sample, censored mask, label) of one output, non-finite values censored as
    the module says."""
    if name in CRACK_OUTPUTS:
        from .fracture import crack_onset
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
    from .tables import COMPLETE
    status = np.asarray(ds["status"].values).reshape(-1)
    broken = ~np.isin(status, [*COMPLETE, "layer_bottomed_out"])
    if broken.any():
        raise StudyError(f"{int(broken.sum())} of {status.size} samples failed or are missing "
                         f"({', '.join(sorted(set(status[broken])))}): no sensitivity indices (run again, or "
                         f"with --rerun-failed)")
    keys = list(design["keys"])
    X = np.column_stack([_unit(np.asarray(ds[k].values, dtype=float), *design["keys"][k]) for k in keys])
    rows, labels, censored = [], [], []
    for name in analysis["outputs"]:
        for eps in (analysis["eps_Y"] if name in CRACK_OUTPUTS else [None]):
            Y, cens, label = output_values(ds, name, eps)
            rows.append(_indices(analysis, design, X, Y))
            labels.append(label)
            censored.append(float(cens.mean()))
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


def _unit(values: np.ndarray, lo: float, hi: float, log: bool) -> np.ndarray:
    """A key's values back on [0, 1] (Morris reads its trajectories' steps from them)."""
    return (np.log(values / lo) / np.log(hi / lo)) if log else (values - lo) / (hi - lo)


def _indices(analysis: dict, design: dict, X: np.ndarray, Y: np.ndarray) -> dict:
    prob = problem(design)
    # a Generator, not the seed: SALib seeds its bootstrap only from a truthy seed, so seed = 0
    # drew other intervals each run (a Generator from the same seed draws what the int did)
    rng = np.random.default_rng(analysis["seed"])
    if np.ptp(Y) == 0:                                     # a constant output depends on nothing
        zero = np.zeros(prob["num_vars"])
        if analysis["method"] == "sobol":
            return {"S1": zero, "S1_conf": zero, "ST": zero, "ST_conf": zero}
        return {"mu_star": zero, "mu_star_conf": zero, "sigma": zero}
    if analysis["method"] == "sobol":
        from SALib.analyze import sobol
        r = sobol.analyze(prob, Y, calc_second_order=False, num_resamples=analysis["resamples"],
                          conf_level=analysis["conf_level"], seed=rng)
        return {k: np.asarray(r[k], dtype=float) for k in ("S1", "S1_conf", "ST", "ST_conf")}
    from SALib.analyze import morris
    r = morris.analyze(prob, X, Y, num_resamples=analysis["resamples"], conf_level=analysis["conf_level"],
                       num_levels=MORRIS_LEVELS, seed=rng)
    return {k: np.asarray(r[k], dtype=float) for k in ("mu_star", "mu_star_conf", "sigma")}



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
    from . import provenance
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
    coords = {"output": ("output", np.array(labels, dtype=object), {"long_name": "output (name@eps_Y for crack onset)"}),
              "key": ("key", np.array(keys, dtype=object), {"long_name": "sampled key"})}
    attrs = {"title": f"floe-impact sensitivity of study {ds.attrs.get('study_name', '')}",
             "analysis": json.dumps(analysis), "design": json.dumps(design),
             "samples": int(ds.sizes["sample"]), "base_samples": int(design["samples"]),
             "conf_level": analysis["conf_level"],
             "solver_time_total": float(np.nansum(np.asarray(ds["run_time"].values, dtype=float))),
             "censoring": "event times that did not happen enter as time_reached; infinite values as the "
                          "design's largest finite value",
             **provenance.attributes(f"computed {analysis['method']} sensitivity indices")}
    out = xr.Dataset(data, coords=coords, attrs=attrs)
    for name in out.coords:
        out[name].encoding["_FillValue"] = None
    return out
