"""The pose EKF: odometry without noise, Jacobians, consistency (NEES over a Monte Carlo), delayed fixes, divergence."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from control.estimation import (
    N_STATE,
    STATE_NAMES,
    EstimatorConfig,
    EstimatorDivergedError,
    EstimatorInputError,
    PoseEstimator,
    chi2_interval,
    kernels,
    nees,
    pose_error,
)
from control.estimation.ekf import IRS, ISLIP, QUANT_PERIOD, RELOCALISE_MAX_NIS
from planning.core.robot import load_robot
from planning.errors import ConfigError, NhsimError, SimulationError
from tests.estimation_helpers import DT, RADIUS, TRACK, Scenario, Synthetic, draw, propagate, run, wheel_rates
from tests.reference_odometry import integrate_wheels

CONFIG = EstimatorConfig()
RUNS = 50
SCENARIO = Scenario(CONFIG, duration=20.0, fix_period=0.2, latency=0.1)


@pytest.fixture(scope="module")
def draws() -> list[Synthetic]:
    return [draw(SCENARIO, seed) for seed in range(RUNS)]


def monte_carlo(config: EstimatorConfig, draws: list[Synthetic], fuse: bool) -> dict[str, np.ndarray]:
    """Errors (S, K+1, 3), NEES (S, K+1), the final gyro-bias error (S,) and its std (S,)."""
    errs, nees_all, bias_err, bias_std = [], [], [], []
    for d in draws:
        est = PoseEstimator(config, RADIUS, TRACK)
        poses, covs = run(est, d, fuse=fuse)
        e = pose_error(poses, d.truth)
        errs.append(e)
        nees_all.append(nees(e, covs))
        bias_err.append(est.gyro_bias - d.bias[-1])
        bias_std.append(math.sqrt(est.cov_full[3, 3]))
    return {
        "err": np.array(errs),
        "nees": np.array(nees_all),
        "bias_err": np.array(bias_err),
        "bias_std": np.array(bias_std),
    }


@pytest.fixture(scope="module")
def nominal(draws: list[Synthetic]) -> dict[bool, dict[str, np.ndarray]]:
    return {fuse: monte_carlo(CONFIG, draws, fuse) for fuse in (True, False)}


def anees_verdict(nees_runs: np.ndarray) -> tuple[float, float]:
    """Time-averaged ANEES after the first second, and the share of 0.5 s samples inside the 95 % bounds."""
    lo, hi = chi2_interval(3, runs=nees_runs.shape[0])
    anees = nees_runs.mean(axis=0)[50::25]
    return float(anees.mean()), float(np.mean((anees > lo) & (anees < hi)))


# --- configuration and calls ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        (
            "wheel_noise",
            -0.1,
            r"^EstimatorConfig\.wheel_noise must be a finite number >= 0 \(rad/sqrt\(rad\)\), got -0\.1; "
            r"a standard deviation is never negative: give its magnitude$",
        ),
        (
            "gyro_noise_density",
            math.nan,
            r"^EstimatorConfig\.gyro_noise_density must be a finite number >= 0 \(rad/s/sqrt\(Hz\)\), got nan$",
        ),
        (
            "track_width_std",
            math.inf,
            r"^EstimatorConfig\.track_width_std must be a finite number >= 0 \(m\), got inf$",
        ),
        (
            "fix_std_xy",
            0.0,
            r"^EstimatorConfig\.fix_std_xy must be a finite number > 0 \(m\), got 0\.0; give its magnitude$",
        ),
        (
            "counts_per_rev",
            -4096.0,
            r"^EstimatorConfig\.counts_per_rev must be a finite number > 0 \(counts/rev\), got -4096\.0; "
            r"give its magnitude$",
        ),
        ("heading", "compass", "heading must be one of gyro, encoders"),
        ("history_steps", 1, r"^EstimatorConfig\.history_steps must be an integer >= 2, got 1$"),
        ("max_outliers", True, r"^EstimatorConfig\.max_outliers must be an integer >= 1, got True$"),
        (
            "gate_prob",
            1.0,
            r"^EstimatorConfig\.gate_prob must be a finite number in \(0, 1\) \(a probability\), got 1\.0; "
            r"e\.g\. 0\.999$",
        ),
        (
            "gate_prob",
            0.0,
            r"^EstimatorConfig\.gate_prob must be a finite number in \(0, 1\) .*, got 0\.0; e\.g\. 0\.999$",
        ),
        ("reject_outliers", "yes", "reject_outliers must be True or False"),
    ],
)
def test_bad_config_raises_naming_the_field(field: str, value: object, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        EstimatorConfig(**{field: value})  # type: ignore[arg-type]


def test_scaled_process_noise_scales_only_process_noise() -> None:
    small = CONFIG.scaled_process_noise(0.1)
    assert small.gyro_bias_walk == pytest.approx(0.1 * CONFIG.gyro_bias_walk)
    assert small.wheel_radius_rel_std == pytest.approx(0.1 * CONFIG.wheel_radius_rel_std)
    assert small.fix_std_xy == CONFIG.fix_std_xy
    with pytest.raises(ConfigError, match=r"^scaled_process_noise: factor must be a finite number >= 0, got -1\.0$"):
        CONFIG.scaled_process_noise(-1.0)


def test_bad_calls_raise() -> None:
    est = PoseEstimator(CONFIG, RADIUS, TRACK)
    with pytest.raises(EstimatorInputError, match="reset"):
        est.predict(0.02, 0.1, 0.1, 0.0)
    with pytest.raises(EstimatorInputError, match="reset"):
        est.correct(0.0, (0.0, 0.0, 0.0))
    with pytest.raises(EstimatorInputError, match="cov0"):
        est.reset(0.0, (0.0, 0.0, 0.0), np.eye(2))
    est.reset(0.0, (0.0, 0.0, 0.0))
    est.predict(0.02, 0.1, 0.1, 0.0)
    state = est.state
    with pytest.raises(EstimatorInputError, match="increase"):
        est.predict(0.02, 0.1, 0.1, 0.0)
    with pytest.raises(EstimatorInputError, match="non-finite"):
        est.predict(0.04, math.nan, 0.1, 0.0)
    assert est.t == 0.02 and np.array_equal(est.state, state)  # a refused reading changes nothing
    with pytest.raises(EstimatorInputError, match="gyro_z"):
        est.predict(0.04, 0.1, 0.1)
    with pytest.raises(EstimatorInputError, match="after the last predict"):
        est.correct(0.05, (0.0, 0.0, 0.0))
    with pytest.raises(EstimatorInputError, match="three numbers"):
        est.correct(0.02, (0.0, 0.0))
    with pytest.raises(EstimatorInputError, match="fix noise"):
        est.correct(0.02, (0.0, 0.0, 0.0), std_xy=-1.0)
    for gain in (np.zeros((2, 3)), np.full((3, 2), math.nan), "wide"):
        with pytest.raises(EstimatorInputError, match=r"range_gain must be a finite \(3, 2\) array"):
            est.correct(0.02, (0.0, 0.0, 0.0), range_gain=gain)
    for cov in (np.eye(2), np.diag([1e-4, -1e-4, 1e-4]), [[1e-4, 1e-5, 0], [0, 1e-4, 0], [0, 0, 1e-4]], "cov"):
        with pytest.raises(EstimatorInputError, match="cov must be a finite, symmetric, positive-definite"):
            est.correct(0.02, (0.0, 0.0, 0.0), cov=cov)
    with pytest.raises(EstimatorInputError, match="either as cov or as std_xy and std_theta"):
        est.correct(0.02, (0.0, 0.0, 0.0), std_xy=0.01, cov=np.eye(3) * 1e-4)
    with pytest.raises(ConfigError, match="EstimatorConfig"):
        PoseEstimator({"heading": "gyro"}, RADIUS, TRACK)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="track width"):
        PoseEstimator(CONFIG, RADIUS, 0.0)
    assert issubclass(EstimatorInputError, NhsimError)


def test_for_robot_takes_the_nominal_geometry() -> None:
    spec = load_robot("edumip")
    est = PoseEstimator.for_robot(spec)
    assert (est.nominal_radius, est.nominal_track) == (spec.wheel_radius, spec.track_width)
    est.reset(0.0, (0.0, 0.0, 0.0))
    assert est.calibration == pytest.approx((spec.wheel_radius, spec.wheel_radius, spec.track_width))
    assert len(STATE_NAMES) == est.state.size
    rolled = PoseEstimator.for_robot(spec, wheel_radius=0.99 * spec.wheel_radius)  # a calibrated radius
    assert (rolled.nominal_radius, rolled.nominal_track) == (0.99 * spec.wheel_radius, spec.track_width)


# --- prediction ----------------------------------------------------------------------------------


@pytest.mark.parametrize("heading", ["gyro", "encoders"])
def test_noise_free_prediction_is_the_odometry(heading: str) -> None:
    t = np.arange(400) * DT
    wl, wr = wheel_rates(t)
    dl, dr = wl * DT, wr * DT
    gyro = RADIUS * (wr - wl) / TRACK  # what a perfect gyro reads for constant wheel speeds
    est = PoseEstimator(EstimatorConfig(heading=heading), RADIUS, TRACK)
    pose0 = (0.2, 0.1, 3.0)
    est.reset(0.0, pose0)
    for i in range(t.size):
        est.predict((i + 1) * DT, dl[i], dr[i], gyro[i])
    want = integrate_wheels(pose0, dl, dr, RADIUS, TRACK)[-1]
    np.testing.assert_allclose(pose_error(est.pose, want), 0.0, atol=1e-11)


@pytest.mark.parametrize("heading", ["gyro", "encoders"])
def test_propagation_jacobians_match_finite_differences(heading: str) -> None:
    """F (state) and Q (noise through the input Jacobian) against central differences of the mean."""
    est = PoseEstimator(EstimatorConfig(heading=heading), RADIUS, TRACK)
    x0 = np.array([0.3, -0.2, 2.9, 0.01, 0.004, -0.003, 0.02, 0.03, 0.01, 0.004])  # slip and range errors too
    u = np.array([0.35, 0.5, 0.7])  # dl, dr [rad], gyro [rad/s]

    def mean(x: np.ndarray, uu: np.ndarray) -> np.ndarray:
        xx = x.copy()
        propagate(est, xx, np.zeros((N_STATE, N_STATE)), uu[0], uu[1], uu[2], DT)
        return xx

    p = np.zeros((N_STATE, N_STATE))
    x = x0.copy()
    propagate(est, x, p, u[0], u[1], u[2], DT)
    f, q = est._F.copy(), est._Q.copy()
    eps = 1e-6

    def diff(k: int, of_input: bool) -> np.ndarray:
        d = np.zeros(3 if of_input else N_STATE)
        d[k] = eps
        hi = mean(x0, u + d) if of_input else mean(x0 + d, u)
        lo = mean(x0, u - d) if of_input else mean(x0 - d, u)
        return (hi - lo) / (2 * eps)  # theta stays near 2.9: no wrap

    np.testing.assert_allclose(f, np.stack([diff(k, False) for k in range(N_STATE)], axis=1), atol=1e-8)
    g = np.stack([diff(k, True) for k in range(3)], axis=1)
    cfg = est.config
    quant = (2 * math.pi / cfg.counts_per_rev) ** 2 / 6 * DT / QUANT_PERIOD  # a density: per second
    var_u = [cfg.wheel_noise**2 * abs(u[0]) + quant, cfg.wheel_noise**2 * abs(u[1]) + quant]
    var_u.append(cfg.gyro_noise_density**2 / DT if heading == "gyro" else 0.0)
    want = g @ np.diag(var_u) @ g.T
    ds = RADIUS * ((1 + x0[4]) * (u[0] + u[1]) + x0[5] * (u[1] - u[0])) / 2
    want[:2, :2] += np.eye(2) * cfg.position_noise**2 * abs(ds)
    want[3, 3] = cfg.gyro_bias_walk**2 * DT if heading == "gyro" else 0.0
    np.testing.assert_allclose(q[:4, :4], want[:4, :4], rtol=1e-6, atol=1e-16)


@pytest.mark.parametrize("heading", ["gyro", "encoders"])
def test_propagated_covariance_is_f_p_ft_plus_q(heading: str) -> None:
    """The compiled covariance update (which skips F's identity rows) is F P F^T + Q of the step's own
    F and Q, for a full (dense, symmetric positive-definite) P."""
    est = PoseEstimator(EstimatorConfig(heading=heading), RADIUS, TRACK)
    rng = np.random.default_rng(4)
    for _ in range(5):
        a = rng.normal(size=(N_STATE, N_STATE))
        p0 = a @ a.T + 0.1 * np.eye(N_STATE)
        x, p = rng.normal(scale=0.05, size=N_STATE), p0.copy()
        propagate(est, x, p, *rng.uniform(-0.5, 0.5, 2), rng.uniform(-1, 1), DT * rng.uniform(0.2, 1.0))
        f, q = est._F, est._Q
        np.testing.assert_allclose(p, f @ p0 @ f.T + q, rtol=1e-13, atol=1e-15)


def test_the_compiled_angle_wrap_is_math_remainder() -> None:
    from control.estimation import kernels

    rng = np.random.default_rng(8)
    angles = np.concatenate([rng.uniform(-1e4, 1e4, 2000), math.pi + rng.normal(scale=1e-12, size=200), [0.0, 7.0]])
    for a in angles.tolist():
        assert kernels.wrap(a) == math.remainder(a, 2 * math.pi), a


def test_record_and_nees_read_the_newest_estimate(draws: list[Synthetic]) -> None:
    """record() writes the pose and the diagonal of its covariance into the row asked for (and
    nothing else); nees() is e^T P^-1 e with the heading error wrapped."""
    d = draws[1]
    est = fresh(d)
    drive(est, d, 0, 30)
    assert est.correct(float(d.t[25]), d.truth[25] + (0.01, -0.02, 0.01))
    pose, variance = np.full((4, 3), np.nan), np.full((4, 3), np.nan)
    assert est.record(pose, variance, 2) == est.pose
    np.testing.assert_array_equal(pose[2], est.pose)
    np.testing.assert_array_equal(variance[2], np.diag(est.cov))
    assert np.isnan(np.delete(pose, 2, axis=0)).all() and np.isnan(np.delete(variance, 2, axis=0)).all()
    truth = d.truth[30] + (0.0, 0.0, 4 * math.pi)  # a heading two turns away is the same heading
    want = nees(pose_error(est.pose, d.truth[30]), est.cov)
    assert est.nees(truth) == pytest.approx(want, rel=1e-12)
    assert want > 0


def test_a_pose_known_to_under_a_micrometre_in_some_direction_judges_nothing() -> None:
    """At 10 Hz the EduMIP's first fix arrived one period after the start, when the estimate's lateral position still
    followed its heading to 1e-17 m^2: an error of 1.8e-9 m in that direction made a NEES of 1.2e15 and the run's
    NEES mean 7e12 beside 92 % of samples in bounds. A covariance whose smallest eigenvalue is under
    kernels.NEES_RESOLUTION^2 now gives NaN (no sample); the run's mean is a chi-square(3) mean again."""
    from sim.pipeline.simulate import simulate_reference

    est = PoseEstimator.for_robot(load_robot("turtlebot3"), EstimatorConfig())
    assert math.isnan(est.nees((0.0, 0.0, 0.0)))  # the start: known exactly
    result = simulate_reference("open", reference="circle", robot="edumip", control_rate=10, runs=["closed_loop"])
    log = result.logs["closed_loop"].estimation
    assert log is not None and log.nees_t[0] == pytest.approx(0.2)  # the delivery at 0.1 s judged nothing
    assert 1.0 < log.nees_mean() < 6.0 and log.nees.max() < 100.0


# --- accuracy and consistency over a Monte Carlo -------------------------------------------------


def test_fixes_bring_the_error_well_below_dead_reckoning(nominal: dict[bool, dict[str, np.ndarray]]) -> None:
    rmse = {
        fuse: float(np.sqrt(np.mean(np.sum(nominal[fuse]["err"][:, :, :2] ** 2, axis=-1)))) for fuse in (True, False)
    }
    final = {
        fuse: float(np.sqrt(np.mean(np.sum(nominal[fuse]["err"][:, -1, :2] ** 2, axis=-1)))) for fuse in (True, False)
    }
    assert rmse[True] < 0.4 * rmse[False]
    assert final[True] < 0.25 * final[False]
    assert rmse[True] < 0.5 * CONFIG.fix_std_xy  # better than the fixes themselves


@pytest.mark.parametrize("fuse", [True, False], ids=["fused", "dead-reckoning"])
def test_nees_over_the_monte_carlo_lies_in_the_chi_square_bounds(
    nominal: dict[bool, dict[str, np.ndarray]], fuse: bool
) -> None:
    lo, hi = chi2_interval(3, runs=RUNS)
    mean, inside = anees_verdict(nominal[fuse]["nees"])
    assert lo < mean < hi
    assert inside >= 0.85  # 95 % expected of a consistent filter; the samples are correlated in time


@pytest.mark.parametrize("fuse", [True, False], ids=["fused", "dead-reckoning"])
def test_nees_test_fails_when_the_process_noise_is_ten_times_too_small(draws: list[Synthetic], fuse: bool) -> None:
    hi = chi2_interval(3, runs=RUNS)[1]
    mean, inside = anees_verdict(monte_carlo(CONFIG.scaled_process_noise(1 / math.sqrt(10)), draws, fuse)["nees"])
    assert mean > hi
    assert inside < 0.5


def test_gyro_bias_estimate_is_consistent_and_learned(nominal: dict[bool, dict[str, np.ndarray]]) -> None:
    lo, hi = chi2_interval(1, runs=RUNS)
    fused = nominal[True]
    assert lo < np.mean((fused["bias_err"] / fused["bias_std"]) ** 2) < hi
    assert np.all(fused["bias_std"] < 0.3 * CONFIG.gyro_bias_std)  # the heading fixes observe the bias
    np.testing.assert_allclose(nominal[False]["bias_std"], CONFIG.gyro_bias_std, rtol=0.01)  # nothing does without


def test_encoder_heading_with_fixes_is_consistent(draws: list[Synthetic]) -> None:
    lo, hi = chi2_interval(3, runs=RUNS)
    mean, inside = anees_verdict(monte_carlo(replace(CONFIG, heading="encoders"), draws, True)["nees"])
    assert lo < mean < hi
    assert inside >= 0.85


def test_cornering_slip_is_learned_and_keeps_the_filter_consistent() -> None:
    """Tyres that slip outwards in turns (a compliance drawn from the prior, large here so that it
    shows: 0.3 rad per m/s^2, up to 50 mrad on this drive): with the slip state the filter stays
    consistent and learns k from the fixes; without it (a zero prior) the same runs fail the test."""
    config = replace(CONFIG, cornering_slip_std=0.3)
    runs = [draw(replace(SCENARIO, config=config, cornering_slip=True), seed) for seed in range(RUNS)]
    lo, hi = chi2_interval(3, runs=RUNS)
    mean, inside = anees_verdict(monte_carlo(config, runs, True)["nees"])
    assert lo < mean < hi
    assert inside >= 0.85
    k_err, k_std = [], []
    for d in runs:
        est = PoseEstimator(config, RADIUS, TRACK)
        run(est, d)
        k_err.append(est.cornering_slip - d.cornering_slip)
        k_std.append(math.sqrt(est.cov_full[ISLIP, ISLIP]))
    assert chi2_interval(1, runs=RUNS)[0] < np.mean((np.array(k_err) / k_std) ** 2) < chi2_interval(1, runs=RUNS)[1]
    assert np.all(np.array(k_std) < 0.3 * config.cornering_slip_std)  # the turns with fixes observe it
    mean, inside = anees_verdict(monte_carlo(replace(config, cornering_slip_std=0.0), runs, True)["nees"])
    assert mean > hi
    assert inside < 0.5


def test_range_sensor_errors_are_learned_and_keep_scan_fixes_consistent() -> None:
    """Fixes matched from a range sensor's scans share its systematic errors (scale and offset, drawn
    once per run from the priors, large here so that it shows: up to 10 cm), moved by a gain that turns
    with the robot: fused with their gains the filter stays consistent and learns the errors; fused as
    independent, each with the errors' share in its own variance (as a localiser's covariance has it),
    the same runs fail the test."""
    config = replace(CONFIG, range_scale_std=0.05, range_offset_std=0.02)
    runs = [draw(replace(SCENARIO, config=config, range_errors=True), seed) for seed in range(RUNS)]
    lo, hi = chi2_interval(3, runs=RUNS)
    verdict = {}
    for gains in (True, False):
        nees_runs, err, std = [], [], []
        for d in runs:
            est = PoseEstimator(config, RADIUS, TRACK)
            poses, covs = run(est, d, gains=gains)
            nees_runs.append(nees(pose_error(poses, d.truth), covs))
            assert d.range_errors is not None
            err.append(np.array(est.range_errors) - d.range_errors)
            std.append(np.sqrt(np.diag(est.cov_full)[IRS:]))
        verdict[gains] = anees_verdict(np.array(nees_runs))
        if gains:
            z2 = np.mean((np.array(err) / np.array(std)) ** 2, axis=0)
            assert np.all((chi2_interval(1, runs=RUNS)[0] < z2) & (z2 < chi2_interval(1, runs=RUNS)[1])), z2
            assert np.all(np.array(std) < 0.5 * np.array([config.range_scale_std, config.range_offset_std]))
    mean, inside = verdict[True]
    assert lo < mean < hi
    assert inside >= 0.85
    mean, inside = verdict[False]
    assert mean > hi
    assert inside < 0.5


def test_a_fix_with_a_range_gain_is_the_textbook_update() -> None:
    """The compiled update with H = [I_3 0 G] and a full noise covariance R against numpy's
    K = P H^T S^-1, x + K nu, P - K S K^T (a dense covariance and state); with G = 0 the same as a fix
    without a gain, and a diagonal R the same as std_xy and std_theta, bit for bit."""
    rng = np.random.default_rng(5)
    a = rng.standard_normal((N_STATE, N_STATE))
    p0 = a @ a.T * 1e-3 + np.eye(N_STATE) * 1e-4
    x0 = rng.standard_normal(N_STATE) * 0.1
    g = rng.standard_normal((3, 2))
    r = np.array([[4e-4, 1e-4, -2e-5], [1e-4, 2e-4, 3e-5], [-2e-5, 3e-5, 1e-4]])
    fix = np.array([0.0, 0.1, -0.05, 0.2, *r[np.triu_indices(3)], *g.ravel()])
    h = np.zeros((3, N_STATE))
    h[:, :3], h[:, IRS:] = np.eye(3), g
    s_mat = h @ p0 @ h.T + r
    k = p0 @ h.T @ np.linalg.inv(s_mat)
    nu = fix[1:4] - h @ x0
    x, p = x0.copy(), p0.copy()
    status, nis, ok = kernels.fix_update(x, p, fix, kernels.parameters(*([1.0] * 8), 100.0, False), True, np.empty(3))
    assert status == kernels.OK and ok
    np.testing.assert_allclose(nis, nu @ np.linalg.solve(s_mat, nu), rtol=1e-10)
    np.testing.assert_allclose(x, x0 + k @ nu, rtol=0, atol=1e-12)
    np.testing.assert_allclose(p, p0 - k @ s_mat @ k.T, rtol=0, atol=1e-12)
    ests = [PoseEstimator(CONFIG, RADIUS, TRACK) for _ in range(3)]
    for est in ests:
        est.reset(0.0, (0.0, 0.0, 0.0), np.eye(3) * 1e-4)
        est.predict(0.02, 0.3, 0.35, 0.5)
    assert ests[0].correct(0.02, (0.01, 0.0, 0.02), 0.03, 0.01)
    assert ests[1].correct(0.02, (0.01, 0.0, 0.02), range_gain=np.zeros((3, 2)), cov=np.diag([9e-4, 9e-4, 1e-4]))
    assert ests[2].correct(0.02, (0.01, 0.0, 0.02), 0.03, 0.01, range_gain=np.zeros((3, 2)))
    for est in ests[1:]:
        assert np.array_equal(est.state, ests[0].state) and np.array_equal(est.cov_full, ests[0].cov_full)


# --- delayed fixes -------------------------------------------------------------------------------


def drive(est: PoseEstimator, data: Synthetic, start: int, stop: int) -> None:
    """Feed the readings of ticks start+1 .. stop."""
    for i in range(start + 1, stop + 1):
        est.predict(float(data.t[i]), float(data.d_left[i - 1]), float(data.d_right[i - 1]), float(data.gyro[i - 1]))


def fresh(data: Synthetic, config: EstimatorConfig = CONFIG) -> PoseEstimator:
    est = PoseEstimator(config, RADIUS, TRACK)
    est.reset(0.0, data.pose0, data.cov0)
    return est


def assert_same_state(a: PoseEstimator, b: PoseEstimator, tol: float) -> None:
    np.testing.assert_allclose(a.state, b.state, rtol=0, atol=tol)
    np.testing.assert_allclose(a.cov_full, b.cov_full, rtol=0, atol=tol * 1e-3)


def test_a_delayed_fix_rewinds_to_what_in_order_processing_gives(draws: list[Synthetic]) -> None:
    d = draws[0]
    z = d.truth[40] + (0.03, -0.02, 0.01)
    in_order, delayed = fresh(d), fresh(d)
    drive(in_order, d, 0, 40)
    assert in_order.correct(float(d.t[40]), z)
    drive(in_order, d, 40, 50)
    drive(delayed, d, 0, 50)
    assert delayed.correct(float(d.t[40]), z)  # 10 periods (200 ms) late
    assert_same_state(in_order, delayed, 1e-13)
    np.testing.assert_array_equal(in_order.nis_history, delayed.nis_history)


def test_a_fix_between_ticks_splits_the_period() -> None:
    """Fused at t_k + 0.3 dt after the fact equals driving to t_meas, fusing, and driving on.

    Without quantisation noise (an encoder of 1e12 counts) the split period's noise is the sum of
    its parts either way, so the two agree to rounding.
    """
    cfg = replace(CONFIG, counts_per_rev=1e12)
    d = draw(replace(SCENARIO, config=cfg, duration=2.0), 5)
    z, t_meas, frac = d.truth[20] + (0.02, 0.01, -0.02), float(d.t[20] + 0.3 * DT), 0.3
    manual, delayed = fresh(d, cfg), fresh(d, cfg)
    drive(manual, d, 0, 20)
    manual.predict(t_meas, frac * d.d_left[20], frac * d.d_right[20], float(d.gyro[20]))
    manual.correct(t_meas, z)
    manual.predict(float(d.t[21]), (1 - frac) * d.d_left[20], (1 - frac) * d.d_right[20], float(d.gyro[20]))
    drive(manual, d, 21, 30)
    drive(delayed, d, 0, 30)
    delayed.correct(t_meas, z)
    assert_same_state(manual, delayed, 1e-12)


@pytest.mark.parametrize("latency", [0.06, 0.18])
def test_latency_changes_nothing_once_the_fixes_are_in(latency: float) -> None:
    """The same draw delivered without latency and with it: the same end state and NIS sequence."""
    now = draw(replace(SCENARIO, latency=0.0, duration=6.0), 7)
    late = draw(replace(SCENARIO, latency=latency, duration=6.0), 7)
    assert [f[0] for f in now.fixes][:25] == [f[0] for f in late.fixes][:25]
    assert [f[1] for f in now.fixes] != [f[1] for f in late.fixes]
    a, b = fresh(now), fresh(late)
    run(a, now)
    run(b, late)
    n = len(late.fixes)  # the last fixes of the zero-latency run arrive in time, the late run's not
    done = [f for f in now.fixes if f[0] <= late.fixes[-1][0]]
    assert len(done) == n
    np.testing.assert_allclose(a.nis_history[:n], b.nis_history, rtol=1e-9, atol=1e-12)
    a_end = fresh(now)
    run(a_end, replace(now, fixes=done))
    assert_same_state(a_end, b, 1e-10)


def test_out_of_order_fixes_equal_in_order(draws: list[Synthetic]) -> None:
    d = draws[1]
    z1, z2 = d.truth[30] + (0.01, 0.02, 0.0), d.truth[35] + (-0.02, 0.0, 0.01)
    a, b = fresh(d), fresh(d)
    drive(a, d, 0, 45)
    drive(b, d, 0, 45)
    a.correct(float(d.t[30]), z1)
    a.correct(float(d.t[35]), z2)
    b.correct(float(d.t[35]), z2)
    b.correct(float(d.t[30]), z1)  # measured earlier, arrives later
    assert_same_state(a, b, 1e-12)


def test_a_fix_older_than_the_history_is_dropped(draws: list[Synthetic]) -> None:
    d = draws[2]
    est = fresh(d, replace(CONFIG, history_steps=10))
    drive(est, d, 0, 30)
    assert est.history_start == pytest.approx(d.t[20])
    before = est.state
    assert not est.correct(float(d.t[15]), d.truth[15])
    assert est.fixes_stale == 1
    np.testing.assert_array_equal(est.state, before)
    assert est.correct(float(d.t[20]), d.truth[20])


def test_heading_innovation_wraps() -> None:
    est = PoseEstimator(CONFIG, RADIUS, TRACK)
    est.reset(0.0, (0.0, 0.0, math.pi - 0.01), np.diag([1e-4, 1e-4, 1e-4]))
    est.predict(0.02, 0.0, 0.0, 0.0)
    assert est.correct(0.02, (0.0, 0.0, -math.pi + 0.01))  # 0.02 rad away, not 2 pi - 0.02
    assert est.nis_history[-1, 1] < 1.0
    assert abs(abs(est.pose[2]) - math.pi) < 0.01


# --- outliers and divergence ---------------------------------------------------------------------


def test_outliers_are_rejected_then_divergence_raises(draws: list[Synthetic]) -> None:
    d = draws[3]
    cfg = replace(CONFIG, max_outliers=3)
    est, dead = fresh(d, cfg), fresh(d, cfg)
    drive(dead, d, 0, 60)
    kidnapped = (1.0, 0.0, 0.0)  # the localiser puts the robot a metre away
    for k, tick in enumerate((20, 40)):
        drive(est, d, tick - 20, tick)
        assert not est.correct(float(d.t[tick]), d.truth[tick] + kidnapped)
        assert est.fixes_rejected == k + 1
    drive(est, d, 40, 60)
    np.testing.assert_allclose(est.state, dead.state, atol=1e-15)  # rejected fixes changed nothing
    with pytest.raises(EstimatorDivergedError, match=r"diverged at t=1\.200 s: 3 consecutive fixes") as info:
        est.correct(float(d.t[60]), d.truth[60] + kidnapped)
    assert info.value.reason == "innovation"
    assert info.value.t == pytest.approx(1.2)
    assert isinstance(info.value, SimulationError)


def _believing(d: Synthetic, config: EstimatorConfig) -> tuple[PoseEstimator, int]:
    """An estimator told the robot starts 0.8 m from where it does (Nav2's initial covariance), after four of the
    localiser's fixes from its spread cloud about that wrong pose: (it, the tick it is at)."""
    est = PoseEstimator(config, RADIUS, TRACK)
    est.reset(0.0, np.asarray(d.pose0) + np.array([0.8, 0.0, 0.0]), np.diag([0.25, 0.25, 0.07]))
    for tick in (10, 20, 30, 40):
        drive(est, d, tick - 10, tick)
        assert est.correct(float(d.t[tick]), d.truth[tick] + np.array([0.8, 0.0, 0.0]), std_xy=0.4, std_theta=0.2)
    return est, 40


def test_fixes_that_agree_on_the_estimates_offset_move_it_there(draws: list[Synthetic]) -> None:
    """Told the robot stands 0.8 m from where it does (a wrong initial pose, Nav2's initial covariance), the
    estimator follows the localiser's first answers (its spread cloud about that pose, 0.4 m); the localiser then
    finds the robot (1 cm fixes) and the estimate, sure of it to about 0.19 m, rejects them (NIS 18.7, above the
    gate of 16.3): five ended the run "diverged". The third that agrees with the two before it moves the estimate
    to them, and the later ones are in the gate. Without ``relocalise_after`` (0) the same fixes raise as before."""
    d = draws[3]
    est, tick = _believing(d, CONFIG)
    applied = []
    for _ in range(5):
        drive(est, d, tick, tick + 10)
        tick += 10
        applied.append(est.correct(float(d.t[tick]), d.truth[tick], std_xy=0.01, std_theta=0.005))
    assert applied == [False, False, True, True, True]
    assert est.relocalisations == 1 and est.fixes_rejected == 2 and est.fixes_widened == 0
    assert math.hypot(*(np.asarray(est.pose[:2]) - d.truth[tick, :2])) < 0.02
    never, tick = _believing(d, replace(CONFIG, relocalise_after=0))
    with pytest.raises(EstimatorDivergedError, match="5 consecutive fixes"):
        for _ in range(5):
            drive(never, d, tick, tick + 10)
            tick += 10
            never.correct(float(d.t[tick]), d.truth[tick], std_xy=0.01, std_theta=0.005)


def test_fixes_far_beyond_a_sure_estimate_are_not_followed_however_well_they_agree(draws: list[Synthetic]) -> None:
    """A localiser biased by unmapped obstacles: every fix 0.44 m off a right estimate (sure of it to millimetres),
    all agreeing (NIS about 3000). Following them would move a right estimate to a wrong place with the run's
    status "ok"; the run ends "diverged" instead, as before relocalisation (a kidnapped robot alike)."""
    d = draws[3]
    est = fresh(d)
    for tick in (10, 20, 30, 40):  # the localiser right
        drive(est, d, tick - 10, tick)
        est.correct(float(d.t[tick]), d.truth[tick], std_xy=0.01, std_theta=0.005)
    tick, bias = 40, np.array([0.0, 0.44, 0.0])
    with pytest.raises(EstimatorDivergedError, match="5 consecutive fixes"):
        for _ in range(5):
            drive(est, d, tick, tick + 10)
            tick += 10
            assert not est.correct(float(d.t[tick]), d.truth[tick] + bias, std_xy=0.01, std_theta=0.005)
    assert est.relocalisations == 0 and est.nis_history[-1, 1] > RELOCALISE_MAX_NIS


def test_outliers_that_disagree_do_not_move_the_estimate(draws: list[Synthetic]) -> None:
    """The estimate as unsure as when relocalising (above), but fixes that put the robot half a metre apart from
    one another (the truth, then 0.5 m aside, alternately): they do not agree on where the estimate is wrong, stay
    outliers, and the fifth raises."""
    d = draws[3]
    est, tick = _believing(d, CONFIG)
    with pytest.raises(EstimatorDivergedError, match="5 consecutive fixes"):
        for k in range(5):
            drive(est, d, tick, tick + 10)
            tick += 10
            aside = np.array([0.0, 0.5 * (k % 2), 0.0])
            assert not est.correct(float(d.t[tick]), d.truth[tick] + aside, std_xy=0.01, std_theta=0.005)
    assert est.relocalisations == 0 and est.nis_history[-1, 1] < RELOCALISE_MAX_NIS  # near enough, but apart


def test_relocalise_after_one_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"relocalise_after must be 0 \(never\) or at least 2"):
        EstimatorConfig(relocalise_after=1)


