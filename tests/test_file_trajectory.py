"""A repaired file as a trajectory in a world: its clock kept or re-timed (with the reason), turns in
place kept, refused where it enters an obstacle or leaves the world, an arena around it by default."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_importer import s_curve, write_csv

from planning.collision.exact import CollisionChecker
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, World
from planning.trajectory.file_formats import TrajectoryFileError
from planning.trajectory.file_trajectory import (
    ARENA_MARGIN,
    arena_scenario,
    densify,
    file_trajectory,
    timing_verdict,
)
from planning.trajectory.from_plan import TrajectoryStatus
from planning.trajectory.importer import HEADING_TO_MOTION, TrajectoryFile, read_trajectory_file
from planning.trajectory.speed_profile import Limits

ROBOT = load_robot("turtlebot3")
LIMITS = Limits.from_robot(ROBOT)
WORLD = World((-0.5, 2.5, -0.5, 1.0))


def s_curve_file(tmp_path: Path, duration: float, step: float = 0.5, **extra: np.ndarray) -> Path:
    t = np.arange(0.0, duration + 1e-9, step)
    xy, _, _ = s_curve(t * 20.0 / duration)  # the 20 s S-curve, slowed to ``duration``
    return write_csv(tmp_path / "s.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1], **extra})


def test_a_file_within_the_limits_keeps_its_own_clock(tmp_path: Path) -> None:
    p = s_curve_file(tmp_path, 30.0)
    imp = read_trajectory_file(TrajectoryFile(p))
    res = file_trajectory(imp, ROBOT, WORLD)
    assert res.success and imp.report.retimed is False and imp.report.time_stretch == 1.0
    assert imp.report.timing == "within the robot's limits"
    traj = res.trajectory
    assert traj is not None
    t = np.arange(0.0, 30.0 + 1e-9, 0.5)
    at = traj.sample_many(t)
    np.testing.assert_allclose(at.pose[:, :2], s_curve(t * 20.0 / 30.0)[0], atol=1e-4)  # where the file is, when
    tail = traj.t > 30.0
    assert traj.duration > 30.0 and not np.any(traj.vel[tail])  # then it stands at the file's end
    end = f"end: the file's 30.00 s then {traj.duration - 30.0:.2f} s at its last position (a stand-still)"
    assert any(n.startswith(end) for n in imp.report.notes), imp.report.notes  # and says so


def test_a_file_a_little_too_fast_is_slowed_uniformly(tmp_path: Path) -> None:
    imp = read_trajectory_file(TrajectoryFile(s_curve_file(tmp_path, 20.0)))
    dense = densify(imp)
    wheel = np.abs(dense.v) + 0.5 * ROBOT.track_width * np.abs(dense.omega)  # the outer wheel's rim speed
    peak = float(np.max(wheel))
    assert LIMITS.max_wheel_linear < peak < 2.0 * LIMITS.max_wheel_linear
    res = file_trajectory(imp, ROBOT, WORLD)
    assert imp.report.retimed is False and "slowed uniformly" in imp.report.timing
    assert imp.report.time_stretch == pytest.approx(peak / LIMITS.max_wheel_linear, rel=1e-6)
    traj = res.trajectory
    assert traj is not None
    assert traj.duration == pytest.approx(20.0 * imp.report.time_stretch + 0.3, abs=0.02)  # and a final hold
    assert any(f"end: the file's {20.0 * imp.report.time_stretch:.2f} s then" in n for n in imp.report.notes)
    rim = np.abs(traj.vel[:, 0]) + 0.5 * ROBOT.track_width * np.abs(traj.vel[:, 1])
    assert np.max(rim) == pytest.approx(LIMITS.max_wheel_linear, rel=1e-6)


def test_a_file_that_starts_moving_is_retimed_from_rest_with_the_reason(tmp_path: Path) -> None:
    t = np.arange(0.0, 10.0 + 1e-9, 0.5)
    x = 0.1 * t  # 10 cm/s from the first row to the last, velocities given
    p = write_csv(
        tmp_path / "line.csv",
        {"t": t, "x": x, "y": np.zeros_like(t), "vx": np.full_like(t, 0.1), "vy": np.zeros_like(t)},
    )
    imp = read_trajectory_file(TrajectoryFile(p))
    res = file_trajectory(imp, ROBOT, WORLD)
    assert imp.report.retimed is True and "starts moving (+0.100 m/s)" in imp.report.timing
    traj = res.trajectory
    assert traj is not None
    assert traj.vel[0, 0] == 0.0 and traj.vel[-1, 0] == 0.0
    assert np.max(np.abs(np.diff(traj.vel[:, 0]) / np.diff(traj.t))) <= LIMITS.max_accel + 1e-6
    np.testing.assert_allclose(traj.pose[-1, :2], [1.0, 0.0], atol=1e-9)


def test_a_file_that_jumps_to_speed_is_retimed_naming_its_acceleration(tmp_path: Path) -> None:
    t = np.arange(0.0, 4.0 + 1e-9, 0.05)
    x = np.concatenate([[0.0, 0.0], 0.14 * 0.05 * np.arange(1, t.size - 1)])  # rest, then 14 cm/s at once
    imp = read_trajectory_file(TrajectoryFile(write_csv(tmp_path / "j.csv", {"t": t, "x": x, "y": 0 * t})))
    retime, why, _ = timing_verdict(densify(imp), LIMITS)
    assert retime and why.startswith("its acceleration reaches 2.8 m/s^2 at t = 0.0") and "limit 0.425 m/s^2" in why


def test_a_file_too_fast_to_keep_its_clock_names_where(tmp_path: Path) -> None:
    """A file with a 0.5 m sideways jump between two rows was re-timed "would slow it x61.5", not saying where:
    the reason now names its fastest sample, the jump's time."""
    t = np.round(np.arange(0.0, 4.0 + 1e-9, 0.1), 10)
    y = np.where(t >= 2.0, 0.5, 0.0)
    imp = read_trajectory_file(TrajectoryFile(write_csv(tmp_path / "j.csv", {"t": t, "x": 0.01 * t / 0.1, "y": y})))
    retime, why, _ = timing_verdict(densify(imp), LIMITS)
    assert retime and "would slow it x" in why and "its fastest: v " in why
    assert 1.9 <= float(why.split("at t = ")[1].split(" s")[0]) <= 2.0, why


