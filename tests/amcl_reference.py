"""Plain-Python reference of :mod:`control.estimation.amcl_kernels`, written from Probabilistic Robotics
and Nav2's amcl sources independently of the compiled kernels (loops over Python floats)."""

from __future__ import annotations

import math

import numpy as np


def angle_diff(a: float, b: float) -> float:
    d = (a - b + math.pi) % (2 * math.pi) - math.pi
    return math.pi if d == -math.pi and a - b > 0 else d


def motion_update(particles, old, new, alphas, normals):  # type: ignore[no-untyped-def]
    dx, dy = new[0] - old[0], new[1] - old[1]
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < 0.01 else angle_diff(math.atan2(dy, dx), old[2])
    rot2 = angle_diff(angle_diff(new[2], old[2]), rot1)

    def fold(r: float) -> float:  # the smaller of the turn and the turn reversed
        return min(abs(r), math.pi - abs(r))

    n1, n2 = fold(rot1), fold(rot2)
    a1, a2, a3, a4 = alphas
    out = []
    for p, z in zip(particles, normals, strict=True):
        r1 = angle_diff(rot1, math.sqrt(a1 * n1**2 + a2 * trans**2) * z[0])
        tr = trans - math.sqrt(a3 * trans**2 + a4 * n1**2 + a4 * n2**2) * z[1]
        r2 = angle_diff(rot2, math.sqrt(a1 * n2**2 + a2 * trans**2) * z[2])
        out.append([p[0] + tr * math.cos(p[2] + r1), p[1] + tr * math.sin(p[2] + r1), p[2] + r1 + r2])
    return np.array(out)


def field_at(field, grid, x, y):  # type: ignore[no-untyped-def]
    x0, y0, h, far = grid[:4]
    fx, fy = (x - x0) / h, (y - y0) / h
    nx, ny = field.shape
    if not (0 <= fx <= nx - 1 and 0 <= fy <= ny - 1):
        return far
    i, j = min(int(fx), nx - 2), min(int(fy), ny - 2)
    u, v = fx - i, fy - j
    return (
        (1 - u) * (1 - v) * field[i, j]
        + (1 - u) * v * field[i, j + 1]
        + u * (1 - v) * field[i + 1, j]
        + u * v * field[i + 1, j + 1]
    )


def likelihood(particles, ranges, bearings, laser, field, grid, model):  # type: ignore[no-untyped-def]
    """p = 1 + sum pz^3 per particle, d at the grid node nearest to each end point (cap off the grid)."""
    z_hit, z_rand, sigma, rmax = model
    x0, y0, h, cap = grid[:4]
    out = []
    for x, y, th in particles:
        lx = x + math.cos(th) * laser[0] - math.sin(th) * laser[1]
        ly = y + math.sin(th) * laser[0] + math.cos(th) * laser[1]
        p = 1.0
        for r, b in zip(ranges, bearings, strict=True):
            a = th + laser[2] + b
            i = math.floor((lx + r * math.cos(a) - x0) / h + 0.5)
            j = math.floor((ly + r * math.sin(a) - y0) / h + 0.5)
            d = field[i, j] if 0 <= i < field.shape[0] and 0 <= j < field.shape[1] else cap
            pz = z_hit * math.exp(-(d**2) / (2 * sigma**2)) + z_rand / rmax
            p += pz**3
        out.append(p)
    return np.array(out)


def kld_limit(k, err, z, least, most):  # type: ignore[no-untyped-def]
    if k <= 1:
        return most
    b = 2 / (9 * (k - 1))
    n = math.ceil((k - 1) / (2 * err) * (1 - b + math.sqrt(b) * z) ** 3)
    return max(least, min(most, n))


def bin_of(p, bins, shape):  # type: ignore[no-untyped-def]
    i = min(max(math.floor((p[0] - bins[0]) / bins[2]), 0), shape[0] - 1)
    j = min(max(math.floor((p[1] - bins[1]) / bins[2]), 0), shape[1] - 1)
    t = min(math.floor((math.atan2(math.sin(p[2]), math.cos(p[2])) + math.pi) / bins[3]), shape[2] - 1)
    return (i, j, t)


def resample(particles, weights, offset, order, w_diff, coins, randoms, bins, shape, kld):  # type: ignore[no-untyped-def]
    m_max = len(order)
    cum = np.cumsum(weights)
    picks = []
    i = 0
    for m in range(m_max):
        u = (offset + m) / m_max
        while u > cum[i] and i < len(weights) - 1:
            i += 1
        picks.append(i)
    out, seen = [], set()
    for count in range(m_max):
        p = randoms[count] if (w_diff > 0 and coins[count] < w_diff) else particles[picks[order[count]]]
        out.append(np.array(p))
        seen.add(bin_of(p, bins, shape))
        if count + 1 > kld_limit(len(seen), kld[0], kld[1], int(kld[2]), m_max):
            break
    return np.array(out)


