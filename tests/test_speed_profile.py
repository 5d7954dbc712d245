"""Speed profiles against closed-form answers: trapezoids on a line, the curvature bound on a circle."""

import numpy as np
import pytest

from planning.core.robot import load_robot
from planning.trajectory.smoothing import PathSegment, SmoothCurve, fit_piecewise, smooth_drive
from planning.trajectory.speed_profile import (
    Limits,
    forward_backward,
    speed_limit,
    time_drive,
    time_rotation,
    yaw_accel_bound,
)

TB3 = load_robot("turtlebot3")
EDU = load_robot("edumip")


def line_curve(length: float) -> SmoothCurve:
    pts = np.column_stack([np.linspace(0, length, 50), np.zeros(50)])
    seg = PathSegment("drive", 1, pts, np.zeros(2))
    return smooth_drive(seg).curve


def test_limits_come_from_the_robot() -> None:
    lim = Limits.from_robot(TB3, margin=1.0)
    assert (lim.max_speed, lim.max_yaw_rate) == (0.165, 2.06)  # what its XL430s sustain (the model's comments)
    lim = Limits.from_robot(EDU, margin=1.0)
    assert (lim.max_speed, lim.max_yaw_rate) == (0.8, 0.5)


def test_forward_backward_is_the_largest_feasible_profile() -> None:
    rng = np.random.default_rng(0)
    ds = rng.uniform(0.001, 0.02, 300)
    vmax = rng.uniform(0.05, 1.0, 301)
    v = forward_backward(ds, vmax, 0.5)
    assert v[0] == 0 and v[-1] == 0 and np.all(v <= vmax + 1e-15)
    assert np.all(np.abs(np.diff(v**2)) <= 2 * 0.5 * ds * (1 + 1e-12))
    # maximal: raising any point breaks a constraint (its bound or an acceleration limit)
    for i in range(1, 300):
        tight = v[i] >= vmax[i] - 1e-12
        tight |= v[i] ** 2 >= v[i - 1] ** 2 + 2 * 0.5 * ds[i - 1] - 1e-12
        tight |= v[i] ** 2 >= v[i + 1] ** 2 + 2 * 0.5 * ds[i] - 1e-12
        assert tight


def test_a_straight_drive_takes_the_trapezoid_time() -> None:
    lim = Limits.from_robot(TB3)
    length = 1.5
    smp = time_drive(line_curve(length), lim, dt=0.005)
    v, a = lim.max_speed, lim.max_accel
    expected = 2 * v / a + (length - v * v / a) / v
    assert smp.t[-1] == pytest.approx(expected, rel=2e-3)
    assert smp.pose[-1, 0] == pytest.approx(length, abs=1e-9) and smp.vel[-1, 0] == 0.0
    assert np.max(smp.vel[:, 0]) == pytest.approx(v, rel=1e-6)
    # speed is the time derivative of position (central differences)
    dx = np.gradient(smp.pose[:, 0], smp.t)
    assert np.abs(dx[1:-1] - smp.vel[1:-1, 0]).max() < 0.003


