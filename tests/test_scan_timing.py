"""The scan localiser's revolutions in time: whatever the control rate, a fix measured at period j is
the revolution centred on j's instant, each beam cast from the true pose of its own instant."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from control.estimation.amcl import AmclConfig
from planning.core.robot import load_robot
from planning.core.world import Box, World
from sim.physics.lidar import LidarProfile, LidarScanner, Scan
from sim.physics.model import build_model
from sim.robot.scan_localiser import LocaliserSetup, ScanLocaliser

WORLD = World((-2.0, 2.0, -1.5, 1.5), (Box((1.0, 0.5), (0.4, 0.3), 0.3),))
SPEED = np.array([0.2, 0.05, 0.3])  # the robot's constant rates [m/s, m/s, rad/s]


@pytest.mark.parametrize("rate", [25.0, 50.0, 125.0])
def test_a_fix_is_the_revolution_centred_on_its_period_at_any_control_rate(
    rate: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    """25 and 125 Hz make a revolution an odd number of control periods (5 and 25): the window of
    poses was rounded to 4 and 24 periods, so the revolution started 20 / 4 ms late and its last beams
    were cast from the pose frozen at the window's end."""
    robot = load_robot("turtlebot3")
    model = build_model(robot, WORLD).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lidar = LidarProfile()
    dt = 1.0 / rate
    loc = ScanLocaliser(model, robot, LocaliserSetup("amcl", WORLD, lidar, AmclConfig(max_particles=500)), 0,
                        t0=0.0, dt=dt, rad_per_count=2 * math.pi / 4096)  # fmt: skip
    cast: list[tuple[float, np.ndarray]] = []
    scan = LidarScanner.scan

    def spy(self: LidarScanner, d: mujoco.MjData, stamp: float, poses: np.ndarray) -> Scan:
        cast.append((stamp, poses.copy()))
        return scan(self, d, stamp, poses)

    monkeypatch.setattr(LidarScanner, "scan", spy)
    start = np.array([-0.5, -0.3, 0.1])
    truth = start + np.arange(round(1.0 * rate))[:, None] * dt * SPEED  # the true pose by period
    loc.start(data, tuple(start), (0, 0))
    j = round(0.4 * rate)  # a fix period (0.4 s: two revolutions)
    loc.mark(j, (0, 0), float(truth[j, 2]))
    loc.fix(j, data, truth, truth.copy())
    stamp, poses = cast[-1]
    assert stamp == pytest.approx(j * dt - 0.5 * lidar.period, abs=1e-12)  # half a revolution before j
    times = stamp + lidar.time_increment * np.arange(lidar.beams)
    want = start + (times[:, None] - 0.0) * SPEED  # each beam from the pose of its own instant
    np.testing.assert_allclose(poses, want, atol=1e-12)
