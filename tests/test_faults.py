"""Faults on real processes: a worker SIGKILLed mid-study, the runner SIGKILLed at random
moments, Ctrl-C. Each is compared with an undisturbed run of the same study."""
import os
import random
import signal
import subprocess
import sys
import time

import pytest

from helpers import (ROOT, assert_same_results, batch_files, children, finished_batches, kill_runner_then_resume,
                     local_workers, resume, run_cli, start_runner, when_frozen)

STUDY = """
description = "fault tests"
[base]
Nmod = 30
[grid]
V = [3.0, 4.0, 5.0, 6.0]
hi = [0.3, 0.5]
[output]
times = { unit = "stage", count = 6 }
fields = ["strain"]
x_points = 21
"""


@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("faults") / "faults.toml"
    path.write_text(STUDY)
    return path


@pytest.fixture(scope="module")
def undisturbed(study_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("faults") / "undisturbed"
    code, _, err = run_cli("run", study_file, "--out", out, "--no-plots")
    assert code == 0, err
    return out


def _worker_while_cases_run(out, proc):
    """Wait for a running study (the runner frozen while looked at): a batch file written and
    a worker alive. Returns that worker's pid, the runner still stopped."""
    def ready():
        files, workers = batch_files(out), local_workers(proc.pid)
        if files and workers:
            return workers[0]
        # no worker after a batch file: the cluster is closed, the study past its cases
        assert not files, f"the study ended its cases before the test saw a worker: {children(proc.pid)}"
        return None
    return when_frozen(proc, ready)


def test_killed_worker_does_not_stop_the_study(study_file, undisturbed, tmp_path):
    out = tmp_path / "worker_killed"
    proc = start_runner(study_file, out)
    worker = _worker_while_cases_run(out, proc)
    os.kill(worker, signal.SIGKILL)
    resume(proc)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    ids = [case for cases in finished_batches(out).values() for case in cases]
    # every case finished; one may have been computed twice: a task's result stays on its worker
    # until the runner fetches it, so a worker killed between writing a batch file and that fetch
    # loses the result and dask runs the batch again (its first file is complete, not in the ledger)
    assert len(set(ids)) == 8 and len(ids) <= 9, ids
    assert not list((out / "batches").glob("*.damaged-*")) and not list((out / "batches").glob(".*tmp*"))
    assert_same_results(out, undisturbed)


@pytest.mark.parametrize("trial", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_killed_runner_resumes_without_loss(study_file, undisturbed, tmp_path, trial):
    kill_runner_then_resume(study_file, undisturbed, tmp_path / f"runner_{trial}",
                            delay=random.Random(trial).uniform(2.0, 6.0))


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(10))
def test_killed_runner_resumes_without_loss_many(study_file, undisturbed, tmp_path, trial):
    kill_runner_then_resume(study_file, undisturbed, tmp_path / f"runner_{trial}",
                            delay=random.Random(100 + trial).uniform(0.5, 9.0))


def test_ctrl_c_keeps_finished_cases_and_says_how_to_resume(study_file, undisturbed, tmp_path):
    out = tmp_path / "interrupted"
    proc = start_runner(study_file, out)
    _worker_while_cases_run(out, proc)
    os.killpg(proc.pid, signal.SIGINT)                  # what a terminal sends on Ctrl-C
    resume(proc)                                        # and the runner takes it now
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "run the same command again to resume" in stderr and "Traceback" not in stderr
    assert len(batch_files(out)) >= 1
    code, _, err = run_cli("run", study_file, "--out", out, "--no-plots")
    assert code == 0, err
    assert "already done" in err
    assert_same_results(out, undisturbed)


def _ctrl_c_at(study_file, undisturbed, out, delay):
    """Ctrl-C (SIGINT to the process group) ``delay`` s after the start: from Python's imports
    through the workers' start-up to the combine. Always exit 130, the one-line hint as the
    last line, no traceback; then the same command finishes with the undisturbed results."""
    proc = start_runner(study_file, out)
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    if proc.returncode == 0:                              # finished before the signal
        return
    assert proc.returncode == 130, (delay, stderr)
    assert "Traceback" not in stderr and "Error" not in stderr, (delay, stderr)
    assert stderr.strip().splitlines()[-1].startswith("interrupted:"), (delay, stderr)
    code, _, err = run_cli("run", study_file, "--out", out, "--no-plots")
    assert code == 0, err
    assert_same_results(out, undisturbed)


@pytest.mark.parametrize("trial", [0, *(pytest.param(i, marks=pytest.mark.slow) for i in (1, 2, 3, 4))])
def test_ctrl_c_at_random_moments_including_start_up(study_file, undisturbed, tmp_path, trial):
    _ctrl_c_at(study_file, undisturbed, tmp_path / f"int{trial}", random.Random(7 + trial).uniform(0.05, 4.0))


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(20))
def test_ctrl_c_at_random_moments_many(study_file, undisturbed, tmp_path, trial):
    _ctrl_c_at(study_file, undisturbed, tmp_path / f"int{trial}", random.Random(70 + trial).uniform(0.05, 6.0))


