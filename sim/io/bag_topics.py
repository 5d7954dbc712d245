"""What a job's ROS 2 bag holds: its topics, each a list of (time, message), built from the run logs.

Frames (REP 105), one tree per run under the run's name (``closed_loop/odom``, ...) beside the shared
``map``, every run's transforms on ``/tf`` (:func:`joined`)::

    map -> RUN/odom -> RUN/base_footprint -> RUN/base_link -> RUN/wheel_left_link, RUN/wheel_right_link
                                                          \\-> RUN/imu_link, RUN/base_scan (static)
    map -> RUN/ground_truth/base_footprint -> RUN/ground_truth/base_link

``RUN/odom -> RUN/base_footprint`` is the robot's wheel odometry (its encoders' counts integrated,
continuous); ``map -> RUN/odom`` is the run's belief composed with the odometry's inverse, so that
``map -> RUN/base_footprint`` is what the run believed (the fused estimate, dead reckoning, or the
truth for a run fed the true pose; the open loop believes nothing: ``map -> odom`` the identity).
``RUN/ground_truth/base_footprint`` is the true pose, where the run's robot marker is drawn. Every
message is stamped at the time its data was taken: an estimate, a fix or a scan at the time of the
sensor readings it is based on (one physics step before the control instant: :func:`sensed_at`), and
``ground_truth/odom`` has the true pose at those times besides the logged samples, so that an
estimate's error against the truth at its stamp is the run record's. ``base_footprint -> base_link``
is the body's height, pitch and roll from the physics (a balancing robot leans); the wheel links are
the TurtleBot3 URDF's (rolled by -1.57 rad about x) turned by their joint angles about their z.

Per run (namespace ``/RUN``): ``odom`` (what the run believed, with its covariance), ``ground_truth/odom``,
``joint_states``, ``imu`` (what the robot's gyro and accelerometer read, their noise included, with the
sensor profile's covariances), ``cmd_vel``, ``fix`` (the localisation fixes, when the run's sensors give them)
and ``scan`` (when the run log carries one). Once per job: ``/clock``, ``/tf``, ``/tf_static``, ``/plan``,
``/reference``, ``/map`` (the map's obstacles and the walls) and ``/obstacles`` (the map's and, apart, the
unmapped ones), the last four and ``/tf_static`` latched.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planning.core.geometry import compose_poses, invert_poses
from planning.core.world import Box, Circle, Ellipse, Polygon, World
from sim.io import rosmsgs as m

FloatArray = NDArray[np.float64]

#: Edge of a map cell [m] (coarser for large worlds: at most MAP_MAX_CELLS cells): the scan localiser's own grid
#: (``AmclConfig.map_resolution``), the physics' walls (0.05 m) two cells thick, and with cell edges on the world's
#: bounds (:func:`map_layout`) every face on the 5 cm lattice of the bounds lies on a cell edge (at 0.02 m every
#: wall face ran through the middle of a cell, and a face at an odd centimetre still would).
MAP_RESOLUTION = 0.025
MAP_MAX_CELLS = 1_000_000
#: Height of a robot's body marker [m].
ROBOT_HEIGHT = 0.12
GRAVITY = 9.80665
WHEELS = ("wheel_left", "wheel_right")
#: A wheel link's fixed roll in base_link, (w, x, y, z): the TurtleBot3 URDF's ``wheel_*_joint`` roll their frames by
#: ``rpy="-1.57 0 0"`` and turn the wheels about the rolled frames' z (base_link's y, to 0.8 mrad), so that ROBOTIS's
#: wheel meshes stand upright.
WHEEL_ROLL = np.array([np.cos(-0.785), np.sin(-0.785), 0.0, 0.0])
#: The model's site of the IMU (``RUN/imu_link``).
IMU_SITE = "imu"
#: The model's site of ROS's ``base_link`` (``RUN/base_link``; the base body's origin in a model without one).
LINK_SITE = "base_link"


@dataclass
class Topic:
    """One topic of the bag.

    A topic of thousands of messages (one per logged sample) is given as ``rows``: a template message
    and the columns of its fields that vary, serialised all at once
    (:func:`sim.io.rosmsgs.serialize_rows`), or several such parts one after the other (messages of
    different layouts on one topic: each run's transforms on ``/tf``, their frame names of different
    lengths); a topic of a few messages (fixes, scans, the latched ones) as ``make``, its messages one
    at a time.

    Attributes:
        name: Topic name (absolute).
        msgtype: Full message type, e.g. ``nav_msgs/msg/Odometry``.
        times: (K,) the messages' times [s], non-decreasing within each part of ``rows``.
        make: Message k of the topic, stamped ``times[k]`` (None when ``rows`` is given).
        latched: Offered with transient-local durability (a late subscriber gets the last message).
        rows: (template, field path -> values), or a list of them whose messages follow one another
            (None when ``make`` is given).
        joins: The job-wide topic this run's messages belong on (``/tf``), gathered there by
            :func:`joined`; None for a topic of its own.
    """

    name: str
    msgtype: str
    times: FloatArray
    make: Callable[[int], Any] | None = None
    latched: bool = False
    rows: Rows | list[Rows] | None = None
    joins: str | None = None

    def serialized(self, which: NDArray[np.int64] | None = None) -> list[bytes | memoryview]:
        """Messages ``which`` (ascending indices into :attr:`times`; None: all) as CDR bytes, in that order: a
        bag is written a stretch of time at a time (:func:`sim.io.bag._write`), never holding every message."""
        if which is None:
            which = np.arange(self.times.size)
        if self.rows is None:
            assert self.make is not None
            return [m.serialize(self.make(int(k))) for k in which]
        out: list[bytes | memoryview] = []
        start = 0
        for template, columns in self.rows if isinstance(self.rows, list) else [self.rows]:
            size = len(next(iter(columns.values()))) if columns else 0
            lo, hi = np.searchsorted(which, [start, start + size])
            if hi > lo:
                local = which[lo:hi] - start
                data = m.serialize_rows(template, {path: np.asarray(v)[local] for path, v in columns.items()})
                flat, width = memoryview(data.tobytes()), data.shape[1]
                out += [flat[k * width : (k + 1) * width] for k in range(data.shape[0])]
            start += size
        return out


def joined(topics: list[Topic]) -> list[Topic]:
    """The topics with the runs' parts of a job-wide topic (:attr:`Topic.joins`: each run's transforms)
    gathered into one topic of that name, in the place of the first part, their messages one run after
    the other (the writer orders them by time)."""
    parts: dict[str, list[Topic]] = {}
    for tp in topics:
        if tp.joins is not None:
            parts.setdefault(tp.joins, []).append(tp)
    out: list[Topic] = []
    for tp in topics:
        if tp.joins is None:
            out.append(tp)
        elif parts[tp.joins][0] is tp:
            group = parts[tp.joins]
            rows: list[Rows] = []
            for g in group:
                assert g.rows is not None and g.msgtype == tp.msgtype
                rows += g.rows if isinstance(g.rows, list) else [g.rows]
            times = np.concatenate([g.times for g in group])
            out.append(Topic(tp.joins, tp.msgtype, times, latched=tp.latched, rows=rows))
    return out


@dataclass(frozen=True)
class Skeleton:
    """The robot's joints and fixed frames from its MJCF file.

    Attributes:
        root: qpos address of the free joint (position then w, x, y, z quaternion).
        wheels: qpos addresses of the left and right wheel joints.
        wheel_pos: (2, 3) wheel axle centres in ``base_link`` [m].
        scan_pos: (3,) the lidar in ``base_link`` [m], or None.
        imu_pos: (3,) the IMU (site :data:`IMU_SITE`) in ``base_link`` [m].
        imu_quat: The IMU's orientation in ``base_link``, ROS (x, y, z, w).
        link: (3,) ``base_link``'s origin in the base body [m]: the model's site :data:`LINK_SITE` (the
            TurtleBot3's URDF puts it 0.010 m above the floor, 0.023 m below the axle), the base body's
            origin in a model without one.
    """

    root: int
    wheels: tuple[int, int]
    wheel_pos: FloatArray
    scan_pos: FloatArray | None
    imu_pos: FloatArray
    imu_quat: tuple[float, float, float, float]
    link: FloatArray


@cache
def skeleton(robot: str) -> Skeleton:
    """The joints and fixed frames of a robot's model (loaded once per robot): the wheels, the lidar body
    ``base_scan`` and the IMU (site :data:`IMU_SITE`; at ``base_link`` in a model without one), each placed
    in ``base_link`` (:attr:`Skeleton.link`) by the compiled model's kinematics at its reference pose."""
    import mujoco

    from planning.core.robot import robot_path

    model = mujoco.MjModel.from_xml_path(str(robot_path(robot)))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    adr = model.jnt_qposadr
    root = model.joint("root")
    base = int(model.jnt_bodyid[root.id])

    turn = data.xmat[base].reshape(3, 3).T
    link = np.zeros(3)
    if (s := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, LINK_SITE)) >= 0:
        link = turn @ (data.site_xpos[s] - data.xpos[base])

    def in_link(xpos: FloatArray, xmat: FloatArray) -> tuple[FloatArray, tuple[float, float, float, float]]:
        wxyz = np.zeros(4)
        mujoco.mju_mat2Quat(wxyz, (turn @ xmat.reshape(3, 3)).ravel())
        return turn @ (xpos - data.xpos[base]) - link, ros_quat(wxyz)

    wheels = tuple(int(adr[model.joint(f"{w}_joint").id]) for w in WHEELS)
    wheel_pos = np.array([in_link(data.xpos[b], data.xmat[b])[0] for b in (model.body(w).id for w in WHEELS)])
    scan, imu_pos, imu_quat = None, -link, (0.0, 0.0, 0.0, 1.0)
    if (b := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "base_scan")) >= 0:
        scan = in_link(data.xpos[b], data.xmat[b])[0]
    if (site := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, IMU_SITE)) >= 0:
        imu_pos, imu_quat = in_link(data.site_xpos[site], data.site_xmat[site])
    return Skeleton(int(adr[root.id]), (wheels[0], wheels[1]), wheel_pos, scan, imu_pos, imu_quat, link)


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


