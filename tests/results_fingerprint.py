"""The fingerprint of the solver's results on one machine, which guards solver.revision.

A fixed set of small cases covering the solver's paths under both quadratures is run and every
output array hashed. On one machine, with one set of libraries, the same code gives the same bits
(adaptive runs included), so a fingerprint that moved means that results moved: the rule's
revision in solver/revision.py must be bumped (tests/test_results_revision.py). Fingerprints are
kept per machine (CPU, its features, numba's target, the libraries' versions) in
tests/data/results_fingerprint.json; another machine's are not compared.

    python tests/results_fingerprint.py --record     # make fingerprint: record this machine's
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
STORE = ROOT / "tests" / "data" / "results_fingerprint.json"


def cases() -> dict:
    """name -> (Parameters, Settings, solve's keywords): both rules on every path, small and fast."""
    from solver import Parameters, Settings
    cases = {}
    for rule in ("paper", "gauss"):
        def S(**kw):
            return Settings(quadrature=rule, error_estimate=False, **kw)
        few = dict(Nmod=12)
        cases.update({
            f"{rule} reference": (Parameters(**few), S(), {}),
            f"{rule} fixed step": (Parameters(**few), S(fixed_step=0.02), {}),
            f"{rule} rk4": (Parameters(**few), S(integrator="rk4"), {"t_end": 0.02}),
            f"{rule} dop853": (Parameters(**few), S(integrator="dop853", tolerance=1e-8), {"t_end": 0.03}),
            f"{rule} bottoming": (Parameters(V=3.0, hi=0.3, **few), S(), {}),
            f"{rule} crack onsets": (Parameters(**few), S(), {"locate_eps_Y": [1e-5, 5e-5]}),
            f"{rule} finite depth": (Parameters(H=0.5, **few), S(), {}),
            f"{rule} free body": (Parameters(body_mass=300.0, **few), S(), {"until_separation": True, "t_end": 0.3}),
            f"{rule} off centre": (Parameters(x0=1.0, **few), S(), {}),
            f"{rule} viscoelastic": (Parameters(tau=1e-3, layer_tau=1e-3, **few), S(), {}),
            f"{rule} wedge": (Parameters(deadrise=5.0, **few), S(), {}),
        })
    for rule in ("paper", "gauss"):
        cases[f"{rule} free floe"] = (Parameters(edges="free", L=6.0, duration=0.03, Nmod=8),
                                      Settings(quadrature=rule, error_estimate=False), {})
    cases["gauss free floe off centre"] = (Parameters(edges="free", L=6.0, duration=0.01, Nmod=8, x0=0.7,
                                                      deadrise=10.0), Settings(error_estimate=False), {})
    # the embedded control, the default before the smoothness control (its runs are unchanged)
    embedded = dict(error_control="embedded", error_estimate=False)
    for rule in ("paper", "gauss"):
        cases[f"{rule} reference, embedded"] = (Parameters(Nmod=12), Settings(quadrature=rule, **embedded), {})
    cases["gauss crack onsets, embedded"] = (Parameters(Nmod=12), Settings(**embedded), {"locate_eps_Y": [1e-5, 5e-5]})
    cases["gauss free floe, embedded"] = (Parameters(edges="free", L=6.0, duration=0.03, Nmod=8), Settings(**embedded),
                                          {})
    # ice that breaks: the paper's body through a cascade, a dropped body to its separation
    cases["gauss breaking"] = (Parameters(Nmod=12, fracture="break", duration=2e-3), Settings(error_estimate=False), {})
    cases["gauss breaking, dropped body"] = (Parameters(Nmod=12, fracture="break", body_mass=100.0, duration=4e-3),
                                             Settings(error_estimate=False), {"until_separation": True})
    return cases


def guards(p, s) -> str:
    """The revisions that guard a case's results, "+"-joined (a bump of any of them gives it new
    ids): its rule, or "floe" for a free floe, "dop853" for the DOP853 reference; and
    "smoothness" for an adaptive etd34 run under the smoothness control, "breaking" for a run in
    which the ice breaks."""
    guard = "floe" if p.edges == "free" else "dop853" if s.integrator == "dop853" else s.quadrature
    if s.integrator == "etd34" and s.fixed_step == 0.0 and s.error_control == "smoothness":
        guard += "+smoothness"
    if p.fracture == "break":
        guard += "+breaking"
    return guard


def _digest(result) -> str:
    """sha256 of every output array and count of a Result."""
    h = hashlib.sha256(f"{result.status} {result.steps} {result.rejected_steps}".encode())
    arrays = [result.times, result.amplitudes, result.velocities, result.contact_intervals, result.force,
              result.plate_energy, result.layer_energy, result.work, result.dissipated_energy,
              result.tension_record["upper"], result.tension_record["lower"], result.contact_record,
              result.body_position, result.body_speed, *result.fields.values()]
    arrays += [np.array([v for k, v in sorted(result.diagnostics.items())], dtype=float)]
    for located in result.extra.get("located_crack_onset", {}).values():
        arrays += list(located)
    for event in result.breaking.breaks if result.breaking is not None else ():   # a run that breaks: each break
        arrays.append([event.time, event.x, event.parts, event.removed_energy])
    for a in arrays:
        h.update(np.ascontiguousarray(np.asarray(a, dtype=float)).tobytes())
    return h.hexdigest()[:24]


def fingerprint() -> dict:
    """case -> (the revisions that guard it, :func:`guards`; the digest of its results)."""
    from solver import solve
    out = {}
    for name, (p, s, kw) in cases().items():
        r = solve(p, s, fields=("strain", "layer_pressure"), **kw)
        out[name] = [guards(p, s), _digest(r)]
    return out


def machine() -> dict:
    """What decides the round-off of a run: the CPU and the target numba compiles for, numpy's SIMD
    dispatch, the libraries' versions."""
    import llvmlite
    import numba
    import scipy
    from solver.compile.kernel_cache import target_cpu
    name, features = target_cpu()
    facts = {"machine": platform.machine(), "numba_target": name,
             "numba_features": hashlib.sha256(features.encode()).hexdigest()[:12],
             "numba": numba.__version__, "llvmlite": llvmlite.__version__, "numpy": np.__version__,
             "scipy": scipy.__version__, "python": platform.python_version()}
    for var in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE"):
        facts[var] = os.environ.get(var, "")
    return facts


def machine_key(facts: dict) -> str:
    return hashlib.sha256(json.dumps(facts, sort_keys=True).encode()).hexdigest()[:16]


def load() -> dict:
    return json.loads(STORE.read_text()) if STORE.exists() else {}


def record() -> str:
    """Record this machine's fingerprint at today's revisions; fingerprints of other machines at
    other revisions are dropped (they no longer describe the code)."""
    from solver.revision import RESULTS_REVISION
    store = {k: v for k, v in load().items() if v["revisions"] == RESULTS_REVISION}
    facts = machine()
    key = machine_key(facts)
    store[key] = {"machine": facts, "revisions": dict(RESULTS_REVISION), "fingerprint": fingerprint()}
    STORE.write_text(json.dumps(store, indent=1, sort_keys=True) + "\n")
    return key


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record", action="store_true", help="record this machine's fingerprint")
    args = ap.parse_args(argv)
    if args.record:
        key = record()
        print(f"recorded the fingerprint of machine {key} in {STORE.relative_to(ROOT)}")
    else:
        print(json.dumps(fingerprint(), indent=1))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
