"""Reading trajectory and path files into named numeric columns, as real files come.

Formats (chosen by the file's suffix):

* **Text** (``.csv``, ``.tsv``, ``.tab``, ``.txt``, ``.dat``, ``.log`` or no suffix: :data:`TEXT_SUFFIXES`):
  comma-, tab-, semicolon- or whitespace-separated cells, one row per line; lines starting with ``#``, ``%``
  or ``//`` and blank lines are skipped. The first row names the columns (a header), or ``columns`` does
  (then a header row, if any, is skipped; a header of valid names that ``columns`` contradicts is an
  error). ``_`` skips a column. A header that is valid but for an unnamed first column (pandas' index) or
  units after its names (``t [s]``) is refused with the ``columns`` that read it (units are not read).
* **JSON** (``.json``): ``{"t": [...], "x": [...], ...}`` (one list per column) or a list of records
  ``[{"t": 0, "x": 0.1, ...}, ...]``; or nhsim's own plan record (``nhsim plan --json``, known by its fields
  :data:`PLAN_RECORD_FIELDS`): its ``path`` of [x, y, theta] states, a path (the headings keep its reversing).
* **YAML** (``.yaml``, ``.yml``): a ROS ``nav_msgs/Path`` as ``ros2 topic echo`` (or ``rostopic echo``)
  writes it: ``poses[].pose.position`` (x, y), ``poses[].pose.orientation`` (a quaternion: the
  heading is its yaw) and ``poses[].header.stamp`` (``sec``/``nanosec`` or ``secs``/``nsecs``; stamps
  that are all equal give no time column); or the same two layouts as JSON. The first document of
  a multi-document file is read.

A file is read in one read and parsed from memory (:func:`planning.core.files.read_input`): a pipe (bash's
``<(command)``, a FIFO) works, read again by the same process from the bytes kept. ``-`` (standard input) is
refused naming the fix: the file is read more than once and named again by a replay command.

Any other suffix (a ``.toml``, ``.xml`` or spreadsheet file) is refused, naming those read here: parsed as a
text table it gave dozens of junk column names.

Column names: :data:`COLUMNS` (t [s], x, y [length], theta [rad], v [length/s], omega [rad/s],
vx, vy [length/s], ax, ay [length/s^2]); units are whatever the file uses, scaled later
(:mod:`planning.trajectory.importer`). Every problem is a :class:`TrajectoryFileError` naming the
file, the row (line, record or pose) and the column.
"""

from __future__ import annotations

import csv
import io
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.checks import given
from planning.core.documents import GivenTwice, load_json, yaml_loader
from planning.core.files import read_input_text, undecodable_at
from planning.errors import ConfigError, option

FloatArray = NDArray[np.float64]

__all__ = [
    "COLUMNS",
    "LAYOUTS",
    "PLAN_RECORD",
    "QUATERNION",
    "SKIP",
    "FileTable",
    "TrajectoryFileError",
    "given_columns",
    "orientation_headings",
    "parse_column_names",
    "quaternion_columns",
    "quaternion_headings",
    "quaternion_yaw",
    "read_table",
    "table_from_arrays",
    "yaml_problem",
]

#: The columns of an orientation quaternion (x, y, z, w): its yaw is the heading, read in place of ``theta``.
QUATERNION = ("qx", "qy", "qz", "qw")
#: The column names a file may use, in this order in messages.
COLUMNS = ("t", "x", "y", "theta", "v", "omega", "vx", "vy", "ax", "ay", *QUATERNION)
#: The name that skips a column.
SKIP = "_"
#: Column layouts that ``columns`` may name alone: ``tum`` is the TUM RGB-D benchmark's trajectory format
#: (``timestamp tx ty tz qx qy qz qw`` a row, as evo reads and writes it), its height tz skipped.
LAYOUTS = {"tum": ("t", "x", "y", SKIP, *QUATERNION)}
#: The TUM format's columns, as its files' comment names them.
TUM_HEADER = "timestamp tx ty tz qx qy qz qw"
#: Largest tilt of an orientation from the plane [rad] read without a note (a ramp, a bump); above
#: :data:`MAX_TILT` an orientation is not a ground robot's (a camera's optical frame has z forward).
NOTED_TILT = 0.1
MAX_TILT = np.pi / 4
#: Largest difference of an orientation quaternion's norm from 1 (within it the quaternion is normalised).
QUATERNION_TOLERANCE = 1e-3
#: A quaternion of a smaller norm is zero: no orientation at all.
ZERO_QUATERNION = 1e-6
_COMMENTS = ("#", "%", "//")
#: Suffixes read as text tables ("": none; ``.tum``: evo's TUM files); JSON and YAML are :data:`DOCUMENT_SUFFIXES`.
TEXT_SUFFIXES = ("", ".csv", ".tsv", ".tab", ".txt", ".dat", ".log", ".tum")
DOCUMENT_SUFFIXES = (".json", ".yaml", ".yml")
#: File suffixes read as bags (:mod:`planning.trajectory.bag_file`; a folder with a ``metadata.yaml`` is one too).
BAG_SUFFIXES = (".mcap", ".bag", ".db3")


class TrajectoryFileError(ConfigError):
    """A trajectory or path file cannot be read or used as it is (the message names the row and the fix)."""


@dataclass(frozen=True)
class FileTable:
    """A file's rows as named columns, before units and repairs.

    Attributes:
        path: The file.
        fmt: "csv", "tsv", "text", "json", "yaml" or "nav_msgs/Path".
        columns: Column name (one of :data:`COLUMNS`) -> (N,) finite values in the file's units.
        rows: (N,) how messages name each row: "line 7", "record 3", "poses[2]".
        frame: The poses' frame (a bag's ``header.frame_id``; "" when empty), None where the format has none.
        notes: What reading did that the import report says (a bag's frame).
    """

    path: Path
    fmt: str
    columns: dict[str, FloatArray]
    rows: tuple[str, ...]
    frame: str | None = None
    notes: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.rows)


