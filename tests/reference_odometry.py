"""Plain-Python references of the differential-drive odometry the EKF's compiled prediction
integrates (control/estimation/odometry.py's module doc: the exact arc in chord form, its
Jacobians, dead reckoning over many periods); the tests check the compiled code against them."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from control.estimation.odometry import SERIES_BELOW, check_geometry, sinc_half
from planning.errors import ConfigError

FloatArray = NDArray[np.float64]


def arc_step(x: float, y: float, theta: float, ds: float, dtheta: float) -> tuple[float, float, float]:
    """End pose of an arc of length ds turning by dtheta, exactly (chord form).

    Args:
        x: Start position [m].
        y: Start position [m].
        theta: Start heading [rad].
        ds: Arc length, signed (negative reverses) [m].
        dtheta: Heading change [rad].

    Returns:
        (x', y', theta') [m, m, rad]; theta' = theta + dtheta, not wrapped.
    """
    c, _ = sinc_half(dtheta)
    phi = theta + 0.5 * dtheta
    return x + ds * c * math.cos(phi), y + ds * c * math.sin(phi), theta + dtheta


def arc_jacobians(theta: float, ds: float, dtheta: float) -> tuple[FloatArray, FloatArray]:
    """Jacobians of :func:`arc_step`'s end pose.

    Args:
        theta: Start heading [rad].
        ds: Arc length [m].
        dtheta: Heading change [rad].

    Returns:
        (F (3, 3), J (3, 2)): d(x', y', theta')/d(x, y, theta) and d(x', y', theta')/d(ds, dtheta).
    """
    c, dc = sinc_half(dtheta)
    phi = theta + 0.5 * dtheta
    cp, sp = math.cos(phi), math.sin(phi)
    f = np.array([[1.0, 0.0, -ds * c * sp], [0.0, 1.0, ds * c * cp], [0.0, 0.0, 1.0]])
    j = np.array(
        [
            [c * cp, ds * (dc * cp - 0.5 * c * sp)],
            [c * sp, ds * (dc * sp + 0.5 * c * cp)],
            [0.0, 1.0],
        ]
    )
    return f, j


def integrate_arcs(pose0: ArrayLike, ds: ArrayLike, dtheta: ArrayLike, slip: ArrayLike | None = None) -> FloatArray:
    """Chain arcs from a start pose, vectorised.

    Args:
        pose0: (3,) start pose [x, y, theta] [m, m, rad].
        ds: (N,) arc lengths [m].
        dtheta: (N,) heading changes [rad].
        slip: (N,) slip angles [rad]: each step's chord turned by its angle off the heading (the
            EKF's cornering slip, :mod:`control.estimation.ekf`); None: none.

    Returns:
        (N+1, 3) poses, the first pose0; heading accumulated, not wrapped.

    Raises:
        ConfigError: Shapes disagree or a value is not finite.
    """
    p0 = np.asarray(pose0, dtype=float)
    d = np.asarray(ds, dtype=float)
    a = np.asarray(dtheta, dtype=float)
    if p0.shape != (3,) or d.ndim != 1 or a.shape != d.shape:
        raise ConfigError(
            f"integrate_arcs needs pose0 (3,), ds (N,) and dtheta (N,), got {p0.shape}, {d.shape}, {a.shape}"
        )
    if not (np.isfinite(p0).all() and np.isfinite(d).all() and np.isfinite(a).all()):
        raise ConfigError("integrate_arcs: pose0, ds and dtheta must be finite")
    theta = p0[2] + np.concatenate(([0.0], np.cumsum(a)))
    h = 0.5 * a
    small = np.abs(h) < SERIES_BELOW
    h_safe = np.where(small, 1.0, h)
    c = np.where(small, 1.0 - h * h / 6.0 + h**4 / 120.0, np.sin(h_safe) / h_safe)
    phi = theta[:-1] + h if slip is None else theta[:-1] + h + np.asarray(slip, dtype=float)
    out = np.empty((d.size + 1, 3))
    out[:, 0] = p0[0] + np.concatenate(([0.0], np.cumsum(d * c * np.cos(phi))))
    out[:, 1] = p0[1] + np.concatenate(([0.0], np.cumsum(d * c * np.sin(phi))))
    out[:, 2] = theta
    return out


def integrate_wheels(
    pose0: ArrayLike, d_left: ArrayLike, d_right: ArrayLike, radius: float, track: float
) -> FloatArray:
    """Dead-reckon a pose sequence from wheel-angle increments (constant wheel speeds per period).

    Args:
        pose0: (3,) start pose [m, m, rad].
        d_left: (N,) left wheel angle increments [rad].
        d_right: (N,) right wheel angle increments [rad].
        radius: Wheel radius [m].
        track: Track width [m].

    Returns:
        (N+1, 3) poses, heading not wrapped.

    Raises:
        ConfigError: A non-positive or non-finite radius or track, or bad shapes (see :func:`integrate_arcs`).
    """
    check_geometry(radius, track)
    dl = np.asarray(d_left, dtype=float)
    dr = np.asarray(d_right, dtype=float)
    return integrate_arcs(pose0, 0.5 * radius * (dl + dr), radius * (dr - dl) / track)
