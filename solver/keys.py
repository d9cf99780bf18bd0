"""The study keys: every physical parameter's long name and units, the names a few of them take,
the values that are the paper's model, the ranges the model is meant for, and the bounds a value
must keep (solver.parameters checks a case against them; pipeline.common.variables writes them to
docs/parameters.md); the error a value outside them raises, and the checks shared with
solver.settings.
"""
from __future__ import annotations

import math

import numpy as np

from .model.layer import LAW_CODES

#: key -> (long_name, units) for every physical parameter.
PARAMETER_INFO = {
    "K": ("rigidity of the elastic layer", "Pa"),
    "he": ("thickness of the elastic layer", "m"),
    "R": ("radius of curvature of the body", "m"),
    "V": ("impact speed of the body", "m s-1"),
    "hi": ("ice thickness", "m"),
    "Nmod": ("number of retained normal modes", "1"),
    "L": ("half-length of the ice plate", "m"),
    "E": ("Young's modulus of ice", "Pa"),
    "nu": ("Poisson's ratio of ice", "1"),
    "rho_i": ("ice density", "kg m-3"),
    "rho_w": ("water density", "kg m-3"),
    "g": ("gravitational acceleration", "m s-2"),
    "H": ("water depth under the ice (inf: deep water, the paper's model)", "m"),
    "body_mass": ("mass of the body per unit width (inf: driven at the constant speed V, the paper's "
                  "model)", "kg m-1"),
    "body_g": ("downward acceleration of a free body besides the ice's reaction (gravity; 0 for a body "
               "whose weight is carried)", "m s-2"),
    "body_p": ("exponent p of the body's power-law profile (|x| - flat_width)^p / (p R^(p-1)) "
               "(2: the paper's parabola)", "1"),
    "flat_width": ("half-width of the body's flat bottom; its corners follow the profile beyond "
                   "(0: the paper's parabola)", "m"),
    "deadrise": ("deadrise angle of a wedge-shaped body, (|x| - flat_width) tan(deadrise) (0: not a "
                 "wedge; R and body_p are then unused)", "degree"),
    "tau": ("retardation time of the Kelvin-Voigt viscoelastic ice, D -> D (1 + tau d/dt) (0: elastic, "
            "the paper's)", "s"),
    "layer_tau": ("retardation time of the viscoelastic layer: pressure K f(delta) max(1 + layer_tau "
                  "d(delta)/dt, 0) where compressed (0: elastic, the paper's)", "s"),
    "x0": ("horizontal position of the body's centre, -L < x0 < L (0: the paper's centred impact)", "m"),
    "layer_law": ("law of the layer's pressure K f(delta): paper, f = delta / (1 - delta); linear, the "
                  "classical Winkler layer f = delta", ""),
    "edges": ("the plate's edges: walls, the paper's basin between sliding walls at x = +-L; free, a floe "
              "in open water with free edges", ""),
    "duration": ("length of the run (0: the walled plate's impact stage b_mean / V; a free floe needs it)",
                 "s"),
    "fracture": ("what the ice does where its tension reaches yield_strain: none, it stays whole (the paper's "
                 "model; crack onset is read from the tension records); break, it breaks through its thickness "
                 "there and the run goes on on the parts", ""),
    "yield_strain": ("yield strain of the ice, the tension at which it breaks (read with fracture = break; "
                     "8e-5: the paper's illustrative value)", "1"),
    "max_parts": ("most parts the whole plate may break into (read with fracture = break): a run that would "
                  "break into more ends with status parts_limit", "1"),
    "crack_spacing": ("shortest distance between two breaks, in ice thicknesses (read with fracture = break): "
                      "within it of a break the tension is not read and the ice does not break again (0: "
                      "none)", "1"),
    "crack_speed": ("speed at which a crack crosses the ice's thickness (read with fracture = break): a break's "
                    "faces carry the moment and shear the ice carried there, released over hi / crack_speed (inf: "
                    "at once)", "m s-1"),
    "edge_shapes": ("edge shapes at each free edge of a broken plate's parts (read with fracture = break): "
                    "boundary layers cosh, sinh(beta (x - c)) at beta = 1, 1/2, 1/4, 1/8 of the parts' largest "
                    "wavenumber, the first edge_shapes of them (a part too short for one: a shape of the whole part "
                    "in its place), which carry the bending a break leaves at its faces and an opening crack's "
                    "moment (0: none)", "1"),
}

#: the parameters only a run that breaks (fracture = "break") reads
BREAKING_KEYS = ("yield_strain", "max_parts", "crack_spacing", "crack_speed", "edge_shapes")

#: the parameters that are whole numbers
INTEGER_PARAMETERS = ("Nmod", "max_parts", "edge_shapes")

#: parameters that take one of a few names: key -> the names (each module of solver.model that
#: reads one declares its names)
CHOICES = {"layer_law": tuple(LAW_CODES), "edges": ("walls", "free"), "fracture": ("none", "break")}

