"""``nhsim bench plan``: birrt against OMPL's C++ RRTConnect, rrt-star against OMPL's best optimal
planner (see :mod:`sim.tools.bench.plan`); ``--markdown`` writes the tables for the docs."""

from __future__ import annotations

import argparse
import datetime
import math
import os
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any

from planning.errors import ConfigError


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    from sim.tools.bench.plan import OPTIMAL

    p.add_argument(
        "--space", choices=["reeds_shepp", "dubins"], default="reeds_shepp", help="curve space of both sides"
    )
    p.add_argument("--seeds", type=int, default=None, help="seeds (trials) per problem (default: 20; 5 with --quick)")
    p.add_argument(
        "--scenarios",
        nargs="+",
        default=None,
        metavar="NAME",
        help="problem names: built-in scenarios, disc10, corridor, maze, tight_park, random<N> "
        "(default: every built-in scenario whose start is outside its goal region, and the four named)",
    )
    p.add_argument(
        "--random-worlds",
        type=int,
        default=None,
        metavar="N",
        help="add seeded random worlds random0.. (default: 3 without --scenarios, else 0)",
    )
    p.add_argument(
        "--optimal",
        nargs="+",
        default=None,
        metavar="PLANNER",
        help=f"OMPL's optimal planners rrt-star races (default: all of {', '.join(OPTIMAL)}; RRTstar with --quick)",
    )
    p.add_argument(
        "--budget", type=float, default=None, metavar="S", help="RRT* time budget [s] (default: 1; 0.5 with --quick)"
    )
    p.add_argument(
        "--goal",
        choices=("region", "pose"),
        default="region",
        help="the length race's goal: 'region' (default): rrt-star with region_goal and OMPL's optimal planners "
        "sampling the same poses of the goal region, so both may end anywhere in it; 'pose': both aim at the "
        "goal pose (rrt-star's default)",
    )
    p.add_argument("--ttfs-limit", type=float, default=10.0, metavar="S", help="time limit for first paths [s]")
    p.add_argument("--no-wheel", action="store_true", help="skip OMPL's Python wheel even when installed")
    p.add_argument("--markdown", metavar="PATH", help="also write the tables as Markdown, stamped, to PATH")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --markdown file")
    p.add_argument(
        "--quick",
        action="store_true",
        help="a quick run: 5 seeds, disc10 only, 0.5 s budget, RRTstar only (--seeds, --scenarios, --budget and "
        "--optimal given with it are used instead)",
    )


def _fmt(v: float, spec: str, width: int = 0) -> str:
    return f"{v:>{width}{spec}}" if math.isfinite(v) else f"{'inf' if v == math.inf else '-':>{width}}"


def against(v: float, target: float, places: int) -> str:
    """``v`` with ``places`` decimals, or as many more as it takes to read apart from ``target`` when it is not
    the target (a median of 0.9903 against 0.99 printed 0.990 beside MISSED)."""
    while math.isfinite(v) and v != target and places < 9 and round(v, places) == round(target, places):
        places += 1
    return _fmt(v, f".{places}f")


def _cells(r: Any, cpp: bool) -> dict[str, str]:
    """One problem's numbers as text, keyed by column."""
    import numpy as np

    from sim.tools.bench.plan import length_median

    def med(v: tuple[float, ...], scale: float = 1.0) -> float:
        return float(np.nanmedian(v) * scale) if np.any(np.isfinite(v)) else float("nan")

    solved = r._solved
    c = {
        "problem": r.problem,
        "ok": f"{np.mean(r.ok_ours):.2f}" + (f"/{np.mean(r.ok_cpp):.2f}" if cpp else ""),
        "t": _fmt(med(solved(r.ttfs_ours, r.ok_ours), 1e3), ".2f"),
        "t_c": _fmt(med(solved(r.ttfs_cpp, r.ok_cpp), 1e3), ".2f") if cpp else "-",
        "t_r": _fmt(r.ttfs_ratio, ".2f"),
        "len": _fmt(length_median(r.len_ours), ".3f"),
        "anchor": r.anchor or "-",
        "len_c": _fmt(length_median(r.len_cpp[r.anchor]), ".3f") if r.anchor else "-",
        "len_r": _fmt(r.length_ratio, ".3f"),
        "star_ok": f"{np.mean(r.star_ok_ours):.2f}" + (f"/{r.success(r.anchor):.2f}" if r.anchor else ""),
        "wheel_t": _fmt(med(r.ttfs_wheel, 1e3), ".2f") if r.ttfs_wheel else "-",
        "wheel_len": _fmt(med(r.len_wheel), ".3f") if r.len_wheel else "-",
        "hybrid": f"{_fmt(1e3 * r.hybrid_time, '.1f')} ms {_fmt(r.hybrid_length, '.2f')} m",
        "miss": "SUCCESS MISSED" if r.success_missed else "",
    }
    for name, lengths in r.len_cpp.items():
        c[name] = f"{_fmt(length_median(lengths), '.3f')} ({np.mean(np.isfinite(lengths)):.2f})"
    return c


