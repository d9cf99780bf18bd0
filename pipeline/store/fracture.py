"""Crack onset against the yield strain, from stored records: no solver run.

Every batch file and ``study.nc`` (unless written with ``[output] records = false``) holds each
case's running-maximum tension records, on both surfaces, over the whole plate and within the
impact zone (``tension_record_*`` along the ``tension_record`` dimension, docs/model.md "Crack
onset"). :func:`crack_onset` turns them into the first time and place at which the tension
reaches each yield strain, plate-wide (``crack_onset_*``) and in the impact zone
(``impact_zone_crack_onset_*``)::

    import xarray as xr
    from pipeline.store.fracture import crack_onset
    onset = crack_onset("results/speed_sweep/study.nc", eps_Y=[5e-5, 8e-5, 2e-4])
    onset["crack_onset_time"].sel(V=5.0, hi=0.5)          # [s] along eps_Y

The combine uses the same function for the study's ``[output] eps_Y``, so a new list of
yield strains never needs new runs; studies that differ only in eps_Y share their results.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from solver import EPS_Y_INFO, ParameterError, crack_onset as _from_record, default_eps_Y
from solver.fracture import above_yield_strain_message, up_to_yield_strain, yield_strains

from .casefile import ragged_offsets, tension_records
from solver.outputs import TENSION_RECORDS, onset_names

from ..common.tables import RECORD_NAMES, TENSION_RECORD_INFO

def _crack_info() -> dict:
    """variable -> (long_name, units), each along eps_Y: from each record of
    solver.outputs.TENSION_RECORDS, the first time and place its tension reaches eps_Y."""
    info = {}
    for record in RECORD_NAMES:
        surface, region, _ = TENSION_RECORDS[record]
        where = "anywhere on the plate" if region == "plate" else "within the impact zone"
        tension = "upper-surface tension (+strain)" if surface == "upper" else "lower-surface tension (-strain)"
        time_name, x_name = onset_names(record)
        info[time_name] = (f"first time the {tension} reaches eps_Y {where} (NaN: not within the run)", "s")
        info[x_name] = (f"position of the {surface}-surface crack onset {where} (centred impact: x >= 0, mirrored "
                        f"at -x; off centre: signed)", "m")
    return info


CRACK_INFO = _crack_info()


def onset_from_records(records: dict, eps_Y) -> dict:
    """name -> array over eps_Y, for one case's records (record name -> (n, 5) rows)."""
    out = {}
    for record in RECORD_NAMES:
        time_name, x_name = onset_names(record)
        out[time_name], out[x_name] = _from_record(records[record], np.asarray(eps_Y, dtype=float))
    return out


def eps_Y_coord(eps_Y) -> tuple:
    long_name, units = EPS_Y_INFO
    return ("eps_Y", np.asarray(eps_Y, dtype=float), {"long_name": long_name, "units": units})


def breaking_yield_strain(ds) -> float | None:
    """The smallest yield_strain of the cases of a study.nc or batch file whose ice breaks (None:
    none does, or the file predates breaking)."""
    if "fracture" not in ds or "yield_strain" not in ds:
        return None
    fracture, strain = xr.broadcast(ds["fracture"], ds["yield_strain"])
    breaks = np.asarray(fracture.values).astype(str) == "break"
    return float(np.min(np.asarray(strain.values, dtype=float)[breaks])) if breaks.any() else None


def crack_onset(source, eps_Y=None) -> xr.Dataset:
    """Crack onset time and place on both surfaces, plate-wide and within the impact zone, for a
    list of yield strains.

    Parameters
    ----------
    source : a batch file ``batches/<sha256>.nc`` or a ``study.nc`` (path, or an open dataset).
    eps_Y : yield strains [1] (default: 10 a decade from 1e-5 to 1e-1 and the paper's 8e-5).

    Returns
    -------
    xarray.Dataset with ``crack_onset_time`` [s], ``crack_onset_x`` [m], their ``_lower``
    versions and their ``impact_zone_`` versions (the impact zone's), over the source's case dimensions (a study's grid keys, or ``case``) and eps_Y.
    """
    try:
        eps = None if eps_Y is None else np.sort(yield_strains(eps_Y).reshape(-1))
    except ParameterError:
        eps = None
    if eps_Y is not None and (eps is None or not np.all(eps < 1)):
        raise ValueError(f"eps_Y must be yield strains in (0, 1), got {eps_Y!r}")
    if isinstance(source, (str, Path)):
        with xr.open_dataset(source) as ds:
            return crack_onset(ds.load(), eps)
    ds = source
    top = breaking_yield_strain(ds)
    if eps is None:                     # the default; where ice breaks, up to its yield strain
        eps = default_eps_Y() if top is None else up_to_yield_strain(default_eps_Y(), top)
    level = ds.attrs.get("answered_eps_Y")
    if level is not None and eps.max() > float(level):
        raise ValueError(f"eps_Y = {eps.max():g} is above {float(level):g}, the largest yield strain this study's "
                         f"runs answered ([output] end = \"answered\"): its records end there; run the study with a "
                         f"larger eps_Y, or without end = \"answered\"")
    if top is not None and eps.max() > top:
        raise ValueError(above_yield_strain_message(float(eps.max()), top))
    missing = [name for name in ("tension_record_count", *TENSION_RECORD_INFO) if name not in ds]
    if missing:
        raise ValueError(f"no tension record in this dataset ({missing[0]} is missing): a study.nc "
                         f"written with [output] records = false keeps them in its batch files only")
    counts = ds["tension_record_count"]
    lead = counts.dims[:-1]                               # the case dimensions
    shape = tuple(ds.sizes[d] for d in lead)
    starts = np.asarray(ds["tension_record_start"].values) if "tension_record_start" in ds \
        else ragged_offsets(counts.values)
    arrays = {name: np.full(shape + (eps.size,), np.nan) for name in CRACK_INFO}
    for index in np.ndindex(*shape):
        records = tension_records(ds, index, starts)
        for name, values in onset_from_records(records, eps).items():
            arrays[name][index] = values
    coords = {d: ds[d] for d in lead if d in ds.coords}
    coords["eps_Y"] = eps_Y_coord(eps)
    asked = json.loads(ds.attrs["outputs"]) if "outputs" in ds.attrs else None
    data = {name: (lead + ("eps_Y",), arrays[name], {"long_name": CRACK_INFO[name][0], "units": CRACK_INFO[name][1],
                                                     **({} if asked is None or name in asked else
                                                        {"computed": "no: not among the study's [output] outputs"})})
            for name in CRACK_INFO}
    return xr.Dataset(data, coords=coords)