def table_from_arrays(
    path: str | Path, columns: Mapping[str, ArrayLike], fmt: str, rows: Sequence[str] | None = None
) -> FileTable:
    """Columns read elsewhere (a ROS 2 bag's messages, a caller's arrays) as a table, checked as a
    file's are: names among :data:`COLUMNS` (``_`` columns dropped), one length, finite numbers.

    Args:
        path: The source the messages name (the bag, the file).
        columns: Column name -> (N,) values in the source's units (scaled later, as a file's).
        fmt: How the import report names the format, e.g. "rosbag2 /odom".
        rows: (N,) how messages name each row ("message 12"); default "row 1 (index 0)", ...

    Raises:
        TrajectoryFileError: An unknown or repeated name, a column that is not 1-D or differs in
            length, a value that is not a finite number (its row and column named).
    """
    p = Path(path)
    names = parse_column_names(list(columns), str(p))
    arrays: dict[str, FloatArray] = {}
    for key, name in zip(columns, names, strict=True):
        try:
            arr = np.asarray(columns[key], dtype=float)
        except (TypeError, ValueError) as exc:
            raise TrajectoryFileError(f"{p}: column {name!r} is not numbers: {exc}") from exc
        if arr.ndim != 1:
            raise TrajectoryFileError(f"{p}: column {name!r} must be one value per row, got shape {arr.shape}")
        if name != SKIP:
            arrays[name] = arr
    sizes = {name: arr.size for name, arr in arrays.items()}
    if len(set(sizes.values())) > 1:
        shown = ", ".join(f"{k}: {v}" for k, v in sizes.items())
        raise TrajectoryFileError(f"{p}: the columns differ in length ({shown}); give every column one value per row")
    n = next(iter(sizes.values()), 0)
    labels = tuple(rows) if rows is not None else _counted("row", n)
    if len(labels) != n:
        raise TrajectoryFileError(f"{p}: {len(labels)} row names for {n} rows")
    for name, arr in arrays.items():
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise TrajectoryFileError(
                f"{p}: {labels[bad[0]]}, column {name!r}: {arr[bad[0]]!r} is not a finite number; fix or drop the row"
            )
    return FileTable(p, fmt, arrays, labels)


#: Other tools' names of columns, read as these (a web tool's {"timestamp", "x", "y", "yaw"} records).
ALIASES = {"time": "t", "timestamp": "t", "stamp": "t", "yaw": "theta", "heading": "theta", "tx": "x", "ty": "y"}


def _valid_names() -> str:
    layouts = ", ".join(f"{name} for {','.join(cols)}" for name, cols in LAYOUTS.items())
    return (
        ", ".join(COLUMNS)
        + f" (also {', '.join(f'{a} for {c}' for a, c in ALIASES.items())}; or a layout's name alone: {layouts})"
    )


def _layout_hint(names: Sequence[str]) -> str:
    """The advice for a header of ``names`` (some unknown) that a named layout (:data:`LAYOUTS`) reads: its known
    names agree with the layout's, column by column; else ""."""
    own = _lenient(names)
    for name, cols in LAYOUTS.items():
        if len(cols) == len(own) and all(SKIP in (a, b) or a == b for a, b in zip(own, cols, strict=True)):
            return f"; {len(own)} names as a TUM trajectory's ({TUM_HEADER}): {option('columns', name)}"
    return ""


def _row_hint(cells: list[str], delimiter: str | None) -> str:
    """The advice for a headerless first row of ``cells``: a TUM trajectory's eight numbers (timestamp tx ty tz
    qx qy qz qw) when its last four are a unit quaternion that lies near the plane (the ``tum`` layout), or the
    same with the quaternion written w first (EuRoC's and Eigen's order); else ""."""
    if len(cells) != len(LAYOUTS["tum"]) or not _is_numeric_row(cells, delimiter):
        return ""
    q = np.array([float(c if delimiter == "," else c.replace(",", ".")) for c in cells[4:]])
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        return ""
    if _tilts(q / norm) <= NOTED_TILT:
        return f"; 8 numbers a row, as a TUM trajectory's ({TUM_HEADER}): {option('columns', 'tum')}"
    if _tilts(q[W_FIRST] / norm) <= NOTED_TILT:
        given = ",".join((*LAYOUTS["tum"][:4], "qw", "qx", "qy", "qz"))
        return (
            f"; 8 numbers a row, as a TUM trajectory's with its quaternion written w first (timestamp tx ty tz qw qx "
            f"qy qz): {option('columns', given)}"
        )
    return ""


#: Indices that read a quaternion written w first, (w, x, y, z), in this module's order (x, y, z, w).
W_FIRST = [1, 2, 3, 0]


def _tilts(quats: FloatArray) -> FloatArray:
    """How far unit quaternions' orientations (..., 4: x, y, z, w) tilt from the plane [rad]: the angle of the body z
    axis from the vertical."""
    return np.arccos(np.clip(1.0 - 2.0 * (quats[..., 0] ** 2 + quats[..., 1] ** 2), -1.0, 1.0))


def _lenient(names: Sequence[str]) -> tuple[str, ...]:
    """A header's names, an unknown one read as ``_``."""
    return tuple(column_of(n) if column_of(n) in COLUMNS else SKIP for n in names)


def column_of(name: object) -> str:
    """The column a header's or a field's ``name`` gives (spaces around it and case ignored, :data:`ALIASES` read)."""
    n = str(name).strip().lower()
    return ALIASES.get(n, n)


