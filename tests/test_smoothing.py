"""Smoothing: the constrained fit, path splitting, and the trajectory of hand-made paths, checked
against the definitions (finite differences, an independent footprint test)."""

import itertools

import numpy as np
import pytest

from planning.collision.exact import CollisionChecker
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.core.world import Circle, World
from planning.planners.base import PlanProblem, PlanResult, PlanStatus
from planning.planners.registry import make_planner
from planning.scenario import load_scenario
from planning.trajectory.from_plan import TrajectoryResult, TrajectoryStatus, make_trajectory
from planning.trajectory.smoothing import SmoothStatus, fit_piecewise, remove_loops, smooth_drive, split_path

TB3 = load_robot("turtlebot3")
OPEN = World((-3.0, 3.0, -3.0, 3.0), ())


def polyline(points: list[list[float]]) -> np.ndarray:
    """Poses along a polyline, heading along each edge (the last repeats)."""
    p = np.array(points, dtype=float)
    d = np.diff(p, axis=0)
    th = np.arctan2(d[:, 1], d[:, 0])
    return np.column_stack([p, np.append(th, th[-1])])


def test_fit_recovers_a_quintic_exactly_and_meets_every_constraint() -> None:
    u = np.linspace(0.0, 1.0, 41)
    cx, cy = [0.1, 1.0, 0.0, 0.3, -0.2, 0.05], [0.0, 0.2, 0.5, -0.1, 0.0, 0.01]
    pts = np.column_stack([np.polyval(cx[::-1], u), np.polyval(cy[::-1], u)])
    d1 = lambda c, x: np.polyval(np.polyder(c[::-1]), x)
    poly = fit_piecewise(pts, np.linspace(0, 1, 4), param=u, end_curvature_zero=False, penalty=0.0,
                         start_tangent=[d1(cx, 0.0), d1(cy, 0.0)], end_tangent=[d1(cx, 1.0), d1(cy, 1.0)])  # fmt: skip
    assert np.abs(poly(u) - pts).max() < 1e-9


@pytest.mark.parametrize("penalty", [1e-6, 1e-3])
def test_fit_is_c2_at_breaks_by_finite_differences(penalty: float) -> None:
    rng = np.random.default_rng(3)
    u = np.linspace(0.0, 2.0, 120)
    pts = np.column_stack([u, np.sign(np.sin(3 * u)) * 0.1]) + rng.normal(0, 0.01, (120, 2))
    breaks = np.linspace(0.0, 2.0, 7)
    poly = fit_piecewise(pts, breaks, param=u, start_tangent=[1, 0], end_tangent=[1, 0], penalty=penalty)
    h = 1e-4
    for b in breaks[1:-1]:
        left = poly(np.array([b - 2 * h, b - h, b]))
        right = poly(np.array([b, b + h, b + 2 * h]))
        assert np.allclose(left[2], right[0], atol=1e-12)  # C0
        d_left = (3 * left[2] - 4 * left[1] + left[0]) / (2 * h)  # one-sided second-order differences
        d_right = (-3 * right[0] + 4 * right[1] - right[2]) / (2 * h)
        assert np.allclose(d_left, d_right, atol=1e-5)  # C1
        g = 1e-5  # second differences: O(g) truncation, O(1e-16 / g^2) rounding
        fl, fr = poly(np.array([b - 2 * g, b - g, b])), poly(np.array([b, b + g, b + 2 * g]))
        dd_left = (fl[2] - 2 * fl[1] + fl[0]) / g**2
        dd_right = (fr[2] - 2 * fr[1] + fr[0]) / g**2
        scale = max(1.0, float(np.abs(dd_left).max()))
        assert np.allclose(dd_left, dd_right, atol=0.01 * scale)  # C2 (first-order differences)
    # fix points and end derivatives
    assert np.allclose(poly(np.array([0.0, 2.0])), pts[[0, -1]], atol=1e-10)
    assert np.allclose(poly(np.array([0.0, 2.0]), 1), [[1, 0], [1, 0]], atol=1e-9)
    assert np.allclose(poly(np.array([0.0, 2.0]), 2), 0.0, atol=1e-8)


