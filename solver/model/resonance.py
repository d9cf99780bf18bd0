r"""The integral of a part's dry mode against a cosine near resonance, in a closed form that does
not divide by beta^4 - mu^4 (docs/model.md, "The run that breaks", the tables' cost).

A part's elastic mode on [x_0, x_1] is, with y = x - c (c its centre, l its half-length), a
trigonometric part A cos(beta y + phi) (phi = 0 or -pi/2; none on an edge shape) plus a
hyperbolic part (e^{beta (y - l)} + s e^{-beta (y + l)}) / (1 + s e^{-2 beta l}) (s = +1
cosh-like, -1 sinh-like; none on a sliding part's cosine). Against cos(mu x) = cos(mu y + mu c):

    int A cos(beta y + phi) cos(mu x) dx = (A D / 2) [cos(d m + phi - mu c) S(d D / 2)
                                                    + cos(e m + phi + mu c) S(e D / 2)],

d = beta - mu, e = beta + mu, m the middle and D the length of [y_0, y_1], S(u) = sin(u) / u
(S(0) = 1): the difference of two sines over d written as their product, exact as d -> 0; and

    int e^{beta (y - l)} cos(mu x) dx = Re [e^{(beta + i mu) y - beta l + i mu c} / (beta + i mu)],
    int e^{-beta (y + l)} cos(mu x) dx = Re [e^{(-beta + i mu) y - beta l + i mu c} / (-beta + i mu)],

between y_0 and y_1, each exponential at most 1 on the part and each denominator at least mu.
The general closed form (solver.model.parts.cosine_integrals) takes the difference of the ends'
terms over beta^4 - mu^4, which loses digits as the two meet; until results revision breaking 14
the pairs within RESONANCE of it were integrated by Gauss-Legendre, mode by mode (half of a
broken plate's tables at N = 240).

Benchmark (tests/test_parts.py): against Gauss-Legendre on every pair near resonance of the
parts of plates broken at N = 60 and 240, with and without edge shapes; finite at exact
resonance, where it is the limit of its neighbours.
"""
import numpy as np


def near_resonance(amplitude, phase, hyperbolic, beta, centre, half, y0, y1, mu):
    """int psi(x) cos(mu x) dx over [c + y0, c + y1] for arrays of pairs of one shape (module
    docstring): amplitude, phase the trigonometric part's A and phi (A = 0: none), hyperbolic the
    hyperbolic part's s (+1, -1; 0: none), beta [m-1], centre c, half l, y0, y1 [m], mu [m-1].
    The mode unscaled (its norm not applied)."""
    length, middle = y1 - y0, 0.5 * (y0 + y1)
    d, e = beta - mu, beta + mu
    trig = 0.5 * amplitude * length * (np.cos(d * middle + phase - mu * centre) * np.sinc(d * length / (2 * np.pi))
                                       + np.cos(e * middle + phase + mu * centre) * np.sinc(e * length / (2 * np.pi)))
    grow, decay = beta + 1j * mu, -beta + 1j * mu

    def ends(y):
        return (np.exp(beta * (y - half) + 1j * mu * (y + centre)) / grow
                + hyperbolic * np.exp(-beta * (y + half) + 1j * mu * (y + centre)) / decay)
    hyp = np.real(ends(y1) - ends(y0)) / (1.0 + hyperbolic * np.exp(-2.0 * beta * half))
    return trig + np.where(hyperbolic != 0.0, hyp, 0.0)
