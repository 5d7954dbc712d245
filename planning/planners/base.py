"""The planner interface: problems, results and statuses (the registry by name is :mod:`planning.planners.registry`)."""

from __future__ import annotations

import dataclasses
import math
import numbers
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.arrays import ReadOnlyArrays
from planning.core.checks import check_number
from planning.core.geometry import Pose2D, check_pose, densify_path, path_length, path_steps, wrap_angle
from planning.core.robot import RobotSpec, check_robot_spec, load_robot
from planning.core.scenario_type import Scenario, check_heading_tolerance
from planning.core.world import World, check_world, span
from planning.errors import ConfigError, NhsimError, PlannerError

FloatArray = NDArray[np.float64]


class PlanStatus(StrEnum):
    """How a planning attempt ended. Only ``SUCCESS`` carries a complete path."""

    SUCCESS = "success"
    TIMEOUT = "timeout"  # budget (time or iterations) spent; best partial result attached
    INFEASIBLE = "infeasible"  # the problem has no solution the planner can find (reason says why)
    BOUNDS_VIOLATED = "bounds_violated"  # a path leaves the state or input bounds, or none fits within them
    INVALID_START = "invalid_start"
    INVALID_GOAL = "invalid_goal"
    FAILED = "failed"  # a numerical failure (reason says which)


