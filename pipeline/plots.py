"""study.nc -> PNG figures in the study's results directory."""
from __future__ import annotations

import itertools
import json
import textwrap
from pathlib import Path

import matplotlib
import matplotlib.colors
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from solver import PAPER_EPS_Y, PARAMETER_INFO, SETTING_INFO  # noqa: E402

from .casefile import temporary_path  # noqa: E402
from .tables import COMPLETE  # noqa: E402

DIAGNOSTICS = [
    ("max_strain", "max tensile strain, upper surface (plate-wide)"),
    ("max_strain_lower", "max tensile strain, lower surface (plate-wide)"),
    ("impact_zone_max_strain", "max tensile strain, upper surface (impact zone)"),
    ("impact_zone_max_strain_lower", "max tensile strain, lower surface (impact zone)"),
    ("crack_onset_time", "crack onset, upper [ms]"),
    ("crack_onset_time_lower", "crack onset, lower [ms]"),
    ("max_contact_intervals", "max contact intervals"),
    ("max_force", "max force [N/m]; ▲: unbounded (bottomed out)"),
    ("max_compression", "max layer compression δ"),
    ("energy_residual", "energy residual / work"),
    ("run_time", "solver wall time [s]"),
]


#: Okabe-Ito colours (distinct in grey print and for colour-blind readers), then markers, one per line
PALETTE = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#000000", "#E69F00", "#56B4E9", "#999933"]
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "h"]


def _line_styles(n: int) -> list:
    """(colour, marker) of n lines: the palette while it lasts, then viridis."""
    if n <= len(PALETTE):
        return list(zip(PALETTE[:n], MARKERS[:n]))
    return [(plt.cm.viridis(v), "o") for v in np.linspace(0, 0.85, n)]


def _log_spaced(values) -> bool:
    """True for keys swept over more than a decade in positive values (K, tolerance, tau...):
    they belong on a log axis (two values are enough: [0, 1e-4, 1e-2] has 1e-4 and 1e-2)."""
    v = np.asarray(values, dtype=float)
    return v.size >= 2 and bool(np.all(v > 0)) and float(v.max() / v.min()) >= 20.0


def _save(fig, path, dpi) -> None:
    """savefig to a temporary file, then os.replace: a symlink at path is replaced, its target
    never written; an interrupted write leaves the old figure."""
    path = Path(path)
    tmp = temporary_path(path)
    try:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip("."))
        import os
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _save_text(path, text: str) -> None:
    import os
    path = Path(path)
    tmp = temporary_path(path)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _tick(value) -> str:
    """A key's value as a tick label: a name as it is, a number in %g."""
    return value if isinstance(value, str) else f"{value:g}"


def _label(key, value):
    if isinstance(value, str):
        return f"{key} = {value}"
    units = (PARAMETER_INFO.get(key) or SETTING_INFO.get(key) or ("", "1"))[1]
    return f"{key} = {value:g}" + ("" if units in ("1", "") else f" {units}")


def _case_keys(ds: xr.Dataset) -> list:
    """The keys that vary along a [[cases]] study's case dimension (its coordinates)."""
    return [k for k in ds.coords if ds[k].dims == ("case",) and k not in ("case", "group")]


def _case_labels(ds: xr.Dataset) -> list:
    """One label per case of a [[cases]] study: its group, then the values of the keys that vary."""
    keys = _case_keys(ds)
    labels = []
    for i in range(ds.sizes["case"]):
        parts = [_label(k, ds[k].values[i].item() if hasattr(ds[k].values[i], "item") else ds[k].values[i])
                 for k in keys]
        group = str(ds["group"].values[i]) if "group" in ds.coords else ""
        labels.append(": ".join(p for p in (group, ", ".join(parts)) if p) or f"case {i}")
    return labels


