"""``nhsim bench plan``: our tree planners against OMPL's on the same problems and collision checker.

Pairs: OMPL ``RRTConnect`` against ``birrt`` (time to first solution, success rate) and OMPL
``RRTstar`` against ``rrt-star`` (path length after the same wall-clock budget), both on a
Reeds–Shepp (or Dubins) state space with the same turning radius. OMPL's validity checker is our
collision checker (its fast exact front end, one pose per call), and OMPL checks motions at the
same spacing as ours. Scenarios: every built-in scenario whose start differs from its goal, plus
``disc10`` (10 x 10 m, one disc of radius 2 m, start (1, 1, 0), goal (9, 9, 0)). Each scenario
runs ``--seeds`` seeds. Targets: birrt median TTFS <= 3x OMPL's, rrt-star median length <= 1.05x
OMPL's, success rates equal. The one-off distance-grid build of each world is done before timing.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

TTFS_TARGET = 3.0
LENGTH_TARGET = 1.05


def problems(names: list[str] | None) -> list[Any]:
    """The problems of the race: ``names`` (scenario names or "disc10"), or by default disc10 and every
    built-in scenario whose start differs from its goal."""
    from planning.core.geometry import Pose2D
    from planning.core.robot import load_robot
    from planning.core.world import Circle, World
    from planning.planners.base import PlanProblem
    from planning.scenario import builtin_scenarios, load_scenario

    disc10 = PlanProblem(
        World((0.0, 10.0, 0.0, 10.0), (Circle((5.0, 5.0), 2.0),)),
        load_robot("turtlebot3"),
        Pose2D(1.0, 1.0, 0.0),
        Pose2D(9.0, 9.0, 0.0),
        name="disc10",
    )
    if names is None:
        out = [disc10]
        for sc in builtin_scenarios():
            s = load_scenario(sc) if isinstance(sc, str) else sc
            if np.hypot(s.start.x - s.goal.x, s.start.y - s.goal.y) > s.position_tolerance:
                out.append(PlanProblem.from_scenario(s))
        return out
    return [disc10 if n == "disc10" else PlanProblem.from_scenario(load_scenario(n)) for n in names]


class _Ompl:
    """OMPL on a Reeds–Shepp / Dubins space with our checker as its validity checker."""

    def __init__(self, problem: Any, space: str, checker: Any, rho: float, step: float) -> None:
        from ompl import base as ob
        from ompl import util as ou

        ou.setLogLevel(ou.LogLevel.LOG_NONE)
        self.ob, self.ou = ob, ou
        sp = ob.ReedsSheppStateSpace(rho) if space == "reeds_shepp" else ob.DubinsStateSpace(rho)
        b = ob.RealVectorBounds(2)
        xmin, xmax, ymin, ymax = problem.world.bounds
        b.setLow(0, xmin)
        b.setHigh(0, xmax)
        b.setLow(1, ymin)
        b.setHigh(1, ymax)
        sp.setBounds(b)
        self.space, self.problem, self.checker, self.step = sp, problem, checker, step

    def solve(self, planner: str, seed: int, limit: float, stop_first: bool) -> tuple[bool, float, float]:
        """(exact solution found, wall time of solve() [s], path length [m])."""
        from ompl import geometric as og

        ob = self.ob
        self.ou.RNG.setSeed(seed + 1)
        ss = og.SimpleSetup(self.space)
        buf = np.empty((1, 3))
        chk = self.checker

        def valid(s: Any) -> bool:
            buf[0, 0], buf[0, 1], buf[0, 2] = s.getX(), s.getY(), s.getYaw()
            return chk.path_free(buf)

        ss.setStateValidityChecker(valid)
        si = ss.getSpaceInformation()
        si.setStateValidityCheckingResolution(self.step / si.getMaximumExtent())
        st, gl = self.space.allocState(), self.space.allocState()
        for s, p in ((st, self.problem.start), (gl, self.problem.goal)):
            s.setX(p.x)
            s.setY(p.y)
            s.setYaw(p.theta)
        ss.setStartAndGoalStates(st, gl, self.problem.position_tolerance)
        if planner == "RRTConnect":
            ss.setPlanner(og.RRTConnect(si))
        else:
            obj = ob.PathLengthOptimizationObjective(si)
            obj.setCostThreshold(ob.Cost(0.0 if not stop_first else np.inf))
            ss.setOptimizationObjective(obj)
            ss.setPlanner(og.RRTstar(si))
        ss.setup()
        t0 = time.perf_counter()
        status = ss.solve(limit)
        dt = time.perf_counter() - t0
        ok = ss.haveExactSolutionPath() and str(status) == "Exact solution"
        length = ss.getSolutionPath().length() if ok else float("nan")
        return ok, dt, float(length)


@dataclass(frozen=True)
class PlanBench:
    """Our planners against OMPL's on one problem over many seeds.

    Attributes:
        problem: Problem name.
        ttfs_ours: Times to first solution of birrt [s], one per seed.
        ttfs_ompl: Times to first solution of OMPL's RRTConnect [s].
        solved_ours: 1.0 where birrt succeeded, else 0.0.
        solved_ompl: 1.0 where RRTConnect found an exact solution.
        length_ours: Path lengths of rrt-star after the budget [m] (nan: none).
        length_ompl: Path lengths of OMPL's RRT* after the budget [m] (nan: none).
    """

    problem: str
    ttfs_ours: tuple[float, ...]
    ttfs_ompl: tuple[float, ...]
    solved_ours: tuple[float, ...]
    solved_ompl: tuple[float, ...]
    length_ours: tuple[float, ...]
    length_ompl: tuple[float, ...]

    @property
    def ttfs_ratio(self) -> float:
        """Median TTFS, ours over OMPL's."""
        return float(np.median(self.ttfs_ours) / np.median(self.ttfs_ompl))

    @property
    def length_ratio(self) -> float:
        """Median length (of the paths found), ours over OMPL's."""
        return float(np.nanmedian(self.length_ours) / np.nanmedian(self.length_ompl))

    @property
    def missed(self) -> dict[str, bool]:
        """Target -> missed: "ttfs", "length", "success" (ours below OMPL's rate)."""
        return {
            "ttfs": bool(self.ttfs_ratio > TTFS_TARGET),
            "length": not self.length_ratio <= LENGTH_TARGET,
            "success": bool(np.mean(self.solved_ours) < np.mean(self.solved_ompl)),
        }


