"""The differential-drive mapping between body commands (v, omega) and wheel speeds."""

from __future__ import annotations

from dataclasses import dataclass

from planning.core.robot import RobotSpec


@dataclass(frozen=True)
class DiffDrive:
    """Wheel geometry and motor limit of a differential drive.

    Attributes:
        wheel_radius: r [m].
        track_width: Distance between the wheels [m].
        max_wheel_speed: |wheel speed| limit [rad/s].
    """

    wheel_radius: float
    track_width: float
    max_wheel_speed: float

    def __post_init__(self) -> None:
        for name in ("wheel_radius", "track_width", "max_wheel_speed"):
            if not getattr(self, name) > 0:
                raise ValueError(f"DiffDrive.{name} must be > 0, got {getattr(self, name)}")

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
        half = 0.5 * self.track_width * omega
        left = (v - half) / self.wheel_radius
        right = (v + half) / self.wheel_radius
        peak = max(abs(left), abs(right))
        if peak > self.max_wheel_speed:
            scale = self.max_wheel_speed / peak
            left *= scale
            right *= scale
        return left, right

    def body_twist(self, left: float, right: float) -> tuple[float, float]:
        """Body (v, omega) [m/s, rad/s] from wheel speeds [rad/s]."""
        r = self.wheel_radius
        return r * (left + right) / 2.0, r * (right - left) / self.track_width
