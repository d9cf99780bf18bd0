"""Rebuild tests/data/regression_small.nc from studies/regression_small.toml.

Run only after a deliberate change of the numbers (make regenerate-reference), and say why in
the commit. The regression test compares a fresh run with this file to 1e-6 of each value or
5e-6 of the variable's scale (tests/test_pipeline.py, assert_matches).
"""
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main():
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "regression_small"
        code = subprocess.call([sys.executable, "-m", "pipeline", "run", "studies/regression_small.toml",
                                "--out", str(out), "--workers", "2", "--no-plots"], cwd=ROOT)
        if code != 0:
            sys.exit(f"the regression study did not end ok (exit {code})")
        target = ROOT / "tests" / "data" / "regression_small.nc"
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(out / "study.nc", target)
        print(f"wrote {target.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