@dataclass(frozen=True)
class PlanProblem:
    """What a planner is asked to solve. Problems compare and hash by value (the robot's footprint too:
    :class:`~planning.core.robot.RobotSpec`), so one made twice from a scenario equals itself.

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

    Raises:
        ConfigError: A field of the wrong type, a tolerance or time limit that is not a finite
            number > 0, or a seed that is not an integer >= 0 (the message names the field).
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

    def __post_init__(self) -> None:
        check_world("PlanProblem.world", self.world)
        check_robot_spec("PlanProblem", self.robot)
        check_pose("PlanProblem.start", self.start)
        check_pose("PlanProblem.goal", self.goal)
        for label in ("position_tolerance", "time_limit"):
            object.__setattr__(self, label, check_number(f"PlanProblem.{label}", getattr(self, label), above=0.0))
        object.__setattr__(self, "heading_tolerance", check_heading_tolerance("PlanProblem", self.heading_tolerance))
        object.__setattr__(self, "seed", check_number("PlanProblem.seed", self.seed, integer=True, at_least=0))
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"PlanProblem.name must be a name (text), e.g. 'my-problem', got {self.name!r:.80}")

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, *, robot: RobotSpec | None = None, seed: int = 0, time_limit: float = 30.0
    ) -> PlanProblem:
        """The planning problem a scenario poses."""
        if not isinstance(scenario, Scenario):
            raise ConfigError(
                f"PlanProblem.from_scenario takes a Scenario (load_scenario('edumip_map')), got {scenario!r}"
            )
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


def checked_problem(problem: object) -> PlanProblem:
    """``problem``, which a planner's ``plan`` takes, checked to be a :class:`PlanProblem`.

    Raises:
        ConfigError: It is something else (a scenario, None), naming how to make one.
    """
    if not isinstance(problem, PlanProblem):
        raise ConfigError(
            f"a planner plans a PlanProblem (PlanProblem.from_scenario(load_scenario(NAME))), got {problem!r:.80}"
        )
    return problem


def end_outside(problem: PlanProblem, planner: str, stats: dict[str, Any] | None = None) -> PlanResult | None:
    """The ``INVALID_START`` / ``INVALID_GOAL`` result of a start or goal whose position lies outside the world's
    bounds (on a wall counts as outside), said alike by every planner; None when both lie inside."""
    xmin, xmax, ymin, ymax = problem.world.bounds
    for which, pose, status in (
        ("start", problem.start, PlanStatus.INVALID_START),
        ("goal", problem.goal, PlanStatus.INVALID_GOAL),
    ):
        if not (xmin < pose.x < xmax and ymin < pose.y < ymax):  # World.wall_distance > 0, without numpy's calls
            reason = (
                f"{which} pose ({pose.x:.3f}, {pose.y:.3f}, {pose.theta:.3f}) lies outside the world's bounds "
                f"({span(*problem.world.bounds)}): move it inside"
            )
            return PlanResult(status, planner, reason=reason, stats=dict(stats or {}))
    return None


def end_overlaps(problem: PlanProblem, planner: str, stats: dict[str, Any] | None = None) -> PlanResult | None:
    """The ``INVALID_START`` / ``INVALID_GOAL`` result of a start or goal pose the robot's footprint cannot take
    (:func:`planning.collision.overlap.footprint_overlap`: the reason names what it overlaps and how far to move),
    for a planner that does not check its ends with a collision grid of its own; None when both are free."""
    from planning.collision.overlap import footprint_overlap  # imported here: compiled code, loaded on first use

    for which, pose, status in (
        ("start", problem.start, PlanStatus.INVALID_START),
        ("goal", problem.goal, PlanStatus.INVALID_GOAL),
    ):
        hit = footprint_overlap(problem.world, problem.robot, pose)
        if hit is not None:
            clearance, what, move = hit
            said = "holds part of it" if clearance == -math.inf else f"overlaps it by {-1e3 * clearance:.1f} mm"
            reason = (
                f"{which} pose ({pose.x:.3f}, {pose.y:.3f}, {pose.theta:.3f}) is in collision with {what}: the "
                f"{problem.robot.name}'s footprint there {said}; move the {which} {max(move, 0.001):.3f} m away from it"
            )
            return PlanResult(status, planner, reason=reason, stats=dict(stats or {}))
    return None


@dataclass(frozen=True, eq=False)
class PlanTree(ReadOnlyArrays):
    """A search tree for plotting: nodes (M, 3) poses, parent index per node (-1 at roots),
    and optionally the dense edge curves (a tuple of (k, 2) arrays).

    The arrays are the tree's own read-only copies, as a :class:`PlanResult`'s are (in its pickled and deep
    copies too). Trees are equal when their arrays are (:func:`planning.core.arrays.same_value`); a tree holds
    arrays, so it is not hashable.

    A planner may hand its result a tree :meth:`deferred`: built, and checked, when one of its fields is first
    read (a plan's plot reads it; a caller that wants only the path never pays for it, as OMPL's users ask a
    planner for its planner data only when they want it).

    Raises:
        ValueError: Nodes that are not (M, 3) numbers, parents that are not M integers, an edge that is not
            (k, 2) numbers.
    """

    nodes: FloatArray
    parents: NDArray[np.int64]
    edges: tuple[FloatArray, ...] = field(default_factory=tuple)  # not a class attribute: a deferred tree has none

    @classmethod
    def deferred(cls, build: Callable[[], tuple[ArrayLike, ArrayLike, tuple[ArrayLike, ...]]]) -> PlanTree:
        """A tree whose ``(nodes, parents, edges)`` ``build()`` gives when a field is first read (and checked
        then, as a tree made directly is). ``build`` must give the same arrays whenever it is called: the
        arrays it reads are not changed after."""
        tree = object.__new__(cls)
        object.__setattr__(tree, "_build", build)
        return tree

    if not TYPE_CHECKING:  # to the type checker a tree has its fields only

        def __getattr__(self, name: str) -> Any:
            """A deferred tree's field, the tree built first (only called for an attribute not set): built once,
            by the first thread that reads it (the others wait for it)."""
            if name in ("nodes", "parents", "edges"):
                with _DEFERRED_BUILD:
                    build = self.__dict__.get("_build")
                    if build is not None:
                        built = PlanTree(*build())  # checked: a tree that fails its checks stays unbuilt
                        self.__dict__.update(vars(built))
                        del self.__dict__["_build"]
                if name in self.__dict__:
                    return self.__dict__[name]
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __getstate__(self) -> dict[str, Any]:
        """Its fields (a deferred tree built first): a pickle or a copy holds arrays, not the builder."""
        self.nodes  # noqa: B018  # a deferred tree is built on this read
        return self.__dict__

    def __post_init__(self) -> None:
        nodes = _tree_array("nodes", self.nodes, 3)
        if not np.isfinite(nodes).all():
            raise ValueError("PlanTree.nodes holds non-finite values")
        parents: NDArray[Any] = np.array(self.parents)
        if parents.dtype.kind not in "iu":  # floats that are whole numbers are taken (a tree's own arrays are)
            whole = parents.dtype.kind == "f" and np.array_equal(parents, np.round(parents))
            parents = parents.astype(np.int64) if whole else np.empty(0)
        if parents.shape != (nodes.shape[0],):
            raise ValueError(
                f"PlanTree.parents must be one integer per node ({nodes.shape[0]}), got {self.parents!r:.80}"
            )
        parents = parents.astype(np.int64, copy=False)
        if why := _not_a_forest(parents):
            raise ValueError(f"PlanTree.parents must name each node's parent (-1 at a root): {why}")
        edges = tuple(_tree_array(f"edges[{k}]", e, 2) for k, e in enumerate(self.edges))
        if bad := [k for k, e in enumerate(edges) if not np.isfinite(e).all()]:
            raise ValueError(f"PlanTree.edges[{bad[0]}] holds non-finite values")
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "parents", _frozen(parents))
        object.__setattr__(self, "edges", edges)

    def __setstate__(self, state: dict[str, Any]) -> None:
        super().__setstate__(state)
        for edge in self.edges:  # the unpickled tuple's arrays are this tree's own
            edge.flags.writeable = False

    def __repr__(self) -> str:
        return f"PlanTree({np.shape(self.nodes)[0]} nodes, {len(self.edges)} edges)"


#: Held while a deferred :class:`PlanTree` is built, so that threads reading it at once build it once.
_DEFERRED_BUILD = threading.RLock()  # re-entrant: a builder may read another deferred tree


def _not_a_forest(parents: NDArray[np.int64]) -> str:
    """Why ``parents`` (one per node) is not a forest: a parent that is no node, no root, or a node whose parents
    lead round in a cycle; "" when it is one. Each node's 2^k-th ancestor, for k up to log2 of the nodes, must
    reach past a root."""
    m = parents.shape[0]
    if m == 0:
        return ""
    if (out := np.flatnonzero((parents < -1) | (parents >= m))).size:
        return f"node {out[0]}'s parent {parents[out[0]]} is no node (nodes 0 to {m - 1})"
    if not (parents == -1).any():
        return "no node is a root"
    up, reach = parents, 1
    while reach < m and (up >= 0).any():
        up = np.where(up >= 0, up[np.maximum(up, 0)], -1)
        reach *= 2
    if (cyc := np.flatnonzero(up >= 0)).size:
        return f"node {cyc[0]}'s parents lead round in a cycle, never to a root"
    return ""


def _frozen(arr: NDArray[Any]) -> NDArray[Any]:
    arr.flags.writeable = False
    return arr


def _tree_array(name: str, value: object, columns: int) -> FloatArray:
    """``value`` as :class:`PlanTree`'s own read-only (K, ``columns``) float copy, else ValueError naming the field."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"PlanTree.{name} must be an array of numbers: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] != columns:
        what = "poses [x, y, theta]" if columns == 3 else "positions [x, y]"
        raise ValueError(f"PlanTree.{name} must be (K, {columns}) {what}, got shape {arr.shape}")
    return _frozen(arr)