#: The first-path table and the length table: (key, header, width).
TTFS_COLS = (("problem", "problem", 17), ("ok", "success birrt/RRTC", 19), ("t", "birrt ms", 10),
             ("t_c", "RRTConnect ms", 14), ("t_r", "ratio", 7), ("wheel_t", "wheel ms", 10))  # fmt: skip
LEN_COLS = (("problem", "problem", 17), ("star_ok", "success rrt*/best", 18), ("len", "rrt-star m", 11),
            ("len_c", "best m", 9), ("len_r", "ratio", 7), ("anchor", "best OMPL", 18),
            ("wheel_len", "wheel RRT* m", 13), ("hybrid", "hybrid-a-star", 20))  # fmt: skip


def _line(cells: dict[str, str], cols: tuple[tuple[str, str, int], ...]) -> str:
    return "".join(f"{cells[k]:<{w}}" if i == 0 else f"{cells[k]:>{w}}" for i, (k, _, w) in enumerate(cols))


def _verdict(rows: list[Any]) -> tuple[bool, list[str]]:
    """The medians over the problems against the targets: (a target missed, lines to print)."""
    from sim.tools.bench.plan import LENGTH_TARGET, TTFS_CAP, TTFS_TARGET, summary

    s = summary(rows)
    ttfs_miss = not s["ttfs_ratio"] <= TTFS_TARGET
    cap_miss = not s["ttfs_worst"] <= TTFS_CAP
    len_miss = not s["length_ratio"] <= LENGTH_TARGET
    succ = [r.problem for r in rows if r.success_missed]
    lines = [
        f"median over problems: first path birrt / RRTConnect {against(s['ttfs_ratio'], TTFS_TARGET, 2)} (target <= "
        f"{TTFS_TARGET}){'  MISSED' if ttfs_miss else ''}, worst {against(s['ttfs_worst'], TTFS_CAP, 2)} (target <= "
        f"{TTFS_CAP}){'  MISSED' if cap_miss else ''}; length rrt-star / best OMPL "
        f"{against(s['length_ratio'], LENGTH_TARGET, 3)} "
        f"(target <= {LENGTH_TARGET}){'  MISSED' if len_miss else ''}",
        f"success below OMPL's on: {', '.join(succ)}  MISSED" if succ else "success: never below OMPL's",
    ]
    return ttfs_miss or cap_miss or len_miss or bool(succ), lines


def _commit() -> str:
    """The commit of the checkout nhsim runs from (short hash; "unknown" outside a git checkout), whatever the
    working directory (run from elsewhere, it read "unknown")."""
    here = Path(__file__).resolve().parent
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False, cwd=here)
    return git.stdout.strip() if git.returncode == 0 else "unknown"


def _now() -> str:
    return datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")


def _stamp(seeds: int, budget: float, space: str, load: tuple[float, float], commit: str, started: str) -> str:
    """Dates, commit (at the start), the command as given, the cores this process may use and the load of a run
    (for the Markdown output): a page reproduced from itself (it named seeds, budget and space only, not the
    problems, the OMPL planners or the goal)."""
    from sim.tools.executor import default_jobs

    command = shlex.join(["nhsim", *sys.argv[1:]])
    return (
        f"Measured {started} to {_now()}, commit {commit}, `{command}`, {default_jobs()} cores, load "
        f"average {load[0]:.1f} at the start and {load[1]:.1f} at the end; {space}, {seeds} seeds per problem, RRT* "
        f"budget {budget:g} s. Ratios are measured within one command, ours and OMPL's trials interleaved seed by seed."
    )


def _markdown(rows: list[Any], stamp: str, verdict: list[str], cpp: bool) -> str:
    names = list(rows[0].len_cpp) if rows else []
    per = (("problem", "problem", 0), *((n, n, 0) for n in names))
    out = [f"_{stamp}_", ""]
    tables = (
        ("First path", TTFS_COLS),
        ("Length after the budget", LEN_COLS),
        ("Each OMPL planner: median length m (success)", per),
    )
    for title, cols in tables:
        if cols is per and not names:
            continue
        out += [f"**{title}**", "", "| " + " | ".join(h for _, h, _ in cols) + " |"]
        out.append("|" + "|".join(":--" if i == 0 else "--:" for i in range(len(cols))) + "|")
        out += ["| " + " | ".join(_cells(r, cpp)[k] for k, _, _ in cols) + " |" for r in rows]
        out.append("")
    return "\n".join(out + [f"- {v}" for v in verdict]) + "\n"


