"""Global sensitivity (issue 23): Sobol' indices and Morris effects through the code path a study
uses (pipeline.study.design's samplers, pipeline.study.analysis.analyze on a study.nc-like dataset), first
on functions whose indices are known, then on the solver end to end; bad [analysis] tables get
one line."""
import math

from dataclasses import replace

import numpy as np
import pytest
import xarray as xr

pytest.importorskip("SALib")

import pipeline  # noqa: E402
from pipeline.analyse.sensitivity import analyze  # noqa: E402
from pipeline.study.analysis import Analysis  # noqa: E402
from pipeline.study.design import Design, design_points  # noqa: E402
from pipeline.study.definition import load_study_text  # noqa: E402

PI = math.pi
#: the Ishigami function's indices (a = 7, b = 0.1), from its closed-form variances
ISHIGAMI_S1 = [0.3139, 0.4424, 0.0]
ISHIGAMI_ST = [0.5576, 0.4424, 0.2437]


def _fake_study(design, outputs: dict) -> xr.Dataset:
    """A study.nc as the runner writes it for a design: the keys along sample, the outputs."""
    points = design_points(design)
    n = len(next(iter(points.values())))
    coords = {k: ("sample", np.array(v)) for k, v in points.items()}
    X = np.column_stack([points[k] for k in design.keys])
    data = {name: ("sample", f(X)) for name, f in outputs.items()}
    data.update(status=("sample", np.array(["ok"] * n, dtype=object)), time_reached=("sample", np.full(n, 1.0)),
                run_time=("sample", np.full(n, 0.01)))
    return xr.Dataset(data, coords={"sample": np.arange(n), **coords}, attrs={"study_name": "fake"})


def ishigami(X):
    return np.sin(X[:, 0]) + 7.0 * np.sin(X[:, 1]) ** 2 + 0.1 * X[:, 2] ** 4 * np.sin(X[:, 0])


def test_sobol_indices_of_the_ishigami_function_within_their_intervals():
    design = Design(**{"method": "saltelli", "samples": 1024, "seed": 2,
              "keys": {"V": (-PI, PI, False), "hi": (-PI, PI, False), "K": (-PI, PI, False)}})
    ds = _fake_study(design, {"max_strain": ishigami})
    analysis = Analysis(**{"method": "sobol", "outputs": ["max_strain"], "eps_Y": [8e-5], "conf_level": 0.95,
                "resamples": 1000, "seed": 2})
    idx = analyze(ds, design, analysis).sel(output="max_strain")
    assert ds.sizes["sample"] == 1024 * 5                          # N (d + 2)
    for name, exact in (("S1", ISHIGAMI_S1), ("ST", ISHIGAMI_ST)):
        values, conf = idx[name].values, idx[f"{name}_conf"].values
        assert np.all(np.abs(values - exact) <= conf), (name, values, conf)
        assert np.all(conf < 0.1), conf


def test_morris_effects_of_a_linear_function():
    """y = 2 V + 0.5 hi on unit ranges: every elementary effect is the coefficient, exactly."""
    design = Design(**{"method": "morris", "samples": 20, "seed": 1,
              "keys": {"V": (1.0, 2.0, False), "hi": (0.0, 1.0, False), "K": (1e6, 1e8, True)}})
    ds = _fake_study(design, {"max_strain": lambda X: 2.0 * X[:, 0] + 0.5 * X[:, 1]})
    analysis = Analysis(**{"method": "morris", "outputs": ["max_strain"], "eps_Y": [], "conf_level": 0.95,
                "resamples": 100, "seed": 1})
    idx = analyze(ds, design, analysis).sel(output="max_strain")
    np.testing.assert_allclose(idx["mu_star"].values, [2.0, 0.5, 0.0], atol=1e-9)
    np.testing.assert_allclose(idx["sigma"].values, [0.0, 0.0, 0.0], atol=1e-9)


def test_an_output_that_did_not_happen_enters_censored_and_says_so():
    design = Design(**{"method": "saltelli", "samples": 64, "seed": 0,
              "keys": {"V": (1.0, 2.0, False), "hi": (0.0, 1.0, False)}})
    ds = _fake_study(design, {"bottoming_time": lambda X: np.where(X[:, 0] > 1.5, 0.1 / X[:, 0], np.nan)})
    analysis = Analysis(**{"method": "sobol", "outputs": ["bottoming_time"], "eps_Y": [], "conf_level": 0.95,
                "resamples": 100, "seed": 0})
    idx = analyze(ds, design, analysis).sel(output="bottoming_time")
    assert 0.4 < float(idx["censored"]) < 0.6                      # half never bottomed: at time_reached
    assert idx["ST"].sel(key="V") > 0.9 and abs(float(idx["ST"].sel(key="hi"))) < 0.05
    failed = ds.copy()
    failed["status"] = failed["status"].copy(data=np.where(np.arange(ds.sizes["sample"]) == 3, "nonfinite", "ok"))
    with pytest.raises(pipeline.StudyError, match="1 of 256 samples failed or are missing"):
        analyze(failed, design, analysis)


