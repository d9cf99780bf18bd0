"""One case of a study: the run it stands for (parameters, settings, output request) and the
time and x coordinates its outputs come on. Built by pipeline.study.identity.make_case; plain data
for a worker (``to_dict``)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from solver import PARAMETER_INFO, Parameters, Settings
from solver.axes import linear_axis, round_significant

@dataclass(frozen=True)
class Case:
    """One run of the solver: its parameters, settings and output request."""

    case_id: str
    index: tuple                    # position in the grid (or (i,) in a case list)
    parameters: Parameters
    settings: Settings
    times_spec: dict                # the [output] times table
    fields: tuple
    x_points: int
    end: str = "stage"              # [output] end
    body: bool = False              # store the body's position and speed (a study with a free body)
    outputs: tuple | None = None    # [output] outputs: what the run computes (None: every output)
    answer_eps_Y: float | None = None   # end "answered": the largest eps_Y whose crack onsets end the run
    break_slots: int = 0            # breaks stored along break_number (0: the study's cases do not break)

    @property
    def t_end(self) -> float:
        """End of the run [s]: the impact stage, or the last output time inside it; for a free
        body (finite body_mass) "last_output" is the last output time itself, and so is
        "separation" (the run may end earlier, at separation). The stage bounds the paper's
        body, which pushes on at V until the layer bottoms out; a free body has no such end.
        "answered" runs as "stage" for the paper's body and as "separation" for a free body (its
        separation is an answer too), ending earlier where its crack onsets are final."""
        stage = self.parameters.stage_duration
        last = float(self.times_seconds()[-1])
        free = self.parameters.free_body
        if self.end == "separation" or (self.end in ("last_output", "answered") and free):
            return last
        if self.end == "last_output":
            return min(stage, last)
        return stage

    def run_options(self) -> dict:
        """solve's keywords for how the run ends and what it computes."""
        answered = self.end == "answered"
        separation = self.end == "separation" or (answered and self.parameters.free_body)
        return {"until_separation": separation, "outputs": self.outputs,
                "eps_Y": [self.answer_eps_Y] if answered else None, "end": "answered" if answered else "stage"}

    def value(self, key):
        """A parameter or a solver setting of the case, by its study-file key."""
        if key in PARAMETER_INFO:
            return getattr(self.parameters, key)
        return getattr(self.settings, key)

    def requested_times(self) -> np.ndarray:
        """Output times in units of the study's time coordinate (t_sc or stage fraction)."""
        return coordinate_times(self.times_spec)

    def times_seconds(self) -> np.ndarray:
        """Requested times in seconds for this case (some may lie past its stage)."""
        t = coordinate_times(self.times_spec)
        p = self.parameters
        unit = self.times_spec["unit"]
        scale = p.time_scale if unit == "t_sc" else 1.0 if unit == "s" else p.stage_duration
        return t * scale

    def to_dict(self) -> dict:
        """Plain data for a worker (no numpy, no classes)."""
        return {"case_id": self.case_id, "index": list(self.index),
                "parameters": self.parameters.as_dict(), "settings": self.settings.as_dict(),
                "times_spec": self.times_spec, "fields": list(self.fields), "x_points": self.x_points,
                "end": self.end, "body": self.body, "outputs": None if self.outputs is None else list(self.outputs),
                "answer_eps_Y": self.answer_eps_Y, "break_slots": self.break_slots}

    @staticmethod
    def from_dict(d: dict) -> "Case":
        return Case(d["case_id"], tuple(d["index"]), Parameters(**d["parameters"]),
                    Settings(**d["settings"]), d["times_spec"], tuple(d["fields"]), d["x_points"],
                    d.get("end", "stage"), d.get("body", False),
                    None if d.get("outputs") is None else tuple(d["outputs"]), d.get("answer_eps_Y"),
                    d.get("break_slots", 0))


def coordinate_times(spec: dict) -> np.ndarray:
    """The output times in the unit of the request, rounded to 12 significant digits (the same
    on every CPU, and 0.6 rather than 0.6000000000000001: solver.axes)."""
    if spec["unit"] in ("t_sc", "s"):
        n = int(math.floor(spec["stop"] / spec["step"] + 1e-9))
        return round_significant(np.round(np.arange(n + 1) * spec["step"], 12))
    return linear_axis(0.0, 1.0, spec["count"])


def x_fractions(x_points: int) -> np.ndarray:
    """The positions of the fields as fractions of L, -1..1 (the study's x coordinate where L
    varies between cases)."""
    return linear_axis(-1.0, 1.0, x_points)


def x_positions(x_points: int, L: float) -> np.ndarray:
    """The positions of the fields [m], -L..L, rounded to 12 significant digits (0.5, not
    0.49999999999999994: solver.axes): where the fields are evaluated, and the study's x
    coordinate where all cases share L."""
    return round_significant(x_fractions(x_points) * L)
