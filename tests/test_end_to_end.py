"""Plan -> smooth -> track in MuJoCo physics, closed loop and open loop.

The fast default uses hand-made plans (a stop-turn-go polyline with a cusp, a turn in place) on
built-in scenarios, one run at 10 Hz, and one registered planner if any; the whole matrix of
built-in scenario x applicable planner x robot is marked slow.
"""

import numpy as np
import pytest

from planning.planners.base import PlanResult, PlanStatus
from planning.planners.registry import PLANNERS
from planning.scenario import load_scenario
from sim.cli.sweep_table import format_row, header, summary
from sim.pipeline.case import Case, PlanOptions
from sim.pipeline.simulate import applicable_planners, simulate_plan
from sim.pipeline.sweep import (
    BALANCING_TARGETS,
    TARGETS,
    Outcome,
    Stage,
    SweepRow,
    sweep_case,
    sweep_cases,
    sweep_passed,
    sweep_record,
)


def assert_targets(job, pos: float = 0.02) -> None:  # type: ignore[no-untyped-def]
    cl = job.metrics["closed_loop"]
    assert cl.final_position_error_m <= pos
    assert cl.final_heading_error_rad <= TARGETS["final_heading_error_rad"]
    assert cl.rms_position_error_m <= TARGETS["rms_position_error_m"]
    assert cl.collisions == 0 and cl.warnings == 0
    goal = job.scenario.goal
    end = job.logs["closed_loop"].pose[-1]
    assert np.hypot(end[0] - goal.x, end[1] - goal.y) <= pos
    assert abs(np.angle(np.exp(1j * (end[2] - goal.theta)))) <= TARGETS["final_heading_error_rad"]


def test_parallel_park_by_hand_with_a_cusp_in_physics() -> None:
    sc = load_scenario("parallel_park")  # (1.0, 0.8, 0) -> (1.0, 0.5, 0)
    path = np.array([[1.0, 0.8, 0.0], [1.3, 0.8, 0.0], [1.3, 0.8, -0.9], [1.0, 0.5, -0.9], [1.0, 0.5, 0.0]])
    plan = PlanResult(PlanStatus.SUCCESS, "by-hand", path=path)
    for robot in ("turtlebot3", "edumip"):
        job = simulate_plan(sc, robot=robot, planning=PlanOptions(plan=plan))
        assert job.source == "planner:by-hand" and job.extra["smoothing"]["drives"] == 2
        assert job.trackers["closed_loop"] == "segmented"
        assert_targets(job)
        assert job.metrics["open_loop"].final_position_error_m > job.metrics["closed_loop"].final_position_error_m


def test_the_balancing_edumip_takes_cusps_and_turns_in_place_through_its_balance_loop() -> None:
    # forwards, a turn in place, backwards (a cusp), a turn in place. A balancing robot cannot stop or
    # turn on skids: every stop, turn and change of direction goes through the balance loop's lean
    # (the balancing targets: BALANCING_TARGETS, no fall)
    sc = load_scenario("parallel_park")  # (1.0, 0.8, 0) -> (1.0, 0.5, 0)
    q = np.pi / 4
    path = np.array([[1.0, 0.8, 0.0], [1.3, 0.8, 0.0], [1.3, 0.8, q], [1.0, 0.5, q], [1.0, 0.5, 0.0]])
    plan = PlanResult(PlanStatus.SUCCESS, "by-hand", path=path)
    job = simulate_plan(sc, robot="edumip-balancing", planning=PlanOptions(plan=plan))
    smoothing = job.extra["smoothing"]
    assert (smoothing["drives"], smoothing["cusps"], smoothing["rotations"]) == (2, 1, 2)
    assert [k for k in job.trajectory.segment_kinds if k != "hold"] == ["forward", "rotate", "reverse", "rotate"]
    cl = job.metrics["closed_loop"]
    values = cl.as_dict()
    assert all(values[k] <= bound for k, bound in BALANCING_TARGETS.items()), values
    assert cl.fell is False and cl.collisions == 0 and cl.warnings == 0
    assert cl.max_pitch_rad is not None and cl.max_pitch_rad > np.radians(2.0)  # it leant to move
    end = job.logs["closed_loop"].pose[-1]
    assert np.hypot(end[0] - sc.goal.x, end[1] - sc.goal.y) <= 0.02
    assert abs(np.angle(np.exp(1j * (end[2] - sc.goal.theta)))) <= 0.05