def crack_onset_figure(ds: xr.Dataset, dims: list, path: Path) -> Path:
    """Crack-onset time [ms] against eps_Y (log axis), upper and lower surface: one line per
    value of the first key, one panel row per combination of the others (at most 6 rows)."""
    eps = ds["eps_Y"].values
    if dims == ["case"]:
        first, others = "case", []
        labels = _case_labels(ds)
    else:
        first, others = dims[0], dims[1:]
        labels = [_label(first, v) for v in ds[first].values]
    combos = list(itertools.product(*(ds[d].values for d in others))) or [()]
    rows = combos[:6]
    fig, axes = plt.subplots(len(rows), 2, figsize=(12, 3.2 * len(rows) + 1.0), squeeze=False,
                             constrained_layout=True, sharex=True)
    colors = [c for c, _ in _line_styles(ds.sizes[first])]
    for row, combo in zip(axes, rows):
        where = dict(zip(others, combo))
        for ax, name, surface in ((row[0], "crack_onset_time", "upper"), (row[1], "crack_onset_time_lower", "lower")):
            sel = ds[name].sel(where)
            for i, (color, label) in enumerate(zip(colors, labels)):
                ax.loglog(eps, sel.isel({first: i}).values * 1e3, "-", color=color, label=label, lw=1.8)
            ax.axvline(PAPER_EPS_Y, color="k", lw=0.8, ls="--")
            ax.set_ylabel("crack onset [ms]")
            ax.set_title(f"{surface} surface" + (", " + ", ".join(_label(k, v) for k, v in where.items())
                                                   if where else ""), fontsize=10)
            ax.grid(alpha=0.3, which="both")
    for ax in axes[-1]:
        ax.set_xlabel("yield strain εY")
    handles, lab = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles[:12], lab[:12], loc="outside lower center", ncol=min(6, len(lab)), fontsize=9)
    title = "First time the tension reaches εY (dashed: the paper's 8e-5); a line ends where εY is not reached"
    if len(combos) > len(rows):
        title += f"\n(first {len(rows)} of {len(combos)} combinations of {', '.join(others)})"
    fig.suptitle(title, fontsize=11)
    _save(fig, path, dpi=120)
    plt.close(fig)
    return path


def _paper_eps_Y(ds: xr.Dataset) -> float:
    """The paper's yield strain 8e-5 if the study has it, else the eps_Y nearest to it."""
    eps = ds["eps_Y"].values
    return float(eps[np.argmin(np.abs(np.log(eps / PAPER_EPS_Y)))])


