"""What a trajectory or path file that cannot be read is told: where the problem is and the fix (exit 2, no
traceback): a file that is not UTF-8 (the byte), a YAML document of no columns (called YAML), an empty JSON
list (no rows), and a pandas export (unnamed index column) or a header with units (the ``--columns`` to give)."""

from __future__ import annotations

from pathlib import Path

import pytest

from planning.trajectory.file_formats import TrajectoryFileError, read_table
from sim.cli.main import main

ROWS = "0,0,0\n5,0.5,0\n10,1.0,0\n"


@pytest.mark.parametrize(
    ("name", "data", "needle"),
    [
        ("latin1.csv", b"t,x,y\n0,0,0\n5,0.5,0\n10,1.0,\xe9\n", "not UTF-8 text (line 4, byte 28 of the file"),
        ("latin1.csv", b"t,x,y\n0,0,0\n5,0.5,0\n10,1.0,\xe9\n", "save it as UTF-8"),
        ("cols.yaml", b"a: 1\nb: 2\n", "a YAML file gives the columns"),
        ("cols.json", b'{"a": 1}', "a JSON file gives the columns"),
        ("empty.json", b"[]", "the file holds no rows"),
        ("pandas.csv", b",t,x,y\n0,0,0,0\n1,5,0.5,0\n2,10,1.0,0\n", "--columns _,t,x,y: the unnamed first column"),
        ("units.csv", b"t [s],x [m],y [m]\n" + ROWS.encode(), "--columns t,x,y: units in the header (s, m, m)"),
        ("units.txt", b"t(s) x(m) y(m)\n" + ROWS.replace(",", " ").encode(), "--columns t,x,y: units"),
    ],
)
def test_a_file_that_cannot_be_read_is_told_where_and_the_fix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, data: bytes, needle: str
) -> None:
    p = tmp_path / name
    p.write_bytes(data)
    with pytest.raises(TrajectoryFileError):
        read_table(p)
    assert main(["simulate", "--trajectory", str(p), "--no-video", "--no-plots", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err
    assert "a list of records must hold one object per row" not in err


def test_the_columns_a_pandas_message_names_read_the_file(tmp_path: Path) -> None:
    p = tmp_path / "pandas.csv"
    p.write_text(",t [s],x [m],y [m]\n0,0,0,0\n1,5,0.5,0\n2,10,1.0,0\n")
    with pytest.raises(TrajectoryFileError, match="--columns _,t,x,y") as info:
        read_table(p)
    assert "unnamed first column" in str(info.value) and "units in the header (s, m, m)" in str(info.value)
    table = read_table(p, ("_", "t", "x", "y"))
    assert list(table.columns) == ["t", "x", "y"] and list(table.columns["x"]) == [0.0, 0.5, 1.0]


def test_another_unknown_header_keeps_the_general_advice(tmp_path: Path) -> None:
    p = tmp_path / "other.csv"
    p.write_text("time,x [m],northing\n" + ROWS)
    with pytest.raises(TrajectoryFileError, match="rename them in the header or give --columns"):
        read_table(p)
