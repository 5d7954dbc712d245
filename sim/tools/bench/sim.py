"""Closed-loop physics throughput against a bare ``mj_step`` loop (``nhsim bench sim``).

Both loops step the same compiled model from the same start for the same number of physics
steps with the same wheel commands: the baseline replays the closed loop's logged wheel commands
as the motors' no-load voltages with ``mj_step(m, d, nstep=k)`` and nothing else (so the engine
does the same contact work), the
closed loop runs the whole simulator (sensing, the tracker (FBL unless told) at the control rate, the drive
mapping, logging, contact checks). Each loop's time includes its start: a new ``MjData`` and the
robot set down at its start pose (:func:`sim.physics.model.set_pose`, which lets it settle on the
floor for 0.5 s of physics first), which both do alike. Target: ratio >= 0.8.
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass
from typing import Any

TARGET_RATIO = 0.8


@dataclass(frozen=True)
class SimBench:
    """One measurement.

    Attributes:
        robot: Robot name.
        reference: Reference name.
        control_rate: Tracker rate [Hz].
        repeats: Timed runs of each loop, alternating (the best of each counts).
        n_steps: Physics steps of each loop.
        duration_s: Simulated time of the closed loop [s].
        bare_s: Best wall time of the bare loop [s].
        closed_s: Best wall time of the closed loop [s].
        bare_cpu_s: Least CPU time of the bare loop's thread [s].
        closed_cpu_s: Least CPU time of the closed loop's thread [s].
        pair_cpu_ratios: Each alternating pair's ratio by CPU time (bare over closed), in run order.
    """

    robot: str
    reference: str
    control_rate: float
    repeats: int
    n_steps: int
    duration_s: float
    bare_s: float
    closed_s: float
    bare_cpu_s: float
    closed_cpu_s: float
    pair_cpu_ratios: tuple[float, ...] = ()

    @property
    def bare_steps_per_s(self) -> float:
        """Physics steps per second of the bare loop."""
        return self.n_steps / self.bare_s

    @property
    def closed_steps_per_s(self) -> float:
        """Physics steps per second of the closed loop."""
        return self.n_steps / self.closed_s

    @property
    def ratio(self) -> float:
        """Closed-loop over bare throughput."""
        return self.closed_steps_per_s / self.bare_steps_per_s

    @property
    def cpu_ratio(self) -> float:
        """Closed-loop over bare throughput by the CPU time of the measuring thread: the same ratio
        without the time other processes held the core (on a loaded machine the wall clock's best of a
        few runs still includes some)."""
        return self.bare_cpu_s / self.closed_cpu_s

    @property
    def pair_median(self) -> float:
        """The median of the pairs' ratios by CPU time: each pair's two loops ran back to back, so a
        slow spell of the machine (another tenant, the clock) meets both loops of a pair alike."""
        return statistics.median(self.pair_cpu_ratios) if self.pair_cpu_ratios else math.nan

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second of the closed loop."""
        return self.duration_s / self.closed_s

    @property
    def passed(self) -> bool:
        """The ratio meets ``TARGET_RATIO``."""
        return self.ratio >= TARGET_RATIO


def measure(
    robot: str = "turtlebot3",
    reference: str = "figure8",
    control_rate: float = 50.0,
    repeats: int = 3,
    tracker: str = "fbl",
) -> SimBench:
    """Time both loops (best of ``repeats``) on a reference at the 'open' scenario's start, the closed
    loop driven by ``tracker`` (a registered name).

    Raises:
        ConfigError: Unknown robot, reference or tracker, or a control rate that is not a whole
            number of physics steps.
    """
    import mujoco

    from control.base import make_tracker
    from planning.core.robot import load_robot
    from planning.scenario import load_scenario
    from planning.trajectory.references import make_reference
    from sim.physics.asbuilt import DEFAULT_BUILD_SEED, AsBuilt
    from sim.physics.model import set_pose
    from sim.physics.simulator import SimConfig, Simulator
    from sim.robot.sensing import SensingSetup
    from sim.robot.sources import PoseSource

    scenario = load_scenario("open")
    spec = load_robot(robot)
    traj = make_reference(reference, spec, scenario.start)
    simulator = Simulator(spec, scenario.world, AsBuilt.draw(spec.name, DEFAULT_BUILD_SEED))
    cfg = SimConfig(control_rate=control_rate)
    k = simulator.steps_per_control(cfg.control_rate)
    n_steps = round(traj.duration / simulator.model.opt.timestep / k) * k
    sensing = SensingSetup.for_robot(spec.name)

    def run_closed() -> Any:
        return simulator.run(traj, make_tracker(tracker, spec), cfg, source=PoseSource.FUSED, sensing=sensing)

    log = run_closed()
    chunks = (len(log) - 1) // (n_steps // k)
    volts = [tuple(row) for row in simulator.motors.no_load_voltage(log.wheel_command[1::chunks])]
    act_l = simulator.model.actuator("wheel_left_motor").id
    act_r = simulator.model.actuator("wheel_right_motor").id

    def bare() -> tuple[float, float]:
        m = simulator.model
        t0, c0 = time.perf_counter(), time.thread_time()
        d = mujoco.MjData(m)
        set_pose(m, d, scenario.start)
        ctrl = d.ctrl
        step = mujoco.mj_step
        for left, right in volts:
            ctrl[act_l] = left
            ctrl[act_r] = right
            step(m, d, nstep=k)
        return time.perf_counter() - t0, time.thread_time() - c0

    def closed() -> tuple[float, float]:
        t0, c0 = time.perf_counter(), time.thread_time()
        run_closed()
        return time.perf_counter() - t0, time.thread_time() - c0

    # alternate the two loops, so a change of the machine's load meets both alike; the best of each counts
    pairs = [(bare(), closed()) for _ in range(repeats)]
    t_bare, c_bare = min(b[0] for b, _ in pairs), min(b[1] for b, _ in pairs)
    t_closed, c_closed = min(c[0] for _, c in pairs), min(c[1] for _, c in pairs)
    pair_ratios = tuple(b[1] / c[1] for b, c in pairs)
    return SimBench(
        spec.name, reference, cfg.control_rate, repeats, n_steps, traj.duration, t_bare, t_closed, c_bare, c_closed,
        pair_ratios,
    )  # fmt: skip
