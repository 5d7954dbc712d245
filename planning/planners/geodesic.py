"""Obstacle-aware 2-D shortest routes: which way round the obstacles a path should go.

A sampling planner's path goes round each obstacle on the side its trees happened to grow, and
shortcuts never change that (a shortcut replaces a stretch by a nearby motion, which stays on the
same side). :func:`route` gives the shortest way for a disc of a given radius instead, from the
same distance field Hybrid-A*'s heuristic searches (:func:`planning.planners.lattice.obstacle_heuristic`,
Dijkstra from the goal over 8-connected cells): cells of side ``cell`` are free where the disc
about the cell's centre provably keeps off everything (the fast checker's distance grid, lower
bound); the route descends the field from the start's cell to the goal's and is then string-pulled,
each vertex kept only where the last kept one cannot see farther along (every point of the straight
segment, sampled at the grid's spacing, keeps the radius by the grid's lower bound).

:func:`curve_waypoints` and :func:`polyline_waypoints` turn a route into poses that a planner's own
steering joins: the simplifier (:func:`planning.planners.simplify.simplify_path`, its ``routes``)
steers through them, checks the result and simplifies it like the search's path, and keeps the
cheaper of the two. So the route only proposes a way round; what the plan drives is always the
planner's exact steering, collision-checked.

The distance fields are cached per world, radius, cell and end cells (the benchmark and the
Monte Carlo runs plan the same problem many times).
"""

from __future__ import annotations

