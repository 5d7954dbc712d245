"""Pose estimation for a differential-drive robot: wheel encoders + gyro, fused with delayed pose fixes.

State (10,): x [m], y [m], theta [rad], b_g [rad/s], e_m [-], e_d [-], beta [-], k [rad s^2/m],
s_r [-], o_r [m]:

- (x, y, theta): the pose of the axle centre.
- b_g: the gyro's z-rate bias. A MEMS gyro left with a residual bias of 2e-3 rad/s after its
  start-up calibration turns the heading by 0.12 rad a minute; consecutive heading fixes observe
  the bias, and estimating it keeps the heading right between fixes and through fix outages
  (the bias random walk keeps it from freezing).
- e_m, e_d, beta: the as-built robot's unknown systematic errors, relative: left and right wheel
  radii r (1 + e_m - e_d) and r (1 + e_m + e_d), track width b (1 + beta). Borenstein and Feng's
  UMBmark (IEEE T-RA 12(6), 1996) names exactly these, unequal wheel diameters (E_d) and the
  uncertain effective wheelbase (E_b), as the dominant systematic odometry errors.
- k: the tyres' cornering compliance. A tyre carries a side force only by slipping sideways: in a
  turn the axle centre moves at a slip angle alpha = -k v omega off its heading (outwards, in
  proportion to the lateral acceleration v omega; Pacejka, Tire and Vehicle Dynamics, 3rd ed. 2012,
  ch. 1: the cornering stiffness). It is small, and it is systematic: on a steady circle every
  step is turned the same way, and position fixes then show the robot moving off its heading. A
  filter without it turns its heading towards the motion it sees, away from the gyro's, and is
  over-confident in the heading on every long turn: on the EduMIP's circle (0.38 m/s, 0.15 m/s^2
  of lateral acceleration) the simulated axle centre moves 3.4 mrad off its heading (k = 0.023),
  and without k the heading estimate lagged by 4-5 mrad against its own 1.5 mrad standard
  deviation (NEES inside its bounds 20 % of the fixes; with k, 95 %). k is constant, with a prior
  of ``cornering_slip_std`` about zero; turns with fixes calibrate it, straight runs leave it be.
- s_r, o_r: the range sensor's systematic errors, when the fixes come from matching its scans to a
  map: a relative scale error of the far readings and an offset of the near ones (the LDS-01's
  datasheet states its accuracy so; :mod:`sim.physics.lidar`). A unit's error is the same in every
  revolution, so every scan fix is off by it, moved through the fit: ``G (s_r, o_r)`` with G the
  fix's gain (the pose's change per unit of each error, :meth:`PoseEstimator.correct`), which
  changes only with the walls around the robot. Fusing such fixes as independent, with the
  systematic part in each one's covariance, lets the common error pull the estimate with a
  confidence it has not earned (measured on sparse random worlds: NEES inside its bounds at 12-79 %
  of the fixes); as states with the datasheet's priors (``range_scale_std``, ``range_offset_std``)
  the filter carries the correlation between fixes, and fixes among walls at different ranges
  calibrate the scanner. With zero priors (no such sensor) they stay at zero and change nothing.

Why the systematic errors are states and not only inflated process noise: a constant scale error
eps makes the distance error grow like eps * s, so its variance grows like s^2, while white
process noise (variance proportional to |ds| per step, the rate-independent form of Chong and
Kleeman, ICRA 1997, and Kelly, IJRR 23(2), 2004) grows like s. An inflation matched at one
horizon is optimistic beyond it and pessimistic before it: the filter cannot stay consistent
over a run. Carrying the errors as constant states with priors equal to the build tolerance is
the limiting case of inflation with the right correlation: the covariance grows exactly as the
systematic error does, the fixes calibrate them online (Martinelli, Tomatis and Siegwart,
Autonomous Robots 22, 2007), and the estimator never needs to know the draw. White noise remains
for what is really random: wheel slip and backlash (``wheel_noise``, variance per radian turned),
encoder quantisation (q = 2 pi / counts; see :data:`QUANT_PERIOD`),
lateral scrub (``position_noise``, variance per metre), gyro angle random walk and bias walk.

Heading: the gyro (``heading="gyro"``, the default). The prediction uses the encoder arc length
ds and the gyro's heading increment (w_gyro - b_g) dt; the encoders' differential yaw
r (dphi_r - dphi_l) / b is not used. Its errors are the systematic ones above, amplified by
r / b: a 0.5 % radius mismatch on a TurtleBot3 (b = 0.16 m) turns the heading by 0.03 rad per
metre driven straight, a 3 mm track error mis-scales every turn by 2 %, and both grow without
bound; a gyro's errors are white noise and a slowly wandering bias, which the EKF models exactly.
This is how robot_localization (Moore and Stouch, IAS-13, 2014) is commonly set up on TurtleBots:
the odometry's forward speed and the IMU's yaw rate, not the odometry's yaw; Borenstein and
Feng's "Gyrodometry" (ICRA 1996) already took the gyro's rate whenever it and the encoders'
disagreed. Fusing the encoder yaw with the gyro's would correlate the process noise with a
pseudo-measurement of the same increment and, on straight runs, bias b_g by the wheel mismatch.
``heading="encoders"`` uses the encoder yaw instead, for a robot without a gyro; then beta and
the radius errors drive the heading (dead reckoning this way reaches a heading std of 0.14 rad
in 20 s on the test drive, where the EKF's linearisation makes the position 1.5x over-confident;
with fixes it stays consistent).

Prediction: exact arc integration (:mod:`control.estimation.odometry`) of (ds, dtheta) with
Jacobians with respect to the state and the noise (Thrun, Burgard and Fox, Probabilistic
Robotics, 2005, secs. 3.3 and 7.4: EKF localisation with the motion model linearised about the
estimate; the odometry motion model of sec. 5.4 gives the structure of the noise).

Correction with a pose fix z = (x, y, theta) + G (s_r, o_r) + v, v ~ N(0, R), R diag(s_xy^2, s_xy^2,
s_th^2) or the fix's own covariance (a localiser's), G zero but for scan fixes; the
heading innovation is wrapped to [-pi, pi]; the covariance update
P - K S K^T is re-symmetrised after every fix. (Joseph's form, which guards against a gain far
from optimal, costs twice as much; with fixes of centimetres against a prior of centimetres to
metres the cancellation in P - K S K^T loses no more than 1e-12 relative.)

Delayed fixes (measured at t_meas, delivered later): the estimator keeps a ring buffer of the
last ``history_steps`` steps (time, wheel increments, gyro rate, posterior state and covariance)
and of the fixes it accepted. A fix rewinds to the last stored step at or before t_meas; if
t_meas falls inside a control period the period is split (the wheel speeds and the gyro rate are
taken as constant over it, as the arc model does), the fix is applied at t_meas, and the stored
inputs, with the stored fixes measured later, are re-propagated to now. This re-filtering gives
exactly what processing every fix at its measurement time would have given, out-of-order fixes
included; the cost is one prediction per stored step after t_meas.

Divergence: a non-finite state or covariance, or ``max_outliers`` consecutive fixes whose
normalised innovation squared (NIS) exceeds the chi-square(3) quantile ``gate_prob``, raises
:class:`EstimatorDivergedError`. With ``reject_outliers`` such fixes are not applied.

Systematic errors beyond the priors: the second (and every later) fix in a row outside the gate
whose position innovation a systematic odometry error of at most ``max_odometry_drift`` of the
distance driven since the last applied fix explains (plus three of the fix's standard deviations)
is taken as evidence that the odometry's systematic error exceeds its prior (a tyre 2 % larger than
the software believes, where the prior is the build tolerance), not as a wrong fix. Rejecting it
would let the drift grow until every later fix is rejected too: accurate scan fixes (2-3 mm) on a
TurtleBot3 with a 2 % radius error were rejected from the fourth on and the run ended "diverged"
while the localiser was right to 2 mm. Such a fix is applied after widening, at its measurement
time, the position variances by the innovation's square and the common radius error's variance by
that of a uniform error within ``max_odometry_drift``, so that the later fixes calibrate the radius
(the widened covariance is a bound the filter has not earned: the NEES of such a run says so).
``fixes_widened`` counts them. A lone outlier is rejected as before (with 2 cm fixes, a chance
outlier is the fix's noise far more often than the odometry's drift), and a jump no such drift
explains (a kidnapped robot, a fix wrongly matched) stays an outlier.

A wrong estimate: ``relocalise_after`` outlier fixes in a row (3 by default) that agree with each other on the
estimate's offset (each innovation the same within three standard deviations of the two fixes' noise, the drift
bound and the turn of a heading offset over the distance driven between them), each within 10 standard
deviations of the estimate (NIS at most :data:`RELOCALISE_MAX_NIS`: an estimate too sure of itself, not one sure of
another place), say that the estimate, not the fixes, is wrong: it started from a wrong pose (``--initial-pose`` a
metre off, while the scan localiser found the robot within seconds). The last of them is applied after widening
the position and heading variances at its measurement time by its innovation's squares, which moves the estimate
to the fixes, as Nav2's AMCL moves ``map -> odom`` when it relocalises. Fixes far beyond the estimate's
uncertainty are not followed however well they agree (a kidnapped robot, or a localiser biased by unmapped
obstacles: 0.44 m off a right estimate at NIS ~3000): after ``max_outliers`` the run ends "diverged", as before.
``relocalisations`` counts the moves (the run record's ``relocalisations``; ``fixes_widened`` counts the drift's).

Cost: the estimator runs once per control period of a simulation, so its arithmetic (a prediction,
a fix update, the rewind and the replay) is compiled (:mod:`control.estimation.kernels`) and works
in place on arrays allocated once per estimator; Python only checks the inputs and keeps the
books (about 1 us a prediction, a few a fix).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from control.estimation import kernels
from control.estimation.consistency import chi2_upper
from control.estimation.odometry import check_geometry
from planning.core.checks import check_flag, check_number, is_number
from planning.core.robot import RobotSpec
from planning.errors import ConfigError, NhsimError, SimulationError

FloatArray = NDArray[np.float64]

#: Size of the state vector and the index of each component.
N_STATE = 10
IX, IY, ITH, IBG, IEM, IED, IBETA, ISLIP, IRS, IRO = range(N_STATE)
#: The largest NIS of an outlier fix that may move the estimate with the ones agreeing with it (``relocalise_after``):
#: within 10 of its standard deviations the estimate was too sure of itself (a wrong initial pose a metre off, the
#: localiser's fixes at NIS 17-20); beyond, it is sure of another place, one of the two is wrong, and the run says so
#: (a localiser biased by unmapped obstacles, fixes 0.44 m off a right estimate at NIS ~3000, ended "diverged").
RELOCALISE_MAX_NIS = 100.0
#: Names of the state components, in order.
STATE_NAMES = (
    "x", "y", "theta", "gyro_bias", "radius_mean_err", "radius_diff_err", "track_err", "cornering_slip",
    "range_scale_err", "range_offset_err",
)  # fmt: skip
#: Where the heading increment comes from.
HEADING_SOURCES = ("gyro", "encoders")
#: Fields that are process-noise standard deviations (scaled together by ``scaled_process_noise``).
PROCESS_NOISE_FIELDS = (
    "wheel_noise",
    "position_noise",
    "wheel_radius_rel_std",
    "track_width_std",
    "gyro_noise_density",
    "gyro_bias_walk",
    "gyro_bias_std",
    "cornering_slip_std",
)
#: The encoders' quantisation as white noise [s]: its variance q^2/6 (of a count difference, q = 2 pi / counts)
#: once per this many seconds, whatever the control rate. A count difference's quantisation does not add up over
#: periods (successive differences share their counts: the sum over any span is itself one difference), so
#: adding q^2/6 at every period, as the filter did, grew its covariance with the rate: at 500 Hz the mean NEES
#: fell by 0.6 against 50 Hz (110 seeds, AMCL, and the same with fixes), for ten times the quantisation noise a
#: second. Spread over time at its value at the default 50 Hz, the default runs are what they were (to rounding).
QUANT_PERIOD = 0.02
#: How far [s] a fix's measurement time may lie after the newest step (clock rounding).
TIME_SLACK = 1e-9
TWO_PI = 2.0 * math.pi

_UNITS = {
    "counts_per_rev": "counts/rev",
    "wheel_noise": "rad/sqrt(rad)",
    "position_noise": "m/sqrt(m)",
    "wheel_radius_rel_std": "-",
    "track_width_std": "m",
    "gyro_noise_density": "rad/s/sqrt(Hz)",
    "gyro_bias_walk": "rad/s/sqrt(s)",
    "gyro_bias_std": "rad/s",
    "cornering_slip_std": "rad s^2/m",
    "range_scale_std": "-",
    "range_offset_std": "m",
    "fix_std_xy": "m",
    "fix_std_theta": "rad",
}


class EstimatorDivergedError(SimulationError):
    """The state estimator lost track of the robot.

    Attributes:
        t: Time [s] at which the divergence was detected.
        reason: "non-finite" (state or covariance) or "innovation" (sustained outlier fixes).
    """

    def __init__(self, message: str, *, t: float, reason: str) -> None:
        super().__init__(message)
        self.t = t
        self.reason = reason


class EstimatorInputError(NhsimError, ValueError):
    """A call to the estimator had an invalid argument (time order, non-finite reading, shape)."""


def _finite_number(name: str, value: object, *, positive: bool) -> float:
    """``EstimatorConfig.<name>`` as a float (:func:`check_number`, with its unit): > 0 (``positive``) or >= 0
    (a standard deviation); a number out of range is told to give its magnitude."""
    fix = ""
    if is_number(value):  # then only the range can fail
        fix = "give its magnitude" if positive else "a standard deviation is never negative: give its magnitude"
    above, at_least = (0.0, None) if positive else (None, 0.0)
    where = f"EstimatorConfig.{name}"
    return check_number(where, value, above=above, at_least=at_least, unit=_UNITS.get(name, ""), fix=fix)


@dataclass(frozen=True)
class EstimatorConfig:
    """Noise model and options of :class:`PoseEstimator`; all values are standard deviations.

    Attributes:
        heading: "gyro" (heading increment from the gyro, default) or "encoders" (from the wheels).
        counts_per_rev: Encoder counts per wheel revolution (quantisation q = 2 pi / counts_per_rev).
        wheel_noise: White wheel-angle noise (slip, backlash) [rad/sqrt(rad)]: an increment dphi
            has variance wheel_noise^2 |dphi|.
        position_noise: White position noise (lateral scrub) [m/sqrt(m)]: variance
            position_noise^2 |ds| on x and on y.
        wheel_radius_rel_std: Build tolerance of each wheel's radius, relative (0.005 = 0.5 %).
        track_width_std: Build tolerance of the track width [m].
        gyro_noise_density: Gyro white noise [rad/s/sqrt(Hz)] (MPU-9250: 0.01 deg/s/sqrt(Hz)).
        gyro_bias_walk: Gyro bias random walk [rad/s/sqrt(s)].
        gyro_bias_std: Gyro bias at reset [rad/s] (residual of a start-up calibration).
        cornering_slip_std: Prior of the tyres' cornering compliance k [rad s^2/m]: the slip angle
            per m/s^2 of lateral acceleration (0.03 covers rubber tyres, whose cornering stiffness
            is 5-20 times the load per radian, k = 0.005-0.02, and both simulated robots').
        range_scale_std: Prior of the range sensor's relative scale error s_r [-] (0: fixes carry no
            range gain; the LDS-01's 5 % band is 3 standard deviations, 0.0167).
        range_offset_std: Prior of the range sensor's offset o_r [m] (the LDS-01's 15 mm band: 0.005).
        fix_std_xy: Default position noise of a pose fix [m].
        fix_std_theta: Default heading noise of a pose fix [rad].
        history_steps: Control periods kept for rewinding to delayed fixes (64 = 1.28 s at 50 Hz).
        gate_prob: A fix whose NIS exceeds the chi-square(3) quantile gate_prob is an outlier.
        reject_outliers: Outlier fixes are not applied (they still count towards divergence).
        max_outliers: This many consecutive outlier fixes raise :class:`EstimatorDivergedError`.
        max_odometry_drift: Largest systematic odometry error, relative to the distance driven since
            the last applied fix, that the position innovation of a second outlier fix in a row is
            taken to reveal (the module doc); 0: every outlier is rejected.
        relocalise_after: This many consecutive outlier fixes that agree with each other (the same offset
            of the estimate, within their noise and the drift) move the estimate to them (the module doc);
            0 never, nor when it is not below ``max_outliers`` (that many raise first).
    """

    heading: str = "gyro"
    counts_per_rev: float = 4096.0
    wheel_noise: float = 2e-3
    position_noise: float = 1e-3
    wheel_radius_rel_std: float = 5e-3
    track_width_std: float = 3e-3
    gyro_noise_density: float = 1.75e-4
    gyro_bias_walk: float = 2e-5
    gyro_bias_std: float = 2e-3
    cornering_slip_std: float = 0.03
    range_scale_std: float = 0.0
    range_offset_std: float = 0.0
    fix_std_xy: float = 0.02
    fix_std_theta: float = 0.02
    history_steps: int = 64
    gate_prob: float = 0.999
    reject_outliers: bool = True
    max_outliers: int = 5
    max_odometry_drift: float = 0.05
    relocalise_after: int = 3

    def __post_init__(self) -> None:
        if self.heading not in HEADING_SOURCES:
            raise ConfigError(
                f"EstimatorConfig.heading must be one of {', '.join(HEADING_SOURCES)}, got {self.heading!r}"
            )
        for name in ("counts_per_rev", "fix_std_xy", "fix_std_theta"):
            object.__setattr__(self, name, _finite_number(name, getattr(self, name), positive=True))
        for name in (*PROCESS_NOISE_FIELDS, "range_scale_std", "range_offset_std"):
            object.__setattr__(self, name, _finite_number(name, getattr(self, name), positive=False))
        for name, low in (("history_steps", 2), ("max_outliers", 1)):
            value = check_number(f"EstimatorConfig.{name}", getattr(self, name), integer=True, at_least=low)
            object.__setattr__(self, name, value)
        gp = check_number(
            "EstimatorConfig.gate_prob", self.gate_prob, above=0.0, below=1.0, unit="a probability", fix="e.g. 0.999"
        )
        object.__setattr__(self, "gate_prob", gp)
        drift = check_number(
            "EstimatorConfig.max_odometry_drift", self.max_odometry_drift, at_least=0.0, at_most=1.0,
            unit="of the distance driven", fix="e.g. 0.05; 0 rejects every outlier",
        )  # fmt: skip
        object.__setattr__(self, "max_odometry_drift", drift)
        object.__setattr__(self, "reject_outliers", check_flag("EstimatorConfig.reject_outliers", self.reject_outliers))
        after = check_number(
            "EstimatorConfig.relocalise_after", self.relocalise_after, integer=True, at_least=0,
            fix="e.g. 3; 0 never relocalises",
        )  # fmt: skip
        if after == 1:
            raise ConfigError(
                "EstimatorConfig.relocalise_after must be 0 (never) or at least 2: one outlier agrees with no other; "
                "e.g. relocalise_after=3"
            )
        object.__setattr__(self, "relocalise_after", after)

    def scaled_process_noise(self, factor: float) -> EstimatorConfig:
        """A copy with every process-noise standard deviation multiplied by factor (>= 0)."""
        check_number("scaled_process_noise: factor", factor, at_least=0.0)  # the product takes factor as given
        return replace(self, **{name: getattr(self, name) * factor for name in PROCESS_NOISE_FIELDS})

    def as_dict(self) -> dict[str, object]:
        """The fields as a plain dict (for run records)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


