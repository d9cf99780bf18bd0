"""Integrity under hostile files, signals and paths (issue 10): bit flips in every stored file,
planted symlinks, --out on someone else's directory, a full disk at study.nc and at the
figures, scheduler addresses that are not dask, inputs that used to crash."""
import errno
import os
import random
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pipeline.store.ledger import LEDGER
from helpers import ROOT, SMALL_GRID_STUDY as STUDY, assert_same_study, batch_files, run_cli

@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("integrity") / "integrity.toml"
    path.write_text(STUDY)
    return path


@pytest.fixture(scope="module")
def finished(study_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("integrity") / "finished"
    code, _, err = run_cli("run", study_file, "--out", out)
    assert code == 0, err
    return out


def _flip(path: Path, rng, keep_time: bool) -> None:
    st = path.stat()
    data = bytearray(path.read_bytes())
    i = rng.randrange(len(data))
    data[i] ^= 1 << rng.randrange(8)
    path.write_bytes(bytes(data))
    if keep_time:
        os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))


@pytest.mark.parametrize("trial", [0, *(pytest.param(i, marks=pytest.mark.slow) for i in (1, 2, 3, 4, 5))])
def test_a_flipped_bit_anywhere_hangs_nothing_and_changes_no_result(study_file, finished, tmp_path, trial):
    """One random bit flipped in a batch file, the ledger or study.nc, with or without its time
    kept: status and run end within their time bound, and the study comes out the same."""
    _flip_and_check(study_file, finished, tmp_path, trial)


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(6, 66))
def test_sixty_more_random_bit_flips(study_file, finished, tmp_path, trial):
    _flip_and_check(study_file, finished, tmp_path, trial)


def _flip_and_check(study_file, finished, tmp_path, trial):
    rng = random.Random(trial)
    out = tmp_path / f"flip{trial}"
    shutil.copytree(finished, out)
    targets = [*batch_files(out), out / LEDGER, out / "study.nc"]
    victim = targets[trial % len(targets)] if trial < len(targets) else rng.choice(targets)
    _flip(victim, rng, keep_time=trial % 2 == 0)
    for args in (("status", study_file, "--out", out), ("run", study_file, "--out", out, "--no-plots")):
        # (a hang's bound, not the run's time: alone each call takes about 1 s, but sixty of them
        # beside the rest of make test-slow on two cores have taken more than 120 s)
        proc = subprocess.run([sys.executable, "-m", "pipeline", *map(str, args)], cwd=ROOT,
                              capture_output=True, text=True, timeout=900)
        assert proc.returncode == 0, (victim.name, proc.stderr)
        assert "Traceback" not in proc.stderr
    assert_same_study(out, finished)


def test_planted_symlinks_are_never_followed(study_file, finished, tmp_path):
    out = tmp_path / "links"
    shutil.copytree(finished, out)
    victims = {name: tmp_path / f"precious_{name.strip('.')}" for name in
               ("study.nc", "diagnostics.png", ".study.nc.tmp-1-1", "crack_onset.png")}
    for name, target in victims.items():
        target.write_text("precious")
        (out / name).unlink(missing_ok=True)
        (out / name).symlink_to(target)
    os.utime(out / LEDGER)                       # inputs changed: study.nc and the figures are rebuilt
    (out / ".study.nc.inputs").unlink()
    code, _, err = run_cli("run", study_file, "--out", out)
    assert code == 0, err
    assert all(t.read_text() == "precious" for t in victims.values())
    assert not (out / "study.nc").is_symlink() and not (out / "diagnostics.png").is_symlink()
    # a .lock symlink is refused with one line; its target is not truncated
    lock_target = tmp_path / "precious_lock"
    lock_target.write_text("precious")
    (out / ".lock").unlink()
    (out / ".lock").symlink_to(lock_target)
    code, _, err = run_cli("run", study_file, "--out", out, "--no-plots")
    assert code == 74 and err.count("\n") == 1 and "symbolic link" in err, err
    assert lock_target.read_text() == "precious"


