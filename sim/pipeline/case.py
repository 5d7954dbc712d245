"""Cases and the plan -> trajectory stage: what to run, and the trajectory a case's runs follow.

A :class:`Case` is one seeded job: scenario × robot × reference or planner × tracker, with its gains,
control rate and perturbation. ``nhsim simulate`` (one job and the ``--all`` sweep), the tuner and the
regression suite all describe their work as cases.

A case tracks an analytic reference placed at the scenario's start pose (``reference = "figure8"``),
a plan of the scenario (``planner = "rrt"``), or a trajectory or path read from a file
(``trajectory_file``, :mod:`planning.trajectory.importer`; the scenario then starts and ends where the
file does).
:func:`prepare_trajectory` makes the trajectory once (a planned case plans, smooths and times the
scenario); :func:`sim.pipeline.simulate.track` runs it.

On the command line (``nhsim tune --scenarios``) a case is ``SCENARIO:REFERENCE`` (e.g.
``open:figure8``), ``SCENARIO:PLANNER`` or a bare ``SCENARIO`` (planned with the default planner).
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import os
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from control.base import TRACKERS, tuned_or_none
from control.estimation.amcl import AmclConfig
from control.fbl import uses_fbl_gains
from control.gains import FBLGains, check_sampled_stability
from planning.collision.exact import DEFAULT_TOLERANCE, CollisionChecker
from planning.core.checks import check_fields, check_flag, check_number
from planning.core.geometry import Pose2D, wrap_angle
from planning.core.robot import RobotSpec, check_robot_name, load_robot
from planning.core.world import span
from planning.errors import ConfigError, ScenarioError, option, options
from planning.planners.base import PlanProblem, PlanResult, PlanStatus, path_collision, run_planner
from planning.planners.registry import PLANNERS, make_planner, planner_options
from planning.scenario import Scenario, builtin_scenarios, load_scenario, scenario_source
from planning.scenario import scenario_with_robot as scenario_with_robot  # defined beside load_scenario
from planning.trajectory.file_trajectory import ARENA_NAME, file_poses, file_trajectory, with_file_ends
from planning.trajectory.from_plan import checked_trajectory
from planning.trajectory.importer import TrajectoryFile, read_trajectory_file
from planning.trajectory.references import REFERENCES, make_reference
from planning.trajectory.trajectory import Trajectory
from sim.physics.asbuilt import DEFAULT_BUILD_SEED, AsBuilt, check_build_seed
from sim.physics.lidar import LDS01_PLANE, load_lidar_profile
from sim.physics.motors import supplied_robot
from sim.physics.perturb import Perturbation
from sim.physics.sensors import load_sensor_profile
from sim.pipeline.runs import PLAN_HOLD_S, PLAN_TRACKER, REFERENCE_TRACKER, Progress, RunKind
from sim.pipeline.sensor_settings import lidar_overrides, sensor_overrides
from sim.robot.pose_estimate import INITIAL_POSES, parse_initial_pose
from sim.robot.scan_localiser import LOCALISERS, LocaliserSetup
from sim.robot.sensing import SensingSetup

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PlanOptions:
    """How a planned case gets its plan.

    Attributes:
        time_limit: Planning budget [s].
        planner_options: Keyword options for the planner factory, over the scenario's own
            ``[planners.<name>]`` options for it.
        smoothing: Keyword options for :func:`planning.trajectory.from_plan.make_trajectory`.
        plan: A ready plan to use instead of planning (its ``planner`` names the source); one that comes closer
            to an obstacle or wall than ``clearance`` is tracked with a :class:`GrazingPlanWarning`.
        clearance: Margin [m] the plan keeps from obstacles and walls, given to planners that take
            a ``clearance`` option unless the scenario or ``planner_options`` set one. The robot
            follows its plan to a few millimetres, fed by its estimator, so a plan that grazed a
            parked car by 3 mm had it touch the car; 0 plans to the limit. Less where the start or
            the goal stands closer to something (:func:`tracked_margin`), and halved while the planner's own
            check finds them closer than it (:func:`_plan_with_margin`).
    """

    time_limit: float = 30.0
    planner_options: Mapping[str, Any] = field(default_factory=dict)
    smoothing: Mapping[str, Any] = field(default_factory=dict)
    plan: PlanResult | None = None
    clearance: float = 0.01

    def __post_init__(self) -> None:
        limits = {
            "time_limit": {"above": 0.0, "unit": "s"},
            "clearance": {"at_least": 0.0, "unit": "m, 0 plans to the limit"},
        }
        check_fields(self, limits, "PlanOptions.")
        for name in ("planner_options", "smoothing"):
            if not isinstance(getattr(self, name), Mapping):
                raise ConfigError(
                    f"PlanOptions.{name} must be a mapping of keyword options, e.g. {{}}, got {getattr(self, name)!r}"
                )
        if self.plan is not None and not isinstance(self.plan, PlanResult):
            raise ConfigError(f"PlanOptions.plan must be a PlanResult (a planner's plan) or None, got {self.plan!r}")


def check_case_scenario(where: str, scenario: object) -> str | Scenario:
    """``scenario`` as a case takes it: a :class:`Scenario`, or text that :func:`load_scenario` reads (a built-in
    scenario's name, a scenario file's path, ``random<N>``); a path (``pathlib.Path``) is made text.

    Raises:
        ConfigError: Anything else (None, a number, empty text), naming ``where``, what was given and what to give.
    """
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, os.PathLike):
        scenario = os.fspath(scenario)
    if isinstance(scenario, str) and scenario.strip():
        return scenario
    raise ConfigError(
        f"{where} must be a Scenario (load_scenario(NAME), or Scenario(...)), a built-in scenario's name (one of "
        f"{', '.join(builtin_scenarios())}), the path of a scenario .toml file, or random<N> for the generated world "
        f"of seed N (e.g. 'random7'), got {scenario!r:.80}"
    )


@dataclass(frozen=True)
class Case:
    """One seeded job.

    Attributes:
        scenario: Built-in scenario name, path of a scenario file (text or a ``Path``, kept as text),
            ``random<N>``, or a loaded Scenario.
        robot: Robot name; None for the scenario's robot.
        reference: Analytic reference name (exclusive with ``planner``).
        planner: Planner name (exclusive with ``reference``); "" for the scenario's planner.
        tracker: Feedback tracker (a key of ``TRACKERS``); None for the source's default
            (``REFERENCE_TRACKER`` for a reference, ``PLAN_TRACKER`` for a plan). One without feedback
            ("open-loop") makes the case's single run (:attr:`kind`) the open loop; a job of closed-loop
            runs refuses it (:func:`sim.pipeline.simulate.check_feedback_tracker`).
        seed: Seed of the job (planner and sensor noise), an integer >= 0.
        control_rate: Tracker rate [Hz].
        gains: FBL gains; None for the defaults.
        params: The feedback tracker's tuned parameters (the value of its tuned option, e.g. an
            ``MPCParams`` for "mpc", see :func:`control.base.tuned_option`); None for its defaults.
        perturbation: Physics perturbation; None for the nominal model.
        name: Case name; derived from the fields when empty.
        fast: In the default (fast) subset of a regression suite.
        planning: Planning budget and options of a planned case.
        build_seed: Seed of the robot's as-built draw (wheel radii, track, friction, mass, centre of
            mass within their tolerances, :mod:`sim.physics.asbuilt`); None for the robot as drawn.
        sensors: ``key=value,...`` overrides of the robot's sensor profile (over the scenario's
            ``[sensors]`` table), e.g. ``fix_rate=10,fix_position_std=0.01``; "" for none.
        noise_seed: Seed of the sensor noise when it differs from ``seed`` (a Monte Carlo run of a
            plan made once); None: ``seed``.
        trajectory_file: A trajectory or path file to track (exclusive with ``reference`` and
            ``planner``); tracked like a plan (segmented tracker, final regulation).
        localiser: Source of the EKF's pose corrections: "amcl" (the robot's laser scans matched
            against the map), "fixes" (synthetic Gaussian fixes), None for the robot's default (amcl
            for a robot with a scanner, the TurtleBot3; fixes otherwise, the EduMIP's motion-capture-like
            source).
        lidar: ``key=value,...`` overrides of the scanner's settings; "" for none.
        amcl: ``key=value,...`` overrides of the localiser's settings; "" for none.
        initial_pose: "known" (the localiser starts around the start pose) or "unknown" (global
            localisation before tracking).
        motors: ``key=value,...`` overrides of the robot's supply (``battery_voltage``, ``supply_sag``,
            ``torque_reserve``; :func:`sim.physics.motors.supplied_robot`), which move its speed limits;
            "" for the robot's own.
    """

    scenario: str | Scenario
    robot: str | None = None
    reference: str | None = None
    planner: str | None = None
    tracker: str | None = None
    seed: int = 0
    control_rate: float = 50.0
    gains: FBLGains | None = None
    perturbation: Perturbation | None = None
    name: str = ""
    params: Any = None
    fast: bool = False
    planning: PlanOptions = field(default_factory=PlanOptions)
    build_seed: int | None = DEFAULT_BUILD_SEED
    sensors: str = ""
    noise_seed: int | None = None
    trajectory_file: TrajectoryFile | None = None
    localiser: str | None = None
    lidar: str = ""
    amcl: str = ""
    initial_pose: str = "known"
    motors: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "scenario", check_case_scenario("Case.scenario", self.scenario))
        object.__setattr__(self, "seed", check_number("Case.seed", self.seed, integer=True, at_least=0))
        rate = check_number("Case.control_rate", self.control_rate, above=0.0, unit="Hz", fix="e.g. 50.0")
        object.__setattr__(self, "control_rate", rate)
        object.__setattr__(self, "fast", check_flag("Case.fast", self.fast))
        if not isinstance(self.planning, PlanOptions):
            raise ConfigError(f"case {self.label}: planning must be a PlanOptions(...), got {self.planning!r}")
        if self.perturbation is not None and not isinstance(self.perturbation, Perturbation):
            raise ConfigError(
                f"case {self.label}: perturbation must be a Perturbation (e.g. Perturbation.parse('mass=1.3')) or "
                f"None, got {self.perturbation!r}"
            )
        self._settings_text()
        if self.localiser not in (None, *LOCALISERS):
            raise ConfigError(
                f"case {self.label}: unknown localiser {self.localiser!r}; choose {', '.join(LOCALISERS)}"
            )
        if self.initial_pose not in INITIAL_POSES:
            try:
                parse_initial_pose(self.initial_pose)  # a pose estimate; checked against the world with it
            except ConfigError as exc:
                raise ConfigError(
                    f"case {self.label}: unknown initial pose {self.initial_pose!r}: choose known or unknown, or give "
                    f"a pose estimate X,Y,THETA ({exc})"
                ) from None
        if self.build_seed is not None:
            check_build_seed(self.build_seed)
        if sum(x is not None for x in (self.reference, self.planner, self.trajectory_file)) != 1:
            raise ConfigError(
                f"case {self.label}: give exactly one of reference or planner, or a trajectory_file instead of both"
            )
        if self.planner is None and self.planning.planner_options:
            given = ", ".join(self.planning.planner_options)
            raise ConfigError(
                f"case {self.label}: planner options ({given}) are given but nothing is planned (an analytic "
                "reference or a file is tracked): drop them (--planner-option), or plan"
            )
        self._check_ready_plan()
        if self.reference is not None and self.reference not in REFERENCES:
            raise ConfigError(
                f"case {self.label}: unknown reference {self.reference!r}; choose {', '.join(REFERENCES)}"
            )
        if self.tracker is not None and self.tracker not in TRACKERS:
            raise ConfigError(
                f"case {self.label}: unknown tracker {self.tracker!r}; choose {', '.join(TRACKERS)}; "
                f"{TRACKERS.unknown_hint()}"
            )
        if self.robot is not None:
            check_robot_name(f"case {self.label}", self.robot)
        self._check_gains()
        if not self.name:
            object.__setattr__(self, "name", self._derived_name())

    def with_plan(self, plan: PlanResult, scenario: Scenario) -> Case:
        """This case on its loaded ``scenario`` with ``plan`` (made for it) as its ready plan, the name kept."""
        return dataclasses.replace(
            self, scenario=scenario, planner="", planning=dataclasses.replace(self.planning, plan=plan)
        )

    def _settings_text(self) -> None:
        """``sensors``, ``lidar``, ``amcl`` and ``motors`` are ``key=value,...`` text (a mapping is refused naming the
        text it stands for); ``sensors`` may be a sensor settings file's path instead (``--sensors FILE``), whose
        ``[sensors]`` and ``[lidar]`` tables become the case's text (``lidar`` given here over the file's)."""
        for name in ("sensors", "lidar", "amcl", "motors"):
            value = getattr(self, name)
            if isinstance(value, os.PathLike) and name == "sensors":
                object.__setattr__(self, name, os.fspath(value))
            elif not isinstance(value, str):
                text = ",".join(f"{k}={v}" for k, v in value.items()) if isinstance(value, Mapping) else "key=value,..."
                raise ConfigError(
                    f"case {self.label}: {name} must be text of key=value pairs, e.g. {name}={text!r}"
                    + (" or a sensor settings file's path" if name == "sensors" else "")
                    + f", got {type(value).__name__} {value!r:.80}"
                )
        if self.sensors:
            lidar = lidar_overrides(self.sensors, self.lidar, self.localiser)  # the file's [lidar], then ours
            object.__setattr__(self, "sensors", sensor_overrides(self.sensors))
            object.__setattr__(self, "lidar", lidar)

    def _check_ready_plan(self) -> None:
        """A ready plan (``planning.plan``) is tracked as it is: refused beside a reference or a file (which would be
        tracked instead of it), and beside a planner other than the one that made it (which would never plan)."""
        plan = self.planning.plan
        if plan is None:
            return
        if self.planner is None:
            tracked = "reference" if self.reference is not None else "trajectory_file"
            raise ConfigError(
                f"case {self.label}: a ready plan (PlanOptions(plan=...)) is given, but {tracked} is what would be "
                f"tracked: drop the plan, or give planner='' to track it"
            )
        if self.planner and self.planner != plan.planner:
            raise ConfigError(
                f"case {self.label}: the ready plan (PlanOptions(plan=...)) was made by {plan.planner!r}, but planner "
                f"{self.planner!r} is named; a ready plan is tracked as it is, not planned again: give planner='' (or "
                f"{plan.planner!r}) to track it, or drop the plan to plan with {self.planner!r}"
            )

    def _check_gains(self) -> None:
        """The FBL gains are given once: as ``gains``, or as ``params`` for a tracker whose tuned option they are
        (fbl, segmented), not both with different values; gains other than the defaults are refused for a tracker
        that takes none (they would change nothing)."""
        if self.gains is not None and not isinstance(self.gains, FBLGains):
            raise ConfigError(f"case {self.label}: gains must be FBLGains(kp=..., kd=...) or None, got {self.gains!r}")
        name = self.feedback_tracker
        if not uses_fbl_gains(name):
            if self.gains is not None and self.gains != FBLGains():
                kind = tuned_or_none(name)
                own = f"params={kind[1].__name__}(...)" if kind is not None else "none it takes"
                raise ConfigError(
                    f"case {self.label}: gains {self.gains} are given, but tracker {name!r} does not use the FBL's "
                    f"gains, so they would change nothing: drop them (its own parameters: {own})"
                )
            return
        if self._params_are_gains and self.gains is not None and self.gains != self.params:
            raise ConfigError(
                f"case {self.label}: tracker {name!r} is given two sets of FBL gains, gains={self.gains} and "
                f"params={self.params} (its tuned parameters are its gains): give them once, as gains=FBLGains(...)"
            )
        # the gains the runs use, the defaults too (the trackers' reset refuses them, after the planning)
        check_sampled_stability(self.fbl_gains or FBLGains(), self.control_rate, f"case {self.label}")

    @property
    def fbl_gains(self) -> FBLGains | None:
        """The FBL gains the case's feedback runs use: ``params`` when they are the tracker's gains (its tuned
        option), else ``gains`` or the defaults; None for a tracker that takes none (mpc, rpp, kanayama)."""
        if not uses_fbl_gains(self.feedback_tracker):
            return None
        if self._params_are_gains:
            return self.params  # type: ignore[no-any-return]
        return self.gains or FBLGains()

    @property
    def _params_are_gains(self) -> bool:
        """Whether ``params`` holds FBL gains given as the feedback tracker's tuned option."""
        tuned = tuned_or_none(self.feedback_tracker)
        return isinstance(self.params, FBLGains) and tuned is not None and tuned[0] == "gains"

    def _derived_name(self) -> str:
        file = None if self.trajectory_file is None else self.trajectory_file.name
        fields = (self.robot, self.reference, self.planner, self.feedback_tracker, self.seed)
        return case_name(self.scenario_name, *fields, self.noise_seed, self.control_rate, file)

    @property
    def scenario_name(self) -> str:
        """The scenario's name (or path, as given)."""
        return self.scenario.name if isinstance(self.scenario, Scenario) else self.scenario

    @property
    def label(self) -> str:
        """Name if set, else the fields in short."""
        return self.name or self.token

    @property
    def token(self) -> str:
        """``SCENARIO:REFERENCE`` / ``SCENARIO:PLANNER`` form."""
        if self.trajectory_file is not None:
            return f"{self.scenario_name}:{self.trajectory_file.path}"
        return f"{self.scenario_name}:{self.reference if self.reference is not None else self.planner}"

    @property
    def feedback_tracker(self) -> str:
        """The tracker of the closed-loop run: ``tracker``, else the source's default."""
        if self.tracker is not None:
            return self.tracker
        return REFERENCE_TRACKER if self.reference is not None else PLAN_TRACKER

    @property
    def kind(self) -> RunKind:
        """The kind of the case's single run (tuning, regression): the one its tracker belongs to."""
        return RunKind.of_tracker(self.feedback_tracker)

    def as_built(self, robot: str) -> AsBuilt:
        """The robot as built for this case (nominal without a build seed)."""
        return AsBuilt.nominal() if self.build_seed is None else AsBuilt.draw(robot, self.build_seed)

    def robot_spec(self, robot: str) -> RobotSpec:
        """The robot on the case's supply (its limits those of the battery's voltage).

        Raises:
            ConfigError: Bad ``motors`` overrides, or overrides for a robot whose supply is fixed.
        """
        return supplied_robot(load_robot(robot), self.motors)

    def sensing(self, scenario: Scenario) -> SensingSetup:
        """The sensors of the case's runs: the robot's profile, the scenario's ``[sensors]`` table and
        the case's overrides, with the case's noise seed (its seed unless set apart) for every noise draw.

        Raises:
            ConfigError: An unknown sensor key or a bad value, or a fix rate that is no whole number of control
                periods (naming the field, the scenario file when its table set it, and the fix).
        """
        table = dict(scenario.sensors)
        where = scenario_source(scenario)
        profile = load_sensor_profile(
            scenario.robot, table=table or None, text=self.sensors or None, source=where, control_rate=self.control_rate
        )
        seed = self.seed if self.noise_seed is None else self.noise_seed
        return SensingSetup(profile, seed, localiser=self.localiser_setup(scenario))

    def localiser_options(self) -> dict[str, str]:
        """The localiser settings given to the case (``localiser``, ``lidar``, ``amcl``, an unknown
        ``initial_pose``), those left to the robot's own omitted: what a study made before they could be
        given did not record."""
        given = {"localiser": self.localiser or "", "lidar": self.lidar, "amcl": self.amcl}
        given["initial_pose"] = "" if self.initial_pose == "known" else self.initial_pose
        return {k: v for k, v in given.items() if v}

    def localiser_setup(self, scenario: Scenario) -> LocaliserSetup:
        """The case's localiser for the scenario's robot (see ``localiser``).

        Raises:
            ConfigError: amcl (or scanner or localiser settings, or an unknown initial pose) for a robot
                without a laser scanner, scanner or localiser settings with the fixes localiser, an
                unknown initial pose in a world without obstacles, or a bad scanner or localiser setting.
        """
        lidar = load_lidar_profile(scenario.robot, text=self.lidar or None)
        kind = self.localiser or ("amcl" if lidar is not None else "fixes")
        initial = ("initial-pose", self.initial_pose)
        if lidar is None and (kind == "amcl" or self.amcl or self.initial_pose != "known"):
            asked: list[str | tuple[str, str]] = [
                opt
                for opt, on in (
                    (("localiser", "amcl"), kind == "amcl"),
                    ("amcl", self.amcl),
                    (initial, self.initial_pose != "known"),
                )
                if on
            ]
            one = len(asked) == 1
            raise ConfigError(
                f"robot {scenario.robot!r} has no laser scanner: {options(*asked)} {'needs' if one else 'need'} one "
                f"(the TurtleBot3's LDS-01); drop {'it' if one else 'them'}: the {scenario.robot} localises from fixes"
            )
        if kind == "fixes":
            given: list[str | tuple[str, str]] = [opt for opt, on in (("lidar", self.lidar), ("amcl", self.amcl)) if on]
            given += [initial] if self.initial_pose != "known" else []
            if given:  # with fixes no scan is taken: the settings would be ignored
                raise ConfigError(
                    f"{options(*given)} {'needs' if len(given) == 1 else 'need'} the amcl localiser (the fixes "
                    f"localiser takes no scan): drop {'it' if len(given) == 1 else 'them'}, or use "
                    f"{option('localiser', 'amcl')}"
                )
            return LocaliserSetup()
        seen = scenario.world.seen_at(LDS01_PLANE)  # the scanner's world: its low obstacles are not in the scan
        if self.initial_pose == "unknown" and not seen.obstacles:  # a pose estimate tells the twins apart
            low = (
                f" (its {len(scenario.world.obstacles)} obstacle(s) all below the scan plane)"
                if scenario.world.obstacles
                else ""
            )
            raise ConfigError(
                f"{option('initial-pose', 'unknown')} in {scenario.name!r}, a bare rectangle of walls to the scanner"
                f"{low}: its scans look the same from a pose and from that pose turned half a turn about the centre, "
                "so global localisation cannot tell them apart; use a world with obstacles the scan sees, or "
                f"{option('initial-pose', 'known')}"
            )
        amcl = AmclConfig().parse(self.amcl) if self.amcl else AmclConfig()
        return LocaliserSetup("amcl", scenario.world, lidar, amcl, self.initial_pose)

    def run_settings(self, scenario: Scenario) -> dict[str, Any]:
        """What the case's runs depend on besides the scenario and the path's source, resolved: the
        values the runs use (the robot's sensor profile with the overrides applied, the localiser the robot
        gets by default, the noise seed ``seed`` stands for), not the settings as written, so two ways of
        asking for the same runs give the same settings. JSON-ready; names as in the run record.

        Raises:
            ConfigError: As :meth:`sensing` and :meth:`robot_spec`.
        """
        sensing = self.sensing(scenario)
        spec = self.robot_spec(scenario.robot)
        pert = self.perturbation
        source, file = self.trajectory_file, None
        if source is not None:  # how the file is read; the file itself is the source, named apart
            file = {k: v for k, v in source.as_dict().items() if k not in ("file", "kind")}
            file.update(scale=source.scale or 1.0, time_scale=source.time_scale or 1.0)
        return {
            "tracker": self.feedback_tracker,
            "params": repr(self.params) if self.params is not None else None,
            # the FBL's gains where the tracker takes them (None for mpc, rpp, kanayama: their params say theirs)
            "gains": None if (gains := self.fbl_gains) is None else dataclasses.asdict(gains),
            "control_rate_hz": float(self.control_rate),
            "seed": self.seed,
            "noise_seed": sensing.seed,
            "build_seed": self.build_seed,
            "supply": {
                k: getattr(spec, k) for k in ("battery_voltage", "max_wheel_speed", "max_speed", "max_yaw_rate")
            },
            "sensors": sensing.profile.as_dict(),
            "localiser": sensing.localiser.as_dict(sensing.seed),
            "perturbation": pert.as_dict() if pert is not None and not pert.is_nominal else None,
            "time_limit_s": float(self.planning.time_limit) if self.planner is not None else None,
            "file": file,
        }

    def tracker_for(self, kind: RunKind) -> str:
        """The tracker a run of ``kind`` uses in this case."""
        return kind.tracker or self.feedback_tracker

    @staticmethod
    def split(token: str) -> tuple[str, str]:
        """``SCENARIO[:REFERENCE|:PLANNER]`` as (scenario, the second part or ""): the token whole when it names an
        existing file (a path with a colon in it), else split at its last colon (a reference's or a planner's name
        has none), so ``/data/run:2/yard.toml:line`` is the file and ``line``."""
        token = token.strip()
        if ":" not in token or os.path.isfile(token):
            return token, ""
        scenario, _, second = token.rpartition(":")
        return scenario, second

    @classmethod
    def parse(cls, token: str, **fields_: Any) -> Case:
        """A case from ``SCENARIO[:REFERENCE|:PLANNER]`` plus keyword fields (robot, seed, ...).

        Raises:
            ConfigError: Empty token, or a second part that is neither a reference nor a planner (the
                message lists both).
        """
        scenario, second = cls.split(token)
        if not scenario:
            raise ConfigError(f"case {token!r}: expected SCENARIO:REFERENCE (e.g. open:figure8) or SCENARIO:PLANNER")
        if second in REFERENCES:
            return cls(scenario, reference=second, **fields_)
        if second and second not in PLANNERS:
            raise ConfigError(
                f"case {token!r}: {second!r} is neither a reference ({', '.join(REFERENCES)}) nor a planner "
                f"({', '.join(sorted(PLANNERS)) or 'none registered'}); write SCENARIO:REFERENCE or SCENARIO:PLANNER"
            )
        return cls(scenario, planner=second, **fields_)


