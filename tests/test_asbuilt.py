"""As-built variation: the draw, its statistics, the exact model edits and their physical effect."""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest
from scipy.stats import norm

from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.errors import ConfigError, ModelError
from sim.physics.asbuilt import CLIP_SIGMAS, DEFAULT_BUILD_SEED, TOLERANCES, AsBuilt
from sim.physics.model import build_model, set_pose

ROBOTS = ("turtlebot3", "edumip")
SKEWED = AsBuilt(
    left_radius_scale=1.01, right_radius_scale=0.98, track_change=0.004, tyre_friction_scale=0.8,
    base_mass_scale=1.2, com_offset_x=0.005, com_offset_y=-0.003,
)  # fmt: skip


@pytest.fixture(scope="module", params=ROBOTS)
def nominal(request: pytest.FixtureRequest) -> tuple[str, mujoco.MjModel]:
    return request.param, build_model(load_robot(request.param)).model


def _arrays(model: mujoco.MjModel) -> dict[str, bytes]:
    out = {}
    for name in dir(model):
        value = getattr(model, name, None)
        if isinstance(value, np.ndarray):
            out[name] = value.tobytes()
    return out


def test_nominal_build_is_an_exact_copy(nominal: tuple[str, mujoco.MjModel]) -> None:
    model = nominal[1]
    before = _arrays(model)
    copy = AsBuilt.nominal().apply_to_model(model)
    assert copy is not model and AsBuilt.nominal().is_nominal and not SKEWED.is_nominal
    assert _arrays(copy) == before
    SKEWED.apply_to_model(model)
    assert _arrays(model) == before  # the input is never edited


def test_model_edits_are_exact(nominal: tuple[str, mujoco.MjModel]) -> None:
    m0 = nominal[1]
    m = SKEWED.apply_to_model(m0)
    base = m0.body("base").id
    rises = []
    for side, scale, sign in (("left", 1.01, 1.0), ("right", 0.98, -1.0)):
        wheel, tyre, visual = (
            m0.body(f"wheel_{side}").id,
            m0.geom(f"wheel_{side}_geom").id,
            m0.geom(f"wheel_{side}_tyre").id,
        )
        for g in (tyre, visual):
            r, half = m0.geom_size[g, 0] * scale, m0.geom_size[g, 1]
            assert m.geom_size[g, 0] == r and m.geom_rbound[g] == math.sqrt(r * r + half * half)
            assert m.geom_aabb[g, 3:].tolist() == [r, r, half]
        assert m.body_pos[wheel, 1] == m0.body_pos[wheel, 1] + sign * 0.002  # half the 4 mm track change
        assert m.geom_friction[tyre, 0] == m0.geom_friction[tyre, 0] * 0.8
        assert m.geom_friction[tyre, 1:].tolist() == m0.geom_friction[tyre, 1:].tolist()
        # the axle centre sits at its own radius above the floor with the base level
        assert m.body_pos[base, 2] + m.body_pos[wheel, 2] == pytest.approx(m0.geom_size[tyre, 0] * scale, abs=1e-15)
        rises.append(m0.geom_size[tyre, 0] * (scale - 1.0))
    assert m.body_pos[base, 2] == pytest.approx(m0.body_pos[base, 2] + sum(rises) / 2, abs=1e-15)
    own = m0.geom_bodyid == base
    assert np.allclose(m.body_pos[base, 2] + m.geom_pos[own, 2], m0.body_pos[base, 2] + m0.geom_pos[own, 2], atol=1e-15)
    others = [g for g in range(m0.ngeom) if m0.geom(g).name not in ("wheel_left_geom", "wheel_right_geom")]
    assert np.array_equal(m.geom_friction[others], m0.geom_friction[others])
    assert m.body_mass[base] == m0.body_mass[base] * 1.2
    assert np.array_equal(m.body_inertia[base], m0.body_inertia[base] * 1.2)
    assert np.array_equal(m.body_ipos[base], m0.body_ipos[base] + [0.005, -0.003, 0.0])
    assert np.array_equal(np.delete(m.body_mass, base), np.delete(m0.body_mass, base))
    parts_mass = m0.body_subtreemass[base] - m0.body_mass[base]  # wheels (and the TurtleBot3's LDS and caster)
    assert m.body_subtreemass[base] == pytest.approx(m0.body_mass[base] * 1.2 + parts_mass, rel=1e-12)  # mj_setConst


