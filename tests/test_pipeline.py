"""The study runner end to end: regression on a real 2-worker LocalCluster, the combined file,
resume, corrupt case files, dry run and status."""
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from pipeline.study.study_files import find_study, load_study
from helpers import ROOT, assert_same_study, batch_files, run_cli
from reference import REFERENCE, SPREAD, SPREAD_FACTOR, assert_matches_reference, within_spread

@pytest.fixture(scope="module")
def regression_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "regression_small"
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out, "--workers", "2")
    assert code == 0, err
    assert "4 cases, 4 to run, 0 already done" in err
    assert "loading the solver's kernels" in err and "kernels ready" in err   # no silent compile
    return out


def test_run_study_from_python_is_the_command_line_run(regression_run, tmp_path):
    """pipeline.run.run_study, as a notebook calls it, gives the study.nc the command line gives
    (every variable but the wall times bit for bit), and returns the exit status."""
    out = tmp_path / "from_python"
    code = ("from pipeline.run import RunOptions, run_study\n"
            "from pipeline.study.study_files import find_study, load_study\n"
            "import sys\n"
            f"sys.exit(run_study(load_study(find_study('regression_small')), {str(out)!r}, "
            "RunOptions(workers=2, no_plots=True)))")
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert_same_study(out, regression_run)


def test_regression_against_stored_reference(regression_run):
    """Within the reference's own spread over tolerances, on any CPU (tests/reference.py).
    Regenerate the reference with: make regenerate-reference (tests/regenerate_reference.py)."""
    assert_matches_reference(regression_run / "study.nc")


def test_the_reference_comparison_catches_a_change_beyond_the_spread(regression_run, tmp_path):
    """The comparison can fail: a strain moved by 10x its spread at one point, a status, and a
    NaN where the reference has a number are each reported."""
    with xr.open_dataset(regression_run / "study.nc") as new, xr.open_dataset(REFERENCE) as ref, \
            xr.open_dataset(SPREAD) as spread:
        new = new.load()
        assert within_spread(new, ref, spread) == []
        moved = new.copy(deep=True)
        moved["strain"][1, 1, 3, 12] += 10 * SPREAD_FACTOR * float(spread["strain"][1, 1]) + 1e-9
        moved["status"][0, 0] = "nonfinite"
        moved["max_strain"][0, 1] = np.nan
        problems = " ".join(within_spread(moved, ref, spread))
        assert "strain:" in problems and "status: differs" in problems and "max_strain: NaN" in problems


def test_generated_axes_are_decimal_on_a_real_study(regression_run):
    """eps_Y, t and x are the doubles nearest their short decimals (solver.axes): sel finds them
    on any CPU (np.logspace gave 9.999999999999999e-06 with numpy's AVX-512 power)."""
    with xr.open_dataset(regression_run / "study.nc") as ds:
        assert float(ds["crack_onset_time"].sel(V=5.0, hi=0.5, eps_Y=1e-5)) > 0
        assert np.isfinite(ds["crack_onset_time"].sel(V=5.0, hi=0.5, eps_Y=1e-4))
        assert ds["strain"].sel(V=3.0, hi=0.3, t=0.6, x=0.5).size == 1
        for name in ("eps_Y", "t", "x"):
            values = ds[name].values
            assert all(v == float(f"{v:.12g}") for v in values), name


