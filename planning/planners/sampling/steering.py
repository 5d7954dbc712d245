"""Local steering for the random-tree planners: the reports' motion primitives and exact curves.

* :func:`bicycle_primitives`: the TurtleBot planning report's 60 primitives, steering straight /
  full left / full right, each at 20 speeds evenly spaced over [-max_speed, max_speed] (zero
  excluded), held for ``duration``. The steering angle is reduced where ``|v| tan(phi) / l`` would
  exceed the robot's yaw-rate limit, so every primitive is drivable. Arcs are exact.
* :func:`unicycle_primitives`: the fruit-farm report's six primitives, v = +-0.15 m/s, omega in
  {-0.15, 0, 0.15} rad/s, integrated by RK4 with step 0.05 s for 100 steps.
* :func:`diffdrive_steer`: the parking-lot report's least-squares wheel speeds toward a sample over
  a 1 s drive, clipped to the wheel, speed and yaw-rate limits.
* :class:`CurveSteering`: exact two-point steering by Dubins (forward only) or Reeds–Shepp curves.

Primitives are stored once in the body frame; the unicycle and bicycle are invariant under
planar rigid motions, so placing them at a pose is one rotation and translation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.geometry import wrap_angle
from planning.core.kinematics import rk4_step, unicycle_rhs, wheel_speeds
from planning.core.robot import RobotSpec
from planning.curves.dubins import dubins_length, dubins_path
from planning.curves.reeds_shepp import reeds_shepp_length, reeds_shepp_path
from planning.curves.words import Word

FloatArray = NDArray[np.float64]

#: Largest arc length between stored samples of a primitive [m].
SAMPLE_STEP = 0.01
#: Largest turning radius of the exact curves [m] (the tree planners' and Hybrid-A*'s option): a curve of a larger
#: one is a straight line in any world nhsim simulates, and its samples (its length over a centimetre) would not fit
#: in memory.
MAX_TURNING_RADIUS = 1000.0
#: Smallest turning radius of the exact curves [m]: they are sampled every centimetre, and a tighter radius (1e-9 m)
#: made their words' lengths in radii overflow the samples' memory.
MIN_TURNING_RADIUS = 0.01


@nb.njit(cache=True)
def se2_metric(nodes: FloatArray, q: FloatArray) -> FloatArray:
    """The TurtleBot planning report's distance on (x, y, cos theta, sin theta), compiled, over many nodes.

    Args:
        nodes: (N, 3) poses.
        q: (3,) pose.

    Returns:
        (N,) distances.
    """
    cq, sq = np.cos(q[2]), np.sin(q[2])
    out = np.empty(nodes.shape[0])
    for i in range(nodes.shape[0]):
        dx = nodes[i, 0] - q[0]
        dy = nodes[i, 1] - q[1]
        dc = np.cos(nodes[i, 2]) - cq
        ds = np.sin(nodes[i, 2]) - sq
        out[i] = np.sqrt(dx * dx + dy * dy + dc * dc + ds * ds)
    return out


def place(body_poses: FloatArray, pose: ArrayLike) -> FloatArray:
    """Body-frame poses (..., 3) placed at a world pose (3,), or at poses (..., 3) that broadcast
    against them (e.g. (M, K, 3) bodies at (M, 1, 3) poses)."""
    p = np.asarray(pose, dtype=float)
    if p.ndim == 1:  # one pose (the common call, kept quick: scalars, no broadcasting)
        x, y, th = p
        out = np.empty_like(body_poses)
    else:
        x, y, th = p[..., 0], p[..., 1], p[..., 2]
        out = np.empty(np.broadcast_shapes(np.shape(body_poses), p.shape))
    c, s = np.cos(th), np.sin(th)
    out[..., 0] = x + c * body_poses[..., 0] - s * body_poses[..., 1]
    out[..., 1] = y + s * body_poses[..., 0] + c * body_poses[..., 1]
    out[..., 2] = th + body_poses[..., 2]
    return out


def arc_poses(v: float, omega: float, duration: float, n: int) -> FloatArray:
    """Exact unicycle poses under constant (v, omega) from the origin, (n + 1, 3), uniform in time."""
    t = np.linspace(0.0, duration, n + 1)
    th = omega * t
    if abs(omega) < 1e-12:
        return np.column_stack([v * t, np.zeros_like(t), th])
    return np.column_stack([v / omega * np.sin(th), v / omega * (1.0 - np.cos(th)), th])


@dataclass(frozen=True)
class PrimitiveSet:
    """Motion primitives in the body frame.

    Attributes:
        name: "bicycle" or "unicycle".
        poses: (P, K + 1, 3) poses from the origin, uniform in time.
        controls: (P, 2) constant [v, omega] of each primitive.
        duration: Duration of every primitive [s].
        steering: (P,) virtual steering angle phi [rad] (bicycle), zeros otherwise.
    """

    name: str
    poses: FloatArray
    controls: FloatArray
    duration: float
    steering: FloatArray

    @property
    def directions(self) -> FloatArray:
        """(P,) +1 forwards, -1 backwards."""
        return np.sign(self.controls[:, 0])  # type: ignore[no-any-return]

    def at(self, pose: ArrayLike) -> FloatArray:
        """(P, K + 1, 3) primitives started at a world pose."""
        return place(self.poses, pose)


def bicycle_primitives(robot: RobotSpec, *, n_speeds: int = 20, duration: float = 1.0) -> PrimitiveSet:
    """The TurtleBot planning report's straight/left/right x ``n_speeds`` speeds primitives (60 by default).

    Args:
        robot: Speed and yaw-rate limits, virtual wheelbase and steering bound.
        n_speeds: Speeds per steering class, evenly spaced over [-max_speed, max_speed], zero
            excluded (even counts never hit zero; for odd counts zero is dropped).
        duration: How long each primitive is held [s].
    """
    if n_speeds < 1 or not duration > 0:
        raise ValueError(f"need n_speeds >= 1 and duration > 0, got {n_speeds}, {duration}")
    speeds = np.linspace(-robot.max_speed, robot.max_speed, n_speeds + (n_speeds % 2))
    speeds = speeds[speeds != 0.0]
    n = int(np.ceil(robot.max_speed * duration / SAMPLE_STEP))
    poses, controls, phis = [], [], []
    for sign in (0.0, 1.0, -1.0):  # straight, left, right
        for v in speeds:
            phi_lim = min(robot.max_steering, float(np.arctan(robot.max_yaw_rate * robot.wheelbase / abs(v))))
            phi = sign * phi_lim
            omega = v * np.tan(phi) / robot.wheelbase
            poses.append(arc_poses(v, omega, duration, n))
            controls.append((v, omega))
            phis.append(phi)
    return PrimitiveSet("bicycle", np.array(poses), np.array(controls), float(duration), np.array(phis))


def unicycle_primitives(
    *, speed: float = 0.15, yaw_rate: float = 0.15, dt: float = 0.05, steps: int = 100
) -> PrimitiveSet:
    """The fruit-farm report's six primitives: v in {+speed, -speed} x omega in {-yaw_rate, 0, +yaw_rate},
    each integrated by RK4 with step ``dt`` for ``steps`` steps."""
    if not (speed > 0 and dt > 0 and steps >= 1):
        raise ValueError(f"need speed > 0, dt > 0, steps >= 1, got {speed}, {dt}, {steps}")
    controls = np.array([(v, w) for v in (speed, -speed) for w in (yaw_rate, 0.0, -yaw_rate)])
    poses = np.empty((controls.shape[0], steps + 1, 3))
    x = np.zeros((controls.shape[0], 3))
    poses[:, 0] = x
    for k in range(steps):
        x = rk4_step(unicycle_rhs, x, controls, dt)
        poses[:, k + 1] = x
    return PrimitiveSet("unicycle", poses, controls, float(dt * steps), np.zeros(controls.shape[0]))


def diffdrive_metric(nodes: FloatArray, q: FloatArray) -> FloatArray:
    """The parking-lot report's nearest-node metric: L2 on (x, y, theta) with the heading difference wrapped."""
    dth = wrap_angle(nodes[:, 2] - q[2])
    return np.sqrt((nodes[:, 0] - q[0]) ** 2 + (nodes[:, 1] - q[1]) ** 2 + dth * dth)  # type: ignore[no-any-return]


