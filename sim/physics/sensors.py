"""Sensor models: wheel encoders, a yaw gyroscope, an accelerometer and a pose source, with noise.

MuJoCo reports true values (its ``noise=`` attribute is metadata only), so the errors a real
robot's sensors make are drawn here, from a seeded numpy generator, once for a whole run: the same
seed gives the same readings bit for bit.

A :class:`SensorProfile` holds one robot's numbers, read from ``models/sensors/<robot>.toml``
(each number cited there) and overridable by a TOML table (a scenario's or a file's
``[sensors]``) and by a ``key=value,...`` string (``nhsim simulate --sensors``), e.g.
``--sensors gyro_noise_density=0,fix_rate=10,fix_latency=0.05``.

A :class:`SensorModel` turns true values into readings, one control period ``k`` at a time:

- Encoders count ``floor(theta * cpr / (2 pi) + phase)`` for a wheel angle ``theta`` [rad], with a
  per-wheel phase drawn uniformly in [0, 1) counts (where the wheel sat in its count at start-up);
  :func:`encoder_count` is the one quantiser every encoder reading goes through, in Python and in
  compiled periods alike.
- The gyroscope reads ``omega + b_k + n_k`` [rad/s]. ``n_k`` is white with standard deviation
  ``gyro_noise_density * sqrt(control_rate / 2)``: datasheets quote a one-sided density (the
  MPU-9250's 0.01 deg/s/sqrt(Hz) times the square root of its 92 Hz filter bandwidth is its table's
  0.1 deg/s total RMS noise), and the reading stands for the mean rate over the control period
  (what the estimator integrates into heading), whose variance is the one-sided density squared
  times the Nyquist band ``control_rate / 2``. The bias starts at ``b_0 ~ N(0, gyro_bias_std^2)``
  and walks: ``b_{k+1} = b_k + gyro_bias_walk * sqrt(T) * N(0, 1)`` with ``T`` the control period,
  so its variance grows by ``gyro_bias_walk^2`` per second.
- The accelerometer reads the true 3-vector (specific force in the IMU frame [m/s^2]) plus a bias
  constant over the run, ``N(0, accel_bias_std^2)`` per axis, and white noise of standard deviation
  ``accel_noise_density * sqrt(control_rate / 2)``.
- Pose fixes (x, y, theta) are measured every ``control_rate / fix_rate`` control periods,
  starting at period 0 (that ratio must be a whole number, within 1e-6, and at least 1), with
  Gaussian noise of ``fix_position_std`` per axis and ``fix_heading_std`` [rad]; ``fix_rate = 0``
  means no pose source. A fix measured at period ``k`` is delivered at period ``k + d`` with
  ``d = ceil(fix_latency * control_rate)``: the estimator runs once per control period, so a fix
  that arrives between two periods is first used at the next one (a latency within 1e-6 periods of
  a whole number counts as that number). A fix delivered at period ``k`` is available to that
  period's estimate.

Each noise has its own stream spawned from ``np.random.SeedSequence(seed)``, so a longer run's
noise begins with a shorter run's. A robot with a second set of sensors read at another rate (the
balancing EduMIP's firmware reads its IMU and encoders at 200 Hz) draws that set's noise as
``part`` 1: stream ``i`` of part ``p`` is child ``p * len(STREAMS) + i`` of the same seed sequence,
so the parts are independent and part 0 is what it always was.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.estimation.kernels import wrap
from planning.core.checks import check_number
from planning.core.files import read_input_text
from planning.core.robot import SENSORS_DIR, robot_files
from planning.errors import ConfigError, option
from sim.physics.keyvalue import parse_number, parse_pairs
from sim.physics.motors import control_steps

if TYPE_CHECKING:
    import mujoco

FloatArray = NDArray[np.float64]


#: Field -> (lowest allowed, highest allowed, unit, a typical value quoted in messages).
LIMITS: dict[str, tuple[float, float, str, str]] = {
    "encoder_cpr": (1.0, 1e7, "counts per wheel revolution", "4096"),
    "gyro_noise_density": (0.0, 0.1, "rad/s/sqrt(Hz)", "2.6e-4"),
    "gyro_bias_walk": (0.0, 0.1, "rad/s^2/sqrt(Hz)", "4e-5"),
    "gyro_bias_std": (0.0, 1.0, "rad/s", "6e-4"),
    "accel_noise_density": (0.0, 1.0, "m/s^2/sqrt(Hz)", "2.3e-3"),
    "accel_bias_std": (0.0, 5.0, "m/s^2", "0.02"),
    "fix_rate": (0.0, 1000.0, "Hz, 0 for no pose source", "5"),
    "fix_position_std": (0.0, 1.0, "m", "0.02"),
    "fix_heading_std": (0.0, math.pi, "rad", "0.02"),
    "fix_latency": (0.0, 5.0, "s", "0.12"),
}

#: A valid ``--sensors`` text, quoted when a part is malformed.
EXAMPLE = "gyro_noise_density=0,fix_rate=10,fix_latency=0.05"

#: Relative tolerance for "a whole number of control periods" (fix period, latency).
WHOLE_TOL = 1e-6


def _setting(name: str, value: str, source: str | None) -> str:
    """How a sensor number is set where it was given: ``--sensors name=value`` on the command line (and
    ``sensors="name=value"`` from Python), or ``name = value`` in the ``[sensors]`` table of ``source`` (a
    scenario or settings file)."""
    return option("sensors", f"{name}={value}") if source is None else f"{name} = {value}"


def _in_table(source: str | None, name: str, message: str) -> str:
    """``message`` led by the file and the field (``FILE: field '[sensors] fix_rate': ...``) for a number
    of the ``[sensors]`` table of ``source``; as it is for the command line's (``source`` None)."""
    return message if source is None else f"{source}: field '[sensors] {name}': {message}"


