"""Arrays as nhsim's compiled kernels take the inputs they only read.

numba compiles a kernel once per combination of argument types, and an array's writability is part of
its type. nhsim's value types (plans, trajectories, robot specs, run logs) hold read-only arrays, while
the arrays a kernel builds and hands to the kernels it calls are writable: a kernel met with both
compiles twice, and one of two array inputs up to four times (the largest take seconds each, and every
process on a new machine or after an update pays for them). Python code passes each array input
through :func:`kernel_input`, so a kernel sees the one type its compiled callers give it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def kernel_input(values: ArrayLike) -> NDArray[np.float64]:
    """``values`` as a C-contiguous, writable float64 array: the array itself when it already is one (the
    kernels given it only read it), else a copy."""
    out = np.ascontiguousarray(values, dtype=np.float64)
    return out if out.flags.writeable else out.copy()
