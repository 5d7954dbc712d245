"""The Python API's inputs: numpy's scalars are numbers (np.int64, np.float64 and np.float32 work wherever
a Python int or float does; they were refused as "not a finite number"), and an argument of the wrong
kind is named where it is given (it was an AttributeError deep inside), as are a scenario's own files' bad
values."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from control.base import TRACKERS, make_tracker
from control.estimation.amcl import AmclConfig
from control.estimation.ekf import EstimatorConfig
from control.fbl import uses_fbl_gains
from control.gains import FBLGains, UnstableGainsError, resolve_gains
from planning.core.geometry import Pose2D
from planning.core.nav2_map import read_map_yaml
from planning.core.robot import load_robot
from planning.core.world import Circle, World
from planning.errors import ConfigError, ScenarioError
from planning.scenario import load_scenario
from planning.trajectory.from_plan import TrajectoryError, to_trajectory
from planning.trajectory.references import make_reference
from sim.viz.replay import RenderSettings


def test_gains_tracker_periods_estimator_and_render_settings_take_numpy_scalars() -> None:
    assert FBLGains(kp=np.int64(9), kd=np.float32(6.0)) == FBLGains(kp=9.0, kd=6.0)
    robot = load_robot("turtlebot3")
    tracker = make_tracker("fbl", robot)
    tracker.reset(make_reference("line", robot, Pose2D(0.0, 0.0, 0.0)), np.float32(0.02))  # a numpy period
    cfg = EstimatorConfig(counts_per_rev=np.int64(4096), history_steps=np.int64(64), gate_prob=np.float32(0.99))
    assert type(cfg.history_steps) is int and type(cfg.gate_prob) is float and cfg.counts_per_rev == 4096.0
    settings = RenderSettings(width=np.int64(640), height=np.int32(480), fps=np.float64(30.0))
    assert (type(settings.width), settings.height) == (int, 480)
    for bad in (True, "640", 641):  # still refused: a bool, text, an odd size
        with pytest.raises(ConfigError):
            RenderSettings(width=bad)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="must be a finite number"):
        FBLGains(kp=np.float64("nan"))


def test_the_wrong_kind_of_argument_is_named_not_an_attribute_error_deep_inside() -> None:
    from planning import PlanProblem, load_scenario, make_planner
    from planning.core.world import Circle, World
    from planning.planners.registry import PLANNERS

    with pytest.raises(ConfigError, match=r"from_scenario takes a Scenario"):
        PlanProblem.from_scenario("edumip_map")  # type: ignore[arg-type]
    scenario = load_scenario("open")
    for name in PLANNERS:
        with pytest.raises(ConfigError, match=r"a planner plans a PlanProblem"):
            make_planner(name).plan(scenario)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"robot must be a RobotSpec"):
        make_tracker("fbl", "edumip")  # type: ignore[arg-type]
    for bad in (Circle((1, 1), 0.5), None, [(1, 1, 0.5)]):
        with pytest.raises(ConfigError, match=r"obstacle"):
            World((0, 5, 0, 5), bad)  # type: ignore[arg-type]
    assert len(World((0, 5, 0, 5), (o for o in [Circle((1, 1), 0.5)])).obstacles) == 1  # any iterable


def test_a_0d_array_is_refused_by_the_shared_number_checks_with_how_to_pass_it() -> None:
    """A 0-d numpy array (``np.array(0.5)``, ``np.squeeze`` of one value) is no ``numbers.Real``: the shared
    checks refused it as "not a finite number, got array(0.5)", which reads as a number. They still refuse it
    (some twenty modules check numbers inline; taking it in two helpers only would make the API uneven), now
    saying what it is and to pass float(x). What numpy's own reductions and indexing return are scalars, taken."""
    from planning.core.checks import check_number
    from planning.planners.sampling.rrt import TreeConfig
    from sim.physics.perturb import Perturbation

    arr = np.array([0.25, 0.5])
    for scalar in (np.float64(0.5)[()], np.mean(arr), arr[1], np.linalg.norm([0.3, 0.4]), np.array(0.5) * 1):
        assert TreeConfig(goal_bias=scalar).goal_bias == float(scalar) and type(TreeConfig().goal_bias) is float
        assert Perturbation(friction=scalar).friction == float(scalar)
    hint = r"got a 0-d numpy array \(array\(0\.5\)\); pass float\(x\)$"
    for zero_d in (np.array(0.5), np.squeeze(arr[1:])):
        with pytest.raises(ConfigError, match=r"^goal_bias must be a finite number in \[0, 1\], " + hint):
            TreeConfig(goal_bias=zero_d)
        friction = r"^perturbation friction must be a finite number in \[0.05, 10\] \(x\), "
        with pytest.raises(ConfigError, match=friction + hint):
            Perturbation(friction=zero_d)
    with pytest.raises(ConfigError, match=r">= 1, got a 0-d numpy array \(array\(3\)\); pass int\(x\)$"):
        TreeConfig(max_iterations=np.array(3))
    with pytest.raises(ConfigError, match=r"must be an integer, got a 0-d numpy array \(array\(3\.5\)\)$"):
        check_number("n", np.array(3.5), integer=True)  # no int(x) advice: it would cut 3.5 to 3
    with pytest.raises(ConfigError, match=r"got array\(\[0\.5\]\)$"):  # a 1-element array stays an array
        check_number("x", np.array([0.5]))


def test_check_number_takes_an_exclusive_upper_bound_and_says_it_as_the_lower_one() -> None:
    """``below`` is to ``at_most`` what ``above`` is to ``at_least``: a probability in (0, 1) says so."""
    from planning.core.checks import check_number

    assert check_number("p", 0.5, above=0.0, below=1.0) == 0.5
    assert check_number("n", np.int64(4), integer=True, at_least=0, below=5) == 4
    for bad in (0.0, 1.0, 2.0):
        with pytest.raises(
            ConfigError, match=rf"^p must be a finite number in \(0, 1\) \(-\), got {bad}; e\.g\. 0\.9$"
        ):
            check_number("p", bad, above=0.0, below=1.0, unit="-", fix="e.g. 0.9")
    with pytest.raises(ConfigError, match=r"^n must be an integer in \[0, 5\), got 5$"):
        check_number("n", 5, integer=True, at_least=0, below=5)
    with pytest.raises(ConfigError, match=r"^q must be a finite number < 1, got 1\.0$"):
        check_number("q", 1.0, below=1.0)
    with pytest.raises(ConfigError, match=r"^r must be a finite number > 0 and >= 0\.5 and < 1, got 0\.25$"):
        check_number("r", 0.25, above=0.0, at_least=0.5, below=1.0)


