"""Trajectory and path files brought into metres and seconds, repaired where that is safe, and said so.

:func:`read_trajectory_file` reads a file (:mod:`planning.trajectory.file_formats`), applies
``scale`` (lengths and their derivatives), ``time_scale`` (the clock) and ``offset`` (a rigid move
into the scenario's frame), and repairs what real files get wrong:

* **Repeated time stamps at one position** (where polynomial pieces meet) merge into one row, the
  given derivatives averaged; repeated or decreasing stamps at *different* positions are an error
  naming the rows. A path's consecutive rows at one pose merge too.
* **Headings** are unwrapped (jumps of more than pi between rows count as wraps).
* **Given derivatives** are checked against the positions by the trapezoid rule over every interval,
  and over every span of rows that moves at least a tolerance's reach (so that dense rows, each within
  the absolute tolerance, cannot hide rates that are wrong all along, such as a column of zeros):
  velocities (``vx, vy``, or ``v`` along the heading) must move the robot as the rows do within
  :data:`DISPLACEMENT_TOLERANCE` (1 cm + 10 % of the step; spans of 10 cm); accelerations must change
  the velocities as they do within :data:`VELOCITY_TOLERANCE` (2 cm/s + 10 %; spans of 0.2 m/s);
  ``omega`` must turn the heading as it turns within :data:`HEADING_TOLERANCE` (0.02 rad + 10 %;
  spans of 0.2 rad). A column set that misses anywhere is
  replaced by the positions' own derivatives, with a note and the largest change. A heading more
  than :data:`HEADING_TO_MOTION` (0.1 rad) off the direction of motion, where the motion resolves
  one, is replaced by it when the file becomes a trajectory (the robot cannot move sideways:
  :func:`planning.trajectory.file_trajectory.densify`; the note is made there).

The positions' own derivatives come from one curve through all rows
(:func:`planning.trajectory.row_curves.stretch_fit`): a cubic spline at rest at the stops (the file's
ends, where stand-stills begin and end, corners sharper than 90 degrees, cusps included), made
shape-preserving where rows far apart in time would make it ring: a file without velocities starts
and ends at rest. Given velocities that pass the check are kept as Hermite data (with
accelerations: quintic Hermite pieces). Rows read elsewhere (a bag's messages) go through the same
steps with :func:`import_table`. The cost is linear in the rows.

:mod:`planning.trajectory.file_trajectory` turns the result into a trajectory in a world.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from planning.core.checks import check_flag, check_number
from planning.core.geometry import wrap_angle
from planning.errors import ConfigError, option, options
from planning.trajectory.file_formats import (
    DOCUMENT_SUFFIXES,
    PLAN_RECORD,
    TEXT_SUFFIXES,
    FileTable,
    TrajectoryFileError,
    given_columns,
    quaternion_columns,
    read_table,
)
from planning.trajectory.row_curves import MOVING_SPEED as MOVING_SPEED
from planning.trajectory.row_curves import SAME_POSITION as SAME_POSITION
from planning.trajectory.row_curves import PositionCurve as PositionCurve
from planning.trajectory.row_curves import hermite_curve
from planning.trajectory.row_curves import stretch_fit as stretch_fit

FloatArray = NDArray[np.float64]

#: Stamps closer than this are one stamp [s] (rows closer than SAME_POSITION are at one position).
SAME_TIME = 1e-9
#: (absolute, relative, reach) of the trapezoid checks: displacement [m], velocity change [m/s], heading
#: change [rad]; besides every interval, every span of rows whose changes add up to the reach is checked.
DISPLACEMENT_TOLERANCE = (0.01, 0.10, 0.10)
VELOCITY_TOLERANCE = (0.02, 0.10, 0.20)
HEADING_TOLERANCE = (0.02, 0.10, 0.20)
#: Largest angle between a given heading and the direction of motion (forwards or backwards) [rad].
HEADING_TO_MOTION = 0.1
#: Longest trajectory a file may describe [s]: a longer one almost surely counts milliseconds.
MAX_DURATION = 3600.0
#: A trajectory never faster than this [m/s] and longer than CRAWL_DURATION [s] gets a note on its time unit.
CRAWL_SPEED, CRAWL_DURATION = 0.01, 600.0
#: Shortest trajectory a file may describe [s]: a shorter one is almost surely read in the wrong time unit (a
#: file of 10 ms or so is read and re-timed, as every file too fast for the robot).
MIN_DURATION = 1e-6

#: Farthest a file's position may be from the origin once scaled and moved [m].
MAX_COORDINATE = 1e9

_DERIVATIVES = ("v", "omega", "vx", "vy", "ax", "ay")


@dataclass(frozen=True)
class TrajectoryFile:
    """A trajectory (timed) or path (untimed) file and how to read it.

    Attributes:
        path: The file.
        timed: True for ``--trajectory`` (its time stamps are used), False for ``--path``.
        columns: Names of a text file's columns (``--columns``: a sequence, or one string of them separated by
            commas or spaces), or a layout's name (``"tum"``, :data:`~planning.trajectory.file_formats.LAYOUTS`);
            None: its header names them.
        scale: Metres per file length unit (lengths and their derivatives); None: 1 (not given).
        time_scale: Seconds per file time unit; None: 1.
        offset: (x [m], y [m], theta [rad]) rigid move applied after scaling: rotate by theta about
            the origin, then shift.
        allow_collisions: Run a file that enters an obstacle or leaves the world anyway.
        topic: The topic of a bag to read (:mod:`planning.trajectory.bag_file`); None for other files.
        message: Which message of a bag's path topic (None: the last).
    """

    path: Path
    timed: bool = True
    columns: tuple[str, ...] | None = None
    scale: float | None = None
    time_scale: float | None = None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    allow_collisions: bool = False
    topic: str | None = None
    message: int | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))
        for name in ("timed", "allow_collisions"):  # "no" would read as true
            try:
                object.__setattr__(self, name, check_flag(f"TrajectoryFile.{name}", getattr(self, name)))
            except ConfigError as exc:
                raise TrajectoryFileError(str(exc)) from exc
        for name in ("scale", "time_scale"):
            try:
                check_number(option(name.replace("_", "-")), getattr(self, name), above=0.0, optional=True)
            except ConfigError as exc:
                raise TrajectoryFileError(str(exc)) from exc
        if len(self.offset) != 3 or not all(np.isfinite(self.offset)):
            raise TrajectoryFileError(f"{option('offset')} must be three finite numbers X,Y,THETA, got {self.offset}")
        if self.columns is not None:  # "t,x,y" or "tum" as --columns takes them (not a name per letter), or names
            object.__setattr__(self, "columns", given_columns(self.columns))

    @property
    def name(self) -> str:
        """The file's stem (names the trajectory and the outputs)."""
        return self.path.stem

    def as_dict(self) -> dict[str, Any]:
        """The options as JSON-ready fields."""
        return {
            "file": str(self.path),
            "kind": "trajectory" if self.timed else "path",
            "columns": list(self.columns) if self.columns else None,
            "scale": self.scale,
            "time_scale": self.time_scale,
            "offset": list(self.offset),
            "allow_collisions": self.allow_collisions,
            "topic": self.topic,
            "message": self.message,
        }


