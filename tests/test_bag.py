"""Runs as ROS 2 bags, checked independently: a job written with ``rosbags`` is read back with ``rosbags``
and, separately, with the ``mcap`` library (counts per topic, stamps, frames, the final true pose), its
``/plan`` read as a path reproduces the job's trajectory, a lidar scan in the run log is published,
and the write is atomic."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import yaml

from planning.errors import ConfigError, OutputExistsError, without_python
from planning.trajectory.importer import TrajectoryFile
from sim.io import bag_topics as bt
from sim.io.bag import write_job_bag
from sim.io.bag_topics import scan_of
from sim.pipeline.runs import RunKind

RUNS = (RunKind.CLOSED_LOOP, RunKind.CLOSED_LOOP_ODOMETRY, RunKind.OPEN_LOOP)
PER_SAMPLE = ("ground_truth/odom", "joint_states", "imu", "cmd_vel", "tracking_error")
ONCE = ("/tf_static", "/plan", "/reference", "/map", "/obstacles")


def path_file(folder: Path) -> Path:
    """A gentle 0.8 m arc as an untimed path (x, y only)."""
    x = np.linspace(0.0, 0.8, 9)
    y = 0.15 * np.sin(np.pi * x / 0.8)
    p = folder / "arc.csv"
    p.write_text("x,y\n" + "\n".join(f"{a:.4f},{b:.4f}" for a, b in zip(x, y, strict=True)) + "\n")
    return p


@pytest.fixture(scope="module")
def job(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Path]:
    from sim.pipeline.simulate import simulate_file

    folder = tmp_path_factory.mktemp("bag")
    result = simulate_file(TrajectoryFile(path_file(folder), timed=False), robot="turtlebot3", runs=RUNS)
    return result, write_job_bag(result, folder / "job").path


def _yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def expected_counts(result: Any) -> dict[str, int]:
    """Messages per topic as the logs dictate (the runs' transforms all on ``/tf``, one message per run and
    sample: tf2, RViz and Nav2 listen there alone)."""
    counts: dict[str, int] = {"/tf": sum(log.t.size for log in result.logs.values())}
    for kind, log in result.logs.items():
        for name in PER_SAMPLE:
            counts[f"/{kind}/{name}"] = log.t.size
        est = log.estimation
        # one estimate per control instant; without an estimator, the logged samples
        counts[f"/{kind}/odom"] = est.t.size if est is not None else log.t.size
        if est is not None:  # the truth at every logged sample and every reading of the sensors
            counts[f"/{kind}/ground_truth/odom"] = np.union1d(ns(log.t), ns(sensed(log, est.t))).size
        counts[f"/{kind}/robot"] = 1
        loc = est.localiser if est is not None else None
        fixes = loc.t.size if loc is not None else est.fix_t.size if est is not None else 0
        if fixes and est is not None and est.source != "odometry":  # dead reckoning localises nothing
            counts[f"/{kind}/fix"] = fixes  # the scan localiser's every update, else each synthetic fix
        scan = scan_of(log)
        if scan is not None and scan.t.size:
            counts[f"/{kind}/scan"] = scan.t.size
    counts["/clock"] = np.unique(np.concatenate([log.t for log in result.logs.values()])).size
    counts.update(dict.fromkeys(ONCE, 1))
    return counts


def ns(t: np.ndarray) -> np.ndarray:
    """Times [s] as a bag's whole nanoseconds."""
    return np.round(np.asarray(t) * 1e9).astype(np.int64)


def sensed(log: Any, t: np.ndarray) -> np.ndarray:
    """The physics times of what the sensors read at control instants ``t`` (independently of
    ``sim.io.bag_topics.sensed_at``): MuJoCo's sensors give the state at the start of the last physics
    step, one timestep before each instant after the first."""
    return np.where(t > log.t[0] + 1e-9, t - float(log.meta["timestep_s"]), t)


def tf_chain(kind: str) -> list[tuple[str, str]]:
    """A run's transforms on ``/tf``, (parent, child) in order: REP 105's chain, then the truth's frames."""
    return [
        ("map", f"{kind}/odom"),
        (f"{kind}/odom", f"{kind}/base_footprint"),
        (f"{kind}/base_footprint", f"{kind}/base_link"),
        (f"{kind}/base_link", f"{kind}/wheel_left_link"),
        (f"{kind}/base_link", f"{kind}/wheel_right_link"),
        ("map", f"{kind}/ground_truth/base_footprint"),
        (f"{kind}/ground_truth/base_footprint", f"{kind}/ground_truth/base_link"),
    ]


def run_tf(msgs: dict[str, list[tuple[int, Any]]], kind: str) -> list[tuple[int, Any]]:
    """A run's transforms: its messages on ``/tf``, told apart by their frames' prefix."""
    return [(t, x) for t, x in msgs["/tf"] if x.transforms[0].child_frame_id.startswith(f"{kind}/")]


def read_rosbags(path: Path) -> tuple[dict[str, str], dict[str, list[tuple[int, Any]]], Any]:
    """Topic -> type, topic -> [(log time ns, message)], and the rosbag2 metadata, read by rosbags."""
    from rosbags.highlevel import AnyReader

    out: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([path]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        for conn, t, raw in reader.messages():
            out.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
    return types, out, qos


def test_rosbags_reads_every_topic_with_the_logs_counts_stamps_and_frames(job: tuple[Any, Path]) -> None:
    result, path = job
    types, msgs, qos = read_rosbags(path)
    assert {k: len(v) for k, v in msgs.items()} == expected_counts(result)
    assert types["/closed_loop/odom"] == "nav_msgs/msg/Odometry"
    assert types["/closed_loop/cmd_vel"] == "geometry_msgs/msg/TwistStamped"
    assert types["/closed_loop/fix"] == "geometry_msgs/msg/PoseWithCovarianceStamped"
    assert "closed_loop_odometry" in result.logs and "/closed_loop_odometry/fix" not in types
    assert types["/map"] == "nav_msgs/msg/OccupancyGrid" and types["/obstacles"] == "visualization_msgs/msg/MarkerArray"
    end = max(float(log.t[-1]) for log in result.logs.values())
    for topic, items in msgs.items():
        times = np.array([t for t, _ in items])
        assert np.all(np.diff(times) >= 0), f"{topic}: log times go back"
        assert times[0] >= 0 and times[-1] <= round(end * 1e9), topic
        header = getattr(items[0][1], "header", None)
        if header is not None and topic not in ONCE:  # each message's stamp is its log time
            stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in items]
            assert stamps == list(times), topic
    for kind in result.logs:  # each run's tree: map -> odom -> base_footprint -> base_link -> wheels; the truth
        tf = run_tf(msgs, kind)
        assert len(tf) == result.logs[kind].t.size
        chain = [(x.header.frame_id, x.child_frame_id) for x in tf[0][1].transforms]
        assert chain == tf_chain(kind)
    latched = {t for t, q in qos.items() if q and q[0].durability.name == "TRANSIENT_LOCAL"}
    assert latched == {*ONCE, *(f"/{kind}/robot" for kind in result.logs)}


