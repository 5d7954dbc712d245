"""Motion primitives and the diff-drive least-squares steer against independent integration."""

import numpy as np
import pytest

from planning.core.kinematics import bicycle_rhs, rollout
from planning.core.robot import load_robot
from planning.planners.sampling.steering import (
    CurveSteering,
    bicycle_primitives,
    default_turning_radius,
    diffdrive_steer,
    place,
    se2_metric,
    unicycle_primitives,
)


@pytest.mark.parametrize("name", ["turtlebot3", "edumip"])
def test_bicycle_primitives_match_rk4_and_limits(name):
    robot = load_robot(name)
    prims = bicycle_primitives(robot)
    assert prims.poses.shape[0] == 60
    assert np.sum(prims.directions > 0) == 30
    v, w = prims.controls[:, 0], prims.controls[:, 1]
    assert np.all(np.abs(v) <= robot.max_speed + 1e-12)
    assert np.all(np.abs(w) <= robot.max_yaw_rate + 1e-9)
    assert np.all(np.abs(prims.steering) <= robot.max_steering + 1e-12)
    for p in range(0, 60, 7):
        n = 2000
        u = np.tile([v[p], 0.0], (n, 1))
        ref = rollout(lambda s, uu: bicycle_rhs(s, uu, robot.wheelbase), [0, 0, 0, prims.steering[p]], u, 1.0 / n)
        assert np.allclose(prims.poses[p, -1], ref[-1, :3], atol=1e-9)
    steps = np.hypot(*np.diff(prims.poses[..., :2], axis=1).transpose(2, 0, 1))
    assert steps.max() <= 0.01 + 1e-12


def test_unicycle_primitives_of_the_fruit_farm_report():
    prims = unicycle_primitives()
    assert prims.poses.shape == (6, 101, 3)
    assert prims.duration == pytest.approx(5.0)
    assert set(map(tuple, prims.controls)) == {(v, w) for v in (0.15, -0.15) for w in (0.15, 0.0, -0.15)}
    # RK4 with a 0.05 s step against the exact arc: error far below a millimetre
    for (v, w), poses in zip(prims.controls, prims.poses, strict=True):
        t = 5.0
        exact = [v * t, 0.0] if w == 0 else [v / w * np.sin(w * t), v / w * (1 - np.cos(w * t))]
        assert np.allclose(poses[-1, :2], exact, atol=1e-9)
        assert poses[-1, 2] == pytest.approx(w * t)


def test_diffdrive_reaches_feasible_targets_and_clips():
    robot = load_robot("turtlebot3")
    # a target reachable by a feasible constant twist over 1 s is reached exactly
    v, w = 0.1, 0.5
    target = np.array([v / w * np.sin(w), v / w * (1 - np.cos(w)), w])
    poses = diffdrive_steer([0, 0, 0], target, robot)
    assert np.linalg.norm(poses[-1, :2] - target[:2]) < 0.01  # least squares on a chord: close, not exact
    # far targets are clipped to the limits
    poses = diffdrive_steer([0, 0, 0], [5.0, 0.0, 0.0], robot)
    assert poses[-1, 0] == pytest.approx(robot.max_speed, rel=1e-9)
    assert np.all(np.hypot(*np.diff(poses[:, :2], axis=0).T) <= 0.0101)


def test_metric_is_heading_periodic():
    nodes = np.array([[0.0, 0.0, np.pi - 1e-3], [0.0, 0.0, 0.0]])
    d = se2_metric(nodes, np.array([0.0, 0.0, -np.pi + 1e-3]))
    assert d[0] < 3e-3 and d[1] > 1.9


def test_curve_steering():
    robot = load_robot("turtlebot3")
    rho = default_turning_radius(robot)
    cs = CurveSteering("reeds_shepp", rho)
    w = cs.curve([0, 0, 0], [1, 0.5, 1.0])
    assert w.length == pytest.approx(cs.lengths([0, 0, 0], [1, 0.5, 1.0])[0])
    with pytest.raises(ValueError, match="curve kind"):
        CurveSteering("spline", 1.0)  # type: ignore[arg-type]


def test_place_at_many_poses_is_place_at_each_bit_for_bit():
    rng = np.random.default_rng(3)
    bodies = rng.normal(size=(6, 5, 3))
    poses = rng.uniform(-4.0, 4.0, size=(6, 3))
    together = place(bodies, poses[:, None, :])
    for k in range(6):
        assert np.array_equal(together[k], place(bodies[k], poses[k]))
