"""Segment inference from (v, omega): hand-computed cases, and agreement with the two former copies."""

from __future__ import annotations

import numpy as np
import pytest

from control.segmented import infer_segments as tracker_infer
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.core.world import World
from planning.planners.base import PlanProblem, make_planner
from planning.scenario import load_scenario
from planning.trajectory.from_plan import _timed_kinds, to_trajectory
from planning.trajectory.references import REFERENCES, make_reference
from planning.trajectory.segments import infer_segments
from planning.trajectory.trajectory import Trajectory

EPS = 1e-4


def _random_inputs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Runs of stand-stills, drives both ways and turns, with values at and around +-eps."""
    pick = np.array([0.0, EPS, -EPS, 2 * EPS, -2 * EPS, 0.5 * EPS, 0.1, -0.1])
    v = pick[rng.integers(0, pick.size, n)] * (rng.random(n) < 0.6)
    w = pick[rng.integers(0, pick.size, n)] * (rng.random(n) < 0.5)
    return v, w


def _agree(v: np.ndarray, w: np.ndarray) -> None:
    new = infer_segments(v, w)
    assert list(new.labels) == _timed_kinds(v, w)
    t = np.arange(v.size, dtype=float)
    seg, kinds = tracker_infer(Trajectory(t, np.zeros((v.size, 3)), np.column_stack([v, w]), np.zeros((v.size, 2))))
    assert new.kinds == kinds and np.array_equal(new.index, seg) and new.index.dtype == seg.dtype


@pytest.mark.parametrize("seed", range(200))
def test_agrees_with_both_former_copies_on_random_inputs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    _agree(*_random_inputs(rng, int(rng.integers(2, 40))))


def test_agrees_with_both_former_copies_on_real_trajectories() -> None:
    trajs = []
    for name in ("turtlebot3", "edumip"):
        robot = load_robot(name)
        trajs += [make_reference(ref, robot, Pose2D(0.1, -0.2, 0.3)) for ref in REFERENCES]
        path = np.array([[0, 0, 0], [0.6, 0, 0], [0.6, 0, 1.5], [0.3, -0.4, 1.5]], dtype=float)
        trajs.append(to_trajectory(path, robot, World((-3.0, 3.0, -3.0, 3.0), ()), directions=[1, 1, 1, -1]))
    for traj in trajs:
        _agree(traj.vel[:, 0], traj.vel[:, 1])
    for scenario in ("turn_in_place", "parallel_park"):  # timed plans: cusps between drives
        plan = make_planner("sinusoidal").plan(PlanProblem.from_scenario(load_scenario(scenario), seed=0))
        assert plan.success and plan.controls is not None
        _agree(np.asarray(plan.controls)[:, 0], np.asarray(plan.controls)[:, 1])
