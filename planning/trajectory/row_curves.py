"""Position curves x(t), y(t) through a timed file's rows, in time linear in the rows.

* :func:`stretch_fit`, the positions' own curve: a cubic spline through the rows, at rest at the
  **stops** (the file's ends, stand-stills, corners sharper than 90 degrees, cusps included), C2
  between them, and **shape-preserving** where a spline would ring: an interval whose curve
  overshoots the range of its two rows (per coordinate) by more than :data:`OVERSHOOT_TOLERANCE`
  (0.1 mm + 10 % of the interval's step) gets its end slopes limited as Fritsch and Carlson's
  monotone cubic does (the sign of the step, at most 3 times its mean rate), so rows far apart in
  time are joined without overshooting them; elsewhere the spline is kept as it is.
* :func:`hermite_curve`: the cubic Hermite curve of given velocities, quintic with given
  accelerations.

A **stand-still** is a stay within :data:`SAME_POSITION` lasting at least :data:`STAND_TIME` (0.1 s: a
mean speed below :data:`MOVING_SPEED`), judged over that time and not row by row: a row-by-row distance
would call every step of a slow, densely sampled file a stand-still (rows 0.01 s apart at 1 cm/s are
0.1 mm apart).

Every curve is one piecewise polynomial over all rows (scipy ``PPoly``): built by one banded solve
and evaluated by binary search, so a log of 200 000 rows costs what 200 rows cost, times 1000.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicHermiteSpline, PPoly
from scipy.linalg import solve_banded

FloatArray = NDArray[np.float64]

#: Rows closer than this are at one position [m].
SAME_POSITION = 1e-4
#: Speed below which the robot counts as standing [m/s].
MOVING_SPEED = 1e-3
#: Shortest stay within SAME_POSITION that counts as a stand-still [s]: MOVING_SPEED's mean speed.
STAND_TIME = SAME_POSITION / MOVING_SPEED
#: A step at most this long [m] moves nothing: a braking whose steps reach it has ended (:func:`stops`).
SETTLED = 1e-9
#: (absolute [m], relative to the interval's step) overshoot of the rows a spline interval may have
#: before its slopes are limited.
OVERSHOOT_TOLERANCE = (1e-4, 0.10)


class PositionCurve:
    """x(t), y(t) through a timed file's rows: one piecewise polynomial, clamped to its time span.

    Args:
        poly: The piecewise polynomial (scipy ``PPoly`` or a subclass) with (2,) values [m].
    """

    def __init__(self, poly: PPoly) -> None:
        self.poly = poly
        self.span = (float(poly.x[0]), float(poly.x[-1]))
        self._integral: PPoly | None = None

    def __call__(self, t: FloatArray, nu: int = 0) -> FloatArray:
        """(M, 2) positions (nu = 0) [m] or their nu-th time derivative at times t (M,) [s]."""
        tq = np.clip(np.asarray(t, dtype=float).reshape(-1), *self.span)
        return np.asarray(self.poly(tq, nu)).reshape(tq.size, 2)

    def mean(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """(M, 2) mean positions [m] over the time intervals [a, b] (M,) [s] (the position at a where
        b <= a), from the curve's antiderivative."""
        a = np.clip(np.asarray(a, dtype=float).reshape(-1), *self.span)
        b = np.clip(np.asarray(b, dtype=float).reshape(-1), *self.span)
        if self._integral is None:
            self._integral = self.poly.antiderivative()
        wide = b > a
        out = self(a)
        area = np.asarray(self._integral(b[wide]) - self._integral(a[wide])).reshape(-1, 2)
        out[wide] = area / (b[wide] - a[wide])[:, None]
        return out


