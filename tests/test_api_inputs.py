"""The Python API's inputs: numpy's scalars are numbers (np.int64, np.float64 and np.float32 work wherever
a Python int or float does; they were refused as "not a finite number"), and an argument of the wrong
kind is named where it is given (it was an AttributeError deep inside)."""

from __future__ import annotations

import numpy as np
import pytest

from control.base import make_tracker
from control.estimation.ekf import EstimatorConfig
from control.fbl import FBLGains
from planning.core.geometry import Pose2D
from planning.core.robot import load_robot
from planning.errors import ConfigError
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
    from planning.errors import ModelError

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
    with pytest.raises(ModelError, match=r"a robot is named by text: one of edumip, .*turtlebot3 .*got None"):
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
