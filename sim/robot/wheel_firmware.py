"""The wheels' firmware velocity loop: wheel-speed commands into motor voltages.

The firmware. A discrete velocity loop, run every ``period`` seconds and vectorised over both
wheels, holds the voltage for a period::

    e_k = r_k - omega_k
    I_k = I_{k-1} + ki T e_k
    u_k = clip(kff r_k + kp e_k + I_k, -V_batt, V_batt)

with r the commanded wheel speed, T the period, kp [V s/rad], ki [V/rad] and a feed-forward kff
[V s/rad]. Against wind-up the integrator grows in the error's direction only up to the level that
saturates the output (it is never pulled back by that bound), and |I_k| <= V_batt. The TurtleBot3's XL430-W250 runs
its Velocity Control Mode this way without feed-forward (kff = 0: the e-Manual's PI with
anti-windup); the EduMIP's rc_balance-like firmware adds the no-load voltage kff = V_batt / omega_nl
(the back-EMF of the commanded speed), so its PI only works off the load.

The stability bound on its period is derived in :mod:`sim.physics.motors` (:meth:`MotorModel.max_period`).

The simulator updates the firmware every ``period`` (a whole number of physics steps, on a grid
fixed from the start of the run, whatever the control rate, latency or logging): a wheel command
that arrives between two updates is taken up at the next, as on the real board.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TYPE_CHECKING

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.errors import ConfigError

if TYPE_CHECKING:
    from sim.physics.motors import MotorModel

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@nb.njit(cache=True, inline="always")
def _wheel(
    integral: float, r: float, measured: float, kff: float, kp: float, ki_t: float, vb: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """One wheel's update: (new integrator [V], voltage [V]) for command r and measured speed [rad/s]."""
    e = r - measured
    fixed = kff * r + kp * e
    grown = integral + ki_t * e
    if e > 0:  # grow up to the level that saturates the output, never beyond (nor pulled back)
        grown = min(grown, max(integral, vb - fixed))
    elif e < 0:
        grown = max(grown, min(integral, -vb - fixed))
    integral = min(max(grown, -vb), vb)
    return integral, min(max(fixed + integral, -vb), vb)


@nb.njit(cache=True)
def _update(
    integral: FloatArray, command: FloatArray, measured: FloatArray, kff: float, kp: float, ki_t: float, vb: float
) -> FloatArray:  # pragma: no cover - compiled
    out = np.empty(integral.shape[0])
    for i in range(integral.shape[0]):
        integral[i], out[i] = _wheel(integral[i], command[i], measured[i], kff, kp, ki_t, vb)
    return out


@nb.njit(cache=True)
def _drive_wired(
    state: FloatArray, commands: FloatArray, qvel: FloatArray, ctrl: FloatArray, row: int
) -> None:  # pragma: no cover - compiled
    """One update of a loop's ``state`` (the n integrators, kff, kp, ki T, V_batt, then the wiring's 2n
    slots: the wheels' dofs in ``qvel``, their actuators in ``ctrl``) with row ``row`` of ``commands``
    (< 0: row 0); the wiring rides in the state so that a compiled call takes one array fewer."""
    n = (len(state) - 4) // 3
    kff, kp, ki_t, vb = state[n], state[n + 1], state[n + 2], state[n + 3]
    row = max(row, 0)
    for i in range(n):
        dof, act = int(state[n + 4 + i]), int(state[n + 4 + n + i])
        state[i], ctrl[act] = _wheel(state[i], commands[row, i], qvel[dof], kff, kp, ki_t, vb)


class VelocityLoop:
    """The firmware velocity loop of a set of wheels (state: one integrator per wheel), updated every
    ``motor.period`` seconds, the voltage being held in between.

    Args:
        motor: Motor constants, gains and update period.
        wheels: Number of wheels driven (2: [left, right]).
    """

    def __init__(self, motor: MotorModel, wheels: int = 2) -> None:
        self.motor = motor
        self._gains = (motor.kff, motor.kp, motor.ki * motor.period, motor.battery_voltage)
        # the integrators, the gains, then the wiring (dofs, actuators) of a driver
        self._state = np.array([0.0] * wheels + list(self._gains) + [-1.0] * (2 * wheels))
        self.integral = self._state[:wheels]

    def reset(self) -> None:
        """Zero the integrators (the firmware at power-up)."""
        self.integral[:] = 0.0

    def __call__(self, command: ArrayLike, measured: ArrayLike) -> FloatArray:
        """One update: the voltages for the next period (compiled; about 1 us a call).

        Args:
            command: (wheels,) commanded wheel speeds [rad/s].
            measured: (wheels,) measured wheel speeds [rad/s].

        Returns:
            (wheels,) motor voltages [V] within +-V_batt.

        Raises:
            ConfigError: ``command`` or ``measured`` does not hold one value per wheel.
        """
        r = np.asarray(command, dtype=np.float64)
        w = np.asarray(measured, dtype=np.float64)
        n = self.integral.shape[0]
        if r.shape != (n,) or w.shape != (n,):
            raise ConfigError(
                f"motor loop: command {r.shape} and measured {w.shape} must each hold {n} wheel speeds [rad/s]"
            )
        return _update(self.integral, r, w, *self._gains)

    def drive(self, commands: FloatArray, row: int, qvel: FloatArray, ctrl: FloatArray, wiring: IntArray) -> None:
        """One update in place, for the simulator's control loop (one compiled call, no copies):
        the command is row ``row`` of ``commands``, the measured speeds are read from ``qvel`` and
        the voltages written into ``ctrl`` where ``wiring`` says; the same arithmetic as a call.

        Args:
            commands: (K, wheels) commanded wheel speeds [rad/s].
            row: Row of ``commands`` in force (< 0: row 0, the command before any was computed).
            qvel: MuJoCo's joint velocities (``MjData.qvel``) [rad/s].
            ctrl: MuJoCo's controls (``MjData.ctrl``) [V].
            wiring: (2, wheels) int64: the wheels' dofs in ``qvel``, then their actuators in ``ctrl``.
        """
        self._wire(wiring)
        _drive_wired(self._state, commands, qvel, ctrl, row)

    def driver(
        self, commands: FloatArray, qvel: FloatArray, ctrl: FloatArray, wiring: IntArray
    ) -> Callable[[int], None]:
        """:meth:`drive` bound to a run's arrays: ``update(row)``, without a Python frame of its own
        (the compiled update with this loop's state, the wiring inside it), for a control loop that
        calls it every firmware period.

        Raises:
            ConfigError: ``wiring`` is not (2, wheels).
        """
        self._wire(wiring)
        return functools.partial(_drive_wired, self._state, commands, qvel, ctrl)

    def _wire(self, wiring: IntArray) -> None:
        """Put a (2, wheels) wiring (dofs, then actuators) into the state; raises ConfigError if misshapen."""
        n = self.integral.shape[0]
        w = np.asarray(wiring)
        if w.shape != (2, n):
            raise ConfigError(f"motor loop: wiring {w.shape} must be (2, {n}): the wheels' dofs, then their actuators")
        self._state[n + 4 :] = w.reshape(-1)
