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
from .model import parts
from .model.assemble import Tables
from .model.layer import law_pressure, pressure_at
from .observe.asked import BITS, plan as plan_outputs
from .observe.reach import zone_ends
from .outputs import DIAGNOSTIC_INFO, OBSERVED, POSITION_SLOTS, RECORDS, SERIES, records_kept
from .fracture import above_yield_strain, crack_onset, thin_record, yield_strains
from .parameters import Parameters, ParameterError
from .settings import Settings
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
    dissipated_energy: np.ndarray      # (T,) dissipated in viscoelastic ice and layer [J m-1] (0: elastic)
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
        """This case as a labelled ``xarray.Dataset``: the same names, units and long names as a
        study's ``study.nc`` (fields over t [s] and x [m], series, diagnostics, crack onset along
        ``eps_Y``, parameters, status, records). Needs the runner's packages (xarray): the
        conversion is :func:`pipeline.store.dataset.case_dataset`; the solver itself stays free of them."""
        from pipeline.store.dataset import case_dataset   # deferred: the one hand-off from solver to pipeline
        return case_dataset(self, eps_Y)


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
    if p.edges == "free":
        raise ParameterError("breaks: a floe's parts are not built yet (its water is the half-plane's)")
    if s.quadrature != "gauss":
        raise ParameterError("breaks need quadrature = 'gauss': the paper's rule interpolates the modes "
                             "between nodes, across a break")
    full = p.off_centre if full_plate is None else bool(full_plate)
    b = np.sort(np.atleast_1d(np.asarray(breaks, dtype=float)))
    inside = (b > -p.L) & (b < p.L) if full else (b >= 0.0) & (b < p.L)
    if b.size == 0 or not np.all(inside) or np.any(np.diff(b) <= 0.0):
        raise ParameterError(f"breaks must be distinct places on the plate ({'-L <' if full else '0 <='} x < L; "
                             f"on the half plate x = 0 is its centre), got {np.asarray(breaks).tolist()}")
    return b + p.L if full else b


def _across_break(p, s, tab, case):
    """The kernel's initial wet amplitudes and rates of the broken plate (tab) from the state
    case.a0, case.v0 of the plate before the break, in the kernel's form: the unbroken plate's
    cosines (solver.model.parts.carry_state) or the parts of a plate broken at fewer places
    (carry_parts); and the plate's energy before and after [J m-1]."""
    wet, a, adot = tab.floe["wet"], case.a0, case.v0
    old = Tables(p, s.subintervals, tab.full_plate, s.quadrature, s.quadrature_density, breaks=case.from_breaks)
    if case.from_breaks is None:
        if a.shape != (p.Nmod * (2 if tab.full_plate else 1),) or a.shape != adot.shape:
            raise ParameterError("the unbroken plate's initial state must be the kernel's cosines' amplitudes and "
                                 "rates")
        domain, mirror = wet.domain, wet.mirror
        b, bdot = parts.carry_state(p, wet, a, adot)
        before = sum(parts.cosine_state_energy(p, domain, mirror, a, adot))
    else:
        if not set(case.from_breaks) < set(case.breaks) or a.shape != old.omega.shape or adot.shape != a.shape:
            raise ParameterError("a broken plate's state carries only to the same plate broken at more places, "
                                 "as the kernel's amplitudes and rates of its wet modes")
        scale = old.floe["scale"][:-1]
        b_old, bdot_old = a[:-1] / scale, adot[:-1] / scale
        b, bdot = parts.carry_parts(p, old.floe["wet"], wet, b_old, bdot_old)
        before = sum(parts.wet_energy(old.floe["wet"], b_old, bdot_old))
    after = sum(parts.wet_energy(wet, b, bdot))
    scale = tab.floe["scale"]                             # (the last wet mode is the null one)
    a_new, adot_new = np.append(b, 0.0) * scale, np.append(bdot, 0.0) * scale
    # the layer's energy too (w at the nodes moves by what the projection leaves out)
    body = (math.nan, math.nan) if case.body is None else case.body[:2]
    layer = [state_series(t, case.t_start, x, xdot, body)[kn.S_E_LAYER]
             for t, x, xdot in ((old, case.a0, case.v0), (tab, a_new, adot_new))]
    return a_new, adot_new, {"before": before, "after": after, "layer_before": layer[0], "layer_after": layer[1]}


