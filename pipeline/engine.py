"""Cases -> workers: run pending cases on a dask.distributed cluster.

Default: a LocalCluster of ``workers`` processes x 1 thread, numba/BLAS threads pinned to 1
before each worker starts. With ``scheduler`` (or DASK_SCHEDULER_ADDRESS) the same cases run
on an existing cluster; its workers must see the results directory (a shared filesystem).
The numba kernels are compiled once (into numba's on-disk cache) before fanning out and
loaded on every worker before the first case, tasks return small records (the case file on
disk is the result), and at most ``2 x workers`` tasks are in flight.
"""
from __future__ import annotations

import logging
import signal
import sys
import time
from contextlib import contextmanager

import dask
from distributed import Client, LocalCluster, as_completed

from solver import compile_kernels

from .casefile import ENDED_EARLY, WRITE_FAILED, CaseWriteError, run_case

SINGLE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                     "NUMBA_NUM_THREADS": "1"}


def probe_scheduler(address: str, timeout: float = 5.0) -> None:
    """A plain TCP connection to the scheduler, so a wrong address fails in seconds."""
    import socket
    from urllib.parse import urlparse

    from .errors import StudyError
    parsed = urlparse(address if "://" in address else f"tcp://{address}")
    if parsed.scheme not in ("tcp", "tls") or not parsed.hostname or not parsed.port:
        raise StudyError(f"scheduler address {address!r} is not of the form tcp://host:port")
    try:
        socket.create_connection((parsed.hostname, parsed.port), timeout=timeout).close()
    except OSError as err:
        raise StudyError(f"cannot reach the dask scheduler at {address!r}: {err.strerror or err}") from None


@contextmanager
def cluster_client(workers: int, scheduler: str | None):
    """A dask Client: on a new LocalCluster, or connected to ``scheduler``."""
    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as err:
            from .errors import StudyError
            raise StudyError(f"cannot reach the dask scheduler at {scheduler!r} within 10 s "
                             f"({type(err).__name__})") from None
        try:
            yield client
        finally:
            client.close()
        return
    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    environ.update(SINGLE_THREAD_ENV)
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ,
                          "distributed.scheduler.allowed-failures": 3}):
        # workers are spawned with SIGINT ignored (kept across exec): on Ctrl-C only the runner
        # reacts, abandons the in-flight cases and shuts the cluster down
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            # CRITICAL: a case's failure reaches the runner as its record (run_case catches
            # everything); what dask logs at ERROR is its own shutdown races (a worker's heartbeat
            # to a scheduler already gone when a full disk stops the study), a traceback the
            # user cannot act on
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.CRITICAL)
        finally:
            signal.signal(signal.SIGINT, previous)
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
            cluster.close()


class Progress:
    """One status line: done / failed / skipped counts and an ETA (a line per case off a tty)."""

    def __init__(self, total: int, skipped: int, stream=sys.stderr):
        self.total, self.skipped, self.stream = total, skipped, stream
        self.done = self.failed = self.early = 0
        self.start = time.monotonic()
        self.tty = stream.isatty()
        self.last = 0.0

    def update(self, record: dict) -> None:
        self.done += 1
        if record["status"] in ENDED_EARLY:
            self.early += 1
        elif record["status"] != "ok":
            self.failed += 1
        todo = self.total - self.skipped
        elapsed = time.monotonic() - self.start
        eta = elapsed / self.done * (todo - self.done)
        width = 30
        filled = int(width * (self.skipped + self.done) / max(self.total, 1))
        line = (f"[{'#' * filled}{'.' * (width - filled)}] {self.skipped + self.done}/{self.total} "
                f"done ({self.early} ended early, {self.failed} failed, {self.skipped} skipped), "
                f"elapsed {elapsed:5.1f} s, ETA {eta:5.1f} s")
        if self.tty:
            self.stream.write("\r" + line)
            if self.done == todo:
                self.stream.write("\n")
        elif self.done == todo or time.monotonic() - self.last > 2.0:
            self.stream.write(line + "\n")
            self.last = time.monotonic()
        self.stream.flush()


def kernels_loaded() -> bool:
    """On a worker: are the solver's kernels compiled or loaded from numba's cache?"""
    import sys as _sys
    kernels = _sys.modules.get("solver.kernels")
    return kernels is not None and len(kernels.integrate.signatures) > 0


def warm_workers(client, one_at_a_time: bool = False) -> None:
    """Load the numba kernels on every worker before the first case, so that a case's
    run_time is solver time, not the cache load of its worker's first case (0.36 s reported for
    a 0.06 s run before). Local workers read the cache the runner filled, all at once; the
    workers of an existing cluster may have to compile, so they go one at a time (no race on
    numba's cache)."""
    if one_at_a_time:
        for address in client.scheduler_info()["workers"]:
            client.run(compile_kernels, workers=[address])
    else:
        client.run(compile_kernels)


def run_pending(cases: list, cases_dir, workers: int = 2, scheduler: str | None = None,
                progress: Progress | None = None) -> list:
    """Run the cases; returns their records (case_id, status, message, run_time)."""
    if not cases:
        return []
    started = time.monotonic()
    print("loading the solver's kernels (the first run after an install or an update compiles "
          "them: about 40 s on this 2-core machine) ...", file=sys.stderr, flush=True)
    compile_kernels()                                  # fill numba's cache once, here
    print(f"kernels ready in {time.monotonic() - started:.1f} s", file=sys.stderr, flush=True)
    records = []
    with cluster_client(workers, scheduler) as client:
        warm_workers(client, one_at_a_time=bool(scheduler))
        n_workers = max(1, len(client.scheduler_info()["workers"]))
        limit = 2 * n_workers
        queue = list(cases)
        futures = as_completed()

        def submit_next():
            case = queue.pop(0)
            futures.add(client.submit(run_case, case.to_dict(), str(cases_dir), pure=False,
                                      key=f"case-{case.case_id}"))

        for _ in range(min(limit, len(queue))):
            submit_next()
        for future in futures:
            try:
                record = future.result()
            except Exception as err:                   # infrastructure: the case file is absent
                record = {"case_id": future.key.removeprefix("case-"), "status": "error",
                          "message": f"task failed: {type(err).__name__}: {err}", "run_time": float("nan")}
            if record["status"] == WRITE_FAILED:       # the disk, not the case: stop the study
                queue.clear()
                raise CaseWriteError(record["message"])
            records.append(record)
            if progress:
                progress.update(record)
            if queue:
                submit_next()
    return records
