"""What a job's ROS 2 bag holds: its topics, each a list of (time, message), built from the run logs.

Frames (REP 105), one tree per run under the run's name (``closed_loop/odom``, ...) beside the shared
``map``::

    map -> RUN/odom -> RUN/base_footprint -> RUN/base_link -> RUN/wheel_left_link, RUN/wheel_right_link
                                                          \\-> RUN/imu_link, RUN/base_scan (static)

``RUN/odom -> RUN/base_footprint`` is what the run's estimator believed (the fused estimate, dead
reckoning, or the truth for a run fed the true pose); ``map -> RUN/odom`` carries the estimate's
error, so ``base_footprint`` sits at the true pose in ``map``. ``base_footprint -> base_link`` is the
body's height, pitch and roll from the physics (a balancing robot leans); the wheels turn by their
joint angles.

Per run (namespace ``/RUN``): ``tf``, ``odom`` (the estimate with its covariance), ``ground_truth/odom``,
``joint_states``, ``imu`` (from the true motion: orientation, yaw rate, planar acceleration plus
gravity; noise-free), ``cmd_vel``, ``fix`` (the localisation fixes, when the run's sensors give them)
and ``scan`` (when the run log carries one). Once per job: ``/clock``, ``/tf_static``, ``/plan``,
``/reference``, ``/map`` and ``/obstacles``, the last four and ``/tf_static`` latched.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planning.core.world import Box, Circle, Ellipse, Polygon, World
from sim.io import rosmsgs as m

FloatArray = NDArray[np.float64]

#: Edge of a map cell [m] (coarser for large worlds: at most MAP_MAX_CELLS cells).
MAP_RESOLUTION = 0.02
MAP_MAX_CELLS = 1_000_000
#: Height of the obstacle markers [m].
OBSTACLE_HEIGHT = 0.25
#: Height of a robot's body marker [m].
ROBOT_HEIGHT = 0.12
GRAVITY = 9.80665
WHEELS = ("wheel_left", "wheel_right")


@dataclass
class Topic:
    """One topic of the bag.

    Messages are made one at a time as they are written (a job's bag holds tens of thousands), so
    that none is kept.

    Attributes:
        name: Topic name (absolute).
        msgtype: Full message type, e.g. ``nav_msgs/msg/Odometry``.
        times: (K,) the messages' times [s], non-decreasing.
        make: Message k of the topic, stamped ``times[k]``: for the topics of many messages, one message
            object filled anew at each call (serialise it before the next).
        latched: Offered with transient-local durability (a late subscriber gets the last message).
    """

    name: str
    msgtype: str
    times: FloatArray
    make: Callable[[int], Any]
    latched: bool = False


@dataclass(frozen=True)
class Skeleton:
    """The robot's joints and fixed frames from its MJCF file.

    Attributes:
        root: qpos address of the free joint (position then w, x, y, z quaternion).
        wheels: qpos addresses of the left and right wheel joints.
        wheel_pos: (2, 3) wheel axle centres in the base body [m].
        scan_pos: (3,) the lidar in the base body [m], or None.
    """

    root: int
    wheels: tuple[int, int]
    wheel_pos: FloatArray
    scan_pos: FloatArray | None


@cache
def skeleton(robot: str) -> Skeleton:
    """The joints and fixed frames of a robot's model (loaded once per robot)."""
    import mujoco

    from planning.core.robot import robot_path

    model = mujoco.MjModel.from_xml_path(str(robot_path(robot)))
    adr = model.jnt_qposadr
    wheels = tuple(int(adr[model.joint(f"{w}_joint").id]) for w in WHEELS)
    wheel_pos = np.array([model.body(w).pos for w in WHEELS], dtype=float)
    names = {model.body(i).name for i in range(model.nbody)}
    scan = np.array(model.body("base_scan").pos, dtype=float) if "base_scan" in names else None
    return Skeleton(int(adr[model.joint("root").id]), (wheels[0], wheels[1]), wheel_pos, scan)


def ros_quat(wxyz: FloatArray) -> tuple[float, float, float, float]:
    """MuJoCo's (w, x, y, z) as ROS's (x, y, z, w)."""
    return (float(wxyz[1]), float(wxyz[2]), float(wxyz[3]), float(wxyz[0]))


def _quat_mul(a: FloatArray, b: FloatArray) -> FloatArray:
    """Hamilton product of (w, x, y, z) quaternions, rowwise over (N, 4)."""
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.column_stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def compose(a: FloatArray, b: FloatArray) -> FloatArray:
    """Planar poses a ∘ b (N, 3): b expressed in a's frame, brought into a's parent."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack(
        [a[:, 0] + c * b[:, 0] - s * b[:, 1], a[:, 1] + s * b[:, 0] + c * b[:, 1], a[:, 2] + b[:, 2]]
    )


def inverse(a: FloatArray) -> FloatArray:
    """Planar poses a⁻¹ (N, 3)."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack([-c * a[:, 0] - s * a[:, 1], s * a[:, 0] - c * a[:, 1], -a[:, 2]])


def body_velocity(t: FloatArray, pose: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(v, omega) (N,) each: speed along the heading [m/s] and yaw rate [rad/s] of a pose series."""
    if t.size < 2:
        return np.zeros(t.size), np.zeros(t.size)
    dx, dy, dth = (np.gradient(pose[:, k], t) for k in range(3))
    return np.cos(pose[:, 2]) * dx + np.sin(pose[:, 2]) * dy, dth


def estimate_at(log: Any, t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """What the run's estimator believed at times ``t``: (poses (N, 3), variances (N, 3)); the true
    pose with zero variance for a run fed the truth."""
    est = log.estimation
    if est is None or est.t.size == 0:
        return log.pose.copy(), np.zeros((t.size, 3))
    e = est.estimate.copy()
    e[:, 2] = np.unwrap(e[:, 2])
    pose = np.column_stack([np.interp(t, est.t, e[:, k]) for k in range(3)])
    var = np.column_stack([np.interp(t, est.t, est.variance[:, k]) for k in range(3)])
    return pose, var


def run_frames(ns: str) -> dict[str, str]:
    """The run's frame names (REP 105, prefixed by the run)."""
    names = ("odom", "base_footprint", "base_link", "wheel_left_link", "wheel_right_link", "imu_link", "base_scan")
    return {n: f"{ns}/{n}" for n in names}


Series = tuple[FloatArray, Callable[[int], Any]]


def _tf_series(log: Any, sk: Skeleton, frames: dict[str, str]) -> Series:
    """``RUN/tf``: per logged sample map -> odom -> base_footprint -> base_link -> wheels."""
    t, truth = log.t, log.pose
    est, _ = estimate_at(log, t)
    map_odom = compose(truth, inverse(est))
    q = log.qpos[:, sk.root + 3 : sk.root + 7]
    yaw_inv = np.column_stack([np.cos(0.5 * truth[:, 2]), np.zeros((t.size, 2)), -np.sin(0.5 * truth[:, 2])])
    tilt = _quat_mul(yaw_inv, q)  # the body's pitch and roll, in the footprint frame
    rel = log.qpos[:, sk.root : sk.root + 2] - truth[:, :2]
    c, s = np.cos(truth[:, 2]), np.sin(truth[:, 2])
    lift = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1], log.qpos[:, sk.root + 2]])
    half = 0.5 * log.qpos[:, list(sk.wheels)]
    fr = frames
    links = [
        ("map", "odom"),
        ("odom", "base_footprint"),
        ("base_footprint", "base_link"),
        ("base_link", "wheel_left_link"),
        ("base_link", "wheel_right_link"),
    ]
    msg = m.tf_message([m.transform(0.0, fr.get(a, a), fr[b], (0.0, 0.0, 0.0), (0, 0, 0, 1)) for a, b in links])
    trs = msg.transforms

    def make(k: int) -> Any:
        tk = float(t[k])
        mo, e = map_odom[k], est[k]
        m.set_transform(trs[0], tk, (mo[0], mo[1], 0.0), m.yaw_quat(mo[2]))
        m.set_transform(trs[1], tk, (e[0], e[1], 0.0), m.yaw_quat(e[2]))
        m.set_transform(trs[2], tk, lift[k], ros_quat(tilt[k]))
        for j in range(2):
            a = float(half[k, j])
            m.set_transform(trs[3 + j], tk, sk.wheel_pos[j], (0.0, math.sin(a), 0.0, math.cos(a)))
        return msg

    return t, make


