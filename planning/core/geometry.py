"""Planar poses and angle helpers."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.checks import check_number, given, is_number, numbers_text, refuse_kind
from planning.errors import ConfigError

FloatArray = NDArray[np.float64]


@overload
def wrap_angle(angle: float) -> float: ...
@overload
def wrap_angle(angle: FloatArray) -> FloatArray: ...


def wrap_angle(angle: float | FloatArray) -> float | FloatArray:
    """Wrap angles to [-pi, pi).

    Args:
        angle: Angle(s) [rad], scalar or array of any shape.

    Returns:
        The wrapped angle(s): a float for a scalar, else a float64 array of the input's shape (NaN stays NaN, and an
        infinity is NaN: no angle to wrap; without numpy's "invalid value" warning, which named no caller).

    Raises:
        ConfigError: ``angle`` is not numbers (a string, None, True: numpy read "1" and True as 1.0).
    """
    try:
        a = np.asarray(angle)
        if a.dtype.kind not in "iuf":  # numbers only: numpy read None as NaN, "1" and True as 1.0
            raise TypeError
        a = a.astype(float, copy=False)
    except (TypeError, ValueError):
        raise ConfigError(
            f"wrap_angle takes angles in radians (numbers), got {type(angle).__name__} {angle!r:.60}"
        ) from None
    # just below -pi, a + pi is a few ulps under 0, whose modulus rounds to 2 pi: pi, outside [-pi, pi)
    if a.ndim == 0:  # Python's float modulus is numpy's (the same fmod and sign rule), without its call's cost
        x = float(a)
        if not math.isfinite(x):  # an infinity has no direction: NaN, as NaN is
            return math.nan
        w = (x + math.pi) % (2.0 * math.pi) - math.pi
        return w - 2.0 * math.pi if w >= math.pi else w
    with np.errstate(invalid="ignore"):  # an infinity: NaN, without numpy's "invalid value" warning
        wrapped = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    return np.where(wrapped >= np.pi, wrapped - 2.0 * np.pi, wrapped)


def heading_in_turn(theta: float) -> float:
    """A pose's heading brought into (-pi, pi] (its direction, whatever turn it was written with: 7 rad is 0.717
    rad); one already in it is kept as written, bit for bit. How a scenario holds its start and goal."""
    if -np.pi < theta <= np.pi:
        return theta
    wrapped = wrap_angle(theta)
    return float(np.pi) if wrapped == -np.pi else wrapped


def unwrap_heading(theta: ArrayLike) -> FloatArray:
    """Remove 2*pi jumps from a heading sequence (N,) [rad]."""
    return np.unwrap(np.asarray(theta, dtype=float))


def compose_poses(a: FloatArray, b: FloatArray) -> FloatArray:
    """Planar poses a ∘ b (N, 3): b expressed in a's frame, brought into a's parent."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack(
        [a[:, 0] + c * b[:, 0] - s * b[:, 1], a[:, 1] + s * b[:, 0] + c * b[:, 1], a[:, 2] + b[:, 2]]
    )