def test_a_radius_error_beyond_the_prior_widens_the_covariance_instead_of_rejecting_every_fix() -> None:
    """Accurate fixes (2 mm, one a second) on a robot whose wheels are 5 % larger than the estimator
    believes (14 standard deviations of its common radius prior): without the widening the
    drift between fixes grows until every fix is an outlier and the estimator declares divergence;
    with it, the first outlier that a drift within max_odometry_drift explains is applied after
    widening, the fixes calibrate the radius and the estimate ends where the robot is."""
    accurate = replace(CONFIG, fix_std_xy=0.002, fix_std_theta=0.002)
    data = draw(Scenario(accurate, duration=30.0, fix_period=1.0, latency=0.12), 7)
    believed = RADIUS / 1.05  # the wheels roll 1.05 x what the estimator's radius says

    def fused(config: EstimatorConfig) -> PoseEstimator:
        est = PoseEstimator(config, believed, TRACK)
        run(est, data)
        return est

    with pytest.raises(EstimatorDivergedError, match="consecutive fixes"):
        fused(replace(accurate, max_odometry_drift=0.0))
    est = fused(accurate)
    assert est.fixes_widened >= 1 and est.fixes_rejected <= 2  # of 30
    assert np.hypot(*(np.array(est.pose[:2]) - data.truth[-1, :2])) < 0.01
    common = 0.5 * (est.calibration[0] + est.calibration[1]) / believed - 1.0  # the estimated e_m
    assert common == pytest.approx(0.05, abs=0.005)
    assert EstimatorConfig(max_odometry_drift=0.1).max_odometry_drift == 0.1
    with pytest.raises(ConfigError, match=r"max_odometry_drift must be a finite number in \[0, 1\]"):
        EstimatorConfig(max_odometry_drift=-0.01)


