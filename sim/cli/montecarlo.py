"""``nhsim montecarlo``: one case on many as-built robots and noise draws, on every core or a cluster."""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shlex
import shutil
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NoReturn

from planning.core.files import is_pipe
from planning.errors import ConfigError, OutputExistsError
from sim.cli.job_outputs import (
    DEFAULT_DIR,
    RUN_SETTINGS,
    add_case_arguments,
    add_executor_arguments,
    check_apart_from_inputs,
    input_paths,
)
from sim.cli.simulate import add_feedback_argument, add_localiser_arguments
from sim.cli.trajectory_files import add_file_arguments, file_options

DESCRIPTION = """\
Run one case N times, each run on its own as-built robot (--build-seed drawn per run), its own sensor
noise and, with --perturb-range, its own perturbation drawn from the ranges; the plan is made once
from --seed (or per run with --replan). Every run drives the three run kinds (fused feedback, odometry
feedback, open loop). Printed and recorded per run kind: the 50/90/99th percentiles of the final
position and heading error and of the RMS and max position error, the success rate against the
scenario's goal tolerance (a reference: the path targets of 'simulate'), the collision rate, and the
worst runs with the 'nhsim simulate' command that replays each one bit for bit.

Runs execute on Dask distributed: --jobs J starts J local worker processes (default: one per core;
--jobs 1 runs in this process), --scheduler tcp://host:8786 uses a running cluster. Each finished run
is appended to the results file (JSON lines, keyed by its seeds) at once: the same command run again
skips what is done, so a killed study resumed ends with the statistics of an uninterrupted one. A
results file of another study is refused, naming what differs.

Outputs (renders/<scenario>-<source>[-<robot>]-mc-<6 hex of the study>.*): .jsonl the runs, .json the
statistics, -fan.png every run's path per run kind, -cdf.png the CDF of the final error. A study
rewrites its own summary and plots; any other existing file is kept unless --overwrite is given.
--bags DIR replays the worst closed-loop runs (bit for bit) and writes each as a ROS 2 bag DIR/worst-<index>.

Exit status: 0 the study finished, 1 a run failed to run (not a missed target: those are statistics),
2 bad input, 130 interrupted (finished runs are kept)."""


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``montecarlo`` subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        "montecarlo",
        help="run one case on many as-built robots and noise draws; percentiles, rates, worst runs",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_case_arguments(p)
    p.add_argument("--runs", type=int, required=True, metavar="N", help="number of runs (>= 1)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the plan and of the draws (default: 0)")
    p.add_argument(
        "--perturb-range",
        default=None,
        metavar="K=LO:HI,...",
        help="draw each run's perturbation uniformly from these ranges (friction, mass, radius, noise, "
        "heading_noise, latency; keys left out stay nominal; K=V without a range holds V for every run), e.g. "
        "radius=0.97:1.03,latency=0:0.02",
    )
    p.add_argument("--replan", action="store_true", help="plan each run anew with its own seed")
    p.add_argument(
        "--time-limit",
        type=float,
        default=RUN_SETTINGS["time_limit"],
        metavar="S",
        help="planning budget (default: 30 s)",
    )
    p.add_argument("--build", choices=["as-built", "nominal"], default="as-built", help="draw each run's robot as "
                   "built (default) or drive the robot as drawn every time")  # fmt: skip
    add_feedback_argument(p)
    p.add_argument(
        "--gains", default=None, metavar="KP,KD|FILE", help="the FBL's gains (fbl, segmented) (default: 9,6)"
    )
    p.add_argument("--sensors", default=None, metavar="KEY=VALUE,...|FILE", help="sensor profile overrides")
    p.add_argument("--control-rate", type=float, default=50.0, metavar="HZ", help="tracker rate (default: 50)")
    add_localiser_arguments(p)
    add_executor_arguments(p, what="the runs", default_jobs="one per core")
    add_file_arguments(p)
    p.add_argument(
        "--results",
        type=Path,
        default=None,
        metavar="PATH",
        help="results file (JSON lines; default: renders/<scenario>-<source>[-<robot>]-mc-<study>.jsonl)",
    )
    p.add_argument(
        "--json",
        type=Path,
        default=None,
        metavar="PATH",
        help="statistics record, the plots beside it as <name>-fan.png and <name>-cdf.png (default: the results "
        "file's path with .json)",
    )
    p.add_argument(
        "--bags",
        type=Path,
        default=None,
        metavar="DIR",
        help="write the worst closed-loop runs as ROS 2 "
        "bags DIR/worst-<index> (replayed after the study; default: none)",
    )
    p.add_argument("--plots", action=argparse.BooleanOptionalAction, default=True, help="write the plots (default: on)")
    p.add_argument("--overwrite", action="store_true", help="replace existing outputs of another study")
    p.add_argument("--quiet", action="store_true", help="print only the table and the worst runs' replay commands")
    p.add_argument("--gl", choices=["osmesa", "egl", "glfw"], default=None, help=argparse.SUPPRESS)
    return p


