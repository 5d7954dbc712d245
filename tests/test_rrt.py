"""RRT, BiRRT and RRT*: valid paths checked independently, determinism, budgets, known failures."""

import dataclasses
import itertools
import math
import re

import numpy as np
import pytest

from planning.core.geometry import Pose2D, path_length, wrap_angle
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, World
from planning.curves.reeds_shepp import reeds_shepp_length
from planning.planners.base import PlanProblem, PlanStatus
from planning.planners.registry import make_planner
from planning.planners.sampling.steering import default_turning_radius
from planning.scenario import builtin_scenarios, load_scenario

ROBOT = load_robot("turtlebot3")
RHO = default_turning_radius(ROBOT)
DISC = World((0.0, 6.0, 0.0, 6.0), (Circle((3.0, 3.0), 1.2),))


def _problem(seed=0, world=DISC, start=(0.6, 0.6, 0.0), goal=(5.4, 5.4, 0.0), **kw):
    return PlanProblem(world, ROBOT, Pose2D(*start), Pose2D(*goal), seed=seed, time_limit=kw.pop("time_limit", 20.0))


def _independent_free(world, robot, path):
    """Footprint boundary every 2 mm, path resampled every 5 mm, against World.signed_distance."""
    fp = robot.footprint
    pts = []
    for a, b in zip(fp, np.roll(fp, -1, axis=0), strict=True):
        n = max(1, int(np.ceil(np.hypot(*(b - a)) / 0.002)))
        pts.append(a + np.arange(n)[:, None] / n * (b - a))
    body = np.vstack(pts)
    seg = np.hypot(*np.diff(path[:, :2], axis=0).T) + robot.radius * np.abs(np.diff(np.unwrap(path[:, 2])))
    k = np.maximum(1, np.ceil(seg / 0.005).astype(int))
    idx = np.repeat(np.arange(len(k)), k)
    frac = np.concatenate([np.arange(m) / m for m in k])
    q = np.column_stack([path[:, :2], np.unwrap(path[:, 2])])
    dense = np.vstack([q[idx] + frac[:, None] * (q[idx + 1] - q[idx]), q[-1:]])
    c, s = np.cos(dense[:, 2])[:, None], np.sin(dense[:, 2])[:, None]
    wx = dense[:, :1] + c * body[:, 0] - s * body[:, 1]
    wy = dense[:, 1:2] + s * body[:, 0] + c * body[:, 1]
    return bool(np.all(world.signed_distance(np.column_stack([wx.ravel(), wy.ravel()])) > 0))


def _check_path(res, prob, curve_rho=None):
    assert res.status is PlanStatus.SUCCESS, res.reason
    p = res.path
    assert np.allclose(p[0], prob.start.as_array())
    g = prob.goal.as_array()
    assert np.hypot(*(p[-1, :2] - g[:2])) <= prob.position_tolerance
    assert abs((p[-1, 2] - g[2] + np.pi) % (2 * np.pi) - np.pi) <= prob.heading_tolerance
    ds = np.hypot(*np.diff(p[:, :2], axis=0).T)
    assert ds.max() <= 0.02 + 1e-9
    assert res.directions is not None and res.directions.shape == (p.shape[0],)
    assert _independent_free(prob.world, prob.robot, p)
    # kinematic feasibility: each step moves along the heading in the stated direction, no sideways jumps
    d = np.diff(p[:, :2], axis=0)
    th = p[:-1, 2] + 0.5 * np.diff(np.unwrap(p[:, 2]))
    along = d[:, 0] * np.cos(th) + d[:, 1] * np.sin(th)
    side = -d[:, 0] * np.sin(th) + d[:, 1] * np.cos(th)
    moving = ds > 1e-9
    assert np.all(np.abs(side[moving]) <= 1e-3 * ds[moving] + 1e-9)
    assert np.all(np.sign(along[moving]) == res.directions[1:][moving])
    if curve_rho is not None:  # curvature bound of exact curves
        dth = np.abs(np.diff(np.unwrap(p[:, 2])))
        # on an arc of radius r >= rho the chord is 2 r sin(dth / 2) >= 2 rho sin(dth / 2)
        assert np.all(2 * curve_rho * np.sin(dth[moving] / 2) <= ds[moving] * (1 + 1e-6) + 1e-9)


@pytest.mark.parametrize(
    ("name", "opts", "rho"),
    [
        ("rrt", {}, None),
        ("birrt", {}, None),
        ("birrt", {"steering": "reeds_shepp"}, RHO),
        ("birrt", {"steering": "dubins"}, RHO),
        ("rrt-star", {"max_iterations": 300}, RHO),
        ("rrt", {"steering": "diffdrive"}, None),
    ],
)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_paths_valid(name, opts, rho, seed):
    prob = _problem(seed)
    res = make_planner(name, **opts).plan(prob)
    _check_path(res, prob, rho)


