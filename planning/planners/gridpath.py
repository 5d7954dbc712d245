"""Shortest collision-free polyline for a disc robot on an occupancy grid (a warm start for optimisers).

The world is sampled on a square grid (at most :data:`MAX_CELLS` nodes: a world too large for the
spacing asked is sampled coarser); a cell is free when the disc of radius ``clearance`` about its
centre touches no obstacle or wall (exact signed distance, compiled with the distance field's broad
phase: :func:`planning.collision.field.signed_distances`). Dijkstra's algorithm on the
16-connected free cells (moves (1,0), (1,1), (2,1) and their symmetric images, each edge checked
at its midpoint too) gives the shortest route, which is then shortened by dropping every vertex
whose neighbours see each other through free space. A signed distance changes by at most the
distance moved, so an edge whose farther-from-obstacles end clears the disc by more than half the
edge is free at its midpoint: only the edges along the free space's border are checked there.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray
from scipy.sparse.csgraph import dijkstra

from planning.clock import PlanClock
from planning.collision.field import FieldTimeout, signed_distances
from planning.core.world import World

FloatArray = NDArray[np.float64]

_MOVES = ((1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2))
#: Most grid nodes (a 20 x 20 m world at the default 2 cm; a 200 x 200 m one at 20 cm took 24 GB
#: of memory and two minutes at 2 cm).
MAX_CELLS = 1_000_000
#: The shortcut tests every this many of a segment's samples first (:func:`_farthest_visible`).
_THIN = 8


def _samples(length: ArrayLike, step: float) -> NDArray[np.int64]:
    """How many evenly spaced points, both ends included, :func:`_segment_free` tests on a segment."""
    return np.maximum(2, np.ceil(np.asarray(length) / step).astype(np.int64) + 1)


def _segment_free(world: World, a: FloatArray, b: FloatArray, clearance: float, step: float) -> bool:
    n = int(_samples(np.hypot(*(b - a)), step))
    pts = a[None, :] + np.linspace(0.0, 1.0, n)[:, None] * (b - a)[None, :]
    return bool(np.all(signed_distances(world, pts, step) > clearance))


def _farthest_visible(world: World, poly: FloatArray, i: int, clearance: float, step: float) -> int:
    """The last vertex ``j > i`` of ``poly`` that vertex ``i`` sees (:func:`_segment_free`; ``i + 1`` when
    no later one). Every segment's samples of :func:`_segment_free`, thinned to every
    :data:`_THIN`-th, are tested in one call first: a segment with a thinned sample in the disc has
    that sample among its full ones, so only the segments that pass are tested in full, from the last."""
    js = np.arange(i + 2, poly.shape[0])
    if js.size == 0:
        return i + 1
    a = poly[i]
    seg = poly[js] - a
    full = _samples(np.hypot(seg[:, 0], seg[:, 1]), step)
    kept = (full - 2) // _THIN + 2  # samples 0, _THIN, 2 _THIN, ... and the last
    first = np.cumsum(kept) - kept  # each segment's first thinned sample
    owner = np.repeat(np.arange(js.size), kept)
    rank = np.arange(owner.size) - np.repeat(first, kept)
    index = np.where(rank == kept[owner] - 1, full[owner] - 1, rank * _THIN)
    pts = a + (index / (full[owner] - 1))[:, None] * seg[owner]
    clear = (signed_distances(world, pts, step) > clearance).astype(np.int8)
    seen = np.minimum.reduceat(clear, first).astype(bool)
    for k in np.flatnonzero(seen)[::-1]:
        if _segment_free(world, a, poly[js[k]], clearance, step):
            return int(js[k])
    return i + 1


def _free_graph(
    world: World,
    pts: FloatArray,
    dist: FloatArray,
    free: NDArray[np.bool_],
    shape: tuple[int, int],
    clearance: float,
    resolution: float,
    clock: PlanClock | None,
) -> sp.csr_matrix | None:
    """The grid's free moves as a sparse graph of lengths (None when ``clock`` says the time is spent):
    both ends clear by more than ``clearance`` [m] (``free``: ``dist > clearance``), and the midpoint
    too, which is checked only where the ends do not already imply it (the signed distance ``dist`` is
    1-Lipschitz)."""
    nx, ny = shape
    grid, free = dist.reshape(nx, ny), free.reshape(nx, ny)
    idx = np.arange(nx * ny, dtype=np.int32).reshape(nx, ny)  # MAX_CELLS fits: half the memory of int64
    rows, cols, weights = [], [], []
    for dx, dy in _MOVES:
        sa = (slice(max(0, -dx), nx - max(0, dx)), slice(max(0, -dy), ny - max(0, dy)))
        sb = (slice(max(0, dx), nx - max(0, -dx)), slice(max(0, dy), ny - max(0, -dy)))
        length = resolution * np.hypot(dx, dy)
        ok = free[sa] & free[sb]
        a, b = idx[sa][ok], idx[sb][ok]
        unsure = np.flatnonzero(np.maximum(grid[sa][ok], grid[sb][ok]) - 0.5 * length <= clearance)
        mid = 0.5 * (pts[a[unsure]] + pts[b[unsure]])
        keep = np.ones(a.size, dtype=bool)
        keep[unsure] = signed_distances(world, mid, resolution, None if clock is None else clock.deadline()) > clearance
        rows.append(a[keep])
        cols.append(b[keep])
        weights.append(np.full(int(keep.sum()), length))
        if clock is not None and clock.expired():
            return None
    n = nx * ny
    return sp.coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()


def grid_path(
    world: World,
    start: FloatArray,
    goal: FloatArray,
    clearance: float,
    resolution: float = 0.02,
    clock: PlanClock | None = None,
) -> FloatArray | None:
    """Shortest free polyline from ``start`` to ``goal`` for a disc of radius ``clearance``.

    Args:
        world: Bounds and obstacles.
        start: (2,) start position [m].
        goal: (2,) goal position [m].
        clearance: Disc radius that must stay clear of obstacles and walls [m].
        resolution: Grid spacing [m]; coarser where the world would need more than :data:`MAX_CELLS`
            nodes.
        clock: The caller's time limit, asked between the steps and held by the signed distances' own look at
            it every :data:`~planning.collision.field.POINTS_PER_CHECK` points (a million of them took 0.25 s
            of one core, two such measurements over a second on a loaded machine); None for no limit.

    Returns:
        (K, 2) vertices from start to goal, or None when no free route exists on the grid (or
        ``clock`` said the time was spent first).
    """

    def late() -> bool:
        return clock is not None and clock.expired()

    xmin, xmax, ymin, ymax = world.bounds
    resolution = world.grid_spacing(resolution, MAX_CELLS)
    xs = np.arange(xmin, xmax + 0.5 * resolution, resolution)
    ys = np.arange(ymin, ymax + 0.5 * resolution, resolution)
    nx, ny = xs.size, ys.size
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    try:
        dist = signed_distances(world, pts, resolution, None if clock is None else clock.deadline())
        free = dist > clearance
        if late():
            return None
        graph = _free_graph(world, pts, dist, free, (nx, ny), clearance, resolution, clock)
    except FieldTimeout:
        return None
    if graph is None:
        return None
    s = np.asarray(start, dtype=float)
    g = np.asarray(goal, dtype=float)

    def nearest_free(p: FloatArray) -> int:
        d = np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1])
        d[~free] = np.inf
        return int(np.argmin(d))

    i_s, i_g = nearest_free(s), nearest_free(g)
    if not (free[i_s] and free[i_g]) or late():
        return None
    cost, pred = dijkstra(graph, directed=False, indices=i_s, return_predecessors=True)
    if not np.isfinite(cost[i_g]):
        return None
    chain = [i_g]
    while chain[-1] != i_s:
        chain.append(int(pred[chain[-1]]))
    poly = np.vstack([s, pts[chain[::-1]], g])
    # Shortcut: keep a vertex only where its predecessor cannot see further ahead.
    out = [poly[0]]
    i = 0
    while i < poly.shape[0] - 1:
        if late():  # the route as it stands from here
            out.extend(poly[i + 1 :])
            break
        i = _farthest_visible(world, poly, i, clearance, 0.5 * resolution)
        out.append(poly[i])
    return np.asarray(out)