def _compose(a: Any, b: Any) -> tuple[float, float, float]:
    """Two transforms' planar poses composed: ``b`` in ``a``'s child frame, in ``a``'s parent."""
    ya = _yaw(a.rotation)
    x = a.translation.x + math.cos(ya) * b.translation.x - math.sin(ya) * b.translation.y
    y = a.translation.y + math.sin(ya) * b.translation.x + math.cos(ya) * b.translation.y
    return x, y, ya + _yaw(b.rotation)


def test_tf_puts_base_footprint_at_the_belief_and_the_truth_frame_at_the_final_pose(job: tuple[Any, Path]) -> None:
    result, path = job
    _, msgs, _ = read_rosbags(path)
    for kind, log in result.logs.items():
        final = log.pose[-1]
        gt = msgs[f"/{kind}/ground_truth/odom"][-1][1]
        assert gt.header.frame_id == "map" and gt.child_frame_id == f"{kind}/ground_truth/base_footprint"
        p = gt.pose.pose
        assert (p.position.x, p.position.y) == pytest.approx((final[0], final[1]), abs=1e-12)
        assert _wrap(_yaw(p.orientation) - final[2]) == pytest.approx(0.0, abs=1e-9)
        tfs = run_tf(msgs, kind)[-1][1].transforms
        truth = tfs[5].transform  # map -> ground_truth/base_footprint: the true pose
        assert (truth.translation.x, truth.translation.y) == pytest.approx((final[0], final[1]), abs=1e-12)
        # map -> odom -> base_footprint composes to what the run believed (the truth for the open loop's
        # start only: it believes nothing, map -> odom the identity, base_footprint its wheel odometry)
        x, y, yaw = _compose(tfs[0].transform, tfs[1].transform)
        believed = bt.belief_at(log, log.t[-1:])
        if believed is None:
            assert (tfs[0].transform.translation.x, tfs[0].transform.translation.y) == (0.0, 0.0)
        else:
            assert (x, y) == pytest.approx((believed[0, 0], believed[0, 1]), abs=1e-9)
            assert _wrap(yaw - believed[0, 2]) == pytest.approx(0.0, abs=1e-9)
        err = msgs[f"/{kind}/tracking_error"][-1][1].vector
        assert err.x == pytest.approx(float(np.hypot(*(log.pose[-1, :2] - log.ref_pose[-1, :2]))), abs=1e-12)
        robot = msgs[f"/{kind}/robot"][0][1].markers
        assert {mk.header.frame_id for mk in robot} == {f"{kind}/ground_truth/base_link"}
        assert all(mk.frame_locked for mk in robot)
        joints = msgs[f"/{kind}/joint_states"][-1][1]
        assert list(joints.name) == ["wheel_left_joint", "wheel_right_joint"]
        assert list(joints.velocity) == pytest.approx(list(log.wheel_speed[-1]), abs=0.0)
        # the angles as the encoders read them: whole counts, within one count below the true angle
        prepared = result.prepared
        per_rad = prepared.case.sensing(prepared.scenario).profile.encoder_cpr / (2 * np.pi)
        counts = np.array([m.position for _, m in msgs[f"/{kind}/joint_states"]]) * per_rad
        np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-6)
        true = log.qpos[:, list(bt.skeleton(prepared.robot.name).wheels)] * per_rad
        assert np.all((true - counts > -1.0) & (true - counts < 1.0)) and np.any(np.abs(true - counts) > 1e-3)


def test_odom_is_stamped_at_its_readings_and_its_error_from_the_bag_is_the_records(job: tuple[Any, Path]) -> None:
    """Each run's /RUN/odom holds one estimate per control instant, stamped at the physics time of the
    sensor readings it is based on (one physics step before the instant: MuJoCo's sensors are evaluated
    at the start of a step), and /RUN/ground_truth/odom has the true pose at that stamp: the error
    computed from the bag alone, each estimate against the truth at its own stamp, is the record's
    estimate RMSE (it was 7 % larger with the estimates stamped at the instants, against the truth 2 ms
    later). tf's map -> odom -> base_footprint at each logged sample is the estimate on the same clock."""
    from sim.physics.metrics import EstimationMetrics

    result, path = job
    _, msgs, _ = read_rosbags(path)
    for kind, log in result.logs.items():
        est = log.estimation
        if est is None:
            continue
        odom = msgs[f"/{kind}/odom"]
        assert [t for t, _ in odom] == list(ns(sensed(log, est.t))), kind
        truth = {t: m.pose.pose for t, m in msgs[f"/{kind}/ground_truth/odom"]}
        err = [math.hypot(m.pose.pose.position.x - truth[t].position.x, m.pose.pose.position.y - truth[t].position.y)
               for t, m in odom]  # fmt: skip
        record = EstimationMetrics.of(est)
        assert math.sqrt(np.mean(np.square(err))) == pytest.approx(record.position_rmse_m, rel=1e-9, abs=0), kind
        head = [_wrap(_yaw(m.pose.pose.orientation) - _yaw(truth[t].orientation)) for t, m in odom]
        assert math.sqrt(np.mean(np.square(head))) == pytest.approx(record.heading_rmse_rad, rel=1e-6), kind
        at = np.array([t for t, _ in odom]) * 1e-9
        x = np.array([m.pose.pose.position.x for _, m in odom])
        tf_x = [_compose(m.transforms[0].transform, m.transforms[1].transform)[0] for _, m in run_tf(msgs, kind)]
        np.testing.assert_allclose(tf_x, np.interp(log.t, at, x), rtol=0, atol=1e-9)


