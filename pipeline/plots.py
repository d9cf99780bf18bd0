"""study.nc -> PNG figures in the study's results directory."""
from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from solver import PARAMETER_INFO  # noqa: E402

DIAGNOSTICS = [
    ("max_strain", "max tensile strain, upper surface"),
    ("max_strain_lower", "max tensile strain, lower surface"),
    ("crack_onset_time_tsc", "crack onset, upper [t_sc]"),
    ("crack_onset_time_lower_tsc", "crack onset, lower [t_sc]"),
    ("max_contact_intervals", "max contact intervals"),
    ("max_force", "max force [N/m]"),
    ("max_compression", "max layer compression δ"),
    ("energy_residual", "energy residual / work"),
    ("run_time", "solver wall time [s]"),
]


def _label(key, value):
    units = PARAMETER_INFO[key][1]
    return f"{key} = {value:g}" + ("" if units == "1" else f" {units}")


def diagnostics_figure(ds: xr.Dataset, dims: list, path: Path) -> Path:
    """Each diagnostic against the first grid key, one line per value of the other keys."""
    first, others = dims[0], dims[1:]
    fig, axes = plt.subplots(3, 3, figsize=(13, 10), constrained_layout=True)
    combos = list(itertools.product(*(ds[d].values for d in others))) or [()]
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(combos)))
    xvals = ds[first].values
    for ax, (name, title) in zip(axes.flat, DIAGNOSTICS):
        for color, combo in zip(colors, combos):
            where = dict(zip(others, combo))
            sel = ds[name].sel(where)
            ok = np.asarray(ds["status"].sel(where).values == "ok")
            label = ", ".join(_label(k, v) for k, v in zip(others, combo)) or None
            ax.plot(xvals, sel.values, "-", color=color, label=label)
            ax.plot(xvals[ok], sel.values[ok], "o", color=color, ms=4)
            ax.plot(xvals[~ok], sel.values[~ok], "o", mfc="white", mec=color, ms=5)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel(_label(first, 0).split(" = ")[0] + f" [{PARAMETER_INFO[first][1]}]")
        if name in ("max_strain", "max_strain_lower"):
            eps_y = float(np.nanmin(ds["eps_Y"].values)) if "eps_Y" in ds else None
            if eps_y:
                ax.axhline(eps_y, color="k", lw=0.8, ls="--", label="εY")
            ax.set_yscale("log")
        if name in ("energy_residual", "run_time", "max_force"):
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    if labels:
        fig.legend(handles, labels, loc="outside lower center", ncol=min(4, len(labels)), fontsize=9)
    title = ds.attrs.get("description") or ds.attrs.get("study_name", "")
    if np.any(ds["status"].values != "ok"):
        title += "\nopen markers: the case ended before its impact stage did (see status); values cover 0..time_reached"
    fig.suptitle(title, fontsize=11)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def paper_fig2(ds: xr.Dataset, dims: list, path: Path, times=(3.8, 4.0, 4.2, 4.4, 4.6)) -> Path:
    """The seed's figure 2 for the first case: (a) body and ice at 3.8 t_sc, (b) deflection,
    (c) layer pressure, (d) upper-surface strain at 3.8 ... 4.6 t_sc."""
    case = ds.isel({d: 0 for d in dims})
    x = case["x"].values

    def param(key):
        return float(case[key].values)

    R, he, V = param("R"), param("he"), param("V")
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5), constrained_layout=True)
    k38 = case["t"].sel(t=times[0], method="nearest")
    t38 = float(case["time"].sel(t=k38))
    ax = axes[0, 0]
    ax.plot(x, x**2 / (2 * R) + he - V * t38, "k-", label="body surface")
    ax.plot(x, case["deflection"].sel(t=k38).values, "C0-", label="ice (upper surface)")
    ax.set_title(f"(a) body and ice at t = {float(k38):.1f} t_sc")
    ax.set_ylabel("y [m]")
    ax.set_ylim(-V * t38 - 0.1, max(0.5, float(np.nanmax(case['deflection'].sel(t=k38))) + 0.1))
    ax.legend()
    panels = [(axes[0, 1], "deflection", "(b) deflection w [m]", 1.0),
              (axes[1, 0], "layer_pressure", "(c) layer pressure P_e [MPa]", 1e-6),
              (axes[1, 1], "strain", "(d) strain, upper surface", 1.0)]
    for ax, name, title, scale in panels:
        for i, tt in enumerate(times):
            sel = case[name].sel(t=tt, method="nearest")
            ax.plot(x, sel.values * scale, color=plt.cm.plasma(i / len(times)),
                    label=f"({i + 1}) t = {float(sel['t']):.1f} t_sc")
        ax.set_title(title)
        ax.set_ylabel(title.split(") ", 1)[1])
        ax.legend(fontsize=8)
    for ax in axes.flat:
        ax.set_xlabel("x [m]")
        ax.grid(alpha=0.3)
    fig.suptitle("Impact of a parabolic body on floating ice: " + ", ".join(
        f"{k} = {param(k):g}" for k in ("K", "he", "R", "V", "hi", "Nmod")), fontsize=11)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def make_plots(ds: xr.Dataset, dims: list, kinds: list, out_dir: Path) -> list:
    """The figures a study asks for; returns the paths written and a note per figure skipped."""
    out_dir = Path(out_dir)
    written, notes = [], []
    for kind in kinds:
        if kind == "diagnostics":
            if dims == ["case"]:
                notes.append("diagnostics figure needs a [grid]: skipped")
                continue
            written.append(diagnostics_figure(ds, dims, out_dir / "diagnostics.png"))
        elif kind == "paper_fig2":
            needed = {"deflection", "layer_pressure", "strain"}
            if not needed <= set(ds.data_vars) or ds["t"].attrs.get("long_name", "").find("t_sc") < 0:
                notes.append("paper_fig2 needs deflection, layer_pressure and strain at times in t_sc: skipped")
                continue
            written.append(paper_fig2(ds, dims, out_dir / "paper_fig2.png"))
    return written, notes
