r"""Hermite cubic finite elements of the walled plate, through its breaks: a discretisation that
shares no basis with the solver's (docs/model.md, "An independent check through a break").

The half plate 0 <= x <= L of a centred impact: x = 0 is the symmetry plane (sliding, w' = 0,
until the plate breaks there) and x = L the wall (sliding). Each node carries w and w'; on an
element w is their cubic Hermite interpolant, so the plate's m, D and rho_w g give the consistent
mass, bending and buoyancy matrices. The water is the channel's (docs/model.md, "Equations"): a
symmetric w = sum_k w_k cos(mu_k x), mu_k = k pi / L, has the kinetic energy
rho_w (L / 2) sum_k coth(mu_k H) / mu_k (dw_k/dt)^2 / 2 on the half plate, and int w dx = 0 (a
Lagrange multiplier). A shape function's w_k = (2 / L) int N cos(mu_k x) dx is exact: a cubic's
integral against a cosine is its boundary terms,

    int_a^b p cos(mu x) dx = [p sin / mu + p' cos / mu^2 - p'' sin / mu^3 - p''' cos / mu^4]_a^b,

summed to TERMS cosines; where w jumps (at a break) the rest of the series is added with
sin^2 at its mean 1/2 (its terms fall as mu^-3). The layer's pressure K f(delta) is integrated
by Gauss-Legendre on each element, split where delta changes sign. Time (``scheme``): by default
a step exact for the plate's and the water's linear part (_exponential_step: the elements' wet
modes advanced by cos and sin, the layer's and the cracks' forces linear over the step, second
order in them); or the trapezoidal rule (_step: Newmark's average acceleration, second order,
the linear part's energy kept exactly, but a phase error of order one on the waves with
omega dt > 1, which a break sends out). Each takes the pressure at the step's end by fixed-point
iteration.

A break at a node gives each side its own w and w' there: w'' = w''' = 0 at the new edges is
the energy's natural condition (nothing to impose), and the state carries exactly: w, w_t and
every energy are the same just after the break as just before. The modal solver's carry is a
projection that leaves out part of the energy; this one leaves out none.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh, lu_factor, lu_solve, null_space
from scipy.sparse import csr_matrix
from scipy.special import zeta

#: cosines of the water's series (the rest added for the jumps at breaks)
TERMS = 8192
#: Gauss-Legendre points on each piece of an element in contact
GAUSS_X, GAUSS_W = np.polynomial.legendre.leggauss(8)
#: the exponential step's fixed-point iterations for the layer's force at its end, at most
ITERATIONS = 40

# the Hermite shape functions phi_l(xi) on [0, 1] (w_a, w'_a / h, w_b, w'_b / h): a slope's
# function carries a factor h on an element of length h (the callers multiply it in)


def _shapes(xi):
    """(4, ...) the Hermite shape functions at xi in [0, 1]."""
    return np.array([1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3, 3 * xi**2 - 2 * xi**3, -xi**2 + xi**3])


#: the shape functions' coefficients (rows: the four functions; columns: powers 0 to 3 of xi)
HERMITE = np.array([[1.0, 0.0, -3.0, 2.0], [0.0, 1.0, -2.0, 1.0], [0.0, 0.0, 3.0, -2.0], [0.0, 0.0, -1.0, 1.0]])


def _second(xi):
    """(4, ...) their second derivatives in xi."""
    return np.array([-6 + 12 * xi, -4 + 6 * xi, 6 - 12 * xi, -2 + 6 * xi])


def _ends(h):
    """(2, 4, 4, E): at xi = 0 and 1, each shape function's value and first three x-derivatives
    on elements of length h (E,)."""
    z, o = np.zeros_like(h), np.ones_like(h)
    at0 = [[o, z, -6 / h**2, 12 / h**3], [z, o / h, -4 / h**2, 6 / h**3], [z, z, 6 / h**2, -12 / h**3],
           [z, z, -2 / h**2, 6 / h**3]]
    at1 = [[z, z, 6 / h**2, 12 / h**3], [z, z, 2 / h**2, 6 / h**3], [o, z, -6 / h**2, -12 / h**3],
           [z, o / h, 4 / h**2, 6 / h**3]]
    return np.array([at0, at1])


@dataclass
class Topology:
    """The degrees of freedom: elem (E, 4) the global indices of each element's (w_a, w'_a, w_b,
    w'_b); count; free: the indices not held at zero (w' at a sliding end); jumps: for each break
    inside, the vector of w's jump there (+1 on the left side's w, -1 on the right's)."""
    elem: np.ndarray
    count: int
    free: np.ndarray
    jumps: list


