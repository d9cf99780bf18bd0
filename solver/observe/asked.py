r"""What a run is asked for: which observers run, and when its answers are final (docs/model.md,
"What a run computes").

The observers are switched by the bits of ``Control.observers``: the tension records (TENSION:
the plate-wide maxima, their records, so crack onset), the
impact zone (ZONE: its records, so its crack onsets, and its reach; its maxima also take the
plate-wide peak of a step where that lies in the zone, so they need TENSION as well), the
contact intervals (CONTACTS: their record and largest count; the count at each step's end,
which steers the step, is taken without them), the force and compression located inside the
steps (LAYER_MAXIMA), a floe's tension maxima located on the dense output at the run's end
(FLOE_MAXIMA: the plate's and the zone's, so it needs both; crack onset, from the records, does
not need it). An observer never changes a step: a run with fewer observers takes the same steps
and the outputs it was asked for are bit for bit those of the run with all of them
(tests/test_asked.py). The energy identity, the step's verdict, bottoming and a free body's
stops and separation always run.

A run asked only for crack onsets ends when they are final (``Control.answer``: for each tension
record, upper, lower, the impact zone's upper and lower, the largest eps_Y asked; -inf: that
record is not asked; +inf: it is, to the end of the run). A record's crossings of every eps_Y up
to its level are final once the running maximum has passed the level by ANSWER_MARGIN and the
record as stored cannot change around them: the greedy thinning (solver.fracture.thin_record)
decides a node from at most THIN_SPAN + 1 rows after it, so the run goes on until the record
holds THIN_SPAN + 1 rows beyond the crossing, or its chain has closed (a step that did not raise
the maximum). Then every crossing of the stored record is the full run's, bit for bit.
"""
import math

from ..compile.jit import kernel
from ..fracture import THIN_SPAN
from ..keys import ParameterError
from ..outputs import OBSERVED_BY, ONSET_RECORD, OUTPUT_NAMES, RECORDS

#: the observers' bits in Control.observers
TENSION, ZONE, CONTACTS, LAYER_MAXIMA, FLOE_MAXIMA = 1, 2, 4, 8, 16
#: every observer (a run that asks for everything: solve's default)
ALL = TENSION | ZONE | CONTACTS | LAYER_MAXIMA | FLOE_MAXIMA
#: the running maximum must exceed a level by this fraction before its crossing counts as passed:
#: the stored (thinned) record may lie below the running maximum by its thinning tolerance
#: (THIN_TIME t |rate| ~ 4e-7 of the value)
ANSWER_MARGIN = 1e-5


@kernel(inline="llvm")
def asks(observers, bit):
    """Whether the observer of bit runs."""
    return (observers & bit) != 0


@kernel
def _record_final(level, run_max, joinable, n, crossed, r):
    """Whether record r's crossings up to level are final (see the module docstring); crossed[r]
    receives the record's row count when the running maximum first passes the level."""
    if level == -math.inf:
        return True
    if not run_max >= level * (1.0 + ANSWER_MARGIN):
        return False
    if math.isnan(crossed[r]):
        crossed[r] = n
        return False
    return n >= crossed[r] + THIN_SPAN + 1 or joinable == 0.0


@kernel
def answered(levels, tension, zone, records, crossed):
    """Whether every crack onset asked is final: levels (4,) per record (upper, lower, the zone's
    upper, lower; Control.answer), the tension observer's and the zone's marks (each surface's
    running maximum, then 1 where its last step was stored), records the loop's Records (their
    row counts read), crossed (4,) scratch, NaN at the start of the run."""
    counts = (records.n_upper, records.n_lower, records.n_zone_upper, records.n_zone_lower)
    done = True
    for r in range(4):
        m = tension if r < 2 else zone
        s = r % 2
        final = _record_final(levels[r], m[s], m[2 + s], counts[r], crossed, r)
        done = done and final
    return done


#: an observer's name (solver.outputs.OBSERVED_BY) -> its bit
BITS = {"tension": TENSION, "zone": ZONE, "zone_maxima": ZONE | TENSION, "contacts": CONTACTS,
        "layer_maxima": LAYER_MAXIMA, "floe_maxima": FLOE_MAXIMA | ZONE | TENSION}
#: how a run may end: at t_end ("stage", whatever it was asked), or when its answers are final
ENDS = ("stage", "answered")


def plan(outputs, eps_Y, end, floe=True):
    """What a run computes for the outputs asked (names of solver.outputs.OUTPUT_NAMES; None:
    every one): (the observers' bits, Control.answer, the set of outputs asked or None); floe:
    whether the run is a floe's (on walls no output needs the observer of a floe's maxima, nor,
    through it, the zone's and the tension observer). With end
    "answered" and only crack onsets asked (eps_Y: the yield strains they are asked at), the run
    ends when they are final; anything else asked runs it to t_end. Raises ParameterError, one
    line, on a name that is no output or an "answered" end with no crack onset to answer."""
    if end not in ENDS:
        raise ParameterError(f"end must be one of {', '.join(repr(e) for e in ENDS)}, got {end!r}")
    if outputs is None:
        if end == "answered":
            raise ParameterError('end = "answered" needs the outputs asked (crack onsets), not every output')
        return ALL, (math.inf,) * 4, None
    asked = set(outputs)
    unknown = sorted(asked - set(OUTPUT_NAMES))
    if unknown:
        raise ParameterError(f"unknown output {unknown[0]!r}; known: {', '.join(OUTPUT_NAMES)}")
    bits = 0
    for observer, names in OBSERVED_BY.items():
        if asked & set(names) and (floe or observer != "floe_maxima"):
            bits |= BITS[observer]
    onsets = asked & set(ONSET_RECORD)
    if end == "stage" or asked - onsets:
        if end == "answered" and not onsets:
            raise ParameterError('end = "answered" with no crack onset asked: nothing ends the run early')
        return bits, (math.inf,) * 4, asked
    levels = [float(v) for v in (eps_Y if eps_Y is not None else ())]
    if not levels:
        raise ParameterError('end = "answered" needs eps_Y, the yield strains the crack onsets are asked at')
    if not all(math.isfinite(v) and v > 0 for v in levels):
        raise ParameterError(f"eps_Y must be yield strains, finite numbers > 0 [1]; got {list(eps_Y)!r}")
    top = max(levels)
    answer = tuple(top if any(ONSET_RECORD[n] == record for n in onsets) else -math.inf for record in RECORDS)
    return bits, answer, asked
