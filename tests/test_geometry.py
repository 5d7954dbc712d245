import math
import warnings

import numpy as np
import pytest

from planning.core.geometry import (
    Pose2D,
    cumulative_length,
    densify_path,
    path_length,
    path_steps,
    wrap_angle,
)


def test_wrap_angle_range_and_identity() -> None:
    a = np.linspace(-20, 20, 1001)
    w = wrap_angle(a)
    assert np.all(w >= -np.pi) and np.all(w < np.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
    assert wrap_angle(np.pi) == pytest.approx(-np.pi)
    assert isinstance(wrap_angle(0.5), float)
    # just below -pi the modulus rounded to 2 pi: +pi came back, outside [-pi, pi)
    below = np.nextafter(-np.pi, -4.0)
    assert -np.pi <= wrap_angle(below) < np.pi
    assert np.all(wrap_angle(np.array([below, below - 2 * np.pi, 3 * np.pi])) < np.pi)
    # an infinity has no direction: NaN, as NaN is, without numpy's "invalid value encountered" warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert math.isnan(wrap_angle(math.inf)) and np.isnan(wrap_angle(np.array([-np.inf, np.nan]))).all()


def test_pose_validation_and_helpers() -> None:
    p = Pose2D.from_array([1, 2, 3])
    assert p.as_array().tolist() == [1.0, 2.0, 3.0]
    assert p.distance_to(Pose2D(4, 6, 0)) == pytest.approx(5.0)
    assert Pose2D(0, 0, 3.1).heading_error_to(Pose2D(0, 0, -3.1)) == pytest.approx(2 * np.pi - 6.2)
    with pytest.raises(ValueError, match="finite"):
        Pose2D(float("nan"), 0, 0)
    with pytest.raises(ValueError, match="3 numbers"):
        Pose2D.from_array([1, 2])


# a 3-4-5 leg, a quarter turn in place, then 1 m back along -y
PATH = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0], [3.0, 4.0, np.pi / 2], [3.0, 3.0, np.pi / 2]])


def test_path_length_counts_turns_only_with_a_radius() -> None:
    assert path_length(PATH) == 6.0
    assert path_length(PATH[:, :2]) == 6.0
    assert path_length(PATH, radius=0.2) == pytest.approx(6.0 + 0.2 * np.pi / 2, abs=1e-15)
    np.testing.assert_array_equal(path_steps(PATH), [5.0, 0.0, 1.0])
    np.testing.assert_array_equal(cumulative_length(PATH), [0.0, 5.0, 5.0, 6.0])
    assert path_length(PATH[:1]) == 0.0 and path_length(np.zeros((0, 3))) == 0.0
    assert cumulative_length(PATH[:1]).tolist() == [0.0]


def test_turns_are_counted_on_unwrapped_headings() -> None:
    across = np.array([[0.0, 0.0, np.pi - 0.1], [0.0, 0.0, -np.pi + 0.1]])  # 0.2 rad across the cut
    assert path_length(across, radius=1.0) == pytest.approx(0.2, abs=1e-12)
    with pytest.raises(ValueError, match="needs \\(N, 3\\) poses"):
        path_steps(PATH[:, :2], radius=0.1)


def test_densify_path_bounds_every_step_and_keeps_the_poses() -> None:
    out = densify_path(PATH, 0.3, radius=0.2)
    steps = path_steps(out, radius=0.2)
    assert steps.max() <= 0.3 + 1e-12
    # ceil(5 / 0.3) = 17, ceil(0.2 pi/2 / 0.3) = 2, ceil(1 / 0.3) = 4 equal parts, plus the last pose
    assert out.shape == (17 + 2 + 4 + 1, 3)
    for row in PATH:
        assert np.min(np.abs(out - row).sum(axis=1)) < 1e-12
    np.testing.assert_allclose(steps[:17], 5.0 / 17, rtol=1e-12)
    assert out[0].tolist() == PATH[0].tolist() and out[-1].tolist() == PATH[-1].tolist()
    assert densify_path(PATH, 0.3).shape[0] == 17 + 1 + 4 + 1  # without a radius the turn is one step


def test_densify_path_slack_and_short_paths() -> None:
    line = np.array([[0.0, 0.0, 0.0], [3 * 0.1, 0.0, 0.0]])
    assert 3 * 0.1 / 0.1 > 3.0  # rounding makes an exact split look longer
    assert densify_path(line, 0.1).shape[0] == 5
    assert densify_path(line, 0.1, slack=1e-9).shape[0] == 4
    one = np.array([[1.0, 2.0, 3.0]])
    assert densify_path(one, 0.1) is one
    wrapped = np.array([[0.0, 0.0, np.pi - 0.1], [0.0, 0.0, -np.pi + 0.1]])
    out = densify_path(wrapped, 0.06, radius=1.0)  # 0.2 rad across the cut: 4 parts, not 2 pi - 0.2
    assert out.shape[0] == 5 and np.all(np.diff(out[:, 2]) > 0)
    with pytest.raises(ValueError, match="spacing must be > 0"):
        densify_path(line, 0.0)


def test_a_slack_and_a_clearance_out_of_range_are_refused_naming_themselves() -> None:
    """``densify_path(slack=nan)`` blamed the spacing and a negative slack was taken; ``World.is_free(clearance=-1)``
    called points inside an obstacle free, nan called every point blocked."""
    from planning.core.world import Circle, World
    from planning.errors import ConfigError

    line = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    for slack in (float("nan"), -0.1, 1.0):
        with pytest.raises(ConfigError, match=r"densify_path: slack must be a finite number in \[0, 1\)"):
            densify_path(line, 0.1, slack=slack)
    world = World((0.0, 4.0, 0.0, 4.0), (Circle((2.0, 2.0), 0.5),))
    for clearance in (-1.0, float("nan")):
        with pytest.raises(ConfigError, match=r"World.is_free: clearance must be a finite number >= 0"):
            world.is_free([[2.0, 2.0]], clearance=clearance)
    assert world.is_free([[2.0, 2.0], [0.5, 0.5]], clearance=0.1).tolist() == [False, True]


def test_wrap_angle_takes_numbers_only() -> None:
    """Its docstring said a string raises; numpy read ``"1"`` and ``True`` as 1.0."""
    from planning.errors import ConfigError

    for bad in ("1", True, np.bool_(False), None, [1.0, "a"], b"2"):
        with pytest.raises(ConfigError, match="wrap_angle takes angles in radians"):
            wrap_angle(bad)  # type: ignore[call-overload]
    assert wrap_angle(np.int64(7)) == pytest.approx(7 - 2 * np.pi) and wrap_angle(np.float32(1.0)) == 1.0