def standing(t: FloatArray, xy: FloatArray) -> NDArray[np.bool_]:
    """(N - 1,) whether the robot stands over each interval (see the module doc).

    An interval stands when its own step is within SAME_POSITION and it lies inside a **stay**: rows
    i..j, j the first row at least STAND_TIME after i (or the last row), whose ends are within
    SAME_POSITION of each other, i.e. a mean speed below MOVING_SPEED over at least STAND_TIME.
    Judged over STAND_TIME rather than row by row, a file sampled every 0.01 s stands where the same
    motion sampled every 0.1 s does, and slow motion in fine steps is not taken for stand-stills.

    Args:
        t: (N,) strictly increasing times [s].
        xy: (N, 2) positions [m].
    """
    n = t.size
    i = np.arange(n)
    j = np.minimum(np.searchsorted(t, t + STAND_TIME * (1.0 - 1e-9)), n - 1)
    stay = (j > i) & (np.hypot(*(xy[j] - xy).T) <= SAME_POSITION)
    cover = np.zeros(n + 1, dtype=np.int64)
    np.add.at(cover, i[stay], 1)
    np.add.at(cover, j[stay], -1)
    inside = np.cumsum(cover)[: n - 1] > 0
    return inside & (np.hypot(*np.diff(xy, axis=0).T) <= SAME_POSITION)


def stops(t: FloatArray, xy: FloatArray) -> NDArray[np.intp]:
    """Indices of the rows where the positions' own curve is at rest: both ends, where a stand-still
    begins and ends (the rows inside it follow their own small drift), and corners sharper than 90
    degrees (cusps included), in increasing order.

    A braking's last steps are shorter than SAME_POSITION, so the stand-still they join begins while
    the robot still rolls: at rows 0.02 s apart braking at 0.425 m/s^2, the last step is 0.085 mm. A
    curve at rest there brakes over the interval before it three times harder than the rows do
    (1.27 m/s^2 measured, nhsim's own reference read back). The stop is moved on to the row where the
    steps stop shrinking (:data:`SETTLED`: the motion has ended), and a start's back to where they
    begin growing, as long as the steps are within the stand-still."""
    d = np.diff(xy, axis=0)
    step = np.hypot(d[:, 0], d[:, 1])
    stand = standing(t, xy)
    sharp = np.flatnonzero(np.einsum("ij,ij->i", d[:-1], d[1:]) < 0.0) + 1
    begins = [_rolled_on(step, stand, int(r), +1) for r in np.flatnonzero(~stand[:-1] & stand[1:]) + 1]
    ends = [_rolled_on(step, stand, int(r), -1) for r in np.flatnonzero(stand[:-1] & ~stand[1:]) + 1]
    return np.unique(np.concatenate([[0], begins, ends, sharp, [t.size - 1]]).astype(np.intp))


def _rolled_on(step: FloatArray, stand: NDArray[np.bool_], row: int, way: int) -> int:
    """The row a stand-still's begin (``way`` +1, at ``row``) or end (-1) moves to: on past each standing
    interval whose step is still shrinking (a braking's tail; -1: still growing backwards, a start's
    head) and not settled (:func:`stops`)."""
    here = row if way > 0 else row - 1  # the standing interval next to the row
    while 0 < here < step.size and stand[here] and SETTLED < step[here] < step[here - way]:
        row += way
        here += way
    return row