def test_split_finds_cusps_rotations_and_sharp_corners() -> None:
    fwd = np.column_stack([np.linspace(0, 1, 11), np.zeros(11), np.zeros(11)])
    back = np.column_stack([np.linspace(1, 0.5, 6)[1:], np.zeros(5), np.zeros(5)])
    segs = split_path(np.vstack([fwd, back]))
    assert [(s.kind, s.direction) for s in segs] == [("drive", 1), ("drive", -1)]
    tip = np.array([[0, 0, 0], [0.5, 0, 0], [0.5, 0, 1.0], [0.5, 0, 2.0], [0.5, 0, 3.0]])
    segs = split_path(tip)
    assert [s.kind for s in segs] == ["drive", "rotate"]
    assert segs[1].headings[1] - segs[1].headings[0] == pytest.approx(3.0)
    # a geometric path (arbitrary headings) is driven forwards; a 135 degree corner is stop-turn-go
    geo = np.array([[0, 0, 2.0], [1, 0, -1.0], [0.3, 0.7, 0.4]])
    segs = split_path(geo, goal_heading=0.0)
    assert [s.kind for s in segs] == ["rotate", "drive", "rotate", "drive", "rotate"]
    assert all(s.direction == 1 for s in segs if s.kind == "drive")
    assert segs[2].headings[1] - segs[2].headings[0] == pytest.approx(0.75 * np.pi)