@dataclass(frozen=True)
class PreparedTrajectory:
    """A case with its scenario, robot and the trajectory its runs follow.

    Attributes:
        case: The case.
        scenario: The scenario (with the case's robot).
        robot: The robot spec.
        trajectory: The reference the trackers follow.
        source: ``"reference:<name>"`` or ``"planner:<name>"``.
        hold: Time simulated after the trajectory ends [s] (final regulation of planned cases).
        extra: Record fields of the stage: a plan's ``plan`` status and statistics and its
            ``smoothing`` statistics; empty for a reference.
        path: (M, 3) the poses the trajectory was made from: the planner's path, a path file's rows
            or a timed file's samples [m, m, rad]; None for a reference.
    """

    case: Case
    scenario: Scenario
    robot: RobotSpec
    trajectory: Trajectory
    source: str
    hold: float = 0.0
    extra: Mapping[str, Any] = field(default_factory=dict)
    path: FloatArray | None = None


def case_name(
    scenario: str,
    robot: str | None,
    reference: str | None,
    planner: str | None,
    tracker: str,
    seed: object,
    noise_seed: object = None,
    control_rate: object = 50.0,
    trajectory_file: str | None = None,
) -> str:
    """The name a case without one is given (:attr:`Case.name`): scenario, robot, what it tracks, the tracker, the
    seed, then the noise seed and the control rate where not the default. Also for a suite's case whose fields do
    not make a case (an unregistered tracker), so its messages name it as ``--list`` does."""
    what = reference if reference is not None else f"plan-{planner or 'default'}"
    if trajectory_file is not None:
        what = f"file-{trajectory_file}"
    parts = [scenario, robot or "default", what, tracker, f"s{seed}"]
    if noise_seed is not None:
        parts.append(f"n{noise_seed}")
    if control_rate != 50.0:
        parts.append(f"{control_rate:g}hz" if isinstance(control_rate, (int, float)) else f"{control_rate}hz")
    return "-".join(parts)


