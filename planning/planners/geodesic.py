"""Obstacle-aware 2-D shortest routes: which way round the obstacles a path should go.

A sampling planner's path goes round each obstacle on the side its trees happened to grow, and
shortcuts never change that (a shortcut replaces a stretch by a nearby motion, which stays on the
same side). :func:`route` gives the shortest way for a disc of a given radius instead, from the
same distance field Hybrid-A*'s heuristic searches (:func:`planning.planners.lattice.obstacle_heuristic`,
Dijkstra from the goal over 8-connected cells): cells of side ``cell`` are free where the disc about
the cell's centre keeps off everything (:func:`centre_distances`). The route descends the field
from the start's cell to the goal's and is then string-pulled: each vertex is kept only where the
last kept one cannot see farther along (every point of the straight segment keeps the radius, by
sphere tracing the exact distance). Where no farther point is seen the next cell's centre is
kept: such a step, at most a cell's diagonal between two centres that keep the radius, may come
closer than the radius by that chord's sagitta (a millimetre or so); near a start or goal that is
closer than the radius to something, the route keeps what that end keeps.

:func:`curve_waypoints` and :func:`polyline_waypoints` turn a route into poses that a planner's own
steering joins: the simplifier (:func:`planning.planners.simplify.simplify_path`, its ``routes``)
steers through them, checks the result, simplifies it like the search's path and keeps the cheaper
of the two. So the route only proposes a way round; what the plan drives is always the planner's
exact steering, collision-checked.

The cells' distances are computed once per world and cell size, the Dijkstra fields cached per
world, radius, cell and end cells (the benchmark and the Monte Carlo runs plan the same problem
many times). :func:`reachable` needs no field: a flood fill over the same cells. With a ``deadline``
each step stops when it passes (:class:`planning.collision.field.FieldTimeout`, naming the step), so
a planner's time limit holds through them.
"""

from __future__ import annotations