def parse_offset(text: str) -> tuple[float, float, float]:
    """``--offset X,Y,THETA`` (metres, metres, radians) as numbers.

    Raises:
        TrajectoryFileError: Not three comma-separated finite numbers.
    """
    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(np.isfinite(values)):
        raise TrajectoryFileError(f"--offset {text!r}: expected X,Y,THETA (metres, metres, radians), e.g. 1.5,0,0.3")
    from planning.core.checks import heading_beyond

    beyond = heading_beyond(values[2])  # a typo or degrees, as a scenario's heading is judged
    if beyond:
        raise TrajectoryFileError(f"--offset {text!r}: THETA is {beyond}")
    return values  # type: ignore[return-value]


def parse_columns(text: str) -> tuple[str, ...]:
    """``--columns t,x,y,...`` as checked names (``_`` skips a column).

    Raises:
        TrajectoryFileError: An unknown or repeated name (the message lists the valid ones).
    """
    return given_columns(text)


@dataclass(frozen=True)
class Correction:
    """One repair of given values, at its largest.

    Attributes:
        what: The values repaired ("velocity (vx, vy)", "theta", ...).
        row: Where the change was largest ("line 7").
        given: The file's value(s) there (after units).
        used: The value(s) used instead.
        difference: Size of the change (vector norm) in ``unit``.
        tolerance: What the check allowed there, in ``unit`` (of the checked quantity).
        unit: Unit of ``difference``.
    """

    what: str
    row: str
    given: tuple[float, ...]
    used: tuple[float, ...]
    difference: float
    tolerance: float
    unit: str

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "what": self.what,
            "row": self.row,
            "given": list(self.given),
            "used": list(self.used),
            "difference": self.difference,
            "unit": self.unit,
        }


@dataclass
class ImportReport:
    """What reading a file did: rows read and merged, every repair, the timing and the world check.

    Attributes:
        file: The file.
        fmt: Its format.
        kind: "trajectory" or "path".
        rows_read: Data rows in the file.
        rows_merged: Rows merged into their neighbour (repeated stamps or poses).
        notes: One sentence per repair or decision, in order.
        corrections: The repaired value sets, each at its largest change.
        headings_unwrapped: Jumps of 2 pi removed from the headings.
        retimed: Whether the trajectory was re-timed (None before timing; False for a kept clock).
        timing: Why it was re-timed, or how its clock was kept.
        time_stretch: The uniform clock stretch applied to a kept timing (1: none).
        world: The world check's finding ("" when the file stays clear).
        collisions_allowed: The file was run although it collides or leaves the world.
        arena: The world is an arena sized around the file (no scenario given).
        frame: The frame the poses were recorded in (a bag's ``header.frame_id``, "" when empty): placed in the
            scenario's map frame by the bag's transforms where it has a chain of them from ``map``, else taken
            as the map frame (the notes say which); None for a file without frames.
    """

    file: str
    fmt: str
    kind: str
    rows_read: int
    rows_merged: int = 0
    notes: list[str] = field(default_factory=list)
    corrections: list[Correction] = field(default_factory=list)
    headings_unwrapped: int = 0
    retimed: bool | None = None
    timing: str = ""
    time_stretch: float = 1.0
    world: str = ""
    collisions_allowed: bool = False
    arena: bool = False
    frame: str | None = None

    @property
    def largest_correction(self) -> Correction | None:
        """The repair that changed its values most, measured in units of its check's tolerance."""
        return max(self.corrections, key=lambda c: c.difference / max(c.tolerance, 1e-12), default=None)

    def as_dict(self) -> dict[str, Any]:
        """The record's ``import`` section."""
        largest = self.largest_correction
        return {
            "file": self.file,
            "format": self.fmt,
            "kind": self.kind,
            "rows_read": self.rows_read,
            "rows_merged": self.rows_merged,
            "retimed": self.retimed,
            "timing": self.timing,
            "time_stretch": self.time_stretch,
            "headings_unwrapped": self.headings_unwrapped,
            "corrections": [c.as_dict() for c in self.corrections],
            "largest_correction": largest.as_dict() if largest is not None else None,
            "notes": list(self.notes),
            "world": self.world,
            "collisions_allowed": self.collisions_allowed,
            "arena": self.arena,
            "frame": self.frame,
        }


