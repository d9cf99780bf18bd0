"""benchmarks/first_compile.py, which CI runs to print the first compile beside the README's
number: it reads the README's claim, and says when a measurement is well above it."""
import importlib.util

import pytest

from helpers import ROOT

spec = importlib.util.spec_from_file_location("first_compile", ROOT / "benchmarks" / "first_compile.py")
first_compile = importlib.util.module_from_spec(spec)
spec.loader.exec_module(first_compile)


def test_it_reads_the_readmes_number():
    stated = first_compile.readme_seconds()
    assert 1.0 < stated < 600.0
    assert first_compile.readme_seconds("kernels once (23 s here with an\n  empty cache, in two") == 23.0
    with pytest.raises(SystemExit, match="README_CLAIM"):
        first_compile.readme_seconds("the kernels compile quickly")


def test_it_says_when_the_compile_grew_past_the_readme():
    assert "above it" not in first_compile.verdict([24.0, 26.9], 23.0)
    line = first_compile.verdict([37.4], 23.0)
    assert "37.4" in line and "README.md says 23 s" in line and "63% above it" in line