#: What ``--quick`` races unless told otherwise: (seeds, problems, budget [s], OMPL planners).
QUICK: tuple[int, list[str] | None, float, tuple[str, ...] | None] = (5, ["disc10"], 0.5, ("RRTstar",))
#: The same without ``--quick`` (problems None: every built-in scenario and the named ones; planners None: all).
FULL: tuple[int, list[str] | None, float, tuple[str, ...] | None] = (20, None, 1.0, None)


def settings(args: argparse.Namespace) -> tuple[int, list[str] | None, float, tuple[str, ...]]:
    """(seeds, problem names, RRT* budget, OMPL planners): the options given, else :data:`QUICK`'s with
    ``--quick``, else :data:`FULL`'s; each checked alike, given or not.

    Raises:
        ConfigError: A count or time out of range, an unknown OMPL planner (naming the option).
    """
    from planning.core.checks import check_number
    from sim.cli.checks import check_at_least, check_once, check_worlds
    from sim.tools.bench.plan import OPTIMAL

    d_seeds, d_names, d_budget, d_optimal = QUICK if args.quick else FULL
    seeds: int = d_seeds if args.seeds is None else args.seeds
    names: list[str] | None = d_names if args.scenarios is None else args.scenarios
    budget: float = d_budget if args.budget is None else args.budget
    optimal = tuple(args.optimal or d_optimal or OPTIMAL)
    check_at_least({"--seeds": (seeds, 1)})
    check_once("--scenarios", args.scenarios)
    check_once("--optimal", args.optimal)
    if args.overwrite and not args.markdown:  # it replaces a --markdown file, and was dropped without a word
        raise ConfigError("--overwrite replaces the --markdown file, and none is given: drop it, or give --markdown")
    if args.random_worlds is not None:
        check_worlds("--random-worlds", args.random_worlds)
    for flag, value in (("--budget", budget), ("--ttfs-limit", args.ttfs_limit)):  # an hour: a trial's at most
        check_number(flag, value, above=0.0, at_most=3600.0, unit="s")
    unknown = [n for n in optimal if n not in OPTIMAL]
    if unknown:
        raise ConfigError(
            f"unknown OMPL planner(s) {', '.join(unknown)} for --optimal: choose from {', '.join(OPTIMAL)}"
        )
    return seeds, None if names is None else list(names), budget, optimal


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed, 0 with a note when OMPL C++ is unavailable."""
    from pathlib import Path

    from sim.cli.checks import check_something_to_plan
    from sim.outputs import atomic_path, check_writable
    from sim.tools.bench.ompl_native import build
    from sim.tools.bench.plan import measure, problems, wheel_available

    seeds, names, budget, optimal = settings(args)
    if args.markdown:
        check_writable(Path(args.markdown), overwrite=args.overwrite)
    randoms = args.random_worlds if args.random_worlds is not None else (3 if names is None else 0)
    probs = problems(names, randoms)
    check_something_to_plan("--scenarios", probs)  # a length ratio divided by zero after the race
    load0, commit, started = os.getloadavg()[0], _commit(), _now()
    why = build.missing()
    harness = build.harness() if why is None else None
    wheel = not args.no_wheel and wheel_available()
    cpp = harness is not None
    if not cpp:
        other = "OMPL's Python wheel only" if wheel else "our planners only (pip install ompl adds the wheel)"
        print(f"note: OMPL's C++ planners cannot be raced: {why}. Racing {other}; no target is judged.")
    print(
        f"space {args.space}, {seeds} seeds per problem, first paths within {args.ttfs_limit:g} s, RRT* budget "
        f"{budget:g} s against {', '.join(optimal)} (goal samples: {args.goal}); times are medians over solved "
        "trials, lengths medians with a failure counted infinitely long"
    )
    heads = {k: h for k, h, _ in TTFS_COLS + LEN_COLS}
    print(f"{_line(heads, TTFS_COLS)}  |{_line(heads, LEN_COLS[1:])}")
    rows = []
    for prob in probs:
        rows.append(measure(prob, args.space, seeds, budget, args.ttfs_limit, harness, wheel, optimal, args.goal))
        c = _cells(rows[-1], cpp)
        print(f"{_line(c, TTFS_COLS)}  |{_line(c, LEN_COLS[1:])}  {c['miss']}", flush=True)
    missed, verdict = _verdict(rows) if cpp else (False, [])
    for v in verdict:
        print(v)
    if args.markdown:
        stamp = _stamp(seeds, budget, args.space, (load0, os.getloadavg()[0]), commit, started)
        with atomic_path(args.markdown, overwrite=args.overwrite) as tmp:
            tmp.write_text(_markdown(rows, stamp, verdict, cpp), encoding="utf-8")
        print(f"wrote {args.markdown}")
    return 1 if missed else 0
