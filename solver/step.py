r"""One step of the integrator, and its dense output (docs/model.md, "Numerics").

The modal variables z_n (solver.model.plate) obey z_n' = mu_n z_n + P_n(t, z) exactly, mu_n =
i omega_n for the paper's elastic ice. With phi_k the phi functions of zeta = mu_n h and
N_k = P(t_k, U_k), a step from t to t + h is:

  * ``ETD34``: exponential Runge-Kutta with Krogstad's fourth-order stages and an embedded
    third-order solution sharing the first-same-as-last stage (the ETD(3,4) pair of Whalen,
    Brio & Moloney, J. Comput. Phys. 280, 2015)::

        U2 = e^{zeta/2} z + (h/2) phi1(zeta/2) N1
        U3 = U2 + h phi2(zeta/2) (N2 - N1)
        U4 = e^{zeta} z + h phi1(zeta) N1 + 2 h phi2(zeta) (N3 - N1)
        z+ = e^{zeta} z + h[(phi1 - 3 phi2 + 4 phi3) N1 + (2 phi2 - 4 phi3)(N2 + N3)
                            + (4 phi3 - phi2) N4]
        err = h (4 phi3 - phi2) (N4 - N5),  N5 = P(t + h, z+)  (reused as N1 of the next step)

    The modal oscillation is exact, so the step is limited only by how fast the forcing
    changes (the contact stiffness), not by omega_N.
  * ``RK4``: the paper's classical Runge-Kutta on the same equations (fixed step); its error
    estimate is its difference from the exponential update on the same stage values.

A free body (solver.model.body) is one more degree of freedom with no linear part: the same
rows of the scheme in the limit omega -> 0 (``body_coefficients``), stepped alongside the modes.

What crosses into a step: the Model tuple, the scheme's Coefficients for the step's length, a
StepWork of scratch (the stage table: forces F, body decelerations G, deficits d, u, the plate's
and the layer's dissipation D, Lp at stages 1..5), the State at the step's start with the
Carried scalars (force, work, dissipated energy, the layer's power, contact intervals), and the
State that receives the step's end.

Analytic benchmark (tests/test_integrators.py): with the layer off (K = 0) and a_n(0) = 1 both
methods return a_n(t) = cos(omega_n t), ETD34 to round-off; the observed order of accuracy is
4 for both (test_observed_order_of_accuracy); RK4 is the classical scheme to round-off
(test_rk4_is_the_classical_scheme).
"""
import math
from collections import namedtuple

from .compile.jit import kernel
from .layout import B_D, B_U, ETD34
from .model.body import Stages, body_error, body_step_work, body_accel, body_coefficients
from .model.contact import count_contacts
from .model.crack import add_crack_forcing, crack_power, opening
from .model.layer import layer_forcing_at, layer_forcing_strain, rule_energy
from .model.plate import (HALF_C, KIND, OMEGA, dissipation_rate, emul, mode_a, mode_adot, mode_phis, phi_from,
                          plate_damped)

#: the state at one time, arrays filled in place: z (N,) complex, forcing P (N,), a, adot (N,),
#: delta and eps at the nodes (J,), the body's deficits yb (2,) (B_D, B_U), the step's local error
#: err (N,) complex and errb (2,), and acc (3,): the energy dissipated by then, the layer's power,
#: the layer's energy by the contact-resolving rule (solver.model.layer.rule_energy; NaN by the
#: paper's)
State = namedtuple("State", "z forcing a adot delta eps yb err errb acc")
#: the scalars a step carries from its start: force F [N m-1], work W [J m-1], dissipated energy
#: [J m-1], the viscoelastic layer's power [W m-1], contact intervals
Carried = namedtuple("Carried", "force work dissipated power contacts")
#: the scheme's weights for one step length: C (9, N) complex (etd_coefficients), Cb (9, 2)
Coefficients = namedtuple("Coefficients", "C Cb")
#: scratch of a step: cz (2, N) complex (the stage state; RK4's increment), rows (5, N) (a at a
#: stage, the stage forcings N2, N3, N4, a' at a stage), fvals (J,), and the stage table (6, 6):
#: rows *_ROW, columns the stages 1..5 (one array, not six: numba counts the references of
#: every array a tuple argument holds at each call)
StepWork = namedtuple("StepWork", "cz rows fvals table")
#: rows of StepWork.table: the force F, the body's deceleration G, its deficits d and u, the
#: plate's dissipation rate D and the layer's power Lp at each stage
F_ROW, G_ROW, D_ROW, U_ROW, DISS_ROW, LP_ROW = range(6)
#: what a step reads of the state at its start: z, the forcing P and the body's deficits yb
Start = namedtuple("Start", "z forcing yb")
#: all a sub-step needs besides its start: the method, the model, its own coefficients, scratch
Stepper = namedtuple("Stepper", "method model coeffs work")
#: what the local error estimate reads and fills of the step's end State: z, the forcing, yb, and
#: err, errb that it fills (the arrays, not the State: numba counts a reference to every array of
#: a tuple at each binding)
ErrorEnd = namedtuple("ErrorEnd", "z forcing yb err errb")


