"""Timed pieces joined end to end never repeat or reverse a stamp: a piece of no duration is refused by
its maker and skipped by the join, and a file that ends by stopping short while its heading turns (the
last sample alone labelled a turn in place, by nothing) is re-timed into a valid trajectory."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_importer import write_csv

from planning.core.robot import load_robot
from planning.core.world import World
from planning.planners.base import PlanResult, PlanStatus
from planning.trajectory.file_trajectory import file_trajectory
from planning.trajectory.from_plan import make_trajectory, turn_legs
from planning.trajectory.importer import TrajectoryFile, read_trajectory_file
from planning.trajectory.speed_profile import Limits, TimedSamples, time_rotation

EDUMIP = load_robot("edumip")


def test_a_turn_by_nothing_is_refused_by_its_maker_not_timed_in_no_time() -> None:
    lim = Limits.from_robot(EDUMIP)
    with pytest.raises(ValueError, match="turns by nothing"):
        time_rotation(np.array([1.0, 2.0]), 0.3, 0.3, lim)
    smp = time_rotation(np.array([1.0, 2.0]), 0.3, 0.3 + 1e-12, lim)  # the smallest turn still takes time
    assert np.all(np.diff(smp.t) > 0.0) and smp.pose[-1, 2] == 0.3 + 1e-12


def test_timed_samples_check_their_stamps() -> None:
    pose, two = np.zeros((3, 3)), np.zeros((3, 2))
    TimedSamples(np.array([0.0, 0.01, 0.02]), pose, two, two)
    for bad in ([0.0, 0.0, 0.0], [0.0, 0.02, 0.01], [0.01, 0.02, 0.03], [0.0, np.nan, 0.02]):
        with pytest.raises(ValueError, match="strictly increase"):
            TimedSamples(np.array(bad), pose, two, two)
    with pytest.raises(ValueError, match="N >= 2"):
        TimedSamples(np.array([0.0, 0.01, 0.02]), pose[:2], two, two)


def test_a_timed_plan_whose_last_sample_alone_turns_is_retimed_into_a_valid_trajectory() -> None:
    t = np.arange(0.0, 5.0 + 1e-9, 0.01)
    s = t / 5.0
    x = 0.5 + 0.5 * (10 * s**3 - 15 * s**4 + 6 * s**5)
    v = 0.5 * (30 * s**2 - 60 * s**3 + 30 * s**4) / 5.0
    w = np.zeros_like(t)
    w[-1] = 0.2  # at rest, turning: labelled a turn in place, alone, with nothing left to turn
    path = np.column_stack([x, np.full_like(t, 0.5), np.zeros_like(t)])
    plan = PlanResult(PlanStatus.SUCCESS, "timed", path, times=t, controls=np.column_stack([v, w]))
    res = make_trajectory(plan, EDUMIP, World((0.0, 1.5, 0.0, 1.0)), retime=True)
    traj = res.trajectory
    assert res.success and traj is not None and np.all(np.diff(traj.t) > 0.0)
    np.testing.assert_allclose(traj.pose[-1], [1.0, 0.5, 0.0], atol=1e-9)


def test_a_file_that_stops_short_while_its_heading_turns_is_retimed_not_broken(tmp_path: Path) -> None:
    # pixels at 1 cm: from rest to 10 px/s, then a stop within the last 0.05 s while the heading turns
    t = np.array([0.0, 1.0, 2.5, 4.0, 5.0, 5.05])
    v = np.array([0.0, 10.0, 10.0, 10.0, 10.0, 0.0])
    x = 50.0 + np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (v[:-1] + v[1:]))])
    cols = {"t": t, "x": x, "y": np.full(6, 50.0), "vx": v, "vy": np.zeros(6), "theta": [0, 0, 0, 0, 0, 0.05]}
    imp = read_trajectory_file(TrajectoryFile(write_csv(tmp_path / "stop.csv", cols), scale=0.01))
    res = file_trajectory(imp, EDUMIP, World((0.0, 2.0, 0.0, 1.5)))
    traj = res.trajectory
    assert res.success and traj is not None and imp.report.retimed and "acceleration" in imp.report.timing
    assert np.all(np.diff(traj.t) > 0.0)
    np.testing.assert_allclose(traj.pose[-1, :2], [0.9525, 0.5], atol=1e-6)  # where the file ends
    assert np.max(np.abs(traj.pose[:, 1] - 0.5)) < 1e-9  # along its line


def _ramp(u: np.ndarray) -> np.ndarray:
    return 10 * u**3 - 15 * u**4 + 6 * u**5


def test_a_turn_in_place_out_and_back_keeps_both_legs_when_retimed() -> None:
    # drive 0.25 m, turn in place to +1 rad and back to 0, drive on 0.25 m: the turn's net is nothing
    t = np.arange(0.0, 12.0 + 1e-9, 0.01)
    s, turn = np.clip(t / 4.0, 0.0, 1.0), np.clip((t - 4.0) / 4.0, 0.0, 1.0)
    s2 = np.clip((t - 8.0) / 4.0, 0.0, 1.0)
    x = 0.5 + 0.25 * _ramp(s) + 0.25 * _ramp(s2)
    theta = np.sin(np.pi * turn)  # 0 -> 1 -> 0 rad
    path = np.column_stack([x, np.full_like(t, 0.5), theta])
    v, w = np.gradient(x, t), np.gradient(theta, t)
    plan = PlanResult(PlanStatus.SUCCESS, "timed", path, times=t, controls=np.column_stack([v, w]))
    res = make_trajectory(plan, EDUMIP, World((0.0, 1.5, 0.0, 1.0)), retime=True)
    traj = res.trajectory
    assert res.success and traj is not None and np.all(np.diff(traj.t) > 0.0)
    assert traj.pose[:, 2].max() == pytest.approx(1.0, abs=1e-3)  # out to +1 rad ...
    assert traj.segment_kinds.count("rotate") == 2 and abs(traj.pose[-1, 2]) < 1e-3  # ... and back


def test_turn_legs_split_at_reversals_beyond_the_tolerance() -> None:
    assert turn_legs(np.array([0.0, 0.5, 1.0, 0.5, 0.0])) == [0, 2, 4]
    assert turn_legs(np.array([0.0, 1e-4, 2e-4, 1e-4, 0.5])) == [0, 4]  # a wobble of 0.1 mrad is no reversal
    assert turn_legs(np.array([0.0, -1.0, 2.0, 2.0])) == [0, 1, 3]
    assert turn_legs(np.array([0.3])) == [0]


def test_a_timed_plan_ending_beside_the_goal_is_moved_onto_it_gradually() -> None:
    """A kept timed plan (its samples as they are) whose end is 3 mm beside the goal: moving only the last
    sample onto the goal made its reference slide 3 mm sideways in one 10 ms period (0.3 m/s, the optim
    planner's ends); the move is spread over the last second, so no step of the reference moves sideways
    faster than a few millimetres a second, and it still ends on the goal."""
    from planning.core.geometry import Pose2D
    from planning.trajectory.from_plan import SNAP_BLEND

    t = np.arange(0.0, 6.001, 0.01)
    v = 0.2 * np.minimum(1.0, np.minimum(t, t[-1] - t) / 1.0)  # 1 s ramps, well within the limits
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    path = np.column_stack([x, np.full_like(x, 0.003), np.zeros_like(x)])
    plan = PlanResult(PlanStatus.SUCCESS, "optim", path, times=t, controls=np.column_stack([v, np.zeros_like(v)]))
    goal = Pose2D(float(x[-1]), 0.0, 0.0)
    res = make_trajectory(plan, EDUMIP, World((-1.0, 2.0, -1.0, 1.0), ()), goal=goal, retime=False)
    traj = res.trajectory
    assert res.success and traj is not None
    end = np.searchsorted(traj.t, t[-1] * (res.stats["time_scale"] or 1.0) - 1e-9)
    np.testing.assert_allclose(traj.pose[end, :2], [goal.x, goal.y], atol=1e-12)
    sideways = np.abs(np.diff(traj.pose[: end + 1, 1])) / np.diff(traj.t[: end + 1])
    assert sideways.max() < 2.0 * 0.003 / SNAP_BLEND  # smoothstep: 1.5x the mean rate at its steepest
    assert np.all(traj.pose[: int(np.searchsorted(traj.t, 4.9)), 1] == 0.003)  # before the last second, as planned
