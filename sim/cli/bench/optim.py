"""``nhsim bench optim``: the optim planner at the TurtleBot planning report's resolution against its
default (see :mod:`sim.tools.bench.optim`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--repeats", type=int, default=5, help="timed solves per setting; medians (default: 5)")
    p.add_argument(
        "--scenarios",
        nargs="+",
        default=["parallel_park", "nav_map1"],
        metavar="NAME",
        help="scenarios to solve (default: parallel_park nav_map1)",
    )


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    from planning.scenario import load_scenario
    from sim.cli.checks import check_at_least, check_once, check_something_to_plan
    from sim.tools.bench import optim as bench

    check_at_least({"--repeats": (args.repeats, 1)})
    check_once("--scenarios", args.scenarios)
    # an unknown name stops here, before anything is printed
    check_something_to_plan("--scenarios", [load_scenario(name) for name in args.scenarios])
    print(
        f"optim: the report's resolution, dt={bench.SEED_DT} (the TurtleBot planning report: N={bench.SEED_N} over "
        f"10 s), against the default's N and dt, over the horizon the default fits to the scenario; median of "
        f"{args.repeats} solves after one warm-up"
    )
    ok = True
    nan = float("nan")
    for name in args.scenarios:
        r = bench.measure(name, args.repeats)
        print(f"\n{name}")
        print(
            f"  {'setting':<8} {'N':>5} {'dt s':>7} {'status':<10} {'median s':>9} {'iters':>6} "
            f"{'final pos err m':>16} {'final head err rad':>19} {'length m':>9}"
        )
        for label, solve in (("report", r.seed), ("default", r.default)):
            res = solve.result
            n, dt = res.stats.get("N", -1), res.stats.get("dt", nan)
            print(
                f"  {label:<8} {n:>5} {dt:>7.4f} {res.status.value:<10} {solve.median_s:>9.4f} "
                f"{res.stats.get('iterations', -1):>6} "
                f"{res.stats.get('final_position_error', nan):>16.2e} "
                f"{res.stats.get('final_heading_error', nan):>19.2e} {res.length():>9.4f}"
            )
        failed = [(label, solve.result.status.value) for label, solve in (("report", r.seed), ("default", r.default))]
        failed = [(label, status) for label, status in failed if status != "success"]
        if failed:  # a ratio to a run that did not solve is no measurement: its time is the limit's
            ended = " and ".join(f"the {label} setting ended {status}" for label, status in failed)
            print(f"  not compared: {ended} (its time is where it stopped, its path no plan); the targets are missed")
        else:
            print(
                f"  speed-up {r.speedup:.1f}x (target >= {bench.TARGET_SPEEDUP:g}x); default final position error "
                f"{r.final_error_m * 1e3:.3g} mm (target <= {bench.TARGET_FINAL_ERROR * 1e3:g} mm); length differs "
                f"by {100 * r.length_rel:.2f} % (target <= {100 * bench.TARGET_LENGTH_REL:g} %)"
            )
        ok &= r.passed
    print(f"\n{'all targets met' if ok else 'a target was missed'}")
    return 0 if ok else 1
