"""Curves through a timed file's rows: the spline where it is well-behaved (checked against scipy's
clamped spline, stretch by stretch), shape-preserving where rows far apart in time would make it ring,
the same curve from a dense slow file as from a coarse one, quintic pieces checked against scipy's
Bernstein form, and a cost linear in the rows."""

from __future__ import annotations

import itertools
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import BPoly, CubicSpline
from test_importer import DURATION, s_curve, write_csv

from planning.core.robot import load_robot
from planning.trajectory.file_trajectory import arena_scenario, densify, file_poses, file_trajectory, timing_verdict
from planning.trajectory.importer import MOVING_SPEED, TrajectoryFile, read_trajectory_file, stretch_fit
from planning.trajectory.row_curves import (
    OVERSHOOT_TOLERANCE,
    hermite_curve,
    limit_overshoot,
    spline_slopes,
    standing,
    stops,
)
from planning.trajectory.speed_profile import Limits

ROBOT = load_robot("turtlebot3")


def _overshoot(t: np.ndarray, xy: np.ndarray, curve: object, per: int = 400) -> np.ndarray:
    """(N - 1,) how far the curve leaves each interval's range of its two rows (the worse coordinate),
    found by sampling, over the interval's allowance."""
    out = np.empty(t.size - 1)
    for i in range(t.size - 1):
        p = curve(np.linspace(t[i], t[i + 1], per))  # type: ignore[operator]
        lo, hi = np.minimum(xy[i], xy[i + 1]), np.maximum(xy[i], xy[i + 1])
        out[i] = max(0.0, float(np.max(p - hi)), float(np.max(lo - p)))
        out[i] /= OVERSHOOT_TOLERANCE[0] + OVERSHOOT_TOLERANCE[1] * np.hypot(*(xy[i + 1] - xy[i]))
    return out


@pytest.mark.parametrize("last", [3000.0, 200.0])
def test_rows_far_apart_in_time_are_joined_without_overshooting_them(tmp_path: Path, last: float) -> None:
    t = np.array([0.0, 1.0, last, last + 1.0])
    x = np.array([0.0, 0.2, 0.4, 0.6])
    imp = read_trajectory_file(TrajectoryFile(write_csv(tmp_path / "far.csv", {"t": t, "x": x, "y": 0 * t})))
    assert imp.curve is not None
    tq = np.linspace(0.0, last + 1.0, 200001)
    xq = imp.curve(tq)[:, 0]
    assert xq.min() >= 0.0 and xq.max() <= 0.6 + 1e-12 and np.all(np.diff(xq) >= -1e-12)  # monotone as its rows
    arena = arena_scenario(imp, ROBOT)  # spans 0.6 m: no "give --scale"
    span = np.ptp(file_poses(imp)[:, :2], axis=0)
    assert span[0] == pytest.approx(0.6, abs=1e-9) and span[1] < 1e-9
    assert arena.world.width < 0.6 + 2 * (ROBOT.radius + 0.25) + 1e-9


def test_rows_at_random_gaps_never_overshoot_beyond_the_tolerance() -> None:
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(3, 12))
        gaps = rng.choice([0.05, 1.0, 1.8, 200.0, 3000.0], n - 1) * rng.uniform(0.5, 2.0, n - 1)
        t = np.concatenate([[0.0], np.cumsum(gaps)])
        xy = np.cumsum(rng.normal(0.0, 0.2, (n, 2)) * (rng.random((n, 1)) < 0.8), axis=0)
        assert np.all(_overshoot(t, xy, stretch_fit(t, xy)) <= 1.0 + 1e-6)


def test_a_well_sampled_smooth_motion_keeps_the_spline_unchanged() -> None:
    for t, xy in [
        (np.arange(0.0, DURATION + 1e-9, 0.5), s_curve(np.arange(0.0, DURATION + 1e-9, 0.5))[0]),
        (np.linspace(0.0, 20.0, 41), np.column_stack([np.sin(np.linspace(0, 5, 41)), np.cos(np.linspace(0, 5, 41))])),
    ]:
        m = spline_slopes(t, xy, stops(t, xy))
        np.testing.assert_array_equal(limit_overshoot(t, xy, m), m)


def test_spline_slopes_are_scipys_clamped_spline_stretch_by_stretch() -> None:
    rng = np.random.default_rng(3)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 1.8, 40))])
    xy = np.cumsum(rng.normal(0.0, 0.1, (41, 2)), axis=0)
    rest = np.array([0, 9, 10, 25, 40])
    m = spline_slopes(t, xy, rest)
    for a, b in itertools.pairwise(rest):
        ref = CubicSpline(t[a : b + 1], xy[a : b + 1], bc_type="clamped")(t[a : b + 1], 1)
        np.testing.assert_allclose(m[a : b + 1], ref, atol=1e-12)


