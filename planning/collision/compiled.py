""":meth:`CollisionChecker.poses_free`, compiled: the verdict :class:`FastChecker` asks for on the poses its
grid leaves undecided.

The same formulas in the same operation order as :mod:`planning.core.world` (signed distances of
circles, ellipses (:func:`planning.core.ellipse.ellipse_local`, the one implementation), boxes,
even-odd polygons, walls) and
:mod:`planning.collision.exact` (disc test; footprint boundary samples at least ``tolerance / 2``
beyond the clearance, and no obstacle anchor inside the footprint), one pose at a time; the exact
checker's clearance is :func:`clearances_kernel` itself. Every obstacle is measured, except an ellipse
whose circumscribed circle is farther from the point than an obstacle already measured (the minimum
cannot change; it saves solving for its closest point), and obstacles a distance field's broad phase
proves farther than the nearest (:func:`field_distance`). Tests compare the clearances with a plain
numpy version bit for bit (``tests/reference_checker.py``), and the fast checker's verdicts with the
exact checker's on random and near-margin poses.
"""

from __future__ import annotations

import functools
import itertools

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.core.ellipse import ellipse_local
from planning.core.world import Box, Circle, Ellipse, Polygon, World

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

CIRCLE, ELLIPSE, BOX, POLYGON = 0, 1, 2, 3
#: An ellipse whose circumscribed circle is this much farther than the nearest obstacle so far is not
#: measured [m] (far above the closest-point solution's error, so the minimum distance is unchanged).
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
def box_local(q0: float, q1: float, sx: float, sy: float) -> float:
    """Signed distance [m] to the box of full size (sx, sy) [m] of a point (q0, q1) >= 0 in its frame,
    folded into the first quadrant."""
    d0, d1 = q0 - 0.5 * sx, q1 - 0.5 * sy
    return float(np.hypot(max(d0, 0.0), max(d1, 0.0)) + min(max(d0, d1), 0.0))


@nb.njit(cache=True)
def polygon_distance(x: float, y: float, v: FloatArray) -> float:
    """Signed distance [m] of (x, y) to the polygon of (K, 2) vertices ``v`` (even-odd rule)."""
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
def shape_distance(x: float, y: float, kind: int, p0: float, p1: float, p2: float, p3: float, p4: float) -> float:
    """Signed distance [m] of (x, y) to a circle, ellipse or box: ``kind`` and its row of :func:`pack_world`'s
    params (p0 .. p4). The row comes as numbers, not as an array: numba counts the references of every
    array a call is given, and a scan that handed each obstacle its row and the polygon table took
    4.5 us a point for 60 circles instead of 0.7 us."""
    if kind == CIRCLE:
        return float(np.hypot(x - p0, y - p1) - p2)
    q0, q1 = _folded(x, y, p0, p1, p4)
    if kind == ELLIPSE:
        return ellipse_local(q0, q1, p2, p3)
    return box_local(q0, q1, p2, p3)


@nb.njit(cache=True)
def _nearer(x: float, y: float, kind: int, p0: float, p1: float, p2: float, p3: float, p4: float, d: float) -> float:
    """``min(d, shape_distance(...))`` [m]; an ellipse whose circumscribed circle is farther than ``d`` (by
    more than :data:`ELLIPSE_SKIP_MARGIN`, far above its distance's 1e-15 m error) is not measured: the
    minimum is the same, without solving for its closest point."""
    if kind == ELLIPSE and np.hypot(x - p0, y - p1) - max(p2, p3) > d + ELLIPSE_SKIP_MARGIN:
        return d
    return min(d, shape_distance(x, y, kind, p0, p1, p2, p3, p4))


@nb.njit(cache=True)
def walls_distance(x: float, y: float, world: WorldArrays) -> float:
    """Distance [m] of (x, y) to the nearest wall, positive inside the bounds (inf without walls)."""
    bounds, walls = world[0], world[1]
    return min(min(x - bounds[0], bounds[1] - x), min(y - bounds[2], bounds[3] - y)) if walls else np.inf


