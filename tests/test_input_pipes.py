"""Input files given as pipes (bash's ``<(...)``, ``/dev/fd/N``) or FIFOs: a pipe can be read once, so every
reader takes its bytes in one read and a command that loads an input more than once gets the same bytes
again (it said "missing [gains] table" or "missing field(s) 'goal', 'start', 'world'" of a file that has
them). Where a pipe cannot work (a map image relative to a pipe's folder, worker processes), the error says
so and what to give instead."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from control.gains import FBLGains, load_gains_file, resolve_gains
from planning.errors import ConfigError, ScenarioError
from planning.scenario import SCENARIOS_DIR, load_scenario
from sim.physics.sensors import read_sensor_file

ROOT = Path(__file__).resolve().parents[1]
GAINS = b"[gains]\nkp = 9.5\nkd = 6.5\n"
SENSORS = b"[sensors]\nfix_rate = 5\n\n[lidar]\nbeams = 180\n"
Pipe = Callable[[bytes], Path]
Fifo = Callable[[bytes, str], Path]


def test_a_scenario_from_a_pipe_loads_again_as_the_commands_load_it(pipe: Pipe, fifo: Fifo) -> None:
    text = (SCENARIOS_DIR / "parking_lot.toml").read_bytes()
    for path in (pipe(text), fifo(text, "yard.toml")):
        first, second = load_scenario(path), load_scenario(str(path))
        assert first.world == second.world and second.name == "parking_lot"
    unnamed = b"\n".join(line for line in text.splitlines() if not line.startswith(b"name = "))
    assert load_scenario(pipe(unnamed)).name == "piped"  # not '63', the descriptor's number
    assert load_scenario(fifo(unnamed, "lot.toml")).name == "lot"  # a FIFO in a folder: its own name


def test_a_map_image_relative_to_a_pipes_folder_is_refused_naming_the_fix(pipe: Pipe) -> None:
    text = (SCENARIOS_DIR / "edumip_map.toml").read_bytes()
    with pytest.raises(ScenarioError, match=r"relative to the scenario file's folder.*give the scenario as a file"):
        load_scenario(pipe(text))


def test_a_map_image_beside_a_fifo_is_found(fifo: Fifo, tmp_path: Path) -> None:
    """A FIFO in a folder of its own is read there: relative paths are relative to that folder."""
    (tmp_path / "maps").mkdir()
    (tmp_path / "maps" / "edumip_map.png").write_bytes((ROOT / "models" / "maps" / "edumip_map.png").read_bytes())
    text = (SCENARIOS_DIR / "edumip_map.toml").read_text().replace("../maps/", "maps/").encode()
    path = fifo(text, "map.toml")
    assert load_scenario(path).name == load_scenario(path).name == "edumip_map"


def test_a_gains_file_from_a_pipe_resolves_again(pipe: Pipe, fifo: Fifo) -> None:
    for path in (pipe(GAINS), fifo(GAINS, "gains.toml")):
        assert resolve_gains(str(path)) == resolve_gains(str(path)) == FBLGains(kp=9.5, kd=6.5)
        assert load_gains_file(path).gains.kp == 9.5


def test_a_sensors_file_from_a_pipe_gives_both_tables(pipe: Pipe, fifo: Fifo) -> None:
    """simulate reads --sensors FILE for its [sensors] table and again for its [lidar] table."""
    from sim.cli.simulate import lidar_overrides, sensor_overrides

    for path in (pipe(SENSORS), fifo(SENSORS, "sensors.toml")):
        assert sensor_overrides(str(path)) == "fix_rate=5"
        assert lidar_overrides(str(path), None) == "beams=180"
        assert read_sensor_file(path)["sensors"] == {"fix_rate": 5}


def test_params_from_a_pipe_holding_a_gains_file_is_told_apart(pipe: Pipe) -> None:
    """--params refuses a gains file by what it holds, read from the same bytes as the JSON attempt."""
    from sim.tools.compare import load_params

    with pytest.raises(ConfigError, match=r"this is a gains file .*not JSON"):
        load_params([pipe(GAINS)])
    assert load_params([pipe(b'{"fbl": {"kp": 4.0}}')])["fbl"].kp == 4.0


def test_tune_refuses_a_piped_scenario_for_worker_processes(pipe: Pipe) -> None:
    from sim.cli.tune import _check_pipes

    path = pipe((SCENARIOS_DIR / "open.toml").read_bytes())
    with pytest.raises(ConfigError, match=r"a pipe .*give the scenario as a file .*or --jobs 1"):
        _check_pipes(argparse.Namespace(scenarios=f"open:line,{path}:line", jobs=2))
    _check_pipes(argparse.Namespace(scenarios=f"{path}:line", jobs=1))


def test_montecarlo_says_a_replay_needs_a_piped_input_as_a_file(pipe: Pipe) -> None:
    from sim.cli.montecarlo import _pipe_notes

    path = str(pipe(GAINS))
    args = argparse.Namespace(scenario="open", gains=path, sensors="fix_rate=5", trajectory=None, path=None)
    assert [n.split(" was ")[0] for n in _pipe_notes(args)] == [f"--gains {path}"]


def _bash(command: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``command`` run by bash (for its ``<(...)``) with ``nhsim`` as ``python -m sim`` of this checkout."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    nhsim = f"{sys.executable} -m sim"
    return subprocess.run(
        ["bash", "-c", command.replace("nhsim", nhsim)], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


def test_cli_reads_piped_inputs_once(tmp_path: Path) -> None:
    """End to end: --params and --scenario given by bash's <(...)."""
    gains = "printf '[gains]\\nkp = 9.0\\nkd = 6.0\\n'"
    done = _bash(f"nhsim compare --reference line --trackers fbl --params <({gains})", tmp_path)
    assert done.returncode == 2 and "this is a gains file" in done.stderr, done.stderr
    done = _bash(f"nhsim plan --scenario <(cat {SCENARIOS_DIR / 'edumip_map.toml'})", tmp_path)
    assert done.returncode == 2 and "give the scenario as a file" in done.stderr, done.stderr


