"""The balance firmware in physics: noisy IMU and encoder readings, pushes, and fall detection.

:class:`BalanceFirmware` is a balancing robot's firmware in the simulator: every period (5 physics
steps of 1 ms at 200 Hz) it reads the IMU at its site (``imu_gyro``, ``imu_accel``) and the wheel
encoders from the physics (:class:`FirmwareSensors`: the robot's sensor profile's noise drawn by
:class:`sim.physics.sensors.SensorModel`, gyroscope white noise and bias with its random walk,
accelerometer white noise and bias, quantised encoder counts), runs
:class:`control.balance.BalanceController` and writes the motor voltages. It watches for a fall: the
true tilt of the body beyond the profile's ``tip_angle`` or the chassis touching the floor; from then on it
drives nothing and the run is to end.

:func:`run_balance` runs the firmware alone (no tracker) for a while, optionally with a wheel-speed
command and a push, and reports the pitch, the drift and a fall.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import mujoco
import numpy as np
from numpy.typing import NDArray

from control.balance import BalanceController, BalanceGains
from control.design.balance_profile import load_balance_profile
from planning.core.geometry import Pose2D
from planning.core.robot import RobotSpec
from planning.errors import ConfigError
from sim.physics.asbuilt import AsBuilt
from sim.physics.model import body_pitch, build_model, set_pose, touches
from sim.physics.motors import whole_steps
from sim.physics.runlog import BalanceLog
from sim.physics.sensors import SensorModel, SensorProfile, load_sensor_profile
from sim.robot.balance_design import balance_gains

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class Push:
    """A horizontal impulse on the top of the body.

    Attributes:
        impulse: Size [N s], positive pushing forward (the heading's +x).
        time: When [s] from the start of the run; the force acts over the balance period that holds
            it (5 ms at 200 Hz), as impulse / period.
    """

    impulse: float
    time: float


#: Firmware periods of noise drawn at first (a minute at 200 Hz); a longer run draws twice as many,
#: beginning with the same noise.
NOISE_PERIODS = 12_000


class FirmwareSensors:
    """A balancing robot's firmware readings, one firmware period at a time: the IMU's pitch rate and
    specific force and the wheel encoders, with the noise of the robot's sensor profile drawn as
    part 1 of the run's seed (:class:`sim.physics.sensors.SensorModel`: independent of the base's
    yaw gyro and encoders, part 0) and the encoders quantised by
    :func:`sim.physics.sensors.encoder_count`.

    Args:
        profile: The sensor profile (its pose fixes are not the firmware's and are left out).
        rate: Readings per second [Hz].
        timestep: Physics time step [s] (a firmware period is a whole number of them).
        seed: Seed of the run's sensor noise.
    """

    def __init__(self, profile: SensorProfile, rate: float, timestep: float, seed: int) -> None:
        quiet = replace(profile, fix_rate=0.0)
        self.noise = SensorModel(quiet, control_rate=rate, timestep=timestep, n_periods=NOISE_PERIODS, seed=seed,
                                 part=1)  # fmt: skip
        self.counts_per_rad = profile.encoder_cpr / (2.0 * math.pi)
        self.k = 0  # readings taken

    def read(
        self, gyro_y: float, accel: FloatArray, angles: FloatArray
    ) -> tuple[float, FloatArray, tuple[float, float]]:
        """The next period's readings of the true pitch rate [rad/s], specific force (3,) [m/s^2] and
        wheel angles (2,) [rad]: (gyro [rad/s], accelerometer (3,) [m/s^2], quantised angles [rad])."""
        k, noise = self.k, self.noise
        if k >= noise.n_periods:
            noise = self.noise = noise.longer(2 * noise.n_periods)
        self.k = k + 1
        left, right = noise.encoder_counts(float(angles[0]), float(angles[1]))
        c = self.counts_per_rad
        return noise.gyro(k, gyro_y), noise.accel(k, accel), (left / c, right / c)


class BalanceFirmware:
    """A balancing robot's firmware on a run's data (see the module docstring).

    Args:
        model: The run's model (perturbed or as built).
        data: The run's data.
        gains: Rates and gains (checked by :func:`sim.robot.balance_design.balance_gains`).
        profile: The robot's sensor profile.
        tip_angle: |tilt| beyond which the robot has fallen [rad].
        seed: Seed of the sensor noise.
        command_period: How often the wheel-speed command changes [s] (the tracker's period); the
            firmware's own if None (see :class:`control.balance.BalanceController`).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        gains: BalanceGains,
        profile: SensorProfile,
        tip_angle: float,
        seed: int = 0,
        command_period: float | None = None,
    ) -> None:
        self.model, self.data, self.tip_angle = model, data, tip_angle
        self.steps = whole_steps(gains.period, float(model.opt.timestep))
        if not self.steps:
            raise ConfigError(
                f"balance rate {gains.rate:g} Hz is not a whole number of {model.opt.timestep * 1e3:g} ms physics steps"
            )
        self.controller = BalanceController(gains, command_period)
        self.sensors = FirmwareSensors(profile, gains.rate, float(model.opt.timestep), seed)
        adr = model.sensor_adr
        self._gyro = int(adr[model.sensor("imu_gyro").id]) + 1
        self._accel = int(adr[model.sensor("imu_accel").id])
        self._quat = int(model.jnt_qposadr[model.joint("root").id]) + 3
        self._wheels = np.array(
            [model.jnt_qposadr[model.joint(n).id] for n in ("wheel_left_joint", "wheel_right_joint")]
        )
        self._chassis, self._floor = model.geom("chassis").id, model.geom("floor").id
        self.fell_at: float | None = None
        self.push: Push | None = None  # a push to give the body (set before the run)
        self._pushing = False
        self._base = model.body("base").id
        self.max_pitch = 0.0
        self.theta_estimates: list[tuple[float, float, float]] = []  # time, estimate, set-point
        self.reset()

    def reset(self) -> None:
        """Start at the data's state: the filter at the true pitch (the robot held upright at arming)."""
        d = self.data
        theta = float(body_pitch(d.qpos[self._quat : self._quat + 4]))
        phi = float(np.mean(d.qpos[self._wheels])) + theta
        self.controller.reset(theta, phi)

    def fallen(self) -> bool:
        """True when the body tilts beyond the tip angle or the chassis touches the floor (first time recorded)."""
        d = self.data
        q = d.qpos[self._quat : self._quat + 4]
        tilt = math.acos(min(1.0, max(-1.0, 1.0 - 2.0 * (q[1] * q[1] + q[2] * q[2]))))
        pitch = abs(float(body_pitch(q)))
        self.max_pitch = max(self.max_pitch, pitch)
        touch = touches(d, self._chassis, self._floor)
        if self.fell_at is None and (tilt > self.tip_angle or touch):
            self.fell_at = round(float(d.time), 9)  # MuJoCo's clock sums its steps: 3.09, not 3.0899999999997707
        return self.fell_at is not None

    def pitch_estimate(self) -> float:
        """The balance loop's own estimate of the body's pitch [rad] (its complementary filter's, after
        the last update): what the robot's software knows of it."""
        return float(self.controller.theta)

    def drive(self, commands: FloatArray, row: int, qvel: FloatArray, ctrl: FloatArray, wiring: IntArray) -> None:
        """One update, with the signature of :meth:`sim.robot.wheel_firmware.VelocityLoop.drive`: the wheel-speed
        command is row ``row`` of ``commands`` [rad/s] (< 0: row 0); the voltages go into ``ctrl`` at
        ``wiring[1]``."""
        d = self.data
        row = max(row, 0)
        self._push_step()
        if self.fallen():
            ctrl[wiring[1]] = 0.0
            return
        s = d.sensordata
        gyro, accel, angles = self.sensors.read(
            float(s[self._gyro]), s[self._accel : self._accel + 3].copy(), d.qpos[self._wheels]
        )
        c = self.controller
        left, right = c.update(gyro, accel, angles, (float(commands[row, 0]), float(commands[row, 1])))
        ctrl[wiring[1, 0]], ctrl[wiring[1, 1]] = left, right
        self.theta_estimates.append((float(d.time), c.theta, c.theta_ref))

    def _push_step(self) -> None:
        """Give the push over the period that holds its time (force = impulse / period at the top of
        the chassis, forward along the heading), and take it off at the next update."""
        d, push = self.data, self.push
        period = self.steps * float(self.model.opt.timestep)
        if push is not None and d.time - 1e-9 <= push.time < d.time + period - 1e-9:
            _apply_push(self.model, d, self._base, push.impulse / period)
            self._pushing = True
        elif self._pushing:
            d.xfrc_applied[self._base] = 0.0
            self._pushing = False

    def to_log(self, t0: float = 0.0) -> BalanceLog:
        """The loop's trace, times shifted by ``t0`` [s] (the trajectory's start)."""
        trace = np.array(self.theta_estimates).reshape(-1, 3)
        fell = None if self.fell_at is None else t0 + self.fell_at
        return BalanceLog(t0 + trace[:, 0], trace[:, 1], trace[:, 2], fell)


def make_firmware(robot: RobotSpec, model: mujoco.MjModel, data: mujoco.MjData, seed: int = 0) -> BalanceFirmware:
    """The balance firmware of a balancing robot on a run's data, its gains checked on ``model``."""
    prof = load_balance_profile(robot.name)
    return BalanceFirmware(model, data, balance_gains(robot.name), load_sensor_profile(robot.name),
                           prof.tip_angle, seed)  # fmt: skip


@dataclass(frozen=True)
class BalanceRun:
    """What a run of the firmware alone did.

    Attributes:
        times: (N,) sample times [s].
        pitch: (N,) true pitch [rad].
        position: (N, 2) base position [m].
        fell_at: Time of a fall [s], None if it stood.
    """

    times: FloatArray
    pitch: FloatArray
    position: FloatArray
    fell_at: float | None

    @property
    def max_pitch(self) -> float:
        """max |pitch| [rad]."""
        return float(np.max(np.abs(self.pitch)))

    @property
    def drift(self) -> float:
        """Distance from the start to the end [m]."""
        return float(np.linalg.norm(self.position[-1] - self.position[0]))


def run_balance(
    robot: RobotSpec,
    duration: float,
    *,
    build: AsBuilt | None = None,
    seed: int = 0,
    push: Push | None = None,
    command: Callable[[float], tuple[float, float]] | None = None,
) -> BalanceRun:
    """Run a balancing robot's firmware on an empty floor.

    Args:
        robot: A balancing robot.
        duration: Seconds to run [s].
        build: The robot as built (nominal if None).
        seed: Sensor-noise seed.
        push: A push, if any.
        command: Wheel-speed command (left, right) [rad/s] at a time [s]; standing still if None.

    Returns:
        The run, cut at a fall.
    """
    base_model = build_model(robot).model
    m = build.apply_to_model(base_model) if build is not None and not build.is_nominal else base_model
    d = mujoco.MjData(m)
    set_pose(m, d, Pose2D(0.0, 0.0, 0.0), settle=0.0)
    fw = make_firmware(robot, m, d, seed)
    wiring = np.array([[m.jnt_dofadr[m.joint(f"wheel_{s}_joint").id] for s in ("left", "right")],
                       [m.actuator(f"wheel_{s}_motor").id for s in ("left", "right")]], dtype=np.int64)  # fmt: skip
    n = round(duration * fw.controller.gains.rate)
    cmd = np.zeros((1, 2))
    times, pitch, pos = np.zeros(n + 1), np.zeros(n + 1), np.zeros((n + 1, 2))
    fw.push = push
    i = 0
    for i in range(n + 1):
        times[i], pitch[i], pos[i] = d.time, body_pitch(d.qpos[3:7]), d.qpos[:2]
        if i == n:
            break
        if command is not None:
            cmd[0] = command(float(d.time))
        fw.drive(cmd, 0, d.qvel, d.ctrl, wiring)
        if fw.fell_at is not None:
            break
        mujoco.mj_step(m, d, fw.steps)
    return BalanceRun(times[: i + 1], pitch[: i + 1], pos[: i + 1], fw.fell_at)


def _apply_push(model: mujoco.MjModel, data: mujoco.MjData, body: int, force_n: float) -> None:
    """Set the base's applied force: ``force_n`` [N] forward along the heading, at the top of the chassis."""
    g = model.geom("chassis").id
    top = data.geom_xpos[g] + data.geom_xmat[g].reshape(3, 3) @ np.array([0.0, 0.0, model.geom_size[g, 2]])
    heading = data.xmat[body].reshape(3, 3)[:, 0].copy()
    heading[2] = 0.0
    force = heading / np.linalg.norm(heading) * force_n
    data.xfrc_applied[body, :3] = force  # at the body's centre of mass, with the moment of the offset
    data.xfrc_applied[body, 3:] = np.cross(top - data.xipos[body], force)
