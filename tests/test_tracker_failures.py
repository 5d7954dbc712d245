"""A tracker that fails stops the run with one SimulationError naming it and the time, whatever it is built on.

A law's non-finite command (NaN or infinite) is no stop: a per-segment tracker's (control/switching.py)
reaches the simulator as a tracker's written from scratch does, and both end the run with the same
message. A tracker's ``command`` that raises (a plugin's bug) is one line naming the tracker, who registered
it, the time and the exception, chained to it; a tracker's own NhsimError passes as it is.
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np
import pytest

from control.base import TRACKERS, register_tracker
from control.switching import PerSegmentTracker, SegmentedParams, period, reference_table, state_dtype
from planning.core.geometry import Pose2D
from planning.core.robot import RobotSpec, load_robot
from planning.errors import ConfigError, SimulationError
from planning.trajectory.references import make_reference
from planning.trajectory.trajectory import Trajectory
from sim.physics.simulator import SimConfig, Simulator

#: Distance along the reference [m] beyond which the failing laws below go wrong.
AFTER = 0.3
#: The control period of the runs [s] (SimConfig's default rate, 50 Hz).
DT = 0.02


@nb.njit(cache=True)
def bad_drive(
    s: Any, ref: Any, k: int, x: float, y: float, theta: float, enter: bool, rested: bool
) -> tuple[float, float]:  # pragma: no cover - compiled
    """The reference's inputs, then ``s.bad`` for both beyond ``s.after`` metres along the reference."""
    r = ref[k]
    return (s.bad, s.bad) if r.arc > s.after else (r.v, r.omega)


@nb.njit(cache=True)
def _bad_period(state: Any, ref: Any, t: float, x: float, y: float, theta: float) -> tuple[int, float, float]:
    return period(state, ref, t, x, y, theta, bad_drive)  # pragma: no cover - compiled


class BadLaw(PerSegmentTracker):
    """A per-segment tracker whose drive law returns ``bad`` (NaN, an infinity) beyond AFTER metres."""

    name = "bad-law"
    STATE = state_dtype([("bad", "f8"), ("after", "f8")])
    DRIVE = staticmethod(bad_drive)
    PERIOD = staticmethod(_bad_period)

    def __init__(self, robot: RobotSpec, *, bad: float = math.nan, smoothed: bool = False) -> None:
        self.bad = bad
        self.SMOOTHED = smoothed  # type: ignore[misc]  # Kanayama's and RPP's smoothing, or none
        super().__init__(robot, SegmentedParams())

    def law_values(self) -> dict[str, float]:
        return {"bad": self.bad, "after": AFTER}


class RawBadLaw:
    """The same law written from scratch (no segment switching): the reference's inputs, then ``bad``."""

    name = "raw-bad-law"

    def __init__(self, robot: RobotSpec, *, bad: float = math.nan) -> None:
        self.bad = bad

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        self._ref = reference_table(trajectory, dt, math.ceil(trajectory.duration / dt) + 1)
        self._t0, self._dt = float(trajectory.t[0]), dt

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        r = self._ref[min(round((t - self._t0) / self._dt), self._ref.size - 1)]
        return (self.bad, self.bad) if r["arc"] > AFTER else (float(r["v"]), float(r["omega"]))


class Boom:
    """A tracker whose ``command`` raises ``error`` (a plugin's bug, or its own refusal) from ``after`` s on."""

    name = "boom"

    def __init__(self, robot: RobotSpec, *, error: Exception | None = None, after: float = 0.5) -> None:
        self.error, self.after = error, after
        self.raised_at: float | None = None
        self._traj: Trajectory | None = None

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        self._traj = trajectory

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        assert self._traj is not None
        if t >= self.after:
            self.raised_at = t
            if self.error is not None:
                raise self.error
            return self._traj.gains  # type: ignore[attr-defined, no-any-return]  # AttributeError: no such field
        s = self._traj.sample_many(np.array([t]))
        return float(s.v[0]), float(s.omega[0])


@pytest.fixture(scope="module")
def line() -> tuple[Simulator, Trajectory]:
    robot = load_robot("turtlebot3")
    return Simulator(robot), make_reference("line", robot, Pose2D(0.0, 0.0, 0.0))


def _registered(monkeypatch: pytest.MonkeyPatch, name: str, factory: Any) -> str:
    """``factory`` registered as ``name`` for one test (the registry restored afterwards)."""
    monkeypatch.setitem(TRACKERS, name, "")  # undone after the test
    register_tracker(name, factory, replace=True)  # over the placeholder above
    return name


