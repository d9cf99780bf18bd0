"""Threshold search (issue 23): the value of a key at which an event first happens, for every
point of a grid, by bisection on runs of the runner. Checked against a dense sweep of the same
runs, killed and resumed, and refused in one line when its input is bad."""
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

import pipeline
from pipeline.study.search import runs_per_search
from pipeline.study.definition import load_study_text
from helpers import ROOT, SEARCH_STUDY as STUDY, run_cli as command


@pytest.fixture(scope="module")
def searched(tmp_path_factory):
    base = tmp_path_factory.mktemp("search")
    (base / "s.toml").write_text(STUDY)
    code, _, err = command("run", base / "s.toml", "--out", base / "out")
    assert code == 0, err
    with xr.open_dataset(base / "out" / "search.nc") as ds:
        return ds.load(), base


def test_the_search_finds_a_bracket_within_the_tolerance(searched):
    ds, base = searched
    assert list(ds["search_status"].values) == ["found", "found"]
    lo, hi = ds["critical_V_lower"].values, ds["critical_V_upper"].values
    assert np.all(hi / lo - 1 <= 0.05) and np.all(lo <= ds["critical_V"].values) and np.all(ds["critical_V"] <= hi)
    assert list(ds["event_above"].values) == [1, 1]                   # faster: the layer bottoms out
    assert ds["critical_V"].attrs["units"] == "m s-1" and ds.attrs["Conventions"].startswith("CF-")
    planned = runs_per_search(load_study_text(STUDY, "s").search)
    assert planned == 9 + 3 and np.all(ds["solves"].values <= planned)      # log2(47.2 / 8) -> 3 halvings
    assert (base / "out" / "search.png").is_file()
    # thick ice bottoms out at a lower speed than thin ice
    assert ds["critical_V"].sel(hi=1.0) < ds["critical_V"].sel(hi=0.3)


@pytest.mark.slow
def test_the_search_agrees_with_a_dense_sweep_using_fewer_runs(tmp_path):
    """At 20 modes, on ice 1 m thick (where the layer bottoms out for every V above the first)
    and 0.5 m thick (where it comes and goes before it stays), against a sweep at the search's
    resolution (48 values of V, ratio 1.0502, over the bracket; the same runner): on thick ice
    the search's V is the sweep's first bottoming V within the tolerance and the sweep's spacing;
    on thinner ice the search returns a crossing at or above the sweep's first. Measured here:
    24 runs against 96."""
    text = STUDY.replace("Nmod = 6", "Nmod = 20").replace("hi = [0.3, 1.0]", "hi = [0.5, 1.0]")
    pipeline.run_study(text, out=tmp_path / "search", name="s", workers=2, quiet=True)
    with xr.open_dataset(tmp_path / "search" / "search.nc") as ds:
        ds = ds.load()
    values = np.array([float(f"{v:.12g}") for v in np.geomspace(1.0, 10.0, 48)])       # ratio 1.0502
    sweep = {"base": {"Nmod": 20}, "grid": {"hi": [0.5, 1.0], "V": values.tolist()},
             "output": {"fields": [], "times": {"unit": "stage", "count": 3}}}
    dense = pipeline.run_study(sweep, out=tmp_path / "sweep", name="sweep", workers=2, plots=False, quiet=True)
    thick = np.isfinite(dense["bottoming_time"].sel(hi=1.0).values)
    first = int(np.argmax(thick))
    assert thick[first:].all() and not thick[:first].any()                     # one crossing
    assert abs(math.log(float(ds["critical_V"].sel(hi=1.0)) / values[first])) <= math.log(1.0502 * 1.05)
    assert int(ds["scan_changes"].sel(hi=1.0)) == 1
    # on 0.5 m ice the layer bottoms out at isolated speeds (3.75, 4.57 m/s in the sweep) below the
    # speed from which it always does; the 9-value scan steps over them and the search returns a
    # crossing above them: never below the sweep's first bottoming
    thin = np.isfinite(dense["bottoming_time"].sel(hi=0.5).values)
    assert np.sum(thin[1:] != thin[:-1]) > 1
    assert float(ds["critical_V_upper"].sel(hi=0.5)) >= values[int(np.argmax(thin))]
    assert int(ds["solves"].sum()) <= 24 < dense.sizes["V"] * 2 == 96


