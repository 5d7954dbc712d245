"""The track stage: a case's trajectory tracked in physics by each run kind, measured.

:func:`track` runs a prepared trajectory (see :func:`sim.pipeline.case.prepare_trajectory`) for a
set of :class:`~sim.pipeline.runs.RunKind`; :func:`simulate` is both stages for one case, and
:func:`simulate_reference` / :func:`simulate_plan` build the case from a scenario and a reference or
a planner. The library returns data; only the CLI prints and writes files.
"""

from __future__ import annotations

import platform
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, fields, replace
from importlib import metadata
from pathlib import Path
from types import MappingProxyType
from typing import Any

import mujoco

from control.base import TRACKERS, Tracker, feedback_trackers, make_tracker, tuned_option, tuned_or_none
from control.fbl import uses_fbl_gains
from control.gains import FBLGains
from planning.core.arrays import ComparedByValue
from planning.core.checks import check_number
from planning.core.robot import RobotSpec
from planning.errors import ConfigError
from planning.planners.registry import PLANNERS
from planning.scenario import Scenario
from planning.trajectory.from_plan import infeasibility
from planning.trajectory.importer import TrajectoryFile
from planning.trajectory.trajectory import Trajectory
from sim.physics.asbuilt import AsBuilt
from sim.physics.metrics import TrackingMetrics, robot_metrics
from sim.physics.perturb import Perturbation
from sim.physics.runlog import RunLog
from sim.physics.simulator import SimConfig, Simulator
from sim.pipeline.case import Case, PreparedTrajectory, check_case_scenario, nothing_to_plan, prepare_trajectory
from sim.pipeline.runs import DEFAULT_RUNS, Progress, RunKind, run_kinds
from sim.robot.sensing import SensingSetup


