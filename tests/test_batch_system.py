"""Issue 40: a study's workers as batch jobs (``--cluster slurm|pbs --jobs N``; pipeline/compute/batch_system.py).

Default suite: the walltime and lifetime arithmetic, the PBS job script as dask-jobqueue renders
it, and every wrong or unreachable batch system refused in one line, exit 2, nothing written.

``make test-cluster`` (marker ``cluster``): a one-node SLURM on this machine (tests/cluster/slurm.sh,
from Debian's packages) runs a study through ``--cluster slurm``, with one worker job cancelled
mid-study, with workers that retire at their lifetime, and interrupted by a Ctrl-C; each completes
with nothing lost or counted twice and study.nc bit for bit as a local run's. A stand-in PBS
(qsub runs the job script as a process) takes the same code path end to end.
"""
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers import JOBS_STUDY, ROOT, assert_same_study, listening_sockets, process_tree, run_cli
from pipeline.store.ledger import Ledger

pytest.importorskip("dask_jobqueue")

def _study(tmp_path, name="jobs", text=JOBS_STUDY):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


# --- default suite: arithmetic, rendering, refusals -------------------------------------------

def test_walltimes_and_the_lifetime_below_them():
    from pipeline.compute.batch_system import lifetime_arguments, walltime_seconds
    assert walltime_seconds("00:30:00") == 1800
    assert walltime_seconds("1-02:00:00") == 93600
    assert walltime_seconds("45") == 2700                 # minutes alone, as sbatch -t reads them
    assert walltime_seconds("2:20") == 140                # MM:SS
    assert walltime_seconds("0-12") == 12 * 3600         # D-HH: the hours of a day
    assert walltime_seconds("1-02:30") == 95400          # D-HH:MM
    assert walltime_seconds("2-0") == 2 * 86400
    assert walltime_seconds("300", "pbs") == 300         # PBS reads a bare number as seconds
    assert walltime_seconds("01:30:00", "pbs") == 5400
    assert lifetime_arguments("1-02:30") == ["--lifetime", "81090s", "--lifetime-stagger", "4770s"]
    assert lifetime_arguments("01:00:00") == ["--lifetime", "3060s", "--lifetime-stagger", "180s"]
    lifetime, stagger = (int(a[:-1]) for a in lifetime_arguments("00:30:00")[1::2])
    assert lifetime + stagger < 1800 * 0.95              # retired before the job is killed
    from pipeline.common.errors import StudyError
    for bad, system in (("1h", "slurm"), ("", "slurm"), ("0:00", "slurm"), ("a:b", "slurm"), ("00:00:01", "slurm"),
                        ("0-0", "slurm"), ("1-02:00:00", "pbs"), ("9", "pbs"), ("0:09", "slurm")):
        with pytest.raises(StudyError, match="walltime"):
            walltime_seconds(bad, system)


def test_the_pbs_job_script_as_dask_jobqueue_renders_it(tmp_path):
    """--cluster pbs goes through the code path of --cluster slurm; no PBS here, so its job script
    is checked as rendered: the site's queue, account, walltime and memory from dask's jobqueue
    configuration, one single-threaded worker, TLS, a lifetime below the walltime."""
    import dask
    from distributed.security import Security

    from pipeline.compute.batch_system import job_script
    config = {"jobqueue.pbs.queue": "short", "jobqueue.pbs.account": "ice-lab",
              "jobqueue.pbs.walltime": "02:00:00", "jobqueue.pbs.memory": "4GB"}
    with dask.config.set(config):
        script = job_script("pbs", tmp_path / "jobs", Security.temporary())
    lines = script.splitlines()
    assert lines[0] == "#!/usr/bin/env bash"
    for directive in ("#PBS -q short", "#PBS -A ice-lab", "#PBS -l walltime=02:00:00", "#PBS -N floe-impact"):
        assert directive in lines, script
    assert "#PBS -l select=1:ncpus=1:mem=3815MB" in lines, script                   # 4 GB in MiB
    for export in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        assert f"export {export}=1" in lines
    command = lines[-1]
    assert " tls://<scheduler-address>:8786 " in command
    assert "--nthreads 1" in command and "--protocol tls://" in command
    assert "--no-dashboard --dashboard-address 127.0.0.1:0" in command     # nothing open over HTTP
    assert "--lifetime 6120s --lifetime-stagger 360s" in command            # 0.85 and 0.05 of 2 h
    for flag in ("--tls-ca-file", "--tls-cert", "--tls-key"):
        assert flag in command


