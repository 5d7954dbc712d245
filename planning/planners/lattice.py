"""Compiled kernels of the Hybrid-A* search (:mod:`planning.planners.hybrid_astar`).

The search lattice is (ix, iy, itheta): square cells of side ``cell`` over the world's bounds and
``bins`` heading bins. Every lattice cell holds at most one node, with its continuous pose (Hybrid-A*
keeps the exact pose a primitive reached, not the cell centre). The cell's id is
``(ix * ny + iy) * bins + itheta``; the nodes themselves are rows in the order the search opens them,
and a table over the lattice gives a cell's row (:func:`_expand`).

Collision verdicts come from :func:`planning.collision.grid.classify_pose` (the fast checker's proofs):
a motion is accepted only when every one of its samples is *proven* free. The few poses the grid
cannot decide (within about two grid spacings of the clearance margin) count as collisions here,
so every accepted motion is free by the exact checker's test as well. The moves out of the search's
root (the start) are decided before the search by the fast checker with its exact fallback
(``root_free``), so a start a few millimetres from an obstacle can be left. (Asking the exact formulas
in the search wherever the grid cannot decide took 1.5-2 times as long an expansion.)

Three short cuts do less work for the very same search (same expansions, same path, bit for bit):
a node where the grid's distance exceeds :func:`_open_beyond` has its primitives proven free from
that one value; a popped node's Reeds–Shepp bound stops at its parent's bound plus the primitive's
cost, or else at the CSC words' best, when that already shows the bound cannot raise the node's key
(:func:`rs_bound`); and the analytic expansion's length test solves the whole curve only when the
straight line to the goal is short enough (:func:`_length_to_try`; most nodes are farther: 60,000
solves, a quarter of the search's time, on an 8 x 8 m world of large obstacles). Measured in
docs/explanation/cold-start.md, with the expansion inlined into the search.
"""

from __future__ import annotations

import heapq

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.clock import monotonic
from planning.collision.compiled import grid_lookup
from planning.collision.grid import classify_pose
from planning.curves.common import mod2pi
from planning.curves.reeds_shepp import CSC_FAMILIES, FAMILIES, RS_WORDS, shortest_radii
from planning.curves.words import _sample_word

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Search outcomes returned by :func:`search`.
FOUND, EXHAUSTED, ITERATIONS, TIMED_OUT = 0, 1, 2, 3

#: Node states.
_UNSEEN, _OPEN, _CLOSED = 0, 1, 2


def cell_counts(bounds: tuple[float, float, float, float], cell: float) -> tuple[int, int]:
    """How many square cells of side ``cell`` [m] cover ``bounds`` (xmin, xmax, ymin, ymax) along x and y."""
    xmin, xmax, ymin, ymax = bounds
    return int(np.ceil((xmax - xmin) / cell)), int(np.ceil((ymax - ymin) / cell))


def cell_centres(bounds: tuple[float, float, float, float], cell: float) -> tuple[int, int, FloatArray]:
    """The square cells of side ``cell`` [m] over ``bounds`` (xmin, xmax, ymin, ymax), cell (0, 0) at the
    lower-left corner: their counts along x and y (:func:`cell_counts`) and their centres, (nx * ny, 2)
    [m] in (ix, iy) order (row ``ix * ny + iy``), the grid :func:`obstacle_heuristic` searches."""
    xmin, _, ymin, _ = bounds
    nx, ny = cell_counts(bounds, cell)
    cx, cy = np.meshgrid(xmin + cell * (np.arange(nx) + 0.5), ymin + cell * (np.arange(ny) + 0.5), indexing="ij")
    return nx, ny, np.column_stack([cx.ravel(), cy.ravel()])


