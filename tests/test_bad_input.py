"""Bad study files and command lines: one line naming the problem, exit 2, nothing written."""
import subprocess
import sys
from pathlib import Path

import pytest

from pipeline.cli import main

ROOT = Path(__file__).resolve().parents[1]
GOOD = """
description = "ok"
[base]
Nmod = 4
[grid]
V = [3.0, 5.0]
[output]
times = { unit = "t_sc", step = 0.5, stop = 1.0 }
fields = ["strain"]
x_points = 11
"""

# (study file text, words the one-line error must contain)
BAD_FILES = [
    ("description = \"x\"\n[grid\nV = [1.0]", "TOML syntax error"),
    (GOOD + "\n[extra]\na = 1", "unknown section or key 'extra'"),
    (GOOD.replace("Nmod = 4", "Nmod = 4\nVel = 3.0"), "unknown parameter 'Vel'"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0, \"fast\"]"), "must be a number"),
    (GOOD.replace("Nmod = 4", "Nmod = \"four\""), "[base].Nmod must be a number"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0, nan]"), "V must be finite and > 0"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0, inf]"), "V must be finite and > 0"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [-3.0]"), "V must be finite and > 0"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [0.0]"), "V must be finite and > 0"),
    (GOOD.replace("Nmod = 4", "Nmod = 4\nnu = 0.5"), "nu must be in [0, 0.5)"),
    (GOOD.replace("Nmod = 4", "Nmod = 0"), "Nmod must be a positive integer"),
    (GOOD.replace("Nmod = 4\n[grid]\nV = [3.0, 5.0]", "K = 8e6\n[grid]\nNmod = [4, 1.5]"), "Nmod value must be an integer"),
    (GOOD.replace("V = [3.0, 5.0]", "V = []"), "must be a non-empty list"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0, 3.0]"), "duplicate values"),
    (GOOD.replace("[grid]\nV = [3.0, 5.0]", "[grid]"), "[grid] is empty"),
    ("cases = []\n" + GOOD.replace("[grid]\nV = [3.0, 5.0]", ""), "[[cases]] is empty"),
    (GOOD.replace("fields = [\"strain\"]", "fields = [\"stress\"]"), "unknown field 'stress'"),
    (GOOD + "\n[solver]\nintegrator = \"euler\"", "integrator must be one of etd34, rk4"),
    (GOOD + "\n[solver]\ntolerance = -1.0", "tolerance must be finite and > 0"),
    (GOOD + "\n[solver]\nquadrature = \"simpson\"", "[solver]: quadrature must be one of paper, gauss, got 'simpson'"),
    (GOOD + "\n[solver]\nquadrature = 2", "[solver]: quadrature must be one of paper, gauss, got 2"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0, 5.0]\nquadrature = [\"gauss\", \"trapezoid\"]"),
     "[grid] quadrature value must be one of paper, gauss, got 'trapezoid'"),
    (GOOD + "\n[solver]\nsteps = 3", "unknown setting 'steps'"),
    (GOOD.replace("step = 0.5, stop = 1.0", "step = 50.0, stop = 400.0"), "past every case's impact stage"),
    (GOOD.replace("times = { unit = \"t_sc\", step = 0.5, stop = 1.0 }", "times = { unit = \"hours\", step = 1 }"), "times must be"),
    (GOOD.replace("x_points = 11", "x_points = 1"), "x_points must be between 2 and 100001"),
    (GOOD.replace("Nmod = 4", "Nmod = 4\nV = 3.0"), "V is both in [base] or [solver] and in [grid]"),
    ("[[cases]]\nV = 3.0\n[[cases]]\nV = 3.0", "repeats an earlier case"),
    (GOOD + "\n[[cases]]\nV = 3.0", "either [grid] or [[cases]]"),
    (GOOD + "\n[plots]\nkinds = [\"movie\"]", "[plots] kinds must be a list from"),
    (GOOD.replace("Nmod = 4", "Nmod = 10000000"), "Nmod must be at most 4096"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0, 5.0]\nintegrator = [\"etd34\", \"euler\"]"),
     "[grid] integrator value must be one of"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0, 5.0]\ntolerance = [1e-8, 0.0]"), "tolerance must be finite and > 0"),
    (GOOD + "\n[reference]\nV = 3.0", "cannot be overridden in a reference"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [" + ", ".join(str(1.0 + i / 1000) for i in range(101)) + "]\n"
                  "hi = [" + ", ".join(str(0.2 + i / 1000) for i in range(100)) + "]"),
     "more than 10000"),
    (GOOD.replace("fields = [\"strain\"]", "fields = [\"strain\", \"strain\"]"), "listed twice"),
    (GOOD + "\n[solver]\nbottoming_gap = 0.9", "bottoming_gap must be between 1e-12 and 0.5"),
    # eps_Y is a post-processing axis, not a parameter
    (GOOD.replace("Nmod = 4", "Nmod = 4\neps_Y = 8e-5"), "[output] eps_Y"),
    (GOOD.replace("V = [3.0, 5.0]", "eps_Y = [8e-5, 1e-4]"), "eps_Y is not a solver input"),
    (GOOD.replace("x_points = 11", "x_points = 11\neps_Y = []"), "eps_Y must be a non-empty list"),
    (GOOD.replace("x_points = 11", "x_points = 11\neps_Y = [0.0, 1e-4]"), "eps_Y values must lie in (0, 1)"),
    (GOOD.replace("x_points = 11", "x_points = 11\neps_Y = [1e-4, 1e-4]"), "eps_Y has duplicate values"),
    (GOOD.replace("x_points = 11", "x_points = 11\neps_Y = {min = 1e-5, max = 1e-1}"), "takes exactly min, max and count"),
    (GOOD.replace("x_points = 11", "x_points = 11\neps_Y = {min = 1e-1, max = 1e-5, count = 9}"), "0 < min < max < 1"),
    # the hostile trial of issue 20: each of these was a traceback, a wrong table, a refusal after
    # the run, or every case failing, on main before it
    *[(GOOD + f"\n[solver]\nsubintervals = {v}", "[solver]: subintervals must be a positive integer")
      for v in ("nan", "inf", "-inf")],
    *[(GOOD.replace("Nmod = 4", f"Nmod = {v}"), "[base] Nmod must be a positive integer") for v in ("nan", "inf")],
    (GOOD + "\n[solver]\nmax_steps = inf", "[solver]: max_steps must be a positive integer"),
    (GOOD.replace("Nmod = 4", "Nmod = 4\nbody_mass = -1.0"), "[base] body_mass must be > 0"),
    *[(GOOD.replace("Nmod = 4", f"Nmod = 4\nflat_width = {v}"), f"flat_width = {v} m covers the whole plate")
      for v in ("6.0", "100.0")],
    *[(GOOD.replace("Nmod = 4", f"Nmod = 4\n{k} = {v}"), "shorter than 0.0001 of the layer's response time")
      for k, v in (("deadrise", "1e-9"), ("flat_width", "5.99"))],
    ("accept_extreme_values = true\n" + GOOD.replace("Nmod = 4", "Nmod = 4\ndeadrise = 1e-308"),
     "shorter than 0.0001 of the layer's response time"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0, 5.0]\ndeadrise = [1.0, 1e-6]"), "deadrise = 1e-06: the impact stage"),
    (GOOD.replace("Nmod = 4", "Nmod = 4\ntau = 1e-3") + "\n[solver]\nintegrator = \"rk4\"",
     "[base] tau = 0.001, [solver] integrator = 'rk4': rk4 integrates"),
    (GOOD.replace("V = [3.0, 5.0]", "V = [3.0]\nlayer_tau = [0.0, 1e-3]\nintegrator = [\"etd34\", \"rk4\"]"),
     "[grid] layer_tau = 0.001, [grid] integrator = 'rk4': rk4 integrates"),
    ("accept_extreme_values = true\n" + GOOD.replace("Nmod = 4", "Nmod = 4\nH = 1e-308"),
     "the water depth H = 1e-308 m makes the water's added mass infinite"),
    ("accept_extreme_values = true\n" + GOOD.replace("Nmod = 4", "Nmod = 4\nbody_p = 1e308"),
     "the body's shape gives no finite impact stage"),
]


