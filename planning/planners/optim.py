"""Trajectory optimisation of the kinematic bicycle with CasADi's Opti and IPOPT.

The horizon ``T = N dt`` is fixed; the decision variables are the states ``X`` (4, N+1)
``[x, y, theta, phi]`` at the nodes and the inputs ``U`` (2, N) ``[u1, u2]`` held over each interval.

- Dynamics: multiple shooting, one classical RK4 step per interval: ``X[:, k+1] = RK4(X[:, k], U[:, k], dt)``.
- Start and goal: equality constraints on the whole state (steering angle 0 at both ends); the goal
  heading is taken on the branch nearest the start heading (or the warm start's final heading).
- Bounds: ``|u1| <= max_speed``, ``|u2| <= u2max``, ``|phi| <= phimax``, yaw rate
  ``|u1 tan(phi) / l| <= max_yaw_rate`` at both ends of each interval (hence all along it), and
  the robot's disc (radius + ``margin``) inside the walls.
- Obstacles, all smooth and exact for the robot's disc of radius ``r`` (robot radius + ``margin``):
  circles as ``|p - c|^2 >= (R + r)^2``; ellipses, boxes and convex polygons by a separating line
  per node and obstacle with direction ``n = (cos psi, sin psi)`` (``psi`` an extra decision
  variable): ``n . (p - c) - h(n) >= r`` where ``h`` is the obstacle's support function about ``c``
  (ellipse: ``sqrt(a^2 (n.e1)^2 + b^2 (n.e2)^2)``; polygon: one constraint ``n . (p - v_i) >= r``
  per vertex). Since ``max_n`` of the left side is the distance from ``p`` to a convex set, the
  constraint is exactly ``distance >= r``. A non-convex polygon is replaced by its convex hull
  (conservative). Constraints hold at the nodes; ``margin`` covers the chord between nodes.
- Cost: ``sum(u1^2 + w_steer u2^2) dt + w_smooth sum(du1^2) / dt``: at fixed horizon the effort in
  ``u1`` is least for the shortest path driven at even speed, so it is also a length cost.

The NLP is built once per shape (N, obstacle kinds and vertex counts) and cached; start, goal,
dt, bounds and obstacle data are parameters, so repeated solves only set values and warm starts.
CasADi expands the graph to SX (``expand=True``) before IPOPT runs. A new shape's set-up comes before
IPOPT's first iteration callback, which holds a solve to the plan's time limit, so it is predicted
(:func:`_setup_units`, :data:`_SETUP_RATE`) and not begun when less than that is left (:meth:`Optim._ready_nlp`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import importlib
import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.casadi_env import SOLVER_LOCK, casadi_module
from planning.clock import PlanClock
from planning.core.checks import check_flag, check_number
from planning.core.geometry import cumulative_length, path_length, wrap_angle
from planning.core.kinematics import bicycle_to_unicycle
from planning.core.world import Box, Circle, Ellipse, Obstacle, Polygon, World
from planning.errors import ConfigError
from planning.planners.base import (
    START_TOLERANCE,
    PlanProblem,
    PlanResult,
    PlanStatus,
    checked_problem,
    end_outside,
)
from planning.planners.registry import PLANNERS, make_planner, planner_options
from planning.signals import signals_end_early, signals_held

FloatArray = NDArray[np.float64]

DEFAULT_N = 50
DEFAULT_DT = 0.2
#: Most intervals of a horizon: 100000 is refused by the set-up's predicted time already (726 s); ten million
#: took gigabytes before the prediction was made.
MAX_N = 100_000
#: Longest horizon N dt [s] of a given dt: the plan is rolled out every 10 ms over it (dt = 1e6 asked numpy for
#: 75 GiB; an hour is 360,000 poses).
MAX_HORIZON = 3600.0
#: Longest spacing [m] of the nodes along the warm start's path when N is not given: a long way gets more than
#: :data:`DEFAULT_N` nodes. The constraints hold at the nodes, and 50 nodes over a 27 m way through 60 obstacles
#: (0.55 m apart) left IPOPT out of time on two of four 20 x 20 m worlds of 60 obstacles
#: (:func:`sim.tools.bench.cold.world_toml` seeds 1-4, size 20, 60 obstacles, scale 0.8; TurtleBot3); one node
#: per 0.2 m solves all four in 2-6 s. Ways up to 10 m (every built-in scenario, the 6 x 6 m random worlds) keep
#: their 50.
NODE_SPACING = 0.2
_BUILTIN_INITS = ("auto", "straight", "grid")
_SUCCESS = {"Solve_Succeeded", "Solved_To_Acceptable_Level"}
_TIMEOUT = {"Maximum_CpuTime_Exceeded", "Maximum_Iterations_Exceeded", "Maximum_WallTime_Exceeded"}
_INFEASIBLE = {"Infeasible_Problem_Detected"}
#: Stretches of the estimated horizon (the warm start at the speed and yaw-rate limits, plus 1 s) a solve tries in
#: turn, the next when IPOPT fails from every warm start. The first leaves a quarter more than the estimate: at the
#: estimate itself the EduMIPs' solves on larger worlds ran out of time where a little slack solves them in seconds.
#: Measured in one process per setting (plans only, 30 s limit, the adaptive barrier update, 2026-12-06): on eight
#: 8-12 m worlds of 15-35 obstacles (:func:`sim.tools.bench.cold.world_toml` seeds 8101-8108) and random5000-5011,
#: three robots each, first stretch 1.0: 57 of 60 solved in 168 s; 1.25: 60 of 60 in 70 s; 1.5: 59 of 60 in 86 s.
#: On eight 14-20 m worlds of 40-60 obstacles (seeds 1-4: 20 m, 60, scale 0.8; 11, 12: 15 m, 40, 0.7; 13: 14 m,
#: 50, 0.5; 14: 16 m, 45, 0.9): 16, 18 and 18 of 24 (1.25 losing none that 1.0 solved; 1.5 lost one), 323, 285
#: and 306 s. Lengths moved by less than 1 % in the median.
HORIZON_STRETCH = (1.25, 1.875, 2.8125)
#: IPOPT's barrier parameter update, ``mu_strategy``: ``"adaptive"`` (Nocedal, Waechter and Waltz's
#: quality-function rule) rather than IPOPT's default monotone decrease. Measured with both in one process, per
#: world (plans only, 30 s limit, 2026-12-06): on the generated worlds random5000-5039, three robots each, both
#: solved all 120, adaptive in 36.9 s together against 50.8 s (each 0.86 of the time in the median, lengths
#: equal in the median, 0.98-1.04 apart at most); on 12 larger generated worlds (12-50 m, 15-80 obstacles) with
#: three robots each, adaptive solved 29 of 36 against 26, losing none, in 336 s against 433 s (0.81 of the time
#: in the median of the 26 both solved, lengths 0.98-1.01 apart). The EduMIPs gain most: their yaw-rate limit at
#: speed makes the NLP tight (300 iterations with the default where the TurtleBot3 took 30). ``mu_strategy``
#: chooses it per planner.
IPOPT_MU_STRATEGY = "adaptive"
#: The values of ``mu_strategy`` IPOPT takes.
MU_STRATEGIES = ("adaptive", "monotone")
#: Most obstacles the NLP keeps clear of (every built-in scenario has at most 31): beyond it, those nearest
#: the warm start, and any a solution comes near (:meth:`Optim._solve_with_margin`).
MAX_NLP_OBSTACLES = 32
#: Solves from one warm start that may add the obstacles a solution came near.
SELECTION_ROUNDS = 4
#: Modules a plan uses that making the planner does not import (SciPy's convex hull of a polygon; the grid route
#: and its sparse graphs): a new process's first plan imports them (:meth:`Optim._load_code`, 0.1-0.2 s), so its
#: reported time holds them, where making the planner imported them unseen by any plan's time.
PLAN_MODULES = ("scipy.spatial", "planning.planners.gridpath")


def _casadi() -> Any:
    return casadi_module("the 'optim' planner")


@functools.cache
def _ipopt_plugin() -> None:
    """Load CasADi (:func:`_casadi`) and its IPOPT plugin (its shared libraries) once a process."""
    _casadi().load_nlpsol("ipopt")


#: Why a plan ended waiting for CasADi's solver (:func:`_solver_turn`); ``limit`` the plan's time limit [s].
_SOLVER_BUSY = (
    "the plan's time limit ({limit:g} s) passed while another thread of this process held CasADi's solver (IPOPT "
    "solves one problem at a time in a process); plan in processes to plan at once"
)


@contextlib.contextmanager
def _solver_turn(clock: PlanClock) -> Iterator[bool]:
    """Hold CasADi's lock (:data:`planning.casadi_env.SOLVER_LOCK`) for the block, waited for until the plan's
    time limit at most: yields whether it was had."""
    had = SOLVER_LOCK.acquire(timeout=max(clock.remaining(), 0.0))
    try:
        yield had
    finally:
        if had:
            SOLVER_LOCK.release()


def _walled_off(problem: PlanProblem, sol: OptimSolution, clock: PlanClock, disc: float) -> OptimSolution:
    """``sol``, a failure, as INFEASIBLE when a 2-D proof finds the goal walled off, within what is left of the time
    limit (IPOPT's local failure shows no such thing): for the robot's inscribed disc (the tree planners' proof,
    :func:`planning.planners.sampling.tree.walled_off_proof`: no path for the robot), else for the disc of radius
    ``disc`` the NLP keeps clear along its whole rollout (the robot's radius and the margin: no path for optim,
    where planners of the footprint may find one). A goal sealed in a corner was "failed", where rrt,
    hybrid-a-star and c-rrt-star said why no path exists; a gap only the footprint passes "may not" have passed."""
    from planning.collision.field import FieldTimeout
    from planning.planners.geodesic import walled_off_reason
    from planning.planners.sampling.tree import walled_off_proof

    try:
        proved = walled_off_proof(problem, "footprint", 0.0)(clock.deadline())
        if proved is None:
            proved = walled_off_reason(
                problem.world,
                (problem.start.xy, problem.goal.xy),
                disc,
                clock.deadline(),
                problem.position_tolerance,
                keeps=f"the disc optim keeps clear (radius {disc:.3f} m: the robot's {problem.robot.radius:.3f} m and "
                "the margin)",
                fix="planners that check the footprint itself (hybrid-a-star, rrt) may pass",
            )
    except FieldTimeout:
        return sol
    if proved is None:
        return sol
    res = sol.result
    ended = res.reason.split(" (")[0]  # IPOPT's status, or why the solve was a failure after it
    if ended.startswith("IPOPT: "):
        ended = "IPOPT ended " + ended.removeprefix("IPOPT: ")
    reason = f"{proved} ({ended})"
    return OptimSolution(dataclasses.replace(res, status=PlanStatus.INFEASIBLE, reason=reason), sol.nodes, sol.inputs)


def _ipopt_failed(sol: OptimSolution) -> bool:
    """IPOPT itself failed the solve (a local infeasibility or its iteration limit), not the time limit."""
    stats = sol.result.stats
    return stats.get("ipopt_status") not in (None, *_SUCCESS) and not stats.get("time_limit_reached")


def polygon_vertices(obstacle: Obstacle) -> FloatArray:
    """Counter-clockwise vertices (K, 2) of a box or of a polygon's convex hull [m]."""
    if isinstance(obstacle, Box):
        return np.asarray(obstacle.corners(), dtype=float)
    if isinstance(obstacle, Polygon):
        from scipy.spatial import ConvexHull  # a plan's import (:data:`PLAN_MODULES`)

        v = obstacle.array
        return np.asarray(v[ConvexHull(v).vertices], dtype=float)
    raise TypeError(f"{obstacle.kind} has no vertices")


@nb.njit(cache=True)
def bicycle_rollout(state0: FloatArray, inputs: FloatArray, dt: float, wheelbase: float) -> FloatArray:
    """Classical RK4 of the bicycle under piecewise-constant inputs, one step per input (compiled).

    Same method as :func:`planning.core.kinematics.rollout` with :func:`planning.core.kinematics.bicycle_rhs`
    (the test's reference), written with scalar math: a plan's dense rollout takes a step every 10 ms, and a
    horizon of minutes (a 1000 m world) took seconds in Python, past the plan's time limit.

    Args:
        state0: (4,) [x, y, theta, phi].
        inputs: (K, 2) [u1, u2], each held for ``dt``.
        dt: Step [s].
        wheelbase: l [m].

    Returns:
        (K + 1, 4) states.
    """
    cos, sin, tan = math.cos, math.sin, math.tan
    out = np.empty((inputs.shape[0] + 1, 4))
    x, y, th, ph = state0[0], state0[1], state0[2], state0[3]
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = x, y, th, ph
    h2, h6, il = 0.5 * dt, dt / 6.0, 1.0 / wheelbase
    for k in range(inputs.shape[0]):
        u1, u2 = inputs[k, 0], inputs[k, 1]
        w1 = u1 * tan(ph) * il
        a1, b1 = u1 * cos(th), u1 * sin(th)
        th2, ph2 = th + h2 * w1, ph + h2 * u2
        w2 = u1 * tan(ph2) * il
        a2, b2 = u1 * cos(th2), u1 * sin(th2)
        th3 = th + h2 * w2
        w3 = u1 * tan(ph2) * il  # phi at the midpoint is the same for k2 and k3
        a3, b3 = u1 * cos(th3), u1 * sin(th3)
        th4, ph4 = th + dt * w3, ph + dt * u2
        w4 = u1 * tan(ph4) * il
        a4, b4 = u1 * cos(th4), u1 * sin(th4)
        x += h6 * (a1 + 2 * a2 + 2 * a3 + a4)
        y += h6 * (b1 + 2 * b2 + 2 * b3 + b4)
        th += h6 * (w1 + 2 * w2 + 2 * w3 + w4)
        ph = ph4
        out[k + 1, 0], out[k + 1, 1], out[k + 1, 2], out[k + 1, 3] = x, y, th, ph
    return out


def dense_clearance(problem: PlanProblem, path: FloatArray) -> float:
    """Smallest clearance of the robot's disc along a dense path [m] (negative: overlap).

    Args:
        problem: The world and robot.
        path: (M, 2+) positions along the motion [m].

    Returns:
        min over the path of the signed distance to obstacles and walls minus the robot's radius.
    """
    return float(np.min(problem.world.signed_distance(np.asarray(path)[:, :2])) - problem.robot.radius)


@dataclass
class _Obstacles:
    """The obstacle parameters of a built NLP and the separating-line angles it adds as variables.

    Attributes:
        circles: (3, n) parameter [cx, cy, R] per circle, or None without circles.
        ellipses: (5, n) parameter [cx, cy, a, b, angle] per ellipse, or None without ellipses.
        polys: One (2, k) vertex parameter per convex polygon.
        psi: One (1, N+1) angle variable per ellipse, then per polygon.
    """

    circles: Any
    ellipses: Any
    polys: list[Any]
    psi: list[Any]


@dataclass
class _Nlp:
    """A built Opti problem and its handles (states x, inputs u, and the parameters set per solve)."""

    opti: Any
    x: Any
    u: Any
    p_start: Any
    p_goal: Any
    p_dt: Any
    p_bounds: Any
    p_limits: Any
    p_wheelbase: Any
    p_clear: Any
    obstacles: _Obstacles
    verbose: bool
    deadline: Any  # the solve's iteration callback (see _deadline): set its ``at`` before each solve


_CACHE: dict[tuple[Any, ...], _Nlp] = {}

#: Seconds of CPU a new NLP shape's set-up (building the Opti problem, then CasADi's expansion and derivatives
#: and IPOPT's start up to its first iteration callback) takes per unit of :func:`_setup_units`: the last one
#: measured in this process; before it, the median of 80 shapes of the generated worlds random3000-3039 (both
#: robots) on a two-core machine, whose quiet runs measured 61-66 us of wall time (under other load up to
#: 130 us: hence the CPU, and the plan's own :meth:`~planning.clock.PlanClock.slowdown` for the wall).
_SETUP_RATE = [6.5e-5]


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _setup_units(key: tuple[Any, ...]) -> float:
    """The size a set-up's time goes with, of an NLP of cache key ``key``: its constraint rows, an ellipse's
    counted 2.2 times (its support function), and 100 for what any shape costs. Measured against it, worlds of
    ellipses, boxes, pentagons and a mix set up at 57-64 us a unit, of 16-32 circles at 46-48 us."""
    n, n_circ, n_ell, poly_k = key[:4]
    rows = 4 * n + 8 + 3 * (n + 1) + 4 * n + (n + 1) * (n_circ + sum(poly_k))
    return float(rows + 2.2 * (n + 1) * n_ell + 100)


@dataclass(frozen=True)
class _ObstacleData:
    """The obstacles the NLP takes (:func:`_nlp_obstacles`): circles, ellipses, and boxes and polygons as
    convex vertex arrays (K, 2) [m], and their indices among the world's."""

    circles: list[Circle]
    ellipses: list[Ellipse]
    polys: list[FloatArray]
    indices: tuple[int, ...]

    @classmethod
    def of(cls, problem: PlanProblem, near: FloatArray, keep: frozenset[int] = frozenset()) -> _ObstacleData:
        """The world's obstacles, at most :data:`MAX_NLP_OBSTACLES` of them: those nearest ``near`` (M, 2)
        [m] (the guess's positions), and every one in ``keep``."""
        idx = _nlp_obstacles(problem.world, near, keep)
        obs = [problem.world.obstacles[i] for i in idx]
        return cls(
            [o for o in obs if isinstance(o, Circle)],
            [o for o in obs if isinstance(o, Ellipse)],
            [polygon_vertices(o) for o in obs if isinstance(o, (Box, Polygon))],
            idx,
        )

    @property
    def counts(self) -> tuple[int, int, tuple[int, ...]]:
        """What the NLP's shape depends on: circle and ellipse counts, the polygons' vertex counts."""
        return len(self.circles), len(self.ellipses), tuple(v.shape[0] for v in self.polys)

    def missed(self, problem: PlanProblem, path: FloatArray, clear: float) -> frozenset[int]:
        """The obstacles left out of the NLP that ``path`` (M, 2+) comes within ``clear`` [m] of."""
        world, taken = problem.world, set(self.indices)
        out = [i for i in range(len(world.obstacles)) if i not in taken]
        if not out:
            return frozenset()
        xy = np.asarray(path)[:, :2]
        lo, hi = xy.min(axis=0) - clear, xy.max(axis=0) + clear
        near = []
        for i in out:  # those whose bounding box reaches the path's
            x0, x1, y0, y1 = world.obstacles[i].bounding_box()
            if x0 <= hi[0] and x1 >= lo[0] and y0 <= hi[1] and y1 >= lo[1]:
                near.append(i)
        return frozenset(i for i, d in zip(near, _least_distances(world, near, xy), strict=True) if d < clear)


#: Speed [m/s] below which an input of the plan stands rather than drives (IPOPT's zero: a plan whose start is
#: its goal had inputs of 1e-7 m/s of either sign, "1 cusp" over a micrometre).
STAND_SPEED = 1e-6


def _directions(speeds: FloatArray) -> FloatArray:
    """(K+1,) +1/-1 per pose of the rollout of (K,) held speeds [m/s]: the direction of the motion arriving at each
    pose (the first repeats the first step's); a speed under :data:`STAND_SPEED` keeps the direction before it
    (the first drive's before any), +1 for a plan that never drives."""
    sign = np.where(speeds < 0, -1.0, 1.0)
    driving = np.abs(speeds) >= STAND_SPEED
    if not driving.any():
        return np.ones(speeds.size + 1)
    last = np.maximum.accumulate(np.where(driving, np.arange(speeds.size), -1))
    arriving = sign[np.where(last >= 0, last, int(np.argmax(driving)))]
    return np.concatenate([arriving[:1], arriving])


def _least_distances(world: World, indices: Sequence[int], points: FloatArray) -> FloatArray:
    """(len(indices),) each obstacle's least signed distance to ``points`` (M, 2) [m] (compiled: a 2000-obstacle
    world's took 0.14 s obstacle by obstacle, half a 0.3 s limit)."""
    from planning.collision.compiled import least_obstacle_distances, world_arrays

    xy = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))
    return least_obstacle_distances(xy, world_arrays(world), np.asarray(indices, dtype=np.int64))  # type: ignore[no-any-return]