def topology(nodes, broken) -> Topology:
    """The degrees of freedom of the plate on ``nodes`` broken at the node indices ``broken``
    (0: the centre, whose w' is then free)."""
    n = nodes.size
    left = np.empty((n, 2), int)
    right = np.empty((n, 2), int)
    count = 0
    for j in range(n):
        left[j] = (count, count + 1)
        count += 2
        if j in broken and 0 < j < n - 1:
            right[j] = (count, count + 1)
            count += 2
        else:
            right[j] = left[j]
    elem = np.hstack([right[:-1], left[1:]])
    fixed = {left[-1][1]} | (set() if 0 in broken else {left[0][1]})
    free = np.array([i for i in range(count) if i not in fixed])
    jumps = []
    for j in sorted(broken):
        if 0 < j < n - 1:
            v = np.zeros(count)
            v[left[j][0]], v[right[j][0]] = 1.0, -1.0
            jumps.append((j, v))
    return Topology(elem, count, free, jumps)


class Plate:
    """The matrices of the half plate of parameters p (solver.Parameters: the plate, the water,
    the layer, the paper's body) on ``nodes`` [m] broken at the node indices ``broken``."""

    def __init__(self, p, nodes, broken, springs=None):
        beyond = [key for key, value in (("x0", p.x0 != 0.0), ("body_mass", math.isfinite(p.body_mass)),
                                         ("tau", p.tau > 0.0), ("layer_tau", p.layer_tau > 0.0),
                                         ("edges", p.edges != "walls"), ("body_p", p.body_p != 2.0),
                                         ("flat_width", p.flat_width > 0.0), ("deadrise", p.deadrise > 0.0))
                  if value]
        if beyond:
            raise ValueError(f"the finite elements model the walled plate under the paper's body only; not {beyond}")
        self.p, self.x = p, np.asarray(nodes, float)
        self.h = np.diff(self.x)
        self.broken = set(broken)
        self.top = topology(self.x, self.broken)
        E, n = self.h.size, self.top.count
        h = self.h[:, None, None]
        m_e = h / 420 * np.array([[156, 22, 54, -13], [22, 4, 13, -3], [54, 13, 156, -22], [-13, -3, -22, 4]])
        k_e = 1 / h**3 * np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]])
        scale = np.stack([np.ones(E), self.h, np.ones(E), self.h], axis=1)      # slopes' shape functions carry h
        m_e = m_e * scale[:, :, None] * scale[:, None, :]
        k_e = k_e * scale[:, :, None] * scale[:, None, :]
        mass, bend = np.zeros((n, n)), np.zeros((n, n))
        rows = self.top.elem[:, :, None].repeat(4, 2)
        cols = self.top.elem[:, None, :].repeat(4, 1)
        np.add.at(mass, (rows, cols), m_e)
        np.add.at(bend, (rows, cols), k_e)
        self.mass = p.plate_mass * mass + self.added_mass()
        self.stiffness = p.rigidity * bend + p.rho_w * p.g * mass
        # a crack part through the thickness at a broken node j: w continuous there (held) and a
        # rotational spring k [N m rad-1 m-1] between the two sides' slopes (at the centre, between
        # w'(0) and its mirror -w'(0): the half plate's share of k (2 w'(0))^2 / 2)
        self.held = []
        for j, k in (springs or {}).items():
            if j == 0:
                self.stiffness[1, 1] += 2.0 * k
                continue
            jump = next(v for i, v in self.top.jumps if i == j)
            left, right = int(np.flatnonzero(jump > 0)[0]) + 1, int(np.flatnonzero(jump < 0)[0]) + 1
            d = np.zeros(n)
            d[right], d[left] = 1.0, -1.0
            self.stiffness += k * np.outer(d, d)
            self.held.append(jump)
        means = np.zeros(n)                       # int N dx: the constraint int w dx = 0
        np.add.at(means, self.top.elem, self.h[:, None] * np.array([0.5, 1 / 12, 0.5, -1 / 12])[None, :] * scale)
        self.means = means
        self._lu = {}
        self._modes = None
        self.cracks = []           # the opening cracks: (load, break time, opening time), crack_load

    def crack_load(self, t):
        """The generalised forces [N m-1, N] of the cracks still opening at t: each the internal
        force its node carried at the break (its moment and shear), times 1 - (t - t_b) / tau
        until the crack has opened through (breaking_run's opening_time)."""
        out = np.zeros(self.top.count)
        for load, t_b, tau in self.cracks:
            out += load * max(0.0, 1.0 - (t - t_b) / tau)
        return out

    def added_mass(self):
        """The channel's added mass [kg m-1] of the degrees of freedom (module docstring)."""
        p, L, E = self.p, self.p.L, self.h.size
        ends = _ends(self.h)                                               # (2, 4, 4, E)
        scale = np.stack([np.ones(E), self.h, np.ones(E), self.h])           # (4, E)
        spread = csr_matrix((np.ones(4 * E), (self.top.elem.T.ravel(), np.arange(4 * E))), shape=(self.top.count, 4 * E))
        A = np.zeros((self.top.count, self.top.count))
        for first in range(1, TERMS + 1, 1024):
            mu = math.pi * np.arange(first, min(first + 1024, TERMS + 1)) / L
            g = 1.0 / mu if not math.isfinite(p.H) else 1.0 / (mu * np.tanh(mu * p.H))
            B = []
            for side, xs in ((0, self.x[:-1]), (1, self.x[1:])):
                s, c = np.sin(np.outer(xs, mu)), np.cos(np.outer(xs, mu))          # (E, K)
                d = ends[side]                                                  # (4, 4, E)
                B.append(d[:, 0, :, None] * s / mu + d[:, 1, :, None] * c / mu**2 - d[:, 2, :, None] * s / mu**3
                         - d[:, 3, :, None] * c / mu**4)                        # (4, E, K)
            integral = (B[1] - B[0]) * scale[:, :, None]                         # int N cos over the element
            coefficients = (2.0 / L) * (spread @ integral.reshape(4 * E, -1))    # (n, K)
            A += p.rho_w * (L / 2.0) * (coefficients * g) @ coefficients.T
        tail = p.rho_w * (1.0 / L) * (L / math.pi) ** 3 * zeta(3.0, TERMS + 1.0)
        for _, jump in self.top.jumps:
            A += tail * np.outer(jump, jump)
        return A

    def solver(self, dt):
        """The factors of the trapezoidal step's matrix [[M + dt^2 K / 4, -c], [c^T, 0]] on the
        free degrees of freedom (c: int N dx); dt = 0: the mass's, for a consistent acceleration.
        The last few are kept (a run's regular step, and the short ones that end on a stop)."""
        if dt not in self._lu:
            while len(self._lu) >= 4:
                self._lu.pop(next(iter(self._lu)))
            f = self.top.free
            M = self.mass[np.ix_(f, f)] + 0.25 * dt**2 * self.stiffness[np.ix_(f, f)]
            c = self.means[f]
            S = np.block([[M, -c[:, None]], [c[None, :], np.zeros((1, 1))]])
            self._lu[dt] = lu_factor(S)
        return self._lu[dt]

    def modes(self):
        """(B, omega, P): the plate's wet modes on its free degrees of freedom under int w dx = 0,
        q_f = B eta with B^T M B = I and B^T K B = diag(omega^2) [s-2], and P = B^T M (eta = P q_f
        for a q_f that meets the constraint); computed once. One eigensolution K v = omega^2 M v
        gives each omega^2 to about 1e-16 omega_max^2 (4 s-2 at 1 cm, 60 s-2 at 5 mm, where
        omega_max^2 is 4e16 and 6e17 s-2): a short part's heave and pitch (omega^2 ~ 15 s-2) would be
        round-off, and move the force on the body by 1e-7 of itself over 1.5 ms. So the slow modes,
        omega^2 below sqrt(omega_min^2 omega_max^2), come from the inverse problem M v = K v /
        omega^2 (each to about 1e-16 omega^2 omega^2 / omega_min^2), and the fast ones from the
        direct problem on the rest of the space (M-orthogonal to the slow ones): each to about
        1e-8 of itself or better. The degrees of freedom are first scaled to a unit diagonal of the
        mass (w' carries h^2 beside w). What is left is the assembled bending matrix's own
        round-off, about eps D / (rho_w g h^4) of a part's heave stiffness: the heave's omega^2 is
        8.828, 8.828, 8.823 s-2 at 4, 2, 1 cm, and drifts 3 % at 5 mm."""
        if self._modes is None:
            f = self.top.free
            M, K = self.mass[np.ix_(f, f)], self.stiffness[np.ix_(f, f)]
            d = 1.0 / np.sqrt(np.diag(M))
            rows = np.vstack([self.means[f]] + [jump[f] for jump in self.held])
            Z = d[:, None] * null_space(rows * d[None, :])
            Mz, Kz = Z.T @ M @ Z, Z.T @ K @ Z
            inverse, V = eigh(Mz, Kz)                               # (omega^-2 ascending, V^T K V = I)
            inverse, V = inverse[::-1], V[:, ::-1]
            fast2 = eigh(Kz, Mz, eigvals_only=True, subset_by_index=[Kz.shape[0] - 1, Kz.shape[0] - 1])[0]
            slow = int(np.count_nonzero(inverse * math.sqrt(fast2 / (1.0 / inverse[0])) > 1.0))
            Vs = V[:, :slow] / np.sqrt(inverse[:slow])              # (M-orthonormal)
            rest = Vs.T @ Mz
            Q = null_space(rest)                                    # the rest of the space, M-orthogonal to the slow modes
            omega2, Phi = eigh(Q.T @ Kz @ Q, Q.T @ Mz @ Q)
            B = Z @ np.hstack([Vs, Q @ Phi])
            omega2 = np.concatenate([1.0 / inverse[:slow], omega2])
            self._modes = (B, np.sqrt(np.maximum(omega2, 0.0)), B.T @ M)
        return self._modes

    def values(self, q, x):
        """w at x [m] of the degrees of freedom q."""
        x = np.asarray(x, float)
        e = np.clip(np.searchsorted(self.x, x, side="right") - 1, 0, self.h.size - 1)
        h = self.h[e]
        N = _shapes((x - self.x[e]) / h) * np.stack([np.ones_like(h), h, np.ones_like(h), h])
        return np.sum(N * q[self.top.elem[e]].T, axis=0)

    def curvature(self, q, x):
        """w'' at x [m]: nodal_curvature, linear between the nodes (NaN next to a break)."""
        return np.interp(np.asarray(x, float), self.x, self.nodal_curvature(q))

    def nodal_curvature(self, q):
        """w'' at the nodes, each the mean of its two elements' ends (second order where the
        elements' own w'' is first); an end takes its one element's; NaN at a break (each side has
        its own, the edge's, which is 0 only weakly)."""
        E, h = self.h.size, self.h
        local = q[self.top.elem] * np.stack([np.ones(E), h, np.ones(E), h], 1)          # (E, 4)
        ends = np.stack([local @ _second(0.0), local @ _second(1.0)], 1) / h[:, None] ** 2   # (E, 2)
        nodal = np.zeros(E + 1)
        count = np.zeros(E + 1)
        for side, nodes in ((0, np.arange(E)), (1, np.arange(1, E + 1))):
            np.add.at(nodal, nodes, ends[:, side])
            np.add.at(count, nodes, 1.0)
        nodal /= count
        nodal[[j for j, _ in self.top.jumps]] = np.nan
        return nodal

    def layer(self, q, t):
        """(generalised forces -int K f(delta) N dx, F = int_0^L K f dx [N m-1], E_layer [J m-1] on
        the half plate) at the state q at t; the pressure integrated where delta > 0."""
        p = self.p
        xs = np.linspace(0.0, 1.0, 9)
        E = self.h.size
        delta = self._delta(q, t, np.arange(E)[:, None].repeat(xs.size, 1), xs[None, :].repeat(E, 0))   # (E, 9)
        contact = np.flatnonzero(np.any(delta > 0, axis=1))
        forces = np.zeros(self.top.count)
        if contact.size == 0:
            return forces, 0.0, 0.0
        lo, hi = np.zeros(contact.size), np.ones(contact.size)
        d0, d1 = delta[contact, 0], delta[contact, -1]
        cross = (d0 > 0) != (d1 > 0)
        if np.any(cross):                       # the root of delta's cubic in xi, by bisection
            ce = contact[cross]
            c = self._cubic(q, t, ce)
            a, b = np.zeros(ce.size), np.ones(ce.size)
            sign0 = d0[cross] > 0
            for _ in range(60):
                mid = 0.5 * (a + b)
                left_side = ((((c[3] * mid + c[2]) * mid + c[1]) * mid + c[0]) > 0) == sign0
                a, b = np.where(left_side, mid, a), np.where(left_side, b, mid)
            root = 0.5 * (a + b)
            lo[cross] = np.where(sign0, 0.0, root)
            hi[cross] = np.where(sign0, root, 1.0)
        xi = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * GAUSS_X[None, :]      # (C, 8)
        wq = 0.5 * (hi - lo)[:, None] * GAUSS_W[None, :] * self.h[contact][:, None]
        dq = np.maximum(self._delta(q, t, contact[:, None].repeat(GAUSS_X.size, 1), xi), 0.0)
        if np.any(dq >= 1.0):
            raise FloatingPointError("the layer bottomed out (delta >= 1)")
        f = dq / (1.0 - dq) if p.layer_law == "paper" else dq
        G = -dq - np.log1p(-dq) if p.layer_law == "paper" else 0.5 * dq**2
        N = _shapes(xi) * np.stack([np.ones(contact.size), self.h[contact], np.ones(contact.size),
                                    self.h[contact]])[:, :, None]                       # (4, C, 8)
        local = -p.K * np.sum(N * (f * wq)[None], axis=2)                               # (4, C)
        np.add.at(forces, self.top.elem[contact].T, local)
        return forces, float(p.K * np.sum(f * wq)), float(p.K * p.he * np.sum(G * wq))

    def _cubic(self, q, t, e):
        """(4, C): delta's coefficients in xi (powers 0 to 3) on the elements e."""
        p, h = self.p, self.h[e]
        local = q[self.top.elem[e]] * np.stack([np.ones_like(h), h, np.ones_like(h), h], 1)      # (C, 4)
        c = local @ HERMITE                                                                 # (C, 4)
        x0 = self.x[e]
        c[:, 0] += p.V * t - x0**2 / (2 * p.R)
        c[:, 1] -= x0 * h / p.R
        c[:, 2] -= h**2 / (2 * p.R)
        return c.T / p.he

    def _delta(self, q, t, e, xi):
        """delta at the local coordinates xi of the elements e."""
        p = self.p
        h = self.h[e]
        N = _shapes(xi) * np.stack([np.ones_like(h), h, np.ones_like(h), h])
        w = np.sum(N * np.moveaxis(q[self.top.elem[e]], -1, 0), axis=0)
        x = self.x[e] + h * xi
        return (w + p.V * t - x**2 / (2 * p.R)) / p.he

    def energy(self, q, v):
        """The plate's and the water's energy [J m-1] on the half plate."""
        return 0.5 * v @ self.mass @ v + 0.5 * q @ self.stiffness @ q


