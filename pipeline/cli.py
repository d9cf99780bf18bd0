"""Command line: ``floe-impact run|status|show STUDY`` (= ``python -m pipeline``). It parses, calls one function per
command (the run is pipeline.run.run_study, the table pipeline.report, a case's figure
pipeline.show), and maps what they return or raise to an exit status:
  0   every case ok or ended by the model itself (``layer_bottomed_out``: the layer was
      squeezed flat before the end of the stage; its data up to then is valid);
  1   some cases failed numerically (nonfinite, step_limit, error);
  2   bad input (one line on stderr, nothing written), including an unreachable scheduler;
  74  I/O error: results directory not writable, disk full (finished cases are kept);
  75  the study is locked by another runner;
  130 interrupted (Ctrl-C): finished cases are kept, the same command resumes.
"""
from __future__ import annotations

import argparse
import errno
import os
import signal
import sys
from pathlib import Path

from . import __version__
# only the standard library here: a locked study or a bad command line is refused in well
# under a second; numba, xarray and dask are imported by the commands that need them
from .common.errors import (EXIT_BAD_INPUT, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_IO, EXIT_LOCKED, EXIT_OK,
                            LARGE_STUDY, ResultsIOError, StudyError, free_space, write_failed)
from .common.interrupts import check
from .report import TABLE_ROWS, ledger_states, print_table
from .run import RunOptions, run_study
from .show import ShowError, choose_case, show
from .store.lock import StudyLocked, refuse_if_locked


class _Parser(argparse.ArgumentParser):
    def error(self, message):                       # one line, exit 2, no usage dump
        raise StudyError(message)


def _parser():
    prog = "floe-impact" if Path(sys.argv[0]).name == "floe-impact" else "python -m pipeline"
    ap = _Parser(prog=prog, description="Run floe-impact parameter studies.")
    ap.add_argument("--version", action="version", version=f"floe-impact {__version__}")
    sub = ap.add_subparsers(dest="command", required=True, parser_class=_Parser)
    run = sub.add_parser("run", help="run a study file")
    run.add_argument("study", help="studies/<name>.toml or a study name")
    run.add_argument("--out", help="results directory (default results/<name>)")
    run.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    run.add_argument("--scheduler", default=None,
                     help="address of an existing dask scheduler (default $DASK_SCHEDULER_ADDRESS, "
                          "unless --cluster is given)")
    run.add_argument("--tls-ca-file", help="with --scheduler tls://...: the cluster's CA certificate (PEM)")
    run.add_argument("--tls-cert", help="with --scheduler tls://...: this client's certificate (PEM)")
    run.add_argument("--tls-key", help="with --scheduler tls://...: this client's private key (PEM)")
    run.add_argument("--cluster", choices=["slurm", "pbs"],
                     help="run the workers as jobs of this batch system (dask-jobqueue; floe-impact[hpc]); "
                          "queue, account, memory, walltime from dask's jobqueue configuration")
    run.add_argument("--jobs", type=int, default=0, help="with --cluster: worker jobs kept running")
    run.add_argument("--dry-run", action="store_true",
                     help="print what a run would compute and write; run nothing")
    run.add_argument("--all", action="store_true", help="with --dry-run: list every case to run")
    run.add_argument("--rerun-failed", action="store_true", help="recompute cases that failed before")
    run.add_argument("--yes", action="store_true", help=f"run studies of more than {LARGE_STUDY} cases")
    run.add_argument("--no-plots", action="store_true", help="skip the figures")
    run.add_argument("--force", action="store_true",
                     help="use --out even if it is a non-empty directory that holds no floe-impact results")
    run.add_argument("--batch-seconds", type=float, default=1.0,
                     help="solver time per batch of cases, one file each (default 1 s)")
    status = sub.add_parser("status", help="what a study has done")
    status.add_argument("study", help="a study name, a study file, or a results directory")
    status.add_argument("--out")
    status.add_argument("--all", action="store_true", help=f"list every case (default: the first {TABLE_ROWS})")
    show = sub.add_parser("show", help="draw one case's time series (force, contacts, strain, energy)")
    show.add_argument("study", help="a study name, a study file, or a results directory")
    show.add_argument("--case", help="a case id (or a unique start of one), or key=value,... of the grid")
    show.add_argument("--out", help="results directory (default results/<name>)")
    show.add_argument("--x", type=float, help="position of the strain curve [m] (default: where the "
                                             "largest tension occurred)")
    show.add_argument("--points", type=int, default=400, help="times on the curves (default 400)")
    show.add_argument("--figure", help="where to write the PNG (default <results>/case_<id>.png)")
    return ap