def _nlp_obstacles(world: World, near: FloatArray, keep: frozenset[int]) -> tuple[int, ...]:
    """Indices of the obstacles the NLP takes, in the world's order: all of them up to
    :data:`MAX_NLP_OBSTACLES`; beyond it ``keep`` and those nearest the positions ``near`` (M, 2) [m]."""
    n = len(world.obstacles)
    if n <= MAX_NLP_OBSTACLES:
        return tuple(range(n))
    dist = _least_distances(world, range(n), near)
    dist[list(keep)] = -np.inf
    return tuple(sorted(int(i) for i in np.argsort(dist, kind="stable")[: max(MAX_NLP_OBSTACLES, len(keep))]))


@dataclass(frozen=True)
class OptimSolution:
    """A plan with the optimiser's own variables.

    Attributes:
        result: The plan (dense rollout of the inputs from the start).
        nodes: (N+1, 4) node states [x, y, theta, phi] as IPOPT left them (None if it never ran).
        inputs: (N, 2) inputs [u1, u2] held over each interval (None if IPOPT never ran).
    """

    result: PlanResult
    nodes: FloatArray | None = None
    inputs: FloatArray | None = None


def _rk4_map(ca: Any, n: int) -> Any:
    """One classical RK4 step of the bicycle (state, input, step, wheelbase) mapped over ``n`` intervals."""
    s, a, h, lb = ca.SX.sym("s", 4), ca.SX.sym("a", 2), ca.SX.sym("h"), ca.SX.sym("l")

    def f(st: Any) -> Any:
        return ca.vertcat(a[0] * ca.cos(st[2]), a[0] * ca.sin(st[2]), a[0] * ca.tan(st[3]) / lb, a[1])

    k1 = f(s)
    k2 = f(s + h / 2 * k1)
    k3 = f(s + h / 2 * k2)
    k4 = f(s + h * k3)
    return ca.Function("rk4", [s, a, h, lb], [s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)]).map(n)