def _float_array(name: str, value: object, shape: tuple[int | None, ...]) -> FloatArray:
    """``value`` as a finite float array of ``shape`` (None: any size), else ValueError naming the field."""
    try:
        arr = np.array(value, dtype=float)  # the result's own copy: the caller's buffer may be re-used
    except (TypeError, ValueError) as exc:
        raise ValueError(f"PlanResult.{name} must be an array of numbers: {exc}") from None
    fits = arr.ndim == len(shape) and all(want in (None, got) for got, want in zip(arr.shape, shape, strict=False))
    if not fits:
        expected = ", ".join("any" if want is None else str(want) for want in shape)
        raise ValueError(f"PlanResult.{name} must have shape ({expected}) (one row per path pose), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"PlanResult.{name} holds non-finite values")
    arr.flags.writeable = False  # read-only, as the frozen result is: an edit would reach every record holding it
    return arr


@dataclass(frozen=True, eq=False)
class PlanResult(ReadOnlyArrays):
    """The outcome of a planning attempt; failure is a status with a reason, never ``None``.

    The arrays are the result's own read-only copies (a caller's later edit of the arrays it gave cannot
    change the result), in its pickled and deep copies too. Results are equal when every field is
    (:func:`planning.core.arrays.same_value`: arrays element by element, the stats item by item); a result's
    stats are a dict the commands add to, so it is not hashable. Its repr is one short line (status, planner, the
    path's size and length, time, reason), not its arrays.

    Attributes:
        status: How it ended.
        planner: Planner name.
        path: (N, 3) finite poses [x, y, theta] densely along the motion (or empty (0, 3); never
            empty on success).
        reason: Human-readable explanation for any status but success.
        stats: Numbers worth reporting (time_s, iterations, nodes, ...).
        tree: The search tree, for planners that grow one.
        times: (N,) time stamps when the planner timed the path itself (optim, sinusoidal).
        controls: (N, 2) [v, omega] at ``times`` when the planner timed the path.
        directions: (N,) +1 forwards / -1 backwards of the motion arriving at each pose of ``path``
            (directions[0] repeats the first step's), when the planner knows.
        states: (N, n) full planner states (e.g. bicycle [x, y, theta, phi]) when richer than poses.
        raw_path: (M, 3) the path as the search found it, before simplification
            (:mod:`planning.planners.simplify`), when the planner simplified ``path``.

    Raises:
        ValueError: A status that is not a :class:`PlanStatus`, a planner's name or reason that is not text,
            stats that are not a dict, a tree that is not a :class:`PlanTree`, an array of the wrong shape or
            with non-finite values, a success without a path, ``times`` without ``controls``, or times that do
            not strictly increase.
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
    raw_path: FloatArray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.status, PlanStatus):
            raise ValueError(f"PlanResult.status must be a PlanStatus, got {self.status!r}")
        for name, kind, what in (
            ("planner", str, "the planner's name"),
            ("reason", str, "a sentence"),
            ("stats", dict, "a dict of the numbers worth reporting ({} for none)"),
        ):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"PlanResult.{name} must be {what}, got {getattr(self, name)!r:.80}")
        if self.tree is not None and not isinstance(self.tree, PlanTree):
            raise ValueError(f"PlanResult.tree must be a PlanTree or None, got {type(self.tree).__name__}")
        path = _float_array("path", self.path, (None, 3))
        n = path.shape[0]
        if self.status is PlanStatus.SUCCESS and n == 0:
            raise ValueError("PlanResult.path is empty but the status is success: a successful plan has a path")
        object.__setattr__(self, "path", path)
        if (self.times is None) != (self.controls is None):
            raise ValueError("PlanResult.times and PlanResult.controls come together: give both or neither")
        for name, shape in (("times", (n,)), ("controls", (n, 2)), ("directions", (n,)), ("states", (n, None))):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _float_array(name, value, shape))
        if self.raw_path is not None:
            object.__setattr__(self, "raw_path", _float_array("raw_path", self.raw_path, (None, 3)))
        if self.times is not None and not (np.diff(self.times) > 0.0).all():
            k = int(np.argmax(np.diff(self.times) <= 0.0)) + 1
            raise ValueError(
                f"PlanResult.times must strictly increase (one stamp per pose): times[{k}] = {float(self.times[k])!r} "
                f"follows {float(self.times[k - 1])!r}"
            )
        if self.directions is not None and not (np.abs(self.directions) == 1.0).all():
            raise ValueError("PlanResult.directions must hold +1 (forwards) or -1 (backwards) per pose")

    def __repr__(self) -> str:
        parts = [self.status.value, f"planner={self.planner!r}", f"path={self.path.shape[0]} poses"]
        if self.path.shape[0]:
            parts.append(f"length={self.length():.3f} m")
        if isinstance(time_s := self.stats.get("time_s"), numbers.Real):
            parts.append(f"time_s={float(time_s):.3f}")
        timed = [name for name in ("times", "states", "raw_path") if getattr(self, name) is not None]
        if timed:
            parts.append(f"with {', '.join(timed)}")
        if self.tree is not None:
            parts.append(f"tree of {np.shape(self.tree.nodes)[0]} nodes")
        if self.reason:
            reason = self.reason if len(self.reason) <= 80 else self.reason[:77] + "..."
            parts.append(f"reason={reason!r}")
        return f"PlanResult({', '.join(parts)})"

    @property
    def success(self) -> bool:
        """Whether the path reaches the goal."""
        return self.status is PlanStatus.SUCCESS

    def length(self) -> float:
        """Length of the x-y path [m] (:func:`planning.core.geometry.path_length`; turns in place add nothing)."""
        return path_length(self.path)


class Planner(Protocol):
    """Anything with a name and ``plan(problem) -> PlanResult``."""

    name: str

    def plan(self, problem: PlanProblem) -> PlanResult:
        """Plan; never raises for an unsolvable problem, returns a status instead."""
        ...


#: How far a successful path's first pose may lie from the start [m, rad]: it is the start (a planner's path
#: begins where the robot stands; the built-in planners' begin there to the bit).
START_TOLERANCE = 1e-6


def run_planner(planner: Planner, name: str, problem: PlanProblem, origin: str = "") -> PlanResult:
    """``planner.plan(problem)`` as the commands run it: a planner that raises (but for a ConfigError: bad
    input it names) or returns something other than a :class:`PlanResult` is a :class:`PlannerError` naming
    it, and a success is checked against the problem: its path must start at the start and end within the goal
    tolerances, or the result is ``FAILED`` saying so (a plugin's planner that called a path to nowhere a
    success was tracked, and the run judged against its own end).

    Args:
        planner: The planner.
        name: Its registered name (for the messages).
        problem: The problem.
        origin: Who registered it, for the messages (``PLANNERS.origin(name)``; "" to leave out).

    Raises:
        PlannerError: As above.
        ConfigError: The planner's own refusal of bad input.
    """
    who = f"planner {name!r}" + (f" ({origin})" if origin else "")
    from planning.clock import ready  # numba and its clock: imported by the first plan, not by a --help

    ready()  # numba's one-time set-up in this process (0.3 s): before the planner's clock, as its own clock takes it
    started = time.perf_counter()
    try:
        result = planner.plan(problem)
    except NhsimError:
        raise
    except Exception as exc:  # whatever the planner's code raised
        raise PlannerError(f"{who} raised {type(exc).__name__}: {exc}") from exc
    if not isinstance(result, PlanResult):
        raise PlannerError(
            f"{who} returned {result!r:.60} ({type(result).__name__}), not a PlanResult (planning.PlanResult)"
        )
    # numba's loading of the planner's code and of its simplification's (a new process, a new install): not held
    code = 0.0
    for key in ("code_s", "simplify_code_s"):
        given = result.stats.get(key, 0.0)
        if not isinstance(given, numbers.Real) or not math.isfinite(given) or given < 0.0:
            raise PlannerError(f"{who} returned stats[{key!r}] = {given!r:.40}: seconds, a finite number >= 0")
        code += float(given)
    spent = time.perf_counter() - started - code
    if spent > OVERRUN_FACTOR * problem.time_limit + OVERRUN_SLACK_S:
        result.stats["overran_s"] = spent  # said by the commands (a planner that does not stop on time)
    if not result.success:
        return result
    missed = _missed(result.path, problem)
    if not missed and (where := path_collision(result.path, problem.world, problem.robot)):
        missed = f"collides {where}"
    if missed:
        reason = f"{who} reported success, but its path {missed}"
        return dataclasses.replace(result, status=PlanStatus.FAILED, reason=reason)
    return result


#: A plan whose wall time (numba's loading of its code apart) exceeds its time limit by this factor plus
#: :data:`OVERRUN_SLACK_S` is said to have overrun it (``stats["overran_s"]``, :func:`run_planner`).
OVERRUN_FACTOR = 1.25
OVERRUN_SLACK_S = 0.1

#: Largest step [m] between a path's poses as its collisions are checked (``nhsim plan`` records its paths so
#: densified, :data:`sim.cli.plan.PATH_SPACING`).
PATH_CHECK_SPACING = 0.02


def path_collision(path: FloatArray, world: World, robot: RobotSpec, name: str = "plan.path") -> str:
    """Where ``path`` (N, 3), densified to :data:`PATH_CHECK_SPACING`, first collides in ``world`` with ``robot``'s
    footprint, "" where it does not: "at (x, y, theta), plan.path[i] of its N poses, the turtlebot3's footprint
    overlaps the circle at ... by 2.1 mm" (``name`` in place of plan.path). The poses are measured by the planners'
    checker (a lower bound within its tolerance of the truth); those it finds overlapping are measured again finely
    (within 0.1 mm, as ``nhsim plan`` measures a path): milliseconds for thousands of poses."""
    from planning.collision.exact import CollisionChecker
    from planning.collision.overlap import footprint_overlap

    if path.shape[0] == 0:
        return ""
    dense = densify_path(path, PATH_CHECK_SPACING, radius=robot.radius, slack=1e-9)
    found = CollisionChecker(world, robot, shape="footprint").first_overlap(dense)
    if found is None:
        return ""
    k, depth = found
    pose = Pose2D(float(dense[k, 0]), float(dense[k, 1]), float(wrap_angle(float(dense[k, 2]))))
    hit = footprint_overlap(world, robot, pose)
    what = f"overlaps {hit[1]}" if hit is not None else "overlaps an obstacle or a wall"
    how = f" by {-1e3 * depth:.1f} mm" if np.isfinite(depth) else " (an obstacle lies inside it, or it lies in one)"
    return (
        f"at ({pose.x:.3f}, {pose.y:.3f}, {pose.theta:.3f}), {_path_place(path, dense, k, robot.radius, name)} of its "
        f"{path.shape[0]} poses, the {robot.name}'s footprint {what}{how}"
    )


def _path_place(path: FloatArray, dense: FloatArray, k: int, radius: float, name: str) -> str:
    """Where pose ``k`` of ``dense`` (``path`` densified, :func:`densify_path` with ``radius``) lies on ``path``
    (called ``name``): ``"plan.path[i]"``, or ``"between plan.path[i] and plan.path[i + 1]"`` for a pose put in
    between."""
    if dense.shape[0] == path.shape[0]:  # nothing was put in between
        return f"{name}[{k}]"
    along = np.concatenate([[0.0], np.cumsum(path_steps(path, radius))])
    at = float(np.sum(path_steps(dense[: k + 1], radius))) if k > 0 else 0.0
    nearest = int(np.argmin(np.abs(along - at)))
    if math.isclose(at, along[nearest], abs_tol=1e-9):
        return f"{name}[{nearest}]"
    i = int(np.clip(np.searchsorted(along, at, side="right") - 1, 0, path.shape[0] - 2))
    return f"between {name}[{i}] and {name}[{i + 1}]"


def _missed(path: FloatArray, problem: PlanProblem) -> str:
    """How a successful ``path`` misses its problem's start or goal ("" when it does not)."""
    start, end, goal = path[0], path[-1], problem.goal
    off = float(np.hypot(start[0] - problem.start.x, start[1] - problem.start.y))
    turned = abs(wrap_angle(float(start[2]) - problem.start.theta))
    if off > START_TOLERANCE or turned > START_TOLERANCE:
        return f"starts {off:.3g} m and {turned:.3g} rad from the start pose"
    far = float(np.hypot(end[0] - goal.x, end[1] - goal.y))
    heading = abs(wrap_angle(float(end[2]) - goal.theta))
    if far > problem.position_tolerance or heading > problem.heading_tolerance:
        return (
            f"ends {far:.3g} m and {heading:.3g} rad from the goal (its tolerances: {problem.position_tolerance:g} m, "
            f"{problem.heading_tolerance:g} rad)"
        )
    return ""
