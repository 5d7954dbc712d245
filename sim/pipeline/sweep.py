"""Every built-in scenario with every applicable planner and robot, planned, smoothed and tracked.

The rule for which planners apply is :func:`sim.pipeline.simulate.applicable_planners`; robots are the ones a
scenario lists (``robots``). The library returns the rows; ``nhsim simulate --all`` prints them.

Every row has an :class:`Outcome`: OK (every closed-loop target met), FAIL, or NA (not applicable).
A case is NA only when the planner rejects the start or goal by a precondition of its own
(``INVALID_START`` / ``INVALID_GOAL``, e.g. C-RRT*'s 0.40 m centre clearance for the EduMIP, the
EduMIP planning report's rule) while that pose is free for the robot's footprint: the planner does
not apply to the scenario. Such rows are reported apart and not counted. Every other planner status
(a timeout, ``BOUNDS_VIOLATED``, ``INFEASIBLE``, a colliding timed plan), a smoothing failure or a
missed target is a failure of that case.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from planning.collision.overlap import end_clearance
from planning.core.robot import load_robot
from planning.errors import ConfigError, NhsimError, option
from planning.planners.base import PlanResult, PlanStatus
from planning.scenario import Scenario, builtin_scenarios, load_scenario
from planning.trajectory.from_plan import PlanFailedError
from sim.physics.metrics import TrackingMetrics
from sim.pipeline.case import Case, load_case_scenario, plan_case
from sim.pipeline.runs import RunKind
from sim.pipeline.simulate import applicable_planners, simulate

#: What a closed-loop run must reach to count as a success in the table.
TARGETS = {"final_position_error_m": 0.02, "final_heading_error_rad": 0.05, "rms_position_error_m": 0.02}
#: A balancing robot's targets: RMS 3 cm, its forward motion waiting on a lean, and
#: |pitch| <= 20 deg; and it must not fall.
BALANCING_TARGETS = {**TARGETS, "rms_position_error_m": 0.03, "max_pitch_rad": math.radians(20.0)}


class Outcome(StrEnum):
    """How a sweep case ended (the value is what the table and the record show)."""

    OK = "ok"
    FAIL = "FAIL"
    NA = "n/a"


class Stage(StrEnum):
    """Where a sweep case ended."""

    PRECONDITION = "precondition"
    PLAN = "plan"
    TRAJECTORY = "trajectory"
    TRACK = "track"


@dataclass(frozen=True)
class SweepRow:
    """One case of the sweep.

    Attributes:
        case: The case.
        outcome: OK, FAIL or NA (see the module doc).
        stage: Where the case ended.
        reason: Why it failed or does not apply ("" for OK).
        plan_status: The planner's status (None when no plan was made).
        plan_time_s: Planning time [s] (precondition and track stages).
        plan_length_m: Length of the plan [m] (track stage).
        duration_s: Duration of the timed trajectory [s] (track stage).
        smoothing: Smoothing statistics (track stage).
        runs: Run kind -> its record entry (metrics, tracker, warnings, contacts; track stage).
    """

    case: Case
    outcome: Outcome
    stage: Stage
    reason: str = ""
    plan_status: str | None = None
    plan_time_s: float | None = None
    plan_length_m: float | None = None
    duration_s: float | None = None
    smoothing: Mapping[str, Any] = field(default_factory=dict)
    runs: Mapping[RunKind, Mapping[str, Any]] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """Every closed-loop target met."""
        return self.outcome is Outcome.OK

    @property
    def robot(self) -> str:
        """The robot's name."""
        return self.case.robot or "default"

    def record(self) -> dict[str, Any]:
        """The row as JSON: the case, the outcome, and what each stage reached."""
        rec: dict[str, Any] = {
            "scenario": self.case.scenario_name,
            "robot": self.robot,
            "planner": self.case.planner,
            "seed": self.case.seed,
            "success": self.success,
            "outcome": self.outcome.value,
            "stage": self.stage.value,
            "reason": self.reason,
        }
        if self.plan_status is not None:
            rec["plan_status"] = self.plan_status
        if self.stage in (Stage.PRECONDITION, Stage.TRACK):
            rec["plan_time_s"] = self.plan_time_s
        if self.stage is Stage.TRACK:
            rec.update(plan_length_m=self.plan_length_m, duration_s=self.duration_s, smoothing=dict(self.smoothing))
            rec.update({str(kind): dict(self.runs.get(kind, {})) for kind in RunKind})
        return rec