def test_quintic_hermite_pieces_are_scipys_bernstein_form() -> None:
    rng = np.random.default_rng(5)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 1.8, 30))])
    xy, vel, acc = (rng.normal(size=(31, 2)) for _ in range(3))
    curve = hermite_curve(t, xy, vel, acc)
    tq = np.linspace(0.0, t[-1], 3001)
    for nu in range(3):
        ref = np.column_stack(
            [BPoly.from_derivatives(t, np.column_stack([xy[:, i], vel[:, i], acc[:, i]]))(tq, nu) for i in range(2)]
        )
        np.testing.assert_allclose(curve(tq, nu), ref, rtol=1e-8, atol=1e-8 * np.abs(ref).max())


def _slow_arc(tmp_path: Path, step: float, duration: float = 100.0, decimals: int = 6) -> tuple[Path, np.ndarray]:
    """A 1 m radius arc of 1 rad in ``duration`` s (100 s: 1 cm/s), rest to rest, written with ``decimals``
    decimals every ``step`` s."""
    t = np.round(np.arange(0.0, duration + 1e-9, step), 6)
    s = t / duration
    a = 10 * s**3 - 15 * s**4 + 6 * s**5
    xy = np.round(np.column_stack([0.5 + np.sin(a), 1.5 - np.cos(a)]), decimals)
    return write_csv(tmp_path / f"arc{step:g}-{duration:g}-{decimals}.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1]}), t


def test_a_dense_slow_file_is_the_same_curve_as_a_coarse_one(tmp_path: Path) -> None:
    dense_file, t = _slow_arc(tmp_path, 0.01)
    assert t.size == 10001
    dense = densify(read_trajectory_file(TrajectoryFile(dense_file)))
    coarse = densify(read_trajectory_file(TrajectoryFile(_slow_arc(tmp_path, 0.1)[0])))
    np.testing.assert_allclose(dense.t, coarse.t)
    assert np.abs(dense.pose[:, :2] - coarse.pose[:, :2]).max() < 1e-4
    # below MOVING_SPEED the robot counts as standing, and where a stand-still ends depends on the rows
    dv = np.abs(dense.v - coarse.v)
    assert dv.max() < 2 * MOVING_SPEED and np.sqrt(np.mean(dv**2)) < 1e-4
    assert dense.v.max() == pytest.approx(0.01875, rel=0.01)  # 1.875 x the mean 1 cm/s: it moves
    # headings of the motion: 1 um of rounding per 0.01 s is 0.1 mm/s of noise in the direction of a slow
    # motion, averaged over HEADING_WINDOW and HEADING_LENGTH
    moving = np.minimum(np.abs(dense.v), np.abs(coarse.v)) > 2 * MOVING_SPEED
    assert np.abs(dense.pose[moving, 2] - coarse.pose[moving, 2]).max() < 0.002


@pytest.mark.slow  # two long files simulated; 3 s
def test_a_slow_file_keeps_its_clock_dense_or_coarse(tmp_path: Path) -> None:
    """The slow arc (1 cm/s, 1.9 cm/s at most) is well within the robot's limits: every 0.01 s and every
    0.1 s its own 100 s clock is kept, and both give the same trajectory. Near its ends, where it moves at
    about MOVING_SPEED, its direction is not resolved by a few rows (a 0.1 mm chord turns by 0.01 rad with
    the file's 1 um of rounding): the heading there continues the resolved one along the path, it does not
    jerk at several rad/s^2 and have the file re-timed 12 times faster."""
    limits = Limits.from_robot(ROBOT, 0.85)
    trajectories = []
    for step in (0.01, 0.1):
        path, t = _slow_arc(tmp_path, step)
        imp = read_trajectory_file(TrajectoryFile(path))
        dense = densify(imp)
        w = np.gradient(dense.omega, dense.t)
        assert np.abs(w).max() < 0.5 * limits.max_yaw_accel, f"every {step} s: yaw acceleration {np.abs(w).max():.3g}"
        assert timing_verdict(dense, limits) == (False, "within the robot's limits", 1.0)
        res = file_trajectory(imp, ROBOT, arena_scenario(imp, ROBOT).world)
        assert res.success and res.trajectory is not None and imp.report.retimed is False
        assert imp.report.time_stretch == 1.0 and res.trajectory.duration < 101.0  # (it ends with a dwell)
        at = res.trajectory.sample_many(t)  # where the file is, when
        assert np.abs(at.pose[:, :2] - imp.xy).max() < 1e-4
        # where it moves, the heading follows the arc's tangent (1 m radius: the angle travelled) within a
        # milliradian (standing, below MOVING_SPEED in its first and last 6 s, it creeps 2.7 mm unturned)
        a = np.arctan2(dense.pose[:, 0] - 0.5, 1.5 - dense.pose[:, 1])
        moving = np.abs(dense.v) > MOVING_SPEED
        assert np.abs(dense.pose[moving, 2] - a[moving]).max() < 1e-3
        trajectories.append(res.trajectory)
    dense_t, coarse_t = trajectories
    np.testing.assert_allclose(dense_t.t, coarse_t.t)
    assert np.abs(dense_t.pose[:, :2] - coarse_t.pose[:, :2]).max() < 1e-4
    assert np.abs(dense_t.pose[:, 2] - coarse_t.pose[:, 2]).max() < 2e-3


def test_a_slow_start_hovering_about_the_moving_speed_keeps_its_clock(tmp_path: Path) -> None:
    """The same arc in 300 s, written with 5 decimals every 0.02 s: for about 25 s at each end its speed
    hovers about MOVING_SPEED (10 um of rounding per row), crossing it again and again. Those crossings
    are no stand-stills (the robot creeps on): its drive is one, not drives of tenths of a millimetre
    with turns between them (6.7 rad/s^2 of yaw acceleration, and the file was re-timed)."""
    limits = Limits.from_robot(ROBOT, 0.85)
    path, _ = _slow_arc(tmp_path, 0.02, duration=300.0, decimals=5)
    dense = densify(read_trajectory_file(TrajectoryFile(path)))
    assert timing_verdict(dense, limits) == (False, "within the robot's limits", 1.0)
    a = np.arctan2(dense.pose[:, 0] - 0.5, 1.5 - dense.pose[:, 1])
    # at the ends it stands (a third of MOVING_SPEED on average) and creeps 2 cm (0.02 rad) unturned
    inner = (a > 0.03) & (a < 0.97)
    assert np.abs(dense.pose[inner, 2] - a[inner]).max() < 0.005


def test_standing_needs_a_small_step_and_a_small_speed() -> None:
    t = np.array([0.0, 0.01, 0.02, 1.02, 2.02])
    xy = np.array([[0.0, 0.0], [1e-4, 0.0], [1e-4, 0.0], [1.5e-4, 0.0], [1.0, 0.0]])
    np.testing.assert_array_equal(standing(t, xy), [False, True, True, False])  # 1 cm/s moves; 0.05 mm/s stands


def _walk(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A 100 Hz log of a wandering robot with noise: thousands of stops (sharp corners) and stand-stills."""
    rng = np.random.default_rng(n)
    t = np.arange(n) * 0.01
    xy = np.cumsum(rng.normal(0.0, 1e-3, (n, 2)), axis=0)
    xy[rng.random(n) < 0.1] = np.nan
    xy = np.where(np.isnan(xy), np.roll(xy, 1, axis=0), xy)  # repeated rows: stand-stills
    return t, np.nan_to_num(xy)


def test_the_cost_of_a_file_grows_linearly_with_its_rows(tmp_path: Path) -> None:
    files = {}
    for n in (10_000, 80_000):
        t, xy = _walk(n)
        files[n] = tmp_path / f"w{n}.csv"
        np.savetxt(files[n], np.column_stack([t, xy]), delimiter=",", header="t,x,y", comments="", fmt="%.6f")
    best = dict.fromkeys(files, np.inf)
    for _ in range(3):  # interleaved, best of three: a loaded machine slows both alike
        for n, p in files.items():
            start = time.perf_counter()
            imp = read_trajectory_file(TrajectoryFile(p))
            assert imp.curve is not None
            imp.curve(np.linspace(0.0, float(imp.t[-1]), n))  # type: ignore[index]
            best[n] = min(best[n], time.perf_counter() - start)
    ratio = best[80_000] / best[10_000]
    assert ratio < 8 * 3, f"8x the rows cost {ratio:.1f}x the time (linear: 8x; quadratic: 64x)"
    assert imp.curve.poly.x.size == imp.t.size  # type: ignore[union-attr]  # one polynomial, rows as breaks


def test_a_stop_is_where_the_braking_ends_not_where_its_steps_turn_short() -> None:
    """Rows every 0.02 s of a braking at 0.425 m/s^2 to a stop between two rows, a stand-still, and a start
    again: the braking's last step (0.085 mm) and the start's first are shorter than SAME_POSITION, so
    the stand-still's intervals begin one row early and end one row late; the curve's stops are the rows
    where the motion has ended and where it begins (on the stand-still rows themselves, 1e-9 apart), and
    its deceleration stays near the rows' (1.27 m/s^2 with the stop a row early)."""
    a, v0, dt = 0.425, 0.12, 0.02
    t = np.arange(0.0, 1.2, dt)
    brake = v0 / a  # 0.2824 s: between the rows 0.28 and 0.30
    s = np.minimum(t, brake)
    x = v0 * s - 0.5 * a * s**2
    restart = 0.8  # and off again from rest, on a row
    u = np.clip(t - restart, 0.0, None)
    x = x + 0.5 * a * u**2
    xy = np.column_stack([x, np.zeros_like(x)])
    step = np.diff(x)
    stand = standing(t, xy)
    first, last = int(np.argmax(stand)), int(len(stand) - 1 - np.argmax(stand[::-1]))
    assert 0 < step[first] < 1e-4 and 0 < step[last] < 1e-4  # the short steps inside the stand-still
    rest = stops(t, xy)
    # the stand-still's intervals are first..last: its stops were rows first and last + 1
    assert first + 1 in rest and first not in rest  # on to where the braking has ended
    assert last in rest and last + 1 not in rest  # back to where the start begins
    accel = stretch_fit(t, xy)(np.linspace(0.16, 1.1, 4701), 2)[:, 0]  # past the start's own stop (it rolls)
    assert np.max(np.abs(accel)) < 1.1 * a