def test_dubins_birrt_joins_forward_without_u_turn():
    # The join must be a forward Dubins curve from the start tree to the goal tree.
    for seed in range(8):
        prob = _problem(seed)
        res = make_planner("birrt", steering="dubins").plan(prob)
        _check_path(res, prob, RHO)
        assert np.all(res.directions == 1.0)


def test_rrt_star_edges_exact_after_rewiring_and_cost_monotone():
    prob = _problem(4)
    res = make_planner("rrt-star", max_iterations=600).plan(prob)
    _check_path(res, prob, RHO)
    tree = res.tree
    nodes, parents = tree.nodes, tree.parents
    for k, edge in enumerate(tree.edges):  # edge k belongs to node k + 1
        child, par = nodes[k + 1], nodes[parents[k + 1]]
        assert np.allclose(edge[0], par[:2], atol=1e-9) and np.allclose(edge[-1], child[:2], atol=1e-9)
        seg = np.hypot(*np.diff(edge, axis=0).T).sum()
        assert seg <= reeds_shepp_length(par, child, RHO)[0] + 1e-9  # chord sum of the exact curve
    costs = [c for _, _, c in res.stats["cost_history"]]
    assert all(b <= a for a, b in itertools.pairwise(costs))
    assert res.raw_path is not None  # cost_m is the tree's path; the result is simplified from it
    assert res.stats["cost_m"] == pytest.approx(path_length(res.raw_path), rel=2e-3)
    assert res.length() <= path_length(res.raw_path) + 1e-9


def test_rrt_star_shorter_than_rrt():
    # the searches themselves (simplification makes both shorter: tests/test_simplify.py)
    star = [make_planner("rrt-star", max_iterations=400, simplify=False).plan(_problem(s)).length() for s in range(5)]
    rrt = [make_planner("rrt", simplify=False).plan(_problem(s)).length() for s in range(5)]
    assert np.median(star) < np.median(rrt)


@pytest.mark.parametrize(("name", "opts"), [("rrt", {}), ("birrt", {}), ("rrt-star", {"max_iterations": 200})])
def test_same_seed_same_plan(name, opts):
    a = make_planner(name, **opts).plan(_problem(5))
    b = make_planner(name, **opts).plan(_problem(5))
    assert np.array_equal(a.path, b.path) and np.array_equal(a.directions, b.directions)


def test_invalid_start_and_goal():
    r = make_planner("rrt").plan(_problem(start=(3.0, 3.0, 0.0)))
    assert r.status is PlanStatus.INVALID_START and "start" in r.reason
    r = make_planner("birrt").plan(_problem(goal=(0.05, 3.0, 0.0)))
    assert r.status is PlanStatus.INVALID_GOAL and "goal" in r.reason


@pytest.mark.parametrize(("name", "opts"), [("rrt", {}), ("birrt", {}), ("rrt-star", {})])
def test_unreachable_goal_ends_in_timeout(name, opts):
    """A wall with a slit the robot's inscribed disc passes and the robot does not: nothing proves the goal
    unreachable, and the search ends at its budget (a sealed wall is proved, above)."""
    walls = (Box((4.5, 1.47), (0.1, 2.94)), Box((4.5, 4.53), (0.1, 2.94)))  # a 0.12 m slit at y = 3
    world = World((0.0, 6.0, 0.0, 6.0), walls)
    prob = _problem(world=world, goal=(5.4, 3.0, 0.0))
    res = make_planner(name, max_iterations=400, time_limit=10.0, **opts).plan(prob)
    assert res.status is PlanStatus.TIMEOUT
    assert "budget" in res.reason and res.path.shape[1] == 3
    res = make_planner(name, max_iterations=10**9, time_limit=0.3, **opts).plan(prob)
    assert res.status is PlanStatus.TIMEOUT and res.stats["time_s"] < 1.5
    sealed = World((0.0, 6.0, 0.0, 6.0), (Box((4.5, 3.0), (0.1, 6.0)),))
    res = make_planner(name, max_iterations=400, time_limit=10.0, **opts).plan(
        _problem(world=sealed, goal=(5.4, 3.0, 0.0))
    )
    assert res.status is PlanStatus.INFEASIBLE and "walled off" in res.reason and res.path.shape[1] == 3


