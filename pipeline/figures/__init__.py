"""study.nc -> the figures and reports in a study's results directory.

One registry of plot kinds (``KINDS``): the files each writes, whether it is for a [design]
(samples) or a sweep (a [grid] or [[cases]]), and the function that draws it, ``draw(ds, dims,
out_dir) -> (paths written, note or "")``, in the module of its family:

- ``sweeps``: the diagnostics against the swept keys, crack onset against the yield strain;
- ``drop``: a dropped body against its mass;  ``paper``: the paper's Fig. 2;
- ``design``: a design's points, its sensitivity indices and emulator, a search's critical values;
- ``reports``: the numerics studies' reports (work_precision, extremes).

The study file's validation and the runner read the registry; it imports no matplotlib (the
figure modules do, when a figure is drawn).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Kind:
    """A plot kind: the files it writes, whether it is a design's, and where it is drawn."""

    files: tuple
    draw: str                      # "module.function" in pipeline.figures
    for_design: bool = False       # drawn for a [design]'s samples, not for a sweep


KINDS = {
    "diagnostics": Kind(("diagnostics.png",), "sweeps.draw_diagnostics"),
    "crack_onset": Kind(("crack_onset.png",), "sweeps.draw_crack_onset"),
    "paper_fig2": Kind(("paper_fig2.png",), "paper.draw"),
    "work_precision": Kind(("work_precision.png", "work_precision.md"), "reports.draw_work_precision"),
    "extremes": Kind(("extremes.md",), "reports.draw_extremes"),
    "drop": Kind(("drop.png",), "drop.draw"),
    "design": Kind(("design.png",), "design.draw_design", for_design=True),
    "sensitivity": Kind(("sensitivity.png",), "design.draw_sensitivity", for_design=True),
    "emulator": Kind(("emulator.png",), "design.draw_emulator", for_design=True),
}


def make_plots(ds, dims: list, kinds: list, out_dir: Path) -> tuple:
    """The figures a study asks for; returns the paths written and a note per figure skipped."""
    out_dir = Path(out_dir)
    written, notes = [], []
    for name in kinds:
        kind = KINDS[name]
        if kind.for_design != (dims == ["sample"]):
            notes.append(f"{name} figure needs a [design]: skipped" if kind.for_design else
                         f"{name} figure is for a [grid] or [[cases]]; a [design] draws \"design\": skipped")
            continue
        module, function = kind.draw.split(".")
        paths, note = getattr(importlib.import_module(f"{__name__}.{module}"), function)(ds, dims, out_dir)
        written += paths
        if note:
            notes.append(note)
    return written, notes
