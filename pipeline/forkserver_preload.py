"""The process the local workers are forked from (multiprocessing's forkserver), made ready once
per runner: one thread for numba and BLAS, the worker's modules imported and, when numba's cache
holds them, the solver's kernels loaded. Each worker is then a fork of it and starts with all
that in memory, where a spawned worker imported it all and loaded the kernels itself (about
1.5 s of CPU per worker, and again for every worker a nanny restarts).

Imported by the forkserver as its preload module (pipeline.forkserver.start), never by the
runner. The forkserver inherits the workers' environment (pipeline.engine.SINGLE_THREAD_ENV)
and imports numpy and numba with one thread.

The forkserver ignores SIGINT and so do the workers forked from it (it passes on the handler its
preload modules left): a Ctrl-C stops the runner alone, which abandons the in-flight cases and
shuts the cluster down.
"""
import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)

import distributed  # noqa: E402,F401

from solver import compile_kernels, kernel_cache  # noqa: E402

from . import worker  # noqa: E402,F401

if kernel_cache.is_complete():                 # the runner compiles a cold cache; workers then load it
    try:
        compile_kernels()
    except Exception:                          # the workers load the kernels themselves (warm_workers)
        pass