@nb.njit(cache=True)
def open_cells(
    grid: FloatArray, x0: float, y0: float, h: float, lattice: tuple[float, float, float, int, int], need: float
) -> NDArray[np.bool_]:
    """(nx, ny) whether each cell of a lattice may hold a disc of radius ``need`` [m] somewhere: the upper bound
    of the signed distance at its centre (the value of its nearest node of ``grid``, spacing ``h`` from (x0,
    y0), plus ``h / sqrt 2``) plus half the cell's diagonal exceeds ``need``. ``lattice`` is (xmin, ymin,
    cell, nx, ny): the cells of :func:`cell_centres`. The values of the fast checker's ``distance_bounds``
    at those centres, without a million-row array of each step (4 ms for a million cells, not 30)."""
    xmin, ymin, cell, nx, ny = lattice
    e = h / np.sqrt(2.0)
    half = cell / np.sqrt(2.0)
    free = np.empty((nx, ny), dtype=np.bool_)
    for i in range(nx):
        x = xmin + cell * (i + 0.5)
        for j in range(ny):
            free[i, j] = grid_lookup(grid, x0, y0, h, x, ymin + cell * (j + 0.5)) + e + half > need
    return free


#: Cells the 2-D Dijkstra settles between two looks at the clock (well under a millisecond).
POPS_PER_CHECK = 4096


@nb.njit(cache=True)
def bounded_heuristic(
    free: NDArray[np.bool_], goal_ix: int, goal_iy: int, cell: float, seconds: float
) -> tuple[FloatArray, bool]:
    """Dijkstra distances [m] from the goal cell over 8-connected free cells (inf: unreachable), within
    ``seconds`` from the call (the clock read every :data:`POPS_PER_CHECK` cells settled).

    Args:
        free: (nx, ny) cells the robot's inscribed disc may occupy.
        goal_ix: Goal cell column.
        goal_iy: Goal cell row.
        cell: Cell side [m].
        seconds: Time the search may take [s] (inf: no limit).

    Returns:
        The distances, and whether the search finished (False: the time ran out, the distances are
        incomplete and must not be used).
    """
    deadline = monotonic() + seconds
    nx, ny = free.shape
    dist = np.full((nx, ny), np.inf)
    dist[goal_ix, goal_iy] = 0.0
    heap = [(0.0, goal_ix * ny + goal_iy)]
    diag = cell * np.sqrt(2.0)
    pops = 0
    while heap:
        pops += 1
        if pops % POPS_PER_CHECK == 0 and monotonic() > deadline:
            return dist, False
        d, k = heapq.heappop(heap)
        i, j = k // ny, k % ny
        if d > dist[i, j]:
            continue
        for di in range(-1, 2):
            for dj in range(-1, 2):
                a, b = i + di, j + dj
                if (di == 0 and dj == 0) or a < 0 or b < 0 or a >= nx or b >= ny or not free[a, b]:
                    continue
                nd = d + (diag if di != 0 and dj != 0 else cell)
                if nd < dist[a, b]:
                    dist[a, b] = nd
                    heapq.heappush(heap, (nd, a * ny + b))
    return dist, True


@nb.njit(cache=True)
def obstacle_heuristic(free: NDArray[np.bool_], goal_ix: int, goal_iy: int, cell: float) -> FloatArray:
    """:func:`bounded_heuristic` without a time limit: the Dijkstra distances [m] from the goal cell."""
    return bounded_heuristic(free, goal_ix, goal_iy, cell, np.inf)[0]


@nb.njit(cache=True, inline="always")
def _place(body: FloatArray, x: float, y: float, th: float, out: FloatArray) -> None:
    """Body-frame poses (K, 3) placed at pose (x, y, th), written into ``out``."""
    c, s = np.cos(th), np.sin(th)
    for k in range(body.shape[0]):
        out[k, 0] = x + c * body[k, 0] - s * body[k, 1]
        out[k, 1] = y + s * body[k, 0] + c * body[k, 1]
        out[k, 2] = th + body[k, 2]


@nb.njit(cache=True)
def _covered(px: float, py: float, th: float, cover: FloatArray, chk: tuple) -> bool:  # type: ignore[type-arg]
    """Whether every disc of ``cover`` ((C, 3) body-frame centres and radii) placed at the pose keeps
    ``clearance + tolerance / 2`` from everything by the grid's lower bound: then every footprint
    point does, which is the exact checker's footprint criterion (no obstacle point lies inside)."""
    grid, x0, y0, h, _, _, _, _, clearance, tol, _ = chk
    e = h / np.sqrt(2.0)
    c, s = np.cos(th), np.sin(th)
    for k in range(cover.shape[0]):
        bx, by = cover[k, 0], cover[k, 1]
        g = grid_lookup(grid, x0, y0, h, px + c * bx - s * by, py + s * bx + c * by)
        if g - e - cover[k, 2] <= clearance + 0.5 * tol:
            return False
    return True


