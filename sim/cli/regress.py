"""``nhsim regress``: run the physics regression suite against its baselines."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

from sim.cli.job_outputs import add_executor_arguments

#: The repository's suite and baselines, the defaults of --suite and --baselines.
REPO_TESTS = Path(__file__).resolve().parents[2] / "tests"
SUITE_PATH = REPO_TESTS / "regression_suite.toml"
BASELINE_DIR = REPO_TESTS / "baselines"

DESCRIPTION = """\
Run the declared regression suite (tests/regression_suite.toml: scenarios x robots x references or
planners x trackers, seeded) and compare each case's metrics with its baseline in tests/baselines/.
Each case runs twice in one process and must be bitwise identical (determinism guard).

Every metric the baseline records is compared. Against a baseline recorded with the same mujoco, numpy
and platform every metric must be equal bit for bit; against one recorded elsewhere a number may get worse
by at most its tolerance (abs + rel * |baseline|, from the suite's [tolerances] or the built-in ones; 0 for
any other metric) and text (status) must be equal. A value that is not finite beside one fails. A table
lists every metric that moved.

By default the fast subset runs; --all runs every case, --case PATTERN the matching ones.
--update rewrites the baselines of the cases run (only when asked) and prints what changed.

Adding a case is one line in the suite's 'cases' array, e.g.
  { scenario = "open", robot = "edumip", reference = "circle", tracker = "fbl", seed = 0, control_rate = 50 },
  { scenario = "farm", robot = "turtlebot3", planner = "rrt", tracker = "fbl", seed = 1, control_rate = 50 },
then: nhsim regress --update --case <its name>.

A baseline records the case's definition too: a case whose fields (gains, build seed, sensors, ...) differ
from the ones its baseline was recorded with fails, naming them. A baseline file that is not one fails its
case (the others still run); --update replaces it.

Exit status: 0 every case passed (or --update wrote baselines), 1 a case regressed, differs from its
baseline's definition, has no baseline or an unreadable one, failed or is not deterministic, 2 bad input."""


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``regress`` subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        "regress",
        help="run the physics regression suite against its baselines",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--update", action="store_true", help="rewrite the baselines of the cases run; print what changed")
    p.add_argument("--all", action="store_true", help="run every case (default: the fast subset)")
    p.add_argument(
        "--case",
        action="append",
        default=None,
        metavar="PATTERN",
        help="run cases whose name matches PATTERN (shell wildcards; repeatable, or comma-separated)",
    )
    p.add_argument(
        "--suite",
        type=Path,
        default=None,
        metavar="TOML",
        help="suite file (default: tests/regression_suite.toml of nhsim's own checkout, wherever the command runs)",
    )
    p.add_argument(
        "--baselines",
        type=Path,
        default=None,
        metavar="DIR",
        help=(
            "baseline directory (default: 'baselines' beside the --suite file; without --suite, tests/baselines "
            "of nhsim's own checkout)"
        ),
    )
    p.add_argument("--list", action="store_true", help="list the selected cases and exit")
    add_executor_arguments(p, what="the cases", default_jobs="1")
    return p


def format_changes(changes: list[Any]) -> str:
    """The table of metrics that moved, its columns as wide as their longest case name, metric and value (two
    different numbers never shown alike: :func:`sim.tools.regress.show_values`)."""
    shown = [c.shown for c in changes]
    cw = max([len("case"), *(len(c.case) for c in changes)])
    mw = max([len("metric"), *(len(c.metric) for c in changes)])
    vw = max([13, *(len(v) for pair in shown for v in pair)])
    head = f"{'case':<{cw}} {'metric':<{mw}} {'baseline':>{vw}} {'now':>{vw}} {'delta':>11} {'allowed':>9}  status"
    lines = [head, "-" * len(head)]
    for c, (old, new) in zip(changes, shown, strict=True):
        delta = "-" if c.delta is None or not math.isfinite(c.delta) else f"{c.delta:+.3g}"
        row = f"{c.case:<{cw}} {c.metric:<{mw}} {old:>{vw}} {new:>{vw}} {delta:>11} {c.allowed:>9.3g}"
        lines.append(f"{row}  {c.status}")
    return "\n".join(lines)


def nothing_moved(outcomes: list[Any]) -> str:
    """What stands for the table when no metric moved: in how many cases metrics were compared at all."""
    compared = sum(o.compared for o in outcomes)
    if not compared:
        return f"no metric compared: none of the {len(outcomes)} case(s) has a baseline it was compared with"
    rest = len(outcomes) - compared
    return f"no metric moved in the {compared} case(s) compared" + (f"; {rest} not compared" if rest else "")


