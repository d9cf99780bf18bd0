"""Cases -> workers: run pending cases on a dask.distributed cluster.

Default: a LocalCluster of ``workers`` processes x 1 thread, numba/BLAS threads pinned to 1
before each worker starts. With ``scheduler`` (or DASK_SCHEDULER_ADDRESS) the same cases run
on an existing cluster; its workers must see the results directory (a shared filesystem).
The numba kernels are compiled once (into numba's on-disk cache) before fanning out and
loaded on every worker before the first case, tasks return small records (the batch file on
disk is the result), and at most ``2 x workers`` tasks are in flight.
"""
from __future__ import annotations

import logging
import signal
import socket
import ssl
import struct
import subprocess
import sys
import time
from contextlib import contextmanager, nullcontext
from urllib.parse import urlparse

import dask
from distributed import Client, LocalCluster, as_completed

from solver import compile_kernels
from solver.compile import kernel_cache

from ..common import interrupts
from ..common.errors import StudyError
from ..common.interrupts import check
from ..common.tables import COMPLETE, ENDED_EARLY, WRITE_FAILED
from ..store.casefile import CaseWriteError
from . import forkserver
from .batch_system import batch_cluster, wait_for_a_worker
from .worker import SINGLE_THREAD_ENV, run_batch


def probe_scheduler(address: str, timeout: float = 5.0, tls: tuple | None = None) -> None:
    """A plain connection to the scheduler, so a wrong address fails in seconds: the port must
    accept, and the server must speak first, as a dask scheduler does (its handshake); an HTTP
    server, say, waits for a request and is refused after ``timeout``. A ``tls://`` scheduler
    gets a TLS handshake with ``tls`` = (CA file, certificate, key), or with dask's
    ``distributed.comm.tls`` configuration: credentials it refuses are refused here."""

    try:
        parsed = urlparse(address if "://" in address else f"tcp://{address}")
        host, port = parsed.hostname, parsed.port
    except ValueError as err:
        raise StudyError(f"scheduler address {address!r} is not of the form tcp://host:port ({err})") from None
    if parsed.scheme not in ("tcp", "tls") or not host or not port:
        raise StudyError(f"scheduler address {address!r} is not of the form tcp://host:port")
    if tls and parsed.scheme != "tls":
        raise StudyError(f"TLS credentials were given but the scheduler address {address!r} is not tls://")
    try:
        with socket.create_connection((host, port), timeout=timeout) as sock:
            sock.settimeout(timeout)
            if parsed.scheme == "tls":
                first = _tls_first_bytes(sock, host, tls, address)
            else:
                first = _handshake(sock.recv)
    except socket.timeout:
        raise StudyError(f"{address!r} accepts connections but does not answer like a dask scheduler "
                         f"within {timeout:g} s" + ("" if parsed.scheme == "tls" else
                                                    " (a tls:// scheduler? give tls://... and its credentials)")) from None
    except OSError as err:
        raise StudyError(f"cannot reach the dask scheduler at {address!r}: {err.strerror or err}") from None
    if not first:
        raise StudyError(f"{address!r} closed the connection: not a dask scheduler, or it refused this client")
    if not _is_dask_handshake(first):
        raise StudyError(f"{address!r} answers, but not as a dask scheduler (its first bytes: {first[:24]!r})")


#: the most of a dask comm's first message the probe reads: its handshake is about 60 bytes
HANDSHAKE_BYTES = 4096


def _handshake(recv) -> bytes:
    """The first message of a dask comm as ``recv`` gives it: 8 bytes of length (uint64), then
    that many bytes (frame count, frame lengths, msgpack), up to HANDSHAKE_BYTES; fewer where
    the server closes, or sends something else, first."""
    data = b""
    while len(data) < 8 or len(data) < min(8 + _length(data), HANDSHAKE_BYTES):
        chunk = recv(HANDSHAKE_BYTES - len(data))
        if not chunk:
            break
        data += chunk
        if len(data) >= 8 and not 0 < _length(data) <= HANDSHAKE_BYTES:
            break                                   # not dask's framing: no need to read on
    return data


