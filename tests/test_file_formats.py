"""Reading trajectory files: every format into the same named columns, every bad file a clear error."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planning.trajectory.file_formats import COLUMNS, TrajectoryFileError, read_table

T = [0.0, 0.5, 1.0]
X = [0.0, 0.1, 0.3]
Y = [1.0, 1.5, 2.5]


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _check_txy(table) -> None:  # type: ignore[no-untyped-def]
    np.testing.assert_array_equal(table.columns["t"], T)
    np.testing.assert_array_equal(table.columns["x"], X)
    np.testing.assert_array_equal(table.columns["y"], Y)


@pytest.mark.parametrize(
    ("name", "text", "fmt"),
    [
        ("a.csv", "t, x, y\n0, 0, 1\n0.5, 0.1, 1.5\n1, 0.3, 2.5\n", "csv"),
        ("a.tsv", "t\tx\ty\n0\t0\t1\n0.5\t0.1\t1.5\n1\t0.3\t2.5\n", "tsv"),
        ("a.txt", "% MATLAB export\nT X Y\n0 0 1\n\n0.5 0.1 1.5\n# note\n1 0.3 2.5\n", "text"),
        ("a.dat", "t,x,y\n0,0,1\n0.5,0.1,1.5\n1,0.3,2.5\n", "csv"),
        ("a.csv", "t; x; y\n0;0;1\n0.5;0.1;1.5\n1;0.3;2.5\n", "csv"),
        ("a.csv", "t;x;y\n0;0;1\n0,5;0,1;1,5\n1;0,3;2,5\n", "csv"),  # a spreadsheet's decimal commas
        ("a.txt", "t\tx\ty\n0\t0\t1\n0,5\t0,1\t1,5\n1\t0,3\t2,5\n", "tsv"),
        ("a.csv", "t,x,y,\n0,0,1,\n0.5,0.1,1.5,\n1,0.3,2.5,\n", "csv"),  # every line ended by a comma
    ],
)
def test_text_files_with_a_header(tmp_path: Path, name: str, text: str, fmt: str) -> None:
    table = read_table(_write(tmp_path, name, text))
    _check_txy(table)
    assert table.fmt == fmt and len(table) == 3


def test_columns_name_a_headerless_file_and_underscore_skips_one(tmp_path: Path) -> None:
    p = _write(tmp_path, "a.txt", "0 9 0 1\n0.5 9 0.1 1.5\n1 9 0.3 2.5\n")
    table = read_table(p, ["t", "_", "x", "y"])
    _check_txy(table)
    assert set(table.columns) == {"t", "x", "y"}
    assert table.rows == ("line 1", "line 2", "line 3")
    # --columns overrides a header, which is then skipped
    headed = _write(tmp_path, "b.csv", "time,a,b,c\n0,9,0,1\n0.5,9,0.1,1.5\n1,9,0.3,2.5\n")
    table = read_table(headed, ["t", "_", "x", "y"])
    _check_txy(table)
    assert table.rows[0] == "line 2"


def test_json_as_columns_and_as_records(tmp_path: Path) -> None:
    _check_txy(read_table(_write(tmp_path, "a.json", json.dumps({"t": T, "x": X, "y": Y}))))
    records = [{"t": t, "x": x, "y": y} for t, x, y in zip(T, X, Y, strict=True)]
    table = read_table(_write(tmp_path, "b.json", json.dumps(records)))
    _check_txy(table)
    assert table.rows == ("record 1 (index 0)", "record 2 (index 1)", "record 3 (index 2)")  # as people count
    # fields of another tool's records are left out, and said so (they were refused, with advice to give
    # --columns, which a JSON file refuses)
    extra = [{**r, "z": 0.0, "frame_id": "map"} for r in records]
    table = read_table(_write(tmp_path, "c.json", json.dumps(extra)))
    _check_txy(table)
    assert len(table.notes) == 1 and table.notes[0].startswith(
        f"fields 'z', 'frame_id' ignored (not among {', '.join(COLUMNS)} (also time for t,"
    )
    assert table.notes[0].endswith("): rename a field that holds one of these")
    table = read_table(_write(tmp_path, "d.json", json.dumps({"t": T, "x": X, "y": Y, "Heading": [0, 0, 0]})))
    assert set(table.columns) == {"t", "x", "y", "theta"} and not table.notes  # another tool's name for theta
    table = read_table(_write(tmp_path, "e.json", json.dumps({"t": T, "x": X, "y": Y, "Bearing": [0, 0, 0]})))
    assert set(table.columns) == {"t", "x", "y"} and "fields 'Bearing' ignored" in table.notes[0]


def _nav_path(yaws: list[float], stamps: list[tuple[int, int]], ros1: bool = False) -> str:
    sec, nsec = ("secs", "nsecs") if ros1 else ("sec", "nanosec")
    lines = ["header:", "  frame_id: map", "poses:"]
    for (x, y), yaw, (s, ns) in zip(zip(X, Y, strict=True), yaws, stamps, strict=True):
        lines += [
            "- header:",
            f"    stamp: {{{sec}: {s}, {nsec}: {ns}}}",
            "  pose:",
            f"    position: {{x: {x}, y: {y}, z: 0.0}}",
            f"    orientation: {{x: 0.0, y: 0.0, z: {float(np.sin(yaw / 2))!r}, w: {float(np.cos(yaw / 2))!r}}}",
        ]
    return "\n".join(lines) + "\n---\n"


@pytest.mark.parametrize("ros1", [False, True])
def test_a_ros_path_gives_positions_yaw_and_stamps(tmp_path: Path, ros1: bool) -> None:
    yaws = [0.3, -2.0, 3.0]
    stamps = [(10, 0), (10, 500_000_000), (11, 0)]
    table = read_table(_write(tmp_path, "p.yaml", _nav_path(yaws, stamps, ros1)))
    assert table.fmt == "nav_msgs/Path" and table.rows[2] == "poses[2]"
    np.testing.assert_allclose(table.columns["theta"], yaws, atol=1e-12)
    np.testing.assert_allclose(table.columns["t"], [10.0, 10.5, 11.0], atol=1e-9)
    np.testing.assert_array_equal(table.columns["x"], X)


def test_a_headerless_file_with_decimal_commas_is_numbers_not_a_header(tmp_path: Path) -> None:
    table = read_table(_write(tmp_path, "a.txt", "0;0;1\n0,5;0,1;1,5\n1;0,3;2,5\n"), ["t", "x", "y"])
    _check_txy(table)


def test_a_ros_path_with_zero_quaternions_has_no_headings_and_a_cut_off_capture_reads_its_first(
    tmp_path: Path,
) -> None:
    text = _nav_path([0.0, 1.0, 2.0], [(0, 0), (1, 0), (2, 0)])
    zero = "\n".join(
        line.split("orientation:")[0] + "orientation: {x: 0, y: 0, z: 0, w: 0}" if "orientation:" in line else line
        for line in text.splitlines()
    )
    table = read_table(_write(tmp_path, "z.yaml", zero + "\n"))  # ROS 1's default quaternion: no heading
    assert set(table.columns) == {"t", "x", "y"}
    mixed = text.replace(f"z: {float(np.sin(0.5))!r}, w: {float(np.cos(0.5))!r}", "z: 0.0, w: 0.0")
    assert mixed != text
    with pytest.raises(TrajectoryFileError, match=r"poses\[1\] has a zero orientation quaternion .* \(1 of 3 poses"):
        read_table(_write(tmp_path, "m.yaml", mixed))
    cut = text + "header:\n  frame_id: map\nposes:\n- header:\n    stamp: {sec: 3, nan"  # echo stopped mid-message
    table = read_table(_write(tmp_path, "c.yaml", cut))
    np.testing.assert_allclose(table.columns["theta"], [0.0, 1.0, 2.0], atol=1e-12)


def test_a_ros_path_with_equal_stamps_has_no_time(tmp_path: Path) -> None:
    table = read_table(_write(tmp_path, "p.yml", _nav_path([0.0, 0.0, 0.0], [(0, 0)] * 3)))
    assert "t" not in table.columns and {"x", "y"} <= set(table.columns)


@pytest.mark.parametrize(
    ("name", "text", "columns", "needles"),
    [
        ("a.csv", "t,x,northing\n0,0,1\n", None, ["'northing'", ", ".join(COLUMNS)]),
        ("a.csv", "0,0,1\n1,1,1\n", ["t", "x", "height"], ["'height'", "--columns (columns=... from Python)"]),
        ("a.csv", "t,x,y\n0,0,1\n0.5,abc,1\n", None, ["line 3", "column 'x'", "'abc'"]),
        ("a.csv", "t,x,y\n0,0,1\n0.5,nan,1\n", None, ["line 3", "column 'x'"]),
        ("a.csv", "t,x,y\n0,0,1\n0.5,1\n", None, ["line 3 has 2 cells"]),
        ("a.csv", "0,0,1\n1,1,1\n", None, ["not a header", '--columns t,x,y (columns=("t", "x", "y") from Python)']),
        ("a.csv", "t,x,x\n0,0,1\n", None, ["named twice"]),
        ("a.json", '{"t": [0, 1], "x": [0, "a"], "y": [0, 1]}', None, ["row 2 (index 1), column 'x'"]),
        ("a.json", '[{"t": 0, "x": 0, "y": 0}, {"t": 1, "x": 1}]', None, ["record 2 (index 1) has no 'y'"]),
        ("a.json", '{"t": [0, 1], "x": [0], "y": [0, 1]}', None, ["differ in length"]),
        (
            "a.json",
            '{"trajectory": [{"t": 0, "x": 0, "y": 0}]}',
            None,
            ["none of its fields ('trajectory') is a column"],
        ),
        ("a.json", "[{}]", None, ["it has no fields; a JSON file gives the columns (t, x, y,"]),
        ("a.json", '{"t": [0, 1]}', ["t", "x"], ["--columns (columns=... from Python)"]),
        ("a.yaml", "poses:\n- pose: {orientation: {x: 0, y: 0, z: 0, w: 1}}\n", None, ["poses[0]", "pose.position"]),
        # a key given twice: the last one won, silently (tracked along x = 5..7)
        ("a.json", '{"t": [0, 1], "x": [0, 1], "y": [0, 0], "x": [5, 6]}', None, ["field 'x' is given twice"]),
        ("a.yaml", "t: [0, 1]\nx: [0, 1]\ny: [0, 0]\nx: [5, 6]\n", None, ["'x' is given twice (again on line 4)"]),
    ],
)
def test_bad_files_are_errors_naming_row_and_column(
    tmp_path: Path, name: str, text: str, columns: list[str] | None, needles: list[str]
) -> None:
    with pytest.raises(TrajectoryFileError) as info:
        read_table(_write(tmp_path, name, text), columns)
    for needle in needles:
        assert needle in str(info.value), str(info.value)


def test_a_missing_file_is_an_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(TrajectoryFileError, match=r"nothing\.csv"):
        read_table(tmp_path / "nothing.csv")


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("traj.toml", "t = [0.0, 1.0]\nx = [0.0, 1.0]\ny = [0.0, 0.0]\n"),
        ("p.xml", "<path><pose t='0' x='0' y='0'/></path>\n"),
        ("book.xlsx", "PK\x03\x04"),
    ],
)
def test_an_unsupported_suffix_is_refused_naming_the_formats_read(tmp_path: Path, name: str, text: str) -> None:
    # parsed as a text table, a .toml file gave "unknown column name(s) 't = [0.0', ..." and dozens more
    with pytest.raises(TrajectoryFileError) as info:
        read_table(_write(tmp_path, name, text))
    message = str(info.value)
    assert f"a {Path(name).suffix} file is not a format read here" in message
    assert all(s in message for s in (".csv", ".txt", "no suffix", ".json", ".yaml", ".mcap")), message
    assert "unknown column" not in message and "\n" not in message
    assert read_table(_write(tmp_path, "plain", "t,x,y\n0,0,1\n0.5,0.1,1.5\n1,0.3,2.5\n")).fmt == "csv"


def test_columns_that_contradict_the_header_are_refused_and_their_advice_fits(tmp_path: Path) -> None:
    p = _write(tmp_path, "a.csv", "t,x,y\n0,0,1\n0.5,0.1,1.5\n1,0.3,2.5\n")
    with pytest.raises(TrajectoryFileError) as info:  # x and y were swapped without a word
        read_table(p, ["t", "y", "x"])
    assert str(info.value) == (
        f"{p}: the columns given (t,y,x) contradict the file's header (line 1: t,x,y): column 2 is 'y', the header "
        "says 'x'; drop --columns (columns=... from Python) to read the header's names, or correct the header"
    )
    _check_txy(read_table(p, ["t", "x", "y"]))  # the same names, and skips, agree with it
    assert set(read_table(p, ["t", "x", "_"]).columns) == {"t", "x"}
    headed = _write(tmp_path, "b.csv", "T [s],x [m],y [m]\n0,0,1\n0.5,0.1,1.5\n1,0.3,2.5\n")
    _check_txy(read_table(headed, ["t", "x", "y"]))  # a header of other names is what --columns is for
    with pytest.raises(TrajectoryFileError) as info:  # it said "or name the columns with --columns": they were
        read_table(p, ["t", "x"])
    assert "line 2 has 3 cells but 2 columns are named (t, x); name every cell with --columns" in str(info.value)
    assert "or name the columns" not in str(info.value)
