"""One solved case as a labelled ``xarray.Dataset``, with the names, units and long names a
``study.nc`` gives the same quantities (``pipeline.case_dataset``: the solver imports nothing of
the runner, so the conversion of its Result lives here)."""
from __future__ import annotations

import json

import numpy as np
import xarray as xr

from solver import DIAGNOSTIC_INFO, FIELD_INFO, PARAMETER_INFO, ParameterError, default_eps_Y
from solver.fracture import above_yield_strain, up_to_yield_strain, yield_strains
from solver.outputs import breaking_values
from solver.outputs import BREAKING_INFO, SERIES, TENSION_RECORDS
from solver.parameters import CHOICES

from ..common import provenance
from .fracture import CRACK_INFO, eps_Y_coord, onset_from_records
from ..common.tables import (BODY_SERIES_INFO, BREAKING_DIMS, CONTACT_RECORD_INFO, RECORD_INFO, SERIES_INFO,
                             TENSION_RECORD_INFO, TEXT_INFO, asked_attributes, diagnostic_values, run_records)

#: the series a Result carries beside the study's (solver.outputs.SERIES): name -> (Result
#: attribute, long_name, units); work and dissipated_energy are the run's totals, as in study.nc
ENERGY_INFO = {row.name: (row.attribute, row.long_name, row.units) for row in SERIES if row.stored == "case"}


def _attrs(long_name: str, units: str | None = None) -> dict:
    return {"long_name": long_name, **({"units": units} if units is not None else {})}


def case_dataset(result, eps_Y=None) -> xr.Dataset:
    """One case as a Dataset labelled as study.nc (the public door: :func:`pipeline.case_dataset`,
    whose docstring tells the arguments)."""
    T = result.times.size
    data = {}
    answered = result.answered_eps_Y if result.end_reason == "answered" else None
    for name, values in result.fields.items():
        data[name] = (("t", "x"), np.asarray(values), _attrs(*FIELD_INFO[name]))
    series = {name: (name, *SERIES_INFO[name]) for name in ("contact_intervals", "force")}
    series.update(ENERGY_INFO)
    if result.body_position is not None and np.isfinite(result.parameters.body_mass):
        series.update({name: (name, *info) for name, info in BODY_SERIES_INFO.items()})
    for name, (attribute, long_name, units) in series.items():
        values = np.asarray(getattr(result, attribute), dtype=float).reshape(T)
        data[name] = (("t",), values, _attrs(long_name, units))
    data["valid"] = (("t",), np.asarray(result.valid, dtype=np.int8),
                     {**_attrs("1: the run reached this time", "1"), "flag_values": np.array([0, 1], np.int8),
                      "flag_meanings": "not_reached reached"})
    for name, value in diagnostic_values(result).items():
        data[name] = ((), value, {**_attrs(*DIAGNOSTIC_INFO[name][:2]), **asked_attributes(name, result.outputs, answered)})
    p = result.parameters
    if p.fracture == "break":                # each break along break_number (solver.outputs.BREAKING_OUTPUTS)
        values = breaking_values(result, result.breaking.break_count)
        for name, (long_name, units, along) in BREAKING_INFO.items():
            data[name] = (BREAKING_DIMS[along], values[name], _attrs(long_name, units))
        data["removed_energy_over_time"] = (("t",), np.asarray(result.breaking.removed_energy, dtype=float),
                                            _attrs("energy the breaks removed up to each time: plate_energy + "
                                                   "layer_energy + dissipated_energy_over_time + this = "
                                                   "work_over_time", "J m-1"))
    records = run_records(result, p.time_scale, p.stage_duration)
    for name, (long_name, units) in RECORD_INFO.items():
        data[name] = ((), float(records[name]), _attrs(long_name, units))
    data["status"] = ((), result.status, _attrs(TEXT_INFO["status"]))
    data["message"] = ((), result.message, _attrs(TEXT_INFO["message"]))
    for key, value in p.as_dict().items():
        long_name, units = PARAMETER_INFO[key]
        data[key] = ((), value, _attrs(long_name, None if key in CHOICES else units))
    eps = yield_strains(default_eps_Y() if eps_Y is None else eps_Y).reshape(-1)
    if eps_Y is None:                        # a run that ended at its answer: the eps_Y it answers
        eps = eps[eps <= result.answered_eps_Y] if np.any(eps <= result.answered_eps_Y) else \
            np.array([result.answered_eps_Y])
    elif np.any(eps > result.answered_eps_Y):
        raise ParameterError(f"eps_Y = {eps.max():g} is above {result.answered_eps_Y:g}, the largest the run "
                             f"answered (end = 'answered')")
    if eps_Y is None and p.fracture == "break":    # ice that breaks: defined up to its yield strain
        eps = up_to_yield_strain(eps, p.yield_strain)
    above_yield_strain(p, eps)
    for name, values in onset_from_records(result.tension_record, eps).items():
        data[name] = (("eps_Y",), values, {**_attrs(*CRACK_INFO[name]), **asked_attributes(name, result.outputs, answered)})
    for record, (_, _, follows) in TENSION_RECORDS.items():     # the event records, one table each
        rows = np.asarray(result.tension_record[record], dtype=float).reshape(-1, 5)
        dim = f"tension_node_{record}"
        for col, (name, (long_name, units)) in enumerate(TENSION_RECORD_INFO.items()):
            data[f"{name}_{record}"] = ((dim,), rows[:, col], _attrs(f"{long_name} (the record of the {follows})",
                                                                      units))
    contacts = np.asarray(result.contact_record if result.contact_record is not None else np.empty((0, 2)),
                          dtype=float).reshape(-1, 2)
    for col, (name, (long_name, units)) in enumerate(CONTACT_RECORD_INFO.items()):
        data[name] = (("contact_change",), contacts[:, col], _attrs(long_name, units))
    coords = {"t": ("t", np.asarray(result.times, dtype=float), _attrs("time since first touch", "s")),
              "x": ("x", np.asarray(result.x, dtype=float), _attrs("position along the plate", "m")),
              "eps_Y": eps_Y_coord(eps)}
    attrs = {"title": "floe-impact case", "solver_settings": json.dumps(result.settings.as_dict()),
             "parameters": json.dumps(p.as_dict()), **provenance.attributes("solved one case")}
    ds = xr.Dataset(data, coords=coords, attrs=attrs)
    for name in ds.coords:                       # CF 2.5.1: no _FillValue on a coordinate variable
        ds[name].encoding["_FillValue"] = None
    return ds
