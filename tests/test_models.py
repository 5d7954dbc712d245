"""Every MJCF model loads, runs warning-free under random controls, and rolls without slip."""

from pathlib import Path

import mujoco
import numpy as np
import pytest

from planning.robot import MODELS_DIR, load_robot
from planning.scenario import builtin_scenarios, load_scenario
from sim.model import build_model, set_pose

SCENES = sorted((MODELS_DIR / "robots").glob("*_scene.xml"))


def _warnings(d: mujoco.MjData) -> list[int]:
    return [int(w.number) for w in d.warning]


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_random_controls_for_a_second_raise_no_warning(path: Path) -> None:
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
    for _ in range(int(1.0 / m.opt.timestep) // 10):
        d.ctrl[:] = rng.uniform(lo, hi)
        mujoco.mj_step(m, d, nstep=10)
    assert sum(_warnings(d)) == 0
    assert np.all(np.isfinite(d.qpos))
    assert d.qpos[2] > 0.0  # still on its wheels, not through the floor


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_every_element_is_named(path: Path) -> None:
    m = mujoco.MjModel.from_xml_path(str(path))
    for kind, count in (("BODY", m.nbody), ("JOINT", m.njnt), ("ACTUATOR", m.nu), ("SENSOR", m.nsensor)):
        for i in range(1 if kind == "BODY" else 0, count):  # body 0 is the world
            assert mujoco.mj_id2name(m, getattr(mujoco.mjtObj, f"mjOBJ_{kind}"), i), f"{kind} {i} unnamed"


@pytest.mark.parametrize("name", ["turtlebot3", "edumip"])
@pytest.mark.parametrize(("wl", "wr"), [(4.0, 4.0), (-3.0, 3.0), (2.0, 5.0), (-4.0, -2.5)])
def test_rolls_without_slip(name: str, wl: float, wr: float) -> None:
    spec = load_robot(name)
    m = mujoco.MjModel.from_xml_path(str(spec.scene))
    d = mujoco.MjData(m)
    d.ctrl[m.actuator("wheel_left_motor").id] = wl
    d.ctrl[m.actuator("wheel_right_motor").id] = wr
    mujoco.mj_step(m, d, nstep=int(1.0 / m.opt.timestep))  # reach steady state
    speeds, rates = [], []
    for _ in range(100):
        mujoco.mj_step(m, d, nstep=5)
        speeds.append(np.hypot(*d.sensordata[m.sensor_adr[m.sensor("base_vel").id] :][:2]))
        rates.append(d.sensordata[m.sensor_adr[m.sensor("base_gyro").id] + 2])
    v_expected = spec.wheel_radius * (wl + wr) / 2
    w_expected = spec.wheel_radius * (wr - wl) / spec.track_width
    # 2 % of the commanded value; where that is zero (turning on the spot), 2 % of the rim speed
    rim = spec.wheel_radius * max(abs(wl), abs(wr))
    assert np.mean(speeds) == pytest.approx(abs(v_expected), rel=0.02, abs=0.02 * rim if v_expected == 0 else 0)
    rim_rate = rim / spec.track_width
    assert np.mean(rates) == pytest.approx(w_expected, rel=0.02, abs=0.02 * rim_rate if w_expected == 0 else 0)
    assert sum(_warnings(d)) == 0


def test_dm_control_builds_a_physics_with_the_pinned_mujoco() -> None:
    from dm_control import mujoco as dm_mujoco

    physics = dm_mujoco.Physics.from_xml_path(str(load_robot("edumip").scene))
    physics.step()
    assert physics.data.time > 0
    assert mujoco.__version__.startswith("3.")


def test_same_seed_same_run_bitwise() -> None:
    spec = load_robot("turtlebot3")
    m = mujoco.MjModel.from_xml_path(str(spec.scene))

    def run() -> np.ndarray:
        d = mujoco.MjData(m)
        rng = np.random.default_rng(42)
        out = []
        for _ in range(100):
            d.ctrl[:] = rng.uniform(m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1])
            mujoco.mj_step(m, d, nstep=5)
            out.append(d.qpos.copy())
        return np.array(out)

    assert run().tobytes() == run().tobytes()


@pytest.mark.parametrize("scenario", builtin_scenarios())
def test_every_builtin_world_composes_and_steps_without_warning(scenario: str) -> None:
    sc = load_scenario(scenario)
    for robot in sc.robots:
        built = build_model(load_robot(robot), sc.world)
        m = built.model
        d = mujoco.MjData(m)
        set_pose(m, d, sc.start)
        rng = np.random.default_rng(1)
        for _ in range(50):
            d.ctrl[:] = rng.uniform(m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1])
            mujoco.mj_step(m, d, nstep=10)
        assert sum(_warnings(d)) == 0, f"{scenario}/{robot}"
        assert len(built.obstacle_geoms) >= len(sc.world.obstacles) + 4  # obstacles (split polygons) + walls