def load_case_scenario(case: Case) -> Scenario:
    """The case's scenario with its robot, which must fit at its start and goal (a trajectory file's case
    starts and ends where the file does instead: the file is checked against the world when it is read).

    Raises:
        ScenarioError: Unknown scenario (the message lists the built-in ones), a bad file, or a start or
            goal where the robot's footprint overlaps an obstacle or wall.
        ConfigError: The scenario does not list the case's robot.
    """
    sc = case.scenario if isinstance(case.scenario, Scenario) else load_scenario(case.scenario)
    sc = scenario_with_robot(sc, case.robot, ends=case.trajectory_file is None)
    if case.trajectory_file is not None:
        sc = with_file_ends(sc, read_trajectory_file(case.trajectory_file))
    return sc


#: Clearance kept beyond the robot's radius when a reference is fitted to its room [m].
FIT_MARGIN_M = 0.02


def fitted_reference(name: str, scenario: Scenario, robot: RobotSpec) -> Trajectory:
    """The named reference from the scenario's start; one that takes a ``length`` (the line) and
    would run into a wall or obstacle is made as long as the room ahead allows (the robot's radius
    and :data:`FIT_MARGIN_M` clear), up to its own default length."""
    traj = make_reference(name, robot, scenario.start)
    clearance = scenario.world.signed_distance(traj.pose[:, :2])
    needed = robot.radius + FIT_MARGIN_M
    takes_length = "length" in inspect.signature(REFERENCES[name]).parameters
    if not takes_length or float(clearance.min()) > needed:
        return traj
    blocked = int(np.argmax(clearance <= needed))
    room = float(np.sum(np.hypot(*np.diff(traj.pose[: blocked + 1, :2], axis=0).T)))
    return make_reference(name, robot, scenario.start, length=room) if room > 0 else traj


