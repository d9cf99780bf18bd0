"""A study whose ice breaks (fracture = "break", docs/model.md, "Breaking into parts"): its
study.nc holds each case's breaks along break_number, the breakthrough and the number of parts
over time, as solve gives them for the same case; a grid over fracture shares its unbroken cases
with a study that does not break; what only breaking reads is refused where nothing breaks."""
import math

import numpy as np
import pytest

import pipeline
from pipeline import StudyError
from pipeline.study.definition import load_study_text
from pipeline.study.identity import case_id
from helpers import assert_breaking_study_consistent
from solver import Parameters, Settings, solve
from solver.outputs import breaking_values

OUTPUT = {"times": {"unit": "s", "step": 2.5e-4, "stop": 1.5e-3}, "fields": [], "x_points": 11}
BASE = {"Nmod": 12, "duration": 1.5e-3}


def _study(**grid):
    return {"base": {**BASE, "max_parts": 6}, "grid": {"hi": [0.3, 0.5], **grid}, "output": OUTPUT}


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """A study that does not break, then one over fracture = none, break in the same results
    directory: its unbroken cases are the first study's (the same ids), stored before breaking
    was asked of any case."""
    out = tmp_path_factory.mktemp("breaking") / "results"
    plain = pipeline.run_study({"base": BASE, "grid": {"hi": [0.3, 0.5]}, "output": OUTPUT}, out=out, workers=1,
                               name="plain", plots=False, quiet=True)
    both = pipeline.run_study(_study(fracture=["none", "break"]), out=out, workers=1, name="both", plots=False,
                              quiet=True)
    return plain, both


def test_a_study_stores_what_solve_gives_for_each_case(studies):
    """Each breaking case's breaks, breakthrough and parts over time in study.nc are those of
    solve on the same case (same machine: bit for bit), its breaks along break_number (max_parts
    - 1 = 5 slots, NaN after the case's own)."""
    _, ds = studies
    assert ds.sizes["break_number"] == 5 and list(ds["break_number"].values) == list(range(5))
    times = np.arange(7) * 2.5e-4
    for hi in (0.3, 0.5):
        case = ds.sel(hi=hi, fracture="break")
        p = Parameters(**BASE, hi=hi, fracture="break", max_parts=6)
        values = breaking_values(solve(p, Settings(), fields=(), times=times, t_end=p.duration), 5)
        assert str(case["status"].values) == "ok"
        for name, expected in values.items():
            np.testing.assert_array_equal(case[name].values, expected, err_msg=name)
        assert case["break_count"] >= 2 and np.isfinite(case["breakthrough_time"])
        assert case["first_break_time"] < case["breakthrough_time"] <= p.duration
        for name in ("break_time", "breakthrough_time", "part_count_over_time"):
            assert ds[name].attrs["units"] in ("s", "1") and ds[name].attrs["long_name"]
    assert_breaking_study_consistent(ds)


def test_crack_onset_of_a_study_that_breaks_stops_at_the_yield_strain(studies):
    """The default eps_Y axis of a study where ice breaks ends at its yield strain (8e-5 here),
    and crack onset there is the first break on its surface (assert_breaking_study_consistent);
    asking the stored records for a larger eps_Y is refused in one line, as a study that lists
    one is."""
    from pipeline.store.fracture import crack_onset
    _, ds = studies
    assert float(ds["eps_Y"].max()) == 8e-5 and float(ds["eps_Y"].min()) == 1e-5
    onset = crack_onset(ds)
    np.testing.assert_array_equal(onset["crack_onset_time"].values, ds["crack_onset_time"].values)
    with pytest.raises(ValueError, match="above yield_strain = 8e-05") as err:
        crack_onset(ds, eps_Y=[8e-5, 1e-4])
    assert "\n" not in str(err.value)
    for bad in ("8e-5", ["x"], [-1e-5]):
        with pytest.raises(ValueError, match="eps_Y must be yield strains"):
            crack_onset(ds, eps_Y=bad)


def test_the_unbroken_cases_of_a_study_that_breaks(studies):
    """A case that does not break has no break, one part at every time it reached and no
    breakthrough, also where it was stored by a study in which no case broke (its batch file
    holds no breaking outputs): its id leaves out max_parts, which it does not read."""
    plain, ds = studies
    unbroken = ds.sel(fracture="none")
    assert set(unbroken["case_id"].values.ravel()) == set(plain["case_id"].values.ravel())
    assert np.all(unbroken["break_count"] == 0) and np.all(unbroken["part_count"] == 1)
    assert np.all(np.isnan(unbroken["break_time"])) and np.all(np.isnan(unbroken["breakthrough_time"]))
    assert np.all(unbroken["part_count_over_time"] == 1)
    np.testing.assert_array_equal(unbroken["max_strain"].values, plain["max_strain"].values)


def test_case_ids_of_a_grid_over_fracture():
    """The grid's one-pass ids are each case's own; where the ice does not break, the keys
    only breaking reads (yield_strain, max_parts) do not enter the id."""
    study = load_study_text(pipeline.study_text(_study(fracture=["none", "break"], yield_strain=[8e-5, 1e-4])), "ids")
    assert [study.case(i).case_id for i in range(study.n_cases)] == study.case_ids
    ids = {(c.parameters.hi, c.parameters.fracture, c.parameters.yield_strain): c.case_id
           for c in (study.case(i) for i in range(study.n_cases))}
    assert ids[(0.3, "none", 8e-5)] == ids[(0.3, "none", 1e-4)]
    assert ids[(0.3, "break", 8e-5)] != ids[(0.3, "break", 1e-4)]
    plain = case_id(Parameters(**BASE, hi=0.3), Settings(), study.output)
    assert ids[(0.3, "none", 8e-5)] == plain


