"""Threshold search: for every point of a study (a grid, a design, or [base] alone), the value
of one key at which an event first happens, by bisection on runs of the same runner::

    [grid]
    hi = [0.3, 0.5, 1.0]
    [search]
    key = "V"                  # the key searched (a continuous parameter, not in [base] or [grid])
    bracket = [0.5, 40.0]      # the event must differ between its ends
    log = true                 # bisect in log(V); tolerance is then relative
    event = "bottoming"        # "bottoming" | "breakthrough" | "crack_onset" | "crack_onset_lower"
                               # | "impact_zone_crack_onset" | "impact_zone_crack_onset_lower" (crack
                               # onset: at each eps_Y; breakthrough: ice that breaks, fracture = "break")
    eps_Y = [8e-5, 1e-3]       # for crack onset: one search per yield strain
    tolerance = 0.01           # the final bracket: hi/lo - 1 (log) or hi - lo (linear)
    scan = 9                   # the first round: 9 values over the bracket, its ends included

The event is a yes/no outcome of a run over the impact stage: the layer bottomed out
(``bottoming_time`` finite), the body broke through ice that breaks (``breakthrough_time``
finite), or the tension reached eps_Y (``crack_onset_time`` finite). A yes/no
outcome carries no distance to the threshold, so the search brackets and bisects (Brent's method
needs a value that changes sign). The event need not be monotone in the key: whether the layer
bottoms out before the stage ends depends on the plate's oscillations near the end, and it can
come and go with V. So the first round scans the bracket, and the search bisects the first scan
interval in which the event differs from the bracket's lower end: it finds the first crossing
at the scan's resolution (a crossing that comes and goes between two scan values is not seen;
``scan_changes`` > 1 says the event changed more than once along the scan). A search takes
``scan`` + ceil(log2(scan interval / tolerance)) runs; runs are shared between the yield strains
of one point.

Every evaluation is a case of the runner, in ``<out>/evaluations`` (its own ledger, batch files
and study.nc): checksummed, resumable, parallel across the points of a round. A search that is
killed and started again replays its rounds from the ledger and computes only what is missing.
The results (``search.nc``): the critical value, its bracket, the direction of the crossing and
the number of runs, per point (and eps_Y).
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from solver import PARAMETER_INFO, SETTING_INFO, Parameters, Settings
from solver.outputs import CRACK_ONSET_TIMES
from solver.parameters import NOT_MONOTONE, ParameterError, outside_physical_range
from solver.settings import check_combination

from ..common.errors import StudyError, check_table
from .design import SAMPLED
from .identity import SAMPLE

#: event -> the variable whose finite value says it happened (crack onset: at each eps_Y)
EVENTS = {"bottoming": "bottoming_time", "breakthrough": "breakthrough_time",
          **{name.replace("_time", ""): name for name in CRACK_ONSET_TIMES}}
#: the events a run's own outcome gives, with no yield strain of the search's (breakthrough's is
#: the cases' yield_strain)
UNSTRAINED = ("bottoming", "breakthrough")
SEARCH_KEYS = {"key", "bracket", "log", "event", "eps_Y", "tolerance", "scan"}
#: points of the first round's scan over the bracket (its ends included), by default
SCAN = 9
#: rounds at most (2^60 halvings: any tolerance a double can hold)
MAX_ROUNDS = 62
#: the finest tolerance, relative to the bracket's values: they are rounded to 12 significant
#: digits (the same case id on every CPU), so a narrower bracket could not be halved
RESOLUTION = 1e-10
#: at most this many (point, scanned value) runs are checked one by one before a run; beyond,
#: the bracket's two ends at every point
MAX_CHECKS = 20_000


@dataclass(frozen=True)
class Search:
    """[search], checked: the parameter ``key`` searched within ``bracket`` (low, high), on a log
    scale if ``log``, for the value at which ``event`` (of EVENTS) first happens, at each yield
    strain of ``eps_Y`` (crack-onset events; () for bottoming), to a bracket ``tolerance``
    (relative on a log scale), after a first round of ``scan`` values over the bracket. Stored
    as JSON in search.nc's ``search`` attribute (dataclasses.asdict, these fields in this order)."""

    key: str
    bracket: tuple
    log: bool
    event: str
    eps_Y: tuple
    tolerance: float
    scan: int


