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
from sim.physics.asbuilt import TOLERANCES
from sim.physics.runlog import EstimationLog
from sim.physics.sensors import SensorModel, SensorProfile, encoder_count, load_sensor_profile
from sim.robot.scan_localiser import LocaliserLost, LocaliserSetup, ScanLocaliser, localiser_schedule
from sim.robot.sources import PoseSource

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
TWO_PI = 2.0 * math.pi

#: Slots of a run's reading state (:func:`_read_and_predict`): the last encoder counts and true
#: heading, then constants: time of period 0 [s], the period [s], counts per radian, the encoders'
#: phases [counts], radians per count, and the encoders' addresses in ``MjData.sensordata``; the
#: gyro's error at each period follows, from slot :data:`GYRO_ERROR`.
COUNTS_L, COUNTS_R, YAW, T0, DT, PER_RAD, PHASE_L, PHASE_R, RAD_PER_COUNT, ENC_L, ENC_R, GYRO_ERROR = range(12)
#: :func:`_read_and_predict`'s status for a period after the run's last (else the estimator's step status).
PAST_THE_RUN = -1


@nb.njit(cache=True)
def _read_and_predict(
    k: int,
    x: float,
    y: float,
    th: float,
    mem: FloatArray,
    sdata: FloatArray,
    io: FloatArray,
    trace: FloatArray,
) -> tuple[int, float, float, float]:  # pragma: no cover - compiled
    """Period k >= 1 of :meth:`Sensing.observe` in one compiled call: log the true pose (x, y, th)
    [m, m, rad], read the encoders (quantised) and the gyro (the mean true yaw rate over the period
    plus its error ``io[GYRO_ERROR + k]``), predict the estimator's block ``mem`` with them
    (:func:`control.estimation.kernels.step`) and log its pose and variances. ``trace`` holds a
    run's true poses, estimates and variances by period, three columns each.

    Returns:
        (status of the step, or PAST_THE_RUN for a period outside 1 .. the run's last; the estimated
        pose); on a failure the pose is NaN and the estimate is not logged.
    """
    if not 0 < k < io.shape[0] - GYRO_ERROR:  # (the trace has as many rows)
        return PAST_THE_RUN, math.nan, math.nan, math.nan
    row = trace[k]
    row[0], row[1], row[2] = x, y, th
    cl = encoder_count(sdata[int(io[ENC_L])], io[PER_RAD], io[PHASE_L])
    cr = encoder_count(sdata[int(io[ENC_R])], io[PER_RAD], io[PHASE_R])
    rate = kernels.wrap(th - io[YAW]) / io[DT]
    q = io[RAD_PER_COUNT]
    t = io[T0] + k * io[DT]
    status = kernels.step(mem, t, (cl - io[COUNTS_L]) * q, (cr - io[COUNTS_R]) * q, rate + io[GYRO_ERROR + k])
    io[COUNTS_L], io[COUNTS_R], io[YAW] = cl, cr, th
    if status != kernels.OK:
        return status, math.nan, math.nan, math.nan
    head = int(mem[kernels.NU_ROW, kernels.HEAD])
    return (status, *kernels.head_pose(mem, head, trace[:, 3:6], trace[:, 6:9], k))


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

    def estimator_config(self, robot: RobotSpec) -> EstimatorConfig:
        """The EKF's configuration for a robot (the explicit one, or derived from the profile)."""
        return self.estimator if self.estimator is not None else estimator_config(self.profile, robot.name)


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
    return cfg