@nb.njit(cache=True)
def _scan(x: float, y: float, world: WorldArrays, candidates: IntArray, every: bool) -> float:
    """Signed distance [m] of (x, y) to the walls (if the world has them) and every obstacle (``every``) or
    the obstacles whose indices are ``candidates``."""
    _, _, kinds, params, verts, offsets = world
    d = walls_distance(x, y, world)
    for m in range(kinds.shape[0] if every else candidates.shape[0]):
        k = m if every else candidates[m]
        if kinds[k] == POLYGON:
            d = min(d, polygon_distance(x, y, verts[offsets[k] : offsets[k + 1]]))
        else:
            d = _nearer(x, y, kinds[k], params[k, 0], params[k, 1], params[k, 2], params[k, 3], params[k, 4], d)
    return d


@nb.njit(cache=True)
def near_obstacles(x: float, y: float, world: WorldArrays, reach: float) -> IntArray:
    """Indices of the obstacles whose signed distance from (x, y) is at most ``reach`` [m] (the walls apart)."""
    _, _, kinds, params, verts, offsets = world
    out = np.empty(kinds.shape[0], dtype=np.int64)
    n = 0
    for k in range(kinds.shape[0]):
        if kinds[k] == POLYGON:
            d = polygon_distance(x, y, verts[offsets[k] : offsets[k + 1]])
        else:
            d = _nearer(x, y, kinds[k], params[k, 0], params[k, 1], params[k, 2], params[k, 3], params[k, 4], np.inf)
        if d <= reach:
            out[n] = k
            n += 1
    return out[:n]


@nb.njit(cache=True)
def least_obstacle_distances(points: FloatArray, world: WorldArrays, indices: IntArray) -> FloatArray:
    """(len(indices),) each indexed obstacle's least signed distance [m] to (M, 2) ``points`` (inf for none)."""
    _, _, kinds, params, verts, offsets = world
    out = np.full(indices.shape[0], np.inf)
    for m in range(indices.shape[0]):
        k = indices[m]
        for q in range(points.shape[0]):
            x, y = points[q, 0], points[q, 1]
            if kinds[k] == POLYGON:
                out[m] = min(out[m], polygon_distance(x, y, verts[offsets[k] : offsets[k + 1]]))
            else:
                p = params[k]
                out[m] = _nearer(x, y, kinds[k], p[0], p[1], p[2], p[3], p[4], out[m])
    return out


#: Obstacles from which :func:`pose_clearance`, without a distance field, first keeps those that may be nearest a
#: boundary sample (fewer are scanned whole for every sample).
NEAR_SCAN_OBSTACLES = 16


@nb.njit(cache=True)
def _world_distance(x: float, y: float, world: WorldArrays) -> float:
    """Signed distance of point (x, y) to the nearest obstacle or (with walls) wall [m]."""
    return _scan(x, y, world, world[2], True)  # (the kinds stand in for the candidates, not read)


@nb.njit(cache=True)
def candidates_distance(x: float, y: float, candidates: IntArray, world: WorldArrays) -> float:
    """Signed distance [m] of (x, y) to the walls (if the world has them) and the obstacles whose
    indices are ``candidates``."""
    return _scan(x, y, world, candidates, False)


#: Nodes per side of a block of a distance field (:mod:`planning.collision.field`).
BLOCK = 8

#: (grid (nx, ny), x0, y0, h, starts, members): the world's signed distance (walls included)
#: tabulated every h from (x0, y0), and each block's candidate obstacles (block ``bi * nby + bj``'s are
#: ``members[starts[b]:starts[b + 1]]``; :class:`planning.collision.field.DistanceField`), or an empty
#: grid: nothing tabulated.
FieldArrays = tuple[FloatArray, float, float, float, IntArray, IntArray]


def empty_field(world: World) -> FieldArrays:
    """No field: nothing tabulated, every point measured against every obstacle (:func:`field_distance`).
    Its grid is read-only, as a built field's is, so the kernels compile once for both."""
    grid = np.empty((0, 0))
    grid.setflags(write=False)
    none = np.zeros(0, dtype=np.int64)
    return (grid, float(world.bounds[0]), float(world.bounds[2]), 1.0, none, none)


