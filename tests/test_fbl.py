"""The dynamic feedback-linearisation tracker on an ideal unicycle (no MuJoCo)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from control.fbl import DynamicFBL, fbl_law_kernel
from control.gains import FBLGains
from planning.core.geometry import Pose2D
from planning.core.kinematics import rk4_step, unicycle_rhs
from planning.core.robot import load_robot
from planning.errors import ConfigError
from planning.trajectory.references import circle, figure8
from tests.reference_laws import fbl_law, xi_period


def _analytic_error(e0: float, de0: float, kp: float, kd: float, t: np.ndarray) -> np.ndarray:
    """Solution of e'' + kd e' + kp e = 0 with e(0) = e0, e'(0) = de0 (distinct real or complex roots)."""
    disc = kd * kd - 4 * kp
    if disc < 0:
        a, w = -kd / 2, math.sqrt(-disc) / 2
        return np.exp(a * t) * (e0 * np.cos(w * t) + (de0 - a * e0) / w * np.sin(w * t))
    r1, r2 = (-kd + math.sqrt(disc)) / 2, (-kd - math.sqrt(disc)) / 2
    c2 = (de0 - r1 * e0) / (r2 - r1)
    return (e0 - c2) * np.exp(r1 * t) + c2 * np.exp(r2 * t)


@pytest.mark.parametrize("gains", [FBLGains(kp=4.0, kd=2.0), FBLGains(kp=9.0, kd=7.0)])
def test_error_follows_the_promised_linear_dynamics(gains: FBLGains) -> None:
    robot = load_robot("turtlebot3")
    ref = circle(robot, Pose2D(0, 0, 0), radius=0.8, dt=0.0005)
    _dxy, _ddxy = ref.flat_derivatives()

    def reference(t: float) -> tuple[float, ...]:
        s = ref.sample(t)
        return (*s.pose[:2], *s.flat_vel, *s.flat_acc)

    # start mid-circle (cruising, so xi stays far from the guarded singularity), off the reference
    # and with a speed and heading the reference does not have
    t0 = 5.0
    r_start = reference(t0)
    x0 = np.array([r_start[0] + 0.03, r_start[1] - 0.02, np.arctan2(r_start[3], r_start[2]) + 0.15, 0.1])

    def closed_loop(t: float, s: np.ndarray) -> list[float]:
        xi_dot, omega = fbl_law_kernel(gains.kp, gains.kd, gains.xi_min, s[0], s[1], s[2], s[3], *reference(t))
        return [s[3] * math.cos(s[2]), s[3] * math.sin(s[2]), omega, xi_dot]

    t_eval = np.linspace(t0, t0 + 6, 61)
    sol = solve_ivp(closed_loop, (t0, t0 + 6), x0, t_eval=t_eval, rtol=1e-10, atol=1e-12, max_step=0.01)
    assert np.all(np.abs(sol.y[3]) > FBLGains().xi_min)
    r0 = reference(t0)
    for axis in (0, 1):
        e0 = x0[axis] - r0[axis]
        de0 = x0[3] * (math.cos(x0[2]) if axis == 0 else math.sin(x0[2])) - r0[2 + axis]
        expected = _analytic_error(e0, de0, gains.kp, gains.kd, t_eval - t0)
        measured = sol.y[axis] - ref.sample_many(t_eval).pose[:, axis]
        # the reference is interpolated linearly from samples 0.5 ms apart: error budget ~1e-6 m
        np.testing.assert_allclose(measured, expected, atol=2e-6)


def test_discrete_tracker_converges_on_an_ideal_unicycle() -> None:
    robot = load_robot("edumip")
    ref = figure8(robot, Pose2D(0, 0, 0.0))
    dt = 0.02
    tracker = DynamicFBL(robot)
    tracker.reset(ref, dt)
    state = np.array([0.05, -0.05, 0.2])
    errors = []
    for k in range(int(ref.duration / dt)):
        v, w = tracker.command(k * dt, *state)
        assert abs(v) <= robot.max_speed and abs(w) <= robot.max_yaw_rate
        for _ in range(10):
            state = rk4_step(unicycle_rhs, state, np.array([v, w]), dt / 10)
        errors.append(np.hypot(*(state[:2] - ref.sample((k + 1) * dt).pose[:2])))
    assert errors[-1] < 1e-3
    assert max(errors[len(errors) // 2 :]) < 2e-3


def test_singularity_guard_keeps_commands_finite_and_saturated() -> None:
    robot = load_robot("turtlebot3")
    ref = figure8(robot, Pose2D(0, 0, 0))
    tracker = DynamicFBL(robot)
    tracker.reset(ref, 0.02)
    tracker.xi = 0.0
    # far off, facing away, at rest: the law divides by the guarded xi
    for k in range(50):
        v, w = tracker.command(k * 0.02, 1.0, -1.0, math.pi)
        assert math.isfinite(v) and math.isfinite(w)
        assert abs(v) <= robot.max_speed and abs(w) <= robot.max_yaw_rate
    g = FBLGains()
    xi_dot, omega = fbl_law_kernel(g.kp, g.kd, g.xi_min, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0)
    assert math.isfinite(xi_dot) and math.isfinite(omega)
    assert (xi_dot, omega) == fbl_law(g, 0.0, 0.0, 0.0, 0.0, (1.0, 1.0, 0.0, 0.0, 0.0, 0.0))


def test_the_compiled_law_is_the_python_reference_bit_for_bit() -> None:
    """The compiled law (control/fbl.py) against the plain-Python one (tests/reference_laws.py), on
    random poses, speeds (through the guard band and zero) and references."""
    rng = np.random.default_rng(11)
    for _ in range(2000):
        g = FBLGains(
            kp=float(rng.uniform(0.5, 20)), kd=float(rng.uniform(0.5, 10)), xi_min=float(rng.uniform(0.001, 0.1))
        )
        pose = rng.normal(0, [2, 2, 4]).tolist()
        xi = float(rng.choice([0.0, rng.normal(0, 0.01), rng.normal(0, 0.3)]))
        ref = rng.normal(0, [2, 2, 0.3, 0.3, 0.5, 0.5]).tolist()
        assert fbl_law_kernel(g.kp, g.kd, g.xi_min, *pose, xi, *ref) == fbl_law(g, *pose, xi, ref)


def _python_period(tracker: DynamicFBL, dt: float, pose: tuple[float, float, float], ref: tuple) -> tuple:
    """One period of the module doc's law in plain Python (tests/reference_laws.py): (v, omega, next xi)."""
    xi_dot, omega = fbl_law(tracker.gains, *pose, tracker.xi, ref)
    vmax, wmax = tracker.robot.max_speed, tracker.robot.max_yaw_rate
    v, xi = xi_period(tracker.xi, xi_dot, dt, vmax, 0.0)
    return min(max(v, -vmax), vmax), min(max(omega, -wmax), wmax), xi