@nb.njit(cache=True)
def _proven_free(poses: FloatArray, chk: tuple, cover: FloatArray) -> bool:  # type: ignore[type-arg]
    """Whether every pose is proven free: by the centre's disc, by the cover discs (:func:`_covered`),
    or by the fast checker's footprint proof; undecided counts as a collision."""
    grid, x0, y0, h, boundary, footprint, anchors, radius, clearance, tol, disc = chk
    e = h / np.sqrt(2.0)
    for k in range(poses.shape[0]):
        px, py, th = poses[k, 0], poses[k, 1], poses[k, 2]
        if grid_lookup(grid, x0, y0, h, px, py) - e - radius > clearance + tol:
            continue
        if not disc and cover.shape[0] > 0 and _covered(px, py, th, cover, chk):
            continue
        if classify_pose(px, py, th, grid, x0, y0, h, boundary, footprint, anchors, radius, clearance, tol, disc) != 1:
            return False
    return True


#: The solver's family bounds (0, the CSC words' end, all) as an array: read from it they are plain
#: integers, where the constants would be literals, for each of which numba compiled ``shortest_radii``
#: again (three versions, 2 s more to compile after an install).
_ALL = np.array([0, CSC_FAMILIES, FAMILIES], dtype=np.int64)


@nb.njit(cache=True, inline="always")
def rs_length(q: FloatArray, goal: FloatArray, rho: float, scratch: FloatArray) -> float:
    """Reeds–Shepp length [m] from pose ``q`` (3,) to ``goal`` (3,); ``scratch`` (2, 5)."""
    return shortest_radii(q, goal, rho, scratch, _ALL[0], _ALL[2], np.inf)[0] * rho


@nb.njit(cache=True, inline="always")
def rs_bound(
    q: FloatArray, goal: FloatArray, rho: float, g: float, f: float, known: float, scratch: FloatArray
) -> tuple[float, bool]:
    """The Reeds–Shepp length [m] from ``q`` to ``goal``, or only an upper bound of it when the bound
    already shows ``g + length <= f``: the length could not raise the node's key then. The bounds
    tried, cheapest first: ``known`` (an upper bound the caller has), then the CSC words' best (a sixth
    of the solve). Returns (value, exact)."""
    if g + known <= f:
        return known, False
    upper = shortest_radii(q, goal, rho, scratch, _ALL[0], _ALL[1], np.inf)[0]
    if g + upper * rho <= f:
        return upper * rho, False
    return shortest_radii(q, goal, rho, scratch, _ALL[1], _ALL[2], upper)[0] * rho, True


@nb.njit(cache=True, inline="always")
def _length_to_try(
    q: FloatArray, goal: FloatArray, rho: float, known: float, exact: bool, longest: float, scratch: FloatArray
) -> float:
    """The Reeds–Shepp length [m] from ``q`` to ``goal`` as far as the analytic expansion's test (is it
    at most ``longest``?) needs it: ``known`` (the node's bound) when it is ``exact`` or already short
    enough, or when the straight line to the goal, no longer than any curve, is already too long (1e-9 m
    covers the solver's rounding); else the whole solve."""
    if exact or known <= longest or np.hypot(q[0] - goal[0], q[1] - goal[1]) > longest + 1e-9:
        return known
    return rs_length(q, goal, rho, scratch)


@nb.njit(cache=True)
def analytic(
    q: FloatArray,
    goal: FloatArray,
    rho: float,
    step: float,
    chk: tuple,  # type: ignore[type-arg]
    cover: FloatArray,
) -> tuple[bool, FloatArray, FloatArray]:
    """The shortest Reeds–Shepp curve from ``q`` to ``goal`` sampled every ``step`` [m], and
    whether it is proven collision-free. Returns (free, (K, 3) poses, (K,) directions)."""
    # the solver the bound uses (one copy of it in the search's code), the word _solve gives
    scratch = np.empty((2, 5))
    word = shortest_radii(q, goal, rho, scratch, _ALL[0], _ALL[2], np.inf)[1]
    if word < 0:
        return False, np.zeros((0, 3)), np.zeros(0)
    poses, dirs = _sample_word(q, RS_WORDS[word], scratch[1], rho, step)
    # Land exactly on the goal (the sampler ends within 1e-9 m of it), keeping the heading continuous.
    poses[-1, 0], poses[-1, 1] = goal[0], goal[1]
    poses[-1, 2] += mod2pi(goal[2] - poses[-1, 2])
    return _proven_free(poses, chk, cover), poses, dirs


