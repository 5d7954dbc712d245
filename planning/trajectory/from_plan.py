"""One way from any plan to a trackable trajectory: smoothing, speed profile, cusps and turns in place.

Two kinds of plan arrive:

* **Untimed paths** (the sampling planners; any (N, 3) array of poses): stretches that return to
  a pose already visited are cut (:func:`planning.trajectory.smoothing.remove_loops`), then split at cusps, sharp
  corners and turns in place (:func:`planning.trajectory.smoothing.split_path`); each drive is fitted by the
  constrained piecewise polynomial and refined until it is collision-free with the robot's footprint
  (:func:`planning.trajectory.smoothing.smooth_drive`), timed by the curvature-limited speed profile
  (:func:`planning.trajectory.speed_profile.time_drive`); turns in place get a trapezoidal yaw-rate profile.
  Every drive starts and ends at rest, so the speed is zero at each cusp and the direction flips
  there; a short stand-still (``dwell``) separates the segments.
* **Timed plans** (``optim``, ``sinusoidal``: ``PlanResult.times`` and ``controls``): already smooth
  in space and dynamically consistent, so their paths are not re-fitted (a fit could only lose
  accuracy). A plan whose speed is smooth too, from rest to rest, keeps its samples and time stamps;
  if it exceeds the robot's limits (with ``margin``) time is stretched uniformly (t' = c t,
  v' = v / c, omega' = omega / c) until it does not. A plan that starts or ends moving, or whose
  speed changes faster than the robot can follow (``optim`` holds each input over an interval, so its
  speed steps at every node), keeps its path and is re-timed: split at cusps by the sign of v, each
  drive timed from rest to rest by the speed profile with its own samples as the curve
  (:class:`planning.trajectory.smoothing.SampledCurve`). Either way they are checked for collision.

Both end with a turn in place to the goal heading when the path's last heading differs from it,
and a final stand-still. The result labels every sample with its segment (``Trajectory.segments``)
for :class:`control.segmented.SegmentedTracker`.
"""

from __future__ import annotations

import dataclasses
import inspect
import itertools
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.collision.exact import CollisionChecker
from planning.core.geometry import Pose2D, wrap_angle
from planning.core.robot import RobotSpec, check_robot_spec
from planning.core.world import World, check_world, span
from planning.errors import ConfigError, NhsimError, option
from planning.planners.base import PlanResult, PlanStatus, path_collision
from planning.trajectory.segments import infer_segments
from planning.trajectory.smoothing import (
    MIN_SPEED,
    PathSegment,
    SampledCurve,
    SmoothResult,
    SmoothStatus,
    check_options,
    remove_loops,
    smooth_drive,
    split_path,
)
from planning.trajectory.speed_profile import Limits, TimedSamples, hold, time_drive, time_rotation
from planning.trajectory.trajectory import Trajectory

FloatArray = NDArray[np.float64]


class TrajectoryError(NhsimError):
    """A plan could not be turned into a collision-free trajectory within the limits."""


class PlanFailedError(TrajectoryError):
    """The plan itself failed (its status is not success), or a timed plan itself collides."""


class TrajectoryStatus(StrEnum):
    """How turning a plan into a trajectory ended. Only ``SUCCESS`` is safe to track."""

    SUCCESS = "success"
    COLLISION = "collision"  # no refinement kept the footprint clear (or a timed plan collides)
    DEVIATION = "deviation"  # the fit strayed from the path
    INVALID = "invalid"  # the plan holds no usable path


@dataclass(frozen=True)
class TrajectoryResult:
    """Outcome of :func:`make_trajectory`.

    Attributes:
        status: How it ended (see :class:`TrajectoryStatus`).
        trajectory: The trajectory (also on collision, for inspection), or None.
        reason: What went wrong, and what to try.
        stats: Segments, cusps, rotations, pieces, refinements, clearance, deviation, time scale, ...
    """

    status: TrajectoryStatus
    trajectory: Trajectory | None
    reason: str = ""
    stats: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.status, TrajectoryStatus):
            raise ValueError(f"TrajectoryResult.status must be a TrajectoryStatus, got {self.status!r}")

    @property
    def success(self) -> bool:
        """Whether the trajectory is usable."""
        return self.status is TrajectoryStatus.SUCCESS


