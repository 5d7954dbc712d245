"""Sinusoidal steering of the kinematic bicycle in chained form (Murray and Sastry, 1993).

The bicycle ``(x, y, theta, phi)`` with inputs ``u1`` (speed) and ``u2`` (steering rate) is written
in chained coordinates ``z = (z1, phi, alpha, z4)`` with virtual inputs ``(v1, v2)``:

standard model (headings near 0 or pi)::

    z1 = x, alpha = sin(theta), z4 = y, v1 = cos(theta) u1, v2 = u2
    z1' = v1, phi' = v2, alpha' = tan(phi) / l v1, z4' = alpha / (s sqrt(1 - alpha^2)) v1

alternate model (headings near +-pi/2, x and y exchanged)::

    z1 = y, alpha = cos(theta), z4 = x, v1 = sin(theta) u1, v2 = u2
    z1' = v1, phi' = v2, alpha' = -tan(phi) / l v1, z4' = alpha / (s sqrt(1 - alpha^2)) v1

with ``s = sign(cos theta)`` (standard) or ``sign(sin theta)`` (alternate) constant inside a region.
The heading circle is cut into four regions at the hand-off headings +-45 deg and +-135 deg; a
manoeuvre whose heading change crosses a hand-off is planned in pieces, one per region, each piece
ending on the hand-off heading, so no piece comes near its model's singularity (|alpha| = 1).

Inside a piece the four chained states are steered in turn:

1. ``z1``: ``v1 = (dz1 / T)(1 - cos wt)``, ``v2 = 0``;
2. ``phi``: ``v1 = 0``, ``v2 = (dphi / T)(1 - cos wt)``;
3. ``alpha``: ``v1 = a1 sin wt``, ``v2 = a2 cos wt``; ``z1`` and ``phi`` return, and
   ``dalpha = a1 * int_0^T f(phi(t)) sin wt dt`` is linear in ``a1``, solved in closed form;
4. ``z4``: ``v1 = a1 sin wt``, ``v2 = a2 cos 2wt``; ``z1``, ``phi`` and ``alpha`` return (``f`` is
   odd), ``dz4(a1)`` is nonlinear and ``a1`` is found by a bracketing root finder (Brent) until
   ``z4`` lands within ``tolerance``.

The amplitudes are bounded by ``u1max`` (``|a1| <= u1max``, and the executed ``u1 = v1 / cos``
checked along the step), ``u2max`` (``|a2| <= u2max``), ``phimax`` (steering amplitude) and the
robot's yaw-rate limit (``|u1 tan(phi) / l|``);
when a step cannot meet them its period is lengthened. The chained states are integrated by
Simpson quadrature on a fine grid (every state is an explicit integral of known time functions).

Obstacles are not this planner's business: the path is checked against them and a path that collides ends as
``INFEASIBLE``; a start or goal the footprint cannot take is ``INVALID_START`` or ``INVALID_GOAL`` before any
steering (:func:`planning.planners.base.end_overlaps`). State bounds (the robot's disc inside the world's walls,
``|phi| <= phimax``, the heading within ``max_heading_offset`` of its chart's centre) and input bounds are
checked and a violation is reported as ``BOUNDS_VIOLATED``: a joined path that leaves them (attached), and a
step that no period up to ``max_period`` makes within them (no path; the reason names the step, the bound its
longest period broke, and what would make it: a ``max_period`` that would, or another planner where the method
cannot, e.g. a sideways step at a hand-off heading, :meth:`Sinusoidal._z4_advice`).
A final state that misses the goal is ``FAILED`` (the
quadrature's numerical error). The problem's ``time_limit`` ends the plan as ``TIMEOUT``: the clock is
read before each quadrature over a step's grid (a few milliseconds at the longest period, 96,001 points),
each block of the fourth step's amplitudes and each of Brent's evaluations, and an answer known only after
the limit (a step that no period makes within the bounds, a joined path checked) is ``TIMEOUT`` too.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import cumulative_simpson, simpson
from scipy.optimize import brentq

from planning.core.checks import check_number
from planning.core.geometry import densify_path, wrap_angle
from planning.core.world import MAX_WORLD_SIDE, World
from planning.errors import ConfigError
from planning.planners.base import (
    PlanProblem,
    PlanResult,
    PlanStatus,
    checked_problem,
    end_outside,
    end_overlaps,
    path_collision,
)

FloatArray = NDArray[np.float64]

#: Hand-off headings between the standard and the alternate model [rad].
HANDOFFS = (-3 * math.pi / 4, -math.pi / 4, math.pi / 4, 3 * math.pi / 4)
_SUB = 8  # fine quadrature points per output interval
#: Finest output sample spacing [s]: the finest physics step of the robots (the balancing EduMIP's; 1e-9 asked for
#: 508 GiB of samples).
MIN_DT = 1e-3
#: Largest output sample spacing [s]: a tenth of the shortest step (``min_period``'s default, 2 s) at most, so that
#: the samples keep the sinusoids' shape.
MAX_DT = 0.2
#: Spacing [m] (with the robot's radius for turns) at which a path's clearance is measured between its samples.
CHECK_SPACING = 0.01
#: Most grid points (amplitudes times times) of the fourth step's amplitude scan between looks at the clock.
_SCAN_POINTS = 1 << 17


@dataclass(frozen=True)
class ChainedModel:
    """One chart of the chained form, valid for headings within 90 deg of ``center``.

    Attributes:
        center: Region centre heading: 0 or pi (standard), pi/2 or -pi/2 (alternate) [rad].
    """

    center: float

    @property
    def alternate(self) -> bool:
        """Whether x and y are exchanged (alpha = cos theta)."""
        return abs(math.cos(self.center)) < 0.5

    @property
    def name(self) -> str:
        """ "standard" or "alternate"."""
        return "alternate" if self.alternate else "standard"

    @property
    def s(self) -> float:
        """Sign of cos(theta) (standard) or sin(theta) (alternate) in the region."""
        return float(np.sign(math.sin(self.center) if self.alternate else math.cos(self.center)))

    @property
    def sigma(self) -> float:
        """Sign in alpha' = sigma tan(phi) / l v1."""
        return -1.0 if self.alternate else 1.0

    def to_chained(self, state: FloatArray) -> FloatArray:
        """Bicycle states (..., 4) [x, y, theta, phi] -> chained (..., 4) [z1, phi, alpha, z4]."""
        x, y, th, phi = (state[..., i] for i in range(4))
        if self.alternate:
            return np.stack([y, phi, np.cos(th), x], axis=-1)
        return np.stack([x, phi, np.sin(th), y], axis=-1)

    def from_chained(self, z: FloatArray) -> FloatArray:
        """Chained (..., 4) -> bicycle states (..., 4); theta in (-pi, pi]."""
        z1, phi, alpha, z4 = (z[..., i] for i in range(4))
        c = self.s * np.sqrt(np.clip(1.0 - alpha * alpha, 0.0, None))
        if self.alternate:
            return np.stack([z4, z1, np.arctan2(c, alpha), phi], axis=-1)
        return np.stack([z1, z4, np.arctan2(alpha, c), phi], axis=-1)

    def g(self, alpha: FloatArray) -> FloatArray:
        """z4' / v1 = alpha / (s sqrt(1 - alpha^2))."""
        return alpha / (self.s * np.sqrt(1.0 - alpha * alpha))

    def speed(self, v1: FloatArray, alpha: FloatArray) -> FloatArray:
        """The bicycle speed u1 = v1 / (s sqrt(1 - alpha^2)) [m/s]."""
        return v1 / (self.s * np.sqrt(1.0 - alpha * alpha))


