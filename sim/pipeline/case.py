"""Cases: one seeded closed-loop run (scenario × robot × reference or planner × tracker), as the
tuner and the regression suite name them.

A case tracks either an analytic reference placed at the scenario's start pose
(``reference = "figure8"``) or a plan of the scenario (``planner = "rrt"``). A planned case plans,
smooths and times the scenario once through :func:`sim.pipeline.simulate.simulate_plan`, and every run of the case
tracks that trajectory.

On the command line (``nhsim tune --scenarios``) a case is ``SCENARIO:REFERENCE`` (e.g.
``open:figure8``), ``SCENARIO:PLANNER`` or a bare ``SCENARIO`` (planned with the default planner).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from control.base import TRACKERS, make_tracker, tracker_options
from control.fbl import FBLGains
from planning.core.robot import ROBOT_FILES, RobotSpec, load_robot
from planning.errors import ConfigError, ScenarioError
from planning.scenario import Scenario, load_scenario
from planning.trajectory.references import REFERENCES, make_reference
from planning.trajectory.trajectory import Trajectory
from sim.physics.metrics import TrackingMetrics, compute_metrics
from sim.physics.perturb import Perturbation
from sim.physics.runlog import RunLog
from sim.physics.simulator import SimConfig, Simulator
from sim.pipeline.simulate import PLAN_HOLD_S, simulate_plan


@dataclass(frozen=True)
class Case:
    """One seeded run.

    Attributes:
        scenario: Built-in scenario name or path.
        robot: Robot name; None for the scenario's robot.
        reference: Analytic reference name (exclusive with ``planner``).
        planner: Planner name (exclusive with ``reference``); "" for the default planner.
        tracker: Tracker name (a key of ``TRACKERS``).
        seed: Seed of the run (planner and noise).
        control_rate: Tracker rate [Hz].
        gains: FBL gains; None for the defaults.
        perturbation: Physics perturbation; None for the nominal model.
        name: Case name; derived from the fields when empty.
        fast: In the default (fast) subset of a regression suite.
    """

    scenario: str
    robot: str | None = None
    reference: str | None = None
    planner: str | None = None
    tracker: str = "fbl"
    seed: int = 0
    control_rate: float = 50.0
    gains: FBLGains | None = None
    perturbation: Perturbation | None = None
    name: str = ""
    fast: bool = False

    def __post_init__(self) -> None:
        if (self.reference is None) == (self.planner is None):
            raise ConfigError(f"case {self.label}: give exactly one of reference or planner")
        if self.reference is not None and self.reference not in REFERENCES:
            raise ConfigError(
                f"case {self.label}: unknown reference {self.reference!r}; choose {', '.join(REFERENCES)}"
            )
        if self.tracker not in TRACKERS:
            raise ConfigError(f"case {self.label}: unknown tracker {self.tracker!r}; choose {', '.join(TRACKERS)}")
        if self.robot is not None and self.robot not in ROBOT_FILES:
            raise ConfigError(f"case {self.label}: unknown robot {self.robot!r}; choose {', '.join(ROBOT_FILES)}")
        if not self.name:
            object.__setattr__(self, "name", self._derived_name())

    def _derived_name(self) -> str:
        what = self.reference if self.reference is not None else f"plan-{self.planner or 'default'}"
        parts = [self.scenario, self.robot or "default", what, self.tracker, f"s{self.seed}"]
        if self.control_rate != 50.0:
            parts.append(f"{self.control_rate:g}hz")
        return "-".join(parts)

    @property
    def label(self) -> str:
        """Name if set, else the fields in short."""
        return self.name or f"{self.scenario}:{self.reference or self.planner}"

    @property
    def token(self) -> str:
        """``SCENARIO:REFERENCE`` / ``SCENARIO:PLANNER`` form."""
        return f"{self.scenario}:{self.reference if self.reference is not None else self.planner}"

    @classmethod
    def parse(cls, token: str, **fields_: Any) -> Case:
        """A case from ``SCENARIO[:REFERENCE|:PLANNER]`` plus keyword fields (robot, seed, ...).

        Raises:
            ConfigError: Empty token.
        """
        scenario, _, second = token.strip().partition(":")
        if not scenario:
            raise ConfigError(f"case {token!r}: expected SCENARIO:REFERENCE (e.g. open:figure8) or SCENARIO:PLANNER")
        if second in REFERENCES:
            return cls(scenario, reference=second, **fields_)
        return cls(scenario, planner=second, **fields_)


@dataclass
class PreparedCase:
    """A case with its scenario, robot, reference and simulator built once, to run many times.

    Attributes:
        case: The case.
        scenario: The loaded scenario (with the case's robot).
        robot: The robot spec.
        trajectory: The reference the tracker follows.
        simulator: The compiled simulator.
        extra: Plan statistics and the like.
        hold: Time simulated after the trajectory ends [s] (final regulation of planned cases).
    """

    case: Case
    scenario: Scenario
    robot: RobotSpec
    trajectory: Trajectory
    simulator: Simulator
    extra: dict[str, Any] = field(default_factory=dict)
    hold: float = 0.0

    def run(
        self, gains: FBLGains | None = None, perturbation: Perturbation | None = None
    ) -> tuple[RunLog, TrackingMetrics]:
        """Run the case once (strict off: MuJoCo warnings are counted in the metrics).

        Args:
            gains: Gains overriding the case's.
            perturbation: Perturbation overriding the case's.
        """
        c = self.case
        options = {"gains": gains or c.gains or FBLGains()} if "gains" in tracker_options(c.tracker) else {}
        tracker = make_tracker(c.tracker, self.robot, **options)
        pert = perturbation if perturbation is not None else c.perturbation
        log = self.simulator.run(
            self.trajectory, tracker, SimConfig(control_rate=c.control_rate, hold=self.hold, strict=False),
            start=self.scenario.start, meta={"seed": c.seed, "case": c.name}, perturbation=pert,
        )  # fmt: skip
        m = compute_metrics(log, self.trajectory, max_speed=self.robot.max_speed, max_yaw_rate=self.robot.max_yaw_rate)
        return log, m


def load_case_scenario(case: Case) -> Scenario:
    """The case's scenario with its robot.

    Raises:
        ScenarioError: Unknown scenario (the message lists the built-in ones) or a bad file.
    """
    sc = load_scenario(case.scenario)
    return sc.with_robot(case.robot) if case.robot is not None else sc


def prepare(case: Case) -> PreparedCase:
    """Build what a case needs (scenario, robot, reference or plan, simulator).

    Raises:
        ScenarioError: Unknown scenario, or a reference that does not fit in the scenario.
        ConfigError: A planned case where this build has no ``sim.pipeline.simulate.simulate_plan``.
    """
    sc = load_case_scenario(case)
    spec = load_robot(sc.robot)
    extra: dict[str, Any] = {}
    if case.reference is not None:
        traj = make_reference(case.reference, spec, sc.start)
        clearance = sc.world.signed_distance(traj.pose[:, :2])
        if float(clearance.min()) <= spec.radius:
            raise ScenarioError(
                f"case {case.label}: reference {case.reference!r} at the start of scenario {sc.name!r} comes within "
                f"{spec.radius:.3f} m (the robot's radius) of an obstacle or wall; use a scenario with room around "
                f"its start pose or a planner"
            )
    else:
        # plan and time the trajectory only (no runs); the case's tracker runs it below
        result = simulate_plan(
            sc, planner=case.planner or None, seed=case.seed, trackers=(),
            config=SimConfig(control_rate=case.control_rate),
        )  # fmt: skip
        traj = result.trajectory
        extra = dict(result.extra)
        hold = PLAN_HOLD_S
        return PreparedCase(case, sc, spec, traj, Simulator(spec, sc.world), extra, hold=hold)
    return PreparedCase(case, sc, spec, traj, Simulator(spec, sc.world), extra)


def with_fields(case: Case, **changes: Any) -> Case:
    """A copy of a case with fields changed (the name is kept unless given)."""
    return replace(case, **changes)
