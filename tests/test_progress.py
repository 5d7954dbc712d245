"""Progress: the simulator's and the jobs' reports, and the CLI bars built on them."""

from __future__ import annotations

import argparse
import time
from itertools import pairwise
from typing import Any, ClassVar

import numpy as np
import pytest

import sim.cli.progress as progress
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.scenario import load_scenario
from planning.trajectory.references import make_reference
from sim.cli.job_outputs import show_progress
from sim.cli.progress import JobBars, TimedBar


class FakeBar:
    """Stands in for tqdm: records what a bar was told."""

    made: ClassVar[list[FakeBar]] = []

    def __init__(self, **kwargs: Any) -> None:
        self.kwargs = kwargs
        self.total = kwargs["total"]
        self.n: float = 0
        self.updates: list[float] = []
        self.closed = False
        FakeBar.made.append(self)

    def update(self, n: float) -> None:
        assert not self.closed
        self.n += n
        self.updates.append(self.n)

    def close(self) -> None:
        self.closed = True


@pytest.fixture
def fake_tqdm(monkeypatch: pytest.MonkeyPatch) -> list[FakeBar]:
    FakeBar.made.clear()
    monkeypatch.setattr(progress, "_tqdm", FakeBar)
    return FakeBar.made


def test_simulator_reports_progress_and_runs_the_same_without() -> None:
    from control.base import make_tracker
    from sim.physics.simulator import PROGRESS_UPDATES, SimConfig, Simulator

    sc = load_scenario("open")
    robot = load_robot(sc.robot)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0), length=0.4)
    sim = Simulator(robot, sc.world)
    cfg = SimConfig(control_rate=50.0)
    reports: list[tuple[int, int]] = []
    with_bar = sim.run(traj, make_tracker("fbl", robot), cfg, progress=lambda d, t: reports.append((d, t)))
    plain = sim.run(traj, make_tracker("fbl", robot), cfg)
    np.testing.assert_array_equal(with_bar.qpos, plain.qpos)  # reporting changes nothing
    total = len(plain) - 1  # at 50 Hz the log has one sample per control period, plus the start
    assert reports[0] == (0, total) and reports[-1] == (total, total)
    done = [d for d, t in reports if t == total]
    assert len(done) == len(reports)
    assert all(b > a for a, b in pairwise(done))
    assert total > PROGRESS_UPDATES and PROGRESS_UPDATES / 2 <= len(reports) <= PROGRESS_UPDATES + 2


def test_jobs_report_each_run_and_planning() -> None:
    from sim.pipeline.case import Case, PlanOptions, PreparedTrajectory
    from sim.pipeline.runs import RunKind
    from sim.pipeline.simulate import simulate_plan, track

    sc = load_scenario("open")
    robot = load_robot(sc.robot)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0), length=0.3)
    seen: list[tuple[str, float, float]] = []
    prepared = PreparedTrajectory(Case("open", reference="line"), sc, robot, traj, "reference:line")
    track(prepared, progress=lambda *r: seen.append(r))
    for label in ("closed_loop", "open_loop"):
        mine = [r for r in seen if r[0] == label]
        assert mine[0][1] == 0 and mine[-1][1] == mine[-1][2] > 0
    # planning: one report when it starts (0 of the budget), one when it returns (the whole budget)
    seen.clear()
    simulate_plan(
        "simple_motion",
        planner="sinusoidal",
        planning=PlanOptions(time_limit=7.0),
        runs=(RunKind.OPEN_LOOP,),
        progress=lambda *r: seen.append(r),
    )
    plan = [r for r in seen if r[0] == "plan"]
    assert plan == [("plan", 0.0, 7.0), ("plan", 7.0, 7.0)]
    assert seen.index(plan[-1]) < next(i for i, r in enumerate(seen) if r[0] == "open_loop")


def test_job_bars_one_bar_per_stage(fake_tqdm: list[FakeBar]) -> None:
    bars = JobBars(True)
    bars("closed_loop", 0, 100)
    bars("closed_loop", 40, 100)
    bars("closed_loop", 100, 100)
    assert len(fake_tqdm) == 1 and fake_tqdm[0].updates == [0, 40, 100] and fake_tqdm[0].closed
    assert fake_tqdm[0].kwargs["desc"] == "physics, closed loop"
    with JobBars(True) as bars:
        bars("plan", 0.0, 5.0)
        time.sleep(0.25)
        timed = bars._bars["plan"]
        assert isinstance(timed, TimedBar) and timed._thread is not None and timed._thread.is_alive()
        bars("open_loop", 0, 10)  # left open: closed by the context manager
    assert all(b.closed for b in fake_tqdm)
    assert timed._thread is None
    silent = JobBars(False)
    silent("plan", 0.0, 5.0)
    silent("closed_loop", 0, 10)
    assert len(fake_tqdm) == 3 and not silent._bars


def test_timed_bar_fills_with_elapsed_time_and_stops(fake_tqdm: list[FakeBar]) -> None:
    t0 = time.perf_counter()
    with TimedBar("planning", 0.3, interval=0.02):
        time.sleep(0.5)
    wall = time.perf_counter() - t0
    (bar,) = fake_tqdm
    assert bar.closed and bar.updates
    assert all(b >= a for a, b in pairwise(bar.updates))
    assert bar.n == pytest.approx(0.3)  # capped at the budget
    assert wall < 1.0
    with TimedBar("planning", 0.3, enabled=False) as off:
        assert off._thread is None
    assert len(fake_tqdm) == 1


def test_bars_only_on_a_terminal_and_never_with_quiet(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    tty = type("Tty", (), {"isatty": staticmethod(lambda: True)})()
    monkeypatch.setattr(sys, "stdout", tty)
    monkeypatch.setattr(sys, "stderr", tty)
    assert show_progress(argparse.Namespace(quiet=False))
    assert not show_progress(argparse.Namespace(quiet=True))
    monkeypatch.setattr(sys, "stderr", type("Log", (), {"isatty": staticmethod(lambda: False)})())
    assert not show_progress(argparse.Namespace(quiet=False))
