"""One run of a checked case (solver.core.solve's body, and each stage of a run that breaks,
solver.breaking): its Model (solver.model.assemble), the state carried across a break, the
kernels (solver.loop.integrate, or DOP853), and the Result, with the fields the caller asked for
from the modal amplitudes at the output times."""
from __future__ import annotations

import math
import time as _time
from collections import namedtuple
from dataclasses import dataclass, field, replace

import numpy as np

from . import layout as kn
from .control import make_control
from .diagnostics import Outputs, Run
from .error_estimate import TOLERANCE_EXPONENT, error_estimates
from .layout import ETD34, RK4
from .loop import integrate, new_records
from .model import broken
from .model.assemble import Tables
from .model.crack import Cracks, crack_loads
from .model.floe_parts import unbroken_floe
from .model.layer import law_pressure, pressure_at
from .observe.asked import BITS, plan as plan_outputs
from .observe.reach import zone_ends
from .outputs import DIAGNOSTIC_INFO, OBSERVED, POSITION_SLOTS, RECORDS, SERIES, records_kept
from .fracture import above_yield_strain, crack_onset, thin_record, yield_strains
from .parameters import Parameters, ParameterError
from .settings import Settings
from .spec import Begin, BodyState, Break, Breaking, CarriedEnergy, RunSpec, RunState, StageEnd
from .scipy_reference import integrate_dop853, state_series
from .statuses import status_message


@dataclass
class Result:
    """Output of one :func:`solve` call: plain numpy arrays and scalars, SI units.

    Arrays over output times have NaN at the times beyond ``time_reached`` (``valid`` False);
    data at valid times is always finite.
    """

    parameters: Parameters
    settings: Settings
    times: np.ndarray                  # (T,) output times [s]
    x: np.ndarray                      # (X,) positions of the fields [m]
    fields: dict                       # name -> (T, X) array
    amplitudes: np.ndarray             # (T, N) a_n of cos(lambda_n x) [m]
    velocities: np.ndarray             # (T, N) da_n/dt [m s-1]
    # the series over the output times (solver.outputs.SERIES: names, units, meaning)
    contact_intervals: np.ndarray      # (T,) contact intervals on -L..L
    force: np.ndarray                  # (T,) F [N m-1]
    plate_energy: np.ndarray           # (T,) [J m-1]
    layer_energy: np.ndarray           # (T,) [J m-1]
    work: np.ndarray                   # (T,) int F U dt [J m-1]
    dissipated_energy: np.ndarray      # (T,) dissipated in viscoelastic ice and layer, and by opening cracks [J m-1]
    valid: np.ndarray                  # (T,) bool
    diagnostics: dict                  # name -> float, see DIAGNOSTIC_INFO
    status: str                        # see STATUS_INFO
    message: str
    time_reached: float                # [s]
    steps: int
    rejected_steps: int
    forcing_evaluations: int
    smallest_step: float               # [s]
    largest_step: float                # [s]
    wall_time: float                   # [s] of the integration (without the error estimate's companion)
    tension_record: dict = field(default_factory=dict)  # solver.outputs.RECORDS -> (n, 5) rows, solver.fracture
    contact_record: np.ndarray = None  # (n, 2) rows (t [s], contact intervals from then on)
    body_position: np.ndarray = None   # (T,) penetration s of the body, V t for the paper's body [m]
    body_speed: np.ndarray = None      # (T,) downward speed U of the body, V for the paper's [m s-1]
    extra: dict = field(default_factory=dict)   # error_estimate_wall_time [s] when a companion ran
    antisymmetric_amplitudes: np.ndarray = None  # (T, N) b_m of sin((m - 1/2) pi x / L) [m]; 0 centred
    antisymmetric_velocities: np.ndarray = None  # (T, N) db_m/dt [m s-1]
    outputs: frozenset = None          # the outputs asked (None: every one); the others are NaN or empty
    end_reason: str = "end"            # "end" (t_end), "answered" (its answers final: solve's end), or the status
    answered_eps_Y: float = math.inf   # crack onsets are final up to this yield strain (inf: the whole run)
    end: StageEnd = None               # how the run ended: its state there, the break it ended at, the energy
    #                                    carried into it across a break, its energy scale (solver.spec)
    breaking: Breaking = None          # a run that breaks (fracture = "break"): its breaks, the energy they
    #                                    removed over time, its stages (solver.spec.Breaking); None: it does not

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def time_scale(self) -> float:
        """t_sc = 1/omega_1 of the case [s]."""
        return self.parameters.time_scale

    @property
    def stage_duration(self) -> float:
        """L^2/(6RV) of the case [s]."""
        return self.parameters.stage_duration

    @property
    def t_sc(self) -> float:
        """The time scale 1/omega_1 [s], by the name study.nc gives it (= time_scale)."""
        return self.parameters.time_scale

    def crack_onset(self, eps_Y, surface: str = "upper", region: str = "plate"):
        """First time [s] and place [m] at which the tension on a surface ("upper": +eps,
        "lower": -eps) reaches each yield strain eps_Y, anywhere on the plate (region "plate") or
        within the impact zone ("impact_zone"), from the run's tension record (NaN: never within
        the run). See :func:`solver.fracture.crack_onset`."""
        if surface not in ("upper", "lower"):
            raise ParameterError(f"surface must be 'upper' or 'lower', got {surface!r}")
        if region not in ("plate", "impact_zone"):
            raise ParameterError(f"region must be 'plate' or 'impact_zone', got {region!r}")
        levels = yield_strains(eps_Y)
        if np.any(levels > self.answered_eps_Y):
            raise ParameterError(f"the run ended when its crack onsets up to eps_Y = {self.answered_eps_Y:g} were "
                                 f"final (end = 'answered'); a larger eps_Y needs a run to the end")
        above_yield_strain(self.parameters, levels)
        return crack_onset(self.tension_record[surface if region == "plate" else f"impact_zone_{surface}"], eps_Y)

    def to_dataset(self, eps_Y=None):
        """Moved: a case's labelled Dataset is ``pipeline.case_dataset(result, eps_Y)`` (the solver
        imports nothing of the study runner, so a Result does not know the store)."""
        raise AttributeError("Result.to_dataset moved to the study runner: pipeline.case_dataset(result, eps_Y=None) "
                             "gives the same Dataset")