def _length(data: bytes) -> int:
    return struct.unpack("<Q", data[:8])[0]


def _is_dask_handshake(data: bytes) -> bool:
    """dask's comm handshake: a length that fits, and the msgpack dict with its keys (an HTTP
    banner or other bytes read as a length asked distributed for exabytes)."""
    return (len(data) >= 8 and 0 < _length(data) <= HANDSHAKE_BYTES and len(data) >= 8 + _length(data)
            and b"pickle-protocol" in data and b"compression" in data)


def security_for(tls: tuple | None):
    """dask's Security for a client: from (CA file, certificate, key), or dask's configuration."""
    from distributed.security import Security
    if not tls:
        return Security()                       # distributed.comm.tls.* of dask's configuration, if any
    ca_file, cert, key = tls
    return Security(tls_ca_file=ca_file, tls_client_cert=cert, tls_client_key=key, require_encryption=True)


def _tls_first_bytes(sock, host: str, tls: tuple | None, address: str) -> bytes:
    """Handshake as a dask client would, and read the scheduler's first bytes: a scheduler that
    does not accept these credentials ends the connection here (TLS 1.3 says so after the
    handshake, at the first read)."""

    context = security_for(tls).get_connection_args("client").get("ssl_context")
    if context is None:
        raise StudyError(f"{address!r} is a tls:// scheduler: give its credentials (--tls-ca-file, --tls-cert, "
                         f"--tls-key, or dask's distributed.comm.tls configuration)")
    try:
        with context.wrap_socket(sock, server_hostname=host) as secure:
            return _handshake(secure.recv)
    except ssl.SSLError as err:
        raise StudyError(f"the TLS handshake with the dask scheduler at {address!r} failed ({err.reason or err}): "
                         f"these credentials are not the cluster's") from None


@contextmanager
def cluster_client(workers: int, scheduler: str | None, tls: tuple | None = None, batch=None):
    """A dask Client: on a new LocalCluster, connected to ``scheduler`` (with the TLS
    credentials ``tls``), or on worker jobs of a batch system (``batch``, a
    pipeline.compute.batch_system.Jobs: its cluster is closed, every job cancelled, on exit)."""
    if batch is not None:
        yield from _batch_cluster_client(batch)
        return
    if scheduler:
        try:
            client = Client(scheduler, timeout="10s", security=security_for(tls))
        except (OSError, TimeoutError) as err:
            raise StudyError(f"cannot reach the dask scheduler at {scheduler!r} within 10 s "
                             f"({type(err).__name__})") from None
        try:
            yield client
        finally:
            client.close()
        return
    with _main_script_hidden():
        yield from _local_cluster_client(workers)


@contextmanager
def _main_script_hidden():
    """While the local cluster lives, its worker processes do not import the runner's main
    script: multiprocessing's spawn runs ``__main__``'s file again in every child, so a script
    that calls run_study without ``if __name__ == "__main__":`` started a cluster in each
    worker ("Nanny failed to start"). The workers run only this package's functions."""
    main = sys.modules.get("__main__")
    saved = {k: getattr(main, k) for k in ("__file__", "__spec__") if main is not None and hasattr(main, k)}
    if main is not None and saved.get("__file__"):
        main.__spec__ = None
        del main.__file__
    try:
        yield
    finally:
        for key, value in saved.items():
            setattr(main, key, value)


