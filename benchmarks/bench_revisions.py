"""Side-by-side solver timing of git revisions on the reference case (make bench-revisions).

Each revision is checked out into a temporary git worktree ("." means the working tree as it
is, uncommitted changes included). Rounds run every revision once in turn, each in its own
process that warms up (numba compile or cache load) and then times several solves; the
machine's drift and noise then fall on all revisions alike. The settings are pinned by value (--rule paper,
the default: the paper's rule at 1000 subintervals and tolerance 1e-8, as every revision before
issue 24 ran by default; --rule gauss: today's default). Reported: the median over rounds
of each round's median wall time of the integration (Result.wall_time, no error-estimate
companion), the error (relative L2 of the strain at the paper's snapshots against a tolerance
1e-13 run of the same revision) and the step counts. Writes results/bench/revisions.md.

    python benchmarks/bench_revisions.py [--revisions 46d95fa .] [--rounds 5] [--nmod 60] [--rule paper|gauss]

A revision may ask for fewer outputs (solve's ``outputs``, from issue 55 on): ``.@plate`` times
the working tree asked only for the plate-wide strain maxima (ASKED), beside the revisions as
they run by default.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from solver import Settings
from solver.settings import PAPER_NUMERICS

ROOT = Path(__file__).resolve().parents[1]

#: code that each revision's tree runs before its probe: a rule pinned to the embedded control
#: loses the key in a tree from before error_control was a setting, where every run was under it
IN_TREE = r"""
def rule_in_tree(rule, known):
    if rule.get("error_control") == "embedded" and "error_control" not in known:
        rule = {k: v for k, v in rule.items() if k != "error_control"}
    return rule
"""

#: run inside each revision's tree; prints one JSON line
PROBE = IN_TREE + r"""
import dataclasses, json, statistics, sys, time
import numpy as np
from solver import Parameters, Settings, solve
p = Parameters(Nmod=int(sys.argv[1]), **json.loads(sys.argv[5]))
rule = json.loads(sys.argv[3])
known = {f.name for f in dataclasses.fields(Settings)}
rule = rule_in_tree(rule, known)
if not set(rule) <= known:
    rule = {k: v for k, v in rule.items() if k in ("subintervals", "tolerance")} if rule.get("quadrature") == "paper" else None
if rule is None:
    print(json.dumps(None))
    sys.exit(0)
times = np.round(np.arange(0.0, 4.6 + 1e-9, 0.2), 10) * p.time_scale
kw = dict(times=times, fields=("strain",))
if sys.argv[4] != "null":
    kw["outputs"] = json.loads(sys.argv[4])
ref = solve(p, Settings(**dict(rule, tolerance=1e-13), error_estimate=False), **kw).fields["strain"]
walls, totals = [], []
for _ in range(int(sys.argv[2])):
    started = time.perf_counter()
    r = solve(p, Settings(**rule, error_estimate=False), **kw)
    totals.append(time.perf_counter() - started)
    walls.append(r.wall_time)
err = float(np.linalg.norm(r.fields["strain"] - ref) / np.linalg.norm(ref))
print(json.dumps({"wall": statistics.median(walls), "total": statistics.median(totals), "error": err,
                  "steps": r.steps, "rejected": r.rejected_steps}))
