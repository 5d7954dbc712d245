"""The balancing EduMIP's model: the EduMIP's wheels, motors and sensors, no skids, cited body numbers."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from control.design.balance_profile import load_balance_profile
from planning.core.geometry import Pose2D
from planning.core.robot import ROBOTS, load_robot
from sim.physics.model import build_model, set_pose
from sim.physics.sensors import load_sensor_profile

NAME = "edumip-balancing"


@pytest.fixture(scope="module")
def models() -> tuple[mujoco.MjModel, mujoco.MjModel]:
    return build_model(load_robot(NAME)).model, build_model(load_robot("edumip")).model


def test_registered_and_loaded() -> None:
    spec = load_robot(NAME)
    assert NAME in ROBOTS
    assert spec.name == NAME and spec.scene.is_file()
    assert spec.wheel_radius == pytest.approx(0.034) and spec.track_width == pytest.approx(0.10)
    assert spec.mass == pytest.approx(0.180 + 2 * 0.027)  # [B]: body and two wheels


def test_body_numbers_cited(models: tuple[mujoco.MjModel, mujoco.MjModel]) -> None:
    m, _ = models
    base = m.body("base").id
    assert m.body_mass[base] == pytest.approx(0.180)
    np.testing.assert_allclose(m.body_ipos[base], [0.0, 0.0, 0.0477], atol=1e-12)  # on the axis, 47.7 mm up
    assert m.body_inertia[base, 1] == pytest.approx(2.63e-4)
    assert m.body_mass[m.body("wheel_left").id] == pytest.approx(0.027)
    assert not [m.geom(g).name for g in range(m.ngeom) if "skid" in m.geom(g).name]


def test_same_wheels_motors_sensors(models: tuple[mujoco.MjModel, mujoco.MjModel]) -> None:
    m, skid = models
    for a in ("wheel_left_motor", "wheel_right_motor"):
        np.testing.assert_array_equal(m.actuator(a).gainprm, skid.actuator(a).gainprm)
        np.testing.assert_array_equal(m.actuator(a).biasprm, skid.actuator(a).biasprm)
        np.testing.assert_array_equal(m.actuator(a).ctrlrange, skid.actuator(a).ctrlrange)
    names = {m.sensor(i).name for i in range(m.nsensor)}
    assert names == {skid.sensor(i).name for i in range(skid.nsensor)}
    np.testing.assert_array_equal(m.dof_armature, skid.dof_armature)
    assert load_sensor_profile(NAME) == load_sensor_profile("edumip")


def test_timestep_gives_whole_balance_and_control_periods(models: tuple[mujoco.MjModel, mujoco.MjModel]) -> None:
    m, _ = models
    rate = load_balance_profile(NAME).rate
    assert rate == 200.0
    for hz in (rate, 50.0):
        steps = 1.0 / (hz * m.opt.timestep)
        assert abs(steps - round(steps)) < 1e-9


def test_fallen_body_rests_on_the_floor(models: tuple[mujoco.MjModel, mujoco.MjModel]) -> None:
    m, _ = models
    d = mujoco.MjData(m)
    set_pose(m, d, Pose2D(0.0, 0.0, 0.0), settle=0.0)
    d.qvel[4] = 0.3  # a nudge forward about the axle; no voltage
    mujoco.mj_step(m, d, nstep=round(3.0 / m.opt.timestep))
    chassis = m.geom("chassis").id
    touching = {int(g) for pair in d.contact.geom[: d.ncon] for g in pair}
    assert chassis in touching
    assert np.linalg.norm(d.qvel) < 1e-3  # at rest
    x, y = d.qpos[4:6]
    up_z = 1.0 - 2.0 * (x * x + y * y)  # the body axis' vertical component
    assert math.degrees(math.acos(up_z)) > 60.0  # lying down
    assert all(w_.number == 0 for w_ in d.warning)
