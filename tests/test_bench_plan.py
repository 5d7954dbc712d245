"""``nhsim bench plan``'s OMPL C++ harness: its checker agrees with FastChecker, its paths are free by
ours, its motion checks are dense enough for 4 cm walls; and the bench without a toolchain."""

from __future__ import annotations

import argparse
import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from planning.collision.exact import CollisionChecker
from planning.collision.grid import FastChecker
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.core.world import Box, Circle, Ellipse, Polygon, World
from planning.curves.reeds_shepp import reeds_shepp_length, reeds_shepp_path
from planning.errors import ConfigError, DependencyError
from planning.planners.base import PlanProblem
from planning.planners.sampling.extend import LocalPlanner
from planning.planners.sampling.tree import make_checker
from sim.tools.bench.ompl_native import build
from sim.tools.bench.ompl_native.problem import Session, check_poses, run_planner, write_problem
from sim.tools.bench.plan_problems import CORRIDOR_FACTOR, HARD, problems

MISSING = build.missing()
needs_harness = pytest.mark.skipif(MISSING is not None, reason=f"OMPL C++ harness cannot be built: {MISSING}")


@pytest.fixture(scope="module")
def harness() -> Path:
    return build.harness()


def _world() -> World:
    """Every obstacle kind, rotated; a non-convex polygon; a 1 cm disc that fits inside the footprint."""
    return World(
        (0.0, 3.0, 0.0, 2.0),
        (
            Circle((0.6, 0.6), 0.25),
            Ellipse((1.6, 1.4), (0.4, 0.15), 0.7),
            Ellipse((2.4, 0.5), (0.1, 0.3), -0.3),
            Box((1.5, 0.5), (0.5, 0.2), 0.4),
            Polygon(((2.2, 1.2), (2.8, 1.2), (2.8, 1.8), (2.5, 1.5), (2.2, 1.8))),
            Circle((0.5, 1.5), 0.01),
        ),
    )


def _poses(world: World, fast: FastChecker, rng: np.random.Generator) -> np.ndarray:
    """20 000 uniform poses (4000 without walls, where the exact checker decides all) with some beyond
    the walls and unwrapped headings, plus 3000 the grid leaves undecided (near the decision margin:
    the exact fallback decides them)."""
    xmin, xmax, ymin, ymax = world.bounds
    n = 200_000
    p = np.column_stack(
        [rng.uniform(xmin - 0.1, xmax + 0.1, n), rng.uniform(ymin - 0.1, ymax + 0.1, n), rng.uniform(-9, 9, n)]
    )
    undecided = fast._classify(p, False) < 0
    return np.vstack([p[: 20_000 if fast.checker.walls else 4000], p[undecided][:3000]])


@needs_harness
@pytest.mark.parametrize(
    ("shape", "clearance", "walls"), [("footprint", 0.0, True), ("footprint", 0.05, True), ("disc", 0.02, True),
                                      ("footprint", 0.0, False)]
)  # fmt: skip
def test_harness_checker_agrees_with_fastchecker(
    harness: Path, tmp_path: Path, shape: str, clearance: float, walls: bool
) -> None:
    world = _world()
    exact = CollisionChecker(world, load_robot("turtlebot3"), shape=shape, clearance=clearance, walls=walls)  # type: ignore[arg-type]
    fast = FastChecker(exact)
    poses = _poses(world, fast, np.random.default_rng(7))
    problem = PlanProblem(world, exact.robot, Pose2D(0.2, 0.2, 0.0), Pose2D(2.8, 0.2, 0.0))
    ours = fast.poses_free(poses)
    cpp = check_poses(harness, write_problem(tmp_path, problem, fast, "reeds_shepp", 0.15, 0.01), poses)
    undecided = int(np.sum(fast._classify(np.ascontiguousarray(poses), False) < 0))
    assert cpp.shape == ours.shape
    assert int(np.sum(cpp != ours)) == 0
    assert undecided >= 3000  # the exact fallback was exercised
    assert 0.1 < ours.mean() < 0.9