def _reached_at_break(tab, s, diag, final, level, records, level_t, level_x, levels):
    """The records and located crossings of a stage that ended at a break, closed there: the
    break is where its surface's tension reached the break level (docs/model.md, "The run that
    breaks"), located on sub-steps to the last one below it, so the surface's plate-wide record,
    and its impact zone's where the break lies in the zone, end at (t_b, level, rate, x_b): its
    last row at t_b takes the level, or a row is added there (its rate eps_t(x_b) from the state
    at t_b). Crack onset for any eps_Y <= level is then defined (at the level: the break's time),
    and so is each located level up to it. Returns the records."""
    t_b, x_b, surface = float(diag[kn.D_BREAK_T]), float(diag[kn.D_BREAK_X]), int(diag[kn.D_BREAK_SURFACE])  # (x_b on
    # the plate)
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


#: one run as run_case takes it, its inputs checked: output times, fields and x, the window, the
#: initial state in the kernel's form (a, adot) of the plate broken at from_breaks (None:
#: unbroken; kernel coordinates), the breaks of the plate it runs on (None: unbroken), the full
#: plate, the free body's end, the outputs asked, the levels to locate, and the break level (inf:
#: none), the first step [s] (None: the first touch's, short), and a free body at t_start
#: (solver.control.Control.body_start: s, U, its first stop's time and deepest penetration
#: before; None: at first touch)
Case = namedtuple("Case", "times fields x t_end t_start a0 v0 from_breaks breaks full_plate until_separation "
                          "outputs eps_Y end locate_eps_Y break_level h_init body", defaults=(None, None))


def cosines_to_kernel(amplitudes, full):
    """The unbroken plate's amplitudes in the kernel's order from those of the symmetric cosines
    cos(lambda_n x) (solver.model.assemble.Tables.to_kernel, without building the tables)."""
    amplitudes = np.asarray(amplitudes, dtype=float)
    if not full:
        return amplitudes
    out = np.zeros(2 * amplitudes.size)
    out[1::2] = (-1.0) ** np.arange(1, amplitudes.size + 1) * amplitudes
    return out


