"""RRT (the TurtleBot planning report) and bidirectional RRT with a connect step (the fruit-farm report).

``rrt``: goal bias 0.05, nearest node by the (x, y, cos theta, sin theta) metric, extension by the
motion primitive whose end lands closest to the sample (the 60 bicycle primitives by default);
once a new node comes within ``goal_connect_radius`` of the goal, an exact Reeds–Shepp (or Dubins)
curve to the goal is tried as the final plan (the TurtleBot planning report, step 8).

``birrt``: two trees, one from the start and one grown backwards from the goal, alternately
extended toward uniform samples; after each extension the other tree runs a connect step toward
the new node (repeated extensions until reached or blocked). With exact curves the trees meet at
a shared pose, the connect step's last extension ending on the node (as OMPL's RRTConnect: no curve
across a longer gap is tried, which would be checked along its whole length); with primitives they
join by an exact curve once within ``goal_connect_radius``.
Every joining curve runs from the start-tree node to the goal-tree node (never reversed), so a
Dubins join cannot turn into a reversed, infeasible U-turn. The fruit-farm report's default: 5000
samples with the unicycle primitives.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from planning.clock import PlanClock
from planning.collision.field import FieldTimeout
from planning.core.checks import FLAG, check_fields
from planning.core.geometry import path_length, wrap_angle
from planning.errors import ConfigError
from planning.planners import geodesic
from planning.planners.base import PlanProblem, PlanResult, PlanStatus, PlanTree, checked_problem
from planning.planners.registry import config_from_options
from planning.planners.sampling.connect_kernel import CHUNK_DONE, IN_REGION, JOINED, CompiledSearch
from planning.planners.sampling.extend import LocalPlanner, Motion, check_steering
from planning.planners.sampling.steering import MAX_TURNING_RADIUS, MIN_TURNING_RADIUS
from planning.planners.sampling.tree import (
    Budget,
    Link,
    Tree,
    check_endpoints,
    draws,
    goal_gap,
    grid_timeout,
    in_goal,
    make_checker,
    merge_trees,
    met_chain,
    sample_pose,
    walled_off_proof,
)
from planning.planners.simplify import DirectedLength, SimplifyConfig, length_cost, simplify_path

FloatArray = NDArray[np.float64]


#: Most bicycle primitive speeds per steering class: every primitive is simulated when the planner is made
#: (100000 took 26 s, outside any time limit).
MAX_SPEEDS = 1000
#: Longest bicycle primitive [s] (a primitive is sampled every centimetre of its motion).
MAX_PRIMITIVE_DURATION = 60.0


@dataclass(frozen=True)
class TreeConfig:
    """Options shared by the tree planners (keyword-only at the factories).

    Attributes:
        steering: "bicycle", "unicycle", "diffdrive", "reeds_shepp" or "dubins".
        goal_bias: Probability of sampling the goal pose.
        max_iterations: Iteration (sample) budget.
        time_limit: Wall-clock budget [s]; None takes the problem's.
        turning_radius: Radius of the exact curves [m]; None: wheelbase / tan(max_steering).
        step_range: Longest exact-curve extension [m]; None: 0.2 x the bounds' diagonal.
        goal_connect_radius: Try an exact curve to the goal (or the other tree) when this close in
            the (x, y, cos, sin) metric.
        n_speeds: Bicycle primitive speeds per steering class.
        primitive_duration: Bicycle primitive and diff-drive drive duration [s].
        shape: Collision model, "footprint" or "disc".
        clearance: Margin every pose must keep from obstacles and walls [m] (simulate jobs
            plan with 1 cm, :class:`sim.pipeline.case.PlanOptions`).
        simplify: Return the path simplified with the exact curves (shortcuts, vertex reduction:
            :func:`planning.planners.simplify.simplify_path`, seeded by the problem's seed); False
            returns the search's raw path. A successful plan's stats report both lengths and cusps.
    """

    steering: str = "bicycle"
    goal_bias: float = 0.05
    max_iterations: int = 20000
    time_limit: float | None = None
    turning_radius: float | None = None
    step_range: float | None = None
    goal_connect_radius: float = 1.0
    n_speeds: int = 20
    primitive_duration: float = 1.0
    shape: str = "footprint"
    clearance: float = 0.0
    simplify: bool = True

    def __post_init__(self) -> None:
        checks: dict[str, Mapping[str, Any]] = {
            "goal_bias": {"at_least": 0.0, "at_most": 1.0},
            "max_iterations": {"integer": True, "at_least": 1},
            "time_limit": {"above": 0.0, "optional": True},
            "turning_radius": {
                "at_least": MIN_TURNING_RADIUS,
                "at_most": MAX_TURNING_RADIUS,
                "optional": True,
                "unit": "m",
            },
            "step_range": {"above": 0.0, "optional": True},
            "goal_connect_radius": {"above": 0.0},
            "n_speeds": {"integer": True, "at_least": 1, "at_most": MAX_SPEEDS},
            "primitive_duration": {"above": 0.0, "at_most": MAX_PRIMITIVE_DURATION},
            "clearance": {"at_least": 0.0},
            "simplify": FLAG,
        }
        check_fields(self, checks)
        check_steering(self.steering)
        if self.shape not in ("footprint", "disc"):
            raise ConfigError(f"shape must be 'footprint' or 'disc', got {self.shape!r}")


ConfigT = TypeVar("ConfigT", bound=TreeConfig)


class _TreePlanner(Generic[ConfigT]):
    """What the tree planners share: options into ``config_class``, setup, sampling, results."""

    name = "tree"
    config_class: type[ConfigT]

    def __init__(self, **options: object) -> None:
        self.config: ConfigT = config_from_options(self.config_class, options)
        self._locals: dict[tuple[int, int, int], tuple[object, object, LocalPlanner]] = {}

    def plan(self, problem: PlanProblem) -> PlanResult:
        """Plan from ``problem.start`` to ``problem.goal``; never raises for an unsolvable problem."""
        problem = checked_problem(problem)
        try:
            local, budget, bad = self._setup(problem)
        except FieldTimeout as exc:  # the time limit passed while the collision grid was built
            return grid_timeout(self.name, exc)
        if bad is not None:
            return bad
        result = self._search(problem, local, budget)
        if self.config.simplify and result.success:
            return simplified(result, local, problem.seed, clock=budget.clock)
        return result

    def _search(self, problem: PlanProblem, local: LocalPlanner, budget: Budget) -> PlanResult:
        """The planner's own search, once the end poses are known to be free (its random generator
        :func:`draws` made when it first needs one)."""
        raise NotImplementedError

    def _setup(self, problem: PlanProblem) -> tuple[LocalPlanner, Budget, PlanResult | None]:
        """The run's local planner and budget, and an INVALID_START / INVALID_GOAL result when an end
        pose collides (else None)."""
        cfg = self.config
        limit = cfg.time_limit if cfg.time_limit is not None else problem.time_limit
        budget = Budget(cfg.max_iterations, limit, planner=self.name)
        budget.proof = walled_off_proof(problem, cfg.shape, cfg.clearance)  # type: ignore[arg-type]
        local = self._local_planner(problem, budget)
        return local, budget, check_endpoints(problem, local.checker, self.name)

    def _local_planner(self, problem: PlanProblem, budget: Budget) -> LocalPlanner:
        """The local planner (steering and checker) for the problem's world and robot: the last one
        built by this thread when it was for the very same world and robot objects (a planner run
        over many seeds of one problem builds it once), else a new one, its collision grid built
        within ``budget`` (its time in ``budget.grid_s``)."""
        key = (id(problem.world), id(problem.robot), threading.get_ident())
        cached = self._locals.get(key)
        if cached is not None and cached[0] is problem.world and cached[1] is problem.robot:
            return cached[2]
        cfg = self.config
        checker = make_checker(problem, cfg.shape, cfg.clearance, budget.deadline)  # type: ignore[arg-type]
        budget.grid_s = checker.grid_seconds  # the grid counts against the time limit
        w = problem.world
        step_range = cfg.step_range if cfg.step_range is not None else 0.2 * float(np.hypot(w.width, w.height))
        local = LocalPlanner(
            cfg.steering,
            problem.robot,
            checker,
            rho=cfg.turning_radius,
            step_range=step_range,
            n_speeds=cfg.n_speeds,
            primitive_duration=cfg.primitive_duration,
        )
        self._locals = {key: (problem.world, problem.robot, local)}  # one entry: the last problem's
        return local

    def _extend_toward_sample(
        self, rng: np.random.Generator, tree: Tree, local: LocalPlanner, problem: PlanProblem
    ) -> tuple[int, Motion] | None:
        """One goal-biased sample, the tree's nearest node to it, and the motion from there toward it
        (None when every motion collides)."""
        q_rand = biased_sample(rng, problem.goal.as_array(), problem, self.config.goal_bias)
        i = local.nearest(tree, q_rand)
        ext = local.extend(tree.nodes[i], q_rand, tree=tree)
        return None if ext is None else (i, ext)

    @staticmethod
    def _stats(budget: Budget, iterations: int, nodes: int) -> dict[str, object]:
        clock = budget.clock
        return {"time_s": clock.elapsed(), "code_s": clock.code(), "grid_s": budget.grid_s,
                "iterations": iterations, "nodes": nodes}  # fmt: skip

    @staticmethod
    def _partial(tree: Tree, problem: PlanProblem) -> tuple[FloatArray, FloatArray, float]:
        """The branch to the node nearest the goal: poses (K, 3), directions (K,) and its gap [m]."""
        gaps = goal_gap(tree.nodes[: tree.n], problem)
        best = int(np.argmin(gaps))
        path, dirs = tree.branch(best)
        return path, dirs, float(gaps[best])

    def _result(
        self,
        status: PlanStatus,
        poses: FloatArray,
        dirs: FloatArray,
        reason: str,
        stats: Mapping[str, object],
        tree: PlanTree,
    ) -> PlanResult:
        stats = {**stats, "length_m": path_length(poses)}
        return PlanResult(status, self.name, path=poses, reason=reason, stats=stats, tree=tree, directions=dirs)


def biased_sample(rng: np.random.Generator, target: FloatArray, problem: PlanProblem, bias: float) -> FloatArray:
    """``target`` with probability ``bias``, else a uniform pose in the world (:func:`.tree.sample_pose`)."""
    return target if rng.random() < bias else sample_pose(rng, problem.world.bounds)


def simplified(
    result: PlanResult, local: LocalPlanner, seed: int, reverse_weight: float = 1.0, clock: PlanClock | None = None
) -> PlanResult:
    """A successful tree plan with its path simplified by the local planner's exact curves
    (the raw path kept in ``raw_path``; stats gain the raw and simplified lengths and cusps). Its cost
    is the x-y length, each backwards metre counted ``reverse_weight`` (>= 1) times
    (:class:`planning.planners.simplify.DirectedLength`: a planner that prices reversing keeps its price).
    With the planner's ``clock``, within what is left of its time limit (the path as far as it got when
    the limit passes, ``stats["simplify_time_limit_reached"]``)."""
    config = SimplifyConfig(turn_stretches=local.curves.kind == "reeds_shepp")  # Dubins cars drive forwards only
    deadline = (lambda: None) if clock is None else clock.deadline
    s = simplify_path(
        result.path,
        result.directions,
        local.steer,
        local.checker.path_free,
        cost=length_cost if reverse_weight == 1.0 else DirectedLength(reverse_weight),
        distance=local.curves.lengths,
        routes=lambda: curve_routes(local, result.path[0], result.path[-1], deadline()),
        config=config,
        seed=seed,
        deadline=deadline(),
    )
    stats = {**result.stats, **s.stats()}
    return dataclasses.replace(result, path=s.path, directions=s.directions, raw_path=result.path, stats=stats)


#: Margins the 2-D route keeps beyond the robot's circumscribed radius and clearance (room for the arcs
#: that round its corners, :func:`planning.planners.geodesic.curve_waypoints`), and, where no such
#: route exists, beyond the footprint's half-width and clearance (what a robot driving along it sweeps) [m].
ROUTE_MARGINS = (0.05, 0.02)


def curve_routes(
    local: LocalPlanner, start: FloatArray, goal: FloatArray, deadline: float | None = None
) -> list[FloatArray]:
    """Waypoints along the obstacle-aware 2-D route from ``start`` to ``goal`` for the local planner's
    curves (:mod:`planning.planners.geodesic`): the route of a disc of the robot's circumscribed
    radius plus the clearance and ``ROUTE_MARGINS[0]``, else of its half-width plus the clearance and
    ``ROUTE_MARGINS[1]``; none when neither route exists. ``deadline``: as :func:`planning.planners.geodesic.route`'s.

    Raises:
        planning.collision.field.FieldTimeout: ``time.perf_counter()`` passed ``deadline``.
    """
    chk = local.checker.checker
    half_width = chk.robot.radius if chk.shape == "disc" else float(np.max(np.abs(chk.robot.footprint[:, 1])))
    assert local.rho is not None
    for size, margin in zip((chk.robot.radius, half_width), ROUTE_MARGINS, strict=True):
        vertices = geodesic.route(chk.world, start, goal, size + chk.clearance + margin, deadline=deadline)
        if vertices is not None:
            return [geodesic.curve_waypoints(vertices, local.rho)]
    return []


class RRT(_TreePlanner[TreeConfig]):
    """The TurtleBot planning report's goal-biased RRT with motion primitives (see the module doc)."""

    name = "rrt"
    config_class = TreeConfig

    def _search(self, problem: PlanProblem, local: LocalPlanner, budget: Budget) -> PlanResult:
        """Grow a tree from the start until a node reaches the goal or the budget is spent."""
        boxed = boxed_in(self.name, local, problem, self._stats(budget, 0, 1), ("start",))
        if boxed is not None:
            return boxed
        rng = draws(problem)
        goal = problem.goal.as_array()
        tree = Tree(problem.start.as_array())
        it = 0
        while not budget.spent(it):
            it += 1
            step = self._extend_toward_sample(rng, tree, local, problem)
            if step is None:
                continue
            i, (q_new, poses, dirs) = step
            j = tree.add(q_new, i, poses, dirs)
            done = in_goal(q_new, problem)
            if not done and local.metric(q_new[None, :], goal)[0] <= self.config.goal_connect_radius:
                final = local.connect(q_new, goal)
                if final is not None:
                    j = tree.add(goal.copy(), j, *final)
                    done = True
            if done:
                path, d = tree.branch(j)
                stats = self._stats(budget, it, tree.n)
                return self._result(PlanStatus.SUCCESS, path, d, "", stats, tree.plan_tree())
        path, d, gap = self._partial(tree, problem)
        turn = abs(wrap_angle(float(path[-1, 2]) - problem.goal.theta))
        reason = (
            f"{budget.why(it)}; partial path to the node nearest the goal ({gap:.3f} m away, its heading "
            f"{turn:.2f} rad off the goal's)"
        )
        return self._result(budget.status, path, d, reason, self._stats(budget, it, tree.n), tree.plan_tree())


