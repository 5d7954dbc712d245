"""Bags in and out safely: ``--overwrite`` replaces only a bag nhsim wrote (a robot's recording, a folder of
notes survive it, and the first refusal does not suggest it); ``nhsim bench bag`` reports a timed command's own
failure and never reads an earlier command's record; an existing bag that ``--overwrite`` cannot move aside is
refused before any work,
and a move that fails at the end keeps the old bag and every other old output (they are one set); no output may be an
input (the same bag read and written, a record over its input file); an imported bag's frame is recorded
(and a frame other than ``map`` said), poses in two frames are refused; a zero or unnormalised orientation
quaternion is refused, one within the tolerance normalised."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planning.errors import ConfigError
from planning.trajectory.file_formats import TrajectoryFileError
from planning.trajectory.importer import TrajectoryFile, read_trajectory_file
from sim.cli.main import main
from tests.test_bag import OLD_META
from tests.test_bag_cli import _arc
from tests.test_bag_read import _LINE, _path_bag

#: A short untimed job on a path file: one run, no video.
JOB = ["simulate", "--runs", "closed_loop", "--no-video", "--quiet"]


def _old_bag(folder: Path) -> Path:
    """A bag nhsim wrote earlier (marked, its one storage file), which ``--overwrite`` may replace."""
    folder.mkdir()
    (folder / "metadata.yaml").write_text(OLD_META)
    (folder / "old.mcap").write_text("old messages")
    return folder


def _kept(folder: Path) -> bool:
    return (folder / "metadata.yaml").read_text() == OLD_META and (folder / "old.mcap").read_text() == "old messages"


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err


# ------------------------------------------------------------ 0. only a bag nhsim wrote is replaced
def _recording(folder: Path) -> dict[str, str]:
    """A real robot's rosbag2 folder (sqlite3 storage) with the user's notes beside it: its files' texts."""
    folder.mkdir()
    files = {
        "metadata.yaml": "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
        "  ros_distro: humble\n  relative_file_paths:\n  - realbag_0.db3\n",
        "realbag_0.db3": "precious robot data",
        "NOTES.txt": "my notes",
    }
    for name, text in files.items():
        (folder / name).write_text(text)
    return files


def _texts(folder: Path) -> dict[str, str]:
    return {p.name: p.read_bytes().decode("latin-1") for p in folder.iterdir()}


def test_a_foreign_bag_survives_overwrite(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--bag realbag --overwrite`` deleted a robot's recording and the notes beside it
    (it held a metadata.yaml). Now: exit 2 before any run, every file intact, the message saying why and what
    to do; without ``--overwrite`` the message does not suggest it."""
    monkeypatch.chdir(tmp_path)
    bag = tmp_path / "realbag"
    files = _recording(bag)
    for extra in (["--overwrite"], []):
        argv = [*JOB, "--path", str(_arc(tmp_path)), "--bag", str(bag), *extra, "--json", "out/r.json"]
        code, err = _run(argv, capsys)
        assert code == 2, err
        assert f"cannot write the bag {bag}: it looks like a bag not written by nhsim (its metadata.yaml has no " in err
        assert "--overwrite replaces only a bag nhsim wrote, so it is kept: move it away, or choose another " in err
        assert "pass --overwrite" not in err and "from Python" not in err
        assert _texts(bag) == files and not (tmp_path / "out").exists()


def test_a_bag_inside_a_bag_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--bag outer/inner`` in nhsim's own bag outer was written; outer then held a folder beside its files, and
    ``--bag outer --overwrite`` refused it as holding "inner, which nhsim did not write"."""
    monkeypatch.chdir(tmp_path)
    bag = tmp_path / "realbag"
    files = _recording(bag)
    for inner in (bag / "inner", bag / "deeper" / "inner"):
        code, err = _run([*JOB, "--path", str(_arc(tmp_path)), "--bag", str(inner), "--json", "out/r.json"], capsys)
        assert code == 2, err
        assert (
            f"cannot write the bag {inner}: it lies inside the bag {bag} (a folder with a rosbag2 metadata.yaml)" in err
        )
        assert _texts(bag) == files and not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "argv",
    [
        [*JOB, "--json", "old/rec.json"],
        ["simulate", "--runs", "closed_loop", "--quiet", "--no-plots", "--video", "old/deeper/v.mp4"],
        ["plan", "--scenario", "simple_motion", "--json", "old/p.json"],
        ["compare", "--reference", "line", "--trackers", "fbl", "--json", "old/c.json"],
        ["simulate", "--all", "--scenario", "simple_motion", "--json", "old/all.json"],
        # regress --update's baselines into a bag: its --baselines folder was not checked
        ["regress", "--case", "open-turtlebot3-line-fbl-s0", "--baselines", "old/bl", "--update"],
    ],
)
def test_an_output_inside_a_bag_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    """A record and plots written into a bag nhsim wrote earlier were taken, and the bag could then not be replaced:
    ``--bag old --overwrite`` said it held files "which nhsim did not write"."""
    monkeypatch.chdir(tmp_path)
    bag = _old_bag(tmp_path / "old")
    code, err = _run(argv, capsys)
    assert code == 2 and f"it lies inside the bag {bag} (a folder with a rosbag2 metadata.yaml)" in err, err
    assert _kept(bag) and sorted(p.name for p in bag.iterdir()) == ["metadata.yaml", "old.mcap"]


def test_a_folder_holding_a_metadata_yaml_of_its_own_is_no_bag(tmp_path: Path) -> None:
    """Only a rosbag2 metadata.yaml makes a bag: a project's own metadata.yaml above the output refused every bag."""
    from sim.io.bag import check_bag_target

    (tmp_path / "metadata.yaml").write_text("title: my project\n")
    check_bag_target(tmp_path / "out" / "b", overwrite=False)


def test_montecarlo_bags_beside_the_studys_outputs_are_fine() -> None:
    """``--bags renders`` with the results in renders/ was refused as "sharing a path" (the bags go in worst-N)."""
    from sim.cli.montecarlo import _check_bags

    _check_bags(Path("renders"), False, [], {"results": Path("renders/r.jsonl"), "json": Path("renders/r.json")})
    with pytest.raises(ConfigError, match="meet where a bag goes"):
        _check_bags(Path("d"), False, [], {"results": Path("d/worst-0/r.jsonl")})


def test_a_folder_that_is_no_bag_is_refused_without_suggesting_overwrite(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--bag notabag`` said "pass --overwrite to replace it", and ``--overwrite`` then refused: the first
    message gives the reason now."""
    monkeypatch.chdir(tmp_path)
    folder = tmp_path / "notabag"
    folder.mkdir()
    (folder / "important.txt").write_text("keep")
    for extra in ([], ["--overwrite"]):
        argv = [*JOB, "--path", str(_arc(tmp_path)), "--bag", str(folder), *extra, "--json", "out/r.json"]
        code, err = _run(argv, capsys)
        assert code == 2, err
        assert f"cannot write the bag {folder}: it is a folder that holds files but no rosbag2 metadata.yaml" in err
        assert "pass --overwrite" not in err and "move it away, or choose another folder with --bag" in err
        assert (folder / "important.txt").read_text() == "keep" and not (tmp_path / "out").exists()


def test_a_bag_nhsim_wrote_is_replaced_and_one_given_other_files_is_not(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    bag = tmp_path / "b"
    argv = [*JOB, "--path", str(_arc(tmp_path)), "--bag", str(bag), "--json", "r.json"]
    assert _run(argv, capsys)[0] == 0
    first = _texts(bag)
    code, err = _run(argv, capsys)  # ours, without --overwrite: the usual advice
    assert code == 2 and f"{bag} exists already; pass --overwrite to replace it" in err
    assert _run([*argv, "--overwrite"], capsys)[0] == 0  # ours: replaced
    assert sorted(_texts(bag)) == sorted(first) and "nhsim.writer: nhsim" in (bag / "metadata.yaml").read_text()
    (bag / "NOTES.txt").write_text("my notes")  # a user's file put into it: no longer only what nhsim wrote
    before = _texts(bag)
    code, err = _run([*argv, "--overwrite"], capsys)
    assert code == 2 and "it is a bag nhsim wrote, but it also holds NOTES.txt, which nhsim did not write" in err
    assert _texts(bag) == before


# ------------------------------------------------------------ nhsim bench bag: a failed command is said
def _bench_runs(monkeypatch: pytest.MonkeyPatch, codes: list[int]) -> list[list[str]]:
    """Make ``nhsim bench bag``'s timed commands end with ``codes`` in turn (a success writes a record with a
    bag section and the bag folder); returns the commands run."""
    import sim.tools.bench.bag as bench

    ran: list[list[str]] = []

    def fake(cmd: list[str], **_: Any) -> subprocess.CompletedProcess[str]:
        ran.append(cmd)
        code = codes[len(ran) - 1]
        if code == 0:
            record = Path(cmd[cmd.index("--json") + 1])
            bag = {"write_s": 0.1, "write_cpu_s": 0.1, "size_bytes": 10, "duration_s": 1.0, "topics": {}}
            record.write_text(json.dumps({"bag": bag}))
            if "--bag" in cmd:
                Path(cmd[cmd.index("--bag") + 1]).mkdir()
        stderr = "" if code == 0 else "Traceback (most recent call last):\nNameError: name 'json_safe' is not defined"
        return subprocess.CompletedProcess(cmd, code, "", stderr)

    monkeypatch.setattr(bench.subprocess, "run", fake)
    return ran


@pytest.mark.parametrize("code", [1, 2, -9])
def test_bench_bag_says_a_failed_commands_own_error_and_reads_no_stale_record(
    monkeypatch: pytest.MonkeyPatch, code: int
) -> None:
    """The bench treated only exit 2 as a failure and read the record the previous (bag-less) command had left:
    a crash of the ``--bag`` command ended in ``KeyError: 'bag'``. Any non-zero exit is a failure now, said with
    the command's own error, and each command writes into a folder of its own."""
    from planning.errors import NhsimError
    from sim.tools.bench.bag import measure

    ran = _bench_runs(monkeypatch, [0, 0, code])  # the warm-up, the first without the bag, then the one with it
    with pytest.raises(NhsimError) as err:
        measure(["--reference", "line"], 1)
    text = str(err.value)
    assert f"the timed command failed (exit {code}), so nothing was measured: nhsim simulate --reference line" in text
    assert "NameError: name 'json_safe' is not defined" in text and "--bag" in text
    records = [cmd[cmd.index("--json") + 1] for cmd in ran]
    assert len(set(records)) == 3 and "--overwrite" not in ran[2]  # a fresh folder each: nothing to overwrite


def test_bench_bag_measures_when_every_command_succeeds(monkeypatch: pytest.MonkeyPatch) -> None:
    from sim.tools.bench.bag import measure

    ran = _bench_runs(monkeypatch, [0, 0, 0, 0, 0])
    result = measure(["--reference", "line"], 2)
    assert len(result.with_s) == 2 == len(result.without_s) and result.size_bytes == 10
    assert len({cmd[cmd.index("--json") + 1] for cmd in ran}) == 5
    # first an untimed command with the bag: a cold kernel cache compiled there, not charged to the first timed
    # one (always one without the bag: with a fresh cache the ratio read 0.20-0.34, "met")
    assert "--bag" in ran[0] and "warm-up" in ran[0][ran[0].index("--json") + 1] and "--bag" not in ran[1]


# ------------------------------------------------------------------ 1. a bag --overwrite cannot move aside
def test_a_bag_that_cannot_be_moved_aside_is_refused_before_any_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A read-only bag folder (what ``chmod a-w`` does for a normal user; root passes every permission
    check, so the answer is forced here): exit 2 naming the folder and the fix, nothing run or written."""
    monkeypatch.chdir(tmp_path)
    bag = _old_bag(tmp_path / "b")
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: False if Path(p) == bag else real(p, mode, **kw))
    argv = [*JOB, "--path", str(_arc(tmp_path)), "--bag", str(bag), "--overwrite", "--json", "out/r.json"]
    code, err = _run(argv, capsys)
    assert code == 2, err
    assert f"cannot replace {bag}: it is not writable" in err and f"chmod u+w {bag}" in err
    assert _kept(bag) and not (tmp_path / "out").exists() and not (tmp_path / "renders").exists()


def _chattr(flag: str, path: Path) -> bool:
    exe = shutil.which("chattr")
    return exe is not None and subprocess.run([exe, flag, str(path)], capture_output=True).returncode == 0


@pytest.mark.skipif(os.geteuid() != 0, reason="chattr +i needs root")
def test_an_immutable_bag_is_refused_before_any_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    bag = _old_bag(tmp_path / "b")
    if not _chattr("+i", bag):
        pytest.skip("the file system takes no immutable flag")
    try:
        argv = [*JOB, "--path", str(_arc(tmp_path)), "--bag", str(bag), "--overwrite", "--json", "out/r.json"]
        code, err = _run(argv, capsys)
    finally:
        _chattr("-i", bag)
    assert code == 2, err
    assert f"cannot replace {bag}: it is immutable" in err and f"chattr -i {bag}" in err
    assert _kept(bag) and not (tmp_path / "out").exists() and not (tmp_path / "renders").exists()


def _refuse_moving(bag: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Make moving ``bag`` fail as an immutable folder's move does (after the check before the run passed)."""
    real = os.replace

    def refused(src: Any, dst: Any) -> None:
        if Path(src) == bag:
            raise PermissionError(1, "Operation not permitted", str(src), None, str(dst))
        real(src, dst)

    monkeypatch.setattr(os, "replace", refused)


def test_a_bag_that_fails_to_move_at_the_end_keeps_the_old_one_and_no_other_output_is_replaced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The check passed, then moving the old bag aside fails (it was made immutable meanwhile): exit 2 naming
    the folder, the old bag in place, and the outputs are one set (:func:`sim.outputs.staged_outputs`): the
    record and plots are not written either (those moved in before the bag are moved out again), the
    folder made for them removed, no temporary file left."""
    monkeypatch.chdir(tmp_path)
    bag = _old_bag(tmp_path / "b")
    _refuse_moving(bag, monkeypatch)
    argv = [*JOB, "--path", str(_arc(tmp_path)), "--bag", str(bag), "--overwrite", "--json", "out/r.json"]
    code, err = _run(argv, capsys)
    assert code == 2, err
    assert f"could not put {bag} in place: Operation not permitted; no output was replaced" in err
    assert _kept(bag) and sorted(p.name for p in tmp_path.iterdir()) == ["arc.csv", "b"]


def test_compare_keeps_the_old_bag_and_writes_no_other_output_when_the_move_fails(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    bag = _old_bag(tmp_path / "b")
    (tmp_path / "r.json").write_text("old record")
    _refuse_moving(bag, monkeypatch)
    argv = ["compare", "--quiet", "--trackers", "fbl", "--path", str(_arc(tmp_path)), "--json", "r.json"]
    code, err = _run([*argv, "--bag", str(bag), "--overwrite"], capsys)
    assert code == 2, err
    assert f"could not put {bag} in place" in err and "no output was replaced" in err
    assert _kept(bag) and (tmp_path / "r.json").read_text() == "old record"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arc.csv", "b", "r.json"]


# --------------------------------------------------------------------------- 2. outputs apart from inputs
def _plan_bag(tmp_path: Path) -> Path:
    return _path_bag(tmp_path / "rec", {"/plan": [_LINE]})


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize(
    ("command", "bag", "said"),
    [
        (["simulate", "--runs", "closed_loop", "--no-video", "--no-plots"], "{rec}", "is the input"),
        (["simulate", "--runs", "closed_loop", "--no-video", "--no-plots"], "{link}", "is the input"),
        (["simulate", "--runs", "closed_loop", "--no-video", "--no-plots"], "{tmp}", "contains the input"),
        (["simulate", "--runs", "closed_loop", "--no-video", "--no-plots"], "{rec}/inner", "lies inside the input"),
        (["compare", "--trackers", "fbl"], "{rec}", "is the input"),
    ],
    ids=["same", "symlink", "contains", "inside", "compare"],
)
def test_a_bag_that_is_contains_or_lies_inside_an_input_is_refused(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    command: list[str],
    bag: str,
    said: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    rec = _plan_bag(tmp_path)
    (tmp_path / "link").symlink_to(rec)
    before = _files(rec)
    out = bag.format(rec=rec, link=tmp_path / "link", tmp=tmp_path)
    argv = [*command, "--quiet", "--path", str(rec), "--topic", "/plan", "--bag", out, "--overwrite"]
    code, err = _run([*argv, "--json", str(tmp_path / "r.json")], capsys)
    assert code == 2, err
    assert f"--bag {out} {said} --path {rec}" in err and "choose another --bag folder" in err
    assert _files(rec) == before and not (tmp_path / "r.json").exists()


@pytest.mark.parametrize(
    "command",
    [["simulate", "--runs", "closed_loop", "--no-video", "--no-plots"], ["compare", "--trackers", "fbl"]],
    ids=["simulate", "compare"],
)
def test_a_record_at_an_input_path_or_inside_an_input_bag_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], command: list[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    arc = _arc(tmp_path)
    text = arc.read_text()
    code, err = _run([*command, "--quiet", "--path", str(arc), "--json", str(arc), "--overwrite"], capsys)
    assert code == 2, err
    assert f"the output {arc} is the input --path {arc}" in err and arc.read_text() == text
    rec = _plan_bag(tmp_path)
    inside = rec / "r.json"
    code, err = _run([*command, "--quiet", "--path", str(rec), "--topic", "/plan", "--json", str(inside)], capsys)
    assert code == 2, err
    assert f"the output {inside} lies inside the input --path {rec}" in err and not inside.exists()


def test_montecarlo_refuses_bags_written_over_its_input(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "worst").mkdir()
    rec = _path_bag(tmp_path / "worst" / "worst-0", {"/plan": [_LINE]})
    before = _files(rec)
    argv = ["montecarlo", "--path", str(rec), "--topic", "/plan", "--runs", "2", "--jobs", "1", "--quiet"]
    code, err = _run([*argv, "--bags", "worst", "--overwrite"], capsys)
    assert code == 2, err
    assert f"--bags worst holds the input --path {rec}" in err and _files(rec) == before
    assert not (tmp_path / "renders").exists()


@pytest.mark.parametrize("output", ["f.json", "f-fan.png", "f.jsonl"])
def test_montecarlo_refuses_bags_on_its_own_outputs_before_any_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], output: str
) -> None:
    """``--bags f.json`` beside ``--json f.json``: the whole study ran and wrote its results, summary and plots,
    then exited 2 ("f.json is a file, not a folder"); now refused before the first run, nothing written."""
    monkeypatch.chdir(tmp_path)
    argv = ["montecarlo", "--reference", "line", "--runs", "2", "--jobs", "1", "--quiet", "--results", "f.jsonl"]
    code, err = _run([*argv, "--json", "f.json", "--bags", output], capsys)
    assert code == 2, err
    what = {"f.json": "summary", "f-fan.png": "fan plot", "f.jsonl": "results"}[output]
    assert f"--bags {output} and the study's {what} {output} share a path" in err, err
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------ 3. and 4. what a bag says
def _header(ty: Any, t: float, frame: str) -> Any:
    stamp = ty["builtin_interfaces/msg/Time"](sec=int(t), nanosec=round((t % 1) * 1e9))
    return ty["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)


def _pose(ty: Any, x: float, y: float, q: tuple[float, float, float, float]) -> Any:
    point = ty["geometry_msgs/msg/Point"](x=x, y=y, z=0.0)
    return ty["geometry_msgs/msg/Pose"](position=point, orientation=ty["geometry_msgs/msg/Quaternion"](*q))


def _unit(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def _write(path: Path, topic: str, msgtype: str, msgs: list[Any]) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection(topic, msgtype, typestore=store)
        for k, msg in enumerate(msgs):
            w.write(conn, k * 1000, store.serialize_cdr(msg, msgtype))
    return path


def _types() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE).types


def path_bag(path: Path, frames: list[str], header: str = "map", quats: list[Any] | None = None) -> Path:
    """One nav_msgs/Path on /plan: a 0.9 m line, pose k in ``frames[k]``, its header in ``header``."""
    ty = _types()
    quats = quats or [_unit(0.0)] * len(frames)
    poses = [
        ty["geometry_msgs/msg/PoseStamped"](header=_header(ty, 0.0, f), pose=_pose(ty, 0.1 * k, 0.25, q))
        for k, (f, q) in enumerate(zip(frames, quats, strict=True))
    ]
    return _write(
        path, "/plan", "nav_msgs/msg/Path", [ty["nav_msgs/msg/Path"](header=_header(ty, 0.0, header), poses=poses)]
    )


def odom_bag(path: Path, frames: list[str], quats: list[Any] | None = None) -> Path:
    """nav_msgs/Odometry on /odom, 0.1 s apart along a line at 0.5 m/s, message k in ``frames[k]``."""
    ty = _types()
    quats = quats or [_unit(0.0)] * len(frames)
    vec = ty["geometry_msgs/msg/Vector3"]
    twist = ty["geometry_msgs/msg/Twist"](linear=vec(x=0.5, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0))
    msgs = [
        ty["nav_msgs/msg/Odometry"](
            header=_header(ty, 0.1 * k, f),
            child_frame_id="base_footprint",
            pose=ty["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(ty, 0.05 * k, 0.0, q), covariance=np.zeros(36)),
            twist=ty["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
        )
        for k, (f, q) in enumerate(zip(frames, quats, strict=True))
    ]
    return _write(path, "/odom", "nav_msgs/msg/Odometry", msgs)


def test_a_plan_in_map_records_its_frame(tmp_path: Path) -> None:
    imported = read_trajectory_file(TrajectoryFile(path_bag(tmp_path / "b", ["map"] * 10), timed=False, topic="/plan"))
    assert imported.report.frame == "map" and imported.report.as_dict()["frame"] == "map"
    assert not any("--offset" in n for n in imported.report.notes)


@pytest.mark.parametrize("kind", ["path", "odometry"])
def test_poses_in_odom_are_taken_as_map_and_said_with_the_offset_to_use(tmp_path: Path, kind: str) -> None:
    if kind == "path":
        source = TrajectoryFile(path_bag(tmp_path / "b", ["odom"] * 10, header="odom"), timed=False, topic="/plan")
    else:
        source = TrajectoryFile(odom_bag(tmp_path / "b", ["odom"] * 10), timed=True, topic="/odom")
    report = read_trajectory_file(source).report
    assert report.as_dict()["frame"] == "odom"
    (note,) = [n for n in report.notes if n.startswith("frame")]
    assert "frame 'odom', not 'map': the poses are taken as they are in the scenario's map frame" in note
    assert "--offset" in note


def test_a_path_whose_header_names_another_frame_uses_its_poses_frame(tmp_path: Path) -> None:
    bag = path_bag(tmp_path / "b", ["odom"] * 10, header="map")
    report = read_trajectory_file(TrajectoryFile(bag, timed=False, topic="/plan")).report
    assert report.frame == "odom"
    assert "the path's header says frame 'map' but its poses are in 'odom': the poses' frame used" in report.notes


def test_the_frame_is_in_the_printed_summary_and_the_record(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    bag = path_bag(tmp_path / "b", ["odom"] * 10, header="odom")
    argv = ["simulate", "--runs", "closed_loop", "--no-video", "--no-plots", "--path", str(bag), "--topic", "/plan"]
    assert main([*argv, "--json", "r.json"]) == 0
    out = capsys.readouterr().out
    assert "  frame 'odom', not 'map'" in out
    assert json.loads((tmp_path / "r.json").read_text())["import"]["frame"] == "odom"


@pytest.mark.parametrize("kind", ["path", "odometry"])
def test_poses_in_two_frames_are_refused(tmp_path: Path, kind: str) -> None:
    frames = ["map"] * 5 + ["odom"] * 5
    if kind == "path":
        source = TrajectoryFile(path_bag(tmp_path / "b", frames), timed=False, topic="/plan")
        said = "message 0 of /plan holds poses in 2 frames: /plan message 0 poses[0] in 'map', /plan message 0 poses[5]"
    else:
        source = TrajectoryFile(odom_bag(tmp_path / "b", frames), timed=True, topic="/odom")
        said = "topic /odom holds poses in 2 frames: /odom message 0 in 'map', /odom message 5 in 'odom'"
    with pytest.raises(TrajectoryFileError) as err:
        read_trajectory_file(source)
    assert said in str(err.value) and "transform the poses into one frame" in str(err.value)


@pytest.mark.parametrize(
    ("q", "said"),
    [
        ((0.0, 0.0, 0.0, 0.0), "has a zero orientation quaternion (x, y, z, w) = (0, 0, 0, 0) (10 of 10 poses)"),
        (
            (0.0, 0.0, 0.0, 1.01),
            "has an unnormalised (norm 1.01) orientation quaternion (x, y, z, w) = (0, 0, 0, 1.01)",
        ),
    ],
    ids=["zero", "unnormalised"],
)
@pytest.mark.parametrize("kind", ["path", "odometry"])
def test_a_zero_or_unnormalised_quaternion_is_refused(tmp_path: Path, kind: str, q: Any, said: str) -> None:
    if kind == "path":
        source = TrajectoryFile(path_bag(tmp_path / "b", ["map"] * 10, quats=[q] * 10), timed=False, topic="/plan")
        row = "/plan message 0 poses[0]"
    else:
        source = TrajectoryFile(odom_bag(tmp_path / "b", ["map"] * 10, quats=[q] * 10), timed=True, topic="/odom")
        row = "/odom message 0"
    with pytest.raises(TrajectoryFileError) as err:
        read_trajectory_file(source)
    text = str(err.value)
    assert f"{row} {said}" in text and "norm 1 within 0.001 (tf2 refuses others)" in text
    assert ("normalise it" if q[3] else "give it the pose's orientation") in text


def test_a_quaternion_within_the_tolerance_is_normalised(tmp_path: Path) -> None:
    yaw = 0.3
    x, y, z, w = (1.0 + 5e-4) * np.array(_unit(yaw))
    bag = path_bag(tmp_path / "b", ["map"] * 10, quats=[(x, y, z, w)] * 10)
    imported = read_trajectory_file(TrajectoryFile(bag, timed=False, topic="/plan"))
    assert imported.theta is not None
    np.testing.assert_allclose(imported.theta, yaw, atol=1e-12)


@pytest.mark.parametrize("name", ["run.mcap", "run.db3", "RUN.MCAP", "run.bag"])
def test_a_bag_named_as_a_file_is_refused_naming_the_folder_to_give(tmp_path: Path, name: str) -> None:
    """--bag run.mcap made a folder run.mcap holding run.mcap.mcap, which a viewer opening "run.mcap" met as a
    folder."""
    from sim.io.bag import check_bag_target

    with pytest.raises(ConfigError, match=r"(?i)a ROS 2 bag is a folder .* give the folder's name, e\.g\. --bag .*run"):
        check_bag_target(tmp_path / name, overwrite=False)
    assert list(tmp_path.iterdir()) == []


def test_a_dangling_link_where_the_bag_goes_is_named_as_one(tmp_path: Path) -> None:
    """It was "a file of that name exists", where a link to nothing stood."""
    from sim.io.bag import check_bag_target

    (tmp_path / "bag").symlink_to(tmp_path / "nothing")
    with pytest.raises(ConfigError, match=rf"a symbolic link to {tmp_path}/nothing, which does not exist, of that"):
        check_bag_target(tmp_path / "bag", overwrite=True)
    assert (tmp_path / "bag").is_symlink()


def test_a_folder_named_as_a_text_file_is_said_to_be_a_folder_not_a_bag(tmp_path: Path) -> None:
    """A folder ``run.csv`` was read as a bag: "the folder has no metadata.yaml, so it is not a rosbag2 bag"."""
    (tmp_path / "run.csv").mkdir()
    with pytest.raises(TrajectoryFileError, match=r"run\.csv is a folder, not a CSV file; give the file"):
        read_trajectory_file(TrajectoryFile(tmp_path / "run.csv"))