@kernel
def etd_coefficients(plate, h, C):
    """ETD34 coefficients of a step h for every mode, rows of C (9, N): e^{zeta}, e^{zeta/2},
    then the stage and update weights of the scheme in the module docstring (a damped mode's
    packed as mode_phis packs them)."""
    omega = plate.modes[OMEGA]
    for n in range(omega.shape[0]):
        if plate.modes[HALF_C, n] == 0.0:
            y = omega[n] * h
            e2 = complex(math.cos(0.5 * y), math.sin(0.5 * y))
            e = e2 * e2                          # one sin/cos for both
            p1, p2, p3 = phi_from(y, e)
            q1, q2, q3 = phi_from(0.5 * y, e2)
        else:
            e, p1, p2, p3 = mode_phis(plate, n, h)
            e2, q1, q2, q3 = mode_phis(plate, n, 0.5 * h)
        C[0, n] = e
        C[1, n] = e2
        C[2, n] = 0.5 * h * q1
        C[3, n] = h * q2
        C[4, n] = h * p1
        C[5, n] = 2.0 * h * p2
        C[6, n] = h * (p1 - 3.0 * p2 + 4.0 * p3)
        C[7, n] = h * (2.0 * p2 - 4.0 * p3)
        C[8, n] = h * (4.0 * p3 - p2)


@kernel(inline="llvm")
def _stage(model, rows, fvals, zs, t, s, U, delta, P):
    """A stage at the state zs at t, the body at penetration s moving down at U: layer_forcing_at
    into P, and the opening cracks' forcing (solver.model.crack). Returns (status, force, jmax,
    the layer's power). a' is needed only by a viscoelastic layer. (The stage's number is not an
    argument: numba would compile a copy for each literal.)"""
    plate = model.plate
    a_work = rows[0]
    adot_work = rows[4]
    for n in range(zs.shape[0]):
        a_work[n] = mode_a(zs[n], n, plate)
    if model.layer.tau > 0.0:
        for n in range(zs.shape[0]):
            adot_work[n] = mode_adot(zs[n], a_work[n], n, plate)
    out = layer_forcing_at(model, s, U, a_work, adot_work, delta, fvals, P)
    add_crack_forcing(model.cracks, t, P)
    return out


@kernel(inline="llvm", nrt=True)
def _last_stage(model, w, zs, yb, delta, forcing, eps, t_new):
    """The forcing at the step's end (stage 5, the next step's first), with the strain at every
    node into eps, from the step end's z and yb (its delta and forcing filled). Returns (status,
    jmax)."""
    plate = model.plate
    a_work = w.rows[0]
    adot_work = w.rows[4]
    for n in range(zs.shape[0]):
        a_work[n] = mode_a(zs[n], n, plate)
    if model.layer.tau > 0.0:
        for n in range(zs.shape[0]):
            adot_work[n] = mode_adot(zs[n], a_work[n], n, plate)
    V = model.body.V
    st, F, jm, Lp = layer_forcing_strain(model, V * t_new - yb[B_D], V - yb[B_U], a_work, adot_work, delta, w.fvals,
                                         forcing, eps)
    add_crack_forcing(model.cracks, t_new, forcing)
    w.table[F_ROW, 5] = F
    w.table[LP_ROW, 5] = Lp
    return st, jm


@kernel(inline="always")
def _dissipation(model, z, t, ice_damped):
    """The power taken from the plate at the modal state z at t: the Kelvin-Voigt damping's (for
    viscoelastic ice) and the opening cracks' (solver.model.crack.crack_power, the fracture's)."""
    d = dissipation_rate(z, model.plate) if ice_damped else 0.0
    return d - crack_power(model.cracks, t, z, model.plate)


@kernel(inline="llvm")
def _contacts_changed(mirror, st, delta, jm, contacts):
    """A stage that succeeded has another number of contact intervals than the step's start."""
    return st == 0 and count_contacts(delta, jm, mirror) != contacts


