import numpy as np
from scipy.integrate import solve_ivp

from planning.core.kinematics import (
    bicycle_rhs,
    bicycle_to_unicycle,
    body_twist,
    rk4_step,
    rollout,
    unicycle_rhs,
    wheel_speeds,
)


def test_wheel_speed_mapping_round_trips() -> None:
    rng = np.random.default_rng(1)
    v, w = rng.normal(size=50), rng.normal(size=50)
    wl = wheel_speeds(v, w, 0.033, 0.16)
    back = body_twist(wl, 0.033, 0.16)
    np.testing.assert_allclose(back[:, 0], v, atol=1e-12)
    np.testing.assert_allclose(back[:, 1], w, atol=1e-12)
    # pure rotation: wheels opposite, |w_wheel| = omega * track / (2 r)
    np.testing.assert_allclose(wheel_speeds(0.0, 1.0, 0.033, 0.16), [-0.08 / 0.033, 0.08 / 0.033])


def test_unicycle_rollout_matches_the_exact_circle() -> None:
    v, w, t_end = 0.5, 0.4, 3.0
    states = rollout(unicycle_rhs, [0, 0, 0], np.tile([v, w], (30, 1)), t_end / 30)
    r = v / w
    exact = [r * np.sin(w * t_end), r * (1 - np.cos(w * t_end)), w * t_end]
    np.testing.assert_allclose(states[-1], exact, atol=1e-9)


def test_bicycle_model_against_an_independent_integrator() -> None:
    wheelbase, u = 0.1, np.array([0.2, 0.3])
    x0 = np.array([0.0, 0.0, 0.1, -0.2])
    ref = solve_ivp(lambda t, x: bicycle_rhs(x, u, wheelbase), (0, 2), x0, rtol=1e-11, atol=1e-12).y[:, -1]
    x = x0
    for _ in range(400):
        x = rk4_step(lambda s, uu: bicycle_rhs(s, uu, wheelbase), x, u, 0.005)
    np.testing.assert_allclose(x, ref, atol=1e-8)


def test_bicycle_runs_on_a_differential_drive_with_omega_v_tan_phi_over_l() -> None:
    st = np.array([[0, 0, 0, 0.3]])
    vw = bicycle_to_unicycle(st, np.array([[0.2, 1.0]]), 0.1)
    np.testing.assert_allclose(vw, [[0.2, 0.2 * np.tan(0.3) / 0.1]])
    # and the pose part of the bicycle equals the unicycle under that mapping
    full = bicycle_rhs(st, np.array([[0.2, 1.0]]), 0.1)
    np.testing.assert_allclose(full[0, :3], unicycle_rhs(st[:, :3], vw)[0])
