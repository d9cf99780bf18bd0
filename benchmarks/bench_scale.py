"""Scale benchmark (make bench-scale): a study of 100 000 small cases, run here, end to end.

benchmarks/scale_100k.toml: Nmod 4-8, V, hi and K swept, the first 0.5 t_sc of each impact
(``end = "last_output"``), summaries only (``fields = []``, ``records = false``), no error
estimate. What it measures, each as the user meets it (``python -m pipeline ...``):

- the whole run with 2 local workers: wall time, the runner's peak RSS (its own, not the
  workers'), the combine's time (printed by the runner), the files it leaves, and the
  efficiency: solver time summed over cases / (workers x wall time);
- ``status``: median of 3;
- a rerun with nothing new: median of 3;
- a runner killed (SIGKILL, with its workers) at a random moment, then rerun: every case
  finished before the kill is kept (none recomputed, none lost) and study.nc is the same.

Writes results/bench/scale.md.

    python benchmarks/bench_scale.py [--study benchmarks/scale_100k.toml] [--keep DIR]
"""
from __future__ import annotations

import argparse
import os
import random
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
#: runs the CLI and reports the runner's own peak RSS on stderr at exit
WRAPPER = ("import resource, sys\nfrom pipeline.cli import main\ncode = main(sys.argv[1:])\n"
           "print(f'peak RSS of the runner: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB', "
           "file=sys.stderr)\nsys.exit(code)")


def cli(*args, timeout=3600):
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", WRAPPER, *map(str, args)], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout)
    return time.perf_counter() - start, proc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", default="benchmarks/scale_100k.toml")
    ap.add_argument("--out", default="results/bench/scale.md")
    ap.add_argument("--keep", help="results directory to use and keep (default: a temporary one)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    tmp = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench_scale_"))
    out, killed = tmp / "run", tmp / "killed"
    for d in (out, killed):
        shutil.rmtree(d, ignore_errors=True)
    wall, proc = cli("run", args.study, "--out", out, "--yes")
    if proc.returncode not in (0, 1):
        sys.exit(proc.stderr[-3000:])
    err = proc.stderr
    rss = float(re.search(r"peak RSS of the runner: (\d+) MiB", err).group(1))
    combine = float(re.search(r"wrote \S+study\.nc \(([\d.]+) s\)", err).group(1))
    with xr.open_dataset(out / "study.nc") as ds:
        solver = float(ds["run_time"].sum())
        n_cases = int(ds["case_id"].size)
        statuses = {s: int((ds["status"] == s).sum()) for s in np.unique(ds["status"].values)}
    files = sum(1 for p in out.rglob("*") if p.is_file())
    batches = sum(1 for _ in (out / "batches").glob("*.nc"))
    status_times, noop_times = [], []
    for _ in range(3):
        t, p = cli("status", args.study, "--out", out)
        assert p.returncode == 0, p.stderr
        status_times.append(t)
        t, p = cli("run", args.study, "--out", out, "--yes")
        assert p.returncode in (0, 1) and "nothing new" in p.stderr, p.stderr[-2000:]
        noop_times.append(t)
    imports, _ = cli("--version")                            # the interpreter and the CLI's imports
    # killed at a random moment, then rerun
    delay = random.Random(args.seed).uniform(0.2, 0.8) * wall
    runner = subprocess.Popen([sys.executable, "-m", "pipeline", "run", args.study, "--out", str(killed), "--yes"],
                              cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              start_new_session=True)
    time.sleep(delay)
    os.killpg(runner.pid, signal.SIGKILL)
    runner.wait()
    from pipeline.store.casefile import DamagedFile, read_batch
    finished = set()
    for path in (killed / "batches").glob("*.nc"):
        try:
            finished.update(str(c) for c in read_batch(path)["case"].values)
        except DamagedFile:
            pass
    t_resume, p = cli("run", args.study, "--out", killed, "--yes")
    resumed = re.search(r"(\d+) to run, (\d+) already done", p.stderr)
    with xr.open_dataset(out / "study.nc") as a, xr.open_dataset(killed / "study.nc") as b:
        same = bool((a["status"].values == b["status"].values).all()
                    and np.array_equal(a["max_strain"].values, b["max_strain"].values, equal_nan=True))
    kept = int(resumed.group(2)) == len(finished)
    lines = [
        f"# Scale benchmark: {Path(args.study).name}",
        "",
        f"`make bench-scale` ({Path(__file__).name}), {time.strftime('%Y-%m-%d')}, this 2-core machine, "
        f"2 local workers. One run of the study from scratch (timings of status and the no-op rerun: "
        f"medians of 3).",
        "",
        "| what | measured | target |",
        "|---|---|---|",
        f"| cases | {n_cases} ({', '.join(f'{n} {s}' for s, n in statuses.items())}) | 100 000 |",
        f"| whole run, wall time | {wall:.0f} s | < 15 min |",
        f"| solver time summed over cases | {solver:.0f} s | |",
        f"| efficiency: solver / (2 workers x wall) | {solver / (2 * wall):.2f} | |",
        f"| runner peak RSS | {rss:.0f} MiB | <= 1 GB |",
        f"| combine (batch files -> study.nc) | {combine:.1f} s | <= 2 min |",
        f"| files left | {files} ({batches} batch files) | <= 2000 |",
        f"| `status` | {statistics.median(status_times):.2f} s | <= 2 s |",
        f"| rerun with nothing new | {statistics.median(noop_times):.2f} s | |",
        f"| interpreter + CLI imports alone (`--version`) | {imports:.2f} s | |",
        f"| runner killed at {delay:.0f} s, then rerun | {len(finished)} cases finished before the kill, "
        f"{resumed.group(2) if resumed else '?'} kept by the rerun, {resumed.group(1) if resumed else '?'} run; "
        f"study.nc {'identical' if same else 'DIFFERENT'} (status, max_strain); rerun {t_resume:.0f} s | "
        f"nothing lost |",
        "",
    ]
    text = "\n".join(lines)
    target = ROOT / args.out
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(text)
    print(text)
    if not args.keep:
        shutil.rmtree(tmp, ignore_errors=True)
    if not (same and kept):
        sys.exit("the killed-and-rerun study lost or changed results")


if __name__ == "__main__":
    main()