def _check_field(name: str, value: object, source: str | None = None) -> float:
    lo, hi, unit, typical = LIMITS[name]
    fix = f"e.g. {_setting(name, typical, source)}"
    try:
        return check_number(f"sensor {name}", value, at_least=lo, at_most=hi, unit=unit, fix=fix)
    except ConfigError as exc:
        raise ConfigError(_in_table(source, name, str(exc))) from exc


def _check_table(table: Mapping[str, object], what: str, source: str | None = None) -> None:
    """Every key of ``table`` a sensor key and every value in its range; ``what`` leads the message of an
    unknown key when the table is not a file's (``source`` None)."""
    unknown = [k for k in table if k not in LIMITS]
    if unknown:
        said = f"unknown key {unknown[0]!r}; the sensor keys are {', '.join(LIMITS)} (see {SENSORS_DIR}/<robot>.toml)"
        raise ConfigError(_in_table(source, unknown[0], said) if source is not None else f"{what}: {said}")
    for name, value in table.items():
        _check_field(name, value, source)


@dataclass(frozen=True)
class SensorProfile:
    """One robot's sensor numbers (see the module docstring for what each does).

    Attributes:
        encoder_cpr: Encoder counts per wheel revolution [-] (need not be whole: a motor encoder
            behind a 35.577:1 gearbox gives 2134.62).
        gyro_noise_density: Gyroscope white noise, one-sided density [rad/s/sqrt(Hz)].
        gyro_bias_walk: Gyroscope bias random walk [rad/s^2/sqrt(Hz)].
        gyro_bias_std: Standard deviation of the gyroscope bias at start [rad/s].
        accel_noise_density: Accelerometer white noise, one-sided density [m/s^2/sqrt(Hz)].
        accel_bias_std: Standard deviation of the accelerometer bias, per axis [m/s^2].
        fix_rate: Pose fixes per second [Hz]; 0 for none.
        fix_position_std: Fix position noise per axis [m].
        fix_heading_std: Fix heading noise [rad].
        fix_latency: Delay from a fix's measurement to its delivery [s].
    """

    encoder_cpr: float
    gyro_noise_density: float
    gyro_bias_walk: float
    gyro_bias_std: float
    accel_noise_density: float
    accel_bias_std: float
    fix_rate: float
    fix_position_std: float
    fix_heading_std: float
    fix_latency: float

    def __post_init__(self) -> None:
        for name in LIMITS:
            object.__setattr__(self, name, _check_field(name, getattr(self, name)))

    @classmethod
    def from_table(cls, table: Mapping[str, object], what: str) -> SensorProfile:
        """A profile from a complete table (a profile file's ``[sensors]``).

        Args:
            table: Every key of :data:`LIMITS` with its number.
            what: Where the table comes from, for messages (the file's path).

        Raises:
            ConfigError: An unknown or missing key, or a bad value (naming the file and the field).
        """
        _check_table(table, what, what)
        missing = [k for k in LIMITS if k not in table]
        if missing:
            raise ConfigError(f"{what}: [sensors] lacks {', '.join(missing)}; give every key of {', '.join(LIMITS)}")
        values: dict[str, Any] = {k: table[k] for k in LIMITS}
        return cls(**values)

    def override(
        self, table: Mapping[str, object], what: str = "[sensors]", *, source: str | None = None
    ) -> SensorProfile:
        """This profile with the keys of ``table`` replaced (a scenario's or a file's ``[sensors]``).

        Args:
            table: Sensor keys and their numbers.
            what: How messages name the table when it is not a file's.
            source: The file (or scenario) whose ``[sensors]`` table it is: messages then name it and the
                field, and say how to set the number there.

        Raises:
            ConfigError: An unknown key or a bad value.
        """
        _check_table(table, what, source)
        values: dict[str, Any] = {**self.as_dict(), **table}
        return SensorProfile(**values)

    def parse(self, text: str) -> SensorProfile:
        """This profile with ``key=value,...`` (``--sensors``) applied; keys left out are kept.

        Raises:
            ConfigError: Unknown or repeated key, non-numeric or out-of-range value.
        """
        what = option("sensors", text)
        pairs = parse_pairs(text, what, LIMITS, EXAMPLE)
        return self.override({k: parse_number(v, k, what) for k, v in pairs.items()}, what)

    def as_dict(self) -> dict[str, float]:
        """Plain-dict view for records."""
        return asdict(self)


