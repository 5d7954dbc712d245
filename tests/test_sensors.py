"""Sensor models: profiles and their overrides, quantisation, noise statistics, fix schedule, seeds.

Statistical checks draw long runs and compare with the profile's numbers within a stated number of
standard errors of the estimate, so a wrong scale (a missing factor of two, sqrt(rate) for
sqrt(rate / 2)) fails them.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

from planning.errors import ConfigError
from sim.physics.model import rolling_radius
from sim.physics.sensors import (
    LIMITS,
    SensorModel,
    SensorProfile,
    load_sensor_profile,
    read_sensor_file,
    read_sensor_table,
    sensor_profile_path,
)

TB3 = load_sensor_profile("turtlebot3")
QUIET = replace(TB3, gyro_noise_density=0.0, gyro_bias_walk=0.0, gyro_bias_std=0.0)


def _model(profile: SensorProfile = TB3, *, rate: float = 50.0, n: int = 100, seed: int = 7) -> SensorModel:
    return SensorModel(profile, control_rate=rate, timestep=0.002, n_periods=n, seed=seed)


# --- profiles ---------------------------------------------------------------------------------


def test_profiles_hold_the_cited_encoder_resolutions() -> None:
    assert TB3.encoder_cpr == 4096.0  # XL430-W250: 4096 pulses per output-shaft turn
    assert load_sensor_profile("edumip").encoder_cpr == pytest.approx(60 * 35.577, abs=1e-9)  # ENCODER_RES x GEARBOX
    for robot in ("turtlebot3", "edumip"):
        table = read_sensor_table(sensor_profile_path(robot))
        assert sorted(table) == sorted(LIMITS)  # every field given, none extra


def test_overrides_apply_table_then_text_and_keep_the_rest() -> None:
    p = load_sensor_profile("turtlebot3", table={"fix_rate": 10, "fix_latency": 0.2}, text="fix_latency=0.05")
    assert (p.fix_rate, p.fix_latency) == (10.0, 0.05)  # the text wins over the table
    assert replace(p, fix_rate=TB3.fix_rate, fix_latency=TB3.fix_latency) == TB3
    assert TB3.parse("") == TB3 and TB3.override({}) == TB3
    assert TB3.parse("gyro_noise_density=0,fix_rate=10,fix_latency=0.05").gyro_noise_density == 0.0
    assert TB3.as_dict()["encoder_cpr"] == 4096.0


def test_a_file_sensors_table_overrides(tmp_path: Path) -> None:
    f = tmp_path / "s.toml"
    f.write_text("[sensors]\nfix_position_std = 0.001\n", encoding="utf-8")
    assert load_sensor_profile("edumip", table=read_sensor_table(f)).fix_position_std == 0.001
    f.write_text("", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"no \[sensors\] table"):
        read_sensor_table(f)
    f.write_text("[sensors\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="cannot read"):
        read_sensor_table(f)


def test_a_settings_file_holds_a_sensors_and_a_lidar_table_and_nothing_else(tmp_path: Path) -> None:
    """A ``--sensors FILE`` is laid out as a profile: its ``[lidar]`` table is read, anything else refused."""
    f = tmp_path / "mine.toml"
    f.write_text(sensor_profile_path("turtlebot3").read_text(encoding="utf-8").replace("beams = 360", "beams = 3"))
    tables = read_sensor_file(f)
    assert tables["lidar"]["beams"] == 3 and tables["sensors"] == read_sensor_table(sensor_profile_path("turtlebot3"))
    f.write_text("[lidar]\nbeams = 90\n", encoding="utf-8")
    assert read_sensor_file(f) == {"lidar": {"beams": 90}}
    for text, what in (("[sensors]\n[lidr]\nbeams = 3\n", "table [lidr]"), ("fix_rate = 5\n", "key 'fix_rate'")):
        f.write_text(text, encoding="utf-8")
        with pytest.raises(ConfigError) as err:
            read_sensor_file(f)
        assert str(err.value).startswith(f"{f}: {what} is not understood here; a sensor settings file holds only a ")
        assert "[sensors] table" in str(err.value) and "[lidar] table" in str(err.value)
    f.write_text("sensors = 5\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r": 'sensors' must be a table \(\[sensors\]\), got 5$"):
        read_sensor_file(f)
    f.write_text("[sensors]\nfix_rate = true\n", encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        read_sensor_file(f)
    assert str(err.value).startswith(f"{f}: field '[sensors] fix_rate': sensor fix_rate must be a finite number")


def test_a_scenario_tables_errors_name_its_file_and_field_not_the_command_line(tmp_path: Path) -> None:
    scen = tmp_path / "s.toml"
    where = str(scen)
    cases = [
        (
            {"fix_rate": -1.0},
            r"field '\[sensors\] fix_rate': sensor fix_rate must be a finite number in \[0, 1000\] .*, got -1.0; "
            r"e\.g\. fix_rate = 5$",
        ),
        ({"fix_rat": 5.0}, r"field '\[sensors\] fix_rat': unknown key 'fix_rat'; the sensor keys are encoder_cpr"),
        (
            {"fix_rate": 3.0},
            r"field '\[sensors\] fix_rate': .*16.67 control periods .*2.5 or 3.125 Hz, e\.g\. fix_rate = 2.5$",
        ),
    ]
    for table, match in cases:
        with pytest.raises(ConfigError, match=match) as err:
            load_sensor_profile("turtlebot3", table=table, source=where, control_rate=50.0)
        assert str(err.value).startswith(f"{where}: ") and "--sensors" not in str(err.value)
    # a rate set on the command line over the table is the command line's to fix
    fix = r'2.5 or 3.125 Hz, e\.g\. --sensors fix_rate=2.5 \(sensors="fix_rate=2.5" from Python\)$'
    with pytest.raises(ConfigError, match=rf"^sensor fix_rate=3 Hz: .*{fix}"):
        load_sensor_profile("turtlebot3", table={"fix_rate": 4.0}, text="fix_rate=3", source=where, control_rate=50.0)
    cli = load_sensor_profile("turtlebot3", table={"fix_rate": 4.0}, text="fix_rate=3")  # no rate to check against
    with pytest.raises(ConfigError, match=rf"^sensor fix_rate=3 Hz: .*{fix}"):
        _model(cli)  # ... until the run is made
    # the robot's own profile's rate: said to be its, the fix an override or a control rate it divides
    with pytest.raises(
        ConfigError,
        match=r"^robot 'edumip' takes pose fixes at 10 Hz \(fix_rate in its sensor "
        r"profile .*edumip.toml\), which a control rate of 25 Hz does not keep: .*e\.g\. --sensors "
        r"fix_rate=6.25 .*; or give a control rate that is a multiple of 10 Hz \(--control-rate",
    ):
        load_sensor_profile("edumip", control_rate=25.0)
    # a control rate the physics cannot run is said first: advice for the fix rate at 50.4 Hz (fix_rate=8.4) was
    # followed by "50.4 Hz is not a whole number of 2 ms physics steps"
    with pytest.raises(ConfigError, match=r"^control rate 50.4 Hz is not a whole number of 2 ms physics steps"):
        load_sensor_profile("edumip", control_rate=50.4)
    # through a case, as every command reads it: the scenario's file is named
    from planning.scenario import load_scenario
    from sim.pipeline.case import Case

    scen.write_text('[world]\nbounds = [-2.0, 2.0, -2.0, 2.0]\n[start]\npose = [0.0, 0.0, 0.0]\n[goal]\n'
                    "pose = [1.0, 1.0, 0.0]\n[sensors]\nfix_rate = -1.0\n")  # fmt: skip
    with pytest.raises(ConfigError, match=rf"^{re.escape(where)}: field '\[sensors\] fix_rate': .*fix_rate = 5$"):
        Case(str(scen), reference="line", localiser="fixes").sensing(load_scenario(scen))


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("gyro=1", r"expected comma-separated key=value with keys encoder_cpr, .*fix_latency"),
        ("fix_rate", "expected comma-separated"),
        ("fix_rate=fast", "fix_rate must be a number, got 'fast'"),
        ("fix_rate=1,fix_rate=2", "fix_rate given twice"),
        (
            "gyro_noise_density=-0.1",
            r"gyro_noise_density must be a finite number in \[0, 0.1\] .*got -0.1; .*--sensors gyro_noise_density=",
        ),
        ("accel_bias_std=nan", r"accel_bias_std must be a finite number.*--sensors accel_bias_std="),
        ("encoder_cpr=0", r"encoder_cpr must be a finite number in \[1, 1e\+07\] .*, got 0.0"),
    ],
)
def test_bad_sensor_text_names_the_field_and_the_fix(text: str, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        TB3.parse(text)


def test_bad_tables_and_robots_are_refused() -> None:
    with pytest.raises(ConfigError, match=r"unknown key 'gyro'.*the sensor keys are encoder_cpr"):
        TB3.override({"gyro": 1.0})
    with pytest.raises(ConfigError, match=r"fix_rate must be .*\[0, 1000\].*, got 'fast'; e\.g\. --sensors fix_rate="):
        TB3.override({"fix_rate": "fast"})
    with pytest.raises(ConfigError, match=r"fix_rate must be a finite number in \[0, 1000\] .*, got True"):
        TB3.override({"fix_rate": True})
    with pytest.raises(ConfigError, match=r"lacks fix_latency; give every key"):
        SensorProfile.from_table({k: v for k, v in TB3.as_dict().items() if k != "fix_latency"}, "t.toml")
    with pytest.raises(ConfigError, match=r"unknown robot 'r2d2': choose one of edumip, edumip-balancing, turtlebot3;"):
        load_sensor_profile("r2d2")


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"profile": replace(TB3, fix_rate=100.0)}, r"fix_rate=100 Hz is above the control rate 50 Hz.*fix_rate=50"),
        (
            {"profile": replace(TB3, fix_rate=7.0)},
            r"fix_rate=7 Hz: its period is 7.143 control .*6.25 or 10 Hz, e\.g\. .*fix_rate=6.25",
        ),
        ({"rate": 30.0}, r"control rate 30 Hz is not a whole number of 2 ms physics steps"),
        ({"rate": -5.0}, r"control rate must be a finite number > 0 \(Hz\), got -5.0"),
        ({"n": 0}, "number of control periods must be an integer >= 1"),
        ({"seed": -1}, r"sensor noise seed must be an integer >= 0, got -1; pass a whole number"),
        ({"seed": 1.5}, "sensor noise seed must be an integer"),
    ],
)
def test_bad_run_settings_are_refused(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        _model(**kwargs)  # type: ignore[arg-type]


# --- encoders ---------------------------------------------------------------------------------


def test_encoder_quantisation_is_floor_of_counts_plus_phase() -> None:
    m = _model()
    n = TB3.encoder_cpr
    checked = 0
    for side in (0, 1):
        phase = float(m.encoder_phase[side])
        assert 0.0 <= phase < 1.0
        for c in (-5000, -1, 0, 1, 4095, 4096, 123456):
            for f in (0.1, 0.3, 0.6, 0.9):
                if abs((f + phase) - round(f + phase)) < 1e-6:
                    continue  # too close to a count boundary for a float angle
                theta = 2.0 * math.pi * (c + f) / n
                angles = (theta, 0.0) if side == 0 else (0.0, theta)
                assert m.encoder_counts(*angles)[side] == c + math.floor(f + phase)
                checked += 1
    assert checked >= 50


def test_encoder_error_is_within_one_count_and_a_non_integer_resolution_accumulates() -> None:
    m = _model(load_sensor_profile("edumip"))
    c = m.profile.encoder_cpr / (2.0 * math.pi)
    rng = np.random.default_rng(0)
    for theta in rng.uniform(-500.0, 500.0, 200):
        counts = m.encoder_counts(float(theta), float(-theta))
        residual = np.array([theta * c, -theta * c]) + m.encoder_phase - counts
        assert np.all((residual >= 0.0) & (residual < 1.0))
    assert m.encoder_phase[0] > 1e-6
    assert m.encoder_counts(100 * 2.0 * math.pi, 0.0)[0] == 213462  # 100 turns x 2134.62 counts


# --- inertial noise -----------------------------------------------------------------------------


def _allan(x: NDArray[np.float64], m: int, batches: int = 20) -> tuple[float, float]:
    """Non-overlapping Allan variance at cluster size m and its standard error.

    Neighbouring differences share a cluster and are correlated, so the standard error is taken
    from the spread of the means of ``batches`` consecutive batches of squared differences.
    """
    means = x[: len(x) // m * m].reshape(-1, m).mean(axis=1)
    half_sq = 0.5 * np.diff(means) ** 2
    batch_means = np.array([b.mean() for b in np.array_split(half_sq, batches)])
    return float(half_sq.mean()), float(batch_means.std(ddof=1) / math.sqrt(batches))


def test_white_noise_std_is_density_times_sqrt_half_the_rate() -> None:
    n, rate = 200_000, 50.0
    m = _model(replace(TB3, gyro_bias_walk=0.0, gyro_bias_std=0.0), rate=rate, n=n)
    expected_g = TB3.gyro_noise_density * math.sqrt(rate / 2.0)
    expected_a = TB3.accel_noise_density * math.sqrt(rate / 2.0)
    assert m.gyro_white_std == expected_g and m.accel_white_std == expected_a
    # the sample std of N normals has relative standard error 1/sqrt(2N); allow 4 of them
    assert np.std(m.gyro_white) == pytest.approx(expected_g, rel=4 / math.sqrt(2 * n))
    assert np.std(m.accel_white, axis=0) == pytest.approx([expected_a] * 3, rel=4 / math.sqrt(2 * n))
    assert abs(np.mean(m.gyro_white)) < 4 * expected_g / math.sqrt(n)
    assert np.all(m.gyro_bias == 0.0)
    readings = np.array([m.gyro(k, 0.25) for k in range(1000)])
    assert np.array_equal(readings, 0.25 + (m.gyro_bias[:1000] + m.gyro_white[:1000]))


def test_bias_variance_grows_linearly_with_time_over_many_seeds() -> None:
    profile = replace(QUIET, gyro_bias_walk=TB3.gyro_bias_walk)
    rate, seeds, lags = 50.0, 2000, (1, 10, 100, 1000)
    walks = np.array([_model(profile, rate=rate, n=1001, seed=s).gyro_bias for s in range(seeds)])
    assert np.all(walks[:, 0] == 0.0)  # no initial bias in this profile
    for lag in lags:
        expected = TB3.gyro_bias_walk**2 * lag / rate  # K^2 t
        # a sample variance of N normals has relative standard error sqrt(2/N); allow 4 of them
        assert np.var(walks[:, lag]) == pytest.approx(expected, rel=4 * math.sqrt(2 / seeds))
    start = np.array([_model(replace(QUIET, gyro_bias_std=1e-3), n=2, seed=s).gyro_bias[0] for s in range(seeds)])
    assert np.std(start) == pytest.approx(1e-3, rel=4 / math.sqrt(2 * seeds))


def test_allan_variance_of_the_gyro_matches_white_noise_plus_bias_walk() -> None:
    rate, n = 50.0, 400_000
    m = _model(replace(TB3, gyro_bias_std=0.0), rate=rate, n=n, seed=3)
    err = m.gyro_bias + m.gyro_white
    q = TB3.gyro_bias_walk**2 / rate  # variance of one bias step
    for cluster in (1, 10, 100, 1000, 4000):
        # white: sigma^2 / m = d^2 / (2 tau); discrete random walk: q (2 m^2 + 1) / (6 m)
        expected = m.gyro_white_std**2 / cluster + q * (2 * cluster**2 + 1) / (6 * cluster)
        avar, se = _allan(err, cluster)
        assert abs(avar - expected) < 5 * se, (cluster, avar, expected, se)
    # the two regimes are both visible: white dominates at 1 period, the walk at 4000
    assert m.gyro_white_std**2 > 100 * q and q * 8000 / 6 > 3 * m.gyro_white_std**2 / 4000


def test_accel_reading_is_truth_plus_constant_bias_plus_white() -> None:
    m = _model(n=10)
    f = np.array([0.1, -0.2, 9.81])
    for k in range(10):
        assert np.array_equal(m.accel(k, f), f + (m.accel_bias + m.accel_white[k]))
    biases = np.array([_model(n=1, seed=s).accel_bias for s in range(3000)])
    assert np.std(biases, axis=0) == pytest.approx([TB3.accel_bias_std] * 3, rel=4 / math.sqrt(2 * 3000))


# --- fixes --------------------------------------------------------------------------------------


def test_fix_schedule_and_latency_on_hand_computed_cases() -> None:
    m = _model(n=45)  # 50 Hz control, 5 Hz fixes, 0.12 s latency
    assert (m.fix_every, m.fix_latency_periods, m.steps_per_control) == (10, 6, 10)
    assert m.fix_periods.tolist() == [0, 10, 20, 30, 40]
    assert m.fix_delivery_periods.tolist() == [6, 16, 26, 36, 46]
    arriving = {k: m.fix_arriving(k) for k in range(45) if m.fix_arriving(k) is not None}
    assert arriving == {6: 0, 16: 10, 26: 20, 36: 30}
    assert [k for k in range(45) if m.is_fix_period(k)] == [0, 10, 20, 30, 40]
    cases = [  # (control rate, fix rate, latency, fix every, latency periods)
        (50.0, 5.0, 0.13, 10, 7),  # 6.5 periods: first used at the 7th
        (50.0, 10.0, 0.1, 5, 5),  # 0.1 x 50 = 5.000000000000001 counts as 5
        (100.0, 10.0, 0.0, 10, 0),  # delivered in the period it is measured
        (25.0, 25.0, 0.001, 1, 1),
        (100.0, 5.0, 0.125, 20, 13),
    ]
    for rate, fix_rate, latency, every, periods in cases:
        mm = _model(replace(TB3, fix_rate=fix_rate, fix_latency=latency), rate=rate, n=50)
        assert (mm.fix_every, mm.fix_latency_periods) == (every, periods), (rate, fix_rate, latency)
        assert mm.as_dict()["fix_latency_effective_s"] == periods / rate


def test_fix_adds_the_drawn_noise_and_wraps_the_heading() -> None:
    m = _model(n=45)
    for i, k in enumerate(m.fix_periods.tolist()):
        dx, dy, dth = m.fix_noise[i]
        assert m.fix(k, (1.0, 2.0, 0.5)) == (1.0 + dx, 2.0 + dy, math.remainder(0.5 + dth, 2 * math.pi))
    noise = m.fix_noise[:, 2]
    k = int(m.fix_periods[int(np.argmax(noise))])  # a fix with positive heading noise
    assert max(noise) > 0
    assert m.fix(k, (0.0, 0.0, math.pi - 1e-9))[2] < 0.0  # wrapped past pi
    with pytest.raises(ValueError, match="no fix is measured at control period 3"):
        m.fix(3, (0.0, 0.0, 0.0))
    big = _model(n=100_000, seed=11)
    stds = np.std(big.fix_noise, axis=0)
    n_fix = len(big.fix_noise)
    assert stds == pytest.approx([0.02, 0.02, 0.02], rel=4 / math.sqrt(2 * n_fix))


def test_no_pose_source_gives_no_fixes() -> None:
    m = _model(replace(TB3, fix_rate=0.0), n=30)
    assert m.fix_every == 0 and len(m.fix_periods) == 0 and m.fix_noise.shape == (0, 3)
    assert not any(m.is_fix_period(k) for k in range(30))
    assert all(m.fix_arriving(k) is None for k in range(30))
    with pytest.raises(ValueError):
        m.fix(0, (0.0, 0.0, 0.0))


def test_periods_outside_the_run_are_refused() -> None:
    m = _model(n=10)
    for call in (lambda: m.gyro(10, 0.0), lambda: m.gyro(-1, 0.0), lambda: m.accel(10, np.zeros(3))):
        with pytest.raises(IndexError, match=r"outside the run's 0 \.\. 9"):
            call()


# --- seeds and records ----------------------------------------------------------------------------

ARRAYS = ("encoder_phase", "gyro_bias", "gyro_white", "accel_bias", "accel_white", "fix_noise")


def test_same_seed_same_draws_bitwise_other_seed_other_draws() -> None:
    profile = replace(TB3, gyro_bias_std=1e-3)
    a, b, c = _model(profile, n=500, seed=5), _model(profile, n=500, seed=5), _model(profile, n=500, seed=6)
    for name in ARRAYS:
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name
        assert not np.any(getattr(a, name) == getattr(c, name)), name
    assert a.as_dict() == b.as_dict() != c.as_dict()


def test_a_longer_run_begins_with_a_shorter_runs_noise() -> None:
    short, long = _model(n=100, seed=4), _model(n=1000, seed=4)
    for name in ARRAYS:
        s = getattr(short, name)
        assert np.array_equal(getattr(long, name)[: len(s)], s), name


def test_longer_keeps_the_noise_and_its_settings() -> None:
    short = _model(n=100, seed=4)
    long = short.longer(1000)
    assert (long.n_periods, long.seed, long.part, long.control_rate) == (1000, 4, 0, short.control_rate)
    for name in ARRAYS:
        assert np.array_equal(getattr(long, name)[: len(getattr(short, name))], getattr(short, name)), name


def test_a_second_part_draws_its_own_streams_of_the_same_seed() -> None:
    """Part 0 draws stream i from child i of the seed's sequence (as before parts existed), part 1
    from child len(STREAMS) + i: the firmware's IMU noise is independent of the base's."""
    from sim.physics.sensors import STREAMS

    profile = replace(TB3, gyro_bias_std=1e-3)
    base = SensorModel(profile, control_rate=50.0, timestep=0.002, n_periods=300, seed=9)
    other = SensorModel(profile, control_rate=50.0, timestep=0.002, n_periods=300, seed=9, part=1)
    children = np.random.SeedSequence(9).spawn(2 * len(STREAMS))
    white = STREAMS.index("gyro_white")
    for model, child in ((base, children[white]), (other, children[len(STREAMS) + white])):
        expected = np.random.default_rng(child).standard_normal(300) * model.gyro_white_std
        assert np.array_equal(model.gyro_white, expected)
    for name in ARRAYS:
        assert not np.any(getattr(base, name) == getattr(other, name)), name
    with pytest.raises(ConfigError, match="sensor part"):
        SensorModel(profile, control_rate=50.0, timestep=0.002, n_periods=3, seed=9, part=-1)


def test_drawn_arrays_are_read_only_and_the_record_is_json() -> None:
    m = _model()
    with pytest.raises(ValueError):
        m.gyro_white[0] = 1.0
    record = json.loads(json.dumps(m.as_dict()))
    assert record["profile"] == TB3.as_dict()
    assert (record["seed"], record["fix_every_periods"], record["n_periods"]) == (7, 10, 100)


class _PlainSensing:
    """The sensing period in plain Python: :class:`SensorModel`'s Python readings (encoder counts, the
    gyro over the period's heading change) into :class:`control.estimation.PoseEstimator`'s Python
    calls, fixes taken, delivered and fused as :mod:`sim.robot.sensing` documents; the compiled
    route is checked against it."""

    def __init__(self, m: Any, robot: Any, setup: Any, n: int, rate: float) -> None:
        from control.estimation import PoseEstimator

        self.sensors = SensorModel(setup.profile, control_rate=rate, timestep=float(m.opt.timestep),
                                   n_periods=n + 1, seed=setup.seed)  # fmt: skip
        # the EKF's nominal radius is the rolling radius under load, as the run's loop uses
        config = setup.estimator_config(robot, rate)
        self.est = PoseEstimator.for_robot(robot, config, wheel_radius=rolling_radius(robot))
        self.adr = [int(m.sensor_adr[m.sensor(s).id]) for s in ("wheel_left_pos", "wheel_right_pos")]
        self.q, self.dt = 2.0 * math.pi / setup.profile.encoder_cpr, 1.0 / rate
        self.truth, self.estimate, self.variance = (np.full((n + 1, 3), np.nan) for _ in range(3))
        self.fixes: dict[int, tuple[float, float, float]] = {}
        self.nees: list[float] = []
        self.counts, self.yaw = (0, 0), 0.0

    def __call__(self, k: int, sdata: NDArray[np.float64], truth: tuple[float, float, float]) -> tuple[float, ...]:
        sensors, est = self.sensors, self.est
        self.truth[k] = truth
        counts = sensors.encoder_counts(float(sdata[self.adr[0]]), float(sdata[self.adr[1]]))
        if k == 0:
            est.reset(0.0, truth)
        else:
            rate = math.remainder(truth[2] - self.yaw, 2.0 * math.pi) / self.dt
            dl, dr = ((c - p) * self.q for c, p in zip(counts, self.counts, strict=True))
            est.predict(k * self.dt, dl, dr, sensors.gyro(k, rate))
        self.counts, self.yaw = counts, truth[2]
        if sensors.is_fix_period(k):
            self.fixes[k] = sensors.fix(k, truth)
        j = sensors.fix_arriving(k)
        if j is not None:
            est.correct(j * self.dt, self.fixes[j])
            self.nees.append(est.nees(truth))
        return est.record(self.estimate, self.variance, k)


def test_a_runs_sensing_is_the_plain_python_period_bit_for_bit() -> None:
    """A run's sensing (:meth:`Sensing.observe`: compiled reading and prediction) sees the same
    estimates as the plain-Python period (:class:`_PlainSensing`) and logs the same, and refuses a
    second MjData and periods outside the run."""
    import mujoco

    from planning.core.geometry import Pose2D
    from planning.core.robot import load_robot
    from sim.physics.model import set_pose
    from sim.physics.simulator import Simulator
    from sim.robot.sensing import Sensing, SensingSetup
    from sim.robot.sources import PoseSource

    robot = load_robot("turtlebot3")
    sim = Simulator(robot)
    m = sim.model
    d = mujoco.MjData(m)
    set_pose(m, d, Pose2D(0.0, 0.0, 0.3))
    n = 60
    setup = SensingSetup.for_robot(robot.name, seed=3)
    looped = Sensing(m, robot, PoseSource.FUSED, setup, n_periods=n, control_rate=50.0, t0=0.0)
    called = _PlainSensing(m, robot, setup, n, 50.0)
    observe = looped.observer(d)
    d.ctrl[:] = [4.0, 6.0]  # volts: a left turn
    for k in range(n):
        truth = sim.read_pose(d)
        assert observe(k, truth) == called(k, d.sensordata, truth), k
        mujoco.mj_step(m, d, 10)
    a = looped.to_log()
    assert a is not None
    b: dict[str, Any] = {"truth": called.truth[:n], "estimate": called.estimate[:n], "variance": called.variance[:n],
         "nees": called.nees}  # fmt: skip
    for name in ("truth", "estimate", "variance", "nees"):
        assert np.array_equal(getattr(a, name), b[name]), name
    assert np.array_equal(a.fix, [called.fixes[k] for k in sorted(called.fixes)])
    assert len(a.fix_t) >= 5  # fixes were taken and fused on the way
    with pytest.raises(ValueError, match="MjData"):
        looped.observer(mujoco.MjData(m))
    for k in (n + 1, n + 50, -3):  # past the run's periods (its logs have n + 1 rows), or before it
        with pytest.raises(IndexError, match="outside the run"):
            observe(k, truth)


def test_a_settings_files_lidar_table_is_applied_under_the_command_lines_lidar(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--sensors FILE``'s ``[lidar]`` reaches the scanner as ``--lidar`` would, ``--lidar`` on top; what the
    file holds that cannot be used is bad input (exit 2, nothing written)."""
    from sim.cli.main import build_parser, main
    from sim.cli.simulate import localiser_fields
    from sim.pipeline.case import Case, load_case_scenario
    from sim.pipeline.sensor_settings import sensor_overrides

    f = tmp_path / "mine.toml"
    f.write_text("[sensors]\nfix_latency = 0.1\n[lidar]\nbeams = 3\nprecision_far = 0\n", encoding="utf-8")

    def setup(*extra: str) -> Any:
        args = build_parser(["simulate"]).parse_args(["simulate", "--sensors", str(f), *extra])
        case = Case("open", reference="line", sensors=sensor_overrides(args.sensors), **localiser_fields(args))
        return case.sensing(load_case_scenario(case))

    alone = setup()
    assert alone.localiser.lidar.beams == 3 and alone.localiser.lidar.precision_far == 0.0
    assert alone.profile.fix_latency == 0.1
    over = setup("--lidar", "beams=90")
    assert over.localiser.lidar.beams == 90 and over.localiser.lidar.precision_far == 0.0
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    run = ["simulate", "--sensors", str(f), "--reference", "line", "--no-video", "--quiet"]
    for text, extra, says in (
        ("[lidr]\nbeams = 3\n", [], f"{f}: table [lidr] is not understood here"),
        ("[lidar]\nbeams = 1000\n", [], f"{f}: field '[lidar] beams': lidar beams must be a finite number in [1, 360]"),
        ("[lidar]\nbeam = 3\n", [], f"{f}: field '[lidar] beam': unknown key; the lidar keys are beams"),
        ("[lidar]\nbeams = 3\n", ["--localiser", "fixes"], f"{f}: table [lidar]: --localiser fixes takes no scan"),
        ("[lidar]\nbeams = 3\n", ["--robot", "edumip"], "and a [lidar] table from the --sensors file"),
    ):
        f.write_text(text, encoding="utf-8")
        assert main([*run, *extra]) == 2
        err = capsys.readouterr().err
        assert says in err and "Traceback" not in err
    assert list(work.iterdir()) == []


