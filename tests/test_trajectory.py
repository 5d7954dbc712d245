import numpy as np
import pytest

from planning.trajectory.trajectory import Trajectory


def _circle(n: int = 2001, radius: float = 2.0, w: float = 0.3) -> Trajectory:
    t = np.linspace(0, 10, n)
    xy = radius * np.column_stack([np.cos(w * t), np.sin(w * t)])
    dxy = radius * w * np.column_stack([-np.sin(w * t), np.cos(w * t)])
    ddxy = -(w**2) * xy
    return Trajectory.from_flat(t, xy, dxy, ddxy)


def test_from_flat_gives_exact_unicycle_inputs_on_a_circle() -> None:
    tr = _circle()
    np.testing.assert_allclose(tr.vel[:, 0], 0.6, atol=1e-12)  # v = R w
    np.testing.assert_allclose(tr.vel[:, 1], 0.3, atol=1e-12)  # omega = w
    np.testing.assert_allclose(tr.acc, 0.0, atol=1e-9)
    # heading is the tangent direction, unwrapped
    np.testing.assert_allclose(tr.pose[:, 2], 0.3 * tr.t + np.pi / 2, atol=1e-9)


def test_flat_derivatives_match_finite_differences() -> None:
    tr = _circle()
    dxy, ddxy = tr.flat_derivatives()
    fd = np.gradient(tr.pose[:, :2], tr.t, axis=0)
    np.testing.assert_allclose(dxy[5:-5], fd[5:-5], atol=1e-4)
    fdd = np.gradient(dxy, tr.t, axis=0)
    np.testing.assert_allclose(ddxy[5:-5], fdd[5:-5], atol=1e-4)


def test_reversing_direction_points_heading_backwards() -> None:
    t = np.linspace(0, 1, 11)
    xy = np.column_stack([-t, np.zeros_like(t)])
    tr = Trajectory.from_flat(t, xy, np.tile([-1.0, 0.0], (11, 1)), np.zeros((11, 2)), direction=-1)
    np.testing.assert_allclose(tr.pose[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(tr.vel[:, 0], -1.0)


def test_sampling_interpolates_and_clamps() -> None:
    tr = _circle(n=11)
    s = tr.sample(0.5)
    np.testing.assert_allclose(s.pose, 0.5 * (tr.pose[0] + tr.pose[1]))
    np.testing.assert_allclose(tr.sample(-5).pose, tr.pose[0])
    np.testing.assert_allclose(tr.sample(50).pose, tr.pose[-1])
    assert tr.sample_many(np.array([0.0, 1.0, 2.0])).shape == (3, 11)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"t": np.array([0.0, 1.0, 1.0])}, "strictly increasing"),
        ({"t": np.array([0.0])}, "at least 2"),
        ({"pose": np.zeros((3, 2))}, r"pose must have shape \(3, 3\)"),
        ({"vel": np.full((3, 2), np.nan)}, "non-finite"),
    ],
)
def test_bad_arrays_are_rejected_with_the_field_named(kwargs: dict, match: str) -> None:
    base = {"t": np.array([0.0, 1.0, 2.0]), "pose": np.zeros((3, 3)), "vel": np.zeros((3, 2)), "acc": np.zeros((3, 2))}
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        Trajectory(**base)


def test_arrays_are_read_only() -> None:
    tr = _circle(n=11)
    with pytest.raises(ValueError):
        tr.pose[0, 0] = 1.0
