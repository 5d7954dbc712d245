"""The optimisation planner at the TurtleBot planning report's resolution against its default
(``nhsim bench optim``).

Parallel park and navigation map 1 are each solved with the planner's default N and dt, and at the report's
resolution, dt = 0.01, over the same horizon: the default's (N dt, which the planner fits to the scenario:
10 s on parallel park, where the report's N = 1000 is that horizon; 17.8 s on navigation map 1, where the
report's fixed 10 s is too short for any resolution: N = 50 and N = 100 over 10 s were infeasible too, so a
comparison at N = 1000 raced two problems). Each is solved repeatedly, after one untimed solve that builds and
caches its NLP. Measured per scenario: median wall time of ``plan()`` for each setting
and their ratio, the rolled-out final state's error against the goal for each, and the path lengths.
Targets: default >= 10x faster, its final position within 1 mm of the goal, its path length within
5 % of the report setting's.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Any

TARGET_SPEEDUP = 10.0
TARGET_FINAL_ERROR = 1e-3  # m
TARGET_LENGTH_REL = 0.05
SEED_N, SEED_DT = 1000, 0.01


@dataclass(frozen=True)
class Solve:
    """One setting's solves of a scenario: median wall time [s] and the last result (a PlanResult)."""

    median_s: float
    result: Any


@dataclass(frozen=True)
class OptimBench:
    """Both settings on one scenario.

    Attributes:
        scenario: Scenario name.
        seed: The TurtleBot planning report's resolution (dt = 0.01) over the default's horizon.
        default: The planner's default setting.
    """

    scenario: str
    seed: Solve
    default: Solve

    @property
    def speedup(self) -> float:
        """The report setting's time over the default's."""
        return self.seed.median_s / self.default.median_s

    @property
    def length_rel(self) -> float:
        """|default length / report setting's length - 1| (inf for an empty path at the report's setting)."""
        seed_len = self.seed.result.length()
        return abs(self.default.result.length() / seed_len - 1.0) if seed_len > 0 else float("inf")

    @property
    def final_error_m(self) -> float:
        """The default setting's final position error [m]."""
        return float(self.default.result.stats.get("final_position_error", float("inf")))

    @property
    def passed(self) -> bool:
        """Both solved and every target met."""
        return bool(
            self.seed.result.success
            and self.default.result.success
            and self.speedup >= TARGET_SPEEDUP
            and self.final_error_m <= TARGET_FINAL_ERROR
            and self.length_rel <= TARGET_LENGTH_REL
        )


def measure(scenario: str, repeats: int = 5) -> OptimBench:
    """Solve a scenario with both settings ``repeats`` times each, after one untimed solve.

    Raises:
        ConfigError: ``repeats`` < 1, or an unknown scenario.
    """
    from planning.core.checks import check_number
    from planning.planners.base import PlanProblem
    from planning.planners.optim import Optim
    from planning.scenario import load_scenario

    check_number("--repeats", repeats, integer=True, at_least=1)
    problem = PlanProblem.from_scenario(load_scenario(scenario))
    default = _solves(Optim(), problem, repeats)
    horizon = default.result.stats["N"] * default.result.stats["dt"]
    report = _solves(Optim(N=max(1, round(horizon / SEED_DT)), dt=SEED_DT), problem, repeats)
    return OptimBench(scenario, report, default)


def _solves(planner: Any, problem: Any, repeats: int) -> Solve:
    """``repeats`` timed solves after one untimed one that builds and caches the NLP."""
    planner.plan(problem)
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = planner.plan(problem)
        times.append(time.perf_counter() - t0)
    return Solve(statistics.median(times), result)
