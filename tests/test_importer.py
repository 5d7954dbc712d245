"""Trajectory files in metres and seconds, repaired where safe and refused where not: each repair checked
against the motion the file was written from (a rest-to-rest quintic S-curve, known in closed form)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from planning.trajectory.file_formats import TrajectoryFileError, table_from_arrays
from planning.trajectory.importer import (
    DISPLACEMENT_TOLERANCE,
    HEADING_TOLERANCE,
    TrajectoryFile,
    import_table,
    parse_columns,
    parse_offset,
    read_trajectory_file,
    stretch_fit,
)

DURATION = 20.0


def s_curve(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (N, 2) [m], velocities and accelerations of a rest-to-rest quintic S-curve, 2 m long."""
    s = t / DURATION
    u = 10 * s**3 - 15 * s**4 + 6 * s**5
    du = (30 * s**2 - 60 * s**3 + 30 * s**4) / DURATION
    ddu = (60 * s - 180 * s**2 + 120 * s**3) / DURATION**2
    xy = np.column_stack([2 * u, 0.4 * np.sin(np.pi * u)])
    vel = np.column_stack([2 * du, 0.4 * np.pi * np.cos(np.pi * u) * du])
    acc = np.column_stack([2 * ddu, 0.4 * np.pi * (np.cos(np.pi * u) * ddu - np.pi * np.sin(np.pi * u) * du**2)])
    return xy, vel, acc


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    names = list(columns)
    n_rows = len(columns[names[0]])
    rows = [",".join(names)] + [",".join(repr(float(columns[n][i])) for n in names) for i in range(n_rows)]
    path.write_text("\n".join(rows) + "\n")
    return path


