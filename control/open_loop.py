"""Open-loop playback: send the trajectory's own (v, omega), ignoring the measured pose."""

from __future__ import annotations

import math

import numpy as np

from control.inputs import check_command, check_reset, not_reset
from planning.core.robot import RobotSpec
from planning.trajectory.trajectory import Trajectory


class OpenLoop:
    """Feed-forward player: the baseline that shows what feedback removes.

    Each command is the reference input averaged over the coming control period (sampled at its
    midpoint), which is the best a zero-order hold can do without feedback.

    Source: the TurtleBot planning report (TurtleBot nonholonomic control), its simulation results:
    plans executed open loop drift from the desired poses because nothing corrects the error. Takes
    no options.

    Args:
        robot: The robot (kept for the interface; the reference is played as it is).
    """

    name = "open-loop"

    def __init__(self, robot: RobotSpec) -> None:
        self.robot = robot
        self._traj: Trajectory | None = None
        self._dt = 0.02
        self._t0 = 0.0
        self._starts: list[float] = []
        self._commands: list[tuple[float, float]] = []

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start playing ``trajectory`` with control period ``dt`` [s]; the commands of the control
        periods starting at t0 + k dt are sampled here, once.

        Raises:
            ConfigError: ``trajectory`` is not a Trajectory, or ``dt`` [s] is not a finite number > 0 (or
                too small for the trajectory's span).
        """
        self._dt = check_reset(self.name, trajectory, dt)
        self._traj = trajectory
        self._t0 = float(trajectory.t[0])
        starts = self._t0 + self._dt * np.arange(math.ceil(trajectory.duration / dt) + 2)
        s = trajectory.sample_many(starts + 0.5 * self._dt)
        self._starts = starts.tolist()
        self._commands = list(zip(s.v.tolist(), s.omega.tolist(), strict=True))

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Reference (v, omega) for the period starting at ``t``; the pose is ignored (but must be finite).

        Raises:
            ConfigError: An argument is not a number (an array, a text), as in every tracker.
            SimulationError: ``t`` or the pose is not finite, as in every tracker.
        """
        if self._traj is None:
            raise not_reset(self.name)
        check_command(self.name, t, x, y, theta)
        k = round((t - self._t0) / self._dt)
        if 0 <= k < len(self._starts) and self._starts[k] == t:  # a control instant: sampled at reset
            return self._commands[k]
        s = self._traj.sample_many(np.array([t + 0.5 * self._dt]))
        return float(s.v[0]), float(s.omega[0])
