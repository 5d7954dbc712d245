"""A hung-up terminal, a full disk, an interrupted benchmark and the words of a few messages.

- SIGHUP (a closed terminal, a dropped ssh connection) ended a command with 129 and left a half-written
  video in its hidden staging folder: it is an interrupt now, as SIGTERM is (exit status 130).
- A full disk met by ``write()`` or ``close()`` (matplotlib, ``Path.write_text``) raised an OSError without a
  file name, and the command said "could not write: No space left on device" without naming the file; the
  video's said "simulation failed: ffmpeg stopped while writing ...".
- ``nhsim bench render`` interrupted left its empty temporary folder in /tmp.
- "trials #1 were interrupted"; "two outputs share a path: same.json and same.json"; ``nhsim bench: error:``.
"""

from __future__ import annotations

import errno
import io
import re
import signal
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from sim.cli.main import main

FULL = "No space left on device"


# ---- SIGHUP -------------------------------------------------------------------------------------


def test_a_hangup_is_an_interrupt_as_sigterm_is_and_nohup_keeps_it_ignored() -> None:
    from planning.signals import signals_held
    from sim.cli.interrupt import sigterm_as_interrupt

    before = signal.getsignal(signal.SIGHUP)
    unhandled: list[int] = []  # in place of SIGHUP's default, which would end the test run
    try:
        signal.signal(signal.SIGHUP, lambda signum, frame: unhandled.append(signum))
        with sigterm_as_interrupt():
            with pytest.raises(KeyboardInterrupt, match="SIGHUP"):
                signal.raise_signal(signal.SIGHUP)
            taken = []
            with pytest.raises(KeyboardInterrupt):  # held as SIGTERM is, and acted on as the block ends
                with signals_held():
                    signal.raise_signal(signal.SIGHUP)
                    taken.append("held")
            assert taken == ["held"]
        assert not unhandled
        signal.raise_signal(signal.SIGHUP)  # the handler before the block is back
        assert unhandled == [signal.SIGHUP]
        signal.signal(signal.SIGHUP, signal.SIG_IGN)  # as ``nohup`` starts a command
        with sigterm_as_interrupt():
            signal.raise_signal(signal.SIGHUP)  # ignored: nothing raised
            assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, before)


def test_an_interrupted_command_ignores_a_hangup_while_it_exits(monkeypatch: pytest.MonkeyPatch) -> None:
    import sim.cli.main as cli

    sigs = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    before = {sig: signal.getsignal(sig) for sig in sigs}
    try:
        monkeypatch.setattr(cli, "main", lambda: 130)
        assert cli.console() == 130
        assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
    finally:
        for sig, handler in before.items():
            signal.signal(sig, handler)


class _HungUp(io.StringIO):
    """The standard error of a terminal that hung up: every write fails (EIO)."""

    def write(self, text: str) -> int:
        raise OSError(errno.EIO, "Input/output error")


