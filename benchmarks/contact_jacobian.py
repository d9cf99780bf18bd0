"""Would the contact's Jacobian inside the exponential shorten the steps? (issue 56)
python benchmarks/contact_jacobian.py [--modes 10] [--block M] [--window 0.005 0.03] [--steps 25 50 100 200]
    [--case reference|thin] [--diagonal]

A prototype in numpy, not the solver's code: the paper's body (prescribed) on the reference case
at N modes, integrated over a window that starts inside the contact (the state there from the
solver at tolerance 1e-13, so that first touch, whose force grows as t^(3/2), is left out), by

* etd4: Krogstad's fourth-order exponential Runge-Kutta with the free modes as the linear part
  and the whole layer reaction explicit (the scheme etd34 steps with), at fixed steps;
* exprb43: the exponential Rosenbrock scheme of Hochbruck, Ostermann & Schweitzer (SIAM J.
  Numer. Anal. 47, 2009), fourth order, whose linear part is the free modes plus the layer
  reaction's Jacobian at the step's start (by finite differences: N + 1 forcings a step; with
  ``--block m`` only its coupling among the first m modes, the rest explicit as in etd4), at the
  same fixed steps;
* etd4 with the Jacobian: etd4 whose linear part is, for each step, exprb43's (with ``--block``,
  the coupling among the first m modes only: ETD4 is fourth order for any linear part, exprb43
  only for the whole Jacobian);
* with ``--diagonal``, etd4 whose linear part is the free modes plus the Jacobian's diagonal (each
  mode's own contact stiffness, which makes its oscillation inside a step exact);
* etd34 adaptive (the solver itself, restarted at the window's start) at tolerances 1e-7..1e-11.

``--case thin`` runs thin ice hit fast (hi 0.3 m, V 10 m/s, K 8e7 Pa) instead of the reference case.

Each run's error: the modal energy norm of a(t_end) against the solver's at tolerance 1e-13.
If the contact's stiffness set the step, exprb43 would be far more accurate than etd4 at the
same steps.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.linalg import expm

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from solver import Parameters, Settings, solve  # noqa: E402
from solver.model.assemble import Tables  # noqa: E402
from solver.model.layer import layer_forcing_at  # noqa: E402


class Problem:
    """y = (a, a', t): y' = L y + (0, P(t, a), 1), L the free modes; P the layer reaction."""

    def __init__(self, p, block=None):
        self.block = p.Nmod if block is None else block
        tables = Tables(p, 250, False, "gauss", 4.0)
        self.model, self.V, self.N = tables.model, p.V, p.Nmod
        self.omega = np.asarray(tables.omega, float)
        J = self.model.basis.cosq.shape[1]
        self.delta, self.fvals, self.P = np.empty(J), np.empty(J), np.empty(self.N)
        N, M = self.N, 2 * self.N + 1
        self.L = np.zeros((M, M))
        self.L[:N, N:2 * N] = np.eye(N)
        self.L[N:2 * N, :N] = -np.diag(self.omega ** 2)

    def forcing(self, t, a):
        status = layer_forcing_at(self.model, self.V * t, self.V, a, 0.0 * a, self.delta, self.fvals, self.P)[0]
        assert status == 0
        return self.P.copy()

    def rhs(self, y):
        N = self.N
        out = self.L @ y
        out[N:2 * N] += self.forcing(y[2 * N], y[:N])
        out[2 * N] = 1.0
        return out

    def jacobian(self, y):
        N, a, t = self.N, y[:self.N], y[2 * self.N]
        A = self.L.copy()
        P0 = self.forcing(t, a)
        step = 1e-7 * max(1e-6, np.max(np.abs(a)))
        b = self.block
        for m in range(b):
            da = a.copy()
            da[m] += step
            A[N:N + b, m] += ((self.forcing(t, da) - P0) / step)[:b]
        A[N:N + b, 2 * N] = ((self.forcing(t + 1e-9, a) - P0) / 1e-9)[:b]
        return A


def phis(Z, k):
    """phi_0 .. phi_k of the matrix Z (the exponential of a block matrix)."""
    n = Z.shape[0]
    B = np.zeros(((k + 1) * n, (k + 1) * n))
    B[:n, :n] = Z
    for i in range(k):
        B[i * n:(i + 1) * n, (i + 1) * n:(i + 2) * n] = np.eye(n)
    E = expm(B)
    return [E[:n, i * n:(i + 1) * n] for i in range(k + 1)]


def etd4_coefficients(h, A):
    """(e, phi_1..3) of h A and (e, phi_1, phi_2) of h A / 2: Krogstad's weights."""
    return phis(h * A, 3), phis(0.5 * h * A, 2)


def diagonal_step(problem, y, h):
    """etd4 whose linear part is the free modes and the diagonal of the layer reaction's Jacobian."""
    J, N = problem.jacobian(y), problem.N
    A = problem.L.copy()
    A[N + np.arange(N), np.arange(N)] = J[N + np.arange(N), np.arange(N)]
    return etd4_step(problem, y, h, etd4_coefficients(h, A), A)


def etd4_step(problem, y, h, coefficients=None, linear=None):
    """Krogstad's ETD4 (the stages of solver/step.py) with the free modes as the linear part, or
    (coefficients None) with the free modes and the layer reaction's Jacobian at y (among the first
    ``block`` modes) as the linear part of this step: ETD4 is fourth order for any linear part."""
    A = linear if linear is not None else problem.L if coefficients is not None else problem.jacobian(y)
    if coefficients is None:
        coefficients = etd4_coefficients(h, A)
    (e, p1, p2, p3), (e2, q1, q2) = coefficients

    def rest(u):
        return problem.rhs(u) - A @ u
    N1 = rest(y)
    U2 = e2 @ y + 0.5 * h * (q1 @ N1)
    N2 = rest(U2)
    N3 = rest(U2 + h * (q2 @ (N2 - N1)))
    N4 = rest(e @ y + h * (p1 @ N1) + 2 * h * (p2 @ (N3 - N1)))
    return e @ y + h * ((p1 - 3 * p2 + 4 * p3) @ N1 + (2 * p2 - 4 * p3) @ (N2 + N3) + (4 * p3 - p2) @ N4)


def exprb43_step(problem, y, h):
    """exprb43 with the Jacobian at y as the linear part."""
    A = problem.jacobian(y)

    def g(u):
        return problem.rhs(u) - A @ u
    f, gy = problem.rhs(y), g(y)
    _, p1, _, p3, p4 = phis(h * A, 4)
    _, q1 = phis(0.5 * h * A, 1)
    D2 = g(y + 0.5 * h * (q1 @ f)) - gy
    D3 = g(y + h * (p1 @ f) + h * (p1 @ D2)) - gy
    return y + h * (p1 @ f) + h * (p3 @ (16 * D2 - 2 * D3)) + h * (p4 @ (-48 * D2 + 12 * D3))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", type=int, default=10)
    ap.add_argument("--block", type=int, default=None, help="the Jacobian among the first BLOCK modes only")
    ap.add_argument("--window", type=float, nargs=2, default=(0.005, 0.03))
    ap.add_argument("--steps", type=int, nargs="+", default=[25, 50, 100, 200])
    ap.add_argument("--no-adaptive", action="store_true", help="leave out the solver's adaptive runs")
    ap.add_argument("--case", choices=["reference", "thin"], default="reference")
    ap.add_argument("--diagonal", action="store_true", help="also etd4 with the Jacobian's diagonal as linear part")
    args = ap.parse_args()
    case = {"reference": {}, "thin": {"hi": 0.3, "V": 10.0, "K": 8e7}}[args.case]
    p = Parameters(Nmod=args.modes, **case)
    t0, t1 = args.window
    problem = Problem(p, args.block)
    N = problem.N
    ref = solve(p, Settings(error_estimate=False, tolerance=1e-13, error_control="embedded"), times=[0.0, t0, t1], fields=(), t_end=t1)
    a, v = np.asarray(ref.amplitudes), np.asarray(ref.velocities)
    a_ref = a[-1][:N]

    def error(a_end):
        return np.sqrt(np.sum(((a_end - a_ref) * problem.omega) ** 2) / np.sum((a_ref * problem.omega) ** 2))

    schemes = ("etd4", "exprb43", "etd4 jacobian") + (("etd4 diagonal",) if args.diagonal else ())
    print(f"{args.case} case, N = {N}, the Jacobian among the first {problem.block} modes, window [{t0}, {t1}] s")
    print("| steps | etd4 error | exprb43 error | etd4 with the Jacobian error |"
          + (" etd4 with its diagonal error |" if args.diagonal else "") + "\n|---|---|---|---|"
          + ("---|" if args.diagonal else ""))
    for steps in args.steps:
        h = (t1 - t0) / steps
        coefficients = etd4_coefficients(h, problem.L)
        ends = []
        for scheme in schemes:
            y = np.concatenate([a[1][:N], v[1][:N], [t0]])
            for _ in range(steps):
                if scheme == "etd4":
                    y = etd4_step(problem, y, h, coefficients)
                elif scheme == "exprb43":
                    y = exprb43_step(problem, y, h)
                elif scheme == "etd4 diagonal":
                    y = diagonal_step(problem, y, h)
                else:
                    y = etd4_step(problem, y, h)
            ends.append(error(y[:N]))
        print("| " + " | ".join([str(steps)] + [f"{e:.2e}" for e in ends]) + " |", flush=True)
    print("\n| etd34 adaptive: tolerance | steps (rejected) | error | smallest step [s] |\n|---|---|---|---|")
    for tolerance in () if args.no_adaptive else (1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        r = solve(p, Settings(error_estimate=False, tolerance=tolerance), times=[t0, t1], fields=(), t_end=t1,
                  t_start=t0, initial_amplitudes=a[1][:N], initial_velocities=v[1][:N])
        print(f"| {tolerance:.0e} | {r.steps} ({r.rejected_steps}) | {error(np.asarray(r.amplitudes)[-1][:N]):.2e} "
              f"| {r.smallest_step:.1e} |", flush=True)


if __name__ == "__main__":
    main()
