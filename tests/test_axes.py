"""Axes the code makes are the same on every CPU (solver.axes): decades exact, each value the
double nearest its short decimal, whatever the last bits of the CPU's pow or exp."""
import numpy as np
import pytest

from pipeline.study.case import coordinate_times, x_positions
from pipeline.study.definition import load_study_text
from solver import default_eps_Y
from solver.axes import linear_axis, log_axis, round_significant


def _another_cpu(values, ulps):
    """values as another CPU's transcendental functions might give them: ulps away."""
    out = np.asarray(values, dtype=float).copy()
    for _ in range(abs(ulps)):
        out = np.nextafter(out, np.inf if ulps > 0 else -np.inf)
    return out


def test_default_eps_Y_has_exact_decades_and_the_papers_value():
    eps = default_eps_Y()
    assert eps.size == 42 and eps.min() == 1e-5 and eps.max() == 1e-1 and 8e-5 in eps
    for decade in (1e-5, 1e-4, 1e-3, 1e-2, 1e-1):
        assert decade in eps
    assert all(v == float(f"{v:.12g}") for v in eps)


@pytest.mark.parametrize("ulps", [-3, -1, 1, 3])
def test_rounding_absorbs_another_cpus_last_bits(ulps):
    """np.logspace(-5, -1, 41)[0] was 9.999999999999999e-06 with numpy's AVX-512 power: a few
    ulps from the decimal. The rounding lands every such value on the same double."""
    raw = 10.0 ** np.linspace(-5, -1, 41)
    np.testing.assert_array_equal(round_significant(_another_cpu(raw, ulps)), round_significant(raw))
    lin = np.linspace(-1.0, 1.0, 25)
    np.testing.assert_array_equal(round_significant(_another_cpu(lin[lin != 0], ulps)),
                                  round_significant(lin[lin != 0]))


def test_generated_axes_are_decimal():
    assert list(linear_axis(0.0, 1.0, 6)) == [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]       # not 0.6000000000000001
    assert list(log_axis(1e-5, 1e-3, 3)) == [1e-5, 1e-4, 1e-3]
    assert list(coordinate_times({"unit": "t_sc", "step": 0.1, "stop": 0.3})) == [0.0, 0.1, 0.2, 0.3]
    assert 0.5 in x_positions(25, 6.0) and x_positions(25, 6.0)[13] == 0.5       # not 0.49999999999999994
    assert round_significant([0.0, np.inf, -np.inf]).tolist() == [0.0, np.inf, -np.inf]


def test_a_study_eps_Y_range_is_decimal():
    study = load_study_text('[base]\nNmod = 4\n[grid]\nV = [5.0]\n[output]\n'
                            'eps_Y = { min = 1e-5, max = 1e-1, count = 5 }\n', "axes")
    assert study.output.eps_Y == (1e-5, 1e-4, 1e-3, 1e-2, 1e-1)
