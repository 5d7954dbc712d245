"""Segment switching: the one compiled control period every per-segment tracker shares.

A planned trajectory (planning/trajectory/from_plan.py) is labelled with segments ("forward",
"reverse", "rotate", "hold"; a trajectory without labels gets them from the sign of v, by
:func:`planning.trajectory.segments.infer_segments`). A per-segment tracker brings only the law of
its drives; this module does the rest, in one compiled call per control period (:func:`period`):

* **Drives** ("forward", "reverse"): the tracker's drive law, told whether the drive starts this
  period (``enter``) and whether the robot was at rest the period before (``rested``: a turn in
  place, a stand-still or the tracker's reset). A drive never reverses by itself: its speed is kept
  on the drive's side of zero.
* **Turns in place and stand-stills** ("rotate", "hold"): omega = omega_ref + heading_gain *
  wrap(theta_ref - theta), with omega_ref the reference's on a turn and 0 on a stand-still; a small
  v = along_gain * (along-heading position error), bounded by hold_speed, holds the spot.
* **After the end** the same regulation holds the final pose, so the heading reaches the goal too.

Every command is clamped to the robot's |v| and |omega| limits. A non-finite command of the law
(NaN or infinite: a division by a vanishing speed, an overflow) is no stop: it is returned as it is,
unclamped and unsmoothed, and the simulator stops the run on it as on any tracker's, with a
SimulationError naming the tracker and the time (sim/physics/simulator.py: one rule for every
tracker). A tracker whose law knows nothing of the robot's dynamics
(``SMOOTHED``: Kanayama's, RPP) has its command smoothed as Nav2's velocity smoother does between
controller and base: v and omega move from the last period's command by at most the robot's
max_accel and max_yaw_accel times the period (:func:`smooth_command`); a balancing robot, which
first rolls backwards to go forwards, falls under a speed step its balance loop cannot follow.
A non-finite time or pose changes nothing and returns
:data:`BAD_POSE` for the tracker to refuse (SimulationError, as every tracker does).

The state is one record (:func:`state_dtype`: the switching's fields below, then the law's own:
its gains and its memory), the reference one structured array (:data:`REFERENCE`), so a period
hands two arrays to compiled code and its reader sees ``s.segment`` and ``ref[k].theta``.

A tracker module (see control/kanayama.py) holds its parameters, its drive law
``drive(s, ref, k, x, y, theta, enter, rested) -> (v, omega)`` (compiled), a compiled
``_period(state, ref, t, x, y, theta)`` that returns ``period(state, ref, t, x, y, theta, drive)``
(module level, so numba caches it) and a short :class:`PerSegmentTracker` subclass.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.base import check_positive_fields
from control.dispatch import bind
from control.estimation.kernels import wrap
from control.inputs import check_command, check_reset, not_reset
from planning.core.robot import RobotSpec
from planning.trajectory.segments import infer_segments
from planning.trajectory.trajectory import Trajectory

#: The reference at one control instant (one row of a tracker's reference table): the pose
#: [m, m, rad], the inputs v [m/s] and omega [rad/s], the flat outputs' first and second
#: derivatives (dx, dy [m/s], ddx, ddy [m/s^2]), the segment in force, its direction ``sign`` (+1
#: forwards, -1 backwards, 0 a turn in place or a stand-still), whether it is a turn in place, the
#: rows its segment spans (``start`` .. ``end`` exclusive) and the arc length of the positions from
#: the first instant [m].
REFERENCE = np.dtype(
    [
        ("x", "f8"),
        ("y", "f8"),
        ("theta", "f8"),
        ("v", "f8"),
        ("omega", "f8"),
        ("dx", "f8"),
        ("dy", "f8"),
        ("ddx", "f8"),
        ("ddy", "f8"),
        ("segment", "i8"),
        ("sign", "f8"),
        ("turn", "?"),
        ("start", "i8"),
        ("end", "i8"),
        ("arc", "f8"),
    ],
    align=True,
)

#: The switching's own fields of a tracker's state record: the first control instant t0 [s], the
#: control period dt [s], the robot's limits vmax [m/s] and wmax [rad/s], the rate limits of the
#: command amax [m/s^2] and alphamax [rad/s^2] (infinite for a tracker that is not smoothed), the
#: command of the last period (v_last_cmd [m/s], w_last_cmd [rad/s]), the regulation's
#: heading_gain [1/s], hold_gain [1/s] (SegmentedParams.along_gain) and hold_speed [m/s], the
#: final pose (goal_x, goal_y [m], goal_theta [rad]), the segment of the last period (-1 before the
#: first) and whether the robot was at rest the last period (``rested``: not in a drive).
SWITCHING_FIELDS: tuple[tuple[str, str], ...] = (
    ("t0", "f8"),
    ("dt", "f8"),
    ("vmax", "f8"),
    ("wmax", "f8"),
    ("amax", "f8"),
    ("alphamax", "f8"),
    ("v_last_cmd", "f8"),
    ("w_last_cmd", "f8"),
    ("heading_gain", "f8"),
    ("hold_gain", "f8"),
    ("hold_speed", "f8"),
    ("goal_x", "f8"),
    ("goal_y", "f8"),
    ("goal_theta", "f8"),
    ("segment", "i8"),
    ("rested", "?"),
)

#: A tracker's state record inside compiled code (a numba Record of :func:`state_dtype`): its fields
#: are read and written as attributes, ``s.segment``.
Record = Any

#: :func:`period`'s status: a command; a non-finite time or pose (nothing changed).
OK, BAD_POSE = range(2)


def state_dtype(law_fields: Sequence[tuple[str, str]]) -> np.dtype:
    """A tracker's state record: :data:`SWITCHING_FIELDS`, then the law's (name, numpy type) fields."""
    return np.dtype([*SWITCHING_FIELDS, *law_fields], align=True)


@dataclass(frozen=True)
class SegmentedParams:
    """Parameters of the segment switching (and of the segmented FBL's blend); all finite and > 0.

    Attributes:
        heading_gain: Gain of the heading controller of turns in place and stand-stills [1/s].
        along_gain: Gain of the spot-holding speed [1/s].
        xi_blend: Speed below which the segmented FBL blends omega towards heading control [m/s].
        hold_speed: |v| bound while holding a spot [m/s].
    """

    heading_gain: float = 3.0
    along_gain: float = 2.0
    xi_blend: float = 0.04
    hold_speed: float = 0.05

    def __post_init__(self) -> None:
        why = "xi_blend divides, and the gains and the hold speed must pull towards the reference"
        check_positive_fields(self, ("heading_gain", "along_gain", "xi_blend", "hold_speed"), why)


def reference_table(trajectory: Trajectory, dt: float, rows: int) -> NDArray[np.void]:
    """The reference at the control instants t0 + k dt, k < ``rows``, as a :data:`REFERENCE` table.

    The segment in force at an instant is that of the last trajectory sample at or before it.

    Args:
        trajectory: The reference (labelled with segments, or labelled here from the sign of v).
        dt: The control period [s].
        rows: How many control instants.
    """
    if trajectory.segments is not None:
        seg, kinds = trajectory.segments, trajectory.segment_kinds
    else:
        inferred = infer_segments(trajectory.vel[:, 0], trajectory.vel[:, 1])
        seg, kinds = inferred.index, inferred.kinds
    times = float(trajectory.t[0]) + dt * np.arange(rows)
    s = trajectory.sample_many(times)
    idx = np.clip(np.searchsorted(trajectory.t, times + 1e-9, side="right") - 1, 0, trajectory.t.size - 1)
    at = seg[idx]
    signs = np.array([1.0 if k == "forward" else (-1.0 if k == "reverse" else 0.0) for k in kinds])
    table = np.zeros(rows, REFERENCE)
    for name in ("x", "y", "theta", "v", "omega", "dx", "dy", "ddx", "ddy"):
        table[name] = getattr(s, name)
    table["segment"], table["sign"] = at, signs[at]
    table["turn"] = np.array([k == "rotate" for k in kinds], dtype=bool)[at]
    table["start"] = np.searchsorted(at, at)
    table["end"] = np.searchsorted(at, at, side="right")
    table["arc"] = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(s.x), np.diff(s.y)))])
    return table


@nb.njit(cache=True, inline="always")
def clamp_command(v: float, w: float, vmax: float, wmax: float) -> tuple[float, float]:  # pragma: no cover - compiled
    """|v| <= vmax [m/s], |w| <= wmax [rad/s]; a non-finite command is returned as it is (not a stop, nor an
    infinity turned into full speed), for the caller to refuse: the simulator stops the run on it."""
    if not (math.isfinite(v) and math.isfinite(w)):
        return v, w
    return (-vmax if v < -vmax else (vmax if v > vmax else v)), (-wmax if w < -wmax else (wmax if w > wmax else w))


@nb.njit(cache=True, inline="always")
def smooth_command(s: Record, v: float, w: float) -> tuple[float, float]:  # pragma: no cover - compiled
    """(v, w) moved from the last period's command by at most amax dt and alphamax dt (nothing for
    infinite limits), remembered as the last command."""
    if s.amax < math.inf:
        step = s.amax * s.dt
        v = min(max(v, s.v_last_cmd - step), s.v_last_cmd + step)
    if s.alphamax < math.inf:
        step = s.alphamax * s.dt
        w = min(max(w, s.w_last_cmd - step), s.w_last_cmd + step)
    s.v_last_cmd, s.w_last_cmd = v, w
    return v, w


@nb.njit(cache=True, inline="always")
def _hold(
    s: Record, x: float, y: float, theta: float, gx: float, gy: float, gth: float, omega_ref: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Hold the spot (gx, gy) and turn to its heading gth: (v, omega) before clamping."""
    c, sn = math.cos(theta), math.sin(theta)
    along = (gx - x) * c + (gy - y) * sn
    v = min(max(s.hold_gain * along, -s.hold_speed), s.hold_speed)
    return v, omega_ref + s.heading_gain * wrap(gth - theta)


