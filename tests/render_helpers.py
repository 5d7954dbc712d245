"""Shared pieces of the rendering tests: a short logged job and the GL gate."""

from __future__ import annotations

import dataclasses
import functools
from typing import TYPE_CHECKING

import numpy as np
import pytest

from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.scenario import load_scenario
from planning.trajectory.references import make_reference

if TYPE_CHECKING:
    import mujoco

    from sim.physics.runlog import RunLog


@functools.cache
def short_job(localiser: str = "fixes"):  # type: ignore[no-untyped-def]
    """A 0.4 m line (about 3.3 s) tracked closed and open loop in the 'open' scenario, by default on
    synthetic fixes (the drawing is under test, not the localiser: the runs' poses stay those the
    pixel checks were made on); ``localiser="amcl"`` for a run with scans."""
    from sim.pipeline.case import Case, PreparedTrajectory
    from sim.pipeline.runs import RunKind
    from sim.pipeline.simulate import track

    sc = load_scenario("open")
    robot = load_robot(sc.robot)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0), length=0.4)
    case = Case("open", reference="line", localiser=localiser)
    prepared = PreparedTrajectory(case, sc, robot, traj, "reference:line")
    return track(prepared, (RunKind.CLOSED_LOOP, RunKind.OPEN_LOOP))


def require_gl() -> None:
    """Skip (with the reason, naming what to install) only where no OpenGL context can be created."""
    from sim.viz.renderer import probe_renderer

    reason = probe_renderer()
    if reason is not None:
        pytest.skip(f"no OpenGL backend can load here: {reason}")


def spread_runs(model, *, overlap: bool = False, spacing: float = 0.3):  # type: ignore[no-untyped-def]
    """The short job's two runs and stand-ins for more, four runs in all, one beside the other to the
    right of the line (below it in the overview, clear of the overlay): the open-loop ghost 0.3 m
    off, an odometry-feedback ghost 0.6 m off and a run of a label the style table does not know
    0.9 m off (0.66 m with ``overlap``: over the odometry ghost's edge)."""

    logs = short_job().logs
    cl = logs["closed_loop"]
    return {
        "closed_loop": cl,
        "open_loop": moved_log(model, logs["open_loop"], (0.0, -spacing)),
        "closed_loop_odometry": moved_log(model, cl, (0.0, -2 * spacing)),
        "wobbly": moved_log(model, cl, (0.0, -2.2 * spacing if overlap else -3 * spacing)),
    }


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
        raise ValueError("moved_log needs a model whose robot has a free joint")
    adr = int(model.jnt_qposadr[free])
    qpos, pose = log.qpos.copy(), log.pose.copy()
    qpos[:, adr : adr + 2] += offset
    pose[:, :2] += offset
    return dataclasses.replace(log, qpos=qpos, pose=pose)


def scenario_replay(  # type: ignore[no-untyped-def]
    name: str, robot: str = "turtlebot3", size: tuple[int, int] = (640, 480), spacing: float = 0.3, **settings: object
):
    """The short job's runs moved to a scenario's start, replayed in that scenario's world with
    ``robot``: (model, replay, world). Four runs (:func:`spread_runs`: ghosts ``spacing``, twice and
    three times that [m] to the right of the closed loop)."""
    from planning.core.robot import load_robot
    from sim.physics.simulator import Simulator
    from sim.viz.replay import RenderSettings, Replay

    sc = load_scenario(name)
    model = Simulator(load_robot(robot), sc.world).model
    start = (sc.start.x, sc.start.y)
    logs = {k: moved_log(model, log, start) for k, log in spread_runs(model, spacing=spacing).items()}
    ref = short_job().trajectory
    traj = dataclasses.replace(ref, pose=ref.pose + np.array([*start, 0.0]), _cache={})
    replay = Replay(model, traj, logs, RenderSettings(width=size[0], height=size[1], **settings))  # type: ignore[arg-type]
    return model, replay, sc.world