@dataclass(frozen=True, eq=False)
class Run(ComparedByValue):
    """One run of a job.

    Attributes:
        kind: The run kind.
        tracker: Tracker name used.
        log: What the engine did.
        metrics: How well it followed the trajectory.
        params: The tracker's tuned parameters as it ran, field -> value (:func:`tracker_params`); empty for a
            tracker with nothing to tune (the open loop).
    """

    kind: RunKind
    tracker: str
    log: RunLog
    metrics: TrackingMetrics
    params: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class JobResult(ComparedByValue):
    """Everything one job produced.

    Attributes:
        prepared: The case and its trajectory.
        runs: Run kind -> run, in the order run.
        config: The simulation settings of the runs.
        build: The robot as built that the runs drove (the simulator's).
        sensing: The sensors and estimator settings the runs used.
        model: The compiled model the runs stepped (the robot as built in the scenario's world, with
            the case's perturbation), which a video of the job draws.
    """

    prepared: PreparedTrajectory
    runs: Mapping[RunKind, Run]
    config: SimConfig
    build: AsBuilt
    sensing: SensingSetup
    model: mujoco.MjModel = field(compare=False, repr=False)

    def __post_init__(self) -> None:
        if not self.runs:
            raise ConfigError("a JobResult holds at least one run; runs is empty")
        object.__setattr__(self, "runs", MappingProxyType(dict(self.runs)))  # read-only, as the result is

    def __getstate__(self) -> dict[str, Any]:  # a read-only mapping does not pickle; its dict does
        return {**self.__dict__, "runs": dict(self.runs)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state, runs=MappingProxyType(state["runs"]))

    def __repr__(self) -> str:
        runs = ", ".join(f"{kind}: {run.metrics.final_position_error_m:.4f} m" for kind, run in self.runs.items())
        return f"JobResult({self.case.name!r}, source={self.source!r}, final errors {{{runs}}})"

    @property
    def case(self) -> Case:
        """The case."""
        return self.prepared.case

    @property
    def scenario(self) -> Scenario:
        """The scenario (with the robot in use)."""
        return self.prepared.scenario

    @property
    def robot(self) -> RobotSpec:
        """The robot spec."""
        return self.prepared.robot

    @property
    def trajectory(self) -> Trajectory:
        """The reference that was tracked."""
        return self.prepared.trajectory

    @property
    def source(self) -> str:
        """``"reference:<name>"`` or ``"planner:<name>"``."""
        return self.prepared.source

    @property
    def seed(self) -> int:
        """The seed."""
        return self.case.seed

    @property
    def gains(self) -> FBLGains | None:
        """The FBL gains the closed loops ran with; None for a tracker with its own parameters (mpc, rpp, ...),
        as the record has it."""
        return self.case.fbl_gains

    @property
    def logs(self) -> dict[str, RunLog]:
        """Run kind -> log (the keys are :class:`RunKind` members, which are strings)."""
        return {kind: run.log for kind, run in self.runs.items()}

    @property
    def metrics(self) -> dict[str, TrackingMetrics]:
        """Run kind -> metrics."""
        return {kind: run.metrics for kind, run in self.runs.items()}

    @property
    def trackers(self) -> dict[str, str]:
        """Run kind -> tracker name used."""
        return {kind: run.tracker for kind, run in self.runs.items()}

    @property
    def extra(self) -> dict[str, Any]:
        """Further record fields: the plan's and the smoothing's statistics, the perturbation."""
        extra = dict(self.prepared.extra)
        pert = self.case.perturbation
        if pert is not None and not pert.is_nominal:
            extra["perturbation"] = pert.as_dict()
            applied = next(iter(self.runs.values())).log.meta.get("latency_applied_s")
            if applied is not None:  # a whole number of physics steps (the asked-for latency is the perturbation's)
                extra["perturbation"]["latency_applied_s"] = applied
        return extra

    def record(self) -> dict[str, Any]:
        """The JSON run record."""
        main = self.runs.get(RunKind.CLOSED_LOOP) or next(iter(self.runs.values()))
        gains = self.gains if uses_fbl_gains(main.tracker) else None
        rec: dict[str, Any] = {
            "scenario": self.scenario.name,
            "scenario_file": str(self.scenario.source) if self.scenario.source else None,
            "robot": self.robot.name,
            "source": self.source,
            "trajectory": {
                "name": self.trajectory.name,
                "duration_s": self.trajectory.duration,
                "length_m": self.trajectory.path_length(),
                # what the robot cannot follow in it (saturated inputs, poses its velocities do not lead to), as the
                # runs warned on stderr; null for none (it was said on stderr only, the record clean)
                "infeasible": infeasibility(self.trajectory, self.robot) or None,
            },
            "tracker": main.tracker,
            # the FBL's gains where the tracker takes them; null for one with its own parameters (mpc, rpp, ...)
            "gains": None if gains is None else {"kp": gains.kp, "kd": gains.kd, "xi_min": gains.xi_min},
            # the tracker's tuned parameters as it ran (its gains for an FBL); null for one with nothing to tune
            "params": dict(main.params) or None,
            "control_rate_hz": self.config.control_rate,
            "seed": self.seed,
            "noise_seed": self.sensing.seed,
            "build_seed": self.case.build_seed,
            "as_built": self.build.as_dict(),
            "battery_voltage_v": self.robot.battery_voltage,
            "sensors": self.sensing.profile.as_dict(),
            "versions": versions(),
        }
        if any(kind.localises for kind in self.runs):
            rec["localiser"] = self.sensing.localiser.as_dict(self.sensing.seed)
        for kind, run in self.runs.items():
            entry: dict[str, Any] = dict(run.metrics.as_dict())
            entry["tracker"] = run.tracker
            entry["warning_messages"] = list(run.log.warnings)
            entry["contacts"] = [{"t": c.t, "obstacle": c.obstacle} for c in run.log.contacts]
            rec[str(kind)] = entry
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


def track(
    prepared: PreparedTrajectory,
    runs: Iterable[RunKind | str] | str = DEFAULT_RUNS,
    *,
    strict: bool = True,
    simulator: Simulator | None = None,
    progress: Progress | None = None,
) -> JobResult:
    """Track a prepared trajectory in physics once per run kind, with the case's gains, control
    rate, seed and perturbation, and measure each run.

    Args:
        prepared: The case and its trajectory.
        runs: Run kinds to run, in order.
        strict: Raise when MuJoCo warns; False counts the warnings in the metrics.
        simulator: A simulator of the case's robot and world to reuse (built if None).
        progress: Told how each run advances (see :data:`sim.pipeline.runs.Progress`); None for silence.

    Raises:
        ConfigError: ``prepared`` is not a prepared trajectory, or the case's tracker feeds nothing back and ``runs``
            hold a closed loop.
        SimulationError: MuJoCo warned (with ``strict``) or a tracker returned a non-finite command.
    """
    if not isinstance(prepared, PreparedTrajectory):
        raise ConfigError(
            f"track: prepared must be a PreparedTrajectory, got {type(prepared).__name__} {prepared!r:.60}; make one "
            "with sim.pipeline.case.prepare_trajectory(case), or call simulate(case) to prepare and track at once"
        )
    runs = run_kinds(runs)
    case = prepared.case
    check_feedback_tracker(case, runs)
    config = SimConfig(control_rate=case.control_rate, hold=prepared.hold, strict=strict)
    if simulator is not None:
        _check_simulator(simulator, prepared)
    simulator = simulator or simulator_for(prepared)
    sensing = case.sensing(prepared.scenario)
    done: dict[RunKind, Run] = {}
    for kind in runs:
        step = None if progress is None else (lambda d, total, _k=kind: progress(_k, d, total))
        tracker = tracker_for_run(case, kind, prepared.robot)
        done[kind] = run_tracker(prepared, kind, tracker, simulator, config, sensing, progress=step)
    return JobResult(prepared, done, config, simulator.build, sensing, simulator.run_model(case.perturbation))


