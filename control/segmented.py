"""A tracker for planned paths: feedback linearisation per drive, heading control for turns in place.

Dynamic feedback linearisation (control/fbl.py) divides by its compensator state xi = v, so it is
singular where the reference stops: at every cusp, at every turn in place, at the start and at the
goal. This tracker drives the EduMIP planning report's FBL along each drive of a planned trajectory
and leaves turns in place, stand-stills and the end to the segment switching (control/switching.py):

* On entering a drive, xi is re-initialised to the reference speed, with the drive's sign (so the
  singularity guard and the law act in the drive's direction even from rest), and it is kept on that
  side of zero for the whole drive (:func:`control.fbl.xi_period`, the FBL's one discretisation).
* Where |xi| is below ``xi_blend`` (starting and stopping), omega is blended towards a heading
  controller ``omega_ref + heading_gain * wrap(theta_ref - theta)`` in proportion to |xi| /
  xi_blend, because there the FBL's lateral correction divided by a vanishing xi would ask for
  turning the robot cannot use.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.base import option_value
from control.estimation.kernels import wrap
from control.fbl import XI_FLOOR, fbl_law_kernel, xi_period
from control.gains import FBLGains, check_period_stability
from control.inputs import check_reset
from control.switching import PerSegmentTracker, Record, SegmentedParams, period, state_dtype
from planning.core.robot import RobotSpec
from planning.trajectory.trajectory import Trajectory

__all__ = ["SegmentedParams", "SegmentedTracker"]

#: The state record: the switching's fields, then the FBL's gains, the blend and xi [m/s].
STATE = state_dtype([("kp", "f8"), ("kd", "f8"), ("xi_min", "f8"), ("xi_blend", "f8"), ("xi", "f8")])


@nb.njit(cache=True)
def drive(
    s: Record, ref: NDArray[np.void], k: int, x: float, y: float, theta: float, enter: bool, rested: bool
) -> tuple[float, float]:  # pragma: no cover - compiled
    """The FBL along a drive (the module doc): (v, omega) before clamping; advances ``s.xi``."""
    r = ref[k]
    sgn = r.sign
    if enter:
        s.xi = sgn * max(abs(r.v) if r.v * sgn > 0 else 0.0, XI_FLOOR)
    xi_dot, w_fbl = fbl_law_kernel(s.kp, s.kd, s.xi_min, x, y, theta, s.xi, r.x, r.y, r.dx, r.dy, r.ddx, r.ddy)
    v, s.xi = xi_period(s.xi, xi_dot, s.dt, s.vmax, sgn)
    alpha = min(abs(s.xi) / s.xi_blend, 1.0)
    if alpha < 1.0:
        return v, alpha * w_fbl + (1.0 - alpha) * (r.omega + s.heading_gain * wrap(r.theta - theta))
    return v, w_fbl


@nb.njit(cache=True)
def _period(
    state: NDArray[np.void], ref: NDArray[np.void], t: float, x: float, y: float, theta: float
) -> tuple[int, float, float]:  # pragma: no cover - compiled
    return period(state, ref, t, x, y, theta, drive)


class SegmentedTracker(PerSegmentTracker):
    """Per-segment FBL tracker (see the module doc).

    Source: the drives use the dynamic feedback linearisation of the EduMIP planning report,
    section III (:class:`control.fbl.DynamicFBL`), whose singularity at v = 0 (G. Oriolo,
    A. De Luca, M. Vendittelli, IEEE Trans. Control Systems Technology 10(6), 2002) is why cusps and
    turns in place switch law; the switching, the low-speed blend and the heading regulation are
    this project's design (README, "control/segmented.py").

    Args:
        robot: Limits (max_speed, max_yaw_rate).
        gains: FBL gains (Kp, Kd, xi_min); None for ``FBLGains()``.
        params: Heading, along-track and blending parameters; None for ``SegmentedParams()``.

    Raises:
        ConfigError: ``gains`` is not an :class:`FBLGains` or ``params`` not a :class:`SegmentedParams`.
    """

    name = "segmented"
    #: The option ``nhsim tune --tracker`` tunes, and its dataclass.
    TUNED = ("gains", FBLGains)
    STATE = STATE
    DRIVE = staticmethod(drive)
    PERIOD = staticmethod(_period)

    def __init__(
        self, robot: RobotSpec, *, gains: FBLGains | None = None, params: SegmentedParams | None = None
    ) -> None:
        self.gains = option_value(self.name, "gains", gains, FBLGains())
        self.params = option_value(self.name, "params", params, SegmentedParams())
        super().__init__(robot, self.params)

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """As :meth:`PerSegmentTracker.reset`, once the FBL's gains are known to be stable at a period of ``dt``.

        Raises:
            ConfigError: As :meth:`PerSegmentTracker.reset`.
            UnstableGainsError: Gains whose error dynamics a period of ``dt`` cannot keep stable.
        """
        check_period_stability(self.gains, check_reset(self.name, trajectory, dt), self.name)
        super().reset(trajectory, dt)

    def law_values(self) -> dict[str, float]:
        """The FBL's gains and the blend speed; xi starts at 0."""
        g = self.gains
        return {"kp": g.kp, "kd": g.kd, "xi_min": g.xi_min, "xi_blend": self.params.xi_blend, "xi": 0.0}

    @property
    def xi(self) -> float:
        """The compensator state xi of the last drive [m/s] (0 before the first)."""
        return 0.0 if self.state is None else float(self.state[0]["xi"])
