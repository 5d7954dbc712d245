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
from control.design.balance_profile import load_balance_profile
from control.design.lqr import check_closed_loop, lqr_gains
from planning.core.robot import load_robot
from sim.physics.model import build_model
from sim.physics.motors import MotorModel
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
def _drawing_plant(robot: str, rate: float) -> tuple[FloatArray, FloatArray, MotorModel, SagittalParams]:
    spec = load_robot(robot)
    model = build_model(spec).model
    a, b = sagittal_model(model, spec.wheel_radius, 1.0 / rate)
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
    a, b, motor, params = _drawing_plant(robot, prof.rate)
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
