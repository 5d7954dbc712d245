"""A job as a ROS 2 bag: a rosbag2 folder with MCAP storage (zstd-compressed chunks) and its
``metadata.yaml``, written with ``rosbags`` (no ROS needed), readable by ``ros2 bag``, Foxglove and
PlotJuggler.

The topics and frames are those of :mod:`sim.io.bag_topics`; every message is stamped in simulated
time, and the bag's own clock (the log time of each message) equals its header stamp. The bag is
written into a temporary folder beside the target and moved into place when complete: an interrupted
write leaves nothing under the target's name, and an existing bag is replaced only when asked, in one
step that a signal does not split: the target holds the old bag or the new one, never neither. Whether
the old bag can be moved aside (permissions, an immutable or append-only flag, a mount point) is checked
before any work; a move that fails anyway keeps the old bag and is a :class:`BagNotPlacedError`.

Only a bag this program wrote is replaced: its ``metadata.yaml`` carries the mark :data:`MARK` in rosbag2's
``custom_data`` (written by the same ``rosbags`` writer call as the rest of the metadata, so a bag is marked
exactly when it is complete), and the folder holds nothing but that file and the storage files it lists. Any
other folder (a robot's recording, a bag another tool wrote, one of ours with a user's notes added) is refused,
with ``--overwrite`` too (:func:`not_ours`).
"""

from __future__ import annotations

import itertools
import os
import re
import shutil
import stat
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from planning.core.checks import check_flag
from planning.errors import ConfigError, NhsimError, OutputExistsError, option
from planning.signals import signals_held
from sim.io import bag_topics as bt
from sim.io import rosmsgs as m
from sim.outputs import APPEND_ONLY, IMMUTABLE, folder_for, inode_flags

#: Writer settings: rosbag2 metadata version, storage and compression.
BAG_VERSION: Literal[8] = 8
#: The mark of a bag this program wrote: a key and its value in ``metadata.yaml``'s ``custom_data``
#: (rosbag2's own place for a writer's notes; ``rosbags`` writes it with the rest of the metadata).
MARK = ("nhsim.writer", "nhsim")


class BagNotPlacedError(NhsimError, OSError):
    """A finished bag could not be moved into place (the old bag there could not be moved aside, or the
    new one not moved in): the old bag is kept under its name, the new one removed; the message says why."""


@dataclass(frozen=True)
class BagSummary:
    """What was written.

    Attributes:
        path: The bag folder.
        topics: Topic -> (message type, message count).
        size_bytes: Bytes of the folder's files.
        duration_s: Span of the message stamps [s].
        write_s: Wall time the writing took [s].
        write_cpu_s: CPU time the writing took [s] (this process's; steadier than wall time on a busy machine).
    """

    path: Path
    topics: dict[str, tuple[str, int]]
    size_bytes: int
    duration_s: float
    write_s: float = 0.0
    write_cpu_s: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """The record's ``bag`` section."""
        return {
            "path": str(self.path),
            "size_bytes": self.size_bytes,
            "duration_s": self.duration_s,
            "write_s": self.write_s,
            "write_cpu_s": self.write_cpu_s,
            "topics": {k: {"type": t, "messages": n} for k, (t, n) in self.topics.items()},
        }


#: Names of a bag's files, not of the folder a ROS 2 bag is (an MCAP or sqlite3 storage file, a ROS 1 bag).
BAG_FILE_SUFFIXES = (".mcap", ".db3", ".bag")


