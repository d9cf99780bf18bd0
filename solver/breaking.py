r"""A run in which the ice breaks (docs/model.md, "Breaking into parts"): :func:`solve_breaking`.

The run goes in stages. Each stage integrates the plate as it is (unbroken, then broken at the
breaks so far) and ends where either surface's tension first reaches the yield strain eps_Y,
located on true sub-steps of the integrator (solver.ending). There the plate breaks
through its thickness: the next stage runs on the parts (solver.model.parts), from the state
carried across the new break (w and w_t projected in the stiffness and the mass). A free edge
carries no moment, so a break cannot reach eps_Y again where it is: the cascade goes on elsewhere
until the run's end or until the plate would have more than ``max_parts`` parts (status
``parts_limit``). With a finite ``crack_speed`` each crack opens over hi / crack_speed: its faces
first carry the moment and shear the ice carried there (``_crack``), released on the stages that
follow (solver.model.crack; docs/model.md, "A crack that opens over a time").

**The carried state's overshoot.** The parts' modes all have w'' = 0 at the new free edge, so the
curvature carried across a break is fitted with an overshoot next to it (Gibbs): the reference
case at N = 30, broken at 1.18 m at 1.62 ms, has 8.7e-5 at 0.93 m just after the break, above
eps_Y = 8e-5, though the tension there was below eps_Y before it (away from the edge the exact
strain is continuous in time). The overshoot travels off on the fastest modes within a quarter of
their period (2e-5 s there). So a surface breaks only once its tension at the nodes has been below
eps_Y since the stage began (solver.ending: the surfaces are "armed"); the tension records keep the
tension the stages reach from there on.

The stages are joined into one Result on the run's output times: the fields, the series (the
work and the dissipated energy summed over the stages), the diagnostics (each by the join
solver.outputs declares for it: maxima from the joined tension records, the largest force with
its time, counts summed, ...), the records and the breaks. The energy identity of the whole run is

    E_plate + E_layer + D + R = W,

R(t) the energy the breaks before t removed (Result.breaking.removed_energy, over the output times):
what the projection onto the parts' modes leaves out, E_plate + E_layer before a break minus
after it.

**Breakthrough.** The body has broken through when the ice under it has been cut from the walls:
a break on each side of the body's centre (on the half plate of a centred impact, one break off
the centre: its mirror is the other side), so that the part under the body reaches no wall. Its
time and the body's penetration then are diagnostics of the run. (A break "beyond the contact"
would be knife-edge: the upper surface breaks at the contact's edge, 0.217 m at 0.233 ms where
the contact reached 0.216 m in studies/breakthrough.toml at hi = 0.1, V = 10 m/s.)
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from . import layout as kn
from .blas import blas_alone
from .outputs import DIAGNOSTIC_JOINS, SERIES
from .parameters import ParameterError
from .run import Result, checked_breaks, cosines_to_kernel, run_case
from .model.assemble import Tables
from .model.peak_margin import competing
from .spec import Begin, Breaking, BreakEvent, Crack, RunSpec

#: the statuses of a breaking run beyond the kernels' (docs/model.md, "Statuses")
PARTS_LIMIT, EDGE_BREAK, NONFINITE = "parts_limit", "edge_break", "nonfinite"
#: a stage after the first starts with this fraction of the previous stage's largest step (the
#: first touch's short first step, and the 10 % a step it may grow by, would cost some 120 steps
#: a stage)
RESTART_STEP = 0.1
#: a break located within this fraction of L of the plate's centre is at the centre (the peak's
#: place there is found to round-off)
CENTRE_SNAP = 1e-9
#: at a break, the same surface's tension elsewhere within this fraction of the break level breaks
#: at the same instant (_racing): a tie to round-off (3.7e-14 measured between the whole plate's
#: two walls under a centred impact)
RACE = 1e-9


def _restart_step(stages):
    """The first step of the next stage [s]: RESTART_STEP of the last stage's largest (None: the
    first touch's, for the first stage, or where the integrator reports no steps, DOP853)."""
    h = RESTART_STEP * stages[-1][1].largest_step if stages else math.nan
    return h if math.isfinite(h) and h > 0.0 else None


