"""``nhsim bench simplify``: simplified birrt / rrt paths and ``simulate --all`` trajectories against
rrt-star's (see :mod:`sim.tools.bench.simplify`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument(
        "--scenarios",
        nargs="+",
        default=None,
        metavar="NAME",
        help="scenarios (built-in names or randomN; default: every built-in one with start != goal, "
        "and the random worlds)",
    )
    p.add_argument(
        "--random-worlds",
        type=int,
        default=None,
        metavar="N",
        help="add seeded random worlds random0.. (default: 6 without --scenarios, else 0)",
    )
    p.add_argument("--seeds", type=int, default=1, metavar="N", help="planner seeds per problem (default: 1)")
    p.add_argument("--no-trajectories", action="store_true", help="skip the simulate --all trajectories (plans only)")


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    import numpy as np

    from sim.cli.checks import check_at_least, check_once, check_something_to_plan, check_worlds
    from sim.tools.bench import simplify as bench

    check_at_least({"--seeds": (args.seeds, 1)})
    randoms = args.random_worlds if args.random_worlds is not None else (6 if args.scenarios is None else 0)
    check_worlds("--random-worlds", randoms)
    check_once("--scenarios", args.scenarios)
    scenarios = bench.problems(args.scenarios, randoms)  # an unknown name stops here, before any print
    check_something_to_plan("--scenarios", scenarios)
    print(
        f"simplified plans against rrt-star's: length <= {bench.LENGTH_TARGET}x, cusps <= rrt-star's + "
        f"{bench.CUSP_SLACK}, simplification <= {1e3 * bench.TIME_TARGET_S:g} ms CPU; clearance {bench.CLEARANCE} m"
    )
    print(
        f"{'problem':<18}{'seed':>5} {'planner':<7}{'raw m':>8}{'simpl m':>9}{'rrt* m':>8}{'ratio':>7}"
        f"{'cusps':>9}{'rrt*':>6}{'cpu ms':>8}{'wall ms':>8}  missed"
    )
    missed = False
    rows = []
    for scenario in scenarios:
        for seed in range(args.seeds):
            for r in bench.measure_plans(scenario, seed):
                rows.append(r)
                missed |= bool(r.missed)
                print(
                    f"{r.problem:<18}{seed:>5} {r.planner:<7}{r.raw_length:>8.2f}{r.length:>9.2f}{r.ref_length:>8.2f}"
                    f"{r.ratio:>7.3f}{f'{r.raw_cusps}->{r.cusps}':>9}{r.ref_cusps:>6}{1e3 * r.cpu_s:>8.1f}"
                    f"{1e3 * r.wall_s:>8.1f}  {','.join(r.missed) or '-'}",
                    flush=True,
                )
    for name in bench.RACED:
        mine = [r for r in rows if r.planner == name]
        ratios = np.array([r.ratio for r in mine])
        cpu = 1e3 * np.array([r.cpu_s for r in mine])
        print(
            f"{name}: length ratio median {np.nanmedian(ratios):.3f}, max {np.nanmax(ratios):.3f}; "
            f"CPU ms median {np.median(cpu):.1f}, max {cpu.max():.1f}; "
            f"{sum(bool(r.missed) for r in mine)} of {len(mine)} rows miss a target"
        )
    if not args.no_trajectories:
        missed |= _trajectories(args)
    return 1 if missed else 0


def _trajectories(args: argparse.Namespace) -> bool:
    """The simulate --all table; True when a case misses its target."""
    import numpy as np

    from planning.scenario import random_seed
    from sim.cli.sweep_table import PLANNER_WIDTH, ROBOT_WIDTH
    from sim.tools.bench import simplify as b

    names = [n for n in args.scenarios if random_seed(n) is None] if args.scenarios else None
    print(
        f"\nsimulate --all trajectories against rrt-star's (length <= {b.TRAJECTORY_TARGET}x for "
        f"{', '.join(b.TRAJECTORY_TARGETED)})"
    )
    print(
        f"{'scenario':<18}{'robot':<{ROBOT_WIDTH + 2}}{'planner':<{PLANNER_WIDTH + 1}}"
        f"{'length m':>9}{'rrt* m':>8}{'ratio':>7}{'s':>7}{'rrt* s':>8}  note"
    )
    missed = False
    ratios = []
    for r in b.measure_trajectory(names):
        missed |= r.missed
        if r.targeted:
            ratios.append(r.ratio)
        flag = "MISSED" if r.missed else (r.note or ("" if r.targeted else "(not a sampling planner)"))
        print(
            f"{r.scenario:<18}{r.robot:<{ROBOT_WIDTH + 2}}{r.planner:<{PLANNER_WIDTH + 1}}"
            f"{r.length:>9.2f}{r.ref_length:>8.2f}{r.ratio:>7.3f}"
            f"{r.duration:>7.1f}{r.ref_duration:>8.1f}  {flag}",
            flush=True,
        )
    finite = np.array([x for x in ratios if np.isfinite(x)])
    unmeasured = len(ratios) - finite.size
    left = f"; {unmeasured} case(s) with no trajectory to compare, named above, not judged" if unmeasured else ""
    if finite.size:
        print(
            f"sampling planners' trajectory length ratio: median {np.median(finite):.3f}, "
            f"max {finite.max():.3f} over {finite.size} of {len(ratios)} cases{left}"
        )
    return missed
