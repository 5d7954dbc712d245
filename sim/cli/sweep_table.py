"""``nhsim simulate --all``: the sweep's table, its closing summary and its JSON record."""

from __future__ import annotations

import argparse
from typing import Any

from planning.core.robot import ROBOTS
from planning.errors import ConfigError
from planning.planners.registry import PLANNERS
from sim.cli.checks import comma_list
from sim.pipeline.runs import RunKind
from sim.pipeline.sweep import Outcome, Stage, SweepRow

NAN = float("nan")
#: Widths of the robot and planner columns: the longest name of each ("edumip-balancing", "hybrid-a-star").
ROBOT_WIDTH = max(map(len, ROBOTS.built_in()))
PLANNER_WIDTH = max(map(len, PLANNERS))


def header() -> str:
    """Column titles of the table (closed loop | open loop) and the rule under them."""
    head = (
        f"{'scenario':<17} {'robot':<{ROBOT_WIDTH}} {'planner':<{PLANNER_WIDTH}} {'ok':>4} {'plan [s]':>8} "
        f"{'fin pos':>9} {'fin head':>9} {'rms pos':>8} {'coll':>4} {'warn':>4} | "
        f"{'OL fin':>9} {'OL rms':>8} {'coll':>4}"
    )
    return head + "\n" + "-" * len(head)


def format_row(row: SweepRow) -> str:
    """One line of the table."""
    head = f"{row.case.scenario_name:<17} {row.robot:<{ROBOT_WIDTH}} {row.case.planner:<{PLANNER_WIDTH}}"
    if row.stage is not Stage.TRACK:
        return f"{head} {row.outcome:>4}  {row.reason[:90]}"
    cl, ol = row.runs.get(RunKind.CLOSED_LOOP, {}), row.runs.get(RunKind.OPEN_LOOP, {})
    pt = row.plan_time_s if row.plan_time_s is not None else NAN
    return (
        f"{head} {row.outcome:>4} {pt:>8.2f} "
        f"{cl['final_position_error_m']:>9.4f} {cl['final_heading_error_rad']:>9.4f} "
        f"{cl['rms_position_error_m']:>8.4f} "
        f"{cl['collisions']:>4d} {cl['warnings']:>4d} | {ol.get('final_position_error_m', NAN):>9.4f} "
        f"{ol.get('rms_position_error_m', NAN):>8.4f} {ol.get('collisions', 0):>4d}"
    )


def summary(rows: list[SweepRow]) -> list[str]:
    """Closing lines: the count over applicable cases, every failure with its stage, and the cases
    that do not apply with their reasons."""
    na = [r for r in rows if r.outcome is Outcome.NA]
    applicable = [r for r in rows if r.outcome is not Outcome.NA]
    ok = sum(r.success for r in applicable)
    lines = [f"{ok}/{len(applicable)} applicable cases met every closed-loop target ({len(na)} not applicable)"]
    for r in applicable:
        if not r.success:
            status = f" [{r.plan_status}]" if r.stage is Stage.PLAN and r.plan_status is not None else ""
            lines.append(f"  FAIL {_where(r)} at {r.stage}{status}: {r.reason}")
    for r in na:
        lines.append(f"  n/a  {_where(r)}: {r.reason}")
    return lines


def _where(row: SweepRow) -> str:
    return f"{row.case.scenario_name}/{row.robot}/{row.case.planner}"


#: ``simulate`` options the sweep of ``--all`` takes (by dest; ``--no-video`` and ``--no-plots`` ask for what it does
#: anyway), see :func:`check_sweep_options`.
SWEEP_OPTIONS = frozenset(
    {"scenario", "robot", "planner", "all", "jobs", "scheduler", "time_limit", "gains", "control_rate", "seed", "json",
     "overwrite", "quiet", "no_video", "plots"}
)  # fmt: skip


def check_sweep_options(args: argparse.Namespace, defaults: dict[str, Any]) -> None:
    """Refuse the options ``--all`` would not use (each case runs the robot as built with seed 1, its own
    sensors and localiser, the default runs, no video and no plots: ``--plots`` too, its default), naming them:
    given and silently dropped, a ``--build-seed`` or a ``--perturb`` would read as a sweep it was not.

    Raises:
        ConfigError: An option away from its default that the sweep does not take.
    """
    unused = {d: v for d, v in defaults.items() if d not in SWEEP_OPTIONS}
    said = ["plots"] if args.plots and getattr(args, "plots_said", False) else []  # its default, but the sweep has none
    given = sorted([d for d, default in unused.items() if getattr(args, d, default) != default] + said)
    if given:
        flags, them = ", ".join("--" + d.replace("_", "-") for d in given), "it" if len(given) == 1 else "them"
        raise ConfigError(
            f"--all sweeps every case with the robot as built (build seed 1), its own sensors and localiser, the "
            f"default runs, no video and no plots; it does not take {flags}: drop {them}, or run one job without --all"
        )


def sweep_scenarios(text: str | None) -> list[str] | None:
    """``--scenario`` with ``--all``: comma-separated scenario names (built-in, ``random<N>`` or a file) the
    sweep is limited to; None for every built-in one.

    Raises:
        ScenarioError: A name that is not a scenario (the message lists the built-in ones).
        ConfigError: No name, or a name given twice.
    """
    if text is None:
        return None
    from planning.scenario import load_scenario

    names = comma_list(text)
    if not names:
        raise ConfigError("--scenario with --all: give one or more scenario names, comma-separated")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:  # each of its cases would run, and print its row, twice
        raise ConfigError(f"--scenario with --all names {', '.join(twice)} twice; give each scenario once")
    for name in names:
        load_scenario(name)
    return names