@pytest.mark.parametrize("change, words", [
    ({"base": {**BASE, "yield_strain": 1e-4}}, "yield_strain is read only by a run that breaks"),
    ({"grid": {"max_parts": [4, 8]}}, "max_parts is read only by a run that breaks"),
    ({"base": {**BASE, "fracture": "break"}, "output": {**OUTPUT, "end": "answered",
                                                         "outputs": ["crack_onset_time"]}}, "end = \"answered\""),
    ({"base": {**BASE, "fracture": "break", "max_parts": 1}}, "max_parts must be an integer >= 2"),
    ({"base": {**BASE, "fracture": "break"}, "solver": {"quadrature": "paper"}}, "quadrature = 'gauss'"),
    ({"base": {**BASE, "fracture": "break"}, "output": {**OUTPUT, "eps_Y": [5e-5, 1e-4]}},
     "eps_Y = 0.0001 is above yield_strain = 8e-05"),
    ({"grid": {"fracture": ["none", "break"], "yield_strain": [5e-5, 1e-4]},
      "output": {**OUTPUT, "eps_Y": [6e-5]}}, "eps_Y = 6e-05 is above yield_strain = 5e-05"),
    ({"base": {**BASE, "fracture": "break"}, "search": {"key": "V", "bracket": [1.0, 5.0], "event": "crack_onset",
                                                       "eps_Y": [2e-4]}},
     "eps_Y = 0.0002 is above yield_strain"),
    ({"output": {**OUTPUT, "outputs": ["breakthrough_time"]}}, "breakthrough_time is an output of ice that breaks"),
    ({"base": {**BASE, "fracture": "break", "max_parts": 1e9}}, "max_parts must be at most 1000"),
    ({"base": {**BASE, "fracture": "break", "max_parts": 2**63 - 1}}, "max_parts must be at most 1000"),
    ({"base": {**BASE, "fracture": "break", "max_parts": math.nan}}, "max_parts must be a positive integer"),
    ({"base": {**BASE, "fracture": "break", "max_parts": math.inf}}, "max_parts must be a positive integer"),
    ({"base": {**BASE, "fracture": "break", "max_parts": "6"}}, "max_parts must be a number"),
])
def test_what_a_study_that_breaks_refuses(change, words):
    """One line naming the problem, when the study is read (before anything is written)."""
    study = {"base": BASE, "output": OUTPUT, **change}
    with pytest.raises(StudyError, match=words) as err:
        load_study_text(pipeline.study_text(study), "bad")
    assert "\n" not in str(err.value)


def test_a_breakthrough_search_reads_the_breakthrough():
    """event = "breakthrough" takes no eps_Y (the cases' yield_strain is the criterion) and needs
    ice that breaks in every case; a run that ended at a break it could not make answers only if
    it had broken through."""
    import xarray as xr
    from pipeline.search_runner import _event
    search = {"key": "V", "bracket": [0.1, 5.0], "log": True, "event": "breakthrough"}
    study = load_study_text(pipeline.study_text({"base": {**BASE, "fracture": "break"}, "search": search,
                                                 "output": OUTPUT}), "s")
    assert study.search.eps_Y == ()
    for bad, words in (({"base": BASE}, 'needs ice that breaks in every case'),
                       ({"base": {**BASE, "fracture": "break"}, "search": {**search, "eps_Y": [8e-5]}},
                        "no yield strain")):
        with pytest.raises(StudyError, match=words):
            load_study_text(pipeline.study_text({"search": search, "output": OUTPUT, **bad}), "bad")
    ds = xr.Dataset({"status": ("case", ["ok", "separated", "edge_break", "parts_limit", "nonfinite"]),
                     "message": ("case", ["", "", "", "the plate would break into more than max_parts = 2 parts", "x"]),
                     "breakthrough_time": ("case", [1e-3, np.nan, 2e-3, np.nan, 1e-3])})
    assert [_event(ds, i, study.search, None) for i in range(5)] == [True, False, True, None, None]
    # a run with no answer says how it ended: a search whose runs all stopped at max_parts names it
    from pipeline.search_runner import _ended
    from pipeline.study.search import Target
    target = Target(0, None, study.search)
    target.learn({2.0: None}, study.search, {2.0: _ended(ds, 3, study.search)})
    assert target.status == "failed"
    assert target.message == ("the run at V = 2 gave no answer: it ended parts_limit before it broke through (the "
                              "plate would break into more than max_parts = 2 parts)")


def test_a_crack_onset_search_on_ice_that_breaks_finds_the_speed(tmp_path):
    """A crack-onset search at the yield strain of ice that breaks there (it exited "no crossing"
    when crack onset at eps_Y = yield_strain was NaN for ice that broke): found, and the speed
    found makes the ice break within the run, the bracket's lower end does not."""
    search = {"key": "V", "bracket": [0.5, 8.0], "log": True, "event": "crack_onset_lower", "eps_Y": [8e-5],
              "tolerance": 0.1, "scan": 3}
    study = {"base": {"Nmod": 12, "duration": 1e-3, "fracture": "break"}, "search": search, "output": OUTPUT}
    found = pipeline.run_study(study, out=tmp_path / "search", name="search", workers=1, plots=False, quiet=True)
    assert set(np.asarray(found["search_status"].values).ravel()) == {"found"}
    lo, hi = (float(found[f"critical_V_{end}"].values.ravel()[0]) for end in ("lower", "upper"))
    assert 0.5 < lo < hi <= lo * 1.1 + 1e-12
    for V, breaks in ((lo, False), (hi, True)):
        r = solve(Parameters(**{**study["base"], "V": V}), Settings(), fields=(), t_end=1e-3, times=[0.0, 1e-3])
        assert (r.breaking.break_count > 0) is breaks
