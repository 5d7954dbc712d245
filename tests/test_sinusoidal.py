"""Sinusoidal steering: the Murray-Sastry step formula, landing, hand-off, bounds and obstacles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from planning.core.geometry import Pose2D, wrap_angle
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, World
from planning.errors import ConfigError
from planning.planners.base import PlanProblem, PlanStatus
from planning.planners.registry import make_planner
from planning.planners.sinusoidal import ChainedModel, Sinusoidal, heading_waypoints, model_for
from planning.scenario import load_scenario

MANOEUVRES = ["simple_motion", "parallel_park", "three_point_turn", "turn_in_place"]


def test_chained_form_step_matches_closed_form() -> None:
    """x4 change over one period of u1 = a1 sin wt, u2 = a2 cos 2wt on the canonical chained form.

    Integrals: x2 = x20 + a2/(2w) sin 2wt; x3 = x30 + x20 a1 (1 - cos wt)/w
    + a1 a2/(2w) (sin wt/(2w) - sin 3wt/(6w)); over T = 2 pi/w, int x3 u1 dt keeps only
    a1^2 a2/(2w) * 1/(2w) * int sin^2 wt dt = a1^2 a2/(4 w^2) * pi/w, so dx4 = pi a1^2 a2 / (4 w^3).
    """
    a1, a2, w = 0.7, 1.3, 2.0
    x0 = np.array([0.3, -0.2, 0.15, 0.4])  # x20, x30 nonzero: they must not contribute

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        u1, u2 = a1 * math.sin(w * t), a2 * math.cos(2 * w * t)
        return np.array([u1, u2, x[1] * u1, x[2] * u1])

    sol = solve_ivp(rhs, (0.0, 2 * math.pi / w), x0, rtol=1e-12, atol=1e-14, method="DOP853")
    closed = math.pi * a1**2 * a2 / (4 * w**3)
    assert sol.y[3, -1] - x0[3] == pytest.approx(closed, rel=1e-9)
    np.testing.assert_allclose(sol.y[:3, -1], x0[:3], atol=1e-10)  # x1, x2, x3 return


def _bicycle_dz4(model: ChainedModel, theta0: float, period: float, a1: float, a2: float, wheelbase: float) -> float:
    """Fourth chained state's change from integrating the bicycle itself (u1 = v1 / cos theta)."""
    w = 2 * math.pi / period

    def rhs(t: float, s: np.ndarray) -> np.ndarray:
        v1 = a1 * math.sin(w * t)
        c = math.sin(s[2]) if model.alternate else math.cos(s[2])
        u1 = v1 / c
        return np.array(
            [u1 * math.cos(s[2]), u1 * math.sin(s[2]), u1 * math.tan(s[3]) / wheelbase, a2 * math.cos(2 * w * t)]
        )

    s0 = np.array([0.0, 0.0, theta0, 0.0])
    sol = solve_ivp(rhs, (0.0, period), s0, rtol=1e-12, atol=1e-13, method="DOP853")
    z0, z1 = model.to_chained(s0), model.to_chained(sol.y[:, -1])
    np.testing.assert_allclose(z1[:3], z0[:3], atol=1e-8)  # z1, phi, alpha return
    return float(z1[3] - z0[3])


@pytest.mark.parametrize(("center", "theta0"), [(0.0, 0.3), (math.pi / 2, 1.2), (math.pi, -2.8), (-math.pi / 2, -1.0)])
def test_planner_step_quadrature_matches_bicycle_integration(center: float, theta0: float) -> None:
    planner = Sinusoidal()
    planner.l = 0.1
    m = model_for(center)
    z0 = m.to_chained(np.array([0.0, 0.0, theta0, 0.0]))
    ref = _bicycle_dz4(m, theta0, 4.0, 0.12, 0.9, 0.1)
    assert planner.dz4(m, z0, 4.0, 0.12, 0.9) == pytest.approx(ref, rel=1e-7, abs=1e-10)