@kernel(inline="llvm")
def _etd_stages(model, coeffs, w, start, contacts, t, t_new, h, delta):
    """ETD34's stages 2, 3 and 4 (the module docstring), the body's alongside: (status, jmax,
    event), event if the number of contact intervals changed among them."""
    C, Cb = coeffs.C, coeffs.Cb
    plate = model.plate
    kind = plate.modes[KIND]
    ice_damped = plate_damped(plate)
    dissipating = ice_damped or opening(model.cracks)
    z, N1 = start.z, start.forcing
    zs = w.cz[0]
    N2, N3, N4 = w.rows[1], w.rows[2], w.rows[3]
    d, u, G1 = start.yb[B_D], start.yb[B_U], w.table[G_ROW, 1]
    V = model.body.V
    th = t + 0.5 * h
    for n in range(z.shape[0]):
        zs[n] = emul(C[1, n], z[n], kind[n]) + C[2, n] * N1[n]
    if dissipating:
        w.table[DISS_ROW, 2] = _dissipation(model, zs, th, ice_damped)
    st, F, jm, Lp = _stage(model, w.rows, w.fvals, zs, th, V * th - w.table[D_ROW, 2], V - w.table[U_ROW, 2], delta,
                           N2)
    w.table[F_ROW, 2], w.table[G_ROW, 2], w.table[LP_ROW, 2] = F, body_accel(model.body, F), Lp
    event = _contacts_changed(model.basis.mirror, st, delta, jm, contacts)
    if st == 0:
        for n in range(z.shape[0]):
            zs[n] = zs[n] + C[3, n] * (N2[n] - N1[n])
        w.table[D_ROW, 3] = w.table[D_ROW, 2] + Cb[3, 1] * (w.table[G_ROW, 2] - G1)
        w.table[U_ROW, 3] = w.table[U_ROW, 2] + Cb[3, 0] * (w.table[G_ROW, 2] - G1)
        if dissipating:
            w.table[DISS_ROW, 3] = _dissipation(model, zs, th, ice_damped)
        st, F, jm, Lp = _stage(model, w.rows, w.fvals, zs, th, V * th - w.table[D_ROW, 3], V - w.table[U_ROW, 3],
                               delta, N3)
        w.table[F_ROW, 3], w.table[G_ROW, 3], w.table[LP_ROW, 3] = F, body_accel(model.body, F), Lp
        event = event or _contacts_changed(model.basis.mirror, st, delta, jm, contacts)
    if st == 0:
        for n in range(z.shape[0]):
            zs[n] = emul(C[0, n], z[n], kind[n]) + C[4, n] * N1[n] + C[5, n] * (N3[n] - N1[n])
        if dissipating:
            w.table[DISS_ROW, 4] = _dissipation(model, zs, t_new, ice_damped)
        w.table[D_ROW, 4] = d + Cb[0, 1] * u + Cb[4, 1] * G1 + Cb[5, 1] * (w.table[G_ROW, 3] - G1)
        w.table[U_ROW, 4] = u + Cb[4, 0] * G1 + Cb[5, 0] * (w.table[G_ROW, 3] - G1)
        st, F, jm, Lp = _stage(model, w.rows, w.fvals, zs, t_new, V * t_new - w.table[D_ROW, 4],
                               V - w.table[U_ROW, 4], delta, N4)
        w.table[F_ROW, 4], w.table[G_ROW, 4], w.table[LP_ROW, 4] = F, body_accel(model.body, F), Lp
        event = event or _contacts_changed(model.basis.mirror, st, delta, jm, contacts)
    return st, jm, event