def _growth_from(p, spec, t0):
    """The time the next stage's step growth cap counts from (solver.control.GROWTH): the run's
    first touch where each crack opens at once (the stage starts from a carried state, not a
    self-similar one: its short first step grows by the PI control, docs/model.md, "Why a stage
    starts with a short step"); the stage's start t0 [s] where cracks open over a time (their
    faces' power is taken on the steps' stages, which then stay short beside the opening)."""
    return spec.window.t_start if p.crack_opening_time == 0.0 else t0


def _snapped(p, x):
    """A break's place x [m] on the plate, at the centre (0) where within CENTRE_SNAP L of it on the
    half plate, and at the wall (+-L) where within CENTRE_SNAP L of it (the peak's place there is
    the end node's, or found to round-off)."""
    if abs(x) < CENTRE_SNAP * p.L and not p.off_centre:
        return 0.0
    return math.copysign(p.L, x) if abs(x) >= p.L * (1.0 - CENTRE_SNAP) else x


def _racing(p, tab, kernel_breaks, amplitudes, where, broken):
    """The other places (x on the plate) where the surface that broke at ``where`` (a StageEnd's
    break) stands at the break level too, within RACE of it, at that instant: local peaks of its
    tension (refined by Newton on the modes within their part) off the places ``broken`` and, with
    a crack spacing, beyond it from them (none on a floe's edges). Two tensions tied to round-off
    (the whole plate's two walls, or x and -x, under a centred impact) break at once, as the half
    plate breaks x and its mirror (docs/model.md, "A break at a wall"). tab: the Tables of the plate
    that broke, at kernel_breaks."""
    sign = (1.0 if where.surface == "upper" else -1.0) * -0.5 * p.hi
    level, origin, dx = p.yield_strain, tab.origin, tab.dx
    cuts = np.sort(np.asarray(kernel_breaks if kernel_breaks is not None else [], dtype=float))
    nodes = tab.xq
    tension = sign * tab.derivative(amplitudes, nodes, 2)
    keep = p.crack_spacing * p.hi
    found = []
    margin = competing(np.ascontiguousarray(tension), level, tab.model.basis.reach, math.inf)
    for j in np.flatnonzero(tension >= level - margin):    # (a peak may stand above its nodes)
        if (j > 0 and tension[j - 1] > tension[j]) or (j < nodes.size - 1 and tension[j + 1] > tension[j]):
            continue
        x = nodes[j]
        if 0 < j < nodes.size - 1:               # Newton on the modes, within the node's part
            lo = max([nodes[j - 1]] + [c for c in cuts if c <= nodes[j]])
            hi = min([nodes[j + 1]] + [c for c in cuts if c > nodes[j]])
            for _ in range(20):
                slope, bend = (sign * float(tab.derivative(amplitudes, x, order)[0]) for order in (3, 4))
                step = -slope / bend if bend < 0.0 else 0.0
                x = min(max(x + step, lo), hi)
                if abs(step) < 1e-12 * p.L:
                    break
        value = sign * float(tab.derivative(amplitudes, x, 2)[0])
        place = float(_snapped(p, float(x) + origin))
        near = any(abs(place - b) <= max(keep, 2.0 * dx) for b in broken + found)
        if value >= level * (1.0 - RACE) and not near and not _free_edge(p, place, broken):
            found.append(place)
    return found


def _free_edge(p, x, broken) -> bool:
    """Whether x [m] on the plate is a free edge already: a place broken, or a floe's edge."""
    return x in broken or (p.edges == "free" and abs(x) == p.L)


def _crack(p, tab, amplitudes, time, x):
    """The crack opening at the break at x [m] at time [s] (a solver.spec.Crack): the moment D w_xx
    and shear D w_xxx the plate that broke (tab, its Tables) carried there in the state of kernel
    amplitudes, which its faces carry at first (solver.model.crack)."""
    at = x - tab.origin                               # (kernel coordinates, as checked_breaks's)
    w2, w3 = (float(tab.derivative(amplitudes, at, order)[0]) for order in (2, 3))
    return Crack(time, at, p.rigidity * w2, p.rigidity * w3)


