"""The distance field (compiled, with a broad phase) against plain-Python references on random worlds.

The references here are the plain formulas of :mod:`planning.core.world` measured against every
obstacle at every node (what the field replaced), and a plain-Python broad phase check: at points of
each block, the nearest obstacle by a full scan is among the block's candidates.
"""

import math
import threading
import time

import numpy as np
import pytest

from planning.collision import field as field_module
from planning.collision.compiled import BLOCK, _world_distance, field_distance, world_arrays
from planning.collision.exact import CollisionChecker
from planning.collision.field import FieldTimeout, distance_field
from planning.collision.grid import FastChecker
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, Ellipse, Polygon, World
from planning.planners.base import PlanProblem, PlanStatus
from planning.planners.registry import make_planner
from tests.fuzz_helpers import crowded_worlds, fast_and_slow
from tests.reference_checker import reference_clearance


def reference_grid(world: World, h: float) -> np.ndarray:
    """The signed distance (walls included) at every node, by the plain formulas, every obstacle at
    every node."""
    xmin, xmax, ymin, ymax = world.bounds
    nx, ny = int(np.ceil((xmax - xmin) / h)) + 1, int(np.ceil((ymax - ymin) / h)) + 1
    xx, yy = np.meshgrid(xmin + h * np.arange(nx), ymin + h * np.arange(ny), indexing="ij")
    return world.signed_distance(np.column_stack([xx.ravel(), yy.ravel()]), walls=True).reshape(nx, ny)


def reference_nearest(world: World, pts: np.ndarray) -> np.ndarray:
    """(M,) index of the nearest obstacle at each point (-1 where a wall is nearer than all), plain."""
    d = np.array([o.signed_distance(pts) for o in world.obstacles]).reshape(len(world.obstacles), -1)
    best = np.argmin(d, axis=0) if len(world.obstacles) else np.full(pts.shape[0], -1)
    nearest = d[best, np.arange(pts.shape[0])] if len(world.obstacles) else np.full(pts.shape[0], np.inf)
    return np.where(world.wall_distance(pts) < nearest, -1, best)


def random_world(seed: int, n: int, size: float, scale: float) -> World:
    """``n`` obstacles of the four kinds (scaled by ``scale`` [m]) in a ``size`` x ``size`` m arena."""
    rng = np.random.default_rng(seed)
    obstacles: list = []
    for k in range(n):
        c = (float(rng.uniform(0, size)), float(rng.uniform(0, size)))
        if min(np.hypot(*c), np.hypot(c[0] - size, c[1] - size)) < 4 * scale + 0.3:
            c = (0.5 * size, 0.5 * size)  # the corners stay free for a start and a goal
        a, b = (float(v) for v in scale * rng.uniform(0.3, 1.5, 2))
        angle = float(rng.uniform(-3, 3))
        kind = k % 4
        if kind == 0:
            obstacles.append(Circle(c, a))
        elif kind == 1:
            obstacles.append(Ellipse(c, (a, b), angle))
        elif kind == 2:
            obstacles.append(Box(c, (2 * a, b), angle))
        else:
            phi = 2 * np.pi * (np.arange(5) + rng.uniform(0, 0.8, 5)) / 5
            r = a * rng.uniform(0.5, 1.0, 5)
            obstacles.append(
                Polygon(tuple((c[0] + r[i] * np.cos(phi[i]), c[1] + r[i] * np.sin(phi[i])) for i in range(5)))
            )
    return World((0.0, size, 0.0, size), tuple(obstacles))


def skyline(x0: float, x1: float, y: float, n: int, cell: float, seed: int) -> Polygon:
    """A map's outline: ``n`` columns between ``x0`` and ``x1`` [m] whose tops and bottoms, snapped to ``cell`` [m],
    step up and down around ``y`` (a rectilinear, non-convex polygon of ``4 n`` vertices, as a map's wall region
    gives)."""
    rng = np.random.default_rng(seed)
    xs = np.round(np.linspace(x0, x1, n + 1) / cell) * cell
    top = np.round((y + rng.uniform(0.1, 1.0, n)) / cell) * cell
    bottom = np.round((y - rng.uniform(0.1, 1.0, n)) / cell) * cell
    upper = [(float(xs[k + e]), float(top[k])) for k in range(n) for e in (0, 1)]
    lower = [(float(xs[k + 1 - e]), float(bottom[k])) for k in reversed(range(n)) for e in (0, 1)]
    ring = upper + lower
    return Polygon(tuple(q for k, q in enumerate(ring) if q != ring[k - 1]))  # equal steps joined