#: largest etd34 step as a fraction of the contact period 2 pi / Parameters.contact_frequency
HMAX_FRACTION = 0.1


def layer_pressure(p, tables, a, s, x, adot=None, U=None):
    """K f at positions x from f at the quadrature nodes, linear between nodes, split as in the
    kernel, the body at penetration s [m]; a viscoelastic layer scales f by
    max(1 + layer_tau d(delta)/dt, 0) at the compressed nodes (from adot [m/s] and the body's
    speed U). This is exactly the reaction the modes feel (solver.model.layer.pressure_at: the
    same law the forcing integrates); with the contact-resolving rule, which integrates
    f(delta(x)) itself, K f(delta(x)) on the modes."""
    if tables.model.basis.rule == 1:      # the contact-resolving rule integrates f(delta(x)) itself
        cos = tables.mode_values(x)                                          # (X, N)
        d = (cos @ a + s - p.body_profile(x)) / p.he
        on = d > 0
        f = np.where(on, law_pressure.py_func(tables.model.layer.law, np.where(on & (d < 1), d, 0.5)), 0.0)
        if p.layer_tau > 0:
            f = f * np.maximum(1.0 + p.layer_tau * (cos @ adot + U) / p.he, 0.0)
        return p.K * f
    delta = (a @ tables.cosq + s - p.body_profile(tables.x_nodes)) / p.he  # (J,)
    rate = (adot @ tables.cosq + U) / p.he if p.layer_tau > 0 else None
    ax = tables.kernel_x(x)
    j = np.minimum((ax / tables.dx).astype(int), delta.size - 2)
    return pressure_at(tables.model, delta, rate, ax / tables.dx - j, j)


