"""What the figures share: matplotlib on Agg, the palette, labels and ticks, atomic saves, and
where a maximum sits (at a wall, in the zone's margin)."""
from __future__ import annotations

import json
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from solver import PAPER_EPS_Y, PARAMETER_INFO, SETTING_INFO  # noqa: E402

from ..store.casefile import temporary_path  # noqa: E402

#: Okabe-Ito colours (distinct in grey print and for colour-blind readers), then markers, one per line
PALETTE = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#000000", "#E69F00", "#56B4E9", "#999933"]



MARKERS = ["o", "s", "^", "D", "v", "P", "X", "h"]



def line_styles(n: int) -> list:
    """(colour, marker) of n lines: the palette while it lasts, then viridis."""
    if n <= len(PALETTE):
        return list(zip(PALETTE[:n], MARKERS[:n]))
    return [(plt.cm.viridis(v), "o") for v in np.linspace(0, 0.85, n)]



def log_spaced(values) -> bool:
    """True for keys swept over more than a decade in positive values (K, tolerance, tau...):
    they belong on a log axis (two values are enough: [0, 1e-4, 1e-2] has 1e-4 and 1e-2)."""
    v = np.asarray(values, dtype=float)
    return v.size >= 2 and bool(np.all(v > 0)) and float(v.max() / v.min()) >= 20.0



def save(fig, path, dpi) -> None:
    """savefig to a temporary file, then os.replace: a symlink at path is replaced, its target
    never written; an interrupted write leaves the old figure."""
    path = Path(path)
    tmp = temporary_path(path)
    try:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip("."))
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)



def save_text(path, text: str) -> None:
    path = Path(path)
    tmp = temporary_path(path)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)



def tick_label(value) -> str:
    """A key's value as a tick label: a name as it is, a number in %g."""
    return value if isinstance(value, str) else f"{value:g}"



def key_label(key, value):
    if isinstance(value, str):
        return f"{key} = {value}"
    units = (PARAMETER_INFO.get(key) or SETTING_INFO.get(key) or ("", "1"))[1]
    return f"{key} = {value:g}" + ("" if units in ("1", "") else f" {units}")



def case_keys(ds: xr.Dataset) -> list:
    """The keys that vary along a [[cases]] study's case dimension (its coordinates)."""
    return [k for k in ds.coords if ds[k].dims == ("case",) and k not in ("case", "group")]



def case_labels(ds: xr.Dataset) -> list:
    """One label per case of a [[cases]] study: its group, then the values of the keys that vary."""
    keys = case_keys(ds)
    labels = []
    for i in range(ds.sizes["case"]):
        parts = [key_label(k, ds[k].values[i].item() if hasattr(ds[k].values[i], "item") else ds[k].values[i])
                 for k in keys]
        group = str(ds["group"].values[i]) if "group" in ds.coords else ""
        labels.append(": ".join(p for p in (group, ", ".join(parts)) if p) or f"case {i}")
    return labels



def spaced_labels(values) -> list:
    """Tick labels for swept values on a log axis, blank where a label would run into the
    previous one (closer than 10% of the axis' decades)."""
    logs = np.log10(np.asarray(values, dtype=float))
    span = float(logs.max() - logs.min()) or 1.0
    labels, last = [], -np.inf
    for v, lv in zip(values, logs):
        keep = lv - last >= 0.1 * span
        labels.append(f"{v:g}" if keep else "")
        last = lv if keep else last
    return labels



def auto_log_y(ax, values) -> None:
    """A log y axis for positive values spanning more than a decade; else linear."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size and np.all(v > 0) and float(v.max() / v.min()) > 10.0:
        ax.set_yscale("log")
        ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda y, _: f"{y:g}"))
        ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())



def yield_line(ax, values, eps_y: float) -> None:
    """εY as a dashed line when it lies near the data; far below it, a note instead (the axis
    would otherwise spend decades of empty space reaching it)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v) & (v > 0)]
    if v.size and eps_y < v.min() / 10:
        ax.set_title(f"{ax.get_title()}\n(εY = {eps_y:g} is off the axis: every value ≥ {v.min() / eps_y:.0f}× εY)",
                     fontsize=10)
    else:
        ax.axhline(eps_y, color="k", lw=0.8, ls="--", label=None)



