r"""The contact intervals: every change of their number inside an accepted step (docs/model.md,
"Events": contacts).

delta at a node near the contact boundary is interpolated by the cubic Hermite of its end values
and rates, delta_t = (w_t + U) / he; every sign change is an event, applied in time order to the
sign pattern, which is recounted. An interval that opens and closes within the step is seen too.
Under the contact-resolving quadrature (Basis.rule 1, whose table is coarse) a change of the count
is placed where the continuous delta's extremum between the node's neighbours crosses 0, not
where the node does (_between_nodes): an interval is born, dies, merges or splits between nodes.

Benchmark (tests/test_events.py, test_short_lived_contact_interval_is_counted and
test_contact_changes_are_placed_on_the_continuous_plate; and tests/test_kernel_pieces.py): an
interval shorter than a step is counted, the default's 250-node record agrees with a 4000-node one,
and the observer on the nodes bounded by reach_in_step equals the observer on every node.
"""
import math
from collections import namedtuple

import numpy as np

from ..cubic import cubic, cubic_sign_changes, hermite
from ..compile.jit import kernel
from ..model.basis import modal_sum_range, refine
from ..model.body import body_position, body_speed
from ..model.contact import count_contacts, node_deltas, reach_in_step
from .record import Rows, append_row

#: candidate nodes at most this far apart share one pass over the table rows (observe_contacts)
RUN_GAP = 4

#: the contact observer's scratch: sgn (J,), the events' times ev_th and nodes ev_j (4 J + 16,),
#: near (4, J): delta and its rate at both ends of the step on an event's node and neighbours
ContactWork = namedtuple("ContactWork", "sgn ev_th ev_j near")
#: what the contact observer reads of a state at one end of a step (the arrays, not the State:
#: numba counts a reference to every array of a tuple at each binding)
Snapshot = namedtuple("Snapshot", "a adot delta yb")


@kernel(nrt=True)
def contact_work(J):
    """A ContactWork for J nodes (allocated once per run)."""
    return ContactWork(np.empty(J), np.empty(4 * J + 16), np.empty(4 * J + 16), np.empty((4, J)))


@kernel(nrt=True)
def _extremum(near, rates, he, h, j, th):
    """The extremum over x of the parabola through delta at nodes j - 1, j, j + 1 at th
    (basis.refine; each node's delta the cubic Hermite of its ends near[0:2] and rates near[2:4]
    + the body's speed rates (U0, U1), over he), and delta's rate there: (value, rate, whether
    the neighbours share a sign: only then is the extremum within half a node of j)."""
    d = np.empty(3)
    r = np.empty(3)
    for k in range(3):
        i = j - 1 + k
        c0, c1, c2, c3 = hermite(near[0, i], near[1, i], (near[2, i] + rates[0]) / he, (near[3, i] + rates[1]) / he, h)
        d[k] = cubic(c0, c1, c2, c3, th)
        r[k] = (c1 + th * (2.0 * c2 + 3.0 * th * c3)) / h
    curv = d[0] - 2.0 * d[1] + d[2]
    if (d[0] > 0.0) != (d[2] > 0.0) or curv == 0.0:
        return d[1], r[1], False
    sign = 1.0 if curv < 0.0 else -1.0                 # a peak, or a dip
    value, x = refine(d, sign, 1, 3, 1.0)
    off = x - 1.0
    rate = r[1] + 0.5 * off * (r[2] - r[0]) + 0.5 * off * off * (r[0] - 2.0 * r[1] + r[2])
    return sign * value, rate, True