def check_reference_fits(name: str, trajectory: Trajectory, scenario: Scenario, robot: RobotSpec) -> None:
    """Raise unless an analytic reference keeps the robot's radius clear of every obstacle and wall.

    Raises:
        ScenarioError: The reference comes within the robot's radius of an obstacle or wall.
    """
    clearance = scenario.world.signed_distance(trajectory.pose[:, :2])
    if float(clearance.min()) <= robot.radius:
        world = scenario.world
        outside = np.flatnonzero(world.wall_distance(trajectory.pose[:, :2]) <= 0.0)
        k = int(outside[0]) if outside.size else int(clearance.argmin())
        x, y = (round(float(v), 3) + 0.0 for v in trajectory.pose[k, :2])  # (+ 0.0: no "-0.000")
        at = f"({x:.3f}, {y:.3f})"
        if outside.size:  # "comes within 0.000 m of an obstacle or wall" it said of a point beyond the walls
            how = f"leaves the world's bounds ({span(*world.bounds)}) at {at}"
        elif clearance[k] < 0.0:
            how = f"runs through an obstacle at {at}"
        else:
            how = f"comes within {float(clearance[k]):.3f} m of an obstacle or wall at {at}"
        room = f", e.g. {option('scenario', 'open')}" if scenario.name != "open" else ""
        raise ScenarioError(
            f"reference {name!r} placed at the start of scenario {scenario.name!r} {how} but the {robot.name} needs "
            f"{robot.radius:.3f} m of room; use a scenario with room for it{room}, another reference, or plan a path "
            f"with {option('planner')}"
        )


