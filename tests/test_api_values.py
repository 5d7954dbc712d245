"""The API's value objects behave as values: they compare by value (``==`` never raises on their arrays), keep
their own copies of what they were given, refuse what they cannot hold, and say themselves in one short line.
"""

from __future__ import annotations

import dataclasses
import json
import math
import pickle
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from copy import deepcopy
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from planning import Circle, PlanProblem, Pose2D, Scenario, World, load_robot, load_scenario
from planning.core.maps import edumip_map_image
from planning.errors import ConfigError, ScenarioError
from planning.planners.base import PlanResult, PlanStatus, PlanTree
from planning.scenario import builtin_scenarios, load_scenario_file, random_scenario
from planning.trajectory.trajectory import Trajectory

ROOT = Path(__file__).resolve().parents[1]


def _arrays(n: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 2.0, n)
    pose = np.column_stack([0.1 * t, np.zeros(n), np.zeros(n)])
    return t, pose, np.tile([0.1, 0.0], (n, 1)), np.zeros((n, 2))


def _result(n: int = 5, reason: str = "", **kw: object) -> PlanResult:
    path = np.column_stack([np.linspace(0.0, 1.0, n), np.zeros(n), np.zeros(n)])
    tree = PlanTree(path.copy(), np.arange(-1, n - 1, dtype=np.int64), (path[:, :2].copy(),))
    stats = {"time_s": 0.25, "iterations": 7, "cost": math.nan, "seq": [1, 2]}
    return PlanResult(
        PlanStatus.SUCCESS, "p", path=path, reason=reason, stats=stats, tree=tree, times=np.linspace(0, 1, n),
        controls=np.ones((n, 2)), **kw,
    )  # fmt: skip


# -- 1: equality ---------------------------------------------------------------------------------------------


def test_robot_specs_compare_and_hash_by_value() -> None:
    a, b = load_robot("turtlebot3"), load_robot("turtlebot3")
    assert a == b and hash(a) == hash(b) and {a: 1}[b] == 1
    assert a != load_robot("edumip")
    assert a != dataclasses.replace(a, footprint=2.0 * a.footprint)
    assert a.__eq__("turtlebot3") is NotImplemented


def test_plan_problems_compare_by_value() -> None:
    sc = load_scenario("simple_motion")
    a, b = PlanProblem.from_scenario(sc, seed=0), PlanProblem.from_scenario(sc, seed=0)
    assert a == b and hash(a) == hash(b)
    assert a != PlanProblem.from_scenario(sc, seed=1)
    assert a.__eq__(sc) is NotImplemented


def test_plan_results_compare_by_value_and_are_not_hashable() -> None:
    a, b = _result(), _result()
    assert a == b and a == pickle.loads(pickle.dumps(a))  # the NaN in the stats equal to itself
    assert a != _result(6) and a != dataclasses.replace(a, reason="other")
    assert a != dataclasses.replace(a, stats={**a.stats, "iterations": 8})
    assert a.__eq__(a.path) is NotImplemented
    with pytest.raises(TypeError, match="unhashable"):
        hash(a)  # its stats are a dict the commands add to


def test_trajectories_compare_and_hash_by_value() -> None:
    a, b = Trajectory(*_arrays()), Trajectory(*_arrays())
    assert a == b and hash(a) == hash(b) and a == pickle.loads(pickle.dumps(a))
    t, pose, vel, acc = _arrays()
    assert a != Trajectory(t, pose, 2.0 * vel, acc) and a != Trajectory(*_arrays(), name="other")
    assert a.__eq__(a.t) is NotImplemented


# -- 2: own copies -------------------------------------------------------------------------------------------


def test_a_plan_result_keeps_its_own_copy_of_the_path() -> None:
    path = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]])
    res = PlanResult(PlanStatus.SUCCESS, "mine", path=path)
    path[1, 0] = np.nan  # the caller re-uses its buffer
    assert np.isfinite(res.path).all() and res.length() == pytest.approx(1.0)
    assert not np.shares_memory(res.path, path) and not res.path.flags.writeable and path.flags.writeable