def _drive(model: mujoco.MjModel, left: float, right: float, seconds: float = 3.0) -> tuple[float, float, float]:
    """Mean yaw rate and wheel speeds [rad/s] over the second half of a run at fixed commands."""
    d = mujoco.MjData(model)
    set_pose(model, d, Pose2D(0.0, 0.0, 0.0))
    d.ctrl[model.actuator("wheel_left_motor").id] = left
    d.ctrl[model.actuator("wheel_right_motor").id] = right
    adr = [model.sensor_adr[model.sensor(n).id] for n in ("base_gyro", "wheel_left_vel", "wheel_right_vel")]
    n = round(seconds / model.opt.timestep)
    samples = []
    for i in range(n):
        mujoco.mj_step(model, d)
        if i >= n // 2:
            samples.append([d.sensordata[adr[0] + 2], d.sensordata[adr[1]], d.sensordata[adr[2]]])
    assert not any(w.number for w in d.warning)
    yaw, wl, wr = np.mean(samples, axis=0)
    return float(yaw), float(wl), float(wr)


@pytest.mark.parametrize("robot", ROBOTS)
def test_unequal_wheels_curve_a_straight_drive_as_the_kinematics_say(robot: str) -> None:
    spec = load_robot(robot)
    r, b = spec.wheel_radius, spec.track_width
    m0 = build_model(spec).model
    assert abs(_drive(m0, 4.0, 4.0)[0]) < 1e-6
    yaw, wl, wr = _drive(AsBuilt(left_radius_scale=0.98, right_radius_scale=1.02).apply_to_model(m0), 4.0, 4.0)
    expected = (wr * 1.02 * r - wl * 0.98 * r) / b  # a bigger right wheel turns the robot left
    assert yaw > 0 and yaw == pytest.approx(expected, rel=0.02)  # the 2 % the tyres are tuned to


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_wider_track_slows_a_pivot_by_the_track_ratio(robot: str) -> None:
    spec = load_robot(robot)
    m0 = build_model(spec).model
    nominal = _drive(m0, -2.0, 2.0)[0]
    wider = _drive(AsBuilt(track_change=0.01).apply_to_model(m0), -2.0, 2.0)[0]
    # the wheel servos' lag is the same in both runs and cancels in the ratio; a 1 cm change is 6-9 %
    assert wider / nominal == pytest.approx(spec.track_width / (spec.track_width + 0.01), rel=0.005)


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_as_built_robot_rests_level_on_both_tyres(robot: str) -> None:
    # the centre of mass moved back: the TurtleBot3's is only 4 mm behind its axle (URDF), and 10 mm
    # forward would tip it onto the front of its chassis
    ab = AsBuilt(left_radius_scale=0.97, right_radius_scale=1.03, com_offset_x=-0.01, base_mass_scale=1.3)
    m = ab.apply_to_model(build_model(load_robot(robot)).model)
    d = mujoco.MjData(m)
    set_pose(m, d, Pose2D(0.0, 0.0, 0.0))
    z0 = float(d.qpos[2])
    mujoco.mj_step(m, d, nstep=500)
    w, x, y, z = d.qpos[3:7]
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    # a level base needs each axle moved: without, the 6 % radius difference would roll it ~0.01 rad
    assert abs(roll) < 1e-4 and abs(d.qpos[2] - z0) < 1e-4


@pytest.mark.parametrize("robot", ROBOTS)
def test_draws_are_repeatable_within_the_band_and_have_the_tolerance_spread(robot: str) -> None:
    tol = TOLERANCES[robot]
    assert AsBuilt.draw(robot, 5) == AsBuilt.draw(robot, 5) != AsBuilt.draw(robot, 6)
    other = next(r for r in ROBOTS if r != robot)
    assert AsBuilt.draw(robot, 5).left_radius_scale != AsBuilt.draw(other, 5).left_radius_scale
    seeds = 3000
    draws = [AsBuilt.draw(robot, s) for s in range(seeds)]
    c = CLIP_SIGMAS  # std of a standard normal clipped at +-c
    clipped = math.sqrt(2 * norm.cdf(c) - 1 - 2 * c * norm.pdf(c) + 2 * c * c * norm.sf(c))
    rel = 4 / math.sqrt(2 * seeds)  # 4 standard errors of a sample std
    for field, sigma, centre in (
        ("left_radius_scale", tol.radius, 1.0), ("right_radius_scale", tol.radius, 1.0),
        ("track_change", tol.track, 0.0), ("tyre_friction_scale", tol.friction, 1.0),
        ("base_mass_scale", tol.mass, 1.0), ("com_offset_x", tol.com_x, 0.0), ("com_offset_y", tol.com_y, 0.0),
    ):  # fmt: skip
        values = np.array([getattr(a, field) for a in draws])
        assert np.all(np.abs(values - centre) <= c * sigma * (1 + 1e-12)), field
        if field == "com_offset_x" and math.isfinite(tol.com_x_forward_max):  # also cut in front
            hi = min(c, tol.com_x_forward_max / sigma)
            m1 = norm.expect(lambda z, hi=hi: np.clip(z, -c, hi))
            m2 = norm.expect(lambda z, hi=hi: np.clip(z, -c, hi) ** 2)
            assert np.std(values) == pytest.approx(sigma * math.sqrt(m2 - m1**2), rel=rel), field
            assert values.max() <= tol.com_x_forward_max
            continue
        assert np.std(values) == pytest.approx(sigma * clipped, rel=rel), field
    left = np.array([a.left_radius_scale for a in draws])
    right = np.array([a.right_radius_scale for a in draws])
    assert abs(np.corrcoef(left, right)[0, 1]) < 4 / math.sqrt(seeds)  # the wheels are drawn independently
    ed = np.array([a.wheel_ratio for a in draws])
    # E_d = D_R / D_L: to first order sqrt(2) x the radius spread; its second-order error is ~sigma
    assert np.std(ed) == pytest.approx(math.sqrt(2) * tol.radius * clipped, rel=rel + 2 * tol.radius)