def sensor_profile_path(robot: str) -> Path:
    """The sensor settings file of a robot (:attr:`planning.core.robot.RobotFiles.sensors`: the built-in robots'
    are ``models/sensors/<robot>.toml``; the balancing EduMIP shares the EduMIP's).

    Raises:
        ConfigError: Unknown robot (the message lists the robots).
    """
    return robot_files(robot).sensors


#: The tables of a sensor settings file (``models/sensors/<robot>.toml``, and ``--sensors FILE`` in the same
#: layout): the sensor numbers, the laser scanner's settings (read by :mod:`sim.physics.lidar`) and, in a robot's
#: own file, its odometry's noise as the estimator models it (:data:`ESTIMATOR_KEYS`).
FILE_TABLES = ("sensors", "lidar", "estimator")
#: What a robot's ``[estimator]`` table may set (:class:`control.estimation.EstimatorConfig` fields that describe the
#: robot's odometry, not its sensors, which the profile gives, nor its builds, which its tolerances give).
ESTIMATOR_KEYS = ("wheel_noise", "position_noise", "cornering_slip_std", "max_odometry_drift")


def read_sensor_file(path: Path) -> dict[str, dict[str, Any]]:
    """The tables of a sensor settings file: ``[sensors]`` (its keys and values checked) and ``[lidar]``, each
    given only when the file has it.

    Raises:
        ConfigError: The file cannot be read or parsed, has neither table, has anything else (the message
            names it and what a file may hold), or a bad key or value in ``[sensors]`` (naming the field).
    """
    try:
        data = tomllib.loads(read_input_text(path))  # read once (a pipe cannot be read again); a BOM is dropped
    except UnicodeDecodeError as exc:
        raise ConfigError(f"cannot read sensor settings from {path}: not UTF-8 text; save it as UTF-8") from exc
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read sensor settings from {path}: {exc}") from exc
    allowed = (
        "a [sensors] table (sensor numbers), a [lidar] table (the laser scanner's settings, as --lidar) and, for a "
        f"robot's own file, an [estimator] table ({', '.join(ESTIMATOR_KEYS)})"
    )
    for key, value in data.items():
        if key not in FILE_TABLES:
            what = f"table [{key}]" if isinstance(value, dict) else f"key {key!r}"
            raise ConfigError(
                f"{path}: {what} is not understood here; a sensor settings file holds only {allowed}: move it into "
                "one of them, or remove it"
            )
        if not isinstance(value, dict):
            raise ConfigError(f"{path}: {key!r} must be a table ([{key}]), got {value!r}")
    if not data:
        raise ConfigError(f"{path} has no [sensors] table; add one with keys such as {EXAMPLE.replace(',', ', ')}")
    _check_table(data.get("sensors", {}), "[sensors]", str(path))
    for key, value in data.get("estimator", {}).items():
        if key not in ESTIMATOR_KEYS:
            raise ConfigError(
                f"{path}: field '[estimator] {key}': unknown key; the estimator keys are {', '.join(ESTIMATOR_KEYS)}"
            )
        check_number(f"{path}: field '[estimator] {key}'", value, at_least=0.0)
    return data