def test_rrts_partial_path_says_how_far_its_heading_is_from_the_goals():
    """A goal facing back down a corridor too narrow to turn in: rrt's nearest node was 0.011 m away and its
    reason said only that, its heading pi off. The reason names both."""
    world = World((0.0, 3.0, 0.0, 0.208))
    prob = PlanProblem(world, load_robot("turtlebot3"), Pose2D(0.3, 0.104, 0.0), Pose2D(2.5, 0.104, math.pi))
    res = make_planner("rrt", max_iterations=1000, time_limit=10.0).plan(prob)
    assert res.status is PlanStatus.TIMEOUT
    m = re.search(r"nearest the goal \(([0-9.]+) m away, its heading ([0-9.]+) rad off the goal.s\)", res.reason)
    assert m, res.reason
    turn = abs(wrap_angle(float(res.path[-1, 2]) - math.pi))
    assert float(m.group(2)) == pytest.approx(turn, abs=0.006) and turn > 2.5


def test_bad_options():
    from planning.errors import ConfigError

    with pytest.raises(ConfigError, match="unknown option"):
        make_planner("rrt", speed=3)
    with pytest.raises(ConfigError, match="steering"):
        make_planner("rrt", steering="magic").plan(_problem())


def _scenarios():
    out = []
    for name in builtin_scenarios():
        s = load_scenario(name)
        if np.hypot(s.start.x - s.goal.x, s.start.y - s.goal.y) > s.position_tolerance:
            out.append(name)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("scenario", _scenarios())
@pytest.mark.parametrize(("name", "opts"), [("rrt", {}), ("birrt", {"steering": "reeds_shepp"}), ("rrt-star", {})])
def test_builtin_scenarios(scenario, name, opts):
    for seed in range(5):
        prob = PlanProblem.from_scenario(load_scenario(scenario), seed=seed, time_limit=30.0)
        res = make_planner(name, max_iterations=3000, **opts).plan(prob)
        if res.status is PlanStatus.SUCCESS:
            _check_path(res, prob, None if name == "rrt" else default_turning_radius(prob.robot))
        else:
            assert res.status is PlanStatus.TIMEOUT and res.reason


# --- rrt-star: goal tree, curves to the goal, informed sampling -------------------------------------------
def _search_until_solved(prob, extra_iterations, **opts):
    """An rrt-star search run step by step until its first solution, then ``extra_iterations`` more."""
    from planning.planners.sampling.rrt_star import RRTStar, _Search

    planner = RRTStar(**opts)
    local, budget, bad = planner._setup(prob)
    assert bad is None
    search = _Search(planner.config, prob, local, np.random.default_rng(prob.seed))
    it = 0
    while not search.goal_nodes:
        assert it < 5000, "no solution"
        it, _ = search.step(it + 1, budget)
    for _ in range(extra_iterations):
        it, _ = search.step(it + 1, budget)
    return search


@pytest.mark.parametrize("connect_iterations", [1000, 0])  # RRT*-Connect's trees; birrt's path from the first
def test_rrt_star_goal_tree_graft_keeps_every_edge_exact_and_every_cost_its_curves(connect_iterations):
    """Through the goal tree's graft (or birrt's path's), the goal-node reparenting and rewiring: each node's cost
    is its parent's plus the exact Reeds–Shepp length between them, and its edge runs from the parent's pose
    to its own with no more chord length than that curve."""
    search = _search_until_solved(_problem(1), 400, connect_iterations=connect_iterations)
    assert search.grafted  # the disc blocks the direct curve: the first path came through the goal tree
    assert (search.birrt_iterations > 0) == (connect_iterations == 0)
    tree = search.tree
    for i in range(1, tree.n):
        parent = int(tree.parents[i])
        poses = tree.edges[i][0]
        assert np.allclose(poses[0, :2], tree.nodes[parent, :2], atol=1e-9)
        assert np.allclose(poses[-1, :2], tree.nodes[i, :2], atol=1e-9)
        curve = reeds_shepp_length(tree.nodes[parent], tree.nodes[i], RHO)[0]
        assert tree.costs[i] == pytest.approx(tree.costs[parent] + curve, abs=1e-9)
        assert np.hypot(*np.diff(poses[:, :2], axis=0).T).sum() <= curve + 1e-9
    assert search.best == pytest.approx(min(tree.costs[g] for g in search.goal_nodes), abs=0.0)


