"""A free floe (docs/model.md, "A free floe"): its dry modes, the water's added mass, its wet
modes, and the impact on it checked against analytic limits, the energy identity, an
independent integrator, a rigid floe's own equation, symmetry, and the walled plate."""
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from solver import Parameters, ParameterError, Settings, solve
from solver.model import floe

#: the floe's numerics in these tests: the paper's rule, tight tolerance (the contact-resolving
#: rule on a floe: tests/test_floe_gauss.py)
FLOE = dict(quadrature="paper", subintervals=500, tolerance=1e-10, error_estimate=False)
#: a fixed step (in t_sc, 5e-5 s) where two code paths must agree to round-off on any CPU
FIXED = dict(FLOE, fixed_step=0.002)


@pytest.mark.parametrize("L", [0.5, 6.0, 40.0])
def test_added_masses_of_a_rigid_strip(L):
    """Heave rho pi c^2 / 2 and pitch rho pi c^4 / 16 (shape x; x / L here) of a strip of
    half-width c = L on a phi = 0 surface."""
    kinds = np.array([floe.HEAVE, floe.PITCH], dtype=float)
    A = floe.added_mass(kinds, np.zeros(2), L, 1000.0)
    assert A[0, 0] == pytest.approx(1000.0 * math.pi * L**2 / 2, rel=1e-13)
    assert A[1, 1] * L**2 == pytest.approx(1000.0 * math.pi * L**4 / 16, rel=1e-13)
    assert abs(A[0, 1]) < 1e-13 * A[0, 0]


