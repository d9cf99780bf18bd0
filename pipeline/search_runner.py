"""A threshold search's runs (pipeline.study.search states the search and checks it): the rounds on
one dask session, each round one run of the evaluations' [[cases]] study in out/evaluations
through the runner (its ledger, batch files and resume), then search.nc and search.png."""
from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math
import os
import sys
import time
import tomllib
from dataclasses import asdict
from pathlib import Path

import numpy as np

from solver import EPS_Y_INFO, PARAMETER_INFO

from .common import provenance
from .common.errors import EXIT_OK, StudyError
from .common.tables import COMPLETE
from .compute.session import session_for
from .store.casefile import temporary_path
from .store.ledger import Ledger
from .store.sealed import open_sealed, seal
from .study.definition import load_study_text
from .study.search import EVENTS, MAX_ROUNDS, UNSTRAINED, Target, runs_per_search
from .study.study_files import study_text


def _event(ds, i: int, search: dict, eps) -> bool | None:
    """Did the event happen in case i of the evaluations' study.nc (None: the case failed)?"""
    status = str(ds["status"].values[i])
    name = EVENTS[search.event]
    if search.event == "breakthrough" and status in ("parts_limit", "edge_break"):
        # the run ended at a break it could not make: an answer only if it had broken through
        return True if np.isfinite(ds[name].values[i]) else None
    if status not in (*COMPLETE, "layer_bottomed_out"):
        return None
    if search.event in UNSTRAINED:
        return bool(np.isfinite(ds[name].values[i]))
    k = int(np.argmin(np.abs(np.log(ds["eps_Y"].values / eps))))
    return bool(np.isfinite(ds[name].values[i, k]))


def _ended(ds, i: int, search: dict) -> str:
    """How case i of the evaluations' study.nc ended without an answer, in a few words: its
    status and message (a run that ended at a break it could not make before breaking through:
    what stopped it)."""
    status, message = str(ds["status"].values[i]), str(ds["message"].values[i])
    before = " before it broke through" if search.event == "breakthrough" and status in ("parts_limit",
                                                                                          "edge_break") else ""
    return f"it ended {status}{before}" + (f" ({message})" if message else "")


def _evaluation_text(study, cases: list) -> str:
    """The evaluations' study: the search study's [base], [solver] and [output] (its eps_Y with
    the search's), and one [[cases]] entry a run."""
    data = tomllib.loads(study.text)
    output = dict(data.get("output", {}))
    eps = study.search.eps_Y
    if eps:
        given = output.get("eps_Y")
        output["eps_Y"] = sorted(set(eps) | set(given if isinstance(given, list) else study.output.eps_Y))
    table = {"description": f"the runs of the search of study {study.name}", "base": data.get("base", {}),
             "solver": data.get("solver", {}), "output": output, "cases": cases}
    if data.get("accept_extreme_values"):
        table = {"accept_extreme_values": True, **table}
    return study_text(table)


def _point_values(study, i: int) -> dict:
    """The keys that place point i (its grid or design values) for a [[cases]] entry."""
    case = study.case(i)
    keys = study.design.keys if study.design else (study.grid if study.grid else {})
    return {k: case.value(k) for k in keys}


def run_search(study, out_dir: Path, options, run_study) -> int:
    """The rounds of every point's bisection on one dask session, each round one run of the
    evaluations' study with ``run_study`` (pipeline.run's, handed in: the runner calls this
    module, not the other way round); then search.nc and search.png."""

    search = study.search
    targets = [Target(i, eps, search) for i in range(study.n_cases) for eps in (search.eps_Y or [None])]
    points = [_point_values(study, i) for i in range(study.n_cases)]
    runs = Runs(study, points, out_dir / "evaluations", run_study,
                dataclasses.replace(options, no_plots=True, dry_run=False, all=False))
    with session_for(options, options.workers, out_dir) as session:     # one cluster for every round
        for round_ in range(MAX_ROUNDS):
            wanted = {id(t): t.wanted(search) for t in targets}
            if not any(wanted.values()):
                break
            ds = runs.run([(t.point, v) for t in targets for v in wanted[id(t)]], session, round_,
                          sum(t.status == "searching" for t in targets))
            for t in targets:
                if wanted[id(t)]:
                    outcomes = {v: _event(ds, runs.row(t.point, v), search, t.eps) for v in wanted[id(t)]}
                    t.learn(outcomes, search, {v: _ended(ds, runs.row(t.point, v), search) for v, happened
                                               in outcomes.items() if happened is None})
            _refuse_no_crossing(search, targets, points)
    none = [t for t in targets if t.status == "no_crossing"]
    if none:
        print(f"note: {len(none)} of {len(targets)} searches found no crossing in the bracket (search_status "
              f"no_crossing in search.nc): the event happens, or does not, at every scanned value", file=sys.stderr)
    write_search(study, out_dir, targets, points)
    return EXIT_OK


