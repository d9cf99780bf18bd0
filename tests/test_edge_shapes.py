"""Edge shapes at a broken plate's free edges (solver/model/parts.py, ``edge_shapes``;
docs/model.md, "Edge shapes"): boundary layers that obey the beam equation, their Gram matrices
exact, the state they carry across a break, the kernels on them against DOP853, and the
parameter's checks."""
import math
from dataclasses import replace

import numpy as np
import pytest

from helpers import composite_gauss
from solver import Parameters, Settings, solve
from solver.parameters import ParameterError
from solver.model import broken, parts

L = 6.0
#: the reference case's first break at N = 60 (the lower surface at x = 0; tests/test_parts.py)
FIRST_BREAK = 0.4925754402552841e-3


def test_edge_shapes_stand_at_free_ends_obey_the_beam_equation_and_their_gram_is_exact():
    """A half plate broken at its centre and at 1.3 m: the free-sliding part [1.3, 6] has one edge
    shape per wavenumber (about its sliding end), the free-free part [0, 1.3] two (both parities
    about its middle); each obeys psi'''' = beta^4 psi and is flat at a sliding end; the mass and
    bending Gram matrices (parts.gram) match a fine composite rule within 1e-11 of their diagonal."""
    beta_max = math.pi * 60 / L
    modes = parts.part_modes(L, [0.0, 1.3], beta_max, edges=3)
    edge = parts.edge_shaped(modes)
    assert np.sum(edge & (modes.parts == 0)) == 6 and np.sum(edge & (modes.parts == 1)) == 3
    assert sorted(set(modes.betas[edge] / beta_max)) == [0.25, 0.5, 1.0]
    x = np.linspace(0.0, L, 3001)
    values = [parts.part_values(modes, x, order) for order in (0, 1, 3, 4)]
    scale = np.max(np.abs(values[0]), axis=1)[:, None]
    fourth = values[3] - modes.betas[:, None] ** 4 * values[0]
    assert np.max(np.abs(fourth[edge]) / (modes.betas[edge, None] ** 4 * scale[edge])) < 1e-10
    sliding = edge & (modes.parts == 1)
    wall = parts.part_values(modes, np.array([L]), 1)[sliding, 0], parts.part_values(modes, np.array([L]), 3)[sliding, 0]
    assert np.max(np.abs(wall[0]) / modes.betas[sliding]) < 1e-12 and np.max(np.abs(wall[1]) / modes.betas[sliding]**3) < 1e-12
    for order in (0, 2):
        G = parts.gram(modes, order)
        fine = np.zeros_like(G)
        for part, (lo, hi) in enumerate(((0.0, 1.3), (1.3, L))):
            on = np.flatnonzero(modes.parts == part)
            xq, wq = composite_gauss(lo, hi)
            v = parts.part_values(modes, xq, order)[on]
            fine[np.ix_(on, on)] = (v * wq) @ v.T
        d = np.diag(fine)
        diagonal = np.sqrt(np.outer(d, d)) + 1e-14 * np.max(d)         # (heave's and pitch's bending: 0)
        assert np.max(np.abs(G - fine) / diagonal) < 1e-11


