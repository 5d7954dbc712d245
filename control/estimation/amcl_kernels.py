"""The compiled steps of :mod:`control.estimation.amcl` (Monte Carlo localisation).

Every random number is drawn by the caller from a numpy generator and passed in, so the kernels
are deterministic functions of their arguments; ``tests/amcl_reference.py`` holds a plain-Python
reference of each, checked against them.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.core.copy_kernels import copy_into

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@nb.njit(cache=True)
def angle_diff(a: float, b: float) -> float:
    """``a - b`` wrapped to [-pi, pi] (Nav2 amcl's ``angle_diff``) [rad]."""
    return _wrapped_diff(math.atan2(math.sin(a), math.cos(a)), math.atan2(math.sin(b), math.cos(b)))


@nb.njit(cache=True, inline="always")
def _wrapped_diff(a: float, b: float) -> float:
    """:func:`angle_diff` of two angles already wrapped to [-pi, pi] [rad]."""
    d1 = a - b
    d2 = 2.0 * math.pi - abs(d1)
    if d1 > 0:
        d2 *= -1.0
    return d1 if abs(d1) < abs(d2) else d2


@nb.njit(cache=True)
def motion_update(
    particles: FloatArray, old: FloatArray, new: FloatArray, alphas: FloatArray, normals: FloatArray
) -> None:
    """Sample the odometry motion model into ``particles`` in place (Probabilistic Robotics table 5.6
    as Nav2's ``DifferentialMotionModel`` does it).

    Args:
        particles: (N, 3) poses (x, y, theta) [m, m, rad], moved in place.
        old: (3,) odometry pose at the last update.
        new: (3,) odometry pose now.
        alphas: (4,) alpha1..alpha4 [-].
        normals: (N, 3) standard normal draws.
    """
    dx, dy = new[0] - old[0], new[1] - old[1]
    trans = math.sqrt(dx * dx + dy * dy)
    rot1 = 0.0 if trans < 0.01 else angle_diff(math.atan2(dy, dx), old[2])
    rot2 = angle_diff(angle_diff(new[2], old[2]), rot1)
    rot1_n = min(abs(angle_diff(rot1, 0.0)), abs(angle_diff(rot1, math.pi)))
    rot2_n = min(abs(angle_diff(rot2, 0.0)), abs(angle_diff(rot2, math.pi)))
    a1, a2, a3, a4 = alphas[0], alphas[1], alphas[2], alphas[3]
    s_rot1 = math.sqrt(a1 * rot1_n * rot1_n + a2 * trans * trans)
    s_trans = math.sqrt(a3 * trans * trans + a4 * rot1_n * rot1_n + a4 * rot2_n * rot2_n)
    s_rot2 = math.sqrt(a1 * rot2_n * rot2_n + a2 * trans * trans)
    for i in range(particles.shape[0]):
        r1 = angle_diff(rot1, s_rot1 * normals[i, 0])
        tr = trans - s_trans * normals[i, 1]
        r2 = angle_diff(rot2, s_rot2 * normals[i, 2])
        th = particles[i, 2]
        particles[i, 0] += tr * math.cos(th + r1)
        particles[i, 1] += tr * math.sin(th + r1)
        particles[i, 2] = th + r1 + r2


@nb.njit(cache=True)
def field_at(field: FloatArray, x0: float, y0: float, h: float, far: float, x: float, y: float) -> float:
    """Bilinear value of a distance grid at (x, y) [m]; ``far`` outside the grid."""
    fx, fy = (x - x0) / h, (y - y0) / h
    nx, ny = field.shape
    if not (fx >= 0.0 and fy >= 0.0 and fx <= nx - 1 and fy <= ny - 1):
        return far
    i, j = min(int(fx), nx - 2), min(int(fy), ny - 2)
    u, v = fx - i, fy - j
    return (1 - u) * ((1 - v) * field[i, j] + v * field[i, j + 1]) + u * (
        (1 - v) * field[i + 1, j] + v * field[i + 1, j + 1]
    )


@nb.njit(cache=True)
def likelihood_update(
    particles: FloatArray,
    weights: FloatArray,
    ranges: FloatArray,
    bearings: FloatArray,
    laser: FloatArray,
    table: FloatArray,
    grid: FloatArray,
    outside: float,
) -> float:
    """Weigh particles by the likelihood-field model (Nav2's ``LikelihoodFieldModel``), in place.

    Per particle, ``p = 1 + sum_i pz_i^3`` over the beams, ``pz^3`` read from ``table`` at the grid
    node nearest to each beam's end point (Nav2 reads the map cell's distance the same way);
    ``weights *= p``.

    Args:
        particles: (N, 3) poses.
        weights: (N,) weights, multiplied in place.
        ranges: (B,) ranges of the beams used (finite, below range_max) [m].
        bearings: (B,) their bearings in the scanner's frame [rad].
        laser: (3,) scanner pose in the robot's frame (x, y, yaw).
        table: (nx, ny) ``pz^3`` at each grid node (:func:`pz_cubed`).
        grid: (x0, y0, h, ...) of ``table``: origin and spacing [m].
        outside: ``pz^3`` of an end point off the grid.

    Returns:
        The sum of the new weights.
    """
    x0, y0, inv_h = grid[0], grid[1], 1.0 / grid[2]
    nx, ny = table.shape
    nb_ = ranges.shape[0]
    ex, ey = np.empty(nb_), np.empty(nb_)  # end points in the robot's frame
    for b in range(nb_):
        ex[b] = laser[0] + ranges[b] * math.cos(laser[2] + bearings[b])
        ey[b] = laser[1] + ranges[b] * math.sin(laser[2] + bearings[b])
    total = 0.0
    for k in range(particles.shape[0]):
        c, s = math.cos(particles[k, 2]), math.sin(particles[k, 2])
        px, py = (particles[k, 0] - x0) * inv_h + 0.5, (particles[k, 1] - y0) * inv_h + 0.5
        cs, ss = c * inv_h, s * inv_h
        p = 1.0
        for b in range(nb_):
            i = math.floor(px + cs * ex[b] - ss * ey[b])
            j = math.floor(py + ss * ex[b] + cs * ey[b])
            p += table[i, j] if 0 <= i < nx and 0 <= j < ny else outside
        weights[k] *= p
        total += weights[k]
    return total


def pz_cubed(d: FloatArray, model: FloatArray) -> FloatArray:
    """``pz^3`` of the likelihood-field model for map distances ``d`` [m]: ``pz = z_hit exp(-d^2 / (2
    sigma_hit^2)) + z_rand / range_max`` with ``model = (z_hit, z_rand, sigma_hit, range_max)``."""
    z_hit, z_rand, sigma, rmax = model
    pz = z_hit * np.exp(-(d * d) / (2.0 * sigma * sigma)) + z_rand / rmax
    return np.asarray(pz * pz * pz)


@nb.njit(cache=True)
def kld_limit(k: int, err: float, z: float, least: int, most: int) -> int:
    """Particles needed for ``k`` occupied bins (Fox 2003; Nav2's ``pf_resample_limit``, which uses
    ``pf_z`` itself as the normal quantile), clamped to [least, most]; ``most`` for k <= 1."""
    if k <= 1:
        return most
    b = 2.0 / (9.0 * (k - 1))
    x = 1.0 - b + math.sqrt(b) * z
    n = math.ceil((k - 1) / (2.0 * err) * x * x * x)
    return max(least, min(most, n))


@nb.njit(cache=True)
def bin_index(x: float, y: float, th: float, bins: FloatArray, shape: IntArray) -> int:
    """Flat index of a pose's histogram bin: (x0, y0, size_xy, size_th) in ``bins``, grid ``shape``."""
    return _bin_of(x, y, math.atan2(math.sin(th), math.cos(th)), bins, shape)


@nb.njit(cache=True, inline="always")
def _bin_of(x: float, y: float, wrapped: float, bins: FloatArray, shape: IntArray) -> int:
    """:func:`bin_index` of a pose whose heading is already wrapped to [-pi, pi]."""
    i = min(max(math.floor((x - bins[0]) / bins[2]), 0), shape[0] - 1)
    j = min(max(math.floor((y - bins[1]) / bins[2]), 0), shape[1] - 1)
    m = min(math.floor((wrapped + math.pi) / bins[3]), shape[2] - 1)
    return (i * shape[1] + j) * shape[2] + m


@nb.njit(cache=True)
def resample(
    particles: FloatArray,
    weights: FloatArray,
    offset: float,
    order: IntArray,
    w_diff: float,
    coins: FloatArray,
    randoms: FloatArray,
    bins: FloatArray,
    shape: IntArray,
    kld: FloatArray,
    out: FloatArray,
) -> int:
    """Low-variance resampling with KLD-adaptive size and random-particle recovery.

    The low-variance sampler (Probabilistic Robotics table 4.4) picks ``M = len(order)`` indices
    at ``(offset + m) / M`` of the weights' cumulative sum; they are taken in ``order`` (a random
    permutation, so any prefix is an unbiased sample) until the count exceeds the KLD limit of the
    bins occupied so far (Nav2's ``pf_update_resample``). Sample ``j`` is instead ``randoms[j]``
    when ``coins[j] < w_diff`` (augmented MCL, table 8.3).

    Args:
        particles: (N, 3) current set.
        weights: (N,) normalised weights.
        offset: Low-variance offset in [0, 1).
        order: (M,) permutation of range(M), M the largest set.
        w_diff: Probability of a random particle, max(0, 1 - w_fast / w_slow).
        coins: (M,) uniform draws (unused when w_diff is 0; may then be empty).
        randoms: (M, 3) random poses in free space (same).
        bins: (x0, y0, size_xy, size_th) of the KLD histogram.
        shape: (3,) its number of bins per axis.
        kld: (pf_err, pf_z, min_particles).
        out: (M, 3) filled with the new set.

    Returns:
        The new set's size.
    """
    n, m_max = particles.shape[0], order.shape[0]
    idx = np.empty(m_max, dtype=np.int64)
    c, i = weights[0], 0
    for m in range(m_max):
        u = (offset + m) / m_max
        while u > c and i < n - 1:
            i += 1
            c += weights[i]
        idx[m] = i
    seen = np.zeros(shape[0] * shape[1] * shape[2], dtype=np.bool_)
    k, count = 0, 0
    least = int(kld[2])
    while count < m_max:
        if w_diff > 0.0 and coins[count] < w_diff:
            copy_into(out[count], randoms[count])
        else:
            copy_into(out[count], particles[idx[order[count]]])
        b = bin_index(out[count, 0], out[count, 1], out[count, 2], bins, shape)
        if not seen[b]:
            seen[b] = True
            k += 1
        count += 1
        if count > kld_limit(k, kld[0], kld[1], least, m_max):
            break
    return count


@nb.njit(cache=True)
def cluster_estimate(
    particles: FloatArray, weights: FloatArray, bins: FloatArray, shape: IntArray
) -> tuple[FloatArray, FloatArray, float]:
    """Mean and covariance of the heaviest cluster: the particles in the 3 x 3 x 3 bins around the
    bin of most weight (headings wrapping).

    Returns:
        (3,) mean (circular in theta), (3, 3) covariance, the cluster's share of the weight.
    """
    nb_ = shape[0] * shape[1] * shape[2]
    mass = np.zeros(nb_)
    n = particles.shape[0]
    which = np.empty(n, dtype=np.int64)
    # each heading's sine, cosine and wrapped value, computed once (bin_index's, the mean's and angle_diff's alike)
    sin, cos, wrapped = np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):
        th = particles[k, 2]
        sin[k], cos[k] = math.sin(th), math.cos(th)
        wrapped[k] = math.atan2(sin[k], cos[k])
        which[k] = _bin_of(particles[k, 0], particles[k, 1], wrapped[k], bins, shape)
        mass[which[k]] += weights[k]
    best = int(np.argmax(mass))
    bt, bj, bi = best % shape[2], (best // shape[2]) % shape[1], best // (shape[1] * shape[2])
    w, sx, sy, sc, ss = 0.0, 0.0, 0.0, 0.0, 0.0
    inside = np.zeros(n, dtype=np.bool_)
    for k in range(n):
        t = which[k] % shape[2]
        j = (which[k] // shape[2]) % shape[1]
        i = which[k] // (shape[1] * shape[2])
        dt = min((t - bt) % shape[2], (bt - t) % shape[2])
        if abs(i - bi) <= 1 and abs(j - bj) <= 1 and dt <= 1:
            inside[k] = True
            wk = weights[k]
            w += wk
            sx += wk * particles[k, 0]
            sy += wk * particles[k, 1]
            sc += wk * cos[k]
            ss += wk * sin[k]
    mean = np.array([sx / w, sy / w, math.atan2(ss, sc)])
    cov = np.zeros((3, 3))
    mean_wrapped = math.atan2(math.sin(mean[2]), math.cos(mean[2]))
    for k in range(n):
        if inside[k]:
            e0, e1 = particles[k, 0] - mean[0], particles[k, 1] - mean[1]
            e2 = _wrapped_diff(wrapped[k], mean_wrapped)  # angle_diff(particles[k, 2], mean[2])
            e = (e0, e1, e2)
            for a in range(3):
                for b in range(3):
                    cov[a, b] += weights[k] * e[a] * e[b] / w
    return mean, cov, w


#: Smallest standard deviation of a range a weight is taken from [m] (a scanner without white noise).
MIN_RANGE_STD = 1e-4
#: :func:`beam_weight`'s noise when the scanner's is not known: every beam weighs the same.
NO_NOISE_MODEL = np.zeros(5)
NO_NOISE_MODEL.setflags(write=False)


@nb.njit(cache=True, inline="always")
def beam_weight(z: float, noise: FloatArray) -> float:  # pragma: no cover - compiled
    """The weight of a beam of range ``z`` [m] in the fit: the inverse variance of its white noise, given as
    ``noise`` = (split [m], standard deviation below it [m], relative standard deviation from it [-],
    the split's ambiguous band below and above it [m]) (the LDS-01's datasheet precision,
    :mod:`sim.physics.lidar`), at least :data:`MIN_RANGE_STD`; 1 for every beam when both standard
    deviations are 0 (no noise model: :data:`NO_NOISE_MODEL`).

    0 (the beam is left out) when ``z`` is within the band about the split: the scanner's systematic error
    is an offset below the split and a scale beyond it, decided by the true range, which a reading
    that close cannot tell (a unit reading 5 % short puts a wall 0.52 m away at 0.495 m); such a beam's
    error is the other model's, up to the whole band, and the near beams' weight would let it move the fit.
    """
    if noise[0] - noise[3] < z < noise[0] + noise[4]:
        return 0.0
    if noise[1] <= 0.0 and noise[2] <= 0.0:
        return 1.0
    sd = max(noise[1] if z < noise[0] else noise[2] * z, MIN_RANGE_STD)
    return 1.0 / (sd * sd)


@nb.njit(cache=True)
def weighed_beams(ranges: FloatArray, noise: FloatArray) -> int:  # pragma: no cover - compiled
    """How many of the beams of ranges ``ranges`` [m] the fit weighs (:func:`beam_weight` above 0: all but those
    read within the band about the split of the scanner's error)."""
    n = 0
    for z in ranges:
        if beam_weight(z, noise) > 0.0:
            n += 1
    return n


@nb.njit(cache=True)
def _solve3(a: FloatArray, ridge: float, b: FloatArray) -> FloatArray:  # pragma: no cover - compiled
    """``x`` of ``(a + ridge I) x = b`` for a (3, 3) ``a``: Gaussian elimination with partial pivoting, as
    LAPACK's ``gesv`` (``np.linalg.solve``) does it; numba's ``np.linalg.solve`` copies ``b`` by a slice
    assignment, whose error message took seconds to compile in every new process (``planning.core.arrays``)."""
    m = np.empty((3, 4))
    for i in range(3):
        for j in range(3):
            m[i, j] = a[i, j] + (ridge if i == j else 0.0)
        m[i, 3] = b[i]
    for c in range(3):
        p = c
        for r in range(c + 1, 3):
            if abs(m[r, c]) > abs(m[p, c]):
                p = r
        if p != c:
            for j in range(4):
                m[c, j], m[p, j] = m[p, j], m[c, j]
        for r in range(c + 1, 3):
            f = m[r, c] / m[c, c]
            for j in range(c, 4):
                m[r, j] -= f * m[c, j]
    x = np.empty(3)
    for i in range(2, -1, -1):
        s = m[i, 3]
        for j in range(i + 1, 3):
            s -= m[i, j] * x[j]
        x[i] = s / m[i, i]
    return x


@nb.njit(cache=True, inline="always")
def field_gradient(
    field: FloatArray, x0: float, y0: float, h: float, far: float, x: float, y: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """The distance grid's gradient at (x, y), by central differences half a spacing either side."""
    gx = (field_at(field, x0, y0, h, far, x + 0.5 * h, y) - field_at(field, x0, y0, h, far, x - 0.5 * h, y)) / h
    gy = (field_at(field, x0, y0, h, far, x, y + 0.5 * h) - field_at(field, x0, y0, h, far, x, y - 0.5 * h)) / h
    return gx, gy


@nb.njit(cache=True)
def beam_residual(
    field: FloatArray, grid: FloatArray, px: float, py: float, ex: float, ey: float, gate: float
) -> tuple[bool, float, float, float]:  # pragma: no cover - compiled
    """A beam's residual in the fit: the signed distance of its end point (``px``, ``py``) [m] from the mapped
    surface its ray, of direction (``ex``, ``ey``), meets, and that surface's normal there, as (used, residual [m],
    normal x, normal y); used is False when there is none within ``gate`` [m].

    An end point in front of a surface that faces the scanner (its map distance ``d >= 0``, the distance's gradient
    against the ray) takes ``d`` and the gradient, as the fit always did. Any other, inside a solid or nearest a
    surface that faces away, is measured from where its ray entered the solid it ended in or behind: the
    point-to-plane distance ``n . (p - q)`` from the entry point ``q``, found walking back along the ray a half
    spacing at a time (at most twice the gate) to the first point with ``d > 0`` after one with ``d <= 0`` (the
    zero crossing between them, by linear interpolation), and ``n`` the unit gradient there, which must face the
    ray. A ray cannot meet a surface from behind: with the nearest surface taken instead, an end point past the
    middle of a thin wall (a ROS map's walls are a pixel or two, 5-10 cm, against the LDS-01's 3.5 % range noise,
    7-10 cm at 2-3 m) was pulled to its far face, and one beyond an obstacle at the world's edge to the seam of the
    two, where the distance is 0 inside the solid: 3.4 cm of bias in a room of 10 cm walls, 0.7 cm with 40 cm
    ones.
    """
    x0, y0, h, far = grid[0], grid[1], grid[2], grid[3]
    d = field_at(field, x0, y0, h, far, px, py)
    gx, gy = field_gradient(field, x0, y0, h, far, px, py)
    if d >= 0.0 and gx * ex + gy * ey <= 0.0:
        return abs(d) <= gate, d, gx, gy
    step = 0.5 * h
    inside = d <= 0.0
    prev, t = d, 0.0
    while t < 2.0 * gate:
        t += step
        v = field_at(field, x0, y0, h, far, px - t * ex, py - t * ey)
        if v <= 0.0:
            inside = True
        elif inside:
            back = t - step * v / (v - prev)  # the zero crossing between t - step (prev <= 0) and t (v > 0)
            qx, qy = px - back * ex, py - back * ey
            nx, ny = field_gradient(field, x0, y0, h, far, qx, qy)
            norm = math.hypot(nx, ny)
            if norm < 0.5:  # no surface there (a seam, the grid's edge)
                return False, 0.0, 0.0, 0.0
            nx, ny = nx / norm, ny / norm
            facing = nx * ex + ny * ey
            r = back * facing  # n . (p - q), p - q = back e
            return facing < 0.0 and abs(r) <= gate, r, nx, ny
        prev = v
    return False, 0.0, 0.0, 0.0


@nb.njit(cache=True, inline="always")
def _laser_origin(pose: FloatArray, laser: FloatArray) -> tuple[float, float]:  # pragma: no cover - compiled
    """Where the scanner sits at ``pose`` (x [m], y [m], theta [rad]), ``laser`` its (x, y, yaw) on the robot [m]."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return pose[0] + c * laser[0] - s * laser[1], pose[1] + s * laser[0] + c * laser[1]


@nb.njit(cache=True, inline="always")
def _beam_fit(
    pose: FloatArray,
    lx: float,
    ly: float,
    z: float,
    bearing: float,
    laser: FloatArray,
    field: FloatArray,
    grid: FloatArray,
    gate: float,
    noise: FloatArray,
) -> tuple[float, bool, float, float, float, float, float]:  # pragma: no cover - compiled
    """One beam of range ``z`` at ``bearing`` in the scan-to-map fit at ``pose``, the scanner at (``lx``, ``ly``):
    (its weight, :func:`beam_weight`; then :func:`beam_residual`'s used, residual and normal; its end point), the
    weight 0 for a beam the fit leaves out (the rest then 0)."""
    w = beam_weight(z, noise)
    if w == 0.0:
        return 0.0, False, 0.0, 0.0, 0.0, 0.0, 0.0
    a = pose[2] + laser[2] + bearing
    ex, ey = math.cos(a), math.sin(a)
    px, py = lx + z * ex, ly + z * ey
    ok, d, gx, gy = beam_residual(field, grid, px, py, ex, ey, gate)
    return w, ok, d, gx, gy, px, py


@nb.njit(cache=True, inline="always")
def _fit_pass(
    x: FloatArray,
    ranges: FloatArray,
    bearings: FloatArray,
    laser: FloatArray,
    field: FloatArray,
    grid: FloatArray,
    gate: float,
    noise: FloatArray,
    info: FloatArray,
    g: FloatArray,
) -> tuple[int, float, float]:  # pragma: no cover - compiled
    """One pass of the scan-to-map fit over the beams at ``x``: ``J^T W J`` into ``info`` and ``J^T W d`` into ``g``
    (both overwritten); returns (beams within the gate, their ``sum w d^2``, the whole objective :func:`fit_cost`)."""
    info[:] = 0.0
    g[:] = 0.0
    # an int64 from the start: a literal 0 had numba type the inlined pass's callers' calls with it first, and
    # compile _descend once more for that type
    used: int = np.int64(0)  # type: ignore[assignment]
    ssr, cost = 0.0, 0.0
    lx, ly = _laser_origin(x, laser)
    for b in range(ranges.shape[0]):
        w, ok, d, gx, gy, px, py = _beam_fit(x, lx, ly, ranges[b], bearings[b], laser, field, grid, gate, noise)
        if w == 0.0:
            continue
        cost += w * (d * d if ok else gate * gate)
        if not ok:
            continue
        jac = (gx, gy, -gx * (py - x[1]) + gy * (px - x[0]))
        for i in range(3):
            g[i] += w * jac[i] * d
            for j in range(3):
                info[i, j] += w * jac[i] * jac[j]
        used += 1
        ssr += w * d * d
    return used, ssr, cost


#: A scan-to-map fit's state after :func:`refine`: (pose (3,), ``J^T W J`` (3, 3) and ``J^T W d`` (3,) at it, the
#: beams within the gate, their ``sum w d^2``, the objective :func:`fit_cost` at the pose).
Fit = tuple[FloatArray, FloatArray, FloatArray, int, float, float]


#: The basis of a fit free in every direction (:func:`refine`).
WHOLE = np.eye(3)
WHOLE.setflags(write=False)


@nb.njit(cache=True, inline="always")
def _step(info: FloatArray, g: FloatArray, basis: FloatArray) -> FloatArray:  # pragma: no cover - compiled
    """The Gauss-Newton step within the span of ``basis``'s columns (orthonormal; a zero column: a direction held):
    ``B (B^T info B)^-1 B^T g``, a held direction's row and column of ``B^T info B`` replaced by the identity's.
    With the identity as basis, the products are exact: the plain step ``info^-1 g``, bit for bit."""
    m, h = np.empty((3, 3)), np.empty(3)
    for i in range(3):
        h[i] = basis[0, i] * g[0] + basis[1, i] * g[1] + basis[2, i] * g[2]
        for j in range(3):
            acc = 0.0
            for a in range(3):
                acc += basis[a, i] * (info[a, 0] * basis[0, j] + info[a, 1] * basis[1, j] + info[a, 2] * basis[2, j])
            m[i, j] = acc
    for i in range(3):
        if basis[0, i] == 0.0 and basis[1, i] == 0.0 and basis[2, i] == 0.0:
            m[i, :] = 0.0
            m[:, i] = 0.0
            m[i, i] = 1.0
    z = _solve3(m, 1e-9, h)
    return basis @ z


@nb.njit(cache=True)
def _descend(
    x: FloatArray,
    info: FloatArray,
    g: FloatArray,
    used: int,
    ssr: float,
    cost: float,
    ranges: FloatArray,
    bearings: FloatArray,
    laser: FloatArray,
    field: FloatArray,
    grid: FloatArray,
    gate: float,
    iterations: int,
    noise: FloatArray,
    basis: FloatArray,
) -> Fit:  # pragma: no cover - compiled
    """Gauss-Newton steps from ``x``, whose pass (:func:`_fit_pass`) gave ``info``, ``g``, ``used``, ``ssr`` and
    ``cost``, within the span of ``basis`` (:func:`_step`): at most ``iterations``, fewer once a step moves less
    than 1e-5 (m and rad); every array updated in place. The state returned is the last pass's, at the pose
    returned."""
    done = iterations <= 0
    for k in range(iterations + 1):
        if k > 0:
            used, ssr, cost = _fit_pass(x, ranges, bearings, laser, field, grid, gate, noise, info, g)
        if used < 10 or done:
            break
        step = _step(info, g, basis)
        x -= step
        done = abs(step[0]) + abs(step[1]) < 1e-5 and abs(step[2]) < 1e-5
        if k == iterations - 1:
            done = True
    return x, info, g, used, ssr, cost


@nb.njit(cache=True)
def refine(
    pose: FloatArray,
    ranges: FloatArray,
    bearings: FloatArray,
    laser: FloatArray,
    field: FloatArray,
    grid: FloatArray,
    gate: float,
    iterations: int,
    noise: FloatArray,
) -> Fit:
    """Scan-to-map refinement: Gauss-Newton on the squared signed map distances of the beams' end points from the
    surfaces their rays meet (:func:`beam_residual`), each weighted by its range's precision (:func:`beam_weight`;
    all alike without a noise model).

    Beams whose end point is farther than ``gate`` [m] from the surface its ray meets (unmapped obstacles,
    or a wrong pose) are left out of each iteration.

    Args:
        pose: (3,) starting pose.
        ranges, bearings, laser: As :func:`likelihood_update`.
        field: (nx, ny) signed distance to the nearest obstacle or wall, negative inside [m].
        grid: (x0, y0, h, far[, slope]) of ``field`` (:func:`field_slope`).
        gate: Largest |distance| of a beam used [m].
        iterations: Most Gauss-Newton steps.
        noise: (5,) the scanner's white range noise and the split's ambiguous band (:func:`beam_weight`).

    Returns:
        The fit (:data:`Fit`): the refined pose, the information ``J^T W J`` and ``J^T W d`` at it, the number of
        beams in it, the weighted sum of their squared distances (``W`` the weights: the identity without a noise
        model, then the sum is in m^2; with one, the inverse variances, and the sum is a chi-square) and the
        objective there (:func:`fit_cost`). :func:`resume` takes it further.
    """
    return refine_within(pose, ranges, bearings, laser, field, grid, gate, iterations, noise, WHOLE)


@nb.njit(cache=True)
def refine_within(
    pose: FloatArray,
    ranges: FloatArray,
    bearings: FloatArray,
    laser: FloatArray,
    field: FloatArray,
    grid: FloatArray,
    gate: float,
    iterations: int,
    noise: FloatArray,
    basis: FloatArray,
) -> Fit:  # pragma: no cover - compiled
    """:func:`refine` moving the pose only within the span of ``basis``'s orthonormal columns (a zero column
    holds a direction where it starts): the fit of a scan that fixes some directions only (a corridor's walls:
    across it and the heading, not along it). :data:`WHOLE` is :func:`refine` itself."""
    x = pose.copy()
    info, g = np.zeros((3, 3)), np.zeros(3)
    used, ssr, cost = _fit_pass(x, ranges, bearings, laser, field, grid, gate, noise, info, g)
    return _descend(x, info, g, used, ssr, cost, ranges, bearings, laser, field, grid, gate, iterations, noise, basis)


@nb.njit(cache=True)
def resume(
    fit: Fit,
    ranges: FloatArray,
    bearings: FloatArray,
    laser: FloatArray,
    field: FloatArray,
    grid: FloatArray,
    gate: float,
    iterations: int,
    noise: FloatArray,
    basis: FloatArray,
) -> Fit:  # pragma: no cover - compiled
    """:func:`refine_within` started at a fit's pose, of the same scan, without repeating the pass at it that the
    fit already holds: the same result, bit for bit, one pass sooner (``fit`` is left as it is)."""
    x, info, g, used, ssr, cost = fit
    return _descend(
        x.copy(), info.copy(), g.copy(), used, ssr, cost, ranges, bearings, laser, field, grid, gate, iterations,
        noise, basis,
    )  # fmt: skip


@nb.njit(cache=True)
def fit_cost(
    pose: FloatArray,
    ranges: FloatArray,
    bearings: FloatArray,
    laser: FloatArray,
    field: FloatArray,
    grid: FloatArray,
    gate: float,
    noise: FloatArray,
) -> float:  # pragma: no cover - compiled
    """The objective :func:`refine` minimises at ``pose``, whole: each weighed beam's ``w d^2`` (:func:`beam_weight`,
    :func:`beam_residual`), or ``w gate^2`` for one with no surface within ``gate`` (a truncated quadratic, the
    gated fit's robust loss). Two fits of one scan are compared by it (:func:`refine` gives it at its pose): by the
    beams within the gate alone, one beam more outweighed a residual three times larger (a pose 0.5 m along a wall,
    chosen over the right one).

    Args:
        pose, ranges, bearings, laser, field, grid, gate, noise: As :func:`refine`.
    """
    return _fit_pass(pose, ranges, bearings, laser, field, grid, gate, noise, np.zeros((3, 3)), np.zeros(3))[2]


@nb.njit(cache=True)
def fit_sensitivity(
    pose: FloatArray,
    ranges: FloatArray,
    bearings: FloatArray,
    laser: FloatArray,
    field: FloatArray,
    grid: FloatArray,
    gate: float,
    split: float,
    noise: FloatArray,
) -> tuple[FloatArray, int, float]:
    """The scan-to-map fit's information at ``pose``, extended by the scanner's systematic range
    errors: a relative scale error ``k`` (a beam of range ``z`` at or beyond ``split`` [m] reads
    ``z (1 + k)``) and an offset ``b`` (nearer beams read ``z + b``).

    With the residuals ``d_i`` (signed map distances of the beams' end points from the surfaces their rays meet,
    beams within ``gate`` as :func:`refine` uses them, :func:`beam_residual`) and their pose Jacobian ``J``, a
    systematic error moves every end point along its beam: ``d_i`` changes by ``u_i = n_i . (z_i e_i)`` per unit
    of ``k`` (far beams) or ``n_i . e_i`` per metre of ``b`` (near ones), ``e_i`` the beam's direction and ``n_i``
    the surface's normal (the distance's gradient). With
    ``A = [J, u_k, u_b]`` (the columns x, y, theta, k, b), the (weighted) least-squares pose moves by
    ``-(J^T W J)^-1 J^T W u`` per unit of each error.

    Args:
        pose: (3,) the fit's pose.
        ranges, bearings, laser, field, grid, gate, noise: As :func:`refine`.
        split: Range [m] from which the error is relative.

    Returns:
        (5, 5) ``A^T W A`` (``W`` the beams' weights, as :func:`refine`'s), the beams used and the
        weighted sum of their squared distances.
    """
    ata = np.zeros((5, 5))
    row = np.zeros(5)
    used, ssr = 0, 0.0
    c, s = math.cos(pose[2]), math.sin(pose[2])
    lx, ly = pose[0] + c * laser[0] - s * laser[1], pose[1] + s * laser[0] + c * laser[1]
    for b in range(ranges.shape[0]):
        w = beam_weight(ranges[b], noise)
        if w == 0.0:
            continue
        a = pose[2] + laser[2] + bearings[b]
        ex, ey = math.cos(a), math.sin(a)
        px, py = lx + ranges[b] * ex, ly + ranges[b] * ey
        ok, d, gx, gy = beam_residual(field, grid, px, py, ex, ey, gate)
        if not ok:
            continue
        along = gx * ex + gy * ey
        row[0], row[1], row[2] = gx, gy, -gx * (py - pose[1]) + gy * (px - pose[0])
        row[3], row[4] = (along * ranges[b], 0.0) if ranges[b] >= split else (0.0, along)
        for i in range(5):
            for j in range(5):
                ata[i, j] += w * row[i] * row[j]
        used += 1
        ssr += w * d * d
    return ata, used, ssr


def field_slope(field: FloatArray, h: float) -> float:
    """The largest change of a distance grid between two neighbouring nodes, per metre (1 for an exact distance
    field, up to rounding; made a little larger, so that rounding cannot make it too small): between two nodes
    ``di``, ``dj`` apart the values differ by at most ``slope h (|di| + |dj|)``, which lets :func:`rays_through`
    skip the nodes that cannot be inside a surface yet."""
    steps = [np.abs(np.diff(field, axis=a)).max(initial=0.0) for a in (0, 1)]
    return float(max(steps)) / h * (1.0 + 1e-9) + 1e-12


@nb.njit(cache=True)
def rays_through(
    lx: float, ly: float, angles: FloatArray, reach: FloatArray, field: FloatArray, grid: FloatArray, margin: FloatArray
) -> int:
    """The rays, cast from the scanner at (``lx``, ``ly``) along ``angles`` [rad], that cross a mapped surface
    well before their ``reach`` [m]: the first grid node inside a surface (``field`` < 0, read at the nearest
    node every grid spacing ``t`` along the ray, as :meth:`control.estimation.amcl.Amcl.see_through` reads
    it) lies at ``t`` with ``t + margin[0] + margin[1] t < reach``. A ray stops at its first such node, or
    where ``t + margin[0] + margin[1] t`` reaches its ``reach`` (no later node can count). With the grid's slope
    bound given (``grid[4]``, :func:`field_slope`) the nodes that cannot be inside yet, by the last value read, are
    not read: the same count, bit for bit, as reading every node (``tests/test_localiser_honesty.py``).

    Args:
        grid: (x0, y0, h, far[, slope]) of ``field``.
        margin: (gate [m], relative margin [-]).
    """
    x0, y0, h = grid[0], grid[1], grid[2]
    per_node = grid[4] * h if grid.shape[0] > 4 else math.inf  # most change between neighbouring nodes
    nx, ny = field.shape
    count = 0
    for k in range(angles.shape[0]):
        ca, sa = math.cos(angles[k]), math.sin(angles[k])
        along = abs(ca) + abs(sa)
        n = 1
        t = h
        while t + margin[0] + margin[1] * t < reach[k]:
            i = min(max(int(np.rint((lx + ca * t - x0) / h)), 0), nx - 1)
            j = min(max(int(np.rint((ly + sa * t - y0) / h)), 0), ny - 1)
            v = field[i, j]
            if v < 0.0:
                count += 1
                break
            # m nodes on are at most (along m + 2) neighbour steps away (each rounding to the nearest node adds
            # one); their value stays >= 0 while that many steps' change is below v: skip them
            m = (v - 1e-9) / per_node - 2.0
            n += 1 + (int(m / along) - 1 if m > along else 0)
            t = h * n
    return count
