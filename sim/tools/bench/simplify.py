"""``nhsim bench simplify``: simplified birrt and rrt paths against rrt-star's on the same problems.

Problems: every built-in scenario whose start differs from its goal (with its own robot and its
``[planners.*]`` options) and random seeded worlds (:func:`planning.scenario.random_scenario`, worlds
no planner was tuned on), all planned with the 1 cm clearance that simulate jobs use. On each,
``rrt-star`` runs at its default budget (anytime: it stops when its cost stalls) and ``birrt`` and
``rrt`` with their defaults, all simplified (the default) and with the same seed.

Targets: simplified birrt and rrt paths within ``LENGTH_TARGET`` x rrt-star's length, with
no more cusps than rrt-star's plus ``CUSP_SLACK``, for at most ``TIME_TARGET_S`` of simplification
(CPU time of the simplifying thread: what the wall time is on an idle machine; the wall time is
printed beside it; the obstacle-aware 2-D route the simplifier tries is computed anew for every row,
not taken from the cache rrt-star's plan of the same problem filled). And for every planned case of
``nhsim simulate --all`` by a sampling planner: its smoothed, timed trajectory no longer than
``TRAJECTORY_TARGET`` x the trajectory rrt-star's plan gives on the same scenario and robot
(:func:`measure_trajectory`; the other planners' rows are printed for comparison).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

LENGTH_TARGET = 1.15
CUSP_SLACK = 1
TIME_TARGET_S = 0.050
TRAJECTORY_TARGET = 1.2
#: Margin the plans keep (as :class:`sim.pipeline.case.PlanOptions` gives simulate jobs) [m].
CLEARANCE = 0.01
RACED = ("birrt", "rrt")
REFERENCE = "rrt-star"
#: Planners whose trajectories the 1.2x target applies to: the sampling planners, which simplify their
#: paths (sinusoidal and optim steer analytically or optimise; their rows are printed for comparison).
TRAJECTORY_TARGETED = ("birrt", "c-rrt-star", "rrt", "rrt-star")


@dataclass(frozen=True)
class PlanRow:
    """One planner on one problem, against rrt-star on the same problem.

    Attributes:
        problem: Problem name.
        planner: Planner name.
        status: The planner's status.
        length: Simplified length [m] (nan without a path).
        raw_length: The search's length [m].
        cusps: Simplified cusps.
        raw_cusps: The search's cusps.
        cpu_s: CPU time of the simplification [s].
        wall_s: Wall time of the simplification [s].
        ref_length: rrt-star's simplified length [m] (nan if it failed).
        ref_cusps: rrt-star's cusps.
    """

    problem: str
    planner: str
    status: str
    length: float
    raw_length: float
    cusps: int
    raw_cusps: int
    cpu_s: float
    wall_s: float
    ref_length: float
    ref_cusps: int

    @property
    def ratio(self) -> float:
        """Length over rrt-star's."""
        return self.length / self.ref_length

    @property
    def missed(self) -> list[str]:
        """The targets this row misses: "success", "length", "cusps", "time"."""
        out = [] if self.status == "success" else ["success"]
        if not self.ratio <= LENGTH_TARGET:
            out.append("length")
        if self.cusps > self.ref_cusps + CUSP_SLACK:
            out.append("cusps")
        if self.cpu_s > TIME_TARGET_S:
            out.append("time")
        return out


def problems(names: list[str] | None, random_worlds: int) -> list[Any]:
    """The scenarios of the benchmark: ``names`` (built-in scenario names or ``random<N>``), or by
    default every built-in scenario whose start differs from its goal; then ``random0`` ..
    ``random<random_worlds - 1>`` for the TurtleBot3 (``--random-worlds`` was dropped beside ``--scenarios``)."""
    from planning.scenario import builtin_scenarios, load_scenario, random_scenario, random_seed

    def one(name: str) -> Any:
        seed = random_seed(name)
        return load_scenario(name) if seed is None else random_scenario("turtlebot3", seed)

    randoms = [random_scenario("turtlebot3", s) for s in range(random_worlds)]  # beside names too, as bench plan has it
    if names is not None:
        return [one(n) for n in names] + randoms
    out = [
        sc for sc in map(load_scenario, builtin_scenarios()) if sc.start.distance_to(sc.goal) > sc.position_tolerance
    ]
    return out + randoms