"""


#: what a revision "<rev>@<name>" is asked for
ASKED = {"plate": ["max_strain", "max_strain_x", "max_strain_time", "max_strain_lower", "max_strain_lower_x",
                   "max_strain_lower_time", "max_abs_strain", "max_abs_strain_x", "max_abs_strain_time"]}


def checkout(rev: str, tmp: Path) -> Path:
    rev = rev.split("@")[0]
    if rev == ".":
        return ROOT
    path = tmp / rev.replace("/", "_")
    if path.exists():
        return path
    subprocess.run(["git", "worktree", "add", "--detach", "-f", str(path), rev], cwd=ROOT, check=True,
                   capture_output=True)
    return path


#: the settings timed, pinned by value so that a change of the defaults does not change the
#: comparison: the paper's rule as every revision before issue 24 ran it by default; the Gauss
#: rule, today's default (a revision without its error control is left out); or the Gauss rule
#: under the embedded control at 1e-9, the default from issue 24 to 2026-11-28
_GAUSS = ("quadrature", "subintervals", "quadrature_density", "tolerance", "error_control")
RULES = {"paper": PAPER_NUMERICS,
         "gauss": {k: getattr(Settings(), k) for k in _GAUSS},
         "embedded": {k: getattr(Settings(error_control="embedded"), k) for k in _GAUSS}}


#: the parameters of the case timed besides Nmod (--case): the reference case, or the same ice
#: breaking at the paper's yield strain through its cascade (a run in stages: its tables and the
#: state carried across each break are in the total time, not in the integration's)
CASES = {"reference": {}, "breaking": {"fracture": "break"}}


def probe(tree: Path, nmod: int, solves: int, rule: str, asked=None, case: str = "reference") -> dict:
    proc = subprocess.run([sys.executable, "-c", PROBE, str(nmod), str(solves), json.dumps(RULES[rule]),
                           json.dumps(asked), json.dumps(CASES[case])], cwd=tree,
                          env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin"}, capture_output=True,
                          text=True, timeout=1200)
    if proc.returncode != 0:
        sys.exit(f"revision at {tree} failed: {proc.stderr.strip().splitlines()[-1:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--revisions", nargs="+", default=["46d95fa", "."])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--solves", type=int, default=7, help="timed solves per process")
    ap.add_argument("--nmod", type=int, default=60)
    ap.add_argument("--rule", choices=sorted(RULES), default="paper",
                    help="the quadrature and its settings, pinned (paper: 1000 subintervals, tolerance 1e-8; "
                         "gauss: 250 subintervals, density 4, tolerance 1e-9)")
    ap.add_argument("--case", choices=sorted(CASES), default="reference",
                    help="the reference case, or its ice breaking (fracture = 'break')")
    ap.add_argument("--out", default="results/bench/revisions.md")
    args = ap.parse_args(argv)
    runs = {rev: [] for rev in args.revisions}
    with tempfile.TemporaryDirectory() as tmp:
        trees = {rev: checkout(rev, Path(tmp)) for rev in args.revisions}
        try:
            for i in range(args.rounds):
                for rev, tree in trees.items():
                    asked = ASKED[rev.split("@")[1]] if "@" in rev else None
                    result = probe(tree, args.nmod, args.solves, args.rule, asked, args.case)
                    if result is not None:
                        runs[rev].append(result)
                print(f"  round {i + 1}/{args.rounds} done", flush=True)
        finally:
            for rev, tree in trees.items():
                if tree != ROOT and tree.exists():
                    subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                                   capture_output=True)
    described = {rev: (subprocess.run(["git", "log", "-1", "--format=%h %cs %s", rev.split("@")[0]], cwd=ROOT,
                                      capture_output=True, text=True).stdout.strip()[:80]
                       if rev.split("@")[0] != "." else "working tree")
                 + (f", asked only {rev.split('@')[1]}" if "@" in rev else "") for rev in args.revisions}
    skipped = [rev for rev in args.revisions if not runs[rev]]
    revisions = [rev for rev in args.revisions if runs[rev]]
    base = statistics.median(r["wall"] for r in runs[revisions[0]])
    base_total = statistics.median(r.get("total", r["wall"]) for r in runs[revisions[0]])
    lines = ["# Solver side by side, git revisions", "",
             f"Generated by `make bench-revisions` (bench_revisions.py). {args.case.capitalize()} case, Nmod = {args.nmod}, "
             f"{args.rule}'s rule ({RULES[args.rule]}), no error-estimate companion; {args.rounds} rounds of one "
             f"process per revision in turn, {args.solves} timed solves per process; medians."
             + (f" Left out (no such settings): {', '.join(skipped)}." if skipped else ""), "",
             "| revision | integration [s] | speed-up vs the first | solve [s] | speed-up | strain error | "
             "accepted steps | rejected |", "|---|---|---|---|---|---|---|---|"]
    for rev in revisions:
        wall = statistics.median(r["wall"] for r in runs[rev])
        total = statistics.median(r.get("total", r["wall"]) for r in runs[rev])
        last = runs[rev][-1]
        lines.append(f"| `{described[rev]}` | {wall:.4f} | {base / wall:.2f}x | {total:.4f} | {base_total / total:.2f}x | "
                     f"{last['error']:.2g} | {last['steps']} | {last['rejected']} |")
    text = "\n".join(lines) + "\n"
    out = ROOT / args.out
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