#: more lines than this in a panel and the diagnostics become heat maps
MAX_LINES = 8
#: the diagnostics drawn as heat maps (a large study): name, title, log colour scale
MAP_DIAGNOSTICS = [
    ("max_strain", "max tensile strain, upper (plate-wide)", True),
    ("max_strain_lower", "max tensile strain, lower (plate-wide)", True),
    ("impact_zone_max_strain", "max tensile strain, upper (impact zone)", True),
    ("crack_onset_time", "crack onset, upper [ms]", False),
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
    eps_y = _paper_eps_Y(ds)
    columns = [None] if third is None else list(dict.fromkeys(
        ds[third].values[np.unique(np.linspace(0, ds.sizes[third] - 1, min(4, ds.sizes[third])).round().astype(int))]))
    shown = [entry for entry in MAP_DIAGNOSTICS if entry[0] in ds]    # (a file from before schema 10:
    fig, axes = plt.subplots(len(shown), len(columns), squeeze=False, sharex=True, sharey=True,  # no zone)
                             figsize=(3.6 * len(columns) + 1.5, 2.4 * len(shown) + 1.2),
                             constrained_layout=True)
    for r, (row, (name, title, log)) in enumerate(zip(axes, shown)):
        var = ds[name].sel(eps_Y=eps_y) * 1e3 if name == "crack_onset_time" else ds[name]
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
                ax.set_title(_label(third, column) if third else "", fontsize=10)
        fig.colorbar(mesh, ax=row[-1], label=title if name != "crack_onset_time" else f"{title}, εY = {eps_y:g}")
    for ax in axes[-1]:
        ticks = np.unique(np.linspace(0, ds.sizes[first] - 1, 4).round().astype(int))
        ax.set_xticks(ticks, [_tick(v) for v in ds[first].values[ticks]])
        ax.set_xlabel(f"{first} [{ds[first].attrs.get('units', '1')}]")
    for ax in axes[:, 0]:
        ticks = np.unique(np.linspace(0, ds.sizes[second] - 1, 5).round().astype(int))
        ax.set_yticks(ticks, [_tick(v) for v in ds[second].values[ticks]])
        ax.set_ylabel(f"{second} [{ds[second].attrs.get('units', '1')}]")
    title = "\n".join(textwrap.wrap(ds.attrs.get("description") or ds.attrs.get("study_name", ""), 140))
    title += f"\n{int(np.prod([ds.sizes[d] for d in dims]))} cases; × : the case did not end ok (see status)"
    if rest:
        title += "; at " + ", ".join(_label(k, v) for k, v in rest.items())
    fig.suptitle(title, fontsize=11)
    _save(fig, path, dpi=110)
    plt.close(fig)
    return path


def _sweep_line(ax, x, values, ok, on_axis, color, marker, label) -> None:
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


#: the strain maxima: plate-wide, and of the impact zone (docs/model.md, "Maxima of the impact zone")
STRAINS = ("max_strain", "max_strain_lower", "impact_zone_max_strain", "impact_zone_max_strain_lower")


def _margin(ds: xr.Dataset) -> float:
    """The study's impact_zone_margin [m] (a grid key, a setting, or the default)."""
    if "impact_zone_margin" in ds.coords:
        return float(np.max(ds["impact_zone_margin"].values))
    try:
        return float(json.loads(ds.attrs.get("solver_settings", "{}")).get("impact_zone_margin", 1.0))
    except (TypeError, ValueError):
        return 1.0


#: the plate-wide maxima whose place the figures mark when it is at a wall (x = +-L)
PLACED_MAXIMA = ("max_strain", "max_strain_lower")


def walled(ds: xr.Dataset) -> xr.DataArray:
    """True for the cases between walls (edges = "walls", and every case of a dataset from before
    free floes); a free floe's edges are not walls."""
    return ds["edges"] != "free" if "edges" in ds.variables else xr.DataArray(True)


def at_wall(ds: xr.Dataset, name: str) -> xr.DataArray:
    """True where the plate-wide maximum ``name`` sits at a wall, |name_x| = L (to 1e-9 L): in
    the paper's confined plate the ice rises along the walls and bends hardest there late in
    the stage (docs/user_guide.md, "Where the largest tension is"). Never on a free floe."""
    return (np.abs(ds[f"{name}_x"]) >= ds["L"] * (1.0 - 1e-9)) & walled(ds)


def diagnostics_figure(ds: xr.Dataset, dims: list, path: Path) -> Path:
    """Each diagnostic against the first grid key, one line per value of the other keys (a
    grid with more than MAX_LINES combinations of the other keys: heat maps instead).
    Crack onsets are at the paper's yield strain (or the study's eps_Y nearest to it)."""
    first, others = dims[0], dims[1:]
    if len(others) and int(np.prod([ds.sizes[d] for d in others])) > MAX_LINES:
        return diagnostics_maps(ds, dims, path)
    eps_y = _paper_eps_Y(ds)
    ds = ds.assign({name: ds[name].sel(eps_Y=eps_y) * 1e3
                    for name in ("crack_onset_time", "crack_onset_time_lower")})
    panels = [entry for entry in DIAGNOSTICS if entry[0] in ds]      # (before schema 10: no zone)
    fig, axes = plt.subplots(-(-len(panels) // 3), 3, figsize=(13, 3.3 * -(-len(panels) // 3)),
                             constrained_layout=True)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    combos = list(itertools.product(*(ds[d].values for d in others))) or [()]
    styles = _line_styles(len(combos))
    all_x = ds[first].values
    names = all_x.dtype.kind not in "iuf" or first == "case"   # names (layer_law), or [[cases]]
    if names:
        labels_x = _case_labels(ds) if first == "case" else [str(v) for v in all_x]
        all_x = np.arange(all_x.size, dtype=float)
    on_axis = np.isfinite(all_x) if all_x.dtype.kind == "f" else np.ones(all_x.size, bool)
    if all_x.dtype.kind == "f" and np.any(all_x == 0) and _log_spaced(all_x[on_axis & (all_x > 0)]):
        on_axis &= all_x > 0             # a sweep over decades and its neutral 0 (tau = 0)
    xvals = all_x[on_axis]               # an infinite key value (H, body_mass), or that 0: a dashed line
    log_x = not names and _log_spaced(xvals)
    for ax, (name, title) in zip(axes.flat, panels):
        unbounded = []
        for (color, marker), combo in zip(styles, combos):
            where = dict(zip(others, combo))
            values = np.asarray(ds[name].sel(where).values, dtype=float)
            ok = np.isin(np.asarray(ds["status"].sel(where).values), COMPLETE)
            inf = np.isinf(values)
            shown = np.where(inf, np.nan, values)        # no meaningless value on an axis
            label = ", ".join(_label(k, v) for k, v in zip(others, combo)) or None
            _sweep_line(ax, all_x, shown, ok, on_axis, color, marker, label)
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
                ax.set_xticks(xvals, _spaced_labels(xvals))
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
            title = f"{title}\ncontact's reach + {_margin(ds):g} m" + (
                ", not within it of a wall" if bool(np.any(walled(ds).values)) else "")
            if f"{name}_at_edge" in ds:
                edges = int(np.sum(ds[f"{name}_at_edge"].values == 1.0))
                title += f"\n◇: at the zone's edge, {edges} of {ds[name].size} cases"
        ax.set_title(title if "crack onset" not in title else f"{title} at εY = {eps_y:g}", fontsize=10)
        ax.set_xlabel(f"{first} [{ds[first].attrs.get('units', '1')}]" if first != "case" else
                      "case (" + ", ".join(_case_keys(ds) or ["[[cases]]"]) + ")")
        if name in STRAINS + ("energy_residual", "run_time", "max_force"):
            _auto_log_y(ax, ds[name].values)
        if name in STRAINS:
            _yield_line(ax, ds[name].values, eps_y)
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
    _save(fig, path, dpi=120)
    plt.close(fig)
    return path


#: the drop figure's panels: variable (or derived name), title, log y when it spans a decade
DROP_PANELS = [
    ("max_strain", "max tensile strain, upper surface"),
    ("max_force", "max force [N/m]"),
    ("max_penetration", "deepest penetration of the body [m]"),
    ("restitution", "rebound speed / impact speed V"),
    ("separation_time", "contact time: separation [ms]"),
    ("crack_onset_time", "crack onset, upper [ms]"),
]


def drop_figure(ds: xr.Dataset, dims: list, path: Path) -> Path:
    """A free body against its mass (the grid key body_mass, on a log axis): max strain, max
    force, deepest penetration, restitution (rebound over impact speed), contact time and crack
    onset at the paper's yield strain; one line per combination of the other keys. The
    paper's body (body_mass = inf in the grid) is the dashed line each curve tends to."""
    others = [d for d in dims if d != "body_mass"]
    eps_y = _paper_eps_Y(ds)
    V = ds["V"]
    derived = {"restitution": ds["separation_speed"] / V,
               "separation_time": ds["separation_time"] * 1e3,
               "crack_onset_time": ds["crack_onset_time"].sel(eps_Y=eps_y) * 1e3}
    masses = ds["body_mass"].values
    finite = np.isfinite(masses)
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), constrained_layout=True)
    combos = list(itertools.product(*(ds[d].values for d in others))) or [()]
    styles = _line_styles(len(combos))
    for ax, (name, title) in zip(axes.flat, DROP_PANELS):
        var = derived.get(name, ds[name] if name in ds else None)
        for (color, marker), combo in zip(styles, combos):
            where = dict(zip(others, combo))
            values = np.asarray(var.sel(where).values, dtype=float)
            ok = np.isin(np.asarray(ds["status"].sel(where).values), COMPLETE)
            label = ", ".join(_label(k, v) for k, v in zip(others, combo)) or None
            _sweep_line(ax, masses, values, ok, finite, color, marker, label)
        ax.set_xscale("log")
        ax.set_xlabel("body_mass [kg/m]")
        ax.set_title(title if name != "crack_onset_time" else f"{title} at εY = {eps_y:g}", fontsize=10)
        if name in ("max_strain", "max_force", "max_penetration"):
            _auto_log_y(ax, var.sel(body_mass=masses[finite]).values)
        ax.grid(alpha=0.3, which="both")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    if labels:
        fig.legend(handles, labels, loc="outside lower center", ncol=min(4, len(labels)), fontsize=9)
    title = ds.attrs.get("description") or ds.attrs.get("study_name", "")
    note = "dashed: the paper's body at constant speed (body_mass = inf)" if not finite.all() else ""
    note += ("; " if note else "") + "no point: the body had not left the ice (or stopped) within the run"
    fig.suptitle("\n".join(textwrap.wrap(title, 140) + [note]), fontsize=11)
    _save(fig, path, dpi=120)
    plt.close(fig)
    return path


