"""A recording's time stamps scattered about a steady clock (a driver's timestamping) are read on that clock: the
motion keeps its clock instead of being re-timed for accelerations the scatter made."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from planning.core.robot import load_robot
from planning.trajectory.file_trajectory import arena_scenario, file_trajectory
from planning.trajectory.importer import ImportReport, TrajectoryFile, read_trajectory_file, steady_clock

RATE = 30.0


def _ramp(n: int = 300) -> tuple[np.ndarray, np.ndarray]:
    """(times, x) of a straight drive from rest to 0.1 m/s and back to rest, sampled at RATE."""
    t = np.arange(n) / RATE
    duration = t[-1]
    v = 0.1 * np.clip(np.minimum(t, duration - t) / 1.0, 0.0, 1.0)  # 1 s ramps at 0.1 m/s^2
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    return t, x


def _report() -> ImportReport:
    return ImportReport("f.csv", "csv", "trajectory", 0)


def test_scattered_stamps_with_a_dropped_message_are_read_on_their_clock() -> None:
    rng = np.random.default_rng(4)
    clock = np.delete(np.arange(120) / RATE, 57)  # message 57 dropped
    stamps = clock + rng.uniform(-0.003, 0.003, clock.size)
    report = _report()
    read = steady_clock(stamps, report)
    steps = np.diff(read) / np.diff(read).min()
    np.testing.assert_allclose(steps, np.where(np.arange(steps.size) == 56, 2.0, 1.0))  # steady; the drop's gap kept
    assert np.ptp(read - clock) < 0.002 < 0.005 < np.ptp(stamps - clock)  # the clock's, up to its offset and rate
    assert re.search(r"about a steady 30(\.0\d)? Hz clock: read on that clock", report.notes[0])


@pytest.mark.parametrize("kind", ["steady", "steady, its last row early", "irregular", "too few"])
def test_stamps_of_no_scattered_steady_clock_are_kept(kind: str) -> None:
    rng = np.random.default_rng(5)
    if kind == "steady":
        stamps = np.arange(200) / RATE
    elif kind == "steady, its last row early":  # a reference sampled every 20 ms to its end, 13 ms after the last
        stamps = np.append(np.arange(200) * 0.02, 199 * 0.02 + 0.013)
    elif kind == "irregular":  # an event-driven log: intervals of 0.5 to 1.5 periods, a random walk off any clock
        stamps = np.cumsum(rng.uniform(0.5, 1.5, 200)) / RATE
    else:
        stamps = np.arange(8) / RATE + rng.uniform(-0.003, 0.003, 8)
    report = _report()
    assert steady_clock(stamps, report) is stamps and report.notes == []


def test_a_recorded_ramp_with_scattered_stamps_keeps_its_clock(tmp_path: Path) -> None:
    """3 ms of scatter on 30 Hz odometry made 0.97 m/s^2 of acceleration where the robot accelerated at 0.1: the
    file was re-timed, 8.1 s instead of its 10 s."""
    t, x = _ramp()
    robot = load_robot("turtlebot3")
    durations = []
    for name, stamps in (("steady", t), ("scattered", t + np.random.default_rng(6).uniform(-0.003, 0.003, t.size))):
        path = tmp_path / f"{name}.csv"
        path.write_text("t,x,y\n" + "".join(f"{a:.6f},{b:.6f},0\n" for a, b in zip(stamps, x, strict=True)))
        imported = read_trajectory_file(TrajectoryFile(path))
        result = file_trajectory(imported, robot, arena_scenario(imported, robot).world)
        assert imported.report.retimed is False, (name, imported.report.timing)
        durations.append(result.trajectory.duration)
    assert durations[1] == pytest.approx(durations[0], abs=0.01)
