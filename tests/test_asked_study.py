"""A study that computes only what it reads ([output] outputs, end = "answered"): its crack onsets
are the full study's bit for bit, its cases' ids say what they hold, and what it did not compute
is labelled, never passed off as a result."""
import shutil

import numpy as np
import pytest
import xarray as xr

from helpers import ROOT, run_cli
from pipeline.common.errors import StudyError
from pipeline.store.fracture import crack_onset
from pipeline.study.definition import load_study_text

FULL = """description = "crack onset"
[base]
Nmod = 12
[grid]
V = [2.0, 5.0]
hi = [0.3, 0.5]
[output]
times = { unit = "stage", count = 3 }
fields = []
eps_Y = [3e-5, 5e-5, 8e-5]
[solver]
error_estimate = false
"""
ONSETS = '["crack_onset_time", "crack_onset_x", "crack_onset_time_lower", "crack_onset_x_lower"]'
ANSWERED = FULL.replace("eps_Y = [3e-5, 5e-5, 8e-5]\n",
                        f'eps_Y = [3e-5, 5e-5, 8e-5]\noutputs = {ONSETS}\nend = "answered"\n')


def _run(tmp_path, name, text):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    code, out, err = run_cli("run", path, "--out", tmp_path / name, "--no-plots", "--workers", "1")
    assert code == 0, err
    return xr.load_dataset(tmp_path / name / "study.nc"), out


@pytest.fixture(scope="module")
def full_and_answered(tmp_path_factory):
    """The directory holding FULL and ANSWERED run to completion, and their study.nc."""
    tmp_path = tmp_path_factory.mktemp("asked")
    return tmp_path, _run(tmp_path, "full", FULL)[0], _run(tmp_path, "answered", ANSWERED)[0]


def test_an_answered_study_gives_the_full_studys_crack_onsets_bit_for_bit(full_and_answered):
    """The crack onsets of study.nc (both surfaces, every eps_Y) are the full study's to the
    bit; each run ended earlier; what it did not compute is NaN and labelled; a crack onset
    beyond the eps_Y it answered is refused, one line; the dry run says what a case computes."""
    tmp_path, full, answered = full_and_answered
    for name in ("crack_onset_time", "crack_onset_x", "crack_onset_time_lower", "crack_onset_x_lower"):
        assert np.array_equal(full[name].values, answered[name].values, equal_nan=True), name
        assert np.all(np.isfinite(answered[name].values)), name
    assert answered["crack_onset_time"].attrs["final_up_to_eps_Y"] == 8e-5
    assert np.all(answered["time_reached"].values < 0.5 * full["time_reached"].values)
    assert np.all(np.isnan(answered["max_strain"].values)) and "computed" in answered["max_strain"].attrs
    assert np.all(np.isnan(answered["impact_zone_crack_onset_time"].values))
    assert "computed" in answered["impact_zone_crack_onset_time"].attrs
    assert "covers" in answered["work"].attrs and answered.attrs["answered_eps_Y"] == 8e-5
    with pytest.raises(ValueError, match="above 8e-05, the largest yield strain this study's runs answered"):
        crack_onset(tmp_path / "answered" / "study.nc", eps_Y=[1e-4])
    below = crack_onset(tmp_path / "answered" / "study.nc", eps_Y=[4e-5])
    assert np.array_equal(below["crack_onset_time"].values, crack_onset(tmp_path / "full" / "study.nc",
                                                                        eps_Y=[4e-5])["crack_onset_time"].values)
    code, out, _ = run_cli("run", tmp_path / "answered.toml", "--out", tmp_path / "answered", "--dry-run")
    assert code == 0 and "0 to run" in out
    assert "its run ends when its crack onsets up to eps_Y = 8e-05 are final" in out


def test_the_ids_say_what_a_case_holds():
    """A study without [output] outputs keeps its ids; one that computes less, or answers up
    to another eps_Y, has other ids (a study that needs more recomputes its cases; one resumed
    with the same request finds them)."""
    full = load_study_text(FULL, "s").case_ids
    answered = load_study_text(ANSWERED, "s").case_ids
    higher = load_study_text(ANSWERED.replace("8e-5]", "1e-4]"), "s").case_ids
    stage = load_study_text(ANSWERED.replace('end = "answered"\n', 'end = "stage"\n'), "s").case_ids
    assert len({*full, *answered, *higher, *stage}) == 4 * len(full)
    # crack onsets only and no end given: the answer ends each run, the same cases
    assert load_study_text(ANSWERED.replace('end = "answered"\n', ""), "s").case_ids == answered
    assert answered == load_study_text(ANSWERED, "s").case_ids == [c.case_id for c in
                                                                   load_study_text(ANSWERED, "s").cases]