def _spaced_labels(values) -> list:
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


def _auto_log_y(ax, values) -> None:
    """A log y axis for positive values spanning more than a decade; else linear."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size and np.all(v > 0) and float(v.max() / v.min()) > 10.0:
        ax.set_yscale("log")
        ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda y, _: f"{y:g}"))
        ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())


def _yield_line(ax, values, eps_y: float) -> None:
    """εY as a dashed line when it lies near the data; far below it, a note instead (the axis
    would otherwise spend decades of empty space reaching it)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v) & (v > 0)]
    if v.size and eps_y < v.min() / 10:
        ax.set_title(f"{ax.get_title()}\n(εY = {eps_y:g} is off the axis: every value ≥ {v.min() / eps_y:.0f}× εY)",
                     fontsize=10)
    else:
        ax.axhline(eps_y, color="k", lw=0.8, ls="--", label=None)


#: the paper's figure 2 snapshots [t_sc]
PAPER_FIG2_TIMES = (3.8, 4.0, 4.2, 4.4, 4.6)


def paper_fig2(ds: xr.Dataset, dims: list, path: Path, times=PAPER_FIG2_TIMES) -> Path:
    """The paper's figure 2 for the first case: (a) body and ice at 3.8 t_sc, with an inset on
    the contact zone where the layer (thickness he) shows, (b) deflection, (c) layer pressure,
    (d) upper-surface strain at 3.8 ... 4.6 t_sc."""
    case = ds.isel({d: 0 for d in dims})
    x = case["x"].values

    def param(key):
        return float(case[key].values)

    R, he, V = param("R"), param("he"), param("V")
    t_sc = float(case["t_sc"].values)
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5), constrained_layout=True)
    k38 = case["t"].sel(t=times[0], method="nearest")
    t38 = float(case["time"].sel(t=k38))
    w38 = case["deflection"].sel(t=k38).values
    body = x**2 / (2 * R) + he - V * t38
    ax = axes[0, 0]
    ax.plot(x, body, "k-", lw=1.6, label="body surface")
    ax.plot(x, w38, "C0-", lw=1.6, label="ice, upper surface")
    ax.set_title(f"(a) body and ice at t = {float(k38):.1f} t_sc = {t38 * 1e3:.1f} ms", loc="left")
    ax.set_ylabel("y [m]")
    ax.set_ylim(-V * t38 - 0.1, max(0.5, float(np.nanmax(w38)) + 0.1))
    ax.legend(loc="lower left", fontsize=9)
    # the 2 cm layer is invisible at this scale: an inset on the contact zone
    touch = np.flatnonzero(body - (w38 + he) <= he)          # within a layer thickness of touching
    half = float(np.max(np.abs(x[touch]))) * 1.3 if touch.size else 0.2 * float(np.max(x))
    half = max(half, 0.02 * float(np.max(x)))                # touching at x = 0 alone: a visible zone
    zoom = np.abs(x) <= half
    inset = ax.inset_axes([0.33, 0.5, 0.34, 0.45])           # the empty space between the body's flanks
    inset.fill_between(x[zoom], w38[zoom], w38[zoom] + he, color="C0", alpha=0.25, lw=0,
                       label=f"layer, he = {he * 100:g} cm")
    inset.plot(x[zoom], w38[zoom], "C0-", lw=1.2)
    inset.plot(x[zoom], body[zoom], "k-", lw=1.2)
    lo = float(np.nanmin(w38[zoom]))
    inset.set_ylim(lo - 1.5 * he, lo + 4 * he)
    inset.set_xlim(-half, half)
    inset.tick_params(labelsize=7)
    inset.set_title("contact zone", fontsize=8, pad=2)
    inset.legend(fontsize=7, loc="lower right")
    ax.indicate_inset_zoom(inset, edgecolor="0.4")
    panels = [(axes[0, 1], "deflection", "(b) deflection", "w [m]", 1.0),
              (axes[1, 0], "layer_pressure", "(c) layer pressure", "P_e [MPa]", 1e-6),
              (axes[1, 1], "strain", "(d) bending strain, upper surface", "ε [–] (positive: tension)", 1.0)]
    colors = plt.cm.plasma(np.linspace(0, 0.85, len(times)))
    for ax, name, title, ylabel, scale in panels:
        for i, tt in enumerate(times):
            sel = case[name].sel(t=tt, method="nearest")
            ax.plot(x, sel.values * scale, color=colors[i], lw=1.4,
                    label=f"({i + 1}) t = {float(sel['t']):.1f} t_sc = {float(sel['t']) * t_sc * 1e3:.1f} ms")
        ax.set_title(title, loc="left")
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=8)
    for ax in axes.flat:
        ax.set_xlabel("x [m]")
        ax.grid(alpha=0.3)
    units = {"K": ("MPa", 1e-6), "he": ("cm", 100.0), "R": ("m", 1.0), "V": ("m/s", 1.0), "hi": ("m", 1.0)}
    fig.suptitle("Impact of a parabolic body on floating ice: " + ", ".join(
        f"{k} = {param(k) * units[k][1]:g} {units[k][0]}" for k in units)
        + f", {int(param('Nmod'))} modes; t_sc = 1/ω₁ = {t_sc * 1e3:.2f} ms", fontsize=11)
    _save(fig, path, dpi=120)
    plt.close(fig)
    return path


