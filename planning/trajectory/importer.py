"""Trajectory and path files brought into metres and seconds, repaired where that is safe, and said so.

:func:`read_trajectory_file` reads a file (:mod:`planning.trajectory.file_formats`), applies
``scale`` (lengths and their derivatives), ``time_scale`` (the clock) and ``offset`` (a rigid move
into the scenario's frame), and repairs what real files get wrong:

* **Repeated time stamps at one position** (where polynomial pieces meet) merge into one row, the
  given derivatives averaged; repeated or decreasing stamps at *different* positions are an error
  naming the rows. A path's consecutive rows at one pose merge too.
* **Headings** are unwrapped (jumps of more than pi between rows count as wraps).
* **Given derivatives** are checked against the positions by the trapezoid rule over every interval:
  velocities (``vx, vy``, or ``v`` along the heading) must move the robot as the rows do within
  :data:`DISPLACEMENT_TOLERANCE` (1 cm + 10 % of the step); accelerations must change the velocities
  as they do within :data:`VELOCITY_TOLERANCE` (2 cm/s + 10 %); ``omega`` must turn the heading as it
  turns within :data:`HEADING_TOLERANCE` (0.02 rad + 10 %). A column set that misses anywhere is
  replaced by the positions' own derivatives, with a note and the largest change. A heading more
  than :data:`HEADING_TO_MOTION` (0.1 rad) off the direction of motion is replaced by it (the
  robot cannot move sideways).

The positions' own derivatives come from a cubic spline through each stretch of rows between
stops (the file's ends, stand-stills, and corners sharper than 90 degrees, cusps included), at rest
at both ends of the stretch: a file without velocities starts and ends at rest. Given velocities
that pass the check are kept as Hermite data (with accelerations: quintic Hermite pieces).

:mod:`planning.trajectory.file_trajectory` turns the result into a trajectory in a world.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import BPoly, CubicHermiteSpline, CubicSpline

from planning.core.geometry import wrap_angle
from planning.trajectory.file_formats import FileTable, TrajectoryFileError, parse_column_names, read_table

FloatArray = NDArray[np.float64]

#: Rows closer than this are at one position [m]; stamps closer than SAME_TIME are one stamp [s].
SAME_POSITION = 1e-4
SAME_TIME = 1e-9
#: (absolute, relative) tolerances of the trapezoid checks: displacement [m], velocity change [m/s],
#: heading change [rad].
DISPLACEMENT_TOLERANCE = (0.01, 0.10)
VELOCITY_TOLERANCE = (0.02, 0.10)
HEADING_TOLERANCE = (0.02, 0.10)
#: Largest angle between a given heading and the direction of motion (forwards or backwards) [rad].
HEADING_TO_MOTION = 0.1
#: Speed below which the robot counts as standing [m/s].
MOVING_SPEED = 1e-3
#: Longest trajectory a file may describe [s]: a longer one almost surely counts milliseconds.
MAX_DURATION = 3600.0

_DERIVATIVES = ("v", "omega", "vx", "vy", "ax", "ay")


@dataclass(frozen=True)
class TrajectoryFile:
    """A trajectory (timed) or path (untimed) file and how to read it.

    Attributes:
        path: The file.
        timed: True for ``--trajectory`` (its time stamps are used), False for ``--path``.
        columns: Names of a text file's columns (``--columns``); None: its header names them.
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
        for name in ("scale", "time_scale"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                flag = "--" + name.replace("_", "-")
                raise TrajectoryFileError(f"{flag} must be a finite number > 0, got {value}")
        if len(self.offset) != 3 or not all(np.isfinite(self.offset)):
            raise TrajectoryFileError(f"--offset must be three finite numbers X,Y,THETA, got {self.offset}")
        if self.columns is not None:
            object.__setattr__(self, "columns", parse_column_names(self.columns, "--columns"))

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
    return values  # type: ignore[return-value]


def parse_columns(text: str) -> tuple[str, ...]:
    """``--columns t,x,y,...`` as checked names (``_`` skips a column).

    Raises:
        TrajectoryFileError: An unknown or repeated name (the message lists the valid ones).
    """
    return parse_column_names([p for p in re.split(r"[,\s]+", text.strip()) if p], "--columns")


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


class PositionCurve:
    """x(t), y(t) through a timed file's rows: one interpolant per stretch of time.

    Args:
        breaks: (K + 1,) times where the stretches meet [s].
        pieces: K interpolants, each callable as ``f(t, nu) -> (M, 2)`` (scipy splines).
    """

    def __init__(self, breaks: FloatArray, pieces: Sequence[Any]) -> None:
        self.breaks = np.asarray(breaks, dtype=float)
        self.pieces = list(pieces)

    def __call__(self, t: FloatArray, nu: int = 0) -> FloatArray:
        """(M, 2) positions (nu = 0) [m] or their nu-th time derivative at times t (M,) [s]."""
        tq = np.clip(np.asarray(t, dtype=float), self.breaks[0], self.breaks[-1])
        k = np.clip(np.searchsorted(self.breaks, tq, side="right") - 1, 0, len(self.pieces) - 1)
        out = np.empty((tq.size, 2))
        for j in np.unique(k):
            sel = k == j
            out[sel] = self.pieces[j](tq[sel], nu)
        return out


class _Hermite2:
    """Two scalar quintic Hermite pieces (x and y) as one ``f(t, nu) -> (M, 2)``."""

    def __init__(self, t: FloatArray, xy: FloatArray, vel: FloatArray, acc: FloatArray) -> None:
        self.parts = [BPoly.from_derivatives(t, np.column_stack([xy[:, i], vel[:, i], acc[:, i]])) for i in range(2)]

    def __call__(self, t: FloatArray, nu: int = 0) -> FloatArray:
        return np.column_stack([p(t, nu) for p in self.parts])


# ------------------------------------------------------------------------------------ reading
def read_trajectory_file(source: TrajectoryFile) -> ImportedFile:
    """Read a file, bring it into metres and seconds and repair it (see the module doc).

    Raises:
        TrajectoryFileError: Unreadable file, unknown columns, missing x or y (or t for a trajectory),
            a non-numeric cell, stamps that go back or repeat at different positions, fewer than
            two distinct positions.
    """
    table = _read_source(source)
    report = ImportReport(str(source.path), table.fmt, "trajectory" if source.timed else "path", len(table))
    cols = _required(table, source, report)
    cols = _to_metres(cols, source)
    rows = table.rows
    if "theta" in cols:
        cols["theta"], report.headings_unwrapped = _unwrap(cols["theta"], rows, report)
    rows, cols = _merge(rows, cols, source.timed, report)
    _check_distinct(table, cols)
    if not source.timed:
        return ImportedFile(source, rows, cols["xy"], None, cols.get("theta"), _directions(cols), None, None, report)
    return _timed(source, rows, cols, report)


def _read_source(source: TrajectoryFile) -> FileTable:
    """The file's columns: a bag's topic (:mod:`planning.trajectory.bag_file`), else a text, JSON or YAML file."""
    from planning.trajectory.bag_file import is_bag, read_bag_table

    if source.topic is None and source.message is None and not is_bag(source.path):
        return read_table(source.path, source.columns)
    if not is_bag(source.path):
        raise TrajectoryFileError(
            f"{source.path}: --topic and --message read a bag (.mcap, .bag, .db3 or a rosbag2 folder): drop them"
        )
    if source.columns is not None:
        raise TrajectoryFileError(f"{source.path}: --columns names a text file's columns; a bag's topic names its own")
    return read_bag_table(source.path, source.topic, source.message, timed=source.timed)


def _required(table: FileTable, source: TrajectoryFile, report: ImportReport) -> dict[str, FloatArray]:
    cols = dict(table.columns)
    missing = [c for c in ("x", "y") if c not in cols]
    if source.timed and "t" not in cols:
        missing.insert(0, "t")
    if missing:
        hint = "; a file without time stamps is a path: use --path" if missing == ["t"] else ""
        raise TrajectoryFileError(
            f"{table.path}: no column {' or '.join(missing)} (columns: {', '.join(cols) or 'none'}); name it in the "
            f"header or with --columns{hint}"
        )
    if len(table) < 2:
        raise TrajectoryFileError(f"{table.path}: {len(table)} row; a trajectory needs at least two positions")
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
    rot = np.array([[np.cos(oth), -np.sin(oth)], [np.sin(oth), np.cos(oth)]])
    out: dict[str, FloatArray] = {"xy": np.column_stack([cols["x"], cols["y"]]) * s @ rot.T + (ox, oy)}
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
            out[f"{pair}xy"] = np.column_stack([cols[names[0]], cols[names[1]]]) * (s / ts**power) @ rot.T
        elif any(n in cols for n in names):
            raise TrajectoryFileError(f"columns {names[0]} and {names[1]} come together: give both or neither")
    return out


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
                "fix the stamps, or use --path to ignore them"
            )
    else:
        turn = np.abs(np.diff(cols["theta"])) if "theta" in cols else np.zeros(step.size)
        same = (step <= SAME_POSITION) & (turn <= 1e-3)
    if not np.any(same):
        return rows, cols
    group = np.concatenate([[0], np.cumsum(~same)])
    count = np.bincount(group).astype(float)
    first = np.flatnonzero(~np.concatenate([[False], same]))
    merged = {k: v[first] if k == "xy" else _group_mean(v, group, count) for k, v in cols.items()}
    report.rows_merged = int(same.sum())
    what = "repeated time stamps at one position" if timed else "repeated poses"
    pairs = _pairs(rows, np.flatnonzero(same), lambda i: "")
    report.notes.append(f"{report.rows_merged} row(s) merged ({what}): {pairs}")
    return tuple(rows[i] for i in first), merged


