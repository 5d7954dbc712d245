"""The plant: the MuJoCo model of a robot in its world, its contacts, motor electrics and sensors'
physics, the as-built draw, perturbations, the closed-loop simulator, run logs and metrics.

Importing this package imports no MuJoCo: each public name below loads its module on first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from planning.lazy import lazy_exports

if TYPE_CHECKING:
    from sim.physics.asbuilt import DEFAULT_BUILD_SEED as DEFAULT_BUILD_SEED
    from sim.physics.asbuilt import AsBuilt as AsBuilt
    from sim.physics.asbuilt import BuildTolerance as BuildTolerance
    from sim.physics.asbuilt import check_build_seed as check_build_seed
    from sim.physics.metrics import EstimationMetrics as EstimationMetrics
    from sim.physics.metrics import TrackingMetrics as TrackingMetrics
    from sim.physics.metrics import compute_metrics as compute_metrics
    from sim.physics.metrics import robot_metrics as robot_metrics
    from sim.physics.model import BuiltModel as BuiltModel
    from sim.physics.model import body_pitch as body_pitch
    from sim.physics.model import build_model as build_model
    from sim.physics.model import scale_wheels as scale_wheels
    from sim.physics.model import set_pose as set_pose
    from sim.physics.motors import MotorModel as MotorModel
    from sim.physics.motors import whole_steps as whole_steps
    from sim.physics.perturb import Perturbation as Perturbation
    from sim.physics.perturb import PerturbationRange as PerturbationRange
    from sim.physics.runlog import BalanceLog as BalanceLog
    from sim.physics.runlog import Contact as Contact
    from sim.physics.runlog import EstimationLog as EstimationLog
    from sim.physics.runlog import RunLog as RunLog
    from sim.physics.sagittal import SagittalParams as SagittalParams
    from sim.physics.sagittal import balance_accel_limit as balance_accel_limit
    from sim.physics.sagittal import linearise_upright as linearise_upright
    from sim.physics.sagittal import sagittal_model as sagittal_model
    from sim.physics.sensors import SensorModel as SensorModel
    from sim.physics.sensors import SensorProfile as SensorProfile
    from sim.physics.sensors import load_sensor_profile as load_sensor_profile
    from sim.physics.simulator import SimConfig as SimConfig
    from sim.physics.simulator import Simulator as Simulator

#: Public name -> the module that defines it.
_EXPORTS = {
    "AsBuilt": "sim.physics.asbuilt",
    "BuildTolerance": "sim.physics.asbuilt",
    "DEFAULT_BUILD_SEED": "sim.physics.asbuilt",
    "check_build_seed": "sim.physics.asbuilt",
    "EstimationMetrics": "sim.physics.metrics",
    "TrackingMetrics": "sim.physics.metrics",
    "compute_metrics": "sim.physics.metrics",
    "robot_metrics": "sim.physics.metrics",
    "BuiltModel": "sim.physics.model",
    "body_pitch": "sim.physics.model",
    "build_model": "sim.physics.model",
    "set_pose": "sim.physics.model",
    "scale_wheels": "sim.physics.model",
    "MotorModel": "sim.physics.motors",
    "whole_steps": "sim.physics.motors",
    "Perturbation": "sim.physics.perturb",
    "PerturbationRange": "sim.physics.perturb",
    "BalanceLog": "sim.physics.runlog",
    "Contact": "sim.physics.runlog",
    "EstimationLog": "sim.physics.runlog",
    "RunLog": "sim.physics.runlog",
    "SagittalParams": "sim.physics.sagittal",
    "balance_accel_limit": "sim.physics.sagittal",
    "linearise_upright": "sim.physics.sagittal",
    "sagittal_model": "sim.physics.sagittal",
    "SensorModel": "sim.physics.sensors",
    "SensorProfile": "sim.physics.sensors",
    "load_sensor_profile": "sim.physics.sensors",
    "SimConfig": "sim.physics.simulator",
    "Simulator": "sim.physics.simulator",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