def test_turn_in_place_in_physics_at_10_hz() -> None:
    sc = load_scenario("turn_in_place")
    plan = PlanResult(PlanStatus.SUCCESS, "by-hand", path=np.array([[0.8, 0.8, 0.0], [0.8, 0.8, np.pi]]))
    job = simulate_plan(sc, robot="edumip", planning=PlanOptions(plan=plan), control_rate=10.0)
    assert job.extra["smoothing"]["rotations"] == 1
    assert_targets(job, pos=0.05)


def test_a_polyline_among_obstacles_at_10_hz_reaches_the_goal_within_5_cm() -> None:
    sc = load_scenario("nav_map1")  # (0.25, 0.25) -> (1.25, 1.25) around three discs
    pts = np.array([[0.25, 0.25], [1.0, 0.25], [1.25, 0.5], [1.25, 1.25]])
    d = np.diff(pts, axis=0)
    th = np.append(np.arctan2(d[:, 1], d[:, 0]), 0.0)
    plan = PlanResult(PlanStatus.SUCCESS, "by-hand", path=np.column_stack([pts, th]))
    job = simulate_plan(sc, robot="turtlebot3", planning=PlanOptions(plan=plan), control_rate=10.0)
    assert_targets(job, pos=0.05)


def test_applicable_planners_rule() -> None:
    assert applicable_planners(load_scenario("open")) == []  # start == goal: nothing to plan
    for name in ("nav_map1", "turn_in_place"):
        sc = load_scenario(name)
        got = applicable_planners(sc)
        assert all(p in PLANNERS for p in got)
        if sc.planner in PLANNERS:
            assert sc.planner in got
        assert ("sinusoidal" in got) == ("sinusoidal" in PLANNERS and not sc.world.obstacles)


FAST = [c for c in sweep_cases() if c.planner in ("c-rrt-star", "rrt-star", "optim")][:1]


@pytest.mark.skipif(not FAST, reason="no planner registered yet")
@pytest.mark.parametrize("case", FAST, ids=lambda c: c.name)
def test_one_registered_planner_end_to_end(case: Case) -> None:
    row = sweep_case(case)
    assert row.stage is Stage.TRACK and row.success, row.record()
    line = format_row(row)
    assert line.split()[:4] == [case.scenario_name, case.robot, case.planner, "ok"]


def test_a_planner_precondition_is_not_applicable_but_a_planner_failure_is_a_failure() -> None:
    # C-RRT* keeps the EduMIP's axle centre 0.40 m from walls (the EduMIP planning report);
    # simple_motion starts 0.40 m from two walls, which the EduMIP's footprint clears easily: the
    # planner does not apply.
    na = sweep_case(Case("simple_motion", robot="edumip", planner="c-rrt-star"))
    assert na.outcome is Outcome.NA and na.stage is Stage.PRECONDITION and not na.success
    assert na.plan_status == "invalid_start" and "0.40" in na.reason
    # a planner that ends with another status on an applicable case is a failure, never hidden (the
    # virtual bicycle's default bounds swing sinusoidal steering out of the corridor)
    options = PlanOptions(planner_options={"phimax": 0.6, "u2max": 2.0})
    fail = sweep_case(Case("three_point_turn", robot="turtlebot3", planner="sinusoidal", planning=options))
    assert fail.outcome is Outcome.FAIL and fail.stage is Stage.PLAN and fail.plan_status == "bounds_violated"
    rows = [na, fail]
    rec = sweep_record(rows)
    assert rec["rows"] == [fail.record()] and rec["not_applicable"] == [na.record()] and rec["settings"] == {}
    assert rec["summary"] == {
        "cases": 1,
        "passed": 0,
        "failed": 1,
        "not_applicable": 1,
        "targets": TARGETS,
        "balancing_targets": BALANCING_TARGETS,
    }
    assert BALANCING_TARGETS["rms_position_error_m"] == 0.03 and BALANCING_TARGETS["max_pitch_rad"] == np.radians(20)
    keys = {"scenario", "robot", "planner", "seed", "success", "outcome", "stage", "reason", "plan_status"}
    assert set(na.record()) == keys | {"plan_time_s"} and set(fail.record()) == keys
    assert na.record()["outcome"] == "n/a" and fail.record()["outcome"] == "FAIL"
    lines = summary(rows)
    assert lines[0].startswith("0/1 applicable cases") and "(1 not applicable)" in lines[0]
    assert any(ln.startswith("  FAIL three_point_turn") and "[bounds_violated]" in ln for ln in lines)
    assert any(ln.startswith("  n/a  simple_motion/edumip/c-rrt-star") for ln in lines)
    assert not sweep_passed(rows) and sweep_passed([na])


