"""The balancing EduMIP's balance loop: linearisation, design, stability, standing, pushes and falls."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest
from numpy.typing import NDArray

from control.balance import BalanceController
from control.design.balance_profile import load_balance_profile
from planning.core.robot import load_robot
from planning.errors import ConfigError
from sim.physics.asbuilt import AsBuilt
from sim.physics.model import build_model
from sim.physics.sagittal import balance_accel_limit, linearise_upright
from sim.robot.balance_design import balance_gains, design_balance
from sim.robot.balance_firmware import Push, run_balance

NAME = "edumip-balancing"
FloatArray = NDArray[np.float64]


def pendulum(model: mujoco.MjModel) -> tuple[FloatArray, FloatArray, float, float, float]:
    """The wheeled inverted pendulum of the model's parameters, linearised at upright.

    Coordinates x (axle position) and theta (pitch); body mass M, centre of mass l (h in the code) above the axle,
    pitch inertia I about it; wheels of mass m and axle inertia J (both wheels), the motors'
    rotors J_a on the joint (wheel relative to body), their torque per volt g_m and back-EMF damping b
    (both motors), a common voltage u:

        [m + M + (J + J_a) / r^2,  M l - J_a / r] [x'']   [0      ]   [1 / r]
        [M l - J_a / r,    I + M l^2 + J_a      ] [th''] = [M g l th] + [-1   ] (2 g_m u - b (x' / r - th'))

    Returns:
        The mass matrix (2, 2), the input direction c = (1 / r, -1), M g l [N m], b [N m s] and
        2 g_m [N m/V].
    """
    base, wheel = model.body("base").id, model.body("wheel_left").id
    big_m, h, i_b = model.body_mass[base], model.body_ipos[base][2], model.body_inertia[base][1]
    r = model.geom_size[model.geom("wheel_left_geom").id][0]
    rot = np.empty(9)  # the wheel's principal axes back to its frame
    mujoco.mju_quat2Mat(rot, model.body_iquat[wheel])
    rot = rot.reshape(3, 3)
    j_w = 2 * (rot @ np.diag(model.body_inertia[wheel]) @ rot.T)[1, 1]
    m_w, j_a = 2 * model.body_mass[wheel], 2 * model.dof_armature[model.joint("wheel_left_joint").dofadr[0]]
    motor = model.actuator("wheel_left_motor").id
    b = -2 * model.actuator_biasprm[motor][2]
    g = -model.opt.gravity[2]
    mass = np.array(
        [[m_w + big_m + (j_w + j_a) / r**2, big_m * h - j_a / r], [big_m * h - j_a / r, i_b + big_m * h * h + j_a]]
    )
    return mass, np.array([1 / r, -1.0]), float(big_m * g * h), float(b), float(2 * model.actuator_gainprm[motor][0])


def pendulum_eigenvalue(model: mujoco.MjModel) -> float:
    """The unstable root [1/s] of :func:`pendulum` with no voltage."""
    mass, c, mgl, b, _ = pendulum(model)
    minv = np.linalg.inv(mass)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [minv @ np.diag([0.0, mgl]), -minv @ (b * np.outer(c, c))]])
    return float(np.max(np.linalg.eigvals(a).real))


def test_linearisation_matches_the_inverted_pendulum() -> None:
    """MuJoCo's finite-difference linearisation at upright has one unstable mode, the pendulum's
    exp(lambda dt); soft contacts and the integrator move it by well under 1 %."""
    model = build_model(load_robot(NAME)).model
    a, _ = linearise_upright(model)
    eig = np.linalg.eigvals(a)
    unstable = eig[np.abs(eig) > 1.0 + 1e-6]
    assert len(unstable) == 1
    measured = math.log(abs(unstable[0])) / model.opt.timestep
    expected = pendulum_eigenvalue(model)
    assert expected == pytest.approx(8.50, abs=0.01)  # the [B] numbers: sqrt-like growth of 8.5 /s
    assert measured == pytest.approx(expected, rel=0.01)


def test_design_reproduces_the_profile_and_is_stable() -> None:
    design = design_balance(NAME)
    prof = load_balance_profile(NAME)
    np.testing.assert_allclose(design.k, prof.k, rtol=1e-4)
    assert prof.lean_per_accel == pytest.approx(design.lean_per_accel, rel=1e-5)
    assert prof.voltage_per_accel == pytest.approx(design.voltage_per_accel, rel=1e-5)
    assert np.max(np.abs(design.open_loop)) > 1.0  # the pendulum
    assert np.max(np.abs(design.poles)) < 1.0  # every closed-loop pole inside the unit disc at 200 Hz
    assert prof.rate == 200.0


@pytest.mark.parametrize(
    ("k", "pole"),
    [((0.0, 0.0, 0.0, 0.0, 0.0), r"\|z\| = 1\.04"), ((49.3772, 4.98, 1.98, 1.38, 0.75), r"\|z\| = ")],
)
def test_destabilising_gains_are_rejected_naming_the_pole(k: tuple[float, ...], pole: str) -> None:
    with pytest.raises(ConfigError, match=r"destabilise the loop: closed-loop pole .*" + pole):
        balance_gains(NAME, k)


def test_complementary_filter_follows_the_tilt_and_rejects_gyro_bias() -> None:
    """Held at 0.1 rad with a gyroscope biased by 0.01 rad/s, the estimate settles at 0.1 + tau b."""
    gains = balance_gains(NAME)
    c = BalanceController(gains)
    tilt, bias = 0.1, 0.01
    accel = 9.81 * np.array([-math.sin(tilt), 0.0, math.cos(tilt)])
    for _ in range(round(5.0 * gains.rate)):  # 10 filter time constants
        c.update(bias, accel, (0.0, 0.0), (0.0, 0.0))
    assert c.theta == pytest.approx(tilt + gains.filter_time_constant * bias, abs=1e-4)


def test_feedforward_is_the_steady_solution_of_the_pendulum() -> None:
    """The lean and voltage the firmware feeds forward for an acceleration a: in the pendulum of the
    model's parameters, at any wheel speed, they give x'' = a and theta'' = 0 (to 1e-5, the rounding of
    the motor constants); in MuJoCo's linearisation over one 5 ms period they leave the body's pitch
    rate at under 5 % of what the same voltage gives upright, the wheel's acceleration within 6 % of
    a / r (the soft tyre contact and the period's hold are not in the analytic model)."""
    model = build_model(load_robot(NAME)).model
    design, gains = design_balance(NAME), balance_gains(NAME)
    mass, c, mgl, b, g2 = pendulum(model)
    a, r = 0.3, 0.034
    for speed in (0.0, 0.5):  # m/s
        u = gains.kff * speed / r + design.voltage_per_accel * a
        forces = np.array([0.0, mgl * design.lean_per_accel * a]) + c * (g2 * u - b * speed / r)
        np.testing.assert_allclose(np.linalg.solve(mass, forces), [a, 0.0], atol=1e-5)  # kff = b / g_m to 1e-6
    a5, b5 = design.a, design.b[:, 0]
    u = design.voltage_per_accel * a
    leant = a5 @ np.array([design.lean_per_accel * a, 0.0, 0.0, 0.0, 0.0]) + b5 * u
    upright = b5 * u
    assert abs(leant[1]) < 0.05 * abs(upright[1])
    assert leant[3] / gains.period == pytest.approx(a / r, rel=0.06)  # the wheel's acceleration


def test_complementary_filter_takes_out_the_commanded_acceleration() -> None:
    """Held at 0.1 rad while the commanded wheel speed ramps at 0.3 m/s^2 and the accelerometer feels
    that acceleration, the estimate settles at the tilt, not at the tilt less a / g (0.03 rad)."""
    gains = balance_gains(NAME)
    c = BalanceController(gains)
    tilt, a, g = 0.1, 0.3, 9.81
    accel = np.array([a * math.cos(tilt) - g * math.sin(tilt), 0.0, g * math.cos(tilt) + a * math.sin(tilt)])
    n = round(5.0 * gains.rate)
    for i in range(n):
        speed = (i + 1) * gains.period * a / gains.wheel_radius
        c.update(0.0, accel, (0.0, 0.0), (speed, speed))
    assert c.accel_ref == pytest.approx(a / gains.wheel_radius, rel=1e-9)
    assert c.theta == pytest.approx(tilt, abs=1e-4)
    with pytest.raises(ConfigError, match="command_period must be a finite number > 0"):
        BalanceController(gains, 0.0)


def lean(build: AsBuilt) -> float:
    """The pitch [rad] that puts the as-built centre of mass over the axle: atan(-dx / l)."""
    return math.atan2(-build.com_offset_x, 0.0477)


@pytest.mark.parametrize("build_seed", [0, 1, 2])
def test_stands_for_a_minute(build_seed: int) -> None:
    """60 s with sensor noise on an as-built draw: within 3 deg of its balance point after the first
    second, drifting at most 2 cm."""
    build = AsBuilt.draw(NAME, build_seed)
    run = run_balance(load_robot(NAME), 60.0, build=build, seed=build_seed)
    assert run.fell_at is None
    settled = run.times >= 1.0
    assert np.max(np.abs(run.pitch[settled] - lean(build))) <= math.radians(3.0)
    assert run.drift <= 0.02


def test_a_push_is_recovered_and_a_big_one_is_a_fall() -> None:
    """The guide's figures, standing on build 0: 0.05 and 0.07 N s recovered (13 and 24 deg), 0.1 N s a fall."""
    robot, build = load_robot(NAME), AsBuilt.draw(NAME, 0)
    for impulse, peak in ((0.05, 13.0), (0.07, 24.0)):
        run = run_balance(robot, 6.0, build=build, push=Push(impulse, 1.0))
        assert run.fell_at is None
        assert math.degrees(run.max_pitch) == pytest.approx(peak, abs=1.0)  # it was felt
        assert abs(run.pitch[-1] - lean(build)) <= math.radians(3.0)
    for impulse in (0.1, 0.3):
        fall = run_balance(robot, 6.0, build=build, push=Push(impulse, 1.0))
        assert fall.fell_at is not None and 1.0 < fall.fell_at < 2.0
        assert fall.times[-1] == pytest.approx(fall.fell_at, abs=0.006)  # the run ended there


def test_acceleration_limit_comes_from_the_lean() -> None:
    """The model's acceleration limit is the profile's lean through the steady-lean relation, checked
    here against a run: held at that acceleration, the nominal robot leans by the profile's lean."""
    robot = load_robot(NAME)
    model = build_model(robot).model
    prof = load_balance_profile(NAME)
    a_max = balance_accel_limit(model, prof.max_lean)
    assert a_max == pytest.approx(0.337, abs=0.001)
    assert robot.max_accel == math.floor(a_max * 100) / 100
    accel = 0.3  # m/s^2 for 1.5 s from rest: wheel speed a t / r
    run = run_balance(robot, 2.0, command=lambda t: (min(t, 1.5) * accel / 0.034,) * 2)
    steady = (run.times > 1.0) & (run.times < 1.5)
    expected = prof.max_lean * accel / a_max
    assert np.mean(run.pitch[steady]) == pytest.approx(expected, rel=0.15)
    # fed forward, the robot keeps to its reference while it accelerates (it lagged 3.4 cm without)
    reference = 0.5 * accel * run.times[steady] ** 2
    assert np.max(np.abs(run.position[steady, 0] - reference)) < 0.005


def test_the_firmware_reads_through_the_one_sensor_model(monkeypatch: pytest.MonkeyPatch) -> None:
    """The firmware's readings are the sensor model's (part 1 of the run's seed, no fixes), the
    encoder angles its quantised counts, also past the noise drawn at first (drawn longer, same start)."""
    from sim.physics.sensors import SensorModel, encoder_count, load_sensor_profile
    from sim.robot import balance_firmware

    monkeypatch.setattr(balance_firmware, "NOISE_PERIODS", 7)
    profile = load_sensor_profile(NAME)
    sensors = balance_firmware.FirmwareSensors(profile, 200.0, 0.001, seed=4)
    whole = SensorModel(replace(profile, fix_rate=0.0), control_rate=200.0, timestep=0.001, n_periods=40, seed=4,
                        part=1)  # fmt: skip
    c = profile.encoder_cpr / (2.0 * math.pi)
    rng = np.random.default_rng(1)
    for k in range(40):
        rate, accel, angles = float(rng.normal()), rng.normal(size=3), rng.normal(size=2) * 10.0
        gyro, acc, (left, right) = sensors.read(rate, accel, angles)
        assert gyro == rate + whole.gyro_error[k], k
        assert np.array_equal(acc, accel + (whole.accel_bias + whole.accel_white[k])), k
        assert (left * c, right * c) == pytest.approx(
            [encoder_count(a, c, p) for a, p in zip(angles, whole.encoder_phase, strict=True)], abs=1e-6
        )
    assert sensors.noise.n_periods == 56  # 7 doubled three times


@pytest.mark.parametrize(
    ("old", "new", "says"),
    [
        (
            "k = [-49.3772, -4.98288, -1.97834, -1.37833, -0.746242]",
            "k = [-49.3772, -4.98288, -1.97834, -1.37833]",
            r"\[gains\] k must be 5 finite gains, one per state \(theta, theta_dot, phi_error, phi_dot_error, "
            r"phi_error_integral\), got \[-49.3772, .*\]; design them with sim.robot.balance_design.design_balance",
        ),
        (
            "tip_angle = 0.85",
            "tip_angle = 5",
            r"\[balance\] tip_angle must be a finite number in \(0, 1.5708\] \(rad\)",
        ),
        ("max_lean = 0.0698", "max_lean = 0.9", r"\[balance\] max_lean must be a finite number in \(0, 0.85\)"),
        ("rate = 200.0", "rate = 0", r"\[balance\] rate must be a finite number > 0 \(Hz\), got 0"),
        ("theta_max = 0.0524", "theta_max = nan", r"\[weights\] theta_max must be a finite number > 0"),
        ("ki = 2.5", "ki = -1", r"\[turn\] ki must be a finite number >= 0"),
    ],
)
def test_a_profile_number_out_of_range_is_refused_naming_the_file_and_key(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, old: str, new: str, says: str
) -> None:
    """A gain vector of four (five states) ended in numpy's 'operands could not be broadcast'; a tip angle of 5 rad
    (beyond the floor) was taken."""
    from control.design import balance_profile

    text = (balance_profile.BALANCE_DIR / f"{NAME}.toml").read_text()
    assert old in text
    (tmp_path / f"{NAME}.toml").write_text(text.replace(old, new))
    monkeypatch.setattr(balance_profile, "BALANCE_DIR", tmp_path)
    with pytest.raises(ConfigError, match=says) as err:
        load_balance_profile(NAME)
    assert str(err.value).startswith(str(tmp_path / f"{NAME}.toml")), err.value


@pytest.mark.parametrize(
    ("edit", "said"),
    [
        (
            {"voltage_max": 0.1},
            r"\[gains\] are not what its \[weights\] and \[balance\] rate design on the robot: k\[0\]",
        ),
        ({"lean_per_accel": -10.0}, r"lean_per_accel -10 \(designed 0.207\d*\)"),
        ({"rate": 100.0}, r"\[gains\] are not what its \[weights\] and \[balance\] rate design"),
        ({"rate": 300.0}, r"\[balance\] rate 300 Hz: its period is not a whole number of the model's 1 ms physics"),
    ],
)
def test_a_profile_edited_without_its_gains_is_refused_naming_the_design(
    monkeypatch: pytest.MonkeyPatch, edit: dict[str, float], said: str
) -> None:
    """A weight or the rate edited and the stored gains left ran the old gains without a word (voltage_max 0.1 gave
    the baseline's numbers, lean_per_accel -10 a fall at 0.36 s); a rate of 300 Hz was "balance period 0.00333333 s
    is not a whole number of 0.001 s physics steps", naming neither file nor key."""
    import sim.robot.balance_design as design

    edited = replace(load_balance_profile(NAME), **edit)
    monkeypatch.setattr(design, "load_balance_profile", lambda robot: edited)
    with pytest.raises(ConfigError, match=said) as refused:
        balance_gains(NAME)
    assert "edumip-balancing.toml" in str(refused.value)
    if "rate 300" not in said:
        assert "design_report('edumip-balancing')" in str(refused.value)
