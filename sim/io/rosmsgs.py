"""ROS 2 messages (Humble) built from arrays, with the typestore of ``rosbags``.

Every builder returns a message object of the typestore's classes; :func:`serialize` turns it into
CDR bytes. Times are simulated seconds, written as ``builtin_interfaces/Time``; planar poses
``[x, y, theta]`` become a position with ``z = 0`` and a yaw quaternion.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import cache, lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
#: Three numbers: a tuple or a (3,) array.
Vec3 = Sequence[float] | FloatArray

#: Message types by short name.
TYPES = {
    "clock": "rosgraph_msgs/msg/Clock",
    "tf": "tf2_msgs/msg/TFMessage",
    "odometry": "nav_msgs/msg/Odometry",
    "path": "nav_msgs/msg/Path",
    "grid": "nav_msgs/msg/OccupancyGrid",
    "joints": "sensor_msgs/msg/JointState",
    "imu": "sensor_msgs/msg/Imu",
    "scan": "sensor_msgs/msg/LaserScan",
    "twist": "geometry_msgs/msg/TwistStamped",
    "fix": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "markers": "visualization_msgs/msg/MarkerArray",
    "vector": "geometry_msgs/msg/Vector3Stamped",
}


@cache
def typestore() -> Any:
    """The ROS 2 Humble typestore of ``rosbags`` (built once)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


@cache
def msg(name: str) -> Any:
    """The message class of a full type name, e.g. ``"geometry_msgs/msg/Pose"``."""
    return typestore().types[name]


def serialize(message: Any) -> bytes:
    """CDR bytes of a message (little-endian, as ROS 2 writes them)."""
    return bytes(typestore().serialize_cdr(message, message.__msgtype__))


def _field(message: Any, path: str) -> tuple[Any, str]:
    """The object holding a dotted field ``path`` of ``message`` (``"transforms.0.header.stamp"``,
    ``"pose.covariance.35"``) and the last key."""
    *head, last = path.split(".")
    obj = message
    for key in head:
        obj = obj[int(key)] if key.isdigit() else getattr(obj, key)
    return obj, last


def _assign(message: Any, path: str, value: Any) -> None:
    """Set a dotted field of ``message`` to ``value``."""
    obj, last = _field(message, path)
    if last.isdigit():
        obj[int(last)] = value
    else:
        setattr(obj, last, value)


def _is_time(message: Any, path: str) -> bool:
    """Whether a dotted field of ``message`` is a ``builtin_interfaces/Time`` (else a float).

    Raises:
        NhsimError: The field is neither.
    """
    from planning.errors import NhsimError

    obj, last = _field(message, path)
    value = obj[int(last)] if last.isdigit() else getattr(obj, last)
    if hasattr(value, "nanosec"):
        return True
    if not isinstance(value, float | np.floating):
        raise NhsimError(f"{message.__msgtype__}.{path} is not a float64 or time field: it cannot vary by rows")
    return False


#: Marks put into the fields of a template to find where its serialisation holds them.
_FLOAT_MARK = 0.1234567890123457
_TIME_MARK = (0x5EC0_0000, 0x3B9A_0000)


def _marked(template: Any, fields: Sequence[str]) -> tuple[bytes, list[tuple[bytes, bool]]]:
    """The template's CDR bytes with a distinct mark in each field, and each field's mark (8 bytes) and
    whether the field is a time."""
    marks = []
    for j, path in enumerate(fields):
        if _is_time(template, path):
            sec, nsec = _TIME_MARK[0] + j, _TIME_MARK[1] + j
            _assign(template, path, msg("builtin_interfaces/msg/Time")(sec=sec, nanosec=nsec))
            marks.append((np.array([sec, nsec], dtype="<u4").tobytes(), True))
            continue
        value = _FLOAT_MARK + j * 2.0**-30
        _assign(template, path, value)
        marks.append((np.float64(value).astype("<f8").tobytes(), False))
    return serialize(template), marks