def _obstacle_constraints(
    ca: Any, opti: Any, x: Any, p_clear: Any, n_circ: int, n_ell: int, poly_k: tuple[int, ...]
) -> _Obstacles:
    """Keep the robot's disc (radius ``p_clear``) off every obstacle at every node (see the module doc)."""
    n1 = x.shape[1]
    px, py = x[0, :], x[1, :]
    p_circles: Any = opti.parameter(3, n_circ) if n_circ else None
    for j in range(n_circ):
        c = p_circles[:, j]
        opti.subject_to((px - c[0]) ** 2 + (py - c[1]) ** 2 >= (c[2] + p_clear) ** 2)
    psi: list[Any] = []
    p_ellipses: Any = opti.parameter(5, n_ell) if n_ell else None
    for j in range(n_ell):
        e = p_ellipses[:, j]
        ps = opti.variable(1, n1)
        psi.append(ps)
        support = ca.sqrt((e[2] * ca.cos(ps - e[4])) ** 2 + (e[3] * ca.sin(ps - e[4])) ** 2)
        opti.subject_to(ca.cos(ps) * (px - e[0]) + ca.sin(ps) * (py - e[1]) - support >= p_clear)
    p_polys = []
    for kv in poly_k:
        vp = opti.parameter(2, kv)
        p_polys.append(vp)
        ps = opti.variable(1, n1)
        psi.append(ps)
        for i in range(kv):
            opti.subject_to(ca.cos(ps) * (px - vp[0, i]) + ca.sin(ps) * (py - vp[1, i]) >= p_clear)
    return _Obstacles(p_circles, p_ellipses, p_polys, psi)


def _deadline(ca: Any) -> Any:
    """An IPOPT iteration callback that asks IPOPT to stop (it returns User_Requested_Stop with its
    last iterate) once ``time.perf_counter()`` passes the callback's ``at``, which each solve sets
    from its plan's time limit: one limit for the whole plan, warm start and re-solves included.
    IPOPT's own ``max_cpu_time`` would be one per solve, fixed when the problem is built.

    It takes only the cost, not the iterate's vectors (empty inputs): with them every iteration
    copied the iterate into Python (nav_map1: 63 -> 79 ms a plan; without them no slower than no
    callback, within this machine's noise)."""

    class Deadline(ca.Callback):  # type: ignore[misc]
        def __init__(self) -> None:
            ca.Callback.__init__(self)
            self.at = math.inf
            self.first: float | None = None  # time.perf_counter() at the solve's first callback (iteration 0)
            self.first_cpu = 0.0  # time.thread_time() then
            self.construct("deadline", {})

        def get_n_in(self) -> int:
            return int(ca.nlpsol_n_out())

        def get_n_out(self) -> int:
            return 1

        def get_name_in(self, i: int) -> str:
            return str(ca.nlpsol_out(i))

        def get_name_out(self, i: int) -> str:
            return "ret"

        def get_sparsity_in(self, i: int) -> Any:
            return ca.Sparsity.scalar() if ca.nlpsol_out(i) == "f" else ca.Sparsity(0, 0)

        def eval(self, arg: Any) -> list[int]:
            if self.first is None:  # the CPU read first: the set-up's CPU time is never more than its wall time
                self.first_cpu = time.thread_time()
                self.first = time.perf_counter()
                return [int(self.first > self.at)]
            return [int(time.perf_counter() > self.at)]

    return Deadline()


