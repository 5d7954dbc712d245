"""The kinematic spec read from the MJCF agrees with what MuJoCo compiles from the same file."""

import dataclasses
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

from planning.core.robot import ROBOTS, load_robot
from planning.errors import ConfigError, ModelError


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_spec_matches_the_compiled_model(name: str) -> None:
    spec = load_robot(name)
    m = mujoco.MjModel.from_xml_path(str(spec.scene))
    assert spec.wheel_radius == pytest.approx(m.geom_size[m.geom("wheel_left_geom").id][0])
    yl = m.body_pos[m.body("wheel_left").id][1]
    yr = m.body_pos[m.body("wheel_right").id][1]
    assert spec.track_width == pytest.approx(yl - yr)
    assert spec.max_wheel_speed == pytest.approx(float(m.numeric("nhsim_max_wheel_speed").data[0]))
    assert spec.mass == pytest.approx(float(np.sum(m.body_mass)), rel=1e-6)
    # the footprint covers every geom's horizontal extent (checked with MuJoCo's own AABBs)
    data = mujoco.MjData(m)
    mujoco.mj_forward(m, data)
    base = m.body("base").id
    for g in range(m.ngeom):
        if m.geom_bodyid[g] == 0:
            continue
        r = m.geom_rbound[g]
        centre = data.geom_xpos[g][:2] - data.xpos[base][:2]
        assert np.hypot(*centre) - spec.radius <= r + 1e-9
    # the robot can reach its planning limits with its motors, below their no-load speed
    assert spec.max_speed <= spec.max_wheel_speed * spec.wheel_radius + 1e-9
    assert spec.max_yaw_rate <= 2 * spec.max_wheel_speed * spec.wheel_radius / spec.track_width + 1e-9
    assert spec.max_wheel_speed < float(m.numeric("nhsim_motor_no_load_speed").data[0])


def test_limits_in_the_models_are_what_the_motors_sustain() -> None:
    """The EduMIP keeps the EduMIP planning report's limits; the TurtleBot3's advertised 0.22 m/s
    and 2.84 rad/s are above its XL430s' 57 rpm no-load speed (0.197 m/s on a 33 mm wheel), so its
    limits are what the motors sustain with margin: 5.0 rad/s at the wheel (see the model's
    comments)."""
    tb3, mip = load_robot("turtlebot3"), load_robot("edumip")
    assert (tb3.wheel_radius, tb3.track_width, tb3.max_wheel_speed) == (0.033, 0.16, 5.0)
    assert (tb3.max_speed, tb3.max_yaw_rate) == (0.165, 2.06)
    assert tb3.max_speed < 57 * 2 * np.pi / 60 * tb3.wheel_radius < 0.22
    assert (mip.max_speed, mip.max_yaw_rate) == (0.8, 0.5)


def test_unknown_robot_names_the_choices() -> None:
    with pytest.raises(ConfigError, match="edumip, edumip-balancing, turtlebot3"):  # a ValueError, as bad input
        load_robot("roomba")


def test_model_missing_a_limit_is_reported(tmp_path) -> None:  # type: ignore[no-untyped-def]
    text = load_robot("edumip").mjcf.read_text().replace('name="nhsim_max_linear_speed"', 'name="other"')
    bad = tmp_path / "bad.xml"
    bad.write_text(text)
    with pytest.raises(ModelError, match="nhsim_max_linear_speed"):
        load_robot(str(bad))


