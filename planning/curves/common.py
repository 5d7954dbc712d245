"""What the Dubins and Reeds–Shepp solvers share: pose pairs, the local frame, verification, the batch API.

Both solve for the shortest word from the origin (heading +x) to a goal ``(x, y, phi)`` given in the
start pose's frame and in turning radii, and verify every candidate by integrating it to its end
pose (:func:`planning.curves.words.word_endpoint`). A :class:`CurveFamily` turns such a compiled
solver into the public functions: lengths, whole batches and single :class:`~planning.curves.words.Word`
paths between poses in the world.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.arrays import kernel_input
from planning.curves.words import Word, make_word, word_endpoint

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Largest end-pose error of a verified word, in turning radii (position) and radians (heading).
TOL = 1e-6

#: A compiled solver: (start poses (N, 3) or (1, 3), goal poses likewise, turning radius [m]) ->
#: (lengths (N,) [m], inf where no candidate verifies; word indices (N,), -1 there; (N, S) signed
#: segment lengths in turning radii), each goal taken in its start's frame by :func:`local_goal`.
Solver = Callable[[FloatArray, FloatArray, float], tuple[FloatArray, IntArray, FloatArray]]


#: 2 pi, the float the wraps divide by.
TWO_PI = 2 * np.pi


@nb.njit(cache=True, inline="always")
def fmod_2pi(a: float) -> float:
    """``np.fmod(a, TWO_PI)``, bit for bit, without fmod's cost (a loop of exact reductions, a tenth
    of a Reeds–Shepp solve) where ``|a| < 4 pi``. fmod's result is exact: for ``|a| < 2 pi`` it is
    ``a``, and for ``2 pi <= |a| < 4 pi`` it is ``a -+ 2 pi`` (signed as ``a``), a difference that
    rounds to itself (Sterbenz: the two are within a factor of two)."""
    m = abs(a)
    if m < TWO_PI:
        return a
    if m < 2.0 * TWO_PI:
        return a - TWO_PI if a > 0.0 else -(m - TWO_PI)  # fmod keeps a's sign, on a zero too
    return np.fmod(a, TWO_PI)  # also nan for nan and +-inf, as fmod


@nb.njit(cache=True, inline="always")
def mod2pi(a: float) -> float:
    """Angle wrapped to [-pi, pi] [rad]."""
    v = fmod_2pi(a)
    if v < -np.pi:
        v += 2 * np.pi
    elif v > np.pi:
        v -= 2 * np.pi
    return v


@nb.njit(cache=True, inline="always")
def lands_on(ex: float, ey: float, eth: float, x: float, y: float, phi: float) -> bool:
    """Whether a word's end pose ``(ex, ey, eth)`` is the goal ``(x, y, phi)`` within :data:`TOL`."""
    return abs(ex - x) < TOL and abs(ey - y) < TOL and abs(mod2pi(eth - phi)) < TOL


@nb.njit(cache=True, inline="always")
def verifies(kappas: IntArray, segs: FloatArray, x: float, y: float, phi: float) -> bool:
    """Whether the word (``kappas``, ``segs`` in turning radii) driven from the origin ends on ``(x, y, phi)``."""
    ex, ey, eth = word_endpoint(kappas, segs)
    return lands_on(ex, ey, eth, x, y, phi)


@nb.njit(cache=True, inline="always")
def local_goal(q0: FloatArray, q1: FloatArray, i: int, rho: float) -> tuple[float, float, float]:
    """Pair ``i``'s goal in its start pose's frame, in turning radii.

    Args:
        q0: (N, 3) or (1, 3) start poses [x, y, theta] (one row is broadcast).
        q1: (N, 3) or (1, 3) goal poses.
        i: Pair index.
        rho: Turning radius [m].

    Returns:
        ``(x, y, phi)``: the goal's position rotated into the start's frame and divided by ``rho``,
        and the heading change (not wrapped) [rad].
    """
    a = q0[0] if q0.shape[0] == 1 else q0[i]
    b = q1[0] if q1.shape[0] == 1 else q1[i]
    dx = (b[0] - a[0]) / rho
    dy = (b[1] - a[1]) / rho
    c, s = np.cos(a[2]), np.sin(a[2])
    return c * dx + s * dy, -s * dx + c * dy, b[2] - a[2]


def pose_pairs(q0: ArrayLike, q1: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Start and goal poses as contiguous (N, 3) arrays; either side may hold a single pose.

    Raises:
        ValueError: A pose that is not 3 numbers, or pose counts that differ without one being 1.
    """
    a = np.atleast_2d(np.asarray(q0, dtype=float))
    b = np.atleast_2d(np.asarray(q1, dtype=float))
    if a.shape[-1] != 3 or b.shape[-1] != 3:
        raise ValueError(f"poses must have shape (N, 3) or (3,), got {a.shape} and {b.shape}")
    if a.shape[0] != b.shape[0] and 1 not in (a.shape[0], b.shape[0]):
        raise ValueError(f"pose counts must match or one be 1, got {a.shape[0]} and {b.shape[0]}")
    return kernel_input(a), kernel_input(b)


def check_rho(rho: float) -> None:
    """Raise ValueError unless the turning radius is > 0."""
    if not rho > 0:
        raise ValueError(f"turning radius must be > 0, got {rho}")


@dataclass(frozen=True)
class CurveFamily:
    """A family of shortest words and its compiled solver.

    Attributes:
        name: Family name for messages ("Dubins", "Reeds–Shepp").
        words: (W, S) steering signs of every word the solver may return (+1 L, 0 S, -1 R).
        solve: The compiled solver (see :data:`Solver`).
    """

    name: str
    words: IntArray
    solve: Solver

    def batch(self, q0: ArrayLike, q1: ArrayLike, rho: float) -> tuple[FloatArray, IntArray, FloatArray]:
        """Shortest words for many pose pairs.

        Args:
            q0: (N, 3) or (3,) start poses [x, y, theta].
            q1: (N, 3) or (3,) end poses (either side may be a single pose, broadcast).
            rho: Turning radius [m].

        Returns:
            Lengths (N,) [m] (inf where no word verifies: non-finite input), word indices (N,) into
            ``words`` (-1 there), and (N, S) signed segment lengths in turning radii.
        """
        check_rho(rho)
        a, b = pose_pairs(q0, q1)
        return self.solve(a, b, float(rho))

    def lengths(self, q0: ArrayLike, q1: ArrayLike, rho: float) -> FloatArray:
        """(N,) lengths [m] of the shortest words between pose pairs (arguments as :meth:`batch`)."""
        return self.batch(q0, q1, rho)[0]

    def path(self, q0: ArrayLike, q1: ArrayLike, rho: float) -> Word:
        """The shortest word from pose ``q0`` (3,) to pose ``q1`` (3,) with turning radius ``rho`` [m].

        Raises:
            ValueError: No word verifies (only for non-finite input).
        """
        _, types, segs = self.batch(q0, q1, rho)
        if types[0] < 0:
            raise ValueError(f"no {self.name} path between {q0!r} and {q1!r} (non-finite input?)")
        return make_word(np.asarray(q0, dtype=float).reshape(3), self.words[types[0]], segs[0], rho)
