"""The figures of a [design], its [analysis] and a [search]: the sampled points and their
outputs, the sensitivity indices, the critical value over the grid."""
from __future__ import annotations

import itertools
import json
import textwrap
from pathlib import Path

import matplotlib.colors
import matplotlib.ticker
import numpy as np
import xarray as xr

from ..store.sealed import problem
from ..common.tables import COMPLETE
from .common import log_spaced, save, tick_label, auto_log_y, paper_eps_Y, design_axis, plt

#: what the design figure colours its points by, and the panel of each against each key
DESIGN_OUTPUTS = [("max_strain", "max tensile strain (upper, plate-wide)"), ("max_force", "max force [N/m]"),
                  ("crack_onset_time", "crack onset, upper, plate-wide [ms]")]



def design_figure(ds: xr.Dataset, path: Path) -> Path:
    """A sampled design: a scatter matrix of the sampled keys (below the diagonal, each point
    coloured by max_strain), each key's effect on the outputs (the columns right of it: max
    strain, max force, crack onset at the paper's yield strain against the key). Open markers:
    the case did not end ok."""
    keys = [k for k in ds.coords if ds[k].dims == ("sample",) and k != "sample"]
    design = json.loads(ds.attrs.get("design", "{}"))
    logs = {k: tuple(v) for k, v in design.get("keys", {}).items()}      # key -> (min, max, log)
    eps_y = paper_eps_Y(ds)
    ok = np.isin(np.asarray(ds["status"].values), COMPLETE)
    colour = np.asarray(ds["max_strain"].values, dtype=float)
    finite = np.isfinite(colour) & (colour > 0)
    log_c = finite.any() and np.nanmax(colour[finite]) / np.nanmin(colour[finite]) > 20
    norm = matplotlib.colors.LogNorm() if log_c else None
    d, n_out = len(keys), len(DESIGN_OUTPUTS)
    fig, axes = plt.subplots(d, d - 1 + n_out if d > 1 else n_out, figsize=(2.6 * (d - 1 + n_out), 2.4 * d + 1.2),
                             squeeze=False, constrained_layout=True)


    scatter = None
    for i, ki in enumerate(keys):
        yi = np.asarray(ds[ki].values, dtype=float)
        for j in range(d - 1):
            ax = axes[i, j]
            if j >= i:
                ax.set_axis_off()
                continue
            xj = np.asarray(ds[keys[j]].values, dtype=float)
            scatter = ax.scatter(xj, yi, c=colour, s=16, norm=norm, cmap="viridis")
            ax.scatter(xj[~ok], yi[~ok], s=44, facecolors="none", edgecolors="#D55E00", lw=0.9)
            design_axis(ax, ds, keys[j], "x", logs)
            design_axis(ax, ds, ki, "y", logs)
        for c, (name, title) in enumerate(DESIGN_OUTPUTS):
            ax = axes[i, (d - 1 if d > 1 else 0) + c]
            values = ds[name].sel(eps_Y=eps_y) * 1e3 if name == "crack_onset_time" else ds[name]
            values = np.asarray(values.values, dtype=float)
            shown = np.where(np.isinf(values), np.nan, values)
            ax.scatter(yi[ok], shown[ok], s=12, color="#0072B2")
            ax.scatter(yi[~ok], shown[~ok], s=14, facecolors="none", edgecolors="#D55E00", lw=0.8)
            design_axis(ax, ds, ki, "x", logs)
            auto_log_y(ax, shown)
            if i == 0:
                ax.set_title(title if name != "crack_onset_time" else f"{title}, εY = {eps_y:g}", fontsize=10)
    if scatter is not None:
        fig.colorbar(scatter, ax=axes[:, :d - 1].ravel().tolist(), label="max tensile strain (upper)",
                     location="left", shrink=0.8)
    method = design.get("method", "design")
    title = (f"{ds.attrs.get('study_name', '')}: {ds.sizes['sample']} samples ({method}); "
             f"ringed or open: the case did not end ok (e.g. the layer bottomed out; values up to then)")
    fig.suptitle(title, fontsize=11)
    save(fig, path, dpi=110)
    plt.close(fig)
    return path