@pytest.mark.parametrize("robot", [TB3, EDU])
def test_a_circle_is_driven_at_the_curvature_bound(robot) -> None:  # type: ignore[no-untyped-def]
    r = 0.3
    a = np.linspace(0, 1.5 * np.pi, 400)
    pts = np.column_stack([r * np.sin(a), r - r * np.cos(a)])
    u = a * r
    poly = fit_piecewise(pts, np.linspace(0, u[-1], 15), param=u, end_curvature_zero=False, penalty=0.0,
                         start_tangent=[1, 0], end_tangent=[np.cos(a[-1]), np.sin(a[-1])])  # fmt: skip
    curve = SmoothCurve.from_poly(poly, 1)
    lim = Limits.from_robot(robot)
    expected = min(lim.max_speed, np.sqrt(lim.max_accel * r), lim.max_yaw_rate * r,
                   lim.max_wheel_linear / (1 + 0.5 * lim.track_width / r))  # fmt: skip
    smp = time_drive(curve, lim)
    mid = smp.vel[smp.vel.shape[0] // 2]
    assert mid[0] == pytest.approx(expected, rel=0.01)
    assert mid[1] == pytest.approx(expected / r, rel=0.01)  # omega = v kappa
    assert np.all(np.abs(smp.vel[:, 1]) <= lim.max_yaw_rate * (1 + 1e-6))
    bound = speed_limit(np.array([1 / r]), np.zeros(1), lim)[0]
    assert bound == pytest.approx(expected)


@pytest.mark.parametrize("turn", [0.3, -2.5, 7.0])
def test_a_turn_in_place_ends_exactly_and_takes_the_trapezoid_time(turn: float) -> None:
    lim = Limits.from_robot(EDU)
    smp = time_rotation(np.array([1.0, 2.0]), 0.5, 0.5 + turn, lim, dt=0.002)
    w, al = lim.max_yaw_rate, lim.max_yaw_accel
    d = abs(turn)
    expected = 2 * w / al + (d - w * w / al) / w if d >= w * w / al else 2 * np.sqrt(d / al)
    assert smp.t[-1] == pytest.approx(expected, rel=1e-9)
    assert smp.pose[-1, 2] == pytest.approx(0.5 + turn, abs=1e-12)
    assert np.all(smp.pose[:, :2] == [1.0, 2.0]) and np.all(smp.vel[:, 0] == 0)
    assert np.abs(smp.vel[:, 1]).max() <= w + 1e-12
    # yaw rate is the derivative of heading
    dth = np.gradient(smp.pose[:, 2], smp.t)
    assert np.abs(dth[1:-1] - smp.vel[1:-1, 1]).max() < 0.01


@pytest.mark.parametrize("robot", [TB3, EDU])
def test_speeding_up_into_and_braking_out_of_a_turn_keeps_the_yaw_acceleration(robot) -> None:  # type: ignore[no-untyped-def]
    """domega/dt = v^2 dkappa/ds + kappa dv/dt: the pointwise bound keeps the first term within the limit,
    the acceleration passes the second. A drive that turns hard from rest and straightens out to stop
    reached 1.5-3 times the yaw-acceleration limit (random worlds' references) before the passes bounded
    each step's acceleration by it."""
    a = np.linspace(0, np.pi / 2, 200)
    r = 0.15 + 0.6 * (a / a[-1]) ** 2  # a spiral opening from 0.15 m: the curvature falls fast
    pts = np.column_stack([np.cumsum(r * np.cos(a)) * (a[1] - a[0]), np.cumsum(r * np.sin(a)) * (a[1] - a[0])])
    seg = PathSegment("drive", 1, pts, np.zeros(2))
    curve = smooth_drive(seg).curve
    lim = Limits.from_robot(robot)
    smp = time_drive(curve, lim, dt=0.002)
    assert np.abs(smp.acc[:, 1]).max() <= lim.max_yaw_accel * (1 + 1e-6)
    # the samples' own rate of turn: within the profile's 5 mm grid this spiral's dkappa/ds grows by up to
    # 17 % and jumps at the fit's breaks; the profile bounds each step with the curve's own dkappa/ds there
    # (measured 1.065 on the EduMIP with the grid's difference quotients, 3.1 before the passes bounded it)
    assert np.abs(np.gradient(smp.vel[:, 1], smp.t)).max() <= lim.max_yaw_accel * (1 + 1e-3)
    assert np.abs(np.diff(smp.vel[:, 1]) / np.diff(smp.t)).max() <= lim.max_yaw_accel * (1 + 1e-6)
    assert np.abs(smp.acc[:, 0]).max() <= lim.max_accel * (1 + 1e-9)
    s, _, kappa = curve.length, None, curve.geometry(np.linspace(0, curve.length, 50))[2]
    assert s > 0 and np.abs(kappa).max() > 4.0  # it does turn hard


def test_the_yaw_acceleration_bound_is_the_textbook_one() -> None:
    # speeding up where the curvature grows (same signs) leaves (alpha - v^2 dkappa) / kappa
    assert yaw_accel_bound(2.0, 3.0, 0.4, 1.0, +1) == pytest.approx((1.0 - 0.16 * 3.0) / 2.0)
    # braking there: the two terms have opposite signs, braking may use alpha + v^2 dkappa
    assert yaw_accel_bound(2.0, 3.0, 0.4, 1.0, -1) == pytest.approx((1.0 + 0.16 * 3.0) / 2.0)
    assert yaw_accel_bound(-2.0, -3.0, 0.4, 1.0, +1) == pytest.approx((1.0 - 0.16 * 3.0) / 2.0)  # mirrored
    assert yaw_accel_bound(0.0, 3.0, 0.4, 1.0, +1) == np.inf
    assert yaw_accel_bound(2.0, 10.0, 0.4, 1.0, +1) == 0.0  # the curvature's change takes it all