def test_the_slurm_job_script(tmp_path):
    import dask

    from pipeline.compute.batch_system import job_script
    with dask.config.set({"jobqueue.slurm.queue": "compute", "jobqueue.slurm.walltime": "00:30:00"}):
        script = job_script("slurm", tmp_path / "jobs")
    assert "#SBATCH -p compute" in script and "#SBATCH -t 00:30:00" in script
    assert "#SBATCH --cpus-per-task=1" in script
    assert f"#SBATCH -e {tmp_path / 'jobs'}" in script                  # its logs beside the results
    assert "--lifetime 1530s --lifetime-stagger 90s" in script


def _fake_commands(directory: Path, **scripts) -> dict:
    """Executables of these names and bodies in ``directory``, and an environment whose PATH
    finds them first."""
    directory.mkdir(exist_ok=True)
    for name, body in scripts.items():
        path = directory / name
        path.write_text("#!/usr/bin/env bash\n" + body + "\n")
        path.chmod(0o755)
    return {"PATH": f"{directory}{os.pathsep}{os.environ['PATH']}"}


def _refused(tmp_path, monkeypatch, *args, env=None, match):
    for key, value in (env or {}).items():
        monkeypatch.setenv(key, value)
    out = tmp_path / "out"
    code, _, err = run_cli("run", _study(tmp_path), "--out", out, "--no-plots", *args)
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert code == 2, err
    assert len(lines) == 1 and match in lines[0], err
    assert not out.exists(), "a refused run wrote into its results directory"
    return lines[0]


UNREACHABLE = 'echo "squeue: error: Unable to contact slurm controller (connect failure)" >&2; exit 1'


