"""Curvature-limited speed profiles and the timed samples of drives and turns in place.

The EduMIP planning report (II-B) assigns each point of the smoothed path the speed
``v = min(sqrt(a_max / kappa), v_max)``. Here the same bound is joined by the other limits a
differential drive has, all scaled by ``margin`` so that the feedback keeps some authority:

* yaw rate: ``|omega| = v |kappa| <= omega_max``;
* wheel speed: ``v (1 + b |kappa| / 2) <= r * wheel_max`` (b track width, r wheel radius);
* yaw acceleration from curvature change: ``v^2 |dkappa/ds| <= alpha_max``;

then a forward pass (``v_{i+1}^2 <= v_i^2 + 2 a ds``) and a backward pass (the same, braking)
make the speed reachable with bounded acceleration, starting and ending at rest. The acceleration
``a`` of a step is bounded by ``a_max`` and by the yaw acceleration it causes on a curve:
``domega/dt = v^2 dkappa/ds + kappa a`` (the pointwise bound above keeps only the first term within
``alpha_max``; speeding up or braking on a curve adds the second), so
``|a| <= (alpha_max -+ sign(kappa) v^2 dkappa/ds) / |kappa|`` at both ends of the step (:func:`yaw_accel_bound`).
Without it the references of random worlds reached 1.5-3 times ``alpha_max`` where they sped up
into or braked out of a turn.

The grid is ``ds`` apart and holds every knot of the curve (:func:`profile_grid`: a fit's breaks, where
its curvature's rate of change jumps; a timed plan's samples, between which its curvature is linear), and
each step is bounded with the least and the most ``dkappa/ds`` the curve itself has within it
(:func:`step_rates`), not the grid's difference quotients. Within a step ``v^2`` is linear in s and the
curvature (nearly) so, so the yaw acceleration bounded at both ends holds all along it, in the samples too.
With difference quotients on a 5 mm grid, the samples of random worlds' ``optim`` references (a plan's
curvature falls at 800 /m^2 right after a sample where the grid saw 600) turned at up to 1.66 times
``alpha_max`` (1.41 times the robot's limit), where their ``acc`` column, from the same quotients, said at
most 1.14. Between two
grid points the acceleration is constant, so time stamps follow exactly
(``dt = 2 ds / (v_i + v_{i+1})``), and the drive is resampled at a uniform time step with
``s(t)`` from the constant-acceleration formula. Heading comes from the path tangent.

A turn in place gets a trapezoidal (or triangular) yaw-rate profile within ``omega_max`` and
``alpha_max``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.core.robot import RobotSpec
from planning.trajectory.smoothing import SampledCurve, SmoothCurve

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Limits:
    """The limits a timed path must respect.

    Attributes:
        max_speed: |v| [m/s].
        max_yaw_rate: |omega| [rad/s].
        max_accel: |dv/dt| and lateral acceleration v^2 |kappa| [m/s^2].
        max_yaw_accel: |domega/dt| [rad/s^2].
        max_wheel_linear: Wheel rim speed limit r * wheel_max [m/s].
        track_width: b [m].
    """

    max_speed: float
    max_yaw_rate: float
    max_accel: float
    max_yaw_accel: float
    max_wheel_linear: float
    track_width: float

    @classmethod
    def from_robot(cls, robot: RobotSpec, margin: float = 0.85) -> Limits:
        """The robot's limits scaled by ``margin`` (0 < margin <= 1)."""
        if not 0.0 < margin <= 1.0:
            raise ValueError(f"margin must be in (0, 1], got {margin}")
        return cls(
            max_speed=margin * robot.max_speed,
            max_yaw_rate=margin * robot.max_yaw_rate,
            max_accel=margin * robot.max_accel,
            max_yaw_accel=margin * robot.max_yaw_accel,
            max_wheel_linear=margin * robot.max_wheel_speed * robot.wheel_radius,
            track_width=robot.track_width,
        )


def speed_limit(kappa: FloatArray, dkappa: FloatArray, limits: Limits) -> FloatArray:
    """Pointwise speed bound from curvature (the EduMIP planning report's formula and the drive's limits).

    Args:
        kappa: (M,) curvature [1/m].
        dkappa: (M,) its derivative along the path [1/m^2].
        limits: The limits.

    Returns:
        (M,) speed bound [m/s], > 0.
    """
    k = np.abs(kappa)
    with np.errstate(divide="ignore"):
        v = np.minimum(limits.max_speed, np.sqrt(limits.max_accel / k))
        v = np.minimum(v, limits.max_yaw_rate / k)
        v = np.minimum(v, np.sqrt(limits.max_yaw_accel / np.abs(dkappa)))
    v = np.minimum(v, limits.max_wheel_linear / (1.0 + 0.5 * limits.track_width * k))
    return v