def invert_poses(a: FloatArray) -> FloatArray:
    """Planar poses a⁻¹ (N, 3)."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack([-c * a[:, 0] - s * a[:, 1], s * a[:, 0] - c * a[:, 1], -a[:, 2]])


@dataclass(frozen=True)
class Pose2D:
    """A planar pose: a position [m] and a heading [rad].

    The heading is in radians: ``Pose2D(0, 0, math.pi / 2)`` faces +y. ``Pose2D(0, 0, 90)`` is accepted (90 rad
    is an angle too, about 116.6 degrees after wrapping) but is not a quarter turn: convert degrees with
    ``math.radians(90)``. The heading is kept as given, not wrapped (:func:`wrap_angle` wraps it).

    Attributes:
        x: Position [m].
        y: Position [m].
        theta: Heading [rad], counter-clockwise from +x; any finite value, not wrapped.

    Raises:
        ConfigError: A coordinate that is not a finite number.
    """

    x: float
    y: float
    theta: float

    def __post_init__(self) -> None:
        for name in ("x", "y", "theta"):
            object.__setattr__(self, name, check_number(f"Pose2D.{name}", getattr(self, name)))

    @classmethod
    def from_array(cls, values: ArrayLike) -> Pose2D:
        """Build a pose from a sequence ``[x, y, theta]``."""
        try:
            arr = np.asarray(values, dtype=float).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"a pose needs exactly 3 numbers [x, y, theta], got {values!r:.80} ({exc})") from None
        if arr.shape != (3,):
            raise ConfigError(f"a pose needs exactly 3 numbers [x, y, theta], got shape {arr.shape}")
        return cls(float(arr[0]), float(arr[1]), float(arr[2]))

    def as_array(self) -> FloatArray:
        """Return ``[x, y, theta]`` as a (3,) array."""
        return np.array([self.x, self.y, self.theta])

    @property
    def xy(self) -> FloatArray:
        """Position as a (2,) array [m]."""
        return np.array([self.x, self.y])

    def distance_to(self, other: Pose2D) -> float:
        """Euclidean distance between the positions [m]."""
        return float(np.hypot(self.x - other.x, self.y - other.y))

    def heading_error_to(self, other: Pose2D) -> float:
        """Absolute wrapped heading difference [rad]."""
        return abs(wrap_angle(self.theta - other.theta))


@overload
def check_pose(where: str, value: object, *, optional: Literal[False] = False) -> Pose2D: ...
@overload
def check_pose(where: str, value: object, *, optional: bool) -> Pose2D | None: ...
def check_pose(where: str, value: object, *, optional: bool = False) -> Pose2D | None:
    """``value`` when it is a :class:`Pose2D` (or None, where ``optional``).

    Raises:
        ConfigError: Anything else, naming ``where``, what was given and how to make a pose of it
            (``Pose2D(1, 1, 0)`` for three numbers, ``Pose2D.from_array`` for an array of three).
    """
    if isinstance(value, Pose2D) or (optional and value is None):
        return value
    if text := numbers_text(value, 3):
        fix = f"Pose2D({text})"
    elif isinstance(value, np.ndarray) and value.shape == (3,):
        fix = "Pose2D.from_array(values), which takes [x, y, theta]"
    else:
        fix = "Pose2D(x, y, theta)"
    raise refuse_kind(where, "a Pose2D or None" if optional else "a Pose2D", value, fix)


# ---------------------------------------------------------------------------------------- paths
# A path is an (N, 3) array of poses [x, y, theta] along a motion. How far the robot moves between
# two consecutive poses is the distance its base origin travels, |dxy| [m]; where a turn must count
# too (a turn in place moves the robot's body although the origin stays put) a caller gives the
# robot's radius R and the step becomes |dxy| + R |dtheta| (headings unwrapped first), a bound on
# how far any point of the robot moves. A path's length is the sum of its steps.


def _steps(path: FloatArray, theta: FloatArray | None, radius: float) -> FloatArray:
    x, y = path[:, 0], path[:, 1]  # np.diff's numbers, without its per-call cost (a plan's result pays it)
    step = np.hypot(x[1:] - x[:-1], y[1:] - y[:-1])
    if radius and theta is not None:
        step = step + radius * np.abs(np.diff(theta))
    return step  # type: ignore[no-any-return]


def _as_path(path: ArrayLike, caller: str) -> FloatArray:
    """``path`` as an (N, 2) or (N, 3) float array; the check of the public functions' ``path`` (a numpy
    attribute or two: the callers' numerics cost far more)."""
    try:
        p = np.asarray(path, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ConfigError(
            f"{caller}: path must be an (N, 2) or (N, 3) array of positions or poses [x, y, theta] (numbers), "
            f"got {type(path).__name__}: {exc}"
        ) from exc
    if p.ndim != 2 or not 2 <= p.shape[1] <= 3:
        one = "; a single pose [x, y, theta] is the one-row path [[x, y, theta]]" if p.ndim == 1 else ""
        wide = "; pass path[:, :3] for the poses alone" if p.ndim == 2 and p.shape[1] > 3 else ""
        raise ConfigError(
            f"{caller}: path must be an (N, 2) or (N, 3) array of positions or poses [x, y, theta], one row per "
            f"point, got shape {p.shape}{one}{wide}"
        )
    return p


def _radius(radius: object, caller: str) -> float:
    """``radius`` [m] as a float when it is a finite number >= 0 (the callers check a float's range first, in a
    comparison: the default 0.0 and a robot's radius cost nothing more)."""
    return check_number(
        f"{caller}: radius", radius, at_least=0.0, unit="m", fix="the robot's radius, or 0 to count positions only"
    )


def _non_finite(p: FloatArray, caller: str) -> ConfigError:
    """The error for a path with a NaN or an infinity, naming its first rows."""
    rows = np.flatnonzero(~np.isfinite(p).all(axis=1))
    return ConfigError(
        f"{caller}: the path has non-finite values (NaN or infinite) in {rows.size} of its {len(p)} poses "
        f"(rows {', '.join(map(str, rows[:10]))}{', ...' if rows.size > 10 else ''}); give finite poses"
    )


def _checked_steps(p: FloatArray, radius: float, caller: str) -> FloatArray:
    """:func:`path_steps` of a checked path (``caller`` names the public function in messages)."""
    if radius and p.shape[1] < 3:
        raise ConfigError(
            f"{caller}: counting turns (radius {radius:g}) needs (N, 3) poses with headings, got shape {p.shape}; "
            "pass radius=0 to count positions only"
        )
    if not radius:
        return _steps(p, None, 0.0)
    with np.errstate(invalid="ignore"):  # an infinite heading: path_length names its row, with no numpy warning
        return _steps(p, np.unwrap(p[:, 2]), radius)


def path_steps(path: ArrayLike, radius: float = 0.0) -> FloatArray:
    """How far the robot moves between consecutive poses (see the note above) [m].

    Args:
        path: (N, 2) positions or (N, 3) poses [x, y, theta].
        radius: R [m], >= 0: a heading change dtheta adds R |dtheta| (headings unwrapped; needs poses).
            0 counts the base origin's travel only.

    Returns:
        (N - 1,) steps [m] (empty for fewer than two poses); a NaN or an infinity in the path gives one
            in the steps next to it (:func:`path_length` refuses it).

    Raises:
        ConfigError: ``path`` is not an (N, 2) or (N, 3) array, or ``radius`` is not a finite number >= 0
            (> 0 with (N, 2) positions: it counts turns).
    """
    p = _as_path(path, "path_steps")
    if type(radius) is not float or not 0.0 <= radius < math.inf:
        radius = _radius(radius, "path_steps")
    return _checked_steps(p, radius, "path_steps")


def path_length(path: ArrayLike, radius: float = 0.0) -> float:
    """Length of a path: the sum of its :func:`path_steps` [m].

    With the default ``radius = 0`` it is the length of the x-y polyline (a turn in place adds
    nothing); with the robot's radius a heading change adds radius * |angle|.

    Args:
        path: (N, 2) positions or (N, 3) poses [x, y, theta].
        radius: R [m], >= 0 (see :func:`path_steps`).

    Returns:
        The length [m]; 0 for fewer than two poses.

    Raises:
        ConfigError: ``path`` is not an (N, 2) or (N, 3) array (a single pose ``[x, y, theta]`` is
            refused: the one-row path is ``[[x, y, theta]]``), or holds a NaN or an infinity where the
            length reads it (the positions; the headings too with a radius), naming its rows;
            ``radius`` is not a finite number >= 0 (> 0 with (N, 2) positions).
    """
    p = _as_path(path, "path_length")
    if type(radius) is not float or not 0.0 <= radius < math.inf:
        radius = _radius(radius, "path_length")
    if p.shape[0] < 2:
        return 0.0
    total = float((_checked_steps(p, radius, "path_length") if radius else _steps(p, None, 0.0)).sum())
    if not math.isfinite(total):  # checked on the sum: free on a finite path (a planner's, in its hot loop)
        used = p if radius else p[:, :2]
        if not np.isfinite(used).all():
            raise _non_finite(used, "path_length")
    return total


def cumulative_length(path: ArrayLike) -> FloatArray:
    """Distance travelled by the base origin from the first pose to each pose [m].

    Args:
        path: (N, 2) positions or (N, 3) poses.

    Returns:
        (N,) running sums of the x-y steps, starting at 0.
    """
    return np.concatenate([[0.0], np.cumsum(path_steps(path))])


#: Most poses :func:`densify_path` makes (240 MB of them; a 1000 m path every 0.1 mm): a spacing that would
#: make more is most likely a mistake of units, refused before numpy is asked for the memory.
MAX_DENSE_POSES = 10_000_000


def _too_dense(poses: float, length: float, spacing: float, n: int) -> ConfigError:
    """The error for a spacing that cuts a path of ``n`` poses, whose steps add up to ``length`` [m], into
    ``poses`` poses."""
    least = length / max(MAX_DENSE_POSES - n, 1)  # then at most length / spacing + n poses
    return ConfigError(
        f"densify_path: spacing {spacing:g} m would cut the path's {length:.6g} m into {poses:.3g} poses (at most "
        f"{MAX_DENSE_POSES:,}); give a larger spacing, at least {float(f'{least * 1.05:.2g}'):g} m (e.g. 0.02)"
    )


def densify_path(path: ArrayLike, spacing: float, *, radius: float = 0.0, slack: float = 0.0) -> FloatArray:
    """Insert poses so that no step (:func:`path_steps` with ``radius``) exceeds ``spacing``.

    Each step is cut into ``ceil(step / spacing - slack)`` equal parts (at least one), positions and
    unwrapped headings interpolated linearly, so the poses must themselves follow the motion (the
    states of a motion primitive, a planner's path).

    Args:
        path: (N, 3) poses [x, y, theta].
        spacing: Largest step allowed [m], > 0.
        radius: R [m]: a heading change counts R |dtheta| (the robot's radius bounds how far any
            point of it moves); 0 counts the base origin's travel only.
        slack: A step longer than k spacings by less than ``slack * spacing`` is cut into k parts,
            not k + 1 (rounding of a step that is an exact multiple); 0: none.

    Returns:
        (N', 3) poses, N' >= N, starting and ending with the given ones, headings unwrapped; a path
            of fewer than two poses comes back as it is.

    Raises:
        ConfigError: ``spacing`` is not a finite number > 0, or ``slack`` one in [0, 1); ``path`` is not an (N, 3)
            array of poses
            (positions without headings, (N, 2), are named as such) or holds a NaN or an infinity.
    """
    if type(spacing) is not float or not 0.0 < spacing < math.inf:  # the callers' float, checked in 0.1 us
        if not (is_number(spacing) and spacing > 0):
            raise ConfigError(f"densify_path: spacing must be > 0 m (a finite number), got {given(spacing)}; e.g. 0.02")
        spacing = float(spacing)
    if type(slack) is not float or not 0.0 <= slack < 1.0:  # a nan was blamed on the spacing
        slack = check_number("densify_path: slack", slack, at_least=0.0, below=1.0, unit="of a spacing")
    p = _as_path(path, "densify_path")
    if p.shape[1] < 3:
        raise ConfigError(
            f"densify_path needs an (N, 3) path of poses [x, y, theta], got shape {p.shape}; for positions alone "
            "add a heading column (e.g. the direction of travel, np.arctan2 of the steps)"
        )
    if not np.isfinite(p).all():
        raise _non_finite(p, "densify_path")
    if type(radius) is not float or not 0.0 <= radius < math.inf:
        radius = _radius(radius, "densify_path")
    if p.shape[0] < 2:
        return p
    th = np.unwrap(p[:, 2])
    steps = _steps(p, th, radius)
    parts = np.maximum(1.0, np.ceil(steps / spacing - slack))
    poses = float(parts.sum()) + 1.0
    if not poses <= MAX_DENSE_POSES:  # before numpy is asked for arrays of that size (a NaN too: an overflow)
        raise _too_dense(poses, float(steps.sum()), spacing, p.shape[0])
    n = parts.astype(int)
    idx = np.repeat(np.arange(len(n)), n)
    frac = np.concatenate([np.arange(k) / k for k in n.tolist()])  # Python ints: faster than numpy's, each
    q = np.column_stack([p[:, 0], p[:, 1], th])
    out = q[idx] + frac[:, None] * (q[idx + 1] - q[idx])
    return np.vstack([out, q[-1:]])
