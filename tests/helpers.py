"""Helpers the test files share: the repository's root, the command line (in this process, or in
a process of its own as a user runs it), a results directory's batch files, determinism of
study.nc on one machine, a small grid study, and a figure's axes drawn without writing it."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]

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


def assert_same_study(out, reference):
    """study.nc of two results directories holds the same variables, statuses and numbers, bit
    for bit but for the wall times: determinism on one machine (another CPU's round-off moves
    an adaptive run within its error: tests/reference.py)."""
    with xr.open_dataset(Path(out) / "study.nc") as ds, xr.open_dataset(Path(reference) / "study.nc") as ref:
        assert set(ds.data_vars) == set(ref.data_vars)
        for name, var in ref.data_vars.items():
            if name not in WALL_TIMES:
                np.testing.assert_array_equal(ds[name].values, var.values, err_msg=name)


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