def test_to_trajectory_names_a_robot_name_a_nan_and_an_unknown_option() -> None:
    """A robot's name was "AttributeError: 'str' object has no attribute 'footprint'", a NaN in the path
    "no usable (N, 3) path (shape (2, 3))", an unknown option a raw TypeError of make_trajectory's."""
    from planning import load_scenario, to_trajectory
    from planning.trajectory.from_plan import TrajectoryError, make_trajectory

    robot, world = load_robot("turtlebot3"), load_scenario("open").world
    path = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    with pytest.raises(ConfigError, match=r"^to_trajectory: robot must be a RobotSpec \(load_robot\('turtlebot3'\)\)"):
        to_trajectory(path, "turtlebot3", world)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"^to_trajectory: world must be a World"):
        to_trajectory(path, robot, "open")  # type: ignore[arg-type]
    bad = path.copy()
    bad[1, 0] = np.nan
    with pytest.raises(TrajectoryError, match=r"non-finite values \(NaN or infinite\) in 1 of its 2 poses \(rows 1\)"):
        to_trajectory(bad, robot, world)
    with pytest.raises(
        TrajectoryError, match=r"no usable \(N, 3\) path \(shape \(2, 2\)\); give one row \[x, y, theta\]"
    ):
        to_trajectory(path[:, :2], robot, world)
    with pytest.raises(ConfigError, match=r"^to_trajectory: unknown option\(s\) speed; valid options: goal, .*margin"):
        to_trajectory(path, robot, world, speed=1.0)
    with pytest.raises(ConfigError, match=r"robot must be a RobotSpec"):
        make_trajectory(path, "turtlebot3", world)  # type: ignore[arg-type]


def test_a_single_pose_path_is_a_stand_still_of_dwell_as_a_start_that_is_the_goal() -> None:
    """Documented, not refused: the planners return the start alone, as a success, when it is the goal
    (``nhsim plan`` reports length 0), and its trajectory is the stand-still there."""
    from planning import PlanProblem, load_scenario, make_planner, to_trajectory

    robot, scenario = load_robot("turtlebot3"), load_scenario("open")
    plan = make_planner("rrt").plan(PlanProblem.from_scenario(scenario, robot=robot))
    assert plan.success and plan.path.shape == (1, 3)
    for path in (plan, np.zeros((1, 3))):
        traj = to_trajectory(path, robot, scenario.world, dwell=0.5)
        assert traj.segment_kinds == ("hold",) and traj.duration == pytest.approx(0.5)
        assert not np.any(traj.vel)


def test_from_flat_densify_and_load_robot_name_a_wrong_argument() -> None:
    """Were numpy's IndexError / ValueError (from_flat, densify_path) and os's TypeError (load_robot(None))."""
    from planning import Trajectory, densify_path

    t, xy, d = [0.0, 1.0, 2.0], [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], [[1.0, 0.0]] * 3
    for args, kwargs, message in [
        ((t, xy, [1.0, 1.0, 1.0], d), {}, r"from_flat: dxy must have shape \(3, 2\) \(one \[dx/dt, dy/dt\] row"),
        ((t, xy[:2], d, d), {}, r"from_flat: xy must have shape \(3, 2\) \(one \[x, y\] row per time\), got \(2, 2\)"),
        ((t, xy, d, d), {"direction": [1, -1]}, r"direction must be \+1 or -1, or an array of one per time \(3,\)"),
        (([0.0], xy[:1], d[:1], d[:1]), {}, r"t must be a 1-D array of at least 2 times, got shape \(1,\)"),
    ]:
        with pytest.raises(ConfigError, match=message):
            Trajectory.from_flat(*args, **kwargs)
    assert Trajectory.from_flat(t, xy, d, [[0.0, 0.0]] * 3, direction=[1, 1, 1]).duration == 2.0
    with pytest.raises(ConfigError, match=r"densify_path needs an \(N, 3\) path of poses \[x, y, theta\], got shape"):
        densify_path(np.array([[0.0, 0.0], [1.0, 0.0]]), 0.1)
    with pytest.raises(ConfigError, match=r"a robot is named by text: one of edumip, .*turtlebot3 .*got None"):
        load_robot(None)  # type: ignore[arg-type]


def test_random_scenario_takes_integer_seeds_from_0_and_known_robots() -> None:
    """Seed -1001 was numpy's ValueError, 2.5 a SeedSequence TypeError, True a world named "randomTrue", -3 one
    named "random-3" that load_scenario refused; an unknown robot was caught only when the world was used."""
    from planning import load_scenario, random_scenario

    for seed in (-1001, -3, 2.5, True, "3"):
        with pytest.raises(ConfigError, match=rf"^random_scenario: seed must be an integer >= 0, got {seed!r}; "):
            random_scenario("edumip", seed)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"^random_scenario: unknown robot 'burger': choose one of edumip, "):
        random_scenario("burger", 3)
    drawn = random_scenario("edumip", np.int64(3))
    assert drawn.name == "random3" and drawn.world == load_scenario("random3").world


# ---- edge cases of the Python API: nhsim's own errors, never a Python one from deep inside -----------------------


def test_fbl_command_before_reset_is_named_not_a_zero_division() -> None:
    """It was ``ZeroDivisionError: division by zero`` from the compiled period (its period was still 0)."""
    tracker = make_tracker("fbl", load_robot("turtlebot3"))
    for t in (0.0, 5.0, -1.0):
        with pytest.raises(ConfigError, match=r"^tracker 'fbl': command\(t, x, y, theta\) was called before reset"):
            tracker.command(t, 0.0, 0.0, 0.0)
    tracker.reset(make_reference("line", load_robot("turtlebot3"), Pose2D(0.0, 0.0, 0.0)), 0.02)
    assert all(np.isfinite(tracker.command(0.0, 0.0, 0.0, 0.0)))


def test_every_tracker_names_a_command_before_reset_alike() -> None:
    """mpc raised a bare AssertionError, the others RuntimeErrors of their class names: one nhsim error now."""
    for name in sorted(TRACKERS):
        tracker = make_tracker(name, load_robot("turtlebot3"))
        with pytest.raises(ConfigError, match=rf"^tracker '{name}': command\(t, x, y, theta\) was called before reset"):
            tracker.command(0.0, 0.0, 0.0, 0.0)