def ompl_available() -> bool:
    """Whether OMPL's Python bindings import."""
    try:
        import ompl  # noqa: F401
    except ImportError:
        return False
    return True


def measure(problem: Any, space: str, seeds: int, budget: float, ttfs_limit: float) -> PlanBench:
    """Race birrt against RRTConnect (first solution within ``ttfs_limit`` [s]) and rrt-star against
    RRT* (length after ``budget`` [s]) on one problem for ``seeds`` seeds, on the same checker."""
    from planning.planners.base import PlanStatus
    from planning.planners.registry import make_planner
    from planning.planners.sampling.extend import LocalPlanner
    from planning.planners.sampling.tree import make_checker

    checker = make_checker(problem, "footprint", 0.0)  # builds the distance grid (not timed)
    local = LocalPlanner(space, problem.robot, checker)
    assert local.rho is not None, "curve steering always has a turning radius"
    ompl_run = _Ompl(problem, space, checker, float(local.rho), local.sample_step)
    # raced as OMPL runs them: birrt's first path unsimplified, rrt-star for the whole budget
    birrt = make_planner("birrt", steering=space, max_iterations=10**7, time_limit=ttfs_limit, simplify=False)
    rstar = make_planner(
        "rrt-star", steering=space, max_iterations=10**8, time_limit=budget, simplify=False, improvement_tol=0.0
    )
    birrt.plan(problem)  # warm-up (compiled kernels loaded)
    rows: dict[str, list[float]] = {k: [] for k in ("t_us", "t_om", "ok_us", "ok_om", "l_us", "l_om")}
    for seed in range(seeds):
        p = type(problem)(**{**problem.__dict__, "seed": seed})
        t0 = time.perf_counter()
        r = birrt.plan(p)
        rows["t_us"].append(time.perf_counter() - t0)
        rows["ok_us"].append(float(r.status is PlanStatus.SUCCESS))
        ok, dt, _ = ompl_run.solve("RRTConnect", seed, ttfs_limit, True)
        rows["t_om"].append(dt)
        rows["ok_om"].append(float(ok))
        rs = rstar.plan(p)
        rows["l_us"].append(float(rs.stats.get("cost_m", np.nan)))
        _, _, length = ompl_run.solve("RRTstar", seed, budget, False)
        rows["l_om"].append(length)
    return PlanBench(problem.name, *(tuple(rows[k]) for k in ("t_us", "t_om", "ok_us", "ok_om", "l_us", "l_om")))
