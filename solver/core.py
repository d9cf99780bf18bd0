"""The one Python entry point of the solver: :func:`solve` adapts a case to the kernels.

It validates the case, assembles its Model (solver.model.assemble), calls
:func:`solver.loop.integrate`, and turns the modal
amplitudes at the output times into the fields the caller asked for. It raises only for bad
input (:class:`solver.parameters.ParameterError`); a numerical failure is a status.
"""
from __future__ import annotations

import math
import time as _time
from collections import namedtuple
from dataclasses import dataclass, field, replace

import numpy as np

from . import first_compile
from .compile import kernel_cache, parallel_compile
from . import layout as kn
from .control import make_control
from .diagnostics import Outputs, Records, Run
from .error_estimate import TOLERANCE_EXPONENT, error_estimates
from .layout import ETD34, RK4
from .loop import integrate
from .model import parts
from .model.assemble import Tables
from .model.layer import law_pressure, pressure_at
from .observe.asked import plan as plan_outputs
from .outputs import (DIAGNOSTIC_INFO, FIELD_INFO, FIELDS, OBSERVED, POSITION_SLOTS, RECORDS, SERIES,
                      records_kept)
from .fracture import compile_crack_onset, crack_onset, thin_record
from .parameters import Parameters, ParameterError
from .settings import Settings, check_combination
from .scipy_reference import integrate_dop853
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
        if np.any(np.asarray(eps_Y, dtype=float) > self.answered_eps_Y):
            raise ParameterError(f"the run ended when its crack onsets up to eps_Y = {self.answered_eps_Y:g} were "
                                 f"final (end = 'answered'); a larger eps_Y needs a run to the end")
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


def _check_times(times, t_start, t_end):
    times = np.atleast_1d(np.asarray(times, dtype=float))
    if times.ndim != 1 or times.size == 0:
        raise ParameterError("times must be a non-empty 1-D sequence of output times [s]")
    if not np.all(np.isfinite(times)):
        raise ParameterError("times must be finite")
    if np.any(np.diff(times) < 0):
        raise ParameterError("times must be sorted in increasing order")
    if times[0] < t_start or times[-1] > t_end * (1 + 1e-12):
        raise ParameterError(
            f"times must lie in [{t_start:.6g}, {t_end:.6g}] s (the run, by default 0 to the impact "
            f"stage L^2/(6RV)); got {times[0]:.6g} .. {times[-1]:.6g} s")
    return np.minimum(times, t_end)


def _layer_pressure(p, tables, a, s, x, adot=None, U=None):
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


def _checked_breaks(p, s, breaks, full_plate):
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


def _across_break(p, tab, a0, v0):
    """The kernel's initial wet amplitudes and rates of the broken plate from the unbroken
    plate's state (a_n, a_n' of the symmetric cosines; solver.model.parts.carry_state), and the
    plate's energy before and after [J m-1]."""
    unbroken = Tables(p, 2, tab.full_plate, "gauss")     # the cosines' kernel order (a small table)
    a, adot = unbroken.to_kernel(a0), unbroken.to_kernel(v0)
    domain, mirror = (2.0 if tab.full_plate else 1.0) * p.L, 1.0 if tab.full_plate else 2.0
    wet = tab.floe["wet"]
    b, bdot = parts.carry_state(p, wet, a, adot)
    before = sum(parts.cosine_state_energy(p, domain, mirror, a, adot))
    after = sum(parts.wet_energy(wet, b, bdot))
    scale = tab.floe["scale"]                             # (the last wet mode is the null one)
    return np.append(b, 0.0) * scale, np.append(bdot, 0.0) * scale, {"before": before, "after": after}


