r"""A free body's stop and separation inside an accepted step (docs/model.md, "A body of finite
mass"): the zeros of its speed U from the cubic Hermite of U (U' = g_b - F / M at the step's
ends), the deepest penetration at a stop, and the time and speed at which it leaves the ice.

Benchmark (tests/test_body_mass.py, test_free_flight_is_exact and
test_ends_separated_stopped_and_ok): a body in free flight follows its parabola to round-off,
and the run ends separated, stopped or ok as its motion says.
"""
import math

import numpy as np

from ..cubic import cubic, cubic_sign_changes, hermite
from ..compile.jit import kernel
from ..layout import D_MAX_PENETRATION, D_SEPARATION_SPEED, D_SEPARATION_T, D_STOP_T
from ..model.body import body_accel, body_position, body_speed


@kernel(nrt=True)
def observe_body(body, t, h, yb0, yb1, F0, F1, contacts, record, diag):
    """A free body's ends within the step [t, t + h] (the body at yb0, yb1, the force F0, F1 at
    its ends): its stops, the deepest penetration taken there, and its separation: no contact at
    t + h while moving up after having stopped, at the last time the contact record (its Rows)
    went to 0 (located by observe_contacts). Returns True at the first separation."""
    if body.inv_mass == 0.0:
        return False
    U0 = body_speed(body, yb0)
    U1 = body_speed(body, yb1)
    c0, c1, c2, c3 = hermite(U0, U1, -body_accel(body, F0), -body_accel(body, F1), h)
    roots = np.empty(3)
    k = cubic_sign_changes(c0, c1, c2, c3, roots)
    for i in range(k):
        th = roots[i]
        if cubic(c0, c1, c2, c3, th + 1e-9) > 0.0:
            continue                                    # U rising through 0: not a stop
        q0, q1, q2, q3 = hermite(body_position(body, t, yb0), body_position(body, t + h, yb1), U0, U1, h)
        depth = cubic(q0, q1, q2, q3, th)
        if math.isnan(diag[D_STOP_T]):
            diag[D_STOP_T] = t + th * h
        if not depth <= diag[D_MAX_PENETRATION]:        # also when NaN (the first stop)
            diag[D_MAX_PENETRATION] = depth
    if math.isnan(diag[D_STOP_T]) or not math.isnan(diag[D_SEPARATION_T]):
        return False
    if contacts != 0 or not U1 < 0.0:
        return False
    rec_c, n_c = record.rows, record.n
    t_sep = t + h
    if n_c > 0 and rec_c[n_c - 1, 1] == 0.0:
        t_sep = min(max(rec_c[n_c - 1, 0], diag[D_STOP_T]), t + h)
    th = min(max((t_sep - t) / h, 0.0), 1.0)
    diag[D_SEPARATION_T] = t_sep
    diag[D_SEPARATION_SPEED] = -cubic(c0, c1, c2, c3, th)
    return True