@dataclass(frozen=True)
class ImportedFile:
    """A file in metres and seconds, repaired: what :mod:`planning.trajectory.file_trajectory` needs.

    Attributes:
        source: The file and its options.
        rows: (N,) how messages name the rows kept.
        xy: (N, 2) positions [m].
        t: (N,) strictly increasing times [s] (None for a path).
        theta: (N,) given headings, unwrapped [rad], or None.
        direction: (N - 1,) +1/-1 travel direction over each interval.
        curve: Position interpolant in time (a timed file), or None.
        omega: (N,) checked yaw rates [rad/s] to interpolate the headings with, or None.
        report: What was read and repaired.
        velocities: ``curve`` passes through the file's own velocities (else it starts and ends at rest).
    """

    source: TrajectoryFile
    rows: tuple[str, ...]
    xy: FloatArray
    t: FloatArray | None
    theta: FloatArray | None
    direction: FloatArray
    curve: PositionCurve | None
    omega: FloatArray | None
    report: ImportReport
    velocities: bool = False


# ------------------------------------------------------------------------------------ reading
def read_trajectory_file(source: TrajectoryFile | str | os.PathLike[str]) -> ImportedFile:
    """Read a file (text, JSON, YAML, or a bag's topic), bring it into metres and seconds and repair it
    (see the module doc).

    Args:
        source: The file and how to read it; a path alone reads a timed trajectory with its header's columns
            (``TrajectoryFile(path)``; a path of untimed poses is ``TrajectoryFile(path, timed=False)``).

    Raises:
        ConfigError: ``source`` is neither a TrajectoryFile nor a path.
        TrajectoryFileError: Unreadable file, unknown columns, missing x or y (or t for a trajectory),
            a non-numeric cell, stamps that go back or repeat at different positions, fewer than
            two distinct positions.
    """
    if isinstance(source, (str, os.PathLike)):
        source = TrajectoryFile(Path(source))
    if not isinstance(source, TrajectoryFile):
        raise ConfigError(
            f"read_trajectory_file takes a TrajectoryFile or a path, got {type(source).__name__}: "
            "read_trajectory_file(TrajectoryFile(path, timed=False)) for a path of untimed poses"
        )
    return import_table(_read_source(source), source)


def import_table(table: FileTable, source: TrajectoryFile) -> ImportedFile:
    """Bring rows already read into metres and seconds and repair them (see the module doc).

    The entry point for sources that are not text, JSON or YAML files (a ROS 2 bag's messages): build
    the table with :func:`planning.trajectory.file_formats.table_from_arrays`, then import it with the
    options of ``source`` (``timed``, ``scale``, ``time_scale``, ``offset``, ``allow_collisions``;
    ``columns`` names a text file's columns and is not used here). The cost is linear in the rows.

    Args:
        table: The rows, in the source's units, named for messages.
        source: The source (``source.path`` names it in messages) and how to read it.

    Returns:
        The imported rows, their curve (a timed source) and the report of every repair.

    Raises:
        TrajectoryFileError: Missing x or y (or t for a trajectory), stamps that go back or repeat at
            different positions, fewer than two distinct positions (the rows named).
    """
    report = ImportReport(str(source.path), table.fmt, "trajectory" if source.timed else "path", len(table))
    report.frame = table.frame
    report.notes.extend(table.notes)
    cols = _required(table, source, report)
    if "theta" in cols:
        _refuse_degrees(cols, table.rows, report)
    cols = _to_metres(cols, source)
    rows = table.rows
    if "theta" in cols:
        cols["theta"], report.headings_unwrapped = _unwrap(cols["theta"], rows, report)
    if source.timed:
        _refuse_instant(report.file, cols["t"], source.time_scale or 1.0)
    rows, cols = _merge(rows, cols, source.timed, report)
    _check_distinct(table, cols, source.scale)
    _note_outliers(rows, cols["xy"], report)
    if not source.timed:
        return ImportedFile(source, rows, cols["xy"], None, cols.get("theta"), _directions(cols), None, None, report)
    return _timed(source, rows, cols, report)


#: A row is said to stand out (:func:`_note_outliers`) when it lies this many times the file's median step off both
#: its neighbours, and at least OUTLIER_MIN [m], and they lie less than half that apart: out and back.
OUTLIER_STEPS, OUTLIER_MIN = 10.0, 0.1
#: Rows :func:`_note_outliers` names one by one (the rest are counted).
OUTLIER_NOTES = 5


def _note_outliers(rows: tuple[str, ...], xy: FloatArray, report: ImportReport) -> None:
    """Note each row that lies far off both its neighbours, which lie close together, by the file's own steps (a
    position fix's glitch: the trajectory goes out to it and back, as the file says, the robot driving metres for a
    row that may be noise). A turn back at the far end of a drive is no such row: its steps are the file's own."""
    if xy.shape[0] < 3:
        return
    step = np.hypot(*np.diff(xy, axis=0).T)
    off = np.minimum(step[:-1], step[1:])
    across = np.hypot(*(xy[2:] - xy[:-2]).T)
    median = float(np.median(step))
    odd = np.flatnonzero((off > max(OUTLIER_MIN, OUTLIER_STEPS * median)) & (across < 0.5 * off))
    for k in odd[:OUTLIER_NOTES]:
        report.notes.append(
            f"{rows[k + 1]} lies {off[k]:.3g} m off the rows either side of it, which lie {across[k]:.3g} m apart "
            f"({off[k] / max(median, 1e-12):.0f} times the file's median step): the trajectory goes out to it and "
            "back; if it is a glitch of the position fix, drop the row"
        )
    if odd.size > OUTLIER_NOTES:
        report.notes.append(f"{odd.size - OUTLIER_NOTES} more rows lie so far off their neighbours")