def _first_instant_beyond(trajectory: Trajectory) -> float:
    """The first control instant whose reference point lies beyond AFTER metres along the path [s]
    (in a drive: where the per-segment law runs)."""
    table = reference_table(trajectory, DT, math.ceil(trajectory.duration / DT) + 1)
    k = int(np.argmax(table["arc"] > AFTER))
    assert table["arc"][k] > AFTER and table["sign"][k] != 0.0  # the line's drive reaches it
    return float(trajectory.t[0]) + k * DT


@pytest.mark.parametrize(
    ("factory", "bad", "smoothed"),
    [(BadLaw, math.nan, False), (BadLaw, math.inf, False), (BadLaw, math.inf, True), (RawBadLaw, math.nan, None)],
    ids=["per-segment-nan", "per-segment-inf", "per-segment-smoothed-inf", "from-scratch-nan"],
)
def test_a_laws_non_finite_command_stops_the_run_naming_the_tracker_and_the_time(
    line: tuple[Simulator, Trajectory], factory: Any, bad: float, smoothed: bool | None
) -> None:
    """Per-segment or from scratch, the same error: no stop in its place (the run went on to a 1.35 m final
    error, said nowhere), nor an infinity clamped to full speed."""
    simulator, trajectory = line
    options = {"smoothed": smoothed} if smoothed is not None else {}
    tracker = factory(simulator.robot, bad=bad, **options)
    with pytest.raises(SimulationError) as info:
        simulator.run(trajectory, tracker, SimConfig(control_rate=1.0 / DT))
    t = _first_instant_beyond(trajectory)
    shown = f"({bad}, {bad})"
    assert str(info.value).startswith(
        f"tracker {tracker.name!r} returned a non-finite command {shown} at t={t:.3f} s: "
    ), str(info.value)


def test_a_registered_per_segment_trackers_nan_fails_its_own_row_of_compare(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Any
) -> None:
    """``nhsim compare`` exits 1 naming the tracker, the time and the command, where it exited 0 on the stop the
    switching made of the NaN; and the other trackers are still compared (one tracker's failure dropped every
    row: ``compare: simulation failed`` and nothing else)."""
    import json

    from sim.cli.main import main

    name = _registered(monkeypatch, BadLaw.name, BadLaw)
    record = tmp_path / "c.json"
    argv = ["compare", "--reference", "line", "--trackers", f"fbl,{name}", "--quiet", "--json", str(record)]
    assert main(argv) == 1
    out, err = capsys.readouterr()
    t = _first_instant_beyond(make_reference("line", load_robot("turtlebot3"), Pose2D(0.0, 0.0, 0.0)))
    why = f"tracker 'bad-law' returned a non-finite command (nan, nan) at t={t:.3f} s: "
    assert f"bad-law run 0: failed: {why}" in out, out
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines() if line.startswith(("fbl ", "bad-law  "))}
    assert err.startswith(f"nhsim compare: simulation failed: {why}") and err.count("\n") == 1, err
    assert rows["bad-law"][0] == "failed" and float(rows["fbl"][0]) < 0.05, out  # fbl's final error [m]
    assert "Traceback" not in err
    trackers = json.loads(record.read_text())["trackers"]
    assert trackers["bad-law"]["summary"] == {"failed_runs": 1.0}
    assert trackers["bad-law"]["runs"][0]["status"] == "failed" and trackers["bad-law"]["runs"][0]["error"].startswith(
        why
    )
    assert trackers["fbl"]["runs"][0]["status"] == "ok"


def test_a_trackers_python_exception_is_one_error_naming_it_the_time_and_the_exception(
    line: tuple[Simulator, Trajectory], monkeypatch: pytest.MonkeyPatch
) -> None:
    simulator, trajectory = line
    _registered(monkeypatch, "boom", Boom)
    tracker = Boom(simulator.robot)
    with pytest.raises(SimulationError) as info:
        simulator.run(trajectory, tracker)
    assert tracker.raised_at is not None
    cause = info.value.__cause__
    assert isinstance(cause, AttributeError) and "gains" in str(cause)  # chained, with its traceback
    assert str(info.value).startswith(
        f"tracker 'boom' (registered by this program's own code) raised AttributeError in command(t, x, y, theta) "
        f"at t={tracker.raised_at:.3f} s: {cause}; "
    ), str(info.value)


