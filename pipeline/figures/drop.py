"""The drop figure: penetration, rebound and contact time against the body's mass."""
from __future__ import annotations

import itertools
import textwrap
from pathlib import Path

import numpy as np
import xarray as xr

from ..common.tables import COMPLETE
from .common import line_styles, save, key_label, auto_log_y, paper_eps_Y, sweep_line, plt


#: the drop figure's panels: variable (or derived name), title, log y when it spans a decade
DROP_PANELS = [
    ("max_strain", "max tensile strain, upper surface"),
    ("max_force", "max force [N/m]"),
    ("max_penetration", "deepest penetration of the body [m]"),
    ("restitution", "rebound speed / impact speed V"),
    ("separation_time", "contact time: separation [ms]"),
    ("crack_onset_time", "crack onset, upper, plate-wide [ms]"),
]



def drop_figure(ds: xr.Dataset, dims: list, path: Path) -> Path:
    """A free body against its mass (the grid key body_mass, on a log axis): max strain, max
    force, deepest penetration, restitution (rebound over impact speed), contact time and crack
    onset at the paper's yield strain; one line per combination of the other keys. The
    paper's body (body_mass = inf in the grid) is the dashed line each curve tends to."""
    others = [d for d in dims if d != "body_mass"]
    eps_y = paper_eps_Y(ds)
    V = ds["V"]
    derived = {"restitution": ds["separation_speed"] / V,
               "separation_time": ds["separation_time"] * 1e3,
               "crack_onset_time": ds["crack_onset_time"].sel(eps_Y=eps_y) * 1e3}
    masses = ds["body_mass"].values
    finite = np.isfinite(masses)
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), constrained_layout=True)
    combos = list(itertools.product(*(ds[d].values for d in others))) or [()]
    styles = line_styles(len(combos))
    for ax, (name, title) in zip(axes.flat, DROP_PANELS):
        var = derived.get(name, ds[name] if name in ds else None)
        for (color, marker), combo in zip(styles, combos):
            where = dict(zip(others, combo))
            values = np.asarray(var.sel(where).values, dtype=float)
            ok = np.isin(np.asarray(ds["status"].sel(where).values), COMPLETE)
            label = ", ".join(key_label(k, v) for k, v in zip(others, combo)) or None
            sweep_line(ax, masses, values, ok, finite, color, marker, label)
        ax.set_xscale("log")
        ax.set_xlabel("body_mass [kg/m]")
        ax.set_title(title if name != "crack_onset_time" else f"{title} at εY = {eps_y:g}", fontsize=10)
        if name in ("max_strain", "max_force", "max_penetration"):
            auto_log_y(ax, var.sel(body_mass=masses[finite]).values)
        ax.grid(alpha=0.3, which="both")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    if labels:
        fig.legend(handles, labels, loc="outside lower center", ncol=min(4, len(labels)), fontsize=9)
    title = ds.attrs.get("description") or ds.attrs.get("study_name", "")
    note = "dashed: the paper's body at constant speed (body_mass = inf)" if not finite.all() else ""
    note += ("; " if note else "") + "no point: the body had not left the ice (or stopped) within the run"
    fig.suptitle("\n".join(textwrap.wrap(title, 140) + [note]), fontsize=11)
    save(fig, path, dpi=120)
    plt.close(fig)
    return path


def draw(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    if "body_mass" not in dims:
        return [], "drop figure needs body_mass as a [grid] key: skipped"
    return [drop_figure(ds, dims, out_dir / "drop.png")], ""