def given_columns(columns: str | Sequence[str], where: str | None = None) -> tuple[str, ...]:
    """The names ``columns`` (``--columns``) gives, checked (:func:`parse_column_names`): a sequence of names, or
    one string of them separated by commas or spaces (``"t,x,y"``), or a layout's name alone (:data:`LAYOUTS`).

    Raises:
        TrajectoryFileError: No name, names that are not text, an unknown or repeated name.
    """
    where = where if where is not None else option("columns")
    if isinstance(columns, str):
        names: Sequence[str] = [c for c in re.split(r"[,\s]+", columns.strip()) if c]
    elif isinstance(columns, Sequence) and all(isinstance(c, str) for c in columns):
        names = columns
    else:
        raise TrajectoryFileError(
            f"{where} must be names (text: 't,x,y' or ['t', 'x', 'y']), got {type(columns).__name__} {columns!r}"
        )
    if not names:
        raise TrajectoryFileError(f"{where} names no column: name each of the file's columns, e.g. t,x,y")
    if len(names) == 1 and column_of(names[0]) in LAYOUTS:
        names = LAYOUTS[column_of(names[0])]
    return parse_column_names(names, where)


def parse_column_names(names: Sequence[str], where: str, fix: str | None = None) -> tuple[str, ...]:
    """Column names as given (a header, ``--columns``, a document's fields), checked: each one of :data:`COLUMNS`
    (or an alias of one, :data:`ALIASES`) or ``_``.

    Args:
        names: The names (spaces around them and case are ignored).
        where: How the message names their source (the file, or ``option("columns")``, :func:`~planning.errors.option`).
        fix: What the message advises for an unknown name (default: rename it in the header or give ``--columns``).

    Raises:
        TrajectoryFileError: An unknown or repeated name (the message lists the valid ones).
    """
    out = tuple(column_of(n) for n in names)
    unknown = [n for n in out if n not in COLUMNS and n != SKIP]
    if unknown:
        advice = fix if fix is not None else f"rename them in the header or give {option('columns')}"
        raise TrajectoryFileError(
            f"{where}: unknown column name(s) {', '.join(repr(n) for n in unknown)}; valid names are "
            f"{_valid_names()} ({SKIP} skips a column); {advice}{_layout_hint(names)}"
        )
    named = [n for n in out if n != SKIP]
    twice = sorted({n for n in named if named.count(n) > 1})
    if twice:
        raise TrajectoryFileError(f"{where}: column(s) {', '.join(twice)} named twice; name each column once")
    return out


def _number(value: Any, where: str, row: str, column: str) -> float:
    """One cell as a finite float, else the error naming the row and the column."""
    try:
        if isinstance(value, bool):
            raise ValueError
        x = float(value)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an integer of JSON or YAML too large for a float
        x = float("nan")
    if not np.isfinite(x):
        raise TrajectoryFileError(
            f"{where}: {row}, column {column!r}: {given(value)} is not a finite number; fix the cell or drop the row"
        )
    return x


def read_table(path: str | Path, columns: Sequence[str] | None = None) -> FileTable:
    """Read a trajectory or path file (see the module doc for the formats).

    Args:
        path: The file.
        columns: Names of a text file's columns (``--columns``, as :func:`given_columns` reads them), overriding
            its header; None: the header names them. Not for JSON or YAML, whose fields are named.

    Raises:
        TrajectoryFileError: An unreadable file, an unknown column name, a missing header, a row
            with the wrong number of cells, a non-numeric cell (row and column named).
    """
    p = Path(path)
    if str(path) == "-":
        raise TrajectoryFileError(
            "- (standard input) is not read as a trajectory or path file: the file is read more than once (its "
            "world, then its run; a replay command names it again); give its path, or a pipe's, e.g. "
            "<(command) in bash"
        )
    suffix = p.suffix.lower()
    if suffix not in TEXT_SUFFIXES + DOCUMENT_SUFFIXES:
        raise TrajectoryFileError(
            f"{p}: a {suffix} file is not a format read here; convert it to a text table ("
            f"{', '.join(s for s in TEXT_SUFFIXES if s)} or no suffix), {', '.join(DOCUMENT_SUFFIXES)} or a ROS bag "
            f"({', '.join(BAG_SUFFIXES)} or a rosbag2 folder)"
        )
    try:
        text = read_input_text(p)  # once (a pipe cannot be read again); a byte-order mark (Windows exports) is dropped
    except OSError as exc:
        raise TrajectoryFileError(f"cannot read trajectory file {p}: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise TrajectoryFileError(
            f"trajectory file {p} is not UTF-8 text ({undecodable_at(exc)}); save it as UTF-8"
        ) from exc
    if "\x00" in text:  # valid UTF-8, but no text file holds a NUL (a binary file, zeros, a UTF-16 one)
        raise TrajectoryFileError(
            f"trajectory file {p} is not text (it holds NUL bytes, from character {text.index(chr(0))}); give a text "
            "table, JSON or YAML saved as UTF-8, or a ROS bag"
        )
    if suffix in DOCUMENT_SUFFIXES:
        if columns is not None:
            raise TrajectoryFileError(
                f"{p}: {option('columns')} names the columns of a text file; a {suffix[1:].upper()} file names "
                "its own fields: drop it"
            )
        data = _load_json(p, text) if suffix == ".json" else _load_yaml(p, text)
        return _from_document(p, data, "json" if suffix == ".json" else "yaml")
    return _read_text(p, text, columns)


def _load_json(p: Path, text: str) -> Any:
    try:
        return load_json(text)
    except json.JSONDecodeError as exc:
        raise TrajectoryFileError(f"{p}: not valid JSON: {exc.msg} at line {exc.lineno}") from exc
    except GivenTwice as exc:
        raise TrajectoryFileError(f"{p}: {exc}; keep the one meant") from None