def test_a_lone_outlier_is_rejected_and_the_second_in_a_row_widens(draws: list[Synthetic]) -> None:
    """Fixes 1 cm off (2 mm fixes, the robot a few decimetres on): a drift within max_odometry_drift
    explains each, but a lone outlier is more likely the fix's fault: the first is rejected and
    changes nothing, the second in a row is applied after widening."""
    d = draws[3]
    accurate = replace(CONFIG, fix_std_xy=0.002, fix_std_theta=0.002)
    est, dead = fresh(d, accurate), fresh(d, accurate)
    off = (0.01, 0.0, 0.0)
    for tick in range(10, 101, 10):  # fixes on the truth: the estimate is sure to a few millimetres
        for e in (est, dead):
            drive(e, d, tick - 10, tick)
            assert e.correct(float(d.t[tick]), d.truth[tick])
    drive(est, d, 100, 110)
    drive(dead, d, 100, 110)
    assert not est.correct(float(d.t[110]), d.truth[110] + off)
    assert est.fixes_rejected == 1 and est.fixes_widened == 0
    np.testing.assert_allclose(est.state, dead.state, atol=0.0)  # the rejected fix changed nothing
    drive(est, d, 110, 120)
    assert est.correct(float(d.t[120]), d.truth[120] + off)
    assert est.fixes_rejected == 1 and est.fixes_widened == 1


