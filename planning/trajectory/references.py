"""Analytic reference trajectories with exact derivatives: line, circle, figure-eight.

Each is placed at a start pose, starts and ends at rest with smooth (quintic, jerk-continuous) speed ramps, and is
sized and timed from the robot's limits so that speed, yaw rate and acceleration stay within
``margin`` times the limits.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from planning.core.checks import check_number
from planning.core.geometry import Pose2D, check_pose
from planning.core.robot import RobotSpec, check_robot_spec
from planning.errors import ConfigError
from planning.trajectory.trajectory import Trajectory

FloatArray = NDArray[np.float64]
Curve = Callable[[FloatArray], tuple[FloatArray, FloatArray, FloatArray]]

#: Most samples a reference may have (2000 s at the default 2 ms), so a tiny dt or huge laps fails clearly.
MAX_SAMPLES = 1_000_000


def _phase_profile(
    rate: float, total: float, ramp: float, dt: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Phase s(t) from 0 to ``total`` with rate ramping 0 -> rate -> 0 along a quintic smoothstep.

    The ramp sdot = rate * (10u^3 - 15u^4 + 6u^5), u = t / ramp, starts and ends with zero
    acceleration and zero jerk, so the reference acceleration the tracker feeds forward is C1.

    Returns:
        t, s, sdot, sddot, each (N,).
    """
    cruise = max(total - rate * ramp, 0.0) / rate  # each ramp covers rate * ramp / 2 of phase
    duration = 2.0 * ramp + cruise
    n = _sample_count(duration, dt)
    t = np.linspace(0.0, duration, n)

    def up(u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        s_ = rate * ramp * (2.5 * u**4 - 3.0 * u**5 + u**6)
        sd = rate * (10 * u**3 - 15 * u**4 + 6 * u**5)
        sdd = rate / ramp * (30 * u**2 - 60 * u**3 + 30 * u**4)
        return s_, sd, sdd

    s = 0.5 * rate * ramp + rate * (t - ramp)
    sdot = np.full(n, rate)
    sddot = np.zeros(n)
    rising = t < ramp
    falling = t > ramp + cruise
    s[rising], sdot[rising], sddot[rising] = up(t[rising] / ramp)
    # the falling ramp mirrors the rising one in time
    s_m, sd_m, sdd_m = up((duration - t[falling]) / ramp)
    s[falling] = rate * ramp + rate * cruise - s_m
    sdot[falling] = sd_m
    sddot[falling] = -sdd_m
    return t, s, sdot, sddot


def _sample_count(duration: float, dt: float) -> int:
    """Samples of a reference lasting ``duration`` [s] every ``dt`` [s] (ConfigError above MAX_SAMPLES)."""
    n = duration / dt + 1.0
    if not n <= MAX_SAMPLES:
        raise ConfigError(
            f"a reference of {duration:.6g} s sampled every dt={dt:g} s needs {n:.3g} samples (at most {MAX_SAMPLES}): "
            "give a larger dt (default 0.002 s) or fewer laps"
        )
    return int(np.ceil(duration / dt)) + 1


def _build(
    curve: Curve, total: float, robot: RobotSpec, start: Pose2D, name: str, margin: float, dt: float
) -> Trajectory:
    """Time a unit-phase curve p(s) within the robot's limits and place it at ``start``.

    Raises:
        ConfigError: ``margin`` is not in (0, 1] or ``dt`` [s] is not a finite number > 0, or the
            reference would need more than ``MAX_SAMPLES`` samples.
    """
    margin = check_number(f"{name} margin", margin, above=0.0, at_most=1.0, unit="a fraction of the robot's limits")
    dt = check_number(f"{name} dt", dt, above=0.0, unit="s")
    s_grid = np.linspace(0.0, total, 4001)
    p, dp, ddp = curve(s_grid)
    g = np.hypot(dp[:, 0], dp[:, 1])
    kappa = np.abs(dp[:, 0] * ddp[:, 1] - dp[:, 1] * ddp[:, 0]) / np.maximum(g, 1e-12) ** 3
    bounds = [margin * robot.max_speed / g.max()]
    if np.max(kappa * g) > 1e-12:
        bounds.append(margin * robot.max_yaw_rate / np.max(kappa * g))
        bounds.append(np.sqrt(margin * robot.max_accel / np.max(kappa * g * g)))
    # wheel-speed limit: |v| + |omega| * track / 2 <= r * wheel_max
    wheel = margin * robot.max_wheel_speed * robot.wheel_radius / np.max(g + kappa * g * robot.track_width / 2)
    bounds.append(wheel)
    rate = float(min(bounds))
    # ramp long enough for the tangential acceleration limit: peak sddot = 1.875 rate / ramp
    ramp = max(1.0, 1.875 * rate * g.max() / (margin * robot.max_accel))
    t, s, sd, sdd = _phase_profile(rate, total, ramp, dt)
    p, dp, ddp = curve(s)
    xy = p
    dxy = dp * sd[:, None]
    ddxy = ddp * (sd**2)[:, None] + dp * sdd[:, None]
    # place: the curve starts at the origin heading along +x; rotate and translate to start
    c, sn = np.cos(start.theta), np.sin(start.theta)
    rot = np.array([[c, -sn], [sn, c]])
    return Trajectory.from_flat(t, xy @ rot.T + start.xy, dxy @ rot.T, ddxy @ rot.T, name=name)


def _check_placement(name: str, robot: object, start: object) -> None:
    """Refuse a ``robot`` that is not a RobotSpec or a ``start`` that is not a Pose2D (ConfigError naming the
    reference and how to make one)."""
    check_robot_spec(f"reference {name!r}", robot)
    check_pose(f"reference {name!r}: start", start)


def _positive(what: str, value: float | None, default: float) -> float:
    """``value`` (or ``default`` when None) as a float, which must be a finite number > 0 (ConfigError
    naming ``what``)."""
    return check_number(what, default if value is None else value, above=0.0)


def line(
    robot: RobotSpec, start: Pose2D, *, length: float | None = None, margin: float = 0.8, dt: float = 0.002
) -> Trajectory:
    """A straight line from ``start`` along its heading.

    Args:
        robot: Limits.
        start: Start pose.
        length: Length [m]; default 10 s worth of top speed, at most 3 m.
        margin: Fraction of each limit to use.
        dt: Sample spacing [s].
    """
    _check_placement("line", robot, start)
    length = _positive("line length", length, min(3.0, 10.0 * robot.max_speed))

    def curve(s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        z = np.zeros_like(s)
        return np.column_stack([s, z]), np.column_stack([np.ones_like(s), z]), np.column_stack([z, z])

    return _build(curve, length, robot, start, "line", margin, dt)


def circle(
    robot: RobotSpec,
    start: Pose2D,
    *,
    radius: float | None = None,
    laps: float = 1.0,
    margin: float = 0.8,
    dt: float = 0.002,
) -> Trajectory:
    """A counter-clockwise circle through ``start``, tangent to its heading.

    Args:
        robot: Limits.
        start: Start pose (on the circle).
        radius: Radius [m]; default max(0.5, v_max / omega_max), at most 1 m.
        laps: Number of turns.
        margin: Fraction of each limit to use.
        dt: Sample spacing [s].
    """
    _check_placement("circle", robot, start)
    radius = _positive("circle radius", radius, min(1.0, max(0.5, robot.max_speed / robot.max_yaw_rate)))

    def curve(s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        p = radius * np.column_stack([np.sin(s), 1.0 - np.cos(s)])
        dp = radius * np.column_stack([np.cos(s), np.sin(s)])
        ddp = radius * np.column_stack([-np.sin(s), np.cos(s)])
        return p, dp, ddp

    return _build(curve, 2.0 * np.pi * _positive("circle laps", laps, 1.0), robot, start, "circle", margin, dt)


def figure8(
    robot: RobotSpec,
    start: Pose2D,
    *,
    size: float | None = None,
    laps: float = 1.0,
    margin: float = 0.8,
    dt: float = 0.002,
) -> Trajectory:
    """A figure-eight (lemniscate of Gerono) whose crossing point is ``start``.

    x = A sin s, y = (A/2) sin 2s in a frame turned so the curve leaves ``start`` along its heading.

    Args:
        robot: Limits.
        start: Start pose (the crossing point).
        size: Half-width A [m]; default clip(2 v_max / omega_max, 0.6, 2.0).
        laps: Number of laps.
        margin: Fraction of each limit to use.
        dt: Sample spacing [s].
    """
    _check_placement("figure8", robot, start)
    a = _positive("figure-eight size", size, float(np.clip(2.0 * robot.max_speed / robot.max_yaw_rate, 0.6, 2.0)))
    c, s_ = np.cos(-np.pi / 4), np.sin(-np.pi / 4)
    rot = np.array([[c, -s_], [s_, c]])  # the lemniscate leaves the origin at 45 degrees

    def curve(s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        p = np.column_stack([a * np.sin(s), 0.5 * a * np.sin(2 * s)])
        dp = np.column_stack([a * np.cos(s), a * np.cos(2 * s)])
        ddp = np.column_stack([-a * np.sin(s), -2 * a * np.sin(2 * s)])
        return p @ rot.T, dp @ rot.T, ddp @ rot.T

    return _build(curve, 2.0 * np.pi * _positive("figure-eight laps", laps, 1.0), robot, start, "figure8", margin, dt)


#: Reference name -> builder(robot, start, **options).
REFERENCES: dict[str, Callable[..., Trajectory]] = {"figure8": figure8, "circle": circle, "line": line}


def make_reference(name: str, robot: RobotSpec, start: Pose2D, **options: float) -> Trajectory:
    """Build a named reference.

    Raises:
        ConfigError: Unknown name (lists the valid ones), an option the reference does not take (lists
            the valid ones), a bad option value, a robot that is no RobotSpec (``load_robot(name)``) or a
            start that is no Pose2D (a sequence [x, y, theta] is not one: ``Pose2D.from_array``).
    """
    if name not in REFERENCES:
        raise ConfigError(f"unknown reference {name!r}: choose one of {', '.join(REFERENCES)}")
    params = inspect.signature(REFERENCES[name]).parameters.values()
    valid = [p.name for p in params if p.kind is p.KEYWORD_ONLY]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ConfigError(
            f"reference {name!r}: unknown option(s) {', '.join(unknown)}; valid options: {', '.join(valid)}"
        )
    return REFERENCES[name](robot, start, **options)