def command_run(args) -> int:
    from .study.study_files import default_results, find_study, load_study
    check()                                           # a Ctrl-C during the imports
    study = load_study(find_study(args.study), max_cases=None if args.yes else LARGE_STUDY)
    check()
    if study.n_cases > LARGE_STUDY and not args.yes:
        raise StudyError(f"the study has {study.n_cases} cases (more than {LARGE_STUDY}); "
                         f"add --yes to run it")
    out_dir = Path(args.out) if args.out else default_results(study)
    tls = (args.tls_ca_file, args.tls_cert, args.tls_key)
    # the environment's scheduler is a default: --cluster, given on the line, chooses the jobs instead
    scheduler = args.scheduler or (None if args.cluster else os.environ.get("DASK_SCHEDULER_ADDRESS") or None)
    options = RunOptions(workers=args.workers, scheduler=scheduler, tls=tls if any(tls) else None,
                         cluster=args.cluster, jobs=args.jobs, batch_seconds=args.batch_seconds,
                         rerun_failed=args.rerun_failed, no_plots=args.no_plots, force=args.force,
                         dry_run=args.dry_run, all=args.all)
    return run_study(study, out_dir, options)


def command_status(args) -> int:
    study, out_dir = study_and_results(args.study, args.out)
    print(f"{study.name}: results in {out_dir}" + ("" if out_dir.is_dir() else " (none yet)"), file=sys.stderr)
    if study.search:                                  # its runs are in out_dir/evaluations
        from .search_runner import search_summary
        print(search_summary(study, out_dir))
        return EXIT_OK
    print_table(study, ledger_states(study, out_dir), all_rows=args.all)
    return EXIT_OK


def command_show(args) -> int:
    from .store.casefile import DamagedFile
    study, out_dir = study_and_results(args.study, args.out)
    if not 2 <= args.points <= 100_000:
        raise StudyError(f"--points must be in 2 .. 100000, got {args.points}")
    try:
        case_id = choose_case(study, args.case)
        figure = Path(args.figure) if args.figure else None
        if figure is None and not out_dir.is_dir():
            raise ShowError(f"no results directory {out_dir}; give --figure FILE to draw a case not run yet")
        _, text = show(study, out_dir, case_id, x=args.x, points=args.points, figure=figure)
    except ShowError as err:
        raise StudyError(str(err)) from None
    except DamagedFile as err:
        raise ResultsIOError(f"the case's batch file failed its checksum ({err}); run the study again to "
                         f"recompute it") from None
    except OSError as err:
        raise write_failed(Path(err.filename) if getattr(err, "filename", None) else out_dir, err) from None
    print(text)
    return EXIT_OK


def study_and_results(name_or_path: str, out: str | None) -> tuple:
    """The study and its results directory, from a study name or file (results/<name> unless
    --out), or from a results directory alone (through the copy of the study a run keeps
    there); a name whose studies/<name>.toml is gone falls back on results/<name>."""
    from .study.study_files import (STUDY_COPY, default_results, find_study, load_study, load_study_copy,
                                    study_copy_name)
    given = Path(name_or_path)
    if given.is_dir():
        if not (given / STUDY_COPY).is_file():
            raise StudyError(f"{given} is not a results directory of a study run by this version "
                             f"(no {STUDY_COPY} in it)")
        return load_study_copy(given), Path(out) if out else given
    try:
        study = load_study(find_study(name_or_path))
    except StudyError:
        fallback = Path(out) if out else Path("results") / given.stem
        if given.suffix or not (fallback / STUDY_COPY).is_file():
            raise
        return load_study_copy(fallback), fallback
    out_dir = Path(out) if out else default_results(study)
    held = study_copy_name(out_dir)
    if held is not None and held != study.name:       # status would list its cases as pending, show draw into it
        raise StudyError(f"{out_dir} holds the results of study {held!r}, not of {study.name!r}: give that "
                         f"study, or the results directory alone")
    return study, out_dir


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv:
        _parser().print_help(sys.stderr)
        print("error: give a command (run, status, show)", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        args = _parser().parse_args(argv)
        if args.command == "run":
            name = Path(args.study).stem
            refuse_if_locked(Path(args.out) if args.out else Path("results") / name)
            return command_run(args)
        if args.command == "show":
            return command_show(args)
        return command_status(args)
    except StudyError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except StudyLocked as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_LOCKED
    except RuntimeError as err:
        from .compute.engine import KernelCompileError
        if not isinstance(err, KernelCompileError):
            raise
        print(f"error: {err}", file=sys.stderr)
        return EXIT_FAILED
    except ResultsIOError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_IO
    except BrokenPipeError:                          # output piped into head, say (before OSError,
        sys.stdout = open(os.devnull, "w")           # which would catch it first)
        return EXIT_OK
    except OSError as err:
        from .store.casefile import CaseWriteError
        if isinstance(err, CaseWriteError):
            print(f"error: {err}; finished cases are kept", file=sys.stderr)
        elif err.errno == errno.ENOSPC or "HDF error" in str(err):
            where = Path(getattr(err, "filename", None) or ".")
            print(f"error: writing results failed ({free_space(where)}): {err}; finished cases are kept",
                  file=sys.stderr)
        else:
            print(f"error: {err.strerror or err} ({getattr(err, 'filename', '') or ''}); finished cases "
                  f"are kept", file=sys.stderr)
        return EXIT_IO
    except KeyboardInterrupt:
        # the run is over: a second SIGINT (seen once in CI, 1.3 s into the start-up) must not
        # kill the shutdown that follows with a signal instead of this exit status
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        print("interrupted: finished cases are kept; run the same command again to resume",
              file=sys.stderr)
        return EXIT_INTERRUPTED
