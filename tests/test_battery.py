"""The TurtleBot3's battery voltage: the motors' no-load speed and the robot's speed limits follow it."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

from planning.core.robot import load_robot
from planning.errors import ConfigError, ModelError
from planning.trajectory.references import make_reference
from sim.physics.model import build_model
from sim.physics.motors import MotorModel, Supply, apply_supply, check_model_limits, supplied_robot
from sim.pipeline.case import Case, PreparedTrajectory, load_case_scenario
from sim.pipeline.runs import RunKind
from sim.pipeline.simulate import track

#: The OpenCR firmware's cap for the Burger: 61 rpm at a 33 mm wheel (turtlebot3.cpp).
FIRMWARE_CAP = 0.033 * 2 * math.pi * 61 / 60
#: A charged 3-cell pack with the margins lowered to what the simulated supply needs (it does not sag).
CHARGED_THIN = "battery_voltage=12.6,supply_sag=0,torque_reserve=0.05"


def _model(spec_path: Path) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(spec_path))


def test_the_nominal_pack_keeps_todays_limits_bit_for_bit() -> None:
    tb3 = load_robot("turtlebot3")
    assert tb3.battery_voltage == 11.1
    assert (tb3.max_speed, tb3.max_yaw_rate, tb3.max_wheel_speed) == (0.165, 2.06, 5.0)
    assert supplied_robot(tb3) is tb3 and supplied_robot(tb3, " ") is tb3
    assert supplied_robot(tb3, "battery_voltage=11.1") == tb3  # the rule at 11.1 V is the model's numbers
    m = _model(tb3.mjcf)
    check_model_limits(tb3, MotorModel.from_model(m), Supply.from_model(m))  # type: ignore[arg-type]
    before = _model(tb3.mjcf)
    apply_supply(m, 11.1)
    assert np.array_equal(m.actuator_ctrlrange, before.actuator_ctrlrange)
    assert np.array_equal(m.numeric_data, before.numeric_data)


def test_the_no_load_speed_scales_with_the_voltage_and_the_back_emf_constant_stays() -> None:
    m = _model(load_robot("turtlebot3").mjcf)
    nominal = MotorModel.from_model(m)
    apply_supply(m, 12.6)
    charged = MotorModel.from_model(m)  # the actuators are checked against the new numerics
    assert charged.battery_voltage == 12.6
    assert charged.no_load_speed == pytest.approx(5.969 * 12.6 / 11.1, rel=1e-12)
    assert charged.stall_torque == pytest.approx(1.4 * 12.6 / 11.1, rel=1e-12)
    assert charged.speed_per_volt == pytest.approx(nominal.speed_per_volt, rel=1e-12)  # 1 / k_e
    assert charged.gain == pytest.approx(nominal.gain, rel=1e-12)
    assert charged.damping == pytest.approx(nominal.damping, rel=1e-12)
    assert m.actuator_ctrlrange.tolist() == [[-12.6, 12.6], [-12.6, 12.6]]
    # the XL430's own table: 61 rpm at 12 V against 57 rpm at 11.1 V; the linear model gives 61.6 rpm
    assert nominal.at_voltage(12.0).no_load_speed * 60 / (2 * math.pi) == pytest.approx(61, rel=0.015)


def test_the_limits_follow_the_voltage_up_to_the_firmware_cap() -> None:
    tb3 = load_robot("turtlebot3")
    charged = supplied_robot(tb3, "battery_voltage=12.6")
    assert (charged.max_speed, charged.max_yaw_rate, charged.max_wheel_speed) == (0.191, 2.39, 5.8)
    low = supplied_robot(tb3, "battery_voltage=9.9")
    assert low.max_speed < tb3.max_speed < charged.max_speed
    thin = supplied_robot(tb3, CHARGED_THIN)
    assert thin.max_wheel_speed == pytest.approx(61 * 2 * math.pi / 60, rel=1e-6)  # capped, not 6.4
    assert thin.max_speed == 0.21 and thin.max_speed <= FIRMWARE_CAP
    assert thin.max_yaw_rate == 2.63 and thin.battery_voltage == 12.6


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (
            "battery_voltage=0",
            "battery_voltage = 0 V is outside the 6.5-12.6 V .*e.g. battery_voltage=12.6, the highest",
        ),
        ("battery_voltage=-11.1", "battery_voltage = -11.1 V is outside"),
        ("battery_voltage=14.8", "battery_voltage = 14.8 V is outside"),
        ("battery_voltage=full", "battery_voltage must be a number, got 'full'"),
        ("battery_voltage=nan", "battery_voltage must be a finite number, got nan; give e.g. battery_voltage=12.6"),
        ("battery_voltage=12,supply_sag=inf", "supply_sag must be a finite number, got inf; give e.g. supply_sag=0.6"),
        ("voltage=12", "unknown key 'voltage'; choose from battery_voltage"),
        ("battery_voltage", "expected KEY=VALUE"),
        ("battery_voltage=12,torque_reserve=1", "torque_reserve must be a fraction in"),
        ("battery_voltage=12,supply_sag=-1", "supply_sag must be in"),
    ],
)
def test_a_bad_supply_is_refused_naming_the_field(text: str, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        supplied_robot(load_robot("turtlebot3"), text)


def test_the_edumip_keeps_its_fixed_supply() -> None:
    mip = load_robot("edumip")
    assert mip.battery_voltage == 7.4 and Supply.from_model(_model(mip.mjcf)) is None
    assert supplied_robot(mip) is mip
    with pytest.raises(ConfigError, match=r'fixed supply of 7\.4 V.*drop --motors \(motors="" from Python\)'):
        supplied_robot(mip, "battery_voltage=7.4")
    assert MotorModel.from_model(build_model(mip).model).battery_voltage == 7.4


def test_the_cli_refuses_a_bad_voltage_with_status_2_writing_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from sim.cli.main import main

    monkeypatch.chdir(tmp_path)
    argv = ["simulate", "--robot", "turtlebot3", "--reference", "line", "--quiet", "--no-video", "--no-plots"]
    assert main([*argv, "--motors", "battery_voltage=0"]) == 2
    err = capsys.readouterr().err
    assert "battery_voltage" in err and "6.5-12.6 V" in err and "Traceback" not in err
    assert main([*argv, "--motors", "battery_voltage=x"]) == 2
    assert "battery_voltage must be a number" in capsys.readouterr().err
    assert (
        main(["simulate", "--robot", "edumip", "--reference", "line", "--quiet", "--motors", "battery_voltage=7"]) == 2
    )
    assert "drop --motors" in capsys.readouterr().err
    assert not any(tmp_path.rglob("*.*"))


def _line_run(case: Case, spec_plan: object, physics_voltage: float) -> dict[str, float]:
    """Closed loop along a straight line timed at the full limits of ``spec_plan``, on a robot whose
    motors run at ``physics_voltage`` (the tracker knows ``spec_plan``'s limits)."""
    sc = load_case_scenario(case)
    plan = dataclasses.replace(spec_plan, battery_voltage=physics_voltage)  # type: ignore[type-var]
    traj = make_reference("line", plan, sc.start, margin=1.0)
    prepared = PreparedTrajectory(case, sc, plan, traj, "reference:line")
    job = track(prepared, [RunKind.CLOSED_LOOP])
    metrics = job.runs[RunKind.CLOSED_LOOP].metrics.as_dict()
    return {**metrics, "peak_speed": float(np.max(np.abs(traj.vel[:, 0])))}


def test_a_charged_pack_tracks_a_plan_at_the_firmware_cap_and_a_nominal_one_cannot() -> None:
    case = Case("open", robot="turtlebot3", reference="line", localiser="fixes", motors=CHARGED_THIN)
    fast = supplied_robot(load_robot("turtlebot3"), CHARGED_THIN)
    charged = _line_run(case, fast, 12.6)
    assert charged["peak_speed"] == pytest.approx(0.21, abs=1e-3)
    assert charged["final_position_error_m"] <= 0.02 and charged["collisions"] == 0
    # the same plan on motors at 11.1 V: their no-load speed, 0.197 m/s at the wheel, is below it
    nominal = _line_run(case, fast, 11.1)
    assert nominal["final_position_error_m"] > 0.04  # measured 5.5 cm behind (12.6 V: 6 mm)
    assert nominal["max_position_error_m"] > 5 * charged["max_position_error_m"]  # 13.5 cm against 1.2 cm


def test_a_model_whose_limits_its_motors_do_not_sustain_is_refused_by_the_simulator(tmp_path: Path) -> None:
    """A TurtleBot3 Waffle's published limits (0.26 m/s, 7.88 rad/s at the wheel) on the Burger's XL430 motors at
    11.1 V (which sustain 5.0 rad/s) ran with 86 % of its commands saturated, 18.5 cm off at the end, status ok."""
    from sim.physics.simulator import Simulator

    text = load_robot("turtlebot3").mjcf.read_text()
    numbers = {"max_wheel_speed": "7.88", "max_linear_speed": "0.26", "max_angular_speed": "1.81"}
    for key, value in numbers.items():
        text = re.sub(rf'(name="nhsim_{key}" data=")[^"]*', rf"\g<1>{value}", text)
    (tmp_path / "waffle.xml").write_text(text)
    scene = load_robot("turtlebot3").scene.read_text().replace("turtlebot3_burger.xml", "waffle.xml")
    (tmp_path / "waffle_scene.xml").write_text(scene)
    waffle = load_robot(str(tmp_path / "waffle.xml"))
    with pytest.raises(ModelError, match=r"max_wheel_speed = 7.88, the rule gives 5.0; .*give the motors"):
        Simulator(waffle)
    assert Simulator(supplied_robot(load_robot("turtlebot3"), "battery_voltage=12.6")).robot.max_speed == 0.191


def test_limits_below_the_rule_are_a_firmware_cap_kept_on_any_supply(tmp_path: Path) -> None:
    """A model's turning limit below what its motors sustain (a Kobuki-like base's firmware caps it at 3.14 rad/s
    where its motors give 6.08) was refused as "not those its motors sustain"; it is a cap of the robot's firmware,
    which a higher voltage does not lift (the other limits still follow the rule)."""
    from sim.physics.simulator import Simulator

    text = load_robot("turtlebot3").mjcf.read_text()
    (tmp_path / "capped.xml").write_text(re.sub(r'(name="nhsim_max_angular_speed" data=")[^"]*', r"\g<1>1.5", text))
    scene = load_robot("turtlebot3").scene.read_text().replace("turtlebot3_burger.xml", "capped.xml")
    (tmp_path / "capped_scene.xml").write_text(scene)
    capped = load_robot(str(tmp_path / "capped.xml"))
    assert Simulator(capped).robot.max_yaw_rate == 1.5  # accepted as it is
    charged = supplied_robot(capped, "battery_voltage=12.6")
    assert (charged.max_yaw_rate, charged.max_speed, charged.max_wheel_speed) == (1.5, 0.191, 5.8)  # cap kept
    burger = supplied_robot(load_robot("turtlebot3"), "battery_voltage=12.6")
    assert (burger.max_yaw_rate, burger.max_speed) == (2.39, 0.191)  # the rule's, where the model sets no cap