#: what the design figure colours its points by, and the panel of each against each key
DESIGN_OUTPUTS = [("max_strain", "max tensile strain (upper)"), ("max_force", "max force [N/m]"),
                  ("crack_onset_time", "crack onset [ms]")]


def design_figure(ds: xr.Dataset, path: Path) -> Path:
    """A sampled design: a scatter matrix of the sampled keys (below the diagonal, each point
    coloured by max_strain), each key's effect on the outputs (the columns right of it: max
    strain, max force, crack onset at the paper's yield strain against the key). Open markers:
    the case did not end ok."""
    keys = [k for k in ds.coords if ds[k].dims == ("sample",) and k != "sample"]
    design = json.loads(ds.attrs.get("design", "{}"))
    logs = {k: tuple(v) for k, v in design.get("keys", {}).items()}      # key -> (min, max, log)
    eps_y = _paper_eps_Y(ds)
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
            _design_axis(ax, ds, keys[j], "x", logs)
            _design_axis(ax, ds, ki, "y", logs)
        for c, (name, title) in enumerate(DESIGN_OUTPUTS):
            ax = axes[i, (d - 1 if d > 1 else 0) + c]
            values = ds[name].sel(eps_Y=eps_y) * 1e3 if name == "crack_onset_time" else ds[name]
            values = np.asarray(values.values, dtype=float)
            shown = np.where(np.isinf(values), np.nan, values)
            ax.scatter(yi[ok], shown[ok], s=12, color="#0072B2")
            ax.scatter(yi[~ok], shown[~ok], s=14, facecolors="none", edgecolors="#D55E00", lw=0.8)
            _design_axis(ax, ds, ki, "x", logs)
            _auto_log_y(ax, shown)
            if i == 0:
                ax.set_title(title if name != "crack_onset_time" else f"{title}, εY = {eps_y:g}", fontsize=10)
    if scatter is not None:
        fig.colorbar(scatter, ax=axes[:, :d - 1].ravel().tolist(), label="max tensile strain (upper)",
                     location="left", shrink=0.8)
    method = design.get("method", "design")
    title = (f"{ds.attrs.get('study_name', '')}: {ds.sizes['sample']} samples ({method}); "
             f"ringed or open: the case did not end ok (e.g. the layer bottomed out; values up to then)")
    fig.suptitle(title, fontsize=11)
    _save(fig, path, dpi=110)
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
            ax.bar(x - 0.2, sel["S1"], 0.4, yerr=sel["S1_conf"], capsize=3, color="#0072B2", label="S1 (first order)")
            ax.bar(x + 0.2, sel["ST"], 0.4, yerr=sel["ST_conf"], capsize=3, color="#D55E00", label="ST (total)")
            ax.set_ylim(min(0.0, float(np.nanmin(sel["S1"] - sel["S1_conf"]))) - 0.02, 1.05)
            ax.axhline(0.0, color="k", lw=0.6)
        else:
            ax.bar(x, sel["mu_star"], 0.6, yerr=sel["mu_star_conf"], capsize=3, color="#0072B2", label="mu*")
            ax.plot(x, sel["sigma"], "D", color="#D55E00", label="sigma")
        censored = float(sel["censored"])
        ax.set_title(out + (f"\n({100 * censored:.0f}% censored)" if censored else ""), fontsize=10)
        ax.set_xticks(x, keys)
        ax.grid(alpha=0.3, axis="y")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=9)
    analysis = json.loads(indices.attrs.get("analysis", "{}"))
    fig.suptitle(f"{analysis.get('method', '')} sensitivity over {indices.attrs.get('samples', '')} cases "
                 f"({100 * float(indices.attrs.get('conf_level', 0.95)):.0f}% intervals)", fontsize=11)
    _save(fig, path, dpi=120)
    plt.close(fig)
    return path


def search_figure(ds: xr.Dataset, dims: list, search: dict, path: Path) -> Path:
    """The critical value found by a threshold search: a map over two grid keys (one panel per
    yield strain), or a line with its bracket over one key or a design's samples."""
    key = search["key"]
    name = f"critical_{key}"
    eps = list(ds["eps_Y"].values) if "eps_Y" in ds.dims else [None]
    units = ds[name].attrs.get("units", "")
    fig, axes = plt.subplots(1, len(eps), figsize=(5.2 * len(eps) + 0.6, 4.2), squeeze=False,
                             constrained_layout=True)
    for ax, e in zip(axes[0], eps):
        sel = ds.sel(eps_Y=e) if e is not None else ds
        title = f"{search['event']}" + (f", εY = {e:g}" if e is not None else "")
        if len(dims) == 2 and dims[0] in ds.coords and ds[dims[0]].dtype.kind == "f":
            y, x = dims                       # one cell per grid point, labelled by its values
            mesh = ax.pcolormesh(np.arange(ds.sizes[x]), np.arange(ds.sizes[y]), sel[name].values, shading="nearest",
                                 cmap="viridis", norm=matplotlib.colors.LogNorm() if search["log"] else None)
            fig.colorbar(mesh, ax=ax, label=f"critical {key} [{units}]")
            ax.set_xticks(np.arange(ds.sizes[x]), [_tick(v) for v in ds[x].values])
            ax.set_yticks(np.arange(ds.sizes[y]), [_tick(v) for v in ds[y].values])
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
            if search["log"]:
                ax.set_yscale("log")
                ax.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
                ax.yaxis.set_minor_formatter(matplotlib.ticker.ScalarFormatter())
            if _log_spaced(xs):
                ax.set_xscale("log")
        ax.set_title(title, fontsize=10)
    fig.suptitle("\n".join(textwrap.wrap(
        f"{ds.attrs.get('title', '')}: the {key} at which the event first happens (final bracket within "
        f"{search['tolerance']:g}{' relative' if search['log'] else ''}; {ds.attrs.get('runs', '')} runs)",
        60 * len(eps))), fontsize=10)
    _save(fig, path, dpi=120)
    plt.close(fig)
    return path