def check_bag_target(path: Path, *, overwrite: bool) -> None:
    """Check, before any work, that a bag can be written at ``path`` (a folder to be created).

    Raises:
        OutputExistsError: ``path`` is an empty folder or a bag this program wrote, and ``overwrite`` is false.
        ConfigError: ``overwrite`` is not True or False, ``path`` lies among the files every run reads
            (:func:`sim.outputs.check_not_read_by_runs`) or inside a bag, is a file, or a folder that is not a bag this
            program wrote (:func:`not_ours`: never replaced, with ``overwrite`` too), or a bag that could not be
            moved aside (:func:`_unmovable`: the folder and the fix named), or its parent folder cannot take new
            files.
    """
    from sim.outputs import check_folder_for, check_not_read_by_runs

    overwrite = check_flag("overwrite", overwrite)
    path = Path(path)
    check_bag_length(path)
    check_not_read_by_runs(path)
    holder = bag_holding(path)
    if holder is not None:  # a bag holds its own files only: the outer bag would read as not a bag, nor nhsim's
        raise ConfigError(
            f"cannot write the bag {path}: it lies inside the bag {holder} (a folder with a rosbag2 metadata.yaml); "
            f"choose a folder outside it with {option('bag', python='path')}"
        )
    if path.suffix.lower() in BAG_FILE_SUFFIXES:
        folder = str(path.with_suffix(""))
        raise ConfigError(
            f"cannot write the bag {path}: a ROS 2 bag is a folder (its metadata.yaml beside its storage file), and "
            f"{path.name} names a file; give the folder's name, e.g. {option('bag', folder, python='path')}"
        )
    if path.exists() or path.is_symlink():
        if not path.is_dir():
            what = f"a symbolic link to {os.readlink(path)}, which does not exist," if not path.exists() else "a file"
            raise ConfigError(
                f"cannot write the bag {path}: {what} of that name stands there; choose another folder with "
                f"{option('bag', python='path')}"
            )
        foreign = not_ours(path)
        if foreign:  # before the --overwrite advice: --overwrite would not replace it either
            raise ConfigError(
                f"cannot write the bag {path}: {foreign}; {option('overwrite', True)} replaces only a bag nhsim "
                f"wrote, so it is kept: move it away, or choose another folder with {option('bag', python='path')}"
            )
        if not overwrite:
            raise OutputExistsError(
                f"{path} exists already; pass {option('overwrite', True)} to replace it, or choose another folder "
                f"with {option('bag', python='path')}"
            )
        reason = _unmovable(path)
        if reason:
            raise ConfigError(
                f"cannot replace {path}: {reason}, so the old bag cannot be moved aside for the new one; fix that, "
                f"or choose another folder with {option('bag', python='path')}"
            )
    check_folder_for(path)


def check_bag_length(path: Path) -> None:
    """The bag folder ``path``'s name, its temporary one and the paths of its files fit the file system's limits
    (:func:`sim.outputs.check_length`): a bag is written as ``.NAME.XXXXXXXX.part/NAME/`` (its storage file
    ``NAME.mcap`` in it) and renamed, and a name of 241-255 bytes passed, the command failing with a traceback once
    the whole run was done.

    Raises:
        ConfigError: Naming the length, the limit and the fix.
    """
    from sim.outputs import check_length

    check_length(path, temporary=(f".{path.name}.", ".part"), inner=2 * len(os.fsencode(path.name)) + 8)


def bag_holding(path: Path) -> Path | None:
    """The bag folder (one with a rosbag2 ``metadata.yaml``) that ``path`` lies inside, or None."""
    return next((p for p in Path(os.path.abspath(path)).parents if _metadata(p / "metadata.yaml") is not None), None)


def not_ours(path: Path) -> str:
    """Why the existing folder ``path`` is not a bag this program wrote, or "" when it is one (or is empty).

    A bag of ours has :data:`MARK` in its ``metadata.yaml``'s ``custom_data`` and holds nothing but that file
    and the storage files the metadata lists (``relative_file_paths``).
    """
    entries = sorted(p.name for p in path.iterdir())
    if not entries:
        return ""
    meta = path / "metadata.yaml"
    if not meta.is_file():
        return "it is a folder that holds files but no rosbag2 metadata.yaml, so it is not a bag"
    info = _metadata(meta)
    custom = info.get("custom_data") if info is not None else None
    key, value = MARK
    if not isinstance(custom, dict) or custom.get(key) != value:
        return (
            f"it looks like a bag not written by nhsim (its metadata.yaml has no custom_data mark '{key}: {value}', "
            "which nhsim writes into every bag)"
        )
    listed = info.get("relative_file_paths") if info is not None else None
    known = {"metadata.yaml", *(str(f) for f in listed or [])}
    extra = [name for name in entries if name not in known]
    if extra:
        shown = ", ".join(extra[:3]) + (f" and {len(extra) - 3} more" if len(extra) > 3 else "")
        return f"it is a bag nhsim wrote, but it also holds {shown}, which nhsim did not write"
    return ""