def test_a_seed_of_0_gives_the_same_intervals_every_run():
    """SALib seeds its bootstrap only from a truthy seed: seed = 0 (the default) drew other
    intervals each run before."""
    design = Design(**{"method": "saltelli", "samples": 64, "seed": 0,
              "keys": {"V": (-PI, PI, False), "hi": (-PI, PI, False), "K": (-PI, PI, False)}})
    ds = _fake_study(design, {"max_strain": ishigami})
    runs = [analyze(ds, design, Analysis(**{"method": "sobol", "outputs": ["max_strain"], "eps_Y": [8e-5],
                                 "conf_level": 0.95, "resamples": 200, "seed": 0})) for _ in range(3)]
    for other in runs[1:]:
        np.testing.assert_array_equal(other["S1_conf"].values, runs[0]["S1_conf"].values)
        np.testing.assert_array_equal(other["ST_conf"].values, runs[0]["ST_conf"].values)
    design_m = Design(**{"method": "morris", "samples": 10, "seed": 0, "keys": {"V": (1.0, 2.0, False), "hi": (0.0, 1.0, False)}})
    ds_m = _fake_study(design_m, {"max_strain": lambda X: X[:, 0] ** 3 + X[:, 0] * X[:, 1]})
    runs = [analyze(ds_m, design_m, Analysis(**{"method": "morris", "outputs": ["max_strain"], "eps_Y": [],
                                     "conf_level": 0.95, "resamples": 200, "seed": 0})) for _ in range(2)]
    np.testing.assert_array_equal(runs[1]["mu_star_conf"].values, runs[0]["mu_star_conf"].values)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_indices_outside_the_unit_interval_are_flagged(seed):
    """One base sample gives S1 = -3.04 or 5.42 with intervals of width 0 (the issue's S1 = 1.34):
    flagged, and the runner warns; Ishigami's indices at 1024 samples are not."""
    from pipeline.analyse.sensitivity import doubtful_outputs
    analysis = Analysis(**{"method": "sobol", "outputs": ["max_strain"], "eps_Y": [8e-5], "conf_level": 0.95,
                "resamples": 100, "seed": seed})
    keys = {"V": (-PI, PI, False), "hi": (-PI, PI, False), "K": (-PI, PI, False)}
    few = Design(**{"method": "saltelli", "samples": 1, "seed": seed, "keys": keys})
    idx = analyze(_fake_study(few, {"max_strain": ishigami}), few, analysis)
    assert int(idx["outside_unit_interval"].sel(output="max_strain")) == 1
    assert doubtful_outputs(idx) == ["max_strain"]
    many = replace(few, samples=1024)
    idx = analyze(_fake_study(many, {"max_strain": ishigami}), many, analysis)
    assert int(idx["outside_unit_interval"].sel(output="max_strain")) == 0 and doubtful_outputs(idx) == []


STUDY = """
description = "sensitivity of a small design"
[base]
Nmod = 4
[design]
method = "saltelli"
samples = 16
seed = 1
[design.keys]
V = { min = 1.0, max = 5.0, log = true }
hi = { min = 0.3, max = 1.0 }
[analysis]
method = "sobol"
outputs = ["max_strain", "crack_onset_time", "bottoming_time"]
eps_Y = [8e-5, 1e-3]
resamples = 100
[solver]
tolerance = 1e-5          # loose: the test is of the analysis, not of the solver
[output]
fields = []
times = { unit = "stage", count = 3 }
"""


def test_a_study_with_an_analysis_writes_its_indices_and_figure(tmp_path):
    out = tmp_path / "sens"
    ds = pipeline.run_study(STUDY, out=out, name="sens", workers=1, quiet=True)
    assert ds.sizes["sample"] == 16 * (2 + 2)
    with xr.open_dataset(out / "sensitivity.nc") as idx:
        assert list(idx["output"].values) == ["max_strain", "crack_onset_time@8e-05", "crack_onset_time@0.001",
                                              "bottoming_time"]
        assert idx["S1"].dims == ("output", "key") and list(idx["key"].values) == ["V", "hi"]
        assert idx.attrs["samples"] == 64 and idx.attrs["Conventions"].startswith("CF-")
        assert np.all(np.isfinite(idx["ST"].values))
    assert (out / "sensitivity.png").is_file() and (out / "design.png").is_file()


