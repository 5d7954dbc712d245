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


def test_poses_the_centre_disc_proves_free_need_no_compiled_call(monkeypatch):
    import planning.collision.grid as grid

    fast = FastChecker(CollisionChecker(WORLD, load_robot("turtlebot3"), clearance=0.05))
    calls = []
    kernel = grid.poses_free_kernel
    monkeypatch.setattr(grid, "poses_free_kernel", lambda p, chk: calls.append(len(p)) or kernel(p, chk))
    clear = [[0.6, -0.3, 0.2], [-0.5, 0.5, 2.0]]  # 0.3 m or more from everything
    assert fast.poses_free(clear).all() and calls == []
    near = [[0.6, -0.3, 0.2], [1.0, 0.62, 0.0], [0.0, 0.0, 0.0]]  # grazing the circle; on the tiny one
    assert (
        fast.poses_free(near).tolist()
        == CollisionChecker(WORLD, load_robot("turtlebot3"), clearance=0.05).poses_free(near).tolist()
    )
    assert calls == [3]  # the disc could not prove them all: one compiled call for the three
    many = np.tile(clear, (3, 1))  # more than a few poses: the compiled checker, whatever they are
    assert fast.poses_free(many).all() and calls == [3, 6]


@pytest.mark.parametrize("reach", [0.05, 0.2])
def test_free_around_a_pose_holds_for_every_pose_within_the_reach(reach):
    """free_around(pose, reach): every pose whose position is within ``reach``, any heading, is free;
    and it says so for most poses that far from everything (it is the grid's bound, not a guess)."""
    robot = load_robot("turtlebot3")
    exact = CollisionChecker(WORLD, robot, clearance=0.02)
    fast = FastChecker(exact)
    rng = np.random.default_rng(3)
    said, where = 0, rng.uniform(-1.4, 1.4, (400, 2))
    for x, y in where:
        if not fast.free_around((x, y, 0.0), reach):
            continue
        said += 1
        a, r = rng.uniform(0, 2 * np.pi, 30), reach * np.sqrt(rng.uniform(0, 1, 30))
        around = np.column_stack([x + r * np.cos(a), y + r * np.sin(a), rng.uniform(-np.pi, np.pi, 30)])
        edge = np.column_stack([x + reach * np.cos(a), y + reach * np.sin(a), a])
        assert exact.poses_free(np.vstack([around, edge])).all()
    far = exact.clearance_of(np.column_stack([where, np.zeros(400)]))  # the footprint's, heading 0
    assert said >= 0.5 * np.sum(far > reach + 0.2)


def test_tiny_obstacle_inside_footprint_is_caught():
    exact = CollisionChecker(WORLD, load_robot("turtlebot3"))
    fast = FastChecker(exact)
    assert not fast.poses_free([[0.0, 0.0, 0.3]])[0]
    assert fast.first_collision([[0.5, 0.0, 0.0], [0.0, 0.0, 0.0]]) == 1


@pytest.mark.parametrize(
    ("robot", "shape", "clearance", "walls"),
    [("turtlebot3", "footprint", 0.0, True), ("edumip", "footprint", 0.1, True), ("turtlebot3", "disc", 0.05, True),
     ("turtlebot3", "footprint", 0.0, False)],
)  # fmt: skip
def test_compiled_exact_matches_exact_near_the_margin(robot, shape, clearance, walls):
    """The compiled exact verdict (what FastChecker asks for the poses its grid leaves undecided)
    equals the exact checker's on 3000 such poses, and on uniform poses."""
    exact = CollisionChecker(WORLD, load_robot(robot), shape=shape, clearance=clearance, walls=walls)
    fast = FastChecker(exact)
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(-2.1, 2.1, (200_000, 2)), rng.uniform(-9, 9, 200_000)])
    undecided = poses[fast._classify(poses, False) < 0][:3000]
    assert undecided.shape[0] == 3000
    for p in (undecided, poses[:3000]):
        ours, ref = fast._exact(p), exact.poses_free(p)
        assert 0.05 < ref.mean() < 0.95
        assert np.array_equal(ours, ref)
