"""Paths made of circular arcs and straight segments (Dubins and Reeds–Shepp words).

A word is up to five segments, each a steering sign ``kappa`` in {+1 (left), 0 (straight),
-1 (right)} and a *signed* length in units of the turning radius: positive drives forwards,
negative backwards. On a segment of signed normalised length ``s`` the heading changes by
``kappa * s`` and the position moves along the exact arc (or line). Everything here is compiled
with numba and works on arrays of many words at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Maximum number of segments in a word.
MAX_SEGMENTS = 5


@nb.njit(cache=True, inline="always")
def _advance(x: float, y: float, th: float, kappa: int, s: float) -> tuple[float, float, float]:
    """Move a unit-radius car along one segment of signed normalised length ``s``."""
    if kappa == 0:
        return x + s * np.cos(th), y + s * np.sin(th), th
    if kappa > 0:
        return x + np.sin(th + s) - np.sin(th), y - np.cos(th + s) + np.cos(th), th + s
    return x - np.sin(th - s) + np.sin(th), y + np.cos(th - s) - np.cos(th), th - s


@nb.njit(cache=True)
def word_endpoint(kappas: IntArray, lengths: FloatArray) -> tuple[float, float, float]:
    """End pose of a unit-radius word started at the origin heading along +x."""
    x, y, th = 0.0, 0.0, 0.0
    for i in range(kappas.shape[0]):
        if lengths[i] != 0.0:
            x, y, th = _advance(x, y, th, kappas[i], lengths[i])
    return x, y, th


@nb.njit(cache=True)
def _sample_word(
    q0: FloatArray, kappas: IntArray, lengths: FloatArray, rho: float, step: float
) -> tuple[FloatArray, FloatArray]:
    total = 0.0
    for i in range(kappas.shape[0]):
        total += abs(lengths[i]) * rho
    # Each segment gets ceil(len/step) intervals, so at most n_seg extra samples.
    cap = int(np.ceil(total / step)) + kappas.shape[0] + 2
    out = np.empty((cap, 3))
    dirs = np.empty(cap)
    x, y, th = q0[0] / rho, q0[1] / rho, q0[2]
    out[0, 0], out[0, 1], out[0, 2] = q0[0], q0[1], q0[2]
    first_dir = 1.0
    for i in range(kappas.shape[0]):
        if lengths[i] != 0.0:
            first_dir = 1.0 if lengths[i] > 0 else -1.0
            break
    dirs[0] = first_dir
    k = 1
    for i in range(kappas.shape[0]):
        s = lengths[i]
        if s == 0.0:
            continue
        n = int(np.ceil(abs(s) * rho / step))
        d = 1.0 if s > 0 else -1.0
        for j in range(1, n + 1):
            px, py, pth = _advance(x, y, th, kappas[i], s * j / n)
            out[k, 0], out[k, 1], out[k, 2] = px * rho, py * rho, pth
            dirs[k] = d
            k += 1
        x, y, th = _advance(x, y, th, kappas[i], s)
    return out[:k], dirs[:k]


@dataclass(frozen=True)
class Word:
    """One arc/line path between two poses.

    Attributes:
        start: (3,) start pose [x, y, theta].
        kappas: (S,) steering signs of the non-empty segments (+1 left, 0 straight, -1 right).
        lengths: (S,) signed segment lengths [m]; negative means driving backwards.
        rho: Turning radius [m].
        name: Word letters, e.g. "LSR".
    """

    start: FloatArray
    kappas: IntArray
    lengths: FloatArray
    rho: float
    name: str

    @property
    def length(self) -> float:
        """Total path length [m]."""
        return float(np.sum(np.abs(self.lengths)))

    def sample(self, step: float = 0.01) -> tuple[FloatArray, FloatArray]:
        """Dense poses along the word.

        Args:
            step: Largest arc length between consecutive samples [m].

        Returns:
            (K, 3) poses [x, y, theta] (theta continuous, not wrapped) from start to end, and
            (K,) directions (+1 forwards, -1 backwards) of the motion arriving at each sample
            (the first takes the first segment's direction).
        """
        if not step > 0:
            raise ValueError(f"step must be > 0, got {step}")
        return _sample_word(  # type: ignore[no-any-return]
            np.asarray(self.start, dtype=float), self.kappas, self.lengths / self.rho, self.rho, step
        )

    def controls(self, speed: float = 1.0) -> tuple[FloatArray, FloatArray]:
        """Piecewise-constant unicycle controls that drive the word.

        Args:
            speed: |v| [m/s].

        Returns:
            (S,) durations [s] and (S, 2) controls [v, omega].
        """
        dur = np.abs(self.lengths) / speed
        v = np.sign(self.lengths) * speed
        return dur, np.column_stack([v, v * self.kappas / self.rho])


def make_word(start: FloatArray, kappas: IntArray, norm_lengths: FloatArray, rho: float) -> Word:
    """A :class:`Word` from a solver's raw output, dropping empty segments."""
    keep = norm_lengths != 0.0
    k = np.asarray(kappas)[keep].astype(np.int64)
    ln = np.asarray(norm_lengths)[keep] * rho
    name = "".join("LSR"[1 - int(c)] for c in k)
    return Word(np.asarray(start, dtype=float).copy(), k, ln, float(rho), name)