def test_small_amplitude_step_tends_to_chained_form() -> None:
    """With tan(phi) ~ phi and alpha/sqrt(1-alpha^2) ~ alpha the step is pi a1^2 a2 / (4 l w^3)."""
    planner = Sinusoidal()
    planner.l = 0.1
    period, a1, a2 = 4.0, 0.002, 0.01
    w = 2 * math.pi / period
    got = planner.dz4(model_for(0.0), np.zeros(4), period, a1, a2)
    assert got == pytest.approx(math.pi * a1**2 * a2 / (4 * 0.1 * w**3), rel=1e-4)


def test_heading_waypoints_cut_at_handoffs() -> None:
    np.testing.assert_allclose(heading_waypoints(0.0, 0.5), [0.0, 0.5])
    np.testing.assert_allclose(heading_waypoints(0.0, 1.4), [0.0, math.pi / 4, 1.4])
    np.testing.assert_allclose(heading_waypoints(0.0, math.pi), [0.0, -math.pi / 4, -3 * math.pi / 4, -math.pi])
    np.testing.assert_allclose(heading_waypoints(3.0, -3.0), [3.0, 2 * math.pi - 3.0])  # across +-pi, one region
    assert [model_for(a).name for a in (0.1, 1.0, 3.0, -1.2)] == ["standard", "alternate", "standard", "alternate"]


def _integrate_controls(result) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Integrate the unicycle with the plan's (v, omega), linearly interpolated, by an adaptive RK."""
    t, u = result.times, result.controls

    def rhs(tt: float, s: np.ndarray) -> np.ndarray:
        v, om = np.interp(tt, t, u[:, 0]), np.interp(tt, t, u[:, 1])
        return np.array([v * math.cos(s[2]), v * math.sin(s[2]), om])

    sol = solve_ivp(rhs, (t[0], t[-1]), result.path[0], rtol=1e-9, atol=1e-11, max_step=0.01, t_eval=t)
    return sol.y.T


@pytest.mark.parametrize("robot_name", ["turtlebot3", "edumip"])
@pytest.mark.parametrize("name", MANOEUVRES)
def test_manoeuvre_lands_within_goal_tolerance(name: str, robot_name: str) -> None:
    sc = load_scenario(name)
    problem = PlanProblem.from_scenario(sc, robot=load_robot(robot_name))
    res = make_planner("sinusoidal").plan(problem)
    assert res.status in (PlanStatus.SUCCESS, PlanStatus.BOUNDS_VIOLATED), res.reason
    if res.status is PlanStatus.BOUNDS_VIOLATED:
        assert "bounds" in res.reason or "phi" in res.reason or "inputs" in res.reason
    assert res.times is not None and res.controls is not None and res.states is not None
    assert res.states.shape == (res.path.shape[0], 4)
    traj = _integrate_controls(res)
    assert np.hypot(traj[-1, 0] - sc.goal.x, traj[-1, 1] - sc.goal.y) < sc.position_tolerance
    assert abs(wrap_angle(traj[-1, 2] - sc.goal.theta)) < sc.heading_tolerance
    # The integrated motion follows the planned path closely all along (5 mm).
    assert np.max(np.hypot(traj[:, 0] - res.path[:, 0], traj[:, 1] - res.path[:, 1])) < 5e-3
    robot = problem.robot
    assert np.max(np.abs(res.controls[:, 0])) <= robot.max_speed * (1 + 1e-9)
    assert np.max(np.abs(res.states[:, 3])) <= robot.max_steering * (1 + 1e-9)
    assert np.max(np.abs(res.controls[:, 1])) <= robot.max_yaw_rate * (1 + 1e-9)
    # omega is the bicycle's u1 tan(phi) / l
    np.testing.assert_allclose(res.controls[:, 1], res.controls[:, 0] * np.tan(res.states[:, 3]) / robot.wheelbase)


