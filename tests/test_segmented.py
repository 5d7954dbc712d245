"""The segmented tracker: bounded finite commands, and closed-loop kinematic runs
(an independent fine-step RK4 unicycle) through cusps and turns in place at 50 Hz and 10 Hz."""

import math
import re

import numpy as np
import pytest

from control.base import MAX_CONTROL_PERIODS, TRACKERS, make_tracker, tracker_factory
from control.segmented import SegmentedParams, SegmentedTracker
from control.switching import SWITCHING_FIELDS, PerSegmentTracker
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.core.world import World
from planning.errors import ConfigError, SimulationError
from planning.trajectory.from_plan import to_trajectory
from planning.trajectory.trajectory import Trajectory
from tests import reference_laws

OPEN = World((-3.0, 3.0, -3.0, 3.0), ())
CUSP_TURN = np.vstack([
    np.column_stack([np.linspace(0, 0.8, 17), np.zeros(17), np.zeros(17)]),
    np.column_stack([0.8 - 0.4 * np.sin(a := np.linspace(0, np.pi / 2, 21)[1:]), 0.4 - 0.4 * np.cos(a), -a]),
    np.array([[0.4, 0.4, -np.pi / 2 + 1.0], [0.4, 0.4, -np.pi / 2 + 2.0]]),
    np.column_stack([0.4 + 0.5 * np.cos(-np.pi / 2 + 2.0) * np.linspace(0, 1, 11)[1:],
                     0.4 + 0.5 * np.sin(-np.pi / 2 + 2.0) * np.linspace(0, 1, 11)[1:], np.full(10, -np.pi / 2 + 2.0)]),
])  # fmt: skip


def simulate(tracker: SegmentedTracker, traj: Trajectory, rate: float, start: Pose2D, hold: float = 2.0) -> np.ndarray:
    """Unicycle under zero-order-held commands, integrated by RK4 at 1 ms (independent of the code)."""
    dt = 1.0 / rate
    tracker.reset(traj, dt)
    x = np.array([start.x, start.y, start.theta])
    sub = round(dt / 0.001)
    h = dt / sub
    out = [x.copy()]
    for k in range(math.ceil((traj.duration + hold) / dt)):
        v, w = tracker.command(traj.t[0] + k * dt, *x)
        assert math.isfinite(v) and math.isfinite(w)
        assert abs(v) <= tracker.robot.max_speed and abs(w) <= tracker.robot.max_yaw_rate
        f = lambda s, v=v, w=w: np.array([v * math.cos(s[2]), v * math.sin(s[2]), w])
        for _ in range(sub):
            k1 = f(x)
            k2 = f(x + 0.5 * h * k1)
            k3 = f(x + 0.5 * h * k2)
            k4 = f(x + h * k3)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(x.copy())
    return np.array(out)


def test_registered_and_commands_stay_finite_and_bounded_for_any_pose() -> None:
    robot = load_robot("edumip")
    tracker = make_tracker("segmented", robot)
    traj = to_trajectory(CUSP_TURN, robot, OPEN)
    tracker.reset(traj, 0.02)
    rng = np.random.default_rng(1)
    for k in range(2000):
        t = float(rng.uniform(-1, traj.duration + 5)) if k % 2 else k * 0.02
        pose = rng.normal(0, [5, 5, 10])
        v, w = tracker.command(t, *pose)
        assert math.isfinite(v) and math.isfinite(w)
        assert abs(v) <= robot.max_speed and abs(w) <= robot.max_yaw_rate


@pytest.mark.parametrize("rate,tol", [(50.0, 0.005), (10.0, 0.02)])
@pytest.mark.parametrize("name", ["turtlebot3", "edumip"])
def test_cusps_and_turns_in_place_are_tracked_to_the_goal(name: str, rate: float, tol: float) -> None:
    robot = load_robot(name)
    goal = Pose2D(CUSP_TURN[-1, 0], CUSP_TURN[-1, 1], 0.3)
    traj = to_trajectory(CUSP_TURN, robot, OPEN, goal=goal)
    assert {"forward", "reverse", "rotate"} <= set(traj.segment_kinds)
    # start 1 cm off and a little turned: the feedback must remove it
    states = simulate(SegmentedTracker(robot), traj, rate, Pose2D(0.0, 0.01, 0.02))
    final = states[-1]
    assert math.hypot(final[0] - goal.x, final[1] - goal.y) < tol
    assert abs(math.remainder(final[2] - goal.theta, 2 * math.pi)) < 0.05
    ref = traj.sample_many(traj.t[0] + np.arange(states.shape[0]) / rate)
    err = np.hypot(states[:, 0] - ref.x, states[:, 1] - ref.y)
    assert np.sqrt(np.mean(err**2)) < max(tol, 0.01)


