"""The solver's numerical settings (:class:`Settings`): the integrator, its tolerance and the
forcing's quadrature, each with its long name and units in :data:`SETTING_INFO`; and the
combinations of parameters and settings that do not go together (:func:`check_combination`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

from .keys import ParameterError, check_positive

if TYPE_CHECKING:
    from .parameters import Parameters

#: key -> (long_name, units) for every solver setting.
SETTING_INFO = {
    "integrator": ("time integrator (etd34: adaptive exponential; rk4: the paper's fixed-step RK4; "
                   "dop853: scipy's DOP853, the outside reference)", ""),
    "tolerance": ("relative error tolerance per step (etd34: energy norm; dop853: rtol)", "1"),
    "subintervals": ("subintervals of [0, L] between the nodes of the basis's table (the paper's "
                     "quadrature integrates over them; the contact-resolving one finds the contact "
                     "intervals on them)", "1"),
    "quadrature": ("the forcing's quadrature (paper: f linear between the nodes; gauss: Gauss-Legendre "
                   "panels on the located contact intervals)", ""),
    "quadrature_density": ("Gauss-Legendre nodes per wavelength of the last mode, 2 pi / lambda_N, "
                           "of the gauss quadrature", "1"),
    "rk4_step_fraction": ("rk4 step as a fraction of the period of the last mode, 2 pi / omega_N", "1"),
    "fixed_step": ("fixed step of etd34 in units of t_sc (0: adaptive)", "1"),
    "max_steps": ("largest number of attempted steps before the run stops with step_limit", "1"),
    "bottoming_gap": ("the layer bottoms out when its gap closes to this fraction of its thickness "
                      "(pressure K / bottoming_gap); smaller: a deeper but less robust criterion", "1"),
    "error_estimate": ("estimate the strain error of each run (etd34: a companion run at 10x the "
                       "tolerance and without observers, about +45% cost)", ""),
    "impact_zone_margin": ("how far the impact zone reaches beyond the farthest point the contact has reached "
                           "(docs/model.md, \"Maxima of the impact zone\")", "m"),
    "error_control": ("what judges an adaptive etd34 step (embedded: its embedded 4(3) estimate; smoothness: "
                      "that and the forcing's smoothness over the step and the one before, docs/model.md, "
                      "\"Numerics\")", ""),
}

INTEGRATORS = ("etd34", "rk4", "dop853")
QUADRATURES = ("paper", "gauss")
ERROR_CONTROLS = ("embedded", "smoothness")
#: the settings that take one of a few names (a study's [solver] and [grid] check them so)
NAMED_SETTINGS = {"integrator": INTEGRATORS, "quadrature": QUADRATURES, "error_control": ERROR_CONTROLS}
#: the paper's rule at its 1000 subintervals and tolerance 1e-8, the defaults before issue 24:
#: Settings(**PAPER_NUMERICS) reproduces those runs bit for bit, and their case ids
PAPER_NUMERICS = {"quadrature": "paper", "subintervals": 1000, "tolerance": 1e-8, "error_control": "embedded"}
#: the default tolerance: under etd34's smoothness control (the default) a run's error is about
#: its tolerance, and 3e-7 puts the reference case at N = 60 within 1e-6 of the continuous-x
#: model (8.4e-7) in 1.03x the time the embedded control took at 1e-9 for 1.3e-6
#: (docs/performance.md, "Error control"); the embedded control's estimate understates a step's
#: error, and its default stays the 1e-9 of the runs before the smoothness control was the
#: default (their case ids hold); DOP853's rtol stays 1e-9
DEFAULT_TOLERANCE = {"smoothness": 3e-7, "embedded": 1e-9}


def default_tolerance(integrator: str, error_control: str) -> float:
    """The tolerance a run takes when none is given: DEFAULT_TOLERANCE of etd34's error control
    (rk4 reads none), 1e-9 for DOP853."""
    return DEFAULT_TOLERANCE[error_control] if integrator == "etd34" else 1e-9


#: largest subintervals accepted (memory: the tables are Nmod x subintervals doubles; time: a
#: case's cost grows as subintervals^1.5 beyond 25 000, measured at 8 modes over the reference
#: stage: 2.2 s at 25 000, 11.9 s at 100 000, 68 s at 300 000; 10^6, the limit before, gave no
#: answer within 600 s)
MAX_SUBINTERVALS = 100_000


@dataclass(frozen=True)
class Settings:
    """Numerical settings of one run.

    The defaults (etd34 under its smoothness control at tolerance 3e-7, the Gauss rule at 4
    nodes a wavelength on a table of 250 subintervals) were chosen by measurement
    (docs/numerics.md, "The quadrature"; docs/performance.md, "Error control"): on the reference
    case at N = 60 their strain error against the continuous-x model is 8.4e-7, in the time the
    embedded control at 1e-9 (the default from issue 24 to 2026-11-28) took for 1.3e-6, and the
    paper's rule for 1.2e-5 at its 1000 subintervals and tolerance 1e-8, the defaults before
    issue 24. ``Settings(**PAPER_NUMERICS)`` reproduces those runs bit for bit, and their case
    ids; ``Settings(error_control="embedded")`` those of the default before 2026-11-28.

    Parameters
    ----------
    integrator : "etd34" (default: adaptive exponential Runge-Kutta 4(3), Krogstad stages)
        or "rk4" (the paper's classical RK4 with a fixed step), or "dop853" (scipy's DOP853 on
        the same right-hand side, rtol = tolerance; no in-loop diagnostics).
    tolerance : relative error per step of etd34, measured in the energy norm, or DOP853's
        rtol [1]. None (the default): 3e-7 under etd34's smoothness control, 1e-9 under its
        embedded one and for DOP853 (``DEFAULT_TOLERANCE``).
    subintervals : subintervals of [0, L] between the nodes of the basis's table (the paper:
        1000): the paper's quadrature integrates over them, the contact-resolving one finds
        the contact intervals and the events on them, and strain observers run on them [1].
    quadrature : the forcing's quadrature: "paper" (f linear between the nodes, the paper's
        rule) or "gauss" (Gauss-Legendre panels on the contact intervals, located on the
        modes; docs/model.md, "Numerics").
    quadrature_density : Gauss-Legendre nodes per wavelength of the last mode, 2 pi /
        lambda_N, of the "gauss" quadrature [1].
    rk4_step_fraction : rk4 step = fraction * 2 pi / omega_N (the paper: 1/20) [1].
    fixed_step : if > 0, etd34 takes this fixed step, in units of t_sc, with no error
        control (for convergence-order studies) [1].
    max_steps : attempted steps after which a run stops with status ``step_limit`` [1].
    error_estimate : estimate the relative strain error of the run (see
        ``solver.error_estimate.error_estimates``); for etd34 this runs a companion at 10x the tolerance.
    bottoming_gap : the layer bottoms out when its gap he (1 - delta) first closes to this
        fraction of he anywhere on the plate (docs/model.md, "Bottoming out") [1].
    impact_zone_margin : the impact zone, whose tension maxima are reported apart from the
        plate-wide ones, reaches this far beyond the farthest point from the body's centre that
        the contact has reached so far (docs/model.md, "Maxima of the impact zone") [m]. An
        observer's setting: the run's state does not depend on it.
    error_control : what judges an adaptive etd34 step: "smoothness" (default: its embedded
        4(3) estimate and the forcing's smoothness over the step and the one before, which sees
        the error of the modes that oscillate once or more inside a step: the run's error then
        falls in proportion to the tolerance) or "embedded" (the embedded estimate alone, the
        default until 2026-11-28) (docs/model.md, "Numerics"; docs/performance.md, "Error
        control").
    """

    integrator: str = "etd34"
    tolerance: float | None = None
    subintervals: int = 250
    quadrature: str = "gauss"
    quadrature_density: float = 4.0
    rk4_step_fraction: float = 0.05
    fixed_step: float = 0.0
    max_steps: int = 500_000
    error_estimate: bool = True
    bottoming_gap: float = 1e-3
    impact_zone_margin: float = 1.0
    error_control: str = "smoothness"

    def __post_init__(self):
        if self.integrator not in INTEGRATORS:
            raise ParameterError(
                f"integrator must be one of {', '.join(INTEGRATORS)}, got {self.integrator!r}")
        if self.error_control not in ERROR_CONTROLS:
            raise ParameterError(
                f"error_control must be one of {', '.join(ERROR_CONTROLS)}, got {self.error_control!r}")
        if self.tolerance is None:
            object.__setattr__(self, "tolerance", default_tolerance(self.integrator, self.error_control))
        check_positive("tolerance", self.tolerance)
        if self.tolerance >= 1.0:
            raise ParameterError(f"tolerance must be < 1, got {self.tolerance!r}")
        check_positive("subintervals", self.subintervals, integer=True)
        if not 8 <= int(self.subintervals) <= MAX_SUBINTERVALS:
            raise ParameterError(f"subintervals must be between 8 and {MAX_SUBINTERVALS}, got {self.subintervals!r}")
        if self.quadrature not in QUADRATURES:
            raise ParameterError(f"quadrature must be one of {', '.join(QUADRATURES)}, got {self.quadrature!r}")
        check_positive("quadrature_density", self.quadrature_density)
        if not 1.0 <= float(self.quadrature_density) <= 1000.0:
            raise ParameterError(f"quadrature_density must be between 1 and 1000, got {self.quadrature_density!r}")
        check_positive("rk4_step_fraction", self.rk4_step_fraction)
        if isinstance(self.fixed_step, bool) or not isinstance(
                self.fixed_step, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(self.fixed_step)) or float(self.fixed_step) < 0.0:
            raise ParameterError(f"fixed_step must be finite and >= 0, got {self.fixed_step!r}")
        check_positive("max_steps", self.max_steps, integer=True)
        check_positive("bottoming_gap", self.bottoming_gap)
        if not 1e-12 <= float(self.bottoming_gap) <= 0.5:
            raise ParameterError(f"bottoming_gap must be between 1e-12 and 0.5, got {self.bottoming_gap!r}")
        if isinstance(self.impact_zone_margin, bool) or not isinstance(
                self.impact_zone_margin, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(self.impact_zone_margin)) or float(self.impact_zone_margin) < 0.0:
            raise ParameterError(f"impact_zone_margin must be finite and >= 0 [m], got {self.impact_zone_margin!r}")
        if not isinstance(self.error_estimate, bool):
            raise ParameterError(f"error_estimate must be true or false, got {self.error_estimate!r}")
        for name in ("tolerance", "rk4_step_fraction", "fixed_step", "bottoming_gap", "quadrature_density",
                     "impact_zone_margin"):
            object.__setattr__(self, name, float(getattr(self, name)))
        for name in ("subintervals", "max_steps"):
            object.__setattr__(self, name, int(getattr(self, name)))

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def check_combination(parameters: Parameters, settings: Settings) -> None:
    """Refuse parameters and settings that are each valid but do not go together (one line)."""
    if (parameters.tau > 0 or parameters.layer_tau > 0) and settings.integrator == "rk4":
        raise ParameterError("rk4 integrates the paper's elastic plate and layer; viscoelastic ice or layer "
                             "(tau, layer_tau > 0) needs etd34 (its damped modes are exact) or dop853")
    if parameters.fracture == "break" and math.isfinite(parameters.crack_speed) and settings.integrator != "etd34":
        raise ParameterError("a crack that opens over a time (crack_speed < inf) needs etd34: its fracture's "
                             "dissipated energy is taken on etd34's stages")
    if parameters.fracture == "break" and settings.quadrature != "gauss":
        raise ParameterError("fracture = 'break' needs quadrature = 'gauss': the paper's rule interpolates the "
                             "modes between nodes, across a break")
