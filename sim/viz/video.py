"""MP4 writer: H.264 in yuv420p (plays in browsers), encoded while frames are still being drawn.

Frames go through a small pool of buffers to a writer thread that streams them into the standard
input of ``ffmpeg`` (the binary shipped by imageio-ffmpeg), so encoding runs alongside rendering
instead of after it. The file is written under a temporary name beside the target and renamed onto
it only when ffmpeg has finished cleanly (:func:`sim.outputs.atomic_path`): an interrupted or failed
render leaves nothing under the final name.
"""

from __future__ import annotations

import contextlib
import errno
import os
import queue
import subprocess
import threading
from pathlib import Path
from types import TracebackType

import numpy as np
from numpy.typing import NDArray

from planning.core.checks import check_flag, check_number
from planning.errors import ConfigError, DependencyError, SimulationError
from planning.signals import signals_held
from sim.outputs import atomic_path, check_video_name, shown

Frame = NDArray[np.uint8]

#: x264 presets accepted by :class:`VideoWriter` (faster ones leave more CPU for rendering).
PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow")

#: The errors of a write that ffmpeg reports in the C library's words (``strerror``): a full disk or quota, a
#: file too large, an I/O error. The video's writer raises them as the OSError any other write raises, naming
#: the file, so the command says "could not write FILE" for the video as for its other outputs (exit status 1).
WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO)


def write_failure(said: str, path: Path) -> OSError | None:
    """The OSError of the write that failed, when ffmpeg's error output ``said`` names one of
    :data:`WRITE_ERRNOS` (writing ``path``); else None."""
    code = next((c for c in WRITE_ERRNOS if os.strerror(c) in said), None)
    return None if code is None else OSError(code, os.strerror(code), str(path))


def ffmpeg_exe() -> str:
    """Path of the ffmpeg binary shipped by imageio-ffmpeg.

    Raises:
        DependencyError: imageio-ffmpeg is missing or has no binary for this platform.
    """
    try:
        import imageio_ffmpeg

        return str(imageio_ffmpeg.get_ffmpeg_exe())
    except (ImportError, RuntimeError) as exc:
        raise DependencyError(f"no ffmpeg binary ({exc}); install it with: pip install imageio-ffmpeg") from exc


#: The frames' conversion to yuv420p, with BT.709's matrix in its limited range, and the stream tagged so. Players
#: decode an untagged stream of HD size as BT.709 while ffmpeg's default conversion is BT.601's: pure green came out as
#: (0, 215, 0) in a browser. The tags cost no time (the conversion is made either way).
BT709 = (
    "scale=out_color_matrix=bt709:out_range=tv,format=yuv420p,"
    "setparams=colorspace=bt709:color_primaries=bt709:color_trc=bt709:range=tv"
)


def ffmpeg_command(
    exe: str, path: Path, width: int, height: int, fps: float, *, crf: int, preset: str, threads: int
) -> list[str]:
    """The ffmpeg command line that reads raw RGB frames on stdin and writes a browser-playable MP4."""
    quiet = ["-hide_banner", "-loglevel", "error", "-nostdin", "-y"]
    source = ["-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{width}x{height}", "-r", f"{fps:g}", "-i", "pipe:0"]
    h264 = ["-an", "-vf", BT709, "-c:v", "libx264", "-preset", preset, "-crf", str(crf)]
    mp4 = ["-threads", str(threads), "-movflags", "+faststart", "-f", "mp4", str(path)]
    return [exe, *quiet, *source, *h264, *mp4]