@pytest.mark.parametrize("name", sorted(TRACKERS))  # the open-loop player too (it raised ValueError for t = NaN)
@pytest.mark.parametrize("bad", [(math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (0.0, 0.0, math.nan)])
def test_a_non_finite_pose_is_refused_by_every_tracker(name: str, bad: tuple[float, float, float]) -> None:
    robot = load_robot("edumip")
    tracker = make_tracker(name, robot)
    tracker.reset(to_trajectory(CUSP_TURN, robot, OPEN), 0.02)
    tracker.command(0.0, 0.0, 0.0, 0.0)
    with pytest.raises(SimulationError, match=rf"tracker '{name}' was given a non-finite pose.*at t=0\.100 s"):
        tracker.command(0.1, *bad)
    # a NaN time is the caller's clock, not the pose (the message blamed a pose of zeros)
    with pytest.raises(SimulationError, match=rf"tracker '{name}' was given a non-finite time t=nan s.*clock"):
        tracker.command(math.nan, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("name", sorted(TRACKERS))
def test_a_command_argument_that_is_no_number_is_named_by_every_tracker(name: str) -> None:
    """An array for x was "TypeError: bad argument type for built-in operation" (compiled trackers) or
    "only 0-dimensional arrays can be converted" (mpc, open-loop); a text or a 0-d array the compiled
    trackers took as the number it holds, where mpc and open-loop refused it."""
    robot = load_robot("edumip")
    tracker = make_tracker(name, robot)
    tracker.reset(to_trajectory(CUSP_TURN, robot, OPEN), 0.02)
    for args, field, got in [
        ((0.0, np.array([0.0, 1.0]), 0.0, 0.0), "x", r"ndarray of shape \(2,\)"),
        ((None, 0.0, 0.0, 0.0), "t", "None"),
        (("0.02", 0.0, 0.0, 0.0), "t", "'0.02'"),
        ((0.02, 0.0, 0.0, np.array(0.0)), "theta", r"a 0-d numpy array \(array\(0\.\)\); pass float\(x\)"),
    ]:
        with pytest.raises(
            ConfigError, match=rf"tracker '{name}': command\(t, x, y, theta\)'s {field} must be a number, got {got}"
        ):
            tracker.command(*args)  # type: ignore[arg-type]
    assert all(math.isfinite(c) for c in tracker.command(np.float64(0.02), 0, np.float32(0.0), 0.0))  # numbers


@pytest.mark.parametrize("name", sorted(TRACKERS))
def test_reset_refuses_what_is_not_a_trajectory(name: str) -> None:
    """None or a path array was "AttributeError: ... has no attribute 'duration'"."""
    tracker = make_tracker(name, load_robot("edumip"))
    with pytest.raises(
        ConfigError, match=rf"tracker '{name}': reset\(trajectory, dt\)'s trajectory must be a Trajectory.*got None$"
    ):
        tracker.reset(None, 0.02)  # type: ignore[arg-type]
    with pytest.raises(
        ConfigError, match=r"got ndarray of shape \(17, 3\); a path of poses becomes one with to_trajectory"
    ):
        tracker.reset(CUSP_TURN[:17], 0.02)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", sorted(TRACKERS))  # the open-loop player took any dt (0: ZeroDivisionError)
@pytest.mark.parametrize("dt", [0.0, -0.02, math.nan, math.inf])
def test_reset_refuses_a_bad_control_period(name: str, dt: float) -> None:
    robot = load_robot("edumip")
    with pytest.raises(ConfigError, match=rf"tracker '{name}': reset\(dt\).*> 0 \(s\), got {dt!r}; pass 1 / control"):
        make_tracker(name, robot).reset(to_trajectory(CUSP_TURN, robot, OPEN), dt)


@pytest.mark.parametrize("name", sorted(TRACKERS))
def test_reset_refuses_a_period_too_small_for_the_trajectory(name: str) -> None:
    """A period of 1e-300 s used to make reset allocate 1e301 samples (MemoryError or ValueError)."""
    robot = load_robot("edumip")
    traj = to_trajectory(CUSP_TURN, robot, OPEN)
    periods = traj.duration / 1e-300
    with pytest.raises(
        ConfigError,
        match=rf"tracker '{name}': reset\(dt=1e-300 s\).*makes {re.escape(f'{periods:.3g}')} control periods",
    ):
        make_tracker(name, robot).reset(traj, 1e-300)
    assert MAX_CONTROL_PERIODS == 1_000_000
    make_tracker(name, robot).reset(traj, traj.duration / 1000)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("heading_gain", math.nan, "a finite number"),
        ("xi_blend", 0.0, "a finite number > 0, got 0.0; xi_blend divides"),
        ("hold_speed", -0.1, "a finite number > 0, got -0.1"),
    ],
)
def test_segmented_params_are_checked(field: str, value: float, message: str) -> None:
    with pytest.raises(ConfigError, match=rf"SegmentedParams\.{field} must be {message}"):
        SegmentedParams(**{field: value})


