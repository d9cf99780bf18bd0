"""A walled plate broken into parts (solver/model/parts.py; docs/model.md, "Breaking into parts"):
the parts' dry modes, the water they share, their wet modes, and the state carried across a
break."""
import math

import numpy as np
import pytest
from scipy.special import zeta

from helpers import composite_gauss
from solver import Parameters, Settings, solve
from solver.model import broken, part_tables, parts, tails

L = 6.0


def _shape(modes, m, x, order=0):
    return modes.norms[m] * parts.raw_mode(modes.kinds[m], modes.betas[m], modes.centres[m], modes.halves[m], x, order)


def test_the_parts_dry_modes_meet_their_ends_and_are_orthogonal():
    """Three parts of a half plate (breaks at 1.7 and 3.9 m): sliding-free, free-free,
    free-sliding. At a sliding end w' = w''' = 0, at a break w'' = w''' = 0 (below 1e-9 of
    beta^k); on each part int psi_m psi_n dx = length delta_mn and int psi_m'' psi_n'' dx =
    beta^4 length delta_mn (1e-11 of the largest)."""
    modes = parts.part_modes(L, [1.7, 3.9], 12.0)
    assert sorted(set(modes.parts)) == [0, 1, 2]
    assert np.max(modes.betas) <= 12.0
    for m in range(modes.kinds.size):
        beta = max(modes.betas[m], 1.0)
        for end in (modes.lows[m], modes.highs[m]):
            orders = (1, 3) if end in (0.0, L) else (2, 3)
            for k in orders:
                assert abs(float(_shape(modes, m, end, k))) < 1e-9 * beta**k, (m, end, k)
    for part in range(3):
        ms = np.flatnonzero(modes.parts == part)
        x, w = composite_gauss(modes.lows[ms[0]], modes.highs[ms[0]])
        values = np.array([_shape(modes, m, x) for m in ms])
        curvatures = np.array([_shape(modes, m, x, 2) for m in ms])
        length = modes.highs[ms[0]] - modes.lows[ms[0]]
        gram = (values * w) @ values.T
        assert np.max(np.abs(gram - length * np.eye(ms.size))) < 1e-11 * length
        bending = (curvatures * w) @ curvatures.T
        expected = np.diag(modes.betas[ms] ** 4 * length)
        assert np.max(np.abs(bending - expected)) < 1e-11 * np.max(expected)
        assert np.allclose(parts.part_lengths(modes)[ms], length)
        assert parts.mode_means(modes)[ms] == pytest.approx(w @ values.T, abs=1e-12 * length)


def test_the_closed_form_cosine_integrals_are_quadratures():
    """int psi_m cos(mu_k x) dx by the closed form (beta^4 - mu^4) I = [boundary terms] and near
    resonance by parts._gauss, against a fine composite Gauss-Legendre rule: within 2e-12 for
    k = 1..400 and at k = 5000, 16000 (a break at 2 m, wavenumbers up to 40 m-1; every third
    mode)."""
    modes = parts.part_modes(L, [2.0], 40.0)
    for k, panels in ((np.arange(1, 401), 300), (np.array([5000, 16000]), 6000)):
        mu = math.pi * k / L
        ours = parts.cosine_integrals(modes, mu)
        for m in range(0, modes.kinds.size, 3):
            x, w = composite_gauss(modes.lows[m], modes.highs[m], panels)
            brute = (w * _shape(modes, m, x)) @ np.cos(np.outer(x, mu))
            assert np.max(np.abs(ours[m] - brute)) < 2e-12, m


@pytest.mark.parametrize("N, breaks, edges, sliding", [(60, [0.0, 0.3321, 0.5263], 0, (True, True)),
                                                        (60, [1.5, 3.0], 2, (True, True)),
                                                        (120, [2.0, 4.5], 4, (False, False))])
