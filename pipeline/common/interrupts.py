"""Ctrl-C, never lost: the runner's SIGINT handler records the interrupt before it raises
KeyboardInterrupt, and the run checks the record at fixed points (after the study is read,
when the kernels are ready, before each batch, before the combine). A KeyboardInterrupt that
some library swallowed (a bare ``except:`` around an optional import, a ctypes callback of the
compiler) still stops the run at the next of them.

Only the standard library here: it is installed before anything else is imported.
"""
import signal

#: True once a SIGINT reached the runner
requested = False


def _on_sigint(signum, frame):
    global requested
    requested = True
    raise KeyboardInterrupt


def install() -> None:
    """The runner's SIGINT handler (the main thread's; dask's threads start with SIGINT blocked)."""
    signal.signal(signal.SIGINT, _on_sigint)


def check() -> None:
    """Raise KeyboardInterrupt if a SIGINT reached the runner, even if its first raise was lost."""
    if requested:
        raise KeyboardInterrupt
