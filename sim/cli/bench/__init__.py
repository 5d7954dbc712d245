"""``nhsim bench``: benchmarks printed as ratios against a baseline run in the same command.

Each benchmark measures in a module under ``sim/tools/bench/`` (returning its numbers) and has a
command module here, registered in ``BENCHMARKS``, with ``add_arguments(parser)`` and
``run(args) -> int`` (which prints the numbers as ratios against the target).
"""

from __future__ import annotations

import argparse
import importlib
from typing import Any

#: Benchmark name -> (module, one-line help).
BENCHMARKS: dict[str, tuple[str, str]] = {
    "sim": ("sim.cli.bench.sim", "closed-loop physics steps/s against a bare mj_step loop, and real-time factor"),
    "plan": (
        "sim.cli.bench.plan",
        "birrt / rrt-star against OMPL C++ RRTConnect / RRT* on the same problems and checker",
    ),
    "optim": (
        "sim.cli.bench.optim",
        "optim planner: the report's N=1000, dt=0.01 against the default (time, final error, length)",
    ),
    "hybrid": (
        "sim.cli.bench.hybrid",
        "hybrid-a-star: time to its path and length against rrt-star's on built-in and seeded worlds",
    ),
    "cold": (
        "sim.cli.bench.cold",
        "nhsim plan in fresh processes on new seeded worlds against the same plans warm (time, process wall)",
    ),
    "simplify": (
        "sim.cli.bench.simplify",
        "simplified birrt / rrt paths and simulate --all trajectories against rrt-star's (length, cusps, time)",
    ),
    "track": (
        "sim.cli.bench.track",
        "control time per step of every tracker in the real robot's loop; MPC's 95th percentile solve time",
    ),
    "render": ("sim.cli.bench.render", "video pipeline frames/s (replay, draw, encode) against a bare Renderer loop"),
    "bag": ("sim.cli.bench.bag", "a run with its ROS 2 bag against the same run without it (time, bag size)"),
    "montecarlo": (
        "sim.cli.bench.montecarlo",
        "Monte Carlo runs on Dask workers against a direct loop (throughput, per-run overhead)",
    ),
}


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``bench`` subcommand and its benchmarks."""
    p: argparse.ArgumentParser = sub.add_parser(
        "bench",
        help="run a benchmark (ratios against a baseline measured in the same command)",
        description="Benchmarks print ratios against a baseline measured in the same command and exit 1 "
        "when a target is missed.",
    )
    bsub = p.add_subparsers(dest="benchmark", metavar="BENCHMARK", required=True)
    for name, (module, help_text) in BENCHMARKS.items():
        bp = bsub.add_parser(name, help=help_text, description=help_text)
        importlib.import_module(module).add_arguments(bp)
        bp.set_defaults(_bench_module=module)
    return p


def run(args: argparse.Namespace) -> int:
    """Execute the chosen benchmark."""
    return int(importlib.import_module(args._bench_module).run(args))
