r"""The layer between body and ice: its law, the forcing it puts on the modes, its energy
(docs/model.md, "Equations", "Viscoelastic layer", "Layer law").

The layer of thickness he and rigidity K is compressed by delta = (w + s - b(x)) / he (the
body's lowest point at y = he - s, its profile b, the ice at w) and presses with K f(delta):

    paper  (law 0):  f(delta) = delta / (1 - delta),  G(delta) = -delta - ln(1 - delta)
    linear (law 1):  f(delta) = delta,                G(delta) = delta^2 / 2

for 0 < delta < 1 (f = 0 where delta <= 0), G the stored energy density, E_layer =
mirror K he int G(delta) dx. The layer has bottomed out where delta reaches 1 (the gap between
body and ice closes; the paper's f has its pole there, the linear layer is fully compressed):
the run ends there for both laws. A viscoelastic layer (tau > 0) presses with
K f max(1 + tau delta', 0) where compressed.

Forcing (the paper's quadrature, :mod:`solver.model.basis`): f linear between the nodes, continued
by f(delta) = delta for delta <= 0 (C1 at 0: f'(0) = 1 for both laws) and cut at its zero, so the
forcing is C1 in the state:

    P_n = coef_n K int f(delta) cos(lambda_n x) dx,   F = mirror K int f(delta) dx.

Both laws are checked against closed forms on ice that does not move, the layer compressed by
d = V t over the half-width a = sqrt(2 R d) (tests/test_layer_law.py):

    linear: F = (4/3) (K/he) d a;   paper: F = K [(2/sqrt(A B)) arctan(a sqrt(B/A)) - 2a],
    A = 1 - d/he, B = 1/(2 R he).
"""
import math
from collections import namedtuple

import numpy as np

from .basis import add_segment, modal_projection, modal_sum, modal_sum_strain, node_strain
from .floe import TABLE_HAT, Segment, floe_plane, floe_segment
from .contact import contact_bound
from ..compile.jit import kernel
from .law import law_energy, law_pressure
from .quadrature import gauss_energy, gauss_reaction
from .plate import COEF, STRAIN, Modes

#: the layer: he [m], K [Pa], tau = layer_tau [s] (0: elastic), law (LAW_CODES)
Layer = namedtuple("Layer", "he K tau law")
#: where the layer's reaction goes: fvals (J,) the nodes' f (the Gauss rule leaves he int G dx in
#: fvals[0]), P (N,) the forcing
ReactionOut = namedtuple("ReactionOut", "fvals P")

#: layer_law -> the kernels' code
LAW_CODES = {"paper": 0, "linear": 1}


@kernel
def layer_forcing(model, t, a, delta, fvals, P):
    """layer_forcing_at for the body at the paper's constant speed (penetration s = V t) and the
    paper's elastic layer: (status, force, jmax)."""
    V = model.body.V
    st, force, jmax, _ = layer_forcing_at(model, V * t, V, a, a, delta, fvals, P)
    return st, force, jmax


@kernel(inline="always")
def layer_forcing_at(model, s, U, a, adot, delta, fvals, P):
    """Modal forcing P_n(s, a) and body force F from the layer reaction, the body's lowest point
    at y = he - s (penetration s: V t for the paper's body).

    Parameters
    ----------
    model : the Model tuple (solver.model.assemble).  s : penetration of the body [m].
    U : the body's downward speed [m s-1].  a, adot : modal amplitudes a_n [m] and a_n' [m s-1]
    (adot is read only by a viscoelastic layer).  delta, fvals : work arrays (J,) receiving
    delta and f at the nodes j < jmax.  P : output (N,), the forcing P_n [m s-2].

    Returns
    -------
    status : 0, or 1 if some node has delta >= 1 (P is then meaningless).
    force : F(t) [N m-1].
    jmax : nodes j >= jmax cannot be in contact (delta < 0 there); delta, fvals are set below it.
    power : the power the viscoelastic layer dissipates [W m-1] (0 for the elastic layer).
    """
    if model.layer.K == 0.0:         # layer switched off (kernel-level tests): no contact at all
        for n in range(P.shape[0]):
            P[n] = 0.0
        return 0, 0.0, 0, 0.0
    jmax = contact_bound(model.body, model.basis, s, a, delta)
    modal_sum(a, model.basis.cosq, delta, jmax)
    st, force, jmax, power = layer_reaction(model.layer, model.body, model.basis, s, U, Modes(a, adot), jmax, delta,
                                            ReactionOut(fvals, P), np.bool_(False))
    return _scaled(model.layer.K, model.basis.mirror, model.plate.modes[COEF], st, force, jmax, power, P)


