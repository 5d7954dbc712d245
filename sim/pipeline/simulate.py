"""The main job: a scenario and a reference, tracked closed loop and open loop, measured.

The library returns data; only the CLI prints and writes files.
"""

from __future__ import annotations

import platform
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

from control.base import make_tracker
from control.fbl import FBLGains
from planning.core.robot import RobotSpec, load_robot
from planning.errors import ConfigError, ScenarioError
from planning.planners.base import PlanProblem, PlanResult
from planning.planners.registry import PLANNERS, make_planner
from planning.scenario import Scenario, load_scenario
from planning.trajectory.from_plan import checked_trajectory
from planning.trajectory.references import make_reference
from planning.trajectory.trajectory import Trajectory
from sim.physics.metrics import TrackingMetrics, compute_metrics
from sim.physics.perturb import Perturbation
from sim.physics.runlog import RunLog
from sim.physics.simulator import SimConfig, Simulator

#: Run label -> tracker name.
RUNS = {"closed_loop": "fbl", "open_loop": "open-loop"}

#: A job's progress: (stage, done, total). Stages: "plan" with seconds of the planning budget
#: (0 when planning starts, total when it returns), and each run label ("closed_loop", ...) with
#: control periods of physics (see :meth:`sim.physics.simulator.Simulator.run`).
Progress = Callable[[str, float, float], Any]


@dataclass
class JobResult:
    """Everything one simulate job produced.

    Attributes:
        scenario: The scenario (with the robot in use).
        robot: The robot spec.
        trajectory: The reference that was tracked.
        source: "reference:<name>" or "planner:<name>".
        logs: Run label ("closed_loop", "open_loop") -> log.
        metrics: Run label -> metrics.
        gains: The tracker gains.
        config: The simulation settings.
        seed: The seed.
        extra: Further record fields (plan statistics, files written, ...).
        trackers: Run label -> tracker name actually used.
    """

    scenario: Scenario
    robot: RobotSpec
    trajectory: Trajectory
    source: str
    logs: dict[str, RunLog]
    metrics: dict[str, TrackingMetrics]
    gains: FBLGains
    config: SimConfig
    seed: int
    extra: dict[str, Any] = field(default_factory=dict)
    trackers: dict[str, str] = field(default_factory=lambda: dict(RUNS))

    def record(self) -> dict[str, Any]:
        """The JSON run record."""
        rec: dict[str, Any] = {
            "scenario": self.scenario.name,
            "scenario_file": str(self.scenario.source) if self.scenario.source else None,
            "robot": self.robot.name,
            "source": self.source,
            "trajectory": {"name": self.trajectory.name, "duration_s": self.trajectory.duration,
                           "length_m": self.trajectory.path_length()},
            "tracker": self.trackers["closed_loop" if "closed_loop" in self.logs else "open_loop"],
            "gains": {"kp": self.gains.kp, "kd": self.gains.kd, "xi_min": self.gains.xi_min},
            "control_rate_hz": self.config.control_rate,
            "seed": self.seed,
            "versions": versions(),
        }  # fmt: skip
        for label, m in self.metrics.items():
            run: dict[str, Any] = dict(m.as_dict())
            run["tracker"] = self.trackers[label]
            run["warning_messages"] = list(self.logs[label].warnings)
            run["contacts"] = [{"t": c.t, "obstacle": c.obstacle} for c in self.logs[label].contacts]
            rec[label] = run
        rec.update(self.extra)
        return rec


