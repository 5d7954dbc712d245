"""Every MJCF model loads, runs warning-free under random controls, and rolls without slip."""

from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from planning.core.robot import MODELS_DIR, load_robot
from planning.scenario import builtin_scenarios, load_scenario
from sim.physics.model import build_model, set_pose
from sim.physics.runlog import RunLog

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


def _steady_run(name: str, wl: float, wr: float) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, Any]:
    """Command wheel speeds, let a second pass, then sample for half a second: body-frame (vx, vy) of the
    axle centre, yaw rate, and the measured wheel speeds [left, right]."""
    spec = load_robot(name)
    m = mujoco.MjModel.from_xml_path(str(spec.scene))
    d = mujoco.MjData(m)
    d.ctrl[m.actuator("wheel_left_motor").id] = wl
    d.ctrl[m.actuator("wheel_right_motor").id] = wr
    mujoco.mj_step(m, d, nstep=int(1.0 / m.opt.timestep))  # reach steady state
    wheels = [m.jnt_dofadr[m.joint(f"wheel_{side}_joint").id] for side in ("left", "right")]
    body_vel, rates, speeds = [], [], []
    for _ in range(100):
        mujoco.mj_step(m, d, nstep=5)
        body_vel.append(d.sensordata[m.sensor_adr[m.sensor("base_vel").id] :][:2].copy())
        rates.append(d.sensordata[m.sensor_adr[m.sensor("base_gyro").id] + 2])
        speeds.append(d.qvel[wheels].copy())
    assert sum(_warnings(d)) == 0
    return spec, np.array(body_vel), np.array(rates), np.array(speeds), d


#: Wheel speeds [left, right] in rad/s: straight, pivot, arc, reversing arc.
DRIVES = [(4.0, 4.0), (-3.0, 3.0), (2.0, 5.0), (-4.0, -2.5)]


def _assert_unicycle(spec: Any, body_vel: np.ndarray, rates: np.ndarray, wl: float, wr: float) -> None:
    """Mean forward speed r (wl + wr) / 2 and yaw rate r (wr - wl) / track for wheel speeds wl, wr, each
    within 2 % (where the value is zero, 2 % of the rim speed r max(|wl|, |wr|), or of rim / track)."""
    v = spec.wheel_radius * (wl + wr) / 2
    w = spec.wheel_radius * (wr - wl) / spec.track_width
    rim = spec.wheel_radius * max(abs(wl), abs(wr))
    assert body_vel.mean(axis=0)[0] == pytest.approx(v, abs=0.02 * (abs(v) if abs(v) > 1e-3 else rim))
    rim_rate = rim / spec.track_width
    assert np.mean(rates) == pytest.approx(w, abs=0.02 * (abs(w) if abs(w) > 1e-3 else rim_rate))


@pytest.mark.parametrize("name", ["turtlebot3", "edumip"])
@pytest.mark.parametrize(("wl", "wr"), DRIVES)
def test_rolls_without_slip(name: str, wl: float, wr: float) -> None:
    """The axle centre moves as a unicycle driven by the wheels' speeds: body-frame velocity
    (r (wl + wr) / 2, 0) and yaw rate r (wr - wl) / track, each within 2 % (where the value is zero,
    2 % of the rim speed). Means of the vectors, not of magnitudes: the magnitude of a zero velocity
    measures the contact's vibration, not slip. The wheels' own speeds are the servo's output; how far
    they lag the command is the servo's business (next test)."""
    spec, body_vel, rates, speeds, _ = _steady_run(name, wl, wr)
    wl_m, wr_m = speeds.mean(axis=0)
    _assert_unicycle(spec, body_vel, rates, wl_m, wr_m)
    assert abs(body_vel.mean(axis=0)[1]) <= 0.02 * spec.wheel_radius * max(abs(wl_m), abs(wr_m))  # lateral


@pytest.mark.parametrize("name", ["turtlebot3", "edumip"])
@pytest.mark.parametrize(("wl", "wr"), DRIVES)
def test_commanded_wheel_speeds_give_the_body_speed_and_yaw_rate(name: str, wl: float, wr: float) -> None:
    """The commanded wheel speeds give the body speed r (wl + wr) / 2 and the yaw rate
    r (wr - wl) / track within 2 % (of the rim speed where the value is zero): the servo lags by its
    load (joint damping, tyre scrub in turns) over kv, and the wheels do not slip."""
    spec, body_vel, rates, _, _ = _steady_run(name, wl, wr)
    _assert_unicycle(spec, body_vel, rates, wl, wr)


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


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_wheel_servo_gain_is_below_the_time_step_bound(path: Path) -> None:
    """A velocity servo held at its torque limit is integrated explicitly: one step there changes the
    wheel speed by F dt / I, and unless that is less than the servo's linear band 2 F / kv the wheel
    swings past the command every step and chatters. So kv dt < 2 I, with I read from the compiled
    model (the wheel's joint-space inertia with the armature)."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    inertia = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, inertia)
    for a in range(m.nu):
        name = m.actuator(a).name
        kv = float(m.actuator_gainprm[a, 0])
        assert m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE, name
        assert -float(m.actuator_biasprm[a, 2]) == kv > 0, f"{name} is not a velocity servo"
        dof = m.jnt_dofadr[m.actuator_trnid[a, 0]]
        assert kv * m.opt.timestep < 2 * inertia[dof, dof], f"{name}: kv {kv} too stiff for the time step"


def _chattering_samples(log: RunLog, tol: float = 0.5) -> int:
    """Log intervals where the measured wheel speeds (mean of both ends) differ from the wheel angles'
    mean rate over the interval by more than ``tol`` rad/s: a wheel swinging back and forth within it."""
    rate = np.diff(log.qpos[:, -2:], axis=0) / np.diff(log.t)[:, None]
    mean = 0.5 * (log.wheel_speed[1:] + log.wheel_speed[:-1])
    return int(np.count_nonzero(np.abs(rate - mean).max(axis=1) > tol))


def test_the_default_job_runs_without_wheel_chatter() -> None:
    """The EduMIP on seed 003's map, closed and open loop: the wheels follow their commands smoothly,
    including the stop at the end (with kv = 0.5 the body rocked on its skids with the wheels chattering
    at +-2 rad/s around a zero command, 37 % of the closed-loop samples)."""
    from sim.pipeline.simulate import simulate_plan

    job = simulate_plan(load_scenario("edumip_map"), planner="c-rrt-star", seed=0)
    for name, log in job.logs.items():
        assert _chattering_samples(log) == 0, name
        assert np.abs(log.wheel_speed[-25:]).max() < 0.05, f"{name}: the wheels do not come to rest"
