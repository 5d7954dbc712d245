"""A repaired trajectory or path file (:mod:`planning.trajectory.importer`) as a trajectory in a world.

A **timed** file is sampled every ``dt`` from its interpolant: positions and their derivatives, and
headings: along the motion where the robot moves (the direction of the curve's chord over
:data:`HEADING_LENGTH` of path and :data:`HEADING_WINDOW` of time, within one drive, continued along
the path near a drive's ends, where the motion is too short to resolve it; a robot that stays within
:data:`NOISE_FLOOR` for :data:`SETTLE_TIME`, a recording's settling, stands with a speed of 0) and, where
it stands, the file's own headings (their turn in place; shifted to meet the motion's heading at both
ends) or a turn from the arriving to the leaving heading. A file that gives headings keeps its own, as
where it stands, along a drive that resolves no direction (a wobble) and between a cusp and the resolved
motion on either side (:func:`_own_headings`). Then it
goes through the stage every timed plan goes through
(:func:`planning.trajectory.from_plan.make_trajectory`): segments from the sign of v, its own samples
kept (slowed uniformly, by at most :data:`MAX_STRETCH`, when it exceeds a limit) or re-timed from
rest to rest by the speed profile, with the reason: it starts or ends moving, it accelerates beyond
the robot's limits, or keeping its clock would take more than ``MAX_STRETCH`` times as long. A file
shorter than ``MIN_SAMPLES * dt`` is sampled ``MIN_SAMPLES`` times over its span, so that a clock far too
fast (seconds read as milliseconds) is judged by its speed; re-timed, such a file's poses are taken on
its clock slowed to a robot's pace (:func:`paced`), where its heading can be resolved.

An **untimed** path goes the way of a planner's path: loops cut, split at cusps and corners, each
drive fitted by piecewise polynomials and timed by the speed profile.

Both are checked against the world first: a robot footprint that enters an obstacle or leaves the
world is an error naming the time (or the row), the position and the obstacle, unless the file
asked to run anyway. Without a scenario, :func:`arena_scenario` builds an empty arena around it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import PPoly
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from planning.collision.exact import CollisionChecker
from planning.core.geometry import Pose2D, wrap_angle
from planning.core.robot import RobotSpec, check_robot_spec
from planning.core.scenario_type import Scenario
from planning.core.world import World
from planning.errors import ConfigError, option, options
from planning.planners.base import PlanResult, PlanStatus
from planning.trajectory.file_formats import TrajectoryFileError
from planning.trajectory.from_plan import (
    TrajectoryResult,
    TrajectoryStatus,
    check_option_names,
    fastest_sample,
    make_trajectory,
    time_scales,
)
from planning.trajectory.importer import (
    HEADING_TO_MOTION,
    MOVING_SPEED,
    Correction,
    ImportedFile,
    ImportReport,
    PositionCurve,
    fastest_row_speed,
    time_unit_fix,
)
from planning.trajectory.smoothing import check_options
from planning.trajectory.speed_profile import Limits
from planning.trajectory.trajectory import Trajectory

FloatArray = NDArray[np.float64]

#: Largest uniform slow-down of a file's own clock that still counts as keeping its timing.
MAX_STRETCH = 2.0
#: Share by which a file's acceleration may exceed its limit and still keep the file's clock (slowed
#: uniformly by the square root of it at most): the rows of a trajectory written at the limit differ
#: by their rounding (nhsim's own /reference reads 3e-7 above it), which re-timing would not be.
ROUNDING = 1e-3
#: Speed [m/s] above which a timed file's rows move faster than a robot's clock would (the fastest robot here goes
#: 0.8 m/s, and a clock more than MAX_STRETCH times too fast is not kept): such a file (a clock in seconds read as
#: milliseconds) is re-timed, and its poses are sampled on its clock slowed until its rows move at PACE_SPEED at
#: most (:func:`paced`). On its own clock a motion of a fraction of a second was shorter than the time windows its
#: heading is taken over: a quarter circle of 1 m radius in 0.2 s drove along its chord, and ended with the chord's
#: heading, 5 cm off its end.
FAST_CLOCK = 2.0
PACE_SPEED = 1.0
#: A re-timed file that keeping its clock would slow by this factor or more is said to have a clock that may
#: not count seconds (a robot's recording is not a hundred times too fast for it).
CLOCK_HINT = 100.0
#: Room between the file's extent (plus the robot's radius) and the walls of a default arena [m].
ARENA_MARGIN = 0.25
#: A file read in its own units spanning this many times the world's width or height may be in pixels.
PIXEL_HINT_FACTOR = 4.0
#: Largest side of a default arena [m]: a larger file is almost surely not in metres.
ARENA_MAX = 50.0
#: The robot of an arena built around a file when none is asked for.
ARENA_ROBOT = "turtlebot3"
#: Sample period of a timed file's samples [s].
DT = 0.01
#: Fewest sample intervals of a timed file: one lasting less than ``MIN_SAMPLES * DT`` is sampled that many
#: times over its span, not every DT. At DT, a file of 10 ms or less (a clock in seconds read as milliseconds)
#: was two samples, both at rest: its speed, between them, was never judged against the robot's limits.
MIN_SAMPLES = 20
#: Least time [s] and path [m] over which a timed file's direction of motion is taken (its heading
#: where it moves).
HEADING_WINDOW = 0.1
HEADING_LENGTH = 0.005
#: Turn [rad] at a row of an untimed file above which the robot arrives and leaves with two headings.
TURN_EPS = 1e-9
#: The noise floor of a recorded motion [m]: a robot whose samples stay within it (the diagonal of their
#: bounding box) for SETTLE_TIME stands (:func:`_settled`). nhsim's own /odom read back from its bag settles
#: at the goal with fix corrections of 0.2-0.6 mm every 0.2 s and encoder ticks of 0.025 mm, the ground
#: truth rocking by 0.1-0.3 mm; every one was a speed sign flip (a cusp) or a turn in place (65 rad/s).
NOISE_FLOOR = 1e-3
#: How long a stay within NOISE_FLOOR must last to stand [s]: a mean speed below MOVING_SPEED.
SETTLE_TIME = NOISE_FLOOR / MOVING_SPEED


@dataclass(frozen=True)
class DenseFile:
    """A timed file sampled every ``dt``.

    Attributes:
        t: (M,) times from 0 [s].
        pose: (M, 3) poses [x, y, theta], heading unwrapped [m, m, rad].
        v: (M,) signed speed [m/s].
        omega: (M,) yaw rate [rad/s].
        v_rows: (M,) the signed speed the rows themselves give (:func:`row_speeds`): what the file's
            acceleration is judged by (:func:`timing_verdict`).
        end_rows: ((time [s], speed [m/s]) of the middle of the first interval of rows, the same of the last):
            where ``v_rows`` leaves and meets the speeds at the file's ends (speeds 0 for a file that gives its
            velocities: it says itself where it rests).
        resolved: (M,) the samples whose heading is the motion's, resolved (:func:`_motion_headings`).
    """

    t: FloatArray
    pose: FloatArray
    v: FloatArray
    omega: FloatArray
    v_rows: FloatArray
    end_rows: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    resolved: NDArray[np.bool_] | None = None


def densify(imported: ImportedFile, dt: float = DT) -> DenseFile:
    """Sample a timed file every ``dt``, or :data:`MIN_SAMPLES` times over a shorter span (see the module doc)."""
    assert imported.t is not None and imported.curve is not None
    t0, t1 = float(imported.t[0]), float(imported.t[-1])
    if t1 - t0 < MIN_SAMPLES * dt:
        tg = np.linspace(t0, t1, MIN_SAMPLES + 1)
    elif (t1 - t0) % dt > 1e-9:
        tg = np.append(np.arange(t0, t1, dt), t1)
    else:
        tg = np.arange(t0, t1 + 0.5 * dt, dt)
    d = imported.curve(tg, 1)
    speed = np.hypot(d[:, 0], d[:, 1])
    k = np.clip(np.searchsorted(imported.t, tg, side="right") - 1, 0, imported.direction.size - 1)
    sgn = imported.direction[k]
    moving = _steady(_steady(speed > MOVING_SPEED, tg, False), tg, True)
    xy = imported.curve(tg, 0)
    settled = _settled(tg, xy)
    moving = _creeping(moving, tg, xy) & ~settled
    heading, resolved = _motion_headings(imported, tg, moving, sgn)
    turn = _turnbacks(moving, sgn, resolved, heading)
    if np.any(turn):  # the motion reverses without a stop: it stops at the turning point and turns there
        moving, settled, xy = moving & ~turn, settled | turn, _held_at_turning_points(xy, turn, speed)
    if imported.theta is not None:  # a wobble, and a cusp's unresolved ends, keep the file's headings
        moving &= ~_own_headings(moving, sgn, resolved)
    heading = _standing_headings(imported, tg, heading, moving)
    heading = np.unwrap(heading)
    pose = np.column_stack([xy, heading])
    v = np.where(settled, 0.0, sgn * speed)
    v_rows = row_speeds(imported, tg, v, settled)
    mids = 0.5 * (imported.t[[0, -2]] + imported.t[[1, -1]]) - t0
    step = np.hypot(*(imported.xy[[1, -1]] - imported.xy[[0, -2]]).T) / np.diff(imported.t)[[0, -1]]
    ends = step * imported.direction[[0, -1]] * (not imported.velocities)  # given velocities say where it rests
    end_rows = ((float(mids[0]), float(ends[0])), (float(mids[1]), float(ends[1])))
    return DenseFile(tg - t0, pose, v, np.gradient(heading, tg), v_rows, end_rows, resolved & moving)


def row_speeds(
    imported: ImportedFile, tg: FloatArray, v: FloatArray, settled: NDArray[np.bool_] | None = None
) -> FloatArray:
    """(M,) the signed speed the rows of a timed file give at times ``tg`` (M,) [s]: over each interval its
    distance over its time, in its travel direction, at its middle (0 for an interval whose middle lies where
    ``settled`` (M,) says the file stands: a recording's jitter at rest is no motion); linear between the middles,
    and from the interpolant's speed ``v`` (M,) at the first and last rows (at rest, or the given velocity).

    Its accelerations are the rows' own differences, each between the middles of two intervals, and
    sampled every ``dt`` (``np.gradient``) they are weighted means of those: a file whose rows are within
    the acceleration limits is, whatever an interpolant through them does between them. (Setting the samples
    where it stands to 0 instead made a step at a stand's first sample: a file slowing to a stand it held for a
    second or more was re-timed for an acceleration its rows do not have.)"""
    assert imported.t is not None
    t = imported.t
    u = np.hypot(*np.diff(imported.xy, axis=0).T) / np.diff(t) * imported.direction
    if settled is not None:
        u = np.where(np.interp(0.5 * (t[1:] + t[:-1]), tg, settled.astype(float)) >= 1.0, 0.0, u)
    knots = np.concatenate([t[:1], 0.5 * (t[1:] + t[:-1]), t[-1:]])
    return np.asarray(np.interp(tg, knots, np.concatenate([v[:1], u, v[-1:]])))


def _spans(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The first indices and the ends of ``mask``'s runs of True: runs ``[a[k], b[k])``, in order."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return edges[::2], edges[1::2]


def _steady(mask: NDArray[np.bool_], tg: FloatArray, value: bool) -> NDArray[np.bool_]:
    """``mask`` (M,) with its runs of ``not value`` shorter than HEADING_WINDOW (between runs of
    ``value``) set to ``value``: a speed hovering about MOVING_SPEED neither stops a drive for a sample
    nor starts one."""
    a, b = _spans(mask != value)  # runs [a, b) of not value
    short = (tg[b - 1] - tg[a] < HEADING_WINDOW) & (a > 0) & (b < tg.size)
    mark = np.zeros(tg.size + 1, dtype=np.int64)
    np.add.at(mark, a[short], 1)
    np.add.at(mark, b[short], -1)
    return np.where(np.cumsum(mark)[:-1] > 0, value, mask)


def _settled(tg: FloatArray, xy: FloatArray) -> NDArray[np.bool_]:
    """(M,) whether each sample stands still within the noise floor: it lies in a window of SETTLE_TIME whose
    samples all stay within NOISE_FLOOR (the diagonal of their bounding box), or in the file's last
    SETTLE_TIME from a settled sample on when the rest stays within it (the file ends before a whole window).

    Sub-millimetre motion is a recording's noise, not a motion to follow: a localiser's corrections and a
    settling robot's rocking, each step a direction of its own, made cusps of every sign flip and turns in
    place of every sideways correction. Samples ``DT`` apart (the last interval may be shorter).

    Args:
        tg: (M,) times [s].
        xy: (M, 2) positions [m].
    """
    m = tg.size
    if m < 2 or tg[-1] - tg[0] < SETTLE_TIME:
        return np.zeros(m, dtype=bool)
    n = min(round(SETTLE_TIME / float(np.median(np.diff(tg)))) + 1, m)
    shift = -(n // 2)  # window [i, i + n): the filters' origin moved to its start
    box = [maximum_filter1d(c, n, origin=shift) - minimum_filter1d(c, n, origin=shift) for c in xy.T]
    ok = np.hypot(*box) <= NOISE_FLOOR
    ok[m - n + 1 :] = False  # windows that run past the end (the filters repeat the last sample)
    start = np.flatnonzero(ok)
    mark = np.zeros(m + 1, dtype=np.int64)
    np.add.at(mark, start, 1)
    np.add.at(mark, np.minimum(start + n, m), -1)
    settled = np.cumsum(mark)[:-1] > 0
    tail = np.arange(max(m - n + 1, 0), m)  # windows cut by the end: from a settled sample on, if within it
    lo, hi = np.minimum.accumulate(xy[::-1])[::-1], np.maximum.accumulate(xy[::-1])[::-1]
    fits = settled[tail] & (np.hypot(*(hi[tail] - lo[tail]).T) <= NOISE_FLOOR)
    if np.any(fits):
        settled[tail[int(np.argmax(fits))] :] = True
    return settled


def _creeping(moving: NDArray[np.bool_], tg: FloatArray, xy: FloatArray) -> NDArray[np.bool_]:
    """``moving`` (M,) with the runs where the robot creeps on rather than stays set moving: those whose
    ends (the samples before and after them) are at least half of what MOVING_SPEED would cover in their
    time apart.

    A robot speeding up or slowing down through MOVING_SPEED over seconds hovers about it: its speed
    crosses it again and again for longer than HEADING_WINDOW, and every crossing split the motion into
    drives of tenths of a millimetre, each too short to resolve a direction, with turns between them
    (yaw accelerations of 5-20 rad/s^2 along slow arcs written with 4 to 6 decimals). Where the robot
    stays (a stand-still, a stop at a sharp corner: at most 0.35 of MOVING_SPEED's distance about a
    right angle, a start or an end from rest: a third) it is still standing.

    Args:
        moving: (M,) whether each sample moves.
        tg: (M,) times [s].
        xy: (M, 2) positions [m].
    """
    a, b = _spans(~moving)  # standing runs [a, b)
    i, j = np.maximum(a - 1, 0), np.minimum(b, tg.size - 1)
    creep = np.hypot(*(xy[j] - xy[i]).T) >= 0.5 * MOVING_SPEED * (tg[j] - tg[i])
    creep &= tg[j] > tg[i]
    mark = np.zeros(tg.size + 1, dtype=np.int64)
    np.add.at(mark, a[creep], 1)
    np.add.at(mark, b[creep], -1)
    return moving | (np.cumsum(mark)[:-1] > 0)


def _runs(moving: NDArray[np.bool_], sgn: FloatArray) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(M,) each sample's run and each run's first sample: the drives (moving samples of one travel direction,
    ``sgn``) and the stands between them, in order."""
    new = np.concatenate([[True], (sgn[1:] != sgn[:-1]) | (moving[1:] != moving[:-1])])
    return np.cumsum(new) - 1, np.flatnonzero(new)


def _run_edges(run: NDArray[np.intp], runs: int, idx: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Each of the ``runs`` runs' first and last sample among the increasing sample indices ``idx`` (-1: none), ``run``
    each sample's run (:func:`_runs`)."""
    first, last = np.full(runs, -1), np.full(runs, -1)
    first[run[idx[::-1]]] = idx[::-1]  # the last write wins: the first of each run
    last[run[idx]] = idx
    return first, last


def _motion_headings(
    imported: ImportedFile, tg: FloatArray, moving: NDArray[np.bool_], sgn: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """(M,) heading of the motion at times tg (M,) [rad], backwards where ``sgn`` is -1, at the moving
    samples (the others are placeholders that :func:`_standing_headings` replaces), and (M,) where the motion
    resolves it (below).

    Where the motion **resolves** it: the direction of the curve's chord about each time over at least
    HEADING_LENGTH of path (or what HEADING_WINDOW of time covers, if more), symmetric in path, each end
    of it the mean position over HEADING_WINDOW about it, all inside the sample's own drive (moving
    samples of one travel direction), the chord at least half that path (a wobble back and forth, a recording's
    rocking, goes nowhere: its chord points anywhere). Over a window rather than at an instant: a file's rounding,
    differentiated between rows 0.01 s apart, turns the direction of a slow motion by tenths of a radian
    from row to row (1 um of rounding at 1 mm/s); over 5 mm of path the same rounding turns it by less
    than a milliradian, and the means keep one row's rounding from jerking the heading as the chord
    slides past it (yaw accelerations of 1.7 rad/s^2 from end points alone, 0.2 with the means, every
    0.01 s along the slow arc of ``tests/test_row_curves.py``). Symmetric in path, the chord of a circle
    is parallel to its tangent at the chord's middle, so a steady turn keeps its heading exactly, at
    any speed profile.

    Near a drive's ends, where such a chord does not fit inside the drive, the motion is too short to
    resolve a direction (a chord of 0.1 mm turns by 0.01 rad with 1 um of rounding: a slowly starting
    robot jerked its heading at 5-9 rad/s^2 while its speed was near MOVING_SPEED, and the file was
    re-timed): there the heading continues the resolved one along the path, turning with the curvature
    the resolved headings have over the first (last) HEADING_LENGTH / 2 of path (exact on a circle). A
    drive too short for any resolved chord keeps the direction of its whole chord."""
    assert imported.curve is not None
    run, starts = _runs(moving, sgn)
    ends = np.append(starts[1:], tg.size) - 1
    lo, hi = tg[starts[run]], tg[ends[run]]
    xy = imported.curve(tg, 0)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])  # path length [m]
    # half the chord in path: HEADING_LENGTH / 2, or what HEADING_WINDOW / 2 of time covers if more
    around = np.interp(tg + 0.5 * HEADING_WINDOW, tg, s) - np.interp(tg - 0.5 * HEADING_WINDOW, tg, s)
    half = np.maximum(0.5 * HEADING_LENGTH, 0.5 * around)
    ta, tb = np.interp(s - half, s, tg), np.interp(s + half, s, tg)
    w = 0.5 * HEADING_WINDOW  # each end of the chord: the mean position over HEADING_WINDOW about it
    resolved = (s - half >= s[starts[run]]) & (s + half <= s[ends[run]]) & (ta - w >= lo) & (tb + w <= hi)
    chord = imported.curve.mean(tb - w, tb + w) - imported.curve.mean(ta - w, ta + w)
    resolved &= np.hypot(chord[:, 0], chord[:, 1]) >= half  # it went somewhere: not a wobble back and forth
    whole = ~np.isin(run, run[resolved])  # drives without a resolved chord: the whole drive's
    chord[whole] = imported.curve(hi[whole], 0) - imported.curve(lo[whole], 0)
    flat = np.hypot(chord[:, 0], chord[:, 1]) == 0.0  # a run of one sample: its velocity
    chord[flat] = imported.curve(tg[flat], 1)
    heading = np.arctan2(sgn * chord[:, 1], sgn * chord[:, 0])
    idx = np.flatnonzero(resolved)
    if idx.size == 0:
        return heading, resolved
    first, last = _run_edges(run, starts.size, idx)  # each drive's first and last resolved sample
    for edge, toward in ((first, 1), (last, -1)):
        k = edge[run]  # each sample's resolved edge of its drive (-1: none)
        out = (k >= 0) & (toward * (np.arange(tg.size) - k) < 0)
        k = k[out]
        other = last[run[out]] if toward > 0 else first[run[out]]
        # the resolved sample half HEADING_LENGTH of path further in (at most the drive's other edge)
        far = np.searchsorted(s, s[k] + toward * 0.5 * HEADING_LENGTH, side="left" if toward > 0 else "right")
        far = far - (toward < 0)
        far = np.clip(far, np.minimum(k, other), np.maximum(k, other))
        span = s[far] - s[k]
        with np.errstate(divide="ignore", invalid="ignore"):
            curvature = np.where(span != 0.0, wrap_angle(heading[far] - heading[k]) / span, 0.0)
        heading[out] = heading[k] + curvature * (s[out] - s[k])
    return heading, resolved


def _turnbacks(
    moving: NDArray[np.bool_], sgn: FloatArray, resolved: NDArray[np.bool_], heading: FloatArray
) -> NDArray[np.bool_]:
    """(M,) the samples of each stretch inside one drive (:func:`_runs`) whose motion resolves no direction
    (:func:`_motion_headings`) between resolved headings more than a right angle apart: where the path turns back
    without a stop (an out-and-back written forwards, a position that jumps out and back). The chord there points
    anywhere, and the heading flipped by pi from one sample to the next while the robot drove on (a trajectory whose
    poses contradict its velocities by metres, the flip spread along the whole drive when it was re-timed); such a
    stretch is a stop at the turning point and a turn in place from the arriving heading to the leaving one."""
    run, _ = _runs(moving, sgn)
    idx = np.flatnonzero(resolved & moving)
    out = np.zeros(moving.size, dtype=bool)
    inside = np.flatnonzero((np.diff(idx) > 1) & (run[idx[:-1]] == run[idx[1:]]))  # gaps within one drive
    for a, b in zip(idx[inside] + 1, idx[inside + 1], strict=True):
        if abs(float(wrap_angle(heading[b] - heading[a - 1]))) > 0.5 * np.pi:
            out[a:b] = True
    return out


def _held_at_turning_points(xy: FloatArray, turn: NDArray[np.bool_], speed: FloatArray) -> FloatArray:
    """``xy`` (M, 2) with each stretch of ``turn`` (:func:`_turnbacks`) held at its turning point, its slowest
    sample (``speed`` (M,)): the robot stands there while it turns (a few millimetres of the curve's
    ``HEADING_LENGTH`` about the point)."""
    out = xy.copy()
    for a, b in zip(*_spans(turn), strict=True):
        out[a:b] = xy[a + int(np.argmin(speed[a:b]))]
    return out


def _given_heading(imported: ImportedFile, tg: FloatArray) -> FloatArray | None:
    """The file's own headings at times tg: Hermite with checked yaw rates, else monotone cubic."""
    from scipy.interpolate import CubicHermiteSpline, PchipInterpolator

    if imported.theta is None:
        return None
    assert imported.t is not None
    if imported.omega is not None:
        return np.asarray(CubicHermiteSpline(imported.t, imported.theta, imported.omega)(tg))
    return np.asarray(PchipInterpolator(imported.t, imported.theta)(tg))


def _standing_headings(
    imported: ImportedFile, tg: FloatArray, heading: FloatArray, moving: NDArray[np.bool_]
) -> FloatArray:
    """Headings while standing: the file's own (shifted to meet the motion at both ends), else a turn
    from the arriving heading to the leaving one."""
    if not np.any(moving):
        given = _given_heading(imported, tg)
        return given if given is not None else np.zeros_like(tg)
    own = _given_heading(imported, tg)
    out = heading.copy()
    for a, b in zip(*_spans(~moving), strict=True):  # standing runs [a, b)
        before, after = (a - 1 if a > 0 else b), (b if b < tg.size else a - 1)
        h0, h1 = heading[before], heading[after]
        w = (tg[a:b] - tg[a]) / max(tg[b - 1] - tg[a], 1e-12)
        if own is None:
            out[a:b] = h0 + w * wrap_angle(h1 - h0)
        else:
            d0, d1 = wrap_angle(h0 - own[before]), wrap_angle(h1 - own[after])
            out[a:b] = own[a:b] + d0 + w * (d1 - d0)
    return out


def _own_headings(moving: NDArray[np.bool_], sgn: FloatArray, resolved: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """(M,) the moving samples where a file that gives headings keeps its own, as where it stands: along a drive (a
    run of moving samples of one travel direction) with no resolved sample (:func:`_motion_headings`), and between a
    cusp (two drives of opposite direction, no stand between them) and the nearest resolved sample on either side.

    A drive that resolves no direction took its whole chord's, and where a recording wobbles as it stops, reverses
    and turns in place (a balancing EduMIP's odometry read back from its bag: steps of tenths of a millimetre, its
    wheel speed's sign flipping every few rows) every short chord pointed elsewhere: the heading flipped by pi from
    one to the next (157 rad/s), and the run was re-timed to 370 times its length. At a cusp each drive's end
    continued its resolved heading along the path, and the two continuations met apart (the balancing EduMIP rolling
    back 3 cm as it leaned, then driving off: a turn at once, 204 rad/s^2), where the robot reverses without turning
    and the file's heading says so."""
    n = moving.size
    run, starts = _runs(moving, sgn)
    driving = moving[starts]  # per run
    cusp_before = np.concatenate([[False], driving[:-1]]) & driving
    cusp_after = np.concatenate([driving[1:], [False]]) & driving
    first, last = _run_edges(run, starts.size, np.flatnonzero(resolved & moving))
    i = np.arange(n)
    unresolved = last[run] < 0  # (first is then -1 too)
    return moving & (unresolved | (cusp_before[run] & (i < first[run])) | (cusp_after[run] & (i > last[run])))


def _note_headings(imported: ImportedFile, dense: DenseFile) -> None:
    """Say in the file's report how far its given headings are off the direction of motion, at most, where it is
    more than HEADING_TO_MOTION: judged at the rows whose nearest sample's heading is the resolved motion's
    (:attr:`DenseFile.resolved`; the heading follows the motion there). Not at a cusp's row, a wobble's or a
    drive's first millimetres, where the motion resolves no direction: judged row by row from the curve's
    velocity, a balancing robot rolling back as it leaned was said to be off by pi at the row where it reversed."""
    if imported.theta is None or dense.resolved is None or imported.t is None:
        return
    rows_t = imported.t - imported.t[0]
    k = np.clip(np.searchsorted(dense.t, rows_t), 1, dense.t.size - 1)
    k = np.where(dense.t[k] - rows_t > rows_t - dense.t[k - 1], k - 1, k)  # the sample nearest each row
    d = wrap_angle(dense.pose[k, 2] - imported.theta)
    off = np.where(dense.resolved[k], np.abs(d), 0.0)
    row = int(np.argmax(off))
    if off[row] <= HEADING_TO_MOTION:
        return
    imported.report.notes.append(
        f"headings disagree with the direction of motion by up to {off[row]:.3f} rad ({imported.rows[row]}; "
        f"tolerance {HEADING_TO_MOTION:g} rad): the heading follows the motion where the robot moves"
    )
    given, used = float(imported.theta[row]), float(imported.theta[row] + d[row])
    fix = Correction("headings theta", imported.rows[row], (given,), (used,), float(off[row]), HEADING_TO_MOTION, "rad")
    imported.report.corrections.append(fix)


#: What a file moving at an end is told (:func:`timing_verdict`): its rows' speed there, without velocities given,
#: meets rest within half an interval, an acceleration no robot has.
AT_REST = ", and a file without velocities is taken to start and end at rest, as the robot does"


def timing_verdict(dense: DenseFile, limits: Limits) -> tuple[bool, str, float]:
    """Whether a timed file must be re-timed, why (or how its clock is kept), and the stretch kept.

    The file's acceleration is judged by its rows' own speeds (``dense.v_rows``): a curve through the rows
    is no measure of it, as a C2 spline rings by about 6 % at every step of the acceleration; a file
    within the limits keeps its clock, slowed uniformly as far as its curve needs (``stretch``, what
    :func:`planning.trajectory.from_plan.make_trajectory` does with a kept clock).

    Returns:
        ``(retime, reason, stretch)``: stretch is the uniform slow-down of a kept clock (1 for none).
    """
    v, w, t = dense.v, dense.omega, dense.t
    dv, dw = np.gradient(dense.v_rows, t), np.gradient(w, t)
    speed_scale, accel_scale = time_scales(v, w, dv, dw, limits)
    curve_scale = time_scales(v, w, np.gradient(v, t), dw, limits)[1]
    fast = ""  # said beside the first reason too: a file at 3x the speed limit was said to start moving, only
    if speed_scale > 1.0 + 1e-9:
        k = fastest_sample(v, w, limits)
        fast = f"; it is also x{speed_scale:.3g} too fast for the speed and yaw-rate limits (v {v[k]:+.3g} m/s at t = "
        fast += f"{t[k]:.2f} s)"
    if abs(v[0]) > 1e-3 or abs(v[-1]) > 1e-3:
        end, value = ("starts", v[0]) if abs(v[0]) > 1e-3 else ("ends", v[-1])
        return True, f"it {end} moving ({value:+.3f} m/s) and the robot starts and ends at rest{fast}", 1.0
    if accel_scale > max(speed_scale, np.sqrt(1.0 + ROUNDING)):
        (t_first, v_first), (t_last, v_last) = dense.end_rows
        ends_at = (("starts", v_first, "first"), ("ends", v_last, "last"))
        moving = [(end, f"{v:+.3f} m/s over its {rows} rows") for end, v, rows in ends_at if abs(v) > MOVING_SPEED]
        # where the gradient reads only the rows' own speeds: both neighbours between the ends' interval middles
        inside = np.zeros(t.size, dtype=bool)
        inside[1:-1] = (t[:-2] >= t_first) & (t[2:] <= t_last)
        if moving:  # what the rows themselves do, the rest met at the ends left out
            dv, dw = np.where(inside, dv, 0.0), np.where(inside, dw, 0.0)
            if time_scales(v, w, dv, dw, limits)[1] <= max(speed_scale, np.sqrt(1.0 + ROUNDING)):
                ends, speeds = " and ".join(m[0] for m in moving), ", ".join(m[1] for m in moving)
                return True, f"it {ends} moving ({speeds}){AT_REST}{fast}", 1.0
        ka, kw = int(np.argmax(np.abs(dv))), int(np.argmax(np.abs(dw)))
        if abs(dv[ka]) / limits.max_accel >= abs(dw[kw]) / limits.max_yaw_accel:
            what, k, peak, unit, limit = "acceleration", ka, abs(dv[ka]), "m/s^2", limits.max_accel
        else:
            what, k, peak, unit, limit = "yaw acceleration", kw, abs(dw[kw]), "rad/s^2", limits.max_yaw_accel
        return True, f"its {what} reaches {peak:.3g} {unit} at t = {t[k]:.2f} s (limit {limit:.3g} {unit})", 1.0
    if speed_scale > MAX_STRETCH:
        why = f"keeping its clock within the speed and yaw-rate limits would slow it x{speed_scale:.3g}"
        k = fastest_sample(v, w, limits)  # where: a jump's rows
        vk, wk = round(v[k], 3) + 0.0, round(w[k], 3) + 0.0  # 0.000, not -7.08e-12 (rounding's noise) or -0.000
        at = f"v {vk:+.3f} m/s, omega {wk:+.3f} rad/s at t = {t[k]:.2f} s"
        return True, f"{why} (more than x{MAX_STRETCH:g}; its fastest: {at})", 1.0
    stretch = max(speed_scale, curve_scale)  # as make_trajectory slows a kept clock
    if stretch > 1.0 + 1e-9:
        which = "speed and yaw-rate" if speed_scale >= curve_scale else "acceleration"
        return False, f"slowed uniformly x{stretch:.3f} to stay within the {which} limits", stretch
    return False, "within the robot's limits", 1.0


def _clock_hint(dense: DenseFile, limits: Limits, time_scale: float | None) -> str:
    """What to add to the reason of a re-timed file whose clock, kept, would be slowed CLOCK_HINT times or more:
    that its time unit may not be seconds (a clock in seconds read as milliseconds; a wrong ``--time-scale``)."""
    rest = np.zeros_like(dense.v)
    if time_scales(dense.v, dense.omega, rest, rest, limits)[0] < CLOCK_HINT:  # as timing_verdict's speed scale
        return ""
    given = time_scale is not None and time_scale != 1.0
    return f"; {'' if given else 'if its stamps are not in seconds, '}{time_unit_fix(time_scale)}"


# ------------------------------------------------------------------------------------ the world
def _culprit(world: World, xy: FloatArray) -> tuple[bool, str]:
    """What a robot at ``xy`` (2,) runs into: (a wall?, its description), the nearest by its centre."""
    xmin, xmax, ymin, ymax = world.bounds
    found: list[tuple[float, bool, str]] = [
        (xy[0] - xmin, True, f"the wall x = {xmin:g}"),
        (xmax - xy[0], True, f"the wall x = {xmax:g}"),
        (xy[1] - ymin, True, f"the wall y = {ymin:g}"),
        (ymax - xy[1], True, f"the wall y = {ymax:g}"),
    ]
    for k, obs in enumerate(world.obstacles):
        x0, x1, y0, y1 = obs.bounding_box()
        label = f"obstacle {k} ({obs.kind} about ({0.5 * (x0 + x1):.2f}, {0.5 * (y0 + y1):.2f}))"
        found.append((float(obs.signed_distance(xy[None])[0]), False, label))
    _, wall, label = min(found, key=lambda f: f[0])
    return wall, label


def _pixel_hint(imported: ImportedFile, world: World) -> str:
    """A hint to give a scale when the file was read in its own units and is several times larger than the
    world (a file in metres that is a little too large is not in pixels)."""
    if imported.source.scale is not None:
        return ""
    span = np.ptp(imported.xy, axis=0)
    if span[0] <= PIXEL_HINT_FACTOR * world.width and span[1] <= PIXEL_HINT_FACTOR * world.height:
        return ""
    return (
        f"; the file spans {span[0]:.4g} x {span[1]:.4g} units but the world is {world.width:g} x {world.height:g} m: "
        f"if its units are pixels (or millimetres), give the metres per unit, e.g. {option('scale', 0.01)} for 1 cm "
        "per pixel"
    )


def check_world(
    imported: ImportedFile, poses: FloatArray, times: FloatArray | None, world: World, robot: RobotSpec
) -> str:
    """Check the robot's footprint along (M, 3) ``poses`` against the world.

    Args:
        imported: The file (its options and rows, for the message).
        poses: (M, 3) poses along the motion, dense enough to check.
        times: (M,) their times [s] from the file's first row on its clock (a trajectory: the time and its nearest
            row are named), or None (a path: the nearest row is named).
        world: The world.
        robot: The robot (its footprint).

    Returns:
        "" when the footprint stays clear, else what happened (with ``allow_collisions``).

    Raises:
        TrajectoryFileError: The footprint enters an obstacle or leaves the world at some pose (the
            message names the time or row, the position and the obstacle or wall) and the file does
            not allow collisions.
    """
    clear = CollisionChecker(world, robot, shape="footprint").clearance_of(poses)
    bad = np.flatnonzero(clear <= 0.0)
    if bad.size == 0:
        return ""
    k = int(bad[0])
    x, y = poses[k, :2]
    wall, label = _culprit(world, poses[k, :2])
    if times is not None:  # from the first row, on the file's clock (a log's stamps may be Unix times): and its row
        assert imported.t is not None
        row = int(np.argmin(np.abs(imported.t - imported.t[0] - times[k])))
        when = f"at t = {times[k]:.2f} s from its first row (near {imported.rows[row]})"
    else:
        when = f"near {imported.rows[int(np.argmin(np.hypot(*(imported.xy - poses[k, :2]).T)))]}"
    what = f"leaves the world across {label}" if wall else f"enters {label}"
    finding = f"{imported.source.path}: the robot {what} {when}, at ({x:.3f}, {y:.3f}) m"
    if imported.source.allow_collisions:
        return finding + f"; run anyway, as {option('allow-collisions', True)} asks"
    fixes = options("offset", "scale", "scenario", ("allow-collisions", True), conjunction="or")
    raise TrajectoryFileError(
        f"{finding}{_pixel_hint(imported, world)}; move the file, scale it, choose another world, or run it "
        f"anyway: {fixes}"
    )


def path_poses(imported: ImportedFile) -> FloatArray:
    """(M, 3) poses of an untimed file: its headings, else those of its steps, driven forwards.

    Without headings, a row where the path turns is the robot there twice: arriving along the step
    before, then leaving along the step after (a turn in place between them, as a planner's polyline
    gives it). The smoothing rounds off the turns that are gentle enough and stops to turn at the
    sharp ones, a U-turn included. Giving the row only its leaving heading made a drive end pointing
    away from its own motion: a path that went out and came back could not be smoothed.
    """
    xy = imported.xy
    if imported.theta is not None:
        return np.column_stack([xy, imported.theta])
    d = np.diff(xy, axis=0)  # every step moves: the import merged repeated rows
    h = np.arctan2(d[:, 1], d[:, 0])
    arrive, leave = np.append(h[:1], h), np.append(h, h[-1:])  # per row: the step into it, the step out
    turn = np.abs(wrap_angle(leave - arrive)) > TURN_EPS
    rows = np.repeat(np.arange(xy.shape[0]), np.where(turn, 2, 1))
    first = np.concatenate([[True], rows[1:] != rows[:-1]])  # a row's arriving pose, then its leaving one
    heading = np.where(first, arrive[rows], leave[rows])
    return np.column_stack([xy[rows], np.unwrap(heading)])


def paced(imported: ImportedFile) -> tuple[ImportedFile, float]:
    """A timed file whose rows move faster than FAST_CLOCK, on its clock slowed by the factor that brings them
    to PACE_SPEED at most (its times, curve and yaw rates scaled), and that factor; else the file as it is, 1.

    The shape of the motion (positions, headings, stops) is the file's, sampled where its heading can be taken:
    only the poses of such a file are used (it is re-timed), never its clock."""
    assert imported.t is not None and imported.curve is not None
    fastest = fastest_row_speed(imported.t, imported.xy)
    if fastest <= FAST_CLOCK:
        return imported, 1.0
    k = fastest / PACE_SPEED
    poly = imported.curve.poly
    order = poly.c.shape[0] - 1
    coefficients = poly.c / k ** (order - np.arange(order + 1, dtype=float)).reshape(-1, *([1] * (poly.c.ndim - 1)))
    curve = PositionCurve(PPoly.construct_fast(coefficients, poly.x * k))
    omega = imported.omega / k if imported.omega is not None else None
    return dataclasses.replace(imported, t=imported.t * k, curve=curve, omega=omega), k


def file_poses(imported: ImportedFile) -> FloatArray:
    """(M, 3) poses along the file: a trajectory's dense samples (of a fast one, :func:`paced`), a path's rows."""
    return densify(paced(imported)[0]).pose if imported.source.timed else path_poses(imported)


def with_file_ends(scenario: Scenario, imported: ImportedFile) -> Scenario:
    """The scenario starting where the file starts and with its goal where the file ends."""
    poses = file_poses(imported)
    start, goal = (Pose2D(float(p[0]), float(p[1]), wrap_angle(float(p[2]))) for p in (poses[0], poses[-1]))
    return dataclasses.replace(scenario, start=start, goal=goal)


#: Name of the arena built around a file when no scenario is given.
ARENA_NAME = "arena"


def arena_scenario(imported: ImportedFile, robot: RobotSpec) -> Scenario:
    """An empty arena around the file: its extent plus the robot's radius and ``ARENA_MARGIN`` on
    every side, starting and ending where the file does.

    Raises:
        TrajectoryFileError: The arena would be wider than ``ARENA_MAX`` (the message suggests --scale).
    """
    xy = file_poses(imported)[:, :2]
    pad = robot.radius + ARENA_MARGIN
    lo, hi = xy.min(axis=0) - pad, xy.max(axis=0) + pad
    if float(np.max(hi - lo)) > ARENA_MAX:
        span = np.ptp(xy, axis=0)
        raise TrajectoryFileError(
            f"{imported.source.path}: the file spans {span[0]:.4g} x {span[1]:.4g} m, and with {pad:.3g} m around it "
            f"for the robot (its radius and {ARENA_MARGIN:g} m) more than the {ARENA_MAX:g} m an arena is built for: "
            f"give the world with {option('scenario')}, or, if its units are not metres (pixels, millimetres), the "
            f"metres per unit, e.g. {option('scale', 0.01)} for 1 cm per pixel"
        )
    world = World((float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])))
    sc = Scenario(
        ARENA_NAME,
        robot.name,
        world,
        Pose2D(0.0, 0.0, 0.0),
        Pose2D(0.0, 0.0, 0.0),
        description=f"empty arena around {imported.source.path}",
    )
    return with_file_ends(sc, imported)