def sensitivity_figure(indices: xr.Dataset, path: Path) -> Path:
    """One panel per output: the keys' indices as bars with their confidence intervals (Sobol':
    first order S1 and total ST side by side; Morris: mu* with sigma marked)."""
    outputs, keys = list(indices["output"].values), list(indices["key"].values)
    sobol = "S1" in indices
    fig, axes = plt.subplots(1, len(outputs), figsize=(3.2 * len(outputs) + 1.0, 3.8), squeeze=False,
                             constrained_layout=True)
    x = np.arange(len(keys))
    for ax, out in zip(axes[0], outputs):
        sel = indices.sel(output=out)
        if sobol:
            lows = [sel[f"{n}_low"] if f"{n}_low" in sel else sel[n] - sel[f"{n}_conf"] for n in ("S1", "ST")]
            highs = [sel[f"{n}_high"] if f"{n}_high" in sel else sel[n] + sel[f"{n}_conf"] for n in ("S1", "ST")]
            for shift, name, lo, hi, colour, label in ((-0.2, "S1", lows[0], highs[0], "#0072B2", "S1 (first order)"),
                                                       (0.2, "ST", lows[1], highs[1], "#D55E00", "ST (total)")):
                value = np.asarray(sel[name], dtype=float)
                ax.bar(x + shift, value, 0.4, yerr=[value - np.asarray(lo), np.asarray(hi) - value], capsize=3,
                       color=colour, label=label)
            low = np.asarray(lows[0], dtype=float)
            ax.set_ylim(min(0.0, float(np.nanmin(low)) if np.isfinite(low).any() else 0.0) - 0.02, 1.05)
            ax.axhline(0.0, color="k", lw=0.6)
            if "refused" in sel and int(sel["refused"]):
                ax.text(0.5, 0.5, "\n".join(textwrap.wrap(f"refused: Q2 = {float(sel['q2']):.2f}", 24)),
                        transform=ax.transAxes, ha="center", va="center", fontsize=9, color="#D55E00")
        else:
            ax.bar(x, sel["mu_star"], 0.6, yerr=sel["mu_star_conf"], capsize=3, color="#0072B2", label="mu*")
            ax.plot(x, sel["sigma"], "D", color="#D55E00", label="sigma")
        censored = float(sel["censored"])
        fit = f"\nQ2 = {float(sel['q2']):.3f}, degree {int(sel['degree'])}" if "q2" in sel else ""
        ax.set_title(out + (f"\n({100 * censored:.0f}% censored)" if censored else "") + fit, fontsize=10)
        ax.set_xticks(x, keys)
        ax.grid(alpha=0.3, axis="y")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=9)
    analysis = json.loads(indices.attrs.get("analysis", "{}"))
    what = "sampling and truncation" if analysis.get("method") == "pce" else "bootstrap"
    fig.suptitle(f"{analysis.get('method', '')} sensitivity over {indices.attrs.get('samples', '')} cases "
                 f"({100 * float(indices.attrs.get('conf_level', 0.95)):.0f}% intervals: {what})", fontsize=11)
    save(fig, path, dpi=120)
    plt.close(fig)
    return path



def emulator_figure(indices: xr.Dataset, path: Path) -> Path:
    """The polynomial-chaos emulator of each output against the solver on runs it did not see:
    each run's prediction by the expansion fitted without its cross-validation fold, against
    the run's value, with the 1:1 line and the error estimate (the cross-validated RMSE)."""
    outputs = list(indices["output"].values)
    fig, axes = plt.subplots(1, len(outputs), figsize=(3.4 * len(outputs) + 0.6, 3.6), squeeze=False,
                             constrained_layout=True)
    for ax, out in zip(axes[0], outputs):
        sel = indices.sel(output=out)
        value, held = np.asarray(sel["value"], dtype=float), np.asarray(sel["held_out"], dtype=float)
        ax.scatter(value, held, s=9, color="#0072B2", alpha=0.7)
        ends = np.array([np.nanmin(value), np.nanmax(value)])
        rmse = float(sel["rmse"])
        ax.plot(ends, ends, color="k", lw=0.8)
        if np.isfinite(rmse):
            ax.fill_between(ends, ends - rmse, ends + rmse, color="#999999", alpha=0.3, lw=0, label="± error estimate")
        state = " (indices refused)" if int(sel["refused"]) else ""
        ax.set_title(f"{out}\nQ2 = {float(sel['q2']):.3f}, RMSE = {rmse:.3g}{state}", fontsize=9)
        ax.set(xlabel="computed", ylabel="emulator, held out")
        ax.grid(alpha=0.3)
    fig.suptitle(f"polynomial-chaos emulator over {indices.attrs.get('samples', '')} runs: each run predicted by the "
                 f"expansion fitted without it (5-fold cross-validation)", fontsize=10)
    save(fig, path, dpi=120)
    plt.close(fig)
    return path