def mesh(L, breaks, spacing):
    """Nodes on [0, L], uniform between 0, the break places and L, at most ``spacing`` apart."""
    cuts = np.unique(np.concatenate([[0.0], np.asarray(breaks, float), [L]]))
    pieces = [np.linspace(a, b, max(1, math.ceil((b - a) / spacing)) + 1)[:-1] for a, b in zip(cuts[:-1], cuts[1:])]
    return np.concatenate(pieces + [[L]])


def run(p, breaks, times, x, spacing=0.02, dt=1e-7, opening_time=0.0, scheme="exponential"):
    """The plate of parameters p from first touch, broken at ``breaks`` [(time [s], place [m])]
    on nodes ``spacing`` apart (each crack opening over ``opening_time`` [s], _break), by steps of
    at most dt [s]: the upper-surface strain at the times
    and places x [m] (T, X), the force on the body [N m-1] (full plate) and the energy identity's
    largest residual |E_plate + E_layer - W| over the largest W (both over the run's steps; W with
    the opening faces' work). ``scheme``: the time step (STEPS); the exponential one steps also to
    each crack's end of opening, where its load has a kink."""
    times = np.asarray(times, float)
    nodes = mesh(p.L, [b for _, b in breaks], spacing)
    index = {b: int(np.argmin(np.abs(nodes - b))) for _, b in breaks}
    broken = set()
    plate = Plate(p, nodes, broken)
    q, v, a = np.zeros(plate.top.count), np.zeros(plate.top.count), np.zeros(plate.top.count)
    t, work, force_now = 0.0, 0.0, 0.0
    stops = sorted(set(times) | {tb for tb, _ in breaks}
                   | ({tb + opening_time for tb, _ in breaks} if opening_time > 0.0 and scheme != "trapezoid" else set()))
    step = STEPS[scheme]
    strain, force = np.full((times.size, len(x)), np.nan), np.full(times.size, np.nan)
    residual, peak_work = 0.0, 0.0
    for stop in stops:
        steps = max(1, math.ceil((stop - t) / dt - 1e-9)) if stop > t else 0
        for k in range(steps):
            h = dt if k < steps - 1 else stop - t
            q_old, faces_old = q, plate.crack_load(t)
            q, v, a, force_new, layer_energy = step(plate, q, v, a, t, h)
            work += 0.5 * h * p.V * 2.0 * (force_now + force_new)
            force_now, t = force_new, t + h if k < steps - 1 else stop
            work += (faces_old + plate.crack_load(t)) @ (q - q_old)      # (the opening faces', whole plate)
            peak_work = max(peak_work, work)
            residual = max(residual, abs(2.0 * (plate.energy(q, v) + layer_energy) - work))
        for i in np.flatnonzero(times == stop):
            strain[i] = -0.5 * p.hi * plate.curvature(q, x)
            force[i] = 2.0 * plate.layer(q, t)[1]
        for tb, b in breaks:
            if tb == stop:
                broken.add(index[b])
                plate, q, v, a = _break(plate, q, v, broken, t, a, opening_time)
    return strain, force, residual / peak_work if peak_work > 0 else 0.0


