"""max_force and max_compression, located inside the steps, against DOP853 (docs/model.md, "Maxima
of the force and the compression"): the relative difference of each value and of its time, etd34
at each tolerance against DOP853 at 1e-12, N = 20.

    python benchmarks/layer_maxima.py [TOLERANCE ...]      (default 1e-7 1e-9 1e-11; about 2 min)
"""
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from solver import Parameters, Settings, solve  # noqa: E402

CASES = {"free body M=200": (Parameters(Nmod=20, body_mass=200.0), {"until_separation": True}),
         "paper V=5": (Parameters(Nmod=20, V=5.0), {}),
         "V=3 hi=0.5": (Parameters(Nmod=20, V=3.0, hi=0.5), {}),
         "floe L=6 (paper rule)": (Parameters(Nmod=20, edges="free", L=6.0, duration=0.03), {})}
NAMES = ("max_force", "max_compression", "max_force_time", "max_compression_time")


def main(tolerances):
    print("| case | tolerance | steps | wall [s] | " + " | ".join(NAMES) + " |")
    print("|---" * (4 + len(NAMES)) + "|")
    for name, (p, kw) in CASES.items():
        s = Settings(error_estimate=False, quadrature="paper" if p.edges == "free" else "gauss")
        ref = solve(p, replace(s, integrator="dop853", tolerance=1e-12), fields=(), **kw)
        for tol in tolerances:
            started = time.perf_counter()
            r = solve(p, replace(s, tolerance=tol), fields=(), **kw)
            wall = time.perf_counter() - started
            gaps = [(r.diagnostics[k] - ref.diagnostics[k]) / abs(ref.diagnostics[k]) for k in NAMES]
            print(f"| {name} | {tol:.0e} | {r.steps} | {wall:.3f} | " + " | ".join(f"{g:+.1e}" for g in gaps) + " |",
                  flush=True)


if __name__ == "__main__":
    main([float(t) for t in sys.argv[1:]] or [1e-7, 1e-9, 1e-11])
