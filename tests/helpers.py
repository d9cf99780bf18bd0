"""Helpers the test files share: the repository's root, the command line (in this process, or in
a process of its own as a user runs it), a results directory's batch files, determinism of
study.nc on one machine, a small grid study, a figure's axes drawn without writing it, and the
sockets a process tree listens on, the composition matrix's options, and a composite
Gauss-Legendre rule independent of the solver's."""
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import xarray as xr

from pipeline.store.casefile import DamagedFile, read_batch

ROOT = Path(__file__).resolve().parents[1]

#: the composition matrix's physics options and numerics (tests/test_composition.py; a run that
#: breaks meets each in tests/test_breaking.py), its base case, and the rules' subintervals
OPTIONS = {"floe": dict(edges="free"), "off_centre": dict(x0=0.7), "finite_mass": dict(body_mass=800.0),
           "wedge": dict(deadrise=10.0), "power_law": dict(body_p=4.0), "flat": dict(flat_width=0.3),
           "viscoelastic_ice": dict(tau=1e-4), "viscoelastic_layer": dict(layer_tau=1e-3),
           "linear_layer": dict(layer_law="linear"), "finite_depth": dict(H=2.0)}
NUMERICS = {**{f"{i}/{q}": dict(integrator=i, quadrature=q) for i in ("etd34", "rk4", "dop853")
               for q in ("gauss", "paper")},
            **{f"etd34-smoothness/{q}": dict(quadrature=q, error_control="smoothness") for q in ("gauss", "paper")}}
BASE = dict(Nmod=6, duration=0.004)
SUBINTERVALS = {"gauss": 64, "paper": 1000}

#: a 2 x 2 grid of 6 modes that runs in a second or two (integrity, command line, figures)
SMALL_GRID_STUDY = """
description = "integrity tests"
[base]
Nmod = 6
[grid]
V = [3.0, 5.0]
hi = [0.3, 0.5]
[output]
times = { unit = "t_sc", step = 0.25, stop = 0.5 }
fields = ["strain"]
x_points = 11
end = "last_output"
"""

#: 60 cases of 16 modes, about 0.2 s each: several seconds of work on two workers, long enough to
#: lose a worker or a job mid-study (tests/test_batch_system.py, tests/test_cluster.py)
JOBS_STUDY = """
description = "60 cases for a cluster"
[base]
Nmod = 16
[grid]
V = [3.0, 4.0, 5.0, 6.0, 7.0]
hi = [0.3, 0.4, 0.5, 0.6]
K = [4e6, 6e6, 8e6]
[output]
times = { unit = "t_sc", step = 0.5, stop = 3.0 }
fields = ["strain"]
x_points = 11
end = "last_output"
"""

#: a threshold search of 6 modes on two thicknesses (tests/test_search.py, test_hostile_tables.py)
SEARCH_STUDY = """
description = "the speed at which the layer bottoms out, on thin and thick ice"
[base]
Nmod = 6
[grid]
hi = [0.3, 1.0]
[search]
key = "V"
bracket = [1.0, 10.0]
log = true
event = "bottoming"
tolerance = 0.05
[output]
fields = []
times = { unit = "stage", count = 3 }
"""

#: what two runs on one machine may differ in: wall times
WALL_TIMES = ("run_time", "error_estimate_run_time")


#: seconds a test's run of the command line may take
RUN_TIMEOUT = 300