def boxed_in(
    planner: str, local: LocalPlanner, problem: PlanProblem, stats: dict[str, object], roots: tuple[str, ...]
) -> PlanResult | None:
    """The INFEASIBLE result of a search whose trees cannot grow: every motion primitive from each of its ``roots``
    ("start", and for a tree grown back from it "goal") collides, so no number of iterations or seed finds a path
    (the search spent its whole budget with the roots alone); None when one of them can grow."""
    ends = {"start": (problem.start, False), "goal": (problem.goal, True)}
    if not all(local.boxed_in(ends[r][0].as_array(), ends[r][1]) for r in roots):
        return None
    which = " and ".join(roots)
    reason = (
        f"every one of the {local.primitives} {local.steering} motion primitives from the {which} collides, so the "
        f"tree{'s' if len(roots) > 1 else ''} cannot grow: plan with steering='reeds_shepp' (exact curves of any "
        "length, --planner-option steering=reeds_shepp), or another planner (hybrid-a-star, rrt-star)"
    )
    return PlanResult(PlanStatus.INFEASIBLE, planner, reason=reason, stats=stats)


def _closer(local: LocalPlanner, tree: Tree, k: int, before: int, target: FloatArray) -> bool:
    """Whether node ``k`` of ``tree`` is nearer ``target`` than node ``before`` (the local planner's metric).
    A connect step of motion primitives that is not has stopped making progress: RRT-Connect's
    "trapped". Without this stop the greedy steps went on turning back and forth (the fruit-farm
    report's primitives turn 0.15 rad per 0.15 m), and the trees' paths grew to hundreds of metres
    of shuffling: 1915 m and 2528 cusps for a 10 m way through two offset doors, 3.6 s to plan; 22 m
    and 0.17 s with it."""
    pair = np.stack([tree.nodes[k], tree.nodes[before]])
    d = local.metric(pair, target)
    return bool(d[0] < d[1])


