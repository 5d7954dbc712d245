"""The tracker interface and the registry of trackers by name."""

from __future__ import annotations

import importlib
from typing import Any, Protocol

from planning.core.robot import RobotSpec
from planning.errors import ConfigError
from planning.trajectory.trajectory import Trajectory


class Tracker(Protocol):
    """A feedback (or feed-forward) law with explicit state.

    The simulator calls ``reset`` once, then ``command`` at the control rate with the measured
    pose, and holds the returned (v, omega) until the next call.
    """

    name: str

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking ``trajectory`` with control period ``dt`` [s]."""
        ...

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command (v [m/s], omega [rad/s]) at time ``t`` [s] for the measured pose."""
        ...


#: Tracker name -> "module:factory"; the factory is called as factory(robot, gains=...).
TRACKERS: dict[str, str] = {
    "fbl": "control.fbl:DynamicFBL",
    "open-loop": "control.open_loop:OpenLoop",
    "segmented": "control.segmented:SegmentedTracker",
}


def make_tracker(name: str, robot: RobotSpec, **options: Any) -> Tracker:
    """Instantiate a registered tracker for a robot.

    Raises:
        ConfigError: Unknown name (lists the valid ones).
    """
    if name not in TRACKERS:
        raise ConfigError(f"unknown tracker {name!r}: choose one of {', '.join(sorted(TRACKERS))}")
    module_name, attr = TRACKERS[name].split(":")
    factory = getattr(importlib.import_module(module_name), attr)
    return factory(robot, **options)  # type: ignore[no-any-return]
