"""The figures of a sweep (a [grid] or [[cases]]): the diagnostics against the swept keys
(lines, or maps over two keys) and crack onset against the yield strain."""
from __future__ import annotations

import itertools
import textwrap
from pathlib import Path

import matplotlib.colors
import matplotlib.ticker
import numpy as np
import xarray as xr

from solver import PAPER_EPS_Y

from ..study.analysis import CRACK_OUTPUTS
from ..common.tables import COMPLETE
from .common import (line_styles, log_spaced, save, tick_label, key_label, case_keys, case_labels,
                     spaced_labels, auto_log_y, yield_line, paper_eps_Y, walled, at_wall, margin, sweep_line,
                     plt)


DIAGNOSTICS = [
    ("max_strain", "max tensile strain, upper surface (plate-wide)"),
    ("max_strain_lower", "max tensile strain, lower surface (plate-wide)"),
    ("impact_zone_max_strain", "max tensile strain, upper surface (impact zone)"),
    ("impact_zone_max_strain_lower", "max tensile strain, lower surface (impact zone)"),
    ("crack_onset_time", "crack onset, upper [ms] (plate-wide)"),
    ("crack_onset_time_lower", "crack onset, lower [ms] (plate-wide)"),
    ("impact_zone_crack_onset_time", "crack onset, upper [ms] (impact zone)"),
    ("impact_zone_crack_onset_time_lower", "crack onset, lower [ms] (impact zone)"),
    ("max_contact_intervals", "max contact intervals"),
    ("max_force", "max force [N/m]; ▲: unbounded (bottomed out)"),
    ("max_compression", "max layer compression δ"),
    ("energy_residual", "energy residual / work"),
    ("run_time", "solver wall time [s]"),
]

#: more lines than this in a panel and the diagnostics become heat maps
MAX_LINES = 8



#: the diagnostics drawn as heat maps (a large study): name, title, log colour scale
MAP_DIAGNOSTICS = [
    ("max_strain", "max tensile strain, upper (plate-wide)", True),
    ("max_strain_lower", "max tensile strain, lower (plate-wide)", True),
    ("impact_zone_max_strain", "max tensile strain, upper (impact zone)", True),
    ("crack_onset_time", "crack onset, upper [ms] (plate-wide)", False),
    ("impact_zone_crack_onset_time", "crack onset, upper [ms] (impact zone)", False),
    ("max_contact_intervals", "max contact intervals", False),
    ("max_compression", "max layer compression δ", False),
    ("run_time", "solver wall time [s]", True),
]



