"""How the broken plate's added mass converges in the number of cosines K it sums before its
tail (solver.model.parts.channel_added_mass; docs/model.md, "The run that breaks", Cost): the
largest difference from 2**18 terms, relative to the largest entry, and the time of one sum.

    python benchmarks/added_mass_terms.py

Measured 2026-12-06 (N = 60, the half plate; the tail to its second order, solver.model.parts.jump_tail):
it falls as K^-6; at 2048 terms (the default) 2e-16 (broken at the centre) to 1.1e-13 (at 5
places, or with a part 1 cm long), at 1024 terms 8e-15 to 7e-12, in 10 to 13 ms a sum. With the
earlier tail (each jump's value alone, sin^2 at its mean) it fell as K^-4: 2.2e-12 at 16384
terms, 2e-9 at 2048.
"""
import time

import numpy as np

from solver import Parameters
from solver.model import parts


def main():
    p = Parameters(Nmod=60)
    beta_max = np.pi * p.Nmod / p.L
    print("| breaks [m] | dry modes | K | largest difference / largest entry | time [ms] |")
    print("|---|---|---|---|---|")
    for breaks in ([0.0], [0.0, 0.3], [0.0, 0.3, 0.6, 1.1, 2.0], [0.0, 0.3, 0.31, 2.0]):
        modes = parts.part_modes(p.L, breaks, beta_max)
        reference = parts.channel_added_mass(modes, p.L, 2.0, p.rho_w, p.H, terms=2**18)
        for K in (512, 1024, 2048, 4096, 16384, 65536):
            parts._PART_ROWS.clear()                  # (each sum from scratch)
            started = time.perf_counter()
            A = parts.channel_added_mass(modes, p.L, 2.0, p.rho_w, p.H, terms=K)
            spent = time.perf_counter() - started
            error = np.max(np.abs(A - reference)) / np.max(np.abs(reference))
            print(f"| {breaks} | {modes.kinds.size} | {K} | {error:.2e} | {1e3 * spent:.1f} |")


if __name__ == "__main__":
    main()
