"""The checks of what a caller hands a tracker: ``reset``'s trajectory and period, ``command``'s time and pose.

Every registered tracker calls :func:`check_reset` first in ``reset`` and :func:`check_command` first
in ``command`` (the compiled ones too: their compiled period would take a text or a 0-d array as the
number it holds; four plain floats cost a tenth of a microsecond), so a wrong argument gets the same
message from every tracker: its name, what it must be, what was given and how to put it right; never
a Python error from deep inside.
"""

from __future__ import annotations

import math
import numbers

from control.base import check_measured_pose, check_period
from planning.core.checks import given
from planning.errors import ConfigError, SimulationError
from planning.trajectory.trajectory import Trajectory


def check_reset(tracker: str, trajectory: object, dt: object) -> float:
    """The control period ``dt`` [s] of a tracker's ``reset(trajectory, dt)``, as a float.

    Args:
        tracker: The tracker's name, for the message.
        trajectory: What was given to track: it must be a :class:`Trajectory`.
        dt: The control period [s] (:func:`control.base.check_period`).

    Raises:
        ConfigError: ``trajectory`` is not a Trajectory (a path of poses, None), or ``dt`` is not a
            finite number > 0 or too small for the trajectory (names the tracker and the argument).
    """
    if not isinstance(trajectory, Trajectory):
        path = hasattr(trajectory, "shape") or isinstance(trajectory, (list, tuple))
        fix = "; a path of poses becomes one with to_trajectory(path, robot, world)" if path else ""
        raise ConfigError(
            f"tracker {tracker!r}: reset(trajectory, dt)'s trajectory must be a Trajectory (from "
            f"to_trajectory(plan, robot, world), make_reference(name, robot, start) or "
            "file_trajectory(read_trajectory_file(path), robot, world).trajectory), "
            f"got {_described(trajectory)}{fix}"
        )
    return check_period(tracker, dt, trajectory)  # type: ignore[arg-type]


def not_reset(tracker: str) -> ConfigError:
    """The error of a tracker's ``command`` called before its ``reset`` (every tracker raises this one)."""
    return ConfigError(
        f"tracker {tracker!r}: command(t, x, y, theta) was called before reset(trajectory, dt); call "
        "tracker.reset(trajectory, dt) first, with the trajectory to track and the control period [s]"
    )


def check_command(tracker: str, t: object, x: object, y: object, theta: object) -> None:
    """Refuse what a tracker's ``command(t, x, y, theta)`` cannot use.

    A Python float or int, or a numpy scalar, is a number; a bool, a text, an array (a whole path, a
    0-d array) is not. A non-finite time is the caller's clock's fault and is named as such; a
    non-finite pose is the measured or estimated pose's (:func:`control.base.check_measured_pose`).

    Raises:
        ConfigError: An argument that is not a number (names it and what was given).
        SimulationError: ``t`` is not finite, or the pose is not (names the tracker and t).
    """
    if type(t) is float and type(x) is float and type(y) is float and type(theta) is float:
        if math.isfinite(t + x + y + theta):  # the common case: nothing more to look at
            return
    else:
        for name, value in (("t", t), ("x", x), ("y", y), ("theta", theta)):
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise ConfigError(
                    f"tracker {tracker!r}: command(t, x, y, theta)'s {name} must be a number, got "
                    f"{_described(value)}; pass one time [s] and one pose (x [m], y [m], theta [rad]) per call"
                )
    if not math.isfinite(t):  # type: ignore[arg-type]
        raise SimulationError(
            f"tracker {tracker!r} was given a non-finite time t={t} s (with the pose x={x}, y={y}, "
            f"theta={theta}): command's t must be a finite time [s]; the caller's clock, not the pose, is at fault"
        )
    check_measured_pose(tracker, t, x, y, theta)  # type: ignore[arg-type]


def _described(value: object) -> str:
    """``value`` as a message quotes it: an array (not 0-d) by its type and shape, else its short repr
    (a 0-d array with how to pass it, :func:`planning.core.checks.given`)."""
    shape = getattr(value, "shape", None)
    if shape:
        return f"{type(value).__name__} of shape {shape}"
    return given(value) if shape == () else f"{value!r:.80}"
