"""Sampled designs (issue 23): a [design] samples the box its keys' bounds span (Sobol',
Latin hypercube, Halton, random), reproducibly from its seed and the same on every CPU; a
Sobol' design extended later reuses every finished case; study.nc holds the samples along
``sample``; a killed runner loses nothing; bad designs get one line."""
import numpy as np
import pytest

import pipeline
from pipeline.study.design import Design, design_points, unit_points
from pipeline.store.ledger import Ledger
from pipeline.study.definition import load_study_text
from helpers import kill_runner_then_resume, run_cli as command

BASE = """
description = "a design"
[base]
Nmod = {nmod}
[design]
method = "{method}"
samples = {samples}
seed = {seed}
[design.keys]
V = {{ min = 1.0, max = 10.0, log = true }}
hi = {{ min = 0.3, max = 1.0 }}
[output]
fields = [{fields}]
times = {{ unit = "stage", count = 5 }}
x_points = 21
"""


def study_text(method="sobol", samples=8, seed=3, nmod=8, fields=""):
    return BASE.format(method=method, samples=samples, seed=seed, nmod=nmod, fields=fields)


def load(**kw):
    return load_study_text(study_text(**kw), "design")


def test_a_design_is_reproducible_from_its_seed():
    a, b, c = load(seed=3), load(seed=3), load(seed=4)
    assert a.case_ids == b.case_ids and a.case_ids != c.case_ids
    assert a.dims == ["sample"] and a.n_cases == 8 and a.varying_keys == ["V", "hi"]
    for case in a.cases:                                     # inside the bounds, 12 digits
        assert 1.0 <= case.parameters.V <= 10.0 and 0.3 <= case.parameters.hi <= 1.0
        assert float(f"{case.parameters.V:.12g}") == case.parameters.V


@pytest.mark.parametrize("method", ["sobol", "latin_hypercube"])
def test_each_key_is_stratified(method):
    """Scrambled Sobol' (2^m points) and a Latin hypercube put exactly one point in each of the
    n equal slices of every key's range: on a log scale for a log key."""
    n = 64
    points = design_points(Design(method=method, samples=n, seed=11,
                                  keys={"V": (1.0, 100.0, True), "hi": (0.3, 1.0, False)}))
    V, hi = np.array(points["V"]), np.array(points["hi"])
    assert sorted(np.floor(np.log(V / 1.0) / np.log(100.0) * n).astype(int)) == list(range(n))
    assert sorted(np.floor((hi - 0.3) / 0.7 * n).astype(int)) == list(range(n))


@pytest.mark.parametrize("method", ["sobol", "halton", "random", "saltelli"])
def test_sequences_keep_their_first_points(method):
    """More samples keep the first ones (Saltelli's design: its first N (d + 2) rows)."""
    pytest.importorskip("SALib") if method == "saltelli" else None
    small, large = unit_points(method, 16, 3, 5), unit_points(method, 64, 3, 5)
    np.testing.assert_array_equal(small, large[:small.shape[0]])


@pytest.mark.slow   # issue 35: make test within 5 min; kept in make test-slow
def test_extending_a_sobol_design_computes_only_the_new_samples(tmp_path):
    out = tmp_path / "extend"
    first = pipeline.run_study(study_text(samples=4), out=out, name="design", workers=1, quiet=True)
    assert first.sizes["sample"] == 4 and first["V"].dims == ("sample",)
    assert first.attrs["design"].startswith('{"method": "sobol"')
    assert len(Ledger.load(out).index()) == 4
    bigger = load_study_text(study_text(samples=8), "design")
    assert bigger.case_ids[:4] == load_study_text(study_text(samples=4), "design").case_ids
    code, _, err = command("run", _write(tmp_path, study_text(samples=8)), "--out", out, "--no-plots")
    assert code == 0, err
    assert "8 cases, 4 to run, 4 already done" in err
    ds = pipeline.open_study(out)
    np.testing.assert_array_equal(ds["max_strain"].values[:4], first["max_strain"].values)
    assert (out / "design.png").is_file()                  # the design's figure (from the first run)


