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

The supply. The battery's voltage V_batt is the robot's profile value ``battery_voltage`` (the
model's ``nhsim_motor_battery_voltage``, overridden per run with ``--motors battery_voltage=V``). The
motor's constants g = k_t / R and b = k_t k_e / R do not depend on it, so a pack at another voltage
moves the stall torque (g V_batt) and the no-load speed (V_batt / k_e = (g / b) V_batt) in
proportion and leaves the back-EMF constant fixed (:meth:`MotorModel.at_voltage`); the drive's
``ctrlrange`` follows (:func:`apply_supply`). The wheel-speed limit the planners and trackers keep
to is derived from the same voltage (:func:`wheel_speed_limit`, :class:`Supply`): the no-load speed
at the voltage left under load (V_batt minus the pack's sag), less the speed that the torque
reserve kept for load and for the loop costs, rounded down to 0.1 rad/s, and never above the
firmware's cap; the linear and turning limits follow from it (:func:`supplied_robot`). A model's
own limit numerics must be this rule at its own voltage (checked).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.checks import check_fields
from planning.core.robot import RobotSpec
from planning.errors import ConfigError, ModelError, option

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


#: Lowest control rate [Hz] (a period of at most a second).
MIN_CONTROL_RATE = 1.0


def whole_steps(duration: float, timestep: float) -> int:
    """``duration / timestep`` when that is a whole number >= 1 (to 1e-6), else 0."""
    ratio = duration / timestep
    k = round(ratio)
    return k if k >= 1 and abs(ratio - k) <= 1e-6 else 0


#: Control rates a message suggests, those of them that divide the model's physics rate (:func:`suggested_rates`):
#: each divides the built-in robots' physics rates and is a whole number of periods of their pose fixes (5 and
#: 10 Hz; 25 Hz, suggested once, is not of the EduMIP's).
RATES = (10, 20, 50, 100)


def suggested_rates(timestep: float) -> str:
    """The rates of :data:`RATES` a period of whole ``timestep`` [s] steps takes, as a message suggests them
    (``"(e.g. 10 or 50 Hz)"`` on 20 ms steps: 20 and 100 Hz are not whole steps there); the physics rate and its
    halves when none of them is."""
    fits: list[float] = [r for r in RATES if whole_steps(1.0 / r, timestep)]
    if not fits:
        rate = 1.0 / timestep
        fits = [rate / k for k in (4, 2, 1) if rate / k >= MIN_CONTROL_RATE]
    said = [f"{r:g}" for r in fits]
    return f"(e.g. {', '.join(said[:-1])} or {said[-1]} Hz)" if len(said) > 1 else f"(e.g. {said[0]} Hz)"


def control_steps(control_rate: float, timestep: float) -> int:
    """Physics steps of ``timestep`` [s] per control period at ``control_rate`` [Hz].

    Raises:
        ConfigError: A rate below :data:`MIN_CONTROL_RATE`, or a period that is not a whole number of steps;
            the message names rates that divide.
    """
    if not control_rate >= MIN_CONTROL_RATE:
        raise ConfigError(
            f"control rate {control_rate:g} Hz is below {MIN_CONTROL_RATE:g} Hz: no tracker steers a wheeled robot "
            f"once a second or less; choose a rate that divides {1.0 / timestep:g} Hz {suggested_rates(timestep)}"
        )
    k = whole_steps(1.0 / control_rate, timestep)
    if not k:
        raise ConfigError(
            f"control rate {control_rate:g} Hz is not a whole number of {timestep * 1e3:g} ms physics steps; "
            f"choose a rate that divides {1.0 / timestep:g} Hz {suggested_rates(timestep)}"
        )
    return k


#: The limits of :class:`MotorModel`'s fields (:func:`planning.core.checks.check_number`).
_MOTOR_LIMITS: dict[str, dict[str, Any]] = {
    "battery_voltage": {"above": 0.0, "unit": "V"},
    "stall_torque": {"above": 0.0, "unit": "N m"},
    "no_load_speed": {"above": 0.0, "unit": "rad/s"},
    "ki": {"above": 0.0, "unit": "V/rad"},
    "period": {"above": 0.0, "unit": "s"},
    "kp": {"at_least": 0.0, "unit": "V s/rad"},
    "kff": {"at_least": 0.0, "unit": "V s/rad"},
}


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
        check_fields(self, _MOTOR_LIMITS, "MotorModel.")
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

    def at_voltage(self, voltage: float) -> MotorModel:
        """The same motor on a supply of ``voltage`` [V]: stall torque g V and no-load speed (g / b) V
        scale with it, g and b (the torque and back-EMF constants over the winding's resistance) stay;
        ``self`` when the voltage is its own.

        Raises:
            ConfigError: The voltage is not a finite number > 0, or the loop is unstable at it.
        """
        if voltage == self.battery_voltage:
            return self
        ratio = voltage / self.battery_voltage
        return replace(
            self,
            battery_voltage=voltage,
            stall_torque=self.stall_torque * ratio,
            no_load_speed=self.no_load_speed * ratio,
        )

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


#: Supply field -> <custom><numeric> name in the MJCF (a robot without them has a fixed supply).
SUPPLY_NUMERICS = {
    "battery_voltage": "nhsim_motor_battery_voltage",
    "min_voltage": "nhsim_motor_min_voltage",
    "max_voltage": "nhsim_motor_max_voltage",
    "supply_sag": "nhsim_motor_supply_sag",
    "torque_reserve": "nhsim_motor_torque_reserve",
    "speed_cap": "nhsim_motor_speed_cap",
}
#: The supply fields ``--motors`` may set.
SUPPLY_KEYS = ("battery_voltage", "supply_sag", "torque_reserve")
#: A valid value of each, for messages (a charged 3-cell pack; the TurtleBot3's own margins).
SUPPLY_EXAMPLES = {"battery_voltage": 12.6, "supply_sag": 0.6, "torque_reserve": 0.1}
#: Steps per unit the limits are rounded down to: the wheel-speed limit to 0.1 rad/s, the linear limit to
#: 1 mm/s, the turning one to 0.01 rad/s; the tolerance keeps a whole step (5.0) from rounding down a step.
_SPEED_STEPS, _LINEAR_STEPS, _TURN_STEPS, _FLOOR_TOL = 10, 1000, 100, 1e-9


@dataclass(frozen=True)
class Supply:
    """A robot's battery and the margins its wheel-speed limit keeps from it.

    Attributes:
        battery_voltage: The pack's voltage V_batt [V], the drive's voltage bound.
        min_voltage: Lowest voltage the motors are rated for [V].
        max_voltage: Highest voltage the motors are rated for [V].
        supply_sag: Voltage the pack loses under the motors' load [V].
        torque_reserve: Fraction of the stall torque (at the loaded voltage) kept for load and for the
            velocity loop to correct, in [0, 1).
        speed_cap: The firmware's wheel-speed cap [rad/s].
    """

    battery_voltage: float
    min_voltage: float
    max_voltage: float
    supply_sag: float
    torque_reserve: float
    speed_cap: float

    def __post_init__(self) -> None:
        limits: dict[str, dict[str, Any]] = {
            f.name: {"fix": f"give e.g. {f.name}={SUPPLY_EXAMPLES.get(f.name, 1.0):g}"} for f in fields(self)
        }
        limits["speed_cap"] |= {"above": 0.0, "unit": "rad/s"}
        check_fields(self, limits, "motors: ")
        v, lo, hi = self.battery_voltage, self.min_voltage, self.max_voltage
        if not lo <= v <= hi:
            raise ConfigError(
                f"motors: battery_voltage = {v:g} V is outside the {lo:g}-{hi:g} V the motors are rated for; give a "
                f"voltage in that range (e.g. battery_voltage={hi:g}, the highest)"
            )
        if not 0 <= self.supply_sag < v:
            raise ConfigError(f"motors: supply_sag must be in [0, battery_voltage) [V], got {self.supply_sag!r}")
        if not 0 <= self.torque_reserve < 1:
            raise ConfigError(f"motors: torque_reserve must be a fraction in [0, 1), got {self.torque_reserve!r}")

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> Supply | None:
        """The supply of a compiled model (its ``nhsim_motor_*`` supply numerics); None when it has none
        but the battery voltage (a robot whose supply is fixed).

        Raises:
            ModelError: Some of the supply numerics but not all, or bad values (named).
        """
        values: dict[str, float] = {}
        for name, key in SUPPLY_NUMERICS.items():
            try:
                values[name] = float(model.numeric(key).data[0])
            except KeyError:
                continue
        if set(values) <= {"battery_voltage"}:
            return None
        missing = [SUPPLY_NUMERICS[k] for k in SUPPLY_NUMERICS if k not in values]
        if missing:
            given = ", ".join(SUPPLY_NUMERICS[k] for k in SUPPLY_NUMERICS if k in values)
            raise ModelError(
                f"model supply numerics: {', '.join(missing)} missing beside {given}: give all of "
                f"{', '.join(SUPPLY_NUMERICS.values())} (the supply's ratings, which the speed limits are checked "
                "against), or none but nhsim_motor_battery_voltage (a fixed supply, its limits not checked)"
            )
        try:
            return cls(**values)
        except ConfigError as exc:
            raise ModelError(f"model supply numerics: {exc}") from exc

    def with_overrides(self, text: str) -> Supply:
        """This supply with ``key=value,...`` overrides of :data:`SUPPLY_KEYS` (``--motors``).

        Raises:
            ConfigError: An unknown key, a malformed item, a value that is not a number or out of range
                (naming the field and the fix).
        """
        changes: dict[str, float] = {}
        for item in (p.strip() for p in text.split(",")):
            if not item:
                continue
            key, eq, raw = (x.strip() for x in item.partition("="))
            if not eq:
                raise ConfigError(
                    f"{option('motors', text)}: expected KEY=VALUE, got {item!r} (e.g. battery_voltage=12.6)"
                )
            if key not in SUPPLY_KEYS:
                raise ConfigError(
                    f"{option('motors', text)}: unknown key {key!r}; choose from {', '.join(SUPPLY_KEYS)}"
                )
            try:
                changes[key] = float(raw)
            except ValueError:
                raise ConfigError(
                    f"motors: {key} must be a number, got {raw!r}; give e.g. {key}={getattr(self, key):g}"
                ) from None
        return replace(self, **changes)


def _floor(value: float, steps: int) -> float:
    """``value`` rounded down to a whole number of 1 / ``steps`` (a value within 1e-9 steps of one stays):
    the float nearest that decimal, as the number written in a model file reads."""
    return math.floor(value * steps + _FLOOR_TOL) / steps


def wheel_speed_limit(motor: MotorModel, supply: Supply) -> float:
    """The wheel speed [rad/s] the motors sustain on ``supply`` with its torque reserve: (1 - reserve)
    times the no-load speed at the loaded voltage (V_batt - sag), rounded down to 0.1 rad/s, capped by
    the firmware (``motor``'s constants; its own voltage does not matter)."""
    loaded = motor.speed_per_volt * (supply.battery_voltage - supply.supply_sag)
    return min(supply.speed_cap, _floor((1.0 - supply.torque_reserve) * loaded, _SPEED_STEPS))


def speed_limits(motor: MotorModel, supply: Supply, wheel_radius: float, track_width: float) -> dict[str, float]:
    """The robot's limits on ``supply``: ``max_wheel_speed`` [rad/s], ``max_speed`` (r times it, rounded
    down to 1 mm/s) [m/s] and ``max_yaw_rate`` (turning in place, 2 r times it over the track, rounded
    down to 0.01 rad/s) [rad/s]."""
    wheel = wheel_speed_limit(motor, supply)
    return {
        "max_wheel_speed": wheel,
        "max_speed": _floor(wheel_radius * wheel, _LINEAR_STEPS),
        "max_yaw_rate": _floor(2.0 * wheel_radius * wheel / track_width, _TURN_STEPS),
    }


def supplied_robot(spec: RobotSpec, overrides: str = "") -> RobotSpec:
    """The robot on its supply with ``--motors`` overrides: its battery voltage and the limits that
    follow from it; ``spec`` itself without overrides.

    Raises:
        ConfigError: Overrides for a robot whose supply is fixed, or bad overrides (named).
        ModelError: The model's own limit numerics are not the rule at its own voltage.
    """
    if not overrides.strip():
        return spec
    model = mujoco.MjModel.from_xml_path(str(spec.mjcf))
    supply = Supply.from_model(model)
    if supply is None:
        drop = option("motors", python='motors=""')
        why = (
            "; the EduMIP's firmware scales its duty cycle by the nominal over the measured battery voltage, so its "
            "motors see the nominal 7.4 V of its 2-cell pack at any charge"
            if spec.name.startswith("edumip")
            else ""
        )
        raise ConfigError(
            f"robot {spec.name!r} runs on a fixed supply of {spec.battery_voltage:g} V (its model gives no supply "
            f"ratings{why}): drop {drop}"
        )
    motor = MotorModel.from_model(model)
    check_model_limits(spec, motor, supply)
    own = speed_limits(motor, supply, spec.wheel_radius, spec.track_width)
    new = supply.with_overrides(overrides)
    limits = speed_limits(motor, new, spec.wheel_radius, spec.track_width)
    # a limit the model sets below the rule at its own supply is its firmware's cap, kept on any supply
    capped = {k: min(v, getattr(spec, k)) if getattr(spec, k) < own[k] else v for k, v in limits.items()}
    return replace(
        spec,
        battery_voltage=new.battery_voltage,
        max_wheel_speed=capped["max_wheel_speed"],
        max_speed=capped["max_speed"],
        max_yaw_rate=capped["max_yaw_rate"],
    )


def check_model_limits(spec: RobotSpec, motor: MotorModel, supply: Supply) -> None:
    """Raise unless the model's limit numerics (``spec``'s) are at most :func:`speed_limits` at its own supply (a
    limit below the rule is a cap of the robot's firmware, which the motors sustain).

    Raises:
        ModelError: A limit above the rule's (named, with the rule's value).
    """
    want = speed_limits(motor, supply, spec.wheel_radius, spec.track_width)
    wrong = [f"{k} = {getattr(spec, k)!r}, the rule gives {v!r}" for k, v in want.items() if getattr(spec, k) > v]
    if wrong:
        raise ModelError(
            f"{spec.mjcf}: the speed limits are beyond what its motors sustain on its supply: {'; '.join(wrong)}; "
            "write the rule's values (nhsim_max_wheel_speed, nhsim_max_linear_speed, nhsim_max_angular_speed) or "
            "lower ones (a firmware cap), or give the motors and supply that sustain yours (the nhsim_motor_* numerics)"
        )


def apply_supply(model: mujoco.MjModel, voltage: float) -> None:
    """Put a compiled model's wheel motors on a supply of ``voltage`` [V], in place: the motor numerics
    (:meth:`MotorModel.at_voltage`) and the actuators' ``ctrlrange``; nothing when it is the model's own.

    Raises:
        ModelError: The model's motors are not the DC motors of its numerics.
    """
    try:
        own = float(model.numeric(NUMERICS["battery_voltage"]).data[0])
    except KeyError as exc:
        raise ModelError(
            f"model has no <custom><numeric name={NUMERICS['battery_voltage']!r}>: add its battery voltage"
        ) from exc
    if voltage == own:
        return
    new = MotorModel.from_model(model).at_voltage(voltage)
    for name in ("battery_voltage", "stall_torque", "no_load_speed"):
        model.numeric_data[model.numeric_adr[model.numeric(NUMERICS[name]).id]] = getattr(new, name)
    for name in WHEEL_ACTUATORS:
        model.actuator_ctrlrange[model.actuator(name).id] = (-voltage, voltage)