def test_a_robot_without_its_scene_file_is_reported(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A robot file copied for a variant without its ``<stem>_scene.xml`` failed inside MuJoCo's parser
    (``ValueError: ParseXML: Error opening file``)."""
    from sim.physics.model import build_model

    mine = tmp_path / "big_bot.xml"
    mine.write_text(load_robot("turtlebot3").mjcf.read_text())
    robot = load_robot(str(mine))
    said = r"robot 'big_bot' has no scene file .*big_bot_scene\.xml .*: copy .*turtlebot3_burger_scene\.xml beside it"
    with pytest.raises(ModelError, match=said):
        build_model(robot)
    scene = load_robot("turtlebot3").scene.read_text().replace("turtlebot3_burger.xml", "big_bot.xml")
    (tmp_path / "big_bot_scene.xml").write_text(scene)
    assert build_model(robot).model.nbody == build_model(load_robot("turtlebot3")).model.nbody


def _inside(poly: np.ndarray, pts: np.ndarray, tol: float) -> np.ndarray:
    """Whether points lie inside a convex counter-clockwise polygon, within ``tol`` [m]."""
    a, b = poly, np.roll(poly, -1, axis=0)
    edge = b - a
    rel = pts[:, None, :] - a[None, :, :]
    cross = edge[None, :, 0] * rel[..., 1] - edge[None, :, 1] * rel[..., 0]
    return np.all(cross / np.hypot(edge[:, 0], edge[:, 1])[None, :] >= -tol, axis=1)


def test_the_balancing_footprint_holds_the_body_at_every_pitch_the_target_allows() -> None:
    from sim.pipeline.sweep import BALANCING_TARGETS

    spec = load_robot("edumip-balancing")
    assert spec.footprint_pitch == pytest.approx(BALANCING_TARGETS["max_pitch_rad"], abs=1e-6)
    assert load_robot("edumip").footprint_pitch == load_robot("turtlebot3").footprint_pitch == 0.0
    # MuJoCo places the chassis box pitched about the axle; its corners' x-y projection (relative to the
    # axle's midpoint, heading +x) stays inside the footprint, and at the bound it touches it
    m = mujoco.MjModel.from_xml_path(str(spec.scene))
    d = mujoco.MjData(m)
    g = m.geom("chassis").id
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * m.geom_size[g]
    reach = 0.0
    for pitch in np.linspace(-spec.footprint_pitch, spec.footprint_pitch, 13):
        d.qpos[3:7] = [np.cos(pitch / 2), 0.0, np.sin(pitch / 2), 0.0]  # about y: the top forward
        mujoco.mj_forward(m, d)
        world = d.geom_xpos[g] + corners @ d.geom_xmat[g].reshape(3, 3).T
        xy = world[:, :2] - d.qpos[:2]
        assert np.all(_inside(spec.footprint, xy, 1e-5)), pitch
        reach = max(reach, float(np.abs(xy[:, 0]).max()))
    assert reach == pytest.approx(np.abs(spec.footprint[:, 0]).max(), abs=1e-4)
    assert reach > 0.06 > m.geom_size[m.geom("wheel_left_geom").id][0]  # beyond the wheels' 34 mm


@pytest.mark.parametrize("bad", ["-0.1", "1.6", "nan"])
def test_a_footprint_pitch_outside_its_range_is_reported(tmp_path, bad: str) -> None:  # type: ignore[no-untyped-def]
    text = load_robot("edumip-balancing").mjcf.read_text()
    text = text.replace('name="nhsim_footprint_pitch" data="0.349066"', f'name="nhsim_footprint_pitch" data="{bad}"')
    path = tmp_path / "edumip_balancing.xml"
    path.write_text(text)
    with pytest.raises(ModelError, match=r"nhsim_footprint_pitch must be in \[0, pi/2\)"):
        load_robot(str(path))


def test_convex_hull_is_qhulls_for_every_footprint_and_random_points():
    """The footprint's hull (written to spare every command scipy's import) against scipy's qhull."""

    from scipy.spatial import ConvexHull

    from planning.core.robot import ROBOTS, convex_hull, load_robot

    for name in ROBOTS:
        fp = load_robot(name).footprint
        np.testing.assert_array_equal(convex_hull(fp), fp)  # a hull is its own hull, in the same order
    rng = np.random.default_rng(0)
    for k in range(50):
        pts = rng.normal(size=(int(rng.integers(3, 200)), 2)) * rng.uniform(0.01, 5.0)
        ours, ref = convex_hull(pts), pts[ConvexHull(pts).vertices]
        assert sorted(map(tuple, ours)) == sorted(map(tuple, ref)), k
        area = 0.5 * np.sum(ours[:, 0] * np.roll(ours[:, 1], -1) - np.roll(ours[:, 0], -1) * ours[:, 1])
        assert area > 0  # counter-clockwise


