"""The balance firmware of a mobile inverted pendulum: pitch from the IMU, an LQR on pitch and wheel
position, and a turn loop on the wheel difference.

It runs at ``rate`` (200 Hz on the balancing EduMIP) and drives the motor voltages directly, in
place of the wheel-speed firmware of the skid robots. Per update of period T:

1. Pitch estimate (complementary filter, as the MAE 144 balance labs on the Robotics Cape do): the
   accelerometer's tilt ``theta_a = atan2(-a_x, a_z)`` (a the specific force in the body frame;
   pitch positive tips the top forward, +x) is low-passed and the gyroscope's pitch rate
   integrated and high-passed with the same time constant tau, in one line::

       theta_k = alpha (theta_{k-1} + T omega_y) + (1 - alpha) theta_a,   alpha = tau / (tau + T).

2. Wheel position ``phi = mean(wheel angles from the encoders) + theta`` (the wheel's angle in the
   world, as ``rc_balance`` computes it) and its rate by a difference over one period.
3. References from the wheel-speed command (left, right) [rad/s] the tracker's (v, omega) maps to:
   the mean moves the wheel-position reference ``phi_ref += T mean``, the half difference is the
   turn loop's target.
4. Forward: ``u = kff phi_dot_ref - K [theta, theta_dot, phi - phi_ref, phi_dot - phi_dot_ref,
   integral of (phi - phi_ref)]`` [V], K the LQR gains designed from the model
   (:mod:`sim.physics.balance`), kff the no-load voltage per wheel speed (the voltage that moves the
   wheels at the reference speed with no torque). Leaning forward to accelerate is the LQR's: the
   pitch set-point is implicit in the position and speed errors (``theta_ref = -(K_phi e_phi + ...)
   / K_theta``), as rc_balance's outer loop sets the inner loop's pitch set-point.
5. Turn: a PI on the half difference of the wheel speeds with the no-load feed-forward, ``u_d``.
6. Voltages ``u - u_d`` (left) and ``u + u_d`` (right), clipped to the battery.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

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
    """

    rate: float
    k: tuple[float, ...]
    filter_time_constant: float
    kff: float
    turn_kp: float
    turn_ki: float
    battery_voltage: float

    def __post_init__(self) -> None:
        if len(self.k) != len(STATE_NAMES):
            raise ConfigError(
                f"balance gains k need {len(STATE_NAMES)} numbers ({', '.join(STATE_NAMES)}), got {self.k}"
            )
        for name in ("rate", "filter_time_constant", "battery_voltage"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"balance {name} must be a finite number > 0, got {value!r}")
        if not all(math.isfinite(x) for x in (*self.k, self.kff, self.turn_kp, self.turn_ki)):
            raise ConfigError(f"balance gains must be finite numbers, got k={self.k}")

    @property
    def period(self) -> float:
        """T = 1 / rate [s]."""
        return 1.0 / self.rate


class BalanceController:
    """The balance firmware's state and its update (see the module docstring).

    Args:
        gains: Rates and gains.
    """

    def __init__(self, gains: BalanceGains) -> None:
        self.gains = gains
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
        self.theta = a * (self.theta + t * gyro_y) + (1.0 - a) * math.atan2(-float(accel[0]), float(accel[2]))
        last = self._last_angles if self._last_angles is not None else angles
        self._last_angles = angles
        phi = 0.5 * (angles[0] + angles[1]) + self.theta
        phi_dot = (phi - self.phi) / t
        self.phi = phi
        mean_ref, half_ref = 0.5 * (command[0] + command[1]), 0.5 * (command[1] - command[0])
        self.phi_ref += t * mean_ref
        e_phi = phi - self.phi_ref
        self.integral += t * e_phi
        k = self._k
        e_rest = k[2] * e_phi + k[3] * (phi_dot - mean_ref) + k[4] * self.integral
        self.theta_ref = -e_rest / k[0] if k[0] else 0.0
        u = g.kff * mean_ref - k[0] * self.theta - k[1] * gyro_y - e_rest
        half = 0.5 * ((angles[1] - last[1]) - (angles[0] - last[0])) / t
        e_turn = half_ref - half
        self.turn_integral = min(
            max(self.turn_integral + g.turn_ki * t * e_turn, -g.battery_voltage), g.battery_voltage
        )
        u_d = g.kff * half_ref + g.turn_kp * e_turn + self.turn_integral
        vb = g.battery_voltage
        return min(max(u - u_d, -vb), vb), min(max(u + u_d, -vb), vb)