def planar_velocity(t: FloatArray, pose: FloatArray) -> FloatArray:
    """(N, 3) the body-frame velocity (forward [m/s], leftward [m/s], yaw rate [rad/s]) of a pose series:
    the positions and the heading differentiated in time (second order, uneven spacing allowed, the ends too: a
    robot starting from rest reads 0 at its first sample, where a first-order end read the first interval's mean)
    and the velocity turned into the body frame by the heading then. The leftward part is the body's sideways
    slip (a tyre carries a side force only by slipping: outwards in a turn)."""
    if t.size < 2:
        return np.zeros((t.size, 3))
    if t.size > 2:
        dx, dy, dth = (np.gradient(pose[:, k], t, edge_order=2) for k in range(3))
    else:
        dx, dy, dth = (np.gradient(pose[:, k], t) for k in range(3))
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, dth])


def sensed_at(log: Any, t: FloatArray) -> FloatArray:
    """The physics time [s] of the state the run's sensors read at sensing time ``t`` (K,) [s]: the control
    instants at which the estimator reads them (and the fixes' and the scans' times, which count on the
    same clock). MuJoCo evaluates the sensors at the start of a physics step, so what they give at a
    control instant after the first is the state one physics step (``timestep_s``) earlier
    (:meth:`sim.physics.simulator.Recorder.to_log`); at the first instant they read the start pose, at
    it. Between the two instants the clock is stretched linearly (a scan's beams there are cast from
    poses interpolated between those two readings); before the start it is the physics clock."""
    t = np.asarray(t, dtype=float)
    t0, lag = float(log.t[0]), float(log.meta.get("timestep_s", 0.0))
    period = 1.0 / float(log.meta.get("control_rate_hz", 50.0))
    first = t0 + (t - t0) * (period - lag) / period
    return np.where(t >= t0 + period, t - lag, np.where(t <= t0, t, first))


