"""The command's entry point, shared by ``python -m pipeline`` and the console script
``floe-impact``: install the interrupt handler, run pipeline.cli.main, leave with its exit status."""
import os
import signal
import sys

from .cli import main
from .common import interrupts

INTERRUPTED = 130


def console() -> None:
    """Run the command line and exit with its status (see pipeline.cli for the statuses)."""
    try:
        interrupts.install()
        code = main()
    except KeyboardInterrupt:                    # Ctrl-C while Python imports the runner, or
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        print("interrupted: finished cases are kept; run the same command again to resume",  # just
              file=sys.stderr)                                                              # after it
        code = INTERRUPTED
    # the work is done (or given up): a Ctrl-C during the interpreter's shutdown (dask's and
    # multiprocessing's exit handlers) would kill it with a signal instead of this exit status
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if code == INTERRUPTED:
        # interrupted: the cluster is closed and the lock released (the finally blocks ran on the
        # way here). The interpreter's own shutdown still ended such a run by SIGINT now and then
        # (exit -2 after the hint: about 1 in 20 trials, also on clean clones); run multiprocessing's
        # clean-up (its semaphores) and leave without the rest of it
        import multiprocessing.util
        multiprocessing.util._exit_function()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(INTERRUPTED)
    sys.exit(code)