@kernel(nrt=True)
def _between_nodes(model, near, t0, h, end0, end1, j, th):
    """The time at which the count changes on the continuous plate, for a change found at node j
    at th (fraction of the step [t0, t0 + h]): where the extremum of delta between j's neighbours
    (_extremum) crosses 0, by Newton in time on the step's Hermites, linear beyond the step.
    Where the count changes at a node its neighbours share a sign (the node is an interval or a
    gap of its own): the extremum is a peak (birth, death) or a dip (merge, split). The node's
    time is kept on an end node (the symmetry line's peak is its node; a wall's node has one
    neighbour) and where the neighbours differ in sign. A death may be placed up to a step after
    t0 + h (the interval outlives the nodes; the run's adapter keeps the record within the run)."""
    J = model.basis.cosq.shape[1]
    if j <= 0 or j >= J - 1:
        return t0 + th * h
    a0, adot0, yb0 = end0.a, end0.adot, end0.yb
    a1, adot1, yb1 = end1.a, end1.adot, end1.yb
    body, he, cosq = model.body, model.layer.he, model.basis.cosq
    node_deltas(he, body, model.basis, a0, body_position(body, t0, yb0), near[0], j - 1, j + 2)
    node_deltas(he, body, model.basis, a1, body_position(body, t0 + h, yb1), near[1], j - 1, j + 2)
    modal_sum_range(adot0, cosq, near[2], j - 1, j + 2)
    modal_sum_range(adot1, cosq, near[3], j - 1, j + 2)
    rates = np.array([body_speed(body, yb0), body_speed(body, yb1)])
    s = th
    for _ in range(6):
        value, rate, valid = _extremum(near, rates, he, h, j, s)
        if not valid or rate == 0.0:
            return t0 + s * h
        step = -value / (rate * h)
        if not math.isfinite(step):
            return t0 + th * h
        s_new = s + step
        if s_new < 0.0 or s_new > 1.0 or abs(step) < 1e-12:
            return t0 + min(s_new, 2.0) * h        # beyond the step: linear from inside it
        s = s_new
    return t0 + s * h


@kernel(inline="llvm", nrt=True)
def _candidates(model, t0, h, end0, jm0, end1, jm1, speed, sgn):
    """The nodes whose delta may change sign in the step (the others cannot reach 0 at |delta'|
    <= speed), tested also beyond both ends' computed ranges jm0, jm1 (reach_in_step; the ends'
    delta are filled up to that range): (candidate nodes, their count, the range jm)."""
    a0, delta0, yb0 = end0.a, end0.delta, end0.yb
    a1, delta1, yb1 = end1.a, end1.delta, end1.yb
    body = model.body
    he = model.layer.he
    S0, S1 = body_position(body, t0, yb0), body_position(body, t0 + h, yb1)
    jm = reach_in_step(body, model.basis, max(jm0, jm1), a0, a1, S0, S1, 0.5 * speed * h * he, sgn)
    node_deltas(he, body, model.basis, a0, S0, delta0, jm0, jm)     # nodes outside an end's computed range
    node_deltas(he, body, model.basis, a1, S1, delta1, jm1, jm)
    cand = np.empty(jm, dtype=np.int64)
    nc = 0
    for j in range(jm):
        d0 = delta0[j]
        d1 = delta1[j]
        sgn[j] = 1.0 if d0 > 0.0 else -1.0
        mid = 0.5 * (d0 + d1)
        if (d0 > 0.0) == (d1 > 0.0):
            if d0 > 0.0 and mid - 0.5 * speed * h > 0.0:
                continue
            if not d0 > 0.0 and mid + 0.5 * speed * h <= 0.0:
                continue
        cand[nc] = j
        nc += 1
    return cand, nc, jm