def test_the_mcap_library_reads_the_same_counts_and_final_pose(job: tuple[Any, Path]) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    result, path = job
    files = list(path.glob("*.mcap"))
    assert len(files) == 1 and (path / "metadata.yaml").is_file()
    counts: dict[str, int] = {}
    last: dict[str, Any] = {}
    with files[0].open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and {c.compression for c in summary.chunk_indexes} == {"zstd"}
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            last[channel.topic] = (message.log_time, decoded)
        qos = {c.topic: yaml.safe_load(c.metadata["offered_qos_profiles"]) for c in summary.channels.values()}
    assert counts == expected_counts(result)
    # rmw's durability 1 is transient local: the once-per-job topics are latched, the others volatile
    latched = {topic for topic, q in qos.items() if q and q[0]["durability"] == 1}
    assert latched == {*ONCE, *(f"/{kind}/robot" for kind in result.logs)}
    log = result.logs[RunKind.CLOSED_LOOP]
    t, gt = last["/closed_loop/ground_truth/odom"]
    assert t == round(float(log.t[-1]) * 1e9)
    assert (gt.pose.pose.position.x, gt.pose.pose.position.y) == pytest.approx(tuple(log.pose[-1, :2]), abs=1e-12)
    grid = last["/map"][1]
    assert grid.info.resolution == pytest.approx(0.025) and len(grid.data) == grid.info.width * grid.info.height


def _file_order(path: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time, CDR bytes) of every message of a bag, in the order its MCAP file holds them."""
    from mcap.reader import make_reader

    (file,) = path.glob("*.mcap")
    with file.open("rb") as f:
        return [(c.topic, msg.log_time, msg.data) for _, c, msg in make_reader(f).iter_messages(log_time_order=False)]


def test_a_bag_written_a_stretch_at_a_time_is_the_bag_written_at_once(
    job: tuple[Any, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A bag held every message of a job in memory while it was written (550 MB above the run's own for a
    600 s run); it is written a stretch of time at a time, the same messages in the same order, ties (one
    stamp on several topics, or twice on the joined /tf) kept in topic and message order across the cuts."""
    from sim.io import bag

    result, _ = job
    written = {}
    for name, window in (("whole", 10**9), ("cut", 97)):
        monkeypatch.setattr(bag, "WINDOW_MESSAGES", window)
        written[name] = _file_order(write_job_bag(result, tmp_path / name).path)
    whole = written["whole"]
    assert len(whole) == sum(expected_counts(result).values()) > 20 * 97
    assert [t for _, t, _ in whole] == sorted(t for _, t, _ in whole)
    assert written["cut"] == whole


def test_the_plan_of_a_bag_read_as_a_path_reproduces_the_jobs_trajectory(job: tuple[Any, Path]) -> None:
    from sim.pipeline.case import Case, prepare_trajectory

    result, path = job
    again = prepare_trajectory(Case(result.scenario, trajectory_file=TrajectoryFile(path, timed=False, topic="/plan")))
    a, b = result.trajectory, again.trajectory
    assert a.t.shape == b.t.shape
    np.testing.assert_allclose(b.t, a.t, atol=1e-9)
    np.testing.assert_allclose(b.pose, a.pose, atol=1e-9)
    assert again.extra["import"]["format"] == "bag topic /plan, nav_msgs/Path"


def test_the_reference_read_back_as_a_trajectory_keeps_its_clock(job: tuple[Any, Path]) -> None:
    """The job's own /reference (its samples every 20 ms), read with --trajectory semantics, is within the
    robot's limits: its clock is kept, not re-timed, slowed uniformly only as far as the curve through
    its rows needs (its spline rings by a few percent at the steps of the acceleration). It was re-timed
    for an acceleration of 0.70 m/s^2 (limit 0.425) that only the curve had, at rest a row before the
    stop that falls between two rows."""
    from planning.trajectory.file_trajectory import file_trajectory
    from planning.trajectory.importer import read_trajectory_file

    result, path = job
    imp = read_trajectory_file(TrajectoryFile(path, timed=True, topic="/reference"))
    res = file_trajectory(imp, result.prepared.robot, result.scenario.world)
    traj = res.trajectory
    assert res.success and traj is not None
    assert imp.report.retimed is False, imp.report.timing
    assert 1.0 <= imp.report.time_stretch < 1.035
    assert imp.t is not None
    at = traj.sample_many(imp.t * imp.report.time_stretch).pose  # where the file is, when
    assert np.abs(at[:, :2] - imp.xy).max() < 1e-5


def test_the_plan_of_a_planned_jobs_bag_reproduces_its_trajectory(tmp_path: Path) -> None:
    """A planner's path on /plan, read back with --path semantics in the job's scenario, is smoothed and timed
    into the very trajectory the job tracked."""
    from sim.pipeline.case import Case, PlanOptions, prepare_trajectory
    from sim.pipeline.simulate import track

    prepared = prepare_trajectory(Case("simple_motion", planner="birrt", planning=PlanOptions(time_limit=5.0)))
    job = track(prepared, (RunKind.OPEN_LOOP,), strict=False)
    path = write_job_bag(job, tmp_path / "planned").path
    read = TrajectoryFile(path, timed=False, topic="/plan")
    again = prepare_trajectory(Case(prepared.scenario, trajectory_file=read))
    assert prepared.path is not None and len(prepared.path) > 2
    np.testing.assert_allclose(again.trajectory.t, prepared.trajectory.t, atol=1e-9)
    np.testing.assert_allclose(again.trajectory.pose, prepared.trajectory.pose, atol=1e-9)


def _with_scan(result: Any, where: str, ranges: np.ndarray, t: np.ndarray) -> Any:
    """The job with synthetic LDS-01 sweeps in its closed loop's log: as ``log.scan``, or where the scan
    localiser keeps them (``log.estimation.localiser``: bearing 0 first, 1 degree apart)."""
    run = result.runs[RunKind.CLOSED_LOOP]
    log = dataclasses.replace(run.log)
    step = 2 * math.pi / ranges.shape[1]
    if where == "log.scan":
        fields = [
            "t",
            "ranges",
            "angle_min",
            "angle_increment",
            "time_increment",
            "scan_time",
            "range_min",
            "range_max",
        ]
        scan = dataclasses.make_dataclass("Scan", fields)(t, ranges, 0.0, step, 0.2 / 360, 0.2, 0.12, 3.5)
        object.__setattr__(log, "scan", scan)
        if log.estimation is not None:  # the run's own scan localiser's revolutions would come first
            est = dataclasses.replace(log.estimation)
            object.__setattr__(est, "localiser", None)
            object.__setattr__(log, "estimation", est)
    else:
        fields = ["scan_t", "scan_ranges", "scan_angle_increment", "scan_time_increment", "range_min", "range_max"]
        fields += ["t", "cov"]  # no updates: the fixes keep the profile's variances
        none = (np.zeros(0), np.zeros((0, 3, 3)))
        loc = dataclasses.make_dataclass("Localiser", fields)(t, ranges, step, 0.2 / 360, 0.12, 3.5, *none)
        est = dataclasses.replace(log.estimation)
        object.__setattr__(est, "localiser", loc)
        object.__setattr__(log, "estimation", est)
    return dataclasses.replace(result, runs={RunKind.CLOSED_LOOP: dataclasses.replace(run, log=log)})