def checked_breaks(p, s, breaks, full_plate):
    """The breaks in kernel coordinates (None: unbroken), or ParameterError naming what a broken
    plate cannot be (docs/model.md, "Breaking into parts")."""
    if breaks is None:
        return None
    if s.quadrature != "gauss":
        raise ParameterError("breaks need quadrature = 'gauss': the paper's rule interpolates the modes "
                             "between nodes, across a break")
    full = p.off_centre if full_plate is None else bool(full_plate)
    b = np.sort(np.atleast_1d(np.asarray(breaks, dtype=float)))
    walls = p.edges != "free"
    inside = (b >= (-p.L if full else 0.0)) & (b <= p.L)
    if not walls:                                 # (a floe's edges are free already)
        inside &= np.abs(b) < p.L
    if b.size == 0 or not np.all(inside) or np.any(np.diff(b) <= 0.0):
        ends = "x = +-L a wall, the ice broken off it" if walls else "a floe's edges x = +-L are free already"
        raise ParameterError(f"breaks must be distinct places on the plate ({'-L' if full else '0'} "
                             f"{'<=' if walls else '<'} x {'<=' if walls else '<'} L: {ends}; on the half plate "
                             f"x = 0 is its centre), got {np.asarray(breaks).tolist()}")
    return b + p.L if full else b


def _across_break(p, s, tab, spec):
    """The kernel's initial wet amplitudes and rates of the broken plate (tab) from the state the
    run begins from (spec.begin) on the plate before the break, in the kernel's form: the unbroken
    plate's cosines (solver.model.broken.carry_state), or the parts of a plate broken at fewer
    places (carry_parts; the unbroken floe's wet modes as one part's, floe_parts.unbroken_floe); and
    the CarriedEnergy (the plate's and the layer's before and after) [J m-1]."""
    begin = spec.begin
    wet, a, adot = tab.floe["wet"], begin.amplitudes, begin.velocities
    old = Tables(p, s.subintervals, tab.full_plate, s.quadrature, s.quadrature_density, breaks=begin.breaks)
    if begin.breaks is None and old.floe is not None:      # an unbroken floe: its wet modes, one part's
        if a.shape != old.omega.shape or adot.shape != a.shape:
            raise ParameterError("the unbroken floe's initial state must be the kernel's amplitudes and rates of its "
                                 "wet modes")
        floe, scale = unbroken_floe(old.floe, p.L, tab.full_plate)
        b, bdot = broken.carry_parts(p, floe, wet, a / scale, adot / scale)
        before = sum(broken.wet_energy(floe, a / scale, adot / scale))
    elif begin.breaks is None:
        if a.shape != (p.Nmod * (2 if tab.full_plate else 1),) or a.shape != adot.shape:
            raise ParameterError("the unbroken plate's initial state must be the kernel's cosines' amplitudes and "
                                 "rates")
        domain, mirror = wet.domain, wet.mirror
        b, bdot = broken.carry_state(p, wet, a, adot)
        before = sum(broken.cosine_state_energy(p, domain, mirror, a, adot))
    else:
        if not set(begin.breaks) < set(spec.breaks) or a.shape != old.omega.shape or adot.shape != a.shape:
            raise ParameterError("a broken plate's state carries only to the same plate broken at more places, "
                                 "as the kernel's amplitudes and rates of its wet modes")
        wet_count = old.floe["wet"].omega.size                # (the last modes are null ones)
        scale = old.floe["scale"][:wet_count]
        b_old, bdot_old = a[:wet_count] / scale, adot[:wet_count] / scale
        b, bdot = broken.carry_parts(p, old.floe["wet"], wet, b_old, bdot_old)
        before = sum(broken.wet_energy(old.floe["wet"], b_old, bdot_old))
    after = sum(broken.wet_energy(wet, b, bdot))
    null = np.zeros(tab.floe["scale"].size - b.size)       # (the last wet modes are null ones)
    a_new, adot_new = np.append(b, null) * tab.floe["scale"], np.append(bdot, null) * tab.floe["scale"]
    # the layer's energy too (w at the nodes moves by what the projection leaves out)
    body = (math.nan, math.nan) if begin.body is None else begin.body[:2]
    t_start = spec.window.t_start
    layer = [state_series(t, t_start, x, xdot, body)[kn.S_E_LAYER]
             for t, x, xdot in ((old, a, adot), (tab, a_new, adot_new))]
    return a_new, adot_new, CarriedEnergy(before, after, layer[0], layer[1])