WORLDS = [
    random_world(0, 8, 6.0, 0.4),  # a room with furniture
    random_world(1, 20, 8.0, 0.3),
    random_world(2, 300, 5.0, 0.05),  # crowded: poles and fruits
    World((-1.0, 1.5, -0.5, 0.7), ()),  # walls only, sides not a whole number of blocks
    # outlines of hundreds of vertices: their distance measured with a broad phase over their edges
    World((0.0, 4.0, 0.0, 3.0), (skyline(0.2, 2.6, 1.5, 90, 0.02, 3), skyline(2.9, 3.8, 1.4, 20, 0.02, 4))),
]


@pytest.mark.parametrize("world", WORLDS, ids=["room", "8m-20", "crowded", "empty", "map-outlines"])
def test_field_equals_the_plain_formulas_at_every_node(world):
    outlines = any(len(getattr(o, "vertices", ())) > 16 for o in world.obstacles)  # plain formulas: slow on them
    h = 0.02 if len(world.obstacles) < 100 and not outlines else 0.05
    field = distance_field(world, h)
    ref = reference_grid(world, h)
    assert field.grid.shape == ref.shape
    np.testing.assert_array_equal(field.grid, ref)  # bit for bit: the same formulas, the same minimum


@pytest.mark.parametrize("world", WORLDS[:3], ids=["room", "8m-20", "crowded"])
def test_every_block_holds_the_nearest_obstacle_of_its_points(world):
    """The broad phase's candidates (plain-Python check): at random points of every block's region
    the nearest obstacle by a full scan is a candidate of the block the point falls in."""
    h = 0.02
    field = distance_field(world, h)
    rng = np.random.default_rng(7)
    pts = rng.uniform(world.bounds[0], world.bounds[1], (20_000, 2))
    i = np.floor((pts[:, 0] - field.x0) / h + 0.5).astype(int)
    j = np.floor((pts[:, 1] - field.y0) / h + 0.5).astype(int)
    nby = -(-field.grid.shape[1] // BLOCK)
    block = (i // BLOCK) * nby + j // BLOCK
    nearest = reference_nearest(world, pts)
    for b, k in zip(block, nearest, strict=True):
        assert k < 0 or k in field.members[field.starts[b] : field.starts[b + 1]]
    # and the broad phase prunes: a block holds few of the obstacles
    per_block = np.diff(field.starts)
    assert per_block.mean() < 0.05 * len(world.obstacles) + 2


@pytest.mark.parametrize("world", WORLDS[:3], ids=["room", "8m-20", "crowded"])
def test_field_distance_equals_a_full_scan_inside_and_outside_the_grid(world):
    field = distance_field(world, 0.02)
    wa = world_arrays(world, True)
    rng = np.random.default_rng(11)
    lo, hi = world.bounds[0] - 0.3, world.bounds[1] + 0.3
    pts = rng.uniform(lo, hi, (5000, 2))
    ours = np.array([field_distance(x, y, wa, field.arrays()) for x, y in pts])
    full = np.array([_world_distance(x, y, wa) for x, y in pts])
    np.testing.assert_array_equal(ours, full)
    np.testing.assert_array_equal(ours, world.signed_distance(pts))


@pytest.mark.parametrize("shape", ["disc", "footprint"])
def test_fast_checker_verdicts_on_a_crowded_world_equal_the_exact_ones(shape):
    world = WORLDS[2]
    exact = CollisionChecker(world, load_robot("turtlebot3"), shape=shape, clearance=0.02)
    fast = FastChecker(exact)
    rng = np.random.default_rng(5)
    m = 1000 if shape == "disc" else 400  # the exact footprint test is slow in plain numpy
    poses = np.column_stack([rng.uniform(-0.1, 5.1, (m, 2)), rng.uniform(-4, 4, m)])
    assert np.array_equal(fast.poses_free(poses), exact.poses_free(poses))
    undecided = poses[fast._classify(poses, False) < 0]
    assert undecided.shape[0] > 20
    assert np.array_equal(fast._exact(undecided), exact.poses_free(undecided))


@pytest.mark.parametrize("world", WORLDS[:3], ids=["room", "8m-20", "crowded"])
@pytest.mark.parametrize("shape", ["footprint", "disc"])
@pytest.mark.parametrize("walls", [True, False])
def test_clearance_equals_the_plain_reference_with_and_without_a_cached_field(world, shape, walls):
    """The compiled clearance bit for bit against the numpy reference (every obstacle measured), before
    and after a distance field of the world is cached (then measured against its block candidates), on
    poses near the obstacles (where the footprint's samples count) and anywhere."""
    from planning.collision import field as fields

    rng = np.random.default_rng(len(world.obstacles))
    x0, x1, y0, y1 = world.bounds
    n = 300 if len(world.obstacles) < 100 else 60  # the reference measures every obstacle at every sample
    anywhere = np.column_stack([rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), rng.uniform(-4, 4, n)])
    near = [
        (*np.asarray(o.center) + rng.normal(0, 0.3, 2), rng.uniform(-4, 4))
        for o in world.obstacles
        if hasattr(o, "center")
    ]
    beyond = np.column_stack([rng.uniform(x1 - 0.2, x1 + 3, 40), rng.uniform(y0, y1, 40), rng.uniform(-4, 4, 40)])
    poses = np.vstack([anywhere, np.asarray(near[: 2 * n // 3]), beyond])  # beyond: across the east wall
    checker = CollisionChecker(world, load_robot("turtlebot3"), shape=shape, clearance=0.05, walls=walls)
    ref = reference_clearance(checker, poses)
    if walls and shape == "footprint":
        assert np.any(np.isneginf(ref[-40:]))  # the footprint wholly beyond the wall
    for key in [k for k in fields._CACHE if k[0] == world]:
        del fields._CACHE[key]
    assert np.array_equal(checker.clearance_of(poses), ref)  # no field: every obstacle scanned
    distance_field(world, 0.05)
    assert fields.cached_field(world) is not None
    assert np.array_equal(checker.clearance_of(poses), ref)  # the field's candidates (walls only)
    assert np.array_equal(checker.poses_free(poses), ref > checker.clearance)


@pytest.mark.parametrize("world", WORLDS[:3], ids=["room", "8m-20", "crowded"])
@pytest.mark.parametrize("tolerance", [1e-3, 2e-4])
def test_a_finely_sampled_clearance_equals_the_plain_reference(world, tolerance):
    """The boundary sampled every millimetre and every 0.2 mm (what ``least_clearance`` refines with), measured
    in runs nearest bound first: bit for bit the reference's, which measures every sample, with and without a
    cached field, on poses grazing the obstacles (where the nearest sample decides)."""
    from planning.collision import field as fields

    rng = np.random.default_rng(11)
    robot = load_robot("turtlebot3")
    near = [
        (*np.asarray(o.center) + rng.normal(0, 0.3, 2), rng.uniform(-4, 4))
        for o in world.obstacles[:12]
        if hasattr(o, "center")
    ]
    _, x1, y0, y1 = world.bounds
    walls = np.column_stack([np.full(6, x1 - robot.radius), rng.uniform(y0, y1, 6), rng.uniform(-4, 4, 6)])
    poses = np.vstack([np.asarray(near), walls])
    checker = CollisionChecker(world, robot, shape="footprint", clearance=math.inf, tolerance=tolerance)
    ref = reference_clearance(checker, poses)
    assert np.isfinite(ref).sum() >= 10
    for key in [k for k in fields._CACHE if k[0] == world]:
        del fields._CACHE[key]
    assert np.array_equal(checker.clearance_of(poses), ref)
    distance_field(world, 0.05)
    assert np.array_equal(checker.clearance_of(poses), ref)


@pytest.mark.parametrize("world", WORLDS, ids=["room", "8m-20", "crowded", "empty", "map-outlines"])
def test_signed_distances_equal_a_full_scan_inside_and_outside_the_bounds(world):
    """``field.signed_distances`` (the block candidates of the cached field, else of one it builds)
    against the compiled scan of every obstacle, bit for bit, at points inside the bounds and up to
    1 m beyond them (outside the grid: every obstacle is scanned there)."""
    from planning.collision import field as fields
    from planning.collision.compiled import world_distances

    for key in [k for k in fields._CACHE if k[0] == world]:
        del fields._CACHE[key]
    x0, x1, y0, y1 = world.bounds
    rng = np.random.default_rng(7)
    pts = np.column_stack([rng.uniform(x0 - 1, x1 + 1, 3000), rng.uniform(y0 - 1, y1 + 1, 3000)])
    full = world_distances(pts, world_arrays(world, True))
    assert np.array_equal(fields.signed_distances(world, pts, 0.05), full)  # builds a field at 5 cm
    assert fields.cached_field(world) is not None
    assert np.array_equal(fields.signed_distances(world, pts, 0.05), full)  # finds it


@pytest.mark.parametrize("world", WORLDS[1:3], ids=["8m-20", "crowded"])
def test_the_field_does_not_depend_on_how_many_threads_build_it(world, monkeypatch):
    built = {}
    for n in (1, 3):
        monkeypatch.setattr(field_module, "threads", lambda n=n: n)
        field_module._CACHE.clear()
        built[n] = distance_field(world, 0.02)
    for name in ("grid", "starts", "members"):
        np.testing.assert_array_equal(getattr(built[1], name), getattr(built[3], name))


def test_shared_work_stops_at_its_deadline_and_on_an_error_in_any_thread(monkeypatch):
    monkeypatch.setattr(field_module, "threads", lambda: 3)
    done: list[int] = []
    field_module._share(lambda i: (time.sleep(0.01), done.append(i)), range(1000), time.perf_counter() + 0.1)
    assert len(done) < 200 and len(set(done)) == len(done)  # each item at most once, and far from all (10 s)
    done.clear()
    field_module._share(done.append, range(500), float("inf"))
    assert sorted(done) == list(range(500))
    names: set[str] = set()

    def work(i: int) -> None:
        names.add(threading.current_thread().name)
        if i == 40:
            raise ValueError("item 40")
        time.sleep(0.001)

    with pytest.raises(ValueError, match="item 40"):
        field_module._share(work, range(10_000), float("inf"))
    helpers = names - {threading.main_thread().name}
    assert len(helpers) == 2  # the work was shared
    assert not any(t.name in helpers for t in threading.enumerate())  # and the helpers have ended


def test_a_passed_deadline_stops_the_build_and_the_planners_time_out_on_it():
    world = random_world(3, 50, 6.0, 0.1)  # never built before in this process
    with pytest.raises(FieldTimeout, match="collision grid"):
        distance_field(world, 0.01, deadline=time.perf_counter())
    problem = PlanProblem(
        random_world(4, 2000, 20.0, 0.03), load_robot("turtlebot3"), Pose2D(0.3, 0.3, 0), Pose2D(19.5, 19.5, 0),
        time_limit=1e-6,
    )  # fmt: skip
    for name in ("hybrid-a-star", "rrt", "birrt", "rrt-star"):
        result = make_planner(name).plan(problem)
        assert result.status is PlanStatus.TIMEOUT, name
        assert "collision grid" in result.reason and "time limit" in result.reason
        assert result.stats["grid_s"] == result.stats["time_s"] > 0


def test_the_grid_is_reported_and_counted_in_the_planners_time():
    world = random_world(5, 12, 5.0, 0.3)
    problem = PlanProblem(world, load_robot("turtlebot3"), Pose2D(0.2, 0.2, 0.0), Pose2D(4.8, 4.8, 0.0))
    for name in ("hybrid-a-star", "birrt"):
        result = make_planner(name).plan(problem)
        assert 0 <= result.stats["grid_s"] <= result.stats["time_s"], name


def _crowded_property(world: World) -> None:
    """On any crowded world: nodes as the plain formulas give them, verdicts as the exact checker's."""
    field = distance_field(world, 0.1)
    np.testing.assert_array_equal(field.grid, reference_grid(world, 0.1))
    exact = CollisionChecker(world, load_robot("turtlebot3"))
    fast = FastChecker(exact, spacing=0.1)
    rng = np.random.default_rng(0)
    b = world.bounds
    poses = np.column_stack([rng.uniform(b[0], b[1], 100), rng.uniform(b[2], b[3], 100), rng.uniform(-4, 4, 100)])
    assert np.array_equal(fast.poses_free(poses), exact.poses_free(poses))


test_crowded_worlds_fuzz, test_crowded_worlds_fuzz_slow = fast_and_slow(crowded_worlds(), _crowded_property, fast=8)


@pytest.mark.parametrize("world", WORLDS, ids=["room", "8m-20", "crowded", "empty", "map-outlines"])
def test_the_least_distance_along_a_polyline_is_the_least_of_every_point_bit_for_bit(world):
    """``least_distance`` skips the points the 1-Lipschitz bound proves farther than the least so far: its
    value is the minimum of the distances at every point, bit for bit, with and without a cached field,
    over random walks that run along, around and into the obstacles, stand still and turn back."""
    from planning.collision import field as fields
    from planning.collision.compiled import least_distance, world_distances

    x0, x1, y0, y1 = world.bounds
    rng = np.random.default_rng(11)
    walks = []
    for _ in range(40):
        steps = rng.normal(0.0, 0.02, (rng.integers(1, 400), 2)) * rng.choice([0.0, 1.0, 5.0], (1, 2))
        start = [rng.uniform(x0, x1), rng.uniform(y0, y1)]
        walks.append(np.ascontiguousarray(start + np.cumsum(steps, axis=0)))
    arrays = world_arrays(world, True)
    for key in [k for k in fields._CACHE if k[0] == world]:
        del fields._CACHE[key]
    checker = CollisionChecker(world, load_robot("turtlebot3"))
    for with_field in (False, True):
        if with_field:
            distance_field(world, 0.05)
        assert (fields.cached_field(world) is not None) == with_field
        for pts in walks:
            full = float(np.min(world_distances(pts, arrays)))
            assert least_distance(pts, arrays, checker._field()) == full
            assert checker.least_distance(pts) == full
    assert checker.least_distance(np.zeros((0, 2))) == np.inf


def test_a_scan_of_circles_is_the_plain_loop_over_them():
    """The compiled scan over 60 circles gives, at 20,000 points, what a plain loop over the circles' centres
    and radii gives. (Each obstacle's parameters are handed on as numbers, not as its row and the polygon
    table, whose reference counting cost a scan 7 times the plain loop; that is a speed, not asserted here.)"""
    import numba as nb

    from planning.collision.compiled import world_distances

    @nb.njit(cache=False)
    def plain(points: np.ndarray, params: np.ndarray) -> np.ndarray:
        out = np.empty(points.shape[0])
        for k in range(points.shape[0]):
            d = np.inf
            for j in range(params.shape[0]):
                d = min(d, np.hypot(points[k, 0] - params[j, 0], points[k, 1] - params[j, 1]) - params[j, 2])
            out[k] = d
        return out

    rng = np.random.default_rng(5)
    world = World(
        (-25.0, 25.0, -25.0, 25.0),
        tuple(Circle((x, y), r) for x, y, r in rng.uniform([-24, -24, 0.2], [24, 24, 1.0], (60, 3))),
    )
    arrays = world_arrays(world, True)
    pts = rng.uniform(-24.0, 24.0, (20_000, 2))
    walls = np.min(np.column_stack([pts[:, 0] + 25, 25 - pts[:, 0], pts[:, 1] + 25, 25 - pts[:, 1]]), axis=1)
    np.testing.assert_allclose(world_distances(pts, arrays), np.minimum(plain(pts, arrays[3]), walls), atol=1e-12)


def test_signed_distances_keep_to_a_deadline():
    from planning.collision import field as fields

    world = random_world(6, 40, 8.0, 0.2)  # never measured before in this process
    pts = np.random.default_rng(3).uniform(0.0, 8.0, (50_000, 2))
    with pytest.raises(FieldTimeout, match=r"measuring the world's signed distance \(50000 points") as caught:
        distance_field(world, 0.05)
        fields.signed_distances(world, pts, 0.05, deadline=time.perf_counter())
    assert isinstance(caught.value, TimeoutError)