def _spec(args: argparse.Namespace) -> Any:
    from control.fbl import uses_fbl_gains
    from control.gains import FBLGains, resolve_gains
    from sim.cli.checks import check_control_rate, check_seeds, check_time_limit
    from sim.cli.simulate import (
        check_scan_beams,
        feedback_option,
        job_source,
        localiser_fields,
        parse_build,
    )
    from sim.cli.trajectory_files import check_file_options, file_given, file_source, file_world
    from sim.physics.perturb import PerturbationRange
    from sim.pipeline.case import Case, PlanOptions, load_case_scenario
    from sim.pipeline.runs import DEFAULT_RUNS
    from sim.pipeline.sensor_settings import sensor_overrides
    from sim.tools.montecarlo import MonteCarloSpec

    check_file_options(args)
    check_time_limit(args.time_limit)
    check_seeds(seed=args.seed)
    check_control_rate(args.control_rate)
    fields = {
        "seed": args.seed,
        "control_rate": args.control_rate,
        "tracker": feedback_option(args.feedback, "the open loop is a run of every study already (open_loop)"),
        "gains": resolve_gains(args.gains) if args.gains else FBLGains(),
        "planning": PlanOptions(time_limit=args.time_limit),
        "build_seed": parse_build(args.build, None),
        "sensors": sensor_overrides(args.sensors),
        **localiser_fields(args),
    }
    tracker = fields["tracker"]  # None: the source's default, an FBL
    if args.gains and tracker is not None and not uses_fbl_gains(tracker):  # a study of gains that change nothing
        raise ConfigError(
            f"--gains: tracker {tracker} does not use the FBL's gains; drop --gains (its own parameters are compared "
            "by nhsim compare --params)"
        )
    if file_given(args):  # a trajectory or path file, read and checked as simulate reads it
        tfile = file_source(args)
        world, robot, _ = file_world(args, tfile)
        case = Case(world, robot=robot, trajectory_file=tfile, **fields)
    else:
        scenario, source = job_source(args.scenario, args.planner, args.reference)
        planner, reference = source.get("planner"), source.get("reference")
        case = Case(scenario, robot=args.robot, planner=planner, reference=reference, **fields)
    if case.reference is not None or case.trajectory_file is not None:  # a plan option would only change the key
        given = [
            opt
            for opt, on in (("--time-limit", args.time_limit != RUN_SETTINGS["time_limit"]), ("--replan", args.replan))
            if on
        ]
        if given:
            raise ConfigError(
                f"{', '.join(given)} {'is' if len(given) == 1 else 'are'} for a planned study, and this one plans "
                "nothing (a reference or a file): drop it"
            )
    loaded = load_case_scenario(case)
    case.sensing(loaded)  # --sensors KEY=VALUE's values, read by each run: refused here, not in every worker
    check_scan_beams(case, loaded, DEFAULT_RUNS)  # its closed loop localises, as simulate's
    ranges = PerturbationRange.parse(args.perturb_range, others="nominal") if args.perturb_range else None
    return MonteCarloSpec(case, args.runs, ranges, replan=args.replan)