def nothing_to_plan(scenario: Scenario) -> bool:
    """Whether the scenario's goal is its start (position and heading, as the ``open`` arena's, for analytic
    references): a planner's path there is the start alone, its trajectory a stand-still."""
    start, goal = scenario.start, scenario.goal
    return start.distance_to(goal) < 1e-9 and start.heading_error_to(goal) < 1e-9


def plan_case(case: Case, scenario: Scenario, robot: RobotSpec, *, progress: Progress | None = None) -> PlanResult:
    """The case's plan: its ready plan, or its planner's result on the scenario.

    Args:
        case: A planned case.
        scenario: Its scenario (with the robot).
        robot: Its robot.
        progress: Told when planning starts and ends (stage "plan", seconds of the budget).

    Raises:
        ConfigError: No planner given and the scenario names none; unknown planner; a scenario with nothing to
            plan (:func:`nothing_to_plan`).
    """
    if case.planning.plan is not None:
        return _ready_plan(case.planning.plan, scenario, robot, case.planning.clearance)
    name = case.planner or scenario.planner
    if name is None:
        raise ConfigError(
            f"scenario {scenario.name!r} names no planner; choose one with {option('planner')}: "
            f"{', '.join(sorted(PLANNERS)) or 'none registered'}"
        )
    if nothing_to_plan(scenario):
        raise ConfigError(
            f"scenario {scenario.name!r} has nothing to plan: its goal is its start ({scenario.start.x:g}, "
            f"{scenario.start.y:g}, {scenario.start.theta:g}), so planner {name!r} would give a stand-still with "
            f"nothing to track; choose a scenario whose goal lies elsewhere, or track an analytic reference there "
            f"({option('reference', 'figure8')})"
        )
    limit = case.planning.time_limit
    problem = PlanProblem.from_scenario(scenario, robot=robot, seed=case.seed, time_limit=limit)
    options = {**scenario.options_for(name), **case.planning.planner_options}
    margin = "clearance" in planner_options(name) and "clearance" not in options and case.planning.clearance > 0
    least = end_clearance(problem) if margin else math.inf
    if margin:
        options["clearance"] = tracked_margin(problem, case.planning.clearance, least)
    if progress is not None:
        progress("plan", 0.0, limit)
    try:
        plan = _plan_with_margin(name, options, problem, least)
    finally:
        if progress is not None:
            progress("plan", limit, limit)
    if margin and not plan.success:  # say what `nhsim plan` (no margin) does not do, and how to match it
        said = (
            f"{plan.reason}; it planned keeping {options['clearance']:g} m from obstacles and walls, the margin a "
            f"tracked plan gets (nhsim plan keeps none): clearance = 0 in a [planners.{name}] table of the "
            "scenario plans without it"
        )
        plan = dataclasses.replace(plan, reason=said)
    return plan


