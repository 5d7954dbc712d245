"""The balance firmware of a mobile inverted pendulum: pitch from the IMU, an LQR on pitch and wheel
position, and a turn loop on the wheel difference.

It runs at ``rate`` (200 Hz on the balancing EduMIP) and drives the motor voltages directly, in
place of the wheel-speed firmware of the skid robots. Per update of period T:

1. Pitch estimate (complementary filter, as the MAE 144 balance labs on the Robotics Cape do): the
   accelerometer's tilt (a the specific force in the body frame; pitch positive tips the top
   forward, +x) is low-passed and the gyroscope's pitch rate integrated and high-passed with the
   same time constant tau, in one line::

       theta_k = alpha (theta_{k-1} + T omega_y) + (1 - alpha) theta_a,   alpha = tau / (tau + T).

   Accelerating forward at a_f adds ``a_f`` along the world's x to the specific force, so the plain
   tilt ``atan2(-a_x, a_z)`` reads low by about a_f / g (0.03 rad at 0.3 m/s^2; over a 1.5 s
   acceleration the filter believed it, the robot stood 0.012 rad less leant than it meant and
   ran 2 cm ahead). The firmware knows the acceleration it asks for over the last period (step 3),
   ``a_f = r phi_ddot_ref``, and takes it out: ``theta_a = atan2(a_f cos theta - a_x, a_z - a_f sin
   theta)`` with theta the last estimate.
2. Wheel position ``phi = mean(wheel angles from the encoders) + theta`` (the wheel's angle in the
   world, as ``rc_balance`` computes it) and its rate by a difference over one period.
3. Reference from the wheel-speed command (left, right) [rad/s] the tracker's (v, omega) maps to.
   The mean is the wheel-speed set-point; it changes once per command period T_c (the tracker's,
   20 ms at 50 Hz), and the reference speed ``phi_dot_ref`` ramps from where it is to each new
   set-point over the next T_c, at ``phi_ddot_ref = (set-point - phi_dot_ref) / T_c``: the
   acceleration the tracker asked for (an FBL tracker's v is its integrated acceleration command),
   one command period late. ``phi_ref`` integrates ``phi_dot_ref`` exactly (trapezoid on the ramp).
   The half difference is the turn loop's target.
4. Feed-forward of that motion: a steady acceleration ``a = r phi_ddot_ref`` needs the body leant
   by ``theta_ff = c_theta a`` and a voltage ``u_ff = kff phi_dot_ref + c_u a`` (kff the no-load
   voltage per wheel speed, the back-EMF; c_theta and c_u derived from the model in
   :class:`sim.physics.sagittal.SagittalParams`). On a ramp the reference (theta_ff, 0, phi_ref,
   phi_dot_ref) is a steady solution of the model's linearisation under u_ff; between ramps the
   lean steps and the loop takes the step as an error.
5. Forward: ``u = u_ff - K [theta - theta_ff, theta_dot, phi - phi_ref, phi_dot - phi_dot_ref,
   integral of (phi - phi_ref)]`` [V], K the LQR gains designed from the model
   (:mod:`sim.robot.balance_design`), the speed error against the reference's mean speed over the period
   the encoder difference spans. Beyond the feed-forward, leaning is the LQR's: the pitch set-point
   is ``theta_ref = theta_ff - (K_phi e_phi + ...) / K_theta``, as rc_balance's outer loop sets the
   inner loop's pitch set-point.
6. Turn: a PI on the half difference of the wheel speeds with the no-load feed-forward, ``u_d``.
7. Voltages ``u - u_d`` (left) and ``u + u_d`` (right), clipped to the battery.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.core.checks import check_fields, check_number
from planning.errors import ConfigError

FloatArray = NDArray[np.float64]

#: Names of the LQR state, in the order of the gains.
STATE_NAMES = ("theta", "theta_dot", "phi_error", "phi_dot_error", "phi_error_integral")


@dataclass(frozen=True)
class BalanceGains:
    """The balance firmware's rates and gains.

    Attributes:
        rate: Updates per second [Hz].
        k: (5,) LQR gains on :data:`STATE_NAMES` [V/rad, V s/rad, V/rad, V s/rad, V/(rad s)].
        filter_time_constant: Complementary filter's tau [s].
        kff: No-load voltage per wheel speed [V s/rad].
        turn_kp: Turn loop's proportional gain [V s/rad].
        turn_ki: Turn loop's integral gain [V/rad].
        battery_voltage: Voltage bound [V].
        lean_per_accel: c_theta r, the steady lean per wheel acceleration [rad per rad/s^2].
        voltage_per_accel: c_u r, the voltage per wheel acceleration beyond the back-EMF [V per rad/s^2].
        wheel_radius: r [m] (the forward acceleration the accelerometer reads is r phi_ddot).
    """

    rate: float
    k: tuple[float, ...]
    filter_time_constant: float
    kff: float
    turn_kp: float
    turn_ki: float
    battery_voltage: float
    lean_per_accel: float
    voltage_per_accel: float
    wheel_radius: float

    def __post_init__(self) -> None:
        if len(self.k) != len(STATE_NAMES):
            raise ConfigError(
                f"balance gains k need {len(STATE_NAMES)} numbers ({', '.join(STATE_NAMES)}), got {self.k}"
            )
        units = {"rate": "Hz", "filter_time_constant": "s", "battery_voltage": "V"}
        check_fields(self, {name: {"above": 0.0, "unit": unit} for name, unit in units.items()}, "balance ")
        feed = (self.kff, self.lean_per_accel, self.voltage_per_accel, self.wheel_radius)
        if not all(math.isfinite(x) for x in (*self.k, *feed, self.turn_kp, self.turn_ki)):
            raise ConfigError(f"balance gains must be finite numbers, got k={self.k}, feed-forward {feed}")

    @property
    def period(self) -> float:
        """T = 1 / rate [s]."""
        return 1.0 / self.rate


class BalanceController:
    """The balance firmware's state and its update (see the module docstring).

    Args:
        gains: Rates and gains.
        command_period: T_c, how often the wheel-speed command changes [s] (the tracker's period);
            the firmware's own period if None (a command that may change at every update).

    Raises:
        ConfigError: A command period that is not a positive number.
    """

    def __init__(self, gains: BalanceGains, command_period: float | None = None) -> None:
        self.gains = gains
        period = gains.period if command_period is None else command_period
        check_number("balance command_period", period, above=0.0, unit="s")
        # the ramp spans the command period, to the nearest whole update (at least one)
        self._ramp_updates = max(1, round(period / gains.period))
        self._k = np.asarray(gains.k, dtype=float)
        t, tau = gains.period, gains.filter_time_constant
        self._alpha = tau / (tau + t)
        self.reset()

    def reset(self, theta: float = 0.0, phi: float = 0.0) -> None:
        """Start from pitch ``theta`` [rad] and wheel position ``phi`` [rad], at rest, references there."""
        self.theta = theta
        self.phi = phi
        self.phi_ref = phi
        self.integral = 0.0
        self.turn_integral = 0.0
        self._last_angles: tuple[float, float] | None = None
        self.theta_ref = 0.0
        self.speed_ref = 0.0  # the reference wheel speed now [rad/s]
        self.accel_ref = 0.0  # its rate over the coming period [rad/s^2]
        self._command = 0.0  # the mean wheel-speed command the ramp heads for [rad/s]
        self._ramp_left = 0  # updates left on the ramp

    def _reference(self, mean_command: float) -> tuple[float, float]:
        """Advance the reference over the last period and take up a new set-point ``mean_command``
        [rad/s] (step 3 of the module docstring).

        Returns:
            The reference's mean wheel speed over the last period and over the coming one [rad/s].
        """
        t = self.gains.period
        last = self.speed_ref + 0.5 * t * self.accel_ref
        self.phi_ref += t * last
        self.speed_ref += t * self.accel_ref
        self._ramp_left -= 1
        if self._ramp_left <= 0:
            self.speed_ref, self.accel_ref = self._command, 0.0
        if mean_command != self._command:
            self._command = mean_command
            self._ramp_left = self._ramp_updates
            self.accel_ref = (mean_command - self.speed_ref) / (self._ramp_updates * t)
        return last, self.speed_ref + 0.5 * t * self.accel_ref

    def update(
        self, gyro_y: float, accel: FloatArray, angles: tuple[float, float], command: tuple[float, float]
    ) -> tuple[float, float]:
        """One update.

        Args:
            gyro_y: Pitch rate from the gyroscope [rad/s].
            accel: (3,) specific force in the body frame from the accelerometer [m/s^2].
            angles: (left, right) wheel angles relative to the body from the encoders [rad].
            command: (left, right) wheel-speed command [rad/s].

        Returns:
            (left, right) motor voltages [V] within the battery's.
        """
        g, t = self.gains, self.gains.period
        a = self._alpha
        # the accelerometer's tilt, less the forward acceleration the reference asks for
        fwd, th = g.wheel_radius * self.accel_ref, self.theta
        tilt = math.atan2(fwd * math.cos(th) - float(accel[0]), float(accel[2]) - fwd * math.sin(th))
        self.theta = a * (self.theta + t * gyro_y) + (1.0 - a) * tilt
        last = self._last_angles if self._last_angles is not None else angles
        self._last_angles = angles
        phi = 0.5 * (angles[0] + angles[1]) + self.theta
        phi_dot = (phi - self.phi) / t
        self.phi = phi
        past, coming = self._reference(0.5 * (command[0] + command[1]))
        e_phi = phi - self.phi_ref
        self.integral += t * e_phi
        k = self._k
        e_rest = k[2] * e_phi + k[3] * (phi_dot - past) + k[4] * self.integral
        lean = g.lean_per_accel * self.accel_ref
        self.theta_ref = lean - e_rest / k[0] if k[0] else lean
        u_ff = g.kff * coming + g.voltage_per_accel * self.accel_ref
        u = u_ff - k[0] * (self.theta - lean) - k[1] * gyro_y - e_rest
        half_ref = 0.5 * (command[1] - command[0])
        half = 0.5 * ((angles[1] - last[1]) - (angles[0] - last[0])) / t
        e_turn = half_ref - half
        self.turn_integral = min(
            max(self.turn_integral + g.turn_ki * t * e_turn, -g.battery_voltage), g.battery_voltage
        )
        u_d = g.kff * half_ref + g.turn_kp * e_turn + self.turn_integral
        vb = g.battery_voltage
        return min(max(u - u_d, -vb), vb), min(max(u + u_d, -vb), vb)
