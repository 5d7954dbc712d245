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
    from sim.pipeline.case import Case, PreparedTrajectory
    from sim.pipeline.simulate import track

    sc = load_scenario("open")
    robot = load_robot(sc.robot)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0), length=0.4)
    return track(PreparedTrajectory(Case("open", reference="line"), sc, robot, traj, "reference:line"))


def require_gl() -> None:
    """Skip (with the reason, naming what to install) only where no OpenGL context can be created."""
    from sim.viz.renderer import probe_renderer

    reason = probe_renderer()
    if reason is not None:
        pytest.skip(f"no OpenGL backend can load here: {reason}")