def estimate_at(log: Any, t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """What the run's estimator believed at physics times ``t``: (poses (N, 3), variances (N, 3)), its
    estimates placed at the times of the readings they are based on (:func:`sensed_at`) and interpolated
    between them; the true pose with zero variance for a run fed the truth."""
    est = log.estimation
    if est is None or est.t.size == 0:
        return log.pose.copy(), np.zeros((t.size, 3))
    e = est.estimate.copy()
    e[:, 2] = np.unwrap(e[:, 2])
    at = sensed_at(log, est.t)
    pose = np.column_stack([np.interp(t, at, e[:, k]) for k in range(3)])
    var = np.column_stack([np.interp(t, at, est.variance[:, k]) for k in range(3)])
    return pose, var


def true_poses(log: Any) -> tuple[FloatArray, FloatArray]:
    """(t (N,), poses (N, 3)): the run's true pose at every logged sample and at every instant its sensors
    were read for the estimator (:func:`sensed_at`; the estimator's record of the truth, ``truth``),
    in time order, headings unwrapped. Each estimate of ``RUN/odom`` has the truth of its stamp here."""
    est = log.estimation
    if est is None or est.t.size == 0:
        return log.t, log.pose
    at = sensed_at(log, est.t)
    logged = np.round(log.t * 1e9)
    extra = ~np.isin(np.round(at * 1e9), logged) & np.all(np.isfinite(est.truth), axis=1)
    t = np.concatenate([log.t, at[extra]])
    pose = np.vstack([log.pose, est.truth[extra]])
    order = np.argsort(t, kind="stable")
    t, pose = t[order], pose[order]
    pose[:, 2] = np.unwrap(pose[:, 2])
    return t, pose


def run_frames(ns: str) -> dict[str, str]:
    """The run's frame names (REP 105, prefixed by the run), and its true pose's (``ground_truth/...``)."""
    names = (
        "odom", "base_footprint", "base_link", "wheel_left_link", "wheel_right_link", "imu_link", "base_scan",
        "ground_truth/base_footprint", "ground_truth/base_link",
    )  # fmt: skip
    return {n: f"{ns}/{n}" for n in names}


def is_open_loop(log: Any) -> bool:
    """Whether the run drove without feedback (no estimator, no belief of where it is)."""
    return log.estimation is None and log.meta.get("tracker") == "open-loop"


def encoder_counts(log: Any, sk: Skeleton, sensors: Any) -> tuple[FloatArray, float]:
    """(N, 2) each wheel's encoder count at the logged samples (its joint angle counted as
    :func:`sim.physics.sensors.encoder_count` does, with the run's own encoder phases), and the counts per
    radian."""
    per_rad = float(sensors.profile.encoder_cpr) / (2.0 * math.pi)
    return np.floor(log.qpos[:, list(sk.wheels)] * per_rad + np.asarray(sensors.encoder_phase)), per_rad


def encoder_turns(log: Any, sk: Skeleton, sensors: Any) -> FloatArray:
    """(N, 2) each wheel's turn since the start [rad] at the logged samples, as the run's encoders counted
    it: the logged joint angle quantised as :func:`sim.physics.sensors.encoder_count` does, with the run's
    own encoder phases (``sensors``: its :class:`sim.physics.sensors.SensorModel`). A balancing robot's
    wheels turn against the floor by that plus the body's pitch change (its balance firmware's pitch
    estimate), as the robot's own odometry adds it (:class:`sim.robot.sensing.EstimatorLoop`)."""
    counts, per_rad = encoder_counts(log, sk, sensors)
    turns = (counts - counts[0]) / per_rad
    bal = log.balance
    if bal is not None and bal.t.size:
        pitch = np.interp(log.t, bal.t, bal.pitch_estimate)
        turns += (pitch - pitch[0])[:, None]
    return turns


def wheel_odometry(
    t: FloatArray, turns: FloatArray, start: FloatArray, radius: float, track: float, config: Any
) -> tuple[FloatArray, FloatArray]:
    """(N, 3) wheel odometry, the poses reached from ``start`` (3,) by the wheel turns ``turns`` (N, 2) [rad]
    at times ``t`` (N,) [s] (exact arcs of a differential drive of wheel ``radius`` and ``track`` [m],
    headings unwrapped), and (N, 3) its variances [m^2, m^2, rad^2] as dead reckoning grows them: the run's
    estimator (:class:`control.estimation.PoseEstimator`, its noise model ``config``: encoder quantisation,
    wheel slip, lateral scrub, the build tolerances of the radii and the track) predicting with the same
    wheel turns, its heading from the encoders, without fixes."""
    from dataclasses import replace

    from control.estimation.ekf import PoseEstimator

    est = PoseEstimator(replace(config, heading="encoders"), radius, track)
    n = t.size
    clock = t[0] + np.concatenate([[0.0], np.cumsum(np.maximum(np.diff(t), 1e-9))])  # increasing
    pose, var = np.zeros((n, 3)), np.zeros((n, 3))
    est.reset(float(clock[0]), start)
    est.record(pose, var, 0)
    d = np.diff(turns, axis=0)
    for k in range(1, n):
        est.predict(float(clock[k]), float(d[k - 1, 0]), float(d[k - 1, 1]))
        est.record(pose, var, k)
    pose[:, 2] = np.unwrap(pose[:, 2])
    return pose, var


def twist_variance(wheels: FloatArray, radius: float, track: float, period: float, config: Any) -> FloatArray:
    """(K, 3, 3) the covariance of (v, vy, omega) [m/s, m/s, rad/s] of a twist from the wheel speeds
    ``wheels`` (K, 2) [rad/s], as a robot differencing its encoders over a control ``period`` [s] knows it:
    per wheel the quantisation of two counts (``q^2 / 6`` over the period squared, q = 2 pi / counts per
    revolution) and the slip's ``wheel_noise^2 |dphi|``, both radii's build tolerance, the track's; the
    lateral speed, which the wheels do not measure, the lateral scrub's ``position_noise^2 |ds|`` (the
    estimator's noise model ``config``, :class:`control.estimation.EstimatorConfig`)."""
    q = 2.0 * math.pi / float(config.counts_per_rev)
    spin = q * q / 6.0 / period**2 + config.wheel_noise**2 * np.abs(wheels) / period  # (K, 2) [rad^2/s^2]
    rel2 = config.wheel_radius_rel_std**2 * wheels**2
    r, b = radius, track
    v = 0.5 * r * (wheels[:, 0] + wheels[:, 1])
    omega = r * (wheels[:, 1] - wheels[:, 0]) / b
    cov = np.zeros((wheels.shape[0], 3, 3))
    cov[:, 0, 0] = 0.25 * r * r * (spin.sum(axis=1) + rel2.sum(axis=1))
    cov[:, 1, 1] = config.position_noise**2 * np.abs(v) / period
    cov[:, 2, 2] = (r / b) ** 2 * (spin.sum(axis=1) + rel2.sum(axis=1)) + (omega * config.track_width_std / b) ** 2
    cov[:, 0, 2] = cov[:, 2, 0] = 0.5 * r * r / b * (spin[:, 1] - spin[:, 0] + rel2[:, 1] - rel2[:, 0])
    return cov


#: A topic's messages as a template and the columns of its varying fields (see :class:`Topic`).
Rows = tuple[Any, dict[str, FloatArray]]
#: A topic's times (K,) and its messages: ``make`` (message k) or :data:`Rows`.
Series = tuple[FloatArray, Callable[[int], Any] | Rows]


def yaw_quats(theta: FloatArray) -> FloatArray:
    """(N, 4) quaternions (x, y, z, w) of rotations by ``theta`` (N,) [rad] about z."""
    zero = np.zeros_like(theta)
    return np.column_stack([zero, zero, np.sin(0.5 * theta), np.cos(0.5 * theta)])


def _pose_columns(prefix: str, xyz: FloatArray, q: FloatArray) -> dict[str, FloatArray]:
    """Columns of a pose or transform at ``prefix`` (``position``/``orientation`` or ``translation``/
    ``rotation`` by what the prefix holds): (K, 3) positions [m], (K, 4) quaternions (x, y, z, w)."""
    where, turn = ("translation", "rotation") if prefix.endswith("transform") else ("position", "orientation")
    cols = {f"{prefix}.{where}.{a}": xyz[:, j] for j, a in enumerate("xyz")}
    cols.update({f"{prefix}.{turn}.{a}": q[:, j] for j, a in enumerate("xyzw")})
    return cols


def _body_tilt(log: Any, sk: Skeleton) -> tuple[FloatArray, FloatArray]:
    """(lift (N, 3) [m], tilt (N, 4) quaternions (x, y, z, w)): ``base_link`` in its footprint frame, its
    height, pitch and roll from the physics (the base body's, ``base_link`` fixed to it at
    :attr:`Skeleton.link`)."""
    t, truth = log.t, log.pose
    q = log.qpos[:, sk.root + 3 : sk.root + 7]
    yaw_inv = np.column_stack([np.cos(0.5 * truth[:, 2]), np.zeros((t.size, 2)), -np.sin(0.5 * truth[:, 2])])
    wxyz = _quat_mul(yaw_inv, q)  # the body's pitch and roll, in the footprint frame
    rel = log.qpos[:, sk.root : sk.root + 2] - truth[:, :2]
    c, s = np.cos(truth[:, 2]), np.sin(truth[:, 2])
    lift = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1], log.qpos[:, sk.root + 2]])
    offset = np.zeros((t.size, 4))
    offset[:, 1:] = sk.link
    conj = wxyz * [1.0, -1.0, -1.0, -1.0]
    lift += _quat_mul(_quat_mul(wxyz, offset), conj)[:, 1:]  # base_link's origin, turned with the body
    return lift, wxyz[:, [1, 2, 3, 0]]