def check_search(table, taken: set) -> Search:
    """Validate a [search] table; ``taken``: the keys in [base], [grid] or [design.keys]."""
    check_table("[search]", table, SEARCH_KEYS)
    key = table.get("key")
    if key not in SAMPLED:
        raise StudyError(f"[search] key must be a continuous parameter ({', '.join(SAMPLED)}), got {key!r}")
    if key in taken:
        raise StudyError(f"[search] key {key} is also in [base], [grid] or [design.keys]: it is what is searched")
    bracket = table.get("bracket")
    if (not isinstance(bracket, list) or len(bracket) != 2 or
            not all(isinstance(b, (int, float)) and not isinstance(b, bool) and math.isfinite(b) for b in bracket)):
        raise StudyError(f"[search] bracket must be [low, high], two finite numbers, got {bracket!r}")
    lo, hi = float(bracket[0]), float(bracket[1])
    if not lo < hi:
        raise StudyError(f"[search] bracket = [{lo:g}, {hi:g}]: low must be below high")
    log = table.get("log", False)
    if not isinstance(log, bool):
        raise StudyError("[search] log must be true or false")
    if log and lo <= 0:
        raise StudyError(f"[search] a log scale needs a bracket above 0, got [{lo:g}, {hi:g}]")
    event = table.get("event")
    if event not in EVENTS:
        raise StudyError(f"[search] event must be one of {', '.join(EVENTS)}, got {event!r}")
    if event in UNSTRAINED and "eps_Y" in table:
        raise StudyError(f"[search] eps_Y = {table['eps_Y']!r} is for a crack-onset event: a {event} search has "
                         f"no yield strain (leave eps_Y out{'; the ice breaks at yield_strain' if event == 'breakthrough' else ''})")
    eps = table.get("eps_Y", [8e-5]) if event not in UNSTRAINED else []
    if event not in UNSTRAINED and (not isinstance(eps, list) or not eps or not all(
            isinstance(e, (int, float)) and not isinstance(e, bool) and 0 < e < 1 for e in eps)):
        raise StudyError(f"[search] eps_Y must be a list of yield strains in (0, 1), got {eps!r}")
    tol = table.get("tolerance", 0.01)
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not tol > 0:
        raise StudyError(f"[search] tolerance must be a number > 0, got {tol!r}")
    width = hi / lo - 1 if log else hi - lo
    finest = RESOLUTION * (1.0 if log else max(abs(lo), abs(hi)))
    if tol < finest:
        raise StudyError(f"[search] tolerance {tol:g} is below what the search's values resolve (they are "
                         f"rounded to 12 significant digits): at least {finest:g}"
                         f"{' (relative, on a log scale)' if log else ' on this bracket'}")
    if tol >= width:
        raise StudyError(f"[search] tolerance {tol:g} is not below the bracket's width {width:g}")
    scan = table.get("scan", SCAN)
    if isinstance(scan, bool) or not isinstance(scan, int) or not 2 <= scan <= 1000:
        raise StudyError(f"[search] scan must be an integer from 2 to 1000 (points over the bracket), got {scan!r}")
    return Search(key=key, bracket=(lo, hi), log=log, event=event, eps_Y=tuple(float(e) for e in eps),
                  tolerance=float(tol), scan=scan)


def check_bracket(search: dict, values: dict, points: list, extreme: bool) -> None:
    """Every run the search's first round makes (each point at each scanned value, the bracket's
    ends included) gives valid parameters and settings, within the physical ranges unless
    ``extreme``: a bracket that breaks the model is refused before anything is written, naming
    the bracket. ``values``: [base] and [solver]; ``points``: each point's own values (a grid's
    combinations, a design's samples, or [{}] for [base] alone)."""
    key, scanned = search.key, scan_values(search)
    if len(points) * len(scanned) > MAX_CHECKS:
        scanned = [scanned[0], scanned[-1]]
    for point in points:
        at = (" at " + ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in point.items())
              if point else "")
        merged = {**values, **point}
        try:
            settings = Settings(**{k: (True if k == "error_estimate" and v == SAMPLE else v)
                                   for k, v in merged.items() if k in SETTING_INFO})
        except ParameterError as err:
            raise StudyError(f"[search] bracket{at}: {err}") from None
        for value in scanned:
            params = {**{k: v for k, v in merged.items() if k in PARAMETER_INFO}, key: value}
            try:
                check_combination(Parameters(**params), settings)
            except ParameterError as err:
                raise StudyError(f"[search] bracket: {key} = {value:g}{at}: {err}") from None
            reason = None if extreme else outside_physical_range(params)
            if reason:
                raise StudyError(f"[search] bracket: {key} = {value:g}{at}: {reason} (accept_extreme_values = "
                                 f"true runs it anyway)")


