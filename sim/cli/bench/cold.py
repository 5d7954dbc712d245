"""``nhsim bench cold``: ``nhsim plan`` in fresh processes on new seeded worlds against the same plans
warm (see :mod:`sim.tools.bench.cold`)."""

from __future__ import annotations

import argparse

#: Obstacle kinds but ellipses (a world without them reached numba's one-time set-up first inside the
#: plan, where an ellipse's reached it while the scenario loaded).
_NO_ELLIPSES = ("circle", "box", "polygon")
#: (name, arena side [m], obstacles, obstacle scale [m], time limit [s], obstacle kinds: None for all four)
#: of the worlds measured.
WORLDS = (
    ("room", 6.0, 8, 0.4, 30.0, None),
    ("hall", 8.0, 20, 0.35, 30.0, None),
    ("hall, no ellipses", 8.0, 20, 0.35, 30.0, _NO_ELLIPSES),
    ("crowded", 20.0, 2000, 0.08, 2.0, None),
)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--planner", default="hybrid-a-star", metavar="P", help="planner (default: hybrid-a-star)")
    p.add_argument("--worlds", type=int, default=2, metavar="N", help="new worlds of each kind (default: 2)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the first world (default: 0)")
    p.add_argument("--repeats", type=int, default=3, metavar="N", help="warm plans per world (default: 3)")
    p.add_argument("--no-crowded", action="store_true", help="skip the 2000-obstacle worlds")
    p.add_argument(
        "--obstacle-scale",
        type=float,
        default=1.0,
        metavar="F",
        help="obstacles F times their default size (default: 1; the halls' are about 0.35 m across)",
    )


def run(args: argparse.Namespace) -> int:
    """Measure and print one row per world as it is done; exit 1 when a target is missed."""
    from planning.core.checks import check_number
    from planning.errors import ConfigError
    from planning.planners.registry import PLANNERS
    from sim.cli.checks import check_at_least, check_seeds
    from sim.tools.bench import cold as bench

    if args.planner not in PLANNERS:
        raise ConfigError(f"--planner {args.planner!r} is not a planner; choose one of {', '.join(sorted(PLANNERS))}")
    check_at_least({"--worlds": (args.worlds, 1), "--repeats": (args.repeats, 1)})
    check_seeds(seed=args.seed)
    check_number("--obstacle-scale", args.obstacle_scale, above=0.0, at_most=4.0)
    print(
        f"{args.planner}: a fresh 'nhsim plan' process per new world (wall and CPU from start to exit, its reported "
        f"plan time, the part of it numba spent readying code (loading cached kernels; not counted by the time "
        f"limit; numba's one-time set-up comes before the plan's clock), the time less it, the grid's part, and "
        f"the path's simplification after the plan, reported beside its time, not in it) against the same plan "
        f"here: new world with code loaded, then warm (median of {args.repeats}); "
        + ("" if args.obstacle_scale == 1.0 else f"obstacles {args.obstacle_scale:g} times their default size; ")
        + bench.load_note()
    )
    bench.warm_up(args.planner)
    rows: list[bench.ColdRow] = []
    for name, size, count, scale, limit, kinds in WORLDS:
        if args.no_crowded and count > 20:
            continue
        for k in range(args.worlds):
            seed = args.seed + 1000 * len(rows) + k
            scale_f = scale * args.obstacle_scale
            rows.append(
                bench.measure(seed, size, count, scale_f, args.planner, limit, args.repeats, kinds or bench.KINDS)
            )
            lines = bench.format_rows(rows[-1:])
            if len(rows) == 1:
                print(lines[0], flush=True)
            print(f"{lines[1]}  ({name})", flush=True)
    print(bench.load_note())
    return 0 if bench.passed(rows) else 1
