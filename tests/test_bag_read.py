"""Reading plans and recorded motion from bags written by other tools (the ``mcap`` library's own ROS 2
writer, a sqlite3 rosbag2 folder, a ROS 1 bag), and every bad bag or topic: exit 2 naming the problem
and the fix, nothing written, no traceback."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planning.trajectory.bag_file import TF_TOPICS, read_bag_table
from planning.trajectory.file_formats import TrajectoryFileError
from planning.trajectory.importer import TrajectoryFile, read_trajectory_file
from sim.cli.main import main

#: The ROS 2 message definitions a recorder stores in an MCAP schema (ros2msg: the type, then each
#: dependency after a line of '='), as ros2 bag record writes them.
_SEP = "=" * 80
_TIME = "int32 sec\nuint32 nanosec"
_HEADER = "builtin_interfaces/Time stamp\nstring frame_id"
_POSE = "Point position\nQuaternion orientation"
_POINT = "float64 x\nfloat64 y\nfloat64 z"
_QUAT = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1"
_DEPS = (
    f"{_SEP}\nMSG: std_msgs/Header\n{_HEADER}\n{_SEP}\nMSG: builtin_interfaces/Time\n{_TIME}\n"
    f"{_SEP}\nMSG: geometry_msgs/Pose\n{_POSE}\n{_SEP}\nMSG: geometry_msgs/Point\n{_POINT}\n"
    f"{_SEP}\nMSG: geometry_msgs/Quaternion\n{_QUAT}\n"
)
POSE_STAMPED_DEF = f"std_msgs/Header header\ngeometry_msgs/Pose pose\n{_DEPS}"
PATH_DEF = (
    f"std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n{_SEP}\nMSG: geometry_msgs/PoseStamped\n"
    f"std_msgs/Header header\ngeometry_msgs/Pose pose\n{_DEPS}"
)
EPOCH = 1_700_000_000  # a real recording's stamps are wall-clock seconds


def _stamped(t: float, x: float, y: float, yaw: float) -> dict[str, Any]:
    sec = math.floor(t)
    return {
        "header": {"stamp": {"sec": EPOCH + sec, "nanosec": round((t - sec) * 1e9)}, "frame_id": "map"},
        "pose": {
            "position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)},
        },
    }


def arc(n: int = 41, duration: float = 8.0) -> tuple[np.ndarray, np.ndarray]:
    """(t (n,), poses (n, 3)): a quarter circle of radius 1 m driven at constant speed, headings along it."""
    t = np.linspace(0.0, duration, n)
    a = 0.5 * np.pi * t / duration
    return t, np.column_stack([np.sin(a), 1.0 - np.cos(a), a])


def mcap_bag(path: Path) -> Path:
    """An MCAP file written by the mcap library's ROS 2 writer: two plans on /plan (the second the arc)
    and the arc's poses on /pose as geometry_msgs/PoseStamped."""
    from mcap_ros2.writer import Writer

    t, poses = arc()
    with path.open("wb") as f:
        writer = Writer(f)
        plan = writer.register_msgdef("nav_msgs/msg/Path", PATH_DEF)
        pose = writer.register_msgdef("geometry_msgs/msg/PoseStamped", POSE_STAMPED_DEF)
        first = [_stamped(0.0, 0.5 * k, 0.0, 0.0) for k in range(3)]
        writer.write_message("/plan", plan, {"header": first[0]["header"], "poses": first}, log_time=EPOCH * 10**9)
        poses_msgs = [_stamped(0.0, *p) for p in poses]
        msg = {"header": poses_msgs[0]["header"], "poses": poses_msgs}
        writer.write_message("/plan", plan, msg, log_time=EPOCH * 10**9 + 1)
        for tk, p in zip(t, poses, strict=True):
            ns = EPOCH * 10**9 + round(tk * 1e9)
            writer.write_message("/pose", pose, _stamped(float(tk), *p), log_time=ns, publish_time=ns)
        writer.finish()
    return path


