"""Property-based tests of every registered planner's inputs.

Drawn: a planner from the registry with its options (each good, or about one time in forty a bad
value: non-finite, zero, negative, a string, a list, an unknown option); a robot; a world of random
bounds and obstacles; a start and a goal (inside the world, outside it, inside an obstacle, equal,
or not numbers); goal tolerances, a seed and a time budget of a few hundredths of a second (or bad
ones). Iteration budgets are kept small so that each example takes well under a second.

Properties: building the problem and the planner and planning return or raise an NhsimError, nothing
else; every returned number is finite (path, times, controls, states, tree, stats); a success
starts at the start, ends within the goal's tolerances, stays inside the world and keeps the
robot's footprint off every obstacle.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import numpy as np
from hypothesis import event
from hypothesis import strategies as st

from planning.collision.exact import CollisionChecker
from planning.core.geometry import Pose2D, densify_path, wrap_angle
from planning.core.robot import ROBOTS, RobotSpec, load_robot
from planning.core.world import Box, Circle, Ellipse, Polygon, World
from planning.planners.base import PlanProblem, PlanResult, PlanStatus
from planning.planners.registry import PLANNERS, make_planner, planner_options
from tests.fuzz_helpers import (
    BAD_NUMBER,
    TEXT,
    assert_finite,
    coordinate,
    expect_nhsim_errors,
    fast_and_slow,
    maybe_bad,
)


@functools.cache
def robot(name: str) -> RobotSpec:
    """A robot, read once."""
    return load_robot(name)


def _real(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def _opt(good: st.SearchStrategy[Any]) -> st.SearchStrategy[Any]:
    """An option value: ``good``, or about one time in forty a bad one."""
    return maybe_bad(good, st.one_of(BAD_NUMBER, st.sampled_from(["x", None, [], {}])), 40)


_TREE = {
    "steering": st.sampled_from(["bicycle", "unicycle", "diffdrive", "reeds_shepp", "dubins"]),
    "goal_bias": _real(0.0, 1.0),
    "max_iterations": st.integers(1, 200),
    "turning_radius": st.one_of(st.none(), _real(0.05, 2.0)),
    "step_range": st.one_of(st.none(), _real(0.05, 5.0)),
    "goal_connect_radius": _real(0.05, 3.0),
    "n_speeds": st.integers(1, 4),
    "primitive_duration": _real(0.1, 2.0),
    "shape": st.sampled_from(["footprint", "disc"]),
    "clearance": _real(0.0, 0.2),
}
#: Planner -> option -> good values (options not listed keep their defaults).
GOOD_OPTIONS: dict[str, dict[str, st.SearchStrategy[Any]]] = {
    "rrt": _TREE,
    "birrt": _TREE,
    "rrt-star": {**_TREE, "steering": st.sampled_from(["reeds_shepp", "dubins"])},
    "c-rrt-star": {
        "gamma": _real(0.0, 1.0),
        "max_step": _real(0.01, 1.0),
        "neighbour_radius": _real(0.05, 2.0),
        "goal_radius": _real(0.01, 1.0),
        "rho": _real(0.0, 1.0),
        "sigma": _real(0.0, 10.0),
        "center_clearance": st.one_of(st.none(), _real(0.0, 0.6)),
        "max_iterations": st.integers(1, 200),
        "stop_at_goal": st.booleans(),
    },
    "sinusoidal": {
        "u1max": st.one_of(st.none(), _real(0.05, 1.0)),
        "u2max": _real(0.1, 5.0),
        "phimax": st.one_of(st.none(), _real(0.1, 1.5)),
        "tolerance": _real(1e-8, 1e-3),
        "dt": _real(0.005, 0.1),
        "min_period": _real(0.5, 5.0),
        "max_period": _real(1.0, 20.0),
        "max_heading_offset": _real(0.1, 1.5),
    },
    "optim": {
        "N": st.integers(2, 25),
        "dt": st.one_of(st.none(), _real(0.05, 1.0)),
        "init": st.sampled_from(["auto", "straight", "grid", "birrt", "sinusoidal"]),
        "u2max": _real(0.1, 5.0),
        "margin": _real(0.0, 0.1),
        "w_steer": _real(0.0, 1.0),
        "w_smooth": _real(0.0, 1.0),
        "max_iter": st.integers(1, 40),
        "max_resolves": st.integers(0, 2),
    },
    "hybrid-a-star": {
        "angle_quantization_bins": st.integers(4, 120),
        "cell_size": _real(0.01, 0.5),
        "turning_radius": st.one_of(st.none(), _real(0.05, 2.0)),
        "reverse_penalty": _real(1.0, 5.0),
        "change_penalty": _real(0.0, 2.0),
        "non_straight_penalty": _real(1.0, 2.0),
        "analytic_expansion_ratio": _real(0.5, 10.0),
        "analytic_expansion_max_length": _real(0.0, 5.0),
        "allow_primitive_interpolation": st.booleans(),
        "max_iterations": st.integers(1, 5000),
        "search_from_goal": st.booleans(),
        "search_from_goal_after": st.integers(0, 5000),
        "shape": st.sampled_from(["footprint", "disc"]),
        "clearance": _real(0.0, 0.1),
    },
}
#: Options that bound a planner's work, always given (with a good value) so an example stays short.
BUDGET = {"rrt": ("max_iterations",), "birrt": ("max_iterations",), "rrt-star": ("max_iterations",),
          "c-rrt-star": ("max_iterations",), "optim": ("max_iter", "N"),
          "hybrid-a-star": ("max_iterations",)}  # fmt: skip


@dataclasses.dataclass
class PlannerCase:
    """One drawn planning problem: raw values, built (and checked) inside the property."""

    planner: str
    options: dict[str, Any]
    robot: str
    bounds: tuple[float, ...]
    obstacles: list[tuple[str, tuple[Any, ...]]]
    start: tuple[Any, ...]
    goal: tuple[Any, ...]
    problem: dict[str, Any]


@st.composite
def obstacles(draw: st.DrawFn, bounds: tuple[float, ...]) -> list[tuple[str, tuple[Any, ...]]]:
    """Up to four obstacles (kind, constructor arguments) inside ``bounds``."""
    out: list[tuple[str, tuple[Any, ...]]] = []
    for _ in range(draw(st.integers(0, 4))):
        c = (draw(_real(bounds[0], bounds[1])), draw(_real(bounds[2], bounds[3])))
        kind = draw(st.sampled_from(["circle", "ellipse", "box", "polygon"]))
        if kind == "circle":
            out.append((kind, (c, draw(_real(0.05, 1.0)))))
        elif kind == "polygon":
            k = draw(st.integers(3, 6))
            angles = [2 * math.pi * (i + draw(st.floats(-0.2, 0.2))) / k for i in range(k)]
            radii = [draw(_real(0.1, 0.8)) for _ in range(k)]
            vertices = tuple(
                (c[0] + r * math.cos(a), c[1] + r * math.sin(a)) for a, r in zip(angles, radii, strict=True)
            )
            out.append((kind, (vertices,)))
        else:
            out.append((kind, (c, (draw(_real(0.05, 1.0)), draw(_real(0.05, 1.0))), draw(_real(-4.0, 4.0)))))
    return out


@st.composite
def pose(draw: st.DrawFn, bounds: tuple[float, ...]) -> tuple[Any, ...]:
    """A pose inside the bounds, or about one time in eight outside them or not made of numbers."""
    margin = 0.2  # [m] off the walls, so that most poses leave the robot inside
    inside = st.tuples(
        _real(bounds[0] + margin, bounds[1] - margin), _real(bounds[2] + margin, bounds[3] - margin), _real(-7.0, 7.0)
    )
    bad = st.tuples(
        st.one_of(coordinate(-1e3, 1e3), BAD_NUMBER), coordinate(-1e3, 1e3), st.one_of(_real(-7, 7), BAD_NUMBER)
    )
    return draw(maybe_bad(inside, bad, 16))


@st.composite
def planner_cases(draw: st.DrawFn) -> PlannerCase:
    """A planner with options, and a problem for it."""
    planner = draw(st.sampled_from(sorted(PLANNERS)))
    good = GOOD_OPTIONS.get(planner, {})
    budget = {k: good[k] for k in BUDGET.get(planner, ())}
    options = draw(st.fixed_dictionaries(budget, optional={k: _opt(v) for k, v in good.items() if k not in budget}))
    options |= draw(maybe_bad(st.just({}), st.dictionaries(TEXT, st.integers(), min_size=1, max_size=1), 40))
    x0, y0 = draw(coordinate(-10, 10)), draw(coordinate(-10, 10))
    bounds = (x0, x0 + draw(_real(1.0, 8.0)), y0, y0 + draw(_real(1.0, 8.0)))
    start = draw(pose(bounds))
    goal = draw(st.one_of(pose(bounds), st.just(start)))
    problem = {
        "position_tolerance": maybe_bad(_real(0.01, 0.5), BAD_NUMBER, 32),
        "heading_tolerance": maybe_bad(_real(0.01, 1.0), BAD_NUMBER, 32),
        "seed": maybe_bad(st.integers(0, 2**32), st.sampled_from([-1, 1.5, "seed", True]), 32),
        "time_limit": maybe_bad(_real(0.01, 0.1), BAD_NUMBER, 32),
    }
    return PlannerCase(
        planner, options, draw(st.sampled_from(sorted(ROBOTS))), bounds, draw(obstacles(bounds)), start, goal,
        draw(st.fixed_dictionaries(problem)),
    )  # fmt: skip


_KINDS = {"circle": Circle, "ellipse": Ellipse, "box": Box, "polygon": Polygon}


def _problem(case: PlannerCase) -> PlanProblem:
    world = World(case.bounds, tuple(_KINDS[kind](*args) for kind, args in case.obstacles))
    return PlanProblem(world, robot(case.robot), Pose2D(*case.start), Pose2D(*case.goal), **case.problem)


def _check_success(res: PlanResult, problem: PlanProblem) -> None:
    """A successful path starts at the start, ends at the goal, stays in the world and off the obstacles."""
    path = res.path
    assert np.allclose(path[0, :2], problem.start.xy, atol=1e-6), (path[0], problem.start)
    assert abs(wrap_angle(path[0, 2] - problem.start.theta)) < 1e-6, (path[0], problem.start)
    end = Pose2D(*path[-1])
    assert end.distance_to(problem.goal) <= problem.position_tolerance + 1e-9, (end, problem.goal)
    assert end.heading_error_to(problem.goal) <= problem.heading_tolerance + 1e-9, (end, problem.goal)
    dense = densify_path(path, 0.005, radius=problem.robot.radius)
    clearance = CollisionChecker(problem.world, problem.robot, shape="footprint").clearance_of(dense)
    assert float(np.min(clearance)) > -0.01, f"the path cuts an obstacle or a wall by {-np.min(clearance):.3f} m"


def planner_property(case: PlannerCase) -> None:
    """Only NhsimErrors; finite results; a success that is one."""
    problem, err = expect_nhsim_errors(lambda: _problem(case))
    if err is None:
        planner, err = expect_nhsim_errors(lambda: make_planner(case.planner, **case.options))
    if err is None:
        res, err = expect_nhsim_errors(lambda: planner.plan(problem))
    if err is not None:
        event("refused", str(err)[:50])
        return
    assert isinstance(res, PlanResult) and isinstance(res.status, PlanStatus)
    assert res.status is PlanStatus.SUCCESS or res.reason, f"{res.status} without a reason"
    for name in ("path", "times", "controls", "directions", "states"):
        assert_finite(getattr(res, name), name)
    if res.tree is not None:
        assert_finite(res.tree.nodes, "tree.nodes")
        assert_finite(list(res.tree.edges), "tree.edges")
    assert_finite(res.stats, "stats")
    if res.success:
        _check_success(res, problem)
    event(case.planner, res.status.value)


test_planners_fast, test_planners_slow = fast_and_slow(planner_cases(), planner_property, fast=15)


def test_every_planner_and_its_options_are_drawn() -> None:
    """The strategy knows every registered planner's options (a new option or planner fails here)."""
    for name in PLANNERS:
        assert name in GOOD_OPTIONS, f"add {name!r} to GOOD_OPTIONS: its options and good values for them ({{}}: none)"
        assert set(GOOD_OPTIONS[name]) <= set(planner_options(name)), name