def spline_slopes(t: FloatArray, y: FloatArray, rest: NDArray[np.intp]) -> FloatArray:
    """Slopes at the rows of the C2 cubic spline through (t, y) with zero slope at the rows ``rest``.

    One tridiagonal system over all rows: at a free row i, continuity of the second derivative
    ``h_i m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_{i-1} m_{i+1} = 3 (h_i d_{i-1} + h_{i-1} d_i)`` (h the
    intervals, d their mean rates); at a row of ``rest``, ``m_i = 0``. Between two rest rows this is
    the clamped cubic spline of that stretch.

    Args:
        t: (N,) strictly increasing times [s].
        y: (N, k) values.
        rest: Row indices with zero slope (must include 0 and N - 1).

    Returns:
        (N, k) slopes [units of y per s].
    """
    n = t.size
    h = np.diff(t)
    d = np.diff(y, axis=0) / h[:, None]
    ab = np.zeros((3, n))
    rhs = np.zeros_like(y, dtype=float)
    ab[1, 1:-1] = 2.0 * (h[:-1] + h[1:])
    ab[0, 2:] = h[:-1]  # row i's coefficient of m_{i+1}
    ab[2, :-2] = h[1:]  # row i's coefficient of m_{i-1}
    rhs[1:-1] = 3.0 * (h[1:, None] * d[:-1] + h[:-1, None] * d[1:])
    ab[1, rest] = 1.0
    ab[0, rest[rest + 1 < n] + 1] = 0.0
    ab[2, rest[rest > 0] - 1] = 0.0
    rhs[rest] = 0.0
    return np.asarray(solve_banded((1, 1), ab, rhs))


def _cubic_extent(y0: FloatArray, y1: FloatArray, m0: FloatArray, m1: FloatArray, h: FloatArray) -> FloatArray:
    """How far each cubic Hermite interval leaves the range of its end values (elementwise, >= 0).

    The interval is ``p(s) = y0 H00 + h m0 H10 + y1 H01 + h m1 H11`` for s in [0, 1]; its interior
    extrema are the roots of ``p'(s) = a s^2 + b s + c``.
    """
    dy = y1 - y0
    a = 6.0 * (y0 - y1) + 3.0 * h * (m0 + m1)
    b = 6.0 * dy - 4.0 * h * m0 - 2.0 * h * m1
    c = h * m0
    lo, hi = np.minimum(y0, y1), np.maximum(y0, y1)
    out = np.zeros_like(y0)
    disc = np.maximum(b * b - 4.0 * a * c, 0.0)
    root = np.sqrt(disc)
    with np.errstate(divide="ignore", invalid="ignore"):
        quad = np.abs(a) > 1e-12 * (np.abs(b) + np.abs(c) + 1e-300)
        s_lin = np.where(np.abs(b) > 0, -c / np.where(b == 0, 1.0, b), -1.0)
        cands = [np.where(quad, (-b + root) / (2 * a), s_lin), np.where(quad, (-b - root) / (2 * a), -1.0)]
    for s in cands:
        s = np.nan_to_num(s, nan=-1.0)
        inside = (s > 0.0) & (s < 1.0)
        sc = np.clip(s, 0.0, 1.0)
        p = (
            y0 * (2 * sc**3 - 3 * sc**2 + 1)
            + h * m0 * (sc**3 - 2 * sc**2 + sc)
            + y1 * (-2 * sc**3 + 3 * sc**2)
            + h * m1 * (sc**3 - sc**2)
        )
        out = np.maximum(out, np.where(inside, np.maximum(p - hi, lo - p), 0.0))
    return out


def _overshooting(t: FloatArray, y: FloatArray, m: FloatArray, idx: NDArray[np.intp]) -> NDArray[np.intp]:
    """Those of the intervals ``idx`` whose curve leaves its rows' range by more than OVERSHOOT_TOLERANCE
    in some coordinate."""
    a, b = y[idx], y[idx + 1]
    ext = _cubic_extent(a, b, m[idx], m[idx + 1], (t[idx + 1] - t[idx])[:, None])
    step = np.hypot(*(b[:, :2] - a[:, :2]).T)[:, None] if y.shape[1] >= 2 else np.abs(b - a)
    return idx[np.any(ext > OVERSHOOT_TOLERANCE[0] + OVERSHOOT_TOLERANCE[1] * step, axis=1)]


