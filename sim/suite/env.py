"""nhsim's scenarios as dm_control environments: a :class:`TrackingTask` on nhsim's composed physics.

One environment step is one control period (``1 / control_rate``). The action is the two wheel-speed
commands [left, right] [rad/s] that the motors' firmware velocity loop then follows, exactly as in
:class:`sim.physics.simulator.Simulator` (the same :class:`~sim.physics.simulator.PeriodPhysics`
steps both). The observations are what the robot's own sensors give (quantised encoder counts, the
IMU's gyro and accelerometer, localisation fixes when they arrive), the reference now and a short
preview, and, named as privileged, the true pose (for learning baselines, never for the robot's own
stack). The reward is :func:`dm_control.utils.rewards.tolerance` on the position and heading error
against the reference; the discount is 1; an episode ends at the trajectory's end plus the final
hold, or with discount 0 (a failure: a crash or a fall has no future) at the first contact with an
obstacle or at the end of the period in which the robot fell (:meth:`TrackingTask.fallen`).

Sensor noise is drawn from the environment's seed: episode ``e`` after construction uses noise seed
``seed + e``, so two environments made with the same arguments give the same episodes, and the first
episode's noise is that of ``nhsim simulate --seed SEED`` (the plan and the as-built robot are fixed
per environment: ``build_seed`` draws the robot once, as a real robot is built once).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from typing import Any

import mujoco
import numpy as np
from dm_control import mujoco as dm_mujoco
from dm_control.rl import control
from dm_control.utils import rewards
from dm_env import specs
from numpy.typing import NDArray

from control.diffdrive import DiffDrive
from planning.core.geometry import Pose2D
from planning.trajectory.trajectory import Trajectory
from sim.physics.model import set_pose, tipped_over
from sim.physics.runlog import RunLog
from sim.physics.sensors import SensorModel, SensorReader
from sim.physics.simulator import PeriodPhysics, Recorder, Schedule, Simulator
from sim.pipeline.case import PreparedTrajectory
from sim.robot.sensing import SensingSetup

FloatArray = NDArray[np.float64]
TWO_PI = 2.0 * math.pi

#: Reference poses in the preview, and their spacing [s].
PREVIEW_SAMPLES = 10
PREVIEW_SPACING_S = 0.1

#: The reward's tolerance: full inside the bounds, falling off over the margin (Gaussian sigmoid,
#: 0.1 at the margin). Position error [m], heading error [rad].
POSITION_BOUNDS, POSITION_MARGIN = (0.0, 0.02), 0.2
HEADING_BOUNDS, HEADING_MARGIN = (0.0, 0.05), 0.5


@dataclass
class Episode:
    """The state of one episode: the run's buffers, its sensors and the readings of the current period.

    Attributes:
        recorder: The run's log buffers (as a simulator run keeps them).
        physics: Steps the control periods (motor firmware, ``mj_step`` chunks, log samples).
        sensors: The episode's sensor noise draws.
        reader: Reads the encoders and the gyro each period, as the simulator's sensing does.
        k: Control periods done.
        counts: Encoder counts now (left, right).
        gyro_z: Gyro reading of the last period [rad/s] (0 before the first period).
        accel: (3,) accelerometer reading [m/s^2].
        fix: The fix delivered now (x, y, theta), or None.
        fix_age: Time from that fix's measurement to now [s].
        measured: Fixes measured so far, by control period.
        fell: Whether the robot has fallen (:meth:`TrackingTask.fallen`; the episode ends there).
    """

    recorder: Recorder
    physics: PeriodPhysics
    sensors: SensorModel
    reader: SensorReader
    k: int = 0
    counts: tuple[int, int] = (0, 0)
    gyro_z: float = 0.0
    accel: FloatArray | None = None
    fix: tuple[float, float, float] | None = None
    fix_age: float = 0.0
    measured: dict[int, tuple[float, float, float]] = field(default_factory=dict)
    fell: bool = False


#: Why an episode cannot be rewound or copied by MuJoCo's state alone, and what replays one instead.
_NO_REWIND = (
    "an nhsim episode cannot be rewound or copied through MuJoCo's state: its motor firmware, sensor noise, log and "
    "reference clock live in the task; to replay from a point, load the environment with the same seed, reset it "
    "and step the same actions (an episode is deterministic for its seed), or run a second environment beside it"
)


class Physics(dm_mujoco.Physics):
    """nhsim's composed model (robot as built, in the scenario's world) as a dm_control Physics.

    :meth:`step` advances one control period with the motor firmware (the environment's
    ``n_sub_steps`` is the period's physics steps); the task starts an episode with :meth:`begin`.
    """

    episode: Episode | None = None

    def begin(self, episode: Episode) -> None:
        """Start stepping an episode's control periods."""
        self.episode = episode

    def set_state(self, physics_state: Any, sig: Any = None) -> None:
        """MuJoCo's state, restored only before the first episode: an episode's motor firmware, sensor draws, log and
        reference clock live in its task, not in MuJoCo's state, so restoring that alone would carry the rest on
        from where they were (the reward scored against a later point of the reference, the poses off by
        millimetres on replay). An ended episode stays the physics' until the next reset, which begins another.

        Raises:
            RuntimeError: An episode has begun (the message says how to replay from a point instead).
        """
        if self.episode is not None:
            raise RuntimeError(_NO_REWIND)
        super().set_state(physics_state, sig)

    def copy(self, share_model: bool = False) -> Physics:
        """dm_control's copy, refused once an episode has begun (until the next reset it would step without the
        episode, see :meth:`set_state`); ``copy.copy``, ``copy.deepcopy`` and pickling alike (:meth:`__getstate__`).

        Raises:
            RuntimeError: An episode has begun (the message says how to replay from a point instead).
        """
        if self.episode is not None:
            raise RuntimeError(_NO_REWIND)
        copied: Physics = super().copy(share_model)
        return copied

    def __getstate__(self) -> Any:
        """MuJoCo's data, as dm_control pickles and copies a Physics; refused once an episode has begun.

        Raises:
            RuntimeError: An episode has begun.
        """
        if self.episode is not None:
            raise RuntimeError(_NO_REWIND)
        return super().__getstate__()

    def step(self, nstep: int = 1) -> None:
        """Advance one control period (``nstep`` physics steps of it), raising
        :class:`dm_control.rl.control.PhysicsError` on a MuJoCo warning."""
        ep = self.episode
        if ep is None:
            raise RuntimeError("reset the environment before stepping it")
        k_ctrl = ep.recorder.schedule.k_ctrl
        if nstep != k_ctrl:
            raise ValueError(f"a step is one control period of {k_ctrl} physics steps, not {nstep}")
        with self.check_invalid_state():
            ep.physics.advance(ep.k)


class TrackingEnvironment(control.Environment):  # type: ignore[misc]
    """dm_control's environment of a :class:`TrackingTask`, its reward spec bounded as the reward is: a scalar in
    [0, 1] (dm_env's default spec said an unbounded float)."""

    def reward_spec(self) -> specs.BoundedArray:
        """A float64 scalar in [0, 1] (:meth:`TrackingTask.get_reward`)."""
        return specs.BoundedArray(shape=(), dtype=np.float64, minimum=0.0, maximum=1.0, name="reward")


class TrackingTask(control.Task):  # type: ignore[misc]
    """Track a prepared trajectory with the robot's own sensors.

    Args:
        prepared: The case and its trajectory (planned once).
        simulator: The compiled simulator of the case's robot as built, in its world.
        sensing: The sensors (profile and the environment's seed; episode e uses ``seed + e``).
        hold: Time simulated after the trajectory ends [s].
        control_rate: Control periods per second [Hz].
    """

    def __init__(
        self,
        prepared: PreparedTrajectory,
        simulator: Simulator,
        sensing: SensingSetup,
        *,
        hold: float,
        control_rate: float,
    ) -> None:
        super().__init__()
        self.prepared, self.simulator, self.sensing = prepared, simulator, sensing
        self.control_rate = control_rate
        self.k_ctrl = simulator.steps_per_control(control_rate)
        self.trajectory: Trajectory = prepared.trajectory
        self.start: Pose2D = prepared.scenario.start
        self.schedule = Schedule.make(self.k_ctrl, float(simulator.model.opt.timestep), self.trajectory.duration + hold)
        self.drive = DiffDrive.from_robot(prepared.robot)
        limit = simulator.motors.no_load_speed
        bound = np.full(2, float(limit))  # one bound per wheel, as dm_control's own suites give them
        self._action_spec = specs.BoundedArray(
            (2,), np.float64, minimum=-bound, maximum=bound, name="wheel_speeds_rad_s"
        )
        m = simulator.model
        self._accel_adr = int(m.sensor_adr[m.sensor("imu_accel").id])
        self._fall_geoms = (m.body("base").id, m.geom("chassis").id, m.geom("floor").id)
        self.episodes = 0
        self.episode: Episode | None = None

    # ------------------------------------------------------------------------------- episodes
    def initialize_episode(self, physics: Physics) -> None:
        """Place the robot at the start, at rest, and draw the episode's sensor noise."""
        m, d = physics.model.ptr, physics.data.ptr
        balancing = self.simulator.balance is not None
        set_pose(m, d, self.start, **({"settle": 0.0} if balancing else {}))  # a balancing robot starts upright
        recorder = Recorder(self.simulator, m, d, self.schedule, float(self.trajectory.t[0]))
        # its firmware, if it balances, told the action period (the commands' ramp)
        sensing = replace(self.sensing, seed=self.sensing.seed + self.episodes)  # this episode's noise
        recorder.balance = self.simulator.balance_for_run(m, d, None, sensing, self.schedule.dt_ctrl)
        sensors = SensorModel(
            sensing.profile, control_rate=self.control_rate, timestep=float(m.opt.timestep),
            n_periods=self.schedule.n_ctrl + 1, seed=sensing.seed,
        )  # fmt: skip
        self.episodes += 1
        self.episode = Episode(recorder, PeriodPhysics(self.simulator, recorder), sensors, SensorReader(m, sensors))
        physics.begin(self.episode)
        self._read_sensors(d)

    def before_step(self, action: Any, physics: Physics) -> None:
        """Check the action against its spec and put it in force for the coming period."""
        ep = self._current()
        try:
            raw = np.asarray(action)
            if np.iscomplexobj(raw):  # float64 would drop the imaginary part with a warning
                raise TypeError(f"action {action!r} is complex; give real wheel speeds")
            value = self._action_spec.validate(raw.astype(np.float64))
        except (ValueError, TypeError) as exc:
            raise ValueError(f"{exc}; the action spec is {self._action_spec!r}") from exc
        if not np.all(np.isfinite(value)):
            raise ValueError(f"action {value} is not finite; the action spec is {self._action_spec!r}")
        left, right = float(value[0]), float(value[1])
        v, w = self.drive.body_twist(left, right)
        ep.recorder.commands[ep.k + 1] = (v, w, left, right)

    def after_step(self, physics: Physics) -> None:
        """Count the period, take the sensors' readings at its end and see whether the robot fell."""
        ep = self._current()
        ep.k += 1
        d = physics.data.ptr
        self._read_sensors(d)
        if not ep.fell and self.fallen(ep, d):
            ep.fell = True
            if ep.recorder.balance is None:  # the run log's status says it, as a simulate run's does
                ep.recorder.tipped_at = float(d.time)

    def fallen(self, episode: Episode, d: mujoco.MjData) -> bool:
        """Whether the robot has fallen, at the end of a period.

        A balancing robot has fallen when its balance firmware says so
        (:meth:`sim.robot.balance_firmware.BalanceFirmware.fallen`, checked at each of its updates:
        the body's tilt beyond the profile's ``tip_angle`` or the chassis touching the floor), the test
        that ends an ``nhsim simulate`` run. A robot that does not balance has no such firmware: it has
        fallen when its body tilts past :data:`sim.physics.model.TIP_ANGLE`, or past
        :data:`sim.physics.model.FLOOR_TILT` with its chassis on the floor (:func:`sim.physics.model.tipped_over`,
        the test that ends its ``simulate`` run too; its wheels, skids or caster are all that touch the floor
        while it stands, and a contact with an obstacle ends the episode anyway).
        """
        balance = episode.recorder.balance
        if balance is not None:
            return balance.fell_at is not None
        return tipped_over(d, *self._fall_geoms)

    def _current(self) -> Episode:
        if self.episode is None:
            raise RuntimeError("reset the environment before stepping it")
        return self.episode

    def _read_sensors(self, d: mujoco.MjData) -> None:
        """The readings at the current period, taken by the reader of :class:`sim.robot.sensing.Sensing`."""
        ep = self._current()
        k, truth, sensors, s = ep.k, ep.recorder.pose, ep.sensors, d.sensordata
        left, right, ep.gyro_z = ep.reader.read(k, truth[2]) if k else ep.reader.start(d, truth[2])
        ep.counts = (left, right)
        ep.accel = sensors.accel(k, s[self._accel_adr : self._accel_adr + 3])
        if sensors.is_fix_period(k):
            ep.measured[k] = sensors.fix(k, truth)
        j = sensors.fix_arriving(k)
        ep.fix = ep.measured.get(j) if j is not None else None
        ep.fix_age = (k - j) / self.control_rate if j is not None else 0.0

    # ---------------------------------------------------------------------------- the interface
    def action_spec(self, physics: Physics) -> specs.BoundedArray:
        """Wheel-speed commands [left, right] [rad/s] within the motors' no-load speed."""
        return self._action_spec

    def observation_spec(self, physics: Physics) -> OrderedDict[str, specs.Array]:
        """Names, shapes and dtypes of :meth:`get_observation`'s arrays."""
        shapes = {
            "encoder_counts": ((2,), np.int64),
            "gyro_z": ((1,), np.float64),
            "accel": ((3,), np.float64),
            "fix": ((3,), np.float64),
            "fix_valid": ((1,), np.float64),
            "fix_age": ((1,), np.float64),
            "time": ((1,), np.float64),
            "pitch_estimate": ((1,), np.float64),
            "reference": ((5,), np.float64),
            "reference_preview": ((PREVIEW_SAMPLES, 3), np.float64),
            "privileged_true_pose": ((3,), np.float64),
        }
        return OrderedDict((k, specs.Array(shape, dtype, name=k)) for k, (shape, dtype) in shapes.items())

    def get_observation(self, physics: Physics) -> OrderedDict[str, FloatArray]:
        """The robot's own sensor readings now, the reference and its preview, and the true pose.

        Keys: ``encoder_counts`` (2,) counts; ``gyro_z`` (1,) yaw rate over the last period [rad/s];
        ``accel`` (3,) specific force [m/s^2]; ``fix`` (3,) the localisation fix delivered now
        (x, y, theta) [m, m, rad] with ``fix_valid`` 1.0 (zeros and 0.0 when none arrives) and
        ``fix_age`` its age [s]; ``time`` trajectory time [s]; ``pitch_estimate`` (1,) a balancing
        robot's own estimate of its body's pitch [rad] (its balance loop's; 0 for the others: the
        encoders turn with the body, see :class:`sim.robot.sensing.EstimatorLoop`); ``reference`` (5,) x, y, theta, v,
        omega now; ``reference_preview`` (10, 3) poses every 0.1 s ahead; ``privileged_true_pose``
        (3,) the true pose (for learning baselines; a real robot has no such sensor).
        """
        ep = self._current()
        t = self.time(ep)
        ref = self.trajectory.sample_many([t])
        ahead = self.trajectory.sample_many(t + PREVIEW_SPACING_S * np.arange(1, PREVIEW_SAMPLES + 1)).pose
        fix, balance = ep.fix, ep.recorder.balance
        assert ep.accel is not None
        return OrderedDict(
            encoder_counts=np.array(ep.counts, dtype=np.int64),
            gyro_z=np.array([ep.gyro_z]),
            accel=np.array(ep.accel, dtype=np.float64),
            fix=np.array(fix if fix is not None else (0.0, 0.0, 0.0)),
            fix_valid=np.array([1.0 if fix is not None else 0.0]),
            fix_age=np.array([ep.fix_age]),
            time=np.array([t]),
            pitch_estimate=np.array([0.0 if balance is None else balance.pitch_estimate()]),
            reference=np.array([ref.x[0], ref.y[0], ref.theta[0], ref.v[0], ref.omega[0]]),
            reference_preview=np.ascontiguousarray(ahead),
            privileged_true_pose=np.array(ep.recorder.pose),
        )

    def time(self, episode: Episode) -> float:
        """Trajectory time at the start of the episode's current period [s]."""
        return episode.recorder.t0 + episode.k * self.schedule.dt_ctrl

    def get_reward(self, physics: Physics) -> float:
        """Tolerance on the position and heading error against the reference now (their product, in [0, 1])."""
        ep = self._current()
        x, y, th = ep.recorder.pose
        rx, ry, rth = self.trajectory.sample(self.time(ep)).pose
        pos = math.hypot(x - rx, y - ry)
        head = abs(math.remainder(th - rth, TWO_PI))
        r_pos = rewards.tolerance(pos, POSITION_BOUNDS, POSITION_MARGIN, sigmoid="gaussian", value_at_margin=0.1)
        r_head = rewards.tolerance(head, HEADING_BOUNDS, HEADING_MARGIN, sigmoid="gaussian", value_at_margin=0.1)
        return float(r_pos * r_head)

    def get_termination(self, physics: Physics) -> float | None:
        """1.0 at the trajectory's end plus the hold; 0.0 (a failure) at the first obstacle contact or
        at the end of the period in which the robot fell (:meth:`fallen`); else None."""
        ep = self._current()
        if ep.recorder.contacts or ep.fell:
            return 0.0
        return 1.0 if ep.k >= self.schedule.n_ctrl else None

    def log(self) -> RunLog:
        """The current episode so far as a run log (what :func:`sim.physics.metrics.compute_metrics` measures)."""
        ep = self._current()
        meta = {
            "robot": self.prepared.robot.name,
            "trajectory": self.trajectory.name,
            "environment": "sim.suite",
            "tracker": "agent",  # the actions came from the environment's caller
        }
        return ep.recorder.to_log(self.trajectory, meta)