def robot_estimator_table(robot: str) -> dict[str, float]:
    """The ``[estimator]`` table of a robot's own sensor settings file (:func:`read_sensor_file`), {} without one.

    Raises:
        ConfigError: As :func:`read_sensor_file`.
    """
    return {k: float(v) for k, v in read_sensor_file(sensor_profile_path(robot)).get("estimator", {}).items()}


def read_sensor_table(path: Path) -> dict[str, Any]:
    """The ``[sensors]`` table of a sensor settings file (:func:`read_sensor_file`).

    Raises:
        ConfigError: As :func:`read_sensor_file`, or the file has no ``[sensors]`` table.
    """
    table = read_sensor_file(path).get("sensors")
    if table is None:
        raise ConfigError(f"{path} has no [sensors] table; add one with keys such as {EXAMPLE.replace(',', ', ')}")
    return table


def load_sensor_profile(
    robot: str,
    *,
    table: Mapping[str, object] | None = None,
    text: str | None = None,
    source: str | None = None,
    control_rate: float | None = None,
) -> SensorProfile:
    """A robot's sensor profile with its overrides applied: first ``table``, then ``text``.

    Args:
        robot: Registry name ("turtlebot3", "edumip").
        table: A ``[sensors]`` table (a scenario's, or :func:`read_sensor_table` of a file).
        text: ``key=value,...`` from ``--sensors``; it wins over ``table``.
        source: The file (or scenario) ``table`` comes from: its errors name it and the field.
        control_rate: The runs' control rate [Hz], when known: checked against the robot's physics step
            (:func:`sim.physics.motors.control_steps`), then the fix rate against it (:func:`fix_period`), its
            error said where the rate was set (``text``, ``table``'s ``source`` and field, or the robot's
            profile).

    Raises:
        ConfigError: No profile for the robot, or a bad key or value anywhere.
    """
    path = sensor_profile_path(robot)
    profile = SensorProfile.from_table(read_sensor_table(path), str(path))
    if table:
        profile = profile.override(table, source=source)
    if text:
        profile = profile.parse(text)
    if control_rate is not None:
        from sim.physics.model import robot_timestep

        control_steps(control_rate, robot_timestep(robot))  # first: a fix rate's advice assumes a rate that runs
        _check_fix_rate(robot, path, profile.fix_rate, control_rate, table, text, source)
    return profile


def _check_fix_rate(
    robot: str,
    path: Path,
    rate: float,
    control_rate: float,
    table: Mapping[str, object] | None,
    text: str | None,
    source: str | None,
) -> None:
    """:func:`fix_period` of the profile's fix rate, its error said where the rate was set: by ``--sensors``, by
    the ``[sensors]`` table of ``source``, or by the robot's own profile (at ``path``: the fix is an override on
    the command line, or a control rate its fixes divide)."""
    if text and "fix_rate" in parse_pairs(text, option("sensors", text), LIMITS, EXAMPLE):
        fix_period(rate, control_rate)
    elif table and "fix_rate" in table:
        fix_period(rate, control_rate, source)  # the table's rate: said where it was set
    else:
        try:
            fix_period(rate, control_rate)
        except ConfigError as exc:
            raise ConfigError(
                f"robot {robot!r} takes pose fixes at {rate:g} Hz (fix_rate in its sensor profile {path}), which a "
                f"control rate of {control_rate:g} Hz does not keep: {exc}; or give a control rate that is a multiple "
                f"of {rate:g} Hz ({option('control-rate')})"
            ) from None


