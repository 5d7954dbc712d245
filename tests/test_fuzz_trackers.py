"""Property-based tests of every registered tracker's inputs.

Drawn: a robot; a trajectory (an analytic reference with drawn options, good or bad, or a raw
trajectory of random samples, with or without segment labels); a control period (good, or zero,
negative, non-finite, absurdly small, not a number); options (gain sets and parameter sets with
drawn values, wrong types, unknown names); then a sequence of commands at control instants and at
odd times, with measured poses near the reference or anywhere, some of them NaN or infinite.

Properties: every call returns or raises an NhsimError, nothing else; every command is two finite
floats, within the robot's |v| and |omega| limits for the feedback trackers; a non-finite time or
measured pose is refused with SimulationError by every tracker; the open-loop player
sends the reference input at the middle of the control period.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import typing
from typing import Any

import numpy as np
from hypothesis import event
from hypothesis import strategies as st

from control.base import TRACKERS, feedback_trackers, make_tracker, tracker_factory, tracker_options
from control.gains import FBLGains
from control.segmented import SegmentedParams
from planning.core.geometry import Pose2D
from planning.core.robot import ROBOTS, RobotSpec, load_robot
from planning.errors import SimulationError
from planning.trajectory.references import REFERENCES, make_reference
from planning.trajectory.trajectory import SEGMENT_KINDS, Trajectory
from tests.fuzz_helpers import BAD_NUMBER, NON_FINITE, coordinate, expect_nhsim_errors, fast_and_slow, maybe_bad


@functools.cache
def robot(name: str) -> RobotSpec:
    """A robot, read once."""
    return load_robot(name)


@dataclasses.dataclass
class TrackerCase:
    """One drawn tracking problem: how to build each input, and the commands to send."""

    tracker: str
    robot: str
    trajectory: Any  # a callable that builds the trajectory
    dt: Any
    options: dict[str, Any]
    calls: list[tuple[float, float, float, float]]
    describe: str = ""

    def __repr__(self) -> str:
        return (
            f"TrackerCase({self.tracker!r}, {self.robot!r}, {self.describe}, dt={self.dt!r}, "
            f"options={self.options!r}, calls={self.calls!r})"
        )


def _number(lo: float, hi: float) -> st.SearchStrategy[Any]:
    """A number in [lo, hi], or about one time in sixteen a bad one."""
    return maybe_bad(st.floats(lo, hi), BAD_NUMBER, 16)


@st.composite
def reference(draw: st.DrawFn) -> tuple[Any, str]:
    """An analytic reference with drawn options (some bad), built on demand."""
    name = draw(st.sampled_from(sorted(REFERENCES)))
    size_key = {"line": "length", "circle": "radius", "figure8": "size"}[name]
    options = draw(
        st.fixed_dictionaries(
            {},
            optional={
                size_key: _number(0.05, 3.0),
                "margin": _number(0.1, 1.0),
                "dt": maybe_bad(st.floats(0.002, 0.05), st.sampled_from([0.0, -0.01, math.nan, math.inf, 1e-12]), 16),
                **({"laps": _number(0.1, 2.0)} if name != "line" else {}),
            },
        )
    )
    start = (draw(coordinate()), draw(coordinate()), draw(st.floats(-10, 10)))
    return (lambda rb: make_reference(name, rb, Pose2D(*start), **options)), f"{name}{options}@{start}"


@st.composite
def raw_trajectory(draw: st.DrawFn) -> tuple[Any, str]:
    """A trajectory of random samples (times strictly increasing), labelled with segments or not."""
    n = draw(st.integers(2, 25))
    steps = draw(
        st.lists(st.one_of(st.floats(1e-3, 2.0), st.sampled_from([1e-9, 50.0])), min_size=n - 1, max_size=n - 1)
    )
    t = draw(st.floats(-100, 100)) + np.concatenate([[0.0], np.cumsum(steps)])
    rows = st.lists(st.floats(-5, 5), min_size=n, max_size=n)
    pose = np.column_stack([draw(rows) for _ in range(3)])
    vel = np.column_stack([draw(rows) for _ in range(2)])
    acc = np.column_stack([draw(rows) for _ in range(2)])
    segments, kinds = None, ()
    if draw(st.booleans()):
        cuts = sorted(draw(st.lists(st.integers(1, n - 1), max_size=3, unique=True)))
        segments = np.searchsorted(cuts, np.arange(n), side="right")
        kinds = tuple(draw(st.sampled_from(SEGMENT_KINDS)) for _ in range(len(cuts) + 1))
    traj = Trajectory(t, pose, vel, acc, segments=segments, segment_kinds=kinds)
    return (lambda rb: traj), f"raw(n={n}, span=[{t[0]:g}, {t[-1]:g}], kinds={kinds})"


def _gains() -> st.SearchStrategy[Any]:
    fields = st.fixed_dictionaries({}, optional={k: _number(0.01, 50.0) for k in ("kp", "kd", "xi_min")})
    return maybe_bad(
        st.one_of(st.none(), fields.map(lambda kw: ("FBLGains", kw))), st.sampled_from(["9,6", {"kp": 9.0}, 3])
    )


def _params() -> st.SearchStrategy[Any]:
    names = ("heading_gain", "along_gain", "xi_blend", "hold_speed")
    fields = st.fixed_dictionaries({}, optional={k: _number(0.001, 10.0) for k in names})
    return maybe_bad(
        st.one_of(st.none(), fields.map(lambda kw: ("SegmentedParams", kw))), st.sampled_from([(), "fast"])
    )


def _options(tracker: str) -> st.SearchStrategy[dict[str, Any]]:
    """Keyword options for ``tracker``: its own (gains, params), and about one time in sixteen an unknown one."""
    drawn = {FBLGains: _gains, SegmentedParams: _params}  # option types drawn field by field
    hints = typing.get_type_hints(tracker_factory(tracker).__init__)  # type: ignore[misc]
    optional: dict[str, st.SearchStrategy[Any]] = {}
    for option in tracker_options(tracker):
        kinds = [kind for kind in drawn if kind in typing.get_args(hints.get(option)) or kind is hints.get(option)]
        if kinds:
            optional[option] = drawn[kinds[0]]()
    unknown = maybe_bad(st.just({}), st.just({"warp": 1}), 16)
    return st.tuples(st.fixed_dictionaries({}, optional=optional), unknown).map(lambda kv: {**kv[0], **kv[1]})


def _build_option(value: Any) -> Any:
    """A drawn option value: ("FBLGains", fields) and ("SegmentedParams", fields) are built (which may
    raise ConfigError)."""
    if isinstance(value, tuple) and len(value) == 2 and value[0] in ("FBLGains", "SegmentedParams"):
        return (FBLGains if value[0] == "FBLGains" else SegmentedParams)(**value[1])
    return value


@st.composite
def tracker_cases(draw: st.DrawFn) -> TrackerCase:
    """A tracker, a robot, a trajectory, a period, options and the commands to send."""
    tracker = draw(st.sampled_from(sorted(TRACKERS)))
    build, describe = draw(st.one_of(reference(), raw_trajectory()))
    dt = draw(maybe_bad(st.floats(1e-3, 0.5), st.one_of(BAD_NUMBER, st.sampled_from([1e-300, 1e-12]))))
    step = dt if isinstance(dt, float) and math.isfinite(dt) and dt > 0 else 0.02
    ks = draw(st.lists(st.integers(-3, 4000), min_size=1, max_size=25))
    odd = st.one_of(NON_FINITE, st.floats(-1e6, 1e6), st.just(1e300))
    calls = []
    for k in sorted(ks):
        t = draw(maybe_bad(st.just(float("nan")), odd, 10)) if draw(st.integers(0, 9)) == 0 else k * step
        pose = [draw(maybe_bad(coordinate(-50, 50), st.one_of(NON_FINITE, st.just(1e200)), 20)) for _ in range(3)]
        calls.append((t, *pose))
    return TrackerCase(
        tracker, draw(st.sampled_from(sorted(ROBOTS))), build, dt, draw(_options(tracker)), calls, describe
    )


def _start(case: TrackerCase) -> tuple[Any, RobotSpec, Trajectory | None]:
    """The tracker reset on the case's trajectory, or None where a bad input was refused."""
    rb = robot(case.robot)
    traj, err = expect_nhsim_errors(lambda: case.trajectory(rb))
    if err is not None:
        event("refused", "trajectory")
        return None, rb, None
    options, err = expect_nhsim_errors(lambda: {k: _build_option(v) for k, v in case.options.items()})
    if err is None:
        tracker, err = expect_nhsim_errors(lambda: make_tracker(case.tracker, rb, **options))
    if err is None:
        _, err = expect_nhsim_errors(lambda: tracker.reset(traj, case.dt))
    if err is not None:
        event("refused", "options or period")
        return None, rb, traj
    return tracker, rb, traj


