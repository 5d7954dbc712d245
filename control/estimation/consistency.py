"""Filter consistency: normalised estimation error squared (NEES) and its chi-square bounds.

A consistent filter's pose error e = x_hat - x_true has the covariance P it reports, so
NEES = e^T P^-1 e is chi-square with n = 3 degrees of freedom, mean 3. Averaged over M
independent Monte Carlo runs at one time (the ANEES), M * ANEES is chi-square with 3 M degrees
of freedom, so the two-sided 95 % interval of the ANEES is chi2.ppf([0.025, 0.975], 3 M) / M
(Bar-Shalom, Li and Kirubarajan, Estimation with Applications to Tracking and Navigation, 2001,
sec. 5.4.2). The same interval holds for the normalised innovation squared (NIS) of fixes.

The quantiles come from :mod:`scipy.stats`, imported and evaluated once per (dof, runs, prob)
and cached; nothing here runs per filter step.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.checks import check_number
from planning.errors import ConfigError

FloatArray = NDArray[np.float64]


def pose_error(estimate: ArrayLike, truth: ArrayLike) -> FloatArray:
    """Estimate minus truth with the heading difference wrapped to [-pi, pi).

    Args:
        estimate: (..., 3) poses [m, m, rad].
        truth: (..., 3) poses, same shape.

    Returns:
        (..., 3) errors [m, m, rad].
    """
    e = np.asarray(estimate, dtype=float) - np.asarray(truth, dtype=float)
    e[..., 2] = np.mod(e[..., 2] + math.pi, 2.0 * math.pi) - math.pi
    return e


def nees(error: ArrayLike, cov: ArrayLike) -> float | FloatArray:
    """Normalised estimation error squared e^T P^-1 e.

    Args:
        error: (n,) or (N, n) errors (heading already wrapped, see :func:`pose_error`).
        cov: (n, n) or (N, n, n) covariances, symmetric positive definite.

    Returns:
        The NEES, a float for one error, (N,) for a batch.

    Raises:
        ConfigError: Shapes disagree.
    """
    e = np.asarray(error, dtype=float)
    p = np.asarray(cov, dtype=float)
    if e.ndim not in (1, 2) or p.shape != (*e.shape, e.shape[-1]):
        raise ConfigError(f"nees needs error (n,) with cov (n, n), or (N, n) with (N, n, n); got {e.shape}, {p.shape}")
    sol = np.linalg.solve(p, e[..., None])[..., 0]
    value = np.sum(e * sol, axis=-1)
    return float(value) if e.ndim == 1 else value


@lru_cache(maxsize=64)
def chi2_interval(dof: int = 3, runs: int = 1, prob: float = 0.95) -> tuple[float, float]:
    """Two-sided interval holding an M-run average of chi-square(dof) samples with probability prob.

    Args:
        dof: Degrees of freedom of one sample (3 for a planar pose).
        runs: Number M of independent samples averaged (Monte Carlo runs).
        prob: Probability inside the interval, in (0, 1).

    Returns:
        (low, high): chi2.ppf((1 -+ prob) / 2, dof * runs) / runs. For dof 3, one run and 95 %:
        (0.216, 9.348).

    Raises:
        ConfigError: dof or runs not a positive integer, or prob outside (0, 1).
    """
    for name, value in (("dof", dof), ("runs", runs)):
        check_number(f"chi2_interval: {name}", value, integer=True, at_least=1)
    if not (isinstance(prob, float) and 0.0 < prob < 1.0):
        raise ConfigError(f"chi2_interval: prob must be a float in (0, 1), e.g. 0.95, got {prob!r}")
    from scipy.stats import chi2

    k = dof * runs
    return float(chi2.ppf(0.5 * (1.0 - prob), k)) / runs, float(chi2.ppf(0.5 * (1.0 + prob), k)) / runs


@lru_cache(maxsize=16)
def chi2_upper(dof: int, prob: float) -> float:
    """One-sided bound: chi-square(dof) lies below it with probability prob (a NIS gate).

    Raises:
        ConfigError: prob outside (0, 1) or dof not a positive integer.
    """
    check_number("chi2_upper: dof", dof, integer=True, at_least=1)
    if not (isinstance(prob, float) and 0.0 < prob < 1.0):
        raise ConfigError(f"chi2_upper: prob must be a float in (0, 1), e.g. 0.999, got {prob!r}")
    from scipy.stats import chi2

    return float(chi2.ppf(prob, dof))
