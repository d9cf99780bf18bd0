r"""The step policy: which step to try, whether to accept it, and the next one (docs/model.md,
"Numerics": error control and the energy guard).

A step is rejected and retried smaller when its local error exceeds the tolerance in the energy
norm (``error_ratio``), a stage reached delta >= 1 or the state is not finite, or the energy
identity E_plate + E_layer + D - W - E(t_start) = 0 jumps by more than ``energy_allowance``.
Accepted steps grow by PI control (Gustafsson), at most by GROWTH (t - t_start) after the first,
and land exactly on every output time. The run's :data:`Control` is built once per run.

With ``error_control = "smoothness"`` a step is also judged by how smooth the forcing is in time
(``smoothness_ratio``). The embedded estimate compares two solutions built on the same three
samples of the forcing, at t, t + h/2 and t + h; a mode that oscillates once or more inside the
step (omega_n h >~ 2) is driven by the part of P_n that those samples alias, and the embedded
estimate does not see it. The forcing's fourth divided difference over the samples of this step
and the one before (tau = -h', -h'/2, 0, h/2, h) estimates what a cubic in time misses:

    r_n = P_n[tau_0, ..., tau_4] h^4 / 16,   e_n = min(h, 2 / omega_n) r_n,

mode n integrating a misfit of the forcing over the step when it is slow, over about a period
when it is fast; ||e|| in the energy norm against the tolerance, as the embedded estimate (the
plate's modes: a free body's velocity stays the embedded estimate's). Its local error falls as
h^5 (exponent 1/5). Benchmarks (tests/test_error_control.py): zero for a forcing cubic in time
and the closed form above for c_n t^4; the run's error falls in proportion to the tolerance where
the embedded estimate alone leaves it at a floor.

Benchmark (tests/test_error_estimate.py, tests/test_energy_and_forcing.py): the run's error
falls with the tolerance as its estimate says; the energy residual shrinks with the tolerance
and as dx^2 with the quadrature.
"""
import math
from collections import namedtuple

from .compile.jit import kernel
from .layout import B_D, B_U
from .observe.asked import ALL
from .model.basis import Field, field_sum
from .model.plate import MASS, OMEGA, ONES, mode_a

#: default bottoming threshold (Settings.bottoming_gap): the layer has bottomed out when its
#: gap he (1 - delta) closes to bottom_gap he anywhere on the plate; the pressure there is
#: K / bottom_gap = 1000 K (8 GPa for the paper's layer: crushed). A larger threshold is less
#: sensitive to grazing approaches: with 1e-6 a bounce whose smallest gap was 1.05e-6 at
#: tolerance 1e-8 crossed it at 1e-9 (N = 40, V = 10 m/s, hi = 1 m)
BOTTOM_GAP = 1e-3
#: energy guard: a step may change the residual E_plate + E_layer - W by at most
#:     ENERGY_JUMP max(W, E_plate + E_layer) + under |dW|.
#: The paper's rule: under = min(1, (RESOLVED_NODES / n_c)^2), n_c the compressed nodes: the
#: quadrature's own mismatch is about |dW| (dx / width)^2, O(1) of the tiny energies of first
#: touch. Normal runs (reference case, thin and thick ice, stiff and thin layers, fast impacts;
#: etd34 and rk4) use at most 10% of this allowance. The Gauss rule keeps the identity to the
#: time error, so under = 0. Under either rule under = 1 on the step from W = 0: the force grows
#: from first touch like t^(1 + 1/p) (p the body's power; t^(3/2) for the paper's parabola),
#: self-similar, and the step's stages miss O(1e-2) of its tiny work at any step size (0.56% on
#: a body of p = 4 under a fixed step, which spreads its contact over 140 of the paper's nodes
#: in that step: refused at the first step before, tests/test_composition.py).
ENERGY_JUMP = 1e-3
RESOLVED_NODES = 4
#: an adaptive step is at most GROWTH (t - t_start) (after a first step h_init): the tension
#: grows like t^3.5 from first touch, and a cubic Hermite interpolant of t^a over a step h at
#: time t misplaces a level by about 0.005 (h/t)^4 of t, 5e-7 at GROWTH = 0.1. The stages of a
#: run that breaks count it from the run's first touch (Control.growth_from): a stage starts from
#: a carried state, not from a self-similar one, and its short first step (solver.breaking) grows
#: by the PI control
GROWTH = 0.1
#: when the layer is within GAP_WATCH of bottoming, a step's local error of delta at the gap
#: must stay below GAP_ACCURACY times the gap 1 - delta
GAP_WATCH = 1e-2
GAP_ACCURACY = 0.1
#: a run whose energy residual ends above this fraction of the work ends energy_violation
ENERGY_BOUND = 1e-3

