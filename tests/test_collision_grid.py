"""The fast front end returns exactly the exact checker's verdicts."""

import numpy as np
import pytest

from planning.collision.exact import CollisionChecker
from planning.collision.grid import FastChecker
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, Ellipse, Polygon, World

WORLD = World(
    (-2.0, 2.0, -2.0, 2.0),
    (
        Circle((1.0, 1.0), 0.3), Ellipse((-1.0, 1.0), (0.5, 0.2), 0.4), Box((1.0, -1.0), (0.6, 0.3), 0.3),
        Polygon(((-1.5, -1.5), (-0.8, -1.4), (-1.2, -0.7))), Circle((0.0, 0.0), 0.01),
    ),
)  # fmt: skip


@pytest.mark.parametrize("robot", ["turtlebot3", "edumip"])
@pytest.mark.parametrize("shape", ["disc", "footprint"])
@pytest.mark.parametrize("clearance", [0.0, 0.1])
def test_same_verdicts_as_exact(robot, shape, clearance):
    exact = CollisionChecker(WORLD, load_robot(robot), shape=shape, clearance=clearance)
    fast = FastChecker(exact)
    rng = np.random.default_rng(0)
    poses = np.column_stack([rng.uniform(-2.1, 2.1, (3000, 2)), rng.uniform(-4, 4, 3000)])
    a, b = exact.poses_free(poses), fast.poses_free(poses)
    assert 0.2 < a.mean() < 0.95
    assert np.array_equal(a, b)
    # motions: densified straight sweeps
    for k in range(20):
        m = np.linspace(poses[k], poses[k + 1], 5)
        assert fast.motion_free(m) == exact.motion_free(m)


def test_tiny_obstacle_inside_footprint_is_caught():
    exact = CollisionChecker(WORLD, load_robot("turtlebot3"))
    fast = FastChecker(exact)
    assert not fast.poses_free([[0.0, 0.0, 0.3]])[0]
    assert fast.first_collision([[0.5, 0.0, 0.0], [0.0, 0.0, 0.0]]) == 1