def belief_at(log: Any, t: FloatArray) -> FloatArray | None:
    """(N, 3) where the run believed it was at physics times ``t`` (the logged samples): its estimate
    (:func:`estimate_at`), the truth for a run fed the truth, None for the open loop (no belief)."""
    if is_open_loop(log) or no_belief(log):
        return None
    return estimate_at(log, t)[0]


def no_belief(log: Any) -> bool:
    """Whether the run had an estimator that never believed a pose (global localisation chose none at its start,
    :meth:`sim.robot.sensing.Sensing.to_log`)."""
    return log.estimation is not None and log.estimation.t.size == 0


def _tf_series(log: Any, sk: Skeleton, frames: dict[str, str], odo: FloatArray) -> Series:
    """The run's part of ``/tf``: per logged sample map -> odom -> base_footprint -> base_link -> wheels
    (``odom -> base_footprint`` the wheel odometry ``odo`` (N, 3), ``map -> odom`` the belief composed
    with its inverse: the identity for the open loop), and map -> ground_truth/base_footprint ->
    ground_truth/base_link (the true pose, and the body's height, pitch and roll)."""
    t, truth = log.t, log.pose
    belief = belief_at(log, t)
    map_odom = np.zeros((t.size, 3)) if belief is None else compose_poses(belief, invert_poses(odo))
    lift, tilt = _body_tilt(log, sk)
    half = 0.5 * log.qpos[:, list(sk.wheels)]
    zero, flat = np.zeros(t.size), np.zeros((t.size, 3))
    links = [
        ("map", "odom", np.column_stack([map_odom[:, :2], zero]), yaw_quats(map_odom[:, 2])),
        ("odom", "base_footprint", np.column_stack([odo[:, :2], zero]), yaw_quats(odo[:, 2])),
        ("base_footprint", "base_link", lift, tilt),
    ]
    for j, wheel in enumerate(("wheel_left_link", "wheel_right_link")):
        spin = np.column_stack([np.cos(half[:, j]), zero, zero, np.sin(half[:, j])])  # (w, x, y, z) about the z
        wxyz = _quat_mul(np.tile(WHEEL_ROLL, (t.size, 1)), spin)  # of the rolled frame, as robot_state_publisher
        links.append(("base_link", wheel, flat + sk.wheel_pos[j], wxyz[:, [1, 2, 3, 0]]))
    links += [
        ("map", "ground_truth/base_footprint", np.column_stack([truth[:, :2], zero]), yaw_quats(truth[:, 2])),
        ("ground_truth/base_footprint", "ground_truth/base_link", lift, tilt),
    ]
    fr = frames
    msg = m.tf_message([m.transform(0.0, fr.get(a, a), fr[b], (0.0, 0.0, 0.0), (0, 0, 0, 1)) for a, b, _, _ in links])
    cols: dict[str, FloatArray] = {}
    for i, (_, _, xyz, quat) in enumerate(links):
        cols[f"transforms.{i}.header.stamp"] = t
        cols.update(_pose_columns(f"transforms.{i}.transform", xyz, quat))
    return t, (msg, cols)


