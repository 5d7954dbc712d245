"""Trajectory files whose clock is far too fast for the robot (seconds read as milliseconds, a wrong
``--time-scale``): judged against the robot's limits and re-timed along their own shape, however short;
a clock lasting less than a microsecond is refused, naming ``--time-scale``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planning.core.robot import load_robot
from planning.trajectory.file_formats import TrajectoryFileError
from planning.trajectory.file_trajectory import arena_scenario, file_poses, file_trajectory
from planning.trajectory.importer import TrajectoryFile, read_trajectory_file
from sim.cli.main import main

#: 1 m along x in 2 ms: 500 m/s.
FAST = "t,x,y\n0,0,0\n0.001,0.5,0\n0.002,1.0,0\n"
#: 1 m along x in 10 s: within a TurtleBot3's limits on its own clock.
SLOW = "t,x,y\n0,0,0\n5,0.5,0\n10,1.0,0\n"


def _quarter_circle(tmp_path: Path, duration: float) -> Path:
    """A quarter circle of 1 m radius from (0, 0) heading along x to (1, 1) heading along y, in ``duration``."""
    a = np.linspace(0.0, 0.5 * np.pi, 11)
    t = np.linspace(0.0, duration, 11)
    rows = ["t,x,y", *(f"{ti:.9g},{np.sin(ai):.6f},{1 - np.cos(ai):.6f}" for ti, ai in zip(t, a, strict=True))]
    p = tmp_path / "arc.csv"
    p.write_text("\n".join(rows) + "\n")
    return p


def test_a_file_of_two_milliseconds_is_re_timed_and_reaches_its_end(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Sampled every 10 ms, the file was two samples at rest: kept on its clock, 0.89 m short of its end."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "fast.csv").write_text(FAST)
    argv = ["simulate", "--trajectory", "fast.csv", "--runs", "closed_loop", "--no-video", "--no-plots"]
    assert main([*argv, "--json", "f.json"]) == 0
    assert "re-timed" in capsys.readouterr().out
    rec = json.loads((tmp_path / "f.json").read_text())
    assert rec["import"]["retimed"] is True and "--time-scale" in rec["import"]["timing"]
    assert rec["closed_loop"]["final_position_error_m"] <= 0.02
    assert rec["trajectory"]["duration_s"] > 5.0  # 1 m at the robot's 0.22 m/s at most


@pytest.mark.parametrize("time_scale", [1e-3, 1e-5, 2e-3])
def test_a_too_small_time_scale_re_times_the_file_and_says_to_check_it(tmp_path: Path, time_scale: float) -> None:
    (tmp_path / "ok.csv").write_text(SLOW)
    robot = load_robot("turtlebot3")
    imported = read_trajectory_file(TrajectoryFile(tmp_path / "ok.csv", time_scale=time_scale))
    res = file_trajectory(imported, robot, arena_scenario(imported, robot).world)
    report = imported.report
    assert report.retimed is True and report.time_stretch == 1.0
    assert f"check --time-scale {time_scale:g}" in report.timing
    assert res.trajectory is not None and res.trajectory.duration > 5.0


@pytest.mark.parametrize("duration", [0.005, 0.2])
def test_a_fast_curve_is_re_timed_along_its_own_shape(tmp_path: Path, duration: float) -> None:
    """On its own clock the curve was shorter than the windows its heading is taken over: it was driven along
    its chord (heading pi/4 throughout) and ended 5 cm off its end."""
    imported = read_trajectory_file(TrajectoryFile(_quarter_circle(tmp_path, duration)))
    poses = file_poses(imported)
    assert poses[0, 2] == pytest.approx(0.0, abs=0.05) and poses[-1, 2] == pytest.approx(0.5 * np.pi, abs=0.05)
    robot = load_robot("turtlebot3")
    res = file_trajectory(imported, robot, arena_scenario(imported, robot).world)
    assert imported.report.retimed is True and res.trajectory is not None
    heading = res.trajectory.pose[:, 2]
    assert heading[0] == pytest.approx(0.0, abs=0.05) and heading[-1] == pytest.approx(0.5 * np.pi, abs=0.05)
    radius = np.hypot(res.trajectory.pose[:, 0], res.trajectory.pose[:, 1] - 1.0)
    assert np.max(np.abs(radius - 1.0)) < 0.01  # along the arc, not its chord


@pytest.mark.parametrize(("time_scale", "needle"), [(1e-9, "check --time-scale 1e-09"), (None, "give the seconds")])
def test_a_clock_shorter_than_a_microsecond_is_refused_naming_time_scale(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], time_scale: float | None, needle: str
) -> None:
    p = tmp_path / "ok.csv"
    p.write_text(SLOW if time_scale else "t,x,y\n0,0,0\n1e-8,0.5,0\n2e-8,1,0\n")
    with pytest.raises(TrajectoryFileError, match="less than 1e-06 s") as info:
        read_trajectory_file(TrajectoryFile(p, time_scale=time_scale))
    assert needle in str(info.value)
    extra = ["--time-scale", str(time_scale)] if time_scale else []
    assert main(["simulate", "--trajectory", str(p), *extra, "--no-video", "--no-plots", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "less than 1e-06 s" in err and "Traceback" not in err
