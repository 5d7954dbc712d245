"""``nhsim bench render``: the whole video pipeline against a bare ``mujoco.Renderer`` loop.

Both loops draw the same model (the default scenario's world and robot) at the same size, with the
same camera and render flags, for the same number of frames, in one process with the one renderer:

- baseline: ``update_scene`` + ``render`` (into a preallocated frame) and nothing else;
- pipeline: a new :class:`sim.viz.replay.Replay` of three runs (its set-up counts): the job's
  closed-loop and open-loop logs and, while the job logs only those two, a stand-in third run (the
  closed-loop log moved sideways, labelled ``closed_loop_odometry``: the cost of a ghost does not
  depend on its path); kinematics of every run, the two ghosts, the reference path and trails, the
  overlay, and H.264 encoding into an MP4 through the writer thread (to a temporary file that is
  deleted). With the fixed overview camera in the fast look the pipeline draws the world once per
  video and only the robots each frame (:mod:`sim.viz.compose`); the chase camera and the high look
  draw the whole scene every frame.

The two loops alternate for ``--repeats`` rounds and the best round of each counts, so load from
other processes hits both alike. Targets: ratio >= 0.9, and >= 30 frames/s for the pipeline at
640x480 in the default (fast) look.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from planning.errors import ConfigError

if TYPE_CHECKING:
    import mujoco

    from sim.physics.runlog import RunLog

TARGET_RATIO = 0.9
TARGET_FPS = 30.0

#: Runs the pipeline replays (the main run and two ghosts).
RUNS = 3
#: Sideways offset of the stand-in third run [m].
STAND_IN_OFFSET = 0.25


def moved_log(model: mujoco.MjModel, log: RunLog, offset: tuple[float, float]) -> RunLog:
    """A copy of a run's log with the robot moved by ``offset`` (dx, dy) [m] in every sample (a
    stand-in run for benchmarks and tests: the cost and look of a ghost do not depend on its path).

    Args:
        model: The runs' model; the robot's root is the body "base" (else the first free joint's).
        log: The log to copy.
        offset: (dx, dy) [m].
    """
    import mujoco

    base = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "base")
    joints = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    free = next((j for j in joints if model.jnt_bodyid[j] == base), joints[0] if joints else None)
    if free is None:
        raise ConfigError("moved_log needs a model whose robot has a free joint")
    adr = int(model.jnt_qposadr[free])
    qpos, pose = log.qpos.copy(), log.pose.copy()
    qpos[:, adr : adr + 2] += offset
    pose[:, :2] += offset
    return dataclasses.replace(log, qpos=qpos, pose=pose)


def bench_logs(model: mujoco.MjModel, logs: Mapping[str, RunLog]) -> dict[str, RunLog]:
    """The job's logs, completed to :data:`RUNS` runs with the closed-loop log moved sideways by
    :data:`STAND_IN_OFFSET` (labelled ``closed_loop_odometry``) while the job logs fewer."""
    out = dict(logs)
    if len(out) < RUNS and "closed_loop_odometry" not in out:
        out["closed_loop_odometry"] = moved_log(model, out["closed_loop"], (0.0, STAND_IN_OFFSET))
    return out


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--size", default="640x480", metavar="WxH", help="frame size (default: 640x480)")
    p.add_argument("--quality", choices=["fast", "high"], default="fast", help="render look (default: fast)")
    p.add_argument("--camera", choices=["overview", "chase"], default="overview", help="camera (default: overview)")
    p.add_argument("--frames", type=int, default=300, metavar="N", help="frames per loop (default: 300)")
    p.add_argument("--repeats", type=int, default=3, metavar="N", help="alternating rounds, best counts (default: 3)")
    p.add_argument("--gl", choices=["osmesa", "egl", "glfw"], default=None, help="OpenGL backend")


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    from sim.viz import gl

    backend = gl.configure(args.gl)
    import mujoco
    import numpy as np

    from sim.physics.simulator import Simulator
    from sim.pipeline.simulate import simulate_reference
    from sim.viz.replay import RenderSettings, Replay, SceneRenderer, parse_size
    from sim.viz.video import VideoWriter

    if args.frames < 10 or args.repeats < 1:
        raise ConfigError("--frames must be >= 10 and --repeats >= 1")
    w, h = parse_size(args.size)
    settings = RenderSettings(width=w, height=h, camera=args.camera, quality=args.quality)
    job = simulate_reference("open")
    model = Simulator(job.robot, job.scenario.world).model
    logs = bench_logs(model, job.logs)
    replay = Replay(model, job.trajectory, logs, settings)
    n = min(args.frames, replay.n_frames)
    tmpdir = Path(tempfile.mkdtemp(prefix="nhsim-bench-"))

    with SceneRenderer(model, w, h, quality=args.quality, max_geom=replay.required_geoms) as renderer:
        data = mujoco.MjData(model)
        data.qpos[:] = job.logs["closed_loop"].qpos[0]
        mujoco.mj_forward(model, data)
        replay.render_frame(renderer, 0)  # sets the camera of frame 0; warms the context up
        camera = replay.camera

        frame = np.empty((h, w, 3), dtype=np.uint8)

        def bare() -> float:
            t0 = time.perf_counter()
            for _ in range(n):
                renderer.renderer.update_scene(data, camera=camera)
                renderer.renderer.render(out=frame)
            return time.perf_counter() - t0

        def pipeline() -> float:
            out = tmpdir / "bench.mp4"
            t0 = time.perf_counter()
            # a new replay each round: its set-up (framing, trails, the fixed view's world layer) counts
            rp = Replay(model, job.trajectory, logs, settings)
            with VideoWriter(out, w, h, settings.fps, overwrite=True) as writer:
                for k in range(n):
                    buf = writer.frame_buffer()
                    rp.render_frame(renderer, k, buf)
                    writer.submit(buf)
            dt = time.perf_counter() - t0
            out.unlink()
            return dt

        t_bare, t_pipe = [], []
        for _ in range(args.repeats):
            t_bare.append(bare())
            t_pipe.append(pipeline())
    tmpdir.rmdir()
    fps_bare = n / min(t_bare)
    fps_pipe = n / min(t_pipe)
    ratio = fps_pipe / fps_bare
    runs = f"{len(logs)} runs ({', '.join(logs)})"
    print(f"{w}x{h}, {args.quality} look, {args.camera} camera, GL {backend}, {n} frames, best of {args.repeats}")
    print(f"replayed                 {runs}")
    print(f"bare Renderer loop       {fps_bare:>8.1f} frames/s   (update_scene + render)")
    how = "world drawn once, robots composited" if replay.composited(renderer) else "full scene every frame"
    print(f"video pipeline           {fps_pipe:>8.1f} frames/s   (replay, ghosts, lines, overlay, H.264; {how})")
    print(f"ratio                    {ratio:>8.3f}            (target >= {TARGET_RATIO})")
    fps_ok = fps_pipe >= TARGET_FPS or (w, h, args.quality) != (640, 480, "fast")
    print(f"pipeline frame rate      {fps_pipe:>8.1f} frames/s   (target >= {TARGET_FPS:g} at 640x480, fast look)")
    return 0 if ratio >= TARGET_RATIO and fps_ok else 1
