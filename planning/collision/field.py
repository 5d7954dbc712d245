"""The world's signed distance tabulated on a grid, built in compiled code with a broad phase.

:class:`~planning.collision.grid.FastChecker` proves verdicts from the world's signed distance
(walls included) at the nodes of a grid of spacing ``h``: every node must hold the exact value, the
minimum over the walls and every obstacle. Measuring every obstacle at every node costs
nodes x obstacles; the broad phase makes it grow with the obstacles *near* each node instead:

* The nodes are cut into blocks of :data:`BLOCK` x :data:`BLOCK`, the blocks into superblocks of
  :data:`SUPER` x :data:`SUPER` blocks. A (super)block's region is the square of points whose nearest
  node lies in it: centre ``c``, circumradius ``r``.
* Every signed distance is 1-Lipschitz, so at any point ``p`` of the region the world's distance is
  at most ``d(c) + r`` (``d(c)`` the minimum over walls and the candidates at the centre), and an
  obstacle's at least ``sd_o(c) - r``. An obstacle with ``sd_o(c) - r > d(c) + r`` (by more than
  :data:`PRUNE_MARGIN`, far above rounding) is therefore never the nearest anywhere in the region and
  is dropped from its candidates. Superblocks prune all obstacles, blocks prune their superblock's
  candidates, nodes measure their block's.
* The minimum over a set that holds the nearest obstacle is the minimum over all: every node holds
  the value a full scan gives, bit for bit (tests compare with the plain formulas of
  :mod:`planning.core.world` on random worlds).

The blocks' candidate lists are kept (:attr:`DistanceField.members`): the exact signed distance of
any point inside the grid is then measured against its block's candidates only
(:func:`planning.collision.compiled.field_distance`), which is what the fast checker's exact
fallback asks on crowded maps.

The field is built a row of blocks at a time, so a build can honour a deadline
(:class:`FieldTimeout`), by as many threads as the process has CPUs (at most :data:`MAX_THREADS`;
the rows' kernel runs without the GIL, and each node's value is the same however many build it);
finished fields are cached per world and spacing. The deadline is moved
on by the time numba spends readying the kernels (compiling them once after an install: several
seconds; loading them in a new process; :mod:`planning.clock`): that time is in the build's reported
:attr:`DistanceField.seconds` but not charged against the deadline, which bounds the work a world
takes, not the installation's or the process's.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.clock import PlanClock
from planning.collision.compiled import (
    BLOCK,
    BOX,
    CIRCLE,
    ELLIPSE_SKIP_MARGIN,
    POLYGON,
    FieldArrays,
    WorldArrays,
    box_local,
    ellipse_local,
    field_distances,
    polygon_distance,
    shape_distance,
    walls_distance,
    world_arrays,
)
from planning.core.copy_kernels import copy_into
from planning.core.world import World
from planning.errors import NhsimError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Blocks per superblock side.
SUPER = 8
#: Slack of the pruning test [m]: far above the signed distances' rounding (1e-12 m), far below
#: anything geometric, so an obstacle is dropped only when it is certainly not the nearest.
PRUNE_MARGIN = 1e-9
#: Finished fields kept (per world and spacing).
CACHE_SIZE = 8
#: Vertices beyond which a polygon's distance over a block is measured with a broad phase over its edges
#: (:func:`polygon_block`); a few are measured at every node, as a full scan does.
EDGE_PRUNE_VERTICES = 16
#: Most threads that build one field (its block rows, filled in compiled code without the GIL).
MAX_THREADS = 4
#: Points :func:`signed_distances` measures between two looks at its deadline (a few milliseconds
#: among thousands of obstacles).
POINTS_PER_CHECK = 8192


class FieldTimeout(NhsimError, TimeoutError):
    """Building a distance field (the collision grid, or a 2-D search's table over cells) passed its
    deadline.

    Attributes:
        seconds: Time spent before giving up [s].
        nodes: Nodes (or cells, points) of the field that was being built.
        obstacles: Obstacles of its world.
        code_s: Of ``seconds``, numba readying the kernels (not charged against the deadline) [s].
        what: What was being built, as the message's subject, and what its nodes are called.
    """

    def __init__(
        self,
        seconds: float,
        nodes: int,
        obstacles: int,
        code_s: float = 0.0,
        what: tuple[str, str] = ("building the collision grid", "nodes"),
    ) -> None:
        self.seconds, self.nodes, self.obstacles, self.code_s, self.what = seconds, nodes, obstacles, code_s, what
        loading = f" (and {code_s:.3f} s loading its code)" if code_s >= 0.001 else ""
        spent = f"passed the time limit after {seconds - code_s:.3f} s{loading}"
        super().__init__(f"{what[0]} ({nodes} {what[1]}, {obstacles} obstacles) {spent}")


@dataclass(frozen=True, eq=False)
class DistanceField:
    """The signed distance of a world (walls included) at the nodes ``(x0 + i h, y0 + j h)``.

    Attributes:
        grid: (nx, ny) signed distances [m], read-only.
        x0: x of node (0, 0) [m].
        y0: y of node (0, 0) [m].
        h: Node spacing [m].
        starts: (nbx * nby + 1,) offsets into ``members`` of block ``bi * nby + bj``'s candidates.
        members: The blocks' candidate obstacle indices, concatenated.
        seconds: Time the build took [s].
    """

    grid: FloatArray
    x0: float
    y0: float
    h: float
    starts: IntArray
    members: IntArray
    seconds: float

    def arrays(self) -> FieldArrays:
        """The field as the compiled kernels take it."""
        return (self.grid, self.x0, self.y0, self.h, self.starts, self.members)


#: The finished fields, least recently used first (a plain dict: reading its items does not hash the
#: keys, as an OrderedDict's do, and a world's hash walks every obstacle: 0.44 ms for 3000).
_CACHE: dict[tuple[World, float], DistanceField] = {}


def distance_field(world: World, h: float, deadline: float | None = None) -> DistanceField:
    """The world's signed distance field at spacing ``h`` [m] (cached per world and spacing).

    Args:
        world: Bounds and obstacles; the bounds count as walls.
        h: Node spacing [m], > 0.
        deadline: ``time.perf_counter()`` value after which the build gives up (None: never).

    Raises:
        FieldTimeout: The deadline passed before the field was finished.
    """
    key = (world, float(h))
    hit = _CACHE.pop(key, None)
    if hit is not None:
        _CACHE[key] = hit  # the most recently used last
        return hit
    field = _build(world, float(h), deadline)
    _CACHE[key] = field
    while len(_CACHE) > CACHE_SIZE:
        del _CACHE[next(iter(_CACHE))]
    return field


def cached_field(world: World) -> DistanceField | None:
    """The world's most recently built field (at any spacing), or None: never builds one."""
    for (w, _), built in reversed(_CACHE.items()):
        if w == world:
            return built
    return None


def signed_distances(
    world: World, points: NDArray[np.float64], spacing: float, deadline: float | None = None
) -> FloatArray:
    """(M,) the world's signed distance [m] (walls included) at (M, 2) points: the values of a scan of
    every obstacle (:func:`planning.collision.compiled.world_distances`), measured against the block
    candidates of the world's distance field, the cached one, else one built now at ``spacing`` [m]. On
    a 20 x 20 m world with 2000 obstacles, 160,000 points take a second (the field included) instead of
    25 s.

    Raises:
        FieldTimeout: ``time.perf_counter()`` passed ``deadline`` (None: no limit) before the field was
            built or the points measured (checked every :data:`POINTS_PER_CHECK` points).
    """
    if deadline is None:
        built = cached_field(world) or distance_field(world, spacing)
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))
        return field_distances(p, world_arrays(world, True), built.arrays())  # type: ignore[no-any-return]
    clock = PlanClock(deadline - time.perf_counter())  # the code readied from here on is not counted
    built = cached_field(world) or distance_field(world, spacing, clock.deadline())
    p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))
    w = world_arrays(world, True)
    out = np.empty(p.shape[0])
    for k in range(0, p.shape[0], POINTS_PER_CHECK):
        if clock.expired():
            what = ("measuring the world's signed distance", "points")
            raise FieldTimeout(clock.elapsed(), p.shape[0], len(world.obstacles), clock.code(), what)
        out[k : k + POINTS_PER_CHECK] = field_distances(p[k : k + POINTS_PER_CHECK], w, built.arrays())
    return out