def _read_source(source: TrajectoryFile) -> FileTable:
    """The file's columns: a bag's topic (:mod:`planning.trajectory.bag_file`), else a text, JSON or YAML file."""
    from planning.trajectory.bag_file import is_bag, read_bag_table

    path = Path(source.path)
    if (
        path.is_dir()
        and path.suffix.lower() in TEXT_SUFFIXES[1:] + DOCUMENT_SUFFIXES
        and not (path / "metadata.yaml").exists()
    ):
        raise TrajectoryFileError(  # named like a file, and no bag: not "a bag without its metadata.yaml"
            f"{path} is a folder, not a {path.suffix[1:].upper()} file; give the file (or a rosbag2 bag folder)"
        )
    if source.topic is None and source.message is None and not is_bag(source.path):
        return read_table(source.path, source.columns)
    if not is_bag(source.path):
        if not Path(source.path).exists():  # a mistyped bag folder: say so, not that the options do not apply
            raise TrajectoryFileError(f"cannot read bag {source.path}: no such file or folder; check the path")
        raise TrajectoryFileError(
            f"{source.path}: {options('topic', 'message')} read a bag (.mcap, .bag, .db3 or a rosbag2 folder): "
            "drop them"
        )
    if source.columns is not None:
        raise TrajectoryFileError(
            f"{source.path}: {option('columns')} names a text file's columns; a bag's topic names its own"
        )
    return read_bag_table(source.path, source.topic, source.message, timed=source.timed)


def _required(table: FileTable, source: TrajectoryFile, report: ImportReport) -> dict[str, FloatArray]:
    cols, notes = quaternion_columns(table)
    report.notes.extend(notes)
    missing = [c for c in ("x", "y") if c not in cols]
    if source.timed and "t" not in cols:
        missing.insert(0, "t")
    if missing:
        hint = f"; a file without time stamps is a path: use {option('path', python='timed=False')}"
        hint = hint if missing == ["t"] else ""
        named = table.fmt in ("json", "yaml", "nav_msgs/Path", PLAN_RECORD)  # a document names its fields: no --columns
        where = "give it in each pose" if named else f"name it in the header or with {option('columns')}"
        if source.columns is not None and not named:
            where = f"name it with {option('columns')}, which names every column (the header's names are not read)"
        if named and missing == ["t"]:  # a document without stamps: a path, for the path option alone
            where = f"a {table.fmt} whose poses carry no times (or all the same stamp) is a path"
            hint = f": use {option('path', python='timed=False')}, or give each pose its time"
        if table.fmt == PLAN_RECORD and missing == ["t"]:
            where = f"an {PLAN_RECORD} holds a path, without times: use {option('path', python='timed=False')}"
            hint = " (it is timed by the robot's limits, as the planner's path is)"
        raise TrajectoryFileError(
            f"{table.path}: no column {' or '.join(missing)} (columns: {', '.join(cols) or 'none'}); {where}{hint}"
        )
    if len(table) < 2:
        rows = f"one row ({table.rows[0]})" if len(table) else "no rows"
        raise TrajectoryFileError(
            f"{table.path}: {rows}; a trajectory needs at least two positions: give rows at two positions or more"
        )
    if not source.timed:
        ignored = [c for c in ("t", *_DERIVATIVES) if c in cols]
        if ignored:
            report.notes.append(f"a path is timed by the robot's limits: columns {', '.join(ignored)} ignored")
        cols = {k: v for k, v in cols.items() if k in ("x", "y", "theta")}
    return cols


def _to_metres(cols: dict[str, FloatArray], source: TrajectoryFile) -> dict[str, FloatArray]:
    """Scale lengths and the clock, then move by the offset; ``xy``, ``vxy``, ``axy`` as (N, 2)."""
    s = source.scale or 1.0
    ts = source.time_scale or 1.0
    ox, oy, oth = source.offset
    c, si = np.cos(oth), np.sin(oth)

    def turn(u: FloatArray, w: FloatArray, k: float) -> FloatArray:  # (N, 2): (u, w) * k turned by oth
        return np.column_stack([k * (c * u - si * w), k * (si * u + c * w)])

    with np.errstate(over="ignore", invalid="ignore"):
        out: dict[str, FloatArray] = {"xy": turn(cols["x"], cols["y"], s) + np.array([ox, oy])}
    far = float(np.max(np.abs(out["xy"]))) if np.all(np.isfinite(out["xy"])) else np.inf
    if far > MAX_COORDINATE:
        offset = ("offset", f"{ox:g},{oy:g},{oth:g}", f"offset=({ox:g}, {oy:g}, {oth:g})")
        raise TrajectoryFileError(
            f"{source.path}: after {options(('scale', s), offset)} the "
            f"file's positions reach {far:.3g} m from the origin, more than {MAX_COORDINATE:g} m: give the scale in "
            "metres per file unit and an offset that moves the file next to the world"
        )
    if "t" in cols:
        out["t"] = cols["t"] * ts
    if "theta" in cols:
        out["theta"] = cols["theta"] + oth
    if "v" in cols:
        out["v"] = cols["v"] * s / ts
    if "omega" in cols:
        out["omega"] = cols["omega"] / ts
    for pair, power in (("v", 1), ("a", 2)):
        names = (f"{pair}x", f"{pair}y")
        if all(n in cols for n in names):
            out[f"{pair}xy"] = turn(cols[names[0]], cols[names[1]], s / ts**power)
        elif any(n in cols for n in names):
            raise TrajectoryFileError(f"columns {names[0]} and {names[1]} come together: give both or neither")
    return out