class Runs:
    """Every run the searches asked for, in order of asking: one [[cases]] study in
    out_dir/evaluations that grows by a round at a time (its finished cases are never run again)."""

    def __init__(self, study, points: list, out_dir: Path, run_study, options):
        self.study, self.points, self.out_dir, self.options = study, points, out_dir, options
        self.run_study = run_study
        self.order, self.index = [], {}

    def row(self, point: int, value: float) -> int:
        return self.index[(point, value)]

    def run(self, wanted: list, session, round_: int, searching: int):
        """Run what is wanted and not run yet; the evaluations' study.nc, loaded."""

        import xarray as xr

        for item in wanted:
            if item not in self.index:
                self.index[item] = len(self.order)
                self.order.append(item)
        key = self.study.search.key
        cases = [{**self.points[p], key: v} for p, v in self.order]
        try:
            sub = load_study_text(_evaluation_text(self.study, cases), f"{self.study.name}_evaluations")
        except StudyError as err:                   # a value inside the checked scan (non-monotone checks)
            raise StudyError(f"[search] bracket: a value the bisection reached in round {round_ + 1} is "
                             f"refused: {err} (the runs made are kept)") from None
        started, log = time.monotonic(), io.StringIO()
        with contextlib.redirect_stderr(log):       # the round's own lines; errors are raised
            self.run_study(sub, self.out_dir, self.options, session)
        new = next((line.split(", ")[1] for line in log.getvalue().splitlines() if " to run, " in line), "")
        print(f"search round {round_ + 1}: {searching} searches, {len(self.order)} runs in all ({new}), "
              f"{time.monotonic() - started:.1f} s", file=sys.stderr)
        with xr.open_dataset(self.out_dir / "study.nc") as ds:
            return ds.load()


def _refuse_no_crossing(search: dict, targets: list, points: list) -> None:
    """A bracket in which no search found a crossing is bad input: one line (the runs made are
    kept). Where only some points have none, those are results (search_status no_crossing in
    search.nc, and a note), and the others go on."""
    bad = [t for t in targets if t.status == "no_crossing"]
    if not bad or any(t.status != "no_crossing" for t in targets):
        return
    t = bad[0]
    label = ", ".join(f"{k}={v:g}" for k, v in points[t.point].items()) or "the base case"
    raise StudyError(f"[search] bracket {search.key} = [{search.bracket[0]:g}, {search.bracket[1]:g}] "
                     f"holds no crossing of {search.event}{f' at eps_Y = {t.eps:g}' if t.eps else ''} at "
                     f"{label} ({len(bad)} of {len(targets)} searches): {t.message}; widen it (the runs made "
                     f"are kept)")


