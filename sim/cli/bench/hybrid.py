"""``nhsim bench hybrid``: Hybrid-A*'s time and length against rrt-star's length (see
:mod:`sim.tools.bench.hybrid`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--random", type=int, default=0, metavar="N", help="also N seeded unseen worlds (default: 0)")
    p.add_argument("--seeds", type=int, default=3, metavar="N", help="rrt-star seeds per problem (default: 3)")
    p.add_argument("--repeats", type=int, default=3, metavar="N", help="timed Hybrid-A* runs per problem (default: 3)")


def run(args: argparse.Namespace) -> int:
    """Measure and print one row per problem as it is done; exit 1 when a target is missed."""
    from sim.cli.checks import check_at_least, check_worlds
    from sim.tools.bench import hybrid as bench

    check_worlds("--random", args.random)
    check_at_least({"--seeds": (args.seeds, 1), "--repeats": (args.repeats, 1)})
    print(
        f"hybrid-a-star against rrt-star (median length of {args.seeds} seeds, 5000 iterations); "
        f"wall median and CPU least of {args.repeats} runs; clearance {bench.CLEARANCE} m"
    )
    rows = []
    for world, robot, sc in bench.problems(args.random):
        rows.append(bench.measure(world, robot, sc, seeds=args.seeds, repeats=args.repeats))
        lines = bench.format_rows(rows[-1:])
        print(lines[0] if len(rows) == 1 else lines[1], flush=True)
        if len(rows) == 1:
            print(lines[1], flush=True)
    print(bench.format_rows(rows)[-1])
    met = bench.passed(rows)
    print(f"targets {'met' if met else 'missed'} (judged on each problem's least CPU time, its success and its ratio)")
    return 0 if met else 1