def footprint_clearance(poses: np.ndarray, circles: list[tuple[float, float, float]]) -> float:
    """Independent clearance: distance from each circle's centre to the footprint polygon, minus r."""
    best = np.inf
    fp = TB3.footprint
    for x, y, th in poses:
        c, s = np.cos(th), np.sin(th)
        poly = np.column_stack([x + c * fp[:, 0] - s * fp[:, 1], y + s * fp[:, 0] + c * fp[:, 1]])
        a, b = poly, np.roll(poly, -1, axis=0)
        for cx, cy, r in circles:
            q = np.array([cx, cy])
            t = np.clip(np.einsum("ij,ij->i", q - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0, 1)
            dist = np.min(np.hypot(*(a + t[:, None] * (b - a) - q).T))
            cross = (b[:, 0] - a[:, 0]) * (q[1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (q[0] - a[:, 0])
            inside = np.all(cross >= 0) or np.all(cross <= 0)
            best = min(best, -dist - r if inside else dist - r)
    return best


def check_definitions(traj, robot) -> None:  # type: ignore[no-untyped-def]
    """Continuity and limits of a planned trajectory, from finite differences of its samples."""
    t, xy, th = traj.t, traj.pose[:, :2], traj.pose[:, 2]
    v, w = traj.vel[:, 0], traj.vel[:, 1]
    dt = np.diff(t)
    step = np.hypot(*np.diff(xy, axis=0).T)
    assert np.all(step <= robot.max_speed * dt * 1.001 + 1e-9)  # position continuous, speed bound
    assert np.all(np.abs(np.diff(th)) <= robot.max_yaw_rate * dt * 1.001 + 1e-9)  # heading (tangent) continuous
    assert np.all(np.abs(v) <= robot.max_speed + 1e-12) and np.all(np.abs(w) <= robot.max_yaw_rate + 1e-12)
    wheel = (np.abs(v) + 0.5 * robot.track_width * np.abs(w)) / robot.wheel_radius
    assert np.all(wheel <= robot.max_wheel_speed + 1e-9)
    assert np.all(np.abs(np.diff(v)) <= robot.max_accel * dt * 1.01 + 1e-9)
    for k, kind in enumerate(traj.segment_kinds):
        idx = np.flatnonzero(traj.segments == k)
        if kind in ("forward", "reverse"):
            assert np.all(np.sign(v[idx][np.abs(v[idx]) > 1e-9]) == (1 if kind == "forward" else -1))
            assert abs(v[idx[0]]) < 1e-9 and abs(v[idx[-1]]) < 1e-9  # rest at every cusp and end
            # tangent from positions (central differences) agrees with the heading
            p = xy[idx]
            mid = slice(1, -1)
            dp = (p[2:] - p[:-2]) / (t[idx][2:] - t[idx][:-2])[:, None]
            moving = np.hypot(*dp.T) > 0.02
            sgn = 1 if kind == "forward" else -1
            ang = np.arctan2(sgn * dp[:, 1], sgn * dp[:, 0])
            err = np.angle(np.exp(1j * (ang - th[idx][mid])))
            assert np.abs(err[moving]).max() < 0.02
            # curvature from positions (independent) is continuous and matches omega / v
            ddp = (p[2:] - 2 * p[1:-1] + p[:-2]) / (np.diff(t[idx])[:-1] ** 2)[:, None]
            sp = np.hypot(*dp.T)
            kap = (dp[:, 0] * ddp[:, 1] - dp[:, 1] * ddp[:, 0]) / np.maximum(sp, 1e-9) ** 3
            ref = w[idx][mid] / np.where(np.abs(v[idx][mid]) > 1e-9, np.abs(v[idx][mid]), 1.0)
            fast = sp > 0.05  # (a short segment between cusps may never reach it: nothing to compare)
            if fast.any():
                assert np.abs(kap[fast] - ref[fast]).max() < 0.05 * max(1.0, np.abs(ref[fast]).max())
            # no curvature jump at ~mm spacing: a jump is one step far above its neighbours' (a steep
            # but continuous ramp, e.g. 0.5 /m per 0.6 mm sample after a cusp, steps evenly)
            if fast.sum() > 2:
                assert np.abs(np.diff(kap[fast], n=2)).max() < 0.5
        else:
            assert np.allclose(xy[idx], xy[idx[0]])  # turns in place and holds stay on the spot


PATHS = {
    "corner": polyline([[0, 0], [1, 0], [1.3, 0.8], [2, 1.0]]),
    "vertical": polyline([[0, -1], [0, 0], [0, 1]]),
    "loop": np.column_stack([0.5 * np.sin(s := np.linspace(0, 2 * np.pi, 80)), 0.5 - 0.5 * np.cos(s), s]),
    "cusp": np.vstack(
        [
            np.column_stack([np.linspace(0, 1, 21), np.zeros(21), np.zeros(21)]),
            np.column_stack([1 - 0.5 * np.sin(a := np.linspace(0, np.pi / 2, 21)[1:]), 0.5 - 0.5 * np.cos(a), -a]),
        ]
    ),
    "turn_in_place": np.array([[0, 0, 0], [0.6, 0, 0], [0.6, 0, 1.5], [0.6, 0, 3.1], [0.0, 0.0, 3.1]]),
}


@pytest.mark.parametrize("name", sorted(PATHS))
@pytest.mark.parametrize("robot", ["turtlebot3", "edumip"])
def test_hand_made_paths_become_continuous_trajectories_within_limits(name: str, robot: str) -> None:
    spec = load_robot(robot)
    path = PATHS[name]
    res = make_trajectory(path, spec, OPEN, goal=Pose2D(path[-1, 0], path[-1, 1], path[-1, 2] + 0.4))
    assert res.success, res.reason
    traj = res.trajectory
    check_definitions(traj, spec)
    assert np.allclose(traj.pose[0, :2], path[0, :2]) and np.allclose(traj.pose[-1, :2], path[-1, :2])
    assert (
        traj.pose[-1, 2] == pytest.approx(np.unwrap(path[:, 2])[-1] + 0.4, abs=1e-6)
        or abs(np.angle(np.exp(1j * (traj.pose[-1, 2] - path[-1, 2] - 0.4)))) < 1e-6
    )
    if name == "cusp":
        assert res.stats["cusps"] == 1 and {"forward", "reverse"} <= set(traj.segment_kinds)
    if name == "turn_in_place":
        assert "rotate" in traj.segment_kinds


def test_a_fit_that_would_clip_an_obstacle_is_refined_until_clear() -> None:
    # a bump over a disc: a stiff, coarse first fit flattens the bump into the disc
    circle = (1.2, 0.03, 0.04)
    world = World((-3, 3, -3, 3), (Circle(circle[:2], circle[2]),))
    path = polyline([[0, 0], [1, 0], [1.1, 0.3], [1.3, 0.3], [1.4, 0], [2.4, 0]])
    seg = split_path(path)[0]
    checker = CollisionChecker(world, TB3)
    first = smooth_drive(seg, checker, piece_length=2.0, penalty=1e-1, max_deviation=1.0, max_attempts=1)
    assert first.status is SmoothStatus.COLLISION
    assert footprint_clearance(first.curve.poses(np.linspace(0, first.curve.length, 200)), [circle]) < 0
    res = smooth_drive(seg, checker, piece_length=2.0, penalty=1e-1, max_deviation=1.0, clearance=0.005)
    assert res.success and res.attempts > 1 and res.pieces > first.pieces
    poses = res.curve.poses(np.linspace(0, res.curve.length, 600))
    assert footprint_clearance(poses, [circle]) > 0.0


def test_a_path_through_an_obstacle_is_a_failure_status() -> None:
    world = World((-3, 3, -3, 3), (Circle((0.5, 0.0), 0.1),))
    res = make_trajectory(polyline([[0, 0], [1, 0]]), TB3, world)
    assert res.status is TrajectoryStatus.COLLISION and not res.success
    assert res.reason.startswith("the path given collides before any smoothing: at (0.3"), res.reason
    with pytest.raises(ValueError, match="must be a TrajectoryStatus"):
        TrajectoryResult("success", None)  # type: ignore[arg-type]


def test_a_drive_that_folds_back_on_itself_says_so_not_that_it_strayed() -> None:
    # headings that follow the motion, but the first drive ends pointing back along itself: every fit
    # keeps close to the path (no deviation to speak of) and folds back at the turn
    path = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, np.pi], [0.0, 0.02, np.pi]])
    res = make_trajectory(path, load_robot("turtlebot3"), World((-2.0, 3.0, -2.0, 2.0)))
    assert res.status is TrajectoryStatus.DEVIATION
    assert "the fitted curve still folds back on itself (its speed along the path falls to 0.0" in res.reason
    assert "deviation 0.0" not in res.reason  # the old message quoted a deviation well within its bound