def test_a_period_is_the_law_at_and_between_control_instants() -> None:
    """The compiled period gives the law's saturated command and xi, bit for bit, on the pre-sampled
    reference at a control instant and on the interpolated reference between them."""
    robot = load_robot("turtlebot3")
    ref = figure8(robot, Pose2D(0.3, -0.2, 0.4))
    tracker = DynamicFBL(robot, gains=FBLGains(kp=5.0, kd=3.0))
    dt = 0.02
    tracker.reset(ref, dt)
    rng = np.random.default_rng(3)
    for t in [0.0, 0.02, 1.0, 3.37, 7.001, 12.5, ref.duration + 0.5]:
        pose = (float(ref.sample(t).pose[0] + rng.normal(0, 0.05)), float(ref.sample(t).pose[1]), 0.3)
        s = ref.sample_many(np.array([t]))
        expected = _python_period(tracker, dt, pose, (s.x[0], s.y[0], s.dx[0], s.dy[0], s.ddx[0], s.ddy[0]))
        assert (*tracker.command(t, *pose), tracker.xi) == expected, t


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), True])
def test_gains_reject_non_positive_and_non_finite(bad: float) -> None:
    with pytest.raises(ConfigError, match="kp"):
        FBLGains(kp=bad)
    with pytest.raises(ConfigError, match="kd"):
        FBLGains(kd=bad)


@pytest.mark.parametrize("text", ["1", "1,2,3", "a,b", "1,-2", "0,1", ""])
def test_gain_strings_are_validated(text: str) -> None:
    with pytest.raises(ConfigError):
        FBLGains.parse(text)
    assert FBLGains.parse(" 4, 3 ") == FBLGains(kp=4.0, kd=3.0)


def test_one_xi_discretisation_is_the_python_reference_bit_for_bit() -> None:
    """control/fbl.py's xi_period (FBL: no direction; segmented: a drive's side of zero, floored)
    against tests/reference_laws.py, and its rule: xi within +-vmax, on the drive's side."""
    from control.fbl import XI_FLOOR
    from control.fbl import xi_period as compiled

    rng = np.random.default_rng(13)
    for _ in range(3000):
        xi, xi_dot, sign = float(rng.normal(0, 0.2)), float(rng.normal(0, 5)), float(rng.choice([-1.0, 0.0, 1.0]))
        v, nxt = compiled(xi, xi_dot, 0.02, 0.22, sign)
        assert (v, nxt) == xi_period(xi, xi_dot, 0.02, 0.22, sign)
        assert v == xi + 0.5 * xi_dot * 0.02 and abs(nxt) <= 0.22
        if sign != 0.0:
            assert sign * nxt >= XI_FLOOR
