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
from numpy.typing import NDArray

from planning.core.copy_kernels import copy_into
from planning.curves.common import CurveFamily, local_goal, mod2pi, verifies

FloatArray = NDArray[np.float64]

_PI = np.pi
_HALF_PI = 0.5 * np.pi
_ZERO = 10 * np.finfo(float).eps

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
def _polar(x: float, y: float) -> tuple[float, float]:
    return np.sqrt(x * x + y * y), np.arctan2(y, x)


@nb.njit(cache=True, inline="always")
def _tau_omega(u: float, v: float, xi: float, eta: float, phi: float) -> tuple[float, float]:
    delta = mod2pi(u - v)
    a = np.sin(u) - np.sin(delta)
    b = np.cos(u) - np.cos(delta) - 1.0
    t1 = np.arctan2(eta * a - xi * b, xi * a + eta * b)
    t2 = 2.0 * (np.cos(delta) - np.cos(v) - np.cos(u)) + 3.0
    tau = mod2pi(t1 + _PI) if t2 < 0 else mod2pi(t1)
    return tau, mod2pi(tau - u + v - phi)


# The formulas take the goal (x, y, phi) through the centre (xi, eta) of its turning circle: the left
# circle (x - sin phi, y - 1 + cos phi) for 8.1, 8.3 and 8.9, the right one (x + sin phi,
# y - 1 - cos phi) for the others. Each returns (found, t, u, v).
_NONE = (False, 0.0, 0.0, 0.0)


@nb.njit(cache=True, inline="always")
def _found(ok: bool | np.bool_, t: float, u: float, v: float) -> tuple[bool, float, float, float]:
    return bool(ok), float(t), float(u), float(v)


@nb.njit(cache=True)
def _lpsplp(xi: float, eta: float, phi: float) -> tuple[bool, float, float, float]:  # 8.1, left circle
    u, t = _polar(xi, eta)
    if t >= -_ZERO:
        v = mod2pi(phi - t)
        if v >= -_ZERO:
            return _found(True, t, u, v)
    return _NONE


@nb.njit(cache=True)
def _lpsprp(xi: float, eta: float, phi: float) -> tuple[bool, float, float, float]:  # 8.2, right circle
    u1, t1 = _polar(xi, eta)
    u1 = u1 * u1
    if u1 >= 4.0:
        u = np.sqrt(u1 - 4.0)
        t = mod2pi(t1 + np.arctan2(2.0, u))
        v = mod2pi(t - phi)
        return _found(t >= -_ZERO and v >= -_ZERO, t, u, v)
    return _NONE


@nb.njit(cache=True)
def _lprml(xi: float, eta: float, phi: float) -> tuple[bool, float, float, float]:  # 8.3, left circle
    u1, theta = _polar(xi, eta)
    if u1 <= 4.0:
        u = -2.0 * np.arcsin(0.25 * u1)
        t = mod2pi(theta + 0.5 * u + _PI)
        return _found(t >= -_ZERO and u <= _ZERO, t, u, mod2pi(phi - t + u))
    return _NONE


@nb.njit(cache=True)
def _lprupluml(xi: float, eta: float, phi: float) -> tuple[bool, float, float, float]:  # 8.7, right circle
    rho = 0.25 * (2.0 + np.sqrt(xi * xi + eta * eta))
    if rho <= 1.0:
        u = np.arccos(rho)
        t, v = _tau_omega(u, -u, xi, eta, phi)
        return _found(t >= -_ZERO and v <= _ZERO, t, u, v)
    return _NONE


@nb.njit(cache=True)
def _lprumlump(xi: float, eta: float, phi: float) -> tuple[bool, float, float, float]:  # 8.8, right circle
    rho = (20.0 - xi * xi - eta * eta) / 16.0
    u = -np.arccos(rho) if 0.0 <= rho <= 1.0 else -np.inf
    if u >= -_HALF_PI:
        t, v = _tau_omega(u, u, xi, eta, phi)
        return _found(t >= -_ZERO and v >= -_ZERO, t, u, v)
    return _NONE


