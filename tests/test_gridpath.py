"""Grid shortest path used as a warm start: straight when free, clear and near-shortest otherwise."""

from __future__ import annotations

import itertools
import math

import numpy as np

from planning.clock import PlanClock
from planning.core.world import Box, Circle, World
from planning.planners.gridpath import grid_path


def test_free_world_gives_the_straight_segment() -> None:
    world = World((0.0, 2.0, 0.0, 2.0))
    path = grid_path(world, np.array([0.3, 0.4]), np.array([1.7, 1.5]), 0.1)
    assert path is not None
    np.testing.assert_allclose(path, [[0.3, 0.4], [1.7, 1.5]])


def test_route_around_a_disc_is_clear_and_near_the_tangent_length() -> None:
    world = World((0.0, 2.0, 0.0, 2.0), (Circle((1.0, 1.0), 0.3),))
    clear = 0.1
    path = grid_path(world, np.array([0.2, 1.0]), np.array([1.8, 1.0]), clear, resolution=0.01)
    assert path is not None
    dense = np.vstack([a + np.linspace(0, 1, 200)[:, None] * (b - a) for a, b in itertools.pairwise(path)])
    assert np.min(world.signed_distance(dense)) > clear
    # Exact shortest length: two tangents of length sqrt(0.8^2 - 0.4^2) and an arc of radius 0.4.
    rr, dd = 0.4, 0.8
    tangent = np.sqrt(dd**2 - rr**2)
    arc = rr * (np.pi - 2 * np.arccos(rr / dd))
    exact = 2 * tangent + arc
    length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
    assert exact <= length <= exact * 1.03


def test_blocked_world_returns_none() -> None:
    world = World((0.0, 2.0, 0.0, 1.0), (Box((1.0, 0.5), (0.1, 1.0)),))
    assert grid_path(world, np.array([0.3, 0.5]), np.array([1.7, 0.5]), 0.1) is None


def test_a_world_too_large_for_the_spacing_is_sampled_coarser(monkeypatch) -> None:
    """A 200 x 200 m world at 2 cm would be 1e8 nodes (24 GB and two minutes): at most MAX_CELLS are
    (40,000 here: a node a metre)."""
    from planning.planners import gridpath

    monkeypatch.setattr(gridpath, "MAX_CELLS", 40_000)
    seen: list[int] = []
    real = gridpath.signed_distances
    monkeypatch.setattr(gridpath, "signed_distances", lambda w, p, *a: (seen.append(len(p)), real(w, p, *a))[1])
    world = World((-100.0, 100.0, -100.0, 100.0), (Circle((0.0, 0.0), 1.0),))
    path = grid_path(world, np.array([-90.0, -90.0]), np.array([90.0, 90.0]), 0.5)
    assert path is not None and np.allclose(path[[0, -1]], [[-90, -90], [90, 90]])
    assert seen[0] <= (np.sqrt(gridpath.MAX_CELLS) + 1) ** 2  # the nodes, both edges included
    dense = np.vstack([a + np.linspace(0, 1, 400)[:, None] * (b - a) for a, b in itertools.pairwise(path)])
    assert np.min(world.signed_distance(dense)) > 0.5


def _plain_farthest(world: World, poly: np.ndarray, i: int, clearance: float, step: float) -> int:
    """The shortcut's scan as first written: from the last vertex back, each segment in full."""
    from planning.planners.gridpath import _segment_free

    j = poly.shape[0] - 1
    while j > i + 1 and not _segment_free(world, poly[i], poly[j], clearance, step):
        j -= 1
    return j


def test_the_thinned_shortcut_scan_is_the_plain_one() -> None:
    """_farthest_visible tests every segment's thinned samples in one call before any in full; on random
    clutter and random polylines it picks the vertex the plain scan picks, at every vertex."""
    from planning.planners.gridpath import _farthest_visible

    rng = np.random.default_rng(3)
    for _ in range(6):
        obstacles = tuple(Circle(tuple(rng.uniform(0.5, 5.5, 2)), float(rng.uniform(0.05, 0.4))) for _ in range(12))
        world = World((0.0, 6.0, 0.0, 6.0), obstacles)
        poly = rng.uniform(0.2, 5.8, (25, 2))
        for i in range(poly.shape[0] - 1):
            for clearance in (0.0, 0.1):
                plain = _plain_farthest(world, poly, i, clearance, 0.01)
                assert _farthest_visible(world, poly, i, clearance, 0.01) == plain


class _Told(PlanClock):
    """A plan clock told spent at its look number ``looks`` (from 0) and after (a deadline far off for the field)."""

    def __init__(self, looks: int) -> None:
        super().__init__(math.inf)
        self.calls, self.looks = itertools.count(), looks

    def expired(self) -> bool:
        return next(self.calls) >= self.looks


def test_grid_path_stops_when_its_time_is_spent() -> None:
    """Told the time is spent before the graph is built, no route; told so during the shortcut, the route
    found, shortened only up to there (still clear, from start to goal)."""
    world = World((0.0, 2.0, 0.0, 2.0), (Circle((1.0, 1.0), 0.3),))
    start, goal = np.array([0.2, 1.0]), np.array([1.8, 1.0])
    assert grid_path(world, start, goal, 0.1, clock=_Told(0)) is None
    steps = 1 + 8 + 1  # after the distances, after each of the 8 moves, before the search
    path = grid_path(world, start, goal, 0.1, clock=_Told(steps + 1))  # and the shortcut's first
    full = grid_path(world, start, goal, 0.1)
    assert path is not None and full is not None and path.shape[0] > full.shape[0]
    assert np.allclose(path[[0, -1]], [start, goal])
    dense = np.vstack([a + np.linspace(0, 1, 200)[:, None] * (b - a) for a, b in itertools.pairwise(path)])
    assert np.min(world.signed_distance(dense)) > 0.1


def test_grid_path_measures_its_distances_within_the_time_limit(monkeypatch) -> None:
    """A million grid nodes took the signed distances 0.25 s of one core, measured whole, twice; on a loaded
    machine a 0.3 s plan spent 2.4 s there. The distances now look at the clock as they go: with the time
    spent, they measure no more than one batch of points."""
    from planning.collision import field

    measured: list[int] = []
    real = field.field_distances
    monkeypatch.setattr(field, "field_distances", lambda p, *a: (measured.append(len(p)), real(p, *a))[1])
    world = World((-10.0, 10.0, -10.0, 10.0), (Circle((0.0, 0.0), 0.5), Box((3.0, 3.0), (0.4, 0.2), 0.3)))
    start, goal = np.array([-9.0, -9.0]), np.array([9.0, 9.0])
    assert grid_path(world, start, goal, 0.1, clock=PlanClock(0.0)) is None
    assert sum(measured) <= field.POINTS_PER_CHECK  # of the grid's million nodes
    assert grid_path(world, start, goal, 0.1) is not None and sum(measured) > 10**6
