"""The `nhsim` command line, run as a user would (a subprocess)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def nhsim(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run the CLI in a scratch directory (default outputs go to its renders/, never the repository's)."""
    import os
    import tempfile

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with tempfile.TemporaryDirectory() as scratch:
        return subprocess.run(
            [sys.executable, "-m", "sim", *args],
            cwd=cwd or scratch,
            capture_output=True,
            text=True,
            timeout=600,
            env=env,
        )


def test_simulate_writes_the_documented_record(tmp_path: Path) -> None:
    out = tmp_path / "run.json"
    r = nhsim("simulate", "--reference", "circle", "--robot", "edumip", "--json", str(out), "--no-video", "--no-plots")
    assert r.returncode == 0, r.stderr
    assert "closed_loop" in r.stdout and "open_loop" in r.stdout
    rec = json.loads(out.read_text())
    for label in ("closed_loop", "open_loop"):
        for key in (
            "final_position_error_m",
            "final_heading_error_rad",
            "rms_position_error_m",
            "max_position_error_m",
            "collisions",
            "warnings",
        ):
            assert key in rec[label]
    assert rec["robot"] == "edumip" and rec["seed"] == 0 and rec["gains"]["kp"] > 0
    assert rec["versions"]["mujoco"].startswith("3.")
    assert rec["closed_loop"]["rms_position_error_m"] < 0.01


def test_json_is_never_silently_overwritten(tmp_path: Path) -> None:
    out = tmp_path / "run.json"
    out.write_text("keep me")
    r = nhsim("simulate", "--reference", "line", "--json", str(out))
    assert r.returncode == 2 and "--overwrite" in r.stderr
    assert out.read_text() == "keep me"


def test_bad_gains_and_scenarios_are_clear_errors(tmp_path: Path) -> None:
    """(In this process: refusals before any run, six of them.)"""
    from tests.cli_helpers import nhsim_here as nhsim

    r = nhsim("simulate", "--gains", "1,-2")
    assert r.returncode == 2 and "KD = -2 is not" in r.stderr
    r = nhsim("simulate", "--gains", "fast")
    assert r.returncode == 2 and "KP,KD" in r.stderr
    # numbers starting with a minus are a value, as argparse reads -1.4 (--initial-pose -1.4,-2.4,1.2 alike) ...
    r = nhsim("simulate", "--gains", "-1,7")
    assert r.returncode == 2 and "KP = -1 is not a positive finite number" in r.stderr
    r = nhsim("simulate", "--gains=-1,7")
    assert r.returncode == 2 and "KP = -1 is not a positive finite number" in r.stderr
    # ... any other value starting with '-' is read as an option by argparse: the message says how to give it
    r = nhsim("simulate", "--gains", "-fast")
    assert r.returncode == 2 and "expected one argument" in r.stderr and "--gains=VALUE" in r.stderr
    r = nhsim("simulate", "--scenario", "no-such-scenario")
    assert r.returncode == 2 and "unknown scenario" in r.stderr
    bad = tmp_path / "bad.toml"
    bad.write_text(
        'robot = "turtlebot3"\n[world]\nbounds = [0, 1, 0, 1]\n[start]\npose = [5, 5, 0]\n[goal]\npose=[0.5,0.5,0]\n'
    )
    r = nhsim("simulate", "--scenario", str(bad))
    assert r.returncode == 2 and "start.pose" in r.stderr and str(bad) in r.stderr


def test_help_documents_the_options() -> None:
    r = nhsim("simulate", "--help")
    for opt in ("--scenario", "--robot", "--reference", "--tracker", "--gains", "--control-rate", "--seed", "--json"):
        assert opt in r.stdout
    # the rate must divide the robot's physics rate, which is 1000 Hz for the balancing EduMIP (1 ms steps)
    words = " ".join(r.stdout.split())
    assert "must divide the robot's physics rate, 500 Hz (edumip-balancing: 1000 Hz)" in words
    assert "the 500 Hz physics rate" not in words


def test_bench_sim_prints_a_ratio() -> None:
    r = nhsim("bench", "sim", "--reference", "line", "--repeats", "1")
    assert "ratio" in r.stdout and r.returncode in (0, 1)


def test_header_prints_the_simulated_time_of_the_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A planned job simulates its trajectory and then a hold of final regulation: the header's time is
    the runs' logged duration (not the trajectory's alone), and names both parts."""
    import re

    from tests.cli_helpers import nhsim_here

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "run.json"
    r = nhsim_here("simulate", "--json", str(out), "--no-video", "--no-plots")
    assert r.returncode in (0, 1), r.stderr
    rec = json.loads(out.read_text())
    header = r.stdout.splitlines()[0]
    m = re.search(r"\| ([\d.]+) s simulated \(trajectory ([\d.]+) s \+ hold ([\d.]+) s\) \|", header)
    assert m is not None, header
    total, trajectory, hold = (float(g) for g in m.groups())
    for kind in ("closed_loop", "open_loop"):
        assert total == round(rec[kind]["duration_s"], 1), (header, rec[kind]["duration_s"])
    assert trajectory == round(rec["trajectory"]["duration_s"], 1)
    assert hold > 0.0 and abs(total - trajectory - hold) <= 0.1 + 1e-9
