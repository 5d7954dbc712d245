import numpy as np
import pytest

from control.diffdrive import DiffDrive
from control.open_loop import OpenLoop
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.trajectory.references import circle


def test_wheel_speeds_are_scaled_keeping_curvature() -> None:
    d = DiffDrive(0.033, 0.16, 6.67)
    left, right = d.wheel_speeds(0.5, 3.0)  # far beyond the motors
    assert max(abs(left), abs(right)) == pytest.approx(6.67)
    v, w = d.body_twist(left, right)
    assert w / v == pytest.approx(3.0 / 0.5)
    assert d.wheel_speeds(0.1, 0.2) == pytest.approx(((0.1 - 0.016) / 0.033, (0.1 + 0.016) / 0.033))


def test_commands_are_written_with_their_wheel_speeds_and_only_when_finite() -> None:
    d = DiffDrive(0.033, 0.16, 6.67)
    table = np.zeros((3, 4))
    write = d.command_writer(table)
    for v, w in [(0.1, 0.2), (0.5, 3.0), (-0.2, -1.0)]:
        assert d.command_into(table, 1, v, w) and table[1].tolist() == [v, w, *d.wheel_speeds(v, w)]
        assert write(2, v, w) and np.array_equal(table[2], table[1])
    for v, w in [(float("nan"), 0.0), (0.1, float("inf"))]:
        assert not d.command_into(table, 0, v, w) and not write(0, v, w)
    assert not table[0].any()  # a refused command writes nothing


def test_diffdrive_validates() -> None:
    with pytest.raises(ValueError, match="wheel_radius"):
        DiffDrive(0.0, 0.1, 1.0)


def test_open_loop_plays_the_reference_inputs_at_mid_period() -> None:
    robot = load_robot("turtlebot3")
    ref = circle(robot, Pose2D(0, 0, 0))
    ol = OpenLoop(robot)
    ol.reset(ref, 0.02)
    v, w = ol.command(5.0, 99.0, 99.0, 1.0)  # the pose is ignored
    row = ref.sample(5.01)
    assert (v, w) == pytest.approx((row.vel[0], row.vel[1]))
    assert np.isclose(w / v, 1.0 / 0.5, rtol=1e-6)  # on the circle omega / v = 1 / R