@kernel(inline="always")
def layer_forcing_strain(model, s, U, a, adot, delta, fvals, P, eps):
    """layer_forcing_at, and the strain at every node into eps (strain_nodes), from one pass over
    the table where both are needed; the contact-resolving rule also leaves the layer's energy
    in fvals[0] (rule_energy)."""
    cosq = model.basis.cosq
    if model.layer.K == 0.0:
        node_strain(model.basis.cosq, model.basis.floe, model.plate.modes[STRAIN], a, eps)
        for n in range(P.shape[0]):
            P[n] = 0.0
        return 0, 0.0, 0, 0.0
    jmax = contact_bound(model.body, model.basis, s, a, delta)
    if model.basis.kind == 0.0:
        modal_sum_strain(a, model.plate.modes[STRAIN], cosq, delta, eps, jmax)
    else:                            # a floe's wet modes: the strain from its own table
        modal_sum(a, cosq, delta, jmax)
        node_strain(model.basis.cosq, model.basis.floe, model.plate.modes[STRAIN], a, eps)
    st, force, jmax, power = layer_reaction(model.layer, model.body, model.basis, s, U, Modes(a, adot), jmax, delta,
                                            ReactionOut(fvals, P), np.bool_(True))
    return _scaled(model.layer.K, model.basis.mirror, model.plate.modes[COEF], st, force, jmax, power, P)


@kernel(inline="always")
def rule_energy(model, fvals):
    """E_layer [J m-1] at the state of the last layer_forcing_strain, by the contact-resolving
    rule, which leaves he int G dx there in fvals[0] (the paper's rule: NaN; layer_energy
    computes its energy from delta)."""
    if model.basis.rule != 1:
        return math.nan
    if model.layer.K == 0.0:
        return 0.0
    return model.basis.mirror * model.layer.K * fvals[0]


@kernel(inline="always")
def _scaled(K, mirror, coef, st, force, jmax, power, P):
    """layer_reaction's result (st, force, jmax, power) with P scaled by K coef_n (the modes' -2 K
    / (L M_n)), where it succeeded; the force times mirror K. (Scalars and the one array it
    reads: binding a Model to a name counts a reference to each of its arrays.)"""
    if st != 0:
        return st, force, jmax, power
    for n in range(P.shape[0]):
        P[n] *= K * coef[n]
    return 0, mirror * K * force, jmax, power


@kernel
def node_reaction(layer, body, basis, s, U, adot, jmax, delta, fvals):
    """delta and f at the nodes j < jmax, given the deflection sum_n a_n cos(lambda_n x_j) in
    delta (with the viscoelastic layer's part, layer_damping): (status, sum of f, jc, power), jc
    the first node beyond which none is compressed; status 1 if a node has delta >= 1."""
    he = layer.he
    law = layer.law
    profile = body.profile
    total = 0.0
    jc = 0                           # nodes j >= jc are not compressed
    for j in range(jmax):
        d = (delta[j] + s - profile[j]) / he
        delta[j] = d
        f = 0.0
        if d > 0.0:
            if not d < 1.0:          # also catches NaN
                return 1, 0.0, jc, 0.0
            f = law_pressure(law, d)
            jc = j + 1
        fvals[j] = f
        total += f
    power = 0.0
    if layer.tau > 0.0 and jc > 0:
        total, power = layer_damping(layer, basis, U, adot, jmax, jc, delta, fvals)
    return 0, total, jc, power


@kernel(nrt=True)
def layer_damping(layer, basis, U, adot, jmax, jc, delta, fvals):
    """The viscoelastic layer (tau_l = layer.tau > 0): at each compressed node f becomes
    f max(1 + tau_l delta', 0), delta' = (w' + U) / he, w' = sum_n adot_n cos(lambda_n x_j) (one
    more pass over the table, on the compressed nodes only). The damping is proportional to the
    elastic reaction (Hunt-Crossley), so the pressure stays continuous as a node enters contact,
    as the forcing's C1 continuation needs; the layer never pulls. Returns the new sum of fvals over
    j < jmax (layer_reaction's force before its end weights) and the power the damping part
    dissipates, 2 K sum_j w_j (p_d / K) he delta' [W m-1], each node weighted by the length the
    force's quadrature gives it (dx/2 on each side towards a compressed neighbour, the compressed
    part of a split subinterval towards an uncompressed one, nothing beyond x = 0 and x = L), so
    that a contact patch narrower than dx is not over-counted."""
    J = delta.shape[0]
    tau_l = layer.tau
    he = layer.he
    wdot = np.empty(jc)
    modal_sum(adot, basis.cosq, wdot, jc)
    power = 0.0
    for j in range(jc):
        if delta[j] > 0.0:
            rate = (wdot[j] + U) / he
            f = fvals[j]
            g = f * max(1.0 + tau_l * rate, 0.0)
            fvals[j] = g
            weight = 0.0
            if j > 0:
                dl = delta[j - 1]
                weight += 0.5 if dl > 0.0 else 0.5 * g / (g - dl) if g > 0.0 else 0.0
            if j < J - 1:
                dr = delta[j + 1] if j + 1 < jmax else -1.0
                weight += 0.5 if dr > 0.0 else 0.5 * g / (g - dr) if g > 0.0 else 0.0
            power += weight * (g - f) * he * rate
    force = 0.0
    for j in range(jmax):
        force += fvals[j]
    return force, basis.mirror * layer.K * basis.dx * power