def _odometry(
    t: FloatArray, frame: str, child: str, pose: FloatArray, var: FloatArray, v: FloatArray, omega: FloatArray
) -> Series:
    """``nav_msgs/Odometry`` at times ``t`` (K,): planar poses (K, 3), their variances (K, 3), body velocity."""
    msg = m.odometry(0.0, frame, child, pose[0], var[0], v[0], omega[0])
    cov, tw = msg.pose.covariance, msg.twist.twist

    def make(k: int) -> Any:
        msg.header.stamp = m.stamp(float(t[k]))
        m.set_planar_pose(msg.pose.pose, pose[k])
        cov[[0, 7, 35]] = var[k]
        tw.linear.x, tw.angular.z = float(v[k]), float(omega[k])
        return msg

    return t, make


def _odom_series(
    log: Any, frames: dict[str, str], wheel: Callable[[FloatArray], tuple[FloatArray, FloatArray]]
) -> Series:
    """``RUN/odom``: the estimate (at the control instants, or the logged samples without an
    estimator) with its variances; the twist from the wheel speeds."""
    est = log.estimation
    t = est.t if est is not None and est.t.size else log.t
    pose, var = estimate_at(log, t)
    v, omega = wheel(t)
    return _odometry(t, frames["odom"], frames["base_footprint"], pose, var, v, omega)


