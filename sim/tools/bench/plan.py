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

import argparse
import time
from typing import Any

import numpy as np

TTFS_TARGET = 3.0
LENGTH_TARGET = 1.05


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--seeds", type=int, default=20, help="seeds per scenario (default: 20)")
    p.add_argument(
        "--scenarios", nargs="*", default=None, help="scenario names (default: all with start != goal, and disc10)"
    )
    p.add_argument("--space", choices=["reeds_shepp", "dubins"], default="reeds_shepp")
    p.add_argument("--budget", type=float, default=1.0, metavar="S", help="RRT* time budget [s] (default: 1)")
    p.add_argument("--ttfs-limit", type=float, default=10.0, metavar="S", help="time limit for first solutions")
    p.add_argument("--quick", action="store_true", help="5 seeds, disc10 only, 0.5 s budget")


def _problems(names: list[str] | None) -> list[Any]:
    from planning.core.geometry import Pose2D
    from planning.core.robot import load_robot
    from planning.core.world import Circle, World
    from planning.planners.base import PlanProblem
    from planning.scenario import builtin_scenarios, load_scenario

    disc10 = PlanProblem(
        World((0.0, 10.0, 0.0, 10.0), (Circle((5.0, 5.0), 2.0),)), load_robot("turtlebot3"),
        Pose2D(1.0, 1.0, 0.0), Pose2D(9.0, 9.0, 0.0), name="disc10",
    )  # fmt: skip
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


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    from planning.planners.base import PlanStatus
    from planning.planners.registry import make_planner
    from planning.planners.sampling.extend import LocalPlanner
    from planning.planners.sampling.tree import make_checker

    if args.quick:
        args.seeds, args.scenarios, args.budget = 5, args.scenarios or ["disc10"], 0.5
    try:
        import ompl  # noqa: F401
    except ImportError:
        print("OMPL is not installed: install the bench extra (pip install -e '.[bench]' or pip install ompl); "
              "skipping the OMPL race. Our planners' numbers alone prove nothing, so this run fails.")  # fmt: skip
        return 1
    problems = _problems(args.scenarios)
    missed = False
    print(f"space {args.space}, {args.seeds} seeds per scenario, RRT* budget {args.budget:g} s")
    header = f"{'scenario':<16}{'pair':<26}{'ours':>12}{'OMPL':>12}{'ratio':>9}  target"
    print(header)
    for prob in problems:
        checker = make_checker(prob, "footprint", 0.0)  # builds the distance grid (not timed)
        local = LocalPlanner(args.space, prob.robot, checker)
        assert local.rho is not None, "curve steering always has a turning radius"
        ompl_run = _Ompl(prob, args.space, checker, float(local.rho), local.sample_step)
        birrt = make_planner("birrt", steering=args.space, max_iterations=10**7, time_limit=args.ttfs_limit)
        rstar = make_planner("rrt-star", steering=args.space, max_iterations=10**8, time_limit=args.budget)
        birrt.plan(prob)  # warm-up (compiled kernels loaded)
        rows: dict[str, list[float]] = {k: [] for k in ("t_us", "t_om", "ok_us", "ok_om", "l_us", "l_om")}
        for seed in range(args.seeds):
            p = type(prob)(**{**prob.__dict__, "seed": seed})
            t0 = time.perf_counter()
            r = birrt.plan(p)
            rows["t_us"].append(time.perf_counter() - t0)
            rows["ok_us"].append(float(r.status is PlanStatus.SUCCESS))
            ok, dt, _ = ompl_run.solve("RRTConnect", seed, args.ttfs_limit, True)
            rows["t_om"].append(dt)
            rows["ok_om"].append(float(ok))
            rs = rstar.plan(p)
            rows["l_us"].append(float(rs.stats.get("cost_m", np.nan)))
            _, _, length = ompl_run.solve("RRTstar", seed, args.budget, False)
            rows["l_om"].append(length)
        t_ratio = np.median(rows["t_us"]) / np.median(rows["t_om"])
        l_ratio = np.nanmedian(rows["l_us"]) / np.nanmedian(rows["l_om"])
        s_us, s_om = np.mean(rows["ok_us"]), np.mean(rows["ok_om"])
        miss_t, miss_l, miss_s = bool(t_ratio > TTFS_TARGET), not l_ratio <= LENGTH_TARGET, bool(s_us < s_om)
        missed |= miss_t or miss_l or miss_s
        name = prob.name
        print(
            f"{name:<16}{'TTFS ms birrt/RRTConnect':<26}{1e3 * np.median(rows['t_us']):>12.2f}"
            f"{1e3 * np.median(rows['t_om']):>12.2f}{t_ratio:>9.2f}  <= {TTFS_TARGET}{'  MISSED' if miss_t else ''}"
        )
        flag = "  MISSED" if miss_s else ""
        print(f"{'':<16}{'success birrt/RRTConnect':<26}{s_us:>12.2f}{s_om:>12.2f}{'':>9}  equal{flag}")
        print(
            f"{'':<16}{'length m rrt-star/RRT*':<26}{np.nanmedian(rows['l_us']):>12.3f}"
            f"{np.nanmedian(rows['l_om']):>12.3f}{l_ratio:>9.3f}  <= {LENGTH_TARGET}{'  MISSED' if miss_l else ''}"
        )
        print(f"{'':<16}{'RRT* success (ours/OMPL)':<26}{np.mean(np.isfinite(rows['l_us'])):>12.2f}"
              f"{np.mean(np.isfinite(rows['l_om'])):>12.2f}")  # fmt: skip
    return 1 if missed else 0
