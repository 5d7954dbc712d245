"""Open-loop playback: send the trajectory's own (v, omega), ignoring the measured pose."""

from __future__ import annotations

import numpy as np

from planning.core.robot import RobotSpec
from planning.trajectory.trajectory import Trajectory


class OpenLoop:
    """Feed-forward player.

    Each command is the reference input averaged over the coming control period (sampled at its
    midpoint), which is the best a zero-order hold can do without feedback.
    """

    name = "open-loop"

    def __init__(self, robot: RobotSpec, **_: object) -> None:
        self.robot = robot
        self._traj: Trajectory | None = None
        self._dt = 0.02

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start playing ``trajectory`` with control period ``dt`` [s]."""
        self._traj = trajectory
        self._dt = float(dt)

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Reference (v, omega) for the period starting at ``t``; the pose is ignored."""
        if self._traj is None:
            raise RuntimeError("OpenLoop.command called before reset")
        row = self._traj.sample_many(np.array([t + 0.5 * self._dt]))[0]
        return float(row[3]), float(row[4])