def test_a_plan_from_the_mcap_librarys_writer_is_read_last_or_by_index(tmp_path: Path) -> None:
    bag = mcap_bag(tmp_path / "other.mcap")
    _, poses = arc()
    last = read_bag_table(bag, "/plan", timed=False)
    np.testing.assert_allclose(last.columns["x"], poses[:, 0], atol=1e-12)
    np.testing.assert_allclose(last.columns["theta"], poses[:, 2], atol=1e-12)
    assert "t" not in last.columns  # all poses stamped alike: no clock
    first = read_bag_table(bag, "/plan", 0, timed=False)
    np.testing.assert_allclose(first.columns["x"], [0.0, 0.5, 1.0])
    assert first.rows[2] == "/plan message 0 poses[2]"


def test_a_recorded_motion_keeps_its_clock_through_the_import(tmp_path: Path) -> None:
    bag = mcap_bag(tmp_path / "other.mcap")
    t, poses = arc()
    imported = read_trajectory_file(TrajectoryFile(bag, timed=True, topic="/pose"))
    assert imported.t is not None
    np.testing.assert_allclose(imported.t, t, atol=2e-9)  # counted from the first stamp
    np.testing.assert_allclose(imported.xy, poses[:, :2], atol=1e-12)
    assert imported.report.fmt == "bag topic /pose, geometry_msgs/PoseStamped"
    assert imported.report.rows_read == t.size


#: A transform on a bag's /tf or /tf_static: (stamp [s], parent, child, x, y, yaw).
Transform = tuple[float, str, str, float, float, float]


