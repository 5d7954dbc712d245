"""A robot of one's own: ``register_robot`` (its model, scene and sensor settings checked when registered), the
plugin hook that brings it to the ``nhsim`` command (``NHSIM_PLUGINS``, entry points of group ``nhsim.robots``),
and everything keyed by a robot's name (scenario files, sensors, scanner, build tolerances, the study digest)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest

from planning.core.plugins import BY_CODE, PLUGIN_VARIABLE
from planning.core.robot import ROBOTS, ROBOTS_DIR, SENSORS_DIR, RobotFiles, load_robot, register_robot
from planning.errors import ConfigError, ModelError
from planning.scenario import load_scenario_file
from sim.physics import asbuilt
from sim.physics.asbuilt import TOLERANCES, AsBuilt
from sim.physics.lidar import load_lidar_profile
from sim.physics.sensors import load_sensor_profile
from tests.doc_blocks import block_of
from tests.registry_helpers import isolated

WHEELBASE = "0.12"  # the copy's virtual wheelbase (0.1 m the Burger's): a spec that has it was read from the copy


@pytest.fixture
def robots(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """The robot registry and the build tolerances as they are now, restored after the test; NHSIM_PLUGINS unset."""
    monkeypatch.setattr(asbuilt, "TOLERANCES", dict(TOLERANCES))
    with isolated(monkeypatch, (ROBOTS,), "loaded"):
        yield


def _robot(folder: Path, stem: str = "slowbot", *, scene: bool = True, lidar: bool = True) -> tuple[Path, Path]:
    """A copy of the Burger's model with a longer virtual wheelbase, its scene (unless ``scene`` is False) and sensor
    settings (without the scanner's table unless ``lidar``) in ``folder``: (model, sensors)."""
    folder.mkdir(parents=True, exist_ok=True)
    text = (ROBOTS_DIR / "turtlebot3_burger.xml").read_text()
    model = folder / f"{stem}.xml"
    model.write_text(text.replace('name="nhsim_wheelbase" data="0.1"', f'name="nhsim_wheelbase" data="{WHEELBASE}"'))
    if scene:
        scene_text = (ROBOTS_DIR / "turtlebot3_burger_scene.xml").read_text()
        (folder / f"{stem}_scene.xml").write_text(scene_text.replace("turtlebot3_burger.xml", model.name))
    sensors_text = (SENSORS_DIR / "turtlebot3.toml").read_text()
    if not lidar:
        sensors_text = sensors_text[: sensors_text.index("[lidar]")]
    sensors = folder / f"{stem}_sensors.toml"
    sensors.write_text(sensors_text)
    return model, sensors


def test_a_registered_robot_is_read_from_its_own_files(robots: None, tmp_path: Path) -> None:
    model, sensors = _robot(tmp_path)
    register_robot("slowbot", model, sensors=sensors)
    spec = load_robot("slowbot")
    assert spec.name == "slowbot" and spec.wheelbase == float(WHEELBASE) and spec.mjcf == model.resolve()
    assert spec.scene == model.resolve().with_name("slowbot_scene.xml")
    assert load_robot(str(model)).name == "slowbot"  # its model's path names it too
    assert load_robot(str(ROBOTS_DIR / "edumip.xml")).name == "edumip"
    assert (
        ROBOTS.origin("slowbot") == BY_CODE
        and "slowbot" in ROBOTS
        and ROBOTS.built_in() == sorted(["turtlebot3", "edumip", "edumip-balancing"])
    )
    assert load_sensor_profile("slowbot") == load_sensor_profile("turtlebot3")
    assert load_lidar_profile("slowbot") == load_lidar_profile("turtlebot3")
    blind, blind_sensors = _robot(tmp_path / "blind", "blindbot", lidar=False)
    register_robot("blindbot", blind, sensors=blind_sensors)
    assert load_lidar_profile("blindbot") is None
    with pytest.raises(
        ConfigError, match=r"robot 'blindbot' has no laser scanner \(.*blindbot_sensors.toml has no \[lidar\]"
    ):
        load_lidar_profile("blindbot", text="beams=90")


def test_a_registration_is_checked_when_made(robots: None, tmp_path: Path) -> None:
    model, sensors = _robot(tmp_path)
    cases: list[tuple[dict[str, object], type[Exception], str]] = [
        ({"name": "a b"}, ConfigError, "name must be non-empty text without commas or whitespace"),
        ({"mjcf": tmp_path / "none.xml"}, ConfigError, r"mjcf '.*none.xml' does not exist; give the path of its .xml"),
        ({"mjcf": tmp_path}, ConfigError, r"mjcf '.*' is a folder"),
        ({"mjcf": sensors}, ConfigError, r"mjcf '.*slowbot_sensors.toml' is not a .xml file"),
        ({"sensors": None}, ConfigError, r"sensors must be the path of a .toml file, got None"),
        ({"sensors": model}, ConfigError, r"sensors '.*slowbot.xml' is not a .toml file"),
    ]
    for change, error, match in cases:
        given: dict[str, object] = {"name": "slowbot", "mjcf": model, "sensors": sensors} | change
        with pytest.raises(error, match=match):
            register_robot(given.pop("name"), given.pop("mjcf"), **given)  # type: ignore[arg-type]
        assert "slowbot" not in ROBOTS
    unscened, _ = _robot(tmp_path / "bare", "bare", scene=False)
    with pytest.raises(
        ModelError, match=r"robot 'bare' has no scene file .*bare_scene.xml .*copy .*turtlebot3_burger_scene"
    ):
        register_robot("bare", unscened, sensors=sensors)
    broken = tmp_path / "broken.xml"
    broken.write_text(model.read_text().replace('name="nhsim_wheelbase"', 'name="nhsim_wheel_base"'))
    with pytest.raises(ModelError, match=r"broken.xml: the model lacks <custom><numeric name='nhsim_wheelbase'>;"):
        register_robot("broken", broken, sensors=sensors)
    assert "bare" not in ROBOTS and "broken" not in ROBOTS


def test_a_taken_name_is_replaced_only_when_asked(robots: None, tmp_path: Path) -> None:
    model, sensors = _robot(tmp_path)
    burger = ROBOTS["turtlebot3"]
    with pytest.raises(
        ConfigError,
        match=r"robot 'turtlebot3' is already registered \(built in\) as .*turtlebot3_burger.xml \(sensors "
        r".*turtlebot3.toml\); choose another name, or pass replace=True",
    ):
        register_robot("turtlebot3", model, sensors=sensors)
    assert ROBOTS["turtlebot3"] == burger
    register_robot("slowbot", model, sensors=sensors)
    register_robot("slowbot", str(model), sensors=str(sensors))  # the same files again (a plugin imported twice)
    other, _ = _robot(tmp_path / "other", "other")
    with pytest.raises(ConfigError, match="robot 'slowbot' is already registered"):
        register_robot("slowbot", other, sensors=sensors)
    register_robot("slowbot", other, sensors=sensors, replace=True)
    assert ROBOTS["slowbot"] == RobotFiles(other.resolve(), sensors.resolve())
    assert load_robot("slowbot").mjcf == other.resolve()


def test_scenario_files_and_builds_take_a_registered_robot(robots: None, tmp_path: Path) -> None:
    model, sensors = _robot(tmp_path)
    file = tmp_path / "lane.toml"
    file.write_text(
        'name = "lane"\nrobot = "slowbot"\nrobots = ["slowbot", "turtlebot3"]\n\n[world]\nbounds = [-1, 3, -1, 1]\n\n'
        "[start]\npose = [0.0, 0.0, 0.0]\n\n[goal]\npose = [2.0, 0.0, 0.0]\n"
    )
    with pytest.raises(
        ConfigError,
        match=r"field 'robot'.*one of edumip, edumip-balancing, turtlebot3 \(a plugin's robot is known once its "
        r"plugin loads: name its module in NHSIM_PLUGINS",
    ):
        load_scenario_file(file)
    register_robot("slowbot", model, sensors=sensors)
    scenario = load_scenario_file(file)
    assert scenario.robot == "slowbot" and scenario.robots == ("slowbot", "turtlebot3")
    with pytest.raises(
        ConfigError,
        match=r"no build tolerances for robot 'slowbot' .*run it as drawn, --build nominal .*"
        r"TOLERANCES\['slowbot'\] = BuildTolerance",
    ):
        AsBuilt.draw("slowbot", 3)
    asbuilt.TOLERANCES["slowbot"] = TOLERANCES["turtlebot3"]
    assert AsBuilt.draw("slowbot", 3) != AsBuilt.draw("turtlebot3", 3)  # its own draw, from its own name


def test_the_code_digest_covers_a_registered_robots_files(robots: None, tmp_path: Path) -> None:
    """A study's runs depend on the robot's model and sensors: editing a registered robot's files makes other runs."""
    from sim.tools import digests

    own = digests.code_digest()
    model, sensors = _robot(tmp_path)
    register_robot("slowbot", model, sensors=sensors)
    with_robot = digests.code_digest()
    assert with_robot != own
    labels = [label for _, label in digests.robot_model_files()]
    assert labels == ["robot slowbot model", "robot slowbot scene", "robot slowbot sensors"]
    sensors.write_text(sensors.read_text().replace("encoder_cpr = 4096", "encoder_cpr = 2048"))
    digests._digest.cache_clear()  # a new process: the files read again
    assert digests.code_digest() not in (own, with_robot)


def _nhsim(folder: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    """``nhsim ARGV`` in a fresh process in ``folder``, with NHSIM_PLUGINS naming the plugin module there."""
    env = {k: v for k, v in os.environ.items() if k not in (PLUGIN_VARIABLE, "NHSIM_TRACEBACK")}
    env |= {
        "PYTHONPATH": os.pathsep.join([str(folder), env.get("PYTHONPATH", "")]),
        PLUGIN_VARIABLE: "nhsim_test_robots",
    }
    return subprocess.run([sys.executable, "-m", "sim", *argv], capture_output=True, text=True, env=env, cwd=folder)


def test_the_command_simulates_a_plugins_robot(tmp_path: Path) -> None:
    """The docs' plugin (docs/how-to/new-robot.md), beside its robot's files: NHSIM_PLUGINS names it, --robot takes
    the robot, a scenario file names it, its runs are drawn from its own tolerances, and --help loads no plugin."""
    _robot(tmp_path, "mybot")
    marker = tmp_path / "imported"
    code = block_of("docs/how-to/new-robot.md").code
    (tmp_path / "nhsim_test_robots.py").write_text(f"open({str(marker)!r}, 'w').close()\n{code}")
    done = _nhsim(tmp_path, "simulate", "--help")
    assert (
        done.returncode == 0
        and not marker.exists()
        and "turtlebot3 or a plugin's robot" in " ".join(done.stdout.split())
    )
    done = _nhsim(tmp_path, "simulate", "--robot", "slowbot2")
    assert (
        done.returncode == 2
        and "unknown robot 'slowbot2': choose one of edumip, edumip-balancing, mybot, turtlebot3" in done.stderr
    )
    (tmp_path / "lane.toml").write_text(
        'name = "lane"\nrobot = "mybot"\n\n[world]\nbounds = [-1, 3, -1, 1]\n\n'
        "[start]\npose = [0.0, 0.0, 0.0]\n\n[goal]\npose = [2.0, 0.0, 0.0]\n"
    )
    argv = ["simulate", "--scenario", "lane.toml", "--reference", "line", "--runs", "closed_loop,open_loop"]
    done = _nhsim(tmp_path, *argv, "--no-video", "--no-plots", "--json", "run.json")
    assert done.returncode == 0, done.stderr
    record = json.loads((tmp_path / "run.json").read_text())
    assert record["robot"] == "mybot" and record["build_seed"] is not None
    assert record["as_built"]["left_radius_scale"] != 1.0  # drawn within the plugin's tolerances
    assert record["closed_loop"]["collisions"] == 0
    assert record["closed_loop"]["final_position_error_m"] < 0.02


def test_a_model_without_what_the_simulator_reads_is_refused_naming_each(robots: None, tmp_path: Path) -> None:
    """A model of one's own without an element the simulator reads by name failed inside a run with MuJoCo's
    KeyError ("Invalid name 'wheel_right_motor'"); then it was refused when a run first built it, and a missing
    numeric when registered, one name at a time. register_robot now names every one it lacks."""
    import re

    import mujoco

    from sim.physics.model import check_named_elements

    model, sensors = _robot(tmp_path)
    text = model.read_text().replace('name="wheel_right_motor"', 'name="wheel_r_motor"')
    text = text.replace('<jointpos name="wheel_left_pos"', '<jointpos name="wheel_l_pos"')
    text = re.sub(r"\s*<touch name=\"wheel_(left|right)_touch\"[^>]*/>", "", text)
    model.write_text(text.replace('name="nhsim_wheelbase"', 'name="nhsim_wheel_base"'))
    with pytest.raises(ModelError) as err:
        register_robot("slowbot", model, sensors=sensors)
    assert str(err.value) == (
        f"{model.resolve()}: the model lacks <custom><numeric name='nhsim_wheelbase'>, actuator 'wheel_right_motor', "
        "sensor 'wheel_left_pos', sensor 'wheel_left_touch', sensor 'wheel_right_touch'; give them as "
        f"{ROBOTS_DIR / 'turtlebot3_burger.xml'} does (docs/how-to/new-robot.md)"
    )
    assert "slowbot" not in ROBOTS
    # a model whose names come from files it includes is checked when compiled, by the same table
    compiled = mujoco.MjModel.from_xml_string(text)
    with pytest.raises(ModelError) as err:
        check_named_elements(replace(load_robot("turtlebot3"), name="slowbot", mjcf=model), compiled)
    assert str(err.value) == (
        f"{model}: robot 'slowbot' lacks actuator 'wheel_right_motor', sensor 'wheel_left_pos', sensor "
        "'wheel_left_touch', sensor 'wheel_right_touch', which the simulator reads by name; give them as "
        f"{ROBOTS_DIR / 'turtlebot3_burger.xml'} does (docs/how-to/new-robot.md)"
    )


def test_a_scene_that_does_not_include_its_robots_model_is_refused_when_registered(
    robots: None, tmp_path: Path
) -> None:
    """A scene copied and left including the Burger's file simulated the Burger where it found that file, and
    failed with MuJoCo's raw "XML Error: Error opening file" where it did not."""
    model, sensors = _robot(tmp_path)
    scene = tmp_path / "slowbot_scene.xml"
    scene.write_text(scene.read_text().replace('file="slowbot.xml"', 'file="turtlebot3_burger.xml"'))
    with pytest.raises(ModelError) as err:
        register_robot("slowbot", model, sensors=sensors)
    assert str(err.value) == (
        f"the scene file of robot 'slowbot', {scene.resolve()}, includes turtlebot3_burger.xml, not its model "
        "slowbot.xml: "
        'make its <include file="slowbot.xml"/>'
    )
    assert "slowbot" not in ROBOTS


def test_a_scanner_without_its_site_and_a_partial_supply_are_said_naming_the_fix(robots: None, tmp_path: Path) -> None:
    """A robot with a [lidar] table and no 'lidar' site was a KeyError traceback; a model with some of the supply's
    ratings said "give all or none" without naming them or the file."""
    from sim.physics.lidar import LidarScanner
    from sim.physics.model import build_model
    from sim.physics.simulator import Simulator

    model, sensors = _robot(tmp_path)
    model.write_text(model.read_text().replace('<site name="lidar"', '<site name="scanner"'))
    register_robot("slowbot", model, sensors=sensors)
    profile = load_lidar_profile("slowbot")
    assert profile is not None
    with pytest.raises(ModelError, match=r"has no site 'lidar', where the scan plane is: give one on the scanner's"):
        LidarScanner(build_model(load_robot("slowbot")).model, profile, seed=0)
    other, _ = _robot(tmp_path / "partial", "partial")
    text = other.read_text()
    start = text.index('<numeric name="nhsim_motor_speed_cap"')
    other.write_text(text[:start] + text[text.index("/>", start) + 2 :])
    register_robot("partial", other, sensors=sensors)
    with pytest.raises(ModelError) as err:
        Simulator(load_robot("partial"))
    said = str(err.value)
    assert said.startswith(f"{other.resolve()}: model supply numerics: nhsim_motor_speed_cap missing beside "), said
    assert "or none but nhsim_motor_battery_voltage (a fixed supply, its limits not checked)" in said


def test_a_plugin_that_fails_is_said_as_itself_by_robot(tmp_path: Path) -> None:
    """--robot looked a failing plugin's robot up inside argparse, which said only "invalid robot_name value:
    'kobuki'" of its error (a duplicate registration, a model the rule refuses, a misspelled module)."""
    (tmp_path / "nhsim_test_robots.py").write_text("raise RuntimeError('no licence')\n")
    done = _nhsim(tmp_path, "simulate", "--scenario", "random3", "--robot", "kobuki")
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "argument --robot: plugin failed to load: module 'nhsim_test_robots' named by NHSIM_PLUGINS" in done.stderr
    assert "RuntimeError: no licence" in done.stderr and "invalid robot_name value" not in done.stderr


def test_a_robots_own_odometry_noise_is_given_in_its_sensor_settings(robots: None, tmp_path: Path) -> None:
    """A robot faster than the built-in ones had their odometry noise in its estimator and no way to give its own
    (a Kobuki-like base's NEES mean 6.3): its sensor settings file takes an [estimator] table."""
    from sim.cli.simulate import sensor_overrides
    from sim.robot.sensing import SensingSetup

    model, sensors = _robot(tmp_path)
    sensors.write_text(sensors.read_text() + "\n[estimator]\nwheel_noise = 0.004\nposition_noise = 0.003\n")
    register_robot("slowbot", model, sensors=sensors)
    config = SensingSetup.for_robot("slowbot").estimator_config(load_robot("slowbot"), 50.0)
    burger = SensingSetup.for_robot("turtlebot3").estimator_config(load_robot("turtlebot3"), 50.0)
    assert (config.wheel_noise, config.position_noise) == (0.004, 0.003)
    assert (burger.wheel_noise, burger.position_noise) == (2e-3, 1e-3)  # the built-in robots' as before
    assert config.cornering_slip_std == burger.cornering_slip_std  # what the table does not give stays
    sensors.write_text(sensors.read_text().replace("wheel_noise = 0.004", "wheel_nois = 0.004"))
    with pytest.raises(
        ConfigError,
        match=r"slowbot_sensors.toml: field '\[estimator\] wheel_nois': unknown key; the "
        r"estimator keys are wheel_noise, position_noise, cornering_slip_std, max_odometry_drift",
    ):
        SensingSetup.for_robot("slowbot").estimator_config(load_robot("slowbot"), 50.0)
    sensors.write_text(sensors.read_text().replace("wheel_nois = 0.004", "wheel_noise = 0.004"))
    said = r"--sensors .*slowbot_sensors.toml \(sensors=\".*\" from Python\): its \[estimator\] table is a robot's"
    with pytest.raises(ConfigError, match=said):
        sensor_overrides(str(sensors))  # not an override of a run: the robot's own
