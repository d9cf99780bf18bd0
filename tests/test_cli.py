"""What a new user meets on the command line (issue 11): a bare command, --version, status
of a results directory on its own, the role column, `show` for one case, and a run's output
free of warnings."""
import shutil
import socket
from pathlib import Path

import numpy as np
import pytest

from helpers import SMALL_GRID_STUDY as STUDY
from helpers import ROOT, batch_files, run_process as run_cli

SMALL = STUDY.replace('description = "integrity tests"', 'description = "cli tests"') + "eps_Y = [1e-4, 1e-3]\n"


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """A finished study run from a file outside studies/, with port 8787 held by another
    process (dask's scheduler used to warn about it)."""
    base = tmp_path_factory.mktemp("cli")
    study = base / "cli_small.toml"
    study.write_text(SMALL)
    out = base / "results" / "cli_small"
    holder = socket.socket()
    try:
        holder.bind(("0.0.0.0", 8787))
        holder.listen()
    except OSError:
        pass                                # taken already: the condition holds anyway
    try:
        code, outp, err = run_cli("run", study, "--out", out)
    finally:
        holder.close()
    assert code == 0, err
    return study, out, outp + err


def test_a_run_prints_no_warnings(small_run):
    _, _, text = small_run
    assert "Warning" not in text and "warn" not in text.lower(), text


def test_bare_command_prints_the_help_and_exits_2():
    code, outp, err = run_cli()
    assert code == 2 and "Traceback" not in err
    assert "usage: python -m pipeline" in err and "{run,status,show}" in err
    assert err.strip().splitlines()[-1] == "error: give a command (run, status, show)"


def test_version_of_both_packages():
    import pipeline as pl
    import solver
    code, outp, _ = run_cli("--version")
    assert code == 0 and outp.strip() == f"floe-impact {pl.__version__}"
    assert solver.__version__ == pl.__version__ != "unknown"


def test_status_of_a_results_directory_on_its_own(small_run, tmp_path):
    """The run keeps a copy of its study: status works on the directory alone (moved, the study
    file gone), and by name from where results/<name> is."""
    study, out, _ = small_run
    copy = tmp_path / "elsewhere" / "moved"
    shutil.copytree(out, copy)
    code, outp, err = run_cli("status", copy, cwd=tmp_path)
    assert code == 0, err
    assert outp.splitlines()[-1] == "cli_small: 4 cases: 4 ok"
    (tmp_path / "results").mkdir()
    shutil.copytree(out, tmp_path / "results" / "cli_small")
    code, outp, err = run_cli("status", "cli_small", cwd=tmp_path)        # no studies/cli_small.toml here
    assert code == 0 and outp.splitlines()[-1] == "cli_small: 4 cases: 4 ok", err
    code, _, err = run_cli("status", tmp_path / "elsewhere")             # not a results directory
    assert code == 2 and err.count("\n") == 1 and "study.toml" in err


@pytest.mark.parametrize("command", ["status", "show"])
def test_another_studys_results_directory_is_refused_in_one_line(small_run, tmp_path, command):
    """A study file with another study's results: status listed every case as pending and show
    drew a figure into that directory. One line, nothing written."""
    _, out, _ = small_run
    other = tmp_path / "other_study.toml"
    other.write_text(SMALL.replace("V = [3.0, 5.0]", "V = [4.0, 6.0]"))
    before = sorted(p.name for p in out.iterdir())
    code, _, err = run_cli(command, other, "--out", out, *(["--case", "V=4,hi=0.5"] if command == "show" else []))
    assert code == 2 and err.count("\n") == 1 and "holds the results of study 'cli_small', not of 'other_study'" in err, err
    assert sorted(p.name for p in out.iterdir()) == before


def test_role_column_only_with_reference_runs_and_explained(tmp_path):
    study = tmp_path / "with_reference.toml"
    study.write_text(SMALL.replace("[grid]\nV = [3.0, 5.0]\nhi = [0.3, 0.5]",
                                   "[grid]\nV = [3.0, 5.0]\n[reference]\nNmod = 12"))
    code, outp, err = run_cli("status", study, "--out", tmp_path / "none")
    assert code == 0, err
    lines = outp.splitlines()
    assert lines[0].split() == ["case_id", "V", "state", "role"]
    assert sorted(line.split()[-1] for line in lines[1:5]) == ["case", "case", "reference", "reference"]
    assert any(line.startswith("role: case = a point of the study; reference = a converged run") for line in lines)


def test_show_draws_one_case_and_prints_its_summary(small_run):
    study, out, _ = small_run
    code, outp, err = run_cli("show", out, "--case", "V=5,hi=0.5")
    assert code == 0, err
    assert "solving the case for its curves (6 modes, 400 times) ..." in err and "solved in" in err, err
    lines = outp.splitlines()
    assert lines[0].startswith("case ") and lines[0].endswith("of cli_small: V=5, hi=0.5")
    assert "status: ok" in lines
    assert any(line.startswith("crack onset, upper surface: εY = 0.0001: ") for line in lines)
    figure = Path(lines[-1].removeprefix("wrote "))
    assert figure.parent == out and figure.name.startswith("case_") and figure.stat().st_size > 20_000
    # by a unique start of its id, from the study file, to a chosen file
    cid = figure.stem.removeprefix("case_")
    code, outp, err = run_cli("show", study, "--out", out, "--case", cid[:6], "--figure", out / "mine.png")
    assert code == 0 and (out / "mine.png").exists(), err


