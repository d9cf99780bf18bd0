"""Growable records (rows of floats) that the observers append to inside the kernels."""
from collections import namedtuple

import numpy as np

from ..arrays import copy_into
from ..compile.jit import kernel

#: a growable record (append_row): its rows and how many of them are filled
Rows = namedtuple("Rows", "rows n")
#: the records of both surfaces (upper: row 0 of the tension arrays), each with its count of
#: filled rows
SurfaceRows = namedtuple("SurfaceRows", "upper n_upper lower n_lower")


@kernel(nrt=True)
def append_row(buf, n, row0, row1, row2, row3, row4):
    """Append a row (the first columns of it) to a growable record; returns (buf, n)."""
    if n == buf.shape[0]:
        bigger = np.empty((2 * buf.shape[0], buf.shape[1]))
        for i in range(n):
            copy_into(bigger[i], buf[i], buf.shape[1])
        buf = bigger
    buf[n, 0] = row0
    buf[n, 1] = row1
    if buf.shape[1] > 2:
        buf[n, 2] = row2
        buf[n, 3] = row3
        buf[n, 4] = row4
    return buf, n + 1