def run_process(*args, cwd=ROOT):
    """python -m pipeline ... as a user runs it, in a process of its own; returns (exit code,
    stdout, stderr). For what only a process shows: its exit status from the console entry
    point, everything written to its stderr (warnings, its workers' output), signals."""
    proc = subprocess.run([sys.executable, "-m", "pipeline", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=RUN_TIMEOUT)
    return proc.returncode, proc.stdout, proc.stderr


def run_cli(*args, cwd=ROOT):
    """The command line's pipeline.cli.main(args), run in this process from ``cwd``; returns
    (exit status, stdout, stderr) as run_process does. A process of its own costs about 2.5 s
    of CPU per run (Python, its imports, the workers' forkserver); here the forkserver of this
    test process serves every run."""
    import contextlib
    import faulthandler
    import io
    import os

    from pipeline.cli import main
    out, err = io.StringIO(), io.StringIO()
    previous = os.getcwd()
    os.chdir(cwd)
    # a run that hangs ends the test process with every thread's traceback, as run_process's
    # timeout ends its run (pytest-xdist reports the test as crashed), instead of hanging the suite
    faulthandler.dump_traceback_later(RUN_TIMEOUT, exit=True)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except SystemExit as exit_:                  # argparse's usage errors
                code = exit_.code
    finally:
        faulthandler.cancel_dump_traceback_later()
        os.chdir(previous)
    return code, out.getvalue(), err.getvalue()


def batch_files(out):
    """The batch files of a results directory (named by their checksums)."""
    return sorted((Path(out) / "batches").glob("*.nc"))


#: a ragged record's start variable -> (its count variable, its sample dimension)
RAGGED = {"tension_record_start": ("tension_record_count", "tension_node"),
          "contact_change_start": ("contact_change_entries", "contact_change")}


def assert_same_study(out, reference):
    """study.nc of two results directories holds the same variables, statuses and numbers, bit
    for bit but for the wall times: determinism on one machine (another CPU's round-off moves
    an adaptive run within its error: tests/reference.py). The ragged records are in grid order
    whatever order the batches arrived in (a worker lost mid-batch, a resume), each case's
    starting where the counts before it end, as a CF contiguous ragged array reader assumes."""
    with xr.open_dataset(Path(out) / "study.nc") as ds, xr.open_dataset(Path(reference) / "study.nc") as ref:
        assert set(ds.data_vars) == set(ref.data_vars)
        samples = {dim: count for count, dim in RAGGED.values()}
        for name, var in ref.data_vars.items():
            if name in WALL_TIMES:
                continue
            sample = set(var.dims) & set(samples)
            if sample:           # a case written twice (a batch run again) leaves unread nodes at the end
                total = int(ref[samples[sample.pop()]].values.sum())
                np.testing.assert_array_equal(ds[name].values[:total], var.values[:total], err_msg=name)
            else:
                np.testing.assert_array_equal(ds[name].values, var.values, err_msg=name)
        for start, (count, _) in RAGGED.items():
            if start in ds:
                counts = np.asarray(ds[count].values, dtype=np.int64).ravel()
                np.testing.assert_array_equal(ds[start].values.ravel(), np.cumsum(counts) - counts, err_msg=start)


def figure_axes(monkeypatch, draw):
    """Draw with save replaced (in each figure module, which imports it by name), and return
    the figure's axes."""
    from pipeline.figures import common, paper, sweeps
    captured = {}
    for module in (sweeps, paper):
        monkeypatch.setattr(module, "save", lambda fig, path, dpi: captured.setdefault("fig", fig))
    monkeypatch.setattr(common.plt, "close", lambda fig: None)
    draw()
    return captured["fig"].axes


def start_runner(study_file, out, workers=2):
    """The runner in a process of its own and a session of its own (so that a test can signal
    its process group), without figures."""
    return subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(study_file), "--out", str(out),
                             "--workers", str(workers), "--no-plots"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)

def finished_batches(out) -> dict:
    """batch file -> case ids, for every complete batch file (its bytes match its name)."""
    done = {}
    for path in batch_files(out):
        try:
            done[path] = [str(c) for c in read_batch(path)["case"].values]
        except DamagedFile:
            pass
    return done

def assert_same_results(out, reference):
    """study.nc of a disturbed run holds the undisturbed statuses and strains, every case present."""
    with xr.open_dataset(Path(out) / "study.nc") as ds, xr.open_dataset(Path(reference) / "study.nc") as ref:
        assert (ds["status"].values == ref["status"].values).all()
        assert (ds["status"].values != "missing").all()
        np.testing.assert_array_equal(ds["strain"].values, ref["strain"].values)
        np.testing.assert_array_equal(ds["max_strain"].values, ref["max_strain"].values)