def search_figure(ds: xr.Dataset, dims: list, search, path: Path) -> Path:
    """The critical value found by a threshold search: a map over two grid keys (one panel per
    yield strain), or a line with its bracket over one key or a design's samples."""
    key = search.key
    name = f"critical_{key}"
    eps = list(ds["eps_Y"].values) if "eps_Y" in ds.dims else [None]
    units = ds[name].attrs.get("units", "")
    fig, axes = plt.subplots(1, len(eps), figsize=(5.2 * len(eps) + 0.6, 4.2), squeeze=False,
                             constrained_layout=True)
    for ax, e in zip(axes[0], eps):
        sel = ds.sel(eps_Y=e) if e is not None else ds
        title = f"{search.event}" + (f", εY = {e:g}" if e is not None else "")
        if len(dims) == 2 and dims[0] in ds.coords and ds[dims[0]].dtype.kind == "f":
            y, x = dims                       # one cell per grid point, labelled by its values
            mesh = ax.pcolormesh(np.arange(ds.sizes[x]), np.arange(ds.sizes[y]), sel[name].values, shading="nearest",
                                 cmap="viridis", norm=matplotlib.colors.LogNorm() if search.log else None)
            fig.colorbar(mesh, ax=ax, label=f"critical {key} [{units}]")
            ax.set_xticks(np.arange(ds.sizes[x]), [tick_label(v) for v in ds[x].values])
            ax.set_yticks(np.arange(ds.sizes[y]), [tick_label(v) for v in ds[y].values])
            status = np.asarray(sel["search_status"].values)
            for i, j in itertools.product(range(ds.sizes[y]), range(ds.sizes[x])):
                value = float(sel[name].values[i, j])      # the value in its cell; why there is none
                ax.text(j, i, f"{value:.3g}" if np.isfinite(value) else str(status[i, j]).replace("_", " "),
                        ha="center", va="center", fontsize=8, color="w" if np.isfinite(value) else "k")
            ax.set(xlabel=f"{x} [{ds[x].attrs.get('units', '1')}]", ylabel=f"{y} [{ds[y].attrs.get('units', '1')}]")
        else:
            first = dims[0]
            xs = ds[first].values if ds[first].dtype.kind in "if" else np.arange(ds.sizes[first])
            values = np.asarray(sel[name].values, dtype=float).reshape(len(xs), -1)
            lo = np.asarray(sel[f"{name}_lower"].values, dtype=float).reshape(values.shape)
            hi = np.asarray(sel[f"{name}_upper"].values, dtype=float).reshape(values.shape)
            for j in range(values.shape[1]):
                ax.errorbar(xs, values[:, j], yerr=[values[:, j] - lo[:, j], hi[:, j] - values[:, j]], fmt="o-",
                            capsize=3)
            ax.set(xlabel=f"{first} [{ds[first].attrs.get('units', '1')}]", ylabel=f"critical {key} [{units}]")
            if search.log:
                ax.set_yscale("log")
                ax.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
                ax.yaxis.set_minor_formatter(matplotlib.ticker.ScalarFormatter())
            if log_spaced(xs):
                ax.set_xscale("log")
        ax.set_title(title, fontsize=10)
    fig.suptitle("\n".join(textwrap.wrap(
        f"{ds.attrs.get('title', '')}: the {key} at which the event first happens (final bracket within "
        f"{search.tolerance:g}{' relative' if search.log else ''}; {ds.attrs.get('runs', '')} runs)",
        60 * len(eps))), fontsize=10)
    save(fig, path, dpi=120)
    plt.close(fig)
    return path


def draw_design(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    return [design_figure(ds, out_dir / "design.png")], ""


def draw_sensitivity(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    """From the [analysis]'s sensitivity.nc beside study.nc (``ds`` is not read)."""
    source = out_dir / "sensitivity.nc"
    if not source.exists():
        return [], "sensitivity figure needs the [analysis]'s sensitivity.nc: skipped"
    wrong = problem(source)
    if wrong is not None:
        return [], f"sensitivity figure: {source} {wrong}: skipped (run again to rebuild it)"
    with xr.open_dataset(source) as indices:
        return [sensitivity_figure(indices.load(), out_dir / "sensitivity.png")], ""


def draw_emulator(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    """From the pce [analysis]'s sensitivity.nc beside study.nc (``ds`` is not read)."""
    source = out_dir / "sensitivity.nc"
    if not source.exists():
        return [], "emulator figure needs the [analysis]'s sensitivity.nc: skipped"
    wrong = problem(source)
    if wrong is not None:
        return [], f"emulator figure: {source} {wrong}: skipped (run again to rebuild it)"
    with xr.open_dataset(source) as indices:
        if "held_out" not in indices:
            return [], "emulator figure needs [analysis] method = \"pce\": skipped"
        return [emulator_figure(indices.load(), out_dir / "emulator.png")], ""