def _concat(pieces: list[tuple[str, TimedSamples]], dt: float, name: str) -> Trajectory:
    ts, poses, vels, accs, segs, kinds = [], [], [], [], [], []
    t0 = 0.0
    for k, (kind, smp) in enumerate(pieces):
        ts.append(smp.t + t0)
        poses.append(smp.pose)
        vels.append(smp.vel)
        accs.append(smp.acc)
        segs.append(np.full(smp.t.size, k, dtype=np.int64))
        kinds.append(kind)
        t0 = float(ts[-1][-1]) + dt
    pose = np.vstack(poses)
    pose[:, 2] = np.unwrap(pose[:, 2])
    return Trajectory(
        np.concatenate(ts),
        pose,
        np.vstack(vels),
        np.vstack(accs),
        name=name,
        segments=np.concatenate(segs),
        segment_kinds=tuple(kinds),
    )


def make_trajectory(
    plan: PlanResult | ArrayLike,
    robot: RobotSpec,
    world: World,
    *,
    goal: Pose2D | None = None,
    directions: ArrayLike | None = None,
    margin: float = 0.85,
    dwell: float = 0.3,
    dt: float = 0.01,
    clearance: float | None = None,
    corner_angle: float = 0.5 * np.pi,
    snap_tolerance: float = 0.05,
    max_deviation: float = 0.05,
    name: str | None = None,
    retime: bool | None = None,
    keep_loops: bool = False,
) -> TrajectoryResult:
    """Turn a plan (or a bare path) into a timed, segment-labelled trajectory.

    A path of one pose, or one that never leaves its first pose (what the planners return, as a
    success, for a start that is the goal already: ``nhsim plan`` reports it with a length of 0), is no
    error: it gives a stand-still there of ``dwell`` seconds (at least one sample period), after a turn
    in place to ``goal``'s heading when that differs.

    Args:
        plan: A successful :class:`PlanResult`, or an (N, 3) path of poses [x, y, theta].
        robot: The robot (limits, footprint), a :class:`RobotSpec` (``load_robot(name)``).
        world: The world the path must stay clear in.
        goal: The goal pose: the path is snapped to its position when within ``snap_tolerance`` and
            the trajectory ends with its heading. None: end where and as the path ends.
        directions: (N,) +1/-1 travel direction per pose (else ``plan.directions`` or inferred).
        margin: Share of every robot limit the reference may use (the rest is left to feedback).
        dwell: Stand-still between segments [s].
        dt: Sample period of the trajectory [s].
        clearance: Footprint clearance the smoothed path must keep [m]; default
            min(1 cm, half the input path's own clearance).
        corner_angle: Corners sharper than this become stop-turn-go [rad].
        snap_tolerance: Largest distance from the path's end to ``goal`` that is closed [m].
        max_deviation: Largest distance from the smoothed path to the input path [m].
        name: Trajectory name (default ``"plan:<planner>"`` or ``"path"``).
        retime: A timed plan only: True re-times it from rest to rest, False keeps its samples (slowed
            uniformly to the limits), None decides by the rule above (the module doc).
        keep_loops: A bare path only: drive the stretches that return to a pose already visited (a route
            given to be followed as it is, such as a file's second lap) instead of cutting them (a
            planner's detours).

    Returns:
        The result, with a status; only ``TrajectoryStatus.SUCCESS`` is safe to track (``INVALID``: no
        (N, 3) path of finite poses, the reason says which).

    Raises:
        ConfigError: ``robot`` is not a RobotSpec (a robot's name is not), ``world`` not a World, or an option
            of the wrong kind or out of its range (named, :func:`planning.trajectory.smoothing.check_options`).
    """
    t_start = time.perf_counter()
    given = {"goal": goal, "margin": margin, "dwell": dwell, "dt": dt, "clearance": clearance, "name": name}
    given |= {"corner_angle": corner_angle, "snap_tolerance": snap_tolerance, "max_deviation": max_deviation}
    o = check_options(given | {"retime": retime, "keep_loops": keep_loops})  # named (dt=0 was an OverflowError)
    path, dirs, label, timed = _plan_path(plan, robot, world, directions, name)
    checker = CollisionChecker(world, robot, shape="footprint")
    if reason := _path_problem(path):
        return TrajectoryResult(TrajectoryStatus.INVALID, None, reason)
    path = _snapped_to_goal(plan, path[:, :3].copy(), timed, goal, o["snap_tolerance"])
    path_clear = checker.least_clearance(checker.densify(path))  # clearance_of: centimetres low away from things
    need = o["clearance"] if o["clearance"] is not None else max(0.0, min(0.01, 0.5 * path_clear))
    stats: dict[str, Any] = {"input_points": int(path.shape[0]), "input_min_clearance_m": path_clear}
    stats |= {"required_clearance_m": need, "timed_input": bool(timed)}
    goal_heading = goal.theta if goal is not None else None
    limits = Limits.from_robot(robot, o["margin"])
    build = _Build(limits, checker, need, goal_heading, o["dwell"], o["dt"], label, stats)
    if timed:
        result = _from_timed(plan, path, build, o["retime"])
    else:
        result = _from_path(path, dirs, build, o["corner_angle"], o["max_deviation"], keep_loops=o["keep_loops"])
        result = _blamed_on_the_path(result, path, checker)
    result.stats["smoothing_time_s"] = time.perf_counter() - t_start
    return result