def _truth_series(log: Any, frames: dict[str, str]) -> Series:
    """``RUN/ground_truth/odom``: the true pose and body velocity in ``map``."""
    v, omega = body_velocity(log.t, log.pose)
    return _odometry(log.t, "map", frames["base_footprint"], log.pose, np.zeros((log.t.size, 3)), v, omega)


def _imu_series(log: Any, sk: Skeleton, frames: dict[str, str]) -> Series:
    """``RUN/imu``: the body's orientation, its yaw rate and planar acceleration plus gravity (true motion)."""
    v, omega = body_velocity(log.t, log.pose)
    dv = np.gradient(v, log.t) if log.t.size > 1 else np.zeros(log.t.size)
    q = log.qpos[:, sk.root + 3 : sk.root + 7]
    t = log.t
    msg = m.imu(0.0, frames["imu_link"], (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, GRAVITY))

    def make(k: int) -> Any:
        msg.header.stamp = m.stamp(float(t[k]))
        m.set_quaternion(msg.orientation, ros_quat(q[k]))
        msg.angular_velocity.z = float(omega[k])
        msg.linear_acceleration.x, msg.linear_acceleration.y = float(dv[k]), float(v[k] * omega[k])
        return msg

    return t, make


def _error_series(log: Any, frame: str) -> Series:
    """``RUN/tracking_error``: x the distance from the reference pose at the same time [m], y the heading
    error [rad] (wrapped), z 0."""
    d = log.pose[:, :2] - log.ref_pose[:, :2]
    dist = np.hypot(d[:, 0], d[:, 1])
    head = np.remainder(log.pose[:, 2] - log.ref_pose[:, 2] + np.pi, 2 * np.pi) - np.pi
    t = log.t
    msg = m.vector_stamped(0.0, frame, 0.0, 0.0, 0.0)

    def make(k: int) -> Any:
        msg.header.stamp = m.stamp(float(t[k]))
        msg.vector.x, msg.vector.y = float(dist[k]), float(head[k])
        return msg

    return t, make


def _joints_series(log: Any, sk: Skeleton) -> Series:
    """``RUN/joint_states``: the wheels' angles [rad] and speeds [rad/s]."""
    t, angles, speeds = log.t, log.qpos[:, list(sk.wheels)], log.wheel_speed
    msg = m.joint_state(0.0, ["wheel_left_joint", "wheel_right_joint"], angles[0], speeds[0])

    def make(k: int) -> Any:
        msg.header.stamp = m.stamp(float(t[k]))
        msg.position, msg.velocity = np.array(angles[k], dtype=float), np.array(speeds[k], dtype=float)
        return msg

    return t, make


