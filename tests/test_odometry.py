"""Differential-drive odometry: arcs against the analytic circle, Jacobians against finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from control.estimation import counts_to_radians
from control.estimation.odometry import SERIES_BELOW, check_geometry, sinc_half, wheel_to_body
from planning.errors import ConfigError
from tests.reference_odometry import arc_jacobians, arc_step, integrate_arcs, integrate_wheels

R, B = 0.033, 0.160


def circle(pose0: np.ndarray, v: float, w: float, t: np.ndarray) -> np.ndarray:
    """Unicycle at constant (v, w) from pose0, in the centre-of-rotation form (not the chord form).

    Evaluated in extended precision (x87 long double, eps 1e-19), so the cancellation in
    rho (sin - sin) stays below 1e-12 m even for rho = v / w of 1e7 m.
    """
    x0, y0, th0 = (np.longdouble(c) for c in pose0)
    tt = np.asarray(t, dtype=np.longdouble)
    th = th0 + np.longdouble(w) * tt
    if w == 0.0:
        out = np.stack([x0 + v * tt * np.cos(th0), y0 + v * tt * np.sin(th0), th], axis=1)
    else:
        rho = np.longdouble(v) / np.longdouble(w)
        out = np.stack([x0 + rho * (np.sin(th) - np.sin(th0)), y0 - rho * (np.cos(th) - np.cos(th0)), th], axis=1)
    return out.astype(float)


# Wheel speeds [rad/s]: left turn, right turn, reversing arc, straight, pivot, a tiny curvature
# (dtheta per step below the series switch) and one just above it.
DRIVES = [(4.0, 6.0), (6.0, 4.0), (-3.0, -5.0), (5.0, 5.0), (-2.0, 2.0), (5.0, 5.0 + 1e-3), (5.0, 5.0 + 2.5)]


@pytest.mark.parametrize(("wl", "wr"), DRIVES)
def test_constant_wheel_speeds_trace_the_analytic_circle(wl: float, wr: float) -> None:
    dt, n = 0.02, 3000  # 60 s: several laps
    pose0 = np.array([0.3, -1.2, 2.9])
    t = np.arange(n + 1) * dt
    v, w = R * (wl + wr) / 2, R * (wr - wl) / B
    want = circle(pose0, v, w, t)
    got = integrate_wheels(pose0, np.full(n, wl * dt), np.full(n, wr * dt), R, B)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    x, y, th = pose0
    for _ in range(n):  # the scalar step, chained
        x, y, th = arc_step(x, y, th, *wheel_to_body(wl * dt, wr * dt, R, B))
    np.testing.assert_allclose((x, y, th), want[-1], rtol=0, atol=1e-9)


def test_one_arc_of_any_length_is_exact() -> None:
    pose0 = np.array([1.0, 2.0, -0.7])
    for dth in (-5.0, -1e-7, 0.0, 3e-3, 0.5, 3.0):
        want = circle(pose0, 0.8, dth, np.array([1.0]))[0]
        np.testing.assert_allclose(arc_step(*pose0, 0.8, dth), want, rtol=0, atol=1e-12)


def test_sinc_series_meets_the_closed_form_at_the_switch() -> None:
    for h in (SERIES_BELOW * (1 - 1e-12), SERIES_BELOW * (1 + 1e-12)):
        c, dc = sinc_half(2 * h)
        assert c == pytest.approx(math.sin(h) / h, rel=1e-15)
        assert dc == pytest.approx(0.5 * (h * math.cos(h) - math.sin(h)) / h**2, rel=1e-9)


@pytest.mark.parametrize("dth", [0.0, 1e-6, 0.019, 0.021, 0.4, -2.5])
def test_arc_jacobians_match_finite_differences(dth: float) -> None:
    theta, ds = 0.8, 0.05
    f, j = arc_jacobians(theta, ds, dth)
    eps = 1e-6

    def end(th: float, s: float, d: float) -> np.ndarray:
        return np.array(arc_step(0.1, 0.2, th, s, d))

    fd_theta = (end(theta + eps, ds, dth) - end(theta - eps, ds, dth)) / (2 * eps)
    fd_ds = (end(theta, ds + eps, dth) - end(theta, ds - eps, dth)) / (2 * eps)
    fd_dth = (end(theta, ds, dth + eps) - end(theta, ds, dth - eps)) / (2 * eps)
    np.testing.assert_allclose(f[:, 2], fd_theta, atol=1e-9)
    np.testing.assert_allclose(f[:, :2], np.eye(3)[:, :2], atol=0)
    np.testing.assert_allclose(j[:, 0], fd_ds, atol=1e-9)
    np.testing.assert_allclose(j[:, 1], fd_dth, atol=1e-9)


def test_counts_to_radians() -> None:
    np.testing.assert_allclose(counts_to_radians([4096, -1024, 0], 4096), [2 * math.pi, -math.pi / 2, 0.0])
    np.testing.assert_allclose(counts_to_radians(60 * 35.555, 60 * 35.555), 2 * math.pi)
    with pytest.raises(ConfigError, match="counts_per_rev"):
        counts_to_radians(3, 0)


@pytest.mark.parametrize(
    ("radius", "track", "name"), [(0.0, B, "wheel radius"), (R, -0.1, "track width"), (R, math.nan, "track width")]
)
def test_bad_geometry_raises(radius: float, track: float, name: str) -> None:
    with pytest.raises(ConfigError, match=name):
        check_geometry(radius, track)
    with pytest.raises(ConfigError, match=name):
        integrate_wheels(np.zeros(3), [0.1], [0.1], radius, track)


def test_integrate_arcs_checks_shapes_and_values() -> None:
    with pytest.raises(ConfigError, match="pose0"):
        integrate_arcs(np.zeros(2), [0.1], [0.0])
    with pytest.raises(ConfigError, match="dtheta"):
        integrate_arcs(np.zeros(3), [0.1, 0.2], [0.0])
    with pytest.raises(ConfigError, match="finite"):
        integrate_arcs(np.zeros(3), [math.inf], [0.0])