def _refuse_degrees(cols: dict[str, FloatArray], rows: tuple[str, ...], report: ImportReport) -> None:
    """Refuse headings written in degrees: following the direction of motion (forwards or backwards, in the
    median over the intervals that move) within HEADING_TO_MOTION when read as degrees but not when read
    as radians, and either beyond a turn or (all within 2 pi, so all within 0.11 rad of the x axis as
    degrees) explaining the motion's direction better than headings of zero would: a file in radians
    along the x axis (forwards, or backwards at about pi) agrees as radians, and its headings read as
    degrees say no more than zeros do (a constant bias of a radian file is not taken for degrees)."""
    theta = cols["theta"]
    d = np.diff(np.column_stack([cols["x"], cols["y"]]), axis=0)
    moving = np.hypot(d[:, 0], d[:, 1]) > 0.0
    if not np.any(moving):
        return
    motion = np.arctan2(d[moving, 1], d[moving, 0])

    def off(h: FloatArray) -> float:  # median over the moving intervals of the nearer end's angle to the motion
        ends = np.column_stack([h[:-1][moving], h[1:][moving]]) - motion[:, None]
        return float(np.median(np.min(np.abs(wrap_angle(2.0 * ends)), axis=1))) / 2.0

    as_rad, as_deg = off(theta), off(np.radians(theta))
    if not as_deg <= HEADING_TO_MOTION < as_rad:
        return
    beyond = float(np.max(np.abs(theta))) > 2.0 * np.pi + 1e-9
    if not beyond and as_deg >= 0.5 * off(np.zeros_like(theta)):
        return
    k = int(np.argmax(np.abs(theta)))
    within = "" if beyond else ", all within 2 pi"
    raise TrajectoryFileError(
        f"{report.file}: column theta looks like degrees ({theta[k]:g} at {rows[k]}{within}; read as degrees the "
        f"headings follow the motion within {as_deg:.2g} rad in the median, read as radians {as_rad:.2g} rad "
        "off it); give headings in radians (degrees x pi / 180), or leave the column out and the heading "
        "follows the motion"
    )


def _unwrap(theta: FloatArray, rows: tuple[str, ...], report: ImportReport) -> tuple[FloatArray, int]:
    jumps = np.flatnonzero(np.abs(np.diff(theta)) > np.pi)
    if jumps.size:
        where = ", ".join(rows[j + 1] for j in jumps[:3]) + (" ..." if jumps.size > 3 else "")
        report.notes.append(f"headings unwrapped: {jumps.size} jump(s) of 2 pi removed ({where})")
    return np.unwrap(theta), int(jumps.size)


def _pairs(rows: tuple[str, ...], idx: NDArray[np.intp], text: Any) -> str:
    shown = "; ".join(f"{rows[i]} -> {rows[i + 1]} {text(i)}".rstrip() for i in idx[:3])
    return shown + (f"; and {idx.size - 3} more" if idx.size > 3 else "")


def _merge(
    rows: tuple[str, ...], cols: dict[str, FloatArray], timed: bool, report: ImportReport
) -> tuple[tuple[str, ...], dict[str, FloatArray]]:
    """Merge repeated stamps at one position (a path: repeated poses); refuse stamps that go back or
    repeat at another position."""
    xy = cols["xy"]
    step = np.hypot(*np.diff(xy, axis=0).T)
    if timed:
        dt = np.diff(cols["t"])
        back = np.flatnonzero(dt < -SAME_TIME)
        if back.size:
            text = _pairs(rows, back, lambda i: f"(t {cols['t'][i]:g} -> {cols['t'][i + 1]:g} s)")
            raise TrajectoryFileError(f"{report.file}: time goes back: {text}; sort the rows by time or fix the stamps")
        same = np.abs(dt) <= SAME_TIME
        clash = np.flatnonzero(same & (step > SAME_POSITION))
        if clash.size:
            text = _pairs(rows, clash, lambda i: f"(t = {cols['t'][i]:g} s, {step[i]:.4g} m apart)")
            raise TrajectoryFileError(
                f"{report.file}: one time stamp at two positions: {text}; a robot is not at two places at once: "
                f"fix the stamps, or use {option('path', python='timed=False')} to ignore them"
            )
    else:
        theta = cols["theta"] if "theta" in cols else np.zeros(xy.shape[0])
        same = _repeated(xy, theta, (step <= SAME_POSITION) & (np.abs(np.diff(theta)) <= SAME_HEADING))
    if not np.any(same):
        return rows, cols
    group = np.concatenate([[0], np.cumsum(~same)])
    count = np.bincount(group).astype(float)
    first = np.flatnonzero(~np.concatenate([[False], same]))
    merged = {k: v[first] if k == "xy" else _group_mean(v, group, count) for k, v in cols.items()}
    report.rows_merged = int(same.sum())
    what = "repeated time stamps at one position"
    if not timed:
        what = f"repeated poses: within {SAME_POSITION * 1e3:g} mm and {SAME_HEADING * 1e3:g} mrad of their run's first"
    pairs = _pairs(rows, np.flatnonzero(same), lambda i: "")
    report.notes.append(f"{report.rows_merged} row(s) merged ({what}): {pairs}")
    return tuple(rows[i] for i in first), merged


#: Largest heading change between two poses of a path that are merged as one repeated pose [rad].
SAME_HEADING = 1e-3


