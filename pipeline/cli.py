"""Command line: ``python -m pipeline run STUDY`` and ``python -m pipeline status STUDY``.

The run reads as a straight line: study file -> cases -> workers (in batches) -> batch files + ledger -> study.nc ->
diagnostics -> plots. Exit status:
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
import shutil
import signal
import sys
import time
from pathlib import Path

# only the standard library here: a locked study or a bad command line is refused in well
# under a second; numba, xarray and dask are imported by the commands that need them
from .errors import LARGE_STUDY, StudyError
from .lock import StudyLock, StudyLocked, refuse_if_locked


class _IOProblem(Exception):
    """Reading or writing results failed (permissions, full disk): exit 74."""


def _free_space(path: Path) -> str:
    """The free space of the filesystem that holds path (or its nearest existing parent)."""
    path = Path(path).absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    try:
        return f"{shutil.disk_usage(path).free // 2**20} MiB free on its filesystem"
    except OSError:
        return "free space unknown"


def _write_failed(what: Path, err: BaseException) -> "_IOProblem":
    detail = getattr(err, "strerror", None) or str(err) or type(err).__name__
    return _IOProblem(f"cannot write {what} ({_free_space(Path(what).parent)}): {detail}; finished cases are kept")


EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_IO, EXIT_LOCKED, EXIT_INTERRUPTED = 0, 1, 2, 74, 75, 130


class _Parser(argparse.ArgumentParser):
    def error(self, message):                       # one line, exit 2, no usage dump
        raise StudyError(message)


def _parser():
    ap = _Parser(prog="python -m pipeline", description="Run floe-impact parameter studies.")
    from . import __version__
    ap.add_argument("--version", action="version", version=f"floe-impact {__version__}")
    sub = ap.add_subparsers(dest="command", required=True, parser_class=_Parser)
    run = sub.add_parser("run", help="run a study file")
    run.add_argument("study", help="studies/<name>.toml or a study name")
    run.add_argument("--out", help="results directory (default results/<name>)")
    run.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    run.add_argument("--scheduler", default=os.environ.get("DASK_SCHEDULER_ADDRESS"),
                     help="address of an existing dask scheduler (default $DASK_SCHEDULER_ADDRESS)")
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


def ledger_states(study, out_dir: Path, ledger=None) -> dict:
    """case_id -> 'ok' | failed status | 'pending', from the study's ledger alone (no result
    file is opened)."""
    from .ledger import Ledger
    ledger = ledger if ledger is not None else Ledger.load(out_dir)
    recorded = ledger.states()
    return {cid: recorded.get(cid, "pending") for cid in study.run_ids}


#: the case table lists at most this many rows unless --all
TABLE_ROWS = 200


def _row_values(study, cid: str, flat: int | None, keys: list) -> list:
    if flat is not None and study.grid:
        import numpy as np
        idx = np.unravel_index(flat, study.shape)
        return [_fmt(study.grid[k][int(j)]) for k, j in zip(keys, idx)]
    case = study.run(cid)
    return [_fmt(case.value(k)) for k in keys]


def print_table(study, states: dict, stream=sys.stdout, all_rows: bool = False, only=None,
                summary: bool = True) -> None:
    """The case table (case_id, the keys that vary, state, and a role column when the study
    has reference runs) and a one-line summary. only: the run ids to list (default all)."""
    keys = study.varying_keys
    first = study.first_position
    with_role = len(study.run_ids) > len(study.case_id_set)
    header = ["case_id", *keys, "state", *(["role"] if with_role else [])]
    listed = study.run_ids if only is None else only
    ids = listed if all_rows else listed[:TABLE_ROWS]
    rows = []
    for cid in ids:
        flat = first.get(cid)
        role = ["reference" if flat is None else "case"] if with_role else []
        rows.append([cid, *_row_values(study, cid, flat, keys), states[cid], *role])
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    for r in [header, *rows]:
        stream.write("  ".join(str(v).ljust(w) for v, w in zip(r, widths)).rstrip() + "\n")
    if len(ids) < len(listed):
        stream.write(f"... {len(listed) - len(ids)} more rows (--all lists them)\n")
    if with_role:
        stream.write("role: case = a point of the study; reference = a converged run ([reference]) that "
                     "the cases' errors are measured against\n")
    if summary:
        counts = {}
        for s in states.values():
            counts[s] = counts.get(s, 0) + 1
        text = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
        stream.write(f"{study.name}: {_count(study)}: {text}\n")


def _count(study) -> str:
    """'N cases' with the distinct runs and reference runs where they differ."""
    n_ref = len(study.run_ids) - len(study.case_id_set)
    distinct = len(study.case_id_set)
    text = f"{study.n_cases} cases"
    if distinct != study.n_cases:
        text += f" ({distinct} distinct runs)"
    if n_ref:
        text += f" and {n_ref} reference runs"
    return text


def _fmt(value) -> str:
    return value if isinstance(value, str) else f"{value:g}"


def _label(study, cid: str) -> str:
    if cid not in study.case_id_set:
        return "reference run"
    flat = study.first_position[cid]
    keys = list(study.grid) if study.grid else [k for k in study.case_list[flat] if k not in ("reference", "group")]
    return ", ".join(f"{k}={v}" for k, v in zip(keys, _row_values(study, cid, flat, keys))) or f"case {flat}"


def _prepare_dirs(out_dir: Path) -> Path:
    from .ledger import BATCHES, LEDGER
    batches = out_dir / BATCHES
    batches.mkdir(parents=True, exist_ok=True)
    for stale in [*batches.glob(".batch.nc.tmp-*"), *out_dir.glob(".study.nc.tmp-*"),
                  *out_dir.glob(".study.nc.inputs.tmp-*"), *out_dir.glob(f".{LEDGER}.tmp-*"),
                  *out_dir.glob(".study.toml.tmp-*")]:
        if stale.is_file() and not stale.is_symlink():     # killed writers
            stale.unlink(missing_ok=True)
    return batches


def command_run(args) -> int:
    from .interrupts import check
    from .study import find_study, load_study
    check()                                           # a Ctrl-C during the imports
    study = load_study(find_study(args.study))
    check()
    if args.workers < 1:
        raise StudyError(f"--workers must be >= 1, got {args.workers}")
    if not 0.0 < args.batch_seconds <= 3600.0:
        raise StudyError(f"--batch-seconds must be in (0, 3600], got {args.batch_seconds}")
    if study.n_cases > LARGE_STUDY and not args.yes:
        raise StudyError(f"the study has {study.n_cases} cases (more than {LARGE_STUDY}); "
                         f"add --yes to run it")
    out_dir = Path(args.out) if args.out else Path("results") / study.name
    if args.scheduler:                                 # unreachable: bad input, refused before writing
        from .engine import probe_scheduler
        probe_scheduler(args.scheduler)
    if args.dry_run:
        return _dry_run(study, out_dir, args.all, args.rerun_failed)
    _refuse_foreign_directory(out_dir, args.force)
    _refuse_what_cannot_fit(study, out_dir)
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


#: what makes a directory a floe-impact results directory
RESULTS_MARKERS = {"ledger.jsonl", "batches", ".lock"}


def _dry_run(study, out_dir: Path, all_rows: bool, rerun_failed: bool) -> int:
    """What a run would do: the cases it would compute, what is done, and the output size."""
    states = ledger_states(study, out_dir)
    items, _ = _todo(study, states, rerun_failed)
    todo = [cid for cid, _ in items]
    from .casefile import FAILED
    failed = sum(1 for cid in study.run_ids if states[cid] in FAILED) if not rerun_failed else 0
    print(f"{study.name}: {_count(study)}, {len(todo)} to run, {len(study.run_ids) - len(todo)} already done "
          f"-> {out_dir}")
    if todo:
        print(f"would run ({len(todo)}):")
        print_table(study, states, all_rows=all_rows, only=todo, summary=False)
    memory, disk = output_size(study)
    print(f"estimated output: {_size(disk * len(todo) / max(len(study.run_ids), 1))} to write for these "
          f"(batch files and study.nc), {_size(disk)} for the whole study; {_size(memory)} of worker memory "
          f"per case")
    if failed:
        print(f"{failed} case(s) failed before and are not run again (--rerun-failed runs them)")
    print("nothing was run (--dry-run)")
    return EXIT_OK


def _size(n: float) -> str:
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n:.0f} B"


def _refuse_foreign_directory(out_dir: Path, force: bool) -> None:
    """--out must be new, empty, or a results directory: the runner writes study.nc, figures
    and a lock there, and would overwrite files of the same names."""
    if out_dir.is_symlink() and not out_dir.exists():
        raise _IOProblem(f"cannot use the results directory {out_dir}: it is a symbolic link to "
                         f"{os.readlink(out_dir)}, which does not exist")
    if force or not out_dir.exists():
        return
    if not out_dir.is_dir():
        raise _IOProblem(f"cannot use the results directory {out_dir}: it is not a directory")
    try:
        entries = {p.name for p in out_dir.iterdir()}
    except OSError as err:
        raise _IOProblem(f"cannot use the results directory {out_dir}: {err.strerror or err}") from None
    if entries and not entries & RESULTS_MARKERS:
        raise StudyError(f"--out {out_dir} is a non-empty directory that holds no floe-impact results "
                         f"({len(entries)} entries); give a new or empty directory, or add --force")


#: bytes a case stores besides its fields: series, diagnostics, and the event records
#: (measured: 800-3100 record nodes of 5 doubles per surface; 50 kB is the high end)
CASE_OVERHEAD = 50_000


def output_size(study) -> tuple:
    """(bytes one case holds in a worker's memory, bytes the study writes to disk), estimated
    from the output request: each field is times x x_points doubles."""
    times = study.case(0).requested_times().size
    fields = len(study.output["fields"]) * times * study.output["x_points"] * 8
    per_case = fields + 3 * times * 8 + CASE_OVERHEAD
    memory = 4 * fields + CASE_OVERHEAD                   # the solver's, the case's and the batch's copies
    disk = 2 * per_case * len(study.run_ids)              # batch files and study.nc
    return memory, disk


def _refuse_what_cannot_fit(study, out_dir: Path) -> None:
    memory, disk = output_size(study)
    total_memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if memory > total_memory / 4:
        raise StudyError(f"one case's output needs about {memory / 2**30:.1f} GiB of memory ([output] fields x "
                         f"times x x_points), more than a quarter of this machine's {total_memory / 2**30:.0f} GiB; "
                         f"ask for fewer fields, times or x_points")
    if (out_dir / "ledger.jsonl").exists():               # a resume: much of it is written already
        return
    base = out_dir.absolute()
    while not base.exists() and base != base.parent:
        base = base.parent
    free = shutil.disk_usage(base).free
    if disk > free:
        raise StudyError(f"the study would write about {disk / 2**30:.1f} GiB, more than the "
                         f"{free / 2**30:.1f} GiB free under {base}; ask for fewer fields, times or x_points")


def _identity(out_dir: Path) -> tuple:
    st = os.stat(out_dir)
    return st.st_dev, st.st_ino


def _still_ours(out_dir: Path, identity: tuple) -> None:
    """Stop if the results directory was removed (make clean) or replaced during the run: its
    lock went with it, and another runner may now be using a new directory of that name."""
    try:
        same = _identity(out_dir) == identity
    except FileNotFoundError:
        same = False
    if not same:
        raise _IOProblem(f"the results directory {out_dir} was removed or replaced during the run; "
                         f"stopping (run the same command again to start over)")


def _todo(study, states: dict, rerun_failed: bool) -> tuple:
    """The runs to compute as (items [case_id, position or -1], signatures)."""
    from .casefile import FAILED
    first = study.first_position
    items, signature = [], []
    for cid in study.run_ids:
        if states[cid] == "pending" or (rerun_failed and states[cid] in FAILED):
            position = first.get(cid, -1)
            items.append([cid, position])
            signature.append(0 if position >= 0 else 1)
    return items, signature


def _run_locked(args, study, out_dir: Path) -> int:
    from .casefile import NUMERICAL_FAILURES
    from .interrupts import check
    from .ledger import reconcile
    batches = _prepare_dirs(out_dir)
    from .study import keep_study_copy
    keep_study_copy(study, out_dir)
    notes = []
    ledger = reconcile(out_dir, notes)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    states = ledger_states(study, out_dir, ledger)
    items, signature = _todo(study, states, args.rerun_failed)
    from .study import cases_past_their_stage
    past = cases_past_their_stage(study)
    if past:
        print(f"note: {past} of {study.n_cases} cases have output times past their impact stage "
              f"(b_mean/V: L^2/(6RV) for the paper's parabola); those times are not integrated and stay NaN",
              file=sys.stderr)
    skipped = len(study.run_ids) - len(items)
    print(f"{study.name}: {_count(study)}, {len(items)} to run, {skipped} already done "
          f"-> {out_dir}", file=sys.stderr)
    if items and study.n_cases > 1000 and "error_estimate" not in study.solver and "error_estimate" not in study.grid:
        print("note: every case also runs the error estimate's companion (0.79x the integration, measured); "
              "[solver] error_estimate = \"sample\" runs it on about 1 case in 10", file=sys.stderr)
    from .session import Session
    from .combine import open_writer, stream_spec
    items_run = list(items)
    identity = _identity(out_dir)
    with Session(args.workers, args.scheduler) as session:
        for attempt in range(3):
            writer = None
            try:
                if items:
                    # each batch's slice of study.nc comes back with its ledger entry and goes
                    # into study.nc at once; the combine then reads only older batch files
                    spec = stream_spec(study)

                    def on_batch(entry, batch):
                        nonlocal writer
                        reduced = entry.pop("reduced", None)
                        _still_ours(out_dir, identity)
                        try:
                            ledger.append(entry)
                        except OSError as err:
                            raise _write_failed(ledger.path, err) from None
                        for cid, status, _, _ in entry["cases"]:
                            states[cid] = status
                        if reduced is not None:
                            writer = writer or open_writer(study, out_dir)
                            writer.write([position for _, position in batch], reduced)
                    try:
                        lost = session.run(study, items, signature, batches, on_batch, len(study.run_ids),
                                           skipped, args.batch_seconds, spec)
                    except OSError:
                        _still_ours(out_dir, identity)   # a batch write failing because the directory went
                        raise
                    for record in lost:
                        print(f"note: case {record['case_id']}: {record['message']} (it stays pending)",
                              file=sys.stderr)
                check()
                fresh = _combine(args, study, out_dir, ledger, states, session, bool(items), writer)
            except BaseException:
                if writer is not None:
                    writer.abandon()
                raise
            if fresh is not None:                      # done: no damaged batch file
                break
            states = ledger_states(study, out_dir, ledger)
            items, signature = _todo(study, states, False)
            items_run += items
            skipped = len(study.run_ids) - len(items)
        else:
            raise _IOProblem("batch files keep failing their checksums; is the disk healthy?")
    _plots(args, study, out_dir, fresh)
    _summary(study, ledger, states, computed={cid for cid, _ in items_run})
    if any(states[cid] in NUMERICAL_FAILURES or states[cid] == "pending" for cid in study.run_ids):
        return EXIT_FAILED
    return EXIT_OK


def _combine(args, study, out_dir: Path, ledger, states: dict, session, computed: bool, writer=None):
    """Write study.nc if its inputs changed; True if written, False if up to date, None if a
    damaged batch file was found (set aside and dropped from the ledger)."""
    from .ledger import inputs_fingerprint, is_up_to_date, set_aside
    index = ledger.index()
    fingerprint = inputs_fingerprint(study, index)
    path = out_dir / "study.nc"
    if not computed and is_up_to_date(out_dir, fingerprint):
        print(f"nothing new: {path} is up to date", file=sys.stderr)
        return False
    streamed = writer.seen if writer is not None else None
    n_files = len({index[cid][0]["file"] for i, cid in enumerate(study.case_ids)
                   if cid in index and (streamed is None or not streamed[i])})
    from .combine import write_study
    mapper = session.mapper() if session.is_open or n_files > 50 else None
    started = time.monotonic()
    try:
        written, damaged = write_study(study, out_dir, index, states, mapper, fingerprint, writer)
    except (OSError, RuntimeError) as err:          # netCDF reports a full disk as "HDF error"
        raise _write_failed(path, err) from None
    if damaged:
        for name in damaged:
            victim = out_dir / "batches" / name
            if victim.exists():
                aside = set_aside(victim)
                print(f"note: batch file {name} failed its checksum; moved to {aside.name}; its cases are "
                      f"computed again", file=sys.stderr)
            ledger.drop(name)
        try:
            ledger.rewrite()
        except OSError as err:
            raise _write_failed(ledger.path, err) from None
        return None
    print(f"wrote {written} ({time.monotonic() - started:.1f} s)", file=sys.stderr)
    return True


def _plots(args, study, out_dir: Path, fresh: bool) -> None:
    from .study import PLOT_FILES
    figures = [out_dir / f for kind in study.plots for f in PLOT_FILES[kind]]
    if args.no_plots or not (fresh or not all(f.exists() for f in figures)):
        return
    import xarray as xr

    from .casefile import file_sha256
    from .ledger import sidecar
    from .plots import make_plots
    path = out_dir / "study.nc"
    record = sidecar(out_dir)
    if not record or record.get("sha256") != file_sha256(path):
        print(f"note: {path} does not match its checksum; run again to rebuild it", file=sys.stderr)
        return
    try:
        with xr.open_dataset(path) as ds:
            written, notes = make_plots(ds, study.dims, study.plots, out_dir)
    except OSError as err:
        raise _write_failed(Path(err.filename) if getattr(err, "filename", None) else out_dir / "figures", err) from None
    for p in written:
        print(f"wrote {p}", file=sys.stderr)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)


def _summary(study, ledger, states: dict, computed: set) -> None:
    """The cases that did not end ok: listed (30 at most) when this run computed them, one
    line when they are old news (status lists them)."""
    index = ledger.index()
    from .casefile import COMPLETE
    not_ok = [cid for cid in study.run_ids if states[cid] not in COMPLETE]
    if not not_ok:
        return
    new = [cid for cid in not_ok if cid in computed]
    if not new:
        print(f"{len(not_ok)} of {len(study.run_ids)} cases did not end ok, as before "
              f"(python -m pipeline status {study.path} lists them)", file=sys.stderr)
        return
    print(f"{len(not_ok)} of {len(study.run_ids)} cases did not end ok ({len(new)} computed in this run):",
          file=sys.stderr)
    for cid in new[:30]:
        entry = index.get(cid)
        msg = entry[0]["cases"][entry[1]][2] if entry else "no result yet"
        print(f"  {cid} ({_label(study, cid)}): {states[cid]}: {msg}", file=sys.stderr)
    if len(new) > 30:
        print(f"  ... and {len(new) - 30} more (python -m pipeline status {study.path})", file=sys.stderr)


def command_status(args) -> int:
    study, out_dir = study_and_results(args.study, args.out)
    print_table(study, ledger_states(study, out_dir), all_rows=args.all)
    return EXIT_OK


def command_show(args) -> int:
    from .casefile import DamagedFile
    from .show import ShowError, choose_case, show
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
        raise _IOProblem(f"the case's batch file failed its checksum ({err}); run the study again to "
                         f"recompute it") from None
    except OSError as err:
        raise _write_failed(Path(err.filename) if getattr(err, "filename", None) else out_dir, err) from None
    print(text)
    return EXIT_OK


def study_and_results(name_or_path: str, out: str | None) -> tuple:
    """The study and its results directory, from a study name or file (results/<name> unless
    --out), or from a results directory alone (through the copy of the study a run keeps
    there); a name whose studies/<name>.toml is gone falls back on results/<name>."""
    from .study import STUDY_COPY, find_study, load_study, load_study_copy
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
    return study, Path(out) if out else Path("results") / study.name


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
        from .engine import KernelCompileError
        if not isinstance(err, KernelCompileError):
            raise
        print(f"error: {err}", file=sys.stderr)
        return EXIT_FAILED
    except _IOProblem as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_IO
    except BrokenPipeError:                          # output piped into head, say (before OSError,
        sys.stdout = open(os.devnull, "w")           # which would catch it first)
        return EXIT_OK
    except OSError as err:
        from .casefile import CaseWriteError
        if isinstance(err, CaseWriteError):
            print(f"error: {err}; finished cases are kept", file=sys.stderr)
        elif err.errno == errno.ENOSPC or "HDF error" in str(err):
            where = Path(getattr(err, "filename", None) or ".")
            print(f"error: writing results failed ({_free_space(where)}): {err}; finished cases are kept",
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