def _step(plate, q, v, a, t, h):
    """One trapezoidal step of length h from t: (q, v, a, F, E_layer) at t + h."""
    f = plate.top.free
    lu = plate.solver(h)
    base = q + h * v + 0.25 * h**2 * a
    a_new = a.copy()
    for _ in range(20):
        q_new = base + 0.25 * h**2 * a_new
        forces, F, layer_energy = plate.layer(q_new, t + h)
        rhs = forces + plate.crack_load(t + h) - plate.stiffness @ base
        x = lu_solve(lu, np.append(rhs[f], 0.0))
        change = np.max(np.abs(x[:-1] - a_new[f]))
        a_new = np.zeros_like(a)
        a_new[f] = x[:-1]
        if change <= 1e-13 * max(np.max(np.abs(a_new)), 1e-300):
            break
    q_new = base + 0.25 * h**2 * a_new
    forces, F, layer_energy = plate.layer(q_new, t + h)
    return q_new, v + 0.5 * h * (a + a_new), a_new, F, layer_energy


def _weights(omega, h):
    """The exponential step's weights for eta'' + omega^2 eta = g(s), g linear over the step from
    g0 to g1 (exact for it): eta(h) = c eta + s eta' + w0 g0 + w1 g1 and
    eta'(h) = -omega^2 s eta + c eta' + u0 g0 + u1 g1 (c = cos omega h, s = sin(omega h) / omega)."""
    x = omega * h
    c, s = np.cos(x), h * np.sinc(x / math.pi)
    a0 = 0.5 * (h * np.sinc(x / (2.0 * math.pi))) ** 2                # (1 - c) / omega^2, without cancellation
    small = x < 1e-2
    xs = np.where(small, x, 1.0)
    a1 = np.where(small, h**2 * (1.0 / 6.0 - xs**2 / 120.0 + xs**4 / 5040.0),
                  (h - s) / np.where(small, 1.0, omega) ** 2 / h)          # int_0^h sin(omega (h - r)) / omega r / h dr
    return c, s, a0 - a1, a1, s - a0 / h, a0 / h


