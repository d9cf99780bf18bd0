"""One case of a study, as time series: ``python -m pipeline show STUDY --case ...``.

What is drawn, for the chosen case (a figure of four panels, time in ms since first touch):
  (a) the force on the body per unit width;
  (b) the number of contact intervals (its exact record from the run);
  (c) the strain at a point x (default: where the largest tension occurred), with the
      running maximum of the tension over the plate on both surfaces (the run's record) and
      the study's yield strains, crack onset marked where the record reaches them;
  (d) the energy balance: plate and layer energy against the work done by the body, and the
      relative residual (E_plate + E_layer - W) / W on a second axis.
The curves come from solving the case again at many times (its stored parameters and solver
settings; the integration is deterministic, so the stored output times fall on them: they are
drawn as markers, read from the case's batch file after its checksum). The records and the
summary printed come from the batch file alone. A case not computed yet is solved here and
drawn from that (nothing is stored).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from .common.errors import StudyError
from .store.ledger import BATCHES, Ledger


class ShowError(Exception):
    """A case that cannot be shown (unknown id, ambiguous choice): one line for the user."""


def choose_case(study, spec: str | None) -> str:
    """The run id chosen by spec: a case id (or a unique prefix of one), key=value pairs
    separated by commas that pick one point of the grid (values compared as numbers; a point off
    the grid is solved, not stored), or case=N / sample=N, a position along a [[cases]] list or a
    [design]."""
    ids = study.run_ids
    if not spec:
        if len(ids) == 1:
            return ids[0]
        keys = ", ".join(study.varying_keys) or "the case id"
        raise ShowError(f"the study has {len(ids)} runs: choose one with --case ID or --case key=value,... "
                        f"(keys: {keys}; python -m pipeline status lists them)")
    if "=" not in spec:
        found = [cid for cid in ids if cid.startswith(spec)]
        if len(found) == 1:
            return found[0]
        if not found:
            raise ShowError(f"no case id of the study starts with {spec!r}")
        raise ShowError(f"{len(found)} case ids start with {spec!r}; give more of it")
    from solver import PARAMETER_INFO, SETTING_INFO
    wanted = {}
    for part in spec.split(","):
        key, _, value = part.partition("=")
        key, value = key.strip(), value.strip()
        if not key or not value:
            raise ShowError(f"--case {spec!r}: expected key=value pairs separated by commas")
        if key in ("case", "sample") and key in study.dims and len(spec.split(",")) == 1:
            if not value.isdigit() or int(value) >= study.n_cases:    # a position along case/sample
                raise ShowError(f"--case {key}={value}: give a number from 0 to {study.n_cases - 1}")
            return study.case_ids[int(value)]
        if key not in PARAMETER_INFO and key not in SETTING_INFO:
            raise ShowError(f"--case: {key!r} is not a parameter or solver setting")
        if key in wanted:
            raise ShowError(f"--case {spec!r}: {key} is given twice; show draws one case")
        wanted[key] = value
    matches = []
    for cid in ids:
        case = study.run(cid)
        try:
            if all(_same(case.value(k), v) for k, v in wanted.items()):
                matches.append(cid)
        except AttributeError as err:
            raise ShowError(f"--case: {err.args[0] if err.args else 'unknown key'} is not a parameter or "
                            f"solver setting") from None
    in_grid = [cid for cid in matches if cid in study.case_id_set]
    matches = in_grid or matches
    if len(matches) == 1:
        return matches[0]
    if not matches:
        return _off_grid(study, wanted, spec)
    raise ShowError(f"{len(matches)} cases have {spec}; add keys to pick one "
                    f"(varying: {', '.join(study.varying_keys)})")


def _off_grid(study, wanted: dict, spec: str) -> str:
    """A point the study did not compute (body_mass=500 on a grid of 300 and 1000): the one case
    of the study that matches the keys whose values it has, with the others set as asked. It is
    added to the study's runs for this call only; show solves it and stores nothing."""
    from solver import PARAMETER_INFO, SETTING_INFO

    from .study.identity import make_case
    unknown = [k for k in wanted if k not in PARAMETER_INFO and k not in SETTING_INFO]
    if unknown:
        raise ShowError(f"--case: {unknown[0]} is not a parameter or solver setting")
    cases = [study.run(cid) for cid in study.case_ids]
    on = {k: v for k, v in wanted.items() if any(_same(c.value(k), v) for c in cases)}
    off = {k: v for k, v in wanted.items() if k not in on}
    rest = [k for k in study.varying_keys if k not in off]           # what the off keys do not set
    base = {tuple(c.value(k) for k in rest): c.case_id
            for c in cases if all(_same(c.value(k), v) for k, v in on.items())}
    base = list(base.values())
    if len(base) != 1:
        others = [k for k in study.varying_keys if k not in wanted]
        raise ShowError(f"no case of the study has {spec}, and {len(base)} cases match the rest; give a value "
                        f"for {', '.join(others) or 'every varying key'} too")
    case = study.run(base[0])
    values = {**{k: case.value(k) for k in PARAMETER_INFO}, **case.settings.as_dict()}
    for key, text in off.items():
        current = values[key]
        if isinstance(current, str):
            values[key] = text
        else:
            try:
                values[key] = int(text) if isinstance(current, int) and not isinstance(current, bool) else float(text)
            except ValueError:
                raise ShowError(f"--case {key}={text}: not a number") from None
    try:
        extra = make_case((), values, study.output, spec)
    except StudyError as err:
        raise ShowError(str(err)) from None
    study._extra_runs[extra.case_id] = extra
    return extra.case_id


