"""The whole video pipeline against a bare ``mujoco.Renderer`` loop (``nhsim bench render``).

Both loops draw the same model (the default scenario's world and robot) at the same size, with the
same camera and render flags, for the same number of frames, in one process with the one renderer:

- baseline: ``update_scene`` + ``render`` (into a preallocated frame) and nothing else;
- pipeline: a new :class:`sim.viz.replay.Replay` of the job's logs (its set-up counts), kinematics
  of the runs, the ghosts, the reference path and trails, the close-up inset, the text, and H.264
  encoding into an MP4 through the writer thread (to a temporary file that is deleted). With the
  fixed overview camera in the fast look the pipeline draws the world once per video and only the
  robots each frame (:mod:`sim.viz.compose`), the close-up likewise; the chase camera and the high
  look draw the whole world picture every frame (the close-up stays composited, in the fast look).

The two loops alternate for ``--repeats`` rounds and the best round of each counts, so load from
other processes hits both alike. Targets: ratio >= 0.9, and >= 30 frames/s for the pipeline at
640x480 in the default (fast) look.

CPU time is counted too (``resource``: this process, its rasteriser threads included, and the
finished ffmpeg child), least of the rounds: where the rasteriser already keeps every core busy, the
pipeline's frame rate can be at most the bare loop's times (bare CPU) / (pipeline CPU), whatever the
scheduling, so that CPU ratio is what bounds the wall ratio on a machine with few cores, and it is
hardly moved by other processes' load.
"""

from __future__ import annotations

import resource
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

TARGET_RATIO = 0.9
TARGET_FPS = 30.0


@dataclass(frozen=True)
class RenderBench:
    """One measurement.

    Attributes:
        width: Frame width [px].
        height: Frame height [px].
        quality: Render look.
        camera: Camera.
        frames: Frames per loop.
        repeats: Alternating rounds (the best of each loop counts).
        bare_s: Best wall time of the bare loop [s].
        pipeline_s: Best wall time of the pipeline [s].
        composited: The pipeline drew the world once and composited the robots.
        bare_cpu_s: Least CPU time of the bare loop [s].
        pipeline_cpu_s: Least CPU time of the pipeline, the encoder's included [s].
        encoder_cpu_s: The encoder's (ffmpeg's) CPU time in that round [s].
    """

    width: int
    height: int
    quality: str
    camera: str
    frames: int
    repeats: int
    bare_s: float
    pipeline_s: float
    composited: bool
    bare_cpu_s: float = float("nan")
    pipeline_cpu_s: float = float("nan")
    encoder_cpu_s: float = float("nan")

    @property
    def cpu_ratio(self) -> float:
        """Bare CPU time over the pipeline's: the frame-rate ratio's bound when the cores are saturated."""
        return self.bare_cpu_s / self.pipeline_cpu_s

    @property
    def bare_fps(self) -> float:
        """Frames per second of the bare loop."""
        return self.frames / self.bare_s

    @property
    def pipeline_fps(self) -> float:
        """Frames per second of the pipeline."""
        return self.frames / self.pipeline_s

    @property
    def ratio(self) -> float:
        """Pipeline over bare frame rate."""
        return self.pipeline_fps / self.bare_fps

    @property
    def passed(self) -> bool:
        """The ratio meets its target, and the frame rate too at 640x480 in the fast look."""
        fps_ok = self.pipeline_fps >= TARGET_FPS or (self.width, self.height, self.quality) != (640, 480, "fast")
        return self.ratio >= TARGET_RATIO and fps_ok


