"""One meaning per exit code across the commands: 0 success, 1 a run or check failed, 2 bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from sim.cli.main import main

TIGHT = (
    'robot = "edumip"\n[world]\nbounds = [0.0, 4.0, 0.0, 4.0]\n'
    '[[world.obstacles]]\ntype = "box"\ncenter = [2.0, 2.0]\nsize = [1.0, 1.0]\n'
    "[start]\npose = [2.0, 2.8, 0.0]\n[goal]\npose = [0.6, 0.6, 0.0]\n"
)


def test_a_failed_plan_exits_1_from_simulate_as_from_plan(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    scen = tmp_path / "tight.toml"
    scen.write_text(TIGHT)
    common = ["--scenario", str(scen), "--planner", "c-rrt-star", "--quiet"]
    assert main(["plan", *common]) == 1
    capsys.readouterr()
    assert main(["simulate", *common, "--no-video", "--no-plots"]) == 1
    err = capsys.readouterr().err
    assert "invalid_start" in err and "0.400 m" in err and "error:" not in err