@pytest.mark.parametrize("args, scripts, match", [
    (["--cluster", "slurm"], {}, "--cluster needs --jobs N"),
    (["--cluster", "slurm", "--jobs", "0"], {}, "--cluster needs --jobs N"),
    (["--jobs", "2"], {}, "--jobs is for --cluster"),
    (["--cluster", "slurm", "--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], {}, "not both"),
    (["--cluster", "lsf", "--jobs", "2"], {}, "invalid choice: 'lsf'"),
    (["--cluster", "slurm", "--jobs", "2"], {"squeue": UNREACHABLE, "sbatch": "exit 0"},
     "the batch system does not answer (squeue -h -o %i: squeue: error: Unable to contact slurm controller"),
    (["--cluster", "slurm", "--jobs", "2"],
     {"squeue": "exit 0", "sbatch": 'echo "sbatch: error: invalid partition specified: nope" >&2; exit 1'},
     "sbatch refuses the worker job: sbatch: error: invalid partition specified: nope"),
    (["--cluster", "pbs", "--jobs", "2"], {"qsub": "exit 0", "qstat": 'echo "Connection refused" >&2; exit 2'},
     "the batch system does not answer (qstat: Connection refused)"),
])
def test_a_wrong_or_unreachable_batch_system_is_one_line(tmp_path, monkeypatch, args, scripts, match):
    env = _fake_commands(tmp_path / "bin", **scripts) if scripts else None
    _refused(tmp_path, monkeypatch, *args, env=env, match=match)


def test_a_dry_run_checks_the_batch_system_and_submits_nothing(tmp_path, monkeypatch):
    """--dry-run with --cluster: the checks run (sbatch --test-only gets the job script on its
    stdin), nothing is submitted, nothing is written."""
    calls = tmp_path / "calls"
    env = _fake_commands(tmp_path / "bin", squeue="exit 0",
                         sbatch=f'echo "sbatch $*" >> {calls}; cat > {calls}.script; exit 0')
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    code, out, err = run_cli("run", _study(tmp_path), "--out", tmp_path / "out", "--cluster", "slurm", "--jobs", "4",
                             "--dry-run")
    assert code == 0, err
    assert "nothing was run (--dry-run)" in out
    assert calls.read_text() == "sbatch --test-only\n"
    assert "--lifetime" in Path(f"{calls}.script").read_text()
    assert not (tmp_path / "out").exists()


def test_no_batch_system_on_path(tmp_path, monkeypatch):
    python_only = tmp_path / "python-only"
    python_only.mkdir()
    (python_only / "python").symlink_to(sys.executable)
    _refused(tmp_path, monkeypatch, "--cluster", "slurm", "--jobs", "2", env={"PATH": str(python_only)},
             match="--cluster slurm: sbatch is not on PATH; run on the cluster's login node")


def test_a_bad_walltime_in_the_configuration(tmp_path, monkeypatch):
    env = _fake_commands(tmp_path / "bin", squeue="exit 0", sbatch="exit 0")
    import dask
    with dask.config.set({"jobqueue.slurm.walltime": "two hours"}):
        _refused(tmp_path, monkeypatch, "--cluster", "slurm", "--jobs", "2", env=env,
                 match="walltime 'two hours' is not a slurm walltime")


def test_a_submission_the_batch_system_refuses_is_one_line_and_leaves_no_credentials(tmp_path, monkeypatch):
    """sbatch --test-only accepts the job script, the real submission is refused (an account,
    QOS or job-count limit that the test does not check): one line with sbatch's own, exit 2,
    no lock left, and no TLS key in jobs/ (it used to wait for ever, resubmitting every 2 s)."""
    refusal = "sbatch: error: Batch job submission failed: Invalid account or account/partition combination specified"
    env = _fake_commands(tmp_path / "bin", squeue="exit 0", scancel="exit 0",
                         sbatch=f'if [[ " $* " == *" --test-only "* ]]; then echo "sbatch: Job 7 to start at now" >&2; '
                                f'exit 0; fi; cat > /dev/null; echo "{refusal}" >&2; exit 1')
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    out = tmp_path / "out"
    started = time.monotonic()
    code, _, err = run_cli("run", _study(tmp_path), "--out", out, "--no-plots", "--cluster", "slurm", "--jobs", "2")
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert code == 2 and len(lines) == 1 and "Invalid account" in lines[0], err
    assert "Traceback" not in err and "never retrieved" not in err and "submitted 2" not in err, err
    assert time.monotonic() - started < 60
    assert not (out / "jobs").exists() and not list(out.rglob(".dask-jobqueue*"))
    from pipeline.store.lock import refuse_if_locked
    refuse_if_locked(out)                                 # released: the same command may run again


def _credentials(directory: Path) -> list:
    """A fresh CA file, certificate and key (dask's Security.temporary) as files."""
    from distributed.security import Security
    security = Security.temporary()
    directory.mkdir(exist_ok=True)
    paths = []
    for name, text in (("ca.pem", security.tls_ca_file), ("cert.pem", security.tls_client_cert),
                       ("key.pem", security.tls_client_key)):
        (directory / name).write_text(text)
        paths.append(directory / name)
    return paths


@pytest.mark.parametrize("spoil, match", [
    (lambda ca, cert, key: ca.write_text(""), "--tls-ca-file {ca} holds no CA certificate"),
    (lambda ca, cert, key: ca.write_text("garbage\n"), "--tls-ca-file {ca} holds no CA certificate"),
    (lambda ca, cert, key: key.write_text("garbage\n"), "are not a certificate and its private key"),
    (lambda ca, cert, key: cert.write_text(""), "are not a certificate and its private key"),
    (lambda ca, cert, key: (ca.unlink(), ca.mkdir()), "--tls-ca-file {ca} is not a file"),
    (lambda ca, cert, key: key.unlink(), "--tls-key {key} does not exist"),
])
def test_tls_files_that_are_not_credentials_are_named_in_one_line(tmp_path, monkeypatch, spoil, match):
    """Empty or garbage credential files were reported as 'cannot reach the dask scheduler', a
    directory as the CA file as 'does not exist'."""
    ca, cert, key = _credentials(tmp_path / "tls")
    spoil(ca, cert, key)
    _refused(tmp_path, monkeypatch, "--scheduler", "tls://127.0.0.1:9", "--tls-ca-file", ca, "--tls-cert", cert,
             "--tls-key", key, match=match.format(ca=ca, cert=cert, key=key))


def test_the_environments_scheduler_gives_way_to_cluster(tmp_path, monkeypatch):
    """DASK_SCHEDULER_ADDRESS is a default: with --cluster on the line the jobs are the workers
    (it was refused as 'give --cluster or --scheduler, not both')."""
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", "tcp://127.0.0.1:9")
    env = _fake_commands(tmp_path / "bin", squeue="exit 0",
                         sbatch='echo "sbatch: Job 7 to start at now" >&2; exit 0')
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    code, _, err = run_cli("run", _study(tmp_path), "--out", tmp_path / "out", "--cluster", "slurm", "--jobs", "2",
                           "--dry-run")
    assert code == 0 and "not both" not in err, err


def test_importing_dask_jobqueue_leaves_the_runners_ctrl_c_alone(monkeypatch):
    """dask_jobqueue 0.9 sets SIGINT to sys.exit() on import: a Ctrl-C ended a --cluster run with
    exit 0 and no message. The runner's handler must survive the import."""
    import signal

    from pipeline.compute import batch_system
    from pipeline.common import interrupts
    for name in [m for m in sys.modules if m.split(".")[0] == "dask_jobqueue"]:
        monkeypatch.delitem(sys.modules, name)                  # imported afresh, restored after
    previous = signal.signal(signal.SIGINT, interrupts._on_sigint)
    try:
        batch_system._cluster_class("slurm")
        assert signal.getsignal(signal.SIGINT) is interrupts._on_sigint
    finally:
        signal.signal(signal.SIGINT, previous)


def test_without_the_hpc_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask_jobqueue", None)                  # import fails
    _refused(tmp_path, monkeypatch, "--cluster", "slurm", "--jobs", "2",
             match="--cluster slurm needs dask-jobqueue: pip install 'floe-impact[hpc]'")


# --- make test-cluster: a real SLURM, and a stand-in PBS -----------------------------------------

def _slurm_is_up() -> bool:
    if shutil.which("sinfo") is None:
        return False
    answer = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True)
    return answer.returncode == 0 and any(state in answer.stdout for state in ("idle", "mix", "alloc"))


slurm = pytest.mark.skipif(not _slurm_is_up(), reason="no SLURM answers here (make test-cluster starts one)")


def _our_jobs() -> list:
    answer = subprocess.run(["squeue", "-h", "-n", "floe-impact", "-o", "%i %T"], capture_output=True, text=True)
    return [line.split() for line in answer.stdout.splitlines() if line.strip()]


def _job_processes(job: str) -> list:
    """The pids of the processes of a SLURM job (SLURM_JOB_ID in their environment; root reads it)."""
    pids = []
    for entry in os.listdir("/proc"):
        try:
            environ = Path(f"/proc/{entry}/environ").read_bytes().split(b"\0") if entry.isdigit() else []
        except OSError:
            continue
        if f"SLURM_JOB_ID={job}".encode() in environ:
            pids.append(int(entry))
    assert pids, f"no process of job {job}"
    return pids


def _assert_no_jobs_left(timeout=60):
    """Every job of the run cancelled: listed COMPLETING a while (slurmd ends its processes),
    then gone."""
    end = time.monotonic() + timeout
    while _our_jobs() and time.monotonic() < end:
        time.sleep(0.5)
    assert _our_jobs() == [], "jobs left in the queue after the run"


def _start(study_file, out, *args, env=None):
    return subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(study_file), "--out", str(out),
                             "--no-plots", *map(str, args)], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            env={**os.environ, **(env or {})})


