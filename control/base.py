"""The tracker interface, the registry of trackers by name, and checks for their option dataclasses."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import math
from collections.abc import Callable
from typing import Any, Protocol, TypeVar

from planning.core.checks import check_fields, check_number
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


#: Tracker name -> its factory, or "module:factory" imported when first used; the factory is called as
#: factory(robot, **keyword-only options). The CLI (compare, bench track, tune), the registry-wide tests
#: and the fuzz suite enumerate this registry: registering a tracker is all it takes to appear there.
TRACKERS: dict[str, str | Callable[..., Tracker]] = {
    "fbl": "control.fbl:DynamicFBL",
    "kanayama": "control.kanayama:KanayamaTracker",
    "mpc": "control.mpc:MPCTracker",
    "open-loop": "control.open_loop:OpenLoop",
    "rpp": "control.rpp:RegulatedPurePursuit",
    "segmented": "control.segmented:SegmentedTracker",
}

#: Registered names without feedback (baselines): not compared by default, not held to the robot's limits.
BASELINES: set[str] = {"open-loop"}


def register_tracker(name: str, target: str | Callable[..., Tracker], *, baseline: bool = False) -> None:
    """Register a tracker by name: its factory (a class), or its import path, e.g. ``"control.fbl:DynamicFBL"``.

    Args:
        name: The tracker's name (``--trackers``, ``--tracker``, the run records).
        target: The factory, called as ``factory(robot, **keyword-only options)``, or "module:attr".
        baseline: A player without feedback (like "open-loop"): left out of ``compare``'s default set
            and not held to the robot's limits by the tests.
    """
    TRACKERS[name] = target
    if baseline:
        BASELINES.add(name)
    else:
        BASELINES.discard(name)


def feedback_trackers() -> tuple[str, ...]:
    """The registered trackers with feedback (every one but the baselines), in registration order."""
    return tuple(name for name in TRACKERS if name not in BASELINES)


def _factory(name: str) -> Callable[..., Tracker]:
    if name not in TRACKERS:
        raise ConfigError(f"unknown tracker {name!r}: choose one of {', '.join(sorted(TRACKERS))}")
    target = TRACKERS[name]
    if not isinstance(target, str):
        return target
    module_name, attr = target.split(":")
    return getattr(importlib.import_module(module_name), attr)  # type: ignore[no-any-return]


def tracker_factory(name: str) -> Callable[..., Tracker]:
    """The factory (class) of a registered tracker.

    Raises:
        ConfigError: Unknown name (lists the valid ones).
    """
    return _factory(name)


def tracker_options(name: str) -> tuple[str, ...]:
    """The keyword options a registered tracker takes (besides the robot), in signature order.

    Raises:
        ConfigError: Unknown name (lists the valid ones).
    """
    params = inspect.signature(_factory(name)).parameters.values()
    return tuple(p.name for p in params if p.kind is inspect.Parameter.KEYWORD_ONLY)


def tuned_option(name: str) -> tuple[str, type]:
    """The option of a registered tracker that ``nhsim tune --tracker`` tunes, and its dataclass.

    A tracker declares it as the class attribute ``TUNED = (option, dataclass)``, e.g.
    ``("params", MPCParams)``.

    Raises:
        ConfigError: Unknown name (lists the valid ones), or a tracker with nothing to tune.
    """
    tuned = getattr(_factory(name), "TUNED", None)
    if tuned is None:
        with_params = [n for n in sorted(TRACKERS) if getattr(_factory(n), "TUNED", None) is not None]
        raise ConfigError(f"tracker {name!r} has no parameters to tune; choose one of {', '.join(with_params)}")
    return tuned  # type: ignore[no-any-return]


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
    if not isinstance(robot, RobotSpec):
        raise ConfigError(f"tracker {name!r}: robot must be a RobotSpec (load_robot('turtlebot3')), got {robot!r}")
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
    check_fields(obj, {name: {"above": 0.0, "fix": why} for name in names}, f"{type(obj).__name__}.")


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
    fix = "pass 1 / control rate, e.g. 0.02 for 50 Hz"
    dt = check_number(f"tracker {tracker!r}: reset(dt)'s control period dt", dt, above=0.0, unit="s", fix=fix)
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


def ranged(default: float, low: float, high: float, unit: str, *, tune: tuple[float, float] | None = None) -> Any:
    """A parameter field with its valid range [low, high] and, if tuned, its search range.

    Use in a frozen parameter dataclass checked by :func:`check_ranges`; an int default makes an
    integer parameter (e.g. a horizon length).

    Args:
        default: Default value.
        low: Smallest valid value.
        high: Largest valid value.
        unit: Unit for messages, e.g. "1/s" ("" for a pure number).
        tune: (low, high) searched log-uniformly by ``nhsim tune --tracker``; None: not tuned.
    """
    return dataclasses.field(default=default, metadata={"range": (low, high), "unit": unit, "tune": tune})


def check_ranges(obj: object) -> None:
    """Check every :func:`ranged` field of a frozen dataclass; store floats as floats.

    Raises:
        ConfigError: A field is not a number (a bool is not; an integer parameter needs an int), not
            finite, or outside its range; the message names it (``MPCParams.horizon``), the range and
            the unit.
    """
    limits: dict[str, dict[str, Any]] = {}
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        if "range" in f.metadata:
            (low, high), unit, integer = f.metadata["range"], f.metadata["unit"], isinstance(f.default, int)
            limits[f.name] = dict(at_least=low, at_most=high, unit=unit, integer=integer, fix="choose a value in range")
    check_fields(obj, limits, f"{type(obj).__name__}.")


def search_space(cls: type) -> dict[str, tuple[float, float]]:
    """The tuned fields of a parameter dataclass and their search ranges (see :func:`ranged`)."""
    return {f.name: f.metadata["tune"] for f in dataclasses.fields(cls) if f.metadata.get("tune") is not None}
