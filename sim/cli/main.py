"""The ``nhsim`` command line.

Each subcommand lives in its own module under ``sim/cli/`` with two functions:
``add_parser(subparsers) -> argparse.ArgumentParser`` and ``run(args) -> int``. The table below is
the whole registry; the CLI, the help text and the tests enumerate it.

Modules are imported only when their command runs, except for building the parsers, which must not
import mujoco at module level: :func:`main` chooses MuJoCo's GL backend first
(:func:`sim.viz.gl.configure` with the command's ``--gl``, else ``MUJOCO_GL`` or the default).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from planning.errors import NhsimError, SimulationError
from planning.trajectory.from_plan import TrajectoryError
from sim.viz import gl

#: Subcommand name -> module path.
COMMANDS: dict[str, str] = {
    "simulate": "sim.cli.simulate",
    "compare": "sim.cli.compare",
    "bench": "sim.cli.bench",
    "scenarios": "sim.cli.scenarios",
    "plan": "sim.cli.plan",
    "tune": "sim.cli.tune",
    "regress": "sim.cli.regress",
    "montecarlo": "sim.cli.montecarlo",
}


def package_version() -> str:
    """The installed ``nhsim`` distribution's version, or "unknown (not installed)" when run from a
    source tree that was never installed."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("nhsim")
    except PackageNotFoundError:
        return "unknown (not installed)"


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="nhsim",
        description="Plan, track and simulate nonholonomic wheeled robots (TurtleBot3, EduMIP) in MuJoCo.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {package_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module in COMMANDS.items():
        mod = importlib.import_module(module)
        p = mod.add_parser(sub)
        p.set_defaults(_module=module)
        assert p.prog.endswith(name)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``nhsim`` console script; returns the process exit code.

    Exit codes: 0 success, 1 a run or check failed (a run failed its checks, a benchmark missed its
    target, a planner ended without a path or its plan could not be made into a trajectory),
    2 bad input (usage or a clear error message), 130 interrupted (Ctrl-C or SIGTERM, handled alike
    for the whole command: :mod:`sim.cli.interrupt`).
    """
    from sim.cli.interrupt import sigterm_as_interrupt

    with sigterm_as_interrupt():
        try:
            return _main(argv)
        except KeyboardInterrupt:  # before a command was chosen (building the parser, parsing)
            print("nhsim: interrupted", file=sys.stderr)
            return 130


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        gl.configure(getattr(args, "gl", None))  # before the command imports mujoco
        mod = importlib.import_module(args._module)
        return int(mod.run(args))
    except SimulationError as exc:
        print(f"nhsim {args.command}: simulation failed: {exc}", file=sys.stderr)
        return 1
    except TrajectoryError as exc:  # a failed plan is a failed run, not bad input (as in ``nhsim plan``)
        print(f"nhsim {args.command}: failed: {exc}", file=sys.stderr)
        return 1
    except NhsimError as exc:
        print(f"nhsim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"nhsim {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
