"""MP4 writer: decodes back (imageio-ffmpeg) with the right codec, size, count and content; atomic."""

from __future__ import annotations

from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from planning.errors import ConfigError, OutputExistsError
from sim.viz.video import VideoWriter, ffmpeg_command


def synthetic(k: int, w: int = 96, h: int = 64) -> np.ndarray:
    """Grey frame with a white 16x16 square moving right by 4 px per frame."""
    f = np.full((h, w, 3), 40, np.uint8)
    x = 4 * k
    f[24:40, x : x + 16] = 255
    return f


def read_video(path: Path) -> tuple[dict, np.ndarray]:
    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    w, h = meta["size"]
    frames = np.stack([np.frombuffer(b, np.uint8).reshape(h, w, 3) for b in gen])
    return meta, frames


def test_roundtrip_h264_yuv420p(tmp_path: Path) -> None:
    out = tmp_path / "v.mp4"
    with VideoWriter(out, 96, 64, 10.0) as w:
        for k in range(12):
            w.write(synthetic(k))
    assert w.frames_written == 12
    meta, frames = read_video(out)
    assert meta["codec"] == "h264"
    assert meta["pix_fmt"].startswith("yuv420p")
    assert frames.shape == (12, 64, 96, 3)
    # lossy, but the square is where it was drawn: mean error small, square bright, background dark
    for k in (0, 5, 11):
        ref = synthetic(k).astype(float)
        assert np.abs(frames[k].astype(float) - ref).mean() < 6.0
        assert frames[k][28:36, 4 * k + 4 : 4 * k + 12].mean() > 200
    assert not list(tmp_path.glob(".*part*")), "temporary file left behind"


def test_colours_play_as_drawn_in_a_player_that_decodes_hd_as_bt709(tmp_path: Path) -> None:
    """The stream was converted with BT.601's matrix and left untagged; browsers decode such an HD stream with
    BT.709's, and pure green played as (0, 215, 0). Converted with BT.709's and tagged so, every decoder agrees."""
    import subprocess

    colours = [(0, 255, 0), (0, 0, 255), (255, 0, 0), (48, 112, 192), (230, 230, 230)]
    out = tmp_path / "c.mp4"
    with VideoWriter(out, 64, 48, 10.0) as w:
        for colour in colours:
            w.write(np.full((48, 64, 3), colour, np.uint8))
    exe = imageio_ffmpeg.get_ffmpeg_exe()
    probe = subprocess.run([exe, "-hide_banner", "-i", str(out)], capture_output=True, text=True).stderr
    assert "yuv420p(tv, bt709, progressive)" in probe
    for matrix in ("null", "scale=in_color_matrix=bt709"):  # as tagged; as a browser assumes for HD
        cmd = [exe, "-hide_banner", "-loglevel", "error", "-i", str(out), "-vf", matrix, "-f", "rawvideo"]
        raw = subprocess.run([*cmd, "-pix_fmt", "rgb24", "-"], capture_output=True, check=True).stdout
        frames = np.frombuffer(raw, np.uint8).reshape(-1, 48, 64, 3).astype(int)
        for frame, colour in zip(frames, colours, strict=True):
            assert np.abs(frame[20:28, 28:36] - colour).max() <= 6, (matrix, colour, frame[24, 32])


def test_encodes_while_frames_arrive(tmp_path: Path) -> None:
    """The writer thread hands frames to ffmpeg before the context exits."""
    out = tmp_path / "v.mp4"
    with VideoWriter(out, 96, 64, 10.0, depth=2) as w:
        for k in range(20):
            w.write(synthetic(k))
        # with a queue of 2 and a pool of 4, at least 16 frames must already be in ffmpeg
        assert w.frames_written >= 20 - 4
    assert read_video(out)[1].shape[0] == 20


