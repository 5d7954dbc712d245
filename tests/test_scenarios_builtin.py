"""Every built-in scenario loads, and its start and goal are collision-free for each of its robots."""

from __future__ import annotations

import numpy as np
import pytest

from planning.collision.exact import CollisionChecker
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, Ellipse
from planning.planners.base import PlanProblem
from planning.scenario import builtin_scenarios, load_scenario

NAMES = builtin_scenarios()


def test_the_reports_scenarios_ship():
    assert {"farm", "parking_lot", "edumip_map"} <= set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_loads_with_free_start_and_goal(name):
    sc = load_scenario(name)
    assert sc.name == name
    assert sc.robot in sc.robots
    for robot_name in sc.robots:
        robot = load_robot(robot_name)
        checker = CollisionChecker(sc.world, robot, shape="footprint")
        poses = np.array([sc.start.as_array(), sc.goal.as_array()])
        assert np.all(checker.poses_free(poses)), f"{name}: start or goal collides for {robot_name}"
        # independently: no footprint vertex inside an obstacle or beyond a wall
        corners = robot.footprint_at(poses).reshape(-1, 2)
        assert np.all(sc.world.signed_distance(corners) > 0)
        PlanProblem.from_scenario(sc, robot=robot)


def test_the_balancing_edumip_goes_wherever_the_edumip_goes():
    # `nhsim scenarios` lists the balancing EduMIP where the EduMIP applies (the same wheels,
    # motors and sensors; only the skids differ), and nowhere else
    with_edumip = {n for n in NAMES if "edumip" in load_scenario(n).robots}
    with_balancing = {n for n in NAMES if "edumip-balancing" in load_scenario(n).robots}
    assert with_balancing == with_edumip
    assert {"open", "edumip_map", "farm", "parking_lot", "turn_in_place"} <= with_balancing
    assert "three_point_turn" not in with_balancing  # a bicycle's manoeuvre: the TurtleBot3's only


def test_farm_is_the_fruit_farm_reports():
    sc = load_scenario("farm")
    assert sc.world.bounds == (-3.0, 3.0, -3.0, 3.0)
    kinds = {type(o) for o in sc.world.obstacles}
    assert kinds == {Circle, Ellipse}
    assert len(sc.world.obstacles) == 13
    np.testing.assert_allclose(sc.start.as_array(), [-1.0, -1.0, np.pi / 4])
    # the fruit-farm report's goal (2.5, 2) is 0.10 m from tree7, inside the TurtleBot3's disc: moved back along y = 2
    np.testing.assert_allclose(sc.goal.as_array(), [2.15, 2.0, 0.0])
    assert (sc.position_tolerance, sc.heading_tolerance) == (0.02, 0.1)
    tree7 = [o for o in sc.world.obstacles if isinstance(o, Circle) and o.center == (2.7, 2.0)]
    assert len(tree7) == 1 and np.hypot(2.7 - 2.15, 0.0) - tree7[0].radius == pytest.approx(0.45)
    # every obstacle and wall at least 0.25 m away (an independent distance: circles and ellipse samples)
    g = np.array([2.15, 2.0])
    for o in sc.world.obstacles:
        if isinstance(o, Circle):
            assert np.hypot(*(g - np.array(o.center))) - o.radius >= 0.25
        else:
            t = np.linspace(0, 2 * np.pi, 2000)
            pts = np.array(o.center) + np.column_stack([o.radii[0] * np.cos(t), o.radii[1] * np.sin(t)])
            assert np.hypot(*(pts - g).T).min() >= 0.25
    assert min(g[0] + 3, 3 - g[0], g[1] + 3, 3 - g[1]) >= 0.25


def test_parking_goal_is_an_empty_bay_between_parked_cars():
    sc = load_scenario("parking_lot")
    assert all(isinstance(o, Box) for o in sc.world.obstacles)
    g = sc.goal
    same_row = [o for o in sc.world.obstacles if abs(o.center[1] - g.y) < 1e-9]
    left = [o for o in same_row if o.center[0] < g.x]
    right = [o for o in same_row if o.center[0] > g.x]
    assert left and right
    assert g.x - max(o.center[0] for o in left) == pytest.approx(0.4)
    assert min(o.center[0] for o in right) - g.x == pytest.approx(0.4)
    assert g.heading_error_to(type(g)(0.0, 0.0, np.pi / 2)) < 1e-12  # nose-in, toward the wall


def test_edumip_map_is_the_edumip_planning_reports():
    sc = load_scenario("edumip_map")
    assert sc.robot == "edumip"
    assert len(sc.world.obstacles) == 4
    np.testing.assert_allclose(sc.start.xy, [0.0, 0.0])
    np.testing.assert_allclose(sc.goal.xy, [5.0, 5.0])
    # start and goal keep C-RRT*'s 40 cm axle-centre clearance from obstacles and walls
    assert np.all(sc.world.signed_distance(np.array([sc.start.xy, sc.goal.xy])) > 0.40)