def test_timed_plans_are_kept_as_they_are_or_slowed_uniformly() -> None:
    t = np.linspace(0.0, 4.0, 401)
    v = 0.1 * np.sin(np.pi * t / 4.0) ** 2
    w = 0.2 * np.sin(np.pi * t / 4.0) ** 2
    th = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t))])
    vx, vy = v * np.cos(th), v * np.sin(th)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (vx[1:] + vx[:-1]) * np.diff(t))])
    y = np.concatenate([[0.0], np.cumsum(0.5 * (vy[1:] + vy[:-1]) * np.diff(t))])
    path = np.column_stack([x, y, th])
    plan = PlanResult(PlanStatus.SUCCESS, "test", path=path, times=t, controls=np.column_stack([v, w]))
    res = make_trajectory(plan, TB3, OPEN, dwell=0.0)
    assert res.success and res.stats["time_scale"] == 1.0
    n = t.size
    assert np.array_equal(res.trajectory.pose[:n], path) and np.array_equal(res.trajectory.t[:n], t)
    fast = PlanResult(PlanStatus.SUCCESS, "test", path=path, times=t / 4.0, controls=np.column_stack([4 * v, 4 * w]))
    res = make_trajectory(fast, TB3, OPEN, dwell=0.0)
    c = res.stats["time_scale"]
    assert c > 1.0 and np.allclose(res.trajectory.t[:n], t / 4.0 * c)
    assert np.abs(res.trajectory.vel[:n, 0]).max() <= 0.85 * TB3.max_speed + 1e-12