def _paths(args: argparse.Namespace, spec: Any, scenario: str) -> dict[str, Path]:
    """The study's outputs; by default named by its key, or by a key an earlier nhsim gave the same study
    (:meth:`MonteCarloSpec.earlier_keys`) when only that one's results file exists (resumed where it is)."""
    from sim.cli.job_outputs import file_safe

    key, robot, own_robot = spec.key(), spec.defaults["robot"], spec.defaults["own_robot"]
    source = Path(key["source"].split(":", 1)[1]).stem or "default"  # a file's stem, not its path
    start = f"{file_safe(scenario)}-{file_safe(source)}" + (f"-{robot}" if robot != own_robot else "") + "-mc-"
    stems = [
        start + hashlib.sha1(json.dumps(k, sort_keys=True).encode()).hexdigest()[:6]
        for k in (key, *spec.earlier_keys())
    ]
    stem = next((s for s in stems if (DEFAULT_DIR / f"{s}.jsonl").exists()), stems[0])
    results = args.results or DEFAULT_DIR / f"{stem}.jsonl"
    out = {"results": results, "json": args.json or _summary_beside(results)}
    if args.plots:
        base = out["json"]
        out.update({name: base.with_name(f"{base.stem}-{name}.png") for name in ("fan", "cdf")})
    return out


def _summary_beside(results: Path) -> Path:
    """The summary's default path: the results file's with ``.json`` (``-summary.json`` for a ``.json`` one), so
    that a study given its own ``--results`` keeps its summary and plots beside it, not over the default study's."""
    if results.suffix == ".json":
        return results.with_name(f"{results.stem}-summary.json")
    return results.with_suffix(".json")


def _check_outputs(paths: dict[str, Path], keys: list[dict[str, Any]], overwrite: bool) -> None:
    """Every output can be written; existing ones must be this study's own: its summary names one of its
    ``keys`` (the key, or one an earlier nhsim gave it) and this results file (the same study's statistics of
    another results file are another run's outputs)."""
    from sim.outputs import check_distinct, check_writable, resolved

    named = {"results": "--results", "json": "--json (the summary)", "fan": "the fan plot", "cdf": "the CDF plot"}
    check_distinct({named.get(kind, kind): path for kind, path in paths.items()})
    summary = paths["json"]
    own = False
    if summary.is_file():  # a device or a pipe is not read (/dev/full gave bytes until memory ran out): refused below
        try:
            doc = json.loads(summary.read_text(encoding="utf-8"))
            own = doc.get("key") in keys and resolved(doc.get("results")) == resolved(paths["results"])
        except (OSError, ValueError, AttributeError, TypeError):  # a loop of links (ConfigError): not its own
            own = False
    for name, path in paths.items():
        if name == "results":
            check_writable(path, overwrite=True)  # its key is checked when it is opened
            continue
        try:
            check_writable(path, overwrite=overwrite or own)
        except OutputExistsError as exc:
            raise OutputExistsError(f"{exc} (it is not this study's output)") from exc


def format_table(stats: dict[str, Any]) -> str:
    """One row per run kind: runs, success and collision rates, percentiles of the errors."""
    head = (
        f"{'run':<21} {'runs':>5} {'success':>8} {'collide':>8}  {'final pos p50/p90/p99 [m]':>27}  "
        f"{'final head p50/p90/p99 [rad]':>28}  {'rms pos p50/p90/p99 [m]':>25}  {'max p99 [m]':>11}"
    )
    lines = [head, "-" * len(head)]
    for kind, s in stats.items():
        if not isinstance(s, dict) or "runs" not in s:
            continue

        def trio(name: str, s: dict[str, Any] = s) -> str:
            v = s[name]
            return f"{v['p50']:.4f}/{v['p90']:.4f}/{v['p99']:.4f}"

        lines.append(
            f"{kind:<21} {s['runs']:>5d} {s['success_rate']:>8.1%} {s['collision_rate']:>8.1%}  "
            f"{trio('final_position_error_m'):>27}  {trio('final_heading_error_rad'):>28}  "
            f"{trio('rms_position_error_m'):>25}  {s['max_position_error_m']['p99']:>11.4f}"
        )
    for kind, s in stats.items():
        ended = s.get("ended_early") if isinstance(s, dict) else None
        if ended:  # a run that stopped (the estimator diverged, the robot fell) has errors of where it stopped
            causes = ", ".join(f"{why}: {count}" for why, count in ended.items())
            lines.append(
                f"{kind}: {sum(ended.values())} of {s['runs']} runs ended early ({causes}); their errors above are "
                "where they stopped, not at the trajectory's end"
            )
    return "\n".join(lines)