def _repeated(xy: FloatArray, theta: FloatArray, small: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """(N-1,) whether each row of a path repeats the pose of the group it follows: a ``small`` step from the row
    before, and within :data:`SAME_POSITION` and :data:`SAME_HEADING` of the group's first row. Measured from that
    first row, not from the row before: a path sampled every 7.5 um (200,001 poses over 1.5 m) was merged into one
    row ("all rows are at one position"), its dense stretches into chords; it is thinned to steps of about
    :data:`SAME_POSITION` now."""
    same = np.zeros(small.size, dtype=bool)
    xs, ys, th = xy[:, 0].tolist(), xy[:, 1].tolist(), theta.tolist()
    anchor = 0
    for i in np.flatnonzero(small).tolist():
        if i == 0 or not same[i - 1]:
            anchor = i  # row i begins its group: the step before it did not join it
        near = math.hypot(xs[i + 1] - xs[anchor], ys[i + 1] - ys[anchor]) <= SAME_POSITION
        same[i] = near and abs(th[i + 1] - th[anchor]) <= SAME_HEADING
    return same


def _group_mean(values: FloatArray, group: NDArray[np.intp], count: FloatArray) -> FloatArray:
    if values.ndim == 1:
        return np.bincount(group, weights=values) / count
    return np.column_stack([np.bincount(group, weights=values[:, j]) / count for j in range(values.shape[1])])


def _check_distinct(table: FileTable, cols: dict[str, FloatArray], scale: float | None) -> None:
    """Refuse a file whose rows (scaled) are all at one position, naming the scale when one shrank them so."""
    xy = cols["xy"]
    if float(np.max(np.hypot(*(xy - xy[0]).T))) <= SAME_POSITION:
        scaled = "" if scale is None else f" after {option('scale', scale)}"
        fix = "give rows that move" if scale is None else f"give rows that move, or a larger {option('scale')}"
        raise TrajectoryFileError(
            f"{table.path}: all {len(table)} rows ({table.rows[0]} to {table.rows[-1]}) are at one position "
            f"({xy[0, 0]:g}, {xy[0, 1]:g}){scaled}; a trajectory needs at least two distinct positions: {fix}"
        )


def _directions(cols: dict[str, FloatArray]) -> FloatArray:
    """+1/-1 per interval: from the sign of a given v, else from given headings against the motion,
    else forwards."""
    d = np.diff(cols["xy"], axis=0)
    if "v" in cols:
        v = np.sign(cols["v"])
        s = np.sign(cols["v"][:-1] + cols["v"][1:])
        # v changes sign over an interval: the cusp is at the row where the steps reverse (its start
        # when the step turns back there, else its end)
        flips = np.flatnonzero(v[:-1] * v[1:] < 0)
        back = np.zeros(flips.size, dtype=bool)
        inner = flips > 0
        back[inner] = np.einsum("ij,ij->i", d[flips[inner] - 1], d[flips[inner]]) < 0.0
        s[flips] = np.where(back, v[flips + 1], v[flips])
    elif "theta" in cols:
        mid = 0.5 * (cols["theta"][:-1] + cols["theta"][1:])
        s = np.sign(np.cos(mid) * d[:, 0] + np.sin(mid) * d[:, 1])
    else:
        return np.ones(d.shape[0])
    return np.where(s == 0, 1.0, s)


# ------------------------------------------------------------------------ timed files: derivatives
def _row_direction(direction: FloatArray) -> FloatArray:
    return np.concatenate([direction, direction[-1:]])


def _motion_heading(vel: FloatArray, direction: FloatArray) -> FloatArray:
    """(N,) heading of the motion at each row, backwards where the robot reverses [rad]; at a row where it
    is at rest (slower than MOVING_SPEED), the heading of the nearest moving row before it (the first
    moving row's before any)."""
    s = _row_direction(direction)
    heading = np.arctan2(s * vel[:, 1], s * vel[:, 0])
    moving = np.hypot(vel[:, 0], vel[:, 1]) > MOVING_SPEED
    if not np.any(moving) or np.all(moving):
        return heading
    last = np.maximum.accumulate(np.where(moving, np.arange(heading.size), -1))
    return heading[np.where(last < 0, int(np.argmax(moving)), last)]


class _Check(NamedTuple):
    """A trapezoid check of N rows over every interval and every span of rows that reaches far enough.

    Attributes:
        worst: The span missing most for its tolerance, or -1 when every span is within it.
        start, end: (M,) the first and last row of each span checked.
        change: (M, k) how the rows' values change over each span.
        predicted: (M, k) how the rates say they change.
        miss: (M,) size of the difference (what is checked).
        allowed: (M,) its tolerance.
    """

    worst: int
    start: NDArray[np.intp]
    end: NDArray[np.intp]
    change: FloatArray
    predicted: FloatArray
    miss: FloatArray
    allowed: FloatArray


def _miss(t: FloatArray, values: FloatArray, rates: FloatArray, tol: tuple[float, float, float]) -> _Check:
    """Trapezoid check of ``rates`` (N, k) against ``values`` (N, k): over each interval, and from each row
    to the first one whose changes add up to ``tol[2]``, the change the rates predict must be within
    ``tol[:2]`` (absolute, relative to the change) of the change of the values."""
    step = np.diff(values, axis=0)
    predicted = np.concatenate(
        [np.zeros((1, values.shape[1])), np.cumsum(0.5 * np.diff(t)[:, None] * (rates[:-1] + rates[1:]), axis=0)]
    )
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(step, axis=1))])
    first = np.arange(len(t) - 1)
    reach = np.searchsorted(arc, arc[:-1] + tol[2])
    span = np.flatnonzero((reach > first + 1) & (reach < len(t)))
    start = np.concatenate([first, span])
    end = np.concatenate([first + 1, reach[span]])
    change = values[end] - values[start]
    pred = predicted[end] - predicted[start]
    miss = np.linalg.norm(change - pred, axis=1)
    allowed = tol[0] + tol[1] * np.linalg.norm(change, axis=1)
    worst = int(np.argmax(miss / allowed))
    return _Check(worst if miss[worst] > allowed[worst] else -1, start, end, change, pred, miss, allowed)