def _unicycle_samples(t: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Poses of a unicycle under piecewise-constant (v, w) held over each sample step (exact arcs)."""
    pose = np.zeros((t.size, 3))
    for k in range(t.size - 1):
        h, (x, y, th) = t[k + 1] - t[k], pose[k]
        vk, wk = v[k], w[k]
        if abs(wk) < 1e-12:
            pose[k + 1] = (x + vk * h * np.cos(th), y + vk * h * np.sin(th), th)
        else:
            th1 = th + wk * h
            pose[k + 1] = (x + vk / wk * (np.sin(th1) - np.sin(th)), y - vk / wk * (np.cos(th1) - np.cos(th)), th1)
    return pose


def test_a_timed_plan_with_speed_steps_keeps_its_path_and_is_retimed() -> None:
    """Inputs held over 0.2 s intervals, moving from the first sample and reversing halfway (the way
    'optim' gives them): the trajectory follows the same path, starts and ends at rest, stops at the
    cusp, and keeps speed and acceleration within the limits, with a continuous speed."""
    t = np.arange(0.0, 6.0 + 1e-9, 0.01)
    knot = np.minimum((t / 0.2).astype(int), 29)
    v_knots = np.where(np.arange(30) < 15, 0.12, -0.1) * (1.0 + 0.3 * np.sin(np.arange(30)))
    w_knots = 0.4 * np.cos(0.5 * np.arange(30))
    v, w = v_knots[knot], w_knots[knot]
    path = _unicycle_samples(t, v, w)
    plan = PlanResult(PlanStatus.SUCCESS, "test", path=path, times=t, controls=np.column_stack([v, w]))
    res = make_trajectory(plan, TB3, OPEN, dwell=0.0)
    assert res.success and res.stats["retimed"] and res.stats["cusps"] == 1
    traj = res.trajectory
    # every trajectory position lies on the plan's path (its polyline, sampled every 10 ms)
    dense = np.vstack([np.linspace(a, b, 20, endpoint=False) for a, b in itertools.pairwise(path[:, :2])])
    gap = np.array([np.hypot(*(dense - p).T).min() for p in traj.pose[::5, :2]])
    assert gap.max() < 1e-3
    assert np.allclose(traj.pose[-1, :2], path[-1, :2], atol=1e-9)
    vel, acc = traj.vel[:, 0], traj.acc[:, 0]
    assert vel[0] == 0.0 and vel[-1] == 0.0
    limit = 0.85 * TB3.max_speed
    assert np.abs(vel).max() <= limit + 1e-9 and np.abs(acc).max() <= 0.85 * TB3.max_accel + 1e-9
    assert np.abs(np.diff(vel)).max() <= 0.85 * TB3.max_accel * np.diff(traj.t).max() + 1e-9  # no steps
    flips = np.flatnonzero(np.sign(vel[:-1]) * np.sign(vel[1:]) < 0)
    assert flips.size == 0  # the direction changes only through a stop
    moving = vel[np.abs(vel) > 1e-6]
    assert moving[0] > 0 and moving[-1] < 0  # forwards first, then backwards, as planned


def test_split_reads_directions_as_arriving_at_each_pose() -> None:
    """A forward arc, a cusp, a reverse arc: directions[i] is the motion that *reaches* pose i (as
    the planners and the curve samplers give it), so the cusp pose ends the forward drive."""
    a = np.linspace(0.0, 0.5, 11)
    fwd = np.column_stack([0.2 * np.sin(a), 0.2 * (1 - np.cos(a)), a])  # left arc, radius 0.2, forwards
    b = np.linspace(0.5, 1.0, 11)[1:]  # backwards on a right arc: heading keeps rising
    c0 = fwd[-1, :2] + 0.2 * np.array([np.sin(0.5), -np.cos(0.5)])  # centre of the right-hand circle
    back = np.column_stack([c0[0] - 0.2 * np.sin(b), c0[1] + 0.2 * np.cos(b), b])
    path = np.vstack([fwd, back])
    dirs = np.concatenate([np.ones(11), -np.ones(10)])
    segs = split_path(path, dirs)
    assert [(s.kind, s.direction, s.points.shape[0]) for s in segs] == [("drive", 1, 11), ("drive", -1, 11)]
    np.testing.assert_allclose(segs[0].points[-1], segs[1].points[0])
    np.testing.assert_allclose([segs[0].headings[1], segs[1].headings[0]], [0.5, 0.5])


def test_remove_loops_cuts_retraced_stretches_and_keeps_only_input_steps() -> None:
    out = np.column_stack([np.linspace(0, 0.6, 7), np.zeros(7), np.zeros(7)])
    back = out[-2::-1][:4]  # drive back over the same poses to x = 0.2
    fwd = np.column_stack([np.linspace(0.3, 1.0, 8), 0.01 * np.arange(1, 9), np.zeros(8)])
    path = np.vstack([out, back, fwd])
    dirs = np.concatenate([np.ones(7), -np.ones(4), np.ones(8)])
    cut, cdirs = remove_loops(path, dirs)
    # the first visit of (0.2, 0) jumps past its last one (the end of the back-up)
    np.testing.assert_array_equal(cut, np.vstack([out[:3], fwd]))
    np.testing.assert_array_equal(cdirs, np.ones(11))
    # every kept step joins the same two poses as some input step (the cut is made of input motion)
    for p, q in itertools.pairwise(cut):
        assert np.any(np.all(np.isclose(path[:-1], p), axis=1) & np.all(np.isclose(path[1:], q), axis=1))
    loop_free = PATHS["corner"]
    again, none = remove_loops(loop_free)
    np.testing.assert_array_equal(again, loop_free)
    assert none is None


def _loops_reference(path: np.ndarray, tolerance: float) -> np.ndarray:
    """remove_loops' kept indices the plain way: a dict from each rounded pose (theta wrapped to
    [-pi, pi)) to its last index, and the walk that jumps past each kept pose's last visit."""
    keys = np.round(np.column_stack([path[:, :2], np.mod(path[:, 2] + np.pi, 2 * np.pi) - np.pi]) / tolerance)
    last = {tuple(k): i for i, k in enumerate(keys.tolist())}
    keep, i = [], 0
    while i < path.shape[0]:
        keep.append(i)
        i = last[tuple(keys[i].tolist())] + 1
    return np.array(keep, dtype=np.int64)


