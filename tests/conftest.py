"""Shared fixtures: runs of the reference case reused by several tests (computed once)."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from solver import Parameters, Settings, compile_kernels, solve


#: the DOP853 reference calls the model's kernels from Python, each compiled whole on first use
#: (solver/jit.py); a tiny reference run compiles and caches them. The crack-onset kernels
#: (fracture.py) compile there too, so that compile_kernels in the controller finds them cached,
#: and so do the pieces tests call from Python (tests/warm_kernels.py). This process ends in
#: about 30 s, the controller's compile of integrate in about 35 s (2 cores)
REFERENCE_KERNELS = ("import numpy as np; from solver import Parameters, Settings, solve, crack_onset; "
                     "from solver.fracture import thin_record; p = Parameters(Nmod=2); "
                     "solve(p, Settings(integrator='dop853'), times=[0.0, p.stage_duration]); "
                     "rec = np.array([[0.0, 0.0, 1.0, 0.0, 0.0], [1.0, 1.0, 1.0, 0.0, 1.0]]); "
                     "crack_onset(rec[thin_record(rec)], [0.5]); "
                     f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
                     "import warm_kernels; warm_kernels.compile_pieces()")


def pytest_configure(config):
    """Compile (or load) the solver's kernels once, in the controller, before pytest-xdist starts its
    workers: each worker would otherwise compile the same kernels with an empty cache. The
    reference's kernels compile at the same time in a second process (two cores)."""
    if not hasattr(config, "workerinput"):
        helper = subprocess.Popen([sys.executable, "-c", REFERENCE_KERNELS])
        try:
            compile_kernels()
        except BaseException:                   # Ctrl-C: stop the helper too, at once
            helper.kill()
            raise
        finally:
            helper.wait()


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
