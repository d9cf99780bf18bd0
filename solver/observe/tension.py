r"""The tension records: the running maximum of the peak tension on each surface over time
(docs/model.md, "Events": crack onset for any eps_Y from one run).

The peak of sign * eps over x (sign +1: the upper surface's tension, -1: the lower's) is followed
through each accepted step: d/dt max_x eps = eps_t at the peak (envelope theorem), so its value
and rate are known exactly at both ends, and between samples the record is their cubic Hermite.
Inside a step the peak is sampled on the exponential dense output (solver.step.dense_states),
which resolves modes that oscillate within the step. A step is stored when it raises the
running maximum; rows (t, value, rate, x, join), join = 1 when the row continues the previous
one (layout R_*). Where the global peak passes from one local peak to another within a step,
the global peak itself is sampled. Crack onset for eps_Y is then the first crossing of eps_Y by
the record (solver.fracture), for every eps_Y from the one run.

A run that breaks (watch_level: its break level finite) watches its steps more closely, since a
break a step hides changes the run (docs/model.md, "Why a stage starts with a short step, and
how a run that breaks watches its steps"): every step whose peak comes within BREAK_RIPPLE of the
level is sampled, the global peak is searched at each sample (_elsewhere) and the step sampled
as a switch where another peak stands above the followed one, and each step's best carries the
time of its largest tension after its first sample below the level (solver.ending arms a
surface there and scans its break at that time).

Benchmark (tests/test_events.py): the record's crossing agrees with the crossing located on
true sub-steps of the integrator (test_record_answers_any_eps_Y_as_exact_location), and one
record answers ten eps_Y as ten separate runs would.
"""
from collections import namedtuple

import numpy as np

from ..arrays import copy_into
from ..cubic import cubic_max, hermite
from ..compile.jit import kernel
from ..layout import D_MAX_UPPER, D_MAX_UPPER_T, D_MAX_UPPER_X
from ..model.basis import Field, climb, field_sum, global_peak, node_strain, peak_and_rate, read_interval
from ..model.floe import floe_dry
from ..model.plate import OMEGA, STRAIN
from ..step import dense_states
from .record import SurfaceRows, append_row

#: the peak tension is sampled at TENSION_SAMPLES - 1 points inside each step, from the
#: exponential dense output: modes that oscillate within a step (omega h ~ 5 at N = 60) give
#: the peak a 3e-4 wobble inside the step that the step ends alone cannot see (a step with
#: omega_N h <= 0.4, such as rk4's, resolves every mode and is not sampled)
TENSION_SAMPLES = 8
#: a step with omega_N h at most this resolves every mode: between its ends the peak is their
#: cubic Hermite (the impact zone's observer uses the same criterion)
RESOLVED = 0.4
#: a step whose end interpolant stays RIPPLE (relative) below the running maximum cannot raise
#: it (the wobble inside a step is ~3e-4): it is not sampled
RIPPLE = 1e-2
#: in a run that breaks, a step whose peak stays BREAK_RIPPLE (relative) below the break level
#: is not sampled: another peak may rise and fall inside a step that does not resolve the
#: waves (8 % within 4 us at N = 80, benchmarks/breaking_sweep.py --seed 21, case 2)
BREAK_RIPPLE = 0.5
#: samples of the global peak in a step where it passes from one local peak to another
SWITCH_SAMPLES = 32
#: a peak that moves more than SWITCH_DISTANCE nodes within one step is taken for a switch
SWITCH_DISTANCE = 10
#: in a run that breaks, a step's global peak above the followed one by more than this
#: (relative: Newton's stop leaves the two refinements of one peak some 1e-12 apart) is another
#: peak, and the step is sampled as a switch (_global_piece)
ELSEWHERE = 1e-9

