"""The problems of ``nhsim bench plan``: built-in scenarios, ``disc10`` and three hard ones for the TurtleBot3.

* ``disc10``: 10 x 10 m, one disc of radius 2 m, start (1, 1, 0), goal (9, 9, 0).
* ``corridor``: a 1 m corridor 1.3 x the robot's width (footprint y-extent) wide between two
  blocks; the start faces across it below the blocks and the goal faces back above them, so every
  path threads the corridor lengthwise.
* ``maze``: 2.4 x 2.1 m, two walls 4 cm thick leaving a serpentine of three 0.68 m lanes joined
  by 0.7 m gaps at alternate ends; the goal is at the far end of the last lane.
* ``tight_park``: a kerbside slot 2 x the robot's length (footprint x-extent) between two parked
  blocks as deep as the slot; the goal is in the slot, the start in the lane.
* ``random<N>``: :func:`planning.scenario.random_scenario`'s seeded 6 x 6 m world ``N`` for the
  TurtleBot3 (seven circles and boxes, corner to corner), a world nothing was tuned on.
"""

from __future__ import annotations

import numpy as np

from planning.core.checks import check_number
from planning.core.geometry import Pose2D
from planning.core.robot import RobotSpec, load_robot
from planning.core.world import Box, Circle, World
from planning.errors import ConfigError
from planning.planners.base import PlanProblem

#: Corridor width over the robot's width, and slot length over the robot's length.
CORRIDOR_FACTOR = 1.3
SLOT_FACTOR = 2.0
#: Thickness of the maze walls [m].
MAZE_WALL = 0.04


def _extent(robot: RobotSpec, axis: int) -> float:
    fp = robot.footprint[:, axis]
    return float(fp.max() - fp.min())


def disc10() -> PlanProblem:
    """One disc in a 10 x 10 m world (see the module doc)."""
    world = World((0.0, 10.0, 0.0, 10.0), (Circle((5.0, 5.0), 2.0),))
    return PlanProblem(world, load_robot("turtlebot3"), Pose2D(1.0, 1.0, 0.0), Pose2D(9.0, 9.0, 0.0), name="disc10")


def corridor() -> PlanProblem:
    """A corridor 1.3 x the robot's width (see the module doc)."""
    robot = load_robot("turtlebot3")
    w = CORRIDOR_FACTOR * _extent(robot, 1)
    y_lo, y_hi = 0.75 - 0.5 * w, 0.75 + 0.5 * w
    blocks = (Box((1.5, 0.5 * y_lo), (1.0, y_lo)), Box((1.5, 0.5 * (y_hi + 1.5)), (1.0, 1.5 - y_hi)))
    world = World((0.0, 3.0, 0.0, 1.5), blocks)
    return PlanProblem(world, robot, Pose2D(0.4, 0.3, np.pi / 2), Pose2D(2.6, 1.2, -np.pi / 2), name="corridor")


def maze() -> PlanProblem:
    """A serpentine of three lanes in 2.4 x 2.1 m (see the module doc)."""
    t = MAZE_WALL
    walls = (
        Box((0.85, 0.7), (1.7, t)),  # y = 0.7, open on the right
        Box((1.55, 1.4), (1.7, t)),  # y = 1.4, open on the left
    )
    world = World((0.0, 2.4, 0.0, 2.1), walls)
    robot = load_robot("turtlebot3")
    return PlanProblem(world, robot, Pose2D(0.3, 0.35, 0.0), Pose2D(2.1, 1.75, 0.0), name="maze")


def tight_park() -> PlanProblem:
    """Parallel parking into a slot 2 x the robot's length (see the module doc)."""
    robot = load_robot("turtlebot3")
    slot, depth = SLOT_FACTOR * _extent(robot, 0), 0.2
    x0, x1 = 0.9, 0.9 + slot
    cars = (Box((x0 - 0.3, 0.5 * depth), (0.6, depth)), Box((x1 + 0.3, 0.5 * depth), (0.6, depth)))
    world = World((0.0, 2.0, 0.0, 0.8), cars)
    fp = robot.footprint[:, 0]
    gx = 0.5 * (x0 + x1) - 0.5 * float(fp.max() + fp.min())  # footprint centred in the slot
    return PlanProblem(world, robot, Pose2D(0.5, 0.45, 0.0), Pose2D(gx, 0.5 * depth, 0.0), name="tight_park")


#: The hand-made problems by name.
HARD = {"disc10": disc10, "corridor": corridor, "maze": maze, "tight_park": tight_park}


def _posed(problem: PlanProblem) -> bool:
    """Whether the start lies outside the goal region (in position or heading)."""
    s, g = problem.start, problem.goal
    dth = abs((s.theta - g.theta + np.pi) % (2 * np.pi) - np.pi)
    return bool(np.hypot(s.x - g.x, s.y - g.y) > problem.position_tolerance or dth > problem.heading_tolerance)


def _random_world(seed: int) -> PlanProblem:
    """``random<seed>``: :func:`planning.scenario.random_scenario`'s world for the TurtleBot3."""
    from planning.scenario import random_scenario

    return PlanProblem.from_scenario(random_scenario("turtlebot3", seed))


def _random(name: str) -> PlanProblem | None:
    """``random<N>``'s problem, or None when ``name`` is not of that form."""
    from planning.scenario import random_seed

    seed = random_seed(name)
    return None if seed is None else _random_world(seed)


def problems(names: list[str] | None = None, random_worlds: int = 0) -> list[PlanProblem]:
    """The race's problems: ``names`` (built-in scenario names, a key of :data:`HARD` or ``random<N>``),
    or by default every built-in scenario whose start is outside its goal region, then :data:`HARD`;
    then the seeded random worlds ``random0`` .. ``random<random_worlds - 1>``.

    Raises:
        ConfigError: An unknown name (the message lists the valid ones) or a negative count.
    """
    from planning.scenario import builtin_scenarios, load_scenario, misspelt_random_name

    check_number("--random-worlds", random_worlds, integer=True, at_least=0)
    builtin = builtin_scenarios()
    extra = [_random_world(s) for s in range(random_worlds)]
    if names is None:
        found = [PlanProblem.from_scenario(load_scenario(n)) for n in builtin]
        return [p for p in found if _posed(p)] + [make() for make in HARD.values()] + extra
    unknown = [n for n in names if n not in HARD and n not in builtin and _random(n) is None]
    misspelt = [why for n in unknown if (why := misspelt_random_name(n))]
    if misspelt:
        raise ConfigError(f"--scenarios: {misspelt[0]}")
    if unknown:
        raise ConfigError(
            f"unknown problem(s) {', '.join(unknown)} for --scenarios: choose from "
            f"{', '.join([*builtin, *HARD])} or random<N>"
        )
    named = [HARD[n]() if n in HARD else _random(n) or PlanProblem.from_scenario(load_scenario(n)) for n in names]
    return named + extra
