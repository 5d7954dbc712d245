"""``nhsim bench track``: control time per step of every tracker in the real robot's loop, and MPC's
95th percentile solve time per solver (see :mod:`sim.tools.bench.track`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    from planning.trajectory.references import REFERENCES
    from sim.cli.checks import add_robot_argument

    add_robot_argument(p, "robot (default: turtlebot3)", "turtlebot3")
    p.add_argument("--reference", choices=list(REFERENCES), default="figure8")
    p.add_argument(
        "--trackers", default=None, metavar="A,B,...", help="(default: every registered tracker with feedback)"
    )
    p.add_argument(
        "--mpc-solvers",
        default="rti,sqp,ipopt",
        metavar="S[:QP],...",
        help="MPC solvers to time (rti, sqp, ipopt), each with its QP solver if not the default (daqp, qrqp), "
        "e.g. rti,sqp:qrqp",
    )
    p.add_argument("--control-rate", type=float, default=50.0, metavar="HZ")


def mpc_solvers(text: str) -> list[str]:
    """``--mpc-solvers``: the ``SOLVER[:QP]`` entries, each checked as MPC reads it, the message naming the option.

    Raises:
        ConfigError: No entry, or one MPC does not know (naming it and the valid names).
    """
    from control.mpc import QP_SOLVERS, SOLVERS
    from planning.errors import ConfigError
    from sim.cli.checks import check_once
    from sim.tools.bench.track import mpc_params

    solvers = [s.strip() for s in text.split(",") if s.strip()]
    check_once("--mpc-solvers", solvers)
    if not solvers:
        raise ConfigError(f"--mpc-solvers {text!r} names no solver; give e.g. --mpc-solvers rti,sqp:qrqp")
    for solver in solvers:
        try:
            mpc_params(solver)
        except ConfigError as exc:
            raise ConfigError(
                f"--mpc-solvers: {solver!r} is not an MPC solver; give SOLVER or SOLVER:QP, SOLVER one of "
                f"{', '.join(SOLVERS)} and QP one of {', '.join(QP_SOLVERS)}, e.g. --mpc-solvers rti,sqp:qrqp"
            ) from exc
    return solvers


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a tracker's 95th percentile exceeds the control period."""
    from sim.cli.checks import check_control_rate
    from sim.tools.bench.track import measure
    from sim.tools.compare import check_trackers

    check_control_rate(args.control_rate)  # named as the option (Case.control_rate was said)
    trackers = check_trackers(args.trackers.split(",")) if args.trackers is not None else None
    rows = measure(args.robot, args.reference, trackers, control_rate=args.control_rate,
                   mpc_solvers=mpc_solvers(args.mpc_solvers))  # fmt: skip
    period = 1e3 / args.control_rate
    print(f"robot {args.robot}, reference {args.reference}, control {args.control_rate:g} Hz ({period:.1f} ms), "
          "real robot's loop (physics, fused estimate)")  # fmt: skip
    print(f"{'tracker':<14}{'steps':>7}{'mean ms':>10}{'p95 ms':>10}{'max ms':>10}{'> period':>10}"
          f"{'solve p95 ms':>14}{'failures':>10}{'RMS [m]':>10}{'solve CPU p95 ms':>18}")  # fmt: skip
    for r in rows:
        solve = f"{r.solver['p95_ms']:.3f}" if "p95_ms" in r.solver else "-"
        fails = str(r.solver.get("failures", "-"))
        cpu = f"{r.solver['cpu_p95_ms']:.3f}" if "cpu_p95_ms" in r.solver else "-"
        print(f"{r.label:<14}{r.steps:>7d}{r.mean_ms:>10.3f}{r.p95_ms:>10.3f}{r.max_ms:>10.3f}{r.over:>10d}"
              f"{solve:>14}{fails:>10}{r.rms_m:>10.4f}{cpu:>18}")  # fmt: skip
    missed = [r.label for r in rows if not r.passed]
    print(f"target: 95th percentile of the control time within the period ({period:.1f} ms): "
          + ("met by every tracker" if not missed else f"MISSED by {', '.join(missed)}"))  # fmt: skip
    return 1 if missed else 0
