"""Every built-in scenario with every applicable planner and robot, planned, smoothed and tracked.

The rule for which planners apply is :func:`sim.jobs.applicable_planners`; robots are the ones a
scenario lists (``robots``). The library returns the rows; ``nhsim simulate --all`` prints them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from control.fbl import FBLGains
from planning.errors import NhsimError
from planning.scenario import builtin_scenarios, load_scenario
from planning.to_trajectory import PlanFailedError
from sim.jobs import applicable_planners, simulate_plan
from sim.simulator import SimConfig

#: What a closed-loop run must reach to count as a success in the table.
TARGETS = {"final_position_error_m": 0.02, "final_heading_error_rad": 0.05, "rms_position_error_m": 0.02}


def matrix_cases(scenarios: list[str] | None = None) -> list[tuple[str, str, str]]:
    """(scenario, robot, planner) triples to run, in a stable order."""
    cases = []
    for name in scenarios if scenarios is not None else builtin_scenarios():
        sc = load_scenario(name)
        for robot in sc.robots:
            for planner in applicable_planners(sc):
                cases.append((sc.name, robot, planner))
    return cases


def run_case(
    scenario: str,
    robot: str,
    planner: str,
    *,
    seed: int = 0,
    gains: FBLGains | None = None,
    control_rate: float = 50.0,
    time_limit: float = 30.0,
) -> dict[str, Any]:
    """Plan, smooth and track one case; a failure is a row with ``success`` False and a reason."""
    row: dict[str, Any] = {"scenario": scenario, "robot": robot, "planner": planner, "seed": seed}
    try:
        cfg = SimConfig(control_rate=control_rate, hold=2.0)
        job = simulate_plan(scenario, robot=robot, planner=planner, seed=seed, gains=gains, config=cfg,
                            time_limit=time_limit)  # fmt: skip
    except PlanFailedError as exc:
        row.update({"success": False, "stage": "plan", "reason": str(exc)})
        return row
    except NhsimError as exc:
        row.update({"success": False, "stage": "trajectory", "reason": str(exc)})
        return row
    rec = job.record()
    cl, ol = rec.get("closed_loop", {}), rec.get("open_loop", {})
    ok = (
        all(cl.get(k, float("inf")) <= v for k, v in TARGETS.items())
        and cl.get("collisions", 1) == 0
        and cl.get("warnings", 1) == 0
    )
    row.update({
        "success": bool(ok), "stage": "track", "reason": "" if ok else "closed loop missed a target (see the errors)",
        "plan_time_s": rec["plan"].get("time_s"), "plan_length_m": rec["plan"].get("length_m"),
        "duration_s": rec["trajectory"]["duration_s"], "smoothing": rec["smoothing"],
        "closed_loop": cl, "open_loop": ol,
    })  # fmt: skip
    return row


def run_matrix(
    cases: list[tuple[str, str, str]],
    *,
    progress: Callable[[dict[str, Any]], None] | None = None,
    **options: Any,
) -> list[dict[str, Any]]:
    """Run every case (see :func:`run_case` for ``options``), calling ``progress`` after each."""
    rows = []
    for scenario, robot, planner in cases:
        row = run_case(scenario, robot, planner, **options)
        rows.append(row)
        if progress is not None:
            progress(row)
    return rows


def format_matrix_row(row: dict[str, Any]) -> str:
    """One line of the ``--all`` table."""
    head = f"{row['scenario']:<17} {row['robot']:<10} {row['planner']:<11}"
    if "closed_loop" not in row:
        return f"{head} {'FAIL':>4}  {row['reason'][:90]}"
    cl, ol = row["closed_loop"], row["open_loop"]
    pt = row["plan_time_s"]
    return (
        f"{head} {'ok' if row['success'] else 'FAIL':>4} {pt if pt is not None else float('nan'):>8.2f} "
        f"{cl['final_position_error_m']:>9.4f} {cl['final_heading_error_rad']:>9.4f} "
        f"{cl['rms_position_error_m']:>8.4f} "
        f"{cl['collisions']:>4d} {cl['warnings']:>4d} | {ol.get('final_position_error_m', float('nan')):>9.4f} "
        f"{ol.get('rms_position_error_m', float('nan')):>8.4f} {ol.get('collisions', 0):>4d}"
    )


def matrix_header() -> str:
    """Column titles of the ``--all`` table (closed loop | open loop)."""
    head = (
        f"{'scenario':<17} {'robot':<10} {'planner':<11} {'ok':>4} {'plan [s]':>8} {'fin pos':>9} {'fin head':>9} "
        f"{'rms pos':>8} {'coll':>4} {'warn':>4} | {'OL fin':>9} {'OL rms':>8} {'coll':>4}"
    )
    return head + "\n" + "-" * len(head)
