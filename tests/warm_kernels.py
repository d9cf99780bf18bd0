"""Kernels the tests call from Python, compiled by ``python tests/warm_kernels.py`` while the
controller compiles integrate (tests/conftest.py): each is compiled whole on its first call from
Python (solver/compile/jit.py), and a test that makes the first call waits for it. The calls here take
the argument types the tests use; a kernel a test calls with other types is compiled in that
test, as before."""
import numpy as np

from solver import Parameters, Settings, solve
from solver.model.assemble import Tables
from solver.compile.parallel_compile import claiming
from solver.model.layer import layer_energy, layer_forcing_at, layer_forcing_strain, rule_energy


def compile_reference() -> None:
    """The model's kernels the DOP853 reference calls from Python, on a tiny run."""
    p = Parameters(Nmod=2)
    solve(p, Settings(integrator="dop853"), times=[0.0, p.stage_duration])


def compile_pieces() -> None:
    """The layer's forcing, strain and energy under both rules, as the quadrature tests call them."""
    p = Parameters(Nmod=2)
    a = np.zeros(p.Nmod)
    for rule in ("paper", "gauss"):
        tab = Tables(p, 16, quadrature=rule)
        J = tab.xq.size
        delta, fvals = np.empty(J), np.empty(J)
        layer_forcing_at(tab.model, 0.0, p.V, a, a, delta, fvals, np.empty(p.Nmod))
        _, _, jmax, _ = layer_forcing_strain(tab.model, 0.0, p.V, a, a, delta, fvals, np.empty(p.Nmod),
                                              np.empty(J))
        rule_energy(tab.model, fvals)
        layer_energy(tab.model, a, 0.0, delta, jmax)


if __name__ == "__main__":
    with claiming():                 # what compile_kernels' processes compile, this one links
        compile_reference()          # (crack onset: compile_kernels' own helper process compiles it)
        compile_pieces()