def test_rrt_star_parks_in_a_slot_twice_its_length_with_its_goal_tree_only():
    """The bench's tight_park: with one tree (OMPL's RRT* way) neither seed finds the slot in 4000
    iterations; with the goal tree both do."""
    from sim.tools.bench.plan_problems import tight_park

    base = tight_park()
    for seed in (3, 5):
        prob = PlanProblem(**{**base.__dict__, "seed": seed, "time_limit": 120.0})
        opts = {"stop_on_first": True, "max_iterations": 4000, "simplify": False}
        with_tree = make_planner("rrt-star", **opts).plan(prob)
        _check_path(with_tree, prob, RHO)
        assert with_tree.stats["goal_tree_joined"] is True
        assert make_planner("rrt-star", goal_tree=False, **opts).plan(prob).status is PlanStatus.TIMEOUT


def test_rrt_star_parks_in_the_tight_slot_by_birrts_search_where_its_own_connect_phase_is_slow():
    """tight_park's first path takes RRT*-Connect 218-27,825 iterations (seeds 0-9; its Python iterations
    about 16,000 a second): after ``connect_iterations`` (here none) birrt's compiled search looks for it
    instead, and its path, grafted into the RRT* tree, is a valid plan into the slot."""
    from sim.tools.bench.plan_problems import tight_park

    base = tight_park()
    for seed in (0, 1):
        prob = PlanProblem(**{**base.__dict__, "seed": seed, "time_limit": 120.0})
        opts = {"stop_on_first": True, "max_iterations": 100_000, "simplify": False, "connect_iterations": 0}
        res = make_planner("rrt-star", **opts).plan(prob)
        _check_path(res, prob, RHO)
        assert res.stats["goal_tree_joined"] is True and res.stats["birrt_iterations"] == res.stats["iterations"]
        # its cost the curves' lengths; the dense poses' chords are at most that, and short of it by the sampling
        assert res.length() <= res.stats["cost_m"] + 1e-9 and res.stats["cost_m"] == pytest.approx(res.length(), 1e-3)


def test_rrt_star_without_a_path_shows_birrts_trees_and_the_nearest_of_their_nodes():
    """A run that handed its first path to birrt's search and ended without one returned the RRT* tree alone: with
    ``connect_iterations=0`` only its root, the start as the partial path (0.674 m from tight_park's goal, where
    birrt's own run ends 0.047 m from it). Now birrt's trees are drawn beside it, and the partial path ends on the
    node of either start tree nearest the goal."""
    from planning.planners.sampling.tree import goal_gap
    from sim.tools.bench.plan_problems import tight_park

    prob = PlanProblem(**{**tight_park().__dict__, "seed": 0, "time_limit": 60.0})
    res = make_planner("rrt-star", connect_iterations=0, max_iterations=3000, simplify=False).plan(prob)
    assert res.status is PlanStatus.TIMEOUT and res.stats["birrt_iterations"] == 3000
    birrt = make_planner("birrt", steering="reeds_shepp", goal_bias=0.05, max_iterations=3000, simplify=False)
    alone = birrt.plan(prob)  # birrt's search, as rrt-star ran it: the same draws after no connect iteration
    assert alone.status is PlanStatus.TIMEOUT
    assert res.tree.nodes.shape[0] == res.stats["nodes"] == 1 + alone.tree.nodes.shape[0]  # the root, birrt's
    gap = goal_gap(res.path[-1:], prob)[0]
    assert gap == pytest.approx(goal_gap(alone.path[-1:], prob)[0], abs=0.0) and gap < 0.1
    np.testing.assert_array_equal(res.path, alone.path)


def test_rrt_star_takes_the_direct_curve_when_the_start_sees_the_goal():
    prob = _problem(0, world=World((0.0, 6.0, 0.0, 6.0), ()))
    res = make_planner("rrt-star", max_iterations=50, simplify=False).plan(prob)
    direct = reeds_shepp_length(prob.start.as_array(), prob.goal.as_array(), RHO)[0]
    assert res.stats["first_solution_iteration"] == 1
    assert res.stats["first_length_m"] == pytest.approx(direct, rel=1e-12)
    assert res.stats["cost_m"] == pytest.approx(direct, rel=1e-12)


@pytest.mark.parametrize("major", [5.0, 40.0])  # drawn in the ellipse; drawn in the bounds and rejected
def test_informed_poses_fill_the_ellipse_uniformly(major):
    from planning.planners.sampling.rrt_star import informed_pose

    prob = _problem(0, world=World((-1.0, 7.0, -3.0, 3.0), ()), start=(0.0, 0.0, 0.0), goal=(4.0, 0.0, 0.0))
    rng = np.random.default_rng(7)
    q = np.array([informed_pose(rng, prob, major) for _ in range(4000)])
    focal = np.hypot(q[:, 0], q[:, 1]) + np.hypot(q[:, 0] - 4.0, q[:, 1])
    assert np.all(focal <= major + 1e-12)
    assert np.all((q[:, 0] >= -1.0) & (q[:, 0] <= 7.0) & (q[:, 1] >= -3.0) & (q[:, 1] <= 3.0))
    assert np.all(np.abs(q[:, 2]) <= np.pi)
    if major == 5.0:  # wholly inside the bounds: half the samples in each half, half in the ellipse scaled by 1/sqrt(2)
        a, b = 2.5, 1.5
        inner = ((q[:, 0] - 2.0) / a) ** 2 + (q[:, 1] / b) ** 2 <= 0.5
        assert abs(np.mean(q[:, 0] > 2.0) - 0.5) < 0.03 and abs(np.mean(inner) - 0.5) < 0.03
        assert abs(np.mean(q[:, 2] > 0.0) - 0.5) < 0.03