@nb.njit(cache=True, inline="always")
def encoder_count(angle: float, counts_per_rad: float, phase: float) -> int:  # pragma: no cover - compiled
    """An encoder's count for a wheel angle: ``floor(angle * counts_per_rad + phase)``.

    Args:
        angle: The wheel's true angle [rad].
        counts_per_rad: The encoder's counts per radian, ``cpr / (2 pi)``.
        phase: Where the wheel sat in its count at start-up [counts], in [0, 1).
    """
    return math.floor(angle * counts_per_rad + phase)


def _whole(ratio: float) -> int | None:
    """``ratio`` as an int if it is one within :data:`WHOLE_TOL` (relative), else None."""
    k = round(ratio)
    return k if abs(ratio - k) <= WHOLE_TOL * max(1.0, abs(ratio)) else None


def latency_periods(latency: float, control_rate: float) -> int:
    """Control periods from a fix's measurement to its delivery: ``latency`` [s] rounded up to a period
    (a whole number of periods within :data:`WHOLE_TOL` as it is)."""
    periods = latency * control_rate
    return _whole(periods) or math.ceil(periods)


#: The noise streams, in the order they are spawned from ``np.random.SeedSequence(seed)``.
STREAMS = ("encoder_phase", "gyro_bias", "gyro_white", "gyro_walk", "accel_bias", "accel_white", "fix")


def _short(rate: float) -> bool:
    """True when ``f"{rate:g}"`` reads back as ``rate`` (a rate worth suggesting)."""
    return float(f"{rate:g}") == rate


def fix_period(rate: float, control_rate: float, source: str | None = None) -> int:
    """Control periods between two pose fixes at ``rate`` [Hz] (0 for no pose source), which must be a whole
    number of periods at ``control_rate`` [Hz] (within :data:`WHOLE_TOL`) and at least one.

    Args:
        rate: The fix rate [Hz].
        control_rate: The control rate [Hz].
        source: The file (or scenario) whose ``[sensors]`` table set the rate; None: the command line.

    Raises:
        ConfigError: A rate above the control rate, or one whose period is not whole (the message suggests
            rates that are, set where this one was).
    """
    if rate == 0.0:
        return 0
    ctrl = control_rate
    if rate > ctrl * (1.0 + WHOLE_TOL):
        said = (
            f"sensor fix_rate={rate:g} Hz is above the control rate {ctrl:g} Hz: a fix is taken at most once per "
            f"control period; lower it (e.g. {_setting('fix_rate', f'{ctrl:g}', source)}) or raise the control rate"
        )
        raise ConfigError(_in_table(source, "fix_rate", said))
    every = _whole(ctrl / rate)
    if every is None:
        ratio = ctrl / rate
        lower = next(ctrl / m for m in range(math.ceil(ratio), 10**6) if _short(ctrl / m))
        higher = next(ctrl / m for m in range(math.floor(ratio), 0, -1) if _short(ctrl / m))
        said = (
            f"sensor fix_rate={rate:g} Hz: its period is {ratio:.4g} control periods at {ctrl:g} Hz, not a whole "
            f"number; choose a rate that divides the control rate, {lower:g} or {higher:g} Hz, e.g. "
            f"{_setting('fix_rate', f'{lower:g}', source)}"
        )
        raise ConfigError(_in_table(source, "fix_rate", said))
    return every


def _readonly(a: NDArray[Any]) -> NDArray[Any]:
    a.setflags(write=False)
    return a


