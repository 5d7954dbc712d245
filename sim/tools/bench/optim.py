"""``nhsim bench optim``: the optimisation planner at the seed's resolution against the default.

Parallel park and navigation map 1 are each solved with N = 1000, dt = 0.01 (the seed's setting)
and with the planner's default N and dt (same horizon), repeatedly, after one untimed solve that
builds and caches each NLP. Printed per scenario: median wall time of ``plan()`` for each setting
and their ratio, the rolled-out final state's error against the goal for each, and the path lengths.
Targets: default >= 10x faster, its final position within 1 mm of the goal, its path length within
5 % of the seed setting's.
"""

from __future__ import annotations

import argparse
import statistics
import time

TARGET_SPEEDUP = 10.0
TARGET_FINAL_ERROR = 1e-3  # m
TARGET_LENGTH_REL = 0.05
SEED_N, SEED_DT = 1000, 0.01


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--repeats", type=int, default=5, help="timed solves per setting; medians (default: 5)")
    p.add_argument(
        "--scenarios", nargs="+", default=["parallel_park", "nav_map1"], metavar="NAME",
        help="scenarios to solve (default: parallel_park nav_map1)",
    )  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    from planning.errors import ConfigError
    from planning.planners.base import PlanProblem
    from planning.planners.optim import DEFAULT_DT, DEFAULT_N, Optim
    from planning.scenario import load_scenario

    if args.repeats < 1:
        raise ConfigError(f"--repeats must be >= 1, got {args.repeats}")
    print(f"optim: seed N={SEED_N}, dt={SEED_DT} against default N={DEFAULT_N}, dt={DEFAULT_DT}; "
          f"median of {args.repeats} solves after one warm-up")  # fmt: skip
    ok = True
    for name in args.scenarios:
        problem = PlanProblem.from_scenario(load_scenario(name))
        rows = {}
        for label, planner in (("seed", Optim(N=SEED_N, dt=SEED_DT)), ("default", Optim())):
            planner.plan(problem)  # builds and caches the NLP
            times, result = [], None
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                result = planner.plan(problem)
                times.append(time.perf_counter() - t0)
            assert result is not None
            rows[label] = (statistics.median(times), result)
        t_seed, r_seed = rows["seed"]
        t_def, r_def = rows["default"]
        speedup = t_seed / t_def
        len_rel = abs(r_def.length() / r_seed.length() - 1.0) if r_seed.length() > 0 else float("inf")
        print(f"\n{name}")
        print(f"  {'setting':<8} {'status':<10} {'median s':>9} {'iters':>6} {'final pos err m':>16} "
              f"{'final head err rad':>19} {'length m':>9}")  # fmt: skip
        for label, (t, r) in rows.items():
            print(f"  {label:<8} {r.status.value:<10} {t:>9.4f} {r.stats.get('iterations', -1):>6} "
                  f"{r.stats.get('final_position_error', float('nan')):>16.2e} "
                  f"{r.stats.get('final_heading_error', float('nan')):>19.2e} {r.length():>9.4f}")  # fmt: skip
        fin = float(r_def.stats.get("final_position_error", float("inf")))
        print(f"  speed-up {speedup:.1f}x (target >= {TARGET_SPEEDUP:g}x); default final position error "
              f"{fin * 1e3:.3g} mm (target <= {TARGET_FINAL_ERROR * 1e3:g} mm); length differs by "
              f"{100 * len_rel:.2f} % (target <= {100 * TARGET_LENGTH_REL:g} %)")  # fmt: skip
        ok &= (
            r_seed.success and r_def.success and speedup >= TARGET_SPEEDUP and fin <= TARGET_FINAL_ERROR
            and len_rel <= TARGET_LENGTH_REL
        )  # fmt: skip
    print(f"\n{'all targets met' if ok else 'a target was missed'}")
    return 0 if ok else 1
