"""Hybrid-A* against rrt-star: time to its (only) path and its length, on the built-in worlds and on
random seeded worlds (``nhsim bench hybrid [--random N] [--seeds N]``).

Per problem: Hybrid-A*'s status, median wall time and least process (CPU) time over ``repeats``
runs (the world's distance grid built before timing, as in ``nhsim bench plan``), expansions and
length; rrt-star's median length over ``seeds`` seeds at its default budget (5000 iterations), and
the ratio. Both plan with the 1 cm clearance ``nhsim simulate`` gives planners. Targets:
time <= 0.2 s, length <= 1.1x rrt-star's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from planning.core.geometry import Pose2D
from planning.core.robot import ROBOTS, load_robot
from planning.core.world import Box, Circle, World
from planning.planners.base import PlanProblem
from planning.planners.registry import make_planner
from planning.scenario import Scenario, builtin_scenarios, load_scenario

TIME_TARGET_S = 0.2
LENGTH_TARGET = 1.1
CLEARANCE = 0.01


@dataclass(frozen=True)
class HybridRow:
    """One problem's figures (lengths in m, times in s; nan where rrt-star found no path)."""

    world: str
    robot: str
    status: str
    wall_s: float
    cpu_s: float
    expansions: int
    length_m: float
    rrt_star_m: float

    @property
    def ratio(self) -> float:
        """Hybrid-A* length over rrt-star's."""
        return self.length_m / self.rrt_star_m


def unseen_world(seed: int) -> Scenario:
    """A 7 x 5 m arena with nine discs and boxes from ``seed``, the corners (-3, -2) and (3, 2) kept clear."""
    rng = np.random.default_rng(5000 + seed)
    ends = np.array([[-3.0, -2.0], [3.0, 2.0]])
    obstacles: list[Circle | Box] = []
    while len(obstacles) < 9:
        c = rng.uniform([-3.0, -2.0], [3.0, 2.0])
        size = rng.uniform(0.15, 0.45)
        if np.min(np.hypot(*(ends - c).T)) > size + 0.5:
            box = Box((float(c[0]), float(c[1])), (2 * size, 0.6 * size), float(rng.uniform(0, np.pi)))
            obstacles.append(box if rng.random() < 0.5 else Circle((float(c[0]), float(c[1])), float(size)))
    headings = rng.uniform(-np.pi, np.pi, 2)
    start, goal = Pose2D(-3.0, -2.0, float(headings[0])), Pose2D(3.0, 2.0, float(headings[1]))
    world = World((-3.5, 3.5, -2.5, 2.5), tuple(obstacles))
    return Scenario(name=f"unseen{seed}", robot="turtlebot3", world=world, start=start, goal=goal)


def problems(random: int = 0) -> list[tuple[str, str, Scenario]]:
    """(world, robot, scenario) for every built-in scenario with a goal and robot it lists, then ``random``
    unseen worlds for both robots."""
    out = []
    for name in builtin_scenarios():
        sc = load_scenario(name)
        if sc.start.distance_to(sc.goal) > 0 or sc.start.heading_error_to(sc.goal) > 0:
            out += [(name, robot, sc.with_robot(robot)) for robot in sc.robots]
    for seed in range(random):
        sc = unseen_world(seed)
        out += [(sc.name, robot, sc.with_robot(robot)) for robot in ("turtlebot3", "edumip")]
    return out


def measure(world: str, robot: str, sc: Scenario, *, seeds: int = 3, repeats: int = 3) -> HybridRow:
    """Hybrid-A* and rrt-star on one problem (see the module doc)."""
    spec = load_robot(robot)
    problem = PlanProblem.from_scenario(sc, robot=spec, time_limit=30.0)
    planner = make_planner("hybrid-a-star", clearance=CLEARANCE)
    planner.plan(problem)  # builds the world's distance grid and loads the compiled kernels
    walls, cpus = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        res = planner.plan(problem)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    star = []
    for seed in range(seeds):
        r = make_planner("rrt-star", clearance=CLEARANCE).plan(PlanProblem.from_scenario(sc, robot=spec, seed=seed))
        star.append(r.length() if r.success else np.nan)
    ref = float(np.nanmedian(star)) if np.any(np.isfinite(star)) else np.nan
    its = int(res.stats.get("iterations", 0))
    return HybridRow(world, robot, res.status.value, float(np.median(walls)), min(cpus), its, res.length(), ref)


def passed(rows: list[HybridRow]) -> bool:
    """Whether every problem succeeded within the time target and the length target. The time judged is the median
    wall time of the repeats, what a user waits (the benchmarks' index says so; the least CPU time was judged, a
    gentler number on a loaded machine); the CPU time is printed beside it."""
    return all(r.status == "success" and r.wall_s <= TIME_TARGET_S and r.ratio <= LENGTH_TARGET for r in rows)


def format_rows(rows: list[HybridRow]) -> list[str]:
    """The table: one line per problem, then the worst time and ratio against the targets."""
    rw = max(map(len, ROBOTS.built_in())) + 2  # the longest robot name ("edumip-balancing") and a gap
    lines = [f"{'world':<18}{'robot':<{rw}}{'status':<10}{'wall ms':>9}{'cpu ms':>9}{'exp':>7}{'length':>9}"
             f"{'rrt*':>9}{'ratio':>8}"]  # fmt: skip
    for r in rows:
        lines.append(
            f"{r.world:<18}{r.robot:<{rw}}{r.status:<10}{1e3 * r.wall_s:>9.1f}{1e3 * r.cpu_s:>9.1f}{r.expansions:>7}"
            f"{r.length_m:>9.3f}{r.rrt_star_m:>9.3f}{r.ratio:>8.3f}"
        )
    if rows:
        wall, cpu, ratio = max(r.wall_s for r in rows), max(r.cpu_s for r in rows), max(r.ratio for r in rows)
        lines.append(
            f"worst: wall {1e3 * wall:.1f} ms, cpu {1e3 * cpu:.1f} ms (target {1e3 * TIME_TARGET_S:.0f} ms); "
            f"ratio {ratio:.3f} (target {LENGTH_TARGET})"
        )
    return lines