def _wait_for_entries(out: Path, n: int, proc, timeout=180):
    end = time.monotonic() + timeout
    while len(Ledger.load(out).entries) < n:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < end, "the study did not progress"
        time.sleep(0.1)


def _assert_each_case_once(study_file, out):
    """The ledger records every case of the study exactly once (nothing lost, nothing twice)."""
    from pipeline.study.study_files import load_study
    study = load_study(study_file)
    recorded = [row[0] for entry in Ledger.load(out).entries for row in entry["cases"]]
    assert sorted(recorded) == sorted(study.run_ids)


@pytest.fixture(scope="module")
def local_reference(tmp_path_factory):
    """The same study on local workers: what every batch-system run must equal bit for bit."""
    tmp = tmp_path_factory.mktemp("local")
    study_file = _study(tmp)
    code, _, err = run_cli("run", study_file, "--out", tmp / "out", "--no-plots", "--workers", "2")
    assert code == 0 or "did not end ok" in err, err
    return tmp / "out"


@pytest.mark.cluster
@slurm
def test_a_cancelled_slurm_job_loses_nothing(tmp_path, local_reference):
    """scancel of one worker job mid-study (a pre-emption): its batch runs again on the other
    worker, a new job replaces it, the study completes; the ledger holds every case once and
    study.nc equals the local run's bit for bit. While the study runs, a dask client without the
    run's TLS credentials is refused by its scheduler."""
    study_file = _study(tmp_path)
    out = tmp_path / "out"
    proc = _start(study_file, out, "--cluster", "slurm", "--jobs", "2", "--batch-seconds", "0.2")
    _wait_for_entries(out, 4, proc)
    jobs = _our_jobs()
    assert len(jobs) == 2 and all(state == "RUNNING" for _, state in jobs), jobs
    _assert_no_listener_answers_a_stranger(proc.pid)
    # the other job's worker held (SIGSTOP) until a replacement is submitted: the study cannot end
    # first (it did once its cases took less than the 2 s lost-worker timeout and the 2 s scale)
    held = _job_processes(jobs[1][0])
    subprocess.run(["scancel", jobs[0][0]], check=True)
    for pid in held:
        os.kill(pid, signal.SIGSTOP)
    try:
        end = time.monotonic() + 60
        while not {job for job, _ in _our_jobs()} - {job for job, _ in jobs}:
            assert proc.poll() is None and time.monotonic() < end, ("no job replaced the cancelled one", _our_jobs())
            time.sleep(0.2)
    finally:
        for pid in held:
            os.kill(pid, signal.SIGCONT)
    _assert_a_client_without_credentials_is_refused(out)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode in (0, 1), err
    assert "submitted 2 worker jobs (slurm); scheduler at tls://" in err
    _assert_each_case_once(study_file, out)
    assert_same_study(out, local_reference)
    _assert_no_jobs_left()
    assert not list((out / "jobs").glob(".dask-jobqueue.worker.*")), "TLS keys left behind"