@pytest.mark.parametrize(("rate", "latency"), [(500.0, 0.2), (50.0, 1.5)])
def test_a_fix_as_late_as_the_profile_delivers_it_is_fused(rate: float, latency: float) -> None:
    """The EKF fuses a fix at its measurement time, which must still be in its history when the fix arrives:
    with a fixed 64 periods, 0.2 s of latency at 500 Hz (or 1.5 s at 50 Hz) dropped every fix as stale and
    the fused run was the dead-reckoning one, silently. The history is sized from the latency; an explicit
    configuration too short for it is refused."""
    from planning.core.robot import load_robot
    from sim.pipeline.runs import RunKind
    from sim.pipeline.simulate import simulate_reference
    from sim.robot.sensing import SensingSetup

    robot = load_robot("edumip")
    setup = SensingSetup.for_robot("edumip", 0, text=f"fix_latency={latency}")
    lag = round(latency * rate)
    assert setup.estimator_config(robot, rate).history_steps >= lag + 2 > 64
    job = simulate_reference(
        "open", reference="line", robot="edumip", runs=(RunKind.CLOSED_LOOP, RunKind.CLOSED_LOOP_ODOMETRY),
        control_rate=rate, sensors=f"fix_latency={latency}",
    )  # fmt: skip
    fused, odometry = (job.metrics[k].estimation for k in (RunKind.CLOSED_LOOP, RunKind.CLOSED_LOOP_ODOMETRY))
    assert fused.fixes_used > 0 and fused.position_rmse_m < 0.5 * odometry.position_rmse_m
    explicit = replace(setup, estimator=setup.estimator_config(robot, 50.0 if rate > 50 else 10.0))
    with pytest.raises(ConfigError, match=rf"history_steps .* keeps less than the fixes' latency .*>= {lag + 2}"):
        explicit.estimator_config(robot, rate)


