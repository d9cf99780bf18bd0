"""The rebound of a dropped body against its mass, with DOP853 beside etd34 (docs/model.md,
"The rebound against the mass"): python benchmarks/rebound.py [--nmod 20] [--body-g 0]

Prints, for each mass, the rebound speed over V from etd34 (tolerance 1e-8) and from scipy's
DOP853 on the same equations (tolerance 1e-10), the contact time in units of the fundamental
mode's half period pi t_sc, and the share of the body's initial energy M V^2 / 2 that is in
the ice when the body leaves (1 - e^2 with body_g = 0)."""
import argparse

import numpy as np

from solver import Parameters, Settings, solve

MASSES = [300.0, 1000.0, 3000.0, 1e4, 2e4, 3e4, 1e5, 3e5, 1e6]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nmod", type=int, default=20)
    ap.add_argument("--V", type=float, default=2.0)
    ap.add_argument("--body-g", type=float, default=0.0)
    ap.add_argument("--t-end", type=float, default=1.0, help="longest run [s]")
    args = ap.parse_args()
    print(f"N = {args.nmod}, V = {args.V} m/s, body_g = {args.body_g} m/s^2, the paper's case otherwise")
    print("| M [kg/m] | e = U_sep / V (etd34) | e (DOP853) | difference | contact / (pi t_sc) | "
          "energy left in the ice / (M V^2/2) |")
    print("|---|---|---|---|---|---|")
    for M in MASSES:
        p = Parameters(Nmod=args.nmod, V=args.V, body_mass=M, body_g=args.body_g)
        e, rows = {}, {}
        for integrator, tolerance in (("etd34", 1e-8), ("dop853", 1e-10)):
            r = solve(p, Settings(integrator=integrator, tolerance=tolerance, error_estimate=False), times=[0.0],
                      fields=(), until_separation=True, t_end=args.t_end)
            e[integrator] = r.diagnostics["separation_speed"] / args.V
            rows[integrator] = r
        r = rows["etd34"]
        left = (r.diagnostics["work"] - r.diagnostics["dissipated_energy"]) / (0.5 * M * args.V**2)
        contact = r.diagnostics["separation_time"] / (np.pi * p.time_scale)
        print(f"| {M:g} | {e['etd34']:.4f} | {e['dop853']:.4f} | {abs(e['etd34'] - e['dop853']):.1e} | "
              f"{contact:.2f} | {left:.3f} |")


if __name__ == "__main__":
    main()
