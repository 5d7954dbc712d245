"""C-RRT*: the EduMIP planning report's customised RRT* (straight segments, biased sampling, clearance cost).

The planner grows a tree of positions joined by straight segments (the EduMIP turns in place about
its axle centre, so any polyline is drivable) exactly as the EduMIP planning report's Algorithms
1, 2 and 5:

1. ``SampleBiased`` (Algorithm 2): a uniform sample ``(x, y, theta)`` in the world bounds; with
   probability ``gamma`` it is replaced by a sample in the quadrant toward the goal as seen from
   the previous node ``q_prev`` (the node added last): ``x`` between ``x_prev`` and the bound on the
   goal's side, likewise ``y``, and ``theta`` in that quadrant's range (e.g. goal up and right:
   ``x in [x_prev, x_max]``, ``y in [y_prev, y_max]``, ``theta in [0, pi/2]``). When the goal is level
   with ``q_prev`` in x or y no quadrant applies and the uniform sample stays, as in the report. The
   sample's heading does not enter the straight-line tree (the report recomputes headings along the
   path); it is drawn so the random stream follows the report's sampler.
2. ``Near``: the node nearest to the sample in (x, y); ``Steer``: move from it toward the sample by
   at most ``max_step``.
3. ``CollisionFree`` (Algorithm 3): the straight segment and both ends keep the clearance (below).
4. Choose-parent among the nodes within ``neighbour_radius`` (collision-free ones only), then
   rewire those neighbours through the new node when that lowers their cost (costs of their
   subtrees drop by the same amount).
5. Edge cost ``c = length + rho * exp(-sigma * d**2)``, ``d`` the edge's obstacle clearance: the
   smallest distance from the axle centre to any obstacle or wall along the segment [m].
6. Stop as soon as a node lies within ``goal_radius`` of the goal and the straight segment to the
   goal is free: the goal joins the tree (choosing its parent like any node) and the path is read
   back from the goal through the parents (Algorithm 5).

Clearance ("40 cm" in the EduMIP planning report): the EduMIP turns about its axle centre and is
40 cm long, and the report requires every checked point to have no obstacle within a 40 cm radius.
Here that means: the axle centre (the base origin) stays at least ``center_clearance`` = 0.40 m
from every obstacle and wall, all along every segment. It is checked with
:class:`planning.collision.exact.CollisionChecker` in ``shape="disc"`` with
``clearance = center_clearance - robot.radius`` (the disc's radius plus that clearance is exactly
0.40 m). Segments are sampled at spacing ``h`` <= the checker's resolution and, because a signed
distance is 1-Lipschitz, a segment is accepted only if every sample keeps
``center_clearance + h / 2``: the whole continuous segment then provably keeps ``center_clearance``.

Budgets: ``max_iterations`` and the problem's ``time_limit``; either ends in ``TIMEOUT`` with the
path to the node nearest the goal. The time limit counts the whole run: the 2-D check that some way
keeps the clearance (a limit that passes during it ends the run before any sample, saying so), the
sampling, and the simplification, which gets what the sampling left and keeps what it has shortened
when that passes. With the same seed and an iteration budget the plan is bit-for-bit identical (a
wall-clock limit may cut a run at a different iteration).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planning.clock import PlanClock
from planning.collision.exact import CollisionChecker
from planning.collision.field import FieldTimeout
from planning.core.checks import FLAG, check_fields
from planning.core.geometry import path_length, wrap_angle
from planning.errors import ConfigError
from planning.planners import geodesic
from planning.planners.base import PlanProblem, PlanResult, PlanStatus, PlanTree, checked_problem, end_outside
from planning.planners.registry import config_from_options
from planning.planners.sampling.tree import draws
from planning.planners.simplify import simplify_path

FloatArray = NDArray[np.float64]

#: What the 2-D route the simplifier tries keeps beyond the axle-centre clearance [m] (the sampled
#: clearance check asks half a sample spacing, at most 1 cm here, more).
ROUTE_MARGIN = 0.02
#: Longest a run that did not reach the goal spends looking for a 2-D route to say none exists [s].
NO_ROUTE_S = 0.3
#: Cell side of that search [m] (coarser where the world would need more cells than a route takes): a way between
#: cell centres is missed when it keeps the clearance by less than half a cell's diagonal, said in the reason (with
#: the planners' 5 cm cells a 0.26 m corridor, 2.5 mm wider than the TurtleBot3 needs, was said to pass "a pinch with
#: under a millimetre to spare").
NO_ROUTE_CELL = 0.01
#: Refining to the budget (``stop_at_goal`` False) with ``simplify``, the share of the time limit the
#: sampling leaves to the simplification once the goal has joined the tree.
SIMPLIFY_SHARE = 0.1
#: The EduMIP planning report's axle-centre clearance per robot [m]; other robots keep just their own radius.
SEED_CLEARANCE: dict[str, float] = {"edumip": 0.40, "edumip-balancing": 0.40}  # the same EduMIP, balancing


@dataclass(frozen=True)
class CRRTStarConfig:
    """C-RRT* parameters. The EduMIP planning report gives the algorithm and the 40 cm clearance; it
    leaves gamma, the step, R, rho and sigma to the user ("tuned through experiments"), so these are
    documented choices for its 5 x 5 m map.

    Attributes:
        gamma: Probability of a goal-quadrant sample (Algorithm 2), in [0, 1]; the report draws it as
            ``10 * gamma`` ones in ten, so tenths reproduce it exactly. 0.5: half the samples point
            at the goal, half keep the tree exploring.
        max_step: Longest edge Steer makes [m]; 0.25 m, a twentieth of the map's side.
        neighbour_radius: R, the choose-parent and rewire radius [m]; 0.6 m, a few steps.
        goal_radius: A node this close to the goal [m] (with a free segment to it) ends the search.
        rho: Weight of the clearance term [m]; 0.1 m per edge.
        sigma: Decay of the clearance term [1/m^2]; 5: the term is 0.45 rho at d = 0.4 m and
            0.04 rho at 0.8 m, so it pushes the path off the 40 cm limit toward mid-corridor.
        center_clearance: Distance the axle centre keeps from obstacles and walls [m]; None: the
            report's 0.40 m for the EduMIP, the robot's own radius for other robots.
        max_iterations: Sampling iterations before ``TIMEOUT``.
        stop_at_goal: Stop at the first node that reaches the goal region (as the report does). If
            False, keep sampling to the iteration or time budget and return the cheapest goal
            connection.
        simplify: Return the path simplified by straight shortcuts between its states (turns in
            place at the vertices, :func:`planning.planners.simplify.simplify_path` seeded by the
            problem's seed), each kept only when it keeps the clearance and lowers the path's cost
            as defined here (length plus one clearance term per segment), and the path along the
            obstacle-aware 2-D route for the axle-centre clearance (straight segments, turns in
            place) simplified the same way, kept instead when it costs less, all within what the
            sampling left of the time limit (:data:`SIMPLIFY_SHARE` of it when refining); False
            returns the tree's path.
    """

    gamma: float = 0.5
    max_step: float = 0.25
    neighbour_radius: float = 0.6
    goal_radius: float = 0.5
    rho: float = 0.1
    sigma: float = 5.0
    center_clearance: float | None = None
    max_iterations: int = 20000
    stop_at_goal: bool = True
    simplify: bool = True

    def __post_init__(self) -> None:
        checks: dict[str, Mapping[str, Any]] = {
            "gamma": {"at_least": 0.0, "at_most": 1.0},
            "max_step": {"above": 0.0},
            "neighbour_radius": {"above": 0.0},
            "goal_radius": {"above": 0.0},
            "rho": {"at_least": 0.0},
            "sigma": {"at_least": 0.0},
            "center_clearance": {"at_least": 0.0, "optional": True},
            "max_iterations": {"integer": True, "at_least": 1},
            "stop_at_goal": FLAG,
            "simplify": FLAG,
        }
        check_fields(self, checks, "C-RRT*: ")


class CRRTStar:
    """The EduMIP planning report's C-RRT* (see the module doc).

    Args:
        config: Parameters; keyword options override its fields (``CRRTStar(gamma=0.3)``).
    """

    name = "c-rrt-star"
    config_class = CRRTStarConfig

    def __init__(self, config: CRRTStarConfig | None = None, **options: Any) -> None:
        self.config = config_from_options(CRRTStarConfig, options, config)

    def required_clearance(self, problem: PlanProblem) -> float:
        """Axle-centre clearance this problem's robot must keep [m]."""
        c = self.config.center_clearance
        if c is None:
            c = SEED_CLEARANCE.get(problem.robot.name, problem.robot.radius)
        if c < problem.robot.radius:
            raise ConfigError(
                f"C-RRT*: center_clearance {c:.3f} m is below the robot's radius {problem.robot.radius:.3f} m; "
                "the robot's body would touch obstacles: give at least the radius"
            )
        return float(c)

    def plan(self, problem: PlanProblem) -> PlanResult:
        """Plan from ``problem.start`` to ``problem.goal``; never raises for an unsolvable problem."""
        problem = checked_problem(problem)
        return _Search(self.config, problem, self.required_clearance(problem)).run()


class _Search:
    """One C-RRT* run: the tree in growable arrays and the report's helper functions."""

    def __init__(self, cfg: CRRTStarConfig, problem: PlanProblem, clearance: float) -> None:
        #: The run's clock, from before anything is built: the time limit counts all of it.
        self.clock = PlanClock(problem.time_limit)
        self.cfg, self.problem, self.required = cfg, problem, clearance
        robot = problem.robot
        self.radius = robot.radius
        self.checker = CollisionChecker(problem.world, robot, shape="disc", clearance=clearance - self.radius)
        self.rng = draws(problem)
        cap = 1024
        self.xy = np.zeros((cap, 2))
        self.cost = np.zeros(cap)
        self.parent = np.full(cap, -1, dtype=np.int64)
        self.edge_len = np.zeros(cap)
        self.edge_d = np.full(cap, np.inf)
        self.children: list[list[int]] = []
        self.n = 0
        self.rewires = 0
        self.biased = 0
        #: Seconds the 2-D check that some way keeps the clearance took (:meth:`walled_off`).
        self.proof_s = 0.0

    # -- helpers of Algorithm 1 -------------------------------------------------------------
    def sample_biased(self, prev: FloatArray) -> FloatArray:
        """Algorithm 2: uniform sample, replaced with probability gamma by a goal-quadrant one."""
        xmin, xmax, ymin, ymax = self.problem.world.bounds
        u = self.rng.random(3)
        q = np.array([xmin + u[0] * (xmax - xmin), ymin + u[1] * (ymax - ymin), u[2] * 2.0 * np.pi])
        if self.rng.random() >= self.cfg.gamma:
            return q
        gx, gy = self.problem.goal.x, self.problem.goal.y
        px, py = prev
        if gx == px or gy == py:  # the report's strict comparisons: no quadrant, the uniform sample stays
            return q
        r = self.rng.random(3)
        x = px + r[0] * (xmax - px) if gx > px else px - r[0] * (px - xmin)
        y = py + r[1] * (ymax - py) if gy > py else py - r[1] * (py - ymin)
        base = {(True, True): 0.0, (False, True): 0.5, (False, False): 1.0, (True, False): 1.5}[(gx > px, gy > py)]
        self.biased += 1
        return np.array([x, y, (r[2] * 0.5 + base) * np.pi])

    def segments(self, a: FloatArray, b: FloatArray) -> tuple[NDArray[np.bool_], FloatArray]:
        """CollisionFree and clearance of straight segments, all at once.

        Args:
            a: (K, 2) or (2,) segment starts [m].
            b: (K, 2) segment ends [m].

        Returns:
            free (K,) whether each segment keeps the required clearance along its whole length, and
            d (K,) the smallest sampled axle-centre distance to obstacles and walls [m].
        """
        a = np.broadcast_to(np.asarray(a, dtype=float), np.shape(b))
        length = np.hypot(b[:, 0] - a[:, 0], b[:, 1] - a[:, 1])
        n = np.maximum(1, np.ceil(length / self.checker.resolution).astype(np.int64))
        seg = np.repeat(np.arange(len(n)), n + 1)
        starts = np.concatenate(([0], np.cumsum(n + 1)[:-1]))
        frac = (np.arange(seg.size) - starts[seg]) / n[seg]
        pts = a[seg] + frac[:, None] * (b[seg] - a[seg])
        poses = np.column_stack([pts, np.zeros(len(pts))])
        centre = self.checker.clearance_of(poses) + self.radius
        d = np.minimum.reduceat(centre, starts)
        free = d - 0.5 * length / n > self.required
        return free, d

    def edge_cost(self, length: FloatArray, d: FloatArray) -> FloatArray:
        """c(Line) = length + rho * exp(-sigma * d^2) [m]."""
        return length + self.cfg.rho * np.exp(-self.cfg.sigma * np.square(d))

    def add(self, xy: FloatArray, parent: int, length: float, d: float) -> int:
        """Append a node; returns its index."""
        if self.n == len(self.cost):
            grow = len(self.cost)
            self.xy = np.vstack([self.xy, np.zeros((grow, 2))])
            self.cost = np.concatenate([self.cost, np.zeros(grow)])
            self.parent = np.concatenate([self.parent, np.full(grow, -1, dtype=np.int64)])
            self.edge_len = np.concatenate([self.edge_len, np.zeros(grow)])
            self.edge_d = np.concatenate([self.edge_d, np.full(grow, np.inf)])
        i = self.n
        self.xy[i] = xy
        self.parent[i] = parent
        self.edge_len[i] = length
        self.edge_d[i] = d
        self.cost[i] = 0.0 if parent < 0 else self.cost[parent] + float(self.edge_cost(np.array(length), np.array(d)))
        self.children.append([])
        if parent >= 0:
            self.children[parent].append(i)
        self.n += 1
        return i

    def insert(self, q_new: FloatArray, nearest: int) -> int | None:
        """Lines 5-27 of Algorithm 1 for a steered point: collision check, choose parent, rewire."""
        n = self.n
        d2 = np.sum(np.square(self.xy[:n] - q_new), axis=1)
        near = np.flatnonzero(d2 <= self.cfg.neighbour_radius**2)
        if nearest not in near:
            near = np.append(near, nearest)
        free, d = self.segments(q_new, self.xy[near])
        if not free[near == nearest][0]:
            return None
        length = np.sqrt(d2[near])
        through = self.cost[near] + self.edge_cost(length, d)
        through[~free] = np.inf
        # q_near first, then any strictly cheaper neighbour (the report's loop, ties to q_near)
        k_near = int(np.flatnonzero(near == nearest)[0])
        best = int(np.argmin(through))
        if not through[best] < through[k_near]:
            best = k_near
        new = self.add(q_new, int(near[best]), float(length[best]), float(d[best]))
        # rewire: q reached through q_new if cheaper
        via = self.cost[new] + self.edge_cost(length, d)
        for k in np.flatnonzero(free):
            q = int(near[k])
            if q == self.parent[new] or not via[k] < self.cost[q]:  # current cost: earlier rewires count
                continue
            self.children[int(self.parent[q])].remove(q)
            self.parent[q] = new
            self.children[new].append(q)
            self.edge_len[q], self.edge_d[q] = length[k], d[k]
            delta = self.cost[q] - via[k]
            stack = [q]
            while stack:
                i = stack.pop()
                self.cost[i] -= delta
                stack.extend(self.children[i])
            self.rewires += 1
        return new

    def path_to(self, i: int) -> FloatArray:
        """Algorithm 5: positions from the root to node ``i`` (K, 2)."""
        chain = [i]
        while self.parent[chain[-1]] >= 0:
            chain.append(int(self.parent[chain[-1]]))
        return self.xy[chain[::-1]].copy()

    def poses(self, pts: FloatArray, final_heading: float | None) -> FloatArray:
        """Dense poses along a polyline: turn in place at each vertex, then drive straight."""
        p = self.problem
        heading = [p.start.theta]
        for a, b in itertools.pairwise(pts):
            moved = b[0] != a[0] or b[1] != a[1]
            heading.append(float(np.arctan2(b[1] - a[1], b[0] - a[0])) if moved else heading[-1])
        if final_heading is not None:
            heading.append(final_heading)
        th = np.unwrap(np.array(heading))
        rows = [[pts[0, 0], pts[0, 1], th[0]]]
        for k in range(len(pts) - 1):
            rows.append([pts[k, 0], pts[k, 1], th[k + 1]])
            rows.append([pts[k + 1, 0], pts[k + 1, 1], th[k + 1]])
        if final_heading is not None:
            rows.append([pts[-1, 0], pts[-1, 1], th[-1]])
        q = np.array(rows)
        keep = np.concatenate([[True], np.any(np.diff(q, axis=0) != 0.0, axis=1)])
        return self.checker.densify(q[keep])

    def result(
        self, status: PlanStatus, goal_node: int | None, clock: PlanClock, iterations: int, reason: str = ""
    ) -> PlanResult:
        n = self.n
        heading = np.zeros(n)
        has = self.parent[:n] >= 0
        dxy = self.xy[:n][has] - self.xy[self.parent[:n][has]]
        heading[has] = np.arctan2(dxy[:, 1], dxy[:, 0])
        heading[0] = self.problem.start.theta
        tree = PlanTree(np.column_stack([self.xy[:n], heading]), self.parent[:n].copy())
        end = goal_node
        if end is None:  # partial: the node nearest the goal
            end = int(np.argmin(np.hypot(*(self.xy[:n] - self.problem.goal.xy).T)))
        pts = self.path_to(end)
        path = self.poses(pts, self.problem.goal.theta if goal_node is not None else None)
        chain = [end]
        while self.parent[chain[-1]] >= 0:
            chain.append(int(self.parent[chain[-1]]))
        edges = np.array(chain[:-1], dtype=np.int64)
        stats: dict[str, Any] = {
            "time_s": clock.elapsed(),
            "code_s": clock.code(),
            "iterations": iterations,
            "nodes": n,
            "rewires": self.rewires,
            "biased_samples": self.biased,
            "cost": float(self.cost[end]),
            "polyline_length_m": float(np.sum(self.edge_len[edges])),
            "edge_clearances_m": self.edge_d[edges][::-1].tolist(),
            "center_clearance_m": self.required,
            "waypoints": pts.tolist(),
            "distance_to_goal_m": float(np.hypot(*(pts[-1] - self.problem.goal.xy))),
            "proof_s": self.proof_s,
        }
        result = PlanResult(
            status, CRRTStar.name, path=path, reason=reason, stats=stats, tree=tree, directions=np.ones(len(path))
        )
        if self.cfg.simplify and status is PlanStatus.SUCCESS:
            return self.simplified(result, pts, limited=True)
        return result

    # -- simplification with the planner's own steering, clearance and cost ------------------------
    def steer(self, qa: FloatArray, qb: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Turn in place toward ``qb``, drive straight to it, turn to its heading: dense poses (K, 3)
        and directions (K,), all forwards."""
        dx, dy = qb[0] - qa[0], qb[1] - qa[1]
        h = qa[2] + float(wrap_angle(np.arctan2(dy, dx) - qa[2])) if dx or dy else float(qa[2])
        end = h + float(wrap_angle(qb[2] - h))
        rows = np.array([qa, [qa[0], qa[1], h], [qb[0], qb[1], h], [qb[0], qb[1], end]])
        keep = np.concatenate([[True], np.any(np.diff(rows, axis=0) != 0.0, axis=1)])
        poses = self.checker.densify(rows[keep])
        poses[-1] = qb
        return poses, np.ones(poses.shape[0])

    def least_clearance(self, poses: FloatArray) -> float:
        """The smallest axle-centre distance of dense poses (K, 3) to obstacles and walls [m]: the
        checker's signed distance, compiled, from as few of the poses as prove it
        (:meth:`planning.collision.exact.CollisionChecker.least_distance`; the simplifier prices and
        checks straight pieces of tens of metres, sampled every 2 cm, many times)."""
        return self.checker.least_distance(poses[:, :2])

    def keeps_clearance(self, poses: FloatArray) -> bool:
        """Whether dense poses keep the axle-centre clearance (the ``segments`` rule: every sample
        farther than the requirement plus half the sample spacing)."""
        h = float(np.max(np.hypot(*np.diff(poses[:, :2], axis=0).T))) if poses.shape[0] > 1 else 0.0
        return bool(self.least_clearance(poses) - 0.5 * h > self.required)

    def piece_cost(self, poses: FloatArray, directions: FloatArray) -> float:
        """c(Line) of one straight piece: length + rho exp(-sigma d^2), d its smallest axle-centre
        clearance [m]; a turn in place costs nothing."""
        length = path_length(poses)
        if length == 0.0:
            return 0.0
        return float(self.edge_cost(np.array(length), np.array(self.least_clearance(poses))))

    def routes(self, deadline: float | None = None) -> list[FloatArray]:
        """The obstacle-aware 2-D route from the start to the goal (:mod:`planning.planners.geodesic`)
        for a disc of the axle-centre clearance plus ``ROUTE_MARGIN``, as poses that this planner's
        steering joins (none when no such route exists): the simplifier's other way round.

        Raises:
            planning.collision.field.FieldTimeout: ``time.perf_counter()`` passed ``deadline``.
        """
        p = self.problem
        radius = self.required + ROUTE_MARGIN
        vertices = geodesic.route(p.world, p.start.as_array(), p.goal.as_array(), radius, deadline=deadline)
        return [] if vertices is None else [geodesic.polyline_waypoints(vertices)]

    def simplified(self, result: PlanResult, pts: FloatArray, limited: bool = False) -> PlanResult:
        """``result`` with its path simplified (the raw one kept in ``raw_path``); ``limited``: within what is
        left of the time limit, stopped with the path as far as it got when it passes."""
        deadline = self.clock.deadline if limited else lambda: None
        path = result.path
        verts, k = [], 0
        for p in pts:  # the dense index of each waypoint: where its turn in place starts
            k += int(np.argmax(np.all(path[k:, :2] == p, axis=1)))
            verts.append(k)
        s = simplify_path(
            path,
            result.directions,
            self.steer,
            self.keeps_clearance,
            cost=self.piece_cost,
            distance=lambda q0, q1: np.atleast_1d(np.hypot(*(np.atleast_2d(q1)[:, :2] - np.atleast_2d(q0)[:, :2]).T)),
            vertices=verts,
            routes=lambda: self.routes(deadline()),
            seed=self.problem.seed,
            deadline=deadline(),
        )
        stats = {**result.stats, **s.stats()}  # "cost" stays the tree path's, "simplified_cost" is the result's
        return dataclasses.replace(result, path=s.path, directions=s.directions, raw_path=path, stats=stats)

    def walled_off(self) -> str | None:
        """Why no path from the start to the goal can keep the axle centre ``required`` off everything,
        when a 2-D search proves it (:func:`planning.planners.geodesic.walled_off`); else None. Its wall time goes
        into ``proof_s``.

        Raises:
            planning.collision.field.FieldTimeout: The time limit passed before the search was done.
        """
        p, req = self.problem, self.required
        t0 = time.perf_counter()
        try:
            return geodesic.walled_off_reason(
                p.world,
                (p.start.xy, p.goal.xy),
                req,
                self.clock.deadline(),
                0.0,
                keeps=f"the axle centre {req:.3f} m",
                fix="lower center_clearance, or plan with another planner",
            )
        finally:
            self.proof_s = time.perf_counter() - t0

    def bad_end(self) -> PlanResult | None:
        """The INVALID_START / INVALID_GOAL result when the start or the goal is too near something."""
        p, req = self.problem, self.required
        outside = end_outside(p, CRRTStar.name, self.early_stats())
        if outside is not None:
            return outside
        for label, pose, status in (
            ("start", p.start, PlanStatus.INVALID_START),
            ("goal", p.goal, PlanStatus.INVALID_GOAL),
        ):
            d = float(self.checker.clearance_of(pose.as_array()[None, :])[0]) + p.robot.radius
            if not d > req:
                why = (
                    f"{label} ({pose.x:.3f}, {pose.y:.3f}) is {d:.4f} m from the nearest obstacle or wall; "
                    f"C-RRT* keeps the axle centre strictly more than {req:.4f} m away: move the {label} or lower "
                    "center_clearance"
                )
                return PlanResult(status, CRRTStar.name, reason=why, stats=self.early_stats())
        return None

    def early_stats(self) -> dict[str, Any]:
        """The stats of a run that ends before sampling: its time, the code's part of it and the proof's."""
        return {"time_s": self.clock.elapsed(), "code_s": self.clock.code(), "iterations": 0, "proof_s": self.proof_s}

    # -- Algorithm 1 ----------------------------------------------------------------------------
    def run(self) -> PlanResult:
        p, clock = self.problem, self.clock
        bad = self.bad_end()
        if bad is not None:
            return bad
        try:
            walled = self.walled_off()
        except FieldTimeout as exc:
            reason = (
                f"no sample drawn: the {p.time_limit:g} s time limit passed after {clock.working():.3f} s while "
                f"checking whether any way keeps the axle centre {self.required:.3f} m from everything, in "
                f"{exc.what[0]} ({exc.nodes} {exc.what[1]}, {exc.obstacles} obstacles); a longer time limit lets "
                "it finish (its tables are kept for the world)"
            )
            return PlanResult(PlanStatus.TIMEOUT, CRRTStar.name, reason=reason, stats=self.early_stats())
        if walled is not None:
            return PlanResult(PlanStatus.INFEASIBLE, CRRTStar.name, reason=walled, stats=self.early_stats())
        best_goal, it = self.sample()
        if best_goal is not None:
            return self.result(PlanStatus.SUCCESS, best_goal, clock, it)
        partial = self.result(PlanStatus.TIMEOUT, None, clock, it)
        reason = self.why_unreached(it, partial.stats["distance_to_goal_m"])
        partial.stats["time_s"] = clock.elapsed()  # the reason's route search included
        return dataclasses.replace(partial, reason=reason)

    def sample(self) -> tuple[int | None, int]:
        """Lines 1-27 of Algorithm 1 from the start until the goal joins the tree (with ``stop_at_goal``)
        or a budget is spent: the goal's node (None: not reached) and the iterations run. Refining
        (``stop_at_goal`` False) with ``simplify``, it leaves the last :data:`SIMPLIFY_SHARE` of the time
        limit to the simplification once the goal has joined."""
        p, cfg, clock = self.problem, self.cfg, self.clock
        goal = p.goal.xy
        self.add(p.start.xy, -1, 0.0, np.inf)
        prev = p.start.xy
        best_goal: int | None = None
        candidates: list[int] = [0]
        it = 0
        while it < cfg.max_iterations:
            for c in candidates if best_goal is None else []:  # line 1: a node near the goal, free path?
                if np.hypot(*(self.xy[c] - goal)) <= cfg.goal_radius:
                    best_goal = self.insert(goal.copy(), c)  # the goal joins the tree (later rewires improve it)
            candidates = []
            if best_goal is not None and cfg.stop_at_goal:
                break
            reserve = SIMPLIFY_SHARE * p.time_limit if best_goal is not None and cfg.simplify else 0.0
            if clock.remaining() <= reserve:
                break
            it += 1
            q_rand = self.sample_biased(prev)
            d2 = np.sum(np.square(self.xy[: self.n] - q_rand[:2]), axis=1)
            nearest = int(np.argmin(d2))
            dist = float(np.sqrt(d2[nearest]))
            if dist < 1e-9:
                continue
            q_new = self.xy[nearest] + min(1.0, cfg.max_step / dist) * (q_rand[:2] - self.xy[nearest])
            new = self.insert(q_new, nearest)
            if new is not None:
                prev = self.xy[new].copy()
                candidates = [new]
        return best_goal, it

    def why_unreached(self, it: int, gap: float) -> str:
        """The reason of a run that ended without reaching the goal after ``it`` iterations, its partial
        path ending ``gap`` [m] from the goal."""
        cfg, limit = self.cfg, self.problem.time_limit
        if it >= cfg.max_iterations:
            spent = f"{it} iterations"
        elif it == 0:
            spent = (
                f"the {limit:g} s time limit, which passed before the first sample (the 2-D check that some way "
                f"keeps the clearance took {self.proof_s:.3f} s of it)"
            )
        else:
            spent = f"the {limit:g} s time limit ({it} iterations)"
        return (
            f"no node reached the goal region ({cfg.goal_radius:g} m) with a free straight segment within "
            f"{spent}; the partial path ends {gap:.3f} m from the goal{self._no_route()}"
        )

    def _no_route(self) -> str:
        """What a run that did not reach the goal may add: that no 2-D route over :data:`NO_ROUTE_CELL` cells keeps
        the clearance and a millimetre (a way between cell centres, keeping the clearance by less than half a cell's
        diagonal, is not seen; the sampler almost never lands in such a pinch: random worlds 1005, 1012 and 1014 for
        the EduMIP), with what to do; "" when one does, or when looking would take longer than :data:`NO_ROUTE_S` or
        than the time limit leaves (a run its time limit ended has nothing left for it)."""
        p, radius = self.problem, self.required + 1e-3
        cell = p.world.grid_spacing(NO_ROUTE_CELL, geodesic.MAX_CELLS)
        left = min(NO_ROUTE_S, self.clock.remaining())
        if left <= 0.0:
            return ""
        try:
            deadline = time.perf_counter() + left
            way = geodesic.route(p.world, p.start.as_array(), p.goal.as_array(), radius, cell, deadline=deadline)
        except FieldTimeout:
            return ""
        if way is not None:
            return ""
        spare = 1e-3 + cell * math.sqrt(0.5)  # the millimetre asked, and half a cell's diagonal
        return (
            f"; a 2-D route search over {cell:g} m cells finds no way keeping the axle centre {radius:.4g} m from "
            f"every obstacle and wall either: a way that keeps the clearance, if any, passes a pinch with under "
            f"{spare * 1000:.0f} mm to spare, where samples almost never land; lower center_clearance, or plan with "
            "hybrid-a-star or rrt-star"
        )