def _command_series(log: Any, frame: str) -> Series:
    """``RUN/cmd_vel``: the body command (v [m/s], omega [rad/s]) in force."""
    t, cmd = log.t, log.command
    msg = m.twist_stamped(0.0, frame, 0.0, 0.0)

    def make(k: int) -> Any:
        msg.header.stamp = m.stamp(float(t[k]))
        msg.twist.linear.x, msg.twist.angular.z = float(cmd[k, 0]), float(cmd[k, 1])
        return msg

    return t, make


def _fix_series(log: Any, std: tuple[float, float]) -> Series:
    """``RUN/fix``: the localisation fixes at their measurement times, with the profile's variances."""
    est = log.estimation
    if est is None or est.fix_t.size == 0:
        return np.zeros(0), lambda k: None
    var = np.array([std[0] ** 2, std[0] ** 2, std[1] ** 2])
    return est.fix_t, lambda k: m.pose_fix(float(est.fix_t[k]), "map", est.fix[k], var)


@dataclass(frozen=True)
class Sweeps:
    """A run's lidar revolutions as ``sensor_msgs/LaserScan`` describes them.

    Attributes:
        t: (K,) stamps (first beam) [s].
        ranges: (K, B) ranges [m] (REP 117: -inf too close, +inf nothing within range).
        angle_min: Bearing of the first beam [rad]; the others follow counter-clockwise.
        angle_increment: Bearing step [rad].
        time_increment: Time between beams [s].
        scan_time: Time between revolutions [s].
        range_min: Shortest range [m].
        range_max: Longest range [m].
    """

    t: FloatArray
    ranges: FloatArray
    angle_min: float
    angle_increment: float
    time_increment: float
    scan_time: float
    range_min: float
    range_max: float

    @property
    def angle_max(self) -> float:
        """Bearing of the last beam [rad]."""
        return self.angle_min + (self.ranges.shape[1] - 1) * self.angle_increment


def scan_of(log: Any) -> Sweeps | None:
    """The run's lidar revolutions, or None: the scans the run's scan localiser took
    (``log.estimation.localiser``: ``scan_t``, ``scan_ranges``, ``scan_angle_increment`` from bearing 0,
    ``scan_time_increment``, ``range_min``, ``range_max``), or a ``log.scan`` with those fields of
    :class:`Sweeps` (``t``, ``ranges``, ``angle_min``, ...)."""
    loc = getattr(log.estimation, "localiser", None) if log.estimation is not None else None
    if loc is not None and np.asarray(loc.scan_t).size:
        t = np.asarray(loc.scan_t, dtype=float)
        period = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        return Sweeps(
            t,
            np.asarray(loc.scan_ranges, dtype=float),
            0.0,
            float(loc.scan_angle_increment),
            float(loc.scan_time_increment),
            period,
            float(loc.range_min),
            float(loc.range_max),
        )
    scan = getattr(log, "scan", None)
    if scan is None:
        return None
    t = np.asarray(scan.t, dtype=float)
    return Sweeps(
        t,
        np.asarray(scan.ranges, dtype=float),
        float(scan.angle_min),
        float(scan.angle_increment),
        float(getattr(scan, "time_increment", 0.0)),
        float(getattr(scan, "scan_time", 0.0)),
        float(scan.range_min),
        float(scan.range_max),
    )


def _scan_series(log: Any, frames: dict[str, str]) -> Series:
    """The revolutions that began in the run (the first fix's revolution is centred on its start, so
    half of it turned while the robot stood there before time 0, which a bag cannot stamp)."""
    scan = scan_of(log)
    if scan is None:
        return np.zeros(0), lambda k: None
    fr = frames["base_scan"]
    keep = np.flatnonzero(scan.t >= 0.0)
    return scan.t[keep], lambda k: m.laser_scan(float(scan.t[keep[k]]), fr, scan, scan.ranges[keep[k]])