def test_a_tracker_made_by_hand_is_named_without_a_registration() -> None:
    robot = load_robot("turtlebot3")
    tracker = Boom(robot, error=KeyError("row"), after=0.2)
    with pytest.raises(SimulationError) as info:
        Simulator(robot).run(make_reference("line", robot, Pose2D(0.0, 0.0, 0.0)), tracker)
    assert info.value.__cause__ is tracker.error and tracker.raised_at is not None
    assert str(info.value).startswith(
        f"tracker 'boom' raised KeyError in command(t, x, y, theta) at t={tracker.raised_at:.3f} s: 'row'; "
    ), str(info.value)


def test_a_trackers_own_nhsim_error_passes_as_it_is(line: tuple[Simulator, Trajectory]) -> None:
    simulator, trajectory = line
    refusal = ConfigError("tracker 'boom': its table is empty; give it a table")
    with pytest.raises(ConfigError) as info:
        simulator.run(trajectory, Boom(simulator.robot, error=refusal))
    assert info.value is refusal


def test_a_trackers_exception_fails_compare_with_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Any
) -> None:
    """One line, as a failing planner's, not a traceback; with no run but failed ones, no output is written (the plots
    said "nothing to render", exit 2)."""
    from sim.cli.main import main

    _registered(monkeypatch, "boom", Boom)
    record = tmp_path / "c.json"
    assert main(["compare", "--reference", "line", "--trackers", "boom", "--quiet", "--json", str(record)]) == 1
    assert not record.exists()
    err = capsys.readouterr().err
    assert err.startswith(
        "nhsim compare: simulation failed: tracker 'boom' (registered by this program's own code) raised "
        "AttributeError in command(t, x, y, theta) at t=0.500 s: "
    ), err
    assert err.count("\n") == 1 and "Traceback" not in err


class BadReset(Boom):
    """A tracker whose ``reset`` fails (a plugin's bug in reading the trajectory)."""

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        raise IndexError("index 3 is out of bounds for axis 0 with size 3")


def test_a_trackers_reset_that_raises_is_one_error_naming_it(line: tuple[Simulator, Trajectory]) -> None:
    simulator, trajectory = line
    with pytest.raises(SimulationError) as info:
        simulator.run(trajectory, BadReset(simulator.robot))
    assert isinstance(info.value.__cause__, IndexError)
    assert str(info.value) == (
        "tracker 'boom' raised IndexError in reset(trajectory, dt): index 3 is out of bounds for axis 0 with size 3; "
        "fix the tracker's reset (the exception is chained to this error, as __cause__, with its traceback)"
    )


class Returns:
    """A tracker whose ``command`` returns ``out`` from ``after`` s on (the reference's inputs before)."""

    name = "returns"

    def __init__(self, out: object, after: float = 0.0) -> None:
        self.out, self.after = out, after
        self._traj: Trajectory | None = None

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        self._traj = trajectory

    def command(self, t: float, x: float, y: float, theta: float) -> Any:
        assert self._traj is not None
        if t >= self.after:
            return self.out
        s = self._traj.sample_many(np.array([t]))
        return float(s.v[0]), float(s.omega[0])


@pytest.mark.parametrize(
    ("out", "after", "shown"),
    [
        (None, 0.0, "None (NoneType)"),
        ((0.1, 0.0, 0.0), 0.0, "(0.1, 0.0, 0.0) (tuple)"),
        ((0.1 + 0j, 0.0), 0.0, "((0.1+0j), 0.0) (tuple)"),
        (("0.1", "0.0"), 0.0, "('0.1', '0.0') (tuple)"),
        (0.1, 0.5, "0.1 (float)"),
    ],
    ids=["none", "three", "complex", "text", "one-number-later"],
)
def test_a_command_that_is_not_two_numbers_stops_the_run_naming_what_it_returned(
    line: tuple[Simulator, Trajectory], out: object, after: float, shown: str
) -> None:
    """A tracker returning None, three numbers or complex ones ended in a traceback of the unpacking or of the
    compiled call ("bad argument type for built-in operation"); one returning text was driven as numbers."""
    simulator, trajectory = line
    with pytest.raises(SimulationError) as info:
        simulator.run(trajectory, Returns(out, after), SimConfig(control_rate=1.0 / DT))
    t = math.ceil(after / DT - 1e-9) * DT
    assert str(info.value) == (
        f"tracker 'returns' returned {shown} from command(t, x, y, theta) at t={t:.3f} s: a command must be two "
        "real numbers (v [m/s], omega [rad/s]), e.g. a tuple of floats; fix the tracker's command"
    )
    assert isinstance(info.value.__cause__, TypeError | ValueError)
