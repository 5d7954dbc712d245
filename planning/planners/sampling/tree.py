"""Shared machinery of the random-tree planners: growable trees, setup checks, results.

A :class:`Tree` keeps its nodes in preallocated arrays (doubled when full) so nearest-neighbour
queries are one vectorised pass over all nodes. Each node stores the dense motion of its edge:
for a tree grown from the start, from the parent to the node; for a tree grown backwards from
the goal, from the node to the parent (always in the direction the robot drives).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.clock import PlanClock
from planning.collision.exact import CollisionChecker, Shape
from planning.collision.field import FieldTimeout
from planning.collision.grid import FastChecker
from planning.planners.base import PlanProblem, PlanResult, PlanStatus, PlanTree, end_outside

FloatArray = NDArray[np.float64]
Metric = Callable[[FloatArray, FloatArray], FloatArray]


@nb.njit(cache=True)
def _se2_distances(nodes: FloatArray, headings: FloatArray, n: int, q: FloatArray) -> FloatArray:
    cq, sq = np.cos(q[2]), np.sin(q[2])
    out = np.empty(n)
    for i in range(n):
        dx = nodes[i, 0] - q[0]
        dy = nodes[i, 1] - q[1]
        dc = headings[i, 0] - cq
        ds = headings[i, 1] - sq
        out[i] = np.sqrt(dx * dx + dy * dy + dc * dc + ds * ds)
    return out


@nb.njit(cache=True)
def _se2_nearest(nodes: FloatArray, headings: FloatArray, n: int, q: FloatArray) -> int:
    d = _se2_distances(nodes, headings, n, q)
    best = 0
    for i in range(1, n):
        if d[i] < d[best]:
            best = i
    return best


class Tree:
    """A search tree with array storage.

    Args:
        root: (3,) root pose.
        backwards: True for a tree grown from the goal (edges stored node -> parent).
        capacity: Initial node capacity (grows by doubling).
    """

    def __init__(self, root: FloatArray, *, backwards: bool = False, capacity: int = 1024) -> None:
        self.backwards = backwards
        self.nodes = np.empty((capacity, 3))
        self.headings = np.empty((capacity, 2))  # cos, sin of each node's heading (for the metric)
        self.parents = np.full(capacity, -1, dtype=np.int64)
        self.costs = np.zeros(capacity)
        self.edges: list[tuple[FloatArray, FloatArray]] = [(np.asarray(root, float)[None, :], np.ones(1))]
        self.children: list[list[int]] = [[]]
        self.nodes[0] = root
        self.headings[0] = np.cos(self.nodes[0, 2]), np.sin(self.nodes[0, 2])
        self.n = 1

    def add(self, q: FloatArray, parent: int, poses: FloatArray, dirs: FloatArray, cost: float = 0.0) -> int:
        """Append a node with its edge motion (K, 3) and directions (K,); returns its index."""
        if self.n == self.nodes.shape[0]:
            cap = 2 * self.n
            self.nodes = np.concatenate([self.nodes, np.empty((self.n, 3))])
            self.headings = np.concatenate([self.headings, np.empty((self.n, 2))])
            self.parents = np.concatenate([self.parents, np.full(cap - self.n, -1, dtype=np.int64)])
            self.costs = np.concatenate([self.costs, np.zeros(cap - self.n)])
        i = self.n
        self.nodes[i] = q
        self.headings[i] = np.cos(self.nodes[i, 2]), np.sin(self.nodes[i, 2])
        self.parents[i] = parent
        self.costs[i] = cost
        self.edges.append((poses, dirs))
        self.children.append([])
        self.children[parent].append(i)
        self.n += 1
        return i

    def nearest(self, q: FloatArray, metric: Metric) -> int:
        """Index of the node nearest to ``q`` under ``metric``."""
        return int(np.argmin(metric(self.nodes[: self.n], q)))

    def se2_distances(self, q: FloatArray) -> FloatArray:
        """(n,) :func:`~planning.planners.sampling.steering.se2_metric` of every node to ``q``, from the
        stored cosines and sines (the same numbers, no trigonometry per query)."""
        return _se2_distances(self.nodes, self.headings, self.n, q)

    def se2_nearest(self, q: FloatArray) -> int:
        """Index of the node nearest to ``q`` by the (x, y, cos, sin) metric (first of equals)."""
        return int(_se2_nearest(self.nodes, self.headings, self.n, q))

    def reparent(self, i: int, parent: int, poses: FloatArray, dirs: FloatArray, cost: float) -> None:
        """Give node ``i`` a new parent and edge; shifts the cost of all its descendants."""
        self.children[int(self.parents[i])].remove(i)
        self.children[parent].append(i)
        self.parents[i] = parent
        self.edges[i] = (poses, dirs)
        delta = cost - self.costs[i]
        stack = [i]
        while stack:
            k = stack.pop()
            self.costs[k] += delta
            stack.extend(self.children[k])

    def branch(self, i: int) -> tuple[FloatArray, FloatArray]:
        """Dense motion between the root and node ``i`` in driving order: root -> i for a forward
        tree, i -> root for a backwards tree. Returns (K, 3) poses and (K,) directions."""
        first = i
        chain = []
        while i > 0:
            chain.append(i)
            i = int(self.parents[i])
        if not self.backwards:
            chain.reverse()
            first = 0
        if not chain:
            return self.nodes[first][None, :].copy(), np.ones(1)
        poses = [self.nodes[first][None, :]]
        dirs = [self.edges[chain[0]][1][:1]]
        for k in chain:
            p, d = self.edges[k]
            poses.append(p[1:])
            dirs.append(d[1:])
        return np.vstack(poses), np.concatenate(dirs)

    def side(self) -> Side:
        """This tree as :func:`met_chain` reads it."""
        return self.nodes, self.parents, self.edges.__getitem__

    def plan_tree(self) -> PlanTree:
        """This tree as a :class:`PlanTree` for plotting (edge curves as (k, 2) arrays)."""
        return PlanTree(*self._drawn(0))

    def _drawn(self, offset: int) -> tuple[FloatArray, NDArray[np.int64], tuple[FloatArray, ...]]:
        """:meth:`plan_tree`'s nodes, parents (``offset`` added to each but a root's -1) and edges."""
        par = self.parents[: self.n].copy()
        par[par >= 0] += offset
        return self.nodes[: self.n].copy(), par, tuple(e[0][:, :2] for e in self.edges[1:])


#: A node of a path through a tree: its pose (3,), and the edge from the node before it, poses (K, 3) and
#: directions (K,) in driving order.
Link = tuple[FloatArray, FloatArray, FloatArray]

#: A tree as :func:`met_chain` reads it: its poses (n, 3), parents (n,) and node i's edge (poses, directions).
Side = tuple[FloatArray, NDArray[np.int64], Callable[[int], tuple[FloatArray, FloatArray]]]


def met_chain(
    start: Side, goal: Side, a: int, b: int, bridge: tuple[FloatArray, FloatArray] | None = None
) -> list[Link]:
    """The path from the start through start-tree node ``a`` and goal-tree node ``b`` to the goal as links after the
    start: the start tree's nodes from the root out, then (from ``a``'s pose to ``b``'s, by ``bridge``; None: they
    are the same pose) :func:`links_in` of the goal tree from ``b``."""
    nodes, parents, edge = start
    links: list[Link] = []
    i = a
    while i > 0:
        links.append((nodes[i], *edge(i)))
        i = int(parents[i])
    links.reverse()
    if bridge is not None:
        links.append((goal[0][b], *bridge))
    return links + links_in(goal, b)


def links_in(goal: Side, b: int) -> list[Link]:
    """The way from node ``b`` of a tree grown backwards to its root as links: each node's parent with the node's
    edge (from the node to its parent: in driving order already)."""
    nodes, parents, edge = goal
    links: list[Link] = []
    while b > 0:
        parent = int(parents[b])
        links.append((nodes[parent], *edge(b)))
        b = parent
    return links


def merge_trees(*trees: Tree) -> PlanTree:
    """Trees drawn as one :class:`PlanTree` (roots keep parent -1)."""
    drawn, offset = [], 0
    for tree in trees:
        drawn.append(tree._drawn(offset))
        offset += tree.n
    nodes, parents, edges = zip(*drawn, strict=True)
    return PlanTree(np.vstack(nodes), np.concatenate(parents), sum(edges, ()))


#: The share of a tree planner's time limit between readings of its clock (:meth:`Budget.spent`).
CHECK_SHARE = 0.005
#: The share of its budget (time or iterations) a tree planner spends without a path before it tries to prove
#: the goal walled off (:attr:`Budget.proof`): a plan that finds its path sooner never pays for the proof.
PROOF_AFTER = 0.25


@dataclass
class Budget:
    """Iteration and time budget of one planning run (the time limit counts planning, not numba readying
    the code: :class:`planning.clock.PlanClock`)."""

    max_iterations: int
    time_limit: float
    clock: PlanClock = field(init=False, repr=False)
    grid_s: float = 0.0  # of the time spent, getting the collision grid [s]
    planner: str = ""  # the planner's registered name, for the advice of :meth:`why`
    #: The first iteration at which :meth:`spent` reads the clock again.
    next_check: int = field(default=0, init=False)
    _last: tuple[int, float] = field(default=(0, 0.0), init=False, repr=False)  # iteration, time of the last reading
    #: Tried once, with the deadline, when :data:`PROOF_AFTER` of the budget is spent and the planner has not
    #: cleared it (set to None on its first path): why the goal is walled off, or None when that is not proved.
    proof: Callable[[float], str | None] | None = field(default=None, repr=False)
    #: What :attr:`proof` proved: the run ends there, :attr:`status` INFEASIBLE.
    walled: str | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        if self.max_iterations < 1:
            raise ValueError(f"max_iterations must be >= 1, got {self.max_iterations}")
        if not self.time_limit > 0:
            raise ValueError(f"time_limit must be > 0 s, got {self.time_limit}")
        self.clock = PlanClock(self.time_limit)

    @property
    def deadline(self) -> float:
        """``time.perf_counter()`` value at which the time limit is spent (as of now)."""
        return self.clock.deadline()

    def elapsed(self) -> float:
        """Seconds since the budget started (the code's readying included)."""
        return self.clock.elapsed()

    def spent(self, iteration: int) -> bool:
        """Whether iteration ``iteration`` (0-based; the loop's count, which only grows) may not run.

        The clock is read at :attr:`next_check` and then about every :data:`CHECK_SHARE` of the time limit
        by the iterations' pace so far (every 4 iterations at first, at most every 256): a world of thousands of
        obstacles, where an iteration takes milliseconds, is checked at every iteration, an open one in bulk.
        With a fixed 16 iterations between readings, 0.25 s limits in a 3000-obstacle world ended up to 1.5x late.
        """
        if iteration >= self.max_iterations:
            return True
        if iteration < self.next_check:
            return False
        if self.clock.expired():
            return True
        now = self.clock.elapsed()
        late = PROOF_AFTER * self.time_limit  # the working time counts; it is at most ``now``, read already
        if self.proof is not None and (
            iteration >= PROOF_AFTER * self.max_iterations or (now >= late and self.clock.working() >= late)
        ):
            return self._try_proof()
        done, then = self._last
        stride = 4
        if iteration > done and now > then:
            pace = (iteration - done) / (now - then)  # iterations a second
            stride = int(min(pace * CHECK_SHARE * self.time_limit, 2 * (iteration - done), 256))
        self.next_check = iteration + max(stride, 1)
        self._last = (iteration, now)
        return False

    def _try_proof(self) -> bool:
        """Run :attr:`proof` (once) within the time limit: whether the run ends (the goal proved walled off, or the
        limit passed while proving)."""
        proof, self.proof = self.proof, None
        assert proof is not None
        try:
            self.walled = proof(self.deadline)
        except FieldTimeout:
            return True
        return self.walled is not None or self.clock.expired()

    @property
    def status(self) -> PlanStatus:
        """How a run that spent this budget without a path ends: INFEASIBLE when :attr:`proof` proved the goal walled
        off, else TIMEOUT."""
        return PlanStatus.INFEASIBLE if self.walled is not None else PlanStatus.TIMEOUT

    def why(self, iteration: int) -> str:
        """Which budget ended the run; for the iteration budget, with time left, what more time would take; the
        proof, when the goal was proved walled off."""
        if self.walled is not None:
            return f"{self.walled} (proved after {iteration} iterations)"
        if iteration < self.max_iterations:
            return f"time budget of {self.time_limit:g} s spent after {iteration} iterations"
        said = f"iteration budget of {self.max_iterations} spent"
        if self.clock.remaining() < 0.1 * self.time_limit:
            return said
        table = f"[planners.{self.planner}]" if self.planner else "[planners.NAME]"
        return (
            f"{said} in {self.clock.working():.2g} s of the {self.time_limit:g} s time limit (a larger max_iterations "
            f"in a {table} table of the scenario, or another seed, may find a path)"
        )


def walled_off_proof(problem: PlanProblem, shape: Shape, clearance: float) -> Callable[[float], str | None]:
    """A tree planner's :attr:`Budget.proof`: by the deadline given, why no collision-free path reaches the goal,
    when a 2-D search proves it for the robot's inscribed disc (:func:`planning.core.robot.inscribed_radius`) kept
    ``clearance`` off everything (:func:`planning.planners.geodesic.walled_off_reason`), else None."""

    def prove(deadline: float) -> str | None:
        from planning.core.robot import inscribed_radius
        from planning.planners.geodesic import walled_off_reason

        disc = inscribed_radius(problem.robot, shape)
        return walled_off_reason(
            problem.world,
            (problem.start.xy, problem.goal.xy),
            disc + clearance,
            deadline,
            problem.position_tolerance,
            keeps=f"the robot's inscribed disc (radius {disc:.3f} m, within every pose's footprint) and the clearance "
            f"({clearance:g} m)",
            fix="move the goal or the start, or open a way to it",
        )

    return prove


def make_checker(problem: PlanProblem, shape: Shape, clearance: float, deadline: float | None = None) -> FastChecker:
    """The shared collision checker for a problem, with its fast exact front end, its grid built by
    ``deadline`` (a ``time.perf_counter()`` value; None: no limit).

    Raises:
        planning.collision.field.FieldTimeout: The grid was not built by ``deadline``.
    """
    exact = CollisionChecker(problem.world, problem.robot, shape=shape, clearance=clearance)
    return FastChecker(exact, deadline=deadline)


def grid_timeout(planner: str, exc: FieldTimeout) -> PlanResult:
    """The TIMEOUT result of a run whose time limit passed while its collision grid was built."""
    grid_s = exc.seconds - exc.code_s  # as FastChecker.grid_seconds: the code's readying left out
    stats = {"time_s": exc.seconds, "grid_s": grid_s, "code_s": exc.code_s, "iterations": 0, "nodes": 0}
    return PlanResult(PlanStatus.TIMEOUT, planner, reason=str(exc), stats=stats)


def check_endpoints(problem: PlanProblem, checker: FastChecker, planner: str) -> PlanResult | None:
    """An INVALID_START / INVALID_GOAL result if the start or goal pose lies outside the world or collides, else
    None."""
    outside = end_outside(problem, planner)
    if outside is not None:
        return outside
    ends = np.array([problem.start.as_array(), problem.goal.as_array()])
    free = checker.poses_free(ends)  # both in one call
    for which, q, ok, status in (
        ("start", ends[0], free[0], PlanStatus.INVALID_START),
        ("goal", ends[1], free[1], PlanStatus.INVALID_GOAL),
    ):
        if not ok:
            clr = float(checker.clearance_of(q[None, :])[0])
            pose = f"{which} pose ({q[0]:.3f}, {q[1]:.3f}, {q[2]:.3f})"
            if np.isfinite(clr):
                said = f"clearance {clr:.3f} m, a lower bound"
            else:  # -inf: an obstacle has a point inside the footprint (a pixel of a noisy map under the robot)
                said = "an obstacle lies inside the robot's footprint, or the footprint inside an obstacle"
            reason = (
                f"{pose} is in collision or closer than the "
                f"required clearance {checker.checker.clearance:g} m ({said}, "
                f"{checker.checker.shape} model): move the {which} or lower the clearance"
            )
            return PlanResult(status, planner, reason=reason)
    return None


def draws(problem: PlanProblem) -> np.random.Generator:
    """The run's random generator, seeded by ``problem.seed`` (same seed, same plan). A search makes it
    when it first needs one: a plan that one curve solves does not pay its set-up (about 8 us, a tenth
    of such a plan)."""
    return np.random.default_rng(problem.seed)


def sample_pose(rng: np.random.Generator, bounds: tuple[float, float, float, float]) -> FloatArray:
    """A uniform pose in the bounds with a uniform heading in [-pi, pi)."""
    u = rng.random(3)
    return np.array(
        [bounds[0] + u[0] * (bounds[1] - bounds[0]), bounds[2] + u[1] * (bounds[3] - bounds[2]), np.pi * (2 * u[2] - 1)]
    )


def in_goal(q: FloatArray, problem: PlanProblem) -> bool:
    """Whether pose ``q`` lies inside the problem's goal tolerance."""
    g = problem.goal.as_array()
    dth = (q[2] - g[2] + np.pi) % (2 * np.pi) - np.pi
    return bool(
        np.hypot(q[0] - g[0], q[1] - g[1]) <= problem.position_tolerance and abs(dth) <= problem.heading_tolerance
    )


#: :func:`goal_region_poses`: positions on the region's rim and headings at its edges and centre.
REGION_ANGLES, REGION_HEADINGS = 12, 3
#: How far inside the region's edges those poses lie (a fraction of each tolerance), against rounding.
REGION_INSET = 1e-3


def goal_region_poses(problem: PlanProblem) -> FloatArray:
    """(K, 3) poses spread over the goal region, the goal pose first: for each of ``REGION_HEADINGS``
    headings evenly over the heading tolerance (its edges and the goal's own), the goal position and
    ``REGION_ANGLES`` positions on the rim of the position tolerance, all ``REGION_INSET`` inside the
    region. The shortest curve into the region ends on its rim and at a heading edge on most problems,
    so the shortest curve to one of these poses is within 2 mm of the region's shortest (0.4 mm in the
    median over 300 random starts, against a grid of 60,000 poses of the region; tested).
    ``rrt-star`` with ``region_goal`` aims its goal connections at them, and the OMPL race gives OMPL's
    optimal planners the same poses as their goal samples.
    """
    g = problem.goal.as_array()
    r = problem.position_tolerance * (1.0 - REGION_INSET)
    a = 2.0 * np.pi * np.arange(REGION_ANGLES) / REGION_ANGLES
    rim = np.column_stack([r * np.cos(a), r * np.sin(a)])
    offsets = np.vstack([np.zeros((1, 2)), rim])
    headings = problem.heading_tolerance * (1.0 - REGION_INSET) * np.linspace(-1.0, 1.0, REGION_HEADINGS)
    headings = headings[np.argsort(np.abs(headings), kind="stable")]  # the goal's heading first
    out = np.array([[g[0] + dx, g[1] + dy, g[2] + h] for h in headings for dx, dy in offsets])
    out[:, 2] = (out[:, 2] + np.pi) % (2.0 * np.pi) - np.pi
    out[0] = g
    return out


def goal_gap(nodes: FloatArray, problem: PlanProblem) -> FloatArray:
    """(N,) position distance of nodes to the goal [m]."""
    g = problem.goal.as_array()
    return np.hypot(nodes[:, 0] - g[0], nodes[:, 1] - g[1])  # type: ignore[no-any-return]