def _reached_at_break(tab, s, diag, final, level, records, level_t, level_x, levels):
    """The records and located crossings of a stage that ended at a break, closed there: the
    break is where its surface's tension reached the break level (docs/model.md, "The run that
    breaks"), located on sub-steps to the last one below it, so the surface's plate-wide record,
    and its impact zone's where the break lies in the zone, end at (t_b, level, rate, x_b): its
    last row at t_b takes the level, or a row is added there (its rate eps_t(x_b) from the state
    at t_b; x_b is on the plate). Crack onset for any eps_Y <= level is then defined (at the level:
    the break's time), and so is each located level up to it. Returns the records."""
    t_b, x_b, surface = float(diag[kn.D_BREAK_T]), float(diag[kn.D_BREAK_X]), int(diag[kn.D_BREAK_SURFACE])
    sign, N = 1.0 - 2.0 * surface, tab.lam.size
    rate = sign * float(tab.mode_values(np.array([x_b]), "strain")[0] @ final[1, :N])
    lo, hi = zone_ends.py_func(tab.model, float(diag[kn.D_CONTACT_EXTENT]), s.impact_zone_margin)
    names = [RECORDS[surface]] + ([RECORDS[2 + surface]] if lo <= x_b - tab.origin <= hi else [])
    records = dict(records)
    for name in names:
        rec = records[name]
        if rec.shape[0] and rec[-1, kn.R_T] == t_b:
            rec = rec.copy()
            rec[-1, kn.R_VALUE] = max(rec[-1, kn.R_VALUE], level)
        elif not rec.shape[0] or rec[-1, kn.R_VALUE] < level:
            rec = np.vstack([rec, [[t_b, level, rate, x_b, 1.0 if rec.shape[0] else 0.0]]])
        records[name] = rec
    missed = np.isnan(level_t[surface]) & (levels <= level)
    level_t[surface, missed], level_x[surface, missed] = t_b, x_b
    return records


def _field_values(p, tab, fields, x, out_a, out_adot, series, valid) -> dict:
    """The requested fields at the output times and positions x [m] from the modal amplitudes: the
    deflection and strain by the modal sums, the compression and the layer's pressure by the
    model's own law (solver.model.layer.pressure_at)."""
    field_values = {}
    if not fields:
        return field_values
    T = out_a.shape[0]
    body_s = series[:, kn.S_BODY_POSITION]
    modes = tab.mode_values(x)                                            # (X, N)
    w = out_a @ modes.T
    for name in fields:
        if name == "deflection":
            field_values[name] = w
        elif name == "strain" and tab.floe is None:
            field_values[name] = (out_a * tab.strain_coef) @ modes.T
        elif name == "strain":
            field_values[name] = out_a @ tab.mode_values(x, "strain").T
        elif name == "compression":
            field_values[name] = (w + body_s[:, None] - p.body_profile(x)) / p.he
        elif name == "layer_pressure":
            pres = np.full((T, x.size), np.nan)
            for k in np.flatnonzero(valid):
                pres[k] = layer_pressure(p, tab, out_a[k], body_s[k], x, out_adot[k],
                                          series[k, kn.S_BODY_SPEED])
            field_values[name] = pres
    return field_values