def versions() -> dict[str, str]:
    """Versions of Python, the platform and the packages a run depends on."""
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for pkg in ("nhsim", "mujoco", "dm-control", "numpy", "scipy", "casadi"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "not installed"
    return out


def run_tracking(
    scenario: Scenario,
    robot: RobotSpec,
    trajectory: Trajectory,
    *,
    source: str,
    trackers: tuple[str, ...] = ("closed_loop", "open_loop"),
    gains: FBLGains | None = None,
    config: SimConfig | None = None,
    seed: int = 0,
    simulator: Simulator | None = None,
    tracker_names: dict[str, str] | None = None,
    perturbation: Perturbation | None = None,
    progress: Progress | None = None,
) -> JobResult:
    """Track a trajectory closed loop and/or open loop in physics and measure both.

    Args:
        scenario: The world.
        robot: The robot.
        trajectory: The reference.
        source: Where the reference came from, for the record.
        trackers: Run labels to run ("closed_loop", "open_loop").
        gains: FBL gains (defaults if None).
        config: Simulation settings.
        seed: Seed, recorded (and used by perturbations).
        simulator: A simulator to reuse (built from scenario and robot if None).
        tracker_names: Run label -> tracker name (default ``RUNS``).
        perturbation: Physics and loop perturbation applied to every run (see :mod:`sim.physics.perturb`).
        progress: Told how each run advances (see :data:`Progress`); None for silence.
    """
    gains = gains or FBLGains()
    config = config or SimConfig()
    simulator = simulator or Simulator(robot, scenario.world)
    logs: dict[str, RunLog] = {}
    metrics: dict[str, TrackingMetrics] = {}
    names = {**RUNS, **(tracker_names or {})}
    for label in trackers:
        tracker = make_tracker(names[label], robot, gains=gains)
        step = None if progress is None else (lambda done, total, _l=label: progress(_l, done, total))
        log = simulator.run(trajectory, tracker, config, start=scenario.start, meta={"seed": seed},
                            perturbation=perturbation, progress=step)  # fmt: skip
        logs[label] = log
        metrics[label] = compute_metrics(log, trajectory, max_speed=robot.max_speed, max_yaw_rate=robot.max_yaw_rate)
    job = JobResult(scenario, robot, trajectory, source, logs, metrics, gains, config, seed,
                    trackers={k: names[k] for k in trackers})  # fmt: skip
    if perturbation is not None and not perturbation.is_nominal:
        job.extra["perturbation"] = perturbation.as_dict()
    return job


def simulate_reference(
    scenario: str = "open",
    *,
    robot: str | None = None,
    reference: str = "figure8",
    trackers: tuple[str, ...] = ("closed_loop", "open_loop"),
    gains: FBLGains | None = None,
    config: SimConfig | None = None,
    seed: int = 0,
    perturbation: Perturbation | None = None,
    progress: Progress | None = None,
) -> JobResult:
    """Track an analytic reference placed at a scenario's start pose.

    Args:
        scenario: Built-in name or path of a scenario file.
        robot: Robot name overriding the scenario's.
        reference: "figure8", "circle" or "line".
        trackers: Run labels to run.
        gains: FBL gains.
        config: Simulation settings.
        seed: Seed.
        perturbation: Physics and loop perturbation (see :mod:`sim.physics.perturb`).
        progress: Told how the runs advance (see :data:`Progress`).
    """
    sc = load_scenario(scenario)
    if robot is not None:
        sc = sc.with_robot(robot)
    spec = load_robot(sc.robot)
    traj = make_reference(reference, spec, sc.start)
    clearance = sc.world.signed_distance(traj.pose[:, :2])
    if float(clearance.min()) <= spec.radius:
        k = int(clearance.argmin())
        raise ScenarioError(
            f"reference {reference!r} placed at the start of scenario {sc.name!r} comes within "
            f"{max(float(clearance[k]), 0.0):.3f} m of an obstacle or wall at ({traj.pose[k, 0]:.2f}, "
            f"{traj.pose[k, 1]:.2f}) but the {spec.name} needs {spec.radius:.3f} m; use a scenario with room "
            f"for it (e.g. --scenario open) or plan a path with --planner"
        )
    return run_tracking(sc, spec, traj, source=f"reference:{reference}", trackers=trackers, gains=gains,
                        config=config, seed=seed, perturbation=perturbation, progress=progress)  # fmt: skip


# ------------------------------------------------------------------------------------------ plans
#: Run label -> tracker name for planned trajectories (cusps and turns in place need the segmented one).
PLAN_RUNS = {"closed_loop": "segmented", "open_loop": "open-loop"}

#: Planners that solve any scenario (they avoid obstacles); they apply to every scenario with a goal.
GENERAL_PLANNERS = ("rrt", "birrt", "rrt-star", "c-rrt-star", "optim")
#: Planners that ignore obstacles; they apply to scenarios without obstacles.
OBSTACLE_FREE_PLANNERS = ("sinusoidal",)

#: Time added after a planned trajectory for the final pose regulation [s].
PLAN_HOLD_S = 2.0


def applicable_planners(scenario: Scenario) -> list[str]:
    """The registered planners that apply to a scenario (the rule ``simulate --all`` uses).

    A planner applies when the scenario names it (its ``planner`` field), when it is a general,
    obstacle-avoiding planner (``GENERAL_PLANNERS``), or when it ignores obstacles
    (``OBSTACLE_FREE_PLANNERS``) and the scenario has none. A scenario whose goal is its start
    (same position and heading, e.g. ``open``, the arena for analytic references) has nothing to
    plan and gets no planner.
    """
    if scenario.start.distance_to(scenario.goal) < 1e-9 and scenario.start.heading_error_to(scenario.goal) < 1e-9:
        return []
    names = []
    for name in sorted(PLANNERS):
        if (
            name == scenario.planner
            or name in GENERAL_PLANNERS
            or (name in OBSTACLE_FREE_PLANNERS and not scenario.world.obstacles)
        ):
            names.append(name)
    return names


def simulate_plan(
    scenario: str | Scenario,
    *,
    robot: str | None = None,
    planner: str | None = None,
    seed: int = 0,
    gains: FBLGains | None = None,
    config: SimConfig | None = None,
    time_limit: float = 30.0,
    planner_options: dict[str, Any] | None = None,
    trackers: tuple[str, ...] = ("closed_loop", "open_loop"),
    plan: PlanResult | None = None,
    smoothing: dict[str, Any] | None = None,
    perturbation: Perturbation | None = None,
    progress: Progress | None = None,
) -> JobResult:
    """Plan a scenario, smooth and time the plan, and track it closed loop and open loop.

    Args:
        scenario: Built-in name, path of a scenario file, or a Scenario.
        robot: Robot name overriding the scenario's.
        planner: Registered planner name (default: the scenario's ``planner``).
        seed: Planner seed (recorded).
        gains: FBL gains.
        config: Simulation settings (default: 50 Hz with ``PLAN_HOLD_S`` of final regulation).
        time_limit: Planning budget [s].
        planner_options: Keyword options for the planner factory, over the scenario's own
            ``[planners.<name>]`` options for it.
        trackers: Run labels to run.
        plan: A ready plan to use instead of planning (its ``planner`` names the source).
        smoothing: Keyword options for :func:`planning.trajectory.from_plan.make_trajectory`.
        perturbation: Physics and loop perturbation of the runs (see :mod:`sim.physics.perturb`).
        progress: Told when planning starts and ends and how the runs advance (see :data:`Progress`).

    Returns:
        The job; ``source`` is "planner:<name>", ``extra["plan"]`` holds the plan's status and
        statistics and ``extra["smoothing"]`` the smoothing's.

    Raises:
        ConfigError: No planner given and the scenario names none; unknown planner.
        TrajectoryError: The plan failed or could not be made into a collision-free trajectory.
    """
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    if robot is not None:
        sc = sc.with_robot(robot)
    spec = load_robot(sc.robot)
    if plan is None:
        name = planner or sc.planner
        if name is None:
            raise ConfigError(
                f"scenario {sc.name!r} names no planner; choose one with --planner "
                f"({', '.join(sorted(PLANNERS)) or 'none registered'})"
            )
        problem = PlanProblem.from_scenario(sc, robot=spec, seed=seed, time_limit=time_limit)
        solver = make_planner(name, **{**sc.options_for(name), **(planner_options or {})})
        if progress is not None:
            progress("plan", 0.0, time_limit)
        try:
            plan = solver.plan(problem)
        finally:
            if progress is not None:
                progress("plan", time_limit, time_limit)
    plan_rec: dict[str, Any] = {
        "planner": plan.planner, "status": plan.status.value, "reason": plan.reason,
        "time_s": plan.stats.get("time_s"), "iterations": plan.stats.get("iterations"), "length_m": plan.length(),
    }  # fmt: skip
    res = checked_trajectory(plan, spec, sc.world, goal=sc.goal, **(smoothing or {}))
    traj = res.trajectory
    assert traj is not None
    config = config or SimConfig(hold=PLAN_HOLD_S)
    job = run_tracking(sc, spec, traj, source=f"planner:{plan.planner}", trackers=trackers, gains=gains,
                       config=config, seed=seed, tracker_names=PLAN_RUNS, perturbation=perturbation,
                       progress=progress)  # fmt: skip
    job.extra["plan"] = plan_rec
    job.extra["smoothing"] = {k: v for k, v in res.stats.items() if isinstance(v, (int, float, str, bool))}
    return job