def kill_runner_then_resume(study_file, undisturbed, out, delay, cases=8):
    """SIGKILL the runner and its workers ``delay`` s into a run of ``cases`` cases, resume it: no
    finished batch rewritten, no case lost or computed twice, the undisturbed results."""
    proc = start_runner(study_file, out)
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGKILL)                 # the runner and its workers, at once
    proc.wait()
    finished = finished_batches(out)     # what a resume may trust: complete files, in the ledger or not
    stamps = {path: path.stat().st_mtime_ns for path in finished}
    n_done = len({cid for ids in finished.values() for cid in ids})
    code, _, err = run_cli("run", study_file, "--out", out, "--no-plots")
    assert code == 0, err
    assert f"{cases - n_done} to run, {n_done} already done" in err   # 0 lost, 0 computed twice
    for path, stamp in stamps.items():
        assert path.stat().st_mtime_ns == stamp, f"{path.name}: a finished batch was rewritten"
    after = finished_batches(out)
    assert sum(len(ids) for ids in after.values()) == cases, "a case was computed twice"
    assert_same_results(out, undisturbed)


def listening_sockets(pids: set) -> list:
    """(address, port) of every TCP socket in LISTEN that one of the processes holds (Linux /proc)."""
    inodes = {}
    for pid in pids:
        try:
            for fd in os.listdir(f"/proc/{pid}/fd"):
                target = os.readlink(f"/proc/{pid}/fd/{fd}")
                if target.startswith("socket:["):
                    inodes[target[8:-1]] = pid
        except OSError:
            continue
    found = []
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            local, state, inode = fields[1], fields[3], fields[9]
            if state == "0A" and inode in inodes:                 # 0A: LISTEN
                address, port = local.split(":")
                raw = bytes.fromhex(address)
                words = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
                found.append((socket.inet_ntop(socket.AF_INET if width == 8 else socket.AF_INET6, words),
                              int(port, 16)))
    return found


def process_tree(root: int) -> set:
    """The process and all its descendants (Linux /proc)."""
    pids, grew = {root}, True
    while grew:
        grew = False
        for entry in os.listdir("/proc"):
            if entry.isdigit() and int(entry) not in pids:
                try:
                    parent = int(Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[1])
                except (OSError, IndexError, ValueError):
                    continue
                if parent in pids:
                    pids.add(int(entry))
                    grew = True
    return pids


def children(pid: int) -> list:
    """(pid, command line) of each live child of ``pid``, from /proc: the whole command line
    (``ps -o args`` cuts it at $COLUMNS, and a clone at a longer path lost "forkserver" from
    its forkserver's line: the killed-worker test found no workers on every such clone)."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            cmdline = Path(f"/proc/{entry}/cmdline").read_bytes()
        except (OSError, IndexError):
            continue
        if int(stat[1]) == pid and stat[0] not in "ZX":
            found.append((int(entry), cmdline.replace(b"\0", b" ").decode(errors="replace").strip()))
    return sorted(found)


def local_workers(runner: int) -> list:
    """The pids of a local run's dask worker processes: the children of its forkserver
    (pipeline.compute.forkserver), or its spawned children where there is no forkserver."""
    kids = children(runner)
    servers = [pid for pid, args in kids if "multiprocessing.forkserver" in args]
    if servers:
        return [pid for server in servers for pid, _ in children(server)]
    return [pid for pid, args in kids if "multiprocessing.spawn" in args]


def when_frozen(proc, ready, timeout: float = 120.0):
    """Wait, with a bound, for a state of a running runner, looked at while it is stopped
    (SIGSTOP: its scheduler, its combine and its exit cannot move on meanwhile). ``ready()``
    returns a value (the state is there), None (not yet), or raises AssertionError (it can no
    longer come). Returns that value with the runner still stopped: the caller acts on it
    (kills a worker, sends a Ctrl-C), then calls ``resume(proc)``. Fails with what it saw."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise AssertionError(f"the runner ended (exit {proc.returncode}) before the state the test "
                                 f"waits for: {proc.communicate()[1][-2000:]}")
        os.kill(proc.pid, signal.SIGSTOP)
        try:
            found = ready()
        except BaseException:
            resume(proc)
            raise
        if found is not None:
            return found
        resume(proc)
        time.sleep(0.02)
    raise AssertionError(f"the state the test waits for did not come within {timeout} s: "
                         f"children {children(proc.pid)}")