def test_a_trajectory_keeps_its_own_copies_and_leaves_the_callers_arrays_alone() -> None:
    t, pose, vel, acc = _arrays()
    tr = Trajectory(t, pose, vel, acc)
    assert all(arr.flags.writeable for arr in (t, pose, vel, acc))  # no side effect on the caller's arrays
    t[:] = t[::-1]
    vel[:] = 7.0
    assert tr.duration == pytest.approx(2.0) and tr.vel[0, 0] == pytest.approx(0.1)
    assert not any(arr.flags.writeable for arr in (tr.t, tr.pose, tr.vel, tr.acc))


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_plans_and_a_trajectorys_copies_keep_their_arrays_read_only(how: str) -> None:
    """A worker process's plan or trajectory comes back through pickle: its arrays are as read-only as the
    original's, the trajectory's derived arrays (made again on use) too."""
    import copy

    copied = (lambda v: pickle.loads(pickle.dumps(v))) if how == "pickle" else copy.deepcopy
    res = PlanResult(PlanStatus.SUCCESS, "mine", path=np.zeros((3, 3)), directions=np.ones(3))
    tr = Trajectory(*_arrays())
    tr.flat_derivatives()  # cached before the copy
    res_c, tr_c = copied(res), copied(tr)
    assert res_c == res and tr_c == tr
    arrays = (res_c.path, res_c.directions, tr_c.t, tr_c.pose, tr_c.vel, tr_c.acc, *tr_c.flat_derivatives())
    assert not any(arr.flags.writeable for arr in arrays)
    np.testing.assert_array_equal(tr_c.flat_derivatives()[0], tr.flat_derivatives()[0])


def test_a_scenario_keeps_read_only_copies_of_its_tables() -> None:
    base = load_scenario("simple_motion")
    sensors, options = {"fix_rate": 5.0}, {"rrt": {"goal_bias": 0.1}}
    sc = Scenario(base.name, base.robot, base.world, base.start, base.goal, sensors=sensors, planner_options=options)
    sensors["fix_rate"] = "fast"  # type: ignore[assignment]
    options["rrt"]["goal_bias"] = 7.0
    assert dict(sc.sensors) == {"fix_rate": 5.0} and sc.options_for("rrt") == {"goal_bias": 0.1}
    with pytest.raises(TypeError):
        sc.sensors["fix_rate"] = 1.0  # type: ignore[index]
    with pytest.raises(TypeError):
        sc.planner_options["rrt"]["goal_bias"] = 1.0  # type: ignore[index]
    again = pickle.loads(pickle.dumps(sc))
    assert again == sc and hash(again) == hash(sc) and dict(again.sensors) == {"fix_rate": 5.0}
    with pytest.raises(TypeError):
        again.sensors["fix_rate"] = 1.0  # type: ignore[index]


# -- 4: non-finite times -------------------------------------------------------------------------------------


@pytest.mark.parametrize("t", [math.nan, math.inf, -math.inf, np.float64("nan"), np.array(np.nan)])
def test_sampling_at_a_non_finite_time_is_refused(t: object) -> None:
    tr = Trajectory(*_arrays())
    with pytest.raises(ConfigError, match=r"Trajectory\.sample was given a non-finite time t=-?(nan|inf) s"):
        tr.sample(t)  # type: ignore[arg-type]
    assert tr.sample(1.0).pose == pytest.approx([0.1, 0.0, 0.0])


def test_sampling_many_with_a_non_finite_time_names_it() -> None:
    tr = Trajectory(*_arrays())
    with pytest.raises(ConfigError, match=r"non-finite time times\[1\]=nan s"):
        tr.sample_many([0.0, math.nan, math.inf])
    with pytest.raises(ConfigError, match=r"times\[2\]=inf s"):
        tr.sample_many(np.array([0.0, 1.0, math.inf]))
    assert tr.sample_many([0.0, 5.0]).x == pytest.approx([0.0, 0.2])  # clamped to the span, as before


# -- 5: optim's time -----------------------------------------------------------------------------------------


def test_an_optim_plans_time_is_the_whole_calls(monkeypatch: pytest.MonkeyPatch) -> None:
    """Code readied before the plan's clock starts (here numba's set-up, made 0.2 s long) is in stats["time_s"]
    and stats["code_s"], not held against the limit."""
    import planning.clock
    from planning.planners.optim import Optim

    problem = PlanProblem.from_scenario(load_scenario("simple_motion"), time_limit=0.05)
    Optim().plan(problem)  # what this process loads once
    setup = planning.clock.ready

    def slow_ready() -> float:
        monkeypatch.setattr(planning.clock, "ready", setup)
        time.sleep(0.2)
        return 0.2 + setup()

    monkeypatch.setattr(planning.clock, "ready", slow_ready)
    t0 = time.perf_counter()
    res = Optim().plan(problem)
    wall = time.perf_counter() - t0
    assert wall - 0.02 <= res.stats["time_s"] <= wall
    assert res.stats["code_s"] >= 0.2 and res.stats["time_s"] - res.stats["code_s"] < wall - 0.2 + 0.01


def test_making_the_optim_planner_leaves_a_plans_imports_to_the_plan() -> None:
    """A new process's first optim plan imports SciPy's convex hull and the grid route inside the plan's time
    (stats["time_s"]), not unseen while the planner is made."""
    code = (
        "import sys, time, json\n"
        "from planning import PlanProblem, load_scenario, make_planner\n"
        "problem = PlanProblem.from_scenario(load_scenario('edumip_map'), time_limit=0.1)\n"
        "modules = [m for m in ('scipy.spatial', 'planning.planners.gridpath') if m not in sys.modules]\n"
        "planner = make_planner('optim')\n"
        "early = [m for m in modules if m in sys.modules]\n"
        "t0 = time.perf_counter(); res = planner.plan(problem); wall = time.perf_counter() - t0\n"
        "print(json.dumps([early, wall, res.stats['time_s']]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    early, wall, time_s = json.loads(out.stdout.splitlines()[-1])
    assert early == []
    assert wall - 0.02 <= time_s <= wall


# -- 6: reprs ------------------------------------------------------------------------------------------------


def test_reprs_are_one_short_line() -> None:
    res = _result(2000, reason="x" * 500)
    text = repr(res)
    assert len(text) < 300 and "\n" not in text and str(res) == text
    assert text.startswith("PlanResult(success, planner='p', path=2000 poses") and "time_s=0.250" in text
    t = np.linspace(0.0, 20.0, 4001)
    tr = Trajectory(t, np.column_stack([t, np.zeros_like(t), np.zeros_like(t)]), np.tile([1.0, 0.0], (4001, 1)),
                    np.zeros((4001, 2)), name="rrt")  # fmt: skip
    text = repr(tr)
    assert len(text) < 300 and "\n" not in text and text.startswith("Trajectory('rrt', 4001 samples")
    assert len(repr(res.tree)) < 100


# -- 3: obstacles outside the world --------------------------------------------------------------------------


def test_a_world_refuses_an_obstacle_wholly_outside_its_bounds() -> None:
    inside, typo = Circle((1.0, 1.0), 0.2), Circle((200.0, 200.0), 0.4)
    with pytest.raises(ConfigError, match=r"obstacle 1 \(circle\) lies wholly outside the world bounds .*remove it"):
        World((0, 4, 0, 4), (inside, typo))
    with pytest.raises(ConfigError, match=r"obstacle 0 .* wholly outside"):
        Scenario("typo", "turtlebot3", World((0, 4, 0, 4), (typo,)), Pose2D(0.5, 0.5, 0), Pose2D(3.5, 3.5, 0))
    assert len(World((0, 4, 0, 4), (inside, Circle((4.1, 2.0), 0.2))).obstacles) == 2  # partly inside: kept


def test_a_scenario_file_still_names_itself_for_an_obstacle_outside(tmp_path: Path) -> None:
    path = tmp_path / "typo.toml"
    path.write_text(
        'name = "typo"\nrobot = "turtlebot3"\n[world]\nbounds = [0, 4, 0, 4]\n[[world.obstacles]]\ntype = "circle"\n'
        "center = [200, 200]\nradius = 0.4\n[start]\npose = [0.5, 0.5, 0]\n[goal]\npose = [3.5, 3.5, 0]\n"
    )
    with pytest.raises(ScenarioError, match=r"typo\.toml: field 'world\.obstacles\[0\]': this circle lies wholly"):
        load_scenario_file(path)


def test_built_in_and_random_worlds_have_no_obstacle_outside() -> None:
    for name in builtin_scenarios():
        assert isinstance(load_scenario(name).world, World)
    for seed in range(20):
        assert len(random_scenario("turtlebot3", seed).world.obstacles) == 7


def test_a_map_cropped_by_the_bounds_keeps_the_part_inside(tmp_path: Path) -> None:
    Image.fromarray(edumip_map_image()).save(tmp_path / "map.png")
    path = tmp_path / "m.toml"
    path.write_text(
        'name = "m"\nrobot = "edumip"\n[world]\nbounds = [-1.0, 2.5, -1.0, 6.0]\n[world.map]\nimage = "map.png"\n'
        "resolution = 0.01\n[start]\npose = [0.0, 0.0, 0.0]\n[goal]\npose = [2.0, 5.0, 0.0]\n"
    )
    world = load_scenario_file(path).world
    assert len(world.obstacles) == 1 and world.obstacles[0].bounding_box()[0] < 2.5


def test_a_plan_tree_keeps_its_own_read_only_copies_in_its_copies_too() -> None:
    """A tree held the caller's arrays: an edit of them after the plan reached the result, and its arrays were
    writable, where a result's are its own read-only copies."""
    nodes, parents, edge = np.zeros((2, 3)), np.array([-1, 0]), np.zeros((4, 2))
    tree = PlanTree(nodes, parents, (edge,))
    nodes[0, 0], edge[0, 0] = 99.0, 99.0
    assert tree.nodes[0, 0] == 0.0 and tree.edges[0][0, 0] == 0.0
    for copy in (tree, pickle.loads(pickle.dumps(tree))):
        assert copy == tree and not copy.nodes.flags.writeable and not copy.parents.flags.writeable
        assert not any(e.flags.writeable for e in copy.edges)
    with pytest.raises(ValueError, match=r"PlanTree.nodes must be \(K, 3\) poses"):
        PlanTree(np.zeros((2, 2)), parents)
    with pytest.raises(ValueError, match=r"PlanTree\.parents must be one integer per node"):
        PlanTree(np.zeros((2, 3)), [0.5, -1])
    with pytest.raises(ValueError, match=r"PlanTree.edges\[0\] must be \(K, 2\) positions"):
        PlanTree(np.zeros((2, 3)), parents, (np.zeros((3, 3)),))


def test_a_deferred_plan_tree_is_built_once_when_first_read_and_is_then_a_tree_like_any() -> None:
    """A planner's tree is built when someone reads it (a plan's plot), not inside the planner's time; once built
    it is checked, copied, pickled and compared as a tree made directly."""
    nodes, parents, edge = np.arange(6.0).reshape(2, 3), np.array([-1, 0]), np.zeros((4, 2))
    calls: list[int] = []

    def build() -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
        calls.append(1)
        return nodes, parents, (edge,)

    direct = PlanTree(nodes, parents, (edge,))
    for first_read in ("nodes", "parents", "edges", "pickle", "deepcopy", "repr", "eq"):
        calls.clear()
        tree = PlanTree.deferred(build)
        result = PlanResult(PlanStatus.SUCCESS, "p", path=nodes, tree=tree)
        assert not calls  # nothing built before it is read
        readers = {
            "pickle": lambda t: pickle.loads(pickle.dumps(t)),
            "deepcopy": deepcopy,
            "repr": repr,
            "eq": lambda t: t == direct,
        }
        read = readers.get(first_read)
        read(result.tree) if read is not None else getattr(result.tree, first_read)
        assert calls == [1]
        assert tree == direct and pickle.loads(pickle.dumps(result)).tree == direct and calls == [1]
        assert not tree.nodes.flags.writeable and not tree.edges[0].flags.writeable
        assert "_build" not in vars(tree) and repr(tree) == "PlanTree(2 nodes, 1 edges)"
    nodes[0, 0] = 99.0  # the built tree holds its own copies
    assert tree.nodes[0, 0] == 0.0
    with pytest.raises(AttributeError, match="has no attribute 'node'"):
        PlanTree.deferred(build).node  # noqa: B018
    bad = PlanTree.deferred(lambda: (np.zeros((2, 2)), parents, ()))
    for _ in range(2):  # checked when built, and not built while it fails
        with pytest.raises(ValueError, match=r"PlanTree.nodes must be \(K, 3\) poses"):
            bad.parents  # noqa: B018


def test_a_deferred_tree_read_by_threads_at_once_is_built_once_and_read_by_each() -> None:
    """Threads that read a deferred tree at once each built it, and one that found it built by another meanwhile
    raised AttributeError (9 in 3000 trials under a fine thread switch interval)."""
    nodes, parents = np.zeros((3, 3)), np.array([-1, 0, 1])
    calls: list[int] = []

    def slow_build() -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
        calls.append(1)
        time.sleep(0.05)  # the other threads arrive while it builds
        return nodes, parents, ()

    tree = PlanTree.deferred(slow_build)
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda name: getattr(tree, name), ["nodes", "parents", "edges", "nodes"]))
    assert calls == [1]
    assert got[0] is tree.nodes and got[3] is tree.nodes and got[1] is tree.parents and got[2] == ()


