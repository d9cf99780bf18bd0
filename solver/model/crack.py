r"""A crack that opens over a time (docs/model.md, "A crack that opens over a time"): the kernels'
part of it.

A crack does not cross the ice at once: its front runs through the thickness at ``crack_speed``,
taking tau = hi / crack_speed. While it opens, the faces of a break still carry the moment M and
shear V the whole plate carried there at the break, released linearly to zero over tau:
r(t) = max(0, 1 - (t - t_b) / tau). On the wet modes that is a forcing of known shape,

    a_k'' + omega_k^2 a_k = P_k(layer) + r(t) G_k,

G_k the faces' generalised force on mode k over its generalised mass (crack_loads:
-M psi'(b+) + V psi(b+) on the face above the break, M psi'(b-) - V psi(b-) on the one below). The
work these loads do on the plate, sum_k m_k r G_k a_k' dt, is the fracture's: it enters the
energy identity as dissipated energy (the plate's damping's place), so E_plate + E_layer + D = W
holds with D the damping's and the cracks' together.

Benchmark (tests/test_crack_opening.py): the forcing at the break is the force the unbroken plate
carried there (the carried state's acceleration continuous), the energy identity through opening
cracks, and the breakthrough against the finite elements' with the same opening time.
"""
from collections import namedtuple

import numpy as np

from ..compile.jit import kernel
from .parts import raw_mode
from .plate import MASS, mode_a, mode_adot

#: the cracks still opening on the kernel's modes: loads (C, N) each crack's G_k [m s-2 per unit
#: amplitude's mass], starts (C,) its break time [s], opening tau [s] (C = 0: none, every crack
#: open; the paper's plate and every run that does not break)
Cracks = namedtuple("Cracks", "loads starts opening")


def no_cracks(N: int) -> Cracks:
    """Cracks for N modes with none opening."""
    return Cracks(np.zeros((0, N)), np.zeros(0), np.inf)


@kernel(inline="always")
def release(cracks, c, t):
    """The share of crack c's load its faces still carry at t: 1 - (t - t_b) / tau in [0, 1]."""
    return min(max(1.0 - (t - cracks.starts[c]) / cracks.opening, 0.0), 1.0)


@kernel
def add_crack_forcing(cracks, t, P):
    """P_k += r_c(t) G_ck over the cracks still opening at t."""
    for c in range(cracks.loads.shape[0]):
        r = release(cracks, c, t)
        if r > 0.0:
            for n in range(P.shape[0]):
                P[n] += r * cracks.loads[c, n]


@kernel
def crack_power(cracks, t, z, plate):
    """sum_c r_c(t) sum_k m_k G_ck a_k' [W m-1]: the power the opening cracks' faces put into the
    plate at the modal state z (negative while they take the fracture's energy from it)."""
    p = 0.0
    for c in range(cracks.loads.shape[0]):
        r = release(cracks, c, t)
        if r > 0.0:
            for n in range(z.shape[0]):
                g = cracks.loads[c, n]
                if g != 0.0:
                    a = mode_a(z[n], n, plate)
                    p += r * g * plate.modes[MASS, n] * mode_adot(z[n], a, n, plate)
    return p


@kernel
def opening(cracks):
    """Whether any crack is still to open (the run then takes their power, crack_power)."""
    return cracks.loads.shape[0] > 0


def crack_loads(p, tables: dict, cracks, full: bool) -> np.ndarray:
    """(C, N): each opening crack's forcing G_ck [m s-2] on the kernel's modes of the broken plate
    of these tables (parts_tables; solver.model.crack): its faces' generalised force, -M psi'(b) +
    V psi(b) on the part above the break b and M psi'(b) - V psi(b) on the part below (M = D w_xx,
    V = D w_xxx the ice carried there: a solver.spec.Crack, b in kernel coordinates), over each
    mode's generalised mass; on the half plate each face stands for its mirror too."""
    modes, Qs, mass = tables["wet"].modes, tables["Q"], tables["mass"]
    out = np.zeros((len(cracks), Qs.shape[1]))
    for c, crack in enumerate(cracks):
        force = np.zeros(modes.kinds.size)
        for m in range(modes.kinds.size):
            for face, sign in ((modes.lows[m], 1.0), (modes.highs[m], -1.0)):
                if face == crack.x:
                    shape = (modes.kinds[m], modes.betas[m], modes.centres[m], modes.halves[m], crack.x)
                    value, slope = (modes.norms[m] * float(raw_mode(*shape, order)) for order in (0, 1))
                    force[m] += sign * (crack.shear * value - crack.moment * slope)
        out[c] = (1.0 if full else 2.0) * (Qs.T @ force) / mass
    return out