def _same(actual, text: str) -> bool:
    if isinstance(actual, str):
        return actual == text
    try:
        value = float(text)
    except ValueError:
        return False
    return bool(np.isclose(float(actual), value, rtol=1e-9, atol=0.0))


def stored_case(out_dir: Path, case_id: str, wider: dict | None = None):
    """The case's slice of its batch file (xarray, loaded; checksum verified), or None when
    the ledger has no entry for it; wider (Study.wider_ids): a case served by the stored run
    that computed everything gives that run's slice."""
    from .store.casefile import read_batch
    index = Ledger.load(out_dir).index(wider)
    if case_id not in index:
        return None
    entry, position = index[case_id]
    ds = read_batch(Path(out_dir) / BATCHES / entry["file"], entry.get("sha256"))
    position = list(ds["case"].values).index(entry["cases"][position][0])
    return ds, position


def stage_text(p) -> str:
    """'impact stage RULE = T ms': L^2/(6RV) for the paper's centred parabola, else b_mean/V; a
    run of a given duration (a free floe's) says so."""
    if p.duration > 0:
        return f"run of {'a free floe, ' if p.edges == 'free' else ''}duration = {p.duration * 1e3:.4g} ms"
    rule = "L^2/(6RV)" if p.parabola and not p.off_centre else "b_mean/V"
    return f"impact stage {rule} = {p.stage_duration * 1e3:.4g} ms"


def running_maximum(record: np.ndarray) -> tuple:
    """(t [s], m(t)) of a tension record: its nodes are values of the peak tension where the
    running maximum rose, of one peak or another (a piece's first node can lie below the
    maximum so far), so the running maximum is their accumulated maximum in time; it never
    falls."""
    order = np.argsort(record[:, 0], kind="stable")
    return record[order, 0], np.maximum.accumulate(record[order, 1])


