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
from numpy.typing import NDArray

from planning.core.copy_kernels import copy_into
from planning.curves.common import TWO_PI, CurveFamily, fmod_2pi, local_goal, verifies

FloatArray = NDArray[np.float64]

DUBINS_WORDS = np.array(
    [[1, 0, 1], [-1, 0, -1], [1, 0, -1], [-1, 0, 1], [-1, 1, -1], [1, -1, 1]], dtype=np.int64
)  # LSL, RSR, LSR, RSL, RLR, LRL


@nb.njit(cache=True, inline="always")
def _m2pi(a: float) -> float:
    """Angle in [0, 2 pi)."""
    v = fmod_2pi(a)
    return v + TWO_PI if v < 0 else v


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
def _solve(q0: FloatArray, q1: FloatArray, rho: float) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """Shortest verified Dubins words between pose pairs (the :data:`planning.curves.common.Solver` contract)."""
    n = max(q0.shape[0], q1.shape[0])
    lengths, types, segs = np.full(n, np.inf), np.full(n, -1, dtype=np.int64), np.zeros((n, 3))
    cand = np.zeros(3)
    for i in range(n):
        x, y, phi = local_goal(q0, q1, i, rho)
        d = np.sqrt(x * x + y * y)
        th = np.arctan2(y, x) if d > 0 else 0.0
        a = _m2pi(-th)
        b = _m2pi(phi - th)
        best = np.inf
        for k in range(6):
            ok, t, p, q = _word(k, d, a, b)
            if not ok or t + p + q >= best:
                continue
            cand[0], cand[1], cand[2] = t, p, q
            if verifies(DUBINS_WORDS[k], cand, x, y, phi):
                best, types[i] = t + p + q, k
                copy_into(segs[i], cand)
        lengths[i] = best * rho  # inf if no candidate verified
    return lengths, types, segs


DUBINS = CurveFamily("Dubins", DUBINS_WORDS, _solve)
# Lengths (N,) [m]; (lengths, indices into DUBINS_WORDS, (N, 3) segments >= 0); one Word (see CurveFamily).
dubins_length, dubins_batch, dubins_path = DUBINS.lengths, DUBINS.batch, DUBINS.path
