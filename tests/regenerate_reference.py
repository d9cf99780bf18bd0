"""Rebuild tests/data/regression_small.nc and its spread from studies/regression_small.toml.

Run only after a deliberate change of the numbers (make regenerate-reference), and say why in
the commit. It writes:

- ``regression_small.nc``: the study at its tolerance, 1e-11 (the file carries, like every
  study.nc, the CPU, numpy's SIMD dispatch, numba's target CPU and the library versions it was
  made with);
- ``regression_small_spread.nc``: for every variable and case, the largest difference over
  (t, x, eps_Y) between five runs at 0.8, 0.9, 1.0, 1.1 and 1.25 times that tolerance. A change
  of round-off (another CPU, another numba target) moves an adaptive run's step sequence, and so
  its results, by as much as such a change of tolerance does; tests/reference.py compares a new
  run with the reference within SPREAD_FACTOR of this spread.
"""
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
STUDY = ROOT / "studies" / "regression_small.toml"
TOLERANCE = 1e-11
FACTORS = (0.8, 0.9, 1.0, 1.1, 1.25)
CASE_DIMS = ("V", "hi")


def run(text: str, tmp: Path, name: str) -> Path:
    study = tmp / f"{name}.toml"
    study.write_text(text)
    out = tmp / name
    code = subprocess.call([sys.executable, "-m", "pipeline", "run", str(study), "--out", str(out),
                            "--workers", "2", "--no-plots"], cwd=ROOT)
    if code != 0:
        sys.exit(f"the regression study at {name} did not end ok (exit {code})")
    return out / "study.nc"


def spread(paths: list, reference: xr.Dataset) -> xr.Dataset:
    """max - min over the runs of every numeric variable, largest over its non-case dims."""
    runs = [xr.open_dataset(p) for p in paths]
    out = {}
    for name, var in reference.data_vars.items():
        if var.dtype.kind in "OUS" or name.startswith("tension_record"):
            continue
        if len({r[name].shape for r in runs}) > 1:
            sys.exit(f"{name} has another shape in one of the runs: it cannot be compared within a spread")
        stack = np.stack([r[name].values for r in runs])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)          # all-NaN slices: never reached
            width = np.nanmax(stack, axis=0) - np.nanmin(stack, axis=0)
        width = np.where(np.isnan(width), 0.0, width)
        cased = set(CASE_DIMS) <= set(var.dims)           # else a ragged record: one spread for all
        other = tuple(range(len(CASE_DIMS), width.ndim)) if cased else tuple(range(width.ndim))
        per_case = width.max(axis=other) if other else width
        out[name] = (CASE_DIMS if cased else (), per_case, {"long_name": f"spread of {name} over tolerances "
                                                        f"{', '.join(f'{f:g}' for f in FACTORS)} x 1e-11",
                                           "units": var.attrs.get("units", "1")})
    for r in runs:
        r.close()
    coords = {d: reference[d].values for d in CASE_DIMS}
    attrs = {k: v for k, v in reference.attrs.items() if k.startswith(("cpu_", "version_", "git_", "created"))}
    return xr.Dataset(out, coords=coords, attrs=attrs)


def main():
    text = STUDY.read_text()
    line = "tolerance = 1e-11"
    if line not in text:
        sys.exit(f"{STUDY} no longer sets {line!r}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        paths = {f: run(text.replace(line, f"tolerance = {f * TOLERANCE!r}") if f != 1.0 else text, tmp, f"x{f:g}" if f != 1.0 else "regression_small")
                 for f in FACTORS}
        DATA.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(paths[1.0], DATA / "regression_small.nc")
        with xr.open_dataset(DATA / "regression_small.nc") as ref:
            spread(list(paths.values()), ref).to_netcdf(DATA / "regression_small_spread.nc")
    for name in ("regression_small.nc", "regression_small_spread.nc"):
        print(f"wrote {(DATA / name).relative_to(ROOT)}")


if __name__ == "__main__":
    main()