def quintic_file(tmp_path: Path, step: float = 0.5, **extra: np.ndarray) -> tuple[Path, np.ndarray]:
    t = np.arange(0.0, DURATION + 1e-9, step)
    xy, _, _ = s_curve(t)
    return write_csv(tmp_path / "q.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1], **extra}), t


def test_the_positions_own_fit_reproduces_a_rest_to_rest_motion_from_coarse_samples() -> None:
    t = np.arange(0.0, DURATION + 1e-9, 0.5)
    fit = stretch_fit(t, s_curve(t)[0])
    tq = np.linspace(0.0, DURATION, 4001)
    xy, vel, _ = s_curve(tq)
    assert np.abs(fit(tq) - xy).max() < 1e-5  # 10 micrometres from samples 0.5 s (up to 7 cm) apart
    assert np.abs(fit(tq, 1) - vel).max() < 1e-4
    np.testing.assert_allclose(fit(np.array([0.0, DURATION]), 1), 0.0, atol=1e-12)  # at rest at both ends


def test_scale_time_scale_and_offset_move_positions_and_derivatives(tmp_path: Path) -> None:
    t = np.arange(0.0, DURATION + 1e-9, 1.0)
    xy, vel, _ = s_curve(t)
    # the file in centimetres and tenths of a second, in a frame turned by -pi/2 from the world's
    p = write_csv(
        tmp_path / "cm.csv",
        {"t": 10 * t, "x": 100 * xy[:, 0], "y": 100 * xy[:, 1], "vx": 10 * vel[:, 0], "vy": 10 * vel[:, 1]},
    )
    imp = read_trajectory_file(TrajectoryFile(p, scale=0.01, time_scale=0.1, offset=(1.0, -2.0, np.pi / 2)))
    rot = np.array([[0.0, -1.0], [1.0, 0.0]])
    np.testing.assert_allclose(imp.t, t, atol=1e-12)
    np.testing.assert_allclose(imp.xy, xy @ rot.T + (1.0, -2.0), atol=1e-12)
    assert imp.curve is not None and not imp.report.corrections  # the velocities agree: kept as given
    np.testing.assert_allclose(imp.curve(t, 1), vel @ rot.T, atol=1e-12)


def test_repeated_stamps_at_one_position_merge_and_say_so(tmp_path: Path) -> None:
    t = np.arange(0.0, DURATION + 1e-9, 1.0)
    xy, vel, _ = s_curve(t)
    k = np.array([5, 12])  # pieces meet here: same stamp, same position, velocities differing by 1 cm/s
    tt, pp, vv = (np.insert(a, k + 1, a[k], axis=0) for a in (t, xy, vel))
    dup = k + 1 + np.arange(k.size)  # where the repeated rows landed
    vv[dup] += 0.01
    vv[dup - 1] -= 0.01  # the first row of each pair, 1 cm/s the other way: their mean is the motion's
    p = write_csv(tmp_path / "r.csv", {"t": tt, "x": pp[:, 0], "y": pp[:, 1], "vx": vv[:, 0], "vy": vv[:, 1]})
    imp = read_trajectory_file(TrajectoryFile(p))
    assert imp.report.rows_read == t.size + 2 and imp.report.rows_merged == 2
    assert "line 7 -> line 8" in imp.report.notes[0] and "line 15 -> line 16" in imp.report.notes[0]
    np.testing.assert_allclose(imp.t, t)
    assert imp.curve is not None
    np.testing.assert_allclose(imp.curve(t, 1), vel, atol=1e-12)


@pytest.mark.parametrize(
    ("t", "needles"),
    [
        ([0.0, 1.0, 1.0, 2.0], ["line 3 -> line 4", "t = 1 s", "--path (timed=False from Python)"]),
        ([0.0, 1.0, 0.5, 2.0], ["line 3 -> line 4", "goes back"]),
    ],
)
def test_stamps_repeated_at_two_positions_or_going_back_are_errors_naming_the_rows(
    tmp_path: Path, t: list[float], needles: list[str]
) -> None:
    p = write_csv(tmp_path / "bad.csv", {"t": np.array(t), "x": np.array([0.0, 0.1, 0.2, 0.3]), "y": np.zeros(4)})
    with pytest.raises(TrajectoryFileError) as info:
        read_trajectory_file(TrajectoryFile(p))
    for needle in needles:
        assert needle in str(info.value), str(info.value)


@pytest.mark.parametrize(
    ("columns", "timed", "needle"),
    [
        ({"t": [0.0, 1.0], "x": [0.0, 1.0]}, True, "no column y"),
        ({"t": [0.0, 1.0], "y": [0.0, 1.0]}, True, "no column x"),
        ({"x": [0.0, 1.0], "y": [0.0, 1.0]}, True, r"use --path \(timed=False from Python\)"),
        ({"t": [0.0, 1.0, 2.0], "x": [0.5, 0.5, 0.5], "y": [1.0, 1.0, 1.0]}, True, "two distinct positions"),
        ({"x": [0.5, 0.5], "y": [1.0, 1.0]}, False, "two distinct positions"),
        ({"t": [0.0, 1.0], "x": [0.0, 1.0], "y": [0.0, 1.0], "vx": [0.0, 0.0]}, True, "vx and vy come together"),
        ({"t": [0.0, 36000.0], "x": [0.0, 1.0], "y": [0.0, 1.0]}, True, "--time-scale 0.001"),
        (
            {"t": [0.0, 2e10], "x": [0.0, 1.0], "y": [0.0, 1.0]},
            True,
            r"nanoseconds, .* --time-scale 1e-09 \(time_scale=1e-09 from Python\)",
        ),
        # 0.1 mm/s all along: a clock in ms read as seconds (tracked, the closed loop ended 11 cm and 2.1 rad off)
        ({"t": [0.0, 1000.0, 2000.0], "x": [0.0, 0.1, 0.2], "y": [0.0] * 3}, True, "counts as standing.*0.001"),
    ],
)
def test_missing_columns_and_a_single_position_are_errors(
    tmp_path: Path, columns: dict[str, list[float]], timed: bool, needle: str
) -> None:
    p = write_csv(tmp_path / "m.csv", {k: np.array(v) for k, v in columns.items()})
    with pytest.raises(TrajectoryFileError, match=needle):
        read_trajectory_file(TrajectoryFile(p, timed=timed))


@pytest.mark.parametrize(
    ("scale", "offset"), [(1e300, (0.0, 0.0, 0.0)), (None, (1e300, 0.0, 0.0)), (1e10, (0.0, 0.0, 0.0))]
)
def test_positions_scaled_or_moved_out_of_reach_are_refused_without_overflowing(
    tmp_path: Path, scale: float | None, offset: tuple[float, float, float]
) -> None:
    p = write_csv(tmp_path / "a.csv", {"t": np.array([0.0, 1.0]), "x": np.array([0.0, 1.0]), "y": np.zeros(2)})
    with np.errstate(all="raise"), pytest.raises(TrajectoryFileError, match=r"positions reach .* more than 1e\+09 m"):
        read_trajectory_file(TrajectoryFile(p, scale=scale, offset=offset))


def test_a_clock_scaled_too_little_is_told_the_scale_that_fits(tmp_path: Path) -> None:
    p = write_csv(tmp_path / "ns.csv", {"t": np.array([0.0, 2e10]), "x": np.array([0.0, 1.0]), "y": np.zeros(2)})
    with pytest.raises(
        TrajectoryFileError,
        match=r"2e\+07 s at --time-scale 0\.001 \(time_scale=0\.001 from Python\).*\(time_scale=1e-09 from Python\)",
    ):
        read_trajectory_file(TrajectoryFile(p, time_scale=0.001))
    assert read_trajectory_file(TrajectoryFile(p, time_scale=1e-9)).t[-1] == pytest.approx(20.0)


@pytest.mark.parametrize("timed", [False, True])
def test_headings_in_degrees_are_refused_and_unwrapped_radians_beyond_a_turn_are_not(
    tmp_path: Path, timed: bool
) -> None:
    t = np.linspace(0.0, 40.0, 81)
    ang = 2.0 * np.pi * 1.75 * (10 * (t / 40) ** 3 - 15 * (t / 40) ** 4 + 6 * (t / 40) ** 5)
    x, y = np.sin(ang), 1.0 - np.cos(ang)
    cols = {"t": t, "x": x, "y": y}
    imp = read_trajectory_file(TrajectoryFile(write_csv(tmp_path / "rad.csv", {**cols, "theta": ang}), timed=timed))
    assert imp.theta is not None and imp.theta.max() == pytest.approx(3.5 * np.pi)  # 1.75 turns, as written
    deg = write_csv(tmp_path / "deg.csv", {**cols, "theta": np.degrees(ang)})
    with pytest.raises(TrajectoryFileError, match=r"column theta looks like degrees \(630 at line 82;.*in radians"):
        read_trajectory_file(TrajectoryFile(deg, timed=timed))


def _line_file(tmp_path: Path, name: str, direction: float, theta: np.ndarray | float, back: bool = False) -> Path:
    """2 m along ``direction`` [rad] in 21 rows 0.5 s apart (and back again with ``back``), headings ``theta``."""
    s = np.linspace(0.0, 2.0, 21)
    s = np.concatenate([s, s[-2::-1]]) if back else s
    t = 0.5 * np.arange(s.size)
    cols = {"t": t, "x": np.round(s * np.cos(direction), 6), "y": np.round(s * np.sin(direction), 6)}
    return write_csv(tmp_path / name, {**cols, "theta": np.broadcast_to(theta, t.shape).astype(float)})


@pytest.mark.parametrize("timed", [False, True])
def test_headings_in_degrees_within_two_pi_are_refused_and_radians_near_the_x_axis_are_not(
    tmp_path: Path, timed: bool
) -> None:
    # a gentle 2 m curve, heading 0..5 (degrees): read as radians it had 2 cusps and was re-timed x91
    t = np.linspace(0.0, 10.0, 21)
    heading = np.radians(np.linspace(0.0, 5.0, 21))
    x = np.concatenate([[0.0], np.cumsum(0.1 * np.cos(0.5 * (heading[1:] + heading[:-1])))])
    y = np.concatenate([[0.0], np.cumsum(0.1 * np.sin(0.5 * (heading[1:] + heading[:-1])))])
    curve = {"t": t, "x": np.round(x, 6), "y": np.round(y, 6)}
    refused = {
        "curve": write_csv(tmp_path / "curve.csv", {**curve, "theta": np.degrees(heading)}),
        "straight at 3 degrees": _line_file(tmp_path, "line.csv", np.radians(3.0), 3.0),  # was driven in reverse
        "out and back": _line_file(tmp_path, "back.csv", np.radians(3.0), 3.0, back=True),
    }
    for p in refused.values():
        with pytest.raises(TrajectoryFileError, match=r"column theta looks like degrees \(.*all within 2 pi;.*radians"):
            read_trajectory_file(TrajectoryFile(p, timed=timed))
    kept = {
        "the curve in radians": write_csv(tmp_path / "curve_rad.csv", {**curve, "theta": heading}),
        "heading 3 rad, backwards": _line_file(tmp_path, "rev.csv", 3.0 - np.pi, 3.0),
        "heading pi, back and forth": _line_file(tmp_path, "revb.csv", 0.0, np.pi, back=True),
        "radians biased 0.2 rad": _line_file(tmp_path, "bias.csv", 0.0, 0.2),  # replaced, not taken for degrees
    }
    for name, p in kept.items():
        imp = read_trajectory_file(TrajectoryFile(p, timed=timed))
        assert imp.theta is not None, name
        if name != "radians biased 0.2 rad":
            assert not imp.report.corrections, name


def test_wrapped_headings_are_unwrapped(tmp_path: Path) -> None:
    t = np.linspace(0.0, 40.0, 81)
    s = t / 40.0
    ang = 2.0 * np.pi * 1.75 * (10 * s**3 - 15 * s**4 + 6 * s**5)  # 1.75 turns of a circle: through pi and 3 pi
    x, y = np.sin(ang), 1.0 - np.cos(ang)
    theta = np.arctan2(np.sin(ang), np.cos(ang))  # heading = angle on the circle, wrapped into (-pi, pi]
    imp = read_trajectory_file(TrajectoryFile(write_csv(tmp_path / "c.csv", {"t": t, "x": x, "y": y, "theta": theta})))
    assert imp.report.headings_unwrapped == 2
    assert imp.theta is not None
    np.testing.assert_allclose(imp.theta, ang, atol=1e-12)
    assert not imp.report.corrections  # the headings follow the motion


def test_velocities_in_the_wrong_units_are_replaced_by_the_positions_own(tmp_path: Path) -> None:
    t = np.arange(0.0, DURATION + 1e-9, 0.5)
    _, vel, _ = s_curve(t)
    p, _ = quintic_file(tmp_path, vx=100 * vel[:, 0], vy=100 * vel[:, 1])  # cm/s in a file in metres
    imp = read_trajectory_file(TrajectoryFile(p))
    assert imp.curve is not None
    np.testing.assert_allclose(imp.curve(t, 1), vel, atol=1e-4)  # the positions' own (the fit above)
    (fix,) = imp.report.corrections
    k = int(np.argmax(np.hypot(*vel.T)))
    assert fix.row == f"line {k + 2}" and fix.difference == pytest.approx(99 * np.hypot(*vel[k]), rel=1e-3)
    assert "velocities (vx, vy) disagree" in imp.report.notes[0]
    assert imp.report.as_dict()["largest_correction"]["row"] == fix.row


def test_velocities_that_agree_are_kept_and_a_small_error_within_tolerance_too(tmp_path: Path) -> None:
    t = np.arange(0.0, DURATION + 1e-9, 0.5)
    _, vel, _ = s_curve(t)
    # 1.5 mm/s off everywhere moves 0.75 mm per 0.5 s step: inside 1 cm + 10 %
    assert 0.0015 * 0.5 < DISPLACEMENT_TOLERANCE[0]
    p, _ = quintic_file(tmp_path, vx=vel[:, 0] + 0.0015, vy=vel[:, 1])
    imp = read_trajectory_file(TrajectoryFile(p))
    assert not imp.report.corrections and imp.curve is not None
    np.testing.assert_allclose(imp.curve(t, 1)[:, 0], vel[:, 0] + 0.0015, atol=1e-12)


def test_dense_rows_cannot_hide_rates_that_are_wrong_all_along(tmp_path: Path) -> None:
    # 20 rows a second: every step is inside the absolute tolerance, so a column of zeros passes each
    # interval's check; over 10 cm of travel it cannot
    t = np.arange(0.0, DURATION + 1e-9, 0.05)
    _, vel, _ = s_curve(t)
    theta = np.unwrap(np.arctan2(vel[:, 1], vel[:, 0]))
    theta[0], theta[-1] = theta[1], theta[-2]
    omega = np.gradient(theta, t)
    steps = np.hypot(*np.diff(s_curve(t)[0], axis=0).T)
    assert steps.max() < DISPLACEMENT_TOLERANCE[0] and np.abs(np.diff(theta)).max() < HEADING_TOLERANCE[0]
    good, _ = quintic_file(tmp_path, step=0.05, theta=theta, v=np.hypot(*vel.T), omega=omega)
    imp = read_trajectory_file(TrajectoryFile(good))
    assert not imp.report.corrections and imp.omega is not None
    zeros = np.zeros_like(t)
    bad, _ = quintic_file(tmp_path, step=0.05, theta=theta, v=zeros, omega=zeros)
    imp = read_trajectory_file(TrajectoryFile(bad))
    assert {f.what for f in imp.report.corrections} == {"speeds v", "yaw rates omega"}
    assert imp.omega is None and imp.curve is not None
    np.testing.assert_allclose(imp.curve(t, 1), vel, atol=2e-3)  # the positions' own: no stop at every row
    assert re.search(r"speeds v disagree with the positions: from line \d+ to line \d+ they move", imp.report.notes[0])
    # without headings the motion's own: at rest (both ends) it is the nearest moving row's, not arctan2(0, 0)
    bare, _ = quintic_file(tmp_path, step=0.05, v=zeros, omega=zeros)
    fixes = {f.what: f for f in read_trajectory_file(TrajectoryFile(bare)).report.corrections}
    assert set(fixes) == {"speeds v", "yaw rates omega"}
    assert fixes["yaw rates omega"].difference < 1.1 * np.abs(omega).max()


def test_speeds_along_the_heading_are_checked_too(tmp_path: Path) -> None:
    t = np.arange(0.0, DURATION + 1e-9, 0.5)
    _, vel, _ = s_curve(t)
    theta = np.arctan2(vel[:, 1], vel[:, 0])
    theta[0], theta[-1] = theta[1], theta[-2]  # at rest: the heading of the motion next to it
    good, _ = quintic_file(tmp_path, theta=theta, v=np.hypot(*vel.T))
    assert not read_trajectory_file(TrajectoryFile(good)).report.corrections
    bad, _ = quintic_file(tmp_path, theta=theta, v=2.0 * np.hypot(*vel.T))
    fixes = read_trajectory_file(TrajectoryFile(bad)).report.corrections
    assert [f.what for f in fixes] == ["speeds v"]


def test_accelerations_that_agree_make_quintic_pieces_and_wrong_ones_are_dropped(tmp_path: Path) -> None:
    t = np.arange(0.0, DURATION + 1e-9, 0.5)
    _, vel, acc = s_curve(t)
    p, _ = quintic_file(tmp_path, vx=vel[:, 0], vy=vel[:, 1], ax=acc[:, 0], ay=acc[:, 1])
    imp = read_trajectory_file(TrajectoryFile(p))
    assert imp.curve is not None and not imp.report.corrections
    np.testing.assert_allclose(imp.curve(t, 2), acc, atol=1e-10)
    p, _ = quintic_file(tmp_path, vx=vel[:, 0], vy=vel[:, 1], ax=-5 * acc[:, 0], ay=acc[:, 1])
    imp = read_trajectory_file(TrajectoryFile(p))
    assert [f.what for f in imp.report.corrections] == ["accelerations (ax, ay)"]


def test_yaw_rates_and_headings_that_disagree_are_noted(tmp_path: Path) -> None:
    t = np.arange(0.0, DURATION + 1e-9, 0.5)
    _, vel, _ = s_curve(t)
    theta = np.unwrap(np.arctan2(vel[:, 1], vel[:, 0]))
    theta[0], theta[-1] = theta[1], theta[-2]
    off = theta.copy()
    off[20] += 0.5  # half a radian sideways at one row
    p, _ = quintic_file(tmp_path, theta=off, omega=np.gradient(theta, t) * 3.0)
    imp = read_trajectory_file(TrajectoryFile(p))
    assert [f.what for f in imp.report.corrections] == ["yaw rates omega"]
    assert imp.omega is None
    # the headings are turned toward the motion, and noted, where the file becomes a trajectory
    from planning.core.robot import load_robot
    from planning.trajectory.file_trajectory import arena_scenario, file_trajectory

    robot = load_robot("turtlebot3")
    file_trajectory(imp, robot, arena_scenario(imp, robot).world)
    whats = {f.what: f for f in imp.report.corrections}
    assert set(whats) == {"headings theta", "yaw rates omega"}
    assert whats["headings theta"].row == "line 22"
    assert whats["headings theta"].difference == pytest.approx(0.5, abs=0.02)  # sampled between the rows


def test_a_path_ignores_times_and_derivatives_and_merges_repeated_poses(tmp_path: Path) -> None:
    p = write_csv(
        tmp_path / "p.csv",
        {"t": np.arange(4.0), "x": np.array([0.0, 1.0, 1.0, 2.0]), "y": np.zeros(4), "v": np.ones(4)},
    )
    imp = read_trajectory_file(TrajectoryFile(p, timed=False))
    assert imp.t is None and imp.report.rows_merged == 1 and imp.rows == ("line 2", "line 3", "line 5")
    assert "columns t, v ignored" in imp.report.notes[0]


def test_option_parsers() -> None:
    assert parse_offset("1.5, -2, 0.3") == (1.5, -2.0, 0.3)
    assert parse_columns("t, x,y _ theta") == ("t", "x", "y", "_", "theta")
    for bad in ("1,2", "a,b,c", "1,2,inf"):
        with pytest.raises(TrajectoryFileError, match="X,Y,THETA"):
            parse_offset(bad)
    with pytest.raises(TrajectoryFileError, match=r"THETA is in radians within \+-4 pi; 90 degrees would be 1.571 rad"):
        parse_offset("1,1,90")  # turned the file by 90 rad
    assert parse_offset("0,0,-6.5") == (0.0, 0.0, -6.5)  # more than a turn, within 4 pi: a direction
    with pytest.raises(TrajectoryFileError, match="valid names are t, x, y, theta"):
        parse_columns("t,x,z")
    with pytest.raises(TrajectoryFileError, match=r"--scale \(scale=\.\.\. from Python\) must be a finite number"):
        TrajectoryFile(Path("a.csv"), scale=0.0)


def test_a_correction_note_quotes_the_miss_that_failed_not_two_sizes_within_tolerance(tmp_path: Path) -> None:
    t = np.arange(0.0, DURATION + 1e-9, 0.5)
    _, vel, _ = s_curve(t)
    p, _ = quintic_file(tmp_path, vx=vel[:, 0], vy=-vel[:, 1])  # vy of the wrong sign: same sizes, wrong way
    (note,) = read_trajectory_file(TrajectoryFile(p)).report.notes
    num = r"(-?[\d.]+(?:e-?\d+)?)"
    found = re.search(
        rf"they move \({num}, {num}\) m but the rows move \({num}, {num}\) m, {num} m apart \(tolerance {num} m\)", note
    )
    assert found, note
    said, rows = (np.array([float(found[i]), float(found[i + 1])]) for i in (1, 3))
    miss, tol = float(found[5]), float(found[6])
    assert miss > tol  # the quantity quoted is the one that failed
    assert miss == pytest.approx(float(np.hypot(*(said - rows))), rel=1e-2)


def test_arrays_import_as_a_file_of_the_same_rows_does(tmp_path: Path) -> None:
    p, t = quintic_file(tmp_path)
    xy = s_curve(t)[0]
    from_file = read_trajectory_file(TrajectoryFile(p, scale=100.0, offset=(1.0, 0.0, 0.3)))
    table = table_from_arrays(p, {"t": t, "x": xy[:, 0], "y": xy[:, 1]}, "arrays", [f"message {i}" for i in t])
    from_arrays = import_table(table, TrajectoryFile(p, scale=100.0, offset=(1.0, 0.0, 0.3)))
    np.testing.assert_array_equal(from_arrays.xy, from_file.xy)
    assert from_arrays.curve is not None and from_file.curve is not None
    np.testing.assert_array_equal(from_arrays.curve(t, 1), from_file.curve(t, 1))
    assert from_arrays.rows[3] == "message 1.5" and from_arrays.report.fmt == "arrays"
    bad = {"t": t, "x": np.where(t == 2.0, np.nan, xy[:, 0]), "y": xy[:, 1]}
    with pytest.raises(TrajectoryFileError, match=r"row 5 \(index 4\), column 'x'"):
        table_from_arrays(p, bad, "arrays")
    with pytest.raises(TrajectoryFileError, match="differ in length"):
        table_from_arrays(p, {"t": t, "x": xy[:-1, 0], "y": xy[:, 1]}, "arrays")
    with pytest.raises(TrajectoryFileError, match="unknown column"):
        table_from_arrays(p, {"t": t, "x": xy[:, 0], "z": xy[:, 1]}, "arrays")


def test_a_missing_column_under_columns_is_to_be_named_there(tmp_path: Path) -> None:
    p = tmp_path / "h.csv"
    p.write_text("t,x,y\n0,0,0\n1,1,0\n")
    with pytest.raises(TrajectoryFileError) as info:  # it said "name it in the header or with --columns"
        read_trajectory_file(TrajectoryFile(p, columns=("_", "x", "y")))
    assert "no column t (columns: x, y); name it with --columns (columns=... from Python), which names" in str(
        info.value
    )


def test_a_row_far_off_both_neighbours_is_noted_and_a_turn_back_is_not(tmp_path: Path) -> None:
    """One row 1.8 m out and back among rows 5 cm apart (a position fix's glitch) was taken without a word; the
    report notes it, naming the row and the fix. A turn back at a drive's far end, its steps the file's own, and
    a plain drive are not noted."""
    t = np.arange(7) * 0.5
    spike = write_csv(tmp_path / "spike.csv", {"t": t, "x": np.array([0, 0.05, 0.1, 2.0, 0.2, 0.25, 0.3]), "y": t * 0})
    notes = read_trajectory_file(TrajectoryFile(spike)).report.notes
    said = [n for n in notes if "lies 1.8 m off the rows either side of it" in n]
    assert len(said) == 1 and said[0].startswith("line 5 ") and said[0].endswith("drop the row"), notes
    x = np.array([0, 0.25, 0.5, 0.75, 1.0, 0.75, 0.5, 0.25, 0])
    back = write_csv(tmp_path / "back.csv", {"t": np.arange(9.0), "x": x, "y": 0.01 * np.arange(9.0)})
    for p in (back, _s_curve_file(tmp_path)):
        assert not any("off the rows either side" in n for n in read_trajectory_file(TrajectoryFile(p)).report.notes)


def _s_curve_file(tmp_path: Path) -> Path:
    t = np.arange(0.0, 20.0 + 1e-9, 0.5)
    xy, _, _ = s_curve(t)
    return write_csv(tmp_path / "s.csv", {"t": t, "x": xy[:, 0], "y": xy[:, 1]})
