"""Path simplification: analytic cases with straight steering, and every sampling planner's simplified
plans (collision-free, same ends, never longer, never more cusps, C-RRT*'s cost never worse)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from planning.collision.exact import CollisionChecker
from planning.core.geometry import densify_path, path_length
from planning.core.robot import load_robot
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
    w = _Work(path, dirs, [0, path.shape[0] - 1], local.steer, checker.path_free, length_cost)
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
