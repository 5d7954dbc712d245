"""``nhsim bench sim``: closed-loop physics throughput against a bare ``mj_step`` loop.

Both loops step the same compiled model from the same start for the same number of physics
steps with the same wheel commands: the baseline replays the closed loop's logged wheel commands
with ``mj_step(m, d, nstep=k)`` and nothing else (so the engine does the same contact work), the
closed loop runs the whole simulator (sensing, the FBL tracker at the control rate, the drive
mapping, logging, contact checks). Target: ratio >= 0.8.
"""

from __future__ import annotations

import argparse
import time

TARGET_RATIO = 0.8


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--robot", choices=["turtlebot3", "edumip"], default="turtlebot3")
    p.add_argument("--reference", choices=["figure8", "circle", "line"], default="figure8")
    p.add_argument("--control-rate", type=float, default=50.0, metavar="HZ")
    p.add_argument("--repeats", type=int, default=3, help="best of N for each loop (default: 3)")


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when the ratio misses the target."""
    import mujoco

    from control.base import make_tracker
    from planning.core.robot import load_robot
    from planning.scenario import load_scenario
    from planning.trajectory.references import make_reference
    from sim.physics.model import set_pose
    from sim.physics.simulator import SimConfig, Simulator

    scenario = load_scenario("open")
    robot = load_robot(args.robot)
    traj = make_reference(args.reference, robot, scenario.start)
    simulator = Simulator(robot, scenario.world)
    cfg = SimConfig(control_rate=args.control_rate)
    k = simulator.steps_per_control(cfg.control_rate)
    n_steps = round(traj.duration / simulator.model.opt.timestep / k) * k

    log = simulator.run(traj, make_tracker("fbl", robot), cfg)
    chunks = (len(log) - 1) // (n_steps // k)
    wheel_cmds = [tuple(row) for row in log.wheel_command[1::chunks]]
    act_l = simulator.model.actuator("wheel_left_motor").id
    act_r = simulator.model.actuator("wheel_right_motor").id

    def bare() -> float:
        m = simulator.model
        d = mujoco.MjData(m)
        set_pose(m, d, scenario.start)
        ctrl = d.ctrl
        step = mujoco.mj_step
        t0 = time.perf_counter()
        for left, right in wheel_cmds:
            ctrl[act_l] = left
            ctrl[act_r] = right
            step(m, d, nstep=k)
        return time.perf_counter() - t0

    def closed() -> float:
        tracker = make_tracker("fbl", robot)
        t0 = time.perf_counter()
        simulator.run(traj, tracker, cfg)
        return time.perf_counter() - t0

    t_bare = min(bare() for _ in range(args.repeats))
    t_closed = min(closed() for _ in range(args.repeats))
    sps_bare = n_steps / t_bare
    sps_closed = n_steps / t_closed
    ratio = sps_closed / sps_bare
    rtf = traj.duration / t_closed
    print(f"robot {robot.name}, reference {args.reference}, {n_steps} physics steps "
          f"({traj.duration:.1f} s simulated), control {cfg.control_rate:g} Hz, best of {args.repeats}")  # fmt: skip
    print(f"bare mj_step loop    {sps_bare:>12,.0f} steps/s")
    print(f"closed-loop run      {sps_closed:>12,.0f} steps/s")
    print(f"ratio                {ratio:>12.3f}   (target >= {TARGET_RATIO})")
    print(f"real-time factor     {rtf:>12.1f}x  (simulated seconds per wall-clock second, closed loop)")
    return 0 if ratio >= TARGET_RATIO else 1
