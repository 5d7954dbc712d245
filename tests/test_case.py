"""Cases: validation, names, the tracker of each run kind, and the plan -> trajectory stage."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from planning import PlanProblem, load_scenario, make_planner
from planning.errors import ConfigError, ScenarioError
from sim.cli.progress import TITLES
from sim.pipeline.case import Case, PlanOptions, prepare_trajectory
from sim.pipeline.runs import PLAN_TRACKER, REFERENCE_TRACKER, RunKind
from sim.pipeline.simulate import simulate_plan


def test_a_case_names_itself_as_the_suite_baselines_do() -> None:
    assert Case("open", robot="turtlebot3", reference="figure8", tracker="fbl").name == "open-turtlebot3-figure8-fbl-s0"
    planned = Case("farm", robot="turtlebot3", planner="birrt", tracker="segmented", control_rate=100.0)
    assert planned.name == "farm-turtlebot3-plan-birrt-segmented-s0-100hz"
    assert Case("open", reference="line").name == f"open-default-line-{REFERENCE_TRACKER}-s0"
    assert Case.parse("maze").name == f"maze-default-plan-default-{PLAN_TRACKER}-s0"


def test_each_run_kind_gets_its_tracker() -> None:
    ref, plan = Case("open", reference="circle"), Case("maze", planner="rrt")
    assert ref.tracker_for(RunKind.CLOSED_LOOP) == "fbl" and plan.tracker_for(RunKind.CLOSED_LOOP) == "segmented"
    assert ref.tracker_for(RunKind.OPEN_LOOP) == plan.tracker_for(RunKind.OPEN_LOOP) == "open-loop"
    assert Case("open", reference="line", tracker="fbl").kind is RunKind.CLOSED_LOOP
    assert Case("open", reference="line", tracker="open-loop").kind is RunKind.OPEN_LOOP
    assert {str(k) for k in RunKind} <= set(TITLES)  # every kind has its progress bar


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"reference": "line", "planner": "rrt"}, "exactly one of reference or planner"),
        ({}, "exactly one of reference or planner"),
        ({"reference": "spiral"}, "unknown reference 'spiral'"),
        ({"reference": "line", "tracker": "pid"}, "unknown tracker 'pid'; choose .*; a plugin's tracker is known once"),
        ({"reference": "line", "robot": "roomba"}, "unknown robot 'roomba'"),
    ],
)
def test_bad_cases_are_refused_naming_the_field(fields: dict[str, str], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        Case("open", **fields)  # type: ignore[arg-type]


def test_a_case_is_frozen() -> None:
    case = Case("open", reference="line")
    with pytest.raises(dataclasses.FrozenInstanceError):
        case.seed = 3  # type: ignore[misc]


def test_a_reference_gets_no_hold_and_a_reference_that_does_not_fit_is_refused() -> None:
    prepared = prepare_trajectory(Case("open", reference="line"))
    assert prepared.hold == 0.0 and prepared.source == "reference:line" and not prepared.extra
    assert prepared.trajectory.start_pose == prepared.scenario.start
    with pytest.raises(
        ScenarioError, match=r"circle' placed at the start of scenario 'random1' runs through an obstacle at"
    ):
        prepare_trajectory(Case("random1", reference="circle", robot="turtlebot3"))
    # one that leaves the world was said to come "within 0.000 m of an obstacle or wall" at a point beyond the walls
    said = r"reference 'figure8' placed at the start of scenario 'simple_motion' leaves the world's bounds \(x 0..2, "
    with pytest.raises(ScenarioError, match=said + r"y 0..1.2\) at \(0.8\d\d, 0.000\) but the turtlebot3 needs"):
        prepare_trajectory(Case("simple_motion", reference="figure8"))


def test_a_plan_failed_with_the_trackers_margin_says_so_and_how_to_plan_without_it(tmp_path) -> None:
    from planning.core.robot import load_robot
    from planning.trajectory.from_plan import PlanFailedError

    # a door 5 mm wider than the robot on each side: passable, not with the tracker's 1 cm margin
    half = float(load_robot("turtlebot3").footprint[:, 1].max()) + 0.005
    path = tmp_path / "door.toml"
    text = (
        'robot = "turtlebot3"\n[world]\nbounds = [-1.5, 1.5, -1.0, 1.0]\n'
        f'[[world.obstacles]]\ntype = "box"\ncenter = [0.0, {(1.0 + half) / 2!r}]\nsize = [0.1, {1.0 - half!r}]\n'
        f'[[world.obstacles]]\ntype = "box"\ncenter = [0.0, {-(1.0 + half) / 2!r}]\nsize = [0.1, {1.0 - half!r}]\n'
        "[start]\npose = [-0.45, 0.0, 0.0]\n[goal]\npose = [0.45, 0.0, 0.0]\n[planners.rrt]\nmax_iterations = 2000\n"
    )
    path.write_text(text)
    with pytest.raises(PlanFailedError, match=r"it planned keeping 0.01 m .*clearance = 0 in a \[planners.rrt\] table"):
        prepare_trajectory(Case(str(path), planner="rrt"))
    path.write_text(text + "clearance = 0\n")  # as the reason says
    assert prepare_trajectory(Case(str(path), planner="rrt")).source == "planner:rrt"


def test_a_start_closer_than_the_trackers_margin_lowers_it_to_half_its_clearance(tmp_path) -> None:
    """The start 5 mm from the wall behind it: ``nhsim plan`` plans it, and simulate refused it for the
    tracker's 1 cm margin, although the robot stands there. The tracked plan keeps half the start's
    clearance instead (planning keeps the rest of the margin where the poses have it)."""
    from planning import PlanProblem, load_scenario
    from planning.core.robot import load_robot
    from sim.pipeline.case import tracked_margin

    rear = -float(load_robot("turtlebot3").footprint[:, 0].min())
    path = tmp_path / "wall.toml"
    path.write_text(
        'robot = "turtlebot3"\n[world]\nbounds = [-1.5, 1.5, -1.0, 1.0]\n'
        f"[start]\npose = [{-1.5 + rear + 0.005!r}, 0.0, 0.0]\n[goal]\npose = [1.0, 0.0, 0.0]\n"
    )
    problem = PlanProblem.from_scenario(load_scenario(str(path)))
    assert 0.0 < tracked_margin(problem, 0.01) < 0.005  # below the start's 5 mm (half a lower bound of it)
    assert tracked_margin(problem, 0.002) == 0.002  # a margin the poses have is kept
    assert prepare_trajectory(Case(str(path), planner="rrt")).source == "planner:rrt"


@pytest.mark.parametrize("gap", [0.003, 0.011, 0.012])
@pytest.mark.parametrize("planner", ["hybrid-a-star", "rrt-star"])
def test_a_goal_the_planners_check_holds_closer_than_the_margin_is_planned_to_with_less(
    tmp_path, gap: float, planner: str
) -> None:
    """A goal 11 or 12 mm from a box behind it: the exact check gave it the 1 cm margin, the planner's own (a lower
    bound, 9 mm) refused it as closer than that, and simulate failed where nhsim plan plans; 3 mm: half the
    margin, refused the same way. The margin is halved until the planner takes the goal."""
    from planning.core.robot import load_robot

    rear = -float(load_robot("turtlebot3").footprint[:, 0].min())
    path = tmp_path / "bay.toml"
    path.write_text(
        'robot = "turtlebot3"\n[world]\nbounds = [0.0, 3.0, 0.0, 2.0]\n[[world.obstacles]]\ntype = "box"\n'
        f"center = [{2.4 - rear - gap - 0.15!r}, 1.0]\nsize = [0.3, 0.6]\n"
        "[start]\npose = [0.6, 1.0, 0.0]\n[goal]\npose = [2.4, 1.0, 0.0]\n"
    )
    prepared = prepare_trajectory(Case(str(path), planner=planner, planning=PlanOptions(time_limit=20.0)))
    assert prepared.source == f"planner:{planner}"


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"time_limit": -1}, r"PlanOptions.time_limit must be a finite number > 0 \(s\), got -1"),
        ({"time_limit": "5"}, r"PlanOptions.time_limit must be a finite number"),
        ({"clearance": float("nan")}, r"PlanOptions.clearance must be a finite number"),
        ({"clearance": -0.01}, r"PlanOptions.clearance must be a finite number >= 0 \(m, 0 plans to the limit\), got"),
        ({"planner_options": [1, 2]}, r"PlanOptions.planner_options must be a mapping"),
        ({"smoothing": None}, r"PlanOptions.smoothing must be a mapping"),
        ({"plan": "x"}, r"PlanOptions.plan must be a PlanResult"),
    ],
)
def test_plan_options_are_checked_when_made(options: dict[str, object], match: str) -> None:
    from sim.pipeline.case import PlanOptions

    with pytest.raises(ConfigError, match=match):
        PlanOptions(**options)  # type: ignore[arg-type]


def test_a_case_refuses_planning_and_perturbation_of_the_wrong_kind() -> None:
    with pytest.raises(ConfigError, match=r"planning must be a PlanOptions"):
        Case("open", reference="line", planning={"time_limit": 1})  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"perturbation must be a Perturbation .*Perturbation.parse"):
        Case("open", reference="line", perturbation={"mass": 1})  # type: ignore[arg-type]


def test_a_ready_plan_must_leave_from_the_scenarios_start_and_end_in_its_goal() -> None:
    import numpy as np

    from planning.planners.base import PlanResult, PlanStatus
    from sim.pipeline.case import PlanOptions

    def case(path: list[list[float]]) -> Case:
        plan = PlanResult(PlanStatus.SUCCESS, "mine", path=np.array(path))
        return Case("edumip_map", planner="", planning=PlanOptions(plan=plan))  # start (0, 0), goal (5, 5)

    with pytest.raises(
        ConfigError, match=r"starts at \(2.000, 0.000, 0.000\), 2.000 m .* from the start of scenario 'edumip_map' \("
    ):
        prepare_trajectory(case([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]]))
    with pytest.raises(
        ConfigError, match=r"ends at \(1.000, 1.000, 0.785\), outside the goal region of scenario 'edumip_map'"
    ):
        prepare_trajectory(case([[0.0, 0.0, np.pi / 4], [1.0, 1.0, np.pi / 4]]))  # the start's heading is pi/4


def test_runs_are_taken_by_their_labels_and_an_empty_or_unknown_list_is_refused() -> None:
    from sim.pipeline.runs import run_kinds

    assert run_kinds(["closed_loop", RunKind.OPEN_LOOP]) == (RunKind.CLOSED_LOOP, RunKind.OPEN_LOOP)
    assert run_kinds("closed_loop") == (RunKind.CLOSED_LOOP,)
    for bad, match in (([], "no run given"), (["closed"], "unknown run 'closed'"), ([1], "unknown run 1")):
        with pytest.raises(ConfigError, match=match):
            run_kinds(bad)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="closed_loop given twice"):
        run_kinds(["closed_loop", "closed_loop"])


def test_a_ready_plan_is_refused_beside_another_planner_a_reference_or_a_file() -> None:
    plan = make_planner("rrt").plan(PlanProblem.from_scenario(load_scenario("simple_motion"), seed=0))
    assert plan.success
    assert Case("simple_motion", planner="", planning=PlanOptions(plan=plan)).planning.plan is plan
    assert Case("simple_motion", planner="rrt", planning=PlanOptions(plan=plan)).planning.plan is plan
    with pytest.raises(ConfigError, match=r"made by 'rrt', but planner 'birrt' is named.*planner=''"):
        Case("simple_motion", planner="birrt", planning=PlanOptions(plan=plan))
    with pytest.raises(ConfigError, match=r"ready plan .* but reference is what would be tracked"):
        Case("simple_motion", reference="circle", planning=PlanOptions(plan=plan))
    with pytest.raises(ConfigError, match=r"planner 'birrt' is named"):
        simulate_plan("simple_motion", planner="birrt", planning=PlanOptions(plan=plan))


def test_a_ready_plan_closer_to_an_obstacle_than_the_tracked_margin_is_warned_of() -> None:
    """A planner's defaults plan to the limit (clearance 0): such a plan, given ready, was tracked without a word
    and the closed loop touched an obstacle 652 times; a plan the case makes keeps 1 cm. It is tracked as given,
    with a warning naming how close it comes and the fix."""
    import warnings

    from planning.collision.exact import CollisionChecker
    from planning.core.robot import load_robot
    from sim.pipeline.case import GrazingPlanWarning, plan_case

    sc = load_scenario("random5")
    plan = make_planner("birrt").plan(PlanProblem.from_scenario(sc))
    robot = load_robot(sc.robot)
    least = CollisionChecker(sc.world, robot).least_clearance(plan.path)
    assert plan.success and least < 0.01
    case = Case("random5", planner="", planning=PlanOptions(plan=plan))
    with pytest.warns(GrazingPlanWarning, match=rf"comes within {least:.4f} m of an obstacle or wall, less than the "):
        assert plan_case(case, sc, robot) is plan
    kept = Case("random5", planner="", planning=PlanOptions(plan=plan, clearance=0.5 * least))
    with warnings.catch_warnings():
        warnings.simplefilter("error", GrazingPlanWarning)
        assert plan_case(kept, sc, robot) is plan  # a margin the case is told the plan keeps: no warning
        for name in ("random5", "nav_map1", "parking_lot"):  # a case's own plan, tracked as a ready plan by the sweep
            own = Case(name, planner="birrt")
            scenario = load_scenario(name)
            made = plan_case(own, scenario, load_robot(scenario.robot))
            assert made.success and plan_case(own.with_plan(made, scenario), scenario, load_robot(scenario.robot))


def test_a_case_token_splits_at_its_last_colon_and_a_file_with_a_colon_is_whole(tmp_path: Path) -> None:
    """``tune --scenarios /data/run:2/yard.toml:line`` split at the first colon ("'2/yard.toml:line' is neither a
    reference nor a planner"); a reference's or a planner's name has no colon, so the last one splits, and a token
    that names an existing file is the scenario whole."""
    folder = tmp_path / "run:2"
    folder.mkdir()
    yard = folder / "yard.toml"
    yard.write_text((Path(__file__).resolve().parents[1] / "models/scenarios/open.toml").read_text())
    assert Case.split(f"{yard}:line") == (str(yard), "line")
    assert Case.split(f" {yard} ") == (str(yard), "")
    assert Case.split("open:figure8") == ("open", "figure8") and Case.split("open") == ("open", "")
    case = Case.parse(f"{yard}:line")
    assert case.reference == "line" and str(case.scenario) == str(yard)