def _only_asked(asked, diagnostics, records, contact_record):
    """The diagnostics the observers produce that no output asked reads set to NaN (they may
    not have run, or cover only part of the run), and the records not asked emptied: (records,
    contact record)."""
    for name in OBSERVED - asked:
        if name in diagnostics:
            diagnostics[name] = math.nan
    kept = records_kept(asked)
    records = {name: rec if name in kept else rec[:0] for name, rec in records.items()}
    return records, contact_record if "contact_record" in asked else contact_record[:0]


def _kernel_loop(method):
    """solver.loop.integrate with the given method, as an Integrator's run. An arithmetic error
    the kernels raise (numba's division by zero, where an extreme value underflowed) ends the run
    with status nonfinite and a message naming it, none of its outputs valid, instead of
    escaping as an exception (a case that fails numerically gets a status)."""
    def run(tab, control, t_out, a0, adot0, levels, outputs):
        try:
            status, n_out, records = integrate(method, tab.model, control, t_out, a0, adot0, levels, outputs)
        except ArithmeticError as err:
            diag = outputs.diag
            diag[kn.D_T_REACHED] = diag[kn.D_FAIL_T] = control.t_start
            diag[kn.D_FAIL_KIND], diag[kn.D_BREAK_T] = kn.FAIL_NONFINITE, math.nan
            for slot in (kn.D_STEPS, kn.D_REJECTED, kn.D_RHS):
                diag[slot] = np.nan_to_num(diag[slot])
            return Run(kn.NONFINITE, 0, new_records(kn.N_REC),
                       f"the kernels met an arithmetic error ({type(err).__name__}: {err}) in the run from t = "
                       f"{control.t_start:.6g} s, where a value under- or overflowed; none of its outputs is kept")
        return Run(status, n_out, records, "")
    return run


#: an integrator as one interface: run(tab, control, t_out, a0, adot0, levels, outputs) -> Run
#: (solver.diagnostics); paper_step: its fixed step is Settings.rk4_step_fraction of the fastest
#: mode's period (the paper's RK4); local_errors: it sums local error estimates into the outputs'
#: error column; companion: its error estimate's time part also comes from a run at a looser
#: tolerance (where adaptive)
Integrator = namedtuple("Integrator", "run paper_step local_errors companion")
INTEGRATORS = {"etd34": Integrator(_kernel_loop(ETD34), False, True, True),
               "rk4": Integrator(_kernel_loop(RK4), True, True, False),
               "dop853": Integrator(integrate_dop853, False, False, False)}


def cosines_to_kernel(amplitudes, full):
    """The unbroken plate's amplitudes in the kernel's order from those of the symmetric cosines
    cos(lambda_n x) (solver.model.assemble.Tables.to_kernel, without building the tables)."""
    amplitudes = np.asarray(amplitudes, dtype=float)
    if not full:
        return amplitudes
    out = np.zeros(2 * amplitudes.size)
    out[1::2] = (-1.0) ** np.arange(1, amplitudes.size + 1) * amplitudes
    return out