#: the tension observer's state and scratch: track (9, 4), rows PEAKS + s each surface's (value,
#: rate, x, node) at the current time, P0, P1 a step's start and end, PIECE one piece's and BEST
#: the step's (max, time, x, after), BACK a backward track's (value, rate, x), STEP_BEST + s each
#: surface's (max, time, x, after) over the last step, after the time of the largest tension
#: from the first sample below the break level on, -1 where none was below it (the impact
#: zone's observer reads the first three, a run that breaks the fourth); samples (TENSION_SAMPLES
#: + 1, 3), A, AD (TENSION_SAMPLES - 1, N) the dense states; A2, AD2, eps, samples2 the same for a
#: switch of peaks (SWITCH_SAMPLES); nodes (TENSION_SAMPLES - 1, J) the strain at every node
#: at the dense states A (a run that breaks: _elsewhere); dry (2, TENSION_SAMPLES - 1, N) on a
#: floe-form basis the dry coefficients of A and AD (solver.model.floe.floe_dry: once a step for
#: the fourteen searches of each surface and the impact zone's samples, fill_dry); marks (9,):
#: RUN_MAX + s the running maximum of surface s, JOINABLE + s 1 when its last step was stored, DENSE (DENSE_SWITCH) 1
#: when the step's dense states A, AD (A2, AD2) are computed, or given by the integrator
#: (dense_due), LEVEL the break level of a run that breaks (inf otherwise: watch_level), NODES 1
#: when nodes holds the step's strains, DRY 1 when dry holds the step's coefficients. (Few
#: arrays: numba counts a reference to each array of a tuple at every binding.)
TensionWork = namedtuple("TensionWork", "track samples A AD A2 AD2 eps samples2 nodes dry marks")
#: rows of TensionWork.track
PEAKS, P0, P1, PIECE, BEST, BACK, STEP_BEST = 0, 2, 3, 4, 5, 6, 7
#: entries of TensionWork.marks
RUN_MAX, JOINABLE, DENSE, DENSE_SWITCH, LEVEL, NODES, DRY = 0, 2, 4, 5, 6, 7, 8
#: the dense output's inputs for one step: z and forcing at its start, its mid stage, its end
Dense = namedtuple("Dense", "z0 N1 Nm N5")
#: what the tension observer reads of a step's two states: eps at its start; eps, a and a' at its
#: end (the arrays, not the States: numba counts a reference to every array of a tuple at each
#: binding)
StepStrains = namedtuple("StepStrains", "eps0 eps1 a1 adot1")
#: a step's dense-output states and what makes them: A, AD (TENSION_SAMPLES - 1, N) the states
#: at t0 + k h / K (computed on demand, ensure_dense), an eps scratch (J,), the step's Dense,
#: the marks (DENSE: computed, DRY: dry holds their dry coefficients), dry (2, TENSION_SAMPLES - 1,
#: N) on a floe-form basis (TensionWork.dry: the tension's and the zone's searches share them)
DenseStates = namedtuple("DenseStates", "A AD eps dense marks dry")


@kernel(nrt=True)
def tension_work(N, J):
    """A TensionWork for N modes and J nodes (allocated once per run)."""
    # (-inf: the step's bests STEP_BEST before the observer's first step; a run without it leaves
    # them so, and the impact zone's maxima then take none of them)
    return TensionWork(np.full((9, 4), -np.inf), np.empty((TENSION_SAMPLES + 1, 3)),
                       np.empty((TENSION_SAMPLES - 1, N)), np.empty((TENSION_SAMPLES - 1, N)),
                       np.empty((SWITCH_SAMPLES - 1, N)), np.empty((SWITCH_SAMPLES - 1, N)), np.empty(J),
                       np.empty((SWITCH_SAMPLES + 1, 3)), np.empty((TENSION_SAMPLES - 1, J)),
                       np.empty((2, TENSION_SAMPLES - 1, N)),
                       np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, np.inf, 0.0, 0.0]))


@kernel
def watch_level(tw, level):
    """A run that breaks at the tension level (finite) has every step near it searched for the
    global peak (_tension_piece): a peak that emerges elsewhere and rises and falls within one
    step is a break the followed peak cannot see. A run that does not break (level inf) is
    unchanged."""
    tw.marks[LEVEL] = level