def test_a_control_period_in_milliseconds_is_refused_by_every_tracker_and_1_s_is_not() -> None:
    """``reset(ref, dt=20.0)`` (20 ms meant) was accepted. The bound is the simulator's slowest control rate."""
    from control.base import MAX_CONTROL_PERIOD
    from sim.physics.motors import MIN_CONTROL_RATE

    assert MAX_CONTROL_PERIOD == 1.0 / MIN_CONTROL_RATE  # no rate the simulator runs is refused here
    robot = load_robot("turtlebot3")
    ref = make_reference("circle", robot, Pose2D(0.0, 0.0, 0.0))
    for name in TRACKERS:
        for dt in (20.0, 1.001):
            with pytest.raises(
                ConfigError,
                match=rf"^tracker '{name}': reset\(dt\)'s control period dt must be at most 1 s .*got {dt:g} s; "
                r"dt is in seconds, not milliseconds: pass 1 / control rate, e.g. 0.02 for 50 Hz",
            ):
                make_tracker(name, robot).reset(ref, dt)
        slow = {"gains": FBLGains(kp=1.0, kd=1.5)} if uses_fbl_gains(name) else {}  # (stable at 1 Hz)
        make_tracker(name, robot, **slow).reset(ref, 1.0)  # 1 Hz, the slowest rate: taken


def test_gains_a_control_period_cannot_keep_stable_are_refused_by_the_trackers_reset_as_by_a_case() -> None:
    """``make_tracker("fbl", robot, gains=FBLGains(kp=1e9, kd=1e9)).reset(ref, 0.02)`` was taken, its commands
    jumping between the speed limits, where ``simulate_reference(..., gains=...)`` refused them."""
    robot = load_robot("turtlebot3")
    ref = make_reference("line", robot, Pose2D(0.0, 0.0, 0.0))
    takers = [name for name in TRACKERS if uses_fbl_gains(name)]
    assert {"fbl", "segmented"} <= set(takers)
    for name in takers:
        for gains, dt in ((FBLGains(kp=1e9, kd=1e9), 0.02), (FBLGains(), 1.0), (FBLGains(kp=30.0, kd=150.0), 0.02)):
            with pytest.raises(UnstableGainsError, match=rf"^tracker '{name}' reset with dt = {dt:g} s: FBL gains "):
                make_tracker(name, robot, gains=gains).reset(ref, dt)
        make_tracker(name, robot, gains=FBLGains(kp=30.0, kd=150.0)).reset(ref, 0.005)  # stable at 200 Hz


def test_default_gains_a_slow_rate_cannot_keep_stable_are_refused_by_the_case_before_any_work() -> None:
    """A case refused only gains it was given: at 2.5 Hz (a rate the physics takes) the defaults passed, then the
    trackers' reset refused them after the planning; compare lost the runs of the trackers before fbl's."""
    from sim.pipeline.case import Case
    from sim.pipeline.simulate import simulate_reference
    from sim.tools.compare import compare_trackers

    slow = {"control_rate": 2.5, "robot": "turtlebot3", "localiser": "fixes", "sensors": "fix_rate=2.5"}
    said = "FBL gains Kp=9, Kd=6 make the error dynamics unstable at the control rate 2.5 Hz"
    with pytest.raises(UnstableGainsError, match=f"^case open:figure8: {said}"):
        simulate_reference("open", reference="figure8", **slow)  # type: ignore[arg-type]
    mpc_case = Case("open", reference="line", tracker="mpc", **slow)  # type: ignore[arg-type]  # mpc takes none
    with pytest.raises(UnstableGainsError, match=f"^the default gains of tracker 'fbl': {said}"):
        compare_trackers(mpc_case, ["mpc", "fbl"])


def test_densify_path_and_path_length_refuse_with_nhsim_errors() -> None:
    """``densify_path(p, 0.0)`` was a plain ValueError, a NaN in its path a RuntimeWarning and an array of
    garbage, ``path_length([1.0, 2.0, 3.0])`` (one pose, flat) a silent 0.0."""
    import math
    import warnings

    from planning import densify_path, path_length
    from planning.core.geometry import path_steps

    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    for spacing in (0.0, -1.0, math.nan, math.inf, "0.02"):
        with pytest.raises(
            ConfigError, match=r"^densify_path: spacing must be > 0 m \(a finite number\), got .*; e\.g\. 0\.02$"
        ):
            densify_path(p, spacing)  # type: ignore[arg-type]
    assert densify_path(p, np.float32(0.5)).shape == (3, 3) and densify_path(p, 1).shape == (2, 3)  # numbers
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy RuntimeWarning before the error
        for column in (0, 2):  # a NaN position, a NaN heading
            bad = np.vstack([p, [[2.0, 0.0, 0.0]]])
            bad[1, column] = np.nan
            with pytest.raises(
                ConfigError,
                match=r"^densify_path: the path has non-finite values \(NaN or infinite\) in 1 of its 3 "
                r"poses \(rows 1\); give finite poses$",
            ):
                densify_path(bad, 0.1)
    for flat in ([1.0, 2.0, 3.0], np.zeros(3)):
        with pytest.raises(
            ConfigError,
            match=r"^path_length: path must be an \(N, 2\) or \(N, 3\) array .*got shape \(3,\); a single "
            r"pose \[x, y, theta\] is the one-row path \[\[x, y, theta\]\]$",
        ):
            path_length(flat)
    assert path_length([[1.0, 2.0, 3.0]]) == 0.0 and path_length([[0, 0], [3, 4]]) == 5.0
    with pytest.raises(ConfigError, match=r"^path_length: path must be .*\(numbers\), got str"):
        path_length("0,0;1,1")
    with pytest.raises(ConfigError, match=r"^path_steps: counting turns \(radius 0.1\) needs \(N, 3\) poses"):
        path_steps([[0.0, 0.0], [1.0, 0.0]], 0.1)


def test_diffdrive_refuses_with_a_config_error_naming_the_field_and_unit() -> None:
    """Was a plain ValueError (``DiffDrive.wheel_radius must be > 0, got 0.0``); infinity was accepted."""
    from control.diffdrive import DiffDrive

    for args, field, unit in [((0.0, 0.16, 6.67), "wheel_radius", "m"), ((0.033, -1, 6.67), "track_width", "m")]:
        with pytest.raises(ConfigError, match=rf"^DiffDrive\.{field} must be a finite number > 0 \({unit}\), got "):
            DiffDrive(*args)
    with pytest.raises(ConfigError, match=r"^DiffDrive\.max_wheel_speed must be .* \(rad/s\), got inf; DiffDrive"):
        DiffDrive(0.033, 0.16, np.inf)
    assert DiffDrive(0.033, 0.16, np.int64(6)).max_wheel_speed == 6.0


