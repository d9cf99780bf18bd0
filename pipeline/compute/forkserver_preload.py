"""What the forkserver the local workers are forked from imports (pipeline.compute.forkserver.start),
never the runner: SIGINT ignored, then the worker's modules and, when numba's cache holds them
all, the solver's kernels; each worker is a fork of it and starts with them in memory.

The forkserver inherits the workers' environment (pipeline.compute.worker.SINGLE_THREAD_ENV: numpy and
numba with one thread). It passes on the SIGINT handler its preload left, so the workers ignore
Ctrl-C too: a Ctrl-C stops the runner alone, which abandons the in-flight cases and shuts the
cluster down.
"""
import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)

import distributed  # noqa: E402,F401

from solver import compile_kernels
from solver.compile import kernel_cache  # noqa: E402

from . import worker  # noqa: E402,F401

if kernel_cache.is_complete():                 # the runner compiles a cold cache; workers then load it
    try:
        compile_kernels()
    except Exception:                          # the workers load the kernels themselves (warm_workers)
        pass