def _exponential_step(plate, q, v, a, t, h):
    """One step of length h from t, exact for the plate's and the water's linear part (its wet
    modes advanced by cos and sin), the layer's and the opening cracks' forces linear in time over
    the step (second order in them; fixed-point iteration for their value at the step's end):
    (q, v, a, F, E_layer) at t + h. The trapezoidal rule (_step) gives a wave a phase error of about
    (omega h)^2 / 12 a step where omega h is small and of order one beyond, whatever the wave's
    amplitude; this step has none."""
    f = plate.top.free
    B, omega, P = plate.modes()
    c, s, w0, w1, u0, u1 = _weights(omega, h)
    eta, rate = P @ q[f], P @ v[f]
    g0 = P @ a[f] + omega**2 * eta                     # (a consistent: eta'' = -omega^2 eta + g)
    base = c * eta + s * rate + w0 * g0
    g1 = g0
    for _ in range(ITERATIONS):
        q_new = np.zeros_like(q)
        q_new[f] = B @ (base + w1 * g1)
        forces, F, layer_energy = plate.layer(q_new, t + h)
        g_next = B.T @ (forces + plate.crack_load(t + h))[f]
        change = np.max(np.abs(g_next - g1))
        g1 = g_next
        if change <= 1e-13 * max(np.max(np.abs(g1)), 1e-300):
            break
    else:
        if change > 1e-9 * max(np.max(np.abs(g1)), 1e-300):
            raise FloatingPointError(f"the layer's force at {t + h:.9g} s did not converge ({change:.1e})")
    eta_new = base + w1 * g1
    q_new = np.zeros_like(q)
    q_new[f] = B @ eta_new
    forces, F, layer_energy = plate.layer(q_new, t + h)
    v_new, a_new = np.zeros_like(v), np.zeros_like(a)
    v_new[f] = B @ (-omega**2 * s * eta + c * rate + u0 * g0 + u1 * g1)
    a_new[f] = B @ (g1 - omega**2 * eta_new)
    return q_new, v_new, a_new, F, layer_energy