def limit_overshoot(t: FloatArray, y: FloatArray, m: FloatArray) -> FloatArray:
    """Slopes ``m`` (N, k) limited where the cubic Hermite curve through (t, y) with them overshoots
    an interval's end values by more than OVERSHOOT_TOLERANCE (see the module doc); elsewhere as given.

    A limited interval is monotone and stays so (its slopes only shrink afterwards), but shrinking a
    slope can make the interval on its other side overshoot (two slopes of the wrong sign may have
    cancelled): those are checked again, and so on. Each interval is limited at most once and each
    round checks only the neighbours of the slopes just changed, so the cost stays linear in N.

    Returns:
        (N, k) slopes.
    """
    m = np.array(m, dtype=float)
    delta = np.diff(y, axis=0) / np.diff(t)[:, None]
    limited = np.zeros(t.size - 1, dtype=bool)
    ring = _overshooting(t, y, m, np.arange(t.size - 1))
    while ring.size:
        limited[ring] = True
        d = delta[ring]
        # Fritsch-Carlson: slopes of the step's sign (zero for no step), (alpha, beta) within radius 3
        with np.errstate(divide="ignore", invalid="ignore"):
            alpha = np.where(d != 0, np.maximum(m[ring] / d, 0.0), 0.0)
            beta = np.where(d != 0, np.maximum(m[ring + 1] / d, 0.0), 0.0)
        radius = np.hypot(alpha, beta)
        tau = np.where(radius > 3.0, 3.0 / np.maximum(radius, 1e-300), 1.0)
        rows = np.concatenate([ring, ring + 1])
        limit = np.concatenate([alpha * tau * d, beta * tau * d])
        with np.errstate(divide="ignore", invalid="ignore"):
            factor = np.where(m[rows] != 0, np.clip(limit / m[rows], 0.0, 1.0), 1.0)
        rows, where = np.unique(rows, return_inverse=True)
        scale = np.ones((rows.size, m.shape[1]))
        np.minimum.at(scale, where, factor)  # a row shared by two limited intervals takes the smaller
        m[rows] *= scale
        changed = rows[np.any(scale < 1.0, axis=1)]
        near = np.unique(np.concatenate([changed - 1, changed]))
        near = near[(near >= 0) & (near < t.size - 1)]
        ring = _overshooting(t, y, m, near[~limited[near]])
    return m


def stretch_fit(t: FloatArray, xy: FloatArray) -> PositionCurve:
    """The positions' own curve (see the module doc).

    Args:
        t: (N,) strictly increasing times [s], N >= 2.
        xy: (N, 2) positions [m].
    """
    m = spline_slopes(t, xy, stops(t, xy))
    return PositionCurve(CubicHermiteSpline(t, xy, limit_overshoot(t, xy, m)))


def hermite_curve(t: FloatArray, xy: FloatArray, vel: FloatArray, acc: FloatArray | None = None) -> PositionCurve:
    """The curve through the rows with the given velocities: cubic Hermite, quintic with accelerations.

    Args:
        t: (N,) strictly increasing times [s].
        xy: (N, 2) positions [m].
        vel: (N, 2) velocities [m/s].
        acc: (N, 2) accelerations [m/s^2], or None.
    """
    if acc is None:
        return PositionCurve(CubicHermiteSpline(t, xy, vel))
    h = np.diff(t)[:, None]
    a0, a1, v0, v1 = acc[:-1], acc[1:], vel[:-1], vel[1:]
    rest = np.diff(xy, axis=0) - v0 * h - 0.5 * a0 * h**2  # what the cubic, quartic and quintic terms add
    dv = v1 - v0 - a0 * h
    da = a1 - a0
    c5 = (6.0 * rest - 3.0 * dv * h + 0.5 * da * h**2) / h**5
    c4 = (-15.0 * rest + 7.0 * dv * h - da * h**2) / h**4
    c3 = (10.0 * rest - 4.0 * dv * h + 0.5 * da * h**2) / h**3
    coeffs = np.stack([c5, c4, c3, 0.5 * a0, v0, xy[:-1]])  # highest power first: (6, N - 1, 2)
    return PositionCurve(PPoly(coeffs, t))