@kernel(inline="llvm")
def _rk4_stages(model, coeffs, w, start, t, t_new, h, delta):
    """Classical RK4's stages 2, 3 and 4 on z' = i omega z + P (w.cz[1] accumulates k1 + 2 k2 +
    2 k3), the body's as ETD34 has them: (status, jmax)."""
    Cb = coeffs.Cb
    omega = model.plate.modes[OMEGA]
    z, N1 = start.z, start.forcing
    zs, incr = w.cz[0], w.cz[1]
    N2, N3, N4 = w.rows[1], w.rows[2], w.rows[3]
    d, u, G1 = start.yb[B_D], start.yb[B_U], w.table[G_ROW, 1]
    V = model.body.V
    th = t + 0.5 * h
    for n in range(z.shape[0]):
        k1 = 1j * omega[n] * z[n] + N1[n]
        incr[n] = k1
        zs[n] = z[n] + 0.5 * h * k1
    st, F, jm, Lp = _stage(model, w.rows, w.fvals, zs, th, V * th - w.table[D_ROW, 2], V - w.table[U_ROW, 2], delta,
                           N2)
    w.table[F_ROW, 2], w.table[G_ROW, 2], w.table[LP_ROW, 2] = F, body_accel(model.body, F), Lp
    if st == 0:
        for n in range(z.shape[0]):
            k2 = 1j * omega[n] * zs[n] + N2[n]
            incr[n] += 2.0 * k2
            zs[n] = z[n] + 0.5 * h * k2
        w.table[D_ROW, 3] = w.table[D_ROW, 2] + Cb[3, 1] * (w.table[G_ROW, 2] - G1)
        w.table[U_ROW, 3] = w.table[U_ROW, 2] + Cb[3, 0] * (w.table[G_ROW, 2] - G1)
        st, F, jm, Lp = _stage(model, w.rows, w.fvals, zs, th, V * th - w.table[D_ROW, 3], V - w.table[U_ROW, 3],
                               delta, N3)
        w.table[F_ROW, 3], w.table[G_ROW, 3], w.table[LP_ROW, 3] = F, body_accel(model.body, F), Lp
    if st == 0:
        for n in range(z.shape[0]):
            k3 = 1j * omega[n] * zs[n] + N3[n]
            incr[n] += 2.0 * k3
            zs[n] = z[n] + h * k3
        w.table[D_ROW, 4] = d + Cb[0, 1] * u + Cb[4, 1] * G1 + Cb[5, 1] * (w.table[G_ROW, 3] - G1)
        w.table[U_ROW, 4] = u + Cb[4, 0] * G1 + Cb[5, 0] * (w.table[G_ROW, 3] - G1)
        st, F, jm, Lp = _stage(model, w.rows, w.fvals, zs, t_new, V * t_new - w.table[D_ROW, 4],
                               V - w.table[U_ROW, 4], delta, N4)
        w.table[F_ROW, 4], w.table[G_ROW, 4], w.table[LP_ROW, 4] = F, body_accel(model.body, F), Lp
    return st, jm


@kernel(inline="llvm")
def _update(method, model, coeffs, w, start, h, z_out, yb_out):
    """The step's solution into z_out and yb_out of the step's end from the stage table."""
    C, Cb = coeffs.C, coeffs.Cb
    plate = model.plate
    z, N1 = start.z, start.forcing
    N2, N3, N4 = w.rows[1], w.rows[2], w.rows[3]
    d, u = start.yb[B_D], start.yb[B_U]
    G = w.table[G_ROW]
    yb_out[B_D] = d + Cb[0, 1] * u + Cb[6, 1] * G[1] + Cb[7, 1] * (G[2] + G[3]) + Cb[8, 1] * G[4]
    yb_out[B_U] = u + Cb[6, 0] * G[1] + Cb[7, 0] * (G[2] + G[3]) + Cb[8, 0] * G[4]
    if method == ETD34:
        for n in range(z.shape[0]):
            z_out[n] = (emul(C[0, n], z[n], plate.modes[KIND, n]) + C[6, n] * N1[n] + C[7, n] * (N2[n] + N3[n])
                        + C[8, n] * N4[n])
    else:
        omega = plate.modes[OMEGA]
        zs, incr = w.cz[0], w.cz[1]
        for n in range(z.shape[0]):
            k4 = 1j * omega[n] * zs[n] + N4[n]
            z_out[n] = z[n] + h / 6.0 * (incr[n] + k4)


