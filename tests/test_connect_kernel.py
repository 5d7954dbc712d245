"""BiRRT's compiled search and the lazily checked curves it extends along.

The compiled loop (:mod:`planning.planners.sampling.connect_kernel`) must grow the same trees and
return the same path as the plain-Python loop (``rrt._meet_python``, the reference), the lazily
computed poses of a cut curve must be the poses its dense samples hold, and the compiled motion
verdict must be the exact checker's on those samples.
"""

import dataclasses
from unittest import mock

import numpy as np
import pytest

from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, World
from planning.planners.base import PlanProblem, PlanStatus
from planning.planners.registry import make_planner
from planning.planners.sampling import rrt
from planning.planners.sampling.connect_kernel import steer_free
from planning.planners.sampling.extend import LocalPlanner, check_order
from planning.planners.sampling.fastcurve import cut_word, steer_kernel, word_pose, word_poses, word_size
from planning.planners.sampling.rrt import BiRRT
from planning.planners.sampling.steering import CurveSteering
from planning.planners.sampling.tree import Budget, draws, make_checker
from planning.scenario import random_scenario

ROBOT = load_robot("turtlebot3")
CLUTTER = World(
    (0.0, 3.0, 0.0, 2.0),
    (Circle((1.0, 1.0), 0.3), Box((2.0, 0.6), (0.4, 0.8)), Circle((2.2, 1.6), 0.15)),
)


def _problems() -> list[PlanProblem]:
    clutter = PlanProblem(CLUTTER, ROBOT, Pose2D(0.3, 0.3, 0.0), Pose2D(2.7, 1.7, np.pi / 2), time_limit=600.0)
    rand = [PlanProblem.from_scenario(random_scenario("turtlebot3", s)) for s in (3, 11)]
    return [clutter, *(dataclasses.replace(p, time_limit=600.0) for p in rand)]


def _python(planner: BiRRT, problem: PlanProblem):
    """The plan with the plain-Python search loop."""
    with mock.patch.object(rrt, "compiled", lambda local: False):
        return planner.plan(problem)


@pytest.mark.parametrize("steering", ["reeds_shepp", "dubins"])
def test_compiled_search_grows_the_python_loops_trees(steering):
    for problem in _problems():
        planner = make_planner("birrt", steering=steering, simplify=False, max_iterations=3000)
        for seed in range(4):
            p = dataclasses.replace(problem, seed=seed)
            fast, ref = planner.plan(p), _python(planner, p)
            assert fast.status is ref.status
            assert fast.stats["iterations"] == ref.stats["iterations"] and fast.stats["nodes"] == ref.stats["nodes"]
            np.testing.assert_array_equal(fast.path, ref.path)
            np.testing.assert_array_equal(fast.directions, ref.directions)
            np.testing.assert_array_equal(fast.tree.nodes, ref.tree.nodes)
            np.testing.assert_array_equal(fast.tree.parents, ref.tree.parents)
            assert len(fast.tree.edges) == len(ref.tree.edges)
            for a, b in zip(fast.tree.edges, ref.tree.edges, strict=True):
                np.testing.assert_array_equal(a, b)


def test_compiled_search_stops_at_its_iteration_budget():
    # no way through: the slit (0.12 m) passes the robot's inscribed disc (so no 2-D proof ends the search early),
    # not the robot (0.178 m wide)
    wall = World((0.0, 3.0, 0.0, 2.0), (Box((1.5, 0.47), (0.1, 0.94)), Box((1.5, 1.53), (0.1, 0.94))))
    p = PlanProblem(wall, ROBOT, Pose2D(0.4, 1.0, 0.0), Pose2D(2.6, 1.0, 0.0), time_limit=600.0)
    planner = make_planner("birrt", steering="reeds_shepp", simplify=False, max_iterations=300)
    fast, ref = planner.plan(p), _python(planner, p)
    assert fast.status is PlanStatus.TIMEOUT and ref.status is PlanStatus.TIMEOUT
    assert fast.stats["iterations"] == ref.stats["iterations"] == 300
    assert fast.stats["nodes"] == ref.stats["nodes"] > 2
    np.testing.assert_array_equal(fast.path, ref.path)