def test_pose2d_takes_any_finite_heading_in_radians_and_says_so() -> None:
    """90 is a valid angle (radians): kept as given; the docstring said no unit in its summary."""
    assert Pose2D(0, 0, 90).theta == 90.0
    assert Pose2D.__doc__ is not None and "radians" in Pose2D.__doc__ and "math.radians(90)" in Pose2D.__doc__


# ---- planners of your own: register_planner checks what it is given, as register_tracker does ---------------------


def test_register_planner_refuses_a_bad_name_target_or_a_taken_name(monkeypatch: pytest.MonkeyPatch) -> None:
    """It took anything: "noattr" failed later as ``ValueError: not enough values to unpack``, and "rrt" silently
    replaced the built-in planner."""
    from planning import make_planner, register_planner
    from planning.core.plugins import BUILT_IN
    from planning.planners.registry import PLANNERS
    from planning.planners.sampling.rrt import RRT, BiRRT

    for name in ("", "my planner", "a,b", None):
        with pytest.raises(ConfigError, match=r"^register_planner: name must be non-empty text without commas"):
            register_planner(name, RRT)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"^register_planner\('x'\): target 'noattr' is not 'package.module:Attr"):
        register_planner("x", "noattr")
    with pytest.raises(ConfigError, match=r"^register_planner\('x'\): target must be a planner class .*got int"):
        register_planner("x", 42)  # type: ignore[arg-type]
    with pytest.raises(
        ConfigError,
        match=r"^register_planner: planner 'rrt' is already registered \(built in\) as "
        r"planning.planners.sampling.rrt:RRT; "
        r"choose another name, or pass replace=True to replace it$",
    ):
        register_planner("rrt", "mypackage.ttt:TurnDriveTurn")
    assert PLANNERS["rrt"] == "planning.planners.sampling.rrt:RRT"
    register_planner("rrt", "planning.planners.sampling.rrt:RRT")  # the same target again: no change
    assert PLANNERS.origin("rrt") == BUILT_IN  # not even of who registered it (simulate --all runs built-in ones)
    monkeypatch.setitem(PLANNERS, "rrt", PLANNERS["rrt"])  # restored after the test
    monkeypatch.setattr(PLANNERS, "origins", dict(PLANNERS.origins))
    register_planner("rrt", BiRRT, replace=True)
    assert isinstance(make_planner("rrt"), BiRRT)


def test_a_planner_that_cannot_be_made_is_a_config_error_naming_it(monkeypatch: pytest.MonkeyPatch) -> None:
    from planning import make_planner, register_planner
    from planning.core.plugins import BY_CODE
    from planning.planners.registry import PLANNERS

    monkeypatch.setitem(PLANNERS, "x", "")  # removed after the test
    for target, message in [
        ("nosuchpackage.mod:Planner", r"cannot load its factory 'nosuchpackage.mod:Planner': ModuleNotFoundError: "),
        ("planning.core.geometry:NoSuch", r"cannot load its factory .*: AttributeError: "),
        ("planning.planners.registry:PLANNERS", r"its factory 'planning.planners.registry:PLANNERS' is not callable"),
    ]:
        register_planner("x", target, replace=True)
        with pytest.raises(ConfigError, match=rf"^planner 'x' \({BY_CODE}\): {message}"):
            make_planner("x")
    register_planner("x", lambda: 0, replace=True)
    with pytest.raises(
        ConfigError,
        match=r"^planner 'x': its factory returned 0 \(int\), which has no plan\(problem\) method; a planner has",
    ):
        make_planner("x")
    PLANNERS["x"] = "noattr"  # set directly, around register_planner's check
    with pytest.raises(ConfigError, match=rf"^planner 'x' \({BY_CODE}\): its factory 'noattr' is not 'package.module"):
        make_planner("x")