def tracker_property(case: TrackerCase) -> None:
    """Only NhsimErrors; finite commands within the limits; non-finite input refused."""
    tracker, rb, traj = _start(case)
    if tracker is None:
        return
    shifted = float(traj.t[0])
    for t, x, y, theta in case.calls:
        t = t + shifted
        cmd, err = expect_nhsim_errors(lambda t=t, x=x, y=y, theta=theta: tracker.command(t, x, y, theta))
        if not all(map(math.isfinite, (t, x, y, theta))):
            assert isinstance(err, SimulationError), f"non-finite input at t={t} gave {cmd!r} / {err!r}"
            event("refused", "non-finite input")
            return
        assert err is None, f"{type(err).__name__} for finite input: {err}"
        assert isinstance(cmd, tuple) and len(cmd) == 2 and all(isinstance(c, float) for c in cmd), cmd
        v, w = cmd
        assert math.isfinite(v) and math.isfinite(w), (t, cmd)
        if case.tracker in feedback_trackers():  # every feedback tracker keeps the limits
            assert abs(v) <= rb.max_speed and abs(w) <= rb.max_yaw_rate, (t, cmd)
        else:  # the open-loop player: the reference input at the middle of the period
            ref = traj.sample_many(np.array([t + 0.5 * float(case.dt)]))
            assert math.isclose(v, float(ref.v[0]), abs_tol=1e-9) and math.isclose(w, float(ref.omega[0]), abs_tol=1e-9)
    event("ran", case.tracker)


test_trackers_fast, test_trackers_slow = fast_and_slow(tracker_cases(), tracker_property)


def test_every_tracker_is_drawn() -> None:
    """The strategy reaches every registered tracker (a new one is fuzzed without editing this file)."""
    from hypothesis import find, settings

    from tests.fuzz_helpers import FAST

    enough = settings(FAST, max_examples=50 * len(TRACKERS))  # find stops at the first example it meets
    for name in TRACKERS:
        assert find(tracker_cases(), lambda c, name=name: c.tracker == name, settings=enough).tracker == name
