"""RRT* with exact steering (the parking-lot report): choose-parent and rewire along Reeds–Shepp (or Dubins) curves.

The parking-lot report raced RRT* against RRT with one drive policy, wheel speeds fitted by least squares toward
the sample and driven 1 s (``steering="diffdrive"`` here, with its (x, y, theta) metric). That drive reaches, from a
node, only the poses of the arcs its two wheel speeds draw (a 2-D family in the 3-D pose space), so the curve from a
new node to a neighbour's pose that choosing a parent and rewiring need ends on that pose only by chance: this RRT*
steers by exact curves instead, and ``diffdrive`` is refused (``rrt`` takes it).

Every edge is the exact shortest curve from its parent's pose to its node's pose, stored densely.
A node's pose never changes; rewiring replaces only the rewired node's own edge by the exact curve
from its new parent, so its children's edges (which start at the unchanged pose) stay exact and
no infeasible corner can appear. Costs are curve lengths; the best goal cost never rises.
Neighbours are the k = ceil(k_rrt log n) nodes (k_rrt = e (1 + 1/3)) of shortest exact curve among the
``neighbour_pool`` x k nearest by the (x, y, cos, sin) metric, all in vectorised calls.

First solution: until one is found, a second tree grows backwards from the goal and the two are
joined by RRT-Connect's connect step (``birrt``'s), as RRT*-Connect does (Klemm et al. 2015); the
goal tree's branch from the meeting pose is then grafted into the RRT* tree (its edges are exact
curves too) and the goal tree dropped. A goal region the size of a parking slot is found this way
where one tree, sampling the goal pose 5 % of the time, almost never reaches it. The two trees hold
birrt's nodes (the same samples and extensions; the RRT* tree chooses their parents and now and then
refuses one), grown in Python; without a solution after ``connect_iterations``, birrt's compiled search
(:func:`.rrt.meet`) looks for it instead, ending too where a start-tree node lands in the goal region,
and its path is grafted (each edge a piece of a shortest curve toward a sample, itself the shortest
curve between its ends).

Goal region (``region_goal``): a goal connection (each node that could beat the best cost tries its
exact curve to the goal) aims at the poses spread over the goal region
(:func:`~planning.planners.sampling.tree.goal_region_poses`), the cheapest free one first, and the
goal bias samples one of them at random, as OMPL's planners use a goal region's samples; the path
then ends wherever in the region it is shortest. By default the connections and the goal bias aim at
the goal pose itself, and the plan ends on it once a curve reached it, which leaves the tracker the
whole goal tolerance (a node that landed in the region by itself ends it only while none has: a search
stopped before then ends up to the tolerance from the goal pose).

Informed sampling (Gammell et al. 2014): once a path of cost c exists, samples are drawn only from
the x-y ellipse with foci at the start and goal and major axis c + the goal's position tolerance
(headings uniform). A curve is never shorter than the straight line between its ends, so every
pose of a shorter path lies in it: the ellipse leaves out nothing that could improve the path.
Path biasing (Akgun and Stilman 2011): a fraction ``path_bias`` of those samples is instead a node of
the best path moved by normal noise, so rewiring straightens the path where it is, while the rest
keep exploring the ellipse.

Anytime: the stats report the first solution's time, iteration and length; the search stops when
the best cost has improved by less than ``improvement_tol`` (0.1 %) over the last half of the run
(measured in iterations by default, so the stop is reproducible), instead of always spending the
whole budget, and at once when the best path is the free-space shortest curve to an aimed goal pose
(the start sees the goal: no path to it is shorter; an open 10 x 10 m world ran its 500 minimum
iterations, 0.15 s, for the curve of its first iteration). ``stopped_by`` says which rule ended it.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.core.checks import FLAG, check_fields
from planning.core.geometry import path_length
from planning.errors import ConfigError
from planning.planners.base import PlanProblem, PlanResult, PlanStatus, PlanTree
from planning.planners.sampling.extend import LocalPlanner
from planning.planners.sampling.rrt import Meeting, TreeConfig, _TreePlanner, meet
from planning.planners.sampling.tree import (
    Budget,
    Link,
    Tree,
    draws,
    goal_region_poses,
    in_goal,
    links_in,
    merge_trees,
    sample_pose,
)

FloatArray = NDArray[np.float64]

K_RRT = np.e * (1.0 + 1.0 / 3.0)


@dataclass(frozen=True)
class RRTStarConfig(TreeConfig):
    """:class:`TreeConfig` for RRT*: Reeds–Shepp steering by default, anytime.

    Attributes:
        stop_on_first: Stop at the first solution.
        improvement_tol: Stop once the best cost has improved by less than this fraction over the
            last half of the run (0.001: 0.1 %), i.e. at clock ``c`` when the best cost at ``c / 2``
            (a solution existed then) was not above ``(1 + improvement_tol)`` times today's; 0 runs
            the whole budget.
        stall_clock: What measures the run for ``improvement_tol``: "iterations" (the default:
            the stop is the same on every run with the same seed, which the regression suite
            needs) or "time" (wall-clock seconds).
        goal_tree: Until the first solution, also grow a tree backwards from the goal and join the
            two by the connect step (see the module doc); False grows one tree, as OMPL's RRT*.
        connect_iterations: With ``goal_tree``, the iterations of that connect phase after which, without a
            solution, the first one is sought by birrt's search instead (see the module doc); 0 from the first.
        informed: After the first solution, sample the admissible x-y ellipse (see the module doc).
        neighbour_pool: Neighbours are the k of shortest exact curve among the ``neighbour_pool`` x k
            nearest by the (x, y, cos, sin) metric (>= 1; 1: the k nearest by that metric).
        connect_steps: Most extensions of one connect step toward the other tree.
        path_bias: After the first solution, the probability that a sample is drawn near the best
            path (see the module doc); 0 never.
        path_sigma: Spread of those samples: normal noise of ``path_sigma`` turning radii in x and y
            and ``path_sigma`` rad in heading.
        region_goal: Aim each goal connection at the poses of the goal region
            (:func:`planning.planners.sampling.tree.goal_region_poses`, the cheapest free one) instead of
            the goal pose alone, so the path may end anywhere in the region (its shortest way in); False
            ends on the goal pose once a curve reached it (before then, where a node landed in the
            region by itself), which leaves the tracker the goal tolerance.
        region_tries: With ``region_goal``, the most region poses whose curve is checked per node
            (cheapest first).
    """

    steering: str = "reeds_shepp"
    max_iterations: int = 5000
    stop_on_first: bool = False
    improvement_tol: float = 0.001
    stall_clock: str = "iterations"
    min_iterations: int = 500
    goal_tree: bool = True
    informed: bool = True
    neighbour_pool: float = 2.0
    connect_steps: int = 50
    path_bias: float = 0.15
    path_sigma: float = 0.5
    region_goal: bool = False
    region_tries: int = 3
    connect_iterations: int = 1000

    def __post_init__(self) -> None:
        super().__post_init__()
        check_fields(
            self,
            {
                "min_iterations": {"integer": True, "at_least": 0},
                "connect_iterations": {"integer": True, "at_least": 0},
                "neighbour_pool": {"at_least": 1.0},
                "connect_steps": {"integer": True, "at_least": 1},
                "path_bias": {"at_least": 0.0, "at_most": 1.0},
                "path_sigma": {"above": 0.0},
                "region_tries": {"integer": True, "at_least": 1},
                "improvement_tol": {"at_least": 0.0, "unit": "0 runs the whole budget"},
                **dict.fromkeys(("stop_on_first", "goal_tree", "informed", "region_goal"), FLAG),
            },
        )
        if self.stall_clock not in ("iterations", "time"):
            raise ConfigError(f"stall_clock must be 'iterations' or 'time', got {self.stall_clock!r}")


class _Anytime:
    """The best cost over the run and the early-stop rule of :class:`RRTStarConfig`."""

    def __init__(self, cfg: RRTStarConfig, budget: Budget) -> None:
        self.cfg, self.budget = cfg, budget
        self.history: list[tuple[int, float, float]] = []  # (iteration, time [s], best cost) at each improvement
        self.clocks: list[float] = []

    def clock(self, it: int) -> float:
        """The run's clock: iterations or seconds (``stall_clock``)."""
        return float(it) if self.cfg.stall_clock == "iterations" else self.budget.clock.working()

    def improved(self, it: int, cost: float) -> None:
        """Record a new best cost at iteration ``it``."""
        self.history.append((it, self.budget.elapsed(), cost))
        self.clocks.append(self.clock(it))

    def converged(self, it: int) -> bool:
        """Whether the best cost improved by less than ``improvement_tol`` over the last half of the run."""
        tol = self.cfg.improvement_tol
        if not self.history or tol <= 0.0 or it < self.cfg.min_iterations:
            return False
        k = bisect.bisect_right(self.clocks, 0.5 * self.clock(it)) - 1
        return k >= 0 and self.history[k][2] - self.history[-1][2] < tol * self.history[k][2]

    def stats(self) -> dict[str, object]:
        """First solution's time [s], iteration and length [m], and the improvements."""
        first = self.history[0] if self.history else None
        return {
            "first_solution_s": None if first is None else first[1],
            "first_solution_iteration": None if first is None else first[0],
            "first_length_m": None if first is None else first[2],
            "cost_history": self.history,
        }