class SensorModel:
    """The readings of one run's sensors, all noise drawn at construction (see the module docstring).

    Args:
        profile: The sensor numbers.
        control_rate: Control periods per second [Hz]; readings are per control period.
        timestep: Physics time step [s]; the control period must be a whole number of steps.
        n_periods: Control periods in the run (``k = 0 .. n_periods - 1``).
        seed: Seed of the noise (an integer >= 0).
        part: Which of the robot's sensor sets (0: the base's, read at the control rate; 1: a
            balancing robot's firmware IMU and encoders); each part's noise is independent.

    Attributes:
        steps_per_control: Physics steps per control period.
        fix_every: Control periods between fixes (0 without a pose source).
        fix_latency_periods: Control periods from a fix's measurement to its delivery.
        gyro_white_std: Standard deviation of the gyroscope's white noise per reading [rad/s].
        accel_white_std: Standard deviation of the accelerometer's white noise per reading [m/s^2].
        encoder_phase: (2,) left and right encoder phase at start [counts], in [0, 1).
        gyro_bias: (n_periods,) gyroscope bias per period [rad/s].
        gyro_white: (n_periods,) gyroscope white noise per period [rad/s].
        gyro_error: (n_periods,) their sum, the gyroscope's error per period [rad/s].
        accel_bias: (3,) accelerometer bias [m/s^2].
        accel_white: (n_periods, 3) accelerometer white noise per period [m/s^2].
        fix_periods: (M,) periods at which fixes are measured.
        fix_delivery_periods: (M,) periods at which they are delivered (may be past the run).
        fix_noise: (M, 3) noise [dx, dy, dtheta] of each fix [m, m, rad].
    """

    def __init__(
        self,
        profile: SensorProfile,
        *,
        control_rate: float,
        timestep: float,
        n_periods: int,
        seed: int,
        part: int = 0,
    ) -> None:
        self.profile = profile
        self.control_rate = check_number("control rate", control_rate, above=0.0, unit="Hz")
        self.timestep = check_number("physics timestep", timestep, above=0.0, unit="s")
        once, seeded = "a run has at least one", "pass a whole number such as seed=0"
        self.n_periods = check_number("number of control periods", n_periods, integer=True, at_least=1, fix=once)
        self.seed = check_number("sensor noise seed", seed, integer=True, at_least=0, fix=seeded)
        parts = "0 for the base's sensors, 1 for a balancing robot's firmware"
        self.part = check_number("sensor part", part, integer=True, at_least=0, fix=parts)
        self.steps_per_control = control_steps(self.control_rate, self.timestep)
        self.fix_every = fix_period(self.profile.fix_rate, self.control_rate)
        self.fix_latency_periods = latency_periods(self.profile.fix_latency, self.control_rate)
        self.gyro_white_std = profile.gyro_noise_density * math.sqrt(self.control_rate / 2.0)
        self.accel_white_std = profile.accel_noise_density * math.sqrt(self.control_rate / 2.0)
        self._draw()

    def _draw(self) -> None:
        p, n = self.profile, self.n_periods
        n_streams = len(STREAMS)
        children = np.random.SeedSequence(self.seed).spawn(n_streams * (self.part + 1))[n_streams * self.part :]
        rng = {name: np.random.default_rng(child) for name, child in zip(STREAMS, children, strict=True)}
        self.encoder_phase = _readonly(rng["encoder_phase"].random(2))
        walk = rng["gyro_walk"].standard_normal(n) * (p.gyro_bias_walk * math.sqrt(1.0 / self.control_rate))
        b0 = float(rng["gyro_bias"].standard_normal()) * p.gyro_bias_std
        self.gyro_bias = _readonly(b0 + np.concatenate(([0.0], np.cumsum(walk[: n - 1]))))
        self.gyro_white = _readonly(rng["gyro_white"].standard_normal(n) * self.gyro_white_std)
        self.accel_bias = _readonly(rng["accel_bias"].standard_normal(3) * p.accel_bias_std)
        self.accel_white = _readonly(rng["accel_white"].standard_normal((n, 3)) * self.accel_white_std)
        every = self.fix_every
        self.fix_periods = _readonly(np.arange(0, n, every, dtype=np.int64) if every else np.zeros(0, np.int64))
        self.fix_delivery_periods = _readonly(self.fix_periods + self.fix_latency_periods)
        scale = np.array([p.fix_position_std, p.fix_position_std, p.fix_heading_std])
        self.fix_noise = _readonly(rng["fix"].standard_normal((len(self.fix_periods), 3)) * scale)
        self.gyro_error = _readonly(self.gyro_bias + self.gyro_white)
        self._gyro_error = self.gyro_error.tolist()
        self._accel_error = _readonly(self.accel_bias + self.accel_white)
        self._counts_per_turn = p.encoder_cpr / (2.0 * math.pi)

    def _period(self, k: int) -> int:
        if not 0 <= k < self.n_periods:
            raise IndexError(f"control period {k} is outside the run's 0 .. {self.n_periods - 1}")
        return k

    def encoder_counts(self, left: float, right: float) -> tuple[int, int]:
        """Encoder counts for true wheel angles [rad]: ``floor(theta * cpr / (2 pi) + phase)``."""
        c, ph = self._counts_per_turn, self.encoder_phase
        return encoder_count(left, c, float(ph[0])), encoder_count(right, c, float(ph[1]))

    def longer(self, n_periods: int) -> SensorModel:
        """The same sensors over a run of ``n_periods`` periods (its noise begins with this one's)."""
        return SensorModel(self.profile, control_rate=self.control_rate, timestep=self.timestep,
                           n_periods=n_periods, seed=self.seed, part=self.part)  # fmt: skip

    def gyro(self, k: int, rate: float) -> float:
        """Gyroscope reading at period ``k`` for a true rate [rad/s] about its axis: ``rate + (b_k + n_k)``."""
        return rate + self._gyro_error[self._period(k)]

    def accel(self, k: int, specific_force: NDArray[np.float64]) -> NDArray[np.float64]:
        """(3,) accelerometer reading at period ``k`` for a true (3,) specific force [m/s^2]."""
        return np.asarray(specific_force, dtype=float) + self._accel_error[self._period(k)]

    def is_fix_period(self, k: int) -> bool:
        """True when a fix is measured at period ``k``."""
        return self.fix_every > 0 and self._period(k) % self.fix_every == 0

    def fix(self, k: int, pose: tuple[float, float, float]) -> tuple[float, float, float]:
        """The noisy fix of the true pose (x, y, theta) [m, m, rad] measured at period ``k``.

        The heading is wrapped to [-pi, pi].

        Raises:
            ValueError: No fix is measured at ``k``.
        """
        if not self.is_fix_period(k):
            raise ValueError(f"no fix is measured at control period {k} (fixes every {self.fix_every} periods)")
        dx, dy, dth = self.fix_noise[k // self.fix_every]
        return pose[0] + float(dx), pose[1] + float(dy), math.remainder(pose[2] + float(dth), 2.0 * math.pi)

    def fix_arriving(self, k: int) -> int | None:
        """The period whose fix is delivered at period ``k``, or None (at most one fix arrives)."""
        j = self._period(k) - self.fix_latency_periods
        return j if j >= 0 and self.fix_every > 0 and j % self.fix_every == 0 else None

    def as_dict(self) -> dict[str, Any]:
        """Plain-dict view for records: the profile, the run's settings and the derived numbers."""
        return {
            "profile": self.profile.as_dict(),
            "control_rate_hz": self.control_rate,
            "timestep_s": self.timestep,
            "n_periods": self.n_periods,
            "seed": self.seed,
            "part": self.part,
            "steps_per_control": self.steps_per_control,
            "fix_every_periods": self.fix_every,
            "fix_latency_periods": self.fix_latency_periods,
            "fix_latency_effective_s": self.fix_latency_periods / self.control_rate,
            "gyro_white_std": self.gyro_white_std,
            "accel_white_std": self.accel_white_std,
            "encoder_phase": self.encoder_phase.tolist(),
        }


#: The record of a run's encoder and gyroscope reading (:func:`read_period`): the last counts and
#: true heading [rad], then constants: the period [s], counts per radian, the encoders' phases
#: [counts] and their addresses in ``MjData.sensordata``.
READER_STATE = np.dtype(
    [("counts", np.int64, (2,)), ("yaw", np.float64), ("dt", np.float64), ("per_rad", np.float64),
     ("phase", np.float64, (2,)), ("encoder", np.int64, (2,))]
)  # fmt: skip


@nb.njit(cache=True)
def read_period(
    k: int, yaw: float, sdata: FloatArray, state: NDArray[np.void], gyro_error: FloatArray
) -> tuple[int, int, float]:  # pragma: no cover - compiled
    """The wheel encoders and the gyroscope at control period ``k``: each encoder's count
    (:func:`encoder_count` of its angle in ``sdata``) and the gyro's reading, the mean true yaw rate
    over the period (the change of the true heading ``yaw`` [rad] since the last reading, wrapped,
    over the period) plus its error ``gyro_error[k]`` [rad/s]. ``state`` is a (1,) array of
    :data:`READER_STATE`; the counts and the heading are kept in it for the next period.

    Returns:
        (left count, right count, gyro reading [rad/s]).
    """
    s = state[0]
    enc, phase, counts = s.encoder, s.phase, s.counts
    left = encoder_count(sdata[enc[0]], s.per_rad, phase[0])
    right = encoder_count(sdata[enc[1]], s.per_rad, phase[1])
    rate = wrap(yaw - s.yaw) / s.dt
    counts[0], counts[1], s.yaw = left, right, yaw
    return left, right, rate + gyro_error[k]


class SensorReader:
    """A run's wheel encoders and yaw gyroscope, read from its ``MjData`` once per control period
    with the noise of its :class:`SensorModel` (the gyro reads the mean yaw rate over the period, as
    an IMU's delta-angle output does). The simulator's sensing and the control-suite environment
    read through it.

    Args:
        model: The run's compiled model (named sensors ``wheel_left_pos`` and ``wheel_right_pos``).
        sensors: The run's noise draws (its control rate is the period's).
    """

    def __init__(self, model: mujoco.MjModel, sensors: SensorModel) -> None:
        self.sensors = sensors
        self._state = np.zeros(1, READER_STATE)
        s = self._state[0]
        s["dt"] = 1.0 / sensors.control_rate
        s["per_rad"] = sensors.profile.encoder_cpr / (2.0 * math.pi)
        s["phase"] = sensors.encoder_phase
        adr = model.sensor_adr
        s["encoder"] = [int(adr[model.sensor(name).id]) for name in ("wheel_left_pos", "wheel_right_pos")]
        self._gyro_error = np.array(sensors.gyro_error)  # writable: one compiled signature for every run
        self._sdata: FloatArray | None = None
        self.counts: NDArray[np.int64] = self._state["counts"][0]  # a view: the last counts (left, right)

    def start(self, data: mujoco.MjData, yaw: float) -> tuple[int, int, float]:
        """Bind the run's data and read period 0 at the true heading ``yaw`` [rad] (the gyro reads
        its error alone: no heading change before the run).

        Raises:
            ValueError: The reader was started on another ``MjData`` (a run reads one).
        """
        if self._sdata is not None and data.sensordata is not self._sdata:
            raise ValueError("a run's periods must all read the MjData of its period 0; make a reader per run")
        self._sdata = data.sensordata
        self._state[0]["yaw"] = yaw
        return self.read(0, yaw)

    def read(self, k: int, yaw: float) -> tuple[int, int, float]:
        """(left count, right count, gyro reading [rad/s]) at control period ``k`` (:func:`read_period`),
        the true heading then being ``yaw`` [rad].

        Raises:
            IndexError: ``k`` is outside the run's periods.
            ValueError: The reader was not started.
        """
        if not 0 <= k < self.sensors.n_periods:
            raise IndexError(f"control period {k} is outside the run's 0 .. {self.sensors.n_periods - 1}")
        if self._sdata is None:
            raise ValueError("start the reader on the run's MjData before reading (SensorReader.start)")
        return read_period(k, yaw, self._sdata, self._state, self._gyro_error)