def _snapped_to_goal(
    plan: PlanResult | ArrayLike, path: FloatArray, timed: bool, goal: Pose2D | None, tolerance: float
) -> FloatArray:
    """``path`` (its own copy) with its end moved onto ``goal``'s position when within ``tolerance`` [m]
    (:func:`snapped`; a timed plan's times given), else as it is."""
    if goal is not None and np.hypot(path[-1, 0] - goal.x, path[-1, 1] - goal.y) <= tolerance:
        times = np.asarray(plan.times, dtype=float).reshape(-1) if isinstance(plan, PlanResult) and timed else None
        path[:, :2] = snapped(path[:, :2], (goal.x, goal.y), times)
    return path


def _blamed_on_the_path(result: TrajectoryResult, path: FloatArray, checker: CollisionChecker) -> TrajectoryResult:
    """``result`` of smoothing ``path``, or where it failed and the path collides itself, with the path's collision
    as its reason: the cause is the path given, not its smoothing (whose clearance there is the path's, -inf inside
    an obstacle). A path that leaves the world keeps the reason that says so."""
    if result.success or result.stats["input_min_clearance_m"] > 0.0:
        return result
    world, robot = checker.world, checker.robot
    inside = bool(np.all(world.wall_distance(path[:, :2]) > 0.0))
    if not inside or not (hit := path_collision(path, world, robot, "path")):
        return result
    reason = f"the path given collides before any smoothing: {hit}; plan it again, or move it clear"
    return dataclasses.replace(result, reason=reason)


#: Time over which a timed plan's end is moved onto the goal [s] (:func:`snapped`).
SNAP_BLEND = 1.0


def snapped(xy: FloatArray, goal: tuple[float, float], times: FloatArray | None) -> FloatArray:
    """The positions (N, 2) with the last one moved onto ``goal``: a path's alone (it is smoothed next); a
    timed plan's, whose samples are kept as they are, over its last :data:`SNAP_BLEND` seconds by a
    smoothstep weight, so its reference does not jump in one sample period (the optim planner's end,
    2.3 mm from the goal, slid 3 mm sideways in its last 10 ms at 0.3 m/s)."""
    out = xy.copy()
    offset = np.asarray(goal, dtype=float) - xy[-1]
    if times is None or times.size != xy.shape[0] or times[-1] - times[0] <= 0.0:
        out[-1] = goal
        return out
    u = np.clip((times - (times[-1] - SNAP_BLEND)) / SNAP_BLEND, 0.0, 1.0)
    out += (u * u * (3.0 - 2.0 * u))[:, None] * offset
    out[-1] = goal
    return out


