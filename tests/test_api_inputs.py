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