@kernel(inline="llvm")
def _watched(tw, s):
    """The level below which a step's peak cannot matter, less the ripple a step may hide: the
    running maximum of surface s less RIPPLE; in a run that breaks, the break level where that
    is lower (after a break the carried peak may stand above it) less BREAK_RIPPLE."""
    run_max = tw.marks[RUN_MAX + s]
    if not tw.marks[LEVEL] < np.inf:
        return run_max - RIPPLE * abs(run_max)
    watched = min(run_max, tw.marks[LEVEL])
    return watched - BREAK_RIPPLE * abs(watched)


@kernel
def dense_due(marks, h):
    """A new step's dense states are due: computed on demand from its Dense by the first observer
    that needs them (none for a step of length 0). An integrator with a dense output of its own
    (the DOP853 reference) fills A, AD, A2, AD2 and calls dense_given instead."""
    marks[DENSE] = 0.0 if h > 0.0 else 1.0
    marks[DENSE_SWITCH] = marks[DENSE]
    marks[NODES] = 0.0
    marks[DRY] = 0.0


@kernel
def dense_given(marks):
    """A new step's dense states A, AD, A2, AD2 given by an integrator with a dense output of its
    own (the DOP853 reference): what is computed from them is due."""
    marks[DENSE] = marks[DENSE_SWITCH] = 1.0
    marks[NODES] = 0.0
    marks[DRY] = 0.0


@kernel
def peak_near(x, xlo, xhi, sign, field, a, adot, lam1, floe, track):
    """Peak of sign * the modal field (field_sums: sum_n w_n a_n cos(lambda_n x) on the cosines)
    near x (Newton, kept in [xlo, xhi]) and its rate, the same field of a' at the peak x*:
    track[:3] = (value, rate, x); on a floe-form basis a and adot are dry coefficients
    (fill_dry). On a plate broken with a crack spacing the bracket stays where the tension is
    read (read_interval)."""
    lo, hi = read_interval(floe, x, xlo, xhi)
    if lo <= x <= hi:
        xlo, xhi = lo, hi
    track[0], track[1], track[2] = peak_and_rate(x, xlo, xhi, sign, field, a, adot, lam1, floe)


@kernel(inline="llvm")
def global_state(model, eps, sign, a, adot, track):
    """The global peak of sign * eps over continuous x (global_peak) and its time derivative
    d/dt = sign * eps_t at the peak (envelope theorem): track[:] = (value, rate, x, node)."""
    strain = model.plate.modes[STRAIN]
    v, x, j = global_peak(eps, sign, model.basis, strain, a, True)
    track[0] = v
    track[1] = sign * field_sum(model.basis.lam1, model.basis.floe, Field(strain, 1), adot, x)
    track[2] = x
    track[3] = j


@kernel
def ensure_dense(model, h, dz, A, AD, marks):
    """The step's dense-output states into A, AD (solver.step.dense_states), once a step: unless
    marks[DENSE] says an observer computed them already."""
    if marks[DENSE] == 0.0:
        dense_states(dz.z0, dz.N1, dz.Nm, dz.N5, model.plate, h, A, AD)
        marks[DENSE] = 1.0


@kernel(nrt=True)
def append_chain(t0, h, samples, rec, n, joinable):
    """The samples (rows (value, rate, x, ...) at t0 + k h / K, k = 0..K) as consecutive record
    rows (t, value, rate, x, join): the first only where the previous step's last row is not
    there to join (joinable). Returns (rec, n)."""
    K = samples.shape[0] - 1
    hk = h / K
    if not joinable:
        rec, n = append_row(rec, n, t0, samples[0, 0], samples[0, 1], samples[0, 2], 0.0)
    for k in range(1, K + 1):
        rec, n = append_row(rec, n, t0 + k * hk, samples[k, 0], samples[k, 1], samples[k, 2], 1.0)
    return rec, n


@kernel(inline="llvm")
def _after_dip(t_max, v0, level):
    """The fourth entry of a step's best where only its ends are known: the time of its largest
    tension where the step starts below level (a surface is armed below it, solver.ending), else
    -1 (none below it)."""
    return t_max if v0 < level else -1.0


