""":meth:`CollisionChecker.poses_free`, compiled: the verdict :class:`FastChecker` asks for on the poses its
grid leaves undecided.

The same formulas in the same operation order as :mod:`planning.core.world` (signed distances of
circles, ellipses by Eberly's 60-step bisection, boxes, even-odd polygons, walls) and
:mod:`planning.collision.exact` (disc test; footprint boundary samples at least ``tolerance / 2``
beyond the clearance, and no obstacle anchor inside the footprint), one pose at a time. The exact
checker skips obstacles whose bounding box is out of reach of a whole batch; that changes no verdict
(such an obstacle is more than ``clearance + tolerance`` from every boundary sample), so every
obstacle is measured here, except an ellipse whose circumscribed circle is farther from the point
than an obstacle already measured (the minimum cannot change; it saves the 60 bisection steps).
Tests compare the verdicts with the exact checker's on random and near-margin poses.
"""

from __future__ import annotations

import functools

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.core.world import Box, Circle, Ellipse, Polygon, World

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

CIRCLE, ELLIPSE, BOX, POLYGON = 0, 1, 2, 3
#: An ellipse whose circumscribed circle is this much farther than the nearest obstacle so far is not
#: measured [m] (far above the bisection's error, so the minimum distance is unchanged).
ELLIPSE_SKIP_MARGIN = 1e-9

#: (bounds (4,), walls, kinds, params, vertices, offsets): the world for the kernels.
WorldArrays = tuple[FloatArray, bool, IntArray, FloatArray, FloatArray, IntArray]
#: (boundary samples, footprint, anchors, radius, clearance, tolerance, disc): the robot and margins.
RobotArrays = tuple[FloatArray, FloatArray, FloatArray, float, float, float, bool]


def pack_world(world: World) -> tuple[IntArray, FloatArray, FloatArray, IntArray]:
    """The obstacles as arrays: kinds (n,), params (n, 5) (centre x, y, then radius; semi-axes and
    angle; full size and angle), polygon vertices (V, 2) and offsets (n + 1,) into them."""
    kinds, params, verts, offsets = [], [], [], [0]
    for o in world.obstacles:
        row = [0.0] * 5
        if isinstance(o, Circle):
            kinds.append(CIRCLE)
            row[:3] = [o.center[0], o.center[1], o.radius]
        elif isinstance(o, Ellipse | Box):
            kinds.append(ELLIPSE if isinstance(o, Ellipse) else BOX)
            ext = o.radii if isinstance(o, Ellipse) else o.size
            row = [o.center[0], o.center[1], ext[0], ext[1], o.angle]
        elif isinstance(o, Polygon):
            kinds.append(POLYGON)
            verts.append(o.array)
        else:
            raise TypeError(f"unknown obstacle {type(o).__name__}")
        params.append([float(v) for v in row])
        offsets.append(offsets[-1] + (o.array.shape[0] if isinstance(o, Polygon) else 0))
    v = np.vstack(verts) if verts else np.empty((0, 2))
    return (
        np.array(kinds, dtype=np.int64),
        np.array(params, dtype=float).reshape(-1, 5),
        np.ascontiguousarray(v, dtype=float),
        np.array(offsets, dtype=np.int64),
    )


@functools.lru_cache(maxsize=8)
def world_arrays(world: World, walls: bool = True) -> WorldArrays:
    """The world as the kernels take it: its bounds, the walls flag and :func:`pack_world`'s arrays
    (cached per world)."""
    return (np.asarray(world.bounds, dtype=float), walls, *pack_world(world))


@nb.njit(cache=True)
def world_distances(points: FloatArray, world: WorldArrays) -> FloatArray:
    """(M,) signed distances [m] of (M, 2) points to the nearest obstacle or (with walls) wall, by the
    formulas of :mod:`planning.core.world` (the exact checker's), compiled."""
    out = np.empty(points.shape[0])
    for k in range(points.shape[0]):
        out[k] = _world_distance(points[k, 0], points[k, 1], world)
    return out


@nb.njit(cache=True)
def _folded(x: float, y: float, cx: float, cy: float, angle: float) -> tuple[float, float]:
    c, s = np.cos(angle), np.sin(angle)
    d0, d1 = x - cx, y - cy
    return abs(c * d0 + s * d1), abs(-s * d0 + c * d1)


@nb.njit(cache=True)
def _ellipse(x: float, y: float, p: FloatArray) -> float:
    q0, q1 = _folded(x, y, p[0], p[1], p[4])
    a, b = p[2], p[3]
    if a >= b:
        y0, y1, e0, e1 = q0, q1, a, b
    else:
        y0, y1, e0, e1 = q1, q0, b, a
    if y1 > 0 and y0 > 0:
        lo = -e1 * e1 + e1 * y1
        hi = -e1 * e1 + np.sqrt(e0 * e0 * y0 * y0 + e1 * e1 * y1 * y1)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            r0, r1 = e0 * y0 / (mid + e0 * e0), e1 * y1 / (mid + e1 * e1)
            if r0 * r0 + r1 * r1 - 1.0 > 0:
                lo = mid
            else:
                hi = mid
        t = 0.5 * (lo + hi)
        dist = np.hypot(e0 * e0 * y0 / (t + e0 * e0) - y0, e1 * e1 * y1 / (t + e1 * e1) - y1)
    elif y1 > 0:
        dist = abs(y1 - e1)
    else:
        x0, x1 = e0, 0.0
        if y0 < (e0 * e0 - e1 * e1) / e0:
            x0 = e0 * e0 * y0 / max(e0 * e0 - e1 * e1, 1e-300)
            r = x0 / e0
            x1 = e1 * np.sqrt(max(1.0 - r * r, 0.0))
        dist = np.hypot(x0 - y0, x1)
    u, v = q0 / a, q1 / b
    return -dist if u * u + v * v < 1.0 else dist