#: the run's control: t_start, t_end [s]; tolerance (relative error per step in the energy norm,
#: ETD34 adaptive); fixed_step [s] (> 0: RK4 always, ETD34 without error control); h_init, h_min,
#: h_max [s] (first trial, smallest and largest step; h_max must resolve the contact oscillation:
#: in free flight the forcing and hence the error estimate vanish, and only h_max stops a step
#: from jumping deep into a new contact); max_steps (attempted steps before STEP_LIMIT);
#: bottom_gap (the layer bottoms out when its gap closes to this fraction of he);
#: until_separation (a free body's run ends when it separates); zone_margin [m] (the impact zone
#: reaches this far beyond the contact, solver.observe.zone); observers (the bits of the observers
#: that run) and answer (4 levels: the run ends when the tension records' crossings up to them
#: are final; -inf a record not asked, +inf one asked to the end), solver.observe.asked;
#: smoothness (1.0: adaptive steps are judged by smoothness_ratio too, 0.0: not); floor (the error
#: norm's floor, a fraction of V sqrt(L M_1): error_scale); break_level (the run ends where a
#: surface's tension reaches it, inf: none); body_start (a free body at t_start: its penetration s
#: [m] and speed U [m/s], and its first stop's time [s] and deepest penetration [m] before t_start;
#: NaN: s = V t_start, U = V, no stop, as at first touch); growth_from (the time [s] the GROWTH cap
#: counts from: t_start, or a run that breaks its first touch for every stage)
Control = namedtuple("Control", "t_start t_end tolerance fixed_step h_init h_min h_max max_steps bottom_gap "
                                "until_separation zone_margin observers answer smoothness floor break_level "
                                "body_start growth_from")

#: the smoothness estimate's exponent: its local error falls as h^5
SMOOTH_EXPONENT = 0.2
#: the error norm's floor under the smoothness control, a fraction of V sqrt(L M_1) (the
#: embedded control keeps 1, its results unchanged). At the floor the tolerance bounds the error
#: absolutely while the plate's energy is below it, in the first 0.4 ms of the reference case:
#: there a crack onset at eps_Y = 2e-5 was 2.2e-6 from the continuous model at every tolerance.
#: Measured on the seven cases of benchmarks/time_integrator.py (eps_Y 2e-5 .. 1e-3, 2026-11-28),
#: the largest onset error at tolerances 1e-6, 3e-7, 1e-7, 3e-8, 1e-8: at 0.01 1.9e-6, 7.0e-7,
#: 2.4e-7, 2.2e-7, 2.7e-7; at 0.1 1.7e-6, 8.2e-7, 1.9e-6, 7.0e-7, 2.4e-7 (not falling with the
#: tolerance), for 1.5 % fewer steps in all (docs/performance.md, "Error control")
SMOOTH_FLOOR = 0.01


def make_control(t_start, t_end, tolerance, fixed_step, h_init, h_min, h_max, max_steps, bottom_gap,
                 until_separation=False, zone_margin=1.0, observers=ALL, answer=(math.inf,) * 4, smoothness=False,
                 break_level=math.inf, body_start=(math.nan,) * 4, growth_from=None):
    """The :data:`Control` of a run (plain Python: built once per run); by default every observer
    runs, the run goes to t_end and only the embedded estimate judges a step, with the error norm's
    floor at V sqrt(L M_1) (SMOOTH_FLOOR of it under the smoothness control), and the steps' GROWTH
    cap counts from t_start."""
    return Control(float(t_start), float(t_end), float(tolerance), float(fixed_step), float(h_init), float(h_min),
                   float(h_max), float(max_steps), float(bottom_gap), bool(until_separation), float(zone_margin),
                   int(observers), tuple(float(level) for level in answer), 1.0 if smoothness else 0.0,
                   SMOOTH_FLOOR if smoothness else 1.0, float(break_level), tuple(float(v) for v in body_start),
                   float(t_start if growth_from is None else growth_from))