def test_simulate_takes_gains_and_sensors_from_pipes(tmp_path: Path) -> None:
    gains, sensors = "printf '[gains]\\nkp = 9.5\\nkd = 6.5\\n'", "printf '[sensors]\\nfix_rate = 5\\n'"
    done = _bash(
        f"nhsim simulate --reference line --runs closed_loop --no-video --no-plots --json run.json "
        f"--scenario <(cat {SCENARIOS_DIR / 'open.toml'}) --gains <({gains}) --sensors <({sensors})",
        tmp_path,
    )
    assert done.returncode == 0, done.stderr
    record = json.loads((tmp_path / "run.json").read_text())
    assert record["gains"]["kp"] == 9.5 and record["sensors"]["fix_rate"] == 5.0


def test_no_output_writes_over_the_map_image_a_piped_scenario_names(
    pipe: Pipe, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A piped scenario's map image (an absolute path: a pipe's folder is not the scenario's) is an input no
    output may overwrite, as a scenario file's is: the check reads the pipe once, and the loader gets those bytes."""
    from sim.cli.main import main

    image = tmp_path / "map.png"
    image.write_bytes((ROOT / "models" / "maps" / "edumip_map.png").read_bytes())
    text = (SCENARIOS_DIR / "edumip_map.toml").read_text(encoding="utf-8")
    text = text.replace('"../maps/edumip_map.png"', json.dumps(str(image)))
    assert str(image) in text
    scenario = pipe(text.encode())
    before = image.read_bytes()
    assert main(["plan", "--scenario", str(scenario), "--plot", str(image), "--overwrite", "--quiet"]) == 2
    assert f"the output {image} is the input --scenario {scenario} (its map image" in capsys.readouterr().err
    assert image.read_bytes() == before


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/full", "/dev/null"])
def test_a_device_given_as_an_input_is_refused_unread(device: str, capsys: pytest.CaptureFixture[str]) -> None:
    """``regress --suite /dev/zero`` read zeros until the kernel stopped the process at 22 GB."""
    from planning.core.files import read_input
    from sim.cli.main import main

    with pytest.raises(OSError, match="a device, not a file: give a file, or a pipe such as <"):
        read_input(device)
    assert main(["regress", "--suite", device, "--list", "--all"]) == 2
    assert f"cannot read regression suite {device}: a device, not a file" in capsys.readouterr().err


def test_montecarlo_does_not_read_a_device_given_as_its_summary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``montecarlo --json /dev/full`` read the "old summary" to see whether it was the study's own: zeros without end,
    22 GB; it is refused as an output now, unread."""
    from sim.cli.montecarlo import _check_outputs

    real = Path.read_text

    def read_text(self: Path, *args: Any, **kwargs: Any) -> str:
        assert not str(self).startswith("/dev/"), f"read {self}"
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, "read_text", read_text)
    with pytest.raises(ConfigError, match="cannot write /dev/full: it is a character device"):
        _check_outputs({"results": tmp_path / "r.jsonl", "json": Path("/dev/full")}, [], overwrite=False)