def resume(proc) -> None:
    """Let a runner stopped by when_frozen go on."""
    try:
        os.kill(proc.pid, signal.SIGCONT)
    except ProcessLookupError:
        pass


def write_fake_batches(study, out, per_batch: int, seed: int = 0):
    """Finished batch files of ``per_batch`` cases each, written directly (no solver), with a
    ledger: each case with random fields, tension records of 300-349 nodes and a few contact
    changes. Returns the Ledger. (tests/test_scale.py; benchmarks/combine_order.py)"""
    from pipeline.store.casefile import batch_dataset, case_arrays, write_batch
    from pipeline.store.ledger import Ledger
    (Path(out) / "batches").mkdir(parents=True)
    ledger, rng = Ledger(out), np.random.default_rng(seed)
    for start in range(0, study.n_cases, per_batch):
        cases = [study.case(i) for i in range(start, min(start + per_batch, study.n_cases))]
        arrays = [case_arrays(c, None, status="ok") for c in cases]
        for a in arrays:
            if "strain" in a:
                a["strain"] = rng.standard_normal(a["strain"].shape)
            a["tension_records"] = [np.sort(rng.random((300 + int(rng.integers(50)), 5)), axis=0)
                                    for _ in a["tension_records"]]
            a["contact_record"] = rng.random((int(rng.integers(6)), 2))
        entry = write_batch(batch_dataset(cases, arrays), Path(out) / "batches")
        entry["cases"] = [[c.case_id, "ok", "", 0.0] for c in cases]
        ledger.append(entry)
    return ledger


def assert_breaking_consistent(result):
    """A run that breaks (solve with fracture = "break") agrees with itself: its breaks in time
    order, each one's part count that of the places so far (solver.breaking.whole_plate_parts),
    the summary's counts, first break and breakthrough those of the breaks, each break's removed
    energy the sum of its plate's part (never negative: the carry is a projection in the plate's
    energies) and its layer's, the removed energies summing to the run's, and crack onset on each
    surface that broke reaching the yield strain exactly at its first break on that surface (none
    above it: a run that breaks refuses a larger eps_Y)."""
    import pytest
    from solver.breaking import whole_plate_parts
    p, events, summary = result.parameters, result.breaking.breaks, result.breaking
    full = result.breaking.full_plate
    times = [e.time for e in events]
    assert times == sorted(times)
    assert summary.break_count == len(events)
    assert [e.parts for e in events] == [whole_plate_parts([e.x for e in events[:k + 1]], full, p.L)
                                            for k in range(len(events))]
    assert summary.parts == (events[-1].parts if events else 1)
    assert summary.first_break_time == (times[0] if events else summary.first_break_time)
    through = [e.time for e in events if e.broken_through]
    assert (np.isnan(summary.breakthrough_time) if not through else summary.breakthrough_time == through[0])
    made = [e for e in events if not np.isnan(e.removed_energy)]      # (a break the run ended at removes none)
    # each removed energy is a difference of the plate's and the layer's energies before and after
    # the carry, which are at most the work done: its rounding is a few eps of the work (1.4e-12
    # J/m on a haswell target where the work is 1.1e4 J/m, tests/test_breaking.py::test_the_cascade)
    rounding = 8 * np.finfo(float).eps * max(abs(result.diagnostics["work"]), 1.0)
    for e in made:
        assert e.removed_plate_energy >= -rounding
        assert e.removed_energy == pytest.approx(e.removed_plate_energy + e.removed_layer_energy, rel=1e-12,
                                                    abs=rounding)
    ok = result.valid
    if made and ok.any():
        assert result.breaking.removed_energy[ok][-1] == pytest.approx(sum(e.removed_energy for e in made),
                                                                        rel=1e-12, abs=1e-12)
    for surface in ("upper", "lower"):
        on = [e.time for e in events if e.surface == surface]
        onset, _ = result.crack_onset([p.yield_strain], surface)
        if on:
            assert onset[0] <= on[0] * (1 + 1e-12) and onset[0] == pytest.approx(on[0], rel=1e-9), surface
    with pytest.raises(Exception, match="above yield_strain"):
        result.crack_onset([1.01 * p.yield_strain])