def _load_yaml(p: Path, text: str) -> Any:
    import yaml

    try:  # the documents one at a time: a capture cut off after its first message still reads
        for doc in yaml.load_all(text, Loader=yaml_loader()):
            if doc is not None:
                return doc
    except GivenTwice as exc:
        raise TrajectoryFileError(f"{p}: {exc}; YAML keys are unique: keep the one meant") from None
    except yaml.YAMLError as exc:
        raise TrajectoryFileError(
            f"{p}: not valid YAML ({yaml_problem(exc)}); fix the file there: a nav_msgs/Path as `ros2 topic echo` "
            "writes it, or a table of columns or records"
        ) from exc
    raise TrajectoryFileError(f"{p}: the YAML file is empty")


def yaml_problem(exc: Exception) -> str:
    """A PyYAML error in one line: where (line and column, counted from 1) and what, without PyYAML's quoted
    excerpt of the text: ``line 2, column 1: expected the node content, but found '<stream end>' (while parsing
    a flow node)``."""
    mark = getattr(exc, "problem_mark", None)
    problem, context = getattr(exc, "problem", None), getattr(exc, "context", None)
    if mark is None or problem is None:  # a reader error (a byte that is not text) or another: its text, one line
        return " ".join(str(exc).split())
    where = f"line {mark.line + 1}, column {mark.column + 1}"
    return f"{where}: {problem}" + (f" ({context})" if context else "")


# ----------------------------------------------------------------------------------------- text
def _delimiter(suffix: str, first: str) -> str | None:
    """The cell separator: tab for ``.tsv``; else a tab, semicolon or comma found in the first content line,
    in that order (a line with a tab or semicolon and a comma is a spreadsheet's whose decimal mark is a
    comma); else a comma for ``.csv``, whitespace for the rest (None)."""
    if suffix in (".tsv", ".tab"):
        return "\t"
    found = [d for d in ("\t", ";", ",") if d in first]
    if found:
        return found[0]
    return "," if suffix == ".csv" else None


def _split(lines: list[tuple[int, str]], delimiter: str | None) -> list[tuple[int, list[str]]]:
    if delimiter is None:
        return [(n, line.split()) for n, line in lines]
    cells = csv.reader([line for _, line in lines], delimiter=delimiter, skipinitialspace=True)
    return [(n, row) for (n, _), row in zip(lines, cells, strict=True)]  # float() ignores spaces around a number


def _is_numeric_row(cells: list[str], delimiter: str | None) -> bool:
    try:
        [float(c if delimiter == "," else c.replace(",", ".")) for c in cells]
    except ValueError:
        return False
    return True


def _commented_header(text: str, first: int, delimiter: str | None) -> str:
    """The hint for a header written as a comment above the first row (numpy's ``savetxt(header=...)`` writes
    ``# t,x,y``): "" when the comment line just before it does not name columns."""
    above = text.splitlines()[first - 2].strip() if first >= 2 else ""
    if not above.startswith(_COMMENTS):
        return ""
    cells = above.lstrip("#%/ ").split(delimiter) if delimiter else above.lstrip("#%/ ").split()
    if not cells or not all(column_of(c) in COLUMNS or c.strip() == SKIP for c in cells):
        return ""
    return f"; line {first - 1} names them but is a comment ({above!r}): drop its {above[0]!r}"


def _read_text(p: Path, text: str, columns: Sequence[str] | None) -> FileTable:
    lines = []
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if line and not line.startswith(_COMMENTS):
            lines.append((n, line))
    if not lines:
        raise TrajectoryFileError(f"{p}: the file holds no rows")
    delimiter = _delimiter(p.suffix.lower(), lines[0][1])
    first = _split(lines[:1], delimiter)[0][1]
    has_header = not _is_numeric_row(first, delimiter)
    if columns is not None:
        names = given_columns(columns)
        if has_header:
            _check_header_agrees(p, lines[0][0], first, names)
    elif has_header:
        trail = delimiter is not None and lines[0][1].endswith(delimiter) and not first[-1].strip()
        header = first[:-1] if trail else first
        names = parse_column_names(header, f"{p}, header (line {lines[0][0]})", _header_fix(header))
        names = (*names, "") if trail else names
    else:
        example = option("columns", "t,x,y", python='columns=("t", "x", "y")')
        raise TrajectoryFileError(
            f"{p}: the first row (line {lines[0][0]}) is numbers, not a header naming the columns: add a header "
            f"or name the columns, e.g. {example} (names {_valid_names()}; {SKIP} skips a column)"
            f"{_commented_header(text, lines[0][0], delimiter) or _row_hint(first, delimiter)}"
        )
    body = lines[1:] if has_header else lines
    if not body:
        raise TrajectoryFileError(f"{p}: the file holds a header and no rows")
    if has_header and delimiter is not None and lines[0][1].endswith(delimiter) and names[-1] == "":
        names = names[:-1]  # every line ended by a separator (a spreadsheet's export): no last column
        body = [(n, line[: -len(delimiter)] if line.endswith(delimiter) else line) for n, line in body]
    body = _decimal_commas(body, delimiter)
    values = _plain_numbers(body, delimiter, names) if '"' not in text else None
    if values is None:  # quoted cells, or a row to name: cell by cell
        values = _numbers(p, _split(body, delimiter), names, columns is not None)
    fmt = {",": "csv", ";": "csv", "\t": "tsv", None: "text"}[delimiter]
    arrays = dict(zip([n for n in names if n != SKIP], values.T, strict=True))
    return FileTable(p, fmt, arrays, tuple(f"line {n}" for n, _ in body))