@pytest.mark.parametrize("change, message", [
    (('end = "answered"\n', 'end = "soon"\n'), "end must be one of"),
    ((f"outputs = {ONSETS}\n", ""), 'end = "answered" needs \\[output\\] outputs'),
    ((f"outputs = {ONSETS}\n", 'outputs = ["max_force"]\n'), "no crack onset among"),
    ((f"outputs = {ONSETS}\n", 'outputs = ["max_stress"]\n'), "unknown output 'max_stress'"),
    (("[solver]\n", '[plots]\nkinds = ["diagnostics"]\n[solver]\n'), "'diagnostics' reads max_strain, which is not among"),
])
def test_a_bad_request_is_one_line_before_anything_runs(change, message):
    with pytest.raises(StudyError, match=message):
        load_study_text(ANSWERED.replace(*change), "s")


def test_an_analysis_reads_only_what_is_computed():
    text = ANSWERED.replace("[grid]\nV = [2.0, 5.0]\nhi = [0.3, 0.5]\n",
                            '[design]\nmethod = "saltelli"\nsamples = 16\n[design.keys]\nV = { min = 2.0, max = 5.0 }\nhi = { min = 0.3, max = 0.5 }\n'
                            '[analysis]\nmethod = "sobol"\noutputs = ["max_strain"]\n')
    with pytest.raises(StudyError, match="max_strain is not among \\[output\\] outputs"):
        load_study_text(text, "s")


@pytest.mark.slow
def test_the_crack_onset_sensitivity_is_the_full_runs_to_the_last_digit(tmp_path):
    """studies/crack_onset_sensitivity.toml at 128 base samples (896 runs) against the same
    design run in full (every output, to the end of each stage): every crack onset and every
    Sobol' index with its interval identical to the last digit."""
    text = (ROOT / "studies" / "crack_onset_sensitivity.toml").read_text().replace("samples = 4096", "samples = 128")
    full_text = text.replace('outputs = ["crack_onset_time", "crack_onset_x"]\nend = "answered"\n', "")
    assert full_text != text
    answered, _ = _run(tmp_path, "answered", text)
    full, _ = _run(tmp_path, "full", full_text)
    assert np.array_equal(answered["crack_onset_time"].values, full["crack_onset_time"].values, equal_nan=True)
    assert np.any(np.isfinite(full["crack_onset_time"].values))
    a = xr.load_dataset(tmp_path / "answered" / "sensitivity.nc")
    b = xr.load_dataset(tmp_path / "full" / "sensitivity.nc")
    assert set(a.data_vars) == set(b.data_vars) and a.data_vars
    for name in a.data_vars:
        assert np.array_equal(a[name].values, b[name].values, equal_nan=True), name