def yaw_accel_bound(kappa: float, dkappa: float, v: float, yaw_accel: float, way: int) -> float:
    """The largest |dv/dt| [m/s^2] at a point of curvature ``kappa`` [1/m] (changing by ``dkappa`` [1/m^2]
    along the path) and speed ``v`` [m/s] that keeps ``|domega/dt| = |v^2 dkappa + kappa dv/dt| <=
    yaw_accel``, speeding up (``way`` +1) or braking (-1); inf on a straight, 0 where the curvature's
    change alone takes it all."""
    k = abs(kappa)
    if k < 1e-9:
        return math.inf
    change = v * v * dkappa * math.copysign(1.0, kappa)  # v^2 dkappa, positive where it adds to kappa's turn
    return max((yaw_accel - way * change) / k, 0.0)


def forward_backward(
    ds: FloatArray,
    vmax: FloatArray,
    accel: float,
    v0: float = 0.0,
    v1: float = 0.0,
    *,
    turn: tuple[FloatArray, FloatArray, float] | None = None,
) -> FloatArray:
    """Speeds within a pointwise bound reachable with |acceleration| <= accel.

    Args:
        ds: (M-1,) arc-length steps [m].
        vmax: (M,) pointwise bound [m/s].
        accel: Acceleration limit [m/s^2].
        v0: Speed at the start [m/s].
        v1: Speed at the end [m/s].
        turn: (kappa (M,) [1/m], the least and the most dkappa/ds within each step (M-1, 2) [1/m^2], the
            yaw acceleration limit [rad/s^2]): each step's acceleration is also bounded by
            :func:`yaw_accel_bound` at both its ends, with both (:func:`_reach`); None: no such bound.

    Returns:
        (M,) speeds: the largest profile below ``vmax`` with v[0] <= v0, v[-1] <= v1 and
        |v_{i+1}^2 - v_i^2| <= 2 a_i ds_i, a_i the step's bound (``accel``, or less with ``turn``).
    """
    v = np.asarray(vmax, dtype=float).copy()
    v[0] = min(v[0], v0)
    v[-1] = min(v[-1], v1)
    for i in range(ds.size):
        v[i + 1] = min(v[i + 1], _reach(v[i], i, i + 1, ds[i], accel, turn, +1))
    for i in range(ds.size - 1, -1, -1):
        v[i] = min(v[i], _reach(v[i + 1], i + 1, i, ds[i], accel, turn, -1))
    return v


def _reach(
    v: float, near: int, far: int, ds: float, accel: float, turn: tuple[FloatArray, FloatArray, float] | None, way: int
) -> float:
    """The most speed point ``far`` can have, ``ds`` [m] from point ``near`` at speed ``v`` [m/s], speeding up
    (``way`` +1) or braking (-1) within ``accel`` and, with ``turn``, within the yaw acceleration at both
    points for every dkappa/ds the step holds (:func:`forward_backward`). At the far point the bound depends
    on the speed being found: ``v_f^2 <= v^2 + 2 ds (alpha - c v_f^2) / |kappa|`` with
    ``c = way sign(kappa) dkappa``, solved for ``v_f^2`` (where the turn tightens as the speed grows, c > 0:
    a point whose curvature changes fast must be passed slowly enough to brake or speed up there at all)."""
    if turn is None:
        return math.sqrt(v * v + 2.0 * accel * ds)
    kappa, rates, yaw = turn
    rate = rates[min(near, far)]  # the step's least and most dkappa/ds
    near_bound = min(yaw_accel_bound(kappa[near], d, v, yaw, way) for d in rate)
    reach = v * v + 2.0 * ds * min(accel, near_bound)
    k = abs(kappa[far])
    if k > 1e-9:
        tightest = max(way * d * math.copysign(1.0, kappa[far]) for d in rate)
        grows = 1.0 + 2.0 * ds * tightest / k
        if grows > 0.0:
            reach = min(reach, (v * v + 2.0 * ds * yaw / k) / grows)
    return math.sqrt(max(reach, 0.0))


