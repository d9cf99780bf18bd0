"""What one run is asked, and how it ends, as typed records built by keyword (docs/architecture.md,
"A run, layer by layer"): :func:`solver.solve` checks its keywords once into a :class:`RunSpec`,
and every layer below reads names, not positions; a run returns its :class:`StageEnd` beside its
Result (``Result.end``), which is what a run that breaks carries from one stage to the next.

Public: :class:`RunState` (a run's state at a time, where a run ends and another can start:
``solve(parameters, settings, start=result.end.state, breaks=[...])``) and :class:`BodyState` (a
free body's part of it); :class:`Breaking` and :class:`BreakEvent`, what a run that breaks
reports of its breaks (``Result.breaking``). The rest is the solver's own.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

#: a free body's state at a time: its penetration s below first touch [m], its downward speed U
#: [m s-1], its first stop's time [s] and its deepest penetration [m] so far (NaN: not stopped
#: yet); what the kernels start a free body from (solver.control.Control.body_start)
BodyState = namedtuple("BodyState", "penetration speed stop_time deepest")


@dataclass(frozen=True)
class RunState:
    """A run's state at ``time`` [s], in the kernel's own form: where a run ended
    (``Result.end.state``) and where another starts (``solve(..., start=state)``).

    ``amplitudes`` and ``velocities`` are the kernel's modal amplitudes [m] and rates [m s-1] of the
    plate broken at ``breaks`` (x [m] on the plate, () unbroken): the unbroken plate's cosines in
    the kernel's order (symmetric, then on the full plate both parities interleaved), or a broken
    plate's wet modes. ``body`` is a free body's :data:`BodyState` (None: the paper's body, at V t).
    A run from it on a plate broken at more places carries it across (docs/model.md, "Breaking
    into parts")."""

    time: float
    amplitudes: np.ndarray
    velocities: np.ndarray
    breaks: tuple = ()
    body: BodyState | None = None


#: where a run ended at a break (the tension reached the break level): time [s], x [m] on the
#: plate, surface ("upper" or "lower")
Break = namedtuple("Break", "time x surface")
#: a crack still opening (solver.model.crack): its break's time [s] and place [m, kernel
#: coordinates], and the moment D w_xx [N m m-1] and shear D w_xxx [N m-1] the ice carried there
Crack = namedtuple("Crack", "time x moment shear")


@dataclass(frozen=True)
class CarriedEnergy:
    """The energy a run started with when its state was carried onto a plate broken at more
    places [J m-1]: the plate's and the layer's before the carry and after it."""

    plate_before: float
    plate_after: float
    layer_before: float
    layer_after: float

    @property
    def plate_removed(self) -> float:
        """What the carry left out of the plate's energy (never negative: a projection)."""
        return self.plate_before - self.plate_after

    @property
    def layer_removed(self) -> float:
        """The layer's energy before the carry less after it (either sign: w moved under the body)."""
        return self.layer_before - self.layer_after

    @property
    def removed(self) -> float:
        """The energy the break removed: the plate's and the layer's before less after."""
        return (self.plate_before + self.layer_before) - (self.plate_after + self.layer_after)

    @property
    def after(self) -> float:
        """The plate's and the layer's energy the run started with."""
        return self.plate_after + self.layer_after


@dataclass(frozen=True)
class StageEnd:
    """How a run ended, for the one that goes on from it: its state at the time reached, the break
    it ended at (None: it did not), the energy carried into it across a break (None: it started on
    its own plate), and its energy scale [J m-1] (what its energy residuals are relative to: the
    energy it started with plus its largest work)."""

    state: RunState
    broke: Break | None
    carried: CarriedEnergy | None
    energy_scale: float


@dataclass(frozen=True)
class Window:
    """The run's time window: output times [s] (sorted, in [t_start, t_end]), its start and end [s]."""

    times: np.ndarray
    t_start: float
    t_end: float


@dataclass(frozen=True)
class Asked:
    """What the run is asked for: the fields at the positions x [m], the outputs (None: every one),
    the yield strains and end of an answered run, the levels to locate on sub-steps."""

    fields: tuple
    x: np.ndarray
    outputs: tuple | None = None
    eps_Y: tuple | None = None
    end: str = "stage"
    locate_eps_Y: tuple = ()


@dataclass(frozen=True)
class Begin:
    """The state a run begins from in the kernel's own form: amplitudes and rates of the plate
    broken at ``breaks`` (kernel coordinates; None: unbroken), and a free body's BodyState (None:
    at first touch, or the paper's body)."""

    amplitudes: np.ndarray
    velocities: np.ndarray
    breaks: np.ndarray | None = None
    body: BodyState | None = None


@dataclass(frozen=True)
class RunSpec:
    """One run, checked (solver.core.solve, solver.breaking): its window, what is asked, the state
    it begins from, the plate it runs on (``breaks`` in kernel coordinates, None: unbroken; the
    full plate or the half plate of a centred impact), and how it ends besides t_end (at a free
    body's separation; where a surface's tension reaches ``break_level``, inf: never); the first
    step [s] (None: first touch's, short); the cracks still opening (Crack, solver.model.crack); the
    time the steps' growth cap counts from (solver.control.GROWTH; None: the window's start)."""

    window: Window
    asked: Asked
    begin: Begin
    full_plate: bool
    breaks: np.ndarray | None = None
    until_separation: bool = False
    break_level: float = math.inf
    first_step: float | None = None
    cracks: tuple = ()
    growth_from: float | None = None


@dataclass(frozen=True)
class BreakEvent:
    """One break of a run that breaks (docs/model.md, "The run that breaks"): its time [s], place
    x [m] on the plate (on the half plate of a centred impact it stands for -x too), surface
    ("upper" or "lower"), the whole plate's parts after it, whether it broke the body through,
    the body's penetration then [m], and the energy it removed [J m-1] with its plate's part
    (never negative) and its layer's (either sign)."""

    time: float
    x: float
    surface: str
    parts: int
    broken_through: bool
    penetration: float
    removed_energy: float = math.nan
    removed_plate_energy: float = math.nan
    removed_layer_energy: float = math.nan


@dataclass(frozen=True)
class Breaking:
    """What a run that breaks reports of its breaks (``Result.breaking``; None for a run that does
    not break): the breaks in the order they happened, the energy they removed up to each output
    time [J m-1] (NaN where the run did not reach it), each stage's own Result, and whether the
    kernels ran the whole plate (else the half plate of a centred impact). Its summary is read
    from the breaks."""

    breaks: tuple
    removed_energy: np.ndarray
    stages: tuple
    full_plate: bool

    @property
    def first_break_time(self) -> float:
        """Time of the first break [s] (NaN: none)."""
        return self.breaks[0].time if self.breaks else math.nan

    @property
    def break_count(self) -> int:
        return len(self.breaks)

    @property
    def parts(self) -> int:
        """Parts of the whole plate at the end of the run."""
        return self.breaks[-1].parts if self.breaks else 1

    @property
    def breakthrough(self):
        """The break that broke the body through (a break on each side of its centre), or None."""
        return next((e for e in self.breaks if e.broken_through), None)

    @property
    def breakthrough_time(self) -> float:
        return self.breakthrough.time if self.breakthrough else math.nan

    @property
    def breakthrough_penetration(self) -> float:
        return self.breakthrough.penetration if self.breakthrough else math.nan
