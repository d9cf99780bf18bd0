"""What a new user hit, from the README and docs alone (issue 22), each fixed and held here: a
[base]-only study is one case; show solves a point off the grid; status names the results
directory it read; a [[cases]] study's figures name the keys that vary; a sweep over decades
with its neutral 0 (tau = [0, 1e-4, 1e-2]) is drawn on a log axis."""
import subprocess
import sys
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import pipeline  # noqa: E402
from pipeline import figures  # noqa: E402
from pipeline.figures import common, sweeps  # noqa: E402
from pipeline.show import choose_case, show  # noqa: E402
from pipeline.study.definition import load_study_text  # noqa: E402
from helpers import figure_axes as _axes  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUTPUT = {"fields": [], "times": {"unit": "stage", "count": 5}, "eps_Y": [8e-5, 1e-3]}


@pytest.fixture(scope="module")
def listed(tmp_path_factory):
    """A [[cases]] study of three cases that vary V and tau."""
    study = {"base": {"Nmod": 6}, "output": OUTPUT,
             "cases": [{"V": 2.0}, {"V": 3.0}, {"V": 3.0, "tau": 1e-3}]}
    out = tmp_path_factory.mktemp("frictions") / "listed"
    return pipeline.run_study(study, out=out, name="listed", workers=1, plots=False, quiet=True).load()


def test_a_base_only_study_is_one_case(tmp_path):
    study = load_study_text("[base]\nV = 3.0\nNmod = 6\n[output]\nfields = []\n", "one")
    assert study.n_cases == 1 and study.case(0).parameters.V == 3.0
    ds = pipeline.run_study({"base": {"V": 3.0, "Nmod": 6}, "output": OUTPUT}, out=tmp_path / "one", name="one",
                            workers=1, quiet=True)
    assert ds.sizes["case"] == 1 and ds["status"].values.tolist() == ["ok"]
    assert (tmp_path / "one" / "crack_onset.png").is_file() and (tmp_path / "one" / "diagnostics.png").is_file()


def test_show_solves_a_point_off_the_grid(tmp_path):
    study = load_study_text("[base]\nNmod = 6\nV = 2.0\n[grid]\nbody_mass = [300.0, 1000.0]\nhi = [0.3, 0.5]\n"
                            "[output]\nfields = []\ntimes = { unit = \"stage\", count = 5 }\n", "drop")
    cid = choose_case(study, "body_mass=500,hi=0.5")
    assert cid not in study.case_id_set
    case = study.run(cid)
    assert case.parameters.body_mass == 500.0 and case.parameters.hi == 0.5 and case.parameters.V == 2.0
    figure, text = show(study, tmp_path / "none", cid, points=20, figure=tmp_path / "case.png")
    assert "body_mass=500" in text and "not computed yet" in text and (tmp_path / "case.png").is_file()
    with pytest.raises(Exception, match="give a value for hi"):
        choose_case(study, "body_mass=500")                    # two thicknesses: which one?
    with pytest.raises(Exception, match="'bogus' is not a parameter"):
        choose_case(study, "bogus=1")


def test_status_names_the_results_directory(tmp_path):
    (tmp_path / "mass.toml").write_text("[base]\nNmod = 6\n[grid]\nV = [2.0, 3.0]\n[output]\nfields = []\n")
    proc = subprocess.run([sys.executable, "-m", "pipeline", "status", "mass.toml"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.splitlines()[0] == f"mass: results in {Path('results') / 'mass'} (none yet)"   # the table: stdout


def test_a_case_list_gets_figures_that_name_its_keys(listed, monkeypatch, tmp_path):
    labels = common.case_labels(listed)
    assert labels == ["V = 2 m s-1, tau = 0 s", "V = 3 m s-1, tau = 0 s", "V = 3 m s-1, tau = 0.001 s"]
    written, notes = figures.make_plots(listed, ["case"], ["diagnostics", "crack_onset"], tmp_path)
    assert notes == [] and [p.name for p in written] == ["diagnostics.png", "crack_onset.png"]
    axes = _axes(monkeypatch, lambda: sweeps.diagnostics_figure(listed, ["case"], tmp_path / "d.png"))
    assert [t.get_text() for t in axes[0].get_xticklabels()] == labels
    assert axes[0].get_xlabel() == "case (V, tau)"
    axes = _axes(monkeypatch, lambda: sweeps.crack_onset_figure(listed, ["case"], tmp_path / "c.png"))
    assert [line.get_label() for line in axes[0].get_lines() if not line.get_label().startswith("_")] == labels
    plt.close("all")


def test_a_sweep_over_decades_with_its_zero_is_drawn_on_a_log_axis(tmp_path, monkeypatch):
    ds = pipeline.run_study({"base": {"Nmod": 6, "V": 2.0}, "grid": {"tau": [0.0, 1e-4, 1e-2]}, "output": OUTPUT},
                            out=tmp_path / "tau", name="tau", workers=1, plots=False, quiet=True).load()
    axes = _axes(monkeypatch, lambda: sweeps.diagnostics_figure(ds, ["tau"], tmp_path / "d.png"))
    assert axes[0].get_xscale() == "log"
    assert [float(t) for t in axes[0].get_xticks()] == [1e-4, 1e-2]
    assert "dashed: tau = 0" in axes[0].figure._suptitle.get_text()        # tau = 0 as a dashed line
    plt.close("all")


def test_each_figure_reads_only_the_observed_outputs_its_kind_declares(listed, tmp_path):
    """A study that computes only some outputs draws the figures whose outputs it holds
    (pipeline.study.definition.PLOT_READS): each sweep figure draws from a study.nc without the
    observed outputs its kind does not declare, and every observed output a figure module names
    is declared by one of the kinds that module draws."""
    import re
    from solver.outputs import OBSERVED
    from pipeline.study.definition import PLOT_READS
    for kind in ("diagnostics", "crack_onset"):
        unread = [name for name in OBSERVED if name not in PLOT_READS[kind] and name in listed]
        paths, _ = sweeps.__dict__[figures.KINDS[kind].draw.split(".")[1]](listed.drop_vars(unread), ["case"],
                                                                            tmp_path)
        assert paths and all(p.is_file() for p in paths), kind
    by_module = {}
    for kind, entry in figures.KINDS.items():
        by_module.setdefault(entry.draw.split(".")[0], set()).update(PLOT_READS.get(kind, ()))
    for module, declared in by_module.items():
        named = set(re.findall(r'"([a-z_]+)"', (ROOT / "pipeline" / "figures" / f"{module}.py").read_text()))
        assert sorted(named & set(OBSERVED) - declared) == [], module