def test_crossing_ninety_degrees_uses_the_handoff() -> None:
    robot = load_robot("turtlebot3")
    world = World((-2.0, 2.0, -2.0, 2.0))
    res = Sinusoidal().plan(PlanProblem(world, robot, Pose2D(0, 0, 0.0), Pose2D(0.2, 0.3, math.radians(100))))
    assert res.success, res.reason
    assert res.stats["handoffs"] == 1 and res.stats["models"] == "standard>alternate"
    assert abs(wrap_angle(res.path[-1, 2] - math.radians(100))) < 1e-6
    turn = Sinusoidal().plan(PlanProblem.from_scenario(load_scenario("turn_in_place")))
    assert turn.stats["handoffs"] == 2 and turn.stats["models"] == "standard>alternate>standard"


def test_bounds_violation_is_reported() -> None:
    sc = load_scenario("parallel_park")
    tight = World((0.7, 1.3, 0.25, 1.05))  # both ends free; the manoeuvre swings 0.32 m ahead of them
    res = Sinusoidal().plan(PlanProblem(tight, load_robot("turtlebot3"), sc.start, sc.goal))
    assert res.status is PlanStatus.BOUNDS_VIOLATED
    assert "world bounds" in res.reason
    assert res.path.shape[0] > 1  # the path is attached for inspection


def test_obstacle_in_the_way_is_infeasible_and_one_aside_is_not() -> None:
    robot = load_robot("turtlebot3")
    start, goal = Pose2D(0.3, 0.5, 0.0), Pose2D(1.5, 0.5, 0.0)
    blocked = World((0.0, 2.0, 0.0, 1.0), (Circle((0.9, 0.5), 0.1),))
    res = Sinusoidal().plan(PlanProblem(blocked, robot, start, goal))
    assert res.status is PlanStatus.INFEASIBLE and "obstacle" in res.reason
    assert "instead: 'rrt-star', 'birrt' or 'hybrid-a-star'" in res.reason  # planners that avoid them
    aside = World((0.0, 2.0, 0.0, 1.0), (Circle((0.9, 0.9), 0.05),))
    res = Sinusoidal().plan(PlanProblem(aside, robot, start, goal))
    assert res.success
    # the reported clearance is the disc's from obstacles and walls alike: here the wall 0.3 m behind the start
    # is nearer than the circle (0.4 m from the path)
    assert res.stats["min_clearance"] == pytest.approx(np.min(aside.signed_distance(res.path[:, :2])) - robot.radius)
    assert res.stats["min_clearance"] < np.min(aside.obstacle_distance(res.path[:, :2])) - robot.radius


def test_same_problem_same_plan() -> None:
    problem = PlanProblem.from_scenario(load_scenario("simple_motion"))
    a, b = Sinusoidal().plan(problem), Sinusoidal().plan(problem)
    assert np.array_equal(a.path, b.path) and np.array_equal(a.controls, b.controls)  # type: ignore[arg-type]


def test_the_clearance_is_measured_between_the_samples_too() -> None:
    """With ``dt=10`` edumip_map's plan had 3 poses and came out a success through a box: the disc was measured at
    the samples alone. Two samples either side of a circle: the path between them hits it."""
    robot = load_robot("turtlebot3")
    world = World((0.0, 2.0, 0.0, 1.0), (Circle((0.9, 0.5), 0.05),))
    problem = PlanProblem(world, robot, Pose2D(0.3, 0.5, 0.0), Pose2D(1.5, 0.5, 0.0))
    x = np.array([[0.3, 0.5, 0.0, 0.0], [1.5, 0.5, 0.0, 0.0]])
    stats = {"final_position_error": 0.0, "final_heading_error": 0.0, "max_phi": 0.0, "max_u1": 0.1, "max_u2": 0.0}
    status, reason = Sinusoidal()._verdict(problem, np.array([0.0, 10.0]), x, np.zeros((2, 2)), stats)
    assert status is PlanStatus.INFEASIBLE and "between plan.path[0] and plan.path[1] of its 2 poses" in reason
    assert stats["min_clearance"] < 0  # the disc's, between the samples