def check_feedback_tracker(case: Case, runs: Iterable[RunKind]) -> None:
    """Refuse a case whose tracker, the closed loops' tracker, feeds nothing back (``"open-loop"``) when ``runs``
    hold a closed loop: that run would be an open loop recorded as a closed one. (Alone, the open loop's run is
    that tracker's run: a case of the regression suite with ``tracker = "open-loop"`` runs only it.)

    Raises:
        ConfigError: Naming the tracker, the closed-loop runs, the trackers with feedback and the open loop's run.
    """
    name = case.feedback_tracker
    closed = [str(kind) for kind in runs if not kind.tracker]
    if closed and name in TRACKERS and name not in feedback_trackers():
        own = [str(kind) for kind in RunKind if kind.tracker == name]
        tail = f"{name!r} drives a run of its own: runs={own!r} (one of the default runs)" if own else ""
        raise ConfigError(
            f"tracker {name!r} feeds nothing back, so the closed-loop runs ({', '.join(closed)}) would not be closed: "
            f"tracker is the closed loops' tracker, one of {', '.join(feedback_trackers())} (None: the default)"
            + (f"; {tail}" if tail else "")
        )


def tracker_for_run(case: Case, kind: RunKind, robot: RobotSpec) -> Tracker:
    """The tracker a run of ``kind`` uses in ``case``: its registered tracker with the case's FBL gains
    (if its ``gains`` option is declared to take FBL gains; any other tracker keeps its own defaults)
    and, for the case's feedback tracker, the case's ``params`` (its tuned option).

    Raises:
        ConfigError: The case's params are not of the tracker's tuned type.
    """
    name = case.tracker_for(kind)
    options: dict[str, Any] = {}
    if uses_fbl_gains(name):
        options["gains"] = case.fbl_gains or FBLGains()
    if case.params is not None and not kind.tracker:
        options[tuned_option(name)[0]] = case.params
    return make_tracker(name, robot, **options)


def run_tracker(
    prepared: PreparedTrajectory,
    kind: RunKind,
    tracker: Tracker,
    simulator: Simulator,
    config: SimConfig,
    sensing: SensingSetup,
    *,
    progress: Callable[[int, int], Any] | None = None,
) -> Run:
    """One run: ``tracker`` drives the prepared trajectory in ``simulator``, fed the pose of ``kind``'s
    source; the log measured against the trajectory.

    Raises:
        SimulationError: MuJoCo warned (with ``config.strict``) or the tracker returned a non-finite command.
    """
    case, robot = prepared.case, prepared.robot
    log = simulator.run(
        prepared.trajectory,
        tracker,
        config,
        start=prepared.scenario.start,
        meta={"seed": case.seed, "noise_seed": sensing.seed, "case": case.name},
        perturbation=case.perturbation,
        progress=progress,
        source=kind.source,
        sensing=sensing,
    )
    metrics = robot_metrics(log, prepared.trajectory, robot)
    name = case.tracker_for(kind)
    return Run(kind, name, log, metrics, tracker_params(name, tracker))


def tracker_params(name: str, tracker: Tracker) -> dict[str, Any]:
    """The tuned parameters ``tracker`` (registered as ``name``) runs with: the value of its tuned option it holds
    under the option's name (as nhsim's trackers do), as a dict of its fields; {} for a tracker with nothing to tune
    or one that holds them elsewhere."""
    tuned = tuned_or_none(name)
    if tuned is None:
        return {}
    option, kind = tuned
    value = getattr(tracker, option, None)
    return plain_params(value) if isinstance(value, kind) else {}