@kernel(inline="llvm", nrt=True)
def _sign_changes(model, cw, h, end0, end1, cand, nc, jm):
    """The candidates' sign changes inside the step, sorted by time into cw.ev_th (fraction of the
    step) and cw.ev_j (node): their end rates from passes over the table rows on runs of
    candidate nodes. Returns the number of events."""
    adot0, delta0, yb0 = end0.adot, end0.delta, end0.yb
    adot1, delta1, yb1 = end1.adot, end1.delta, end1.yb
    he = model.layer.he
    cosq = model.basis.cosq
    U0, U1 = body_speed(model.body, yb0), body_speed(model.body, yb1)
    ev_th, ev_j = cw.ev_th, cw.ev_j
    rate0 = np.empty(jm)
    rate1 = np.empty(jm)
    i = 0
    while i < nc:
        lo = cand[i]
        while i + 1 < nc and cand[i + 1] <= cand[i] + RUN_GAP:
            i += 1
        hi = cand[i] + 1
        modal_sum_range(adot0, cosq, rate0, lo, hi)
        modal_sum_range(adot1, cosq, rate1, lo, hi)
        i += 1
    n_ev = 0
    roots = np.empty(3)
    for i in range(nc):
        j = cand[i]
        c0, c1, c2, c3 = hermite(delta0[j], delta1[j], (rate0[j] + U0) / he, (rate1[j] + U1) / he, h)
        k = cubic_sign_changes(c0, c1, c2, c3, roots)
        for r in range(k):
            if n_ev < ev_th.shape[0]:
                ev_th[n_ev] = roots[r]
                ev_j[n_ev] = j
                n_ev += 1
    for i in range(1, n_ev):            # insertion sort by time
        th = ev_th[i]
        jj = ev_j[i]
        m = i - 1
        while m >= 0 and ev_th[m] > th:
            ev_th[m + 1] = ev_th[m]
            ev_j[m + 1] = ev_j[m]
            m -= 1
        ev_th[m + 1] = th
        ev_j[m + 1] = jj
    return n_ev


@kernel(inline="llvm", nrt=True)
def observe_contacts(model, cw, t0, h, end0, jm0, end1, jm1, contacts, record):
    """Changes of the number of contact intervals inside the step [t0, t0 + h], between its two
    states, each a Snapshot, their nodes computed up to jm0, jm1; record: the Rows (t, count after
    the change). Returns (contacts at t1, the record, largest count in the step)."""
    rec, n = record.rows, record.n
    adot0, yb0 = end0.adot, end0.yb
    adot1, delta1, yb1 = end1.adot, end1.delta, end1.yb
    he = model.layer.he
    U0, U1 = body_speed(model.body, yb0), body_speed(model.body, yb1)
    Ub = max(abs(U0), abs(U1))
    if model.body.inv_mass > 0.0:
        Ub *= 2.0                       # a free body's speed may swing between the step's ends
    r0 = 0.0
    r1 = 0.0
    for k in range(adot0.shape[0]):
        r0 += abs(adot0[k])
        r1 += abs(adot1[k])
    speed = (2.0 * max(r0, r1) + Ub) / he   # a bound on |d delta / dt| within the step
    cand, nc, jm = _candidates(model, t0, h, end0, jm0, end1, jm1, speed, cw.sgn)
    n_ev = _sign_changes(model, cw, h, end0, end1, cand, nc, jm)
    largest = contacts
    if n_ev == 0:
        return contacts, Rows(rec, n), largest
    mirror = model.basis.mirror
    for i in range(n_ev):
        j = int(cw.ev_j[i])
        cw.sgn[j] = -cw.sgn[j]
        c = count_contacts(cw.sgn, jm, mirror)
        if c != contacts:
            t_ev = t0 + cw.ev_th[i] * h
            if model.basis.rule == 1:
                t_ev = _between_nodes(model, cw.near, t0, h, end0, end1, j, cw.ev_th[i])
                if n > 0:
                    t_ev = max(t_ev, rec[n - 1, 0])      # the record stays in time order
            rec, n = append_row(rec, n, t_ev, float(c), 0.0, 0.0, 0.0)
            contacts = c
            if c > largest:
                largest = c
    final = count_contacts(delta1, jm, mirror)
    if final != contacts:               # the end pattern is exact: it wins
        rec, n = append_row(rec, n, t0 + h, float(final), 0.0, 0.0, 0.0)
        contacts = final
        if final > largest:
            largest = final
    return contacts, Rows(rec, n), largest