def _design_axis(ax, ds, key, which, bounds: dict) -> None:
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


def make_plots(ds: xr.Dataset, dims: list, kinds: list, out_dir: Path) -> list:
    """The figures a study asks for; returns the paths written and a note per figure skipped."""
    out_dir = Path(out_dir)
    written, notes = [], []
    for kind in kinds:
        if dims == ["sample"] and kind not in ("design", "sensitivity"):
            notes.append(f"{kind} figure is for a [grid] or [[cases]]; a [design] draws \"design\": skipped")
            continue
        if kind == "sensitivity":
            source = out_dir / "sensitivity.nc"
            if not source.exists():
                notes.append("sensitivity figure needs the [analysis]'s sensitivity.nc: skipped")
                continue
            with xr.open_dataset(source) as indices:
                written.append(sensitivity_figure(indices.load(), out_dir / "sensitivity.png"))
        elif kind == "design":
            if dims != ["sample"]:
                notes.append("design figure needs a [design]: skipped")
                continue
            written.append(design_figure(ds, out_dir / "design.png"))
        elif kind == "diagnostics":
            written.append(diagnostics_figure(ds, dims, out_dir / "diagnostics.png"))
        elif kind == "drop":
            if "body_mass" not in dims:
                notes.append("drop figure needs body_mass as a [grid] key: skipped")
                continue
            written.append(drop_figure(ds, dims, out_dir / "drop.png"))
        elif kind == "crack_onset":
            written.append(crack_onset_figure(ds, dims, out_dir / "crack_onset.png"))
        elif kind == "paper_fig2":
            needed = {"deflection", "layer_pressure", "strain"}
            if not needed <= set(ds.data_vars) or ds["t"].attrs.get("long_name", "").find("t_sc") < 0:
                notes.append("paper_fig2 needs deflection, layer_pressure and strain at times in t_sc: skipped")
                continue
            case = ds.isel({d: 0 for d in dims})
            reached = float(case["time_reached"]) / float(case["t_sc"])
            if not reached >= PAPER_FIG2_TIMES[-1] * (1 - 1e-9):
                notes.append(f"paper_fig2 shows the first case at 3.8 ... 4.6 t_sc, and it ended at {reached:.3g} t_sc "
                             f"({case['status'].item()}): skipped")
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
    _save(fig, path, dpi=110)
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
    _save_text(path, "\n".join(lines) + "\n")
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
    _save_text(path, "\n".join(lines) + "\n")
    return path