def test_combined_file_is_labelled_and_carries_provenance(regression_run):
    ds = xr.open_dataset(regression_run / "study.nc")
    try:
        assert {k: v for k, v in ds.sizes.items() if k not in ("tension_node", "contact_change")} == \
            {"V": 2, "hi": 2, "t": 6, "x": 25, "tension_record": 4, "eps_Y": 42}
        assert ds["strain"].dims == ("V", "hi", "t", "x")
        for name in list(ds.data_vars) + list(ds.coords):
            var = ds[name]
            assert "long_name" in var.attrs, name
            if var.dtype.kind not in "OUS":
                assert "units" in var.attrs, name
        assert ds["V"].attrs["units"] == "m s-1" and ds["strain"].attrs["units"] == "1"
        for key in ("study_file", "floe_impact_version", "git_commit", "git_dirty", "host", "created",
                    "version_numba", "version_xarray", "solver_settings"):
            assert key in ds.attrs, key
        assert "V = [3.0, 5.0]" in ds.attrs["study_file"]
        case = ds.sel(V=5.0, hi=0.5)
        assert case["status"].item() == "ok"
        assert float(case["Nmod"]) == 10                       # constant parameters are stored
        assert np.all(np.isfinite(case["strain"].values))
        # post-processing from the in-loop diagnostics and the event records
        for name in ("max_strain", "max_abs_strain", "max_strain_lower", "max_contact_intervals",
                     "max_force", "bottoming_time", "energy_residual", "run_time"):
            assert ds[name].dims == ("V", "hi"), name
        for name in ("crack_onset_time", "crack_onset_x", "crack_onset_time_lower", "crack_onset_x_lower",
                     "impact_zone_crack_onset_time", "impact_zone_crack_onset_x", "impact_zone_crack_onset_time_lower",
                     "impact_zone_crack_onset_x_lower"):
            assert ds[name].dims == ("V", "hi", "eps_Y"), name
        assert ds["tension_record_time"].dims == ("tension_node",)        # ragged (CF contiguous)
        assert ds["tension_record_count"].dims == ("V", "hi", "tension_record")
        assert list(ds["tension_record"].values) == ["upper", "lower", "impact_zone_upper", "impact_zone_lower"]
        assert ds["contact_change_time"].dims == ("contact_change",)
        assert int(ds["tension_record_count"].sum()) == ds.sizes["tension_node"]
        assert int(ds["contact_change_entries"].sum()) == ds.sizes["contact_change"]
        assert np.all(ds["max_strain"] >= ds["strain"].max(("t", "x")) * (1 - 1e-9))
        # the paper's eps_Y is on the default axis; crack onset grows with eps_Y
        onset = ds["crack_onset_time"].sel(eps_Y=8e-5)
        assert np.all(onset > 0) and np.all(onset < ds["time_reached"])
        assert np.all(ds["crack_onset_time"].diff("eps_Y").fillna(1) > 0)
        assert np.all(ds["contact_intervals"].max("t") <= ds["max_contact_intervals"])
        # times are fractions of each case's own stage
        np.testing.assert_allclose(ds["time"].isel(t=-1), ds["stage_duration"], rtol=1e-12)
    finally:
        ds.close()


def test_a_study_that_differs_only_in_eps_Y_computes_nothing(regression_run, tmp_path):
    """eps_Y is not part of a case's identity: another list reuses every case file, and the new
    study.nc holds crack onset along it, equal to pipeline.store.fracture.crack_onset on the records."""
    from pipeline.store.fracture import crack_onset
    out = tmp_path / "other_eps"
    shutil.copytree(regression_run, out)
    text = (ROOT / "studies" / "regression_small.toml").read_text()
    study = tmp_path / "regression_eps.toml"
    study.write_text(text.replace("x_points = 25", "x_points = 25\neps_Y = [5e-5, 8e-5, 2e-4]"))
    code, _, err = run_cli("run", study, "--out", out, "--no-plots")
    assert code == 0, err
    assert "4 cases, 0 to run, 4 already done" in err
    with xr.open_dataset(out / "study.nc") as ds, xr.open_dataset(regression_run / "study.nc") as first:
        assert list(ds["eps_Y"].values) == [5e-5, 8e-5, 2e-4]
        np.testing.assert_array_equal(ds["crack_onset_time"].sel(eps_Y=8e-5), first["crack_onset_time"].sel(eps_Y=8e-5))
        again = crack_onset(out / "study.nc", [2e-4, 5e-5])
        for name in ("crack_onset_time", "impact_zone_crack_onset_time", "impact_zone_crack_onset_x_lower"):
            np.testing.assert_array_equal(again[name].sel(eps_Y=2e-4), ds[name].sel(eps_Y=2e-4))
        # and from the batch file that holds the case, the same numbers
        case_id = str(ds["case_id"].sel(V=5.0, hi=0.5).item())
        for path in batch_files(out):
            one = crack_onset(path, [5e-5, 8e-5, 2e-4])
            if case_id in one["case"].values:
                np.testing.assert_array_equal(one["crack_onset_time_lower"].sel(case=case_id).values,
                                              ds["crack_onset_time_lower"].sel(V=5.0, hi=0.5).values)
                break
        else:
            raise AssertionError("no batch file holds the case")
    assert (regression_run / "crack_onset.png").stat().st_size > 10_000