@nb.njit(cache=True, inline="always")
def _cell_id(x: float, y: float, th: float, lat: tuple) -> int:  # type: ignore[type-arg]
    """Lattice id of a pose, or -1 outside the bounds. ``lat`` = (xmin, ymin, cell, nx, ny, bins)."""
    xmin, ymin, cell, nx, ny, bins = lat
    ix = int(np.floor((x - xmin) / cell))
    iy = int(np.floor((y - ymin) / cell))
    if ix < 0 or iy < 0 or ix >= nx or iy >= ny:
        return -1
    it = int(np.floor(th / (2.0 * np.pi / bins) + 0.5)) % bins
    return (ix * ny + iy) * bins + it


@nb.njit(cache=True)
def _in_goal(x: float, y: float, th: float, goal: FloatArray, tol: FloatArray) -> bool:
    return np.hypot(x - goal[0], y - goal[1]) <= tol[0] and abs(mod2pi(th - goal[2])) <= tol[1]


@nb.njit(cache=True, inline="always")
def _open_beyond(body: FloatArray, chk: tuple) -> float:  # type: ignore[type-arg]
    """The grid value at a node's position [m] beyond which every primitive from it is proven free
    without checking its samples one by one.

    A sample lies within ``reach`` (the farthest any primitive's sample gets from its start) of the
    node, so its nearest grid node within ``reach + sqrt(2) h`` of the node's nearest; the grid holds
    the world's exact signed distance, which is 1-Lipschitz, so the sample's grid value is at least
    the node's less that. Beyond this value the first test of :func:`_proven_free` (the centre's disc)
    passes at every sample: the verdict is the same, from one lookup instead of one per sample
    (1e-9 m covers rounding)."""
    _, _, _, h, _, _, _, radius, clearance, tol, _ = chk
    reach = 0.0
    for p in range(body.shape[0]):
        for k in range(body.shape[1]):
            reach = max(reach, np.hypot(body[p, k, 0], body[p, k, 1]))
    return radius + clearance + tol + h / np.sqrt(2.0) + reach + np.sqrt(2.0) * h + 1e-9