@pytest.mark.parametrize("rows", [0.2, 1 / 30])
def test_a_file_moving_at_its_ends_is_retimed_saying_so_not_naming_an_acceleration_it_never_had(
    tmp_path: Path, rows: float
) -> None:
    """A steady 0.1 m/s file without velocities, cut from a longer recording: its speed meets the rest it is taken
    to start and end at within half an interval, and the reason named that as the file's acceleration ("reaches
    2 m/s^2 at t = 599.98 s"), pointing at data that never accelerated."""
    t = np.arange(0.0, 4.0 + 1e-9, rows)
    imp = read_trajectory_file(TrajectoryFile(write_csv(tmp_path / "s.csv", {"t": t, "x": 0.1 * t, "y": 0 * t})))
    retime, why, _ = timing_verdict(densify(imp), LIMITS)
    assert retime and why == (
        "it starts and ends moving (+0.100 m/s over its first rows, +0.100 m/s over its last rows), and a file "
        "without velocities is taken to start and end at rest, as the robot does"
    )


def test_a_file_moving_at_its_ends_and_too_fast_says_both(tmp_path: Path) -> None:
    """A file at 0.5 m/s (about three times the TurtleBot3's limit) that starts and ends moving was re-timed "as it
    starts moving" only: the speed it asks for is said beside it."""
    t = np.arange(0.0, 4.01, 0.5)
    p = write_csv(tmp_path / "fast.csv", {"t": t, "x": 0.5 * t, "y": 0.0 * t, "v": 0.5 + 0.0 * t})
    imp = read_trajectory_file(TrajectoryFile(p))
    retime, why, _ = timing_verdict(densify(imp), LIMITS)
    assert retime and why.startswith("it starts moving") and "too fast for the speed and yaw-rate limits (v +0.5" in why
    slow = write_csv(tmp_path / "slow.csv", {"t": t, "x": 0.02 * t, "y": 0.0 * t, "v": 0.02 + 0.0 * t})
    why = timing_verdict(densify(read_trajectory_file(TrajectoryFile(slow))), LIMITS)[1]
    assert why.startswith("it starts moving") and "too fast" not in why


def test_a_turn_in_place_in_a_timed_file_follows_its_headings(tmp_path: Path) -> None:
    t = np.array([0.0, 5.0, 10.0, 12.0, 14.0, 19.0, 24.0])
    rows = np.array(
        [
            [0, 0, 0],
            [0.5, 0, 0],
            [1, 0, 0],
            [1, 0, np.pi / 4],
            [1, 0, np.pi / 2],
            [1, 0.5, np.pi / 2],
            [1, 1, np.pi / 2],
        ]
    )
    p = write_csv(tmp_path / "turn.csv", {"t": t, "x": rows[:, 0], "y": rows[:, 1], "theta": rows[:, 2]})
    imp = read_trajectory_file(TrajectoryFile(p))
    dense = densify(imp)
    k = np.searchsorted(dense.t, [10.0, 12.0, 14.0])
    np.testing.assert_allclose(dense.pose[k, 2], [0.0, np.pi / 4, np.pi / 2], atol=1e-9)
    np.testing.assert_allclose(dense.pose[k, :2], [[1.0, 0.0]] * 3, atol=1e-9)
    res = file_trajectory(imp, ROBOT, World((-1.0, 2.0, -1.0, 2.0)))
    assert res.trajectory is not None and "rotate" in res.trajectory.segment_kinds