@pytest.mark.parametrize("text, words", BAD_FILES, ids=[w[:40] for _, w in BAD_FILES])
def test_bad_study_file(tmp_path, capsys, text, words):
    study = tmp_path / "bad.toml"
    study.write_text(text)
    out = tmp_path / "out"
    code = main(["run", str(study), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert words in err, err
    assert not out.exists()


@pytest.mark.parametrize("argv, words", [
    (["run", "no_such_study"], "unknown study 'no_such_study'"),
    (["run", "missing/file.toml"], "no study file"),
    (["run", "regression_small", "--workers", "0"], "--workers must be >= 1"),
    (["run", "regression_small", "--workers", "two"], "invalid int value"),
    (["run"], "the following arguments are required"),
    (["run", "regression_small", "--scheduler", "nonsense"], "is not of the form tcp://host:port"),
    (["run", "regression_small", "--scheduler", "tcp://127.0.0.1:9"], "cannot reach the dask scheduler"),
    (["launch", "x"], "invalid choice"),
])
def test_bad_command_line(tmp_path, capsys, monkeypatch, argv, words):
    monkeypatch.chdir(ROOT)
    code = main(argv + ["--out", str(tmp_path / "out")] if argv[:1] == ["run"] and len(argv) > 1 else argv)
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert words in err, err
    assert not (tmp_path / "out").exists()


def test_bad_input_from_a_real_process_has_no_traceback(tmp_path):
    study = tmp_path / "bad.toml"
    study.write_text(BAD_FILES[0][0])
    proc = subprocess.run([sys.executable, "-m", "pipeline", "run", str(study), "--out", str(tmp_path / "o")],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_a_dry_run_refuses_what_a_run_refuses(tmp_path, capsys):
    """--dry-run validates the whole file as a run does (flat_width >= L: exit 0 before)."""
    study = tmp_path / "bad.toml"
    study.write_text(GOOD.replace("Nmod = 4", "Nmod = 4\nflat_width = 6.0"))
    code = main(["run", str(study), "--out", str(tmp_path / "out"), "--dry-run"])
    err = capsys.readouterr().err
    assert code == 2 and "flat_width = 6.0 m covers the whole plate" in err and err.count("\n") == 1, err


def test_a_large_grid_is_checked_where_the_checks_are_not_monotone(tmp_path, capsys, monkeypatch):
    """Beyond MAX_COMBINATIONS the coupled keys are checked at their extremes, but every value of
    body_p: a body's mean height (so its stage) is least at an inner body_p (4.5 here, with
    L/R = 1.5). The combination V = 6000, body_p = 4.5 is refused at load, not by a worker (where
    the case would stay pending); each value alone with the base is fine."""
    from pipeline.study import consistency
    monkeypatch.setattr(consistency, "MAX_COMBINATIONS", 2)
    text = "accept_extreme_values = true\n" + GOOD.replace("V = [3.0, 5.0]", "V = [5.0, 6000.0]\nbody_p = [1.0, 4.5, 10.0]") \
        .replace("Nmod = 4", "Nmod = 4\nK = 1e3\nhe = 1.0\nhi = 5.0\nR = 4.0")
    path = tmp_path / "grid.toml"
    path.write_text(text)
    code = main(["run", str(path), "--out", str(tmp_path / "out"), "--dry-run"])
    err = capsys.readouterr().err
    assert code == 2 and "V = 6000.0, body_p = 4.5" in err and "impact stage" in err, err
