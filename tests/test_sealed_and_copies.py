"""The files a study keeps beside study.nc belong to it: a sealed file (sensitivity.nc,
search.nc) names the study that wrote it, so one copied in from another study with its record is
refused in one line, as a damaged one is, and a missing record is said as such; the copy of its
study a results directory keeps runs as the study it is (its name, its directory, nothing
rewritten); the dry run counts a study's break slots."""
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import pipeline
from pipeline.store.sealed import is_intact, open_sealed, record_path, seal
from pipeline.study.definition import load_study_text
from pipeline.study.study_files import STUDY_COPY, copy_identity, keep_study_copy, load_study, study_identity
from helpers import SMALL_GRID_STUDY, run_cli


def _results(directory, text, name):
    """A results directory holding the copy of a study and a sealed file of its own."""
    directory.mkdir()
    keep_study_copy(load_study_text(text, name), directory)
    target = directory / "sensitivity.nc"
    xr.Dataset({"S1": ("output", np.array([0.5, 0.25]))}, attrs={"study": name}).to_netcdf(target)
    seal(target)
    return target


def test_a_sealed_file_of_another_study_is_refused(tmp_path):
    """Two studies of the same keys and outputs, differing in one value: the first's sensitivity.nc
    copied with its record into the second's directory is intact byte for byte but another
    study's, refused in one line naming it (open_sealed, open_sensitivity, open_emulator); the
    record names the study by its identity, the SHA-256 of its text (what the copy holds)."""
    first = _results(tmp_path / "a", SMALL_GRID_STUDY, "a")
    second = _results(tmp_path / "b", SMALL_GRID_STUDY.replace("V = [3.0, 5.0]", "V = [3.0, 6.0]"), "b")
    assert copy_identity(tmp_path / "a") == study_identity(load_study_text(SMALL_GRID_STUDY, "a").text)
    assert is_intact(first) and is_intact(second)
    shutil.copy2(first, second)
    shutil.copy2(record_path(first), record_path(second))
    assert not is_intact(second) and is_intact(second, copy_identity(tmp_path / "a"))
    for opener in (lambda: open_sealed(second), lambda: pipeline.open_sensitivity(tmp_path / "b"),
                   lambda: pipeline.open_emulator(tmp_path / "b")):
        with pytest.raises(pipeline.ResultsIOError, match="belongs to another study") as err:
            opener()
        assert "\n" not in str(err.value) and str(second) in str(err.value)


def test_a_missing_or_damaged_record_is_said_as_such(tmp_path):
    """A deleted checksum record is not a checksum mismatch: each of the three is named."""
    target = _results(tmp_path / "a", SMALL_GRID_STUDY, "a")
    data = bytearray(target.read_bytes())
    data[len(data) // 2] ^= 0xFF
    target.write_bytes(bytes(data))
    with pytest.raises(pipeline.ResultsIOError, match="does not match the checksum recorded"):
        open_sealed(target)
    record_path(target).write_text("{not json")
    with pytest.raises(pipeline.ResultsIOError, match="has a damaged checksum record"):
        open_sealed(target)
    record_path(target).unlink()
    with pytest.raises(pipeline.ResultsIOError, match="has no checksum record") as err:
        open_sealed(target)
    assert "\n" not in str(err.value)


def test_running_the_kept_copy_runs_the_study_as_it_ran(tmp_path):
    """results/<study>/study.toml, given to `run`, is the study it holds: the same name (not
    "study"), the same results directory, the copy kept as it is (no header added), and nothing
    recomputed or rewritten (study.nc keeps its bytes and time)."""
    study = tmp_path / "grid.toml"
    study.write_text(SMALL_GRID_STUDY)
    out = tmp_path / "out"
    code, _, err = run_cli("run", study, "--out", out, "--workers", "1")
    assert code == 0, err
    copy = out / STUDY_COPY
    before = {name: (out / name).stat().st_mtime_ns for name in ("study.nc", STUDY_COPY)}
    text = copy.read_bytes()
    assert load_study(copy).name == "grid"
    for _ in range(2):                     # (from another directory: results/ there stays empty)
        code, _, err = run_cli("run", copy, "--workers", "1", cwd=tmp_path)
        assert code == 0, err
        assert "4 already done" in err and "wrote" not in err, err
    ds = pipeline.run_study(copy, workers=1, plots=False, quiet=True)       # the same from Python
    assert ds.attrs["study_name"] == "grid" and int(ds.attrs["cases_ok"]) == 4
    assert copy.read_bytes() == text and text.count(b"# floe-impact keeps this copy") == 1
    assert {name: (out / name).stat().st_mtime_ns for name in before} == before
    assert not (tmp_path / "results").exists() and not (Path.cwd() / "results" / "grid").exists()


def test_the_dry_run_counts_the_break_slots(tmp_path):
    """A study whose ice breaks stores max_parts - 1 break slots per case: the dry run's estimate
    grows with max_parts (at 1000, five values in 999 slots: about 40 kB a case more)."""
    sizes = {}
    for parts in (2, 1000):
        path = tmp_path / f"parts{parts}.toml"
        path.write_text(SMALL_GRID_STUDY.replace("Nmod = 6", f'Nmod = 6\nfracture = "break"\nmax_parts = {parts}'))
        code, out, err = run_cli("run", path, "--out", tmp_path / f"out{parts}", "--dry-run")
        assert code == 0, err
        line = next(l for l in out.splitlines() if l.startswith("estimated output"))
        sizes[parts] = line.split("for the whole study; ")[0]
    assert sizes[2] != sizes[1000]
    from pipeline.run import output_size
    small, large = (output_size(load_study(tmp_path / f"parts{n}.toml")) for n in (2, 1000))
    assert large[1] - small[1] == 2 * 4 * 5 * 998 * 8            # (batch files and study.nc, 4 cases)
    assert not any((tmp_path / f"out{n}").exists() for n in (2, 1000))
