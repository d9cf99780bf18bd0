"""A broken plate's tables in a free floe's form for the kernels (docs/model.md, "Breaking into
parts"): its wet modes (solver.model.parts) at the nodes, their hat weights and largest values,
the shapes table the kernels read each dry mode's kind, wavenumber, centre, half-length and part
from (solver.model.floe), the header with the breaks, and the Kelvin-Voigt damping.

Benchmark (tests/test_parts.py): the kernels' point sums and dry-mode table on these tables
against the parts' modes in numpy; a run's stages reuse each part's rows bit for bit.
"""
import numpy as np

from . import floe as fl
from ..blas import blas_alone
from .broken import wet_parts
from .quadrature import legendre_rule
from .parts import (PartModes, by_part, edge_shaped, free_ends, gram, kernel_shapes, part_edges, part_lengths,
                    part_values, values_at)


@blas_alone
def parts_tables(p, xq, breaks, full: bool, beta_max: float) -> dict:
    """Everything the kernels need of the plate of parameters p broken at ``breaks`` (kernel
    coordinates: 0..L on the half plate of a centred impact, 0..2L on the whole), in the form of
    a floe's tables (solver.model.floe.floe_tables, whose kernels read each dry mode's centre,
    half-length and part from the shapes table): omega, mass (the generalised masses 1 / s_k^2
    [kg m-1]), damping and damping_matrix (Kelvin-Voigt), cosq (N, J) the wet modes at the nodes
    xq, packed, strain_scale, scale (max |Psi_k|: the kernel's amplitude of wet mode k is b_k
    scale_k), Q (the scaled wet modes, Nd x Nd: the last a null mode, as the kernels pair wet and
    dry modes one to one), the dry modes' betas, and the WetParts. The parts' wavenumbers go up to
    beta_max [m-1]."""
    domain, mirror = (2.0 if full else 1.0) * p.L, 1.0 if full else 2.0
    wet = wet_parts(p, domain, mirror, breaks, beta_max)
    modes, x = wet.modes, np.asarray(xq, dtype=float)
    fine = np.linspace(0.0, domain, 8 * (x.size - 1) + 1)
    scale = np.max(np.abs(wet.Q.T @ part_values(modes, fine)), axis=1)
    Qs = wet.Q / scale
    values = [Qs.T @ part_values(modes, x, order) for order in range(3)]
    # the kernels pair wet and dry modes one to one, and int w dx = 0 leaves one wet mode fewer
    # (and a near-dependent edge shape one more, wet_parts): the last wet modes are null ones
    # (no shape, never forced, at rest)
    N = modes.kinds.size
    null = N - wet.omega.size
    Qs = np.hstack([Qs, np.zeros((N, null))])
    values = [np.vstack([v, np.zeros((null, v.shape[1]))]) for v in values]
    omega, scale = np.append(wet.omega, np.full(null, wet.omega[-1])), np.append(scale, np.ones(null))
    Q = np.hstack([wet.Q, np.zeros((N, null))])
    tables = np.empty((4,) + values[0].shape)
    tables[fl.TABLE_STRAIN] = -0.5 * p.hi * values[2]
    tables[fl.TABLE_SLOPE], tables[fl.TABLE_CURVATURE] = values[1], values[2]
    tables[fl.TABLE_HAT] = _hat_weights(Qs, modes, x)
    shapes = kernel_shapes(modes, 0.0, domain, fl.SHAPE_ROWS + 2 * N)
    edge = edge_shaped(modes)
    shapes[fl.SHAPE_ROWS:fl.SHAPE_ROWS + N] = Qs
    shapes[fl.SHAPE_ROWS + N:] = Qs.T
    header = np.zeros(fl.HEADER)
    header[fl.STRAIN_FACTOR], header[fl.HALF_LENGTH], header[fl.FIRST_EVEN] = -0.5 * p.hi, p.L, N
    cuts = part_edges(domain, breaks)[1:-1]
    if cuts.size > fl.MAX_BREAKS:
        raise ValueError(f"at most {fl.MAX_BREAKS} breaks, got {cuts.size}")
    header[fl.BREAK_COUNT] = cuts.size
    header[fl.FIRST_BREAK:fl.FIRST_BREAK + cuts.size] = cuts
    header[fl.CRACK_BAND] = p.crack_spacing * p.hi
    low_free, high_free = free_ends(domain, breaks)
    header[fl.LOW_CUT], header[fl.HIGH_CUT] = float(low_free), domain if high_free else 0.0
    if np.any(edge):
        bending = Q.T @ (mirror * p.rigidity * gram(modes, 2)) @ Q
    else:
        bending = Q.T @ (Q * (mirror * p.rigidity * modes.betas**4 * part_lengths(modes))[:, None])
    damping = p.tau * np.diag(bending).copy()
    damping[wet.omega.size:] = damping[wet.omega.size - 1]      # (the null modes', at rest: damped if any is)
    return {"omega": omega, "mass": 1.0 / scale**2, "cosq": np.ascontiguousarray(values[0]),
            "damping": damping,
            "damping_matrix": p.tau * bending * scale[:, None] / scale[None, :],
            "packed": fl.pack_floe(tables, shapes, header),
            "strain_scale": np.max(np.abs(tables[fl.TABLE_STRAIN]), axis=1), "betas": modes.betas, "wet": wet,
            "scale": scale, "Q": Qs}


def _hat_weights(Qs, modes: PartModes, x):
    """int hat_j Psi_k dx [m] (N, J) on the evenly spaced nodes x: the wet modes' combination of
    the dry modes' (_part_hats, each part's kept across a run's stages)."""
    x = np.asarray(x, dtype=float)
    return Qs.T @ by_part(modes, ("hats", x.tobytes()), lambda sub: _part_hats(sub, x), x.size)


def _part_hats(modes: PartModes, x):
    """int hat_j psi_m dx [m] (Nd, J) of the dry modes of one part on the evenly spaced nodes x: 8
    Gauss-Legendre nodes on each piece of a subinterval within the part (the modes are smooth
    there), the part's ends cutting the subintervals they fall in (an end within 1e-12 dx of a
    node taken at the node)."""
    dx = x[1] - x[0]
    ends = np.array([modes.lows[0], modes.highs[0]])
    ends = np.where(np.abs(ends / dx - np.round(ends / dx)) > 1e-12, ends, dx * np.round(ends / dx))
    cuts = np.unique(np.concatenate([ends, x[(x > ends[0]) & (x < ends[1])]]))
    lo, hi = cuts[:-1], cuts[1:]
    j = np.minimum(np.searchsorted(x, lo + 0.5 * (hi - lo), side="right") - 1, x.size - 2)   # each piece's subinterval
    gx, gw = legendre_rule(8)
    pts = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * gx[None, :]
    vals = values_at(modes, pts.ravel()).reshape(modes.kinds.size, lo.size, gx.size)
    t = (pts - x[j][:, None]) / dx
    w = 0.5 * (hi - lo)[:, None] * gw[None, :]
    hat = np.zeros((modes.kinds.size, x.size))
    np.add.at(hat.T, j, np.einsum("mpg,pg->pm", vals, w * (1.0 - t)))
    np.add.at(hat.T, j + 1, np.einsum("mpg,pg->pm", vals, w * t))
    return hat