def _quantity(value: FloatArray, unit: str) -> str:
    """A value (k,) with its unit: "0.25 rad", "(0.25, -0.04) m"."""
    text = ", ".join(f"{v:.4g}" for v in value)
    return f"{text} {unit}" if value.size == 1 else f"({text}) {unit}"


def _replace(
    report: ImportReport,
    what: str,
    rows: tuple[str, ...],
    check: _Check,
    given: FloatArray,
    used: FloatArray,
    units: tuple[str, str],
    verb: str,
) -> None:
    """Note that ``given`` (N, k) values failed their check at its worst interval, quoting what failed
    (the two changes and how far apart they are), and record the largest change to ``used``.

    Args:
        units: (unit of ``given``, unit of the checked change).
    """
    i, unit = check.worst, units[1]
    report.notes.append(
        f"{what} disagree with the positions: from {rows[check.start[i]]} to {rows[check.end[i]]} they {verb} "
        f"{_quantity(check.predicted[i], unit)} but the rows {verb} {_quantity(check.change[i], unit)}, "
        f"{check.miss[i]:.3g} {unit} apart (tolerance {check.allowed[i]:.3g} {unit}); replaced by the positions' own"
    )
    diff = np.linalg.norm(given - used, axis=1)
    k = int(np.argmax(diff))
    report.corrections.append(
        Correction(
            what,
            rows[k],
            tuple(map(float, given[k])),
            tuple(map(float, used[k])),
            float(diff[k]),
            float(check.allowed[i]),
            units[0],
        )
    )


#: A recording's stamps are read on a steady clock when they scatter about one by at most this fraction of its
#: period (rms), and none by half a period or more.
JITTER_RMS_FRACTION = 0.3
#: Scatter [s] below which stamps are a steady clock's already (a float's rounding, a text file's digits).
STEADY_CLOCK = 1e-6


def steady_clock(t: FloatArray, report: ImportReport) -> FloatArray:
    """The stamps ``t`` (N,) [s] of a recording made at a steady rate, read on that clock: each at its tick of the
    clock fitted to them (least squares over the tick numbers, so a dropped message leaves its gap), when they
    scatter about it by at most :data:`JITTER_RMS_FRACTION` of its period rms and none by half a period; else as
    they are (a file timed otherwise: a planner's knots, an event-driven log).

    A driver stamps its messages when it gets to them, a few milliseconds late or early: 3 ms of scatter on a
    30 Hz odometry made speed steps of 10 % between rows and accelerations the motion never had, so the file was
    re-timed instead of keeping its clock. The note says the scatter and the clock's rate."""
    if t.size < 10:
        return t
    intervals = np.diff(t)
    if np.median(np.abs(intervals - np.median(intervals))) < STEADY_CLOCK:  # most on a clock already: an interval
        return t  # off it (a last row at the motion's end, a pause) is the file's own
    # ticks from one stamp to the next: one, or more where messages were dropped (a stamp late by most of a period
    # and the next one early still make one tick; a clock that is not steady fails the scatter's test below)
    steps = np.maximum(1.0, np.rint(intervals / np.median(intervals)))
    ticks = np.concatenate([[0.0], np.cumsum(steps)])
    basis = np.column_stack([np.ones_like(ticks), ticks])
    (start, step), *_ = np.linalg.lstsq(basis, t, rcond=None)
    scatter = t - (start + step * ticks)
    rms, worst = float(np.sqrt(np.mean(scatter**2))), float(np.max(np.abs(scatter)))
    if worst < STEADY_CLOCK or rms > JITTER_RMS_FRACTION * step or worst >= 0.5 * step:
        return t
    report.notes.append(
        f"time stamps scattered by {rms * 1e3:.3g} ms rms (at most {worst * 1e3:.3g} ms) about a steady "
        f"{1.0 / step:.4g} Hz clock: read on that clock (differentiated, the scatter made accelerations the motion "
        "did not have)"
    )
    return np.asarray(start + step * ticks)


def _timed(
    source: TrajectoryFile, rows: tuple[str, ...], cols: dict[str, FloatArray], report: ImportReport
) -> ImportedFile:
    """A timed file's interpolant: given derivatives where they agree with the positions, else the
    positions' own; headings and yaw rates checked."""
    t, xy = steady_clock(cols["t"], report), cols["xy"]
    if t[-1] - t[0] > MAX_DURATION:
        raise TrajectoryFileError(_too_long(report.file, t[-1] - t[0], source.time_scale or 1.0))
    direction = _directions(cols)
    fit = stretch_fit(t, xy)
    derived = fit(t, 1)
    fastest = fastest_row_speed(t, xy)
    _refuse_standing(report.file, fastest, source.time_scale or 1.0)
    _note_crawling(report, fastest, float(t[-1] - t[0]), source.time_scale or 1.0)
    theta = cols.get("theta")
    heading = theta if theta is not None else np.unwrap(_motion_heading(derived, direction))
    curve: PositionCurve = fit
    given, what, velocities = None, "", False
    if "vxy" in cols:
        given, what = cols["vxy"], "velocities (vx, vy)"
    elif "v" in cols:
        given, what = cols["v"][:, None] * np.column_stack([np.cos(heading), np.sin(heading)]), "speeds v"
    if given is not None:
        check = _miss(t, xy, given, DISPLACEMENT_TOLERANCE)
        if check.worst >= 0:
            _replace(report, what, rows, check, given, derived, ("m/s", "m"), "move")
        else:
            curve = _with_velocities(t, xy, given, cols.get("axy"), rows, report)
            velocities = True
    elif "axy" in cols:
        report.notes.append("accelerations (ax, ay) unused: the file gives no velocities to go with them")
    omega = cols.get("omega")
    if omega is not None:
        check = _miss(t, heading[:, None], omega[:, None], HEADING_TOLERANCE)
        if check.worst >= 0:
            own = np.gradient(heading, t)
            _replace(report, "yaw rates omega", rows, check, omega[:, None], own[:, None], ("rad/s", "rad"), "turn")
            omega = None
    return ImportedFile(source, rows, xy, t, theta, direction, curve, omega, report, velocities)


