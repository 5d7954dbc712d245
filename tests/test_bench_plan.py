"""``nhsim bench plan``'s OMPL C++ harness: its checker agrees with FastChecker, its paths are free by
ours, its motion checks are dense enough for 4 cm walls; and the bench without a toolchain."""

from __future__ import annotations

import argparse
import itertools
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
from sim.tools.bench.ompl_native.problem import check_poses, run_planner, write_problem
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
def test_measure_races_both_sides(harness: Path) -> None:
    """One problem, two seeds through the warm harness session: both sides solve, and on an empty
    world both RRT* paths are no shorter than the Reeds–Shepp optimum (the direct curve, less the goal
    tolerance) and within 25 % of it after 0.3 s (on a loaded machine RRT* gets few iterations)."""
    from sim.tools.bench.plan import measure

    problem = problems(["simple_motion"])[0]
    r = measure(problem, "reeds_shepp", 2, 0.3, 5.0, harness, wheel=False)
    assert r.ok_ours == (1.0, 1.0) and r.ok_cpp == (1.0, 1.0) and r.star_ok_cpp == (1.0, 1.0)
    assert all(0 < t < 5.0 for t in r.ttfs_ours + r.ttfs_cpp)
    rho = LocalPlanner("reeds_shepp", problem.robot, make_checker(problem, "footprint", 0.0)).rho
    optimum = float(reeds_shepp_length(problem.start.as_array(), problem.goal.as_array(), rho)[0])
    for length in r.len_ours + r.len_cpp:
        assert optimum - problem.position_tolerance <= length <= 1.25 * optimum
    assert np.isfinite(r.ttfs_ratio) and np.isfinite(r.length_ratio)
