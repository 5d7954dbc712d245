"""Piecewise constrained polynomial smoothing of a planned path (the EduMIP planning report, section II-B).

A planner's path is a sequence of poses. It is first split into *segments* (:func:`split_path`):
drives (forwards or backwards) separated by cusps, where the direction of travel flips, and
rotations, where a differential drive turns in place. Each drive is then fitted by a piecewise
polynomial curve ``p(u) = (x(u), y(u))`` (:func:`fit_piecewise`), with ``u`` the cumulative chord
length of the path points (a close approximation of arc length), so vertical segments, loops and
backtracking are represented as easily as anything else; the curve is resampled by its true arc
length later (:class:`SmoothCurve`).

The fit follows the EduMIP planning report: the curve passes through fix points (the drive's two
ends) and satisfies derivative constraints (the end tangents, zero end curvature, and position,
tangent and curvature continuity between neighbouring pieces: C0, C1 and C2), and fits all path
points by least squares. The report solves this in two steps, ``p = p^c + p^s``: ``p^c`` satisfies
the constraints ``A p = b``, and ``p^s`` then fits the residual of the points. Taken literally, an
unconstrained ``p^s`` breaks the constraints again (it is fitted to the points alone). The two steps
are right when ``p^s`` is restricted to the null space of ``A``; that is exactly the
equality-constrained least-squares problem ``min |B p - y|^2 subject to A p = b``, solved here in
one sparse solve of its KKT system ``[[B^T B, A^T], [A, 0]] [p; mu] = [B^T y; b]`` (linear in the
number of pieces, where a dense null space would be cubic). Every constraint holds to rounding, and
all pieces of all coordinates are fitted together, so continuity is exact rather than imposed piece
by piece. A small penalty on the third derivative keeps pieces with few points well posed and free
of wiggles.

The smoothed drive is checked against the world with the robot's footprint
(:class:`planning.collision.exact.CollisionChecker`) and against its distance from the input path; when
either check fails the fit is refined (shorter pieces, lighter penalty) until it passes, or the
segment is reported as failed (:class:`SmoothStatus`).
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Any, Literal

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.collision.exact import CollisionChecker
from planning.core.arrays import kernel_input
from planning.core.checks import check_flag, check_number
from planning.core.geometry import check_pose, cumulative_length, path_steps, wrap_angle
from planning.errors import ConfigError

if TYPE_CHECKING:  # scipy.sparse is loaded where a fit is solved, not by every planner that imports this
    import scipy.sparse

FloatArray = NDArray[np.float64]
SegmentKind = Literal["drive", "rotate"]


class SmoothStatus(StrEnum):
    """How smoothing a drive ended."""

    SUCCESS = "success"
    COLLISION = "collision"  # every refinement still touched an obstacle or wall
    DEVIATION = "deviation"  # every refinement strayed too far from the path


# ---------------------------------------------------------------------------------------- options
#: Longest sample period [s] of a trajectory made from a plan (``dt``). A tracker follows the reference
#: linearly between its samples, along chords of the smoothed curve, which is what is checked against the
#: world: at 0.1 s and the robots' top speeds on their tightest turns a chord strays less than half a
#: millimetre from the curve, at 1 s some 3 cm (more than the default 1 cm clearance). It is nhsim's slowest
#: control period too (10 Hz; the default 0.01 s is finer than its 50 Hz).
MAX_SAMPLE_PERIOD = 0.1
#: Shortest sample period [s]: a tenth of the finest physics step (1 ms); finer samples only cost memory.
MIN_SAMPLE_PERIOD = 1e-4
#: Longest stand-still between segments (``dwell``) [s].
MAX_DWELL = 60.0

#: Each number option of :func:`planning.trajectory.from_plan.make_trajectory` (``to_trajectory``'s and
#: ``PlanOptions.smoothing``'s) -> the keyword arguments of :func:`planning.core.checks.check_number`.
OPTION_LIMITS: dict[str, dict[str, Any]] = {
    "margin": {
        "above": 0.0,
        "at_most": 1.0,
        "unit": "a fraction of the robot's limits",
        "fix": "the share of each limit the reference may use, e.g. 0.85 (the default)",
    },
    "dwell": {"at_least": 0.0, "at_most": MAX_DWELL, "unit": "s", "fix": "the stand-still between segments, e.g. 0.3"},
    "dt": {
        "at_least": MIN_SAMPLE_PERIOD,
        "at_most": MAX_SAMPLE_PERIOD,
        "unit": "s",
        "fix": "the trajectory's sample period, e.g. 0.01 (the default): a tracker follows straight chords between "
        "samples, which leave the smoothed, collision-checked curve when they are far apart",
    },
    "clearance": {
        "at_least": 0.0,
        "unit": "m",
        "fix": "the footprint clearance kept, e.g. 0.01, or None for the default",
    },
    "corner_angle": {"at_least": 0.0, "at_most": math.pi, "unit": "rad", "fix": "for degrees use math.radians(90)"},
    "snap_tolerance": {"at_least": 0.0, "unit": "m", "fix": "e.g. 0.05 (the default)"},
    "max_deviation": {"above": 0.0, "unit": "m", "fix": "the distance allowed from the planned path, e.g. 0.05"},
}


def check_option(name: str, value: object) -> float:
    """A number option of :func:`planning.trajectory.from_plan.make_trajectory` (a key of
    :data:`OPTION_LIMITS`) as a float, when it is a finite number in its range.

    Raises:
        ConfigError: Naming the option (``to_trajectory: dt must be ...``), its range and what was given.
    """
    return check_number(f"to_trajectory: {name}", value, **OPTION_LIMITS[name])


def check_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """The options of :func:`planning.trajectory.from_plan.make_trajectory` (``to_trajectory(**options)``,
    ``PlanOptions.smoothing``), each checked on entry: the numbers (:data:`OPTION_LIMITS`; ``clearance`` may
    be None) as floats, the flags (``keep_loops``; ``retime`` True, False or None), ``goal`` a Pose2D or None
    and ``name`` text or None. Keys it does not know are left to the caller (which lists the valid ones).

    Raises:
        ConfigError: An option of the wrong kind or out of its range, named.
    """
    out = dict(options)
    for key, value in options.items():
        if key in OPTION_LIMITS and not (key == "clearance" and value is None):
            out[key] = check_option(key, value)
        elif key == "keep_loops":
            out[key] = check_flag(f"to_trajectory: {key}", value)
        elif key == "retime" and value is not None:
            if not isinstance(value, bool | np.bool_):
                raise ConfigError(f"to_trajectory: retime must be True, False or None (by the plan), got {value!r:.80}")
            out[key] = bool(value)
        elif key == "goal":
            check_pose("to_trajectory: goal", value, optional=True)
        elif key == "name" and value is not None and not isinstance(value, str):
            raise ConfigError(f"to_trajectory: name must be text or None, got {value!r:.80}")
    return out


# ---------------------------------------------------------------------------------------- segments
@dataclass(frozen=True)
class PathSegment:
    """One piece of a path between cusps or turns in place.

    Attributes:
        kind: "drive" (the base moves along ``points``) or "rotate" (turn in place).
        direction: +1 forwards, -1 backwards (drives); sign of the turn (rotations).
        points: (K, 2) positions along a drive, or (1, 2) the spot of a rotation [m].
        headings: (2,) heading at the start and end [rad] (unwrapped: the end minus the start is the
            signed turn of a rotation).
    """

    kind: SegmentKind
    direction: int
    points: FloatArray
    headings: FloatArray


def _heading_consistent(d: FloatArray, th: FloatArray, moving: NDArray[np.bool_]) -> bool:
    """Whether the path's headings follow its motion (forwards or backwards) rather than being arbitrary."""
    if not np.any(moving):
        return True
    u = d[moving] / np.linalg.norm(d[moving], axis=1, keepdims=True)
    align = np.abs(u[:, 0] * np.cos(th[moving]) + u[:, 1] * np.sin(th[moving]))
    return bool(np.median(align) > 0.9)