@contextmanager
def _ctrl_c_held():
    """A Ctrl-C during the cluster's start does not interrupt it half-way: it is raised once the
    cluster is up (which is then closed). SIGINT is blocked in this thread meanwhile, so that
    the threads the start creates inherit it blocked; only the runner reacts to a Ctrl-C,
    abandons the in-flight cases and shuts the cluster down.

    The workers ignore SIGINT: those forked from the forkserver as it does
    (pipeline.compute.forkserver_preload), spawned ones through their launcher
    (forkserver.spawned_ignoring_sigint). The runner records the Ctrl-C in a handler; it goes
    to any thread that does not block it (numpy's BLAS threads, started at import), and the
    handler runs in this one."""
    interrupted = []
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    previous = signal.signal(signal.SIGINT, lambda signum, frame: interrupted.append(signum))
    try:
        yield
    finally:
        # unblocked first: a Ctrl-C still pending is taken by this thread now, and the handlers
        # run inside pthread_sigmask (PyErr_CheckSignals) while the recording one is installed.
        # (In the other order, one that a busy machine had not yet delivered to another thread
        # went to the previous handler: the start went on as if there had been none.)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        signal.signal(signal.SIGINT, previous)
        if interrupted and previous is not signal.SIG_IGN:
            interrupts.requested = True
            raise KeyboardInterrupt


#: the only interface a local run's scheduler, workers and dashboard listen on
LOOPBACK = "127.0.0.1"


def _local_cluster_client(workers: int):
    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    environ.update(SINGLE_THREAD_ENV)
    method = forkserver.start(environ)
    launcher = forkserver.spawned_ignoring_sigint() if method == "spawn" else nullcontext()
    with launcher, dask.config.set({"distributed.nanny.pre-spawn-environ": environ,
                                    "distributed.scheduler.allowed-failures": 3,
                                    "distributed.worker.multiprocessing-method": method}):
        cluster = None
        try:
            with _ctrl_c_held():
                # CRITICAL: a case's failure reaches the runner as its record (run_batch catches
                # everything); what dask logs at ERROR is its own shutdown races (a worker's
                # heartbeat to a scheduler already gone when a full disk stops the study), a
                # traceback the user cannot act on
                # dashboard_address=None still binds the scheduler's HTTP server to 8787 and warns
                # when another process holds that port; port 0 takes any free port, silently.
                # Every listener on the loopback only (issue 40): ":0" served the dashboard, its
                # worker pages and logs, on all interfaces, to anyone who could reach the machine
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       host=LOOPBACK, dashboard_address=f"{LOOPBACK}:0",
                                       silence_logs=logging.CRITICAL)
        except KeyboardInterrupt:
            if cluster is not None:
                cluster.close()
            raise
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
            cluster.close()


def _batch_cluster_client(batch):
    with batch_cluster(batch.system, batch.jobs, batch.directory) as cluster, Client(cluster) as client:
        print(f"submitted {batch.jobs} worker jobs ({batch.system}); scheduler at {cluster.scheduler_address}",
              file=sys.stderr, flush=True)
        wait_for_a_worker(client, cluster, batch.system, batch.directory)
        yield client


class Progress:
    """One status line: done / failed / skipped counts and an ETA (off a tty, a line every 2 s)."""

    def __init__(self, total: int, skipped: int, stream=None):
        # sys.stderr as it is now, not at import: a notebook or a test may have replaced it since
        self.total, self.skipped, self.stream = total, skipped, stream or sys.stderr
        self.done = self.failed = self.early = 0
        self.start = time.monotonic()
        self.tty = self.stream.isatty()
        self.last = 0.0

    def update(self, record: dict) -> None:
        self.update_many([record])

    def update_many(self, records: list) -> None:
        for record in records:
            self.done += 1
            if record["status"] in ENDED_EARLY:
                self.early += 1
            elif record["status"] not in COMPLETE:
                self.failed += 1
        todo = self.total - self.skipped
        elapsed = time.monotonic() - self.start
        # the first cases run one per batch (to measure them) and cost more than the rest:
        # no ETA before 2% of the work or 5 cases
        settled = self.done >= max(5, 0.02 * todo) or self.done == todo
        eta = f"{elapsed / self.done * (todo - self.done):5.1f} s" if settled else "  -- "
        width = 30
        filled = int(width * (self.skipped + self.done) / max(self.total, 1))
        line = (f"[{'#' * filled}{'.' * (width - filled)}] {self.skipped + self.done}/{self.total} "
                f"done ({self.early} ended early, {self.failed} failed, {self.skipped} skipped), "
                f"elapsed {elapsed:5.1f} s, ETA {eta}")
        if self.tty:
            self.stream.write("\r" + line)
            if self.done == todo:
                self.stream.write("\n")
        elif self.done == todo or time.monotonic() - self.last > 2.0:
            self.stream.write(line + "\n")
            self.last = time.monotonic()
        self.stream.flush()