#: A unit after a column's name in a header: ``t [s]``, ``x (m)``.
_UNIT = re.compile(r"^(?P<name>[^\[\](){}]*?)\s*[\[({](?P<unit>[^\[\](){}]*)[\])}]$")


def _header_fix(header: list[str]) -> str | None:
    """The advice for a header whose names are valid once an unnamed first column (pandas' index) is skipped and
    units after the names (``t [s]``) are dropped: the ``--columns`` that reads it, saying why; None for another
    header (the default advice). Units are not read: values are in the file's units (``--scale``, ``--time-scale``)."""
    names = [c.strip() for c in header]
    given = [
        SKIP if not n and k == 0 else (m.group("name") if (m := _UNIT.match(n)) else n) for k, n in enumerate(names)
    ]
    if given == names or any(g.strip().lower() not in (*COLUMNS, SKIP) for g in given):
        return None
    why = []
    if not names[0]:
        why.append("the unnamed first column (a pandas index, written by to_csv without index=False) is skipped by _")
    units = [m.group("unit") for n in names if (m := _UNIT.match(n))]
    if units:
        why.append(
            f"units in the header ({', '.join(units)}) are not read: the values are taken in the file's units, "
            f"metres and seconds unless {option('scale')} and {option('time-scale')} say otherwise"
        )
    example = ",".join(g.strip().lower() for g in given)
    return f"name the columns with {option('columns', example)}: {'; '.join(why)}"


def _decimal_commas(body: list[tuple[int, str]], delimiter: str | None) -> list[tuple[int, str]]:
    """Rows whose cells are separated by tabs, semicolons or spaces with decimal commas (``0,25``), read with
    decimal points; rows as they are when a comma separates cells or a point is already there."""
    if delimiter == "," or not any("," in line for _, line in body) or any("." in line for _, line in body):
        return body
    return [(n, line.replace(",", ".")) for n, line in body]


def _plain_numbers(body: list[tuple[int, str]], delimiter: str | None, names: tuple[str, ...]) -> FloatArray | None:
    """(rows, named columns) values of unquoted rows, parsed by numpy at once; None when a row has the
    wrong number of cells or a cell (skipped columns' too) is not a finite number: the cell-by-cell
    reading then names the row, or reads the skipped columns' text."""
    try:  # every column, so that a row with more or fewer cells fails
        values = np.loadtxt(
            io.StringIO("\n".join(line for _, line in body)), delimiter=delimiter, ndmin=2, comments=None, dtype=float
        )
    except ValueError:
        return None
    if values.shape != (len(body), len(names)) or not np.all(np.isfinite(values)):
        return None
    values = values[:, [j for j, name in enumerate(names) if name != SKIP]]
    return values


def _check_header_agrees(p: Path, line: int, header: list[str], names: tuple[str, ...]) -> None:
    """Refuse ``--columns`` that name a column other than a header of valid names does (``_`` on either side
    agrees with anything): ``t,y,x`` over a header ``t,x,y`` would swap x and y without a word. A header
    of other names (``time,px,py``) is what ``--columns`` is for: a name the header has that is not a column (``tz``)
    agrees with anything, as ``_`` does."""
    own = _lenient(header)
    clash = [k for k, (a, b) in enumerate(zip(own, names, strict=False)) if SKIP not in (a, b) and a != b]
    if clash:
        k = clash[0]
        raise TrajectoryFileError(
            f"{p}: the columns given ({','.join(names)}) contradict the file's header (line {line}: {','.join(own)}): "
            f"column {k + 1} is {names[k]!r}, the header says {own[k]!r}; drop {option('columns')} to read the "
            "header's names, or correct the header"
        )


def _numbers(p: Path, body: list[tuple[int, list[str]]], names: tuple[str, ...], given: bool) -> FloatArray:
    """(rows, named columns) values of a text file's cells; a row with the wrong number of cells, or a
    cell that is not a finite number, is an error naming its line (and column). ``given``: the names are
    ``--columns`` (the advice is then to name every cell there)."""
    for n, cells in body:
        if len(cells) != len(names):
            fix = f"give every row the same cells, or name the columns with {option('columns')}"
            if given:
                fix = f"name every cell with {option('columns')} ({SKIP} skips one), or give every row the same cells"
            raise TrajectoryFileError(
                f"{p}: line {n} has {len(cells)} cells but {len(names)} columns are named ({', '.join(names)}); {fix}"
            )
    keep = [j for j, name in enumerate(names) if name != SKIP]
    where = str(p)
    return np.array(
        [[_number(cells[j], where, f"line {n}", names[j]) for j in keep] for n, cells in body], dtype=float
    ).reshape(len(body), len(keep))


# ------------------------------------------------------------------------------- JSON and YAML
#: The fields by which a JSON document is nhsim's own plan record (``nhsim plan --json``).
PLAN_RECORD_FIELDS = ("path", "planner", "status", "scenario")
#: The format an nhsim plan record is named by.
PLAN_RECORD = "nhsim plan record"


def _from_document(p: Path, data: Any, fmt: str) -> FileTable:
    if isinstance(data, Mapping) and "poses" in data:
        return _nav_path(p, data)
    if isinstance(data, Mapping) and all(k in data for k in PLAN_RECORD_FIELDS):
        return _plan_record(p, data)
    if isinstance(data, Mapping) and "header" in data:  # a message's header; no column is called that
        raise TrajectoryFileError(
            f"{p}: has a header but no poses list; a nav_msgs/Path needs one (poses: a list of stamped poses, each "
            "with pose.position and pose.orientation): give the whole message, as `ros2 topic echo --once /plan` "
            "writes it, or a table of columns or records"
        )
    if isinstance(data, Mapping):
        return _from_columns(p, data, fmt)
    if isinstance(data, list):
        return _from_records(p, data, fmt)
    raise TrajectoryFileError(
        f'{p}: expected a table of columns ({{"t": [...], "x": [...]}}), a list of records '
        f'([{{"t": 0, "x": 0}}, ...]) or a nav_msgs/Path (poses: [...]), got a {type(data).__name__}'
    )