@pytest.mark.parametrize("delay", [1.0, 4.0])
def test_ctrl_c_while_the_kernels_compile(study_file, tmp_path, delay):
    """A first run compiles the numba kernels (about a minute). Ctrl-C then used to interrupt LLVM
    inside the runner, which crashed at exit (SIGSEGV, seen on a clean clone) instead of exit
    130. The compile now runs in a child process, which the Ctrl-C stops alone."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty_numba_cache")}
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(study_file), "--out",
                             str(tmp_path / "out"), "--no-plots"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, env=env)
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    started = time.monotonic()
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and stderr.strip().splitlines()[-1].startswith("interrupted:"), stderr
    assert time.monotonic() - started < 10, "the runner waited for the compile to finish"


#: the runner behind a library that swallows a KeyboardInterrupt (a bare except around an
#: optional import, a ctypes callback in the compiler): it prints "ready", then the test's
#: SIGINT lands in the swallowing code
SWALLOWING = """
import runpy, sys, time
from pipeline.common import interrupts
interrupts.install()
try:
    print("ready", flush=True)
    time.sleep(30)
except BaseException:
    pass
sys.argv = ["pipeline", *sys.argv[1:]]
runpy.run_module("pipeline", run_name="__main__")
"""


def test_a_ctrl_c_that_a_library_swallowed_still_stops_the_run(study_file, tmp_path):
    """The SIGINT handler records the interrupt; the run checks the record when it has read
    the study, so a KeyboardInterrupt lost inside other code stops it all the same (seen once:
    a Ctrl-C 1.0 s into a first run, under load, was lost and the run went on to exit 0)."""
    proc = subprocess.Popen([sys.executable, "-c", SWALLOWING, "run", str(study_file), "--out",
                             str(tmp_path / "out"), "--no-plots"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    assert proc.stdout.readline().strip() == "ready"
    os.killpg(proc.pid, signal.SIGINT)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert stderr.strip().splitlines()[-1].startswith("interrupted:") and "Traceback" not in stderr, stderr
    assert not (tmp_path / "out").exists()               # stopped before anything was written


def test_the_compile_notice_shows_only_when_the_kernels_compile(capsys, monkeypatch):
    """'compiling them ... about a minute' is printed when the kernels take longer than
    COMPILE_NOTICE to load (a compile), not on every run (from the cache they load in 1.5 s)."""
    from pipeline.compute import engine
    monkeypatch.setattr(engine, "COMPILE_NOTICE", 0.5)
    for seconds, shown in ((0.0, False), (1.5, True)):
        child = subprocess.Popen([sys.executable, "-c", f"import time; time.sleep({seconds})"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        engine.kernels_ready((child, time.monotonic()))
        err = capsys.readouterr().err
        assert ("compiling them" in err) == shown and "kernels ready in" in err, err


def test_a_ctrl_c_while_the_cluster_starts_is_raised_once_it_is_up(monkeypatch):
    """The Ctrl-C goes to a thread that does not block SIGINT (numpy's BLAS threads, started at
    import, do not): ignored there during the cluster's start, it was lost and the study ran to
    its end (seen 4 s into a first run). It is recorded, raised when the cluster is up, and the
    cluster is closed."""
    import threading

    from pipeline.compute import engine
    from pipeline.common import interrupts
    closed = []

    class Cluster:
        def __init__(self, **kwargs):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)

        def close(self):
            closed.append(True)

    stop = threading.Event()
    other = threading.Thread(target=stop.wait)          # started before: SIGINT not blocked there
    other.start()
    monkeypatch.setattr(engine, "LocalCluster", Cluster)
    monkeypatch.setattr(interrupts, "requested", False)
    # as a runner has it (interrupts.install): a test process started in the background by a
    # non-interactive shell inherits SIGINT ignored, and a run that ignores Ctrl-C is not this test's
    handler = signal.signal(signal.SIGINT, interrupts._on_sigint)
    try:
        with pytest.raises(KeyboardInterrupt):
            with engine.cluster_client(1, None):
                pytest.fail("the run went on after the Ctrl-C")
    finally:
        signal.signal(signal.SIGINT, handler)
        stop.set()
        other.join()
    assert closed and interrupts.requested


def test_spawned_workers_ignore_a_ctrl_c_during_the_cluster_start(monkeypatch, capfd):
    """Where workers are spawned (no forkserver), the Ctrl-C that a terminal sends to the whole
    process group during the cluster's start is recorded by the runner and raised once the
    cluster is up; the workers, started through a launcher that ignores SIGINT, are not killed
    half-way (their tracebacks on the runner's stderr). It was lost: the runner ignored SIGINT
    meanwhile, so that the workers inherited it ignored."""
    from pipeline.compute import engine, forkserver
    from pipeline.common import interrupts
    sent = {}

    class Cluster(engine.LocalCluster):
        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            workers = [pid for pid, args in children(os.getpid()) if "multiprocessing.spawn" in args]
            for pid in workers:
                os.kill(pid, signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)
            # each worker has had the signal once it is no longer pending there (ignored: dropped),
            # or holds it blocked (inherited from the runner's start; it is dropped, ignored, when
            # unblocked: in a full suite it stayed so, and the wait ran to its 30 s)
            deadline = time.monotonic() + 30
            while any(_sigint(pid, "ShdPnd", "SigPnd") and not _sigint(pid, "SigBlk") for pid in workers) \
                    and time.monotonic() < deadline:
                time.sleep(0.05)
            sent["workers"] = workers
            sent["alive"] = [pid for pid in workers if _alive(pid)]

    monkeypatch.setattr(forkserver, "start", lambda environ: "spawn")
    monkeypatch.setattr(engine, "LocalCluster", Cluster)
    monkeypatch.setattr(interrupts, "requested", False)
    handler = signal.signal(signal.SIGINT, interrupts._on_sigint)
    try:
        with pytest.raises(KeyboardInterrupt):
            with engine.cluster_client(2, None):
                pytest.fail("the run went on after the Ctrl-C")
    finally:
        signal.signal(signal.SIGINT, handler)
    assert len(sent["workers"]) == 2 and sent["alive"] == sent["workers"], sent
    assert interrupts.requested
    err = capfd.readouterr().err                       # the workers write to the runner's stderr
    assert "KeyboardInterrupt" not in err, err[-3000:]


def _alive(pid: int) -> bool:
    try:
        state = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in "ZX"


def _sigint(pid: int, *keys) -> bool:
    """SIGINT's bit in any of the process ``pid``'s signal masks ``keys`` of /proc/<pid>/status
    (ShdPnd, SigPnd: pending; SigBlk: blocked)."""
    try:
        status = dict(line.split(":", 1) for line in open(f"/proc/{pid}/status").read().splitlines())
    except OSError:
        return False
    bit = 1 << (signal.SIGINT - 1)
    return any(int(status[key].strip(), 16) & bit for key in keys)