def at_wall(breaks, L) -> np.ndarray:
    """(B,) bool: which breaks (x on the plate) are at a wall, |x| = L: the ice broken off it."""
    return np.abs(np.asarray(breaks, dtype=float)) == float(L)


def whole_plate_parts(breaks, full, L=math.inf) -> int:
    """The number of parts of the whole plate broken at ``breaks`` (x on the plate): one more
    than its breaks inside the plate, where on the half plate of a centred impact each break but
    the centre's stands for two (x and -x); a break at a wall (|x| = L) cuts no part off."""
    b = np.asarray(breaks, dtype=float)
    b = b[~at_wall(b, L)]
    cuts = b.size if full else 2 * np.count_nonzero(b != 0.0) + np.count_nonzero(b == 0.0)
    return int(cuts) + 1


def broken_through(breaks, x0, full, L=math.inf) -> bool:
    """Whether the breaks cut the ice under the body off the rest of the ice: a break inside the
    plate on each side of the body's centre x0 (on the half plate, one off the centre: its mirror
    is the other). A break at a wall frees the ice from it but cuts nothing off the ice."""
    b = np.asarray(breaks, dtype=float)
    b = b[~at_wall(b, L)]
    if full:
        return bool(np.any(b < x0) and np.any(b > x0))
    return bool(np.any(b > 0.0))


@blas_alone
def solve_breaking(p, s, spec: RunSpec) -> Result:
    """The run of ``spec`` (solver.spec.RunSpec, from the unbroken plate at rest) in which the plate
    breaks where its tension first reaches p.yield_strain, and again on its parts, to at most
    p.max_parts parts (module docstring): run a stage; while it ended at a break, carry its end
    (Result.end) across and run the next. Returns the stages joined into one Result, its breaks in
    ``Result.breaking`` (solver.spec.Breaking: each break, the energy removed over the output times,
    the stages' own Results, the plate the kernels ran; its first break, count, parts and
    breakthrough)."""
    if spec.asked.end != "stage":
        raise ParameterError("fracture = 'break' runs to t_end, or to a free body's separation (end = 'stage')")
    yield_strain, max_parts, full, times = p.yield_strain, p.max_parts, spec.full_plate, spec.window.times
    zeros = cosines_to_kernel(np.zeros(p.Nmod), full)
    begin, breaks, t0 = Begin(zeros, zeros.copy()), [], spec.window.t_start
    stages, events, status, message, cracks = [], [], None, "", []
    opening = p.crack_opening_time                    # (0: each crack opens at once)
    while True:
        later = times >= t0 if not stages else times > t0
        kernel_breaks = checked_breaks(p, s, breaks, full) if breaks else None
        try:
            stage = run_case(p, s, replace(spec, window=replace(spec.window, times=times[later], t_start=t0),
                                           begin=begin, breaks=kernel_breaks, break_level=float(yield_strain),
                                           first_step=_restart_step(stages), growth_from=_growth_from(p, spec, t0),
                                           cracks=tuple(c for c in cracks if c.time + opening > t0)))
        except np.linalg.LinAlgError as error:          # (a broken plate's wet modes, or the carry onto them)
            if not stages:
                raise
            status, message = NONFINITE, _no_wet_modes(breaks, t0, error)
            break
        stages.append((later, stage))
        end = stage.end
        if end.carried is not None:              # (breaks at one instant: their carry's, on the last)
            for event in events[:-1]:
                if event["time"] == events[-1]["time"]:
                    event.update(removed_energy=0.0, removed_plate_energy=0.0, removed_layer_energy=0.0)
            events[-1].update(removed_energy=end.carried.removed, removed_plate_energy=end.carried.plate_removed,
                              removed_layer_energy=end.carried.layer_removed)
        if stage.status != "ok" or end.broke is None:
            break
        where = end.broke
        x_b = _snapped(p, where.x)
        if _free_edge(p, x_b, breaks):
            status = EDGE_BREAK
            message = (f"the tension reached yield_strain = {yield_strain:g} at a free edge (x = {x_b:.6g} m, t = "
                       f"{where.time:.6g} s, {where.surface} surface), which carries no moment in the model: the "
                       f"basis is too coarse there; data up to then is valid")
            break
        tab = Tables(p, s.subintervals, full, s.quadrature, s.quadrature_density, breaks=kernel_breaks)
        places = [x_b] + _racing(p, tab, kernel_breaks, end.state.amplitudes, where, breaks + [x_b])
        new_breaks = sorted(breaks + places)
        if whole_plate_parts(new_breaks, full, p.L) > max_parts:
            status = PARTS_LIMIT
            message = (f"the plate would break into more than max_parts = {max_parts} parts at t = "
                       f"{where.time:.6g} s (x = {x_b:.6g} m, {where.surface} surface); data up to then is valid")
            break
        body = end.state.body
        for k, x in enumerate(places):
            so_far = breaks + places[:k + 1]
            events.append({"time": where.time, "x": x, "surface": where.surface,
                           "parts": whole_plate_parts(so_far, full, p.L),
                           "broken_through": broken_through(so_far, p.x0, full, p.L),
                           "penetration": p.V * where.time if body is None else body.penetration})
            if opening > 0.0:
                cracks.append(_crack(p, tab, end.state.amplitudes, where.time, x))
        breaks, t0 = new_breaks, stage.time_reached
        begin = Begin(end.state.amplitudes, end.state.velocities, kernel_breaks, body)
    return _joined(p, s, spec, stages, events, status, message, full)


