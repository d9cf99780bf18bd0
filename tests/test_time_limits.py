"""No test can hang the suite (docs/reliability.md, "What fires when"): every test has a time limit
(pytest-timeout, pyproject.toml), longer for slow and cluster tests (tests/conftest.py); when it
fires, the stack of every thread is printed and the test's process ends, whatever it was stuck in."""
import subprocess
import sys
import time

import pytest

from conftest import TIME_LIMITS, pytest_collection_modifyitems
from helpers import ROOT

HANGS = '''
import threading


def test_waits_for_a_lock_never_released():
    lock = threading.Lock()
    lock.acquire()
    threading.Thread(target=threading.Event().wait, name="a-worker-that-never-comes", daemon=True).start()
    lock.acquire()
'''


def test_a_test_that_hangs_is_stopped_with_every_threads_stack(tmp_path):
    """A test that deadlocks (the main thread on a lock never released, another on an event never
    set), under the project's own settings with a 2 s limit: stopped within seconds, reported with
    the stacks of both threads, and the run fails."""
    test_file = tmp_path / "test_hangs.py"
    test_file.write_text(HANGS)
    started = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-c", str(ROOT / "pyproject.toml"),
                           "--rootdir", str(tmp_path), "-o", "timeout=2", str(test_file)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    output = proc.stdout + proc.stderr
    assert proc.returncode != 0, output
    assert time.monotonic() - started < 60
    assert "Timeout" in output and "a-worker-that-never-comes" in output, output
    assert "lock.acquire()" in output, output            # the main thread's stack: where it waits


class _Item:
    def __init__(self, *markers):
        self.markers = {m: getattr(pytest.mark, m).mark for m in markers}

    def get_closest_marker(self, name):
        return self.markers.get(name)

    def add_marker(self, mark):
        self.markers[mark.name] = mark


def test_slow_and_cluster_tests_have_longer_limits():
    """The default limit is pyproject.toml's; a slow test gets TIME_LIMITS["slow"], a cluster test
    TIME_LIMITS["cluster"], and a test's own limit wins."""
    import tomllib
    settings = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]
    assert settings["timeout"] == 300 and settings["timeout_method"] == "thread"
    items = [_Item(), _Item("slow"), _Item("cluster"), _Item("slow", "timeout")]
    items[3].markers["timeout"] = pytest.mark.timeout(5).mark
    pytest_collection_modifyitems(None, items)
    limits = [item.get_closest_marker("timeout") for item in items]
    assert limits[0] is None and limits[1].args == (TIME_LIMITS["slow"],) and limits[2].args == (TIME_LIMITS["cluster"],)
    assert limits[3].args == (5,) and TIME_LIMITS["slow"] > settings["timeout"]