def test_the_new_planner_page_registers_plans_and_simulates_its_planner(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """docs/how-to/new-planner.md's block runs as printed: each print's output is the comment beside it."""
    import re
    import sys
    import types

    from planning import Planner, make_planner
    from planning.planners.registry import PLANNERS
    from sim.cli.main import main
    from tests.doc_blocks import block_of

    block = block_of("docs/how-to/new-planner.md")
    monkeypatch.setitem(PLANNERS, "turn-drive-turn", "")  # the page's registration is undone after the test
    module = types.ModuleType("tdt")
    monkeypatch.setitem(sys.modules, "tdt", module)
    exec(compile(block.code, block.name, "exec"), module.__dict__)  # imported: it registers, and prints nothing
    assert PLANNERS["turn-drive-turn"] is module.TurnDriveTurn and capsys.readouterr().out == ""
    monkeypatch.setitem(PLANNERS, "turn-drive-turn", "")
    module = types.ModuleType("__main__")  # run as a script (python mypackage/tdt.py)
    exec(compile(block.code, block.name, "exec"), module.__dict__)
    printed = capsys.readouterr().out.splitlines()
    expected = re.findall(r"^    print\(.*\)  # (.*)$", block.code, flags=re.M)
    assert len(expected) == 3 and printed == expected
    assert PLANNERS["turn-drive-turn"] is module.TurnDriveTurn
    planner: Planner = make_planner("turn-drive-turn", spacing=0.05)
    assert planner.name == "turn-drive-turn"
    with pytest.raises(ConfigError, match=r"unknown option\(s\) speed for planner 'turn-drive-turn'"):
        make_planner("turn-drive-turn", speed=1.0)
    with pytest.raises(ConfigError, match=r"a planner plans a PlanProblem"):
        planner.plan(module.scenario)
    assert main(["plan", "--scenario", "simple_motion", "--planner", "turn-drive-turn", "--quiet"]) == 0


# ---- arguments checked where they are given: a push, smoothing options, robots, worlds, starts, jobs, paths --------


def test_a_perturbation_push_is_checked_when_made_like_its_other_fields() -> None:
    """``Perturbation(push="1,2")`` and ``push=(nan, 0)`` were accepted; the run then failed with
    ``TypeError: '>=' not supported between instances of 'str' and 'float'`` deep in the physics."""
    from sim.physics.perturb import Perturbation

    pair = r"^perturbation push must be a pair \(impulse \[N s\], time \[s\]\) or None, got "
    fix = r"; e\.g\. Perturbation\(push=\(0\.05, 10\.0\)\) \(Perturbation\.parse\('push=0\.05@10'\) reads the "
    for bad, given in [("1,2", r"'1,2'"), ((0.05,), r"\(0\.05,\)"), (0.05, r"0\.05"), ((0.05, 1.0, 2.0), r"\(0\.05, ")]:
        with pytest.raises(ConfigError, match=pair + given + (fix if given != r"\(0\.05, " else "")):
            Perturbation(push=bad)  # type: ignore[arg-type]
    for bad, message in [
        ((np.nan, 0.0), r"^perturbation push impulse must be a finite number in \[-1, 1\] \(N s\), got nan$"),
        ((2.0, 1.0), r"^perturbation push impulse must be a finite number in \[-1, 1\] \(N s\), got 2\.0$"),
        (("0.05", 1.0), r"^perturbation push impulse must be .*, got '0\.05'$"),
        ((0.05, -1.0), r"^perturbation push time must be a finite number in \[0, 1e\+06\] \(s\), got -1\.0$"),
        ((0.05, np.inf), r"^perturbation push time must be .*, got inf$"),
    ]:
        with pytest.raises(ConfigError, match=message):
            Perturbation(push=bad)  # type: ignore[arg-type]
    for good in ([0.05, 10], np.array([0.05, 10.0]), (np.float32(0.05), np.int64(10))):
        push = Perturbation(push=good).push  # type: ignore[arg-type]
        assert push == pytest.approx((0.05, 10.0)) and type(push) is tuple and type(push[1]) is float
    assert Perturbation.parse("push=-0.05@3").push == (-0.05, 3.0) and Perturbation().push is None


def test_smoothing_options_are_checked_on_entry_naming_each() -> None:
    """``clearance="0.1"`` was a TypeError deep inside the fit, ``dt=-0.01`` "Trajectory.t must be strictly
    increasing", ``dt=10`` a 5-sample trajectory and ``margin=-1`` a plain ValueError. The options that reach the
    smoothing (clearance, max_deviation, corner_angle) are checked there; ``check_options`` checks them all."""
    import inspect
    import math

    from planning import load_scenario, to_trajectory
    from planning.trajectory.from_plan import make_trajectory
    from planning.trajectory.smoothing import MAX_SAMPLE_PERIOD, check_options

    robot, world = load_robot("turtlebot3"), load_scenario("open").world
    path = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, math.pi / 2]])
    for options, message in [
        ({"clearance": "0.1"}, r"clearance must be a finite number >= 0 \(m\), got '0\.1'; the footprint clearance"),
        ({"clearance": -0.01}, r"clearance must be a finite number >= 0 \(m\), got -0\.01"),
        ({"max_deviation": 0.0}, r"max_deviation must be a finite number > 0 \(m\), got 0\.0; the distance allowed"),
        ({"corner_angle": 90}, r"corner_angle must be .* in \[0, 3\.14159\] \(rad\), got 90; for degrees use math"),
    ]:
        with pytest.raises(ConfigError, match=r"^to_trajectory: " + message):
            to_trajectory(path, robot, world, **options)
    assert to_trajectory(path, robot, world, clearance=None, corner_angle=np.float64(1.0)).duration > 0
    assert MAX_SAMPLE_PERIOD == 0.1
    for options, message in [
        ({"dt": -0.01}, r"dt must be a finite number in \[0\.0001, 0\.1\] \(s\), got -0\.01; the trajectory's sample"),
        ({"dt": 10}, r"dt must be a finite number in \[0\.0001, 0\.1\] \(s\), got 10; .*collision-checked curve"),
        ({"dt": 1e-9}, r"dt must be a finite number in \[0\.0001, 0\.1\] \(s\), got 1e-09"),
        ({"margin": -1}, r"margin must be a finite number in \(0, 1\] \(a fraction of the robot's limits\), got -1"),
        ({"dwell": "0.3"}, r"dwell must be a finite number in \[0, 60\] \(s\), got '0\.3'"),
        ({"snap_tolerance": math.nan}, r"snap_tolerance must be a finite number >= 0 \(m\), got nan"),
        ({"retime": "no"}, r"retime must be True, False or None \(by the plan\), got 'no'"),
        ({"keep_loops": 1}, r"keep_loops must be True or False, got 1"),
        ({"goal": (1.0, 1.0, 0.0)}, r"goal must be a Pose2D or None: pass Pose2D\(1\.0, 1\.0, 0\.0\), got tuple"),
        ({"name": 3}, r"name must be text or None, got 3"),
    ]:
        with pytest.raises(ConfigError, match=r"^to_trajectory: " + message):
            check_options(options)
        with pytest.raises(ConfigError, match=r"^to_trajectory: " + message):
            to_trajectory(path, robot, world, **options)  # the entry point checks them all
    params = inspect.signature(make_trajectory).parameters.values()
    defaults = {p.name: p.default for p in params if p.kind is p.KEYWORD_ONLY}
    assert check_options(defaults) == defaults  # every default passes
    given = check_options({"dt": np.float32(0.02), "margin": 1, "retime": np.bool_(True), "speed": 3})
    assert given == {"dt": pytest.approx(0.02), "margin": 1.0, "retime": True, "speed": 3}  # unknown: the caller's
    assert type(given["margin"]) is float and type(given["retime"]) is bool


def test_references_simulators_and_videos_name_an_argument_of_the_wrong_kind(tmp_path: Path) -> None:
    """Each was an AttributeError from inside (``'tuple' object has no attribute 'theta'``, ``'str' object has
    no attribute 'scene'``, ``'tuple' object has no attribute 'obstacles'``, ``'NoneType' object has no attribute
    'model'``) or pathlib's TypeError (``write_video(job, 5)``)."""
    from types import SimpleNamespace

    from sim.physics.simulator import Simulator
    from sim.viz.job_video import write_video

    robot = load_robot("edumip")
    for start, fix in (((0, 0, 0), r"Pose2D\(0, 0, 0\), got tuple"), (np.zeros(3), r"Pose2D\.from_array\(values\)")):
        with pytest.raises(ConfigError, match=r"^reference 'circle': start must be a Pose2D: pass " + fix):
            make_reference("circle", robot, start)  # type: ignore[arg-type]
    with pytest.raises(
        ConfigError, match=r"^reference 'line': start must be a Pose2D: pass Pose2D\(x, y, theta\), got"
    ):
        make_reference("line", robot, None)  # type: ignore[arg-type]
    with pytest.raises(
        ConfigError, match=r"^reference 'figure8': robot must be a RobotSpec \(load_robot\('edumip'\)\)"
    ):
        make_reference("figure8", "edumip", Pose2D(0.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"^Simulator: robot must be a RobotSpec \(load_robot\('edumip'\)\), got 'e"):
        Simulator("edumip")  # type: ignore[arg-type]
    with pytest.raises(
        ConfigError,
        match=r"^Simulator: world must be a World or None \(an empty floor\): pass World\(\(0, 1, 0, 1\)\) for bounds "
        r"alone, got tuple \(0, 1, 0, 1\)$",
    ):
        Simulator(robot, (0, 1, 0, 1))  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"world must be .*: pass load_scenario\('open'\)\.world, got str 'open'$"):
        Simulator(robot, "open")  # type: ignore[arg-type]
    video = tmp_path / "run.mp4"
    with pytest.raises(ConfigError, match=r"^write_video: job must be a simulated job \(what simulate_plan, "):
        write_video(None, video)  # type: ignore[arg-type]
    job = SimpleNamespace(trajectory=None, logs={}, model=None)  # what the checks look for, no simulation
    with pytest.raises(ConfigError, match=r"^write_video: path must be a file name ending in \.mp4 .*, got 5; e\.g\."):
        write_video(job, 5)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"^write_video: settings must be a RenderSettings or None .*, got \(640, "):
        write_video(job, video, (640, 480))  # type: ignore[arg-type]
    assert not video.exists() and not any(tmp_path.iterdir())