def show(study, out_dir: Path, case_id: str, x: float | None = None, points: int = 400,
         figure: Path | None = None) -> tuple:
    """Draw the case; returns (figure path, text summary)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    from solver import solve

    from .figures.common import save
    from .store.casefile import tension_records

    case = study.run(case_id)
    p = case.parameters
    stored = stored_case(out_dir, case_id, study.wider_ids)
    lines = [f"case {case_id} of {study.name}: " + ", ".join(
        f"{k}={case.value(k):g}" if not isinstance(case.value(k), str) else f"{k}={case.value(k)}"
        for k in study.varying_keys)]
    lines.append("parameters: " + ", ".join(f"{k}={v if isinstance(v, str) else format(v, 'g')}"
                                            for k, v in p.as_dict().items()))
    lines.append(f"time scale t_sc = {p.time_scale * 1e3:.4g} ms, {stage_text(p)} (b_mean: the body's mean "
                 f"height over the plate)")
    records = None
    if stored is not None:
        ds, i = stored
        status, message = str(ds["status"].values[i]), str(ds["message"].values[i])
        t_reached = float(ds["time_reached"].values[i])
        lines.append(f"status: {status}" + (f" ({message})" if message else ""))
        records = tension_records(ds, (i,))
        contact = _contact_record(ds, i)
        for name, label in (("max_strain", "largest tension, upper surface"),
                            ("max_strain_lower", "largest tension, lower surface")):
            v = float(ds[name].values[i])
            lines.append(f"{label}: {v:.6g} at x = {float(ds[name + '_x'].values[i]):.4g} m, "
                         f"t = {float(ds[name + '_time'].values[i]) * 1e3:.4g} ms")
        lines.append(f"largest force: {float(ds['max_force'].values[i]):.4g} N/m; largest layer "
                     f"compression: {float(ds['max_compression'].values[i]):.4g}; energy residual / work: "
                     f"{float(ds['energy_residual'].values[i]):.2g}")
        x_peak = float(ds["max_strain_x"].values[i])
    else:
        lines.append("not computed yet in this results directory: solved here, nothing stored")
        ds = None
        x_peak = None

    settings = case.settings.__class__(**{**case.settings.as_dict(), "error_estimate": False})
    x_point = x if x is not None else (x_peak if x_peak is not None and np.isfinite(x_peak) else 0.0)
    if not -p.L <= x_point <= p.L:
        raise ShowError(f"--x {x_point:g} m is outside the plate (-{p.L:g} .. {p.L:g} m)")
    end = case.t_end
    times = np.linspace(0.0, end, max(points, 2))
    started = time.monotonic()
    # said before the solve: a case of thousands of modes takes minutes, and show would be silent
    print(f"solving the case for its curves ({p.Nmod} modes, {times.size} times) ...", file=sys.stderr, flush=True)
    r = solve(p, settings, times=times, fields=("strain",), x=np.array([x_point]), t_end=end,
              until_separation=case.end == "separation")
    print(f"solved in {time.monotonic() - started:.1f} s", file=sys.stderr, flush=True)
    if stored is None:
        status, message, t_reached = r.status, r.message, r.time_reached
        lines.append(f"status: {status}" + (f" ({message})" if message else ""))
        records = r.tension_record
        contact = r.contact_record
    ok = r.valid
    ms = times * 1e3

    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True, constrained_layout=True)
    (ax_f, ax_c), (ax_s, ax_e) = axes
    ax_f.plot(ms[ok], r.force[ok] / 1e6, color="C0", lw=1.5, label="force")
    ax_f.set_ylabel("force on the body [MN/m]")
    ax_f.set_title("(a) force" + (" and the body's speed" if p.free_body else ""), loc="left")
    if p.free_body:                      # a free body: its speed on a second axis
        ax_u = ax_f.twinx()
        ax_u.plot(ms[ok], r.body_speed[ok], color="C3", lw=1.2, ls="--")
        ax_u.axhline(0.0, color="C3", lw=0.6, ls=":")
        ax_u.set_ylabel("downward speed of the body U [m/s] (dashed)", color="C3")
        for name, style in (("stop_time", "v"), ("separation_time", "^")):
            t_event = r.diagnostics[name]
            if np.isfinite(t_event):
                ax_u.plot([t_event * 1e3], [np.interp(t_event, times[ok], r.body_speed[ok])], style,
                          color="C3", ms=7, label=name.replace("_", " "))
        if ax_u.get_legend_handles_labels()[0]:
            ax_u.legend(fontsize=8, loc="lower right")

    if contact is not None and len(contact):
        tc = np.append(contact[:, 0], t_reached) * 1e3
        cc = np.append(contact[:, 1], contact[-1, 1])
        ax_c.step(tc, cc, where="post", color="C1", lw=1.5, label="recorded changes")
    ax_c.set_ylabel("contact intervals on −L..L")
    ax_c.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax_c.set_title("(b) contact intervals", loc="left")

    ax_s.plot(ms[ok], r.fields["strain"][ok, 0], color="C2", lw=1.2, label=f"strain at x = {x_point:.3g} m")
    for surface, color in (("upper", "C3"), ("lower", "C4")):
        rec = records.get(surface) if records else None
        if rec is not None and len(rec):
            sign = 1.0 if surface == "upper" else -1.0
            t_rec, m_rec = running_maximum(rec)
            ax_s.plot(t_rec * 1e3, sign * m_rec, color=color, lw=1.0, ls="--", drawstyle="steps-post",
                      label=f"largest tension so far, {surface} surface" + (" (−)" if sign < 0 else ""))
    from solver import crack_onset
    eps_Y = sorted(float(e) for e in study.output.eps_Y)
    upper = records.get("upper") if records else None
    top = float(np.nanmax(upper[:, 1])) if upper is not None and len(upper) else np.nan
    # the yield strains the figure can show: at most three, spread over those above 5% of the
    # largest tension (smaller ones sit on the axis); every one is in the printed summary
    visible = [e for e in eps_Y if np.isfinite(top) and 0.05 * top <= e <= 1.2 * top]
    if len(visible) > 3:
        visible = [visible[0], visible[len(visible) // 2], visible[-1]]
    for e in visible:
        ax_s.axhline(e, color="0.5", lw=0.6, ls=":")
        t_on, _ = crack_onset(upper, e)
        if np.isfinite(t_on):
            ax_s.plot([t_on * 1e3], [e], "v", color="k", ms=6)
    if visible:
        ax_s.plot([], [], ":", color="0.5", label="yield strains εY (▼ crack onset)")
    if eps_Y and upper is not None:
        shown = eps_Y if len(eps_Y) <= 6 else [eps_Y[0], eps_Y[len(eps_Y) // 2], eps_Y[-1]]
        onsets = [(e, crack_onset(upper, e)) for e in shown]
        lines.append("crack onset, upper surface: " + "; ".join(
            f"εY = {e:.3g}: " + (f"{t * 1e3:.4g} ms at x = {xo:.3g} m" if np.isfinite(t) else "not reached")
            for e, (t, xo) in onsets) + (f" ({len(eps_Y)} εY in the study; study.nc has all)" if len(eps_Y) > 6 else ""))
    ax_s.set_ylabel("bending strain [1]")
    ax_s.set_xlabel("time since first touch [ms]")
    ax_s.set_title("(c) strain", loc="left")
    ax_s.legend(fontsize=8, loc="best")

    ax_e.plot(ms[ok], r.plate_energy[ok] / 1e3, color="C0", lw=1.3, label="plate E_plate")
    ax_e.plot(ms[ok], r.layer_energy[ok] / 1e3, color="C1", lw=1.3, label="layer E_layer")
    ax_e.plot(ms[ok], r.work[ok] / 1e3, color="k", lw=1.0, ls="--", label="work W")
    ax_e.set_ylabel("energy [kJ/m]")
    ax_e.set_xlabel("time since first touch [ms]")
    ax_e.set_title("(d) energy balance", loc="left")
    # relative to the work once it is 0.1% of its final value (before, a ratio of small numbers)
    w_end = np.nanmax(r.work[ok]) if ok.any() else np.nan
    grown = r.work > 1e-3 * w_end
    residual = np.where(grown, (r.plate_energy + r.layer_energy - r.work) / np.where(grown, r.work, 1.0), np.nan)
    twin = ax_e.twinx()
    twin.plot(ms[ok], residual[ok], color="C7", lw=0.8, alpha=0.8)
    twin.set_ylabel("(E_plate + E_layer − W) / W  (grey)", color="C7")
    twin.tick_params(axis="y", colors="C7")
    ax_e.legend(fontsize=8, loc="upper left")

    if ds is not None:
        i = stored[1]
        t_out = ds["time"].values[i] * 1e3
        ax_f.plot(t_out, ds["force"].values[i] / 1e6, "o", color="C0", ms=4, mfc="none",
                  label="stored output times")
        ax_c.plot(t_out, ds["contact_intervals"].values[i], "o", color="C1", ms=4, mfc="none",
                  label="stored output times")
        ax_c.legend(fontsize=8, loc="best")
    ax_f.legend(fontsize=8, loc="best")
    fig.suptitle(f"{study.name}, case {case_id}: " + ", ".join(
        f"{k} = {case.value(k):g}" for k in study.varying_keys if not isinstance(case.value(k), str))
        + f"  —  status {status}", fontsize=11)
    figure = Path(figure) if figure is not None else Path(out_dir) / f"case_{case_id}.png"
    if not figure.parent.is_dir():
        raise ShowError(f"cannot write {figure}: no directory {figure.parent}")
    save(fig, figure, dpi=130)
    plt.close(fig)
    lines.append(f"wrote {figure}")
    return figure, "\n".join(lines)


def _contact_record(ds, i: int):
    """(n, 2) rows (t, contact intervals) of case i of a batch dataset."""
    from .store.casefile import ragged_offsets
    counts = ds["contact_change_entries"].values
    start = int(ragged_offsets(counts)[i])
    n = int(counts[i])
    if n <= 0:
        return np.empty((0, 2))
    return np.stack([ds["contact_change_time"].values[start:start + n],
                     ds["contact_change_count"].values[start:start + n]], axis=-1)


__all__ = ["ShowError", "choose_case", "show", "stored_case"]
