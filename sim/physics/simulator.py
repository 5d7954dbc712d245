"""The physics loop: a tracker drives the wheel joints of a robot in MuJoCo, and everything is logged.

Physics steps at the model's timestep (2 ms); the tracker is called at the control rate and physics
advances with ``mj_step(m, d, nstep=k)`` in between, so the Python controller costs once per control period;
within reach of an obstacle it advances one ``mj_step`` at a time, the obstacle contact sensor read after each,
so that a touch between two log samples is counted. The log is written every ``log_steps`` physics steps
(at least at the control rate, at most every 20 ms). The wheels are DC motors: the motors' firmware
velocity loop (:mod:`sim.physics.motors`) turns the wheel-speed command in force into voltages from
the measured wheel speeds every ``nhsim_motor_period`` (10 ms), on a grid fixed from the start.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.base import TRACKERS, Tracker
from control.design.balance_profile import is_balancing, load_balance_profile
from control.diffdrive import DiffDrive
from control.dispatch import bind
from control.estimation import EstimatorDivergedError
from planning.core.checks import check_flag, check_number, is_number, refuse_kind
from planning.core.copy_kernels import copy_into
from planning.core.geometry import Pose2D, check_pose
from planning.core.robot import RobotSpec, check_robot_spec, load_robot
from planning.core.world import World, check_world
from planning.errors import ConfigError, ModelError, NhsimError, SimulationError, option
from planning.trajectory.from_plan import infeasibility
from planning.trajectory.trajectory import Trajectory
from sim.physics.asbuilt import AsBuilt
from sim.physics.model import FLOOR_TILT, TIP_ANGLE, BuiltModel, set_pose, tipped_over, yaw_from_quat
from sim.physics.motors import MotorModel, Supply, check_model_limits, control_steps
from sim.physics.perturb import Perturbation
from sim.physics.runlog import Contact, RunLog
from sim.robot.balance_design import balance_gains
from sim.robot.balance_firmware import BalanceFirmware, Push
from sim.robot.sensing import Sensing, SensingSetup
from sim.robot.sources import PoseSource
from sim.robot.wheel_firmware import VelocityLoop

#: Progress reports during a run (besides the first and the last), see :meth:`Simulator.run`.
PROGRESS_UPDATES = 100

SENSOR = mujoco.mjtObj.mjOBJ_SENSOR

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

WARNING_NAMES = {int(v): k for k, v in mujoco.mjtWarning.__members__.items() if k != "mjNWARNING"}


#: Indices into a run's sensor address array (see :func:`_sample`), then the log's next row.
ADR_CONTACT, ADR_POS, ADR_QUAT, ADR_TOUCH_L, ADR_TOUCH_R, NEXT_ROW = range(6)


@nb.njit(cache=True)
def _sample(
    log: FloatArray,
    qpos: FloatArray,
    qvel: FloatArray,
    sdata: FloatArray,
    adr: IntArray,
    near: FloatArray,
    boxes: FloatArray,
    time: float,
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """The next row of a run's log (``adr[NEXT_ROW]``, counted up) [time, a wheel off the floor (1/0),
    qpos, qvel]; returns the pose x, y, theta the pose sensors read. A touch sensor address < 0: none.

    Sets ``near[0]`` to 1 when an obstacle's box (``boxes``: rows of centre x, y and half-widths, world frame)
    lies within ``near[1] + near[2] |v|`` [m] of the pose sensors' point (the robot's reach, a margin, and as
    far as its speed ``|v|`` [m/s], the root's at dof ``near[3]``, takes it by the next sample, thrice over), else
    to 0: only then can a contact begin before the next sample (:meth:`Recorder._physics_steps`)."""
    i = adr[NEXT_ROW]
    adr[NEXT_ROW] = i + 1
    row, nq = log[i], qpos.shape[0]
    row[0] = time
    tl, tr = adr[ADR_TOUCH_L], adr[ADR_TOUCH_R]
    row[1] = 1.0 if tl >= 0 and (sdata[tl] <= 0.0 or sdata[tr] <= 0.0) else 0.0
    copy_into(row[2 : 2 + nq], qpos)
    copy_into(row[2 + nq :], qvel)
    p, q = adr[ADR_POS], adr[ADR_QUAT]
    yaw = yaw_from_quat(sdata[q], sdata[q + 1], sdata[q + 2], sdata[q + 3])
    x, y = sdata[p], sdata[p + 1]
    dof = int(near[3])
    reach = near[1] + near[2] * np.hypot(qvel[dof], qvel[dof + 1])
    near[0] = 0.0
    for k in range(boxes.shape[0]):
        if abs(x - boxes[k, 0]) <= boxes[k, 2] + reach and abs(y - boxes[k, 1]) <= boxes[k, 3] + reach:
            near[0] = 1.0
            break
    return x, y, yaw


class InfeasibleReferenceWarning(UserWarning):
    """A trajectory given to :meth:`Simulator.run` asks for more than the robot can do (its wheels saturate), or its
    poses do not follow its velocities: the run goes on, as given, and its errors show the consequence."""


#: Slack [m] beyond the robot's reach within which an obstacle makes the physics look for contacts after every
#: step (:meth:`Recorder._physics_steps`): far more than a run moves in a log interval beyond its speed's share.
NEAR_MARGIN = 0.1

#: Longest hold after a trajectory's end [s] (:class:`SimConfig`): more is a unit slip, and would run for hours.
MAX_HOLD = 3600.0


@dataclass(frozen=True)
class SimConfig:
    """Settings of a run.

    Attributes:
        control_rate: Tracker calls per second [Hz]; the control period must be a whole number of
            physics steps.
        hold: Extra time simulated after the trajectory ends [s] (the reference holds its end), at most
            :data:`MAX_HOLD`.
        strict: Raise :class:`SimulationError` when MuJoCo warns (the log is attached); True or False
            (anything else is a ConfigError: ``"no"`` would read as true).
    """

    control_rate: float = 50.0
    hold: float = 0.0
    strict: bool = True

    def __post_init__(self) -> None:
        check_number("control rate", self.control_rate, above=0.0, unit="Hz")
        fix = "give the seconds to settle after the trajectory's end (a few: an hour of physics takes minutes to run)"
        check_number("SimConfig.hold", self.hold, at_least=0.0, at_most=MAX_HOLD, unit="s", fix=fix)
        object.__setattr__(self, "strict", check_flag("SimConfig.strict", self.strict))


class Simulator:
    """A robot in a world, ready to run trajectories.

    Args:
        robot: The robot spec as drawn (its MJCF scene is compiled); trackers and estimators know
            only this robot.
        world: Obstacles and walls to add; None for an empty floor.
        build: The robot as built (wheel radii, track, friction, mass, centre of mass; see
            :mod:`sim.physics.asbuilt`); None or nominal simulates the drawing.

    Raises:
        ConfigError: An argument of the wrong type (a robot's name for its spec, a seed for a build), naming it,
            what was given and what to pass.
        ModelError: The speed limits of a model file's own spec are not those its motors sustain on its supply
            (:func:`sim.physics.motors.check_model_limits`; a model with supply ratings).
    """

    def __init__(self, robot: RobotSpec, world: World | None = None, build: AsBuilt | None = None) -> None:
        self.robot = check_robot_spec("Simulator", robot)
        self.world = check_world("Simulator: world", world, none="an empty floor")
        self.build = check_as_built(robot, build)
        self.built: BuiltModel = self.build.compile(robot, world)
        self.model = self.built.model
        m = self.model
        self._pos_adr = int(m.sensor_adr[m.sensor("base_pos").id])
        self._quat_adr = int(m.sensor_adr[m.sensor("base_quat").id])
        self._wl_adr = int(m.sensor_adr[m.sensor("wheel_left_vel").id])
        self._wr_adr = int(m.sensor_adr[m.sensor("wheel_right_vel").id])
        self.root_qpos_adr = int(m.jnt_qposadr[m.joint("root").id])
        self.wheel_dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in ("wheel_left_joint", "wheel_right_joint")]
        self._act_l = m.actuator("wheel_left_motor").id
        self._act_r = m.actuator("wheel_right_motor").id
        self.motors = MotorModel.from_model(m)
        try:
            supply = Supply.from_model(m)
        except ModelError as exc:
            raise ModelError(f"{robot.mjcf}: {exc}") from None
        if supply is not None and robot == load_robot(str(robot.mjcf)):  # the file's own spec, not a supply's
            check_model_limits(robot, self.motors, supply)  # a user's model claiming more than its motors give
        # A balancing robot's firmware is its balance loop, its gains checked stable before any run.
        self.balance = balance_gains(robot.name) if is_balancing(robot.name) else None
        self._is_obstacle = np.zeros(m.ngeom, dtype=bool)
        self._is_obstacle[self.built.obstacle_geoms] = True
        self._is_robot = np.zeros(m.ngeom, dtype=bool)
        self._is_robot[self.built.robot_geoms] = True

    def balance_firmware(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        seed: int = 0,
        command_period: float | None = None,
        sensing: SensingSetup | None = None,
    ) -> BalanceFirmware:
        """The balance firmware of a run of this (balancing) robot on ``model`` and ``data``, with
        sensor-noise seed ``seed``, its wheel-speed commands changing every ``command_period`` [s]
        (the tracker's period; every firmware update if None), its sensors those of ``sensing``'s
        profile (the robot's own if None)."""
        if self.balance is None:
            raise ConfigError(f"robot {self.robot.name!r} does not balance: it has no balance firmware")
        sensors = (sensing or SensingSetup.for_robot(self.robot.name)).profile
        tip = load_balance_profile(self.robot.name).tip_angle
        return BalanceFirmware(model, data, self.balance, sensors, tip, seed, command_period)

    def balance_for_run(
        self,
        m: mujoco.MjModel,
        d: mujoco.MjData,
        pert: Perturbation | None,
        sensing: SensingSetup | None,
        command_period: float | None = None,
    ) -> BalanceFirmware | None:
        """A run's balance firmware (None for a robot that does not balance), with the perturbation's
        push; its sensor noise seeded by the sensing setup's seed, its commands changing every
        ``command_period`` [s] (the control period).

        Raises:
            ConfigError: A push for a robot that does not balance.
        """
        push = pert.push if pert is not None else None
        if self.balance is None:
            if push is not None:
                given = option("perturb", "push", python="perturbation=Perturbation(push=...)")
                raise ConfigError(
                    f"{given}: robot {self.robot.name!r} does not balance; a push is given to a balancing robot's "
                    f"body, e.g. {option('robot', 'edumip-balancing')}"
                )
            return None
        firmware = self.balance_firmware(m, d, sensing.seed if sensing is not None else 0, command_period, sensing)
        firmware.push = Push(*push) if push is not None else None
        return firmware

    def run_model(self, perturbation: Perturbation | None = None) -> mujoco.MjModel:
        """The model a run with ``perturbation`` steps: this robot as built, perturbed where the
        perturbation changes the model (friction, mass, wheel radius; a copy), else :attr:`model`."""
        pert = perturbation
        return pert.apply_to_model(self.model) if pert is not None and pert.changes_model else self.model

    def steps_per_control(self, control_rate: float) -> int:
        """Physics steps per control period; raises if the period is not a whole number of steps."""
        return control_steps(control_rate, float(self.model.opt.timestep))

    def read_pose(self, data: mujoco.MjData) -> tuple[float, float, float]:
        """Pose (x, y, theta) from the position and orientation sensors."""
        s = data.sensordata
        p, q = self._pos_adr, self._quat_adr
        return (
            float(s[p]),
            float(s[p + 1]),
            yaw_from_quat(float(s[q]), float(s[q + 1]), float(s[q + 2]), float(s[q + 3])),
        )

    def touching(self, data: mujoco.MjData) -> list[int]:
        """Obstacle geom ids the robot touches now (sorted)."""
        n = data.ncon
        if n == 0:
            return []
        g = data.contact.geom[:n]
        a, b = g[:, 0], g[:, 1]
        hit_a = self._is_obstacle[a] & self._is_robot[b]
        hit_b = self._is_obstacle[b] & self._is_robot[a]
        return sorted(set(a[hit_a].tolist()) | set(b[hit_b].tolist()))

    def run(
        self,
        trajectory: Trajectory,
        tracker: Tracker,
        config: SimConfig | None = None,
        *,
        start: Pose2D | None = None,
        drive: DiffDrive | None = None,
        meta: dict[str, Any] | None = None,
        perturbation: Perturbation | None = None,
        progress: Callable[[int, int], Any] | None = None,
        source: PoseSource = PoseSource.TRUTH,
        sensing: SensingSetup | None = None,
    ) -> RunLog:
        """Track a trajectory with a tracker in physics.

        Args:
            trajectory: The reference.
            tracker: The tracker (reset here).
            config: Rates and options.
            start: Initial pose; defaults to the trajectory's first pose.
            drive: The drive mapping the controller believes; defaults to the robot's.
            meta: Extra fields for the log's ``meta``.
            perturbation: Friction, mass, wheel radius, pose noise and latency changes (see
                :mod:`sim.physics.perturb`); None or nominal runs the model as built.
            progress: Called with (control periods done, total) at the start, at most about
                :data:`PROGRESS_UPDATES` times during the run and at the end; None costs nothing.
            source: Where the tracker's pose comes from: the fused estimate, dead reckoning or the
                truth (see :mod:`sim.robot.sensing`).
            sensing: The sensors and the estimator (default: the robot's sensor profile, seed 0);
                unused when ``source`` is the truth.

        Returns:
            The log; a run whose estimator diverged ends there, with its ``status`` saying why.

        Warns:
            InfeasibleReferenceWarning: The trajectory asks for more than the robot can do, or its poses do not
                follow its velocities (:func:`planning.trajectory.from_plan.infeasibility`); it is run as given.

        Raises:
            SimulationError: MuJoCo warned (with ``config.strict``), listing the warnings; the tracker returned a
                non-finite command, or raised other than an NhsimError (chained), naming it and the time.
            ConfigError: An argument of the wrong type, or a start outside the world's walls (:meth:`_check_run`;
                a start in an obstacle is run, its contact counted from the first step: a caller refuses it where it
                must, as a scenario does); a timed perturbation outside the run (:meth:`Perturbation.check_within`).
        """
        args = (trajectory, tracker, config, start, drive, meta, perturbation, progress, source, sensing)
        cfg, placed, source = self._check_run(*args)
        if why := infeasibility(trajectory, self.robot):  # run as given (a study of saturation may want it), said
            warnings.warn(
                f"Simulator.run: trajectory {trajectory.name!r}: {why}", InfeasibleReferenceWarning, stacklevel=2
            )
        pert = perturbation if perturbation is not None and not perturbation.is_nominal else None
        step = float(self.model.opt.timestep)  # a perturbed model's too
        delay = pert.latency_steps(step) if pert is not None else 0
        schedule = Schedule.make(self.steps_per_control(cfg.control_rate), step, trajectory.duration + cfg.hold, delay)
        if pert is not None:  # before any physics, against the run's whole control periods
            pert.check_within(schedule.duration)
        m = self.run_model(pert)
        d = mujoco.MjData(m)
        # a balancing robot starts upright at once: left alone to settle, it would topple
        set_pose(m, d, placed, **({"settle": 0.0} if self.balance is not None else {}))
        noise = pert.sensor_noise(schedule.n_ctrl) if pert is not None else None
        reset_tracker(tracker, trajectory, schedule.dt_ctrl)
        recorder = Recorder(self, m, d, schedule, float(trajectory.t[0]))
        recorder.balance = self.balance_for_run(m, d, pert, sensing, schedule.dt_ctrl)
        sensed = None
        if source is not PoseSource.TRUTH:
            setup = sensing if sensing is not None else SensingSetup.for_robot(self.robot.name)
            sensed = Sensing(m, self.robot, source, setup, n_periods=schedule.n_ctrl,
                             control_rate=cfg.control_rate, t0=recorder.t0)  # fmt: skip
        self._control_loop(recorder, tracker, drive or DiffDrive.from_robot(self.robot), noise, progress, sensed)
        info = self._run_meta(trajectory, tracker, cfg, float(m.opt.timestep), pert, meta)
        log = recorder.to_log(trajectory, info, sensed)
        if log.warnings and cfg.strict:
            err = SimulationError(f"MuJoCo warned during the run: {'; '.join(log.warnings)}")
            err.log = log  # type: ignore[attr-defined]
            raise err
        return log

    def _run_meta(
        self,
        trajectory: Trajectory,
        tracker: Tracker,
        cfg: SimConfig,
        timestep: float,
        pert: Perturbation | None,
        meta: Mapping[str, Any] | None,
    ) -> dict[str, Any]:
        """A run's log ``meta``: the robot, tracker, rates and trajectory (the balance loop's rate and the
        perturbation where there are), then the caller's ``meta``."""
        info: dict[str, Any] = {
            "robot": self.robot.name,
            "tracker": tracker.name,
            "control_rate_hz": cfg.control_rate,
            "timestep_s": timestep,
            "trajectory": trajectory.name,
        }
        if self.balance is not None:
            info["balance_rate_hz"] = self.balance.rate
        if pert is not None:
            info["perturbation"] = pert.as_dict()
            if pert.latency:  # a whole number of physics steps: 1 ms at 2 ms steps is none
                info["latency_applied_s"] = pert.latency_steps(timestep) * timestep
        info.update(meta or {})
        return info

    def _check_run(
        self,
        trajectory: object,
        tracker: object,
        config: object,
        start: object = None,
        drive: object = None,
        meta: object = None,
        perturbation: object = None,
        progress: object = None,
        source: object = PoseSource.TRUTH,
        sensing: object = None,
    ) -> tuple[SimConfig, Pose2D, PoseSource]:
        """The arguments of :meth:`run`, checked once before any physics (the control loop checks nothing):
        its settings, the pose the robot is placed at and the pose source.

        Raises:
            ConfigError: An argument of the wrong type (a tracker's name for a tracker, a dict for a
                :class:`SimConfig`, a tuple for a start pose), naming it, what was given and what to pass; a
                tracker made for another robot (its ``robot``'s name not this simulator's); a start
                (``start``, else the trajectory's first pose) outside the world's walls (:func:`check_start`).
        """
        if not isinstance(trajectory, Trajectory):
            fix = "make_reference(name, robot, start), or to_trajectory(plan, robot, world) for a plan"
            raise refuse_kind("Simulator.run: trajectory", "a Trajectory", trajectory, fix)
        if not (hasattr(tracker, "name") and all(callable(getattr(tracker, f, None)) for f in ("reset", "command"))):
            name = tracker if isinstance(tracker, str) else "fbl"
            kind = "a Tracker (an object with a name, reset(trajectory, dt) and command(t, x, y, theta))"
            raise refuse_kind("Simulator.run: tracker", kind, tracker, f"make_tracker({name!r}, robot)")
        made_for = getattr(getattr(tracker, "robot", None), "name", self.robot.name)
        if made_for != self.robot.name:  # its wheel geometry and limits are another robot's
            raise ConfigError(
                f"Simulator.run: tracker {tracker.name!r} was made for robot {made_for!r}, but this simulator runs "
                f"{self.robot.name!r}: make it for this one, make_tracker({tracker.name!r}, simulator.robot)"
            )
        if config is not None and not isinstance(config, SimConfig):
            fix = "SimConfig(control_rate=50.0)"
            if isinstance(config, Mapping) and all(isinstance(k, str) and k.isidentifier() for k in config):
                fix = f"SimConfig({', '.join(f'{k}={v!r}' for k, v in config.items())})"
            raise refuse_kind("Simulator.run: config", "a SimConfig or None (the defaults)", config, fix)
        placed = check_pose("Simulator.run: start", start, optional=True)
        if placed is None:
            placed = trajectory.start_pose
        check_start(self.world, placed, "start" if start is not None else "the trajectory's first pose")
        kinds: tuple[tuple[str, object, type, str], ...] = (
            ("drive", drive, DiffDrive, "DiffDrive.from_robot(robot)"),
            ("meta", meta, Mapping, "a dict of extra fields, e.g. {'seed': 0}"),
            ("perturbation", perturbation, Perturbation, "Perturbation(mass=1.3), or Perturbation.parse('mass=1.3')"),
            ("sensing", sensing, SensingSetup, f"SensingSetup.for_robot({self.robot.name!r})"),
        )
        for argument, value, cls, fix in kinds:
            if value is not None and not isinstance(value, cls):
                raise refuse_kind(f"Simulator.run: {argument}", f"a {cls.__name__} or None", value, fix)
        if progress is not None and not callable(progress):
            raise refuse_kind("Simulator.run: progress", "a callable or None", progress, "a function (done, total)")
        if not isinstance(source, str) or source not in tuple(PoseSource):
            said = ", ".join(f"PoseSource.{s.name} ({s.value!r})" for s in PoseSource)
            raise refuse_kind("Simulator.run: source", "a PoseSource", source, f"one of {said}")
        return config or SimConfig(), placed, PoseSource(source)

    def _control_loop(
        self,
        recorder: Recorder,
        tracker: Tracker,
        drive: DiffDrive,
        noise: NDArray[np.float64] | None,
        progress: Callable[[int, int], Any] | None,
        sensing: Sensing | None = None,
    ) -> None:
        """Run the recorder's schedule: the tracker once per control period, physics in ``nstep`` chunks
        between log samples and motor-firmware updates, the wheel commands taken up as they arrive
        (after the latency, if any). Python runs per control period, per log sample and per firmware
        update (10 ms), never per physics step; the chunks of each period are planned once
        (:meth:`Schedule.plan`), and the tracker's pose is the one the pose sensors read at the last
        log sample (the end of the previous period: the same state :meth:`read_pose` would read)."""
        schedule, d = recorder.schedule, recorder.data
        n_ctrl, t0, dt_ctrl = schedule.n_ctrl, recorder.t0, schedule.dt_ctrl
        commands = recorder.commands
        command, write = tracker.command, drive.command_writer(commands)
        advance = PeriodPhysics(self, recorder).advance
        every = max(1, -(-n_ctrl // PROGRESS_UPDATES))
        report = every if progress is not None else -1  # the next period that reports progress
        if progress is not None:
            progress(0, n_ctrl)
        balance = recorder.balance
        pitch = None if balance is None else balance.pitch_estimate
        observe = sensing.observer(d, pitch) if sensing is not None else None
        pose = recorder.pose  # the pose sensors at the last sample
        for k in range(n_ctrl):
            if k == report and progress is not None:
                progress(k, n_ctrl)
                report += every
            if observe is not None:
                try:
                    x, y, th = observe(k, pose)
                except EstimatorDivergedError as exc:
                    assert sensing is not None
                    sensing.diverged(exc)
                    break
            else:
                x, y, th = pose
            if noise is not None:
                x, y, th = x + noise[k, 0], y + noise[k, 1], th + noise[k, 2]
            t = t0 + k * dt_ctrl
            try:
                out = command(t, x, y, th)
            except NhsimError:  # the tracker's own refusal: its message says what went wrong
                raise
            except Exception as exc:  # whatever the tracker's code raised (a plugin's bug): one line, chained
                raise tracker_failed(tracker, f"command(t, x, y, theta) at t={t:.3f} s", exc) from exc
            try:
                v, w = out
                if k == 0 and (isinstance(v, str | bytes) or isinstance(w, str | bytes)):
                    raise TypeError("text, not numbers")  # numba's conversion would read it as numbers
                written = write(k + 1, v, w)  # commands[k + 1] = [v, w, left, right], if finite
            except (TypeError, ValueError) as exc:
                raise not_a_command(tracker, out, t) from exc
            if not written:
                raise SimulationError(
                    f"tracker {tracker.name!r} returned a non-finite command ({v}, {w}) at t={t:.3f} s: a command "
                    "must be two finite numbers (v [m/s], omega [rad/s]); fix the tracker's law (e.g. a division "
                    "by a vanishing speed or distance)"
                )
            pose = advance(k)
            if balance is not None:
                if balance.fell_at is not None:
                    break  # the robot fell: the run ends here (its status says when)
            elif tipped_over(d, *recorder.fall_geoms):  # a robot that does not balance fell over
                recorder.tipped_at = float(d.time)
                break
        if progress is not None:
            progress(n_ctrl, n_ctrl)


def not_a_command(tracker: Tracker, out: object, t: float) -> SimulationError:
    """The error of a run whose tracker's ``command`` returned ``out`` at ``t``, which is not two numbers."""
    shown = " ".join(repr(out).split())
    shown = shown if len(shown) <= 60 else shown[:57] + "..."
    return SimulationError(
        f"tracker {tracker.name!r} returned {shown} ({type(out).__name__}) from command(t, x, y, theta) at "
        f"t={t:.3f} s: a command must be two real numbers (v [m/s], omega [rad/s]), e.g. a tuple of floats; fix "
        "the tracker's command"
    )


def check_as_built(robot: RobotSpec, build: object) -> AsBuilt:
    """``build`` when it is an :class:`AsBuilt`; None gives the robot as drawn (:meth:`AsBuilt.nominal`).

    Raises:
        ConfigError: Anything else, naming the argument and what to pass (``AsBuilt.draw(name, seed)`` for a seed).
    """
    if build is None:
        return AsBuilt.nominal()
    if isinstance(build, AsBuilt):
        return build
    if is_number(build, integer=True) and build >= 0:
        fix = f"AsBuilt.draw({robot.name!r}, {build!r}) for the build of seed {build}"
    else:
        fix = f"AsBuilt.draw({robot.name!r}, seed), or None for the robot as drawn"
    raise refuse_kind("Simulator: build", "an AsBuilt or None (the robot as drawn)", build, fix)


def check_start(world: World | None, pose: Pose2D, what: str) -> None:
    """Refuse a start pose (``what`` names it) whose position lies outside the world's walls: the robot would be
    placed beyond them, and the run would say nothing of it. None (an empty floor) has none. A start in an obstacle
    is the caller's to refuse (a scenario's is; a file run with ``allow_collisions`` may start in one).

    Raises:
        ConfigError: Naming the pose, the bounds and the fix.
    """
    if world is None:
        return
    xy = np.array([[pose.x, pose.y]])
    if not float(world.wall_distance(xy)[0]) > 0.0:
        xmin, xmax, ymin, ymax = world.bounds
        raise ConfigError(
            f"Simulator.run: {what} ({pose.x:g}, {pose.y:g}, {pose.theta:g}) lies outside the world's walls (x "
            f"{xmin:g}..{xmax:g}, y {ymin:g}..{ymax:g} m): give a start inside them (start=Pose2D(x, y, theta)), or "
            "a world whose bounds hold it"
        )


def reset_tracker(tracker: Tracker, trajectory: Trajectory, dt: float) -> None:
    """``tracker.reset(trajectory, dt)``; an exception of the tracker's own code (not an NhsimError, its refusal
    of a trajectory it cannot track) is a SimulationError naming it (:func:`tracker_failed`)."""
    try:
        tracker.reset(trajectory, dt)
    except NhsimError:
        raise
    except Exception as exc:  # whatever the tracker's code raised
        raise tracker_failed(tracker, "reset(trajectory, dt)", exc) from exc


def tracker_failed(tracker: Tracker, call: str, exc: Exception) -> SimulationError:
    """The error of a run whose tracker raised ``exc`` (not an NhsimError) in ``call`` (its ``reset``, or its
    ``command`` at a time): it names the tracker, who registered it (when registered: built in, a plugin, the
    program's own code), the call, and the exception's type and message, on one line (the caller chains ``exc``
    to it)."""
    name = tracker.name
    origin = TRACKERS.origins.get(name) if isinstance(name, str) else None  # a tracker made by hand has none
    who = f"tracker {name!r}" + (f" ({origin})" if origin else "")
    said = " ".join(str(exc).split())  # one line, as the command line prints it
    return SimulationError(
        f"{who} raised {type(exc).__name__} in {call}: {said}; fix the tracker's {call.split('(')[0]} (the "
        "exception is chained to this error, as __cause__, with its traceback)"
    )


class PeriodPhysics:
    """The physics of a run's control periods: the motor firmware and ``mj_step`` chunks its schedule
    plans (:meth:`Schedule.plan`), with the recorder's log samples between them.

    The simulator's control loop and the control-suite environment (:mod:`sim.suite`) step a period
    with the same code, so both drive the same physics from the same wheel commands, bit for bit.

    Args:
        simulator: The simulator (wheel joints and actuators, motor firmware).
        recorder: The run's buffers; its ``wheel_command`` row ``k + 1`` holds period k's command.

    Attributes:
        advance: ``advance(k)`` steps control period ``k``: the wheel command in force is taken up as it
            arrives (after the latency, if any) at each firmware update; returns the pose the pose
            sensors read at the period's last log sample [m, m, rad]. A closure with the run's
            constants bound (called every period, it looks nothing up).
    """

    advance: Callable[[int], tuple[float, float, float]]

    def __init__(self, simulator: Simulator, recorder: Recorder) -> None:
        m, d, wcmd = recorder.model, recorder.data, recorder.wheel_command
        qvel, ctrl = d.qvel, d.ctrl
        # qvel and ctrl indices of the left and right wheel
        wiring = np.array([simulator.wheel_dofs, [simulator._act_l, simulator._act_r]], dtype=np.int64)
        firmware: Callable[[int], None]  # update(row of the wheel command in force)
        if (balance := recorder.balance) is not None:  # the balance loop drives the voltages at its own rate

            def firmware(row: int) -> None:
                balance.drive(wcmd, row, qvel, ctrl, wiring)

            k_fw = balance.steps
        else:  # every k_fw steps from the start of the run
            firmware = VelocityLoop(simulator.motors).driver(wcmd, qvel, ctrl, wiring)
            k_fw = simulator.motors.steps_per_update(m.opt.timestep)
        self.advance = self._stepper(recorder, firmware, recorder.schedule.plan(k_fw))

    @staticmethod
    def _stepper(
        rec: Recorder, firmware: Callable[[int], None], plans: tuple[tuple[tuple[bool, int, int, bool], ...], ...]
    ) -> Callable[[int], tuple[float, float, float]]:
        """The :attr:`advance` of a run: in general it follows ``plans[k % len(plans)]``; when every
        period is the same chunks, each after a firmware update with the period's own command (no
        latency) and the log sampled after the last, it runs just those."""
        sample, n_plans, step = rec.sample, len(plans), rec.step
        m, d, mj_step, near = rec.model, rec.data, mujoco.mj_step, rec.near
        last = len(plans[0]) - 1
        plain = all(update and src == 1 and log == (i == last) for i, (update, src, _, log) in enumerate(plans[0]))
        if plain and len(set(plans)) == 1:
            steps = tuple(n for _, _, n, _ in plans[0])

            def advance_plain(k: int) -> tuple[float, float, float]:
                row = k + 1  # the command computed at the start of the period
                if near[0] == 0.0:  # no obstacle within reach until the period's sample: nstep chunks, unwatched
                    for n in steps:
                        firmware(row)
                        mj_step(m, d, n)  # nstep, passed by position (a keyword costs a pybind11 lookup)
                else:
                    for n in steps:
                        firmware(row)
                        step(n)
                return sample()

            return advance_plain

        def advance(k: int) -> tuple[float, float, float]:
            pose = rec.pose
            for update, src, n, log in plans[k % n_plans]:
                if update:  # the wheel command in force: row k + src (the last computed at or before now - latency)
                    firmware(k + src)  # a row < 0 (latency, at the start) reads row 0
                step(n)
                if log:
                    pose = sample()
            return pose

        return advance


@dataclass(frozen=True)
class Schedule:
    """When a run calls its tracker and samples its log.

    Attributes:
        k_ctrl: Physics steps per control period.
        chunks: Log samples per control period (at most 10 physics steps each, and with latency
            ending where commands arrive).
        k_log: Physics steps per log sample.
        n_ctrl: Control periods of the run.
        delay: Latency in physics steps.
        dt_ctrl: Control period [s].
    """

    k_ctrl: int
    chunks: int
    k_log: int
    n_ctrl: int
    delay: int
    dt_ctrl: float

    @classmethod
    def make(cls, k_ctrl: int, timestep: float, horizon: float, delay: int = 0) -> Schedule:
        """The schedule of a run of ``horizon`` seconds [s] at ``k_ctrl`` steps of ``timestep`` [s]
        per control period, with ``delay`` physics steps of latency."""
        chunks = next(
            c for c in range(1, k_ctrl + 1) if k_ctrl % c == 0 and k_ctrl // c <= 10 and delay % (k_ctrl // c) == 0
        )
        dt_ctrl = k_ctrl * timestep
        n_ctrl = math.ceil(horizon / dt_ctrl - 1e-9)
        return cls(k_ctrl, chunks, k_ctrl // chunks, n_ctrl, delay, dt_ctrl)

    @property
    def duration(self) -> float:
        """How long the run lasts: its whole control periods [s]."""
        return self.n_ctrl * self.dt_ctrl

    def plan(self, k_fw: int) -> tuple[tuple[tuple[bool, int, int, bool], ...], ...]:
        """The physics chunks of the control periods, with the motor firmware updated every ``k_fw``
        physics steps on a grid fixed from the start of the run.

        Period k's chunks are ``plan[k % len(plan)]``: (update the firmware first, with the wheel
        command of row ``max(k + src, 0)``; ``src``; physics steps; take a log sample after them).
        A chunk ends at a firmware update or a log sample, whichever comes first.

        Args:
            k_fw: Physics steps per firmware update (>= 1).
        """
        phases = k_fw // math.gcd(self.k_ctrl, k_fw)  # the pattern repeats after this many periods
        plans = []
        for phase in range(phases):
            chunks: list[tuple[bool, int, int, bool]] = []
            for j in range(self.chunks):
                # the command computed at the last control instant <= now - latency (row k + src)
                src = (j * self.k_log - self.delay) // self.k_ctrl + 1 if self.delay else 1
                s = phase * self.k_ctrl + j * self.k_log
                end = s + self.k_log
                while s < end:
                    n = min(end, s - s % k_fw + k_fw) - s
                    chunks.append((s % k_fw == 0, src, n, s + n == end))
                    s += n
            plans.append(tuple(chunks))
        return tuple(plans)

    @property
    def n_log(self) -> int:
        """Log samples of the run (the start, then ``chunks`` per control period)."""
        return self.n_ctrl * self.chunks + 1

    def command_rows(self) -> NDArray[np.int64]:
        """(n_log,) row of the command table in force during each log sample: the one set at the
        start of its control period (row 0: none yet)."""
        return np.concatenate([[0], np.repeat(np.arange(1, self.n_ctrl + 1), self.chunks)])

    def wheel_command_rows(self) -> NDArray[np.int64]:
        """(n_log,) row of the wheel command table actually applied during each log interval."""
        if not self.delay:
            return self.command_rows()
        arrived = (np.arange(self.n_log - 1) * self.k_log - self.delay) // self.k_ctrl + 1
        return np.concatenate([[0], np.maximum(arrived, 0)])


class Recorder:
    """The buffers of one run, filled by the control loop and turned into its :class:`RunLog`.

    Args:
        simulator: The simulator (sensor and joint addresses, obstacle geoms).
        model: The model the run steps (perturbed or not).
        data: The run's data, at the start pose (sampled here as the first log row).
        schedule: The run's schedule.
        t0: Trajectory time of the start [s].
    """

    def __init__(
        self, simulator: Simulator, model: mujoco.MjModel, data: mujoco.MjData, schedule: Schedule, t0: float
    ) -> None:
        self.simulator, self.model, self.data, self.schedule, self.t0 = simulator, model, data, schedule, t0
        n_log, nq = schedule.n_log, model.nq
        self._log = np.empty((n_log, 2 + nq + model.nv))  # time, a wheel off the floor (1/0), qpos, qvel
        self.times, self.qpos, self.qvel = self._log[:, 0], self._log[:, 2 : 2 + nq], self._log[:, 2 + nq :]
        self.commands = np.zeros((schedule.n_ctrl + 1, 4))  # v, omega, left, right from the tracker
        self.command, self.wheel_command = self.commands[:, :2], self.commands[:, 2:]
        self.contacts: list[Contact] = []
        self.balance: BalanceFirmware | None = None  # a balancing robot's firmware (set by the simulator)
        #: When a robot that does not balance fell over (:func:`sim.physics.model.tipped_over`, at the end of a
        #: period; the run ended there), else None.
        self.tipped_at: float | None = None
        self.fall_geoms = (model.body("base").id, model.geom("chassis").id, model.geom("floor").id)
        self._touching: set[int] = set()
        self._qpos, self._qvel, self._sdata = data.qpos, data.qvel, data.sensordata
        touch = [n for n in ("wheel_left_touch", "wheel_right_touch") if mujoco.mj_name2id(model, SENSOR, n) >= 0]
        self._has_touch = len(touch) == 2
        adr = [int(model.sensor_adr[model.sensor(n).id]) for n in ("obstacle_contact", "base_pos", "base_quat")]
        adr += [int(model.sensor_adr[model.sensor(n).id]) for n in touch] if self._has_touch else [-1, -1]
        self._adr = np.array([*adr, 0], dtype=np.int64)  # and the next row of the log
        root = float(model.jnt_dofadr[model.joint("root").id])
        #: The gate of :meth:`_physics_steps`: [near (1.0) or not (0.0) at the last log sample, the robot's reach and
        #: margin [m], its speed's share [s], its root's first velocity dof] (set by :func:`_sample`).
        self.near = np.array([1.0, *self._reach(simulator, model, data, schedule), root])
        boxes = self._obstacle_boxes(simulator, model, data)
        # the compiled sample bound to the run's arrays, its overload resolved once (control/dispatch.py)
        self._sample = bind(
            _sample, self._log, self._qpos, self._qvel, self._sdata, self._adr, self.near, boxes, free=(0.0,)
        )
        self.pose = self._sample(data.time)  # the pose sensors' pose at the start
        self.step = self._physics_steps()

    def _reach(
        self, simulator: Simulator, model: mujoco.MjModel, data: mujoco.MjData, schedule: Schedule
    ) -> tuple[float, float]:
        """The robot's reach from the pose sensors' point (the farthest of its geoms' bounding spheres, whatever
        its attitude) and :data:`NEAR_MARGIN` [m], and how far a speed [m/s] takes it by the next log sample,
        thrice over (:func:`_sample`'s gate)."""
        p = int(self._adr[ADR_POS])
        here = data.sensordata[p : p + 3]
        robot = np.flatnonzero(simulator._is_robot)
        reach = float(np.max(np.linalg.norm(data.geom_xpos[robot] - here, axis=1) + model.geom_rbound[robot]))
        return reach + NEAR_MARGIN, 3.0 * schedule.k_log * float(model.opt.timestep)

    @staticmethod
    def _obstacle_boxes(simulator: Simulator, model: mujoco.MjModel, data: mujoco.MjData) -> FloatArray:
        """(K, 4) the obstacle and wall geoms' boxes in the world's x-y plane: centre x, y and half-widths [m]
        (MuJoCo's own boxes of them, ``geom_aabb``, turned into the world frame; they do not move)."""
        g = np.flatnonzero(simulator._is_obstacle)
        if g.size == 0:
            return np.zeros((0, 4))
        rot = data.geom_xmat[g].reshape(-1, 3, 3)
        centre = data.geom_xpos[g] + np.einsum("kij,kj->ki", rot, model.geom_aabb[g, :3])
        half = np.einsum("kij,kj->ki", np.abs(rot), model.geom_aabb[g, 3:])
        return np.ascontiguousarray(np.column_stack([centre[:, :2], half[:, :2]]))

    def _physics_steps(self) -> Callable[[int], None]:
        """``step(n)``: ``n`` physics steps. Near an obstacle (:func:`_sample`'s gate, as the last log sample
        found it) each is followed by a look at the obstacle contact sensor (and at the contacts, while it fires
        or one was touching), so that a touch between two log samples is counted: the log is sampled every 20 ms
        at most, and a robot grazing a box for 4-8 ms between two samples was a run without a collision. Away
        from them, ``mj_step(m, d, nstep=n)``, the same states bit for bit: stepping one at a time throughout took
        ``nhsim bench sim`` to 0.756 of a bare loop (its target 0.8), against 0.80-0.84 for this gate and for the
        code before it, in the same hour (2026-12-06)."""
        m, d, step, sdata, contact = self.model, self.data, mujoco.mj_step, self._sdata, int(self._adr[ADR_CONTACT])
        check, near = self._contact_check, self.near

        def steps(n: int) -> None:
            if near[0] == 0.0:
                step(m, d, n)  # nstep, passed by position (a keyword costs a pybind11 lookup)
                return
            for _ in range(n):
                step(m, d)
                if sdata[contact] > 0.0 or self._touching:
                    check()

        return steps

    def sample(self) -> tuple[float, float, float]:
        """Log the state now.

        Returns:
            The pose (x, y, theta) [m, m, rad] the pose sensors read now (as :meth:`Simulator.read_pose`).
        """
        pose = self.pose = self._sample(self.data.time)
        return pose

    def _contact_check(self) -> None:
        d = self.data
        now = set(self.simulator.touching(d))
        names = self.simulator.built.obstacle_names
        for g in sorted(now - self._touching):
            self.contacts.append(Contact(float(self.t0 + d.time), names.get(g, str(g))))
        self._touching = now

    def warnings(self) -> tuple[str, ...]:
        """MuJoCo's warnings of the run, one line per kind."""
        w = self.data.warning
        return tuple(
            f"{WARNING_NAMES.get(j, str(j))} x{w[j].number} (last at step info {w[j].lastinfo})"
            for j in range(len(w))
            if w[j].number > 0
        )

    def to_log(self, trajectory: Trajectory, meta: dict[str, Any], sensing: Sensing | None = None) -> RunLog:
        """The run's log: true poses at the logged times, the commands in force, the reference, and
        what the estimator believed (a run that ended early is cut where it ended)."""
        sim, n = self.simulator, int(self._adr[NEXT_ROW])
        qpos = self.qpos[:n]
        t_log = self.t0 + self.times[:n]
        # The log records the true state at the logged time (qpos after the step); the tracker saw
        # the pose sensors, which MuJoCo evaluates at the start of the last step (2 ms earlier).
        r = sim.root_qpos_adr
        q = qpos[:, r + 3 : r + 7]
        yaw = np.arctan2(2.0 * (q[:, 0] * q[:, 3] + q[:, 1] * q[:, 2]), 1.0 - 2.0 * (q[:, 2] ** 2 + q[:, 3] ** 2))
        pose = np.column_stack([qpos[:, r], qpos[:, r + 1], yaw])
        pose[:, 2] = np.unwrap(pose[:, 2])
        cmd = self.command[self.schedule.command_rows()[:n]]
        wcmd = self.wheel_command[self.schedule.wheel_command_rows()[:n]]
        wspd = self.qvel[:n, sim.wheel_dofs]
        ref = trajectory.sample_many(t_log).pose
        estimation = sensing.to_log() if sensing is not None else None
        status = sensing.status if sensing is not None else "ok"
        fw = self.balance
        ended = np.inf
        if fw is not None and fw.fell_at is not None:
            ended = self.t0 + fw.fell_at
            status = (
                f"fell at t={ended:.3f} s (|tilt| beyond {fw.tip_angle:g} rad or the chassis on the floor); the run "
                "ended there"
            )
        elif self.tipped_at is not None:
            ended = self.t0 + self.tipped_at
            status = (
                f"fell at t={ended:.3f} s (|tilt| beyond {TIP_ANGLE:g} rad, or beyond {FLOOR_TILT:g} rad with the "
                "chassis on the floor); the run ended there"
            )
        first = next((c for c in self.contacts if c.t <= ended), None)  # not one the fall itself made
        if status != "ok" and first is not None:  # a collision moved the robot: say it before what it caused
            status = f"collided with {first.obstacle!r} at t={first.t:.3f} s, then {status}"
        return RunLog(
            t_log, pose, qpos, ref, cmd, wcmd, wspd, tuple(self.contacts), self.warnings(), meta,
            estimation=estimation, wheel_off_floor=self._log[:n, 1] > 0.5 if self._has_touch else None,
            status=status, balance=fw.to_log(self.t0) if fw is not None else None,
        )  # fmt: skip
