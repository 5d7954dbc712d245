"""Segment inference from (v, omega): hand-computed cases, and a slow sample-by-sample reference on
random inputs and real trajectories."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.core.world import World
from planning.planners.base import PlanProblem
from planning.planners.registry import make_planner
from planning.scenario import load_scenario
from planning.trajectory.from_plan import to_trajectory
from planning.trajectory.references import REFERENCES, make_reference
from planning.trajectory.segments import infer_segments

EPS = 1e-4
F, R, ROT = "forward", "reverse", "rotate"


@pytest.mark.parametrize(
    "v,w,labels,kinds,index",
    [
        # stand-stills join the next moving sample; the trailing one joins the last
        ([0, 0.1, 0, -0.1, 0, 0], [0, 0, 0, 0, 0.3, 0], [F, F, R, R, ROT, ROT], (F, R, ROT), [0, 0, 1, 1, 2, 2]),
        ([0, 0, 0], [0, 0, 0], [F, F, F], (F,), [0, 0, 0]),  # never moves: one forward segment
        ([EPS, -EPS, 0], [0, 0, EPS], [F, F, F], (F,), [0, 0, 0]),  # |v|, |omega| <= eps are zero
        ([EPS, 0.5], [1.0, 1.0], [ROT, F], (ROT, F), [0, 1]),  # a turn needs |v| <= eps
        ([-2 * EPS, 0, -0.2], [5.0, 0, 0], [R, R, R], (R,), [0, 0, 0]),  # one drive across a stop
        ([0.1, 0, 0, 0.2, -0.1], [0, 0.2, 0, 0, 0], [F, ROT, F, F, R], (F, ROT, F, R), [0, 1, 2, 2, 3]),
        ([math.nan, -0.1], [1.0, 0], [R, R], (R,), [0, 0]),  # a non-finite speed is a stand-still
    ],
)
def test_hand_computed_cases(v: list[float], w: list[float], labels: list[str], kinds: tuple, index: list[int]) -> None:
    seg = infer_segments(v, w)
    assert seg.labels == tuple(labels) and seg.kinds == kinds
    assert seg.index.tolist() == index and seg.index.dtype == np.int64


def test_empty_input_and_bad_shapes() -> None:
    seg = infer_segments([], [])
    assert seg.labels == () and seg.kinds == () and seg.index.shape == (0,)
    with pytest.raises(ValueError, match="omega"):
        infer_segments([0.1, 0.2], [0.0])


def _reference(v: np.ndarray, w: np.ndarray) -> tuple[list[str], list[int], list[str]]:
    """Sample by sample: label, fill backwards from the next moving sample, then forwards."""
    labels = []
    for vi, wi in zip(v.tolist(), w.tolist(), strict=True):
        labels.append(F if vi > EPS else R if vi < -EPS else ROT if abs(vi) <= EPS and abs(wi) > EPS else "")
    nxt = ""
    for i in reversed(range(len(labels))):
        labels[i] = nxt = labels[i] or nxt
    for i in range(len(labels)):
        labels[i] = labels[i] or (labels[i - 1] if i else F)
    index, kinds = [], []
    for i, label in enumerate(labels):
        if i == 0 or label != labels[i - 1]:
            kinds.append(label)
        index.append(len(kinds) - 1)
    return labels, index, kinds


def _agree(v: np.ndarray, w: np.ndarray) -> None:
    seg = infer_segments(v, w)
    labels, index, kinds = _reference(v, w)
    assert list(seg.labels) == labels and seg.index.tolist() == index and list(seg.kinds) == kinds


@pytest.mark.parametrize("seed", range(50))
def test_agrees_with_a_sample_by_sample_reference_on_random_inputs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 60))
    pick = np.array([0.0, EPS, -EPS, 2 * EPS, -2 * EPS, 0.5 * EPS, 0.1, -0.1])  # at and around +-eps
    v = pick[rng.integers(0, pick.size, n)] * (rng.random(n) < 0.6)
    w = pick[rng.integers(0, pick.size, n)] * (rng.random(n) < 0.5)
    _agree(v, w)


def test_agrees_with_the_reference_on_real_trajectories() -> None:
    for name in ("turtlebot3", "edumip"):
        robot = load_robot(name)
        for ref in REFERENCES:
            traj = make_reference(ref, robot, Pose2D(0.1, -0.2, 0.3))
            _agree(traj.vel[:, 0], traj.vel[:, 1])
        path = np.array([[0, 0, 0], [0.6, 0, 0], [0.6, 0, 1.5], [0.3, -0.4, 1.5]], dtype=float)
        traj = to_trajectory(path, robot, World((-3.0, 3.0, -3.0, 3.0), ()), directions=[1, 1, 1, -1])
        _agree(traj.vel[:, 0], traj.vel[:, 1])
    for scenario in ("turn_in_place", "parallel_park"):  # timed plans: cusps between drives
        plan = make_planner("sinusoidal").plan(PlanProblem.from_scenario(load_scenario(scenario), seed=0))
        assert plan.success and plan.controls is not None
        _agree(np.asarray(plan.controls)[:, 0], np.asarray(plan.controls)[:, 1])