def plain_params(params: Any) -> dict[str, Any]:
    """A parameter dataclass as a dict of its fields."""
    names = getattr(params, "__dataclass_fields__", {})
    return {k: getattr(params, k) for k in names}


def _check_simulator(simulator: Any, prepared: PreparedTrajectory) -> None:
    """Refuse a simulator given to :func:`track` that is not the case's: another robot, world or build would be
    tracked and recorded as the case's.

    Raises:
        ConfigError: Naming what differs and the fix (``simulator_for(prepared)``, or None to build it).
    """
    fix = "pass simulator_for(prepared), or simulator=None to have it built"
    if not all(hasattr(simulator, name) for name in ("robot", "world", "build", "run")):  # a Simulator's fields
        raise ConfigError(f"track: simulator must be a Simulator or None ({fix}), got {simulator!r:.80}")
    build = prepared.case.as_built(prepared.robot.name)
    differs = [
        what
        for what, same in (
            (
                f"its robot ({simulator.robot.name}, not the case's {prepared.robot.name})",
                simulator.robot == prepared.robot,
            ),
            (
                "its world (not the scenario's, unmapped obstacles included)",
                simulator.world == prepared.scenario.physical_world,
            ),
            (
                "its build (the robot as built: the case's build_seed draws it, None the nominal)",
                simulator.build == build,
            ),
        )
        if not same
    ]
    if differs:
        raise ConfigError(f"track: the simulator given is not the case's: {'; '.join(differs)}; {fix}")


def simulator_for(prepared: PreparedTrajectory) -> Simulator:
    """A compiled simulator of a prepared case's robot, as its case builds it, in its world."""
    return Simulator(prepared.robot, prepared.scenario.physical_world, prepared.case.as_built(prepared.robot.name))


def simulate(
    case: Case, runs: Iterable[RunKind | str] | str = DEFAULT_RUNS, *, progress: Progress | None = None
) -> JobResult:
    """Prepare a case's trajectory and track it (see :func:`track`; MuJoCo warnings raise).

    Raises:
        ConfigError: ``case`` is not a case, or its tracker feeds nothing back and ``runs`` hold a closed loop
            (:func:`check_feedback_tracker`), before anything is planned.
        NhsimError: From :func:`sim.pipeline.case.prepare_trajectory` and :func:`track`.
    """
    if not isinstance(case, Case):
        raise ConfigError(
            f"simulate: case must be a Case, got {type(case).__name__} {case!r:.60}; e.g. simulate(Case('farm')), or "
            "simulate_plan('farm') / simulate_reference('open', reference='circle') with a scenario's name"
        )
    runs = run_kinds(runs)
    check_feedback_tracker(case, runs)  # before the plan: the runs are known
    return track(prepare_trajectory(case, progress=progress), runs, progress=progress)


def _case(where: str, scenario: object, fields_: dict[str, Any], **source: Any) -> Case:
    """The case ``where`` (a function's name) was given, its scenario and seed checked under that function's name.

    Raises:
        ConfigError: A scenario that is none (None, a number), a seed that is not an integer >= 0, or a keyword
            that is not a field of a case.
    """
    scenario = check_case_scenario(f"{where}: scenario", scenario)
    if "seed" in fields_:
        fix = "the seed of the planner and of the sensor noise; same seed, same job"
        fields_ = {
            **fields_,
            "seed": check_number(f"{where}: seed", fields_["seed"], integer=True, at_least=0, fix=fix),
        }
    unknown = [k for k in fields_ if k not in CASE_FIELDS]
    if unknown:
        said = ", ".join(f"{k!r}{_field_hint(k)}" for k in unknown)
        raise ConfigError(
            f"{where}: unknown keyword{'s' * (len(unknown) > 1)} {said}; the keywords are the fields of a case "
            f"(sim.pipeline.case.Case): {', '.join(f for f in CASE_FIELDS if f != 'scenario')}"
        )
    try:
        return Case(scenario, **source, **fields_)
    except TypeError as exc:
        raise ConfigError(f"{where}: {exc}; the fields of a case are those of sim.pipeline.case.Case") from exc


#: The fields of a case, the keywords of :func:`simulate_plan` and its kin.
CASE_FIELDS = tuple(f.name for f in fields(Case))
#: The ``nhsim simulate`` options whose case field has another name.
_CLI_NAMES = {"feedback": "tracker", "time_limit": "planning=PlanOptions(time_limit=...)"}