def run_case(p, s, spec: RunSpec) -> Result:
    """One run of a checked RunSpec (solve's body, each stage of a run that breaks, and the error
    estimate's companion run), in named steps: what it observes (_plan), the tables of its plate,
    the state it begins from (_begun: at rest, a given state, or carried across a break), its
    control (_control), the kernels (_kernels), what they recorded (_recorded), the diagnostics
    and the fields, and the Result with the run's end (StageEnd)."""
    observers, answer, asked = _plan(p, spec)
    tab = Tables(p, s.subintervals, spec.full_plate, s.quadrature, s.quadrature_density, breaks=spec.breaks)
    if spec.cracks:                                   # the cracks still opening (solver.model.crack)
        loads = crack_loads(p, tab.floe, spec.cracks, spec.full_plate)
        tab.model = tab.model._replace(cracks=Cracks(loads, np.array([c.time for c in spec.cracks]),
                                                     p.crack_opening_time))
    a0, v0, carried = _begun(p, s, tab, spec)
    integrator = INTEGRATORS[s.integrator]
    control = _control(p, s, spec, tab, integrator, observers, answer)
    ran = _kernels(integrator, tab, control, spec, a0, v0)
    diag, T = ran.outputs.diag, spec.window.times.size
    records, contact_record = _recorded(tab, s, spec, ran)
    status = kn.STATUS_NAMES[ran.code]
    t_reached = float(diag[kn.D_T_REACHED])
    valid = np.arange(T) < ran.n_out
    field_values = _field_values(p, tab, spec.asked.fields, spec.asked.x, ran.outputs.a, ran.outputs.adot,
                                 ran.outputs.series, valid)
    diagnostics = {name: float(diag[i]) for name, (_, _, i) in DIAGNOSTIC_INFO.items() if i is not None}
    diagnostics["gravity_time_ratio"] = t_reached / math.sqrt(p.L / p.g) if p.edges == "free" else math.nan
    answered = not math.isnan(diag[kn.D_ANSWERED_T])
    if asked is not None:                           # what no output asked reads: not reported
        records, contact_record = _only_asked(asked, diagnostics, records, contact_record)
    extra = _error_estimated(p, s, spec, tab, integrator, ran, Begin(a0, v0, spec.breaks, spec.begin.body),
                             diagnostics, answered)
    message = status_message(p, s, status, diagnostics, diag, spec.window.t_end, control.fixed_step, ran.fail,
                             tab.full_plate)
    if ran.levels.size:
        extra["located_crack_onset"] = {"upper": (ran.outputs.level_t[0], ran.outputs.level_x[0]),
                                        "lower": (ran.outputs.level_t[1], ran.outputs.level_x[1])}
    sym_a, anti_a = tab.from_kernel(ran.outputs.a)
    sym_v, anti_v = tab.from_kernel(ran.outputs.adot)
    series = ran.outputs.series
    return Result(
        parameters=p, settings=s, times=spec.window.times, x=spec.asked.x, fields=field_values,
        amplitudes=sym_a, velocities=sym_v, antisymmetric_amplitudes=anti_a, antisymmetric_velocities=anti_v,
        **{row.attribute: series[:, i] for i, row in enumerate(SERIES) if row.attribute is not None},
        valid=valid, diagnostics=diagnostics, status=status, message=message,
        time_reached=t_reached, steps=int(diag[kn.D_STEPS]), rejected_steps=int(diag[kn.D_REJECTED]),
        forcing_evaluations=int(diag[kn.D_RHS]), smallest_step=float(diag[kn.D_H_MIN]),
        largest_step=float(diag[kn.D_H_MAX]), wall_time=ran.wall, tension_record=records,
        contact_record=contact_record, extra=extra, outputs=None if asked is None else frozenset(asked),
        end_reason="answered" if answered and status == "ok" else "end" if status == "ok" else status,
        answered_eps_Y=max(answer) if answered else math.inf, end=_stage_end(p, tab, spec, ran, carried))


def _plan(p, spec):
    """(the observers' bits, Control.answer, the outputs asked or None) for what the run is asked
    (solver.observe.asked); a run that can break locates its break on the tension's observer."""
    asked = spec.asked
    observers, answer, outputs = plan_outputs(asked.outputs, asked.eps_Y, asked.end,
                                              floe=p.edges == "free" or spec.breaks is not None)
    if spec.break_level < math.inf:
        observers |= BITS["tension"]
    return observers, answer, outputs


def _begun(p, s, tab, spec):
    """The kernel's amplitudes and rates at the run's start, and the CarriedEnergy where its state
    was carried across a break (None where not): a free floe at rest; a state carried onto a plate
    broken at more places than the one it was on; else the state given, of the plate run on."""
    begin, broken = spec.begin, spec.breaks is not None
    a0, v0 = begin.amplitudes, begin.velocities
    if tab.floe is not None and not broken:          # a free floe starts at rest (solve checks it)
        a0, v0 = np.zeros(tab.omega.size), np.zeros(tab.omega.size)
    if broken and (begin.breaks is None or not np.array_equal(begin.breaks, spec.breaks)):
        return _across_break(p, s, tab, spec)        # the state across the break
    if a0.shape != (tab.omega.size,) or v0.shape != (tab.omega.size,) or (begin.breaks is None) == broken:
        raise ParameterError(f"the initial state must be the kernel's {tab.omega.size} amplitudes and rates "
                             f"of the plate the run is on")
    return a0, v0, None


