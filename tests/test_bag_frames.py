"""A bag's frames, read back with ``rosbags``: every run's transforms on ``/tf`` (REP 105: the wheel odometry
continuous in ``odom``, the belief's corrections in ``map -> odom``, the truth in its own frames), each run's
``/odom`` what it believed with honest covariances, the true body velocity with its sideways slip, and
``/map`` with the arena's walls on it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from planning.core.geometry import compose_poses
from sim.io import bag_topics as bt
from sim.pipeline.runs import RunKind
from tests.test_bag import tf_chain

RUNS = (RunKind.CLOSED_LOOP, RunKind.CLOSED_LOOP_ODOMETRY, RunKind.OPEN_LOOP, RunKind.CLOSED_LOOP_TRUTH)


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, dict[str, list[tuple[int, Any]]]]:
    """A circle (steady cornering) by the four kinds of run, written as a bag and read back by rosbags."""
    from rosbags.highlevel import AnyReader

    from sim.io.bag import write_job_bag
    from sim.pipeline.simulate import simulate_reference

    job = simulate_reference("open", reference="circle", robot="turtlebot3", runs=RUNS)
    path = tmp_path_factory.mktemp("frames") / "circle"
    write_job_bag(job, path)  # as the commands write it
    msgs: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([path]) as reader:
        for conn, t, raw in reader.messages():
            msgs.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
    return job, msgs


def _yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _planar(tf: Any) -> np.ndarray:
    """A transform as a planar pose (x, y, yaw)."""
    return np.array([tf.transform.translation.x, tf.transform.translation.y, _yaw(tf.transform.rotation)])


def run_tf(msgs: dict[str, list[tuple[int, Any]]], kind: str) -> tuple[np.ndarray, dict[tuple[str, str], np.ndarray]]:
    """A run's messages on /tf: their stamps [s] and each (parent, child)'s planar poses (K, 3)."""
    own = [(t, x) for t, x in msgs["/tf"] if x.transforms[0].child_frame_id.startswith(f"{kind}/")]
    links: dict[tuple[str, str], list[np.ndarray]] = {}
    for _, x in own:
        for tf in x.transforms:
            links.setdefault((tf.header.frame_id, tf.child_frame_id), []).append(_planar(tf))
    return np.array([t for t, _ in own]) * 1e-9, {k: np.array(v) for k, v in links.items()}


def _unwrapped(p: np.ndarray) -> np.ndarray:
    p = p.copy()
    p[:, 2] = np.unwrap(p[:, 2])
    return p


def test_every_runs_transforms_are_on_tf(bag: tuple[Any, dict[str, Any]]) -> None:
    job, msgs = bag
    assert not [t for t in msgs if t.endswith("/tf") and t != "/tf"]  # no run's own tf topic
    assert sum(len(x.transforms) for _, x in msgs["/tf"]) == 7 * sum(log.t.size for log in job.logs.values())
    for kind, log in job.logs.items():
        t, links = run_tf(msgs, kind)
        np.testing.assert_allclose(t, log.t, atol=1e-9)
        assert list(links) == tf_chain(kind)
        truth = links[("map", f"{kind}/ground_truth/base_footprint")]
        np.testing.assert_allclose(_unwrapped(truth), log.pose, atol=1e-9)
        robot = msgs[f"/{kind}/robot"][0][1].markers  # drawn where the physics put the robot
        assert {mk.header.frame_id for mk in robot} == {f"{kind}/ground_truth/base_link"}


def test_odom_is_continuous_wheel_odometry_and_map_to_odom_carries_the_corrections(
    bag: tuple[Any, dict[str, Any]],
) -> None:
    """odom -> base_footprint moves no further between samples than the wheels turned (it jumped by the
    fused fixes' corrections, 1-26 mm, when it was the estimate); map -> odom holds the corrections, and
    map -> base_footprint is what the run believed: its /odom at the same stamps (interpolated)."""
    job, msgs = bag
    r, b = job.prepared.robot.wheel_radius, job.prepared.robot.track_width
    for kind, log in job.logs.items():
        _, links = run_tf(msgs, kind)
        odo = _unwrapped(links[(f"{kind}/odom", f"{kind}/base_footprint")])
        turned = np.abs(np.diff(log.qpos[:, list(bt.skeleton("turtlebot3").wheels)], axis=0)).sum(axis=1)
        count = 2 * math.pi / 4096  # an encoder count [rad]: the odometry counts the turns
        step = np.hypot(*np.diff(odo[:, :2], axis=0).T)
        assert np.all(step <= 0.5 * r * (turned + 2 * count) * 1.01), kind
        assert np.all(np.abs(np.diff(odo[:, 2])) <= r * (turned + 2 * count) / b * 1.01), kind
        map_odom = links[("map", f"{kind}/odom")]
        believed = compose_poses(map_odom, odo)
        odom = msgs[f"/{kind}/odom"]
        at = np.array([t for t, _ in odom]) * 1e-9
        pose = _unwrapped(np.array([[x.pose.pose.position.x, x.pose.pose.position.y, _yaw(x.pose.pose.orientation)]
                                    for _, x in odom]))  # fmt: skip
        want = np.column_stack([np.interp(log.t, at, pose[:, k]) for k in range(3)])
        np.testing.assert_allclose(believed[:, :2], want[:, :2], atol=1e-9)
        np.testing.assert_allclose(np.angle(np.exp(1j * (believed[:, 2] - want[:, 2]))), 0.0, atol=1e-9)
        if kind == RunKind.OPEN_LOOP:  # no belief: map -> odom the identity
            assert np.all(map_odom == 0.0)
            assert odom[0][1].header.frame_id == "open_loop/odom"
        else:
            assert odom[0][1].header.frame_id == "map"
    fused = run_tf(msgs, RunKind.CLOSED_LOOP)[1][("map", "closed_loop/odom")]
    jumps = np.hypot(*np.diff(fused[:, :2], axis=0).T)
    assert jumps.max() > 1e-3  # a fix's correction


def test_the_open_loops_odom_is_its_wheel_odometry_with_a_growing_covariance(bag: tuple[Any, dict[str, Any]]) -> None:
    job, msgs = bag
    log = job.logs[RunKind.OPEN_LOOP]
    odom = msgs["/open_loop/odom"]
    _, links = run_tf(msgs, "open_loop")
    odo = links[("open_loop/odom", "open_loop/base_footprint")]
    got = np.array([[x.pose.pose.position.x, x.pose.pose.position.y] for _, x in odom])
    np.testing.assert_allclose(got, odo[:, :2], atol=1e-12)
    assert np.abs(got - log.pose[:, :2]).max() > 1e-3  # not the true pose
    var = np.array([np.asarray(x.pose.covariance)[[0, 7, 35]] for _, x in odom])
    assert var[0].tolist() == [0.0, 0.0, 0.0] and np.all(var[-1] > 0)
    quarter = var[var.shape[0] // 4]  # dead reckoning's variances grow
    assert var[-1, :2].sum() > 10 * quarter[:2].sum() and var[-1, 2] > 2 * quarter[2]
    err = np.hypot(*(got[-1] - log.pose[-1, :2]))
    assert err < 5 * math.sqrt(var[-1, 0] + var[-1, 1])  # the stated covariance covers the drift


def test_odom_twists_have_a_covariance(bag: tuple[Any, dict[str, Any]]) -> None:
    """The twist from the wheel speeds is not exact: its covariance (encoder quantisation over a control
    period, wheel slip, build tolerances) is positive on v and omega, and large on what a planar robot has
    not (z, roll, pitch)."""
    _, msgs = bag
    for kind in RUNS:
        cov = np.asarray(msgs[f"/{kind}/odom"][-1][1].twist.covariance).reshape(6, 6)
        assert cov[0, 0] > 0 and cov[1, 1] > 0 and cov[5, 5] > 0, kind
        assert cov[2, 2] == cov[3, 3] == cov[4, 4] == 1e6 and cov[0, 5] == cov[5, 0], kind
        assert 1e-9 < math.sqrt(cov[0, 0]) < 0.01, kind


def test_the_true_twist_carries_the_sideways_slip(bag: tuple[Any, dict[str, Any]]) -> None:
    """On the circle the tyres slip outwards: the true body velocity in ground_truth/odom has a lateral part,
    the positions differentiated and turned into the body frame (it was exactly zero)."""
    job, msgs = bag
    for kind, log in job.logs.items():
        gt = msgs[f"/{kind}/ground_truth/odom"]
        assert gt[0][1].child_frame_id == f"{kind}/ground_truth/base_footprint"
        t = np.array([s for s, _ in gt]) * 1e-9
        vel = np.array([[x.twist.twist.linear.x, x.twist.twist.linear.y, x.twist.twist.angular.z] for _, x in gt])
        turning = np.abs(vel[:, 2]) > 0.1
        assert turning.mean() > 0.5, kind
        lateral = vel[turning, 1] * np.sign(vel[turning, 2])
        assert np.median(lateral) < -1e-5, kind  # outwards, against the turn
        at = np.searchsorted(t, log.t[1:-1] - 1e-10)  # the logged samples, central differences
        dx, dy = np.gradient(log.pose[:, 0], log.t), np.gradient(log.pose[:, 1], log.t)
        th = log.pose[:, 2]
        side = (-np.sin(th) * dx + np.cos(th) * dy)[1:-1]
        assert np.corrcoef(vel[at, 1], side)[0, 1] > 0.5, kind


def test_the_map_has_the_walls_and_the_scans_land_on_it(bag: tuple[Any, dict[str, Any]]) -> None:
    """The arena's walls (the physics' boxes just outside the bounds) are occupied on /map, whose grid
    reaches over them; the lidar's returns land on occupied cells within the scanner's accuracy (5 % of
    the range; on the open arena only the walls return, and none did)."""
    from scipy.ndimage import distance_transform_edt

    from sim.physics.model import build_model

    job, msgs = bag
    import inspect

    thick = inspect.signature(build_model).parameters["wall_thickness"].default
    world = job.prepared.scenario.world
    xmin, xmax, ymin, ymax = world.bounds
    grid = msgs["/map"][0][1]
    res, w, h = grid.info.resolution, grid.info.width, grid.info.height
    ox, oy = grid.info.origin.position.x, grid.info.origin.position.y
    assert (ox, oy) == pytest.approx((xmin - thick, ymin - thick))
    assert w * res == pytest.approx(xmax - xmin + 2 * thick, abs=res) and h * res >= ymax - ymin + 2 * thick - 1e-6
    occ = np.asarray(grid.data).reshape(h, w) == 100
    assert occ[:, 0].all() and occ[:, -1].all() and occ[0].all() and occ[-1].all()
    assert not occ[h // 2, int((xmin + 0.1 - ox) / res)]  # inside the bounds, free
    far = distance_transform_edt(~occ) * res  # each cell's distance to the nearest occupied one [m]
    scans = msgs["/closed_loop/scan"]
    gt = msgs["/closed_loop/ground_truth/odom"]
    gt_t = np.array([s for s, _ in gt]) * 1e-9
    pose = _unwrapped(np.array([[x.pose.pose.position.x, x.pose.pose.position.y, _yaw(x.pose.pose.orientation)]
                                for _, x in gt]))  # fmt: skip
    static = next(tf for tf in msgs["/tf_static"][0][1].transforms if tf.child_frame_id == "closed_loop/base_scan")
    lx, ly = static.transform.translation.x, static.transform.translation.y
    near = []
    for stamp, scan in scans:
        r = np.asarray(scan.ranges, dtype=float)
        i = np.flatnonzero((r > scan.range_min) & (r < scan.range_max))
        at = stamp * 1e-9 + i * scan.time_increment
        x, y, th = (np.interp(at, gt_t, pose[:, k]) for k in range(3))
        bearing = th + scan.angle_min + i * scan.angle_increment
        px = x + np.cos(th) * lx - np.sin(th) * ly + r[i] * np.cos(bearing)
        py = y + np.sin(th) * lx + np.cos(th) * ly + r[i] * np.sin(bearing)
        col = np.clip(((px - ox) / res).astype(int), 0, w - 1)
        row = np.clip(((py - oy) / res).astype(int), 0, h - 1)
        near.append(far[row, col] <= 0.03 + 0.05 * r[i])  # the LDS-01's accuracy: 5 % of the range
    hits = np.concatenate(near)
    assert hits.size > 1000 and hits.mean() > 0.85  # 0.91 (none without the walls)


def test_the_wheel_links_are_the_urdfs_rolled_frames_turned_by_the_joints(bag: tuple[Any, dict[str, Any]]) -> None:
    """The TurtleBot3 URDF's wheel joints roll their frames by -1.57 rad about x and turn them about their z: the
    wheel links were turned about y alone (the roll missing), so ROBOTIS's wheel meshes lay flat in RViz."""
    from scipy.spatial.transform import Rotation

    job, msgs = bag
    kind = RunKind.CLOSED_LOOP
    log = job.logs[kind]
    wheels = bt.skeleton("turtlebot3").wheels
    rotations = {"left": [], "right": []}
    for _, x in msgs["/tf"]:
        for tf in x.transforms:
            for side in rotations:
                if tf.child_frame_id == f"{kind}/wheel_{side}_link":
                    r = tf.transform.rotation
                    rotations[side].append([r.x, r.y, r.z, r.w])
    for j, side in enumerate(("left", "right")):
        got = Rotation.from_quat(np.array(rotations[side]))
        # robot_state_publisher: the joint's origin (rpy -1.57 0 0), then the angle about the joint's axis (0 0 1)
        urdf = Rotation.from_euler("x", -1.57) * Rotation.from_rotvec(np.outer(log.qpos[:, wheels[j]], [0, 0, 1]))
        assert np.max((got.inv() * urdf).magnitude()) < 1e-9
