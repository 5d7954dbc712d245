"""Trajectory and path files given as pipes (bash's ``<(...)``, ``/dev/fd/N``) or FIFOs: ``simulate`` reads the
file more than once (the arena around it, then the run), so the reader takes its bytes in one read and gets them
again; a second read of the pipe found it empty ("the file holds no rows"). Standard input (``-``) is refused
naming the fix."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

from planning.trajectory.file_formats import TrajectoryFileError, read_table
from sim.cli.main import main

ROWS = b"t,x,y\n0,0,0\n5,0.5,0\n10,1.0,0\n"
Source = Callable[[bytes], Path]


@pytest.mark.parametrize("kind", ["pipe", "fifo"])
def test_a_pipe_reads_again_with_the_same_rows(request: pytest.FixtureRequest, kind: str) -> None:
    path = request.getfixturevalue(kind)(ROWS)
    first, second = read_table(path), read_table(path)
    assert len(first) == len(second) == 3 and list(second.columns["x"]) == [0.0, 0.5, 1.0]


def test_simulate_tracks_a_trajectory_from_a_pipe_in_an_arena_around_it(
    pipe: Source, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The arena is sized by one read of the file and the run reads it again."""
    monkeypatch.chdir(tmp_path)
    argv = ["simulate", "--trajectory", str(pipe(ROWS)), "--runs", "closed_loop", "--no-video", "--no-plots"]
    assert main([*argv, "--quiet", "--json", "run.json"]) == 0
    rec = json.loads((tmp_path / "run.json").read_text())
    assert rec["import"]["rows_read"] == 3 and rec["closed_loop"]["final_position_error_m"] <= 0.02


@pytest.mark.parametrize("option", ["--trajectory", "--path"])
def test_standard_input_is_refused_naming_a_path_to_give(
    option: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(TrajectoryFileError, match="standard input"):
        read_table("-")
    assert main(["simulate", option, "-", "--no-video", "--no-plots", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "(standard input) is not read" in err and "<(command)" in err and "Traceback" not in err
    assert "No such file" not in err
