"""The tracker interface, the registry of trackers by name, and checks for their option dataclasses."""

from __future__ import annotations

import importlib
import inspect
import math
from collections.abc import Callable
from typing import Any, Protocol, TypeVar

from planning.core.robot import RobotSpec
from planning.errors import ConfigError, SimulationError
from planning.trajectory.trajectory import Trajectory

T = TypeVar("T")


class Tracker(Protocol):
    """A feedback (or feed-forward) law with explicit state.

    The simulator calls ``reset`` once, then ``command`` at the control rate with the measured
    pose, and holds the returned (v, omega) until the next call. A tracker is built as
    ``factory(robot, **options)`` with keyword-only options (see :func:`make_tracker`).
    """

    name: str

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking ``trajectory`` with control period ``dt`` [s]."""
        ...

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command (v [m/s], omega [rad/s]) at time ``t`` [s] for the measured pose."""
        ...


#: Tracker name -> "module:factory"; the factory is called as factory(robot, **keyword-only options).
TRACKERS: dict[str, str] = {
    "fbl": "control.fbl:DynamicFBL",
    "open-loop": "control.open_loop:OpenLoop",
    "segmented": "control.segmented:SegmentedTracker",
}


def register_tracker(name: str, target: str) -> None:
    """Register a tracker factory by import path, e.g. ``"control.fbl:DynamicFBL"``."""
    TRACKERS[name] = target


def _factory(name: str) -> Callable[..., Tracker]:
    if name not in TRACKERS:
        raise ConfigError(f"unknown tracker {name!r}: choose one of {', '.join(sorted(TRACKERS))}")
    module_name, attr = TRACKERS[name].split(":")
    return getattr(importlib.import_module(module_name), attr)  # type: ignore[no-any-return]


def tracker_options(name: str) -> tuple[str, ...]:
    """The keyword options a registered tracker takes (besides the robot), in signature order.

    Raises:
        ConfigError: Unknown name (lists the valid ones).
    """
    params = inspect.signature(_factory(name)).parameters.values()
    return tuple(p.name for p in params if p.kind is inspect.Parameter.KEYWORD_ONLY)


def make_tracker(name: str, robot: RobotSpec, **options: Any) -> Tracker:
    """Instantiate a registered tracker for a robot.

    Args:
        name: A key of :data:`TRACKERS`.
        robot: The robot whose limits the commands respect.
        **options: The tracker's keyword options (see :func:`tracker_options`).

    Raises:
        ConfigError: Unknown name (lists the valid ones), an option the tracker does not take (names
            it and lists the valid ones) or a bad option value.
    """
    factory = _factory(name)
    valid = tracker_options(name)
    unknown = [key for key in options if key not in valid]
    if unknown:
        raise ConfigError(
            f"tracker {name!r}: unknown option(s) {', '.join(map(repr, unknown))}; "
            f"valid options: {', '.join(valid) or '(none)'}"
        )
    return factory(robot, **options)


def option_value(tracker: str, option: str, value: T | None, default: T) -> T:
    """A tracker option checked to be of its default's type; None gives the default.

    Raises:
        ConfigError: ``value`` is neither None nor of the default's type.
    """
    if value is None:
        return default
    kind = type(default)
    if not isinstance(value, kind):
        raise ConfigError(
            f"tracker {tracker!r}: option {option} must be an instance of {kind.__name__} (e.g. {default!r}), "
            f"or None for that default; got {type(value).__name__}"
        )
    return value


def check_positive_fields(obj: object, names: tuple[str, ...], why: str) -> None:
    """Check that the named fields of a frozen dataclass are finite numbers > 0; store them as floats.

    Args:
        obj: The dataclass instance (from its ``__post_init__``).
        names: The fields to check.
        why: What needs them positive, appended to the message.

    Raises:
        ConfigError: A field is not a number (a bool is not), not finite, or not > 0; the message
            names it, e.g. ``FBLGains.kp``.
    """
    for name in names:
        value = getattr(obj, name)
        where = f"{type(obj).__name__}.{name}"
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"{where} must be a finite number, got {value!r}")
        if value <= 0:
            raise ConfigError(f"{where} must be > 0, got {value!r} ({why})")
        object.__setattr__(obj, name, float(value))


#: Most control periods a tracker pre-samples its reference at (a day at 10 Hz, 5.6 h at 50 Hz).
MAX_CONTROL_PERIODS = 1_000_000


def check_period(tracker: str, dt: float, trajectory: Trajectory) -> float:
    """The control period ``dt`` [s] given to a tracker's ``reset``, as a float.

    Args:
        tracker: The tracker's name, for the message.
        dt: The control period [s].
        trajectory: The reference the tracker pre-samples at every control instant of its span.

    Raises:
        ConfigError: ``dt`` is not a finite number > 0, or so small that the trajectory would span
            more than ``MAX_CONTROL_PERIODS`` control periods (names the tracker).
    """
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not (math.isfinite(dt) and dt > 0):
        raise ConfigError(
            f"tracker {tracker!r}: reset(dt) needs the control period dt as a finite number of seconds > 0, "
            f"got {dt!r}; pass 1 / control rate, e.g. 0.02 for 50 Hz"
        )
    periods = trajectory.duration / dt
    if not periods <= MAX_CONTROL_PERIODS:
        raise ConfigError(
            f"tracker {tracker!r}: reset(dt={dt:g} s) over the trajectory's {trajectory.duration:.6g} s makes "
            f"{periods:.3g} control periods (at most {MAX_CONTROL_PERIODS}); pass a longer period, e.g. 0.02 for 50 Hz"
        )
    return float(dt)


def check_measured_pose(tracker: str, t: float, x: float, y: float, theta: float) -> None:
    """Refuse a non-finite time or measured pose given to a tracker's ``command``.

    Every tracker calls this first (the open-loop player too, which ignores the pose), so a NaN from a
    sensor or an estimator stops the run with the same error in every tracker, never a silent stop, a
    non-finite command or a Python error.

    Raises:
        SimulationError: ``t``, ``x``, ``y`` or ``theta`` is NaN or infinite (names the tracker and t).
    """
    if not math.isfinite(t + x + y + theta):
        raise SimulationError(
            f"tracker {tracker!r} was given a non-finite pose (x={x}, y={y}, theta={theta}) at t={t:.3f} s: "
            "the measured or estimated pose diverged"
        )