@dataclass(frozen=True)
class BiRRTConfig(TreeConfig):
    """:class:`TreeConfig` with the fruit-farm report's defaults: unicycle primitives, 5000 samples, no goal bias.

    Attributes:
        connect_steps: Longest connect step (extensions of the other tree toward the new node).
        direct_curve: First try the exact curve from the start to the goal (a plan it solves grows no tree);
            False grows the trees from the first iteration, as the fruit-farm report's planner did.
    """

    steering: str = "unicycle"
    goal_bias: float = 0.0
    max_iterations: int = 5000
    connect_steps: int = 50
    direct_curve: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        check_fields(self, {"connect_steps": {"integer": True, "at_least": 1}, "direct_curve": FLAG})
        if self.steering == "diffdrive":  # refused whatever the world (a plan one curve solved took it before)
            raise ConfigError(
                "birrt cannot steer by 'diffdrive': the least-squares drive grows forward trees only, and birrt's "
                "goal tree grows backwards; use it with 'rrt', or give birrt 'unicycle', 'bicycle', 'reeds_shepp' "
                "or 'dubins'"
            )


class BiRRT(_TreePlanner[BiRRTConfig]):
    """Bidirectional RRT with a connect step (see the module doc)."""

    name = "birrt"
    config_class = BiRRTConfig

    def _search(self, problem: PlanProblem, local: LocalPlanner, budget: Budget) -> PlanResult:
        """The direct curve when it is free (``direct_curve``), else both trees grown until they join or the
        budget is spent (:func:`meet`)."""
        cfg = self.config
        joined = self._joined_roots(problem, local, budget)
        if joined is not None:
            return joined
        if not compiled(local):
            boxed = boxed_in(self.name, local, problem, self._stats(budget, 0, 2), ("start", "goal"))
            if boxed is not None:
                return boxed
        rng = draws(problem)  # after the direct curve, which needs none (a plan it solves does not pay for one)
        met = meet(problem, local, budget, rng, cfg, cfg.connect_steps)
        stats = self._stats(budget, met.iterations, met.nodes)
        if met.joined:
            path, dirs = met.path()
            return self._result(PlanStatus.SUCCESS, path, dirs, "", stats, met.plan_tree())
        path, d, _ = self._partial(met.trees()[0], problem)
        reason = f"{budget.why(met.iterations)}; the trees did not meet (partial path from the start tree)"
        return self._result(budget.status, path, d, reason, stats, met.plan_tree())

    def _joined_roots(self, problem: PlanProblem, local: LocalPlanner, budget: Budget) -> PlanResult | None:
        """The plan when one exact curve joins the start and the goal (the trees are then just their
        roots), else None (and without ``direct_curve``)."""
        if not self.config.direct_curve:
            return None
        start, goal = problem.start.as_array(), problem.goal.as_array()
        direct = local.connect(start, goal)
        if direct is None:
            return None
        roots = PlanTree(np.array([start, goal]), np.array([-1, -1], dtype=np.int64))
        return self._result(PlanStatus.SUCCESS, direct[0], direct[1], "", self._stats(budget, 0, 2), roots)


