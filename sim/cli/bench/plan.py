"""``nhsim bench plan``: birrt / rrt-star against OMPL's RRTConnect / RRT* (see
:mod:`sim.tools.bench.plan`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--seeds", type=int, default=20, help="seeds per scenario (default: 20)")
    p.add_argument(
        "--scenarios", nargs="*", default=None, help="scenario names (default: all with start != goal, and disc10)"
    )
    p.add_argument("--space", choices=["reeds_shepp", "dubins"], default="reeds_shepp")
    p.add_argument("--budget", type=float, default=1.0, metavar="S", help="RRT* time budget [s] (default: 1)")
    p.add_argument("--ttfs-limit", type=float, default=10.0, metavar="S", help="time limit for first solutions")
    p.add_argument("--quick", action="store_true", help="5 seeds, disc10 only, 0.5 s budget")


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    import numpy as np

    from sim.tools.bench.plan import LENGTH_TARGET, TTFS_TARGET, measure, ompl_available, problems

    seeds, scenarios, budget = (
        (5, args.scenarios or ["disc10"], 0.5) if args.quick else (args.seeds, args.scenarios, args.budget)
    )
    if not ompl_available():
        print(
            "OMPL is not installed: install the bench extra (pip install -e '.[bench]' or pip install ompl); "
            "skipping the OMPL race. Our planners' numbers alone prove nothing, so this run fails."
        )
        return 1
    missed = False
    print(f"space {args.space}, {seeds} seeds per scenario, RRT* budget {budget:g} s")
    print(f"{'scenario':<16}{'pair':<26}{'ours':>12}{'OMPL':>12}{'ratio':>9}  target")
    for prob in problems(scenarios):
        r = measure(prob, args.space, seeds, budget, args.ttfs_limit)
        miss = r.missed
        missed |= any(miss.values())
        flags = {k: "  MISSED" if v else "" for k, v in miss.items()}
        print(
            f"{r.problem:<16}{'TTFS ms birrt/RRTConnect':<26}{1e3 * np.median(r.ttfs_ours):>12.2f}"
            f"{1e3 * np.median(r.ttfs_ompl):>12.2f}{r.ttfs_ratio:>9.2f}  <= {TTFS_TARGET}{flags['ttfs']}"
        )
        print(
            f"{'':<16}{'success birrt/RRTConnect':<26}{np.mean(r.solved_ours):>12.2f}{np.mean(r.solved_ompl):>12.2f}"
            f"{'':>9}  equal{flags['success']}"
        )
        print(
            f"{'':<16}{'length m rrt-star/RRT*':<26}{np.nanmedian(r.length_ours):>12.3f}"
            f"{np.nanmedian(r.length_ompl):>12.3f}{r.length_ratio:>9.3f}  <= {LENGTH_TARGET}{flags['length']}"
        )
        print(
            f"{'':<16}{'RRT* success (ours/OMPL)':<26}{np.mean(np.isfinite(r.length_ours)):>12.2f}"
            f"{np.mean(np.isfinite(r.length_ompl)):>12.2f}"
        )
    return 1 if missed else 0