@nb.njit(cache=True)
def _lprmsmlm(xi: float, eta: float, phi: float) -> tuple[bool, float, float, float]:  # 8.9, left circle
    rho, theta = _polar(xi, eta)
    if rho >= 2.0:
        r = np.sqrt(rho * rho - 4.0)
        t = mod2pi(theta + np.arctan2(r, -2.0))
        u, v = 2.0 - r, mod2pi(phi - _HALF_PI - t)
        return _found(t >= -_ZERO and u <= _ZERO and v <= _ZERO, t, u, v)
    return _NONE


@nb.njit(cache=True)
def _lprmsmrm(xi: float, eta: float, phi: float) -> tuple[bool, float, float, float]:  # 8.10, right circle
    rho, t = _polar(-eta, xi)
    if rho >= 2.0:
        u, v = 2.0 - rho, mod2pi(t + _HALF_PI - phi)
        return _found(t >= -_ZERO and u <= _ZERO and v <= _ZERO, t, u, v)
    return _NONE


@nb.njit(cache=True)
def _lprmslmrp(xi: float, eta: float, phi: float) -> tuple[bool, float, float, float]:  # 8.11, right circle
    rho, _theta = _polar(xi, eta)
    u = 4.0 - np.sqrt(rho * rho - 4.0) if rho >= 2.0 else np.inf
    if u <= _ZERO:
        t = mod2pi(np.arctan2((4.0 - u) * xi - 2.0 * eta, -2.0 * xi + (u - 4.0) * eta))
        v = mod2pi(t - phi)
        return _found(t >= -_ZERO and v >= -_ZERO, t, u, v)
    return _NONE


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
def _formula(
    f: int, x: float, y: float, phi: float, sin_phi: float, cos_phi: float
) -> tuple[bool, float, float, float]:
    """Formula ``f`` (see :data:`_FAMILIES`) at the goal ``(x, y, phi)``, given ``phi``'s sine and cosine."""
    if f in (0, 2, 5):  # the left turning circle
        xi, eta = x - sin_phi, y - 1.0 + cos_phi
    else:
        xi, eta = x + sin_phi, y - 1.0 - cos_phi
    if f == 0:
        return _lpsplp(xi, eta, phi)
    if f == 1:
        return _lpsprp(xi, eta, phi)
    if f == 2:
        return _lprml(xi, eta, phi)
    if f == 3:
        return _lprupluml(xi, eta, phi)
    if f == 4:
        return _lprumlump(xi, eta, phi)
    if f == 5:
        return _lprmsmlm(xi, eta, phi)
    if f == 6:
        return _lprmsmrm(xi, eta, phi)
    return _lprmslmrp(xi, eta, phi)


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


#: Candidate families in :data:`_FAMILIES`, and how many of them, first, are the CSC words (8.1, 8.2):
#: the cheapest to solve, whose best verified word bounds the length from above (see :func:`shortest_radii`).
FAMILIES, CSC_FAMILIES = int(_FAMILIES.shape[0]), 2


