"""Physical parameters and their derived scales (the solver's settings: solver.settings).

All values are SI. The keys are those of ``docs/model.md`` (the language of the field and
of the study files); :data:`PARAMETER_INFO` gives each its long name and units.

Derived quantities (docs/model.md, "Equations" and "Scales")::

    m   = rho_i hi                          plate mass per unit area        [kg m-2]
    D   = E hi^3 / (12 (1 - nu^2))          flexural rigidity               [N m]
    lambda_n = pi n / L                     modal wavenumber                [m-1]
    M_n = m + rho_w coth(lambda_n H) / lambda_n   mass with added water mass [kg m-2]
                                            (deep water, H = inf: m + rho_w / lambda_n)
    omega_n^2 = (D lambda_n^4 + rho_w g) / M_n                              [s-2]
    t_sc = 1 / omega_1,  w_sc = K / (omega_1^2 M_1),  T = L^2 / (6 R V)
    d1 = w_sc / he,  d2 = V / (omega_1 he),  d3 = L^2 / (2 R he)
"""
from __future__ import annotations

import math
from functools import cached_property
from dataclasses import dataclass, fields

import numpy as np

from .keys import (BEYOND_BOUNDS, CHOICES, INTEGER_PARAMETERS, PAPER_DEFAULTS, PARAMETER_INFO,  # noqa: F401
                   PHYSICAL_RANGES, ParameterError, check_bound, check_positive, outside_physical_range)

#: largest Nmod accepted (memory: the tables are Nmod x subintervals doubles; subintervals:
#: solver.settings.MAX_SUBINTERVALS)
MAX_MODES = 4096
#: the most edge shapes a free edge of a broken plate's part may carry (solver.model.parts.EDGE_FACTORS)
EDGE_SHAPES = 4
#: the most parts a run that breaks may make (max_parts): each part carries its own modes (at least
#: its heave), and a study stores max_parts - 1 break slots per case; the reference case's cascade
#: makes 8 parts in 2 ms
MAX_PARTS = 1000

#: the shortest impact stage the model resolves, as a fraction of the layer's response time
#: 1/Omega_c (Parameters.contact_frequency): a body flatter than that (deadrise = 1e-9 degree:
#: 1e-8 of it) sinks by its mean height before the layer passes any force to the ice, and
#: the run would report a strain of 1e-28 as a result; the paper's case is at 112, its
#: V = 1000 m/s at 0.56, a 1e-3 degree wedge at 1e-2
MIN_STAGE_RESPONSE = 1e-4

#: the parameters t_sc depends on
TIME_SCALE_KEYS = ("hi", "L", "E", "nu", "rho_i", "rho_w", "g", "H")
#: the keys Parameters checks together (_check_scales: the time scale, the impact stage against
#: the layer's response time, flat_width against L + |x0|; x0 against L; hi against L): a
#: study checks every combination of its grid's values of them (pipeline.study.consistency)
COUPLED_KEYS = (*TIME_SCALE_KEYS, "R", "V", "body_p", "flat_width", "deadrise", "x0", "K", "he")
#: the keys those checks are not monotone in (the stage against body_p, and against |x0|): where
#: a grid has too many combinations, every value of these is checked with the extremes of the rest
NOT_MONOTONE = ("body_p", "x0")


def water_added_mass(rho_w, lam, H):
    """rho_w coth(lambda H) / lambda [kg m-2], the water's added mass of a mode of wavenumber
    lambda under depth H (scalars or arrays); exactly rho_w / lambda where H is infinite."""
    lam = np.asarray(lam, dtype=float)
    H = np.asarray(H, dtype=float)
    deep = np.asarray(rho_w) / lam
    finite = np.isfinite(H)
    if not np.any(finite):
        return deep
    with np.errstate(over="ignore", invalid="ignore"):
        shallow = deep / np.tanh(lam * np.where(finite, H, 1.0))
    return np.where(finite, shallow, deep)


