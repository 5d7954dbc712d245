import numpy as np
import pytest

from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.errors import ConfigError
from planning.trajectory.references import REFERENCES, make_reference


@pytest.mark.parametrize("robot_name", ["turtlebot3", "edumip"])
@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_reference_respects_limits_and_has_exact_derivatives(robot_name: str, name: str) -> None:
    robot = load_robot(robot_name)
    start = Pose2D(0.5, -0.3, 0.7)
    tr = make_reference(name, robot, start)
    np.testing.assert_allclose(tr.pose[0], start.as_array(), atol=1e-9)
    assert np.all(np.abs(tr.vel[:, 0]) <= robot.max_speed + 1e-9)
    assert np.all(np.abs(tr.vel[:, 1]) <= robot.max_yaw_rate + 1e-9)
    assert np.all(np.abs(tr.acc[:, 0]) <= robot.max_accel + 1e-9)
    r, half = robot.wheel_radius, robot.track_width / 2
    wheel = (np.abs(tr.vel[:, 0]) + half * np.abs(tr.vel[:, 1])) / r
    assert np.all(wheel <= robot.max_wheel_speed + 1e-9)
    assert tr.vel[0, 0] == pytest.approx(0, abs=1e-12) and tr.vel[-1, 0] == pytest.approx(0, abs=1e-9)
    # exact derivatives: finite differences of the samples agree
    dxy, ddxy = tr.flat_derivatives()
    fd = np.gradient(tr.pose[:, :2], tr.t, axis=0)
    np.testing.assert_allclose(dxy[2:-2], fd[2:-2], atol=1e-5)
    fdd = np.gradient(dxy, tr.t, axis=0)
    np.testing.assert_allclose(ddxy[2:-2], fdd[2:-2], atol=2e-4)
    th = np.gradient(tr.pose[:, 2], tr.t)
    moving = np.abs(tr.vel[:, 0]) > 1e-3
    np.testing.assert_allclose(th[moving][2:-2], tr.vel[moving, 1][2:-2], atol=1e-3)


def test_closed_curves_end_where_they_start() -> None:
    robot = load_robot("turtlebot3")
    for name in ("circle", "figure8"):
        tr = make_reference(name, robot, Pose2D(1, 1, 0.3))
        np.testing.assert_allclose(tr.pose[-1, :2], [1, 1], atol=1e-9)


def test_unknown_reference_and_bad_sizes() -> None:
    robot = load_robot("turtlebot3")
    with pytest.raises(ConfigError, match="figure8"):
        make_reference("spiral", robot, Pose2D(0, 0, 0))
    with pytest.raises(ConfigError, match="radius"):
        make_reference("circle", robot, Pose2D(0, 0, 0), radius=-1.0)


@pytest.mark.parametrize(
    ("name", "options", "match"),
    [  # each of these raised TypeError, ValueError, ZeroDivisionError, OverflowError or IndexError
        ("circle", {"margin": [0.5]}, r"circle margin must be a finite number in \(0, 1\] .*, got \[0\.5\]"),
        ("circle", {"margin": 1.5}, r"circle margin must be .* in \(0, 1\] \(a fraction of the robot's limits\)"),
        ("figure8", {"size": "big"}, r"figure-eight size must be a finite number > 0, got 'big'"),
        ("circle", {"radius": float("nan")}, r"circle radius must be a finite number > 0, got nan"),
        ("circle", {"laps": 0.0}, r"circle laps must be a finite number > 0"),
        ("line", {"dt": 0.0}, r"line dt must be a finite number > 0 \(s\), got 0\.0"),
        ("line", {"dt": -0.01}, r"line dt must be a finite number > 0"),
        ("figure8", {"dt": float("inf")}, r"figure8 dt must be a finite number > 0 \(s\), got inf"),
        ("line", {"dt": 1e-12}, r"sampled every dt=1e-12 s needs .* samples \(at most 1000000\)"),
        ("circle", {"laps": 1e300}, r"samples \(at most 1000000\): give a larger dt .* or fewer laps"),
        ("line", {"laps": 2.0}, r"reference 'line': unknown option\(s\) laps; valid options: length, margin, dt"),
    ],
)
def test_bad_reference_options_raise_config_errors_naming_them(name: str, options: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        make_reference(name, load_robot("turtlebot3"), Pose2D(0, 0, 0), **options)
