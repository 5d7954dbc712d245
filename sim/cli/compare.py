"""``nhsim compare``: several trackers on the same trajectory, robot and noise, side by side."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sim.cli.checks import add_planner_option_argument, comma_list
from sim.cli.job_outputs import RUN_SETTINGS, add_case_arguments, tracker_notes, unused_time_limit
from sim.cli.trajectory_files import add_file_arguments

DESCRIPTION = """\
Run several trackers on the same trajectory (an analytic reference, or one plan of the scenario,
planned once), on the same as-built robot with the same sensor noise, each in the real robot's loop
(fused estimate), and print one row per tracker: final, RMS and max position error [m], final and
RMS heading error [rad], effort = integral of (dv/dt)^2 + (domega/dt)^2 over the run, saturation
fraction, control time per step (mean and 95th percentile of wall clock, and the 95th percentile of CPU time) [ms] and
collisions; MPC's
solver failures and overruns of the control period beside it.

--runs N (N > 1) runs every tracker on the same N held-out draws (robots and noise made from --seed,
never those a tuning study trains on) and prints the means; --runs 1, the default, runs each once on the
case's own robot and noise (the as-built robot of build seed 1 and the noise of --seed, as simulate's
defaults), not on the first held-out draw. --params FILE[,FILE] gives tuned parameters: the JSON that
'nhsim tune --tracker T' writes, or {"tracker": {"field": value, ...}, ...}; a later file's field
overrides an earlier one's, field by field. A trajectory read from a file (--path, --trajectory) is said
and recorded as simulate says it (the record's "import").

With no --reference or --planner: the default job (the EduMIP planning report's), a C-RRT* plan through
'edumip_map' (when that planner and scenario are installed; else figure-eight in 'open').

Outputs (each only when asked; an existing file is replaced only with --overwrite): --json PATH the
record (every run), --plots STEM STEM-paths.png (the paths overlaid) and STEM-errors.png (errors
against time), --video PATH one MP4 with every tracker's robot in its own colour (the first tracker
solid, the others ghosts), --bag DIR a ROS 2 bag (rosbag2 folder, MCAP) with every tracker's first run
under its own namespace (/fbl/..., /segmented/...). They are written as one set: each under a
temporary name beside it, then all moved into place together, so an interrupt (or a failure) before
the end leaves every old file as it was.

Exit status: 0 done, 2 bad input (nothing run), 1 a run ended early (a balancing robot fell, the estimate
was lost) or failed (a tracker's command was not finite or raised: the other trackers are still compared):
said below the table and in the record's run "status"."""

#: What --plots STEM adds to its stem: the paths overlaid, the errors against time.
PLOT_SUFFIXES = ("-paths.png", "-errors.png")
#: What --trackers defaults to: every registered tracker with feedback (control.base.feedback_trackers).
DEFAULT_TRACKERS = "every registered tracker with feedback (all but open-loop)"


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``compare`` subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        "compare",
        help="several trackers on the same trajectory, robot and noise: a table, plots and one video",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_case_arguments(p)
    add_planner_option_argument(p)
    add_file_arguments(p)
    p.add_argument(
        "--trackers",
        nargs="+",
        action="extend",  # given again, it adds (it replaced the trackers given before without a word)
        default=None,
        metavar="T",
        help=f"the trackers, comma- or space-separated, or the option given again: fbl,mpc or fbl mpc (default: "
        f"{DEFAULT_TRACKERS})",
    )
    p.add_argument(
        "--runs",
        type=int,
        default=1,
        metavar="N",
        help="runs per tracker: N > 1 on N held-out draws; 1 (the default) on the case's own robot and noise",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the plan and the noise (default: 0)")
    limit = RUN_SETTINGS["time_limit"]
    p.add_argument(
        "--time-limit", type=float, default=limit, metavar="S", help=f"planning budget (default: {limit:g} s)"
    )
    p.add_argument(
        "--params",
        default=None,
        metavar="FILE[,FILE]",
        help="tuned parameters: the JSON record 'nhsim tune' writes (its .json, not the .toml gains file)",
    )
    p.add_argument("--json", default=None, metavar="PATH", help="write the record here")
    p.add_argument(
        "--plots",
        default=None,
        metavar="STEM",
        help="write STEM-paths.png and STEM-errors.png; STEM is a file stem, e.g. renders/cmp, not a folder",
    )
    p.add_argument("--video", default=None, metavar="PATH", help="write one MP4 of every tracker here")
    p.add_argument("--bag", type=Path, default=None, metavar="DIR", help="write every tracker's run as a ROS 2 bag")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    return p


#: The outputs as a refusal of two at one path names them.
OUTPUT_NAMES = {
    "json": "--json (the record)",
    "paths": "--plots (its paths plot)",
    "errors": "--plots (its errors plot)",
    "video": "--video",
}


def _outputs(args: argparse.Namespace) -> dict[str, Path]:
    """The files asked for, checked writable before anything runs."""
    from sim.cli.checks import check_file_stem
    from sim.cli.job_outputs import check_apart_from_inputs
    from sim.outputs import check_distinct, check_video_name, check_writable

    out: dict[str, Path] = {}
    if args.json is not None:
        out["json"] = Path(args.json)
    if args.plots is not None:
        check_file_stem(args.plots, "--plots", "renders/cmp", PLOT_SUFFIXES)
        out["paths"], out["errors"] = (Path(f"{args.plots}{suffix}") for suffix in PLOT_SUFFIXES)
    if args.video is not None:
        out["video"] = Path(args.video)
        check_video_name(out["video"], "--video")
    check_apart_from_inputs(args, out.values(), args.bag)
    check_distinct({OUTPUT_NAMES[kind]: path for kind, path in out.items()})
    for path in out.values():
        check_writable(path, overwrite=args.overwrite)
    if args.bag is not None:
        from sim.io.bag import check_bag_apart, check_bag_target

        check_bag_target(args.bag, overwrite=args.overwrite)
        check_bag_apart(args.bag, out.values())
        out["bag"] = args.bag
    return out


def _case(args: argparse.Namespace) -> Any:
    """The case of the comparison (the default job when neither a reference nor a planner is given)."""
    from sim.cli.checks import check_seeds, check_time_limit, planner_option_values
    from sim.cli.simulate import job_source
    from sim.cli.trajectory_files import check_file_options, file_given, file_source, file_world
    from sim.pipeline.case import Case, PlanOptions

    check_file_options(args)
    check_time_limit(args.time_limit)
    check_seeds(seed=args.seed)
    options = planner_option_values(args.planner_option)
    fields = {"seed": args.seed, "planning": PlanOptions(time_limit=args.time_limit, planner_options=options)}
    if file_given(args):  # a trajectory or path file, read and checked as simulate reads it
        tfile = file_source(args)
        world, robot, _ = file_world(args, tfile)
        return Case(world, robot=robot, trajectory_file=tfile, **fields)
    scenario, source = job_source(args.scenario, args.planner, args.reference)
    planner, reference = source.get("planner"), source.get("reference")
    return Case(scenario, robot=args.robot, planner=planner, reference=reference, **fields)


def run(args: argparse.Namespace) -> int:
    """Execute ``compare``."""
    from control.base import feedback_trackers
    from planning.errors import ConfigError
    from sim.cli.trajectory_files import format_import
    from sim.tools.compare import check_trackers, compare_trackers, format_table, load_params

    given = None if args.trackers is None else [n for arg in args.trackers for n in arg.split(",")]
    names = check_trackers(given if given is not None else feedback_trackers())
    files = [] if args.params is None else comma_list(args.params)
    if args.params is not None and not files:
        raise ConfigError("--params names no file; give one or more JSON files, comma-separated (FILE[,FILE...])")
    params = load_params(files)
    unused = sorted(set(params) - set(names))
    if unused:
        raise ConfigError(
            f"--params gives parameters of {', '.join(unused)}, which --trackers {','.join(names)} does not run: "
            "add it to --trackers, or drop its parameters"
        )
    outputs = _outputs(args)
    case = _case(args)
    for line in unused_time_limit(case.planner is not None, args.time_limit):
        print(f"nhsim compare: {line}", file=sys.stderr)

    def progress(name: str, done: int, total: int) -> None:
        if not args.quiet:
            print(f"compare: {name} run {done}/{total}", file=sys.stderr, flush=True)

    result = compare_trackers(case, names, runs=args.runs, params=params, progress=progress)
    p = result.prepared
    print(f"{p.scenario.name} · {p.robot.name} · {p.source} · {p.trajectory.duration:.1f} s")
    if "import" in p.extra and not args.quiet:  # what was read from the file and repaired, as simulate says it
        print("\n".join(format_import(p.extra["import"])))
    print(format_table(result))
    for line in _missed(result, names, planned=case.reference is None):
        print(line)
    for line in tracker_notes(case.reference is not None, names):
        print(f"nhsim compare: {line}", file=sys.stderr)
    failed = [r.exception for r in result.runs if r.exception is not None]
    if len(failed) < len(result.runs):  # the files hold every run; with none but failed runs, there is nothing
        _write(result, outputs, overwrite=args.overwrite)
    if failed:  # the first failure is the command's error line
        raise failed[0]
    return 1 if result.ended_early() else 0


#: The comparison's columns (:data:`sim.tools.compare.COLUMNS`) of the metrics ``simulate`` judges its closed loop by.
JUDGED = {
    "final_position_error_m": "final_m",
    "rms_position_error_m": "rms_m",
    "final_heading_error_rad": "final_heading_rad",
}


def _missed(result: Any, names: Sequence[str], *, planned: bool) -> list[str]:
    """One line per feedback tracker whose mean errors miss the targets ``simulate`` judges its closed loop by
    (:func:`sim.pipeline.sweep.closed_loop_targets`): a table of 1.6 m errors said nothing, and the note on a tracker
    that trails the reference quoted its 2-5 cm."""
    from sim.pipeline.runs import RunKind
    from sim.pipeline.sweep import closed_loop_targets

    targets = closed_loop_targets(result.prepared.scenario, planned=planned)
    lines = []
    for name in names:
        s = result.summary(name)
        if RunKind.of_tracker(name) is RunKind.OPEN_LOOP:  # no feedback: its drift is the point, not a miss
            continue
        missed = [
            f"{key} {s[JUDGED[key]]:.4g} > {bound:g}"
            for key, bound in targets.items()
            if not s.get(JUDGED[key], 0.0) <= bound
        ]
        if missed:
            lines.append(f"{name} missed the targets simulate judges a closed loop by: {', '.join(missed)}")
    return lines


def _write(result: Any, outputs: dict[str, Path], *, overwrite: bool) -> None:
    """Write the record, the plots, the video and the bag asked for, as one set
    (:func:`sim.outputs.staged_outputs`): all moved into place together once every one is written, so an
    interrupt or a failure leaves every old file as it was."""
    from sim.io.bag import check_bag_target
    from sim.outputs import staged_outputs, write_json

    bag = outputs.get("bag")
    with staged_outputs(overwrite=overwrite, folders={bag: check_bag_target} if bag is not None else {}) as stage:
        if "json" in outputs:
            write_json(stage.path(outputs["json"]), result.record())
        if "paths" in outputs:
            from sim.viz.plots.draw import save_figure
            from sim.viz.plots.run import errors_figure, world_figure

            p, logs = result.prepared, result.logs()
            title = f"{p.scenario.name} · {p.robot.name} · {p.source}"
            paths = world_figure(p.scenario.world, p.trajectory, logs, title=title)
            save_figure(paths, stage.path(outputs["paths"]))
            save_figure(errors_figure(logs, title=title), stage.path(outputs["errors"]))
        if "video" in outputs:
            from sim.viz.job_video import write_video

            write_video(result.recorded(), stage.path(outputs["video"]))
        if bag is not None:
            from sim.io.bag import write_bag

            write_bag(result.prepared, result.logs(), stage.path(bag))
    for path in outputs.values():
        print(f"wrote {path}")