@kernel(nrt=True)
def _store_samples(t0, h, K, level, samples, rec, n, joinable, run_max, best):
    """The peak sampled at t0 + k h / K, k = 0..K (rows of samples: value, rate, x): best
    receives the (max, time, x) of the Hermite pieces between samples, and the time of their
    largest from the first sample below level on (-1: none below it; _after_dip); the samples
    are stored as consecutive record rows when that maximum rises above run_max. Returns (rec,
    n, stored)."""
    hk = h / K
    best[0], best[3] = -np.inf, -1.0
    after = -np.inf
    for k in range(K):
        c0, c1, c2, c3 = hermite(samples[k, 0], samples[k + 1, 0], samples[k, 1], samples[k + 1, 1], hk)
        vmax, th = cubic_max(c0, c1, c2, c3)
        if vmax > best[0]:
            best[0] = vmax
            best[1] = t0 + (k + th) * hk
            best[2] = samples[k, 2] + th * (samples[k + 1, 2] - samples[k, 2])
        if (best[3] >= 0.0 or samples[k, 0] < level) and vmax > after:
            after = vmax
            best[3] = t0 + (k + th) * hk
    if not best[0] > run_max:
        return rec, n, False
    rec, n = append_chain(t0, h, samples[:K + 1], rec, n, joinable == 1.0)
    return rec, n, True


@kernel(inline="llvm", nrt=True)
def _tension_piece(model, tw, s, t0, h, dz, rec, n):
    """The peak of surface s over the step: from track P0 (t0) to P1 (t0 + h), each (value, rate,
    x), through the dense-output states inside the step (computed from dz unless marks DENSE says
    they are; samples[k] receives the larger of the peaks followed forward from x0 and backward
    from x1). Stored as consecutive record rows when it rises above the running maximum; track
    PIECE receives (max, time, x) of the piece. Returns (rec, n, stored)."""
    p0, p1, best, samples = tw.track[P0], tw.track[P1], tw.track[PIECE], tw.samples
    joinable, run_max, watched = tw.marks[JOINABLE + s], tw.marks[RUN_MAX + s], _watched(tw, s)
    sign = 1.0 - 2.0 * s
    K = tw.A.shape[0] + 1
    c0, c1, c2, c3 = hermite(p0[0], p1[0], p0[1], p1[1], h)
    vmax, th = cubic_max(c0, c1, c2, c3)
    best[0] = vmax                               # from the ends; refined by the samples below
    best[1] = t0 + th * h
    best[2] = p0[2] + th * (p1[2] - p0[2])
    best[3] = _after_dip(best[1], p0[0], tw.marks[LEVEL])
    if vmax < watched:                           # cannot raise the record (nor reach a break level)
        return rec, n, False
    omega = model.plate.modes[OMEGA]
    if omega[omega.shape[0] - 1] * h <= RESOLVED:    # every mode resolved by the step: its ends suffice
        if not vmax > run_max:
            return rec, n, False
        if not joinable:
            rec, n = append_row(rec, n, t0, p0[0], p0[1], p0[2], 0.0)
        rec, n = append_row(rec, n, t0 + h, p1[0], p1[1], p1[2], 1.0)
        return rec, n, True
    ensure_dense(model, h, dz, tw.A, tw.AD, tw.marks)
    A, AD = dense_dry(model, tw)
    # follow the peak forward from p0 and backward from p1, each sample by Newton near the
    # previous one; keep the larger (the global peak may pass from one local peak to another)
    field, dx, L = Field(model.plate.modes[STRAIN], 1), model.basis.dx, model.basis.length
    xf = p0[2]
    for k in range(1, K):
        peak_near(xf, max(0.0, xf - 3.0 * dx), min(L, xf + 3.0 * dx), sign, field, A[k - 1], AD[k - 1],
                  model.basis.lam1, model.basis.floe, samples[k])
        xf = samples[k, 2]
    xb = p1[2]
    back = tw.track[BACK]
    for k in range(K - 1, 0, -1):
        peak_near(xb, max(0.0, xb - 3.0 * dx), min(L, xb + 3.0 * dx), sign, field, A[k - 1], AD[k - 1],
                  model.basis.lam1, model.basis.floe, back)
        xb = back[2]
        if back[0] > samples[k, 0]:
            copy_into(samples[k], back, 3)
    copy_into(samples[0], p0, 3)
    copy_into(samples[K], p1, 3)
    if tw.marks[LEVEL] < np.inf and _elsewhere(model, tw, sign, K):
        return _global_piece(model, tw, s, t0, h, dz, rec, n)
    return _store_samples(t0, h, K, tw.marks[LEVEL], samples, rec, n, joinable, run_max, best)


