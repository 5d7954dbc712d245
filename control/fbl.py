"""Dynamic feedback linearisation for trajectory tracking of a unicycle (seed report 003, III).

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
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.base import check_measured_pose, check_period, check_positive_fields, option_value
from planning.core.robot import RobotSpec
from planning.errors import ConfigError
from planning.trajectory.trajectory import Trajectory, TrajectorySamples

#: The reference the law takes: (x_d, y_d, xdot_d, ydot_d, xddot_d, yddot_d) [m, m/s, m/s^2].
FlatReference = tuple[float, float, float, float, float, float]


def flat_references(samples: TrajectorySamples) -> list[FlatReference]:
    """The law's reference at each sampled instant, as Python floats (cheap to read per call).

    Args:
        samples: The reference at M instants.

    Returns:
        M tuples (x_d, y_d, xdot_d, ydot_d, xddot_d, yddot_d).
    """
    columns = (samples.x, samples.y, samples.dx, samples.dy, samples.ddx, samples.ddy)
    return list(zip(*(c.tolist() for c in columns), strict=True))


@dataclass(frozen=True)
class FBLGains:
    """Gains of the dynamic feedback-linearisation tracker.

    Attributes:
        kp: Position error gain Kp [1/s^2].
        kd: Velocity error gain Kd [1/s].
        xi_min: Smallest |xi| used in the division [m/s] (singularity guard).
    """

    kp: float = 9.0
    kd: float = 6.0
    xi_min: float = 0.02

    def __post_init__(self) -> None:
        check_positive_fields(self, ("kp", "kd", "xi_min"), "the error dynamics need Kp, Kd > 0")

    @classmethod
    def parse(cls, text: str) -> FBLGains:
        """Parse ``"KP,KD"`` (as given to ``--gains``).

        Raises:
            ConfigError: Not two comma-separated positive numbers.
        """
        parts = [p.strip() for p in text.split(",")]
        if len(parts) != 2:
            raise ConfigError(f"gains must be 'KP,KD' (two positive numbers, e.g. 9,6), got {text!r}")
        try:
            kp, kd = float(parts[0]), float(parts[1])
        except ValueError as exc:
            raise ConfigError(f"gains must be 'KP,KD' (two positive numbers, e.g. 9,6), got {text!r}") from exc
        return cls(kp=kp, kd=kd)


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
    """:func:`fbl_law` with the gains and the reference as numbers (compiled, for compiled callers)."""
    c, s = math.cos(theta), math.sin(theta)
    w1 = ddxd - kp * (x - xd) - kd * (xi * c - dxd)
    w2 = ddyd - kp * (y - yd) - kd * (xi * s - dyd)
    xi_dot = c * w1 + s * w2
    guard = xi if abs(xi) >= xi_min else math.copysign(xi_min, xi if xi != 0.0 else 1.0)
    omega = (-s * w1 + c * w2) / guard
    return xi_dot, omega


def fbl_law(
    gains: FBLGains,
    x: float,
    y: float,
    theta: float,
    xi: float,
    ref: FlatReference,
) -> tuple[float, float]:
    """The continuous-time law: (xi_dot, omega) for a state and a reference (the module doc's
    equations; compiled).

    Args:
        gains: Kp, Kd, xi_min.
        x: Position [m].
        y: Position [m].
        theta: Heading [rad].
        xi: Compensator state (speed) [m/s].
        ref: (x_d, y_d, xdot_d, ydot_d, xddot_d, yddot_d).

    Returns:
        (xi_dot [m/s^2], omega [rad/s]), before saturation.
    """
    return fbl_law_kernel(gains.kp, gains.kd, gains.xi_min, x, y, theta, xi, *ref)


#: Slots of a tracker's state array (:func:`_step`): xi [m/s], then its constants: Kp, Kd, xi_min,
#: the speed and yaw-rate limits, the control period [s] and the trajectory's start time [s].
XI, KP, KD, XI_MIN, VMAX, WMAX, DT, T0 = range(8)
#: Rows of a tracker's block before its reference table (the state, flat in their 12 slots).
STATE_ROWS = 2
#: :func:`_period`'s status: a command; a non-finite time or pose; a time off the control instants.
OK, BAD_POSE, OFF_GRID = range(3)


@nb.njit(cache=True)
def _step(
    st: NDArray[np.float64],
    x: float,
    y: float,
    theta: float,
    xd: float,
    yd: float,
    dxd: float,
    dyd: float,
    ddxd: float,
    ddyd: float,
) -> tuple[float, float]:  # pragma: no cover - compiled
    """One period of the tracker on its state ``st`` for a reference: the saturated command (v, omega),
    xi advanced by one period (see :meth:`DynamicFBL.command`)."""
    xi = st[XI]
    xi_dot, omega = fbl_law_kernel(st[KP], st[KD], st[XI_MIN], x, y, theta, xi, xd, yd, dxd, dyd, ddxd, ddyd)
    vmax, wmax, dt = st[VMAX], st[WMAX], st[DT]
    v = xi + 0.5 * xi_dot * dt
    v = -vmax if v < -vmax else (vmax if v > vmax else v)
    xi += xi_dot * dt
    st[XI] = -vmax if xi < -vmax else (vmax if xi > vmax else xi)
    return v, (-wmax if omega < -wmax else (wmax if omega > wmax else omega))


@nb.njit(cache=True)
def _period(
    t: float, x: float, y: float, theta: float, block: NDArray[np.float64]
) -> tuple[int, float, float]:  # pragma: no cover - compiled
    """:meth:`DynamicFBL.command` at a control instant on a tracker's block (the state in its first
    :data:`STATE_ROWS` rows, then the reference at control instant k in row STATE_ROWS + k, (M, 6)):
    (OK, v, omega); (BAD_POSE or OFF_GRID, nan, nan) changing nothing."""
    if not math.isfinite(t + x + y + theta):
        return BAD_POSE, math.nan, math.nan
    st = block[:STATE_ROWS].reshape(-1)
    k = round((t - st[T0]) / st[DT])
    if not (0 <= k < block.shape[0] - STATE_ROWS and abs(st[T0] + k * st[DT] - t) < 1e-9):
        return OFF_GRID, math.nan, math.nan
    r = block[STATE_ROWS + k]
    v, omega = _step(st, x, y, theta, r[0], r[1], r[2], r[3], r[4], r[5])
    return OK, v, omega


class DynamicFBL:
    """Dynamic feedback-linearisation tracker with explicit state xi (see the module doc).

    Source: seed report 003 (EduMIP planning and tracking), section III: the compensator xi = v and
    the virtual input w = yddot_d - Kp e - Kd edot; the law and its singularity at xi = 0 as in
    G. Oriolo, A. De Luca, M. Vendittelli, "WMR control via dynamic feedback linearization: design,
    implementation, and experimental validation", IEEE Trans. Control Systems Technology 10(6),
    835-852, 2002.

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
        # xi and the constants (XI .. T0, set at reset) in the first rows, then the law's reference at the
        # control instants
        self._block = np.zeros((STATE_ROWS, 6))
        self._state = self._block[:STATE_ROWS].reshape(-1)

    @property
    def xi(self) -> float:
        """The compensator state xi (the speed) [m/s]."""
        return float(self._state[XI])

    @xi.setter
    def xi(self, value: float) -> None:
        self._state[XI] = value

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking: xi starts at the reference speed; the reference is pre-sampled at the
        control instants; the gains and the robot's limits are taken as they are now.

        Raises:
            ConfigError: ``dt`` [s] is not a finite number > 0.
        """
        dt = check_period(self.name, dt, trajectory)
        self._traj = trajectory
        t0 = float(trajectory.t[0])
        n = math.ceil(trajectory.duration / dt) + 2
        s = trajectory.sample_many(t0 + dt * np.arange(n))
        self._block = np.vstack([np.zeros((STATE_ROWS, 6)), np.column_stack([s.x, s.y, s.dx, s.dy, s.ddx, s.ddy])])
        self._state = self._block[:STATE_ROWS].reshape(-1)
        g, r = self.gains, self.robot
        self._state[:8] = (trajectory.vel[0, 0], g.kp, g.kd, g.xi_min, r.max_speed, r.max_yaw_rate, dt, t0)

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command for the period starting at ``t``; advances xi by one period.

        One compiled call (:func:`_period`) at a control instant; between them the reference is
        interpolated from the trajectory.

        Raises:
            SimulationError: ``t`` or the pose is not finite.
        """
        status, v, omega = _period(t, x, y, theta, self._block)
        if status == OK:
            return v, omega
        check_measured_pose(self.name, t, x, y, theta)  # raises for BAD_POSE
        if self._traj is None:
            raise RuntimeError("DynamicFBL.command called before reset")
        return _step(self._state, x, y, theta, *flat_references(self._traj.sample_many(np.array([t])))[0])
