"""[[cases]] studies, output times past a case's stage, and failed cases (--rerun-failed)."""
import numpy as np
import xarray as xr

from helpers import run_cli

CASES = """
description = "two cases"
[[cases]]
V = 5.0
Nmod = 6
[[cases]]
V = 20.0
Nmod = 6
he = 0.05
K = 8e7
[output]
times = { unit = "t_sc", step = 0.5, stop = 2.0 }
fields = ["strain"]
x_points = 11
"""


def test_case_list_gives_a_case_dimension_and_nan_past_the_stage(tmp_path):
    study = tmp_path / "two_cases.toml"
    study.write_text(CASES)
    code, _, err = run_cli("run", study, "--out", tmp_path / "out", "--workers", "1", "--no-plots")
    assert code == 0, err
    assert err.count("have output times past their impact stage") == 1
    with xr.open_dataset(tmp_path / "out" / "study.nc") as ds:
        assert ds["strain"].dims == ("case", "t", "x")
        assert list(ds["V"].values) == [5.0, 20.0] and ds["V"].dims == ("case",)
        assert list(ds["he"].values) == [0.02, 0.05]
        assert float(ds["Nmod"]) == 6 and float(ds["hi"]) == 0.5
        assert list(ds["status"].values) == ["ok", "ok"]
        fast = ds.isel(case=1)
        stage_tsc = float(fast["stage_duration"] / fast["t_sc"])
        past = ds["t"].values > stage_tsc
        assert past.any() and (~past).sum() >= 2
        assert np.all(np.isnan(fast["strain"].values[past]))
        assert np.all(np.isnan(fast["time"].values[past]))
        assert np.all(np.isfinite(fast["strain"].values[~past]))
        assert np.all(np.isfinite(ds.isel(case=0)["strain"].values))


def test_failed_cases_are_recorded_skipped_and_rerun_on_request(tmp_path):
    study = tmp_path / "doomed.toml"
    study.write_text(CASES + "\n[solver]\nmax_steps = 30\n")
    out = tmp_path / "out"
    code, _, err = run_cli("run", study, "--out", out, "--workers", "1", "--no-plots")
    assert code == 1, err
    assert "2 of 2 cases did not end ok" in err and err.count("step_limit: stopped at t =") == 2
    with xr.open_dataset(out / "study.nc") as ds:
        assert list(ds["status"].values) == ["step_limit", "step_limit"]
        assert all("max_steps = 30" in m for m in ds["message"].values)
        reached = ds["time_reached"].values
        for i in range(2):
            t = ds["time"].isel(case=i).values
            strain = ds["strain"].isel(case=i).values
            assert np.all(np.isnan(strain[~(t <= reached[i])]))
        assert ds.attrs["cases_failed"] == 2
    code, _, err = run_cli("run", study, "--out", out, "--workers", "1", "--no-plots")
    assert code == 1 and "2 cases, 0 to run, 2 already done" in err
    code, _, err = run_cli("run", study, "--out", out, "--workers", "1", "--no-plots", "--rerun-failed")
    assert code == 1 and "2 cases, 2 to run, 0 already done" in err


GROUPS = """
description = "two groups, two integrators"
cases = [
  { group = "slow", V = 3.0, Nmod = 6 },
  { group = "slow", V = 3.0, Nmod = 6, integrator = "rk4", quadrature = "paper", max_steps = 2000 },
  { group = "fast", V = 20.0, Nmod = 6 },
  { group = "fast", V = 20.0, Nmod = 6, integrator = "rk4", quadrature = "paper", max_steps = 2000 },
]
[output]
times = { unit = "t_sc", step = 0.5, stop = 1.0 }
fields = []
[plots]
kinds = ["extremes"]
"""


def test_groups_are_coordinates_and_the_extremes_table_is_written(tmp_path):
    """A [[cases]] study's group labels are coordinates of its variables in study.nc (the
    extremes table and the work_precision figure select by them: they were skipped when the
    labels were a plain variable)."""
    study = tmp_path / "groups.toml"
    study.write_text(GROUPS)
    out = tmp_path / "out"
    code, _, err = run_cli("run", study, "--out", out, "--workers", "1")
    assert code in (0, 1), err
    assert "extremes needs" not in err, err
    with xr.open_dataset(out / "study.nc") as ds:
        assert "group" in ds.coords and list(ds["group"].values) == ["slow", "slow", "fast", "fast"]
        assert "group" in ds["max_strain"].coords
    table = (out / "extremes.md").read_text()
    assert "| slow | ok |" in table and "| fast |" in table