def run(args: argparse.Namespace) -> int:
    """Execute ``regress``."""
    from planning.errors import ConfigError
    from sim.tools.executor import make_executor, worker_count
    from sim.tools.regress import Status, check_task, load_suite

    worker_count(args.jobs, args.scheduler, default=1)  # with --list too: one meaning for every option
    if args.list and args.update:  # --list runs nothing: the update was dropped without a word
        raise ConfigError("--list lists the cases and runs none, so --update would rewrite nothing: drop one of them")
    suite = load_suite(args.suite or SUITE_PATH)
    baselines: Path = args.baselines or (args.suite.parent / "baselines" if args.suite else BASELINE_DIR)
    patterns = [p.strip() for arg in (args.case or []) for p in arg.split(",") if p.strip()]
    if args.case is not None and not patterns:
        raise ConfigError("--case needs a pattern (a case name or shell wildcards, e.g. 'open-*'); see --list")
    cases = suite.select(patterns, all_cases=args.all)
    if args.list:
        for c in cases:
            print(f"{c.name}{'  (fast)' if c.fast else ''}")
        return 0
    try:
        read = check_baselines(baselines, cases, update=args.update, reads=suite.reads)
    except ConfigError as exc:
        raise ConfigError(_with_files(str(exc), args)) from None
    tty = sys.stderr.isatty()
    done = {}
    with make_executor(args.jobs, args.scheduler, default=1) as executor:
        for case, outcome in executor.map_unordered(check_task, cases, shared=(baselines, suite.tolerances, read)):
            done[case.name] = outcome
            if tty:
                print(f"\r[{len(done)}/{len(cases)}] {case.name:<60}", end="", file=sys.stderr, flush=True)
    if tty:
        print("\r" + " " * 72 + "\r", end="", file=sys.stderr)
    outcomes = [done[c.name] for c in cases]

    moved = [c for o in outcomes for c in o.changes]
    print(format_changes(moved) if moved else nothing_moved(outcomes))
    print()
    for o in outcomes:
        print(f"{o.status.upper():<16} {o.case.name}" + (f" ({o.summary})" if o.summary else ""))

    if args.update:
        written = update_baselines(outcomes, read)
        print(f"{written} baseline(s) written, {len(outcomes) - written} unchanged or not run")
        bad = [o for o in outcomes if o.status in (Status.ERROR, Status.NONDETERMINISTIC)]
        for o in bad:
            print(f"nhsim regress: {o.status}: {o.message}", file=sys.stderr)
        return 1 if bad else 0

    failed = [o for o in outcomes if not o.ok]
    passed = sum(o.ok for o in outcomes)
    print(f"\n{passed} passed, {len(failed)} failed of {len(outcomes)} case(s)")
    for o in failed:
        print(f"nhsim regress: {o.status}: {_with_files(o.message, args)}", file=sys.stderr)
    _say_orphans(baselines, suite)
    return 1 if failed else 0


def _say_orphans(baselines: Path, suite: Any) -> None:
    """Say on stderr which baselines of the folder no case of the suite names (a case renamed or removed left
    its baseline behind, unread, and nothing said so); they are kept: the suite's owner deletes them."""
    named = {f"{c.name}.json".casefold() for c in suite.cases}
    try:
        orphans = sorted(p.name for p in baselines.glob("*.json") if p.name.casefold() not in named)
    except OSError:
        return
    if orphans:
        shown = ", ".join(orphans[:5]) + (f" and {len(orphans) - 5} more" if len(orphans) > 5 else "")
        print(
            f"nhsim regress: note: {baselines} holds {len(orphans)} baseline(s) no case of the suite names: {shown} (a "
            "renamed or removed case's, never read: delete them, or name the case again)",
            file=sys.stderr,
        )


def _with_files(message: str, args: argparse.Namespace) -> str:
    """A message's ``nhsim regress --update`` hint with the --suite and --baselines this run was given, so
    that following it records where this run reads (without them it wrote the repository's baselines)."""
    given = [f"--{name} {value}" for name, value in (("suite", args.suite), ("baselines", args.baselines)) if value]
    return message.replace("nhsim regress --update", " ".join(["nhsim regress --update", *given]))