def _rosbags_bag(
    path: Path,
    *,
    ros1: bool,
    logged: list[int] | None = None,
    second_type: bool = False,
    tf: Sequence[Transform] = (),
    tf_static: Sequence[Transform] = (),
) -> Path:
    """The arc as nav_msgs/Odometry on /odom (with its twist), written by rosbags as a sqlite3 rosbag2
    folder or a ROS 1 bag; ``logged``: the order the messages are logged in (their stamps unchanged);
    ``second_type``: a geometry_msgs/PoseStamped publisher on /odom too; ``tf``, ``tf_static``: transforms,
    one message each."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if "tf2_msgs/msg/TFMessage" not in store.types:  # ROS 1 Noetic's store lacks it: tf2_msgs/TFMessage's text
        store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    ty = store.types
    t, poses = arc()
    speed = 0.5 * np.pi / t[-1]
    msgs = []
    for tk, p in zip(t, poses, strict=True):
        stamp = ty["builtin_interfaces/msg/Time"](sec=EPOCH + int(tk), nanosec=round((tk % 1) * 1e9))
        head = {"stamp": stamp, "frame_id": "odom", **({"seq": 0} if ros1 else {})}
        pose = ty["geometry_msgs/msg/Pose"](
            position=ty["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=0.0),
            orientation=ty["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(p[2] / 2), w=math.cos(p[2] / 2)),
        )
        vec = ty["geometry_msgs/msg/Vector3"]
        tw = ty["geometry_msgs/msg/Twist"](linear=vec(x=speed, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=speed))
        msgs.append(
            (
                int(tk * 1e9),
                ty["nav_msgs/msg/Odometry"](
                    header=ty["std_msgs/msg/Header"](**head),
                    child_frame_id="base_footprint",
                    pose=ty["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                    twist=ty["geometry_msgs/msg/TwistWithCovariance"](twist=tw, covariance=np.zeros(36)),
                ),
            )
        )
    transforms = []
    for topic, given in (("/tf", tf), ("/tf_static", tf_static)):
        for tk, parent, child, x, y, yaw in given:
            stamp = ty["builtin_interfaces/msg/Time"](sec=EPOCH + int(tk), nanosec=round((tk % 1) * 1e9))
            head = {"stamp": stamp, "frame_id": ("/" if ros1 else "") + parent, **({"seq": 0} if ros1 else {})}
            vec, quat = ty["geometry_msgs/msg/Vector3"], ty["geometry_msgs/msg/Quaternion"]
            one = ty["geometry_msgs/msg/TransformStamped"](
                header=ty["std_msgs/msg/Header"](**head),
                child_frame_id=child,
                transform=ty["geometry_msgs/msg/Transform"](
                    translation=vec(x=x, y=y, z=0.0),
                    rotation=quat(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)),
                ),
            )
            transforms.append((topic, int(tk * 1e9), ty["tf2_msgs/msg/TFMessage"](transforms=[one])))
    if ros1:
        from rosbags.rosbag1 import Writer as Writer1

        with Writer1(path) as w1:
            conn = w1.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
            for ns, msg in msgs:
                w1.write(conn, EPOCH * 10**9 + ns, store.serialize_ros1(msg, "nav_msgs/msg/Odometry"))
            conns1 = {
                t: w1.add_connection(t, "tf2_msgs/msg/TFMessage", typestore=store) for t in TF_TOPICS if transforms
            }
            for topic, ns, msg in transforms:
                w1.write(conns1[topic], EPOCH * 10**9 + ns, store.serialize_ros1(msg, "tf2_msgs/msg/TFMessage"))
        return path
    from rosbags.rosbag2 import StoragePlugin, Writer

    with Writer(path, version=8, storage_plugin=StoragePlugin.SQLITE3) as w2:
        conn = w2.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        for k, i in enumerate(logged or range(len(msgs))):  # logged at the k-th message's time, stamped its own
            w2.write(conn, EPOCH * 10**9 + msgs[k][0], store.serialize_cdr(msgs[i][1], "nav_msgs/msg/Odometry"))
        if transforms:
            conns2 = {topic: w2.add_connection(topic, "tf2_msgs/msg/TFMessage", typestore=store) for topic in TF_TOPICS}
            for topic, ns, msg in transforms:
                w2.write(conns2[topic], EPOCH * 10**9 + ns, store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
        if second_type:
            other = w2.add_connection("/odom", "geometry_msgs/msg/PoseStamped", typestore=store)
            pose = ty["geometry_msgs/msg/PoseStamped"](header=msgs[0][1].header, pose=msgs[0][1].pose.pose)
            w2.write(other, EPOCH * 10**9, store.serialize_cdr(pose, "geometry_msgs/msg/PoseStamped"))
    return path


@pytest.mark.parametrize("ros1", [False, True], ids=["rosbag2-sqlite3", "ros1-bag"])
def test_odometry_from_a_sqlite3_folder_or_a_ros1_bag(tmp_path: Path, ros1: bool) -> None:
    bag = _rosbags_bag(tmp_path / ("odom.bag" if ros1 else "odom"), ros1=ros1)
    t, poses = arc()
    table = read_bag_table(bag, "/odom", timed=True)
    np.testing.assert_allclose(table.columns["t"], t, atol=2e-9)
    np.testing.assert_allclose(table.columns["y"], poses[:, 1], atol=1e-12)
    np.testing.assert_allclose(table.columns["omega"], 0.5 * np.pi / t[-1])
    imported = read_trajectory_file(TrajectoryFile(bag, timed=True, topic="/odom"))
    assert imported.report.corrections == []  # its twist agrees with its poses: kept


def _moved(pose: np.ndarray, x: float, y: float, yaw: float) -> np.ndarray:
    """(N, 3) poses moved by the planar transform (x, y, yaw)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack([x + c * pose[:, 0] - s * pose[:, 1], y + s * pose[:, 0] + c * pose[:, 1], pose[:, 2] + yaw])