def diffdrive_steer(q_near: ArrayLike, q_target: ArrayLike, robot: RobotSpec, *, duration: float = 1.0) -> FloatArray:
    """The parking-lot report's drive policy: least-squares wheel speeds toward a sample, driven for ``duration``.

    Minimises (v T cos th - dx)^2 + (v T sin th - dy)^2 + (omega T - dth)^2 over (v, omega), i.e.
    over the wheel speeds (u_l, u_r) with v = r (u_l + u_r) / 2 and omega = r (u_r - u_l) / L;
    the wheel speeds are then scaled down uniformly to respect the wheel, speed and yaw-rate limits.

    Returns:
        (K + 1, 3) exact poses of the drive from ``q_near``, at most 1 cm apart.
    """
    a = np.asarray(q_near, dtype=float)
    b = np.asarray(q_target, dtype=float)
    c, s = np.cos(a[2]), np.sin(a[2])
    v = ((b[0] - a[0]) * c + (b[1] - a[1]) * s) / duration
    w = float(wrap_angle(b[2] - a[2])) / duration
    wl, wr = wheel_speeds(v, w, robot.wheel_radius, robot.track_width)
    scale = max(
        1.0,
        max(abs(wl), abs(wr)) / robot.max_wheel_speed,
        abs(v) / robot.max_speed,
        abs(w) / robot.max_yaw_rate,
    )
    v, w = v / scale, w / scale
    n = max(1, int(np.ceil((abs(v) + robot.radius * abs(w)) * duration / SAMPLE_STEP)))
    return place(arc_poses(v, w, duration, n), a)


CurveKind = Literal["dubins", "reeds_shepp"]


@dataclass(frozen=True)
class CurveSteering:
    """Exact two-point steering with Dubins (forward only) or Reeds–Shepp curves.

    Attributes:
        kind: "dubins" or "reeds_shepp".
        rho: Turning radius [m].
    """

    kind: CurveKind
    rho: float

    def __post_init__(self) -> None:
        if self.kind not in ("dubins", "reeds_shepp"):
            raise ValueError(f"curve kind must be 'dubins' or 'reeds_shepp', got {self.kind!r}")
        if not self.rho > 0:
            raise ValueError(f"turning radius must be > 0, got {self.rho}")

    def lengths(self, q0: ArrayLike, q1: ArrayLike) -> FloatArray:
        """(N,) curve lengths [m] from q0 to q1 (either may be a single pose)."""
        fn = dubins_length if self.kind == "dubins" else reeds_shepp_length
        return fn(q0, q1, self.rho)

    def curve(self, q0: ArrayLike, q1: ArrayLike) -> Word:
        """The shortest curve from ``q0`` to ``q1``."""
        fn = dubins_path if self.kind == "dubins" else reeds_shepp_path
        return fn(q0, q1, self.rho)


def default_turning_radius(robot: RobotSpec) -> float:
    """The virtual bicycle's minimum turning radius l / tan(phi_max) [m]."""
    return float(robot.wheelbase / np.tan(robot.max_steering))
