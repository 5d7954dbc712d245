"""Planning layer of nhsim: geometry, worlds, kinematics, planners and trajectories.

Pure numerics; nothing here imports MuJoCo or the control layer. The public names are re-exported
here (rooms: ``core``, ``collision``, ``curves``, ``planners``, ``trajectory``)::

    from planning import load_scenario, make_planner, PlanProblem, to_trajectory

    scenario = load_scenario("edumip_map")
    problem = PlanProblem.from_scenario(scenario, seed=0, time_limit=10.0)
    result = make_planner("c-rrt-star").plan(problem)          # a PlanResult with a PlanStatus
    trajectory = to_trajectory(result, problem.robot, scenario.world)

Importing this package imports none of its modules: each public name loads its module on first use,
so that a command loads only what it runs (``nhsim --version`` loads no numerics).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from planning.kernel_cache import configure as _configure_kernel_cache
from planning.lazy import lazy_exports

_configure_kernel_cache()  # numba's cache directory, before any kernel is defined (planning.kernel_cache)

if TYPE_CHECKING:
    from planning.core.geometry import Pose2D as Pose2D
    from planning.core.geometry import densify_path as densify_path
    from planning.core.geometry import path_length as path_length
    from planning.core.geometry import wrap_angle as wrap_angle
    from planning.core.nav2_map import map_yaml_obstacles as map_yaml_obstacles
    from planning.core.nav2_map import read_map_yaml as read_map_yaml
    from planning.core.robot import RobotSpec as RobotSpec
    from planning.core.robot import load_robot as load_robot
    from planning.core.robot import register_robot as register_robot
    from planning.core.world import Box as Box
    from planning.core.world import Circle as Circle
    from planning.core.world import Ellipse as Ellipse
    from planning.core.world import Polygon as Polygon
    from planning.core.world import World as World
    from planning.errors import ConfigError as ConfigError
    from planning.errors import NhsimError as NhsimError
    from planning.planners.base import Planner as Planner
    from planning.planners.base import PlanProblem as PlanProblem
    from planning.planners.base import PlanResult as PlanResult
    from planning.planners.base import PlanStatus as PlanStatus
    from planning.planners.registry import PLANNERS as PLANNERS
    from planning.planners.registry import make_planner as make_planner
    from planning.planners.registry import register_planner as register_planner
    from planning.planners.simplify import SimplifiedPath as SimplifiedPath
    from planning.planners.simplify import SimplifyConfig as SimplifyConfig
    from planning.planners.simplify import simplify_path as simplify_path
    from planning.scenario import Scenario as Scenario
    from planning.scenario import builtin_scenarios as builtin_scenarios
    from planning.scenario import load_scenario as load_scenario
    from planning.scenario import random_scenario as random_scenario
    from planning.trajectory.file_trajectory import file_trajectory as file_trajectory
    from planning.trajectory.from_plan import to_trajectory as to_trajectory
    from planning.trajectory.importer import TrajectoryFile as TrajectoryFile
    from planning.trajectory.importer import read_trajectory_file as read_trajectory_file
    from planning.trajectory.references import REFERENCES as REFERENCES
    from planning.trajectory.references import make_reference as make_reference
    from planning.trajectory.trajectory import Trajectory as Trajectory
    from planning.trajectory.trajectory import TrajectorySamples as TrajectorySamples

#: Public name -> the module that defines it (loaded on first use).
_EXPORTS = {
    "Pose2D": "planning.core.geometry",
    "densify_path": "planning.core.geometry",
    "path_length": "planning.core.geometry",
    "wrap_angle": "planning.core.geometry",
    "read_map_yaml": "planning.core.nav2_map",
    "map_yaml_obstacles": "planning.core.nav2_map",
    "RobotSpec": "planning.core.robot",
    "load_robot": "planning.core.robot",
    "register_robot": "planning.core.robot",
    "Box": "planning.core.world",
    "Circle": "planning.core.world",
    "Ellipse": "planning.core.world",
    "Polygon": "planning.core.world",
    "World": "planning.core.world",
    "ConfigError": "planning.errors",
    "NhsimError": "planning.errors",
    "Planner": "planning.planners.base",
    "PlanProblem": "planning.planners.base",
    "PlanResult": "planning.planners.base",
    "PlanStatus": "planning.planners.base",
    "PLANNERS": "planning.planners.registry",
    "make_planner": "planning.planners.registry",
    "register_planner": "planning.planners.registry",
    "SimplifiedPath": "planning.planners.simplify",
    "SimplifyConfig": "planning.planners.simplify",
    "simplify_path": "planning.planners.simplify",
    "Scenario": "planning.scenario",
    "builtin_scenarios": "planning.scenario",
    "load_scenario": "planning.scenario",
    "random_scenario": "planning.scenario",
    "file_trajectory": "planning.trajectory.file_trajectory",
    "to_trajectory": "planning.trajectory.from_plan",
    "TrajectoryFile": "planning.trajectory.importer",
    "read_trajectory_file": "planning.trajectory.importer",
    "REFERENCES": "planning.trajectory.references",
    "make_reference": "planning.trajectory.references",
    "Trajectory": "planning.trajectory.trajectory",
    "TrajectorySamples": "planning.trajectory.trajectory",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