def _plan_path(
    plan: PlanResult | ArrayLike, robot: object, world: object, directions: ArrayLike | None, name: str | None
) -> tuple[FloatArray, ArrayLike | None, str, bool]:
    """A plan's (or a bare path's) path as floats, its directions, the trajectory's label and whether it is
    timed (see :func:`make_trajectory`), once the robot and the world are checked to be what they must.

    Raises:
        ConfigError: ``robot`` is not a RobotSpec, ``world`` not a World, or ``plan`` no numbers.
    """
    check_robot_spec("to_trajectory", robot)
    check_world("to_trajectory: world", world)
    if isinstance(plan, PlanResult):
        path, label = np.asarray(plan.path, dtype=float), name or f"plan:{plan.planner}"
        timed = plan.times is not None and plan.controls is not None
        return path, _directions(directions if directions is not None else plan.directions, len(path)), label, timed
    try:
        path = np.asarray(plan, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(
            f"to_trajectory takes a PlanResult or an (N, 3) path of poses [x, y, theta], got {plan!r:.80}"
        ) from None
    return path, _directions(directions, len(path)), name or "path", False


def _directions(directions: ArrayLike | None, poses: int) -> FloatArray | None:
    """``directions`` checked: one +1 (forwards) or -1 (backwards) a pose, or None (inferred from the path)."""
    if directions is None:
        return None
    try:
        dirs = np.asarray(directions, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        dirs = np.array([np.nan])
    if dirs.size != poses or not np.all(np.abs(dirs) == 1.0):
        raise ConfigError(
            f"to_trajectory: directions must be one +1 (forwards) or -1 (backwards) a pose ({poses}), got "
            f"{directions!r:.80}; or leave them out to infer them from the path"
        )
    return dirs


def _path_problem(path: FloatArray) -> str:
    """Why ``path`` is no path of poses a trajectory can follow: not (N, 3) with N >= 1, or a pose that is not
    finite; "" when it is one."""
    if path.ndim != 2 or path.shape[0] < 1 or path.shape[1] < 3:
        return f"the plan holds no usable (N, 3) path (shape {path.shape}); give one row [x, y, theta] per pose"
    bad = np.flatnonzero(~np.isfinite(path[:, :3]).all(axis=1))
    if bad.size:
        rows = ", ".join(map(str, bad[:5].tolist())) + (", ..." if bad.size > 5 else "")
        return (
            f"the plan's path holds non-finite values (NaN or infinite) in {bad.size} of its {path.shape[0]} poses "
            f"(rows {rows}): every pose [x, y, theta] must be finite"
        )
    return ""


Piece = tuple[str, TimedSamples]


@dataclass(frozen=True)
class _Build:
    """What every step of one :func:`make_trajectory` call shares.

    Attributes:
        limits: The robot's limits with the margin applied.
        checker: Footprint collision checker of the robot in the world.
        need: Footprint clearance the trajectory must keep [m].
        goal_heading: Heading to end with [rad]; None: as the path ends.
        dwell: Stand-still between segments [s].
        dt: Sample period [s].
        label: Trajectory name.
        stats: The result's statistics, filled in as the build goes.
    """

    limits: Limits
    checker: CollisionChecker
    need: float
    goal_heading: float | None
    dwell: float
    dt: float
    label: str
    stats: dict[str, Any]

    def pause(self, pieces: list[Piece]) -> None:
        """Append a stand-still of ``dwell`` at the end of the last piece (if any, and a dwell is asked)."""
        if pieces and self.dwell > 0:
            pieces.append(("hold", hold(pieces[-1][1].pose[-1], self.dwell, dt=self.dt)))


def _from_path(
    path: FloatArray,
    dirs: ArrayLike | None,
    build: _Build,
    corner_angle: float,
    max_deviation: float,
    *,
    keep_loops: bool = False,
) -> TrajectoryResult:
    """An untimed path: loops cut (unless kept), split at cusps, corners and turns, each drive smoothed
    and timed."""
    n_in = path.shape[0]
    if not keep_loops:
        path, dirs = remove_loops(path, dirs)
    build.stats["loop_poses_removed"] = n_in - path.shape[0]
    segs = split_path(path, dirs, goal_heading=build.goal_heading, corner_angle=corner_angle)
    limits, dt = build.limits, build.dt
    pieces: list[Piece] = []
    status, reason = TrajectoryStatus.SUCCESS, ""
    n_pieces, attempts, devs, clears = 0, 0, [0.0], [np.inf]
    for seg in segs:
        build.pause(pieces)
        if seg.kind == "rotate":
            pieces.append(("rotate", time_rotation(seg.points[0], seg.headings[0], seg.headings[1], limits, dt=dt)))
            clears.append(_turn_clearance(build.checker, seg))  # a corner's turn may come closest
            continue
        res = smooth_drive(seg, build.checker, clearance=build.need, max_deviation=max_deviation)
        n_pieces += res.pieces
        attempts = max(attempts, res.attempts)
        devs.append(res.max_deviation)
        clears.append(res.min_clearance)
        if not res.success and status is TrajectoryStatus.SUCCESS:
            status, reason = TrajectoryStatus(res.status.value), _smoothing_failure(seg, res, build, max_deviation)
        pieces.append(("forward" if seg.direction > 0 else "reverse", time_drive(res.curve, limits, dt=dt)))
    if not pieces:  # already at the goal
        pieces.append(("hold", hold(path[-1], max(build.dwell, dt), dt=dt)))
    else:
        build.pause(pieces)
    traj = _concat(pieces, dt, build.label)
    kinds = [s.kind for s in segs]
    dirs_k = [s.direction for s in segs if s.kind == "drive"]
    build.stats.update(
        {
            "segments": len(segs),
            "drives": kinds.count("drive"),
            "rotations": kinds.count("rotate"),
            "cusps": int(sum(a != b for a, b in itertools.pairwise(dirs_k))),
            "pieces": n_pieces,
            "refinements": attempts,
            "max_deviation_m": float(max(devs)),
            "min_clearance_m": float(min(clears)),
            "duration_s": traj.duration,
            "length_m": traj.path_length(),
        }
    )
    return TrajectoryResult(status, traj, reason, build.stats)


def _turn_clearance(checker: CollisionChecker, seg: PathSegment) -> float:
    """The footprint's least clearance [m] over a turn in place (a "rotate" segment), measured."""
    (x, y), (h0, h1) = seg.points[0][:2], seg.headings
    return checker.least_clearance(checker.densify(np.array([[x, y, h0], [x, y, h1]])))


def _smoothing_failure(seg: PathSegment, res: SmoothResult, build: _Build, max_deviation: float) -> str:
    at = seg.points[0]
    world = build.checker.world
    out = np.flatnonzero(world.wall_distance(seg.points[:, :2]) <= 0.0)
    if out.size:  # no smoothing makes a path that leaves the world a drive inside it
        x, y = seg.points[out[0], :2]
        return (
            f"the drive from ({at[0]:.2f}, {at[1]:.2f}) leaves the world's bounds ({span(*world.bounds)}) "
            f"at ({x:.2f}, {y:.2f}): every pose of a path must lie inside the world"
        )
    if res.status is SmoothStatus.DEVIATION and res.max_deviation <= max_deviation:
        return (
            f"the drive from ({at[0]:.2f}, {at[1]:.2f}) could not be smoothed: after {res.attempts} refinements "
            f"the fitted curve still folds back on itself (its speed along the path falls to "
            f"{res.min_speed:.2f} of the path's, at most {MIN_SPEED:g}): the path turns too sharply there to be "
            "rounded off; give it a corner the robot can stop and turn at, or headings that follow its motion"
        )
    return (
        f"the drive from ({at[0]:.2f}, {at[1]:.2f}) could not be smoothed: {res.status.value} after "
        f"{res.attempts} refinements (clearance {res.min_clearance:.4f} m, needed > {build.need:.4f} m; "
        f"deviation {res.max_deviation:.4f} m, allowed {max_deviation:.4f} m); plan with more clearance "
        f"or allow a larger deviation"
    )


def _runs(kinds: list[str]) -> list[tuple[str, int, int]]:
    """Maximal runs of equal kinds as (kind, first index, last index + 1)."""
    out, start = [], 0
    for kind, group in itertools.groupby(kinds):
        stop = start + len(list(group))
        out.append((kind, start, stop))
        start = stop
    return out


#: A turn in place reverses where its heading comes back by more than this from its extreme [rad].
TURN_REVERSAL = 1e-3


def turn_legs(theta: FloatArray, tol: float = TURN_REVERSAL) -> list[int]:
    """Where a turn in place reverses: indices into ``theta`` (M,) [rad] of its first sample, of every
    extreme the heading comes back from by more than ``tol``, and of its last sample."""
    legs, ext, sign = [0], 0, 0.0
    for i in range(1, theta.size):
        step = theta[i] - theta[ext]
        if sign == 0.0 and abs(step) > tol:
            sign = float(np.sign(step))
        if sign * step > 0.0:
            ext = i
        elif sign != 0.0 and -sign * step > tol:  # came back from the extreme: a leg ends there
            legs.append(ext)
            ext, sign = i, -sign
    if legs[-1] != theta.size - 1:
        legs.append(theta.size - 1)
    return legs


def _retimed_pieces(path: FloatArray, kinds: list[str], build: _Build) -> list[Piece]:
    """A timed plan's path, re-timed: each drive of one direction from rest to rest by the speed profile
    (its own samples as the curve), each turn in place by the yaw-rate profile (one per leg where it
    turns back), stand-stills between."""
    pieces: list[Piece] = []
    for kind, start, stop in _runs(kinds):
        sl = slice(start, min(stop + 1, len(kinds)))  # through the next piece's first pose
        if kind == "rotate":
            th = path[sl][:, 2]
            legs = [(th[a], th[b]) for a, b in itertools.pairwise(turn_legs(th))]
            timed = [time_rotation(path[start, :2], a, b, build.limits, dt=build.dt) for a, b in legs if a != b]
        else:
            try:
                curve = SampledCurve.from_poses(path[sl], 1 if kind == "forward" else -1)
            except ValueError:  # stands still: nothing to drive
                continue
            timed = [time_drive(curve, build.limits, dt=build.dt)]
        for smp in timed:  # a turn by nothing (a last sample labelled "rotate" alone) times no piece
            build.pause(pieces)
            pieces.append((kind, smp))
    return pieces


def _kept_samples(
    t: FloatArray, path: FloatArray, vel: FloatArray, acc: FloatArray, kinds: list[str], label: str
) -> Trajectory:
    """A timed plan's own samples (t (N,), path (N, 3), vel and acc (N, 2)), one segment per run of kinds."""
    runs = _runs(kinds)
    seg = np.concatenate([np.full(stop - start, k, dtype=np.int64) for k, (_, start, stop) in enumerate(runs)])
    return Trajectory(t, path, vel, acc, name=label, segments=seg, segment_kinds=tuple(kind for kind, _, _ in runs))


def time_scales(v: FloatArray, w: FloatArray, dv: FloatArray, dw: FloatArray, limits: Limits) -> tuple[float, float]:
    """How much slower a timed plan must run to respect the speed limits, and the acceleration limits.

    Args:
        v: (N,) speed [m/s].
        w: (N,) yaw rate [rad/s].
        dv: (N,) dv/dt [m/s^2].
        dw: (N,) domega/dt [rad/s^2].
        limits: The limits.

    Returns:
        ``(speed_scale, accel_scale)``: the clock stretch (>= 1) that brings speed, yaw rate and wheel
        speed within their limits, and the one (any size) that brings both accelerations within theirs.
    """
    wheel = np.abs(v) + 0.5 * limits.track_width * np.abs(w)
    speed_scale = max(
        1.0,
        float(np.max(np.abs(v))) / limits.max_speed,
        float(np.max(np.abs(w))) / limits.max_yaw_rate,
        float(np.max(wheel)) / limits.max_wheel_linear,
    )
    accel_scale = max(
        float(np.sqrt(np.max(np.abs(dv)) / limits.max_accel)), float(np.sqrt(np.max(np.abs(dw)) / limits.max_yaw_accel))
    )
    return speed_scale, accel_scale


#: How far a trajectory's poses may stray from where its velocities take them before :func:`infeasibility` says so:
#: in one sample [m], and over the whole trajectory [m] plus a share of its length.
POSE_STRAY_STEP, POSE_STRAY_TOTAL, POSE_STRAY_SHARE = 0.01, 0.05, 0.05


def infeasibility(trajectory: Trajectory, robot: RobotSpec) -> str:
    """What in ``trajectory`` the robot cannot follow, as a sentence ("" for nothing): inputs beyond its limits
    (speed, yaw rate, wheel speed: the commands saturate; :func:`time_scales` at the robot's own limits), or
    poses its velocities do not lead to (a jump, or headings that contradict the motion: the tracker follows
    the velocities while the errors are measured against the poses). Trajectories nhsim times (plans,
    references, imported files) have neither; a hand-built one may."""
    said = []
    v, w = trajectory.vel[:, 0], trajectory.vel[:, 1]
    dv, dw = trajectory.acc[:, 0], trajectory.acc[:, 1]
    limits = Limits.from_robot(robot, margin=1.0)
    speed, accel = time_scales(v, w, dv, dw, limits)
    if speed > 1.0 + 1e-6:
        k = fastest_sample(v, w, limits)
        said.append(
            f"its inputs are beyond the {robot.name}'s limits (at t={trajectory.t[k]:.2f} s v={v[k]:.3f} m/s, "
            f"omega={w[k]:.3f} rad/s; the limits {robot.max_speed:g} m/s and {robot.max_yaw_rate:g} rad/s): the "
            f"wheels saturate; slow it by x{speed:.2f} at least"
        )
    elif accel > 1.0 + 1e-6:
        said.append(f"its accelerations are beyond the {robot.name}'s limits: slow it by x{accel:.2f} at least")
    dt, mid = np.diff(trajectory.t), trajectory.pose[:-1, 2] + 0.5 * np.diff(trajectory.pose[:, 2])
    step = 0.5 * (v[:-1] + v[1:]) * dt
    moved = np.diff(trajectory.pose[:, :2], axis=0)
    stray = np.hypot(moved[:, 0] - step * np.cos(mid), moved[:, 1] - step * np.sin(mid))
    length = float(np.sum(np.hypot(moved[:, 0], moved[:, 1])))
    if stray.max() > POSE_STRAY_STEP or stray.sum() > POSE_STRAY_TOTAL + POSE_STRAY_SHARE * length:
        k = int(np.argmax(stray))
        said.append(
            f"its poses do not follow its velocities (at t={trajectory.t[k]:.2f} s the pose moves "
            f"{float(np.hypot(*moved[k])):.3f} m where v and theta take it {abs(float(step[k])):.3f} m; "
            f"{float(stray.sum()):.3f} m apart in all): a jump, or headings or speeds that contradict the motion, "
            "which the tracker follows by the velocities while the errors are measured against the poses"
        )
    return "; ".join(said)


def fastest_sample(v: FloatArray, w: FloatArray, limits: Limits) -> int:
    """Index of the sample whose speed and yaw rate (v, w (N,)) ask most of ``limits`` together: where a
    trajectory too fast for them is said to be so."""
    return int(np.argmax(np.abs(v) / limits.max_speed + np.abs(w) / limits.max_yaw_rate))


def _end_at_goal(body: Trajectory, end: FloatArray, build: _Build) -> Trajectory:
    """``body`` followed by a turn in place at the plan's ``end`` pose (3,) to the goal heading (when it
    differs) and a final stand-still."""
    end_pose = end.copy()
    tail: list[Piece] = []
    if build.goal_heading is not None and abs(wrap_angle(build.goal_heading - end_pose[2])) > 1e-3:
        if build.dwell > 0:
            tail.append(("hold", hold(end_pose, build.dwell, dt=build.dt)))
        th1 = end_pose[2] + wrap_angle(build.goal_heading - end_pose[2])
        tail.append(("rotate", time_rotation(end_pose[:2], end_pose[2], th1, build.limits, dt=build.dt)))
        end_pose[2] = th1
    if build.dwell > 0:
        tail.append(("hold", hold(end_pose, build.dwell, dt=build.dt)))
    if not tail:
        return body
    rest = _concat(tail, build.dt, build.label)
    assert body.segments is not None and rest.segments is not None
    return Trajectory(
        np.concatenate([body.t, rest.t + (body.t[-1] + build.dt)]),
        np.vstack([body.pose, rest.pose]),
        np.vstack([body.vel, rest.vel]),
        np.vstack([body.acc, rest.acc]),
        name=build.label,
        segments=np.concatenate([body.segments, rest.segments + len(body.segment_kinds)]),
        segment_kinds=body.segment_kinds + rest.segment_kinds,
    )


#: The least step between a timed plan's stamps [s] (:func:`_from_timed`): finer ones are not told apart from the
#: same instant, and a trajectory needs a derivative between them.
MIN_TIME_STEP = 1e-9


def _from_timed(plan: PlanResult | ArrayLike, path: FloatArray, build: _Build, force: bool | None) -> TrajectoryResult:
    """A timed plan: its path kept, its samples kept (slowed uniformly) or re-timed from rest to rest."""
    assert isinstance(plan, PlanResult) and plan.times is not None and plan.controls is not None
    t = np.asarray(plan.times, dtype=float).reshape(-1)
    if t.size < 2:
        return TrajectoryResult(TrajectoryStatus.INVALID, None, f"timed plan has {t.size} times for {t.size} poses")
    close = np.flatnonzero(np.diff(t - t[0]) <= MIN_TIME_STEP)
    if close.size:  # (rows dropped here once ended the trajectory short of the plan's end)
        k = int(close[0]) + 1
        return TrajectoryResult(
            TrajectoryStatus.INVALID,
            None,
            f"timed plan's times[{k}] = {float(t[k])!r} is not {MIN_TIME_STEP:g} s after "
            f"times[{k - 1}] = {float(t[k - 1])!r}: give each pose its own time stamp",
        )
    t, u = t - t[0], np.asarray(plan.controls, dtype=float)
    v, w = u[:, 0], u[:, 1]
    dv, dw = np.gradient(v, t), np.gradient(w, t)
    speed_scale, accel_scale = time_scales(v, w, dv, dw, build.limits)
    clear = float(build.stats["input_min_clearance_m"])  # the path kept as it is: its measured clearance
    kinds = list(infer_segments(v, w).labels)
    # A plan that starts or ends moving, or whose speed changes faster than the robot can follow
    # (inputs held over intervals step at every node), keeps its path but is re-timed from rest to rest
    # by the speed profile; a smooth one keeps its samples, slowed uniformly if it exceeds a limit.
    rule = max(abs(float(v[0])), abs(float(v[-1]))) > 1e-3 or accel_scale > speed_scale
    retime = rule if force is None else force
    pieces = _retimed_pieces(path, kinds, build) if retime else []
    scale: float | None = None
    if pieces:
        body = _concat(pieces, build.dt, build.label)
    else:  # keep the planner's own samples and time stamps, slowed uniformly by ``scale``
        retime, scale = False, max(speed_scale, accel_scale)
        t, v, w, dv, dw = t * scale, v / scale, w / scale, dv / scale**2, dw / scale**2
        body = _kept_samples(t, path, np.column_stack([v, w]), np.column_stack([dv, dw]), kinds, build.label)
    body = _end_at_goal(body, path[-1], build)
    status = TrajectoryStatus.SUCCESS if clear > 0.0 else TrajectoryStatus.COLLISION
    reason = "" if clear > 0.0 else f"the timed plan comes within {clear:.4f} m of an obstacle or wall"
    signs = np.sign(v[np.abs(v) > 1e-4])
    build.stats.update(
        {
            "segments": len(body.segment_kinds),
            "time_scale": scale,
            "retimed": retime,
            "min_clearance_m": clear,
            "cusps": int(np.sum(signs[1:] != signs[:-1])),
            "duration_s": body.duration,
            "length_m": body.path_length(),
            "rotations": int(sum(k == "rotate" for k in body.segment_kinds)),
            "pieces": 0,
            "refinements": 0,
            "max_deviation_m": 0.0,
        }
    )
    return TrajectoryResult(status, body, reason, build.stats)


#: What to try after a failed plan, by its status.
_FAILED_PLAN_FIX = {
    PlanStatus.TIMEOUT: (
        f"try another seed, more of the budget the reason says ran out (a longer {option('time-limit')}, or a larger "
        "max_iterations), or another planner"
    ),
    PlanStatus.INVALID_START: "move the start into free space, or lower the clearance",
    PlanStatus.INVALID_GOAL: "move the goal into free space, or lower the clearance",
    PlanStatus.INFEASIBLE: "widen the way to the goal, lower the clearance, or try another planner",
}


def check_option_names(where: str, options: Mapping[str, Any]) -> None:
    """Raise :class:`ConfigError` naming the options :func:`make_trajectory` does not take, and those it does."""
    valid = [p.name for p in inspect.signature(make_trajectory).parameters.values() if p.kind is p.KEYWORD_ONLY]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ConfigError(
            f"{where}: unknown option(s) {', '.join(unknown)}; valid options: {', '.join(valid)} (see make_trajectory)"
        )


def checked_trajectory(
    plan: PlanResult | ArrayLike, robot: RobotSpec, world: World, **options: Any
) -> TrajectoryResult:
    """:func:`make_trajectory`, raising when there is no usable trajectory.

    Raises:
        ConfigError: An option :func:`make_trajectory` does not take (the message lists those it does), a
            robot that is not a RobotSpec or a world that is not a World.
        TrajectoryError: The plan failed, or no collision-free trajectory was found.
    """
    check_option_names("to_trajectory", options)
    if isinstance(plan, PlanResult) and not plan.success:
        raise PlanFailedError(
            f"planner {plan.planner!r} ended with status {plan.status.value}: {plan.reason or 'no reason given'}; "
            f"a failed plan has no trajectory ({_FAILED_PLAN_FIX.get(plan.status, 'try another planner')})"
        )
    res = make_trajectory(plan, robot, world, **options)
    if not res.success or res.trajectory is None:
        if res.stats.get("timed_input"):  # a timed plan is not re-fitted: its own collision is the planner's
            raise PlanFailedError(res.reason)
        raise TrajectoryError(res.reason)
    return res


def to_trajectory(plan: PlanResult | ArrayLike, robot: RobotSpec, world: World, **options: Any) -> Trajectory:
    """The trajectory of a plan (the one entry point every planner's output goes through).

    Args:
        plan: A successful plan or an (N, 3) path (one pose, or a start that is the goal: a stand-still,
            see :func:`make_trajectory`).
        robot: The robot (``load_robot(name)``).
        world: The world.
        **options: As :func:`make_trajectory`.

    Raises:
        ConfigError: An option make_trajectory does not take, a robot that is no RobotSpec or a world
            that is no World.
        TrajectoryError: The plan failed, or no collision-free trajectory was found (a path that is not
            (N, 3) or holds a NaN too).
    """
    traj = checked_trajectory(plan, robot, world, **options).trajectory
    assert traj is not None
    return traj