def test_path_length_and_densify_path_refuse_a_bad_radius_shape_nan_or_spacing(monkeypatch: pytest.MonkeyPatch) -> None:
    """``path_length(p, radius=-1)`` was 0.0, an (N, 4) array was measured, a NaN gave nan, the (N, 2) error
    named path_steps, and ``densify_path(p, 1e-9)`` was numpy's MemoryError (7.28 TiB)."""
    import math

    from planning import densify_path, path_length
    from planning.core import geometry
    from planning.core.geometry import path_steps

    p = [[0.0, 0.0, 0.0], [1.0, 0.0, 1.0]]
    radius = r"radius must be a finite number >= 0 \(m\), got {}; the robot's radius, or 0 to count positions only$"
    for bad, shown in [(-1, "-1"), (math.nan, "nan"), (math.inf, "inf"), ("0.1", "'0.1'")]:
        for call, name in [(path_length, "path_length"), (path_steps, "path_steps")]:
            with pytest.raises(ConfigError, match=rf"^{name}: " + radius.format(shown)):
                call(p, radius=bad)  # type: ignore[arg-type]
        with pytest.raises(ConfigError, match=r"^densify_path: " + radius.format(shown)):
            densify_path(p, 0.1, radius=bad)  # type: ignore[arg-type]
    assert path_length(p, radius=np.float32(0.1)) == pytest.approx(1.1) and path_length(p, radius=0) == 1.0
    with pytest.raises(
        ConfigError, match=r"^path_length: path must be .*got shape \(2, 4\); pass path\[:, :3\] for the poses alone$"
    ):
        path_length([[0, 0, 0, 0], [3, 4, 0, 0]])
    nan_row = r"^path_length: the path has non-finite values \(NaN or infinite\) in 1 of its 3 poses \(rows 1\); "
    for bad, r in [([[0, 0, 0], [math.nan, 0, 0], [1, 1, 1]], 0.0), ([[0, 0, 0], [0, 0, math.inf], [1, 1, 1]], 0.1)]:
        with pytest.raises(ConfigError, match=nan_row + "give finite poses$"):
            path_length(bad, radius=r)
    assert path_length([[0, 0, 0], [0, 0, math.nan], [3, 4, 0]]) == 5.0  # a heading the length does not read
    with pytest.raises(ConfigError, match=r"^path_length: counting turns \(radius 0\.1\) needs \(N, 3\) poses"):
        path_length([[0.0, 0.0], [1.0, 0.0]], radius=0.1)
    with pytest.raises(
        ConfigError,
        match=r"^densify_path: spacing 1e-09 m would cut the path's 1000 m into 1e\+12 poses \(at most 10,000,000\); "
        r"give a larger spacing, at least 0\.00011 m \(e\.g\. 0\.02\)$",
    ):
        densify_path([[0, 0, 0], [1000, 0, 0]], 1e-9)
    with pytest.raises(ConfigError, match=r"^densify_path: spacing 1e-300 m would cut .* into 1e\+303 poses"):
        densify_path([[0, 0, 0], [1000, 0, 0]], 1e-300)
    monkeypatch.setattr(geometry, "MAX_DENSE_POSES", 11)  # the bound itself is taken, one more pose is not
    assert densify_path([[0, 0, 0], [1, 0, 0]], 0.1).shape == (11, 3)
    with pytest.raises(ConfigError, match=r"into 13 poses \(at most 11\); give a larger spacing, at least 0\.12 m"):
        densify_path([[0, 0, 0], [1, 0, 0]], 0.09)


@pytest.mark.parametrize(
    ("keywords", "said"),
    [
        ({"feedback": "fbl"}, "unknown keyword 'feedback' (did you mean 'tracker'?); "),
        ({"trackr": "fbl"}, "unknown keyword 'trackr' (did you mean 'tracker'?); "),
        ({"time_limit": 3.0}, "unknown keyword 'time_limit' (did you mean planning=PlanOptions(time_limit=...)?); "),
        ({"colour": 1, "sead": 2}, "unknown keywords 'colour', 'sead' (did you mean 'seed'?); "),
    ],
)
def test_a_keyword_that_is_no_field_of_a_case_is_named_with_the_field_meant(
    keywords: dict[str, Any], said: str
) -> None:
    """``simulate_plan(..., feedback="stanley")`` (the command line's --feedback) said only "Case.__init__() got an
    unexpected keyword argument 'feedback'"."""
    from sim import simulate_plan

    with pytest.raises(ConfigError) as err:
        simulate_plan("parallel_park", **keywords)
    assert str(err.value).startswith(f"simulate_plan: {said}the keywords are the fields of a case"), str(err.value)
    fields = "robot, reference, planner, tracker, seed, control_rate, gains, perturbation, name, params, fast"
    more = "planning, build_seed, sensors, noise_seed, trajectory_file, localiser, lidar, amcl, initial_pose, motors"
    assert str(err.value).endswith(f": {fields}, {more}")


# ---- the API's and a scenario file's edges (each raised something else, or ran on, before) -----------
TB3 = load_robot("turtlebot3")


def test_a_path_that_is_no_numbers_is_named() -> None:  # ValueError: could not convert string to float
    with pytest.raises(ConfigError, match=r"to_trajectory takes a PlanResult or an \(N, 3\) path of poses"):
        to_trajectory("abc", TB3, World((0.0, 2.0, 0.0, 1.2)))  # type: ignore[arg-type]