def _control(p, s, spec, tab, integrator, observers, answer):
    """The run's Control (solver.control): the window, the step policy (a fixed step: rk4's the
    paper's fraction of the fastest mode's period, or Settings.fixed_step in t_sc; the first
    step short enough that the tension, ~ t^3.5 from first touch, crossed inside it is far below
    any yield strain of interest, later steps growing at most 10 % a step from it; the largest
    a tenth of the contact's period), the observers, the answered end, the break level and a free
    body's start."""
    window = spec.window
    if integrator.paper_step:
        fixed = s.rk4_step_fraction * 2 * np.pi / tab.omega[-1]
    else:
        fixed = s.fixed_step * p.time_scale
    h_init = spec.first_step or min(1e-6 * (window.t_end - window.t_start), 1e-5 * p.time_scale)
    h_max = HMAX_FRACTION * 2 * np.pi / p.contact_frequency
    body = spec.begin.body
    return make_control(float(window.t_start), float(window.t_end), s.tolerance, fixed, h_init, 1e-13 * window.t_end,
                        h_max, s.max_steps, s.bottoming_gap, spec.until_separation, s.impact_zone_margin, observers,
                        answer, s.error_control == "smoothness", spec.break_level,
                        (math.nan,) * 4 if body is None else body, spec.growth_from)


#: what the kernels gave back: their status code, the output times filled, the Records, a
#: failure's words (DOP853's), the Outputs they filled, the levels located, the wall time [s]
Ran = namedtuple("Ran", "code n_out records fail outputs levels wall")


def _kernels(integrator, tab, control, spec, a0, v0) -> Ran:
    """The integration (solver.loop.integrate, or DOP853) into fresh Outputs."""
    T, N = spec.window.times.size, tab.lam.size      # the kernel's modes: 2 Nmod on the full plate
    levels = np.ascontiguousarray(np.atleast_1d(np.asarray(spec.asked.locate_eps_Y, dtype=float)))
    outputs = Outputs(np.full((T, N), np.nan), np.full((T, N), np.nan), np.full((T, kn.N_SERIES), np.nan),
                      np.full(kn.N_DIAG, np.nan), np.full((2, levels.size), np.nan), np.full((2, levels.size), np.nan),
                      np.full((2, N + 1), np.nan))
    started = _time.perf_counter()
    code, n_out, records, fail = integrator.run(tab, control, spec.window.times, a0, v0, levels, outputs)
    return Ran(code, n_out, records, fail, outputs, levels, _time.perf_counter() - started)


def _recorded(tab, s, spec, ran):
    """The tension records as stored (nodes the Hermite pieces reproduce to 1e-7 of the time
    dropped; none past a break the run ended at, whose step the observers saw whole; closed at
    the break's level: _reached_at_break) and the contact record, in x on the plate; the
    diagnostics' positions and the located levels' places moved there too."""
    rec, diag, out = ran.records, ran.outputs.diag, ran.outputs
    raw = zip(RECORDS, ((rec.upper, rec.n_upper), (rec.lower, rec.n_lower), (rec.zone_upper, rec.n_zone_upper),
                        (rec.zone_lower, rec.n_zone_lower)))
    records = {name: r[:n][thin_record(r[:n])] for name, (r, n) in raw}
    t_break = float(diag[kn.D_BREAK_T])
    if not math.isnan(t_break):
        records = {name: r[r[:, kn.R_T] <= t_break] for name, r in records.items()}
    contact_record = rec.contacts[:rec.n_contacts].copy()
    # under the Gauss rule a death between nodes may be placed after its step (solver.observe.
    # contacts._between_nodes): not after the run's end
    contact_record[:, 0] = np.minimum(contact_record[:, 0], diag[kn.D_T_REACHED])
    for r in records.values():
        r[:, kn.R_X] += tab.origin                   # kernel coordinates -> x on the plate
    diag[list(POSITION_SLOTS)] += tab.origin
    out.level_x[...] += tab.origin
    for s_, i in enumerate((kn.D_ZONE_UPPER, kn.D_ZONE_LOWER)):
        if not np.isfinite(diag[i]):                 # the zone was empty (the walls' margins cover the plate)
            diag[i:i + 3] = np.nan
            diag[kn.D_ZONE_UPPER_EDGE + s_] = np.nan
    if not math.isnan(t_break):
        records = _reached_at_break(tab, s, diag, out.final, spec.break_level, records, out.level_t, out.level_x,
                                    ran.levels)
    return records, contact_record