def test_default_build_and_records() -> None:
    a = AsBuilt.draw("turtlebot3", DEFAULT_BUILD_SEED)
    record = json.loads(json.dumps(a.as_dict()))
    assert (record["robot"], record["build_seed"]) == ("turtlebot3", DEFAULT_BUILD_SEED)
    assert record["wheel_ratio"] == a.right_radius_scale / a.left_radius_scale
    assert a.wheelbase_ratio(0.16) == (0.16 + a.track_change) / 0.16
    assert AsBuilt.nominal().as_dict()["build_seed"] is None


@pytest.mark.parametrize("seed", ["3", 1.5, True, -1, None])
def test_a_bad_build_seed_names_the_option_and_the_fix(seed: object) -> None:
    said = (
        rf"--build-seed \(build_seed=\.\.\. from Python\) must be an integer >= 0, got .*e\.g\. {DEFAULT_BUILD_SEED}$"
    )
    with pytest.raises(ConfigError, match=said):
        AsBuilt.draw("turtlebot3", seed)  # type: ignore[arg-type]


def test_bad_builds_and_models_are_refused() -> None:
    with pytest.raises(
        ConfigError,
        match=r"no build tolerances for robot 'r2d2' \(robots with them: turtlebot3, edumip, edumip-balancing\): "
        r"run it as drawn, --build nominal",
    ):
        AsBuilt.draw("r2d2", 1)
    with pytest.raises(ConfigError, match=r"as-built left_radius_scale must be .* in \[0.8, 1.2\] \(x\), got 1.5"):
        AsBuilt(left_radius_scale=1.5)
    with pytest.raises(ConfigError, match="as-built track_change must be a finite number"):
        AsBuilt(track_change=float("nan"))
    bare = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body name='base'><geom size='0.1'/></body></worldbody></mujoco>"
    )
    with pytest.raises(ModelError, match="no body named in"):
        SKEWED.apply_to_model(bare)


def test_no_turtlebot3_build_has_its_centre_of_mass_where_it_tips_over() -> None:
    """The TurtleBot3's centre of mass is 4 mm behind its axle with nothing in front: builds are cut
    at 2.5 mm forward, and one cut there still rests level (pitch under 1 degree after 3 s)."""
    import dataclasses

    import mujoco

    from planning.core.geometry import Pose2D
    from planning.core.robot import load_robot
    from sim.physics.asbuilt import TOLERANCES
    from sim.physics.model import build_model, set_pose

    limit = TOLERANCES["turtlebot3"].com_x_forward_max
    xs = [AsBuilt.draw("turtlebot3", s).com_offset_x for s in range(300)]
    assert max(xs) == limit and min(xs) < -limit  # cut in front only
    base = build_model(load_robot("turtlebot3"), None).model
    build = dataclasses.replace(AsBuilt.draw("turtlebot3", 52), com_offset_x=limit)
    m = build.apply_to_model(base)
    d = mujoco.MjData(m)
    set_pose(m, d, Pose2D(0.0, 0.0, 0.0))
    mujoco.mj_step(m, d, 1500)
    w, x, y, z = d.qpos[3:7]
    assert abs(np.degrees(np.arcsin(2 * (w * y - z * x)))) < 1.0
