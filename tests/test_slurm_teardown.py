"""``tests/cluster/slurm.sh down`` leaves no SLURM process, whatever the jobs did (``make
test-cluster`` runs this file last; docs/reliability.md, "What fires when"): a job cancelled
while its step runs, a step whose process ignores SIGTERM, and a job still waiting for a CPU;
afterwards no slurmctld, slurmd, slurmstepd, munged or job process is left, and SLURM comes up
again."""
import os
import signal
import subprocess
import time

import pytest

from helpers import ROOT

pytestmark = pytest.mark.cluster

SLURM = str(ROOT / "tests" / "cluster" / "slurm.sh")
DAEMONS = ("slurmctld", "slurmd", "slurmstepd", "munged")


def _alive(pids) -> list:
    """Those of pids that are running (not zombies, which init reaps when it will)."""
    out = subprocess.run(["ps", "-o", "pid=,stat=", "-p", ",".join(map(str, pids))], capture_output=True, text=True)
    return [int(line.split()[0]) for line in out.stdout.splitlines() if not line.split()[1].startswith("Z")] \
        if pids else []


def _pids(name: str) -> list:
    out = subprocess.run(["pgrep", "-x", name], capture_output=True, text=True)
    return _alive([int(p) for p in out.stdout.split()])


def _marked(mark: str) -> list:
    """The processes whose command line holds mark (the jobs' own)."""
    out = subprocess.run(["pgrep", "-f", mark], capture_output=True, text=True)
    return _alive([int(p) for p in out.stdout.split() if int(p) != os.getpid()])


def _running(job: str) -> bool:
    out = subprocess.run(["squeue", "-h", "-j", job, "-o", "%T"], capture_output=True, text=True)
    return out.stdout.strip() == "RUNNING"


def test_down_leaves_no_slurm_process(tmp_path):
    mark = f"floe-impact-teardown-{os.getpid()}"
    jobs = []
    for name, trap in (("cancelled", ""), ("stubborn", "trap '' TERM\n"), ("pending", "")):   # (an ignored
        script = tmp_path / f"{name}.sh"                                                 # signal stays so
        script.write_text(f"#!/bin/bash\n{trap}exec -a {mark}-{name} sleep 600\n")       # across exec)
        script.chmod(0o755)
        out = subprocess.run(["sbatch", "--parsable", "-n", "1", "--mem", "10", "-o", str(tmp_path / "%j.out"),
                              str(script)], capture_output=True, text=True, check=True)
        jobs.append(out.stdout.strip().split(";")[0])
    try:
        end = time.monotonic() + 60
        while not all(_running(j) for j in jobs[:2]) or len(_marked(mark)) < 2:     # (2 CPUs: the third waits)
            assert time.monotonic() < end, ("the jobs did not start", jobs, _marked(mark))
            time.sleep(0.2)
        subprocess.run(["scancel", "--signal=KILL", jobs[0]], check=True)     # cancelled mid-step
        down = subprocess.run([SLURM, "down"], capture_output=True, text=True, timeout=120)
        assert down.returncode == 0, down.stdout + down.stderr
        left = {name: _pids(name) for name in DAEMONS}
        assert not any(left.values()), left
        assert _marked(mark) == [], subprocess.run(["ps", "-ef"], capture_output=True, text=True).stdout
    finally:
        for pid in _marked(mark):
            os.kill(pid, signal.SIGKILL)
        up = subprocess.run([SLURM, "up"], capture_output=True, text=True, timeout=180)
        assert up.returncode == 0, up.stdout + up.stderr