def closed_loop_targets(scenario: Scenario, *, planned: bool) -> dict[str, float]:
    """What the fused closed loop must reach for ``simulate`` to exit 0: metric -> its upper bound.

    A planned job must end inside the scenario's goal tolerance (position [m], heading [rad]) of the
    trajectory's final pose (the segmented tracker regulates the final pose). A reference is tracked by
    the FBL, whose output is the position (x, y): it must not leave the path by more than the sweep's
    position targets (:data:`sim.pipeline.sweep.TARGETS`: final position 2 cm, RMS 2 cm); its heading
    is not regulated once the reference stops, so it is reported, not judged.
    """
    if planned:
        return {
            "final_position_error_m": scenario.position_tolerance,
            "final_heading_error_rad": scenario.heading_tolerance,
        }
    return {k: v for k, v in TARGETS.items() if k != "final_heading_error_rad"}


#: Share of a run's scans with too few returns to match beyond which a miss is said to be its localiser's.
STARVED_SHARE = 0.25


def missed_targets(metrics: TrackingMetrics, scenario: Scenario, *, planned: bool) -> list[str]:
    """One line per target (:func:`closed_loop_targets`, and a balancing robot's pitch within
    ``BALANCING_TARGETS``' bound) the closed loop's metrics missed; [] when all met. A run
    whose scan localiser could match few of its scans (more than :data:`STARVED_SHARE` with too few returns: the
    world's surfaces beyond the scanner's range) says so on one more line, with the way to run without it."""
    values = metrics.as_dict()
    missed = [
        f"closed-loop run missed its target: {key} = {values[key]:.4g} > {bound:g}"
        + (" (the scenario's goal tolerance)" if planned else "")
        for key, bound in closed_loop_targets(scenario, planned=planned).items()
        if not values[key] <= bound
    ]
    pitch, bound = values.get("max_pitch_rad"), BALANCING_TARGETS["max_pitch_rad"]
    if pitch is not None and not pitch <= bound:  # a balancing robot's body (None for the others)
        missed.append(
            f"closed-loop run missed its target: max_pitch_rad = {pitch:.4g} > {bound:.4g} ({math.degrees(bound):g} "
            "deg: the planners' footprint holds the body pitched that far, not more)"
        )
    est = metrics.estimation
    blind, cast = (est.scans_without_returns, est.scans_cast) if est is not None else (None, None)
    if missed and blind and cast and blind > STARVED_SHARE * cast:
        missed.append(
            f"its scan localiser had too few returns to match in {blind} of its {cast} scans (the walls and obstacles "
            f"beyond the scanner's range for much of the run): it cannot hold the pose in this world; "
            "--localiser fixes runs on pose fixes instead, or give the world features within range"
        )
    return missed


def sweep_cases(scenarios: list[str] | None = None, **fields_: Any) -> list[Case]:
    """The cases of the sweep, in a stable order: every scenario (default: the built-in ones) ×
    the robots it lists × its applicable planners.

    Args:
        scenarios: Scenario names (built-in, ``random<N>``) or paths of scenario files.
        **fields_: Further case fields (seed, gains, control_rate, planning).

    A scenario given by name stays a name in its cases; one read from a file goes into them as read (its name
    is not a built-in's, or is one and would reload the built-in instead of the file).

    Raises:
        ConfigError: A scenario of ``scenarios`` with nothing to plan (its goal is its start, as the ``open``
            arena's: no planner applies), which the sweep would otherwise pass over without a word.
    """
    cases = []
    for name in scenarios if scenarios is not None else builtin_scenarios():
        sc = load_scenario(name)
        scenario: str | Scenario = name if name == sc.name else sc
        planners = applicable_planners(sc)
        if scenarios is not None and not planners:
            start = f"({sc.start.x:g}, {sc.start.y:g}, {sc.start.theta:g})"
            raise ConfigError(
                f"scenario {name} has nothing to plan: its goal is its start {start}, so no planner applies; drop "
                f"it from {option('scenario', python='scenarios')} of the sweep, or track an analytic reference "
                f"there instead (nhsim simulate --scenario {name} --reference figure8)"
            )
        for robot in sc.robots:
            for planner in planners:
                cases.append(Case(scenario, robot=robot, planner=planner, **fields_))
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
    if end_clearance(scenario.world, load_robot(scenario.robot), which) <= 0.0:
        return None
    return f"{plan.status.value} by the planner's own clearance rule: {plan.reason}"


def met_targets(metrics: TrackingMetrics) -> bool:
    """Whether a closed-loop run met every target of the table (:data:`BALANCING_TARGETS` for a balancing
    robot's run, which must also stay up), without contact or warning."""
    return not sweep_misses(metrics)


