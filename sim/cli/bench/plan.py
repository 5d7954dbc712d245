"""``nhsim bench plan``: birrt / rrt-star against OMPL's C++ RRTConnect / RRT* (see
:mod:`sim.tools.bench.plan`)."""

from __future__ import annotations

import argparse
import math
from typing import Any


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument(
        "--space", choices=["reeds_shepp", "dubins"], default="reeds_shepp", help="curve space of both sides"
    )
    p.add_argument("--seeds", type=int, default=20, help="seeds (trials) per problem (default: 20)")
    p.add_argument(
        "--scenarios",
        nargs="*",
        default=None,
        help="problem names: built-in scenarios, disc10, corridor, maze, tight_park "
        "(default: every built-in scenario whose start is outside its goal region, and the four named)",
    )
    p.add_argument("--budget", type=float, default=1.0, metavar="S", help="RRT* time budget [s] (default: 1)")
    p.add_argument("--ttfs-limit", type=float, default=10.0, metavar="S", help="time limit for first paths [s]")
    p.add_argument("--no-wheel", action="store_true", help="skip OMPL's Python wheel even when installed")
    p.add_argument("--quick", action="store_true", help="5 seeds, disc10 only, 0.5 s budget")


def _fmt(v: float, spec: str, width: int) -> str:
    return f"{v:>{width}{spec}}" if math.isfinite(v) else f"{'-':>{width}}"


def _header(cpp: bool, wheel: bool, hybrid: bool) -> str:
    h = f"{'problem':<17}{'success birrt/RRTC':>19}{'TTFS ms ours':>13}"
    h += f"{'C++':>9}{'ratio':>7}" if cpp else ""
    h += f"{'wheel':>9}" if wheel else ""
    h += f"{'success rrt*/RRT*':>19}{'len m ours':>11}"
    h += f"{'C++':>9}{'ratio':>7}" if cpp else ""
    h += f"{'wheel':>9}" if wheel else ""
    h += f"{'HA* ms':>9}{'HA* m':>8}" if hybrid else ""
    return h


def _row(r: Any, cpp: bool, wheel: bool, hybrid: bool) -> str:
    import numpy as np

    from sim.tools.bench.plan import PlanBench

    def med(v: tuple[float, ...], scale: float = 1.0) -> float:
        return float(np.nanmedian(v) * scale) if np.any(np.isfinite(v)) else float("nan")

    solved = PlanBench._solved
    ok = f"{np.mean(r.ok_ours):.2f}" + (f"/{np.mean(r.ok_cpp):.2f}" if cpp else "")
    s = f"{r.problem:<17}{ok:>19}{_fmt(med(solved(r.ttfs_ours, r.ok_ours), 1e3), '.2f', 13)}"
    if cpp:
        s += _fmt(med(solved(r.ttfs_cpp, r.ok_cpp), 1e3), ".2f", 9) + _fmt(r.ttfs_ratio, ".2f", 7)
    s += _fmt(med(r.ttfs_wheel, 1e3), ".2f", 9) if wheel else ""
    star = f"{np.mean(r.star_ok_ours):.2f}" + (f"/{np.mean(r.star_ok_cpp):.2f}" if cpp else "")
    s += f"{star:>19}{_fmt(med(r.len_ours), '.3f', 11)}"
    if cpp:
        s += _fmt(med(r.len_cpp), ".3f", 9) + _fmt(r.length_ratio, ".3f", 7)
    s += _fmt(med(r.len_wheel), ".3f", 9) if wheel else ""
    s += _fmt(1e3 * r.hybrid_time, ".1f", 9) + _fmt(r.hybrid_length, ".2f", 8) if hybrid else ""
    return s + ("  SUCCESS MISSED" if r.success_missed else "")


def _verdict(rows: list[Any]) -> bool:
    """Print the medians over the problems against the targets; True when a target is missed."""
    from sim.tools.bench.plan import LENGTH_TARGET, TTFS_TARGET, summary

    s = summary(rows)
    ttfs_miss = not s["ttfs_ratio"] <= TTFS_TARGET
    len_miss = not s["length_ratio"] <= LENGTH_TARGET
    succ = [r.problem for r in rows if r.success_missed]
    print(
        f"median over problems: TTFS birrt / RRTConnect {s['ttfs_ratio']:.2f} (target <= {TTFS_TARGET})"
        f"{'  MISSED' if ttfs_miss else ''}; length rrt-star / RRT* {s['length_ratio']:.3f} "
        f"(target <= {LENGTH_TARGET}){'  MISSED' if len_miss else ''}"
    )
    print(f"success below OMPL's on: {', '.join(succ)}  MISSED" if succ else "success: never below OMPL's")
    return ttfs_miss or len_miss or bool(succ)


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed, 0 with a note when OMPL C++ is unavailable."""
    from planning.errors import ConfigError
    from planning.planners.registry import PLANNERS
    from sim.tools.bench.ompl_native import build
    from sim.tools.bench.plan import HYBRID, measure, problems, wheel_available

    seeds, names, budget = (
        (5, args.scenarios or ["disc10"], 0.5) if args.quick else (args.seeds, args.scenarios, args.budget)
    )
    if seeds < 1 or not budget > 0 or not args.ttfs_limit > 0:
        raise ConfigError("--seeds must be >= 1, --budget and --ttfs-limit > 0 s")
    probs = problems(names)
    why = build.missing()
    harness = build.harness() if why is None else None
    wheel = not args.no_wheel and wheel_available()
    if harness is None:
        other = "OMPL's Python wheel only" if wheel else "our planners only (pip install ompl adds the wheel)"
        print(f"note: OMPL's C++ planners cannot be raced: {why}. Racing {other}; no target is judged.")
    hybrid = HYBRID in PLANNERS
    print(
        f"space {args.space}, {seeds} seeds per problem, first paths within {args.ttfs_limit:g} s, RRT* budget "
        f"{budget:g} s; times are medians over solved trials"
    )
    print(_header(harness is not None, wheel, hybrid))
    rows = []
    for prob in probs:
        rows.append(measure(prob, args.space, seeds, budget, args.ttfs_limit, harness, wheel))
        print(_row(rows[-1], harness is not None, wheel, hybrid), flush=True)
    if harness is None:
        return 0
    return 1 if _verdict(rows) else 0
