"""Where a run's tracker gets its pose (no MuJoCo here: the command line imports it to build parsers)."""

from __future__ import annotations

from enum import StrEnum


class PoseSource(StrEnum):
    """Where the tracker's pose comes from (see :mod:`sim.robot.sensing`).

    - ``fused``: the EKF's estimate from wheel encoders, gyro and localisation fixes;
    - ``odometry``: dead reckoning, the same EKF without fixes;
    - ``truth``: MuJoCo's true pose.
    """

    FUSED = "fused"
    ODOMETRY = "odometry"
    TRUTH = "truth"
