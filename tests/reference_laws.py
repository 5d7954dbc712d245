"""Plain-Python references of the compiled control laws and of the segment switching.

The compiled kernels in control/ are the implementation; these are written from the equations of
their module docs, in plain Python (math on floats, no numba), so the tests can check the
compiled code against them: the law and the period bit for bit where the arithmetic is the same.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from control.fbl import XI_FLOOR
from control.gains import FBLGains
from control.kanayama import KanayamaParams
from control.switching import SegmentedParams


def fbl_law(gains: FBLGains, x: float, y: float, theta: float, xi: float, ref: Sequence[float]) -> tuple[float, float]:
    """The dynamic FBL (control/fbl.py): (xi_dot, omega) for a pose, xi and the flat reference
    (x_d, y_d, xdot_d, ydot_d, xddot_d, yddot_d)."""
    xd, yd, dxd, dyd, ddxd, ddyd = ref
    c, s = math.cos(theta), math.sin(theta)
    w1 = ddxd - gains.kp * (x - xd) - gains.kd * (xi * c - dxd)
    w2 = ddyd - gains.kp * (y - yd) - gains.kd * (xi * s - dyd)
    xi_dot = c * w1 + s * w2
    guard = xi if abs(xi) >= gains.xi_min else math.copysign(gains.xi_min, xi if xi != 0.0 else 1.0)
    return xi_dot, (-s * w1 + c * w2) / guard


def xi_period(xi: float, xi_dot: float, dt: float, vmax: float, sign: float) -> tuple[float, float]:
    """The FBL's discretisation (control/fbl.py): (v before clamping, the next xi)."""
    v = xi + 0.5 * xi_dot * dt
    nxt = xi + xi_dot * dt
    if sign == 0.0:
        return v, min(max(nxt, -vmax), vmax)
    return v, sign * min(max(sign * nxt, XI_FLOOR), vmax)


def kanayama_law(params: KanayamaParams, x: float, y: float, theta: float, ref: Sequence[float]) -> tuple[float, float]:
    """Kanayama's law (control/kanayama.py) for ref = (x_r, y_r, theta_r, v_r, omega_r)."""
    xr, yr, thr, vr, wr = ref[:5]
    c, s = math.cos(theta), math.sin(theta)
    ex, ey = c * (xr - x) + s * (yr - y), -s * (xr - x) + c * (yr - y)
    eth = math.remainder(thr - theta, 2.0 * math.pi)
    return vr * math.cos(eth) + params.kx * ex, wr + vr * params.ky * ey + abs(vr) * params.ktheta * math.sin(eth)


def clamp(value: float, limit: float) -> float:
    """``value`` within [-limit, limit]."""
    return min(max(value, -limit), limit)