def split_path(
    path: ArrayLike,
    directions: ArrayLike | None = None,
    *,
    start_heading: float | None = None,
    goal_heading: float | None = None,
    corner_angle: float = 0.5 * np.pi,
    min_step: float = 1e-4,
    heading_eps: float = 1e-3,
) -> list[PathSegment]:
    """Split a path into drives and turns in place.

    A drive ends at a cusp (the sign of travel flips), at a corner sharper than ``corner_angle``
    (a differential drive stops and turns there rather than swinging wide), and where the base stops
    moving. Rotations are inserted wherever the heading at the end of one drive differs from the
    heading at the start of the next, at the start (from ``start_heading``) and at the end (to
    ``goal_heading``).

    The sign of travel comes from ``directions`` when given; else from the headings when they follow
    the motion (a kinematic planner's path); else (a geometric path whose headings are arbitrary)
    every step is driven forwards.

    Args:
        path: (N, 3) poses [x, y, theta] along the motion.
        directions: (N,) +1/-1 per pose: the direction of the motion *arriving* at each pose (the
            step from pose i to i+1 uses directions[i + 1]; directions[0] is ignored), as
            :class:`planning.planners.base.PlanResult` and the curve samplers give them. Optional.
        start_heading: Heading the robot starts with [rad]; default the path's first heading.
        goal_heading: Heading it must end with [rad]; default the last drive's heading (geometric
            paths) or the path's last heading.
        corner_angle: Turns of the travel direction sharper than this between two steps split the
            drive [rad].
        min_step: Steps shorter than this count as standing still [m].
        heading_eps: Heading differences below this need no rotation [rad].

    Returns:
        The segments in order.

    Raises:
        ValueError: Bad shapes or a path with fewer than 1 pose.
    """
    steps = _Steps.of(path, min_step)
    th = steps.th
    drives = steps.drives(steps.signs(directions), corner_angle)
    out = _Segments(float(th[0]) if start_heading is None else float(start_heading), heading_eps)
    last_pose = 0
    for a, b, sgn_k in drives:
        out.add_drive(steps, a, b, sgn_k, last_pose)
        last_pose = b
    if goal_heading is None:
        goal = float(th[-1]) if (steps.consistent or not drives) else out.heading
    else:
        goal = float(goal_heading)
    end_xy = steps.xy[-1] if not drives else out.segs[-1].points[-1]
    hint = float(th[-1] - th[last_pose]) if (steps.consistent and last_pose < th.size - 1) else None
    if hint is not None and abs(wrap_angle(goal - out.heading - hint)) > 1e-6:
        hint = None
    out.rotate_to(goal, end_xy, hint)
    return out.segs


