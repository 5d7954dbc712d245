"""nhsim's own plan record (``nhsim plan --json``) as a ``--path`` file: recognised by its fields, its path of
[x, y, theta] states read with its headings, so its reversing (cusps) is kept; ``simulate`` said "none of its
fields ('cusps', 'first_path_length_m', ...) is a column"."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sim.cli.main import main


def _plan(tmp_path: Path, scenario: str) -> tuple[Path, dict]:
    record = tmp_path / f"plan-{scenario}.json"
    assert main(["plan", "--scenario", scenario, "--json", str(record)]) == 0
    return record, json.loads(record.read_text())


@pytest.mark.parametrize("scenario", ["three_point_turn", "parking_lot"])
def test_a_plan_record_is_tracked_as_a_path_with_its_cusps(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], scenario: str
) -> None:
    monkeypatch.chdir(tmp_path)
    record, plan = _plan(tmp_path, scenario)
    out = tmp_path / "run.json"
    argv = ["simulate", "--scenario", scenario, "--path", str(record), "--runs", "closed_loop"]
    assert main([*argv, "--no-video", "--no-plots", "--json", str(out)]) == 0
    assert "(nhsim plan record, path)" in capsys.readouterr().out
    rec = json.loads(out.read_text())
    assert rec["import"]["format"] == "nhsim plan record" and rec["import"]["rows_read"] == len(plan["path"])
    assert rec["smoothing"]["cusps"] == plan["cusps"]  # three_point_turn reverses twice
    assert rec["closed_loop"]["final_position_error_m"] <= 0.02 and rec["closed_loop"]["collisions"] == 0


def test_a_plan_record_as_a_trajectory_is_sent_to_the_path_option(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    record, _ = _plan(tmp_path, "three_point_turn")
    argv = ["simulate", "--scenario", "three_point_turn", "--trajectory", str(record), "--no-video", "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "an nhsim plan record holds a path, without times: use --path" in err


def test_the_record_of_a_failed_plan_is_refused_naming_its_reason(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    record, plan = _plan(tmp_path, "three_point_turn")
    record.write_text(json.dumps({**plan, "status": "timeout", "reason": "no path within 0.1 s"}))
    argv = ["simulate", "--scenario", "three_point_turn", "--path", str(record), "--no-video", "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "status 'timeout': no path within 0.1 s" in err and "plan again" in err