class Switcher:
    """The segment switching of control/switching.py in plain Python, driving a Python drive law.

    Args:
        ref: The tracker's reference table (control.switching.REFERENCE), read as Python floats.
        robot: Limits (max_speed, max_yaw_rate).
        turns: The switching's parameters.
        drive: ``drive(switcher, k, x, y, theta, enter, rested) -> (v, omega)``; its memory lives on
            the switcher (``switcher.memory``, a dict).
        smoothed: Whether the commands move by at most the robot's max_accel and max_yaw_accel per
            second from the last period's (a tracker's ``SMOOTHED``).
    """

    def __init__(self, ref: Any, t0: float, dt: float, goal: Sequence[float], robot: Any, turns: SegmentedParams,
                 drive: Callable[..., tuple[float, float]], smoothed: bool = False) -> None:  # fmt: skip
        self.rows = [dict(zip(ref.dtype.names, row.tolist(), strict=True)) for row in ref]
        self.t0, self.dt, self.goal = t0, dt, tuple(goal)
        self.vmax, self.wmax, self.turns, self.drive = robot.max_speed, robot.max_yaw_rate, turns, drive
        self.accel = (robot.max_accel, robot.max_yaw_accel) if smoothed else None
        self.last = (0.0, 0.0)
        self.segment, self.rested, self.memory = -1, True, {}  # type: ignore[var-annotated]

    def hold(self, x: float, y: float, theta: float, spot: Sequence[float], omega_ref: float) -> tuple[float, float]:
        """Hold ``spot`` (x, y) and turn to its heading."""
        c, s = math.cos(theta), math.sin(theta)
        along = (spot[0] - x) * c + (spot[1] - y) * s
        v = clamp(self.turns.along_gain * along, self.turns.hold_speed)
        return v, omega_ref + self.turns.heading_gain * math.remainder(spot[2] - theta, 2.0 * math.pi)

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """The period starting at ``t`` (the pose finite)."""
        k = round((t - self.t0) / self.dt)
        if k >= len(self.rows):
            v, w = self.hold(x, y, theta, self.goal, 0.0)
            self.rested = True
        else:
            k = max(k, 0)
            r = self.rows[k]
            if r["sign"] != 0.0:
                v, w = self.drive(self, k, x, y, theta, r["segment"] != self.segment, self.rested)
                v = r["sign"] * max(r["sign"] * v, 0.0)
                self.rested = False
            else:
                v, w = self.hold(x, y, theta, (r["x"], r["y"], r["theta"]), r["omega"] if r["turn"] else 0.0)
                self.rested = True
            self.segment = r["segment"]
        if not (math.isfinite(v) and math.isfinite(w)):
            return v, w  # the law's fault, passed on unclamped for the simulator to refuse
        v, w = clamp(v, self.vmax), clamp(w, self.wmax)
        if self.accel is not None:
            (v0, w0), (a, alpha) = self.last, self.accel
            v = min(max(v, v0 - a * self.dt), v0 + a * self.dt)
            w = min(max(w, w0 - alpha * self.dt), w0 + alpha * self.dt)
            self.last = (v, w)
        return v, w


def segmented_drive(gains: FBLGains, params: SegmentedParams) -> Callable[..., tuple[float, float]]:
    """The segmented tracker's drive law (control/segmented.py) for :class:`Switcher`."""

    def drive(sw: Switcher, k: int, x: float, y: float, theta: float, enter: bool, rested: bool) -> tuple[float, float]:
        r = sw.rows[k]
        sgn = r["sign"]
        if enter:
            sw.memory["xi"] = sgn * max(abs(r["v"]) if r["v"] * sgn > 0 else 0.0, XI_FLOOR)
        flat = (r["x"], r["y"], r["dx"], r["dy"], r["ddx"], r["ddy"])
        xi_dot, w_fbl = fbl_law(gains, x, y, theta, sw.memory["xi"], flat)
        v, xi = xi_period(sw.memory["xi"], xi_dot, sw.dt, sw.vmax, sgn)
        sw.memory["xi"] = xi
        alpha = min(abs(xi) / params.xi_blend, 1.0)
        if alpha < 1.0:
            heading = r["omega"] + params.heading_gain * math.remainder(r["theta"] - theta, 2.0 * math.pi)
            return v, alpha * w_fbl + (1.0 - alpha) * heading
        return v, w_fbl

    return drive


def kanayama_drive(params: KanayamaParams) -> Callable[..., tuple[float, float]]:
    """Kanayama's drive law (control/kanayama.py) for :class:`Switcher`."""

    def drive(sw: Switcher, k: int, x: float, y: float, theta: float, enter: bool, rested: bool) -> tuple[float, float]:
        r = sw.rows[k]
        return kanayama_law(params, x, y, theta, (r["x"], r["y"], r["theta"], r["v"], r["omega"]))

    return drive


def _crossing(cx: float, cy: float, radius: float, p1: Sequence[float], p2: Sequence[float]) -> tuple[float, float]:
    """Where p1 -> p2 (p1 inside the circle) leaves it (p2 for a degenerate segment)."""
    ax, ay, dx, dy = p1[0] - cx, p1[1] - cy, p2[0] - p1[0], p2[1] - p1[1]
    a = dx * dx + dy * dy
    if a < 1e-18:
        return p2[0], p2[1]
    b, c = 2.0 * (ax * dx + ay * dy), ax * ax + ay * ay - radius * radius
    s = min(max((-b + math.sqrt(max(b * b - 4.0 * a * c, 0.0))) / (2.0 * a), 0.0), 1.0)
    return p1[0] + s * dx, p1[1] + s * dy