@kernel(inline="llvm")
def error_scale(model, control, den_old, den_new):
    """What an error in the energy norm is measured against: the tolerance times the plate's
    energy norm at the step's start or end (den_old, den_new: sum L M_n |z_n|^2), the larger, or
    the floor f V sqrt(L M_1) while the plate's energy is below it (f: control.floor, 1 under the
    embedded control and SMOOTH_FLOOR under the smoothness control)."""
    floor = control.floor * model.body.V * math.sqrt(model.plate.lm_floor)
    return control.tolerance * max(math.sqrt(max(den_old, den_new)), floor)


@kernel(inline="llvm")
def error_ratio(model, control, z, znew, err, errb, gap, scratch):
    """Local error (err, errb) over tolerance in the energy norm: the plate's error and a free
    body's velocity error M err_U^2, against the plate's energy at the step's start (z) or end
    (znew) (docs/model.md, "A body of finite mass"); near bottoming (gap: the largest delta, its
    rate and place at the start) also the error of delta at the gap against the gap itself."""
    LM = model.plate.modes[MASS]
    num = 0.0
    den_old = 0.0
    den_new = 0.0
    for n in range(z.shape[0]):
        num += LM[n] * (err[n].real ** 2 + err[n].imag ** 2)
        den_old += LM[n] * (z[n].real ** 2 + z[n].imag ** 2)
        den_new += LM[n] * (znew[n].real ** 2 + znew[n].imag ** 2)
    im = model.body.inv_mass
    if im > 0.0:
        # the body's error in the same energy units, measured against the plate's energy,
        # not against the body's own kinetic energy M U^2 / 2: that grows with M and would
        # loosen the plate's control as M -> inf, where the paper's body is the limit
        num += errb[B_U] ** 2 / im
    ratio = math.sqrt(num) / error_scale(model, control, den_old, den_new)
    he = model.layer.he
    if model.layer.K > 0.0 and gap[0] > 1.0 - max(GAP_WATCH, 10.0 * control.bottom_gap):
        # near bottoming the local error of delta at the gap must be small against the
        # gap itself, or a grazing approach crosses the threshold in one run and not in
        # another: |err(delta)| <= GAP_ACCURACY (1 - delta)
        for n in range(z.shape[0]):
            scratch[n] = mode_a(err[n], n, model.plate)
        e_delta = abs(field_sum(model.basis.lam1, model.basis.floe, Field(model.plate.modes[ONES], 0), scratch, gap[2]) - errb[B_D]) / he
        ratio = max(ratio, e_delta / (GAP_ACCURACY * (1.0 - gap[0])))
    if not math.isfinite(ratio):
        ratio = 1e10
    return ratio


#: the forcing at the start and the middle of the last accepted step (rows of samples (2, N)),
#: [its length, 1.0 if it can be the smoothness estimate's first half] (last (2,)), and a free
#: body's deceleration G at its start and middle (body (2,))
History = namedtuple("History", "samples last body")
#: the forcing P (N,) at a step's start, its middle (the stage N3) and its end; body (3,): the
#: body's deceleration G at the same three times
Samples = namedtuple("Samples", "start middle end body")


@kernel(inline="llvm")
def _misfit(y0, y1, y2, y3, y4, hp, h):
    """What a cubic in time misses of the samples y0 .. y4 at -hp, -hp/2, 0, h/2, h (the last
    step's start and middle, this step's start, middle and end): their fourth divided difference
    times h^4 / 16."""
    t0, t1, t3, t4 = -hp, -0.5 * hp, 0.5 * h, h                # (t2 = 0)
    d01, d12, d23, d34 = (y1 - y0) / (t1 - t0), (y2 - y1) / -t1, (y3 - y2) / t3, (y4 - y3) / (t4 - t3)
    d012, d123, d234 = (d12 - d01) / -t0, (d23 - d12) / (t3 - t1), (d34 - d23) / t4
    return ((d234 - d123) / (t4 - t1) - (d123 - d012) / (t3 - t0)) / (t4 - t0) * h ** 4 / 16.0


