"""Shared pieces of the rendering tests: a short logged job and the GL gate."""

from __future__ import annotations

import functools

import pytest

from planning.geometry import Pose2D
from planning.references import make_reference
from planning.robot import load_robot
from planning.scenario import load_scenario


@functools.cache
def short_job():  # type: ignore[no-untyped-def]
    """A 0.4 m line (about 3.3 s) tracked closed and open loop in the 'open' scenario."""
    from sim.jobs import run_tracking

    sc = load_scenario("open")
    robot = load_robot(sc.robot)
    traj = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0), length=0.4)
    return run_tracking(sc, robot, traj, source="reference:line")


def require_gl() -> None:
    """Skip (with the reason, naming what to install) only where no OpenGL context can be created."""
    from sim.render import probe_renderer

    reason = probe_renderer()
    if reason is not None:
        pytest.skip(f"no OpenGL backend can load here: {reason}")
