import sys

try:
    from .cli import main
except KeyboardInterrupt:                        # Ctrl-C while Python imports the runner
    print("interrupted: nothing was started", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
