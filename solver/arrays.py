"""Copies between the kernels' work arrays, as plain loops.

``target[:] = source`` in a kernel makes numba compile its shape check, whose error message
formats the shapes as text: about 3.7 s of the first compile for the solver's copies
(docs/performance.md, "The first compile"). Every copy here is between buffers whose shapes the
loop fixed when it made them.
"""

from .compile.jit import kernel


@kernel
def copy_into(target, source, n):
    """target[:n] = source[:n] for 1-D arrays."""
    for i in range(n):
        target[i] = source[i]