def time_scale_of(hi, L, E, nu, rho_i, rho_w, g, H=math.inf):
    """t_sc = 1/omega_1 [s] for scalars or broadcastable arrays: omega_1^2 = (D lambda_1^4 +
    rho_w g) / (rho_i hi + rho_w coth(lambda_1 H) / lambda_1), D = E hi^3 / (12 (1 - nu^2)),
    lambda_1 = pi / L."""
    lam = np.pi / np.asarray(L, dtype=float)
    rigidity = np.asarray(E) * np.asarray(hi) ** 3 / (12.0 * (1.0 - np.asarray(nu) ** 2))
    omega2 = (rigidity * lam**4 + np.asarray(rho_w) * g) / (np.asarray(rho_i) * hi + water_added_mass(rho_w, lam, H))
    return 1.0 / np.sqrt(omega2)


@dataclass(frozen=True)
class Parameters:
    """One impact case, SI units; defaults are the paper's reference case.

    Parameters
    ----------
    K : float
        Rigidity of the elastic layer [Pa].
    he : float
        Thickness of the elastic layer [m].
    R : float
        Radius of curvature of the body [m].
    V : float
        Impact speed [m/s].
    hi : float
        Ice thickness [m].
    Nmod : int
        Retained normal modes.
    L : float
        Half-length of the plate between the walls [m].
    E : float
        Young's modulus of ice [Pa].
    nu : float
        Poisson's ratio of ice, 0 <= nu < 0.5.
    rho_i, rho_w : float
        Ice and water density [kg/m^3].
    g : float
        Gravitational acceleration [m/s^2].
    H : float
        Water depth under the ice [m]; inf (the default) is the paper's deep water
        (docs/model.md, "Finite water depth").
    body_mass : float
        Mass M of the body per unit width [kg/m]; inf (the default) drives it at the constant
        speed V, the paper's model. Finite: it starts at V and obeys ``M s'' = M body_g - F``
        (docs/model.md, "A body of finite mass").
    body_g : float
        Downward acceleration of a free body besides the ice's reaction [m/s^2]: gravity (the
        default 9.81), or 0 for a body whose weight is carried; unused when body_mass = inf.
    body_p, flat_width, deadrise : float
        The body's shape (docs/model.md, "Body shapes"): with ``u = max(|x| - flat_width, 0)``,
        the profile is ``u tan(deadrise)`` for a wedge (deadrise > 0 [degree]), else
        ``u^body_p / (body_p R^(body_p - 1))``; the defaults (2, 0 m, 0) are the paper's
        parabola ``x^2 / 2R``.
    tau : float
        Retardation time of Kelvin-Voigt viscoelastic ice [s]: ``D -> D (1 + tau d/dt)`` damps
        mode n at ``c_n = tau D lambda_n^4 / M_n`` (docs/model.md, "Viscoelastic ice"); 0 (the
        default) is the paper's elastic ice.
    layer_tau : float
        Retardation time of a viscoelastic layer [s]: its pressure is
        ``K f(delta) max(1 + layer_tau d(delta)/dt, 0)`` where it is compressed (docs/model.md,
        "Viscoelastic layer"); 0 (the default) is the paper's elastic layer.
    x0 : float
        Horizontal position of the body's centre [m], -L < x0 < L: the body is
        ``y = b(x - x0) + he - s`` and moves vertically only, without rotating (docs/model.md,
        "Off-centre impact"). 0 (the default) is the paper's centred impact on the symmetric
        modes; any other value is solved on the full plate, Nmod symmetric and Nmod
        antisymmetric modes.
    layer_law : {"paper", "linear"}
        The law of the layer's pressure ``K f(delta)`` (docs/model.md, "Layer law"): "paper"
        (the default), ``f = delta / (1 - delta)``, stiffening without bound as the layer is
        crushed; "linear", the classical Winkler layer ``f = delta``.
    edges : {"walls", "free"}
        "walls" (the default): the paper's basin, sliding walls at x = +-L. "free": a floe of
        half-length L in open water, free edges, heave and pitch, phi = 0 on the water outside
        (docs/model.md, "A free floe"); Nmod symmetric and Nmod antisymmetric elastic modes.
    duration : float
        Length of the run [s]. 0 (the default): the walled plate's impact stage ``b_mean / V``
        (``L^2 / (6 R V)`` for the parabola); a free floe has no such end and needs a duration.
    fracture : {"none", "break"}
        "none" (the default): the ice stays whole, the paper's model; crack onset for any yield
        strain is read from the run's tension records. "break": where either surface's tension
        first reaches ``yield_strain`` the plate breaks through its thickness, and the run goes
        on on the parts, which may break again (docs/model.md, "Breaking into parts"): between
        walls (the ice breaks off a wall too) and on a floe, under the Gauss quadrature.
    yield_strain : float
        The tension at which the ice breaks [1], read with fracture = "break" (the default 8e-5
        is the paper's illustrative yield strain).
    max_parts : int
        The most parts the whole plate may break into, read with fracture = "break" (default
        16): a run that would break into more ends with status ``parts_limit``, its data up to
        then valid.
    crack_spacing : float
        The shortest distance between two breaks, in ice thicknesses hi, read with fracture =
        "break": within it of a break (a free edge) the tension is not read and the ice does not
        break again (docs/model.md, "The crack spacing"). 0 (the default): none, the
        discretisation's resolution acts as one.
    crack_speed : float
        The speed [m s-1] at which a crack crosses the ice's thickness, read with fracture =
        "break": a break's faces first carry the moment and shear the ice carried there, released
        linearly over hi / crack_speed, their work the fracture's dissipated energy (docs/model.md,
        "A crack that opens over a time"). inf (the default): at once.
    edge_shapes : int
        How many edge shapes each free edge of a broken plate's parts carries, read with fracture =
        "break" (0 to 4): boundary layers cosh and sinh of beta (x - c), beta = 1, 1/2, 1/4, 1/8 of
        the parts' largest wavenumber (a part too short for one takes a shape of the whole part,
        beta l = 1.5, in its place), which carry the bending a break leaves at its faces and an
        opening crack's moment (docs/model.md, "Edge shapes"). 0 (the default): the parts'
        free-free modes alone. It needs a crack_spacing.
    """

    K: float = 8e6
    he: float = 0.02
    R: float = 10.0
    V: float = 5.0
    hi: float = 0.5
    Nmod: int = 60
    L: float = 6.0
    E: float = 4.2e9
    nu: float = 0.33
    rho_i: float = 917.0
    rho_w: float = 1000.0
    g: float = 9.81
    H: float = math.inf
    body_mass: float = math.inf
    body_g: float = 9.81
    body_p: float = 2.0
    flat_width: float = 0.0
    deadrise: float = 0.0
    tau: float = 0.0
    layer_tau: float = 0.0
    x0: float = 0.0
    layer_law: str = "paper"
    edges: str = "walls"
    duration: float = 0.0
    fracture: str = "none"
    yield_strain: float = 8e-5
    max_parts: int = 16
    crack_spacing: float = 0.0
    crack_speed: float = math.inf
    edge_shapes: int = 0

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in CHOICES:
                if not isinstance(value, str) or value not in CHOICES[f.name]:
                    raise ParameterError(f"{f.name} must be one of {', '.join(CHOICES[f.name])}, got {value!r}")
                continue
            number = not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating))
            if f.name in BEYOND_BOUNDS:
                check_bound(f.name, value, *BEYOND_BOUNDS[f.name])
                if f.name == "edge_shapes" and (int(value) != value or value > EDGE_SHAPES):
                    raise ParameterError(f"edge_shapes must be a whole number from 0 to {EDGE_SHAPES} (at 1, 1/2, "
                                         f"1/4 and 1/8 of the parts' largest wavenumber), got {value!r}")
            elif f.name == "deadrise":
                if not number or not 0.0 <= float(value) < 90.0:
                    raise ParameterError(f"deadrise must be in [0, 90) degrees (0: not a wedge), got {value!r}")
            elif f.name == "x0":
                if not number or not math.isfinite(float(value)):
                    raise ParameterError(f"x0 must be a finite number of metres (0: the paper's centred impact), "
                                         f"got {value!r}")
            elif f.name == "nu":
                if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                        or not math.isfinite(float(value)) or not 0.0 <= float(value) < 0.5:
                    raise ParameterError(f"nu must be in [0, 0.5), got {value!r}")
            else:
                check_positive(f.name, value, integer=f.name in INTEGER_PARAMETERS)
                if f.name == "Nmod" and int(value) > MAX_MODES:
                    raise ParameterError(f"Nmod must be at most {MAX_MODES}, got {value!r}")
                if f.name == "max_parts" and int(value) > MAX_PARTS:
                    raise ParameterError(f"max_parts must be at most {MAX_PARTS} (each part carries modes of its "
                                         f"own, and a case stores max_parts - 1 breaks), got {value!r}")
            object.__setattr__(self, f.name, int(value) if f.name in INTEGER_PARAMETERS else float(value))
        if not abs(self.x0) < self.L:
            raise ParameterError(f"x0 must lie inside the plate, -L < x0 < L = {self.L!r} m, got {self.x0!r}")
        if self.edges == "free":
            self._check_floe()
        self._check_fracture()
        self._check_scales()

    def _check_floe(self) -> None:
        """What a free floe needs (one line)."""
        if not self.duration > 0.0:
            raise ParameterError("a free floe (edges = 'free') needs duration > 0 [s]: its run has no end of its "
                                 "own (the walls' impact stage follows from int w dx = 0, which a floe lacks)")

    def _check_fracture(self) -> None:
        """What breaking reads, and what it does not compose with yet (one line)."""
        if self.fracture == "none":        # (yield_strain and max_parts unread: a grid over fracture sets them)
            return
        if self.max_parts < 2:
            raise ParameterError(f"max_parts must be an integer >= 2 (a break makes two parts), got {self.max_parts!r}")
        if self.edge_shapes > 0 and self.crack_spacing == 0.0:
            raise ParameterError("edge_shapes > 0 needs crack_spacing > 0: edge shapes carry a new edge's bending (at "
                                 "once, or an opening crack's held moment), so the tension next to a break stays at "
                                 "yield_strain and the ice would break again within a millimetre of it")

    def _check_scales(self) -> None:
        """Refuse values that are each allowed but give no finite time scale or impact stage,
        or a stage too short to resolve (MIN_STAGE_RESPONSE): one line naming the keys."""
        with np.errstate(all="ignore"):
            try:
                t_sc = float(self.time_scale)
            except (OverflowError, ZeroDivisionError):
                t_sc = math.nan
        if not (math.isfinite(t_sc) and t_sc > 0.0):
            with np.errstate(all="ignore"):
                added = float(water_added_mass(self.rho_w, np.pi / self.L, self.H))
            cause = (f"the water depth H = {self.H!r} m makes the water's added mass infinite" if not
                     math.isfinite(added) else "from hi, L, E, nu, rho_i, rho_w, g and H")
            raise ParameterError(f"these parameters give no finite time scale 1/omega_1 (t_sc = {t_sc!r} s): "
                                 f"{cause}")
        if self.flat_width >= self.L + abs(self.x0):
            raise ParameterError(f"flat_width = {self.flat_width!r} m covers the whole plate (L + |x0| = "
                                 f"{self.L + abs(self.x0)!r} m): the flat bottom meets all the ice at once and "
                                 f"the impact stage is 0; flat_width must be < L + |x0|")
        try:
            stage = float(self.stage_duration)
        except (OverflowError, ZeroDivisionError):
            stage = math.nan
        if not (math.isfinite(stage) and stage > 0.0):
            raise ParameterError(f"the body's shape gives no finite impact stage (stage = {stage!r} s from "
                                 f"R = {self.R!r} m, body_p = {self.body_p!r}, flat_width = {self.flat_width!r} m, "
                                 f"deadrise = {self.deadrise!r} degree, V = {self.V!r} m/s)")
        response = 1.0 / self.contact_frequency
        if not stage >= MIN_STAGE_RESPONSE * response:
            raise ParameterError(
                f"the impact stage, {stage:.3g} s, is shorter than {MIN_STAGE_RESPONSE:g} of the layer's "
                f"response time sqrt(he rho_i hi / K) = {response:.3g} s: the body sinks by its mean height "
                f"over the plate before the layer can pass a force to the ice, an impact the model does not "
                f"resolve (a body this flat: flat_width = {self.flat_width!r} m, deadrise = {self.deadrise!r} "
                f"degree, R = {self.R!r} m, body_p = {self.body_p!r}; or V = {self.V!r} m/s)")

    @property
    def contact_frequency(self) -> float:
        """Omega_c = sqrt(K / (he rho_i hi)) [rad s-1]: the layer on the bare plate at first touch.

        The layer's stiffness per unit area is K f'(delta)/he, f'(0) = 1; on the plate mass alone
        (no added water mass, no bending) this is the fastest the contact force can change.
        """
        return math.sqrt(self.K / (self.he * self.plate_mass))

    # --- derived quantities -------------------------------------------------------------
    @property
    def crack_opening_time(self) -> float:
        """hi / crack_speed [s]: how long a crack takes to cross the ice (0: at once)."""
        return self.hi / self.crack_speed

    @property
    def plate_mass(self) -> float:
        """m = rho_i hi [kg m-2]."""
        return self.rho_i * self.hi

    @property
    def rigidity(self) -> float:
        """D = E hi^3 / (12 (1 - nu^2)) [N m]."""
        return self.E * self.hi**3 / (12.0 * (1.0 - self.nu**2))

    @property
    def wavenumbers(self) -> np.ndarray:
        """lambda_n = pi n / L, n = 1..Nmod [m-1]."""
        return np.pi * np.arange(1, self.Nmod + 1) / self.L

    def mode_constants(self, lam):
        """(M, omega, c) of modes of wavenumbers lam [m-1]: the mass with the water's added mass
        M = m + rho_w coth(lam H) / lam [kg m-2] (m + rho_w / lam in deep water, H = inf, bit for
        bit the paper's), omega = sqrt((D lam^4 + rho_w g) / M) [rad s-1] and the Kelvin-Voigt
        damping c = tau D lam^4 / M [s-1]. The symmetric modes' are ``added_masses``,
        ``frequencies`` and ``damping``; an off-centre impact also takes lam = k pi / 2L."""
        lam = np.asarray(lam, dtype=float)
        if math.isinf(self.H):
            M = self.plate_mass + self.rho_w / lam
        else:
            M = self.plate_mass + water_added_mass(self.rho_w, lam, self.H)
        omega = np.sqrt((self.rigidity * lam**4 + self.rho_w * self.g) / M)
        return M, omega, self.tau * self.rigidity * lam**4 / M

    @property
    def added_masses(self) -> np.ndarray:
        """M_n = m + rho_w coth(lambda_n H) / lambda_n [kg m-2] (see mode_constants)."""
        return self.mode_constants(self.wavenumbers)[0]

    @property
    def damping(self) -> np.ndarray:
        """c_n = tau D lambda_n^4 / M_n [s-1]: a_n'' + c_n a_n' + omega_n^2 a_n = P_n."""
        return self.mode_constants(self.wavenumbers)[2]

    @property
    def frequencies(self) -> np.ndarray:
        """omega_n = sqrt((D lambda_n^4 + rho_w g) / M_n) [rad s-1]."""
        return self.mode_constants(self.wavenumbers)[1]

    @cached_property
    def time_scale(self) -> float:
        """t_sc = 1 / omega_1 [s]."""
        return float(time_scale_of(**{k: getattr(self, k) for k in TIME_SCALE_KEYS}))

    @property
    def deflection_scale(self) -> float:
        """w_sc = K / (omega_1^2 M_1) [m]."""
        return self.K / (self.frequencies[0] ** 2 * self.added_masses[0])

    @property
    def parabola(self) -> bool:
        """True for the paper's body shape x^2 / 2R."""
        return self.body_p == 2.0 and self.flat_width == 0.0 and self.deadrise == 0.0

    @property
    def tan_deadrise(self) -> float:
        return math.tan(math.radians(self.deadrise)) if self.deadrise > 0.0 else 0.0

    @property
    def off_centre(self) -> bool:
        """True when the body's centre x0 is not 0: solved on the full plate."""
        return self.x0 != 0.0

    def body_profile(self, x):
        """b(x - x0) [m]: the body is y = b(x - x0) + he - s (s = V t for the paper's body);
        x^2 / (2R) for the paper's parabola (the same expression as before shapes existed)."""
        x = np.asarray(x, dtype=float) - self.x0
        if self.parabola:
            return x**2 / (2 * self.R)
        u = np.maximum(np.abs(x) - self.flat_width, 0.0)
        if self.deadrise > 0.0:
            return u * self.tan_deadrise
        return u**self.body_p / (self.body_p * self.R ** (self.body_p - 1.0))

    def profile_mean(self) -> float:
        """``b_mean = (1/2L) int_-L^L b(x - x0) dx`` [m], the mean height of the body's profile over
        the plate. The modes keep ``int w dx = 0`` (mass conservation), so the mean compression of
        the layer is ``(s - b_mean) / he``: it bottoms out before the penetration s reaches
        ``b_mean + he``. Centred (x0 = 0): ``(1/L) int_0^L b dx``."""
        if self.off_centre:
            # the profile rises away from x0 on both sides: b_mean = (B(L + |x0|) + B(L - |x0|)) / 2L
            return (self._profile_integral(self.L + abs(self.x0))
                    + self._profile_integral(self.L - abs(self.x0))) / (2.0 * self.L)
        c = min(self.flat_width, self.L)
        if self.deadrise > 0.0:
            return (self.L - c) ** 2 * self.tan_deadrise / (2.0 * self.L)
        p = self.body_p
        return (self.L - c) ** (p + 1.0) / ((p + 1.0) * p * self.R ** (p - 1.0) * self.L)

    def _profile_integral(self, reach: float) -> float:
        """B(r) = int_0^r b(u) du [m2] of the centred profile."""
        u = max(reach - self.flat_width, 0.0)
        if self.deadrise > 0.0:
            return u**2 * self.tan_deadrise / 2.0
        p = self.body_p
        return u ** (p + 1.0) / ((p + 1.0) * p * self.R ** (p - 1.0))

    @property
    def free_body(self) -> bool:
        """True for a body of finite mass (its speed is then part of the solution)."""
        return math.isfinite(self.body_mass)

    @property
    def stage_duration(self) -> float:
        """``T = L^2 / (6 R V)``, the impact stage computed [s]; for any body shape and centre
        ``T = b_mean / V``, ``b_mean = (1/2L) int_-L^L b(x - x0) dx`` (docs/model.md, "Body
        shapes"; the parabola off centre: ``(L^2/3 + x0^2) / (2 R V)``)."""
        if self.duration > 0.0:
            return self.duration
        if self.parabola and not self.off_centre:
            return self.L**2 / (6.0 * self.R * self.V)
        return self.profile_mean() / self.V

    @property
    def d1(self) -> float:
        return self.deflection_scale / self.he

    @property
    def d2(self) -> float:
        return self.V * self.time_scale / self.he

    @property
    def d3(self) -> float:
        return self.L**2 / (2.0 * self.R * self.he)

    def replace(self, **changes) -> "Parameters":
        """A copy with some keys changed (validated again)."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        unknown = set(changes) - set(values)
        if unknown:
            raise ParameterError(f"unknown parameter {sorted(unknown)[0]!r}; known: {', '.join(values)}")
        values.update(changes)
        return Parameters(**values)

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}