def test_the_cosine_integrals_near_resonance_keep_their_digits(N, breaks, edges, sliding):
    """The pairs within RESONANCE of beta = mu (solver.model.resonance: the trigonometric part's
    difference of sines as a product, the hyperbolic part's ends over beta +- i mu) against
    Gauss-Legendre on each mode's own panels (parts.gauss_rule: exact to round-off; how they
    were integrated until results revision breaking 14), every such pair of plates broken on
    walls and a floe's, with and without edge shapes: within 5e-14 of the row's largest
    (measured 9e-15 to 3e-14; 6.8e-14 at N = 240 with 4 shapes)."""
    modes = parts.part_modes(L, breaks, math.pi * N / L, edges, sliding)
    mu = math.pi * np.arange(1, 2049) / L
    ours = parts.cosine_integrals(modes, mu)
    near = np.abs(modes.betas[:, None] ** 4 - mu[None, :] ** 4) < parts.RESONANCE * mu[None, :] ** 4
    assert np.sum(near) > 40 and np.all(np.isfinite(ours))
    for m in np.flatnonzero(np.any(near, axis=1)):
        x, w = parts.gauss_rule(modes, m, np.max(mu[near[m]]))
        gauss = (w * _shape(modes, m, x)) @ np.cos(np.outer(x, mu[near[m]]))
        assert np.max(np.abs(ours[m, near[m]] - gauss)) < 5e-14 * np.max(np.abs(ours[m])), m


def test_at_exact_resonance_a_sliding_parts_cosine_integral_is_its_limit():
    """A plate broken nowhere is one sliding part whose cosines are the channel's: int sqrt(2)
    cos(n pi x / L) cos(k pi x / L) dx = L / sqrt(2) for k = n, 0 otherwise, where beta = mu
    exactly (the general closed form divides by zero there)."""
    modes = parts.part_modes(L, [], math.pi * 40 / L)
    mu = math.pi * np.arange(1, 61) / L
    ours = parts.cosine_integrals(modes, mu)[1:]              # (the heave's row: sin(mu L) / mu = 0)
    np.testing.assert_allclose(np.diag(ours[:, :40]), L / math.sqrt(2.0), rtol=1e-14)
    assert np.max(np.abs(ours[:, :40] - np.diag(np.diag(ours[:, :40])))) < 1e-13
    assert np.max(np.abs(ours[:, 40:])) < 1e-13


def test_two_rigid_parts_added_mass_in_closed_form():
    """A half plate broken at L/2, its parts heaving h_1, h_2: the velocity's cosine coefficients
    are (2/L) 2 (h_1 - h_2) sin(mu_k L / 2) / mu_k, so the added mass is 2 mirror rho (h_1 - h_2)^2
    (L / pi)^3 (7/8) zeta(3) / L: the series with its tail to 1e-14 (1e-15 measured from 512 to
    16384 terms), without the tail at 4096 terms 7e-12 off."""
    rho = 1000.0
    modes = parts.part_modes(L, [L / 2], 0.1)
    assert list(modes.kinds) == [0.0, 0.0]
    v = np.array([1.0, -1.0])
    exact = 2 * 2.0 * rho * 4.0 * (L / math.pi) ** 3 * 7.0 / 8.0 * zeta(3.0) / L
    assert v @ parts.channel_added_mass(modes, L, 2.0, rho) @ v == pytest.approx(exact, rel=1e-14)
    assert v @ parts.channel_added_mass(modes, L, 2.0, rho, terms=512) @ v == pytest.approx(exact, rel=1e-14)


def _cosine_sum_from(n, theta):
    """sum_{k >= n} cos(k theta) / k^3 for large n: its integral (the cosine integral Ci) and half
    its first term (Euler-Maclaurin, theta taken to [-pi, pi]; the next term, f'(n) / 12, is below
    1e-25 here)."""
    from scipy.special import sici
    theta = math.remainder(theta, 2.0 * math.pi)
    x = n * abs(theta)
    integral = 0.5 / n**2 if x == 0.0 else theta**2 * (math.cos(x) / (2 * x**2) - 0.5 * (math.sin(x) / x - sici(x)[1]))
    return integral + 0.5 * math.cos(n * theta) / n**3