@dataclass(frozen=True)
class TimedSamples:
    """Uniformly timed samples of one segment.

    Pieces are joined end to end into one trajectory (:func:`planning.trajectory.from_plan.make_trajectory`),
    so a piece checks itself: its times start at 0 and strictly increase (a piece of no duration, such
    as a turn by nothing, is not a piece: its maker refuses it).

    Attributes:
        t: (N,) times from 0 [s], N >= 2, strictly increasing.
        pose: (N, 3) poses [m, m, rad].
        vel: (N, 2) [v, omega] [m/s, rad/s].
        acc: (N, 2) [dv/dt, domega/dt] [m/s^2, rad/s^2].

    Raises:
        ValueError: Times that do not start at 0 or do not strictly increase, or arrays of other shapes.
    """

    t: FloatArray
    pose: FloatArray
    vel: FloatArray
    acc: FloatArray

    def __post_init__(self) -> None:
        n = self.t.shape[0] if self.t.ndim == 1 else -1
        if n < 2 or self.pose.shape != (n, 3) or self.vel.shape != (n, 2) or self.acc.shape != (n, 2):
            shapes = (self.t.shape, self.pose.shape, self.vel.shape, self.acc.shape)
            raise ValueError(
                f"TimedSamples: t, pose, vel, acc must be (N,), (N, 3), (N, 2), (N, 2), N >= 2; got {shapes}"
            )
        if self.t[0] != 0.0 or not np.all(np.diff(self.t) > 0.0):
            bad = int(np.argmax(np.diff(self.t) <= 0.0)) + 1 if self.t[0] == 0.0 else 0
            raise ValueError(f"TimedSamples: times must start at 0 and strictly increase; t[{bad}] = {self.t[bad]!r}")


def profile_grid(curve: SmoothCurve | SampledCurve, ds: float) -> FloatArray:
    """The arc lengths [m] the speed profile is found at: ``ds`` [m] apart, and every knot of the curve, where
    its curvature's rate of change may jump (a fit's breaks, a plan's samples); a grid point closer than a
    micrometre to a knot gives way to it. Between two points the curvature is then smooth (linear between a
    plan's samples), so the range of dkappa/ds in each step (:func:`step_rates`) is the curve's own."""
    n = max(int(np.ceil(curve.length / ds)), 2)
    s = np.linspace(0.0, curve.length, n + 1)
    knots = curve.knots
    knots = knots[(knots > 1e-6) & (knots < curve.length - 1e-6)]
    if knots.size == 0:
        return s
    j = np.clip(np.searchsorted(knots, s), 1, knots.size)
    near = np.minimum(np.abs(s - knots[j - 1]), np.abs(s - knots[np.minimum(j, knots.size - 1)]))
    keep = near > 1e-6
    keep[0] = keep[-1] = True
    return np.union1d(s[keep], knots)


#: Where each step of the profile's grid is probed for its curvature's rate of change (fractions of the step,
#: its ends moved in by a thousandth so that a knot's jump counts for the step on its side only).
_PROBES = np.concatenate([[1e-3], np.linspace(0.0, 1.0, 9)[1:-1], [1.0 - 1e-3]])


def step_rates(curve: SmoothCurve | SampledCurve, s: FloatArray) -> FloatArray:
    """(M-1, 2) the least and the most dkappa/ds [1/m^2] within each step of the grid ``s`` (M,) [m].

    The samples between two grid points see the curve's own rate of change of curvature, not the grid's
    difference quotient: a plan's curvature, linear between its samples, kinks at each of them, and a fit's
    kinks at its breaks and can change its slope by half within 5 mm; the yaw acceleration
    ``v^2 dkappa/ds + kappa dv/dt`` must hold for all of it (:func:`profile_grid` puts the kinks on the grid).
    """
    q = s[:-1, None] + np.diff(s)[:, None] * _PROBES[None, :]
    r = curve.curvature_rate(q.ravel()).reshape(q.shape)
    return np.column_stack([r.min(axis=1), r.max(axis=1)])


