"""DC wheel motors: their electrics in the model, their constants, and the bound that keeps their firmware stable.

The motor. Each wheel is driven by a geared DC motor, modelled in the MJCF as a ``general``
actuator with ``gaintype="fixed"`` and ``biastype="affine"``::

    torque = g u - b omega,     g = tau_stall / V_batt,     b = tau_stall / omega_nl,

with u the motor voltage [V] (``ctrlrange`` = +-V_batt), omega the wheel speed [rad/s], tau_stall
the stall torque [N m] at the wheel at V_batt and omega_nl the no-load wheel speed [rad/s] at V_batt:
full voltage gives the stall torque at rest and no torque at the no-load speed, the straight
torque-speed line of a DC motor whose inductance is negligible at these rates. The constants are
``<custom><numeric name="nhsim_motor_...">`` entries of the model, so code reads them from the model
(:meth:`MotorModel.from_model`), which also checks that the actuators agree with them.

Stability bound of the firmware velocity loop (:mod:`sim.robot.wheel_firmware`). Let K = g / b =
omega_nl / V_batt [rad/s per V] be the motor's static speed gain and tau = J / b its time constant
with J the inertia the wheel drives (its own, the armature, its share of the robot).
Over one period at constant u the wheel speed obeys the exact step response::

    omega_{k+1} = a omega_k + (1 - a) K u_k,     a = exp(-T / tau) in [0, 1).

With r = 0 (feed-forward acts on the command only, not on the loop) and e = -omega, the loop
u_k = -kp omega_k - ki T sum_{j<=k} omega_j closes to (z transform; S = z Omega / (z - 1))::

    (z - a)(z - 1) + (1 - a) K (kp (z - 1) + ki T z) = 0
    z^2 - (1 + a - P - I) z + (a - P) = 0,     P = (1 - a) K kp,  I = (1 - a) K ki T.

Jury's test for z^2 + c1 z + c0 asks p(1) > 0, p(-1) > 0 and |c0| < 1: p(1) = I > 0 holds for
ki > 0; p(-1) = 2 (1 + a) - 2 P - I > 0 gives ``(1 - a) K (2 kp + ki T) < 2 (1 + a)``, and it
implies |a - P| < 1. Since (1 + a) / (1 - a) >= 1 for every a in [0, 1), the loop is stable for every
load inertia, including a wheel lifted off the floor (J small, a -> 0, the hardest case), when::

    K (2 kp + ki T) < 2,    i.e.  T < T_max = (2 / K - 2 kp) / ki.

Both wheels coupled through the floor share the same argument: the plant is
omega_{k+1} = A omega_k + (1 - A) K u_k with A = expm(-T b J^-1) for the symmetric positive-definite
2x2 inertia J, and the identical diagonal controller commutes with it, so every mode of J obeys the
scalar bound with its own a. Saturation only removes gain, and the clamped integrator cannot wind
up. :meth:`MotorModel.max_period` returns T_max, and a model whose ``nhsim_motor_period`` is not
below it is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.errors import ConfigError, ModelError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: The wheel actuators the firmware drives, in the order [left, right].
WHEEL_ACTUATORS = ("wheel_left_motor", "wheel_right_motor")
#: Field -> <custom><numeric> name in the MJCF.
NUMERICS = {
    "battery_voltage": "nhsim_motor_battery_voltage",
    "stall_torque": "nhsim_motor_stall_torque",
    "no_load_speed": "nhsim_motor_no_load_speed",
    "kp": "nhsim_motor_kp",
    "ki": "nhsim_motor_ki",
    "kff": "nhsim_motor_kff",
    "period": "nhsim_motor_period",
}
#: Relative tolerance when the actuators' parameters are compared with the numerics.
_MATCH = 1e-6


def whole_steps(duration: float, timestep: float) -> int:
    """``duration / timestep`` when that is a whole number >= 1 (to 1e-6), else 0."""
    ratio = duration / timestep
    k = round(ratio)
    return k if k >= 1 and abs(ratio - k) <= 1e-6 else 0


@dataclass(frozen=True)
class MotorModel:
    """A wheel motor (at the wheel, gearbox included) and the gains of its firmware velocity loop.

    Attributes:
        battery_voltage: V_batt, the voltage bound of the drive [V].
        stall_torque: Torque at rest with V_batt applied [N m].
        no_load_speed: Wheel speed with V_batt applied and no load [rad/s].
        kp: Proportional gain [V s/rad].
        ki: Integral gain [V/rad].
        kff: Feed-forward gain on the commanded speed [V s/rad] (0 for none).
        period: Time between the firmware's updates T [s]; below :meth:`max_period`.
    """

    battery_voltage: float
    stall_torque: float
    no_load_speed: float
    kp: float
    ki: float
    kff: float
    period: float

    def __post_init__(self) -> None:
        for name in ("battery_voltage", "stall_torque", "no_load_speed", "ki", "period"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"MotorModel.{name} must be a finite number > 0, got {value!r}")
        for name in ("kp", "kff"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"MotorModel.{name} must be a finite number >= 0, got {value!r}")
        if self.max_period() <= 0:
            raise ConfigError(
                f"MotorModel.kp = {self.kp:g} V s/rad leaves no stable loop period: 2 kp must be below "
                f"2 / K = {2 / self.speed_per_volt:g} V s/rad; lower kp"
            )
        if self.period >= self.max_period():
            raise ConfigError(
                f"MotorModel.period = {self.period:g} s is not below the loop's stability bound "
                f"T_max = (2 / K - 2 kp) / ki = {self.max_period():.4g} s; update the firmware more often or lower ki"
            )

    @property
    def gain(self) -> float:
        """g = stall torque / battery voltage [N m / V]: the actuator's ``gainprm[0]``."""
        return self.stall_torque / self.battery_voltage

    @property
    def damping(self) -> float:
        """b = stall torque / no-load speed [N m s/rad]: minus the actuator's ``biasprm[2]``."""
        return self.stall_torque / self.no_load_speed

    @property
    def speed_per_volt(self) -> float:
        """K = g / b, the no-load wheel speed per volt [rad/s / V]."""
        return self.no_load_speed / self.battery_voltage

    def max_period(self) -> float:
        """T_max = (2 / K - 2 kp) / ki [s]: the loop is stable for every load below this period."""
        return (2.0 / self.speed_per_volt - 2.0 * self.kp) / self.ki

    def loop_gain(self, period: float) -> float:
        """K (2 kp + ki T) for a loop period T [s]: stable for every load when below 2."""
        return self.speed_per_volt * (2.0 * self.kp + self.ki * period)

    def torque(self, voltage: ArrayLike, speed: ArrayLike) -> FloatArray:
        """Motor torque g u - b omega [N m] for voltages [V] and wheel speeds [rad/s] (broadcast)."""
        return self.gain * np.asarray(voltage, dtype=float) - self.damping * np.asarray(speed, dtype=float)

    def no_load_voltage(self, speed: ArrayLike) -> FloatArray:
        """The voltage [V] that holds a wheel at ``speed`` [rad/s] without load, clipped to the battery."""
        v = np.asarray(speed, dtype=float) / self.speed_per_volt
        return np.clip(v, -self.battery_voltage, self.battery_voltage)

    def steps_per_update(self, timestep: float) -> int:
        """Physics steps of ``timestep`` [s] per firmware update.

        Raises:
            ConfigError: The period is not a whole number of physics steps.
        """
        k = whole_steps(self.period, timestep)
        if not k:
            raise ConfigError(
                f"motor firmware period {self.period:g} s is not a whole number of {timestep * 1e3:g} ms physics "
                f"steps; set nhsim_motor_period to a multiple of the timestep"
            )
        return k

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> MotorModel:
        """Read the motor constants and gains from a compiled model's ``nhsim_motor_*`` numerics.

        The wheel actuators must be the DC motors the numerics describe: ``general`` with a fixed
        gain g and an affine bias -b omega, ``ctrlrange`` = +-V_batt and limited.

        Raises:
            ModelError: A numeric or an actuator is missing, or an actuator disagrees (named).
        """
        values: dict[str, float] = {}
        for field_name, key in NUMERICS.items():
            try:
                data = model.numeric(key).data
            except KeyError as exc:
                raise ModelError(
                    f"model has no <custom><numeric name={key!r}>: add the motor's {field_name.replace('_', ' ')}"
                ) from exc
            if data.size != 1:
                raise ModelError(f"<numeric name={key!r}> needs one number, got {data.size}")
            values[field_name] = float(data[0])
        try:
            motor = cls(**values)
        except ConfigError as exc:
            raise ModelError(f"model motor numerics: {exc}") from exc
        for name in WHEEL_ACTUATORS:
            motor._check_actuator(model, name)
        return motor

    def _check_actuator(self, model: mujoco.MjModel, name: str) -> None:
        try:
            a = model.actuator(name).id
        except KeyError as exc:
            raise ModelError(f"model has no actuator {name!r} (the wheel's DC motor)") from exc
        problems = []
        if model.actuator_gaintype[a] != mujoco.mjtGain.mjGAIN_FIXED:
            problems.append("gaintype must be fixed")
        if model.actuator_biastype[a] != mujoco.mjtBias.mjBIAS_AFFINE:
            problems.append("biastype must be affine")
        if not math.isclose(float(model.actuator_gainprm[a, 0]), self.gain, rel_tol=_MATCH):
            problems.append(f"gainprm {model.actuator_gainprm[a, 0]:g} != stall torque / V_batt = {self.gain:.6g}")
        bias = model.actuator_biasprm[a, :3]
        if bias[0] != 0 or bias[1] != 0 or not math.isclose(-float(bias[2]), self.damping, rel_tol=_MATCH):
            problems.append(f"biasprm {bias.tolist()} != [0, 0, -stall torque / no-load speed = {-self.damping:.6g}]")
        lo, hi = model.actuator_ctrlrange[a]
        vb = self.battery_voltage
        if not (
            model.actuator_ctrllimited[a]
            and math.isclose(hi, vb, rel_tol=_MATCH)
            and math.isclose(-lo, vb, rel_tol=_MATCH)
        ):
            problems.append(f"ctrlrange [{lo:g}, {hi:g}] must be limited to +-V_batt = {vb:g}")
        if problems:
            raise ModelError(
                f"actuator {name!r} is not the DC motor of the nhsim_motor_* numerics: {'; '.join(problems)}"
            )
