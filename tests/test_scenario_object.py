"""A Scenario built in Python, and what simulate_plan is given with it: every field checked where it is given
(a tuple for a pose, a negative tolerance or an unknown robot were taken, then failed deep inside or under a
class the user never built), a start or goal outside the world refused as such (it was an OverflowError), the
scenario and seed of simulate_plan named as its own, a tracker without feedback refused as the closed loops'
tracker, and a ready plan that collides in the scenario or with the robot refused before it is smoothed."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planning.collision.overlap import footprint_overlap
from planning.core.geometry import Pose2D
from planning.core.robot import ROBOTS, load_robot
from planning.core.world import Box, Circle, World
from planning.errors import ConfigError, ScenarioError
from planning.planners.base import PlanResult, PlanStatus
from planning.scenario import (
    Scenario,
    builtin_scenarios,
    check_ends_fit,
    load_scenario,
    random_scenario,
)
from sim.pipeline.case import Case, PlanOptions, plan_case
from sim.pipeline.runs import RunKind
from sim.pipeline.simulate import check_feedback_tracker, simulate_plan

WORLD = World((0.0, 3.0, 0.0, 3.0))


def _scenario(**fields: Any) -> Scenario:
    given: dict[str, Any] = {
        "name": "x",
        "robot": "edumip",
        "world": WORLD,
        "start": Pose2D(1.0, 1.0, 0.0),
        "goal": Pose2D(2.0, 2.0, 0.0),
    }
    return Scenario(**(given | fields))


def _refused_where_checked_and_where_run(scenario: Scenario, said: str) -> None:
    """``scenario`` refused with ``said`` by :func:`check_ends_fit` and by ``simulate_plan`` alike."""
    with pytest.raises(ScenarioError, match=said):
        check_ends_fit(scenario)
    with pytest.raises(ScenarioError, match=said):
        simulate_plan(scenario, planner="rrt", runs=["closed_loop"])


# ------------------------------------------------------------------ 1. a start or goal outside the world
@pytest.mark.parametrize(("label", "pose"), [("start", Pose2D(5.0, 5.0, 0.0)), ("goal", Pose2D(-1.0, 2.0, 0.0))])
def test_a_start_or_goal_outside_the_world_is_refused_as_such_not_with_an_overflow(label: str, pose: Pose2D) -> None:
    scenario = _scenario(**{label: pose})
    said = (
        rf"scenario 'x': field '{label}.pose': \[{pose.x}, {pose.y}, 0.0\] lies outside the world \(the map\), whose "
        rf"bounds are x 0..3, y 0..3: move the {label} inside them, more than 0.066 m from every wall"
    )
    _refused_where_checked_and_where_run(scenario, said)


def test_a_pose_just_beyond_a_wall_is_outside_and_one_just_inside_overlaps_the_wall() -> None:
    with pytest.raises(ScenarioError, match=r"lies outside the world"):
        check_ends_fit(_scenario(start=Pose2D(3.05, 1.0, 0.0)))
    with pytest.raises(ScenarioError, match=r"overlaps the wall x = 3 by .* mm .*move the start more than"):
        check_ends_fit(_scenario(start=Pose2D(2.97, 1.0, 0.0)))


def test_a_footprint_wholly_beyond_the_walls_is_measured_by_how_far_it_sticks_out_not_infinity() -> None:
    hit = footprint_overlap(WORLD, load_robot("edumip"), Pose2D(5.0, 1.0, 0.0))
    assert hit is not None
    clearance, what, move = hit
    assert clearance == -math.inf and what == "the wall x = 3" and move == pytest.approx(2.051, abs=1e-6)


# ------------------------------------------------------------------ 2. Scenario checks its fields
@pytest.mark.parametrize(
    ("fields", "said"),
    [
        ({"start": (1, 1, 0)}, r"Scenario.start must be a Pose2D: pass Pose2D\(1, 1, 0\), got tuple \(1, 1, 0\)"),
        ({"goal": None}, r"Scenario.goal must be a Pose2D: pass Pose2D\(x, y, theta\), got NoneType None"),
        (
            {"world": (0, 3, 0, 3)},
            r"Scenario.world must be a World: pass World\(\(0, 3, 0, 3\)\) for bounds alone, got tuple",
        ),
        ({"position_tolerance": -1}, r"Scenario.position_tolerance must be a finite number > 0 \(m, .*got -1$"),
        (
            {"heading_tolerance": "0.1"},
            r"Scenario.heading_tolerance must be a finite number in \(0, 3.14159\] \(rad\), got '0.1'",
        ),
        (  # said "3.1416 degrees would be 0.05483 rad"
            {"heading_tolerance": 3.1416},
            r"in \(0, 3.14159\] \(rad\), got 3.1416; pi takes any heading; pi rounded up is above it: write 3.14159 ",
        ),
        ({"robot": None}, r"Scenario.robot must be a robot's name, one of edumip, edumip-balancing, turtlebot3"),
        ({"name": ""}, r"Scenario.name must be a non-empty string, got ''"),
        ({"description": 3}, r"Scenario.description must be a string"),
        ({"planner": 3}, r"Scenario.planner must be a planner's name \(e.g. 'rrt'\) or None, got 3"),
        ({"robots": "edumip"}, r"Scenario.robots must be a tuple of robot names, .*got 'edumip'"),
        ({"robots": ("edumip", None)}, r"Scenario.robots must be a tuple of robot names"),
        ({"planner_options": {"rrt": 3}}, r"Scenario.planner_options must map planner names to mappings"),
        ({"sensors": {"fix_rate": "5"}}, r"Scenario.sensors must map sensor profile keys to numbers"),
        ({"source": 3}, r"Scenario.source must be the path of the scenario's file or None, got 3"),
        ({"unmapped": (Circle((1, 2), 0.1), "box")}, r"Scenario.unmapped\[1\] must be an obstacle"),
        ({"unmapped": Circle((1, 2), 0.1)}, r"Scenario.unmapped must be a tuple of obstacles"),
    ],
)
def test_a_scenario_field_of_the_wrong_kind_is_refused_where_it_is_given(fields: dict[str, Any], said: str) -> None:
    with pytest.raises(ConfigError, match=said):
        _scenario(**fields)


def test_a_scenario_keeps_what_it_is_given_as_its_fields_are() -> None:
    sc = _scenario(robots=["edumip", "turtlebot3"], unmapped=[Circle((1, 2), 0.1)], source="here.toml")
    assert sc.robots == ("edumip", "turtlebot3") and isinstance(sc.unmapped, tuple) and sc.source == Path("here.toml")
    assert _scenario().robots == ("edumip",) and isinstance(_scenario(position_tolerance=1).position_tolerance, float)
    hash(sc)  # a frozen scenario stays hashable (lists are made tuples)
    moved = dataclasses.replace(sc, start=Pose2D(1.5, 1.0, 0.0))  # replace checks again, and passes
    assert moved.start.x == 1.5
    with pytest.raises(ConfigError, match=r"Scenario.start must be a Pose2D"):
        dataclasses.replace(sc, start=[1.5, 1.0, 0.0])  # type: ignore[arg-type]


def test_an_unknown_robot_is_a_config_error_naming_the_scenarios_robot_before_anything_runs() -> None:
    scenario = _scenario(robot="husky")  # a robot read from an MJCF file has its file's name: checked when loaded
    said = r"scenario 'x': Scenario.robot: unknown robot 'husky': choose one of edumip, edumip-balancing, turtlebot3"
    with pytest.raises(ConfigError, match=said):
        check_ends_fit(scenario)
    with pytest.raises(ConfigError, match=said):
        simulate_plan(scenario, planner="rrt", runs=["closed_loop"])


def test_every_built_in_and_generated_scenario_still_builds() -> None:
    for name in builtin_scenarios():
        sc = load_scenario(name)
        assert dataclasses.replace(sc) == sc
    for robot in ROBOTS:
        assert random_scenario(robot, 3).robot == robot
    assert load_scenario("random5").name == "random5"


# ------------------------------------------------------------------ 3. simulate_plan's scenario and seed
@pytest.mark.parametrize("bad", [None, 3, ""])
def test_a_scenario_that_is_none_is_named_as_simulate_plans_scenario(bad: object) -> None:
    said = (
        r"simulate_plan: scenario must be a Scenario \(load_scenario\(NAME\), or Scenario\(...\)\), a built-in "
        r"scenario's name \(one of .*edumip_map.*\), the path of a scenario .toml file, or random<N> .*, got "
    )
    with pytest.raises(ConfigError, match=said + repr(bad)):
        simulate_plan(bad, planner="rrt")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"^Case.scenario must be a Scenario"):
        Case(bad, planner="rrt")  # type: ignore[arg-type]


def test_a_scenario_file_given_as_a_path_names_its_case() -> None:
    path = Path(__file__).parents[1] / "models" / "scenarios" / "open.toml"
    case = Case(path, reference="line")  # type: ignore[arg-type]
    assert case.scenario == str(path) and case.name == f"{path}-default-line-fbl-s0"


@pytest.mark.parametrize("bad", [-1, 1.5, "0", True])
def test_a_bad_seed_is_named_as_simulate_plans_seed(bad: object) -> None:
    with pytest.raises(ConfigError, match=rf"^simulate_plan: seed must be an integer >= 0, got {bad!r}; the seed"):
        simulate_plan("edumip_map", planner="rrt", seed=bad)
    with pytest.raises(ConfigError, match=r"^Case.seed must be an integer >= 0"):
        Case("open", reference="line", seed=bad)  # type: ignore[arg-type]


# ------------------------------------------------------------------ 4. a tracker without feedback
def test_open_loop_is_refused_as_the_closed_loops_tracker_and_pointed_to_its_own_run() -> None:
    said = (
        r"^tracker 'open-loop' feeds nothing back, so the closed-loop runs \(closed_loop\) would not be closed: "
        r"tracker is the closed loops' tracker, one of .*fbl.* \(None: the default\); 'open-loop' drives a run of "
        r"its own: runs=\['open_loop'\] \(one of the default runs\)$"
    )
    with pytest.raises(ConfigError, match=said):
        simulate_plan("edumip_map", planner="c-rrt-star", tracker="open-loop", runs=["closed_loop"])
    with pytest.raises(ConfigError, match=r"closed-loop runs \(closed_loop, closed_loop_odometry\)"):
        simulate_plan("edumip_map", planner="c-rrt-star", tracker="open-loop")  # the default runs


def test_open_loop_still_names_a_cases_single_run_the_open_loop() -> None:
    case = Case("open", reference="line", tracker="open-loop")  # as the regression suite's cases do
    assert case.kind is RunKind.OPEN_LOOP
    check_feedback_tracker(case, (RunKind.OPEN_LOOP,))  # its own run: no closed loop to refuse
    check_feedback_tracker(Case("open", reference="line", tracker="mpc"), tuple(RunKind))


# ------------------------------------------------------------------ 5. a ready plan that collides
def _line(start: Pose2D, goal: Pose2D, n: int = 300) -> PlanResult:
    return PlanResult(PlanStatus.SUCCESS, "mine", path=np.linspace(start.as_array(), goal.as_array(), n))


START, GOAL = Pose2D(0.5, 1.0, 0.0), Pose2D(3.5, 1.0, 0.0)


def test_a_ready_plan_through_an_obstacle_of_the_scenario_is_refused_where_it_collides() -> None:
    blocked = Scenario("blocked", "edumip", World((0, 4, 0, 2), (Circle((2.0, 1.0), 0.3),)), START, GOAL)
    said = (
        r"^the ready plan \(mine\) collides in scenario 'blocked' with robot 'edumip': at \(1\.6\d\d, 1\.000, "
        r"0\.000\), plan\.path\[\d+\] of its 300 poses, the edumip's footprint overlaps the circle at x 1\.7\.\.2\.3, "
        r"y 0\.7\.\.1\.3 by \d+\.\d mm \(a plan made in another world, or for another robot\?\): plan again in this "
        r"scenario with this robot \(PlanProblem.from_scenario\(scenario, robot=load_robot\('edumip'\)\)\), or track "
        r"the plan in the scenario and with the robot it was made for$"
    )
    with pytest.raises(ConfigError, match=said):
        simulate_plan(blocked, planning=PlanOptions(plan=_line(START, GOAL)), runs=["closed_loop"])
    sparse = _line(START, GOAL, 2)  # two poses: the path between them is checked too
    with pytest.raises(ConfigError, match=r"between plan\.path\[0\] and plan\.path\[1\] of its 2 poses"):
        plan_case(Case(blocked, planner="", planning=PlanOptions(plan=sparse)), blocked, load_robot("edumip"))
    free = dataclasses.replace(blocked, world=World((0, 4, 0, 2)))
    plan = _line(START, GOAL)
    assert plan_case(Case(free, planner="", planning=PlanOptions(plan=plan)), free, load_robot("edumip")) is plan


def test_a_ready_plan_of_a_smaller_robot_is_refused_for_a_larger_one() -> None:
    gap = (Box((2.0, 0.51), (0.4, 0.82)), Box((2.0, 1.49), (0.4, 0.82)))  # a 16 cm gap at y 0.92..1.08
    sc = Scenario("gap", "edumip", World((0, 4, 0, 2), gap), START, GOAL, robots=("edumip", "turtlebot3"))
    plan = _line(START, GOAL)
    assert plan_case(Case(sc, planner="", planning=PlanOptions(plan=plan)), sc, load_robot("edumip")) is plan
    said = r"collides in scenario 'gap' with robot 'turtlebot3': .* the turtlebot3's footprint overlaps the box at"
    with pytest.raises(ConfigError, match=said):
        simulate_plan(sc, robot="turtlebot3", planning=PlanOptions(plan=plan), runs=["closed_loop"])


def test_a_ready_plan_of_thousands_of_poses_is_checked_whole() -> None:
    sc = load_scenario("edumip_map")
    robot = load_robot(sc.robot)
    free = Scenario("free", sc.robot, World(sc.world.bounds), sc.start, sc.goal)
    plan = _line(sc.start, sc.goal, 5000)
    case = Case(free, planner="", planning=PlanOptions(plan=plan))
    assert plan_case(case, free, robot) is plan
    blocked = dataclasses.replace(free, world=sc.world)  # the straight line runs through the map's walls
    with pytest.raises(ConfigError, match=r"the ready plan \(mine\) collides in scenario 'free'"):
        plan_case(case, blocked, robot)


@pytest.mark.parametrize("planner", ["rrt", "birrt", "rrt-star"])
def test_a_tree_planner_says_an_end_outside_the_world_is_outside_it(planner: str) -> None:
    """(It said an obstacle lay inside the robot's footprint, in a world without obstacles.)"""
    from planning.planners.base import PlanProblem
    from planning.planners.registry import make_planner

    problem = PlanProblem(WORLD, load_robot("edumip"), Pose2D(1.0, 1.0, 0.0), Pose2D(-2.0, 2.0, 0.0))
    result = make_planner(planner).plan(problem)
    assert result.status is PlanStatus.INVALID_GOAL
    assert (
        result.reason
        == "goal pose (-2.000, 2.000, 0.000) lies outside the world's bounds (x 0..3, y 0..3): move it inside"
    )


def test_a_jobs_gains_are_the_fbls_only_where_its_tracker_takes_them() -> None:
    """(JobResult.gains gave FBLGains(9, 6) for kanayama, rpp and mpc, whose records say null.)"""
    from control.gains import FBLGains
    from sim.pipeline.simulate import simulate_reference

    own = simulate_reference("open", reference="line", tracker="kanayama", runs=["closed_loop_truth"])
    assert own.gains is None and own.record()["gains"] is None
    fbl = simulate_reference("open", reference="line", gains=FBLGains(5.0, 4.0), runs=["closed_loop_truth"])
    assert fbl.gains == FBLGains(5.0, 4.0) and fbl.record()["gains"]["kp"] == 5.0


def test_robots_must_list_the_scenarios_own_robot() -> None:
    """As a scenario file's ``robots`` must: a Scenario made in Python with robots=("edumip",) and its robot the
    TurtleBot3 was run on the TurtleBot3 without a word."""
    with pytest.raises(ConfigError, match=r"Scenario.robots \('turtlebot3',\) must include the scenario's own robot"):
        _scenario(robots=("turtlebot3",))
    assert _scenario(robots=("edumip", "turtlebot3")).robots == ("edumip", "turtlebot3")


# ------------------------------------------------------------------ checked as a scenario file's fields are
def test_an_unmapped_obstacle_at_the_start_is_refused_as_a_files_is() -> None:
    """An unmapped obstacle over the robot at its start was refused in a file, but a Scenario made in Python ran
    on: the run began in a collision and its estimator diverged."""
    scenario = _scenario(unmapped=(Circle((1.0, 1.05), 0.1),))
    said = (
        r"scenario 'x': Scenario.unmapped\[0\] \(circle\) overlaps the robot at its start \(-0.050 m from "
        r"start.pose, the edumip reaches 0.\d+ m\); move it away from the start"
    )
    _refused_where_checked_and_where_run(scenario, said)


@pytest.mark.parametrize(
    ("fields", "said"),
    [
        ({"planner": "rrt_star"}, r"Scenario.planner: 'rrt_star' is not a registered planner \(.*rrt-star"),
        ({"planner_options": {"birt": {}}}, r"Scenario.planner_options\['birt'\]: 'birt' is not a registered"),
    ],
)
def test_a_planner_name_that_is_not_registered_is_refused_not_ignored(fields: dict[str, Any], said: str) -> None:
    """A misspelt planner in ``planner_options`` was ignored (its options never reached the planner) where a
    scenario file's is refused."""
    with pytest.raises(ConfigError, match=said):
        simulate_plan(_scenario(**fields), planner="rrt", runs=["closed_loop"])


def test_a_heading_beyond_four_pi_is_refused_and_one_within_is_brought_into_one_turn() -> None:
    """A goal heading of 100 rad (degrees, or a typo) was taken and tracked; a file's is refused. One within
    +-4 pi is the direction it names, as in a file: 7 rad is 7 - 2 pi."""
    with pytest.raises(ConfigError, match=r"Scenario.goal's heading must be in radians within \+-4 pi.*, got 100"):
        _scenario(goal=Pose2D(2.0, 2.0, 100.0))
    assert _scenario(goal=Pose2D(2.0, 2.0, 7.0)).goal.theta == pytest.approx(7.0 - 2 * math.pi, abs=1e-15)
    assert _scenario(start=Pose2D(1.0, 1.0, -math.pi)).start.theta == math.pi
    kept = 3.0000000000000004
    assert _scenario(start=Pose2D(1.0, 1.0, kept)).start.theta == kept  # within one turn: kept bit for bit