#: with --scheduler: say after this many seconds that the scheduler has no worker; stop after
#: NO_WORKER_LIMIT (a scheduler whose workers never come: the run would wait without a word)
NO_WORKER_NOTICE, NO_WORKER_LIMIT = 5.0, 600.0


def wait_for_workers(client, address: str) -> None:
    """Until a worker has joined the existing scheduler at ``address``: said once after
    NO_WORKER_NOTICE; StudyError after NO_WORKER_LIMIT; a Ctrl-C stops the wait."""
    started, said = time.monotonic(), False
    while not client.scheduler_info()["workers"]:
        check()
        waited = time.monotonic() - started
        if not said and waited > NO_WORKER_NOTICE:
            print(f"the dask scheduler at {address} has no worker: waiting for one to join "
                  f"(dask worker {address}) ...", file=sys.stderr, flush=True)
            said = True
        if waited > NO_WORKER_LIMIT:
            raise StudyError(f"no worker joined the dask scheduler at {address} within {NO_WORKER_LIMIT:.0f} s: "
                             f"start its workers (dask worker {address}) and run the same command again")
        time.sleep(0.25)


def kernels_loaded() -> bool:
    """On a worker: are the solver's kernels compiled or loaded from numba's cache?"""
    loop = sys.modules.get("solver.loop")
    return loop is not None and len(loop.integrate.signatures) > 0


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


#: a batch is sized to about this much solver work [s]: long enough that writing its file and
#: the scheduler's round trip are a small part of it, short enough that a killed runner or
#: worker loses little
BATCH_SECONDS = 1.0
#: and holds at most this many cases
MAX_BATCH = 2000


