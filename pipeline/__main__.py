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
sys.exit(code)
