"""Reeds–Shepp curves: shortest paths of a car that drives forwards and backwards.

The 48 candidate words of Reeds and Shepp (1990), formulas 8.1–8.11 with their time-flip and
reflection symmetries (the same families OMPL's ``ReedsSheppStateSpace`` enumerates). Every
candidate is verified by integrating it to its end pose before it may win, so a word is only
returned if it really joins the two poses (to 1e-6 turning radii). Compiled with numba; the
length of many pose pairs is one call (about a microsecond per pair).
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.curves.words import Word, make_word, word_endpoint

FloatArray = NDArray[np.float64]

_PI = np.pi
_HALF_PI = 0.5 * np.pi
_ZERO = 10 * np.finfo(float).eps
_TOL = 1e-6

# Word kappas (+1 L, 0 S, -1 R); unused trailing segments have length 0.
_L, _S, _R = 1, 0, -1
RS_WORDS = np.array(
    [
        [_L, _R, _L, 0, 0], [_R, _L, _R, 0, 0], [_L, _R, _L, _R, 0], [_R, _L, _R, _L, 0],
        [_L, _R, _S, _L, 0], [_R, _L, _S, _R, 0], [_L, _S, _R, _L, 0], [_R, _S, _L, _R, 0],
        [_L, _R, _S, _R, 0], [_R, _L, _S, _L, 0], [_R, _S, _R, _L, 0], [_L, _S, _L, _R, 0],
        [_L, _S, _R, 0, 0], [_R, _S, _L, 0, 0], [_L, _S, _L, 0, 0], [_R, _S, _R, 0, 0],
        [_L, _R, _S, _L, _R], [_R, _L, _S, _R, _L],
    ],
    dtype=np.int64,
)  # fmt: skip


@nb.njit(cache=True, inline="always")
def _mod2pi(a: float) -> float:
    v = np.fmod(a, 2 * np.pi)
    if v < -np.pi:
        v += 2 * np.pi
    elif v > np.pi:
        v -= 2 * np.pi
    return v


@nb.njit(cache=True, inline="always")
def _polar(x: float, y: float) -> tuple[float, float]:
    return np.sqrt(x * x + y * y), np.arctan2(y, x)


@nb.njit(cache=True, inline="always")
def _tau_omega(u: float, v: float, xi: float, eta: float, phi: float) -> tuple[float, float]:
    delta = _mod2pi(u - v)
    a = np.sin(u) - np.sin(delta)
    b = np.cos(u) - np.cos(delta) - 1.0
    t1 = np.arctan2(eta * a - xi * b, xi * a + eta * b)
    t2 = 2.0 * (np.cos(delta) - np.cos(v) - np.cos(u)) + 3.0
    tau = _mod2pi(t1 + _PI) if t2 < 0 else _mod2pi(t1)
    return tau, _mod2pi(tau - u + v - phi)


@nb.njit(cache=True)
def _lpsplp(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:  # 8.1
    u, t = _polar(x - np.sin(phi), y - 1.0 + np.cos(phi))
    if t >= -_ZERO:
        v = _mod2pi(phi - t)
        if v >= -_ZERO:
            return True, float(t), float(u), float(v)
    return False, 0.0, 0.0, 0.0


@nb.njit(cache=True)
def _lpsprp(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:  # 8.2
    u1, t1 = _polar(x + np.sin(phi), y - 1.0 - np.cos(phi))
    u1 = u1 * u1
    if u1 >= 4.0:
        u = np.sqrt(u1 - 4.0)
        theta = np.arctan2(2.0, u)
        t = _mod2pi(t1 + theta)
        v = _mod2pi(t - phi)
        return bool(t >= -_ZERO and v >= -_ZERO), float(t), float(u), float(v)
    return False, 0.0, 0.0, 0.0


@nb.njit(cache=True)
def _lprml(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:  # 8.3
    xi = x - np.sin(phi)
    eta = y - 1.0 + np.cos(phi)
    u1, theta = _polar(xi, eta)
    if u1 <= 4.0:
        u = -2.0 * np.arcsin(0.25 * u1)
        t = _mod2pi(theta + 0.5 * u + _PI)
        v = _mod2pi(phi - t + u)
        return bool(t >= -_ZERO and u <= _ZERO), float(t), float(u), float(v)
    return False, 0.0, 0.0, 0.0


@nb.njit(cache=True)
def _lprupluml(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:  # 8.7
    xi = x + np.sin(phi)
    eta = y - 1.0 - np.cos(phi)
    rho = 0.25 * (2.0 + np.sqrt(xi * xi + eta * eta))
    if rho <= 1.0:
        u = np.arccos(rho)
        t, v = _tau_omega(u, -u, xi, eta, phi)
        return bool(t >= -_ZERO and v <= _ZERO), float(t), float(u), float(v)
    return False, 0.0, 0.0, 0.0


@nb.njit(cache=True)
def _lprumlump(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:  # 8.8
    xi = x + np.sin(phi)
    eta = y - 1.0 - np.cos(phi)
    rho = (20.0 - xi * xi - eta * eta) / 16.0
    if 0.0 <= rho <= 1.0:
        u = -np.arccos(rho)
        if u >= -_HALF_PI:
            t, v = _tau_omega(u, u, xi, eta, phi)
            return bool(t >= -_ZERO and v >= -_ZERO), float(t), float(u), float(v)
    return False, 0.0, 0.0, 0.0


@nb.njit(cache=True)
def _lprmsmlm(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:  # 8.9
    xi = x - np.sin(phi)
    eta = y - 1.0 + np.cos(phi)
    rho, theta = _polar(xi, eta)
    if rho >= 2.0:
        r = np.sqrt(rho * rho - 4.0)
        u = 2.0 - r
        t = _mod2pi(theta + np.arctan2(r, -2.0))
        v = _mod2pi(phi - _HALF_PI - t)
        return bool(t >= -_ZERO and u <= _ZERO and v <= _ZERO), float(t), float(u), float(v)
    return False, 0.0, 0.0, 0.0


@nb.njit(cache=True)
def _lprmsmrm(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:  # 8.10
    xi = x + np.sin(phi)
    eta = y - 1.0 - np.cos(phi)
    rho, theta = _polar(-eta, xi)
    if rho >= 2.0:
        t = theta
        u = 2.0 - rho
        v = _mod2pi(t + _HALF_PI - phi)
        return bool(t >= -_ZERO and u <= _ZERO and v <= _ZERO), float(t), float(u), float(v)
    return False, 0.0, 0.0, 0.0


@nb.njit(cache=True)
def _lprmslmrp(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:  # 8.11
    xi = x + np.sin(phi)
    eta = y - 1.0 - np.cos(phi)
    rho, _theta = _polar(xi, eta)
    if rho >= 2.0:
        u = 4.0 - np.sqrt(rho * rho - 4.0)
        if u <= _ZERO:
            t = _mod2pi(np.arctan2((4.0 - u) * xi - 2.0 * eta, -2.0 * xi + (u - 4.0) * eta))
            v = _mod2pi(t - phi)
            return bool(t >= -_ZERO and v >= -_ZERO), float(t), float(u), float(v)
    return False, 0.0, 0.0, 0.0


# Candidate families: (formula, backwards, layout, word index of the unreflected word).
# formula: 0: 8.1, 1: 8.2, 2: 8.3, 3: 8.7, 4: 8.8, 5: 8.9, 6: 8.10, 7: 8.11.
# layout: 0: (t, u, v); 1: (v, u, t); 2: (t, u, -u, v); 3: (t, u, u, v); 4: (t, -pi/2, u, v);
#         5: (v, u, -pi/2, t); 6: (t, -pi/2, u, -pi/2, v).
_FAMILIES = np.array(
    [
        [0, 0, 0, 14], [1, 0, 0, 12],  # CSC
        [2, 0, 0, 0], [2, 1, 1, 0],  # CCC
        [3, 0, 2, 2], [4, 0, 3, 2],  # CCCC
        [5, 0, 4, 4], [6, 0, 4, 8], [5, 1, 5, 6], [6, 1, 5, 10],  # CCSC
        [7, 0, 6, 16],  # CCSCC
    ],
    dtype=np.int64,
)  # fmt: skip


@nb.njit(cache=True)
def _formula(f: int, x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    if f == 0:
        return _lpsplp(x, y, phi)
    if f == 1:
        return _lpsprp(x, y, phi)
    if f == 2:
        return _lprml(x, y, phi)
    if f == 3:
        return _lprupluml(x, y, phi)
    if f == 4:
        return _lprumlump(x, y, phi)
    if f == 5:
        return _lprmsmlm(x, y, phi)
    if f == 6:
        return _lprmsmrm(x, y, phi)
    return _lprmslmrp(x, y, phi)


@nb.njit(cache=True)
def _layout(k: int, t: float, u: float, v: float, segs: FloatArray) -> None:
    segs[:] = 0.0
    if k == 0:
        segs[0], segs[1], segs[2] = t, u, v
    elif k == 1:
        segs[0], segs[1], segs[2] = v, u, t
    elif k == 2:
        segs[0], segs[1], segs[2], segs[3] = t, u, -u, v
    elif k == 3:
        segs[0], segs[1], segs[2], segs[3] = t, u, u, v
    elif k == 4:
        segs[0], segs[1], segs[2], segs[3] = t, -_HALF_PI, u, v
    elif k == 5:
        segs[0], segs[1], segs[2], segs[3] = v, u, -_HALF_PI, t
    else:
        segs[0], segs[1], segs[2], segs[3], segs[4] = t, -_HALF_PI, u, -_HALF_PI, v


@nb.njit(cache=True)
def _solve_local(x: float, y: float, phi: float, out_segs: FloatArray) -> int:
    """Shortest verified word from the origin to (x, y, phi) (unit turning radius).

    Writes the five signed segment lengths into ``out_segs`` and returns the word index into
    ``RS_WORDS``, or -1 if no candidate verifies (only for non-finite input).
    """
    best = np.inf
    best_type = -1
    segs = np.zeros(5)
    xb = x * np.cos(phi) + y * np.sin(phi)
    yb = x * np.sin(phi) - y * np.cos(phi)
    for i in range(_FAMILIES.shape[0]):
        f, back, lay, base = _FAMILIES[i, 0], _FAMILIES[i, 1], _FAMILIES[i, 2], _FAMILIES[i, 3]
        px, py = (xb, yb) if back else (x, y)
        for sym in range(4):
            sx = -1.0 if sym & 1 else 1.0  # time flip: drive the word backwards
            sy = -1.0 if sym & 2 else 1.0  # reflection: swap left and right
            ok, t, u, v = _formula(f, sx * px, sy * py, sx * sy * phi)
            if not ok:
                continue
            _layout(lay, t, u, v, segs)
            length = 0.0
            for k in range(5):
                segs[k] *= sx
                length += abs(segs[k])
            if length >= best:
                continue
            wtype = base + (1 if sy < 0 else 0)
            ex, ey, eth = word_endpoint(RS_WORDS[wtype], segs)
            if abs(ex - x) < _TOL and abs(ey - y) < _TOL and abs(_mod2pi(eth - phi)) < _TOL:
                best = length
                best_type = wtype
                out_segs[:] = segs
    return best_type


@nb.njit(cache=True)
def _to_local(q0: FloatArray, q1: FloatArray, rho: float) -> tuple[float, float, float]:
    dx = (q1[0] - q0[0]) / rho
    dy = (q1[1] - q0[1]) / rho
    c, s = np.cos(q0[2]), np.sin(q0[2])
    return c * dx + s * dy, -s * dx + c * dy, q1[2] - q0[2]


@nb.njit(cache=True)
def _batch(q0: FloatArray, q1: FloatArray, rho: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    n = max(q0.shape[0], q1.shape[0])
    lengths = np.empty(n)
    types = np.empty(n, dtype=np.int64)
    segs = np.zeros((n, 5))
    for i in range(n):
        a = q0[0] if q0.shape[0] == 1 else q0[i]
        b = q1[0] if q1.shape[0] == 1 else q1[i]
        x, y, phi = _to_local(a, b, rho)
        types[i] = _solve_local(x, y, phi, segs[i])
        lengths[i] = np.sum(np.abs(segs[i])) * rho if types[i] >= 0 else np.inf
    return lengths, types, segs


def _pairs(q0: ArrayLike, q1: ArrayLike) -> tuple[FloatArray, FloatArray]:
    a = np.atleast_2d(np.asarray(q0, dtype=float))
    b = np.atleast_2d(np.asarray(q1, dtype=float))
    if a.shape[-1] != 3 or b.shape[-1] != 3:
        raise ValueError(f"poses must have shape (N, 3) or (3,), got {a.shape} and {b.shape}")
    if a.shape[0] != b.shape[0] and 1 not in (a.shape[0], b.shape[0]):
        raise ValueError(f"pose counts must match or one be 1, got {a.shape[0]} and {b.shape[0]}")
    return np.ascontiguousarray(a), np.ascontiguousarray(b)


def _check_rho(rho: float) -> None:
    if not rho > 0:
        raise ValueError(f"turning radius must be > 0, got {rho}")


def reeds_shepp_length(q0: ArrayLike, q1: ArrayLike, rho: float) -> FloatArray:
    """Lengths of the shortest Reeds–Shepp paths between pose pairs.

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


def reeds_shepp_batch(q0: ArrayLike, q1: ArrayLike, rho: float) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """Shortest words for many pose pairs: lengths (N,) [m], word indices (N,) into ``RS_WORDS``,
    and (N, 5) signed segment lengths in turning radii."""
    _check_rho(rho)
    a, b = _pairs(q0, q1)
    return _batch(a, b, float(rho))  # type: ignore[no-any-return,return-value]


def reeds_shepp_path(q0: ArrayLike, q1: ArrayLike, rho: float) -> Word:
    """The shortest Reeds–Shepp path from ``q0`` to ``q1`` as a :class:`Word`.

    Args:
        q0: (3,) start pose [x, y, theta].
        q1: (3,) end pose.
        rho: Turning radius [m].
    """
    _, types, segs = reeds_shepp_batch(q0, q1, rho)
    if types[0] < 0:  # cannot happen for finite input; guard against NaN poses
        raise ValueError(f"no Reeds–Shepp path between {q0!r} and {q1!r} (non-finite input?)")
    return make_word(np.asarray(q0, dtype=float).reshape(3), RS_WORDS[types[0]], segs[0], rho)
