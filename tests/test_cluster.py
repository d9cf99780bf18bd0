"""Scale-out: the same study on a real dask cluster (a `dask scheduler` and two `dask worker`
processes on 127.0.0.1) gives the LocalCluster's results bit for bit, and the stored reference's
within its spread. About 30 s, so it runs in CI."""
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import xarray as xr

from reference import assert_matches_reference
from helpers import ROOT, assert_same_study, run_cli

DASK = str(Path(sys.executable).with_name("dask"))


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def cluster(tmp_path):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    logs = [open(tmp_path / f"{name}.log", "w") for name in ("scheduler", "worker0", "worker1")]
    procs = [subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stdout=logs[0], stderr=subprocess.STDOUT, env=env,
                              start_new_session=True)]
    end = time.monotonic() + 60
    while True:                                          # wait for the scheduler to listen
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            break
        except OSError:
            assert time.monotonic() < end, (tmp_path / "scheduler.log").read_text()
            time.sleep(0.2)
    for i in range(2):
        procs.append(subprocess.Popen([DASK, "worker", address, "--nthreads", "1", "--nworkers", "1",
                                       "--no-dashboard", "--name", f"w{i}"], stdout=logs[i + 1],
                                      stderr=subprocess.STDOUT, env=env, cwd=ROOT, start_new_session=True))
    try:
        yield address
    finally:
        # the test is over: kill each process group (a dask worker's nanny and its worker
        # process) at once; a graceful shutdown took 8 s of teardown
        for proc in procs:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        for proc in procs:
            proc.wait(timeout=30)
        for log in logs:
            log.close()


@pytest.mark.slow   # issue 35: make test within 5 min; kept in make test-slow
def test_study_on_a_real_dask_cluster_matches_local(cluster, tmp_path):
    out = tmp_path / "on_cluster"
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out, "--scheduler", cluster,
                            "--no-plots")
    assert code == 0, err
    assert "4 cases, 4 to run" in err
    assert_matches_reference(out / "study.nc")
    # on one machine the scheduler does not matter: the LocalCluster's run is the same bit for bit
    local = tmp_path / "local"
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", local, "--workers", "2",
                            "--no-plots")
    assert code == 0, err
    assert_same_study(out, local)


def _listening(pids: set) -> list:
    """(address, port) of every TCP socket in LISTEN that one of the processes holds (Linux /proc)."""
    inodes = {}
    for pid in pids:
        try:
            for fd in os.listdir(f"/proc/{pid}/fd"):
                target = os.readlink(f"/proc/{pid}/fd/{fd}")
                if target.startswith("socket:["):
                    inodes[target[8:-1]] = pid
        except OSError:
            continue
    found = []
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            local, state, inode = fields[1], fields[3], fields[9]
            if state == "0A" and inode in inodes:                 # 0A: LISTEN
                address, port = local.split(":")
                raw = bytes.fromhex(address)
                words = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
                found.append((socket.inet_ntop(socket.AF_INET if width == 8 else socket.AF_INET6, words),
                              int(port, 16)))
    return found


def _tree(root: int) -> set:
    pids, grew = {root}, True
    while grew:
        grew = False
        for entry in os.listdir("/proc"):
            if entry.isdigit() and int(entry) not in pids:
                try:
                    parent = int(Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[1])
                except (OSError, IndexError, ValueError):
                    continue
                if parent in pids:
                    pids.add(int(entry))
                    grew = True
    return pids


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's /proc")
def test_a_local_run_listens_on_the_loopback_only(tmp_path):
    """Issue 40: the scheduler, the workers and the dashboard of a local run bind 127.0.0.1 (the
    dashboard listened on 0.0.0.0 before). Sampled while the run's workers are up."""
    study = tmp_path / "listen.toml"
    study.write_text('description = "listeners"\n[base]\nNmod = 4\n[grid]\nV = [1.0, 1.5, 2.0, 2.5, 3.0, 3.5]\n'
                     '[output]\nfields = []\n[plots]\nkinds = []\n')
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(study), "--out", str(tmp_path / "out"),
                             "--workers", "2", "--batch-seconds", "0.01"], cwd=ROOT, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    seen, end = set(), time.monotonic() + 120
    while proc.poll() is None and time.monotonic() < end:
        seen.update(_listening(_tree(proc.pid)))
        time.sleep(0.05)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    hosts = {host for host, _ in seen}
    assert len(seen) >= 3, seen                 # the scheduler, its dashboard, the workers
    assert hosts <= {"127.0.0.1"}, seen