@nb.njit(cache=True, inline="always")
def _shortest(
    x: float, y: float, phi: float, segs: FloatArray, out: FloatArray, first: int, last: int, best: float
) -> tuple[float, int]:
    """The shortest verified word to the goal ``(x, y, phi)`` (in its start's frame, turning radii)
    among families ``first`` to ``last - 1`` that is shorter than ``best``.

    Every candidate (each family time-flipped and reflected: 48 in all) shorter than the best so far
    is integrated to its end pose and must land on the goal. The result is the shortest verified
    length whatever the order the families are tried in (a candidate is skipped only when one as
    short has verified), so solving families ``[0, k)`` and then ``[k, FAMILIES)`` from that best
    gives the length one pass gives.

    Returns:
        (its length in turning radii, its index into :data:`RS_WORDS`), or (``best``, -1) when no
        candidate is shorter; its signed segments are written into ``out`` (5,). ``segs`` (5,) is scratch.
    """
    wbest = -1
    # phi's sine and cosine once per pair: the symmetries only flip phi's sign, and the C library's sine
    # is odd and its cosine even, exactly (tests/test_reeds_shepp.py checks it where the solver runs).
    # Computed per candidate they took a third of the solve.
    sin_phi, cos_phi = np.sin(phi), np.cos(phi)
    xb = x * cos_phi + y * sin_phi
    yb = x * sin_phi - y * cos_phi
    for f in range(first, last):
        formula, back, lay, base = _FAMILIES[f, 0], _FAMILIES[f, 1], _FAMILIES[f, 2], _FAMILIES[f, 3]
        px, py = (xb, yb) if back else (x, y)
        for sym in range(4):
            sx = -1.0 if sym & 1 else 1.0  # time flip: drive the word backwards
            sy = -1.0 if sym & 2 else 1.0  # reflection: swap left and right
            ok, t, u, v = _formula(formula, sx * px, sy * py, sx * sy * phi, sx * sy * sin_phi, cos_phi)
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
            if verifies(RS_WORDS[wtype], segs, x, y, phi):
                best, wbest = length, wtype
                copy_into(out, segs)
    return best, wbest


@nb.njit(cache=True)
def _solve(q0: FloatArray, q1: FloatArray, rho: float) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """Shortest verified words between pose pairs (the :data:`planning.curves.common.Solver` contract)."""
    n = max(q0.shape[0], q1.shape[0])
    lengths, types, out_segs = np.full(n, np.inf), np.full(n, -1, dtype=np.int64), np.zeros((n, 5))
    segs = np.zeros(5)
    for i in range(n):
        x, y, phi = local_goal(q0, q1, i, rho)
        best, types[i] = _shortest(x, y, phi, segs, out_segs[i], 0, FAMILIES, np.inf)
        lengths[i] = best * rho  # inf if no candidate verified
    return lengths, types, out_segs


@nb.njit(cache=True)
def shortest_radii(
    q0: FloatArray, q1: FloatArray, rho: float, scratch: FloatArray, first: int, last: int, best: float
) -> tuple[float, int]:
    """Length in turning radii of the shortest Reeds–Shepp word from pose ``q0`` (3,) to ``q1`` (3,)
    among families ``first`` to ``last - 1`` shorter than ``best`` [turning radii] (else ``best``),
    and that word's index into :data:`RS_WORDS` (-1 when none is shorter), its signed segments written
    into ``scratch[1]`` ((2, 5) scratch): for compiled callers that need many single curves without
    :func:`_solve`'s arrays.

    ``shortest_radii(q0, q1, rho, s, 0, FAMILIES, inf)`` is the word :func:`_solve` gives, its length
    times ``rho`` the length it gives; ``u = shortest_radii(q0, q1, rho, s, 0, CSC_FAMILIES, inf)[0]``
    is an upper bound of that length (a sixth of the work), and ``shortest_radii(q0, q1, rho, s,
    CSC_FAMILIES, FAMILIES, u)[0]`` is then the exact length.
    """
    x, y, phi = local_goal(q0.reshape(1, 3), q1.reshape(1, 3), 0, rho)
    return _shortest(x, y, phi, scratch[0], scratch[1], first, last, best)


REEDS_SHEPP = CurveFamily("Reeds–Shepp", RS_WORDS, _solve)
# Lengths (N,) [m]; (lengths, indices into RS_WORDS, (N, 5) signed segments); one Word (see CurveFamily).
reeds_shepp_length, reeds_shepp_batch, reeds_shepp_path = REEDS_SHEPP.lengths, REEDS_SHEPP.batch, REEDS_SHEPP.path