def test_edge_shapes_carry_the_bending_a_break_leaves_at_its_faces():
    """The reference case (N = 60) where it first cracks, broken at the centre: the plate's energy
    the carry leaves out is 6.3e-2 on the parts' modes alone, 8.3e-3, 6.0e-5 and 1.7e-8 with 1, 2
    and 3 edge shapes (docs/model.md, "Edge shapes"); the carried strain is the unbroken plate's
    within 4.6e-8 everywhere with 3 (the free-free modes alone miss the break's own 8e-5 there and
    overshoot the largest tension by 2.1e-6 next to it)."""
    p = Parameters(Nmod=60)
    r = solve(p, Settings(), times=np.array([0.0, FIRST_BREAK]), fields=())
    a, v = r.amplitudes[-1], r.velocities[-1]
    before = sum(broken.cosine_state_energy(p, L, 2.0, a, v))
    x = np.linspace(0.0, L, 6001)
    lam = math.pi * np.arange(1, 61) / L
    unbroken = 0.5 * p.hi * (-(lam**2)[:, None] * np.cos(np.outer(lam, x))).T @ a         # the lower surface's
    left, strain_error = [], []
    for count in range(4):
        q = replace(p, fracture="break", edge_shapes=count, crack_spacing=1.0 if count else 0.0)
        wet = broken.wet_parts(q, L, 2.0, [0.0], math.pi * 60 / L)
        b, bdot = broken.carry_state(q, wet, a, v)
        left.append(1.0 - sum(broken.wet_energy(wet, b, bdot)) / before)
        strain_error.append(np.max(np.abs(0.5 * p.hi * broken.wet_values(wet, x, 2).T @ b - unbroken)))
    assert left == pytest.approx([6.3e-2, 8.3e-3, 6.0e-5, 1.7e-8], rel=0.05)
    assert strain_error[0] == pytest.approx(8e-5, rel=1e-3) and strain_error[3] < 5e-8


def test_a_run_on_edge_shapes_keeps_the_energy_identity_and_what_a_break_removes_is_small():
    """The reference case at N = 20 with 3 edge shapes and a crack spacing of hi, to 0.7 ms: the
    first break (the centre) removes 5.3e-4 J/m of the plate's energy where the parts' modes alone
    remove 0.67 J/m, the run breaks through at the spacing's edge, and the energy identity holds
    within 1e-7 of the work."""
    runs = {count: solve(Parameters(Nmod=20, fracture="break", edge_shapes=count, crack_spacing=1.0),
                         Settings(), times=np.linspace(0.0, 7e-4, 3), fields=(), t_end=7e-4) for count in (0, 3)}
    for run in runs.values():
        assert run.status == "ok" and abs(run.diagnostics["energy_residual"]) < 1e-7
    first = {count: run.breaking.breaks[0] for count, run in runs.items()}
    assert first[0].time == first[3].time and first[0].x == first[3].x == 0.0
    assert first[0].removed_plate_energy == pytest.approx(0.666, rel=0.01)
    assert first[3].removed_plate_energy < 1e-3
    assert runs[3].breaking.breakthrough_time == pytest.approx(6.599e-4, rel=1e-3)
    assert runs[3].breaking.breaks[1].x == pytest.approx(0.5, abs=1e-9)


@pytest.mark.heavy
def test_the_kernels_on_edge_shapes_agree_with_dop853():
    """The same run, N = 20 with 3 edge shapes (wet frequencies to 20 omega_N), by etd34 and by
    DOP853 on the same right-hand side at 1e-11: the same breaks, their times within 1e-10 s."""
    p = Parameters(Nmod=20, fracture="break", edge_shapes=3, crack_spacing=1.0)
    runs = [solve(p, Settings(integrator=integrator, tolerance=1e-11), times=np.linspace(0.0, 7e-4, 3), fields=(),
                  t_end=7e-4) for integrator in ("etd34", "dop853")]
    breaks = [run.breaking.breaks for run in runs]
    assert len(breaks[0]) == len(breaks[1]) == 2
    for one, other in zip(*breaks):
        assert abs(one.time - other.time) < 1e-10 and one.x == pytest.approx(other.x, abs=1e-9)
    assert all(abs(run.diagnostics["energy_residual"]) < 1e-10 for run in runs)