@kernel(inline="llvm")
def _local_error(method, model, coeffs, w, start, h, event, out):
    """The step's local error estimate into err and errb of the step end's ErrorEnd: ETD34's embedded estimate, or, across a change of contact (event), its
    difference from the exponential trapezoid, whose estimate does not read zero where the
    forcing is only (t - t*)^{3/2} smooth; RK4's against the exponential (Krogstad) update from
    the same stage values (RK4's Taylor approximation of e^{i w h} dominates its error; the
    body's update is the same in both)."""
    C, Cb = coeffs.C, coeffs.Cb
    kind = model.plate.modes[KIND]
    z_out, N5, yb_out, err, errb = out.z, out.forcing, out.yb, out.err, out.errb
    z, N1 = start.z, start.forcing
    N2, N3, N4 = w.rows[1], w.rows[2], w.rows[3]
    d, u = start.yb[B_D], start.yb[B_U]
    G = w.table[G_ROW]
    if method != ETD34:
        for n in range(z.shape[0]):
            err[n] = z_out[n] - (C[0, n] * z[n] + C[6, n] * N1[n] + C[7, n] * (N2[n] + N3[n]) + C[8, n] * N4[n])
        errb[B_D] = 0.0
        errb[B_U] = 0.0
    elif event:
        for n in range(z.shape[0]):
            err[n] = z_out[n] - (emul(C[0, n], z[n], kind[n]) + (C[4, n] - 0.5 * C[5, n]) * N1[n]
                                 + 0.5 * C[5, n] * N5[n])
        errb[B_D] = yb_out[B_D] - (d + Cb[0, 1] * u + (Cb[4, 1] - 0.5 * Cb[5, 1]) * G[1] + 0.5 * Cb[5, 1] * G[5])
        errb[B_U] = yb_out[B_U] - (u + (Cb[4, 0] - 0.5 * Cb[5, 0]) * G[1] + 0.5 * Cb[5, 0] * G[5])
    else:
        for n in range(z.shape[0]):
            err[n] = C[8, n] * (N4[n] - N5[n])
        body_error(h, G[1], G[2], G[3], G[4], G[5], errb)      # 0 exactly for the prescribed body


@kernel
def take_step(method, model, coeffs, w, start, carried, t, t_new, h, out):
    """One step from (t, start) to t_new = t + h, coeffs for h (RK4 uses them for its error
    estimate), the start's forcing, force, work, dissipated energy and layer power given.

    Fills out: z, forcing and delta at t_new, the strain at every node (eps, from the last
    stage's pass over the table), the body (yb; the prescribed body stays at d = u = 0 exactly),
    the local error estimate (err, errb), and acc = (energy dissipated by t_new: the step's
    weights on the damped plate's dissipation rate plus the viscoelastic layer's power at its
    stages, 0 for the paper's elastic ice and layer; the layer's power at t_new; its energy by
    the contact-resolving rule, from the last stage's pass). Returns
    (status, F(t_new), jmax(t_new), W(t_new), event): status 1 if a stage reached delta >= 1
    (out then meaningless); event if the number of contact intervals changed among the stages.
    """
    body, plate = model.body, model.plate
    Cb = coeffs.Cb
    ice_damped = plate_damped(plate)
    damped = ice_damped or model.layer.tau > 0.0 or opening(model.cracks)
    d, u = start.yb[B_D], start.yb[B_U]
    for k in range(1, 5):
        w.table[DISS_ROW, k] = 0.0
    w.table[F_ROW, 1] = carried.force
    w.table[G_ROW, 1] = body_accel(body, carried.force)
    w.table[D_ROW, 2] = d + Cb[1, 1] * u + Cb[2, 1] * w.table[G_ROW, 1]
    w.table[U_ROW, 2] = u + Cb[2, 0] * w.table[G_ROW, 1]
    if ice_damped or opening(model.cracks):
        w.table[DISS_ROW, 1] = _dissipation(model, start.z, t, ice_damped)
    event = False
    if method == ETD34:
        st, jm, event = _etd_stages(model, coeffs, w, start, carried.contacts, t, t_new, h, out.delta)
    else:
        st, jm = _rk4_stages(model, coeffs, w, start, t, t_new, h, out.delta)
    if st == 0:
        _update(method, model, coeffs, w, start, h, out.z, out.yb)
        st, jm = _last_stage(model, w, out.z, out.yb, out.delta, out.forcing, out.eps, t_new)
    if st != 0:
        return 1, 0.0, jm, carried.work, event
    w.table[G_ROW, 5] = body_accel(body, w.table[F_ROW, 5])
    if method == ETD34:
        event = event or count_contacts(out.delta, jm, model.basis.mirror) != carried.contacts
    else:
        event = count_contacts(out.delta, jm, model.basis.mirror) != carried.contacts
    _local_error(method, model, coeffs, w, start, h, event, ErrorEnd(out.z, out.forcing, out.yb, out.err, out.errb))
    V = body.V
    F = w.table[F_ROW]
    w_new = body_step_work(body, h, carried.work, Stages(F[1], F[2], F[3], F[4]),
                           Stages(V - u, V - w.table[U_ROW, 2], V - w.table[U_ROW, 3], V - w.table[U_ROW, 4]))
    D, Lp = w.table[DISS_ROW], w.table[LP_ROW]
    out.acc[0] = (carried.dissipated + h * ((D[1] + carried.power) / 6.0 + (D[2] + Lp[2] + D[3] + Lp[3]) / 3.0
                                            + (D[4] + Lp[4]) / 6.0) if damped else carried.dissipated)
    out.acc[1] = Lp[5]
    out.acc[2] = rule_energy(model, w.fvals)
    return 0, w.table[F_ROW, 5], jm, w_new, event