@needs_harness
def test_harness_paths_are_free_by_our_checker(harness: Path, tmp_path: Path) -> None:
    """The maze's 4 cm walls: OMPL 1.5's per-component segment count would step over them; the
    harness's curve-length count must not. Every curve of its paths, sampled by us every 5 mm, is free."""
    problem = HARD["maze"]()
    checker = make_checker(problem, "footprint", 0.0)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    assert local.rho is not None
    pf = write_problem(tmp_path, problem, checker, "reeds_shepp", local.rho, local.sample_step)
    rc = run_planner(harness, pf, "RRTConnect", 20.0, 3, 5)
    assert rc.solved.all()
    path = rc.path
    assert np.allclose(path[0], problem.start.as_array(), atol=1e-9)
    assert np.hypot(*(path[-1, :2] - problem.goal.as_array()[:2])) <= problem.position_tolerance
    lengths = reeds_shepp_length(path[:-1], path[1:], local.rho)
    assert rc.length_m[-1] == pytest.approx(float(np.sum(lengths)), rel=1e-9)
    for a, b in itertools.pairwise(path):
        poses, _ = reeds_shepp_path(a, b, local.rho).sample(0.005)
        assert checker.path_free(poses)
    direct = float(reeds_shepp_length(problem.start.as_array(), problem.goal.as_array(), local.rho)[0])
    assert np.all(rc.length_m > direct)  # the walls force a detour
    assert np.all(rc.time_s < 20.0)


@needs_harness
def test_harness_rrtstar_spends_its_budget(harness: Path, tmp_path: Path) -> None:
    problem = problems(["disc10"])[0]
    checker = make_checker(problem, "footprint", 0.0)
    pf = write_problem(tmp_path, problem, checker, "reeds_shepp", 0.146, 0.01)
    rs = run_planner(harness, pf, "RRTstar", 0.3, 2, 1)
    assert rs.solved.all()
    assert np.all(rs.time_s >= 0.3) and np.all(rs.time_s < 1.0)
    assert np.all(rs.first_s < rs.time_s)
    lower = float(reeds_shepp_length(problem.start.as_array(), problem.goal.as_array(), 0.146)[0])
    assert np.all(rs.length_m >= lower - problem.position_tolerance)


def test_missing_compiler_names_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CXX", "no-such-compiler-nhsim")
    why = build.missing()
    assert why is not None and "g++" in why and "libompl-dev" in why
    with pytest.raises(DependencyError, match="libompl-dev"):
        build.harness()


