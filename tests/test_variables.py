"""docs/variables.md, the table of every study.nc variable, is what the code writes (issue 11),
and every variable is labelled the CF way."""
import xarray as xr

from pipeline.common.variables import generate, parameter_table, table
from helpers import ROOT


def test_variables_table_is_in_step_with_the_code(tmp_path):
    fresh = generate(tmp_path)
    stored = (ROOT / "docs" / "variables.md").read_text()
    assert fresh == stored, ("docs/variables.md is out of step with the code: run make variables-table "
                             "and commit the result")
    with xr.open_dataset(tmp_path / "everything" / "study.nc") as ds:
        assert table(ds) == fresh
        for name, var in ds.variables.items():
            assert var.attrs.get("long_name"), name
            if var.dtype.kind in "OUS":
                assert "units" not in var.attrs, name                   # CF: text has no units
            else:
                assert var.attrs.get("units"), name
        # every per-case variable a study can ask for is in this study
        for name in ("compression", "error_strain", "reference_case_id", "tension_record_start",
                     "crack_onset_time_lower", "time", "t_sc", "stage_duration"):
            assert name in ds.variables, name


def test_the_docs_point_to_the_table_and_name_no_variable_it_lacks():
    import re
    assert "docs/variables.md" in (ROOT / "README.md").read_text()
    readme = (ROOT / "docs" / "user_guide.md").read_text()
    assert "variables.md" in readme
    text = (ROOT / "docs" / "variables.md").read_text()
    documented = set(re.findall(r"^\| `([A-Za-z_0-9]+)` \|", text, re.M))
    for dims in re.findall(r"^\| `[^`]+` \| \(([^)]*)\)", text, re.M):
        documented |= {d.strip() for d in dims.split(",")}              # dimensions too
    # names the user guide's "Post-processing" list gives in backticks must exist in study.nc
    section = readme.split("Post-processing, from events", 1)[1].split("\n## ", 1)[0]
    named = set(re.findall(r"`([a-z_]+)`", section)) - {"_x", "_time", "_lower", "_modes", "inf"}
    missing = sorted(n for n in named if n not in documented and not n.endswith("_"))
    assert not missing, f"docs/user_guide.md names variables study.nc does not have: {missing}"


def test_parameter_table_is_in_step_with_the_code():
    """docs/parameters.md (every study key's units, reference value, range and neutral value) is
    what the solver's tables say; make variables-table rewrites it."""
    stored = (ROOT / "docs" / "parameters.md").read_text()
    assert parameter_table() == stored, "docs/parameters.md is out of step with the code: run make variables-table"
    from solver import PARAMETER_INFO, SETTING_INFO
    for key in [*PARAMETER_INFO, *SETTING_INFO]:
        assert f"| `{key}` |" in stored, key
    assert "| `body_p` |" in stored and "| 1 – 10 |" in stored          # the ranges users asked for
