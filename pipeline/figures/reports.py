"""The reports of the numerics studies: error against run time (work_precision) and the stiff
and extreme cases against a second integrator (extremes)."""
from __future__ import annotations

from pathlib import Path

import matplotlib.colors
import matplotlib.ticker
import numpy as np
import xarray as xr

from solver import PARAMETER_INFO

from .common import PALETTE, save, save_text, key_label, plt

def _physical_cases(ds: xr.Dataset) -> list:
    """(label, boolean mask over case) for each distinct physical case of a case-list study."""
    keys = [k for k in PARAMETER_INFO if k != "Nmod" and k in ds.coords and ds[k].dims == ("case",)]
    combos = sorted({tuple(float(ds[k].values[i]) for k in keys) for i in range(ds.sizes["case"])})
    out = []
    for combo in combos:
        mask = np.ones(ds.sizes["case"], bool)
        for k, v in zip(keys, combo):
            mask &= ds[k].values == v
        out.append((", ".join(key_label(k, v) for k, v in zip(keys, combo)) or "reference case", mask))
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
        for (name, marker), color in zip((("rk4", "s"), ("etd34", "o"), ("dop853", "^")), PALETTE):
            sel = mask & (group == "integrator") & (ds["integrator"].values == name)
            order = np.argsort(run[sel])
            ax.loglog(run[sel][order], err[sel][order], marker + "-", color=color, label=name)
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
            ax.set_ylabel("relative L2 strain error")
            ax.set_title(f"{label}\n{title} (etd34, tolerance 1e-10)\nlabels: solver wall time of each run",
                         fontsize=10)
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    for ax in axes.flat:
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("Error against run time: errors are relative to each case's reference run "
                 "(same physics, tighter numerics or more modes); times are single runs", fontsize=11)
    save(fig, path, dpi=110)
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
    save_text(path, "\n".join(lines) + "\n")
    return path



def extremes_table(ds: xr.Dataset, path: Path) -> Path:
    """Markdown: per extreme case, how the default integrator fares and whether rk4 survives."""
    group, integ = ds["group"].values, ds["integrator"].values
    lines = ["| case | etd34 status | reached [% of stage] | steps (rejected) | smallest step [s] "
             "| largest δ | energy residual | wall [s] | rk4 at the paper's rule |",
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
            elif status == "layer_bottomed_out":
                verdict = f"bottoms out too, at {reached:.1f}% of the stage"
            elif status == "step_limit":
                verdict = f"not finished within the step cap ({reached:.0f}% of the stage)"
            else:
                verdict = f"fails: {status} at {reached:.1f}% of the stage"
            cells.append(verdict)
        else:
            cells.append("-")
        lines.append("| " + " | ".join(cells) + " |")
    save_text(path, "\n".join(lines) + "\n")
    return path


def draw_work_precision(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    if "error_strain" not in ds or "group" not in ds.coords:
        return [], "work_precision needs a [[cases]] study with groups and a [reference]: skipped"
    return [work_precision_figure(ds, out_dir / "work_precision.png"),
            work_precision_table(ds, out_dir / "work_precision.md")], ""


def draw_extremes(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    if "group" not in ds.coords or "integrator" not in ds.coords:
        return [], "extremes needs a [[cases]] study with groups and two integrators: skipped"
    return [extremes_table(ds, out_dir / "extremes.md")], ""