def test_out_on_a_foreign_directory_is_refused(study_file, tmp_path):
    mine = tmp_path / "my_documents"
    mine.mkdir()
    (mine / "study.nc").write_text("my own file")
    (mine / ".study.nc.tmp-1-1").write_text("mine too")
    before = sorted(p.name for p in mine.iterdir())
    code, _, err = run_cli("run", study_file, "--out", mine)
    assert code == 2 and err.count("\n") == 1 and "--force" in err, err
    assert sorted(p.name for p in mine.iterdir()) == before and (mine / "study.nc").read_text() == "my own file"
    code, _, err = run_cli("run", study_file, "--out", "/")
    assert code == 2 and "non-empty" in err and not Path("/study.nc").exists()


def _limit(size):
    def apply():
        import resource
        import signal
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))
    return apply


def test_disk_full_at_study_nc_is_exit_74_and_one_line(study_file, finished, tmp_path):
    """Batch files (~25 kB) fit, study.nc does not: exit 74, one line naming study.nc and the
    free space of the results directory's filesystem; the batch files are all kept."""
    out = tmp_path / "full"
    size = max(p.stat().st_size for p in batch_files(finished)) + 2000
    assert (finished / "study.nc").stat().st_size > size
    proc = subprocess.run([sys.executable, "-m", "pipeline", "run", str(study_file), "--out", str(out), "--no-plots"],
                          cwd=ROOT, capture_output=True, text=True, timeout=300, preexec_fn=_limit(size))
    assert proc.returncode == 74, proc.stderr
    assert "Traceback" not in proc.stderr
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith(f"error: cannot write {out / 'study.nc'}") and "MiB free" in last, last
    assert not list(out.glob(".study.nc.tmp-*"))
    code, _, err = run_cli("run", study_file, "--out", out, "--no-plots")
    assert code == 0 and "0 to run" in err