def beam_weight(z, noise):  # type: ignore[no-untyped-def]
    """Inverse variance of a range z [m] under noise (split, sd near [m], relative sd far, ambiguous band
    below and above the split [m]), 1 without; 0 within the band."""
    if noise[0] - noise[3] < z < noise[0] + noise[4]:
        return 0.0
    if noise[1] <= 0 and noise[2] <= 0:
        return 1.0
    return 1.0 / max(noise[1] if z < noise[0] else noise[2] * z, 1e-4) ** 2


def _gradient(field, grid, p):  # type: ignore[no-untyped-def]
    h = grid[2]
    return np.array(
        [
            (field_at(field, grid, p[0] + h / 2, p[1]) - field_at(field, grid, p[0] - h / 2, p[1])) / h,
            (field_at(field, grid, p[0], p[1] + h / 2) - field_at(field, grid, p[0], p[1] - h / 2)) / h,
        ]
    )


def beam_residual(field, grid, p, e, gate):  # type: ignore[no-untyped-def]
    """(used, residual, normal) of a beam ending at p along e: the map distance where p lies in front of a surface
    facing the ray; else the point-to-plane distance from where the ray, walked back in half-spacing steps (at
    most 2 gate), left the solid, the unit gradient there its normal (which must face the ray)."""
    d = field_at(field, grid, p[0], p[1])
    grad = _gradient(field, grid, p)
    if d >= 0 and grad @ e <= 0:
        return abs(d) <= gate, d, grad
    ts = [0.0]
    values = [d]
    while ts[-1] < 2 * gate:
        ts.append(len(ts) * grid[2] / 2)
        q = p - ts[-1] * e
        values.append(field_at(field, grid, q[0], q[1]))
        if values[-1] > 0 and any(v <= 0 for v in values[:-1]):
            t0, t1, v0, v1 = ts[-2], ts[-1], values[-2], values[-1]
            back = t0 + (t1 - t0) * (0 - v0) / (v1 - v0)
            n = _gradient(field, grid, p - back * e)
            if np.hypot(*n) < 0.5:
                return False, 0.0, n
            n = n / np.hypot(*n)
            r = float(n @ (back * e))
            return bool(n @ e < 0 and abs(r) <= gate), r, n
    return False, 0.0, grad


def fit_sensitivity(pose, ranges, bearings, laser, field, grid, gate, split, noise):  # type: ignore[no-untyped-def]
    """A^T W A of the scan-to-map fit at a pose, A = [J, u_scale, u_offset] (central differences), W the
    beams' inverse range variances."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    lx, ly = pose[0] + c * laser[0] - s * laser[1], pose[1] + s * laser[0] + c * laser[1]
    rows, ds, ws = [], [], []
    for z, bearing in zip(ranges, bearings, strict=True):
        e = np.array([math.cos(pose[2] + laser[2] + bearing), math.sin(pose[2] + laser[2] + bearing)])
        p = np.array([lx, ly]) + z * e
        used, d, grad = beam_residual(field, grid, p, e, gate)
        if not used or beam_weight(z, noise) == 0.0:
            continue
        lever = p - np.asarray(pose[:2], dtype=float)
        along = float(grad @ e)
        u = [along * z, 0.0] if z >= split else [0.0, along]
        rows.append([grad[0], grad[1], grad[1] * lever[0] - grad[0] * lever[1], *u])
        ds.append(d)
        ws.append(beam_weight(z, noise))
    a, d_, w = np.array(rows).reshape(-1, 5), np.array(ds), np.array(ws)
    return a.T @ (w[:, None] * a), len(ds), float(d_ @ (w * d_))


def fit_cost(pose, ranges, bearings, laser, field, grid, gate, noise):  # type: ignore[no-untyped-def]
    """The scan-to-map fit's objective at a pose: each weighed beam's w d^2, or w gate^2 with no surface within
    the gate (a truncated quadratic)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    origin = np.array([pose[0] + c * laser[0] - s * laser[1], pose[1] + s * laser[0] + c * laser[1]])
    cost = 0.0
    for z, bearing in zip(ranges, bearings, strict=True):
        w = beam_weight(z, noise)
        if w == 0.0:
            continue
        e = np.array([math.cos(pose[2] + laser[2] + bearing), math.sin(pose[2] + laser[2] + bearing)])
        ok, d, _ = beam_residual(field, grid, origin + z * e, e, gate)
        cost += w * (d * d if ok else gate * gate)
    return cost
