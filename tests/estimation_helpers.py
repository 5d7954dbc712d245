"""Synthetic sensor data for the estimator tests: a differential drive with systematic errors.

The robot drives smooth wheel-speed profiles. Its as-built wheel radii and track width differ from
the nominal ones by draws from the build tolerances, its wheels slip by white noise (and, in a
scenario with ``cornering_slip``, sideways in turns by a compliance drawn from the EKF's prior),
and the truth is integrated with exact arcs at ``SUBSTEPS`` sub-steps per control period (the wheel speeds vary
inside a period, as on a real robot). The sensors see: quantised cumulative encoder counts (floor),
a gyro reading the period's mean z-rate plus a random-walk bias and white noise, and pose fixes
measured at sub-step times (so often between control ticks) with Gaussian noise, delivered at the
first control tick at or after t_meas + latency.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from control.estimation import EstimatorConfig, PoseEstimator, kernels
from tests.reference_odometry import integrate_arcs

FloatArray = NDArray[np.float64]

RADIUS, TRACK = 0.033, 0.160  # TurtleBot3 Burger as drawn [m]
DT = 0.02  # control period [s]
SUBSTEPS = 4


@dataclass(frozen=True)
class Scenario:
    """What the synthetic world draws; the noise values match an :class:`EstimatorConfig`."""

    config: EstimatorConfig
    duration: float = 20.0
    fix_period: float = 0.2
    latency: float = 0.1
    pose_std0: float = 0.01  # initial pose error std [m] and [rad]
    cornering_slip: bool = False  # the tyres slip in turns, k drawn from the config's prior
    range_errors: bool = False  # the fixes carry a range sensor's errors, drawn from the config's priors


@dataclass(frozen=True)
class Synthetic:
    """One drawn run. K control periods; fixes as (t_meas, tick index delivered at, z (3,))."""

    t: FloatArray  # (K+1,) tick times [s]
    truth: FloatArray  # (K+1, 3) true poses at the ticks
    d_left: FloatArray  # (K,) measured left wheel increments [rad]
    d_right: FloatArray  # (K,)
    gyro: FloatArray  # (K,) gyro readings [rad/s]
    bias: FloatArray  # (K+1,) true gyro bias at the ticks [rad/s]
    fixes: list[tuple[float, int, FloatArray]]
    pose0: FloatArray  # (3,) initial estimate (truth + error drawn from cov0)
    cov0: FloatArray  # (3, 3)
    cornering_slip: float = 0.0  # the tyres' true compliance k [rad s^2/m]
    range_errors: FloatArray | None = None  # (2,) the true range scale and offset errors [-, m]
    range_gains: list[FloatArray] | None = None  # each fix's (3, 2) gain on them


def range_gain(theta: float) -> FloatArray:
    """A scan fix's (3, 2) gain on the range errors as a heading-dependent function (the walls in
    range turn with the robot): 0.9 m per unit of scale along the heading, 0.6 m per metre of
    offset across it, and a little heading."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[0.9 * c, -0.6 * s], [0.9 * s, 0.6 * c], [0.1, 0.3]])


