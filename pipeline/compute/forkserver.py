"""Local workers forked ready: the runner starts multiprocessing's forkserver with the workers'
environment, the forkserver imports pipeline.compute.forkserver_preload (the workers' modules, the
kernels), and dask's nannies fork each worker from it (distributed's
"multiprocessing-method" = "forkserver"). A spawned worker imported all that and loaded the
kernels itself: about 1.5 s of CPU per worker, and again for every worker a nanny restarts.

The forkserver lives as long as the process, so that the workers of a later run in a notebook
or a script start as fast. It is stopped and started afresh when it holds code older than the
tree (an edit under solver/ or pipeline/ since it started: its workers would run the old code),
or was started before the kernels were cached.
"""
from __future__ import annotations

import multiprocessing
import os
import shlex
import signal
import tempfile
from contextlib import contextmanager
from pathlib import Path

#: how local workers start; "spawn" (dask's default) where there is no forkserver
METHOD = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
PRELOAD = "pipeline.compute.forkserver_preload"
#: what the running forkserver was started from: (source digest, kernels cached), or None
_started_from = None


def _source() -> tuple:
    from solver.compile import kernel_cache
    digest = kernel_cache.source_digest() + kernel_cache.source_digest(Path(__file__).resolve().parents[1])
    return digest, kernel_cache.is_complete()


def start(environ: dict) -> str:
    """Start the forkserver with ``environ`` added to this process's environment, unless one
    started from the same source runs. Returns how the workers start: "forkserver", or "spawn"
    where there is none, or where a stale one cannot be stopped (a Python without
    ForkServer._stop).

    Its Python starts with SIGINT ignored, inherited across exec, so that a Ctrl-C cannot
    kill it half-way through its start-up (a traceback on the runner's stderr); the runner
    ignores SIGINT only while it forks and execs the forkserver and multiprocessing's resource
    tracker, a few milliseconds."""
    global _started_from
    if METHOD != "forkserver":
        return "spawn"
    from multiprocessing import forkserver

    from distributed.utils import get_mp_context
    source = _source()
    if _started_from is not None and source != _started_from:
        stop = getattr(forkserver._forkserver, "_stop", None)    # CPython's own (its tests')
        if stop is None:
            return "spawn"
        stop()                                   # started afresh below
    # distributed names its own preload modules the first time it asks for the context (once
    # per process); asked here first, its list is replaced by ours, which imports them and more
    get_mp_context().set_forkserver_preload([PRELOAD])
    saved = {key: os.environ.get(key) for key in environ}
    os.environ.update({key: str(value) for key, value in environ.items()})
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    _started_from = source
    return "forkserver"


@contextmanager
def spawned_ignoring_sigint():
    """While it is open, the processes multiprocessing spawns (the workers where there is no
    forkserver, and those a nanny restarts) start with SIGINT ignored, as the forkserver's
    children do: their Python is exec'd by a two-line shell launcher that ignores SIGINT first
    (an ignored signal stays ignored across exec; a handler does not, and CPython's fork_exec
    clears the signal mask, so the runner cannot hand it down any other way). A Ctrl-C then
    reaches only the runner, which records it during the cluster's start and shuts the
    workers down after it. The launcher lives in a temporary directory for the run."""
    from multiprocessing import spawn
    python = spawn.get_executable()
    with tempfile.TemporaryDirectory(prefix="floe-impact-launcher-") as directory:
        launcher = Path(directory) / "python-ignoring-sigint"
        launcher.write_text(f"#!/bin/sh\ntrap '' INT\nexec {shlex.quote(os.fsdecode(python))} \"$@\"\n")
        launcher.chmod(0o700)
        spawn.set_executable(str(launcher))
        try:
            yield
        finally:
            spawn.set_executable(python)
