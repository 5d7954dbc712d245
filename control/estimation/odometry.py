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

The EKF's compiled prediction (:func:`control.estimation.kernels.propagate`) integrates the arc and
its Jacobians with :func:`sinc_half`; plain-Python references of the arc, its Jacobians and of
dead reckoning over many periods live in tests/reference_odometry.py.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.checks import check_number

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
        check_number(name, value, above=0.0, unit="m, the robot as drawn")


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
    counts_per_rev = check_number("counts_per_rev", counts_per_rev, above=0.0, fix="e.g. 4096")
    return np.asarray(delta_counts, dtype=float) * (2.0 * math.pi / counts_per_rev)