#: Smallest margin [m] a plan refused at its start or goal is tried again with before none (:func:`_plan_with_margin`).
LEAST_MARGIN = 0.0005


def _plan_with_margin(name: str, options: dict[str, Any], problem: PlanProblem, least: float) -> PlanResult:
    """The planner's result; and where the planner refuses the start or the goal while their exact clearance
    ``least`` [m] (:func:`end_clearance`) is within its check's error of the tracked margin ``options["clearance"]``
    (its check, a lower bound, reads up to half :data:`DEFAULT_TOLERANCE` less: a goal 11 mm from a box was refused
    for a 10 mm margin), the result with the margin halved until they keep it (none below :data:`LEAST_MARGIN`),
    within what is left of the time limit; ``options["clearance"]`` is then the margin planned with. A refusal for
    another reason (a planner's own rule) is returned as it is."""
    started = time.perf_counter()
    ends = (PlanStatus.INVALID_START, PlanStatus.INVALID_GOAL)
    while True:
        plan = run_planner(make_planner(name, **options), name, problem, PLANNERS.origin(name))
        left = problem.time_limit - (time.perf_counter() - started)
        margin = options.get("clearance", 0.0)
        near = least < margin + 0.5 * DEFAULT_TOLERANCE  # the planner's reading may fall below the margin
        if not (plan.status in ends and near and margin > 0.0 and left > 0.0):
            return plan
        options["clearance"] = 0.5 * margin if 0.5 * margin >= LEAST_MARGIN else 0.0
        problem = dataclasses.replace(problem, time_limit=left)


