"""A floe broken into parts (solver/model/floe_parts.py; docs/model.md, "A floe breaks"): the water
its parts share (the half-plane's, phi = 0 on the open surface), the state carried across a break
from the unbroken floe's wet modes, and a run in which a floe breaks."""
import math

import numpy as np
import pytest

from helpers import assert_breaking_consistent
from solver import Parameters, Settings, solve
from solver.model import floe as fl, floe_parts, parts

EPS_Y = 8e-5


def _whole_floe_as_one_part(p, full):
    """The unbroken floe's dry modes (solver.model.floe) as one part's PartModes, in kernel
    coordinates, and the floe's own added mass of them."""
    kinds, betas = fl.dry_modes(p.L, p.Nmod, full)
    norms = 1.0 / np.sqrt(fl.exact_norms(kinds, p.L) / (2.0 * p.L))
    n, domain = kinds.size, (2.0 if full else 1.0) * p.L
    modes = parts.PartModes(kinds, betas, np.full(n, p.L if full else 0.0), np.full(n, p.L), np.zeros(n),
                            np.full(n, domain), norms, np.zeros(n, dtype=int))
    return modes, fl.added_mass(kinds, betas, p.L, p.rho_w, norms, p.H)


@pytest.mark.parametrize("full, H", [(False, math.inf), (True, math.inf), (True, 2.0)])
def test_the_unbroken_floe_as_one_part_has_the_floes_added_mass(full, H):
    """The parts' added mass (Gauss-Legendre in t, and the jumps' tail, here none: the modes are
    0 only at the floe's edges, where sin t = 0) of the unbroken floe's modes is the floe's own
    (solver.model.floe.added_mass, the trapezoid rule on their sine coefficients), deep and on
    2 m of water, within 1e-12 of its largest entry (2e-15 measured, deep)."""
    p = Parameters(Nmod=20, edges="free", duration=0.01, H=H)
    modes, A = _whole_floe_as_one_part(p, full)
    ours = floe_parts.floe_added_mass(modes, p.L, full, p.rho_w, p.H)
    assert np.max(np.abs(ours - A)) < 1e-12 * np.max(np.abs(A))


def test_the_tail_makes_the_series_converge_and_the_halves_heave_as_the_floe():
    """A floe broken at 4 and 8.5 m of its 12 (the whole floe, N = 20): the parts' modes jump to 0
    at the breaks, their coefficients fall as 1 / k, and the series to K terms misses 3.8e-5 of
    the largest entry without its tail. With the tail to second order the result moves by 1e-7,
    3.5e-9, 1.7e-10 from K = 256, 512, 1024 to 4096 (about K^-4.5; K = 256 and 512 tested against
    2048, within 3e-7 and 1e-8). Broken at the centre, the two halves' heaves together are the floe's heave: the sum
    of their 2 x 2 block is rho_w pi L^2 / 2 within 1e-10."""
    p = Parameters(Nmod=20, edges="free", duration=0.01)
    L = p.L
    modes = parts.part_modes(2 * L, [4.0, 8.5], math.pi * p.Nmod / L, 0, (False, False))
    at = {}
    original = floe_parts.FLOE_TERMS
    try:
        for K in (256, 512, 2048):
            floe_parts.FLOE_TERMS = K
            at[K] = floe_parts.floe_added_mass(modes, L, True, p.rho_w)
        floe_parts.FLOE_TERMS = 256
        P = floe_parts.sine_rows(modes, L, True, 256)
        bare = p.rho_w * L * L * (np.pi / 2.0) * (P / np.arange(1, 257)) @ P.T
    finally:
        floe_parts.FLOE_TERMS = original
    largest = np.max(np.abs(at[2048]))
    assert np.max(np.abs(bare - at[2048])) > 1e-5 * largest
    for K, bound in ((256, 3e-7), (512, 1e-8)):
        assert np.max(np.abs(at[K] - at[2048])) < bound * largest, K
    halves = parts.part_modes(2 * L, [L], math.pi * p.Nmod / L, 0, (False, False))
    A = floe_parts.floe_added_mass(halves, L, True, p.rho_w)
    heave = np.flatnonzero(halves.kinds == fl.HEAVE)
    assert heave.size == 2
    assert np.sum(A[np.ix_(heave, heave)]) == pytest.approx(p.rho_w * math.pi * L**2 / 2.0, rel=1e-10)