#: A pose given as three numbers (x [m], y [m], theta [rad]): a tuple, a list or a (3,) array.
PoseLike = Sequence[float] | FloatArray
#: t_meas, z_x, z_y, z_theta, the noise covariance's upper triangle by rows, then the range gain G (3, 2)
#: row by row (kernels.FIX_COLS).
Fix = tuple[float, ...]
#: A fix's range gain when it has none.
NO_GAIN = (0.0,) * (kernels.FIX_COLS - kernels.GAIN)


def _fix_key(fix: Fix) -> float:
    return fix[0]


class PoseEstimator:
    """EKF pose estimator: encoders and gyro predict, delayed pose fixes correct (see the module doc).

    Dead reckoning is the same object with no :meth:`correct` calls. Typical use at the control
    rate::

        est = PoseEstimator.for_robot(load_robot("turtlebot3"), EstimatorConfig())
        est.reset(0.0, (x0, y0, theta0))
        est.predict(t, d_left, d_right, gyro_z)   # every period: increments since the last call
        est.correct(t_meas, (zx, zy, ztheta))     # whenever a fix arrives, t_meas <= t
        x, y, theta = est.pose

    Args:
        config: Noise model and options.
        wheel_radius: Nominal wheel radius r [m] (the robot as drawn).
        track_width: Nominal track width b [m].

    Raises:
        ConfigError: config is not an :class:`EstimatorConfig`, or a non-positive geometry.
    """

    def __init__(self, config: EstimatorConfig, wheel_radius: float, track_width: float) -> None:
        if not isinstance(config, EstimatorConfig):
            raise ConfigError(f"PoseEstimator needs an EstimatorConfig, got {type(config).__name__}")
        check_geometry(wheel_radius, track_width)
        self.config = config
        self.nominal_radius = float(wheel_radius)
        self.nominal_track = float(track_width)
        self._gyro = config.heading == "gyro"
        q = TWO_PI / config.counts_per_rev
        self._gate = chi2_upper(3, config.gate_prob)
        cap = config.history_steps + 1
        self._cap = cap
        self._mem = kernels.allocate(cap)  # every array of the filter, in one block
        block = kernels.Block.of(self._mem)
        self._prm, self._F, self._Q, self._tmp = block.prm, block.f, block.q, block.tmp  # constants, F, Q, scratch
        self._nu, self._bt, self._bu = block.nu, block.bt, block.bu  # last gated innovation, ring times and inputs
        self._bx, self._bP = block.bx, block.bP  # ring states and covariances
        block.prm[:] = kernels.parameters(
            self.nominal_radius, self.nominal_track, config.wheel_noise**2, config.position_noise**2,
            config.gyro_noise_density**2 if self._gyro else 0.0, config.gyro_bias_walk**2 if self._gyro else 0.0,
            q * q / 6.0 / QUANT_PERIOD, self._gyro, self._gate, config.reject_outliers,
        )  # fmt: skip
        self._hdr = self._mem[kernels.NU_ROW]  # the ring's newest step, its size and time (kernels.HEAD ..)
        self._fixes: list[Fix] = []
        self._no_fixes = np.zeros((0, kernels.FIX_COLS))
        self._finite = True  # the state after the last replay
        self._nis: list[tuple[float, float]] = []
        self._outliers = 0
        self._rejected = 0
        self._stale = 0
        self._widened = self._relocalised = 0
        #: The current run of consecutive outliers: (innovation x, y, theta, position and heading variance of the
        #: fix, odometry distance then, its NIS) each (:meth:`_relocalising`).
        self._streak: list[tuple[float, float, float, float, float, float, float]] = []
        self._odo_fix = 0.0  # the distance driven when the last fix was applied [m]

    @classmethod
    def for_robot(
        cls, robot: RobotSpec, config: EstimatorConfig | None = None, *, wheel_radius: float | None = None
    ) -> PoseEstimator:
        """An estimator for a robot spec's track width and wheel radius (default config): ``wheel_radius``
        [m] the radius its odometry multiplies the wheel angles by, when not the drawn one (the
        simulator's robot software passes the tyre's rolling radius under load,
        ``sim.physics.model.rolling_radius``)."""
        radius = robot.wheel_radius if wheel_radius is None else wheel_radius
        return cls(config if config is not None else EstimatorConfig(), radius, robot.track_width)

    def prior_covariance(self, cov0: ArrayLike | None = None) -> FloatArray:
        """The (10, 10) covariance at reset: cov0 for the pose, the config's priors for the rest.

        Args:
            cov0: (3, 3) pose covariance [m^2, rad^2], symmetric, non-negative diagonal; None: zero.

        Raises:
            EstimatorInputError: cov0 has the wrong shape, is not finite or not symmetric.
        """
        cfg = self.config
        p = np.zeros((N_STATE, N_STATE))
        if cov0 is not None:
            c = np.asarray(cov0, dtype=float)
            if c.shape != (3, 3) or not np.isfinite(c).all():
                raise EstimatorInputError(f"cov0 must be a finite (3, 3) pose covariance, got shape {c.shape}")
            if not _symmetric(c) or (np.diag(c) < 0).any():
                raise EstimatorInputError("cov0 must be symmetric with a non-negative diagonal [m^2, m^2, rad^2]")
            p[:3, :3] = c
        var_eps = 0.5 * cfg.wheel_radius_rel_std**2  # e_m and e_d from two independent wheel errors
        p[IBG, IBG] = cfg.gyro_bias_std**2 if self._gyro else 0.0
        p[IEM, IEM] = var_eps
        p[IED, IED] = var_eps
        p[IBETA, IBETA] = (cfg.track_width_std / self.nominal_track) ** 2 if not self._gyro else 0.0
        p[ISLIP, ISLIP] = cfg.cornering_slip_std**2
        p[IRS, IRS] = cfg.range_scale_std**2
        p[IRO, IRO] = cfg.range_offset_std**2
        return p

    def reset(self, t0: float, pose0: ArrayLike, cov0: ArrayLike | None = None) -> None:
        """Start (or restart) at a known pose: clears the history, the fixes and the statistics.

        Args:
            t0: Time [s].
            pose0: (3,) pose [x, y, theta] [m, m, rad].
            cov0: (3, 3) pose covariance; None: the pose is exact.

        Raises:
            EstimatorInputError: A non-finite time or pose, or a bad cov0.
        """
        p0 = np.asarray(pose0, dtype=float)
        if p0.shape != (3,) or not np.isfinite(p0).all() or not math.isfinite(t0):
            raise EstimatorInputError(f"reset needs a finite time and a finite (3,) pose, got t0={t0!r}, {p0!r}")
        self._bP[0] = self.prior_covariance(cov0)
        self._bx[0] = 0.0
        self._bx[0, :3] = p0
        self._bx[0, ITH] = math.remainder(p0[2], TWO_PI)
        self._bt[0] = float(t0)
        self._bu[0] = 0.0
        hdr = self._hdr
        hdr[kernels.HEAD], hdr[kernels.SIZE], hdr[kernels.TIME], hdr[kernels.ODO] = 0, 1, t0, 0.0
        self._fixes.clear()
        self._nis.clear()
        self._outliers = self._rejected = self._stale = self._widened = self._relocalised = 0
        self._odo_fix = 0.0
        self._streak.clear()

    def predict(self, t: float, d_left: float, d_right: float, gyro_z: float | None = None) -> None:
        """Advance to time t with the wheel increments since the last call.

        Args:
            t: Time of the readings [s], later than the previous call's (or the reset's).
            d_left: Left wheel angle increment since the last call [rad] (forward positive).
            d_right: Right wheel angle increment [rad].
            gyro_z: Mean z-rate over the period [rad/s], as read (bias included); required with
                ``heading="gyro"``, ignored with ``"encoders"``.

        Raises:
            EstimatorInputError: Not reset, time not increasing, a non-finite reading, no gyro.
            EstimatorDivergedError: The state or covariance became non-finite.
        """
        if self._gyro and gyro_z is None:
            raise EstimatorInputError(
                "predict: heading='gyro' needs gyro_z [rad/s]; use heading='encoders' without a gyro"
            )
        status = kernels.step(
            self._mem, float(t), float(d_left), float(d_right), 0.0 if gyro_z is None else float(gyro_z)
        )
        if status != kernels.OK:
            self.raise_status(status, t, (d_left, d_right, gyro_z))

    @property
    def block(self) -> FloatArray:
        """The filter's whole state in one array (:mod:`control.estimation.kernels`), for a compiled
        caller that predicts with :func:`~control.estimation.kernels.step` and reads with
        :func:`~control.estimation.kernels.head_pose` (raising a failed step's status with
        :meth:`raise_status`)."""
        return self._mem

    def raise_status(self, status: int, t: float, readings: tuple[object, ...] = ()) -> None:
        """Raise the error a kernel's status stands for, at time t [s] (the step's readings
        (d_left, d_right, gyro_z) named in the message, when given).

        Raises:
            EstimatorInputError: BAD_TIME (not reset, or the time does not increase), BAD_READING.
            EstimatorDivergedError: The state or covariance became non-finite.
        """
        if status == kernels.BAD_TIME:
            raise EstimatorInputError(
                f"predict: time must be finite and increase (previous {self._t!r} s, got {t!r} s); call reset first"
            )
        if status == kernels.BAD_READING:
            raise EstimatorInputError(f"predict at t={t} s: non-finite reading {', '.join(map(repr, readings))}")
        self._diverged(status, t)

    @property
    def _head(self) -> int:
        return int(self._hdr[kernels.HEAD])

    @property
    def _size(self) -> int:
        return int(self._hdr[kernels.SIZE])

    @property
    def _t(self) -> float:
        return float(self._hdr[kernels.TIME])

    def _diverged(self, status: int, t: float) -> None:
        """Raise the divergence a kernel reported (its status) at time t [s]."""
        what = {
            kernels.BAD_INCREMENT: "the motion increment",
            kernels.BAD_STATE: "the state or its covariance",
            kernels.BAD_INNOVATION: "the innovation covariance (not positive definite)",
        }[status]
        self._diverged_non_finite(t, what)

    def _diverged_non_finite(self, t: float, what: str) -> None:
        raise EstimatorDivergedError(
            f"pose estimate diverged at t={t:.3f} s: {what} became non-finite (an extreme reading or "
            "a covariance blown up by the process noise); check the sensor readings and EstimatorConfig",
            t=t,
            reason="non-finite",
        )

    def _replay(self, new: Fix, widen: tuple[float, float, float] | None = None) -> tuple[float, bool] | None:
        """Rewind to the newest step at or before the new fix's measurement time, apply the fix there
        and re-filter to now with the stored later fixes (:func:`control.estimation.kernels.rewind`
        and :func:`~control.estimation.kernels.replay`); with ``widen`` (position variance [m^2],
        common radius error variance [-], heading variance [rad^2]) that step's covariance is widened first
        (:meth:`_widening`, :meth:`_relocalising`), and kept only if the fix is then applied.

        Returns:
            (NIS of the new fix, whether it was applied); None when the fix is older than the
            history. A rejected fix changes nothing.
        """
        j = kernels.rewind(self._mem, self._head, self._size, new[0])
        if j < 0:
            return None
        # forget the fixes no rewind can reach (at or before the oldest step), then take the later ones
        del self._fixes[: bisect.bisect_right(self._fixes, self.history_start, key=_fix_key)]
        later = bisect.bisect_right(self._fixes, self._bt[j], key=_fix_key)
        stored = np.array(self._fixes[later:]) if later < len(self._fixes) else self._no_fixes
        before = self._bP[j].copy() if widen is not None else None
        if widen is not None:
            self._bP[j, IX, IX] += widen[0]
            self._bP[j, IY, IY] += widen[0]
            self._bP[j, IEM, IEM] += widen[1]
            self._bP[j, ITH, ITH] += widen[2]
        status, t_bad, nis, ok, finite = kernels.replay(self._mem, j, self._head, stored, np.array(new))
        if status != kernels.OK:
            self._diverged(status, t_bad)
        if before is not None and not ok:
            self._bP[j] = before
        self._finite = finite
        return nis, ok

    def _widening(self, fix: Fix) -> tuple[float, float, float] | None:
        """How far to widen the covariance for an outlier fix (the second in a row or later, as the caller
        asks) whose position innovation (the last gated, :attr:`_nu`) a systematic odometry drift of at
        most ``max_odometry_drift`` of the distance driven since the last applied fix explains, with three
        of the fix's position standard deviations: (the innovation's square [m^2], the variance of a
        uniform common radius error within ``max_odometry_drift`` [-]); None when none explains it (module
        doc)."""
        bound = self.config.max_odometry_drift
        driven = float(self._hdr[kernels.ODO]) - self._odo_fix
        miss = math.hypot(float(self._nu[0]), float(self._nu[1]))
        fix_std = math.sqrt(max(fix[kernels.NOISE], fix[kernels.NOISE + 3]))
        if not (bound > 0.0 and driven > 0.0 and miss <= bound * driven + 3.0 * fix_std):
            return None
        return miss * miss, bound * bound / 3.0, 0.0

    def _relocalising(self, fix: Fix, nis: float) -> tuple[float, float, float] | None:
        """How far to widen the covariance to move the estimate to an outlier fix that the ``relocalise_after - 1``
        outliers before it, in a row, agree with: each one's innovation (the estimate's offset from its fix) the
        same as this one's within three standard deviations of the two fixes' noise, plus the drift
        (``max_odometry_drift``) and the turn of a heading offset (its innovation's heading times the distance
        driven) between them, and each one's NIS at most :data:`RELOCALISE_MAX_NIS`. Then the estimate, not the
        fixes, is wrong (it started from a wrong pose), and the localiser has said so a number of times: (the
        innovation's position and heading squared [m^2, rad^2], no radius widening). None otherwise; the outlier
        joins the streak (module doc)."""
        nx, ny, nth = (float(v) for v in self._nu)
        vxy, vth = max(fix[kernels.NOISE], fix[kernels.NOISE + 3]), fix[kernels.NOISE + 5]
        odo = float(self._hdr[kernels.ODO])
        need = self.config.relocalise_after
        agree = 0 < need < self.config.max_outliers and len(self._streak) + 1 >= need and nis <= RELOCALISE_MAX_NIS
        for px, py, pth, pvxy, pvth, podo, pnis in self._streak[-(need - 1) :] if agree else ():
            driven = odo - podo
            reach = 3.0 * math.sqrt(vxy + pvxy) + (self.config.max_odometry_drift + abs(nth)) * driven
            agree = agree and math.hypot(nx - px, ny - py) <= reach and pnis <= RELOCALISE_MAX_NIS
            agree = agree and abs(math.remainder(nth - pth, 2 * math.pi)) <= 3.0 * math.sqrt(vth + pvth)
        self._streak.append((nx, ny, nth, vxy, vth, odo, nis))
        return (nx * nx + ny * ny, 0.0, nth * nth) if agree else None

    def correct(
        self,
        t_meas: float,
        z: PoseLike,
        std_xy: float | None = None,
        std_theta: float | None = None,
        range_gain: ArrayLike | None = None,
        cov: ArrayLike | None = None,
    ) -> bool:
        """Fuse a pose fix measured at t_meas (now or earlier), rewinding and re-propagating.

        Args:
            t_meas: Time the fix was measured [s], at most the time of the last :meth:`predict`.
            z: (3,) measured pose [x, y, theta] [m, m, rad].
            std_xy: Position noise of this fix [m] (its white part, with a ``range_gain``); None:
                ``config.fix_std_xy``.
            std_theta: Heading noise of this fix [rad]; None: ``config.fix_std_theta``.
            range_gain: (3, 2) the fix's change per unit of the range sensor's scale error and per
                metre of its offset (a scan matched to a map; the module doc's G) [m, m, rad per
                unit]; None: the fix does not depend on them.
            cov: (3, 3) the fix's whole noise covariance [m^2, m^2, rad^2 and their products], symmetric
                positive definite (a localiser's, whose position is surer across a corridor than
                along it), instead of ``std_xy`` and ``std_theta``.

        Returns:
            True if applied; False if rejected as an outlier or older than the history (stale).

        Raises:
            EstimatorInputError: Not reset, a fix from the future, a non-finite or misshapen z,
                a non-positive noise, a cov that is not a covariance, or cov with std_xy or std_theta.
            EstimatorDivergedError: ``max_outliers`` consecutive outliers, or a non-finite state.
        """
        zx, zy, zth, vxy, vth = self._check_fix(t_meas, z, std_xy, std_theta)
        noise = (vxy, 0.0, 0.0, vxy, 0.0, vth) if cov is None else _check_cov(cov, std_xy, std_theta)
        gain = NO_GAIN if range_gain is None else _check_gain(range_gain)
        if t_meas > self._t:
            if t_meas - self._t > TIME_SLACK:
                raise EstimatorInputError(
                    f"correct: fix measured at t={t_meas} s is after the last predict ({self._t} s)"
                )
            t_meas = self._t
        fix = (float(t_meas), zx, zy, zth, *noise, *gain)
        result = self._replay(fix)
        if result is None:
            self._stale += 1
            return False
        nis, ok = result
        self._nis.append((fix[0], nis))
        widen = None if ok or self._outliers == 0 else self._widening(fix)  # from the second outlier in a row
        if widen is not None:
            widened = self._replay(fix, widen)
            assert widened is not None  # the same step as the first replay's
            nis_after, ok = widened
            self._widened += ok
            nis = nis_after if ok else nis
        if not ok and (widen := self._relocalising(fix, nis)) is not None:
            moved = self._replay(fix, widen)
            assert moved is not None
            nis_after, ok = moved
            self._relocalised += ok
            nis = nis_after if ok else nis
        if ok:
            bisect.insort_right(self._fixes, fix, key=_fix_key)
            self._odo_fix = float(self._hdr[kernels.ODO])
        else:
            self._rejected += 1
        self._count_outlier(fix[0], nis)
        if not self._finite:
            self._diverged_non_finite(self._t, "the state or its covariance")
        return ok

    def _check_fix(
        self, t_meas: float, z: PoseLike, std_xy: float | None, std_theta: float | None
    ) -> tuple[float, float, float, float, float]:
        if self._head < 0:
            raise EstimatorInputError("correct: call reset(t0, pose0) first")
        try:
            a, b, c = z
            zx, zy, zth = float(a), float(b), float(c)
        except (TypeError, ValueError) as exc:
            raise EstimatorInputError(f"correct: z must be three numbers (x, y, theta), got {z!r}") from exc
        sx = self.config.fix_std_xy if std_xy is None else std_xy
        st = self.config.fix_std_theta if std_theta is None else std_theta
        if not (math.isfinite(t_meas) and math.isfinite(zx + zy + zth)):
            raise EstimatorInputError(f"correct: non-finite fix t_meas={t_meas!r}, z={z!r}")
        if not (math.isfinite(sx) and math.isfinite(st) and sx > 0 and st > 0):
            raise EstimatorInputError(f"correct: fix noise must be finite and > 0, got std_xy={sx!r}, std_theta={st!r}")
        return zx, zy, zth, sx * sx, st * st

    def _count_outlier(self, t_meas: float, nis: float) -> None:
        if not nis > self._gate:
            self._outliers = 0
            self._streak.clear()
            return
        self._outliers += 1
        if self._outliers >= self.config.max_outliers:
            n0, n1, n2 = self._nu.tolist()
            raise EstimatorDivergedError(
                f"pose estimate diverged at t={self._t:.3f} s: {self._outliers} consecutive fixes (the last "
                f"measured at t={t_meas:.3f} s) had a normalised innovation squared above {self._gate:.2f} "
                f"(the chi-square(3) {self.config.gate_prob} quantile); last NIS {nis:.1f}, innovation "
                f"dx={n0:+.3f} m, dy={n1:+.3f} m, dtheta={n2:+.3f} rad. The fixes disagree with the odometry "
                "beyond the noise assumed and beyond a systematic drift of max_odometry_drift "
                f"({self.config.max_odometry_drift:g} of the distance driven): a wheel radius or track further "
                "from the robot's than that (its dimensions, or --perturb radius), fixes noisier than their "
                "stated covariance (fix_std_xy, fix_std_theta, or the localiser's), or a robot moved by hand; "
                "EstimatorConfig holds the noise model and the bound",
                t=self._t,
                reason="innovation",
            )

    @property
    def t(self) -> float:
        """Time of the newest step [s]."""
        return self._t

    @property
    def pose(self) -> tuple[float, float, float]:
        """Estimated pose (x [m], y [m], theta [rad] in [-pi, pi])."""
        x = self._bx[self._head]
        return float(x[0]), float(x[1]), float(x[2])

    def record(self, pose: FloatArray, variance: FloatArray, row: int) -> tuple[float, float, float]:
        """Write the pose and the variances of its components into row ``row`` of two arrays.

        The cheap per-period read for a logger (no copies, one compiled call).

        Args:
            pose: (K, 3) float array for [x, y, theta] [m, m, rad], written in place.
            variance: (K, 3) float array for [var_x, var_y, var_theta] [m^2, m^2, rad^2], written in place.
            row: Row to write, 0 <= row < K.

        Returns:
            The pose, as :attr:`pose`.
        """
        return kernels.head_pose(self._mem, self._head, pose, variance, row)

    def nees(self, truth: PoseLike) -> float:
        """Normalised estimation error squared of the pose against a true pose (heading error
        wrapped): e^T P^-1 e with e = pose - truth and P :attr:`cov` (see
        :mod:`control.estimation.consistency`); NaN while P is singular (a start pose known exactly,
        before any motion noise has entered it).

        Args:
            truth: (3,) true pose [x, y, theta] [m, m, rad].
        """
        tx, ty, tth = truth
        return kernels.head_nees(self._mem, self._head, float(tx), float(ty), float(tth))

    @property
    def cov(self) -> FloatArray:
        """(3, 3) covariance of the pose [m^2, m^2, rad^2] (a copy)."""
        return self._bP[self._head, :3, :3].copy()

    @property
    def state(self) -> FloatArray:
        """(10,) full state, components named in :data:`STATE_NAMES` (a copy)."""
        return self._bx[self._head].copy()

    @property
    def cov_full(self) -> FloatArray:
        """(10, 10) covariance of the full state (a copy)."""
        return self._bP[self._head].copy()

    @property
    def gyro_bias(self) -> float:
        """Estimated gyro z-rate bias [rad/s]."""
        return float(self._bx[self._head, IBG])

    @property
    def calibration(self) -> tuple[float, float, float]:
        """Estimated as-built (left wheel radius [m], right wheel radius [m], track width [m])."""
        em, ed, be = self._bx[self._head, IEM : IBETA + 1].tolist()
        r, b = self.nominal_radius, self.nominal_track
        return r * (1.0 + em - ed), r * (1.0 + em + ed), b * (1.0 + be)

    @property
    def cornering_slip(self) -> float:
        """Estimated cornering compliance k [rad s^2/m]: the slip angle per m/s^2 of lateral acceleration."""
        return float(self._bx[self._head, ISLIP])

    @property
    def range_errors(self) -> tuple[float, float]:
        """Estimated range sensor errors (relative scale [-], offset [m]) (zero without scan fixes)."""
        return float(self._bx[self._head, IRS]), float(self._bx[self._head, IRO])

    @property
    def history_start(self) -> float:
        """Oldest time [s] a fix may be measured at and still be fused (older ones are stale)."""
        oldest = self._head - self._size + 1
        return float(self._bt[oldest if oldest >= 0 else oldest + self._cap])

    @property
    def nis_history(self) -> FloatArray:
        """(K, 2) [t_meas [s], NIS] of every fix received (applied or rejected), in arrival order."""
        return np.array(self._nis, dtype=float).reshape(-1, 2)

    @property
    def nis_gate(self) -> float:
        """NIS above which a fix is an outlier (chi-square(3) quantile ``config.gate_prob``)."""
        return self._gate

    @property
    def fixes_rejected(self) -> int:
        """Fixes not applied because their NIS exceeded the gate."""
        return self._rejected

    @property
    def fixes_widened(self) -> int:
        """Outlier fixes applied after widening the covariance: a systematic odometry drift within
        ``max_odometry_drift`` explained them (the module doc)."""
        return self._widened

    @property
    def relocalisations(self) -> int:
        """Times the estimate moved to the fixes: ``relocalise_after`` outliers in a row agreed on its offset."""
        return self._relocalised

    @property
    def fixes_stale(self) -> int:
        """Fixes dropped because they were measured before the history's start."""
        return self._stale