class RRTStar(_TreePlanner[RRTStarConfig]):
    """Asymptotically optimal RRT* (see the module doc)."""

    name = "rrt-star"
    config_class = RRTStarConfig

    def _search(self, problem: PlanProblem, local: LocalPlanner, budget: Budget) -> PlanResult:
        """Grow and rewire until the budget is spent, the cost stops improving (``improvement_tol``) or,
        with ``stop_on_first``, at the first solution."""
        cfg = self.config
        if not local.exact:
            raise ConfigError(
                f"rrt-star needs exact steering ('reeds_shepp' or 'dubins'), got {cfg.steering!r}: choosing a parent "
                "and rewiring join two poses exactly, which primitives and the diffdrive drive do not; plan with "
                "rrt for those"
            )
        if in_goal(problem.start.as_array(), problem):
            return self._start_in_goal(problem, local, budget)
        search = _Search(cfg, problem, local, draws(problem))
        run = _Anytime(cfg, budget)
        # no path to an aimed goal pose is shorter than the free-space curve to the nearest of them
        floor = float(local.curves.lengths(search.start, search.aims).min())
        stop = "budget"
        it = 0
        while not budget.spent(it):
            it += 1
            if run.converged(it):
                stop = "converged"
                break
            it, better = search.step(it, budget)
            if better:
                budget.proof = None  # a path: nothing to prove
                run.improved(it, search.best)
                if cfg.stop_on_first:
                    stop = "first solution"
                    break
                if search.best <= floor + 1e-9:
                    stop = "shortest curve"
                    break
        tree = search.tree
        stats: dict[str, object] = {
            **self._stats(budget, it, tree.n + (search.met.nodes if search.met and not search.met.joined else 0)),
            **run.stats(),
            "stopped_by": stop,
            "goal_tree_joined": search.grafted,
            "birrt_iterations": search.birrt_iterations,
        }
        if search.goal_nodes:
            g = search.final_goal()
            path, dirs = tree.branch(g)
            stats["cost_m"] = float(tree.costs[g])
            return self._result(PlanStatus.SUCCESS, path, dirs, "", stats, tree.plan_tree())
        reason = f"{budget.why(it)} without reaching the goal; partial path to the node nearest the goal"
        trees = (tree, *search.met.trees()) if search.met is not None else (tree,)  # birrt's too, when it ran
        path, dirs, _ = min((self._partial(t, problem) for t in trees[:2]), key=lambda p: p[2])
        return self._result(budget.status, path, dirs, reason, stats, merge_trees(*trees))

    def _start_in_goal(self, problem: PlanProblem, local: LocalPlanner, budget: Budget) -> PlanResult:
        """The plan of a start inside the goal region, at once, as birrt's: the exact curve to the goal
        pose when it is free (the tracker then has the whole goal tolerance), else, or with
        ``region_goal`` (the path ends wherever in the region it is shortest), the start itself. No path
        is shorter than the curve to the goal pose, the shortest there is, nor than the start alone:
        there is nothing to improve."""
        start, goal = problem.start.as_array(), problem.goal.as_array()
        direct = None if self.config.region_goal else local.connect(start, goal)
        path, dirs = direct if direct is not None else (start[None, :].copy(), np.ones(1))
        nodes = np.vstack([start, goal]) if direct is not None else start[None, :].copy()
        tree = PlanTree(nodes, np.arange(-1, nodes.shape[0] - 1, dtype=np.int64))
        length = path_length(path)
        stats: dict[str, object] = {
            **self._stats(budget, 0, nodes.shape[0]),
            "first_solution_s": budget.elapsed(),
            "first_solution_iteration": 0,
            "first_length_m": length,
            "cost_history": [(0, budget.elapsed(), length)],
            "stopped_by": "start in goal region",
            "goal_tree_joined": False,
            "birrt_iterations": 0,
            "cost_m": length,
        }
        return self._result(PlanStatus.SUCCESS, path, dirs, "", stats, tree)


