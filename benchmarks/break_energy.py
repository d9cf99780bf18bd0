"""What each break of random breaking cases removes, split into the plate's part and the layer's
(docs/model.md, "The energy identity through the breaks"): the plate's part is never negative (the
carry is a Galerkin projection in the plate's own energies), the layer's can be, since the
projection moves w under the body, so a break can add energy in all.

    python benchmarks/break_energy.py [--seed S] [--cases N]

Draws the paper's body (and one option: off centre, finite depth, a free body) on ice 0.05-1 m
thick, layers of stiffness 1e5-1e9 Pa and thickness 5-50 mm, N = 10-40, yield strains 2e-5-1e-3,
2 or 5 ms. Measured 2026-12-06 (--seed 7, 400 draws): 71 breaks in 52 cases added energy; the
worst added 2.0 % of the energy before it (N = 10, hi = 0.2 m, K = 4.2e8 Pa, he = 5 mm, off
centre), the median of those 0.056 %; the plate's part was positive at every break.
"""
from __future__ import annotations

import argparse

import numpy as np

from solver import ParameterError, Parameters, Settings, solve


def draw(rng) -> dict:
    kw = dict(Nmod=int(rng.choice([10, 20, 30, 40])), hi=float(rng.choice([0.05, 0.1, 0.2, 0.5, 1.0])),
              V=float(10 ** rng.uniform(-0.5, 1.5)), fracture="break", yield_strain=float(10 ** rng.uniform(-4.7, -3.0)),
              K=float(10 ** rng.uniform(5, 9)), he=float(rng.choice([0.005, 0.02, 0.05])),
              duration=float(rng.choice([2e-3, 5e-3])))
    option = rng.integers(0, 5)
    if option == 1:
        kw["x0"] = float(rng.uniform(-2, 2))
    elif option == 2:
        kw["H"] = float(rng.uniform(0.3, 3))
    elif option == 3:
        kw["body_mass"] = float(10 ** rng.uniform(1.5, 4))
    return kw


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--cases", type=int, default=400)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    breaks, adding, plate_negative, relative = 0, [], 0, []
    for i in range(args.cases):
        kw = draw(rng)
        try:
            p = Parameters(**kw)
        except ParameterError:
            continue
        r = solve(p, Settings(error_estimate=False), fields=(), times=np.linspace(0, p.duration, 11))
        for stage in r.breaking.stages if r.breaking is not None else ():
            energy = stage.end.carried
            if energy is None:
                continue
            breaks += 1
            plate, layer = energy.plate_removed, energy.layer_removed
            plate_negative += plate < 0
            if plate + layer < 0:
                adding.append(i)
                relative.append(-(plate + layer) / (energy.plate_before + energy.layer_before))
                print(f"{i:4d} adds {-(plate + layer):.3g} J/m, {relative[-1]:.2e} of the energy before (plate "
                      f"{plate:.3g}, layer {layer:.3g}) {kw}", flush=True)
    print(f"{breaks} breaks; {len(adding)} in {len(set(adding))} cases added energy (worst "
          f"{max(relative, default=0.0):.2e}, median {np.median(relative) if relative else 0.0:.2e} of the energy "
          f"before); the plate's part was negative at {plate_negative}")


if __name__ == "__main__":
    main()