def _assert_no_listener_answers_a_stranger(runner: int):
    """Every socket the run listens on (the runner's, and its workers' in their jobs) is either on
    127.0.0.1 (the dashboard) or speaks only TLS to holders of the run's certificates: a plain
    HTTP request gets no answer, where a dashboard would serve its pages."""
    import socket

    pids = process_tree(runner)
    for worker in subprocess.run(["pgrep", "-f", "distributed.cli.dask_worker"], capture_output=True,
                                 text=True).stdout.split():
        pids |= process_tree(int(worker))
    listeners = set(listening_sockets(pids))
    beyond = {(host, port) for host, port in listeners if host != "127.0.0.1"}
    assert any(host == "127.0.0.1" for host, _ in listeners), listeners        # the dashboard
    assert len(beyond) >= 3, listeners                # the scheduler; each worker and its nanny
    for host, port in beyond:
        with socket.create_connection(("127.0.0.1" if host in ("0.0.0.0", "::") else host, port), timeout=5) as sock:
            sock.settimeout(3)
            sock.sendall(b"GET / HTTP/1.0\r\n\r\n")
            try:
                answer = sock.recv(64)
            except (socket.timeout, ConnectionResetError):
                answer = b""
        assert not answer.startswith(b"HTTP/"), (host, port, answer)


