"""``nhsim bench bag``: what writing the ROS 2 bag adds to ``nhsim simulate --no-video`` (see
:mod:`sim.tools.bench.bag`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    from sim.cli.job_outputs import add_case_arguments

    add_case_arguments(p)
    p.add_argument("--repeats", type=int, default=2, metavar="N", help="runs with and without the bag (default: 2)")


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    from planning.errors import ConfigError
    from sim.tools.bench.bag import TARGET_MB, TARGET_RATIO, measure

    if args.repeats < 1:
        raise ConfigError(f"--repeats must be >= 1, got {args.repeats}")
    argv = []
    for opt in ("scenario", "robot", "planner", "reference"):
        if getattr(args, opt) is not None:
            argv += [f"--{opt}", str(getattr(args, opt))]
    r = measure(argv, args.repeats)
    print(
        f"nhsim simulate {' '.join(argv)} --no-video: {r.duration_s:.1f} s simulated, {args.repeats} runs each way, "
        "interleaved"
    )
    print(f"without the bag      {min(r.without_s):>7.2f} .. {max(r.without_s):.2f} s")
    print(f"with the bag         {min(r.with_s):>7.2f} .. {max(r.with_s):.2f} s")
    print(f"bag write            {min(r.write_s):>7.2f} .. {max(r.write_s):.2f} s   ({r.messages} messages)")
    print(f"ratio                {r.ratio:>7.3f}             (median with / median without; target <= {TARGET_RATIO})")
    print(f"bag write share      {r.share:>7.3f}             (1 + median write / median without)")
    print(f"bag size             {r.size_bytes / 1e6:>7.2f} MB          (target <= {TARGET_MB:g} MB)")
    return 0 if r.passed else 1
