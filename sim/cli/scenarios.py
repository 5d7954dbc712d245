"""``nhsim scenarios``: list the built-in scenarios."""

from __future__ import annotations

import argparse
from typing import Any


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``scenarios`` subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        "scenarios",
        help="list the built-in scenarios (robots, bounds, obstacles, description)",
        description=(
            "List the scenarios shipped in models/scenarios: name, robots (the default first), world bounds "
            "[xmin, xmax, ymin, ymax] in metres, number of obstacles, default planner and description. "
            "Any of them can be passed as --scenario NAME. Exit status 1 if one fails to load (its row says why); 2 "
            "if a planner plugin fails to load."
        ),
    )
    return p


def scenario_rows() -> list[dict[str, Any]]:
    """One row per built-in scenario; a scenario that fails to load carries its error instead.

    Raises:
        ConfigError: A planner plugin failed to load (the scenarios' planner names are checked against the
            registry): one error for the command, not the same one on every row that names a planner.
    """
    from planning.errors import NhsimError
    from planning.planners.registry import PLANNERS
    from planning.scenario import builtin_scenarios, load_scenario

    PLANNERS.load_plugins()  # what every scenario naming a planner looks up (once per process)
    rows: list[dict[str, Any]] = []
    for name in builtin_scenarios():
        try:
            sc = load_scenario(name)
        except NhsimError as exc:
            rows.append({"name": name, "error": str(exc)})
            continue
        robots = [sc.robot, *[r for r in sc.robots if r != sc.robot]]
        rows.append(
            {
                "name": sc.name,
                "robots": robots,
                "bounds": list(sc.world.bounds),
                "obstacles": len(sc.world.obstacles),
                "planner": sc.planner or "-",
                "description": sc.description,
            }
        )
    return rows


def run(args: argparse.Namespace) -> int:
    """Execute ``scenarios``."""
    rows = scenario_rows()
    width = max((len(", ".join(r["robots"])) for r in rows if "robots" in r), default=6)
    head = f"{'name':<16} {'robots':<{width}} {'bounds [m]':<26} {'obstacles':>9}  {'planner':<12} description"
    print(head)
    print("-" * len(head))
    failed = False
    for r in rows:
        if "error" in r:
            failed = True
            print(f"{r['name']:<16} error: {r['error']}")
            continue
        bounds = "[" + ", ".join(f"{b:g}" for b in r["bounds"]) + "]"
        print(
            f"{r['name']:<16} {', '.join(r['robots']):<{width}} {bounds:<26} {r['obstacles']:>9}  "
            f"{r['planner']:<12} {r['description']}"
        )
    return 1 if failed else 0