def _assert_a_client_without_credentials_is_refused(out: Path):
    """A dask client that reaches the run's scheduler without its credentials gets nowhere:
    in plain TCP, or in TLS with credentials of its own (a stranger's fresh CA). The address is
    read from the log of a job whose worker registered (a job cancelled before its worker did,
    and the order in which the logs are listed, leave others without it)."""
    logs = [path.read_text() for path in sorted((out / "jobs").glob("*.err"))]
    address = next((word for log in logs for line in log.splitlines() if "Registered to:" in line
                    for word in line.split() if word.startswith("tls://")), None)
    assert address is not None, f"no job log says where its worker registered: {len(logs)} logs"
    code = ("import sys\nfrom distributed import Client\nfrom distributed.security import Security\n"
            f"for address, security in (({address.replace('tls://', 'tcp://')!r}, None), "
            f"({address!r}, Security.temporary())):\n"
            "    try:\n        Client(address, security=security, timeout='5s')\n"
            "    except Exception as err:\n        print('refused', address, type(err).__name__)\n"
            "    else:\n        print('CONNECTED', address); sys.exit(1)\n")
    answer = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert answer.returncode == 0 and answer.stdout.count("refused") == 2, (answer.stdout, answer.stderr)


@pytest.mark.cluster
@slurm
def test_slurm_workers_retire_before_their_walltime_and_are_replaced(tmp_path):
    """A study longer than the workers' lifetime: with a walltime of 15 s each worker retires at
    11-13 s (0.85 of it, staggered by 1 s), its job ends, a new job replaces it, and the study
    completes as a local run does. The study is sized by its work, not by a machine's speed: 240
    cases of 40 modes over 6 t_sc take about 4x the lifetime here (at 16 modes over 3 t_sc it
    ended in 13 s, before any worker retired, once the solver got 12 % faster)."""
    text = (JOBS_STUDY.replace("K = [4e6, 6e6, 8e6]", "K = [4e6, 5e6, 6e6, 7e6, 8e6, 9e6]\nR = [1.0, 1.5]")
            .replace("Nmod = 16", "Nmod = 40").replace("stop = 3.0", "stop = 6.0"))
    assert "Nmod = 40" in text and "stop = 6.0" in text
    study_file = _study(tmp_path, "retiring", text)
    started = time.monotonic()
    proc = _start(study_file, tmp_path / "out", "--cluster", "slurm", "--jobs", "2", "--batch-seconds", "0.3",
                  env={"DASK_JOBQUEUE__SLURM__WALLTIME": "0:15"})
    _, err = proc.communicate(timeout=400)
    wall = time.monotonic() - started
    assert proc.returncode in (0, 1), err
    _assert_each_case_once(study_file, tmp_path / "out")
    logs = sorted((tmp_path / "out" / "jobs").glob("*.err"))
    retired = [p.name for p in logs if "Reason: worker-lifetime-reached" in p.read_text()]
    assert len(retired) >= 2 and len(logs) >= 4, ([p.name for p in logs], retired, f"{wall:.0f} s")
    local = tmp_path / "local"
    code, _, err = run_cli("run", study_file, "--out", local, "--no-plots", "--workers", "2")
    assert_same_study(tmp_path / "out", local)
    _assert_no_jobs_left()


