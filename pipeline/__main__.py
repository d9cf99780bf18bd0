import os
import signal
import sys

INTERRUPTED = 130

try:
    from .cli import main
    code = main()
except KeyboardInterrupt:                        # Ctrl-C while Python imports the runner, or
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    print("interrupted: finished cases are kept; run the same command again to resume",  # just
          file=sys.stderr)                                                              # after it
    code = INTERRUPTED
# the work is done (or given up): a Ctrl-C during the interpreter's shutdown (dask's and
# multiprocessing's exit handlers) would kill it with a signal instead of this exit status
signal.signal(signal.SIGINT, signal.SIG_IGN)
if code == INTERRUPTED:
    # interrupted: the cluster is closed, the lock released and the partial study.nc removed
    # (the finally blocks ran on the way here); skip the interpreter's shutdown, in which a
    # second SIGINT still ended the process by that signal (exit -2, 2 of about 40 trials)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(INTERRUPTED)
sys.exit(code)
