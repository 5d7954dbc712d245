import numpy as np
import pytest

from planning.core.geometry import Pose2D, wrap_angle


def test_wrap_angle_range_and_identity() -> None:
    a = np.linspace(-20, 20, 1001)
    w = wrap_angle(a)
    assert np.all(w >= -np.pi) and np.all(w < np.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
    assert wrap_angle(np.pi) == pytest.approx(-np.pi)
    assert isinstance(wrap_angle(0.5), float)


def test_pose_validation_and_helpers() -> None:
    p = Pose2D.from_array([1, 2, 3])
    assert p.as_array().tolist() == [1.0, 2.0, 3.0]
    assert p.distance_to(Pose2D(4, 6, 0)) == pytest.approx(5.0)
    assert Pose2D(0, 0, 3.1).heading_error_to(Pose2D(0, 0, -3.1)) == pytest.approx(2 * np.pi - 6.2)
    with pytest.raises(ValueError, match="finite"):
        Pose2D(float("nan"), 0, 0)
    with pytest.raises(ValueError, match="3 numbers"):
        Pose2D.from_array([1, 2])