def test_a_path_that_leaves_the_world_says_so() -> None:
    """It said "could not be smoothed: collision after 5 refinements (clearance -inf m ...)"."""
    path = np.array([[0.4, 0.4, 0.0], [5.0, 0.4, 0.0]])
    with pytest.raises(TrajectoryError, match=r"leaves the world's bounds \(x 0..2, y 0..1.2\) at \(5.00, 0.40\)"):
        to_trajectory(path, TB3, World((0.0, 2.0, 0.0, 1.2)))


def test_a_path_through_an_obstacle_is_named_as_the_cause() -> None:
    """It said "could not be smoothed: collision after 5 refinements (clearance -inf m, ...); plan with more
    clearance or allow a larger deviation", of a path that no smoothing within the deviation could clear."""
    world = World((0.0, 3.0, 0.0, 3.0), (Circle((1.5, 1.5), 0.3),))
    path = np.array([[0.5, 1.5, 0.0], [1.0, 1.5, 0.0], [2.5, 1.5, 0.0]])
    said = (
        r"the path given collides before any smoothing: at \(1.1\d\d, 1.500, 0.000\), between path\[1\] and "
        r"path\[2\] of its 3 poses, the turtlebot3's footprint overlaps the circle at x 1.2..1.8, y 1.2..1.8 by"
    )
    with pytest.raises(TrajectoryError, match=said):
        to_trajectory(path, TB3, world)
    clear = np.array([[0.5, 0.5, 0.0], [2.5, 0.5, 0.0]])
    assert to_trajectory(clear, TB3, world).duration > 0.0


def test_a_time_that_is_no_number_is_named() -> None:  # ValueError from numpy
    trajectory = make_reference("line", TB3, Pose2D(0.0, 0.0, 0.0))
    with pytest.raises(ConfigError, match=r"Trajectory.sample: the time must be a number \[s\], got str 'a'"):
        trajectory.sample("a")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"Trajectory.sample: the time must be a number \[s\], got NoneType"):
        trajectory.sample(None)  # type: ignore[arg-type]


def test_gains_that_are_no_text_are_named() -> None:  # TypeError from pathlib
    with pytest.raises(ConfigError, match=r"resolve_gains takes text, 'KP,KD'.*FBLGains\(kp=9, kd=6\)"):
        resolve_gains(None)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ["", " ", "."])
def test_a_scenario_named_by_nothing_or_a_folder_says_so(name: str) -> None:
    """It said "cannot read scenario file .: Is a directory"."""
    with pytest.raises(ScenarioError, match=r"a scenario is a built-in name, random<N> or a \.toml file"):
        load_scenario(name)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("laser_max_range=0", "amcl laser_max_range must be > 0"),  # ran, with a numpy divide-by-zero warning
        ("map_resolution=10", "amcl map_resolution must be at most 0.5 m"),  # "the map has no free space ..."
        ("base_frame_id=x", "'base_frame_id' is not taken: ROS plumbing"),  # "base_frame_id must be a number"
    ],
)
def test_localiser_settings_that_cannot_work_are_refused(text: str, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        AmclConfig().parse(text)


def test_localiser_ranges_beyond_the_scanners_are_refused() -> None:
    """laser_min_range=5 above the LDS-01's 3.5 m ran, weighing no beam: "7 scans used, RMSE 21.7 cm"."""
    from sim.physics.lidar import LidarProfile
    from sim.robot.scan_localiser import LocaliserSetup

    world = World((0.0, 3.0, 0.0, 3.0))
    with pytest.raises(ConfigError, match=r"leave no range of the scanner's 0.12-3.5 m to use"):
        LocaliserSetup("amcl", world, LidarProfile(), AmclConfig().parse("laser_min_range=5"))
    LocaliserSetup("amcl", world, LidarProfile(), AmclConfig().parse("laser_min_range=3"))


def _map(tmp_path: Path, origin: str) -> Path:
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 2\n255\n" + bytes([254, 254, 0, 254]))
    path = tmp_path / "m.yaml"
    path.write_text(f"image: m.pgm\nresolution: 0.05\norigin: {origin}\noccupied_thresh: 0.65\nfree_thresh: 0.25\n")
    return path


def test_a_map_origin_yaw_in_degrees_is_refused(tmp_path: Path) -> None:  # 90 was taken as radians
    with pytest.raises(ScenarioError, match=r"field 'origin': .*the yaw in radians within \+-4 pi; 90 degrees"):
        read_map_yaml(_map(tmp_path, "[0.0, 0.0, 90]"))
    assert read_map_yaml(_map(tmp_path, "[0.0, 0.0, 1.5708]")).origin[2] == 1.5708


def test_an_image_given_as_the_map_yaml_says_where_an_image_goes(tmp_path: Path) -> None:
    """It said "cannot be read: 'utf-8' codec can't decode byte 0x89"."""
    png = tmp_path / "m.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(32))
    with pytest.raises(
        ScenarioError, match=r"is not text .*an image itself goes in the scenario's \[world.map\] table"
    ):
        read_map_yaml(png)


def test_a_sensor_value_of_the_wrong_type_is_named(tmp_path: Path) -> None:
    """It said "expected a [sensors] table of numbers ..., got a table"."""
    text = (Path(__file__).resolve().parents[1] / "models/scenarios/open.toml").read_text()
    path = tmp_path / "s.toml"
    path.write_text(text + '\n[sensors]\nfix_rate = "5"\n')
    with pytest.raises(ScenarioError, match=r"field 'sensors.fix_rate': expected a finite number \(e.g. fix_rate = 5"):
        load_scenario(path)


def test_track_and_simulate_name_what_they_take() -> None:
    """``sim.track('x')`` and ``sim.simulate('x')`` raised AttributeError from deep inside."""
    import sim

    with pytest.raises(
        ConfigError, match=r"track: prepared must be a PreparedTrajectory, got str .*prepare_trajectory"
    ):
        sim.track("farm")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"simulate: case must be a Case, got str .*simulate_plan\('farm'\)"):
        sim.simulate("farm")  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [[], [1.0], np.zeros(3)])
def test_trajectory_sample_takes_one_time(bad: object) -> None:
    """``sample([])`` blamed sample_many and a shape (1, 0) it made itself."""
    traj = make_reference("circle", load_robot("edumip"), Pose2D(0.0, 0.0, 0.0))
    with pytest.raises(ConfigError, match=r"Trajectory.sample takes one time \[s\].*sample_many\(times\)"):
        traj.sample(bad)  # type: ignore[arg-type]
    np.testing.assert_array_equal(traj.sample(np.float64(1.0)).pose, traj.sample(1).pose)  # any one number


