"""Figures a researcher can put in a paper (issue 11): log axes for keys swept over decades,
no empty decades to reach εY, units and t_sc stated, every panel labelled."""
import matplotlib
import numpy as np
import pytest
import xarray as xr

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from pipeline.figures import common, paper, sweeps  # noqa: E402
from helpers import SMALL_GRID_STUDY as STUDY, figure_axes  # noqa: E402
from helpers import run_cli  # noqa: E402

LOG_GRID = STUDY.replace('description = "integrity tests"', 'description = "layer rigidity over three decades"') \
    .replace("V = [3.0, 5.0]", "K = [1e6, 1e7, 1e8, 1e9]")


@pytest.fixture(scope="module")
def log_study(tmp_path_factory):
    base = tmp_path_factory.mktemp("figures")
    (base / "log_grid.toml").write_text(LOG_GRID)
    code, _, err = run_cli("run", base / "log_grid.toml", "--out", base / "out", "--no-plots")
    assert code == 0, err
    with xr.open_dataset(base / "out" / "study.nc") as ds:
        return ds.load(), base


def test_diagnostics_log_key_on_a_log_axis_and_no_empty_decades(log_study, monkeypatch, tmp_path):
    ds, _ = log_study
    axes = figure_axes(monkeypatch, lambda: sweeps.diagnostics_figure(ds, ["K", "hi"], tmp_path / "d.png"))
    panels = axes[:9]
    assert all(ax.get_xscale() == "log" for ax in panels)              # K spans three decades
    assert [float(t) for t in panels[0].get_xticks()] == [1e6, 1e7, 1e8, 1e9]
    strain = panels[0]
    lo, hi = strain.get_ylim()
    values = ds["max_strain"].values
    if np.nanmin(values) > 10 * 8e-5:                                  # εY far below: a note, not an axis
        assert "off the axis" in strain.get_title() and lo > 8e-5
    for ax in panels:
        assert ax.get_xlabel() == "K [Pa]" and ax.get_title()
    plt.close("all")


def test_linear_key_keeps_plain_ticks_without_offset(log_study, monkeypatch, tmp_path):
    ds, _ = log_study
    axes = figure_axes(monkeypatch, lambda: sweeps.diagnostics_figure(ds, ["hi", "K"], tmp_path / "d.png"))
    assert axes[0].get_xscale() == "linear"
    assert axes[0].xaxis.get_major_formatter().get_offset() == ""
    plt.close("all")


def test_paper_fig2_states_units_and_time_scale(monkeypatch, tmp_path):
    code, _, err = run_cli("run", "studies/paper_fig2.toml", "--out", tmp_path / "fig2", "--no-plots")
    assert code == 0, err
    with xr.open_dataset(tmp_path / "fig2" / "study.nc") as ds:
        ds = ds.load()
    axes = figure_axes(monkeypatch, lambda: paper.paper_fig2(ds, list(ds["status"].dims), tmp_path / "f.png"))
    fig = axes[0].figure
    title = fig._suptitle.get_text()
    for text in ("K = 8 MPa", "he = 2 cm", "R = 10 m", "V = 5 m/s", "hi = 0.5 m", "t_sc = 1/ω₁ = "):
        assert text in title, title
    main = [ax for ax in axes if ax.get_title(loc="left")]
    assert len(main) == 4 and all(ax.get_ylabel() and "[" in ax.get_ylabel() for ax in main)
    assert any(c.get_title() == "contact zone" for ax in axes for c in ax.child_axes)   # the layer, zoomed
    plt.close("all")


def test_crowded_log_ticks_leave_a_label_out():
    labels = common.spaced_labels([0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 1000.0])
    assert labels == ["0.25", "", "1", "", "4", "", "1000"]         # every other octave, and the deep end


def test_paper_fig2_of_a_case_that_ended_early_is_skipped_with_a_note(tmp_path):
    """Viscoelastic ice with tau = 10 s bottoms out at 0.16 t_sc: the figure's snapshots at 3.8 to
    4.6 t_sc do not exist. Drawing it raised 'Axis limits cannot be NaN or Inf' (a traceback,
    exit 1); now the run ends as its case did, with one note."""
    study = tmp_path / "early.toml"
    study.write_text('[[cases]]\nNmod = 10\ntau = 10.0\n[output]\ntimes = { unit = "t_sc", step = 0.2, stop = 4.6 }\n'
                     'fields = ["deflection", "strain", "layer_pressure"]\nx_points = 41\n'
                     '[plots]\nkinds = ["paper_fig2"]\n')
    code, _, err = run_cli("run", study, "--out", tmp_path / "out")
    assert code == 0 and "Traceback" not in err, err
    assert "note: paper_fig2 shows the first case at 3.8 ... 4.6 t_sc, and it ended at 0.16 t_sc" in err, err
    assert not (tmp_path / "out" / "paper_fig2.png").exists()


def test_plate_wide_maxima_at_a_wall_are_ringed_and_counted(log_study, monkeypatch, tmp_path):
    """The strain panels say their maxima are plate-wide, ring each case whose maximum sits at
    a wall (x = +-L) and count them in the title (issue 25: the confined plate bends hardest at
    the walls late in the stage); a maximum moved off the wall is not ringed."""
    ds, _ = log_study
    ds = ds.copy()
    x = ds["max_strain_x"].values.copy()
    x.flat[0], x.flat[1] = float(ds["L"]), 0.5 * float(ds["L"])        # one case at a wall, one not
    ds["max_strain_x"].values = x
    axes = figure_axes(monkeypatch, lambda: sweeps.diagnostics_figure(ds, ["K", "hi"], tmp_path / "d.png"))
    upper = axes[0]
    walls = int(common.at_wall(ds, "max_strain").sum())
    assert "plate-wide" in upper.get_title()
    assert f"at a wall (x = ±L), {walls} of {ds['max_strain'].size} cases" in upper.get_title()
    rings = [line for line in upper.lines if line.get_marker() == "o" and line.get_markerfacecolor() == "none"
             and line.get_markeredgecolor() == "black"]
    assert sum(len(line.get_xdata()) for line in rings) == walls >= 1
    assert bool(common.at_wall(ds, "max_strain").values.flat[0]) and not common.at_wall(ds, "max_strain").values.flat[1]