def _odometry(
    t: FloatArray,
    frame: str,
    child: str,
    pose: FloatArray,
    var: FloatArray,
    vel: FloatArray,
    twist_cov: FloatArray | None = None,
) -> Series:
    """``nav_msgs/Odometry`` at times ``t`` (K,): planar poses (K, 3), their variances (K, 3), the body
    velocity ``vel`` (K, 3) (forward, leftward, yaw rate) and its covariance (K, 3, 3) (None: zero)."""
    tv = None if twist_cov is None else twist_cov[0]
    msg = m.odometry(0.0, frame, child, pose[0], var[0], vel[0, 0], vel[0, 2], vel[0, 1], tv)
    cols = {"header.stamp": t}
    cols.update(_pose_columns("pose.pose", np.column_stack([pose[:, :2], np.zeros(t.size)]), yaw_quats(pose[:, 2])))
    cols.update({f"pose.covariance.{i}": var[:, j] for j, i in enumerate((0, 7, 35))})
    cols.update({"twist.twist.linear.x": vel[:, 0], "twist.twist.linear.y": vel[:, 1]})
    cols["twist.twist.angular.z"] = vel[:, 2]
    if twist_cov is not None:
        axes = (0, 1, 5)
        for a, b in ((0, 0), (1, 1), (2, 2), (0, 2), (2, 0)):
            cols[f"twist.covariance.{6 * axes[a] + axes[b]}"] = twist_cov[:, a, b]
    return t, (msg, cols)


@dataclass(frozen=True)
class Wheels:
    """A run's wheel odometry at its logged samples and its twist from the wheel speeds.

    Attributes:
        pose: (N, 3) wheel odometry from the start pose (:func:`wheel_odometry`).
        variance: (N, 3) its variances as dead reckoning grows them (:func:`wheel_odometry`).
        twist: The body velocity (K, 3) and its covariance (K, 3, 3) at times (K,) from the wheel speeds.
    """

    pose: FloatArray
    variance: FloatArray
    twist: Callable[[FloatArray], tuple[FloatArray, FloatArray]]


def _odom_series(log: Any, frames: dict[str, str], wheels: Wheels) -> Series:
    """``RUN/odom``: what the run believed. With an estimator each estimate with its variances in ``map``,
    stamped at the time of the readings it is based on (:func:`sensed_at`); the open loop's wheel odometry
    in ``RUN/odom`` with the variances dead reckoning gives it; a run fed the truth the true pose in
    ``map``, exact. The twist from the wheel speeds, with the covariance a robot's encoders give it."""
    est = log.estimation
    if est is not None and est.t.size:
        t, pose, var, frame = sensed_at(log, est.t), est.estimate, est.variance, "map"
    elif no_belief(log):  # no message: it knew nothing (it was the truth, exact)
        return np.zeros(0), lambda k: None
    elif is_open_loop(log):
        t, pose, var, frame = log.t, wheels.pose, wheels.variance, frames["odom"]
    else:
        t, pose, var, frame = log.t, log.pose, np.zeros((log.t.size, 3)), "map"
    vel, cov = wheels.twist(t)
    return _odometry(t, frame, frames["base_footprint"], pose, var, vel, cov)


def _truth_series(log: Any, frames: dict[str, str]) -> Series:
    """``RUN/ground_truth/odom``: the true pose (:func:`true_poses`) in ``map`` and the body-frame velocity
    (:func:`planar_velocity`: the positions differentiated, the sideways slip included)."""
    t, pose = true_poses(log)
    vel = planar_velocity(t, pose)
    return _odometry(t, "map", frames["ground_truth/base_footprint"], pose, np.zeros((t.size, 3)), vel)


def _period_yaw_rates(log: Any, rate: float, n: int) -> FloatArray:
    """(n,) the true mean yaw rate over each control period ending at period k (0 at period 0) [rad/s]:
    the heading change over the period over its length, from the true headings the run's sensors read
    (the estimator's record, ``log.estimation.truth``), else the logged poses at the periods' instants."""
    t = log.t
    heading = np.interp(t[0] + np.arange(n) / rate, t, np.unwrap(log.pose[:, 2]))
    est = log.estimation
    if est is not None and est.t.size:
        j = np.round((est.t - t[0]) * rate).astype(np.int64)
        seen = np.unwrap(est.truth[:, 2])
        keep = (j >= 0) & (j < n) & np.isfinite(seen)
        heading[j[keep]] = seen[keep]
    return np.diff(heading, prepend=heading[0]) * rate


def run_sensors(log: Any, sensing: Any) -> Any:
    """The run's own sensor noise (:class:`sim.physics.sensors.SensorModel` of the run's noise seed: a
    compare draw's own), one control period per logged period."""
    from sim.physics.sensors import SensorModel

    rate = float(log.meta.get("control_rate_hz", 50.0))
    k = np.clip(np.round((log.t - log.t[0]) * rate).astype(np.int64), 0, None)
    return SensorModel(
        sensing.profile,
        control_rate=rate,
        timestep=float(log.meta.get("timestep_s", 1.0 / rate)),
        n_periods=int(k.max()) + 1,
        seed=int(log.meta.get("noise_seed", sensing.seed)),
    )


