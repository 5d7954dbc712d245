"""The scenario type: a world, a robot, a start and a goal with its tolerances (read from TOML files by
:mod:`planning.scenario`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planning.core.geometry import Pose2D
from planning.core.robot import check_robot_name
from planning.core.world import Obstacle, World

DEFAULT_POSITION_TOLERANCE = 0.05
DEFAULT_HEADING_TOLERANCE = 0.1


@dataclass(frozen=True)
class Scenario:
    """A planning and tracking problem.

    Attributes:
        name: Scenario name.
        robot: Robot registry name.
        world: Bounds and obstacles.
        start: Start pose.
        goal: Goal pose.
        position_tolerance: Goal region radius [m].
        heading_tolerance: Goal heading tolerance [rad].
        description: Free text.
        planner: The planner this scenario is meant for by default, if any.
        robots: Robots the scenario suits (defaults to ``(robot,)``).
        planner_options: Planner name -> keyword options for that planner in this scenario (the
            ``[planners.<name>]`` tables).
        sensors: Overrides of the robot's sensor profile in this scenario (the ``[sensors]`` table,
            e.g. ``fix_rate = 5.0``); its keys are checked by the simulator against the profile.
        source: The file it was loaded from, if any.
        unmapped: Obstacles that exist in physics and in the laser scan but not in ``world``, the map
            the planner and the localiser use (the ``[[world.unmapped]]`` tables).
    """

    name: str
    robot: str
    world: World
    start: Pose2D
    goal: Pose2D
    position_tolerance: float = DEFAULT_POSITION_TOLERANCE
    heading_tolerance: float = DEFAULT_HEADING_TOLERANCE
    description: str = ""
    planner: str | None = None
    robots: tuple[str, ...] = ()
    planner_options: Mapping[str, Mapping[str, Any]] = field(default_factory=dict, hash=False)
    sensors: Mapping[str, float] = field(default_factory=dict, hash=False)
    source: Path | None = field(default=None, compare=False)
    unmapped: tuple[Obstacle, ...] = ()

    @property
    def physical_world(self) -> World:
        """The world as it is (the map's obstacles and the unmapped ones): what physics and the scan see."""
        if not self.unmapped:
            return self.world
        return World(self.world.bounds, self.world.obstacles + tuple(self.unmapped))

    def __post_init__(self) -> None:
        if not self.robots:
            object.__setattr__(self, "robots", (self.robot,))

    def with_robot(self, robot: str) -> Scenario:
        """The same scenario for another robot.

        Raises:
            ConfigError: ``robot`` is not a robot name (the message lists them).
        """
        return dataclasses.replace(self, robot=check_robot_name("Scenario.with_robot", robot))

    def options_for(self, planner: str) -> dict[str, Any]:
        """Keyword options this scenario gives ``planner`` (a copy; empty if none)."""
        return dict(self.planner_options.get(planner, {}))
