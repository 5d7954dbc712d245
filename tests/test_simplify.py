"""Path simplification: analytic cases with straight steering, and every sampling planner's simplified
plans (collision-free, same ends, never longer, never more cusps, C-RRT*'s cost never worse)."""

from __future__ import annotations

import itertools
import time

import numpy as np
import pytest

from planning.collision.exact import CollisionChecker
from planning.collision.grid import FastChecker
from planning.core.geometry import Pose2D, densify_path, path_length
from planning.core.robot import load_robot
from planning.core.world import World
from planning.errors import ConfigError
from planning.planners.base import PlanProblem, PlanStatus
from planning.planners.registry import make_planner
from planning.planners.sampling.extend import LocalPlanner
from planning.planners.sampling.tree import make_checker
from planning.planners.simplify import SimplifyConfig, count_cusps, length_cost, simplify_path
from planning.scenario import load_scenario, random_scenario

STEP = 0.01  # dense spacing of the synthetic paths [m]


def straight(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Straight steering: heading along the segment (kept when not moving), samples every STEP."""
    h = float(np.arctan2(b[1] - a[1], b[0] - a[0])) if np.any(a[:2] != b[:2]) else float(a[2])
    n = max(1, int(np.ceil(np.hypot(*(b[:2] - a[:2])) / STEP)))
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    poses = np.column_stack([a[:2] + s * (b[:2] - a[:2]), np.full(n + 1, h)])
    poses[0], poses[-1] = a, b
    return poses, np.ones(n + 1)


def polyline(*pts: tuple[float, float]) -> tuple[np.ndarray, list[int]]:
    """Dense poses along straight segments through ``pts`` and the indices of the corners."""
    parts, verts = [np.array([[*pts[0], 0.0]])], [0]
    for a, b in itertools.pairwise(pts):
        p, _ = straight(np.array([*a, 0.0]), np.array([*b, 0.0]))
        parts.append(p[1:])
        verts.append(verts[-1] + p.shape[0] - 1)
    return np.vstack(parts), verts


def outside_disc(centre: tuple[float, float], r: float):
    """A checker: every pose's position at least ``r`` from ``centre``."""
    return lambda poses: bool(np.all(np.hypot(poses[:, 0] - centre[0], poses[:, 1] - centre[1]) >= r))


def test_zigzag_in_free_space_becomes_the_straight_line():
    path, verts = polyline((0, 0), (0.5, 0.7), (1.2, -0.4), (2.5, 0.9), (3.1, -0.6), (4, 0))
    s = simplify_path(path, None, straight, lambda p: True, vertices=verts)
    assert s.length == pytest.approx(4.0, abs=1e-9) and s.raw_length == pytest.approx(path_length(path), abs=1e-12)
    np.testing.assert_array_equal(s.path[0], path[0])
    np.testing.assert_array_equal(s.path[-1], path[-1])
    assert s.vertices.tolist() == [0, s.path.shape[0] - 1] and s.cusps == s.raw_cusps == 0


def test_shortcuts_around_a_disc_approach_the_shortest_path_and_never_enter_it():
    """From (0, 0) to (4, 0) around a disc of radius 0.5 at (2, 0): the shortest path is two tangents
    and an arc, 2 sqrt(d^2 - r^2) + r (pi - 2 acos(r / d)) with d = 2; polylines stay above it."""
    r, d = 0.5, 2.0
    shortest = 2 * np.sqrt(d * d - r * r) + r * (np.pi - 2 * np.arccos(r / d))
    path, verts = polyline((0, 0), (0, 1), (4, 1), (4, 0))
    free = outside_disc((2.0, 0.0), r)
    s = simplify_path(path, None, straight, free, vertices=verts, seed=3)
    dense = densify_path(s.path, 0.001)  # an independent check between the samples too
    assert np.min(np.hypot(dense[:, 0] - 2.0, dense[:, 1])) >= r - 1e-3  # chord sag of a 1 cm step
    assert shortest - 1e-9 <= s.length <= 1.03 * shortest < s.raw_length


def test_a_simplification_that_would_collide_is_never_applied():
    path, verts = polyline((0, 0), (0, 1), (4, 1), (4, 0))
    s = simplify_path(path, None, straight, lambda p: False, vertices=verts)
    np.testing.assert_array_equal(s.path, path)
    assert s.shortcuts == 0 and s.length == s.raw_length


def test_same_seed_same_result():
    path, verts = polyline((0, 0), (0, 1), (4, 1), (4, 0))
    free = outside_disc((2.0, 0.0), 0.5)
    a, b = (simplify_path(path, None, straight, free, vertices=verts, seed=7) for _ in range(2))
    assert a.path.tobytes() == b.path.tobytes() and a.vertices.tolist() == b.vertices.tolist()


def test_a_cost_that_penalises_shortcuts_is_never_made_worse():
    """Cost = length + 10 x the length inside the band |x - 2| < 1, y < 0.5: the straight line is
    shorter but costlier (24 against 6), so the path may not cut through the band."""

    def cost(poses: np.ndarray, dirs: np.ndarray) -> float:
        mid = 0.5 * (poses[1:] + poses[:-1])
        inside = (np.abs(mid[:, 0] - 2.0) < 1.0) & (mid[:, 1] < 0.5)
        steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
        return float(steps.sum() + 10.0 * steps[inside].sum())

    path, verts = polyline((0, 0), (0, 1), (4, 1), (4, 0))
    s = simplify_path(path, None, straight, lambda p: True, cost=cost, vertices=verts, seed=1)
    own = sum(cost(s.path[a : b + 1], s.directions[a : b + 1]) for a, b in itertools.pairwise(s.vertices))
    assert s.raw_cost == pytest.approx(6.0, abs=1e-9)
    assert s.cost == pytest.approx(own, abs=1e-9) and own < s.raw_cost
    assert s.length < s.raw_length


def test_a_retraced_stretch_is_cut_even_when_no_shortcut_is_free():
    """Forward to x = 1, backwards to x = 0.5 over the same poses, forward to x = 2: the back-and-forth
    goes (it repeats poses), and with it both cusps, though the checker refuses every new motion."""
    x = np.concatenate([np.arange(0, 101), np.arange(99, 49, -1), np.arange(51, 201)]) * STEP
    path = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    dirs = np.sign(np.concatenate([[1.0], np.diff(x)]))
    s = simplify_path(path, dirs, straight, lambda p: False)
    assert s.raw_cusps == 2 and s.cusps == 0
    assert s.length == pytest.approx(2.0, abs=1e-9) and s.raw_length == pytest.approx(3.0, abs=1e-9)


def test_a_shortcut_merges_cusps_with_reeds_shepp_steering():
    problem = PlanProblem.from_scenario(load_scenario("open"))
    checker = make_checker(problem, "footprint", 0.0)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    q = [np.array(v) for v in ([0, 0, 0], [1, 0, 0], [0.5, 0.3, 0], [2, 0.3, 0])]
    forward, back, on = local.steer(q[0], q[1]), local.steer(q[1], q[2]), local.steer(q[2], q[3])
    path = np.vstack([forward[0], back[0][1:], on[0][1:]])
    dirs = np.concatenate([forward[1], back[1][1:], on[1][1:]])
    s = simplify_path(path, dirs, local.steer, checker.path_free, distance=local.curves.lengths)
    assert s.raw_cusps >= 2 and s.cusps == 0
    direct = path_length(local.steer(q[0], q[3])[0])
    assert s.length == pytest.approx(direct, abs=1e-9) and s.length < s.raw_length


def test_count_cusps():
    assert count_cusps(np.array([1, 1, -1, -1, 1.0])) == 2
    assert count_cusps(np.array([-1, 1, 1.0])) == 0  # directions[0] repeats the first step's
    assert count_cusps(None) == 0


def test_bad_config_and_input_are_named():
    with pytest.raises(ConfigError, match="range_ratio"):
        SimplifyConfig(range_ratio=0.0)
    with pytest.raises(ValueError, match="directions"):
        simplify_path(np.zeros((3, 3)), np.ones(2), straight, lambda p: True)


# --- the planners ------------------------------------------------------------------------------------
PROBLEMS = [("random", 0), ("random", 1), ("random", 2), ("parking_lot", 0), ("nav_map1", 0)]


def _problem(name: str, seed: int) -> PlanProblem:
    scenario = random_scenario("turtlebot3", seed) if name == "random" else load_scenario(name)
    return PlanProblem.from_scenario(scenario, seed=seed, time_limit=20.0)


@pytest.mark.parametrize("planner", ["rrt", "birrt", "rrt-star"])
@pytest.mark.parametrize(("name", "seed"), PROBLEMS)
def test_simplified_tree_plans_are_free_shorter_and_keep_their_ends(planner, name, seed):
    problem = _problem(name, seed)
    options = {"steering": "reeds_shepp"} if name == "nav_map1" and planner == "birrt" else {}
    res = make_planner(planner, **options).plan(problem)
    assert res.status is PlanStatus.SUCCESS, res.reason
    raw = res.raw_path
    assert raw is not None
    np.testing.assert_array_equal(res.path[0], raw[0])
    np.testing.assert_array_equal(res.path[-1], raw[-1])
    exact = CollisionChecker(problem.world, problem.robot, shape="footprint")
    assert np.all(exact.poses_free(exact.densify(res.path)))  # the exact checker, densified again
    assert res.length() <= path_length(raw) + 1e-9
    assert res.stats["cusps"] == count_cusps(res.directions) <= res.stats["raw_cusps"]
    assert res.stats["length_m"] == pytest.approx(res.length(), abs=1e-9)
    plain = make_planner(planner, simplify=False, **options).plan(problem)
    np.testing.assert_array_equal(plain.path, raw)  # the raw path is the search's own
    assert plain.raw_path is None and "simplify_time_s" not in plain.stats


@pytest.mark.parametrize("seed", range(3))
def test_simplified_c_rrt_star_keeps_its_clearance_and_never_costs_more(seed):
    scenario = load_scenario("edumip_map") if seed == 0 else random_scenario("edumip", seed)
    problem = PlanProblem.from_scenario(scenario, robot=load_robot("edumip"), seed=seed, time_limit=60.0)
    res = make_planner("c-rrt-star").plan(problem)
    assert res.status is PlanStatus.SUCCESS, res.reason
    st = res.stats
    assert st["raw_cost"] == pytest.approx(st["cost"], rel=1e-9)  # the simplifier prices the path as the planner
    assert st["simplified_cost"] <= st["cost"]
    dense = densify_path(res.path, 0.001)
    assert np.min(problem.world.signed_distance(dense[:, :2])) >= 0.40 - 1e-9
    # independent cost: straight pieces between the places where the robot turns in place (a vertex
    # without a turn, between two collinear pieces, only adds a clearance term to the reported cost)
    p = res.path
    turns = np.flatnonzero(np.all(p[1:, :2] == p[:-1, :2], axis=1) & (p[1:, 2] != p[:-1, 2]))
    pts = np.vstack([p[:1, :2], p[turns, :2], p[-1:, :2]])
    pts = pts[np.concatenate([[True], np.any(np.diff(pts, axis=0) != 0, axis=1)])]
    lengths = np.hypot(*np.diff(pts, axis=0).T)
    d = np.array([np.min(problem.world.signed_distance(densify_path(np.c_[[a, b], [0, 0]], 0.0005)[:, :2]))
                  for a, b in itertools.pairwise(pts)])  # fmt: skip
    own = np.sum(lengths + 0.1 * np.exp(-5.0 * d**2))
    lipschitz = 0.1 * np.sqrt(10.0) * np.exp(-0.5)  # |d/dd rho exp(-sigma d^2)| at most, per piece
    assert own <= st["simplified_cost"] + lipschitz * 0.0105 * len(lengths)
    assert res.length() == pytest.approx(np.sum(lengths), abs=1e-9)
    assert res.length() <= path_length(res.raw_path)


def test_invalid_start_and_goal_keep_their_status_with_simplification():
    problem = _problem("random", 0)
    bad_start = PlanProblem(**{**problem.__dict__, "start": type(problem.start)(-3.0, -3.0, 0.0)})
    bad_goal = PlanProblem(**{**problem.__dict__, "goal": type(problem.goal)(3.0, 3.0, 0.0)})
    for name in ("rrt", "birrt", "rrt-star"):
        assert make_planner(name).plan(bad_start).status is PlanStatus.INVALID_START
        assert make_planner(name).plan(bad_goal).status is PlanStatus.INVALID_GOAL
    edumip = PlanProblem(**{**bad_goal.__dict__, "robot": load_robot("edumip")})
    assert make_planner("c-rrt-star").plan(edumip).status is PlanStatus.INVALID_GOAL


# --- anytime rrt-star ---------------------------------------------------------------------------------
def test_rrt_star_reports_its_first_path_and_stops_when_the_cost_stalls():
    problem = _problem("random", 1)
    res = make_planner("rrt-star", simplify=False).plan(problem)
    st = res.stats
    assert st["stopped_by"] == "converged" and st["iterations"] < 5000
    history = st["cost_history"]
    assert st["first_solution_iteration"] == history[0][0] and st["first_length_m"] == history[0][2]
    assert st["first_solution_s"] == history[0][1] > 0 and st["first_length_m"] >= st["cost_m"]
    # the rule at the stop: the best cost at half the run improved by less than 0.1 % since
    it = st["iterations"]
    then = [c for i, _, c in history if i <= 0.5 * it][-1]
    assert then - st["cost_m"] < 1e-3 * then
    full = make_planner("rrt-star", simplify=False, improvement_tol=0.0, max_iterations=1500).plan(problem)
    assert full.stats["stopped_by"] == "budget" and full.stats["iterations"] == 1500
    again = make_planner("rrt-star", simplify=False).plan(problem)
    assert again.path.tobytes() == res.path.tobytes()


@pytest.mark.parametrize("region_goal", [False, True])
def test_rrt_star_stops_at_once_when_the_start_sees_the_goal(region_goal: bool) -> None:
    """The free-space shortest curve to an aimed goal pose is the shortest path there is: once in hand,
    nothing is left to improve (the search used to run its 500 minimum iterations, then stall out)."""
    from planning.planners.sampling.tree import goal_region_poses

    for seed, goal in enumerate((Pose2D(3.0, 1.0, 0.5), Pose2D(-3.0, 2.0, 3.0), Pose2D(-2.5, -3.0, -2.0))):
        problem = PlanProblem(World((-5, 5, -5, 5), ()), load_robot("turtlebot3"), Pose2D(-3, -3, 0), goal, seed=seed)
        planner = make_planner("rrt-star", simplify=False, region_goal=region_goal)
        res = planner.plan(problem)
        aims = goal_region_poses(problem) if region_goal else goal.as_array()[None]
        curves = LocalPlanner("reeds_shepp", problem.robot, make_checker(problem, "footprint", 0.0)).curves
        shortest = curves.lengths(problem.start.as_array(), aims).min()
        assert res.success and res.stats["stopped_by"] == "shortest curve" and res.stats["iterations"] == 1
        assert res.stats["cost_m"] == pytest.approx(shortest, abs=1e-9)


def test_rrt_star_rejects_a_bad_stall_option():
    with pytest.raises(ConfigError, match="stall_clock"):
        make_planner("rrt-star", stall_clock="minutes")
    with pytest.raises(ConfigError, match="improvement_tol"):
        make_planner("rrt-star", improvement_tol=-0.1)


# --- the benchmark -------------------------------------------------------------------------------------
def test_bench_rows_on_a_free_problem_are_the_exact_shortest_curve():
    """simple_motion is free between start and goal: every planner's simplified path is the one
    Reeds–Shepp curve between them (length by the closed form), so every ratio is 1."""
    from planning.curves.reeds_shepp import reeds_shepp_length
    from planning.planners.sampling.steering import default_turning_radius
    from sim.tools.bench.simplify import TrajectoryRow, measure_plans

    sc = load_scenario("simple_motion")
    robot = load_robot(sc.robot)
    exact = float(reeds_shepp_length(sc.start.as_array(), sc.goal.as_array(), default_turning_radius(robot))[0])
    rows = measure_plans(sc)
    assert [r.planner for r in rows] == ["birrt", "rrt"]
    for r in rows:
        assert r.length == pytest.approx(exact, rel=1e-3) and r.ref_length == pytest.approx(exact, rel=1e-3)
        assert r.missed == [] and r.cusps == r.ref_cusps == 0
    row = TrajectoryRow("s", "turtlebot3", "sinusoidal", 3.0, 9.0, 1.0, 5.0)
    assert row.ratio == 3.0 and not row.targeted and not row.missed
    assert TrajectoryRow("s", "turtlebot3", "birrt", 1.3, 9.0, 1.0, 5.0).missed


def test_a_stretch_driven_the_other_way_round_keeps_its_ground_and_flips_heading_and_direction():
    """The turned-around candidate: steered to pose m1 turned by pi, poses m1..m2 over the same
    ground with headings turned by pi and directions reversed, steered from pose m2 turned to b."""
    from planning.planners.simplify import _Work

    problem = PlanProblem.from_scenario(load_scenario("open"))
    checker = make_checker(problem, "footprint", 0.0)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    q = [np.array(v) for v in ([0, 0, 0], [1, 0, 0], [0.4, 0.2, 0.3], [2, 0.5, 0.2])]
    parts = [local.steer(u, v) for u, v in itertools.pairwise(q)]
    path = np.vstack([parts[0][0], *(m[0][1:] for m in parts[1:])])
    dirs = np.concatenate([parts[0][1], *(m[1][1:] for m in parts[1:])])
    w = _Work(path, dirs, [0, path.shape[0] - 1], (local.steer, checker.path_free, length_cost))
    n0 = parts[0][0].shape[0]
    m1, m2 = n0 + 5, n0 + parts[1][0].shape[0] - 8
    motion = w._motion(path[2], path[-3], (m1, m2))
    assert motion is not None
    poses, mdirs = motion
    first = local.steer(path[2], path[m1] + [0, 0, np.pi])[0]
    k = first.shape[0] - 1
    middle = poses[k : k + m2 - m1 + 1]
    np.testing.assert_array_equal(middle[:, :2], path[m1 : m2 + 1, :2])
    np.testing.assert_allclose(middle[:, 2], path[m1 : m2 + 1, 2] + np.pi, atol=1e-12)
    np.testing.assert_array_equal(mdirs[k + 1 : k + m2 - m1 + 1], -dirs[m1 + 1 : m2 + 1])
    np.testing.assert_array_equal(poses[0], path[2])
    np.testing.assert_array_equal(poses[-1], path[-3])
    assert np.max(np.hypot(*np.diff(poses[:, :2], axis=0).T)) <= 0.01 + 1e-9  # dense for the checker


# --- other ways round: the 2-D route ------------------------------------------------------------------
DISC_C, DISC_R = (2.0, 0.2), 0.5  # a disc a little above the line from (0, 0) to (4, 0): under it is shorter


def round_disc(side: float) -> float:
    """Shortest length from (0, 0) to (4, 0) past the disc on ``side`` (+1 over, -1 under): two tangents
    and the arc between their touching points (the ends are D from the centre, at beta off its level)."""
    dist, beta = np.hypot(2.0, DISC_C[1]), np.arctan2(DISC_C[1], 2.0)
    return 2.0 * np.sqrt(dist**2 - DISC_R**2) + DISC_R * (np.pi + 2.0 * side * beta - 2.0 * np.arccos(DISC_R / dist))


def _over_the_disc() -> tuple[np.ndarray, list[int], np.ndarray]:
    """A path the long way, over the disc, its corners, and waypoints along the 2-D route (under it)."""
    from planning.core.world import Circle, World
    from planning.planners import geodesic

    path, verts = polyline((0, 0), (0.5, 1.2), (3.5, 1.2), (4, 0))
    world = World((-1.0, 5.0, -2.0, 2.0), (Circle(DISC_C, DISC_R),))
    route = geodesic.route(world, path[0], path[-1], 0.01)
    assert route is not None
    return path, verts, geodesic.polyline_waypoints(route)


def test_shortcuts_alone_keep_the_way_round_and_a_route_changes_it():
    """Shortcuts keep the input's way over the disc (never below the shortest length over it); with the
    route's waypoints the result goes under it, within 3 % of the shortest length there."""
    path, verts, route = _over_the_disc()
    free = outside_disc(DISC_C, DISC_R)
    alone = simplify_path(path, None, straight, free, vertices=verts, seed=2)
    assert alone.route == -1 and alone.length >= round_disc(+1) - 1e-9
    s = simplify_path(path, None, straight, free, vertices=verts, routes=[route], seed=2)
    assert s.route == 0 and round_disc(-1) - 1e-9 <= s.length <= 1.03 * round_disc(-1) < round_disc(+1)
    dense = densify_path(s.path, 0.001)
    assert np.min(np.hypot(dense[:, 0] - DISC_C[0], dense[:, 1] - DISC_C[1])) >= DISC_R - 1e-3
    np.testing.assert_array_equal(s.path[0], path[0])
    np.testing.assert_array_equal(s.path[-1], path[-1])
    assert s.cost == pytest.approx(path_length(s.path), abs=1e-9) and s.cusps == 0


def test_a_route_that_collides_or_adds_cusps_is_not_taken():
    path, verts, route = _over_the_disc()
    free = outside_disc(DISC_C, DISC_R)
    alone = simplify_path(path, None, straight, free, vertices=verts, seed=2)
    through = np.array([[2.0, 0.0, 0.0]])  # straight through the disc
    s = simplify_path(path, None, straight, free, vertices=verts, routes=[through], seed=2)
    assert s.route == -1 and s.path.tobytes() == alone.path.tobytes()

    def flagged(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Straight, but a motion that ends below y = -0.01 counts as driven backwards."""
        poses, dirs = straight(a, b)
        return poses, (-dirs if b[1] < -0.01 else dirs)

    s = simplify_path(path, None, flagged, free, vertices=verts, routes=[route], seed=2)
    assert s.route == -1 and s.cusps == 0 and s.length >= round_disc(+1) - 1e-9  # shorter, but with cusps


def test_best_gains_are_those_of_measuring_every_candidate():
    from planning.planners.simplify import _best_gains

    rng = np.random.default_rng(5)
    for _ in range(200):
        n, k = int(rng.integers(1, 60)), int(rng.integers(1, 5))
        qa, qs = rng.uniform(-2, 2, 3), rng.uniform(-2, 2, (n, 3))
        line = np.hypot(*(qs[:, :2] - qa[:2]).T)
        extra = rng.choice([0.0, 0.3], n) * rng.random(n)  # the distance: the line plus something, or the line
        table = {q.tobytes(): e for q, e in zip(qs, extra, strict=True)}

        def distance(q0: np.ndarray, q1: np.ndarray, table=table) -> np.ndarray:
            rows = np.atleast_2d(q1)
            return np.hypot(*(rows[:, :2] - q0[:2]).T) + np.array([table[r.tobytes()] for r in rows])

        saved = line + rng.choice([0.0, 0.5, 1.0], n)  # ties among the gains too
        every = distance(qa, qs)
        full = saved - every
        some, asked = _best_gains(saved, line, qa, qs, distance, k)
        top = np.argsort(-full, kind="stable")[:k]
        np.testing.assert_array_equal(np.argsort(-some, kind="stable")[:k], top)
        np.testing.assert_array_equal(some[top], full[top])
        # the distances it reports are those it asked about (the same numbers), inf for the others
        np.testing.assert_array_equal(asked[np.isfinite(some)], every[np.isfinite(some)])
        assert np.all(np.isinf(asked[~np.isfinite(some)]))


def _box_problem(robot: str, low: float, high: float) -> PlanProblem:
    """From (-2, 0) to (2, 0) past a box x in [-0.5, 0.5], y in [low, high] (low < 0 < high): the way
    over it crosses x = 0 above ``high``, so any path that way is longer than ``over_box(high)``."""
    from planning.core.geometry import Pose2D
    from planning.core.world import Box, World

    world = World((-3.0, 3.0, -3.0, 3.0), (Box((0.0, 0.5 * (low + high)), (1.0, high - low)),))
    return PlanProblem(world, load_robot(robot), Pose2D(-2.0, 0.0, 0.0), Pose2D(2.0, 0.0, 0.0))


def over_box(high: float) -> float:
    """The straight-line bound of a path from (-2, 0) to (2, 0) through a point of x = 0 above ``high``."""
    return float(2.0 * np.hypot(2.0, high))


def _over_the_box() -> tuple[PlanProblem, FastChecker, LocalPlanner, np.ndarray, np.ndarray]:
    """A search path over the box (Reeds–Shepp curves through waypoints above it): its problem, checker, local
    planner, poses and directions."""
    problem = _box_problem("turtlebot3", -0.7, 2.3)
    checker = make_checker(problem, "footprint", 0.01)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    q = [np.array(v) for v in ([-2, 0, 0], [-1.2, 2.6, 0.6], [0, 2.65, 0], [1.2, 2.6, -0.6], [2, 0, 0])]
    parts = [local.steer(a, b) for a, b in itertools.pairwise(q)]
    path = np.vstack([parts[0][0], *(m[0][1:] for m in parts[1:])])
    dirs = np.concatenate([parts[0][1], *(m[1][1:] for m in parts[1:])])
    return problem, checker, local, path, dirs


def test_a_tree_path_the_long_way_round_a_box_is_simplified_the_short_way():
    """A search path over the box (Reeds–Shepp curves through waypoints above it): the simplified
    path goes under it, shorter than any path over it, collision-free by the exact checker."""
    from planning.planners.base import PlanResult
    from planning.planners.sampling.rrt import simplified

    problem, checker, local, path, dirs = _over_the_box()
    assert checker.path_free(path) and path_length(path) > over_box(2.3)
    raw = PlanResult(PlanStatus.SUCCESS, "rrt", path=path, directions=dirs, stats={})
    res = simplified(raw, local, 0)
    assert res.stats["simplify_route"] == 0 and res.length() < over_box(2.3)
    assert res.stats["cusps"] == count_cusps(res.directions) <= count_cusps(dirs)
    exact = CollisionChecker(problem.world, problem.robot, shape="footprint", clearance=0.01)
    assert np.all(exact.poses_free(exact.densify(res.path)))
    np.testing.assert_array_equal(res.path[0], path[0])
    np.testing.assert_array_equal(res.path[-1], path[-1])


def _steered(local: LocalPlanner, *poses: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """Dense poses and directions of the planner's curves through ``poses`` in turn."""
    q = [np.array(v, dtype=float) for v in poses]
    parts = [local.steer(a, b) for a, b in itertools.pairwise(q)]
    return np.vstack([parts[0][0], *(m[0][1:] for m in parts[1:])]), np.concatenate(
        [parts[0][1], *(m[1][1:] for m in parts[1:])]
    )


def _wander(local: LocalPlanner, base: np.ndarray, dirs: np.ndarray, every: int) -> tuple[np.ndarray, np.ndarray]:
    """``base`` with an excursion after every ``every``-th pose, as a motion-primitive tree drives
    them: a curve out to a random pose nearby and back over the same poses (reversing), when it is
    collision-free."""
    rng = np.random.default_rng(7)
    poses, out_dirs = [base[:1]], [dirs[:1]]
    for k in range(1, base.shape[0]):
        poses.append(base[k : k + 1])
        out_dirs.append(dirs[k : k + 1])
        if k % every or k == base.shape[0] - 1:
            continue
        target = base[k] + np.array([*rng.uniform(-0.8, 0.8, 2), rng.uniform(-1.5, 1.5)])
        m, md = local.steer(base[k], target)
        if local.checker.path_free(m):
            m = m.copy()
            m[0] = base[k]
            poses += [m[1:], m[-2::-1]]  # out, then back over the same poses to base[k]
            out_dirs += [md[1:], -md[:0:-1]]  # the step into pose j on the way back reverses the step out of it
    return np.vstack(poses), np.concatenate(out_dirs)


def test_a_long_looping_tree_path_costs_only_its_loop_cutting():
    """A raw path like birrt's worst (hundreds of metres of excursions driven out and back, hundreds of
    cusps, tens of thousands of poses) around a path over the box: its loops cut leave exactly that
    path, and the simplification does the same work (the same shortcuts steered) and gives the same
    result bit for bit as on that path alone: under the box, collision-free, ends kept."""
    from planning.planners.sampling.rrt import curve_routes
    from planning.trajectory.smoothing import remove_loops

    problem = _box_problem("turtlebot3", -0.7, 2.3)
    checker = make_checker(problem, "footprint", 0.01)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    over = ([-2.4, 1.5, 1.6], [-1.2, 2.6, 0.3], [0, 2.65, 0], [1.2, 2.6, -0.3], [2.4, 1.5, -1.6])
    base, base_dirs = _steered(local, [-2, 0, 0], *over, [2, 0, 0])
    path, dirs = _wander(local, base, base_dirs, 4)
    assert checker.path_free(path) and path.shape[0] > 20 * base.shape[0]
    assert path_length(path) > 20 * path_length(base) and count_cusps(dirs) > 100 * max(1, count_cusps(base_dirs))
    cut, cut_dirs = remove_loops(path, dirs)
    np.testing.assert_array_equal(cut, base)
    np.testing.assert_array_equal(cut_dirs, base_dirs)

    def simplify(p: np.ndarray, d: np.ndarray):
        routes = curve_routes(local, p[0], p[-1])
        return simplify_path(p, d, local.steer, checker.path_free, distance=local.curves.lengths, routes=routes)

    s, alone = simplify(path, dirs), simplify(base, base_dirs)
    assert s.attempts == alone.attempts and s.shortcuts == alone.shortcuts and s.route == alone.route == 0
    np.testing.assert_array_equal(s.path, alone.path)
    np.testing.assert_array_equal(s.directions, alone.directions)
    assert (s.raw_length, s.raw_cusps) == (path_length(path), count_cusps(dirs))
    assert s.length < over_box(2.3) and s.cusps <= count_cusps(base_dirs)
    exact = CollisionChecker(problem.world, problem.robot, shape="footprint", clearance=0.01)
    assert np.all(exact.poses_free(exact.densify(s.path)))
    np.testing.assert_array_equal(s.path[[0, -1]], path[[0, -1]])


def test_a_c_rrt_star_path_the_long_way_round_a_box_is_simplified_the_short_way():
    """C-RRT*'s tree path over the box: simplified along the route under it, 40 cm from everything,
    at a lower cost (its own: length plus a clearance term per segment) than any path over the box."""
    from planning.planners.base import PlanResult
    from planning.planners.sampling.crrt_star import CRRTStarConfig, _Search

    problem = _box_problem("edumip", -0.9, 1.9)
    search = _Search(CRRTStarConfig(), problem, 0.40)
    pts = np.array([[-2.0, 0.0], [-1.0, 2.45], [1.0, 2.45], [2.0, 0.0]])
    path = search.poses(pts, 0.0)
    assert search.keeps_clearance(path)
    raw = PlanResult(PlanStatus.SUCCESS, "c-rrt-star", path=path, directions=np.ones(len(path)), stats={})
    res = search.simplified(raw, pts)
    st = res.stats
    assert st["simplify_route"] == 0 and st["simplified_cost"] < st["raw_cost"]
    assert res.length() <= st["simplified_cost"] < over_box(1.9)  # the cost is at least the length
    dense = densify_path(res.path, 0.001)
    assert np.min(problem.world.signed_distance(dense[:, :2])) >= 0.40 - 1e-9
    np.testing.assert_array_equal(res.path[-1], path[-1])


@pytest.mark.parametrize("seed", [31, 32, 33, 34])
def test_on_worlds_no_test_tuned_on_every_plan_keeps_the_guarantees(seed):
    """birrt and rrt on random worlds the benchmark does not use: ends kept, collision-free by the exact
    checker, never longer and never more cusps than the search's path, whichever way the result goes."""
    problem = PlanProblem.from_scenario(random_scenario("turtlebot3", seed), seed=seed, time_limit=20.0)
    exact = CollisionChecker(problem.world, problem.robot, shape="footprint")
    for planner in ("birrt", "rrt"):
        res = make_planner(planner).plan(problem)
        assert res.status is PlanStatus.SUCCESS, res.reason
        raw = res.raw_path
        assert raw is not None and res.stats["simplify_route"] in (-1, 0)
        np.testing.assert_array_equal(res.path[0], raw[0])
        np.testing.assert_array_equal(res.path[-1], raw[-1])
        assert np.all(exact.poses_free(exact.densify(res.path)))
        assert res.length() <= path_length(raw) + 1e-9
        assert res.stats["cusps"] == count_cusps(res.directions) <= res.stats["raw_cusps"]


def test_a_directed_length_weights_the_backwards_metres_and_refuses_a_weight_below_one() -> None:
    from planning.planners.simplify import DirectedLength

    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0], [1.0, 2.0, 1.0]])
    dirs = np.array([1.0, 1.0, -1.0, -1.0])  # the 2 m step arrives backwards; the turn in place costs nothing
    assert length_cost(poses, dirs) == pytest.approx(3.0)
    assert DirectedLength(2.0)(poses, dirs) == pytest.approx(1.0 + 2.0 * 2.0)
    for bad in (0.5, float("nan"), True):
        with pytest.raises(ValueError, match="reverse_weight must be a finite number >= 1"):
            DirectedLength(bad)  # type: ignore[arg-type]