def _build(world: World, h: float, deadline: float | None) -> DistanceField:
    """Build the field a row of blocks at a time, the rows shared among :func:`threads` threads (see the
    module doc); the values do not depend on how many."""
    xmin, xmax, ymin, ymax = world.bounds
    nx = int(np.ceil((xmax - xmin) / h)) + 1
    ny = int(np.ceil((ymax - ymin) / h)) + 1
    clock = PlanClock(float("inf") if deadline is None else deadline - time.perf_counter())
    w = world_arrays(world, True)
    grid = np.empty((nx, ny))
    nbx, nby = -(-nx // BLOCK), -(-ny // BLOCK)
    counts = np.zeros(nbx * nby, dtype=np.int64)
    side = BLOCK * SUPER
    rows = list(range(0, nx, BLOCK))
    parts: list[IntArray | None] = [None] * len(rows)

    def timeout() -> FieldTimeout:
        return FieldTimeout(clock.elapsed(), nx * ny, len(world.obstacles), clock.code())

    tops = []
    for s0 in range(0, nx, side):  # the superblocks' candidates, a column of them a call
        if clock.expired():
            raise timeout()
        tops.append(superblock_candidates(s0, min(nx, s0 + side), ny, float(xmin), float(ymin), h, w))

    def fill(r: int) -> None:
        parts[r] = fill_rows(grid, float(xmin), float(ymin), h, rows[r], w, counts, tops[rows[r] // side])

    if clock.expired():
        raise timeout()
    fill(0)  # here first: numba readies the kernels in the thread whose clock times it
    until = clock.deadline()  # no code is readied from here on: the other threads read this
    _share(fill, range(1, len(rows)), until)
    if any(part is None for part in parts):
        raise timeout()
    grid.setflags(write=False)
    starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    members = np.concatenate(parts).astype(np.int64)  # type: ignore[arg-type]
    return DistanceField(grid, float(xmin), float(ymin), h, starts, members, clock.elapsed())


def threads() -> int:
    """Threads that build a field: the CPUs this process may run on, at most :data:`MAX_THREADS`."""
    return max(1, min(MAX_THREADS, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1))


def _share(work: Callable[[int], None], items: range, until: float) -> None:
    """``work(i)`` for each item, shared among :func:`threads` threads (this one among them) that each
    take the next item left, until none is left or ``time.perf_counter()`` passes ``until``; an
    exception in any ends them all and is raised here (an interrupt of this thread too)."""
    left = iter(items)
    lock = threading.Lock()
    stop = threading.Event()
    errors: list[BaseException] = []

    def worker() -> None:
        try:
            while not stop.is_set() and time.perf_counter() <= until:
                with lock:
                    i = next(left, None)
                if i is None:
                    return
                work(i)
        except BaseException as exc:  # handed to the calling thread
            errors.append(exc)
            stop.set()

    helpers = [threading.Thread(target=worker, daemon=True) for _ in range(threads() - 1)]
    for t in helpers:
        t.start()
    try:
        worker()
    finally:
        stop.set()  # the others end after their current row (about a millisecond)
        for t in helpers:
            t.join()
    if errors:
        raise errors[0]


@nb.njit(cache=True)
def _region(lo: int, n: int, origin: float, h: float) -> tuple[float, float]:
    """Centre [m] and half-width [m] of the points whose nearest node index lies in [lo, lo + n)."""
    return origin + (lo + 0.5 * (n - 1)) * h, 0.5 * n * h


@nb.njit(cache=True)
def prune(cx: float, cy: float, r: float, candidates: IntArray, world: WorldArrays) -> IntArray:
    """The candidates that may be the nearest obstacle somewhere within ``r`` [m] of (cx, cy) [m]
    (the module doc's test), in their given order."""
    _, _, kinds, params, verts, offsets = world
    n = candidates.shape[0]
    vals = np.empty(n)
    d = walls_distance(cx, cy, world)
    for m in range(n):
        k = candidates[m]
        if kinds[k] == POLYGON:
            vals[m] = polygon_distance(cx, cy, verts[offsets[k] : offsets[k + 1]])
        else:  # the row as numbers (see shape_distance)
            p0, p1, p2, p3, p4 = params[k, 0], params[k, 1], params[k, 2], params[k, 3], params[k, 4]
            vals[m] = shape_distance(cx, cy, kinds[k], p0, p1, p2, p3, p4)
        d = min(d, vals[m])
    keep = vals - r <= d + r + PRUNE_MARGIN
    return candidates[keep]


@nb.njit(cache=True)
def fill_block(
    grid: FloatArray, i0: int, j0: int, x0: float, y0: float, h: float, candidates: IntArray, world: WorldArrays
) -> None:
    """``grid``'s block of nodes from (i0, j0): the distance to the walls, then the minimum with each
    candidate's, one obstacle at a time over the block (the values of
    :func:`planning.collision.compiled.candidates_distance`)."""
    bounds, _, kinds, params, verts, offsets = world
    i1, j1 = min(grid.shape[0], i0 + BLOCK), min(grid.shape[1], j0 + BLOCK)
    for i in range(i0, i1):
        x = x0 + i * h
        for j in range(j0, j1):
            y = y0 + j * h
            grid[i, j] = min(min(x - bounds[0], bounds[1] - x), min(y - bounds[2], bounds[3] - y))
    for m in range(candidates.shape[0]):
        k = candidates[m]
        kind, p = kinds[k], params[k]
        cx, cy, c, s = p[0], p[1], np.cos(p[4]), np.sin(p[4])
        v = verts[offsets[k] : offsets[k + 1]]
        if kind == POLYGON and v.shape[0] > EDGE_PRUNE_VERTICES:
            polygon_block(grid, i0, i1, j0, j1, x0, y0, h, v)
            continue
        for i in range(i0, i1):
            x = x0 + i * h
            for j in range(j0, j1):
                y = y0 + j * h
                d0, d1 = x - cx, y - cy
                if kind == CIRCLE:
                    grid[i, j] = min(grid[i, j], np.hypot(d0, d1) - p[2])
                elif kind == POLYGON:
                    grid[i, j] = min(grid[i, j], polygon_distance(x, y, v))  # a few vertices (else below)
                elif kind == BOX:
                    q0, q1 = abs(c * d0 + s * d1), abs(-s * d0 + c * d1)
                    grid[i, j] = min(grid[i, j], box_local(q0, q1, p[2], p[3]))
                elif np.hypot(d0, d1) - max(p[2], p[3]) <= grid[i, j] + ELLIPSE_SKIP_MARGIN:
                    # (farther ones are not measured, as in a full scan: they cannot be the nearest)
                    q0, q1 = abs(c * d0 + s * d1), abs(-s * d0 + c * d1)
                    grid[i, j] = min(grid[i, j], ellipse_local(q0, q1, p[2], p[3]))


@nb.njit(cache=True)
def polygon_block(
    grid: FloatArray, i0: int, i1: int, j0: int, j1: int, x0: float, y0: float, h: float, v: FloatArray
) -> None:
    """``grid[i0:i1, j0:j1]``'s minimum with the signed distance of the polygon of (K, 2) vertices ``v``: the
    values :func:`planning.collision.compiled.polygon_distance` gives at each node, bit for bit, with a broad
    phase over the polygon's edges (a map's wall outline has a thousand: every node measuring every edge took
    most of a published map's grid).

    * The block's nodes lie within ``r`` of its centre ``c``. An edge farther from ``c`` than the nearest edge by
      more than ``2 r`` is nearer than it at none of them (each distance is 1-Lipschitz), so the nodes' minimum
      over the edges kept is the minimum over all, the same numbers compared.
    * Inside or outside: where the nearest edge is farther from ``c`` than ``r``, no node is on the other side of
      the outline from ``c``, and all take ``c``'s even-odd count; elsewhere each row of nodes counts the
      crossings of its ``y``, computed once a row by the expression ``polygon_distance`` evaluates per node.
    """
    n = v.shape[0]
    cx, cy = x0 + 0.5 * (i0 + i1 - 1) * h, y0 + 0.5 * (j0 + j1 - 1) * h
    r = 0.5 * h * np.hypot(i1 - 1 - i0, j1 - 1 - j0)
    to_centre = np.empty(n)
    nearest, crossings = np.inf, 0
    for e in range(n):
        ax, ay, bx, by = v[e, 0], v[e, 1], v[(e + 1) % n, 0], v[(e + 1) % n, 1]
        ab0, ab1 = bx - ax, by - ay
        t = min(max(((cx - ax) * ab0 + (cy - ay) * ab1) / (ab0 * ab0 + ab1 * ab1), 0.0), 1.0)
        to_centre[e] = np.hypot(cx - (ax + t * ab0), cy - (ay + t * ab1))
        nearest = min(nearest, to_centre[e])
        if (ay > cy) != (by > cy) and cx < ax + (cy - ay) * ab0 / (by - ay):
            crossings += 1
    kept = np.flatnonzero(to_centre <= nearest + 2.0 * r + PRUNE_MARGIN)
    one_side = nearest > r + PRUNE_MARGIN
    across = np.empty(n)
    for j in range(j0, j1):
        y = y0 + j * h
        m = 0
        if not one_side:  # this row's crossings of the outline
            for e in range(n):
                ax, ay, by = v[e, 0], v[e, 1], v[(e + 1) % n, 1]
                if (ay > y) != (by > y):
                    across[m] = ax + (y - ay) * (v[(e + 1) % n, 0] - ax) / (by - ay)
                    m += 1
        for i in range(i0, i1):
            x = x0 + i * h
            dist = np.inf
            for q in range(kept.shape[0]):
                e = kept[q]
                ax, ay, bx, by = v[e, 0], v[e, 1], v[(e + 1) % n, 0], v[(e + 1) % n, 1]
                ab0, ab1 = bx - ax, by - ay
                t = min(max(((x - ax) * ab0 + (y - ay) * ab1) / (ab0 * ab0 + ab1 * ab1), 0.0), 1.0)
                dist = min(dist, np.hypot(x - (ax + t * ab0), y - (ay + t * ab1)))
            count = crossings
            if not one_side:
                count = 0
                for q in range(m):
                    if x < across[q]:
                        count += 1
            grid[i, j] = min(grid[i, j], -dist if count % 2 == 1 else dist)


@nb.njit(cache=True)
def superblock_candidates(
    i0: int, i1: int, ny: int, x0: float, y0: float, h: float, world: WorldArrays
) -> tuple[IntArray, IntArray]:
    """The candidates of the superblocks of node rows [i0, i1) (at most a superblock), left to right:
    superblock ``s``'s are ``flat[offsets[s]:offsets[s + 1]]``."""
    side = BLOCK * SUPER
    everything = np.arange(world[2].shape[0])
    cx, hx = _region(i0, i1 - i0, x0, h)
    n = (ny + side - 1) // side
    offsets = np.zeros(n + 1, dtype=np.int64)
    flat = np.empty(0, dtype=np.int64)
    for s in range(n):
        cy, hy = _region(s * side, min(ny, (s + 1) * side) - s * side, y0, h)
        mine = prune(cx, cy, np.hypot(hx, hy), everything, world)
        flat = np.concatenate((flat, mine))
        offsets[s + 1] = flat.shape[0]
    return flat, offsets


@nb.njit(cache=True, nogil=True)
def fill_rows(
    grid: FloatArray,
    x0: float,
    y0: float,
    h: float,
    i0: int,
    world: WorldArrays,
    counts: IntArray,
    tops: tuple[IntArray, IntArray],
) -> IntArray:
    """Fill ``grid``'s block row from node row ``i0`` (a multiple of ``BLOCK``) and its blocks' candidate
    counts (block ``bi * nby + bj``), pruning the candidates ``tops`` of its superblocks
    (:func:`superblock_candidates`); return the blocks' candidates, block after block."""
    ny = grid.shape[1]
    nby = (ny + BLOCK - 1) // BLOCK
    flat, offsets = tops
    out = np.empty(16 * BLOCK * BLOCK, dtype=np.int64)
    used = 0
    for bj0 in range(0, ny, BLOCK):  # blocks in index order: their candidates are concatenated so
        # a block's region is its full square even at the grid's edge (a superset is harmless)
        bx, hbx = _region(i0, BLOCK, x0, h)
        by, hby = _region(bj0, BLOCK, y0, h)
        s = bj0 // (BLOCK * SUPER)
        mine = prune(bx, by, np.hypot(hbx, hby), flat[offsets[s] : offsets[s + 1]], world)
        counts[(i0 // BLOCK) * nby + bj0 // BLOCK] = mine.shape[0]
        if used + mine.shape[0] > out.shape[0]:
            grown = np.empty(2 * out.shape[0] + mine.shape[0], dtype=np.int64)
            copy_into(grown[:used], out[:used])
            out = grown
        copy_into(out[used : used + mine.shape[0]], mine)
        used += mine.shape[0]
        fill_block(grid, i0, bj0, x0, y0, h, mine, world)
    return out[:used].copy()
