"""Shortest collision-free polyline for a disc robot on an occupancy grid (a warm start for optimisers).

The world is sampled on a square grid (at most :data:`MAX_CELLS` nodes: a world too large for the
spacing asked is sampled coarser); a cell is free when the disc of radius ``clearance`` about its
centre touches no obstacle or wall (exact signed distance, compiled with the distance field's broad
phase: :func:`planning.collision.field.signed_distances`). Dijkstra's algorithm on the
16-connected free cells (moves (1,0), (1,1), (2,1) and their symmetric images, each edge checked
at its midpoint too) gives the shortest route, which is then shortened by dropping every vertex
whose neighbours see each other through free space.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import dijkstra

from planning.collision.field import signed_distances
from planning.core.world import World

FloatArray = NDArray[np.float64]

_MOVES = ((1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2))
#: Most grid nodes (a 20 x 20 m world at the default 2 cm; a 200 x 200 m one at 20 cm took 24 GB
#: of memory and two minutes at 2 cm).
MAX_CELLS = 1_000_000


def _segment_free(world: World, a: FloatArray, b: FloatArray, clearance: float, step: float) -> bool:
    n = max(2, int(np.ceil(np.hypot(*(b - a)) / step)) + 1)
    pts = a[None, :] + np.linspace(0.0, 1.0, n)[:, None] * (b - a)[None, :]
    return bool(np.all(signed_distances(world, pts, step) > clearance))


def grid_path(
    world: World, start: FloatArray, goal: FloatArray, clearance: float, resolution: float = 0.02
) -> FloatArray | None:
    """Shortest free polyline from ``start`` to ``goal`` for a disc of radius ``clearance``.

    Args:
        world: Bounds and obstacles.
        start: (2,) start position [m].
        goal: (2,) goal position [m].
        clearance: Disc radius that must stay clear of obstacles and walls [m].
        resolution: Grid spacing [m]; coarser where the world would need more than :data:`MAX_CELLS`
            nodes.

    Returns:
        (K, 2) vertices from start to goal, or None when no free route exists on the grid.
    """
    xmin, xmax, ymin, ymax = world.bounds
    resolution = world.grid_spacing(resolution, MAX_CELLS)
    xs = np.arange(xmin, xmax + 0.5 * resolution, resolution)
    ys = np.arange(ymin, ymax + 0.5 * resolution, resolution)
    nx, ny = xs.size, ys.size
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    free = signed_distances(world, pts, resolution) > clearance
    idx = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, weights = [], [], []
    for dx, dy in _MOVES:
        a = idx[max(0, -dx) : nx - max(0, dx), max(0, -dy) : ny - max(0, dy)].ravel()
        b = idx[max(0, dx) : nx - max(0, -dx), max(0, dy) : ny - max(0, -dy)].ravel()
        ok = free[a] & free[b]
        mid = 0.5 * (pts[a[ok]] + pts[b[ok]])
        good = np.flatnonzero(ok)[signed_distances(world, mid, resolution) > clearance]
        rows.append(a[good])
        cols.append(b[good])
        weights.append(np.full(good.size, resolution * np.hypot(dx, dy)))
    graph = sp.coo_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(nx * ny, nx * ny)
    ).tocsr()
    s = np.asarray(start, dtype=float)
    g = np.asarray(goal, dtype=float)

    def nearest_free(p: FloatArray) -> int:
        d = np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1])
        d[~free] = np.inf
        return int(np.argmin(d))

    i_s, i_g = nearest_free(s), nearest_free(g)
    if not (free[i_s] and free[i_g]):
        return None
    dist, pred = dijkstra(graph, directed=False, indices=i_s, return_predecessors=True)
    if not np.isfinite(dist[i_g]):
        return None
    chain = [i_g]
    while chain[-1] != i_s:
        chain.append(int(pred[chain[-1]]))
    poly = np.vstack([s, pts[chain[::-1]], g])
    # Shortcut: keep a vertex only where its predecessor cannot see further ahead.
    out = [poly[0]]
    i = 0
    while i < poly.shape[0] - 1:
        j = poly.shape[0] - 1
        while j > i + 1 and not _segment_free(world, poly[i], poly[j], clearance, 0.5 * resolution):
            j -= 1
        out.append(poly[j])
        i = j
    return np.asarray(out)