def search_points(grid: dict, case_list: list) -> list:
    """The points a search runs at, as the values that place each: a grid's combinations (at
    most MAX_CHECKS; beyond, each key's lowest and highest value, every value of the keys
    the checks are not monotone in), a design's samples, or [{}] for [base] alone."""

    if not grid:
        return [dict(c) for c in case_list] or [{}]
    choices = list(grid.values())
    if math.prod(len(c) for c in choices) > MAX_CHECKS:
        choices = [c if k in NOT_MONOTONE or not all(isinstance(v, (int, float)) for v in c)
                   else sorted({min(c), max(c)}) for k, c in grid.items()]
    return [dict(zip(grid, combo)) for combo in itertools.product(*choices)]


def scan_values(search: dict) -> list:
    """The first round's points: ``scan`` values over the bracket, its ends included, evenly
    spaced (in the logarithm where log)."""
    lo, hi = search.bracket
    u = np.linspace(0.0, 1.0, search.scan)
    values = lo * (hi / lo) ** u if search.log else lo + u * (hi - lo)
    return [lo, *(_round(v) for v in values[1:-1]), hi]


def _round(value: float) -> float:
    return float(f"{value:.12g}")            # the same double, and case id, on every CPU


def _middle(lo: float, hi: float, log: bool) -> float:
    return _round(math.sqrt(lo * hi) if log else 0.5 * (lo + hi))


def _narrow(lo: float, hi: float, search: dict) -> bool:
    return (hi / lo - 1 if search.log else hi - lo) <= search.tolerance


class Target:
    """One search: a point of the study (and a yield strain); its bracket and what is known."""

    def __init__(self, point: int, eps, search: dict):
        self.point, self.eps = point, eps
        self.lo, self.hi = search.bracket
        self.at_lo = self.at_hi = None           # the event at the bracket's ends (True/False)
        self.values = []                         # the key values this search needed
        self.changes = 0                         # changes of the event along the scan (1: one crossing)
        self.status, self.message = "searching", ""

    def wanted(self, search: dict) -> list:
        """The key values to run next: the scan over the bracket first, then the middle of the
        bracket it found; [] when done."""
        if self.status != "searching":
            return []
        if self.at_lo is None:
            return scan_values(search)
        return [_middle(self.lo, self.hi, search.log)]

    def learn(self, outcomes: dict, search: dict, why: dict | None = None) -> None:
        """The outcomes of this round's runs (value -> True/False, or None: the run gave no answer,
        why[value] saying how it ended)."""
        for value, happened in outcomes.items():
            if value not in self.values:
                self.values.append(value)
            if happened is None:
                reason = (why or {}).get(value)
                self.status, self.message = "failed", f"the run at {search.key} = {value:g} " + (
                    f"gave no answer: {reason}" if reason else "failed")
                return
        if self.at_lo is None:                   # the scan: the first interval where the event changes
            values = sorted(outcomes)
            seen = [outcomes[v] for v in values]
            self.changes = sum(a != b for a, b in zip(seen, seen[1:]))
            if not self.changes:
                self.status = "no_crossing"
                self.message = (f"the event {'happens' if seen[0] else 'does not happen'} at all {len(seen)} "
                                f"scanned values")
                return
            k = next(i for i in range(1, len(seen)) if seen[i] != seen[0])
            self.lo, self.hi, self.at_lo, self.at_hi = values[k - 1], values[k], seen[0], seen[k]
            if self.changes > 1:
                self.message = (f"the event changes {self.changes} times along the scan: the first crossing "
                                f"was searched")
        else:
            (value, happened), = outcomes.items()
            if happened == self.at_lo:
                self.lo = value
            else:
                self.hi = value
        if _narrow(self.lo, self.hi, search):
            self.status = "found"


def runs_per_search(search: dict) -> int:
    """Runs one search takes: the scan, then one per halving of a scan interval down to the
    tolerance."""
    lo, hi = search.bracket
    width = (math.log(hi / lo) / math.log1p(search.tolerance) if search.log
             else (hi - lo) / search.tolerance) / (search.scan - 1)
    return search.scan + max(0, math.ceil(math.log2(width)))