@pytest.mark.parametrize("ros1", [False, True], ids=["rosbag2-sqlite3", "ros1-bag"])
def test_poses_in_odom_are_placed_in_map_by_the_bags_transforms_at_their_stamps(tmp_path: Path, ros1: bool) -> None:
    """A recording in ``odom`` was taken as if in ``map``; the bag's AMCL-style ``map -> site`` (static) and
    ``site -> odom`` (moving, from 2 s) place each pose as tf2 would at its stamp: between two transforms
    linearly, before the first by the first (counted in the report)."""
    t, poses = arc()
    site = (1.0, -0.5, 0.2)
    moving = [(2.0, 0.3, 0.1, -0.4), (6.0, 0.5, 0.05, -0.3)]  # AMCL correcting the odometry's drift
    bag = _rosbags_bag(
        tmp_path / ("odom.bag" if ros1 else "odom"),
        ros1=ros1,
        tf_static=[(0.0, "map", "site", *site)],
        tf=[(tk, "site", "odom", x, y, yaw) for tk, x, y, yaw in moving],
    )
    table = read_bag_table(bag, "/odom", timed=True)
    at = np.column_stack([np.interp(t, [m[0] for m in moving], [m[j] for m in moving]) for j in (1, 2, 3)])
    want = np.array([_moved(_moved(p[None], *a), *site)[0] for p, a in zip(poses, at, strict=True)])
    got = np.column_stack([table.columns[k] for k in ("x", "y", "theta")])
    np.testing.assert_allclose(got, want, atol=1e-9)
    before, after = int(np.sum(t < 2.0)), int(np.sum(t > 6.0))
    assert before > 0 and after > 0
    (note,) = [n for n in table.notes if n.startswith("frame 'odom'")]
    assert note == (
        "frame 'odom': the poses are placed in 'map' by the bag's transforms (map -> site -> odom, at each pose's "
        f"stamp; {before + after} of {t.size} poses lie beyond the transforms' stamps, placed by the nearest)"
    )
    imported = read_trajectory_file(TrajectoryFile(bag, timed=True, topic="/odom"))
    np.testing.assert_allclose(imported.xy, want[:, :2], atol=1e-9)
    assert note in imported.report.notes


def test_without_a_chain_to_map_the_poses_stay_and_the_report_says_why(tmp_path: Path) -> None:
    """Transforms that do not reach ``odom`` from ``map`` (another branch of the tree, a frame given two parents)
    leave the poses as they were read, with the offset to use."""
    _, poses = arc()
    bag = _rosbags_bag(
        tmp_path / "odom",
        ros1=False,
        tf=[
            (0.0, "map", "other", 1.0, 1.0, 0.0),
            (0.0, "site", "odom", 1.0, 0.0, 0.0),
            (1.0, "map", "odom", 1.0, 0.0, 0.0),
        ],
    )
    table = read_bag_table(bag, "/odom", timed=True)
    np.testing.assert_allclose(table.columns["x"], poses[:, 0], atol=1e-12)
    (note,) = [n for n in table.notes if n.startswith("frame 'odom'")]
    # the chain is there, but odom has two parents: said as such (it read "no chain of transforms")
    assert "the bag's /tf gives 'odom' 2 parents ('map' and 'site'), whose transforms are not followed" in note
    assert "--offset" in note
    elsewhere = _rosbags_bag(tmp_path / "other", ros1=False, tf=[(0.0, "map", "other", 1.0, 1.0, 0.0)])
    (note,) = [n for n in read_bag_table(elsewhere, "/odom", timed=True).notes if n.startswith("frame 'odom'")]
    assert "hold no chain of transforms from 'map' to 'odom'" in note and "--offset" in note


# ------------------------------------------------------------------------------------------ bad input
def test_messages_logged_out_of_their_stamps_order_are_read_in_it(tmp_path: Path) -> None:
    """Two messages logged swapped (two publishers, a network) were refused as "time goes back" with a fix for a
    text file (sort the rows), and when the first logged was not the earliest the times shown were negative."""
    t, poses = arc()
    for logged in ([0, 1, 2, 4, 3, *range(5, t.size)], [1, 0, *range(2, t.size)]):
        imported = read_trajectory_file(
            TrajectoryFile(_rosbags_bag(tmp_path / f"odom{logged[0]}", ros1=False, logged=logged), topic="/odom")
        )
        assert imported.t is not None
        np.testing.assert_allclose(imported.t, t, atol=2e-9)
        np.testing.assert_allclose(imported.xy, poses[:, :2], atol=1e-12)
        assert "2 messages of /odom were logged out of their stamps' order" in " ".join(imported.report.notes)


def test_a_topic_of_two_types_is_named_with_both(tmp_path: Path) -> None:
    """rosbags gives a topic of two types no type: the error said "carries , not a path" and named as the fix the
    topic given."""
    bag = _rosbags_bag(tmp_path / "odom", ros1=False, second_type=True)
    with pytest.raises(TrajectoryFileError, match=r"carries 2 types \(geometry_msgs/PoseStamped, nav_msgs/Odometry\)"):
        read_trajectory_file(TrajectoryFile(bag, topic="/odom"))