def serialize_rows(template: Any, columns: dict[str, FloatArray]) -> NDArray[np.uint8]:
    """CDR bytes of K messages that differ from ``template`` only in fixed-size numeric fields, at once.

    ``rosbags`` serialises the template once, with a distinct mark in each field of ``columns``; each
    mark's place in the bytes is where that field lies in every message of the same fixed layout (the
    template's strings and sequence lengths are those of all K), and the K values are written there
    as columns. The result equals ``serialize`` of each message filled field by field (tests check
    it), at a small fraction of the cost for the topics of thousands of messages.

    Args:
        template: A message; its fields named in ``columns`` are overwritten (it serves as scratch).
        columns: Dotted field path -> (K,) values: times [s] for the ``builtin_interfaces/Time`` fields,
            floats for the ``float64`` fields.

    Returns:
        (K, L) bytes, row k message k.

    Raises:
        NhsimError: A field's place is not unique (not a fixed-size float64 or time field).
    """
    from planning.errors import NhsimError

    fields = list(columns)
    base, marks = _marked(template, fields)
    k = len(next(iter(columns.values()))) if fields else 0
    rows = np.tile(np.frombuffer(base, dtype=np.uint8), (k, 1))
    for path, (mark, is_time) in zip(fields, marks, strict=True):
        at = base.find(mark)
        if at < 0 or base.find(mark, at + 1) >= 0:
            raise NhsimError(f"{template.__msgtype__}.{path} has no single place in its serialisation")
        values = np.asarray(columns[path], dtype=float)
        if is_time:
            ns = np.round(values * 1e9).astype(np.int64)
            pair = np.column_stack([ns // 1_000_000_000, ns % 1_000_000_000])
            cell = pair.astype("<i4").view(np.uint8)
        else:
            cell = values.astype("<f8").view(np.uint8)
        rows[:, at : at + 8] = cell.reshape(k, 8)
    return rows


def stamp(t: float) -> Any:
    """``builtin_interfaces/Time`` of ``t`` seconds (t >= 0)."""
    return _stamp(round(float(t) * 1e9))


@lru_cache(maxsize=4096)
def _stamp(ns: int) -> Any:
    """One shared (read-only) message per time: every topic of a sample stamps it."""
    return msg("builtin_interfaces/msg/Time")(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header(t: float, frame: str) -> Any:
    """``std_msgs/Header`` stamped ``t`` [s] in ``frame``."""
    return msg("std_msgs/msg/Header")(stamp=stamp(t), frame_id=frame)


def yaw_quat(theta: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``theta`` [rad] about z."""
    return (0.0, 0.0, math.sin(0.5 * theta), math.cos(0.5 * theta))


def quaternion(q: tuple[float, float, float, float]) -> Any:
    """``geometry_msgs/Quaternion`` of (x, y, z, w)."""
    return msg("geometry_msgs/msg/Quaternion")(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))


def vector(x: float, y: float, z: float) -> Any:
    """``geometry_msgs/Vector3``."""
    return msg("geometry_msgs/msg/Vector3")(x=float(x), y=float(y), z=float(z))


def vector_stamped(t: float, frame: str, x: float, y: float, z: float) -> Any:
    """``geometry_msgs/Vector3Stamped``."""
    return msg(TYPES["vector"])(header=header(t, frame), vector=vector(x, y, z))


def point(x: float, y: float, z: float = 0.0) -> Any:
    """``geometry_msgs/Point``."""
    return msg("geometry_msgs/msg/Point")(x=float(x), y=float(y), z=float(z))


def pose(x: float, y: float, z: float, q: tuple[float, float, float, float]) -> Any:
    """``geometry_msgs/Pose`` at (x, y, z) [m] with orientation ``q`` (x, y, z, w)."""
    return msg("geometry_msgs/msg/Pose")(position=point(x, y, z), orientation=quaternion(q))


def set_quaternion(q_msg: Any, q: tuple[float, float, float, float]) -> None:
    """Fill a ``geometry_msgs/Quaternion`` in place with (x, y, z, w)."""
    q_msg.x, q_msg.y, q_msg.z, q_msg.w = float(q[0]), float(q[1]), float(q[2]), float(q[3])


def set_vector(v_msg: Any, x: float, y: float, z: float) -> None:
    """Fill a ``geometry_msgs/Vector3`` or ``Point`` in place."""
    v_msg.x, v_msg.y, v_msg.z = float(x), float(y), float(z)


def set_planar_pose(pose_msg: Any, p: FloatArray) -> None:
    """Fill a ``geometry_msgs/Pose`` in place with a planar pose ``[x, y, theta]``."""
    set_vector(pose_msg.position, p[0], p[1], 0.0)
    set_quaternion(pose_msg.orientation, yaw_quat(float(p[2])))


def set_transform(tf_msg: Any, t: float, xyz: Vec3, q: tuple[float, float, float, float]) -> None:
    """Fill a ``geometry_msgs/TransformStamped`` in place: stamp ``t`` [s], translation, rotation."""
    tf_msg.header.stamp = stamp(t)
    set_vector(tf_msg.transform.translation, *xyz)
    set_quaternion(tf_msg.transform.rotation, q)


def planar_pose(p: FloatArray) -> Any:
    """``geometry_msgs/Pose`` of a planar pose ``[x, y, theta]``."""
    return pose(p[0], p[1], 0.0, yaw_quat(float(p[2])))


def transform(t: float, parent: str, child: str, xyz: Vec3, q: tuple[float, float, float, float]) -> Any:
    """``geometry_msgs/TransformStamped`` of ``child`` in ``parent`` at ``t`` [s]."""
    tf = msg("geometry_msgs/msg/Transform")(translation=vector(*xyz), rotation=quaternion(q))
    return msg("geometry_msgs/msg/TransformStamped")(header=header(t, parent), child_frame_id=child, transform=tf)


def tf_message(transforms: list[Any]) -> Any:
    """``tf2_msgs/TFMessage`` of transforms."""
    return msg(TYPES["tf"])(transforms=transforms)


def twist(v: float, omega: float, vy: float = 0.0) -> Any:
    """``geometry_msgs/Twist`` of a planar body velocity: forward ``v`` [m/s], yaw rate ``omega`` [rad/s],
    lateral ``vy`` [m/s]."""
    return msg("geometry_msgs/msg/Twist")(linear=vector(v, vy, 0.0), angular=vector(0.0, 0.0, omega))


def planar_covariance(var: FloatArray) -> FloatArray:
    """(36,) row-major 6x6 covariance of a planar pose, given as the variances of x, y [m^2] and yaw
    [rad^2] (3,) or as their whole covariance (3, 3); z, roll and pitch (which a planar robot does not
    have) get a large variance, as ROS drivers write."""
    cov = np.zeros((6, 6))
    axes = np.array([0, 1, 5])
    v = np.asarray(var, dtype=float)
    cov[np.ix_(axes, axes)] = v if v.shape == (3, 3) else np.diag(v)
    cov[[2, 3, 4], [2, 3, 4]] = 1e6
    return cov.ravel()


def odometry(
    t: float,
    frame: str,
    child: str,
    p: FloatArray,
    var: FloatArray,
    v: float,
    omega: float,
    vy: float = 0.0,
    twist_var: FloatArray | None = None,
) -> Any:
    """``nav_msgs/Odometry``: planar pose ``p`` with variances ``var`` (3,), body velocity (v, omega, and
    lateral vy) with the covariance ``twist_var`` of (v, vy, omega) ((3,) variances or (3, 3), laid out as
    :func:`planar_covariance`; None: all zero, the velocity exact)."""
    cls = msg(TYPES["odometry"])
    pwc = msg("geometry_msgs/msg/PoseWithCovariance")(pose=planar_pose(p), covariance=planar_covariance(var))
    tcov = np.zeros(36) if twist_var is None else planar_covariance(twist_var)
    twc = msg("geometry_msgs/msg/TwistWithCovariance")(twist=twist(v, omega, vy), covariance=tcov)
    return cls(header=header(t, frame), child_frame_id=child, pose=pwc, twist=twc)


def pose_fix(t: float, frame: str, p: FloatArray, var: FloatArray) -> Any:
    """``geometry_msgs/PoseWithCovarianceStamped`` of a planar pose with variances (3,) or a covariance (3, 3)."""
    pwc = msg("geometry_msgs/msg/PoseWithCovariance")(pose=planar_pose(p), covariance=planar_covariance(var))
    return msg(TYPES["fix"])(header=header(t, frame), pose=pwc)


def twist_stamped(t: float, frame: str, v: float, omega: float) -> Any:
    """``geometry_msgs/TwistStamped`` of a body command [m/s, rad/s]."""
    return msg(TYPES["twist"])(header=header(t, frame), twist=twist(v, omega))


def joint_state(t: float, names: list[str], position: FloatArray, velocity: FloatArray) -> Any:
    """``sensor_msgs/JointState`` (positions [rad], velocities [rad/s], no efforts)."""
    return msg(TYPES["joints"])(
        header=header(t, ""),
        name=names,
        position=np.array(position, dtype=float),
        velocity=np.array(velocity, dtype=float),
        effort=np.zeros(0),
    )


def imu(t: float, frame: str, q: tuple[float, float, float, float], gyro: Vec3, accel: Vec3) -> Any:
    """``sensor_msgs/Imu``: orientation, angular velocity [rad/s], linear acceleration [m/s^2] (covariances
    zero: not given)."""
    return msg(TYPES["imu"])(
        header=header(t, frame),
        orientation=quaternion(q),
        orientation_covariance=np.zeros(9),
        angular_velocity=vector(*gyro),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=vector(*accel),
        linear_acceleration_covariance=np.zeros(9),
    )


def path(t: float, frame: str, poses: FloatArray, times: FloatArray | None = None) -> Any:
    """``nav_msgs/Path`` of planar poses (M, 3), each stamped ``times`` (M,) [s] (None: all ``t``)."""
    ps = msg("geometry_msgs/msg/PoseStamped")
    stamps = np.full(poses.shape[0], t) if times is None else times
    items = [ps(header=header(float(s), frame), pose=planar_pose(p)) for s, p in zip(stamps, poses, strict=True)]
    return msg(TYPES["path"])(header=header(t, frame), poses=items)


def laser_scan(t: float, frame: str, scan: Any, ranges: FloatArray) -> Any:
    """``sensor_msgs/LaserScan`` of one sweep: the geometry from ``scan`` (``angle_min``, ``angle_max``,
    ``angle_increment`` [rad], ``range_min``, ``range_max`` [m], ``scan_time``, ``time_increment`` [s]),
    ``ranges`` (B,) [m] (REP 117: -inf too close, +inf no return)."""
    return msg(TYPES["scan"])(
        header=header(t, frame),
        angle_min=float(scan.angle_min),
        angle_max=float(scan.angle_max),
        angle_increment=float(scan.angle_increment),
        time_increment=float(scan.time_increment),
        scan_time=float(scan.scan_time),
        range_min=float(scan.range_min),
        range_max=float(scan.range_max),
        ranges=np.array(ranges, dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )
