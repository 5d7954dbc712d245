"""``--bag`` on the command line: simulate records the bag in its run record, compare writes one
namespace per tracker, montecarlo writes its worst runs replayed; all on a short path file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sim.cli.main import main


def _arc(folder: Path) -> Path:
    x = np.linspace(0.0, 0.6, 7)
    p = folder / "arc.csv"
    p.write_text("x,y\n" + "\n".join(f"{a:.4f},{0.1 * np.sin(np.pi * a / 0.6):.4f}" for a in x) + "\n")
    return p


def _topics(path: Path) -> dict[str, int]:
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        return {name: info.msgcount for name, info in reader.topics.items()}


def test_simulate_writes_the_bag_and_lists_it_in_the_record(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    arc = _arc(tmp_path)
    argv = ["simulate", "--path", str(arc), "--runs", "closed_loop", "--no-video", "--no-plots", "--quiet"]
    assert main([*argv, "--bag", "out/run-bag", "--json", "out/run.json"]) == 0
    record = json.loads((tmp_path / "out" / "run.json").read_text())
    assert record["files"]["bag"] == "out/run-bag"
    topics = _topics(tmp_path / "out" / "run-bag")
    assert {k: v["messages"] for k, v in record["bag"]["topics"].items()} == topics
    assert record["bag"]["size_bytes"] == sum(f.stat().st_size for f in (tmp_path / "out" / "run-bag").iterdir())
    assert "/closed_loop/ground_truth/odom" in topics and "/open_loop/odom" not in topics


def test_compare_and_montecarlo_write_bags(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    arc = str(_arc(tmp_path))
    assert main(["compare", "--path", arc, "--trackers", "fbl,open-loop", "--bag", "cmp", "--quiet"]) == 0
    topics = _topics(tmp_path / "cmp")
    assert {"/fbl/cmd_vel", "/open_loop/cmd_vel", "/plan", "/map"} <= set(topics)  # open-loop: a ROS name
    mc = ["montecarlo", "--path", arc, "--runs", "2", "--jobs", "1", "--no-plots", "--quiet", "--bags", "worst"]
    assert main(mc) == 0
    summary = json.loads(next((tmp_path / "renders").glob("*-mc-*.json")).read_text())
    worst = [w["index"] for w in summary["statistics"]["closed_loop"]["worst"]]
    assert sorted(p.name for p in (tmp_path / "worst").iterdir()) == sorted(f"worst-{i}" for i in worst)
    for i in worst:  # each bag is its run replayed: the record's final error, to the bit
        from rosbags.highlevel import AnyReader

        with AnyReader([tmp_path / "worst" / f"worst-{i}"]) as reader:
            conns = [c for c in reader.connections if c.topic == "/closed_loop/tracking_error"]
            *_, (c, _, raw) = reader.messages(connections=conns)
            last = reader.deserialize(raw, c.msgtype).vector.x
        entry = next(w for w in summary["statistics"]["closed_loop"]["worst"] if w["index"] == i)
        assert last == pytest.approx(entry["final_position_error_m"], abs=1e-9)


def test_a_bag_of_a_sweep_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--all", "--bag", "b", "--no-video"]) == 2
    assert "--bag writes one job's runs" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "--reference", "line", "--runs", "closed_loop", "--no-video", "--quiet"],
        ["compare", "--reference", "line", "--trackers", "fbl", "--quiet"],
    ],
)
def test_a_file_output_at_the_bags_path_is_refused_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    for json_path, bag in (("out.json", "out.json"), ("out/run.json", "out")):  # the same path, or inside it
        assert main([*argv, "--json", str(tmp_path / json_path), "--bag", str(tmp_path / bag)]) == 2
        assert f"and --bag {tmp_path / bag} share a path" in capsys.readouterr().err
        assert list(tmp_path.iterdir()) == []  # nothing run, nothing written


def test_compare_refuses_a_video_that_is_not_mp4(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    video = tmp_path / "all.avi"
    assert main(["compare", "--reference", "line", "--trackers", "fbl", "--quiet", "--video", str(video)]) == 2
    assert "--video must name an .mp4 file" in capsys.readouterr().err and not video.exists()
