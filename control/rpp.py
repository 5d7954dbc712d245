"""Regulated Pure Pursuit, as Nav2 describes it, on the drives of a timed trajectory.

Per control period, on the current drive's path (the reference positions at the control instants):

1. **Lookahead scaled with speed:** L = clip(|v| * lookahead_time, min_lookahead, max_lookahead),
   |v| the last speed commanded; then no longer than sqrt(8 R max_cut) (at least min_lookahead),
   R the tightest radius |v_r / omega_r| of the reference in the next L of the drive, so that the
   corner pure pursuit cuts, about L^2 / (8 R), stays within ``max_cut`` (this project's addition).
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
:mod:`control.switching`, so the tracker accepts every trajectory. Nav2's third
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
from control.switching import PerSegmentTracker, Record, SegmentedParams, dataclass_values, period, state_dtype
from planning.core.robot import RobotSpec
from planning.errors import ConfigError

#: Path points past the last closest one that may be farther before the search for the closest stops.
_PATIENCE = 4


@dataclass(frozen=True)
class RPPParams:
    """Parameters of Regulated Pure Pursuit (Nav2's names in brackets; ranges checked).

    The defaults are Nav2's except where its values exceed these small robots (its minimum
    lookahead 0.3 m and minimum regulated speed 0.25 m/s are above a TurtleBot3's 0.125 m tightest
    reference radius and 0.22 m/s top speed), ``lookahead_time`` and the bound ``max_cut``, which
    together keep the lookahead inside two limits (measured in physics with the fused estimate; a
    run counts when it ends within the worlds' 5 cm goal tolerance without contact or fall):

    - Stability, ``lookahead_time`` 1.0 s (Nav2 1.5 s): a lookahead scaled with speed makes the
      steering loop's natural frequency about sqrt(2) / lookahead_time whatever the speed, and it must
      stay slower than the robot's yaw can follow (the EduMIPs turn at most 0.5 rad/s and reverse
      that in 1 s). Shorter, the balancing EduMIP weaved about its path with its yaw rate saturated
      (43 of 60 counting on random700-759 at 0.8 s with a 0.2 m cap, 60 at 1.0 s); a fixed cap on
      the lookahead does the same at speed (random740's 0.8 m/s reverse with a 0.2 m cap: 5.7 rad/s).
    - Accuracy, ``max_cut`` 7 mm: pure pursuit cuts a turn of radius R by about L^2 / (8 R), and the
      EduMIP's plans turn as tight as 0.1 m after driving at up to 0.68 m/s: with Nav2's bounds alone
      (0.9 m, 1.5 s) 7 of 60 EduMIP runs counted on random700-759 (hybrid-a-star); no single cap kept
      both (0.3 m cut random716's turn into an obstacle, 0.2 m weaved on random740). The bound
      shortens the lookahead only before tight turns, where the reference is slow anyway. It was 1 cm
      until the physics counted the whole tyre's contacts (a 1 mm tyre rolls on the floor; the tyre
      itself is 12 mm wide on the EduMIP): 1 cm grazed obstacles on random707 and random716 (EduMIP,
      about a millimetre deep), 7 mm keeps all 180 runs of the three robots on random700-759.

    With these, every TurtleBot3 and EduMIP run on random700-759 (hybrid-a-star) and random740-779
    (birrt) counts, 339 of 340 (the balancing EduMIP meets an obstacle on random773 and falls, as it
    grazed it with every cap from 0.2 to 0.9 m and no bound); 4 held-out as-built robots each on
    random700-711 and random740-759 (birrt) count for both EduMIPs (``nhsim compare --runs 4``;
    tests/test_peer_trackers.py holds a sample and, slow, random720-759).
    Pure pursuit steers to a point of the path, not of the timed reference: a
    tracker of the reference (segmented, kanayama, mpc) is closer to it (docs/explanation/trackers.md).

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
        max_cut: Corner the lookahead may cut on the tightest turn ahead [m] (this project's; 0: no bound).
    """

    lookahead_time: float = ranged(1.0, 0.01, 10.0, "s", tune=(0.1, 5.0))
    min_lookahead: float = ranged(0.1, 0.01, 5.0, "m", tune=(0.02, 0.2))
    max_lookahead: float = ranged(0.9, 0.01, 10.0, "m")
    min_radius: float = ranged(0.3, 0.0, 10.0, "m", tune=(0.01, 2.0))
    min_regulated_speed: float = ranged(0.05, 0.0, 10.0, "m/s")
    approach_dist: float = ranged(0.2, 0.0, 10.0, "m", tune=(0.01, 1.0))
    min_approach_speed: float = ranged(0.05, 0.0, 10.0, "m/s")
    along_gain: float = ranged(1.0, 0.0, 100.0, "1/s", tune=(0.05, 10.0))
    rotate_angle: float = ranged(0.785, 0.01, math.pi, "rad")
    max_cut: float = ranged(0.007, 0.0, 1.0, "m, 0: no bound")

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


#: The state record: the switching's fields, then RPPParams' fields and the law's memory: the
#: closest row found the period before (``near``) and the speed the law commanded then (``v_last``).
STATE = state_dtype([*((f.name, "f8") for f in dataclasses.fields(RPPParams)), ("near", "i8"), ("v_last", "f8")])


@nb.njit(cache=True)
def _carrot(
    ref: NDArray[np.void], near: int, end: int, x: float, y: float, lookahead: float, sgn: float
) -> tuple[float, float, int]:  # pragma: no cover - compiled
    """The carrot (x, y) [m] on the drive's path (``ref`` rows before ``end``), and the closest row."""
    near = min(near, end - 1)
    gap, j, misses = math.hypot(ref[near].x - x, ref[near].y - y), near + 1, 0
    while j < end and misses < _PATIENCE:  # forwards from the last closest point, as Nav2 prunes
        d = math.hypot(ref[j].x - x, ref[j].y - y)
        if d < gap:
            near, gap, misses = j, d, 0
        else:
            misses += 1
        j += 1
    # no point closer along the path than lookahead - gap can be lookahead from the robot: start there
    j = near + int(np.searchsorted(ref["arc"][near:end], ref[near].arc + lookahead - gap))
    while j < end and math.hypot(ref[j].x - x, ref[j].y - y) < lookahead:
        j += 1
    if j < end:
        i = max(j - 1, near)
        gx, gy = circle_crossing(x, y, lookahead, (ref[i].x, ref[i].y), (ref[j].x, ref[j].y))
        return gx, gy, near
    last = ref[end - 1]
    reach = sgn * 2.0 * lookahead
    far = (last.x + reach * math.cos(last.theta), last.y + reach * math.sin(last.theta))
    gx, gy = circle_crossing(x, y, lookahead, (last.x, last.y), far)
    return gx, gy, near


@nb.njit(cache=True)
def _cut_bound(
    ref: NDArray[np.void], near: int, end: int, lookahead: float, max_cut: float
) -> float:  # pragma: no cover - compiled
    """The lookahead whose corner cut, L^2 / (8 R), is max_cut on the tightest turn of the path's next
    ``lookahead`` metres from row ``near``."""
    near = min(near, end - 1)
    limit = ref[near].arc + lookahead
    tight = math.inf
    j = near
    while j < end and ref[j].arc <= limit:
        w = abs(ref[j].omega)
        if w > 1e-9:
            tight = min(tight, abs(ref[j].v) / w)
        j += 1
    return math.sqrt(8.0 * tight * max_cut) if tight < math.inf else math.inf


@nb.njit(cache=True)
def drive(
    s: Record, ref: NDArray[np.void], k: int, x: float, y: float, theta: float, enter: bool, rested: bool
) -> tuple[float, float]:  # pragma: no cover - compiled
    """One period of Regulated Pure Pursuit along the drive of row ``k`` of ``ref`` (the module
    doc's steps 1-5): (v, omega) before clamping. Its memory: the closest row ``s.near`` (the drive's
    first on entering it) and the speed ``s.v_last`` it commanded the period before (0 after a rest)."""
    r = ref[k]
    sgn, end = r.sign, r.end
    if enter:
        s.near = r.start
    if rested:
        s.v_last = 0.0
    lookahead = min(max(abs(s.v_last) * s.lookahead_time, s.min_lookahead), s.max_lookahead)
    if s.max_cut > 0.0:
        lookahead = min(lookahead, max(s.min_lookahead, _cut_bound(ref, s.near, end, lookahead, s.max_cut)))
    gx, gy, s.near = _carrot(ref, s.near, end, x, y, lookahead, sgn)
    co, si = math.cos(theta), math.sin(theta)
    xc, yc = co * (gx - x) + si * (gy - y), -si * (gx - x) + co * (gy - y)
    bearing = math.atan2(yc, xc) if sgn > 0 else math.atan2(-yc, -xc)
    if abs(bearing) > s.rotate_angle:
        s.v_last = 0.0
        return 0.0, s.heading_gain * bearing
    kappa = 2.0 * yc / max(xc * xc + yc * yc, 1e-12)
    along = sgn * (co * (r.x - x) + si * (r.y - y))
    desired = min(max(abs(r.v) + s.along_gain * along, 0.0), s.vmax)
    v = desired
    radius = 1.0 / abs(kappa) if kappa != 0.0 else math.inf
    if radius < s.min_radius:
        v = max(v * radius / s.min_radius, min(desired, s.min_regulated_speed))
    remaining = ref[end - 1].arc - ref[s.near].arc
    if remaining < s.approach_dist:
        v = max(v * remaining / s.approach_dist, min(desired, s.min_approach_speed))
    if abs(v * kappa) > s.wmax:
        v = s.wmax / abs(kappa)
    s.v_last = sgn * v
    return sgn * v, sgn * v * kappa


@nb.njit(cache=True)
def _period(
    state: NDArray[np.void], ref: NDArray[np.void], t: float, x: float, y: float, theta: float
) -> tuple[int, float, float]:  # pragma: no cover - compiled
    return period(state, ref, t, x, y, theta, drive)


class RegulatedPurePursuit(PerSegmentTracker):
    """Regulated Pure Pursuit on the drives; turns in place by segment (see the module doc).

    Source: S. Macenski, S. Singh, F. Martin, J. Gines, "Regulated Pure Pursuit for Robot Path
    Tracking", Autonomous Robots 47, 2023; Nav2 documentation, "Regulated Pure Pursuit"
    (docs.nav2.org/configuration/packages/configuring-regulated-pp.html); pure pursuit after
    R. C. Coulter, "Implementation of the Pure Pursuit Path Tracking Algorithm", CMU-RI-TR-92-01, 1992.

    Args:
        robot: Limits (max_speed, max_yaw_rate; max_accel, max_yaw_accel smooth the commands).
        params: Lookahead and regulation parameters; None for ``RPPParams()``.
        turns: Heading and spot-holding parameters of turns in place and stand-stills (its
            heading_gain also turns to the carrot); None for ``SegmentedParams()``.

    Raises:
        ConfigError: ``params`` is not an :class:`RPPParams` or ``turns`` not a :class:`SegmentedParams`.
    """

    name = "rpp"
    #: Commands within the robot's acceleration limits (control/switching.py, a velocity smoother).
    SMOOTHED = True
    #: It follows the path, not the reference's clock: on a timed reference, which has no hold of final
    #: regulation, it trails and ends short (2-5 cm on the built-in references; nhsim simulate says so).
    FOLLOWS_CLOCK = False
    #: The option ``nhsim tune --tracker`` tunes, and its dataclass.
    TUNED = ("params", RPPParams)
    STATE = STATE
    DRIVE = staticmethod(drive)
    PERIOD = staticmethod(_period)

    def __init__(
        self, robot: RobotSpec, *, params: RPPParams | None = None, turns: SegmentedParams | None = None
    ) -> None:
        self.params = option_value(self.name, "params", params, RPPParams())
        super().__init__(robot, option_value(self.name, "turns", turns, SegmentedParams()))

    def law_values(self) -> dict[str, float]:
        """The parameters; the closest row and the last speed start at 0."""
        return {**dataclass_values(self.params), "near": 0, "v_last": 0.0}