def check_baselines(
    baselines: Path, cases: list[Any], *, update: bool, reads: tuple[tuple[str, Path], ...] = ()
) -> dict[str, Any]:
    """Before any case runs: the baselines folder exists and is a folder (to compare), or its baselines
    can be written there (``--update``), none over a file the suite reads (``reads``: the suite's
    :attr:`~sim.tools.regress.Suite.reads`, and the map files of its scenario files); returns the cases'
    baselines as read (:func:`read_baselines`), here, so that no run reads a file and an unreadable one is its
    case's failure, not the run's.

    Raises:
        ConfigError: Naming the folder (or the baseline and the input) and the fix.
    """
    from planning.errors import ConfigError
    from sim.cli.job_outputs import refuse_inside_a_bag, scenario_inputs
    from sim.outputs import check_writable, resolved
    from sim.tools.regress import baseline_path, read_baselines

    if baselines.exists() and not baselines.is_dir():
        raise ConfigError(f"--baselines {baselines} is a file, not a folder; give the folder that holds the baselines")
    if update:
        inputs = [found for what, path in reads for found in _read_files(what, path, scenario_inputs)]
        for case in cases:
            path = baseline_path(case, baselines)
            if path.is_dir():  # the file's name is the case's: the folder must go
                raise ConfigError(f"case {case.name}'s baseline {path} is a folder; move or remove it, then update")
            refuse_inside_a_bag(path, resolved(path))  # a bag holds its own files only, as for every output
            for what, source in inputs:  # a gains file named <case>.json in the folder was replaced, exit 0
                if resolved(path) == resolved(source):
                    raise ConfigError(
                        f"case {case.name}'s baseline {path} is {what}, which the suite reads: --update would replace "
                        "it; give another --baselines folder (or move the file)"
                    )
            check_writable(path, overwrite=True)
    elif not baselines.exists():
        raise ConfigError(
            f"the baselines folder {baselines} does not exist (--baselines, by default the folder baselines beside the "
            "suite file); give the folder that holds the baselines, or record them there with nhsim regress --update"
            # with this run's --suite and --baselines (run: _with_files)
        )
    return read_baselines(cases, baselines)


def _read_files(what: str, path: Path, scenario_inputs: Any) -> list[tuple[str, Path]]:
    """A file the suite reads, with the map files a scenario file reads besides it."""
    if "scenario file" not in what:
        return [(what, path)]
    return [(what, path), *scenario_inputs(what, str(path))[1:]]


def update_baselines(outcomes: list[Any], read: dict[str, Any]) -> int:
    """Rewrite the baselines of the cases measured whose document changed (``read``: the baselines as read
    before the runs, by case name), as one set (:func:`sim.outputs.staged_outputs`: all moved into place
    once all are written, or none), printing what changed; returns how many were written.

    Raises:
        OutputsNotPlacedError: A baseline could not be moved into place (every old baseline is kept).
    """
    from sim.outputs import json_safe, staged_outputs, write_json
    from sim.tools.regress import baseline_document, baseline_problem

    said: list[str] = []
    with staged_outputs(overwrite=True) as stage:
        for o in outcomes:
            if not o.metrics:
                continue
            old, doc = read[o.case.name], json_safe(baseline_document(o.case, dict(o.metrics)))  # as written
            if old.document == doc:
                continue
            write_json(stage.path(old.path), doc)
            problem = baseline_problem(old, o.metrics)  # not a baseline, or one without a metric the run measured
            if problem:
                said.append(f"replaced unreadable baseline {old.path} ({problem})")
            elif old.document is None:
                said.append(f"new baseline {old.path}")
            else:
                what = baseline_changes(old.document, o, doc)
                said.append(f"updated {old.path}: " + ("; ".join(what) or "rewritten, no value changed"))
    for line in said:
        print(line)
    return len(said)


def baseline_changes(old: dict[str, Any], outcome: Any, new: dict[str, Any]) -> list[str]:
    """What an update changes in a baseline (``new``: the document written): the metrics that moved, those it no
    longer records, the environment, the case's fields that differ from the ones recorded, the fields recorded
    now that the old baseline left out, and the ones it held that the new one drops."""
    from sim.tools.regress import definition_changes, environment, model_change, show_values

    metrics = new["metrics"]
    moved = [k for k, v in metrics.items() if k not in old["metrics"] or old["metrics"][k] != v]
    what = [f"{k} {' -> '.join(show_values(old['metrics'].get(k), metrics[k]))}" for k in moved]
    gone = [f"{k} ({show_values(v, None)[0]})" for k, v in old["metrics"].items() if k not in metrics]
    if gone:
        what.append(f"no longer records metric(s) {', '.join(gone)}")
    if old.get("environment") != environment():
        what.append(f"environment {old.get('environment')} -> {environment()}")
    recorded = old.get("case", {})
    differs = definition_changes(recorded, outcome.case)
    if differs:
        what.append(f"case {', '.join(differs)}")
    added = [f"{k} = {json.dumps(v)}" for k, v in new["case"].items() if k not in recorded]
    model = model_change(old.get("model"), outcome.case)
    if model:
        what.append(model)
    elif "model" not in old:  # recorded before baselines named their robot's files
        added.append(f"model = {json.dumps(new['model'])}")
    if added:
        what.append(f"now records {', '.join(added)}")
    dropped = [f"case field {k}" for k in recorded if k not in new["case"]]
    dropped += [f"field {k}" for k in old if k not in new]
    if dropped:
        what.append(f"removed {', '.join(dropped)}")
    return what