def test_wrap_angle_names_what_it_takes() -> None:
    """``wrap_angle('x')`` raised numpy's "could not convert string to float"."""
    from planning.core.geometry import wrap_angle

    for bad in ("x", None, {"a": 1}):
        with pytest.raises(ConfigError, match=r"wrap_angle takes angles in radians \(numbers\), got"):
            wrap_angle(bad)  # type: ignore[arg-type]
    assert wrap_angle(7.0) == pytest.approx(7.0 - 2 * np.pi)


def test_an_integer_too_large_for_a_float_is_refused_as_not_a_finite_number(tmp_path: Path) -> None:
    """TOML, JSON and Python's int take integers of any size; ``math.isfinite`` and ``float`` raise OverflowError on
    one beyond a float's range, which escaped every check as a traceback (a scenario's pose, height, tolerance or
    ``[sensors]`` value, a gains file, ``--params``, a JSON trajectory's cell). Refused now by the field's own
    message, quoting the number by its digits, not all 401 of them."""
    import json

    from planning.core.checks import check_number, is_number
    from planning.trajectory.file_formats import read_table

    huge = 10**400
    assert not is_number(huge) and not is_number(huge, integer=True) and not is_number(-huge)
    assert is_number(10**300) and is_number(10**300, integer=True)  # within a float's range
    with pytest.raises(ConfigError, match=r"^n must be an integer >= 1, got an integer of 401 digits$"):
        check_number("n", huge, integer=True, at_least=1)
    with pytest.raises(ConfigError, match=r"^x must be a finite number, got an integer of 401 digits$"):
        check_number("x", -huge)
    scenario = tmp_path / "s.toml"
    base = (
        'name = "s"\nrobot = "turtlebot3"\n[world]\nbounds = [-2.0, 2.0, -2.0, 2.0]\n'
        "[start]\npose = [0.0, 0.0, 0.0]\n[goal]\npose = [1.0, 0.0, 0.0]\n"
    )
    for edit, field in (
        (base.replace("[1.0, 0.0, 0.0]", f"[{huge}, 0.0, 0.0]"), r"field 'goal\.pose'.*\(413 characters\)$"),
        (base + f"position_tolerance = {huge}\n", r"field 'goal\.position_tolerance'.* got an integer of 401 digits$"),
        (base + f"[sensors]\nfix_rate = {huge}\n", r"field 'sensors\.fix_rate'.* got an integer of 401 digits$"),
    ):
        scenario.write_text(edit)
        with pytest.raises(ScenarioError, match=field):
            load_scenario(scenario)
    trajectory = tmp_path / "t.json"
    trajectory.write_text(json.dumps({"t": [0, 1, 2], "x": [0, huge, 0.2], "y": [0, 0, 0]}))
    with pytest.raises(ConfigError, match=r"column 'x': an integer of 401 digits is not a finite number"):
        read_table(trajectory)


def test_a_video_beyond_h264_level_5_2_is_refused_naming_the_largest_that_fits() -> None:
    """4096x4096 at 30 frames/s and 4096x2304 at 60 were encoded at level 6.0 (read from the MP4's avcC box), which
    hardware decoders and some browsers refuse; the sizes and rates of level 5.2 pass."""
    assert RenderSettings(width=4096, height=2304, fps=30.0).width == 4096
    assert RenderSettings(width=3840, height=2160, fps=60.0).fps == 60.0
    with pytest.raises(ConfigError, match=r"video size 4096x4096 is 65536 macroblocks .* level 5\.2's 36864"):
        RenderSettings(width=4096, height=4096, fps=30.0)
    with pytest.raises(ConfigError, match=r"60 frames/s at 4096x2304 is 2211840 macroblocks a second.* --fps 56 "):
        RenderSettings(width=4096, height=2304, fps=60.0)


def test_to_trajectorys_directions_are_one_sign_a_pose() -> None:
    """A list of the wrong length ended in a bare ValueError from the smoothing, and ``[0, 0, 0]`` was taken."""
    from planning import load_robot, load_scenario, to_trajectory
    from planning.errors import ConfigError

    path = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]])
    world, robot = load_scenario("open").world, load_robot("turtlebot3")
    for bad in ([1, 1], [0, 0, 0], [1, 2, 1], ["a", "b", "c"], [1.0, np.nan, 1.0]):
        with pytest.raises(ConfigError, match=r"to_trajectory: directions must be one \+1 .* a pose \(3\)"):
            to_trajectory(path, robot, world, directions=bad)
    given = to_trajectory(path, robot, world, directions=[1, 1, 1])
    assert given.duration == to_trajectory(path, robot, world).duration


def test_a_robot_spec_holds_its_footprint_as_a_read_only_array_and_its_name_as_text() -> None:
    """A list footprint was taken (``radius`` then failed with a TypeError), and None as the name."""
    import dataclasses

    from planning import load_robot
    from planning.errors import ConfigError

    robot = load_robot("turtlebot3")
    listed = dataclasses.replace(robot, footprint=robot.footprint.tolist())
    assert listed == robot and listed.radius == robot.radius and not listed.footprint.flags.writeable
    for bad in ({"name": None}, {"name": " "}, {"footprint": [["a", "b"]] * 3}, {"footprint": [[0.0, 0.0]] * 2}):
        with pytest.raises(ConfigError, match=r"RobotSpec: name must be|the footprint must be"):
            dataclasses.replace(robot, **bad)


@pytest.mark.parametrize("name", ["fbl", "kanayama", "rpp", "segmented", "mpc", "open-loop"])
def test_a_tracker_pickles_and_goes_on_as_it_would_have(name: str) -> None:
    """fbl, kanayama, rpp and segmented could not be pickled (their compiled period is a closure): a tracker could
    not be sent to another process or kept. An unpickled tracker goes on with the same commands, its state the one
    its compiled period updates."""
    import pickle

    from planning import load_robot
    from planning.core.geometry import Pose2D
    from planning.trajectory.references import make_reference

    robot = load_robot("turtlebot3")
    reference = make_reference("circle", robot, Pose2D(0.0, 0.0, 0.0))
    tracker = make_tracker(name, robot)
    assert pickle.loads(pickle.dumps(tracker)).name == name  # before reset too
    tracker.reset(reference, 0.02)

    def drive(t: Any, steps: range) -> list[tuple[float, float]]:
        return [t.command(k * 0.02, *map(float, reference.pose[k] + [0.01, -0.02, 0.03])) for k in steps]

    drive(tracker, range(5))
    copy = pickle.loads(pickle.dumps(tracker))
    assert drive(copy, range(5, 30)) == drive(tracker, range(5, 30))
    bound = getattr(copy, "_period", None)
    if bound is not None:  # the compiled period updates the state the tracker holds
        assert bound.args[0] is copy.state