def measure(size: str, camera: str, quality: str, frames: int, repeats: int) -> RenderBench:
    """Time both loops on the default reference job's logs (call after :func:`sim.viz.gl.configure`).

    Raises:
        ConfigError: ``frames`` < 100, ``repeats`` < 1, or a bad size.
    """
    import mujoco
    import numpy as np

    from planning.core.checks import check_number
    from sim.pipeline.runs import RunKind
    from sim.pipeline.simulate import simulate_reference
    from sim.viz.replay import RenderSettings, Replay, SceneRenderer, parse_size

    check_number(
        "--frames",
        frames,
        integer=True,
        at_least=100,
        fix="the pipeline's set-up (a new replay, the encoder started) counts in its time, as in a job's video, "
        "so fewer frames measure mostly that (640x480: ratio 0.60 at 30 frames, 0.77 at 100 and 0.76 at 300)",
    )
    check_number("--repeats", repeats, integer=True, at_least=1)
    w, h = parse_size(size)
    settings = RenderSettings(width=w, height=h, camera=camera, quality=quality)
    job = simulate_reference("open")
    model = job.model
    replay = Replay(model, job.trajectory, job.logs, settings)
    n = min(frames, replay.n_frames)
    with SceneRenderer(model, w, h, quality=quality, max_geom=replay.required_geoms) as renderer:
        data = mujoco.MjData(model)
        data.qpos[:] = job.logs[RunKind.CLOSED_LOOP].qpos[0]
        mujoco.mj_forward(model, data)
        replay.render_frame(renderer, 0)  # sets the camera of frame 0; warms the context up
        view = replay.camera
        frame = np.empty((h, w, 3), dtype=np.uint8)

        def bare() -> tuple[float, float]:
            t0, c0 = time.perf_counter(), _cpu(resource.RUSAGE_SELF)
            for _ in range(n):
                renderer.renderer.update_scene(data, camera=view)
                renderer.renderer.render(out=frame)
            return time.perf_counter() - t0, _cpu(resource.RUSAGE_SELF) - c0

        t_bare, t_pipe = [], []
        for _ in range(repeats):
            t_bare.append(bare())
            t_pipe.append(_pipeline(model, job, settings, renderer, n))
        composited = bool(replay.composited(renderer))
    least = min(t_pipe, key=lambda t: t[1])
    walls = (min(t[0] for t in t_bare), min(t[0] for t in t_pipe))
    cpus = (min(t[1] for t in t_bare), least[1], least[2])
    return RenderBench(w, h, quality, camera, n, repeats, *walls, composited, *cpus)


def _cpu(who: int) -> float:
    """User plus system CPU time [s] of this process (``RUSAGE_SELF``) or its finished children."""
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def _pipeline(model: Any, job: Any, settings: Any, renderer: Any, n: int) -> tuple[float, float, float]:
    """Wall time, CPU time (the encoder's included) and the encoder's CPU time [s] of a new replay (its
    set-up counts) drawing and encoding ``n`` frames to a deleted MP4, in a temporary folder removed however
    the pipeline ends (an interrupt, an error: ``bench`` leaves nothing behind)."""
    from planning.signals import signals_held
    from sim.viz.replay import Replay
    from sim.viz.video import VideoWriter

    with signals_held():  # an interrupt landing as the folder is made waits until it is named
        tmpdir = Path(tempfile.mkdtemp(prefix="nhsim-bench-"))
    try:
        out = tmpdir / "bench.mp4"
        t0, c0, e0 = time.perf_counter(), _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_CHILDREN)
        rp = Replay(model, job.trajectory, job.logs, settings)
        with VideoWriter(out, settings.width, settings.height, settings.fps, overwrite=True) as writer:
            for k in range(n):
                buf = writer.frame_buffer()
                rp.render_frame(renderer, k, buf)
                writer.submit(buf)
        dt, enc = time.perf_counter() - t0, _cpu(resource.RUSAGE_CHILDREN) - e0  # ffmpeg is reaped on close
        cpu = _cpu(resource.RUSAGE_SELF) - c0 + enc
    finally:
        with signals_held():  # removed whole: an interrupt waits until it is gone
            shutil.rmtree(tmpdir, ignore_errors=True)
    return dt, cpu, enc