def _plan(scenario: Any, planner: str, seed: int) -> Any:
    from planning.core.robot import load_robot
    from planning.planners.base import PlanProblem
    from planning.planners.registry import make_planner

    problem = PlanProblem.from_scenario(scenario, robot=load_robot(scenario.robot), seed=seed, time_limit=30.0)
    return make_planner(planner, clearance=CLEARANCE, **scenario.options_for(planner)).plan(problem)


def measure_plans(scenario: Any, seed: int = 0) -> list[PlanRow]:
    """birrt and rrt against rrt-star on one scenario with one seed (one row each); the 2-D route's
    caches are cleared before each, so its simplification time counts the route from nothing."""
    from planning.planners import geodesic

    ref = _plan(scenario, REFERENCE, seed)
    nan = float("nan")
    ref_len = float(ref.stats["length_m"]) if ref.success else nan
    ref_cusps = int(ref.stats["cusps"]) if ref.success else 0
    rows = []
    for name in RACED:
        geodesic.clear_caches()  # each row's simplification time includes its whole 2-D route
        r = _plan(scenario, name, seed)
        st = r.stats
        ok = r.success
        rows.append(
            PlanRow(
                scenario.name,
                name,
                r.status.value,
                float(st["length_m"]) if ok else nan,
                float(st["raw_length_m"]) if ok else nan,
                int(st["cusps"]) if ok else 0,
                int(st["raw_cusps"]) if ok else 0,
                float(st["simplify_cpu_s"]) if ok else 0.0,
                float(st["simplify_time_s"]) if ok else 0.0,
                ref_len,
                ref_cusps,
            )
        )
    return rows


@dataclass(frozen=True)
class TrajectoryRow:
    """One planned case of ``simulate --all``: its trajectory against rrt-star's.

    Attributes:
        scenario: Scenario name.
        robot: Robot name.
        planner: Planner name.
        length: x-y length of the case's trajectory [m] (nan when planning or smoothing failed).
        duration: Its duration [s].
        ref_length: The same for rrt-star's plan on the same scenario and robot [m].
        ref_duration: Its duration [s].
        note: Why a length is missing ("" when none is).
    """

    scenario: str
    robot: str
    planner: str
    length: float
    duration: float
    ref_length: float
    ref_duration: float
    note: str = ""

    @property
    def ratio(self) -> float:
        """Trajectory length over rrt-star's (nan when either is missing)."""
        return self.length / self.ref_length

    @property
    def targeted(self) -> bool:
        """Whether the target applies to this planner (``TRAJECTORY_TARGETED``)."""
        return self.planner in TRAJECTORY_TARGETED

    @property
    def missed(self) -> bool:
        """Whether the target applies, both lengths exist and the ratio is over ``TRAJECTORY_TARGET``."""
        return bool(self.targeted and np.isfinite(self.ratio) and self.ratio > TRAJECTORY_TARGET)


def _trajectory(case: Any) -> tuple[float, float, str]:
    """(length [m], duration [s], "") of a case's trajectory, or (nan, nan, why)."""
    from planning.core.geometry import path_length
    from planning.errors import NhsimError
    from sim.pipeline.case import prepare_trajectory

    try:
        traj = prepare_trajectory(case).trajectory
    except NhsimError as exc:
        return float("nan"), float("nan"), str(exc).split("\n")[0][:60]
    return path_length(traj.pose), float(traj.t[-1] - traj.t[0]), ""


def measure_trajectory(scenarios: list[str] | None, seed: int = 0) -> list[TrajectoryRow]:
    """Every planned case of ``simulate --all`` (of ``scenarios``; default all) against the rrt-star
    case of the same scenario and robot."""
    from sim.pipeline.sweep import sweep_cases

    rows, refs = [], {}
    for case in sweep_cases(scenarios, seed=seed):
        key = (case.scenario_name, case.robot)
        if key not in refs:
            refs[key] = _trajectory(replace(case, planner=REFERENCE, name=""))
        length, duration, note = _trajectory(case) if case.planner != REFERENCE else refs[key]
        ref = refs[key]
        rows.append(
            TrajectoryRow(
                case.scenario_name, str(case.robot), str(case.planner), length, duration, ref[0], ref[1], note
            )
        )
    return rows