@pytest.mark.parametrize(
    "bad", [{"u2max": 0.0}, {"u1max": -1.0}, {"phimax": 2.0}, {"max_heading_offset": 2.0}, {"dt": 10.0}]
)
def test_bad_options_raise_config_error(bad: dict[str, float]) -> None:
    with pytest.raises(ConfigError):
        make_planner("sinusoidal", **bad)


def test_a_step_no_period_makes_within_the_bounds_is_bounds_violated_not_infeasible() -> None:
    """On generated worlds the step that moves the fourth chained state finds no amplitude within u1max
    and the heading's region at any period: the bounds, not obstacles, stop it (it was reported
    ``infeasible``, which this planner keeps for a path that hits an obstacle)."""
    from planning.scenario import random_scenario

    for robot in ("turtlebot3", "edumip"):
        problem = PlanProblem.from_scenario(random_scenario(robot, 604))
        res = make_planner("sinusoidal").plan(problem)
        assert res.status is PlanStatus.BOUNDS_VIOLATED, res.reason
        # the y still to go counts from where the piece's earlier steps left the robot, beyond the walls (y -3..3):
        # "y by 9.05 m" alone read as a distance in the world
        said = (
            "cannot steer y by 9.05 m (from y = -6.65 m, where the piece's earlier steps left it, to 2.4 m) within "
            "the input limits (u1max, u2max, phimax, the robot's yaw rate) and max_heading_offset at any period up "
            "to max_period = 120 s"
        )
        assert said in res.reason
        assert "no amplitude of u1 within u1max and the heading's region" in res.reason
    simple = PlanProblem.from_scenario(load_scenario("simple_motion"))
    cramped = Sinusoidal(u1max=0.001, max_period=4.0).plan(simple)
    assert cramped.status is PlanStatus.BOUNDS_VIOLATED and "max_period = 4 s" in cramped.reason
    # the x step's period follows from the distance and u1max: the reason names it, and that period lets it through
    slow = Sinusoidal(u1max=0.05, max_period=4.0).plan(simple)
    assert "; a max_period of at least 40.82 s (or a higher u1max) lets it through, or plan with" in slow.reason
    assert Sinusoidal(u1max=0.05, max_period=41.0).plan(simple).status is PlanStatus.SUCCESS


@pytest.mark.slow  # a message's advice; 3 s
def test_a_heading_reversal_beyond_the_method_says_so_and_suggests_no_option_that_cannot_help() -> None:
    """A user's empty 6 x 6 m world, the goal 4 m ahead facing back: piece 2 of 3 (the alternate chart, -45 to
    -135 deg) must move x by 1.46 m sideways, in one fourth-state step at its end heading, 45 deg off its chart's
    centre, where no amplitude moves it more than 0.287 m. The reason said "within the bounds" (read as the
    walls) and advised raising u1max, u2max, phimax, max_heading_offset or max_period: u1max=0.5 and 1.0,
    u2max=10, max_heading_offset=1.5 and max_period=600 all ended the same. It now says what caps the step,
    that raising u1max, u2max or max_period does not help, and names planners that plan it."""
    problem = PlanProblem(
        World((-3.0, 3.0, -3.0, 3.0), ()), load_robot("turtlebot3"), Pose2D(-2.0, 0.0, 0.0), Pose2D(2.0, 0.0, 3.141593)
    )
    res = Sinusoidal().plan(problem)
    assert res.status is PlanStatus.BOUNDS_VIOLATED
    assert res.reason.startswith(
        "sinusoidal steering of piece 2 of 3 (headings -45 to -135 deg): cannot steer x by 1.46 m (from x = "
    )
    assert "within the input limits (u1max, u2max, phimax, the robot's yaw rate) and max_heading_offset" in res.reason
    assert "the farthest any amplitude tried moves it is 0.287 m" in res.reason
    assert "this is a limit of sinusoidal steering, not of the world's walls" in res.reason
    assert (
        "45 deg off its chart's centre" in res.reason and "a longer max_period does not move it farther" in res.reason
    )
    assert "raise u1max" not in res.reason and "within the bounds" not in res.reason
    assert res.reason.endswith("plan with hybrid-a-star or rrt-star (--planner hybrid-a-star)")
    for planner in ("hybrid-a-star", "rrt-star"):  # the planners it names plan it
        assert make_planner(planner).plan(problem).status is PlanStatus.SUCCESS
    longer = Sinusoidal(max_period=600.0).plan(problem)  # as it says: the same step, no farther
    assert longer.status is PlanStatus.BOUNDS_VIOLATED and "x by 1.46 m" in longer.reason and "0.287 m" in longer.reason