def run_topics(ns: str, log: Any, robot: Any, sk: Skeleton, fix_std: tuple[float, float]) -> list[Topic]:
    """The topics of one run under ``/ns``.

    Args:
        ns: The run's name (its namespace and frame prefix).
        log: Its :class:`sim.physics.runlog.RunLog`.
        robot: The robot spec (wheel radius and track for the odometry twist).
        sk: The robot's skeleton.
        fix_std: Standard deviations of the localisation fixes (position [m], heading [rad]).
    """
    frames = run_frames(ns)
    r, b = robot.wheel_radius, robot.track_width

    def wheel(t: FloatArray) -> tuple[FloatArray, FloatArray]:
        wl, wr = (np.interp(t, log.t, log.wheel_speed[:, j]) for j in range(2))
        return 0.5 * r * (wl + wr), r * (wr - wl) / b

    base = frames["base_link"]
    series: list[tuple[str, str, Series]] = [
        ("tf", "tf", _tf_series(log, sk, frames)),
        ("odom", "odometry", _odom_series(log, frames, wheel)),
        ("ground_truth/odom", "odometry", _truth_series(log, frames)),
        ("joint_states", "joints", _joints_series(log, sk)),
        ("imu", "imu", _imu_series(log, sk, frames)),
        ("cmd_vel", "twist", _command_series(log, base)),
        ("tracking_error", "vector", _error_series(log, base)),
        ("fix", "fix", _fix_series(log, fix_std)),
        ("scan", "scan", _scan_series(log, frames)),
    ]
    return [Topic(f"/{ns}/{name}", m.TYPES[kind], times, make) for name, kind, (times, make) in series if times.size]


def static_transforms(namespaces: list[str], sk: Skeleton) -> Any:
    """``/tf_static``: each run's IMU at its base, and its lidar where the model has one."""
    tfs = []
    for ns in namespaces:
        fr = run_frames(ns)
        tfs.append(m.transform(0.0, fr["base_link"], fr["imu_link"], np.zeros(3), (0.0, 0.0, 0.0, 1.0)))
        if sk.scan_pos is not None:
            tfs.append(m.transform(0.0, fr["base_link"], fr["base_scan"], sk.scan_pos, (0.0, 0.0, 0.0, 1.0)))
    return m.tf_message(tfs)


def occupancy(world: World, resolution: float = MAP_RESOLUTION) -> tuple[float, NDArray[np.int8]]:
    """The world's obstacles as occupancy (100 inside one, 0 free), rows along y from ``(xmin, ymin)``.

    Returns:
        (resolution [m], coarsened for large worlds, (H, W) int8 grid).
    """
    xmin, xmax, ymin, ymax = world.bounds
    area = (xmax - xmin) * (ymax - ymin)
    res = max(resolution, math.ceil(math.sqrt(area / MAP_MAX_CELLS) * 1000.0) / 1000.0)
    w, h = max(1, math.ceil((xmax - xmin) / res)), max(1, math.ceil((ymax - ymin) / res))
    xs, ys = xmin + (np.arange(w) + 0.5) * res, ymin + (np.arange(h) + 0.5) * res
    gx, gy = np.meshgrid(xs, ys)
    inside = world.obstacle_distance(np.column_stack([gx.ravel(), gy.ravel()])) <= 0.0
    return res, np.where(inside, 100, 0).astype(np.int8).reshape(h, w)


def map_message(world: World) -> Any:
    """``/map``: the occupancy grid of the world (see :func:`occupancy`)."""
    res, grid = occupancy(world)
    info = m.msg("nav_msgs/msg/MapMetaData")(
        map_load_time=m.stamp(0.0),
        resolution=res,
        width=grid.shape[1],
        height=grid.shape[0],
        origin=m.pose(world.bounds[0], world.bounds[2], 0.0, (0.0, 0.0, 0.0, 1.0)),
    )
    return m.msg(m.TYPES["grid"])(header=m.header(0.0, "map"), info=info, data=grid.ravel())


OBSTACLE_COLOUR = (0.55, 0.45, 0.35, 0.9)
#: Colours of the runs' robots (RGBA), in the order of the job's runs; the rest grey.
RUN_COLOURS = ((0.12, 0.47, 0.71, 1.0), (1.0, 0.5, 0.05, 0.9), (0.5, 0.5, 0.5, 0.5), (0.17, 0.63, 0.17, 0.9))