import time
from collections import OrderedDict

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.clock import PlanClock, monotonic
from planning.collision.compiled import FieldArrays, WorldArrays, empty_field, field_distance, world_arrays
from planning.collision.field import FieldTimeout, cached_field, signed_distances
from planning.core.world import World
from planning.planners.lattice import bounded_heuristic, cell_centres

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Cell side of the 2-D search [m] (Hybrid-A*'s default ``cell_size``).
CELL = 0.05
#: How much farther than its radius every point of a string-pulled segment must be [m].
SEE_MARGIN = 1e-4
#: Smallest turn at a route's vertex that :func:`curve_waypoints` rounds [rad]; a smaller one moves the
#: straight line past the vertex by at most the segment's length times half of it.
MIN_TURN = 1e-3
#: Distance fields kept (the most recently used).
CACHE_SIZE = 16
#: Most cells of a :func:`route` (a world too large for its cell side is searched on larger cells: a
#: 200 x 200 m world on 10 cm cells; a 1000 x 1000 km one on 5 cm cells failed allocating 2.8 PiB).
MAX_CELLS = 4_000_000
_FIELDS: OrderedDict[tuple[object, ...], FloatArray] = OrderedDict()
#: Cell distances kept (per world and cell side; the most recently used).
CENTRES_CACHE_SIZE = 8
_CENTRES: OrderedDict[tuple[World, float], FloatArray] = OrderedDict()


def centre_distances(world: World, cell: float, deadline: float | None = None) -> FloatArray:
    """(nx, ny) signed distances [m] from the centres of the cells of side ``cell`` over the world's
    bounds (cell (0, 0) at its lower-left corner) to the nearest obstacle or wall: the exact signed
    distance, compiled, with the distance field's broad phase
    (:func:`planning.collision.field.signed_distances`); cached per world and cell.

    Raises:
        planning.collision.field.FieldTimeout: ``time.perf_counter()`` passed ``deadline`` (None: no limit).
    """
    key = (world, float(cell))
    hit = _CENTRES.get(key)
    if hit is not None:
        _CENTRES.move_to_end(key)
        return hit
    nx, ny, centres = cell_centres(world.bounds, cell)
    d = signed_distances(world, centres, cell, deadline).reshape(nx, ny)
    d.setflags(write=False)
    _CENTRES[key] = d
    if len(_CENTRES) > CENTRES_CACHE_SIZE:
        _CENTRES.popitem(last=False)
    return d  # type: ignore[no-any-return]


def clear_caches() -> None:
    """Forget the cached cell distances and distance fields (to time a route computed from nothing)."""
    _CENTRES.clear()
    _FIELDS.clear()


def _cell_of(p: FloatArray, origin: tuple[float, float], cell: float, shape: tuple[int, ...]) -> tuple[int, int]:
    i = int(np.clip(np.floor((p[0] - origin[0]) / cell), 0, shape[0] - 1))
    j = int(np.clip(np.floor((p[1] - origin[1]) / cell), 0, shape[1] - 1))
    return i, j


def _cells(
    world: World, start: FloatArray, goal: FloatArray, cell: float, deadline: float | None
) -> tuple[FloatArray, tuple[float, float], tuple[int, int], tuple[int, int]]:
    """The cells' distances (:func:`centre_distances`), the lower-left corner of cell (0, 0) [m], and the
    start's and the goal's cells."""
    xmin, _, ymin, _ = world.bounds
    origin = (float(xmin), float(ymin))
    centres = centre_distances(world, cell, deadline)  # cached per world and cell
    return centres, origin, _cell_of(start, origin, cell, centres.shape), _cell_of(goal, origin, cell, centres.shape)


def _free(centres: FloatArray, radius: float, ends: tuple[tuple[int, int], ...], cell: float) -> NDArray[np.bool_]:
    """The cells whose centre keeps ``radius`` off everything, and those within ``radius`` of each of the
    ``ends``' cells (the ends may sit closer to something than the disc allows)."""
    free = centres > radius
    reach = int(np.ceil(radius / cell))
    for ci, cj in ends:
        for di in range(-reach, reach + 1):
            for dj in range(-reach, reach + 1):
                a, b = ci + di, cj + dj
                if 0 <= a < free.shape[0] and 0 <= b < free.shape[1] and np.hypot(di, dj) * cell <= radius:
                    free[a, b] = True
    return free


def distance_field(
    world: World, radius: float, start: FloatArray, goal: FloatArray, cell: float = CELL, deadline: float | None = None
) -> tuple[FloatArray, tuple[float, float]]:
    """Dijkstra distances [m] to the goal's cell over the cells whose centre keeps ``radius`` off
    everything (:func:`centre_distances`), the cells within ``radius`` of the start and of the goal
    counted free too (the ends may sit closer to something than the disc allows; the steered path is
    checked anyway). Cached per world, radius, cell and end cells.

    Returns:
        (nx, ny) distances (inf where unreachable) and the lower-left corner of cell (0, 0) [m].

    Raises:
        planning.collision.field.FieldTimeout: ``time.perf_counter()`` passed ``deadline`` (None: no limit)
            before the cells' distances or the Dijkstra were done.
    """
    clock = PlanClock(np.inf if deadline is None else deadline - time.perf_counter())  # less the code readied
    centres, origin, s, g = _cells(world, start, goal, cell, None if deadline is None else clock.deadline())
    key = (world, cell, radius, s, g)
    hit = _FIELDS.get(key)
    if hit is not None:
        _FIELDS.move_to_end(key)
        return hit, origin
    free = _free(centres, radius, (s, g), cell)
    field, finished = bounded_heuristic(free, g[0], g[1], float(cell), clock.remaining())
    if not finished:
        what = (f"the 2-D search for a way {radius:.3f} m off everything, Dijkstra over {cell:g} m cells", "cells")
        raise FieldTimeout(clock.elapsed(), free.size, len(world.obstacles), clock.code(), what)
    field.setflags(write=False)
    _FIELDS[key] = field
    if len(_FIELDS) > CACHE_SIZE:
        _FIELDS.popitem(last=False)
    return field, origin


#: Cells the flood fill of :func:`reachable` visits between two looks at the clock.
VISITS_PER_CHECK = 65536


@nb.njit(cache=True)
def _connected(free: NDArray[np.bool_], s: tuple[int, int], target: NDArray[np.bool_], seconds: float) -> int:
    """1 when a ``target`` cell is reached from cell ``s`` over the 8-connected ``free`` cells (the targets
    themselves counted free), 0 when none is, -1 when ``seconds`` passed first (a flood fill, each cell visited
    once)."""
    deadline = monotonic() + seconds
    nx, ny = free.shape
    seen = np.zeros((nx, ny), dtype=np.bool_)
    stack = np.empty(nx * ny, dtype=np.int64)
    seen[s[0], s[1]] = True
    stack[0], top, visits = s[0] * ny + s[1], 1, 0
    while top > 0:
        visits += 1
        if visits % VISITS_PER_CHECK == 0 and monotonic() > deadline:
            return -1
        top -= 1
        i, j = stack[top] // ny, stack[top] % ny
        if target[i, j]:
            return 1
        for a in range(max(0, i - 1), min(nx, i + 2)):
            for b in range(max(0, j - 1), min(ny, j + 2)):
                if (free[a, b] or target[a, b]) and not seen[a, b]:
                    seen[a, b] = True
                    stack[top] = a * ny + b
                    top += 1
    return 0


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
def _sees(a: FloatArray, b: FloatArray, world: WorldArrays, field: FieldArrays, keep: float) -> bool:
    """Whether every point of segment a-b is farther than ``keep`` from everything, by sphere tracing:
    the distance is 1-Lipschitz, so from a point ``excess = distance - keep`` away from the limit the
    next ``excess`` of the segment keeps it; a point within ``SEE_MARGIN`` of the limit is a no. The
    distance is measured against ``field``'s block candidates (the values of a scan of everything)."""
    length = np.hypot(b[0] - a[0], b[1] - a[1])
    t = 0.0
    while True:
        f = t / length if length > 0.0 else 0.0
        excess = field_distance(a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), world, field) - keep
        if excess <= SEE_MARGIN:
            return False
        if t >= length:
            return True
        t = min(length, t + excess)