def model_for(theta: float) -> ChainedModel:
    """The chart whose hand-off region [c - 45 deg, c + 45 deg] contains ``theta``."""
    c = round(float(wrap_angle(theta)) / (math.pi / 2)) * (math.pi / 2)
    return ChainedModel(float(wrap_angle(c)) if abs(abs(c) - math.pi) > 1e-9 else math.pi)


def heading_waypoints(theta0: float, theta1: float) -> list[float]:
    """Headings from ``theta0`` to ``theta1`` (the shorter way) with every hand-off crossed in between.

    Returns:
        Unwrapped headings [rad], first ``theta0``, last ``theta0 + wrap(theta1 - theta0)``.
    """
    delta = float(wrap_angle(theta1 - theta0))
    end = theta0 + delta
    lo, hi = sorted((theta0, end))
    k0 = math.ceil((lo - math.pi / 4) / (math.pi / 2) + 1e-12)
    k1 = math.floor((hi - math.pi / 4) / (math.pi / 2) - 1e-12)
    cuts = [math.pi / 4 + k * math.pi / 2 for k in range(k0, k1 + 1)]
    cuts = [c for c in cuts if lo + 1e-9 < c < hi - 1e-9]
    if delta < 0:
        cuts.reverse()
    return [theta0, *cuts, end]


@dataclass
class _Segment:
    t: FloatArray  # (M,) local time from 0 [s]
    z: FloatArray  # (M, 4) chained states
    v: FloatArray  # (M, 2) virtual inputs
    model: ChainedModel
    step: str


