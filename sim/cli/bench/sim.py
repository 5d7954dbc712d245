"""``nhsim bench sim``: closed-loop physics steps/s against a bare ``mj_step`` loop (see
:mod:`sim.tools.bench.sim`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    from planning.trajectory.references import REFERENCES
    from sim.cli.checks import add_robot_argument

    add_robot_argument(
        p,
        "robot both loops step; not a balancing one, whose wheel voltages come from its balance firmware, which the "
        "bare loop does not run (default: turtlebot3)",
        "turtlebot3",
    )
    p.add_argument(
        "--reference",
        choices=list(REFERENCES),
        default="figure8",
        help="reference the closed loop tracks from the 'open' scenario's start; the bare loop replays its wheel "
        "commands (default: figure8)",
    )
    p.add_argument(
        "--control-rate",
        type=float,
        default=50.0,
        metavar="HZ",
        help="tracker rate of the closed loop; its period must be a whole number of physics steps (default: 50)",
    )
    p.add_argument("--repeats", type=int, default=3, help="best of N for each loop (default: 3)")
    p.add_argument("--tracker", default="fbl", metavar="NAME", help="tracker of the closed loop (default: fbl)")
    p.add_argument(
        "--localiser",
        choices=("fixes", "amcl"),
        default="fixes",
        help="the estimator's corrections: synthetic fixes, or the LDS-01's scans through AMCL; amcl also prints the "
        "CPU time of a revolution's scan and of a localiser update (500 particles, 60 beams) (default: fixes)",
    )


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when the ratio misses the target."""
    from control.design.balance_profile import is_balancing
    from planning.errors import ConfigError
    from sim.cli.checks import check_at_least, check_control_rate
    from sim.tools.bench.sim import TARGET_RATIO, TARGET_RATIO_AMCL, measure, measure_scan

    check_at_least({"--repeats": (args.repeats, 1)})
    check_control_rate(args.control_rate)
    if is_balancing(args.robot):
        raise ConfigError(
            f"--robot {args.robot}: the bare loop replays wheel voltages, and a balancing robot's come from its "
            "balance firmware, which the bare loop does not run (it would fall: not the same physics); bench "
            "turtlebot3 or edumip"
        )
    r = measure(args.robot, args.reference, args.control_rate, args.repeats, args.tracker, args.localiser)
    print(
        f"robot {r.robot}, reference {r.reference}, tracker {args.tracker}, localiser {args.localiser}, "
        f"{r.n_steps} physics steps "
        f"({r.duration_s:.1f} s simulated), "
        f"control {r.control_rate:g} Hz, best of {r.repeats}"
    )
    print(f"bare mj_step loop    {r.bare_steps_per_s:>12,.0f} steps/s")
    print(f"closed-loop run      {r.closed_steps_per_s:>12,.0f} steps/s")
    target = TARGET_RATIO if args.localiser == "fixes" else TARGET_RATIO_AMCL
    print(f"ratio                {r.ratio:>12.3f}   (by the best wall times)")
    print(f"ratio by CPU time    {r.cpu_ratio:>12.3f}   (the measuring thread's; without other processes' turns)")
    print(f"median pair by CPU   {r.pair_median:>12.3f}   (of the {r.repeats} back-to-back pairs' ratios)")
    print(f"real-time factor     {r.real_time_factor:>12.1f}x  (simulated seconds per wall-clock second, closed loop)")
    if args.localiser == "amcl":
        s = measure_scan()
        print(
            f"per revolution       scan {1e3 * s.scan_cpu_s:.3f} ms CPU ({s.beams} beams), localiser "
            f"{1e3 * s.localiser_cpu_s:.3f} ms CPU ({s.particles} particles, {s.max_beams} beams; median of "
            f"{s.revolutions}; aim <= 1 ms each)"
        )
    met = r.judged >= target
    print(
        f"target               {'met' if met else 'missed'}: {r.judged:.3f} {'>=' if met else '<'} {target} (the lower "
        "of the two ratios: a slowed baseline does not flatter the closed loop)"
    )
    return 0 if met else 1