class _Search:
    """One run's RRT* tree, its goal tree until the first solution, and its goal nodes."""

    def __init__(self, cfg: RRTStarConfig, problem: PlanProblem, local: LocalPlanner, rng: np.random.Generator) -> None:
        self.cfg, self.problem, self.local, self.rng = cfg, problem, local, rng
        self.start, self.goal = problem.start.as_array(), problem.goal.as_array()
        self.tree = Tree(self.start)
        self.back: Tree | None = Tree(self.goal, backwards=True) if cfg.goal_tree else None
        self.goal_nodes: list[int] = []
        # the poses goal connections aim at (the goal pose first) and the node on each (-1: none yet)
        self.aims = goal_region_poses(problem) if cfg.region_goal else self.goal[None].copy()
        self.aim_nodes = np.full(len(self.aims), -1, dtype=np.int64)
        self.grafted = False  # whether the first solution came through the goal tree
        self.birrt_iterations = 0  # of the run's iterations, birrt's search's (:meth:`_meet`)
        self.met: Meeting | None = None  # birrt's search, when it ran
        self.incumbent = np.zeros(0, dtype=np.int64)  # the best path's nodes (root excluded)
        self.best = np.inf

    def best_goal(self) -> int:
        """The cheapest goal node (first of equals)."""
        nodes = np.asarray(self.goal_nodes)
        costs = self.tree.costs[nodes]
        return int(nodes[costs == costs.min()].min())

    def final_goal(self) -> int:
        """The goal node the plan ends on: without ``region_goal``, the node on the goal pose once a curve
        reached it, though a node that landed elsewhere in the region by itself may be cheaper (that one
        would leave the tracker less of the goal tolerance; it is the end only while no curve reached the
        goal pose); with it, the cheapest (:meth:`best_goal`)."""
        if not self.cfg.region_goal and self.aim_nodes[0] >= 0:
            return int(self.aim_nodes[0])
        return self.best_goal()

    def step(self, it: int, budget: Budget) -> tuple[int, bool]:
        """Iteration ``it`` (and, when birrt's search takes over the connect phase, the iterations it runs until
        the trees meet or ``budget`` is spent); returns the iterations done and whether the best cost fell."""
        if it == 1:
            self._to_goal(0)  # the start may see the goal
        if self.back is not None and not self.goal_nodes and it > self.cfg.connect_iterations:
            it = self._meet(it - 1, budget)
        elif self.back is not None and not self.goal_nodes:
            self._connect_step(it)
        else:
            self.back = None  # the goal tree's work is done at the first solution
            j = self._grow(self._sample())
            if j is not None and self.goal_nodes:
                self._to_goal(j)
        if not self.goal_nodes:
            return it, False
        g = self.best_goal()
        if self.tree.costs[g] < self.best:  # rewiring may have lowered it
            self.best = float(self.tree.costs[g])
            self.incumbent = self._branch_nodes(g)
            return it, True
        return it, False

    def _meet(self, done: int, budget: Budget) -> int:
        """birrt's search (:func:`.rrt.meet`) after ``done`` iterations, its path grafted when the trees met (the
        goal tree dropped either way); the iterations done then."""
        met = meet(self.problem, self.local, budget, self.rng, self.cfg, self.cfg.connect_steps, done, region=True)
        self.back, self.met = None, met
        self.birrt_iterations = met.iterations - done
        if met.joined:
            self._graft_path(met.chain())
            self.grafted = met.goal_tree
        return met.iterations

    def _branch_nodes(self, i: int) -> NDArray[np.int64]:
        """The nodes between the root (excluded) and node ``i``."""
        out = []
        while i > 0:
            out.append(i)
            i = int(self.tree.parents[i])
        return np.array(out, dtype=np.int64)

    def _sample(self, toward_start: bool = False) -> FloatArray:
        """The goal (with ``region_goal`` one of the aimed poses at random; for the goal tree, the start)
        with probability ``goal_bias``; once a solution exists, a pose near it with probability
        ``path_bias``, else one from the informed ellipse; else a uniform pose."""
        cfg, rng = self.cfg, self.rng
        if rng.random() < cfg.goal_bias:
            if toward_start:
                return self.start
            return self.goal if len(self.aims) == 1 else self.aims[rng.integers(len(self.aims))]
        if self.incumbent.size and rng.random() < cfg.path_bias:
            return self._near_path()
        if cfg.informed and np.isfinite(self.best):
            return informed_pose(rng, self.problem, self.best + self.problem.position_tolerance)
        return sample_pose(rng, self.problem.world.bounds)

    def _near_path(self) -> FloatArray:
        """A node of the best path moved by normal noise (``path_sigma``), kept inside the bounds."""
        cfg, rng, b = self.cfg, self.rng, self.problem.world.bounds
        q = self.tree.nodes[self.incumbent[rng.integers(self.incumbent.size)]]
        assert self.local.rho is not None
        noise = rng.normal(0.0, cfg.path_sigma, 3) * np.array([self.local.rho, self.local.rho, 1.0])
        x, y = np.clip(q[0] + noise[0], b[0], b[1]), np.clip(q[1] + noise[1], b[2], b[3])
        return np.array([x, y, (q[2] + noise[2] + np.pi) % (2.0 * np.pi) - np.pi])

    def _grow(self, target: FloatArray) -> int | None:
        """One RRT* extension toward ``target`` (choose-parent and rewire); the new node or None."""
        tree, local = self.tree, self.local
        ext = local.extend(tree.nodes[local.nearest(tree, target)], target)
        j = None if ext is None else _insert(tree, local, ext[0], self.cfg.neighbour_pool)
        if j is not None:
            self._note(j)
        return j

    def _note(self, j: int) -> None:
        """Record new node ``j`` if it is in the goal region (or on the goal pose)."""
        q = self.tree.nodes[j]
        if in_goal(q, self.problem):
            self.goal_nodes.append(j)
            on = np.flatnonzero(np.all(self.aims == q, axis=1))
            if on.size:
                self.aim_nodes[on[0]] = j

    def _to_goal(self, j: int) -> None:
        """Try the exact curves from node ``j`` to the aimed goal poses (the goal pose, or the region's
        with ``region_goal``) that would beat the best cost, cheapest first (at most ``region_tries``);
        the first free one becomes the edge of that pose's node (added the first time)."""
        tree, aims, nodes = self.tree, self.aims, self.aim_nodes
        q, cost = tree.nodes[j], float(tree.costs[j])
        # below each aimed node's own cost too, so j is not its descendant (rewiring may have lowered it)
        bound = np.where(nodes < 0, self.best, np.minimum(self.best, tree.costs[np.maximum(nodes, 0)]))
        line = np.hypot(aims[:, 0] - q[0], aims[:, 1] - q[1])
        cand = np.flatnonzero((nodes != j) & (cost + line < bound - 1e-9))
        if cand.size == 0:
            return
        through = cost + self.local.curves.lengths(q, aims[cand])
        tries = 0
        for o in np.argsort(through, kind="stable"):
            k = int(cand[o])
            if through[o] >= bound[k] - 1e-9:
                continue
            if tries == self.cfg.region_tries:
                return
            tries += 1
            curve = self.local.connect(q, aims[k])
            if curve is None:
                continue
            if nodes[k] < 0:
                self._note(tree.add(aims[k].copy(), j, curve[0], curve[1], float(through[o])))
            else:
                tree.reparent(int(nodes[k]), j, curve[0], curve[1], float(through[o]))
            return

    def _connect_step(self, it: int) -> None:
        """birrt's iteration with the RRT* tree as its start tree: odd iterations grow the RRT* tree
        toward a sample and connect the goal tree to the new node, even ones the other way round."""
        if it % 2:
            j = self._grow(self._sample())
            if j is not None and not self.goal_nodes:
                self._connect_back(j)
            return
        back, local = self.back, self.local
        assert back is not None
        q = self._sample(toward_start=True)
        k = local.nearest(back, q)
        ext = local.extend(back.nodes[k], q, backwards=True)
        if ext is not None:
            self._connect_forward(back.add(ext[0], k, ext[1], ext[2]))

    def _connect_back(self, j: int) -> None:
        """Extend the goal tree toward RRT* node ``j`` until it reaches it (then graft) or is blocked."""
        back, local = self.back, self.local
        assert back is not None
        target = self.tree.nodes[j]
        k = local.nearest(back, target)
        for _ in range(self.cfg.connect_steps):
            if np.array_equal(back.nodes[k], target):
                self._graft(j, k)
                return
            ext = local.extend(back.nodes[k], target, backwards=True)
            if ext is None:
                return
            k = back.add(ext[0], k, ext[1], ext[2])

    def _connect_forward(self, b: int) -> None:
        """Grow the RRT* tree toward goal-tree node ``b`` until it reaches it (then graft), is blocked
        or reaches the goal region."""
        back, tree = self.back, self.tree
        assert back is not None
        target = back.nodes[b]
        for _ in range(self.cfg.connect_steps):
            i = self.local.nearest(tree, target)
            if np.array_equal(tree.nodes[i], target):
                self._graft(i, b)
                return
            if self._grow(target) is None or self.goal_nodes:
                return

    def _graft_path(self, chain: list[Link], prev: int = 0) -> None:
        """Add ``chain``'s nodes to the RRT* tree after node ``prev`` (the pose the chain starts from), each edge as
        it is (an exact curve: a goal-tree edge, or a piece of the shortest curve from its parent toward a sample,
        itself the shortest curve between its ends), its cost the curve length between its poses."""
        tree = self.tree
        for pose, poses, dirs in chain:
            cost = tree.costs[prev] + float(self.local.curves.lengths(tree.nodes[prev], pose[None])[0])
            prev = tree.add(pose.copy(), prev, poses, dirs, cost)
            self._note(prev)

    def _graft(self, a: int, b: int) -> None:
        """Add goal-tree node ``b``'s branch to the goal under RRT* node ``a`` (the same pose): each
        goal-tree edge, the exact curve from a node to its parent, becomes an RRT* edge as it is."""
        assert self.back is not None
        self._graft_path(links_in(self.back.side(), b), a)
        self.grafted = True