def test_a_rerun_with_nothing_new_rewrites_nothing(regression_run, tmp_path):
    """study.nc and the figures keep their mtimes when nothing is computed; touching study.nc
    (or changing a case file) makes the next run rebuild them."""
    out = tmp_path / "noop"
    shutil.copytree(regression_run, out)
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out)
    assert code == 0, err                         # the copy's mtimes differ: rebuilt once
    products = [out / "study.nc", out / "diagnostics.png", out / "crack_onset.png", out / "study.toml",
                out / "ledger.jsonl", *batch_files(out)]
    stamps = {p: p.stat().st_mtime_ns for p in products}
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out)
    assert code == 0, err
    assert "nothing new" in err and "wrote" not in err
    assert all(p.stat().st_mtime_ns == stamps[p] for p in products), "a no-op rerun rewrote a file"
    (out / "crack_onset.png").unlink()            # a missing figure is drawn again, study.nc kept
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out)
    assert (out / "crack_onset.png").exists() and (out / "study.nc").stat().st_mtime_ns == stamps[out / "study.nc"]
    os.utime(out / "study.nc")                    # touched by hand: no longer what the sidecar says
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out, "--no-plots")
    assert code == 0 and f"wrote {out / 'study.nc'}" in err


def test_second_run_computes_nothing(regression_run):
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", regression_run, "--no-plots")
    assert code == 0, err
    assert "4 cases, 0 to run, 4 already done" in err


def test_resume_computes_exactly_the_missing_cases(regression_run, tmp_path):
    out = tmp_path / "resume"
    shutil.copytree(regression_run, out)
    cases = batch_files(out)                     # one case per batch in a 4-case study
    removed, kept = cases[:2], cases[2:]
    stamps = {p: p.stat().st_mtime_ns for p in kept}
    for p in removed:
        p.unlink()
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out, "--workers", "1", "--no-plots")
    assert code == 0, err
    assert "4 cases, 2 to run, 2 already done" in err
    assert len(batch_files(out)) == 4 and "is missing" in err
    assert all(p.stat().st_mtime_ns == stamps[p] for p in kept), "finished cases were rewritten"


@pytest.mark.parametrize("damage", ["truncate", pytest.param("empty", marks=pytest.mark.slow),
                                    pytest.param("flip", marks=pytest.mark.slow), "other_case"])   # flips: test_integrity
def test_corrupt_case_file_is_set_aside_and_recomputed(regression_run, tmp_path, damage):
    out = tmp_path / damage
    shutil.copytree(regression_run, out)
    cases = batch_files(out)
    victim, others = cases[0], cases[1:]
    stamps = {p: p.stat().st_mtime_ns for p in others}
    data = victim.read_bytes()
    if damage == "truncate":
        victim.write_bytes(data[: len(data) // 2])
    elif damage == "empty":
        victim.write_bytes(b"")
    elif damage == "flip":
        victim.write_bytes(data[:200] + bytes(b ^ 0xFF for b in data[200:4000]) + data[4000:])
    else:                                   # a valid netCDF file, but of another case
        shutil.copyfile(cases[1], victim)
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out, "--workers", "1", "--no-plots")
    assert code == 0, err
    assert "4 cases, 1 to run, 3 already done" in err
    aside = list((out / "batches").glob(victim.name + ".damaged-*"))
    assert len(aside) == 1, "the damaged file is kept aside, never deleted"
    assert all(p.stat().st_mtime_ns == stamps[p] for p in others)
    with xr.open_dataset(out / "study.nc") as ds, xr.open_dataset(regression_run / "study.nc") as ref:
        np.testing.assert_allclose(ds["strain"].values, ref["strain"].values, rtol=1e-12)


def test_stale_temporary_files_are_swept(regression_run, tmp_path):
    out = tmp_path / "stale"
    shutil.copytree(regression_run, out)
    stale = out / "batches" / ".batch.nc.tmp-999-1"
    stale.write_bytes(b"half a file")
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out, "--no-plots")
    assert code == 0, err
    assert not stale.exists()


def test_dry_run_says_what_would_run_and_status_what_is_done(regression_run, tmp_path):
    code, outp, err = run_cli("run", "studies/regression_small.toml", "--out", regression_run, "--dry-run")
    assert code == 0, err
    assert outp.splitlines()[0] == f"regression_small: 4 cases, 0 to run, 4 already done -> {regression_run}"
    assert "would run" not in outp and outp.strip().endswith("nothing was run (--dry-run)")
    fresh = tmp_path / "never_run"
    code, outp, _ = run_cli("run", "studies/regression_small.toml", "--out", fresh, "--dry-run")
    lines = outp.splitlines()
    assert code == 0 and lines[2] == "would run (4):" and not fresh.exists()
    assert lines[1].startswith("each case computes every output; the study reads 17 of the 36 that observers make")
    assert lines[3].split() == ["case_id", "V", "hi", "state"]             # no role column: no references
    assert all(line.split()[-1] == "pending" for line in lines[4:8])
    assert lines[8].startswith("estimated output: ") and "of worker memory per case" in lines[8]
    code, outp, _ = run_cli("status", "regression_small", "--out", regression_run)
    assert outp.splitlines()[-2].startswith("each case computes every output; the study reads 17")
    rows = [line.split() for line in outp.splitlines()[1:-2]]
    assert code == 0 and outp.splitlines()[-1] == "regression_small: 4 cases: 4 ok"
    assert len(rows) == 4 and all(r[-1] == "ok" for r in rows) and "would run" not in outp