def _build(key: tuple[Any, ...]) -> _Nlp:
    ca = _casadi()
    n, n_circ, n_ell, poly_k, w_steer, w_smooth, max_iter, verbose, mu_strategy = key
    opti = ca.Opti()
    x = opti.variable(4, n + 1)
    u = opti.variable(2, n)
    p_start, p_goal = opti.parameter(4), opti.parameter(4)
    p_dt, p_l, p_clear = opti.parameter(), opti.parameter(), opti.parameter()
    p_bounds, p_limits = opti.parameter(4), opti.parameter(4)
    opti.subject_to(x[:, 1:] == _rk4_map(ca, n)(x[:, :-1], u, p_dt, p_l))
    opti.subject_to(x[:, 0] == p_start)
    opti.subject_to(x[:, n] == p_goal)
    opti.subject_to(opti.bounded(p_bounds[0], x[0, :], p_bounds[1]))
    opti.subject_to(opti.bounded(p_bounds[2], x[1, :], p_bounds[3]))
    opti.subject_to(opti.bounded(-p_limits[2], x[3, :], p_limits[2]))
    opti.subject_to(opti.bounded(-p_limits[0], u[0, :], p_limits[0]))
    opti.subject_to(opti.bounded(-p_limits[1], u[1, :], p_limits[1]))
    # phi is linear in time within an interval and tan is monotone, so |u1 tan(phi) / l| peaks at an end.
    opti.subject_to(opti.bounded(-p_limits[3], u[0, :] * ca.tan(x[3, :-1]) / p_l, p_limits[3]))
    opti.subject_to(opti.bounded(-p_limits[3], u[0, :] * ca.tan(x[3, 1:]) / p_l, p_limits[3]))
    obstacles = _obstacle_constraints(ca, opti, x, p_clear, n_circ, n_ell, poly_k)
    du = u[0, 1:] - u[0, :-1]
    opti.minimize(p_dt * (ca.sumsqr(u[0, :]) + w_steer * ca.sumsqr(u[1, :])) + w_smooth * ca.sumsqr(du) / p_dt)
    ipopt = {
        "print_level": 5 if verbose else 0,
        "sb": "yes",
        "max_iter": max_iter,
        "tol": 1e-8,
        "mu_strategy": mu_strategy,
    }
    deadline = _deadline(ca)
    plugin = {"expand": True, "print_time": bool(verbose), "error_on_fail": False, "iteration_callback": deadline}
    opti.solver("ipopt", plugin, ipopt)
    return _Nlp(opti, x, u, p_start, p_goal, p_dt, p_bounds, p_limits, p_l, p_clear, obstacles, verbose, deadline)


def _check_init_options(init: str, options: dict[str, Any]) -> None:
    """``init_options`` are options of the warm start's planner (``init`` a registered planner), checked as that
    planner checks them when it is made (names and values); the built-in warm starts take none.

    Raises:
        ConfigError: Options for a built-in warm start, or options the planner does not take (names them).
    """
    if not options:
        return
    if init in _BUILTIN_INITS:
        raise ConfigError(
            f"optim: init_options ({', '.join(sorted(options))}) are a warm-start planner's options, and "
            f"init={init!r} is none; give init=<planner> (e.g. init='hybrid-a-star') or drop init_options"
        )
    valid = planner_options(init)
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ConfigError(
            f"optim: init_options: unknown option(s) {', '.join(unknown)} for the warm start's planner {init!r}: "
            f"valid options are {', '.join(valid)}"
        )
    try:
        make_planner(init, **options)  # its values too, now: plan() returns a status, it does not raise
    except ConfigError as exc:
        raise ConfigError(f"optim: init_options for the warm start's planner {init!r}: {exc}") from None