@nb.njit(cache=True)
def _box(x: float, y: float, p: FloatArray) -> float:
    q0, q1 = _folded(x, y, p[0], p[1], p[4])
    d0, d1 = q0 - 0.5 * p[2], q1 - 0.5 * p[3]
    return np.hypot(max(d0, 0.0), max(d1, 0.0)) + min(max(d0, d1), 0.0)


@nb.njit(cache=True)
def _polygon(x: float, y: float, v: FloatArray) -> float:
    dist = np.inf
    crossings = 0
    n = v.shape[0]
    for i in range(n):
        ax, ay, bx, by = v[i, 0], v[i, 1], v[(i + 1) % n, 0], v[(i + 1) % n, 1]
        ab0, ab1 = bx - ax, by - ay
        t = min(max(((x - ax) * ab0 + (y - ay) * ab1) / (ab0 * ab0 + ab1 * ab1), 0.0), 1.0)
        dist = min(dist, np.hypot(x - (ax + t * ab0), y - (ay + t * ab1)))
        if (ay > y) != (by > y) and x < ax + (y - ay) * ab0 / (by - ay):
            crossings += 1
    return -dist if crossings % 2 == 1 else dist


@nb.njit(cache=True)
def _world_distance(x: float, y: float, world: WorldArrays) -> float:
    """Signed distance of point (x, y) to the nearest obstacle or (with walls) wall [m]."""
    bounds, walls, kinds, params, verts, offsets = world
    d = min(min(x - bounds[0], bounds[1] - x), min(y - bounds[2], bounds[3] - y)) if walls else np.inf
    for k in range(kinds.shape[0]):
        kind, p = kinds[k], params[k]
        if kind == CIRCLE:
            d = min(d, np.hypot(x - p[0], y - p[1]) - p[2])
        elif kind == ELLIPSE:
            # Skipped when even the circumscribed circle is farther than d (by more than the bisection's
            # 1e-12 m error): the minimum is the same, without 60 bisection steps.
            if np.hypot(x - p[0], y - p[1]) - max(p[2], p[3]) <= d + ELLIPSE_SKIP_MARGIN:
                d = min(d, _ellipse(x, y, p))
        elif kind == BOX:
            d = min(d, _box(x, y, p))
        else:
            d = min(d, _polygon(x, y, verts[offsets[k] : offsets[k + 1]]))
    return d


@nb.njit(cache=True)
def _anchor_inside(lx: float, ly: float, footprint: FloatArray) -> bool:
    nf = footprint.shape[0]
    for v in range(nf):
        ax, ay = footprint[v, 0], footprint[v, 1]
        bx, by = footprint[(v + 1) % nf, 0], footprint[(v + 1) % nf, 1]
        if not (bx - ax) * (ly - ay) - (by - ay) * (lx - ax) >= 0.0:
            return False
    return True


@nb.njit(cache=True)
def grid_lookup(grid: FloatArray, x0: float, y0: float, h: float, x: float, y: float) -> float:
    """The tabulated signed distance [m] at the grid node nearest (x, y) (nodes every ``h`` from
    (x0, y0)); -inf outside the grid (inside a wall)."""
    i = int(np.floor((x - x0) / h + 0.5))
    j = int(np.floor((y - y0) / h + 0.5))
    if i < 0 or j < 0 or i >= grid.shape[0] or j >= grid.shape[1]:
        return -np.inf  # outside the bounds: inside a wall
    return grid[i, j]


#: (grid (nx, ny), x0, y0, h): the world's signed distance (walls included) tabulated every h from
#: (x0, y0) (:class:`planning.collision.grid.FastChecker`'s), or an empty grid: nothing proven.
GridArrays = tuple[FloatArray, float, float, float]


@nb.njit(cache=True)
def exact_free_kernel(
    poses: FloatArray, world: WorldArrays, robot: RobotArrays, proof: GridArrays
) -> NDArray[np.bool_]:
    """(M,) ``CollisionChecker.poses_free`` of (M, 3) poses; ``world`` as :func:`pack_world` with the
    bounds and walls flag in front, ``robot`` the checker's (boundary samples, footprint, obstacle
    anchors, radius, clearance, tolerance, disc shape). A boundary sample whose grid bound (``proof``:
    the node's distance less ``h / sqrt(2)``, what :class:`planning.collision.grid.FastChecker`
    proves free with) already keeps ``clearance + tolerance / 2`` is not measured: the verdict, that
    every sample keeps it, is the same."""
    boundary, footprint, anchors, radius, clearance, tol, disc = robot
    grid, x0, y0, h = proof
    e = h / np.sqrt(2.0)
    out = np.empty(poses.shape[0], dtype=np.bool_)
    for k in range(poses.shape[0]):
        x, y, th = poses[k, 0], poses[k, 1], poses[k, 2]
        centre = _world_distance(x, y, world)
        clr = centre - radius
        if not disc and centre <= radius + clearance + tol:
            c, s = np.cos(th), np.sin(th)
            sd = np.inf
            for b in range(boundary.shape[0]):
                bx, by = boundary[b, 0], boundary[b, 1]
                px, py = x + c * bx - s * by, y + s * bx + c * by
                if grid.size > 0 and grid_lookup(grid, x0, y0, h, px, py) - e - 0.5 * tol > clearance:
                    continue
                sd = min(sd, _world_distance(px, py, world))
            clr = sd - 0.5 * tol
            for a in range(anchors.shape[0]):
                dx, dy = anchors[a, 0] - x, anchors[a, 1] - y
                if _anchor_inside(c * dx + s * dy, -s * dx + c * dy, footprint):
                    clr = -np.inf
                    break
        out[k] = clr > clearance
    return out