def _metadata(meta: Path) -> dict[str, Any] | None:
    """The ``rosbag2_bagfile_information`` mapping of a ``metadata.yaml``, or None when it is not one."""
    import yaml

    try:
        data = yaml.safe_load(meta.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return None
    info = data.get("rosbag2_bagfile_information") if isinstance(data, dict) else None
    return info if isinstance(info, dict) else None


def _unmovable(path: Path) -> str:
    """Why the existing bag folder ``path`` cannot be moved into another folder beside it, or "" when
    nothing shows it: the rename needs write and search permission on its folder, write permission on the
    bag folder itself (its ``..`` entry changes), no immutable flag on it nor an immutable or append-only
    flag on its folder, a sticky folder's rename rights, and a bag folder that is no mount point."""
    parent = path.parent
    link = path.is_symlink()  # the link is moved, not the folder it names
    flags = inode_flags(parent)  # before the permissions: access() refuses writing an immutable inode too
    if flags & (IMMUTABLE | APPEND_ONLY):
        what = "immutable" if flags & IMMUTABLE else "append-only"
        return f"its folder {parent} is {what} (as root: chattr -i -a {parent})"
    if not link and inode_flags(path) & IMMUTABLE:
        return f"it is immutable (lsattr -d shows 'i'; as root: chattr -i {path})"
    if not os.access(parent, os.W_OK | os.X_OK):
        need = "write and search permission"
        return f"its folder {parent} lets no entry be renamed (that needs {need}: chmod u+wx {parent})"
    if not link and not os.access(path, os.W_OK):
        return f"it is not writable, and a folder moved into another needs that (chmod u+w {path})"
    info, folder = path.lstat(), parent.stat()
    if folder.st_mode & stat.S_ISVTX and os.geteuid() not in (0, info.st_uid, folder.st_uid):
        return f"its folder {parent} is sticky (as /tmp is) and neither it nor {path} is yours: only an owner moves it"
    if not link and os.path.ismount(path):
        return "it is a mount point"
    return ""


def check_bag_apart(bag: Path, files: Iterable[Path]) -> None:
    """Check, before any work, that no file output of the same command is the bag folder or lies inside it.

    Raises:
        ConfigError: Naming the file and the bag.
    """
    folder = Path(bag).resolve()
    for f in files:
        target = Path(f).resolve()
        if target == folder or folder in target.parents:
            raise ConfigError(
                f"{f} and --bag {bag} share a path (the bag is a folder of that name); choose distinct names"
            )


def latched_qos() -> Any:
    """Transient-local, reliable, keep-last-1: a late subscriber (RViz, Foxglove) gets the message."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    forever = QosTime(sec=2147483647, nsec=4294967295)
    return Qos(
        QosHistory.KEEP_LAST,
        1,
        QosReliability.RELIABLE,
        QosDurability.TRANSIENT_LOCAL,
        forever,
        forever,
        QosLiveliness.AUTOMATIC,
        forever,
        False,
    )


#: Messages serialised at once while a bag is written, about: the bag of a long run is written a stretch of
#: time at a time (a 600 s run's 560,000 messages held at once took 550 MB above the run's own memory).
WINDOW_MESSAGES = 50_000
#: Spacing of the samples of ``/reference`` (and of a reference's ``/plan``) [s]: the trajectory's own
#: samples (every 2-10 ms) thinned to the control period of the default rate.
REFERENCE_PERIOD = 0.02


def _thinned(t: np.ndarray) -> np.ndarray:
    """Indices of the samples at times ``t`` (N,) at least :data:`REFERENCE_PERIOD` apart, the last kept."""
    grid = np.arange(t[0], t[-1], REFERENCE_PERIOD)
    idx = np.unique(np.searchsorted(t, grid - 1e-9))
    return np.unique(np.append(idx[idx < t.size], t.size - 1))


def _distinct(poses: np.ndarray) -> np.ndarray:
    """The poses without the repeats of a trajectory standing still (the path of a reference)."""
    keep = np.concatenate([[True], np.any(np.abs(np.diff(poses, axis=0)) > 1e-9, axis=1)])
    return poses[keep]


def _once(message: Any) -> Callable[[int], Any]:
    """The ``make`` of a topic of one message."""
    return lambda k: message


def ros_name(label: str) -> str:
    """A run's label as a ROS name (letters, digits and underscores, not starting with a digit)."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", label)
    return name if name[:1].isalpha() else f"run_{name}"


def job_topics(prepared: Any, logs: Mapping[str, Any]) -> list[bt.Topic]:
    """Every topic of a job (see :mod:`sim.io.bag_topics`), the per-run ones under each run's name.

    Args:
        prepared: The job's :class:`sim.pipeline.case.PreparedTrajectory` (robot, world, trajectory, plan).
        logs: Run label (a run kind, a tracker) -> its :class:`sim.physics.runlog.RunLog`.
    """
    sk = bt.skeleton(prepared.robot.name)
    sensing = prepared.case.sensing(prepared.scenario)
    names = [ros_name(str(label)) for label in logs]
    topics: list[bt.Topic] = []
    for k, (ns, log) in enumerate(zip(names, logs.values(), strict=True)):
        topics += bt.run_topics(ns, log, prepared.robot, sk, sensing)
        colour = bt.RUN_COLOURS[min(k, len(bt.RUN_COLOURS) - 1)]
        robot = bt.robot_markers(ns, prepared.robot, sk, colour)
        topics.append(bt.Topic(f"/{ns}/robot", m.TYPES["markers"], np.zeros(1), _once(robot), latched=True))
    times = np.unique(np.concatenate([log.t for log in logs.values()]))
    clock = m.msg(m.TYPES["clock"])
    topics.append(bt.Topic("/clock", m.TYPES["clock"], times, rows=(clock(clock=m.stamp(0.0)), {"clock": times})))
    traj, world = prepared.trajectory, prepared.scenario.world
    ref = _thinned(traj.t)
    path = prepared.path if prepared.path is not None else _distinct(traj.pose[ref])
    once = [
        ("/tf_static", "tf", bt.static_transforms(names, sk)),
        ("/plan", "path", m.path(0.0, "map", np.asarray(path, dtype=float))),
        ("/reference", "path", m.path(0.0, "map", traj.pose[ref], traj.t[ref])),
        ("/map", "grid", bt.map_message(world)),
        ("/obstacles", "markers", bt.obstacle_markers(world, prepared.scenario.unmapped)),
    ]
    for name, kind, message in once:
        topics.append(bt.Topic(name, m.TYPES[kind], np.zeros(1), _once(message), latched=True))
    return bt.joined(topics)  # the runs' transforms as one /tf


def _write(topics: list[bt.Topic], folder: Path) -> None:
    """Write the topics into a new rosbag2 folder, messages in time order (ties: topic order, then message
    order), serialised a stretch of time at a time (:data:`WINDOW_MESSAGES`)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    writer = Writer(folder, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    writer.set_custom_data(*MARK)  # what check_bag_target looks for before it replaces the bag
    stamps = [np.round(tp.times * 1e9).astype(np.int64) for tp in topics]
    by_time = [np.argsort(ns, kind="stable") for ns in stamps]  # a joined topic's parts each start over
    sorted_ns = [ns[k] for ns, k in zip(stamps, by_time, strict=True)]
    total = sum(ns.size for ns in stamps)
    first = min((int(ns[0]) for ns in sorted_ns if ns.size), default=0)
    last = max((int(ns[-1]) for ns in sorted_ns if ns.size), default=0)
    cuts = np.linspace(first, last + 1, 2 + total // WINDOW_MESSAGES).astype(np.int64)
    with writer:
        conns = [
            writer.add_connection(
                tp.name, tp.msgtype, typestore=m.typestore(), offered_qos_profiles=[latched_qos()] if tp.latched else []
            )
            for tp in topics
        ]
        for lo, hi in itertools.pairwise(cuts.tolist()):  # the messages stamped in [lo, hi) ns
            picked = [
                np.sort(k[np.searchsorted(ns, lo) : np.searchsorted(ns, hi)])
                for ns, k in zip(sorted_ns, by_time, strict=True)
            ]
            payloads = [tp.serialized(pick) for tp, pick in zip(topics, picked, strict=True)]
            topic = np.concatenate([np.full(pick.size, i) for i, pick in enumerate(picked)])
            message = np.concatenate(picked)
            slot = np.concatenate([np.arange(pick.size) for pick in picked])  # its place in payloads[topic]
            ns = np.concatenate([s[pick] for s, pick in zip(stamps, picked, strict=True)])
            order = np.lexsort((message, topic, ns))  # by time, then topic, then message
            for i, k, t in zip(topic[order].tolist(), slot[order].tolist(), ns[order].tolist(), strict=True):
                writer.write(conns[i], t, payloads[i][k])


def _swap_in(new: Path, path: Path, aside: Path, *, overwrite: bool) -> None:
    """Move the finished bag ``new`` to ``path``, an existing bag there first moved to ``aside`` (a folder
    cannot be renamed over a folder that holds files). The two renames are one step: SIGINT and SIGTERM
    wait until both are done, and when the second fails the old bag goes back, so ``path`` always holds
    one complete bag, the old or the new (an interrupt acts once the new one is in place)."""
    with signals_held():
        if path.exists():
            check_bag_target(path, overwrite=overwrite)
            os.replace(path, aside)
        try:
            os.replace(new, path)
        except BaseException:
            if aside.exists():
                os.replace(aside, path)
            raise


def _not_placed(path: Path, work: Path, exc: BaseException) -> str:
    """What :class:`BagNotPlacedError` says: why, where the old bag is, and that the new one is removed."""
    reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
    old = work / "replaced"
    if old.exists():  # moved aside and not back: it stays there, named
        kept = f"the old bag could not be moved back either: it is at {old}; move it back to {path}"
    elif path.exists():
        kept = f"{path} still holds the old bag"
    else:
        kept = f"nothing is at {path}"
    if isinstance(exc, NhsimError):  # the check made again as the bag moves in: it says why and the fix
        return f"{exc} (found as the new bag was moved in); {kept}; the new bag was not kept"
    why = _unmovable(path) if path.exists() else ""
    fix = f"{path}: {why}" if why else f"check that {path} and its folder can be renamed (permissions, lsattr -d)"
    return (
        f"could not put the new bag in place at {path}: {reason}; {kept}; the new bag was not kept: {fix}, then "
        f"run the command again, or choose another folder with {option('bag', python='path')}"
    )


def write_job_bag(result: Any, path: Path, *, overwrite: bool = False) -> BagSummary:
    """Write a :class:`sim.pipeline.simulate.JobResult`'s runs as a bag (see :func:`write_bag`)."""
    return write_bag(result.prepared, result.logs, path, overwrite=overwrite)


def write_bag(prepared: Any, logs: Mapping[str, Any], path: Path, *, overwrite: bool = False) -> BagSummary:
    """Write a job's runs as a rosbag2 folder at ``path`` (atomically: built beside it, then moved into place).

    Args:
        prepared: The job's :class:`sim.pipeline.case.PreparedTrajectory`.
        logs: Run label -> run log (each run's namespace and frame prefix, see :func:`ros_name`).
        path: The bag folder to create.
        overwrite: Replace an existing bag there.

    Raises:
        OutputExistsError, ConfigError: See :func:`check_bag_target`.
        BagNotPlacedError: The finished bag could not be moved into place (the old bag is kept).
    """
    start, cpu = time.perf_counter(), time.process_time()
    path = Path(path)
    check_bag_target(path, overwrite=overwrite)
    topics = job_topics(prepared, logs)
    work: Path | None = None
    with folder_for(path):
        try:
            with signals_held():  # an interrupt landing as the folder is made waits until ``work`` names it
                work = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent))
            _write(topics, work / path.name)
            try:
                _swap_in(work / path.name, path, work / "replaced", overwrite=overwrite)
            except (OSError, NhsimError) as exc:
                error = BagNotPlacedError(_not_placed(path, work, exc))
                if (work / "replaced").exists():  # the old bag, moved aside and not back: kept there, named
                    shutil.rmtree(work / path.name, ignore_errors=True)
                    work = None
                raise error from exc
        finally:
            if work is not None:
                shutil.rmtree(work, ignore_errors=True)
    stamps = np.concatenate([tp.times for tp in topics])
    size = sum(f.stat().st_size for f in path.iterdir() if f.is_file())
    counts = {tp.name: (tp.msgtype, int(tp.times.size)) for tp in topics}
    span = float(stamps.max() - stamps.min())
    return BagSummary(path, counts, size, span, time.perf_counter() - start, time.process_time() - cpu)