def _group_mean(values: FloatArray, group: NDArray[np.intp], count: FloatArray) -> FloatArray:
    if values.ndim == 1:
        return np.bincount(group, weights=values) / count
    return np.column_stack([np.bincount(group, weights=values[:, j]) / count for j in range(values.shape[1])])


def _check_distinct(table: FileTable, cols: dict[str, FloatArray]) -> None:
    xy = cols["xy"]
    if float(np.max(np.hypot(*(xy - xy[0]).T))) <= SAME_POSITION:
        raise TrajectoryFileError(
            f"{table.path}: all {len(table)} rows are at one position ({xy[0, 0]:g}, {xy[0, 1]:g}); a trajectory "
            "needs at least two distinct positions"
        )


def _directions(cols: dict[str, FloatArray]) -> FloatArray:
    """+1/-1 per interval: from the sign of a given v, else from given headings against the motion,
    else forwards."""
    d = np.diff(cols["xy"], axis=0)
    if "v" in cols:
        s = np.sign(cols["v"][:-1] + cols["v"][1:])
    elif "theta" in cols:
        mid = 0.5 * (cols["theta"][:-1] + cols["theta"][1:])
        s = np.sign(np.cos(mid) * d[:, 0] + np.sin(mid) * d[:, 1])
    else:
        return np.ones(d.shape[0])
    return np.where(s == 0, 1.0, s)