def _replay_line(argv_base: list[str], worst: dict[str, Any]) -> str:
    """The command that replays run ``worst``; with the plugins this process was given by NHSIM_PLUGINS (a plugin's
    planner or tracker, whose code the study's key digests), as the variable's assignment before it."""
    from planning.core.plugins import PLUGIN_VARIABLE
    from sim.tools.montecarlo import replay_options

    plugins = os.environ.get(PLUGIN_VARIABLE, "").strip()
    env = [f"{PLUGIN_VARIABLE}={shlex.quote(plugins)}"] if plugins else []
    cmd = ["nhsim", "simulate", *argv_base, *replay_options(worst), "--no-video"]
    return " ".join([*env, *(shlex.quote(c) for c in cmd)])


def _pipe_notes(args: argparse.Namespace) -> list[str]:
    """Notes for the replay commands' options that name a pipe (bash's ``<(...)``): read once, gone after this
    command, so a replay must be given the content as a file."""
    named = [(opt, getattr(args, opt.removeprefix("--").replace("-", "_"), None)) for opt in _FILE_OPTIONS]
    return [
        f"{opt} {value} was a pipe, read once: to replay a run, save what it gave to a file and give that file's "
        f"path in place of {value}"
        for opt, value in named
        if isinstance(value, str) and is_pipe(value)
    ]


#: The options of a replay command that may name a file.
_FILE_OPTIONS = ("--scenario", "--gains", "--sensors", "--trajectory", "--path")


def _gains_text(given: str | None, gains: Any) -> str | None:
    """``--gains`` for the replay commands: the study's gains as numbers (a gains file may be rewritten after the
    study, by a resumed tune for one, and the replay would run other gains), the file where they cannot say it
    all (a guard other than the default)."""
    from control.gains import FBLGains

    if given is None or gains is None or gains.xi_min != FBLGains().xi_min:
        return given
    return f"{gains.kp!r},{gains.kd!r}"


def _base_argv(args: argparse.Namespace, case: Any) -> list[str]:
    """The ``simulate`` options of the study's case (the seeds are per run)."""
    if case.trajectory_file is not None:  # the file's own options; its world is --scenario's or an arena
        argv = ["--scenario", args.scenario] if args.scenario is not None else []
        argv += file_options(args)
    else:
        argv = ["--scenario", str(case.scenario)]
        argv += ["--reference", case.reference] if case.reference is not None else ["--planner", str(case.planner)]
    if args.robot:
        argv += ["--robot", args.robot]
    for opt, value, default in (
        ("--time-limit", args.time_limit, RUN_SETTINGS["time_limit"]),
        ("--feedback", args.feedback, None),
        ("--gains", _gains_text(args.gains, case.gains), None),
        ("--sensors", args.sensors, None),
        ("--control-rate", args.control_rate, 50.0),
        ("--localiser", args.localiser, None),
        ("--lidar", args.lidar, None),
        ("--amcl", args.amcl, None),
        ("--initial-pose", args.initial_pose, "known"),
    ):
        if value != default:
            argv += [opt, str(value)]
    return argv


