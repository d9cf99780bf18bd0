"""study.nc -> PNG figures in the study's results directory."""
from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib
import matplotlib.ticker

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
        elif kind == "work_precision":
            if "error_strain" not in ds or "group" not in ds.coords:
                notes.append("work_precision needs a [[cases]] study with groups and a [reference]: skipped")
                continue
            written.append(work_precision_figure(ds, out_dir / "work_precision.png"))
            written.append(work_precision_table(ds, out_dir / "work_precision.md"))
        elif kind == "extremes":
            if "group" not in ds.coords or "integrator" not in ds.coords:
                notes.append("extremes needs a [[cases]] study with groups and two integrators: skipped")
                continue
            written.append(extremes_table(ds, out_dir / "extremes.md"))
    return written, notes


def _physical_cases(ds: xr.Dataset) -> list:
    """(label, boolean mask over case) for each distinct physical case of a case-list study."""
    keys = [k for k in PARAMETER_INFO if k != "Nmod" and k in ds.coords and ds[k].dims == ("case",)]
    combos = sorted({tuple(float(ds[k].values[i]) for k in keys) for i in range(ds.sizes["case"])})
    out = []
    for combo in combos:
        mask = np.ones(ds.sizes["case"], bool)
        for k, v in zip(keys, combo):
            mask &= ds[k].values == v
        out.append((", ".join(_label(k, v) for k, v in zip(keys, combo)) or "reference case", mask))
    return out


def work_precision_figure(ds: xr.Dataset, path: Path) -> Path:
    """Per physical case: strain error against run time for each integrator, and against Nmod
    and subintervals (errors against each case's reference run)."""
    phys = _physical_cases(ds)
    group = ds["group"].values
    fig, axes = plt.subplots(len(phys), 3, figsize=(15, 4.2 * len(phys)), constrained_layout=True,
                             squeeze=False)
    err, run = ds["error_strain"].values, ds["run_time"].values
    for row, (label, mask) in zip(axes, phys):
        ax = row[0]
        for name, marker in (("rk4", "s"), ("etd34", "o"), ("dop853", "^")):
            sel = mask & (group == "integrator") & (ds["integrator"].values == name)
            order = np.argsort(run[sel])
            ax.loglog(run[sel][order], err[sel][order], marker + "-", label=name)
        ax.set_xlabel("solver wall time [s]")
        ax.set_ylabel("relative L2 strain error")
        ax.set_title(f"{label}\nintegrators (Nmod 60)", fontsize=10)
        ax.legend()
        for ax, key, title in ((row[1], "Nmod", "modes"), (row[2], "subintervals", "subintervals")):
            sel = mask & (group == title)
            order = np.argsort(ds[key].values[sel])
            ax.loglog(ds[key].values[sel][order], err[sel][order], "o-")
            for xv, ev, tv in zip(ds[key].values[sel][order], err[sel][order], run[sel][order]):
                ax.annotate(f"{tv:.2f} s", (xv, ev), textcoords="offset points", xytext=(4, 4), fontsize=7)
            ax.set_xlabel(key)
            ax.set_title(f"{label}\n{title} (etd34, tolerance 1e-10)", fontsize=10)
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    for ax in axes.flat:
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("Error against run time: errors are relative to each case's reference run "
                 "(same physics, tighter numerics or more modes); times are single runs", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def work_precision_table(ds: xr.Dataset, path: Path) -> Path:
    """Markdown: the cheapest run of each sweep that reaches 1e-2, 1e-3, 1e-4 strain error."""
    group, err, run = ds["group"].values, ds["error_strain"].values, ds["run_time"].values
    lines = ["| case | target | integrator sweep: cheapest run | time [s] | modes sweep: fewest modes | time [s] |",
             "|---|---|---|---|---|---|"]
    for label, mask in _physical_cases(ds):
        for target in (1e-2, 1e-3, 1e-4):
            cells = []
            sel = np.flatnonzero(mask & (group == "integrator") & (err <= target))
            if sel.size:
                i = sel[np.argmin(run[sel])]
                integ = str(ds["integrator"].values[i])
                knob = (f"rk4, step fraction {float(ds['rk4_step_fraction'].values[i]):g}" if integ == "rk4"
                        else f"{integ}, tolerance {float(ds['tolerance'].values[i]):g}")
                cells += [f"{knob} (error {err[i]:.1e})", f"{run[i]:.3f}"]
            else:
                cells += ["none reached it", "-"]
            sel = np.flatnonzero(mask & (group == "modes") & (err <= target))
            if sel.size:
                i = sel[np.argmin(ds["Nmod"].values[sel])]
                cells += [f"Nmod {int(ds['Nmod'].values[i])} (error {err[i]:.1e})", f"{run[i]:.3f}"]
            else:
                cells += ["none reached it", "-"]
            lines.append(f"| {label} | {target:.0e} | " + " | ".join(cells) + " |")
    path.write_text("\n".join(lines) + "\n")
    return path


def extremes_table(ds: xr.Dataset, path: Path) -> Path:
    """Markdown: per extreme case, how the default integrator fares and whether rk4 survives."""
    group, integ = ds["group"].values, ds["integrator"].values
    lines = ["| case | etd34 status | reached [% of stage] | steps (rejected) | smallest step [s] "
             "| largest δ | energy residual | wall [s] | rk4 at the seed's rule |",
             "|---|---|---|---|---|---|---|---|---|"]
    seen = []
    for g in group:
        if g not in seen:
            seen.append(g)
    for g in seen:
        e = np.flatnonzero((group == g) & (integ == "etd34"))
        r = np.flatnonzero((group == g) & (integ == "rk4"))
        cells = [g]
        if e.size:
            i = e[0]
            reached = 100 * float(ds["time_reached"].values[i] / ds["stage_duration"].values[i])
            delta = float(ds["max_compression"].values[i])
            delta_text = f"1 - {1 - delta:.0e}" if delta > 0.9999 else f"{delta:.4f}"
            cells += [str(ds["status"].values[i]), f"{reached:.1f}",
                      f"{int(ds['steps'].values[i])} ({int(ds['rejected_steps'].values[i])})",
                      f"{float(ds['smallest_step'].values[i]):.1e}", delta_text,
                      f"{float(ds['energy_residual'].values[i]):.1e}", f"{float(ds['run_time'].values[i]):.2f}"]
        else:
            cells += ["-"] * 7
        if r.size:
            i = r[0]
            status = str(ds["status"].values[i])
            reached = 100 * float(ds["time_reached"].values[i] / ds["stage_duration"].values[i])
            if status == "ok":
                verdict = f"survives ({float(ds['run_time'].values[i]):.1f} s)"
            elif status == "step_limit":
                verdict = f"not finished within the step cap ({reached:.0f}% of the stage)"
            else:
                verdict = f"fails: {status} at {reached:.1f}% of the stage"
            cells.append(verdict)
        else:
            cells.append("-")
        lines.append("| " + " | ".join(cells) + " |")
    path.write_text("\n".join(lines) + "\n")
    return path
