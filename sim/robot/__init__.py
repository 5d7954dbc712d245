"""The robot's own software: the wheels' firmware velocity loop, the balance firmware and its design,
and the sensing wired into the estimator that feeds the tracker.

Importing this package imports no MuJoCo: each public name below loads its module on first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from planning.lazy import lazy_exports

if TYPE_CHECKING:
    from sim.robot.balance_design import BalanceDesign as BalanceDesign
    from sim.robot.balance_design import balance_gains as balance_gains
    from sim.robot.balance_design import design_balance as design_balance
    from sim.robot.balance_design import design_report as design_report
    from sim.robot.balance_firmware import BalanceFirmware as BalanceFirmware
    from sim.robot.balance_firmware import BalanceRun as BalanceRun
    from sim.robot.balance_firmware import Push as Push
    from sim.robot.balance_firmware import make_firmware as make_firmware
    from sim.robot.balance_firmware import run_balance as run_balance
    from sim.robot.sensing import Sensing as Sensing
    from sim.robot.sensing import SensingSetup as SensingSetup
    from sim.robot.sensing import estimator_config as estimator_config
    from sim.robot.sources import PoseSource as PoseSource
    from sim.robot.wheel_firmware import VelocityLoop as VelocityLoop

#: Public name -> the module that defines it.
_EXPORTS = {
    "BalanceDesign": "sim.robot.balance_design",
    "balance_gains": "sim.robot.balance_design",
    "design_balance": "sim.robot.balance_design",
    "design_report": "sim.robot.balance_design",
    "BalanceFirmware": "sim.robot.balance_firmware",
    "BalanceRun": "sim.robot.balance_firmware",
    "Push": "sim.robot.balance_firmware",
    "make_firmware": "sim.robot.balance_firmware",
    "run_balance": "sim.robot.balance_firmware",
    "Sensing": "sim.robot.sensing",
    "SensingSetup": "sim.robot.sensing",
    "estimator_config": "sim.robot.sensing",
    "PoseSource": "sim.robot.sources",
    "VelocityLoop": "sim.robot.wheel_firmware",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