def write_search(study, out_dir: Path, targets: list, points: list) -> Path:
    """search.nc: per point (and eps_Y) the critical value, its bracket, the direction of the
    crossing, the runs it took and the search's status."""
    import xarray as xr

    search = study.search
    key, (long_name, units) = search.key, PARAMETER_INFO[search.key]
    eps_list = search.eps_Y
    shape = tuple(study.shape) + ((len(eps_list),) if eps_list else ())
    dims = tuple(study.dims) + (("eps_Y",) if eps_list else ())

    def grid(fn, dtype=float):
        return np.array([fn(t) for t in targets], dtype=dtype).reshape(shape)

    found = lambda t: t.status == "found"             # noqa: E731
    centre = lambda t: (math.sqrt(t.lo * t.hi) if search.log else 0.5 * (t.lo + t.hi)) if found(t) else np.nan  # noqa: E731
    data = {
        f"critical_{key}": (dims, grid(centre), {"long_name": f"{long_name} at which the event "
                                                 f"({search.event}) first happens: the middle of the final bracket",
                                                 "units": units}),
        f"critical_{key}_lower": (dims, grid(lambda t: t.lo if found(t) else np.nan),
                                  {"long_name": f"lower end of the final bracket of {key}", "units": units}),
        f"critical_{key}_upper": (dims, grid(lambda t: t.hi if found(t) else np.nan),
                                  {"long_name": f"upper end of the final bracket of {key}", "units": units}),
        "event_above": (dims, grid(lambda t: 1 if t.at_hi else 0, np.int8),
                        {"long_name": f"1: the event happens above the critical {key}; 0: below it", "units": "1"}),
        "scan_changes": (dims, grid(lambda t: t.changes, np.int32),
                         {"long_name": "changes of the event along the first round's scan (more than 1: the "
                                       "event is not monotone in the key; the first crossing was searched)",
                          "units": "1"}),
        "solves": (dims, grid(lambda t: len(t.values), np.int32),
                   {"long_name": "runs this search needed (a run shared with another yield strain counted in each)",
                    "units": "1"}),
        "search_status": (dims, grid(lambda t: t.status, object), {"long_name": "found | failed | no_crossing"}),
        "search_message": (dims, grid(lambda t: t.message, object), {"long_name": "why a search did not find"}),
    }
    coords = {}
    if study.grid:
        from .store.combine import parameter_coord
        for (k, values), d in zip(study.grid.items(), study.dims):
            values_, attrs = parameter_coord(k, values)
            coords[d] = (d, values_, attrs)
    else:
        d = study.dims[0]
        coords[d] = (d, np.arange(study.n_cases, dtype=np.int32), {"long_name": f"{d} number"})
        for k in (points[0] if points else {}):
            values_ = np.array([p[k] for p in points], dtype=float)
            coords[k] = (d, values_, {"long_name": PARAMETER_INFO[k][0], "units": PARAMETER_INFO[k][1]})
    if eps_list:
        coords["eps_Y"] = ("eps_Y", np.array(eps_list), {"long_name": EPS_Y_INFO[0], "units": EPS_Y_INFO[1]})
    runs = len({(t.point, v) for t in targets for v in t.values})
    attrs = {"title": f"floe-impact threshold search of study {study.name}", "search": json.dumps(asdict(search)),
             "study_file": study.text, "runs": runs,
             **provenance.attributes(f"searched {key} for {search.event}")}
    ds = xr.Dataset(data, coords=coords, attrs=attrs)
    for name in ds.coords:
        ds[name].encoding["_FillValue"] = None
    target = Path(out_dir) / "search.nc"
    tmp = temporary_path(target)
    try:
        ds.to_netcdf(tmp)
        os.replace(tmp, target)
        seal(target)
    finally:
        tmp.unlink(missing_ok=True)
    print(f"wrote {target} ({runs} runs for {len(targets)} searches)", file=sys.stderr)
    from .figures.design import search_figure
    search_figure(ds, study.dims, search, Path(out_dir) / "search.png")
    return target


def search_summary(study, out_dir: Path) -> str:
    """What status says of a search: its plan, the runs done, and what search.nc found."""
    search = study.search
    n = study.n_cases * max(1, len(search.eps_Y))
    lines = [f"{study.name}: a search of {search.key} in [{search.bracket[0]:g}, {search.bracket[1]:g}] "
             f"for {search.event} at {n} point(s): at most {runs_per_search(search)} runs each"]
    evaluations = Path(out_dir) / "evaluations"
    done = len(Ledger.load(evaluations).index()) if (evaluations / "ledger.jsonl").exists() else 0
    lines.append(f"runs done: {done} (in {evaluations})")
    path = Path(out_dir) / "search.nc"
    if path.exists():
        with open_sealed(path) as ds:
            statuses = np.asarray(ds["search_status"].values).ravel()
            counts = {s: int((statuses == s).sum()) for s in sorted(set(statuses))}
        lines.append("search.nc: " + ", ".join(f"{v} {k}" for k, v in counts.items()))
    else:
        lines.append("search.nc: not written yet (run the study to finish the search)")
    return "\n".join(lines)
