r"""Nonlinear model-predictive tracking of a unicycle, solved with CasADi each control period.

Over a horizon of N steps of ``step`` seconds from the measured pose x_0, with the unicycle
x' = (v cos theta, v sin theta, omega) integrated by one RK4 step per horizon step (multiple
shooting), the controller solves

    min  sum_k h [ q_p |p_{k+1} - p^r_{k+1}|^2 + q_theta (theta_{k+1} - theta^r_{k+1})^2
                   + r_v (v_k - v^r_k)^2 + r_omega (omega_k - omega^r_k)^2
                   + r_a (dv_k / h)^2 + r_alpha (domega_k / h)^2 ]
         + terminal * (q_p |p_N - p^r_N|^2 + q_theta (theta_N - theta^r_N)^2)
    s.t. |v_k| <= v_max, |omega_k| <= omega_max, |v_k| + |omega_k| b / 2 <= r w_max  (wheel speed),
         |v_k - v_{k-1}| <= a_max h_k, |omega_k - omega_{k-1}| <= alpha_max h_k,

with (v_{-1}, omega_{-1}) the command in force and h_0 the control period (h_k = step after), and
applies (v_0, omega_0). The rate terms price the change of the input beyond the reference's own
change, dv_k = (v_k - v_{k-1}) - (v^r_k - v^r_{k-1}) (at k = 0 the reference's change over one
control period, extrapolated), so following an accelerating reference costs nothing; the
constraints bound the change itself. The robot's limits (:class:`planning.core.robot.RobotSpec`)
are the constraints. The measured heading is unwrapped to the reference's branch, so the quadratic
heading cost never sees a 2 pi jump. The reference past the trajectory's end is its final pose at
rest, so the same problem regulates the goal.

The NLP is built once per (robot, parameters, period) with ``expand=True`` (SX) and kept; each
solve is warm-started from the previous solution shifted by one control period, primal and dual
(CasADi's ``x0``, ``lam_x0``, ``lam_g0``). Three solvers (``MPCParams.solver``):

* ``"rti"`` (default), the real-time iteration (M. Diehl, H. G. Bock, J. P. Schloeder, SIAM J.
  Control Optim. 43(5), 2005; acados' SQP_RTI): one full step of CasADi's ``sqpmethod`` per control
  period (exact Hessian, regularised to convexity, no line search) from the shifted previous
  solution. Its cost is one linearisation and one QP, the same every period, so its time has no
  tail of many-iteration solves; the solution is never iterated to convergence, but the next period
  starts from it, so over the periods the iterates contract to the moving optimum. Its result is
  used when the step's QP met the input constraints (linear, so a correct QP meets them exactly);
  the shooting gaps left by one step are the method's.
* ``"sqp"``, the same ``sqpmethod`` iterated to convergence (``max_iter``).
* ``"ipopt"``, the interior-point method, warm-started with ``warm_start_init_point``.

The QP solver of the first two is DAQP (D. Arnstroem, A. Bemporad, D. Axehill, IEEE Trans.
Automatic Control 67(8), 2022; ``qp_solver="daqp"``, default), a dual active-set method for small
dense QPs, or CasADi's ``qrqp``, which on the default job's cusps stopped at an infeasible point in
about half the one-step QPs. ``nhsim bench track`` measures them all.

Solve times are recorded (:meth:`MPCTracker.stats`), with the solves that ran past the control
period. A solve that fails (solver error, not converged, or a non-finite solution) is counted and
the command falls back to the last feasible plan at the current time, or, past its end, brakes
towards rest within the acceleration limits: the command is always finite and within the limits.

The model accepts every trajectory: v may take either sign, so cusps and turns in place are part
of the optimisation, with no segment switching.

Interrupts: CasADi polls Python for signals inside a solve (its interrupt check calls the Python
signal handlers), and a ``KeyboardInterrupt`` raised there is caught inside the solver, which ends
the solve as failed (it warns ``KeyboardInterruptException``) and returns: the interrupt would be
lost. Reading its results is no safer: numpy converts a CasADi matrix through ``DM.__array__``,
whose compiled wrapper calls Python back, and an interrupt raised in there leaves the wrapper with an
exception set, which Python reports as a ``SystemError`` (the command then crashed with exit 1 instead
of stopping with 130). So SIGINT and SIGTERM are held for the solve's few milliseconds and the reading
of its results (:func:`planning.signals.signals_held`) and delivered to their own handlers as that
returns: Ctrl-C or SIGTERM stops a run of this tracker as promptly as any other.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from control.base import check_ranges, option_value, ranged
from control.inputs import check_command, check_reset, not_reset
from planning.casadi_env import SOLVER_LOCK, casadi_module
from planning.core.robot import RobotSpec
from planning.errors import ConfigError, DependencyError
from planning.signals import signals_held
from planning.trajectory.trajectory import Trajectory

FloatArray = NDArray[np.float64]

#: The solvers: "rti" (one full step of CasADi's sqpmethod per control period, the real-time
#: iteration), "sqp" (sqpmethod iterated to convergence) and "ipopt".
SOLVERS = ("rti", "sqp", "ipopt")
#: The QP solvers of "rti" and "sqp" (CasADi conic plugins): DAQP, a dual active-set method for small
#: dense QPs, and CasADi's own active-set ``qrqp``.
QP_SOLVERS = ("daqp", "qrqp")
#: sqpmethod's status when its line search can make no further step from a feasible iterate: the
#: iterate is stationary to the step tolerance, so the solve counts as converged if it is feasible
#: (every constraint met within ``_FEASIBILITY``).
_STATIONARY = frozenset({"Search_Direction_Becomes_Too_Small"})
_FEASIBILITY = 1e-6
#: sqpmethod's status after the one iteration "rti" allows (the step is taken, as the real-time
#: iteration means it to be).
_ONE_STEP = frozenset({"Maximum_Iterations_Exceeded"})


@dataclass(frozen=True)
class MPCParams:
    """Horizon, weights and solver of the MPC (ranges checked; out of range raises ConfigError).

    Attributes:
        horizon: Horizon steps N.
        step: Model step h of the horizon [s].
        q_position: Position error weight q_p [1/(m^2 s)].
        q_heading: Heading error weight q_theta [1/(rad^2 s)].
        r_speed: Speed deviation weight r_v [s/m^2].
        r_yaw_rate: Yaw-rate deviation weight r_omega [s/rad^2].
        r_accel: Acceleration weight r_a [s^3/m^2].
        r_yaw_accel: Yaw acceleration weight r_alpha [s^3/rad^2].
        terminal: Terminal weight factor (times q_p, q_theta) [s].
        max_iter: Iteration cap of one solve ("rti" makes one iteration whatever it says).
        solver: "rti" (one SQP step a period), "sqp" (SQP to convergence) or "ipopt".
        qp_solver: The QP solver of "rti" and "sqp": "daqp" or "qrqp".
    """

    horizon: int = ranged(15, 2, 200, "steps")
    step: float = ranged(0.04, 0.005, 1.0, "s")
    q_position: float = ranged(100.0, 1e-6, 1e6, "1/(m^2 s)", tune=(1.0, 1e4))
    q_heading: float = ranged(1.0, 0.0, 1e6, "1/(rad^2 s)", tune=(0.01, 1e3))
    r_speed: float = ranged(1.0, 0.0, 1e6, "s/m^2", tune=(0.01, 100.0))
    r_yaw_rate: float = ranged(0.1, 0.0, 1e6, "s/rad^2", tune=(0.001, 10.0))
    r_accel: float = ranged(0.05, 0.0, 1e6, "s^3/m^2", tune=(1e-4, 10.0))
    r_yaw_accel: float = ranged(0.005, 0.0, 1e6, "s^3/rad^2", tune=(1e-5, 1.0))
    terminal: float = ranged(0.5, 0.0, 1e3, "s", tune=(0.01, 10.0))
    max_iter: int = ranged(50, 1, 1000, "iterations")
    solver: str = "rti"
    qp_solver: str = "daqp"

    def __post_init__(self) -> None:
        check_ranges(self)
        if self.solver not in SOLVERS:
            raise ConfigError(f"MPCParams.solver must be one of {', '.join(SOLVERS)}, got {self.solver!r}")
        if self.qp_solver not in QP_SOLVERS:
            raise ConfigError(f"MPCParams.qp_solver must be one of {', '.join(QP_SOLVERS)}, got {self.qp_solver!r}")


@dataclass(frozen=True)
class _Limits:
    """The constraint values of one robot and control period (hashable: the solver cache's key)."""

    v: float
    w: float
    wheel: float
    half_track: float
    accel: float
    yaw_accel: float
    dt: float


def _casadi() -> Any:
    return casadi_module("the 'mpc' tracker")


def _transcribe(p: MPCParams, lim: _Limits) -> tuple[dict[str, Any], FloatArray, FloatArray]:
    """The NLP of the module doc (symbols), and the bounds of its constraints g (lbg, ubg)."""
    ca = _casadi()
    n, h = p.horizon, p.step
    xs, us = ca.SX.sym("X", 3, n + 1), ca.SX.sym("U", 2, n)
    x0, ref, uref, uprev = ca.SX.sym("x0", 3), ca.SX.sym("R", 3, n + 1), ca.SX.sym("UR", 2, n), ca.SX.sym("up", 2)

    def f(x: Any, u: Any) -> Any:
        return ca.vertcat(u[0] * ca.cos(x[2]), u[0] * ca.sin(x[2]), u[1])

    q = ca.DM([p.q_position, p.q_position, p.q_heading])
    r, rd = ca.DM([p.r_speed, p.r_yaw_rate]), ca.DM([p.r_accel, p.r_yaw_accel])
    g, cost, prev, lo, hi = [xs[:, 0] - x0], 0, uprev, [0.0] * 3, [0.0] * 3
    for k in range(n):
        x, u = xs[:, k], us[:, k]
        k1 = f(x, u)
        k2 = f(x + h / 2 * k1, u)
        k3 = f(x + h / 2 * k2, u)
        g.append(xs[:, k + 1] - (x + h / 6 * (k1 + 2 * k2 + 2 * k3 + f(x + h * k3, u))))
        # the input's change beyond the reference's (extrapolated back one control period at k = 0)
        change = uref[:, k] - uref[:, k - 1] if k else (uref[:, min(1, n - 1)] - uref[:, 0]) * (lim.dt / h)
        e, du = xs[:, k + 1] - ref[:, k + 1], u - prev - change
        cost += h * (ca.dot(q * e, e) + ca.dot(r * (u - uref[:, k]), u - uref[:, k])) + ca.dot(rd * du, du) / h
        g += [u - prev, ca.vertcat(u[0] + lim.half_track * u[1], u[0] - lim.half_track * u[1])]
        span = lim.dt if k == 0 else h
        lo += [0.0] * 3 + [-lim.accel * span, -lim.yaw_accel * span, -lim.wheel, -lim.wheel]
        hi += [0.0] * 3 + [lim.accel * span, lim.yaw_accel * span, lim.wheel, lim.wheel]
        prev = u
    e = xs[:, n] - ref[:, n]
    cost += p.terminal * ca.dot(q * e, e)
    nlp = {"x": ca.vertcat(ca.vec(xs), ca.vec(us)), "p": ca.vertcat(x0, ca.vec(ref), ca.vec(uref), uprev),
           "f": cost, "g": ca.vertcat(*g)}  # fmt: skip
    return nlp, np.array(lo), np.array(hi)


@lru_cache(maxsize=16)
def _solver(p: MPCParams, lim: _Limits) -> tuple[Any, FloatArray, FloatArray]:
    """The CasADi solver of (params, limits), built once and kept, with its constraint bounds."""
    ca = _casadi()
    nlp, lbg, ubg = _transcribe(p, lim)
    quiet = {"expand": True, "print_time": False, "error_on_fail": False}
    if p.solver == "ipopt":
        ipopt = {"print_level": 0, "sb": "yes", "warm_start_init_point": "yes", "max_iter": p.max_iter}
        return ca.nlpsol("mpc", "ipopt", nlp, {**quiet, "ipopt": ipopt}), lbg, ubg
    qp: dict[str, Any] = {"error_on_fail": False}
    if p.qp_solver == "qrqp":
        qp |= {"print_iter": False, "print_header": False, "print_info": False, "max_iter": 100}
    elif not ca.has_conic(p.qp_solver):  # pragma: no cover - CasADi's wheels carry DAQP
        raise DependencyError(f"this CasADi has no {p.qp_solver!r} QP plugin; use MPCParams(qp_solver='qrqp')")
    opts = {**quiet, "qpsol": p.qp_solver, "qpsol_options": qp, "max_iter": p.max_iter, "print_header": False,
            "print_iteration": False, "print_status": False, "convexify_strategy": "regularize"}  # fmt: skip
    if p.solver == "rti":  # one full Newton-type step from the shifted guess: no line search
        opts |= {"max_iter": 1, "max_iter_ls": 0}
    return ca.nlpsol("mpc", "sqpmethod", nlp, opts), lbg, ubg


@lru_cache(maxsize=16)
def _shift_weights(n: int, h: float, dt: float) -> tuple[FloatArray, FloatArray]:
    """Linear interpolation one control period ``dt`` [s] on along a horizon of ``n`` steps of ``h`` [s],
    as matrices: shifted states = (N + 1, N + 1) @ states, shifted inputs = (N, N) @ inputs (the last
    entries held)."""
    grid = h * np.arange(n + 1)
    at = np.minimum(grid + dt, grid[-1])
    states = np.array([np.interp(at, grid, e) for e in np.eye(n + 1)]).T
    inputs = np.array([np.interp(at[:-1], grid[:-1], e) for e in np.eye(n)]).T
    return states, inputs


@lru_cache(maxsize=16)
def _input_bounds(n: int, v: float, w: float) -> tuple[FloatArray, FloatArray]:
    """(lbx, ubx) of the decision vector: states free, |v| <= v [m/s], |omega| <= w [rad/s]."""
    ubx = np.full(3 * (n + 1) + 2 * n, np.inf)
    ubx[3 * (n + 1) :: 2], ubx[3 * (n + 1) + 1 :: 2] = v, w
    return -ubx, ubx


class MPCTracker:
    """Nonlinear MPC on the unicycle with the robot's limits as constraints (see the module doc).

    Source: the formulation follows J. B. Rawlings, D. Q. Mayne, M. M. Diehl, "Model Predictive
    Control: Theory, Computation, and Design", 2nd ed., Nob Hill, 2017 (tracking MPC, ch. 1-2; real-
    time iterations and warm starts, ch. 8); multiple shooting after H. G. Bock, K. J. Plitt, IFAC
    1984; solved with CasADi (J. A. E. Andersson et al., Mathematical Programming Computation 11,
    2019), warm-started as its documentation describes (``x0``, ``lam_x0``, ``lam_g0``).

    Args:
        robot: Limits: max_speed, max_yaw_rate, max_accel, max_yaw_accel, the wheel-speed limit.
        params: Horizon, weights and solver; None for ``MPCParams()``.

    Raises:
        ConfigError: ``params`` is not an :class:`MPCParams`.
    """

    name = "mpc"
    #: The option ``nhsim tune --tracker`` tunes, and its dataclass.
    TUNED = ("params", MPCParams)

    def __init__(self, robot: RobotSpec, *, params: MPCParams | None = None) -> None:
        self.robot = robot
        self.params = option_value(self.name, "params", params, MPCParams())
        self._traj: Trajectory | None = None
        self._dt = 0.02
        self._lim: _Limits | None = None
        self._guess: FloatArray = np.zeros(0)
        self._lam: tuple[Any, Any] | None = None
        self._plan: tuple[float, FloatArray] | None = None  # (start time, (N, 2) inputs) of the last feasible plan
        self._u = np.zeros(2)
        self.solve_times: list[float] = []
        self.solve_cpu_times: list[float] = []
        self.failures = 0

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking: build (or reuse) the solver, then solve once from the start pose so the
        first control period starts warm (that solve is not counted).

        Raises:
            ConfigError: ``trajectory`` is not a Trajectory, or ``dt`` [s] is not a finite number > 0.
        """
        self._dt = check_reset(self.name, trajectory, dt)
        self._traj = trajectory
        r = self.robot
        self._lim = _Limits(r.max_speed, r.max_yaw_rate, r.max_wheel_speed * r.wheel_radius, r.track_width / 2.0,
                            r.max_accel, r.max_yaw_accel, self._dt)  # fmt: skip
        n = self.params.horizon
        ref, uref = self._reference(float(trajectory.t[0]))
        self._guess = np.concatenate([ref.T.ravel(), uref.T.ravel()])
        self._lam, self._plan = None, None
        self._u = uref[:, 0].copy()
        x0 = trajectory.pose[0]
        self._solve(float(trajectory.t[0]), float(x0[0]), float(x0[1]), float(x0[2]))
        self.solve_times, self.solve_cpu_times, self.failures = [], [], 0
        self._u = np.array([float(trajectory.vel[0, 0]), float(trajectory.vel[0, 1])])
        assert self._guess.size == 3 * (n + 1) + 2 * n

    def _reference(self, t: float) -> tuple[FloatArray, FloatArray]:
        """(3, N + 1) reference poses at the horizon's instants and (2, N) reference inputs at the
        midpoints of its steps, from ``t``."""
        if self._traj is None:
            raise not_reset(self.name)
        n, h = self.params.horizon, self.params.step
        # the horizon's instants, then the midpoints of its steps (a held input is best at its midpoint)
        s = self._traj.sample_many(t + h * np.concatenate([np.arange(n + 1.0), np.arange(n) + 0.5]))
        return np.vstack([s.x[: n + 1], s.y[: n + 1], s.theta[: n + 1]]), np.vstack([s.v[n + 1 :], s.omega[n + 1 :]])

    def _solve(self, t: float, x: float, y: float, theta: float) -> FloatArray | None:
        """One warm-started solve from the pose at ``t``: the (N, 2) inputs, or None if it failed; the process's
        solver of this horizon built and called with CasADi's lock held (:data:`planning.casadi_env.SOLVER_LOCK`)."""
        with SOLVER_LOCK:
            return self._solve_held(t, x, y, theta)

    def _solve_held(self, t: float, x: float, y: float, theta: float) -> FloatArray | None:
        assert self._lim is not None
        solver, lbg, ubg = _solver(self.params, self._lim)
        n, lim = self.params.horizon, self._lim
        ref, uref = self._reference(t)
        theta += 2.0 * math.pi * round((float(ref[2, 0]) - theta) / (2.0 * math.pi))  # the reference's branch
        p = np.concatenate([[x, y, theta], ref.T.ravel(), uref.T.ravel(), self._u])
        lbx, ubx = _input_bounds(n, lim.v, lim.w)
        args: dict[str, Any] = {"x0": self._guess, "p": p, "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
        if self._lam is not None:
            args["lam_x0"], args["lam_g0"] = self._lam
        try:
            with signals_held():  # CasADi would swallow them, or turn them into errors (see the module doc)
                sol = self._call(solver, args)
                status = solver.stats()
                z = np.asarray(sol["x"], dtype=float).ravel()
                g = np.asarray(sol["g"], dtype=float).ravel()
        except RuntimeError:
            return None
        if not self._accepted(status, g, lbg, ubg) or not np.all(np.isfinite(z)):
            return None
        self._lam = (sol["lam_x"], sol["lam_g"])
        self._guess = self._shifted(z)
        return z[3 * (n + 1) :].reshape(n, 2)

    def _accepted(self, status: dict[str, Any], g: FloatArray, lbg: FloatArray, ubg: FloatArray) -> bool:
        """Whether a solve's result is used: converged, or stationary and feasible; for "rti" its one
        step taken with the input constraints (linear, so met by the step's QP) holding."""
        excess = np.maximum(lbg - g, g - ubg)  # > 0 where a constraint is violated
        if self.params.solver == "rti":
            stepped = status.get("success", False) or status.get("return_status") in _ONE_STEP
            return bool(stepped and np.all(excess[lbg < ubg] <= _FEASIBILITY))  # the dynamics' gap is RTI's
        feasible = bool(np.all(excess <= _FEASIBILITY))
        return bool(status.get("success", False) or (status.get("return_status") in _STATIONARY and feasible))

    def _call(self, solver: Any, args: dict[str, Any]) -> Any:
        """Call the solver (a seam: tests replace it to force a failure)."""
        return solver(**args)

    def _shifted(self, z: FloatArray) -> FloatArray:
        """The solution moved one control period on: the next solve's initial guess."""
        n = self.params.horizon
        shift_x, shift_u = _shift_weights(n, self.params.step, self._dt)
        xs, us = z[: 3 * (n + 1)].reshape(n + 1, 3), z[3 * (n + 1) :].reshape(n, 2)
        return np.concatenate([(shift_x @ xs).ravel(), (shift_u @ us).ravel()])

    def _fallback(self, t: float) -> FloatArray:
        """The command after a failed solve: the last feasible plan at ``t``, else rest, reached from the
        command in force within the acceleration limits of one control period."""
        assert self._lim is not None
        target = np.zeros(2)
        if self._plan is not None:
            start, inputs = self._plan
            k = math.floor((t - start) / self.params.step + 1e-9)
            if 0 <= k < inputs.shape[0]:  # a time before the plan's (a clock run back) has none of its inputs
                target = inputs[k]
        step = np.array([self._lim.accel, self._lim.yaw_accel]) * self._dt
        return np.asarray(self._u + np.clip(target - self._u, -step, step))

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Solve, apply the first input (or fall back, see the module doc); record the solve time.

        Raises:
            ConfigError: An argument is not a number (an array, a text).
            SimulationError: ``t`` or the pose is not finite.
        """
        check_command(self.name, t, x, y, theta)
        if self._traj is None:
            raise not_reset(self.name)
        start, cpu = time.perf_counter(), time.thread_time()
        inputs = self._solve(t, x, y, theta)
        self.solve_times.append(time.perf_counter() - start)
        self.solve_cpu_times.append(time.thread_time() - cpu)
        if inputs is None:
            self.failures += 1
            u = self._fallback(t)
        else:
            self._plan = (t, inputs)
            u = inputs[0]
        vmax, wmax = self.robot.max_speed, self.robot.max_yaw_rate
        v, w = min(max(float(u[0]), -vmax), vmax), min(max(float(u[1]), -wmax), wmax)
        self._u = np.array([v, w])  # finite: the solver's inputs are checked, else the fallback is used
        return v, w

    def stats(self) -> dict[str, float | int]:
        """Solve statistics of the run so far: solves, failures, overruns (solves longer than the
        control period), mean, 95th percentile and max solve time [ms] by the wall clock, and the mean
        and 95th percentile of the CPU time of the solving thread [ms] (the wall clock less the time
        other processes held the core: what the solve itself costs on a shared machine)."""
        times, cpu = np.asarray(self.solve_times) * 1e3, np.asarray(self.solve_cpu_times) * 1e3
        out: dict[str, float | int] = {"solves": int(times.size), "failures": self.failures, "overruns": 0}
        out |= {"mean_ms": 0.0, "p95_ms": 0.0, "max_ms": 0.0, "cpu_mean_ms": 0.0, "cpu_p95_ms": 0.0}
        if times.size:
            out["overruns"] = int(np.count_nonzero(times > self._dt * 1e3))
            out["mean_ms"], out["p95_ms"] = float(times.mean()), float(np.percentile(times, 95))
            out["max_ms"] = float(times.max())
        if cpu.size:
            out |= {"cpu_mean_ms": float(cpu.mean()), "cpu_p95_ms": float(np.percentile(cpu, 95))}
        return out