def _imu_series(log: Any, frames: dict[str, str], sensing: Any, sensors: Any) -> Series:
    """``RUN/imu``: what the robot's IMU measured at each logged sample, in period ``k``: the gyro (yaw)
    the true mean yaw rate over the period plus its bias and white noise, the accelerometer the planar
    specific force (acceleration along and across the heading, gravity up) plus its bias and white
    noise, from the run's own noise draws (``sensors``: :func:`run_sensors`).
    Covariances from the sensor profile: the gyro's z variance is its white noise's plus its bias's,
    which walks (``gyro_bias_std^2 + gyro_bias_walk^2 t``); x and y, which a yaw gyro does not measure,
    a large variance; the accelerometer's per axis its white noise's plus its bias's. The orientation is
    not measured (``orientation_covariance[0] = -1``, as ``sensor_msgs/Imu`` asks)."""
    t = log.t
    rate = float(log.meta.get("control_rate_hz", 50.0))
    k = np.clip(np.round((t - t[0]) * rate).astype(np.int64), 0, None)
    yaw_rate = _period_yaw_rates(log, rate, int(k.max()) + 1)[k]
    v, _, omega = planar_velocity(t, log.pose).T
    dv = np.gradient(v, t) if t.size > 1 else np.zeros(t.size)
    accel = np.column_stack([dv, v * omega, np.full(t.size, GRAVITY)]) + sensors.accel_bias + sensors.accel_white[k]
    p = sensing.profile
    gyro_var = sensors.gyro_white_std**2 + p.gyro_bias_std**2 + p.gyro_bias_walk**2 * (t - t[0])
    accel_var = sensors.accel_white_std**2 + p.accel_bias_std**2
    msg = m.imu(0.0, frames["imu_link"], (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, GRAVITY))
    msg.orientation_covariance[0] = -1.0
    msg.angular_velocity_covariance[[0, 4]] = 1e6
    msg.linear_acceleration_covariance[[0, 4, 8]] = accel_var
    cols = {"header.stamp": t, "angular_velocity.z": yaw_rate + sensors.gyro_error[k]}
    cols.update({f"linear_acceleration.{a}": accel[:, j] for j, a in enumerate("xyz")})
    cols["angular_velocity_covariance.8"] = gyro_var
    return t, (msg, cols)


def _error_series(log: Any, frame: str) -> Series:
    """``RUN/tracking_error``: x the distance from the reference pose at the same time [m], y the heading
    error [rad] (wrapped), z 0."""
    d = log.pose[:, :2] - log.ref_pose[:, :2]
    dist = np.hypot(d[:, 0], d[:, 1])
    head = np.remainder(log.pose[:, 2] - log.ref_pose[:, 2] + np.pi, 2 * np.pi) - np.pi
    msg = m.vector_stamped(0.0, frame, 0.0, 0.0, 0.0)
    return log.t, (msg, {"header.stamp": log.t, "vector.x": dist, "vector.y": head})


def _joints_series(log: Any, sk: Skeleton, sensors: Any) -> Series:
    """``RUN/joint_states``: the wheels' angles [rad] as their encoders read them (whole counts, as a robot's
    driver publishes them; the true angles turn the wheels in ``tf``) and their measured speeds [rad/s]."""
    t, speeds = log.t, log.wheel_speed
    counts, per_rad = encoder_counts(log, sk, sensors)
    angles = counts / per_rad
    msg = m.joint_state(0.0, ["wheel_left_joint", "wheel_right_joint"], angles[0], speeds[0])
    cols = {"header.stamp": t}
    for j in range(2):
        cols[f"position.{j}"], cols[f"velocity.{j}"] = angles[:, j], speeds[:, j]
    return t, (msg, cols)


def _command_series(log: Any, frame: str) -> Series:
    """``RUN/cmd_vel``: the body command (v [m/s], omega [rad/s]) in force."""
    msg = m.twist_stamped(0.0, frame, 0.0, 0.0)
    cols = {"header.stamp": log.t, "twist.linear.x": log.command[:, 0], "twist.angular.z": log.command[:, 1]}
    return log.t, (msg, cols)


def _fix_series(log: Any, std: tuple[float, float]) -> Series:
    """``RUN/fix``: the localisation fixes at their measurement times (:func:`sensed_at`): the scan localiser's
    every update with its own covariance (as Nav2's ``amcl_pose``; one the run ended before it arrived at the
    estimator too, as the record's localiser error counts it), else the synthetic fixes with the profile's
    variances. None for a dead-reckoning run: its fixes only score its estimate (NEES), it never localised."""
    est = log.estimation
    if est is None or est.source == "odometry":
        return np.zeros(0), lambda k: None
    loc = getattr(est, "localiser", None)
    if loc is not None and loc.t.size:
        at = sensed_at(log, loc.t)
        return at, lambda k: m.pose_fix(float(at[k]), "map", loc.pose[k], loc.cov[k])
    if est.fix_t.size == 0:
        return np.zeros(0), lambda k: None
    at = sensed_at(log, est.fix_t)
    var = np.array([std[0] ** 2, std[0] ** 2, std[1] ** 2])
    return at, lambda k: m.pose_fix(float(at[k]), "map", est.fix[k], var)


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
    """The run's lidar revolutions, or None: a ``log.scan`` with the fields of :class:`Sweeps` (``t``,
    ``ranges``, ``angle_min``, ...), else the scans the run's scan localiser took
    (``log.estimation.localiser``: ``scan_t``, ``scan_ranges``, ``scan_angle_increment`` from bearing 0,
    ``scan_time_increment``, ``range_min``, ``range_max``), cast from the poses its sensors read: their
    stamps on the physics clock (:func:`sensed_at`)."""
    scan = getattr(log, "scan", None)
    if scan is not None:
        return Sweeps(
            np.asarray(scan.t, dtype=float),
            np.asarray(scan.ranges, dtype=float),
            float(scan.angle_min),
            float(scan.angle_increment),
            float(getattr(scan, "time_increment", 0.0)),
            float(getattr(scan, "scan_time", 0.0)),
            float(scan.range_min),
            float(scan.range_max),
        )
    loc = getattr(log.estimation, "localiser", None) if log.estimation is not None else None
    if loc is not None and np.asarray(loc.scan_t).size:
        t = sensed_at(log, np.asarray(loc.scan_t, dtype=float))
        period = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        if loc.scan_time_increment > 0:  # a revolution's time, the same from one scan as from many
            period = float(loc.scan_time_increment * 2 * np.pi / loc.scan_angle_increment)
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
    return None