def test_interrupted_render_leaves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "v.mp4"
    with pytest.raises(KeyboardInterrupt), VideoWriter(out, 96, 64, 10.0) as w:
        for k in range(5):
            w.write(synthetic(k))
        raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_interrupted_render_keeps_existing_file(tmp_path: Path) -> None:
    out = tmp_path / "v.mp4"
    out.write_bytes(b"old video")
    with pytest.raises(RuntimeError), VideoWriter(out, 96, 64, 10.0, overwrite=True) as w:
        w.write(synthetic(0))
        raise RuntimeError("boom")
    assert out.read_bytes() == b"old video"
    assert [p.name for p in tmp_path.iterdir()] == ["v.mp4"]


def test_never_overwrites_without_permission(tmp_path: Path) -> None:
    out = tmp_path / "v.mp4"
    out.write_bytes(b"keep me")
    with pytest.raises(OutputExistsError, match="--overwrite"), VideoWriter(out, 96, 64, 10.0):
        pass
    assert out.read_bytes() == b"keep me"
    with VideoWriter(out, 96, 64, 10.0, overwrite=True) as w:
        w.write(synthetic(0))
    assert read_video(out)[1].shape == (1, 64, 96, 3)


@pytest.mark.parametrize(("w", "h"), [(95, 64), (96, 63), (8, 8)])
def test_rejects_odd_or_tiny_sizes(tmp_path: Path, w: int, h: int) -> None:
    with pytest.raises(ConfigError, match="even"):
        VideoWriter(tmp_path / "v.mp4", w, h, 10.0)


def test_rejects_wrong_frame_shape(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="frame must be"), VideoWriter(tmp_path / "v.mp4", 96, 64, 10.0) as w:
        w.write(np.zeros((64, 96, 4), np.uint8))
    assert list(tmp_path.iterdir()) == []


def test_command_is_browser_playable() -> None:
    cmd = ffmpeg_command("ffmpeg", Path("x.mp4"), 640, 480, 30.0, crf=23, preset="veryfast", threads=1)
    joined = " ".join(cmd)
    assert "-c:v libx264" in joined and "format=yuv420p" in joined and "+faststart" in joined
    assert "-s 640x480" in joined and "-r 30" in joined


def test_an_interrupt_while_ffmpeg_starts_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """SIGTERM (as KeyboardInterrupt) can land after the temporary file exists and before the writer is
    open: nothing may stay behind."""
    import sim.viz.video as video

    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt("signal SIGTERM")

    monkeypatch.setattr(video, "ffmpeg_command", interrupted)  # called once the temporary file exists
    writer = VideoWriter(tmp_path / "x.mp4", 64, 48, 10)  # kept alive, as a traceback being handled keeps it
    with pytest.raises(KeyboardInterrupt), writer:
        pass
    assert list(tmp_path.iterdir()) == []


def test_an_interrupt_as_the_temporary_file_is_created_leaves_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A signal landing just after ``mkstemp`` made the temporary file, before its name is returned and
    kept: the interrupt waits until the name is kept, so the file is removed (it stayed behind once
    under load, a SIGTERM sent as soon as the file appeared)."""
    import signal
    import tempfile

    real = tempfile.mkstemp

    def made_then_interrupted(*args: object, **kwargs: object) -> tuple[int, str]:
        made = real(*args, **kwargs)  # type: ignore[call-overload]
        signal.raise_signal(signal.SIGINT)  # Python's own handler: KeyboardInterrupt at once
        return made  # type: ignore[no-any-return]

    monkeypatch.setattr(tempfile, "mkstemp", made_then_interrupted)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with pytest.raises(KeyboardInterrupt), VideoWriter(tmp_path / "x.mp4", 64, 48, 10):
        pass
    assert list(tmp_path.iterdir()) == []


def test_an_interrupt_as_ffmpeg_starts_stops_it_and_leaves_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A signal landing inside ``Popen``, once ffmpeg runs and before the writer holds it: raised there,
    ffmpeg ran on unknown to the writer and, once its input closed, re-created the removed temporary
    file (4 renders in 30 stopped as soon as the file appeared left it behind, with exit status 130).
    The interrupt now waits until the writer holds ffmpeg, which it then stops."""
    import signal
    import subprocess

    real = subprocess.Popen
    started: list[subprocess.Popen[bytes]] = []

    def started_then_interrupted(*args: object, **kwargs: object) -> subprocess.Popen[bytes]:
        started.append(real(*args, **kwargs))  # type: ignore[call-overload]
        signal.raise_signal(signal.SIGINT)  # Python's own handler: KeyboardInterrupt at once
        return started[-1]

    monkeypatch.setattr(subprocess, "Popen", started_then_interrupted)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with pytest.raises(KeyboardInterrupt), VideoWriter(tmp_path / "x.mp4", 64, 48, 10):
        pass
    ffmpeg = started[0]
    if ffmpeg.stdin is not None:
        ffmpeg.stdin.close()  # what the garbage collector does to an orphan's pipe
    assert ffmpeg.wait(timeout=30) != 0  # stopped, not left to finish its file
    assert list(tmp_path.iterdir()) == []