def test_rrt_star_never_stops_before_its_minimum_iterations():
    res = make_planner("rrt-star", simplify=False, min_iterations=900, max_iterations=2000).plan(_problem(2))
    assert res.stats["iterations"] >= 900


@pytest.mark.parametrize(
    ("opts", "field"),
    [({"neighbour_pool": 0.5}, "neighbour_pool"), ({"min_iterations": -1}, "min_iterations"),
     ({"connect_steps": 0}, "connect_steps"), ({"region_tries": 0}, "region_tries")],
)  # fmt: skip
def test_rrt_star_rejects_bad_search_options(opts, field):
    from planning.errors import ConfigError

    with pytest.raises(ConfigError, match=field):
        make_planner("rrt-star", **opts)


def test_rrt_star_path_bias_samples_around_the_best_path():
    """After the first solution, ``path_bias`` = 1 draws every non-goal sample within a few ``path_sigma``
    of a node of the best path (normal noise: 4 sigma bounds all but ~1e-4 of them), inside the bounds."""
    search = _search_until_solved(_problem(1), 50, path_bias=1.0, goal_bias=0.0)
    path_nodes = search.tree.nodes[search.incumbent]
    assert search.incumbent.size and search.incumbent[0] == search.best_goal()

    def near(points):  # fraction within 4 sigma (radially, sqrt(2) sigma per axis) of a path node
        gap = np.hypot(points[:, None, 0] - path_nodes[None, :, 0], points[:, None, 1] - path_nodes[None, :, 1])
        return np.mean(gap.min(axis=1) <= 4 * 0.5 * RHO * np.sqrt(2))

    q = np.array([search._sample() for _ in range(2000)])
    assert near(q) > 0.999
    assert np.all((q[:, :2] >= 0.0) & (q[:, :2] <= 6.0)) and np.all(np.abs(q[:, 2]) <= np.pi)
    assert near(search.rng.random((2000, 2)) * 6.0) < 0.9  # the same test fails for uniform samples


def test_check_order_is_ompl_bisection_and_keeps_verdicts() -> None:
    """Motions are checked new end first, then the other end, then the interior by bisection (OMPL's
    order): a permutation of every pose, so the verdict, and with it every plan, is unchanged."""
    from planning.planners.sampling.extend import check_order

    assert check_order(8, False).tolist() == [7, 0, 3, 1, 5, 2, 4, 6]
    assert check_order(8, True).tolist() == [0, 7, 3, 1, 5, 2, 4, 6]
    assert check_order(1, False).tolist() == [0] and check_order(2, True).tolist() == [0, 1]
    for n in range(1, 300):
        for new_first in (False, True):
            assert sorted(check_order(n, new_first).tolist()) == list(range(n))


def test_birrts_connect_steps_stop_when_they_no_longer_close_in():
    """Two offset 3.2 m walls with 0.8 m doors, and a turn about: the fruit-farm report's primitives
    turn 0.15 rad per 0.15 m, and connect steps that went on after they stopped closing in on their
    target shuffled back and forth (raw paths of 92-1915 m, up to 2528 cusps, for a way of 10 m)."""
    walls = (Box((2.7, 1.6), (0.2, 3.2)), Box((5.3, 2.4), (0.2, 3.2)))
    world = World((0.0, 8.0, 0.0, 4.0), walls)
    for seed in range(4):
        prob = _problem(seed, world=world, start=(1.0, 1.0, np.pi / 2), goal=(7.0, 3.0, -np.pi / 2))
        res = make_planner("birrt", simplify=False).plan(prob)
        _check_path(res, prob)
        assert res.length() < 40.0 and res.stats["iterations"] < 1000


