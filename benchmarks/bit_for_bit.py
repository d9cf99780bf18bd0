"""Are the solver's results bit for bit those of another git revision? (make bit-for-bit)

Runs fifteen cases that cover the solver's paths at the paper's rule (the reference case, rk4, a
case that bottoms out, one that crushes the layer, located crack onsets, finite depth, a fixed
step, DOP853, a light free body to its separation, a heavy one, an off-centre body, viscoelastic
ice and layer, a wedge, a flat-bottomed power-law body, rk4 on shallow water with a located crack
onset), eight at the Gauss rule (the default), a free floe under each rule (off centre, a
wedge, under the Gauss rule), and five runs in which the ice breaks (its cascade on walls, a
cascade ended at max_parts, a dropped body across the breaks to its separation, off centre on the
whole plate, DOP853; each break's time, place, surface, parts, penetration and removed energy
compared beside every array), every setting pinned by value,
in a git worktree of the base revision and in the working tree, each in its own process, and
compares every output array (fields, amplitudes, series, diagnostics, tension and contact
records) exactly. Exit 0 when all are identical; else 1, with one line per difference. For a
refactoring that must not change results (issue 12's "bit for bit or <= 1e-12"):

    python benchmarks/bit_for_bit.py [--base HEAD]
"""
from __future__ import annotations

import argparse
import json
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_revisions import IN_TREE, ROOT, RULES, checkout  # noqa: E402

#: run inside each tree: pickles {case: {name: value}} to argv[1]; argv[2]: [paper rule, Gauss rule] as JSON
PROBE = IN_TREE + r"""
import dataclasses, json, pickle, sys
import numpy as np
from solver import Parameters, Settings, solve
KNOWN = {f.name for f in dataclasses.fields(Settings)}
def S(**kw):
    # settings pinned by value, so that a change of the defaults is not a difference; a tree whose
    # Settings lacks a key asked for (a revision before the Gauss rule) skips the case
    return Settings(**kw) if set(kw) <= KNOWN else None
# the rules as the working tree pins them (bench_revisions.RULES); the paper's without the key
# "quadrature" in a tree from before it, where that rule was the only one
PAPER, GAUSS = (dict(rule_in_tree(rule, KNOWN), error_estimate=False) for rule in json.loads(sys.argv[2]))
if "quadrature" not in KNOWN:
    PAPER.pop("quadrature")
quiet = S(**PAPER)
gauss = S(**GAUSS)
cases = {
    "reference": (Parameters(), quiet, {}),
    "rk4": (Parameters(Nmod=20), S(**dict(PAPER, integrator="rk4")), {}),
    "bottoming": (Parameters(V=3.0, hi=0.3, Nmod=30), quiet, {}),
    "crushing": (Parameters(V=10.0, hi=0.3, Nmod=30), quiet, {}),
    "crack_onsets": (Parameters(Nmod=30), quiet, {"locate_eps_Y": [1e-5, 5e-5]}),
    "finite_depth": (Parameters(Nmod=30, H=0.5), quiet, {}),
    "fixed_step": (Parameters(Nmod=20), S(**dict(PAPER, fixed_step=0.01)), {}),
    "dop853": (Parameters(Nmod=20), S(**dict(PAPER, integrator="dop853", tolerance=1e-9)), {}),
    "free_body": (Parameters(Nmod=20, body_mass=300.0), quiet, {"until_separation": True, "t_end": 0.3}),
    "heavy_body": (Parameters(Nmod=20, body_mass=3000.0), quiet, {}),
    "off_centre": (Parameters(Nmod=20, x0=1.0), quiet, {}),
    "viscoelastic": (Parameters(Nmod=20, tau=1e-3, layer_tau=1e-3), quiet, {}),
    "wedge": (Parameters(Nmod=20, deadrise=5.0), quiet, {}),
    "power_flat": (Parameters(Nmod=20, body_p=4.0, flat_width=0.2), quiet, {}),
    "shallow_rk4": (Parameters(Nmod=20, H=0.3), S(**dict(PAPER, integrator="rk4")),
                    {"locate_eps_Y": [2e-5]}),
    # the Gauss rule (the default since issue 24) on the paths it has of its own
    "gauss reference": (Parameters(), gauss, {}),
    "gauss bottoming": (Parameters(V=3.0, hi=0.3, Nmod=30), gauss, {}),
    "gauss crack_onsets": (Parameters(Nmod=30), gauss, {"locate_eps_Y": [1e-5, 5e-5]}),
    "gauss free_body": (Parameters(Nmod=20, body_mass=300.0), gauss, {"until_separation": True, "t_end": 0.3}),
    "gauss off_centre": (Parameters(Nmod=20, x0=1.0), gauss, {}),
    "gauss viscoelastic": (Parameters(Nmod=20, tau=1e-3, layer_tau=1e-3), gauss, {}),
    "gauss wedge": (Parameters(Nmod=20, deadrise=5.0), gauss, {}),
    "gauss dop853": (Parameters(Nmod=20), S(**dict(GAUSS, integrator="dop853")), {}),
}
# a free floe (a tree from before it has none; one from before issue 38 refuses the Gauss rule on it)
try:
    FLOE = dict(edges="free", L=6.0, duration=0.03, Nmod=12)
    cases["paper floe"] = (Parameters(**FLOE), quiet, {})
    cases["gauss floe off_centre wedge"] = (Parameters(**FLOE, x0=0.7, deadrise=10.0), gauss, {})
except Exception:
    pass
# ice that breaks (a tree from before it has none): on walls through its cascade, to the part cap,
# a dropped body across the breaks to its separation, off centre on the whole plate, and DOP853
try:
    BREAK = dict(fracture="break")
    cases["gauss breaking walls"] = (Parameters(Nmod=20, **BREAK), gauss, {"t_end": 2e-3})
    cases["gauss breaking to the part cap"] = (Parameters(Nmod=16, max_parts=4, **BREAK), gauss, {"t_end": 3e-3})
    cases["gauss breaking dropped body"] = (Parameters(Nmod=20, body_mass=100.0, **BREAK), gauss,
                                            {"until_separation": True, "t_end": 3e-3})
    cases["gauss breaking off centre"] = (Parameters(Nmod=16, x0=0.5, **BREAK), gauss, {"t_end": 2e-3})
    cases["gauss breaking dop853"] = (Parameters(Nmod=12, **BREAK), S(**dict(GAUSS, integrator="dop853")),
                                      {"t_end": 1e-3})
except Exception:
    pass
#: what each break reports, in every tree that breaks
BREAK_KEYS = ("time", "x", "surface", "parts", "broken_through", "penetration", "removed_energy")
out = {}
for name, (p, s, kw) in cases.items():
    if s is None:
        continue
    try:
        r = solve(p, s, fields=("strain", "layer_pressure", "compression"), **kw)
    except Exception as err:
        out[name] = {"status": f"refused: {err}"}
        continue
    d = {"status": r.status, "steps": r.steps, "amplitudes": r.amplitudes, "velocities": r.velocities,
         "contact_intervals": r.contact_intervals, "force": r.force, "plate_energy": r.plate_energy,
         "layer_energy": r.layer_energy, "work": r.work, "contact_record": r.contact_record,
         **{name + "_record": rec for name, rec in r.tension_record.items()},
         **{"field " + k: v for k, v in r.fields.items()},
         **{"diagnostic " + k: v for k, v in r.diagnostics.items()}}
    if "located_crack_onset" in r.extra:
        d["located"] = np.concatenate([np.concatenate(v) for v in r.extra["located_crack_onset"].values()])
    typed = getattr(r, "breaking", None)               # (Result.breaking from 2026-12-06; extra's before)
    if typed is not None or "breaks" in r.extra:
        events = [dataclasses.asdict(e) for e in typed.breaks] if typed is not None else r.extra["breaks"]
        d["body_position"] = r.body_position
        d["removed_energy"] = typed.removed_energy if typed is not None else r.extra["removed_energy"]
        for k, event in enumerate(events):
            for key in BREAK_KEYS:
                value = event.get(key, float("nan"))
                d[f"break {k} {key}"] = value if not isinstance(value, str) else ("upper", "lower").index(value)
        d.update({"breaking " + k: (getattr(typed, k) if typed is not None else r.extra["breaking"][k])
                  for k in ("first_break_time", "break_count", "parts", "breakthrough_time", "breakthrough_penetration")})
    out[name] = d
pickle.dump(out, open(sys.argv[1], "wb"))
"""


