"""What a run's tracker sees: the robot's own sensors, through an estimator, or the truth.

Each control period the simulator hands :class:`Sensing` the true state (MuJoCo's sensors); it turns
it into what the real robot would measure (:class:`sim.physics.sensors.SensorModel`: quantised
wheel encoders, a gyro with white noise and a wandering bias, pose fixes from a localiser, noisy and
late) and feeds those to an EKF (:class:`control.estimation.PoseEstimator`) that knows only the
robot as drawn. The tracker then gets, by :class:`PoseSource`:

- ``fused``: the EKF's estimate from encoders, gyro and fixes (the real robot's closed loop);
- ``odometry``: dead reckoning, the same EKF without fixes (feedback cannot remove what it cannot
  sense);
- ``truth``: MuJoCo's true pose, for comparison (and for the open-loop player, which ignores it).

The gyro reads the true *mean* yaw rate over the period (the heading change over the period
divided by its length, as an IMU's delta-angle output does) plus its bias and white noise. The
estimate, its variances and the consistency of each fix (NEES against the truth at the fix's
delivery) are kept for the run's :class:`sim.physics.runlog.EstimationLog`.

Everything is drawn from the run's noise seed, so the same seed gives the same run, bit for bit,
and every run kind of a job sees the same noise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import mujoco
import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.estimation import EstimatorConfig, EstimatorDivergedError, PoseEstimator, chi2_interval, kernels
from planning.core.robot import RobotSpec
from planning.errors import ConfigError
from sim.physics.asbuilt import TOLERANCES
from sim.physics.model import rolling_radius
from sim.physics.runlog import EstimationLog
from sim.physics.sensors import (
    SensorModel,
    SensorProfile,
    SensorReader,
    latency_periods,
    load_sensor_profile,
    robot_estimator_table,
    sensor_profile_path,
)
from sim.robot.scan_localiser import (
    AMBIGUOUS,
    LOST,
    UNCONVERGED,
    LocaliserAmbiguous,
    LocaliserLost,
    LocaliserSetup,
    ScanLocaliser,
    localiser_schedule,
    range_bias,
)
from sim.robot.sources import PoseSource

FloatArray = NDArray[np.float64]
TWO_PI = 2.0 * math.pi

#: The record of an estimator loop's period (:func:`predict_period`): the last encoder counts, the
#: time of period 0 [s], the period [s], radians per count and the last body pitch [rad].
LOOP_STATE = np.dtype(
    [
        ("counts", np.int64, (2,)),
        ("t0", np.float64),
        ("dt", np.float64),
        ("rad_per_count", np.float64),
        ("pitch", np.float64),
    ]
)
#: :func:`predict_period`'s status for a period outside 1 .. the run's last (else the estimator's step status).
PAST_THE_RUN = -1


@nb.njit(cache=True)
def predict_period(
    k: int,
    left: int,
    right: int,
    gyro: float,
    pitch: float,
    mem: FloatArray,
    state: NDArray[np.void],
    trace: FloatArray,
) -> tuple[int, float, float, float]:  # pragma: no cover - compiled
    """Period k >= 1 of an :class:`EstimatorLoop` in one compiled call: predict the estimator's
    block ``mem`` (:func:`control.estimation.kernels.step`) with the wheels' turns since the last
    period (the counts ``left``, ``right`` against those kept in ``state``, a (1,) array of
    :data:`LOOP_STATE`, plus the body's change of ``pitch`` [rad]: see :class:`EstimatorLoop`) and the
    gyro's reading [rad/s], and log its pose and variances into row k of ``trace`` (K, 6).

    Returns:
        (status of the step, or PAST_THE_RUN for a period outside 1 .. K - 1; the estimated pose);
        on a failure the pose is NaN and the estimate is not logged.

    The block layout and the prediction of ``kernels`` are compiled in: numba's cache for this kernel
    is renewed with theirs (:mod:`planning.kernel_cache`).
    """
    if not 0 < k < trace.shape[0]:
        return PAST_THE_RUN, math.nan, math.nan, math.nan
    s = state[0]
    counts, q = s.counts, s.rad_per_count
    dl, dr = (left - counts[0]) * q, (right - counts[1]) * q
    tilt = pitch - s.pitch
    if tilt != 0.0:  # the wheels' turns against the floor (added only when the body pitched)
        dl, dr = dl + tilt, dr + tilt
    status = kernels.step(mem, s.t0 + k * s.dt, dl, dr, gyro)
    counts[0], counts[1], s.pitch = left, right, pitch
    if status != kernels.OK:
        return status, math.nan, math.nan, math.nan
    head = int(mem[kernels.NU_ROW, kernels.HEAD])
    return (status, *kernels.head_pose(mem, head, trace[:, :3], trace[:, 3:], k))


class EstimatorLoop:
    """The robot's pose estimator run on its sensors' readings, once per control period: the EKF
    (:class:`control.estimation.PoseEstimator`, knowing only the robot as drawn) predicted with the
    encoder counts and the gyro's reading, corrected with the fixes that arrive, its pose and
    variances logged by period. The simulator's sensing and the control suite's reference policy
    run it.

    The EKF's nominal wheel radius is the drawing's rolling radius under the robot's weight
    (:func:`sim.physics.model.rolling_radius`: 0.3-0.4 % below the drawn radius, as a calibration
    drive on the robot as designed would find it), and its prior on each wheel's error about it is
    the build tolerance. With the drawn radius, the mean radius error started 2.2 (TurtleBot3) and
    1.7 (EduMIP) of that prior's sigmas away: the TurtleBot3's estimate led the truth along the path
    by 2 mm on average and its mean NEES reached 5.5 against 3 until the filter learnt the error
    (docs/explanation/sensors-ekf.md).

    The encoders measure each wheel's turn against the body. A robot whose body pitches (the
    balancing EduMIP leans to stand and to accelerate) turns its wheels against the floor by that
    plus the body's pitch change: rc_balance's wheel position is ``phi = mean(encoder angles) +
    theta`` (:mod:`control.balance`). Such a robot's loop is given its own pitch estimate (the balance
    firmware's, what the robot knows) at each period and adds its change to both wheels' turns;
    without it, the lean the balancing EduMIP takes to stand read as travel it never made (a turn in
    place: 2.8 mm of position error, the NEES inside its bounds at 3 % of the fixes).
    Robots whose pitch is not given (0) are predicted from the encoders alone.

    Args:
        robot: The robot as drawn (the estimator's geometry: its rolling radius and track).
        config: The estimator's noise model.
        n_periods: Control periods of the run (the estimate is logged at periods 0 .. n_periods).
        dt: The control period [s].
        rad_per_count: Wheel radians per encoder count.
    """

    def __init__(
        self, robot: RobotSpec, config: EstimatorConfig, *, n_periods: int, dt: float, rad_per_count: float
    ) -> None:
        self.estimator = PoseEstimator.for_robot(robot, config, wheel_radius=rolling_radius(robot))
        self.dt = dt
        self._trace = np.full((n_periods + 1, 6), np.nan)  # estimate, variances by period
        self.estimate, self.variance = self._trace[:, :3], self._trace[:, 3:]
        self._state = np.zeros(1, LOOP_STATE)
        self._state[0]["dt"], self._state[0]["rad_per_count"] = dt, rad_per_count
        self.t0 = 0.0

    def start(
        self,
        t0: float,
        pose: tuple[float, float, float],
        counts: tuple[int, int],
        pitch: float = 0.0,
        cov0: FloatArray | None = None,
    ) -> tuple[float, float, float]:
        """Period 0 at time ``t0`` [s]: the estimator at ``pose`` with covariance ``cov0`` (None: a known pose,
        the robot placed there), the encoders reading ``counts``, the body at ``pitch`` [rad] (see the class
        doc). Returns the pose."""
        self.t0 = t0
        self.estimator.reset(t0, pose, cov0)
        self._state[0]["t0"], self._state[0]["counts"], self._state[0]["pitch"] = t0, counts, pitch
        return self.record(0)

    def step(self, k: int, left: int, right: int, gyro: float, pitch: float = 0.0) -> tuple[float, float, float]:
        """Period ``k`` >= 1 (:func:`predict_period`) with the encoders' counts, the gyro's reading
        [rad/s] and the body's pitch [rad] (see the class doc); returns the estimated pose [m, m, rad].

        Raises:
            IndexError: ``k`` is outside the run's periods.
            EstimatorDivergedError: The estimator diverged.
            EstimatorInputError: A reading was not finite.
        """
        status, x, y, th = predict_period(k, left, right, gyro, pitch, self.estimator.block, self._state, self._trace)
        if status != kernels.OK:
            if status == PAST_THE_RUN:
                raise IndexError(f"control period {k} is outside the run's 1 .. {self._trace.shape[0] - 1}")
            self.estimator.raise_status(status, self.t0 + k * self.dt)
        return x, y, th

    def correct(
        self, j: int, fix: tuple[float, float, float], std_xy: float | None = None, std_theta: float | None = None
    ) -> bool:
        """Fuse the fix measured at period ``j`` (the estimator replays the periods since); True when
        it was applied (see :meth:`control.estimation.PoseEstimator.correct`)."""
        return self.estimator.correct(self.t0 + j * self.dt, fix, std_xy, std_theta)

    def record(self, k: int) -> tuple[float, float, float]:
        """Log the estimate as period ``k``'s (after a correction) and return its pose."""
        return self.estimator.record(self.estimate, self.variance, k)


@dataclass(frozen=True)
class SensingSetup:
    """The sensors and the estimator of a job's runs.

    Attributes:
        profile: The sensors' numbers (noise, rates, latency).
        seed: Seed of every noise draw (an integer >= 0); every run of a job uses the same one.
        estimator: The EKF's noise model; None derives it from the profile and the robot's build
            tolerances (:func:`estimator_config`).
        localiser: Where the fixes come from: synthetic (the profile's fix noise) or AMCL on the
            robot's laser scans (:mod:`sim.robot.scan_localiser`).
    """

    profile: SensorProfile
    seed: int = 0
    estimator: EstimatorConfig | None = field(default=None)
    localiser: LocaliserSetup = field(default_factory=LocaliserSetup)

    @classmethod
    def for_robot(cls, robot: str, seed: int = 0, *, text: str | None = None) -> SensingSetup:
        """The robot's own sensor profile (``models/sensors/<robot>.toml``), optionally overridden."""
        return cls(load_sensor_profile(robot, text=text), seed)

    def estimator_config(self, robot: RobotSpec, control_rate: float) -> EstimatorConfig:
        """The EKF's configuration for a robot at a control rate [Hz] (the explicit one, or derived from the
        profile and, with scan fixes, the scanner's accuracy: the priors of its range errors,
        :func:`range_bias`), its history long enough to take a fix as late as the profile delivers one.

        Raises:
            ConfigError: An explicit configuration whose history is shorter than the fixes' latency.
        """
        lag = latency_periods(self.profile.fix_latency, control_rate) if self.profile.fix_rate > 0 else 0
        if self.estimator is not None:
            if self.estimator.history_steps <= lag + 1:
                raise ConfigError(
                    f"EstimatorConfig.history_steps {self.estimator.history_steps} keeps less than the fixes' "
                    f"latency ({self.profile.fix_latency:g} s, {lag} periods at {control_rate:g} Hz): every fix "
                    f"would arrive too late to be fused; give history_steps >= {lag + 2}"
                )
            return self.estimator
        cfg = estimator_config(self.profile, robot.name)
        if self.localiser.kind == "amcl" and self.localiser.lidar is not None:
            _, sd_offset, sd_scale = range_bias(self.localiser.lidar)
            cfg = replace(cfg, range_scale_std=sd_scale, range_offset_std=sd_offset)
        # a fix is fused at its measurement time, which must still be in the history when it arrives: with 64
        # periods, a 0.2 s latency at 500 Hz (or 1.28 s at 50 Hz) dropped every fix, silently
        return replace(cfg, history_steps=max(cfg.history_steps, lag + 2))


def estimator_config(profile: SensorProfile, robot: str) -> EstimatorConfig:
    """An EKF configuration matched to the sensors and to the spread of the robot's builds.

    The estimator knows the noise of its sensors (the profile) and the tolerances the robot is
    built to (:data:`sim.physics.asbuilt.TOLERANCES`), never the draw itself.
    """
    cfg = EstimatorConfig(
        counts_per_rev=float(profile.encoder_cpr),
        gyro_noise_density=max(profile.gyro_noise_density, 1e-9),
        gyro_bias_walk=max(profile.gyro_bias_walk, 1e-12),
        gyro_bias_std=max(profile.gyro_bias_std, 1e-9),
        fix_std_xy=max(profile.fix_position_std, 1e-6),
        fix_std_theta=max(profile.fix_heading_std, 1e-6),
    )
    tol = TOLERANCES.get(robot)
    if tol is not None:
        cfg = replace(cfg, wheel_radius_rel_std=max(tol.radius, 1e-6), track_width_std=max(tol.track, 1e-6))
    own = robot_estimator_table(robot)  # a robot's own odometry noise, from its sensor settings file
    if own:
        try:
            cfg = replace(cfg, **own)  # type: ignore[arg-type]  # ESTIMATOR_KEYS: float fields only
        except ConfigError as exc:
            raise ConfigError(f"{sensor_profile_path(robot)}: [estimator]: {exc}") from None
    return cfg


class Sensing:
    """One run's sensors and estimator, called once per control period by the simulator.

    A period reads the sensors (:class:`sim.physics.sensors.SensorReader`), runs the estimator on
    the readings (:class:`EstimatorLoop`) and, at the periods that take or deliver a pose fix, takes
    it and fuses it.

    Args:
        model: The run's compiled model (named sensors ``base_pos``, ``base_quat``, and the encoders
            ``wheel_left_pos`` / ``wheel_right_pos``).
        robot: The robot as drawn (the estimator's geometry).
        source: Where the tracker's pose comes from.
        setup: Sensors and estimator.
        n_periods: Control periods of the run (readings are taken at periods 0 .. n_periods).
        control_rate: Control periods per second [Hz].
        t0: Time of period 0 [s].
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        robot: RobotSpec,
        source: PoseSource,
        setup: SensingSetup,
        *,
        n_periods: int,
        control_rate: float,
        t0: float,
    ) -> None:
        self.source = PoseSource(source)
        self.sensors = SensorModel(
            setup.profile, control_rate=control_rate, timestep=float(model.opt.timestep), n_periods=n_periods + 1,
            seed=setup.seed,
        )  # fmt: skip
        self.reader = SensorReader(model, self.sensors)
        self.dt = 1.0 / control_rate
        self.t0 = t0
        self._rad_per_count = TWO_PI / setup.profile.encoder_cpr
        self.loop: EstimatorLoop | None = None
        if self.source is not PoseSource.TRUTH:
            config = setup.estimator_config(robot, control_rate)
            self.loop = EstimatorLoop(robot, config, n_periods=n_periods, dt=self.dt, rad_per_count=self._rad_per_count)
        self.estimator = self.loop.estimator if self.loop is not None else None
        self.truth = np.full((n_periods + 1, 3), np.nan)  # true pose by period
        loop = self.loop
        self.estimate = loop.estimate if loop is not None else np.full_like(self.truth, np.nan)
        self.variance = loop.variance if loop is not None else np.full_like(self.truth, np.nan)
        self.nees: list[tuple[int, float]] = []  # (period, NEES) at each fix delivery
        self.fixes: dict[int, tuple[float, float, float]] = {}
        self.applied: list[int] = []  # periods whose fix the estimator accepted
        # fixes by period: measured at these, delivered at period -> measured at period
        self._fix_taken = frozenset(self.sensors.fix_periods.tolist())
        self._fix_delivered = dict(
            zip(self.sensors.fix_delivery_periods.tolist(), self.sensors.fix_periods.tolist(), strict=True)
        )
        self._events = self._fix_taken | self._fix_delivered.keys()  # periods with a fix taken or delivered
        self.status = "ok"
        self._k = -1
        self._data: mujoco.MjData | None = None
        self._pitch: Callable[[], float] | None = None
        self.scans: ScanLocaliser | None = None
        if setup.localiser.kind == "amcl" and self.source is PoseSource.FUSED:
            localiser_schedule(setup.localiser, self.sensors.fix_every, self.sensors.fix_latency_periods, self.dt)
            self.scans = ScanLocaliser(
                model,
                robot,
                setup.localiser,
                setup.seed,
                t0=t0,
                dt=self.dt,
                rad_per_count=self._rad_per_count,
                gyro_error=self.sensors.gyro_error,
            )

    def observer(
        self, data: mujoco.MjData, pitch: Callable[[], float] | None = None
    ) -> Callable[[int, tuple[float, float, float]], tuple[float, float, float]]:
        """:meth:`observe` of a run on ``data`` (its ``MjData``, the same object at every period);
        ``pitch``, for a robot whose body pitches, gives its own estimate of the body's pitch [rad]
        at each period (:class:`EstimatorLoop`: the wheels' turns against the floor).

        Raises:
            ValueError: This run's sensing already reads another ``MjData``.
        """
        if self._data is not None and data is not self._data:
            raise ValueError("Sensing.observer: a run's periods must all read the MjData of its period 0")
        self._data = data
        self._pitch = pitch
        return self.observe

    def observe(self, k: int, truth: tuple[float, float, float]) -> tuple[float, float, float]:
        """The pose the tracker sees at control period ``k`` (``truth`` is MuJoCo's pose then), the
        run's data bound by :meth:`observer`.

        Raises:
            EstimatorDivergedError: The estimator diverged, or global localisation ended undecided at period 0
                (reason :data:`sim.robot.scan_localiser.AMBIGUOUS`; the simulator ends the run on it).
            IndexError: ``k`` is outside the run's periods.
        """
        loop, data = self.loop, self._data
        if data is None:
            raise ValueError("Sensing.observe: bind the run's MjData first (Sensing.observer)")
        undecided, believed, cov0 = None, truth, None
        if k == 0:
            left, right, _ = self.reader.start(data, truth[2])
            if self.scans is not None:
                try:
                    self.scans.start(data, truth, (left, right))
                    believed, cov0 = self.scans.belief(truth)
                except LocaliserAmbiguous as exc:
                    undecided = exc
        else:
            left, right, gyro = self.reader.read(k, truth[2])
        self._k = k
        self.truth[k] = truth
        if loop is None:
            return truth
        pitch = 0.0 if self._pitch is None else self._pitch()
        if k == 0:
            pose = loop.start(self.t0, believed, (left, right), pitch, cov0)
        else:
            pose = loop.step(k, left, right, gyro, pitch)
        if undecided is not None:  # global localisation could not choose a pose: the run ends before tracking
            self._k = -1  # with no belief: the loop started at the truth only to end here, not an estimate
            raise EstimatorDivergedError(str(undecided), t=self.t0, reason=undecided.status) from undecided
        if k in self._events:
            self._fix_events(k, truth)
            pose = loop.record(k)
        return pose

    def _fix_events(self, k: int, truth: tuple[float, float, float]) -> None:
        """Take the fix measured at period ``k`` and fuse the one delivered then, if any."""
        if k in self._fix_taken:
            if self.scans is None:
                self.fixes[k] = self.sensors.fix(k, truth)
            elif k > 0:
                left, right = self.reader.counts.tolist()
                self.scans.mark(k, (left, right), truth[2])
        j = self._fix_delivered.get(k)
        if j is not None:
            self._deliver(j, k, truth)

    def _deliver(self, j: int, k: int, truth: tuple[float, float, float]) -> None:
        """The fix measured at period j arrives at period k: fuse it (with ``fused``) and measure the
        estimate's consistency (NEES) against the truth then. A fused run takes no sample for a fix
        too old for the estimator's history (it judged nothing), so a run whose fixes all came too
        late has no NEES statistic (NaN, written null and printed "-"), not a perfect one; a
        dead-reckoning run samples at every delivery, the instants its fused twin is checked. A run on
        the scan localiser samples where it gave a fix (a revolution that did not move the filter
        gives none and judges nothing)."""
        est = self.estimator
        assert est is not None
        stale = est.fixes_stale
        if self.scans is not None:
            if not self._deliver_scan(j, est):
                return
        elif self.source is PoseSource.FUSED and est.correct(self.t0 + j * self.dt, self.fixes[j]):
            self.applied.append(j)
        if est.fixes_stale > stale:  # older than the history: never compared with the estimate
            return
        nees = est.nees(truth)
        if math.isfinite(nees):  # NaN: a covariance singular in some direction judges nothing
            self.nees.append((k, nees))

    def _deliver_scan(self, j: int, est: PoseEstimator) -> bool:
        """The scan localiser's answer for the revolution centred on period j, fused at j's time with
        its own covariance (nothing when AMCL did not update); whether there was an answer.

        Raises:
            EstimatorDivergedError: The localiser lost the robot (the run ends there).
        """
        assert self.scans is not None and self._data is not None
        try:
            got = self.scans.fix(j, self._data, self.truth, self.estimate)
        except LocaliserLost as lost:
            raise EstimatorDivergedError(str(lost), t=lost.t, reason=LOST) from lost
        if got is None:
            return False
        self.fixes[j] = got.pose
        if est.correct(self.t0 + j * self.dt, got.pose, range_gain=got.range_gain, cov=got.cov):
            self.applied.append(j)
        return True

    def diverged(self, error: EstimatorDivergedError) -> None:
        """Record why the run ends at the current period, as what happened: the localiser never chose a pose
        ("localisation ambiguous: ..."), its global localisation did not converge, or it lost the robot ("localisation
        lost at t=...": the EKF did not diverge, its corrections were wrong); else the estimator diverged."""
        if error.reason == AMBIGUOUS:
            self.status = f"{AMBIGUOUS}: {error}"
        elif error.reason in (UNCONVERGED, LOST):  # their messages start with it
            self.status = str(error)
        else:
            self.status = f"estimator diverged at t={error.t:.3f} s ({error.reason}): {error}"

    def to_log(self) -> EstimationLog | None:
        """The run's estimation record (None when the tracker saw the truth); of no period when global localisation
        chose no pose at period 0 (the run had no belief: its statistics are null, its bag has no ``RUN/odom``)."""
        if self.estimator is None:
            return None
        n = self._k + 1
        periods = np.array([k for k in sorted(self.fixes) if k < n], dtype=np.int64)
        nees = np.array([v for _, v in self.nees])
        lo, hi = chi2_interval(3)
        return EstimationLog(
            source=str(self.source),
            t=np.asarray(self.t0 + self.dt * np.arange(n), dtype=float),
            truth=self.truth[:n].copy(),
            estimate=self.estimate[:n].copy(),
            variance=self.variance[:n].copy(),
            fix_t=np.asarray(self.t0 + self.dt * periods, dtype=float),
            fix=np.array([self.fixes[k] for k in periods]).reshape(-1, 3),
            fix_applied=np.isin(periods, self.applied),
            nees_t=self.t0 + self.dt * np.array([k for k, _ in self.nees], dtype=float),
            nees=nees,
            nees_bounds=(float(lo), float(hi)),
            status=self.status,
            localiser=self.scans.to_log() if self.scans is not None else None,
            fixes_widened=self.estimator.fixes_widened,
            relocalisations=self.estimator.relocalisations,
        )
