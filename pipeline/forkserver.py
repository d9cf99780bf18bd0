"""The process the local workers are forked from (multiprocessing's forkserver), made ready once
per runner: one thread for numba and BLAS, the worker's modules imported and, when numba's cache
holds them, the solver's kernels loaded. Each worker is then a fork of it and starts with all
that in memory, where a spawned worker imported it all and loaded the kernels itself (about
1.5 s of CPU per worker, and again for every worker a nanny restarts).

Imported by the forkserver as its preload module (pipeline.engine), never by the runner.
The forkserver is started by the first worker's nanny, after it has set the workers'
environment (pipeline.engine.SINGLE_THREAD_ENV, in distributed.nanny.pre-spawn-environ) in the
runner's: the forkserver inherits it, and imports numpy and numba with one thread.
"""
import distributed  # noqa: F401

from solver import compile_kernels, kernel_cache

from . import worker  # noqa: F401

if kernel_cache.is_complete():                 # the runner compiles a cold cache; workers then load it
    try:
        compile_kernels()
    except Exception:                          # the workers load the kernels themselves (warm_workers)
        pass
