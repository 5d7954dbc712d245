"""Discrete LQR design with Bryson weights, and the check that a closed loop is stable."""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from planning.errors import ConfigError

FloatArray = NDArray[np.float64]


def lqr_gains(a: FloatArray, b: FloatArray, maxima: tuple[float, ...], voltage_max: float) -> FloatArray:
    """Discrete LQR gains K (1, n) with Bryson weights Q = diag(1 / maxima^2), R = 1 / voltage_max^2."""
    q = np.diag(1.0 / np.square(np.asarray(maxima, dtype=float)))
    r = np.array([[1.0 / voltage_max**2]])
    p = scipy.linalg.solve_discrete_are(a, b, q, r)
    return np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)  # type: ignore[no-any-return]


def check_closed_loop(a: FloatArray, b: FloatArray, k: FloatArray | tuple[float, ...]) -> NDArray[np.complex128]:
    """The closed loop's poles ``eig(A - B K)``, checked to lie inside the unit disc.

    Raises:
        ConfigError: A pole on or outside the unit circle (named, with its magnitude).
    """
    gains = np.atleast_2d(np.asarray(k, dtype=float))
    poles = np.linalg.eigvals(a - b @ gains)
    worst = poles[np.argmax(np.abs(poles))]
    if not np.abs(worst) < 1.0:
        raise ConfigError(
            f"balance gains k={gains.ravel().round(4).tolist()} destabilise the loop: closed-loop pole "
            f"{worst.real:.4f}{worst.imag:+.4f}j has |z| = {abs(worst):.4f} >= 1 at the loop's rate; "
            f"recompute them with sim.robot.balance_design.design_report"
        )
    return np.asarray(poles, dtype=complex)