@kernel(nrt=True)
def layer_reaction(layer, body, basis, s, U, modes, jmax, delta, out, energy):
    """The rest of layer_forcing_at, given the deflection sum_n a_n cos(lambda_n x_j) in delta
    (j < jmax) and the Modes, into the ReactionOut: P / (K coef_n) and int f dx by the basis's
    rule. The paper's (rule 0): the nodes' f (node_reaction), the hat weights on the
    nodes (the trapezoid's half weights at x = 0 and at the far end), and the split
    subintervals. The contact-resolving rule (1): delta at the nodes, then
    solver.model.quadrature, and with energy, he int G dx into fvals[0]. (The Body, Basis and
    Layer it reads, not the Model: see contact.py.)"""
    if basis.rule == 1:
        return _gauss_reaction(layer, body, basis, s, U, modes, jmax, delta, out, energy)
    adot = modes.adot
    fvals, P = out.fvals, out.P
    N = P.shape[0]
    J = delta.shape[0]
    cosq = basis.cosq
    wq = basis.wq
    st, force, jc, power = node_reaction(layer, body, basis, s, U, adot, jmax, delta, fvals)
    if st != 0:
        return 1, 0.0, jmax, 0.0
    if jc > 0 and basis.kind != 0.0:         # a floe's wet modes: their own hat weights
        modal_projection(fvals, floe_plane(basis.floe, N, J, TABLE_HAT), P, jc)
        force -= 0.5 * fvals[0] + (0.5 * fvals[J - 1] if jc == J else 0.0)
    elif jc > 0:
        modal_projection(fvals, cosq, P, jc)
        f0 = 0.5 * fvals[0]          # trapezoid ends: half weight at x = 0 and x = L
        force -= f0
        for n in range(N):
            P[n] -= f0 * cosq[n, 0]
        if jc == J:
            f1 = 0.5 * fvals[J - 1]
            force -= f1
            for n in range(N):
                P[n] -= f1 * cosq[n, J - 1]
        for n in range(N):
            P[n] *= wq[n]
    else:
        for n in range(N):
            P[n] = 0.0
    return 0, split_segments(basis, jmax, delta, fvals, P, force * basis.dx), jmax, power


@kernel
def _gauss_reaction(layer, body, basis, s, U, modes, jmax, delta, out, energy):
    """layer_reaction by the contact-resolving rule: delta at the nodes j < jmax (status 1 if
    one has delta >= 1), then gauss_reaction into the ReactionOut, he int G dx into fvals[0]
    if energy: (status, int f dx, jmax, the power with its factor mirror K), as the paper's rule
    returns them."""
    fvals, P = out.fvals, out.P
    he = layer.he
    profile = body.profile
    for j in range(jmax):
        d = (delta[j] + s - profile[j]) / he
        delta[j] = d
        if d > 0.0 and not d < 1.0:
            return 1, 0.0, jmax, 0.0
    st, force, power, stored = gauss_reaction(layer, body, basis, s, U, modes, jmax, delta, P, energy)
    if st != 0:
        return 1, 0.0, jmax, 0.0
    if energy:
        fvals[0] = stored
    return 0, force, jmax, basis.mirror * layer.K * power