def assert_breaking_study_consistent(ds):
    """A study.nc in which ice breaks agrees with itself, case by case (assert_breaking_consistent's
    rules on what study.nc stores): the listed breaks in time order and first, their count
    break_count (or all slots, where a run broke more often than there are slots), each break's
    part count that of the places so far and part_count the last, first_break_time and the
    parts over time those of the break times, the removed energies summing to the case's, and
    crack onset at the yield strain of ice that broke on a surface its first break there; its
    eps_Y axis stops at the smallest yield strain of ice that breaks."""
    from solver.breaking import whole_plate_parts
    names = ["break_time", "break_x", "break_surface", "break_part_count", "break_removed_energy", "break_count",
             "part_count", "first_break_time", "breakthrough_time", "removed_energy", "part_count_over_time",
             "fracture", "yield_strain", "x0", "L", "status"]
    case_dims = [d for d in ds["part_count"].dims]
    table = xr.Dataset({n: xr.broadcast(ds[n], ds["part_count"])[0] if ds[n].ndim < len(case_dims) else ds[n]
                        for n in names})
    flat = table.stack(case=case_dims) if case_dims else table.expand_dims("case")
    onset = {s: ds[f"crack_onset_time{'' if s == 'upper' else '_lower'}"] for s in ("upper", "lower")}
    breaking = np.asarray(flat["fracture"].values).astype(str) == "break"
    if breaking.any():
        assert float(ds["eps_Y"].max()) <= float(np.min(np.asarray(flat["yield_strain"].values)[breaking]))
    t = ds["t"].values
    for i in range(flat.sizes["case"]):
        c = flat.isel(case=i)
        times = np.asarray(c["break_time"].values, dtype=float)
        n = int(np.isfinite(times).sum())
        assert np.all(np.isfinite(times[:n])) and np.all(np.diff(times[:n]) >= 0)
        count = int(c["break_count"])
        assert count == n or (n == times.size and count > n)
        if str(c["fracture"].values) != "break":
            assert count == 0 and int(c["part_count"]) == 1
            continue
        x = np.asarray(c["break_x"].values, dtype=float)[:n]
        full = float(c["x0"]) != 0.0 or bool(np.any(x < 0))
        parts = [whole_plate_parts(x[:k + 1], full, float(c["L"])) for k in range(n)]
        np.testing.assert_array_equal(np.asarray(c["break_part_count"].values)[:n], parts)
        if count == n:
            assert int(c["part_count"]) == (parts[-1] if n else 1)
        assert (np.isnan(float(c["first_break_time"])) if not n else float(c["first_break_time"]) == times[0])
        over = np.asarray(c["part_count_over_time"].values, dtype=float)
        expected = np.array([([1] + parts)[int(np.sum(times[:n] < tk))] for tk in t], dtype=float)
        reached = np.isfinite(over)
        np.testing.assert_array_equal(over[reached], expected[reached])
        removed = np.asarray(c["break_removed_energy"].values, dtype=float)[:n]
        made = removed[np.isfinite(removed)]
        assert float(c["removed_energy"]) == pytest_approx(float(made.sum()))
        if n:
            index = {d: c[d].values for d in case_dims}
            surfaces = np.asarray(c["break_surface"].values)[:n]
            for code, surface in enumerate(("upper", "lower")):
                on = times[:n][surfaces == code]
                if on.size:
                    value = float(onset[surface].sel(**index).sel(eps_Y=float(c["yield_strain"]), method="nearest"))
                    assert abs(value - on[0]) <= 1e-9 * on[0], (index, surface, value, on[0])


def pytest_approx(value):
    import pytest
    return pytest.approx(value, rel=1e-12, abs=1e-12)


def composite_gauss(lo, hi, panels=400):
    """(x, w): composite Gauss-Legendre of 16 nodes on ``panels`` panels of [lo, hi] (independent
    of solver.model.parts.gauss_rule)."""
    g, w = np.polynomial.legendre.leggauss(16)
    edges = np.linspace(lo, hi, panels + 1)
    half = 0.5 * np.diff(edges)
    x = (edges[:-1] + half)[:, None] + half[:, None] * g
    return x.ravel(), (half[:, None] * w).ravel()
