"""``nhsim plan``: plan a scenario with a registered planner; print, and optionally write JSON and a plot."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planning.errors import ConfigError
from sim.cli.checks import add_planner_option_argument, add_robot_argument

#: Largest motion between consecutive path states in the JSON record [m].
PATH_SPACING = 0.02


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``plan`` subcommand."""
    from planning.planners.registry import PLANNERS

    planners = ", ".join(PLANNERS.built_in()) + ", or one a plugin registers"
    p: argparse.ArgumentParser = sub.add_parser(
        "plan",
        help="plan a path through a scenario and report status, time, length and clearance",
        description=(
            "Plan from the scenario's start to its goal with one of the registered planners and print "
            "status, planning time, iterations, path length and minimum clearance (the smallest distance "
            "between the robot's footprint and any obstacle or wall at the path's states, the JSON record's "
            "path: a lower bound, at most 0.1 mm below the exact distance; the planners' own check, "
            "within 2.5 mm, is refined at the states that may hold the least).\n\n"
            f"Planners: {planners}.\n\n"
            "JSON record (--json): status, planner, reason, scenario, robot, seed, time_limit_s, time_s (the "
            "planner's, its collision grid included: stats.grid_s; Hybrid-A* also gives its CPU time, stats.cpu_s; "
            "numba readying the planner's kernels (compiling them once after an install, loading them in a new "
            "process) is in it but not held against the time limit: stats.code_s), "
            "iterations, length_m, raw_length_m, cusps, raw_cusps, simplify_time_s, first_path_time_s, "
            "first_path_length_m, min_clearance_m (null with no path, or where the path collides: "
            "path_collides), path_collides, goal_position_error_m, goal_heading_error_rad, "
            f"path_spacing_m, path (a list of [x, y, theta] states at most {PATH_SPACING * 100:g} cm apart "
            "along the motion, counting a turn in place as the robot's radius times the angle), stats.\n\n"
            "Exit status: 0 when the plan succeeded, 1 when the planner ended in another status "
            "(outputs are still written), 2 on bad input.\n\n"
            "The sampling planners return their path simplified (shortcuts with their own steering, fewer "
            "vertices): length_m and cusps are the simplified path's, raw_length_m and raw_cusps the search's "
            "(equal when nothing was simplified; simplify_time_s is then null; the part of it numba spent loading "
            "the simplification's kernels in a new process: stats.simplify_code_s); --no-simplify keeps the raw path. "
            "first_path_time_s and first_path_length_m (rrt-star) are its first solution's."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--scenario",
        required=True,
        metavar="NAME|PATH",
        help="built-in scenario name (see 'nhsim scenarios'), random<N> (the generated world of seed N) or path to "
        "a scenario .toml",
    )
    p.add_argument(
        "--planner", default=None, metavar="P", help=f"planner: {planners} (default: the scenario's planner)"
    )
    add_planner_option_argument(p)
    add_robot_argument(
        p, "robot, overriding the scenario's: one of the robots it lists (default: the scenario's robot)"
    )
    p.add_argument("--seed", type=int, default=0, metavar="N", help="random seed; same seed, same plan (default: 0)")
    p.add_argument(
        "--time-limit",
        type=float,
        default=30.0,
        metavar="S",
        help=(
            "wall-clock budget in seconds; when spent the planner returns TIMEOUT, as it does when its "
            "iteration budget is spent first (the reason says which) (default: 30)"
        ),
    )
    p.add_argument(
        "--no-simplify",
        action="store_true",
        help="return the search's raw path (sampling planners simplify their path by default)",
    )
    p.add_argument("--json", type=Path, default=None, metavar="PATH", help="write the plan record as JSON")
    p.add_argument(
        "--plot",
        type=Path,
        default=None,
        metavar="PATH",
        help="write an image of world, tree and path, in the format its suffix names (.png, .svg, .pdf, ...)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="print only the results")
    return p


def record_path(path: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    """The path written to the JSON record: states at most ``PATH_SPACING`` apart.

    Steps count ``|dxy| + radius * |dtheta|`` (:func:`planning.core.geometry.densify_path`); a path
    already that dense is returned as the planner gave it.

    Args:
        path: (N, 3) states [x, y, theta].
        radius: Robot radius [m].

    Returns:
        (N', 3) states, N' >= N, containing the given ones.
    """
    from planning.core.geometry import densify_path

    dense = densify_path(path, PATH_SPACING, radius=radius, slack=1e-9)  # slack: rounding of an exact split
    return path if dense.shape[0] == path.shape[0] else dense


def path_spacing(path: NDArray[np.float64], radius: float) -> float:
    """Largest ``|dxy| + radius * |dtheta|`` between consecutive states [m] (0 for fewer than two)."""
    from planning.core.geometry import path_steps

    return float(np.max(path_steps(path, radius))) if path.shape[0] >= 2 else 0.0


def run(args: argparse.Namespace) -> int:
    """Execute ``plan``."""
    from planning.core.robot import load_robot
    from planning.planners.base import PlanProblem, PlanStatus, run_planner
    from planning.planners.registry import PLANNERS, make_planner
    from planning.scenario import load_scenario, scenario_with_robot
    from sim.cli.checks import check_seeds, check_time_limit, planner_option_values
    from sim.cli.job_outputs import check_apart_from_inputs
    from sim.outputs import check_writable, image_format, resolved

    check_seeds(seed=args.seed)
    check_time_limit(args.time_limit)
    outputs = [out for out in (args.json, args.plot) if out is not None]
    check_apart_from_inputs(args, outputs)  # the scenario file and its map image are read
    for out in outputs:
        check_writable(out, overwrite=args.overwrite)
    if args.plot is not None:
        image_format(args.plot, "--plot")
    if args.json is not None and args.plot is not None and resolved(args.json) == resolved(args.plot):
        raise ConfigError("--json and --plot name the same file; give two different paths")
    scenario = scenario_with_robot(load_scenario(args.scenario), args.robot)
    check_scenario_sensors(scenario)
    name = args.planner or scenario.planner
    if name is None:
        raise ConfigError(f"scenario {scenario.name!r} names no default planner: pass --planner")
    options = {**scenario.options_for(name), **planner_option_values(args.planner_option)}
    planner = make_planner(name, **plan_options(name, options, simplify=not args.no_simplify))
    robot = load_robot(scenario.robot)
    problem = PlanProblem.from_scenario(scenario, robot=robot, seed=args.seed, time_limit=args.time_limit)
    if not args.quiet:
        print(
            f"scenario {scenario.name} | robot {robot.name} | planner {name} | seed {args.seed} | "
            f"time limit {args.time_limit:g} s"
        )
    from sim.cli.job_outputs import show_progress
    from sim.cli.progress import TimedBar

    t0 = time.perf_counter()
    with TimedBar("planning", args.time_limit, enabled=show_progress(args)):
        result = run_planner(planner, name, problem, PLANNERS.origin(name))
    facts = plan_facts(problem, result, time.perf_counter() - t0)
    status, reason = trusted_status(result.status, result.reason, facts["min_clearance_m"])
    min_clear, iterations = facts["min_clearance_m"], facts["iterations"]
    partial = "" if status is PlanStatus.SUCCESS or min_clear is None else " (of the partial path)"
    lines = [
        f"status          {status.value}",
        f"time            {facts['time_s']:.3f} s{grid_note(result.stats)}",
        f"iterations      {iterations if iterations is not None else '-'}",
        f"path length     {facts['length_m']:.3f} m{raw_note(facts, result.stats)}{partial}",
        f"min clearance   {clearance_text(min_clear)}{partial}",
    ]
    if reason:
        lines.append(f"reason          {reason}")
    faster = timing_note(result, robot)
    if faster:
        lines.append(f"note            {faster}")
    if "overran_s" in result.stats:  # a planner of a plugin's that does not stop on time
        lines.append(
            f"note            planner {name!r} took {result.stats['overran_s']:.3f} s (loading code apart), over "
            f"its time limit of {args.time_limit:g} s: a planner stops within problem.time_limit"
        )
    print("\n".join(lines))
    record = {
        "status": status.value,
        "planner": name,
        "reason": reason,
        "scenario": scenario.name,
        "robot": robot.name,
        "seed": args.seed,
        "time_limit_s": args.time_limit,
        **facts,
        "stats": {k: v for k, v in result.stats.items() if _jsonable(v)},
    }
    _write(args, record, problem, result)
    if status is PlanStatus.SUCCESS:
        return 0
    # the failure's one line on stderr, as every command's (the table above is the standard output's)
    print(f"nhsim plan: failed: planner {name!r} ended with status {status.value}: {reason}", file=sys.stderr)
    return 1


def check_scenario_sensors(scenario: Any) -> None:
    """Refuse a scenario whose ``[sensors]`` table ``simulate`` would refuse (an unknown key, a bad value), by
    the same check (:func:`sim.physics.sensors.load_sensor_profile`, as
    :meth:`sim.pipeline.case.Case.sensing` makes it): a plan uses no sensors, but the file is the same
    scenario, bad for every command. Whether a fix rate fits the control rate is left to the commands that
    run a controller (``plan`` has no control rate).

    Raises:
        ConfigError: Naming the file, the field and the fix.
    """
    if not scenario.sensors:
        return
    from planning.scenario import scenario_source
    from sim.physics.sensors import load_sensor_profile

    load_sensor_profile(scenario.robot, table=dict(scenario.sensors), source=scenario_source(scenario))


def _write(args: argparse.Namespace, record: dict[str, Any], problem: Any, result: Any) -> None:
    """Write the JSON record and the plot asked for, as one set (:func:`sim.outputs.staged_outputs`: both
    moved into place once both are written); print what was written."""
    from sim.outputs import staged_outputs, write_json

    with staged_outputs(overwrite=args.overwrite) as stage:
        if args.json is not None:
            write_json(stage.path(args.json), record)
        if args.plot is not None:
            from sim.viz.plots.draw import save_figure
            from sim.viz.plots.plan import plan_figure

            save_figure(plan_figure(problem, result), stage.path(args.plot))
    if not args.quiet:
        for out in (args.json, args.plot):
            if out is not None:
                print(f"wrote {out}")


def plan_options(name: str, options: dict[str, Any], *, simplify: bool) -> dict[str, Any]:
    """A planner's options with ``simplify=False`` added for ``--no-simplify`` (planners that simplify).

    Raises:
        ConfigError: ``--no-simplify`` for a planner that does not simplify (the message names those that do).
    """
    from planning.planners.registry import PLANNERS, planner_options

    if simplify:
        return options
    if "simplify" not in planner_options(name):
        which = ", ".join(sorted(n for n in PLANNERS if "simplify" in planner_options(n)))
        raise ConfigError(f"--no-simplify: planner {name!r} does not simplify its path; only {which} do")
    return {**options, "simplify": False}


def timing_note(result: Any, robot: Any) -> str:
    """What to know when a plan timed by its planner (``result.controls``: optim's, sinusoidal's) moves faster than the
    robot does (a planner option above its limits, such as sinusoidal's ``u1max``), else ""."""
    if result.controls is None or not len(result.controls):
        return ""
    v, w = np.abs(result.controls).max(axis=0)
    over = [
        f"{what} {got:.3g} {unit} over the robot's {limit:.3g}"
        for what, got, limit, unit in (
            ("speed", v, robot.max_speed, "m/s"),
            ("yaw rate", w, robot.max_yaw_rate, "rad/s"),
        )
        if got > limit * (1 + 1e-6)
    ]
    if not over:
        return ""
    return (
        f"the plan's own timing reaches {' and '.join(over)} (a planner option above the robot's limits); nhsim "
        "simulate times the path again within them"
    )


def grid_note(stats: dict[str, Any]) -> str:
    """`` (collision grid 0.012 s, CPU 0.050 s, loading code 0.345 s, ...)`` for the parts of the plan's time
    its stats report (the grid is built inside the planner's time and limit; numba readying the kernels,
    compiling them once after an install or loading them in a new process, is not held against the limit
    and is named only when it took a millisecond or more), else ""."""
    parts = [
        f"{label} {stats[key]:.3f} s" for key, label in (("grid_s", "collision grid"), ("cpu_s", "CPU")) if key in stats
    ]
    if stats.get("code_s", 0.0) >= 0.001:
        parts.append(f"loading code {stats['code_s']:.3f} s, not held against the time limit")
    return f" ({', '.join(parts)})" if parts else ""


def raw_note(facts: dict[str, Any], stats: dict[str, Any]) -> str:
    """`` (raw 12.345 m, 3 -> 1 cusps, simplified in 8 ms)`` when the plan was simplified, else "";
    ``, cut short by the time limit`` when the limit stopped the simplification (the path as far as it got);
    ``, 5 ms of it loading code`` is added when numba readied the simplification's kernels for a
    millisecond or more (``stats["simplify_code_s"]``: loading them in a new process)."""
    if facts["simplify_time_s"] is None:
        return ""
    code = float(stats.get("simplify_code_s", 0.0))
    loading = f", {1e3 * code:.0f} ms of it loading code" if code >= 0.001 else ""
    cut = ", cut short by the time limit" if stats.get("simplify_time_limit_reached") else ""
    return (
        f" (raw {facts['raw_length_m']:.3f} m, {facts['raw_cusps']} -> {facts['cusps']} cusps, "
        f"simplified in {1e3 * facts['simplify_time_s']:.0f} ms{loading}{cut})"
    )


def clearance_text(min_clear: float | None) -> str:
    """The printed minimum clearance: metres to 0.1 mm and what the number is (a lower bound, at most
    ``REFINED_TOLERANCE / 2`` below the exact distance: :meth:`CollisionChecker.least_clearance`), "-"
    without a path, and for the checker's -inf (an obstacle inside the footprint, or the whole footprint
    inside an obstacle or beyond a wall) words that say so."""
    from planning.collision.exact import REFINED_TOLERANCE

    if min_clear is None:
        return "-"
    if not np.isfinite(min_clear):
        return (
            "in collision (an obstacle inside the robot's footprint, or the robot wholly inside an obstacle or "
            "beyond a wall)"
        )
    return f"{min_clear:.4f} m (a lower bound, at most {500 * REFINED_TOLERANCE:g} mm below the exact distance)"


def trusted_status(status: Any, reason: str, min_clearance: float | None) -> tuple[Any, str]:
    """The status to report: a success whose clearance is not a number is reported as failed (a success whose
    path collides is already one: :func:`planning.planners.base.run_planner` checks it).

    Args:
        status: The planner's PlanStatus.
        reason: The planner's reason ("" when none).
        min_clearance: Minimum clearance along the path [m], None without a path.

    Returns:
        (status, reason) to print and record.
    """
    from planning.planners.base import PlanStatus

    if status is not PlanStatus.SUCCESS or min_clearance is None or not math.isnan(min_clearance):
        return status, reason
    return PlanStatus.FAILED, (
        f"the path's minimum clearance is {min_clearance} (not finite), so its collision check cannot be "
        "trusted; check the scenario's obstacles"
    )


def plan_facts(problem: Any, result: Any, wall: float) -> dict[str, Any]:
    """What the record says of a plan: time, iterations, length, clearance, goal errors, the path.

    Args:
        problem: The PlanProblem.
        result: The planner's PlanResult.
        wall: Wall time of the planner's call [s] (when its stats have no ``time_s``).

    Returns:
        time_s, iterations, length_m, raw_length_m, cusps, raw_cusps, simplify_time_s (None when
        not simplified), first_path_time_s, first_path_length_m (None unless the planner reports
        them), min_clearance_m (:meth:`CollisionChecker.least_clearance` of the path's states, -inf where
        they overlap something), path_collides (whether they do; None without a path), goal_position_error_m,
        goal_heading_error_rad (None without a path), path_spacing_m and path (densified states).
    """
    from planning.collision.exact import CollisionChecker
    from planning.core.geometry import path_length, wrap_angle
    from planning.planners.simplify import count_cusps

    robot = problem.robot
    path = record_path(np.asarray(result.path, dtype=float).reshape(-1, 3), robot.radius)
    min_clear = goal_pos = goal_head = None
    if path.shape[0] > 0:
        checker = CollisionChecker(problem.world, robot, shape="footprint")
        min_clear = checker.least_clearance(path)  # the planners' lower bound, refined to within 0.1 mm
        goal_pos = float(np.hypot(path[-1, 0] - problem.goal.x, path[-1, 1] - problem.goal.y))
        goal_head = abs(float(wrap_angle(path[-1, 2] - problem.goal.theta)))
    stats = result.stats
    simplified = result.raw_path is not None
    cusps = count_cusps(result.directions)
    return {
        "time_s": float(stats.get("time_s", wall)),
        "iterations": stats.get("iterations"),
        "length_m": path_length(path),
        "raw_length_m": path_length(result.raw_path) if simplified else path_length(path),
        "cusps": cusps,
        "raw_cusps": int(stats.get("raw_cusps", cusps)) if simplified else cusps,
        "simplify_time_s": stats.get("simplify_time_s") if simplified else None,
        "first_path_time_s": stats.get("first_solution_s"),
        "first_path_length_m": stats.get("first_length_m"),
        "min_clearance_m": min_clear,
        # an overlap has no clearance to give (-inf, null in JSON): said, not left to read as "no path"
        "path_collides": None if min_clear is None else bool(min_clear < 0.0),
        "goal_position_error_m": goal_pos,
        "goal_heading_error_rad": goal_head,
        "path_spacing_m": path_spacing(path, robot.radius),
        "path": path.tolist(),
    }


def _jsonable(value: Any) -> bool:
    return isinstance(value, (int, float, str, bool, list, dict, type(None))) or hasattr(value, "tolist")
