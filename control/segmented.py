"""A tracker for planned paths: feedback linearisation per drive, heading control for turns in place.

Dynamic feedback linearisation (control/fbl.py) divides by its compensator state xi = v, so it is
singular where the reference stops: at every cusp, at every turn in place, at the start and at the
goal. A planned trajectory (planning/trajectory/from_plan.py) is labelled with segments ("forward",
"reverse", "rotate", "hold"; a trajectory without labels gets them from the sign of v, by
:func:`planning.trajectory.segments.infer_segments`), and this tracker switches law per segment:

* **Drives.** On entering a drive, xi is re-initialised to the reference speed, with the drive's
  sign (so the singularity guard and the law act in the drive's direction even from rest), and it is
  kept on that side of zero for the whole drive: a drive never reverses by itself. The law is the
  seed's FBL (``fbl_law``). Where |xi| is below ``xi_blend`` (starting and stopping), omega is blended
  towards a heading controller ``omega_ref + k_heading * wrap(theta_ref - theta)`` in proportion to
  |xi| / xi_blend, because there the FBL's lateral correction divided by a vanishing xi would ask for
  turning the robot cannot use.
* **Turns in place and stand-stills.** omega = omega_ref + k_heading * wrap(theta_ref - theta); a
  small v = k_along * (along-heading position error) holds the spot.
* **After the end** the same regulation holds the final pose, so the heading reaches the goal too.

Every command is clamped to the robot's |v| and |omega| limits and is finite (a non-finite
intermediate becomes a stop); a non-finite time or pose is refused (SimulationError), as by every tracker.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.base import check_measured_pose, check_period, check_positive_fields, option_value
from control.estimation.kernels import wrap
from control.fbl import FBLGains, FlatReference, fbl_law_kernel
from planning.core.robot import RobotSpec
from planning.trajectory.segments import infer_segments
from planning.trajectory.trajectory import Trajectory, TrajectorySamples


class _Instant(NamedTuple):
    """The reference at one control instant, as Python floats."""

    x: float
    y: float
    theta: float
    v: float
    omega: float
    flat: FlatReference
    segment: int


class _Instants:
    """The reference at a trajectory's control instants, each :class:`_Instant` made when it is read.

    The numbers are kept in columns of Python floats: thousands of tuples made at once (one per
    instant) woke the garbage collector, which then spent more than a run's whole control loop.

    Args:
        s: The reference sampled at the control instants.
        segment: (M,) the segment in force at each instant.
    """

    def __init__(self, s: TrajectorySamples, segment: NDArray[np.int64]) -> None:
        self._columns = tuple(c.tolist() for c in (s.x, s.y, s.theta, s.v, s.omega, s.dx, s.dy, s.ddx, s.ddy))
        self._segment = segment.tolist()

    def __len__(self) -> int:
        return len(self._segment)

    def __getitem__(self, k: int) -> _Instant:
        x, y, th, v, w, dx, dy, ddx, ddy = self._columns
        return _Instant(x[k], y[k], th[k], v[k], w[k], (x[k], y[k], dx[k], dy[k], ddx[k], ddy[k]), self._segment[k])


@dataclass(frozen=True)
class SegmentedParams:
    """Parameters of the segmented tracker besides its FBL gains; all finite and > 0.

    Attributes:
        heading_gain: k_heading of the heading controller [1/s].
        along_gain: k_along of the spot-holding speed [1/s].
        xi_blend: Speed below which omega blends from FBL to heading control [m/s].
        hold_speed: |v| bound while holding a spot [m/s].
    """

    heading_gain: float = 3.0
    along_gain: float = 2.0
    xi_blend: float = 0.04
    hold_speed: float = 0.05

    def __post_init__(self) -> None:
        why = "xi_blend divides, and the gains and the hold speed must pull towards the reference"
        check_positive_fields(self, ("heading_gain", "along_gain", "xi_blend", "hold_speed"), why)


class SegmentSwitcher:
    """The segment switching every per-segment tracker shares (see the module doc).

    A subclass gives the law of the drives (:meth:`_drive`) and the parameters of the turns in place
    and stand-stills (``self._turns``: heading_gain, along_gain, hold_speed of a
    :class:`SegmentedParams`); this class pre-samples the reference and its segment at every control
    instant, switches law by segment, holds the final pose after the end, clamps every command to
    the robot's limits and turns a non-finite one into a stop.

    Args:
        robot: Limits (max_speed, max_yaw_rate).
        turns: Heading and spot-holding parameters of turns in place, stand-stills and the end.
    """

    name = "segment-switcher"

    def __init__(self, robot: RobotSpec, turns: SegmentedParams) -> None:
        self.robot = robot
        self._turns = turns
        self.segment = -1
        self._instants: _Instants | list[_Instant] = []
        self._path: np.ndarray = np.zeros((0, 3))  # (M, 3) reference pose at each control instant
        self._block = np.zeros((1, 13))  # constants, then the instants as numbers (see reset)
        self._kinds: tuple[str, ...] = ()
        self._signs: tuple[float, ...] = ()
        self._spans: list[tuple[int, int]] = []
        self._final = (0.0, 0.0, 0.0)
        self._vmax, self._wmax = float(robot.max_speed), float(robot.max_yaw_rate)
        self._dt = 0.02
        self._t0 = 0.0
        self._traj: Trajectory | None = None

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking: pre-sample the reference and its segment at every control instant.

        Raises:
            ConfigError: The control period ``dt`` [s] is not a finite number > 0.
        """
        self._dt = dt = check_period(self.name, dt, trajectory)
        self._traj = trajectory
        self._t0 = float(trajectory.t[0])
        if trajectory.segments is not None:
            seg, kinds = trajectory.segments, trajectory.segment_kinds
        else:
            inferred = infer_segments(trajectory.vel[:, 0], trajectory.vel[:, 1])
            seg, kinds = inferred.index, inferred.kinds
        n = math.ceil(trajectory.duration / dt) + 1
        times = self._t0 + dt * np.arange(n)
        s = trajectory.sample_many(times)
        # the segment in force at a control instant: that of the last sample at or before it
        idx = np.clip(np.searchsorted(trajectory.t, times + 1e-9, side="right") - 1, 0, trajectory.t.size - 1)
        at = seg[idx]
        self._instants = _Instants(s, at)
        self._path = np.column_stack([s.x, s.y, s.theta])
        # per segment: +1 forwards, -1 backwards, 0 turn in place or stand-still
        signs = np.array([1.0 if k == "forward" else (-1.0 if k == "reverse" else 0.0) for k in kinds])
        # for compiled drives: row 0 the constants (T0 .., a subclass's from LAW), then the instants as
        # numbers: x, y, theta, v, omega, the flat reference, segment, sign
        table = np.column_stack([s.x, s.y, s.theta, s.v, s.omega, s.x, s.y, s.dx, s.dy, s.ddx, s.ddy, at, signs[at]])
        self._block = np.vstack([np.zeros((1, table.shape[1])), table])
        self._block[0, :LAW] = (self._t0, dt, self._vmax, self._wmax)
        self._spans = [
            (int(np.searchsorted(at, i)), int(np.searchsorted(at, i, side="right"))) for i in range(len(kinds))
        ]
        self._kinds = tuple(kinds)
        self._signs = tuple(signs.tolist())  # (read once a period)
        self._final = (float(trajectory.pose[-1, 0]), float(trajectory.pose[-1, 1]), float(trajectory.pose[-1, 2]))
        self.segment = -1
        self._idle()

    def _idle(self) -> None:
        """Called whenever no drive is under way (reset, turns, stand-stills, after the end)."""

    def _drive(
        self, x: float, y: float, theta: float, ref: _Instant, sgn: float, k: int
    ) -> tuple[float, float]:  # pragma: no cover - abstract
        """The law of a drive of direction ``sgn`` at control instant ``k``: (v, omega) before clamping."""
        raise NotImplementedError

    def _regulate(
        self, x: float, y: float, theta: float, spot: tuple[float, float, float], omega_ref: float
    ) -> tuple[float, float]:
        """Hold ``spot`` (x, y) and turn to its heading: (v, omega) before clamping."""
        c, s = math.cos(theta), math.sin(theta)
        along = (spot[0] - x) * c + (spot[1] - y) * s
        v = min(max(self._turns.along_gain * along, -self._turns.hold_speed), self._turns.hold_speed)
        err = math.remainder(spot[2] - theta, 2.0 * math.pi)
        return v, omega_ref + self._turns.heading_gain * err

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command for the period starting at ``t``.

        Raises:
            SimulationError: ``t`` or the pose is not finite.
        """
        if self._traj is None:
            raise RuntimeError(f"{type(self).__name__}.command called before reset")
        if not math.isfinite(t + x + y + theta):
            check_measured_pose(self.name, t, x, y, theta)  # raises
        k = round((t - self._t0) / self._dt)
        if k >= len(self._instants):
            v, w = self._regulate(x, y, theta, self._final, 0.0)
            self._idle()
        else:
            k = k if k > 0 else 0
            ref = self._instants[k]
            sgn = self._signs[ref.segment]
            if sgn != 0.0:
                v, w = self._drive(x, y, theta, ref, sgn, k)
            else:
                rotate = self._kinds[ref.segment] == "rotate"
                v, w = self._regulate(x, y, theta, (ref.x, ref.y, ref.theta), ref.omega if rotate else 0.0)
                self._idle()
            self.segment = ref.segment
        if not (math.isfinite(v) and math.isfinite(w)):
            v, w = 0.0, 0.0
        vmax, wmax = self._vmax, self._wmax
        return (-vmax if v < -vmax else (vmax if v > vmax else v)), (-wmax if w < -wmax else (wmax if w > wmax else w))


#: Slots of row 0 of a segment switcher's block: the start time [s], the control period [s], the speed
#: and yaw-rate limits, then the drive law's constants (a subclass's), from LAW.
T0, DT, VMAX, WMAX, LAW = range(5)
#: A compiled drive period's status: a command; the general path decides (not a drive under way).
DRIVE, GENERAL = range(2)


@nb.njit(cache=True, inline="always")
def drive_row(
    t: float, x: float, y: float, theta: float, segment: int, block: NDArray[np.float64]
) -> int:  # pragma: no cover - compiled
    """The row of a segment switcher's block (row 1 + k: control instant k) whose drive is under way at
    ``t`` in ``segment`` (the segment of the last period), or -1: not a drive, a new segment, past the
    end, or a non-finite time or pose (the general path decides)."""
    c = block[0]
    if not math.isfinite(t + x + y + theta):
        return -1
    k = round((t - c[T0]) / c[DT])
    if k >= block.shape[0] - 1:
        return -1
    i = 1 + (k if k > 0 else 0)
    if block[i, 12] == 0.0 or block[i, 11] != segment:
        return -1
    return i


@nb.njit(cache=True, inline="always")
def clamp_command(v: float, w: float, c: NDArray[np.float64]) -> tuple[float, float]:  # pragma: no cover - compiled
    """:meth:`SegmentSwitcher.command`'s last step: a non-finite command is a stop; then the limits in
    row 0 ``c`` of the block."""
    if not (math.isfinite(v) and math.isfinite(w)):
        v, w = 0.0, 0.0
    vmax, wmax = c[VMAX], c[WMAX]
    return (-vmax if v < -vmax else (vmax if v > vmax else v)), (-wmax if w < -wmax else (wmax if w > wmax else w))


@nb.njit(cache=True)
def _drive_step(
    c: NDArray[np.float64],
    xi: float,
    x: float,
    y: float,
    theta: float,
    ref_theta: float,
    ref_omega: float,
    sgn: float,
    xd: float,
    yd: float,
    dxd: float,
    dyd: float,
    ddxd: float,
    ddyd: float,
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """:meth:`SegmentedTracker._drive` after a drive's start, compiled: (v, omega, the next xi) for row 0
    ``c`` of the block (the law's constants from LAW: Kp, Kd, xi_min, xi_blend, the heading gain)."""
    kp, kd, xi_min, xi_blend, heading_gain = c[LAW], c[LAW + 1], c[LAW + 2], c[LAW + 3], c[LAW + 4]
    xi_dot, w_fbl = fbl_law_kernel(kp, kd, xi_min, x, y, theta, xi, xd, yd, dxd, dyd, ddxd, ddyd)
    dt = c[DT]
    v = xi + 0.5 * xi_dot * dt
    xi = sgn * min(max(sgn * (xi + xi_dot * dt), 1e-6), c[VMAX])
    alpha = min(abs(xi) / xi_blend, 1.0)
    if alpha < 1.0:
        w = alpha * w_fbl + (1.0 - alpha) * (ref_omega + heading_gain * wrap(ref_theta - theta))
    else:
        w = w_fbl
    return sgn * max(sgn * v, 0.0), w, xi


@nb.njit(cache=True)
def _drive_period(
    t: float, x: float, y: float, theta: float, xi: float, segment: int, block: NDArray[np.float64]
) -> tuple[int, float, float, float]:  # pragma: no cover - compiled
    """:meth:`SegmentedTracker.command` in one compiled call while a drive is under way
    (:func:`drive_row`): (DRIVE, v, omega, the next xi), clamped as the general path clamps; (GENERAL,
    nan, nan, xi) for the general path to decide, nothing changed."""
    i = drive_row(t, x, y, theta, segment, block)
    if i < 0:
        return GENERAL, math.nan, math.nan, xi
    r, c = block[i], block[0]
    v, w, xi = _drive_step(c, xi, x, y, theta, r[2], r[4], r[12], r[5], r[6], r[7], r[8], r[9], r[10])
    v, w = clamp_command(v, w, c)
    return DRIVE, v, w, xi


class SegmentedTracker(SegmentSwitcher):
    """Per-segment tracker (see the module doc).

    Source: the drives use the dynamic feedback linearisation of seed report 003, section III
    (:class:`control.fbl.DynamicFBL`), whose singularity at v = 0 (G. Oriolo, A. De Luca,
    M. Vendittelli, IEEE Trans. Control Systems Technology 10(6), 2002) is why cusps and turns in
    place switch law; the switching, the low-speed blend and the heading regulation are this
    project's design (README, "control/segmented.py").

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

    def __init__(
        self, robot: RobotSpec, *, gains: FBLGains | None = None, params: SegmentedParams | None = None
    ) -> None:
        self.gains = option_value(self.name, "gains", gains, FBLGains())
        self.params = option_value(self.name, "params", params, SegmentedParams())
        self.xi = 0.0
        super().__init__(robot, self.params)

    def _idle(self) -> None:
        self.xi = 0.0

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking (see :meth:`SegmentSwitcher.reset`); the gains and parameters are taken as
        they are now."""
        super().reset(trajectory, dt)
        g, p = self.gains, self.params
        self._block[0, LAW : LAW + 5] = (g.kp, g.kd, g.xi_min, p.xi_blend, p.heading_gain)

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command for the period starting at ``t`` (see :meth:`SegmentSwitcher.command`): one
        compiled call while a drive is under way (:func:`_drive_period`)."""
        if self._traj is not None:
            status, v, w, xi = _drive_period(t, x, y, theta, self.xi, self.segment, self._block)
            if status == DRIVE:
                self.xi = xi
                return v, w
        return super().command(t, x, y, theta)

    def _drive(self, x: float, y: float, theta: float, ref: _Instant, sgn: float, k: int) -> tuple[float, float]:
        """FBL along a drive of direction ``sgn`` (+1 forwards, -1 backwards): (v, omega) before clamping;
        advances xi by one period, keeping it on the drive's side of zero (compiled: :func:`_drive_step`)."""
        if ref.segment != self.segment:
            self.xi = sgn * max(abs(ref.v) if ref.v * sgn > 0 else 0.0, 1e-6)
        v, w, self.xi = _drive_step(self._block[0], self.xi, x, y, theta, ref.theta, ref.omega, sgn, *ref.flat)
        return v, w