@pytest.mark.parametrize("theta", [0.0, 1e-7, 1e-4, 3e-3, 9e-3, 0.1, 1.0, math.pi, 2 * math.pi, -0.5, 7.0])
def test_the_tails_of_the_cosine_and_sine_series_against_their_sums(theta):
    """sum_{k > K} cos(k theta) / k^3 (tails.cosine_tail) within 3e-8 of its largest value,
    zeta(3, K + 1) = 1.2e-7 (9e-9 measured at 60 theta from 1e-8 to pi): 3e-15, the round-off of
    the whole sum, of order 1, that it is taken from less its first K terms where (K + 1) theta is
    small (elsewhere within 1e-12); the sums of k^-4 and k^-5 (tails.power_tail, the tail's second
    order) within 1e-4 of theirs: against the terms K + 1 ... K + 2e6 summed, and the rest by
    Euler-Maclaurin."""
    K = 2048
    k = np.arange(K + 1.0, K + 1.0 + 2e6)
    brute3 = np.cos(k * theta) @ k**-3 + _cosine_sum_from(K + 1.0 + 2e6, theta)
    assert abs(tails.cosine_tail(theta, K) - brute3) < 3e-8 * zeta(3.0, K + 1.0)
    tail = np.exp(1j * k * theta)
    for p in (4, 5):
        assert abs(tails.power_tail(theta, K, p) - tail @ k**-float(p)) < 1e-4 * zeta(float(p), K + 1.0)


@pytest.mark.parametrize("breaks", [[0.0], [0.0, 0.34], [0.0, 0.34, 0.56, 0.66, 0.77, 0.88, 0.99], [0.01, 0.02, 0.5]])
def test_the_added_mass_series_with_its_tail_converges_to_round_off(breaks):
    """The broken plate's added mass at 1024 and 2048 cosines with the jumps' tail to its second
    order (parts.jump_tail) against 32768: within 1e-11 and 1e-12 of the largest entry (4e-12 and
    5e-14 measured; the tail's first order alone left 1e-9 and 6e-9 at 2048 where a part is 1 cm
    long, with the centre broken 4e-11), the broken plates of a cascade on N = 60's parts."""
    beta_max = 60 * math.pi / L
    modes = parts.part_modes(L, breaks, beta_max)
    reference = parts.channel_added_mass(modes, L, 2.0, 1000.0, terms=32768)
    scale = np.max(np.abs(reference))
    for terms, bound in ((1024, 1e-11), (2048, 1e-12)):
        A = parts.channel_added_mass(modes, L, 2.0, 1000.0, terms=terms)
        assert np.max(np.abs(A - reference)) < bound * scale