def test_a_model_is_parsed_once_per_text_and_its_spec_shared_read_only(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Loading a robot (its MJCF parsed, its footprint's hull over every pitch sample) cost every scenario,
    checker and run that named one; the same text now gives the same spec, and an edited file a new one."""
    spec = load_robot("edumip")
    assert load_robot("edumip") is spec
    assert not spec.footprint.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        spec.footprint[0, 0] = 1.0
    mine = tmp_path / "bot.xml"
    text = spec.mjcf.read_text()
    mine.write_text(text)
    first = load_robot(str(mine))
    assert first == dataclasses.replace(spec, name="bot", mjcf=mine, scene=mine.with_name("bot_scene.xml"))
    slower = text.replace('name="nhsim_max_linear_speed" data="0.8"', 'name="nhsim_max_linear_speed" data="0.7"')
    assert slower != text
    mine.write_text(slower)  # written at once: the same modification time, at the clock's grain
    assert load_robot(str(mine)).max_speed < first.max_speed
    mine.write_text(text)
    assert load_robot(str(mine)) is first


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"wheel_radius": -0.03}, "wheel_radius"),
        ({"max_speed": -1.0}, r"max_speed \(nhsim_max_linear_speed\)"),
        ({"max_speed": float("nan")}, "max_speed"),
        ({"max_accel": 0.0}, r"max_accel \(nhsim_max_linear_accel\)"),
        ({"track_width": 0.0}, "track_width"),
        ({"max_steering": 2.0}, "max_steering"),
        ({"footprint": np.zeros((0, 2))}, "footprint"),
        ({"max_speed": 0.2}, "beyond what the wheels reach"),
        ({"max_yaw_rate": 2.1}, "beyond what the wheels reach"),
    ],
)
def test_a_spec_refuses_a_number_no_robot_has(change: dict[str, object], named: str) -> None:
    """A spec's numbers were never checked: a negative wheel radius or speed made a planner ask numpy for 1.49 PiB,
    a NaN speed ended in a speed profile's int(NaN), a zero track was planned and tracked."""
    with pytest.raises(ConfigError, match=named):
        dataclasses.replace(load_robot("turtlebot3"), **change)


@pytest.mark.parametrize(
    ("numeric", "value", "named"),
    [
        ("max_linear_speed", "1e9", r"max_speed \(nhsim_max_linear_speed\) must be a finite number in \(0, 50\]"),
        ("max_linear_speed", "-0.26", "nhsim_max_linear_speed"),
        ("max_angular_speed", "0", "nhsim_max_angular_speed"),
        ("max_linear_speed", "fast", "numbers separated by spaces, got 'fast'"),
    ],
)
def test_a_model_file_with_such_a_number_is_refused_naming_file_and_numeric(
    tmp_path: Path, numeric: str, value: str, named: str
) -> None:
    text = load_robot("turtlebot3").mjcf.read_text()
    mine = tmp_path / "waffle.xml"
    edited = re.sub(rf'(name="nhsim_{numeric}" data=")[^"]*', rf"\g<1>{value}", text)
    assert edited != text
    mine.write_text(edited)
    with pytest.raises(ModelError, match=named) as caught:
        load_robot(str(mine))
    assert str(mine) in str(caught.value)


def test_a_robot_path_that_is_no_file_says_so(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"'.*nope\.xml' does not exist: give the path of a robot's MJCF file"):
        load_robot(str(tmp_path / "nope.xml"))
    with pytest.raises(ConfigError, match="is a folder"):
        load_robot(str(tmp_path) + "/")
    with pytest.raises(ConfigError, match="unknown robot 'nope'"):
        load_robot("nope")