from collections import OrderedDict

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.collision.grid import FastChecker, _lookup
from planning.planners.lattice import obstacle_heuristic

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Cell side of the 2-D search [m] (Hybrid-A*'s default ``cell_size``).
CELL = 0.05
#: Smallest turn at a route's vertex that :func:`curve_waypoints` rounds [rad]; a smaller one moves the
#: straight line past the vertex by at most the segment's length times half of it.
MIN_TURN = 1e-3
#: Distance fields kept (the most recently used).
CACHE_SIZE = 16
_FIELDS: OrderedDict[tuple[object, ...], FloatArray] = OrderedDict()


def free_cells(checker: FastChecker, cell: float, radius: float) -> tuple[NDArray[np.bool_], tuple[float, float]]:
    """Cells of side ``cell`` over the world's bounds whose centre keeps a disc of ``radius`` [m] off
    every obstacle and wall by the checker's distance grid (its lower bound, so provably).

    Returns:
        (nx, ny) free cells and the (x, y) of the lower-left corner of cell (0, 0) [m].
    """
    xmin, xmax, ymin, ymax = checker.checker.world.bounds
    nx, ny = int(np.ceil((xmax - xmin) / cell)), int(np.ceil((ymax - ymin) / cell))
    cx, cy = np.meshgrid(xmin + cell * (np.arange(nx) + 0.5), ymin + cell * (np.arange(ny) + 0.5), indexing="ij")
    lower, _ = checker.distance_bounds(np.column_stack([cx.ravel(), cy.ravel()]))
    return (lower > radius).reshape(nx, ny), (float(xmin), float(ymin))


def _cell_of(p: FloatArray, origin: tuple[float, float], cell: float, shape: tuple[int, ...]) -> tuple[int, int]:
    i = int(np.clip(np.floor((p[0] - origin[0]) / cell), 0, shape[0] - 1))
    j = int(np.clip(np.floor((p[1] - origin[1]) / cell), 0, shape[1] - 1))
    return i, j


def distance_field(
    checker: FastChecker, radius: float, start: FloatArray, goal: FloatArray, cell: float = CELL
) -> tuple[FloatArray, tuple[float, float]]:
    """Dijkstra distances [m] to the goal's cell over the free cells (:func:`free_cells`), the cells
    within ``radius`` of the start and of the goal counted free too (the ends may sit closer to
    something than the disc allows; the steered path is checked anyway). Cached per world, grid,
    radius, cell and end cells.

    Returns:
        (nx, ny) distances (inf where unreachable) and the lower-left corner of cell (0, 0) [m].
    """
    free, origin = free_cells(checker, cell, radius)
    s, g = _cell_of(start, origin, cell, free.shape), _cell_of(goal, origin, cell, free.shape)
    args = checker.proof_arguments()
    key = (checker.checker.world, args[3], cell, radius, s, g)
    hit = _FIELDS.get(key)
    if hit is not None:
        _FIELDS.move_to_end(key)
        return hit, origin
    reach = int(np.ceil(radius / cell))
    for ci, cj in (s, g):
        for di in range(-reach, reach + 1):
            for dj in range(-reach, reach + 1):
                a, b = ci + di, cj + dj
                if 0 <= a < free.shape[0] and 0 <= b < free.shape[1] and np.hypot(di, dj) * cell <= radius:
                    free[a, b] = True
    field = obstacle_heuristic(free, g[0], g[1], float(cell))
    field.setflags(write=False)
    _FIELDS[key] = field
    if len(_FIELDS) > CACHE_SIZE:
        _FIELDS.popitem(last=False)
    return field, origin


@nb.njit(cache=True)
def _descend(field: FloatArray, i: int, j: int) -> IntArray:
    """Cells from (i, j) to the field's zero, each to the 8-neighbour of least distance ((K, 2))."""
    nx, ny = field.shape
    out = [(i, j)]
    while field[i, j] > 0.0:
        bi, bj, best = i, j, field[i, j]
        for di in range(-1, 2):
            for dj in range(-1, 2):
                a, b = i + di, j + dj
                if 0 <= a < nx and 0 <= b < ny and field[a, b] < best:
                    bi, bj, best = a, b, field[a, b]
        if bi == i and bj == j:
            break
        i, j = bi, bj
        out.append((i, j))
    res = np.empty((len(out), 2), dtype=np.int64)
    for k in range(len(out)):
        res[k, 0], res[k, 1] = out[k]
    return res


@nb.njit(cache=True)
def _sees(a: FloatArray, b: FloatArray, grid: FloatArray, x0: float, y0: float, h: float, radius: float) -> bool:
    """Whether every point of segment a-b keeps ``radius`` by the grid's lower bound, or, for an end
    closer than that to something (a start or goal pose near a wall), what that end keeps less one
    spacing (samples every h; the bound is 1-Lipschitz, so half a spacing more is asked of each)."""
    e = h / np.sqrt(2.0)
    keep = min(radius, _lookup(grid, x0, y0, h, a[0], a[1]) - e - h, _lookup(grid, x0, y0, h, b[0], b[1]) - e - h)
    length = np.hypot(b[0] - a[0], b[1] - a[1])
    n = max(1, int(np.ceil(length / h)))
    for k in range(n + 1):
        t = k / n
        x, y = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
        if _lookup(grid, x0, y0, h, x, y) - e - 0.5 * length / n <= keep:
            return False
    return True


@nb.njit(cache=True)
def _pull(pts: FloatArray, grid: FloatArray, x0: float, y0: float, h: float, radius: float) -> IntArray:
    """Indices of the points kept by string-pulling: from each kept point, the farthest point up to
    which every one is seen (:func:`_sees`; the next point at least)."""
    keep = [0]
    i, n = 0, pts.shape[0]
    while i < n - 1:
        j = i + 1
        while j + 1 < n and _sees(pts[i], pts[j + 1], grid, x0, y0, h, radius):
            j += 1
        keep.append(j)
        i = j
    return np.array(keep, dtype=np.int64)


def route(
    checker: FastChecker, start: FloatArray, goal: FloatArray, radius: float, cell: float = CELL
) -> FloatArray | None:
    """The shortest 2-D route for a disc of ``radius`` [m] from ``start`` to ``goal`` (see the module doc).

    Args:
        checker: The planner's fast checker (its world and distance grid; it needs walls).
        start: Start position, (2,) or a pose (3,) [m].
        goal: Goal position, (2,) or a pose (3,) [m].
        radius: Radius of the disc about the route [m].
        cell: Cell side of the search [m].

    Returns:
        (M, 2) vertices from ``start`` to ``goal`` (M >= 2), or None when the goal's cell cannot be
        reached from the start's.
    """
    s, g = np.asarray(start, dtype=float)[:2], np.asarray(goal, dtype=float)[:2]
    field, origin = distance_field(checker, radius, s, g, cell)
    i, j = _cell_of(s, origin, cell, field.shape)
    if not np.isfinite(field[i, j]):
        return None
    cells = _descend(field, i, j)
    centres = np.column_stack([origin[0] + cell * (cells[:, 0] + 0.5), origin[1] + cell * (cells[:, 1] + 0.5)])
    pts = np.vstack([s, centres[1:-1], g]) if cells.shape[0] > 2 else np.vstack([s, g])
    grid, x0, y0, h = checker.proof_arguments()[:4]
    return pts[_pull(np.ascontiguousarray(pts), grid, x0, y0, h, radius)]  # type: ignore[no-any-return]


def polyline_waypoints(vertices: FloatArray) -> FloatArray:
    """The interior vertices of a route as poses (W, 3), each heading along the segment that arrives
    at it (straight segments and turns in place join them: C-RRT*'s steering)."""
    v = np.asarray(vertices, dtype=float)
    d = np.diff(v, axis=0)
    return np.column_stack([v[1:-1], np.arctan2(d[:-1, 1], d[:-1, 0])])


def curve_waypoints(vertices: FloatArray, rho: float) -> FloatArray:
    """Poses (W, 3) along a route for curve steering of turning radius ``rho`` [m], one per interior
    vertex that turns by more than ``MIN_TURN``: the middle of the arc of radius ``rho`` tangent to
    both segments (the corner's fillet), heading half-way between the segments'. Where the fillet
    does not fit (its tangent points farther than half of either segment from the vertex) the pose
    is the vertex itself. Reeds–Shepp or Dubins steering from one such pose to the next then drives
    the rest of the first fillet, the straight segment and the start of the next fillet (no pose
    lies on a straight segment, where the curves' solvers can return arcs of ~1e-9 m with cusps)."""
    v = np.asarray(vertices, dtype=float)
    d = np.diff(v, axis=0)
    seg = np.hypot(d[:, 0], d[:, 1])
    heading = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    out = []
    for k in range(1, v.shape[0] - 1):
        turn = float(heading[k] - heading[k - 1])
        if abs(turn) < MIN_TURN:
            continue
        half = 0.5 * abs(turn)
        mid = heading[k - 1] + 0.5 * turn
        inward = mid + np.copysign(0.5 * np.pi, turn)  # toward the centre of the fillet
        fits = rho * np.tan(half) <= 0.5 * min(seg[k - 1], seg[k])
        offset = rho * (1.0 / np.cos(half) - 1.0) if fits else 0.0
        out.append([v[k, 0] + offset * np.cos(inward), v[k, 1] + offset * np.sin(inward), mid])
    return np.array(out).reshape(-1, 3)