def _scan_series(log: Any, frames: dict[str, str]) -> Series:
    """``RUN/scan``: the lidar revolutions, each stamped at its first beam. A revolution begun before the
    run (the first, centred on period 0) keeps its beams from time 0 on, stamped at the first of them
    with ``angle_min`` its bearing: a bag's time starts at 0."""
    scan = scan_of(log)
    if scan is None:
        return np.zeros(0), lambda k: None
    fr = frames["base_scan"]
    skip = np.zeros(scan.t.size, dtype=int)
    if scan.time_increment > 0:
        late = np.ceil(-scan.t / scan.time_increment - 1e-6)
        skip = np.clip(late, 0, scan.ranges.shape[1] - 1).astype(int)
    stamps = np.maximum(scan.t + skip * scan.time_increment, 0.0)

    def make(k: int) -> Any:
        msg = m.laser_scan(float(stamps[k]), fr, scan, scan.ranges[k, skip[k] :])
        msg.angle_min += float(skip[k] * scan.angle_increment)
        return msg

    return stamps, make


def run_wheels(log: Any, robot: Any, sk: Skeleton, sensing: Any, sensors: Any) -> Wheels:
    """The run's wheel odometry (its encoders' turns integrated with the rolling radius the robot's own
    odometry multiplies them by, :func:`sim.physics.model.rolling_radius`, and the drawn track), from
    the start pose; its variances for the open loop; the twist from the wheel speeds."""
    from sim.physics.model import rolling_radius

    r, b = rolling_radius(robot), robot.track_width
    rate = float(log.meta.get("control_rate_hz", 50.0))
    config = sensing.estimator_config(robot, rate)
    turns = encoder_turns(log, sk, sensors)
    pose, var = wheel_odometry(log.t, turns, log.pose[0], r, b, config)

    def twist(t: FloatArray) -> tuple[FloatArray, FloatArray]:
        w = np.column_stack([np.interp(t, log.t, log.wheel_speed[:, j]) for j in range(2)])
        v, omega = 0.5 * r * (w[:, 0] + w[:, 1]), r * (w[:, 1] - w[:, 0]) / b
        return np.column_stack([v, np.zeros(t.size), omega]), twist_variance(w, r, b, 1.0 / rate, config)

    return Wheels(pose, var, twist)


def run_topics(ns: str, log: Any, robot: Any, sk: Skeleton, sensing: Any) -> list[Topic]:
    """The topics of one run under ``/ns``, and its part of ``/tf`` (:attr:`Topic.joins`).

    Args:
        ns: The run's name (its namespace and frame prefix).
        log: Its :class:`sim.physics.runlog.RunLog`.
        robot: The robot spec (wheel radius and track for the odometry).
        sk: The robot's skeleton.
        sensing: The job's :class:`sim.robot.sensing.SensingSetup` (its sensor profile and noise seed).
    """
    frames = run_frames(ns)
    sensors = run_sensors(log, sensing)
    wheels = run_wheels(log, robot, sk, sensing, sensors)
    base = frames["base_link"]
    series: list[tuple[str, str, Series]] = [
        ("tf", "tf", _tf_series(log, sk, frames, wheels.pose)),
        ("odom", "odometry", _odom_series(log, frames, wheels)),
        ("ground_truth/odom", "odometry", _truth_series(log, frames)),
        ("joint_states", "joints", _joints_series(log, sk, sensors)),
        ("imu", "imu", _imu_series(log, frames, sensing, sensors)),
        ("cmd_vel", "twist", _command_series(log, base)),
        ("tracking_error", "vector", _error_series(log, base)),
        ("fix", "fix", _fix_series(log, (sensing.profile.fix_position_std, sensing.profile.fix_heading_std))),
        ("scan", "scan", _scan_series(log, frames)),
    ]
    topics = [topic(f"/{ns}/{name}", m.TYPES[kind], times, how) for name, kind, (times, how) in series if times.size]
    for tp in topics:
        if tp.name == f"/{ns}/tf":
            tp.joins = "/tf"
    return topics


def topic(name: str, msgtype: str, times: FloatArray, how: Callable[[int], Any] | Rows) -> Topic:
    """A :class:`Topic` of the messages ``how`` gives: ``make`` (message k) or :data:`Rows`."""
    return Topic(name, msgtype, times, rows=how) if isinstance(how, tuple) else Topic(name, msgtype, times, how)


def static_transforms(namespaces: list[str], sk: Skeleton) -> Any:
    """``/tf_static``: each run's IMU where the model puts it (:func:`skeleton`), and its lidar where the model
    has one."""
    tfs = []
    for ns in namespaces:
        fr = run_frames(ns)
        tfs.append(m.transform(0.0, fr["base_link"], fr["imu_link"], sk.imu_pos, sk.imu_quat))
        if sk.scan_pos is not None:
            tfs.append(m.transform(0.0, fr["base_link"], fr["base_scan"], sk.scan_pos, (0.0, 0.0, 0.0, 1.0)))
    return m.tf_message(tfs)


def wall_thickness() -> float:
    """Thickness [m] of the walls the physics puts just outside the world's bounds
    (:func:`sim.physics.model.build_model`'s default)."""
    import inspect

    from sim.physics.model import build_model

    return float(inspect.signature(build_model).parameters["wall_thickness"].default)


def map_layout(world: World, resolution: float = MAP_RESOLUTION) -> tuple[float, int, int, int]:
    """How ``/map``'s cells lie: (resolution [m], walls' cells beyond each bound, columns, rows).

    The grid reaches past the world's bounds by the walls' thickness (:func:`wall_thickness`) rounded up to
    whole cells, so that cell edges fall on the world's lower bounds (and on its upper ones when the bounds
    span a whole number of cells): a wall face, and an obstacle face on the grid of the bounds, lies between
    two cells, not across one. The resolution is coarsened for large worlds (at most :data:`MAP_MAX_CELLS`).
    """
    xmin, xmax, ymin, ymax = world.bounds
    t = wall_thickness()
    area = (xmax - xmin + 2 * t) * (ymax - ymin + 2 * t)
    res = max(resolution, math.ceil(math.sqrt(area / MAP_MAX_CELLS) * 1000.0) / 1000.0)
    pad = math.ceil(t / res - 1e-9)
    w = max(1, math.ceil((xmax - xmin) / res - 1e-9)) + 2 * pad
    h = max(1, math.ceil((ymax - ymin) / res - 1e-9)) + 2 * pad
    return res, pad, w, h