@pytest.mark.parametrize(
    ("parents", "edge", "message"),
    [
        ([-1, 0, 7], None, "node 2's parent 7 is no node"),
        ([-1, -5, 0], None, "node 1's parent -5 is no node"),
        ([1, 2, 0], None, "no node is a root"),
        ([-1, 2, 1], None, "node 1's parents lead round in a cycle, never to a root"),
        ([-1, 0, 1], [[0.0, np.nan]], r"PlanTree.edges\[0\] holds non-finite values"),
    ],
)
def test_a_tree_whose_parents_are_no_forest_or_whose_edges_are_not_finite_is_refused(parents, edge, message) -> None:
    """A plugin's tree with a parent past its nodes was taken and ended `nhsim plan --plot` in an IndexError; one of
    -5 was drawn to the wrong node; cycles, no root and NaN edges were taken too."""
    edges = () if edge is None else (np.array(edge),)
    with pytest.raises(ValueError, match=message):
        PlanTree(np.zeros((3, 3)), parents, edges)
    PlanTree(np.zeros((3, 3)), [-1, -1, 0])  # a forest: two roots


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("stats", None, "PlanResult.stats must be a dict"),
        ("planner", None, "PlanResult.planner must be the planner's name"),
        ("reason", 3, "PlanResult.reason must be a sentence"),
        ("tree", "junk", "PlanResult.tree must be a PlanTree or None, got str"),
        ("path", "abc", "PlanResult.path must be an array of numbers"),
    ],
)
def test_a_plan_result_refuses_fields_of_the_wrong_kind(field: str, value: object, message: str) -> None:
    """A plugin's plan with ``stats=None`` ended ``nhsim plan`` in a traceback from its repr (the command promises
    one line naming the planner), a tree of text likewise."""
    given = {"status": PlanStatus.SUCCESS, "planner": "x", "path": [[0.0, 0.0, 0.0]], field: value}
    with pytest.raises(ValueError, match=message):
        PlanResult(**given)  # type: ignore[arg-type]


