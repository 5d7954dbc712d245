"""Time-parametrised reference trajectories for a planar nonholonomic robot."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.arrays import ReadOnlyArrays
from planning.core.geometry import Pose2D, wrap_angle
from planning.errors import ConfigError

FloatArray = NDArray[np.float64]

#: Kinds of trajectory segment: drive forwards, drive backwards, turn in place, stand still.
SEGMENT_KINDS = ("forward", "reverse", "rotate", "hold")


@dataclass(frozen=True)
class TrajectorySample:
    """The reference at one instant.

    Attributes:
        t: Time [s].
        pose: (3,) reference pose [x, y, theta] [m, m, rad].
        vel: (2,) reference inputs [v, omega] [m/s, rad/s].
        acc: (2,) their derivatives [dv/dt, domega/dt] [m/s^2, rad/s^2].
        flat_vel: (2,) output velocity [dx/dt, dy/dt] [m/s].
        flat_acc: (2,) output acceleration [d2x/dt2, d2y/dt2] [m/s^2].
    """

    t: float
    pose: FloatArray
    vel: FloatArray
    acc: FloatArray
    flat_vel: FloatArray
    flat_acc: FloatArray


#: The quantities a trajectory is sampled at, in the order of ``Trajectory``'s interpolation table.
SAMPLE_FIELDS = ("x", "y", "theta", "v", "omega", "dv", "domega", "dx", "dy", "ddx", "ddy")


@dataclass(frozen=True)
class TrajectorySamples:
    """The reference at M instants (:meth:`Trajectory.sample_many`), one (M,) array per quantity.

    The arrays are read-only rows of one table, so building this costs no copy.

    Attributes:
        t: (M,) query times [s] (as asked; the reference is clamped to the trajectory's span).
        x: (M,) position x [m].
        y: (M,) position y [m].
        theta: (M,) heading [rad], unwrapped.
        v: (M,) speed [m/s].
        omega: (M,) yaw rate [rad/s].
        dv: (M,) dv/dt [m/s^2].
        domega: (M,) domega/dt [rad/s^2].
        dx: (M,) flat-output velocity dx/dt [m/s].
        dy: (M,) flat-output velocity dy/dt [m/s].
        ddx: (M,) flat-output acceleration d2x/dt2 [m/s^2].
        ddy: (M,) flat-output acceleration d2y/dt2 [m/s^2].
    """

    t: FloatArray
    x: FloatArray
    y: FloatArray
    theta: FloatArray
    v: FloatArray
    omega: FloatArray
    dv: FloatArray
    domega: FloatArray
    dx: FloatArray
    dy: FloatArray
    ddx: FloatArray
    ddy: FloatArray

    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def pose(self) -> FloatArray:
        """(M, 3) poses [x, y, theta] [m, m, rad]."""
        return np.column_stack([self.x, self.y, self.theta])

    @property
    def vel(self) -> FloatArray:
        """(M, 2) inputs [v, omega] [m/s, rad/s]."""
        return np.column_stack([self.v, self.omega])

    @property
    def flat_vel(self) -> FloatArray:
        """(M, 2) output velocities [dx/dt, dy/dt] [m/s]."""
        return np.column_stack([self.dx, self.dy])

    @property
    def flat_acc(self) -> FloatArray:
        """(M, 2) output accelerations [d2x/dt2, d2y/dt2] [m/s^2]."""
        return np.column_stack([self.ddx, self.ddy])

    def at(self, k: int) -> TrajectorySample:
        """The k-th instant as a :class:`TrajectorySample`."""
        return TrajectorySample(
            t=float(self.t[k]),
            pose=np.array([self.x[k], self.y[k], self.theta[k]]),
            vel=np.array([self.v[k], self.omega[k]]),
            acc=np.array([self.dv[k], self.domega[k]]),
            flat_vel=np.array([self.dx[k], self.dy[k]]),
            flat_acc=np.array([self.ddx[k], self.ddy[k]]),
        )


def _as_2d(name: str, value: ArrayLike, n: int, cols: int, rows: str = "") -> FloatArray:
    """``value`` as an (n, cols) float array of finite values, else a ConfigError naming ``Trajectory.<name>``
    (and, with ``rows``, what its rows hold)."""
    arr = np.array(value, dtype=float)  # a copy: the trajectory's arrays are its own
    if arr.shape != (n, cols):
        said = f" ({rows})" if rows else ""
        raise ConfigError(f"Trajectory.{name} must have shape ({n}, {cols}){said}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f"Trajectory.{name} contains non-finite values")
    return arr


@dataclass(frozen=True, eq=False)
class Trajectory(ReadOnlyArrays):
    """A reference trajectory sampled at N instants.

    The heading column is stored unwrapped (continuous), so interpolation never jumps by 2*pi. The arrays are
    the trajectory's own read-only copies, in its pickled and deep copies too: the caller's arrays stay as
    they were (writeable), and a later edit of them does not reach the trajectory. Trajectories are equal
    when their names, segment kinds and arrays are (``np.array_equal``); the hash is of the name, the size
    and the span, so equal ones hash alike. The repr is one short line (name, samples, span, segments), not
    the arrays.

    Attributes:
        t: (N,) strictly increasing times [s].
        pose: (N, 3) poses [x, y, theta] [m, m, rad].
        vel: (N, 2) inputs [v, omega] [m/s, rad/s]; v < 0 drives backwards.
        acc: (N, 2) input derivatives [dv/dt, domega/dt] [m/s^2, rad/s^2].
        name: Free-form label (reference or planner name).
        segments: Optional (N,) index of the segment each sample belongs to (non-decreasing), for
            trackers that switch law between drives, cusps and turns in place.
        segment_kinds: Kind of each segment, one of ``SEGMENT_KINDS`` ("forward", "reverse",
            "rotate", "hold"); required with ``segments``.

    Raises:
        ConfigError: Times not finite and strictly increasing, arrays of the wrong shape or with
            non-finite values, or segments that are not non-decreasing indices of known kinds.
    """

    t: FloatArray
    pose: FloatArray
    vel: FloatArray
    acc: FloatArray
    name: str = "trajectory"
    segments: NDArray[np.int64] | None = None
    segment_kinds: tuple[str, ...] = ()
    _cache: dict[str, FloatArray] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = np.array(self.t, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise ConfigError(f"Trajectory.t must be a 1-D array of at least 2 times, got shape {t.shape}")
        if not np.all(np.isfinite(t)):
            raise ConfigError("Trajectory.t contains non-finite values")
        if not math.isfinite(float(t[-1]) - float(t[0])):
            raise ConfigError(f"Trajectory.t spans {t[0]:g} to {t[-1]:g} s, a duration too long to be a number")
        if np.any(np.diff(t) <= 0.0):
            bad = int(np.argmax(np.diff(t) <= 0.0))
            raise ConfigError(f"Trajectory.t must be strictly increasing; t[{bad + 1}] <= t[{bad}]")
        n = t.size
        pose = _as_2d("pose", self.pose, n, 3)
        pose[:, 2] = np.unwrap(pose[:, 2])
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "pose", pose)
        object.__setattr__(self, "vel", _as_2d("vel", self.vel, n, 2))
        object.__setattr__(self, "acc", _as_2d("acc", self.acc, n, 2))
        for arr in (self.t, self.pose, self.vel, self.acc):
            arr.setflags(write=False)
        if self.segments is not None:
            seg = np.asarray(self.segments)
            if seg.shape != (n,) or not np.issubdtype(seg.dtype, np.integer):
                raise ConfigError(f"Trajectory.segments must be an integer array of shape ({n},), got {seg.shape}")
            kinds = tuple(self.segment_kinds)
            if np.any(np.diff(seg) < 0) or seg.min() < 0 or seg.max() >= len(kinds):
                raise ConfigError(
                    f"Trajectory.segments must be non-decreasing indices into segment_kinds ({len(kinds)} kinds)"
                )
            unknown = [name for name in kinds if name not in SEGMENT_KINDS]
            if unknown:
                raise ConfigError(f"Trajectory.segment_kinds: unknown kind(s) {unknown}; choose from {SEGMENT_KINDS}")
            seg = seg.astype(np.int64)
            seg.setflags(write=False)
            object.__setattr__(self, "segments", seg)
            object.__setattr__(self, "segment_kinds", kinds)

    def __setstate__(self, state: dict[str, Any]) -> None:
        super().__setstate__({**state, "_cache": {}})  # derived arrays are made again, read-only, when asked for

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Trajectory) or other.__class__ is not self.__class__:
            return NotImplemented
        if (self.name, tuple(self.segment_kinds)) != (other.name, tuple(other.segment_kinds)):
            return False
        mine, theirs = (self.t, self.pose, self.vel, self.acc), (other.t, other.pose, other.vel, other.acc)
        if not all(np.array_equal(a, b) for a, b in zip(mine, theirs, strict=True)):
            return False
        if self.segments is None or other.segments is None:
            return self.segments is other.segments
        return np.array_equal(self.segments, other.segments)

    def __hash__(self) -> int:  # type: ignore[override]  # hashable: its arrays are its own, read-only
        return hash((self.name, self.t.size, float(self.t[0]), float(self.t[-1])))

    def __repr__(self) -> str:
        segments = "" if self.segments is None else f", {len(self.segment_kinds)} segments"
        return (
            f"Trajectory({self.name!r}, {self.t.size} samples, t {float(self.t[0]):g}..{float(self.t[-1]):g} s, "
            f"{self.path_length():.3f} m{segments})"
        )

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_flat(
        cls,
        t: ArrayLike,
        xy: ArrayLike,
        dxy: ArrayLike,
        ddxy: ArrayLike,
        *,
        direction: ArrayLike | float = 1.0,
        name: str = "trajectory",
    ) -> Trajectory:
        """Build a trajectory from the flat outputs (x, y) and their time derivatives.

        Heading follows the velocity (or its opposite where ``direction`` is -1). Where the
        speed vanishes the heading is held from the nearest moving sample.

        Args:
            t: (N,) times [s].
            xy: (N, 2) positions [m].
            dxy: (N, 2) velocities [m/s].
            ddxy: (N, 2) accelerations [m/s^2].
            direction: +1 forwards, -1 backwards; scalar or (N,).
            name: Label.

        Returns:
            The trajectory with v, omega and their derivatives from the exact flat relations.

        Raises:
            ConfigError: ``t`` is not 1-D with 2 times or more, an array has another shape than its line
                above says (N from ``t``) or a non-finite value, or the times do not increase (the message
                names the argument).
        """
        t = np.asarray(t, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise ConfigError(f"Trajectory.from_flat: t must be a 1-D array of at least 2 times, got shape {t.shape}")
        xy = _as_2d("from_flat: xy", xy, t.size, 2, "one [x, y] row per time")
        dxy = _as_2d("from_flat: dxy", dxy, t.size, 2, "one [dx/dt, dy/dt] row per time")
        ddxy = _as_2d("from_flat: ddxy", ddxy, t.size, 2, "one [d2x/dt2, d2y/dt2] row per time")
        direction = np.asarray(direction, dtype=float)
        if direction.shape not in ((), t.shape):
            raise ConfigError(
                f"Trajectory.from_flat: direction must be +1 or -1, or an array of one per time ({t.size},), "
                f"got shape {direction.shape}"
            )
        sgn = np.broadcast_to(np.sign(direction), t.shape).copy()
        sgn[sgn == 0] = 1.0
        speed = np.hypot(dxy[:, 0], dxy[:, 1])
        moving = speed > 1e-9
        theta = np.arctan2(sgn * dxy[:, 1], sgn * dxy[:, 0])
        if not np.all(moving):
            if np.any(moving):
                idx = np.arange(t.size)
                mi = idx[moving]
                nearest = mi[np.clip(np.searchsorted(mi, idx), 0, mi.size - 1)]
                theta = np.where(moving, theta, theta[nearest])
            else:
                theta = np.zeros_like(t)
        v = sgn * speed
        cross = dxy[:, 0] * ddxy[:, 1] - dxy[:, 1] * ddxy[:, 0]
        dot = dxy[:, 0] * ddxy[:, 0] + dxy[:, 1] * ddxy[:, 1]
        safe = np.where(moving, speed, 1.0)
        omega = np.where(moving, cross / safe**2, 0.0)
        dv = np.where(moving, sgn * dot / safe, 0.0)
        domega = np.gradient(omega, t)
        pose = np.column_stack([xy, theta])
        return cls(t, pose, np.column_stack([v, omega]), np.column_stack([dv, domega]), name=name)

    # ------------------------------------------------------------------ queries
    @property
    def duration(self) -> float:
        """Length of the time span [s]."""
        return float(self.t[-1] - self.t[0])

    @property
    def start_pose(self) -> Pose2D:
        """Pose at the first sample."""
        return Pose2D(float(self.pose[0, 0]), float(self.pose[0, 1]), wrap_angle(float(self.pose[0, 2])))

    @property
    def final_pose(self) -> Pose2D:
        """Pose at the last sample."""
        return Pose2D(float(self.pose[-1, 0]), float(self.pose[-1, 1]), wrap_angle(float(self.pose[-1, 2])))

    def flat_derivatives(self) -> tuple[FloatArray, FloatArray]:
        """Velocity and acceleration of the output (x, y) at every sample.

        Returns:
            ``(dxy, ddxy)``, each (N, 2): [dx/dt, dy/dt] [m/s] and [d2x/dt2, d2y/dt2] [m/s^2],
                from xdot = v cos(theta), xddot = vdot cos(theta) - v omega sin(theta) (and alike for y).
        """
        if "dxy" not in self._cache:
            c, s = np.cos(self.pose[:, 2]), np.sin(self.pose[:, 2])
            v, w = self.vel[:, 0], self.vel[:, 1]
            dv = self.acc[:, 0]
            dxy = np.column_stack([v * c, v * s])
            ddxy = np.column_stack([dv * c - v * w * s, dv * s + v * w * c])
            dxy.setflags(write=False)  # the trajectory's own, as its arrays: every later sample is built from them
            ddxy.setflags(write=False)
            self._cache["dxy"], self._cache["ddxy"] = dxy, ddxy
        return self._cache["dxy"], self._cache["ddxy"]

    def _table(self) -> FloatArray:
        """(11, N) table of the ``SAMPLE_FIELDS`` at every sample, one contiguous row per quantity."""
        if "table" not in self._cache:
            dxy, ddxy = self.flat_derivatives()
            table = np.ascontiguousarray(np.column_stack([self.pose, self.vel, self.acc, dxy, ddxy]).T)
            table.setflags(write=False)
            self._cache["table"] = table
        return self._cache["table"]

    def sample_many(self, times: ArrayLike) -> TrajectorySamples:
        """Interpolate the reference linearly at many times at once.

        Times outside the span are clamped to the end samples.

        Args:
            times: (M,) query times [s].

        Returns:
            The reference at the M times, one (M,) array per quantity.

        Raises:
            ConfigError: ``times`` is not 1-D numbers, or holds a time that is not finite (NaN or infinite: the
                caller's clock is at fault; the message names the first such time and its index).
        """
        try:
            tq_asked = np.array(times, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(f"Trajectory.sample_many: times must be numbers [s], got {times!r:.80}") from None
        if tq_asked.ndim != 1:
            raise ConfigError(f"Trajectory.sample_many: times must be a 1-D array (M,), got shape {tq_asked.shape}")
        if not np.isfinite(tq_asked).all():
            k = int(np.argmin(np.isfinite(tq_asked)))
            raise ConfigError(
                f"Trajectory.sample_many was given a non-finite time times[{k}]={tq_asked[k]} s: the reference is "
                "sampled at finite times [s]; the caller's clock is at fault"
            )
        return self._interpolate(tq_asked)

    def _interpolate(self, tq_asked: FloatArray) -> TrajectorySamples:
        """:meth:`sample_many` at (M,) finite times [s] (a new array, made read-only here)."""
        tq_asked.setflags(write=False)
        tq = np.clip(tq_asked, self.t[0], self.t[-1])
        table = self._table()
        idx = np.clip(np.searchsorted(self.t, tq, side="right") - 1, 0, self.t.size - 2)
        t0, t1 = self.t[idx], self.t[idx + 1]
        a = (tq - t0) / (t1 - t0)
        rows = (1.0 - a) * table.take(idx, axis=1) + a * table.take(idx + 1, axis=1)
        rows.setflags(write=False)
        return TrajectorySamples(tq_asked, *rows)

    def sample(self, t: float) -> TrajectorySample:
        """Interpolate the reference at one time (clamped to the span).

        Raises:
            ConfigError: ``t`` is not finite (NaN or infinite: the caller's clock is at fault).
        """
        try:
            finite = math.isfinite(t)
        except TypeError:  # not one number
            if t is None or isinstance(t, str | bytes):
                what = f"{type(t).__name__} {t!r:.60}"
                raise ConfigError(f"Trajectory.sample: the time must be a number [s], got {what}") from None
            if np.ndim(t) != 0:
                raise ConfigError(
                    f"Trajectory.sample takes one time [s], got {type(t).__name__} {t!r:.60}; for several times "
                    "call Trajectory.sample_many(times)"
                ) from None
            return self.sample_many([t]).at(0)  # a number of another kind: sample_many says what it cannot use
        if not finite:
            raise ConfigError(
                f"Trajectory.sample was given a non-finite time t={t} s: the reference is sampled at a finite "
                "time [s]; the caller's clock is at fault"
            )
        return self._interpolate(np.array([t], dtype=float)).at(0)

    def path_length(self) -> float:
        """Length of the x-y path [m]."""
        return float(np.sum(np.hypot(np.diff(self.pose[:, 0]), np.diff(self.pose[:, 1]))))
