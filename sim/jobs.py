"""The main job: a scenario and a reference, tracked closed loop and open loop, measured.

The library returns data; only the CLI prints and writes files.
"""

from __future__ import annotations

import platform
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

from control.fbl import FBLGains
from control.tracker import make_tracker
from planning.errors import ScenarioError
from planning.references import make_reference
from planning.robot import RobotSpec, load_robot
from planning.scenario import Scenario, load_scenario
from planning.trajectory import Trajectory
from sim.metrics import TrackingMetrics, compute_metrics
from sim.runlog import RunLog
from sim.simulator import SimConfig, Simulator

#: Run label -> tracker name.
RUNS = {"closed_loop": "fbl", "open_loop": "open-loop"}


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

    def record(self) -> dict[str, Any]:
        """The JSON run record."""
        rec: dict[str, Any] = {
            "scenario": self.scenario.name,
            "scenario_file": str(self.scenario.source) if self.scenario.source else None,
            "robot": self.robot.name,
            "source": self.source,
            "trajectory": {"name": self.trajectory.name, "duration_s": self.trajectory.duration,
                           "length_m": self.trajectory.path_length()},
            "tracker": "fbl" if "closed_loop" in self.logs else "open-loop",
            "gains": {"kp": self.gains.kp, "kd": self.gains.kd, "xi_min": self.gains.xi_min},
            "control_rate_hz": self.config.control_rate,
            "seed": self.seed,
            "versions": versions(),
        }  # fmt: skip
        for label, m in self.metrics.items():
            run: dict[str, Any] = dict(m.as_dict())
            run["tracker"] = RUNS[label]
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
    """
    gains = gains or FBLGains()
    config = config or SimConfig()
    simulator = simulator or Simulator(robot, scenario.world)
    logs: dict[str, RunLog] = {}
    metrics: dict[str, TrackingMetrics] = {}
    for label in trackers:
        tracker = make_tracker(RUNS[label], robot, gains=gains)
        log = simulator.run(trajectory, tracker, config, start=scenario.start, meta={"seed": seed})
        logs[label] = log
        metrics[label] = compute_metrics(log, trajectory, max_speed=robot.max_speed, max_yaw_rate=robot.max_yaw_rate)
    return JobResult(scenario, robot, trajectory, source, logs, metrics, gains, config, seed)


def simulate_reference(
    scenario: str = "open",
    *,
    robot: str | None = None,
    reference: str = "figure8",
    trackers: tuple[str, ...] = ("closed_loop", "open_loop"),
    gains: FBLGains | None = None,
    config: SimConfig | None = None,
    seed: int = 0,
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
                        config=config, seed=seed)  # fmt: skip