def test_edge_shapes_are_a_whole_number_up_to_four_and_need_a_crack_spacing():
    """edge_shapes is 0 to 4, whole; edge shapes carry a new edge's bending, so the tension next to
    a break stays at eps_Y: without a crack spacing the ice breaks again within a millimetre of it
    (cracks over 25 us, N = 80, 4 shapes: 0.3451 and 0.3455 m, twice each, at 0.63307 ms), with
    cracks that open at once or over a time alike: refused in one line."""
    for bad in (-1, 1.5, 5):
        with pytest.raises(ParameterError, match="edge_shapes"):
            Parameters(fracture="break", edge_shapes=bad, crack_spacing=1.0)
    for speed in (math.inf, 2e4, 1250.0):
        with pytest.raises(ParameterError, match="crack_spacing > 0"):
            Parameters(fracture="break", edge_shapes=2, crack_speed=speed)
    assert Parameters(fracture="break", edge_shapes=2, crack_spacing=0.5).edge_shapes == 2
    assert Parameters(fracture="break", edge_shapes=2, crack_spacing=0.5, crack_speed=2e4).edge_shapes == 2


@pytest.mark.parametrize("N, shapes", [(120, 4), (240, 2), (240, 4), (320, 4)])
def test_edge_shapes_leave_the_parts_slow_wet_modes_as_they_are(N, shapes):
    """Edge shapes are boundary layers: the parts' heave and pitch on the water, the slowest wet
    modes (2.845 and 4.064 rad/s for the reference case broken at 0 and 0.5 m), are those of the
    parts' modes alone, within 1e-11. Until breaking 13 the span's near-dependent directions were
    dropped after a rotation to the mass's eigenvectors and the volume constraint taken on an
    orthonormal null space: D beta_max^4's round-off then reached rho_w g, and the slowest went to
    2.8716 and 4.1652 rad/s at N = 240 with 4 shapes (2.5 %); the strain after the second break of
    a crack opening over 0.4 ms drifted by 7.5e-3 of its largest from N = 240 to 320."""
    breaks, beta_max = [0.0, 0.5], N * math.pi / L
    plain = broken.wet_parts(Parameters(Nmod=N, fracture="break"), L, 2.0, breaks, beta_max)
    shaped = broken.wet_parts(Parameters(Nmod=N, fracture="break", edge_shapes=shapes, crack_spacing=1.0), L, 2.0,
                              breaks, beta_max)
    slow, slow_shaped = np.sort(plain.omega)[:4], np.sort(shaped.omega)[:4]
    assert slow[0] == pytest.approx(2.845138, rel=1e-6) and slow[1] == pytest.approx(4.063918, rel=1e-6)
    np.testing.assert_allclose(slow_shaped, slow, rtol=1e-11)
    assert shaped.omega.size > plain.omega.size


def test_a_part_too_short_for_an_edge_shape_takes_a_whole_part_shape_that_holds_a_face_moment():
    """The 0.3356 m part the reference case's second break cuts under the body (N = 60): the
    layer at beta_max / 2 is too steep for it (beta l = 2.6 < EDGE_LENGTH), so it takes the whole
    part's shapes at beta l = EDGE_WHOLE in its place. A curvature rising linearly to a face, as
    an opening crack's held moment leaves it, is then fitted (least squares, the energy's norm)
    within 1.2e-2 of its largest value at least 0.1 m from the face, where the part's free-free
    modes, all with w'' = 0 at the face, miss it by 0.21, and with the layer at beta_max alone
    by 0.13 (docs/model.md, "Edge shapes")."""
    beta_max, length = math.pi * 60 / L, 0.3356
    x = np.linspace(0.0, length, 2001)[:-1]
    ramp = x / length
    away = {}
    for edges in (0, 1, 2):
        modes = parts.part_modes(L, [0.0, length], beta_max, edges=edges)
        on = modes.parts == 0
        shapes = on & parts.edge_shaped(modes)
        if edges == 2:
            assert sorted(set(modes.betas[shapes] * length / 2)) == pytest.approx([parts.EDGE_WHOLE, beta_max * length / 2])
        values = parts.part_values(modes, x, 2)[on].T
        fit = values @ np.linalg.lstsq(values, ramp, rcond=None)[0]
        away[edges] = np.max(np.abs(fit - ramp)[x <= length - 0.1])
    assert away[0] > 0.2 and away[1] > 0.12 and away[2] < 1.2e-2