def test_a_search_returns_a_crossing_its_own_runs_confirm(searched):
    """Each final bracket is a crossing: the event did not happen at its lower end and did at its
    upper end, in the runs the search made (the evaluations' study.nc)."""
    ds, base = searched
    with xr.open_dataset(base / "out" / "evaluations" / "study.nc") as ev:
        for hi in (0.3, 1.0):
            at = lambda v: bool(np.isfinite(ev["bottoming_time"].values[  # noqa: E731
                np.flatnonzero((ev["hi"].values == hi) & (ev["V"].values == v))[0]]))
            assert not at(float(ds["critical_V_lower"].sel(hi=hi))) and at(float(ds["critical_V_upper"].sel(hi=hi)))
    assert int(ds["scan_changes"].sel(hi=0.3)) > 1          # at 6 modes the event comes and goes on thin ice


def test_status_and_a_rerun_say_what_the_search_did(searched):
    ds, base = searched
    code, out, _ = command("status", base / "s.toml", "--out", base / "out")
    runs = int(ds["solves"].sum())
    assert code == 0 and "at most 12 runs each" in out and f"runs done: {runs}" in out and "2 found" in out
    code, _, err = command("run", base / "s.toml", "--out", base / "out")
    assert code == 0 and "(0 to run)" in err                                # every run reused


def test_a_damaged_search_nc_is_one_line_and_the_same_command_rebuilds_it(searched, tmp_path):
    """search.nc carries its checksum as study.nc does: damaged, status and the API name it in
    one line (no library error); the same command writes it again from the runs, computing none."""
    import shutil
    ds, base = searched
    out = tmp_path / "out"
    shutil.copytree(base / "out", out)
    target = out / "search.nc"
    data = bytearray(target.read_bytes())
    data[len(data) // 2] ^= 0xFF
    target.write_bytes(bytes(data))
    code, _, err = command("status", base / "s.toml", "--out", out)
    assert code != 0 and err.strip().splitlines()[-1].startswith("error: ") and "HDF" not in err, err
    assert f"{target} does not match the checksum" in err and "Traceback" not in err
    code, _, err = command("run", base / "s.toml", "--out", out)
    assert code == 0 and "(0 to run)" in err, err
    from pipeline.store.sealed import open_sealed
    with open_sealed(target) as again:
        np.testing.assert_array_equal(again["critical_V"].values, ds["critical_V"].values)


@pytest.mark.slow       # 40 s; test_status_and_a_rerun_say_what_the_search_did replays a search in make test
def test_a_killed_search_resumes_where_it_stopped(searched, tmp_path):
    ds, base = searched
    out = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(base / "s.toml"), "--out", str(out)],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    batches = out / "evaluations" / "batches"
    end = time.monotonic() + 120
    while time.monotonic() < end and len(list(batches.glob("*.nc"))) < 6:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    before = {p: p.stat().st_mtime_ns for p in batches.glob("*.nc")}
    code, _, err = command("run", base / "s.toml", "--out", out)
    assert code == 0, err
    for path, stamp in before.items():                     # no finished run computed again
        assert path.stat().st_mtime_ns == stamp
    with xr.open_dataset(out / "search.nc") as again:
        for name in ("critical_V", "critical_V_lower", "critical_V_upper", "solves"):
            np.testing.assert_array_equal(again[name].values, ds[name].values)
    from pipeline.store.ledger import Ledger
    assert len(Ledger.load(out / "evaluations").index()) == int(ds["solves"].sum())


def test_crack_onset_searches_one_per_yield_strain(tmp_path):
    """The tension of this confined plate is large (max strain 0.1 at 1 m/s on 0.3 m ice): crack
    onset within the stage at eps_Y = 0.115 and 0.125 comes with speed. One search per yield
    strain, sharing the scan's runs."""
    text = (STUDY.replace('event = "bottoming"', 'event = "crack_onset"\neps_Y = [0.115, 0.125]')
            .replace("Nmod = 6", "Nmod = 20").replace("bracket = [1.0, 10.0]", "bracket = [1.0, 8.0]")
            .replace("hi = [0.3, 1.0]", "hi = [0.3]"))
    pipeline.run_study(text, out=tmp_path / "crack", name="crack", workers=2, quiet=True)
    with xr.open_dataset(tmp_path / "crack" / "search.nc") as found:
        assert found["critical_V"].dims == ("hi", "eps_Y")
        v = found["critical_V"].sel(hi=0.3).values
        assert list(found["search_status"].values.ravel()) == ["found", "found"] and v[0] <= v[1]
        assert found.attrs["runs"] < int(found["solves"].sum())          # the scan's runs are shared