def test_the_rates_suggested_for_a_model_of_other_steps_are_whole_steps_there() -> None:
    """A model of 20 ms steps was told to choose "e.g. 10, 20, 50 or 100 Hz" when 100 Hz was refused: the
    suggestions were fixed. They are those that divide its physics rate."""
    from sim.physics import motors

    with pytest.raises(ConfigError, match=r"divides 50 Hz \(e\.g\. 10 or 50 Hz\)$"):
        motors.control_steps(100.0, 0.02)
    assert motors.suggested_rates(0.03) == "(e.g. 8.33333, 16.6667 or 33.3333 Hz)"  # none of 10..100 is whole


def test_the_control_rates_a_message_suggests_run_every_built_in_robot() -> None:
    """A rate below 1 Hz or off the physics steps was told "e.g. 10, 25, 50, 100"; 25 Hz was then refused on the
    EduMIP, whose 10 Hz fixes are 2.5 of its periods."""
    import re

    from planning.core.robot import ROBOTS
    from sim.physics import motors
    from sim.physics.model import robot_timestep

    rates = [float(r) for r in re.findall(r"\d+", motors.suggested_rates(0.002))]
    assert rates == [10.0, 20.0, 50.0, 100.0]
    for robot in ROBOTS.built_in():
        for rate in rates:
            assert motors.control_steps(rate, robot_timestep(robot)) >= 1
            load_sensor_profile(robot, control_rate=rate)  # its own fixes a whole number of periods