#: the time steps (tests/fe_reference.run's and breaking_run's ``scheme``)
STEPS = {"trapezoid": _step, "exponential": _exponential_step}


def _broken_state(plate, q, v, broken):
    """The state on the degrees of freedom of the plate broken at the node indices ``broken``
    (one more than plate's): each side's w and w' at the new break those of the tied node before."""
    after = topology(plate.x, broken)
    return _carry(plate.top, after, q), _carry(plate.top, after, v)


def _carry(before, after, q):
    """The degrees of freedom q of the topology before on the topology after (each element's own)."""
    out = np.zeros(after.count)
    out[after.elem.ravel()] = q[before.elem.ravel()]
    return out


def _break(plate, q, v, broken, t, a=None, opening_time=0.0):
    """(plate, q, v, a) just after the plate broke at the node indices ``broken`` (one more than
    plate's) at t: the state carried, the matrices of the broken plate, the acceleration consistent
    with them (the constraint's multiplier eliminated). With an opening_time [s] > 0 (and the
    acceleration a before the break) the new crack opens over that time: the broken plate's new
    node first carries the internal force the whole plate's carried there (its moment and shear:
    the broken equations' residual at the carried state and acceleration, which is zero elsewhere),
    released linearly to zero (Plate.crack_load), so the acceleration is continuous at the break."""
    before, q_before = plate, q
    q, v = _broken_state(plate, q, v, broken)
    plate = Plate(plate.p, plate.x, broken)
    plate.cracks = [(_carry(before.top, plate.top, load), t_b, tau) for load, t_b, tau in before.cracks]
    f = plate.top.free
    forces = plate.layer(q, t)[0] + plate.crack_load(t)
    if opening_time > 0.0:
        held = before.mass @ a + before.stiffness @ q_before - before.layer(q_before, t)[0] - before.crack_load(t)
        c = before.means[before.top.free]
        multiplier = (c @ held[before.top.free]) / (c @ c)     # (held = c multiplier on the free dofs)
        carried = _carry(before.top, plate.top, a)
        residual = plate.mass @ carried + plate.stiffness @ q - forces - plate.means * multiplier
        node = min(set(broken) - before.broken)
        dofs = set(plate.top.elem[node, :2]) | (set(plate.top.elem[node - 1, 2:]) if node > 0 else set())
        load = np.zeros(plate.top.count)
        new = sorted(dofs & set(f))
        load[new] = residual[new]
        plate.cracks.append((load, t, opening_time))
        forces = forces + load
    x = lu_solve(plate.solver(0.0), np.append((forces - plate.stiffness @ q)[f], 0.0))
    a = np.zeros(plate.top.count)
    a[f] = x[:-1]
    return plate, q, v, a


