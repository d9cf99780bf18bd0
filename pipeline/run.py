"""A study's run, in the order it happens (study file -> cases -> workers -> batch files + ledger
-> study.nc -> figures -> report): plan the cases still to compute, compute them on dask workers
while each batch's slice streams into study.nc, combine, draw the figures, and report the cases
that did not end ok. :func:`run_study` is the whole of it; ``python -m pipeline run`` parses its
command line into :class:`RunOptions` and maps what it returns or raises to an exit status.
"""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import ssl
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from .common.errors import EXIT_FAILED, EXIT_OK, ResultsIOError, StudyError, WriteFailed, write_failed
from .common.interrupts import check
from .compute import batch_system
from .compute.session import jobs_directory, session_for
from .figures import KINDS, make_plots
from .report import case_label, ledger_states, print_table, study_size, what_a_case_computes
from .store.ledger import BATCHES, LEDGER, Ledger, inputs_fingerprint, is_up_to_date, reconcile, set_aside, sidecar
from .store.lock import StudyLock


@dataclass
class RunOptions:
    """How to run a study (the command line's options, by the same names)."""

    workers: int = 2                 # local worker processes
    scheduler: str | None = None     # address of an existing dask scheduler (then no local workers)
    tls: tuple | None = None         # (CA file, certificate, key) for a tls:// scheduler
    cluster: str | None = None       # a batch system ("slurm", "pbs") whose jobs are the workers
    jobs: int = 0                    # with cluster: worker jobs kept running
    batch_seconds: float = 1.0       # solver time per batch of cases, one file each
    rerun_failed: bool = False       # compute again the cases that failed before
    no_plots: bool = False           # skip the figures
    force: bool = False              # use an output directory that holds something else
    dry_run: bool = False            # say what a run would do; run nothing
    all: bool = False                # with dry_run: list every case to run