def test_added_mass_is_the_half_plane_map_of_each_modes_potential():
    """An independent check of the Chebyshev construction: the potential phi_n of each dry
    mode's velocity (zero outside the floe), put through the lower half-plane's
    Dirichlet-to-Neumann map |k| by FFT on a wide box, gives back rho int phi_m psi_n = A_mn."""
    L, rho = 1.0, 1000.0
    kinds, betas = floe.dry_modes(L, 3)
    A = floe.added_mass(kinds, betas, L, rho)
    P = floe.sine_coefficients(kinds, betas, L)                 # (Nd, K)
    box, n = 16.0 * L, 2**18
    x = (np.arange(n) - n // 2) * (2 * box / n)
    inside = np.abs(x) < L
    theta = np.arccos(np.clip(x[inside] / L, -1, 1))
    k = np.arange(1, P.shape[1] + 1)
    # phi = sum_k (L p_k / k) sqrt(1 - xi^2) U_{k-1}(xi) = sum_k (L p_k / k) sin(k theta)
    phi = np.zeros((kinds.size, n))
    phi[:, inside] = (P * (L / k)) @ np.sin(np.outer(k, theta))
    spec = np.fft.rfft(phi, axis=1) * (2 * box / n)
    kappa = np.pi * np.arange(spec.shape[1]) / box
    weight = np.where((np.arange(spec.shape[1]) == 0) | (np.arange(spec.shape[1]) == n // 2), 1.0, 2.0)
    energy = rho * ((spec * kappa * weight) @ spec.conj().T).real / (2 * box)
    assert np.allclose(energy, A, rtol=0, atol=2e-3 * np.max(np.abs(A)))


def test_dry_modes_are_the_free_free_beam_modes():
    """beta 2L = 4.7300, 7.8532, 10.9956, 14.1372, 17.2788; w_xx = w_xxx = 0 at both edges; the
    modes (heave and pitch with them) are orthogonal on the floe."""
    L = 3.0
    kinds, betas = floe.dry_modes(L, 40)
    assert np.allclose((2 * L * betas[2:7]), [4.7300, 7.8532, 10.9956, 14.1372, 17.2788], atol=5e-5)
    edges = np.array([-L, L])
    for kind, beta in zip(kinds[2:], betas[2:]):
        for order in (2, 3):
            assert np.all(np.abs(floe.dry_mode(int(kind), beta, L, edges, order)) < 1e-9 * beta**order)
    xg, wg = np.polynomial.legendre.leggauss(600)
    values = np.array([floe.dry_mode(int(k), b, L, L * xg) for k, b in zip(kinds, betas)])
    gram = (values * (L * wg)) @ values.T
    assert np.max(np.abs(gram - np.diag(np.diag(gram)))) < 1e-10 * np.max(gram)
    # the closed-form norms the wet modes use: int psi^2 dx = 2L (2L / 3 for pitch)
    np.testing.assert_allclose(np.diag(gram), floe.exact_norms(kinds, L), rtol=1e-12)
    np.testing.assert_allclose(floe.mode_norms(kinds, betas, L), floe.exact_norms(kinds, L), rtol=1e-12)


def test_wet_frequencies_lie_below_the_dry_ones_and_converge():
    """The water's added mass lowers every frequency (Courant-Fischer: same stiffness, more
    mass); the wet frequencies fall monotonically and converge as dry modes are added."""
    p = Parameters()
    omega = {n: floe.wet_modes(p, n)[0] for n in (10, 20, 40)}
    kinds, betas = floe.dry_modes(p.L, 40)
    dry = np.sort(np.sqrt((p.rigidity * betas**4 + p.rho_w * p.g) / p.plate_mass))
    assert np.all(omega[40] < dry)
    low = slice(0, 12)
    assert np.all(omega[10][low] >= omega[20][low] * (1 - 1e-13))
    assert np.all(omega[20][low] >= omega[40][low] * (1 - 1e-13))
    change = [np.max(np.abs(omega[a][low] / omega[40][low] - 1)) for a in (10, 20)]
    assert change[1] < change[0] / 10 and change[1] < 1e-6
    # the rigid modes: heave and pitch on the water (plate + added mass against buoyancy)
    m2L = p.plate_mass * 2 * p.L
    assert omega[40][0] < math.sqrt(p.rho_w * p.g * 2 * p.L / (m2L + p.rho_w * math.pi * p.L**2 / 2))


def _run(p, **settings):
    return solve(p, Settings(**{**FLOE, **settings}), fields=("deflection", "strain"))


@pytest.mark.heavy
def test_floe_energy_identity_and_dop853():
    """The energy identity with the floe's rigid-body kinetic and hydrostatic energy (the wet
    modes' plate energy), and DOP853 on the same right-hand side within 1e-6 of the largest
    strain, its max_strain within 1e-6 (DOP853 samples the peak at 8 points a step: 7e-8 and
    3.9e-7 on two machines)."""
    p = Parameters(Nmod=10, edges="free", duration=0.05)
    r = _run(p, tolerance=1e-11)
    d = _run(p, integrator="dop853", tolerance=1e-12)
    assert r.status == "ok" and d.status == "ok"
    assert r.diagnostics["energy_residual"] < 1e-5
    assert np.allclose(r.plate_energy + r.layer_energy, r.work, rtol=0, atol=1e-5 * r.work[-1])
    top = np.max(np.abs(r.fields["strain"]))
    assert np.max(np.abs(r.fields["strain"] - d.fields["strain"])) < 1e-6 * top
    assert r.diagnostics["max_strain"] == pytest.approx(d.diagnostics["max_strain"], rel=1e-6)


def test_a_centred_floe_on_its_half_equals_the_full_floe():
    """The half floe's symmetric wet modes are the full floe's (the added mass couples no mode
    of one parity to the other): at a fixed step the two runs agree to round-off."""
    p = Parameters(Nmod=10, edges="free", duration=0.05)
    half, full = _run(p, **FIXED), solve(p, Settings(**FIXED), fields=("deflection", "strain"), full_plate=True)
    assert np.max(np.abs(half.fields["strain"] - full.fields["strain"])) < 1e-9 * np.max(np.abs(half.fields["strain"]))
    assert full.amplitudes.shape[1] == 2 * p.Nmod + 2 and half.amplitudes.shape[1] == p.Nmod + 1


def test_an_off_centre_body_pitches_the_floe_and_mirroring_mirrors_everything():
    p = Parameters(Nmod=10, edges="free", duration=0.05, x0=1.5)
    a, b = _run(p, **FIXED), _run(p.replace(x0=-1.5), **FIXED)
    w = a.fields["deflection"]
    assert np.max(np.abs(w - b.fields["deflection"][:, ::-1])) < 1e-10 * np.max(np.abs(w))
    assert np.max(np.abs(a.fields["strain"] - b.fields["strain"][:, ::-1])) < 1e-10 * np.max(np.abs(a.fields["strain"]))
    # the maximum located in time (solver.observe.dense_maxima): at a flat maximum its time, and the
    # place that moves with it, are set to ~sqrt(eps) of the search's bracket (measured 5e-9)
    assert a.diagnostics["max_strain"] == pytest.approx(b.diagnostics["max_strain"], rel=1e-10)
    assert a.diagnostics["max_strain_x"] == pytest.approx(-b.diagnostics["max_strain_x"], rel=1e-7)
    # each wet mode is even or odd: the odd ones (pitch, the second slowest, among them) change sign
    top = np.max(np.abs(a.amplitudes))
    even = np.abs(a.amplitudes[-1] - b.amplitudes[-1]) < 1e-10 * top
    odd = np.abs(a.amplitudes[-1] + b.amplitudes[-1]) < 1e-10 * top
    assert np.all(even | odd) and odd[1] and even[0] and np.abs(a.amplitudes[-1, 1]) > 1e-3 * top
    # pitched: the edge beyond the body goes down further than the other one
    assert w[-1, -1] < w[-1, 0] - 0.01
    assert a.diagnostics["energy_residual"] < 2e-5


def _rigid_heave(p, times, added=None):
    """The rigid floe's heave w(t): (2 L m + A) w'' + 2 L rho g w = -K int f(delta) dx, A the
    heave added mass (deep water: rho pi L^2 / 2), delta = (w + V t - x^2 / 2R) / he, its force
    by adaptive quadrature, scipy's DOP853."""
    mass = 2 * p.L * p.plate_mass + (p.rho_w * math.pi * p.L**2 / 2 if added is None else added)

    def force(t, w):
        lift = w + p.V * t
        if lift <= 0:
            return 0.0
        reach = min(math.sqrt(2 * p.R * lift), p.L)
        f = lambda x: (lambda d: d / (1 - d))((lift - x * x / (2 * p.R)) / p.he)
        return 2 * p.K * quad(f, 0, reach, epsabs=0, epsrel=1e-12)[0]

    sol = solve_ivp(lambda t, y: [y[1], (-force(t, y[0]) - 2 * p.L * p.rho_w * p.g * y[0]) / mass],
                    (0, times[-1]), [0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-14, t_eval=times)
    return sol.y[0]


@pytest.mark.parametrize("stiffer, subintervals, bound", [(1e6, 2000, 1e-4), (1e8, 4000, 5e-6)])
def test_a_rigid_floe_heaves_as_its_one_scalar_equation(stiffer, subintervals, bound):
    """E x 1e6 and 1e8: the floe's heave (its slowest wet mode, 1 on the whole floe to 1e-8)
    follows the rigid floe's one equation, until the layer is nearly crushed (the floe's
    inertia holds it: at 5 m/s the layer bottoms out at 4.1 ms). Measured: 7.6e-5 and 3.5e-6;
    the difference is the floe's bending, which lessens the compression under the body (6.5e-5
    at E x 1e6, 6.5e-6 at 1e7: as 1/E), and the paper's rule's dx^2 (1.1e-5 at 2000 subintervals,
    2.9e-6 at 4000)."""
    p = Parameters(Nmod=6, edges="free", duration=0.003, E=4.2e9 * stiffer)
    times = np.linspace(0, p.duration, 11)
    r = solve(p, Settings(**{**FLOE, "subintervals": subintervals, "tolerance": 1e-11}), times=times, fields=())
    assert r.status == "ok"
    rigid = _rigid_heave(p, times)
    assert np.max(np.abs(r.amplitudes[:, 0] - rigid)) < bound * np.max(np.abs(rigid))


def test_a_rigid_floe_on_finite_depth_heaves_with_that_depths_added_mass():
    """E x 1e8 on water 3 m deep (H / L = 0.5): the heave follows the rigid floe's one equation
    with the heave added mass of that depth (1.52 x the deep water's), by the default numerics.
    Measured: 7.5e-7; with the deep water's added mass instead the heave is 47% off."""
    p = Parameters(Nmod=6, edges="free", duration=0.003, E=4.2e9 * 1e8, H=3.0)
    added = floe.added_mass(np.array([floe.HEAVE], float), np.zeros(1), p.L, p.rho_w, H=p.H)[0, 0]
    assert 1.4 < added / (p.rho_w * math.pi * p.L**2 / 2) < 1.7
    times = np.linspace(0, p.duration, 11)
    r = solve(p, Settings(tolerance=1e-11, error_estimate=False), times=times, fields=())
    assert r.status == "ok"
    rigid = _rigid_heave(p, times, added)
    assert np.max(np.abs(r.amplitudes[:, 0] - rigid)) < 1e-5 * np.max(np.abs(rigid))
    deep = _rigid_heave(p, times)
    assert np.max(np.abs(deep - rigid)) > 1e-2 * np.max(np.abs(rigid))      # the depth matters


def _finite_difference_added_mass(L, H, psi, n):
    """rho_w = 1: int phi psi dx on the floe, phi from the 5-point Laplacian on [-X, X] x [-H, 0],
    cells H / n: phi = 0 on the open surface and at x = +-X (X = L + 12 H: phi decays as
    exp(-pi |x| / 2H) beyond the floe), phi_y = psi on the floe, phi_y = 0 on the bottom (ghost
    nodes). Independent of the Galerkin solution; first order in the cell (the edges' sqrt)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl
    X, h = L + 12 * H, H / n
    x = np.linspace(-X, X, int(round(2 * X / h)) + 1)
    hx, nx, ny = x[1] - x[0], x.size, n + 1
    on = np.abs(x) < L
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    r = i * ny + j
    fixed = (i == 0) | (i == nx - 1) | ((j == 0) & ~on[i])
    rows, cols, vals = [r[fixed]], [r[fixed]], [np.ones(fixed.sum())]
    inner = ~fixed
    ri, ii, jj = r[inner], i[inner], j[inner]
    for dc, v in ((-ny, 1 / hx**2), (ny, 1 / hx**2), (0, -2 / hx**2 - 2 / h**2)):
        rows.append(ri), cols.append(ri + dc), vals.append(np.full(ri.size, v))
    up = np.where(jj == 0, 0.0, 1 / h**2) + np.where(jj == n, 1 / h**2, 0.0)        # mirror at the bottom
    down = np.where(jj == n, 0.0, 1 / h**2) + np.where(jj == 0, 1 / h**2, 0.0)      # ghost above the floe
    rows += [ri[jj > 0], ri[jj < n]]
    cols += [ri[jj > 0] - 1, ri[jj < n] + 1]
    vals += [up[jj > 0], down[jj < n]]
    b = np.zeros(nx * ny)
    surface = inner & (j == 0)
    b[r[surface]] = -2 * psi(x[i[surface]]) / h
    A = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nx * ny,) * 2)
    phi = spl.spsolve(A, b)[::ny]
    return np.sum(np.where(on, hx, 0.0) * phi * psi(x))


def test_the_bessel_table_is_scipys():
    """floe.bessel_table (recurrences: forward where x >= n, Miller's backward elsewhere) against
    scipy.special.jv for n = 0..200, x from 1e-4 to 1600 (the depth correction's range at
    H / L = 1/80): within 3.5e-14 measured, at 1/40 of jv's time."""
    from scipy import special
    from solver.model.depth import bessel_table
    x = np.concatenate([np.geomspace(1e-4, 5.0, 300), np.linspace(5.0, 1600.0, 3000), [200.0, 199.5, 200.5]])
    table = bessel_table(200, x)
    assert np.max(np.abs(table - special.jv(np.arange(201)[:, None], x[None, :]))) < 1e-13


def test_added_mass_on_finite_depth():
    """The floe's added mass on water of depth H (floe.added_mass, depth.depth_correction):
    as H -> inf the deep water's matrix (1/H^2: 2.0e-3 of heave at H / L = 10, 2.1e-5 at 100);
    as H / L -> 0 the shallow water's heave 2 rho L^3 / (3H) (H phi_xx = -w_t under the floe,
    phi = 0 at its edges; ratio 1.040, 1.013 at H / L = 0.03, 0.01: as 1 + 1.3 H / L); at H / L =
    0.5 a finite-difference solve of the potential problem agrees, Richardson-extrapolated from
    cells of H / 20 and H / 40 (heave 1.2e-4, pitch 1.4e-4; from H / 40 and H / 80: 3e-5, 3.5e-5;
    the finest alone is 1.1e-2 and 1.9e-2 off)."""
    L, rho = 1.0, 1000.0
    kinds, betas = floe.dry_modes(L, 3)
    deep = floe.added_mass(kinds, betas, L, rho)
    near = floe.added_mass(kinds, betas, L, rho, H=1000.0)
    assert np.max(np.abs(near - deep)) < 1e-6 * np.max(np.abs(deep))
    heave, pitch = np.array([floe.HEAVE, floe.PITCH], float), np.zeros(2)
    ratios = [floe.added_mass(heave, pitch, L, rho, H=H)[0, 0] / (2 * rho * L**3 / (3 * H)) for H in (0.03, 0.01)]
    assert 1.0 < ratios[1] < ratios[0] < 1.05 and (ratios[0] - 1) / (ratios[1] - 1) == pytest.approx(3, rel=0.1)
    A = floe.added_mass(heave, pitch, L, rho, H=0.5)
    for m, psi in ((0, lambda x: np.ones_like(x)), (1, lambda x: x / L)):
        coarse, fine = (rho * _finite_difference_added_mass(L, 0.5, psi, n) for n in (20, 40))
        assert 2 * fine - coarse == pytest.approx(A[m, m], rel=2e-4)
        assert abs(fine - A[m, m]) > 1e-3 * A[m, m]          # the extrapolation does the work


def test_a_floe_needs_a_duration():
    with pytest.raises(ParameterError, match="duration"):
        Parameters(edges="free")
    with pytest.raises(ParameterError, match="edges"):
        Parameters(edges="open")


@pytest.mark.slow   # issue 35: make test within 5 min; kept in make test-slow
def test_a_viscoelastic_floe():
    """Kelvin-Voigt ice on a floe: the wet modes' damping tau Q^T K_b Q keeps its diagonal in the
    kernels (one exact damped oscillator per wet mode). Energy identity with the dissipation;
    DOP853 on the same equations; and DOP853 with the whole matrix, the exact Kelvin-Voigt floe,
    measures what the diagonal leaves out: 1.2e-6 of the largest strain at tau = 1e-4 s and
    1.1e-5 at 1e-3 s (as tau), while the damping itself moves the strain by 11% and 31%."""
    from solver import layout as kn
    from solver.control import BOTTOM_GAP, make_control
    from solver.diagnostics import Outputs
    from solver.model.assemble import Tables
    from solver.scipy_reference import integrate_dop853
    times = np.linspace(0, 0.05, 51)
    left_out = []
    for tau in (1e-4, 1e-3):
        p = Parameters(Nmod=10, edges="free", duration=0.05, tau=tau)
        r = solve(p, Settings(**{**FLOE, "tolerance": 1e-11}), times=times, fields=("strain",))
        d = solve(p, Settings(**{**FLOE, "integrator": "dop853", "tolerance": 1e-12}), times=times, fields=("strain",))
        assert r.status == "ok" and r.diagnostics["energy_residual"] < 1e-5
        assert 0.01 < r.dissipated_energy[-1] / r.work[-1] < 0.5
        top = np.max(np.abs(r.fields["strain"]))
        assert np.max(np.abs(r.fields["strain"] - d.fields["strain"])) < 1e-6 * top
        tab = Tables(p, FLOE["subintervals"], False, "paper", 4.0)
        zero = np.zeros(tab.omega.size)
        strain = []
        control = make_control(0.0, p.duration, 1e-12, 0.0, 1e-8, 0.0, np.inf, 10**6, BOTTOM_GAP)
        for coupled in (False, True):
            T, N = times.size, zero.size
            out = Outputs(np.full((T, N), np.nan), np.full((T, N), np.nan), np.full((T, kn.N_SERIES), np.nan),
                          np.full(kn.N_DIAG, np.nan), np.full((2, 0), np.nan), np.full((2, 0), np.nan),
                          np.empty((2, N + 1)))
            integrate_dop853(tab, control, times, zero, zero, np.empty(0), out, coupled_damping=coupled)
            strain.append(out.a @ tab.mode_values(np.linspace(0, p.L, 301), "strain").T)
        left_out.append(np.max(np.abs(strain[1] - strain[0])) / np.max(np.abs(strain[0])))
    assert left_out[0] < 5e-6 and 4 < left_out[1] / left_out[0] < 20, left_out


def test_the_floe_and_the_walled_plate_agree_near_the_impact_as_L_grows():
    """Up to crack onset at eps_Y = 8e-5 (0.72 ms at 5 m/s) and near the impact (|x| <= 1.5 m,
    t <= 1 ms), the free floe and the walled plate of the same L (same dx and last wavenumber)
    agree better as L grows, at the rate 1/L: measured crack-onset times 3.1e-3, 1.6e-3, 8.1e-4
    apart and strains 1.7e-3, 8.5e-4, 4.3e-4 of the largest at L = 6, 12, 24 m (and 5.9e-3,
    4.1e-4 at 3 and 48 m). What differs is global: the walls' int w dx = 0 against the floe's
    heave, whose effect on the impact falls as the plate's length grows."""
    onset, strain = [], []
    for L, N in ((6.0, 20), (12.0, 40), (24.0, 80)):
        settings = Settings(**{**FLOE, "subintervals": int(500 * L / 6)})
        walls = Parameters(Nmod=N, L=L, duration=0.004)
        runs = [solve(q, settings, fields=("strain",), times=np.linspace(0, 0.001, 5), x=np.linspace(-1.5, 1.5, 61))
                for q in (walls, walls.replace(edges="free"))]
        t = [r.crack_onset([8e-5])[0][0] for r in runs]
        onset.append(abs(t[0] - t[1]) / t[0])
        top = np.max(np.abs(runs[0].fields["strain"]))
        strain.append(np.max(np.abs(runs[0].fields["strain"] - runs[1].fields["strain"])) / top)
    for errors in (onset, strain):
        rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
        assert np.all((rates > 0.8) & (rates < 1.2)), errors
    assert onset[-1] < 1e-3 and strain[-1] < 6e-4


@pytest.mark.parametrize("changes", [dict(body_mass=800.0), dict(deadrise=10.0, x0=0.7),
                                     dict(flat_width=0.3, layer_law="linear", layer_tau=1e-3)])
def test_a_floe_takes_the_bodies_and_layers_of_the_walled_plate(changes):
    """A body of finite mass (its own energy balance), a wedge off centre, a flat-bottomed body
    on a viscoelastic Winkler layer: on the floe each keeps the energy identity (with the
    layer's dissipation) as on the walled plate, to the paper's rule's accuracy, falling as
    dx^2. Measured at 1000 and 4000 subintervals: 4.8e-5 and 3.0e-6 (free body), 3.0e-4 and
    1.9e-5 (wedge off centre, whose layer bottoms out at 4.5 ms), 1.9e-6 and 1.2e-7 (flat body,
    viscoelastic Winkler layer); the walled plate's within 2%."""
    residual = {}
    for edges in ("walls", "free"):
        for sub in (1000, 4000):
            p = Parameters(Nmod=10, edges=edges, duration=0.03, **changes)
            r = solve(p, Settings(**{**FLOE, "subintervals": sub, "tolerance": 1e-9}), fields=())
            assert r.status in ("ok", "layer_bottomed_out"), r.message
            residual[edges, sub] = r.diagnostics["energy_residual"]
            if p.free_body:
                assert r.diagnostics["body_energy_residual"] < 1e-9 and r.body_speed[-1] < p.V
    for sub in (1000, 4000):
        assert residual["free", sub] < 1.2 * residual["walls", sub] + 1e-8
    assert residual["free", 4000] < residual["free", 1000] / 8


def test_the_depth_correction_in_chunks_and_past_round_off(monkeypatch):
    """Its k-nodes a chunk at a time (a floe of L = 1000 m on H = 0.01 m needed 7.7 GiB at once):
    the same matrix to round-off; a depth beyond DEEP_ENOUGH L gives zero (H = 1e300 made the
    Bessel recurrence overflow: an internal error), and such a floe runs as on deep water."""
    from solver.model import depth
    whole = depth.depth_correction(30, 6.0, 0.5)
    monkeypatch.setattr(depth, "DEPTH_NODES_AT_ONCE", 100)
    np.testing.assert_allclose(depth.depth_correction(30, 6.0, 0.5), whole, rtol=0, atol=1e-14 * np.abs(whole).max())
    assert not depth.depth_correction(30, 6.0, 6.0 * depth.DEEP_ENOUGH * 2).any()
    p = dict(Nmod=10, edges="free", duration=0.05)
    deep, far = (solve(Parameters(**p, H=H), Settings(error_estimate=False), fields=()) for H in (math.inf, 1e300))
    assert far.status == deep.status == "ok"
    assert far.diagnostics["max_strain"] == pytest.approx(deep.diagnostics["max_strain"], rel=1e-9)