class Sensing:
    """One run's sensors and estimator, called once per control period by the simulator.

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
        self.dt = 1.0 / control_rate
        self.t0 = t0
        adr = model.sensor_adr
        self._enc_l = int(adr[model.sensor("wheel_left_pos").id])
        self._enc_r = int(adr[model.sensor("wheel_right_pos").id])
        self._rad_per_count = TWO_PI / setup.profile.encoder_cpr
        self.estimator: PoseEstimator | None = None
        if self.source is not PoseSource.TRUTH:
            self.estimator = PoseEstimator.for_robot(robot, setup.estimator_config(robot))
        n = n_periods + 1
        self._trace = np.full((n, 9), np.nan)  # true pose, estimate, variances by period
        self.truth, self.estimate, self.variance = self._trace[:, :3], self._trace[:, 3:6], self._trace[:, 6:]
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
        # the compiled period's state and inputs (_read_and_predict), bound to the run's data at period 0
        self._io = np.concatenate([np.zeros(GYRO_ERROR), self.sensors.gyro_error])
        self._io[T0:GYRO_ERROR] = (t0, self.dt, setup.profile.encoder_cpr / TWO_PI, *self.sensors.encoder_phase,
                                   self._rad_per_count, self._enc_l, self._enc_r)  # fmt: skip
        self._data: mujoco.MjData | None = None
        self.scans: ScanLocaliser | None = None
        if setup.localiser.kind == "amcl" and self.source is PoseSource.FUSED:
            localiser_schedule(setup.localiser, self.sensors.fix_every, self.sensors.fix_latency_periods, self.dt)
            self.scans = ScanLocaliser(
                model, robot, setup.localiser, setup.seed, t0=t0, dt=self.dt, rad_per_count=self._rad_per_count
            )

    def observe(self, k: int, data: mujoco.MjData, truth: tuple[float, float, float]) -> tuple[float, float, float]:
        """The pose the tracker sees at control period ``k`` (``truth`` is MuJoCo's pose then; ``data``
        is the run's data, the same object at every period). A loop calls :meth:`observer` instead.

        Raises:
            EstimatorDivergedError: The estimator diverged (the simulator ends the run on it).
        """
        self._k = k
        est = self.estimator
        if est is None:
            self.truth[k] = truth
            return truth
        if k == 0:
            self.truth[k] = truth
            s = data.sensordata
            counts = self.sensors.encoder_counts(float(s[self._enc_l]), float(s[self._enc_r]))
            est.reset(self.t0, truth)
            self._io[COUNTS_L], self._io[COUNTS_R], self._io[YAW] = *counts, truth[2]
            self._data = data
            if self.scans is not None:
                self.scans.start(data, truth, counts)
        else:
            sdata = data.sensordata
            if data is not self._data:
                raise ValueError("Sensing.observe: a run's periods must all read the MjData of its period 0")
            status, *_ = _read_and_predict(k, *truth, est.block, sdata, self._io, self._trace)
            if status != kernels.OK:
                self._refuse(status, k)
        if k in self._fix_taken:
            if self.scans is None:
                self.fixes[k] = self.sensors.fix(k, truth)
            elif k > 0:
                self.scans.mark(k, (int(self._io[COUNTS_L]), int(self._io[COUNTS_R])))
        j = self._fix_delivered.get(k)
        if j is not None:
            self._deliver(j, k, truth)
        return est.record(self.estimate, self.variance, k)

    def observer(self, data: mujoco.MjData) -> Callable[[int, tuple[float, float, float]], tuple[float, float, float]]:
        """:meth:`observe` bound to the run's data, for a loop that calls it every period:
        ``observe(k, truth)``. A period after the first without a fix to take or deliver is one compiled
        call (:func:`_read_and_predict`, the same arithmetic) and a few operations."""
        observe, est, events, kernel = self.observe, self.estimator, self._events, _read_and_predict
        if est is None:
            return lambda k, truth: observe(k, data, truth)
        bound, refuse = (est.block, data.sensordata, self._io, self._trace), self._refuse

        def fast(k: int, truth: tuple[float, float, float]) -> tuple[float, float, float]:
            if k == 0 or k in events:
                return observe(k, data, truth)
            status, x, y, th = kernel(k, truth[0], truth[1], truth[2], *bound)
            self._k = k
            if status != kernels.OK:
                refuse(status, k)
            return x, y, th

        return fast

    def _refuse(self, status: int, k: int) -> None:
        """Raise the error of a failed period ``k`` (:func:`_read_and_predict`'s status)."""
        if status == PAST_THE_RUN:
            raise IndexError(f"control period {k} is outside the run's 0 .. {self.sensors.n_periods - 1}")
        assert self.estimator is not None
        self.estimator.raise_status(status, self.t0 + k * self.dt)

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
        self.nees.append((k, est.nees(truth)))

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
            raise EstimatorDivergedError(str(lost), t=lost.t, reason="localisation lost") from lost
        if got is None:
            return False
        self.fixes[j] = got[0]
        if est.correct(self.t0 + j * self.dt, got[0], got[1], got[2]):
            self.applied.append(j)
        return True

    def diverged(self, error: EstimatorDivergedError) -> None:
        """Record that the estimator diverged at the current period (the run ends there)."""
        self.status = f"estimator diverged at t={error.t:.3f} s ({error.reason}): {error}"

    def to_log(self) -> EstimationLog | None:
        """The run's estimation record (None when the tracker saw the truth)."""
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
        )