def _middle(ds, key):
    return ds[key].values[(ds.sizes[key] - 1) // 2]



def diagnostics_maps(ds: xr.Dataset, dims: list, path: Path) -> Path:
    """A large grid: each diagnostic as a heat map over the two keys with the most values
    (small multiples: one column per value of the next key, at most 4 spread over its range);
    the other keys at their middle value, as the title says. Cases that did not end ok are
    marked ×."""
    ranked = sorted(dims, key=lambda d: -ds.sizes[d])          # stable: ties keep the file order
    first, second = ranked[0], ranked[1]
    third = ranked[2] if len(ranked) > 2 else None
    rest = {k: _middle(ds, k) for k in ranked[3:]}
    eps_y = paper_eps_Y(ds)
    columns = [None] if third is None else list(dict.fromkeys(
        ds[third].values[np.unique(np.linspace(0, ds.sizes[third] - 1, min(4, ds.sizes[third])).round().astype(int))]))
    shown = [entry for entry in MAP_DIAGNOSTICS if entry[0] in ds]    # (a file from before schema 10:
    fig, axes = plt.subplots(len(shown), len(columns), squeeze=False, sharex=True, sharey=True,  # no zone)
                             figsize=(3.6 * len(columns) + 1.5, 2.4 * len(shown) + 1.2),
                             constrained_layout=True)
    for r, (row, (name, title, log)) in enumerate(zip(axes, shown)):
        var = ds[name].sel(eps_Y=eps_y) * 1e3 if name in CRACK_OUTPUTS else ds[name]
        panels = [var.sel({**rest, **({third: c} if third else {})}).transpose(second, first).values.astype(float)
                  for c in columns]
        finite = np.concatenate([p[np.isfinite(p)].ravel() for p in panels])
        positive = finite[finite > 0]
        if log and positive.size:
            norm = matplotlib.colors.LogNorm(positive.min(), positive.max())
        elif finite.size:
            norm = matplotlib.colors.Normalize(finite.min(), finite.max())
        else:
            norm = None
        for ax, column, values in zip(row, columns, panels):
            where = {**rest, **({third: column} if third else {})}
            mesh = ax.pcolormesh(np.arange(ds.sizes[first]), np.arange(ds.sizes[second]),
                                 np.where(np.isfinite(values), values, np.nan), norm=norm, cmap="viridis",
                                 shading="nearest")
            bad = ~np.isin(ds["status"].sel(where).transpose(second, first).values, COMPLETE)
            yy, xx = np.nonzero(bad)
            ax.plot(xx, yy, "x", color="w", ms=3, mew=0.6)
            if r == 0:
                ax.set_title(key_label(third, column) if third else "", fontsize=10)
        fig.colorbar(mesh, ax=row[-1], label=title if name not in CRACK_OUTPUTS else f"{title}, εY = {eps_y:g}")
    for ax in axes[-1]:
        ticks = np.unique(np.linspace(0, ds.sizes[first] - 1, 4).round().astype(int))
        ax.set_xticks(ticks, [tick_label(v) for v in ds[first].values[ticks]])
        ax.set_xlabel(f"{first} [{ds[first].attrs.get('units', '1')}]")
    for ax in axes[:, 0]:
        ticks = np.unique(np.linspace(0, ds.sizes[second] - 1, 5).round().astype(int))
        ax.set_yticks(ticks, [tick_label(v) for v in ds[second].values[ticks]])
        ax.set_ylabel(f"{second} [{ds[second].attrs.get('units', '1')}]")
    title = "\n".join(textwrap.wrap(ds.attrs.get("description") or ds.attrs.get("study_name", ""), 140))
    title += f"\n{int(np.prod([ds.sizes[d] for d in dims]))} cases; × : the case did not end ok (see status)"
    if rest:
        title += "; at " + ", ".join(key_label(k, v) for k, v in rest.items())
    fig.suptitle(title, fontsize=11)
    save(fig, path, dpi=110)
    plt.close(fig)
    return path



#: the strain maxima: plate-wide, and of the impact zone (docs/model.md, "Maxima of the impact zone")
STRAINS = ("max_strain", "max_strain_lower", "impact_zone_max_strain", "impact_zone_max_strain_lower")



#: the plate-wide maxima whose place the figures mark when it is at a wall (x = +-L)
PLACED_MAXIMA = ("max_strain", "max_strain_lower")



def diagnostics_figure(ds: xr.Dataset, dims: list, path: Path) -> Path:
    """Each diagnostic against the first grid key, one line per value of the other keys (a
    grid with more than MAX_LINES combinations of the other keys: heat maps instead).
    Crack onsets are at the paper's yield strain (or the study's eps_Y nearest to it)."""
    first, others = dims[0], dims[1:]
    if len(others) and int(np.prod([ds.sizes[d] for d in others])) > MAX_LINES:
        return diagnostics_maps(ds, dims, path)
    eps_y = paper_eps_Y(ds)
    ds = ds.assign({name: ds[name].sel(eps_Y=eps_y) * 1e3 for name in CRACK_OUTPUTS if name in ds})
    panels = [entry for entry in DIAGNOSTICS if entry[0] in ds]      # (before schema 10: no zone)
    fig, axes = plt.subplots(-(-len(panels) // 3), 3, figsize=(13, 3.3 * -(-len(panels) // 3)),
                             constrained_layout=True)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    combos = list(itertools.product(*(ds[d].values for d in others))) or [()]
    styles = line_styles(len(combos))
    all_x = ds[first].values
    names = all_x.dtype.kind not in "iuf" or first == "case"   # names (layer_law), or [[cases]]
    if names:
        labels_x = case_labels(ds) if first == "case" else [str(v) for v in all_x]
        all_x = np.arange(all_x.size, dtype=float)
    on_axis = np.isfinite(all_x) if all_x.dtype.kind == "f" else np.ones(all_x.size, bool)
    if all_x.dtype.kind == "f" and np.any(all_x == 0) and log_spaced(all_x[on_axis & (all_x > 0)]):
        on_axis &= all_x > 0             # a sweep over decades and its neutral 0 (tau = 0)
    xvals = all_x[on_axis]               # an infinite key value (H, body_mass), or that 0: a dashed line
    log_x = not names and log_spaced(xvals)
    for ax, (name, title) in zip(axes.flat, panels):
        unbounded = []
        for (color, marker), combo in zip(styles, combos):
            where = dict(zip(others, combo))
            values = np.asarray(ds[name].sel(where).values, dtype=float)
            ok = np.isin(np.asarray(ds["status"].sel(where).values), COMPLETE)
            inf = np.isinf(values)
            shown = np.where(inf, np.nan, values)        # no meaningless value on an axis
            label = ", ".join(key_label(k, v) for k, v in zip(others, combo)) or None
            sweep_line(ax, all_x, shown, ok, on_axis, color, marker, label)
            unbounded.append((color, xvals[inf[on_axis]]))
            if name in PLACED_MAXIMA:                    # ringed: the maximum is at a wall
                wall = np.asarray(at_wall(ds, name).sel(where).values, dtype=bool) & on_axis
                ax.plot(all_x[wall], shown[wall], "o", mfc="none", mec="black", mew=1.0, ms=11)
            elif f"{name}_at_edge" in ds:                # diamond: at the impact zone's edge
                edge = (np.asarray(ds[f"{name}_at_edge"].sel(where).values) == 1.0) & on_axis
                ax.plot(all_x[edge], shown[edge], "D", mfc="none", mec="black", mew=1.0, ms=11)
        if any(x.size for _, x in unbounded):           # drawn just inside the top edge
            for i, (color, x) in enumerate(unbounded):   # one row per line, so none hides another
                ax.plot(x, np.full(x.size, 0.95 - 0.05 * i), "^", color=color, ms=7,
                        transform=ax.get_xaxis_transform())
        if log_x:
            ax.set_xscale("log")
            if xvals.size <= 10:                         # the swept values as plain tick labels
                ax.set_xticks(xvals, spaced_labels(xvals))
                ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        else:
            span = float(np.max(xvals) - np.min(xvals)) or 1.0
            ax.set_xlim(float(np.min(xvals)) - 0.03 * span, float(np.max(xvals)) + 0.03 * span)
            if names:
                ax.set_xticks(all_x, labels_x, rotation=30 if first == "case" else 0,
                              ha="right" if first == "case" else "center", fontsize=8)
            else:
                ax.ticklabel_format(axis="x", useOffset=False)
        if name in PLACED_MAXIMA and bool(np.any(walled(ds).values)):
            walls = int(np.sum(at_wall(ds, name).values & np.isfinite(ds[name].values)))
            title = f"{title}\n○: at a wall (x = ±L), {walls} of {ds[name].size} cases"
        elif name in PLACED_MAXIMA:
            title = f"{title}\nfree floe: no walls"
        elif name in STRAINS:
            title = f"{title}\ncontact's reach + {margin(ds):g} m" + (
                ", not within it of a wall" if bool(np.any(walled(ds).values)) else "")
            if f"{name}_at_edge" in ds:
                edges = int(np.sum(ds[f"{name}_at_edge"].values == 1.0))
                title += f"\n◇: at the zone's edge, {edges} of {ds[name].size} cases"
        ax.set_title(title if "crack onset" not in title else f"{title} at εY = {eps_y:g}", fontsize=10)
        ax.set_xlabel(f"{first} [{ds[first].attrs.get('units', '1')}]" if first != "case" else
                      "case (" + ", ".join(case_keys(ds) or ["[[cases]]"]) + ")")
        if name in STRAINS + ("energy_residual", "run_time", "max_force"):
            auto_log_y(ax, ds[name].values)
        if name in STRAINS:
            yield_line(ax, ds[name].values, eps_y)
        ax.grid(alpha=0.3, which="both" if log_x else "major")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    if labels:
        fig.legend(handles, labels, loc="outside lower center", ncol=min(4, len(labels)), fontsize=9)
    title = "\n".join(textwrap.wrap(ds.attrs.get("description") or ds.attrs.get("study_name", ""), 140))
    if not on_axis.all():
        title += f"\ndashed: {first} = {all_x[~on_axis][0]:g}"
    if not np.all(np.isin(ds["status"].values, COMPLETE)):
        title += ("\nopen markers: the case did not end ok (see status), e.g. the layer bottomed out: "
                  "values cover the run up to then")
    fig.suptitle(title, fontsize=11)
    save(fig, path, dpi=120)
    plt.close(fig)
    return path



def crack_onset_figure(ds: xr.Dataset, dims: list, path: Path) -> Path:
    """Crack-onset time [ms] against eps_Y (log axis), upper and lower surface, plate-wide (solid)
    and within the impact zone (dashed, where the study has it): one colour per value of the
    first key, one panel row per combination of the others (at most 6 rows)."""
    eps = ds["eps_Y"].values
    if dims == ["case"]:
        first, others = "case", []
        labels = case_labels(ds)
    else:
        first, others = dims[0], dims[1:]
        labels = [key_label(first, v) for v in ds[first].values]
    combos = list(itertools.product(*(ds[d].values for d in others))) or [()]
    rows = combos[:6]
    fig, axes = plt.subplots(len(rows), 2, figsize=(12, 3.2 * len(rows) + 1.0), squeeze=False,
                             constrained_layout=True, sharex=True)
    colors = [c for c, _ in line_styles(ds.sizes[first])]
    for row, combo in zip(axes, rows):
        where = dict(zip(others, combo))
        for ax, suffix, surface in ((row[0], "", "upper"), (row[1], "_lower", "lower")):
            for prefix, style, width, region in (("", "-", 1.8, "plate-wide"), ("impact_zone_", "--", 1.4, "impact zone")):
                if prefix + "crack_onset_time" + suffix not in ds:        # (before schema 11: no zone)
                    continue
                sel = ds[prefix + "crack_onset_time" + suffix].sel(where)
                for i, (color, label) in enumerate(zip(colors, labels)):
                    ax.loglog(eps, sel.isel({first: i}).values * 1e3, style, color=color, lw=width,
                              label=f"{label} ({region})" if len(labels) == 1 else (label if not prefix else None))
            ax.axvline(PAPER_EPS_Y, color="k", lw=0.8, ls="--")
            ax.set_ylabel("crack onset [ms]")
            ax.set_title(f"{surface} surface" + (", " + ", ".join(key_label(k, v) for k, v in where.items())
                                                   if where else ""), fontsize=10)
            ax.grid(alpha=0.3, which="both")
    for ax in axes[-1]:
        ax.set_xlabel("yield strain εY")
    handles, lab = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles[:12], lab[:12], loc="outside lower center", ncol=min(6, len(lab)), fontsize=9)
    title = ("First time the tension reaches εY: solid anywhere on the plate, dashed within the impact zone "
             "(vertical: the paper's 8e-5);\na line ends where εY is not reached")
    if len(combos) > len(rows):
        title += f"\n(first {len(rows)} of {len(combos)} combinations of {', '.join(others)})"
    fig.suptitle(title, fontsize=11)
    save(fig, path, dpi=120)
    plt.close(fig)
    return path


def draw_diagnostics(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    return [diagnostics_figure(ds, dims, out_dir / "diagnostics.png")], ""


def draw_crack_onset(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    return [crack_onset_figure(ds, dims, out_dir / "crack_onset.png")], ""