class VideoWriter:
    """Stream RGB frames into an MP4 file; use as a context manager.

    Args:
        path: Final file name, ending in ``.mp4`` (the one container written); its folder is made if
            missing, as for every output (:func:`sim.outputs.atomic_path`), and removed again if the
            video fails.
        width: Frame width [px], even.
        height: Frame height [px], even.
        fps: Frames per second.
        overwrite: Replace an existing file (else :class:`OutputExistsError` before anything runs); True or
            False (anything else is a ConfigError).
        crf: x264 constant rate factor (lower is better quality, 0-51).
        preset: x264 preset (see :data:`PRESETS`).
        threads: Encoder threads (1 leaves the other core to the renderer on a two-core machine).
        depth: Frames that may wait for the encoder before :meth:`frame_buffer` blocks.

    Example::

        with VideoWriter("out.mp4", 640, 480, 30) as w:
            for frame in frames:
                w.write(frame)
    """

    def __init__(
        self,
        path: str | Path,
        width: int,
        height: int,
        fps: float,
        *,
        overwrite: bool = False,
        crf: int = 23,
        preset: str = "superfast",
        threads: int = 1,
        depth: int = 6,
    ) -> None:
        check_video_name(path)
        if width % 2 or height % 2 or width < 16 or height < 16:
            raise ConfigError(f"H.264 in yuv420p needs an even frame size of at least 16x16, got {width}x{height}")
        check_number("frame rate", fps, above=0.0, unit="frames/s")
        if preset not in PRESETS:
            raise ConfigError(f"unknown x264 preset {preset!r}: choose one of {', '.join(PRESETS)}")
        if not 0 <= crf <= 51:
            raise ConfigError(f"crf must be in [0, 51], got {crf}")
        self.path = Path(path)
        self.width, self.height, self.fps = width, height, fps
        self.overwrite = check_flag("overwrite", overwrite)
        self._crf, self._preset, self._threads = crf, preset, threads
        self._free: queue.Queue[Frame] = queue.Queue()
        for _ in range(depth + 2):
            self._free.put(np.empty((height, width, 3), dtype=np.uint8))
        self._todo: queue.Queue[Frame | None] = queue.Queue(maxsize=depth)
        self._stack = contextlib.ExitStack()
        self._proc: subprocess.Popen[bytes] | None = None
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self.frames_written = 0

    # ---- lifecycle ------------------------------------------------------------------------------
    def __enter__(self) -> VideoWriter:
        exe = ffmpeg_exe()
        # An interrupt (Ctrl-C, SIGTERM) before this returns never reaches __exit__, so this method
        # removes the temporary file (and stops ffmpeg) itself, from the moment the file exists.
        try:
            tmp = self._stack.enter_context(atomic_path(self.path, overwrite=self.overwrite))
            size = (self.width, self.height)
            cmd = ffmpeg_command(exe, tmp, *size, self.fps, crf=self._crf, preset=self._preset, threads=self._threads)
            try:  # an interrupt while ffmpeg starts waits until it is ours to stop: raised inside Popen, it
                # left ffmpeg running unknown to us, and ffmpeg re-created the file once it had been removed
                with signals_held():
                    self._proc = subprocess.Popen(
                        cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
                    )
            except OSError as exc:
                raise DependencyError(f"cannot start ffmpeg ({exc}); reinstall: pip install imageio-ffmpeg") from exc
            self._thread = threading.Thread(target=self._pump, name="mp4-writer", daemon=True)
            self._thread.start()
        except BaseException as err:
            self._abort()
            self._stack.__exit__(type(err), err, err.__traceback__)
            raise
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        try:
            if exc_type is None:
                self._finish()
            else:
                self._abort()
        except BaseException as err:
            self._abort()
            self._stack.__exit__(type(err), err, err.__traceback__)
            raise
        if exc_type is None:
            self._stack.close()  # renames the finished file onto the target
        else:
            self._stack.__exit__(exc_type, exc, tb)  # removes the temporary file

    def _pump(self) -> None:
        assert self._proc is not None and self._proc.stdin is not None
        stdin = self._proc.stdin
        while True:
            frame = self._todo.get()
            if frame is None:
                return
            try:
                if self._error is None:
                    stdin.write(frame.data.cast("B"))
                    self.frames_written += 1
            except (BrokenPipeError, OSError, ValueError) as exc:
                self._error = exc
            finally:
                self._free.put(frame)

    def _finish(self) -> None:
        """Send the end of the frames, wait for ffmpeg and close its pipes, whatever happens (an open one is a
        ResourceWarning, its file descriptor held until the garbage collector runs).

        Raises:
            OSError: ffmpeg reported a failed write (a full disk, :func:`write_failure`).
            SimulationError: ffmpeg failed otherwise, or the frames' pipe broke.
        """
        assert self._proc is not None and self._thread is not None
        proc = self._proc
        try:
            self._todo.put(None)
            self._thread.join()
            with contextlib.suppress(BrokenPipeError, OSError):
                if proc.stdin is not None:
                    proc.stdin.close()
            err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
        except BaseException:  # an interrupt: ffmpeg is stopped first (a pipe it still fills could block a close)
            self._abort()
            raise
        self._close_pipes()
        rc = proc.wait()
        if rc != 0 or self._error is not None:
            failure = write_failure(err, self.path)
            if failure is not None:
                raise failure
            raise SimulationError(
                f"ffmpeg failed writing {shown(self.path)} (exit {rc}): {err.strip() or self._error}; "
                "check the frame size and free disk space"
            )

    def _abort(self) -> None:
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
        if self._thread is not None and self._thread.is_alive():
            self._error = self._error or RuntimeError("aborted")
            with contextlib.suppress(queue.Full):
                self._todo.put(None, timeout=5.0)
            self._thread.join(timeout=5.0)
        if self._proc is not None:
            with contextlib.suppress(Exception):
                self._proc.wait(timeout=5.0)
        self._close_pipes()

    def _close_pipes(self) -> None:
        """Close ffmpeg's stdin and stderr pipes (again: harmless), each whether or not the other closed."""
        if self._proc is None:
            return
        for stream in (self._proc.stdin, self._proc.stderr):
            if stream is not None:
                with contextlib.suppress(Exception):
                    stream.close()

    # ---- frames ---------------------------------------------------------------------------------
    def frame_buffer(self) -> Frame:
        """A free (height, width, 3) uint8 buffer for the next frame (blocks while the encoder is behind)."""
        self._check()
        return self._free.get()

    def submit(self, frame: Frame) -> None:
        """Queue a frame obtained from :meth:`frame_buffer` (it returns to the pool once encoded)."""
        self._check()
        self._todo.put(frame)

    def write(self, frame: NDArray[np.uint8]) -> None:
        """Copy one (height, width, 3) uint8 RGB frame in and queue it."""
        if frame.shape != (self.height, self.width, 3) or frame.dtype != np.uint8:
            raise ConfigError(f"frame must be ({self.height}, {self.width}, 3) uint8, got {frame.shape} {frame.dtype}")
        buf = self.frame_buffer()
        buf[...] = frame
        self.submit(buf)

    def _check(self) -> None:
        if self._proc is None:
            raise RuntimeError("VideoWriter is not open: use it in a with-statement")
        if self._error is not None:
            said = self._said()
            failure = write_failure(said, self.path)  # a full disk: the write failed, not the simulation
            if failure is not None:
                raise failure from self._error
            last = said.splitlines()[-1].strip() if said else ""
            why = f"{last} (ffmpeg's last words); check free disk space" if last else str(self._error)
            raise SimulationError(f"ffmpeg stopped while writing {shown(self.path)}: {why}")

    def _said(self) -> str:
        """Why ffmpeg stopped taking frames: its own error output once it has exited (a full disk says "No space
        left on device" there, not always on its last line), or "" (then the error the frames' pipe gave says
        it)."""
        proc = self._proc
        if proc is not None and proc.stderr is not None:
            with contextlib.suppress(subprocess.TimeoutExpired, OSError, ValueError):
                proc.wait(timeout=2.0)
                return proc.stderr.read().decode(errors="replace").strip()
        return ""