def test_case_ids_are_stable_and_change_with_settings(tmp_path):
    study = load_study(find_study("regression_small", ROOT / "studies"))
    again = load_study(find_study("regression_small", ROOT / "studies"))
    assert [c.case_id for c in study.cases] == [c.case_id for c in again.cases]
    assert len({c.case_id for c in study.cases}) == 4
    text = (ROOT / "studies" / "regression_small.toml").read_text().replace("1e-11", "1e-9")
    (tmp_path / "regression_small.toml").write_text(text)
    changed = load_study(tmp_path / "regression_small.toml")
    assert not {c.case_id for c in changed.cases} & {c.case_id for c in study.cases}
    # grid order: the last key varies fastest
    assert [(c.parameters.V, c.parameters.hi) for c in study.cases] == [(3, .3), (3, .5), (5, .3), (5, .5)]


@pytest.mark.parametrize("rule", ["gauss", "paper"])
def test_a_results_revision_recomputes_only_its_rules_cases(monkeypatch, rule):
    """solver.revision.RESULTS_REVISION enters the id of a case by its rule: when one rule's
    results change at the same settings its stored cases are recomputed, the other's are kept."""
    import pipeline.study.identity as identity
    import pipeline.study.definition as study_module
    text = (ROOT / "studies" / "regression_small.toml").read_text()
    texts = {r: text.replace("[solver]", f'[solver]\nquadrature = "{r}"', 1) for r in ("gauss", "paper")}
    assert all(t != text for t in texts.values())
    before = {r: study_module.load_study_text(t, "s").case_ids for r, t in texts.items()}
    monkeypatch.setitem(identity.RESULTS_REVISION, rule, identity.RESULTS_REVISION[rule] + 1)
    after = {r: study_module.load_study_text(t, "s").case_ids for r, t in texts.items()}
    other = "paper" if rule == "gauss" else "gauss"
    assert not set(after[rule]) & set(before[rule])
    assert after[other] == before[other]
    assert after[rule] == [c.case_id for c in study_module.load_study_text(texts[rule], "s").cases]


def test_the_floes_results_revision_recomputes_only_the_floes_cases(monkeypatch):
    """RESULTS_REVISION["floe"] enters the id of a free floe's case (beside its rule's), and of
    no other: walls and floe in one grid, and the grid's fast ids are the cases' own."""
    import pipeline.study.identity as identity
    import pipeline.study.definition as study_module
    text = ('[base]\nNmod = 4\nduration = 0.01\n[grid]\nedges = ["walls", "free"]\nV = [2.0, 3.0]\n'
            '[output]\ntimes = { unit = "stage", count = 3 }\n')
    before = study_module.load_study_text(text, "s").case_ids
    monkeypatch.setitem(identity.RESULTS_REVISION, "floe", identity.RESULTS_REVISION["floe"] + 1)
    after = study_module.load_study_text(text, "s")
    moved = [a != b for a, b in zip(after.case_ids, before)]
    assert moved == [c.parameters.edges == "free" for c in after.cases] and any(moved) and not all(moved)
    assert after.case_ids == [c.case_id for c in after.cases]


def test_the_references_results_revision_recomputes_only_its_cases(monkeypatch):
    """RESULTS_REVISION["dop853"] enters the id of a DOP853 case (beside its rule's), and of no
    etd34 or rk4 case: a change of the reference's observers recomputes its cases only."""
    import pipeline.study.identity as identity
    import pipeline.study.definition as study_module
    text = (ROOT / "studies" / "regression_small.toml").read_text()
    texts = {i: text.replace("[solver]", f'[solver]\nintegrator = "{i}"', 1) for i in ("dop853", "etd34", "rk4")}
    before = {i: study_module.load_study_text(t, "s").case_ids for i, t in texts.items()}
    monkeypatch.setitem(identity.RESULTS_REVISION, "dop853", identity.RESULTS_REVISION["dop853"] + 1)
    after = {i: study_module.load_study_text(t, "s") for i, t in texts.items()}
    assert not set(after["dop853"].case_ids) & set(before["dop853"])
    assert after["etd34"].case_ids == before["etd34"] and after["rk4"].case_ids == before["rk4"]
    assert after["dop853"].case_ids == [c.case_id for c in after["dop853"].cases]


