"""Workers as batch jobs (``floe-impact run STUDY --cluster slurm --jobs N``; issue 40).

dask-jobqueue's SLURMCluster or PBSCluster (the optional extra ``floe-impact[hpc]``) starts the
scheduler in the runner and submits one job per worker: one single-threaded worker process,
numba/BLAS threads pinned to 1, as a local worker. What a site sets (queue, account, memory,
walltime, job directives, the network interface) comes from dask's jobqueue configuration
(``~/.config/dask/jobqueue.yaml`` or ``DASK_JOBQUEUE__SLURM__QUEUE=...``); the rest is set here:

- **TLS with fresh credentials** (``Security.temporary()``): the scheduler must be reachable
  from the compute nodes, and a dask client that reaches it can run code as the user. The
  workers' keys are written (mode 0600) into the results directory's ``jobs/``, which the
  compute nodes see at the same path, and removed when the cluster closes.
- **A worker lifetime below the walltime** (``--lifetime`` 0.85 of it, ``--lifetime-stagger``
  0.05): a worker retires before its job is killed, its batch is run again elsewhere, and a new
  job replaces it (:func:`keep_jobs`), so a study may last longer than one job.
- **The job's logs** in ``jobs/`` unless the configuration names a directory.
- **The dashboard** on 127.0.0.1 only (reach it with ``ssh -L``); the workers serve none.

Every job is cancelled when the run ends, fails or is interrupted (the cluster's close); a
runner killed outright leaves its workers to exit ``death-timeout`` (60 s) after the scheduler.
"""
from __future__ import annotations

import re
import shutil
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from ..common.errors import StudyError
from ..common import interrupts

#: --cluster NAME: dask-jobqueue's cluster class, the command that submits a job, the one that
#: lists the jobs (it must answer before a run starts)
SYSTEMS = {"slurm": ("SLURMCluster", "sbatch", ["squeue", "-h", "-o", "%i"]),
           "pbs": ("PBSCluster", "qsub", ["qstat"])}
#: memory per job when the site's configuration sets none (a case needs far less; output_size)
DEFAULT_MEMORY = "2GiB"
#: a worker retires at this fraction of the walltime, staggered by STAGGER of it
LIFETIME, STAGGER = 0.85, 0.05
#: seconds between two checks that every job is alive (a lost one is replaced)
REPLACE_EVERY = 2.0
#: where a run keeps its jobs' logs and the workers' TLS files, under the results directory
JOBS_DIR = "jobs"


@dataclass(frozen=True)
class Jobs:
    """Where a run's workers come from when they are batch jobs."""

    system: str          # a key of SYSTEMS
    jobs: int            # worker jobs kept running (one single-threaded worker each)
    directory: Path      # their logs and TLS files (seen by the compute nodes at the same path)


#: the shortest walltime a worker job is given: its worker must start, load the kernels, run
#: batches and retire (LIFETIME) before the batch system kills it
MIN_WALLTIME = 10.0


def walltime_seconds(text, system: str = "slurm") -> float:
    """A batch walltime in seconds, as the batch system reads it. SLURM (sbatch -t): minutes,
    MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS. PBS (-l walltime): seconds, MM:SS, HH:MM:SS."""
    value = str(text).strip()
    days_form = r"(\d+)-(\d+)(?::(\d+))?(?::(\d+))?"          # D-HH[:MM[:SS]]: hours after the day
    plain_form = r"(\d+)(?::(\d+))?(?::(\d+))?"                # M | MM:SS | HH:MM:SS
    days = re.fullmatch(days_form, value) if system == "slurm" else None
    plain = re.fullmatch(plain_form, value)
    if days:
        d, h, m, sec = (int(g or 0) for g in days.groups())
        seconds = 86400 * d + 3600 * h + 60 * m + sec
    elif plain:
        parts = [int(g) for g in plain.groups() if g is not None]
        if len(parts) == 1:                     # sbatch -t 45: minutes; PBS walltime=45: seconds
            seconds = parts[0] * (60 if system == "slurm" else 1)
        elif len(parts) == 2:
            seconds = 60 * parts[0] + parts[1]
        else:
            seconds = 3600 * parts[0] + 60 * parts[1] + parts[2]
    else:
        forms = "minutes, MM:SS, HH:MM:SS or D-HH:MM:SS" if system == "slurm" else "seconds, MM:SS or HH:MM:SS"
        raise StudyError(f"walltime {value!r} is not a {system} walltime ({forms}; dask's jobqueue configuration)")
    if seconds < MIN_WALLTIME:
        raise StudyError(f"walltime {value!r} is {seconds} s: a worker job needs at least {MIN_WALLTIME:.0f} s "
                         f"(dask's jobqueue configuration)")
    return float(seconds)