def _no_wet_modes(breaks, time, error) -> str:
    """The message of a run that ends where a broken plate's wet modes cannot be computed (a
    factorisation of its mass or stiffness failed: parts the basis cannot resolve)."""
    places = ", ".join(f"{x:.6g}" for x in breaks)
    return (f"the plate broken at x = {places} m has no wet modes the solver can compute at t = {time:.6g} s "
            f"({error}); data up to then is valid")


def joined_record(records):
    """One running-maximum tension record from the stages' (solver.fracture's rows): a later
    stage's rows where they pass the largest value so far, the first of them starting a new
    piece (join 0)."""
    rows, top = [], -math.inf
    for rec in records:
        kept = rec[rec[:, kn.R_VALUE] > top].copy()
        if kept.size:
            if rows:
                kept[0, kn.R_JOIN] = 0.0
            rows.append(kept)
            top = kept[-1, kn.R_VALUE]
    return np.vstack(rows) if rows else np.empty((0, kn.N_REC))


def _joined_series(spec, stages):
    """The fields, series and amplitudes over the run's output times from the stages' (the
    amplitudes are the unbroken plate's: NaN after the first break, where the modes are the
    parts'), the work and dissipated energy summed over the stages, and the removed energy R."""
    T, first = spec.window.times.size, stages[0][1]
    fields = {name: np.full((T,) + v.shape[1:], np.nan) for name, v in first.fields.items()}
    series = {row.attribute: np.full(T, np.nan) for row in SERIES if row.attribute is not None}
    amplitudes = {name: np.full((T,) + getattr(first, name).shape[1:], np.nan)
                  for name in ("amplitudes", "velocities", "antisymmetric_amplitudes", "antisymmetric_velocities")}
    removed_series, valid = np.full(T, np.nan), np.zeros(T, bool)
    work = dissipated = removed = 0.0
    for i, (rows, stage) in enumerate(stages):
        if stage.end.carried is not None:             # the stage starts at a break
            removed += stage.end.carried.removed
        at = np.flatnonzero(rows)[stage.valid]
        valid[at] = True
        for name in fields:
            fields[name][at] = stage.fields[name][stage.valid]
        for name in series:
            series[name][at] = getattr(stage, name)[stage.valid]
        series["work"][at] += work
        series["dissipated_energy"][at] += dissipated
        removed_series[at] = removed
        if i == 0:
            for name in amplitudes:
                amplitudes[name][at] = getattr(stage, name)[stage.valid]
        work += stage.diagnostics["work"]
        dissipated += stage.diagnostics["dissipated_energy"]
    return fields, series, amplitudes, removed_series, valid


#: a record row's column by the name a join gives it (solver.outputs.JOINS)
_COLUMNS = {"value": kn.R_VALUE, "x": kn.R_X, "time": kn.R_T}


def _largest_stage(results, name):
    """The first stage whose diagnostic ``name`` is largest (NaN counts as none)."""
    return max(results, key=lambda r: np.nan_to_num(r.diagnostics[name], nan=-np.inf))