def _checked(parameters, settings, times, fields, x, t_end, t_start, initial, until_separation, full_plate):
    """solve's inputs validated (ParameterError, one line, on the first that is wrong) and with
    their defaults: (parameters, settings, times, x, t_end, a0, v0)."""
    p = parameters if parameters is not None else Parameters()
    s = settings if settings is not None else Settings()
    if not isinstance(p, Parameters):
        raise ParameterError("parameters must be a solver.Parameters")
    if not isinstance(s, Settings):
        raise ParameterError("settings must be a solver.Settings")
    unknown = [f for f in fields if f not in FIELD_INFO]
    if unknown:
        raise ParameterError(f"unknown field {unknown[0]!r}; known: {', '.join(FIELDS)}")
    if t_end is None:
        t_end = p.stage_duration
    if not (math.isfinite(t_start) and t_start >= 0):
        raise ParameterError(f"t_start must be finite and >= 0, got {t_start!r}")
    if not (math.isfinite(t_end) and t_end > t_start):
        raise ParameterError(f"t_end must be finite and > t_start, got {t_end!r}")
    times = (np.linspace(t_start, t_end, 25) if times is None
             else _check_times(times, t_start, t_end))
    x = np.linspace(-p.L, p.L, 241) if x is None else np.atleast_1d(np.asarray(x, dtype=float))
    if x.ndim != 1 or not np.all(np.isfinite(x)) or np.any(np.abs(x) > p.L * (1 + 1e-12)):
        raise ParameterError(f"x must be a 1-D sequence of positions in [-L, L] = [{-p.L}, {p.L}] m")
    N = p.Nmod
    initial_amplitudes, initial_velocities = initial
    a0 = np.zeros(N) if initial_amplitudes is None else np.asarray(initial_amplitudes, float)
    v0 = np.zeros(N) if initial_velocities is None else np.asarray(initial_velocities, float)
    if a0.shape != (N,) or v0.shape != (N,):
        raise ParameterError(f"initial amplitudes and velocities must have shape ({N},)")
    if p.edges == "free" and (np.any(a0 != 0) or np.any(v0 != 0) or t_start != 0):
        raise ParameterError("a free floe's run starts at rest at first touch (t_start = 0, no initial "
                             "amplitudes or velocities)")
    if not isinstance(until_separation, bool):
        raise ParameterError(f"until_separation must be true or false, got {until_separation!r}")
    check_combination(p, s)
    if p.free_body and t_start > 0:
        raise ParameterError("a free body's run starts at first touch (t_start = 0): its state at a later "
                             "start is not an input")
    if until_separation and not p.free_body:
        raise ParameterError("until_separation needs a free body (a finite body_mass): the paper's body "
                             "moves down at V for ever")

    if full_plate is not None and not isinstance(full_plate, bool):
        raise ParameterError(f"full_plate must be true, false or None, got {full_plate!r}")
    if full_plate is False and p.off_centre:
        raise ParameterError(f"an off-centre body (x0 = {p.x0!r} m) needs the full plate's antisymmetric modes")
    return p, s, times, x, t_end, a0, v0


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
                pres[k] = _layer_pressure(p, tab, out_a[k], body_s[k], x, out_adot[k],
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
    """solver.loop.integrate with the given method, as an Integrator's run."""
    def run(tab, control, t_out, a0, adot0, levels, outputs):
        status, n_out, records = integrate(method, tab.model, control, t_out, a0, adot0, levels, outputs)
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


def solve(parameters: Parameters | None = None, settings: Settings | None = None, times=None,
          fields=("deflection", "strain", "layer_pressure"), x=None, t_end=None,
          initial_amplitudes=None, initial_velocities=None, t_start=0.0, locate_eps_Y=(),
          until_separation=False, full_plate=None, outputs=None, eps_Y=None, end="stage", breaks=None) -> Result:
    """Integrate one impact case.

    Parameters
    ----------
    parameters : the case (default: the paper's reference case).
    settings : numerical settings (default: etd34 at its default tolerance).
    times : output times [s], sorted, in [0, t_end] (default: 25 evenly spaced over the run).
    fields : names from :data:`FIELDS` to evaluate at the output times (``()`` for none).
    x : positions of the fields [m] (default: 241 points evenly spaced on -L..L).
    t_end : end of the run [s] (default: the impact stage L^2/(6RV)). Diagnostics cover the run.
    initial_amplitudes, initial_velocities : a_n and da_n/dt at t_start [m, m/s] (default 0).
    t_start : start of the run [s] (default 0, first touch); with the two above, a restart.
    locate_eps_Y : yield strains whose first crossings are also located on true sub-steps of
        the integrator (etd34, rk4), in ``extra["located_crack_onset"]`` = {"upper": (t, x),
        "lower": (t, x)}: the exact reference for the tension record (costs a root search
        per value; for verification, not needed for results).
    until_separation : a free body's run (finite body_mass) ends when the body leaves the ice
        moving up (status ``separated``), at the latest at t_end (``stopped`` if it had stopped
        by then; ``ok`` if it was still moving down).
    full_plate : solve on the full plate, Nmod symmetric and Nmod antisymmetric modes (default
        None: exactly when the body is off centre, x0 != 0; True at x0 = 0 is for verification:
        it must agree with the symmetric run, its antisymmetric amplitudes staying 0).
    outputs : the outputs asked, names of :data:`solver.outputs.OUTPUT_NAMES` (diagnostics,
        tension records ``tension_record_<record>``, crack onsets such as ``crack_onset_time``,
        ``contact_record``, series); default None: every one. Observers no output asked reads
        do not run (solver.observe.asked); the outputs asked are bit for bit those of the run
        with every observer, the others NaN (or empty records).
    eps_Y : the yield strains crack onsets are asked at (with ``end="answered"``).
    end : "stage" (default): the run goes to t_end; "answered": with only crack onsets asked, it
        ends once they are final for every eps_Y up to the largest (``end_reason`` "answered",
        ``time_reached`` then; ``Result.crack_onset`` refuses a larger eps_Y).
    breaks : places x [m] where the walled plate is broken through its thickness (docs/model.md,
        "Breaking into parts"; x > 0 on the half plate of a centred impact, and the break at -x
        with it): the run is on the parts' wet modes (amplitudes as a floe's), and initial
        amplitudes and velocities, the unbroken plate's state at t_start, are carried across
        the break (``extra["break_energy"]``: the plate's energy before and after [J m-1]).

    Returns
    -------
    Result

    Raises
    ------
    ParameterError
        Parameters, settings, times or positions out of their ranges: one line naming the
        value (a case that fails numerically is not raised: its ``status`` says why).

    Examples
    --------
    >>> from solver import Parameters, solve
    >>> result = solve(Parameters(Nmod=20), fields=())
    >>> result.status
    'ok'
    >>> bool(result.diagnostics["max_strain"] > 0.0)
    True
    """
    p, s, times, x, t_end, a0, v0 = _checked(parameters, settings, times, fields, x, t_end, t_start,
                                             (initial_amplitudes, initial_velocities), until_separation, full_plate)
    kernel_breaks = _checked_breaks(p, s, breaks, full_plate)
    observers, answer, asked = plan_outputs(outputs, eps_Y, end, floe=p.edges == "free" or breaks is not None)
    tab = Tables(p, s.subintervals, full_plate, s.quadrature, s.quadrature_density, breaks=kernel_breaks)
    a0_sym, v0_sym = a0, v0                          # a restart gives the symmetric modes' state
    extra = {}
    if kernel_breaks is not None:                    # the unbroken plate's state across the break
        a0, v0, extra["break_energy"] = _across_break(p, tab, a0, v0)
    else:
        a0 = tab.to_kernel(a0)
        v0 = tab.to_kernel(v0)
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
    h_init = min(1e-6 * (t_end - t_start), 1e-5 * p.time_scale)
    h_max = HMAX_FRACTION * 2 * np.pi / p.contact_frequency
    levels = np.ascontiguousarray(np.atleast_1d(np.asarray(locate_eps_Y, dtype=float)))
    level_t = np.full((2, levels.size), np.nan)
    level_x = np.full((2, levels.size), np.nan)
    control = make_control(float(t_start), float(t_end), s.tolerance, fixed, h_init, 1e-13 * t_end, h_max,
                           s.max_steps, s.bottoming_gap, until_separation, s.impact_zone_margin, observers, answer,
                           s.error_control == "smoothness")
    started = _time.perf_counter()
    code, n_out, rec, fail = integrator.run(tab, control, times, a0, v0, levels,
                                            Outputs(out_a, out_adot, series, diag, level_t, level_x))
    raw = zip(RECORDS, ((rec.upper, rec.n_upper), (rec.lower, rec.n_lower), (rec.zone_upper, rec.n_zone_upper),
                        (rec.zone_lower, rec.n_zone_lower)))
    # the record as stored: nodes the Hermite pieces reproduce to 1e-7 of the time are dropped
    records = {name: r[:n][thin_record(r[:n])] for name, (r, n) in raw}
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
    field_values = _field_values(p, tab, fields, x, out_a, out_adot, series, valid)
    diagnostics = {name: float(diag[i]) for name, (_, _, i) in DIAGNOSTIC_INFO.items() if i is not None}
    diagnostics["gravity_time_ratio"] = t_reached / math.sqrt(p.L / p.g) if p.edges == "free" else math.nan
    answered = not math.isnan(diag[kn.D_ANSWERED_T])
    if asked is not None:                           # what no output asked reads: not reported
        records, contact_record = _only_asked(asked, diagnostics, records, contact_record)
    companion = None
    if s.error_estimate and integrator.companion and s.fixed_step == 0 and n_out > 0:
        looser = replace(s, tolerance=min(10 * s.tolerance, 0.5), error_estimate=False)
        other = solve(p, looser, times=times[valid], fields=(), t_end=t_reached if answered else t_end,
                      t_start=t_start, initial_amplitudes=a0_sym, initial_velocities=v0_sym,
                      until_separation=until_separation, full_plate=tab.full_plate, outputs=outputs,
                      breaks=breaks)
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


def compile_kernels() -> None:
    """Compile (or load from numba's cache) every kernel by running a tiny case once.

    Returns
    -------
    None
        The kernels are in numba's cache (solver/__pycache__/kernels, or
        ``FLOE_IMPACT_KERNEL_CACHE``): a later process loads them in about a second.

    Examples
    --------
    ::

        python -c "import solver; solver.compile_kernels()"   # once, after an install or an edit
    """
    p, s, times = first_compile.tiny_case()
    with parallel_compile.helper(first_compile.run_helper):   # a second process compiles part of integrate's tree
        solve(p, s, times=times, fields=FIELDS)
        solve(p, replace(s, integrator="rk4"), times=times, fields=(), locate_eps_Y=[1e-6])
    compile_crack_onset()
    if not kernel_cache.is_complete():         # (each worker calls this at start: write once)
        kernel_cache.mark_complete()

