"""Dubins curves: shortest forward-only paths with a bounded turning radius.

The six words LSL, RSR, LSR, RSL, RLR, LRL (Dubins 1957; closed forms as in Shkel & Lumelsky
2001). Every candidate is verified by integrating it to its end pose before it may win.
Compiled with numba; many pose pairs are one call.

The Dubins distance is not symmetric: ``dubins_length(a, b) != dubins_length(b, a)`` in general,
so a caller joining two trees must steer from the start-side pose to the goal-side pose.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.curves.reeds_shepp import _check_rho, _mod2pi, _pairs, _to_local
from planning.curves.words import Word, make_word, word_endpoint

FloatArray = NDArray[np.float64]

_TOL = 1e-6
DUBINS_WORDS = np.array(
    [[1, 0, 1], [-1, 0, -1], [1, 0, -1], [-1, 0, 1], [-1, 1, -1], [1, -1, 1]], dtype=np.int64
)  # LSL, RSR, LSR, RSL, RLR, LRL


@nb.njit(cache=True, inline="always")
def _m2pi(a: float) -> float:
    """Angle in [0, 2 pi)."""
    v = np.fmod(a, 2 * np.pi)
    return v + 2 * np.pi if v < 0 else v


@nb.njit(cache=True)
def _word(k: int, d: float, a: float, b: float) -> tuple[bool, float, float, float]:
    sa, sb, ca, cb = np.sin(a), np.sin(b), np.cos(a), np.cos(b)
    cab = np.cos(a - b)
    if k == 0:  # LSL
        p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * (sa - sb)
        if p2 < 0:
            return False, 0.0, 0.0, 0.0
        th = np.arctan2(cb - ca, d + sa - sb)
        return True, _m2pi(th - a), np.sqrt(p2), _m2pi(b - th)
    if k == 1:  # RSR
        p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * (sb - sa)
        if p2 < 0:
            return False, 0.0, 0.0, 0.0
        th = np.arctan2(ca - cb, d - sa + sb)
        return True, _m2pi(a - th), np.sqrt(p2), _m2pi(th - b)
    if k == 2:  # LSR
        p2 = -2.0 + d * d + 2.0 * cab + 2.0 * d * (sa + sb)
        if p2 < 0:
            return False, 0.0, 0.0, 0.0
        p = np.sqrt(p2)
        th = np.arctan2(-ca - cb, d + sa + sb) - np.arctan2(-2.0, p)
        return True, _m2pi(th - a), p, _m2pi(th - b)
    if k == 3:  # RSL
        p2 = -2.0 + d * d + 2.0 * cab - 2.0 * d * (sa + sb)
        if p2 < 0:
            return False, 0.0, 0.0, 0.0
        p = np.sqrt(p2)
        th = np.arctan2(ca + cb, d - sa - sb) - np.arctan2(2.0, p)
        return True, _m2pi(a - th), p, _m2pi(b - th)
    if k == 4:  # RLR
        c = (6.0 - d * d + 2.0 * cab + 2.0 * d * (sa - sb)) / 8.0
        if abs(c) > 1.0:
            return False, 0.0, 0.0, 0.0
        p = _m2pi(2 * np.pi - np.arccos(c))
        t = _m2pi(a - np.arctan2(ca - cb, d - sa + sb) + 0.5 * p)
        return True, t, p, _m2pi(a - b - t + p)
    # LRL
    c = (6.0 - d * d + 2.0 * cab + 2.0 * d * (sb - sa)) / 8.0
    if abs(c) > 1.0:
        return False, 0.0, 0.0, 0.0
    p = _m2pi(2 * np.pi - np.arccos(c))
    t = _m2pi(-a + np.arctan2(-ca + cb, d + sa - sb) + 0.5 * p)
    return True, t, p, _m2pi(b - a - t + p)


@nb.njit(cache=True)
def _solve_local(x: float, y: float, phi: float, out: FloatArray) -> int:
    d = np.sqrt(x * x + y * y)
    th = np.arctan2(y, x) if d > 0 else 0.0
    a = _m2pi(-th)
    b = _m2pi(phi - th)
    best = np.inf
    best_k = -1
    segs = np.zeros(3)
    for k in range(6):
        ok, t, p, q = _word(k, d, a, b)
        if not ok or t + p + q >= best:
            continue
        segs[0], segs[1], segs[2] = t, p, q
        ex, ey, eth = word_endpoint(DUBINS_WORDS[k], segs)
        if abs(ex - x) < _TOL and abs(ey - y) < _TOL and abs(_mod2pi(eth - phi)) < _TOL:
            best = t + p + q
            best_k = k
            out[:] = segs
    return best_k


@nb.njit(cache=True)
def _batch(q0: FloatArray, q1: FloatArray, rho: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    n = max(q0.shape[0], q1.shape[0])
    lengths = np.empty(n)
    types = np.empty(n, dtype=np.int64)
    segs = np.zeros((n, 3))
    for i in range(n):
        a = q0[0] if q0.shape[0] == 1 else q0[i]
        b = q1[0] if q1.shape[0] == 1 else q1[i]
        x, y, phi = _to_local(a, b, rho)
        types[i] = _solve_local(x, y, phi, segs[i])
        lengths[i] = (segs[i, 0] + segs[i, 1] + segs[i, 2]) * rho if types[i] >= 0 else np.inf
    return lengths, types, segs


def dubins_length(q0: ArrayLike, q1: ArrayLike, rho: float) -> FloatArray:
    """Lengths of the shortest forward-only paths from ``q0`` to ``q1``.

    Args:
        q0: (N, 3) or (3,) start poses [x, y, theta].
        q1: (N, 3) or (3,) end poses (either side may be a single pose, broadcast).
        rho: Turning radius [m].

    Returns:
        (N,) lengths [m].
    """
    _check_rho(rho)
    a, b = _pairs(q0, q1)
    return _batch(a, b, float(rho))[0]  # type: ignore[no-any-return]


def dubins_batch(q0: ArrayLike, q1: ArrayLike, rho: float) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """Shortest words for many pairs: lengths (N,) [m], word indices (N,) into ``DUBINS_WORDS``,
    and (N, 3) segment lengths in turning radii (all >= 0)."""
    _check_rho(rho)
    a, b = _pairs(q0, q1)
    return _batch(a, b, float(rho))  # type: ignore[no-any-return,return-value]


def dubins_path(q0: ArrayLike, q1: ArrayLike, rho: float) -> Word:
    """The shortest Dubins path from ``q0`` to ``q1`` as a :class:`Word`.

    Args:
        q0: (3,) start pose [x, y, theta].
        q1: (3,) end pose.
        rho: Turning radius [m].
    """
    _, types, segs = dubins_batch(q0, q1, rho)
    if types[0] < 0:
        raise ValueError(f"no Dubins path between {q0!r} and {q1!r} (non-finite input?)")
    return make_word(np.asarray(q0, dtype=float).reshape(3), DUBINS_WORDS[types[0]], segs[0], rho)