def _field_hint(name: str) -> str:
    """`` (did you mean 'tracker'?)`` for a keyword that is (or is close to) a field's or a command-line option's name
    (``feedback``, ``nhsim simulate --feedback``: the field ``tracker``)."""
    import difflib

    close = [name] if name in _CLI_NAMES else difflib.get_close_matches(name, [*CASE_FIELDS, *_CLI_NAMES], n=1)
    if not close:
        return ""
    meant = _CLI_NAMES.get(close[0], close[0])
    return f" (did you mean {meant}?)" if meant.endswith(")") else f" (did you mean {meant!r}?)"


def simulate_reference(
    scenario: str | Scenario = "open",
    *,
    reference: str = "figure8",
    runs: Iterable[RunKind | str] | str = DEFAULT_RUNS,
    progress: Progress | None = None,
    **fields_: Any,
) -> JobResult:
    """Track an analytic reference placed at a scenario's start pose, once per run kind.

    Args:
        scenario: Built-in name, path of a scenario file, or a Scenario.
        reference: A key of ``planning.trajectory.references.REFERENCES``.
        runs: Run kinds to run.
        progress: Told how the runs advance (see :data:`sim.pipeline.runs.Progress`).
        **fields_: Further :class:`~sim.pipeline.case.Case` fields (robot, seed, gains,
            control_rate, perturbation, tracker).

    Raises:
        ScenarioError: The reference does not fit in the scenario.
    """
    return simulate(_case("simulate_reference", scenario, fields_, reference=reference), runs, progress=progress)


def simulate_plan(
    scenario: str | Scenario,
    *,
    planner: str | None = None,
    runs: Iterable[RunKind | str] | str = DEFAULT_RUNS,
    progress: Progress | None = None,
    **fields_: Any,
) -> JobResult:
    """Plan a scenario, smooth and time the plan, and track it once per run kind.

    Args:
        scenario: Built-in name, path of a scenario file, or a Scenario.
        planner: Registered planner name (default: the scenario's ``planner``).
        runs: Run kinds to run.
        progress: Told when planning starts and ends and how the runs advance.
        **fields_: Further :class:`~sim.pipeline.case.Case` fields (robot, seed, gains,
            control_rate, perturbation, tracker, and ``planning``: a
            :class:`~sim.pipeline.case.PlanOptions` with the budget, planner and smoothing options
            or a ready plan).

    Returns:
        The job; ``source`` is ``"planner:<name>"``, ``extra["plan"]`` holds the plan's status and
            statistics and ``extra["smoothing"]`` the smoothing's.

    Raises:
        ConfigError: A scenario that is none, a seed that is not an integer >= 0, a tracker without feedback for
            the closed loops; no planner given and the scenario names none; unknown planner; a ready plan
            (``planning=PlanOptions(plan=...)``) beside a ``planner`` other than the one that made it, or one that
            does not start at the scenario's start, end in its goal region or keep the robot's footprint clear of
            its world.
        ScenarioError: The start or goal lies outside the world or the robot's footprint overlaps something there.
        TrajectoryError: The plan failed or could not be made into a collision-free trajectory.
    """
    return simulate(_case("simulate_plan", scenario, fields_, planner=planner or ""), runs, progress=progress)


def simulate_file(
    source: TrajectoryFile | str | Path,
    scenario: str | Scenario | None = None,
    *,
    runs: Iterable[RunKind | str] | str = DEFAULT_RUNS,
    progress: Progress | None = None,
    **fields_: Any,
) -> JobResult:
    """Track a trajectory (timed) or path (untimed) file, as a plan is tracked, once per run kind.

    Args:
        source: The file and how to read it (a bare path: a timed file in metres and seconds).
        scenario: Built-in name, path of a scenario file, or a Scenario giving the world; None: an empty
            arena around the file (for ``robot``, default TurtleBot3).
        runs: Run kinds to run.
        progress: Told how the runs advance.
        **fields_: Further :class:`~sim.pipeline.case.Case` fields (robot, seed, gains, ...).

    Returns:
        The job; ``source`` is ``"file:<stem>"``, ``extra["import"]`` says what was read and repaired.

    Raises:
        TrajectoryFileError: The file cannot be read or used, or it enters an obstacle or leaves the
            world (unless ``source.allow_collisions``).
    """
    from planning.core.robot import load_robot
    from planning.trajectory.file_trajectory import ARENA_ROBOT, arena_scenario
    from planning.trajectory.importer import read_trajectory_file

    if not isinstance(source, TrajectoryFile):
        source = TrajectoryFile(Path(source))
    if scenario is None:
        robot = fields_.pop("robot", None) or ARENA_ROBOT
        scenario = arena_scenario(read_trajectory_file(source), load_robot(robot))
    return simulate(_case("simulate_file", scenario, fields_, trajectory_file=source), runs, progress=progress)