def _python_reference(name: str, tracker: PerSegmentTracker, traj: Trajectory, dt: float) -> reference_laws.Switcher:
    """The plain-Python switcher with the plain-Python drive law of a registered per-segment tracker."""
    opts = tracker.__dict__
    drives = {
        "segmented": lambda: reference_laws.segmented_drive(opts["gains"], opts["params"]),
        "kanayama": lambda: reference_laws.kanayama_drive(opts["params"]),
        "rpp": lambda: reference_laws.rpp_drive(opts["params"], tracker.turns),
    }
    t0, goal = float(traj.t[0]), traj.pose[-1].tolist()
    return reference_laws.Switcher(
        tracker._ref, t0, dt, goal, tracker.robot, tracker.turns, drives[name](), smoothed=type(tracker).SMOOTHED
    )


@pytest.mark.parametrize("name", ["segmented", "kanayama", "rpp", "rpp-tight-cut"])
def test_a_compiled_period_is_the_python_reference_bit_for_bit(name: str) -> None:
    """Along a plan with a cusp and a turn in place, from noisy poses, past the end and before the
    start, a per-segment tracker's compiled period (control/switching.py and its drive law) gives
    what the plain-Python reference (tests/reference_laws.py) gives, command and state, bit for bit."""
    robot = load_robot("turtlebot3")
    traj = to_trajectory(CUSP_TURN, robot, OPEN)
    if name == "rpp-tight-cut":  # RPP's corner bound shortening the lookahead on most of this plan's turns
        from control.rpp import RPPParams

        name, options = "rpp", {"params": RPPParams(max_cut=0.001, min_lookahead=0.03)}
    else:
        options = {}
    tracker = make_tracker(name, robot, **options)
    assert isinstance(tracker, PerSegmentTracker)
    tracker.reset(traj, 0.02)
    python = _python_reference(name, tracker, traj, 0.02)
    assert {"forward", "reverse", "rotate"} <= set(traj.segment_kinds)
    rng = np.random.default_rng(4)
    n = math.ceil(traj.duration / 0.02) + 20
    drives = 0
    for k in range(-3, n):
        t = float(traj.t[0]) + k * 0.02
        ref = traj.sample(min(max(t, float(traj.t[0])), float(traj.t[-1]))).pose
        pose = (float(ref[0] + rng.normal(0, 0.02)), float(ref[1] + rng.normal(0, 0.02)), float(ref[2] + 0.1))
        assert tracker.command(t, *pose) == python.command(t, *pose), k
        s = tracker.state[0]  # type: ignore[index]
        assert (int(s["segment"]), bool(s["rested"])) == (python.segment, python.rested), k
        for field, value in python.memory.items():
            assert s[field] == value, (k, field)
        drives += not python.rested
    assert tracker.segment == python.segment == len(traj.segment_kinds) - 1
    assert 0.5 * n < drives < n  # most periods were drives, the others were not


def per_segment_trackers() -> list[str]:
    """The registered trackers that switch law per segment (control/switching.py)."""
    return [n for n in sorted(TRACKERS) if issubclass(tracker_factory(n), PerSegmentTracker)]  # type: ignore[arg-type]


@pytest.mark.parametrize("name", per_segment_trackers())
def test_the_compiled_switching_is_the_python_switching_for_every_registered_law(name: str) -> None:
    """Every registered per-segment tracker, its own compiled drive law given to the plain-Python
    switching (tests/reference_laws.py) on a copy of its state: the same commands, segment and law
    state as its compiled period, bit for bit, along a cusp-and-turn plan from noisy poses, before
    the start and past the end. (A new tracker is checked here by registering it.)"""
    robot = load_robot("edumip")
    traj = to_trajectory(CUSP_TURN, robot, OPEN)
    tracker = make_tracker(name, robot)
    assert isinstance(tracker, PerSegmentTracker)
    tracker.reset(traj, 0.05)
    assert tracker.state is not None
    record, law = tracker.state.copy(), type(tracker).DRIVE
    own = [f for f in record.dtype.names if f not in dict(SWITCHING_FIELDS)]

    def drive(sw: reference_laws.Switcher, k: int, x: float, y: float, theta: float, enter: bool, rested: bool):
        return law(record[0], tracker._ref, k, x, y, theta, enter, rested)

    t0, goal = float(traj.t[0]), traj.pose[-1].tolist()
    python = reference_laws.Switcher(tracker._ref, t0, 0.05, goal, robot, tracker.turns, drive, type(tracker).SMOOTHED)
    rng = np.random.default_rng(5)
    for k in range(-2, math.ceil(traj.duration / 0.05) + 10):
        t = t0 + k * 0.05
        ref = traj.sample(min(max(t, t0), float(traj.t[-1]))).pose
        pose = (float(ref[0] + rng.normal(0, 0.03)), float(ref[1] + rng.normal(0, 0.03)), float(ref[2] - 0.2))
        assert tracker.command(t, *pose) == python.command(t, *pose), k
        assert (tracker.segment, bool(tracker.state[0]["rested"])) == (python.segment, python.rested), k
        assert [tracker.state[0][f] for f in own] == [record[0][f] for f in own], k
    assert tracker.segment == len(traj.segment_kinds) - 1
