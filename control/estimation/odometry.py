"""Differential-drive odometry: wheel-angle increments to body motion, exact arc integration, Jacobians.

The estimator knows only the robot as it is drawn (nominal wheel radius r and track width b), so
these functions take the geometry as arguments. Over one control period the wheels turn by
(dphi_l, dphi_r) [rad]; the body then travels

    ds     = r (dphi_l + dphi_r) / 2          [m]     (arc length of the axle centre)
    dtheta = r (dphi_r - dphi_l) / b          [rad]   (heading change)

If the wheel speeds are constant over the period the axle centre moves along a circular arc (or a
straight line), and the end pose is, exactly,

    x' = x + ds * sinc(dtheta/2) * cos(theta + dtheta/2)
    y' = y + ds * sinc(dtheta/2) * sin(theta + dtheta/2)
    theta' = theta + dtheta,                  sinc(h) = sin(h) / h,

the chord form of the arc, which has no 0/0 at dtheta = 0 (Thrun, Burgard and Fox, Probabilistic
Robotics, 2005, sec. 5.3, the velocity motion model's exact circular motion, written with the chord
so a straight segment needs no special case). sinc and its derivative switch to their Taylor series
below |h| = 1e-2, where both series are exact to double precision.

:func:`arc_jacobians` gives the derivatives of the end pose with respect to the start pose and to
(ds, dtheta), which the EKF of :mod:`control.estimation.ekf` chains with its input model.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.errors import ConfigError

FloatArray = NDArray[np.float64]

#: Below this |h| [rad] sinc(h) and its derivative use their Taylor series.
SERIES_BELOW = 1e-2


@nb.njit(cache=True)
def sinc_half(dtheta: float) -> tuple[float, float]:
    """sin(h)/h with h = dtheta/2, and its derivative with respect to dtheta (compiled: the EKF's
    prediction kernel calls it).

    Args:
        dtheta: Heading increment [rad].

    Returns:
        (c, dc/ddtheta) [-, 1/rad].
    """
    h = 0.5 * dtheta
    if abs(h) < SERIES_BELOW:
        h2 = h * h
        c = 1.0 - h2 / 6.0 + h2 * h2 / 120.0
        dc_dh = h * (-1.0 / 3.0 + h2 / 30.0 - h2 * h2 / 840.0)
    else:
        s, co = math.sin(h), math.cos(h)
        c = s / h
        dc_dh = (h * co - s) / (h * h)
    return c, 0.5 * dc_dh


def check_geometry(radius: float, track: float) -> None:
    """Check a nominal wheel radius and track width.

    Raises:
        ConfigError: Either is not a finite number > 0 (it names which, with the value).
    """
    for name, value in (("wheel radius", radius), ("track width", track)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise ConfigError(f"{name} must be a finite number > 0 [m] (the robot as drawn), got {value!r}")


def wheel_to_body(d_left: float, d_right: float, radius: float, track: float) -> tuple[float, float]:
    """Body motion of a differential drive from its wheel-angle increments.

    Args:
        d_left: Left wheel angle increment [rad] (positive drives forward).
        d_right: Right wheel angle increment [rad].
        radius: Wheel radius r [m].
        track: Track width b [m].

    Returns:
        (ds [m], dtheta [rad]): arc length of the axle centre and heading change.
    """
    return 0.5 * radius * (d_left + d_right), radius * (d_right - d_left) / track


def counts_to_radians(delta_counts: ArrayLike, counts_per_rev: float) -> FloatArray:
    """Encoder count increments to wheel-angle increments.

    Args:
        delta_counts: Count increments, any shape (integers or floats).
        counts_per_rev: Counts per wheel revolution (4096 for the XL430 on a TurtleBot3;
            60 x 35.555 = 2133.3 for the EduMIP's motor encoder behind its gearbox).

    Returns:
        Wheel-angle increments [rad], same shape.

    Raises:
        ConfigError: counts_per_rev is not a finite positive number.
    """
    if not (isinstance(counts_per_rev, (int, float)) and math.isfinite(counts_per_rev) and counts_per_rev > 0):
        raise ConfigError(f"counts_per_rev must be a finite number > 0 (e.g. 4096), got {counts_per_rev!r}")
    return np.asarray(delta_counts, dtype=float) * (2.0 * math.pi / counts_per_rev)


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


def integrate_arcs(pose0: ArrayLike, ds: ArrayLike, dtheta: ArrayLike) -> FloatArray:
    """Chain arcs from a start pose, vectorised.

    Args:
        pose0: (3,) start pose [x, y, theta] [m, m, rad].
        ds: (N,) arc lengths [m].
        dtheta: (N,) heading changes [rad].

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
    phi = theta[:-1] + h
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