def lifetime_arguments(walltime, system: str = "slurm") -> list:
    """dask worker's ``--lifetime`` and ``--lifetime-stagger`` for a job of this walltime: it
    retires between 0.80 and 0.90 of it, leaving the rest to hand its batch back and exit."""
    seconds = walltime_seconds(walltime, system)
    return ["--lifetime", f"{int(LIFETIME * seconds)}s", "--lifetime-stagger", f"{max(1, int(STAGGER * seconds))}s"]


def _config(kind: str, key: str, default=None):
    import dask
    return dask.config.get(f"jobqueue.{kind}.{key}", default)


def _cluster_class(kind: str):
    if kind not in SYSTEMS:
        raise StudyError(f"--cluster must be one of {', '.join(SYSTEMS)}, got {kind!r}")
    handler = signal.getsignal(signal.SIGINT)
    try:
        import dask_jobqueue
    except ImportError:
        raise StudyError(f"--cluster {kind} needs dask-jobqueue: pip install 'floe-impact[hpc]'") from None
    finally:
        # importing dask_jobqueue (0.9: its runner module) sets SIGINT to sys.exit(): a Ctrl-C
        # then ended the run with exit 0, no message, the ledger unsaved. The runner's own
        # handler (pipeline.common.interrupts) is put back.
        signal.signal(signal.SIGINT, handler)
    return getattr(dask_jobqueue, SYSTEMS[kind][0])


def job_options(kind: str, directory: Path, security=None) -> dict:
    """The keyword arguments of dask-jobqueue's cluster: one single-threaded worker per job, the
    site's configuration for the rest, a lifetime below the walltime, logs in ``directory``."""
    extra = list(_config(kind, "worker-extra-args") or [])
    if not {"--dashboard", "--no-dashboard", "--dashboard-address"} & set(extra):
        # no worker pages; and the HTTP server a worker starts even so (/health, /metrics) on
        # the node's loopback, not open to the compute nodes' network
        extra += ["--no-dashboard", "--dashboard-address", "127.0.0.1:0"]
    if "--lifetime" not in extra:
        extra += lifetime_arguments(_config(kind, "walltime"), kind)
    from .worker import SINGLE_THREAD_ENV  # what a local worker runs with, and so each job
    prologue = [f"export {name}={value}" for name, value in SINGLE_THREAD_ENV.items()] + \
        list(_config(kind, "job-script-prologue") or [])
    options = dict(cores=1, processes=1, memory=_config(kind, "memory") or DEFAULT_MEMORY,
                   worker_extra_args=extra, job_script_prologue=prologue,
                   log_directory=_config(kind, "log-directory") or str(directory),
                   shared_temp_directory=_config(kind, "shared-temp-directory") or str(directory),
                   scheduler_options={"dashboard_address": "127.0.0.1:0",
                                      **(_config(kind, "scheduler-options") or {})})
    if _config(kind, "name") in (None, "dask-worker"):
        options["job_name"] = "floe-impact"
    if security is not None:
        options["security"] = security
    return options


def job_script(kind: str, directory: Path, security=None, logs: bool = True) -> str:
    """The job script a worker's job runs (dask-jobqueue's rendering, with a placeholder for the
    scheduler's address): what --cluster submits, inspectable without a batch system. Rendering
    it creates the log directory (dask-jobqueue does); ``logs=False`` leaves the logs out."""
    cls = _cluster_class(kind)
    options = {k: v for k, v in job_options(kind, directory).items()
               if k not in ("scheduler_options", "shared_temp_directory")}
    if not logs:
        options["log_directory"] = None
    if security is not None:                # the files the cluster writes its in-memory keys to
        from distributed.security import Security
        options["protocol"] = "tls://"
        options["security"] = Security(
            require_encryption=True, **{f"tls_{'' if key == 'ca_file' else 'worker_'}{key}":
                                        str(directory / f".dask-jobqueue.worker.{key}.XXXXXXXX")
                                        for key in ("ca_file", "cert", "key")})
    job = cls.job_cls("tls://<scheduler-address>:8786" if security is not None else "tcp://<scheduler-address>:8786",
                      name="<worker-name>", **options)
    return job.job_script()