def _pairs(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo, hi = np.array([0.0, 0.0, -np.pi]), np.array([3.0, 2.0, np.pi])
    return rng.uniform(lo, hi, size=(n, 2, 3))


@pytest.mark.parametrize("kind", ["reeds_shepp", "dubins"])
def test_an_uncut_curve_samples_as_the_word_does(kind):
    rho, step = 0.15, 0.01
    for q0, q1 in _pairs(40):
        poses, dirs, ok = steer_kernel(kind == "reeds_shepp", q0, q1, rho, step, np.inf, False)
        assert ok
        ref, ref_dirs = CurveSteering(kind, rho).curve(q0, q1).sample(step)
        ref[-1] = q1  # the end pinned
        np.testing.assert_array_equal(poses, ref)
        np.testing.assert_array_equal(dirs, ref_dirs)


@pytest.mark.parametrize("keep_end", [False, True])
def test_a_cut_curve_keeps_its_arc_and_lies_on_the_whole_curve(keep_end):
    rho, step, max_len = 0.15, 0.01, 0.4
    for q0, q1 in _pairs(40, seed=1):
        word, ok = cut_word(True, q0, q1, rho, step, max_len, keep_end)
        whole, ok2 = cut_word(True, q0, q1, rho, step, np.inf, False)
        assert ok and ok2
        total = float(np.sum(np.abs(whole[2]))) * rho
        kept = float(np.sum(np.abs(word[2]))) * rho
        assert kept == pytest.approx(min(total, max_len), abs=1e-9)
        poses, _ = word_poses(word, rho)
        assert word_size(word) == poses.shape[0]
        for j in (0, poses.shape[0] // 2, poses.shape[0] - 1):
            np.testing.assert_array_equal(poses[j], word_pose(word, j, rho)[:3])
        if keep_end:
            np.testing.assert_array_equal(poses[-1], q1)
        else:
            np.testing.assert_array_equal(poses[0], q0)
        steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
        assert steps.max() <= step + 1e-12
        # every kept pose is on the whole curve (within the sampling's rounding)
        dense = steer_kernel(True, q0, q1, rho, 0.001, np.inf, False)[0]
        gap = np.min(np.hypot(dense[None, :, 0] - poses[:, None, 0], dense[None, :, 1] - poses[:, None, 1]), axis=1)
        assert gap.max() <= 0.001


def test_the_lazy_motion_check_gives_the_checkers_verdict():
    problem = _problems()[0]
    chk = make_checker(problem, "footprint", 0.0)
    local = LocalPlanner("reeds_shepp", ROBOT, chk, step_range=0.6)
    assert local.rho is not None and local.check_arrays is not None
    geometry = np.array([local.rho, local.sample_step])
    spans = np.empty(8, dtype=np.int64)  # too short: replaced inside
    buf_p, buf_d = np.empty((4, 3)), np.empty(4)  # too short: replaced
    verdicts = []
    for q0, q1 in _pairs(300, seed=2):
        for max_len, keep_end in ((np.inf, False), (0.6, False), (0.6, True)):
            args = (True, q0, q1, geometry, max_len, keep_end, 1, local.check_arrays, spans, buf_p, buf_d)
            n, verdict, p, d = steer_free(*args)
            poses, dirs = word_poses(
                cut_word(True, q0, q1, local.rho, local.sample_step, max_len, keep_end)[0], local.rho
            )
            assert n == poses.shape[0]
            assert verdict == int(chk.path_free(poses))
            assert verdict == int(bool(np.all(chk.checker.poses_free(poses))))
            if verdict:  # every pose was computed while checked
                np.testing.assert_array_equal(p[:n], poses)
                np.testing.assert_array_equal(d[:n], dirs)
            verdicts.append(verdict)
    assert 0.1 < np.mean(verdicts) < 0.9  # both verdicts were exercised


@pytest.mark.parametrize(
    ("shape", "clearance"), [("footprint", 0.0), ("footprint", 0.05), ("disc", 0.0), ("disc", 0.04)]
)
def test_poses_the_grid_proves_free_by_a_neighbours_margin_give_the_checkers_verdict(shape, clearance):
    """A pose proven free by the disc proves its neighbours within the margin free (unclassified): the verdict
    must stay the exact checker's on every pose, in worlds drawn at random, the curves' ends anywhere in them
    (so near obstacles and walls too), with a clearance and without."""
    verdicts = []
    for seed in (5, 17, 29):
        problem = PlanProblem.from_scenario(random_scenario("edumip" if seed == 17 else "turtlebot3", seed))
        chk = make_checker(problem, shape, clearance)
        local = LocalPlanner("reeds_shepp", problem.robot, chk)
        assert local.rho is not None and local.check_arrays is not None
        geometry = np.array([local.rho, local.sample_step])
        xmin, xmax, ymin, ymax = problem.world.bounds
        rng = np.random.default_rng(seed)
        ends = rng.uniform([xmin, ymin, -np.pi], [xmax, ymax, np.pi], size=(150, 2, 3))
        spans, buf_p, buf_d = np.empty(8, dtype=np.int64), np.empty((4, 3)), np.empty(4)
        for q0, q1 in ends:
            for max_len in (np.inf, 1.5):
                args = (True, q0, q1, geometry, max_len, False, 1, local.check_arrays, spans, buf_p, buf_d)
                n, verdict, p, _ = steer_free(*args)
                poses, _ = word_poses(
                    cut_word(True, q0, q1, local.rho, local.sample_step, max_len, False)[0], local.rho
                )
                assert verdict == int(bool(np.all(chk.checker.poses_free(poses)))), (seed, q0, q1, max_len)
                if verdict:
                    np.testing.assert_array_equal(p[:n], poses)
                verdicts.append(verdict)
    assert 0.1 < np.mean(verdicts) < 0.9  # both verdicts were exercised


def test_check_order_is_a_permutation():
    for n in (1, 2, 3, 10, 57):
        for new_first in (False, True):
            assert sorted(check_order(n, new_first).tolist()) == list(range(n))


def _ring_problem(seed: int) -> PlanProblem:
    """The goal inside a closed ring the robot cannot enter, its tolerance (0.25 m) reaching outside: the goal tree
    never leaves the ring, and a path ends where a start-tree node lands within the tolerance."""
    ring = (Box((1.9625, 0.88), (0.235, 0.02)), Box((1.9625, 1.12), (0.235, 0.02)),
            Box((1.855, 1.0), (0.02, 0.26)), Box((2.07, 1.0), (0.02, 0.26)))  # fmt: skip
    return PlanProblem(World((0.0, 3.0, 0.0, 2.0), ring), ROBOT, Pose2D(0.5, 1.0, 0.0), Pose2D(1.98, 1.0, 0.0),
                       seed=seed, time_limit=600.0, position_tolerance=0.25, heading_tolerance=np.pi)  # fmt: skip


@pytest.mark.parametrize("region", [True, False])
def test_the_compiled_meeting_ends_where_the_python_loops_does(region):
    """rrt-star's first path by birrt's search (``meet``, with ``region``: a start-tree node in the goal region ends
    it too): the compiled loop stops at the iteration and on the nodes the Python loop does, with the same chain of
    nodes and edges. In the region: the ring's goal (by an extension) and, with a 0.8 m tolerance in the clutter,
    by a connect step toward the goal tree."""
    clutter = _problems()[0]
    wide = dataclasses.replace(clutter, position_tolerance=0.8, heading_tolerance=np.pi)
    cases = [(_ring_problem(0), "ring"), (_ring_problem(1), "ring"), (wide, "region")] if region else []
    for problem, ends in [*cases, *((p, "goal") for p in _problems()[:2])]:
        planner = make_planner("rrt-star", simplify=False)
        local, _, bad = planner._setup(problem)
        assert bad is None

        def met(local=local, problem=problem, planner=planner):
            budget = Budget(20000, 600.0)
            return rrt.meet(problem, local, budget, draws(problem), planner.config, 50, 7, region)

        fast = met()
        with mock.patch.object(rrt, "compiled", lambda local: False):
            ref = met()
        assert fast.joined and ref.joined and fast.iterations == ref.iterations > 7
        np.testing.assert_array_equal(fast.path()[0], ref.path()[0])
        fast_chain, ref_chain = fast.chain(), ref.chain()
        assert len(fast_chain) == len(ref_chain) > 0
        for f, r in zip(fast_chain, ref_chain, strict=True):
            for x, y in zip(f, r, strict=True):
                np.testing.assert_array_equal(x, y)
        end, goal = fast_chain[-1][0], problem.goal.as_array()
        off = np.hypot(end[0] - goal[0], end[1] - goal[1])
        if ends == "goal":
            np.testing.assert_array_equal(end, goal)
        else:  # in the region, not on the goal pose (the ring's: outside the ring)
            assert (0.15 if ends == "ring" else 0.0) < off <= problem.position_tolerance
