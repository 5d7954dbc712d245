"""``nhsim simulate --trajectory/--path``: a coarse pixel file with repeated stamps tracked through a world
with obstacles to the closed-loop targets; every bad file exits 2 and writes nothing."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sim.cli.main import main

WORLD = """robot = "turtlebot3"
[world]
bounds = [0.0, 3.0, 0.0, 2.0]
[[world.obstacles]]
type = "circle"
center = [1.5, 1.65]
radius = 0.2
[[world.obstacles]]
type = "box"
center = [0.9, 0.85]
size = [0.4, 0.2]
[[world.obstacles]]
type = "circle"
center = [2.3, 0.5]
radius = 0.2
[start]
pose = [0.4, 1.0, 0.0]
[goal]
pose = [2.6, 1.0, 0.0]
"""
DURATION = 36.0


def pixel_file(tmp_path: Path, step: float = 1.0) -> Path:
    """A rest-to-rest quintic arc in pixels (1 cm each) sampled every ``step`` s, with velocities in pixels
    per second; where its two pieces meet (12 s, 24 s) the stamp repeats with velocities 0.5 px/s apart."""
    t = np.arange(0.0, DURATION + 1e-9, step)
    s = t / DURATION
    u = 10 * s**3 - 15 * s**4 + 6 * s**5
    du = (30 * s**2 - 60 * s**3 + 30 * s**4) / DURATION
    x, y = 40 + 220 * u, 100 + 30 * np.sin(np.pi * u)
    vx, vy = 220 * du, 30 * np.pi * np.cos(np.pi * u) * du
    rows = ["t,x,y,vx,vy"]
    for i in range(t.size):
        joint = t[i] in (12.0, 24.0)
        for dv in (-0.5, 0.5) if joint else (0.0,):
            rows.append(f"{t[i]:.4f},{x[i]:.4f},{y[i]:.4f},{vx[i] + dv:.4f},{vy[i]:.4f}")
    p = tmp_path / "px.csv"
    p.write_text("\n".join(rows) + "\n")
    return p


def test_a_coarse_pixel_trajectory_with_repeated_stamps_is_tracked_through_obstacles(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "world.toml").write_text(WORLD)
    out = tmp_path / "run.json"
    argv = ["simulate", "--trajectory", str(pixel_file(tmp_path)), "--scale", "0.01", "--scenario", "world.toml"]
    # the import is under test, on the fix loop its 2 cm were set for (the scan localiser's own
    # targets are tests/test_scan_localiser.py's: between its updates, every 0.25 m, odometry drifts)
    assert main([*argv, "--no-video", "--json", str(out), "--localiser", "fixes"]) == 0
    printed = capsys.readouterr().out
    assert "2 merged; timing kept" in printed and "line 14 -> line 15" in printed
    rec = json.loads(out.read_text())
    closed = rec["closed_loop"]
    assert closed["final_position_error_m"] <= 0.02 and closed["final_heading_error_rad"] <= 0.05
    assert closed["rms_position_error_m"] <= 0.02
    assert closed["collisions"] == 0 and closed["warnings"] == 0 and closed["status"] == "ok"
    assert rec["open_loop"]["final_position_error_m"] > closed["final_position_error_m"]
    imp = rec["import"]
    assert (imp["rows_read"], imp["rows_merged"], imp["retimed"], imp["scale"]) == (39, 2, False, 0.01)
    assert rec["source"] == "file:px" and rec["smoothing"]["timed_input"] is True
    assert rec["trajectory"]["duration_s"] == pytest.approx(DURATION + 0.3, abs=0.02)  # its own clock, then a hold
    assert {"plot_world", "plot_errors", "plot_commands", "json"} <= set(rec["files"])
    assert all(Path(f).exists() for f in rec["files"].values())


def test_a_ros_path_runs_in_an_arena_around_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    lines = ["poses:"] + [
        f"- pose: {{position: {{x: {x!r}, y: 0.5}}, orientation: {{x: 0, y: 0, z: 0, w: 1}}}}"
        for x in np.linspace(-1.0, 0.0, 11).tolist()
    ]
    p = tmp_path / "nav.yaml"
    p.write_text("\n".join(lines) + "\n")
    assert main(["simulate", "--path", str(p), "--runs", "closed_loop", "--no-video", "--no-plots", "--quiet"]) == 0
    (out,) = (tmp_path / "renders").glob("arena-nav-*.json")  # named after the arena and the file, tagged by --runs
    rec = json.loads(out.read_text())
    assert rec["scenario"] == "arena" and rec["import"]["arena"] and rec["import"]["format"] == "nav_msgs/Path"
    assert rec["closed_loop"]["final_position_error_m"] <= 0.02


def test_a_ros_path_of_identity_orientations_running_west_is_read_as_unset(tmp_path: Path) -> None:
    """Nav2's NavFn leaves the orientations the identity (yaw 0): a westward path dumped to YAML was driven in
    reverse; its orientations are unset, the headings the motion's, as a bag's."""
    from planning.trajectory.importer import TrajectoryFile, read_trajectory_file

    lines = ["poses:"] + [
        f"- pose: {{position: {{x: {x!r}, y: 0.5}}, orientation: {{x: 0, y: 0, z: 0, w: 1}}}}"
        for x in np.linspace(0.0, -1.0, 11).tolist()
    ]
    p = tmp_path / "nav.yaml"
    p.write_text("\n".join(lines) + "\n")
    imported = read_trajectory_file(TrajectoryFile(p, timed=False))
    assert (imported.direction > 0).all() and imported.theta is None
    assert any(n.startswith("orientations: poses[0..9] carry the identity") for n in imported.report.notes)


def test_a_ros_path_without_times_given_as_a_trajectory_is_sent_to_the_path_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The message pointed to --columns, which a YAML document refuses ("names its own fields")."""
    lines = ["poses:"] + [
        f"- pose: {{position: {{x: {x!r}, y: 0.5}}, orientation: {{x: 0, y: 0, z: 0, w: 1}}}}" for x in (0.0, 1.0)
    ]
    p = tmp_path / "nav.yaml"
    p.write_text("\n".join(lines) + "\n")
    assert main(["simulate", "--trajectory", str(p), "--no-video", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "no column t" in err and "--columns" not in err and "use --path" in err


@pytest.mark.parametrize(
    ("text", "extra", "needle"),
    [
        ("t,x,northing\n0,0,0\n1,1,1\n", [], "valid names are t, x, y, theta"),
        ("t,x\n0,0\n1,1\n", [], "no column y"),
        ("t,x,y\n0,1,1\n1,1,1\n", [], "two distinct positions: give rows that move"),
        (  # a scale that shrank the rows to one position is named, and a larger one asked for
            "t,x,y\n0,0,0\n1,1,1\n",
            ["--scale", "1e-300"],
            "at one position (0, 0) after --scale 1e-300; a trajectory needs at least two distinct positions: give "
            "rows that move, or a larger --scale",
        ),
        ("t,x,y\n0,0,0\n1,abc,1\n", [], "line 3, column 'x': 'abc'"),
        ("t,x,y\n0,0,0\n1,1,1\n1,2,1\n", [], "line 3 -> line 4"),
        ("t,x,y\n0,0,0\n1,1,1\n", ["--reference", "line"], "drop --planner, --reference"),
        ("t,x,y\n0,0,0\n1,1,1\n", ["--offset", "1,2"], "X,Y,THETA"),
        ("t,x,y\n0,0,0\n1,1,1\n", ["--all"], "drop it to track"),
        ("t,x,y\n0,0,0\n1,1,1\n", ["--columns", "t,x,q"], "valid names"),
    ],
)
def test_bad_files_exit_2_and_write_nothing(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    text: str,
    extra: list[str],
    needle: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    p = tmp_path / "bad.csv"
    p.write_text(text)
    assert main(["simulate", "--trajectory", str(p), *extra, "--no-video", "--quiet"]) == 2
    assert needle in capsys.readouterr().err
    assert not (tmp_path / "renders").exists() or not any((tmp_path / "renders").iterdir())


@pytest.mark.parametrize(
    ("command", "options", "named"),
    [
        (["simulate", "--reference", "circle", "--no-video"], ["--scale", "0.01"], "--scale says"),
        (["simulate", "--no-video"], ["--time-scale", "2", "--offset=1,0,0"], "--time-scale, --offset say"),
        (["compare", "--reference", "line"], ["--topic", "/plan", "--message", "0"], "--topic, --message say"),
        (["montecarlo", "--reference", "line", "--runs", "2"], ["--allow-collisions"], "--allow-collisions says"),
        (["simulate", "--planner", "birrt", "--no-video"], ["--columns", "t,x,y"], "--columns says"),
    ],
)
def test_reading_options_without_a_file_exit_2_instead_of_being_ignored(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    command: list[str],
    options: list[str],
    named: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main([*command, *options, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert named in err and "--trajectory or --path" in err and "drop" in err
    assert not (tmp_path / "renders").exists()


def test_a_pixel_file_without_scale_is_refused_suggesting_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "world.toml").write_text(WORLD)
    p = pixel_file(tmp_path)
    assert main(["simulate", "--trajectory", str(p), "--scenario", "world.toml", "--no-video", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "leaves the world" in err and "e.g. --scale 0.01 for 1 cm per pixel" in err and "px.csv" in err
    assert "from Python" not in err  # the command prints the command-line form only
    assert main(["simulate", "--trajectory", str(p), "--no-video", "--quiet"]) == 2  # no scenario: too big an arena
    assert "--scale" in capsys.readouterr().err
    assert not (tmp_path / "renders").exists() or not any((tmp_path / "renders").iterdir())


def test_a_file_through_an_obstacle_is_refused_or_run_anyway_on_request(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "hit.toml").write_text(WORLD.replace("center = [1.5, 1.65]", "center = [1.5, 1.3]"))
    argv = ["simulate", "--trajectory", str(pixel_file(tmp_path)), "--scale", "0.01", "--scenario", "hit.toml"]
    out = tmp_path / "hit.json"
    assert main([*argv, "--no-video", "--no-plots", "--json", str(out)]) == 2
    err = capsys.readouterr().err
    # the time from the first row and the row near it (a log's stamps may be Unix times: the time alone finds no row)
    assert "enters obstacle 0 (circle about (1.50, 1.30)) at t = 15.87 s from its first row (near line 19)" in err
    assert "--allow-collisions" in err
    assert not out.exists()
    rc = main([*argv, "--runs", "open_loop", "--no-video", "--no-plots", "--json", str(out), "--allow-collisions"])
    assert rc == 0  # the open loop is not judged; the record says what was allowed
    rec = json.loads(out.read_text())
    assert rec["import"]["collisions_allowed"] and "enters obstacle 0" in rec["import"]["world"]
    assert rec["open_loop"]["collisions"] > 0


def test_simulate_file_from_python_starts_where_the_file_does(tmp_path: Path) -> None:
    from planning import TrajectoryFile
    from sim import RunKind, simulate_file

    job = simulate_file(  # the fix loop, as above
        TrajectoryFile(pixel_file(tmp_path, step=0.5), scale=0.01), runs=(RunKind.CLOSED_LOOP,), localiser="fixes"
    )
    assert job.source == "file:px" and job.scenario.name == "arena"
    assert (job.scenario.start.x, job.scenario.start.y) == pytest.approx((0.40, 1.00), abs=1e-9)
    assert job.extra["import"]["rows_merged"] == 2 and job.extra["import"]["arena"] is True
    assert job.metrics[RunKind.CLOSED_LOOP].final_position_error_m <= 0.02


def test_a_scenario_file_with_another_robot_names_the_outputs_after_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    both = 'robot = "turtlebot3"\nrobots = ["turtlebot3", "edumip"]'
    (tmp_path / "world.toml").write_text(WORLD.replace('robot = "turtlebot3"', both))
    argv = ["simulate", "--trajectory", str(pixel_file(tmp_path)), "--scale", "0.01", "--scenario", "world.toml"]
    assert main([*argv, "--robot", "edumip", "--runs", "closed_loop", "--no-video", "--no-plots", "--quiet"]) == 0
    (out,) = (tmp_path / "renders").glob("world-px-edumip-*.json")
    assert json.loads(out.read_text())["robot"] == "edumip"


def test_a_json_file_with_wrong_velocities_is_repaired_and_the_summary_and_record_say_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    lines = pixel_file(tmp_path).read_text().split()
    names = lines[0].split(",")
    records = [dict(zip(names, map(float, row.split(",")), strict=True)) for row in lines[1:]]
    for r in records:
        r["vx"], r["vy"] = 100 * r["vx"], 100 * r["vy"]  # centimetres of pixels per second: wrong units
    p = tmp_path / "px.json"
    p.write_text(json.dumps(records))
    out = tmp_path / "run.json"
    argv = ["simulate", "--trajectory", str(p), "--scale", "0.01", "--runs", "closed_loop", "--no-video", "--no-plots"]
    assert main([*argv, "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "velocities (vx, vy) disagree with the positions" in printed
    assert "largest correction: velocities (vx, vy) at record" in printed
    imp = json.loads(out.read_text())["import"]
    assert imp["format"] == "json" and imp["rows_merged"] == 2
    assert imp["largest_correction"]["what"] == "velocities (vx, vy)" and imp["largest_correction"]["unit"] == "m/s"


FOUR_BOXES = """robot = "edumip"
robots = ["edumip"]
[world]
bounds = [0.0, 2.0, 0.0, 1.5]
[[world.obstacles]]
type = "box"
center = [0.2, 0.2]
size = [0.2, 0.2]
[[world.obstacles]]
type = "box"
center = [1.8, 0.2]
size = [0.2, 0.2]
[[world.obstacles]]
type = "box"
center = [0.2, 1.3]
size = [0.2, 0.2]
[[world.obstacles]]
type = "box"
center = [1.8, 1.3]
size = [0.2, 0.2]
[start]
pose = [0.5, 0.5, 0.0]
[goal]
pose = [0.95, 0.5, 0.0]
"""


def test_a_headerless_pixel_file_stopping_short_while_turning_runs_among_four_boxes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """All eight columns in pixels of 1 cm, no header: its last row stops within 0.05 s while the heading
    turns (the re-timing labelled that sample alone a turn in place, timed in no time: t[k+1] <= t[k])."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "boxes.toml").write_text(FOUR_BOXES)
    t = [0.0, 1.0, 2.5, 4.0, 5.0, 5.05]
    x = [50.0, 55.0, 70.0, 85.0, 95.0, 95.25]
    vx, ax = [0.0, 10.0, 10.0, 10.0, 10.0, 0.0], [10.0, 0.0, 0.0, 0.0, 0.0, -200.0]
    theta = [0.0, 0.0, 0.0, 0.0, 0.0, 0.05]
    rows = [f"{a},{b},50,{c},0,{d},0,{e}" for a, b, c, d, e in zip(t, x, vx, ax, theta, strict=True)]
    p = tmp_path / "edumip.csv"
    p.write_text("\n".join(rows) + "\n")
    out = tmp_path / "run.json"
    argv = ["simulate", "--trajectory", str(p), "--columns", "t,x,y,vx,vy,ax,ay,theta", "--scale", "0.01"]
    rc = main([*argv, "--scenario", "boxes.toml", "--no-video", "--no-plots", "--json", str(out), "--quiet"])
    assert rc in (0, 1) and out.exists()
    rec = json.loads(out.read_text())
    assert rec["import"]["retimed"] and rec["closed_loop"]["collisions"] == 0


def test_an_untimed_row_where_the_path_turns_is_arrived_at_and_left_with_two_headings(tmp_path: Path) -> None:
    from planning import TrajectoryFile
    from planning.trajectory.file_trajectory import path_poses
    from planning.trajectory.importer import read_trajectory_file

    p = tmp_path / "ell.csv"
    p.write_text("x,y\n0,0\n0.5,0\n1,0\n1,1\n0,1\n")  # a straight row, then two corners of 90 deg
    poses = path_poses(read_trajectory_file(TrajectoryFile(p, timed=False)))
    h = np.pi / 2
    expect = [(0, 0, 0), (0.5, 0, 0), (1, 0, 0), (1, 0, h), (1, 1, h), (1, 1, 2 * h), (0, 1, 2 * h)]
    assert np.allclose(poses, expect, atol=1e-12)


@pytest.mark.parametrize(
    ("rows", "length", "rotations"),
    [
        ("x,y\n0,0\n1,0\n0,0\n", 2.0, 1),  # out and back: a U-turn in place (it could not be smoothed)
        ("x,y\n0,0\n1,0\n0,0\n1,0\n0,0\n", 4.0, 3),  # there and back twice: the second trip is driven too
        ("x,y\n0,0\n1,0\n0,0.1\n", 2.005, 1),  # a corner of 174 deg
    ],
)
def test_a_path_that_turns_back_is_driven_as_given(tmp_path: Path, rows: str, length: float, rotations: int) -> None:
    from planning import TrajectoryFile
    from sim import RunKind, simulate_file

    p = tmp_path / "back.csv"
    p.write_text(rows)
    job = simulate_file(TrajectoryFile(p, timed=False), runs=(RunKind.CLOSED_LOOP,), localiser="fixes")
    smoothing = job.extra["smoothing"]
    assert smoothing["length_m"] == pytest.approx(length, abs=0.01) and smoothing["rotations"] == rotations
    assert smoothing["loop_poses_removed"] == 0
    assert job.metrics[RunKind.CLOSED_LOOP].final_position_error_m <= 0.02


def test_a_route_driven_twice_keeps_both_laps(tmp_path: Path) -> None:
    from planning import TrajectoryFile
    from planning.core.robot import load_robot
    from planning.trajectory.file_trajectory import arena_scenario, file_trajectory
    from planning.trajectory.importer import read_trajectory_file

    a = np.linspace(0.0, 4.0 * np.pi, 201)
    p = tmp_path / "laps.csv"
    p.write_text("x,y\n" + "".join(f"{np.cos(t) - 1:.6f},{np.sin(t):.6f}\n" for t in a))
    imported = read_trajectory_file(TrajectoryFile(p, timed=False))
    robot = load_robot("turtlebot3")
    res = file_trajectory(imported, robot, arena_scenario(imported, robot).world)
    assert res.success and res.stats["loop_poses_removed"] == 0
    assert res.stats["length_m"] == pytest.approx(4.0 * np.pi, rel=0.005)  # two laps of a 1 m circle


def test_a_clock_in_milliseconds_read_as_seconds_is_said_where_the_file_still_moves(tmp_path: Path) -> None:
    """3 s of 2 m/s written with a millisecond clock: read as seconds it moves at 2 mm/s for 50 min, above the
    1 mm/s of a standing robot and under the hour a file may last, so it ran silently as that; it runs, saying so."""
    from planning.trajectory.importer import TrajectoryFile, read_trajectory_file

    p = tmp_path / "ms.csv"
    p.write_text("t,x,y\n" + "".join(f"{a},{a / 1000 * 2:.4f},0\n" for a in range(0, 3001, 100)))
    notes = read_trajectory_file(TrajectoryFile(p, timed=True)).report.notes
    assert any("moves at 2 mm/s at most over 50 min: if its clock counts milliseconds" in n for n in notes), notes
    fine = read_trajectory_file(TrajectoryFile(p, timed=True, time_scale=0.001)).report.notes
    assert not any("clock counts milliseconds" in n for n in fine)


def test_other_tools_names_of_time_and_heading_are_read(tmp_path: Path) -> None:
    """A web tool's ``{"timestamp", "x", "y", "yaw"}`` records: both fields were dropped and the error said the file
    had no times, sending the user to --path (which throws the clock away). time, timestamp and stamp read as t,
    yaw and heading as theta, in a CSV header too; a file naming one column twice is still refused."""
    from planning.trajectory.file_formats import TrajectoryFileError
    from planning.trajectory.importer import TrajectoryFile, read_trajectory_file

    rows = [{"timestamp": float(k), "x": 0.1 * k, "y": 0.0, "yaw": 0.0} for k in range(4)]
    p = tmp_path / "web.json"
    p.write_text(json.dumps(rows))
    imported = read_trajectory_file(TrajectoryFile(p, timed=True))
    np.testing.assert_allclose(imported.t, [0.0, 1.0, 2.0, 3.0])
    assert imported.theta is not None and not any("ignored" in n for n in imported.report.notes)
    csv = tmp_path / "h.csv"
    csv.write_text("Time,X,Y,Heading\n0,0,0,0\n1,0.1,0,0\n2,0.2,0,0\n")
    assert read_trajectory_file(TrajectoryFile(csv, timed=True)).theta is not None
    csv.write_text("t,timestamp,x,y\n0,0,0,0\n1,1,0.1,0\n")
    with pytest.raises(TrajectoryFileError, match=r"column\(s\) t named twice"):
        read_trajectory_file(TrajectoryFile(csv, timed=True))


def test_a_file_of_nul_bytes_is_said_to_be_no_text(tmp_path: Path) -> None:
    """2000 zero bytes are valid UTF-8: the error echoed them as an 8 KB "unknown column name"."""
    from planning.trajectory.file_formats import TrajectoryFileError
    from planning.trajectory.importer import TrajectoryFile, read_trajectory_file

    p = tmp_path / "zeros.csv"
    p.write_bytes(bytes(2000))
    with pytest.raises(TrajectoryFileError, match=r"is not text \(it holds NUL bytes, from character 0\)") as err:
        read_trajectory_file(TrajectoryFile(p, timed=True))
    assert len(str(err.value)) < 300


def test_a_header_written_as_a_comment_is_pointed_at(tmp_path: Path) -> None:
    """numpy's ``savetxt(header="t,x,y")`` writes ``# t,x,y``: the error said to add a header."""
    from planning.trajectory.file_formats import TrajectoryFileError
    from planning.trajectory.importer import TrajectoryFile, read_trajectory_file

    p = tmp_path / "np.csv"
    np.savetxt(p, np.column_stack([np.arange(5.0), 0.1 * np.arange(5.0), np.zeros(5)]), delimiter=",", header="t,x,y")
    with pytest.raises(TrajectoryFileError, match=r"line 1 names them but is a comment \('# t,x,y'\): drop its '#'"):
        read_trajectory_file(TrajectoryFile(p, timed=True))
    p.write_text("# a comment\n0,0,0\n1,0.1,0\n")  # a comment that names no columns: no such hint
    with pytest.raises(TrajectoryFileError) as err:
        read_trajectory_file(TrajectoryFile(p, timed=True))
    assert "is a comment" not in str(err.value)


def test_records_under_a_poses_key_are_read_as_records(tmp_path: Path) -> None:
    """A web tool's ``{"poses": [{"x", "y", "theta"}, ...]}`` was refused as a nav_msgs/Path without pose.position."""
    from planning.trajectory.importer import TrajectoryFile, read_trajectory_file

    p = tmp_path / "web.json"
    p.write_text(json.dumps({"poses": [{"x": 0.1 * k, "y": 0.0, "theta": 0.0} for k in range(5)]}))
    imported = read_trajectory_file(TrajectoryFile(p, timed=False))
    np.testing.assert_allclose(imported.xy[:, 0], 0.1 * np.arange(5))
    assert imported.theta is not None


def test_a_densely_sampled_path_is_thinned_not_merged_into_one_row(tmp_path: Path) -> None:
    """Rows closer than 0.1 mm to the row before were merged one into the next, however far the run went: a path
    sampled every 50 um over 0.5 m was "all at one position", a dense first 0.1 m became one row (a chord). Each
    row is merged into its run's first while within 0.1 mm of it: a path of steps of about 0.1 mm is left."""
    from planning.trajectory.importer import TrajectoryFile, read_trajectory_file

    x = np.arange(10001) * 5e-5
    p = tmp_path / "dense.csv"
    p.write_text("x,y\n" + "".join(f"{v!r},0.0\n" for v in x.tolist()))
    imported = read_trajectory_file(TrajectoryFile(p, timed=False))
    steps = np.diff(imported.xy[:, 0])
    assert imported.xy[0, 0] == 0.0 and imported.xy[-1, 0] >= 0.4999 and (steps > 0.0).all()
    assert steps.max() < 2e-4 and imported.xy.shape[0] >= 2500  # 0.1 mm and a row of 50 um at most
    said = "row(s) merged (repeated poses: within 0.1 mm and 1 mrad of their run's first)"
    assert any(said in n for n in imported.report.notes)