def check(kind: str, directory: Path) -> None:
    """Before anything is written: the extra is installed, the batch system's commands are on
    PATH and its controller answers, the configuration renders a job script, and (SLURM) sbatch
    accepts that script (``--test-only``: a wrong partition or account is refused here, in one
    line). Raises StudyError."""
    _cluster_class(kind)
    _, submit, listing = SYSTEMS[kind]
    for command in (submit, listing[0]):
        if shutil.which(command) is None:
            raise StudyError(f"--cluster {kind}: {command} is not on PATH; run on the cluster's login node")
    answer = _call(listing, kind)
    if answer.returncode != 0:
        raise StudyError(f"--cluster {kind}: the batch system does not answer ({' '.join(listing)}: "
                         f"{_last_line(answer)})")
    try:
        script = job_script(kind, directory, logs=False)          # writes nothing
    except (ValueError, TypeError) as err:
        raise StudyError(f"--cluster {kind}: dask's jobqueue configuration is not usable: "
                         f"{str(err).splitlines()[0]}") from None
    if kind == "slurm":
        answer = _call(["sbatch", "--test-only"], kind, script)
        if answer.returncode != 0:
            raise StudyError(f"--cluster slurm: sbatch refuses the worker job: {_last_line(answer)}")


def _call(command: list, kind: str, stdin: str | None = None):
    try:
        return subprocess.run(command, input=stdin, capture_output=True, text=True, timeout=30)
    except subprocess.TimeoutExpired:
        raise StudyError(f"--cluster {kind}: {command[0]} did not answer within 30 s") from None


def _last_line(answer) -> str:
    lines = (answer.stderr or answer.stdout or "").strip().splitlines()
    return lines[-1] if lines else f"exit {answer.returncode}"


@contextmanager
def batch_cluster(kind: str, jobs: int, directory: Path):
    """The jobqueue cluster of ``jobs`` worker jobs, TLS on, every job cancelled on exit."""
    import dask
    from distributed.security import Security
    cls = _cluster_class(kind)
    directory.mkdir(mode=0o700, parents=True, exist_ok=True)      # its logs and TLS keys: the user's alone
    # a lost worker's job is closed (cancelled) and replaced after this delay (dask: 15 s)
    with dask.config.set({"distributed.deploy.lost-worker-timeout": "2s"}):
        cluster = cls(**job_options(kind, directory, Security.temporary()))
        try:
            _submit(cluster, kind, jobs)
            with keep_jobs(cluster, jobs):
                yield cluster
        finally:
            cluster.close()
            _remove_credentials(cluster, directory)


def _submit(cluster, kind: str, jobs: int) -> None:
    """Submit the first jobs here and now, and wait for the batch system's answer: a refusal
    that ``sbatch --test-only`` does not check (an invalid account, a QOS or job-count limit) is
    one StudyError with its line. (``scale`` submits in a task of the cluster's loop of its own,
    whose error nobody retrieved: a traceback, then a wait without end for jobs that never were.)"""
    while len(cluster.worker_spec) < jobs:                # a jobqueue cluster's spec: one entry a job
        cluster.worker_spec.update(cluster.new_worker_spec())
    try:
        cluster.sync(cluster._correct_state)
    except RuntimeError as err:
        from distributed.core import Status
        for name in [name for name, job in cluster.workers.items() if not getattr(job, "job_id", None)]:
            cluster.workers[name].status = Status.failed              # never submitted: nothing to cancel
            del cluster.workers[name], cluster.worker_spec[name]
        raise StudyError(f"--cluster {kind}: submitting the worker jobs failed: {_submission_error(err)}") from None
    if not job_ids(cluster):
        raise StudyError(f"--cluster {kind}: {SYSTEMS[kind][1]} gave no job id for the worker jobs")


