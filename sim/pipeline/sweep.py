"""Every built-in scenario with every applicable planner and robot, planned, smoothed and tracked.

The rule for which planners apply is :func:`sim.pipeline.simulate.applicable_planners`; robots are the ones a
scenario lists (``robots``). The library returns the rows; ``nhsim simulate --all`` prints them.

Every row has an ``outcome``: "ok" (every closed-loop target met), "FAIL", or "n/a". A case is
"n/a" only when the planner rejects the start or goal by a precondition of its own
(``INVALID_START`` / ``INVALID_GOAL``, e.g. C-RRT*'s 0.40 m centre clearance for the EduMIP, seed
003's rule) while that pose is free for the robot's footprint: the planner does not apply to the
scenario. Such rows are reported apart and not counted. Every other planner status (a timeout,
``BOUNDS_VIOLATED``, ``INFEASIBLE``, a colliding timed plan), a smoothing failure or a missed target
is a failure of that case.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from control.fbl import FBLGains
from planning.collision.exact import CollisionChecker
from planning.core.robot import load_robot
from planning.errors import NhsimError
from planning.planners.base import PlanProblem, PlanResult, PlanStatus
from planning.planners.registry import make_planner
from planning.scenario import Scenario, builtin_scenarios, load_scenario
from planning.trajectory.from_plan import PlanFailedError
from sim.physics.simulator import SimConfig
from sim.pipeline.simulate import applicable_planners, simulate_plan

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


def precondition_not_met(scenario: Scenario, plan: PlanResult) -> str | None:
    """Why a planner does not apply to a scenario, or None if it does (see the module doc).

    Args:
        scenario: The scenario, with the robot in use.
        plan: The planner's result on it.

    Returns:
        The planner's own reason when it rejected a start or goal that the robot's footprint fits;
        None for every other result (including a start or goal that collides for the robot itself,
        which is the scenario's fault and stays a failure).
    """
    which = {PlanStatus.INVALID_START: scenario.start, PlanStatus.INVALID_GOAL: scenario.goal}.get(plan.status)
    if which is None:
        return None
    checker = CollisionChecker(scenario.world, load_robot(scenario.robot), shape="footprint")
    if float(checker.clearance_of(which.as_array()[None, :])[0]) <= 0.0:
        return None
    return f"{plan.status.value} by the planner's own clearance rule: {plan.reason}"


def run_case(
    scenario: str,
    robot: str,
    planner: str,
    *,
    seed: int = 0,
    gains: FBLGains | None = None,
    control_rate: float = 50.0,
    time_limit: float = 30.0,
    planner_options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Plan, smooth and track one case; a failure is a row with ``success`` False and a reason.

    The planner gets the scenario's own options for it (``[planners.<name>]``), overridden by
    ``planner_options``. ``outcome`` is
    "ok", "FAIL" or "n/a" (see the module doc); ``stage`` says where a case ended ("precondition",
    "plan", "trajectory" or "track").
    """
    row: dict[str, Any] = {"scenario": scenario, "robot": robot, "planner": planner, "seed": seed}
    try:
        sc = load_scenario(scenario).with_robot(robot)
        problem = PlanProblem.from_scenario(sc, robot=load_robot(robot), seed=seed, time_limit=time_limit)
        plan = make_planner(planner, **{**sc.options_for(planner), **(planner_options or {})}).plan(problem)
        row["plan_status"] = plan.status.value
        na = precondition_not_met(sc, plan)
        if na is not None:
            row.update({"success": False, "outcome": "n/a", "stage": "precondition", "reason": na,
                        "plan_time_s": plan.stats.get("time_s")})  # fmt: skip
            return row
        cfg = SimConfig(control_rate=control_rate, hold=2.0)
        job = simulate_plan(sc, plan=plan, seed=seed, gains=gains, config=cfg)
    except PlanFailedError as exc:
        row.update({"success": False, "outcome": "FAIL", "stage": "plan", "reason": str(exc)})
        return row
    except NhsimError as exc:
        row.update({"success": False, "outcome": "FAIL", "stage": "trajectory", "reason": str(exc)})
        return row
    rec = job.record()
    cl, ol = rec.get("closed_loop", {}), rec.get("open_loop", {})
    ok = (
        all(cl.get(k, float("inf")) <= v for k, v in TARGETS.items())
        and cl.get("collisions", 1) == 0
        and cl.get("warnings", 1) == 0
    )
    row.update({
        "success": bool(ok), "outcome": "ok" if ok else "FAIL", "stage": "track",
        "reason": "" if ok else "closed loop missed a target (see the errors)",
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
        return f"{head} {row.get('outcome', 'FAIL'):>4}  {row['reason'][:90]}"
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


def matrix_summary(rows: list[dict[str, Any]]) -> list[str]:
    """Closing lines of the ``--all`` table: the count over applicable cases, every failure with its
    stage, and the cases that do not apply with their reasons."""
    na = [r for r in rows if r.get("outcome") == "n/a"]
    applicable = [r for r in rows if r.get("outcome") != "n/a"]
    ok = sum(bool(r["success"]) for r in applicable)
    lines = [f"{ok}/{len(applicable)} applicable cases met every closed-loop target ({len(na)} not applicable)"]
    for r in applicable:
        if not r["success"]:
            status = f" [{r['plan_status']}]" if r.get("stage") == "plan" and "plan_status" in r else ""
            lines.append(f"  FAIL {r['scenario']}/{r['robot']}/{r['planner']} at {r['stage']}{status}: {r['reason']}")
    for r in na:
        lines.append(f"  n/a  {r['scenario']}/{r['robot']}/{r['planner']}: {r['reason']}")
    return lines


def matrix_record(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The JSON record of a matrix run: applicable rows, not-applicable rows apart, and counts."""
    na = [r for r in rows if r.get("outcome") == "n/a"]
    applicable = [r for r in rows if r.get("outcome") != "n/a"]
    return {
        "rows": applicable,
        "not_applicable": na,
        "summary": {"cases": len(applicable), "passed": sum(bool(r["success"]) for r in applicable),
                    "failed": sum(not r["success"] for r in applicable), "not_applicable": len(na),
                    "targets": TARGETS},
    }  # fmt: skip


def matrix_passed(rows: list[dict[str, Any]]) -> bool:
    """Whether every applicable case met every target."""
    return all(r["success"] for r in rows if r.get("outcome") != "n/a")