@dataclass(frozen=True)
class _Steps:
    """The steps of a path: positions, unwrapped headings, step vectors and lengths, which steps move.

    Attributes:
        xy: (N, 2) positions [m].
        th: (N,) unwrapped headings [rad].
        d: (N - 1, 2) steps [m].
        step: (N - 1,) their lengths [m].
        moving: (N - 1,) whether each step is longer than the stand-still threshold.
        min_step: That threshold [m].
        consistent: Whether the headings follow the motion (see :func:`_heading_consistent`).
    """

    xy: FloatArray
    th: FloatArray
    d: FloatArray
    step: FloatArray
    moving: NDArray[np.bool_]
    min_step: float
    consistent: bool

    @classmethod
    def of(cls, path: ArrayLike, min_step: float) -> _Steps:
        """The steps of (N, 3) poses; ValueError for a bad shape or non-finite values."""
        p = np.asarray(path, dtype=float)
        if p.ndim != 2 or p.shape[1] < 3 or p.shape[0] < 1:
            raise ValueError(f"path must be an (N, 3) array of poses with N >= 1, got shape {p.shape}")
        if not np.all(np.isfinite(p[:, :3])):
            raise ValueError("path contains non-finite values")
        xy, th = p[:, :2], np.unwrap(p[:, 2])
        d = np.diff(xy, axis=0)
        step = np.hypot(d[:, 0], d[:, 1])
        moving = step > min_step
        return cls(xy, th, d, step, moving, min_step, _heading_consistent(d, th[:-1], moving))

    def signs(self, directions: ArrayLike | None) -> FloatArray:
        """(N - 1,) +1/-1 sign of travel of each step (see :func:`split_path`)."""
        if directions is not None:
            dirs = np.sign(np.asarray(directions, dtype=float).reshape(-1))
            if dirs.size != self.th.size:
                raise ValueError(f"directions must have one entry per pose ({self.th.size}), got {dirs.size}")
            return np.where(dirs[1:] == 0, 1.0, dirs[1:])
        if self.consistent:
            hd = 0.5 * (self.th[:-1] + self.th[1:])
            dot = self.d[:, 0] * np.cos(hd) + self.d[:, 1] * np.sin(hd)
            return np.where(dot < 0, -1.0, 1.0)
        return np.ones(self.d.shape[0])

    def drives(self, sgn: FloatArray, corner_angle: float) -> list[tuple[int, int, int]]:
        """Moving steps grouped into drives: (first pose, last pose, direction) each.

        A stop inside a drive (a planner's turn in place at a polyline vertex) is smoothed over
        unless the corner, or the turn made while stopped, is sharper than ``corner_angle``.
        """
        d, step, th = self.d, self.step, self.th
        drives: list[tuple[int, int, int]] = []
        cur: list[int] | None = None  # [first step, direction, last moving step]
        for i in np.flatnonzero(self.moving).tolist():
            if cur is not None:
                prev = cur[2]
                cosang = float(d[prev] @ d[i]) / (step[prev] * step[i])
                turned = abs(float(th[i] - th[prev + 1])) if self.consistent else 0.0
                if sgn[i] != cur[1] or cosang < np.cos(corner_angle) or turned > corner_angle:
                    drives.append((cur[0], prev + 1, cur[1]))
                    cur = None
            if cur is None:
                cur = [i, int(sgn[i]), i]
            else:
                cur[2] = i
        if cur is not None:
            drives.append((cur[0], cur[2] + 1, cur[1]))
        return drives


class _Segments:
    """The segments of a path as they are found, and the heading the robot has at the end of them."""

    def __init__(self, heading: float, heading_eps: float) -> None:
        self.heading = heading
        self.heading_eps = heading_eps
        self.segs: list[PathSegment] = []

    def rotate_to(self, target: float, at: FloatArray, hint: float | None = None) -> None:
        """Turn in place at ``at`` to ``target`` (by ``hint``, the signed turn, when given) [rad]."""
        turn = wrap_angle(target - self.heading) if hint is None else hint
        if abs(turn) > self.heading_eps:
            rot = PathSegment(
                "rotate", 1 if turn > 0 else -1, at.reshape(1, 2), np.array([self.heading, self.heading + turn])
            )
            self.segs.append(rot)
        self.heading = self.heading + turn

    def add_drive(self, steps: _Steps, a: int, b: int, sgn_k: int, last_pose: int) -> None:
        """The drive over poses a..b in direction ``sgn_k``, after a turn in place to its start heading."""
        th, pts, dd = steps.th, steps.xy[a : b + 1], steps.d[a:b]
        if steps.consistent:
            h0 = float(th[a])
            # a stationary stretch before this drive with its own heading change is a turn in place
            hint = float(th[a] - th[last_pose]) if a > last_pose else None
            ok = hint is not None and abs(wrap_angle(h0 - self.heading - hint)) < 1e-6
            self.rotate_to(h0, pts[0], hint if ok else None)
        else:
            self.rotate_to(float(np.arctan2(sgn_k * dd[0][1], sgn_k * dd[0][0])), pts[0])
        h0 = self.heading
        if steps.consistent:
            h1 = h0 + float(th[b] - th[a])
        else:  # total turning of the travel direction, so loops keep their full winding
            ang = np.arctan2(sgn_k * dd[:, 1], sgn_k * dd[:, 0])
            h1 = h0 + float(np.sum(wrap_angle(np.diff(ang[steps.step[a:b] > steps.min_step]))))
        self.segs.append(PathSegment("drive", int(sgn_k), pts.copy(), np.array([h0, h1])))
        self.heading = h1