@pytest.mark.parametrize("where", ["log.scan", "estimation.localiser"])
def test_a_scan_in_the_run_log_is_published_with_its_frame(job: tuple[Any, Path], tmp_path: Path, where: str) -> None:
    from rosbags.highlevel import AnyReader

    result, _ = job
    k, beams = 7, 360
    ranges = np.linspace(0.2, 3.0, k * beams).reshape(k, beams)
    ranges[0, 5], ranges[1, 7] = np.inf, -np.inf  # REP 117: nothing within range, too close
    t = np.linspace(0.0, 1.2, k)
    path = write_job_bag(_with_scan(result, where, ranges, t), tmp_path / "scan").path
    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.topic == "/closed_loop/scan"]
        assert [c.msgtype for c in conns] == ["sensor_msgs/msg/LaserScan"]
        got = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]
        static = next(reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/tf_static")
    assert len(got) == k
    assert got[3].header.frame_id == "closed_loop/base_scan"
    lag = float(result.logs[RunKind.CLOSED_LOOP].meta["timestep_s"]) if where == "estimation.localiser" else 0.0
    assert got[3].header.stamp.sec * 10**9 + got[3].header.stamp.nanosec == round((t[3] - lag) * 1e9)  # cast
    np.testing.assert_array_equal(got[3].ranges, ranges[3].astype(np.float32))
    assert got[0].ranges[5] == np.inf and got[1].ranges[7] == -np.inf
    assert got[0].angle_max == pytest.approx(2 * math.pi * 359 / 360)
    assert got[0].scan_time == pytest.approx(0.2) and got[0].range_max == pytest.approx(3.5)
    scan_tf = [x for x in static.transforms if x.child_frame_id == "closed_loop/base_scan"]
    assert len(scan_tf) == 1 and scan_tf[0].transform.translation.z == pytest.approx(0.172)  # the URDF's


def test_an_existing_bag_is_kept_without_overwrite_and_replaced_with_it(job: tuple[Any, Path], tmp_path: Path) -> None:
    result, _ = job
    target = _old_bag(tmp_path / "b")
    with pytest.raises(OutputExistsError, match="--overwrite"):
        write_job_bag(result, target)
    assert (target / "metadata.yaml").read_text() == OLD_META
    write_job_bag(result, target, overwrite=True)
    assert "rosbag2_bagfile_information" in (target / "metadata.yaml").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b"]  # no temporary folder left
    write_job_bag(result, target, overwrite=True)  # the bag just written is one of ours: replaced again
    other = tmp_path / "notes"
    other.mkdir()
    (other / "keep.txt").write_text("mine")
    for overwrite in (False, True):  # not "pass --overwrite": it would not replace it either
        with pytest.raises(ConfigError, match="not a bag") as err:
            write_job_bag(result, other, overwrite=overwrite)
        assert "pass --overwrite" not in without_python(str(err.value)) and "move it away" in str(err.value)
    assert (other / "keep.txt").read_text() == "mine"


def test_a_written_bag_carries_the_mark_and_lists_its_files(job: tuple[Any, Path]) -> None:
    """What tells a bag nhsim wrote from any other (:func:`sim.io.bag.not_ours`): the mark in metadata.yaml's
    custom_data, and nothing in the folder but the metadata and the storage files it lists."""
    from sim.io.bag import MARK, not_ours

    _, path = job
    info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["custom_data"] == {MARK[0]: MARK[1]}
    assert sorted(p.name for p in path.iterdir()) == sorted(["metadata.yaml", *info["relative_file_paths"]])
    assert not_ours(path) == ""


@pytest.mark.parametrize(
    ("meta", "extra", "said"),
    [
        (
            "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n  ros_distro: humble\n",
            {"realbag_0.db3": "precious robot data", "NOTES.txt": "my notes"},
            "it looks like a bag not written by nhsim (its metadata.yaml has no custom_data mark 'nhsim.writer: nhsim'",
        ),
        ("not: [yaml", {"x.mcap": "data"}, "it looks like a bag not written by nhsim"),
        (
            "rosbag2_bagfile_information:\n  custom_data:\n    nhsim.writer: other\n  relative_file_paths: [b.mcap]\n",
            {"b.mcap": "data"},
            "it looks like a bag not written by nhsim",
        ),
        (None, {"NOTES.txt": "my notes"}, "it is a bag nhsim wrote, but it also holds NOTES.txt, which nhsim did not"),
    ],
    ids=["ros2-recording", "broken-metadata", "other-mark", "ours-with-notes"],
)
def test_a_folder_that_is_not_exactly_a_bag_nhsim_wrote_survives_overwrite(
    job: tuple[Any, Path], tmp_path: Path, meta: str | None, extra: dict[str, str], said: str
) -> None:
    """A robot's recording (its metadata.yaml, .db3 and notes) was deleted by ``--overwrite`` because it held a
    metadata.yaml; now only a folder marked by nhsim and holding nothing else is replaced."""
    result, _ = job
    target = _old_bag(tmp_path / "b") if meta is None else tmp_path / "b"
    if meta is not None:
        target.mkdir()
        (target / "metadata.yaml").write_text(meta)
    for name, text in extra.items():
        (target / name).write_text(text)
    before = {p.name: p.read_text() for p in target.iterdir()}
    for overwrite in (False, True):
        with pytest.raises(ConfigError) as err:
            write_job_bag(result, target, overwrite=overwrite)
        text = without_python(str(err.value))
        assert f"cannot write the bag {target}: {said}" in text, text
        assert "--overwrite replaces only a bag nhsim wrote" in text and "move it away" in text
        assert "pass --overwrite" not in text
    assert {p.name: p.read_text() for p in target.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b"]


def test_an_interrupted_write_leaves_nothing(
    job: tuple[Any, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    result, _ = job
    from rosbags.rosbag2 import Writer

    calls = {"n": 0}
    real = Writer.write

    def failing(self: Any, *args: Any) -> None:  # Ctrl-C amid the messages
        calls["n"] += 1
        if calls["n"] > 500:
            raise KeyboardInterrupt
        real(self, *args)

    monkeypatch.setattr(Writer, "write", failing)
    with pytest.raises(KeyboardInterrupt):
        write_job_bag(result, tmp_path / "cut")
    assert list(tmp_path.iterdir()) == []


def test_an_interrupt_as_the_work_folder_is_made_leaves_nothing(
    job: tuple[Any, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A signal landing just after ``mkdtemp`` made the bag's work folder, before its name is kept: the
    interrupt waits until it is, so the folder is removed."""
    import signal
    import tempfile

    result, _ = job
    real = tempfile.mkdtemp

    def made_then_interrupted(*args: Any, **kwargs: Any) -> str:
        made = real(*args, **kwargs)
        signal.raise_signal(signal.SIGINT)  # Python's own handler: KeyboardInterrupt at once
        return made

    monkeypatch.setattr(tempfile, "mkdtemp", made_then_interrupted)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with pytest.raises(KeyboardInterrupt):
        write_job_bag(result, tmp_path / "cut")
    assert list(tmp_path.iterdir()) == []

    def work_then_interrupted(*args: Any, **kwargs: Any) -> str:  # the work folder's, not the checker's
        return made_then_interrupted(*args, **kwargs) if kwargs.get("suffix") == ".part" else real(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkdtemp", work_then_interrupted)
    with pytest.raises(KeyboardInterrupt):  # into folders that do not exist yet: they go too
        write_job_bag(result, tmp_path / "new" / "deeper" / "cut")
    assert list(tmp_path.iterdir()) == []


def test_the_foxglove_layout_names_only_topics_and_fields_a_bag_has(job: tuple[Any, Path]) -> None:
    import json

    from rosbags.highlevel import AnyReader

    result, path = job
    layout = json.loads((Path(__file__).resolve().parents[1] / "docs" / "foxglove" / "nhsim-bag.json").read_text())
    panels = layout["configById"]
    shown = set(panels["3D!nhsim"]["topics"])
    plotted = [p["value"] for key, panel in panels.items() if key.startswith("Plot!") for p in panel["paths"]]
    _, msgs, _ = read_rosbags(path)
    assert shown <= set(msgs)  # the TurtleBot3 has its lidar: its closed loop's scan is there too
    assert "/closed_loop/scan" in shown
    assert {f"/{kind}/robot" for kind in result.logs} <= shown  # the three robots
    with AnyReader([path]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
    for value in plotted:  # each plotted field exists and is a number
        topic, *fields = value.split(".")
        node = msgs[topic][0][1]
        for name in fields:
            node = getattr(node, name)
        assert isinstance(node, float), (value, types[topic])
    assert {v.split(".")[0].split("/")[1] for v in plotted} == {str(k) for k in result.logs}


def test_a_revolution_begun_before_the_run_keeps_its_beams_from_time_zero(
    job: tuple[Any, Path], tmp_path: Path
) -> None:
    from rosbags.highlevel import AnyReader

    result, _ = job
    ranges = np.linspace(0.2, 3.0, 3 * 360).reshape(3, 360)
    t = np.array([-0.1, 0.1, 0.3])  # the first centred on t = 0: half of it before the run
    path = write_job_bag(_with_scan(result, "log.scan", ranges, t), tmp_path / "early").path
    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.topic == "/closed_loop/scan"]
        got = [(s, reader.deserialize(raw, c.msgtype)) for c, s, raw in reader.messages(connections=conns)]
    (s0, first), (s1, second) = got[0], got[1]
    step = 2 * math.pi / 360
    assert s0 == 0 and first.header.stamp.sec == 0 and first.header.stamp.nanosec == 0
    assert first.angle_min == pytest.approx(180 * step) and first.angle_max == pytest.approx(359 * step)
    np.testing.assert_array_equal(first.ranges, ranges[0, 180:].astype(np.float32))
    assert s1 == round(0.1e9) and second.angle_min == 0.0 and second.ranges.size == 360


def test_obstacles_not_on_the_map_are_drawn_apart_and_left_off_the_map(job: tuple[Any, Path]) -> None:
    from planning.core.world import OBSTACLE_HEIGHT, Box, Circle
    from sim.io.bag import job_topics
    from sim.io.bag_topics import OBSTACLE_COLOUR, UNMAPPED_COLOUR
    from sim.physics.model import build_model

    result, _ = job
    hidden = (Box((0.4, 0.5), (0.3, 0.2), 0.3, height=0.1), Circle((0.2, -0.4), 0.1))  # one below the scan plane
    scenario = dataclasses.replace(result.prepared.scenario, unmapped=hidden)
    topics = {tp.name: tp for tp in job_topics(dataclasses.replace(result.prepared, scenario=scenario), result.logs)}
    markers = topics["/obstacles"].make(0).markers  # type: ignore[misc]
    mapped = [x for x in markers if x.ns == "obstacles"]
    unmapped = [x for x in markers if x.ns == "unmapped"]
    assert len(mapped) == len(scenario.world.obstacles) + 1  # and the walls
    assert [(x.id, x.type) for x in unmapped] == [(0, 1), (1, 3)]  # a cube, a cylinder
    assert (unmapped[0].pose.position.x, unmapped[0].pose.position.y) == (0.4, 0.5)
    assert (unmapped[0].scale.x, unmapped[0].scale.y) == (0.3, 0.2) and unmapped[1].scale.x == pytest.approx(0.2)
    # as tall as the physics builds them (the scanner sees what is drawn): the box's geom's half height
    built = build_model(result.prepared.robot, dataclasses.replace(scenario.world, obstacles=hidden)).model
    box = next(
        g
        for g in range(built.ngeom)
        if built.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX and built.geom_size[g][0] == 0.15
    )
    assert unmapped[0].scale.z == pytest.approx(2 * built.geom_size[box][2]) == pytest.approx(0.1)
    assert unmapped[1].scale.z == pytest.approx(OBSTACLE_HEIGHT) and unmapped[1].pose.position.z == OBSTACLE_HEIGHT / 2
    colours = {(x.color.r, x.color.g, x.color.b, x.color.a) for x in unmapped}
    assert colours == {UNMAPPED_COLOUR} and all(
        (x.color.r, x.color.g, x.color.b, x.color.a) == OBSTACLE_COLOUR for x in mapped[:-1]
    )
    grid = topics["/map"].make(0)  # type: ignore[misc]
    res, w = grid.info.resolution, grid.info.width
    ox, oy = grid.info.origin.position.x, grid.info.origin.position.y
    cell = int((0.5 - oy) / res) * w + int((0.4 - ox) / res)
    assert grid.data[cell] == 0  # the map the planner and the localiser use does not hold them


def test_the_imu_reads_what_the_robots_gyro_and_accelerometer_measured(job: tuple[Any, Path]) -> None:
    """The gyro reading at period k is the heading change over the period (from the estimator's record of
    the true pose by period) over its length plus the seed's gyro error at k, as the estimator was fed."""
    from sim.physics.sensors import SensorModel

    result, path = job
    _, msgs, _ = read_rosbags(path)
    setup = result.prepared.case.sensing(result.prepared.scenario)
    log = result.logs[RunKind.CLOSED_LOOP]
    est, rate = log.estimation, log.meta["control_rate_hz"]
    n = est.t.size
    sensors = SensorModel(setup.profile, control_rate=rate, timestep=0.002, n_periods=n, seed=setup.seed)
    imu = [x for _, x in msgs["/closed_loop/imu"]]
    stamps = np.array([x.header.stamp.sec + 1e-9 * x.header.stamp.nanosec for x in imu])
    ks = np.arange(1, n)
    rows = np.searchsorted(stamps, est.t[ks] - 1e-9)
    true_rate = np.array([_wrap(float(a - b)) for a, b in zip(est.truth[ks, 2], est.truth[ks - 1, 2], strict=True)])
    gyro = np.array([imu[r].angular_velocity.z for r in rows])
    np.testing.assert_allclose(gyro, true_rate * rate + sensors.gyro_error[ks], atol=1e-9)
    assert np.std(gyro - true_rate * rate) > 0.5 * sensors.gyro_white_std  # the noise is there
    accel = np.array([[x.linear_acceleration.x, x.linear_acceleration.y, x.linear_acceleration.z] for x in imu])
    assert np.median(accel[:, 2]) == pytest.approx(9.80665 + sensors.accel_bias[2], abs=4 * sensors.accel_white_std)
    p = setup.profile
    first = imu[0]
    assert first.orientation_covariance[0] == -1.0  # not measured
    assert first.angular_velocity_covariance[8] == pytest.approx(sensors.gyro_white_std**2 + p.gyro_bias_std**2)
    assert imu[-1].angular_velocity_covariance[8] > first.angular_velocity_covariance[8]  # the bias walks
    assert first.linear_acceleration_covariance[0] == pytest.approx(sensors.accel_white_std**2 + p.accel_bias_std**2)


def test_the_imu_noise_is_the_runs_own_seed(job: tuple[Any, Path]) -> None:
    """A run drawn with another noise seed (a compare draw) reads its own gyro noise in the bag."""
    from sim.io.bag import job_topics
    from sim.physics.sensors import SensorModel

    result, _ = job
    setup = result.prepared.case.sensing(result.prepared.scenario)
    log = result.logs[RunKind.CLOSED_LOOP]
    other = dataclasses.replace(log, meta={**log.meta, "noise_seed": setup.seed + 7})

    def gyro(run_log: Any) -> np.ndarray:
        topics = job_topics(result.prepared, {RunKind.CLOSED_LOOP: run_log})
        imu = next(tp for tp in topics if tp.name.endswith("/imu"))
        return np.asarray(imu.rows[1]["angular_velocity.z"])  # type: ignore[index]

    n = log.t.size
    k = np.round((log.t - log.t[0]) * log.meta["control_rate_hz"]).astype(int)

    def error(seed: int) -> np.ndarray:
        model = SensorModel(setup.profile, control_rate=50.0, timestep=0.002, n_periods=int(k.max()) + 1, seed=seed)
        return model.gyro_error[k]

    assert log.meta["noise_seed"] == setup.seed and n > 100
    np.testing.assert_allclose(gyro(other) - gyro(log), error(setup.seed + 7) - error(setup.seed), atol=1e-12)


def test_a_scan_fix_carries_the_localisers_own_covariance(job: tuple[Any, Path]) -> None:
    """Each ``/RUN/fix`` of a run on the scan localiser is one of its updates, with the update's whole
    covariance (x, y, yaw and their correlations), not the synthetic fixes' profile variances."""
    result, path = job
    loc = result.logs[RunKind.CLOSED_LOOP].estimation.localiser
    assert loc is not None and loc.t.size > 3
    _, msgs, _ = read_rosbags(path)
    fixes = msgs["/closed_loop/fix"]
    assert len(fixes) == loc.t.size
    axes = np.ix_([0, 1, 5], [0, 1, 5])
    measured = sensed(result.logs[RunKind.CLOSED_LOOP], loc.t)  # the state a physics step before the instant
    for (_, fix), cov, t in zip(fixes, loc.cov, measured, strict=True):
        assert fix.header.stamp.sec + 1e-9 * fix.header.stamp.nanosec == pytest.approx(t, abs=1e-9)
        np.testing.assert_allclose(np.asarray(fix.pose.covariance).reshape(6, 6)[axes], cov, rtol=1e-12, atol=0)
    assert any(abs(cov[0, 1]) > 0 for cov in loc.cov)  # correlations are written, not only variances


def test_a_run_lost_at_its_first_scan_publishes_the_update_it_is_judged_on(tmp_path: Path) -> None:
    """A start pose 3.7 m off: the run ends ("localisation lost") before the first update reaches the estimator.
    The record scores that update (localiser RMSE 3.7 m) but the bag had no ``/fix`` to recompute it from, and
    its one scan said ``scan_time`` 0 (the period was taken between scans): one fix, and 0.2 s, the LDS-01's."""
    from planning import load_scenario
    from sim.pipeline.simulate import simulate_reference

    one = (RunKind.CLOSED_LOOP,)
    result = simulate_reference(
        load_scenario("random8"), reference="line", robot="turtlebot3", runs=one, initial_pose="0.3,0.2,0.3"
    )
    log = result.logs[RunKind.CLOSED_LOOP]
    loc = log.estimation.localiser
    assert "localisation lost" in result.runs[RunKind.CLOSED_LOOP].metrics.status
    assert loc.t.size == 1 and log.estimation.fix_t.size == 0  # judged on, never delivered
    _, msgs, _ = read_rosbags(write_job_bag(result, tmp_path / "b").path)
    (_, fix), (_, scan) = msgs["/closed_loop/fix"][0], msgs["/closed_loop/scan"][0]
    assert len(msgs["/closed_loop/fix"]) == 1 and len(msgs["/closed_loop/scan"]) == 1
    assert (fix.pose.pose.position.x, fix.pose.pose.position.y) == tuple(loc.pose[0, :2])
    assert scan.scan_time == pytest.approx(0.2, rel=1e-7)  # float32


@pytest.mark.parametrize("robot", ["turtlebot3", "edumip", "edumip-balancing"])
def test_the_imu_frame_is_the_models_imu_site(robot: str) -> None:
    """``base_link -> imu_link`` in /tf_static is where the robot's model puts its IMU (site ``imu`` on the
    base body), read from the compiled model: on the TurtleBot3 32 mm behind and 45 mm above the axle,
    68 mm above base_link (the URDF's), not at base_link (it was the identity)."""
    import mujoco

    from planning.core.robot import robot_path
    from sim.io.bag_topics import skeleton, static_transforms

    model = mujoco.MjModel.from_xml_path(str(robot_path(robot)))
    site = model.site("imu")
    assert model.body(int(model.site_bodyid[site.id])).name == "base"
    tfs = {x.child_frame_id: x for x in static_transforms(["run"], skeleton(robot)).transforms}
    imu = tfs["run/imu_link"]
    assert imu.header.frame_id == "run/base_link"
    got = imu.transform.translation
    link = model.site("base_link").pos if robot == "turtlebot3" else np.zeros(3)
    np.testing.assert_allclose([got.x, got.y, got.z], site.pos - link, rtol=0, atol=1e-12)
    q = imu.transform.rotation
    np.testing.assert_allclose([q.w, q.x, q.y, q.z], site.quat, rtol=0, atol=1e-12)
    if robot == "turtlebot3":
        np.testing.assert_allclose(site.pos, [-0.032, 0.0, 0.045])


#: The TurtleBot3 Burger's fixed frames in ROBOTIS's turtlebot3_description (urdf/turtlebot3_burger.urdf):
#: each joint's origin in its parent, base_footprint -> base_link and base_link -> the others [m].
URDF_FRAMES = {
    "base_link": (0.0, 0.0, 0.010),
    "imu_link": (-0.032, 0.0, 0.068),
    "base_scan": (-0.032, 0.0, 0.172),
    "wheel_left_link": (0.0, 0.08, 0.023),
    "wheel_right_link": (0.0, -0.08, 0.023),
}


def test_the_turtlebot3s_frames_are_its_urdfs(job: tuple[Any, Path]) -> None:
    """A bag played beside ``robot_state_publisher`` and the TurtleBot3's URDF must not contradict it: its
    base_link was the model's base body, at the axle, 33 mm above the floor (URDF: 10 mm), so base_scan sat
    149 mm above it (URDF: 172 mm) and the IMU 45 mm (68 mm). The static frames and, on the floor,
    base_footprint -> base_link are the URDF's to the millimetre (the tyres' sink and the body's pitch)."""
    from sim.io.bag_topics import skeleton, static_transforms

    sk = skeleton("turtlebot3")
    tfs = {x.child_frame_id: x.transform.translation for x in static_transforms(["run"], sk).transforms}
    for name in ("imu_link", "base_scan"):
        got = tfs[f"run/{name}"]
        np.testing.assert_allclose([got.x, got.y, got.z], URDF_FRAMES[name], atol=1e-9)
    np.testing.assert_allclose(sk.wheel_pos, [URDF_FRAMES["wheel_left_link"], URDF_FRAMES["wheel_right_link"]])
    _, msgs, _ = read_rosbags(job[1])
    lifts = np.array(
        [
            (tf.transform.translation.x, tf.transform.translation.z)
            for _, x in run_tf(msgs, "closed_loop")
            for tf in x.transforms
            if tf.child_frame_id == "closed_loop/base_link"
        ]
    )
    assert lifts.shape[0] > 100
    np.testing.assert_allclose(lifts[:, 1], URDF_FRAMES["base_link"][2], atol=1.5e-3)
    np.testing.assert_allclose(lifts[:, 0], 0.0, atol=1.5e-3)


#: The metadata of an old bag nhsim wrote (its mark, its one storage file), as :func:`sim.io.bag._write` leaves it.
OLD_META = (
    "rosbag2_bagfile_information:\n  version: 8\n  custom_data:\n    nhsim.writer: nhsim\n"
    "  relative_file_paths:\n  - old.mcap\n"
)


def _old_bag(folder: Path) -> Path:
    """A bag nhsim wrote earlier (marked), which ``--overwrite`` replaces."""
    folder.mkdir()
    (folder / "metadata.yaml").write_text(OLD_META)
    (folder / "old.mcap").write_text("old messages")
    return folder


def test_a_failed_swap_puts_the_old_bag_back(
    job: tuple[Any, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--overwrite moves the old bag aside, then the new one in: when the second move fails the old bag is
    back under its name (it was left in the work folder and removed with it)."""
    import os

    result, _ = job
    target = _old_bag(tmp_path / "b")
    real = os.replace

    def failing(src: Any, dst: Any) -> None:
        if Path(dst) == target and Path(src).name != "replaced":  # the new bag moving in
            raise OSError("disk gone")
        real(src, dst)

    monkeypatch.setattr(os, "replace", failing)
    with pytest.raises(OSError, match="disk gone"):
        write_job_bag(result, target, overwrite=True)
    assert (target / "metadata.yaml").read_text() == OLD_META and (target / "old.mcap").read_text() == "old messages"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b"]  # no work folder left


def test_an_interrupt_between_the_two_moves_waits_for_the_new_bag(
    job: tuple[Any, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A Ctrl-C landing after the old bag was moved aside acts once the new one is in place: the bag folder
    always holds a complete bag (it held neither)."""
    import os
    import signal

    result, _ = job
    target = _old_bag(tmp_path / "b")
    real = os.replace

    def interrupted(src: Any, dst: Any) -> None:
        real(src, dst)
        if Path(src) == target:  # the old bag just moved aside
            signal.raise_signal(signal.SIGINT)

    monkeypatch.setattr(os, "replace", interrupted)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with pytest.raises(KeyboardInterrupt):
        write_job_bag(result, target, overwrite=True)
    assert "rosbag2_bagfile_information" in (target / "metadata.yaml").read_text()
    assert not (target / "old.mcap").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b"]
    _, msgs, _ = read_rosbags(target)
    assert {k: len(v) for k, v in msgs.items()} == expected_counts(result)


#: A room (3 x 2 m, one box 2.2-2.6 x 1.35-1.65 m): every face on the 5 cm lattice of the bounds.
ROOM = ((0.0, 3.0, 0.0, 2.0), ((2.4, 1.5), (0.4, 0.3)))


def _grid(world: Any) -> tuple[np.ndarray, float, float, float]:
    """``/map`` of ``world`` as (H, W) occupancy, resolution and origin (x, y)."""
    msg = bt.map_message(world)
    info = msg.info
    grid = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
    return grid, float(info.resolution), float(info.origin.position.x), float(info.origin.position.y)


def test_the_maps_cell_edges_fall_on_the_walls_faces() -> None:
    """The grid's origin was 0.05 m (the walls' thickness) outside the bounds with 0.02 m cells: each wall face ran
    through the middle of a cell, and the half-covered cells were drawn as wall (a 1 cm bias). Now the walls are
    whole cells (0.025 m, the localiser's grid): each face lies between a wall cell and a free one, as does each
    face of an obstacle on the 5 cm lattice."""
    from planning.core.world import Box, World

    world = World(ROOM[0], (Box(*ROOM[1]),))
    grid, res, ox, oy = _grid(world)
    assert res == pytest.approx(0.025) and (ox, oy) == pytest.approx((-0.05, -0.05), abs=1e-9)
    col = {x: (x - ox) / res for x in (0.0, 3.0, 2.2, 2.6)}
    row = {y: (y - oy) / res for y in (0.0, 2.0, 1.35, 1.65)}
    for edge in (*col.values(), *row.values()):
        assert edge == pytest.approx(round(edge), abs=1e-6)  # on an edge, not mid-cell
    mid_y, mid_x = round((1.0 - oy) / res), round((1.0 - ox) / res)  # a row and a column through free space
    c0, c3, r0, r2 = round(col[0.0]), round(col[3.0]), round(row[0.0]), round(row[2.0])
    assert (grid[mid_y, c0 - 1], grid[mid_y, c0], grid[mid_y, c3 - 1], grid[mid_y, c3]) == (100, 0, 0, 100)
    assert (grid[r0 - 1, mid_x], grid[r0, mid_x], grid[r2 - 1, mid_x], grid[r2, mid_x]) == (100, 0, 0, 100)
    box_y = round((1.5 - oy) / res)  # the box's faces x = 2.2 and 2.6 in its middle row
    b0, b1 = round(col[2.2]), round(col[2.6])
    assert (grid[box_y, b0 - 1], grid[box_y, b0], grid[box_y, b1 - 1], grid[box_y, b1]) == (0, 100, 100, 0)
    box_x, c0, c1 = round((2.4 - ox) / res), round(row[1.35]), round(row[1.65])  # its faces y = 1.35 and 1.65
    assert (grid[c0 - 1, box_x], grid[c0, box_x], grid[c1 - 1, box_x], grid[c1, box_x]) == (0, 100, 100, 0)
    assert grid.shape == (80 + 4, 120 + 4)  # 2 wall cells beyond each bound
    big = World((-1.0, 39.0, 0.5, 40.5))  # coarser cells (a million at most): the walls still whole cells
    res, pad, w, h = bt.map_layout(big)
    assert res == pytest.approx(0.041) and pad == 2 and w * h <= bt.MAP_MAX_CELLS
    assert bt.map_origin(big) == pytest.approx((-1.0 - 2 * res, 0.5 - 2 * res))


def _true_range(o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Distance along rays (N, 2) from ``o`` (N, 2) to the room's walls or box (slabs; axis-aligned)."""
    (x0, x1, y0, y1), ((cx, cy), (sx, sy)) = ROOM
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(d[:, 0] > 0, (x1 - o[:, 0]) / d[:, 0], (x0 - o[:, 0]) / d[:, 0])
        ty = np.where(d[:, 1] > 0, (y1 - o[:, 1]) / d[:, 1], (y0 - o[:, 1]) / d[:, 1])
        walls = np.minimum(np.where(np.isfinite(tx), tx, np.inf), np.where(np.isfinite(ty), ty, np.inf))
        lo = (np.array([cx - sx / 2, cy - sy / 2]) - o) / d
        hi = (np.array([cx + sx / 2, cy + sy / 2]) - o) / d
    near = np.nan_to_num(np.minimum(lo, hi), nan=-np.inf).max(axis=1)
    far = np.nan_to_num(np.maximum(lo, hi), nan=np.inf).min(axis=1)
    box = np.where((near <= far) & (near > 0), near, np.inf)
    return np.minimum(walls, box)


def test_ranges_marched_on_the_map_match_the_world_without_bias() -> None:
    """An independent check of the map without the simulation: rays from free points, marched through ``/map``
    in 0.2 mm steps to the first occupied cell, against the exact distance to the world's faces. With the faces
    mid-cell the median was -10.5 mm (the walls drawn 1 cm thick); now it is within a fraction of a millimetre."""
    from planning.core.world import Box, World

    world = World(ROOM[0], (Box(*ROOM[1]),))
    grid, res, ox, oy = _grid(world)
    rng = np.random.default_rng(3)
    o = rng.uniform([0.2, 0.2], [2.0, 1.8], size=(400, 2))
    a = rng.uniform(-np.pi, np.pi, 400)
    d = np.column_stack([np.cos(a), np.sin(a)])
    truth = _true_range(o, d)
    steps = np.arange(0.0, 4.0, 0.0002)
    px, py = o[:, :1] + steps * d[:, :1], o[:, 1:] + steps * d[:, 1:]
    ci, ri = np.floor((px - ox) / res).astype(int), np.floor((py - oy) / res).astype(int)
    inside = (ci >= 0) & (ci < grid.shape[1]) & (ri >= 0) & (ri < grid.shape[0])
    hit = ~inside | (grid[np.clip(ri, 0, grid.shape[0] - 1), np.clip(ci, 0, grid.shape[1] - 1)] > 50)
    marched = steps[np.argmax(hit, axis=1)]
    err = truth - marched
    assert abs(float(np.median(err))) < 0.5e-3, np.median(err)
    assert np.mean(np.abs(err) < 1e-3) > 0.95  # the rays end on the faces themselves (not half a cell short)


def test_the_truths_velocity_is_second_order_at_the_ends_too() -> None:
    """A robot starting from rest with a constant acceleration reads 0 at its first sample and the exact speed at its
    last; the first-order end read the first interval's mean (0.0013 m/s at rest in a run's ground truth)."""
    t = np.sort(np.concatenate([[0.0, 3.0], np.random.default_rng(2).uniform(0.0, 3.0, 40)]))  # uneven spacing
    s, th = 0.25 * t**2, 0.1 * t**2  # along x at 0.5 m/s^2, the heading turning at 0.2 t rad/s (quadratics)
    pose = np.column_stack([s, np.zeros_like(s), th])
    vel = bt.planar_velocity(t, pose)
    assert abs(vel[0, 0]) < 1e-12 and abs(vel[0, 2]) < 1e-12  # at rest
    assert vel[-1, 2] == pytest.approx(0.2 * 3.0, abs=1e-12)
    assert np.hypot(vel[-1, 0], vel[-1, 1]) == pytest.approx(0.5 * 3.0, abs=1e-12)
