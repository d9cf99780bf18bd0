"""Study benchmark: speed_sweep with 1 and 2 local workers, and a 1000-case study
(benchmarks/scale_1000.toml: 20 modes, summaries only) with 2 workers: whole-study
efficiency, status and a rerun with nothing new.

Each configuration runs the whole study from scratch (fresh results directory) as a user
would (python -m pipeline run ...), interleaved over several repeats; medians are reported.
Writes results/bench/study.md.

    python benchmarks/bench_study.py [--repeats 3] [--study speed_sweep] [--scale-repeats 3]
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import xarray as xr

ROOT = Path(__file__).resolve().parents[1]


def run(study, workers, out):
    start = time.perf_counter()
    path = study if study.endswith(".toml") else f"studies/{study}.toml"
    proc = subprocess.run([sys.executable, "-m", "pipeline", "run", path, "--out", str(out),
                           "--workers", str(workers), "--no-plots"], cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode not in (0, 1):
        sys.exit(proc.stderr)
    with xr.open_dataset(out / "study.nc") as ds:
        solver = float(ds["run_time"].sum() + ds["error_estimate_run_time"].sum())
        cases = int(ds["case_id"].size)
    return wall, solver, cases


def timed(*args):
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pipeline", *map(str, args)], cwd=ROOT, capture_output=True, text=True)
    return time.perf_counter() - start, proc


def scale_1000(repeats):
    """The 1000-case study from scratch with 2 workers; then status, a no-op rerun, and the
    interpreter with the CLI's imports alone (--version), each timed."""
    study = "benchmarks/scale_1000.toml"
    walls, solvers, effs, statuses, noops, imports = [], [], [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(repeats):
            out = Path(tmp) / f"scale_{rep}"
            wall, solver, cases = run(study, 2, out)
            walls.append(wall)
            solvers.append(solver)
            effs.append(solver / (2 * wall))
            for _ in range(3):
                t, proc = timed("status", study, "--out", out)
                statuses.append(t)
                t, proc = timed("run", study, "--out", out, "--no-plots")
                assert "nothing new" in proc.stderr, proc.stderr[-2000:]
                noops.append(t)
                imports.append(timed("--version")[0])
            print(f"scale_1000 repeat {rep + 1}/{repeats}: {wall:.1f} s, efficiency {effs[-1]:.3f}", flush=True)
    med = statistics.median
    return [
        f"## {cases} cases: benchmarks/scale_1000.toml, 2 workers",
        "",
        f"{repeats} runs from scratch; status and the no-op rerun 3 times after each; medians.",
        "",
        "| what | measured |",
        "|---|---|",
        f"| wall time, whole study | {med(walls):.1f} s (runs: {', '.join(f'{w:.1f}' for w in walls)}) |",
        f"| solver time summed over cases (integration + error-estimate companion) | {med(solvers):.1f} s |",
        f"| efficiency: solver / (2 x wall) | {med(effs):.3f} (runs: {', '.join(f'{e:.3f}' for e in effs)}) |",
        f"| `status` | {med(statuses):.2f} s |",
        f"| rerun with nothing new | {med(noops):.2f} s |",
        f"| interpreter + CLI imports alone (`--version`) | {med(imports):.2f} s |",
        "",
    ]


def cluster_start(workers):
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", "from pipeline.compute.engine import cluster_client\n"
                    f"with cluster_client({workers}, None) as c: c.submit(abs, -1).result()"],
                   cwd=ROOT, check=True, capture_output=True)
    return time.perf_counter() - start


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--study", default="speed_sweep")
    ap.add_argument("--out", default="results/bench/study.md")
    ap.add_argument("--scale-repeats", type=int, default=3)
    args = ap.parse_args(argv)
    scale = scale_1000(args.scale_repeats)
    walls = {1: [], 2: []}
    solver = {1: [], 2: []}
    starts = {1: [], 2: []}
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(args.repeats):
            for workers in (1, 2):
                out = Path(tmp) / f"{workers}_{rep}"
                wall, solver_time, cases = run(args.study, workers, out)
                walls[workers].append(wall)
                solver[workers].append(solver_time)
                starts[workers].append(cluster_start(workers))
            print(f"repeat {rep + 1}/{args.repeats}: 1 worker {walls[1][-1]:.1f} s, "
                  f"2 workers {walls[2][-1]:.1f} s", flush=True)
    med = {w: statistics.median(v) for w, v in walls.items()}
    med_solver = {w: statistics.median(v) for w, v in solver.items()}
    med_start = {w: statistics.median(v) for w, v in starts.items()}
    efficiency = med[1] / (2 * med[2])
    overhead = (med[1] - med_solver[1] - med_start[1]) / cases
    lines = [
        f"# Study benchmark: {args.study}",
        "",
        f"`make bench` ({Path(__file__).name}), {time.strftime('%Y-%m-%d')}; {args.repeats} interleaved repeats "
        f"of the whole study from scratch ({cases} cases) with `python -m pipeline run`, medians.",
        "",
        "| workers | wall time [s] | solver time, sum over cases [s] | cluster start + stop [s] |",
        "|---|---|---|---|",
        f"| 1 | {med[1]:.1f} | {med_solver[1]:.1f} | {med_start[1]:.1f} |",
        f"| 2 | {med[2]:.1f} | {med_solver[2]:.1f} | {med_start[2]:.1f} |",
        "",
        f"Parallel efficiency with 2 workers: {efficiency:.2f} (wall(1) / (2 wall(2))).",
        f"Runner overhead per case with 1 worker (wall - solver - cluster start, over {cases} cases; "
        f"it includes writing the batch files, imports and the combine): {overhead:.2f} s.",
        "",
        *scale,
    ]
    out = ROOT / args.out
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