def _marker(
    k: int,
    kind: int,
    p: Any,
    scale: tuple[float, float, float],
    points: list[Any],
    *,
    frame: str = "map",
    ns: str = "obstacles",
    colour: tuple[float, ...] = OBSTACLE_COLOUR,
) -> Any:
    """A ``visualization_msgs/Marker`` (lifetime forever; locked to its frame, so it moves with it)."""
    marker = m.msg("visualization_msgs/msg/Marker")
    r, g, b, a = colour
    return marker(
        header=m.header(0.0, frame),
        ns=ns,
        id=k,
        type=kind,
        action=0,
        pose=p,
        scale=m.vector(*scale),
        color=m.msg("std_msgs/msg/ColorRGBA")(r=r, g=g, b=b, a=a),
        lifetime=m.msg("builtin_interfaces/msg/Duration")(sec=0, nanosec=0),
        frame_locked=frame != "map",
        points=points,
        colors=[],
        texture_resource="",
        texture=m.msg("sensor_msgs/msg/CompressedImage")(
            header=m.header(0.0, ""), format="", data=np.zeros(0, dtype=np.uint8)
        ),
        uv_coordinates=[],
        text="",
        mesh_resource="",
        mesh_file=m.msg("visualization_msgs/msg/MeshFile")(filename="", data=np.zeros(0, dtype=np.uint8)),
        mesh_use_embedded_materials=False,
    )


def robot_markers(ns: str, robot: Any, sk: Skeleton, colour: tuple[float, ...]) -> Any:
    """``RUN/robot``: the run's robot drawn in its ``base_link`` (a box over the footprint, two wheels),
    locked to the frame so that it drives with the run's transforms."""
    frame = run_frames(ns)["base_link"]
    lo, hi = robot.footprint.min(axis=0), robot.footprint.max(axis=0)
    r, height = robot.wheel_radius, ROBOT_HEIGHT
    body = m.pose(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * height + 0.005 - r, (0.0, 0.0, 0.0, 1.0))
    size = (float(hi[0] - lo[0]), float(hi[1] - lo[1]), height)
    markers = [_marker(0, 1, body, size, [], frame=frame, ns=ns, colour=colour)]
    axle = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))  # a cylinder's axis turned from z onto y
    for j, pos in enumerate(sk.wheel_pos):
        wheel = m.pose(pos[0], pos[1], pos[2], axle)
        markers.append(
            _marker(j + 1, 3, wheel, (2 * r, 2 * r, 0.018), [], frame=frame, ns=ns, colour=(0.1, 0.1, 0.1, colour[3]))
        )
    return m.msg(m.TYPES["markers"])(markers=markers)


def obstacle_markers(world: World) -> Any:
    """``/obstacles``: each obstacle as a solid of :data:`OBSTACLE_HEIGHT` (a polygon as its outline),
    and the world's walls as a line."""
    hz, markers = 0.5 * OBSTACLE_HEIGHT, []
    for k, obs in enumerate(world.obstacles):
        if isinstance(obs, Polygon):
            pts = [m.point(x, y, OBSTACLE_HEIGHT) for x, y in [*obs.vertices, obs.vertices[0]]]
            markers.append(_marker(k, 4, m.pose(0, 0, 0, (0, 0, 0, 1)), (0.02, 0, 0), pts))
            continue
        if isinstance(obs, Circle):
            size, angle, kind = (2 * obs.radius, 2 * obs.radius), 0.0, 3
        elif isinstance(obs, Ellipse):
            size, angle, kind = (2 * obs.radii[0], 2 * obs.radii[1]), obs.angle, 3
        elif isinstance(obs, Box):
            size, angle, kind = (obs.size[0], obs.size[1]), obs.angle, 1
        else:
            continue
        p = m.pose(obs.center[0], obs.center[1], hz, m.yaw_quat(angle))
        markers.append(_marker(k, kind, p, (size[0], size[1], OBSTACLE_HEIGHT), []))
    xmin, xmax, ymin, ymax = world.bounds
    walls = [m.point(x, y) for x, y in ((xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax), (xmin, ymin))]
    markers.append(_marker(len(world.obstacles), 4, m.pose(0, 0, 0, (0, 0, 0, 1)), (0.02, 0, 0), walls))
    return m.msg(m.TYPES["markers"])(markers=markers)
