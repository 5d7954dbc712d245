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

from collections.abc import Callable
from typing import TYPE_CHECKING

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from control.dispatch import bind
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


def state_dtype(wheels: int) -> np.dtype[np.void]:
    """The record of a loop's state: the integrators [V], the gains (kff [V s/rad], kp [V s/rad],
    ki T [V s/rad], V_batt [V]) and the wiring (the wheels' dofs in ``MjData.qvel``, their actuators in
    ``MjData.ctrl``; -1 until wired), one record so that a compiled update takes one array."""
    f8, i8 = np.float64, np.int64
    fields = [("integral", f8, (wheels,)), ("kff", f8), ("kp", f8), ("ki_t", f8), ("vb", f8)]
    return np.dtype([*fields, ("dof", i8, (wheels,)), ("act", i8, (wheels,))])


@nb.njit(cache=True)
def _drive(
    state: NDArray[np.void], commands: FloatArray, qvel: FloatArray, ctrl: FloatArray, row: int
) -> None:  # pragma: no cover - compiled
    """One update of a loop's ``state`` (a (1,) array of :func:`state_dtype`) with row ``row`` of
    ``commands`` (< 0: row 0): each wheel's speed read from ``qvel[dof]``, its voltage written to
    ``ctrl[act]``."""
    s = state[0]
    row = max(row, 0)
    integral, dof, act = s.integral, s.dof, s.act
    for i in range(integral.shape[0]):
        integral[i], ctrl[act[i]] = _wheel(integral[i], commands[row, i], qvel[dof[i]], s.kff, s.kp, s.ki_t, s.vb)


class VelocityLoop:
    """The firmware velocity loop of a set of wheels (state: one integrator per wheel), updated every
    ``motor.period`` seconds, the voltage being held in between.

    Args:
        motor: Motor constants, gains and update period.
        wheels: Number of wheels driven (2: [left, right]).
    """

    def __init__(self, motor: MotorModel, wheels: int = 2) -> None:
        self.motor = motor
        self._state = np.zeros(1, state_dtype(wheels))
        s = self._state[0]
        s["kff"], s["kp"], s["ki_t"], s["vb"] = motor.kff, motor.kp, motor.ki * motor.period, motor.battery_voltage
        s["dof"], s["act"] = -1, -1
        self.integral: FloatArray = self._state["integral"][0]  # a view: (wheels,) integrators [V]
        self._own = np.arange(wheels, dtype=np.int64)  # the wiring of a call: command i -> voltage i
        self._bound = False

    def reset(self) -> None:
        """Zero the integrators (the firmware at power-up)."""
        self.integral[:] = 0.0

    def __call__(self, command: ArrayLike, measured: ArrayLike) -> FloatArray:
        """One update: the voltages for the next period (the compiled update of :meth:`drive`, wired
        command i -> voltage i).

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
        if self._bound:
            raise ConfigError("motor loop: a loop bound to a run by driver() is updated through it, not called")
        out = np.empty(n)
        self._wire(np.stack([self._own, self._own]))
        _drive(self._state, r.reshape(1, n), w, out, 0)
        return out

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
        _drive(self._state, commands, qvel, ctrl, row)

    def driver(
        self, commands: FloatArray, qvel: FloatArray, ctrl: FloatArray, wiring: IntArray
    ) -> Callable[[int], None]:
        """:meth:`drive` bound to a run's arrays: ``update(row)``, without a Python frame of its own
        (the compiled update with this loop's state, the wiring inside it, its overload resolved once:
        :func:`control.dispatch.bind`), for a control loop that calls it every firmware period. The
        loop is then updated through it only (a call raises).

        Raises:
            ConfigError: ``wiring`` is not (2, wheels).
        """
        self._wire(wiring)
        self._bound = True
        return bind(_drive, self._state, commands, qvel, ctrl, free=(0,))

    def _wire(self, wiring: IntArray) -> None:
        """Put a (2, wheels) wiring (dofs, then actuators) into the state; raises ConfigError if misshapen."""
        n = self.integral.shape[0]
        w = np.asarray(wiring)
        if w.shape != (2, n):
            raise ConfigError(f"motor loop: wiring {w.shape} must be (2, {n}): the wheels' dofs, then their actuators")
        s = self._state[0]
        s["dof"], s["act"] = w[0], w[1]