def end_clearance(problem: PlanProblem) -> float:
    """The least clearance [m] of the robot's footprint at the start and the goal (the exact checker's lower bound,
    within its tolerance of the truth)."""
    ends = np.array([problem.start.as_array(), problem.goal.as_array()])
    return float(CollisionChecker(problem.world, problem.robot).least_clearance(ends))


def tracked_margin(problem: PlanProblem, margin: float, least: float | None = None) -> float:
    """The margin [m] a tracked plan keeps from obstacles and walls: ``margin``, or half the footprint's
    clearance (its checker's lower bound) at the start or the goal where the robot stands closer there (it
    is at the start already and must end at the goal, so a margin those poses lack would refuse a scenario
    ``nhsim plan`` plans: a start 6 mm from a wall was refused for its 1 cm); 0 where one overlaps (the
    planner then says so). ``least``: :func:`end_clearance`, when known."""
    least = end_clearance(problem) if least is None else least
    return margin if least >= margin else max(0.0, 0.5 * least)


class GrazingPlanWarning(UserWarning):
    """A ready plan keeps less than the tracked margin (``PlanOptions.clearance``) from obstacles and walls: the
    robot follows it to a few millimetres and may touch them (it is tracked as given)."""


def _ready_plan(plan: PlanResult, scenario: Scenario, robot: RobotSpec, margin: float) -> PlanResult:
    """A plan given ready (``PlanOptions.plan``), checked against the scenario it is to be tracked in: a
    successful one starts at the scenario's start, ends in its goal region and is free in its world for the
    robot's footprint (:func:`_check_ready_path`); one that keeps less than ``margin`` [m] (the margin a plan made
    here gets) is tracked with a :class:`GrazingPlanWarning`.

    Raises:
        ConfigError: It starts elsewhere (the robot is placed at the scenario's start) or ends outside the
            goal region, naming both poses; or its path collides (another world's plan, or another robot's).
    """
    if not plan.success or plan.path.shape[0] == 0:
        return plan
    first, last, start, goal = plan.path[0], plan.path[-1], scenario.start, scenario.goal
    tolerance = (scenario.position_tolerance, scenario.heading_tolerance)
    off, turned = _pose_gap(first, start)
    if off > tolerance[0] or turned > tolerance[1]:
        raise ConfigError(
            f"the ready plan ({plan.planner}) starts at ({first[0]:.3f}, {first[1]:.3f}, {first[2]:.3f}), "
            f"{off:.3f} m and {turned:.3f} rad from the start of scenario {scenario.name!r} ({start.x:g}, {start.y:g}, "
            f"{start.theta:g}), where the robot is placed: plan for this scenario (PlanProblem.from_scenario), or "
            "give the scenario whose start the plan leaves from"
        )
    miss, missed = _pose_gap(last, goal)
    if miss > tolerance[0] or missed > tolerance[1]:
        raise ConfigError(
            f"the ready plan ({plan.planner}) ends at ({last[0]:.3f}, {last[1]:.3f}, {last[2]:.3f}), outside "
            f"the goal region of scenario {scenario.name!r} ({goal.x:g}, {goal.y:g}, {goal.theta:g}; "
            f"{tolerance[0]:g} m, {tolerance[1]:g} rad): plan for this scenario"
        )
    _check_ready_path(plan, scenario, robot)
    least = CollisionChecker(scenario.world, robot).least_clearance(plan.path)
    # what a plan made here keeps (less by the planners' checks' error: the case's own plan, tracked as a ready plan
    # by ``nhsim simulate --all`` and the suite, is not warned of)
    kept = tracked_margin(PlanProblem.from_scenario(scenario, robot=robot), margin)
    if least < kept - 0.5 * DEFAULT_TOLERANCE:  # a planner's default plans to the limit: a closed loop touched
        warnings.warn(
            f"the ready plan ({plan.planner}) comes within {least:.4f} m of an obstacle or wall, less than the "
            f"{kept:g} m a plan made here keeps (PlanOptions.clearance): the robot follows its plan to a few "
            f"millimetres and may touch it; plan with a margin (make_planner({plan.planner!r}, clearance={margin:g}), "
            "where the planner takes one), or let the case plan",
            GrazingPlanWarning,
            stacklevel=3,
        )
    return plan


