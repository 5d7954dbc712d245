"""Bad planner inputs raise ConfigError naming the field (each case below raised something else, or
planned on, before: found by tests/test_fuzz_planners.py)."""

from __future__ import annotations

import dataclasses
import inspect
import math
import re
from typing import Any

import numpy as np
import pytest

from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, Ellipse, World
from planning.errors import ConfigError
from planning.planners.base import PlanProblem, PlanStatus
from planning.planners.registry import PLANNERS, make_planner, planner_options
from planning.planners.sampling.crrt_star import CRRTStarConfig

ROBOT = load_robot("turtlebot3")
WORLD = World((0.0, 3.0, 0.0, 2.0))


def _problem(**fields: Any) -> PlanProblem:
    base: dict[str, Any] = {
        "world": WORLD,
        "robot": ROBOT,
        "start": Pose2D(0.5, 1.0, 0.0),
        "goal": Pose2D(2.5, 1.0, 0.0),
    }
    return PlanProblem(**(base | fields))


@pytest.mark.parametrize(
    ("fields", "match"),
    [  # a NaN tolerance made rrt report success for start == goal; a negative seed raised numpy's ValueError
        ({"position_tolerance": math.nan}, r"PlanProblem.position_tolerance must be a finite number > 0, got nan"),
        (
            {"heading_tolerance": -0.1},
            r"PlanProblem.heading_tolerance must be a finite number in \(0, 3.14159\] \(rad\), got -0.1",
        ),
        (
            {"heading_tolerance": 180},
            r"heading_tolerance .*, got 180; pi takes any heading; 180 degrees would be 3.142 rad",
        ),
        ({"time_limit": 0.0}, r"PlanProblem.time_limit must be a finite number > 0, got 0.0"),
        ({"time_limit": []}, r"PlanProblem.time_limit must be a finite number > 0, got \[\]"),
        ({"seed": -1}, r"PlanProblem.seed must be an integer >= 0, got -1"),
        ({"seed": 1.5}, r"PlanProblem.seed must be an integer >= 0, got 1.5"),
        ({"start": (0.5, 1.0, 0.0)}, r"PlanProblem.start must be a Pose2D: pass Pose2D\(0\.5, 1\.0, 0\.0\), got tuple"),
        ({"robot": "edumip"}, r"^PlanProblem: robot must be a RobotSpec \(load_robot\('edumip'\)\), got 'edumip'$"),
        (
            {"world": None},
            r"^PlanProblem.world must be a World: pass World\(\(xmin, xmax, ymin, ymax\), obstacles\), or ",
        ),
    ],
)
def test_a_bad_problem_field_is_refused_when_the_problem_is_made(fields: dict[str, Any], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        _problem(**fields)


@pytest.mark.parametrize(
    ("make", "match"),
    [  # these raised ValueError (a NaN or a string), or built a world whose distances are not finite
        (lambda: Pose2D(math.nan, 0.0, 0.0), r"Pose2D.x must be a finite number, got nan"),
        (lambda: World(("a", 1.0, 0.0, 1.0)), r"bounds must be 4 finite numbers"),
        (lambda: Circle((0.0, 0.0), math.inf), r"circle radius must be a finite number > 0, got inf"),
        (lambda: Circle((math.nan, 0.0), 1.0), r"circle center must be two finite numbers"),
        (lambda: Ellipse((0.0, 0.0), (1.0, 0.5), math.nan), r"ellipse angle must be a finite number, got nan"),
        (lambda: Box((0.0, 0.0), (math.inf, 1.0)), r"box size must be two finite numbers"),
    ],
)
def test_bad_geometry_raises_config_error(make: Any, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        make()


@pytest.mark.parametrize(
    ("planner", "options", "match"),
    [  # each of these was accepted and raised TypeError or ValueError while planning (or at once, not an NhsimError)
        ("rrt-star", {"clearance": {}}, r"clearance must be a finite number >= 0, got \{\}"),
        ("birrt", {"n_speeds": 1.5}, r"n_speeds must be an integer in \[1, 1000\], got 1.5"),
        ("rrt", {"time_limit": math.nan}, r"time_limit must be a finite number > 0 \(or omitted\), got nan"),
        (
            "rrt",
            {"turning_radius": 1e300, "steering": "dubins"},
            r"turning_radius must be a finite number in \[0.01, 1000\] \(m\) \(or omitted\), got 1e\+300",
        ),
        (
            "rrt",
            {"primitive_duration": 1e9},
            r"primitive_duration must be a finite number in \(0, 60\], got 1000000000.0",
        ),
        ("optim", {"max_iter": math.nan}, r"optim: max_iter must be an integer >= 1, got nan"),
        ("optim", {"init_options": 5}, r"optim: init_options must be a table"),
        (  # were ignored: the straight line takes no options
            "optim",
            {"init": "straight", "init_options": {"range": 1}},
            r"optim: init_options \(range\) are a warm-start planner's options, and init='straight' is none",
        ),
        (  # were refused only when the plan ran its warm start
            "optim",
            {"init": "birrt", "init_options": {"bogus": 1}},
            r"optim: init_options: unknown option\(s\) bogus for the warm start's planner 'birrt': valid options are",
        ),
        (  # its values were checked only when the plan ran its warm start (plan() then raised)
            "optim",
            {"init": "rrt", "init_options": {"max_iterations": -5}},
            r"optim: init_options for the warm start's planner 'rrt': max_iterations must be an integer >= 1, got -5",
        ),
        ("sinusoidal", {"max_period": math.nan}, r"sinusoidal: max_period must be a finite number > 0, got nan"),
        # each ran out of memory (MemoryError: a planner's failure, exit 1) or ran minutes past --time-limit
        ("birrt", {"turning_radius": 1e-9}, r"turning_radius must be .* in \[0.01, 1000\] \(m\) \(or omitted\)"),
        ("rrt", {"n_speeds": 100_000}, r"n_speeds must be an integer in \[1, 1000\], got 100000"),
        (
            "sinusoidal",
            {"dt": 1e-9},
            r"sinusoidal: dt must be a finite number in \[0.001, 0.2\] \(s: from the finest physics step to a tenth",
        ),
        ("hybrid-a-star", {"turning_radius": 1e-9}, r"turning_radius must be .* in \[0.01, 1000\] \(m\)"),
        ("optim", {"N": 10_000_000}, r"optim: N must be an integer in \[2, 100000\] \(or omitted\), got 10000000"),
    ],
)
def test_bad_planner_options_are_refused_when_the_planner_is_made(planner: str, options: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        make_planner(planner, **options)


def _flag_options(planner: str) -> list[str]:
    """The options of a built-in planner whose default is True or False."""
    factory = PLANNERS.factory(planner)
    defaults = {p.name: p.default for p in inspect.signature(factory).parameters.values()}
    config_class = getattr(factory, "config_class", None)
    if dataclasses.is_dataclass(config_class):
        defaults |= {f.name: f.default for f in dataclasses.fields(config_class)}
    return [name for name in planner_options(planner) if isinstance(defaults.get(name), bool)]


@pytest.mark.parametrize("planner", ["birrt", "c-rrt-star", "optim", "rrt", "rrt-star"])
def test_a_planners_flag_is_true_or_false(planner: str) -> None:
    """A flag read for its truth took ``--planner-option simplify=no`` (bare text: the string "no") as true and
    simplified; ``verbose="no"`` printed IPOPT's log."""
    flags = _flag_options(planner)
    assert flags
    for name in flags:
        for value in ("no", 0, None):
            with pytest.raises(ConfigError, match=rf"{name} must be True or False, got {re.escape(repr(value))}"):
                make_planner(planner, **{name: value})
        with pytest.raises(ConfigError, match=r"got 'false' \(true or false, unquoted, in a TOML or JSON file"):
            make_planner(planner, **{name: "false"})
        make_planner(planner, **{name: np.bool_(False)})  # a numpy bool is a flag


@pytest.mark.parametrize("planner", ["birrt", "rrt-star"])
@pytest.mark.parametrize("value", [0, -3, 1.5, "50"])
def test_the_connect_step_is_a_whole_number_of_extensions(planner: str, value: object) -> None:
    """birrt took ``connect_steps=0`` (never connecting) and ``-3``, ``"50"`` unchecked."""
    with pytest.raises(ConfigError, match=rf"connect_steps must be an integer >= 1, got {re.escape(repr(value))}"):
        make_planner(planner, connect_steps=value)


def test_a_crrt_star_config_checks_its_types_without_the_registry() -> None:
    with pytest.raises(ConfigError, match=r"C-RRT\*: gamma must be a finite number in \[0, 1\], got 'x'"):
        CRRTStarConfig(gamma="x")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"C-RRT\*: max_iterations must be an integer >= 1, got 2.5"):
        CRRTStarConfig(max_iterations=2.5)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("world", "status", "reason"),
    [
        (World((0.0, 2.0, 0.0, 2.0)), PlanStatus.INVALID_START, "in collision with the wall x = 0"),
        (World((-2.0, 2.0, 0.0, 2.0), (Circle((0.1, 1.0), 0.3),)), PlanStatus.INVALID_START, "with the circle at"),
    ],
)
def test_sinusoidal_judges_a_start_that_is_already_the_goal(world: World, status: PlanStatus, reason: str) -> None:
    """Start = goal on a wall or in an obstacle: the one-pose path used to be returned as a success unchecked; it is
    an invalid start, as every planner's is."""
    at = Pose2D(0.01, 1.0, 0.0)
    res = make_planner("sinusoidal").plan(_problem(world=world, start=at, goal=at))
    assert res.status is status and reason in res.reason
    free = make_planner("sinusoidal").plan(_problem(start=Pose2D(1.0, 1.0, 0.3), goal=Pose2D(1.0, 1.0, 0.3)))
    assert free.success and free.path.shape == (1, 3)


@pytest.mark.parametrize("which", ["start", "goal"])
@pytest.mark.parametrize("planner", ["sinusoidal", "rrt", "birrt", "rrt-star", "c-rrt-star", "hybrid-a-star", "optim"])
def test_an_end_outside_the_world_is_refused_alike_by_every_planner(planner: str, which: str) -> None:
    """The sinusoidal steering reported BOUNDS_VIOLATED ("cannot steer y by -9.3 m within the input limits") for a
    start outside the world, where the contract (docs/how-to/new-planner.md) asks INVALID_START; C-RRT* and optim
    said the start was "-8.8000 m from the nearest obstacle or wall"."""
    res = make_planner(planner).plan(_problem(**{which: Pose2D(10.0, 10.0, 0.0)}))
    assert res.status is (PlanStatus.INVALID_START if which == "start" else PlanStatus.INVALID_GOAL)
    assert res.reason == (
        f"{which} pose (10.000, 10.000, 0.000) lies outside the world's bounds (x 0..3, y 0..2): move it inside"
    )
    on_wall = make_planner(planner).plan(_problem(**{which: Pose2D(3.0, 1.0, 0.0)}))  # on the wall counts as outside
    assert on_wall.status is res.status and "(3.000, 1.000, 0.000) lies outside the world's bounds" in on_wall.reason
