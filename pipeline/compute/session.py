"""The runner's dask session, opened only when there is work (dask is imported then)."""
from __future__ import annotations

from collections import deque
from contextlib import ExitStack
from pathlib import Path

from ..common.interrupts import check
from .batch_system import JOBS_DIR, Jobs


def jobs_directory(out_dir: Path) -> Path:
    """Where a run on batch jobs keeps their logs and the workers' TLS files."""
    return Path(out_dir).absolute() / JOBS_DIR


def session_for(options, workers: int, out_dir: Path) -> "Session":
    """The session a run's options ask for (pipeline.run.RunOptions): local workers, an
    existing scheduler, or a batch system's jobs."""
    batch = None
    if options.cluster:
        batch = Jobs(options.cluster, options.jobs, jobs_directory(out_dir))
    return Session(workers, options.scheduler, options.tls, batch)


class Session:
    """The runner's dask session: the cluster starts on first use (a rerun with nothing to do
    starts none), the kernels are loaded on every worker before the first case, and the same
    workers then read the batch files for the combine."""

    def __init__(self, workers: int, scheduler: str | None, tls: tuple | None = None, batch=None):
        self.workers, self.scheduler, self.tls, self.batch = workers, scheduler, tls, batch
        self._stack = None
        self.client = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._stack is not None:
            self._stack.close()
            self._stack = None
            self.client = None

    @property
    def is_open(self) -> bool:
        return self.client is not None

    def open(self):
        if self.client is None:

            from .engine import cluster_client, kernels_ready, start_kernels, wait_for_workers, warm_workers
            compiling = start_kernels()                  # alongside the cluster's start
            stack = ExitStack()
            try:
                try:
                    self.client = stack.enter_context(cluster_client(self.workers, self.scheduler, self.tls,
                                                                    self.batch))
                except BaseException:
                    if compiling[0] is not None:
                        compiling[0].kill()
                        compiling[0].wait()
                    raise
                kernels_ready(compiling)
                check()
                if self.scheduler:
                    wait_for_workers(self.client, self.scheduler)
                warm_workers(self.client, one_at_a_time=bool(self.scheduler or self.batch))
                check()
            except BaseException:
                stack.close()
                self.client = None
                raise
            self._stack = stack
        return self.client

    def run(self, study, items, signature, batches_dir, on_batch, total: int, skipped: int,
            batch_seconds: float, reduce=None) -> list:
        from .engine import Progress, run_pending
        client = self.open()
        return run_pending(client, study, items, signature, batches_dir, on_batch, Progress(total, skipped),
                           batch_seconds, reduce, expected_workers=self.batch.jobs if self.batch else 0)

    def mapper(self):
        """map(function, [(key, args)]) on the workers, yielding (key, result) in the order of
        the tasks (so study.nc's layout does not depend on which worker is faster), with at
        most 2 tasks per worker submitted ahead: the runner holds O(one batch)."""
        client = self.open()
        n_workers = max(1, len(client.scheduler_info()["workers"]), self.batch.jobs if self.batch else 0)

        def mapper(function, tasks):
            queue, window = deque(tasks), deque()

            def submit():
                key, args = queue.popleft()
                window.append((key, client.submit(function, *args, pure=False)))

            while queue and len(window) < 2 * n_workers:
                submit()
            while window:
                key, future = window.popleft()
                result = future.result()
                future.release()
                if queue:
                    submit()
                yield key, result
        return mapper
