"""Control time per step of every tracker in the real robot's loop (``nhsim bench track``).

Each tracker drives the same reference in physics (the 'open' scenario's start, the as-built robot,
the fused estimate, :func:`sim.tools.compare.compare_trackers`), its every ``command`` timed by the
wall clock. MPC is run once per solver (by default the real-time iteration, SQP to convergence and
IPOPT) and its own solve times give the 95th percentile the issue asks for, by the wall clock and by
the solving thread's CPU time (the wall clock less preemption by other processes). Target: the 95th
percentile of the control time per step is within the control period (a tracker that cannot keep
50 Hz on this machine fails).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from control.base import feedback_trackers
from control.mpc import MPCParams
from sim.pipeline.case import Case
from sim.tools.compare import compare_trackers


@dataclass(frozen=True)
class TrackBench:
    """One tracker's timing.

    Attributes:
        label: Tracker name (MPC with its solver, e.g. "mpc (ipopt)").
        steps: Control periods timed.
        mean_ms: Mean control time per step [ms].
        p95_ms: Its 95th percentile [ms].
        max_ms: Its maximum [ms].
        over: Steps longer than the control period.
        period_ms: The control period [ms].
        solver: MPC's solver statistics (p95 solve time, failures, overruns), else {}.
        rms_m: RMS position error of the run [m] (that the tracker tracked while timed).
    """

    label: str
    steps: int
    mean_ms: float
    p95_ms: float
    max_ms: float
    over: int
    period_ms: float
    solver: dict[str, Any]
    rms_m: float

    @property
    def passed(self) -> bool:
        """The 95th percentile of the control time is within the control period."""
        return self.p95_ms <= self.period_ms


def measure(
    robot: str = "turtlebot3",
    reference: str = "figure8",
    trackers: Sequence[str] | None = None,
    *,
    control_rate: float = 50.0,
    mpc_solvers: Sequence[str] = ("rti", "sqp", "ipopt"),
) -> list[TrackBench]:
    """Time every tracker (MPC once per solver, each ``SOLVER[:QP]`` as :func:`mpc_params` reads it) on
    one reference in physics; ``trackers`` None: every registered tracker with feedback.

    Raises:
        ConfigError: Unknown robot, reference, tracker or solver.
    """
    case = Case("open", robot=robot, reference=reference, control_rate=control_rate)
    trackers = feedback_trackers() if trackers is None else trackers
    plain = [t for t in trackers if t != "mpc"]
    rows: list[TrackBench] = []
    jobs: list[tuple[str, list[str], dict[str, Any]]] = [("", plain, {})] if plain else []
    if "mpc" in trackers:
        jobs += [(f" ({solver})", ["mpc"], {"mpc": mpc_params(solver)}) for solver in mpc_solvers]
    for suffix, names, params in jobs:
        result = compare_trackers(replace(case), names, params=params)
        for run in result.runs:
            rows.append(_row(run, suffix, 1e3 / control_rate))
    return rows


def mpc_params(solver: str) -> MPCParams:
    """MPC's default parameters with the solver ``SOLVER[:QP]`` given, e.g. "rti" or "sqp:qrqp".

    Raises:
        ConfigError: An unknown solver or QP solver (names the valid ones).
    """
    name, _, qp = solver.partition(":")
    return MPCParams(solver=name, qp_solver=qp) if qp else MPCParams(solver=name)


def _row(run: Any, suffix: str, period_ms: float) -> TrackBench:
    import numpy as np

    times = np.asarray(run.times) * 1e3
    return TrackBench(
        run.tracker + (suffix if run.tracker == "mpc" else ""),
        int(times.size),
        float(times.mean()),
        float(np.percentile(times, 95)),
        float(times.max()),
        int(np.count_nonzero(times > period_ms)),
        period_ms,
        dict(run.solver),
        float(run.values["rms_m"]),
    )