def sweep_settings(args: argparse.Namespace, gains: Any) -> dict[str, Any]:
    """What every case of the sweep ran with, for its record: the seed, the FBL gains (and the ``--gains``
    they came from, None for the defaults), the control rate and the planners' time limit."""
    import dataclasses

    return {
        "seed": args.seed,
        "gains": dataclasses.asdict(gains),
        "gains_from": args.gains,
        "control_rate_hz": args.control_rate,
        "time_limit_s": args.time_limit,
    }


def check_sweep_planner(planner: str, runs: list[str], names: list[str], given: bool) -> None:
    """``--all --planner P`` keeps P's cases of the sweep: refuse a P that has none, saying why (without the check
    the sweep ran no case and passed).

    Args:
        planner: ``--planner``.
        runs: The planners the sweep's cases run, sorted.
        names: The scenarios swept.
        given: Whether ``--scenario`` named them (else: every built-in scenario).

    Raises:
        ConfigError: A planner that applies to none of the swept scenarios
            (:func:`sim.pipeline.simulate.applicable_planners`: a plugin's planner applies only to a scenario that
            names it), naming those it does run and what to do.
    """
    from planning.core.plugins import BUILT_IN
    from planning.planners.registry import PLANNERS

    if planner in runs:
        return
    swept = ", ".join(names) if given else "the built-in scenarios"
    if PLANNERS.origin(planner) != BUILT_IN:
        why = (
            f"{planner} ({PLANNERS.origin(planner)}) is a plugin's planner, which --all runs only on a scenario that "
            f'names it (planner = "{planner}" in its file)'
        )
    else:
        why = (
            f"{planner} does not apply to {swept} (--all runs a scenario's own planner, the obstacle-avoiding ones, "
            "and the obstacle-free ones only where there are no obstacles)"
        )
    raise ConfigError(
        f"--all --planner {planner}: no case to run: {why}; it runs {', '.join(runs) or 'none'} there. Run {planner} "
        f"on one scenario without --all (nhsim simulate --scenario {names[0]} --planner {planner}), or sweep a "
        f"scenario file whose planner is {planner} (nhsim simulate --all --scenario FILE.toml)"
    )


def run_all(args: argparse.Namespace, gains: Any) -> int:
    """Run the sweep: print the table as rows come, the summary, and write the record with --json."""
    from planning.planners.registry import PLANNERS
    from planning.scenario import builtin_scenarios
    from sim.outputs import check_writable, write_json
    from sim.pipeline.case import PlanOptions
    from sim.pipeline.sweep import run_sweep, sweep_cases, sweep_passed, sweep_record
    from sim.tools.executor import make_executor, worker_count

    worker_count(args.jobs, args.scheduler, default=1)
    if args.planner is not None:
        PLANNERS.factory(args.planner)  # an unknown name: "unknown planner 'P': choose one of ...", as a job says
    if args.json is not None:
        from sim.cli.job_outputs import check_apart_from_inputs

        check_apart_from_inputs(args, [args.json])  # not over a scenario it reads, nor inside a bag
        check_writable(args.json, overwrite=args.overwrite)
    planning = PlanOptions(time_limit=args.time_limit)
    scenarios = sweep_scenarios(args.scenario)
    cases = sweep_cases(scenarios, seed=args.seed, gains=gains, control_rate=args.control_rate, planning=planning)
    if args.planner is not None:
        names = scenarios or builtin_scenarios()
        check_sweep_planner(args.planner, sorted({c.planner for c in cases if c.planner}), names, scenarios is not None)
    if args.robot is not None:
        listed = {c.robot for c in cases if c.robot is not None}
        cases = [c for c in cases if c.robot == args.robot]
        if not cases:  # the sweep ran nothing and passed
            raise ConfigError(
                f"--all --robot {args.robot}: no case to run: no scenario swept lists {args.robot} (they list "
                f"{', '.join(sorted(listed)) or 'none'}); choose one of those, or a scenario whose robots include it"
            )
    if args.planner is not None:
        cases = [c for c in cases if c.planner == args.planner]
    settings = sweep_settings(args, gains)
    with make_executor(args.jobs, args.scheduler, default=1) as executor:
        if executor.workers > 1 and not args.quiet:
            print(f"{len(cases)} cases on {executor.where} (rows print as they finish)", flush=True)
        if args.gains:  # every row ran with them: said before the rows, kept in the record's settings
            g = settings["gains"]
            print(f"gains Kp={g['kp']:g} Kd={g['kd']:g} xi_min={g['xi_min']:g} (--gains {args.gains}) on every case")
        print(header(), flush=True)
        show = lambda row: print(format_row(row), flush=True)
        rows = run_sweep(cases, progress=show, mapper=executor.map_unordered)
    print("\n".join(summary(rows)))  # part of the results: printed with --quiet too
    if args.json is not None:
        write_json(args.json, sweep_record(rows, settings), overwrite=args.overwrite)
        if not args.quiet:
            print(f"wrote {args.json}")
    return 0 if sweep_passed(rows) else 1