@kernel(inline="llvm")
def fill_dry(model, states):
    """On a floe-form basis the dry coefficients (floe_dry) of a step's dense states (states: a
    TensionWork or the DenseStates, computed: their A, AD, dry and marks), computed once a step
    (marks DRY) for both surfaces' searches forward and back and the impact zone's samples
    (solver.observe.zone); nothing on the cosines."""
    floe = model.basis.floe
    if floe.shape[0] > 0 and states.marks[DRY] == 0.0:
        for k in range(states.A.shape[0]):
            floe_dry(floe, states.A[k], states.dry[0, k])
            floe_dry(floe, states.AD[k], states.dry[1, k])
        states.marks[DRY] = 1.0


@kernel(inline="llvm", nrt=True)
def dense_dry(model, states):
    """A step's dense states as the peak searches read them: A, AD on the cosines, their dry
    coefficients on a floe-form basis (fill_dry)."""
    fill_dry(model, states)
    if model.basis.floe.shape[0] == 0:
        return states.A, states.AD
    return states.dry[0], states.dry[1]


@kernel(inline="llvm", nrt=True)
def _elsewhere(model, tw, sign, K):
    """Whether, at one of the step's inner samples, the global peak (over every node's local
    peak, global_peak) stands above the peak followed there (samples[k]): another peak rose
    inside the step. The strains at the nodes are computed once a step, for both surfaces."""
    strain = model.plate.modes[STRAIN]
    if tw.marks[NODES] == 0.0:
        for k in range(1, K):
            node_strain(model.basis.cosq, model.basis.floe, strain, tw.A[k - 1], tw.nodes[k - 1])
        tw.marks[NODES] = 1.0
    for k in range(1, K):
        v = global_peak(tw.nodes[k - 1], sign, model.basis, strain, tw.A[k - 1], False)[0]
        if v > tw.samples[k, 0] + ELSEWHERE * abs(tw.samples[k, 0]):
            return True
    return False


@kernel(nrt=True)
def _global_piece(model, tw, s, t0, h, dz, rec, n):
    """The global peak over a step in which it passes from one local peak to another (a new
    peak may emerge inside the step, where no track can follow it): at SWITCH_SAMPLES - 1
    points of the dense output the strain is evaluated at every node and the global peak
    searched among all local peaks (global_peak); the states are computed once a step, unless
    marks DENSE_SWITCH says they are. Stored like _tension_piece."""
    p0, p1, best, samples = tw.track[P0], tw.track[P1], tw.track[PIECE], tw.samples2
    joinable, run_max, watched = tw.marks[JOINABLE + s], tw.marks[RUN_MAX + s], _watched(tw, s)
    sign = 1.0 - 2.0 * s
    K = SWITCH_SAMPLES
    if max(p0[0], p1[0]) < watched:              # far below the record: not needed
        best[0] = max(p0[0], p1[0])
        best[1] = t0 if p0[0] >= p1[0] else t0 + h
        best[2] = p0[2] if p0[0] >= p1[0] else p1[2]
        best[3] = _after_dip(best[1], p0[0], tw.marks[LEVEL])
        return rec, n, False
    if tw.marks[DENSE_SWITCH] == 0.0:
        dense_states(dz.z0, dz.N1, dz.Nm, dz.N5, model.plate, h, tw.A2, tw.AD2)
        tw.marks[DENSE_SWITCH] = 1.0
    copy_into(samples[0], p0, 3)
    copy_into(samples[K], p1, 3)
    strain = model.plate.modes[STRAIN]
    for k in range(1, K):
        node_strain(model.basis.cosq, model.basis.floe, strain, tw.A2[k - 1], tw.eps)
        v, x, j = global_peak(tw.eps, sign, model.basis, strain, tw.A2[k - 1], False)
        samples[k, 0] = v
        samples[k, 1] = sign * field_sum(model.basis.lam1, model.basis.floe, Field(strain, 1), tw.AD2[k - 1], x)
        samples[k, 2] = x
    return _store_samples(t0, h, K, tw.marks[LEVEL], samples, rec, n, joinable, run_max, best)