def test_a_good_fix_resets_the_outlier_count(draws: list[Synthetic]) -> None:
    d = draws[3]
    est = fresh(d, replace(CONFIG, max_outliers=2))
    for tick, offset in ((10, 1.0), (20, 0.0), (30, 1.0), (40, 0.0)):
        drive(est, d, tick - 10, tick)
        est.correct(float(d.t[tick]), d.truth[tick] + (offset, 0.0, 0.0))
    assert est.fixes_rejected == 2


def test_without_rejection_an_outlier_is_applied(draws: list[Synthetic]) -> None:
    d = draws[3]
    est = fresh(d, replace(CONFIG, reject_outliers=False))
    drive(est, d, 0, 20)
    pose, cov = np.array(est.pose), est.cov
    z = d.truth[20] + (1.0, 0.0, 0.0)
    assert est.correct(float(d.t[20]), z)
    assert est.nis_history[-1, 1] > est.nis_gate
    gain = cov @ np.linalg.inv(cov + np.diag([CONFIG.fix_std_xy**2] * 2 + [CONFIG.fix_std_theta**2]))
    np.testing.assert_allclose(est.pose, pose + gain @ (z - pose), rtol=1e-9)  # the Kalman update, textbook form
    assert est.pose[0] - pose[0] > 0.1


def test_a_non_finite_state_raises_divergence() -> None:
    est = PoseEstimator(CONFIG, RADIUS, TRACK)
    est.reset(0.0, (0.0, 0.0, 0.0), np.eye(3))
    with np.errstate(over="ignore"), pytest.raises(EstimatorDivergedError, match=r"at t=0\.020 s.*non-finite") as info:
        est.predict(0.02, 1e300, -1e300, 0.0)  # finite readings, infinite covariance
    assert info.value.reason == "non-finite"
