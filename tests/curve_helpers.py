"""Helpers shared by the Dubins and Reeds–Shepp tests: random pose pairs, driving a word, OMPL's distance."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from planning.core.kinematics import rollout, unicycle_rhs
from planning.curves.words import Word


def pose_pairs(seed: int, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """Two (n, 3) arrays of random poses in [-4, 4]^2 x [-pi, pi)."""
    rng = np.random.default_rng(seed)
    a = np.column_stack([rng.uniform(-4, 4, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    b = np.column_stack([rng.uniform(-4, 4, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    return a, b


def wrap(a: np.ndarray | float) -> np.ndarray | float:
    """Angles wrapped to [-pi, pi) [rad]."""
    return (a + np.pi) % (2 * np.pi) - np.pi


def drive(start: np.ndarray, word: Word, speed: float, dt: float) -> tuple[np.ndarray, float]:
    """Integrate a word's controls from ``start`` with RK4 steps of at most ``dt`` [s].

    Returns:
        The end pose (3,) and the distance driven [m].
    """
    dur, u = word.controls(speed=speed)
    x = np.asarray(start, dtype=float).copy()
    travelled = 0.0
    for d, uk in zip(dur, u, strict=True):
        n = max(1, int(np.ceil(d / dt)))
        x = rollout(unicycle_rhs, x, np.repeat(uk[None, :], n, axis=0), d / n)[-1]
        travelled += abs(uk[0]) * d
    return x, travelled


def ompl_distances(space: str, rho: float, a: np.ndarray, b: np.ndarray) -> list[float]:
    """OMPL's distance between pose pairs in ``ompl.base.<space>(rho)`` (skips the test without OMPL)."""
    ob = pytest.importorskip("ompl.base")
    sp: Callable[..., object] = getattr(ob, space)(rho)
    s0, s1 = sp.allocState(), sp.allocState()  # type: ignore[attr-defined]
    ref = []
    for p, q in zip(a, b, strict=True):
        s0.setX(p[0]), s0.setY(p[1]), s0.setYaw(p[2])
        s1.setX(q[0]), s1.setY(q[1]), s1.setYaw(q[2])
        ref.append(sp.distance(s0, s1))  # type: ignore[attr-defined]
    return ref
