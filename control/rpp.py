"""Regulated Pure Pursuit, as Nav2 describes it, on the drives of a timed trajectory.

Per control period, on the current drive's path (the reference positions at the control instants):

1. **Lookahead scaled with speed:** L = clip(|v| * lookahead_time, min_lookahead, max_lookahead),
   |v| the last speed commanded.
2. **Carrot:** the path is pruned to the point closest to the robot (searched forwards from the
   last one); the carrot is where the path leaves the circle of radius L about the robot
   (interpolated on the crossing path segment); past the drive's end the path is extended along its
   last heading, so the carrot stays at distance L.
3. **Curvature:** kappa = 2 y_c / L^2, (x_c, y_c) the carrot in the robot's frame.
4. **Speed:** the desired speed is the reference speed plus ``along_gain`` times the along-track
   error to the reference of this instant (this project's addition: Nav2 drives at a constant
   desired speed; the comparison is on timed trajectories). It is then regulated as Nav2 does:
   by curvature (times R / min_radius where the radius R = 1 / |kappa| is below min_radius, never
   below min_regulated_speed) and by proximity to the drive's end (times d / approach_dist within
   approach_dist of it, never below min_approach_speed). Where the yaw rate v kappa would exceed
   the robot's limit, v is scaled down so the curvature is kept.
5. **Rotate to heading:** when the carrot is more than ``rotate_angle`` off the driving direction,
   the robot turns in place towards it (omega = heading_gain * angle).

Backwards drives aim the same construction behind the robot (v < 0, omega = v kappa). Turns in
place and stand-stills are held by the segment switching of
:class:`control.segmented.SegmentSwitcher`, so the tracker accepts every trajectory. Nav2's third
regulation, by proximity to obstacles, reads a costmap: a tracker here is given the trajectory, not
the map (the plan keeps its clearance), so that heuristic is left out.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.base import check_ranges, option_value, ranged
from control.segmented import DRIVE, GENERAL, SegmentedParams, SegmentSwitcher, _Instant, clamp_command, drive_row
from planning.core.robot import RobotSpec
from planning.errors import ConfigError
from planning.trajectory.trajectory import Trajectory

FloatArray = NDArray[np.float64]

#: Path points past the last closest one that may be farther before the search for the closest stops.
_PATIENCE = 4


@dataclass(frozen=True)
class RPPParams:
    """Parameters of Regulated Pure Pursuit (Nav2's names in brackets; ranges checked).

    The defaults are Nav2's except where its values exceed these small robots (its minimum
    lookahead 0.3 m and minimum regulated speed 0.25 m/s are above a TurtleBot3's 0.125 m tightest
    reference radius and 0.22 m/s top speed).

    Attributes:
        lookahead_time: Lookahead per speed [s] (lookahead_time).
        min_lookahead: Smallest lookahead [m] (min_lookahead_dist).
        max_lookahead: Largest lookahead [m] (max_lookahead_dist).
        min_radius: Path radius below which the speed is scaled down [m]
            (regulated_linear_scaling_min_radius).
        min_regulated_speed: Floor of the curvature-regulated speed [m/s]
            (regulated_linear_scaling_min_speed).
        approach_dist: Distance to the drive's end within which the speed is scaled down [m]
            (approach_velocity_scaling_dist).
        min_approach_speed: Floor of the approach-scaled speed [m/s] (min_approach_linear_velocity).
        along_gain: Gain of the along-track error on the desired speed [1/s] (this project's).
        rotate_angle: Carrot bearing beyond which the robot turns in place [rad]
            (rotate_to_heading_min_angle).
    """

    lookahead_time: float = ranged(1.5, 0.01, 10.0, "s", tune=(0.1, 5.0))
    min_lookahead: float = ranged(0.1, 0.01, 5.0, "m", tune=(0.02, 0.5))
    max_lookahead: float = ranged(0.9, 0.01, 10.0, "m")
    min_radius: float = ranged(0.3, 0.0, 10.0, "m", tune=(0.01, 2.0))
    min_regulated_speed: float = ranged(0.05, 0.0, 10.0, "m/s")
    approach_dist: float = ranged(0.2, 0.0, 10.0, "m", tune=(0.01, 1.0))
    min_approach_speed: float = ranged(0.05, 0.0, 10.0, "m/s")
    along_gain: float = ranged(1.0, 0.0, 100.0, "1/s", tune=(0.05, 10.0))
    rotate_angle: float = ranged(0.785, 0.01, math.pi, "rad")

    def __post_init__(self) -> None:
        check_ranges(self)
        if self.min_lookahead > self.max_lookahead:
            raise ConfigError(
                f"RPPParams.min_lookahead ({self.min_lookahead} m) must be <= max_lookahead ({self.max_lookahead} m)"
            )


@nb.njit(cache=True)
def circle_crossing(
    cx: float, cy: float, radius: float, p1: tuple[float, float], p2: tuple[float, float]
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Where the segment p1 -> p2 (p1 inside the circle, p2 on or outside it) leaves the circle.

    Args:
        cx: Circle centre x [m].
        cy: Circle centre y [m].
        radius: Circle radius [m].
        p1: Segment start (inside).
        p2: Segment end (outside).

    Returns:
        The crossing point (x, y) [m] (p2 when the segment is degenerate).
    """
    ax, ay = p1[0] - cx, p1[1] - cy
    dx, dy = p2[0] - p1[0], p2[1] - p1[1]
    a = dx * dx + dy * dy
    if a < 1e-18:
        return p2
    b = 2.0 * (ax * dx + ay * dy)
    c = ax * ax + ay * ay - radius * radius
    s = (-b + math.sqrt(max(b * b - 4.0 * a * c, 0.0))) / (2.0 * a)
    s = min(max(s, 0.0), 1.0)
    return p1[0] + s * dx, p1[1] + s * dy


#: Layout of the kernel's constants (built by ``RegulatedPurePursuit.reset``): RPPParams' fields in
#: declaration order, then the turns' heading gain and the robot's speed and yaw-rate limits.
_LOOKAHEAD_TIME, _MIN_LOOKAHEAD, _MAX_LOOKAHEAD, _MIN_RADIUS, _MIN_REGULATED, _APPROACH = range(6)
_MIN_APPROACH, _ALONG, _ROTATE, _HEADING, _VMAX, _WMAX = range(6, 12)


@nb.njit(cache=True)
def _carrot(
    path: FloatArray, near: int, end: int, x: float, y: float, lookahead: float, sgn: float
) -> tuple[float, float, int]:  # pragma: no cover - compiled
    """The carrot (x, y) [m] on the drive's path ending before row ``end``, and the closest row.

    ``path`` is (M, 4): x, y, heading and arc length of the reference at each control instant.
    """
    near = min(near, end - 1)
    gap, j, misses = math.hypot(path[near, 0] - x, path[near, 1] - y), near + 1, 0
    while j < end and misses < _PATIENCE:  # forwards from the last closest point, as Nav2 prunes
        d = math.hypot(path[j, 0] - x, path[j, 1] - y)
        if d < gap:
            near, gap, misses = j, d, 0
        else:
            misses += 1
        j += 1
    # no point closer along the path than lookahead - gap can be lookahead from the robot: start there
    j = near + int(np.searchsorted(path[near:end, 3], path[near, 3] + lookahead - gap))
    while j < end and math.hypot(path[j, 0] - x, path[j, 1] - y) < lookahead:
        j += 1
    if j < end:
        i = max(j - 1, near)
        gx, gy = circle_crossing(x, y, lookahead, (path[i, 0], path[i, 1]), (path[j, 0], path[j, 1]))
        return gx, gy, near
    lx, ly, lth = path[end - 1, 0], path[end - 1, 1], path[end - 1, 2]
    reach = sgn * 2.0 * lookahead
    gx, gy = circle_crossing(x, y, lookahead, (lx, ly), (lx + reach * math.cos(lth), ly + reach * math.sin(lth)))
    return gx, gy, near


@nb.njit(cache=True)
def _rpp_drive(
    path: FloatArray,
    c: FloatArray,
    near: int,
    end: int,
    pose: tuple[float, float, float],
    ref: tuple[float, float, float],
    sgn: float,
    v_last: float,
) -> tuple[float, float, int]:  # pragma: no cover - compiled
    """One period of Regulated Pure Pursuit (the module doc's steps 1-5): (v, omega, closest row).

    Args:
        path: (M, 4) x, y, heading and arc length of the reference at each control instant.
        c: The constants (indices ``_LOOKAHEAD_TIME`` ... ``_WMAX``).
        near: The closest row found the period before.
        end: One past the drive's last row.
        pose: The measured (x, y, theta).
        ref: The reference's (x, y, v) at this instant.
        sgn: +1 forwards, -1 backwards.
        v_last: The speed commanded the period before [m/s].
    """
    x, y, theta = pose
    lookahead = min(max(abs(v_last) * c[_LOOKAHEAD_TIME], c[_MIN_LOOKAHEAD]), c[_MAX_LOOKAHEAD])
    gx, gy, near = _carrot(path, near, end, x, y, lookahead, sgn)
    co, si = math.cos(theta), math.sin(theta)
    xc, yc = co * (gx - x) + si * (gy - y), -si * (gx - x) + co * (gy - y)
    bearing = math.atan2(yc, xc) if sgn > 0 else math.atan2(-yc, -xc)
    if abs(bearing) > c[_ROTATE]:
        return 0.0, c[_HEADING] * bearing, near
    kappa = 2.0 * yc / max(xc * xc + yc * yc, 1e-12)
    along = sgn * (co * (ref[0] - x) + si * (ref[1] - y))
    desired = min(max(abs(ref[2]) + c[_ALONG] * along, 0.0), c[_VMAX])
    v = desired
    radius = 1.0 / abs(kappa) if kappa != 0.0 else math.inf
    if radius < c[_MIN_RADIUS]:
        v = max(v * radius / c[_MIN_RADIUS], min(desired, c[_MIN_REGULATED]))
    remaining = path[end - 1, 3] - path[near, 3]
    if remaining < c[_APPROACH]:
        v = max(v * remaining / c[_APPROACH], min(desired, c[_MIN_APPROACH]))
    if abs(v * kappa) > c[_WMAX]:
        v = c[_WMAX] / abs(kappa)
    return sgn * v, sgn * v * kappa, near


@nb.njit(cache=True)
def _drive_period(
    t: float,
    x: float,
    y: float,
    theta: float,
    segment: int,
    near: int,
    v_last: float,
    block: FloatArray,
    path: FloatArray,
    c: FloatArray,
) -> tuple[int, float, float, int, float]:  # pragma: no cover - compiled
    """:meth:`RegulatedPurePursuit.command` in one compiled call while a drive is under way
    (:func:`control.segmented.drive_row`): (DRIVE, v, omega clamped as the general path clamps, the
    closest row, v before clamping); (GENERAL, nan, nan, near, v_last) for the general path to decide.
    ``path`` column 4 is the end (exclusive) of each row's segment."""
    i = drive_row(t, x, y, theta, segment, block)
    if i < 0:
        return GENERAL, math.nan, math.nan, near, v_last
    r = block[i]
    end = int(path[i - 1, 4])
    v, w, near = _rpp_drive(path, c, near, end, (x, y, theta), (r[0], r[1], r[3]), r[12], v_last)
    vc, wc = clamp_command(v, w, block[0])
    return DRIVE, vc, wc, near, v


class RegulatedPurePursuit(SegmentSwitcher):
    """Regulated Pure Pursuit on the drives; turns in place by segment (see the module doc).

    Source: S. Macenski, S. Singh, F. Martin, J. Gines, "Regulated Pure Pursuit for Robot Path
    Tracking", Autonomous Robots 47, 2023; Nav2 documentation, "Regulated Pure Pursuit"
    (docs.nav2.org/configuration/packages/configuring-regulated-pp.html); pure pursuit after
    R. C. Coulter, "Implementation of the Pure Pursuit Path Tracking Algorithm", CMU-RI-TR-92-01, 1992.

    Args:
        robot: Limits (max_speed, max_yaw_rate).
        params: Lookahead and regulation parameters; None for ``RPPParams()``.
        turns: Heading and spot-holding parameters of turns in place and stand-stills (its
            heading_gain also turns to the carrot); None for ``SegmentedParams()``.

    Raises:
        ConfigError: ``params`` is not an :class:`RPPParams` or ``turns`` not a :class:`SegmentedParams`.
    """

    name = "rpp"
    #: The option ``nhsim tune --tracker`` tunes, and its dataclass.
    TUNED = ("params", RPPParams)

    def __init__(
        self, robot: RobotSpec, *, params: RPPParams | None = None, turns: SegmentedParams | None = None
    ) -> None:
        self.params = option_value(self.name, "params", params, RPPParams())
        super().__init__(robot, option_value(self.name, "turns", turns, SegmentedParams()))
        # (M, 5) x, y, heading, arc length, the end (exclusive) of its segment's rows at each control instant
        self._track: FloatArray = np.zeros((0, 5))
        self._arc: FloatArray = np.zeros(0)
        self._c: FloatArray = np.zeros(12)
        self._near = 0
        self._v_last = 0.0

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking: the path (position, heading, arc length) of every control instant, the
        progress and speed at zero, the kernel's constants."""
        super().reset(trajectory, dt)
        pose = self._path
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(pose[:, 0]), np.diff(pose[:, 1])))])
        ends = np.zeros(len(pose))
        for start, end in self._spans:
            ends[start:end] = end
        self._track = np.column_stack([pose, arc, ends])
        self._arc = self._track[:, 3]
        p, r = self.params, self.robot
        fields = [getattr(p, f.name) for f in dataclasses.fields(p)]
        self._c = np.array([*fields, self._turns.heading_gain, r.max_speed, r.max_yaw_rate], dtype=float)
        self._near, self._v_last = 0, 0.0

    def _idle(self) -> None:
        self._v_last = 0.0

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command for the period starting at ``t`` (see :meth:`SegmentSwitcher.command`): one
        compiled call while a drive is under way (:func:`_drive_period`)."""
        if self._traj is not None:
            args = (self.segment, self._near, self._v_last, self._block, self._track, self._c)
            status, v, w, near, v_raw = _drive_period(t, x, y, theta, *args)
            if status == DRIVE:
                self._near, self._v_last = near, v_raw
                return v, w
        return super().command(t, x, y, theta)

    def _drive(self, x: float, y: float, theta: float, ref: _Instant, sgn: float, k: int) -> tuple[float, float]:
        """One period of Regulated Pure Pursuit along a drive of direction ``sgn`` (a compiled kernel:
        no allocation, the closest point searched forwards from the last one)."""
        start, end = self._spans[ref.segment]
        if ref.segment != self.segment:
            self._near = start
        pose, at = (float(x), float(y), float(theta)), (ref.x, ref.y, ref.v)
        v, w, self._near = _rpp_drive(self._track, self._c, self._near, end, pose, at, sgn, self._v_last)
        self._v_last = v
        return v, w
