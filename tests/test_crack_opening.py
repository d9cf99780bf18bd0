"""A crack that opens over a time (solver/model/crack.py; docs/model.md, "A crack that opens over
a time"): a break's faces first carry the moment and shear the ice carried there, released over
hi / crack_speed. The faces' forcing is the unbroken plate's internal force, the fracture's work is
in the energy identity, and the breakthrough converges in the modes and agrees with the finite
elements' with the same opening time."""
import math

import numpy as np
import pytest

from solver import ParameterError, Parameters, Settings, solve
from solver.model import parts
from solver.model.broken import carry_state
from solver.model.assemble import Tables
from solver.model.crack import crack_loads
from solver.spec import Crack

EPS_Y = 8e-5


@pytest.mark.parametrize("place", [0.0, 1.3])
def test_the_faces_carry_the_force_the_unbroken_plate_carried(place):
    """The reference case's state at its first break (N = 20) carried onto the plate broken at
    ``place`` (the centre, or 1.3 m: a face on each side): on every kernel mode Psi_k of the broken
    plate, its elastic force less the faces' forcing is the unbroken plate's internal force acting
    on it, omega_k^2 a_k - G_k = (mirror / m_k) int Psi_k (D w'''' + rho_w g w) dx (integration by
    parts on each part: the faces' terms are G's), within 1e-9 of omega_k^2 a_k's largest. Without
    G it fails by the released moment."""
    p, s = Parameters(Nmod=20), Settings(quadrature="gauss")
    first = solve(p, s, fields=(), t_end=1e-3, break_strain=EPS_Y)
    a = first.end.state.amplitudes
    whole = Tables(p, s.subintervals, False, s.quadrature, s.quadrature_density)
    broken = Tables(p, s.subintervals, False, s.quadrature, s.quadrature_density, breaks=np.array([place]))
    moment, shear = (p.rigidity * float(whole.derivative(a, place, k)[0]) for k in (2, 3))
    G = crack_loads(p, broken.floe, [Crack(0.0, place, moment, shear)], False)[0]
    wet = broken.floe["wet"]
    b, _ = carry_state(p, wet, a, np.zeros_like(a))
    scale = broken.floe["scale"]
    elastic = np.append(wet.omega**2 * b, 0.0) * scale                     # omega_k^2 a_k, kernel units
    g, w = np.polynomial.legendre.leggauss(24)
    cuts = np.unique([0.0, place, p.L])
    edges = np.concatenate([np.linspace(lo, hi, 200, endpoint=False) for lo, hi in zip(cuts[:-1], cuts[1:])] + [[p.L]])
    half = 0.5 * np.diff(edges)
    x = ((edges[:-1] + half)[:, None] + half[:, None] * g).ravel()
    weights = (half[:, None] * w).ravel()
    load = p.rigidity * whole.derivative(a, x, 4) + p.rho_w * p.g * whole.derivative(a, x, 0)
    modes = broken.floe["Q"].T @ parts.part_values(wet.modes, x)            # the kernel's modes (N, X)
    internal = 2.0 * (modes * weights) @ load / broken.floe["mass"]
    top = np.max(np.abs(elastic))
    assert np.max(np.abs(elastic - G - internal)) < 1e-9 * top
    assert np.max(np.abs(elastic - internal)) > 1e-3 * top                 # (the faces' part is not small)
    assert abs(moment) > 0 and (abs(shear) < 1e-9 * abs(moment) if place == 0.0 else abs(shear) > 1e-3 * abs(moment))


def test_the_energy_identity_holds_while_cracks_open():
    """The reference case (N = 40) breaking with cracks that open over 100 us: the energy identity
    E_plate + E_layer + D + R = W within 1e-7 of the work (2.7e-9 measured), D the fracture's
    energy, which the opening faces take from the plate (above 0; elastic ice and layer dissipate
    nothing else); with cracks that open at once, D is 0."""
    s = Settings(quadrature="gauss")
    times = np.linspace(0.0, 1e-3, 41)
    runs = {speed: solve(Parameters(Nmod=40, fracture="break", yield_strain=EPS_Y, crack_speed=speed), s, fields=(),
                         times=times, t_end=times[-1]) for speed in (5000.0, math.inf)}
    opening, at_once = runs[5000.0], runs[math.inf]
    assert opening.status == at_once.status == "ok"
    assert opening.diagnostics["energy_residual"] < 1e-7
    first = opening.breaking.first_break_time
    after = opening.times > first + 1e-4
    assert np.all(opening.dissipated_energy[after] > 0.0)
    assert np.all(opening.dissipated_energy[opening.times < first] == 0.0)
    assert np.all(at_once.dissipated_energy[at_once.valid] == 0.0)


def test_with_an_opening_crack_the_breakthrough_and_the_cascade_converge_in_the_modes():
    """Cracks that open over 25 us (crack_speed 2e4 m/s on 0.5 m ice): the breakthrough at N = 60
    and 80 within 3e-4 (0.63217 and 0.63227 ms measured, 0.63229 at 120), at the same place
    within 2 mm (0.3356, 0.3366 m); the first break the unbroken plate's crack onset. The whole
    cascade to 2 ms converges too: four breaks at N = 60, 80 and 120 on the same surfaces, the
    third at 1.54029, 1.53906, 1.53918 ms (1.1185, 1.1200, 1.1233 m), the fourth at 1.77069,
    1.77121, 1.77282 ms (0.652, 0.662, 0.670 m); where cracks open at once the third break moves
    from 0.637 to 0.629 to 0.662 ms and the count from 6 to 7 (docs/model.md, "A crack that opens
    over a time")."""
    s = Settings(quadrature="gauss")
    runs = {N: solve(Parameters(Nmod=N, fracture="break", yield_strain=EPS_Y, crack_speed=2e4), s, fields=(),
                     times=[0.0, 2e-3], t_end=2e-3).breaking for N in (60, 80)}
    assert runs[80].breakthrough_time == pytest.approx(runs[60].breakthrough_time, rel=3e-4)
    through = [next(e for e in r.breaks if e.broken_through) for r in runs.values()]
    assert abs(through[0].x - through[1].x) < 2e-3 and through[0].surface == through[1].surface == "upper"
    assert runs[80].first_break_time == pytest.approx(runs[60].first_break_time, rel=3e-4)
    for r in runs.values():
        assert [e.surface for e in r.breaks] == ["lower", "upper", "lower", "upper"]
    for a, b in zip(runs[60].breaks, runs[80].breaks):
        assert a.time == pytest.approx(b.time, rel=1.5e-3) and abs(a.x - b.x) < 0.015


def test_an_opening_crack_needs_etd34():
    """The fracture's dissipated energy is taken on etd34's stages: rk4 and dop853 refuse a crack
    that opens over a time, in one line; crack_speed must be a positive speed."""
    p = Parameters(Nmod=10, fracture="break", crack_speed=1000.0)
    for integrator in ("rk4", "dop853"):
        with pytest.raises(ParameterError, match="needs etd34") as err:
            solve(p, Settings(quadrature="gauss", integrator=integrator), fields=(), t_end=1e-4)
        assert "\n" not in str(err.value)
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(ParameterError, match="crack_speed"):
            Parameters(fracture="break", crack_speed=bad)
