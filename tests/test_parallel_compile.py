"""The first compile on two cores (solver/compile/parallel_compile.py): the helper compiles exactly the
subtrees integrate calls, one process compiles each function, and the helper never outlives
the process that started it."""
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from numba import typeof
from numba.core.caching import NullCache

import solver
from solver import loop
from solver import first_compile
from solver.compile import parallel_compile
from solver.compile.parallel_compile import Claims

from helpers import children

ROOT = Path(__file__).resolve().parents[1]


def test_the_helpers_subtrees_are_those_integrate_calls(monkeypatch):
    """helper_jobs builds its argument types as integrate does: type integrate (for linking,
    its callees from the link cache) on compile_kernels' first case, and each of the helper's
    signatures must be one integrate asked for. (If they drifted, the helper's work would be
    wasted: the results the same, the first compile 10 s slower.)"""
    seen = []

    def recording(*args):
        seen.append(args)
        return integrate(*args)

    integrate = solver.run.integrate
    monkeypatch.setattr(solver.run, "integrate", recording)
    p, s, times = first_compile.tiny_case()
    solver.solve(p, s, times=times)
    argtypes = tuple(typeof(a) for a in seen[0])
    # integrate typed here (not its link-only library from the cache, which a run of this test
    # leaves there): its callees come from the link cache
    monkeypatch.setattr(loop.integrate.link_dispatcher, "_cache", NullCache())
    loop.integrate.link_dispatcher.compile(argtypes)
    jobs = first_compile.helper_jobs()
    assert [function.__name__ for function, _ in jobs] == ["observe_step", "take_step", "ending_event", "break_inside_step",
                                                           "judge_step"]
    for function, job in jobs:
        assert job in function.link_dispatcher.overloads, function.__name__


class _FakeCache:
    """What Claims needs of a LinkCache: a name, an index key and the cached result."""

    def __init__(self):
        self.result = None
        self._impl = type("Impl", (), {"filename_base": "link-fake.f-1.py311"})()

    def _index_key(self, sig, codegen):
        return (sig, "magic")

    def load_cached(self, sig, target_context):
        return self.result


class _Context:
    def codegen(self):
        return None


def _dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_a_function_is_claimed_once_and_a_stale_claim_is_taken_over(tmp_path):
    claims, cache = Claims(tmp_path), _FakeCache()
    path = claims.path(cache, ("f8",), None)
    assert claims.load_or_claim(cache, ("f8",), _Context()) is None          # ours: compile it
    assert path.read_text() == str(os.getpid()) and not claims.take(path)
    claims.release(cache, ("f8",), None)
    assert not path.exists()
    path.write_text(str(_dead_pid()))                   # a process that died while compiling
    assert claims.load_or_claim(cache, ("f8",), _Context()) is None
    assert path.read_text() == str(os.getpid())
    claims.release_all()
    assert not path.exists()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="zombies are seen in /proc")
def test_a_claim_of_a_process_that_ended_unreaped_is_stale(tmp_path):
    """The helper ended (say its compile raised) but its parent, the one waiting for its claim,
    has not reaped it yet: a zombie holds nothing, or the parent would wait PATIENCE for it."""
    claims = Claims(tmp_path)
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    try:
        deadline = time.monotonic() + 10
        while Path(f"/proc/{child.pid}/stat").read_text().rpartition(")")[2].split()[0] != "Z":
            assert time.monotonic() < deadline
            time.sleep(0.01)
        (tmp_path / "claim").write_text(str(child.pid))
        assert not claims.holder_alive(tmp_path / "claim")
        (tmp_path / "claim").write_text(str(os.getpid()))
        assert claims.holder_alive(tmp_path / "claim")
    finally:
        child.wait()


def test_a_function_another_process_compiles_is_waited_for(tmp_path):
    """The other process (alive) holds the claim; its result appears in the cache 0.3 s later:
    this process waits and takes it instead of compiling."""
    claims, cache = Claims(tmp_path), _FakeCache()
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        claims.path(cache, ("f8",), None).write_text(str(other.pid))
        threading.Timer(0.3, lambda: setattr(cache, "result", "compiled elsewhere")).start()
        started = time.monotonic()
        assert claims.load_or_claim(cache, ("f8",), _Context()) == "compiled elsewhere"
        assert 0.25 < time.monotonic() - started < 5
        assert not claims.held
    finally:
        other.kill()
        other.wait()


def _alive(pid):
    try:
        return Path(f"/proc/{pid}/status").read_text().split("State:\t")[1][0] not in "ZX"
    except (OSError, IndexError):
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux") or len(os.sched_getaffinity(0)) < 2,
                    reason="the helper runs on Linux machines with two cores or more")
@pytest.mark.parametrize("how", ["SIGKILL", "SIGINT"])
def test_the_helper_ends_with_the_process_that_started_it(tmp_path, how):
    """A first compile (empty cache) starts its helper; killed (kill -9) or interrupted (Ctrl-C
    to it alone), the compile's process takes its helper with it. (The helper's end is what is
    asserted after a Ctrl-C, not the first process's: once in a full suite on a fresh clone, that
    process had not exited 10 s after its Ctrl-C; a run's compile process is killed by the
    runner, pipeline/compute/engine.py.)"""
    env = dict(os.environ, FLOE_IMPACT_KERNEL_CACHE=str(tmp_path / "kernels"))
    env.pop(parallel_compile.ENABLE, None)
    proc = subprocess.Popen([sys.executable, "-c", "import solver; solver.compile_kernels()"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        while not (helpers := [pid for pid, _ in children(proc.pid)]) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert helpers, "no helper process started"
        time.sleep(1.0)                                  # both compiling
        proc.send_signal(9 if how == "SIGKILL" else 2)
        if how == "SIGKILL":
            proc.wait(timeout=10)
        deadline = time.monotonic() + 15
        while any(_alive(pid) for pid in helpers) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(_alive(pid) for pid in helpers), "the helper outlived its parent"
    finally:
        proc.kill()
        proc.wait()


def test_a_run_compiles_in_one_process_when_asked(monkeypatch):
    """FLOE_IMPACT_COMPILE_HELPER=0 (or one core, or a complete cache): no helper is started."""
    monkeypatch.setenv(parallel_compile.ENABLE, "0")
    started = []
    monkeypatch.setattr(parallel_compile.subprocess, "Popen", lambda *a, **k: started.append(a))
    with parallel_compile.helper(first_compile.run_helper):
        pass
    assert started == [] and solver.compile.jit.claims is None


def test_the_interrupt_handler_is_the_one_before_after_the_compile():
    """The handler that stops the helper on Ctrl-C is set for the compile only."""
    import signal
    before = signal.getsignal(signal.SIGINT)
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        with parallel_compile._stop_on_interrupt(child):
            assert signal.getsignal(signal.SIGINT) is not before
        assert signal.getsignal(signal.SIGINT) is before
    finally:
        child.kill()
        child.wait()
