"""Plans and runs recorded in bags, as the named columns every trajectory file becomes.

A bag is a ROS 2 MCAP file (``.mcap``), a rosbag2 folder (MCAP or sqlite3 storage, with its
``metadata.yaml``) or a ROS 1 ``.bag``, read with ``rosbags`` (no ROS needed). One topic is read:

* ``nav_msgs/Path`` (a planner's ``/plan``): one message, the last on the topic unless ``message``
  says which (0 the first, -1 the last); its poses are the rows (x, y, the heading of the
  orientation, and the pose stamps as ``t`` when they differ).
* ``nav_msgs/Odometry``, ``geometry_msgs/PoseStamped`` or ``geometry_msgs/PoseWithCovarianceStamped``
  (a robot's recorded motion): every message is a row, its header stamp the clock (counted from
  the first message); an odometry message's twist gives ``v`` and ``omega``.

The poses' frame (their ``header.frame_id``; a path's poses', which a path header that says another
frame does not override) goes into the import report. Poses in another frame than ``map`` (an ``odom``
recording) are placed in ``map`` by the bag's transforms (:func:`place_in_map`): the chain from ``map``
down to their frame on ``/tf`` and ``/tf_static`` (AMCL's ``map -> odom``), each pose by the
transforms at its own stamp, a moving one interpolated between its stamps as tf2 does. Where tf2
would refuse to extrapolate (a pose stamped before the first transform, as the start of a run before
AMCL's first), the nearest transform is used and the report counts those poses. A bag without that
chain leaves the poses as they are, and the report says so and points to ``--offset``. Orientation
quaternions must have norm 1 within :data:`QUATERNION_TOLERANCE` (tf2 refuses others; those within it
are normalised) and lie within 45 degrees of the plane, read as a YAML path's and a table's are
(:func:`planning.trajectory.file_formats.orientation_headings`).

The table then goes through :func:`planning.trajectory.importer.read_trajectory_file`'s repairs and
checks like any other file. Every problem (no such bag, a truncated file or one that is not a bag,
a topic that is missing, of another type or empty, a path of fewer than two poses, a trajectory whose
poses carry no times, a non-finite position or quaternion, a zero or unnormalised quaternion, poses in
more than one frame) is a :class:`TrajectoryFileError` naming it (the topic and message) and a fix that
exists (another message or topic of the bag, when it has one).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from planning.core.geometry import compose_poses
from planning.errors import option
from planning.trajectory.file_formats import BAG_SUFFIXES as BAG_SUFFIXES  # one list: the formats' message too
from planning.trajectory.file_formats import QUATERNION_TOLERANCE as QUATERNION_TOLERANCE  # one check: bags, YAML
from planning.trajectory.file_formats import (
    FileTable,
    TrajectoryFileError,
    orientation_headings,
    quaternion_yaw,
    table_from_arrays,
    yaml_problem,
)

PATH_TYPE = "nav_msgs/msg/Path"
#: Types whose messages are each one row of a recorded motion.
MOTION_TYPES = ("nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PoseWithCovarianceStamped")
#: The frame the scenario's coordinates are in.
MAP_FRAME = "map"
#: The topics and the type of a bag's transforms.
TF_TOPICS = ("/tf", "/tf_static")
TF_TYPE = "tf2_msgs/msg/TFMessage"
#: The longest chain of transforms followed from a frame up to ``map``.
MAX_TF_HOPS = 16


def is_bag(path: Path) -> bool:
    """Whether ``path`` names a bag: a ``.mcap``, ``.bag`` or ``.db3`` file, or a rosbag2 folder."""
    path = Path(path)
    return path.suffix.lower() in BAG_SUFFIXES or path.is_dir()


def _name(t: str) -> str:
    return t.replace("/msg/", "/")


def _open(path: Path) -> Any:
    """An open ``rosbags`` AnyReader of the bag (ROS 2 Humble types for bags that carry none)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    if not path.exists():
        raise TrajectoryFileError(f"cannot read bag {path}: no such file or folder; check the path")
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise TrajectoryFileError(
            f"cannot read bag {path}: the folder has no metadata.yaml, so it is not a rosbag2 bag; give the bag "
            "folder ros2 bag record wrote (or its .mcap file); `ros2 bag reindex` rebuilds a lost metadata.yaml"
        )
    if path.is_dir():
        _check_metadata(path / "metadata.yaml")
    reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
    try:
        reader.open()
    except Exception as exc:  # rosbags raises its own errors, and struct/OS errors on broken files
        raise TrajectoryFileError(
            f"cannot read bag {path}: {exc or type(exc).__name__}; it is truncated or not a bag: give a complete "
            ".mcap, rosbag2 folder or ROS 1 .bag (a recording cut short can be repaired with `ros2 bag reindex` "
            "or `mcap recover`)"
        ) from exc
    return reader