def _residual(results, name):
    """A residual over the whole run (solver.outputs.JOINS["residual"]): each stage's is against
    its own energy scale (the energy it starts with plus its largest work); against the whole
    run's, the largest work so far, summed (a bound). NaN stays NaN (a free body's, for the
    paper's body)."""
    value = results[-1].diagnostics[name]
    if np.isnan(value):
        return value
    before, scale = 0.0, 0.0
    for r in results:
        carried = r.end.carried.after if r.end.carried is not None else 0.0
        scale = max(scale, before + r.end.energy_scale - carried)
        before += r.diagnostics["work"]
    return sum(r.diagnostics[name] * r.end.energy_scale for r in results) / scale if scale > 0 else 0.0


def joined_diagnostics(results, records) -> dict:
    """The whole run's diagnostics from its stages' Results, each by its declared join
    (solver.outputs.DIAGNOSTIC_JOINS, in the order they are declared: a "larger" join reads
    values joined before it); records: the joined tension records."""
    last, d = results[-1], {}
    for name, (kind, *args) in DIAGNOSTIC_JOINS.items():
        if kind == "record":
            rec = records.get(args[0])
            d[name] = rec[-1, _COLUMNS[args[1]]] if rec is not None and rec.size else last.diagnostics[name]
        elif kind == "larger":
            upper, lower = d[args[0]], d[args[1]]
            if np.isfinite(upper) or np.isfinite(lower):
                side = args[0] if np.nan_to_num(upper, nan=-1.0) >= np.nan_to_num(lower, nan=-1.0) else args[1]
                d[name] = d[side + args[2]]
            else:
                d[name] = last.diagnostics[name]
        elif kind in ("largest", "with"):
            d[name] = _largest_stage(results, args[0] if args else name).diagnostics[name]
        elif kind == "sum":
            d[name] = sum(r.diagnostics[name] for r in results)
        elif kind == "first":
            found = [r for r in results if np.isfinite(r.diagnostics[args[0]])]
            d[name] = (found[0] if found else last).diagnostics[name]
        elif kind == "residual":
            d[name] = _residual(results, name)
        else:                                              # "last"
            d[name] = last.diagnostics[name]
    return d


def _joined(p, s, spec, stages, events, status, message, full):
    """The stages as one Result (module docstring)."""
    fields, series, amplitudes, removed_series, valid = _joined_series(spec, stages)
    results = [stage for _, stage in stages]
    last = results[-1]
    names = results[0].tension_record.keys()
    records = {name: joined_record([r.tension_record[name] for r in results]) for name in names}
    contacts = np.vstack([r.contact_record for r in results])
    diagnostics = joined_diagnostics(results, records)
    extra = {}
    breaking = Breaking(tuple(BreakEvent(**event) for event in events), removed_series, tuple(results), full)
    locate = spec.asked.locate_eps_Y
    if locate is not None and np.size(locate):
        located = {}
        for surface in ("upper", "lower"):
            t = np.full(np.size(locate), np.nan)
            x = t.copy()
            for r in results:
                rt, rx = r.extra["located_crack_onset"][surface]
                new = np.isnan(t) & np.isfinite(rt)
                t[new], x[new] = rt[new], rx[new]
            located[surface] = (t, x)
        extra["located_crack_onset"] = located
    if status is None:
        status, message = last.status, last.message
    return Result(parameters=p, settings=s, times=spec.window.times, x=spec.asked.x, fields=fields, **amplitudes, **series,
                  valid=valid, diagnostics=diagnostics, status=status, message=message,
                  time_reached=last.time_reached, steps=sum(r.steps for r in results),
                  rejected_steps=sum(r.rejected_steps for r in results),
                  forcing_evaluations=sum(r.forcing_evaluations for r in results),
                  smallest_step=min(r.smallest_step for r in results),
                  largest_step=max(r.largest_step for r in results), wall_time=sum(r.wall_time for r in results),
                  tension_record=records, contact_record=contacts, extra=extra, outputs=last.outputs,
                  end_reason="end" if status == "ok" else status, end=last.end, breaking=breaking)