@nb.njit(cache=True, inline="always")
def period(
    state: NDArray[np.void], ref: NDArray[np.void], t: float, x: float, y: float, theta: float, drive: Callable
) -> tuple[int, float, float]:  # pragma: no cover - compiled
    """One control period of a per-segment tracker (the module doc): (OK, v, omega), clamped (a non-finite
    command of the law as it is, the last command unchanged); or (BAD_POSE, nan, nan) for a non-finite time
    or pose, nothing changed.

    Args:
        state: (1,) the tracker's state record (:func:`state_dtype`), updated in place.
        ref: (M,) the reference at the control instants (:data:`REFERENCE`).
        t: The period's start [s]; the reference instant is the nearest, the first before t0 and
            past the last the final pose.
        x: Measured position [m].
        y: Measured position [m].
        theta: Measured heading [rad].
        drive: The tracker's compiled drive law ``drive(s, ref, k, x, y, theta, enter, rested)``:
            (v, omega) before clamping on the state record ``s`` at row ``k`` of ``ref``.
    """
    s = state[0]
    if not math.isfinite(t + x + y + theta):
        return BAD_POSE, math.nan, math.nan
    k = round((t - s.t0) / s.dt)
    if k >= ref.size:
        v, w = _hold(s, x, y, theta, s.goal_x, s.goal_y, s.goal_theta, 0.0)
        s.rested = True
    else:
        i = k if k > 0 else 0
        r = ref[i]
        sgn = r.sign
        if sgn != 0.0:
            v, w = drive(s, ref, i, x, y, theta, r.segment != s.segment, s.rested)
            v = sgn * max(sgn * v, 0.0)
            s.rested = False
        else:
            v, w = _hold(s, x, y, theta, r.x, r.y, r.theta, r.omega if r.turn else 0.0)
            s.rested = True
        s.segment = r.segment
    v, w = clamp_command(v, w, s.vmax, s.wmax)
    if math.isfinite(v) and math.isfinite(w):  # else the law's fault, passed on for the simulator to refuse
        v, w = smooth_command(s, v, w)
    return OK, v, w


