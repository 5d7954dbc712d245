"""The TurtleBot3's scan-based localiser in the loop: LDS-01 revolutions cast in the run's physics
(:mod:`sim.physics.lidar`) and matched against the map by AMCL (:mod:`control.estimation.amcl`).

It replaces the synthetic pose fixes of :class:`sim.robot.sensing.Sensing` on the same schedule: a
fix "measured" at control period ``j`` is the AMCL estimate for the revolution centred on ``j``
(its beams from half a revolution before ``j``'s instant to half a revolution after it, whether or not
a revolution is an even number of control periods, each from the true pose of its own instant,
interpolated between control periods), with the odometry pose at ``j``; it is
delivered at period ``j + fix_latency`` (after the revolution has ended) and fused by the EKF at
its measurement time ``j`` with the localiser's own covariance (its white part, with the scanner's
systematic range error as a gain on the EKF's range error states, :mod:`control.estimation.ekf`).
AMCL updates only when the odometry has moved past ``update_min_d`` or ``update_min_a``: a
revolution without an update delivers nothing, nor does one with fewer than
:data:`control.estimation.amcl.MIN_BEAMS` returns (nothing to match; the record counts them apart).

The odometry AMCL takes is the robot's ``odom`` frame as the TurtleBot3 publishes it
(``turtlebot3_node``'s odometry with ``odometry.use_imu: true``, the Burger's setting in
``turtlebot3_bringup/param/burger.yaml``): the distance from its quantised wheel encoders with the
robot's drawn wheel radius, the heading from the IMU, whose yaw is the gyro's integral (the true
turn plus the gyro's error of :mod:`sim.physics.sensors`), one arc per fix period. A wheel that
slips (the robot pushed against an obstacle, or stuck) moves the encoders' distance but not the
gyro's heading; encoder headings turned with such a slip had the particles and the refinement's
prior turn with it (measured on a seeded random world, 40 deg in 2.4 s of scraping along a box).
Without a gyro error (``gyro_error`` None) the heading is the encoders' differential.

The fix's covariance is the refined pose's with the LDS-01's datasheet accuracy carried through the
fit (:func:`range_bias`, :class:`control.estimation.amcl.Amcl`), not the particle cloud's; the fit
weighs each beam by the datasheet's precision (:func:`range_noise`).

With ``initial = "unknown"`` the particles start spread over the free space and the robot, standing
at its start before the run, takes up to :data:`GLOBAL_SCANS` revolutions (forced updates, Nav2's
``nomotion_update``) until the particle spread is below :data:`CONVERGED_SPREAD`; each revolution
until then is also searched over the whole free space (a correlative search,
:meth:`control.estimation.amcl.Amcl.search`), whose best pose, once it fits the map well
(:data:`SEARCH_FIT`) and no distinct pose explains the scan alike, seeds the particles; the run then
says after how many, and whether the error then was below :data:`CONVERGED_ERROR`. A scan that distinct
poses explain alike (a symmetric world's twins) seeds nothing, and the particles' spread does not count as
convergence after it (a cloud gathered on one of the poses is not evidence for it); after
:data:`AMBIGUOUS_SCANS` such revolutions in a row, or as many without returns, the run ends before tracking
with the status :data:`AMBIGUOUS`, naming the poses (:class:`LocaliserAmbiguous`); after :data:`GLOBAL_SCANS`
revolutions without converging it ends there too, its message :data:`UNCONVERGED` (:class:`LocaliserUnconverged`:
tracking from a cloud spread over the map would fuse its guesses). With a pose estimate (``initial`` "X,Y,THETA",
a ROS user's "2D Pose Estimate") the particles start around it with Nav2's initial covariance, the robot at the
scenario's start wherever the estimate says; the EKF starts where the localiser says (:meth:`ScanLocaliser.belief`).
The localiser decides
from its scans alone; the truth only judges its answer. A localiser whose error against the truth passes
:data:`LOST_ERROR` ends the run with that status.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import mujoco
import numpy as np
from numpy.typing import NDArray

from control.estimation.amcl import MIN_BEAMS, Amcl, AmclConfig, AmclEstimate, scan_returns
from control.estimation.amcl_kernels import angle_diff
from planning.core.robot import RobotSpec
from planning.core.world import World
from planning.errors import ConfigError, option
from sim.physics.asbuilt import CLIP_SIGMAS
from sim.physics.lidar import LidarProfile, LidarScanner, beam_poses, unit_errors
from sim.physics.runlog import LocaliserLog
from sim.robot.pose_estimate import INITIAL_POSES, POSE_EXAMPLE, check_initial_pose, parse_initial_pose

FloatArray = NDArray[np.float64]

#: Error against the truth beyond which the localiser counts as lost [m] ...
LOST_ERROR = 0.5
#: ... when its own covariance does not cover it either: the position error's squared Mahalanobis distance
#: beyond the chi-square's 99.9 % point for two degrees of freedom. A localiser that says it does not know
#: where it is (a particle cloud still 0.4 m wide after a pose estimate 0.8 m off) is not lost but unsure; it
#: is lost when it is sure of a wrong place.
LOST_DISTANCE2 = 13.8
#: Global localisation: most revolutions taken standing at the start.
GLOBAL_SCANS = 40
#: Converged: particle spread below this [m] ...
CONVERGED_SPREAD = 0.2
#: ... with the estimate's error below this [m].
CONVERGED_ERROR = 0.1
#: Global localisation: a correlative search's best pose seeds the particles when this share of the
#: scan's valid beams ends within the fit's gate of the map there ...
SEARCH_FIT = 0.8
#: ... as a Gaussian cloud of these standard deviations [m], [rad].
SEED_STD_XY = 0.05
SEED_STD_THETA = 0.03
#: Global localisation ends undecided after this many revolutions in a row whose search found distinct poses
#: explaining the scan alike (or that had too few returns to search): standing still, the next revolution
#: sees the same.
AMBIGUOUS_SCANS = 3
#: The status of a run whose global localisation ended undecided.
AMBIGUOUS = "localisation ambiguous"
#: Variances [m^2, m^2, rad^2] added to a fix's covariance, so that the EKF gets a positive-definite
#: one (a particle cluster's can be singular).
COV_FLOOR = (1e-8, 1e-8, 1e-10)
#: Particles kept per update in the log, for the video's cloud.
CLOUD_KEPT = 200
#: The sources of the EKF's pose corrections (``--localiser``).
LOCALISERS = ("amcl", "fixes")
#: The start of the status text (after :data:`AMBIGUOUS`, the run's ending before tracking) and of the message of
#: a global localisation that did not converge in :data:`GLOBAL_SCANS` revolutions (:class:`LocaliserUnconverged`).
UNCONVERGED = "global localisation did not converge"


#: Offset of the localiser's seeds from the run's noise seed (its own stream).
SEED_OFFSET = 0x5CA9


@dataclass(frozen=True)
class LocaliserSetup:
    """Which localiser corrects the EKF, with its settings.

    Attributes:
        kind: "amcl" (LDS-01 scans matched against the map) or "fixes" (synthetic Gaussian fixes).
        world: The scenario's world (unmapped obstacles left out); None with "fixes". The localiser's map is
            the part of it its scanner sees (:meth:`planning.core.world.World.seen_at`: no obstacle below the
            scan plane).
        lidar: The scanner's settings; None with "fixes".
        amcl: The localiser's settings.
        initial: "known" (particles around the start pose, Nav2's initial covariance), "unknown"
            (global localisation before tracking), or a pose estimate "X,Y,THETA" [m, m, rad] (particles
            around it with Nav2's initial covariance, the robot at the scenario's start: a ROS user's
            "2D Pose Estimate"), which must be finite, inside the world's walls and outside its obstacles.

    Raises:
        ConfigError: A pose estimate that is malformed, not finite, outside the walls or inside an obstacle.
    """

    kind: str = "fixes"
    world: World | None = None
    lidar: LidarProfile | None = None
    amcl: AmclConfig = field(default_factory=AmclConfig)
    initial: str = "known"

    def __post_init__(self) -> None:
        if self.initial not in INITIAL_POSES:
            pose = parse_initial_pose(self.initial)
            if self.world is not None:
                check_initial_pose(pose, self.world, self.initial)
        if self.lidar is not None:
            low, high = self.amcl.range_limits(self.lidar.range_min, self.lidar.range_max)
            if not low < high:
                c = self.amcl
                raise ConfigError(
                    f"amcl laser_min_range={c.laser_min_range:g} and laser_max_range={c.laser_max_range:g} leave no "
                    f"range of the scanner's {self.lidar.range_min:g}-{self.lidar.range_max:g} m to use: no beam "
                    "would be weighed; keep laser_min_range below the scanner's range_max (-1 uses the scan's own "
                    "range_min, Nav2's default) and laser_max_range above its range_min"
                )

    @property
    def initial_pose(self) -> tuple[float, float, float] | None:
        """The pose estimate the particles start around, or None ("known" or "unknown")."""
        return None if self.initial in INITIAL_POSES else parse_initial_pose(self.initial)

    def as_dict(self, seed: int | None = None) -> dict[str, object]:
        """Plain-dict view for records; given the run's noise seed, with the scan localiser also the systematic
        errors of the scanner unit it draws (``lidar_unit``, :func:`sim.physics.lidar.unit_errors`)."""
        out: dict[str, object] = {"kind": self.kind, "initial": self.initial}
        if self.kind == "amcl":
            out["lidar"] = self.lidar.as_dict() if self.lidar is not None else None
            out["amcl"] = self.amcl.as_dict()
            if seed is not None and self.lidar is not None:
                out["lidar_unit"] = unit_errors(self.lidar, seed)
        return out


class ScanFix(NamedTuple):
    """A revolution's pose fix for the EKF (:meth:`control.estimation.PoseEstimator.correct`).

    Attributes:
        pose: (x [m], y [m], theta [rad]).
        cov: (3, 3) its covariance (positive definite), without the scanner's systematic error when
            ``range_gain`` carries it.
        range_gain: (3, 2) the pose's change per unit of the scanner's scale error and per metre of
            its offset (the EKF's states s_r, o_r); None when the particles, not the fit, gave it.
    """

    pose: tuple[float, float, float]
    cov: FloatArray
    range_gain: FloatArray | None


#: How soon after a stretch of scans without returns [s] a loss is said to follow it (:class:`LocaliserLost`): the
#: particles spread by the motion noise while nothing was weighed, and the first scans back meet a wide cloud.
BLIND_RECENT = 10.0
#: The smaller motion noise a loss after such a stretch suggests (an empty 12 x 12 m arena, 48 s without
#: returns: lost with Nav2's 0.2, at the goal with these).
BLIND_ALPHA = 0.05
BLIND_ALPHAS = ",".join(f"alpha{i}={BLIND_ALPHA:g}" for i in range(1, 5))
#: The start of the status of a run whose localiser lost the robot (:class:`LocaliserLost`).
LOST = "localisation lost"


class LocaliserLost(Exception):
    """The localiser's error passed :data:`LOST_ERROR` (the run ends)."""

    def __init__(self, t: float, error: float, blind: tuple[float, float] | None = None, alpha: float = 0.0) -> None:
        why = ""
        if blind is not None and t - blind[1] <= BLIND_RECENT:
            why = (
                f"; from t={blind[0]:.1f} s to {blind[1]:.1f} s its scans had no returns (every surface beyond the "
                f"scanner's range), and the particles spread by the odometry's motion noise meanwhile (alpha1..4 up "
                f"to {alpha:g})"
            )
            if alpha > BLIND_ALPHA:
                why += f": for odometry better than that, lower them ({option('amcl', BLIND_ALPHAS)})"
        super().__init__(f"{LOST} at t={t:.3f} s: the localiser's pose is {error:.2f} m from the truth{why}")
        self.t = t


class LocaliserAmbiguous(Exception):
    """Global localisation cannot choose between poses from its own scans (the run ends before tracking).

    Attributes:
        scans: Revolutions taken.
        poses: (P, 3) the distinct poses that explained them alike, or None: the scans had too few returns.
    """

    def __init__(self, scans: int, poses: FloatArray | None, range_max: float) -> None:
        fix = f"give the start pose ({option('initial-pose', 'known')})"
        if poses is None:
            text = (
                f"global localisation: the scanner saw nothing within {range_max:g} m in {scans} revolutions at the "
                f"start (fewer than {MIN_BEAMS} returns each), which every pose that far from the map explains "
                f"alike; {fix} or start within its range of a wall or obstacle"
            )
        else:
            listed = ", ".join(f"({p[0]:.2f}, {p[1]:.2f}, {math.degrees(p[2]):.0f} deg)" for p in poses)
            text = (
                f"global localisation: {poses.shape[0]} poses explain the scans alike ({listed}) in {scans} "
                f"revolutions at the start; {fix} or a world with a feature that tells them apart"
            )
        super().__init__(text)
        self.scans = scans
        self.poses = poses

    #: The run's status starts with this (then the message), :meth:`sim.robot.sensing.Sensing.diverged`.
    status = AMBIGUOUS


class LocaliserUnconverged(LocaliserAmbiguous):
    """Global localisation took :data:`GLOBAL_SCANS` revolutions without the particles gathering (spread below
    :data:`CONVERGED_SPREAD`) or a search's pose seeding them: the run ends before tracking, as an ambiguous
    one does (its status :data:`AMBIGUOUS` then the message, which starts :data:`UNCONVERGED`).

    Attributes:
        spread: The particles' spread after the last revolution [m].
    """

    def __init__(self, scans: int, spread: float, range_max: float) -> None:
        super().__init__(scans, None, range_max)
        self.args = (
            f"{UNCONVERGED} in {scans} revolutions at the start: no search found a pose that explains the scan "
            f"(at least {SEARCH_FIT:.0%} of its weighed beams on the map) and the particles stayed {spread:.2f} m "
            f"apart (converged: below {CONVERGED_SPREAD:g} m); give the start pose "
            f"({option('initial-pose', 'known')}) or a pose estimate ({option('initial-pose', POSE_EXAMPLE)})",
        )
        self.spread = spread

    status = UNCONVERGED  # the message starts with it


class ScanLocaliser:
    """One run's scanner and AMCL (see the module docstring).

    Args:
        model: The run's compiled model (the physical world, unmapped obstacles included).
        robot: The robot as drawn (the odometry's wheel radius and track).
        setup: The localiser's settings (kind "amcl").
        seed: The run's noise seed.
        t0: Time of control period 0 [s].
        dt: Control period [s].
        rad_per_count: Wheel angle of one encoder count [rad].
        gyro_error: (K,) the gyro's error by control period [rad/s] (its heading's drift), or None for
            an odometry heading from the encoders.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        robot: RobotSpec,
        setup: LocaliserSetup,
        seed: int,
        *,
        t0: float,
        dt: float,
        rad_per_count: float,
        gyro_error: FloatArray | None = None,
    ) -> None:
        assert setup.world is not None and setup.lidar is not None
        self.scanner = LidarScanner(model, setup.lidar, seed)
        laser = (float(self.scanner.offset[0]), float(self.scanner.offset[1]), 0.0)
        # the map it matches scans to: what the scanner sees (an obstacle below its plane is not on it)
        self.amcl = Amcl(
            setup.world.seen_at(self.scanner.height), setup.amcl, laser, seed + SEED_OFFSET,
            range_bias=range_bias(setup.lidar), range_noise=range_noise(setup.lidar),
        )  # fmt: skip
        self.setup, self.t0, self.dt = setup, t0, dt
        # control periods a revolution (a whole number, :func:`localiser_schedule`), and the periods from
        # its centre to the first at or past either end: the poses its beams are interpolated between
        self.per_rev = max(1, round(setup.lidar.period / dt))
        self.half = (self.per_rev + 1) // 2
        self.r, self.track = robot.wheel_radius, robot.track_width
        self.rad_per_count = rad_per_count
        self.odom = np.zeros(3)
        self.counts = (0, 0)
        # the gyro's integrated error by period (the IMU yaw's drift), and the last fix period's true heading
        self.gyro_drift = None if gyro_error is None else dt * np.cumsum(np.asarray(gyro_error, dtype=float))
        self.last: tuple[int, float] = (0, 0.0)
        self.odom_at: dict[int, FloatArray] = {}
        self.rows: list[tuple[float, ...]] = []  # t, pose(3), cov(9), truth(3), particles, spread
        self.clouds: list[FloatArray] = []
        self.scan_t: list[float] = []
        self.scan_ranges: list[FloatArray] = []
        self.lost_at: float | None = None
        #: The last stretch of scans without returns (its first and last scan's times), and the current one's start.
        self.blind: tuple[float, float] | None = None
        self._blind_from: float | None = None
        self.global_scans: int | None = None
        self.global_converged: bool | None = None

    def start(self, data: mujoco.MjData, truth: tuple[float, float, float], counts: tuple[int, int]) -> None:
        """Period 0: the odometry's origin, and the particles (around the start, or global localisation)."""
        self.counts = counts
        self.last = (0, float(truth[2]))
        self.odom_at[0] = self.odom.copy()
        if self.setup.initial != "unknown":  # around the start, or the pose estimate given (Nav2's covariance)
            estimate = self.setup.initial_pose
            self.amcl.reset(truth if estimate is None else estimate)
            return
        self.amcl.reset_global()
        try:
            self.global_scans, self.global_converged = self._localise(data, truth)
        except LocaliserAmbiguous as undecided:
            self.global_scans, self.global_converged = undecided.scans, False
            raise

    def belief(self, truth: tuple[float, float, float]) -> tuple[tuple[float, float, float], FloatArray | None]:
        """Where the EKF starts after :meth:`start` (``truth``: the robot's start): at the start, exactly, when it
        is known; at the pose estimate given, with the particles' initial covariance (Nav2's, as a "2D Pose
        Estimate" resets AMCL and the pose the robot believes); after global localisation, at the localiser's
        estimate and its covariance. The robot believes what it was told or found, not where it stands."""
        c = self.amcl.config
        estimate = self.setup.initial_pose
        if estimate is not None:
            return estimate, np.diag([c.initial_std_xy**2, c.initial_std_xy**2, c.initial_std_theta**2])
        found = self.amcl.estimate if self.setup.initial == "unknown" else None
        if found is None:
            return truth, None
        pose = (float(found.pose[0]), float(found.pose[1]), math.remainder(float(found.pose[2]), 2 * math.pi))
        return pose, found.cov + np.diag(COV_FLOOR)

    def _localise(self, data: mujoco.MjData, truth: tuple[float, float, float]) -> tuple[int, bool]:
        """Global localisation, the robot standing at ``truth``: the revolutions taken, and whether the
        particles converged there (the truth only judges the answer, after it is given).

        Raises:
            LocaliserAmbiguous: :data:`AMBIGUOUS_SCANS` revolutions in a row had distinct poses explaining
                them alike, or too few returns to search.
            LocaliserUnconverged: :data:`GLOBAL_SCANS` revolutions did not gather the particles (tracking
                from a cloud spread over the map would fuse its guesses).
        """
        lidar = self.scanner.profile
        pose = np.tile(np.asarray(truth, dtype=float), (lidar.beams, 1))
        limits = (lidar.range_min, lidar.range_max, 0.0, lidar.angle_increment)
        seeded, blind, alike = False, 0, 0  # revolutions in a row without returns, and ambiguous ones
        for n in range(1, GLOBAL_SCANS + 1):
            scan = self.scanner.scan(data, self.t0 - (GLOBAL_SCANS - n + 1) * lidar.period, pose)
            blind = blind + 1 if scan_returns(scan.ranges, lidar.range_min, lidar.range_max) < MIN_BEAMS else 0
            if blind >= AMBIGUOUS_SCANS:
                raise LocaliserAmbiguous(n, None, lidar.range_max)
            if blind:  # nothing to localise on
                continue
            ambiguous = False
            if not seeded:  # a correlative search of the free space seeds the particles once it fits well
                found = self.amcl.search(scan.ranges, lidar.range_min, lidar.range_max, scan.bearings)
                ambiguous = found.ambiguous
                alike = alike + 1 if ambiguous else 0
                if alike >= AMBIGUOUS_SCANS:
                    raise LocaliserAmbiguous(n, found.poses, lidar.range_max)
                if not ambiguous and found.share >= SEARCH_FIT:
                    self.amcl.reset(found.pose, SEED_STD_XY, SEED_STD_THETA)
                    seeded = True
            self.amcl.update(self.odom, scan.ranges, *limits, force=True)
            est = self.amcl.estimate
            if not ambiguous and est is not None and est.spread < CONVERGED_SPREAD:  # one mode of several is not
                err = math.hypot(est.pose[0] - truth[0], est.pose[1] - truth[1])
                return n, err < CONVERGED_ERROR
        spread = math.nan if self.amcl.estimate is None else self.amcl.estimate.spread
        raise LocaliserUnconverged(GLOBAL_SCANS, spread, self.scanner.profile.range_max)

    def mark(self, k: int, counts: tuple[int, int], yaw: float | None = None) -> None:
        """The encoder counts and the true heading ``yaw`` [rad] at a fix period ``k``: the odometry
        there (one arc since the last; its heading the IMU's, the true turn plus the gyro's drift, when
        the gyro's error and ``yaw`` are known, else the encoders')."""
        dl, dr = counts[0] - self.counts[0], counts[1] - self.counts[1]
        self.counts = counts
        sl, sr = dl * self.rad_per_count * self.r, dr * self.rad_per_count * self.r
        ds, dth = 0.5 * (sl + sr), (sr - sl) / self.track
        if self.gyro_drift is not None and yaw is not None:
            k0, yaw0 = self.last
            dth = angle_diff(yaw, yaw0) + float(self.gyro_drift[k] - self.gyro_drift[k0])
            self.last = (k, float(yaw))
        x, y, th = self.odom
        phi = th + 0.5 * dth
        c = 1.0 if abs(dth) < 1e-9 else math.sin(0.5 * dth) / (0.5 * dth)
        self.odom = np.array([x + ds * c * math.cos(phi), y + ds * c * math.sin(phi), th + dth])
        self.odom_at[k] = self.odom.copy()

    def fix(self, j: int, data: mujoco.MjData, truth: FloatArray, estimate: FloatArray) -> ScanFix | None:
        """The localiser's answer for the revolution centred on period ``j`` (None if AMCL did not update,
        or the revolution had fewer than :data:`control.estimation.amcl.MIN_BEAMS` returns: nothing to match).

        The scan is deskewed first, as the robot can: each beam moved into the frame of the estimated
        pose at ``j`` by the estimator's own poses over the revolution (:func:`deskew`).

        Args:
            j: The fix's period (its measurement time).
            data: The run's data (the static geoms placed).
            truth: (K, 3) true poses by period, filled up to the current period (at least ``j + half``).
            estimate: (K, 3) the estimator's poses by period, filled as far.

        Returns:
            The fix (its white noise apart from the scanner's systematic error, which it carries as a
            gain, when the fit gave it).

        Raises:
            LocaliserLost: The estimate is more than :data:`LOST_ERROR` from the truth at ``j``, further than its
                covariance says it may be (:data:`LOST_DISTANCE2`).
        """
        lidar = self.scanner.profile
        ks = np.clip(np.arange(j - self.half, j + self.half + 1), 0, None)
        t = np.asarray(self.t0 + self.dt * np.arange(j - self.half, j + self.half + 1), dtype=float)
        stamp = self.t0 + self.dt * (j - 0.5 * self.per_rev)  # the revolution's start, half of it before j
        times = np.asarray(stamp + lidar.time_increment * np.arange(lidar.beams), dtype=float)
        scan = self.scanner.scan(data, stamp, beam_poses(t, truth[ks], times))
        self.scan_t.append(stamp)
        self.scan_ranges.append(scan.ranges)
        odom = self.odom_at.pop(j)
        if scan_returns(scan.ranges, lidar.range_min, lidar.range_max) < MIN_BEAMS:  # nothing to match: no fix
            self.amcl.predict(odom)  # but the particles follow the odometry (Nav2's motion update): no scan used
            self._blind_from = stamp if self._blind_from is None else self._blind_from
            self.blind = (self._blind_from, stamp)
            return None
        self._blind_from = None
        if not self.amcl.moved_enough(odom):  # AMCL takes no scan until the robot has moved (Nav2's rule)
            return None
        est_poses = beam_poses(t, estimate[ks], times)
        ranges, bearings = deskew(scan.ranges, scan.bearings, est_poses, estimate[j], self.amcl.laser)
        limits = (lidar.range_min, lidar.range_max, 0.0, lidar.angle_increment)
        updated = self.amcl.update(odom, ranges, *limits, bearings=bearings)
        assert updated
        est = self._record(j, truth)
        pose = (float(est.pose[0]), float(est.pose[1]), math.remainder(float(est.pose[2]), 2 * math.pi))
        cov = (est.cov if est.noise_cov is None else est.noise_cov) + np.diag(COV_FLOOR)  # a cluster's may be singular
        return ScanFix(pose, cov, est.range_gain)

    def _record(self, j: int, truth: FloatArray) -> AmclEstimate:
        """Log the localiser's estimate after its update at period ``j`` (and a sample of its cloud); returns it.

        Raises:
            LocaliserLost: As :meth:`fix` says.
        """
        est = self.amcl.estimate
        assert est is not None
        tj = self.t0 + self.dt * j
        true = truth[j]
        err = math.hypot(est.pose[0] - true[0], est.pose[1] - true[1])
        self.rows.append((tj, *est.pose, *est.cov.ravel(), *true, est.particles, est.spread))
        step = max(1, self.amcl.particles.shape[0] // CLOUD_KEPT)
        self.clouds.append(self.amcl.particles[::step][:CLOUD_KEPT].copy())
        if err > LOST_ERROR and self.lost_at is None:
            e = est.pose[:2] - true[:2]
            if float(e @ np.linalg.solve(est.cov[:2, :2], e)) > LOST_DISTANCE2:  # sure of a wrong place
                self.lost_at = tj
                c = self.amcl.config
                raise LocaliserLost(tj, err, self.blind, max(c.alpha1, c.alpha2, c.alpha3, c.alpha4))
        return est

    def heading_error(self, pose: FloatArray, true: FloatArray) -> float:
        """Wrapped heading error [rad]."""
        return angle_diff(float(pose[2]), float(true[2]))

    def to_log(self) -> LocaliserLog:
        """The run's localiser record (its updates against the truth, and every scan cast)."""
        rows = np.array(self.rows, dtype=float).reshape(-1, 18)
        lidar = self.scanner.profile
        cloud = np.full((len(self.clouds), CLOUD_KEPT, 3), np.nan)
        for i, c in enumerate(self.clouds):
            cloud[i, : c.shape[0]] = c
        return LocaliserLog(
            t=rows[:, 0].copy(),
            pose=rows[:, 1:4].copy(),
            cov=rows[:, 4:13].reshape(-1, 3, 3).copy(),
            truth=rows[:, 13:16].copy(),
            particles=rows[:, 16].astype(np.int64),
            spread=rows[:, 17].copy(),
            cloud=cloud,
            scan_t=np.array(self.scan_t, dtype=float),
            scan_ranges=np.array(self.scan_ranges, dtype=float).reshape(-1, lidar.beams),
            scan_angle_increment=lidar.angle_increment,
            scan_time_increment=lidar.time_increment,
            range_min=lidar.range_min,
            range_max=lidar.range_max,
            lost_at=self.lost_at,
            global_scans=self.global_scans,
            global_converged=self.global_converged,
            laser=(float(self.amcl.laser[0]), float(self.amcl.laser[1]), float(self.amcl.laser[2])),
        )


def range_bias(lidar: LidarProfile) -> tuple[float, float, float]:
    """The scanner's systematic range error as the localiser models it: (split [m], standard deviation
    of the offset below it [m], of the relative scale error from it [-]); the datasheet's accuracy is
    the band a unit's own error fills at :data:`sim.physics.asbuilt.CLIP_SIGMAS` standard deviations
    (:mod:`sim.physics.lidar`)."""
    return lidar.accuracy_split, lidar.accuracy_near / CLIP_SIGMAS, lidar.accuracy_far / CLIP_SIGMAS


def range_noise(lidar: LidarProfile) -> tuple[float, float, float, float, float]:
    """The scanner's white range noise as the localiser's fit weighs its beams: (split [m], standard
    deviation below it [m], relative standard deviation from it [-]), the datasheet's precision, and
    the band below and above the split whose beams the fit leaves out [m]: a reading there may carry
    either side's systematic error (:func:`control.estimation.amcl_kernels.beam_weight`): a far wall
    read short by the whole scale band, a near one read long by the whole offset band."""
    split = lidar.accuracy_split
    return split, lidar.precision_near, lidar.precision_far, split * lidar.accuracy_far, lidar.accuracy_near


def _rate_between_ticks(rate: float, dt: float) -> str:
    """The refusal of a scan rate whose revolution is not a whole number of control periods ``dt`` [s]: the
    localiser's fix is taken at a control tick once a revolution, so the fix rate could not equal it."""
    from sim.physics.lidar import LIMITS

    low, high, _ = LIMITS["rate"]
    control = 1.0 / dt
    periods = range(max(1, math.floor(control / high)), math.ceil(control / low) + 1)
    fit = [f"{control / n:g}" for n in periods if low - 1e-9 <= control / n <= high + 1e-9]
    said = (
        f"give {option('lidar', 'rate=' + fit[0])}" + (f" (or {', '.join(fit[1:])} Hz)" if fit[1:] else "")
        if fit
        else f"no rate within the LDS-01's {60 * low:g}-{60 * high:g} rpm fits {control:g} Hz: give "
        f"{option('control-rate', 50)}, which 5 Hz fits"
    )
    return (
        f"lidar rate={rate:g} Hz: a revolution is {control / rate:.4g} control periods at {control:g} Hz, not a whole "
        f"number, and the amcl localiser takes its fix once a revolution, at a control tick; {said}"
    )


def localiser_schedule(setup: LocaliserSetup, fix_every: int, latency_periods: int, dt: float) -> None:
    """Check that the fix schedule fits the scanner: one fix per revolution, delivered after it ends.

    Raises:
        ConfigError: The fix rate is not the scan rate, or the latency is shorter than half a
            revolution plus a control period (naming the sensor field and the fix).
    """
    assert setup.lidar is not None
    per_rev = setup.lidar.period / dt
    if abs(per_rev - round(per_rev)) > 1e-6 * per_rev:  # the fix rate, which must equal it, could not either
        raise ConfigError(_rate_between_ticks(setup.lidar.rate, dt))
    if fix_every == 0 or abs(fix_every - per_rev) > 1e-6 * per_rev:
        rate = setup.lidar.rate
        raise ConfigError(
            f"sensor fix_rate must equal the scan rate ({rate:g} Hz) with the amcl localiser: one fix a revolution; "
            f"set {option('sensors', f'fix_rate={rate:g}')} (or fix_rate = {rate:g} in the [sensors] table of the "
            f"scenario or sensor profile that sets it), or use {option('localiser', 'fixes')}"
        )
    half = max(1, round(0.5 * per_rev))
    if latency_periods < half + 1:
        need = (half + 1) * dt
        raise ConfigError(
            f"sensor fix_latency must be at least half a revolution plus a control period ({need:g} s) with "
            f"the amcl localiser: a revolution's fix is known only when it has ended; set "
            f"{option('sensors', f'fix_latency={need:g}')}"
        )


def deskew(
    ranges: FloatArray, bearings: FloatArray, poses: FloatArray, ref: FloatArray, laser: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """A revolution's beams as seen from one pose: each finite beam's end point, placed by the pose the
    robot believed it had at its instant, in the scanner's frame at ``ref``.

    Args:
        ranges: (B,) ranges [m] (non-finite ones are kept as they are).
        bearings: (B,) bearings in the scanner's frame [rad].
        poses: (B, 3) the robot's pose at each beam's instant.
        ref: (3,) the pose to see them from.
        laser: (3,) the scanner's pose in the robot's frame.

    Returns:
        (B,) ranges [m] and (B,) bearings [rad] from the scanner at ``ref``.
    """
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    lx = poses[:, 0] + c * laser[0] - s * laser[1]
    ly = poses[:, 1] + s * laser[0] + c * laser[1]
    fin = np.isfinite(ranges)
    r = np.where(fin, ranges, 0.0)
    a = poses[:, 2] + laser[2] + bearings
    px, py = lx + r * np.cos(a), ly + r * np.sin(a)
    cr, sr = math.cos(ref[2]), math.sin(ref[2])
    mx, my = ref[0] + cr * laser[0] - sr * laser[1], ref[1] + sr * laser[0] + cr * laser[1]
    dx, dy = px - mx, py - my
    out_r = np.where(fin, np.hypot(dx, dy), ranges)
    out_b = np.where(fin, np.arctan2(dy, dx) - ref[2] - laser[2], bearings)
    return np.asarray(out_r, dtype=float), np.asarray(out_b, dtype=float)