def run_study(study, out_dir: Path, options: RunOptions | None = None, session=None) -> int:
    """Run a loaded study into out_dir: EXIT_OK when every case is ok or ended by the model itself,
    EXIT_FAILED when some failed numerically. Raises StudyError (bad input, before anything is
    written), ResultsIOError (the results cannot be written; finished cases are kept),
    StudyLocked, KeyboardInterrupt (finished cases are kept; the same call resumes). ``session``:
    an open pipeline.compute.session.Session to run on (a search's rounds share one; default a new one)."""
    options = options or RunOptions()
    if options.workers < 1:
        raise StudyError(f"--workers must be >= 1, got {options.workers}")
    if not 0.0 < options.batch_seconds <= 3600.0:
        raise StudyError(f"--batch-seconds must be in (0, 3600], got {options.batch_seconds}")
    out_dir = Path(out_dir)
    _check_placement(options, out_dir)                 # unreachable: bad input, refused before writing
    if session is None:                                # not a search's round: said once, by the search
        from .study.consistency import validity_warnings
        for line in validity_warnings(study):
            print(line, file=sys.stderr)
    if options.dry_run:
        if study.search:
            from .search_runner import search_summary
            print(search_summary(study, out_dir))
            print("nothing was run (--dry-run)")
            return EXIT_OK
        return _dry_run(study, out_dir, options.all, options.rerun_failed)
    _refuse_foreign_directory(out_dir, options.force)
    _refuse_what_cannot_fit(study, out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        lock = StudyLock(out_dir)
        lock.__enter__()
    except OSError as err:
        raise ResultsIOError(f"cannot use the results directory {out_dir}: {err.strerror or err}") from None
    try:
        if study.search:                               # rounds of runs in out_dir/evaluations
            from .search_runner import run_search
            from .study.study_files import keep_study_copy
            keep_study_copy(study, out_dir)
            return run_search(study, out_dir, options, run_study)
        return _run_locked(options, study, out_dir, session)
    finally:
        lock.__exit__()


def _check_tls_files(ca_file, cert, key) -> None:
    """The three TLS files exist, are files, and hold a CA certificate and a certificate with
    its private key (each refused in one line naming the file, before any connection)."""
    for flag, path in (("--tls-ca-file", ca_file), ("--tls-cert", cert), ("--tls-key", key)):
        path = Path(path)
        if not path.exists():
            raise StudyError(f"{flag} {path} does not exist")
        if not path.is_file():
            raise StudyError(f"{flag} {path} is not a file")
        if not os.access(path, os.R_OK):
            raise StudyError(f"{flag} {path} cannot be read")
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    try:
        context.load_verify_locations(cafile=str(ca_file))
    except (ssl.SSLError, ValueError) as err:
        raise StudyError(f"--tls-ca-file {ca_file} holds no CA certificate (PEM): {getattr(err, 'reason', None) or err}") from None
    try:
        context.load_cert_chain(str(cert), str(key))
    except (ssl.SSLError, ValueError) as err:
        raise StudyError(f"--tls-cert {cert} and --tls-key {key} are not a certificate and its private key (PEM): "
                         f"{getattr(err, 'reason', None) or err}") from None


def _check_placement(options, out_dir: Path) -> None:
    """Where the workers run: an existing scheduler, a batch system's jobs, or local processes;
    a wrong or unreachable one is refused before anything is written (StudyError)."""
    if options.cluster and options.scheduler:
        raise StudyError("give --cluster or --scheduler, not both")
    if options.tls:
        if not options.scheduler:
            raise StudyError("--tls-ca-file, --tls-cert and --tls-key are for --scheduler tls://...")
        if len(options.tls) != 3 or not all(options.tls):
            raise StudyError("give all three of --tls-ca-file, --tls-cert and --tls-key")
        _check_tls_files(*options.tls)
    if options.scheduler:
        from .compute.engine import probe_scheduler
        probe_scheduler(options.scheduler, tls=options.tls)
    elif options.cluster:
        if not 1 <= options.jobs <= 10_000:
            raise StudyError(f"--cluster needs --jobs N (worker jobs, 1 .. 10000), got {options.jobs}")
        batch_system.check(options.cluster, jobs_directory(out_dir))
    elif options.jobs:
        raise StudyError("--jobs is for --cluster slurm|pbs")


def _prepare_dirs(out_dir: Path) -> Path:
    batches = out_dir / BATCHES
    batches.mkdir(parents=True, exist_ok=True)
    _remove_temporaries([*batches.glob(".batch.nc.tmp-*"), *out_dir.glob(".study.nc.tmp-*"),
                         *out_dir.glob(".study.nc.inputs.tmp-*"), *out_dir.glob(f".{LEDGER}.tmp-*"),
                         *out_dir.glob(".study.toml.tmp-*")])
    return batches


def _remove_temporaries(paths) -> None:
    """Remove the temporary files of killed writers (the runner holds the study's lock)."""
    for stale in paths:
        if stale.is_file() and not stale.is_symlink():
            stale.unlink(missing_ok=True)


#: what makes a directory a floe-impact results directory
RESULTS_MARKERS = {"ledger.jsonl", "batches", ".lock"}


def _dry_run(study, out_dir: Path, all_rows: bool, rerun_failed: bool) -> int:
    """What a run would do: the cases it would compute, what is done, and the output size."""
    ledger = Ledger.load(out_dir)
    states = ledger_states(study, out_dir, ledger)
    items, _ = _todo(study, states, rerun_failed)
    todo = [cid for cid, _ in items]
    from .common.tables import FAILED
    failed = sum(1 for cid in study.run_ids if states[cid] in FAILED) if not rerun_failed else 0
    print(f"{study.name}: {study_size(study)}, {len(todo)} to run, {_done(study, ledger, states, len(todo))} "
          f"-> {out_dir}")
    computes = what_a_case_computes(study)
    if computes:
        print(computes)
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
        raise ResultsIOError(f"cannot use the results directory {out_dir}: it is a symbolic link to "
                         f"{os.readlink(out_dir)}, which does not exist")
    if force or not out_dir.exists():
        return
    if not out_dir.is_dir():
        raise ResultsIOError(f"cannot use the results directory {out_dir}: it is not a directory")
    try:
        entries = {p.name for p in out_dir.iterdir()}
    except OSError as err:
        raise ResultsIOError(f"cannot use the results directory {out_dir}: {err.strerror or err}") from None
    if entries and not entries & RESULTS_MARKERS:
        raise StudyError(f"--out {out_dir} is a non-empty directory that holds no floe-impact results "
                         f"({len(entries)} entries); give a new or empty directory, or add --force")


#: bytes a case stores besides its fields: series, diagnostics, and the event records
#: (measured: 800-3100 record nodes of 5 doubles per surface; 50 kB is the high end)
CASE_OVERHEAD = 50_000


def output_size(study) -> tuple:
    """(bytes one case holds in a worker's memory, bytes the study writes to disk), estimated
    from the output request: each field is times x x_points doubles; where ice breaks, each
    case's break slots (max_parts - 1) hold the BREAKING_INFO values along break_number, and the
    parts over time one more series."""
    from solver.outputs import BREAKING_INFO       # (numba: the doors do not load it at their tops)
    times = study.case(0).requested_times().size
    fields = len(study.output.fields) * times * study.output.x_points * 8
    slots = study.output.break_slots
    breaks = (sum(along == "break" for *_, along in BREAKING_INFO.values()) * slots + times) * 8 if slots else 0
    per_case = fields + breaks + 3 * times * 8 + CASE_OVERHEAD
    memory = 4 * (fields + breaks) + CASE_OVERHEAD        # the solver's, the case's and the batch's copies
    disk = 2 * per_case * len(study.run_ids)              # batch files and study.nc
    return memory, disk


def _refuse_what_cannot_fit(study, out_dir: Path) -> None:
    memory, disk = output_size(study)
    total_memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if memory > total_memory / 4:
        raise StudyError(f"one case's output needs about {memory / 2**30:.1f} GiB of memory ([output] fields x "
                         f"times x x_points{', and max_parts - 1 break slots' if study.output.break_slots else ''}), "
                         f"more than a quarter of this machine's {total_memory / 2**30:.0f} GiB; ask for fewer fields, "
                         f"times or x_points{', or a smaller max_parts' if study.output.break_slots else ''}")
    if (out_dir / "ledger.jsonl").exists():               # a resume: much of it is written already
        return
    base = out_dir.absolute()
    while not base.exists() and base != base.parent:
        base = base.parent
    free = shutil.disk_usage(base).free
    if disk > free:
        raise StudyError(f"the study would write about {disk / 2**30:.1f} GiB, more than the "
                         f"{free / 2**30:.1f} GiB free under {base}; ask for fewer fields, times or x_points"
                         f"{', or a smaller max_parts' if study.output.break_slots else ''}")


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
        raise ResultsIOError(f"the results directory {out_dir} was removed or replaced during the run; "
                         f"stopping (run the same command again to start over)")


def _workers_for(requested: int, runs: int, batches: Path) -> int:
    """Local workers to start: no more than there is work for (the runs to compute, and the batch
    files of earlier runs the combine reads), so that a one-case study or a rerun of one case
    starts one worker process, not two (each costs about 1 s of CPU to start)."""
    if runs >= requested:
        return requested
    earlier = sum(1 for _ in zip(range(requested), batches.glob("*.nc")))
    return max(1, min(requested, runs + earlier))


def _done(study, ledger, states: dict, todo: int) -> str:
    """'N already done', and how many of them a stored run that computed everything serves
    (Study.wider_ids)."""
    text = f"{len(study.run_ids) - todo} already done"
    if study.wider_ids:
        own = ledger.index()
        served = sum(1 for cid in study.wider_ids if cid not in own and states.get(cid, "pending") != "pending")
        if served:
            text += f" ({served} of them by stored runs that computed every output)"
    return text


def _todo(study, states: dict, rerun_failed: bool) -> tuple:
    """The runs to compute as (items [case_id, position or -1], signatures)."""
    from .common.tables import FAILED
    first = study.first_position
    items, signature = [], []
    for cid in study.run_ids:
        if states[cid] == "pending" or (rerun_failed and states[cid] in FAILED):
            position = first.get(cid, -1)
            items.append([cid, position])
            signature.append(0 if position >= 0 else 1)
    return items, signature


def _run_locked(options, study, out_dir: Path, session=None) -> int:
    """Plan, compute and stream, combine (again, where a batch file turned out damaged), figures,
    report."""
    from .common.tables import NUMERICAL_FAILURES
    batches = _prepare_dirs(out_dir)
    from .study.study_files import keep_study_copy
    keep_study_copy(study, out_dir)
    notes = []
    ledger = reconcile(out_dir, notes)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    states = ledger_states(study, out_dir, ledger)
    items, signature = _todo(study, states, options.rerun_failed)
    from .study.consistency import cases_past_their_stage
    past = cases_past_their_stage(study)
    if past:
        print(f"note: {past} of {study.n_cases} cases have output times past their impact stage "
              f"(b_mean/V: L^2/(6RV) for the paper's parabola); those times are not integrated and stay NaN",
              file=sys.stderr)
    skipped = len(study.run_ids) - len(items)
    print(f"{study.name}: {study_size(study)}, {len(items)} to run, {_done(study, ledger, states, len(items))} "
          f"-> {out_dir}", file=sys.stderr)
    if items and study.n_cases > 1000 and "error_estimate" not in study.solver and "error_estimate" not in study.grid:
        print("note: every case also runs the error estimate's companion (0.79x the integration, measured); "
              "[solver] error_estimate = \"sample\" runs it on about 1 case in 10", file=sys.stderr)
    from .store.combine import open_writer, stream_spec
    items_run = list(items)
    identity = _identity(out_dir)
    workers = _workers_for(options.workers, len(items), batches)
    local_workers = session is None and not options.scheduler and not options.cluster   # ended with the with
    with contextlib.nullcontext(session) if session is not None else session_for(options, workers, out_dir) \
            as session:
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
                            raise write_failed(ledger.path, err) from None
                        for cid, status, _, _ in entry["cases"]:
                            states[cid] = status
                        if reduced is not None:
                            writer = writer or open_writer(study, out_dir)
                            writer.write([position for _, position in batch], reduced)
                    lost = session.run(study, items, signature, batches, on_batch, len(study.run_ids),
                                       skipped, options.batch_seconds, spec)
                    for record in lost:
                        print(f"note: case {record['case_id']}: {record['message']} (it stays pending)",
                              file=sys.stderr)
                check()
                fresh = _combine(options, study, out_dir, ledger, states, session, bool(items), writer)
            except BaseException as err:
                if writer is not None:
                    writer.abandon()
                if isinstance(err, (OSError, WriteFailed)):
                    # a batch, ledger or study.nc write failing because the directory went (make
                    # clean mid-run) says so
                    _still_ours(out_dir, identity)
                raise
            if fresh is not None:                      # done: no damaged batch file
                break
            states = ledger_states(study, out_dir, ledger)
            items, signature = _todo(study, states, False)
            items_run += items
            skipped = len(study.run_ids) - len(items)
        else:
            raise ResultsIOError("batch files keep failing their checksums; is the disk healthy?")
    if local_workers:
        # this run's local workers have all ended: a temporary batch file is a killed worker's
        _remove_temporaries(batches.glob(".batch.nc.tmp-*"))
    _analysis(study, out_dir, fresh)
    _plots(options, study, out_dir, fresh)
    _summary(study, ledger, states, computed={cid for cid, _ in items_run})
    if any(states[cid] in NUMERICAL_FAILURES or states[cid] == "pending" for cid in study.run_ids):
        return EXIT_FAILED
    return EXIT_OK


def _combine(options, study, out_dir: Path, ledger, states: dict, session, computed: bool, writer=None):
    """Write study.nc if its inputs changed; True if written, False if up to date, None if a
    damaged batch file was found (set aside and dropped from the ledger)."""
    index = ledger.index(study.wider_ids)
    fingerprint = inputs_fingerprint(study, index)
    path = out_dir / "study.nc"
    if not computed and is_up_to_date(out_dir, fingerprint):
        print(f"nothing new: {path} is up to date", file=sys.stderr)
        return False
    streamed = writer.seen if writer is not None else None
    n_files = len({index[cid][0]["file"] for i, cid in enumerate(study.case_ids)
                   if cid in index and (streamed is None or not streamed[i])})
    from .store.combine import write_study
    mapper = session.mapper() if session.is_open or n_files > 50 else None
    started = time.monotonic()
    try:
        written, damaged = write_study(study, out_dir, index, states, mapper, fingerprint, writer)
    except (OSError, RuntimeError) as err:          # netCDF reports a full disk as "HDF error"
        raise write_failed(path, err) from None
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
            raise write_failed(ledger.path, err) from None
        return None
    print(f"wrote {written} ({time.monotonic() - started:.1f} s)", file=sys.stderr)
    return True


def _analysis(study, out_dir: Path, fresh: bool) -> None:
    """The study's [analysis] (sensitivity indices) from study.nc into sensitivity.nc, when
    study.nc is new or the indices are missing; a design that cannot be analysed says why."""
    if not study.analysis:
        return
    target = out_dir / "sensitivity.nc"
    from .store.sealed import is_intact, seal
    if not fresh and is_intact(target):             # (a damaged or unsealed one is written again)
        return
    import xarray as xr

    from .analyse.sensitivity import analyze, doubtful_outputs
    from .store.casefile import temporary_path
    try:
        with xr.open_dataset(out_dir / "study.nc") as ds:
            indices = analyze(ds, study.design, study.analysis)
    except StudyError as err:
        print(f"note: {err}", file=sys.stderr)
        return
    tmp = temporary_path(target)
    try:
        indices.to_netcdf(tmp)
        os.replace(tmp, target)
        seal(target)
    except OSError as err:
        raise write_failed(target, err) from None
    finally:
        tmp.unlink(missing_ok=True)
    print(f"wrote {target}", file=sys.stderr)
    for label, reason in json.loads(indices.attrs.get("refusals", "{}")).items():
        print(f"warning: no indices for {label}: {reason}", file=sys.stderr)
    doubtful = doubtful_outputs(indices)
    if doubtful:
        print(f"warning: the Sobol' indices of {', '.join(doubtful)} lie outside [0, 1] beyond their intervals: "
              f"too few samples for these outputs (flagged in {target.name}: outside_unit_interval); "
              f"raise [design] samples", file=sys.stderr)


def _plots(options, study, out_dir: Path, fresh: bool) -> None:
    figures = [out_dir / f for kind in study.plots for f in KINDS[kind].files]
    if options.no_plots or not (fresh or not all(f.exists() for f in figures)):
        return
    import xarray as xr

    from .store.casefile import file_sha256
    path = out_dir / "study.nc"
    record = sidecar(out_dir)
    if not record or record.get("sha256") != file_sha256(path):
        print(f"note: {path} does not match its checksum; run again to rebuild it", file=sys.stderr)
        return
    try:
        with xr.open_dataset(path) as ds:
            written, notes = make_plots(ds, study.dims, study.plots, out_dir)
    except OSError as err:
        raise write_failed(Path(err.filename) if getattr(err, "filename", None) else out_dir / "figures", err) from None
    for p in written:
        print(f"wrote {p}", file=sys.stderr)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)


def _summary(study, ledger, states: dict, computed: set) -> None:
    """The cases that did not end ok: listed (30 at most) when this run computed them, one
    line when they are old news (status lists them)."""
    index = ledger.index(study.wider_ids)
    from .common.tables import COMPLETE
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
        print(f"  {cid} ({case_label(study, cid)}): {states[cid]}: {msg}", file=sys.stderr)
    if len(new) > 30:
        print(f"  ... and {len(new) - 30} more (python -m pipeline status {study.path})", file=sys.stderr)