@nb.njit(cache=True)
def _pull(pts: FloatArray, world: WorldArrays, field: FieldArrays, radius: float) -> IntArray:
    """Indices of the points kept by string-pulling: from each kept point, the farthest point up to
    which every one is seen (:func:`_sees`: keeping ``radius``, or, on a segment from the first point
    or to the last, what that end keeps less 1 cm when it is nearer to something: a start or goal
    near a wall); the next point at least."""
    n = pts.shape[0]
    first = min(radius, field_distance(pts[0, 0], pts[0, 1], world, field) - 0.01)
    last = min(radius, field_distance(pts[n - 1, 0], pts[n - 1, 1], world, field) - 0.01)
    keep = [0]
    i = 0
    while i < n - 1:
        j = i + 1
        while j + 1 < n:
            need = min(first if i == 0 else radius, last if j + 1 == n - 1 else radius)
            if not _sees(pts[i], pts[j + 1], world, field, need):
                break
            j += 1
        keep.append(j)
        i = j
    return np.array(keep, dtype=np.int64)


def reachable(
    world: World,
    start: FloatArray,
    goal: FloatArray,
    radius: float,
    cell: float = CELL,
    deadline: float | None = None,
    goal_radius: float = 0.0,
) -> bool:
    """Whether the goal's cell, or with ``goal_radius`` [m] any cell that holds a point within it of the goal,
    can be reached from the start's over the 8-connected cells whose centres keep ``radius`` off everything (the
    cells near either end counted free, as in :func:`distance_field`), by a flood fill (the cells
    :func:`distance_field`'s Dijkstra gives a finite distance, in a tenth of its time).

    A proof of the contrary: any continuous path inside the bounds whose points all keep
    ``radius + cell / sqrt(2)`` passes through 8-connected cells whose centres keep ``radius`` (a signed
    distance is 1-Lipschitz, and a centre is at most half a cell's diagonal from the path in its cell),
    so when this is False no such path exists to the goal, nor to any point within ``goal_radius`` of it (a
    planner that ends anywhere in its goal tolerance).

    Raises:
        planning.collision.field.FieldTimeout: ``time.perf_counter()`` passed ``deadline`` (None: no limit).
    """
    clock = PlanClock(np.inf if deadline is None else deadline - time.perf_counter())  # less the code readied
    s, g = np.asarray(start, dtype=float)[:2], np.asarray(goal, dtype=float)[:2]
    centres, origin, si, gi = _cells(world, s, g, cell, None if deadline is None else clock.deadline())
    free = _free(centres, radius, (si, gi), cell)
    target = np.zeros(free.shape, dtype=np.bool_)
    target[gi] = True
    if goal_radius > 0.0:  # every cell a point within goal_radius of the goal may lie in: its centre that near,
        reach = goal_radius + cell / np.sqrt(2.0)  # looked for among the cells around the goal (a million cells'
        lo = np.maximum(np.floor((g - reach - origin) / cell).astype(np.int64) - 1, 0)  # table took 0.1-0.25 s)
        hi = np.minimum(np.floor((g + reach - origin) / cell).astype(np.int64) + 2, free.shape)
        x = origin[0] + cell * (np.arange(lo[0], hi[0]) + 0.5)
        y = origin[1] + cell * (np.arange(lo[1], hi[1]) + 0.5)
        near = np.hypot(*np.meshgrid(x - g[0], y - g[1], indexing="ij")) <= reach
        target[lo[0] : hi[0], lo[1] : hi[1]] |= near
    found = _connected(free, si, target, clock.remaining())
    if found < 0:
        what = (f"the 2-D search for a way {radius:.3f} m off everything, a flood fill over {cell:g} m cells", "cells")
        raise FieldTimeout(clock.elapsed(), free.size, len(world.obstacles), clock.code(), what)
    return found == 1


#: Cell sides [m] :func:`walled_off` tries, coarse to fine, while the answer is open.
PROOF_CELLS = (0.05, 0.02, 0.01)
#: Most cells a proof of :func:`walled_off` searches (a finer one is not tried in a larger world).
PROOF_MAX_CELLS = 1_000_000