#: parameters beyond the paper's model, with the value that is the paper's model: a case id
#: leaves them out at that value, so the ids of every study from before they existed hold
PAPER_DEFAULTS = {"H": math.inf, "body_mass": math.inf, "body_g": 9.81, "body_p": 2.0, "flat_width": 0.0,
                  "deadrise": 0.0, "tau": 0.0, "layer_tau": 0.0, "x0": 0.0, "layer_law": "paper", "edges": "walls",
                  "duration": 0.0, "fracture": "none", "yield_strain": 8e-5, "max_parts": 16,
                  "crack_spacing": 0.0, "crack_speed": math.inf, "edge_shapes": 0}

#: key -> (lowest, highest) value the model is meant for [units of PARAMETER_INFO]: floating
#: sea or lake ice and the bodies that strike it, with a wide margin. A study refuses values
#: outside (one line naming the range) unless it says ``accept_extreme_values = true``; the
#: solver itself takes any finite positive value. Besides: hi <= L (a plate, not a block).
PHYSICAL_RANGES = {
    "K": (1e3, 1e12), "he": (1e-5, 1.0), "R": (1e-2, 1e4), "V": (1e-3, 1e3), "hi": (1e-3, 100.0),
    "L": (0.1, 1e5), "E": (1e6, 1e12), "rho_i": (10.0, 1e5),
    "rho_w": (10.0, 1e5), "g": (1e-3, 1e3), "H": (1e-2, 1e5), "body_mass": (1e-2, 1e10),
    "body_g": (0.0, 1e3), "body_p": (1.0, 10.0), "flat_width": (0.0, 1e4), "deadrise": (0.0, 80.0),
    "tau": (0.0, 10.0), "layer_tau": (0.0, 10.0), "duration": (1e-6, 1e4),
    "yield_strain": (1e-6, 1e-1), "crack_spacing": (0.0, 100.0), "crack_speed": (1.0, 1e5),
    "edge_shapes": (0.0, 4.0),
}


def outside_physical_range(values: dict) -> str | None:
    """A one-line reason if a parameter lies outside PHYSICAL_RANGES (or hi > L), else None."""
    for key, value in values.items():
        lo, hi = PHYSICAL_RANGES.get(key, (None, None))
        if key in CHOICES or (key in PAPER_DEFAULTS and float(value) == PAPER_DEFAULTS[key]):
            continue                                       # H = inf: deep water; M = inf
        if lo is not None and not lo <= float(value) <= hi:
            unit = PARAMETER_INFO[key][1]
            return (f"{key} = {value!r} lies outside the range the model is meant for, {lo:g}..{hi:g} "
                    f"{unit}".rstrip())
    if "hi" in values and "L" in values and values["hi"] > values["L"]:
        return f"hi = {values['hi']!r} m is thicker than the plate's half-length L = {values['L']!r} m"
    return None


#: the allowed values of the keys beyond the paper: key -> (lowest, lowest excluded, inf allowed,
#: a note for the message)
BEYOND_BOUNDS = {
    "H": (0.0, True, True, "inf: deep water"),
    "body_mass": (0.0, True, True, "inf: the paper's body at constant speed"),
    "body_g": (0.0, False, False, ""),
    "body_p": (1.0, False, False, "a convex body"),
    "flat_width": (0.0, False, False, ""),
    "tau": (0.0, False, False, "0: elastic ice"),
    "layer_tau": (0.0, False, False, "0: elastic layer"),
    "duration": (0.0, False, False, "0: the walled plate's impact stage"),
    "yield_strain": (0.0, True, False, "a tension"),
    "crack_spacing": (0.0, False, False, "0: none, a break may follow next to another"),
    "crack_speed": (0.0, True, True, "inf: a crack opens at once"),
    "edge_shapes": (0.0, False, False, "0: none"),
}


class ParameterError(ValueError):
    """A parameter or setting with a value outside its allowed range."""


def check_bound(name: str, value, lowest: float, strict: bool, infinite: bool, note: str) -> None:
    """Refuse a value that is not a number, is NaN, lies below lowest (at it, when strict) or is
    infinite where that is not allowed: one line naming the key and its range."""
    number = not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating))
    v = float(value) if number else math.nan
    if number and not math.isnan(v) and (v > lowest if strict else v >= lowest) and (infinite or math.isfinite(v)):
        return
    bound = f"{'>' if strict else '>='} {lowest:g}"
    raise ParameterError(f"{name} must be {bound if infinite else 'finite and ' + bound}"
                         f"{f' ({note})' if note else ''}, got {value!r}")


def check_positive(name: str, value, integer: bool = False) -> None:
    """Refuse a value that is not a finite number > 0 (a positive integer, when integer)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(f"{name} must be a number, got {value!r}")
    if integer:
        whole = isinstance(value, (int, np.integer)) or (math.isfinite(float(value)) and float(value).is_integer())
        if not whole or int(value) < 1:
            raise ParameterError(f"{name} must be a positive integer, got {value!r}")
        return
    if not math.isfinite(float(value)) or float(value) <= 0.0:
        raise ParameterError(f"{name} must be finite and > 0, got {value!r}")