def fastest_row_speed(t: FloatArray, xy: FloatArray) -> float:
    """The fastest speed between two consecutive rows of a timed file [m/s] (its rows merged: stamps increase)."""
    return float(np.max(np.hypot(*np.diff(xy, axis=0).T) / np.diff(t)))


def _refuse_standing(file: str, fastest: float, time_scale: float) -> None:
    """Refuse a trajectory that never moves faster than MOVING_SPEED between its rows (``fastest``,
    :func:`fastest_row_speed`): the robot would count as standing all along (a clock in milliseconds read as seconds
    makes one)."""
    if fastest >= MOVING_SPEED:
        return
    given = f" at {option('time-scale', time_scale)}" if time_scale != 1.0 else ""
    raise TrajectoryFileError(
        f"{file}: the trajectory moves at {fastest * 1e3:.3g} mm/s at most{given}, slower than the "
        f"{MOVING_SPEED * 1e3:g} mm/s below which the robot counts as standing: if its clock counts milliseconds, "
        f"give the seconds per file time unit, {option('time-scale', time_scale * 1e-3)}"
    )


def _note_crawling(report: ImportReport, fastest: float, span: float, time_scale: float) -> None:
    """Say so when a trajectory never moves faster than :data:`CRAWL_SPEED` between its rows (``fastest``) and
    lasts more than :data:`CRAWL_DURATION` (``span`` [s]): a robot hardly drives so, and a clock in milliseconds
    read as seconds makes one of a file of a few seconds at metres a second (it runs, as the file says, but not
    silently)."""
    if fastest >= CRAWL_SPEED or span <= CRAWL_DURATION:
        return
    report.notes.append(
        f"the trajectory moves at {fastest * 1e3:.3g} mm/s at most over {span / 60:.3g} min: if its clock counts "
        f"milliseconds, give the seconds per file time unit, {option('time-scale', time_scale * 1e-3)}"
    )


def _refuse_instant(file: str, t: FloatArray, time_scale: float) -> None:
    """Refuse a trajectory whose stamps differ but span less than MIN_DURATION: read in seconds, its clock
    is in other units (``--time-scale`` too small, or stamps that are not times)."""
    span = float(np.max(t) - np.min(t))
    if span == 0.0 or span >= MIN_DURATION:  # one stamp for all rows: the merge names the rows
        return
    given = f" at {option('time-scale', time_scale)}" if time_scale != 1.0 else ""
    raise TrajectoryFileError(
        f"{file}: the trajectory lasts {span:.3g} s{given}, less than {MIN_DURATION:g} s: its clock is not in "
        f"seconds: {time_unit_fix(time_scale)}, or fix the stamps"
    )


def time_unit_fix(time_scale: float | None) -> str:
    """The fix for a file whose clock seems not to count seconds: give ``--time-scale``, or check the one given
    (``time_scale``; None or 1: none given)."""
    if time_scale is None or time_scale == 1.0:
        return f"give the seconds per file time unit with {option('time-scale')}"
    return f"check {option('time-scale', time_scale)}: it is the seconds per file time unit (1 for seconds)"


def _too_long(file: str, span: float, time_scale: float) -> str:
    """What to say of a file lasting ``span`` seconds (more than MAX_DURATION) at ``time_scale``: the
    first of milli-, micro- and nanoseconds per file time unit that brings it under the limit."""
    given = f" at {option('time-scale', time_scale)}" if time_scale != 1.0 else ""
    text = f"{file}: the trajectory lasts {span:.6g} s{given}, more than {MAX_DURATION:g} s"
    for power, unit in ((3, "milliseconds"), (6, "microseconds"), (9, "nanoseconds")):
        if span * 10.0**-power <= MAX_DURATION:
            scale = time_scale * 10.0**-power
            fix = f"give the seconds per file time unit, {option('time-scale', scale)}"
            return f"{text}: if its clock counts {unit}, {fix}"
    return f"{text}: give the seconds per file time unit with {option('time-scale')}, or fix the stamps"


def _with_velocities(
    t: FloatArray,
    xy: FloatArray,
    vel: FloatArray,
    acc: FloatArray | None,
    rows: tuple[str, ...],
    report: ImportReport,
) -> PositionCurve:
    """The Hermite interpolant of checked velocities, quintic with accelerations that pass their check."""
    cubic = hermite_curve(t, xy, vel)
    if acc is None:
        return cubic
    check = _miss(t, vel, acc, VELOCITY_TOLERANCE)
    if check.worst >= 0:
        verb = "change the velocity by"
        _replace(report, "accelerations (ax, ay)", rows, check, acc, cubic(t, 2), ("m/s^2", "m/s"), verb)
        return cubic
    return hermite_curve(t, xy, vel, acc)
