"""The balance firmware's design from the robot's model, and its gains before a run.

Design. A discrete LQR (:func:`control.design.lqr.lqr_gains`) on the sagittal model of the robot
over one firmware period (:func:`sim.physics.sagittal.sagittal_model`) with Bryson weights from the
profile (:mod:`control.design.balance_profile`) gives the gains ``K`` of
:class:`control.balance.BalanceController`; the closed loop's poles ``eig(A - B K)`` must lie inside
the unit disc (:func:`control.design.lqr.check_closed_loop`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from control.balance import STATE_NAMES, BalanceGains
from control.design.balance_profile import BalanceProfile, load_balance_profile
from control.design.lqr import check_closed_loop, lqr_gains
from planning.core.robot import load_robot
from planning.errors import ConfigError
from sim.physics.model import build_model
from sim.physics.motors import MotorModel, whole_steps
from sim.physics.sagittal import SagittalParams, sagittal_model

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class BalanceDesign:
    """A balance loop designed from a model.

    Attributes:
        a: (5, 5) plant over one period.
        b: (5, 1) its input (common voltage).
        k: (5,) LQR gains.
        poles: (5,) complex closed-loop poles.
        open_loop: (5,) complex open-loop poles (one outside the unit disc: the pendulum).
        lean_per_accel: Steady lean per forward acceleration [rad per m/s^2] (:class:`SagittalParams`).
        voltage_per_accel: Voltage per forward acceleration [V per m/s^2] (:class:`SagittalParams`).
    """

    a: FloatArray
    b: FloatArray
    k: FloatArray
    poles: NDArray[np.complex128]
    open_loop: NDArray[np.complex128]
    lean_per_accel: float
    voltage_per_accel: float


def design_balance(robot: str, model: mujoco.MjModel | None = None) -> BalanceDesign:
    """Design a balancing robot's loop from its model and profile weights.

    Args:
        robot: Registry name of a balancing robot.
        model: Its compiled model (the drawing's if None).
    """
    spec = load_robot(robot)
    prof = load_balance_profile(robot)
    m = model if model is not None else build_model(spec).model
    a, b = sagittal_model(m, spec.wheel_radius, 1.0 / prof.rate)
    k = lqr_gains(a, b, prof.maxima, prof.voltage_max)
    params = SagittalParams.from_model(m)
    open_loop = np.asarray(np.linalg.eigvals(a), dtype=complex)
    return BalanceDesign(
        a, b, k.ravel(), check_closed_loop(a, b, k), open_loop, params.lean_per_accel, params.voltage_per_accel
    )


@functools.lru_cache(maxsize=8)
def _drawing_plant(robot: str, prof: BalanceProfile) -> tuple[FloatArray, FloatArray, MotorModel, SagittalParams]:
    """The robot as drawn, linearised upright over one balance period of its profile.

    Raises:
        ConfigError: The profile's rate has no whole number of the model's physics steps a period (naming the
            file, the key and rates that have).
    """
    spec = load_robot(robot)
    model = build_model(spec).model
    step = float(model.opt.timestep)
    if not whole_steps(1.0 / prof.rate, step):
        fits = [f"{r:g}" for r in (100.0, 200.0, 250.0, 500.0, 1000.0) if whole_steps(1.0 / r, step)]
        raise ConfigError(
            f"{prof.path}: [balance] rate {prof.rate:g} Hz: its period is not a whole number of the model's "
            f"{step * 1e3:g} ms physics steps; choose a rate whose period is, e.g. {', '.join(fits)} Hz (and design "
            "the gains for it: sim.robot.balance_design.design_report)"
        )
    a, b = sagittal_model(model, spec.wheel_radius, 1.0 / prof.rate)
    return a, b, MotorModel.from_model(model), SagittalParams.from_model(model)


def balance_gains(robot: str, k: tuple[float, ...] | None = None) -> BalanceGains:
    """The firmware gains of a balancing robot: its profile's stored gains (or ``k``), checked stable
    (:func:`check_closed_loop`) on the linearisation of the robot as drawn, the model the firmware
    knows (as a tracker knows the drawing, not the build), before a run.

    Raises:
        ConfigError: The gains destabilise the loop (the offending pole named).
    """
    prof = load_balance_profile(robot)
    gains = prof.k if k is None else tuple(float(x) for x in k)
    a, b, motor, params = _drawing_plant(robot, prof)
    if k is None:
        _check_designed(robot, prof, lqr_gains(a, b, prof.maxima, prof.voltage_max).ravel(), params)
    check_closed_loop(a, b, gains)
    return BalanceGains(
        rate=prof.rate,
        k=gains,
        filter_time_constant=prof.filter_time_constant,
        kff=motor.battery_voltage / motor.no_load_speed,
        turn_kp=prof.turn_kp,
        turn_ki=prof.turn_ki,
        battery_voltage=motor.battery_voltage,
        lean_per_accel=prof.lean_per_accel * params.wheel_radius,
        voltage_per_accel=prof.voltage_per_accel * params.wheel_radius,
        wheel_radius=params.wheel_radius,
    )


#: How far a profile's stored gains may differ from its design (relative): the printed lines' digits.
DESIGN_RTOL = 1e-4


def _check_designed(robot: str, prof: BalanceProfile, k: FloatArray, params: SagittalParams) -> None:
    """Refuse a profile whose ``[gains]`` are not what its ``[weights]`` and ``[balance] rate`` design on the robot
    as drawn (a weight or the rate edited, the gains left: the edit would be silently ignored).

    Raises:
        ConfigError: Naming the file, the gains that differ and how to print the designed ones.
    """
    stored = np.array([*prof.k, prof.lean_per_accel, prof.voltage_per_accel])
    designed = np.array([*k, params.lean_per_accel, params.voltage_per_accel])
    if np.allclose(stored, designed, rtol=DESIGN_RTOL, atol=0.0):
        return
    names = [*(f"k[{i}]" for i in range(len(k))), "lean_per_accel", "voltage_per_accel"]
    pairs = zip(names, stored, designed, strict=True)
    off = [f"{n} {a:.6g} (designed {d:.6g})" for n, a, d in pairs if not math.isclose(a, d, rel_tol=DESIGN_RTOL)]
    raise ConfigError(
        f"{prof.path}: [gains] are not what its [weights] and [balance] rate design on the robot: {'; '.join(off)}; "
        f'put the designed lines in [gains] (python -c "from sim.robot.balance_design import design_report; '
        f"print(design_report('{robot}'))\")"
    )


def design_report(robot: str) -> str:
    """The design of a balancing robot's loop as text: its poles and the profile's ``[gains]`` lines."""
    design = design_balance(robot)
    slowest = float(np.abs(design.poles).max())
    rate = load_balance_profile(robot).rate
    return "\n".join(
        [
            f"open-loop poles: {np.round(design.open_loop, 5).tolist()}",
            f"closed-loop poles: {np.round(design.poles, 5).tolist()} (max |z| = {slowest:.5f})",
            f"slowest time constant: {-1.0 / (math.log(slowest) * rate):.3f} s",
            "k = [" + ", ".join(f"{x:.6g}" for x in design.k) + "]  # " + ", ".join(STATE_NAMES),
            f"lean_per_accel = {design.lean_per_accel:.6g}  # rad per m/s^2",
            f"voltage_per_accel = {design.voltage_per_accel:.6g}  # V per m/s^2",
        ]
    )