@nb.njit(cache=True)
def field_distance(x: float, y: float, world: WorldArrays, field: FieldArrays) -> float:
    """Signed distance [m] of (x, y), equal to :func:`_world_distance`'s: measured against the
    candidates of the block whose region holds the point (every obstacle outside the grid, or
    without one)."""
    grid, x0, y0, h, starts, members = field
    i = int(np.floor((x - x0) / h + 0.5))
    j = int(np.floor((y - y0) / h + 0.5))
    if grid.size == 0 or i < 0 or j < 0 or i >= grid.shape[0] or j >= grid.shape[1]:
        return _world_distance(x, y, world)
    b = (i // BLOCK) * ((grid.shape[1] + BLOCK - 1) // BLOCK) + j // BLOCK
    return candidates_distance(x, y, members[starts[b] : starts[b + 1]], world)


@nb.njit(cache=True)
def field_distances(points: FloatArray, world: WorldArrays, field: FieldArrays) -> FloatArray:
    """(M,) :func:`field_distance` of (M, 2) points [m]: :func:`world_distances`' values, measured against
    the field's block candidates."""
    out = np.empty(points.shape[0])
    for k in range(points.shape[0]):
        out[k] = field_distance(points[k, 0], points[k, 1], world, field)
    return out


#: Slack of :func:`least_distance`'s skipping [m]: far above the rounding of its running bound (1e-12 m
#: over thousands of steps), far below anything geometric.
LEAST_MARGIN = 1e-9


@nb.njit(cache=True)
def least_distance(points: FloatArray, world: WorldArrays, field: FieldArrays) -> float:
    """The least :func:`field_distance` [m] over (M, 2) points along a polyline (inf for none): the value of
    ``np.min(field_distances(points, world, field))``, from the points that could hold it. A signed
    distance is 1-Lipschitz, so a point at most ``s`` along the polyline from a measured point of distance
    ``D`` is at least ``D - s`` from everything; while that bound exceeds the least so far (by more than
    :data:`LEAST_MARGIN`), the point is not measured. A straight 50 m in the open, sampled every 2 cm,
    is measured at tens of points instead of 2500."""
    best = np.inf
    bound = np.inf  # the current point's distance is at least this
    for k in range(points.shape[0]):
        if k > 0:
            bound -= np.hypot(points[k, 0] - points[k - 1, 0], points[k, 1] - points[k - 1, 1])
        if bound > best + LEAST_MARGIN:
            continue
        bound = field_distance(points[k, 0], points[k, 1], world, field)
        best = min(best, bound)
    return best


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


@nb.njit(cache=True)
def _samples_distance(
    x: float, y: float, c: float, s: float, boundary: FloatArray, world: WorldArrays, reach: float
) -> float:
    """The least distance [m] of the boundary samples of the footprint at (x, y) heading (c, s) = (cos, sin), without
    a field (every sample would scan every obstacle: a 2000-obstacle world's finely sampled pose took 0.15 s). A
    sample is within the footprint's radius of the centre, so its nearest obstacle (at most the centre's distance
    plus the radius away, the distance being 1-Lipschitz) is within ``reach``, the centre's distance plus twice the
    radius, of the centre: only those obstacles are scanned."""
    candidates = near_obstacles(x, y, world, reach + 1e-9)
    sd = np.inf
    for b in range(boundary.shape[0]):
        bx, by = boundary[b, 0], boundary[b, 1]
        sd = min(sd, candidates_distance(x + c * bx - s * by, y + s * bx + c * by, candidates, world))
    return sd


@nb.njit(cache=True)
def _holds_anchor(x: float, y: float, c: float, s: float, robot: RobotArrays) -> bool:
    """Whether an obstacle's anchor lies inside the footprint at (x, y) heading (c, s) = (cos, sin)."""
    footprint, anchors, radius = robot[1], robot[2], robot[3]
    for a in range(anchors.shape[0]):
        dx, dy = anchors[a, 0] - x, anchors[a, 1] - y
        if dx * dx + dy * dy > (radius + 1e-9) * (radius + 1e-9):
            continue  # outside the circumscribed disc, so outside the footprint
        if _anchor_inside(c * dx + s * dy, -s * dx + c * dy, footprint):
            return True
    return False


@nb.njit(cache=True)
def pose_clearance(
    x: float, y: float, th: float, world: WorldArrays, robot: RobotArrays, field: FieldArrays, proven_above: float
) -> float:
    """``CollisionChecker.clearance_of`` of one pose (x [m], y [m], heading [rad]) [m]: the centre's
    distance less the radius, but for the footprint near something (its centre within ``radius +
    clearance + tolerance``) the nearest boundary sample's distance less ``tolerance / 2``, or -inf
    with an obstacle's anchor inside the footprint or the whole footprint in collision (the centre more
    than ``radius + tolerance`` inside an obstacle or beyond a wall: every point of the circumscribed disc
    is, the distance being 1-Lipschitz; not measured sample by sample, which cost a path far outside the
    world tens of seconds). The other arguments as :func:`exact_free_kernel`'s.

    A boundary sample whose grid bound (the node's distance less ``h / sqrt(2)``) already exceeds
    ``proven_above + tolerance / 2`` is not measured: whether the result exceeds ``proven_above`` is the
    same, though the result itself may then be larger (:func:`measured_clearance` measures it)."""
    boundary, _, _, radius, clearance, tol, disc = robot
    grid, x0, y0, h = field[0], field[1], field[2], field[3]
    e = h / np.sqrt(2.0)
    centre = field_distance(x, y, world, field)
    clr = centre - radius
    if not disc and centre < -(radius + tol):
        return -np.inf
    if not disc and centre <= radius + clearance + tol:
        c, s = np.cos(th), np.sin(th)
        sd = np.inf
        if _scans_near(world, field):
            sd = _samples_distance(x, y, c, s, boundary, world, centre + 2.0 * radius)
        else:
            for b in range(boundary.shape[0]):
                bx, by = boundary[b, 0], boundary[b, 1]
                px, py = x + c * bx - s * by, y + s * bx + c * by
                if grid.size > 0 and grid_lookup(grid, x0, y0, h, px, py) - e - 0.5 * tol > proven_above:
                    continue
                sd = min(sd, field_distance(px, py, world, field))
        clr = -np.inf if _holds_anchor(x, y, c, s, robot) else sd - 0.5 * tol
    return clr


#: (centres (G, 2), spreads (G,), starts (G + 1,)): the footprint's boundary samples in runs of consecutive ones
#: (samples ``starts[g]`` to ``starts[g + 1]``), each with a centre and the distance of its farthest sample from it
#: (:func:`boundary_groups`).
Groups = tuple[FloatArray, FloatArray, IntArray]


def boundary_groups(boundary: FloatArray) -> Groups:
    """:data:`Groups` of (M, 2) boundary samples: about sqrt(M) runs of about sqrt(M) samples each (a pose then
    measures about sqrt(M) centres and the few runs whose bound reaches the least, not all M samples)."""
    m = boundary.shape[0]
    size = max(1, round(float(np.sqrt(m))))
    starts = np.append(np.arange(0, m, size), m).astype(np.int64)
    runs = [boundary[a:b] for a, b in itertools.pairwise(starts)]
    centres = np.array([run.mean(axis=0) for run in runs])
    spreads = np.array([np.hypot(*(run - centre).T).max() for run, centre in zip(runs, centres, strict=True)])
    return centres.reshape(-1, 2), spreads, starts


@nb.njit(cache=True)
def _scans_near(world: WorldArrays, field: FieldArrays) -> bool:
    """Whether a footprint's samples are measured against the obstacles near its centre (:func:`_samples_distance`):
    without a field, in a world of more than :data:`NEAR_SCAN_OBSTACLES`."""
    return field[0].size == 0 and world[2].shape[0] > NEAR_SCAN_OBSTACLES


@nb.njit(cache=True)
def _grouped_distance(
    x: float,
    y: float,
    c: float,
    s: float,
    boundary: FloatArray,
    groups: Groups,
    world: WorldArrays,
    field: FieldArrays,
    reach: float,
) -> float:
    """The least distance [m] of the boundary samples of the footprint at (x, y) heading (c, s), measured as
    :func:`pose_clearance` measures each (against the field's candidates, or without a field in a world of many
    obstacles those within ``reach`` of the centre, :func:`_samples_distance`), the same value: a run's samples
    are at least its centre's distance less its spread away (the distance being 1-Lipschitz), so the runs are
    measured nearest bound first until the next bound (less :data:`LEAST_MARGIN`) cannot go below the least."""
    centres, spreads, starts = groups
    near = _scans_near(world, field)
    candidates = near_obstacles(x, y, world, reach + 1e-9) if near else np.empty(0, dtype=np.int64)
    bound = np.empty(spreads.shape[0])
    for g in range(spreads.shape[0]):
        gx, gy = x + c * centres[g, 0] - s * centres[g, 1], y + s * centres[g, 0] + c * centres[g, 1]
        # (the choice written out here and below: through a helper of its own the kernel ran 25-30 % slower)
        d = candidates_distance(gx, gy, candidates, world) if near else field_distance(gx, gy, world, field)
        bound[g] = d - spreads[g] if d == d else -np.inf  # (a NaN: measured first, as every sample once was)
    sd = np.inf
    while True:  # the nearest bound left, picked by a scan (a sort's code would double the kernel's compile time)
        g, least = -1, np.inf
        for k in range(bound.shape[0]):
            if bound[k] < least:
                g, least = k, bound[k]
        if g < 0 or least - LEAST_MARGIN > sd:
            break
        bound[g] = np.inf  # measured
        for b in range(starts[g], starts[g + 1]):
            px, py = x + c * boundary[b, 0] - s * boundary[b, 1], y + s * boundary[b, 0] + c * boundary[b, 1]
            sd = min(
                sd, candidates_distance(px, py, candidates, world) if near else field_distance(px, py, world, field)
            )
    return sd


@nb.njit(cache=True)
def measured_clearance(
    x: float, y: float, th: float, world: WorldArrays, robot: RobotArrays, field: FieldArrays, groups: Groups
) -> float:
    """:func:`pose_clearance` with every sample that could be the nearest measured (``proven_above`` infinite),
    the boundary taken in ``groups`` (:func:`_grouped_distance`: the same value, a few runs measured)."""
    boundary, _, _, radius, clearance, tol, disc = robot
    centre = field_distance(x, y, world, field)
    if not disc and centre < -(radius + tol):
        return -np.inf
    if disc or centre > radius + clearance + tol:
        return centre - radius
    c, s = np.cos(th), np.sin(th)
    if _holds_anchor(x, y, c, s, robot):
        return -np.inf
    return _grouped_distance(x, y, c, s, boundary, groups, world, field, centre + 2.0 * radius) - 0.5 * tol


@nb.njit(cache=True)
def exact_pose_free(x: float, y: float, th: float, world: WorldArrays, robot: RobotArrays, field: FieldArrays) -> bool:
    """``CollisionChecker.poses_free`` of one pose (x [m], y [m], heading [rad]); the other arguments
    and the method as :func:`exact_free_kernel`'s."""
    clearance = robot[4]
    return pose_clearance(x, y, th, world, robot, field, clearance) > clearance


@nb.njit(cache=True)
def clearances_kernel(
    poses: FloatArray, world: WorldArrays, robot: RobotArrays, field: FieldArrays, groups: Groups
) -> FloatArray:
    """(M,) :func:`measured_clearance` of (M, 3) poses: :func:`pose_clearance` with every sample that could be
    the nearest measured."""
    out = np.empty(poses.shape[0])
    for k in range(poses.shape[0]):
        out[k] = measured_clearance(poses[k, 0], poses[k, 1], poses[k, 2], world, robot, field, groups)
    return out


@nb.njit(cache=True)
def exact_free_kernel(
    poses: FloatArray, world: WorldArrays, robot: RobotArrays, field: FieldArrays
) -> NDArray[np.bool_]:
    """(M,) ``CollisionChecker.poses_free`` of (M, 3) poses; ``world`` as :func:`pack_world` with the
    bounds and walls flag in front, ``robot`` the checker's (boundary samples, footprint, obstacle
    anchors, radius, clearance, tolerance, disc shape), ``field`` the world's distance field (with the
    same walls) or an empty one. Distances are measured against the field's block candidates
    (:func:`field_distance`, the same values as a full scan). A boundary sample whose grid bound (the
    node's distance less ``h / sqrt(2)``, what :class:`planning.collision.grid.FastChecker` proves free
    with) already keeps ``clearance + tolerance / 2`` is not measured: the verdict, that every sample
    keeps it, is the same; nor is an anchor outside the robot's circumscribed disc (``radius``)."""
    out = np.empty(poses.shape[0], dtype=np.bool_)
    for k in range(poses.shape[0]):
        out[k] = exact_pose_free(poses[k, 0], poses[k, 1], poses[k, 2], world, robot, field)
    return out
