"""Every physics option composes with every other, and with each integrator and quadrature
(issue 38; docs/model.md, "What composes with what").

The whole matrix at small settings (6 modes, 4 ms, the contact-resolving rule on 64
subintervals, the paper's on 1000): each pair of options, and each option under each integrator
(etd34 under both error controls) and quadrature, either runs to ok or to a status of the model (the layer bottoming out, a body
leaving the ice), with the energy identity, or is refused in one line for a reason docs/model.md
states. The refusals and numerical failures the matrix has are listed here exactly: a new one,
or one that went away, fails the test.
"""
import itertools

import pytest

from helpers import BASE, NUMERICS, OPTIONS, SUBINTERVALS
from solver import Parameters, ParameterError, Settings, solve

MODEL_STATUSES = {"ok", "layer_bottomed_out", "separated", "stopped"}
#: the energy identity's residual (of the work) allowed: the time integration's under the
#: contact-resolving rule; under the paper's its dx^2 (measured up to 1.9e-4 here)
RESIDUAL = {"gauss": 1e-5, "paper": 1e-3}

#: refusals, each with the words of its one line; all physical: rk4 integrates the paper's
#: elastic equations, not damped modes
REFUSED = {("viscoelastic_ice", "rk4/gauss"): "rk4 integrates the paper's elastic plate",
           ("viscoelastic_ice", "rk4/paper"): "rk4 integrates the paper's elastic plate",
           ("viscoelastic_layer", "rk4/gauss"): "rk4 integrates the paper's elastic plate",
           ("viscoelastic_layer", "rk4/paper"): "rk4 integrates the paper's elastic plate"}
#: runs that end in a numerical failure, with its status: none. (The paper's rule under rk4's
#: fixed step on a power-law body, p = 4, broke the energy guard at its first step until the guard
#: allowed the whole work of the step from first touch under either rule: docs/model.md, "What
#: composes with what".)
FAILS = {}

COMBOS = ([(f"{a}+{b}", (a, b), {**OPTIONS[a], **OPTIONS[b]}, {}) for a, b in itertools.combinations(OPTIONS, 2)]
          + [(f"{a}+{n}", (a, n), OPTIONS[a], NUMERICS[n]) for a in OPTIONS for n in NUMERICS])


@pytest.mark.parametrize("key, options, numerics", [c[1:] for c in COMBOS], ids=[c[0] for c in COMBOS])
def test_every_pair_composes(key, options, numerics):
    quadrature = numerics.get("quadrature", "gauss")
    settings = dict(numerics, subintervals=SUBINTERVALS[quadrature], tolerance=1e-8, error_estimate=False)
    try:
        r = solve(Parameters(**BASE, **options), Settings(**settings), fields=())
    except ParameterError as err:
        assert key in REFUSED, f"refused: {err}"
        assert REFUSED[key] in str(err) and "\n" not in str(err)
        return
    assert key not in REFUSED, "runs now: take it off REFUSED"
    if key in FAILS:
        assert r.status == FAILS[key], f"{r.status}: take it off FAILS"
        return
    assert r.status in MODEL_STATUSES, r.message
    assert r.diagnostics["energy_residual"] < RESIDUAL[quadrature]


@pytest.mark.parametrize("power", [3.0, 4.0, 6.0])
def test_a_fixed_step_from_first_touch_on_a_flat_body_keeps_the_energy_guard(power):
    """A power-law body spreads its contact over many of the paper's nodes in a fixed first step,
    while the step's stages miss a fixed fraction of its work (the force grows like t^(1 + 1/p)):
    the guard allows that step's whole work under either rule (solver.control.energy_allowance),
    and the run's residual ends far below the bound (measured 4e-7 to 1.6e-6). These stopped
    with energy_violation at the first step before."""
    for quadrature in ("paper", "gauss"):
        r = solve(Parameters(**BASE, body_p=power),
                  Settings(integrator="rk4", quadrature=quadrature, subintervals=SUBINTERVALS[quadrature],
                           error_estimate=False), fields=())
        assert r.status == "ok", r.message
        assert r.diagnostics["energy_residual"] < 1e-5