class PerSegmentTracker:
    """A tracker that switches law per segment (the module doc); a subclass names its law.

    A subclass sets ``name``, ``STATE`` (:func:`state_dtype` with its law's fields), ``DRIVE`` (its
    compiled drive law) and ``PERIOD`` (its compiled ``_period``), both as staticmethods, and
    :meth:`law_values` (its fields' values at reset); its constructor stores its options and calls
    this one.

    Args:
        robot: Limits (max_speed, max_yaw_rate).
        turns: Heading and spot-holding parameters of turns in place, stand-stills and the end.
    """

    name: ClassVar[str] = "per-segment"
    STATE: ClassVar[np.dtype] = state_dtype(())
    #: Whether the commands are smoothed within the robot's acceleration limits (the module doc).
    SMOOTHED: ClassVar[bool] = False
    DRIVE: ClassVar[Callable[..., tuple[float, float]]]
    PERIOD: ClassVar[Callable[..., tuple[int, float, float]]]

    def __init__(self, robot: RobotSpec, turns: SegmentedParams) -> None:
        self.robot = robot
        self.turns = turns
        self.state: NDArray[np.void] | None = None
        self._ref: NDArray[np.void] = np.zeros(0, REFERENCE)
        self._period: Callable[[float, float, float, float], tuple[int, float, float]] | None = None

    def law_values(self) -> dict[str, float]:
        """The law's constants in the state record (by field name), taken at reset."""
        return {}

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking: the reference at every control instant; the parameters as they are now.

        Raises:
            ConfigError: ``trajectory`` is not a Trajectory, or the control period ``dt`` [s] is not a
                finite number > 0 (or too small).
        """
        dt = check_reset(self.name, trajectory, dt)
        self._ref = reference_table(trajectory, dt, math.ceil(trajectory.duration / dt) + 1)
        state = np.zeros(1, self.STATE)
        r, p = self.robot, self.turns
        goal = trajectory.pose[-1]
        accel = (r.max_accel, r.max_yaw_accel) if self.SMOOTHED else (math.inf, math.inf)
        values = {
            "t0": trajectory.t[0], "dt": dt, "vmax": r.max_speed, "wmax": r.max_yaw_rate,
            "amax": accel[0], "alphamax": accel[1], "v_last_cmd": 0.0, "w_last_cmd": 0.0,
            "heading_gain": p.heading_gain, "hold_gain": p.along_gain, "hold_speed": p.hold_speed,
            "goal_x": goal[0], "goal_y": goal[1], "goal_theta": goal[2], "segment": -1, "rested": True,
            **self.law_values(),
        }  # fmt: skip
        for key, value in values.items():
            state[key] = value
        self.state = state
        # PERIOD bound to this run's record and table, its overload resolved once (control/dispatch.py)
        self._period = bind(self.PERIOD, state, self._ref, free=(0.0, 0.0, 0.0, 0.0))

    @property
    def segment(self) -> int:
        """The segment of the last period (-1 before the first)."""
        return -1 if self.state is None else int(self.state[0]["segment"])

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command (v [m/s], omega [rad/s]) for the period starting at ``t``: one compiled call. A
        non-finite command of the law is returned as it is: the simulator stops the run on it (the module doc).

        Raises:
            ConfigError: An argument is not a number (an array, a text).
            SimulationError: ``t`` or the pose is not finite.
        """
        if self._period is None:
            raise not_reset(self.name)
        check_command(self.name, t, x, y, theta)  # before the compiled period, which takes a text for a float
        _, v, w = self._period(t, x, y, theta)  # OK: its BAD_POSE is what the check above has named
        return v, w


def dataclass_values(params: object) -> dict[str, float]:
    """A parameter dataclass's fields by name (for :meth:`PerSegmentTracker.law_values`)."""
    return {f.name: getattr(params, f.name) for f in dataclasses.fields(params)}  # type: ignore[arg-type]
