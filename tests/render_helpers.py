"""Shared pieces of the rendering tests: a short logged job and the GL gate."""

from __future__ import annotations

import functools

import pytest

from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.scenario import load_scenario
from planning.trajectory.references import make_reference


@functools.cache
def short_job():  # type: ignore[no-untyped-def]
    """A 0.4 m line (about 3.3 s) tracked closed and open loop in the 'open' scenario."""
    from sim.pipeline.simulate import run_tracking

    sc = load_scenario("open")
    robot = load_robot(sc.robot)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0), length=0.4)
    return run_tracking(sc, robot, traj, source="reference:line")


def require_gl() -> None:
    """Skip (with the reason, naming what to install) only where no OpenGL context can be created."""
    from sim.viz.renderer import probe_renderer

    reason = probe_renderer()
    if reason is not None:
        pytest.skip(f"no OpenGL backend can load here: {reason}")


def spread_runs(model, *, overlap: bool = False):  # type: ignore[no-untyped-def]
    """The short job's two runs and stand-ins for more, four runs in all, one beside the other to the
    right of the line (below it in the overview, clear of the overlay): the open-loop ghost 0.3 m
    off, an odometry-feedback ghost 0.6 m off and a run of a label the style table does not know
    0.9 m off (0.66 m with ``overlap``: over the odometry ghost's edge)."""
    from sim.tools.bench.render import moved_log

    logs = short_job().logs
    cl = logs["closed_loop"]
    return {
        "closed_loop": cl,
        "open_loop": moved_log(model, logs["open_loop"], (0.0, -0.3)),
        "closed_loop_odometry": moved_log(model, cl, (0.0, -0.6)),
        "wobbly": moved_log(model, cl, (0.0, -0.66 if overlap else -0.9)),
    }