def _check_metadata(metadata: Path) -> None:
    """A rosbag2 folder's ``metadata.yaml`` must be YAML; else one line naming where it breaks and the fix (rosbags'
    own message quotes PyYAML's several lines)."""
    import yaml

    try:
        yaml.safe_load(metadata.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError):  # rosbags says why it cannot read it
        return
    except yaml.YAMLError as exc:
        raise TrajectoryFileError(
            f"cannot read bag {metadata.parent}: {metadata} is not valid YAML ({yaml_problem(exc)}); fix it there, "
            "or rebuild it from the bag's storage files with `ros2 bag reindex`"
        ) from exc


def _topics_text(reader: Any) -> str:
    return ", ".join(f"{name} ({_name(info.msgtype or '?')}, {info.msgcount})" for name, info in reader.topics.items())


def _which_topic(reader: Any, timed: bool) -> str:
    """The bag's topics and which to name: with ``--topic``, or, for a path (not ``timed``) in a bag that holds
    recorded motions and no path, the motion with ``--trajectory`` (naming it with ``--topic`` would be refused)."""
    paths = [name for name, info in reader.topics.items() if info.msgtype == PATH_TYPE]
    motions = [name for name, info in reader.topics.items() if info.msgtype in MOTION_TYPES]
    fix = f"name one with {option('topic')}"
    if not timed and motions and not paths:
        read = option("trajectory", python="timed=True")
        fix = f"it holds no path: read the recorded motion of {motions[0]} with {read}"
    return f"the bag has {_topics_text(reader) or 'no topics'}: {fix}"


def _messages(reader: Any, path: Path, topic: str, timed: bool) -> tuple[str, list[Any]]:
    """The topic's type and its deserialised messages, checked."""
    if topic not in reader.topics:
        raise TrajectoryFileError(f"{path}: no topic {topic!r}; {_which_topic(reader, timed)}")
    msgtype = reader.topics[topic].msgtype or ""
    types = sorted({_name(c.msgtype) for c in reader.connections if c.topic == topic})
    if len(types) > 1:  # rosbags gives such a topic no type
        raise TrajectoryFileError(
            f"{path}: topic {topic} carries {len(types)} types ({', '.join(types)}) from different publishers; a "
            "file is read from one: record them on topics of their own (remap one), or split the bag "
            "(ros2 bag convert) and give the part of one type"
        )
    wanted = (PATH_TYPE, *MOTION_TYPES) if timed else (PATH_TYPE,)
    if msgtype not in wanted:
        use = "a nav_msgs/Path topic (e.g. /plan)"
        if timed:
            use = "a nav_msgs/Path, nav_msgs/Odometry or geometry_msgs/PoseStamped topic (e.g. /odom)"
        elif msgtype in MOTION_TYPES:
            use += f", or read the recorded motion of {topic} with {option('trajectory', python='timed=True')}"
        what = "a path or a recorded motion" if timed else "a path"
        raise TrajectoryFileError(f"{path}: topic {topic} carries {_name(msgtype)}, not {what}; give {use}")
    conns = [c for c in reader.connections if c.topic == topic]
    try:
        msgs = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]
    except Exception as exc:  # a chunk that ends early or fails to decompress
        raise TrajectoryFileError(
            f"cannot read topic {topic} of bag {path}: {exc}; the bag is truncated or damaged (try `ros2 bag reindex` "
            "or `mcap recover`)"
        ) from exc
    if not msgs:
        raise TrajectoryFileError(
            f"{path}: topic {topic} holds no messages; the bag has {_topics_text(reader)}: record it again (the "
            f"recording stopped before anything was published on it), or name a topic with messages with "
            f"{option('topic')}"
        )
    return msgtype, msgs