@kernel(inline="llvm", nrt=True)
def observe_tension(model, tw, s, t0, h, ends, dz, rec, n):
    """Running-maximum record of the tension of surface s (sign = 1 - 2 s) over the step
    [t0, t0 + h], between its two states: ends, a StepStrains.

    tw.track[PEAKS + s] holds (value, rate, x, node) of the global peak at t0 and receives it at t1. The
    peak is followed from the step's start to its end through TENSION_SAMPLES - 1 samples of the
    dense output inside the step (see _tension_piece); where the global peak passes from one
    local peak to another within the step, the global peak itself is sampled (_global_piece). A
    step is stored when it rises above tw.marks[RUN_MAX + s], the running maximum so far (updated,
    and JOINABLE + s). Returns (rec, n); track BEST receives the (max, time, x) of the step.
    """
    sign = 1.0 - 2.0 * s
    eps0, eps1 = ends.eps0, ends.eps1
    J = eps1.shape[0]
    p0, p1, best, piece = tw.track[P0], tw.track[P1], tw.track[BEST], tw.track[PIECE]
    copy_into(p0, tw.track[PEAKS + s], p0.shape[0])
    j0 = int(p0[3])
    global_state(model, eps1, sign, ends.a1, ends.adot1, p1)
    jb0 = climb(eps0, sign, int(p1[3]), J)
    best[0] = -np.inf
    # one track through the step, unless the peak at t1 climbs back to another local peak at t0
    # or jumped too far for one track (a peak that emerged inside the step)
    if jb0 == j0 and abs(p1[2] - p0[2]) <= SWITCH_DISTANCE * model.basis.dx:
        rec, n, stored = _tension_piece(model, tw, s, t0, h, dz, rec, n)
    else:                                           # the global peak moved to another local peak
        rec, n, stored = _global_piece(model, tw, s, t0, h, dz, rec, n)
    tw.marks[JOINABLE + s] = 1.0 if stored else 0.0
    if piece[0] > best[0]:
        copy_into(best, piece, 3)
    best[3] = piece[3]
    if best[0] > tw.marks[RUN_MAX + s]:
        tw.marks[RUN_MAX + s] = best[0]
    copy_into(tw.track[PEAKS + s], p1, p1.shape[0])
    return rec, n


@kernel(nrt=True)
def observe_tensions(model, tw, t, h, ends, dz, records, diag):
    """The tension records of both surfaces over the accepted step (observe_tension; ends, a
    StepStrains), records a SurfaceRows; the largest tensions into diag. Returns the records."""
    rec_up, n_up, rec_lo, n_lo = records.upper, records.n_upper, records.lower, records.n_lower
    for s in range(2):                  # (a loop: numba compiles a copy per literal surface index)
        if s == 0:
            rec_up, n_up = observe_tension(model, tw, s, t, h, ends, dz, rec_up, n_up)
        else:
            rec_lo, n_lo = observe_tension(model, tw, s, t, h, ends, dz, rec_lo, n_lo)
        _largest(tw.track[BEST], s, diag)
        copy_into(tw.track[STEP_BEST + s], tw.track[BEST], 4)
    return SurfaceRows(rec_up, n_up, rec_lo, n_lo)


@kernel(inline="llvm")
def _largest(best, s, diag):
    """The step's (max, time, x) of surface s into diag where it is the largest so far."""
    if best[0] > diag[D_MAX_UPPER + 3 * s]:
        diag[D_MAX_UPPER + 3 * s] = best[0]
        diag[D_MAX_UPPER_T + 3 * s] = best[1]
        diag[D_MAX_UPPER_X + 3 * s] = best[2]
