"""The yaw acceleration a timed reference's own samples show stays within the limit its speed profile aims at.

``domega/dt = v^2 dkappa/ds + kappa dv/dt`` is bounded on the profile's grid; the samples between two grid
points see the curve's own curvature. A plan's curvature (``optim``: linear between its samples, kinked at
each, steep where the plan is slow) and a fit's (kinked at its breaks) change faster there than the grid's
difference quotients say, and a heading interpolated linearly between a plan's samples turns in a
staircase around the curvature: random worlds' ``optim`` references reached 1.4 times the robot's yaw
acceleration in their yaw-rate column, 1.6 times in their headings, while their ``acc`` column said 0.85.
"""

import numpy as np
import pytest

from planning.core.robot import load_robot
from planning.trajectory.smoothing import SampledCurve
from planning.trajectory.speed_profile import Limits, time_drive

TB3 = load_robot("turtlebot3")
EDU = load_robot("edumip")


def sample_yaw_accel(t: np.ndarray, vel: np.ndarray, pose: np.ndarray) -> tuple[float, float, float]:
    """The largest |domega/dt| [rad/s^2] of samples: the yaw-rate column differenced between consecutive
    samples, the heading differenced twice between them, and over five of them."""
    column = np.abs(np.diff(vel[:, 1]) / np.diff(t)).max()
    w = np.diff(np.unwrap(pose[:, 2])) / np.diff(t)
    tm = 0.5 * (t[1:] + t[:-1])
    heading = np.abs(np.diff(w) / np.diff(tm)).max()
    heading5 = np.abs((w[5:] - w[:-5]) / (tm[5:] - tm[:-5])).max()
    return float(column), float(heading), float(heading5)


def held_input_plan(rng: np.random.Generator, steps: int = 30) -> np.ndarray:
    """Poses every 10 ms of a drive whose speed and rate of steering are held over 0.2 s intervals (the way
    ``optim`` rolls its plans out): the curvature is linear between samples, its slope steps at each node,
    steeply where the speed is low. Integrated finely, so the poses are exact to rounding."""
    v = rng.uniform(0.01, 0.12, steps)
    rate = rng.choice([-1.0, 1.0], steps) * rng.uniform(2.0, 6.0, steps)  # dkappa/dt [1/(m s)]
    fine = 100  # substeps per 10 ms
    n = steps * 20 * fine
    h = 0.01 / fine
    node = np.arange(n) // (20 * fine)
    kappa = np.concatenate([[0.0], np.cumsum(rate[node] * h)])
    kappa = np.clip(kappa, -6.0, 6.0)
    ds = v[node] * h
    th = np.concatenate([[0.0], np.cumsum(0.5 * (kappa[1:] + kappa[:-1]) * ds)])
    x = np.concatenate([[0.0], np.cumsum(np.cos(0.5 * (th[1:] + th[:-1])) * ds)])
    y = np.concatenate([[0.0], np.cumsum(np.sin(0.5 * (th[1:] + th[:-1])) * ds)])
    return np.column_stack([x, y, th])[::fine]


@pytest.mark.parametrize("robot", [TB3, EDU])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_retimed_plan_turns_within_the_yaw_acceleration_between_the_grid_points(robot, seed) -> None:  # type: ignore[no-untyped-def]
    poses = held_input_plan(np.random.default_rng(seed))
    curve = SampledCurve.from_poses(poses, 1)
    lim = Limits.from_robot(robot)
    smp = time_drive(curve, lim)
    column, heading, heading5 = sample_yaw_accel(smp.t, smp.vel, smp.pose)
    assert column <= lim.max_yaw_accel * (1 + 1e-6)
    assert heading5 <= lim.max_yaw_accel * (1 + 1e-3)
    assert heading <= lim.max_yaw_accel * (1 + 1e-2)  # a second difference of 10 ms samples
    assert np.abs(smp.acc[:, 1]).max() <= lim.max_yaw_accel * (1 + 1e-6)
    # the yaw rate is the heading's: omega = v kappa of the same curve
    w = np.diff(np.unwrap(smp.pose[:, 2])) / np.diff(smp.t)
    assert np.abs(w - 0.5 * (smp.vel[1:, 1] + smp.vel[:-1, 1])).max() < 0.01 * robot.max_yaw_rate
    # the plan's own path: its poses at its samples, and its heading to well below a milliradian
    xy, tangent, _ = curve.geometry(curve.s_table)
    assert np.allclose(xy, poses[:, :2], atol=1e-12)
    assert np.abs(np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0])) - poses[:, 2]).max() < 2e-4


def test_random3021_turtlebot3_optim_keeps_the_yaw_acceleration() -> None:
    """The reference of ``nhsim simulate --scenario random3021 --robot turtlebot3 --planner optim``: its
    yaw-rate column stepped at 5.64 rad/s^2 at 1.33 s (v = 0.078 m/s; the TurtleBot3's limit is 4, the
    profile's 3.4), where the plan's curvature fell at 790 /m^2 right after a node the grid saw as 620."""
    from sim import PlanOptions
    from sim.pipeline.case import Case, prepare_trajectory

    traj = prepare_trajectory(
        Case("random3021", robot="turtlebot3", planner="optim", planning=PlanOptions(time_limit=10))
    ).trajectory
    aim = Limits.from_robot(TB3).max_yaw_accel
    assert "forward" in traj.segment_kinds
    column, heading, heading5 = sample_yaw_accel(traj.t, traj.vel, traj.pose)
    assert column <= aim * (1 + 1e-6)
    assert heading5 <= aim * (1 + 1e-3)
    assert heading <= aim * (1 + 1e-2)
    assert np.abs(traj.acc[:, 1]).max() <= aim * (1 + 1e-6)