def casadi_reason(exc: BaseException) -> str:
    """The cause a CasADi error ends with (its last line; the lines before it are CasADi's call stack)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[-1] if lines else type(exc).__name__


class Optim:
    """Bicycle-model trajectory optimisation (CasADi Opti + IPOPT).

    Args:
        N: Number of intervals; None: :data:`DEFAULT_N`, or one per :data:`NODE_SPACING` of the warm start's
            path where that is more (the straight line's length for a straight start).
        dt: Interval length [s]; the horizon is ``N * dt``. Default (None): ``DEFAULT_DT``, lengthened
            when the warm start's path needs more than ``N * DEFAULT_DT - 1 s`` at full speed and
            full turn rate, to ``(length / max_speed + turning / max_yaw_rate + 1 s) / N`` (turning:
            the total heading change along the warm start); give ``dt`` to fix the horizon. A
            horizon too short for the turns (the EduMIP turns at 0.5 rad/s) leaves IPOPT pressing
            on the yaw-rate bound: parking lot, EduMIP took 260 iterations and 26 s, now 68 and 5 s.
        init: Warm start: "auto" (with obstacles Hybrid-A*'s plan for the robot's disc, then the grid's
            route if IPOPT fails from it; else "sinusoidal"; see :meth:`_warm_starts`), "straight" (line
            from start to goal), "grid" (shortest free polyline on a grid,
            :mod:`planning.planners.gridpath`) or the name of a registered planner whose path is
            resampled onto the nodes by arc length (e.g. "rrt-star", "sinusoidal").
        init_options: Options for the warm-start planner.
        u2max: Steering-rate bound [rad/s].
        margin: Clearance added to the robot's radius [m].
        w_steer: Weight of u2^2 in the cost.
        w_smooth: Weight of the u1 increments in the cost.
        max_iter: IPOPT iteration limit.
        mu_strategy: IPOPT's barrier parameter update, "adaptive" (:data:`IPOPT_MU_STRATEGY`) or "monotone"
            (IPOPT's own default).
        max_resolves: Re-solves with a larger margin when the dense rollout cuts an obstacle
            between nodes (see :meth:`solve`).
        verbose: Let IPOPT print.
    """

    name = "optim"

    def __init__(
        self,
        *,
        N: int | None = None,
        dt: float | None = None,
        init: str = "auto",
        init_options: dict[str, Any] | None = None,
        u2max: float = 2.0,
        margin: float = 0.01,
        w_steer: float = 0.01,
        w_smooth: float = 0.01,
        max_iter: int = 3000,
        mu_strategy: str = IPOPT_MU_STRATEGY,
        max_resolves: int = 3,
        verbose: bool = False,
    ) -> None:
        given = check_number("optim: N", N, integer=True, at_least=2, at_most=MAX_N, optional=True)
        self.N_opt = None if given is None else int(given)
        self.N: int = DEFAULT_N if self.N_opt is None else self.N_opt
        self.dt_opt = check_number("optim: dt", dt, above=0.0, optional=True)
        self.dt = DEFAULT_DT if self.dt_opt is None else self.dt_opt
        if self.dt_opt is not None and self.N * self.dt > MAX_HORIZON:
            raise ConfigError(
                f"optim: N dt = {self.N} x {self.dt:g} s = {self.N * self.dt:g} s, a horizon longer than "
                f"{MAX_HORIZON:g} s (the plan is rolled out every 10 ms over it): give a smaller dt or N"
            )
        self.u2max = check_number("optim: u2max", u2max, above=0.0)
        self.margin = check_number("optim: margin", margin, at_least=0.0)
        self.w_steer = check_number("optim: w_steer", w_steer, at_least=0.0)
        self.w_smooth = check_number("optim: w_smooth", w_smooth, at_least=0.0)
        self.max_iter = check_number("optim: max_iter", max_iter, integer=True, at_least=1)
        self.max_resolves = check_number("optim: max_resolves", max_resolves, integer=True, at_least=0)
        if mu_strategy not in MU_STRATEGIES:
            raise ConfigError(
                f"optim: mu_strategy must be one of {', '.join(MU_STRATEGIES)} (IPOPT's barrier parameter "
                f"update), got {mu_strategy!r}"
            )
        self.mu_strategy = mu_strategy
        if init not in _BUILTIN_INITS and init not in PLANNERS:
            raise ConfigError(
                f"optim: init {init!r} is neither one of {', '.join(_BUILTIN_INITS)} nor a registered planner "
                f"({', '.join(sorted(PLANNERS)) or 'none'}); use init='auto' or register the planner"
            )
        if init == self.name:
            raise ConfigError("optim: init='optim' would warm start from itself; choose 'straight' or another planner")
        if not isinstance(init_options, (dict, type(None))):
            raise ConfigError(
                f"optim: init_options must be a table of the warm-start planner's options, got {init_options!r}"
            )
        _check_init_options(init, init_options or {})
        self.init = init
        self.init_options = dict(init_options or {})
        self.verbose = check_flag("optim: verbose", verbose)
        self._stretch = 1.0  # the horizon's stretch over its estimate (solve)
        self._warm_paths: dict[str, tuple[FloatArray | None, str]] = {}  # by warm start, this plan's (solve)

    # -- warm start ----------------------------------------------------------------------------
    def _warm_path(self, problem: PlanProblem, init: str, options: dict[str, Any]) -> tuple[FloatArray | None, str]:
        """The path warm start ``init`` gives (None: start from a straight line) and where it came from."""
        s = problem.start.as_array()
        if init == "grid":
            from planning.planners.gridpath import grid_path  # a plan's import (:data:`PLAN_MODULES`)

            clear = problem.robot.radius + self.margin + 0.01
            within = PlanClock(problem.time_limit)  # what is left of the plan's limit (:meth:`_guess`)
            poly = grid_path(problem.world, problem.start.xy, problem.goal.xy, clear, clock=within)
            if poly is not None and poly.shape[0] >= 2:
                heading = np.arctan2(np.diff(poly[:, 1]), np.diff(poly[:, 0]))
                heading = np.unwrap(np.concatenate([[s[2]], heading]))
                return np.column_stack([poly, heading]), init
            if within.expired():  # (spent: the plan's clock is too, and the solve says the grid took it)
                return None, init
            return None, "straight (no free route on the grid)"
        if init == "straight":
            return None, init
        res = make_planner(init, **options).plan(problem)
        if res.path.shape[0] >= 2 and res.status in (PlanStatus.SUCCESS, PlanStatus.BOUNDS_VIOLATED):
            return res.path, init
        if res.status is PlanStatus.SUCCESS:  # a path of one pose: the start is the goal
            return None, f"straight (init planner {init!r} gave a single pose)"
        return None, f"straight (init planner {init!r} ended {res.status.value})"

    def _initial_guess(
        self, problem: PlanProblem, init: str, options: dict[str, Any]
    ) -> tuple[FloatArray, FloatArray, str]:
        """Node states (N+1, 4) and inputs (N, 2) to start IPOPT from, and where they came from
        (``init`` and ``options``: the warm start and its planner's options, as ``self.init``)."""
        s = problem.start.as_array()
        if init not in self._warm_paths:  # one per plan: the margin's re-solves and the stretches reuse it
            self._warm_paths[init] = self._warm_path(problem, init, options)
        path, source = self._warm_paths[init]
        if path is None:
            g = np.array([problem.goal.x, problem.goal.y, s[2] + float(wrap_angle(problem.goal.theta - s[2]))])
            n = self._nodes_for(float(np.hypot(*(g - s)[:2])))
            tau = np.linspace(0.0, 1.0, n + 1)
            xs = s[None, :] + tau[:, None] * (g - s)[None, :]
        else:
            arc = cumulative_length(path)
            n = self._nodes_for(float(arc[-1]))
            tau = np.linspace(0.0, 1.0, n + 1)
            if arc[-1] <= 1e-9:
                arc = np.linspace(0.0, 1.0, path.shape[0])
            q = tau * arc[-1]
            theta = np.unwrap(path[:, 2])
            xs = np.column_stack(
                [np.interp(q, arc, path[:, 0]), np.interp(q, arc, path[:, 1]), np.interp(q, arc, theta)]
            )
        # The goal heading on the branch nearest the guess's final heading.
        xs[-1, 2] = xs[-1, 2] + float(wrap_angle(problem.goal.theta - xs[-1, 2]))
        x0 = np.column_stack([xs, np.zeros(n + 1)])
        d = np.diff(xs[:, :2], axis=0)
        if self.dt_opt is None:  # lengthen the horizon for a long way round or a lot of turning
            turn = float(np.sum(np.abs(np.diff(xs[:, 2]))))
            need = (
                float(np.sum(np.hypot(d[:, 0], d[:, 1]))) / problem.robot.max_speed
                + turn / problem.robot.max_yaw_rate
                + 1.0
            )
            self.dt = max(DEFAULT_DT, self._stretch * need / n)
        u1 = (d[:, 0] * np.cos(xs[:-1, 2]) + d[:, 1] * np.sin(xs[:-1, 2])) / self.dt
        lim = problem.robot.max_speed
        u0 = np.column_stack([np.clip(u1, -lim, lim), np.zeros(n)])
        return x0, u0, source

    def _nodes_for(self, length: float) -> int:
        """The intervals of a solve whose warm start is ``length`` [m] long (``N``, or see its default), kept in
        ``self.N`` for the solve."""
        if self.N_opt is None:
            self.N = max(DEFAULT_N, math.ceil(length / NODE_SPACING))
        return self.N

    # -- solving -------------------------------------------------------------------------------
    def plan(self, problem: PlanProblem) -> PlanResult:
        """Solve the NLP for ``problem``; every failure is a status with IPOPT's reason."""
        problem = checked_problem(problem)
        return self.solve(problem).result

    def solve(self, problem: PlanProblem) -> OptimSolution:
        """Like :meth:`plan`, also returning IPOPT's node states and inputs.

        The constraints hold at the nodes; between them the robot moves up to ``max_speed * dt``
        (16 cm for the EduMIP at the default dt) and a chord past a corner or a disc can come
        closer than the nodes. So the dense rollout's disc clearance is measured, and while it is
        negative the NLP is solved again with the margin raised by the shortfall plus ``5 mm``
        (``max_resolves`` times at most); a rollout that still cuts an obstacle moves on to the next warm
        start (``init="auto"``'s route after Hybrid-A*'s plan: on the generated world random405 the
        balancing EduMIP's solve from Hybrid-A*'s plan kept cutting a corner by 0.3 mm, the route's solved),
        and is a failure after the last one.

        Without a given ``dt`` the horizon is estimated as the warm start's length at the speed limit plus its
        turning at the yaw-rate limit plus 1 s, and stretched by the first of :data:`HORIZON_STRETCH`; the
        limits on acceleration and the bicycle's curvature at speed can need more. When IPOPT fails from every
        warm start (locally infeasible or out of iterations, not out of time), the whole is tried again with
        the next stretches in turn (``stats["horizon_stretch"]``).

        ``stats["time_s"]`` is the whole call's, from its start: the loading of code before the plan's clock
        starts (:meth:`_load_code`, numba's set-up: ``stats["code_s"]``, not held against the time limit) too.
        """
        called = time.perf_counter()
        code_s = self._load_code(problem)
        self._warm_paths = {}
        clock = PlanClock(problem.time_limit)  # numba readying code (Hybrid-A*'s kernels) is not held against it
        code_s += clock.setup_s  # numba's set-up, if this plan was the process's first to need it
        before = clock.t0 - called  # the loading and the set-up: the call's time before the clock
        stretches = HORIZON_STRETCH if self.dt_opt is None else (1.0,)
        stay = self._start_is_goal(problem, clock)
        if stay is not None:
            stay.result.stats.update(time_s=clock.elapsed() + before, code_s=clock.code() + code_s)
            return stay
        for stretch in stretches:
            self._stretch = stretch
            sol = self._solve_from_starts(problem, clock)
            if sol.result.success or not _ipopt_failed(sol) or clock.expired():
                break
        if sol.result.status is PlanStatus.FAILED:
            sol = _walled_off(problem, sol, clock, problem.robot.radius + self.margin)
        stats = sol.result.stats
        stats["horizon_stretch"] = self._stretch
        # loading code is in the plan's time, not held against its limit (as every planner's numba code)
        stats["time_s"] = stats.get("time_s", clock.elapsed()) + before
        stats["code_s"] = clock.code() + code_s
        return sol

    def _start_is_goal(self, problem: PlanProblem, clock: PlanClock) -> OptimSolution | None:
        """The start alone when it is the goal (to :data:`~planning.planners.base.START_TOLERANCE`), as every planner
        answers it (an NLP over a horizon with no motion failed IPOPT's restoration beside any obstacle), its ends
        judged as any plan's (:meth:`_ends_outside_disc`); else None."""
        start, goal = problem.start, problem.goal
        off = math.hypot(goal.x - start.x, goal.y - start.y)
        if off > START_TOLERANCE or abs(float(wrap_angle(goal.theta - start.theta))) > START_TOLERANCE:
            return None
        bad = self._ends_outside_disc(problem, clock, self.margin)
        if bad is not None:
            return bad
        path = start.as_array()[None, :]
        stats: dict[str, Any] = {"final_position_error": off, "length": 0.0, "iterations": 0}
        stats.update(final_heading_error=abs(float(wrap_angle(goal.theta - start.theta))))
        stats["min_clearance"] = dense_clearance(problem, path)
        result = PlanResult(
            PlanStatus.SUCCESS,
            self.name,
            path=path,
            stats=stats,
            times=np.zeros(1),
            controls=np.zeros((1, 2)),
            directions=np.ones(1),
            states=np.append(path[0], 0.0)[None, :],
        )
        return OptimSolution(result)

    def _load_code(self, problem: PlanProblem) -> float:
        """Import what the solve runs (:data:`PLAN_MODULES`, CasADi and its IPOPT plugin, the warm starts'
        planners) before its clock starts, as :mod:`planning.clock` leaves numba's loading out of a limit (a new
        process's first optim plan on nav_map1 spent its whole 0.2 s limit loading Hybrid-A*'s code for its warm
        start; the plugin's libraries were 2-3 ms of a process's first set-up of an NLP). The seconds it took (0.0
        under a millisecond: once loaded)."""
        t = time.perf_counter()
        for module in PLAN_MODULES:
            importlib.import_module(module)
        _ipopt_plugin()
        bicycle_rollout(np.zeros(4), np.zeros((1, 2)), 0.1, 1.0)  # compiled: loaded (or compiled) here
        for init, _ in self._warm_starts(problem):
            if init in PLANNERS:
                make_planner(init)
        took = time.perf_counter() - t
        return took if took >= 1e-3 else 0.0

    def _solve_from_starts(self, problem: PlanProblem, clock: PlanClock) -> OptimSolution:
        """:meth:`solve` at the current horizon: each warm start in turn, the margin raised as needed."""
        extra, attempt = 0.0, 0
        starts = self._warm_starts(problem)
        init = starts.pop(0)
        sol = self._solve_with_margin(problem, self.margin, clock, init)
        while True:
            res = sol.result
            if not res.success:
                if not (starts and self._worth_another_start(sol, problem, clock, init[0])):
                    return self._without_warm_start(problem, sol)
                init = starts.pop(0)
                sol = self._solve_with_margin(problem, self.margin + extra, clock, init)
                continue
            gap = dense_clearance(problem, res.path)
            res.stats.update(dense_disc_clearance=gap, margin_used=self.margin + extra, resolves=attempt)
            if gap >= 0.0:
                return sol
            if attempt == self.max_resolves:
                if not (starts and not clock.expired()):
                    break
                init, extra, attempt = starts.pop(0), 0.0, 0  # the next warm start, from the plain margin
                sol = self._solve_with_margin(problem, self.margin, clock, init)
                continue
            attempt += 1
            extra += -gap + 0.005
            sol = self._solve_with_margin(problem, self.margin + extra, clock, init)
        reason = (
            f"the robot's disc comes within {gap:.4f} m of an obstacle or wall between nodes even with the "
            f"margin raised to {self.margin + extra:.3f} m; use more nodes (N) or a shorter dt"
        )
        stats = dict(res.stats, time_s=clock.elapsed())
        failed = dataclasses.replace(res, status=PlanStatus.FAILED, reason=reason, stats=stats)
        return OptimSolution(failed, sol.nodes, sol.inputs)

    def _failure(self, status: PlanStatus, reason: str, stats: dict[str, Any]) -> OptimSolution:
        return OptimSolution(PlanResult(status, self.name, reason=reason, stats=stats))

    def _warm_starts(self, problem: PlanProblem) -> list[tuple[str, dict[str, Any]]]:
        """The warm starts to solve from, in turn (each later one only after IPOPT failed from the one
        before, :meth:`_worth_another_start`), as (init, planner options).

        ``init="auto"`` with obstacles starts from Hybrid-A*'s plan for the robot's disc (the disc
        the NLP keeps clear, plus the margin and 1 cm) with reversing free (``reverse_penalty`` 1), as
        the NLP's cost has it (even in the speed's sign), then from the grid's route. With Hybrid-A*'s
        default price of reversing (2), its forward plans led IPOPT to longer optima than the plans it
        used to simplify with plain length (on 6 of the 12 worlds both solved, 0.5-8 % longer; worlds
        9820-9834 of ``sim.tools.bench.cold.world_toml``, 15 s); with reversing free, 14 of the 15
        solved (13 before), as long as before on each world both solved but one (7.93 against 7.35 m).
        The route is a polyline a car cannot drive (corners, gaps only a disc takes): on 15 random 6-8 m worlds
        (TurtleBot3 and EduMIP, 15 s) IPOPT succeeded from it on 7, from Hybrid-A*'s plan on 14, in
        0.2-4.5 s against 0.6-12 s, never longer but by 0.1 %; the one world Hybrid-A*'s start failed on
        the route solved. Without obstacles, ``auto`` is the sinusoidal steering's path.
        """
        if self.init != "auto":
            return [(self.init, self.init_options)]
        if not problem.world.obstacles:
            return [("sinusoidal", {})]
        kinematic = {"shape": "disc", "clearance": self.margin + 0.01, "reverse_penalty": 1.0}
        return [("hybrid-a-star", kinematic), ("grid", {})]

    def _without_warm_start(self, problem: PlanProblem, sol: OptimSolution) -> OptimSolution:
        """A failed solve, its reason saying so when it started from a straight line because its warm start
        gave no path (``stats["init"]`` "straight (...)"): with obstacles, most often a gap the robot's disc
        (the disc the NLP keeps clear, and the warm starts' extra centimetre) does not fit."""
        res = sol.result
        source = str(res.stats.get("init", ""))
        if not source.startswith("straight (") or not problem.world.obstacles or res.status is PlanStatus.TIMEOUT:
            return sol
        disc = problem.robot.radius + self.margin
        reason = (
            f"{res.reason}; it started from a straight line, {source[len('straight (') : -1]}: the disc optim keeps "
            f"clear (radius {disc:.3f} m, the robot's {problem.robot.radius:.3f} m and the margin) may not pass this "
            "world's gaps, with the 1 cm the warm starts add; planners that check the footprint itself "
            "(hybrid-a-star, rrt) may"
        )
        return OptimSolution(dataclasses.replace(res, reason=reason), sol.nodes, sol.inputs)

    @staticmethod
    def _worth_another_start(sol: OptimSolution, problem: PlanProblem, clock: PlanClock, init: str) -> bool:
        """Whether a failed solve from warm start ``init`` may be tried again from the next one: IPOPT
        itself failed (a local infeasibility or its iteration limit, not the plan's time limit) or the
        warm start gave no path (IPOPT started from a straight line instead: the solve's ``init`` is
        then not ``init``), and time is left: not when what was left could not set IPOPT up (the next warm
        start's solve would need the same set-up, :meth:`_ready_nlp`)."""
        no_start = sol.result.stats.get("init", init) != init
        short = "setup_predicted_s" in sol.result.stats and "setup_s" not in sol.result.stats
        return (_ipopt_failed(sol) or no_start) and not short and not clock.expired()

    def _solve_with_margin(
        self, problem: PlanProblem, margin: float, clock: PlanClock, init: tuple[str, dict[str, Any]]
    ) -> OptimSolution:
        """One solve from warm start ``init`` with the robot's disc grown by ``margin`` [m]. In a world of more
        than :data:`MAX_NLP_OBSTACLES` obstacles the NLP holds those nearest the guess; while a solution comes
        within the disc of one left out, it is solved again from where IPOPT ended with that one added
        (:data:`SELECTION_ROUNDS` solves at most, within the plan's time limit)."""
        clear = problem.robot.radius + margin
        ends = self._ends_outside_disc(problem, clock, margin)
        if ends is not None:
            return ends
        x_init, u_init, source = self._guess(problem, clock, init)
        keep: frozenset[int] = frozenset()
        for _ in range(SELECTION_ROUNDS):
            obstacles = _ObstacleData.of(problem, x_init[:, :2], keep)
            sol = self._solve_nlp(problem, clear, clock, obstacles, (x_init, u_init, source))
            if not sol.result.success or sol.nodes is None or sol.inputs is None:
                break
            if clock.expired():
                break
            missed = obstacles.missed(problem, sol.result.path, clear)
            if not missed:
                break
            keep, x_init, u_init = keep | missed, sol.nodes, sol.inputs
        sol.result.stats["nlp_obstacles"] = len(obstacles.indices)
        return sol

    def _ends_outside_disc(self, problem: PlanProblem, clock: PlanClock, margin: float) -> OptimSolution | None:
        """The failure of a start or goal whose robot disc grown by ``margin`` (the disc optim keeps clear, at
        every node, the first and last too) overlaps an obstacle or wall; else None. With the margin raised
        past the one given (:meth:`_solve_from_starts`' re-solves) it is a failed plan, not a bad end."""
        outside = end_outside(problem, self.name, {"time_s": clock.elapsed()})
        if outside is not None:
            return OptimSolution(outside)
        from planning.collision.compiled import world_arrays, world_distances  # numpy's: 70 ms of 2000 obstacles

        robot, world = problem.robot, problem.world
        clear = robot.radius + margin
        for label, pose, status in (
            ("start", problem.start, PlanStatus.INVALID_START),
            ("goal", problem.goal, PlanStatus.INVALID_GOAL),
        ):
            dist = float(world_distances(np.array([pose.xy], dtype=float), world_arrays(world))[0])
            if dist >= clear:
                continue
            disc = (
                f"the {label}'s centre is {dist:.4f} m from the nearest obstacle or wall, so the disc optim keeps "
                f"off everything (the robot's radius {robot.radius:.4f} m and the margin {margin:.4f} m) overlaps it"
            )
            if margin > self.margin:
                reason = (
                    f"{disc}: the margin was raised from {self.margin:.4f} m because the path between nodes came "
                    "too close to an obstacle; use more nodes (N) or a shorter dt"
                )
                return self._failure(PlanStatus.FAILED, reason, {"time_s": clock.elapsed()})
            room = dist - robot.radius
            lower = f", give a margin below {room:.4f} m (margin=...)" if room > 0 else ""
            reason = (
                f"{disc}; move the {label} at least {clear - dist:.4f} m farther away{lower}, or plan with another "
                "planner (they check the footprint)"
            )
            return self._failure(status, reason, {"time_s": clock.elapsed()})
        return None

    def _guess(
        self, problem: PlanProblem, clock: PlanClock, init: tuple[str, dict[str, Any]]
    ) -> tuple[FloatArray, FloatArray, str]:
        """:meth:`_initial_guess` of warm start ``init``, its planner given what is left of the plan's time."""
        self.dt = DEFAULT_DT if self.dt_opt is None else self.dt_opt
        try:
            left = dataclasses.replace(problem, time_limit=max(1e-3, clock.remaining()))
            return self._initial_guess(left, *init)
        except ConfigError as exc:
            raise ConfigError(f"optim: warm start from {init[0]!r} failed: {exc}") from exc

    def _solve_nlp(
        self,
        problem: PlanProblem,
        clear: float,
        clock: PlanClock,
        obstacles: _ObstacleData,
        guess: tuple[FloatArray, FloatArray, str],
    ) -> OptimSolution:
        """IPOPT from ``guess`` (nodes (N+1, 4), inputs (N, 2), where they came from) on the NLP of
        ``obstacles``, the robot's disc of radius ``clear`` [m] kept off them, until the plan's time limit; the
        NLP set up, solved and read with CasADi's lock held (:func:`_solver_turn`)."""
        x_init, u_init, init_source = guess
        if clock.expired():
            # a warm start fallen back to a straight line ("straight (init planner 'x' ended timeout)"): its planner
            fell_back = init_source.startswith("straight (")
            spent_by = f"the warm start ({init_source[10:-1]})" if fell_back else f"the warm start from {init_source}"
            why = (
                f"the plan's time limit ({problem.time_limit:g} s) was spent before IPOPT could start ({spent_by} "
                f"took it); raise the time limit, or warm start from another planner with init=..."
            )
            return self._failure(PlanStatus.TIMEOUT, why, {"time_s": clock.elapsed(), "init": init_source})
        with _solver_turn(clock) as turn:
            if not turn:
                why = _SOLVER_BUSY.format(limit=problem.time_limit)
                return self._failure(PlanStatus.TIMEOUT, why, {"time_s": clock.elapsed(), "init": init_source})
            ready = self._ready_nlp(problem, clock, obstacles, init_source)
            if isinstance(ready, OptimSolution):
                return ready
            nlp, setup = ready
            self._set_values(nlp, problem, clear, obstacles, x_init[-1, 2])
            self._warm_start(nlp, x_init, u_init, obstacles)
            t_solve, cpu_solve = time.perf_counter(), time.thread_time()
            nlp.deadline.at = clock.deadline()  # the plan's limit, warm start and earlier solves in it
            nlp.deadline.first = None
            # CasADi ends a solve at a signal and swallows the interrupt: it is acted on as the solve returns,
            # and held while the results are read (see planning.signals)
            failed: RuntimeError | None = None
            with signals_end_early():
                try:
                    nlp.opti.solve_limited()
                except RuntimeError as exc:
                    failed = exc  # a failed solve raises; its status and last iterate are read below
            try:
                with signals_held():
                    ipopt_stats = nlp.opti.stats()
                    xv = np.asarray(nlp.opti.debug.value(nlp.x)).T
                    uv = np.asarray(nlp.opti.debug.value(nlp.u)).T.reshape(self.N, 2)
            except RuntimeError as exc:  # no solve to read: the solve's own error says why, not the reading's
                why = f"IPOPT stopped with an error: {casadi_reason(failed or exc)}"
                return self._failure(PlanStatus.FAILED, why, {"time_s": clock.elapsed(), "init": init_source})
        solve_s = time.perf_counter() - t_solve
        if nlp.deadline.first is not None:  # IPOPT reached its first iteration: the set-up is measured
            setup["setup_s"] = setup["build_time_s"] + nlp.deadline.first - t_solve
            if not setup["nlp_cached"]:
                setup["setup_cpu_s"] = setup["build_cpu_s"] + nlp.deadline.first_cpu - cpu_solve
                _SETUP_RATE[0] = setup["setup_cpu_s"] / setup.pop("units")
        setup.pop("build_cpu_s", None)
        setup.pop("units", None)
        return_status = str(ipopt_stats.get("return_status", "unknown"))
        late = return_status == "User_Requested_Stop" and time.perf_counter() > nlp.deadline.at
        stats: dict[str, Any] = {
            "time_limit_reached": late,
            "time_s": clock.elapsed(),
            "solve_time_s": solve_s,
            **setup,
            "ipopt_status": return_status,
            "iterations": int(ipopt_stats.get("iter_count", -1)),
            "N": self.N,
            "dt": self.dt,
            "init": init_source,
        }
        result = self._result(problem, xv, uv, return_status, stats)
        stats["time_s"] = clock.elapsed()  # the dense rollout and its clearance are the plan's time too
        return OptimSolution(result, xv, uv)

    def _ready_nlp(
        self, problem: PlanProblem, clock: PlanClock, obstacles: _ObstacleData, init_source: str
    ) -> tuple[_Nlp, dict[str, Any]] | OptimSolution:
        """The NLP of ``obstacles``' shape and the stats of its set-up: the process's own once built, else built
        now if what is left of the time limit covers the set-up's prediction (:data:`_SETUP_RATE`); if not, the
        plan's ``TIMEOUT``, naming the set-up. IPOPT's iteration callback, which holds a solve to the limit, is
        first called after it (0.05-0.15 s for the generated worlds' shapes, 0.4 s for 32 polygons)."""
        key = (self.N, *obstacles.counts, self.w_steer, self.w_smooth, self.max_iter, self.verbose, self.mu_strategy)
        if key in _CACHE:
            return _CACHE[key], {"build_time_s": 0.0, "nlp_cached": True}
        units = _setup_units(key)
        predicted = _SETUP_RATE[0] * units * clock.slowdown()
        left = clock.remaining()
        if left < predicted:
            n_circ, n_ell, poly_k = obstacles.counts
            why = (
                f"the plan's time limit ({problem.time_limit:g} s) had {left:.3f} s left after the warm start from "
                f"{init_source} ({clock.working():.3f} s), less than setting IPOPT up for this NLP's new shape is "
                f"predicted to take ({predicted:.3f} s: N={self.N}, {_count(n_circ, 'circle')}, "
                f"{_count(n_ell, 'ellipse')}, {_count(len(poly_k), 'polygon')}; a shape set up once is kept for the "
                "process); raise the time limit"
            )
            stats = {
                "time_s": clock.elapsed(),
                "init": init_source,
                "nlp_cached": False,
                "setup_predicted_s": predicted,
            }
            return self._failure(PlanStatus.TIMEOUT, why, stats)
        t_build, cpu_build = time.perf_counter(), time.thread_time()
        _CACHE[key] = _build(key)
        cpu_build = time.thread_time() - cpu_build  # the CPU read inside the wall time's reads: never more than it
        t_build = time.perf_counter() - t_build
        return _CACHE[key], {
            "build_time_s": t_build,
            "build_cpu_s": cpu_build,
            "nlp_cached": False,
            "setup_predicted_s": predicted,
            "units": units,
        }

    def _set_values(
        self, nlp: _Nlp, problem: PlanProblem, clear: float, obstacles: _ObstacleData, goal_heading: float
    ) -> None:
        """The problem's numbers into the NLP's parameters (``clear``: disc radius plus margin [m];
        ``goal_heading``: the goal's heading on the warm start's branch [rad])."""
        opti, robot = nlp.opti, problem.robot
        opti.set_value(nlp.p_start, [problem.start.x, problem.start.y, problem.start.theta, 0.0])
        opti.set_value(nlp.p_goal, [problem.goal.x, problem.goal.y, goal_heading, 0.0])
        opti.set_value(nlp.p_dt, self.dt)
        opti.set_value(nlp.p_wheelbase, robot.wheelbase)
        opti.set_value(nlp.p_clear, clear)
        xmin, xmax, ymin, ymax = problem.world.bounds
        opti.set_value(nlp.p_bounds, [xmin + clear, xmax - clear, ymin + clear, ymax - clear])
        opti.set_value(nlp.p_limits, [robot.max_speed, self.u2max, robot.max_steering, robot.max_yaw_rate])
        if obstacles.circles:
            circles = [[c.center[0], c.center[1], c.radius] for c in obstacles.circles]
            opti.set_value(nlp.obstacles.circles, np.array(circles).T)
        if obstacles.ellipses:
            ellipses = [[e.center[0], e.center[1], e.radii[0], e.radii[1], e.angle] for e in obstacles.ellipses]
            opti.set_value(nlp.obstacles.ellipses, np.array(ellipses).T)
        for vp, verts in zip(nlp.obstacles.polys, obstacles.polys, strict=True):
            opti.set_value(vp, verts.T)

    def _warm_start(self, nlp: _Nlp, x_init: FloatArray, u_init: FloatArray, obstacles: _ObstacleData) -> None:
        """Initial values: the guess's nodes (N+1, 4) and inputs (N, 2), and each separating line facing
        the guess from its obstacle's centre."""
        opti = nlp.opti
        opti.set_initial(nlp.x, x_init.T)
        opti.set_initial(nlp.u, u_init.T)
        centres = [np.asarray(e.center) for e in obstacles.ellipses] + [v.mean(axis=0) for v in obstacles.polys]
        for ps, c in zip(nlp.obstacles.psi, centres, strict=True):
            opti.set_initial(ps, np.arctan2(x_init[:, 1] - c[1], x_init[:, 0] - c[0])[None, :])

    def _result(
        self, problem: PlanProblem, xv: FloatArray, uv: FloatArray, return_status: str, stats: dict[str, Any]
    ) -> PlanResult:
        robot = problem.robot
        sub = max(1, math.ceil(self.dt / 0.01 - 1e-9))
        h = self.dt / sub
        u_dense = np.repeat(uv, sub, axis=0)
        # from the start itself (the NLP's start state): an iterate IPOPT gave up on need not begin there
        x0 = np.array([problem.start.x, problem.start.y, problem.start.theta, 0.0])
        states = bicycle_rollout(x0, np.ascontiguousarray(u_dense, dtype=float), h, robot.wheelbase)
        times = np.arange(states.shape[0]) * h
        u_full = np.vstack([u_dense, u_dense[-1:]])
        controls = bicycle_to_unicycle(states, u_full, robot.wheelbase)
        direction = _directions(u_dense[:, 0])
        path = states[:, :3].copy()
        end = states[-1]
        pos_err = float(np.hypot(end[0] - problem.goal.x, end[1] - problem.goal.y))
        head_err = abs(float(wrap_angle(end[2] - problem.goal.theta)))
        defect = xv[1:] - bicycle_rollout(x0, np.ascontiguousarray(uv, dtype=float), self.dt, robot.wheelbase)[1:]
        stats.update(
            final_position_error=pos_err,
            final_heading_error=head_err,
            final_state_error=float(np.linalg.norm(end - np.array([problem.goal.x, problem.goal.y, xv[-1, 2], 0.0]))),
            length=path_length(path),
            max_abs_u1=float(np.max(np.abs(uv[:, 0]))),
            max_abs_phi=float(np.max(np.abs(xv[:, 3]))),
            rollout_drift=float(np.max(np.abs(defect[:, :2]))) if defect.size else 0.0,
        )
        stats["min_clearance"] = dense_clearance(problem, path)  # obstacles and walls, as the record's
        kw: dict[str, Any] = {
            "path": path,
            "times": times,
            "controls": controls,
            "directions": direction,
            "states": states,
        }
        reason = f"IPOPT: {return_status}"
        if return_status in _SUCCESS:
            if pos_err > problem.position_tolerance or head_err > problem.heading_tolerance:
                why = f"{reason}, but the rollout misses the goal by {pos_err:.3g} m, {head_err:.3g} rad; reduce dt"
                return PlanResult(PlanStatus.FAILED, self.name, reason=why, stats=stats, **kw)
            return PlanResult(PlanStatus.SUCCESS, self.name, reason="", stats=stats, **kw)
        if return_status in _INFEASIBLE:  # IPOPT is a local method: no proof that no solution exists
            status = PlanStatus.FAILED
            reason += (
                " (IPOPT stopped where the constraints cannot all hold near its iterate, which does not show that "
                "no plan exists: another warm start (init=grid, init=rrt-star, ...), a longer horizon N*dt "
                "or more room helps)"
            )
        elif return_status in _TIMEOUT or stats["time_limit_reached"]:
            status = PlanStatus.TIMEOUT
            if stats["time_limit_reached"]:
                reason = f"IPOPT stopped at the time limit ({problem.time_limit:g} s, warm start included)"
                if stats["iterations"] == 0 and "setup_s" in stats:
                    reason += f" before its first iteration, setting it up took {stats['setup_s']:.3f} s"
                    if "setup_predicted_s" in stats:
                        reason += f" (a new NLP shape, predicted {stats['setup_predicted_s']:.3f} s)"
            longer, more = f"{1.5 * self.dt:.2g}", round(1.6 * self.N)
            reason += (
                f" (a longer horizon or more nodes often solves what more iterations do not: --planner-option "
                f"dt={longer} (the horizon is {self.N * self.dt:.1f} s now) or N={more}; or raise max_iter "
                "(--planner-option max_iter=6000) or the time limit, or warm start from another planner with init=... "
                "(--planner-option init=grid))"
            )
        else:
            status = PlanStatus.FAILED
        return PlanResult(status, self.name, reason=reason, stats=stats, **kw)