def _counted(kind: str, n: int) -> tuple[str, ...]:
    """How messages name rows 1..n of a JSON document or a caller's arrays: "record 8 (index 7)"."""
    return tuple(f"{kind} {i + 1} (index {i})" for i in range(n))


def _json_fields(p: Path, keys: list[str], fmt: str) -> tuple[dict[str, str], tuple[str, ...]]:
    """A JSON document's fields that are columns (field -> column name, checked as a header's) and the note
    naming the others, which are left out: a record exported by another tool carries fields of its own (z,
    frame_id, a stamp)."""
    known = [k for k in keys if column_of(k) in COLUMNS]
    if not known:
        shown = ", ".join(repr(k) for k in keys[:6]) + (", ..." if len(keys) > 6 else "")
        said = f"none of its fields ({shown}) is a column" if keys else "it has no fields"
        raise TrajectoryFileError(
            f"{p}: {said}; a {fmt.upper()} file gives the columns ({_valid_names()}) at its top level: "
            '{"t": [...], "x": [...], "y": [...]} or [{"t": 0, "x": 0, "y": 0}, ...]'
        )
    notes: list[str] = []
    # another tool's name beside the column's own (tx beside x, timestamp beside t): the column's own is read
    own = {column_of(k) for k in known if column_of(k) == k.strip().lower()}
    beside = [k for k in known if column_of(k) != k.strip().lower() and column_of(k) in own]
    if beside:
        notes.append(
            f"fields {', '.join(repr(k) for k in beside)} ignored: the columns they name "
            f"({', '.join(column_of(k) for k in beside)}) are given under their own names"
        )
    known = [k for k in known if k not in beside]
    names = parse_column_names(known, str(p))
    others = [k for k in keys if k not in known and k not in beside]
    if others:
        notes.append(
            f"fields {', '.join(repr(k) for k in others)} ignored (not among {_valid_names()}): rename a field that "
            "holds one of these"
        )
    return dict(zip(known, names, strict=True)), tuple(notes)


def _from_columns(p: Path, data: Mapping[str, Any], fmt: str) -> FileTable:
    fields, notes = _json_fields(p, list(data), fmt)
    lengths = {}
    for key, name in fields.items():
        if not isinstance(data[key], list):
            raise TrajectoryFileError(f"{p}: field {key!r} must be a list of numbers, got {type(data[key]).__name__}")
        lengths[name] = len(data[key])
    if len(set(lengths.values())) > 1:
        sizes = ", ".join(f"{k}: {v}" for k, v in lengths.items())
        raise TrajectoryFileError(f"{p}: the columns differ in length ({sizes}); give every column one value per row")
    n = next(iter(lengths.values()), 0)
    labels = _counted("row", n)
    cols = {
        name: np.array([_number(v, str(p), labels[i], name) for i, v in enumerate(data[key])])
        for key, name in fields.items()
    }
    return FileTable(p, fmt, cols, labels, notes=notes)


def _from_records(p: Path, data: list[Any], fmt: str) -> FileTable:
    if not data:
        raise TrajectoryFileError(
            f'{p}: the file holds no rows (an empty list); give one record per row: [{{"t": 0, "x": 0, "y": 0}}, ...]'
        )
    if not all(isinstance(r, Mapping) for r in data):
        raise TrajectoryFileError(f'{p}: a list of records must hold one object per row, like {{"t": 0, "x": 0}}')
    fields, notes = _json_fields(p, list(dict.fromkeys(k for r in data for k in r)), fmt)
    labels = _counted("record", len(data))
    cols: dict[str, list[float]] = {name: [] for name in fields.values()}
    for i, rec in enumerate(data):
        for key, name in fields.items():
            if key not in rec:
                raise TrajectoryFileError(f"{p}: {labels[i]} has no {key!r}; give every record the same fields")
            cols[name].append(_number(rec[key], str(p), labels[i], name))
    arrays = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    return FileTable(p, fmt, arrays, labels, notes=notes)


def _field(node: Any, path: tuple[str, ...], p: Path, where: str) -> Any:
    """``node[path[0]][path[1]]...``, else the error naming the missing field."""
    for key in path:
        if not isinstance(node, Mapping) or key not in node:
            raise TrajectoryFileError(f"{p}: {where} has no {'.'.join(path)}; a nav_msgs/Path pose needs it")
        node = node[key]
    return node


def _stamp(pose: Mapping[str, Any], p: Path, where: str) -> float | None:
    stamp = pose.get("header", {}).get("stamp") if isinstance(pose.get("header"), Mapping) else None
    if not isinstance(stamp, Mapping):
        return None
    sec = stamp.get("sec", stamp.get("secs", 0))
    nsec = stamp.get("nanosec", stamp.get("nsecs", 0))
    return _number(sec, str(p), where, "header.stamp.sec") + 1e-9 * _number(nsec, str(p), where, "header.stamp.nanosec")


def _quaternion(pose: Mapping[str, Any], p: Path, where: str) -> list[float] | None:
    q = pose["pose"].get("orientation")
    if q is None:
        return None
    return [_number(_field(q, (k,), p, where), str(p), where, f"orientation.{k}") for k in "xyzw"]


def quaternion_yaw(qx: float, qy: float, qz: float, qw: float) -> float:
    """The yaw of an orientation quaternion [rad]; NaN for a zero quaternion (no orientation given)."""
    norm = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if norm < 1e-9:
        return float("nan")
    qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
    return float(np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz)))