@pytest.mark.parametrize("args, words", [
    (["--case", "V=5"], "2 cases have V=5; add keys"),
    (["--case", "V=7"], "no case of the study has V=7"),
    (["--case", "zz"], "no case id of the study starts with 'zz'"),
    ([], "the study has 4 runs: choose one with --case"),
    (["--case", "V=5,hi=0.5", "--x", "99"], "--x 99 m is outside the plate"),
    (["--case", "V=3,V=5"], "V is given twice"),
])
def test_show_bad_choices_are_one_line(small_run, args, words):
    _, out, _ = small_run
    code, _, err = run_cli("show", out, *args)
    assert code == 2 and err.count("\n") == 1 and words in err, err


def test_show_a_damaged_batch_is_an_io_error_not_a_wrong_figure(small_run, tmp_path):
    _, out, _ = small_run
    copy = tmp_path / "damaged"
    shutil.copytree(out, copy)
    for path in batch_files(copy):
        data = bytearray(path.read_bytes())
        data[len(data) // 2] ^= 0x10
        path.write_bytes(bytes(data))
    before = sorted(copy.glob("case_*.png"))
    code, _, err = run_cli("show", copy, "--case", "V=3,hi=0.3")
    assert code == 74 and err.count("\n") == 1 and "checksum" in err, err
    assert sorted(copy.glob("case_*.png")) == before                    # no figure drawn


def test_show_a_case_not_run_yet_solves_it_and_says_so(tmp_path):
    study = tmp_path / "fresh.toml"
    study.write_text(SMALL)
    code, outp, err = run_cli("show", study, "--case", "V=3,hi=0.5", "--figure", tmp_path / "f.png",
                               "--out", tmp_path / "nothing_here")
    assert code == 0, err
    assert "not computed yet in this results directory: solved here, nothing stored" in outp
    assert (tmp_path / "f.png").exists() and not (tmp_path / "nothing_here").exists()


def test_show_is_in_the_readme_and_the_command_line_reference():
    assert "floe-impact show " in (ROOT / "README.md").read_text()
    assert "python -m pipeline show " in (ROOT / "docs" / "cli.md").read_text()


def test_result_gives_its_time_scales_as_the_readme_says():
    from solver import Parameters, solve
    r = solve(Parameters(V=5.0, Nmod=10), times=[0.0, 0.01], fields=())
    p = Parameters(V=5.0, Nmod=10)
    assert r.t_sc == r.time_scale == p.time_scale and r.stage_duration == p.L**2 / (6 * p.R * p.V)


def test_output_piped_into_head_ends_quietly(tmp_path):
    """status --all of 2400 cases into a pipe its reader closes after one line: exit 0 and
    nothing on stderr (BrokenPipeError is an OSError: it must be caught before OSError, which
    reported it as an I/O error, exit 74)."""
    import subprocess
    import sys
    values = lambda xs: "[" + ", ".join(xs) + "]"          # noqa: E731
    study = tmp_path / "big.toml"
    study.write_text(f"[base]\nNmod = 10\n[grid]\nV = {values(f'{v}.0' for v in range(1, 61))}\n"
                     f"hi = {values(f'0.{v}' for v in range(101, 141))}\n")
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "status", str(study), "--all", "--out",
                             str(tmp_path / "none")], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout.readline().startswith(b"case_id")
    proc.stdout.close()
    err = proc.stderr.read().decode()
    # stderr holds the one line naming the results directory status read, and nothing else
    assert proc.wait(timeout=120) == 0 and err == f"big: results in {tmp_path / 'none'} (none yet)\n", err


def test_shows_largest_tension_so_far_never_falls():
    """The record of a free body that rebounds (M = 3000 kg/m, drop_mass's case) has nodes of
    two peaks: joining them drew a 'largest tension so far' that fell from 0.00412 to 0.00336.
    The running maximum drawn now rises or stays, and meets every record node's value where
    the maximum rose there."""
    from pipeline.show import running_maximum
    from solver import Parameters, Settings, solve
    r = solve(Parameters(Nmod=20, body_mass=3000.0), Settings(error_estimate=False), fields=(),
              until_separation=True, t_end=0.05)
    for surface in ("upper", "lower"):
        rec = r.tension_record[surface]
        assert np.any(np.diff(rec[:, 1]) < 0)                 # the nodes themselves do fall
        t, m = running_maximum(rec)
        assert np.all(np.diff(t) >= 0) and np.all(np.diff(m) >= 0)
        assert m[-1] == rec[:, 1].max() and m[0] == rec[np.argmin(rec[:, 0]), 1]


def test_show_names_the_stage_rule_of_the_body():
    """A wedge's stage is b_mean / V, not L^2/(6RV) (show printed the formula of the parabola
    with another body's value)."""
    from pipeline.show import stage_text
    from solver import Parameters
    assert stage_text(Parameters()) == "impact stage L^2/(6RV) = 120 ms"
    wedge = Parameters(deadrise=15.0)
    assert stage_text(wedge) == f"impact stage b_mean/V = {wedge.stage_duration * 1e3:.4g} ms"
    assert stage_text(Parameters(x0=1.0)).startswith("impact stage b_mean/V = 130")