def test_a_sideways_step_that_u1max_caps_names_the_period_and_it_lets_the_step_through() -> None:
    problem = PlanProblem(
        World((-5.0, 5.0, -5.0, 5.0), ()), load_robot("turtlebot3"), Pose2D(0, 0, 0), Pose2D(0, 0.1, 0)
    )
    res = Sinusoidal(u1max=0.02, max_period=20.0).plan(problem)
    assert res.status is PlanStatus.BOUNDS_VIOLATED
    assert "the farthest any amplitude tried moves it is 0.035 m" in res.reason
    assert "; a longer max_period or a higher u1max lets it move farther, or plan with hybrid-a-star" in res.reason
    assert Sinusoidal(u1max=0.02, max_period=40.0).plan(problem).status is PlanStatus.SUCCESS


def test_the_time_limit_ends_the_steering() -> None:
    from planning.scenario import random_scenario

    problem = PlanProblem.from_scenario(random_scenario("turtlebot3", 601), time_limit=0.02)
    res = make_planner("sinusoidal").plan(problem)
    assert res.status is PlanStatus.TIMEOUT and res.reason.startswith("time limit of 0.02 s spent steering piece")
    assert res.stats["time_s"] < 0.02 + 0.1  # one period's quadrature past it at most


def _own_time(res, cpu: float) -> float:
    """The time a plan held against its limit: by the wall (sinusoidal readies no numba code), or by this
    process's CPU time where a loaded machine's wall clock ran on without it."""
    return min(res.stats["time_s"] - res.stats.get("code_s", 0.0), cpu)


def test_the_time_limit_holds_inside_a_long_period() -> None:
    """A lateral move is one step of the fourth chained state; at a 300 s period its grid has 240,001 points,
    and one period (32 amplitudes scanned per sign, Brent's method, the quadratures) took 0.3-0.5 s with a
    single look at the clock before it: a 0.05 s limit was overrun by all of it. The clock is now read
    before each quadrature, block of amplitudes and Brent evaluation."""
    import time

    world = World((-5.0, 5.0, -5.0, 5.0), ())
    problem = PlanProblem(
        world, load_robot("turtlebot3"), Pose2D(0.0, 0.0, 0.0), Pose2D(0.0, 0.3, 0.0), time_limit=0.05
    )
    cpu = time.process_time()
    res = Sinusoidal(min_period=300.0, max_period=300.0).plan(problem)
    cpu = time.process_time() - cpu
    assert res.status is PlanStatus.TIMEOUT, res.reason
    assert res.reason == "time limit of 0.05 s spent steering piece 1 of 1"
    assert _own_time(res, cpu) <= 0.05 * 1.1 + 0.02, res.stats


def test_an_answer_known_only_after_the_limit_is_a_timeout(monkeypatch) -> None:
    """random3014's EduMIP at 0.5 s once ended ``bounds_violated`` 0.58 s in: its last period began before
    the limit and failed after it. An answer that comes after the limit, a step no period makes within the
    bounds or a joined path checked, is ``timeout``; the joined path stays attached, and the reason says what
    the answer would have been."""
    import time

    def late(fn):
        def slow(self, *args):
            time.sleep(max(0.0, self._deadline - time.perf_counter()) + 0.01)
            return fn(self, *args)

        return slow

    simple = PlanProblem.from_scenario(load_scenario("simple_motion"), time_limit=0.5)
    assert Sinusoidal().plan(simple).status is PlanStatus.SUCCESS
    monkeypatch.setattr(Sinusoidal, "_verdict", late(Sinusoidal._verdict))
    res = Sinusoidal().plan(simple)
    assert res.status is PlanStatus.TIMEOUT and res.path is not None and res.path.shape[0] > 1
    assert res.reason == "time limit of 0.5 s spent before the answer was known (it came after, success)"
    monkeypatch.undo()
    cramped = Sinusoidal(u1max=0.001, max_period=4.0)
    monkeypatch.setattr(Sinusoidal, "_cannot", late(Sinusoidal._cannot))
    res = cramped.plan(simple)
    assert res.status is PlanStatus.TIMEOUT and res.path.shape[0] == 0
    assert res.reason.startswith("time limit of 0.5 s spent before the answer was known (it came after, ")
    assert "bounds_violated: sinusoidal steering of piece 1 of 1 (heading 0 deg): cannot steer" in res.reason