def breaking_run(p, spacing=0.01, dt=4e-7, t_end=1.5e-3, max_breaks=3, band=0.0, opening_time=0.0,
                 scheme="exponential"):
    """The elements' own breaks: the plate of parameters p on nodes ``spacing`` apart breaks at a
    node where the tension of an armed surface (armed once its peak is below p.yield_strain, as the
    solver's) first reaches p.yield_strain, at the time interpolated between two steps' peaks (the
    step then taken again to it); the search skips the wall and the nodes closer than ``band`` [m]
    to a break, as the solver's crack spacing (with no band, the break's node and the next: a free
    edge's own tension is 0 only weakly in the elements; the centre's symmetry plane is searched
    until it breaks); each crack opens over ``opening_time`` [s] (0: at once; _break). Returns
    [(time [s], x [m], surface)] up to max_breaks breaks, to the first one off the centre (the
    breakthrough), or to t_end. ``scheme``: the time step (STEPS)."""
    step = STEPS[scheme]
    nodes = mesh(p.L, [], spacing)
    broken, found = set(), []
    plate = Plate(p, nodes, broken)
    q, v, a = np.zeros(plate.top.count), np.zeros(plate.top.count), np.zeros(plate.top.count)
    t, armed = 0.0, [True, True]
    level = p.yield_strain
    before = _peaks(plate, q, broken, p, band)
    while t < t_end and len(found) < max_breaks:
        state = (q, v, a)
        q, v, a, _, _ = step(plate, q, v, a, t, dt)
        peaks = _peaks(plate, q, broken, p, band)
        crossing = [s for s in range(2) if armed[s] and peaks[s][0] >= level]
        if crossing:
            s = min(crossing, key=lambda s: (level - before[s][0]) / (peaks[s][0] - before[s][0]))
            h = dt * (level - before[s][0]) / (peaks[s][0] - before[s][0])
            q, v, a, _, _ = step(plate, *state, t, h)
            t += h
            node = _peaks(plate, q, broken, p, band)[s][1]
            found.append((t, float(nodes[node]), ("upper", "lower")[s]))
            if node > 0:
                break                                             # the breakthrough
            broken.add(node)
            plate, q, v, a = _break(plate, q, v, broken, t, a, opening_time)
            armed = [False, False]
        else:
            t += dt
        before = _peaks(plate, q, broken, p, band)
        armed = [armed[s] or before[s][0] < level for s in range(2)]
    return found


def _peaks(plate, q, broken, p, band):
    """[(peak tension, its node)] of the upper and the lower surface over the nodes searched."""
    strain = -0.5 * p.hi * plate.nodal_curvature(q)
    skip = np.zeros(strain.size, bool)
    skip[-1] = True                                              # the wall
    reach = band if band > 0.0 else 1.01 * np.max(plate.h)        # (no band: the break's node and the next)
    for j in broken:
        skip[np.abs(plate.x - plate.x[j]) < reach - 1e-9] = True
    out = []
    for sign in (1.0, -1.0):
        values = np.where(skip, -np.inf, sign * np.nan_to_num(strain, nan=-np.inf))
        node = int(np.argmax(values))
        out.append((float(values[node]), node))
    return out