def _remove_credentials(cluster, directory: Path) -> None:
    """The workers' TLS files (CA, certificate, private key), which dask-jobqueue writes beside
    the logs and deletes only when its cluster object is collected (after a Ctrl-C, the
    traceback kept it past the exit): removed now, and the directory if no log is in it."""
    for key in ("ca_file", "cert", "key"):
        handle = getattr(cluster, f"_job_{key}", None)
        try:
            if handle is not None:
                handle.close()                             # a NamedTemporaryFile: deleted
        except OSError:                                    # gone already (the results removed mid-run)
            pass
    try:
        for path in directory.glob(".dask-jobqueue.worker.*"):
            path.unlink(missing_ok=True)
        directory.rmdir()
    except OSError:                                        # the jobs' logs are there: kept
        pass


def _submission_error(err: Exception) -> str:
    text = str(err)
    match = re.search(r"stderr:\s*(.*?)(?:\n\s*stdout:|$)", text, re.S)
    lines = (match.group(1) if match else text).strip().splitlines()
    return lines[-1].strip() if lines else type(err).__name__


@contextmanager
def keep_jobs(cluster, jobs: int):
    """Every REPLACE_EVERY seconds, replace the jobs whose worker has left (retired at its
    lifetime, pre-empted, cancelled): dask closes a lost worker's job after the lost-worker
    timeout, and ``scale`` then submits a new one for it."""
    from tornado.ioloop import PeriodicCallback
    callback = PeriodicCallback(lambda: cluster.scale(jobs=jobs), REPLACE_EVERY * 1000)
    cluster.loop.add_callback(callback.start)
    try:
        yield
    finally:
        cluster.loop.add_callback(callback.stop)


def job_ids(cluster) -> list:
    """The batch system's ids of the cluster's current jobs (for squeue/scancel)."""
    return [job.job_id for job in cluster.workers.values() if getattr(job, "job_id", None)]


#: how often the runner looks for its first worker while the jobs wait in the queue [s], and how
#: often it asks the batch system whether they are still there (squeue costs the site's controller)
POLL, LIST_EVERY = 1.0, 10.0


def wait_for_a_worker(client, cluster, kind: str, directory: Path) -> None:
    """Until the first worker joins: the jobs may wait in the queue for as long as the site
    makes them (said once); if every job has ended with no worker joined (a job script that
    fails on the compute node), StudyError names the log to read."""
    said = False
    started = listed_at = time.monotonic()
    while not client.scheduler_info()["workers"]:
        interrupts.check()
        if not said and time.monotonic() - started > 5 * POLL:
            print(f"waiting for the worker jobs to start ({SYSTEMS[kind][2][0]} shows them; their logs are in "
                  f"{directory})", file=sys.stderr, flush=True)
            said = True
        ids = job_ids(cluster)
        listed = None
        if ids and time.monotonic() - listed_at >= LIST_EVERY:
            listed, listed_at = _listed_jobs(kind), time.monotonic()
        if listed is not None and not {i.split(".")[0] for i in ids} & listed:
            raise StudyError(f"--cluster {kind}: the worker jobs {', '.join(ids)} ended before a worker "
                             f"reached the scheduler; see {_newest_log(directory)}")
        time.sleep(POLL)


def _listed_jobs(kind: str):
    """The ids of the jobs the batch system lists, or None if it does not answer now."""
    try:
        answer = subprocess.run(SYSTEMS[kind][2], capture_output=True, text=True, timeout=30)
    except subprocess.TimeoutExpired:
        return None
    if answer.returncode != 0:                         # the controller is busy: ask again later
        return None
    return {line.split()[0].split(".")[0] for line in answer.stdout.splitlines()
            if line.strip() and line.split()[0][0].isdigit()}


def _newest_log(directory: Path) -> str:
    logs = sorted(directory.glob("*.err"), key=lambda p: p.stat().st_mtime)
    if not logs:
        return f"the job logs in {directory}"
    lines = [line for line in logs[-1].read_text(errors="replace").splitlines() if line.strip()]
    return f"{logs[-1]}" + (f" (last line: {lines[-1].strip()})" if lines else "")