class Batcher:
    """Cuts the pending cases into batches of about BATCH_SECONDS of work, from the measured
    solver time per case (the first batches hold one case each, to measure it). Near the
    end, batches shrink so that every worker has work until the last case. Cases with
    different output requests (a study's cases and its reference runs) never share a batch."""

    def __init__(self, items: list, signature: list, n_workers: int, seconds: float = BATCH_SECONDS):
        self.items, self.signature, self.n_workers, self.seconds = items, signature, n_workers, seconds
        self.next = 0
        self.cases_done = 0
        self.seconds_done = 0.0

    def __bool__(self):
        return self.next < len(self.items)

    def record(self, run_times) -> None:
        finite = [t for t in run_times if t == t]
        self.cases_done += len(finite)
        self.seconds_done += sum(finite)

    def size(self) -> int:
        if self.cases_done < self.n_workers:
            return 1
        per_case = max(self.seconds_done / self.cases_done, 1e-5)
        remaining = len(self.items) - self.next
        size = int(self.seconds / per_case)
        size = min(size, MAX_BATCH, -(-remaining // (2 * self.n_workers)))
        return max(1, size)

    def take(self) -> list:
        start = self.next
        stop = min(start + self.size(), len(self.items))
        sig = self.signature[start]
        end = start + 1
        while end < stop and self.signature[end] == sig:
            end += 1
        self.next = end
        return self.items[start:end]


class KernelCompileError(RuntimeError):
    """The solver's kernels could not be compiled (an installation problem): one line, exit 1."""


def start_kernels():
    """Start filling numba's cache, before the workers load it: in a child process, so that a
    Ctrl-C during the compile interrupts only the child (an interrupt inside LLVM left the
    runner to crash at exit: SIGSEGV, or a second SIGINT) and the runner exits cleanly. It
    runs while the cluster starts; kernels_ready waits for it. Returns (process, start time), or
    (None, start time) where compile_kernels has cached them all before (solver.compile.kernel_cache)."""
    print("loading the solver's kernels ...", file=sys.stderr, flush=True)
    if kernel_cache.is_complete():                     # cached whole: the workers load them
        return None, time.monotonic()
    # SIGINT kills the child outright (SIG_DFL): a KeyboardInterrupt raised inside the compiler
    # could be swallowed there and the compile go on
    code = "import signal; signal.signal(signal.SIGINT, signal.SIG_DFL); " \
           "from solver import compile_kernels; compile_kernels()"
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    return proc, time.monotonic()


#: seconds after which loading the kernels is taken for a compile and said so (from numba's
#: cache they load in about 1.5 s)
COMPILE_NOTICE = 4.0


def kernels_ready(handle) -> None:
    """Wait for start_kernels' child; one line if it failed (KernelCompileError)."""
    proc, started = handle
    if proc is None:
        print("kernels ready (cached)", file=sys.stderr, flush=True)
        return
    try:
        try:
            _, stderr = proc.communicate(timeout=COMPILE_NOTICE)
        except subprocess.TimeoutExpired:              # not from the cache: numba compiles them
            print("compiling them (the first run after an install or an update: about a minute on a 2-core "
                  "machine) ...", file=sys.stderr, flush=True)
            _, stderr = proc.communicate()
    except BaseException:                              # Ctrl-C: the child got it too
        proc.kill()
        proc.wait()
        raise
    if proc.returncode != 0:
        last = (stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
        if proc.returncode == -signal.SIGINT or last == "KeyboardInterrupt":
            raise KeyboardInterrupt         # the Ctrl-C reached the child while the runner ignored it
        raise KernelCompileError(f"compiling the solver's kernels failed: {last}")
    print(f"kernels ready in {time.monotonic() - started:.1f} s", file=sys.stderr, flush=True)


def run_pending(client, study, items: list, signature: list, batches_dir, on_batch,
                progress: Progress | None = None, batch_seconds: float = BATCH_SECONDS, reduce=None,
                expected_workers: int = 0) -> list:
    """Run the cases ``items`` ([case_id, position]) in batches on the client's workers.

    ``on_batch(entry, batch)`` is called in the runner for every batch file written (the
    runner records it in the ledger and streams its "reduced" data, if any, into study.nc).
    ``expected_workers``: the workers the run expects (its batch jobs, some perhaps still in the
    queue), counted from the start in the batch sizes and the tasks in flight. Returns the records of cases whose task
    failed without a file (infrastructure failures: they stay pending)."""
    if not items:
        return []
    n_workers = max(1, len(client.scheduler_info()["workers"]), expected_workers)
    batcher = Batcher(items, signature, n_workers, batch_seconds)
    limit = 2 * n_workers
    futures = as_completed()
    in_flight = {}
    lost = []

    def submit_next():
        batch = batcher.take()
        future = client.submit(run_batch, study.text, study.name, batch, str(batches_dir), reduce, pure=False,
                               key=f"batch-{batch[0][0]}-{len(batch)}-{time.monotonic_ns()}")
        in_flight[future.key] = batch
        futures.add(future)

    for _ in range(limit):
        if batcher:
            check()
            submit_next()
    for future in futures:
        batch = in_flight.pop(future.key)
        try:
            entry = future.result()
        except Exception as err:                       # infrastructure: no file was written
            message = f"task failed: {type(err).__name__}: {err}"
            records = [{"case_id": cid, "status": "error", "message": message, "run_time": float("nan")}
                       for cid, _ in batch]
            lost.extend(records)
            batcher.record([])
        else:
            if entry.get("status") == WRITE_FAILED:    # the disk, not the case: stop the study
                raise CaseWriteError(entry["message"])
            on_batch(entry, batch)
            records = [{"case_id": c, "status": s, "message": m, "run_time": r} for c, s, m, r in entry["cases"]]
            batcher.record([r["run_time"] for r in records])
        if progress:
            progress.update_many(records)
        check()
        if batcher:
            submit_next()
    return lost