def run(args: argparse.Namespace) -> int:
    """Execute ``montecarlo``."""
    from sim.viz import gl

    gl.configure(args.gl)
    from sim.pipeline.case import load_case_scenario
    from sim.tools.executor import make_executor, worker_count
    from sim.tools.montecarlo import ResultsFile, check_study, run_montecarlo

    worker_count(args.jobs, args.scheduler)
    spec = _spec(args)
    scenario = load_case_scenario(spec.case)  # unknown scenario, a robot it does not list: stop here
    paths = _paths(args, spec, scenario.name)
    if not args.overwrite:  # another study's runs: what differs, said before its summary is refused as not ours
        try:
            check_study(paths["results"], spec.key(), spec.earlier_keys())
        except ConfigError as exc:
            _refuse_kept(exc, paths["results"])
    _check_outputs(paths, [spec.key(), *spec.earlier_keys()], args.overwrite)
    check_apart_from_inputs(args, paths.values())
    if args.bags is not None:
        _check_bags(args.bags, args.overwrite, input_paths(args), paths)
    try:
        results = ResultsFile(paths["results"], spec.key(), spec.earlier_keys(), seeds=spec.record_seeds)
    except ConfigError as exc:
        if not args.overwrite:  # another study's runs, or not a results file: kept
            _refuse_kept(exc, paths["results"])
        # the other study's runs, summary and plots kept until this one is written (its runs in NAME.partial)
        results = ResultsFile(paths["results"], spec.key(), replacing=True, seeds=spec.record_seeds)
    for note in results.notes:
        print(f"note: {note}", file=sys.stderr)
    if not args.quiet and results.records:
        print(f"resuming: {len(results.records)} runs done in {results.file}")
    kept = f"the finished runs are kept in {results.file}, and the same command resumes"
    with _bar(args, spec.runs) as bar, make_executor(args.jobs, args.scheduler, notify=bar.say, kept=kept) as executor:
        if not args.quiet:
            what = f"{scenario.name} | {scenario.robot} | {spec.key()['source']}"
            print(f"{spec.runs} runs of {what} on {executor.where}")
        result = run_montecarlo(spec, executor, results, progress=bar)
    stats = result.stats
    print(format_table(stats))
    base = _base_argv(args, spec.case)
    closed = stats.get("closed_loop", {})
    for worst in closed.get("worst", []):
        err = worst["final_position_error_m"]
        print(f"worst closed loop #{worst['index']} ({err:.4f} m): {_replay_line(base, worst)}")
    for line in _pipe_notes(args) if closed.get("worst") else []:
        print(f"nhsim montecarlo: {line}", file=sys.stderr)
    if result.retries:
        print(f"{result.retries} runs were run again after their worker died")
    record = {"key": spec.key(), "runs": spec.runs, "ran_now": result.ran, "retries": result.retries}
    record.update(statistics=stats, results=str(paths["results"]), replay_base=base)
    _write(result, paths, record, args, results)
    bags = _worst_bags(result, args.bags, args.overwrite) if args.bags is not None else []
    if not args.quiet:
        for bag in bags:
            print(f"wrote {bag}")
        for name, path in paths.items():
            if name != "results":
                print(f"wrote {path}")
            elif result.ran:  # the runs' results, appended one by one as they finished
                print(f"wrote {path} ({result.ran} run{'s' * (result.ran > 1)} appended)")
    return 0


def _refuse_kept(exc: ConfigError, results: Path) -> NoReturn:
    """Raise ``exc``, the refusal of a results file kept without ``--overwrite`` (another study's, or no results
    file), naming the runs of a study that replaces it when they wait in its partial sibling (this command's runs
    of an earlier ``--overwrite``, interrupted)."""
    from sim.tools.montecarlo import partial_path

    waiting = partial_path(results)
    if waiting.exists():
        raise ConfigError(f"{exc} (runs of a study that replaces it wait in {waiting})") from exc
    raise exc


def _write(result: Any, paths: dict[str, Path], record: dict[str, Any], args: argparse.Namespace, results: Any) -> None:
    """The record and the plots, as one set (:func:`sim.outputs.staged_outputs`: moved into place together, or
    none of them); each target was checked before the study: absent, this study's, or ``--overwrite``. A study that
    replaces another's results file moves its runs (``results.file``, the partial sibling) over it in the same set."""
    import shutil

    from sim.outputs import staged_outputs, write_json
    from sim.viz.plots.draw import save_figure
    from sim.viz.plots.montecarlo import montecarlo_figures

    with staged_outputs(overwrite=True) as stage:
        if results.replacing:  # copied in (an interrupt of the set leaves the partial runs to resume from)
            shutil.copyfile(results.file, stage.path(paths["results"]))
        if args.plots:
            prep = result.prepared
            title = f"{prep.scenario.name} | {prep.robot.name} | {prep.source} | {result.spec.runs} runs"
            figures = montecarlo_figures(prep.scenario.world, prep.trajectory, result.records, title=title)
            for name, fig in figures.items():
                save_figure(fig, stage.path(paths[name]))
        write_json(stage.path(paths["json"]), record)
    if results.replacing:
        results.file.unlink()  # in place now, as this study's results file