def walled_off(
    world: World,
    start: FloatArray,
    goal: FloatArray,
    radius: float,
    deadline: float | None = None,
    goal_radius: float = 0.0,
) -> tuple[float, float] | None:
    """A proof that no way from the start to the goal, or to any point within ``goal_radius`` [m] of it (a goal
    tolerance), keeps ``radius`` [m] off every obstacle and wall: the cell side and the radius (``radius`` less
    half the cell's diagonal) at which :func:`reachable` finds them walled off, on cells of 5 cm, then 2 cm and
    1 cm while the answer is open (none finer than :data:`PROOF_MAX_CELLS` cells over the world); None when no
    such proof is found (a way of cells keeps ``radius``, or the finest grid could not tell).

    Raises:
        planning.collision.field.FieldTimeout: ``time.perf_counter()`` passed ``deadline`` first.
    """
    xmin, xmax, ymin, ymax = world.bounds
    for cell in PROOF_CELLS:
        if (xmax - xmin) * (ymax - ymin) / cell**2 > PROOF_MAX_CELLS:
            break
        proof = radius - cell / np.sqrt(2.0) - 1e-9
        if not reachable(world, start, goal, proof, cell, deadline, goal_radius):
            return cell, proof
        if reachable(world, start, goal, radius, cell, deadline, goal_radius):
            break  # a way of cells keeps it
    return None


def walled_off_reason(
    world: World,
    ends: tuple[FloatArray, FloatArray],
    radius: float,
    deadline: float | None,
    goal_radius: float,
    *,
    keeps: str,
    fix: str,
) -> str | None:
    """Why no way reaches the goal, as a planner's reason says it, when :func:`walled_off` proves it for a disc of
    ``radius`` [m] (``keeps``: what a way would keep off everything, e.g. ``"the axle centre 0.400 m"``; ``fix``: how
    to put it right), else None.

    Raises:
        planning.collision.field.FieldTimeout: ``time.perf_counter()`` passed ``deadline`` first.
    """
    proved = walled_off(world, ends[0], ends[1], radius, deadline, goal_radius)
    if proved is None:
        return None
    cell, proof = proved
    where = f"every point within the goal tolerance ({goal_radius:g} m)" if goal_radius > 0.0 else "the goal"
    return (
        f"no path reaches the goal keeping {keeps} off every obstacle and wall: a 2-D search over {cell:g} m cells "
        f"finds {where} walled off even for a disc of {proof:.3f} m (the {radius:.3f} m less half a cell's diagonal, "
        f"so that no way the cells miss could pass); {fix}"
    )


def _from_start(
    world: World, start: FloatArray, goal: FloatArray, radius: float, cell: float, deadline: float | None
) -> tuple[FloatArray, tuple[float, float], tuple[int, int]]:
    """:func:`distance_field` for these ends, and the start's cell."""
    s = np.asarray(start, dtype=float)[:2]
    field, origin = distance_field(world, radius, s, np.asarray(goal, dtype=float)[:2], cell, deadline)
    return field, origin, _cell_of(s, origin, cell, field.shape)


def route(
    world: World,
    start: FloatArray,
    goal: FloatArray,
    radius: float,
    cell: float = CELL,
    deadline: float | None = None,
) -> FloatArray | None:
    """The shortest 2-D route for a disc of ``radius`` [m] from ``start`` to ``goal`` (see the module doc).

    Args:
        world: Bounds (walls) and obstacles.
        start: Start position, (2,) or a pose (3,) [m].
        goal: Goal position, (2,) or a pose (3,) [m].
        radius: Radius of the disc about the route [m].
        cell: Cell side of the search [m]; larger where the world would need more than
            :data:`MAX_CELLS` cells.
        deadline: ``time.perf_counter()`` value by which the cells' distances and the Dijkstra must be
            done (None: no limit; the string-pulling after them is not timed: a few segments).

    Returns:
        (M, 2) vertices from ``start`` to ``goal`` (M >= 2), or None when the goal's cell cannot be
        reached from the start's.

    Raises:
        planning.collision.field.FieldTimeout: The deadline passed.
    """
    cell = world.grid_spacing(cell, MAX_CELLS)
    s, g = np.asarray(start, dtype=float)[:2], np.asarray(goal, dtype=float)[:2]
    field, origin, (i, j) = _from_start(world, s, g, radius, cell, deadline)
    if not np.isfinite(field[i, j]):
        return None
    cells = _descend(field, i, j)
    centres = np.column_stack([origin[0] + cell * (cells[:, 0] + 0.5), origin[1] + cell * (cells[:, 1] + 0.5)])
    pts = np.vstack([s, centres[1:-1], g]) if cells.shape[0] > 2 else np.vstack([s, g])
    built = cached_field(world)  # centre_distances made or found one
    arrays = built.arrays() if built is not None else empty_field(world)
    return pts[_pull(np.ascontiguousarray(pts), world_arrays(world), arrays, radius)]  # type: ignore[no-any-return]


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
