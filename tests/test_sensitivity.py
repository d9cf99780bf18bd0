"""Global sensitivity (issue 23): Sobol' indices and Morris effects through the code path a study
uses (pipeline.design's samplers, pipeline.analysis.analyze on a study.nc-like dataset), first
on functions whose indices are known, then on the solver end to end; bad [analysis] tables get
one line."""
import math

import numpy as np
import pytest
import xarray as xr

pytest.importorskip("SALib")

import pipeline  # noqa: E402
from pipeline.sensitivity import analyze  # noqa: E402
from pipeline.design import design_points  # noqa: E402
from pipeline.study import load_study_text  # noqa: E402

PI = math.pi
#: the Ishigami function's indices (a = 7, b = 0.1), from its closed-form variances
ISHIGAMI_S1 = [0.3139, 0.4424, 0.0]
ISHIGAMI_ST = [0.5576, 0.4424, 0.2437]


def _fake_study(design, outputs: dict) -> xr.Dataset:
    """A study.nc as the runner writes it for a design: the keys along sample, the outputs."""
    points = design_points(design)
    n = len(next(iter(points.values())))
    coords = {k: ("sample", np.array(v)) for k, v in points.items()}
    X = np.column_stack([points[k] for k in design["keys"]])
    data = {name: ("sample", f(X)) for name, f in outputs.items()}
    data.update(status=("sample", np.array(["ok"] * n, dtype=object)), time_reached=("sample", np.full(n, 1.0)),
                run_time=("sample", np.full(n, 0.01)))
    return xr.Dataset(data, coords={"sample": np.arange(n), **coords}, attrs={"study_name": "fake"})


def ishigami(X):
    return np.sin(X[:, 0]) + 7.0 * np.sin(X[:, 1]) ** 2 + 0.1 * X[:, 2] ** 4 * np.sin(X[:, 0])


def test_sobol_indices_of_the_ishigami_function_within_their_intervals():
    design = {"method": "saltelli", "samples": 1024, "seed": 2,
              "keys": {"V": (-PI, PI, False), "hi": (-PI, PI, False), "K": (-PI, PI, False)}}
    ds = _fake_study(design, {"max_strain": ishigami})
    analysis = {"method": "sobol", "outputs": ["max_strain"], "eps_Y": [8e-5], "conf_level": 0.95,
                "resamples": 1000, "seed": 2}
    idx = analyze(ds, design, analysis).sel(output="max_strain")
    assert ds.sizes["sample"] == 1024 * 5                          # N (d + 2)
    for name, exact in (("S1", ISHIGAMI_S1), ("ST", ISHIGAMI_ST)):
        values, conf = idx[name].values, idx[f"{name}_conf"].values
        assert np.all(np.abs(values - exact) <= conf), (name, values, conf)
        assert np.all(conf < 0.1), conf


def test_morris_effects_of_a_linear_function():
    """y = 2 V + 0.5 hi on unit ranges: every elementary effect is the coefficient, exactly."""
    design = {"method": "morris", "samples": 20, "seed": 1,
              "keys": {"V": (1.0, 2.0, False), "hi": (0.0, 1.0, False), "K": (1e6, 1e8, True)}}
    ds = _fake_study(design, {"max_strain": lambda X: 2.0 * X[:, 0] + 0.5 * X[:, 1]})
    analysis = {"method": "morris", "outputs": ["max_strain"], "eps_Y": [], "conf_level": 0.95,
                "resamples": 100, "seed": 1}
    idx = analyze(ds, design, analysis).sel(output="max_strain")
    np.testing.assert_allclose(idx["mu_star"].values, [2.0, 0.5, 0.0], atol=1e-9)
    np.testing.assert_allclose(idx["sigma"].values, [0.0, 0.0, 0.0], atol=1e-9)


def test_an_output_that_did_not_happen_enters_censored_and_says_so():
    design = {"method": "saltelli", "samples": 64, "seed": 0,
              "keys": {"V": (1.0, 2.0, False), "hi": (0.0, 1.0, False)}}
    ds = _fake_study(design, {"bottoming_time": lambda X: np.where(X[:, 0] > 1.5, 0.1 / X[:, 0], np.nan)})
    analysis = {"method": "sobol", "outputs": ["bottoming_time"], "eps_Y": [], "conf_level": 0.95,
                "resamples": 100, "seed": 0}
    idx = analyze(ds, design, analysis).sel(output="bottoming_time")
    assert 0.4 < float(idx["censored"]) < 0.6                      # half never bottomed: at time_reached
    assert idx["ST"].sel(key="V") > 0.9 and abs(float(idx["ST"].sel(key="hi"))) < 0.05
    failed = ds.copy()
    failed["status"] = failed["status"].copy(data=np.where(np.arange(ds.sizes["sample"]) == 3, "nonfinite", "ok"))
    with pytest.raises(pipeline.StudyError, match="1 of 256 samples failed or are missing"):
        analyze(failed, design, analysis)


STUDY = """
description = "sensitivity of a small design"
[base]
Nmod = 6
[design]
method = "saltelli"
samples = 4
seed = 1
[design.keys]
V = { min = 1.0, max = 5.0, log = true }
hi = { min = 0.3, max = 1.0 }
[analysis]
method = "sobol"
outputs = ["max_strain", "crack_onset_time", "bottoming_time"]
eps_Y = [8e-5, 1e-3]
resamples = 100
[output]
fields = []
times = { unit = "stage", count = 3 }
"""


def test_a_study_with_an_analysis_writes_its_indices_and_figure(tmp_path):
    out = tmp_path / "sens"
    ds = pipeline.run_study(STUDY, out=out, name="sens", workers=1, quiet=True)
    assert ds.sizes["sample"] == 4 * (2 + 2)
    with xr.open_dataset(out / "sensitivity.nc") as idx:
        assert list(idx["output"].values) == ["max_strain", "crack_onset_time@8e-05", "crack_onset_time@0.001",
                                              "bottoming_time"]
        assert idx["S1"].dims == ("output", "key") and list(idx["key"].values) == ["V", "hi"]
        assert idx.attrs["samples"] == 16 and idx.attrs["Conventions"].startswith("CF-")
        assert np.all(np.isfinite(idx["ST"].values))
    assert (out / "sensitivity.png").is_file() and (out / "design.png").is_file()


BAD = [
    (STUDY.replace('method = "saltelli"', 'method = "sobol"'), 'method = "sobol" needs [design] method = "saltelli"'),
    (STUDY.replace('outputs = ["max_strain", ', 'outputs = ["max_stress", '), "unknown output 'max_stress'"),
    (STUDY.replace('method = "sobol"\noutputs', 'method = "fast"\noutputs'), "method must be one of sobol, morris"),
    (STUDY.replace("eps_Y = [8e-5, 1e-3]", "eps_Y = [2.0]"), "eps_Y must be a list of yield strains in (0, 1)"),
    (STUDY.replace("hi = { min = 0.3, max = 1.0 }\n", ""), "at least two sampled keys"),
    (STUDY.split("[design]")[0] + "[analysis]" + STUDY.split("[analysis]")[1], "needs a [design]"),
]


@pytest.mark.parametrize("text,words", BAD, ids=[w for _, w in BAD])
def test_a_bad_analysis_is_refused_in_one_line(text, words):
    with pytest.raises(pipeline.StudyError) as err:
        load_study_text(text, "sens")
    assert words in str(err.value) and "\n" not in str(err.value)