def test_an_interrupt_with_a_hung_up_terminal_still_exits_130(monkeypatch: pytest.MonkeyPatch) -> None:
    """Its "interrupted" could not be printed on the closed terminal: the print's OSError ended it with 1."""
    import sim.cli.scenarios as command

    def hung_up(args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(command, "run", hung_up)
    monkeypatch.setattr(sys, "stderr", _HungUp())
    assert main(["scenarios"]) == 130


# ---- a full disk --------------------------------------------------------------------------------


def _full(*args: Any, **kwargs: Any) -> None:
    raise OSError(errno.ENOSPC, FULL)  # as write() and close() raise it: no file name


def test_a_full_disk_writing_a_plot_names_the_plot(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from matplotlib.figure import Figure

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(Figure, "savefig", _full)
    argv = ["plan", "--scenario", "simple_motion", "--planner", "rrt", "--quiet", "--json", "p.json"]
    assert main([*argv, "--plot", "p.svg"]) == 1
    err = capsys.readouterr().err
    assert err == (
        f"nhsim plan: failed: could not write p.svg: {FULL}; no output was written or replaced: free space (or give "
        "a path on another disk) and run it again\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_writing_staged_or_atomic_outputs_names_the_file(tmp_path: Path) -> None:
    from sim.outputs import atomic_path, shown, staged_outputs, write_json

    target = tmp_path / "r.json"
    with pytest.raises(OSError) as caught, staged_outputs() as stage:
        stage.path(tmp_path / "first.json").write_text("{}")
        stage.path(target)
        _full()  # a write of the output last asked for
    assert caught.value.filename == str(target)
    with pytest.raises(OSError) as caught, atomic_path(target) as tmp:
        tmp.write_bytes(b"x")
        _full()
    assert caught.value.filename == str(target)
    with pytest.raises(OSError) as caught, staged_outputs() as stage:
        staged = stage.path(target)
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(Path, "write_text", _full)
            write_json(staged, {"a": 1})
    assert shown(caught.value.filename) == str(target)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(FileNotFoundError) as missing, staged_outputs() as stage:  # not a write's error: as it was
        stage.path(target)
        raise FileNotFoundError(errno.ENOENT, "gone")
    assert missing.value.filename is None


def test_a_full_disk_while_encoding_a_video_is_a_write_failure_naming_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ffmpeg writing to /dev/full says "No space left on device", as on a full disk."""
    import sim.viz.video as video

    real = video.ffmpeg_command
    monkeypatch.setattr(
        video, "ffmpeg_command", lambda exe, path, *a, **k: [*real(exe, path, *a, **k)[:-1], "/dev/full"]
    )
    target = tmp_path / "v.mp4"
    frame = np.zeros((64, 64, 3), dtype=np.uint8)
    with pytest.raises(OSError) as caught:
        with video.VideoWriter(target, 64, 64, 30) as writer:
            for _ in range(400):
                writer.write(frame)
    assert not isinstance(caught.value, video.SimulationError)
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(target)
    assert list(tmp_path.iterdir()) == []


# ---- bench render -------------------------------------------------------------------------------


def test_an_interrupted_render_benchmark_leaves_no_temporary_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sim.viz.replay as replay
    from sim.tools.bench.render import _pipeline

    def interrupted(*args: Any, **kwargs: Any) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(replay, "Replay", interrupted)
    with pytest.raises(KeyboardInterrupt):
        _pipeline(None, SimpleNamespace(trajectory=None, logs=None), None, None, 100)
    assert list(tmp_path.iterdir()) == []


# ---- wording ------------------------------------------------------------------------------------


def test_one_interrupted_trial_is_one(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from sim.cli.tune import _settle
    from sim.tools import tune

    class Study:
        def get_trials(self, **kwargs: Any) -> list[Any]:
            return []

    for numbers, said in (([1], "trial #1 was interrupted: its gains are"), ([1, 4], "trials #1, #4 were")):
        monkeypatch.setattr(tune, "requeue_interrupted", lambda study, numbers=numbers: numbers)
        _settle(Study(), quiet=False)
        assert capsys.readouterr().err.startswith(said)


def test_two_outputs_at_one_path_are_named_by_their_options(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from planning.errors import ConfigError
    from sim.outputs import check_distinct

    monkeypatch.chdir(tmp_path)
    assert main(["tune", "--scenarios", "simple_motion", "--out", "same.json", "--json", "same.json"]) == 2
    err = capsys.readouterr().err
    assert "--out (the gains) and --json (the record) both name same.json; choose distinct names" in err
    assert list(tmp_path.iterdir()) == []
    # a job's video by its default name, the record given there: "is given for two of them" named neither
    assert main(["simulate", "--reference", "line", "--json", "renders/open-line.mp4", "--no-plots"]) == 2
    said = "--video (the video) and --json (the record) both name renders/open-line.mp4; choose distinct names"
    assert said in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ConfigError) as caught:
        check_distinct([Path("same.json"), Path("other.json"), Path("same.json")])
    assert not re.search(r"same\.json and same\.json", str(caught.value))
    assert "same.json is given for two of them" in str(caught.value)


def test_a_benchmarks_error_names_the_benchmark(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "render", "--frames", "0"]) == 2
    assert capsys.readouterr().err.startswith("nhsim bench render: error: --frames must be")
