"""A 2-D laser scanner (the TurtleBot3's LDS-01) cast in MuJoCo with ``mj_multiRay``.

The scanner turns at ``rate`` revolutions per second and takes ``beams`` samples a revolution, evenly
``360 / beams`` degrees apart (1 deg at the LDS-01's 360; 51.4 deg at 7),
counter-clockwise from the ``lidar`` site's x axis (the ROBOTIS ``base_scan`` frame), one every
``1 / (rate * beams)`` seconds: beam ``i`` of a revolution that starts at ``t0`` is measured at
``t0 + i / (rate * beams)`` from the pose the robot had then. A turning or driving robot's scan
is therefore skewed, as a real one is. The scene's obstacles and walls are static, so a beam can
be cast after the fact from any earlier pose: the simulator keeps the true poses of a revolution
and casts the whole revolution when it is complete (:meth:`LidarScanner.scan`).

Casting: beams are grouped into batches no longer than ``batch_time`` (10 ms, 18 beams, by default;
a call costs about 9 us however few its rays); each batch is one ``mujoco.mj_multiRay`` call from
the lidar's position at the batch's middle beam, each ray along its own beam's direction at its
own instant (the origin of a beam is off by at most the distance travelled in half a batch,
1 mm at 0.21 m/s, a tenth of the scanner's precision). The robot's
own geoms are excluded by ``bodyexclude`` (its root body, which carries the chassis and the
scanner's housing); the constructor checks that no other body of the robot reaches the scan plane.

Noise (from the run's noise seed; :data:`STREAMS`): the datasheet's accuracy is the band a unit's
systematic (calibration) error lies in, drawn once per run as every as-built tolerance is
(:mod:`sim.physics.asbuilt`): ``u_near * accuracy_near`` below ``accuracy_split`` and ``u_far *
accuracy_far * r`` above, ``u`` a standard normal clipped at ``CLIP_SIGMAS`` and divided by it, so
the band is three standard deviations wide and no unit leaves it; its precision is white Gaussian
noise of standard deviation ``precision_near`` or ``precision_far * r`` per return.

Ranges follow REP 117 (``sensor_msgs/LaserScan``): a return measured below ``range_min`` reads
``-inf``, nothing within ``range_max`` reads ``+inf``; NaN is never produced (the scene has no
invalid returns).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from planning.core.checks import check_number
from planning.errors import ConfigError, ModelError, option
from sim.physics.asbuilt import CLIP_SIGMAS
from sim.physics.keyvalue import parse_number, parse_pairs
from sim.physics.sensors import sensor_profile_path

FloatArray = NDArray[np.float64]

#: Datasheet limits of the LDS-01 (ROBOTIS e-Manual, LDS-01 appendix): field -> (lowest, highest, unit). The
#: accuracy and precision figures are bounds a unit within its datasheet meets: from 0 (a calibrated or noise-free
#: unit) up to the datasheet's figure; a larger one would be another scanner.
LIMITS: dict[str, tuple[float, float, str]] = {
    "beams": (1, 360, "samples a revolution; the LDS-01 takes 360 at 1 deg"),
    "rate": (290.0 / 60.0, 310.0 / 60.0, "Hz; the LDS-01 turns at 300 +- 10 rpm"),
    "range_min": (0.12, 3.5, "m; the LDS-01 measures 0.12-3.5 m"),
    "range_max": (0.12, 3.5, "m; the LDS-01 measures 0.12-3.5 m"),
    "accuracy_near": (0.0, 0.015, "m; the LDS-01 is accurate to 15 mm below 0.5 m, 0 a calibrated unit"),
    "accuracy_far": (0.0, 0.05, "fraction of the range; the LDS-01 is accurate to 5 % from 0.5 m, 0 a calibrated unit"),
    "precision_near": (0.0, 0.01, "m; the LDS-01's precision is 10 mm below 0.5 m, 0 a noise-free unit"),
    "precision_far": (0.0, 0.035, "fraction of the range; the LDS-01's precision is 3.5 % from 0.5 m, 0 noise-free"),
    "accuracy_split": (0.5, 0.5, "m; the LDS-01's figures change from absolute to relative at 0.5 m"),
}

#: Longest time spanned by the beams of one ``mj_multiRay`` call [s].
BATCH_TIME = 0.01
#: Height of the TurtleBot3's LDS-01 scan plane above the floor [m] (its ``lidar`` site in the MJCF, which
#: :attr:`LidarScanner.height` reads; ``tests/test_lidar.py`` checks they agree): an obstacle no taller is not
#: in the scan (:meth:`planning.core.world.World.seen_at`).
LDS01_PLANE = 0.182
#: A valid ``--lidar`` text, quoted when a part is malformed.
EXAMPLE = "beams=180,precision_far=0"

#: The noise streams, spawned in this order from ``np.random.SeedSequence([seed, LIDAR_KEY])``.
STREAMS = ("lidar_accuracy", "lidar_precision")
#: Second entropy word of the scanner's seed sequence, so its streams are not the other sensors'.
LIDAR_KEY = 0x11DA


@dataclass(frozen=True)
class LidarProfile:
    """A scanner's settings (see the module docstring and ``models/sensors/turtlebot3.toml``).

    Attributes:
        beams: Samples a revolution [-].
        rate: Revolutions per second [Hz].
        range_min: Shortest range measured [m].
        range_max: Longest range measured [m].
        accuracy_near: Bound of the systematic error below ``accuracy_split`` [m].
        accuracy_far: Bound of the systematic error from ``accuracy_split``, relative [-].
        precision_near: Standard deviation of the white noise below ``accuracy_split`` [m].
        precision_far: Standard deviation of the white noise from ``accuracy_split``, relative [-].
        accuracy_split: Range where the figures change from absolute to relative [m].
    """

    beams: int = 360
    rate: float = 5.0
    range_min: float = 0.12
    range_max: float = 3.5
    accuracy_near: float = 0.015
    accuracy_far: float = 0.05
    precision_near: float = 0.01
    precision_far: float = 0.035
    accuracy_split: float = 0.5

    def __post_init__(self) -> None:
        for name, (lo, hi, unit) in LIMITS.items():
            fix = f"give a value in [{lo:g}, {hi:g}], e.g. {option('lidar', f'{name}={getattr(LidarProfile, name)}')}"
            value = check_number(f"lidar {name}", getattr(self, name), at_least=lo, at_most=hi, unit=unit, fix=fix)
            object.__setattr__(self, name, value)
        if self.beams != int(self.beams):
            raise ConfigError(
                f"lidar beams must be a whole number, got {self.beams!r}; e.g. {option('lidar', 'beams=360')}"
            )
        object.__setattr__(self, "beams", int(self.beams))
        if self.range_min >= self.range_max:
            raise ConfigError(
                f"lidar range_min={self.range_min:g} m must be below range_max={self.range_max:g} m; "
                "the LDS-01 measures 0.12-3.5 m"
            )

    @property
    def period(self) -> float:
        """Time of one revolution [s]."""
        return 1.0 / self.rate

    @property
    def time_increment(self) -> float:
        """Time between two beams [s]."""
        return 1.0 / (self.rate * self.beams)

    @property
    def angle_increment(self) -> float:
        """Angle between two beams [rad]."""
        return 2.0 * math.pi / self.beams

    def override(self, table: Mapping[str, object], what: str = "[lidar]") -> LidarProfile:
        """This profile with the keys of ``table`` replaced.

        Raises:
            ConfigError: An unknown key or a value outside the datasheet.
        """
        unknown = [k for k in table if k not in LIMITS]
        if unknown:
            raise ConfigError(f"{what}: unknown key {unknown[0]!r}; the lidar keys are {', '.join(LIMITS)}")
        values: dict[str, Any] = {**asdict(self), **table}
        return LidarProfile(**values)

    def parse(self, text: str) -> LidarProfile:
        """This profile with ``key=value,...`` (``--lidar``) applied.

        Raises:
            ConfigError: Unknown or repeated key, non-numeric or out-of-range value.
        """
        what = option("lidar", text)
        pairs = parse_pairs(text, what, LIMITS, EXAMPLE)
        return self.override({k: parse_number(v, k, what) for k, v in pairs.items()}, what)

    def as_dict(self) -> dict[str, float]:
        """Plain-dict view for records."""
        return asdict(self)


def load_lidar_profile(robot: str, *, text: str | None = None) -> LidarProfile | None:
    """A robot's scanner settings (the ``[lidar]`` table of its sensor profile), or None without one.

    Args:
        robot: Registry name.
        text: ``key=value,...`` from ``--lidar``.

    Raises:
        ConfigError: A bad key or value, or ``text`` given for a robot without a scanner.
    """
    path = sensor_profile_path(robot)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read the scanner settings from {path}: {exc}") from exc
    table = data.get("lidar")
    if table is None:
        if text:
            drop = option("lidar", python='lidar=""')
            raise ConfigError(
                f"robot {robot!r} has no laser scanner ({path} has no [lidar] table); drop {drop} (and a [lidar] "
                "table from the --sensors file)"
            )
        return None
    if not isinstance(table, dict):
        raise ConfigError(f"{path}: [lidar] must be a table")
    profile = LidarProfile().override(table, f"{path} [lidar]")
    return profile.parse(text) if text else profile


@dataclass(frozen=True)
class Scan:
    """One revolution, laid out as ``sensor_msgs/LaserScan``.

    Attributes:
        stamp: Time of the first beam [s].
        angle_min: Bearing of the first beam in the scanner's frame [rad] (0).
        angle_increment: Bearing step [rad].
        time_increment: Time between beams [s].
        scan_time: Time of a revolution [s].
        range_min: Shortest range measured [m].
        range_max: Longest range measured [m].
        ranges: (beams,) ranges [m]; -inf below range_min, +inf beyond range_max (REP 117).
    """

    stamp: float
    angle_min: float
    angle_increment: float
    time_increment: float
    scan_time: float
    range_min: float
    range_max: float
    ranges: FloatArray

    @property
    def bearings(self) -> FloatArray:
        """(beams,) bearing of each beam in the scanner's frame [rad]."""
        return np.asarray(self.angle_min + self.angle_increment * np.arange(self.ranges.size), dtype=float)

    @property
    def times(self) -> FloatArray:
        """(beams,) time of each beam [s]."""
        return np.asarray(self.stamp + self.time_increment * np.arange(self.ranges.size), dtype=float)