def _check_gain(gain: ArrayLike) -> tuple[float, ...]:
    """A fix's range gain as the fix's six numbers, or an error naming what is wrong."""
    g = _float_array(gain)
    if g.shape != (3, 2) or not np.isfinite(g).all():
        raise EstimatorInputError(
            f"correct: range_gain must be a finite (3, 2) array (the fix's change per unit of the range "
            f"scale error and per metre of its offset), got shape {g.shape}"
        )
    return tuple(float(v) for v in g.ravel())


def _check_cov(cov: ArrayLike, std_xy: float | None, std_theta: float | None) -> tuple[float, ...]:
    """A fix's noise covariance as the upper triangle's six numbers, or an error naming what is wrong."""
    if std_xy is not None or std_theta is not None:
        raise EstimatorInputError("correct: give a fix's noise either as cov or as std_xy and std_theta, not both")
    c = _float_array(cov)
    ok = c.shape == (3, 3) and bool(np.isfinite(c).all()) and _symmetric(c)
    if ok:
        try:
            np.linalg.cholesky(c)
        except np.linalg.LinAlgError:
            ok = False
    if not ok:
        raise EstimatorInputError(
            f"correct: cov must be a finite, symmetric, positive-definite (3, 3) covariance [m^2, m^2, rad^2], "
            f"got {np.array2string(c, precision=3) if c.size else repr(cov)}"
        )
    return float(c[0, 0]), float(c[0, 1]), float(c[0, 2]), float(c[1, 1]), float(c[1, 2]), float(c[2, 2])


def _symmetric(c: FloatArray) -> bool:
    """Whether a finite square matrix is symmetric (a covariance) up to round-off."""
    return bool(np.allclose(c, c.T, rtol=1e-9, atol=1e-15))


def _float_array(value: ArrayLike) -> FloatArray:
    """``value`` as a float array; an empty one when it is not numbers (its check then fails on the shape)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return np.zeros(0)