def test_an_unfinished_output_leaves_no_folder_it_made(tmp_path: Path) -> None:
    from sim.outputs import atomic_path, write_json

    keep = tmp_path / "renders" / "other.json"
    write_json(keep, {})
    with pytest.raises(KeyboardInterrupt), atomic_path(tmp_path / "renders" / "new" / "deeper" / "x.json"):
        raise KeyboardInterrupt  # an interrupt while the output is being written
    assert [p.relative_to(tmp_path) for p in tmp_path.rglob("*")] == [Path("renders"), Path("renders/other.json")]
    write_json(tmp_path / "a" / "b" / "y.json", {"done": 1})  # a finished one keeps the folders it made
    assert (tmp_path / "a" / "b" / "y.json").is_file()


@pytest.mark.parametrize("flag", ["no", "yes", 0, 1, None, 0.0])
def test_every_writer_refuses_an_overwrite_that_is_not_true_or_false(tmp_path: Path, flag: object) -> None:
    """Every output goes through :func:`sim.outputs.atomic_path` (or the bag's own target check), which once
    read ``overwrite`` for its truth: ``"no"`` replaced the file. A flag is True or False (a numpy bool too)."""
    from sim.io.bag import check_bag_target
    from sim.outputs import atomic_path, check_writable, write_json

    out = tmp_path / "v.mp4"
    out.write_bytes(b"keep me")
    refused = pytest.raises(ConfigError, match=r"^overwrite must be True or False, got ")
    with refused:
        VideoWriter(out, 96, 64, 10.0, overwrite=flag)  # type: ignore[arg-type]
    with refused:
        write_json(out, {}, overwrite=flag)  # type: ignore[arg-type]
    with refused, atomic_path(out, overwrite=flag):  # type: ignore[arg-type]
        pass
    with refused:
        check_writable(out, overwrite=flag)  # type: ignore[arg-type]
    with refused:
        check_bag_target(tmp_path / "bag", overwrite=flag)  # type: ignore[arg-type]
    assert out.read_bytes() == b"keep me" and [p.name for p in tmp_path.iterdir()] == ["v.mp4"]
    write_json(out, {"kept": False}, overwrite=np.True_)
    assert out.read_text() == '{\n  "kept": false\n}\n'


@pytest.mark.parametrize("name", ["v.avi", "v.mkv", "v", "v.mp4.part"])
def test_a_name_that_is_not_mp4_is_refused_before_anything_is_written(tmp_path: Path, name: str) -> None:
    """ffmpeg is told ``-f mp4``: "x.avi" held MP4 data under a false name."""
    with pytest.raises(ConfigError, match=r"^a video's path must name an \.mp4 file \(the video is H\.264 in MP4"):
        VideoWriter(tmp_path / "sub" / name, 96, 64, 10.0)
    assert list(tmp_path.iterdir()) == []  # no file, no folder
    with VideoWriter(tmp_path / "sub" / "V.MP4", 96, 64, 10.0) as w:  # any case; the missing folder is made
        w.write(synthetic(0))
    assert (tmp_path / "sub" / "V.MP4").stat().st_size > 0
