"""What a run asked only for crack onset costs, beside the full run (make bench-answered).

Five cases at N = 60, the default numerics without the error estimate, each solved three ways
in one process, alternately over ROUNDS rounds (medians of the integration's wall time): the full
run (every observer, the whole impact stage), the same stage with only the observers the four
crack onsets read (outputs = the four onsets, end "stage"), and the runs that end when the crack
onsets up to eps_Y = 8e-5 are final (end "answered"): the plate-wide onsets of both surfaces, and
all four (the impact zone's too; the zone's upper tension may reach eps_Y much later than the
plate's). Every crack onset of the answered runs at 50 eps_Y up to 8e-5 is checked bit for bit
against the full run's. The first row is the reference case. Writes results/bench/answered.md.

    python benchmarks/answered.py [--rounds 5]
"""
from __future__ import annotations

import argparse
import statistics
from pathlib import Path

import numpy as np

from solver import Parameters, Settings, solve
from solver.outputs import ONSET_RECORD, onset_names

ROOT = Path(__file__).resolve().parents[1]
#: the issue's cases: (V, hi)
CASES = ((5.0, 0.5), (1.0, 1.0), (2.0, 0.5), (5.0, 0.3), (10.0, 1.0))
EPS_Y = 8e-5
ONSETS = tuple(ONSET_RECORD)
PLATE = (*onset_names("upper"), *onset_names("lower"))


def _runs(p, s):
    return {"full": lambda: solve(p, s, fields=()),
            "tension only": lambda: solve(p, s, fields=(), outputs=ONSETS),
            "plate": lambda: solve(p, s, fields=(), outputs=PLATE, eps_Y=[EPS_Y], end="answered"),
            "all four": lambda: solve(p, s, fields=(), outputs=ONSETS, eps_Y=[EPS_Y], end="answered")}


def _identical(full, answered, regions) -> bool:
    levels = np.geomspace(EPS_Y / 100, EPS_Y, 50)
    for surface in ("upper", "lower"):
        for region in regions:
            a, b = full.crack_onset(levels, surface, region), answered.crack_onset(levels, surface, region)
            if not (np.array_equal(a[0], b[0], equal_nan=True) and np.array_equal(a[1], b[1], equal_nan=True)):
                return False
    return True


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args(argv)
    s = Settings(error_estimate=False)
    rows = ["| V [m/s] | hi [m] | onset upper / lower / zone upper [ms] | full [s] | onsets' observers only [s] | "
            "answered, plate [s] | ratio | answered, all four [s] | ratio | steps full / plate / four | identical |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for V, hi in CASES:
        p = Parameters(Nmod=60, V=V, hi=hi)
        runs = _runs(p, s)
        last = {name: run() for name, run in runs.items()}          # warm-up (compile or cache load)
        times = {name: [] for name in runs}
        for _ in range(args.rounds):
            for name, run in runs.items():
                last[name] = run()
                times[name].append(last[name].wall_time)
        med = {name: statistics.median(t) for name, t in times.items()}
        full, plate, four = last["full"], last["plate"], last["all four"]
        onsets = [1e3 * float(np.atleast_1d(full.crack_onset(EPS_Y, surface, region)[0])[0])
                  for surface, region in (("upper", "plate"), ("lower", "plate"), ("upper", "impact_zone"))]
        same = _identical(full, plate, ("plate",)) and _identical(full, four, ("plate", "impact_zone"))
        rows.append(f"| {V:g} | {hi:g} | {onsets[0]:.2f} / {onsets[1]:.2f} / {onsets[2]:.2f} | {med['full']:.4f} | "
                    f"{med['tension only']:.4f} | {med['plate']:.4f} | {med['full'] / med['plate']:.0f}x | "
                    f"{med['all four']:.4f} | {med['full'] / med['all four']:.0f}x | "
                    f"{full.steps} / {plate.steps} / {four.steps} | {'yes' if same else 'NO'} |")
        print(rows[-1], flush=True)
    text = ("# A crack-onset run against the full run\n\nN = 60, default numerics, no error estimate; eps_Y = "
            f"{EPS_Y:g}; medians of {args.rounds} rounds (`python benchmarks/answered.py`).\n\n" + "\n".join(rows) + "\n")
    out = ROOT / "results" / "bench" / "answered.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(f"wrote {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
