"""Hybrid-A* (``hybrid-a-star``): the search Nav2's Smac planner uses for car-like robots.

A* over a lattice of (x, y, theta) cells (``cell_size`` squares, ``angle_quantization_bins``
headings), keeping in each cell the exact pose a motion primitive reached (Dolgov et al., 2008).
Primitives are sized as Smac sizes them: a turning arc of the turning radius just long enough to
leave a cell (its chord at least sqrt(2) cells), its heading change rounded up to whole bins, and a
straight move of the same chord; each forwards and backwards. With
``allow_primitive_interpolation`` the arcs that turn by fewer bins (wider radius, same chord) are
added too. The cost of a move is its length, times ``non_straight_penalty`` on arcs (plus
``change_penalty`` when the steering side changes), times ``reverse_penalty`` backwards (Smac's
parameters and defaults).

The heuristic is the larger of two lower bounds: the obstacle-aware 2-D distance to the goal
(Dijkstra from the goal cell over the 8-connected cells where the robot's inscribed disc fits, the
costmap Smac searches on) and the obstacle-free Reeds–Shepp distance. A cell the 2-D search never
reaches is pruned: a goal walled off from the start ends the search at once. Every
``max(1, h / (analytic_expansion_ratio * cell))`` expansions (and whenever a node enters the goal
tolerance) the shortest Reeds–Shepp curve to the goal is tried; when it is collision-free and no
longer than ``analytic_expansion_max_length`` it completes the path, which therefore ends exactly
on the goal pose.

Once the search has expanded ``search_from_goal_after`` nodes, a second search from the goal towards
the start (the moves reversed in time) runs beside it on a second thread, and gives the plan when it
reaches the start in more than that many fewer expansions than the first reaches the goal (a dead end
the heuristic cannot see from one side may not be there from the other; :class:`_GoalSearch`).

A search that expands every state it can reach without a path is run again on cells of half the size
(``refine_when_exhausted``), and again while exhausted, down to 1.25 cm cells (:data:`FINEST_REFINED_CELL`):
the lattice keeps one pose per cell, so a gap little wider than the robot can be missed on the coarse one (a
0.142 m gap the EduMIP passes: none on 5 cm cells, a path on 2.5 cm; a 0.20 m one for the 0.178 m TurtleBot3
met off its axis: none on 5 or 2.5 cm, a path on 1.25 cm).
One that spends its iteration budget on a world more than :data:`WIDE_WORLD_CELLS` cells across is run again
on cells twice the size (``coarsen_when_spent``; a 50 x 50 m world: 1,000,000 expansions spent in 3.6 s on
5 cm cells, a plan in 0.9 s on 10 cm ones).

The time limit holds for all of a plan: the collision grid, the 2-D heuristic (each built within what
is left of it, a limit that passes first ending the plan ``TIMEOUT`` before the search, naming what was
under way), the search, and the simplification after it.

The search is deterministic (no random numbers: ``problem.seed`` is not used; which of the two
searches gives the plan is decided by their counts, not by the threads' timing). Every motion is
collision-checked at the exact checker's resolution through the fast checker's proofs (see
:mod:`planning.planners.lattice`). The planner needs a turning radius > 0: it plans both robots
with the virtual bicycle's radius, as the Reeds–Shepp tree planners do (no turn in place).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planning.clock import PlanClock
from planning.collision.field import FieldTimeout
from planning.collision.grid import FastChecker
from planning.core.checks import check_fields
from planning.core.geometry import path_length, unwrap_heading
from planning.core.robot import RobotSpec, inscribed_radius
from planning.errors import ConfigError
from planning.planners import lattice
from planning.planners.base import PlanProblem, PlanResult, PlanStatus, PlanTree, checked_problem
from planning.planners.registry import config_from_options
from planning.planners.sampling.extend import LocalPlanner
from planning.planners.sampling.rrt import simplified
from planning.planners.sampling.steering import (
    MAX_TURNING_RADIUS,
    MIN_TURNING_RADIUS,
    arc_poses,
    default_turning_radius,
    place,
)
from planning.planners.sampling.tree import check_endpoints, grid_timeout, make_checker
from planning.signals import KernelRun, stoppable

FloatArray = NDArray[np.float64]


#: Largest cell side [m] of the discs that cover the footprint for the fast collision proof.
COVER_SIDE = 0.05
#: A world more than this many lattice cells across is searched again on cells twice the size when the search spends
#: its iteration budget (``coarsen_when_spent``), and the reason of a spent budget names coarser cells
#: (:meth:`HybridAStar._coarser`).
WIDE_WORLD_CELLS = 400


@dataclass(frozen=True)
class HybridAStarConfig:
    """Options of ``hybrid-a-star`` (names and defaults of Smac's Hybrid-A* where it has them).

    Attributes:
        angle_quantization_bins: Heading bins of the lattice (even, >= 8); 72 is 5 degrees.
        cell_size: Side of a lattice cell and of the 2-D heuristic's cells [m].
        turning_radius: Turning radius of the primitives and of the Reeds–Shepp curves [m];
            None: the virtual bicycle's, wheelbase / tan(max_steering) (Smac's
            ``minimum_turning_radius``).
        reverse_penalty: Cost factor of backwards moves (>= 1).
        change_penalty: Added to the arc factor when the steering side changes (>= 0).
        non_straight_penalty: Cost factor of arcs (>= 1).
        analytic_expansion_ratio: Try the analytic Reeds–Shepp completion every
            ``max(1, h / (ratio * cell))`` expansions (> 0).
        analytic_expansion_max_length: Longest analytic completion [m] (> 0).
        allow_primitive_interpolation: Also use arcs that turn by fewer heading bins.
        max_iterations: Expansion budget (>= 1), of each search.
        search_from_goal: Once the search from the start has expanded ``search_from_goal_after`` nodes,
            also search from the goal (the moves reversed in time, the costs those of the moves they
            reverse) on a second thread; the search from the goal gives the plan when it reaches the start
            in more than ``search_from_goal_after`` fewer expansions than the search from the start
            reaches the goal, which is then stopped (the plan does not depend on the threads' timing).
        search_from_goal_after: The head start of the search from the start [expansions] (>= 0).
        refine_when_exhausted: When the search expands every state it can reach without a path, search
            again on cells of half the size (the lattice keeps one pose per cell, so a gap little wider than
            the robot can be missed), and again while that is exhausted, down to :data:`FINEST_REFINED_CELL`
            (at least once), within what is left of the time limit and where the machine has the memory for
            that lattice.
        coarsen_when_spent: When the search spends its iteration budget on a world more than
            :data:`WIDE_WORLD_CELLS` cells across, search once more on cells twice the size, within what is
            left of the time limit (on 0.05 m cells the TurtleBot3's primitives turn by 30 degrees, and over
            tens of metres A* fills the wide region where a zigzag of them costs less than the way found).
        time_limit: Wall-clock budget [s]; None takes the problem's.
        shape: Collision model, "footprint" or "disc".
        clearance: Margin every pose keeps from obstacles and walls [m] (>= 0).
        simplify: Return the path simplified as the sampling planners' are (shortcuts with
            Reeds–Shepp curves of the same radius, vertex reduction, cusp merging:
            :func:`planning.planners.sampling.rrt.simplified`); False returns the lattice's path.
    """

    angle_quantization_bins: int = 72
    cell_size: float = 0.05
    turning_radius: float | None = None
    reverse_penalty: float = 2.0
    change_penalty: float = 0.0
    non_straight_penalty: float = 1.2
    analytic_expansion_ratio: float = 3.5
    analytic_expansion_max_length: float = 3.0
    allow_primitive_interpolation: bool = False
    max_iterations: int = 1_000_000
    search_from_goal: bool = True
    search_from_goal_after: int = 16_000
    refine_when_exhausted: bool = True
    coarsen_when_spent: bool = True
    time_limit: float | None = None
    shape: str = "footprint"
    clearance: float = 0.0
    simplify: bool = True

    def __post_init__(self) -> None:
        check_fields(self, _NUMBERS, "hybrid-a-star option ")
        for name, (expected, ok) in _RULES.items():
            value = getattr(self, name)
            if not ok(value):
                raise ConfigError(f"hybrid-a-star option {name} must be {expected}, got {value!r}")


#: The numeric options -> their limits (:func:`planning.core.checks.check_number`), the fix an example.
_NUMBERS: dict[str, dict[str, Any]] = {
    "angle_quantization_bins": {"integer": True, "at_least": 8, "fix": "an even number, e.g. 72"},
    "cell_size": {"above": 0.0, "unit": "m", "fix": "e.g. 0.05"},
    "turning_radius": {
        "at_least": MIN_TURNING_RADIUS,
        "at_most": MAX_TURNING_RADIUS,
        "unit": "m",
        "optional": True,
        "fix": "Reeds–Shepp curves need a turning radius; plan turns in place with c-rrt-star",
    },
    "reverse_penalty": {"at_least": 1.0, "fix": "e.g. 2.0"},
    "change_penalty": {"at_least": 0.0, "fix": "e.g. 0.0"},
    "non_straight_penalty": {"at_least": 1.0, "fix": "e.g. 1.2"},
    "analytic_expansion_ratio": {"above": 0.0, "fix": "e.g. 3.5"},
    "analytic_expansion_max_length": {"above": 0.0, "unit": "m", "fix": "e.g. 3.0"},
    "max_iterations": {"integer": True, "at_least": 1},
    "search_from_goal_after": {"integer": True, "at_least": 0, "fix": "e.g. 16000"},
    "time_limit": {"above": 0.0, "unit": "s", "optional": True},
    "clearance": {"at_least": 0.0, "unit": "m"},
}
#: The other options (and what the numbers' limits do not say) -> (what it must be, its test).
_RULES: dict[str, tuple[str, Callable[[Any], bool]]] = {
    "angle_quantization_bins": ("an even integer >= 8 (e.g. 72)", lambda v: v % 2 == 0),
    "allow_primitive_interpolation": ("true or false", lambda v: isinstance(v, bool)),
    "search_from_goal": ("true or false", lambda v: isinstance(v, bool)),
    "refine_when_exhausted": ("true or false", lambda v: isinstance(v, bool)),
    "coarsen_when_spent": ("true or false", lambda v: isinstance(v, bool)),
    "shape": ("'footprint' or 'disc'", lambda v: v in ("footprint", "disc")),
    "simplify": ("true or false", lambda v: isinstance(v, bool)),
}


@dataclass(frozen=True)
class Primitives:
    """Motion primitives in the body frame.

    Attributes:
        body: (P, K, 3) poses along each primitive from the origin, uniform in arc length.
        lengths: (P,) arc lengths [m].
        directions: (P,) +1 forwards, -1 backwards.
        steer: (P,) +1 left arc, 0 straight, -1 right arc.
    """

    body: FloatArray
    lengths: FloatArray
    directions: FloatArray
    steer: FloatArray

    @property
    def ends(self) -> FloatArray:
        """(P, 3) end poses."""
        return np.ascontiguousarray(self.body[:, -1])


def motion_primitives(rho: float, cell: float, bins: int, step: float, *, interpolate: bool = False) -> Primitives:
    """Smac's Hybrid-A* primitives (see the module doc).

    Args:
        rho: Turning radius [m].
        cell: Lattice cell side [m].
        bins: Heading bins.
        step: Largest arc length between samples [m].
        interpolate: Also the arcs turning by 1 .. (increments - 1) bins at the same chord.
    """
    bin_size = 2.0 * np.pi / bins
    angle = 2.0 * np.arcsin(min(1.0, np.sqrt(2.0) * cell / (2.0 * rho)))
    increments = max(1, int(np.ceil(angle / bin_size - 1e-9)))
    chord = 2.0 * rho * np.sin(0.5 * increments * bin_size)
    turns = range(1, increments + 1) if interpolate else (increments,)
    arcs = [(0.0, chord)] + [(m * bin_size, chord / (2.0 * np.sin(0.5 * m * bin_size))) for m in turns]
    n = int(np.ceil(max(r * a if a else chord for a, r in arcs) / step))
    body, lengths, dirs, steer = [], [], [], []
    for d in (1.0, -1.0):
        for a, r in arcs:
            for side in (1.0, -1.0) if a else (0.0,):
                length = r * a if a else chord
                body.append(arc_poses(d, d * side / r if a else 0.0, length, n))
                lengths.append(length)
                dirs.append(d)
                steer.append(side)
    return Primitives(np.ascontiguousarray(body), np.array(lengths), np.array(dirs), np.array(steer))


def footprint_cover(robot: RobotSpec, side: float) -> FloatArray:
    """Discs covering the footprint's bounding box: (C, 3) body-frame centres [m] and radii [m].

    The box is cut into the fewest equal cells no longer than ``side`` on either axis; each cell's
    circumscribed disc covers it.
    """
    lo, hi = robot.footprint.min(axis=0), robot.footprint.max(axis=0)
    n = np.maximum(1, np.ceil((hi - lo) / side)).astype(int)
    size = (hi - lo) / n
    cx, cy = np.meshgrid(lo[0] + size[0] * (np.arange(n[0]) + 0.5), lo[1] + size[1] * (np.arange(n[1]) + 0.5))
    return np.column_stack([cx.ravel(), cy.ravel(), np.full(cx.size, 0.5 * float(np.hypot(*size)))])


@dataclass(frozen=True)
class _Setup:
    """What one run needs besides the problem: the checker, the lattice and the heuristic."""

    checker: FastChecker
    rho: float
    step: float
    prims: Primitives
    lat: tuple[float, float, float, int, int, int]
    h2d: FloatArray
    free: NDArray[np.bool_]


#: The finest cells [m] an exhausted search refines to by itself (``refine_when_exhausted``; at least one halving of
#: the configured cells): near the collision grid's 1 cm spacing, below which a lattice gains little (its proof
#: margin, about a centimetre a side, bounds the gaps any cell size passes).
FINEST_REFINED_CELL = 0.0125
#: Up to how many times the expansions a lattice of half the cell size took (5 cm -> 2.5 cm -> 1.25 cm -> 6.25 mm
#: on a 0.19 m gap for the TurtleBot3: 11,255, 87,898, 530,486, 4,210,659; 31,665 -> 251,154 on a diagonal one).
REFINE_COST = 8
#: Where the reasons send a plan this planner cannot find: planners whose checks fall back on the exact formulas.
SAMPLING = (
    "rrt or rrt-star (--planner rrt; a larger max_iterations where they run out), whose collision checks fall back "
    "on the exact formulas"
)


class HybridAStar:
    """Hybrid-A* over (x, y, theta) with Reeds–Shepp completion (see the module doc)."""

    name = "hybrid-a-star"
    config_class = HybridAStarConfig

    def __init__(self, **options: object) -> None:
        self.config: HybridAStarConfig = config_from_options(HybridAStarConfig, options)

    def plan(self, problem: PlanProblem) -> PlanResult:
        """Plan from ``problem.start`` to ``problem.goal``; never raises for an unsolvable problem. A lattice
        searched to exhaustion is searched again on cells of half the size (``refine_when_exhausted``), one whose
        budget was spent on a wide world on cells twice the size (``coarsen_when_spent``)."""
        problem = checked_problem(problem)
        cfg = self.config
        res = self._plan(problem)
        if res.stats.get("exhausted") and cfg.refine_when_exhausted:
            cell, finest = cfg.cell_size, min(FINEST_REFINED_CELL, cfg.cell_size / 2)
            # halved again while exhausted, time is left and the lattice fits (a 0.20 m gap for the 0.178 m
            # TurtleBot3 exhausts 5 and 2.5 cm cells and is found on 1.25 cm ones in 0.07 s)
            while (
                res.stats.get("exhausted")
                and cell / 2 >= finest - 1e-12
                and not _lattice_too_large(problem, cell / 2, cfg.angle_quantization_bins)
            ):
                finer = self._again(problem, res, cell / 2, cell)
                if finer is res:  # no time left for the finer cells: the limit, not the lattice, ended the plan
                    why = f"{res.reason}; the time limit left no time to search cells of {cell / 2:g} m"
                    return dataclasses.replace(res, status=PlanStatus.TIMEOUT, reason=why)
                res, cell = finer, cell / 2
            return res
        if res.stats.get("budget_spent") and cfg.coarsen_when_spent and _wide(problem, cfg.cell_size):
            return self._again(problem, res, 2 * cfg.cell_size, cfg.cell_size)
        return res

    def _again(self, problem: PlanProblem, res: PlanResult, cell: float, before: float) -> PlanResult:
        """The search on cells of side ``cell`` after ``res``'s on cells of side ``before``, within what is left of
        the time limit (``res`` itself when nothing is), the times of both in its stats and the first's in
        ``stats["coarse"]`` (refined) or ``stats["fine"]`` (coarsened)."""
        cfg = self.config
        limit = cfg.time_limit if cfg.time_limit is not None else problem.time_limit
        left = limit - (float(res.stats["time_s"]) - float(res.stats["code_s"]))  # what the limit counts
        if left <= 0:
            return res
        options = {
            **dataclasses.asdict(cfg),
            "cell_size": cell,
            "refine_when_exhausted": False,
            "coarsen_when_spent": False,
            "time_limit": left,
        }
        again = HybridAStar(**options)._plan(problem, stated_limit=limit)
        refined = cell < before
        # both searches' time (a second run that ended early, at its grid, reports no CPU time)
        times = {
            k: float(res.stats[k]) + float(again.stats.get(k, 0.0)) for k in ("time_s", "code_s", "cpu_s", "grid_s")
        }
        if not refined and again.stats.get("exhausted"):  # coarse cells can miss a gap: the fine search's timeout
            said = f" (cells of {cell:g} m were searched after it and exhausted in {again.stats['iterations']})"
            return dataclasses.replace(res, reason=res.reason + said, stats={**res.stats, **times})
        stats = {
            **again.stats,
            **times,
            "coarse" if refined else "fine": {
                "cell_size": before,
                "iterations": res.stats["iterations"],
                "time_s": res.stats["time_s"],
            },
            "cell_size": cell,
        }
        reason = again.reason
        if again.status is not PlanStatus.SUCCESS and refined:
            reason += f" (searched after the {before:g} m lattice was exhausted in {res.stats['iterations']}"
            if again.status is PlanStatus.TIMEOUT and "iteration budget" in again.reason:
                reason += f"; cells of half the size take up to about {REFINE_COST} times the expansions"
            reason += ")"
        elif again.status is not PlanStatus.SUCCESS:
            reason += f" (searched after the budget was spent on {before:g} m cells)"
        return dataclasses.replace(again, reason=reason, stats=stats)

    def _plan(self, problem: PlanProblem, stated_limit: float | None = None) -> PlanResult:
        """One search on the configured lattice (see :meth:`plan`); a timeout's reason names
        ``stated_limit`` [s] when given (a refinement's budget is what was left of the plan's, whose
        limit the reason names), else the search's own."""
        cfg = self.config
        limit = cfg.time_limit if cfg.time_limit is not None else problem.time_limit
        said = limit if stated_limit is None else stated_limit
        clock = (PlanClock(limit), time.process_time())
        setup = self._prepare(problem, clock, said)
        if isinstance(setup, PlanResult):
            return setup
        start, goal = problem.start.as_array(), problem.goal.as_array()
        space = (
            (*_moves(setup.prims, cfg, 1.0), _root_free(setup, start)),
            setup.lat,
            setup.h2d,
            setup.checker.proof_arguments(),
            footprint_cover(problem.robot, COVER_SIDE),
        )
        tol = np.array([problem.position_tolerance, problem.heading_tolerance])
        expansion = np.array([cfg.analytic_expansion_ratio, cfg.analytic_expansion_max_length])
        race = np.array([cfg.max_iterations, 0], dtype=np.int64)  # lowered by the race; the expansions so far
        args = (
            start,
            goal,
            tol,
            setup.rho,
            setup.step,
            space,
            expansion,
            cfg.max_iterations,
            race,
            clock[0].remaining(),
        )
        other = _GoalSearch(self, setup, args, clock[0]) if cfg.search_from_goal else None
        try:
            out = stoppable(lattice.search, *args, watch=None if other is None else other.watch)
        except MemoryError:  # within the machine's memory, yet not to be had
            reason = _lattice_too_large(problem, cfg.cell_size, cfg.angle_quantization_bins, failed=True)
            return PlanResult(PlanStatus.INFEASIBLE, self.name, reason=reason, stats=_stats(clock, setup.checker, 0, 0))
        if other is None or not other.wins(out):
            return self._result(problem, setup, out, clock, said, {} if other is None else other.stats(out))
        return self._result(problem, setup, other.out, clock, said, other.stats(out))

    def _prepare(self, problem: PlanProblem, clock: tuple[PlanClock, float], limit: float) -> _Setup | PlanResult:
        """What the search needs (the collision grid, the lattice, the 2-D heuristic), built within the time
        limit, or the result that ends the plan before the search: the lattice too large, an end pose in
        collision, the goal walled off, or the limit (``limit`` [s], as the reason names it) passed first."""
        cfg = self.config
        too_large = _lattice_too_large(problem, cfg.cell_size, cfg.angle_quantization_bins)
        if too_large:
            return PlanResult(PlanStatus.INFEASIBLE, self.name, reason=too_large, stats=_stats(clock, None, 0, 0))
        try:  # the grid counts against the time limit
            checker = make_checker(problem, cfg.shape, cfg.clearance, clock[0].deadline())  # type: ignore[arg-type]
        except FieldTimeout as exc:  # the grid's timeout as every planner's, with this planner's CPU time
            out = grid_timeout(self.name, exc)
            stats = {**out.stats, "cpu_s": time.process_time() - clock[1]}
            reason = f"time budget of {limit:g} s spent before the search: {exc}"
            return dataclasses.replace(out, reason=reason, stats=stats)
        bad = check_endpoints(problem, checker, self.name)
        if bad is not None:
            return bad
        try:
            setup = self._setup(problem, checker, clock[0])
        except FieldTimeout as exc:
            reason = f"time budget of {limit:g} s spent before the search: {exc} (the collision grid took "
            reason += f"{checker.grid_seconds:.3f} s of it)"
            return PlanResult(PlanStatus.TIMEOUT, self.name, reason=reason, stats=_stats(clock, checker, 0, 0))
        if not np.isfinite(setup.h2d[self._cell(setup, problem.start.as_array())]):
            reason = (
                "the goal cannot be reached from the start even by the robot's inscribed disc "
                f"(radius {inscribed_radius(problem.robot, cfg.shape):.3f} m plus the clearance "
                f"{cfg.clearance:g} m) on the {cfg.cell_size:g} m grid: the goal is walled off"
            )
            return PlanResult(PlanStatus.INFEASIBLE, self.name, reason=reason, stats=_stats(clock, checker, 0, 0))
        return setup

    def _setup(self, problem: PlanProblem, checker: FastChecker, clock: PlanClock) -> _Setup:
        """The turning radius, primitives, lattice and obstacle heuristic of a run, the heuristic within
        ``clock``'s time limit.

        Raises:
            planning.collision.field.FieldTimeout: The time limit passed before the heuristic was done.
        """
        cfg = self.config
        robot = problem.robot
        rho = cfg.turning_radius if cfg.turning_radius is not None else default_turning_radius(robot)
        # Robot points move at most step * (1 + R / rho) between samples: the checker's resolution.
        step = min(0.01, checker.resolution / (1.0 + robot.radius / rho))
        prims = motion_primitives(
            rho, cfg.cell_size, cfg.angle_quantization_bins, step, interpolate=cfg.allow_primitive_interpolation
        )
        xmin, _, ymin, _ = problem.world.bounds
        cell = cfg.cell_size
        nx, ny = lattice.cell_counts(problem.world.bounds, cell)
        # A cell is blocked only when no point of it leaves room for the inscribed disc.
        need = inscribed_radius(robot, cfg.shape) + cfg.clearance
        grid, x0, y0, h = checker.proof_arguments()[:4]
        free = lattice.open_cells(grid, x0, y0, h, (float(xmin), float(ymin), float(cell), nx, ny), need)
        lat = (float(xmin), float(ymin), float(cell), nx, ny, int(cfg.angle_quantization_bins))
        setup = _Setup(checker, float(rho), float(step), prims, lat, np.zeros((nx, ny)), free)
        gi, gj = self._cell(setup, problem.goal.as_array())
        free[gi, gj] = True
        h2d = _heuristic(free, (gi, gj), float(cell), clock, len(problem.world.obstacles))
        return dataclasses.replace(setup, h2d=h2d)

    @staticmethod
    def _cell(setup: _Setup, q: FloatArray) -> tuple[int, int]:
        """The (ix, iy) cell holding pose ``q`` (clipped to the lattice)."""
        xmin, ymin, cell, nx, ny, _ = setup.lat
        return min(nx - 1, max(0, int((q[0] - xmin) // cell))), min(ny - 1, max(0, int((q[1] - ymin) // cell)))

    def _result(
        self,
        problem: PlanProblem,
        setup: _Setup,
        out: tuple,  # type: ignore[type-arg]
        clock: tuple[PlanClock, float],
        limit: float,
        race: dict[str, object],
    ) -> PlanResult:
        """The plan result of a finished search (see :func:`planning.planners.lattice.search`): the search
        from the start's, or the search from the goal's when ``race["search"]`` says so (its path then read
        backwards); ``race`` goes into the stats; ``limit`` [s] is the time limit a timeout's reason names."""
        outcome, end, its, nodes, meta, tail, tail_dirs = out
        # the searched nodes in the order the search opened them (its root first), parents by row
        tree = PlanTree(nodes[:, :3].copy(), meta[:, 0].copy())
        if outcome != lattice.FOUND:
            gaps = np.hypot(*(nodes[:, :2] - problem.goal.as_array()[:2]).T)
            end = int(np.argmin(gaps)) if outcome != lattice.EXHAUSTED else end
            tail, tail_dirs = np.zeros((0, 3)), np.zeros(0)
        path, dirs = _branch(nodes, meta, setup.prims, int(end), tail, tail_dirs)
        if race.get("search") == "from the goal":
            path, dirs = _read_backwards(path, dirs, problem.start.as_array())
        stats = {
            **_stats(clock, setup.checker, its, nodes.shape[0]),
            **race,
            "length_m": path_length(path),
            "analytic": tail.shape[0] > 0,
        }
        if outcome == lattice.FOUND:
            found = PlanResult(PlanStatus.SUCCESS, self.name, path=path, stats=stats, tree=tree, directions=dirs)
            return self._simplified(problem, setup, found, clock[0])
        if outcome == lattice.EXHAUSTED:
            status, reason = PlanStatus.INFEASIBLE, self._exhausted(problem, its, setup.checker)
            stats["exhausted"] = True
        else:
            status = PlanStatus.TIMEOUT
            reason = "partial path to the expanded node nearest the goal"
            if outcome == lattice.ITERATIONS:
                stats["budget_spent"] = True
                reason = (
                    f"iteration budget of {its} spent on {self.config.cell_size:g} m cells; {reason} (the budget is "
                    f"the max_iterations option: raise it, e.g. --planner-option max_iterations={4 * its}, or in a "
                    f"[planners.hybrid-a-star] table of the scenario{self._coarser(problem)}, or plan with {SAMPLING})"
                )
            else:
                reason = f"time budget of {limit:g} s spent; {reason}"
        return PlanResult(status, self.name, path=path, reason=reason, stats=stats, tree=tree, directions=dirs)

    def _coarser(self, problem: PlanProblem) -> str:
        """The hint of coarser cells for a search that spent its budget on a world of more than
        :data:`WIDE_WORLD_CELLS` cells across ("" otherwise; why they help: ``coarsen_when_spent``)."""
        cell = self.config.cell_size
        if not _wide(problem, cell):
            return ""
        return f"; or coarser cells for a world this wide, e.g. --planner-option cell_size={2 * cell:g}"

    def _exhausted(self, problem: PlanProblem, its: int, checker: FastChecker) -> str:
        """Why a search that expanded every state it could reach found no path, and what may: a sampling
        planner, for a gap narrower than the collision grid's proof margin (no lattice passes it), and the
        lattice keeps one pose per cell, so a way through a wider gap may need finer cells (half the size,
        where the machine has the memory for that lattice, with the larger budget they take). The status stays
        ``INFEASIBLE`` (no solution this planner can find), the reason leads with what it does not prove."""
        cell, bins = self.config.cell_size, self.config.angle_quantization_bins
        spacing = checker.proof_arguments()[3]
        margin = spacing / np.sqrt(2.0) + checker.checker.tolerance / 2
        narrow = (
            f"a gap up to about {1000 * margin:.0f} mm a side wider than the robot (the collision grid's proof "
            f"margin: its {100 * spacing:g} cm spacing / sqrt 2 + half the footprint tolerance, beyond the clearance) "
            f"may be passed at no cell size: for it, plan with {SAMPLING}"
        )
        said = (
            "no path found, which does not prove that the robot has none: the lattice search expanded every "
            f"state it could reach ({its}) on {cell:g} m cells, {bins} headings, one pose kept per cell, each "
            "motion proven free on the collision grid, so a gap up to a centimetre or two wider than the robot "
            "may not be passed (the resolution limit: docs/explanation/hybrid-astar.md)"
        )
        if its <= BOXED_IN:  # finer cells box it in as well (a dead end's start: 3 expansions, then 7)
            return (
                f"{said}; it could barely leave where it began: no motion from there is proven free on the "
                f"collision grid, which errs up to about {1000 * margin:.0f} mm on the safe side beyond the "
                f"clearance kept ({checker.checker.clearance:g} m), so a start or goal that close to obstacles is "
                f"boxed in at every cell size: plan with {SAMPLING}, or with less clearance"
            )
        if _lattice_too_large(problem, cell / 2, bins):
            return f"{said}; {narrow}; a finer lattice would need more memory than this machine has"
        need = REFINE_COST * its
        budget = (
            f"the max_iterations of {self.config.max_iterations} may do"
            if need <= self.config.max_iterations
            else f"raise max_iterations to {need} or more"
        )
        return (
            f"{said}; {narrow}; a wider gap may need finer cells: try cell_size = {cell / 2:g} in a "
            f"[planners.hybrid-a-star] table of the scenario (or --planner-option cell_size={cell / 2:g}); cells of "
            f"half the size take up to about {REFINE_COST} times the expansions ({its} here: {budget}; and when they "
            "are exhausted too, the search goes on to cells half as large again: refine_when_exhausted)"
        )

    def _simplified(self, problem: PlanProblem, setup: _Setup, found: PlanResult, clock: PlanClock) -> PlanResult:
        """The lattice's path simplified as the sampling planners' paths are, with Reeds–Shepp curves of
        the search's radius and its checker (the raw path kept in ``raw_path``; the stats report both
        lengths and cusps). Smoothing follows in :mod:`planning.trajectory`, as for every planner. A
        backwards metre costs ``reverse_penalty`` forwards metres there too, as in the search: the
        simplified path does not turn forward stretches round to save a few centimetres backwards
        (it did, without the weight: a world's 7.13 m path, 0.12 m of it backwards, became 7.03 m, 6.93 m
        of it backwards). It runs within what is left of the time limit (``clock``, the plan's)."""
        if not self.config.simplify:
            return found
        local = LocalPlanner("reeds_shepp", problem.robot, setup.checker, rho=setup.rho)
        # deterministic: the same path whatever the problem's seed
        out = simplified(found, local, 0, reverse_weight=self.config.reverse_penalty, clock=clock)
        return dataclasses.replace(out, stats={**out.stats, "length_m": path_length(out.path)})


#: Expansions at most of a search that barely left its first pose (:meth:`HybridAStar._exhausted`).
BOXED_IN = 10


#: Bytes of the search's tables per lattice state (:func:`planning.planners.lattice.search`: six float64
#: and three int64 of a node, one int8 of its state, one int32 of its row). They are allocated whole with
#: room for a node in every state; the nodes' rows are written in order and the state and row tables
#: only where the search goes: a 100 x 100 m world's 2.9e8 states take 22 GB of address space.
BYTES_PER_STATE = 6 * 8 + 3 * 8 + 1 + 4
#: Most lattice states the search indexes (its table of a cell's row is 32-bit).
MAX_STATES = 2**31 - 1


def memory_bytes() -> int:
    """This machine's physical memory [bytes] (0 when it cannot be read)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 0


def _wide(problem: PlanProblem, cell: float) -> bool:
    """Whether the world is more than :data:`WIDE_WORLD_CELLS` cells of side ``cell`` [m] across."""
    xmin, xmax, ymin, ymax = problem.world.bounds
    return max(xmax - xmin, ymax - ymin) / cell > WIDE_WORLD_CELLS


def _lattice_too_large(problem: PlanProblem, cell: float, bins: int, failed: bool = False) -> str:
    """Why the search's tables over the world's lattice of ``cell`` [m] cells and ``bins`` headings cannot
    be had, naming the fix; "" when they can. They cannot when they need more than the machine's memory,
    when the lattice has more states than the search's 32-bit row table indexes (:data:`MAX_STATES`), or
    when their allocation ``failed``. (The 2-D heuristic's arrays, tens of bytes a cell, are far
    smaller: checked first, the lattice covers them.)"""
    nx, ny = lattice.cell_counts(problem.world.bounds, cell)
    states = nx * ny * bins
    need = states * BYTES_PER_STATE
    memory = memory_bytes()
    if not failed and (memory == 0 or need <= memory) and states <= MAX_STATES:
        return ""
    # cells this much larger need at most half the memory (the tables grow as 1 / cell^2), and hold at
    # most half the states the rows' 32-bit table can index
    coarser = cell * np.sqrt(max(need / (0.5 * memory) if memory else 4.0, states / (0.5 * MAX_STATES)))
    coarser = float(np.ceil(coarser / 0.05 - 1e-9) * 0.05)
    if failed:
        have = "which could not be allocated"
    elif states > MAX_STATES:
        have = f"more states than the search's 32-bit row table indexes ({MAX_STATES:.3g})"
    else:
        have = f"more than this machine's {memory / 1e9:.3g} GB of memory"
    return (
        f"the search lattice of this {problem.world.width:g} x {problem.world.height:g} m world ({nx} x {ny} cells "
        f"of {cell:g} m, {bins} headings: {states:.3g} states) needs {need / 1e9:.3g} GB of tables, {have}; plan "
        f"it with larger cells (cell_size = {coarser:g} in a [planners.hybrid-a-star] table of the scenario) or on "
        f"a smaller world"
    )


def _stats(
    clock: tuple[PlanClock, float], checker: FastChecker | None, iterations: int, nodes: int
) -> dict[str, object]:
    """time_s (wall: grid, lattice and search), cpu_s (this process's CPU time over the same span: the
    cost without other processes' load), grid_s (the collision grid's part of time_s, its code's readying
    left out), iterations and nodes, code_s (numba readying the kernels: cache loads, compiling; not
    counted against the time limit); ``clock`` is (the planner's
    :class:`planning.clock.PlanClock`, ``time.process_time()`` at the start)."""
    return {
        "time_s": clock[0].elapsed(),
        "code_s": clock[0].code(),
        "cpu_s": time.process_time() - clock[1],
        "grid_s": 0.0 if checker is None else checker.grid_seconds,
        "iterations": iterations,
        "nodes": nodes,
    }


def _moves(prims: Primitives, cfg: HybridAStarConfig, sense: float) -> tuple[FloatArray, ...]:
    """The search's moves (body, ends, cost, change_extra, turn_class; :func:`planning.planners.lattice.search`)
    for a search forwards in time (``sense`` 1) or backwards (-1: from the goal, each primitive then
    undoes a move driven the other way, whose costs it takes)."""
    dirs = sense * prims.directions
    cost = (
        prims.lengths
        * np.where(prims.steer != 0, cfg.non_straight_penalty, 1.0)
        * np.where(dirs < 0, cfg.reverse_penalty, 1.0)
    )
    change = prims.lengths * cfg.change_penalty * np.where(dirs < 0, cfg.reverse_penalty, 1.0)
    turn_class = np.where(prims.steer == 0, 0, np.where(prims.steer > 0, 1, 2) + np.where(dirs < 0, 2, 0))
    return prims.body, prims.ends, cost, change, turn_class.astype(np.int64)


def _root_free(setup: _Setup, root: FloatArray) -> NDArray[np.bool_]:
    """(P,) whether each move from ``root`` is free, by the fast checker with its exact fallback: the
    search proves its other moves by the grid alone, whose undecided poses count as collisions, so that a
    root a few millimetres from an obstacle would have no move (see :mod:`planning.planners.lattice`)."""
    body = setup.prims.body
    if setup.checker.free_around(root, float(np.hypot(body[..., 0], body[..., 1]).max())):
        return np.ones(body.shape[0], dtype=bool)  # in the open (most roots): no compiled call
    free = setup.checker.poses_free(place(body.reshape(-1, 3), root))
    return np.asarray(free.reshape(body.shape[:2]).all(axis=1))


class _GoalSearch:
    """The search from the goal, raced against the search from the start (``search_from_goal``).

    It starts once the search from the start has expanded ``after`` nodes, on a second thread, towards
    the start with no tolerance (its path must leave from the start pose itself, which it reaches by
    the analytic expansion alone). It decides the plan when it reaches the start after B expansions
    and the search from the start has not ended (reached the goal, or expanded every state it can
    reach) within ``after + B`` of its own: whichever ends first lowers the other's budget to where it
    could still win, so both stop at about ``min(F, after + B)`` expansions (F the search from the
    start's), and the winner is decided by the counts alone, not by which thread came first (the
    loser's count where it was stopped does depend on the threads' timing). Running out of states, it
    decides nothing: it may miss the start pose that the other search leaves from by a primitive."""

    def __init__(self, planner: HybridAStar, setup: _Setup, args: tuple[Any, ...], clock: PlanClock) -> None:
        start, goal, _, rho, step, space, expansion, _, race, _ = args
        self.after = planner.config.search_from_goal_after
        self.race, self.clock = race, clock
        self.setup, self.fixed = setup, (goal, start, np.zeros(2), rho, step, space, expansion)
        self.budget = np.array([max(0, race[0] - self.after - 1), 0], dtype=np.int64)  # as race, for this one
        self.moves = _moves(setup.prims, planner.config, -1.0)
        self.args: tuple[Any, ...] | None = None
        self.late = False  # whether the time limit passed before its heuristic was made
        self.run: KernelRun | None = None

    @property
    def out(self) -> Any:
        return None if self.run is None else self.run.out

    def watch(self, first: KernelRun, spawn: Callable[..., KernelRun]) -> None:
        """:func:`planning.signals.stoppable`'s watch: start this search, and lower the loser's budget."""
        if first.done.is_set() and _ended(first.out):  # this one wins only below F - after
            self.budget[0] = min(self.budget[0], max(0, first.out[2] - self.after - 1))
        if self.run is None:
            # started even when the first has ended (within its head start, or just past it): the plan
            # may not depend on whether this thread had started by then
            count = first.out[2] if first.done.is_set() else self.race[1]  # race[1]: every 256 expansions
            if count < self.after // 2 or (first.done.is_set() and first.out[0] == lattice.TIMED_OUT):
                return
            if self.args is None and not self.late:
                self.args = self._args()  # its heuristic made while the first runs, to start at once
                self.late = self.args is None  # the time limit passed before its heuristic was done
            if self.args is None:
                return
            if count >= self.after and self.budget[0] > 0:
                budget = int(self.budget[0])
                self.run = spawn(lattice.search, *self.args, budget, self.budget, self.clock.remaining())
            return
        if self.run.done.is_set() and self.run.out[0] == lattice.FOUND:
            self.race[0] = min(self.race[0], self.after + self.run.out[2])

    def _args(self) -> tuple[Any, ...] | None:
        """The search's arguments (its heuristic, from the start, made within the time limit), or None
        when the time limit passed first."""
        goal, start, tol, rho, step, space, expansion = self.fixed
        free, (i, j) = self.setup.free.copy(), HybridAStar._cell(self.setup, start)
        free[i, j] = True  # as the goal's cell is for the search from the start
        try:
            h2d = _heuristic(free, (i, j), self.setup.lat[2], self.clock, 0)
        except FieldTimeout:
            return None
        moves = (*self.moves[:5], _root_free(self.setup, goal))
        return goal, start, tol, rho, step, (moves, space[1], h2d, space[3], space[4]), expansion

    def wins(self, first: tuple) -> bool:  # type: ignore[type-arg]
        """Whether this search gives the plan, given the search from the start's result."""
        if self.out is None or self.out[0] != lattice.FOUND:
            return False
        return bool(not _ended(first) or first[2] > self.after + self.out[2])

    def stats(self, first: tuple) -> dict[str, object]:  # type: ignore[type-arg]
        """Which search gave the plan and how far each went [expansions]."""
        return {
            "search": "from the goal" if self.wins(first) else "from the start",
            "expansions_from_start": int(first[2]),
            "expansions_from_goal": 0 if self.out is None else int(self.out[2]),
        }


def _heuristic(
    free: NDArray[np.bool_], goal: tuple[int, int], cell: float, clock: PlanClock, obstacles: int
) -> FloatArray:
    """The 2-D heuristic (:func:`planning.planners.lattice.bounded_heuristic` from the ``goal`` cell over
    the ``free`` cells of side ``cell`` [m]) within what is left of ``clock``'s time limit.

    Raises:
        planning.collision.field.FieldTimeout: The time limit passed first (``obstacles``: the world's, for
            the message).
    """
    h2d, finished = lattice.bounded_heuristic(free, goal[0], goal[1], cell, clock.remaining())
    if not finished:
        seconds = clock.elapsed()
        raise FieldTimeout(seconds, free.size, obstacles, clock.code(), ("building the 2-D heuristic", "cells"))
    return h2d


def _ended(out: tuple) -> bool:  # type: ignore[type-arg]
    """Whether a search's result ends it: the goal reached, or every reachable state expanded."""
    return bool(out[0] == lattice.FOUND or out[0] == lattice.EXHAUSTED)


def _read_backwards(path: FloatArray, dirs: FloatArray, start: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The path of the search from the goal (poses (K, 3) from the goal to the start, and each pose's
    direction of arrival in that search's time), read from the start to the goal: each move is driven
    the other way, and the headings are shifted by whole turns to leave from the start's own."""
    poses = path[::-1].copy()
    poses[:, 2] -= 2.0 * np.pi * np.round((poses[0, 2] - start[2]) / (2.0 * np.pi))
    poses[0] = start
    arrive = -dirs[::-1]  # the move into pose k (from k - 1) is the other search's move out of it
    out = np.concatenate([arrive[:1], arrive[:-1]]) if arrive.shape[0] > 1 else arrive.copy()
    return poses, out


def _branch(
    nodes: FloatArray, meta: NDArray[np.int64], prims: Primitives, end: int, tail: FloatArray, tail_dirs: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Dense poses (K, 3) and directions (K,) from the start to node ``end``, then along ``tail``."""
    chain = [end]
    while meta[chain[-1], 0] >= 0:
        chain.append(int(meta[chain[-1], 0]))
    chain.reverse()
    child, parent = np.array(chain[1:], dtype=np.int64), np.array(chain[:-1], dtype=np.int64)
    prim = meta[child, 1]
    # each primitive's samples after its first, placed at its parent's pose, all at once
    segs = place(prims.body[prim, 1:], nodes[parent, None, :3])
    segs[:, -1] = nodes[child, :3]
    parts = [nodes[chain[0], :3][None, :], segs.reshape(-1, 3)]
    dparts = [np.ones(1), np.repeat(prims.directions[prim], segs.shape[1])]
    if tail.shape[0] > 1:
        parts.append(tail[1:])
        dparts.append(tail_dirs[1:])
    path, dirs = np.vstack(parts), np.concatenate(dparts)
    path[:, 2] = unwrap_heading(path[:, 2])
    if dirs.shape[0] > 1:
        dirs[0] = dirs[1]
    return path, dirs