# ------------------------------------------------------------------------------- the trajectory
def _note_end(report: ImportReport, trajectory: Trajectory, span: float) -> None:
    """Say what the trajectory adds after a kept clock's ``span`` [s] (the file's, stretched): every reference
    made here ends at its goal with a stand-still (after a turn to the goal heading where the motion ends
    pointing elsewhere), which the segmented tracker settles in."""
    after = int(np.searchsorted(trajectory.t, trajectory.t[0] + span + 1e-9))
    extra = float(trajectory.t[-1] - trajectory.t[0]) - span
    if after >= trajectory.t.size or extra <= 0.0:
        return
    assert trajectory.segments is not None
    kinds = trajectory.segment_kinds[int(trajectory.segments[after]) :]
    what = "a turn to the file's last heading, then a stand-still" if "rotate" in kinds else "a stand-still"
    report.notes.append(
        f"end: the file's {span:.2f} s then {extra:.2f} s at its last position ({what}), as every reference ends"
    )


def file_trajectory(imported: ImportedFile, robot: RobotSpec, world: World, **options: Any) -> TrajectoryResult:
    """The trajectory of a repaired file in a world (see the module doc); the report says how.

    Args:
        imported: From :func:`planning.trajectory.importer.read_trajectory_file`.
        robot: The robot (limits, footprint).
        world: The world.
        **options: Further :func:`planning.trajectory.from_plan.make_trajectory` options.

    Returns:
        A successful result, or (with ``allow_collisions``) one whose status is ``COLLISION``.

    Raises:
        TrajectoryFileError: The file enters an obstacle or leaves the world (see :func:`check_world`).
        ConfigError: ``imported`` is not a file as read (a path: read it first).
    """
    if not isinstance(imported, ImportedFile):
        raise ConfigError(
            f"file_trajectory takes a file as read, got {type(imported).__name__}: "
            "file_trajectory(read_trajectory_file(path), robot, world).trajectory is a path's Trajectory"
        )
    robot = check_robot_spec("file_trajectory", robot)  # read before make_trajectory checks it
    check_option_names("file_trajectory", options)
    options = check_options(options)  # where the smoothing options enter, as to_trajectory's do
    source, report = imported.source, imported.report
    name = f"file:{source.name}"
    goal = with_file_ends(Scenario("file", robot.name, world, Pose2D(0, 0, 0), Pose2D(0, 0, 0)), imported).goal
    if source.timed:
        dense = densify(imported)
        _note_headings(imported, dense)
        limits = Limits.from_robot(robot, options.get("margin", 0.85))
        retime, why, _ = timing_verdict(dense, limits)
        why += _clock_hint(dense, limits, source.time_scale) if retime else ""
        k = 1.0
        if retime:  # its clock is not kept: a fast file's poses from its clock slowed k times
            slow, k = paced(imported)
            dense = densify(slow) if k != 1.0 else dense
        report.world = check_world(imported, dense.pose, dense.t / k, world, robot)
        plan = PlanResult(
            PlanStatus.SUCCESS, name, dense.pose, times=dense.t, controls=np.column_stack([dense.v, dense.omega])
        )
        res = make_trajectory(plan, robot, world, goal=goal, retime=retime, name=name, **options)
        report.retimed, report.timing = retime, why
        report.time_stretch = float(res.stats.get("time_scale") or 1.0)
        if not retime and res.trajectory is not None:
            _note_end(report, res.trajectory, float(dense.t[-1]) * report.time_stretch)
    else:
        poses = path_poses(imported)
        checker = CollisionChecker(world, robot, shape="footprint")
        report.world = check_world(imported, checker.densify(poses), None, world, robot)
        res = make_trajectory(poses, robot, world, goal=goal, name=name, keep_loops=True, **options)
        report.timing = "a path has no clock: timed by the speed profile within the robot's limits"
    report.collisions_allowed = bool(report.world)
    ok = res.success or (source.allow_collisions and res.status is TrajectoryStatus.COLLISION)
    if not ok or res.trajectory is None:
        from planning.trajectory.from_plan import TrajectoryError

        raise TrajectoryError(f"{source.path}: {res.reason}")
    return res
