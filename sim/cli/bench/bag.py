"""``nhsim bench bag``: what writing the ROS 2 bag adds to ``nhsim simulate --no-video`` (see
:mod:`sim.tools.bench.bag`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    from sim.cli.job_outputs import add_case_arguments

    add_case_arguments(p)
    p.add_argument("--repeats", type=int, default=2, metavar="N", help="runs with and without the bag (default: 2)")


def _span(values: tuple[float, ...]) -> str:
    return f"{min(values):>7.2f} .. {max(values):.2f} s"


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    from sim.cli.checks import check_at_least
    from sim.tools.bench.bag import TARGET_MB, TARGET_RATIO, measure

    check_at_least({"--repeats": (args.repeats, 1)})
    argv = []
    for opt in ("scenario", "robot", "planner", "reference"):
        if getattr(args, opt) is not None:
            argv += [f"--{opt}", str(getattr(args, opt))]
    r = measure(argv, args.repeats)
    print(f"nhsim simulate {' '.join(argv)} --no-video: {r.duration_s:.1f} s simulated, {args.repeats} run(s) each way")
    print(f"{'':22}{'wall':>20}{'CPU':>24}")
    print(f"{'without the bag':22}{_span(r.without_s):>20}{_span(r.without_cpu_s):>24}")
    print(f"{'with the bag':22}{_span(r.with_s):>20}{_span(r.with_cpu_s):>24}")
    print(f"{'bag write':22}{_span(r.write_s):>20}{_span(r.write_cpu_s):>24}   ({r.messages} messages)")
    print(f"{'ratio (medians)':22}{r.ratio:>20.3f}{r.cpu_ratio:>24.3f}   (target: CPU <= {TARGET_RATIO})")
    print(f"{'ratio (least)':22}{'':>20}{r.cpu_ratio_min:>24.3f}")
    print(f"{'bag write / without':22}{'':>20}{1.0 + r.write_share:>24.3f}   (1 + the write's CPU share)")
    print(f"bag size {r.size_bytes / 1e6:.2f} MB (target <= {TARGET_MB:g} MB)")
    print(f"targets {'met' if r.passed else 'missed'}")
    return 0 if r.passed else 1
