r"""Parameters -> the Model tuple the kernels take, built once per case (plain Python).

The centred impact (x0 = 0, or full_plate False) is solved on the symmetric half plate
0 <= x <= L: modes cos(lambda_n x), lambda_n = pi n / L, integrals over 0..L doubled
(mirror = 2). An off-centre impact (full_plate True) is solved on the full plate in the
kernel coordinate xi = x + L in 0..2L: the sliding-wall modes cos(k pi xi / 2L),
k = 1..2 Nmod (even k = 2n: (-1)^n cos(lambda_n x), the symmetric modes; odd k = 2m - 1:
(-1)^m sin((m - 1/2) pi x / L), the antisymmetric ones), integrals over 0..2L (mirror = 1),
twice the nodes at the same dx. Everything the kernels see has the same form on both
(docs/model.md, "Off-centre impact").
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .basis import QUADRATURE_CODES, Basis
from .peak_margin import peak_reach
from .body import Body
from .crack import no_cracks
from .floe import dry_values, floe_tables
from .part_tables import parts_tables
from .parts import part_values
from .layer import LAW_CODES, Layer
from .plate import COEF, MASS, STRAIN, Plate, make_plate
from .quadrature import PANEL_POINTS, legendre_rule

#: the broken plates' tables last built (read only), keyed by (Parameters, subintervals, full
#: plate, breaks): at most PARTS_TABLES_KEPT, the oldest dropped first
PARTS_TABLES_KEPT = 32
_PARTS_TABLES = {}
#: what the kernels take for one case: Plate, Basis, Body, Layer, Cracks (each defined by its module;
#: Cracks: the cracks still opening, none but in a stage of a run that breaks with a crack_speed)
Model = namedtuple("Model", "plate basis body layer cracks")

#: a damped mode is kept at least this far (omega_d or kappa over omega) from critical damping
CRITICAL_GAP = 1e-6


class Tables:
    """A case's Model, and the Python side of its basis: the wavenumbers lam, the nodes in kernel
    coordinates xq and on the plate x_nodes, the plate's origin in kernel coordinates, and the
    maps between the kernel's modal order and the symmetric and antisymmetric amplitudes."""

    def __init__(self, p, subintervals: int, full_plate: bool | None = None, quadrature: str = "paper",
                 quadrature_density: float = 8.0, breaks=None):
        self.floe = None
        self.hi = float(p.hi)
        full = p.off_centre if full_plate is None else bool(full_plate)
        if breaks is not None:
            self._broken(p, subintervals, full, quadrature, quadrature_density, breaks)
            return
        if p.edges == "free":
            self._free_floe(p, subintervals, full, quadrature, quadrature_density)
            return
        self.full_plate = full
        if full:
            lam = np.pi * np.arange(1, 2 * p.Nmod + 1) / (2.0 * p.L)
            self.origin = -p.L                       # x of the kernel's xi = 0
        else:
            lam = p.wavenumbers
            self.origin = 0.0
        M, self.omega, self.damping = p.mode_constants(lam)
        self.lam = lam
        self.dx = p.L / subintervals
        self.xq = self.dx * np.arange((2 if full else 1) * subintervals + 1)   # the nodes in kernel coordinates
        self.x_nodes = self.xq + self.origin                                  # and on the plate
        plate = self._plate(p, M, full)
        self.coef, self.LM, self.strain_coef = plate.modes[COEF], plate.modes[MASS], plate.modes[STRAIN]
        self.cosq = np.ascontiguousarray(np.cos(np.outer(lam, self.xq)))       # (N, J)
        sinc2 = np.sinc(lam * self.dx / (2 * np.pi)) ** 2                     # np.sinc(u) = sin(pi u)/(pi u)
        self.wq = self.dx * sinc2            # (N,): int hat_j cos(lam_n x) dx = wq_n cos(lam_n x_j) inside
        gauss_x, gauss_w = legendre_rule(PANEL_POINTS)
        # panels of PANEL_POINTS Gauss nodes, quadrature_density of them per wavelength of the last mode
        panel = PANEL_POINTS / float(quadrature_density) * 2.0 * np.pi / float(lam[-1])
        basis = Basis(float(lam[0]), float(self.dx), self.cosq, self.wq, 1.0 if full else 2.0,
                      float(self.dx * (self.xq.size - 1)), QUADRATURE_CODES[quadrature], gauss_x, gauss_w, panel,
                      0.0, np.zeros(0), np.zeros(0), peak_reach(float(lam[-1]), self.dx))
        self.model = Model(plate, basis, self._body(p, full), Layer(float(p.he), float(p.K), float(p.layer_tau),
                                                                    LAW_CODES[p.layer_law]),
                           no_cracks(self.omega.size))

    def _free_floe(self, p, subintervals, full, quadrature, quadrature_density):
        """A free floe (docs/model.md, "A free floe"): its wet modes (solver.model.floe) in the
        node table; the full floe -L..L in kernel coordinates xi = x + L, or for a centred impact
        the half floe 0..L and the symmetric wet modes (mirror = 2). The contact-resolving rule's
        panels are sized by the largest dry wavenumber, as the cosines' by lambda_N."""
        self._nodes(p, subintervals, full)
        self.floe_length = float(p.L)
        self._wet_basis(p, full, quadrature, quadrature_density, floe_tables(p, self.xq, full))
        fl = self.floe
        self._dry_values = lambda x, order: dry_values(fl["kinds"], fl["betas"], fl["norms"], self.floe_length,
                                                        x + self.origin, order)

    def _broken(self, p, subintervals, full, quadrature, quadrature_density, breaks):
        """A walled plate or a floe broken into parts at ``breaks`` [m, kernel coordinates]
        (docs/model.md, "Breaking into parts", "A floe breaks"): its wet modes (solver.model.parts)
        in a floe's form, the parts' wavenumbers up to the cosines' lambda_N."""
        self._nodes(p, subintervals, full)
        lam_N = np.pi * p.Nmod / p.L
        key = (p, subintervals, full, tuple(float(b) for b in breaks))
        fl = _PARTS_TABLES.get(key)
        if fl is None:            # (a run that breaks builds each plate's once: its stages, companions, checks)
            fl = _PARTS_TABLES[key] = parts_tables(p, self.xq, breaks, full, lam_N)
            while len(_PARTS_TABLES) > PARTS_TABLES_KEPT:
                _PARTS_TABLES.pop(next(iter(_PARTS_TABLES)))
        self._wet_basis(p, full, quadrature, quadrature_density, fl)
        self._dry_values = lambda x, order: part_values(fl["wet"].modes, x, order)

    def _nodes(self, p, subintervals, full):
        """The nodes: xq in kernel coordinates, x_nodes on the plate."""
        self.full_plate = full
        self.origin = -p.L if full else 0.0
        self.dx = p.L / subintervals
        self.xq = self.dx * np.arange((2 if full else 1) * subintervals + 1)
        self.x_nodes = self.xq + self.origin

    def _wet_basis(self, p, full, quadrature, quadrature_density, fl):
        """The Model of wet modes (a floe's, or a broken plate's) from their tables fl."""
        self.floe = fl
        N = fl["omega"].size
        self.omega, self.damping = fl["omega"], fl["damping"]
        self.lam = np.full(N, np.nan)                 # no wavenumbers: the wet modes are not cosines
        self.cosq, self.wq = fl["cosq"], np.zeros(N)
        mass = fl["mass"]
        half_c, wd, over = self._damped()
        plate = make_plate(self.omega, (-1.0 if full else -2.0) / mass, fl["strain_scale"], mass, half_c, wd, over,
                           mass[0])
        self.coef, self.LM, self.strain_coef = plate.modes[COEF], plate.modes[MASS], plate.modes[STRAIN]
        gauss_x, gauss_w = legendre_rule(PANEL_POINTS)
        panel = PANEL_POINTS / float(quadrature_density) * 2.0 * np.pi / float(np.max(fl["betas"]))
        basis = Basis(0.0, float(self.dx), self.cosq, self.wq, 1.0 if full else 2.0,
                      float(self.dx * (self.xq.size - 1)), QUADRATURE_CODES[quadrature], gauss_x, gauss_w, panel,
                      1.0, fl["packed"], np.empty(fl["omega"].size), peak_reach(float(np.max(fl["betas"])), self.dx))
        self.model = Model(plate, basis, self._body(p, full), Layer(float(p.he), float(p.K), float(p.layer_tau),
                                                                    LAW_CODES[p.layer_law]),
                           no_cracks(self.omega.size))

    def derivative(self, a, x, order):
        """The deflection's x-derivative of the given order [m1-order] at kernel coordinates x of the
        kernel's amplitudes a (the cosines', or a broken plate's wet modes')."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if self.floe is None:
            return np.cos(np.outer(x, self.lam) + order * np.pi / 2) @ (self.lam**order * np.asarray(a))
        return (self.floe["Q"].T @ self._dry_values(x, order)).T @ np.asarray(a)

    def mode_values(self, x, field: str = "deflection"):
        """(X, N): each kernel mode's deflection (field "deflection") or upper-surface strain
        ("strain") per unit amplitude at plate positions x [m] (numpy; on the cosines the strain
        is their deflection times strain_coef)."""
        ax = self.kernel_x(x)
        if self.floe is None:
            cos = np.cos(np.outer(ax, self.lam))
            return cos if field == "deflection" else cos * self.strain_coef
        order = 0 if field == "deflection" else 2
        values = (self.floe["Q"].T @ self._dry_values(ax, order)).T
        return values if field == "deflection" else -0.5 * self.hi * values

    def _damped(self):
        """(c/2, omega_d, overdamped) of each mode from omega and the Kelvin-Voigt damping c."""
        half_c = 0.5 * self.damping                  # Kelvin-Voigt: 0 for the paper's elastic ice
        over = half_c > self.omega                   # overdamped modes: two real decay rates
        wd = np.sqrt(np.abs(self.omega - half_c) * (self.omega + half_c))
        # a mode within 1e-12 of critical damping is taken as underdamped with omega_d = 1e-6
        # omega (its rates move by 1e-12; a from z loses at most 1e-10 to the small omega_d)
        near = (half_c > 0) & (wd < CRITICAL_GAP * self.omega)
        over = over & ~near
        wd = np.where(half_c == 0.0, self.omega, np.where(near, CRITICAL_GAP * self.omega, wd))
        return half_c, wd, over.astype(float)

    def _plate(self, p, M, full):
        """The Plate table: the modes' constants and the Kelvin-Voigt damping."""
        half_c, wd, over = self._damped()
        LM = p.L * M
        return make_plate(self.omega, (-1.0 if full else -2.0) / (p.L * M), 0.5 * p.hi * self.lam**2, LM, half_c, wd,
                          over, LM[1] if full else LM[0])

    def _body(self, p, full):
        """The Body: its motion, its shape, and its profile at the nodes."""
        if full:
            profile = p.body_profile(self.x_nodes)                                  # b(x_j - x0)
        else:
            profile = self.xq * self.xq * (0.5 / p.R) if p.parabola else p.body_profile(self.xq)   # b(x_j)
        free = p.free_body
        return Body(float(p.V), 1.0 / p.body_mass if free else 0.0, float(p.body_g) if free else 0.0, float(p.R),
                    float(p.body_p), float(p.flat_width), float(p.tan_deadrise), float(p.L + p.x0) if full else 0.0,
                    np.ascontiguousarray(profile, dtype=float))

    def kernel_x(self, x):
        """Kernel coordinates of plate positions x [m]: |x| on the half plate, x + L on the full."""
        x = np.asarray(x, dtype=float)
        return x - self.origin if self.full_plate else np.abs(x)

    def to_kernel(self, symmetric, antisymmetric=None):
        """Modal amplitudes in the kernel's order from those of cos(lambda_n x) (and of
        sin((m - 1/2) pi x / L) on the full plate): the last axis has Nmod entries each."""
        symmetric = np.asarray(symmetric, dtype=float)
        if self.floe is not None:         # a floe starts at rest (solve refuses other initial states)
            return np.zeros(symmetric.shape[:-1] + (self.omega.size,))
        if not self.full_plate:
            return symmetric
        n = symmetric.shape[-1]
        out = np.zeros(symmetric.shape[:-1] + (2 * n,))
        sign = (-1.0) ** np.arange(1, n + 1)
        out[..., 1::2] = sign * symmetric
        if antisymmetric is not None:
            out[..., 0::2] = sign * np.asarray(antisymmetric, dtype=float)
        return out

    def from_kernel(self, amplitudes):
        """(symmetric, antisymmetric) amplitudes of cos(lambda_n x) and sin((m - 1/2) pi x / L)
        from the kernel's; on the half plate the antisymmetric ones are 0 (NaN where the
        symmetric are)."""
        if not self.full_plate or self.floe is not None:   # a floe's: its wet modes' amplitudes, none apart
            return amplitudes, np.where(np.isnan(amplitudes), np.nan, 0.0)
        n = amplitudes.shape[-1] // 2
        sign = (-1.0) ** np.arange(1, n + 1)
        return sign * amplitudes[..., 1::2], sign * amplitudes[..., 0::2]