@kernel
def smoothness_ratio(model, control, history, forcing, h, z0, z1):
    """The smoothness estimate over the tolerance (module docstring): the forcing's samples of the
    last accepted step (History) and of this one (forcing: its Samples), the step's states z0 and
    z1 for the norm; 0 where the last step cannot be its first half. A free body's velocity
    (a mode of omega = 0) is judged the same way on its deceleration G, in the same energy
    units as the embedded estimate's (M e_U^2)."""
    if control.smoothness == 0.0 or history.last[1] == 0.0:
        return 0.0
    plate = model.plate
    hp = history.last[0]
    num = den_old = den_new = 0.0
    for n in range(z0.shape[0]):
        r = _misfit(history.samples[0, n], history.samples[1, n], forcing.start[n], forcing.middle[n], forcing.end[n],
                    hp, h)
        w = plate.modes[OMEGA, n]
        e = (h if w * h <= 2.0 else 2.0 / w) * r
        num += plate.modes[MASS, n] * e * e
        den_old += plate.modes[MASS, n] * (z0[n].real ** 2 + z0[n].imag ** 2)
        den_new += plate.modes[MASS, n] * (z1[n].real ** 2 + z1[n].imag ** 2)
    im = model.body.inv_mass
    if im > 0.0:
        e_u = h * _misfit(history.body[0], history.body[1], forcing.body[0], forcing.body[1], forcing.body[2], hp, h)
        num += e_u * e_u / im
    return math.sqrt(num) / error_scale(model, control, den_old, den_new)


@kernel
def remember_step(history, n1, nm, g, h, smooth):
    """The accepted step's forcing at its start and middle (and a free body's deceleration g at
    its start and middle, g (3,): start, middle, end), and its length, into the History;
    smooth: it can be the first half of the next estimate (no change of contact, no bottoming)."""
    for n in range(n1.shape[0]):
        history.samples[0, n] = n1[n]
        history.samples[1, n] = nm[n]
    history.body[0] = g[0]
    history.body[1] = g[1]
    history.last[0] = h
    history.last[1] = 1.0 if smooth else 0.0


@kernel
def energy_allowance(delta_new, jm5, e_new, w_new, e0, work, basis):
    """How much one step may change the residual E_plate + E_layer - W (see ENERGY_JUMP); the
    paper's rule's compressed nodes counted as on the half plate (mirror / 2 of them on the
    full plate)."""
    if work == 0.0:
        under = 1.0
    elif basis.rule == 1:
        under = 0.0
    else:
        compressed = 0
        for j in range(jm5):
            if delta_new[j] > 0.0:
                compressed += 1
        under = min(1.0, (RESOLVED_NODES / max(compressed * (0.5 * basis.mirror), 1.0)) ** 2)
    return ENERGY_JUMP * max(e_new, w_new, e0) + under * abs(w_new - work)


@kernel
def next_step(control, t, target, h, fixed):
    """The step to try from t towards the next output time: (h_step, t_new, landing).
    fixed = [target the fixed step was chosen for, that step] (updated)."""
    remaining = target - t
    fixed_step = control.fixed_step
    if fixed_step > 0.0:
        # one step size per output interval, fixed for the whole interval (the ETD
        # coefficients are then computed once per interval); the last step lands on target
        if target != fixed[0]:
            fixed[0] = target
            n_sub = math.ceil(remaining / fixed_step * (1.0 - 1e-12))
            fixed[1] = remaining / max(n_sub, 1)
        landing = remaining <= 1.5 * fixed[1]
        h_step = remaining if landing else fixed[1]
    else:
        h_step = min(h, max(control.h_init, GROWTH * (t - control.growth_from)))
        if h_step >= remaining * (1.0 - 1e-12) or remaining - h_step < 0.01 * h_step:
            h_step = remaining
        landing = h_step >= remaining * (1.0 - 1e-12)
    t_new = target if landing else t + h_step
    return h_step, t_new, landing


@kernel
def grown_step(control, ratio, expo, prev_ratio, h_step, h, landing):
    """The next step after an accepted one, by PI control (Gustafsson: damps the accept/reject
    oscillation of a plain I step): (h, the ratio to remember)."""
    r_now = max(ratio, 1e-10)
    fac = 0.9 * r_now ** (-0.7 * expo) * prev_ratio ** (0.4 * expo)
    fac = min(5.0, max(0.2, fac))
    h_next = h_step * fac
    if landing and h_step < h:
        h_next = max(h_next, h)   # a step shortened to land keeps the old proposal
    return min(h_next, control.h_max), r_now
