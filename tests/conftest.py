"""Shared fixtures: runs of the reference case reused by several tests (computed once)."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from solver import Parameters, Settings, compile_kernels, solve


#: the kernels tests call from Python (the DOP853 reference's, crack onset's, the layer's pieces),
#: compiled in a second process while the controller compiles integrate: it ends in about 30 s,
#: the controller in about 35 s (2 cores)
WARM_KERNELS = Path(__file__).with_name("warm_kernels.py")


def pytest_configure(config):
    """Compile (or load) the solver's kernels once, in the controller, before pytest-xdist starts its
    workers: each worker would otherwise compile the same kernels with an empty cache. The
    kernels tests call from Python compile at the same time in a second process (two cores)."""
    if not hasattr(config, "workerinput"):
        helper = subprocess.Popen([sys.executable, str(WARM_KERNELS)])
        try:
            compile_kernels()
        except BaseException:                   # Ctrl-C: stop the helper too, at once
            helper.kill()
            raise
        finally:
            helper.wait()


#: the time limits of tests by marker [s] (pytest-timeout; the default, 300 s, is pyproject.toml's):
#: a long run, and a study on a batch system that waits for its jobs; a test's own
#: @pytest.mark.timeout wins
TIME_LIMITS = {"slow": 1800, "cluster": 900}


def pytest_collection_modifyitems(config, items):
    """Slow and cluster tests get their longer time limits (TIME_LIMITS)."""
    for item in items:
        if item.get_closest_marker("timeout") is None:
            limits = [TIME_LIMITS[m] for m in TIME_LIMITS if item.get_closest_marker(m) is not None]
            if limits:
                item.add_marker(pytest.mark.timeout(max(limits)))


def relative_l2(a, b):
    """||a - b|| / ||b|| over all entries."""
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(b))


def snapshot_times(p, step=0.2, stop=4.6):
    """0, step, ..., stop in units of the case's t_sc, in seconds (the paper's snapshots)."""
    return np.round(np.arange(0.0, stop + 1e-9, step), 10) * p.time_scale


@pytest.fixture(scope="session")
def reference60():
    """The paper's case with 60 modes at the default settings, snapshots every 0.2 t_sc."""
    p = Parameters(Nmod=60)
    return solve(p, Settings(), times=snapshot_times(p), fields=("deflection", "strain", "layer_pressure"))


@pytest.fixture(scope="session")
def reference40():
    p = Parameters(Nmod=40)
    return solve(p, Settings(), times=snapshot_times(p), fields=("strain",))