@pytest.mark.parametrize(
    ("x", "step"),
    [
        ([0, 0.25, 0.5, 0.75, 1.0, 0.75, 0.5, 0.25, 0], 1.0),  # out and back at 0.25 m/s, no stop at the far end
        ([0, 0.05, 0.1, 2.0, 0.2, 0.25, 0.3], 0.5),  # one row far out and back (a position fix's glitch)
    ],
    ids=["out-and-back", "outlier-row"],
)
def test_a_path_that_turns_back_without_a_stop_turns_in_place_at_the_turning_point(
    tmp_path: Path, x: list[float], step: float
) -> None:
    """A file without headings whose motion reverses without stopping: the heading flipped by pi from one sample to
    the next while the robot drove on, and re-timed, that flip was spread over the whole drive (the heading 1.3 rad
    off the motion at its far end; the poses 0.3-2.8 m from where the velocities lead, said on stderr only, the
    record clean). It stops at the turning point and turns in place there now: poses and velocities agree."""
    from planning.trajectory.from_plan import infeasibility

    t = np.arange(len(x)) * step
    p = write_csv(tmp_path / "back.csv", {"t": t, "x": np.array(x, float), "y": 0.01 * np.arange(len(x))})
    imp = read_trajectory_file(TrajectoryFile(p))
    tr = file_trajectory(imp, ROBOT, arena_scenario(imp, ROBOT).world).trajectory
    assert tr is not None and infeasibility(tr, ROBOT) == ""
    far = int(np.argmax(tr.pose[:, 0]))
    assert tr.pose[far, 0] == pytest.approx(max(x), abs=0.01)
    moving = np.abs(tr.vel[:, 0]) > 0.02  # the heading is the motion's wherever it drives
    step_xy = np.diff(tr.pose[:, :2], axis=0)
    along = np.cos(tr.pose[:-1, 2]) * step_xy[:, 0] + np.sin(tr.pose[:-1, 2]) * step_xy[:, 1]
    assert np.all(along[moving[:-1]] >= -1e-6)
    turns = [np.flatnonzero(tr.segments == k) for k, kind in enumerate(tr.segment_kinds) if kind == "rotate"]
    assert turns, tr.segment_kinds
    k = max(turns, key=lambda k: float(np.ptp(tr.pose[k, 2])))  # the largest turn: at the far end, in place
    assert np.ptp(tr.pose[k, 2]) > 2.5 and np.ptp(tr.pose[k, :2], axis=0).max() < 1e-9
    assert tr.pose[k[0], 0] == pytest.approx(max(x), abs=0.01)


def test_a_file_through_an_obstacle_is_refused_naming_time_position_and_obstacle(tmp_path: Path) -> None:
    world = World(WORLD.bounds, (Box((0.3, -0.3), (0.2, 0.2)), Circle((1.0, 0.3), 0.1)))
    imp = read_trajectory_file(TrajectoryFile(s_curve_file(tmp_path, 30.0)))
    with pytest.raises(TrajectoryFileError) as info:
        file_trajectory(imp, ROBOT, world)
    msg = str(info.value)
    assert "enters obstacle 1 (circle about (1.00, 0.30))" in msg and "--allow-collisions" in msg
    assert "offset=..., scale=..., scenario=..., allow_collisions=True from Python" in msg
    t = float(msg.split("at t = ")[1].split(" s")[0])
    x, y = (float(v) for v in msg.split("at (")[1].split(")")[0].split(", "))
    dense = densify(imp)
    k = int(np.argmin(np.abs(dense.t - t)))
    np.testing.assert_allclose(dense.pose[k, :2], [x, y], atol=1e-3)  # the position at that time
    clear = _outline_clearance(world, dense.pose[: k + 1])
    # the first touch, as far as the footprint checker sees it (a lower bound within tolerance / 2)
    assert clear[-1] <= 0.5 * CollisionChecker(world, ROBOT).tolerance + 1e-4 and clear[:-1].min() > 0.0
    allowed = read_trajectory_file(TrajectoryFile(s_curve_file(tmp_path, 30.0), allow_collisions=True))
    res = file_trajectory(allowed, ROBOT, world)
    assert res.status is TrajectoryStatus.COLLISION and res.trajectory is not None
    assert allowed.report.collisions_allowed and "run anyway" in allowed.report.world


