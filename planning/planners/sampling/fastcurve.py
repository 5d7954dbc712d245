"""Exact-curve steering for the tree planners in one compiled call: solve, sample and cut.

:func:`steer_kernel` returns exactly the samples that ``CurveSteering.curve(...)`` followed by
``Word.sample(step)``, the end pose pinned, and the chord-length cut of :class:`LocalPlanner` return
(the same solver, sampler and operation order), without the Python objects in between: the tree
planners spend most of their time in these calls, one per extension, connection or rewiring.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.curves.dubins import DUBINS_WORDS
from planning.curves.dubins import _solve as _dubins_solve
from planning.curves.reeds_shepp import RS_WORDS
from planning.curves.reeds_shepp import _solve as _rs_solve
from planning.curves.words import _sample_word

FloatArray = NDArray[np.float64]


@nb.njit(cache=True)
def _chord_cut(poses: FloatArray, length: float, from_end: bool) -> int:
    """Largest k such that the chords over the first (or, ``from_end``, the last) k steps sum to
    at most ``length`` [m] (the cumulative chord length the planners used before, summed in the same order)."""
    n = poses.shape[0]
    acc = 0.0
    k = 0
    for i in range(1, n):
        a, b = (n - 1 - i, n - i) if from_end else (i, i - 1)
        acc += np.hypot(poses[a, 0] - poses[b, 0], poses[a, 1] - poses[b, 1])
        if acc > length:
            break
        k = i
    return k


@nb.njit(cache=True)
def steer_kernel(
    reeds_shepp: bool, q0: FloatArray, q1: FloatArray, rho: float, step: float, max_len: float, keep_end: bool
) -> tuple[FloatArray, FloatArray, bool]:
    """Samples of the shortest curve from ``q0`` (3,) to ``q1`` (3,), cut to ``max_len`` of chords.

    Args:
        reeds_shepp: Reeds–Shepp curves, else Dubins.
        q0, q1: Start and end poses of the curve (contiguous float64).
        rho: Turning radius [m].
        step: Largest arc length between samples [m].
        max_len: Longest kept chord length [m] (inf: the whole curve).
        keep_end: Keep the part ending at ``q1`` (a backwards extension), else the part from ``q0``.

    Returns:
        (K, 3) poses, (K,) directions (+1 / -1), and False when no curve verifies (non-finite input).
    """
    a, b = q0.reshape((1, 3)), q1.reshape((1, 3))
    if reeds_shepp:
        _, types, segs = _rs_solve(a, b, rho)
        words = RS_WORDS
    else:
        _, types, segs = _dubins_solve(a, b, rho)
        words = DUBINS_WORDS
    if types[0] < 0:
        return np.empty((0, 3)), np.empty(0), False
    # Word.sample's normalised lengths: (segment * rho) / rho, zeros kept (the sampler skips them).
    norm = np.empty(segs.shape[1])
    for k in range(segs.shape[1]):
        norm[k] = segs[0, k] * rho / rho
    poses, dirs = _sample_word(q0, words[types[0]].astype(np.int64), norm, rho, step)
    n = poses.shape[0]
    poses[n - 1] = q1
    if keep_end:
        k = n - 1 - _chord_cut(poses, max_len, True)
        poses, dirs = poses[k:], dirs[k:]
        if k == 0:
            poses[0] = q0
        return poses, dirs, True
    k = _chord_cut(poses, max_len, False)
    return poses[: k + 1], dirs[: k + 1], True
