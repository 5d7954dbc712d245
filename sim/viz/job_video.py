"""A job's runs as one MP4: the library's way to write a video (the command line adds a progress bar).

``write_video(job, "renders/run.mp4")`` replays every run of a job (its logs, drawn from its robot
in its world) through :class:`sim.viz.replay.Replay` into an H.264 MP4, written atomically.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol

import mujoco

from planning.core.robot import RobotSpec
from planning.errors import ConfigError
from planning.scenario import Scenario
from planning.trajectory.trajectory import Trajectory
from sim.physics.runlog import RunLog
from sim.viz.renderer import SceneRenderer
from sim.viz.replay import RenderSettings, Replay, render_frames
from sim.viz.video import VideoWriter


class RecordedJob(Protocol):
    """What a video needs of a job (:class:`sim.pipeline.simulate.JobResult` has it): the robot, the
    world, the reference, the logs, and the compiled model the runs stepped."""

    @property
    def robot(self) -> RobotSpec: ...

    @property
    def scenario(self) -> Scenario: ...

    @property
    def trajectory(self) -> Trajectory: ...

    @property
    def logs(self) -> Mapping[str, RunLog]: ...

    @property
    def model(self) -> mujoco.MjModel: ...


def write_video(
    job: RecordedJob,
    path: str | Path,
    settings: RenderSettings | None = None,
    *,
    model: mujoco.MjModel | None = None,
    overwrite: bool = False,
    progress: Callable[[int], Any] | None = None,
) -> dict[str, Any]:
    """Render a job's runs into an MP4 (the main run solid, the others as ghosts).

    Args:
        job: The job (robot, scenario, trajectory and logs).
        path: The MP4 to write, its name ending in ``.mp4``; an existing file is replaced only with
            ``overwrite``; a missing folder is made, as for every output of nhsim
            (:func:`sim.outputs.atomic_path`), and removed again if the render fails.
        settings: Size, frame rate, camera and look (default: 640x480, 30 frames/s, overview, fast).
        model: The model to draw (default: the job's, the model its runs stepped).
        overwrite: Replace an existing file.
        progress: Called with the number of frames done since the last call.

    Returns:
        Facts for the run record: frames, fps, size, camera, quality, the close-up's magnification
            over the world picture, GL backend, seconds taken.

    Raises:
        DependencyError: No OpenGL backend can draw here (the message says what to install).
        FileExistsError: ``path`` exists and ``overwrite`` is false.
        ConfigError: ``overwrite`` is not True or False (``"no"`` is refused, not read as true),
            ``path`` is not a file name (text or a path) ending in .mp4, ``job`` is not a job (it lacks the
            trajectory, logs or model), ``settings`` not a RenderSettings or ``model`` not an MjModel (all
            before anything is drawn).
    """
    _check_arguments(job, path, settings, model)
    s = settings or RenderSettings()
    writer = VideoWriter(Path(path), s.width, s.height, s.fps, overwrite=overwrite)  # checks its arguments
    model = model if model is not None else job.model
    replay = Replay(model, job.trajectory, dict(job.logs), s)
    t0 = time.perf_counter()
    with SceneRenderer(model, s.width, s.height, quality=s.quality, max_geom=replay.required_geoms) as renderer:
        with writer:
            n = render_frames(replay, renderer, writer, progress=progress)
        backend = renderer.backend
    return {
        "frames": n,
        "fps": s.fps,
        "size": [s.width, s.height],
        "camera": s.camera,
        "quality": s.quality,
        "inset_magnification": round(replay.magnification, 3),
        "gl_backend": backend,
        "render_seconds": round(time.perf_counter() - t0, 3),
    }


def _check_arguments(job: object, path: object, settings: object, model: object) -> None:
    """Refuse what :func:`write_video` cannot draw or write to, naming the argument (they were an
    AttributeError or pathlib's TypeError)."""
    needs = ("trajectory", "logs") + (("model",) if model is None else ())
    if not all(hasattr(job, name) for name in needs):
        raise ConfigError(
            f"write_video: job must be a simulated job (what simulate_plan, simulate_reference or simulate "
            f"returns), got {job!r:.80}; e.g. job = simulate_plan('edumip_map', planner='c-rrt-star'), then "
            "write_video(job, 'renders/run.mp4')"
        )
    if not isinstance(path, str | os.PathLike):
        raise ConfigError(
            f"write_video: path must be a file name ending in .mp4 (text or a pathlib.Path), got {path!r:.80}; "
            "e.g. 'renders/run.mp4'"
        )
    if settings is not None and not isinstance(settings, RenderSettings):
        raise ConfigError(
            f"write_video: settings must be a RenderSettings or None (the defaults), got {settings!r:.80}; "
            "e.g. RenderSettings(width=640, height=480, fps=30)"
        )
    if model is not None and not isinstance(model, mujoco.MjModel):
        raise ConfigError(f"write_video: model must be a mujoco.MjModel or None (the job's), got {model!r:.80}")