def informed_pose(rng: np.random.Generator, problem: PlanProblem, c: float) -> FloatArray:
    """A pose uniform over the x-y ellipse {p : |p - start| + |p - goal| <= c} inside the bounds, heading
    uniform (Gammell et al. 2014): drawn in the ellipse when it is smaller than the bounds, else drawn
    in the bounds and rejected outside it; a uniform pose in the bounds after 100 misses.

    Args:
        rng: The run's generator.
        problem: Start, goal and bounds.
        c: Major axis [m] (a path's cost plus the goal's position tolerance).
    """
    s, g = problem.start.as_array()[:2], problem.goal.as_array()[:2]
    b = problem.world.bounds
    focal = float(np.hypot(*(g - s)))
    semi = np.array([0.5 * c, 0.5 * np.sqrt(max(c * c - focal * focal, 0.0))])
    in_ellipse = np.pi * semi[0] * semi[1] < (b[1] - b[0]) * (b[3] - b[2])
    angle = np.arctan2(g[1] - s[1], g[0] - s[0])
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    for _ in range(100):
        if in_ellipse:
            r, t = np.sqrt(rng.random()), 2.0 * np.pi * rng.random()
            x, y = 0.5 * (s + g) + rot @ (semi * r * np.array([np.cos(t), np.sin(t)]))
            if b[0] <= x <= b[1] and b[2] <= y <= b[3]:
                return np.array([x, y, np.pi * (2.0 * rng.random() - 1.0)])
        else:
            q = sample_pose(rng, b)
            if np.hypot(*(q[:2] - s)) + np.hypot(*(q[:2] - g)) <= c:
                return q
    return sample_pose(rng, b)