def wheel_rates(t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Nominal wheel speeds [rad/s] for a curvy drive (speed 0.1-0.2 m/s, yaw rate up to 0.9 rad/s)."""
    v = 0.15 + 0.05 * np.sin(0.3 * t)
    w = 0.7 * np.sin(0.25 * t) + 0.2 * np.sin(1.1 * t)
    return (v - 0.5 * TRACK * w) / RADIUS, (v + 0.5 * TRACK * w) / RADIUS


def draw(scenario: Scenario, seed: int) -> Synthetic:
    """Draw one run's truth and sensor readings from a seeded generator."""
    cfg = scenario.config
    rng = np.random.default_rng(seed)
    k = round(scenario.duration / DT)
    h = DT / SUBSTEPS
    n = k * SUBSTEPS
    r_l, r_r = RADIUS * (1.0 + cfg.wheel_radius_rel_std * rng.standard_normal(2))
    b = TRACK + cfg.track_width_std * rng.standard_normal()
    wl, wr = wheel_rates((np.arange(n) + 0.5) * h)
    enc_l, enc_r = wl * h, wr * h  # what the wheels turn (the encoders see it)
    roll_l = enc_l + cfg.wheel_noise * np.sqrt(np.abs(enc_l)) * rng.standard_normal(n)  # what rolls
    roll_r = enc_r + cfg.wheel_noise * np.sqrt(np.abs(enc_r)) * rng.standard_normal(n)
    ds = 0.5 * (r_l * roll_l + r_r * roll_r)
    dth = (r_r * roll_r - r_l * roll_l) / b
    cov0 = np.eye(3) * scenario.pose_std0**2
    start = np.array([0.5, -0.3, 0.4])
    slip, k_slip = None, 0.0
    if scenario.cornering_slip:  # its own stream: the other draws stay those of the run without
        k_slip = cfg.cornering_slip_std * np.random.default_rng([seed, 1]).standard_normal()
        slip = -k_slip * (ds / h) * (dth / h)  # -k v omega
    sub = integrate_arcs(start, ds, dth, slip)
    scrub = cfg.position_noise * np.sqrt(np.abs(ds))[:, None] * rng.standard_normal((n, 2))
    sub[1:, :2] += np.cumsum(scrub, axis=0)
    counts_l = np.floor(np.concatenate(([0.0], np.cumsum(enc_l))) * cfg.counts_per_rev / (2 * math.pi))
    counts_r = np.floor(np.concatenate(([0.0], np.cumsum(enc_r))) * cfg.counts_per_rev / (2 * math.pi))
    q = 2 * math.pi / cfg.counts_per_rev
    bias = cfg.gyro_bias_std * rng.standard_normal() + np.concatenate(
        ([0.0], np.cumsum(cfg.gyro_bias_walk * math.sqrt(h) * rng.standard_normal(n - 1)))
    )
    rate = dth / h + bias + cfg.gyro_noise_density / math.sqrt(h) * rng.standard_normal(n)
    fixes, gains = [], []
    errors = None
    if scenario.range_errors:  # its own stream, as the slip
        errors = np.random.default_rng([seed, 2]).standard_normal(2) * (cfg.range_scale_std, cfg.range_offset_std)
    every = round(scenario.fix_period / h)
    for i in range(3, n + 1, every):  # measured 3 sub-steps after a tick: between ticks
        t_meas = i * h
        z = sub[i] + rng.standard_normal(3) * (cfg.fix_std_xy, cfg.fix_std_xy, cfg.fix_std_theta)
        tick = math.ceil((t_meas + scenario.latency) / DT - 1e-9)
        if tick <= k:
            if errors is not None:
                gains.append(range_gain(float(sub[i, 2])))
                z = z + gains[-1] @ errors
            fixes.append((t_meas, tick, z))
    return Synthetic(
        t=np.arange(k + 1) * DT,
        truth=sub[::SUBSTEPS],
        d_left=np.diff(counts_l[::SUBSTEPS]) * q,
        d_right=np.diff(counts_r[::SUBSTEPS]) * q,
        gyro=rate.reshape(k, SUBSTEPS).mean(axis=1),
        bias=np.concatenate((bias, bias[-1:]))[::SUBSTEPS],
        fixes=fixes,
        pose0=sub[0] + rng.multivariate_normal(np.zeros(3), cov0),
        cov0=cov0,
        cornering_slip=k_slip,
        range_errors=errors,
        range_gains=gains if errors is not None else None,
    )


def run(est: PoseEstimator, data: Synthetic, *, fuse: bool = True, gains: bool = True) -> tuple[FloatArray, FloatArray]:
    """Run an estimator over a drawn run (it ends in the run's last state).

    Fixes with range errors are fused with their gains; with ``gains`` False, each as independent
    with the range errors' share (at the config's priors) added to its position variance instead.

    Returns:
        The pose estimates (K+1, 3) and their covariances (K+1, 3, 3) at the ticks.
    """
    est.reset(float(data.t[0]), data.pose0, data.cov0)
    k = data.t.size - 1
    poses, covs = np.empty((k + 1, 3)), np.empty((k + 1, 3, 3))
    poses[0], covs[0] = est.pose, est.cov
    fixes = data.fixes if fuse else []
    j = 0
    for i in range(1, k + 1):
        est.predict(float(data.t[i]), float(data.d_left[i - 1]), float(data.d_right[i - 1]), float(data.gyro[i - 1]))
        while j < len(fixes) and fixes[j][1] == i:
            g = None if data.range_gains is None else data.range_gains[j]
            if g is not None and not gains:
                cfg = est.config
                share = g @ np.diag([cfg.range_scale_std**2, cfg.range_offset_std**2]) @ g.T
                sxy = math.sqrt(cfg.fix_std_xy**2 + max(share[0, 0], share[1, 1]))
                est.correct(fixes[j][0], fixes[j][2], sxy, math.sqrt(cfg.fix_std_theta**2 + share[2, 2]))
            else:
                est.correct(fixes[j][0], fixes[j][2], range_gain=g)
            j += 1
        poses[i], covs[i] = est.pose, est.cov
    return poses, covs


def propagate(
    est: PoseEstimator,
    x: NDArray[np.float64],
    p: NDArray[np.float64],
    dl: float,
    dr: float,
    w: float,
    dt: float,
) -> None:
    """One compiled prediction of ``est`` (:func:`control.estimation.kernels.propagate`) on a state x
    (N,) and covariance p (N, N), in place, over dt [s] with wheel increments (dl, dr) [rad], gyro
    rate w [rad/s]; its Jacobian and noise are left in ``est._F``, ``est._Q``.

    Raises:
        AssertionError: The kernel reports a non-finite state.
    """
    status = kernels.propagate(x, p, est._F, est._Q, est._tmp, est._prm, dl, dr, w, dt)
    assert status == kernels.OK, status