@dataclass(frozen=True)
class Meeting:
    """birrt's two trees as its search (:func:`meet`) left them.

    Attributes:
        iterations: Iterations run.
        nodes: Nodes of both trees.
        joined: Whether a path was found: the trees met, or (with ``region``) a start-tree node landed in the
            goal region.
        goal_tree: Whether that path runs through the goal tree (False: it ends in the region).
        path: Once joined, the poses (K, 3) and directions (K,) from the start to the path's end.
        chain: Once joined, the same path as the nodes after the start, each with its edge (:data:`Link`).
        plan_tree: Both trees drawn as one.
        trees: The start and goal trees.
    """

    iterations: int
    nodes: int
    joined: bool
    goal_tree: bool
    path: Callable[[], tuple[FloatArray, FloatArray]]
    chain: Callable[[], list[Link]]
    plan_tree: Callable[[], PlanTree]
    trees: Callable[[], tuple[Tree, Tree]]


def compiled(local: LocalPlanner) -> bool:
    """Whether :func:`meet` runs compiled (:mod:`.connect_kernel`): exact curves, a checker with walls."""
    return local.exact and local.check_arrays is not None


def meet(
    problem: PlanProblem,
    local: LocalPlanner,
    budget: Budget,
    rng: np.random.Generator,
    cfg: TreeConfig,
    connect_steps: int,
    done: int = 0,
    region: bool = False,
) -> Meeting:
    """Grow birrt's two trees (see the module doc) until they meet or ``budget`` is spent, drawing from ``rng`` and
    sampling the other tree's root with ``cfg.goal_bias``, connect steps of at most ``connect_steps`` extensions:
    compiled on exact curves (:mod:`.connect_kernel`, the same trees and path as :func:`_meet_python`), else in
    Python. ``done``: the run's iterations before (the budget counts them, and the meeting's after them);
    ``region``: a start-tree node landing in the goal region ends the search too, the path ending on it."""
    if not compiled(local):
        return _meet_python(problem, local, budget, rng, cfg, connect_steps, done, region)
    chk = local.check_arrays
    assert chk is not None and local.rho is not None
    geometry = (local.rho, local.sample_step, local.step_range)
    rs = local.curves.kind == "reeds_shepp"
    search = CompiledSearch(chk, rs, geometry, problem, cfg.goal_bias, connect_steps, region)
    what, a, b = -1, 0, 0
    while what not in (JOINED, IN_REGION) and not budget.spent(done + search.iterations):
        what, a, b = search.run(rng, min(budget.next_check, budget.max_iterations) - done, budget.deadline)
        if what == CHUNK_DONE and budget.clock.expired():  # stopped at the deadline (numba's readying left out)
            break
    its, n = done + search.iterations, search.nodes
    if what not in (JOINED, IN_REGION):
        return Meeting(its, n, False, False, _unmet, _unmet, search.plan_tree, search.trees)
    path = lambda: search.path(a, b)
    chain = lambda: met_chain(*search.sides(), a, b)
    return Meeting(its, n, True, what == JOINED, path, chain, search.plan_tree, search.trees)