def _check_ready_path(plan: PlanResult, scenario: Scenario, robot: RobotSpec) -> None:
    """Refuse a ready plan whose path collides in the scenario's world (the map the planners plan on) with the
    robot's footprint (:func:`planning.planners.base.path_collision`): a plan made in another world or for another
    robot, which no trajectory could follow.

    Raises:
        ConfigError: Naming the first colliding pose (its index in ``plan.path``), what it overlaps, and the fix.
    """
    found = path_collision(plan.path, scenario.world, robot)
    if not found:
        return
    raise ConfigError(
        f"the ready plan ({plan.planner}) collides in scenario {scenario.name!r} with robot {robot.name!r}: {found} (a "
        "plan made in another world, or for another robot?): plan again in this scenario with this robot "
        f"(PlanProblem.from_scenario(scenario, robot=load_robot({robot.name!r}))), or track the plan in the scenario "
        "and with the robot it was made for"
    )


def _pose_gap(pose: FloatArray, to: Pose2D) -> tuple[float, float]:
    """How far a path's pose (3,) is from ``to``: (distance [m], |heading difference| [rad])."""
    return math.hypot(pose[0] - to.x, pose[1] - to.y), abs(float(wrap_angle(float(pose[2]) - to.theta)))


def prepare_trajectory(case: Case, *, progress: Progress | None = None) -> PreparedTrajectory:
    """Make the trajectory a case's runs follow: its reference at the start pose, or its plan
    smoothed and timed (with ``PLAN_HOLD_S`` of final regulation after it).

    Raises:
        ScenarioError: Unknown scenario, or a reference that does not fit in the scenario.
        ConfigError: A planned case with no planner, or an unknown one.
        TrajectoryError: The plan failed or could not be made into a collision-free trajectory.
    """
    sc = load_case_scenario(case)
    spec = case.robot_spec(sc.robot)
    if case.reference is not None:
        traj = fitted_reference(case.reference, sc, spec)
        check_reference_fits(case.reference, traj, sc, spec)
        return PreparedTrajectory(case, sc, spec, traj, f"reference:{case.reference}")
    if case.trajectory_file is not None:
        return _prepare_file(case, case.trajectory_file, sc, spec)
    plan = plan_case(case, sc, spec, progress=progress)
    plan_rec: dict[str, Any] = {
        "planner": plan.planner,
        "status": plan.status.value,
        "reason": plan.reason,
        "time_s": plan.stats.get("time_s"),
        "iterations": plan.stats.get("iterations"),
        "length_m": plan.length(),
    }
    res = checked_trajectory(plan, spec, sc.world, goal=sc.goal, **case.planning.smoothing)
    assert res.trajectory is not None
    smoothing = {k: v for k, v in res.stats.items() if isinstance(v, (int, float, str, bool))}
    return PreparedTrajectory(
        case,
        sc,
        spec,
        res.trajectory,
        f"planner:{plan.planner}",
        PLAN_HOLD_S,
        {"plan": plan_rec, "smoothing": smoothing},
        np.asarray(plan.path, dtype=float),
    )


def _prepare_file(case: Case, source: TrajectoryFile, sc: Scenario, spec: RobotSpec) -> PreparedTrajectory:
    """A file case's trajectory (read, repaired, checked against the world, timed), tracked like a
    plan; its record gains ``import`` (what was read and repaired) and ``smoothing``.

    Raises:
        TrajectoryFileError: The file cannot be read or used, or it collides (without allow_collisions).
        TrajectoryError: No trajectory could be made of it.
    """
    imported = read_trajectory_file(source)
    imported.report.arena = sc.name == ARENA_NAME and sc.source is None
    res = file_trajectory(imported, spec, sc.world, **case.planning.smoothing)
    assert res.trajectory is not None
    smoothing = {k: v for k, v in res.stats.items() if isinstance(v, (int, float, str, bool))}
    extra = {"import": {**source.as_dict(), **imported.report.as_dict()}, "smoothing": smoothing}
    path = file_poses(imported)
    return PreparedTrajectory(case, sc, spec, res.trajectory, f"file:{source.name}", PLAN_HOLD_S, extra, path)
