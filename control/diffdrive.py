"""The differential-drive mapping between body commands (v, omega) and wheel speeds."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.dispatch import bind
from planning.core.checks import check_fields
from planning.core.robot import RobotSpec


@nb.njit(cache=True)
def _wheel_speeds(
    v: float, omega: float, radius: float, track: float, limit: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """:meth:`DiffDrive.wheel_speeds`, compiled."""
    half = 0.5 * track * omega
    left = (v - half) / radius
    right = (v + half) / radius
    peak = max(abs(left), abs(right))
    if peak > limit:
        scale = limit / peak
        left *= scale
        right *= scale
    return left, right


@nb.njit(cache=True)
def _command_into(
    radius: float, track: float, limit: float, commands: NDArray[np.float64], row: int, v: float, omega: float
) -> bool:  # pragma: no cover - compiled
    """:meth:`DiffDrive.command_into`, compiled (the drive's constants first, to be bound)."""
    if not (math.isfinite(v) and math.isfinite(omega)):
        return False
    left, right = _wheel_speeds(v, omega, radius, track, limit)
    c = commands[row]
    c[0], c[1], c[2], c[3] = v, omega, left, right
    return True


@dataclass(frozen=True)
class DiffDrive:
    """Wheel geometry and motor limit of a differential drive.

    Attributes:
        wheel_radius: r [m].
        track_width: Distance between the wheels [m].
        max_wheel_speed: |wheel speed| limit [rad/s].

    Raises:
        ConfigError: A field that is not a finite number > 0 (names it, its unit and where a robot's come from).
    """

    wheel_radius: float
    track_width: float
    max_wheel_speed: float

    def __post_init__(self) -> None:
        fix = "DiffDrive.from_robot(load_robot('turtlebot3')) takes a robot's"
        units = {"wheel_radius": "m", "track_width": "m", "max_wheel_speed": "rad/s"}
        check_fields(
            self, {name: {"above": 0.0, "unit": unit, "fix": fix} for name, unit in units.items()}, "DiffDrive."
        )

    @classmethod
    def from_robot(cls, robot: RobotSpec, *, wheel_radius: float | None = None) -> DiffDrive:
        """The drive of a robot spec; ``wheel_radius`` overrides what the controller believes."""
        return cls(wheel_radius or robot.wheel_radius, robot.track_width, robot.max_wheel_speed)

    def wheel_speeds(self, v: float, omega: float) -> tuple[float, float]:
        """Wheel speeds [left, right] [rad/s] for a body command, scaled to the motor limit.

        When a wheel would exceed ``max_wheel_speed`` both are scaled by the same factor, so the
        path curvature omega / v is kept and only the pace drops.

        Args:
            v: Body speed [m/s].
            omega: Yaw rate [rad/s].
        """
        return _wheel_speeds(v, omega, self.wheel_radius, self.track_width, self.max_wheel_speed)

    def command_into(self, commands: NDArray[np.float64], row: int, v: float, omega: float) -> bool:
        """Write a finite body command and its wheel speeds (:meth:`wheel_speeds`) into row ``row``
        of a (K, 4) float array [v, omega, left, right] in one compiled call (a control loop's per-period
        bookkeeping).

        Returns:
            False, writing nothing, when ``v`` or ``omega`` is not finite.
        """
        return _command_into(self.wheel_radius, self.track_width, self.max_wheel_speed, commands, row, v, omega)

    def command_writer(self, commands: NDArray[np.float64]) -> Callable[[int, float, float], bool]:
        """:meth:`command_into` bound to one table: ``write(row, v, omega)``, without a Python frame of its
        own (the compiled call with the drive and the table bound, its overload resolved once:
        :func:`control.dispatch.bind`), for a loop that writes every period."""
        return bind(
            _command_into, self.wheel_radius, self.track_width, self.max_wheel_speed, commands, free=(0, 0.0, 0.0)
        )

    def body_twist(self, left: float, right: float) -> tuple[float, float]:
        """Body (v, omega) [m/s, rad/s] from wheel speeds [rad/s]."""
        r = self.wheel_radius
        return r * (left + right) / 2.0, r * (right - left) / self.track_width
