"""OMPL's Python wheel (``pip install ompl``) on our problems, the second column of ``nhsim bench plan``.

Its validity checker is a Python callback into :class:`FastChecker` (one pose per call), so every
state check pays the Python call; the C++ harness (:mod:`sim.tools.bench.ompl_native`) is the fair race.
Motions are checked at the same curve spacing (the state-validity resolution set from ``step``).
Its goal is OMPL's own (the Reeds–Shepp distance to the goal pose within the position tolerance),
not our region: the column is shown, not judged.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from planning.planners.base import PlanProblem


def _wrap(theta: float) -> float:
    """``theta`` in [-pi, pi) (OMPL's SO2 bounds reject +pi)."""
    return float(theta - 2.0 * np.pi * np.floor((theta + np.pi) / (2.0 * np.pi)))


class WheelOmpl:
    """OMPL (Python) on a Reeds–Shepp / Dubins space with our checker as its validity checker.

    Args:
        problem: The problem.
        space: "reeds_shepp" or "dubins".
        checker: Our :class:`FastChecker`.
        rho: Turning radius [m].
        step: Motion-check spacing along the curve [m].
    """

    def __init__(self, problem: PlanProblem, space: str, checker: Any, rho: float, step: float) -> None:
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

    def solve(self, planner: str, seed: int, limit: float) -> tuple[bool, float, float]:
        """(exact path found, wall time of solve() [s], path length [m] or nan)."""
        from ompl import geometric as og

        ob = self.ob
        self.ou.RNG.setSeed(seed + 1)
        ss = og.SimpleSetup(self.space)
        buf = np.empty((1, 3))
        chk = self.checker

        def valid(s: Any) -> bool:
            buf[0, 0], buf[0, 1], buf[0, 2] = s.getX(), s.getY(), s.getYaw()
            return bool(chk.path_free(buf))

        ss.setStateValidityChecker(valid)
        si = ss.getSpaceInformation()
        si.setStateValidityCheckingResolution(self.step / si.getMaximumExtent())
        st, gl = self.space.allocState(), self.space.allocState()
        for s, p in ((st, self.problem.start), (gl, self.problem.goal)):
            s.setX(p.x)
            s.setY(p.y)
            s.setYaw(_wrap(p.theta))
        ss.setStartAndGoalStates(st, gl, self.problem.position_tolerance)
        if planner == "RRTConnect":
            ss.setPlanner(og.RRTConnect(si))
        else:
            obj = ob.PathLengthOptimizationObjective(si)
            obj.setCostThreshold(ob.Cost(0.0))
            ss.setOptimizationObjective(obj)
            ss.setPlanner(og.RRTstar(si))
        t0 = time.perf_counter()
        ss.solve(ob.timedPlannerTerminationCondition(limit))  # no watchdog thread (ss.solve(limit) starts one)
        dt = time.perf_counter() - t0
        ok = bool(ss.haveExactSolutionPath())
        return ok, dt, float(ss.getSolutionPath().length()) if ok else float("nan")