def _improve_parent(tree: Tree, local: LocalPlanner, e: int, nbrs: NDArray[np.int64]) -> None:
    """Reparent existing node ``e`` through the cheapest of ``nbrs`` whose exact curve to it is free and
    shorter than its cost (a sample that lands on a node, e.g. the goal, improves that node)."""
    if e == 0:
        return
    others = nbrs[nbrs != e]
    to_e = local.curves.lengths(tree.nodes[others], tree.nodes[e])
    through = tree.costs[others] + to_e
    for o in np.argsort(through, kind="stable"):
        if through[o] >= tree.costs[e] - 1e-9:
            return  # a descendant of e costs at least as much as e: never a cycle
        curve = local.connect(tree.nodes[others[o]], tree.nodes[e])
        if curve is not None:
            tree.reparent(e, int(others[o]), curve[0], curve[1], float(through[o]))
            return


def _insert(tree: Tree, local: LocalPlanner, q_new: FloatArray, pool: float) -> int | None:
    """Add ``q_new`` through its cheapest collision-free neighbour and rewire the neighbours through it.

    Neighbours are the k = ceil(K_RRT log(n + 1)) nodes of shortest exact curve among the ceil(pool k)
    nearest by the local metric. Returns the new node's index, or None when ``q_new`` is already in the
    tree or no neighbour reaches it.
    """
    n = tree.n
    k = min(n, int(np.ceil(K_RRT * np.log(n + 1))))
    m = min(n, int(np.ceil(pool * k)))
    d = local.tree_distances(tree, q_new)
    nbrs = np.argpartition(d, m - 1)[:m] if m < n else np.arange(n)
    if d[nbrs].min() < 1e-9:
        _improve_parent(tree, local, int(nbrs[np.argmin(d[nbrs])]), nbrs)
        return None  # already in the tree
    to_new = local.curves.lengths(tree.nodes[nbrs], q_new)
    if m > k:
        keep = np.sort(np.argpartition(to_new, k - 1)[:k])
        nbrs, to_new = nbrs[keep], to_new[keep]
    parent, motion, c_new = -1, None, 0.0
    for o in np.argsort(tree.costs[nbrs] + to_new, kind="stable"):
        motion = local.connect(tree.nodes[nbrs[o]], q_new)
        if motion is not None:
            parent, c_new = int(nbrs[o]), float(tree.costs[nbrs[o]] + to_new[o])
            break
    if motion is None:
        return None
    j = tree.add(q_new, parent, motion[0], motion[1], c_new)
    # Rewire: reparent neighbours through the new node when that is shorter. No curve is shorter than
    # the straight line (bound lowered by 1e-12 against rounding), so only neighbours the line could
    # improve get a curve solved. Reeds–Shepp lengths are symmetric (drive the curve backwards), so
    # theirs are the lengths already solved; Dubins curves are solved again the other way.
    line = np.hypot(tree.nodes[nbrs, 0] - q_new[0], tree.nodes[nbrs, 1] - q_new[1]) * (1.0 - 1e-12) - 1e-12
    improvable = (c_new + line < tree.costs[nbrs] - 1e-9) & (nbrs != parent)
    cand = nbrs[improvable]
    if cand.size == 0:
        return j
    if local.curves.kind == "reeds_shepp":
        from_new = to_new[improvable]
    else:
        from_new = local.curves.lengths(q_new, tree.nodes[cand])
    for o in np.argsort(from_new, kind="stable"):
        nb = int(cand[o])
        if c_new + from_new[o] >= tree.costs[nb] - 1e-9:
            continue
        curve = local.connect(q_new, tree.nodes[nb])
        if curve is not None:
            tree.reparent(nb, j, curve[0], curve[1], c_new + float(from_new[o]))
    return j