def test_remove_loops_keeps_what_the_plain_walk_keeps_on_long_paths_with_many_revisits():
    """Random paths drawn from a few hundred poses (so most poses recur, some with headings 2 pi apart,
    some half a grid step apart: rounded to the same or the next key), up to 50 000 long: the
    compiled walk keeps exactly the poses the plain one keeps."""
    rng = np.random.default_rng(11)
    for n, tolerance in ((0, 1e-6), (1, 1e-6), (50, 1e-6), (2_000, 0.01), (50_000, 1e-6)):
        pool = np.column_stack([rng.uniform(-3, 3, (300, 2)), rng.uniform(-np.pi, np.pi, 300)])
        path = pool[rng.integers(0, 300, n)]
        path[:, 2] += 2 * np.pi * rng.integers(-2, 3, n)  # the same heading, wound differently
        path[rng.random(n) < 0.1, :2] += rng.choice([0.4, 0.6], (1, 2)) * tolerance  # a rounding either way
        cut, _ = remove_loops(path, tolerance=tolerance)
        np.testing.assert_array_equal(cut, path[_loops_reference(path, tolerance)])
        if n > 100:
            assert cut.shape[0] < 0.1 * n


def footprint_world_clearance(traj, robot, world) -> float:  # type: ignore[no-untyped-def]
    """Independent footprint test: footprint edges at every sample, 40 points each, against the
    world's exact signed distances (obstacles and walls)."""
    corners = robot.footprint_at(traj.pose)
    nxt = np.roll(corners, -1, axis=1)
    t = np.linspace(0.0, 1.0, 40)[None, None, :, None]
    pts = (corners[:, :, None, :] * (1 - t) + nxt[:, :, None, :] * t).reshape(-1, 2)
    return float(np.min(world.signed_distance(pts)))


SAMPLING_CASES = [
    # (scenario, robot, planner, options): paths that used to fail with "deviation after 5 refinements"
    ("parallel_park", "turtlebot3", "rrt-star", {"max_iterations": 1500}),  # Reeds-Shepp curves with cusps
    ("nav_map1", "turtlebot3", "rrt", {}),  # bicycle primitives, an exact curve to the goal
    ("edumip_map", "edumip", "birrt", {}),  # unicycle primitives (they drove forwards and straight back)
]


@pytest.mark.parametrize("simplify", [False, True], ids=["raw", "simplified"])
@pytest.mark.parametrize(("scenario", "robot", "planner", "options"), SAMPLING_CASES, ids=lambda c: str(c))
def test_sampling_planner_paths_smooth_collision_free_and_continuous(
    scenario: str, robot: str, planner: str, options: dict, simplify: bool
) -> None:
    sc = load_scenario(scenario).with_robot(robot)
    spec = load_robot(robot)
    problem = PlanProblem.from_scenario(sc, robot=spec, seed=0, time_limit=20)
    plan = make_planner(planner, simplify=simplify, **options).plan(problem)
    assert plan.success, plan.reason
    res = make_trajectory(plan, spec, sc.world, goal=sc.goal)
    assert res.success, res.reason
    traj = res.trajectory
    check_definitions(traj, spec)
    assert footprint_world_clearance(traj, spec, sc.world) > 0.0
    if planner == "birrt" and not simplify:  # its raw path of primitives no longer drives out and straight back:
        # over half of it was such loops before its connect steps stopped when they no longer closed in, and the
        # rest went while its trees added a primitive's reverse as a copy of the node it left (test_rrt)
        assert res.stats["loop_poses_removed"] == 0
    # the drives keep the planner's travel directions: cusps in the plan are cusps in the trajectory
    d = np.asarray(plan.directions)
    assert res.stats["cusps"] <= int(np.sum(d[1:] != d[:-1]))
    kinds = [k for k in traj.segment_kinds if k in ("forward", "reverse")]
    assert res.stats["cusps"] == sum(a != b for a, b in itertools.pairwise(kinds))
    # starts at the start, ends on the goal pose
    np.testing.assert_allclose(traj.pose[0, :2], sc.start.xy.reshape(-1), atol=1e-9)
    assert np.hypot(traj.pose[-1, 0] - sc.goal.x, traj.pose[-1, 1] - sc.goal.y) <= sc.position_tolerance
    assert abs(np.angle(np.exp(1j * (traj.pose[-1, 2] - sc.goal.theta)))) < 1e-6