def test_a_corridor_the_footprint_fits_and_the_disc_does_not_is_planned() -> None:
    """A straight corridor of two boxes 0.24 m apart: the TurtleBot3's footprint (0.178 m across) clears its sides
    by 3 cm, its bounding disc (0.253 m) does not; the exactly straight path was refused as "its path hits one"."""
    robot = load_robot("turtlebot3")
    start, goal = Pose2D(0.4, 0.6, 0.0), Pose2D(3.6, 0.6, 0.0)
    world = World((0.0, 4.0, 0.0, 1.2), (Box((2.0, 0.97), (2.0, 0.5)), Box((2.0, 0.23), (2.0, 0.5))))
    res = Sinusoidal().plan(PlanProblem(world, robot, start, goal))
    assert res.success, res.reason
    np.testing.assert_allclose(res.path[:, 1], 0.6, atol=1e-9)
    narrower = World((0.0, 4.0, 0.0, 1.2), (Box((2.0, 0.93), (2.0, 0.5)), Box((2.0, 0.27), (2.0, 0.5))))  # 0.16 m
    res = Sinusoidal().plan(PlanProblem(narrower, robot, start, goal))
    assert res.status is PlanStatus.INFEASIBLE and "footprint overlaps the box" in res.reason


def test_a_start_or_goal_in_collision_is_invalid_before_any_steering() -> None:
    """A start inside a box and a goal far off were answered BOUNDS_VIOLATED ("cannot steer y by 0.584 m ...")
    where the planners' contract is INVALID_START; the reason names what the footprint overlaps."""
    robot = load_robot("turtlebot3")
    world = World((0.0, 4.0, 0.0, 3.0), (Box((2.0, 1.5), (0.6, 0.6)),))
    res = Sinusoidal().plan(PlanProblem(world, robot, Pose2D(2.0, 1.5, 0.0), Pose2D(3.5, 2.5, 0.0)))
    assert res.status is PlanStatus.INVALID_START, res.reason
    assert "start pose (2.000, 1.500, 0.000) is in collision with the box at x 1.7..2.3, y 1.2..1.8" in res.reason
    res = Sinusoidal().plan(PlanProblem(world, robot, Pose2D(0.5, 0.5, 0.0), Pose2D(1.75, 1.5, 0.0)))
    assert res.status is PlanStatus.INVALID_GOAL and "overlaps it by 92.5 mm; move the goal 0.093 m" in res.reason


def test_a_failed_pieces_headings_are_said_within_a_turn_of_zero() -> None:
    """A start heading of 100 rad (as PlanProblem takes it) was said as "headings 5730 to 5760 deg"."""
    import re

    start = Pose2D(-2.0, 0.0, 100.0)
    problem = PlanProblem(
        World((-3.0, 3.0, -3.0, 3.0)), load_robot("turtlebot3"), start, Pose2D(2.0, 0.0, 100.0 + math.pi)
    )
    res = Sinusoidal().plan(problem)
    said = re.search(r"\(headings (-?\d+) to (-?\d+) deg\)", res.reason)
    assert res.status is PlanStatus.BOUNDS_VIOLATED and said is not None, res.reason
    assert -180 <= int(said.group(1)) <= 180 and abs(int(said.group(2)) - int(said.group(1))) <= 180