def quaternion_headings(
    q: ArrayLike, rows: Sequence[str], where: str | Path, *, all_zero: bool = False
) -> FloatArray | None:
    """The headings (yaws) of poses' orientation quaternions (N, 4: x, y, z, w), each of norm 1 within
    :data:`QUATERNION_TOLERANCE` (normalised), as tf2 takes them: the one check of a bag's and a YAML file's.

    Args:
        q: The quaternions, finite.
        rows: How messages name each pose.
        where: The file (and topic) in messages.
        all_zero: Every quaternion zero means no headings (a ROS 1 message's default, in a YAML capture): None.

    Raises:
        TrajectoryFileError: A zero quaternion (among others that are not) or one whose norm is off 1 by more
            than the tolerance: the first named, with its values and the fix.
    """
    quats = np.asarray(q, dtype=float).reshape(-1, 4)
    norm = np.linalg.norm(quats, axis=1)
    zero = norm < ZERO_QUATERNION
    if all_zero and zero.all():
        return None
    bad = np.flatnonzero(zero | (np.abs(norm - 1.0) > QUATERNION_TOLERANCE))
    if bad.size:
        k = int(bad[0])
        what = "a zero" if zero[k] else f"an unnormalised (norm {norm[k]:.6g})"
        fix = "normalise it (x, y, z and w divided by their norm)"
        if zero[k]:
            fix = "give it the pose's orientation, (0, 0, sin(yaw/2), cos(yaw/2)) for a heading yaw"
            fix += ", or every pose a zero quaternion for no headings" if all_zero else ""
        raise TrajectoryFileError(
            f"{where}: {rows[k]} has {what} orientation quaternion (x, y, z, w) = "
            f"({', '.join(f'{v:g}' for v in quats[k])}) ({bad.size} of {len(rows)} poses); an orientation is a unit "
            f"quaternion, norm 1 within {QUATERNION_TOLERANCE:g} (tf2 refuses others): {fix}"
        )
    return np.array([quaternion_yaw(*o) for o in quats], dtype=float)


def quaternion_columns(table: FileTable) -> tuple[dict[str, FloatArray], tuple[str, ...]]:
    """The table's columns with an orientation quaternion's (:data:`QUATERNION`; or qz and qw alone, a planar one)
    replaced by its yaw as ``theta`` (:func:`orientation_headings`, as a bag's and a YAML path's; all zero: no
    headings), and the notes reading them made. Beside ``theta`` the quaternion is left out, said.

    Raises:
        TrajectoryFileError: qx or qy without all four; qz or qw without the other; a quaternion that
            :func:`orientation_headings` refuses.
    """
    cols = dict(table.columns)
    given = [c for c in QUATERNION if c in cols]
    if not given:
        return cols, ()
    p = table.path
    if "theta" in cols:
        for c in given:
            del cols[c]
        return cols, (f"columns {', '.join(given)} ignored: theta gives the heading",)
    if given not in (list(QUATERNION), list(QUATERNION[2:])):
        lacking = [c for c in QUATERNION if c not in cols]
        fix = f"name all four, or qz and qw alone (a planar quaternion); skip the others with {SKIP}"
        if table.fmt in ("json", "yaml"):
            fix = "give all four fields, or qz and qw alone (a planar quaternion); or drop them"
        raise TrajectoryFileError(
            f"{p}: an orientation quaternion's columns are {', '.join(QUATERNION)}, and {', '.join(lacking)} "
            f"{'is' if len(lacking) == 1 else 'are'} missing: {fix}"
        )
    zero = np.zeros(len(table))
    q = np.column_stack([cols.pop(c) if c in given else zero for c in QUATERNION])
    theta, notes = orientation_headings(q, table.rows, p, cols.get("x"), cols.get("y"), all_zero=True)
    if theta is not None:
        cols["theta"] = theta
    return cols, notes


def orientation_headings(
    q: ArrayLike,
    rows: Sequence[str],
    where: str | Path,
    x: FloatArray | None,
    y: FloatArray | None,
    *,
    all_zero: bool = False,
) -> tuple[FloatArray | None, tuple[str, ...]]:
    """The headings poses' orientation quaternions (N, 4: x, y, z, w) give, and what reading them made of them:
    the one reading of a table's, a YAML path's and a bag's orientations.

    Each quaternion is checked by :func:`quaternion_headings` (norm 1 within :data:`QUATERNION_TOLERANCE`); every
    one zero, where ``all_zero`` allows it, means no headings. Only the yaw is read: an orientation tilted from
    the plane by more than :data:`NOTED_TILT` is noted, by more than :data:`MAX_TILT` refused. Orientations left
    unset (:func:`unset_orientations`, Nav2's NavFn) give no headings either, said.

    Args:
        q: (N, 4) quaternions, finite.
        rows: How messages name each pose.
        where: The file (and topic) in messages.
        x, y: (N,) positions, for the unset check (None: not checked).
        all_zero: Every quaternion zero means no headings (a table's or a YAML capture's) rather than an error.

    Returns:
        The headings [rad] (N,), or None; the notes for the import report.

    Raises:
        TrajectoryFileError: A zero (among others) or unnormalised quaternion, or one tilted more than
            :data:`MAX_TILT` (its row named).
    """
    quats = np.asarray(q, dtype=float).reshape(-1, 4)
    theta = quaternion_headings(quats, rows, where, all_zero=all_zero)
    if theta is None:
        return None, ("every orientation quaternion is zero: no headings read (the motion's are used)",)
    u = quats / np.linalg.norm(quats, axis=1, keepdims=True)
    tilt = _tilts(u)
    over = np.flatnonzero(tilt > MAX_TILT)
    k = int(over[0]) if over.size else int(np.argmax(tilt))  # the first row refused, else the most tilted
    if over.size:
        why = (
            "not a ground robot's pose (a camera's optical frame, z forward, reads so); give the robot's poses "
            "(base_link in the map frame) or its heading as theta"
        )
        if np.all(_tilts(u[:, W_FIRST]) <= NOTED_TILT):  # read w, x, y, z: all near the plane
            why = (
                "read as (w, x, y, z) instead, every one lies near the plane: the quaternion is written w first "
                "(EuRoC's and Eigen's order); name its columns in that order, qw,qx,qy,qz"
            )
        raise TrajectoryFileError(
            f"{where}: {rows[k]}'s orientation quaternion tilts {np.degrees(tilt[k]):.0f} deg from the plane "
            f"(more than {np.degrees(MAX_TILT):.0f} deg; {over.size} of {len(tilt)} poses): {why}"
        )
    if x is not None and y is not None and (unset := unset_orientations(quats, x, y)):
        return None, unset
    if tilt[k] > NOTED_TILT:
        return theta, (
            f"headings: the yaw of each orientation quaternion; they tilt up to {np.degrees(tilt[k]):.1f} deg from "
            f"the plane ({rows[k]}), which a planar robot does not follow",
        )
    return theta, ()