@dataclass(frozen=True)
class PreparedCase:
    """A case's trajectory and compiled simulator, built once to run many times (tuning).

    Attributes:
        trajectory: The case and its trajectory.
        simulator: The compiled simulator of its robot and world.
    """

    trajectory: PreparedTrajectory
    simulator: Simulator

    @property
    def case(self) -> Case:
        """The case."""
        return self.trajectory.case

    def with_build(self, build_seed: int | None) -> PreparedCase:
        """The same trajectory on another as-built robot: a simulator of that build is compiled
        here (self when the build is the case's own).

        Args:
            build_seed: Build seed of the robot (see :meth:`sim.pipeline.case.Case.as_built`); None
                for the robot as drawn.

        Raises:
            ConfigError: A bad build seed.
        """
        if build_seed == self.case.build_seed:
            return self
        trajectory = replace(self.trajectory, case=replace(self.case, build_seed=build_seed))
        return PreparedCase(trajectory, simulator_for(trajectory))

    def run(
        self,
        gains: FBLGains | None = None,
        perturbation: Perturbation | None = None,
        *,
        seed: int | None = None,
        params: Any = None,
    ) -> Run:
        """The case's single run (its tracker's kind), strict off: MuJoCo warnings are counted.

        Args:
            gains: Gains overriding the case's.
            perturbation: Perturbation overriding the case's.
            seed: Sensor noise seed overriding the case's (the trajectory, planned or not, stays).
            params: The tracker's tuned parameters overriding the case's (see ``Case.params``).
        """
        case = self.case
        if gains is not None or perturbation is not None or seed is not None or params is not None:
            case = replace(
                case,
                gains=gains or case.gains,
                perturbation=perturbation if perturbation is not None else case.perturbation,
                seed=seed if seed is not None else case.seed,
                params=params if params is not None else case.params,
            )
        job = track(replace(self.trajectory, case=case), (case.kind,), strict=False, simulator=self.simulator)
        return job.runs[case.kind]


def prepare_case(case: Case) -> PreparedCase:
    """Prepare a case's trajectory and compile its simulator.

    What would otherwise stop every run of the case is refused here, before any run: a control rate the
    physics steps cannot hold, sensor settings and a localiser the robot cannot take (so a study that
    runs the case many times, ``tune``, stops with the error instead of scoring failed runs).

    Raises:
        NhsimError: From :func:`sim.pipeline.case.prepare_trajectory`; ConfigError for the above.
    """
    prepared = prepare_trajectory(case)
    simulator = simulator_for(prepared)
    simulator.steps_per_control(case.control_rate)
    case.sensing(prepared.scenario)  # the sensors, and the localiser with them (Case.localiser_setup)
    return PreparedCase(prepared, simulator)


# ------------------------------------------------------------------------------------------ plans
def applicable_planners(scenario: Scenario) -> list[str]:
    """The registered planners that apply to a scenario (the rule ``simulate --all`` uses).

    A planner applies when the scenario names it (its ``planner`` field), or when it is built in (one of
    ``planning.planners.registry.PLANNERS``' own entries) and avoids obstacles or the scenario has none: a
    planner whose factory says ``ignores_obstacles = True`` (sinusoidal steering) plans obstacle-free scenarios
    only. A plugin's planner applies only where a scenario names it. A scenario whose goal is its start (same
    position and heading, e.g. ``open``, the arena for analytic references) has nothing to plan and gets no
    planner.
    """
    if nothing_to_plan(scenario):
        return []
    built_in = set(PLANNERS.built_in())
    names = []
    for name in sorted(PLANNERS):
        if name == scenario.planner:
            names.append(name)
        elif name in built_in and not (scenario.world.obstacles and ignores_obstacles(name)):
            names.append(name)
    return names


def ignores_obstacles(planner: str) -> bool:
    """Whether a registered planner plans as if the world were empty (its factory's ``ignores_obstacles``
    attribute; False without one)."""
    return bool(getattr(PLANNERS.factory(planner), "ignores_obstacles", False))