def _check_bags(folder: Path, overwrite: bool, inputs: list[tuple[str, Path]], outputs: Mapping[str, Path]) -> None:
    """Before any run: ``--bags`` names a folder that can take new bags, not one of the study's own ``outputs``
    (by kind: the results, the summary, its plots), not an input, inside one or holding one where a bag may go
    (``worst-*``), not among the files every run reads, and one holding bags of an earlier study only with
    ``--overwrite`` (which bags the worst runs will be is known only after)."""
    from sim.io.bag import check_bag_length
    from sim.outputs import check_folder_for, check_not_read_by_runs, resolved

    check_bag_length(folder / "worst-99999")  # the longest a bag of the folder is named: a folder name too long
    if folder.exists() and not folder.is_dir():
        raise ConfigError(f"--bags {folder}: a file of that name exists; give a folder")
    check_not_read_by_runs(folder)
    here = resolved(folder)
    for kind, out in outputs.items():  # beside them is fine: the bags go in DIR/worst-<index>
        target = resolved(out)
        if target == here or _where_bags_go(here, target):
            what = {"json": "summary", "fan": "fan plot", "cdf": "CDF plot"}.get(kind, kind)
            where = "share a path (the bags go in a folder of that name)" if target == here else "meet where a bag goes"
            raise ConfigError(f"--bags {folder} and the study's {what} {out} {where}; choose another --bags folder")
    for given, path in inputs:
        source = resolved(path)
        inside = _where_bags_go(here, source)
        if source == here or source in here.parents or inside:
            raise ConfigError(
                f"--bags {folder} {'holds' if inside else 'is or lies inside'} the input {given}: the bags written "
                "there would replace or change what the study reads; choose another --bags folder"
            )
    earlier = sorted(p.name for p in _earlier_bags(folder))
    if earlier and not overwrite:
        raise OutputExistsError(
            f"--bags {folder} holds bags already ({', '.join(earlier[:3])}{', ...' if len(earlier) > 3 else ''}); "
            "pass --overwrite to replace them, or choose another --bags folder"
        )
    check_folder_for(folder / "worst-0")


def _where_bags_go(folder: Path, path: Path) -> bool:
    """Whether ``path`` lies in a ``worst-*`` folder of the (resolved) bags ``folder``, where a bag is written."""
    return folder in path.parents and path.relative_to(folder).parts[0].startswith("worst-")


def _worst_bags(result: Any, folder: Path, overwrite: bool) -> list[Path]:
    """Replay the worst closed-loop runs of a study (the runs its table names) and write each as a bag."""
    from dataclasses import replace

    from sim.io.bag import write_job_bag
    from sim.pipeline.case import prepare_trajectory
    from sim.pipeline.runs import DEFAULT_RUNS
    from sim.pipeline.simulate import track

    spec, draws, out = result.spec, result.spec.draws(), []
    earlier = _earlier_bags(folder)
    for worst in result.stats.get("closed_loop", {}).get("worst", []):
        case = spec.case_of(draws[worst["index"]])
        prep = prepare_trajectory(case) if spec.replan else replace(result.prepared, case=case)
        job = track(prep, DEFAULT_RUNS, strict=False)
        out.append(write_job_bag(job, folder / f"worst-{worst['index']}", overwrite=overwrite).path)
    for stale in set(earlier) - {path.resolve() for path in out}:  # an earlier study's worst runs, not this one's
        shutil.rmtree(stale)
    return out


def _earlier_bags(folder: Path) -> list[Path]:
    """The bags nhsim wrote in ``folder`` as a study's worst runs (``worst-<index>`` folders; other files kept)."""
    from sim.io.bag import not_ours

    found = folder.glob("worst-*") if folder.is_dir() else []
    return sorted(p.resolve() for p in found if p.is_dir() and not p.is_symlink() and not not_ours(p))


class _bar:
    """A progress bar of runs done (on a terminal, without --quiet), drawn from the first count (once the
    workers are there); a no-op otherwise. It also says the executor's notes (:meth:`say`)."""

    def __init__(self, args: argparse.Namespace, total: int) -> None:
        from sim.cli.job_outputs import show_progress

        self._bar: Any = None
        self._show, self._total = show_progress(args), total

    def __call__(self, done: int, total: int) -> None:
        if self._bar is None and self._show:
            from tqdm import tqdm

            self._bar = tqdm(total=self._total, desc="runs", unit="run", dynamic_ncols=True, file=sys.stderr)
        if self._bar is not None:
            self._bar.n = done
            self._bar.refresh()

    def say(self, message: str) -> None:
        """``message`` on stderr, as the command's (above the bar, which is drawn again below it)."""
        line = f"nhsim montecarlo: {message}"
        if self._bar is not None:
            self._bar.write(line, file=sys.stderr)
        else:
            print(line, file=sys.stderr, flush=True)

    def __enter__(self) -> _bar:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()