def test_disk_full_at_the_figures_is_exit_74_and_one_line(study_file, finished, tmp_path, monkeypatch, capsys):
    out = tmp_path / "full_figures"
    shutil.copytree(finished, out)
    (out / "diagnostics.png").unlink()
    import matplotlib.figure

    def full(self, fname, *a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", str(fname))
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", full)
    from pipeline.cli import main
    code = main(["run", str(study_file), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 74, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("error: cannot write") and str(out) in last and "MiB free" in last, last
    assert not list(out.glob(".*.png.tmp-*"))


def test_scheduler_addresses_that_are_not_dask_fail_fast(study_file, tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    http = subprocess.Popen([sys.executable, "-m", "http.server", str(port), "--bind", "127.0.0.1"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(50):
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                time.sleep(0.1)
        started = time.monotonic()
        code, _, err = run_cli("run", study_file, "--out", tmp_path / "o", "--scheduler", f"tcp://127.0.0.1:{port}")
        assert code == 2 and err.count("\n") == 1 and "dask scheduler" in err, err
        assert time.monotonic() - started < 30 and not (tmp_path / "o").exists()
    finally:
        http.kill()
        http.wait()
    code, _, err = run_cli("run", study_file, "--out", tmp_path / "o", "--scheduler", "tcp://127.0.0.1:99999")
    assert code == 2 and err.count("\n") == 1 and "tcp://host:port" in err, err


@pytest.mark.parametrize("greeting", [b"SSH-2.0-OpenSSH_9.2\r\n", b"HTTP/1.1 400 Bad Request\r\n\r\n", b"\x01\x02",
                                      b"\xff" * 8 + b"garbage"])
def test_a_server_that_speaks_first_but_not_dask_is_one_line_and_nothing_written(study_file, tmp_path, greeting):
    """A server that greets, or sends a few bytes and closes, passed the probe: the runner wrote
    its lock, batches/ and study.toml, then distributed read the greeting as a frame length and
    asked for exabytes. The probe now reads dask's handshake."""
    import threading
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    server.settimeout(0.1)
    stop = threading.Event()

    def greet():
        while not stop.is_set():
            try:
                connection, _ = server.accept()
            except OSError:
                continue
            connection.sendall(greeting)
            connection.close()
    thread = threading.Thread(target=greet, daemon=True)
    thread.start()
    try:
        address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
        code, _, err = run_cli("run", study_file, "--out", tmp_path / "o", "--scheduler", address)
        assert code == 2 and err.count("\n") == 1 and "dask scheduler" in err, err
        assert not (tmp_path / "o").exists()
    finally:
        stop.set()
        thread.join(timeout=10)
        server.close()


def test_a_dask_scheduler_with_no_worker_is_said_and_ends_in_one_line(study_file, tmp_path, monkeypatch):
    """A scheduler that has no worker: the run printed nothing after 'kernels ready', for ever.
    It now says so, then stops with one line after NO_WORKER_LIMIT (here shortened)."""
    from pipeline.compute import engine
    monkeypatch.setattr(engine, "NO_WORKER_NOTICE", 0.5)
    monkeypatch.setattr(engine, "NO_WORKER_LIMIT", 3.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                  "--port", str(port), "--dashboard-address", "127.0.0.1:0"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while True:                                   # the state: the scheduler accepts
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                assert scheduler.poll() is None and time.monotonic() < deadline, scheduler.communicate()
                time.sleep(0.1)
        code, _, err = run_cli("run", study_file, "--out", tmp_path / "o", "--scheduler", f"tcp://127.0.0.1:{port}",
                               "--no-plots")
        assert code == 2 and "has no worker: waiting for one to join" in err, err
        last = err.strip().splitlines()[-1]
        assert last.startswith("error: no worker joined the dask scheduler") and "Traceback" not in err, err
    finally:
        scheduler.kill()
        scheduler.wait()


def test_inputs_that_used_to_crash(tmp_path):
    study = tmp_path / "count.toml"
    study.write_text(STUDY.replace('times = { unit = "t_sc", step = 0.25, stop = 0.5 }',
                                   'times = { unit = "stage", count = 3.0 }').replace('end = "last_output"', ""))
    code, _, err = run_cli("run", study, "--out", tmp_path / "count", "--dry-run")
    assert code == 0, err
    latin = tmp_path / "latin.toml"
    latin.write_bytes(STUDY.replace("integrity tests", "d\xe9j\xe0 vu").encode("latin-1"))
    code, _, err = run_cli("run", latin, "--out", tmp_path / "latin")
    assert code == 2 and err.count("\n") == 1 and "UTF-8" in err and not (tmp_path / "latin").exists()


@pytest.mark.parametrize("change, words", [
    ("[base]\nL = 1e308", "L = 1e+308 lies outside"),
    ("[base]\nhi = 1e308", "hi = 1e+308 lies outside"),
    ("[base]\nK = 1e300", "K = 1e+300 lies outside"),
    ("[base]\nhi = 1e-300", "hi = 1e-300 lies outside"),
    ("[base]\nrho_w = 1e308", "rho_w = 1e+308 lies outside"),
    ("[base]\nL = 2.0\nhi = 3.0", "thicker than the plate"),
])
def test_values_far_outside_the_physical_ranges_are_refused(tmp_path, change, words):
    study = tmp_path / "extreme.toml"
    text = STUDY.replace("[base]", change, 1)
    if "hi =" in change:                               # hi leaves the grid for [base]
        text = text.replace("hi = [0.3, 0.5]\n", "")
    study.write_text(text)
    started = time.monotonic()
    code, _, err = run_cli("run", study, "--out", tmp_path / "x")
    assert code == 2 and err.count("\n") == 1 and words in err and "accept_extreme_values" in err, err
    assert time.monotonic() - started < 20 and not (tmp_path / "x").exists()


def test_output_that_cannot_fit_is_refused_before_anything_is_written(tmp_path):
    study = tmp_path / "huge_output.toml"
    study.write_text(STUDY.replace('times = { unit = "t_sc", step = 0.25, stop = 0.5 }',
                                   'times = { unit = "stage", count = 100000 }')
                     .replace("x_points = 11", "x_points = 100001").replace('end = "last_output"', ""))
    code, _, err = run_cli("run", study, "--out", tmp_path / "x")
    assert code == 2 and err.count("\n") == 1 and "GiB of memory" in err, err
    assert not (tmp_path / "x").exists()


def test_results_directory_removed_mid_run_stops_the_runner(tmp_path):
    """make clean (rm -rf results) while a study runs: the runner stops with exit 74 and one
    line, rather than append to a ledger a second runner may be using."""
    study = tmp_path / "long.toml"
    study.write_text(STUDY.replace("V = [3.0, 5.0]", "V = [2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5]")
                     .replace("Nmod = 6", "Nmod = 30"))
    out = tmp_path / "results" / "long"
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(study), "--out", str(out), "--no-plots",
                             "--batch-seconds", "0.01"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    end = time.monotonic() + 120
    while not list((out / "batches").glob("*.nc")) if (out / "batches").exists() else True:
        assert time.monotonic() < end and proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    while (tmp_path / "results").exists():           # as rm -rf run again: the workers may add a
        shutil.rmtree(tmp_path / "results", ignore_errors=True)   # batch file while it removes
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 74, err
    assert "Traceback" not in err and err.strip().splitlines()[-1].startswith("error: the results directory"), err


#: runs the pipeline with the results directory removed just before the first ledger append,
#: after the runner last looked: the race of make clean with a batch coming back
_REMOVED_BEFORE_APPEND = r"""
import runpy, shutil, sys
import pipeline.store.ledger as L
original = L.Ledger.append
def append(self, entry):
    while self.path.parent.exists():     # as rm -rf run again: a worker may add a batch file meanwhile
        shutil.rmtree(self.path.parent, ignore_errors=True)
    return original(self, entry)
L.Ledger.append = append
sys.argv = ["pipeline", *sys.argv[1:]]
runpy.run_module("pipeline", run_name="__main__")
"""


def test_results_directory_removed_just_before_a_ledger_append_says_so(study_file, tmp_path):
    """The ledger write fails because the directory went (not the disk): the one line says the
    directory was removed, as when the runner sees it gone first."""
    out = tmp_path / "removed"
    last = _last_line_of_a_patched_run(_REMOVED_BEFORE_APPEND, study_file, out)
    assert last.startswith(f"error: the results directory {out} was removed or replaced"), last


def _last_line_of_a_patched_run(script: str, study_file, out) -> str:
    """Run the study under a script that patches the ledger; it must stop with exit 74 and one
    line, no traceback: that line."""
    proc = subprocess.run([sys.executable, "-c", script, "run", str(study_file), "--out", str(out), "--no-plots"],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 74, proc.stderr
    assert "Traceback" not in proc.stderr
    return proc.stderr.strip().splitlines()[-1]


#: runs the pipeline with every ledger append failing as on a full disk, after half the line
#: reached the file (a torn write)
_TORN_LEDGER = r"""
import errno, os, runpy, sys
import pipeline.store.ledger as L
real_write = os.write
def torn(fd, data):
    real_write(fd, bytes(data)[: len(data) // 2])
    raise OSError(errno.ENOSPC, "No space left on device")
original = L.Ledger.append
def append(self, entry):
    os.write = torn
    try:
        return original(self, entry)
    finally:
        os.write = real_write
L.Ledger.append = append
sys.argv = ["pipeline", *sys.argv[1:]]
runpy.run_module("pipeline", run_name="__main__")
"""


def test_disk_full_at_the_ledger_is_exit_74_one_line_and_no_torn_line(study_file, finished, tmp_path):
    from pipeline.store.ledger import Ledger
    out = tmp_path / "full_ledger"
    last = _last_line_of_a_patched_run(_TORN_LEDGER, study_file, out)
    assert last.startswith(f"error: cannot write {out / LEDGER}") and "MiB free" in last, last
    assert "finished cases are kept" in last
    ledger = Ledger.load(out)
    assert ledger.bad_lines == 0 and not ledger.entries            # cut back, not torn
    kept = batch_files(out)                                        # the batches written are kept
    assert kept
    import netCDF4
    done = 0
    for path in kept:
        with netCDF4.Dataset(path) as nc:
            done += len(nc.dimensions["case"])
    code, _, err = run_cli("run", study_file, "--out", out, "--no-plots")
    assert code == 0, err
    for path in kept:                                              # read back, not recomputed
        assert f"batch file {path.name} was not in the ledger" in err
    assert f"4 cases, {4 - done} to run, {done} already done" in err
    assert_same_study(out, finished)