def test_a_floe_breaks_into_parts_on_the_half_and_the_whole_floe():
    """A floe of the reference case's size (12 m) under the paper's body, N = 20, 2 ms: it breaks
    at its centre (lower surface, 0.5137 ms), then at 0.32 m (upper surface, 0.6391 ms: the body
    through), and twice more; the whole floe (full_plate=True) breaks at the same times, each
    break off the centre with its mirror: the breakthrough's pair within 1e-9 of the half floe's
    time and 1e-8 L of its place, the later pairs within 1e-5 (8e-7 and 3.5e-7 L measured: the
    two adaptive runs' own error, grown through three carries). E_plate + E_layer + D + R = W through every break within 1e-7 of the work
    (1.7e-9 and 2.3e-9 measured); each break removes energy from the plate (a pair broken at one
    instant, by their joint carry, the last of them); the parts are counted
    on the whole floe."""
    p = Parameters(Nmod=20, edges="free", duration=2e-3, fracture="break", yield_strain=EPS_Y)
    s = Settings(quadrature="gauss")
    times = np.linspace(0.0, 2e-3, 21)
    half, whole = (solve(p, s, fields=(), times=times, t_end=times[-1], full_plate=full) for full in (False, True))
    for r in (half, whole):
        assert r.status == "ok", r.message
        balance = r.plate_energy + r.layer_energy + r.dissipated_energy + r.breaking.removed_energy - r.work
        assert np.max(np.abs(balance[r.valid])) < 1e-7 * np.max(r.work[r.valid])
        made = r.breaking.breaks
        assert all(e.removed_plate_energy > 0.0 or (e.removed_energy == 0.0 and later.time == e.time)
                   for e, later in zip(made, made[1:] + made[-1:]))      # (breaks at one instant: the last's)
        assert_breaking_consistent(r)
    first, second = half.breaking.breaks[:2]
    assert first.x == 0.0 and first.surface == "lower" and first.time == pytest.approx(5.137e-4, rel=1e-3)
    assert second.surface == "upper" and second.broken_through and 0.2 < second.x < 0.5
    assert half.breaking.breakthrough_time == second.time
    listed = whole.breaking.breaks
    assert len(listed) == 2 * len(half.breaking.breaks) - 1 and listed[0].x == 0.0
    for k, e in enumerate(half.breaking.breaks[1:]):
        pair, bound = listed[1 + 2 * k: 3 + 2 * k], (1e-9 if k == 0 else 1e-5)
        assert sorted(abs(b.x) for b in pair) == pytest.approx([e.x, e.x], abs=10 * bound * p.L)
        assert [b.time for b in pair] == pytest.approx([e.time, e.time], rel=bound)
    assert half.breaking.parts == whole.breaking.parts


@pytest.mark.slow   # DOP853 on a floe: make test-slow
def test_dop853_breaks_a_floe_where_etd34_does():
    """DOP853 at 1e-12 on the same right-hand side through a floe's first two breaks (N = 16, the
    half floe, to 0.8 ms): the breaks' times, places and penetrations within 1e-9 of etd34 at
    1e-10."""
    p = Parameters(Nmod=16, edges="free", duration=8e-4, fracture="break", yield_strain=EPS_Y)
    runs = [solve(p, Settings(quadrature="gauss", integrator=name, tolerance=tol, error_estimate=False), fields=(),
                  times=np.linspace(0.0, 8e-4, 9), t_end=8e-4).breaking.breaks
            for name, tol in (("etd34", 1e-10), ("dop853", 1e-12))]
    assert len(runs[0]) == len(runs[1]) >= 2
    for a, b in zip(*runs):
        assert a.time == pytest.approx(b.time, rel=1e-9) and a.x == pytest.approx(b.x, abs=1e-9 * p.L)
        assert a.penetration == pytest.approx(b.penetration, rel=1e-9) and a.surface == b.surface