def _unmet() -> Any:
    raise ValueError("the trees did not meet: there is no path through them")


def _meet_python(
    problem: PlanProblem,
    local: LocalPlanner,
    budget: Budget,
    rng: np.random.Generator,
    cfg: TreeConfig,
    steps: int,
    done: int,
    region: bool,
) -> Meeting:
    """:func:`meet`, one Python step at a time."""
    start, goal = problem.start.as_array(), problem.goal.as_array()
    ta, tb = Tree(start), Tree(goal, backwards=True)
    it = done
    while not budget.spent(it):
        it += 1
        grow, other = (ta, tb) if (it - done) % 2 else (tb, ta)
        q_rand = biased_sample(rng, goal if grow is ta else start, problem, cfg.goal_bias)
        j = _grow(local, grow, local.nearest(grow, q_rand), q_rand)
        if j is None:
            continue
        if region and grow is ta and in_goal(ta.nodes[j], problem):
            return _met(ta, tb, j, 0, None, it, through_goal_tree=False)
        target = grow.nodes[j]
        k = local.nearest(other, target)
        for _ in range(steps):
            a, b = (j, k) if grow is ta else (k, j)
            if local.exact and np.array_equal(ta.nodes[a], tb.nodes[b]):
                return _met(ta, tb, a, b, None, it)
            if not local.exact and local.metric(ta.nodes[a][None, :], tb.nodes[b])[0] <= cfg.goal_connect_radius:
                bridge = local.connect(ta.nodes[a], tb.nodes[b])
                if bridge is not None:
                    return _met(ta, tb, a, b, bridge, it)
            k_new = _grow(local, other, k, target)
            if k_new is None:
                break
            if region and other is ta and in_goal(ta.nodes[k_new], problem):
                return _met(ta, tb, k_new, 0, None, it, through_goal_tree=False)
            k, k_old = k_new, k
            if not local.exact and not _closer(local, other, k, k_old, target):
                break  # primitives that no longer close in on the target shuffle in place: trapped
    return Meeting(it, ta.n + tb.n, False, False, _unmet, _unmet, lambda: merge_trees(ta, tb), lambda: (ta, tb))


