"""The planner interface: problems, results, statuses, and the registry of planners by name."""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from planning.core.geometry import Pose2D
from planning.core.robot import RobotSpec, load_robot
from planning.core.world import World
from planning.errors import ConfigError
from planning.scenario import Scenario

FloatArray = NDArray[np.float64]


class PlanStatus(StrEnum):
    """How a planning attempt ended. Only ``SUCCESS`` carries a complete path."""

    SUCCESS = "success"
    TIMEOUT = "timeout"  # budget (time or iterations) spent; best partial result attached
    INFEASIBLE = "infeasible"  # the problem has no solution the planner can find (reason says why)
    BOUNDS_VIOLATED = "bounds_violated"  # a path was found but leaves the state or input bounds
    INVALID_START = "invalid_start"
    INVALID_GOAL = "invalid_goal"
    FAILED = "failed"  # a numerical failure (reason says which)


@dataclass(frozen=True)
class PlanProblem:
    """What a planner is asked to solve.

    Attributes:
        world: Bounds and obstacles.
        robot: The robot (footprint, limits).
        start: Start pose.
        goal: Goal pose.
        position_tolerance: Goal region radius [m].
        heading_tolerance: Goal heading tolerance [rad].
        seed: Seed of the planner's random generator; same seed, same plan.
        time_limit: Wall-clock budget [s].
        name: Scenario name, for records.
    """

    world: World
    robot: RobotSpec
    start: Pose2D
    goal: Pose2D
    position_tolerance: float = 0.05
    heading_tolerance: float = 0.1
    seed: int = 0
    time_limit: float = 30.0
    name: str = "problem"

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, *, robot: RobotSpec | None = None, seed: int = 0, time_limit: float = 30.0
    ) -> PlanProblem:
        """The planning problem a scenario poses."""
        return cls(
            world=scenario.world,
            robot=robot if robot is not None else load_robot(scenario.robot),
            start=scenario.start,
            goal=scenario.goal,
            position_tolerance=scenario.position_tolerance,
            heading_tolerance=scenario.heading_tolerance,
            seed=seed,
            time_limit=time_limit,
            name=scenario.name,
        )


@dataclass(frozen=True)
class PlanTree:
    """A search tree for plotting: nodes (M, 3) poses, parent index per node (-1 at roots),
    and optionally the dense edge curves (list of (k, 2) arrays)."""

    nodes: FloatArray
    parents: NDArray[np.int64]
    edges: tuple[FloatArray, ...] = ()


@dataclass(frozen=True)
class PlanResult:
    """The outcome of a planning attempt; failure is a status with a reason, never ``None``.

    Attributes:
        status: How it ended.
        planner: Planner name.
        path: (N, 3) poses [x, y, theta] densely along the motion (or empty (0, 3)).
        reason: Human-readable explanation for any status but success.
        stats: Numbers worth reporting (time_s, iterations, nodes, ...).
        tree: The search tree, for planners that grow one.
        times: (N,) time stamps when the planner timed the path itself (optim, sinusoidal).
        controls: (N, 2) [v, omega] at ``times`` when the planner timed the path.
        directions: (N,) +1 forwards / -1 backwards of the motion arriving at each pose of ``path``
            (directions[0] repeats the first step's), when the planner knows.
        states: (N, n) full planner states (e.g. bicycle [x, y, theta, phi]) when richer than poses.
    """

    status: PlanStatus
    planner: str
    path: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    reason: str = ""
    stats: dict[str, Any] = field(default_factory=dict)
    tree: PlanTree | None = None
    times: FloatArray | None = None
    controls: FloatArray | None = None
    directions: FloatArray | None = None
    states: FloatArray | None = None

    @property
    def success(self) -> bool:
        """Whether the path reaches the goal."""
        return self.status is PlanStatus.SUCCESS

    def length(self) -> float:
        """Length of the x-y path [m]."""
        if self.path.shape[0] < 2:
            return 0.0
        return float(np.sum(np.hypot(np.diff(self.path[:, 0]), np.diff(self.path[:, 1]))))


class Planner(Protocol):
    """Anything with a name and ``plan(problem) -> PlanResult``."""

    name: str

    def plan(self, problem: PlanProblem) -> PlanResult:
        """Plan; never raises for an unsolvable problem, returns a status instead."""
        ...


#: Planner name -> "module:factory". The factory takes keyword-only options and returns a Planner.
PLANNERS: dict[str, str] = {
    "rrt": "planning.planners.sampling.rrt:RRT",
    "birrt": "planning.planners.sampling.rrt:BiRRT",
    "rrt-star": "planning.planners.sampling.rrt_star:RRTStar",
    "c-rrt-star": "planning.planners.sampling.crrt_star:CRRTStar",
    "sinusoidal": "planning.planners.sinusoidal:Sinusoidal",
    "optim": "planning.planners.optim:Optim",
}


def register_planner(name: str, target: str) -> None:
    """Register a planner factory by import path, e.g. ``"planning.planners.sampling.rrt:RRT"``."""
    PLANNERS[name] = target


def make_planner(name: str, **options: Any) -> Planner:
    """Instantiate a registered planner.

    Raises:
        ConfigError: Unknown name (the message lists the valid ones) or bad options.
    """
    if name not in PLANNERS:
        raise ConfigError(f"unknown planner {name!r}: choose one of {', '.join(sorted(PLANNERS)) or '(none)'}")
    module_name, attr = PLANNERS[name].split(":")
    factory = getattr(importlib.import_module(module_name), attr)
    try:
        return factory(**options)  # type: ignore[no-any-return]
    except TypeError as exc:
        raise ConfigError(f"planner {name!r}: {exc}") from exc