@pytest.mark.parametrize("times", [[0.0, 2.0, 1.0], [0.0, 1.0, 1.0]])
def test_a_timed_plan_whose_times_do_not_increase_is_refused(times: list[float]) -> None:
    """The trajectory of such a plan dropped the rows out of order and ended at x = 1.5 m, where the plan ends at
    2.5 m, as a success."""
    path, controls = [[0.5, 0.5, 0.0], [1.5, 0.5, 0.0], [2.5, 0.5, 0.0]], [[0.25, 0.0]] * 3
    with pytest.raises(ValueError, match=r"PlanResult.times must strictly increase \(one stamp per pose\): times\[2\]"):
        PlanResult(PlanStatus.SUCCESS, "x", path=path, times=times, controls=controls)


def test_a_timed_plan_with_stamps_closer_than_a_nanosecond_is_no_trajectory() -> None:
    from planning.trajectory.from_plan import TrajectoryStatus, make_trajectory

    path, controls = [[0.5, 0.5, 0.0], [1.5, 0.5, 0.0], [2.5, 0.5, 0.0]], [[0.25, 0.0]] * 3
    plan = PlanResult(PlanStatus.SUCCESS, "x", path=path, times=[0.0, 1e-10, 2e-10], controls=controls)
    res = make_trajectory(plan, load_robot("turtlebot3"), World((0.0, 3.0, 0.0, 3.0)))
    assert res.status is TrajectoryStatus.INVALID and "times[1] = 1e-10 is not 1e-09 s after times[0]" in res.reason


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("dt", 0.0, "dt must be"),
        ("dt", "0.01", "dt must be"),
        ("dwell", -1.0, "dwell must be"),
        ("clearance", -0.1, "clearance must be"),
        ("corner_angle", -1.0, "corner_angle must be"),
        ("max_deviation", math.nan, "max_deviation must be"),
        ("retime", "yes", "retime must be True, False or None"),
    ],
)
def test_make_trajectory_checks_its_options(option: str, value: object, message: str) -> None:
    """Only ``to_trajectory`` checked them: ``make_trajectory(dt=0)`` was an OverflowError deep in the speed
    profile, a negative dwell or clearance passed silently, a negative corner angle made a 26 s drive of 227 s."""
    from planning.trajectory.from_plan import make_trajectory

    path = np.array([[0.5, 0.5, 0.0], [2.5, 0.5, 0.0]])
    with pytest.raises(ConfigError, match=message):
        make_trajectory(path, load_robot("turtlebot3"), World((0.0, 3.0, 0.0, 3.0)), **{option: value})


