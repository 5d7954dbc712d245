"""RunLog: the time series of what the engine did in one run."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planning.core.arrays import ReadOnlyArrays, freeze_arrays
from planning.errors import SimulationError

FloatArray = NDArray[np.float64]

#: Series -> columns (None: a (N,) series; 0: any number, e.g. nq).
WIDTHS: dict[str, int | None] = {
    "t": None,
    "pose": 3,
    "qpos": 0,
    "ref_pose": 3,
    "command": 2,
    "wheel_command": 2,
    "wheel_speed": 2,
}


#: Longest status a :class:`RunLog`'s repr quotes [characters] (a collision then a fall says more).
REPR_STATUS = 80


def _cut(text: str, most: int) -> str:
    """``text`` cut to ``most`` characters, "..." marking a cut."""
    return text if len(text) <= most else text[: most - 3] + "..."


@dataclass(frozen=True)
class Contact:
    """A robot-obstacle contact seen in the log: time [s] and obstacle geom name."""

    t: float
    obstacle: str


@dataclass(frozen=True, eq=False)
class BalanceLog(ReadOnlyArrays):
    """What a balancing robot's balance loop did.

    Attributes:
        t: (K,) update times [s].
        pitch_estimate: (K,) the complementary filter's pitch [rad].
        pitch_setpoint: (K,) the pitch the loop asked for (its position and speed errors as a lean) [rad].
        fell_at: Time of a fall [s] (the run ended there), None if it stayed up.
    """

    t: FloatArray
    pitch_estimate: FloatArray
    pitch_setpoint: FloatArray
    fell_at: float | None = None

    def __post_init__(self) -> None:
        freeze_arrays(self)


@dataclass(frozen=True, eq=False)
class LocaliserLog(ReadOnlyArrays):
    """What a scan localiser (AMCL on LDS-01 scans) answered, against the truth, and the scans it took.

    Attributes:
        t: (L,) measurement times of its updates [s].
        pose: (L, 3) its poses [x, y, theta].
        cov: (L, 3, 3) their covariances.
        truth: (L, 3) the true poses then.
        particles: (L,) particle count after each update.
        spread: (L,) root of the trace of the particles' (x, y) covariance [m].
        cloud: (L, P, 3) up to P particles kept per update, NaN rows where fewer.
        scan_t: (S,) stamps (first beam) of every revolution cast [s].
        scan_ranges: (S, B) their ranges [m], REP 117 (-inf too close, +inf nothing within range).
        scan_angle_increment: Bearing step of the scans [rad] (angle_min 0).
        scan_time_increment: Time between beams [s].
        range_min: Shortest range [m].
        range_max: Longest range [m].
        lost_at: Measurement time at which the error passed 0.5 m (the run ended there), or None.
        global_scans: Revolutions taken by global localisation (None: the start pose was known).
        global_converged: Whether global localisation converged (None: not run).
        laser: The scanner's pose in the robot's frame (x, y, yaw) [m, m, rad].
    """

    t: FloatArray
    pose: FloatArray
    cov: FloatArray
    truth: FloatArray
    particles: NDArray[np.int64]
    spread: FloatArray
    cloud: FloatArray
    scan_t: FloatArray
    scan_ranges: FloatArray
    scan_angle_increment: float
    scan_time_increment: float
    range_min: float
    range_max: float
    lost_at: float | None = None
    global_scans: int | None = None
    global_converged: bool | None = None
    laser: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        freeze_arrays(self)

    def errors(self) -> FloatArray:
        """(L,) position error of each update [m]."""
        return np.asarray(np.hypot(*(self.pose[:, :2] - self.truth[:, :2]).T), dtype=float)

    def heading_errors(self) -> FloatArray:
        """(L,) wrapped heading error of each update [rad]."""
        return np.asarray(np.remainder(self.pose[:, 2] - self.truth[:, 2] + np.pi, 2 * np.pi) - np.pi)


@dataclass(frozen=True, eq=False)
class EstimationLog(ReadOnlyArrays):
    """What a run's estimator believed, per control period, against the truth.

    Attributes:
        source: "fused" (encoders, gyro and fixes) or "odometry" (no fixes).
        t: (K,) control instants [s].
        truth: (K, 3) true pose [x, y, theta] at each instant (theta wrapped).
        estimate: (K, 3) the estimate the tracker saw.
        variance: (K, 3) the estimate's variances [m^2, m^2, rad^2].
        fix_t: (M,) measurement times of the localisation fixes [s].
        fix: (M, 3) the fixes (noisy poses).
        fix_applied: (M,) whether the estimator used each fix (False: not yet arrived, an outlier,
            or dead reckoning, which uses none).
        nees_t: (J,) times at which fixes were delivered [s].
        nees: (J,) normalised estimation error squared of the pose after each delivery.
        nees_bounds: Two-sided 95 % chi-square interval of the NEES (3 degrees of freedom).
        status: "ok", or why the estimator stopped (the run ended there).
        localiser: The scan localiser's own answers, when one gave the fixes.
        fixes_widened: Outlier fixes applied after widening the covariance (a systematic odometry
            drift beyond the priors explained them: :mod:`control.estimation.ekf`).
        relocalisations: Times the estimate moved to outlier fixes that agreed on its offset
            (:mod:`control.estimation.ekf`).
    """

    source: str
    t: FloatArray
    truth: FloatArray
    estimate: FloatArray
    variance: FloatArray
    fix_t: FloatArray
    fix: FloatArray
    fix_applied: NDArray[np.bool_]
    nees_t: FloatArray
    nees: FloatArray
    nees_bounds: tuple[float, float]
    status: str = "ok"
    localiser: LocaliserLog | None = None
    fixes_widened: int = 0
    relocalisations: int = 0

    def __post_init__(self) -> None:
        k, m = self.t.shape[0], self.fix_t.shape[0]
        shapes = {"truth": (k, 3), "estimate": (k, 3), "variance": (k, 3), "fix": (m, 3), "fix_applied": (m,),
                  "nees": self.nees_t.shape}  # fmt: skip
        for name, want in shapes.items():
            if getattr(self, name).shape != want:
                raise ValueError(f"EstimationLog.{name} must have shape {want}, got {getattr(self, name).shape}")
        freeze_arrays(self)

    def position_errors(self) -> FloatArray:
        """(K,) distance between the estimate and the truth [m]."""
        d = self.estimate[:, :2] - self.truth[:, :2]
        return np.hypot(d[:, 0], d[:, 1])

    def heading_errors(self) -> FloatArray:
        """(K,) wrapped heading error of the estimate [rad]."""
        return np.asarray(np.remainder(self.estimate[:, 2] - self.truth[:, 2] + np.pi, 2 * np.pi) - np.pi)

    def nees_in_bound_fraction(self) -> float:
        """Share of fix deliveries whose NEES lies inside the 95 % chi-square interval (NaN: none)."""
        if self.nees.size == 0:
            return float("nan")
        lo, hi = self.nees_bounds
        return float(np.mean((self.nees >= lo) & (self.nees <= hi)))

    def nees_mean(self) -> float:
        """Mean NEES over the fix deliveries (3 for a consistent estimator of a planar pose; NaN: none)."""
        return float(np.mean(self.nees)) if self.nees.size else float("nan")


@dataclass(frozen=True, repr=False, eq=False)
class RunLog(ReadOnlyArrays):
    """What one run did, sampled at the log rate (at least the control rate).

    Checks itself on construction: every series has N rows (``t`` is (N,), N >= 1) and the stated
    columns (ValueError naming the series otherwise), and every value is finite (SimulationError:
    the run diverged). Its arrays are then read-only (:func:`freeze_arrays`), as the log is frozen; its
    repr is one short line (the series are read from the fields, or :meth:`arrays`).

    Attributes:
        t: (N,) times [s] (increasing, except where MuJoCo reset an unstable run and its clock).
        pose: (N, 3) true pose [x, y, theta] of the base at each time (theta unwrapped); the tracker
            itself sees the pose sensors.
        qpos: (N, nq) full generalised positions, for replay and rendering.
        ref_pose: (N, 3) reference pose at the same times.
        command: (N, 2) body command [v, omega] in force [m/s, rad/s].
        wheel_command: (N, 2) wheel speed command [left, right] [rad/s].
        wheel_speed: (N, 2) measured wheel speeds [rad/s].
        contacts: Robot-obstacle contacts (first sample of each touching spell).
        warnings: MuJoCo warnings raised during the run (empty on a clean run).
        meta: Robot, tracker, gains, rates, seed, trajectory name.
        estimation: What the estimator believed (None when the tracker saw the true pose).
        wheel_off_floor: (N,) whether a drive wheel was off the floor at each sample (None: the
            model has no wheel contact sensors).
        status: "ok", or why the run ended early (e.g. the estimator diverged, the robot fell).
        balance: A balancing robot's balance loop (None for the others).
    """

    t: FloatArray
    pose: FloatArray
    qpos: FloatArray
    ref_pose: FloatArray
    command: FloatArray
    wheel_command: FloatArray
    wheel_speed: FloatArray
    contacts: tuple[Contact, ...] = ()
    warnings: tuple[str, ...] = ()
    meta: dict[str, Any] = field(default_factory=dict)
    estimation: EstimationLog | None = None
    wheel_off_floor: NDArray[np.bool_] | None = None
    status: str = "ok"
    balance: BalanceLog | None = None

    def __post_init__(self) -> None:
        if self.t.ndim != 1 or self.t.size < 1:
            raise ValueError(f"RunLog.t must be (N,) with N >= 1 samples, got shape {self.t.shape}")
        n = self.t.size
        for name, a in self.arrays().items():
            width = WIDTHS[name]
            want = (n,) if width is None else (n, width or (a.shape[1] if a.ndim == 2 else -1))
            if a.shape != want:
                expected = "(N,)" if width is None else f"(N, {width or 'nq'})"
                raise ValueError(f"RunLog.{name} must be {expected} with N = {n} (the length of t), got {a.shape}")
            finite = np.isfinite(a).reshape(n, -1).all(axis=1)
            if not finite.all():
                k = int(np.argmin(finite))
                raise SimulationError(
                    f"RunLog.{name} is not finite at sample {k} (t = {self.t[k]:g} s): the run diverged"
                )

        if self.wheel_off_floor is not None and self.wheel_off_floor.shape != (n,):
            raise ValueError(f"RunLog.wheel_off_floor must be (N,) with N = {n}, got {self.wheel_off_floor.shape}")
        freeze_arrays(self)

    def __repr__(self) -> str:
        """One line: who ran what (the tracker, the trajectory and the robot, from :attr:`meta`), the samples, the
        time span and the status (cut at :data:`REPR_STATUS` characters)."""
        m = self.meta
        label = _cut(f"{m.get('tracker', '?')} on {m.get('trajectory', '?')}", 60)
        robot = f", {_cut(m['robot'], 40)}" if isinstance(m.get("robot"), str) else ""
        t0, t1 = float(self.t[0]), float(self.t[-1])
        said = _cut(self.status, REPR_STATUS)
        return f"RunLog({label!r}{robot}, {self.t.size} samples, t {t0:g}..{t1:g} s, status={said!r})"

    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def wheel_contact_loss_fraction(self) -> float:
        """Share of the logged physics steps with a drive wheel off the floor (0 without sensors)."""
        return 0.0 if self.wheel_off_floor is None else float(np.mean(self.wheel_off_floor))

    def arrays(self) -> dict[str, FloatArray]:
        """The numeric series by name (for comparisons and saving)."""
        return {name: getattr(self, name) for name in WIDTHS}

    def identical_to(self, other: RunLog) -> bool:
        """Bitwise equality of every series, the contacts and the warnings."""
        a, b = self.arrays(), other.arrays()
        for log, arrays in ((self, a), (other, b)):
            if log.estimation is not None:
                e = log.estimation
                arrays.update(est_estimate=e.estimate, est_variance=e.variance, est_fix=e.fix, est_nees=e.nees)
        return (
            a.keys() == b.keys()
            and all(a[k].shape == b[k].shape and a[k].tobytes() == b[k].tobytes() for k in a)
            and self.contacts == other.contacts
            and self.warnings == other.warnings
            and self.status == other.status
        )