#: Cases known to miss their targets, by case name, with why (none now: the balancing EduMIP's
#: c-rrt-star, hybrid-a-star and optim cases on edumip_map met their 3 cm once the balance loop fed
#: the reference's acceleration forward, and its 40 cases on the other scenarios, cusps and turns in
#: place included, meet them too). Strict: a case that starts passing fails here until its line is
#: removed.
KNOWN_MISSES: dict[str, str] = {}


def _sweep_params() -> list[object]:
    cases = sweep_cases(planning=PlanOptions(time_limit=10.0))
    return [
        pytest.param(c, id=c.name, marks=[pytest.mark.xfail(strict=True, reason=KNOWN_MISSES[c.name])])
        if c.name in KNOWN_MISSES
        else pytest.param(c, id=c.name)
        for c in cases
    ]


@pytest.mark.slow
@pytest.mark.parametrize("case", _sweep_params())
def test_every_scenario_planner_and_robot(case: Case) -> None:
    row = sweep_case(case)
    if row.outcome is Outcome.NA:  # the planner's own start/goal rule on a pose the robot fits: not applicable
        pytest.skip(row.reason)
    assert row.success, row.record()
    cl = row.record()["closed_loop"]
    targets = BALANCING_TARGETS if "max_pitch_rad" in cl and cl["max_pitch_rad"] is not None else TARGETS
    for key, bound in targets.items():
        assert cl[key] <= bound, (key, row.record())
    assert cl["collisions"] == 0 and cl["warnings"] == 0, row.record()


def test_the_table_keeps_its_columns_for_the_longest_robot_and_planner_names() -> None:
    head = header().splitlines()[0]
    case = Case("parking_lot", robot="edumip-balancing", planner="hybrid-a-star")
    row = SweepRow(case, Outcome.NA, Stage.PRECONDITION, reason="why")
    line = format_row(row)
    assert line.index("hybrid-a-star") == head.index("planner")
    assert line.index(" n/a") + len(" n/a") == head.index(" ok") + len(" ok")


def test_a_start_the_robot_itself_does_not_fit_is_no_excuse() -> None:
    import dataclasses

    from planning.core.geometry import Pose2D
    from sim.pipeline.sweep import precondition_not_met

    sc = load_scenario("simple_motion").with_robot("edumip")
    rejected = PlanResult(PlanStatus.INVALID_START, "c-rrt-star", reason="start too close")
    assert precondition_not_met(sc, rejected) is not None  # (0.4, 0.4): free for the footprint
    x0 = sc.world.bounds[0]
    tight = dataclasses.replace(sc, start=Pose2D(x0 + 0.02, sc.start.y, sc.start.theta))  # wheels in the wall
    assert precondition_not_met(tight, rejected) is None
    assert precondition_not_met(sc, PlanResult(PlanStatus.TIMEOUT, "c-rrt-star")) is None