def test_a_run_and_a_job_equal_their_pickled_and_deep_copies() -> None:
    """``==`` of a job and its pickled copy raised numpy's 'truth value of an array is ambiguous' (the runs' logs
    compared their arrays with ``==``)."""
    import copy

    from sim import simulate_reference

    job = simulate_reference("open", reference="line", runs=["open_loop"])
    for other in (pickle.loads(pickle.dumps(job)), copy.deepcopy(job)):
        assert other == job and other.runs["open_loop"] == job.runs["open_loop"]
        assert other.runs["open_loop"].log == job.runs["open_loop"].log
    with pytest.raises(TypeError):
        hash(job.runs["open_loop"].log)


def test_optim_answers_a_start_that_is_the_goal_beside_an_obstacle_with_the_start() -> None:
    """Every planner answers it with the start alone; optim's NLP of no motion failed IPOPT's restoration whenever
    the world held an obstacle."""
    from planning import make_planner

    at = Pose2D(0.5, 0.5, 0.0)
    world = World((0.0, 3.0, 0.0, 3.0), (Circle((1.5, 1.5), 0.3),))
    res = make_planner("optim").plan(PlanProblem(world, load_robot("turtlebot3"), at, at, time_limit=10.0))
    assert res.success and res.path.shape == (1, 3) and res.length() == 0.0, res
    assert np.array_equal(res.path[0], at.as_array())
    inside = Pose2D(1.5, 1.3, 0.0)
    res = make_planner("optim").plan(PlanProblem(world, load_robot("turtlebot3"), inside, inside, time_limit=10.0))
    assert res.status is PlanStatus.INVALID_START


def test_text_where_numbers_go_is_named() -> None:
    from control.gains import FBLGains
    from planning import Polygon

    with pytest.raises(ConfigError, match=r"a pose needs exactly 3 numbers \[x, y, theta\], got \['a', 0, 0\]"):
        Pose2D.from_array(["a", 0, 0])
    with pytest.raises(ConfigError, match=r"polygon vertices must be \[x, y\] numbers"):
        Polygon((("a", "b"), (1.0, 0.0), (0.0, 1.0)))
    with pytest.raises(ConfigError, match="gains must be 'KP,KD'"):
        FBLGains.parse(None)  # type: ignore[arg-type]
    for name in (None, 5, ""):
        with pytest.raises(ConfigError, match=r"PlanProblem\.name must be a name"):
            PlanProblem(
                World((0.0, 3.0, 0.0, 3.0)), load_robot("turtlebot3"), Pose2D(1, 1, 0), Pose2D(2, 1, 0), name=name
            )  # type: ignore[arg-type]


def test_run_planner_names_a_plugin_whose_result_is_malformed() -> None:
    """``nhsim plan`` with a plugin planner returning ``stats=None`` ended in a traceback from the result's repr; the
    command promises one line naming the planner (docs/how-to/new-planner.md), which PlannerError gives."""
    from planning.errors import PlannerError
    from planning.planners.base import run_planner

    problem = PlanProblem(World((0.0, 3.0, 0.0, 3.0)), load_robot("turtlebot3"), Pose2D(1, 1, 0), Pose2D(2, 1, 0))

    class Bad:
        name = "bad"

        def __init__(self, stats: object) -> None:
            self.stats = stats

        def plan(self, problem: PlanProblem) -> PlanResult:
            return PlanResult(PlanStatus.SUCCESS, self.name, path=[[1.0, 1.0, 0.0]], stats=self.stats)  # type: ignore[arg-type]

    with pytest.raises(PlannerError, match=r"planner 'bad' raised ValueError: PlanResult\.stats must be a dict"):
        run_planner(Bad(None), "bad", problem)
    with pytest.raises(PlannerError, match=r"planner 'bad' returned stats\['code_s'\] = 'x': seconds"):
        run_planner(Bad({"code_s": "x"}), "bad", problem)


def test_a_robot_spec_where_a_robots_name_goes_is_told_to_give_the_name() -> None:
    """``simulate_plan(scenario, robot=load_robot("edumip"))`` said the edumip was an unknown robot."""
    from planning.core.robot import check_robot_name

    with pytest.raises(ConfigError, match=r"case: a robot is named here, not given as a RobotSpec: robot='edumip'"):
        check_robot_name("case", load_robot("edumip"))
