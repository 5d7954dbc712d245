"""Building a control-suite environment for a (scenario, robot, source) case."""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np
from dm_control.mujoco.wrapper import core
from dm_control.rl import control

from planning.core.checks import check_number, is_number
from planning.core.robot import check_robot_name, load_robot
from planning.errors import ConfigError
from planning.planners.registry import PLANNERS
from planning.trajectory.references import REFERENCES
from sim.physics.asbuilt import DEFAULT_BUILD_SEED, check_build_seed
from sim.physics.simulator import SimConfig
from sim.pipeline.case import Case, PreparedTrajectory, load_case_scenario, plan_case, prepare_trajectory
from sim.pipeline.simulate import simulator_for
from sim.pipeline.sweep import precondition_not_met, sweep_cases
from sim.suite.env import Physics, TrackingEnvironment, TrackingTask


class NotApplicableError(ConfigError):
    """The planner does not apply to the scenario (``nhsim simulate --all`` reports such a case as n/a)."""


def suite_seed(seed: Any) -> int:
    """The environment's seed from what dm_control's suite takes as a task's ``random``: an int
    (>= 0 here: it seeds the plan), None (a seed drawn from the operating system's entropy) or a
    ``numpy.random.RandomState`` (a seed drawn from it).

    Raises:
        ConfigError: Anything else (a string, a float, a bool, a negative int), named with its type.
    """
    if seed is None:
        return int(np.random.SeedSequence().generate_state(1)[0] >> 1)
    if isinstance(seed, np.random.RandomState):
        return int(seed.randint(2**31 - 1))
    if not (is_number(seed, integer=True) and seed >= 0):
        raise ConfigError(
            f"seed must be an integer >= 0, None (a random seed) or a numpy.random.RandomState, as dm_control's "
            f"suite takes; got {seed!r} ({type(seed).__name__})"
        )
    return int(seed)


@cache
def all_cases() -> tuple[tuple[str, str, str], ...]:
    """(scenario, robot, planner) of every case ``nhsim simulate --all`` runs, in its order."""
    return tuple((str(c.scenario), str(c.robot), str(c.planner)) for c in sweep_cases())


def _case(
    scenario: str, robot: str, source: str, seed: int, build_seed: int | None, control_rate: float, sensors: str = ""
) -> Case:
    check_robot_name("sim.suite", robot)
    is_reference = source in REFERENCES
    if is_reference or source in PLANNERS:
        return Case(
            scenario,
            robot=robot,
            reference=source if is_reference else None,
            planner=None if is_reference else source,
            seed=seed,
            build_seed=build_seed,
            control_rate=control_rate,
            sensors=sensors,
            localiser="fixes",  # the observations carry pose fixes, not laser scans: the estimator is set for them
        )
    raise ConfigError(
        f"unknown source {source!r}: give a planner ({', '.join(sorted(PLANNERS))}) "
        f"or a reference ({', '.join(REFERENCES)})"
    )


@cache
def _prepared(
    scenario: str, robot: str, source: str, seed: int, build_seed: int | None, rate: float, sensors: str
) -> PreparedTrajectory:
    """The case's trajectory, planned as ``nhsim simulate --all`` plans it (cached per process)."""
    case = _case(scenario, robot, source, seed, build_seed, rate, sensors)
    if case.reference is not None:
        return prepare_trajectory(case)
    sc = load_case_scenario(case)
    plan = plan_case(case, sc, load_robot(sc.robot))
    why = precondition_not_met(sc, plan)
    if why is not None:
        raise NotApplicableError(f"planner {case.planner!r} does not apply to {sc.name} with the {sc.robot}: {why}")
    return prepare_trajectory(case.with_plan(plan, sc))


def load(
    scenario: str,
    robot: str,
    source: str,
    *,
    seed: int | np.random.RandomState | None = 0,
    build_seed: int | None = DEFAULT_BUILD_SEED,
    control_rate: float = 50.0,
    sensors: str = "",
) -> control.Environment:
    """A control-suite environment: the robot as built in the scenario's world, tracking the source's
    trajectory with its own sensors (see :mod:`sim.suite.env`).

    Args:
        scenario: Built-in scenario name or scenario file.
        robot: Robot name (``turtlebot3`` or ``edumip``); one the scenario lists.
        source: A planner name (the plan is made once, with ``seed``) or an analytic reference.
        seed: Seed of the plan and of the first episode's sensor noise (episode e: ``seed + e``): an
            int >= 0, None for a random one, or a ``numpy.random.RandomState`` a seed is drawn from,
            as dm_control's own suite takes its ``random`` (:func:`suite_seed`).
        build_seed: Seed of the as-built draw (None: the robot as drawn).
        control_rate: Control periods (environment steps) per second [Hz].
        sensors: Overrides of the robot's sensor profile, as ``nhsim simulate --sensors`` takes them
            (``"fix_rate=6.25"``: at 25 Hz the default 10 Hz fixes do not fit a control period).

    Raises:
        ConfigError: Unknown robot or source (the message lists the valid ones), a robot the
            scenario does not list, a bad seed or rate.
        NotApplicableError: The planner does not apply to the scenario (its own start/goal rule).
        ScenarioError: Unknown scenario (the message lists the built-in ones).
        TrajectoryError: The plan failed.
    """
    rate = check_number("control_rate", control_rate, above=0.0, unit="Hz", fix="e.g. 50")
    if build_seed is not None:
        build_seed = check_build_seed(build_seed)
    if not isinstance(sensors, str):
        raise ConfigError(f"sensors must be text such as 'fix_rate=5', got {sensors!r}")
    prepared = _prepared(scenario, robot, source, suite_seed(seed), build_seed, rate, sensors)
    simulator = simulator_for(prepared)
    SimConfig(control_rate=control_rate, hold=prepared.hold)  # checks the rate and the hold
    task = TrackingTask(
        prepared, simulator, prepared.case.sensing(prepared.scenario), hold=prepared.hold, control_rate=control_rate
    )
    physics = Physics.from_model(core.MjModel(simulator.model))
    return TrackingEnvironment(physics, task, n_sub_steps=task.k_ctrl, legacy_step=False)