@pytest.mark.slow  # 62,000 region poses; 3 s
def test_goal_region_poses_lie_in_the_region_and_reach_its_shortest_curve():
    """The region's poses are in the goal region, the goal pose first, and from random starts the
    shortest curve to one of them is within 2.5 mm of the shortest to a grid of 60,000 poses of the
    region (measured: 0.4 mm median, 2.0 mm worst over 300 starts); the goal pose alone is centimetres off."""
    from planning.planners.sampling.tree import goal_region_poses, in_goal

    prob = _problem(0, world=World((0.0, 6.0, 0.0, 6.0), ()), goal=(3.0, 3.0, 3.1))  # heading edge past pi
    aims = goal_region_poses(prob)
    g = prob.goal.as_array()
    assert np.array_equal(aims[0], g) and len(np.unique(aims, axis=0)) == len(aims)
    assert all(in_goal(a, prob) for a in aims)
    r, a, h = np.meshgrid(
        np.linspace(0.0, prob.position_tolerance, 21),
        np.linspace(0.0, 2.0 * np.pi, 72, endpoint=False),
        np.linspace(-prob.heading_tolerance, prob.heading_tolerance, 41),
        indexing="ij",
    )
    grid = np.column_stack([g[0] + (r * np.cos(a)).ravel(), g[1] + (r * np.sin(a)).ravel(), g[2] + h.ravel()])
    rng = np.random.default_rng(5)
    gaps, pose_gaps = [], []
    for _ in range(40):
        d, b = rng.uniform(0.2, 3.0), rng.uniform(-np.pi, np.pi)
        s = np.array([g[0] + d * np.cos(b), g[1] + d * np.sin(b), rng.uniform(-np.pi, np.pi)])
        best = reeds_shepp_length(s, grid, RHO).min()
        gaps.append(reeds_shepp_length(s, aims, RHO).min() - best)
        pose_gaps.append(reeds_shepp_length(s, g, RHO)[0] - best)
    assert min(gaps) >= -1e-9 and max(gaps) <= 2.5e-3
    assert np.median(pose_gaps) > 0.02


