"""What a run's status means (STATUS_INFO; docs/model.md, "Statuses") and the one line that says
how a run that did not end ok ended (status_message), from its status, its diagnostics and the
kernels' failure record."""
from __future__ import annotations

import math

from . import layout as kn
from .control import ENERGY_BOUND, ENERGY_JUMP
from .parameters import Parameters

#: status -> meaning (docs/model.md, "Statuses")
STATUS_INFO = {
    "ok": "the run reached the end of its time window",
    "layer_bottomed_out": "the layer's gap closed to bottoming_gap (default 1e-3, pressure 1000 K) of its "
                          "thickness at bottoming_time: the model's own end; data up to then is valid",
    "nonfinite": "a fixed-step run met delta >= 1 or a non-finite state, or the adaptive step "
                 "could not avoid one, or a broken plate's wet modes could not be computed",
    "step_limit": "max_steps attempted, or error control drove the step below its floor",
    "energy_violation": "the energy identity E_plate + E_layer + D = W (D: dissipated, by viscoelastic ice or "
                        "layer and opening cracks) was broken: a step made it jump and no smaller step mended it, or the residual ended "
                        "above 1e-3 of the work (for a free body, also its own balance "
                        "M (U^2 - V^2)/2 - M body_g s + W = 0)",
    "separated": "a free body (finite body_mass) left the ice moving up at separation_time, and the run "
                 "was asked to end there (until separation); data up to then is valid",
    "parts_limit": "a run that breaks (fracture = 'break') would have broken into more than max_parts parts: "
                   "it ended at that break; data up to then is valid",
    "edge_break": "a run that breaks (fracture = 'break') reached yield_strain at a free edge (a place already "
                  "broken, or a floe's edge), which carries no moment in the model: its basis is too coarse "
                  "there; it ended there; data up to then is valid",
    "stopped": "a free body stopped (its speed reached zero at stop_time) and was still on the ice at the "
               "end of a run asked to go until separation; data is valid",
}


def energy_bound_message(p: Parameters, diagnostics: dict, quadrature: str) -> str:
    """Which energy balance ended the run above ENERGY_BOUND: the ice's, or a free body's
    own (with its round-off floor when the body is so heavy that M V^2 x 1e-16 is not small
    against the work)."""
    plate, body = diagnostics["energy_residual"], diagnostics["body_energy_residual"]
    if not plate > ENERGY_BOUND and body > ENERGY_BOUND:
        text = (f"energy identity broken: the free body's balance |M (U^2 - V^2)/2 - M body_g s + W| reached "
                f"{body:.2e} of the work (bound {ENERGY_BOUND:g}; the ice's residual is {plate:.2e})")
        floor = 1e-16 * p.body_mass * p.V**2 / max(diagnostics["work"], 1e-300)
        if floor > 1e-2 * ENERGY_BOUND:
            text += (f"; at body_mass = {p.body_mass:g} kg/m its round-off alone, M V^2 x 1e-16, is {floor:.1e} of "
                     f"the work: a body this heavy is the paper's body (body_mass = inf)")
        return text
    if quadrature == "paper":                 # a free floe runs the paper's rule only (check_combination)
        mend = ("more subintervals or a tighter tolerance" if p.edges == "free"
                else "more subintervals, quadrature = \"gauss\" or a tighter tolerance")
    else:
        mend = "a tighter tolerance or a larger quadrature_density"
    return (f"energy identity broken: the residual |E_plate + E_layer + D - W| reached {plate:.2e} of the work "
            f"(bound {ENERGY_BOUND:g}; {mend} may mend it)")


def status_message(p, s, status, diagnostics, diag, t_end, fixed, fail, full_plate) -> str:
    """One line saying how a run that did not end ok ended (docs/model.md, "Statuses"), from its
    status, diagnostics and the kernels' failure record (diag's D_FAIL_*); "" for ok."""
    max_delta = diagnostics["max_compression"]
    t_sc = p.time_scale
    t_reached = float(diag[kn.D_T_REACHED])
    if status == "ok":
        return ""
    if status == "separated":
        message = (f"the body left the ice at t = {diagnostics['separation_time']:.6g} s moving up at "
                   f"{diagnostics['separation_speed']:.4g} m/s (it had stopped at "
                   f"{diagnostics['stop_time']:.6g} s, {diagnostics['max_penetration']:.4g} m deep)")
    elif status == "stopped":
        message = (f"the body stopped at t = {diagnostics['stop_time']:.6g} s, "
                   f"{diagnostics['max_penetration']:.4g} m deep, and had not left the ice by "
                   f"t = {t_reached:.6g} s")
    else:
        t_fail = float(diag[kn.D_FAIL_T])
        where = f"at t = {t_fail:.6g} s ({t_fail / t_sc:.4g} t_sc; stage {p.stage_duration / t_sc:.4g} t_sc)"
        kind = int(diag[kn.D_FAIL_KIND])
        floor = f"{1e-13 * t_end:.1e} s"
        if kind == kn.FAIL_LOCATED:
            message = (f"layer bottomed out {where}: its gap closed to {s.bottoming_gap:g} of its thickness "
                       f"at x = {'' if full_plate else '+-'}{diagnostics['bottoming_x']:.4g} m, closing at "
                       f"{diagnostics['bottoming_closing_speed']:.3g} m/s; the force there is unbounded")
        elif kind == kn.FAIL_BOTTOMED:
            message = (f"layer bottomed out {where} (not located to the threshold): the compression "
                       f"reached delta = 1 - {max(1.0 - max_delta, 0.0):.1e} and no step down to {floor} "
                       f"kept it below 1")
        elif kind == kn.FAIL_FIXED_STEP and s.integrator == "dop853":
            message = f"dop853 {fail} {where}"
        elif kind == kn.FAIL_FIXED_STEP:
            message = (f"{s.integrator} with a fixed step {fixed:.3g} s reached delta >= 1 or a "
                       f"non-finite value {where}; a fixed step cannot be retried "
                       f"(largest delta before: {max_delta:.6g})")
        elif kind == kn.FAIL_NONFINITE and s.integrator == "dop853":
            message = f"dop853 failed {where}: {fail}"
        elif kind == kn.FAIL_NONFINITE and fail:
            message = f"{s.integrator} failed: {fail}"
        elif kind == kn.FAIL_NONFINITE:
            message = f"non-finite state {where} with the step at its smallest ({floor})"
        elif kind == kn.FAIL_STEP_UNDERFLOW:
            message = (f"error control drove the step below {floor} {where}; "
                       f"largest delta reached {max_delta:.6g}")
        elif kind == kn.FAIL_ENERGY_JUMP:
            message = (f"energy identity broken {where}: a step changed E_plate + E_layer + D - W by more "
                       f"than {ENERGY_JUMP:g} of the energy in play, and " +
                       ("a fixed step cannot be retried" if fixed > 0 else f"no step down to {floor} mended it"))
        elif kind == kn.FAIL_ENERGY_BOUND:
            message = energy_bound_message(p, diagnostics, s.quadrature) + (
                f"; the run reached t = {t_reached:.6g} s ({t_reached / t_sc:.4g} t_sc)")
            if math.isfinite(diagnostics["bottoming_time"]):
                message += ", where the layer bottomed out"
        else:
            message = (f"stopped {where} after {int(diag[kn.D_STEPS] + diag[kn.D_REJECTED])} attempted "
                       f"steps (max_steps = {s.max_steps}); largest delta reached {max_delta:.6g}")
    return message
