"""Kanayama's tracking law on the pose error, per segment of a trajectory.

With the pose error expressed in the robot's frame,

    e_x =  cos(theta) (x_r - x) + sin(theta) (y_r - y)
    e_y = -sin(theta) (x_r - x) + cos(theta) (y_r - y)
    e_theta = wrap(theta_r - theta),

the command is

    v     = v_r cos(e_theta) + K_x e_x
    omega = omega_r + v_r K_y e_y + |v_r| K_theta sin(e_theta).

Kanayama et al. prove, with the Lyapunov function V = (e_x^2 + e_y^2) / 2 + (1 - cos e_theta) / K_y,
that the error converges for v_r > 0; the heading term here carries |v_r| instead of v_r so that the
linearised lateral error e_y'' + |v_r| K_theta e_y' + v_r^2 K_y e_y = 0 is stable backwards too
(critically damped for K_theta = 2 sqrt(K_y)). Where v_r vanishes the lateral and heading
corrections vanish with it, so turns in place and stand-stills are held by the segment switching
of :class:`control.segmented.SegmentSwitcher` (heading control, spot holding), as for the
segmented FBL: the tracker accepts every trajectory, with cusps and turns in place.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np
import numpy.typing as npt

from control.base import check_ranges, option_value, ranged
from control.estimation.kernels import wrap
from control.segmented import DRIVE, GENERAL, LAW, SegmentedParams, SegmentSwitcher, _Instant, clamp_command, drive_row
from planning.core.robot import RobotSpec
from planning.trajectory.trajectory import Trajectory


@dataclass(frozen=True)
class KanayamaParams:
    """Gains of Kanayama's law (ranges checked; out of range raises ConfigError naming the range).

    The defaults are the paper's (K_x = 10 1/s, K_y = 6.4e-3 1/cm^2, K_theta = 0.16 1/cm).

    Attributes:
        kx: Along-track gain K_x [1/s].
        ky: Lateral gain K_y [1/m^2].
        ktheta: Heading gain K_theta [1/m] (critical damping at 2 sqrt(K_y)).
    """

    kx: float = ranged(10.0, 0.01, 100.0, "1/s", tune=(0.2, 40.0))
    ky: float = ranged(64.0, 0.01, 10000.0, "1/m^2", tune=(1.0, 1000.0))
    ktheta: float = ranged(16.0, 0.01, 1000.0, "1/m", tune=(0.5, 100.0))

    def __post_init__(self) -> None:
        check_ranges(self)


@nb.njit(cache=True)
def _law(
    kx: float,
    ky: float,
    ktheta: float,
    x: float,
    y: float,
    theta: float,
    xr: float,
    yr: float,
    thr: float,
    vr: float,
    wr: float,
) -> tuple[float, float]:  # pragma: no cover - compiled
    """:func:`kanayama_law` with the gains and the reference as numbers, compiled."""
    c, s = math.cos(theta), math.sin(theta)
    dx, dy = xr - x, yr - y
    ex, ey = c * dx + s * dy, -s * dx + c * dy
    eth = wrap(thr - theta)
    v = vr * math.cos(eth) + kx * ex
    omega = wr + vr * ky * ey + abs(vr) * ktheta * math.sin(eth)
    return v, omega


@nb.njit(cache=True)
def _drive_period(
    t: float, x: float, y: float, theta: float, segment: int, block: npt.NDArray[np.float64]
) -> tuple[int, float, float]:  # pragma: no cover - compiled
    """:meth:`KanayamaTracker.command` in one compiled call while a drive is under way
    (:func:`control.segmented.drive_row`; the gains K_x, K_y, K_theta in row 0 from LAW): (DRIVE, v,
    omega), clamped as the general path clamps; (GENERAL, nan, nan) for the general path to decide."""
    i = drive_row(t, x, y, theta, segment, block)
    if i < 0:
        return GENERAL, math.nan, math.nan
    r, c = block[i], block[0]
    v, w = _law(c[LAW], c[LAW + 1], c[LAW + 2], x, y, theta, r[0], r[1], r[2], r[3], r[4])
    sgn = r[12]
    v, w = clamp_command(sgn * max(sgn * v, 0.0), w, c)
    return DRIVE, v, w


def kanayama_law(params: KanayamaParams, x: float, y: float, theta: float, ref: Sequence[Any]) -> tuple[float, float]:
    """Kanayama's command for a pose and a reference (see the module doc).

    Args:
        params: K_x, K_y, K_theta.
        x: Position [m].
        y: Position [m].
        theta: Heading [rad].
        ref: (x_r [m], y_r [m], theta_r [rad], v_r [m/s], omega_r [rad/s]), or a longer sequence
            that starts with them (a segment switcher's reference instant).

    Returns:
        (v [m/s], omega [rad/s]), before saturation.
    """
    return _law(params.kx, params.ky, params.ktheta, x, y, theta, ref[0], ref[1], ref[2], ref[3], ref[4])


class KanayamaTracker(SegmentSwitcher):
    """Kanayama's stable tracking law on the drives; turns in place by segment (see the module doc).

    Source: Y. Kanayama, Y. Kimura, F. Miyazaki, T. Noguchi, "A stable tracking control method for an
    autonomous mobile robot", Proc. IEEE International Conference on Robotics and Automation 1990,
    pp. 384-389, eq. (8) (the law) and section IV (the Lyapunov function and the gains); |v_r| in the
    heading term for reverse drives is this project's extension.

    Args:
        robot: Limits (max_speed, max_yaw_rate).
        params: K_x, K_y, K_theta; None for ``KanayamaParams()``.
        turns: Heading and spot-holding parameters of turns in place and stand-stills (its
            ``xi_blend`` is unused); None for ``SegmentedParams()``.

    Raises:
        ConfigError: ``params`` is not a :class:`KanayamaParams` or ``turns`` not a :class:`SegmentedParams`.
    """

    name = "kanayama"
    #: The option ``nhsim tune --tracker`` tunes, and its dataclass.
    TUNED = ("params", KanayamaParams)

    def __init__(
        self, robot: RobotSpec, *, params: KanayamaParams | None = None, turns: SegmentedParams | None = None
    ) -> None:
        self.params = option_value(self.name, "params", params, KanayamaParams())
        super().__init__(robot, option_value(self.name, "turns", turns, SegmentedParams()))

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking (see :meth:`SegmentSwitcher.reset`); the gains are taken as they are now."""
        super().reset(trajectory, dt)
        p = self.params
        self._block[0, LAW : LAW + 3] = (p.kx, p.ky, p.ktheta)

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command for the period starting at ``t`` (see :meth:`SegmentSwitcher.command`): one
        compiled call while a drive is under way (:func:`_drive_period`)."""
        if self._traj is not None:
            status, v, w = _drive_period(t, x, y, theta, self.segment, self._block)
            if status == DRIVE:
                return v, w
        return super().command(t, x, y, theta)

    def _drive(self, x: float, y: float, theta: float, ref: _Instant, sgn: float, k: int) -> tuple[float, float]:
        """Kanayama's law along a drive, its speed kept on the drive's side of zero."""
        p = self.params
        v, w = _law(p.kx, p.ky, p.ktheta, x, y, theta, ref.x, ref.y, ref.theta, ref.v, ref.omega)
        return sgn * max(sgn * v, 0.0), w