def _grow(local: LocalPlanner, tree: Tree, i: int, target: FloatArray) -> int | None:
    """Extend ``tree`` from node ``i`` toward ``target``: the new node, or None when the motion collides."""
    ext = local.extend(tree.nodes[i], target, backwards=tree.backwards, tree=tree)
    if ext is None:
        return None
    return tree.add(ext[0], i, ext[1], ext[2])


def _met(
    ta: Tree,
    tb: Tree,
    a: int,
    b: int,
    bridge: tuple[FloatArray, FloatArray] | None,
    it: int,
    through_goal_tree: bool = True,
) -> Meeting:
    """The meeting of start-tree node ``a`` and goal-tree node ``b``, joined by ``bridge`` (None: the same pose), or
    (not ``through_goal_tree``) start-tree node ``a`` in the goal region (``b`` 0)."""

    def path() -> tuple[FloatArray, FloatArray]:
        pa, da = ta.branch(a)
        pb, db = tb.branch(b)
        parts_p, parts_d = [pa], [da]
        if bridge is not None:
            parts_p.append(bridge[0][1:])
            parts_d.append(bridge[1][1:])
        parts_p.append(pb[1:])
        parts_d.append(db[1:])
        return np.vstack(parts_p), np.concatenate(parts_d)

    chain = lambda: met_chain(ta.side(), tb.side(), a, b, bridge)
    drawn = lambda: merge_trees(ta, tb)
    return Meeting(it, ta.n + tb.n, True, through_goal_tree, path, chain, drawn, lambda: (ta, tb))