# ------------------------------------------------------------------------ timed files: derivatives
def stretch_fit(t: FloatArray, xy: FloatArray) -> PositionCurve:
    """The positions' own interpolant: a cubic spline through each stretch of rows between stops (the
    ends, stand-stills, corners sharper than 90 degrees), at rest at both ends of every stretch.

    Args:
        t: (N,) strictly increasing times [s].
        xy: (N, 2) positions [m].
    """
    d = np.diff(xy, axis=0)
    stand = np.hypot(d[:, 0], d[:, 1]) <= SAME_POSITION
    inner = np.arange(1, t.size - 1)
    sharp = np.einsum("ij,ij->i", d[:-1], d[1:]) < 0.0
    stops = inner[stand[:-1] | stand[1:] | sharp]
    knots = np.concatenate([[0], stops, [t.size - 1]])
    pieces: list[Any] = []
    for a, b in itertools.pairwise(knots):
        if np.all(stand[a:b]):
            pieces.append(CubicHermiteSpline(t[[a, b]], xy[[a, a]], np.zeros((2, 2))))
        else:
            pieces.append(CubicSpline(t[a : b + 1], xy[a : b + 1], bc_type="clamped"))
    return PositionCurve(t[knots], pieces)


def _row_direction(direction: FloatArray) -> FloatArray:
    return np.concatenate([direction, direction[-1:]])


def _motion_heading(vel: FloatArray, direction: FloatArray) -> FloatArray:
    """(N,) heading of the motion at each row, backwards where the robot reverses [rad]."""
    s = _row_direction(direction)
    return np.arctan2(s * vel[:, 1], s * vel[:, 0])


def _miss(t: FloatArray, values: FloatArray, rates: FloatArray, tol: tuple[float, float]) -> tuple[int, FloatArray]:
    """Trapezoid check of ``rates`` (N, k) against ``values`` (N, k): the worst interval (-1 when every
    interval is within ``tol``) and, per interval, [change, predicted, allowed]."""
    change = np.diff(values, axis=0)
    predicted = 0.5 * np.diff(t)[:, None] * (rates[:-1] + rates[1:])
    miss = np.linalg.norm(change - predicted, axis=1)
    size = np.linalg.norm(change, axis=1)
    allowed = tol[0] + tol[1] * size
    worst = int(np.argmax(miss / allowed))
    table = np.column_stack([size, np.linalg.norm(predicted, axis=1), allowed])
    return (worst if miss[worst] > allowed[worst] else -1), table


