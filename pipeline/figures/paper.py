"""The paper's Fig. 2: deflection, layer pressure and strain of the first case at 3.8 ... 4.6 t_sc."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from .common import save, plt


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
    save(fig, path, dpi=120)
    plt.close(fig)
    return path


def draw(ds: xr.Dataset, dims: list, out_dir: Path) -> tuple:
    needed = {"deflection", "layer_pressure", "strain"}
    if not needed <= set(ds.data_vars) or ds["t"].attrs.get("long_name", "").find("t_sc") < 0:
        return [], "paper_fig2 needs deflection, layer_pressure and strain at times in t_sc: skipped"
    case = ds.isel({d: 0 for d in dims})
    reached = float(case["time_reached"]) / float(case["t_sc"])
    if not reached >= PAPER_FIG2_TIMES[-1] * (1 - 1e-9):
        return [], (f"paper_fig2 shows the first case at 3.8 ... 4.6 t_sc, and it ended at {reached:.3g} t_sc "
                    f"({case['status'].item()}): skipped")
    return [paper_fig2(ds, dims, out_dir / "paper_fig2.png")], ""
