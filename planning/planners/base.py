"""The planner interface: problems, results and statuses (the registry by name is :mod:`planning.planners.registry`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from planning.core.geometry import Pose2D
from planning.core.robot import RobotSpec, load_robot
from planning.core.world import World

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


class ScenarioLike(Protocol):
    """What :meth:`PlanProblem.from_scenario` reads from a scenario (:class:`planning.scenario.Scenario`)."""

    @property
    def name(self) -> str:
        """Scenario name."""
        ...

    @property
    def robot(self) -> str:
        """Robot registry name."""
        ...

    @property
    def world(self) -> World:
        """Bounds and obstacles."""
        ...

    @property
    def start(self) -> Pose2D:
        """Start pose."""
        ...

    @property
    def goal(self) -> Pose2D:
        """Goal pose."""
        ...

    @property
    def position_tolerance(self) -> float:
        """Goal region radius [m]."""
        ...

    @property
    def heading_tolerance(self) -> float:
        """Goal heading tolerance [rad]."""
        ...


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
        cls, scenario: ScenarioLike, *, robot: RobotSpec | None = None, seed: int = 0, time_limit: float = 30.0
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
