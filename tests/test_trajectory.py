import re

import numpy as np
import pytest

from planning.errors import ConfigError
from planning.trajectory.trajectory import SAMPLE_FIELDS, Trajectory


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
    # the trajectory's own, read-only: every later sample is built from them (an edit tripled the flat velocity)
    for array in (dxy, ddxy):
        with pytest.raises(ValueError, match="read-only"):
            array *= 3.0


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


def test_sample_many_names_every_quantity() -> None:
    t = np.array([0.0, 1.0, 2.0, 4.0])
    pose = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.2], [2.0, 1.5, 0.6], [2.5, 2.0, 1.0]])
    vel = np.array([[0.0, 0.1], [1.0, 0.3], [0.8, -0.2], [0.0, 0.0]])
    acc = np.array([[1.0, 0.2], [0.4, 0.1], [-0.6, -0.3], [-0.4, 0.1]])
    tr = Trajectory(t, pose, vel, acc)
    c, sn, v, w, dv = np.cos(pose[:, 2]), np.sin(pose[:, 2]), vel[:, 0], vel[:, 1], acc[:, 0]
    dxy = np.column_stack([v * c, v * sn])  # the flat outputs' derivatives of a unicycle
    ddxy = np.column_stack([dv * c - v * w * sn, dv * sn + v * w * c])
    # at the samples, halfway between two and a quarter of the way, and clamped outside the span
    times = np.array([1.0, 1.5, 2.5, -1.0, 9.0])
    k0, k1, a = np.array([1, 1, 2, 0, 3]), np.array([1, 2, 3, 0, 3]), np.array([0.0, 0.5, 0.25, 0.0, 0.0])
    s = tr.sample_many(times)
    assert len(s) == 5 and np.array_equal(s.t, times)
    expected = {
        "x": pose[:, 0],
        "y": pose[:, 1],
        "theta": pose[:, 2],
        "v": vel[:, 0],
        "omega": vel[:, 1],
        "dv": acc[:, 0],
        "domega": acc[:, 1],
        "dx": dxy[:, 0],
        "dy": dxy[:, 1],
        "ddx": ddxy[:, 0],
        "ddy": ddxy[:, 1],
    }
    assert tuple(expected) == SAMPLE_FIELDS
    for name, col in expected.items():
        np.testing.assert_allclose(getattr(s, name), (1 - a) * col[k0] + a * col[k1], rtol=0, atol=1e-12, err_msg=name)
        with pytest.raises(ValueError):
            getattr(s, name)[0] = 0.0  # read-only
    np.testing.assert_array_equal(s.pose, np.column_stack([s.x, s.y, s.theta]))
    np.testing.assert_array_equal(s.vel, np.column_stack([s.v, s.omega]))
    np.testing.assert_array_equal(s.flat_acc, np.column_stack([s.ddx, s.ddy]))
    one = tr.sample(2.5)
    assert one.t == 2.5
    for got, want in [
        (one.pose, s.pose[2]),
        (one.vel, s.vel[2]),
        (one.acc, [s.dv[2], s.domega[2]]),
        (one.flat_vel, s.flat_vel[2]),
        (one.flat_acc, s.flat_acc[2]),
    ]:
        np.testing.assert_array_equal(got, want)
    with pytest.raises(ValueError, match="1-D"):
        tr.sample_many(1.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"t": np.array([0.0, 1.0, 1.0])}, "strictly increasing"),
        ({"t": np.array([0.0])}, "at least 2"),
        ({"pose": np.zeros((3, 2))}, r"pose must have shape \(3, 3\)"),
        ({"vel": np.full((3, 2), np.nan)}, "non-finite"),
        ({"t": np.array([-1e308, 0.0, 1e308])}, "a duration too long to be a number"),  # trackers overflowed
    ],
)
def test_bad_arrays_are_rejected_with_the_field_named(kwargs: dict, match: str) -> None:
    base = {"t": np.array([0.0, 1.0, 2.0]), "pose": np.zeros((3, 3)), "vel": np.zeros((3, 2)), "acc": np.zeros((3, 2))}
    base.update(kwargs)
    with pytest.raises(ConfigError, match=match):
        Trajectory(**base)


def test_arrays_are_read_only() -> None:
    tr = _circle(n=11)
    with pytest.raises(ValueError):
        tr.pose[0, 0] = 1.0


@pytest.mark.parametrize(
    ("status", "advice"),
    [("timeout", "try another seed, more of the budget the reason says ran out (a longer --time-limit"),
     ("invalid_start", "move the start into free space"),
     ("invalid_goal", "move the goal into free space"), ("infeasible", "widen the way to the goal")],
)  # fmt: skip
def test_a_failed_plan_names_what_to_try_for_its_status(status, advice):
    from planning.core.robot import load_robot
    from planning.core.world import World
    from planning.planners.base import PlanResult, PlanStatus
    from planning.trajectory.from_plan import PlanFailedError, checked_trajectory

    failed = PlanResult(PlanStatus(status), "birrt", reason="why")
    message = rf"status {status}: why; a failed plan has no trajectory \({re.escape(advice)}"
    with pytest.raises(PlanFailedError, match=message) as err:
        checked_trajectory(failed, load_robot("turtlebot3"), World((0.0, 1.0, 0.0, 1.0), ()))
    assert (status == "timeout") == ("another seed" in str(err.value))