def rpp_drive(params: Any, turns: SegmentedParams, patience: int = 4) -> Callable[..., tuple[float, float]]:
    """Regulated Pure Pursuit along a drive (control/rpp.py, steps 1-5) for :class:`Switcher`."""
    p = params

    def carrot(sw: Switcher, near: int, end: int, x: float, y: float, look: float, sgn: float) -> tuple:
        rows, dist = sw.rows, lambda j: math.hypot(sw.rows[j]["x"] - x, sw.rows[j]["y"] - y)
        near = min(near, end - 1)
        gap, j, misses = dist(near), near + 1, 0
        while j < end and misses < patience:
            if dist(j) < gap:
                near, gap, misses = j, dist(j), 0
            else:
                misses += 1
            j += 1
        target = rows[near]["arc"] + look - gap
        j = next((i for i in range(near, end) if rows[i]["arc"] >= target), end)
        while j < end and dist(j) < look:
            j += 1
        if j < end:
            i = max(j - 1, near)
            return (*_crossing(x, y, look, (rows[i]["x"], rows[i]["y"]), (rows[j]["x"], rows[j]["y"])), near)
        last, reach = rows[end - 1], sgn * 2.0 * look
        far = (last["x"] + reach * math.cos(last["theta"]), last["y"] + reach * math.sin(last["theta"]))
        return (*_crossing(x, y, look, (last["x"], last["y"]), far), near)

    def drive(sw: Switcher, k: int, x: float, y: float, theta: float, enter: bool, rested: bool) -> tuple[float, float]:
        r, m = sw.rows[k], sw.memory
        sgn, end = r["sign"], r["end"]
        if enter:
            m["near"] = r["start"]
        if rested:
            m["v_last"] = 0.0
        look = min(max(abs(m["v_last"]) * p.lookahead_time, p.min_lookahead), p.max_lookahead)
        if p.max_cut > 0.0:  # the tightest turn of the next `look` metres: its cut L^2 / (8 R) within max_cut
            first = min(m["near"], end - 1)
            ahead = [j for j in range(first, end) if sw.rows[j]["arc"] <= sw.rows[first]["arc"] + look]
            radii = [abs(sw.rows[j]["v"]) / abs(sw.rows[j]["omega"]) for j in ahead if abs(sw.rows[j]["omega"]) > 1e-9]
            if radii:
                look = min(look, max(p.min_lookahead, math.sqrt(8.0 * min(radii) * p.max_cut)))
        gx, gy, m["near"] = carrot(sw, m["near"], end, x, y, look, sgn)
        co, si = math.cos(theta), math.sin(theta)
        xc, yc = co * (gx - x) + si * (gy - y), -si * (gx - x) + co * (gy - y)
        bearing = math.atan2(yc, xc) if sgn > 0 else math.atan2(-yc, -xc)
        if abs(bearing) > p.rotate_angle:
            m["v_last"] = 0.0
            return 0.0, turns.heading_gain * bearing
        kappa = 2.0 * yc / max(xc * xc + yc * yc, 1e-12)
        desired = min(max(abs(r["v"]) + p.along_gain * sgn * (co * (r["x"] - x) + si * (r["y"] - y)), 0.0), sw.vmax)
        v = desired
        radius = 1.0 / abs(kappa) if kappa != 0.0 else math.inf
        if radius < p.min_radius:
            v = max(v * radius / p.min_radius, min(desired, p.min_regulated_speed))
        remaining = sw.rows[end - 1]["arc"] - sw.rows[m["near"]]["arc"]
        if remaining < p.approach_dist:
            v = max(v * remaining / p.approach_dist, min(desired, p.min_approach_speed))
        if abs(v * kappa) > sw.wmax:
            v = sw.wmax / abs(kappa)
        m["v_last"] = sgn * v
        return sgn * v, sgn * v * kappa

    return drive