def test_outputs_read_computes_what_the_study_reads(tmp_path):
    """[output] outputs = "read" is the study's own reads (its [analysis] outputs, [search] event,
    plots' outputs, records): the same cases as the list written out; a plot whose outputs are not
    computed is one line naming the output; a study that reads nothing observed is one line; the
    dry run of a study that computes everything says what it reads."""
    sweep = FULL.replace("[solver]", '[plots]\nkinds = ["crack_onset"]\n[solver]')
    read = load_study_text(sweep.replace("fields = []\n", 'fields = []\nrecords = false\noutputs = "read"\n'), "r")
    onsets = ("crack_onset_time", "crack_onset_time_lower", "impact_zone_crack_onset_time",
              "impact_zone_crack_onset_time_lower")
    assert read.output.outputs == tuple(sorted(onsets)) and read.output.end == "answered"
    assert read.output.answer_eps_Y == 8e-5               # no end given, crack onsets only: the answer ends a run
    staged = load_study_text(sweep.replace("fields = []\n", 'fields = []\nrecords = false\noutputs = "read"\n'
                                                          'end = "stage"\n'), "s")
    assert staged.output.end == "stage" and set(staged.run_ids).isdisjoint(read.run_ids)
    assert load_study_text(FULL.replace("fields = []\n", 'fields = []\noutputs = ["crack_onset_time", "max_force"]\n'),
                           "m").output.end == "stage"             # max force reads the whole stage
    listed = load_study_text(sweep.replace("fields = []\n", f"fields = []\nrecords = false\noutputs = {list(onsets)!r}\n"
                                           .replace("'", '"')), "l")
    assert read.run_ids == listed.run_ids
    with pytest.raises(StudyError, match="'diagnostics' reads max_strain, which is not among"):
        load_study_text(ANSWERED.replace("[solver]", '[plots]\nkinds = ["diagnostics"]\n[solver]'), "d")
    assert load_study_text(ANSWERED.replace("[solver]", '[plots]\nkinds = ["crack_onset"]\n[solver]')
                           .replace(ONSETS, repr(list(onsets)).replace("'", '"')), "c").plots == ["crack_onset"]
    nothing = FULL.replace("fields = []\n", 'fields = []\nrecords = false\noutputs = "read"\n').replace(
        "[solver]", '[plots]\nkinds = ["paper_fig2"]\n[solver]')
    path = tmp_path / "nothing.toml"
    path.write_text(nothing)
    code, out, err = run_cli("run", path, "--out", tmp_path / "nothing", "--dry-run")
    assert code == 2 and err.strip().count("\n") == 0 and "reads no output an observer computes" in err
    assert not (tmp_path / "nothing").exists()
    path.write_text(sweep)
    code, out, _ = run_cli("run", path, "--out", tmp_path / "sweep", "--dry-run")
    assert code == 0 and ("the study reads 8 of the 36 that observers make ([output] outputs = \"read\" computes "
                          "only those)") in out


def test_a_narrowed_study_reuses_the_runs_that_computed_everything(full_and_answered, tmp_path):
    """A study whose [output] narrows to crack onsets, run where the full study's runs are
    stored, computes nothing: each case is served by its full run, and study.nc holds what the
    narrowed study computed afresh holds, bit for bit, for every output it computes; what it
    does not compute is NaN there too, though the full runs have it (their records included).
    Widened again past what is stored (no run computed everything), it computes every case."""
    stored, _, computed = full_and_answered
    shutil.copytree(stored / "full", tmp_path / "s")
    (tmp_path / "s.toml").write_text(ANSWERED)
    code, out, err = run_cli("run", tmp_path / "s.toml", "--out", tmp_path / "s", "--no-plots", "--workers", "1")
    assert code == 0, err
    assert "0 to run, 4 already done (4 of them by stored runs that computed every output)" in err
    served = xr.load_dataset(tmp_path / "s" / "study.nc")
    for name in ("crack_onset_time", "crack_onset_x", "crack_onset_time_lower", "crack_onset_x_lower"):
        assert np.array_equal(served[name].values, computed[name].values, equal_nan=True), name
        assert np.all(np.isfinite(served[name].values)), name
    for name in ("max_strain", "max_force", "impact_zone_crack_onset_time", "max_contact_intervals"):
        assert np.all(np.isnan(served[name].values)) and np.all(np.isnan(computed[name].values)), name
    assert np.array_equal(served["tension_record_count"].values[..., 2:], computed["tension_record_count"].values[..., 2:])
    assert not served["tension_record_count"].values[..., 2:].any()         # the zone's records: not asked
    assert served.sizes["contact_change"] == computed.sizes["contact_change"] == 0
    assert np.all(served["time_reached"].values > 2 * computed["time_reached"].values)   # the full runs' stage
    code, out, err = run_cli("show", tmp_path / "s.toml", "--out", tmp_path / "s", "--case", "V=5,hi=0.5",
                             "--figure", tmp_path / "served.png")
    assert code == 0 and "status: ok" in out.splitlines(), err      # the stored run that served it
    # what only the answered runs hold cannot serve a study that reads more
    shutil.copytree(stored / "answered", tmp_path / "fresh")
    (tmp_path / "fresh.toml").write_text(FULL)
    code, out, err = run_cli("run", tmp_path / "fresh.toml", "--out", tmp_path / "fresh", "--dry-run")
    assert code == 0 and "4 to run" in out + err, out + err
