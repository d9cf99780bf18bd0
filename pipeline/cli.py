"""Command line: ``python -m pipeline run STUDY`` and ``python -m pipeline status STUDY``.

The run reads as a straight line: study file -> cases -> workers -> case files -> study.nc ->
diagnostics -> plots. Exit status:
  0   every case ok or ended by the model itself (``layer_bottomed_out``: the layer was
      squeezed flat before the end of the stage; its data up to then is valid);
  1   some cases failed numerically (nonfinite, step_limit, error);
  2   bad input (one line on stderr, nothing written), including an unreachable scheduler;
  74  I/O error: results directory not writable, disk full (finished case files are kept);
  75  the study is locked by another runner;
  130 interrupted (Ctrl-C): finished cases are kept, the same command resumes.
"""
from __future__ import annotations

import argparse
import errno
import os
import shutil
import sys
import time
from pathlib import Path

# only the standard library here: a locked study or a bad command line is refused in well
# under a second; numba, xarray and dask are imported by the commands that need them
from .errors import LARGE_STUDY, StudyError
from .lock import StudyLock, StudyLocked, refuse_if_locked


class _IOProblem(Exception):
    """Reading or writing results failed (permissions, full disk): exit 74."""


EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_IO, EXIT_LOCKED, EXIT_INTERRUPTED = 0, 1, 2, 74, 75, 130


class _Parser(argparse.ArgumentParser):
    def error(self, message):                       # one line, exit 2, no usage dump
        raise StudyError(message)


def _parser():
    ap = _Parser(prog="python -m pipeline", description="Run floe-impact parameter studies.")
    sub = ap.add_subparsers(dest="command", required=True, parser_class=_Parser)
    run = sub.add_parser("run", help="run a study file")
    run.add_argument("study", help="studies/<name>.toml or a study name")
    run.add_argument("--out", help="results directory (default results/<name>)")
    run.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    run.add_argument("--scheduler", default=os.environ.get("DASK_SCHEDULER_ADDRESS"),
                     help="address of an existing dask scheduler (default $DASK_SCHEDULER_ADDRESS)")
    run.add_argument("--dry-run", action="store_true", help="print the cases and what is done; run nothing")
    run.add_argument("--rerun-failed", action="store_true", help="recompute cases that failed before")
    run.add_argument("--yes", action="store_true", help=f"run studies of more than {LARGE_STUDY} cases")
    run.add_argument("--no-plots", action="store_true", help="skip the figures")
    status = sub.add_parser("status", help="what a study has done")
    status.add_argument("study")
    status.add_argument("--out")
    return ap


def case_states(study, out_dir: Path) -> dict:
    """case_id -> 'ok' | failed status | 'pending' | 'corrupt' from the files on disk."""
    from .casefile import case_path, read_case
    states = {}
    for case in study.all_cases():
        path = case_path(out_dir / "cases", case.case_id)
        if not path.exists():
            states[case.case_id] = "pending"
            continue
        ds = read_case(path, case)
        states[case.case_id] = "corrupt" if ds is None else str(ds["status"].values[0])
    return states


def print_table(study, states: dict, stream=sys.stdout) -> None:
    from solver import PARAMETER_INFO, SETTING_INFO
    runs = study.all_cases()
    keys = study.dims if study.grid else [k for k in [*PARAMETER_INFO, *SETTING_INFO]
                                          if len({c.value(k) for c in runs}) > 1]
    header = ["case_id", *keys, "state", "role"]
    rows = []
    for case in runs:
        role = "reference" if study.is_reference(case) else "case"
        rows.append([case.case_id, *(_fmt(case.value(k)) for k in keys), states[case.case_id], role])
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    for r in [header, *rows]:
        stream.write("  ".join(str(v).ljust(w) for v, w in zip(r, widths)).rstrip() + "\n")
    counts = {}
    for s in states.values():
        counts[s] = counts.get(s, 0) + 1
    summary = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    stream.write(f"{study.name}: {_count(study)}: {summary}\n")


def _count(study) -> str:
    """'N cases' with the distinct runs and reference runs where they differ."""
    runs = study.all_cases()
    n_ref = sum(1 for r in runs if study.is_reference(r))
    distinct = len(runs) - n_ref
    text = f"{len(study.cases)} cases"
    if distinct != len(study.cases):
        text += f" ({distinct} distinct runs)"
    if n_ref:
        text += f" and {n_ref} reference runs"
    return text


def _fmt(value) -> str:
    return value if isinstance(value, str) else f"{value:g}"


def _label(study, case) -> str:
    if study.is_reference(case):
        return "reference run"
    keys = study.dims if study.grid else [k for k in study.case_list[case.index[0]] if k not in ("reference", "group")]
    return ", ".join(f"{k}={_fmt(case.value(k))}" for k in keys) or f"case {case.index[0]}"


def _prepare_dirs(out_dir: Path) -> Path:
    cases_dir = out_dir / "cases"
    cases_dir.mkdir(parents=True, exist_ok=True)
    for stale in [*cases_dir.glob(".*.nc.tmp-*"), *out_dir.glob(".study.nc.tmp-*"),
                  *out_dir.glob(".study.nc.inputs.tmp-*")]:                        # killed writers
        stale.unlink(missing_ok=True)
    return cases_dir