def _other_bodies_below(model: mujoco.MjModel, root: int, height: float) -> None:
    """Raise ValueError if a geom of the robot outside its root body reaches the scan plane at rest."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        if b != root and int(model.body_rootid[b]) == root:
            top = data.geom_xpos[g, 2] + model.geom_rbound[g]
            if top >= height:
                name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
                raise ValueError(f"geom {name!r} of the robot reaches the scan plane; bodyexclude would not skip it")


def _unit_draws(seed: int) -> tuple[tuple[float, float], np.random.Generator]:
    """A run's scanner unit from its noise seed: its systematic errors as fractions of the datasheet's accuracy
    (near, far; each within [-1, 1]) and the generator of its white noise (:data:`STREAMS`)."""
    seq = np.random.SeedSequence([int(seed), LIDAR_KEY]).spawn(len(STREAMS))
    accuracy, precision = (np.random.default_rng(s) for s in seq)
    near, far = (float(v) for v in np.clip(accuracy.standard_normal(2), -CLIP_SIGMAS, CLIP_SIGMAS) / CLIP_SIGMAS)
    return (near, far), precision


def unit_errors(profile: LidarProfile, seed: int) -> dict[str, float]:
    """The systematic range errors of the unit a run with noise seed ``seed`` has (the draw
    :class:`LidarScanner` makes): ``offset_near_m``, added below ``accuracy_split`` [m], and ``scale_far``, the
    relative error from it [-] (the run record's ``localiser.lidar_unit``)."""
    (near, far), _ = _unit_draws(seed)
    return {"offset_near_m": near * profile.accuracy_near, "scale_far": far * profile.accuracy_far}


class LidarScanner:
    """Casts a scanner's revolutions in a compiled model (see the module docstring).

    Args:
        model: The compiled model (robot and world).
        profile: The scanner's settings.
        seed: The run's noise seed.
        site: Name of the scanner's site.
        batch_time: Longest time spanned by one ``mj_multiRay`` call [s].
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        profile: LidarProfile,
        seed: int,
        *,
        site: str = "lidar",
        batch_time: float = BATCH_TIME,
    ) -> None:
        self.model = model
        self.profile = profile
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        if sid < 0:
            raise ModelError(
                f"the robot has a laser scanner (a [lidar] table in its sensor settings) but its model has no site "
                f"{site!r}, where the scan plane is: give one on the scanner's body, as models/robots/"
                "turtlebot3_burger.xml does, or drop the [lidar] table"
            )
        self.root = int(model.body_rootid[model.site_bodyid[sid]])
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        rot = data.xmat[self.root].reshape(3, 3)
        #: Offset of the scanner from the root body's frame, in that frame at rest [m] (3,).
        self.offset = rot.T @ (data.site_xpos[sid] - data.xpos[self.root])
        self.height = float(data.site_xpos[sid, 2])
        _other_bodies_below(model, self.root, self.height)
        self.batch = max(1, int(batch_time / profile.time_increment + 1e-9))
        (self.bias_near, self.bias_far), self._precision = _unit_draws(seed)
        self._geomgroup = np.ones(6, dtype=np.uint8)
        n = profile.beams
        self._geomid = np.empty(n, dtype=np.int32)
        self._dist = np.empty(n)
        self._vec = np.zeros((n, 3))
        self._heading = profile.angle_increment * np.arange(n)
        # each batch's beams: (its middle beam, its rays' directions, their geom ids and distances: views, written
        # in place by each revolution's cast)
        self._batches = [
            ((a + b - 1) // 2, self._vec[a:b].reshape(-1), self._geomid[a:b], self._dist[a:b], b - a)
            for a, b in ((a, min(n, a + self.batch)) for a in range(0, n, self.batch))
        ]

    def origins(self, poses: FloatArray) -> FloatArray:
        """(N, 3) scanner positions for (N, 3) planar poses (x, y, theta) of the robot's base [m]."""
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        ox, oy = self.offset[0], self.offset[1]
        return np.column_stack(
            [poses[:, 0] + c * ox - s * oy, poses[:, 1] + s * ox + c * oy, np.full(len(poses), self.height)]
        )

    def cast(self, data: mujoco.MjData, poses: FloatArray) -> FloatArray:
        """True distances of one revolution's beams, each from its own pose [m].

        Args:
            data: Data whose static geoms are placed (after any ``mj_step`` or ``mj_kinematics``).
            poses: (beams, 3) pose of the robot's base at each beam's instant (x, y, theta).

        Returns:
            (beams,) distance to the first surface along each beam, +inf if none within range_max
            plus a margin.
        """
        n = self.profile.beams
        if poses.shape != (n, 3):
            raise ValueError(f"poses must have shape ({n}, 3), got {poses.shape}")
        origin = self.origins(poses)
        heading = poses[:, 2] + self._heading
        vec = self._vec
        vec[:, 0], vec[:, 1] = np.cos(heading), np.sin(heading)
        cutoff, model, group, root, ray = 2.0 * self.profile.range_max, self.model, self._geomgroup, self.root, 1
        for middle, rays, geomid, dist, count in self._batches:
            mujoco.mj_multiRay(model, data, origin[middle], rays, group, ray, root, geomid, dist, None, count, cutoff)
        out = self._dist.copy()
        out[self._geomid < 0] = np.inf
        return out

    def measure(self, true_ranges: FloatArray) -> FloatArray:
        """Readings of one revolution: accuracy and precision errors added, REP 117 out-of-range values.

        Draws the revolution's white noise from the run's stream (call once per revolution, in order).

        Args:
            true_ranges: (beams,) true distances [m], +inf for no surface.

        Returns:
            (beams,) ranges [m]; -inf below range_min, +inf beyond range_max.
        """
        p = self.profile
        r = np.asarray(true_ranges, dtype=float)
        noise = self._precision.standard_normal(r.size)
        finite = np.isfinite(r)
        rr = np.where(finite, r, 0.0)
        near = rr < p.accuracy_split
        bias = np.where(near, self.bias_near * p.accuracy_near, self.bias_far * p.accuracy_far * rr)
        sigma = np.where(near, p.precision_near, p.precision_far * rr)
        z = rr + bias + sigma * noise
        out = np.where(z > p.range_max, np.inf, np.where(z < p.range_min, -np.inf, z))
        return np.where(finite, out, np.inf)

    def scan(self, data: mujoco.MjData, stamp: float, poses: FloatArray) -> Scan:
        """One revolution measured: :meth:`cast` then :meth:`measure`.

        Args:
            data: Data whose static geoms are placed.
            stamp: Time of the first beam [s].
            poses: (beams, 3) pose of the robot's base at each beam's instant.
        """
        p = self.profile
        return Scan(
            stamp=float(stamp),
            angle_min=0.0,
            angle_increment=p.angle_increment,
            time_increment=p.time_increment,
            scan_time=p.period,
            range_min=p.range_min,
            range_max=p.range_max,
            ranges=self.measure(self.cast(data, poses)),
        )


def beam_poses(t: FloatArray, poses: FloatArray, times: FloatArray) -> FloatArray:
    """Poses at beam instants, interpolated linearly (heading unwrapped) between logged poses.

    Args:
        t: (M,) increasing times of the logged poses [s].
        poses: (M, 3) logged poses (x, y, theta).
        times: (N,) beam instants within [t[0], t[-1]] [s].

    Returns:
        (N, 3) poses.
    """
    steps = np.remainder(np.diff(poses[:, 2]) + np.pi, 2.0 * np.pi) - np.pi  # unwrapped heading steps
    th = poses[0, 2] + np.concatenate(([0.0], np.cumsum(steps)))
    out = np.empty((times.size, 3))
    out[:, 0] = np.interp(times, t, poses[:, 0])
    out[:, 1] = np.interp(times, t, poses[:, 1])
    out[:, 2] = np.interp(times, t, th)
    return out