# inlined into the search: 0.58-0.81x the plan's time on 8 x 8 m worlds of 20 obstacles (the same
# expansions; docs/explanation/cold-start.md), for about 0.3-0.5 s more to compile after an install
@nb.njit(cache=True, inline="always")
def _expand(
    cid: int,
    tables: tuple,  # type: ignore[type-arg]
    heap: list,  # type: ignore[type-arg]
    counter: int,
    count: int,
    space: tuple,  # type: ignore[type-arg]
    buf: FloatArray,
    open_beyond: float,
) -> tuple[int, int]:
    """Push every collision-free primitive successor of node ``cid`` that improves its cell.

    ``tables`` = (nodes, meta, state, slot). The nodes are rows in the order they were first opened:
    ``nodes[c]`` = (x, y, theta, g, f, h_rs), h_rs -1 until the node is popped, then the Reeds–Shepp
    length to the goal or, where that could not raise f, an upper bound of it (:func:`rs_bound`;
    the start's is its length, set when the search begins);
    ``meta[c]`` = (parent's row, primitive index, lattice id). Over the lattice, ``state[k]`` is the
    state of the node in cell ``k`` and ``slot[k]`` its row (read only where the state is not unseen):
    the rows are written in order, so a search touches the memory of the nodes it opens, not a page of
    lattice-wide rows per node. ``count`` is the number of rows; ``space`` as in :func:`search`;
    ``open_beyond`` from :func:`_open_beyond`.
    Returns the updated push counter (the heap's deterministic tie-break) and row count.
    """
    nodes, meta, state, slot = tables
    prims, lat, h2d, chk, cover = space
    body, ends, cost, change_extra, turn_class, root_free = prims
    x, y, th, g = nodes[cid, 0], nodes[cid, 1], nodes[cid, 2], nodes[cid, 3]
    in_open = grid_lookup(chk[0], chk[1], chk[2], chk[3], x, y) > open_beyond
    parent_class = turn_class[meta[cid, 1]] if meta[cid, 1] >= 0 else 0
    c, s = np.cos(th), np.sin(th)
    ny, bins = lat[4], lat[5]
    q = np.empty(3)
    for p in range(ends.shape[0]):
        q[0] = x + c * ends[p, 0] - s * ends[p, 1]
        q[1] = y + s * ends[p, 0] + c * ends[p, 1]
        q[2] = mod2pi(th + ends[p, 2])
        k = _cell_id(q[0], q[1], q[2], lat)
        if k < 0 or k == meta[cid, 2] or state[k] == _CLOSED:
            continue
        g_new = g + cost[p]
        if turn_class[p] != 0 and turn_class[p] != parent_class:
            g_new += change_extra[p]
        if state[k] == _OPEN and g_new >= nodes[slot[k], 3] - 1e-12:
            continue
        h_grid = h2d[(k // bins) // ny, (k // bins) % ny]
        if not np.isfinite(h_grid):
            continue
        if not in_open:
            if cid == 0:  # the root's moves: decided beforehand, the exact formulas where the grid cannot
                if not root_free[p]:
                    continue
            else:
                _place(body[p], x, y, th, buf)
                if not _proven_free(buf, chk, cover):
                    continue
        f = g_new + h_grid  # the Reeds–Shepp bound is added when the node is popped (see search)
        if state[k] == _UNSEEN:
            slot[k] = count
            meta[count, 2] = k
            count += 1
        j = np.int64(slot[k])
        nodes[j, 0], nodes[j, 1], nodes[j, 2] = q[0], q[1], q[2]
        nodes[j, 3], nodes[j, 4], nodes[j, 5] = g_new, f, -1.0
        meta[j, 0], meta[j, 1] = cid, p
        state[k] = _OPEN
        counter += 1
        heapq.heappush(heap, (f, counter, j))
    return counter, count


@nb.njit(cache=True, inline="always")
def _tables(
    start: FloatArray,
    goal: FloatArray,
    rho: float,
    lat: tuple,  # type: ignore[type-arg]
    h2d: FloatArray,
    scratch: FloatArray,
) -> tuple[FloatArray, IntArray, NDArray[np.int8], NDArray[np.int32]]:
    """The search's tables (nodes, meta, state and slot as in :func:`_expand`; room for a node in every
    lattice cell, allocated, not written) holding the start node open in row 0."""
    n = lat[3] * lat[4] * lat[5]
    nodes = np.empty((n, 6))
    meta = np.empty((n, 3), dtype=np.int64)
    state = np.zeros(n, dtype=np.int8)
    slot = np.empty(n, dtype=np.int32)
    k = _cell_id(start[0], start[1], start[2], lat)
    h0 = rs_length(start, goal, rho, scratch)
    nodes[0, 0], nodes[0, 1], nodes[0, 2], nodes[0, 3], nodes[0, 5] = start[0], start[1], start[2], 0.0, h0
    nodes[0, 4] = max(h0, h2d[(k // lat[5]) // lat[4], (k // lat[5]) % lat[4]])
    meta[0, 0], meta[0, 1], meta[0, 2] = -1, -1, k
    state[k], slot[k] = _OPEN, 0
    return nodes, meta, state, slot


@nb.njit(cache=True, inline="always")
def _told_to_stop(it: int, race: IntArray, stop: NDArray[np.bool_], deadline: float) -> bool:
    """Every 256 expansions: ``race[1] = it``, and whether the search must stop, ``it`` having reached
    ``race[0]`` (which another thread may lower while the search runs: the race of
    :mod:`planning.planners.hybrid_astar`), ``stop`` set, or the deadline passed."""
    if it % 256 != 0:
        return False
    race[1] = it
    return it >= race[0] or stop[0] or monotonic() > deadline


@nb.njit(cache=True, nogil=True)
def search(
    start: FloatArray,
    goal: FloatArray,
    tol: FloatArray,
    rho: float,
    step: float,
    space: tuple,  # type: ignore[type-arg]
    expansion: FloatArray,
    max_iterations: int,
    race: IntArray,
    seconds: float,
    stop: NDArray[np.bool_],
) -> tuple:  # type: ignore[type-arg]
    """Hybrid-A* from ``start`` to ``goal`` (see the module doc).

    Args:
        start, goal: (3,) start and goal poses.
        tol: (2,) goal position [m] and heading [rad] tolerance.
        rho, step: Turning radius and the analytic expansion's sample step [m].
        space: (prims, lat, h2d, chk, cover): prims = (body (P, K, 3), ends (P, 3), cost, change_extra,
            turn_class, root_free (P,): whether each move from ``start`` is free); lat = (xmin, ymin, cell,
            nx, ny, bins); h2d (nx, ny) the obstacle heuristic [m]; chk the fast checker's arguments
            (:func:`_proven_free`); cover (C, 3) body-frame discs [x, y, r] (:func:`_covered`).
        expansion: (2,) analytic expansion ratio and largest analytic length [m].
        max_iterations: Expansion budget.
        race: (2,) int64: a budget another thread may lower, and the count so far (:func:`_told_to_stop`).
        seconds: Time the search may take [s], from its start (after numba has compiled or loaded it).
        stop: (1,) flag: set, the search ends within 256 expansions (:func:`planning.signals.stoppable`).

    Returns:
        (outcome, terminal node's row, expansions, nodes, meta, analytic poses, analytic dirs): ``nodes`` and
        ``meta`` as in :func:`_expand`, a row per node the search opened, in that order (the start's first).
    """
    deadline = monotonic() + seconds
    prims, lat, h2d, chk, cover = space
    buf, scratch = np.empty((prims[0].shape[1], 3)), np.empty((2, 5))
    open_beyond = _open_beyond(prims[0], chk)
    tables = _tables(start, goal, rho, lat, h2d, scratch)
    nodes, meta, state, _ = tables
    heap = [(nodes[0, 4], 0, 0)]
    # typed integers, not literals (for each of which numba would compile _expand again)
    counter: int = np.int64(0)  # type: ignore[assignment]
    count: int = np.int64(1)  # type: ignore[assignment]
    it, countdown = 0, 0
    outcome, end, poses, dirs = EXHAUSTED, 0, np.zeros((0, 3)), np.zeros(0)
    while heap:
        f, _, cid = heapq.heappop(heap)
        if state[meta[cid, 2]] == _CLOSED or f != nodes[cid, 4]:
            continue
        exact = True
        if nodes[cid, 5] < 0.0:  # lazily: the Reeds–Shepp bound only for nodes that reach the top
            g, parent = nodes[cid, 3], meta[cid, 0]
            # the length is a metric and the primitive from the parent, reversed, a curve at most its
            # cost long: the parent's bound plus that cost bounds it (most nodes of a flood settle so)
            via = nodes[parent, 5] + (g - nodes[parent, 3])
            nodes[cid, 5], exact = rs_bound(nodes[cid, :3], goal, rho, g, f, via, scratch)
            if g + nodes[cid, 5] > f:
                nodes[cid, 4] = g + nodes[cid, 5]
                counter += 1
                heapq.heappush(heap, (nodes[cid, 4], counter, cid))
                continue
        state[meta[cid, 2]] = _CLOSED
        it += 1
        q = nodes[cid, :3].copy()
        near = _in_goal(q[0], q[1], q[2], goal, tol)
        countdown -= 1
        if countdown <= 0:
            nodes[cid, 5] = _length_to_try(q, goal, rho, nodes[cid, 5], exact, expansion[1], scratch)
        if near or (countdown <= 0 and nodes[cid, 5] <= expansion[1]):
            h_cells = (nodes[cid, 4] - nodes[cid, 3]) / lat[2]
            countdown = max(1, int(np.floor(h_cells / expansion[0])))
            free, tail, tail_dirs = analytic(q, goal, rho, step, chk, cover)
            if free:
                outcome, end, poses, dirs = FOUND, cid, tail, tail_dirs
                break
        if near or it >= max_iterations or _told_to_stop(it, race, stop, deadline):
            outcome, end = FOUND if near else ITERATIONS if it >= min(max_iterations, race[0]) else TIMED_OUT, cid
            break
        counter, count = _expand(cid, tables, heap, counter, count, space, buf, open_beyond)
    return outcome, end, it, nodes[:count], meta[:count], poses, dirs
