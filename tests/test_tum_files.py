"""Orientation quaternions in trajectory files, and the TUM layout (``timestamp tx ty tz qx qy qz qw``) evo reads."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planning import TrajectoryFile
from planning.trajectory.file_formats import TrajectoryFileError
from planning.trajectory.importer import parse_columns, read_trajectory_file
from sim.cli.main import main

#: A quarter circle of radius 1 m driven forwards at 0.1 m/s, yaw along the tangent, on a unix clock.
N = 40
ANGLE = np.linspace(0.0, np.pi / 2, N)
X, Y = np.sin(ANGLE), 1.0 - np.cos(ANGLE)
YAW = ANGLE.copy()
T = 1305031102.1753 + ANGLE * 10.0  # 0.1 m/s over the arc


def _quaternions(yaw: np.ndarray, tilt: float = 0.0) -> np.ndarray:
    """(N, 4) x, y, z, w: yaw about z, then a roll of ``tilt`` about the body x axis."""
    cz, sz, cr, sr = np.cos(yaw / 2), np.sin(yaw / 2), np.cos(tilt / 2), np.sin(tilt / 2)
    return np.column_stack([cz * sr, sz * sr, sz * cr, cz * cr])


def _tum(tmp_path: Path, q: np.ndarray | None = None, name: str = "gt.txt") -> Path:
    """A TUM file as the RGB-D benchmark writes its ground truth (comment lines, then 8 numbers a row)."""
    q = _quaternions(YAW) if q is None else q
    rows = [
        f"{t:.4f} {x:.6f} {y:.6f} {0.01 * k:.4f} " + " ".join(f"{v:.7f}" for v in qk)
        for k, (t, x, y, qk) in enumerate(zip(T, X, Y, q, strict=True))
    ]
    head = "# ground truth trajectory\n# file: 'rgbd_dataset.bag'\n# timestamp tx ty tz qx qy qz qw\n"
    p = tmp_path / name
    p.write_text(head + "\n".join(rows) + "\n")
    return p


def _table(tmp_path: Path, header: str, rows: np.ndarray) -> Path:
    p = tmp_path / "bad.csv"
    p.write_text(header + "\n" + "\n".join(",".join(f"{v:.9g}" for v in r) for r in rows) + "\n")
    return p


def test_the_tum_layout_reads_positions_times_and_the_quaternions_yaw(tmp_path: Path) -> None:
    imported = read_trajectory_file(TrajectoryFile(_tum(tmp_path), columns="tum"))
    np.testing.assert_allclose(imported.xy, np.column_stack([X, Y]), atol=1e-6)
    assert imported.theta is not None and imported.t is not None
    np.testing.assert_allclose(imported.theta, YAW, atol=1e-6)  # the yaw, unwrapped as any heading
    np.testing.assert_allclose(np.diff(imported.t), np.diff(T), atol=1e-4)
    assert not any("tilt" in n for n in imported.report.notes)
    # the same layout by its names, from the command line or from Python
    assert parse_columns("tum") == parse_columns("t,x,y,_,qx,qy,qz,qw") == TrajectoryFile("a", columns=("tum",)).columns


def test_a_headerless_file_of_eight_numbers_is_pointed_to_the_tum_layout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    p = _tum(tmp_path)
    assert main(["simulate", "--trajectory", str(p), "--no-video", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "is numbers, not a header" in err and err.rstrip().endswith(
        "8 numbers a row, as a TUM trajectory's (timestamp tx ty tz qx qy qz qw): --columns tum"
    )
    # a header row of TUM's names (not a comment): tx and ty are x and y, tz is unknown and the layout is advised
    q = _quaternions(YAW)
    lines = ["timestamp,tx,ty,tz,qx,qy,qz,qw"] + [
        ",".join(str(v) for v in (t, x, y, 0.0, *qk)) for t, x, y, qk in zip(T, X, Y, q, strict=True)
    ]
    p2 = tmp_path / "gt.csv"
    p2.write_text("\n".join(lines) + "\n")
    with pytest.raises(TrajectoryFileError, match=r"unknown column name\(s\) 'tz'.*: --columns tum"):
        read_trajectory_file(p2)
    assert read_trajectory_file(TrajectoryFile(p2, columns="tum")).theta is not None


def test_quaternion_columns_in_a_header_or_json_give_the_heading(tmp_path: Path) -> None:
    q = _quaternions(YAW)
    p = _table(tmp_path, "t,x,y,qx,qy,qz,qw", np.column_stack([T - T[0], X, Y, q]))
    np.testing.assert_allclose(read_trajectory_file(p).theta, YAW, atol=1e-9)  # type: ignore[arg-type]
    records = [
        {"t": t - T[0], "x": x, "y": y, "qx": a, "qy": b, "qz": c, "qw": d}
        for t, x, y, (a, b, c, d) in zip(T, X, Y, q.tolist(), strict=True)
    ]
    pj = tmp_path / "q.json"
    pj.write_text(json.dumps(records))
    np.testing.assert_allclose(read_trajectory_file(pj).theta, YAW, atol=1e-9)  # type: ignore[arg-type]
    # a path (untimed) reads them too
    path = read_trajectory_file(TrajectoryFile(_tum(tmp_path), timed=False, columns="tum"))
    np.testing.assert_allclose(path.theta, YAW, atol=1e-6)  # type: ignore[arg-type]


def test_bad_quaternions_are_refused_naming_the_row_and_the_fix(tmp_path: Path) -> None:
    t = T - T[0]
    q = _quaternions(YAW)
    some = _table(tmp_path, "t,x,y,qx,qz,qw", np.column_stack([t, X, Y, q[:, [0, 2, 3]]]))
    with pytest.raises(TrajectoryFileError, match=r"columns are qx, qy, qz, qw, and qy is missing: name all four, or"):
        read_trajectory_file(some)
    pj = tmp_path / "some.json"
    pj.write_text(json.dumps([{"t": a, "x": b, "y": c, "qw": d} for a, b, c, d in zip(t, X, Y, q[:, 3], strict=True)]))
    with pytest.raises(TrajectoryFileError, match=r"qx, qy, qz are missing: give all four fields, or qz and qw"):
        read_trajectory_file(pj)  # a document's fields cannot be skipped with _
    q_bad = q.copy()
    q_bad[5] *= 1.5
    with pytest.raises(TrajectoryFileError, match=r"line 7 has an unnormalised \(norm 1\.5\) orientation quaternion"):
        read_trajectory_file(_table(tmp_path, "t,x,y,qx,qy,qz,qw", np.column_stack([t, X, Y, q_bad])))
    q_bad = q.copy()
    q_bad[3] = 0.0
    with pytest.raises(TrajectoryFileError, match=r"line 5 has a zero orientation quaternion"):
        read_trajectory_file(_table(tmp_path, "t,x,y,qx,qy,qz,qw", np.column_stack([t, X, Y, q_bad])))
    # a camera's optical frame (z forward: tilted 90 degrees) is not a ground robot's pose
    camera = _quaternions(YAW, tilt=-np.pi / 2)
    with pytest.raises(TrajectoryFileError, match=r"line 2's orientation quaternion tilts 90 deg .* 40 of 40 poses"):
        read_trajectory_file(_table(tmp_path, "t,x,y,qx,qy,qz,qw", np.column_stack([t, X, Y, camera])))


def test_zero_quaternions_mean_no_headings_and_a_tilt_is_said(tmp_path: Path) -> None:
    t = T - T[0]
    zero = read_trajectory_file(_table(tmp_path, "t,x,y,qx,qy,qz,qw", np.column_stack([t, X, Y, np.zeros((N, 4))])))
    assert zero.theta is None
    assert "every orientation quaternion is zero: no headings read" in " ".join(zero.report.notes)
    rolled = np.column_stack([t, X, Y, _quaternions(YAW, 0.2)])
    ramp = read_trajectory_file(_table(tmp_path, "t,x,y,qx,qy,qz,qw", rolled))
    np.testing.assert_allclose(ramp.theta, YAW, atol=1e-9)  # type: ignore[arg-type]  # the yaw of a rolled pose
    said = "headings: the yaw of each orientation quaternion; they tilt up to 11.5 deg"
    assert any(n.startswith(said) for n in ramp.report.notes)


def test_columns_given_as_one_string_are_names_not_letters() -> None:
    assert TrajectoryFile("a.csv", columns="t, x,y").columns == ("t", "x", "y")
    with pytest.raises(TrajectoryFileError, match=r"unknown column name\(s\) 'txy'"):
        TrajectoryFile("a.csv", columns="txy")  # was read as t, x, y, letter by letter


def test_identity_orientations_on_a_path_running_west_are_unset_as_in_a_bag(tmp_path: Path) -> None:
    """A table's quaternions are read as a bag's and a YAML path's (one function): identity orientations on every
    pose but the last of a path that runs off +x are Nav2's unset ones, not headings (read as headings, the westward
    leg was driven in reverse)."""
    x = np.r_[np.zeros(10), -0.1 * np.arange(1, 10)]
    y = np.r_[0.1 * np.arange(10), np.full(9, 0.9)]
    q = np.tile([0.0, 0.0, 0.0, 1.0], (19, 1))
    q[-1] = [0.0, 0.0, 1.0, 0.0]  # the goal's orientation (yaw pi) on the last pose alone
    path = read_trajectory_file(
        TrajectoryFile(_table(tmp_path, "x,y,qx,qy,qz,qw", np.column_stack([x, y, q])), timed=False)
    )
    assert path.theta is None and (path.direction > 0).all()  # forwards throughout, headings from the motion
    assert any(n.startswith("orientations: poses[0..17] carry the identity quaternion") for n in path.report.notes)


def test_a_bag_paths_positions_are_placed_in_map_when_its_orientations_are_unset() -> None:
    """Unset orientations leave no headings; placing such a path from another frame into ``map`` needed them
    (a KeyError)."""
    from planning.trajectory.bag_file import Hop, place_in_map

    hops = {"odom": Hop("map", True, np.array([0], dtype=np.int64), np.array([[1.0, 2.0, np.pi / 2]]))}
    cols: dict[str, np.ndarray] = {"x": np.array([0.0, 1.0]), "y": np.array([0.0, 0.0])}
    assert place_in_map(hops, "odom", np.array([1, 2], dtype=np.int64), cols) is not None
    np.testing.assert_allclose(np.column_stack([cols["x"], cols["y"]]), [[1.0, 2.0], [1.0, 3.0]], atol=1e-12)
    assert "theta" not in cols


def test_theta_beside_a_quaternion_wins_and_a_planar_quaternion_is_qz_and_qw(tmp_path: Path) -> None:
    """Fields a JSON export carries beside the columns were left out with a note; a quaternion beside theta (and tx,
    ty beside x, y) are too, rather than refused with advice a document cannot follow. qz and qw alone are a planar
    quaternion, as many 2-D tools write it."""
    t = T - T[0]
    q = _quaternions(YAW)
    rows = [
        {"t": a, "x": b, "y": c, "theta": d, "qx": 0.0, "qy": 0.0, "qz": 1.0, "qw": 0.0, "tx": 9.0, "ty": 9.0}
        for a, b, c, d in zip(t, X, Y, YAW, strict=True)
    ]
    pj = tmp_path / "both.json"
    pj.write_text(json.dumps(rows))
    both = read_trajectory_file(pj)
    np.testing.assert_allclose(both.theta, YAW, atol=1e-9)  # type: ignore[arg-type]
    np.testing.assert_allclose(both.xy, np.column_stack([X, Y]), atol=1e-12)
    notes = " ".join(both.report.notes)
    assert "columns qx, qy, qz, qw ignored: theta gives the heading" in notes
    assert "fields 'tx', 'ty' ignored: the columns they name (x, y) are given under their own names" in notes
    planar = read_trajectory_file(_table(tmp_path, "t,x,y,qz,qw", np.column_stack([t, X, Y, q[:, 2:]])))
    np.testing.assert_allclose(planar.theta, YAW, atol=1e-9)  # type: ignore[arg-type]


def test_evos_tum_suffix_and_a_quaternion_written_w_first(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gt = _tum(tmp_path, name="gt.tum")  # evo's --save_as_tum writes NAME.tum
    np.testing.assert_allclose(read_trajectory_file(TrajectoryFile(gt, columns="tum")).theta, YAW, atol=1e-6)  # type: ignore[arg-type]
    w_first = _tum(tmp_path, q=_quaternions(YAW)[:, [3, 0, 1, 2]], name="euroc.txt")
    assert main(["simulate", "--trajectory", str(w_first), "--no-video", "--quiet"]) == 2
    said = "its quaternion written w first (timestamp tx ty tz qw qx qy qz): --columns t,x,y,_,qw,qx,qy,qz"
    assert capsys.readouterr().err.rstrip().endswith(said)
    with pytest.raises(TrajectoryFileError, match=r"read as \(w, x, y, z\) instead, every one lies near the plane"):
        read_trajectory_file(TrajectoryFile(w_first, columns="tum"))  # identity read x first: upside down
    imported = read_trajectory_file(TrajectoryFile(w_first, columns="t,x,y,_,qw,qx,qy,qz"))
    np.testing.assert_allclose(imported.theta, YAW, atol=1e-6)  # type: ignore[arg-type]
    # a header naming the quaternion w first contradicts the tum layout (its tz, not a column, agrees with _)
    header = _table(
        tmp_path,
        "timestamp,tx,ty,tz,qw,qx,qy,qz",
        np.column_stack([T, X, Y, 0 * X, _quaternions(YAW)[:, [3, 0, 1, 2]]]),
    )
    with pytest.raises(TrajectoryFileError, match=r"column 5 is 'qx', the header says 'qw'"):
        read_trajectory_file(TrajectoryFile(header, columns="tum"))
    with pytest.raises(TrajectoryFileError, match=r"unknown column name\(s\) 'tz'") as err:
        read_trajectory_file(header)
    assert "--columns tum" not in str(err.value)  # its order is not the layout's


def test_eight_numbers_that_are_not_a_tum_row_are_not_pointed_to_it(tmp_path: Path) -> None:
    rows = np.column_stack([T - T[0], X, Y, YAW, np.full(N, 0.1), np.zeros(N), np.zeros(N), np.zeros(N)])
    p = tmp_path / "eight.txt"
    p.write_text("\n".join(" ".join(f"{v:.6f}" for v in r) for r in rows) + "\n")
    with pytest.raises(TrajectoryFileError, match=r"is numbers, not a header") as err:
        read_trajectory_file(p)
    assert "TUM" not in str(err.value)


@pytest.mark.parametrize(
    ("columns", "said"),
    [("", "names no column"), (" , ", "names no column"), (b"t,x,y", "must be names"), ("txy", "'txy'")],
)
def test_columns_that_name_nothing_or_are_not_text_are_refused(columns: object, said: str, tmp_path: Path) -> None:
    with pytest.raises(TrajectoryFileError, match=said):
        TrajectoryFile("a.csv", columns=columns)  # type: ignore[arg-type]
    from planning.trajectory.file_formats import read_table

    p = _tum(tmp_path)
    with pytest.raises(TrajectoryFileError, match=said):
        read_table(p, columns=columns)  # type: ignore[arg-type]
    assert set(read_table(p, columns="tum").columns) == {"t", "x", "y", "qx", "qy", "qz", "qw"}


def test_birrt_refuses_the_diffdrive_drive_whatever_the_world() -> None:
    """The forward-only drive was taken when one curve solved the world, refused where the trees had to grow."""
    from planning.errors import ConfigError
    from planning.planners.registry import make_planner

    with pytest.raises(ConfigError, match=r"birrt cannot steer by 'diffdrive'.*use it with 'rrt'"):
        make_planner("birrt", steering="diffdrive")