def test_the_clearance_a_plan_keeps_is_measured_not_bounded() -> None:
    """The smoothing's own requirement is half the plan's clearance, at most 1 cm. It read the plan's clearance
    from the checker's bound, which away from things is the bounding disc's (centimetres low): a Hybrid-A* plan
    on a random world keeping 4.35 cm was recorded as 0.61 cm and smoothed to keep only 3 mm. It is measured
    (``least_clearance``, within 0.1 mm of the exact least distance) and the smoothing keeps 1 cm."""
    from planning.scenario import random_scenario

    sc = random_scenario("turtlebot3", 902)
    robot = load_robot("turtlebot3")
    plan = make_planner("hybrid-a-star", clearance=0.04).plan(PlanProblem.from_scenario(sc))
    checker = CollisionChecker(sc.world, robot, shape="footprint")
    dense = checker.densify(plan.path)
    assert float(checker.clearance_of(dense).min()) < 0.01 < 0.04 < checker.least_clearance(dense)  # the bound's gap
    res = make_trajectory(plan, robot, sc.world, goal=sc.goal)
    assert res.status is TrajectoryStatus.SUCCESS
    assert res.stats["input_min_clearance_m"] == pytest.approx(checker.least_clearance(dense), abs=1e-4)
    assert res.stats["required_clearance_m"] == 0.01


def _least(world: World, robot_name: str, poses: np.ndarray) -> float:
    checker = CollisionChecker(world, load_robot(robot_name), shape="footprint")
    return checker.least_clearance(checker.densify(poses))


def test_the_smoothings_clearance_is_the_references_not_a_bound_of_it() -> None:
    """The record's ``smoothing.min_clearance_m`` was the collision grid's bound wherever it cleared the requirement:
    a drive 5 cm from a disc said 1.6 cm (the footprint's bounding disc), an optim plan kept as it was 4.7 cm from
    an obstacle said 1.0 cm. It is the reference's least clearance, measured (within 0.1 mm)."""
    world = World((-1.0, 3.0, -1.0, 1.0), (Circle((1.0, 0.3), 0.1),))
    robot = load_robot("turtlebot3")
    gap = 0.3 - 0.1 - robot.radius - 0.03  # the line passes 3 cm beyond the footprint's bounding disc
    path = np.column_stack([np.linspace(0.0, 2.0, 201), np.full(201, gap), np.zeros(201)])
    res = make_trajectory(path, robot, world)
    assert res.status is TrajectoryStatus.SUCCESS and res.trajectory is not None
    truth = _least(world, "turtlebot3", res.trajectory.pose)
    assert res.stats["min_clearance_m"] == pytest.approx(truth, abs=2e-4)
    sc = load_scenario("nav_map1")
    plan = make_planner("optim").plan(PlanProblem.from_scenario(sc))
    timed = make_trajectory(plan, load_robot(sc.robot), sc.world, goal=sc.goal)
    assert timed.status is TrajectoryStatus.SUCCESS and timed.trajectory is not None
    assert timed.stats["min_clearance_m"] == timed.stats["input_min_clearance_m"]
    assert timed.stats["min_clearance_m"] == pytest.approx(_least(sc.world, sc.robot, plan.path), abs=2e-4)
    # a stop-turn-go whose turn in place comes closest: the drives' clearance alone said 5.6 cm for 3.35 cm
    corner = World((0.0, 4.0, -1.0, 3.0), (Circle((2.0, 1.0 - 0.21), 0.05),))
    path = np.array([[0.5, 1.0, 0.0], [2.0, 1.0, 0.0], [2.0, 1.0, np.pi / 2], [2.0, 2.5, np.pi / 2]])
    turned = make_trajectory(path, robot, corner)
    assert turned.status is TrajectoryStatus.SUCCESS and turned.trajectory is not None
    assert turned.stats["rotations"] == 1
    truth = _least(corner, "turtlebot3", turned.trajectory.pose)
    assert turned.stats["min_clearance_m"] == pytest.approx(truth, abs=2e-4)