def _exit_2(argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["simulate", *argv, "--no-video", "--json", str(tmp_path / "out" / "r.json")]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists() and not (tmp_path / "renders").exists()
    return err


def _bad_bags(tmp_path: Path) -> dict[str, Path]:
    good = mcap_bag(tmp_path / "good.mcap")
    data = good.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    text = tmp_path / "notes.mcap"
    text.write_text("t,x,y\n0,0,0\n")
    folder = tmp_path / "folder"
    folder.mkdir()
    from rosbags.rosbag2 import StoragePlugin, Writer

    empty = tmp_path / "empty"
    with Writer(empty, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        from rosbags.typesys import Stores, get_typestore

        w.add_connection("/plan", "nav_msgs/msg/Path", typestore=get_typestore(Stores.ROS2_HUMBLE))
    odom = _rosbags_bag(tmp_path / "odom", ros1=False)  # recorded motion only, no path
    return {"good": good, "cut": cut, "text": text, "folder": folder, "empty": empty, "odom": odom}


@pytest.mark.parametrize(
    ("case", "argv", "said"),
    [
        ("missing", ["--path", "{tmp}/nowhere.mcap", "--topic", "/plan"], "no such file or folder"),
        ("missing folder", ["--path", "{tmp}/no_such_bag", "--topic", "/plan"], "no_such_bag: no such file or folder"),
        ("cut", ["--path", "{cut}", "--topic", "/plan"], "truncated or not a bag"),
        ("text", ["--path", "{text}", "--topic", "/plan"], "truncated or not a bag"),
        ("folder", ["--path", "{folder}", "--topic", "/plan"], "no metadata.yaml"),
        (
            "no topic given",
            ["--path", "{good}"],
            "is a bag: give the topic to read; the bag has /plan (nav_msgs/Path, 2), /pose",
        ),
        ("topic missing", ["--path", "{good}", "--topic", "/odom"], "no topic '/odom'; the bag has /plan"),
        ("wrong type", ["--path", "{good}", "--topic", "/pose"], "carries geometry_msgs/PoseStamped, not a path"),
        (
            "empty",
            ["--path", "{empty}", "--topic", "/plan"],
            "holds no messages; the bag has /plan (nav_msgs/Path, 0): record it again",
        ),
        ("motion only", ["--path", "{odom}"], "it holds no path: read the recorded motion of /odom with --trajectory"),
        (
            "motion only, a path named",
            ["--path", "{odom}", "--topic", "/plan"],
            "no topic '/plan'; the bag has /odom (nav_msgs/Odometry, 41): it holds no path: read the recorded motion",
        ),
        ("message out of range", ["--path", "{good}", "--topic", "/plan", "--message", "5"], "give 0 to 1"),
        ("topic on a text file", ["--path", "{tmp}/a.csv", "--topic", "/plan"], "drop them"),
    ],
)
def test_a_bad_bag_or_topic_exits_2_naming_it(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    case: str,
    argv: list[str],
    said: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.csv").write_text("x,y\n0,0\n1,0\n")
    names = {k: str(v) for k, v in _bad_bags(tmp_path).items()} | {"tmp": str(tmp_path)}
    err = _exit_2([a.format(**names) for a in argv], tmp_path, capsys)
    assert said in err, err


def test_an_existing_bag_folder_stops_the_job_before_it_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    from tests.test_bag import OLD_META

    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "metadata.yaml").write_text(OLD_META)
    err = _exit_2(["--reference", "circle", "--bag", str(tmp_path / "b")], tmp_path, capsys)
    assert "exists already; pass --overwrite" in err
    assert (tmp_path / "b" / "metadata.yaml").read_text() == OLD_META


def test_a_monte_carlo_study_of_a_bag_folder_is_keyed_by_its_files(tmp_path: Path) -> None:
    from sim.tools.montecarlo import _file_key

    folder = _rosbags_bag(tmp_path / "odom", ros1=False)
    key = _file_key(TrajectoryFile(folder, timed=True, topic="/odom"))
    assert key["topic"] == "/odom" and key["message"] is None
    (folder / "metadata.yaml").write_text((folder / "metadata.yaml").read_text() + "\n")
    assert _file_key(TrajectoryFile(folder, timed=True, topic="/odom"))["sha1"] != key["sha1"]
    single = tmp_path / "plan.mcap"
    mcap_bag(single)
    import hashlib

    assert _file_key(TrajectoryFile(single, timed=False))["sha1"] == hashlib.sha1(single.read_bytes()).hexdigest()


def _path_bag(path: Path, topics: dict[str, list[list[tuple[float, float, float, float, float]]]]) -> Path:
    """A rosbag2 folder (MCAP) of nav_msgs/Path messages: topic -> messages, each a list of poses
    (stamp [s], x, y, quaternion z, w)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    ty = store.types

    def header(t: float) -> Any:
        stamp = ty["builtin_interfaces/msg/Time"](sec=int(t), nanosec=round((t % 1) * 1e9))
        return ty["std_msgs/msg/Header"](stamp=stamp, frame_id="map")

    def pose(t: float, x: float, y: float, qz: float, qw: float) -> Any:
        q = ty["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=qz, w=qw)
        p = ty["geometry_msgs/msg/Pose"](position=ty["geometry_msgs/msg/Point"](x=x, y=y, z=0.0), orientation=q)
        return ty["geometry_msgs/msg/PoseStamped"](header=header(t), pose=p)

    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        for topic, messages in topics.items():
            conn = w.add_connection(topic, "nav_msgs/msg/Path", typestore=store)
            for k, poses in enumerate(messages):
                msg = ty["nav_msgs/msg/Path"](header=header(0.0), poses=[pose(*p) for p in poses])
                w.write(conn, k * 1000, store.serialize_cdr(msg, "nav_msgs/msg/Path"))
    return path


_LINE = [(0.1 * k, 0.25 + 0.1 * k, 0.25, 0.0, 1.0) for k in range(10)]  # stamped 0.1 s apart, heading 0
_NAN_Q = [*_LINE[:4], (0.4, 0.65, 0.25, math.nan, math.nan), *_LINE[5:]]


@pytest.mark.parametrize(
    ("topics", "timed", "said", "unsaid"),
    [
        (
            {"/plan": [_NAN_Q]},
            False,
            "/plan message 0 poses[4] has a non-finite orientation quaternion; fix or drop",
            "zero",
        ),
        (
            {"/plan": [_LINE[:1]]},
            False,
            "message 0 of /plan is a path of one pose, and the robot needs two positions or more to follow; no other "
            "message or nav_msgs/Path topic of the bag has two poses: record the plan again",
            "--message",
        ),
        ({"/plan": [[]]}, False, "message 0 of /plan is an empty path", "--message"),
        (
            {"/plan": [_LINE, []]},
            False,
            "choose another with --message (message=... from Python): of messages 0 to 1, 0 hold two poses or more",
            "",
        ),
        ({"/plan": [[]], "/global_plan": [_LINE]}, False, "name another nav_msgs/Path topic with --topic", "--message"),
        (
            {"/plan": [[(0.0, *p[1:]) for p in _LINE]]},
            True,
            "message 0 of /plan has no clock: its 10 poses all carry the stamp 0 s, so it is a path, not a "
            "trajectory; track it with --path (timed=False from Python)",
            "--columns",
        ),
    ],
    ids=["nan quaternion", "one pose", "empty, alone", "empty, another message", "empty, another topic", "untimed"],
)
def test_a_bad_path_message_is_named_with_a_fix_that_exists(
    tmp_path: Path, topics: dict[str, Any], timed: bool, said: str, unsaid: str
) -> None:
    from planning.trajectory.file_formats import TrajectoryFileError

    bag = _path_bag(tmp_path / "bag", topics)
    with pytest.raises(TrajectoryFileError) as err:
        read_trajectory_file(TrajectoryFile(bag, timed=timed, topic="/plan"))
    text = str(err.value)
    assert said in text, text
    assert not unsaid or unsaid not in text, text


def test_a_recorded_motion_of_one_message_is_named_with_a_fix(tmp_path: Path) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from planning.trajectory.file_formats import TrajectoryFileError

    store = get_typestore(Stores.ROS2_HUMBLE)
    ty = store.types
    stamp = ty["builtin_interfaces/msg/Time"](sec=EPOCH, nanosec=0)
    q = ty["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    p = ty["geometry_msgs/msg/Pose"](position=ty["geometry_msgs/msg/Point"](x=1.0, y=1.0, z=0.0), orientation=q)
    msg = ty["geometry_msgs/msg/PoseStamped"](header=ty["std_msgs/msg/Header"](stamp=stamp, frame_id="map"), pose=p)
    with Writer(tmp_path / "bag", version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/pose", "geometry_msgs/msg/PoseStamped", typestore=store)
        w.write(conn, 0, store.serialize_cdr(msg, "geometry_msgs/msg/PoseStamped"))
    with pytest.raises(TrajectoryFileError, match=r"topic /pose holds one message; a recorded motion needs two"):
        read_trajectory_file(TrajectoryFile(tmp_path / "bag", timed=True, topic="/pose"))


def test_a_one_pose_plan_exits_2_naming_its_topic_and_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    bag = _path_bag(tmp_path / "bag", {"/plan": [_LINE[:1]]})
    err = _exit_2(["--path", str(bag), "--topic", "/plan"], tmp_path, capsys)
    assert "message 0 of /plan is a path of one pose" in err and "record the plan again" in err


def test_a_navfn_path_of_identity_orientations_is_driven_forwards(tmp_path: Path) -> None:
    """Nav2's NavFn planner leaves every pose's orientation the identity but the last (the goal's): taken as headings
    they had a westward leg driven in reverse, silently, or the L's end refused as folding back. Unset, the headings
    are the motion's, said in a note; a path along +x with identity orientations keeps them (they agree)."""
    north = [(0.0, 1.0, 1.0 + 0.1 * k, 0.0, 1.0) for k in range(10)]
    west = [(0.0, 1.0 - 0.1 * k, 1.9, 0.0, 1.0) for k in range(1, 10)]
    goal = (0.0, 0.0, 1.9, 1.0, 0.0)  # facing west (yaw pi): the goal's orientation on the last pose
    bag = _path_bag(tmp_path / "navfn", {"/plan": [north + west + [goal]]})
    table = read_bag_table(bag, "/plan", message=None, timed=False)
    assert "theta" not in table.columns
    assert any(n.startswith("orientations: poses[0..18] carry the identity quaternion") for n in table.notes)
    imported = read_trajectory_file(TrajectoryFile(bag, topic="/plan", timed=False))
    assert (imported.direction > 0).all()  # forwards throughout
    east = _path_bag(tmp_path / "east", {"/plan": [[(0.0, 0.5 + 0.1 * k, 1.0, 0.0, 1.0) for k in range(10)]]})
    table = read_bag_table(east, "/plan", message=None, timed=False)
    assert "theta" in table.columns and not any(n.startswith("orientations") for n in table.notes)


def test_a_recorded_motion_reversing_with_identity_orientations_keeps_them(tmp_path: Path) -> None:
    """A robot backing 1.5 m along -x, heading 0 throughout, recorded as PoseStamped: its orientations were taken as
    unset, Nav2 NavFn's, and the note said it would be driven forwards (it ran in reverse, as recorded). A recorded
    motion's orientations are measured: the headings are 0 and the motion reverses, without that note."""
    from mcap_ros2.writer import Writer

    bag = tmp_path / "back.mcap"
    with bag.open("wb") as f:
        writer = Writer(f)
        pose = writer.register_msgdef("geometry_msgs/msg/PoseStamped", POSE_STAMPED_DEF)
        for k in range(16):
            ns = EPOCH * 10**9 + k * 10**9
            writer.write_message("/pose", pose, _stamped(float(k), 1.5 - 0.1 * k, 0.5, 0.0), log_time=ns)
        writer.finish()
    table = read_bag_table(bag, "/pose", timed=True)
    assert not any(n.startswith("orientations") for n in table.notes)
    np.testing.assert_array_equal(table.columns["theta"], np.zeros(16))
    imported = read_trajectory_file(TrajectoryFile(bag, timed=True, topic="/pose"))
    assert (imported.direction[1:] < 0).all()