def test_rrt_star_region_goal_ends_on_the_shortest_way_into_the_region():
    """With ``region_goal`` the start that sees the goal takes the shortest curve to the region's poses,
    a valid path ending inside the region; without it, the curve to the goal pose. Around a disc every
    edge stays the exact curve from its parent and every cost the sum of its curves."""
    from planning.planners.sampling.tree import goal_region_poses

    prob = _problem(0, world=World((0.0, 6.0, 0.0, 6.0), ()))
    aims = goal_region_poses(prob)
    region = make_planner("rrt-star", max_iterations=50, simplify=False, region_goal=True).plan(prob)
    pose = make_planner("rrt-star", max_iterations=50, simplify=False).plan(prob)
    _check_path(region, prob, RHO)
    shortest = reeds_shepp_length(prob.start.as_array(), aims, RHO).min()
    assert region.stats["cost_m"] == pytest.approx(shortest, rel=1e-12)
    assert region.stats["cost_m"] == pytest.approx(path_length(region.path), rel=1e-3)
    assert region.stats["cost_m"] < pose.stats["cost_m"] - 0.02
    search = _search_until_solved(_problem(1), 300, region_goal=True)
    tree = search.tree
    for i in range(1, tree.n):
        parent = int(tree.parents[i])
        curve = reeds_shepp_length(tree.nodes[parent], tree.nodes[i], RHO)[0]
        assert tree.costs[i] == pytest.approx(tree.costs[parent] + curve, abs=1e-9)
    on_aims = search.aim_nodes[search.aim_nodes >= 0]
    assert on_aims.size >= 1 and np.array_equal(tree.nodes[on_aims], aims[search.aim_nodes >= 0])
    assert search.best == pytest.approx(min(tree.costs[g] for g in search.goal_nodes), abs=0.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rrt_star_region_goal_plans_valid_paths_on_random_worlds(seed):
    """Seeded random worlds (nothing was tuned on them): with ``region_goal`` every path is valid by the
    independent check (collision-free footprint, kinematics, exact curves' curvature), ends in the goal
    region, and its reported cost is its length."""
    from planning.scenario import random_scenario

    sc = random_scenario("turtlebot3", 40 + seed)
    prob = PlanProblem.from_scenario(sc, seed=seed)
    res = make_planner("rrt-star", max_iterations=800, simplify=False, region_goal=True).plan(prob)
    _check_path(res, prob, RHO)
    assert res.stats["cost_m"] == pytest.approx(path_length(res.path), rel=2e-3)


def test_rrt_star_with_its_start_in_the_goal_region_returns_at_once():
    """A start equal to the goal took 1.0-1.4 s: its first solution cost 0, which no later one improves, and
    the stall rule measures a relative improvement, so the run went on to its whole budget. Now, as birrt
    does, the exact curve to the goal pose (free here) or, with ``region_goal``, the start itself."""
    for goal in ((0.6, 0.6, 0.0), (0.63, 0.6, 0.05)):  # the start itself; inside the goal's tolerance
        prob = _problem(goal=goal)
        res = make_planner("rrt-star").plan(prob)
        assert res.stats["time_s"] - res.stats["code_s"] < 0.05
        assert res.success and res.stats["iterations"] == 0 and res.stats["stopped_by"] == "start in goal region"
        assert res.stats["birrt_iterations"] == 0 and res.stats["goal_tree_joined"] is False  # every run's stats
        np.testing.assert_array_equal(res.path[0], prob.start.as_array())
        np.testing.assert_allclose(res.path[-1], prob.goal.as_array(), atol=1e-9)
        region = make_planner("rrt-star", region_goal=True).plan(prob)
        assert region.success and region.path.tobytes() == prob.start.as_array()[None, :].tobytes()


def test_rrt_star_ends_on_the_goal_pose_once_a_curve_reached_it() -> None:
    """A slalom through three walls (a held-out world): a node that landed on the goal region's rim by
    itself was cheaper than the node a curve put on the goal pose, and the plan ended there, 4.9 cm from
    the goal, though region_goal is off; it ends on the goal pose (the tracker keeps the whole tolerance)."""
    walls = (Box((1.5, 1.15), (0.1, 2.3)), Box((3.0, 1.85), (0.1, 2.3)), Box((4.5, 1.15), (0.1, 2.3)))
    problem = PlanProblem(
        World((0, 6, 0, 3), walls), load_robot("edumip-balancing"), Pose2D(0.5, 0.5, 1.57), Pose2D(5.5, 2.5, 0.0),
        position_tolerance=0.05, heading_tolerance=0.1, time_limit=8.0, seed=0,
    )  # fmt: skip
    res = make_planner("rrt-star").plan(problem)
    assert res.status is PlanStatus.SUCCESS
    np.testing.assert_allclose(res.path[-1], [5.5, 2.5, 0.0], atol=1e-9)


def _clutter(seed: int, n: int = 220) -> World:
    """A 4 x 4 m floor of small circles (1.5-4 cm), the held-out world where birrt's unicycle trees filled with
    copies of five poses."""
    rng = np.random.default_rng(seed)
    xs, ys, rs = rng.uniform(0.2, 3.8, n), rng.uniform(0.2, 3.8, n), rng.uniform(0.015, 0.04, n)
    discs = [Circle((float(x), float(y)), float(r)) for x, y, r in zip(xs, ys, rs, strict=True)]
    clear = [d for d in discs if min(d.signed_distance([[0.4, 0.4], [3.6, 3.6]])) > 0.2]
    return World((0.0, 4.0, 0.0, 4.0), tuple(clear))


@pytest.mark.parametrize("name", ["rrt", "birrt"])
def test_primitive_trees_hold_each_pose_once(name: str) -> None:
    """A primitive and its reverse land on the node they left; added again, such copies filled birrt's trees
    (2502 nodes, 5 poses) and its partial path went back and forth over them (581 m, 154,901 poses, in a 4 x 4 m
    world; 12 s of wall time for a 1.5 s plan, checking its clearance)."""
    start, goal = Pose2D(0.35, 0.35, 0.0), Pose2D(3.65, 3.65, math.pi / 2)
    problem = PlanProblem(_clutter(5), load_robot("edumip"), start, goal, seed=0)  # 752 nodes, 4 poses; rrt 617 of 856
    result = make_planner(name, max_iterations=1500).plan(problem)
    tree = result.tree
    assert tree is not None
    poses = np.round(np.asarray(tree.nodes), 9)
    assert len(np.unique(poses, axis=0)) == len(poses)
    assert path_length(result.path) < 60.0  # a partial path goes somewhere, once


def test_birrt_whose_roots_cannot_grow_says_so_at_once() -> None:
    """Start and goal in bays shorter than every unicycle primitive (0.75 m) and the direct curve blocked: birrt
    spent 37,923 iterations with its two roots alone and told the user to raise max_iterations."""
    world = World((0.0, 1.6, 0.0, 0.8), (Box((0.8, 0.4), (0.2, 0.3)),))
    problem = PlanProblem(world, load_robot("turtlebot3"), Pose2D(0.3, 0.4, 0.0), Pose2D(1.3, 0.4, 0.0), seed=0)
    result = make_planner("birrt").plan(problem)
    assert result.status is PlanStatus.INFEASIBLE and result.stats["iterations"] == 0
    assert "motion primitives from the start and goal collides, so the trees cannot grow" in result.reason
    assert "steering='reeds_shepp'" in result.reason
    assert make_planner("rrt", steering="unicycle").plan(problem).status is PlanStatus.INFEASIBLE
    assert make_planner("birrt", steering="reeds_shepp").plan(problem).status is not PlanStatus.INFEASIBLE


WALLED = World(  # the goal inside four walls, no way in
    (0.0, 4.0, 0.0, 4.0),
    (
        Box((2.8, 2.0), (1.8, 0.1)),
        Box((2.8, 3.6), (1.8, 0.1)),
        Box((2.0, 2.8), (0.1, 1.8)),
        Box((3.6, 2.8), (0.1, 1.8)),
    ),
)


@pytest.mark.parametrize("name", ["rrt", "birrt", "rrt-star"])
def test_a_walled_off_goal_is_proved_infeasible_not_a_timeout(name):
    """The goal walled in: the tree planners spent their whole limit and said "timeout ... a larger max_iterations
    or another seed may find a path" (rrt 5 s of 5). A quarter into the budget without a path they now try the 2-D
    proof Hybrid-A* and C-RRT* make before searching: infeasible, saying why, well within the limit."""
    problem = _problem(world=WALLED, start=(0.5, 0.5, 0.0), goal=(2.8, 2.8, 0.0), time_limit=4.0)
    result = make_planner(name).plan(problem)
    assert result.status is PlanStatus.INFEASIBLE, result.reason
    assert "2-D search" in result.reason and "walled off" in result.reason and "may find a path" not in result.reason
    assert result.stats["time_s"] - result.stats.get("code_s", 0.0) < 0.5 * 4.0  # a quarter, and the proof
    # an open door: the same planner still finds its path (the proof, if it runs, proves nothing)
    door = World(WALLED.bounds, (*WALLED.obstacles[1:], Box((3.1, 2.0), (1.2, 0.1))))
    assert make_planner(name).plan(_problem(world=door, start=(0.5, 0.5, 0.0), goal=(2.8, 2.8, 0.0))).success


def test_a_goal_walled_in_but_within_tolerance_of_a_reachable_place_is_not_proved_walled_off():
    """The goal inside a closed ring the robot fits in but cannot enter, its tolerance (0.25 m) reaching outside
    the ring: the tree planners may end anywhere within it, and rrt-star does. The proof asked whether the goal's
    own cell was reachable and called the problem infeasible a quarter into the budget."""
    ring = (Box((1.9625, 0.88), (0.235, 0.02)), Box((1.9625, 1.12), (0.235, 0.02)),
            Box((1.855, 1.0), (0.02, 0.26)), Box((2.07, 1.0), (0.02, 0.26)))  # fmt: skip
    world = World((0.0, 3.0, 0.0, 2.0), ring)
    for seed in (0, 1):
        problem = PlanProblem(world, ROBOT, Pose2D(0.5, 1.0, 0.0), Pose2D(1.98, 1.0, 0.0), seed=seed, time_limit=8.0,
                              position_tolerance=0.25, heading_tolerance=math.pi)  # fmt: skip
        result = make_planner("rrt-star").plan(problem)
        assert result.success, (seed, result.reason)
        assert result.stats["birrt_iterations"] > 0  # birrt's search found it, RRT*-Connect's 1000 iterations not
        assert result.stats["goal_tree_joined"] is False  # its path ends in the region, not through the goal tree
        assert 0.15 < math.hypot(result.path[-1, 0] - 1.98, result.path[-1, 1] - 1.0) <= 0.25  # outside the ring


def test_the_fruit_farm_reports_finding_birrt_meets_where_rrt_fails() -> None:
    """The fruit-farm report: one tree of unicycle primitives did not reach the fruit in 5000 samples, two trees met
    (in ~2500). Under its conditions (primitives only, no direct curve, trees joined within 0.05 in the metric,
    5000 samples) birrt plans the farm in every seed and rrt in none; by default one curve joins the farm's ends."""
    problem = PlanProblem.from_scenario(load_scenario("farm"))
    report = {"steering": "unicycle", "max_iterations": 5000, "goal_connect_radius": 0.05, "simplify": False}
    for seed in range(4):
        p = dataclasses.replace(problem, seed=seed)
        bi = make_planner("birrt", direct_curve=False, **report).plan(p)
        assert bi.status is PlanStatus.SUCCESS and bi.stats["iterations"] > 0, bi
        one = make_planner("rrt", **report).plan(p)
        assert one.status is PlanStatus.TIMEOUT and one.stats["iterations"] == 5000, one
    direct = make_planner("birrt").plan(problem)
    assert direct.status is PlanStatus.SUCCESS and direct.stats["iterations"] == 0
