"""NEES and its chi-square bounds: table values, an explicit inverse, and a Monte Carlo of known covariance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from control.estimation import chi2_interval, chi2_upper, nees, pose_error
from planning.errors import ConfigError


def test_chi2_interval_matches_tables() -> None:
    # chi-square quantiles for 3 dof (Abramowitz and Stegun, table 26.8): 0.2158 (2.5 %), 9.3484 (97.5 %).
    lo, hi = chi2_interval(3)
    assert lo == pytest.approx(0.215795, abs=1e-6)
    assert hi == pytest.approx(9.348404, abs=1e-6)
    assert chi2_upper(3, 0.999) == pytest.approx(16.266236, abs=1e-6)
    lo50, hi50 = chi2_interval(3, runs=50)
    # 150 dof over 50 runs against the Wilson-Hilferty approximation k (1 - a + z sqrt(a))^3, a = 2 / (9 k).
    a = 2 / (9 * 150)
    for got, z in ((lo50, -1.959964), (hi50, 1.959964)):
        assert got == pytest.approx(150 * (1 - a + z * math.sqrt(a)) ** 3 / 50, abs=2e-3)


def test_nees_equals_the_explicit_quadratic_form() -> None:
    rng = np.random.default_rng(3)
    a = rng.standard_normal((5, 3, 3))
    covs = a @ a.transpose(0, 2, 1) + 0.1 * np.eye(3)
    errs = rng.standard_normal((5, 3))
    want = [e @ np.linalg.inv(c) @ e for e, c in zip(errs, covs, strict=True)]
    np.testing.assert_allclose(nees(errs, covs), want, rtol=1e-12)
    assert nees(errs[0], covs[0]) == pytest.approx(want[0], rel=1e-12)


def test_monte_carlo_of_a_consistent_estimate_lies_in_the_interval_and_a_wrong_one_does_not() -> None:
    rng = np.random.default_rng(11)
    cov = np.array([[4e-4, 1e-4, 0.0], [1e-4, 2e-4, 2e-5], [0.0, 2e-5, 1e-3]])
    errs = rng.multivariate_normal(np.zeros(3), cov, size=(200, 50))  # 200 times x 50 runs
    lo, hi = chi2_interval(3, runs=50)
    anees = nees(errs.reshape(-1, 3), np.broadcast_to(cov, (10000, 3, 3))).reshape(200, 50).mean(axis=1)
    inside = np.mean((anees > lo) & (anees < hi))
    assert 0.9 < inside <= 1.0  # 95 % expected
    anees_wrong = nees(errs.reshape(-1, 3), np.broadcast_to(cov / 2, (10000, 3, 3))).reshape(200, 50).mean(axis=1)
    assert np.mean((anees_wrong > lo) & (anees_wrong < hi)) < 0.05


def test_pose_error_wraps_the_heading() -> None:
    e = pose_error([[1.0, 2.0, 3.1]], [[0.5, 2.5, -3.1]])
    np.testing.assert_allclose(e, [[0.5, -0.5, 6.2 - 2 * math.pi]], atol=1e-12)


def test_bad_arguments_raise() -> None:
    with pytest.raises(ConfigError, match="nees needs"):
        nees(np.zeros(3), np.eye(2))
    with pytest.raises(ConfigError, match="runs"):
        chi2_interval(3, runs=0)
    with pytest.raises(ConfigError, match="prob"):
        chi2_interval(3, prob=1.5)
    with pytest.raises(ConfigError, match="prob"):
        chi2_upper(3, 1.0)