def test_a_deadline_stops_the_simplification_with_the_path_as_far_as_it_got(monkeypatch):
    """Simplification is anytime: every shortcut kept leaves a whole path. With a checker of 5 ms a motion
    and a deadline 40 ms away, it checks no motion once it has seen the deadline pass, so one motion ends
    past it at most, the path free, its ends kept and no costlier, and says so; a deadline already passed
    returns the input; a routes callable that runs out of time leaves the path simplified as far as it got,
    with no route."""
    from planning.clock import PlanClock
    from planning.collision.field import FieldTimeout

    path, verts, route = _over_the_disc()
    free = outside_disc(DISC_C, DISC_R)
    full = simplify_path(path, None, straight, free, vertices=verts, routes=[route], seed=2)
    assert not full.timed_out and full.stats()["simplify_time_limit_reached"] is False

    looked: list[tuple[float, bool]] = []  # (when, expired) of each look at the deadline
    expired = PlanClock.expired

    def watched(self: PlanClock) -> bool:
        out = expired(self)
        looked.append((time.perf_counter(), out))
        return out

    monkeypatch.setattr(PlanClock, "expired", watched)
    begun: list[tuple[float, bool]] = []  # the last look before each motion

    def slow(poses: np.ndarray) -> bool:
        begun.append(looked[-1])
        time.sleep(0.005)
        return free(poses)

    t0 = time.perf_counter()
    cut = simplify_path(path, None, straight, slow, vertices=verts, routes=[route], seed=2, deadline=t0 + 0.04)
    # Every motion follows a look that found time left, taken before the deadline (where the process is held
    # back between that look and the motion is the machine's, not the simplification's: timing the motion's
    # start instead failed by 20 us under load), and the last look found it passed
    assert begun and all(not gone and when <= t0 + 0.04 for when, gone in begun)
    assert looked[-1][1] and looked[-1][0] > t0 + 0.04
    assert time.perf_counter() - t0 < 0.04 + 1.0
    assert cut.timed_out and cut.stats()["simplify_time_limit_reached"] is True
    assert cut.attempts < full.attempts and cut.cost <= cut.raw_cost
    dense = densify_path(cut.path, 0.001)
    assert np.min(np.hypot(dense[:, 0] - DISC_C[0], dense[:, 1] - DISC_C[1])) >= DISC_R - 1e-3
    np.testing.assert_array_equal(cut.path[[0, -1]], path[[0, -1]])
    late = simplify_path(path, None, straight, free, vertices=verts, routes=[route], deadline=time.perf_counter() - 1)
    assert late.timed_out and late.shortcuts == 0 and late.path.tobytes() == path.tobytes()

    def out_of_time() -> list[np.ndarray]:
        raise FieldTimeout(0.1, 1000, 1, what=("the 2-D route", "cells"))

    no_route = simplify_path(path, None, straight, free, vertices=verts, routes=out_of_time, seed=2)
    alone = simplify_path(path, None, straight, free, vertices=verts, seed=2)
    assert no_route.timed_out and no_route.route == -1 and no_route.path.tobytes() == alone.path.tobytes()


def test_a_tree_plan_is_simplified_within_what_is_left_of_its_time_limit():
    """rrt, birrt, rrt-star and hybrid-a-star simplify through ``rrt.simplified`` with the plan's clock: a
    limit already spent leaves the search's path as it was (and says so), one with time left simplifies
    it the short way round as before."""
    from planning.clock import PlanClock
    from planning.planners.base import PlanResult
    from planning.planners.sampling.rrt import simplified

    _, _, local, path, dirs = _over_the_box()
    raw = PlanResult(PlanStatus.SUCCESS, "rrt", path=path, directions=dirs, stats={})
    spent = PlanClock(1e-9)
    time.sleep(0.001)
    res = simplified(raw, local, 0, clock=spent)
    assert res.stats["simplify_time_limit_reached"] is True and res.path.tobytes() == path.tobytes()
    res = simplified(raw, local, 0, clock=PlanClock(60.0))
    assert res.stats["simplify_time_limit_reached"] is False
    assert res.stats["simplify_route"] == 0 and res.length() < over_box(2.3)
