"""Local workers are forked from a forkserver that imported their modules and loaded the
kernels (pipeline.compute.forkserver): they start with what a spawned worker imports and loads (about
1.5 s of CPU each), keep the one-thread environment, ignore Ctrl-C, and never run code older
than the tree."""
import os

import pytest

from pipeline.compute import forkserver
from pipeline.compute.engine import cluster_client

pytestmark = pytest.mark.skipif(forkserver.METHOD != "forkserver", reason="no forkserver on this platform")


def _worker_facts():
    import signal

    import numba

    from pipeline.compute.engine import kernels_loaded
    return {"parent": os.getppid(), "omp": os.environ.get("OMP_NUM_THREADS"),
            "numba_threads": numba.config.NUMBA_NUM_THREADS, "kernels": kernels_loaded(),
            "sigint_ignored": signal.getsignal(signal.SIGINT) == signal.SIG_IGN}


def _facts(workers=1):
    with cluster_client(workers, None) as client:
        return list(client.run(_worker_facts).values())


def test_workers_share_one_forkserver_with_one_thread_each_and_ignore_ctrl_c():
    facts = _facts(2)
    assert len({f["parent"] for f in facts}) == 1 and facts[0]["parent"] != os.getpid()
    assert all(f["omp"] == "1" and f["numba_threads"] == 1 and f["kernels"] for f in facts)
    assert all(f["sigint_ignored"] for f in facts)              # a Ctrl-C stops the runner alone
    assert _facts()[0]["parent"] == facts[0]["parent"]          # a later run reuses the forkserver


def test_an_edit_of_the_source_starts_a_new_forkserver(monkeypatch):
    """Its workers would otherwise run the code the forkserver imported before the edit."""
    before = _facts()[0]["parent"]
    from solver.compile import kernel_cache
    digest = kernel_cache.source_digest
    monkeypatch.setattr(kernel_cache, "source_digest", lambda *a: "edited" + digest(*a))
    after = _facts()[0]["parent"]
    assert after != before
    with pytest.raises(ProcessLookupError):                   # the old one has ended
        os.kill(before, 0)


def test_a_stale_forkserver_that_cannot_be_stopped_gives_spawned_workers(monkeypatch):
    """On a Python without ForkServer._stop (CPython's own, used by its tests), a forkserver
    older than the tree is not used: the workers are spawned and import the tree's code."""
    from multiprocessing import forkserver as mp_forkserver

    from solver.compile import kernel_cache
    running = _facts()[0]["parent"]
    monkeypatch.delattr(type(mp_forkserver._forkserver), "_stop")
    digest = kernel_cache.source_digest
    monkeypatch.setattr(kernel_cache, "source_digest", lambda *a: "edited" + digest(*a))
    facts = _facts()
    assert facts[0]["parent"] == os.getpid() and not facts[0]["kernels"]  # spawned by this process's nanny
    os.kill(running, 0)                                                   # the old forkserver was left alone