def run(tree: Path, path: Path, gauss: str) -> dict:
    rules = json.dumps([RULES["paper"], RULES[gauss]])
    proc = subprocess.run([sys.executable, "-c", PROBE, str(path), rules], cwd=tree,
                          env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin"}, capture_output=True,
                          text=True, timeout=1800)
    if proc.returncode != 0:
        sys.exit(f"the tree at {tree} failed: {proc.stderr.strip().splitlines()[-1:]}")
    with open(path, "rb") as f:
        return pickle.load(f)


def differences(base: dict, new: dict) -> list:
    """One line per value of base that new does not reproduce exactly (values new adds, such as
    diagnostics that did not exist in base, are not differences)."""
    lines = []
    for case, values in base.items():
        for name, old in values.items():
            if name not in new[case]:
                lines.append(f"{case}: {name} is gone")
                continue
            now = new[case][name]
            if isinstance(old, np.ndarray):
                same = isinstance(now, np.ndarray) and old.shape == now.shape and np.array_equal(old, now,
                                                                                                 equal_nan=True)
            else:
                same = old == now or (old != old and now != now)
            if not same:
                lines.append(f"{case}: {name} differs" + _by_how_much(old, now))
    return lines


def _by_how_much(old, now) -> str:
    """', by r of its largest' (the largest difference over the largest magnitude of old) where
    both are numbers of one shape, else ''."""
    try:
        a, b = np.asarray(old, dtype=float), np.asarray(now, dtype=float)
        if a.shape != b.shape or not a.size:
            return ""
        finite = np.isfinite(a) & np.isfinite(b)
        scale = np.max(np.abs(a[finite])) if np.any(finite) else 0.0
        if not np.array_equal(np.isfinite(a), np.isfinite(b)) or scale == 0.0:
            return ""
        return f", by {np.max(np.abs(a[finite] - b[finite])) / scale:.1e} of its largest"
    except (TypeError, ValueError):
        return ""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="HEAD", help="the revision to compare against (default HEAD)")
    ap.add_argument("--gauss-rule", choices=("gauss", "embedded"), default="gauss",
                    help="the Gauss cases' settings (bench_revisions.RULES): today's default, or the embedded "
                         "control at 1e-9 (the default before 2026-11-28)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tree = checkout(args.base, Path(tmp))
        try:
            base = run(tree, Path(tmp) / "base.pkl", args.gauss_rule)
        finally:
            if tree != ROOT:
                subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, capture_output=True)
        new = run(ROOT, Path(tmp) / "new.pkl", args.gauss_rule)
    lines = differences(base, new)
    for line in lines:
        print(line)
    count = sum(len(v) for v in base.values())
    print(f"{len(base)} cases, {count} values: " + ("bit for bit" if not lines else f"{len(lines)} differ")
          + f" (working tree against {args.base})")
    return 1 if lines else 0


if __name__ == "__main__":
    sys.exit(main())