#: a shipped study of more cases than this is checked in the default suite with its design's
#: samples cut to 16 (every table, key and bound checked, and 16 x (keys + 2) samples), and whole
#: in test_shipped_designs_are_valid_whole (each of the two 28672-case designs takes about 6 s)
QUICK_CASES = 5000


def test_shipped_studies_are_valid():
    from pipeline.study.definition import load_study_text
    for path in sorted((ROOT / "studies").glob("*.toml")):
        text = path.read_text()
        samples = re.search(r"^samples = (\d+)", text, re.M)
        if samples and int(samples.group(1)) * 8 > QUICK_CASES:
            text = text.replace(samples.group(0), "samples = 16")
        study = load_study_text(text, path.stem, path)
        assert study.cases, path
    speed = load_study(ROOT / "studies" / "speed_sweep.toml")
    assert len(speed.grid["V"]) >= 8 and min(speed.grid["V"]) == 1.0 and max(speed.grid["V"]) == 20.0
    assert len(speed.grid["hi"]) == 3


@pytest.mark.slow
def test_shipped_designs_are_valid_whole():
    """The shipped studies whose designs test_shipped_studies_are_valid cuts, each sample checked."""
    for path in sorted((ROOT / "studies").glob("*.toml")):
        if re.search(r"^samples = (\d+)", path.read_text(), re.M):
            assert load_study(path).cases, path


def test_interrupted_combine_is_rebuilt_from_case_files(regression_run, tmp_path):
    """A combine killed mid-write leaves only its temporary file; the rerun rebuilds study.nc."""
    out = tmp_path / "combine"
    shutil.copytree(regression_run, out)
    (out / "study.nc").unlink()
    stale = out / ".study.nc.tmp-4242-1"
    stale.write_bytes(b"CDF\x01 half written")
    code, _, err = run_cli("run", "studies/regression_small.toml", "--out", out, "--no-plots")
    assert code == 0, err
    assert "0 to run, 4 already done" in err and not stale.exists()
    with xr.open_dataset(out / "study.nc") as ds, xr.open_dataset(regression_run / "study.nc") as ref:
        np.testing.assert_array_equal(ds["strain"].values, ref["strain"].values)


def test_a_run_starts_no_more_workers_than_it_has_work_for(tmp_path):
    """--workers N is an upper bound: the runs to compute, plus the batch files of earlier runs
    the combine reads, bound it (a one-case study starts one worker process, not two)."""
    from pipeline.run import _workers_for
    batches = tmp_path / "batches"
    batches.mkdir()
    assert [_workers_for(2, runs, batches) for runs in (0, 1, 2, 9)] == [1, 1, 2, 2]
    assert _workers_for(4, 3, batches) == 3 and _workers_for(1, 9, batches) == 1
    for i in range(3):
        (batches / f"{i}.nc").write_bytes(b"")
    assert [_workers_for(2, runs, batches) for runs in (0, 1)] == [2, 2]
    assert _workers_for(8, 1, batches) == 4


def test_workers_are_warm_before_the_first_case(monkeypatch):
    """Every local worker has the kernels loaded before any case runs, so run_time is solver
    time (issue 9: the first case on each worker used to carry numba's cache load): forked from
    the forkserver that loaded them (pipeline.compute.forkserver), or, spawned, by warm_workers."""
    from pipeline.compute import forkserver
    from pipeline.compute.engine import cluster_client, kernels_loaded, warm_workers
    from solver import compile_kernels
    compile_kernels()
    with cluster_client(2, None) as client:
        loaded = client.run(kernels_loaded)
        assert len(loaded) == 2 and all(loaded.values()), "forked with the kernels in memory"
    monkeypatch.setattr(forkserver, "METHOD", "spawn")
    with cluster_client(2, None) as client:
        assert not any(client.run(kernels_loaded).values()), "spawned workers have not loaded them yet"
        warm_workers(client)
        loaded = client.run(kernels_loaded)
        assert len(loaded) == 2 and all(loaded.values())
