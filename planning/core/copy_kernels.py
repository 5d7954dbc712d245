"""The copies nhsim's compiled kernels make of one array into another.

Kernels copy one array into another with :func:`copy_into` and :func:`copy_rows_into`, not by slice
assignment (``dst[:] = src``, ``dst[i] = row``): numba compiles that with the error it raises on a shape
mismatch, whose message formatting took 4-5 s to compile in every process that compiled such a kernel
afresh, once per pair of dimensions (1-D and 2-D: 10 s; measured alone, a kernel of one plain loop
compiling in 0.6 s). The kernels' disk cache skips it; a new machine, an update and every test worker
pay it. (Apart from :mod:`planning.core.arrays`, whose value types every command's parser imports: numba
is imported by the commands that run kernels, not by a ``--help``.)
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray


@nb.njit(cache=True)
def copy_into(dst: NDArray[np.generic], src: NDArray[np.generic]) -> None:  # pragma: no cover - compiled
    """``dst[k] = src[k]`` for each k of two 1-D arrays of one length (a view as ``dst`` writes through)."""
    if dst.shape[0] != src.shape[0]:
        raise ValueError("copy_into: the arrays differ in length")
    for k in range(src.shape[0]):
        dst[k] = src[k]


@nb.njit(cache=True)
def copy_rows_into(dst: NDArray[np.generic], src: NDArray[np.generic]) -> None:  # pragma: no cover - compiled
    """``dst[i, j] = src[i, j]`` for each entry of two 2-D arrays of one shape."""
    if dst.shape[0] != src.shape[0] or dst.shape[1] != src.shape[1]:
        raise ValueError("copy_rows_into: the arrays differ in shape")
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]
