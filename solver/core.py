"""The one Python entry point of the solver: :func:`solve` validates a case and runs it.

A run is solver.run's: it assembles the Model (solver.model.assemble), calls
:func:`solver.loop.integrate`, and turns the modal amplitudes at the output times into the
fields the caller asked for; a run that breaks (``Parameters(fracture="break")``) is solver.breaking's, in
stages that are each such a run. It raises only for bad input
(:class:`solver.parameters.ParameterError`); a numerical failure is a status.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from . import first_compile
from .breaking import solve_breaking
from .compile import kernel_cache, parallel_compile
from .fracture import above_yield_strain, compile_crack_onset, yield_strains
from .loop import integrate                                   # (the kernels' entry, as solver.core.integrate)
from .model.assemble import Tables
from .observe.asked import ENDS
from .outputs import BREAKING_INFO, FIELD_INFO, FIELDS
from .parameters import Parameters, ParameterError
from .run import Result, checked_breaks, cosines_to_kernel, run_case
from .settings import Settings, check_combination
from .spec import Asked, Begin, BodyState, RunSpec, RunState, Window

__all__ = ["Result", "compile_kernels", "solve", "Tables", "integrate"]


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


def _checked(parameters, settings, times, fields, x, t_end, t_start, initial, until_separation, full_plate,
             body_given=False):
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
    if p.free_body and t_start > 0 and not body_given:
        raise ParameterError("a free body's run starts at first touch (t_start = 0), or from a run's end with "
                             "the body's state (start = result.end.state)")
    if until_separation and not p.free_body:
        raise ParameterError("until_separation needs a free body (a finite body_mass): the paper's body "
                             "moves down at V for ever")

    if full_plate is not None and not isinstance(full_plate, bool):
        raise ParameterError(f"full_plate must be true, false or None, got {full_plate!r}")
    if full_plate is False and p.off_centre:
        raise ParameterError(f"an off-centre body (x0 = {p.x0!r} m) needs the full plate's antisymmetric modes")
    return p, s, times, x, t_end, a0, v0


def solve(parameters: Parameters | None = None, settings: Settings | None = None, times=None,
          fields=("deflection", "strain", "layer_pressure"), x=None, t_end=None,
          initial_amplitudes=None, initial_velocities=None, t_start=0.0, locate_eps_Y=(),
          until_separation=False, full_plate=None, outputs=None, eps_Y=None, end="stage", breaks=None,
          start=None, break_strain=None) -> Result:
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
        the break (``result.end.carried``: the plate's and the layer's energy before and after
        [J m-1]).
    start : a :class:`solver.RunState`, the state the run starts from at its ``time`` (instead of
        t_start, initial_amplitudes and initial_velocities): a run's end, ``result.end.state``,
        in the kernel's own form, of the plate broken at its ``breaks``, with a free body's
        :data:`solver.BodyState`; carried across to ``breaks`` where the run's plate is broken
        at more places.
    break_strain : the run ends where either surface's tension first reaches it, located on
        true sub-steps (``result.end.broke``: time, x, surface; ``result.end.state`` the state
        there): one stage of a run that breaks. Default None: no such end. A whole run that
        breaks is ``Parameters(fracture="break", yield_strain=..., max_parts=...)``: the plate
        breaks where and when its tension first reaches yield_strain, and again on its parts
        (solver.breaking.solve_breaking; docs/model.md, "Breaking into parts").

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
    fields, outputs = _names("fields", fields), None if outputs is None else _names("outputs", outputs)
    if end not in ENDS:
        raise ParameterError(f"end must be one of {', '.join(repr(e) for e in ENDS)}, got {end!r}")
    eps_Y = None if eps_Y is None else tuple(yield_strains(eps_Y).tolist())
    locate_eps_Y = tuple(yield_strains(locate_eps_Y).tolist()) if np.size(locate_eps_Y) else ()
    if start is not None:
        if not isinstance(start, RunState):
            raise ParameterError(f"start must be a solver.RunState (a run's end: result.end.state), got "
                                 f"{type(start).__name__}")
        if t_start != 0.0 or initial_amplitudes is not None or initial_velocities is not None:
            raise ParameterError("give the initial state as start (a RunState, its time the run's start) or as "
                                 "t_start, initial_amplitudes and initial_velocities, not both")
        t_start = start.time
    body_given = start is not None and start.body is not None
    p, s, times, x, t_end, a0, v0 = _checked(parameters, settings, times, fields, x, t_end, t_start,
                                             (initial_amplitudes, initial_velocities), until_separation, full_plate,
                                             body_given)
    breaking = sorted(set(outputs or ()) & set(BREAKING_INFO))
    if breaking and p.fracture != "break":
        raise ParameterError(f"outputs: {breaking[0]} is an output of a run that breaks (fracture = 'break')")
    full = p.off_centre if full_plate is None else bool(full_plate)
    window, asked = Window(times, float(t_start), t_end), Asked(tuple(fields), x, outputs, eps_Y, end, locate_eps_Y)
    if p.fracture == "break":
        _checked_breaking(p, locate_eps_Y, eps_Y, start=start, initial_amplitudes=initial_amplitudes,
                          initial_velocities=initial_velocities, breaks=breaks, break_strain=break_strain,
                          t_start=None if t_start == 0 else t_start)
        return solve_breaking(p, s, RunSpec(window, asked, Begin(cosines_to_kernel(a0, full), cosines_to_kernel(v0, full)),
                                            full, until_separation=until_separation))
    kernel_breaks = checked_breaks(p, s, breaks, full_plate)
    if break_strain is not None and not (math.isfinite(break_strain) and break_strain > 0):
        raise ParameterError(f"break_strain must be a positive strain, got {break_strain!r}")
    if start is not None:
        begin = Begin(np.asarray(start.amplitudes, float), np.asarray(start.velocities, float),
                      checked_breaks(p, s, start.breaks, full_plate) if len(start.breaks) else None,
                      _checked_body(p, start.body))
    else:
        begin = Begin(cosines_to_kernel(a0, full), cosines_to_kernel(v0, full))
    return run_case(p, s, RunSpec(window, asked, begin, full, kernel_breaks, until_separation,
                                  math.inf if break_strain is None else float(break_strain)))


def _names(what, names) -> tuple:
    """A list of names (fields, outputs) as a tuple, or ParameterError: a single string is not a list
    (it would be read letter by letter)."""
    if isinstance(names, (str, bytes)):
        raise ParameterError(f"{what} must be a list of names, got the string {names!r} (give [{names!r}])")
    try:
        names = tuple(names)
    except TypeError:
        raise ParameterError(f"{what} must be a list of names, got {names!r}") from None
    bad = [n for n in names if not isinstance(n, str)]
    if bad:
        raise ParameterError(f"{what} must be a list of names, got {bad[0]!r} in it")
    return names


def _checked_breaking(p, locate_eps_Y, eps_Y, **unread):
    """What a run that breaks refuses of solve's keywords beyond its parameters' checks: a state
    or an end of its own (it starts from the unbroken plate at rest at first touch and breaks
    at p.yield_strain), and crack onsets above the yield strain (solver.fracture)."""
    given = [name for name, value in unread.items() if value is not None]
    if given:
        raise ParameterError(f"{given[0]} is not read by a run that breaks (fracture = 'break'): it starts from the "
                             f"unbroken plate at rest at first touch and breaks where its tension reaches yield_strain")
    above_yield_strain(p, [*locate_eps_Y, *(eps_Y or ())])


def _checked_body(p, body):
    """A free body's BodyState at the start (its stop time and deepest penetration NaN: no stop
    yet), as a run's end.state gives it; None for the paper's body."""
    if body is None:
        return None
    values = tuple(float(v) for v in body)
    if not p.free_body or len(values) != 4 or not all(math.isfinite(v) for v in values[:2]):
        raise ParameterError("start.body is a free body's BodyState (penetration [m], speed [m/s], stop time [s], "
                             "deepest penetration [m]), as result.end.state gives it")
    return BodyState(*values)


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

