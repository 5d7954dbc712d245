"""Kinematic models: unicycle, differential drive, and the bicycle model run on a differential drive.

State conventions:
    unicycle / differential drive: ``[x, y, theta]`` [m, m, rad], inputs ``[v, omega]``.
    bicycle: ``[x, y, theta, phi]`` with virtual steering angle phi [rad] and wheelbase l [m];
    inputs ``[u1, u2]`` = [speed, steering rate]; the differential drive executes
    ``omega = u1 * tan(phi) / l``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def unicycle_rhs(state: FloatArray, u: FloatArray) -> FloatArray:
    """Time derivative of the unicycle, vectorised over leading dimensions.

    Args:
        state: (..., 3) [x, y, theta].
        u: (..., 2) [v, omega].

    Returns:
        (..., 3) [xdot, ydot, thetadot].
    """
    theta = state[..., 2]
    v, w = u[..., 0], u[..., 1]
    return np.stack([v * np.cos(theta), v * np.sin(theta), w], axis=-1)


def bicycle_rhs(state: FloatArray, u: FloatArray, wheelbase: float) -> FloatArray:
    """Time derivative of the kinematic bicycle, vectorised over leading dimensions.

    Args:
        state: (..., 4) [x, y, theta, phi].
        u: (..., 2) [u1 (speed, m/s), u2 (steering rate, rad/s)].
        wheelbase: Virtual wheelbase l [m].

    Returns:
        (..., 4) derivatives.
    """
    theta, phi = state[..., 2], state[..., 3]
    u1, u2 = u[..., 0], u[..., 1]
    return np.stack([u1 * np.cos(theta), u1 * np.sin(theta), u1 * np.tan(phi) / wheelbase, u2], axis=-1)


def bicycle_to_unicycle(state: FloatArray, u: FloatArray, wheelbase: float) -> FloatArray:
    """The (v, omega) a differential drive executes for bicycle state and inputs.

    Args:
        state: (..., 4) bicycle states.
        u: (..., 2) bicycle inputs.
        wheelbase: Virtual wheelbase l [m].

    Returns:
        (..., 2) [v, omega] with omega = u1 tan(phi) / l.
    """
    return np.stack([u[..., 0], u[..., 0] * np.tan(state[..., 3]) / wheelbase], axis=-1)


def wheel_speeds(v: ArrayLike, omega: ArrayLike, wheel_radius: float, track_width: float) -> FloatArray:
    """Differential-drive inverse kinematics.

    Args:
        v: Body speed(s) [m/s].
        omega: Yaw rate(s) [rad/s].
        wheel_radius: r [m].
        track_width: Distance between the wheel contact points [m].

    Returns:
        (..., 2) wheel angular speeds [left, right] [rad/s].
    """
    v = np.asarray(v, dtype=float)
    omega = np.asarray(omega, dtype=float)
    half = 0.5 * track_width * omega
    return np.stack([(v - half) / wheel_radius, (v + half) / wheel_radius], axis=-1)


def body_twist(wheel_lr: ArrayLike, wheel_radius: float, track_width: float) -> FloatArray:
    """Differential-drive forward kinematics.

    Args:
        wheel_lr: (..., 2) wheel angular speeds [left, right] [rad/s].
        wheel_radius: r [m].
        track_width: Distance between the wheel contact points [m].

    Returns:
        (..., 2) [v, omega] = [r (wR + wL) / 2, r (wR - wL) / track].
    """
    w = np.asarray(wheel_lr, dtype=float)
    return np.stack(
        [wheel_radius * (w[..., 1] + w[..., 0]) / 2.0, wheel_radius * (w[..., 1] - w[..., 0]) / track_width],
        axis=-1,
    )


def rk4_step(
    rhs: Callable[[FloatArray, FloatArray], FloatArray], state: FloatArray, u: FloatArray, dt: float
) -> FloatArray:
    """One classical Runge-Kutta step with the input held constant, vectorised.

    Args:
        rhs: f(state, u) -> dstate/dt.
        state: (..., n) states.
        u: (..., m) inputs, held over the step.
        dt: Step [s].

    Returns:
        (..., n) states after ``dt``.
    """
    k1 = rhs(state, u)
    k2 = rhs(state + 0.5 * dt * k1, u)
    k3 = rhs(state + 0.5 * dt * k2, u)
    k4 = rhs(state + dt * k3, u)
    return state + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def rollout(
    rhs: Callable[[FloatArray, FloatArray], FloatArray],
    state0: ArrayLike,
    controls: ArrayLike,
    dt: float,
    substeps: int = 1,
) -> FloatArray:
    """Integrate a model under a piecewise-constant input sequence with RK4.

    Args:
        rhs: f(state, u) -> dstate/dt.
        state0: (n,) initial state.
        controls: (K, m) inputs, each held for ``dt``.
        dt: Duration of each input [s].
        substeps: RK4 steps per input.

    Returns:
        (K + 1, n) states, the first being ``state0``.
    """
    x = np.asarray(state0, dtype=float)
    us = np.asarray(controls, dtype=float)
    out = np.empty((us.shape[0] + 1, x.size))
    out[0] = x
    h = dt / substeps
    for k in range(us.shape[0]):
        for _ in range(substeps):
            x = rk4_step(rhs, x, us[k], h)
        out[k + 1] = x
    return out