def run_case(p, s, case: Case) -> Result:
    """One run of a checked case (solve's body): the Model, the kernels, and the Result."""
    times, fields, x, t_end, t_start = case.times, case.fields, case.x, case.t_end, case.t_start
    locate_eps_Y = case.locate_eps_Y
    until_separation, outputs, eps_Y, end = case.until_separation, case.outputs, case.eps_Y, case.end
    kernel_breaks = case.breaks
    broken = kernel_breaks is not None
    observers, answer, asked = plan_outputs(outputs, eps_Y, end, floe=p.edges == "free" or broken)
    if case.break_level < math.inf:                  # the break is located on the tension's observer
        observers |= BITS["tension"]
    tab = Tables(p, s.subintervals, case.full_plate, s.quadrature, s.quadrature_density, breaks=kernel_breaks)
    extra = {}
    a0, v0 = case.a0, case.v0
    if tab.floe is not None and not broken:          # a free floe starts at rest (solve checks it)
        a0, v0 = np.zeros(tab.omega.size), np.zeros(tab.omega.size)
    if broken and (case.from_breaks is None or not np.array_equal(case.from_breaks, kernel_breaks)):
        a0, v0, extra["break_energy"] = _across_break(p, s, tab, case)     # the state across the break
    elif a0.shape != (tab.omega.size,) or v0.shape != (tab.omega.size,) or (case.from_breaks is None) == broken:
        raise ParameterError(f"the initial state must be the kernel's {tab.omega.size} amplitudes and rates "
                             f"of the plate the run is on")
    N = tab.lam.size                                 # the kernel's modes: 2 Nmod on the full plate
    integrator = INTEGRATORS[s.integrator]
    if integrator.paper_step:
        fixed = s.rk4_step_fraction * 2 * np.pi / tab.omega[-1]
    else:
        fixed = s.fixed_step * p.time_scale
    T = times.size
    out_a = np.full((T, N), np.nan)
    out_adot = np.full((T, N), np.nan)
    series = np.full((T, kn.N_SERIES), np.nan)
    diag = np.full(kn.N_DIAG, np.nan)
    # first step: short enough that the tension (~ t^3.5 from first touch) crossed inside it is
    # far below any yield strain of interest; later steps grow at most 10% a step from it
    h_init = case.h_init or min(1e-6 * (t_end - t_start), 1e-5 * p.time_scale)
    h_max = HMAX_FRACTION * 2 * np.pi / p.contact_frequency
    levels = np.ascontiguousarray(np.atleast_1d(np.asarray(locate_eps_Y, dtype=float)))
    level_t = np.full((2, levels.size), np.nan)
    level_x = np.full((2, levels.size), np.nan)
    control = make_control(float(t_start), float(t_end), s.tolerance, fixed, h_init, 1e-13 * t_end, h_max,
                           s.max_steps, s.bottoming_gap, until_separation, s.impact_zone_margin, observers, answer,
                           s.error_control == "smoothness", case.break_level,
                           (math.nan,) * 4 if case.body is None else case.body)
    final = np.full((2, N + 1), np.nan)
    started = _time.perf_counter()
    code, n_out, rec, fail = integrator.run(tab, control, times, a0, v0, levels,
                                            Outputs(out_a, out_adot, series, diag, level_t, level_x, final))
    raw = zip(RECORDS, ((rec.upper, rec.n_upper), (rec.lower, rec.n_lower), (rec.zone_upper, rec.n_zone_upper),
                        (rec.zone_lower, rec.n_zone_lower)))
    # the record as stored: nodes the Hermite pieces reproduce to 1e-7 of the time are dropped
    records = {name: r[:n][thin_record(r[:n])] for name, (r, n) in raw}
    t_break = float(diag[kn.D_BREAK_T])
    if not math.isnan(t_break):            # the observers saw the whole step the break is in: not past it
        records = {name: r[r[:, kn.R_T] <= t_break] for name, r in records.items()}
    contact_record = rec.contacts[:rec.n_contacts].copy()
    # under the Gauss rule a death between nodes may be placed after its step (solver.observe.
    # contacts._between_nodes): not after the run's end
    contact_record[:, 0] = np.minimum(contact_record[:, 0], diag[kn.D_T_REACHED])
    wall = _time.perf_counter() - started
    for rec in records.values():
        rec[:, kn.R_X] += tab.origin                     # kernel coordinates -> x on the plate

    status = kn.STATUS_NAMES[code]
    t_reached = float(diag[kn.D_T_REACHED])
    out_err = series[:, kn.S_ERR]
    valid = np.arange(T) < n_out
    diag[list(POSITION_SLOTS)] += tab.origin        # kernel coordinates -> x on the plate
    level_x += tab.origin
    for s_, i in enumerate((kn.D_ZONE_UPPER, kn.D_ZONE_LOWER)):
        if not np.isfinite(diag[i]):                 # the zone was empty (the walls' margins cover the plate)
            diag[i:i + 3] = np.nan
            diag[kn.D_ZONE_UPPER_EDGE + s_] = np.nan
    if not math.isnan(t_break):
        records = _reached_at_break(tab, s, diag, final, case.break_level, records, level_t, level_x, levels)
    field_values = _field_values(p, tab, fields, x, out_a, out_adot, series, valid)
    diagnostics = {name: float(diag[i]) for name, (_, _, i) in DIAGNOSTIC_INFO.items() if i is not None}
    diagnostics["gravity_time_ratio"] = t_reached / math.sqrt(p.L / p.g) if p.edges == "free" else math.nan
    answered = not math.isnan(diag[kn.D_ANSWERED_T])
    if asked is not None:                           # what no output asked reads: not reported
        records, contact_record = _only_asked(asked, diagnostics, records, contact_record)
    companion = None
    if s.error_estimate and integrator.companion and s.fixed_step == 0 and n_out > 0:
        looser = replace(s, tolerance=min(10 * s.tolerance, 0.5), error_estimate=False)
        # (the companion runs to the time reached, no break of its own: its outputs are the same times')
        other = run_case(p, looser, case._replace(times=times[valid], fields=(), locate_eps_Y=(), break_level=math.inf,
                                              a0=a0, v0=v0, from_breaks=kernel_breaks,      # (carried once)
                                              t_end=t_reached if answered or not math.isnan(t_break) else t_end))
        companion = (other.amplitudes if tab.floe is not None       # a floe's: its wet modes' already
                     else tab.to_kernel(other.amplitudes, other.antisymmetric_amplitudes))
        extra["error_estimate_wall_time"] = other.wall_time
    if s.error_estimate:                  # without local estimates (dop853) its time part is NaN
        diagnostics.update(error_estimates(out_a[valid], tab.strain_coef, diagnostics["energy_residual"],
                                           companion=companion, exponent=TOLERANCE_EXPONENT[s.error_control],
                                           accumulated=out_err[valid] if integrator.local_errors else None))
    else:
        diagnostics.update({name: np.nan for name in ("error_estimate", "error_estimate_time",
                                                       "error_estimate_modes", "error_estimate_quadrature")})
    message = status_message(p, s, status, diagnostics, diag, t_end, fixed, fail, tab.full_plate)
    body = (final[0, N], final[1, N], diag[kn.D_STOP_T], diag[kn.D_MAX_PENETRATION]) if p.free_body else None
    extra["energy_scale"] = float(diag[kn.D_ENERGY_SCALE])     # what the energy residuals are relative to
    extra["final_state"] = (final[0, :N], final[1, :N], [] if kernel_breaks is None else
                            list(kernel_breaks + tab.origin), body)
    if not math.isnan(t_break):
        extra["break"] = {"time": t_break, "x": float(diag[kn.D_BREAK_X]),
                          "surface": ("upper", "lower")[int(diag[kn.D_BREAK_SURFACE])]}
    if levels.size:
        extra["located_crack_onset"] = {"upper": (level_t[0], level_x[0]), "lower": (level_t[1], level_x[1])}
    sym_a, anti_a = tab.from_kernel(out_a)
    sym_v, anti_v = tab.from_kernel(out_adot)
    return Result(
        parameters=p, settings=s, times=times, x=x, fields=field_values,
        amplitudes=sym_a, velocities=sym_v, antisymmetric_amplitudes=anti_a, antisymmetric_velocities=anti_v,
        **{row.attribute: series[:, i] for i, row in enumerate(SERIES) if row.attribute is not None},
        valid=valid, diagnostics=diagnostics, status=status, message=message,
        time_reached=t_reached, steps=int(diag[kn.D_STEPS]), rejected_steps=int(diag[kn.D_REJECTED]),
        forcing_evaluations=int(diag[kn.D_RHS]), smallest_step=float(diag[kn.D_H_MIN]),
        largest_step=float(diag[kn.D_H_MAX]), wall_time=wall, tension_record=records,
        contact_record=contact_record, extra=extra, outputs=None if asked is None else frozenset(asked),
        end_reason="answered" if answered and status == "ok" else "end" if status == "ok" else status,
        answered_eps_Y=max(answer) if answered else math.inf)