@kernel
def split_segments(basis, jmax, delta, fvals, P, force):
    """Subintervals where delta changes sign: f is continued by f(delta) = delta for delta <= 0
    (C1 at 0, since f'(0) = 1), interpolated linearly, and only its positive part kept; the split
    point xs then moves smoothly and P stays C1 when a node changes sign. Corrects P (the hat
    weights' projection) and returns force (int f dx so far) corrected."""
    dx = basis.dx
    for j in range(jmax - 1):
        d0 = delta[j]
        d1 = delta[j + 1]
        if (d0 > 0.0) != (d1 > 0.0):
            x0 = j * dx
            x1 = x0 + dx
            if d0 > 0.0:
                f0 = fvals[j]
                xs = x0 + dx * f0 / (f0 - d1)
                _segment(P, basis, j, Segment(x0, x1, f0, 0.0), -1.0)
                _segment(P, basis, j, Segment(x0, xs, f0, 0.0), 1.0)
                force += 0.5 * f0 * (xs - x0 - dx)
            else:
                f1 = fvals[j + 1]
                xs = x0 + dx * (-d0) / (f1 - d0)
                _segment(P, basis, j, Segment(x0, x1, 0.0, f1), -1.0)
                _segment(P, basis, j, Segment(xs, x1, 0.0, f1), 1.0)
                force += 0.5 * f1 * (x1 - xs - dx)
    return force


@kernel(inline="always")
def _segment(P, basis, j, segment, sign):
    """P_n += sign * int g(x) mode_n(x) dx over the Segment in the subinterval j, g linear from
    ga to gb: exact on the cosines (add_segment), by the quintic Hermite of the modes on a floe
    (solver.model.floe.floe_segment)."""
    if basis.kind == 0.0:
        add_segment(P, basis.lam1, segment.alpha, segment.beta, segment.ga, segment.gb, sign)
    else:
        floe_segment(P, basis.cosq, basis.floe, basis.dx, j, segment, sign)


@kernel
def layer_energy(model, a, s, delta, jmax):
    """E_layer = 2 K he int_0^L G(delta) dx (delta > 0); on the full plate of an off-centre
    impact (mirror = 1) K he int_0^2L G dx; delta at the nodes j < jmax, the modes a and the
    body's penetration s (read by the contact-resolving rule only).

    By the forcing's rule. The paper's: trapezoid on the nodes; on a subinterval where delta
    changes sign, G is taken linear from 0 at the split point of the forcing quadrature to the
    compressed node. The contact-resolving rule: its Gauss nodes on the contact intervals
    (solver.model.quadrature.gauss_energy).
    """
    if model.basis.rule == 1:
        return model.basis.mirror * model.layer.K * gauss_energy(model.layer, model.body, model.basis, s, a, delta,
                                                                  jmax)
    return node_energy(model, delta, jmax)


@kernel
def node_energy(model, delta, jmax):
    """E_layer by the paper's rule from delta at the nodes j < jmax (layer_energy)."""
    J = delta.shape[0]
    dx = model.basis.dx
    law = model.layer.law
    total = 0.0
    for j in range(jmax):
        d = delta[j]
        if d > 0.0:
            G = law_energy(law, d)
            wl = 0.5 * dx if j > 0 else 0.0
            wr = 0.5 * dx if j < J - 1 else 0.0
            f = law_pressure(law, d)
            if j > 0 and not delta[j - 1] > 0.0:
                wl = 0.5 * dx * f / (f - delta[j - 1])
            if j < J - 1 and j + 1 < jmax and not delta[j + 1] > 0.0:
                wr = 0.5 * dx * f / (f - delta[j + 1])
            total += (wl + wr) * G
    return model.basis.mirror * model.layer.K * model.layer.he * total


def pressure_at(model, delta, rate, theta, j):
    """K f at points between the nodes j and j + 1 (theta in [0, 1] along the subinterval), from
    delta and its rate d(delta)/dt at every node (numpy arrays): f linear between the nodes, a
    split subinterval continued by delta as the forcing has it. The reaction the modes feel
    (the field reconstruction of solver.core; plain numpy, the same law_pressure)."""
    compressed = delta > 0
    f = np.where(compressed, law_pressure.py_func(model.layer.law, np.where(compressed, delta, 0.0)), 0.0)
    if model.layer.tau > 0:
        f = np.where(compressed, f * np.maximum(1.0 + model.layer.tau * rate, 0.0), 0.0)
    d0, d1 = delta[j], delta[j + 1]
    f0, f1 = f[j], f[j + 1]
    out = np.where((d0 > 0) & (d1 > 0), f0 + theta * (f1 - f0), 0.0)
    g0 = np.where(d0 > 0, f0, d0)
    g1 = np.where(d1 > 0, f1, d1)
    out = np.where((d0 > 0) != (d1 > 0), np.maximum(g0 + theta * (g1 - g0), 0.0), out)
    return model.layer.K * out