BAD = [
    (STUDY.replace('method = "saltelli"', 'method = "sobol"'), 'method = "sobol" needs [design] method = "saltelli"'),
    (STUDY.replace('outputs = ["max_strain", ', 'outputs = ["max_stress", '), "unknown output 'max_stress'"),
    (STUDY.replace('method = "sobol"\noutputs', 'method = "fast"\noutputs'), "method must be one of sobol, morris"),
    (STUDY.replace("eps_Y = [8e-5, 1e-3]", "eps_Y = [2.0]"), "eps_Y must be a list of yield strains in (0, 1)"),
    (STUDY.replace("hi = { min = 0.3, max = 1.0 }\n", ""), "at least two sampled keys"),
    (STUDY.split("[design]")[0] + "[analysis]" + STUDY.split("[analysis]")[1], "needs a [design]"),
    (STUDY.replace('"bottoming_time"]', '"bottoming_time", "max_strain"]'), "outputs: 'max_strain' is listed twice"),
    (STUDY.replace("eps_Y = [8e-5, 1e-3]", "eps_Y = [8e-5, 8.0e-5]"), "eps_Y: 8e-05 is listed twice"),
    (STUDY.replace("eps_Y = [8e-5, 1e-3]", 'eps_Y = "abc"'), "eps_Y must be a list of yield strains in (0, 1), got 'abc'"),
    (STUDY.replace("eps_Y = [8e-5, 1e-3]", "eps_Y = 5"), "eps_Y must be a list of yield strains in (0, 1), got 5"),
    (STUDY.replace('"max_strain", "crack_onset_time", ', '"max_strain", '), "no output asked for takes it"),
    (STUDY.replace("samples = 16", "samples = 8"), "needs [design] samples >= 16, got 8"),
    (STUDY.replace("samples = 16", "samples = 1"), "needs [design] samples >= 16, got 1"),
]


@pytest.mark.parametrize("text,words", BAD, ids=[w for _, w in BAD])
def test_a_bad_analysis_is_refused_in_one_line(text, words):
    with pytest.raises(pipeline.StudyError) as err:
        load_study_text(text, "sens")
    assert words in str(err.value) and "\n" not in str(err.value)


MORRIS = """
description = "Morris at the size the issue found refused: 4 trajectories of 2 keys share grid points"
[base]
Nmod = 4
[design]
method = "morris"
samples = 4
seed = 5
[design.keys]
V = { min = 1.0, max = 5.0, log = true }
hi = { min = 0.3, max = 1.0 }
[analysis]
method = "morris"
outputs = ["max_strain"]
resamples = 50
[output]
fields = []
times = { unit = "stage", count = 3 }
[plots]
kinds = []
"""


def test_a_morris_design_with_repeated_points_runs_each_point_once(tmp_path):
    """Morris trajectories lie on a 4-level grid and share points: a repeated point is one run,
    stored at each of its samples (refused as "two cases are identical" before)."""
    study = load_study_text(MORRIS, "morris")
    assert study.n_cases == 12 and len(study.run_ids) < 12            # repeats, for this seed
    ds = pipeline.run_study(MORRIS, out=tmp_path / "m", name="morris", workers=1, quiet=True)
    assert ds.sizes["sample"] == 12
    ids, strain = ds["case_id"].values, ds["max_strain"].values
    assert np.all(np.isfinite(strain))
    for cid in set(ids):
        assert len(set(strain[ids == cid])) == 1
    with xr.open_dataset(tmp_path / "m" / "sensitivity.nc") as idx:
        assert np.all(np.isfinite(idx["mu_star"].values)) and float(idx["mu_star"].sel(output="max_strain", key="V")) > 0
    # each sample's records once, in sample order, the sample dimension no longer than the counts
    # (a repeated point's positions were streamed and then read again: their records stored twice)
    counts = ds["tension_record_count"].values.astype(np.int64).ravel()
    assert ds.sizes["tension_node"] == counts.sum()
    np.testing.assert_array_equal(ds["tension_record_start"].values.ravel(), np.cumsum(counts) - counts)