def _write(tmp_path, text, name="design.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def design_file(tmp_path_factory):
    return _write(tmp_path_factory.mktemp("design_faults"), study_text(nmod=30, fields='"strain"'))


@pytest.fixture(scope="module")
def design_undisturbed(design_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("design_faults") / "undisturbed"
    code, _, err = command("run", design_file, "--out", out, "--no-plots")
    assert code == 0, err
    return out


@pytest.mark.slow       # the machinery of tests/test_faults.py (in make test), on a design
def test_a_killed_runner_loses_no_sample(design_file, design_undisturbed, tmp_path):
    kill_runner_then_resume(design_file, design_undisturbed, tmp_path / "killed", delay=3.0)


BAD = [
    (study_text().replace("min = 1.0, max = 10.0", "min = 10.0, max = 1.0"), "min = 10 must be below max = 1"),
    (study_text().replace("hi = { min = 0.3, max = 1.0 }", "hi = { min = 0.0, max = 1.0, log = true }"),
     "a log scale needs min > 0"),
    (study_text(method="fibonacci"), "method must be one of sobol, latin_hypercube, halton, random"),
    (study_text(samples=12), "balanced only at a power of 2 (e.g. 8 or 16)"),
    (study_text(samples=0), "samples must be an integer"),
    (study_text().replace("hi = {", "Nmod = {"), "not a parameter a design can sample"),
    (study_text().replace("Nmod = 8", "Nmod = 8\nV = 2.0"), "V is both in [base] and in [design.keys]"),
    (study_text() + "\n[grid]\nK = [1e6, 1e7]\n", "one of [grid], [[cases]] and [design]"),
    (study_text().replace("[design.keys]", "[design.bounds]"), "unknown key 'bounds'"),
    (study_text().replace("V = { min = 1.0, max = 10.0, log = true }", "V = [1.0, 10.0]"), "must be { min"),
]


@pytest.mark.parametrize("text,words", BAD, ids=[w for _, w in BAD])
def test_a_bad_design_is_refused_in_one_line(text, words):
    with pytest.raises(pipeline.StudyError) as err:
        load_study_text(text, "design")
    assert words in str(err.value) and "\n" not in str(err.value)


def test_a_bad_design_is_exit_2_and_writes_nothing(tmp_path):
    code, out, err = command("run", _write(tmp_path, BAD[0][0]), "--out", tmp_path / "out")
    assert code == 2 and BAD[0][1] in err and err.count("\n") == 1, err
    assert not (tmp_path / "out").exists()


def test_show_picks_a_sample_by_its_position():
    from pipeline.show import ShowError, choose_case
    study = load()
    assert choose_case(study, "sample=3") == study.case_ids[3]
    with pytest.raises(ShowError, match="from 0 to 7"):
        choose_case(study, "sample=8")


def test_a_free_floes_sampled_duration_counts_when_the_other_keys_bounds_are_checked():
    """Each key's bounds were checked against [base] alone: a design sampling a free floe's
    duration beside hi was refused as "hi.min = 0.3: a free floe needs duration > 0"."""
    text = ('description = "a free floe\'s design"\n[base]\nNmod = 12\nedges = "free"\n[design]\n'
            'method = "latin_hypercube"\nsamples = 8\n[design.keys]\nhi = { min = 0.3, max = 1.0 }\n'
            'duration = { min = 0.01, max = 0.05 }\n')
    study = load_study_text(text, "floe_design")
    assert study.n_cases == 8 and all(0.01 <= study.case(i).parameters.duration <= 0.05 for i in range(8))
    with pytest.raises(pipeline.StudyError, match=r"\[design.keys\] hi.min = -0.3: "):   # still named
        load_study_text(text.replace("min = 0.3", "min = -0.3"), "floe_design")
