"""Planar poses and angle helpers."""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


@overload
def wrap_angle(angle: float) -> float: ...
@overload
def wrap_angle(angle: FloatArray) -> FloatArray: ...


def wrap_angle(angle: float | FloatArray) -> float | FloatArray:
    """Wrap angles to [-pi, pi).

    Args:
        angle: Angle(s) [rad], scalar or array of any shape.

    Returns:
        The wrapped angle(s), same shape and type as the input.
    """
    wrapped = np.mod(np.asarray(angle, dtype=float) + np.pi, 2.0 * np.pi) - np.pi
    if np.ndim(wrapped) == 0:
        return float(wrapped)
    return wrapped


def unwrap_heading(theta: ArrayLike) -> FloatArray:
    """Remove 2*pi jumps from a heading sequence (N,) [rad]."""
    return np.unwrap(np.asarray(theta, dtype=float))


@dataclass(frozen=True)
class Pose2D:
    """A planar pose.

    Attributes:
        x: Position [m].
        y: Position [m].
        theta: Heading [rad], counter-clockwise from +x.
    """

    x: float
    y: float
    theta: float

    def __post_init__(self) -> None:
        for name in ("x", "y", "theta"):
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.floating, np.integer)) or not np.isfinite(value):
                raise ValueError(f"Pose2D.{name} must be a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))

    @classmethod
    def from_array(cls, values: ArrayLike) -> Pose2D:
        """Build a pose from a sequence ``[x, y, theta]``."""
        arr = np.asarray(values, dtype=float).reshape(-1)
        if arr.shape != (3,):
            raise ValueError(f"a pose needs exactly 3 numbers [x, y, theta], got shape {arr.shape}")
        return cls(float(arr[0]), float(arr[1]), float(arr[2]))

    def as_array(self) -> FloatArray:
        """Return ``[x, y, theta]`` as a (3,) array."""
        return np.array([self.x, self.y, self.theta])

    @property
    def xy(self) -> FloatArray:
        """Position as a (2,) array [m]."""
        return np.array([self.x, self.y])

    def distance_to(self, other: Pose2D) -> float:
        """Euclidean distance between the positions [m]."""
        return float(np.hypot(self.x - other.x, self.y - other.y))

    def heading_error_to(self, other: Pose2D) -> float:
        """Absolute wrapped heading difference [rad]."""
        return abs(wrap_angle(self.theta - other.theta))