@nb.njit(cache=True)
def _pose_key(p: FloatArray, i: int, tolerance: float) -> tuple[int, int, int]:
    """Pose i's x, y and wrapped theta (:func:`planning.core.geometry.wrap_angle`, with numpy's
    floating-point modulo written out) rounded to the ``tolerance`` grid, as integers."""
    two_pi = 2.0 * np.pi
    m = np.fmod(p[i, 2] + np.pi, two_pi)
    if m != 0.0 and m < 0.0:
        m += two_pi
    elif m == 0.0:
        m = 0.0
    th = m - np.pi
    return int(np.rint(p[i, 0] / tolerance)), int(np.rint(p[i, 1] / tolerance)), int(np.rint(th / tolerance))


@nb.njit(cache=True)
def _loop_cut(p: FloatArray, tolerance: float) -> NDArray[np.int64]:
    """Indices of the poses :func:`remove_loops` keeps: equal poses (same key) are grouped by an
    open-addressing hash table, each group remembers its last index, and the walk from each kept
    pose jumps to just after its group's last one (linear in the poses)."""
    n = p.shape[0]
    size = 16
    while size < 2 * n:
        size *= 2
    table = np.full(size, -1, dtype=np.int64)  # group of each slot
    keys = np.empty((n, 3), dtype=np.int64)  # each group's key, by group
    last = np.empty(n, dtype=np.int64)  # each group's last index, by group
    group = np.empty(n, dtype=np.int64)
    groups = 0
    for i in range(n):
        k0, k1, k2 = _pose_key(p, i, tolerance)
        h = (k0 * 73856093) ^ (k1 * 19349663) ^ (k2 * 83492791)
        slot = h & (size - 1)
        while True:
            g = table[slot]
            if g < 0:
                g = groups
                groups += 1
                table[slot] = g
                keys[g, 0], keys[g, 1], keys[g, 2] = k0, k1, k2
                break
            if keys[g, 0] == k0 and keys[g, 1] == k1 and keys[g, 2] == k2:
                break
            slot = (slot + 1) & (size - 1)
        group[i] = g
        last[g] = i
    keep = np.empty(n, dtype=np.int64)
    kept, i = 0, 0
    while i < n:
        keep[kept] = i
        kept += 1
        i = last[group[i]] + 1
    return keep[:kept]


def remove_loops(
    path: ArrayLike,
    directions: ArrayLike | None = None,
    *,
    tolerance: float = 1e-6,
) -> tuple[FloatArray, FloatArray | None]:
    """Cut every stretch of a path that returns to a pose it already had (a loop in x, y, theta).

    A motion-primitive tree can drive a primitive and then its exact reverse, or wander back to a
    pose it passed before; the stretch between the two visits achieves nothing. Keeping the poses
    before the first visit and after the last one leaves a path made only of the input's own
    poses and steps (each kept step joins the same two poses as an input step, up to
    ``tolerance``), so it is exactly as feasible and collision-free as the input, and only shorter.
    Visits are matched greedily: from each kept pose the walk jumps to just after the *last*
    revisit of that pose. Compiled, linear in the poses (a hash of the rounded poses): ~1 ms for
    a 95 000-pose tree path.

    Args:
        path: (N, 3) poses [x, y, theta].
        directions: (N,) directions of the motion arriving at each pose (optional); cut alongside.
        tolerance: Poses whose x, y [m] and wrapped theta [rad] all agree after rounding to this
            grid count as the same pose.

    Returns:
        ``(path (M, 3), directions (M,) or None)`` with M <= N.
    """
    p = np.asarray(path, dtype=float)
    if p.ndim != 2 or p.shape[1] < 3:
        raise ValueError(f"path must be an (N, 3) array of poses, got shape {p.shape}")
    if not tolerance > 0:
        raise ValueError(f"tolerance must be > 0, got {tolerance}")
    dirs = None if directions is None else np.asarray(directions, dtype=float).reshape(-1)
    if dirs is not None and dirs.size != p.shape[0]:
        raise ValueError(f"directions must have one entry per pose ({p.shape[0]}), got {dirs.size}")
    idx = _loop_cut(kernel_input(p[:, :3]), float(tolerance))
    # the step into a kept pose is the input's step into it, so its arriving direction is unchanged
    return p[idx], None if dirs is None else dirs[idx]


# ---------------------------------------------------------------------------------------- the fit
@dataclass(frozen=True)
class PiecewisePolynomial:
    """A planar piecewise polynomial curve p(u), u in [breaks[0], breaks[-1]].

    Attributes:
        breaks: (m+1,) increasing parameter values [m] (chord length).
        coeffs: (m, k+1, 2) coefficients of piece j in the local variable tau = (u - breaks[j]) / h_j,
            ascending powers.
    """

    breaks: FloatArray
    coeffs: FloatArray

    @property
    def degree(self) -> int:
        """Polynomial degree k."""
        return int(self.coeffs.shape[1] - 1)

    def __call__(self, u: ArrayLike, der: int = 0) -> FloatArray:
        """The ``der``-th derivative with respect to u at parameters ``u`` (clamped to the span).

        Args:
            u: (M,) parameters [m].
            der: Derivative order (0..k).

        Returns:
            (M, 2) values [m / m^der].
        """
        uq = np.clip(np.asarray(u, dtype=float).reshape(-1), self.breaks[0], self.breaks[-1])
        j = np.clip(np.searchsorted(self.breaks, uq, side="right") - 1, 0, self.breaks.size - 2)
        h = self.breaks[j + 1] - self.breaks[j]
        tau = (uq - self.breaks[j]) / h
        k = self.degree
        out = np.zeros((uq.size, 2))
        for p in range(der, k + 1):
            fac = float(np.prod(np.arange(p - der + 1, p + 1))) if der else 1.0
            out += (fac * tau ** (p - der))[:, None] * self.coeffs[j, p, :]
        return out / (h**der)[:, None]