def command_run(args) -> int:
    from .study import find_study, load_study
    study = load_study(find_study(args.study))
    if args.workers < 1:
        raise StudyError(f"--workers must be >= 1, got {args.workers}")
    if len(study.cases) > LARGE_STUDY and not args.yes:
        raise StudyError(f"the study has {len(study.cases)} cases (more than {LARGE_STUDY}); "
                         f"add --yes to run it")
    out_dir = Path(args.out) if args.out else Path("results") / study.name
    if args.scheduler:                                 # unreachable: bad input, refused before writing
        from .engine import probe_scheduler
        probe_scheduler(args.scheduler)
    if args.dry_run:
        states = case_states(study, out_dir) if out_dir.exists() else {c.case_id: "pending" for c in study.all_cases()}
        print_table(study, states)
        return EXIT_OK
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        lock = StudyLock(out_dir)
        lock.__enter__()
    except OSError as err:
        raise _IOProblem(f"cannot use the results directory {out_dir}: {err.strerror or err}") from None
    try:
        return _run_locked(args, study, out_dir)
    finally:
        lock.__exit__()


def _run_locked(args, study, out_dir: Path) -> int:
    from .casefile import FAILED, NUMERICAL_FAILURES, case_path, read_case
    cases_dir = _prepare_dirs(out_dir)
    everything = study.all_cases()
    states = case_states(study, out_dir)
    for case in everything:                            # set aside, never delete, a corrupt file
        if states[case.case_id] == "corrupt":
            path = case_path(cases_dir, case.case_id)
            aside = path.with_name(f"{path.name}.corrupt-{time.strftime('%Y%m%dT%H%M%S')}")
            path.rename(aside)
            print(f"note: case file {path.name} is not valid; moved to {aside.name} and recomputed",
                  file=sys.stderr)
            states[case.case_id] = "pending"
    todo = [c for c in everything
            if states[c.case_id] == "pending" or (args.rerun_failed and states[c.case_id] in FAILED)]
    past = sum(1 for c in study.cases if c.times_seconds()[-1] > c.t_end * (1 + 1e-12))
    if past:
        print(f"note: {past} of {len(study.cases)} cases have output times past their impact stage "
              f"L^2/(6RV); those times are not integrated and stay NaN", file=sys.stderr)
    from .engine import Progress, run_pending           # dask only when there is work
    skipped = len(everything) - len(todo)
    print(f"{study.name}: {_count(study)}, {len(todo)} to run, {skipped} already done "
          f"-> {out_dir}", file=sys.stderr)
    records = run_pending(todo, cases_dir, workers=args.workers, scheduler=args.scheduler,
                          progress=Progress(len(everything), skipped))
    for record in records:
        states[record["case_id"]] = record["status"]
    from .combine import inputs_fingerprint, is_up_to_date, write_study
    fingerprint = inputs_fingerprint(study, out_dir)
    path = out_dir / "study.nc"
    fresh = bool(records) or not is_up_to_date(study, out_dir, fingerprint)
    if fresh:
        write_study(study, out_dir, fingerprint)
        print(f"wrote {path}", file=sys.stderr)
    else:                                              # a rerun with nothing new rewrites nothing
        print(f"nothing new: {path} is up to date", file=sys.stderr)
    from .plots import PLOT_FILES
    figures = [out_dir / f for kind in study.plots for f in PLOT_FILES[kind]]
    if not args.no_plots and (fresh or not all(f.exists() for f in figures)):
        import xarray as xr

        from .plots import make_plots
        with xr.open_dataset(path) as ds:
            written, notes = make_plots(ds.load(), study.dims, study.plots, out_dir)
        for p in written:
            print(f"wrote {p}", file=sys.stderr)
        for note in notes:
            print(f"note: {note}", file=sys.stderr)
    not_ok = [c for c in everything if states[c.case_id] != "ok"]
    if not_ok:
        print(f"{len(not_ok)} of {len(everything)} cases did not end ok:", file=sys.stderr)
        for case in not_ok[:30]:
            ds = read_case(case_path(cases_dir, case.case_id), case)
            msg = str(ds["message"].values[0]) if ds is not None else "no valid case file"
            print(f"  {case.case_id} ({_label(study, case)}): {states[case.case_id]}: {msg}", file=sys.stderr)
        if len(not_ok) > 30:
            print(f"  ... and {len(not_ok) - 30} more (python -m pipeline status {study.name})", file=sys.stderr)
    if any(states[c.case_id] in NUMERICAL_FAILURES or states[c.case_id] == "pending" for c in everything):
        return EXIT_FAILED
    return EXIT_OK


def command_status(args) -> int:
    from .study import find_study, load_study
    study = load_study(find_study(args.study))
    out_dir = Path(args.out) if args.out else Path("results") / study.name
    states = case_states(study, out_dir) if out_dir.exists() else {c.case_id: "pending" for c in study.all_cases()}
    print_table(study, states)
    return EXIT_OK


def main(argv=None) -> int:
    try:
        args = _parser().parse_args(argv)
        if args.command == "run":
            name = Path(args.study).stem
            refuse_if_locked(Path(args.out) if args.out else Path("results") / name)
            return command_run(args)
        return command_status(args)
    except StudyError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except StudyLocked as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_LOCKED
    except _IOProblem as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_IO
    except OSError as err:
        from .casefile import CaseWriteError
        if isinstance(err, CaseWriteError):
            print(f"error: {err}; finished case files are kept", file=sys.stderr)
        elif err.errno == errno.ENOSPC or "HDF error" in str(err):
            print(f"error: writing results failed (disk full? {shutil.disk_usage('.').free // 2**20} MiB free): "
                  f"{err}; finished case files are kept", file=sys.stderr)
        else:
            print(f"error: {err.strerror or err} ({getattr(err, 'filename', '') or ''}); finished case "
                  f"files are kept", file=sys.stderr)
        return EXIT_IO
    except BrokenPipeError:                          # output piped into head, say
        sys.stdout = open(os.devnull, "w")
        return EXIT_OK
    except KeyboardInterrupt:
        print("interrupted: finished cases are kept; run the same command again to resume",
              file=sys.stderr)
        return EXIT_INTERRUPTED