def _finite_difference_added_mass(Lam, H, b, n):
    """rho_w = 1: int phi v dx for the rigid parts' velocity v = Lambda - b on [0, b), -b on (b,
    Lambda] (mean 0), phi from the 5-point Laplacian on [0, Lambda] x [-H, 0], cells H / n:
    phi_x = 0 at the walls, phi_y = v on top and 0 on the bottom (ghost nodes), one node pinned.
    Independent of the series."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl
    h = H / n
    nx, ny = int(round(Lam / h)) + 1, n + 1
    x = np.linspace(0.0, Lam, nx)
    v = np.where(x < b, Lam - b, -b)
    v[np.isclose(x, b)] = 0.5 * (Lam - 2.0 * b)                   # the jump's node: its mean
    i, j = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij"))
    r = i * ny + j
    rows, cols, vals = [r], [r], [np.full(r.size, -4.0 / h**2)]
    for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        ii, jj = np.abs(i + di), np.abs(j + dj)                     # mirror at x = 0 and above the top
        ii = np.where(ii > nx - 1, 2 * (nx - 1) - ii, ii)           # at x = Lambda
        jj = np.where(jj > ny - 1, 2 * (ny - 1) - jj, jj)           # below the bottom
        rows.append(r), cols.append(ii * ny + jj), vals.append(np.full(r.size, 1.0 / h**2))
    rhs = np.where(j == 0, -2.0 * v[i] / h, 0.0)                  # the ghost above: phi(h) = phi(-h) + 2 h v
    A = sp.lil_matrix(sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                    shape=(r.size,) * 2))
    A[r.size - 1] = 0.0
    A[r.size - 1, r.size - 1] = 1.0
    rhs[r.size - 1] = 0.0
    phi = spl.spsolve(A.tocsc(), rhs)
    weights = np.full(nx, h)
    weights[[0, -1]] = 0.5 * h
    return float(np.sum(weights * phi[i[j == 0] * ny] * v))


def test_the_channel_added_mass_against_finite_differences():
    """A break at 3/8 of a 1 m channel of depth 0.5 m, the two parts heaving with int w dx = 0: the
    series on finite depth (coth(mu H) / mu) against the potential solved by finite differences,
    which converge to it (error 3.5e-3, 9.9e-4, 2.8e-4 at cells H/20, H/40, H/80: order 1.8,
    the jump's singularity)."""
    Lam, H, b = 1.0, 0.5, 0.375
    modes = parts.part_modes(Lam, [b], 0.1)
    v = np.array([Lam - b, -b])
    series = v @ parts.channel_added_mass(modes, Lam, 1.0, 1.0, H=H) @ v
    errors = [abs(_finite_difference_added_mass(Lam, H, b, n) / series - 1.0) for n in (20, 40, 80)]
    assert errors[2] < 4e-4
    assert errors[0] / errors[1] > 3.0 and errors[1] / errors[2] > 3.0


def test_the_unbroken_plate_is_the_walled_plates_cosines():
    """No break: one sliding part, whose dry modes are heave and the cosines; the constraint int w
    dx = 0 removes heave, and the wet modes are the walled plate's, omega_n to 1e-13 (N = 60). A
    state carried across 'no break' keeps both energies to 1e-12 and the deflection to 1e-12."""
    p = Parameters(Nmod=60)
    wet = broken.wet_parts(p, L, 2.0, [], p.wavenumbers[-1])
    assert wet.omega.size == 60
    assert np.max(np.abs(wet.omega / p.frequencies - 1.0)) < 1e-13
    rng = np.random.default_rng(1)
    a, adot = rng.standard_normal(60) * 1e-3 / np.arange(1, 61) ** 2, rng.standard_normal(60) * 1e-2 / np.arange(1, 61)
    b, bdot = broken.carry_state(p, wet, a, adot)
    before, after = broken.cosine_state_energy(p, L, 2.0, a, adot), broken.wet_energy(wet, b, bdot)
    assert after == pytest.approx(before, rel=1e-12)
    x = np.linspace(0.0, L, 301)
    w = a @ np.cos(np.outer(p.wavenumbers, x))
    assert np.max(np.abs(b @ broken.wet_values(wet, x) - w)) < 1e-12 * np.max(np.abs(w))


def test_the_state_carried_across_a_break_converges():
    """The reference case's state at 0.5 ms (N = 60) carried across a break at 0.3 m, where the
    plate bends hard: each energy after the break is at most the one before (Bessel's inequality
    in the mass and in the stiffness). What the projection leaves out is the bending energy near
    the new free edge, where every part mode has w'' = 0: it falls as 1 / beta_max (8.1e-3,
    3.5e-3, 1.7e-3 of the potential energy with the parts' wavenumbers up to 1, 2, 4 times the
    plate's), the kinetic energy's as beta_max^-5 (5.9e-8, 1.5e-9, 4.5e-11), the deflection's
    largest error 2.3e-3, 4.9e-4, 1.1e-4 of its largest value. Breaks at 2 and 4 m, where the
    plate bends less, leave out 4.6e-6 of the potential energy."""
    p = Parameters(Nmod=60)
    r = solve(p, Settings(), times=np.array([0.0, 0.5e-3]))
    a, adot = r.amplitudes[-1], r.velocities[-1]
    kinetic, potential = broken.cosine_state_energy(p, L, 2.0, a, adot)
    x = np.linspace(0.0, L, 1201)
    w = a @ np.cos(np.outer(p.wavenumbers, x))
    lost, errors = [], []
    for factor in (1, 2, 4):
        wet = broken.wet_parts(p, L, 2.0, [0.3], factor * p.wavenumbers[-1])
        b, bdot = broken.carry_state(p, wet, a, adot)
        k_after, p_after = broken.wet_energy(wet, b, bdot)
        assert k_after <= kinetic * (1 + 1e-12) and p_after <= potential * (1 + 1e-12)
        lost.append((1 - k_after / kinetic, 1 - p_after / potential))
        errors.append(np.max(np.abs(b @ broken.wet_values(wet, x) - w)) / np.max(np.abs(w)))
    kinetic_lost, potential_lost = np.array(lost).T
    assert 5e-3 < potential_lost[0] < 1.2e-2 and kinetic_lost[0] < 1e-7
    assert 1.8 < potential_lost[0] / potential_lost[1] < 2.6 and 1.8 < potential_lost[1] / potential_lost[2] < 2.6
    assert kinetic_lost[1] / kinetic_lost[2] > 10
    assert errors[0] / errors[1] > 3 and errors[1] / errors[2] > 3
    wet = broken.wet_parts(p, L, 2.0, [2.0, 4.0], p.wavenumbers[-1])        # where the plate bends less
    b, bdot = broken.carry_state(p, wet, a, adot)
    assert 1 - broken.wet_energy(wet, b, bdot)[1] / potential < 1e-5              # 4.6e-6 measured


def test_a_break_lowers_the_frequencies_within_two():
    """Cutting the plate frees w and w' at the break: two constraints fewer, so by the min-max
    principle the broken plate's k-th frequency lies between the unbroken plate's (k - 2)-th and
    k-th (the slowest 20, a break at 0.3 m; the parts' wavenumbers up to 4 lambda_N, where the
    slowest 20 have converged to 3.7e-9, and to 4.1e-8 at lambda_N). The slowest is the small
    part heaving against the rest: 3.14 rad/s against the unbroken plate's 39.5."""
    p = Parameters(Nmod=60)
    fine = broken.wet_parts(p, L, 2.0, [0.3], 4 * p.wavenumbers[-1]).omega[:20]
    coarse = broken.wet_parts(p, L, 2.0, [0.3], p.wavenumbers[-1]).omega[:20]
    unbroken = p.frequencies[:20]
    assert np.all(fine <= unbroken * (1 + 1e-12))
    assert np.all(unbroken[:18] <= fine[2:] * (1 + 1e-12))
    assert np.max(np.abs(coarse / fine - 1)) < 1e-7
    assert fine[0] == pytest.approx(3.14, rel=1e-2)


@pytest.fixture(scope="module")
def state_at_break():
    """The reference case at N = 20 (the contact-resolving rule, tolerance 1e-10): its state at
    0.4 ms, when the contact reaches about 0.2 m."""
    p = Parameters(Nmod=20)
    r = solve(p, Settings(quadrature="gauss", tolerance=1e-10), times=np.array([0.0, 0.4e-3]), fields=())
    return p, r.amplitudes[-1], r.velocities[-1]


@pytest.mark.parametrize("place, bound", [(2.0, 1e-8), (0.3, 5e-7), (0.0, 1e-7)])
def test_a_broken_plate_runs_as_dop853_on_the_same_equations(state_at_break, place, bound):
    """The plate broken at 0.4 ms, run 3 ms on its parts (solve(..., breaks=...)): etd34 at 1e-12
    against DOP853 at 1e-13 on the same right-hand side, strain fields at 7 times. Broken at 2 m,
    away from the body: 7.2e-10 of the largest strain (1.0e-8 at 1e-10). Broken at the centre,
    where the reference case first cracks (the lower surface, 0.49 ms): 1.1e-8. Broken at 0.3 m, just
    beyond the contact, where the outer part's edge rises into the layer between two nodes:
    1.0e-7 (8.2e-7 at 1e-10). The energy identity holds on the parts, DOP853's to 1e-13 (1e-7 at
    0.3 m before the contact intervals were found part by part), etd34's to 1e-8; the break's own
    energy (result.end.carried) falls, never rises."""
    p, a, v = state_at_break
    times = np.linspace(0.4e-3, 3.4e-3, 7)
    kw = dict(times=times, fields=("strain",), t_start=times[0], t_end=times[-1], initial_amplitudes=a,
              initial_velocities=v, breaks=[place], x=np.linspace(-p.L, p.L, 241))
    ours = solve(p, Settings(quadrature="gauss", error_control="embedded", tolerance=1e-12), **kw)
    dop = solve(p, Settings(quadrature="gauss", integrator="dop853", tolerance=1e-13), **kw)
    assert ours.status == dop.status == "ok"
    strain = dop.fields["strain"]
    assert np.max(np.abs(ours.fields["strain"] - strain)) < bound * np.max(np.abs(strain))
    assert dop.diagnostics["energy_residual"] < 1e-12 and ours.diagnostics["energy_residual"] < 1e-8
    energy = ours.end.carried
    assert energy.plate_after <= energy.plate_before


def test_what_a_broken_plate_refuses():
    """One line naming the problem: the paper's rule (it interpolates the modes between nodes,
    across a break), a break off the plate (beyond a wall; at the wall, x = L, the ice breaks off
    it; at a floe's edge, free already) or twice."""
    from solver import ParameterError
    floe = Parameters(Nmod=10, edges="free", duration=0.01)
    for bad in ([6.0], [-6.0]):
        with pytest.raises(ParameterError, match="free already") as err:
            solve(floe, Settings(quadrature="gauss"), breaks=bad, full_plate=True)
        assert "\n" not in str(err.value)
    with pytest.raises(ParameterError, match="gauss"):
        solve(Parameters(Nmod=10), Settings(quadrature="paper"), breaks=[1.0])
    for bad in ([6.5], [-1.0], [1.0, 1.0], []):
        with pytest.raises(ParameterError, match="breaks"):
            solve(Parameters(Nmod=10), Settings(quadrature="gauss"), breaks=bad)


def test_a_plate_broken_at_its_centre_is_the_same_on_the_half_and_the_whole_plate(state_at_break):
    """Broken at x = 0: on the half plate one part, free at the centre and sliding at the wall;
    on the whole plate (full_plate=True) two parts, each free at x = 0, their modes of both
    parities. The same symmetric state carried across gives the same strains (etd34 at 1e-12:
    within 1e-7 of the largest, measured 4.5e-9) and the same energies before and after the break
    (to 1e-9; 1.3e-11 measured)."""
    p, a, v = state_at_break
    times = np.linspace(0.4e-3, 2.4e-3, 5)
    kw = dict(times=times, fields=("strain",), t_start=times[0], t_end=times[-1], initial_amplitudes=a,
              initial_velocities=v, breaks=[0.0], x=np.linspace(-p.L, p.L, 241))
    s = Settings(quadrature="gauss", error_control="embedded", tolerance=1e-12)
    half, whole = solve(p, s, **kw), solve(p, s, full_plate=True, **kw)
    assert half.status == whole.status == "ok"
    strain = half.fields["strain"]
    assert np.max(np.abs(whole.fields["strain"] - strain)) < 1e-7 * np.max(np.abs(strain))
    for key in ("plate_before", "plate_after"):
        assert getattr(whole.end.carried, key) == pytest.approx(getattr(half.end.carried, key), rel=1e-9)


def test_a_plate_broken_off_its_walls_is_the_same_on_the_half_and_the_whole_plate(state_at_break):
    """Broken at the walls (x = L on the half plate; -L and L on the whole): no part cut off, the
    part next to each wall free there (w'' = w''' = 0 at x = L: each mode's within 1e-9 of its
    largest on the part), sliding at the centre (w' = 0). The same symmetric state carried across
    gives the same strains on the half and the whole plate (etd34 at 1e-12: within 1e-7 of the
    largest) and the same energies before and after the break (to 1e-9); the strain at the freed
    walls is 0."""
    p, a, v = state_at_break
    modes = parts.part_modes(p.L, [p.L], math.pi * p.Nmod / p.L)
    assert np.all(modes.parts == 0) and np.all(modes.lows == 0.0) and np.all(modes.highs == p.L)
    fine = np.linspace(0.0, p.L, 2001)
    for order in (2, 3):
        at_wall = parts.part_values(modes, np.array([p.L]), order)[:, 0]
        largest = np.max(np.abs(parts.part_values(modes, fine, order)), axis=1)
        assert np.all(np.abs(at_wall) <= 1e-9 * np.maximum(largest, 1e-300))
    slope = parts.part_values(modes, np.array([0.0, 1e-3]), 1)
    assert np.all(np.abs(slope[:, 0]) <= 1e-9 * np.maximum(np.abs(slope[:, 1]), 1e-300))
    times = np.linspace(0.4e-3, 2.4e-3, 5)
    kw = dict(times=times, fields=("strain",), t_start=times[0], t_end=times[-1], initial_amplitudes=a,
              initial_velocities=v, x=np.linspace(-p.L, p.L, 241))
    s = Settings(quadrature="gauss", error_control="embedded", tolerance=1e-12)
    half, whole = solve(p, s, breaks=[p.L], **kw), solve(p, s, full_plate=True, breaks=[-p.L, p.L], **kw)
    assert half.status == whole.status == "ok"
    strain = half.fields["strain"]
    assert np.max(np.abs(whole.fields["strain"] - strain)) < 1e-7 * np.max(np.abs(strain))
    assert np.max(np.abs(strain[1:, [0, -1]])) < 1e-12 * np.max(np.abs(strain))
    for key in ("plate_before", "plate_after"):
        assert getattr(whole.end.carried, key) == pytest.approx(getattr(half.end.carried, key), rel=1e-9)


@pytest.mark.slow   # 7 s here (the parts' modes up to 8 lambda_N): make test-slow
def test_what_a_break_at_the_centre_removes():
    """The reference case (N = 60, default numerics) where it first cracks, the lower surface at
    x = 0 at 0.4926 ms: the plate follows the body there, and the potential energy a break at the
    centre leaves out is the bending energy near the new free edge, where every part mode has
    w'' = 0. Of the potential energy: 21.6 %, 10.8 %, 5.4 %, 2.7 % with the parts' wavenumbers up
    to 1, 2, 4, 8 lambda_N (as 1 / beta_max); of the plate's whole energy 6.3 %, 3.2 %, 1.6 %,
    0.8 %; of the kinetic energy 2.9e-6, 9.1e-8, 2.8e-9, 8.7e-11."""
    p = Parameters(Nmod=60)
    r = solve(p, Settings(), times=np.array([0.0, 0.4925754402552841e-3]), fields=())
    a, v = r.amplitudes[-1], r.velocities[-1]
    kinetic, potential = broken.cosine_state_energy(p, L, 2.0, a, v)
    lost = []
    for factor in (1, 2, 4, 8):
        wet = broken.wet_parts(p, L, 2.0, [0.0], factor * p.wavenumbers[-1])
        k, pot = broken.wet_energy(wet, *broken.carry_state(p, wet, a, v))
        lost.append((1 - k / kinetic, 1 - pot / potential))
    kinetic_lost, potential_lost = np.array(lost).T
    assert potential_lost == pytest.approx([0.216, 0.108, 0.0541, 0.0271], rel=0.05)
    assert np.all(kinetic_lost < [1e-5, 3e-7, 1e-8, 3e-10])


def test_a_parts_rows_are_kept_for_the_later_stages_bit_for_bit():
    """Each part's rows of its cosine integrals and grid values are computed once a run and kept
    (parts._by_part): the tables of a plate broken further, with the rows of its unchanged parts
    taken from the previous stage, are those built from nothing, bit for bit; and only the new
    parts are computed."""
    p = Parameters(Nmod=20, fracture="break")
    xq = np.linspace(0.0, p.L, 201)
    beta_max = np.pi * p.Nmod / p.L
    parts._PART_ROWS.clear()
    fresh = part_tables.parts_tables(p, xq, [0.0, 0.3, 1.1], False, beta_max)
    parts._PART_ROWS.clear()
    part_tables.parts_tables(p, xq, [0.0, 0.3], False, beta_max)            # the stage before
    computed = []
    original = parts._cosine_rows
    parts._cosine_rows = lambda sub, mu: computed.append((sub.lows[0], sub.highs[0])) or original(sub, mu)
    try:
        kept = part_tables.parts_tables(p, xq, [0.0, 0.3, 1.1], False, beta_max)
    finally:
        parts._cosine_rows = original
    for name, value in fresh.items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(kept[name], value, err_msg=name)
    assert sorted(computed) == [(0.3, 1.1), (1.1, p.L)]               # [0, 0.3] was kept


@pytest.mark.parametrize("breaks, edges", [([0.0, 0.3321, 0.5263, 2.7925], 0), ([0.0, 1.3], 3)])
def test_the_kernels_point_sums_and_table_on_the_parts_match_their_modes(breaks, edges):
    """A broken plate's point sums and dry-mode table (solver.model.points: each part's evenly
    spaced wavenumbers by rotation, its exponentials by products) against the parts' modes in numpy
    (parts.part_values), at N = 60 on 601 points: the deflection and the strain with their two
    x-derivatives within 1e-12 of their largest, the table within 1e-13; and the rotation is
    exercised (some modes continue a run)."""
    from solver.model import floe, points
    p = Parameters(Nmod=60, fracture="break", edge_shapes=edges, crack_spacing=1.0 if edges else 0.0)
    tables = part_tables.parts_tables(p, np.linspace(0.0, L, 301), breaks, False, math.pi * 60 / L)
    packed, modes, Q = tables["packed"], tables["wet"].modes, tables["Q"]
    N = modes.kinds.size
    shapes = floe.floe_shapes(packed, N)
    assert np.sum(shapes[floe.RUNS] > 0.0) > N // 2
    c = np.random.default_rng(3).standard_normal(N)
    d = np.empty(N)
    floe.floe_dry(packed, c, d)
    x = np.linspace(0.0, L, 601)[:-1]
    for field, order, scale in ((0, 0, 1.0), (1, 2, -0.5 * p.hi)):
        got = np.array([points.floe_dry_sums(packed, d, xi, field) for xi in x]).T
        for k in range(3):
            exact = scale * (Q.T @ parts.part_values(modes, x, order + k)).T @ c
            assert np.max(np.abs(got[k] - exact)) < 1e-12 * np.max(np.abs(exact))
    table = np.empty((N, x.size))
    points.dry_table(packed, x, table)
    raw = parts.part_values(modes, x) / modes.norms[:, None]
    assert np.max(np.abs(table - raw)) < 1e-13 * np.max(np.abs(raw))