def _error_estimated(p, s, spec, tab, integrator, ran, begun, diagnostics, answered) -> dict:
    """The error estimate's diagnostics into diagnostics (solver.error_estimate), with its
    companion run at ten times the tolerance from the state the run began with (begun: already
    carried, so carried once) to the time reached, on the same output times, with no break and
    no observer of its own (only its amplitudes are read); returns the Result's extra (the
    companion's wall time)."""
    extra, companion, valid = {}, None, np.arange(spec.window.times.size) < ran.n_out
    diag = ran.outputs.diag
    if s.error_estimate and integrator.companion and s.fixed_step == 0 and ran.n_out > 0:
        looser = replace(s, tolerance=min(10 * s.tolerance, 0.5), error_estimate=False)
        t_reached, t_break = float(diag[kn.D_T_REACHED]), float(diag[kn.D_BREAK_T])
        window = replace(spec.window, times=spec.window.times[valid],
                         t_end=t_reached if answered or not math.isnan(t_break) else spec.window.t_end)
        # only its amplitudes are read: no observer (an observer never changes a step, solver.observe.asked)
        nothing = replace(spec.asked, fields=(), outputs=(), end="stage", locate_eps_Y=())
        other = run_case(p, looser, replace(spec, window=window, asked=nothing, begin=begun, break_level=math.inf))
        companion = (other.amplitudes if tab.floe is not None       # a floe's: its wet modes' already
                     else tab.to_kernel(other.amplitudes, other.antisymmetric_amplitudes))
        extra["error_estimate_wall_time"] = other.wall_time
    if s.error_estimate:                  # without local estimates (dop853) its time part is NaN
        out_err = ran.outputs.series[:, kn.S_ERR]
        diagnostics.update(error_estimates(ran.outputs.a[valid], tab.strain_coef, diagnostics["energy_residual"],
                                           companion=companion, exponent=TOLERANCE_EXPONENT[s.error_control],
                                           accumulated=out_err[valid] if integrator.local_errors else None))
    else:
        diagnostics.update({name: np.nan for name in ("error_estimate", "error_estimate_time",
                                                       "error_estimate_modes", "error_estimate_quadrature")})
    return extra


def _stage_end(p, tab, spec, ran, carried) -> StageEnd:
    """How the run ended (a StageEnd): its state at the time reached (a free body's too), the
    break it ended at, the energy carried into it, its energy scale."""
    diag, final, N = ran.outputs.diag, ran.outputs.final, tab.lam.size
    body = BodyState(final[0, N], final[1, N], diag[kn.D_STOP_T], diag[kn.D_MAX_PENETRATION]) if p.free_body \
        else None
    state = RunState(float(diag[kn.D_T_REACHED]), final[0, :N], final[1, :N],
                     () if spec.breaks is None else tuple(spec.breaks + tab.origin), body)
    t_break = float(diag[kn.D_BREAK_T])
    broke = None if math.isnan(t_break) else Break(t_break, float(diag[kn.D_BREAK_X]),
                                                   ("upper", "lower")[int(diag[kn.D_BREAK_SURFACE])])
    return StageEnd(state, broke, carried, float(diag[kn.D_ENERGY_SCALE]))