#: Where to plan instead when sinusoidal steering cannot make a step (both plan the user's heading reversals).
_OTHERS = "plan with hybrid-a-star or rrt-star (--planner hybrid-a-star)"


class _StepFailed(Exception):
    """A step cannot be made within the input limits and the heading's region (the message says which).

    Attributes:
        advice: What would make it, worded for the user: an option that lets the step through, or another planner.
    """

    def __init__(self, message: str, advice: str = _OTHERS) -> None:
        super().__init__(message)
        self.advice = advice


class _OutOfTime(Exception):
    """The problem's time limit passed while a step was being steered."""


class Sinusoidal:
    """Sinusoidal steering planner for the bicycle model.

    Args:
        u1max: Bound on |u1| [m/s] (default: the robot's max speed).
        u2max: Bound on |u2|, the steering rate [rad/s].
        phimax: Bound on |phi| [rad] (default: the robot's max steering angle).
        tolerance: Landing tolerance of the root search on the fourth state [m].
        dt: Output sample spacing [s].
        min_period: Shortest step duration [s].
        max_period: Longest step duration tried before giving up [s].
        max_heading_offset: Largest heading excursion from a piece's model centre [rad] (< pi/2).
    """

    name = "sinusoidal"
    #: It plans in an empty world (its paths are checked afterwards): ``simulate --all`` runs it on scenarios
    #: without obstacles only.
    ignores_obstacles = True

    def __init__(
        self,
        *,
        u1max: float | None = None,
        u2max: float = 2.0,
        phimax: float | None = None,
        tolerance: float = 1e-6,
        dt: float = 0.01,
        min_period: float = 2.0,
        max_period: float = 120.0,
        max_heading_offset: float = math.radians(80.0),
    ) -> None:
        self.u2max = check_number("sinusoidal: u2max", u2max, above=0.0)
        self.tolerance = check_number("sinusoidal: tolerance", tolerance, above=0.0)
        between = "s: from the finest physics step to a tenth of the shortest step"
        self.dt = check_number("sinusoidal: dt", dt, at_least=MIN_DT, at_most=MAX_DT, unit=between)
        self.min_period = check_number("sinusoidal: min_period", min_period, above=0.0)
        robots = "omit it for the robot's limit"
        self.u1max_opt = check_number("sinusoidal: u1max", u1max, above=0.0, optional=True, fix=robots)
        self.phimax_opt = check_number("sinusoidal: phimax", phimax, above=0.0, optional=True, fix=robots)
        if phimax is not None and phimax >= math.pi / 2:
            raise ConfigError(f"sinusoidal: phimax must be < pi/2, got {phimax}")
        if not 0 < max_heading_offset < math.pi / 2:
            raise ConfigError(f"sinusoidal: max_heading_offset must lie in (0, pi/2), got {max_heading_offset}")
        self.max_period = check_number("sinusoidal: max_period", max_period, above=0.0)
        if max_period < min_period:
            raise ConfigError(f"sinusoidal: max_period ({max_period}) must be >= min_period ({min_period})")
        self.alpha_lim = math.sin(max_heading_offset)
        # Set per problem by plan(): wheelbase [m] and the effective bounds.
        self.l = 0.1
        self.u1max = self.u1max_opt if self.u1max_opt is not None else 0.22
        self.phimax = self.phimax_opt if self.phimax_opt is not None else 0.6
        self.wmax = math.inf  # the differential drive's yaw-rate limit omega = u1 tan(phi) / l [rad/s]
        self._deadline = math.inf  # time.perf_counter() value at which the plan's time limit passes

    # -- steps ---------------------------------------------------------------------------------
    def _grid(self, period: float) -> FloatArray:
        n = max(2, math.ceil(period / self.dt - 1e-9))
        return np.linspace(0.0, period, n * _SUB + 1)

    def _integrate(self, m: ChainedModel, z0: FloatArray, t: FloatArray, v1: FloatArray, phi: FloatArray) -> FloatArray:
        """Chained states along ``t`` for given v1(t) and phi(t) (fine grid, Simpson quadrature)."""
        z = np.empty((t.size, 4))
        self._tick()
        z[:, 0] = z0[0] + cumulative_simpson(v1, x=t, initial=0.0)
        z[:, 1] = phi
        self._tick()
        z[:, 2] = z0[2] + cumulative_simpson(m.sigma * np.tan(phi) / self.l * v1, x=t, initial=0.0)
        if np.max(np.abs(z[:, 2])) >= self.alpha_lim + 1e-12:
            raise _StepFailed("the heading leaves its chart's region (max_heading_offset)")
        self._tick()
        z[:, 3] = z0[3] + cumulative_simpson(m.g(z[:, 2]) * v1, x=t, initial=0.0)
        return z

    def _accept(
        self, m: ChainedModel, t: FloatArray, z: FloatArray, v1: FloatArray, v2: FloatArray, step: str
    ) -> _Segment:
        u1 = m.speed(v1, z[:, 2])
        if np.max(np.abs(u1)) > self.u1max * (1 + 1e-9):
            raise _StepFailed(f"|u1| reaches {np.max(np.abs(u1)):.3g} m/s > u1max {self.u1max:.3g}")
        if np.max(np.abs(v2)) > self.u2max * (1 + 1e-9):
            raise _StepFailed(f"|u2| reaches {np.max(np.abs(v2)):.3g} rad/s > u2max {self.u2max:.3g}")
        yaw = np.max(np.abs(u1 * np.tan(z[:, 1]))) / self.l
        if yaw > self.wmax * (1 + 1e-9):
            raise _StepFailed(f"the yaw rate reaches {yaw:.3g} rad/s > the robot's {self.wmax:.3g}")
        if np.max(np.abs(z[:, 1])) > self.phimax * (1 + 1e-9):
            raise _StepFailed(f"|phi| reaches {np.max(np.abs(z[:, 1])):.3g} > phimax {self.phimax:.3g}")
        sl = slice(None, None, _SUB)
        return _Segment(t[sl], z[sl], np.column_stack([v1, v2])[sl], m, step)

    def _steer_z1(self, m: ChainedModel, z0: FloatArray, target: float) -> _Segment:
        d = target - z0[0]
        c = math.sqrt(max(1.0 - z0[2] ** 2, 1e-12))
        period = max(self.min_period, 2.0 * abs(d) / (0.98 * self.u1max * c))
        last = ""
        while period <= self.max_period:
            self._tick()
            t = self._grid(period)
            w = 2 * math.pi / period
            v1 = d / period * (1.0 - np.cos(w * t))
            try:
                z = self._integrate(m, z0, t, v1, np.full_like(t, z0[1]))
                return self._accept(m, t, z, v1, np.zeros_like(t), "z1")
            except _StepFailed as exc:
                last = str(exc)
                period *= 1.25
        need = 2.0 * abs(d) / (0.98 * self.u1max * c)
        advice = f"a max_period of at least {need:.4g} s (or a higher u1max) lets it through, or {_OTHERS}"
        raise _StepFailed(self._cannot(f"{'y' if m.alternate else 'x'} by {d:.3g} m", last), advice)

    def _steer_phi(self, m: ChainedModel, z0: FloatArray, target: float) -> _Segment:
        d = target - z0[1]
        period = max(self.min_period, 2.0 * abs(d) / (0.98 * self.u2max))
        self._tick()
        t = self._grid(period)
        w = 2 * math.pi / period
        v2 = d / period * (1.0 - np.cos(w * t))
        phi = z0[1] + d / period * (t - np.sin(w * t) / w)
        z = self._integrate(m, z0, t, np.zeros_like(t), phi)
        return self._accept(m, t, z, np.zeros_like(t), v2, "phi")

    def _phi_amp(self, phi0: float) -> float:
        return 0.95 * (self.phimax - abs(phi0))

    def _steer_alpha(self, m: ChainedModel, z0: FloatArray, target: float) -> _Segment:
        d = target - z0[2]
        period = self.min_period
        last = ""
        while period <= self.max_period:
            self._tick()
            w = 2 * math.pi / period
            amp = min(self.u2max / w, self._phi_amp(z0[1]))
            t = self._grid(period)
            phi = z0[1] + amp * np.sin(w * t)
            self._tick()
            gain = simpson(m.sigma * np.tan(phi) / self.l * np.sin(w * t), x=t)  # dalpha per unit a1
            a1 = d / gain
            last = f"the amplitude of u1 would be {abs(a1):.3g} m/s > u1max {self.u1max:.3g}"
            if abs(a1) <= self.u1max:
                v1 = a1 * np.sin(w * t)
                try:
                    z = self._integrate(m, z0, t, v1, phi)
                    return self._accept(m, t, z, v1, amp * w * np.cos(w * t), "alpha")
                except _StepFailed as exc:
                    last = str(exc)
            period *= 1.25
        advice = f"a longer max_period or a higher u1max lets it turn farther, or {_OTHERS}"
        raise _StepFailed(self._cannot(f"alpha by {d:.3g}", last), advice)

    def dz4(self, m: ChainedModel, z0: FloatArray, period: float, a1: float, a2: float) -> float:
        """Change of the fourth chained state over one z4 step (v1 = a1 sin wt, v2 = a2 cos 2wt).

        Args:
            m: The chart.
            z0: (4,) chained state at the step's start.
            period: Step duration T = 2 pi / w [s].
            a1: Amplitude of v1 [m/s].
            a2: Amplitude of v2 [rad/s].

        Returns:
            z4(T) - z4(0) [m].
        """
        t = self._grid(period)
        w = 2 * math.pi / period
        phi = z0[1] + a2 / (2 * w) * np.sin(2 * w * t)
        big_a = cumulative_simpson(m.sigma * np.tan(phi) / self.l * np.sin(w * t), x=t, initial=0.0)
        return float(a1 * simpson(m.g(z0[2] + a1 * big_a) * np.sin(w * t), x=t))

    def _steer_z4(self, m: ChainedModel, z0: FloatArray, target: float) -> _Segment:
        d = target - z0[3]
        period = self.min_period
        last = ""
        # the farthest any amplitude tried moves it; whether u1max capped the longest period's; whether an amplitude
        # found was then refused (u1 = v1 / cos, the yaw rate)
        reach, speed_bound, rejected = 0.0, False, False
        while period <= self.max_period:
            self._tick()
            w = 2 * math.pi / period
            t = self._grid(period)
            sw = np.sin(w * t)
            amp = min(self.u2max / (2 * w), self._phi_amp(z0[1]))
            refused = ""
            for sign in (1.0, -1.0):
                phi = z0[1] + sign * amp * np.sin(2 * w * t)
                root, far, speed_bound = self._z4_amplitude(m, z0, t, sw, phi, d)
                reach = max(reach, far)
                if root is None:
                    continue
                v1 = root * sw
                try:
                    z = self._integrate(m, z0, t, v1, phi)
                    return self._accept(m, t, z, v1, sign * amp * 2 * w * np.cos(2 * w * t), "z4")
                except _StepFailed as exc:
                    refused = str(exc)
            rejected = bool(refused)
            last = refused or (
                "no amplitude of u1 within u1max and the heading's region moves it that far; the farthest any "
                f"amplitude tried moves it is {reach:.3g} m"
            )
            period *= 1.25
        axis = "x" if m.alternate else "y"
        advice = _OTHERS if rejected else self._z4_advice(z0, axis, speed_bound)
        # from where the piece's earlier steps left it, which may lie far from the start (or beyond the walls)
        moved = f"{axis} by {d:.3g} m (from {axis} = {z0[3]:.3g} m, where the piece's earlier steps left it, to "
        moved += f"{target:.3g} m)"
        raise _StepFailed(self._cannot(moved, last), advice)

    def _z4_advice(self, z0: FloatArray, axis: str, speed_bound: bool) -> str:
        """What would make a fourth-state (sideways) step from chained state ``z0`` that no period made: a longer
        period when u1max capped the longest one's amplitude, else another planner (the heading's region caps the
        amplitude, and the step's reach no longer grows with the period: the path keeps its shape, only slower).
        No other option is named: a higher u1max or u2max moves it a little farther at short periods (0.287 to
        0.462 m for u1max 0.165 to 1 m/s on a user's heading reversal that needed 1.46 m), not as far as needed
        on the heading reversals measured."""
        if speed_bound:
            return f"a longer max_period or a higher u1max lets it move farther, or {_OTHERS}"
        off = math.degrees(math.asin(min(1.0, abs(float(z0[2])))))
        where = (
            f"{off:.0f} deg off its chart's centre: the farther off, the less the step moves sideways"
            if off > 1.0
            else "on its chart's centre"
        )
        return (
            f"this is a limit of sinusoidal steering, not of the world's walls: a piece moves {axis} sideways in one "
            f"step, at the piece's end heading ({where}), and at the longest periods the heading's region, not u1max, "
            f"caps that step's amplitude, so a longer max_period does not move it farther; {_OTHERS}"
        )

    def _z4_amplitude(
        self, m: ChainedModel, z0: FloatArray, t: FloatArray, sw: FloatArray, phi: FloatArray, d: float
    ) -> tuple[float | None, float, bool]:
        """The amplitude a1 > 0 of ``v1 = a1 sin wt`` (``sw``) that moves the fourth state by ``d`` with the
        steering ``phi`` over times ``t``, within u1max and the heading's region, found to ``tolerance``
        (the first sign change of 32 amplitudes, then Brent's method); None when there is none. Also: the
        farthest the 32 amplitudes move it in ``d``'s direction [m], and whether u1max (not the heading's region)
        capped them."""
        self._tick()
        big_a = cumulative_simpson(m.sigma * np.tan(phi) / self.l * sw, x=t, initial=0.0)
        # |alpha0 + a1 A(t)| <= alpha_lim bounds a1 (a1 > 0).
        with np.errstate(divide="ignore"):
            lim = np.where(
                big_a > 1e-15,
                (self.alpha_lim - z0[2]) / big_a,
                np.where(big_a < -1e-15, (self.alpha_lim + z0[2]) / -big_a, np.inf),
            )
        amax = min(self.u1max, 0.999 * float(np.min(lim)))
        speed_bound = amax >= self.u1max

        def h(a1: float) -> float:
            self._tick()
            return float(a1 * simpson(m.g(z0[2] + a1 * big_a) * sw, x=t)) - d

        grid = np.linspace(0.0, amax, 33)[1:]
        vals = self._z4_scan(m, z0[2], big_a, sw, t, grid)
        if vals is None:
            return None, 0.0, speed_bound
        far = max(0.0, float(np.max(vals * np.sign(d))))
        vals -= d
        prev_a, prev_v = 0.0, -d
        for a, val in zip(grid, vals, strict=True):
            if np.sign(val) != np.sign(prev_v) or val == 0.0:
                try:
                    root = float(brentq(h, prev_a, a, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200))
                except RuntimeError:  # not converged in maxiter: no amplitude at this period
                    return None, far, speed_bound
                return (root if abs(h(root)) <= self.tolerance else None), far, speed_bound
            prev_a, prev_v = a, val
        return None, far, speed_bound

    def _z4_scan(
        self, m: ChainedModel, alpha0: float, big_a: FloatArray, sw: FloatArray, t: FloatArray, grid: FloatArray
    ) -> FloatArray | None:
        """The fourth state's change ``a1 int g(alpha0 + a1 A(t)) sin wt dt`` for each amplitude of ``grid``, in
        blocks of at most :data:`_SCAN_POINTS` points with a look at the clock before each (row by row the
        same numbers as all at once); None when one reaches ``|alpha| >= 1``."""
        rows = max(1, _SCAN_POINTS // t.size)
        out = np.empty(grid.size)
        for i in range(0, grid.size, rows):
            self._tick()
            block = grid[i : i + rows]
            alpha = alpha0 + block[:, None] * big_a[None, :]
            if np.max(np.abs(alpha)) >= 1.0:
                return None
            out[i : i + rows] = block * simpson(m.g(alpha) * sw[None, :], x=t, axis=1)
        return out

    def _cannot(self, what: str, last: str) -> str:
        """Why a step could not steer ``what``: no period up to max_period kept the bounds; ``last``: how the
        longest period tried broke them (empty: none was tried)."""
        longest = f" (the longest period tried: {last})" if last else ""
        return (
            f"cannot steer {what} within the input limits (u1max, u2max, phimax, the robot's yaw rate) and "
            f"max_heading_offset at any period up to max_period = {self.max_period:g} s{longest}"
        )

    def _tick(self) -> None:
        """Raise :class:`_OutOfTime` once the problem's time limit has passed (before each period tried, each
        quadrature over its grid, each block of amplitudes scanned and each of Brent's evaluations)."""
        if time.perf_counter() > self._deadline:
            raise _OutOfTime

    def steer_piece(self, state0: FloatArray, state1: FloatArray, m: ChainedModel) -> list[_Segment]:
        """Steer the bicycle from ``state0`` to ``state1`` (both (4,)) in one chart.

        Returns:
            The non-trivial steps (z1, phi, alpha, z4 in that order).
        """
        goal = m.to_chained(state1)
        z = m.to_chained(state0)
        segs: list[_Segment] = []
        eps = (1e-12, 1e-12, 1e-12, self.tolerance * 1e-3)
        for idx, fn in enumerate((self._steer_z1, self._steer_phi, self._steer_alpha, self._steer_z4)):
            if abs(goal[idx] - z[idx]) <= eps[idx]:
                continue
            seg = fn(m, z, float(goal[idx]))
            segs.append(seg)
            z = seg.z[-1].copy()
        return segs

    # -- planning ------------------------------------------------------------------------------
    def plan(self, problem: PlanProblem) -> PlanResult:
        """Plan from ``problem.start`` to ``problem.goal`` (steering angle 0 at both ends)."""
        problem = checked_problem(problem)
        t_start = time.perf_counter()
        bad_end = end_outside(problem, self.name) or end_overlaps(problem, self.name)
        if bad_end is not None:
            bad_end.stats["time_s"] = time.perf_counter() - t_start
            return bad_end
        self._deadline = t_start + problem.time_limit
        robot = problem.robot
        self.l = robot.wheelbase
        self.u1max = self.u1max_opt if self.u1max_opt is not None else robot.max_speed
        self.phimax = self.phimax_opt if self.phimax_opt is not None else robot.max_steering
        self.wmax = robot.max_yaw_rate
        s0, s1 = problem.start, problem.goal
        headings = heading_waypoints(s0.theta, s1.theta)
        n_pieces = len(headings) - 1
        waypoints = [
            np.array([s0.x + (s1.x - s0.x) * k / n_pieces, s0.y + (s1.y - s0.y) * k / n_pieces, headings[k], 0.0])
            for k in range(n_pieces + 1)
        ]
        models = [model_for(0.5 * (headings[k] + headings[k + 1])) for k in range(n_pieces)]
        segs: list[_Segment] = []
        state = waypoints[0]
        k = 0
        try:
            for k, m in enumerate(models):
                piece = self.steer_piece(state, waypoints[k + 1], m)
                segs.extend(piece)
                if piece:
                    state = m.from_chained(piece[-1].z[-1])
        except _StepFailed as exc:  # the bounds, not obstacles: no step within them
            turns = 360.0 * round(math.degrees(headings[k]) / 360.0)  # whole turns off (a start heading of 100 rad)
            h0, h1 = math.degrees(headings[k]) - turns, math.degrees(headings[k + 1]) - turns
            turn = f"headings {h0:.0f} to {h1:.0f} deg" if round(h0) != round(h1) else f"heading {h0:.0f} deg"
            status = PlanStatus.BOUNDS_VIOLATED
            reason = f"sinusoidal steering of piece {k + 1} of {len(models)} ({turn}): {exc}; {exc.advice}"
        except _OutOfTime:
            status = PlanStatus.TIMEOUT
            reason = f"time limit of {problem.time_limit:g} s spent steering piece {k + 1} of {len(models)}"
        else:
            return self._in_time(problem, self._result(problem, segs, models, t_start))
        return self._in_time(
            problem, PlanResult(status, self.name, reason=reason, stats={"time_s": time.perf_counter() - t_start})
        )

    def _in_time(self, problem: PlanProblem, res: PlanResult) -> PlanResult:
        """``res``, or ``TIMEOUT`` (its path, if any, attached) when its answer came after the time limit: the
        last period tried, or the joined path's check, ended past it (the reason says what it would have been)."""
        if res.status is PlanStatus.TIMEOUT or time.perf_counter() <= self._deadline:
            return res
        found = res.status.value + (f": {res.reason}" if res.reason else "")
        reason = f"time limit of {problem.time_limit:g} s spent before the answer was known (it came after, {found})"
        return dataclasses.replace(res, status=PlanStatus.TIMEOUT, reason=reason)

    def _result(self, problem: PlanProblem, segs: list[_Segment], models: list[ChainedModel], t0: float) -> PlanResult:
        if segs:
            t, x, uu = self._assemble(problem, segs)
        else:  # already at the goal: the start alone, judged as any path (it may touch an obstacle or a wall)
            t, x, uu = np.zeros(1), np.append(problem.start.as_array(), 0.0)[None, :], np.zeros((1, 2))
        controls = np.column_stack([uu[:, 0], uu[:, 0] * np.tan(x[:, 3]) / self.l])
        direction = np.sign(uu[:, 0])
        for i in range(direction.size):
            if direction[i] == 0:
                direction[i] = direction[i - 1] if i else 1.0
        end = x[-1]
        stats: dict[str, Any] = {
            "time_s": time.perf_counter() - t0,
            "duration_s": float(t[-1]),
            "pieces": len(models),
            "handoffs": len(models) - 1,
            "models": ">".join(m.name for m in models),
            "steps": len(segs),
            "final_position_error": float(np.hypot(end[0] - problem.goal.x, end[1] - problem.goal.y)),
            "final_heading_error": abs(float(wrap_angle(end[2] - problem.goal.theta))),
            "max_u1": float(np.max(np.abs(uu[:, 0]))),
            "max_u2": float(np.max(np.abs(uu[:, 1]))),
            "max_phi": float(np.max(np.abs(x[:, 3]))),
        }
        status, reason = self._verdict(problem, t, x, controls, stats)
        stats["time_s"] = time.perf_counter() - t0  # the answer known
        arrays: dict[str, Any] = {
            "path": x[:, :3].copy(),
            "times": t,
            "controls": controls,
            "directions": direction,
            "states": x,
        }
        return PlanResult(status, self.name, reason=reason, stats=stats, **arrays)

    def _assemble(self, problem: PlanProblem, segs: list[_Segment]) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The steps joined: times (M,) [s], bicycle states (M, 4) with the heading unwrapped from the
        start's, and inputs (M, 2) [u1, u2]."""
        times, states, u = [], [], []
        offset = 0.0
        for i, sg in enumerate(segs):
            sl = slice(1, None) if i else slice(None)
            st = sg.model.from_chained(sg.z)
            times.append(sg.t[sl] + offset)
            states.append(st[sl])
            u.append(np.column_stack([sg.model.speed(sg.v[:, 0], sg.z[:, 2]), sg.v[:, 1]])[sl])
            offset += float(sg.t[-1])
        x = np.concatenate(states)
        x[:, 2] = np.unwrap(x[:, 2])
        x[:, 2] += problem.start.theta - x[0, 2]
        return np.concatenate(times), x, np.concatenate(u)

    def _verdict(
        self, problem: PlanProblem, t: FloatArray, x: FloatArray, controls: FloatArray, stats: dict[str, Any]
    ) -> tuple[PlanStatus, str]:
        """How the joined path ends: missing the goal, hitting an obstacle, leaving a bound, or success
        (adds the clearances to ``stats`` as far as it gets)."""
        pos_err, head_err = stats["final_position_error"], stats["final_heading_error"]
        if pos_err > problem.position_tolerance or head_err > problem.heading_tolerance:
            return PlanStatus.FAILED, f"final state misses the goal by {pos_err:.3g} m, {head_err:.3g} rad"
        world, r = problem.world, problem.robot.radius
        # the path between its samples as every later stage reads it (a coarse dt put 3 samples on edumip_map's
        # plan, and the disc, measured at them alone, missed the box the footprint crossed between two)
        dense = densify_path(x[:, :3], CHECK_SPACING, radius=r)
        if world.obstacles:
            d = world.obstacle_distance(dense[:, :2])
            i = int(np.argmin(d))
            stats["min_clearance"] = float(d[i] - r)
            # the disc a lower bound: where it reaches an obstacle, the footprint decides (a corridor 0.24 m wide
            # takes the TurtleBot3, 0.18 m across, whose disc is 0.25 m)
            hit = path_collision(x[:, :3], World(_around(world), world.obstacles), problem.robot) if d[i] < r else ""
            if hit:
                return PlanStatus.INFEASIBLE, (
                    f"sinusoidal steering does not avoid obstacles and its path hits one: {hit}; plan with a planner "
                    "that avoids them instead: 'rrt-star', 'birrt' or 'hybrid-a-star' (or 'optim', which keeps the "
                    "robot's disc clear of them and may refuse a start or goal closer than its radius)"
                )
        problems = []
        wall = world.wall_distance(dense[:, :2])
        stats["min_wall_clearance"] = float(np.min(wall) - r)
        # the disc's clearance from obstacles and walls alike, as every planner's stats and the record mean it
        stats["min_clearance"] = min(stats.get("min_clearance", np.inf), stats["min_wall_clearance"])
        if np.any(wall < r):  # the disc, which keeps the room its steering swings wide with from the walls
            j = int(np.argmax(wall < r))
            k = int(np.argmin(np.hypot(x[:, 0] - dense[j, 0], x[:, 1] - dense[j, 1])))  # the sample nearest it
            problems.append(
                f"the robot's disc (radius {r:.3f} m) leaves the world bounds near t = {t[k]:.2f} s "
                f"(centre {dense[j, 0]:.3f}, {dense[j, 1]:.3f})"
            )
        if stats["max_phi"] > self.phimax * (1 + 1e-9):
            problems.append(f"|phi| reaches {stats['max_phi']:.3f} > phimax {self.phimax:.3f}")
        max_w = float(np.max(np.abs(controls[:, 1])))
        over = (stats["max_u1"], self.u1max), (stats["max_u2"], self.u2max), (max_w, self.wmax)
        if any(value > bound * (1 + 1e-9) for value, bound in over):
            problems.append(f"inputs reach |u1| {stats['max_u1']:.3f}, |u2| {stats['max_u2']:.3f}, |omega| {max_w:.3f}")
        return (PlanStatus.BOUNDS_VIOLATED, "; ".join(problems)) if problems else (PlanStatus.SUCCESS, "")


def _around(world: World) -> tuple[float, float, float, float]:
    """Bounds up to a metre beyond ``world``'s on every side (as far as :data:`MAX_WORLD_SIDE` allows): a world of
    its obstacles alone, its walls out of the footprint's reach."""
    x0, x1, y0, y1 = world.bounds
    pad = min(1.0, 0.5 * (MAX_WORLD_SIDE - max(x1 - x0, y1 - y0)))
    return (x0 - pad, x1 + pad, y0 - pad, y1 + pad)