def sweep_misses(metrics: TrackingMetrics) -> list[str]:
    """What a closed-loop run missed of the table's targets (:func:`met_targets`), each as
    ``"rms_position_error_m 0.0317 > 0.03"``, a fall, contacts or warnings; [] when it met them all."""
    values = metrics.as_dict()
    targets = BALANCING_TARGETS if metrics.fell is not None else TARGETS
    missed = [f"{k} {values[k]:.4g} > {v:g}" for k, v in targets.items() if not values[k] <= v]
    missed += ["it fell"] if metrics.fell else []
    missed += [f"{metrics.collisions} contact(s)"] if metrics.collisions else []
    missed += [f"{metrics.warnings} MuJoCo warning(s)"] if metrics.warnings else []
    return missed


def sweep_case(case: Case) -> SweepRow:
    """Plan, smooth and track one planned case; a failure is a row with its stage and reason.

    The planner gets the scenario's own options for it (``[planners.<name>]``), overridden by the
    case's ``planning.planner_options``.
    """
    status: str | None = None
    try:
        sc = load_case_scenario(case)
        plan = plan_case(case, sc, load_robot(sc.robot))
        status = plan.status.value
        na = precondition_not_met(sc, plan)
        if na is not None:
            return SweepRow(case, Outcome.NA, Stage.PRECONDITION, na, status, plan.stats.get("time_s"))
        job = simulate(case.with_plan(plan, sc))
    except PlanFailedError as exc:
        return SweepRow(case, Outcome.FAIL, Stage.PLAN, str(exc), status)
    except NhsimError as exc:
        return SweepRow(case, Outcome.FAIL, Stage.TRAJECTORY, str(exc), status)
    rec = job.record()
    closed = job.runs.get(RunKind.CLOSED_LOOP)
    missed = sweep_misses(closed.metrics) if closed is not None else ["no closed-loop run"]
    ok = not missed
    return SweepRow(
        case,
        Outcome.OK if ok else Outcome.FAIL,
        Stage.TRACK,
        "" if ok else f"closed loop missed: {', '.join(missed)}",
        status,
        rec["plan"].get("time_s"),
        rec["plan"].get("length_m"),
        rec["trajectory"]["duration_s"],
        rec["smoothing"],
        {kind: rec[kind] for kind in job.runs},
    )


#: Runs ``fn(shared, item)`` for every item and yields ``(item, result)`` as each finishes: the
#: ``map_unordered`` of an executor (:mod:`sim.tools.executor`, local processes or a Dask cluster).
Mapper = Callable[[Callable[[Any, Case], SweepRow], list[Case]], Iterable[tuple[Case, SweepRow]]]


def run_sweep(
    cases: list[Case], *, progress: Callable[[SweepRow], None] | None = None, mapper: Mapper | None = None
) -> list[SweepRow]:
    """Run every case (see :func:`sweep_case`), calling ``progress`` with each row as it is done.

    Args:
        cases: The cases.
        progress: Told each row as it is done (in the order they finish).
        mapper: Where the cases run (see :data:`Mapper`); None: one after the other, here.

    Returns:
        The rows, in the order of ``cases``.
    """
    runs: Iterable[tuple[Case, SweepRow]] = (
        ((case, sweep_case(case)) for case in cases) if mapper is None else mapper(sweep_task, cases)
    )
    done = {}
    for case, row in runs:
        done[case.name] = row
        if progress is not None:
            progress(row)
    return [done[c.name] for c in cases]


def sweep_task(shared: object, case: Case) -> SweepRow:
    """One case as an executor's task (see :mod:`sim.tools.executor`; ``shared`` is unused)."""
    return sweep_case(case)


def sweep_record(rows: list[SweepRow], settings: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The JSON record of a sweep: the ``settings`` every case ran with (seed, gains, control rate, time
    limit: what tells one sweep from another), applicable rows, not-applicable rows apart, and counts, with
    the targets a row is judged by (``targets``; a balancing robot's row by ``balancing_targets``)."""
    na = [r for r in rows if r.outcome is Outcome.NA]
    applicable = [r for r in rows if r.outcome is not Outcome.NA]
    return {
        "settings": dict(settings or {}),
        "rows": [r.record() for r in applicable],
        "not_applicable": [r.record() for r in na],
        "summary": {
            "cases": len(applicable),
            "passed": sum(r.success for r in applicable),
            "failed": sum(not r.success for r in applicable),
            "not_applicable": len(na),
            "targets": TARGETS,
            "balancing_targets": BALANCING_TARGETS,
        },
    }


def sweep_passed(rows: list[SweepRow]) -> bool:
    """Whether every applicable case met every target."""
    return all(r.success for r in rows if r.outcome is not Outcome.NA)