#: Largest angle between a step of a path and the heading (0 rad) its identity orientations give before they are
#: taken as unset (:func:`unset_orientations`) [rad].
UNSET_HEADING_TO_MOTION = 0.1


def unset_orientations(quats: FloatArray, x: FloatArray, y: FloatArray) -> tuple[str, ...]:
    """A note when a nav_msgs/Path's orientations (N, 4: x, y, z, w) are unset, else (): every pose but the last
    has the identity orientation (Nav2's NavFn planner leaves them so, giving the goal's orientation to the last
    pose alone) while the path moves off the heading that gives (0 rad) somewhere, so taken as headings they would
    have a westward leg driven in reverse. The caller then takes its headings from the motion."""
    if len(quats) < 2 or not (quats[:-1] == (0.0, 0.0, 0.0, 1.0)).all():
        return ()
    dx, dy = np.diff(x), np.diff(y)
    moving = np.hypot(dx, dy) > 0.0
    if not np.any(np.abs(np.arctan2(dy[moving], dx[moving])) > UNSET_HEADING_TO_MOTION):
        return ()  # the identity agrees with the motion (a path heading along +x): nothing to say
    return (
        f"orientations: poses[0..{len(quats) - 2}] carry the identity quaternion and the path does not run along "
        "+x, so they are unset (as Nav2's NavFn planner leaves them), not headings: the headings are the motion's, "
        "forwards (the last pose's orientation, the goal's, is not used)",
    )


def _nav_path(p: Path, data: Mapping[str, Any]) -> FileTable:
    poses = data["poses"]
    if not isinstance(poses, list) or not poses:
        raise TrajectoryFileError(f"{p}: poses must be a non-empty list of stamped poses")
    if all(isinstance(r, Mapping) and "pose" not in r and any(column_of(k) in COLUMNS for k in r) for r in poses):
        return _from_records(p, poses, "json")  # a web tool's {"poses": [{"x": .., "y": .., "theta": ..}, ...]}
    rows = tuple(f"poses[{i}]" for i in range(len(poses)))
    xs, ys, quats, stamps = [], [], [], []
    for where, pose in zip(rows, poses, strict=True):
        pos = _field(pose, ("pose", "position"), p, where)
        xs.append(_number(_field(pos, ("x",), p, where), str(p), where, "pose.position.x"))
        ys.append(_number(_field(pos, ("y",), p, where), str(p), where, "pose.position.y"))
        quats.append(_quaternion(pose, p, where))
        stamps.append(_stamp(pose, p, where))
    cols = {"x": np.asarray(xs, dtype=float), "y": np.asarray(ys, dtype=float)}
    notes: tuple[str, ...] = ()
    if all(q is not None for q in quats):
        theta, notes = orientation_headings(np.array(quats, dtype=float), rows, p, cols["x"], cols["y"], all_zero=True)
        if theta is not None:
            cols["theta"] = theta
    if all(s is not None for s in stamps) and len(set(stamps)) > 1:
        cols["t"] = np.asarray(stamps, dtype=float)
    return FileTable(p, "nav_msgs/Path", cols, rows, notes=notes)


def _plan_record(p: Path, data: Mapping[str, Any]) -> FileTable:
    """The path of nhsim's own plan record (``nhsim plan --json``): its ``path``, a list of [x, y, theta] states,
    as columns x, y, theta (the headings keep its directions of travel: reversing, and its turns in place)."""
    status, reason = data.get("status"), data.get("reason") or ""
    if status != "success":
        raise TrajectoryFileError(
            f"{p}: an nhsim plan record whose plan did not succeed (status {status!r}{': ' + reason if reason else ''})"
            f": its path does not reach the goal; plan again (another seed, a longer {option('time-limit')}, another "
            "planner) and give the new record"
        )
    states = data["path"]
    if not isinstance(states, list) or not all(isinstance(q, list) and len(q) == 3 for q in states):
        raise TrajectoryFileError(
            f"{p}: an nhsim plan record's path must be a list of [x, y, theta] states; write it again with "
            "`nhsim plan --json`"
        )
    rows = tuple(f"path[{i}]" for i in range(len(states)))
    cols = {
        name: np.array([_number(q[j], str(p), row, name) for q, row in zip(states, rows, strict=True)], dtype=float)
        for j, name in enumerate(("x", "y", "theta"))
    }
    note = f"an nhsim plan record ({data['planner']} on {data['scenario']}): its path read as x, y, theta"
    return FileTable(p, PLAN_RECORD, cols, rows, notes=(note,))