def paper_eps_Y(ds: xr.Dataset) -> float:
    """The paper's yield strain 8e-5 if the study has it, else the eps_Y nearest to it."""
    eps = ds["eps_Y"].values
    return float(eps[np.argmin(np.abs(np.log(eps / PAPER_EPS_Y)))])



def walled(ds: xr.Dataset) -> xr.DataArray:
    """True for the cases between walls (edges = "walls", and every case of a dataset from before
    free floes); a free floe's edges are not walls."""
    return ds["edges"] != "free" if "edges" in ds.variables else xr.DataArray(True)



def at_wall(ds: xr.Dataset, name: str) -> xr.DataArray:
    """True where the plate-wide maximum ``name`` sits at a wall, |name_x| = L (to 1e-9 L): in
    the paper's confined plate the ice rises along the walls and bends hardest there late in
    the stage (docs/user_guide.md, "Where the largest tension is"). Never on a free floe."""
    return (np.abs(ds[f"{name}_x"]) >= ds["L"] * (1.0 - 1e-9)) & walled(ds)



def margin(ds: xr.Dataset) -> float:
    """The study's impact_zone_margin [m] (a grid key, a setting, or the default)."""
    if "impact_zone_margin" in ds.coords:
        return float(np.max(ds["impact_zone_margin"].values))
    try:
        return float(json.loads(ds.attrs.get("solver_settings", "{}")).get("impact_zone_margin", 1.0))
    except (TypeError, ValueError):
        return 1.0



def design_axis(ax, ds, key, which, bounds: dict) -> None:
    """A sampled key's axis over the design's bounds, log where the design sampled it so."""
    values = np.asarray(ds[key].values, dtype=float)
    lo, hi, log = bounds.get(key, (values.min(), values.max(),
                                   bool(np.all(values > 0)) and values.max() / values.min() >= 20))
    pad = (hi / lo) ** 0.03 if log else 0.03 * (hi - lo)
    limits = (lo / pad, hi * pad) if log else (lo - pad, hi + pad)
    units = ds[key].attrs.get("units", "1")
    label = f"{key} [{units}]" if units not in ("1", "") else key
    axis = ax.xaxis if which == "x" else ax.yaxis
    (ax.set_xscale if which == "x" else ax.set_yscale)("log" if log else "linear")
    (ax.set_xlim if which == "x" else ax.set_ylim)(*limits)
    (ax.set_xlabel if which == "x" else ax.set_ylabel)(label)
    if log:
        axis.set_minor_formatter(matplotlib.ticker.NullFormatter())



def sweep_line(ax, x, values, ok, on_axis, color, marker, label) -> None:
    """One line of a sweep: the values over the key values on the axis, filled markers where
    the case ended complete (COMPLETE), open ones where it did not, and a legend entry; a key
    value off the axis (inf, or the neutral 0 of a sweep over decades) as a dashed line."""
    off = values[~on_axis]
    for value in off[np.isfinite(off)]:
        ax.axhline(value, color=color, lw=1.0, ls="--")
    xs, vs, good = x[on_axis], values[on_axis], ok[on_axis]
    ax.plot(xs, vs, "-", color=color, lw=1.6)
    ax.plot(xs[good], vs[good], marker, color=color, ms=6)
    ax.plot(xs[~good], vs[~good], marker, mfc="white", mec=color, mew=1.4, ms=6.5)
    ax.plot([], [], "-", color=color, lw=1.6, marker=marker, ms=6, label=label)   # legend entry