@pytest.mark.cluster
@slurm
def test_a_ctrl_c_cancels_the_jobs_and_the_same_command_resumes(tmp_path, local_reference):
    study_file = _study(tmp_path)
    out = tmp_path / "out"
    proc = _start(study_file, out, "--cluster", "slurm", "--jobs", "2", "--batch-seconds", "0.2")
    _wait_for_entries(out, 3, proc)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    _assert_no_jobs_left()
    assert not list((out / "jobs").glob(".dask-jobqueue*")), "the workers' CA, certificate and key were left"
    done = len(Ledger.load(out).entries)
    assert done >= 3
    proc = _start(study_file, out, "--cluster", "slurm", "--jobs", "2", "--batch-seconds", "0.2")
    _, err = proc.communicate(timeout=300)
    assert proc.returncode in (0, 1), err
    assert "already done" in err
    _assert_each_case_once(study_file, out)
    assert_same_study(out, local_reference)


@pytest.mark.cluster
@slurm
def test_a_partition_slurm_does_not_have_is_one_line(tmp_path, monkeypatch):
    import dask
    with dask.config.set({"jobqueue.slurm.queue": "no-such-partition"}):
        line = _refused(tmp_path, monkeypatch, "--cluster", "slurm", "--jobs", "2", match="sbatch refuses the worker job")
    assert "invalid partition" in line.lower(), line


#: a stand-in PBS: qsub runs the job script as a process of its own and prints its id, qstat
#: lists the live ones, qdel kills one's process group
PBS = {
    # the script is copied first: dask-jobqueue removes its file as soon as qsub returns
    "qsub": 'job=$(mktemp --suffix=.fake-pbs.sh); cp "$1" "$job"; '
            'setsid bash "$job" > "$job.log" 2>&1 < /dev/null & echo "$!.fake-pbs"',
    "qstat": 'echo "Job id  Name  User"; for pid in $(pgrep -f "fake-pbs\\.sh$"); do echo "$pid.fake-pbs R"; done',
    "qdel": 'kill -TERM -- "-${1%%.*}" 2>/dev/null; exit 0',
}


@pytest.mark.cluster
def test_pbs_takes_the_same_path_end_to_end(tmp_path, local_reference):
    """--cluster pbs with a stand-in qsub/qstat/qdel that runs each job script as a local process:
    the same code path as SLURM's (TLS, lifetime, logs, the jobs cancelled at the end)."""
    env = _fake_commands(tmp_path / "bin", **PBS)
    study_file = _study(tmp_path)
    proc = _start(study_file, tmp_path / "out", "--cluster", "pbs", "--jobs", "2", "--batch-seconds", "0.2", env=env)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode in (0, 1), err
    assert "submitted 2 worker jobs (pbs); scheduler at tls://" in err
    _assert_each_case_once(study_file, tmp_path / "out")
    assert_same_study(tmp_path / "out", local_reference)


@pytest.mark.cluster
def test_jobs_that_fail_on_the_node_are_one_line_naming_their_log(tmp_path):
    """A job script that fails before its worker starts (here the site's prologue exits): once
    every job has ended with no worker joined, the run stops with one line, exit 2, instead of
    waiting for ever."""
    env = _fake_commands(tmp_path / "bin", **PBS)
    env["DASK_JOBQUEUE__PBS__JOB_SCRIPT_PROLOGUE"] = '["echo python not found on this node >&2; exit 3"]'
    proc = _start(_study(tmp_path), tmp_path / "out", "--cluster", "pbs", "--jobs", "2", env=env)
    _, err = proc.communicate(timeout=120)
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert proc.returncode == 2, err
    assert len(errors) == 1 and "ended before a worker reached the scheduler" in errors[0], err


@pytest.mark.cluster
@slurm
def test_an_error_mid_study_cancels_the_jobs(tmp_path):
    """The results directory removed mid-study (make clean): the run stops, exit 74, and its
    jobs are cancelled."""
    out = tmp_path / "out"
    proc = _start(_study(tmp_path), out, "--cluster", "slurm", "--jobs", "2", "--batch-seconds", "0.2")
    _wait_for_entries(out, 3, proc)
    while out.exists():                      # as rm -rf run again: a worker may add a batch file meanwhile
        shutil.rmtree(out, ignore_errors=True)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 74, err
    assert "was removed or replaced during the run" in err
    _assert_no_jobs_left()
