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
from planning.curves.words import _advance

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


#: A cut word: (start pose (3,) [m, m, rad], kappas (S,), signed lengths in turning radii (S,),
#: segment starts (S, 3) in turning radii, pieces per segment (S,), pinned end pose (3,) or empty).
CutWord = tuple[FloatArray, IntArray, FloatArray, FloatArray, IntArray, FloatArray]


@nb.njit(cache=True)
def cut_word(
    reeds_shepp: bool, q0: FloatArray, q1: FloatArray, rho: float, step: float, max_len: float, keep_end: bool
) -> tuple[CutWord, bool]:
    """The shortest curve from ``q0`` (3,) to ``q1`` (3,), cut to ``max_len`` [m] of arc from its start
    (or, ``keep_end``, from its end), laid out for sampling every ``step`` [m] of arc; and False when
    no curve verifies (non-finite input)."""
    a, b = q0.reshape((1, 3)), q1.reshape((1, 3))
    if reeds_shepp:
        _, types, segs = _rs_solve(a, b, rho)
        words = RS_WORDS
    else:
        _, types, segs = _dubins_solve(a, b, rho)
        words = DUBINS_WORDS
    m = segs.shape[1]
    kap = np.zeros(m, dtype=np.int64)
    seg = np.zeros(m)
    if types[0] < 0:
        return (q0.copy(), kap, seg, np.zeros((m, 3)), np.zeros(m, dtype=np.int64), np.empty(0)), False
    total = 0.0
    for k in range(m):
        kap[k] = words[types[0], k]
        seg[k] = segs[0, k] * rho / rho  # Word.sample's normalised lengths
        total += abs(seg[k]) * rho
    start = q0.copy()
    pin = q1.copy()
    if total > max_len:
        skip = total - max_len if keep_end else 0.0  # arc [m] dropped before the kept part
        keep = max_len
        x, y, th = q0[0] / rho, q0[1] / rho, q0[2]
        for k in range(m):
            s = seg[k]
            ln = abs(s) * rho
            sign = 1.0 if s > 0 else -1.0
            drop = min(ln, skip)  # from this segment's start
            skip -= drop
            if drop > 0.0:
                x, y, th = _advance(x, y, th, kap[k], sign * drop / rho)
            rest = min(ln - drop, keep)
            keep -= rest
            seg[k] = sign * rest / rho if ln > 0.0 else 0.0
        if keep_end:
            start = np.array([x * rho, y * rho, th])
        else:
            pin = np.empty(0)
    starts = np.zeros((m, 3))
    counts = np.zeros(m, dtype=np.int64)
    x, y, th = start[0] / rho, start[1] / rho, start[2]
    for k in range(m):
        starts[k, 0], starts[k, 1], starts[k, 2] = x, y, th
        if seg[k] == 0.0:
            continue
        counts[k] = int(np.ceil(abs(seg[k]) * rho / step))
        x, y, th = _advance(x, y, th, kap[k], seg[k])
    return (start, kap, seg, starts, counts, pin), True


# word_size and word_pose are inlined where they are called: a word is a tuple of six arrays, and a
# call per dense pose that passed it cost more than the pose (BiRRT's plans 0.87-0.99x the time
# inlined, the same trees; docs/benchmarks/ompl-race.md)
@nb.njit(cache=True, inline="always")
def word_size(word: CutWord) -> int:
    """Number of dense poses of a cut word (its start and every piece's end)."""
    n = 1
    for c in word[4]:
        n += c
    return n


@nb.njit(cache=True, inline="always")
def word_pose(word: CutWord, j: int, rho: float) -> tuple[float, float, float, float]:
    """Dense pose ``j`` of a cut word: (x [m], y [m], heading [rad], direction +1 / -1)."""
    start, kap, seg, starts, counts, pin = word
    n = word_size(word)
    first = 1.0
    for k in range(seg.shape[0]):
        if seg[k] != 0.0:
            first = 1.0 if seg[k] > 0 else -1.0
            break
    if j == n - 1 and pin.shape[0] == 3:  # the curve's end, pinned
        d = first
        for k in range(seg.shape[0]):
            if seg[k] != 0.0:
                d = 1.0 if seg[k] > 0 else -1.0
        return pin[0], pin[1], pin[2], d
    if j == 0:
        return start[0], start[1], start[2], first
    rest = j
    for k in range(seg.shape[0]):
        c = counts[k]
        if rest <= c:
            d = 1.0 if seg[k] > 0 else -1.0
            px, py, pth = _advance(starts[k, 0], starts[k, 1], starts[k, 2], kap[k], seg[k] * rest / c)
            return px * rho, py * rho, pth, d
        rest -= c
    return start[0], start[1], start[2], first  # unreachable for 0 <= j < n


@nb.njit(cache=True)
def word_poses(word: CutWord, rho: float) -> tuple[FloatArray, FloatArray]:
    """All dense poses (n, 3) of a cut word and their directions (n,) (:func:`word_pose` for each)."""
    n = word_size(word)
    poses = np.empty((n, 3))
    dirs = np.empty(n)
    for j in range(n):
        poses[j, 0], poses[j, 1], poses[j, 2], dirs[j] = word_pose(word, j, rho)
    return poses, dirs


@nb.njit(cache=True)
def steer_kernel(
    reeds_shepp: bool, q0: FloatArray, q1: FloatArray, rho: float, step: float, max_len: float, keep_end: bool
) -> tuple[FloatArray, FloatArray, bool]:
    """Dense samples of the shortest curve from ``q0`` (3,) to ``q1`` (3,), cut to ``max_len`` of arc.

    Args:
        reeds_shepp: Reeds–Shepp curves, else Dubins.
        q0, q1: Start and end poses of the curve (contiguous float64).
        rho: Turning radius [m].
        step: Largest arc length between samples [m].
        max_len: Longest kept arc [m] (inf: the whole curve).
        keep_end: Keep the part ending at ``q1`` (a backwards extension), else the part from ``q0``.

    Returns:
        (K, 3) poses, (K,) directions (+1 / -1), and False when no curve verifies (non-finite input).
    """
    word, ok = cut_word(reeds_shepp, q0, q1, rho, step, max_len, keep_end)
    if not ok:
        return np.empty((0, 3)), np.empty(0), False
    poses, dirs = word_poses(word, rho)
    return poses, dirs, True