def map_origin(world: World) -> tuple[float, float]:
    """The lower-left corner of ``/map`` [m]: the world's, moved out by the walls' thickness in whole cells
    (:func:`map_layout`)."""
    res, pad, _, _ = map_layout(world)
    return world.bounds[0] - pad * res, world.bounds[2] - pad * res


def occupancy(world: World, resolution: float = MAP_RESOLUTION) -> tuple[float, NDArray[np.int8]]:
    """The world's obstacles and its walls as occupancy (100 inside one, 0 free), rows along y from
    :func:`map_origin`: the grid spans the bounds and the walls around them (:func:`map_layout`), a cell
    occupied when its centre lies inside an obstacle or outside the bounds (the walls'). The cell edges fall
    on the bounds, so a wall face lies on a cell edge and the map's walls are where the world's are; so does an
    obstacle's face on the lattice of the bounds (a multiple of 2.5 cm from them at the default resolution). A
    face midway between two edges runs through a row of centres: those cells, half inside, count as occupied (a
    planner's safe side), so such a face is drawn up to half a cell out.

    Returns:
        (resolution [m], coarsened for large worlds, (H, W) int8 grid).
    """
    xmin, xmax, ymin, ymax = world.bounds
    res, pad, w, h = map_layout(world, resolution)
    # centres counted from the bounds (not from the corner), so that none lands on a face by round-off
    xs, ys = xmin + (np.arange(w) - pad + 0.5) * res, ymin + (np.arange(h) - pad + 0.5) * res
    gx, gy = np.meshgrid(xs, ys)
    centres = np.column_stack([gx.ravel(), gy.ravel()])
    inside = world.obstacle_distance(centres) <= 1e-9  # a centre on a face (a tie) counts as in
    wall = ((gx < xmin) | (gx > xmax) | (gy < ymin) | (gy > ymax)).ravel()
    return res, np.where(inside | wall, 100, 0).astype(np.int8).reshape(h, w)


def map_message(world: World) -> Any:
    """``/map``: the occupancy grid of the world and its walls (see :func:`occupancy`)."""
    res, grid = occupancy(world)
    info = m.msg("nav_msgs/msg/MapMetaData")(
        map_load_time=m.stamp(0.0),
        resolution=res,
        width=grid.shape[1],
        height=grid.shape[0],
        origin=m.pose(*map_origin(world), 0.0, (0.0, 0.0, 0.0, 1.0)),
    )
    return m.msg(m.TYPES["grid"])(header=m.header(0.0, "map"), info=info, data=grid.ravel())


OBSTACLE_COLOUR = (0.55, 0.45, 0.35, 0.9)
#: Colour of the obstacles not on the map (RGBA): red, half transparent.
UNMAPPED_COLOUR = (0.85, 0.15, 0.15, 0.7)
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
    """``RUN/robot``: the run's robot drawn in its ``ground_truth/base_link`` (a box over the footprint, two
    wheels), locked to the frame so that it drives where the physics put the robot."""
    frame = run_frames(ns)["ground_truth/base_link"]
    lo, hi = robot.footprint.min(axis=0), robot.footprint.max(axis=0)
    r, height = robot.wheel_radius, ROBOT_HEIGHT
    floor = -r - float(sk.link[2])  # the floor under the axle, in base_link
    body = m.pose(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * height + 0.005 + floor, (0.0, 0.0, 0.0, 1.0))
    size = (float(hi[0] - lo[0]), float(hi[1] - lo[1]), height)
    markers = [_marker(0, 1, body, size, [], frame=frame, ns=ns, colour=colour)]
    axle = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))  # a cylinder's axis turned from z onto y
    for j, pos in enumerate(sk.wheel_pos):
        wheel = m.pose(pos[0], pos[1], pos[2], axle)
        markers.append(
            _marker(j + 1, 3, wheel, (2 * r, 2 * r, 0.018), [], frame=frame, ns=ns, colour=(0.1, 0.1, 0.1, colour[3]))
        )
    return m.msg(m.TYPES["markers"])(markers=markers)


def _obstacle_marker(k: int, obs: Any, ns: str, colour: tuple[float, ...]) -> Any | None:
    """One obstacle as a solid of its height (a polygon as its outline at that height), or None (a shape not
    drawn)."""
    h = obs.height
    if isinstance(obs, Polygon):
        pts = [m.point(x, y, h) for x, y in [*obs.vertices, obs.vertices[0]]]
        return _marker(k, 4, m.pose(0, 0, 0, (0, 0, 0, 1)), (0.02, 0, 0), pts, ns=ns, colour=colour)
    if isinstance(obs, Circle):
        size, angle, kind = (2 * obs.radius, 2 * obs.radius), 0.0, 3
    elif isinstance(obs, Ellipse):
        size, angle, kind = (2 * obs.radii[0], 2 * obs.radii[1]), obs.angle, 3
    elif isinstance(obs, Box):
        size, angle, kind = (obs.size[0], obs.size[1]), obs.angle, 1
    else:
        return None
    p = m.pose(obs.center[0], obs.center[1], 0.5 * h, m.yaw_quat(angle))
    return _marker(k, kind, p, (size[0], size[1], h), [], ns=ns, colour=colour)


def obstacle_markers(world: World, unmapped: Sequence[Any] = ()) -> Any:
    """``/obstacles``: the map's obstacles (namespace ``obstacles``), the world's walls as a line (its last
    id), and the obstacles that are not on the map (namespace ``unmapped``, :data:`UNMAPPED_COLOUR`: in
    physics and in the scan, unknown to the planner and the localiser), each a solid of its height (a polygon
    as its outline)."""
    mapped = [_obstacle_marker(k, obs, "obstacles", OBSTACLE_COLOUR) for k, obs in enumerate(world.obstacles)]
    xmin, xmax, ymin, ymax = world.bounds
    walls = [m.point(x, y) for x, y in ((xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax), (xmin, ymin))]
    mapped.append(_marker(len(world.obstacles), 4, m.pose(0, 0, 0, (0, 0, 0, 1)), (0.02, 0, 0), walls))
    hidden = [_obstacle_marker(k, obs, "unmapped", UNMAPPED_COLOUR) for k, obs in enumerate(unmapped)]
    return m.msg(m.TYPES["markers"])(markers=[x for x in mapped + hidden if x is not None])