BAD = [
    (STUDY.replace("bracket = [1.0, 10.0]", "bracket = [10.0, 1.0]"), "low must be below high"),
    (STUDY.replace("bracket = [1.0, 10.0]", "bracket = [0.0, 10.0]"), "a log scale needs a bracket above 0"),
    (STUDY.replace('event = "bottoming"', 'event = "fracture"'), "event must be one of bottoming"),
    (STUDY.replace('key = "V"', 'key = "hi"'), "key hi is also in [base], [grid] or [design.keys]"),
    (STUDY.replace("tolerance = 0.05", "tolerance = 20.0"), "is not below the bracket's width"),
    (STUDY.replace('key = "V"', 'key = "Nmod"'), "key must be a continuous parameter"),
    (STUDY.replace("tolerance = 0.05", 'tolerance = 0.05\neps_Y = "junk"'), "is for a crack-onset event"),
    (STUDY.replace('key = "V"', 'key = "L"').replace("Nmod = 6", "Nmod = 6\nhi = 1.0")
     .replace("[grid]\nhi = [0.3, 1.0]", "[grid]\nV = [2.0]").replace("bracket = [1.0, 10.0]", "bracket = [0.5, 10.0]"),
     "[search] bracket: L = 0.5 at V=2: hi = 1.0 m is thicker"),
    (STUDY.replace('key = "V"', 'key = "duration"').replace("Nmod = 6", 'Nmod = 6\nedges = "free"')
     .replace("[grid]\nhi = [0.3, 1.0]", "[grid]\nV = [2.0]").replace("bracket = [1.0, 10.0]", "bracket = [0.0, 0.1]")
     .replace("log = true", "log = false").replace("tolerance = 0.05", "tolerance = 0.01"),
     "[search] bracket: duration = 0 at V=2: a free floe (edges = 'free') needs duration > 0"),
    (STUDY.replace("[grid]\nhi = [0.3, 1.0]", "[[cases]]\nhi = 0.3\n[[cases]]\nhi = 1.0"), "not [[cases]]"),
]


@pytest.mark.parametrize("text,words", BAD, ids=[w for _, w in BAD])
def test_a_bad_search_is_refused_in_one_line(text, words):
    with pytest.raises(pipeline.StudyError) as err:
        load_study_text(text, "s")
    assert words in str(err.value) and "\n" not in str(err.value)


def test_a_bracket_without_a_crossing_is_exit_2_and_keeps_its_runs(tmp_path):
    study = tmp_path / "none.toml"
    study.write_text(STUDY.replace("bracket = [1.0, 10.0]", "bracket = [15.0, 20.0]"))   # bottoms out at all
    code, _, err = command("run", study, "--out", tmp_path / "out")
    assert code == 2 and err.count("\n") <= 2, err
    assert "holds no crossing of bottoming at hi=0.3" in err and "the runs made are kept" in err
    assert "happens at all 9 scanned values" in err
    assert len(list((tmp_path / "out" / "evaluations" / "batches").glob("*.nc"))) >= 1


def test_points_without_a_crossing_are_results_when_others_have_one(tmp_path):
    """1 m ice bottoms out at every V in [1.5, 10] (6 modes), 0.3 m ice does not at 1.5: the
    thick point is recorded as no_crossing, the thin one is searched, exit 0 and a note."""
    study = tmp_path / "some.toml"
    study.write_text(STUDY.replace("bracket = [1.0, 10.0]", "bracket = [1.5, 10.0]"))
    code, _, err = command("run", study, "--out", tmp_path / "out")
    assert code == 0, err
    assert "1 of 2 searches found no crossing" in err
    with xr.open_dataset(tmp_path / "out" / "search.nc") as ds:
        assert list(ds["search_status"].values) == ["found", "no_crossing"]
        assert np.isnan(float(ds["critical_V"].sel(hi=1.0))) and "at all 9 scanned values" in str(
            ds["search_message"].sel(hi=1.0).values)
