"""The obstacle-aware 2-D route (planning.planners.geodesic): the shorter way round an obstacle, the
radius kept all along, the analytic shortest length approached from above, waypoints on the fillets."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from planning.collision.compiled import world_arrays, world_distances
from planning.core.geometry import densify_path, path_length
from planning.core.world import MAX_WORLD_SIDE, Box, Circle, World
from planning.planners import geodesic
from planning.scenario import load_scenario


def test_the_route_goes_the_short_way_round_a_disc_and_keeps_its_radius():
    """A disc of 0.5 m at (0, 0.3) between (-2, 0) and (2, 0): under it is the shorter way. For a route
    of radius R the disc grows to r = 0.5 + R, and the shortest way under it is two tangents of
    sqrt(D^2 - r^2) (D the ends' distance from the centre) and the arc between their touching points,
    r (pi - 2 beta - 2 acos(r / D)) with beta = atan(0.3 / 2)."""
    world = World((-3.0, 3.0, -3.0, 3.0), (Circle((0.0, 0.3), 0.5),))
    radius = 0.2
    v = geodesic.route(world, np.array([-2.0, 0.0]), np.array([2.0, 0.0]), radius)
    assert v is not None
    np.testing.assert_array_equal(v[0], [-2.0, 0.0])
    np.testing.assert_array_equal(v[-1], [2.0, 0.0])
    dense = densify_path(np.column_stack([v, np.zeros(len(v))]), 0.001)
    assert np.min(world.signed_distance(dense[:, :2])) > radius  # every point, not just the samples
    assert np.max(dense[:, 1]) <= 1e-12 and np.min(dense[:, 1]) < 0.3 - 0.5 - radius  # under the grown disc
    r, dist, beta = 0.5 + radius, np.hypot(2.0, 0.3), np.arctan2(0.3, 2.0)
    exact = 2.0 * np.sqrt(dist**2 - r**2) + r * (np.pi - 2.0 * beta - 2.0 * np.arccos(r / dist))
    over = 2.0 * np.sqrt(dist**2 - r**2) + r * (np.pi + 2.0 * beta - 2.0 * np.arccos(r / dist))
    assert exact - 1e-9 <= path_length(v) <= 1.03 * exact < over


def test_around_a_disc_on_the_line_the_route_length_approaches_the_analytic_one():
    """Two tangents and the arc between them round a disc of 0.5 m + R centred between the ends."""
    world = World((-3.0, 3.0, -3.0, 3.0), (Circle((0.0, 0.0), 0.5),))
    for radius in (0.1, 0.3):
        v = geodesic.route(world, np.array([-2.0, 0.0]), np.array([2.0, 0.0]), radius)
        assert v is not None
        r = 0.5 + radius
        exact = 2.0 * np.sqrt(4.0 - r * r) + r * (np.pi - 2.0 * np.arccos(r / 2.0))
        assert exact - 1e-9 <= path_length(v) <= 1.03 * exact


def test_a_walled_off_goal_has_no_route():
    wall = Box((0.0, 0.0), (0.2, 6.0))  # from wall to wall
    world = World((-3.0, 3.0, -3.0, 3.0), (wall,))
    assert geodesic.route(world, np.array([-2.0, 0.0]), np.array([2.0, 0.0]), 0.1) is None


def test_curve_waypoints_lie_on_the_fillets_of_the_corners():
    """A right-angle corner at (1, 0) with radius 0.2: the fillet's middle is (1 - 0.2 (1 - 1/sqrt 2),
    0.2 (1 - 1/sqrt 2)) from the corner inwards, heading 45 degrees; a straight vertex gives nothing."""
    v = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 2.0]])
    wp = geodesic.curve_waypoints(v, 0.2)
    inward = 0.2 * (np.sqrt(2.0) - 1.0) / np.sqrt(2.0)  # rho (1 / cos 45 - 1) along the bisector
    np.testing.assert_allclose(wp, [[1.0 - inward, inward, np.pi / 4]], atol=1e-12)
    assert np.hypot(wp[0, 0] - 0.8, wp[0, 1] - 0.2) == pytest.approx(0.2, abs=1e-12)  # on the arc
    tight = geodesic.curve_waypoints(v, 5.0)  # the fillet does not fit: the vertex itself
    np.testing.assert_allclose(tight, [[1.0, 0.0, np.pi / 4]], atol=1e-12)
    poly = geodesic.polyline_waypoints(v)
    np.testing.assert_allclose(poly, [[1.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]], atol=1e-12)


def test_compiled_world_distances_equal_the_worlds_own():
    world = load_scenario("farm").world  # circles and ellipses (bisection), walls
    pts = np.random.default_rng(4).uniform(-3.2, 3.2, (5000, 2))
    np.testing.assert_allclose(world_distances(pts, world_arrays(world)), world.signed_distance(pts), atol=1e-12)


def test_a_world_too_large_for_the_cell_is_routed_on_larger_cells(monkeypatch):
    """The largest world, 1 x 1 km, on 5 cm cells would be 4e8 of them (a 1000 x 1000 km one, before worlds
    were limited, made every sampling planner's simplification fail allocating 2.8 PiB): at most MAX_CELLS
    are searched (10,000 here)."""
    monkeypatch.setattr(geodesic, "MAX_CELLS", 10_000)  # a 20 x 20 m world on 20 cm cells
    huge = World((0.0, MAX_WORLD_SIDE, 0.0, MAX_WORLD_SIDE), ())
    vertices = geodesic.route(huge, np.array([0.15, 0.15]), np.array([0.2, 0.2]), 0.1)
    assert vertices is not None and np.allclose(vertices[[0, -1]], [[0.15, 0.15], [0.2, 0.2]])
    world = World((0.0, 20.0, 0.0, 20.0), (Circle((10.0, 10.0), 2.0),))
    vertices = geodesic.route(world, np.array([1.0, 1.0]), np.array([19.0, 19.0]), 0.3)
    assert vertices is not None and vertices.shape[0] >= 3  # round the disc
    dense = np.vstack([a + np.linspace(0, 1, 400)[:, None] * (b - a) for a, b in itertools.pairwise(vertices)])
    assert np.min(world.signed_distance(dense)) > 0.25  # the radius, less a 20 cm cell's chord's sagitta


def test_reachable_is_the_dijkstra_fields_verdict_and_both_keep_to_a_deadline():
    """``reachable`` floods the cells instead of solving the Dijkstra field (11 ms against 160 ms on a
    million cells): the same verdict on random worlds and radii, some walled off; and ``reachable`` and
    ``route`` end at their deadline with a FieldTimeout that says what was under way."""
    from planning.collision.field import FieldTimeout
    from planning.scenario import random_scenario

    verdicts = []
    for seed in range(12):
        sc = random_scenario("turtlebot3", seed)
        for radius in (0.1, 0.4, 0.7, 0.9):
            field, _, at = geodesic._from_start(sc.world, sc.start.xy, sc.goal.xy, radius, 0.05, None)
            verdicts.append(geodesic.reachable(sc.world, sc.start.xy, sc.goal.xy, radius))
            assert verdicts[-1] == bool(np.isfinite(field[at]))
    assert any(verdicts) and not all(verdicts)
    world = World((0.0, 30.0, 0.0, 30.0), (Circle((15.0, 15.0), 1.0),))  # 360,000 cells, never searched
    s, g = np.array([1.0, 1.0]), np.array([29.0, 29.0])
    geodesic.centre_distances(world, 0.05)  # the cells' distances found: the search itself is timed out
    with pytest.raises(FieldTimeout, match=r"flood fill over 0\.05 m cells \(360000 cells, 1 obstacles\) passed"):
        geodesic.reachable(world, s, g, 0.3, deadline=0.0)
    with pytest.raises(FieldTimeout, match=r"Dijkstra over 0\.05 m cells"):
        geodesic.route(world, s, g, 0.3, deadline=0.0)
    geodesic.clear_caches()
    with pytest.raises(FieldTimeout):  # the cells' distances themselves
        geodesic.reachable(world, s, g, 0.3, deadline=0.0)
    assert geodesic.reachable(world, s, g, 0.3) and geodesic.route(world, s, g, 0.3) is not None


def test_the_goal_regions_cells_are_those_whose_centres_lie_within_its_reach(monkeypatch: pytest.MonkeyPatch) -> None:
    """``reachable``'s target cells with a goal radius, looked for around the goal only (the table over every
    cell of a 50 x 50 m world took 0.1-0.25 s), are the cells the whole table marks: goals inside the bounds,
    on their edges and corners, radii from under a cell to metres."""
    world = World((-5.0, 5.0, -4.0, 4.0), (Circle((1.0, 2.0), 0.5),))
    seen: list[np.ndarray] = []
    monkeypatch.setattr(geodesic, "_connected", lambda free, s, target, seconds: seen.append(target.copy()) or 1)
    rng = np.random.default_rng(4)
    goals = [(-5.0, -4.0), (5.0, 4.0), (4.99, -3.0), *rng.uniform([-5, -4], [5, 4], (6, 2))]
    for (gx, gy), radius, cell in itertools.product(goals, (0.004, 0.25, 3.0), (0.05, 0.2)):
        seen.clear()
        geodesic.reachable(world, np.array([-3.0, -3.0]), np.array([gx, gy]), 0.1, cell, goal_radius=radius)
        target = seen[0]
        nx, ny = target.shape
        x = -5.0 + cell * (np.arange(nx) + 0.5)  # every cell's centre, as the whole table had it
        y = -4.0 + cell * (np.arange(ny) + 0.5)
        whole = np.hypot(*np.meshgrid(x - gx, y - gy, indexing="ij")) <= radius + cell / np.sqrt(2.0)
        # every cell of the table, and besides them at most one: the goal's own
        assert np.array_equal(target & whole, whole) and (target & ~whole).sum() <= 1