def _basis(tau: FloatArray, k: int, der: int) -> FloatArray:
    """(M, k+1) rows: der-th derivative in tau of [1, tau, ..., tau^k]."""
    out = np.zeros((tau.size, k + 1))
    for p in range(der, k + 1):
        fac = float(np.prod(np.arange(p - der + 1, p + 1))) if der else 1.0
        out[:, p] = fac * tau ** (p - der)
    return out


def fit_piecewise(
    points: ArrayLike,
    breaks: ArrayLike,
    *,
    param: ArrayLike | None = None,
    start_tangent: ArrayLike | None = None,
    end_tangent: ArrayLike | None = None,
    end_curvature_zero: bool = True,
    degree: int = 5,
    continuity: int = 2,
    penalty: float = 1e-6,
) -> PiecewisePolynomial:
    """Constrained least-squares fit of a piecewise polynomial through points (the EduMIP planning report, II-B).

    Fix points: the first and last point. Derivative constraints: dp/du at the ends equal to the
    given tangents (unit vectors, so the curve starts and ends at unit parametric speed), d2p/du2 = 0
    at both ends if ``end_curvature_zero``, and continuity of derivatives 0..``continuity`` at every
    interior break. Objective: sum of squared distances to the points plus ``penalty`` times the
    integral of |d3p/du3|^2 (Gauss-Legendre quadrature, 3 nodes per piece).

    Solved exactly through the KKT system of the equality-constrained least-squares problem (the
    report's ``p = p^c + p^s`` with ``p^s`` kept in the null space of the constraints); see the module
    doc.

    Args:
        points: (n, 2) points to fit [m].
        breaks: (m+1,) piece boundaries in the parameter [m], from param[0] to param[-1].
        param: (n,) parameter of each point; default cumulative chord length.
        start_tangent: (2,) unit tangent at the start (optional).
        end_tangent: (2,) unit tangent at the end (optional).
        end_curvature_zero: Constrain the second derivative to zero at both ends.
        degree: Polynomial degree k per piece (>= 2 * continuity + 1 recommended).
        continuity: Highest derivative order continuous across breaks (2 for C2).
        penalty: Weight of the third-derivative penalty [m^4].

    Returns:
        The fitted curve.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 2:
        raise ValueError(f"points must be an (n, 2) array with n >= 2, got shape {pts.shape}")
    if param is None:
        u = cumulative_length(pts)
    else:
        u = np.asarray(param, dtype=float).reshape(-1)
    br = np.asarray(breaks, dtype=float).reshape(-1)
    if br.size < 2 or np.any(np.diff(br) <= 0):
        raise ValueError("breaks must be strictly increasing with at least 2 entries")
    m = br.size - 1
    bsp, y = _data_rows(pts, u, br, degree, penalty)
    tangents = (start_tangent, end_tangent)
    a_mat, b_mat = _constraint_rows(pts, br, degree, tangents, end_curvature_zero, continuity)
    # KKT system of min |B p - y|^2 s.t. A p = b: [[B^T B, A^T], [A, 0]] [p; mu] = [B^T y; b]
    import scipy.sparse.linalg

    kkt = scipy.sparse.block_array([[bsp.T @ bsp, a_mat.T], [a_mat, None]], format="csc")
    kkt_rhs = np.vstack([bsp.T @ y, b_mat])
    n_coef = m * (degree + 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scipy.sparse.linalg.MatrixRankWarning)
        p = np.asarray(scipy.sparse.linalg.spsolve(kkt, kkt_rhs))[:n_coef]
    if not np.all(np.isfinite(p)):  # redundant constraints: fall back to the least-squares solution
        p = np.linalg.lstsq(kkt.toarray(), kkt_rhs, rcond=None)[0][:n_coef]
    return PiecewisePolynomial(br, p.reshape(m, degree + 1, 2))


def _data_rows(
    pts: FloatArray, u: FloatArray, br: FloatArray, k: int, penalty: float
) -> tuple[scipy.sparse.csr_array, FloatArray]:
    """The least-squares rows B (sparse) and right-hand sides y (rows, 2) of :func:`fit_piecewise`: one
    row per point (each touches the k+1 coefficients of its piece), then the third-derivative
    penalty by 3-point Gauss-Legendre quadrature on each piece."""
    m, nc = br.size - 1, k + 1
    h = np.diff(br)
    j = np.clip(np.searchsorted(br, u, side="right") - 1, 0, m - 1)
    tau = (u - br[j]) / h[j]
    cols = (j[:, None] * nc + np.arange(nc)[None, :]).ravel()
    rws = np.repeat(np.arange(u.size), nc)
    data = [_basis(tau, k, 0).ravel()]
    r_idx, c_idx = [rws], [cols]
    rhs = [pts]
    nrow = u.size
    if penalty > 0 and k >= 3:
        gx, gw = np.polynomial.legendre.leggauss(3)
        b3 = _basis(0.5 * (gx + 1.0), k, 3)  # (3, nc)
        scale = np.sqrt(penalty * 0.5 * gw[None, :] * h[:, None]) / h[:, None] ** 3  # (m, 3)
        data.append((scale[:, :, None] * b3[None, :, :]).ravel())
        r_idx.append(nrow + np.repeat(np.arange(3 * m), nc))
        c_idx.append(np.repeat(np.arange(m), 3 * nc) * nc + np.tile(np.arange(nc), 3 * m))
        rhs.append(np.zeros((3 * m, 2)))
        nrow += 3 * m
    import scipy.sparse

    bsp = scipy.sparse.csr_array(
        (np.concatenate(data), (np.concatenate(r_idx), np.concatenate(c_idx))), shape=(nrow, m * nc)
    )
    return bsp, np.vstack(rhs)


def _constraint_rows(
    pts: FloatArray,
    br: FloatArray,
    k: int,
    tangents: tuple[ArrayLike | None, ArrayLike | None],
    end_curvature_zero: bool,
    continuity: int,
) -> tuple[scipy.sparse.csr_array, FloatArray]:
    """The constraints A p = b of :func:`fit_piecewise` (the same A for x and y, one column of b each)."""
    m, nc = br.size - 1, k + 1
    h = np.diff(br)
    a_data: list[FloatArray] = []
    a_r: list[NDArray[np.int64]] = []
    a_c: list[NDArray[np.int64]] = []
    b_rows: list[FloatArray] = []

    def add(terms: list[tuple[int, float, int, float]], value: ArrayLike) -> None:
        row = len(b_rows)
        for piece, t, der, sign in terms:
            a_data.append(sign * _basis(np.array([t]), k, der)[0] / h[piece] ** der)
            a_r.append(np.full(nc, row, dtype=np.int64))
            a_c.append(piece * nc + np.arange(nc, dtype=np.int64))
        b_rows.append(np.asarray(value, dtype=float))

    add([(0, 0.0, 0, 1.0)], pts[0])
    add([(m - 1, 1.0, 0, 1.0)], pts[-1])
    if tangents[0] is not None:
        add([(0, 0.0, 1, 1.0)], tangents[0])
    if tangents[1] is not None:
        add([(m - 1, 1.0, 1, 1.0)], tangents[1])
    if end_curvature_zero:
        add([(0, 0.0, 2, 1.0)], np.zeros(2))
        add([(m - 1, 1.0, 2, 1.0)], np.zeros(2))
    for jj in range(m - 1):
        for der in range(continuity + 1):
            add([(jj, 1.0, der, 1.0), (jj + 1, 0.0, der, -1.0)], np.zeros(2))
    import scipy.sparse

    a_mat = scipy.sparse.csr_array(
        (np.concatenate(a_data), (np.concatenate(a_r), np.concatenate(a_c))), shape=(len(b_rows), m * nc)
    )
    return a_mat, np.vstack(b_rows)


# ---------------------------------------------------------------------------------------- curves
@dataclass(frozen=True)
class SmoothCurve:
    """A fitted drive, resampled by arc length s.

    Attributes:
        poly: The fitted curve p(u).
        direction: +1 forwards, -1 backwards.
        u_table: (M,) parameter values of a fine table [m].
        s_table: (M,) arc length at those parameters [m], from 0.
    """

    poly: PiecewisePolynomial
    direction: int
    u_table: FloatArray = field(repr=False)
    s_table: FloatArray = field(repr=False)

    @classmethod
    def from_poly(cls, poly: PiecewisePolynomial, direction: int, spacing: float = 5e-4) -> SmoothCurve:
        """Tabulate the arc length of ``poly`` (trapezoidal rule on a ``spacing`` grid)."""
        span = float(poly.breaks[-1] - poly.breaks[0])
        n = max(int(np.ceil(span / spacing)), 16) + 1
        u = np.linspace(poly.breaks[0], poly.breaks[-1], n)
        sp = np.hypot(*poly(u, 1).T)
        s = np.concatenate([[0.0], np.cumsum(0.5 * (sp[1:] + sp[:-1]) * np.diff(u))])
        return cls(poly, int(direction), u, s)

    @property
    def length(self) -> float:
        """Arc length [m]."""
        return float(self.s_table[-1])

    def geometry(self, s: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position, unit tangent and signed curvature at arc lengths s.

        Args:
            s: (M,) arc lengths [m] (clamped to [0, length]).

        Returns:
            ``(xy (M, 2) [m], tangent (M, 2), kappa (M,) [1/m])``; the tangent points along
            increasing s (the direction of travel is ``direction`` times it).
        """
        u = np.interp(np.clip(np.asarray(s, dtype=float), 0.0, self.length), self.s_table, self.u_table)
        xy, d1, d2 = self.poly(u, 0), self.poly(u, 1), self.poly(u, 2)
        sp = np.maximum(np.hypot(d1[:, 0], d1[:, 1]), 1e-12)
        kappa = (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / sp**3
        return xy, d1 / sp[:, None], kappa

    @property
    def knots(self) -> FloatArray:
        """Arc lengths [m] of the interior breaks: the fit is C2, so the curvature's rate of change
        (with the third derivative) may jump there."""
        return np.asarray(np.interp(self.poly.breaks[1:-1], self.u_table, self.s_table))

    def curvature_rate(self, s: ArrayLike) -> FloatArray:
        """(M,) ``dkappa/ds`` [1/m^2] at arc lengths s (clamped; at a knot, the next piece's), from the
        fit's first three derivatives."""
        u = np.interp(np.clip(np.asarray(s, dtype=float), 0.0, self.length), self.s_table, self.u_table)
        d1, d2, d3 = self.poly(u, 1), self.poly(u, 2), self.poly(u, 3)
        sp = np.maximum(np.hypot(d1[:, 0], d1[:, 1]), 1e-12)
        cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
        cross3 = d1[:, 0] * d3[:, 1] - d1[:, 1] * d3[:, 0]
        along = d1[:, 0] * d2[:, 0] + d1[:, 1] * d2[:, 1]
        return np.asarray((cross3 / sp**3 - 3.0 * cross * along / sp**5) / sp)

    def poses(self, s: ArrayLike) -> FloatArray:
        """(M, 3) robot poses at arc lengths s (heading flipped on reverse drives)."""
        xy, tan, _ = self.geometry(s)
        th = np.unwrap(np.arctan2(self.direction * tan[:, 1], self.direction * tan[:, 0]))
        return np.column_stack([xy, th])


@dataclass(frozen=True)
class SampledCurve:
    """A drive given by a timed plan's own dense poses, kept as they are and resampled by arc length.

    Position and curvature are interpolated linearly between the samples; the plans that give them
    (``optim``, ``sinusoidal``) roll their kinematics out every 10 ms, a few millimetres apart, so the
    curve is the planner's own to far below a millimetre. The heading is the integral of that curvature,
    so that the heading a reference samples turns at the yaw rate it states (``omega = v kappa``): a heading
    interpolated linearly between the samples turns at each interval's own rate, a staircase around the
    curvature, and a reference slower than the plan turns in jerks at each sample, beyond the yaw
    acceleration its yaw rate keeps to. The curvature is the heading's difference quotient (second order),
    plus one constant over the drive that makes its integral the plan's whole turn; the heading then stays
    within 2e-4 rad of the plan's at every sample (random worlds' ``optim`` plans) and ends on it. Same
    interface as :class:`SmoothCurve` for :func:`planning.trajectory.speed_profile.time_drive`.

    Attributes:
        direction: +1 forwards, -1 backwards.
        s_table: (M,) arc length at the samples [m], from 0, strictly increasing.
        xy: (M, 2) positions [m].
        heading: (M,) robot heading at the samples, unwrapped [rad].
        kappa: (M,) signed curvature dtheta/ds [1/m].
    """

    direction: int
    s_table: FloatArray = field(repr=False)
    xy: FloatArray = field(repr=False)
    heading: FloatArray = field(repr=False)
    kappa: FloatArray = field(repr=False)

    @classmethod
    def from_poses(cls, poses: ArrayLike, direction: int) -> SampledCurve:
        """The curve through (M, 3) poses [x, y, theta] driven in ``direction`` (repeated points dropped).

        Raises:
            ValueError: Fewer than two distinct positions.
        """
        q = np.asarray(poses, dtype=float)
        step = path_steps(q)
        keep = np.concatenate([[True], step > 1e-9])
        q, step = q[keep], step[step > 1e-9]
        if q.shape[0] < 2:
            raise ValueError("a sampled curve needs two distinct positions")
        s = np.concatenate([[0.0], np.cumsum(step)])
        th = np.unwrap(q[:, 2])
        kappa = np.gradient(th, s)
        kappa += (th[-1] - th[0] - np.sum(0.5 * step * (kappa[1:] + kappa[:-1]))) / s[-1]  # turns as the plan does
        heading = th[0] + np.concatenate([[0.0], np.cumsum(0.5 * step * (kappa[1:] + kappa[:-1]))])
        return cls(int(direction), s, q[:, :2].copy(), heading, kappa)

    @property
    def length(self) -> float:
        """Arc length [m]."""
        return float(self.s_table[-1])

    def geometry(self, s: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position, unit tangent (along increasing s) and signed curvature at arc lengths s (clamped)."""
        sq = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        xy = np.column_stack([np.interp(sq, self.s_table, self.xy[:, 0]), np.interp(sq, self.s_table, self.xy[:, 1])])
        j = np.clip(np.searchsorted(self.s_table, sq, side="right") - 1, 0, self.s_table.size - 2)
        h = self.s_table[j + 1] - self.s_table[j]
        tau = sq - self.s_table[j]
        k0, k1 = self.kappa[j], self.kappa[j + 1]
        excess = self.heading[j + 1] - self.heading[j] - 0.5 * h * (k0 + k1)  # none from from_poses
        th = self.heading[j] + tau * (k0 + 0.5 * (k1 - k0) * tau / h + excess / h)
        tangent = self.direction * np.column_stack([np.cos(th), np.sin(th)])
        return xy, tangent, k0 + (k1 - k0) * tau / h

    @property
    def knots(self) -> FloatArray:
        """Arc lengths [m] of the interior samples: the curvature is linear between them, so its rate of
        change jumps there (a plan's speed or steering steps at its nodes)."""
        return self.s_table[1:-1]

    def curvature_rate(self, s: ArrayLike) -> FloatArray:
        """(M,) ``dkappa/ds`` [1/m^2] at arc lengths s (clamped): the slope of the curvature between the
        samples around each (at a sample, the next interval's)."""
        sq = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        slope = np.diff(self.kappa) / np.diff(self.s_table)
        j = np.clip(np.searchsorted(self.s_table, sq, side="right") - 1, 0, slope.size - 1)
        return np.asarray(slope[j])


def _densify(points: FloatArray, spacing: float) -> FloatArray:
    """Points along a polyline no more than ``spacing`` apart, keeping the vertices."""
    out = [points[:1]]
    for a, b in itertools.pairwise(points):
        n = max(1, int(np.ceil(np.hypot(*(b - a)) / spacing)))
        out.append(a + (np.arange(1, n + 1) / n)[:, None] * (b - a))
    return np.vstack(out)


def _polyline_distance(q: FloatArray, poly: FloatArray) -> FloatArray:
    """(M,) distance from each query point to a polyline."""
    a, b = poly[:-1], poly[1:]
    ab = b - a
    ll = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18)
    best = np.full(q.shape[0], np.inf)
    for start in range(0, a.shape[0], 256):
        sl = slice(start, start + 256)
        t = np.clip(((q[:, None, :] - a[None, sl]) * ab[None, sl]).sum(-1) / ll[None, sl], 0.0, 1.0)
        proj = a[None, sl] + t[..., None] * ab[None, sl]
        best = np.minimum(best, np.hypot(*(q[:, None, :] - proj).transpose(2, 0, 1)).min(axis=1))
    return best


#: Smallest speed of a fitted drive along its parameter (the path's length) that still follows the
#: path: a fit whose speed collapses has a kink or a loop.
MIN_SPEED = 0.3


@dataclass(frozen=True)
class SmoothResult:
    """Outcome of smoothing one drive.

    Attributes:
        status: SUCCESS, or why every refinement failed.
        curve: The smoothed drive (the last attempt's, on failure).
        pieces: Number of polynomial pieces used.
        attempts: Refinements tried.
        max_deviation: Largest distance from the curve to the input polyline [m].
        min_clearance: The footprint's least clearance along the curve [m], measured (within 0.1 mm:
            ``least_clearance``); a curve too far from the path, its bound when that clears the requirement
            (``clearance_of``: up to centimetres low away from obstacles); inf without a checker.
        min_speed: Smallest speed of the curve along its parameter, the path's length (1 follows the path;
            at most :data:`MIN_SPEED` the fit folds back on itself and fails as a deviation).
    """

    status: SmoothStatus
    curve: SmoothCurve
    pieces: int
    attempts: int
    max_deviation: float
    min_clearance: float
    min_speed: float = 1.0

    @property
    def success(self) -> bool:
        """Whether the drive was smoothed collision-free."""
        return self.status is SmoothStatus.SUCCESS


def _clearance(checker: CollisionChecker | None, poses: FloatArray, need: float, kept: bool) -> float:
    """The footprint's least clearance over ``poses`` [m], measured (``least_clearance``) where it decides ``>
    need`` or the curve is ``kept`` if it does; else the checker's bound, which clears ``need`` (``clearance_of``:
    up to centimetres low away from things, which failed curves that kept their clearance and reported
    centimetres less than a kept curve holds). inf without a checker."""
    if checker is None:
        return float("inf")
    dense = checker.densify(poses)
    bound = float(checker.clearance_of(dense).min())
    return checker.least_clearance(dense) if kept or bound <= need else bound


def smooth_drive(
    segment: PathSegment,
    checker: CollisionChecker | None = None,
    *,
    piece_length: float = 0.3,
    penalty: float = 1e-5,
    max_deviation: float = 0.05,
    clearance: float = 0.0,
    max_attempts: int = 5,
    sample_spacing: float = 0.01,
) -> SmoothResult:
    """Fit a drive segment and refine until it is collision-free and close to the path.

    Each refinement halves the piece length and divides the penalty by 10 (a tighter fit).

    Args:
        segment: A "drive" segment.
        checker: Footprint collision checker (None skips the collision test).
        piece_length: Initial parameter length of a polynomial piece [m].
        penalty: Initial third-derivative penalty [m^4].
        max_deviation: Largest allowed distance from the curve to the path [m].
        clearance: Footprint clearance the curve must keep [m].
        max_attempts: Number of refinements before giving up.
        sample_spacing: Arc-length spacing of the checks [m].

    Returns:
        The result; ``status`` says whether it succeeded.

    (``clearance`` and ``max_deviation`` come checked: :func:`check_options`, where the options enter.)
    """
    if segment.kind != "drive":
        raise ValueError("smooth_drive needs a 'drive' segment")
    pts = segment.points
    keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-9])
    pts = pts[keep]
    if pts.shape[0] < 2:
        raise ValueError("a drive segment needs two distinct points")
    dense = _densify(pts, 0.01)
    u = cumulative_length(dense)
    length = float(u[-1])
    sgn = segment.direction
    h0, h1 = segment.headings
    t0 = sgn * np.array([np.cos(h0), np.sin(h0)])
    t1 = sgn * np.array([np.cos(h1), np.sin(h1)])
    status = SmoothStatus.DEVIATION
    result: SmoothResult | None = None
    for attempt in range(max_attempts):
        m = max(1, int(np.ceil(length / piece_length)))
        breaks = np.linspace(0.0, length, m + 1)
        poly = fit_piecewise(dense, breaks, param=u, start_tangent=t0, end_tangent=t1, penalty=penalty)
        curve = SmoothCurve.from_poly(poly, sgn)
        s = np.linspace(0.0, curve.length, max(int(np.ceil(curve.length / sample_spacing)), 2) + 1)
        poses = curve.poses(s)
        dev = float(_polyline_distance(poses[:, :2], pts).max())
        # the parametric speed must stay near 1: a collapsing derivative means a kink or a loop
        sp = np.hypot(*poly(curve.u_table, 1).T)
        ok_shape = dev <= max_deviation and float(sp.min()) > MIN_SPEED
        clear = _clearance(checker, poses, clearance, kept=ok_shape)
        ok_clear = clear > clearance
        status = (
            SmoothStatus.SUCCESS
            if (ok_shape and ok_clear)
            else (SmoothStatus.COLLISION if ok_shape else SmoothStatus.DEVIATION)
        )
        result = SmoothResult(status, curve, m, attempt + 1, dev, clear, float(sp.min()))
        if status is SmoothStatus.SUCCESS:
            break
        piece_length *= 0.5
        penalty *= 0.1
    assert result is not None
    return result
