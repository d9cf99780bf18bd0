"""Shared by the tests of keys beyond the paper: a small study text, and the check that case ids
leave a key out at its neutral value (the paper's model), so that studies from before the key
keep their ids and results."""
from pipeline.study.definition import load_study_text

SMALL_STUDY = """
[base]
Nmod = 6
{extra}
[grid]
V = [3.0, 5.0]
[output]
times = {{ unit = "t_sc", step = 0.25, stop = 0.5 }}
fields = ["strain"]
x_points = 11
"""


def study(extra="", grid=""):
    """SMALL_STUDY with a line in [base] and keys swept beside V."""
    return SMALL_STUDY.format(extra=extra).replace("V = [3.0, 5.0]", f"V = [3.0, 5.0]\n{grid}")


def assert_ids_hold_at_neutral(key, neutral, other):
    """Ids of a study without the key equal those with key = neutral (and each case's own);
    key = other gives new ids; swept over [other, neutral] the fast ids agree with each case's
    and the neutral cases keep the ids of the study without the key."""
    before = load_study_text(study(), "s")
    at_neutral = load_study_text(study(f"{key} = {neutral}"), "s")
    changed = load_study_text(study(f"{key} = {other}"), "s")
    assert before.case_ids == at_neutral.case_ids == [c.case_id for c in at_neutral.cases]
    assert not set(changed.case_ids) & set(at_neutral.case_ids)
    assert changed.case_ids == [c.case_id for c in changed.cases]
    swept = load_study_text(study(grid=f"{key} = [{other}, {neutral}]"), "s")
    assert swept.case_ids == [c.case_id for c in swept.cases]             # the fast ids agree
    assert swept.case_ids[1] == before.case_ids[0] and swept.case_ids[0] == changed.case_ids[0]


def run_swept_study(tmp_path, key, values, units):
    """Run study() with V replaced by ``key = values`` through the command line (no plots);
    assert it ends ok and stores the key as a coordinate with these values and units; return the
    path of its study.nc."""
    import numpy as np
    import xarray as xr
    from helpers import run_cli
    path = tmp_path / f"{key}.toml"
    text = "[" + ", ".join("inf" if np.isinf(v) else repr(float(v)) for v in values) + "]"
    path.write_text(study().replace("V = [3.0, 5.0]", f"{key} = {text}"))
    code, _, err = run_cli("run", path, "--out", tmp_path / "o", "--no-plots")
    assert code == 0, err
    out = tmp_path / "o" / "study.nc"
    with xr.open_dataset(out) as ds:
        assert list(ds[key].values) == list(values) and ds[key].attrs["units"] == units
    return out