def test_bench_without_toolchain_races_ours_and_exits_0(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from sim.cli.bench import plan as cli

    monkeypatch.setattr(build, "missing", lambda: "no C++ compiler found; " + build.INSTALL_HINT)
    p = argparse.ArgumentParser()
    cli.add_arguments(p)
    args = p.parse_args(["--seeds", "1", "--budget", "0.2", "--scenarios", "disc10", "--no-wheel"])
    assert cli.run(args) == 0
    out = capsys.readouterr().out
    assert "sudo apt-get install g++ libompl-dev" in out
    assert "disc10" in out.splitlines()[-1] and "1.00" in out.splitlines()[-1]


def test_hard_problems() -> None:
    robot = load_robot("turtlebot3")
    width = float(np.ptp(robot.footprint[:, 1]))
    corridor = HARD["corridor"]()
    gap = corridor.world.signed_distance(np.array([[1.5, 0.75]]), walls=False)[0]
    assert 2 * gap == pytest.approx(CORRIDOR_FACTOR * width, rel=1e-12)
    for make in HARD.values():
        p = make()
        chk = make_checker(p, "footprint", 0.0)
        assert chk.poses_free(np.array([p.start.as_array(), p.goal.as_array()])).all(), p.name
    names = [p.name for p in problems()]
    assert {"three_point_turn", "parking_lot", *HARD} <= set(names) and "open" not in names
    with pytest.raises(ConfigError, match=r"nowhere.*choose from"):
        problems(["nowhere"])


@needs_harness
def test_measure_races_both_sides(harness: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """One problem, two seeds through the warm harness session: both sides solve, and on an empty
    world every RRT* path is no shorter than the Reeds–Shepp optimum (the direct curve, less the goal
    tolerance) and within 25 % of it after 0.3 s (on a loaded machine RRT* gets few iterations); every
    trial of both sides runs on one CPU, and ours gets its CPUs back."""
    from sim.tools.bench.plan import measure

    problem = problems(["simple_motion"])[0]
    mine = os.sched_getaffinity(0)
    cpus: list[tuple[set[int], set[int]]] = []  # (ours, the harness's) at each of OMPL's trials
    solve = Session.solve

    def watched(self: Session, *args: object) -> dict[str, float]:
        cpus.append((os.sched_getaffinity(0), os.sched_getaffinity(self.pid)))
        return solve(self, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(Session, "solve", watched)
    r = measure(problem, "reeds_shepp", 2, 0.3, 5.0, harness, wheel=False, optimal=("RRTstar", "BITstar"))
    assert len(cpus) == 6 and all(c == ({max(mine)}, {max(mine)}) for c in cpus), cpus  # the trials on one CPU
    assert os.sched_getaffinity(0) == mine  # given back
    assert r.ok_ours == (1.0, 1.0) and r.ok_cpp == (1.0, 1.0)
    assert set(r.len_cpp) == {"RRTstar", "BITstar"} and r.success("RRTstar") == r.success("BITstar") == 1.0
    assert all(0 < t < 5.0 for t in r.ttfs_ours + r.ttfs_cpp)
    rho = LocalPlanner("reeds_shepp", problem.robot, make_checker(problem, "footprint", 0.0)).rho
    optimum = float(reeds_shepp_length(problem.start.as_array(), problem.goal.as_array(), rho)[0])
    for length in r.len_ours + r.len_cpp["RRTstar"] + r.len_cpp["BITstar"]:
        assert optimum - problem.position_tolerance <= length <= 1.25 * optimum
    assert r.anchor in ("RRTstar", "BITstar")
    assert np.isfinite(r.ttfs_ratio) and np.isfinite(r.length_ratio)


def _serve(session: object, request: str) -> dict[str, float]:
    """One raw request line to a harness session (flags included)."""
    proc = session._proc  # type: ignore[attr-defined]
    proc.stdin.write(request + "\n")
    proc.stdin.flush()
    return {k: float("nan") if v is None else v for k, v in json.loads(proc.stdout.readline()).items()}


@needs_harness
def test_harness_times_solve_without_overhead(harness: Path, tmp_path: Path) -> None:
    """On a trivial problem (an empty world, RRTConnect solves in ~0.1 ms), the time the harness reports
    is within 1.35x of when the planner's last validity check returned: nothing of note runs around the
    solve. The same probe catches OMPL's watchdog thread (ss.solve(double), limit >= 1 s): the time
    after its last check is at least 1.5x the plain solve's (measured 2.4-2.7x), interleaved trials."""
    from sim.tools.bench.ompl_native.problem import Session

    problem = problems(["simple_motion"])[0]
    checker = make_checker(problem, "footprint", 0.0)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    assert local.rho is not None
    pf = write_problem(tmp_path, problem, checker, "reeds_shepp", local.rho, local.sample_step)
    rows: dict[str, list[dict[str, float]]] = {"probe": [], "watchdog probe": []}
    with Session(harness, pf, 3) as s:
        for _ in range(60):
            for flags, out in rows.items():
                out.append(_serve(s, f"RRTConnect 1.0 {flags}"))

    def med(key: str, flags: str) -> float:
        return float(np.median([r[key] for r in rows[flags]]))

    def tail(flags: str) -> float:
        return float(np.median([r["time_s"] - r["last_check_s"] for r in rows[flags]]))

    with Session(harness, pf, 3) as s:
        warm = s.solve("RRTConnect", 1.0, "warm", "probe")  # an untimed solve first, then the timed one
    assert warm["solved"] and 0 < warm["last_check_s"] <= warm["time_s"] < 0.05
    assert all(r["solved"] for out in rows.values() for r in out)
    assert all(0 < r["last_check_s"] <= r["time_s"] for out in rows.values() for r in out)
    assert med("time_s", "probe") <= 1.35 * med("last_check_s", "probe")
    assert tail("watchdog probe") >= 1.5 * tail("probe")


@needs_harness
def test_harness_goal_is_our_region(harness: Path, tmp_path: Path) -> None:
    """OMPL is given our goal region: every path, RRTConnect's and the optimal planners', ends within
    the position and heading tolerances of the goal pose (the goal pose itself for RRTConnect)."""
    problem = problems(["parallel_park"])[0]
    checker = make_checker(problem, "footprint", 0.0)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    assert local.rho is not None
    pf = write_problem(tmp_path, problem, checker, "reeds_shepp", local.rho, local.sample_step)
    assert f"{problem.heading_tolerance!r}" in pf.read_text().split("\ngoal ")[1].splitlines()[0]
    g = problem.goal.as_array()
    for planner, limit in (("RRTConnect", 5.0), ("RRTstar", 0.3), ("BITstar", 0.3), ("RRTstar+informed", 0.3)):
        t = run_planner(harness, pf, planner, limit, 1, 2)
        assert t.solved.all(), planner
        end = t.path[-1]
        assert np.hypot(*(end[:2] - g[:2])) <= problem.position_tolerance + 1e-12, planner
        assert abs((end[2] - g[2] + np.pi) % (2 * np.pi) - np.pi) <= problem.heading_tolerance + 1e-12, planner
        if planner == "RRTConnect":
            assert np.allclose(end[:2], g[:2], atol=1e-12)


@needs_harness
def test_harness_region_flag_samples_our_region_poses(harness: Path, tmp_path: Path) -> None:
    """The problem file carries goal_region_poses; with the `region` flag OMPL's goal samples are those
    poses, so on parallel_park (the direct curve is free) RRT* ends on the shortest curve to one of
    them, 6 cm shorter than the curve to the goal pose, as rrt-star with region_goal does."""
    from planning.planners.sampling.tree import goal_region_poses

    problem = problems(["parallel_park"])[0]
    checker = make_checker(problem, "footprint", 0.0)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    assert local.rho is not None
    pf = write_problem(tmp_path, problem, checker, "reeds_shepp", local.rho, local.sample_step)
    aims = goal_region_poses(problem)
    line = pf.read_text().split("\nregion ")[1].splitlines()[0].split()
    assert int(line[0]) == len(aims) and np.array_equal(np.array(line[1:], dtype=float).reshape(-1, 3), aims)
    start = problem.start.as_array()
    shortest = reeds_shepp_length(start, aims, local.rho).min()
    to_pose = reeds_shepp_length(start, problem.goal.as_array(), local.rho)[0]
    with Session(harness, pf, 4) as s:
        for planner in ("RRTstar+informed", "BITstar"):  # 1 s of wall clock: about 0.3 s of CPU converges,
            t = s.solve(planner, 1.0, "region")  # which a loaded machine (load 9) did not give in 0.3 s
            assert t["solved"] and shortest - 1e-9 <= t["length_m"] <= shortest + 1e-3 < to_pose - 0.05, planner
        assert s.solve("RRTConnect", 5.0, "region")["solved"]


def test_length_median_counts_failures_and_picks_the_anchor() -> None:
    from sim.tools.bench.plan import PlanBench, length_median, summary

    nan = float("nan")
    assert length_median((1.0, 3.0, nan)) == 3.0
    assert length_median((1.0, nan, nan)) == np.inf
    r = PlanBench(
        "p",
        (0.1, 0.3),
        (1.0, 1.0),
        (2.0, 2.2),
        (1.0, 1.0),
        (0.2, 0.2),
        (1.0, 1.0),
        {"A": (1.9, nan, nan), "B": (2.2, 2.4, 2.0), "C": (2.1, nan, 2.3)},
    )
    assert r.anchor == "B"  # A's median is infinite (it failed in most trials), C's 2.3
    assert r.length_ratio == pytest.approx(2.1 / 2.2)
    assert r.ttfs_ratio == pytest.approx(1.0)
    assert r.success("C") == pytest.approx(2 / 3) and not r.success_missed
    worse = PlanBench("q", (0.1,), (1.0,), (nan,), (0.0,), (0.05,), (1.0,), {"A": (1.0,)})
    assert worse.length_ratio == np.inf and worse.success_missed
    s = summary([r, worse])
    assert s["length_ratio"] == np.inf and s["ttfs_worst"] == pytest.approx(2.0)


def test_markdown_is_stamped_and_never_overwritten(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from planning.errors import OutputExistsError
    from sim.cli.bench import plan as cli

    monkeypatch.setattr(build, "missing", lambda: "no C++ compiler found; " + build.INSTALL_HINT)
    p = argparse.ArgumentParser()
    cli.add_arguments(p)
    out = tmp_path / "plan.md"
    argv = ["--seeds", "1", "--budget", "0.2", "--scenarios", "disc10", "--no-wheel", "--markdown", str(out)]
    monkeypatch.setattr(sys, "argv", ["/somewhere/bin/nhsim", "bench", "plan", *argv])
    assert cli.run(p.parse_args(argv)) == 0
    text = out.read_text()
    assert "2 cores" in text or "cores" in text.splitlines()[0]
    # the command as given: the problems, planners and goal a page was measured on (it named seeds and budget only)
    assert f"`nhsim bench plan --seeds 1 --budget 0.2 --scenarios disc10 --no-wheel --markdown {out}`" in text
    assert "load average" in text.splitlines()[0] and "commit" in text.splitlines()[0]
    assert "| disc10 |" in text
    out.write_text("keep")
    with pytest.raises(OutputExistsError, match="--overwrite"):
        cli.run(p.parse_args(argv))
    assert out.read_text() == "keep"
    with pytest.raises(ConfigError, match="--optimal"):
        cli.run(p.parse_args([*argv, "--overwrite", "--optimal", "RRTfast"]))


def test_random_worlds_join_the_problems() -> None:
    names = [p.name for p in problems(["maze"], 2)]
    assert names == ["maze", "random0", "random1"]
    assert problems(["random4"])[0].name == "random4"
    with pytest.raises(ConfigError, match="random<N>"):
        problems(["randomx"])


@needs_harness
def test_harness_motions_check_the_poses_ours_do(harness: Path, tmp_path: Path) -> None:
    """The harness's motion checks agree with ours (LocalPlanner.connect) on curves into and around
    tight_park's slot, where a car reversing at a cusp touches the kerb: OMPL's own validator spaces
    its states evenly over the curve and steps over the cusps, accepting motions our checks refuse
    (its RRTConnect paths there collided by 2 mm sampling). Curves from the slot's goal pose and
    between random poses; the two sides sample the same poses up to rounding."""
    from sim.tools.bench.ompl_native.problem import check_motions

    problem = HARD["tight_park"]()
    checker = make_checker(problem, "footprint", 0.0)
    local = LocalPlanner("reeds_shepp", problem.robot, checker)
    assert local.rho is not None
    pf = write_problem(tmp_path, problem, checker, "reeds_shepp", local.rho, local.sample_step)
    rng = np.random.default_rng(11)
    b = problem.world.bounds
    n = 1500
    ends = np.column_stack([rng.uniform(b[0], b[1], n), rng.uniform(b[2], b[3], n), rng.uniform(-np.pi, np.pi, n)])
    near = problem.goal.as_array() + rng.normal(0.0, [0.15, 0.05, 0.3], (n, 3))
    starts = np.vstack([np.tile(problem.goal.as_array(), (n, 1)), ends[: n // 2], near[: n // 2]])
    goals = np.vstack([np.where(rng.random((n, 1)) < 0.5, ends, near), ends[n // 2 :], near[n // 2 :]])
    free_start = checker.poses_free(starts)
    starts, goals = starts[free_start], goals[free_start]
    ours = np.array([local.connect(a, g) is not None for a, g in zip(starts, goals, strict=True)])
    cpp = check_motions(harness, pf, np.hstack([starts, goals]))
    assert 0.01 < ours.mean() < 0.9
    assert int(np.sum(cpp != ours)) <= max(1, len(ours) // 1000), (int(np.sum(cpp & ~ours)), int(np.sum(~cpp & ours)))


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="the system cannot pin processes to CPUs")
def test_one_core_pins_both_processes_and_gives_ours_back() -> None:
    """``one_core`` puts this process and the other on this process's highest CPU, and restores ours
    afterwards, also when the block raises."""
    from sim.tools.bench.plan import one_core

    mine = os.sched_getaffinity(0)
    child = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE)
    try:
        with pytest.raises(RuntimeError), one_core(child.pid) as cpu:
            assert cpu == max(mine)
            assert os.sched_getaffinity(0) == {cpu} == os.sched_getaffinity(child.pid)
            raise RuntimeError
        assert os.sched_getaffinity(0) == mine
        with one_core(None) as cpu:
            assert os.sched_getaffinity(0) == {cpu}
        assert os.sched_getaffinity(0) == mine
        gone = subprocess.Popen([sys.executable, "-c", "pass"])
        gone.wait()
        with one_core(gone.pid) as cpu:  # an ended process (its trials report why): ours is still pinned
            assert os.sched_getaffinity(0) == {cpu}
        assert os.sched_getaffinity(0) == mine
    finally:
        assert child.stdin is not None
        child.stdin.close()
        child.wait()
