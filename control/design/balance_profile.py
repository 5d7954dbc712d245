"""A balancing robot's firmware settings: rates, Bryson weights, turn gains and stored LQR gains.

Read from ``models/balance/<robot>.toml``; the gains stored there are designed from the robot's
model by :func:`sim.robot.balance_design.design_balance` and checked stable before every run
(:func:`sim.robot.balance_design.balance_gains`).
"""

from __future__ import annotations

import math
import numbers
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planning.core.checks import check_number
from planning.core.robot import MODELS_DIR
from planning.errors import ConfigError

BALANCE_DIR = MODELS_DIR / "balance"
#: Profile keys: table -> keys.
PROFILE_KEYS = {
    "balance": ("rate", "filter_time_constant", "tip_angle", "max_lean"),
    "weights": ("theta_max", "theta_dot_max", "phi_max", "phi_dot_max", "phi_integral_max", "voltage_max"),
    "turn": ("kp", "ki"),
    "gains": ("k", "lean_per_accel", "voltage_per_accel"),
}


@dataclass(frozen=True)
class BalanceProfile:
    """A balancing robot's firmware settings (``models/balance/<robot>.toml``).

    Attributes:
        rate: Updates per second [Hz].
        filter_time_constant: Complementary filter's tau [s].
        tip_angle: |pitch| beyond which the robot has fallen [rad].
        max_lean: Lean allowed for the planned accelerations [rad] (:func:`balance_accel_limit`).
        maxima: (5,) Bryson maxima of :data:`control.balance.STATE_NAMES` [rad, rad/s, rad, rad/s, rad s].
        voltage_max: Bryson maximum of the voltage [V].
        turn_kp: Turn loop's proportional gain [V s/rad].
        turn_ki: Turn loop's integral gain [V/rad].
        k: (5,) stored gains [V per state unit].
        lean_per_accel: Stored steady lean per forward acceleration [rad per m/s^2]
            (:attr:`SagittalParams.lean_per_accel`).
        voltage_per_accel: Stored voltage per forward acceleration [V per m/s^2]
            (:attr:`SagittalParams.voltage_per_accel`).
        path: The file it was read from.
    """

    rate: float
    filter_time_constant: float
    tip_angle: float
    max_lean: float
    maxima: tuple[float, ...]
    voltage_max: float
    turn_kp: float
    turn_ki: float
    k: tuple[float, ...]
    lean_per_accel: float
    voltage_per_accel: float
    path: Path


def is_balancing(robot: str) -> bool:
    """True when the robot has a balance profile (``models/balance/<robot>.toml``): it balances."""
    return (BALANCE_DIR / f"{robot}.toml").is_file()


def balance_profile_path(robot: str) -> Path:
    """``models/balance/<robot>.toml``.

    Raises:
        ConfigError: The robot has no balance profile (it does not balance).
    """
    path = BALANCE_DIR / f"{robot}.toml"
    if not path.is_file():
        known = ", ".join(sorted(p.stem for p in BALANCE_DIR.glob("*.toml")))
        raise ConfigError(f"robot {robot!r} has no balance profile {path}: balancing robots are {known}")
    return path


#: The profile's numbers and their ranges (the keyword arguments of :func:`check_number`, and the unit): a
#: tip angle beyond a quarter turn is the body lying on the floor, a lean allowed at or beyond it a fall.
_RANGES: dict[str, dict[str, Any]] = {
    "balance.rate": {"above": 0.0, "unit": "Hz"},
    "balance.filter_time_constant": {"above": 0.0, "unit": "s"},
    "balance.tip_angle": {"above": 0.0, "at_most": math.pi / 2, "unit": "rad"},
    **{f"weights.{key}": {"above": 0.0} for key in PROFILE_KEYS["weights"]},
    "turn.kp": {"at_least": 0.0, "unit": "V s/rad"},
    "turn.ki": {"at_least": 0.0, "unit": "V/rad"},
    "gains.lean_per_accel": {"unit": "rad per m/s^2"},
    "gains.voltage_per_accel": {"unit": "V per m/s^2"},
}


def _check_values(path: Path, values: dict[str, Any]) -> None:
    """Raise :class:`ConfigError` naming the file, the table and the key of the first number out of its range
    (:data:`_RANGES`; the lean below the tip angle, and ``k`` one finite gain per state of
    :data:`control.balance.STATE_NAMES`)."""
    from control.balance import STATE_NAMES

    for name, limits in _RANGES.items():
        table, key = name.split(".")
        check_number(f"{path}: [{table}] {key}", values[name], **limits)
    tip = values["balance.tip_angle"]
    check_number(
        f"{path}: [balance] max_lean", values["balance.max_lean"], above=0.0, below=tip, unit="rad, below tip_angle"
    )
    k = values["gains.k"]
    if len(k) != len(STATE_NAMES) or not all(math.isfinite(x) for x in k):
        raise ConfigError(
            f"{path}: [gains] k must be {len(STATE_NAMES)} finite gains, one per state ({', '.join(STATE_NAMES)}), got "
            f"{k!r:.120}; design them with sim.robot.balance_design.design_balance"
        )


def load_balance_profile(robot: str) -> BalanceProfile:
    """Read a balancing robot's profile.

    Raises:
        ConfigError: No profile, or a table or key is missing, not a number or out of its range (named).
    """
    path = balance_profile_path(robot)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read balance profile {path}: {exc}") from exc
    values: dict[str, Any] = {}
    for table, keys in PROFILE_KEYS.items():
        for key in keys:
            value = data.get(table, {}).get(key)
            listed = key == "k" and isinstance(value, list) and all(isinstance(x, numbers.Real) for x in value)
            if not (listed or (key != "k" and isinstance(value, numbers.Real) and not isinstance(value, bool))):
                kind = "a list of numbers" if key == "k" else "a number"
                raise ConfigError(f"{path}: [{table}] {key} must be {kind}, got {value!r}")
            values[f"{table}.{key}"] = value
    _check_values(path, values)
    w = PROFILE_KEYS["weights"]
    return BalanceProfile(
        rate=float(values["balance.rate"]),
        filter_time_constant=float(values["balance.filter_time_constant"]),
        tip_angle=float(values["balance.tip_angle"]),
        max_lean=float(values["balance.max_lean"]),
        maxima=tuple(float(values[f"weights.{key}"]) for key in w[:-1]),
        voltage_max=float(values["weights.voltage_max"]),
        turn_kp=float(values["turn.kp"]),
        turn_ki=float(values["turn.ki"]),
        k=tuple(float(x) for x in values["gains.k"]),
        lean_per_accel=float(values["gains.lean_per_accel"]),
        voltage_per_accel=float(values["gains.voltage_per_accel"]),
        path=path,
    )