@kernel
def substep(stepper, start, carried, t, s, out):
    """A step of length s from (t, start) into out, with the stepper's own coefficients; out.a and
    out.adot receive a_n and a_n' at t + s. Returns take_step's tuple."""
    plate = stepper.model.plate
    etd_coefficients(plate, s, stepper.coeffs.C)
    body_coefficients(s, stepper.coeffs.Cb)
    res = take_step(stepper.method, stepper.model, stepper.coeffs, stepper.work, start, carried, t, t + s, s, out)
    for k in range(out.z.shape[0]):
        out.a[k] = mode_a(out.z[k], k, plate)
        out.adot[k] = mode_adot(out.z[k], out.a[k], k, plate)
    return res


@kernel
def dense_states(z0, N1, Nm, N5, plate, h, A, AD):
    """a_n and a_n' at t0 + k h / K, k = 1..K-1 (K = A.shape[0] + 1), inside an accepted step.

    Exponential dense output: the modal oscillation exact, the forcing quadratic in time
    through P(t0) = N1, the mid stage Nm ~ P(t0 + h/2) and P(t0 + h) = N5:
        P(t0 + s) = N1 + b1 s + b2 s^2.
    For such a forcing, z' = i w z + P has the exact sub-step of length d = h / K
        z(s + d) = e^{i w d} z(s) + d phi1 P(s) + d^2 phi2 P'(s) + d^3 phi3 P''   (phi_k of i w d),
    so one set of phi functions per mode serves every sample. It resolves modes that oscillate
    within the step, which a polynomial through the step ends cannot.
    """
    K = A.shape[0] + 1
    d = h / K
    omega = plate.modes[OMEGA]
    for n in range(z0.shape[0]):
        w = omega[n]
        b1 = (4.0 * Nm[n] - 3.0 * N1[n] - N5[n]) / h
        b2 = 2.0 * (N1[n] - 2.0 * Nm[n] + N5[n]) / (h * h)
        kind = plate.modes[KIND, n]
        if plate.modes[HALF_C, n] == 0.0:
            y = w * d
            e = complex(math.cos(y), math.sin(y))
            p1, p2, p3 = phi_from(y, e)
        else:
            e, p1, p2, p3 = mode_phis(plate, n, d)
        c1 = d * p1
        c2 = d * d * p2
        c3 = 2.0 * b2 * d * d * d * p3
        z = z0[n]
        for k in range(1, K):
            sk = (k - 1) * d
            z = emul(e, z, kind) + c1 * (N1[n] + sk * (b1 + b2 * sk)) + c2 * (b1 + 2.0 * b2 * sk) + c3
            a = mode_a(z, n, plate)
            A[k - 1, n] = a
            AD[k - 1, n] = mode_adot(z, a, n, plate)


@kernel
def dense_state_at(z0, N1, Nm, N5, plate, h, s, a, adot):
    """a_n and a_n' at t0 + s, 0 <= s <= h, inside an accepted step: dense_states' exact solution
    for the quadratic forcing through N1, Nm, N5, taken as one sub-step of length s from t0
        z(s) = e^{i w s} z0 + s phi1 N1 + s^2 phi2 b1 + 2 b2 s^3 phi3   (phi_k of i w s)
    (the located maxima of a floe's tension, solver.observe.dense_maxima)."""
    omega = plate.modes[OMEGA]
    for n in range(z0.shape[0]):
        b1 = (4.0 * Nm[n] - 3.0 * N1[n] - N5[n]) / h
        b2 = 2.0 * (N1[n] - 2.0 * Nm[n] + N5[n]) / (h * h)
        if plate.modes[HALF_C, n] == 0.0:
            y = omega[n] * s
            e = complex(math.cos(y), math.sin(y))
            p1, p2, p3 = phi_from(y, e)
        else:
            e, p1, p2, p3 = mode_phis(plate, n, s)
        z = emul(e, z0[n], plate.modes[KIND, n]) + s * p1 * N1[n] + s * s * p2 * b1 + 2.0 * b2 * s * s * s * p3
        a[n] = mode_a(z, n, plate)
        adot[n] = mode_adot(z, a[n], n, plate)