def _outline_clearance(world: World, poses: np.ndarray) -> np.ndarray:
    """(M,) least signed distance of the footprint's outline (every edge at 60 points) at each pose [m]."""
    corners = ROBOT.footprint_at(poses)  # (M, K, 2)
    nxt = np.roll(corners, -1, axis=1)
    w = np.linspace(0.0, 1.0, 60)[None, None, :, None]
    outline = corners[:, :, None, :] + w * (nxt - corners)[:, :, None, :]
    return world.signed_distance(outline.reshape(-1, 2)).reshape(poses.shape[0], -1).min(axis=1)


def test_a_file_in_pixels_leaving_the_world_suggests_scale(tmp_path: Path) -> None:
    t = np.arange(0.0, 30.0 + 1e-9, 0.5)
    xy = s_curve(t * 20.0 / 30.0)[0] * 100.0  # centimetres
    p = write_csv(tmp_path / "px.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1]})
    with pytest.raises(
        TrajectoryFileError,
        match=r"leaves the world across the wall y = 1 at t = .*e\.g\. --scale 0\.01 \(scale=0\.01 from Python\)",
    ):
        file_trajectory(read_trajectory_file(TrajectoryFile(p)), ROBOT, WORLD)
    res = file_trajectory(read_trajectory_file(TrajectoryFile(p, scale=0.01)), ROBOT, WORLD)
    assert res.success
    with pytest.raises(TrajectoryFileError, match=r"more than the 50 m an arena is built for.*--scale 0\.01 \(scale="):
        arena_scenario(read_trajectory_file(TrajectoryFile(p, scale=1.0 / 0.3)), ROBOT)


def test_a_file_in_metres_a_little_too_large_is_not_told_it_may_be_in_pixels(tmp_path: Path) -> None:
    t = np.arange(0.0, 30.0 + 1e-9, 0.5)
    xy = s_curve(t * 20.0 / 30.0)[0] * 1.8  # 3.6 m long in a 3 m wide world: it leaves it, in metres
    p = write_csv(tmp_path / "m.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1]})
    with pytest.raises(TrajectoryFileError, match=r"leaves the world") as info:
        file_trajectory(read_trajectory_file(TrajectoryFile(p)), ROBOT, WORLD)
    assert "pixels" not in str(info.value)


def test_the_default_arena_holds_the_file_and_the_robot(tmp_path: Path) -> None:
    imp = read_trajectory_file(TrajectoryFile(s_curve_file(tmp_path, 30.0)))
    sc = arena_scenario(imp, ROBOT)
    xy = densify(imp).pose[:, :2]
    pad = ROBOT.radius + ARENA_MARGIN
    expected = (xy[:, 0].min() - pad, xy[:, 0].max() + pad, xy[:, 1].min() - pad, xy[:, 1].max() + pad)
    np.testing.assert_allclose(sc.world.bounds, expected, atol=1e-12)
    assert (sc.start.x, sc.start.y) == (0.0, 0.0) and sc.goal.x == pytest.approx(2.0)
    assert file_trajectory(imp, ROBOT, sc.world).success


def test_an_untimed_ros_path_is_timed_by_the_speed_profile(tmp_path: Path) -> None:
    u = np.linspace(0.0, 1.0, 41)
    xy = np.column_stack([2.0 * u, 0.4 * np.sin(np.pi * u)])
    d = np.gradient(xy, axis=0)
    yaw = np.arctan2(d[:, 1], d[:, 0])
    lines = ["header: {frame_id: map}", "poses:"]
    for (x, y), th in zip(xy, yaw, strict=True):
        q = f"{{x: 0.0, y: 0.0, z: {float(np.sin(th / 2))!r}, w: {float(np.cos(th / 2))!r}}}"
        lines.append(f"- pose: {{position: {{x: {float(x)!r}, y: {float(y)!r}, z: 0.0}}, orientation: {q}}}")
    p = tmp_path / "nav.yaml"
    p.write_text("\n".join(lines) + "\n")
    imp = read_trajectory_file(TrajectoryFile(p, timed=False))
    res = file_trajectory(imp, ROBOT, WORLD)
    traj = res.trajectory
    assert res.success and traj is not None and imp.report.retimed is None
    np.testing.assert_allclose(traj.pose[-1], [2.0, 0.0, yaw[-1]], atol=1e-6)
    assert np.max(np.abs(traj.vel[:, 0])) <= LIMITS.max_speed + 1e-9
    assert traj.duration > traj.path_length() / LIMITS.max_speed


def test_a_cusp_from_the_sign_of_v_drives_forwards_then_backwards(tmp_path: Path) -> None:
    """Forwards 0.6 m, then backwards along a 0.5 m arc: the speed's sign splits the drives at the cusp."""
    t1 = np.arange(0.0, 10.0 + 1e-9, 0.5)
    u = 10 * (t1 / 10) ** 3 - 15 * (t1 / 10) ** 4 + 6 * (t1 / 10) ** 5
    phi = 0.8 * u[1:]  # the second half, on the arc
    x = np.concatenate([0.6 * u, 0.6 - 0.5 * np.sin(phi)])
    y = np.concatenate([0 * u, 0.5 * (1 - np.cos(phi))])
    t = np.concatenate([t1, 10.0 + t1[1:]])
    v = np.concatenate([np.full(t1.size, 0.05), np.full(phi.size, -0.05)])  # only the sign is read here
    p = write_csv(tmp_path / "cusp.csv", {"t": t, "x": x, "y": y, "v": v})
    imp = read_trajectory_file(TrajectoryFile(p))
    assert [c.what for c in imp.report.corrections] == ["speeds v"]  # 5 cm/s is not how fast it moves
    # v changes sign over the interval after the cusp row: backwards from the cusp on, the heading never flips
    assert np.abs(np.diff(densify(imp).pose[:, 2])).max() < 0.05
    res = file_trajectory(imp, ROBOT, World((-1.0, 2.0, -1.0, 2.0)))
    traj = res.trajectory
    assert res.success and traj is not None and traj.segments is not None
    kinds = [traj.segment_kinds[k] for k in traj.segments[np.abs(traj.vel[:, 0]) > 1e-3]]
    assert kinds[0] == "forward" and kinds[-1] == "reverse" and set(kinds) == {"forward", "reverse"}
    first_back = int(np.argmax(traj.vel[:, 0] < 0.0))  # one cusp: forwards until it, backwards after it
    assert np.all(traj.vel[:first_back, 0] >= 0.0) and np.all(traj.vel[first_back:, 0] <= 0.0)
    np.testing.assert_allclose(traj.pose[-1, :2], [x[-1], y[-1]], atol=1e-9)
    np.testing.assert_allclose(traj.pose[-1, 2], -0.8, atol=1e-3)  # backing along the arc turns it clockwise


def _trapezoid_file(tmp_path: Path, share: float) -> tuple[Path, np.ndarray, np.ndarray]:
    """A straight drive at ``share`` of the acceleration limit: from rest, to 12 cm/s, on, and braking to a
    stop that falls between two rows (every 0.02 s, as nhsim's /reference is written), then standing.

    Returns:
        (file, its times (N,), its x (N,)).
    """
    a = share * LIMITS.max_accel
    ramp = 0.12 / a
    cruise = 1.0
    stop = 2 * ramp + cruise
    t = np.arange(0.0, stop + 0.5, 0.02)
    assert np.min(np.abs(t - stop)) > 0.004  # the stop is no row

    def x_at(s: np.ndarray) -> np.ndarray:
        up = np.clip(s, 0.0, ramp)
        on = np.clip(s - ramp, 0.0, cruise)
        down = np.clip(s - ramp - cruise, 0.0, ramp)
        return 0.5 * a * up**2 + 0.12 * on + 0.12 * down - 0.5 * a * down**2

    x = x_at(t)
    return write_csv(tmp_path / "trapezoid.csv", {"t": t, "x": x, "y": np.zeros_like(t)}), t, x


def test_a_file_at_the_acceleration_limit_keeps_its_clock(tmp_path: Path) -> None:
    """The rows' own accelerations are 0.999 of the limit: the clock is kept, not re-timed, slowed
    uniformly only as far as the curve through the rows needs (a C2 spline rings by about 6 % at every
    step of the acceleration: 3 % of time), and the file is where it was, when it was, on the
    slowed clock. Before, the curve was at rest a row before the stop (the braking's last 0.085 mm
    counted as standing) and braked at twice the limit over the interval before it: re-timed."""
    path, t, x = _trapezoid_file(tmp_path, 0.999)
    imp = read_trajectory_file(TrajectoryFile(path))
    dense = densify(imp)
    retime, _, stretch = timing_verdict(dense, LIMITS)
    assert not retime and 1.0 <= stretch < 1.035
    assert np.max(np.abs(np.gradient(dense.v, dense.t))) <= 1.07 * LIMITS.max_accel  # the ringing, no more
    assert np.max(np.abs(np.gradient(dense.v_rows, dense.t))) <= 0.999 * LIMITS.max_accel * (1 + 1e-9)
    res = file_trajectory(imp, ROBOT, WORLD)
    traj = res.trajectory
    assert res.success and traj is not None
    assert imp.report.retimed is False and imp.report.time_stretch == pytest.approx(stretch)
    np.testing.assert_allclose(traj.sample_many(t * stretch).pose[:, 0], x, atol=1e-9)  # where the file is, when


def test_a_file_past_the_acceleration_limit_is_still_retimed(tmp_path: Path) -> None:
    path, _, _ = _trapezoid_file(tmp_path, 1.2)
    imp = read_trajectory_file(TrajectoryFile(path))
    retime, why, _ = timing_verdict(densify(imp), LIMITS)
    assert retime and why.startswith("its acceleration reaches 0.51 m/s^2")
    res = file_trajectory(imp, ROBOT, WORLD)
    traj = res.trajectory
    assert res.success and traj is not None and imp.report.retimed is True
    assert np.max(np.abs(np.diff(traj.vel[:, 0]) / np.diff(traj.t))) <= LIMITS.max_accel + 1e-6


def test_a_files_smoothing_options_are_checked_where_they_enter(tmp_path: Path) -> None:
    """A file's trajectory takes the smoothing options to_trajectory takes, checked alike (dt=10 made a
    trajectory of a few samples; a negative max_deviation failed deep in the fit)."""
    from planning.errors import ConfigError

    imp = read_trajectory_file(TrajectoryFile(s_curve_file(tmp_path, 30.0)))
    with pytest.raises(ConfigError, match=r"^to_trajectory: dt must be a finite number in \[0\.0001, 0\.1\]"):
        file_trajectory(imp, ROBOT, WORLD, dt=10.0)
    with pytest.raises(ConfigError, match=r"^to_trajectory: max_deviation must be a finite number > 0"):
        file_trajectory(imp, ROBOT, WORLD, max_deviation=-1.0)


def test_a_recorded_robot_settling_within_the_noise_floor_stands_still(tmp_path: Path) -> None:
    """An /odom recording's settling at the goal, as nhsim's own bag has it: a rest-to-rest drive of 1 m along
    x, then 2 s of a localiser's corrections (0.2-0.6 mm every 0.2 s, any direction) and encoder ticks of
    0.025 mm back and forth. Read back, every correction was a turn (65 rad/s) and every tick a cusp: 7 cusps
    and a clock re-timed x37. Within the noise floor the robot stands."""
    rng = np.random.default_rng(3)
    t_drive = np.arange(0.0, 10.0, 0.02)
    u = t_drive / 10.0
    x_drive = 10 * u**3 - 15 * u**4 + 6 * u**5  # 1 m, at rest at both ends
    t_settle = np.arange(10.0, 12.0 + 1e-9, 0.02)
    jumps = np.zeros((t_settle.size, 2))
    every = np.arange(5, t_settle.size, 10)  # a fix every 0.2 s
    angle = rng.uniform(-np.pi, np.pi, every.size)
    size = rng.uniform(2e-4, 6e-4, every.size)
    jumps[every] = np.column_stack([size * np.cos(angle), size * np.sin(angle)])
    ticks = 2.5e-5 * rng.integers(-1, 2, t_settle.size)
    settle = np.cumsum(jumps, axis=0) + np.column_stack([ticks, np.zeros_like(ticks)])
    settle = 0.5 * (settle - settle.mean(axis=0))  # about the goal, within 1 mm
    xy = np.vstack([np.column_stack([x_drive, np.zeros_like(x_drive)]), np.array([1.0, 0.0]) + settle])
    t = np.concatenate([t_drive, t_settle])
    assert np.ptp(settle[:, 0]) < 1e-3 and np.ptp(settle[:, 1]) < 1e-3
    p = write_csv(tmp_path / "odom.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1], "theta": np.zeros_like(t)})
    dense = densify(read_trajectory_file(TrajectoryFile(p)))
    signs = np.sign(dense.v[np.abs(dense.v) > 1e-4])
    assert int(np.sum(signs[1:] != signs[:-1])) == 0  # no cusp
    assert np.all(dense.v[dense.t > 10.1] == 0.0) and np.abs(dense.omega).max() < 0.05  # no turn
    retime, why, stretch = timing_verdict(dense, LIMITS)
    assert not retime and stretch < 1.5, why  # the drive's own speed, not the settling


@pytest.mark.parametrize("rock", [0.3e-3, 1.0e-3])
def test_a_recording_that_rocks_as_it_turns_in_place_keeps_its_headings_within_the_tolerance(
    tmp_path: Path, rock: float
) -> None:
    """A balancing EduMIP's odometry read back from its own bag: it drives 1 m, then turns in place by 0.3 rad at
    its goal while it rocks fore and aft (here by +-``rock`` at 4 Hz, drifting 2 mm), its wheel speed ``v`` flipping
    sign every eighth of a second, and its position moves by a localiser's fixes. Each short rock was taken for a
    drive with the direction of its chord: the heading flipped by pi from one to the next (157 rad/s), a heading
    note said "off by 3.142 rad", and the run was re-timed to 370 times its length. Rocking goes nowhere: the
    file's headings are kept there, shifted at most by what the resolved motion about it turns them (within the
    0.1 rad a heading may be off the motion before it is noted)."""
    t_drive = np.arange(0.0, 10.0, 0.02)
    u = t_drive / 10.0
    x_drive = 10 * u**3 - 15 * u**4 + 6 * u**5  # 1 m, at rest at both ends
    t_turn = np.arange(10.0, 13.0 + 1e-9, 0.02)
    w = np.clip((t_turn - 10.0) / 2.0, 0.0, 1.0)
    th_turn = 0.3 * (0.5 - 0.5 * np.cos(np.pi * w))  # 0 -> 0.3 rad over 2 s, then still
    along = rock * np.sin(2 * np.pi * 4.0 * (t_turn - 10.0)) + 2e-3 * w  # fore and aft, and a drift
    xy_turn = np.array([1.0, 0.0]) + along[:, None] * np.column_stack([np.cos(th_turn), np.sin(th_turn)])
    rng = np.random.default_rng(7)  # and a localiser's fixes, 0.2-0.6 mm any way every 0.1 s, which v knows nothing of
    fixes = np.zeros_like(xy_turn)
    angle, size = rng.uniform(-np.pi, np.pi, fixes[::5].shape[0]), rng.uniform(2e-4, 6e-4, fixes[::5].shape[0])
    fixes[::5] = np.column_stack([size * np.cos(angle), size * np.sin(angle)])
    xy_turn += np.cumsum(fixes, axis=0) - np.cumsum(fixes, axis=0).mean(axis=0)
    t = np.concatenate([t_drive, t_turn])
    xy = np.vstack([np.column_stack([x_drive, np.zeros_like(x_drive)]), xy_turn])
    theta = np.concatenate([np.zeros_like(t_drive), th_turn])
    v = np.concatenate([np.gradient(x_drive, t_drive), np.gradient(along, t_turn)])
    p = write_csv(tmp_path / "odom.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1], "theta": theta, "v": v})
    imp = read_trajectory_file(TrajectoryFile(p))
    dense = densify(imp)
    given = np.interp(dense.t, t, theta)
    assert np.abs(dense.pose[:, 2] - given).max() < HEADING_TO_MOTION  # no flip, no turn of its own
    assert np.abs(dense.omega).max() < 2.0  # 29-95 rad/s before
    res = file_trajectory(imp, ROBOT, World((-0.5, 2.5, -1.0, 1.0)))
    assert not [f for f in imp.report.corrections if f.what == "headings theta"]
    # re-timed (it ends moving, at the rocking's speed), but not made to last what the flips made it (3.4-4.3x)
    assert res.trajectory is not None and res.trajectory.duration < 2.0 * (t[-1] - t[0])


@pytest.mark.parametrize("seed", range(5))
def test_a_recording_reversing_at_a_cusp_does_not_turn_there(tmp_path: Path, seed: int) -> None:
    """A balancing EduMIP rolls back 3 cm as it leans, turning by 0.2 rad, then drives off straight, its position
    moved by a localiser's fixes (0.2-0.6 mm every 0.1 s). Each drive's end continued its own resolved heading
    along the path, and the two met at the cusp apart: a turn at once (6-60 rad/s over these seeds). The robot
    reverses without turning, and the file's heading says so: it is kept between the cusp and the resolved motion
    on either side."""
    t1 = np.arange(0.0, 0.8, 0.02)
    u = t1 / 0.8
    s1 = -0.03 * (3 * u**2 - 2 * u**3)  # back along an arc, rest to rest
    th1 = 0.785 - 0.225 * (3 * u**2 - 2 * u**3)
    ds = np.diff(s1, prepend=0.0)
    x1, y1 = np.cumsum(ds * np.cos(th1)), np.cumsum(ds * np.sin(th1))
    t2 = np.arange(0.8, 10.8 + 1e-9, 0.02)
    w = (t2 - 0.8) / 10.0
    s2 = 10 * w**3 - 15 * w**4 + 6 * w**5  # then 1 m straight on
    t = np.concatenate([t1, t2])
    xy = np.column_stack(
        [np.concatenate([x1, x1[-1] + s2 * np.cos(0.56)]), np.concatenate([y1, y1[-1] + s2 * np.sin(0.56)])]
    )
    rng = np.random.default_rng(seed)
    fixes = np.zeros_like(xy)
    angle, size = rng.uniform(-np.pi, np.pi, fixes[::5].shape[0]), rng.uniform(2e-4, 6e-4, fixes[::5].shape[0])
    fixes[::5] = np.column_stack([size * np.cos(angle), size * np.sin(angle)])
    xy += np.cumsum(fixes, axis=0)
    theta = np.concatenate([th1, np.full_like(t2, 0.56)])
    v = np.concatenate([np.gradient(s1, t1), np.gradient(s2, t2)])
    p = write_csv(tmp_path / "odom.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1], "theta": theta, "v": v})
    dense = densify(read_trajectory_file(TrajectoryFile(p)))
    near = (dense.t > 0.5) & (dense.t < 1.2)
    assert np.abs(dense.omega[near]).max() < 3.0


def test_a_path_given_where_a_file_as_read_goes_is_read_or_named(tmp_path: Path) -> None:
    """``read_trajectory_file('ok.csv')`` raised AttributeError ('str' object has no attribute 'topic'), and
    ``file_trajectory('ok.csv', ...)`` another; a tracker's error advised ``file_trajectory(path)``."""
    from planning.errors import ConfigError

    p = s_curve_file(tmp_path, 30.0)
    as_text = read_trajectory_file(str(p))
    np.testing.assert_array_equal(as_text.xy, read_trajectory_file(TrajectoryFile(p)).xy)
    assert file_trajectory(read_trajectory_file(p), ROBOT, WORLD).trajectory is not None
    with pytest.raises(ConfigError, match=r"file_trajectory\(read_trajectory_file\(path\), robot, world\)"):
        file_trajectory(str(p), ROBOT, WORLD)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="takes a TrajectoryFile or a path, got int"):
        read_trajectory_file(3)  # type: ignore[arg-type]


@pytest.mark.parametrize("rows", [2, 121])
def test_a_file_slowing_to_a_stand_it_holds_keeps_its_clock(tmp_path: Path, rows: int) -> None:
    """A slow drive of half a metre in 10 s, then a stand of 2 s: the samples of the stand were set to rest while the
    rows' speeds fell linearly to it between the intervals' middles, a step at the stand's first sample that read as
    0.53 m/s^2 and re-timed the two rows (which brake at 0.008 m/s^2), and as 0.25 m/s^2 for 121 rows of a smooth
    drive (0.03 m/s^2 at most): a stand a little faster was re-timed too (0.59 m/s^2 read)."""
    t = np.linspace(0.0, 10.0, rows)
    u = t / 10.0
    x = 0.5 * (10 * u**3 - 15 * u**4 + 6 * u**5 if rows > 2 else u)  # a smooth drive, or two rows
    t, x = np.append(t, 12.0), np.append(x, 0.5)  # the stand
    imp = read_trajectory_file(TrajectoryFile(write_csv(tmp_path / "stand.csv", {"t": t, "x": x, "y": 0.0 * t})))
    dense = densify(imp)
    assert np.max(np.abs(np.gradient(dense.v_rows, dense.t))) < 0.1
    retime, why, stretch = timing_verdict(dense, LIMITS)
    assert not retime and stretch < 1.25, why
    res = file_trajectory(imp, ROBOT, WORLD)
    traj = res.trajectory
    assert res.success and traj is not None and imp.report.retimed is False
    assert traj.duration >= 12.0 * stretch - 1e-9  # the stand kept, on the file's clock


def test_the_fastest_sample_is_said_without_rounding_noise(tmp_path: Path) -> None:
    """A straight start's yaw rate was said as 'omega -7.08e-12 rad/s'."""
    t = np.array([0.0, 2.0, 4.0, 6.0])
    cols = {"t": t, "x": np.array([0.0, 0.5, 1.0, 1.5]), "y": np.array([0.0, 0.0, 0.2, 0.5])}
    p = write_csv(tmp_path / "head.csv", {**cols, "theta": np.array([0.0, 0.0, 0.4, 0.6])})
    retime, why, _ = timing_verdict(densify(read_trajectory_file(TrajectoryFile(p))), LIMITS)
    assert retime and "its fastest: v +0.394 m/s, omega +0.000 rad/s at t = 4.50 s" in why, why


def test_a_bad_robot_or_option_is_named_as_to_trajectory_names_it(tmp_path: Path) -> None:
    """``file_trajectory(imp, "turtlebot3", world)`` ended in AttributeError ('str' object has no attribute
    'name'), and an unknown option in a bare TypeError from make_trajectory."""
    from planning.errors import ConfigError

    imp = read_trajectory_file(TrajectoryFile(s_curve_file(tmp_path, 30.0)))
    with pytest.raises(ConfigError, match=r"file_trajectory: robot must be a RobotSpec \(load_robot\('turtlebot3'\)\)"):
        file_trajectory(imp, "turtlebot3", WORLD)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"file_trajectory: unknown option\(s\) bogus; valid options: .*margin"):
        file_trajectory(imp, ROBOT, WORLD, bogus=1)