def _nanoseconds(stamp: Any) -> int:
    """A stamp as whole nanoseconds (exact: a wall-clock stamp in float seconds keeps only ~0.2 us)."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _pose_of(msg: Any, msgtype: str) -> Any:
    """The geometry_msgs/Pose of a motion message."""
    return msg.pose.pose if msgtype != "geometry_msgs/msg/PoseStamped" else msg.pose


def _columns(
    path: Path, poses: list[Any], stamps: list[int], rows: tuple[str, ...], *, planned: bool
) -> tuple[dict[str, Any], tuple[str, ...]]:
    """The poses' columns (their headings read as a YAML path's and a table's, :func:`orientation_headings`) and
    the notes reading them made. Only a ``planned`` path's orientations may be unset (Nav2's NavFn leaves a
    nav_msgs/Path's so); a recorded motion's are measured, identity ones too (a robot reversing along -x)."""
    cols = {
        "x": np.array([p.position.x for p in poses], dtype=float),
        "y": np.array([p.position.y for p in poses], dtype=float),
    }
    q = np.array([[p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w] for p in poses], dtype=float)
    _check_finite(path, {**cols, "orientation quaternion": q}, rows)
    xy = (cols["x"], cols["y"]) if planned else (None, None)
    theta, notes = orientation_headings(q, rows, path, *xy)  # a zero quaternion is refused
    if theta is not None:  # None: unset orientations (Nav2's NavFn), said in the notes
        cols["theta"] = theta
    if len(set(stamps)) > 1:
        cols["t"] = np.array([s - stamps[0] for s in stamps], dtype=float) * 1e-9
    return cols, notes


def _one_frame(path: Path, what: str, frames: list[str], rows: tuple[str, ...]) -> str:
    """The one frame of the rows (named by ``rows``) of ``what``; poses in two frames are refused."""
    seen = list(dict.fromkeys(frames))
    if len(seen) > 1:
        a, b = (rows[frames.index(f)] for f in seen[:2])
        raise TrajectoryFileError(
            f"{path}: {what} holds poses in {len(seen)} frames: {a} in {seen[0]!r}, {b} in {seen[1]!r}; one "
            "trajectory is in one frame: transform the poses into one frame (e.g. with tf2) before recording them, "
            f"or read another topic with {option('topic')}"
        )
    return seen[0] if seen else ""


def _frame_notes(frame: str, header: str | None, placed: str | None, unplaced: str) -> tuple[str, ...]:
    """What the import report says of the poses' ``frame`` (and of a path ``header`` that said another), and
    ``placed``, how the bag's transforms placed them in ``map`` (:func:`place_in_map`; None: they did not, for the
    reason ``unplaced``, :meth:`Transforms.unplaced`)."""
    notes = []
    if header and header != frame:  # an empty header says nothing
        notes.append(f"the path's header says frame {header!r} but its poses are in {frame!r}: the poses' frame used")
    if frame.lstrip("/") == MAP_FRAME:
        notes.append(f"frame {frame!r}: the poses are in the scenario's map frame")
    elif not frame:
        notes.append("frame: none given (empty header.frame_id); the poses are taken in the scenario's map frame")
    elif placed is not None:
        notes.append(f"frame {frame!r}: the poses are placed in {MAP_FRAME!r} by the bag's transforms ({placed})")
    else:
        offset = option("offset", "X,Y,THETA", python="offset=(X, Y, THETA)")
        notes.append(
            f"frame {frame!r}, not {MAP_FRAME!r}: the poses are taken as they are in the scenario's map frame "
            f"({unplaced}); "
            f"place them with {offset}, the pose of {frame!r} in {MAP_FRAME!r}"
        )
    return tuple(notes)


class Hop(NamedTuple):
    """A frame's transform from its parent in a bag: planar (x, y, yaw), over time or static.

    Attributes:
        parent: The parent frame (no leading ``/``).
        static: From ``/tf_static``: the same at every time.
        stamps: (K,) increasing stamps [ns].
        pose: (K, 3) the transform at each stamp: the frame's origin in the parent [m] and its yaw [rad],
            unwrapped along the stamps.
    """

    parent: str
    static: bool
    stamps: NDArray[np.int64]
    pose: NDArray[np.float64]

    def at(self, stamps: NDArray[np.int64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """(N, 3) the transform at ``stamps`` [ns] (stamp 0, tf2's "latest": the last), linear between the
        stamps and held beyond them; and which stamps lay beyond them."""
        q = np.where(stamps == 0, self.stamps[-1], stamps)
        if self.static or self.stamps.size == 1:
            return np.tile(self.pose[-1], (q.size, 1)), np.zeros(q.size, dtype=bool)
        out = np.column_stack([np.interp(q, self.stamps, self.pose[:, j]) for j in range(3)])
        return out, (q < self.stamps[0]) | (q > self.stamps[-1])


class Transforms(NamedTuple):
    """A bag's transforms: each frame's :class:`Hop` from its one parent, and the frames given more than one parent
    (frame -> its parents, sorted), which are not followed."""

    hops: dict[str, Hop]
    ambiguous: dict[str, tuple[str, ...]]

    def unplaced(self, frame: str) -> str:
        """Why no chain leads from ``map`` to ``frame`` (for the import report)."""
        at = frame.lstrip("/")
        for _ in range(MAX_TF_HOPS):
            if at in self.ambiguous:
                parents = " and ".join(repr(p) for p in self.ambiguous[at])
                return (
                    f"the bag's /tf gives {at!r} {len(self.ambiguous[at])} parents ({parents}), whose transforms "
                    f"are not followed one at a time as tf2 would: no chain from {MAP_FRAME!r} to {frame!r} is taken"
                )
            hop = self.hops.get(at)
            if hop is None or hop.parent == MAP_FRAME:
                break
            at = hop.parent
        return f"the bag's /tf and /tf_static hold no chain of transforms from {MAP_FRAME!r} to {frame!r}"


def read_transforms(reader: Any, path: Path) -> Transforms:
    """Each frame's transform from its parent on the bag's ``/tf`` and ``/tf_static`` (frame names without a
    leading ``/``), planar: the yaw of the rotation. Transforms with a non-finite value are dropped (tf2 drops
    them); a frame given two parents (which tf2 would follow one at a time) is left out of the hops and named."""
    conns = [c for c in reader.connections if c.topic in TF_TOPICS and _name(c.msgtype) == _name(TF_TYPE)]
    if not conns:  # (rosbags reads every connection when given none)
        return Transforms({}, {})
    seen: dict[str, tuple[str, bool, list[tuple[int, float, float, float]]]] = {}
    parents: dict[str, set[str]] = {}
    try:
        for conn, _, raw in reader.messages(connections=conns):
            for tr in reader.deserialize(raw, conn.msgtype).transforms:
                child, parent = tr.child_frame_id.lstrip("/"), tr.header.frame_id.lstrip("/")
                v, q = tr.transform.translation, tr.transform.rotation
                yaw = quaternion_yaw(q.x, q.y, q.z, q.w)  # NaN for a zero quaternion: dropped below
                if not all(math.isfinite(value) for value in (v.x, v.y, yaw)):
                    continue
                parents.setdefault(child, set()).add(parent)
                seen.setdefault(child, (parent, conn.topic == "/tf_static", []))[2].append(
                    (_nanoseconds(tr.header.stamp), v.x, v.y, yaw)
                )
    except Exception as exc:  # a chunk that ends early or fails to decompress
        raise TrajectoryFileError(
            f"cannot read the transforms (/tf, /tf_static) of bag {path}: {exc}; the bag is truncated or damaged (try "
            "`ros2 bag reindex` or `mcap recover`)"
        ) from exc
    hops = {}
    ambiguous = {child: tuple(sorted(ps)) for child, ps in parents.items() if len(ps) > 1}
    for child, (parent, static, rows) in seen.items():
        if child in ambiguous:
            continue
        table = np.array(sorted(rows), dtype=float)
        stamps = table[:, 0].astype(np.int64)
        last = np.append(stamps[1:] != stamps[:-1], True)  # of one stamp given twice, the later
        pose = table[last, 1:]
        pose[:, 2] = np.unwrap(pose[:, 2])
        hops[child] = Hop(parent, static, stamps[last], pose)
    return Transforms(hops, ambiguous)


def place_in_map(hops: dict[str, Hop], frame: str, stamps: NDArray[np.int64], columns: dict[str, Any]) -> str | None:
    """Move the poses in ``columns`` (``x``, ``y`` and ``theta`` when given), in ``frame`` at ``stamps`` [ns], into
    ``map`` along the chain of ``hops`` from ``map`` down to ``frame``, each pose by the transforms at its stamp;
    return what was done, for the report, or None (``columns`` unchanged) when no such chain exists."""
    chain: list[str] = [frame.lstrip("/")]
    while chain[-1] != MAP_FRAME:
        hop = hops.get(chain[-1])
        if hop is None or len(chain) > MAX_TF_HOPS or hop.parent in chain:
            return None
        chain.append(hop.parent)
    frame_in_map = np.zeros((stamps.size, 3))  # built upwards, one parent at a time
    held = np.zeros(stamps.size, dtype=bool)
    for child in chain[:-1]:
        pose, beyond = hops[child].at(stamps)
        frame_in_map = compose_poses(pose, frame_in_map)
        held |= beyond
    headings = columns.get("theta")  # None: orientations unset (the poses' positions are placed alone)
    poses = np.column_stack([columns["x"], columns["y"], np.zeros(stamps.size) if headings is None else headings])
    placed = compose_poses(frame_in_map, np.asarray(poses, dtype=float)).T
    columns["x"], columns["y"] = placed[0], placed[1]
    if headings is not None:
        columns["theta"] = placed[2]
    said = " -> ".join(reversed(chain)) + ", at each pose's stamp"
    if held.any():
        said += f"; {int(held.sum())} of {stamps.size} poses lie beyond the transforms' stamps, placed by the nearest"
    return said


def _check_finite(path: Path, cols: dict[str, Any], rows: tuple[str, ...]) -> None:
    """Each value of every column (a row's several values: a quaternion) a finite number."""
    for name, values in cols.items():
        bad = np.flatnonzero(~np.all(np.isfinite(np.reshape(values, (len(rows), -1))), axis=1))
        if bad.size:
            raise TrajectoryFileError(f"{path}: {rows[bad[0]]} has a non-finite {name}; fix or drop that pose")


def _instead(sizes: list[int], k: int, paths: list[str]) -> str:
    """What to read instead of message ``k`` of a path topic whose messages hold ``sizes`` poses: another
    message of two poses or more, else another nav_msgs/Path topic of the bag (``paths``), else nothing
    in this bag."""
    good = [i for i, n in enumerate(sizes) if n >= 2 and i != k]
    if good:
        shown = ", ".join(map(str, good[:5])) + (", ..." if len(good) > 5 else "")
        last = len(sizes) - 1
        return f"choose another with {option('message')}: of messages 0 to {last}, {shown} hold two poses or more"
    if paths:
        return f"name another nav_msgs/Path topic with {option('topic')}: {', '.join(paths)}"
    return "no other message or nav_msgs/Path topic of the bag has two poses: record the plan again"


class _Rows(NamedTuple):
    """A topic read: its rows' names, its columns, the poses' frame, the header frame of a path (None for a
    motion), the poses' stamps [ns] and notes for the report."""

    rows: tuple[str, ...]
    columns: dict[str, Any]
    frame: str
    header: str | None
    stamps: list[int]
    notes: tuple[str, ...] = ()


def _path_rows(path: Path, topic: str, msgs: list[Any], message: int | None, paths: list[str], timed: bool) -> _Rows:
    """The path message ``message`` (None: the last) of ``topic``, checked: in range, two poses or more in one
    frame, and for a trajectory (``timed``) poses that carry their times."""
    k = len(msgs) - 1 if message is None else message
    if not -len(msgs) <= k < len(msgs):
        raise TrajectoryFileError(
            f"{path}: {option('message', message)} but topic {topic} holds {len(msgs)} message(s); give 0 to "
            f"{len(msgs) - 1} (or -1 for the last)"
        )
    k %= len(msgs)
    poses = msgs[k].poses
    if len(poses) < 2:
        what = "an empty path" if not poses else "a path of one pose"
        raise TrajectoryFileError(
            f"{path}: message {k} of {topic} is {what}, and the robot needs two positions or more to follow; "
            f"{_instead([len(m.poses) for m in msgs], k, paths)}"
        )
    rows = tuple(f"{topic} message {k} poses[{i}]" for i in range(len(poses)))
    header = msgs[k].header.frame_id
    frames = [p.header.frame_id or header for p in poses]  # a pose without a frame is in the path's
    frame = _one_frame(path, f"message {k} of {topic}", frames, rows)
    stamps = [_nanoseconds(p.header.stamp) for p in poses]
    if timed and len(set(stamps)) == 1:
        raise TrajectoryFileError(
            f"{path}: message {k} of {topic} has no clock: its {len(poses)} poses all carry the stamp "
            f"{stamps[0] * 1e-9:.9g} s, so it is a path, not a trajectory; track it with "
            f"{option('path', python='timed=False')}, or give a path whose poses carry their times"
        )
    cols, notes = _columns(path, [p.pose for p in poses], stamps, rows, planned=True)
    return _Rows(rows, cols, frame, header, stamps, notes)


def _motion_rows(path: Path, topic: str, msgs: list[Any], msgtype: str) -> _Rows:
    """A recorded motion (every message a row), checked: two messages or more, with a clock, in one frame."""
    stamps = [_nanoseconds(mm.header.stamp) for mm in msgs]
    if len(msgs) < 2 or len(set(stamps)) == 1:
        what = "one message" if len(msgs) < 2 else f"{len(msgs)} messages all stamped {stamps[0] * 1e-9:.9g} s"
        raise TrajectoryFileError(
            f"{path}: topic {topic} holds {what}; a recorded motion needs two messages or more at distinct "
            f"stamps: record a longer run, or name another topic with {option('topic')}"
        )
    # messages are logged as they arrive, which two publishers or a network may reorder: read by their stamps
    order = sorted(range(len(msgs)), key=stamps.__getitem__)
    moved = sum(k != i for k, i in enumerate(order))
    msgs, stamps = [msgs[i] for i in order], [stamps[i] for i in order]
    rows = tuple(f"{topic} message {i}" for i in order)
    frame = _one_frame(path, f"topic {topic}", [mm.header.frame_id for mm in msgs], rows)
    cols, notes = _columns(path, [_pose_of(mm, msgtype) for mm in msgs], stamps, rows, planned=False)
    if msgtype == "nav_msgs/msg/Odometry":
        cols["v"] = np.array([mm.twist.twist.linear.x for mm in msgs], dtype=float)
        cols["omega"] = np.array([mm.twist.twist.angular.z for mm in msgs], dtype=float)
    if moved:
        notes += (f"{moved} messages of {topic} were logged out of their stamps' order: read in the stamps' order",)
    return _Rows(rows, cols, frame, None, stamps, notes)


def read_bag_table(path: Path, topic: str | None, message: int | None = None, *, timed: bool) -> FileTable:
    """One topic of a bag as named columns (see the module doc).

    Args:
        path: The bag (file or rosbag2 folder).
        topic: The topic to read; None is an error listing the bag's topics.
        message: Which message of a path topic (0 the first, negative from the end); None: the last.
        timed: Read for ``--trajectory`` (motion topics allowed) rather than ``--path``.

    Raises:
        TrajectoryFileError: No bag there, a truncated file or one that is not a bag, no ``topic``, a topic
            missing, of another type or empty, a ``message`` out of range or of fewer than two poses, a
            trajectory without a clock, a non-finite pose, a zero or unnormalised quaternion, poses in
            more than one frame. Each names the topic and message and the fix.
    """
    path = Path(path)
    reader = _open(path)
    try:
        if topic is None:
            raise TrajectoryFileError(f"{path} is a bag: give the topic to read; {_which_topic(reader, timed)}")
        msgtype, msgs = _messages(reader, path, topic, timed)
        paths = [name for name, info in reader.topics.items() if info.msgtype == PATH_TYPE and name != topic]
        if msgtype == PATH_TYPE:
            got = _path_rows(path, topic, msgs, message, paths, timed)
        else:
            if message is not None:
                raise TrajectoryFileError(
                    f"{option('message')} picks one nav_msgs/Path; {topic} carries {_name(msgtype)}: drop it"
                )
            got = _motion_rows(path, topic, msgs, msgtype)
        placed: str | None = None
        unplaced = ""
        if got.frame.lstrip("/") not in ("", MAP_FRAME):
            tf = read_transforms(reader, path)
            placed = place_in_map(tf.hops, got.frame, np.array(got.stamps), got.columns)
            unplaced = tf.unplaced(got.frame) if placed is None else ""
    finally:
        reader.close()
    _check_finite(path, got.columns, got.rows)  # named as a pose of the topic, before the table's own check
    table = table_from_arrays(path, got.columns, f"bag topic {topic}, {_name(msgtype)}", got.rows)
    return replace(table, frame=got.frame, notes=_frame_notes(got.frame, got.header, placed, unplaced) + got.notes)
