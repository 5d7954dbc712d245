"""Dynamic feedback linearisation for trajectory tracking of a unicycle (the EduMIP planning report, III).

Output y = (x, y). Differentiating twice gives

    [xddot, yddot]^T = R(theta) [xi_dot, xi * omega]^T,     xi = v  (the compensator state),

so with the virtual input  w = yddot_d - Kp (y - y_d) - Kd (ydot - ydot_d)  and

    xi_dot = cos(theta) w1 + sin(theta) w2,   omega = (-sin(theta) w1 + cos(theta) w2) / xi,

the output error obeys  e'' + Kd e' + Kp e = 0. ydot is xi (cos theta, sin theta), from the
compensator, not from a velocity measurement. xi is integrated at the control rate; the command
holds xi at the midpoint of the coming period (xi + xi_dot dt / 2), the zero-order-hold
equivalent of the ramp xi follows in continuous time.

Where xi approaches 0 the law is singular: the division uses xi clamped away from zero by
``xi_min`` (keeping its sign), and the commands are saturated to the robot's limits, so no
command is ever non-finite.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.base import TRACKERS, option_takes, option_value
from control.dispatch import bind
from control.gains import FBLGains, check_period_stability
from control.inputs import check_command, check_reset, not_reset
from control.switching import REFERENCE, clamp_command, reference_table
from planning.core.robot import RobotSpec
from planning.trajectory.trajectory import Trajectory


@nb.njit(cache=True)
def fbl_law_kernel(
    kp: float,
    kd: float,
    xi_min: float,
    x: float,
    y: float,
    theta: float,
    xi: float,
    xd: float,
    yd: float,
    dxd: float,
    dyd: float,
    ddxd: float,
    ddyd: float,
) -> tuple[float, float]:  # pragma: no cover - compiled
    """The continuous-time law (the module doc's equations): (xi_dot [m/s^2], omega [rad/s]) before
    saturation, for gains Kp, Kd, xi_min, a pose (x, y [m], theta [rad]), the compensator state xi
    [m/s] and the flat reference (x_d, y_d [m], xdot_d, ydot_d [m/s], xddot_d, yddot_d [m/s^2])."""
    c, s = math.cos(theta), math.sin(theta)
    w1 = ddxd - kp * (x - xd) - kd * (xi * c - dxd)
    w2 = ddyd - kp * (y - yd) - kd * (xi * s - dyd)
    xi_dot = c * w1 + s * w2
    guard = xi if abs(xi) >= xi_min else math.copysign(xi_min, xi if xi != 0.0 else 1.0)
    omega = (-s * w1 + c * w2) / guard
    return xi_dot, omega


#: Smallest |xi| [m/s] kept along a drive of known direction (:func:`xi_period`), so xi keeps the
#: drive's sign through a stop.
XI_FLOOR = 1e-6


@nb.njit(cache=True, inline="always")
def xi_period(
    xi: float, xi_dot: float, dt: float, vmax: float, sign: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """The FBL's discretisation of one control period: (v, the next xi).

    xi integrates xi_dot over the period (u1 <- u1 + u1_dot dt, the EduMIP planning report, III) and
    stays within the speed limit |u1| <= vmax; along a drive of known direction (``sign`` +1
    forwards, -1 backwards) within that direction's side, sign * xi in [XI_FLOOR, vmax], so a drive
    never reverses and the law keeps dividing by a speed of the drive's sign; ``sign`` 0 (a
    reference without a direction) bounds xi by +-vmax only. The command v is xi at the period's
    midpoint, xi + xi_dot dt / 2, before the caller clamps it.

    Args:
        xi: The compensator state [m/s].
        xi_dot: Its rate from the law [m/s^2].
        dt: The control period [s].
        vmax: The speed limit [m/s].
        sign: The drive's direction: +1, -1, or 0 for none.
    """
    v = xi + 0.5 * xi_dot * dt
    xi = xi + xi_dot * dt
    if sign == 0.0:
        return v, -vmax if xi < -vmax else (vmax if xi > vmax else xi)
    return v, sign * min(max(sign * xi, XI_FLOOR), vmax)


#: The state record of :class:`DynamicFBL`: xi [m/s], the gains, the speed and yaw-rate limits, the
#: control period [s] and the trajectory's start time [s].
STATE = np.dtype([(name, "f8") for name in ("xi", "kp", "kd", "xi_min", "vmax", "wmax", "dt", "t0")], align=True)
#: :func:`_period`'s status: a command; a non-finite time or pose; a time off the control instants.
OK, BAD_POSE, OFF_GRID = range(3)


@nb.njit(cache=True)
def step(
    state: NDArray[np.void], ref: NDArray[np.void], k: int, x: float, y: float, theta: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """One period of the tracker on its state record for the reference row ``ref[k]``
    (:data:`control.switching.REFERENCE`): the clamped command (v, omega); xi advanced one period."""
    s, r = state[0], ref[k]
    xi_dot, omega = fbl_law_kernel(s.kp, s.kd, s.xi_min, x, y, theta, s.xi, r.x, r.y, r.dx, r.dy, r.ddx, r.ddy)
    v, s.xi = xi_period(s.xi, xi_dot, s.dt, s.vmax, 0.0)
    return clamp_command(v, omega, s.vmax, s.wmax)


@nb.njit(cache=True)
def _period(
    state: NDArray[np.void], ref: NDArray[np.void], t: float, x: float, y: float, theta: float
) -> tuple[int, float, float]:  # pragma: no cover - compiled
    """:meth:`DynamicFBL.command` at a control instant (``ref`` row k at t0 + k dt): (OK, v, omega);
    (BAD_POSE or OFF_GRID, nan, nan) changing nothing."""
    if not math.isfinite(t + x + y + theta):
        return BAD_POSE, math.nan, math.nan
    s = state[0]
    k = round((t - s.t0) / s.dt)
    if not (0 <= k < ref.size and abs(s.t0 + k * s.dt - t) < 1e-9):
        return OFF_GRID, math.nan, math.nan
    v, omega = step(state, ref, k, x, y, theta)
    return OK, v, omega


class DynamicFBL:
    """Dynamic feedback-linearisation tracker with explicit state xi (see the module doc).

    Source: the EduMIP planning report (Trajectory planning and control for the EduMIP), section III:
    the compensator xi = v and the virtual input w = yddot_d - Kp e - Kd edot; the law and its
    singularity at xi = 0 as in G. Oriolo, A. De Luca, M. Vendittelli, "WMR control via dynamic
    feedback linearization: design, implementation, and experimental validation", IEEE Trans.
    Control Systems Technology 10(6), 835-852, 2002.

    Args:
        robot: Limits (max_speed, max_yaw_rate) the commands are saturated to.
        gains: Kp, Kd, xi_min; None for ``FBLGains()``.

    Raises:
        ConfigError: ``gains`` is not an :class:`FBLGains`.
    """

    name = "fbl"
    #: The option ``nhsim tune --tracker`` tunes, and its dataclass.
    TUNED = ("gains", FBLGains)

    def __init__(self, robot: RobotSpec, *, gains: FBLGains | None = None) -> None:
        self.robot = robot
        self.gains = option_value(self.name, "gains", gains, FBLGains())
        self._traj: Trajectory | None = None
        self.state = np.zeros(1, STATE)
        # Before reset: no control instant (an infinite period, an empty table), so command's compiled period
        # answers OFF_GRID, dividing by no zero, and command names the missing reset; no check per call.
        self.state[0]["dt"] = math.inf
        self._ref = np.zeros(0, REFERENCE)  # the law's reference at the control instants
        self._bind()

    @property
    def xi(self) -> float:
        """The compensator state xi (the speed) [m/s]."""
        return float(self.state[0]["xi"])

    @xi.setter
    def xi(self, value: float) -> None:
        self.state[0]["xi"] = value

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking: xi starts at the reference speed; the reference is pre-sampled at the
        control instants; the gains and the robot's limits are taken as they are now.

        Raises:
            ConfigError: ``trajectory`` is not a Trajectory, or ``dt`` [s] is not a finite number > 0.
            UnstableGainsError: Gains whose error dynamics a period of ``dt`` cannot keep stable.
        """
        dt = check_reset(self.name, trajectory, dt)
        check_period_stability(self.gains, dt, self.name)
        self._traj = trajectory
        self._ref = reference_table(trajectory, dt, math.ceil(trajectory.duration / dt) + 2)
        g, r = self.gains, self.robot
        values = (trajectory.vel[0, 0], g.kp, g.kd, g.xi_min, r.max_speed, r.max_yaw_rate, dt, trajectory.t[0])
        self.state = np.array([values], STATE)
        self._bind()

    def _bind(self) -> None:
        """:func:`_period` bound to the state record and the reference table, its overload resolved
        once (:func:`control.dispatch.bind`): ``self._period(t, x, y, theta)``."""
        self._period = bind(_period, self.state, self._ref, free=(0.0, 0.0, 0.0, 0.0))

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command for the period starting at ``t``; advances xi by one period.

        One compiled call (:func:`_period`) at a control instant; between them the reference is
        interpolated from the trajectory.

        Raises:
            ConfigError: An argument is not a number (an array, a text), or ``reset`` was not called first.
            SimulationError: ``t`` or the pose is not finite.
        """
        check_command(self.name, t, x, y, theta)  # before the compiled period, which takes a text for a float
        status, v, omega = self._period(t, x, y, theta)
        if status == OK:
            return v, omega
        if self._traj is None:
            raise not_reset(self.name)
        return step(self.state, _at(self._traj, t), 0, x, y, theta)


def _at(trajectory: Trajectory, t: float) -> NDArray[np.void]:
    """The law's reference at time ``t`` [s], interpolated, as a one-row table."""
    s = trajectory.sample_many(np.array([t]))
    row = np.zeros(1, REFERENCE)
    for name in ("x", "y", "dx", "dy", "ddx", "ddy"):
        row[name] = getattr(s, name)
    return row


def uses_fbl_gains(name: str) -> bool:
    """Whether registered tracker ``name`` takes the FBL's gains (its ``gains`` option declared an
    :class:`FBLGains`: fbl, segmented, an FBL of a plugin); False for any other, an unknown name included."""
    return name in TRACKERS and option_takes(name, "gains", FBLGains)
