"""Tracking metrics of a run against its reference."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from control.estimation import chi2_interval
from control.estimation.amcl import MIN_BEAMS, scan_returns
from planning.core.checks import check_number
from planning.core.geometry import wrap_angle
from planning.core.robot import RobotSpec
from planning.errors import ConfigError
from planning.trajectory.trajectory import Trajectory
from sim.physics.model import body_pitch
from sim.physics.runlog import EstimationLog, RunLog


@dataclass(frozen=True)
class EstimationMetrics:
    """How well a run's estimator knew where the robot was (against the true pose).

    Attributes:
        source: "fused" (encoders, gyro and fixes) or "odometry" (dead reckoning).
        position_rmse_m: RMS of the estimate's position error over the control instants [m].
        heading_rmse_rad: RMS of its wrapped heading error [rad].
        final_position_error_m: Position error of the last estimate [m].
        nees_in_bound_fraction: Share of fix deliveries whose NEES lies inside the two-sided 95 %
            chi-square interval (about 0.95 for a consistent estimator; NaN, a statistic of nothing,
            without a delivery the estimator compared: none, or all older than its history).
        fixes_used: Fixes the estimator applied.
        fixes_widened: Of those, outliers applied after widening its covariance: a systematic odometry
            drift beyond its priors explained them (:mod:`control.estimation.ekf`; the NEES shows
            what that cost its consistency).
        relocalisations: Times the estimate moved to outlier fixes that agreed on its offset (a wrong initial
            pose the localiser corrected; :mod:`control.estimation.ekf`): the run went on from there.
        nees_mean: Mean NEES over those deliveries (3 for a consistent estimator of a planar pose;
            above 3 over-confident, below conservative). The share inside the interval can be 100 %
            with a mean of 5: the per-fix interval (0.22-9.35) is wide; the mean shows the bias.
        localiser_rmse_m: RMS position error of the scan localiser's updates [m] (None: no scan
            localiser).
        localiser_heading_rmse_rad: RMS heading error of its updates [rad].
        localiser_nees_in_bound_fraction: Share of its updates whose NEES against its own covariance
            lies inside the 95 % chi-square(3) interval.
        localiser_nees_mean: Their mean NEES (3 when its covariance is right).
        mean_particles: Mean particle count over its updates.
        scans_used: Its updates (scans that moved the filter).
        scans_without_returns: Revolutions with fewer returns than the localiser needs
            (:data:`control.estimation.amcl.MIN_BEAMS` ranges within the scanner's limits): no fix came of them.
        scans_cast: Revolutions cast while tracking.
        localisation_lost: Time its error passed 0.5 m [s] (the run ended there), or None.
        global_localisation_scans: Revolutions global localisation took (None: start pose known).
        global_localisation_converged: Whether it converged (error < 0.1 m, spread < 0.2 m).
    """

    source: str
    position_rmse_m: float
    heading_rmse_rad: float
    final_position_error_m: float
    nees_in_bound_fraction: float
    fixes_used: int
    nees_mean: float = math.nan
    fixes_widened: int = 0
    relocalisations: int = 0
    localiser_rmse_m: float | None = None
    localiser_heading_rmse_rad: float | None = None
    localiser_nees_in_bound_fraction: float | None = None
    localiser_nees_mean: float | None = None
    mean_particles: float | None = None
    scans_used: int | None = None
    scans_without_returns: int | None = None
    scans_cast: int | None = None
    localisation_lost: float | None = None
    global_localisation_scans: int | None = None
    global_localisation_converged: bool | None = None

    @classmethod
    def of(cls, log: EstimationLog) -> EstimationMetrics:
        """The metrics of an estimation log."""
        pe, he = log.position_errors(), log.heading_errors()
        if not pe.size:  # no estimate (global localisation chose no pose): a statistic of nothing
            pe = he = np.array([math.nan])
        return cls(
            **_localiser_metrics(log),
            source=log.source,
            position_rmse_m=float(np.sqrt(np.mean(pe**2))),
            heading_rmse_rad=float(np.sqrt(np.mean(he**2))),
            final_position_error_m=float(pe[-1]),
            nees_in_bound_fraction=log.nees_in_bound_fraction(),
            fixes_used=int(np.count_nonzero(log.fix_applied)),
            nees_mean=log.nees_mean(),
            fixes_widened=log.fixes_widened,
            relocalisations=log.relocalisations,
        )


def _localiser_metrics(log: EstimationLog) -> dict[str, Any]:
    """The scan localiser's fields of :class:`EstimationMetrics` (none without one)."""
    loc = log.localiser
    if loc is None:
        return {}
    n = loc.t.size
    e, h = loc.errors(), loc.heading_errors()
    err = np.column_stack([loc.pose[:, :2] - loc.truth[:, :2], h]) if n else np.zeros((0, 3))
    inside = mean = math.nan
    if n:
        lo, hi = chi2_interval(3)
        nees = np.array([float(x @ np.linalg.solve(c, x)) for x, c in zip(err, loc.cov, strict=True)])
        inside, mean = float(np.mean((nees >= lo) & (nees <= hi))), float(np.mean(nees))
    return {
        "localiser_rmse_m": float(np.sqrt(np.mean(e**2))) if n else math.nan,
        "localiser_heading_rmse_rad": float(np.sqrt(np.mean(h**2))) if n else math.nan,
        "localiser_nees_in_bound_fraction": inside,
        "localiser_nees_mean": mean,
        "mean_particles": float(np.mean(loc.particles)) if n else math.nan,
        "scans_used": int(n),
        "scans_without_returns": int(
            np.count_nonzero(scan_returns(loc.scan_ranges, loc.range_min, loc.range_max) < MIN_BEAMS)
        ),
        "scans_cast": int(loc.scan_t.size),
        "localisation_lost": loc.lost_at,
        "global_localisation_scans": loc.global_scans,
        "global_localisation_converged": loc.global_converged,
    }


@dataclass(frozen=True)
class TrackingMetrics:
    """How well a run followed its reference.

    A run that ended early (``status`` not "ok": a balancing robot fell, the estimate was lost) is measured up to
    its end: its final errors are against the reference at that moment, not the goal, so a small
    ``final_position_error_m`` there is no success; ``final_goal_error_m`` is the distance to the goal and
    ``status`` says why it ended (as ``nhsim simulate`` marks such a row with an asterisk and a note).

    Attributes:
        final_position_error_m: |p - p_ref| at the end of the run [m].
        final_heading_error_rad: |wrap(theta - theta_ref)| at the end [rad].
        rms_position_error_m: RMS of |p - p_ref| over the log [m].
        max_position_error_m: Max of |p - p_ref| over the log [m].
        final_goal_error_m: |p - p_final| at the end, against the trajectory's last pose [m].
        collisions: Number of robot-obstacle contact spells.
        warnings: Number of MuJoCo warnings.
        saturation_fraction: Share of logged control periods where a command sat on a limit: the
            body command on |v| or |omega|, or a wheel command on the wheel-speed limit (the drive
            mapping scales (v, omega) down so the faster wheel sits on it).
        duration_s: Simulated time [s].
        wheel_contact_loss_fraction: Share of the logged physics steps with a drive wheel off the
            floor.
        status: "ok", or why the run ended early (the estimator diverged, the robot fell).
        estimation: The estimator's accuracy and consistency (None when the tracker saw the truth).
        max_pitch_rad: A balancing robot's largest |pitch| over the log [rad] (None for the others).
        fell: Whether a balancing robot fell (None for the others).
        fall_time_s: When it fell [s] (None if it did not).
    """

    final_position_error_m: float
    final_heading_error_rad: float
    rms_position_error_m: float
    max_position_error_m: float
    final_goal_error_m: float
    collisions: int
    warnings: int
    saturation_fraction: float
    duration_s: float
    wheel_contact_loss_fraction: float = 0.0
    status: str = "ok"
    estimation: EstimationMetrics | None = None
    max_pitch_rad: float | None = None
    fell: bool | None = None
    fall_time_s: float | None = None

    def as_dict(self) -> dict[str, Any]:
        """Plain-dict view for JSON (``estimation`` a nested dict, NaN as None; the balance fields only
        for a balancing robot)."""
        out = asdict(self)
        if self.fell is None:
            for key in ("max_pitch_rad", "fell", "fall_time_s"):
                del out[key]
        if out["estimation"] is None:
            del out["estimation"]
        else:
            est = out["estimation"]
            if self.estimation is not None and self.estimation.scans_used is None:  # no scan localiser
                est = {k: v for k, v in est.items() if k not in _LOCALISER_KEYS}
            out["estimation"] = {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in est.items()}
        return out


#: The scan localiser's fields of :class:`EstimationMetrics` (those None without one), left out of records of
#: runs without one.
_LOCALISER_KEYS = tuple(f.name for f in fields(EstimationMetrics) if f.default is None)


def position_errors(log: RunLog) -> np.ndarray:
    """(N,) distance between the measured and the reference position at each log time [m]."""
    d = log.pose[:, :2] - log.ref_pose[:, :2]
    return np.hypot(d[:, 0], d[:, 1])


def heading_errors(log: RunLog) -> np.ndarray:
    """(N,) wrapped heading error at each log time [rad]."""
    return np.asarray(wrap_angle(log.pose[:, 2] - log.ref_pose[:, 2]))


def saturated(log: RunLog, *, max_speed: float, max_yaw_rate: float, max_wheel_speed: float) -> np.ndarray:
    """(N,) whether each logged command sat on a limit.

    A sample counts when the body command is on |v| >= max_speed or |omega| >= max_yaw_rate, or
    either wheel command is on |wheel| >= max_wheel_speed (where the drive mapping scaled the
    body command down). Limits are met within a relative 1e-9.

    Args:
        log: The run.
        max_speed: |v| limit [m/s].
        max_yaw_rate: |omega| limit [rad/s].
        max_wheel_speed: |wheel speed| limit [rad/s].
    """
    tight = 1 - 1e-9
    body = (np.abs(log.command[:, 0]) >= max_speed * tight) | (np.abs(log.command[:, 1]) >= max_yaw_rate * tight)
    wheel = np.abs(log.wheel_command).max(axis=1) >= max_wheel_speed * tight
    return np.asarray(body | wheel)


def compute_metrics(
    log: RunLog, trajectory: Trajectory, *, max_speed: float, max_yaw_rate: float, max_wheel_speed: float
) -> TrackingMetrics:
    """Metrics of a run.

    Args:
        log: The run.
        trajectory: Its reference.
        max_speed: |v| limit, for the saturation share [m/s].
        max_yaw_rate: |omega| limit [rad/s].
        max_wheel_speed: |wheel speed| limit, for the saturation share [rad/s].

    Raises:
        ConfigError: ``log`` is not a run log or ``trajectory`` not a trajectory, a limit is not a positive number,
            or the log's reference is not ``trajectory`` (the errors are the log's against its own reference).
    """
    limits = {"max_speed": max_speed, "max_yaw_rate": max_yaw_rate, "max_wheel_speed": max_wheel_speed}
    _check_metric_inputs(log, trajectory, limits)
    err = position_errors(log)
    herr = heading_errors(log)
    final = trajectory.final_pose
    sat = saturated(log, max_speed=max_speed, max_yaw_rate=max_yaw_rate, max_wheel_speed=max_wheel_speed)
    return TrackingMetrics(
        final_position_error_m=float(err[-1]),
        final_heading_error_rad=float(abs(herr[-1])),
        rms_position_error_m=float(np.sqrt(np.mean(err**2))),
        max_position_error_m=float(err.max()),
        final_goal_error_m=float(np.hypot(log.pose[-1, 0] - final.x, log.pose[-1, 1] - final.y)),
        collisions=len(log.contacts),
        warnings=len(log.warnings),
        saturation_fraction=float(np.mean(sat)),
        duration_s=float(log.t[-1] - log.t[0]),
        wheel_contact_loss_fraction=log.wheel_contact_loss_fraction,
        status=log.status,
        estimation=EstimationMetrics.of(log.estimation) if log.estimation is not None else None,
        **balance_metrics(log),
    )


def _check_metric_inputs(log: object, trajectory: object, limits: dict[str, float]) -> None:
    """:func:`compute_metrics`'s checks (see there): the types, the limits, and that the log's reference poses at a
    dozen of its times are ``trajectory``'s there (held at its end), to 1 um."""
    if not isinstance(log, RunLog):
        raise ConfigError(f"compute_metrics: log must be a RunLog (a run's log, Run.log), got {type(log).__name__}")
    if not isinstance(trajectory, Trajectory):
        raise ConfigError(
            f"compute_metrics: trajectory must be the run's Trajectory (JobResult.prepared.trajectory), got "
            f"{type(trajectory).__name__}"
        )
    for name, value in limits.items():
        check_number(f"compute_metrics: {name}", value, above=0.0, fix="the robot's limit (its RobotSpec's)")
    rows = np.unique(np.linspace(0, log.t.size - 1, 12).round().astype(int))
    want = trajectory.sample_many(np.minimum(log.t[rows], trajectory.duration)).pose[:, :2]
    off = float(np.max(np.hypot(*(want - log.ref_pose[rows, :2]).T)))
    if off > 1e-6:
        raise ConfigError(
            f"compute_metrics: the log was not run on this trajectory (its reference is {off:.3g} m from the "
            f"trajectory's pose at the same time): give the trajectory the run tracked, {log!r:.80}"
        )


def balance_metrics(log: RunLog) -> dict[str, Any]:
    """``max_pitch_rad``, ``fell`` and ``fall_time_s`` of a balancing robot's run (empty for the others);
    the pitch from the logged base quaternion (the free joint's qpos 3:7, the model's first joint)."""
    if log.balance is None:
        return {}
    pitch = body_pitch(log.qpos[:, 3:7])
    fell_at = log.balance.fell_at
    return {"max_pitch_rad": float(np.max(np.abs(pitch))), "fell": fell_at is not None, "fall_time_s": fell_at}


def robot_metrics(log: RunLog, trajectory: Trajectory, robot: RobotSpec) -> TrackingMetrics:
    """:func:`compute_metrics` of a run with the robot's own speed, yaw-rate and wheel-speed limits."""
    return compute_metrics(
        log,
        trajectory,
        max_speed=robot.max_speed,
        max_yaw_rate=robot.max_yaw_rate,
        max_wheel_speed=robot.max_wheel_speed,
    )
