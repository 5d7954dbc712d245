"""The scenario type: a world, a robot, a start and a goal with its tolerances (read from TOML files by
:mod:`planning.scenario`)."""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from planning.core.checks import check_number, degrees_hint, heading_beyond, is_number
from planning.core.geometry import Pose2D, check_pose, heading_in_turn
from planning.core.robot import ROBOTS, check_robot_name
from planning.core.world import Obstacle, World, check_world
from planning.errors import ConfigError

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
            ``[planners.<name>]`` tables); a read-only copy of the mappings given, so an edit of those after
            the scenario was checked does not reach it.
        sensors: Overrides of the robot's sensor profile in this scenario (the ``[sensors]`` table,
            e.g. ``fix_rate = 5.0``); its keys are checked by the simulator against the profile. A read-only
            copy, as ``planner_options``.
        source: The file it was loaded from, if any.
        unmapped: Obstacles that exist in physics and in the laser scan but not in ``world``, the map
            the planner and the localiser use (the ``[[world.unmapped]]`` tables).

    Raises:
        ConfigError: A field of the wrong type (``start=(1, 1, 0)`` for ``Pose2D(1, 1, 0)``), a tolerance
            that is not a finite number > 0, or a start or goal heading beyond +-4 pi (degrees, or a typo; one
            within it is brought into (-pi, pi], as a scenario file's is); the message names the field, what
            was given and the fix. The robot's name, the planners named and the unmapped obstacles' distance
            from the start are checked where the scenario is used (:func:`planning.scenario.scenario_with_robot`,
            :func:`planning.scenario.check_ends_fit`): a robot read from an MJCF file has its file's name.
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
        _check_text("name", self.name)
        _check_text("robot", self.robot, f"a robot's name, one of {', '.join(ROBOTS.built_in())} or a plugin's")
        check_world("Scenario.world", self.world)
        for label in ("start", "goal"):
            object.__setattr__(self, label, _end_pose(label, getattr(self, label)))
        unit = "m, the goal region's radius"
        value = check_number("Scenario.position_tolerance", self.position_tolerance, above=0.0, unit=unit)
        object.__setattr__(self, "position_tolerance", value)
        object.__setattr__(self, "heading_tolerance", check_heading_tolerance("Scenario", self.heading_tolerance))
        if not isinstance(self.description, str):
            raise ConfigError(f"Scenario.description must be a string (free text), got {self.description!r:.80}")
        if self.planner is not None:
            _check_text("planner", self.planner, "a planner's name (e.g. 'rrt') or None")
        robots = _sequence("robots", self.robots, "robot names, e.g. ('turtlebot3', 'edumip')")
        if not all(isinstance(robot, str) and robot for robot in robots):
            raise ConfigError(
                "Scenario.robots must be a tuple of robot names, e.g. ('turtlebot3', 'edumip'), got "
                f"{self.robots!r:.80}"
            )
        object.__setattr__(self, "robots", robots or (self.robot,))
        if self.robot not in self.robots:  # as a scenario file's robots must list its robot
            raise ConfigError(
                f"Scenario.robots {self.robots!r:.80} must include the scenario's own robot {self.robot!r} "
                "(Scenario.robot): add it, or leave robots out for the robot alone"
            )
        _check_tables(self.planner_options, self.sensors)
        options = {name: MappingProxyType(dict(table)) for name, table in self.planner_options.items()}
        object.__setattr__(self, "planner_options", MappingProxyType(options))
        object.__setattr__(self, "sensors", MappingProxyType(dict(self.sensors)))
        if self.source is not None:
            if not isinstance(self.source, str | os.PathLike):
                raise ConfigError(
                    f"Scenario.source must be the path of the scenario's file or None, got {self.source!r}"
                )
            object.__setattr__(self, "source", Path(self.source))
        unmapped = _sequence("unmapped", self.unmapped, "obstacles (Circle, Ellipse, Box, Polygon)")
        for i, ob in enumerate(unmapped):
            if not isinstance(ob, Obstacle):
                raise ConfigError(
                    f"Scenario.unmapped[{i}] must be an obstacle (Circle, Ellipse, Box or Polygon), got {ob!r:.80}"
                )
        object.__setattr__(self, "unmapped", unmapped)

    def __getstate__(self) -> dict[str, Any]:  # a read-only mapping does not pickle; its dict does
        options = {name: dict(table) for name, table in self.planner_options.items()}
        return {**self.__dict__, "planner_options": options, "sensors": dict(self.sensors)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        options = {name: MappingProxyType(table) for name, table in state["planner_options"].items()}
        self.__dict__.update(
            state, planner_options=MappingProxyType(options), sensors=MappingProxyType(state["sensors"])
        )

    def with_robot(self, robot: str) -> Scenario:
        """The same scenario for another robot, which its ``robots`` then list (added last when they did not: the
        caller chose it; :func:`planning.scenario.scenario_with_robot` is the check that they list it).

        Raises:
            ConfigError: ``robot`` is not a robot name (the message lists them).
        """
        name = check_robot_name("Scenario.with_robot", robot)
        robots = self.robots if name in self.robots else (*self.robots, name)
        return dataclasses.replace(self, robot=name, robots=robots)

    def options_for(self, planner: str) -> dict[str, Any]:
        """Keyword options this scenario gives ``planner`` (a copy; empty if none)."""
        return dict(self.planner_options.get(planner, {}))


def check_heading_tolerance(owner: str, value: object) -> float:
    """A goal's heading tolerance [rad]: a finite number in (0, pi] (pi takes any heading; more is degrees, or
    a typo).

    Raises:
        ConfigError: Naming ``<owner>.heading_tolerance``, the value, and the degrees it could have been.
    """
    fix = f"pi takes any heading{degrees_hint(value, 360.0)}"
    if is_number(value) and math.pi < value < math.pi + 0.01:  # pi rounded up (3.1416), not 3.14 degrees
        fix = "pi takes any heading; pi rounded up is above it: write 3.14159 (or less)"
    return check_number(f"{owner}.heading_tolerance", value, above=0.0, at_most=math.pi, unit="rad", fix=fix)


def _end_pose(label: str, value: object) -> Pose2D:
    """``Scenario.start`` or ``.goal`` checked as a scenario file's pose is: a :class:`Pose2D` whose heading is
    within :data:`planning.core.checks.MAX_HEADING` (more is degrees, or a typo), brought into (-pi, pi]."""
    pose = check_pose(f"Scenario.{label}", value)
    if why := heading_beyond(pose.theta):
        raise ConfigError(f"Scenario.{label}'s heading must be {why}, got {pose.theta!r}")
    theta = heading_in_turn(pose.theta)
    return pose if theta == pose.theta else Pose2D(pose.x, pose.y, theta)


def _check_text(label: str, value: object, expected: str = "a non-empty string") -> None:
    """Raise a ConfigError naming ``Scenario.<label>`` unless ``value`` is a non-empty string."""
    if not isinstance(value, str) or not value:
        raise ConfigError(f"Scenario.{label} must be {expected}, got {value!r:.80}")


def _sequence(label: str, value: object, of: str) -> tuple[Any, ...]:
    """``value`` (a list or tuple) as a tuple, else a ConfigError naming ``Scenario.<label>`` and what it holds."""
    if not isinstance(value, Sequence) or isinstance(value, str):
        raise ConfigError(f"Scenario.{label} must be a tuple of {of}, got {value!r:.80}")
    return tuple(value)


def _check_tables(planner_options: object, sensors: object) -> None:
    """``planner_options`` maps planner names to mappings of options; ``sensors`` maps keys to numbers."""
    if not isinstance(planner_options, Mapping) or not all(
        isinstance(k, str) and isinstance(v, Mapping) for k, v in planner_options.items()
    ):
        raise ConfigError(
            "Scenario.planner_options must map planner names to mappings of keyword options, e.g. "
            f"{{'birrt': {{'steering': 'reeds_shepp'}}}}, got {planner_options!r:.80}"
        )
    if not isinstance(sensors, Mapping) or not all(
        isinstance(k, str) and isinstance(v, numbers.Real) and not isinstance(v, bool) for k, v in sensors.items()
    ):
        raise ConfigError(
            f"Scenario.sensors must map sensor profile keys to numbers, e.g. {{'fix_rate': 5.0}}, got {sensors!r:.80}"
        )