def _replace(
    report: ImportReport,
    what: str,
    rows: tuple[str, ...],
    check: tuple[int, FloatArray],
    given: FloatArray,
    used: FloatArray,
    unit: str,
    verb: str,
) -> None:
    """Note that ``given`` (N, k) values failed their check at interval ``check[0]`` and record the
    largest change to ``used``."""
    i, table = check
    change, predicted, allowed = table[i]
    report.notes.append(
        f"{what} disagree with the positions: from {rows[i]} to {rows[i + 1]} they {verb} {predicted:.4g} but the "
        f"rows {verb} {change:.4g} (tolerance {allowed:.3g}); replaced by the positions' own"
    )
    diff = np.linalg.norm(given - used, axis=1)
    k = int(np.argmax(diff))
    report.corrections.append(
        Correction(
            what, rows[k], tuple(map(float, given[k])), tuple(map(float, used[k])), float(diff[k]), float(allowed), unit
        )
    )


def _timed(
    source: TrajectoryFile, rows: tuple[str, ...], cols: dict[str, FloatArray], report: ImportReport
) -> ImportedFile:
    """A timed file's interpolant: given derivatives where they agree with the positions, else the
    positions' own; headings and yaw rates checked."""
    t, xy = cols["t"], cols["xy"]
    if t[-1] - t[0] > MAX_DURATION:
        raise TrajectoryFileError(
            f"{report.file}: the trajectory lasts {t[-1] - t[0]:.6g} s, more than {MAX_DURATION:g} s: if its clock "
            "counts milliseconds, give --time-scale 0.001 (seconds per file time unit)"
        )
    direction = _directions(cols)
    fit = stretch_fit(t, xy)
    derived = fit(t, 1)
    theta = cols.get("theta")
    heading = theta if theta is not None else np.unwrap(_motion_heading(derived, direction))
    curve: PositionCurve = fit
    given, what = None, ""
    if "vxy" in cols:
        given, what = cols["vxy"], "velocities (vx, vy)"
    elif "v" in cols:
        given, what = cols["v"][:, None] * np.column_stack([np.cos(heading), np.sin(heading)]), "speeds v"
    if given is not None:
        check = _miss(t, xy, given, DISPLACEMENT_TOLERANCE)
        if check[0] >= 0:
            _replace(report, what, rows, check, given, derived, "m/s", "move")
        else:
            curve = _with_velocities(t, xy, given, cols.get("axy"), rows, report)
    elif "axy" in cols:
        report.notes.append("accelerations (ax, ay) unused: the file gives no velocities to go with them")
    used_vel = curve(t, 1)
    if theta is not None:
        _check_heading(theta, _motion_heading(used_vel, direction), used_vel, rows, report)
    omega = cols.get("omega")
    if omega is not None:
        check = _miss(t, heading[:, None], omega[:, None], HEADING_TOLERANCE)
        if check[0] >= 0:
            own = np.gradient(heading, t)
            _replace(report, "yaw rates omega", rows, check, omega[:, None], own[:, None], "rad/s", "turn")
            omega = None
    return ImportedFile(source, rows, xy, t, theta, direction, curve, omega, report)


def _with_velocities(
    t: FloatArray,
    xy: FloatArray,
    vel: FloatArray,
    acc: FloatArray | None,
    rows: tuple[str, ...],
    report: ImportReport,
) -> PositionCurve:
    """The Hermite interpolant of checked velocities, quintic with accelerations that pass their check."""
    cubic = CubicHermiteSpline(t, xy, vel)
    if acc is None:
        return PositionCurve(t[[0, -1]], [cubic])
    check = _miss(t, vel, acc, VELOCITY_TOLERANCE)
    if check[0] >= 0:
        _replace(report, "accelerations (ax, ay)", rows, check, acc, cubic(t, 2), "m/s^2", "change the velocity by")
        return PositionCurve(t[[0, -1]], [cubic])
    return PositionCurve(t[[0, -1]], [_Hermite2(t, xy, vel, acc)])


def _check_heading(
    theta: FloatArray, motion: FloatArray, vel: FloatArray, rows: tuple[str, ...], report: ImportReport
) -> None:
    """Note given headings off the direction of motion by more than HEADING_TO_MOTION where it moves."""
    moving = np.hypot(vel[:, 0], vel[:, 1]) > MOVING_SPEED
    off = np.where(moving, np.abs(wrap_angle(theta - motion)), 0.0)
    k = int(np.argmax(off))
    if off[k] <= HEADING_TO_MOTION:
        return
    report.notes.append(
        f"headings disagree with the direction of motion by up to {off[k]:.3f} rad ({rows[k]}; tolerance "
        f"{HEADING_TO_MOTION:g} rad): the heading follows the motion where the robot moves"
    )
    report.corrections.append(
        Correction(
            "headings theta",
            rows[k],
            (float(theta[k]),),
            (float(theta[k] - wrap_angle(theta[k] - motion[k])),),
            float(off[k]),
            HEADING_TO_MOTION,
            "rad",
        )
    )
