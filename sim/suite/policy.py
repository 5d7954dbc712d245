"""nhsim's own stack as a control-suite policy: the EKF on the robot's sensors, then the tracker.

:func:`reference_policy` runs what ``nhsim simulate`` runs in its closed loop (the fused estimate
from encoders, gyro and localisation fixes, and the case's feedback tracker), fed only from the
environment's observations, with one exception the simulator shares: the estimator starts at the
true start pose (the robot is placed at a known pose; ``privileged_true_pose`` of the first
observation only). Run through the environment it gives ``nhsim simulate``'s closed-loop run on the
same seeds, equal to the last bit in every logged pose (the test checks it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import dm_env
import numpy as np
from dm_control.rl import control
from numpy.typing import NDArray

from control.base import Tracker, make_tracker, tracker_options
from control.diffdrive import DiffDrive
from control.gains import FBLGains
from sim.physics.metrics import TrackingMetrics, robot_metrics
from sim.physics.runlog import RunLog
from sim.pipeline.runs import RunKind
from sim.robot.sensing import EstimatorLoop
from sim.robot.sources import PoseSource
from sim.suite.env import TrackingTask

FloatArray = NDArray[np.float64]


class ReferencePolicy:
    """The estimator and tracker of a task's closed loop, as ``policy(timestep) -> action``.

    The estimator runs the simulator's own period on the observed readings
    (:class:`sim.robot.sensing.EstimatorLoop`).

    Args:
        task: The environment's task (the robot as drawn, its sensor profile, the trajectory and
            the case's tracker and gains: what the robot's own software is configured with).
        source: ``fused`` (encoders, gyro and fixes) or ``odometry`` (fixes ignored).

    Attributes:
        loop: The estimator's loop; its ``estimate`` and ``variance`` (N + 1, 3) are logged by period.
    """

    def __init__(self, task: TrackingTask, source: PoseSource = PoseSource.FUSED) -> None:
        if PoseSource(source) is PoseSource.TRUTH:
            raise ValueError("the reference policy estimates its pose: choose source 'fused' or 'odometry'")
        self.task, self.source = task, PoseSource(source)
        case, robot = task.prepared.case, task.prepared.robot
        self.tracker_name = case.tracker_for(RunKind.CLOSED_LOOP)
        options = {"gains": case.gains or FBLGains()} if "gains" in tracker_options(self.tracker_name) else {}
        self.tracker: Tracker = make_tracker(self.tracker_name, robot, **options)
        self.loop = EstimatorLoop(
            robot, task.sensing.estimator_config(robot, task.control_rate), n_periods=task.schedule.n_ctrl,
            dt=1.0 / task.control_rate, rad_per_count=2.0 * np.pi / task.sensing.profile.encoder_cpr,
        )  # fmt: skip
        self.drive = DiffDrive.from_robot(robot)
        self._k = 0

    def __call__(self, timestep: dm_env.TimeStep) -> FloatArray:
        """The wheel-speed command [left, right] [rad/s] for the timestep's observation."""
        obs, task, loop = timestep.observation, self.task, self.loop
        t = float(obs["time"][0])
        left, right = (int(c) for c in obs["encoder_counts"])
        pitch = float(obs["pitch_estimate"][0])
        if timestep.first():
            self._k = 0
            loop.start(t, tuple(obs["privileged_true_pose"]), (left, right), pitch)
            self.tracker.reset(task.trajectory, task.schedule.dt_ctrl)
        else:
            self._k += 1
            loop.step(self._k, left, right, float(obs["gyro_z"][0]), pitch)
        if obs["fix_valid"][0] > 0.0 and self.source is PoseSource.FUSED:
            j = self._k - round(float(obs["fix_age"][0]) * task.control_rate)  # the period it was measured at
            loop.correct(j, tuple(obs["fix"]))
        x, y, th = loop.record(self._k)
        v, w = self.tracker.command(t, x, y, th)
        return np.array(self.drive.wheel_speeds(v, w))


def reference_policy(env: control.Environment, source: PoseSource | str = PoseSource.FUSED) -> ReferencePolicy:
    """nhsim's estimator and the case's feedback tracker driving the environment (see :class:`ReferencePolicy`)."""
    task = env.task
    if not isinstance(task, TrackingTask):
        raise TypeError(f"reference_policy needs an environment from sim.suite.load, got a {type(task).__name__}")
    return ReferencePolicy(task, PoseSource(source))


@dataclass(frozen=True)
class EpisodeResult:
    """One episode driven by a policy.

    Attributes:
        ret: The sum of the rewards.
        steps: Environment steps taken.
        log: The run log (true poses, commands, contacts, warnings).
        metrics: How well it followed the trajectory (as ``nhsim simulate`` measures its runs).
    """

    ret: float
    steps: int
    log: RunLog
    metrics: TrackingMetrics


def run_episode(env: control.Environment, policy: Callable[[dm_env.TimeStep], Any]) -> EpisodeResult:
    """Reset the environment and step it with the policy to the episode's end."""
    task = env.task
    timestep = env.reset()
    ret, steps = 0.0, 0
    while not timestep.last():
        timestep = env.step(policy(timestep))
        ret += float(timestep.reward)
        steps += 1
    log = task.log()
    metrics = robot_metrics(log, task.trajectory, task.prepared.robot)
    return EpisodeResult(ret, steps, log, metrics)