def time_drive(
    curve: SmoothCurve | SampledCurve, limits: Limits, *, dt: float = 0.01, ds: float = 0.005
) -> TimedSamples:
    """Time a drive from rest to rest within the limits.

    Args:
        curve: The drive (a fitted curve, or a timed plan's own samples).
        limits: The limits.
        dt: Output sample period [s].
        ds: Arc-length grid of the speed profile [m].

    Returns:
        The samples; the last one is exactly at the end of the drive, at rest.
    """
    s = profile_grid(curve, ds)
    _, _, kappa = curve.geometry(s)
    rates = step_rates(curve, s)
    step = np.diff(s)
    worst = np.abs(rates).max(axis=1)  # each step's steepest: both its ends see it
    steepest = np.maximum(np.append(worst, 0.0), np.insert(worst, 0, 0.0))
    turn = (kappa, rates, limits.max_yaw_accel)
    v = forward_backward(step, speed_limit(kappa, steepest, limits), limits.max_accel, turn=turn)
    seg_t = 2.0 * step / np.maximum(v[:-1] + v[1:], 1e-12)
    tg = np.concatenate([[0.0], np.cumsum(seg_t)])
    a = (v[1:] ** 2 - v[:-1] ** 2) / (2.0 * step)
    m = max(int(np.ceil(tg[-1] / dt)), 1)
    t = np.linspace(0.0, tg[-1], m + 1)
    i = np.clip(np.searchsorted(tg, t, side="right") - 1, 0, step.size - 1)
    tau = t - tg[i]
    sq = np.minimum(s[i] + v[i] * tau + 0.5 * a[i] * tau**2, curve.length)
    sdot = np.maximum(v[i] + a[i] * tau, 0.0)
    sddot = a[i]
    sq[-1], sdot[-1] = curve.length, 0.0
    sdot[0] = 0.0
    xy, tan, kap = curve.geometry(sq)
    dkap = curve.curvature_rate(sq)
    sgn = curve.direction
    th = np.unwrap(np.arctan2(sgn * tan[:, 1], sgn * tan[:, 0]))
    vel = np.column_stack([sgn * sdot, kap * sdot])
    acc = np.column_stack([sgn * sddot, dkap * sdot**2 + kap * sddot])
    return TimedSamples(t, np.column_stack([xy, th]), vel, acc)


def time_rotation(xy: FloatArray, theta0: float, theta1: float, limits: Limits, *, dt: float = 0.01) -> TimedSamples:
    """Time a turn in place from rest to rest with a trapezoidal yaw-rate profile.

    Args:
        xy: (2,) the spot [m].
        theta0: Start heading [rad].
        theta1: End heading (unwrapped: theta1 - theta0 is the signed turn) [rad].
        limits: The limits (max_yaw_rate, max_yaw_accel).
        dt: Sample period [s].

    Returns:
        The samples.

    Raises:
        ValueError: A turn of zero (or not finite): there is nothing to time.
    """
    turn = float(theta1 - theta0)
    dist = abs(turn)
    if not (np.isfinite(dist) and dist > 0.0):
        raise ValueError(f"a turn in place from {theta0!r} to {theta1!r} rad turns by nothing: nothing to time")
    sgn = 1.0 if turn >= 0 else -1.0
    wmax, amax = limits.max_yaw_rate, limits.max_yaw_accel
    if dist >= wmax**2 / amax:  # trapezoid
        tr = wmax / amax
        tc = (dist - wmax**2 / amax) / wmax
        peak = wmax
    else:  # triangle
        tr = np.sqrt(dist / amax)
        tc = 0.0
        peak = amax * tr
    total = 2.0 * tr + tc
    m = max(int(np.ceil(total / dt)), 2)
    t = np.linspace(0.0, total, m + 1)
    w = np.where(t < tr, amax * t, np.where(t <= tr + tc, peak, np.maximum(amax * (total - t), 0.0)))
    alpha = np.where(t < tr, amax, np.where(t <= tr + tc, 0.0, -amax))
    ang = np.where(
        t < tr,
        0.5 * amax * t**2,
        np.where(t <= tr + tc, 0.5 * amax * tr**2 + peak * (t - tr), dist - 0.5 * amax * (total - t) ** 2),
    )
    ang[-1], w[-1], w[0] = dist, 0.0, 0.0
    pose = np.column_stack([np.full(t.size, xy[0]), np.full(t.size, xy[1]), theta0 + sgn * ang])
    vel = np.column_stack([np.zeros(t.size), sgn * w])
    acc = np.column_stack([np.zeros(t.size), sgn * alpha])
    return TimedSamples(t, pose, vel, acc)


def hold(pose: FloatArray, duration: float, *, dt: float = 0.01) -> TimedSamples:
    """Standing still at ``pose`` for ``duration`` seconds (a pause at a cusp or before a turn)."""
    m = max(int(np.ceil(duration / dt)), 1)
    t = np.linspace(0.0, duration, m + 1)
    return TimedSamples(
        t, np.tile(np.asarray(pose, dtype=float), (t.size, 1)), np.zeros((t.size, 2)), np.zeros((t.size, 2))
    )
