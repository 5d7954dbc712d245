"""``nhsim simulate``: track a reference (or a plan) closed loop and open loop in MuJoCo physics."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from planning.errors import ConfigError, without_python
from sim.cli.checks import add_planner_option_argument, add_robot_argument
from sim.cli.job_outputs import RUN_SETTINGS, add_executor_arguments, add_output_arguments, tracker_notes
from sim.cli.trajectory_files import add_file_arguments, check_file_options, file_given, format_import
from sim.pipeline.runs import RunKind, run_kinds
from sim.pipeline.sensor_settings import lidar_overrides, sensor_overrides

#: The scenario of a job that names none: this map for a plan (the default job, the EduMIP planning report's: the EduMIP
#: plans through it with its planner, C-RRT*), the empty arena for an analytic reference.
DEFAULT_SCENARIO = "edumip_map"
REFERENCE_SCENARIO = "open"
#: The reference tracked when neither --planner nor --reference is given and the scenario names no planner.
DEFAULT_REFERENCE = "figure8"
#: ``--build-seed``'s default as its help states it: :data:`sim.physics.asbuilt.DEFAULT_BUILD_SEED`
#: (not imported here: it loads mujoco, which must wait for ``--gl``; a test holds them equal).
BUILD_SEED_HELP = "1"

DESCRIPTION = (
    "Run the robot in MuJoCo physics along a reference trajectory three times (--runs): closed loop on the "
    "EKF's fused estimate (closed_loop), closed loop on dead reckoning (closed_loop_odometry) and replaying "
    "the reference inputs (open_loop); a reference is tracked by the dynamic feedback-linearisation tracker, "
    "a plan or a file by the segmented one; print each run's errors.\n\n"
    f"What runs, one rule: the scenario is --scenario, else '{REFERENCE_SCENARIO}' with --reference, else "
    f"'{DEFAULT_SCENARIO}'; the path is --reference's curve or --planner's plan, else the plan of the "
    f"scenario's own planner, else (the scenario names none) the '{DEFAULT_REFERENCE}' reference. With no "
    f"arguments: the default job (the EduMIP planning report's), '{DEFAULT_SCENARIO}' planned with its own planner, "
    "smoothed and tracked; "
    f"'--scenario farm' plans the farm with its own planner; '--reference circle' tracks a circle in "
    f"'{REFERENCE_SCENARIO}'.\n\n"
    "--planner P plans the scenario with P, smooths the path (piecewise polynomial, speed "
    "profile, cusps and turns in place) and tracks it with the segmented tracker. --all runs "
    "every built-in scenario with every applicable planner (the scenario's own planner, every "
    "built-in obstacle-avoiding planner, and obstacle-free planners where there are no obstacles; a plugin's "
    "planner only where the scenario names it) for every robot the scenario lists, and prints one row each; "
    "--scenario A,B,... (names or scenario files), --robot R and --planner P keep those cases (a planner that "
    "applies to none of the scenarios is refused, exit 2).\n\n"
    f"JSON record (--json): per run ({', '.join(repr(str(kind)) for kind in RunKind)}) final_position_error_m, "
    "final_heading_error_rad, rms_position_error_m, max_position_error_m, final_goal_error_m, collisions, "
    "warnings, saturation_fraction, duration_s, wheel_contact_loss_fraction, status, estimation (runs on an "
    "estimator; a balancing robot's also max_pitch_rad, fell, fall_time_s); plus scenario, robot, source, "
    "tracker, gains, control_rate_hz, seeds, the robot as built, sensors, localiser and package versions "
    "(every field: docs/reference/run-record.md).\n\n"
    "Outputs: renders/<scenario>-<planner or reference>.mp4 (every run: closed loop solid, the others as "
    "ghosts), PNG plots and a JSON record beside it; an existing file is never replaced without "
    "--overwrite (the command stops with an error before running anything).\n\n"
    "Exit status: 0 when every run is clean (no MuJoCo warning, no collision in closed loop) and the "
    "closed loop ends on target (a plan: inside the scenario's goal tolerance of the trajectory's final "
    "pose; a reference: final position 2 cm and RMS position 2 cm, the heading reported, not judged: the "
    "tracker follows a reference's position and stops with it); 1 otherwise, or "
    "when the plan fails or the closed loop ends early (a balancing robot falls, the estimate is lost) "
    "(the missed target, the reason or the fall time on stderr); 2 on bad input. Beside the closed loop "
    "the other runs are comparisons: their collisions, falls or lost estimates are reported on stderr, "
    "not judged (without a closed loop, every run's collisions, falls and lost estimates are judged; a "
    "target is the closed loop's alone)."
)


def run_choices() -> dict[str, tuple[RunKind, ...]]:
    """``--tracker`` choice -> the run kinds it makes: the closed loop on the fused estimate (named
    by the reference's feedback tracker), the open loop (named by its tracker), or both: the default
    runs (fused closed loop, dead-reckoning closed loop, open loop)."""
    from sim.pipeline.runs import DEFAULT_RUNS, REFERENCE_TRACKER

    return {
        REFERENCE_TRACKER: (RunKind.CLOSED_LOOP,),
        RunKind.OPEN_LOOP.tracker: (RunKind.OPEN_LOOP,),
        "both": DEFAULT_RUNS,
    }


def tracker_runs_option(text: str) -> str:
    """``--tracker``'s value: one of :func:`run_choices`, which picks the runs. A tracker's name that is not one
    (mpc, rpp, kanayama, segmented, a plugin's) is refused pointing at ``--feedback``, which picks the closed
    loops' tracker; any other value, naming the choices and ``--feedback`` too.

    Raises:
        argparse.ArgumentTypeError: Anything but a choice (exit 2, as argparse's invalid choice).
    """
    choices = list(run_choices())  # the closed loop's, the open loop's, both
    if text in choices:
        return text
    picks = (
        f"--tracker picks the runs ({', '.join(choices)}: the closed loop on the fused estimate, the open loop, or "
        "the default runs)"
    )
    from control.base import feedback_trackers  # no MuJoCo: before --gl is applied

    try:
        tracker = text in feedback_trackers()
    except ConfigError:  # a tracker plugin that does not load: the built-in names only
        tracker = False
    if tracker:
        raise argparse.ArgumentTypeError(
            f"{text!r} is a tracker: {picks}; to close the loops with {text}, give --feedback {text}"
        )
    named = ", ".join(sorted(choices))
    raise argparse.ArgumentTypeError(
        f"invalid choice: {text!r} (choose from {named}); the closed loops' tracker is --feedback T"
    )


def parse_runs(text: str) -> tuple[RunKind, ...]:
    """``--runs`` (comma-separated run kinds, e.g. ``closed_loop,closed_loop_truth``) as run kinds.

    Raises:
        ConfigError: An unknown or repeated run kind (the message lists the valid ones).
    """
    try:
        return run_kinds([p.strip() for p in text.split(",")])
    except ConfigError as exc:
        raise ConfigError(f"--runs {text!r}: {exc}") from exc


def parse_build(build: str, build_seed: int | None) -> int | None:
    """The case's build seed from ``--build as-built|nominal`` and ``--build-seed N``.

    Raises:
        ConfigError: ``--build nominal`` with a ``--build-seed``.
    """
    from sim.physics.asbuilt import DEFAULT_BUILD_SEED, check_build_seed

    if build == "nominal":
        if build_seed is not None:
            raise ConfigError(
                "--build nominal simulates the robot as drawn: drop --build-seed, or use --build as-built"
            )
        return None
    return DEFAULT_BUILD_SEED if build_seed is None else check_build_seed(build_seed)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``simulate`` subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        "simulate",
        help="track a reference closed loop and open loop in MuJoCo and report the errors",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_job_arguments(p)
    add_file_arguments(p)
    _add_run_arguments(p)
    add_output_arguments(p)
    return p


def _add_job_arguments(p: argparse.ArgumentParser) -> None:
    """What to run: scenario, robot, reference or planner, the sweep."""
    from planning.planners.registry import PLANNERS
    from planning.trajectory.references import REFERENCES

    p.add_argument(
        "--scenario",
        default=None,
        metavar="NAME|PATH",
        help=f"built-in scenario name, random<N> (the generated world of seed N) or path to a scenario .toml "
        f"(default: {DEFAULT_SCENARIO}; {REFERENCE_SCENARIO} with --reference)",
    )
    add_robot_argument(
        p, "robot, overriding the scenario's: one of the robots it lists (default: the scenario's robot)"
    )
    p.add_argument(
        "--reference",
        choices=list(REFERENCES),
        default=None,
        help="analytic reference placed at the scenario's start pose (default: none, the scenario's planner plans "
        f"the path; {DEFAULT_REFERENCE} when the scenario names no planner)",
    )
    planners = ", ".join(PLANNERS.built_in()) + ", or one a plugin registers"
    p.add_argument(
        "--planner",
        default=None,
        metavar="P",
        help=f"plan the scenario with planner P ({planners}) and track the plan (default: the scenario's planner)",
    )
    add_planner_option_argument(p)
    p.add_argument(
        "--all",
        action="store_true",
        help="every built-in scenario (or those of --scenario A,B,...) x applicable planner x robot",
    )
    add_executor_arguments(p, what="the cases of --all", default_jobs="1")
    limit, budget = RUN_SETTINGS["time_limit"], "planning budget (default: %(default)g s)"
    p.add_argument("--time-limit", type=float, default=limit, metavar="S", help=budget)


def _add_run_kind_arguments(p: argparse.ArgumentParser) -> None:
    """Which runs (``--tracker``, ``--runs``) and the closed loops' tracker (``--feedback``)."""
    p.add_argument(
        "--tracker",
        type=tracker_runs_option,
        choices=sorted(run_choices()),
        default=RUN_SETTINGS["tracker"],
        help="the runs: fbl (closed loop on the fused estimate), open-loop, or both: the default runs, closed loop on "
        "the fused estimate, closed loop on dead reckoning and open loop (default: %(default)s); the closed loops' "
        "tracker (mpc, rpp, kanayama, ...) is --feedback T",
    )
    add_feedback_argument(p)
    p.add_argument(
        "--runs",
        default=RUN_SETTINGS["runs"],
        metavar="KIND,...",
        help=f"the runs, overriding --tracker: any of {', '.join(str(k) for k in RunKind)} "
        "(closed_loop_truth feeds the tracker the true pose, for comparison) (default: those of --tracker)",
    )


def add_feedback_argument(p: argparse.ArgumentParser) -> None:
    """``--feedback T``: the closed loops' tracker (:func:`feedback_option` checks it)."""
    p.add_argument(
        "--feedback",
        default=None,
        metavar="T",
        help="the tracker of the closed-loop runs: fbl, segmented, mpc, rpp, kanayama, or one a plugin registers "
        "(docs/how-to/new-tracker.md) (default: segmented on a plan, fbl on a reference)",
    )


def _add_run_arguments(p: argparse.ArgumentParser) -> None:
    """How to run it: runs, build, sensors, gains, perturbation, rate, seed, record, verbosity. Defaults
    are :data:`sim.cli.job_outputs.RUN_SETTINGS` (which also names outputs by the settings that differ)."""
    from control.gains import FBLGains

    _add_run_kind_arguments(p)
    p.add_argument(
        "--build",
        choices=["as-built", "nominal"],
        default=RUN_SETTINGS["build"],
        help="as-built: wheel radii, track, tyre friction, mass and centre of mass drawn within their tolerances from "
        "--build-seed (the tracker and estimator know only the drawing); nominal: the robot as drawn "
        "(default: %(default)s)",
    )
    p.add_argument(
        "--build-seed",
        type=int,
        default=RUN_SETTINGS["build_seed"],
        metavar="N",
        help=f"seed of the as-built draw (default: {BUILD_SEED_HELP})",
    )
    p.add_argument(
        "--sensors",
        default=RUN_SETTINGS["sensors"],
        metavar="KEY=VALUE,...|FILE",
        help="override the robot's sensor profile (models/sensors/<robot>.toml), e.g. fix_rate=10,fix_latency=0.05, "
        "or a TOML file laid out as that profile: a [sensors] table and optionally a [lidar] table (the scanner's "
        "settings, under --lidar) (default: the profile as it is)",
    )
    p.add_argument(
        "--motors",
        default=RUN_SETTINGS["motors"],
        metavar="KEY=VALUE,...",
        help="the wheel motors' supply: battery_voltage [V] (the TurtleBot3's 3-cell pack, 11.1 V nominal, 12.6 V "
        "charged; rated 6.5-12.6 V), supply_sag [V] and torque_reserve (the margins of its wheel-speed limit), e.g. "
        "battery_voltage=12.6; the no-load speed and the robot's speed limits follow (default: the robot's own; the "
        "EduMIP's is fixed)",
    )
    add_localiser_arguments(p)
    p.add_argument(
        "--gains",
        default=RUN_SETTINGS["gains"],
        metavar="KP,KD|FILE",
        help="feedback gains Kp,Kd (both > 0), or a gains file written by 'nhsim tune' "
        f"(default: {FBLGains().kp:g},{FBLGains().kd:g})",
    )
    p.add_argument(
        "--perturb",
        default=RUN_SETTINGS["perturb"],
        metavar="KEY=VALUE,...",
        help="perturb physics and loop: friction, mass, radius (scales), noise [m], heading_noise [rad], "
        "latency [s], e.g. friction=0.6,mass=1.3,radius=1.02,noise=0.005,latency=0.02 (noise uses --noise-seed); "
        "a balancing robot also takes push=J@T, an impulse of J N s on its body top at T s (e.g. push=0.05@10) "
        "(default: none)",
    )
    p.add_argument(
        "--control-rate",
        type=float,
        default=RUN_SETTINGS["control_rate"],
        metavar="HZ",
        help="tracker rate; must divide the robot's physics rate, 500 Hz (edumip-balancing: 1000 Hz), and be a "
        "multiple of its pose fixes' rate (the TurtleBot3's 5 Hz, the EduMIP's 10 Hz; --sensors fix_rate=F changes it) "
        "(default: %(default)g)",
    )
    seed, every = RUN_SETTINGS["seed"], "seed for every random choice (default: %(default)s)"
    p.add_argument("--seed", type=int, default=seed, metavar="N", help=every)
    _add_record_arguments(p)


def _add_record_arguments(p: argparse.ArgumentParser) -> None:
    """The record, overwriting and verbosity."""
    p.add_argument(
        "--noise-seed",
        type=int,
        default=None,
        metavar="N",
        help="seed of the sensor noise (and --perturb's pose noise) apart from the plan's: replays a run of "
        "'nhsim montecarlo' (default: --seed)",
    )
    p.add_argument(
        "--json",
        type=Path,
        default=None,
        metavar="PATH",
        help="run record (default: beside the video, renders/<scenario>-<planner or reference>[-...].json)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="print only the results table; no progress bars")


def _latency_note(result: Any, perturbation: Any) -> list[str]:
    """The latency the runs applied, when it is not the one asked for: a command waits a whole number of physics
    steps (``--perturb latency=0.001`` ran as none, and the record kept 0.001)."""
    if perturbation is None or not perturbation.latency:
        return []
    meta = next(iter(result.runs.values())).log.meta
    applied, step = meta.get("latency_applied_s"), meta.get("timestep_s")
    if applied is None or abs(applied - perturbation.latency) <= 1e-12:
        return []
    return [
        f"latency={perturbation.latency:g} s is applied as {applied:g} s: a command waits a whole number of the "
        f"physics' {step * 1e3:g} ms steps (the runs' latency_applied_s)"
    ]


def _build_line(record: dict[str, Any]) -> str:
    b = record.get("as_built") or {}
    if record.get("build_seed") is None:
        return "built as drawn (--build nominal)"
    line = (
        f"as built (seed {record['build_seed']}): wheels {b['left_radius_scale']:.4f}/{b['right_radius_scale']:.4f} "
        f"x r, track {b['track_change'] * 1e3:+.1f} mm"
    )
    balances = any(isinstance(v, dict) and "max_pitch_rad" in v for v in record.values())  # a run's metrics say
    if "com_offset_x" in b and balances:  # what a balancing body leans by, and what holds it
        line += (
            f", centre of mass {b['com_offset_x'] * 1e3:+.1f} mm ahead of the axle, body mass "
            f"x{b['base_mass_scale']:.3f}, tyre friction x{b['tyre_friction_scale']:.3f}"
        )
    return line


def _sensor_line(record: dict[str, Any]) -> str:
    s = record.get("sensors") or {}
    if not s.get("fix_rate"):
        return f"encoders {s.get('encoder_cpr', 0):g}/rev, no localisation fixes"
    loc = record.get("localiser")
    if loc is None:  # the record has one only when a run localised (closed loop on the fused estimate)
        return f"encoders {s.get('encoder_cpr', 0):g}/rev, no run localised"
    if loc.get("kind") == "amcl":
        initial = str(loc.get("initial", "known"))
        start = {"unknown": "global localisation first", "known": "from the start pose"}.get(
            initial, f"from the pose estimate ({initial})"
        )
        return (
            f"encoders {s['encoder_cpr']:g}/rev, AMCL on LDS-01 scans ({s['fix_rate']:g} Hz, {start}), "
            f"{s['fix_latency'] * 1e3:g} ms late"
        )
    return (
        f"encoders {s['encoder_cpr']:g}/rev, fixes {s['fix_rate']:g} Hz +-{s['fix_position_std'] * 1e3:g} mm "
        f"+-{s['fix_heading_std']:g} rad, {s['fix_latency'] * 1e3:g} ms late"
    )


def _scans(n: int) -> str:
    """``n`` scans, the noun in the number's form ("1 scan", "3 scans")."""
    return f"{n} scan{'' if n == 1 else 's'}"


def localiser_line(est: dict[str, Any], status: str = "ok") -> str:
    """The closed loop's scan localiser in one line ("" without one): its accuracy, its particles, its
    revolutions with fewer returns than it matches (:data:`control.estimation.amcl.MIN_BEAMS`: no fix came of
    them) and, after ``--initial-pose unknown``, how global localisation went (the run's ``status`` says whether
    it ended undecided)."""
    from control.estimation.amcl import MIN_BEAMS
    from sim.robot.scan_localiser import AMBIGUOUS

    if est.get("scans_used") is None:
        return ""
    rmse, head = est.get("localiser_rmse_m"), est.get("localiser_heading_rmse_rad")
    text = (
        f"localiser: {_scans(est['scans_used'])} used, RMSE "
        + (f"{rmse * 100:.1f} cm / {math.degrees(head):.2f} deg" if rmse is not None and head is not None else "-")
        + (f", {est['mean_particles']:.0f} particles on average" if est.get("mean_particles") is not None else "")
    )
    few, cast = est.get("scans_without_returns") or 0, est.get("scans_cast") or 0
    if few:  # the record's count: revolutions with fewer than MIN_BEAMS returns, none or a few
        every = f"all {cast} scans" if few == cast > 1 else _scans(few)
        text += f"; {every} with fewer than {MIN_BEAMS} returns, the fewest the localiser matches (no fix)"
    if est.get("localisation_lost") is not None:
        text += f"; LOST at t={est['localisation_lost']:.2f} s"
    scans = est.get("global_localisation_scans")
    if scans is not None:
        ok = est.get("global_localisation_converged")
        said = "ambiguous after" if status.startswith(AMBIGUOUS) else "converged after" if ok else "did not converge in"
        text += f"; global localisation {said} {_scans(scans)}"
    return text


def format_table(record: dict[str, Any]) -> str:
    """The metrics table printed by ``simulate``: one row per run in the record (estimation columns
    for runs fed by an estimator: its RMS position error, the share of fixes with a NEES inside
    the 95 % interval, and the mean NEES, 3 for a consistent estimator of a planar pose: the share can be
    high while the mean shows a bias). A run that ended early is marked ``*``, its reason in a line under the table."""
    head = (
        f"{'run':<21} {'final pos [m]':>13} {'final head [rad]':>16} {'rms pos [m]':>11} {'max pos [m]':>11} "
        f"{'est rms [m]':>11} {'NEES ok':>7} {'NEES mean':>9} {'collisions':>10} {'warnings':>8}"
    )
    lines = [head, "-" * len(head)]
    for kind in RunKind:
        if kind not in record:
            continue
        r = record[kind]
        est = r.get("estimation")
        nees = est.get("nees_in_bound_fraction") if est else None
        rmse = est.get("position_rmse_m") if est else None  # None: the estimator diverged (its status says)
        est_rms = f"{rmse:.4f}" if rmse is not None else "-"
        nees_ok = f"{nees:.0%}" if nees is not None else "-"
        mean = est.get("nees_mean") if est else None
        nees_mean = f"{mean:.2f}" if mean is not None and math.isfinite(mean) else "-"
        label = f"{kind}*" if r.get("status", "ok") != "ok" else str(kind)
        lines.append(
            f"{label:<21} {r['final_position_error_m']:>13.4f} {r['final_heading_error_rad']:>16.4f} "
            f"{r['rms_position_error_m']:>11.4f} {r['max_position_error_m']:>11.4f} "
            f"{est_rms:>11} {nees_ok:>7} {nees_mean:>9} "
            f"{r['collisions']:>10d} {r['warnings']:>8d}"
        )
    return "\n".join(lines + _ended_early(record) + _pitches(record))


def _pitches(record: dict[str, Any]) -> list[str]:
    """A balancing robot's largest pitch per run, a line under the table ([] for another robot)."""
    pitched = [(kind, r["max_pitch_rad"]) for kind in RunKind if (r := record.get(kind)) and r.get("max_pitch_rad")]
    if not pitched:
        return []
    return ["max pitch: " + ", ".join(f"{kind} {math.degrees(p):.1f} deg" for kind, p in pitched)]


def _ended_early(record: dict[str, Any]) -> list[str]:
    """A line under the table for each run that ended early (a fall, a lost estimate, a localiser that lost
    the robot or never found it): its row's errors are up to then, which alone would read as a run on target."""
    lines = []
    for kind in RunKind:
        r = record.get(kind)
        if r is None or r.get("status", "ok") == "ok":
            continue
        goal = r.get("final_goal_error_m")
        lines.append(
            f"* {kind} ended at {r['duration_s']:.1f} s: {str(r['status']).split(': ')[0]}; its errors are up to then"
            + (f", {goal:.3f} m from the goal" if goal is not None else "")
        )
    return lines


def run(args: argparse.Namespace) -> int:
    """Execute ``simulate``."""
    from sim.viz import gl

    gl.configure(args.gl)  # before anything imports mujoco
    from sim.cli.checks import check_control_rate, check_seeds, check_time_limit

    check_seeds(seed=args.seed, noise_seed=args.noise_seed)
    gains, _ = gains_and_perturbation(args)
    check_control_rate(args.control_rate)
    check_time_limit(args.time_limit)
    if args.all and args.bag is not None:
        raise ConfigError("--bag writes one job's runs; --all sweeps many jobs: drop one of them")
    check_file_options(args)
    if args.all and file_given(args):
        raise ConfigError("--all sweeps the built-in scenarios' plans: drop it to track a --trajectory or --path file")
    if args.all and args.planner_option:
        raise ConfigError("--planner-option is one planner's: drop it with --all, which runs every planner")
    if args.all and args.feedback is not None:
        raise ConfigError("--feedback is one job's: --all tracks every plan with its default tracker; drop one of them")
    if args.all:
        from sim.cli.sweep_table import check_sweep_options, run_all

        check_sweep_options(args, option_defaults())
        return run_all(args, gains)
    if args.jobs is not None or args.scheduler is not None:
        raise ConfigError("--jobs and --scheduler spread --all's sweep over workers; one job runs here: drop it")
    for line in ignored_options(args):
        print(f"nhsim simulate: {line}", file=sys.stderr)
    case, source = job_case(args)
    runs = parse_runs(args.runs) if args.runs is not None else run_choices()[args.tracker]
    if not all(kind.tracker for kind in runs):  # a run feeds back: its tracker, on this trajectory
        for line in tracker_notes(case.reference is not None, [case.feedback_tracker]):
            print(f"nhsim simulate: {line}", file=sys.stderr)
    return _track_job(args, case, source)


def gains_and_perturbation(args: argparse.Namespace) -> tuple[Any, Any]:
    """The FBL gains of ``--gains`` (the defaults without it) and the perturbation of ``--perturb`` (None
    without it; its random draws seeded by the noise seed).

    Raises:
        ConfigError: Bad gains (or gains file) or perturbation.
    """
    from control.gains import FBLGains, resolve_gains
    from sim.physics.perturb import Perturbation

    noise_seed = args.seed if args.noise_seed is None else args.noise_seed
    gains = resolve_gains(args.gains) if args.gains else FBLGains()
    return gains, Perturbation.parse(args.perturb, seed=noise_seed) if args.perturb else None


def option_defaults() -> dict[str, Any]:
    """``simulate``'s options and their defaults, by dest (from its own parser)."""
    sub = argparse.ArgumentParser().add_subparsers()
    return {a.dest: a.default for a in add_parser(sub)._actions if a.option_strings and a.dest != "help"}


def ignored_options(args: argparse.Namespace) -> list[str]:
    """Options given away from their defaults that the job does not use, as notes: the planner's time limit
    when nothing is planned (a reference, a file), the time scale of a path (which has no clock), the
    gains when no run feeds back (the open loop alone)."""
    from control.fbl import uses_fbl_gains
    from sim.cli.job_outputs import unused_time_limit

    notes = unused_time_limit(args.reference is None and not file_given(args), args.time_limit)
    if getattr(args, "path", None) is not None and args.time_scale is not None:
        notes.append("--time-scale ignored: a --path file has no clock (the speed profile times it)")
    runs = parse_runs(args.runs) if args.runs is not None else run_choices()[args.tracker]
    if args.feedback is not None and all(kind.tracker for kind in runs):
        notes.append(f"--feedback ignored: no run of {', '.join(runs)} feeds back")
    if args.initial_pose != "known" and not any(kind.localises for kind in runs):
        notes.append(
            f"--initial-pose {args.initial_pose} ignored: no run of {', '.join(runs)} localises with scans (only "
            f"{RunKind.CLOSED_LOOP}, on the fused estimate, does)"
        )
    if args.gains and runs == (RunKind.OPEN_LOOP,):
        notes.append("--gains ignored: the open loop alone feeds nothing back")
    elif args.gains and args.feedback is not None and not uses_fbl_gains(args.feedback):
        notes.append(
            f"--gains ignored: tracker {args.feedback} does not use the FBL's gains (give its parameters to nhsim "
            "compare --params)"
        )
    return notes


def check_scan_beams(case: Any, scenario: Any, runs: tuple[RunKind, ...]) -> None:
    """Refuse a scanner with fewer beams than the scan localiser matches (:data:`control.estimation.amcl.MIN_BEAMS`)
    when a run localises with it: no revolution could give a fix, and that run would be dead reckoning under the
    closed loop's name. (A run that takes no scan leaves the setting unused.)

    Raises:
        ConfigError: Naming the beams, the minimum and the fix.
    """
    from control.estimation.amcl import MIN_BEAMS

    if not any(kind.localises for kind in runs):
        return
    setup = case.localiser_setup(scenario)
    if setup.kind != "amcl" or setup.lidar is None or setup.lidar.beams >= MIN_BEAMS:
        return
    beams = setup.lidar.beams
    raise ConfigError(
        f"lidar beams={beams} (--lidar, or a --sensors file's [lidar] table): the scan localiser matches a "
        f"revolution only with at least {MIN_BEAMS} returns (control.estimation.amcl.MIN_BEAMS), so with {beams} "
        f"beams it would never make a fix and {RunKind.CLOSED_LOOP} would run on dead reckoning; give "
        f"--lidar beams={MIN_BEAMS} or more (the LDS-01 takes 360)"
    )


def feedback_option(
    name: str | None, open_loop: str = "its run is --runs open_loop (or --tracker open-loop)"
) -> str | None:
    """``--feedback``'s tracker: one with feedback (a player without it, "open-loop", is the open loop's run,
    ``open_loop`` says where a command has it).

    Raises:
        ConfigError: A tracker without feedback.
    """
    from control.base import TRACKERS, feedback_trackers

    if name is not None and name in TRACKERS and name not in feedback_trackers():
        raise ConfigError(
            f"--feedback {name}: {name!r} feeds nothing back, so the closed-loop runs would not be closed; {open_loop}"
        )
    return name


def _case_fields(args: argparse.Namespace, gains: Any, perturbation: Any) -> dict[str, Any]:
    """The case fields every job takes from the options (seed, rate, gains, build, sensors, ...); the gains only for a
    tracker that takes them (--gains with another is ignored, as :func:`ignored_options` notes)."""
    from control.fbl import uses_fbl_gains
    from sim.cli.checks import planner_option_values
    from sim.pipeline.case import PlanOptions

    tracker = feedback_option(args.feedback)
    return {
        "seed": args.seed,
        "control_rate": args.control_rate,
        "gains": gains if tracker is None or uses_fbl_gains(tracker) else None,
        "perturbation": perturbation,
        "planning": PlanOptions(time_limit=args.time_limit, planner_options=planner_option_values(args.planner_option)),
        "tracker": tracker,
        "build_seed": parse_build(args.build, args.build_seed),
        "sensors": sensor_overrides(args.sensors),
        "noise_seed": args.noise_seed,
        "motors": args.motors or "",
        **localiser_fields(args),
    }


def add_localiser_arguments(p: argparse.ArgumentParser) -> None:
    """``--localiser``, ``--lidar``, ``--amcl`` and ``--initial-pose``: where the EKF's fixes come from."""
    p.add_argument(
        "--localiser",
        choices=("amcl", "fixes"),
        default=RUN_SETTINGS["localiser"],
        help="source of the estimator's pose corrections: amcl (the LDS-01's scans matched against the map; the "
        "TurtleBot3's) or fixes (synthetic Gaussian fixes; the EduMIP's motion-capture-like source) (default: the "
        "robot's own: amcl for a robot with a laser scanner, fixes otherwise)",
    )
    p.add_argument(
        "--lidar",
        default=RUN_SETTINGS["lidar"],
        metavar="KEY=VALUE,...",
        help="override the laser scanner's settings ([lidar] in models/sensors/<robot>.toml, and in a --sensors "
        "file), e.g. beams=180 (default: the profile as it is)",
    )
    p.add_argument(
        "--amcl",
        default=RUN_SETTINGS["amcl"],
        metavar="KEY=VALUE,...",
        help="override the localiser's settings (Nav2's amcl names), e.g. max_particles=1000,refine=0 "
        "(default: Nav2's defaults, control/estimation/amcl.py)",
    )
    p.add_argument(
        "--initial-pose",
        type=initial_pose_option,
        default=RUN_SETTINGS["initial_pose"],
        metavar="known|unknown|X,Y,THETA",
        help="known: the localiser starts around the start pose; unknown: global localisation over the free space "
        "before tracking; X,Y,THETA (metres, radians, e.g. 1.2,0.5,0.3): a pose estimate (ROS's '2D Pose "
        "Estimate'), the particles start around it with Nav2's initial covariance (0.5 m, 0.26 rad) while the robot "
        "starts at the scenario's start; it must lie inside the walls and outside the obstacles (default: "
        "%(default)s)",
    )


def initial_pose_option(text: str) -> str:
    """``--initial-pose``'s value: "known" or "unknown" (in any case), or a pose estimate ``X,Y,THETA`` of three
    finite numbers, the heading within +-4 pi as a scenario's (:data:`planning.core.checks.MAX_HEADING`); its place
    in the world is checked with the world (:class:`sim.robot.scan_localiser.LocaliserSetup`).

    Raises:
        argparse.ArgumentTypeError: Anything else (exit 2, naming the forms; the command line's words only).
    """
    from sim.robot.pose_estimate import INITIAL_POSES, parse_initial_pose  # no MuJoCo: before --gl

    if text.strip().lower() in INITIAL_POSES:  # the keywords as the help spells them, but UNKNOWN is meant alike
        return text.strip().lower()
    if not text.strip():  # as every text option refuses it (sim.cli.checks.refuse_blank_values)
        raise argparse.ArgumentTypeError(
            "the value is empty; give known, unknown or X,Y,THETA, or leave --initial-pose out"
        )
    try:
        parse_initial_pose(text)  # three finite numbers, the heading within +-4 pi as a scenario's
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(without_python(str(exc))) from None
    return text


def localiser_fields(args: argparse.Namespace) -> dict[str, Any]:
    """The case fields of :func:`add_localiser_arguments`' options (the scanner's settings: ``--lidar`` over the
    ``[lidar]`` table of a ``--sensors FILE``, :func:`lidar_overrides`)."""
    return {
        "localiser": args.localiser,
        "lidar": lidar_overrides(getattr(args, "sensors", None), args.lidar, args.localiser),
        "amcl": args.amcl or "",
        "initial_pose": args.initial_pose,
    }


def job_source(scenario: str | None, planner: str | None, reference: str | None) -> tuple[str, dict[str, str]]:
    """What ``simulate`` runs, by the one rule its ``--help`` states.

    The scenario is ``scenario``, else :data:`REFERENCE_SCENARIO` with a reference, else
    :data:`DEFAULT_SCENARIO`; the path is ``planner``'s plan or ``reference``'s curve, else the plan of
    the scenario's own planner, else (the scenario names no planner) :data:`DEFAULT_REFERENCE`.

    Args:
        scenario: ``--scenario`` (a built-in name or a path), or None.
        planner: ``--planner``, or None.
        reference: ``--reference``, or None.

    Returns:
        (scenario, ``{"planner": name}`` or ``{"reference": name}``).

    Raises:
        ConfigError: Both a planner and a reference.
        ScenarioError: An unknown scenario or a bad scenario file (read only when its planner is needed).
    """
    if planner is not None and reference is not None:
        raise ConfigError("--reference and --planner exclude each other: track an analytic curve or a plan")
    if scenario is None:
        scenario = REFERENCE_SCENARIO if reference is not None else DEFAULT_SCENARIO
    if planner is not None:
        return scenario, {"planner": planner}
    if reference is not None:
        return scenario, {"reference": reference}
    from planning.scenario import load_scenario

    own = load_scenario(scenario).planner
    return scenario, ({"planner": own} if own is not None else {"reference": DEFAULT_REFERENCE})


def _law_text(tracker: str, gains: Any) -> str:
    """The closed loops' law in the job's first line: the FBL gains (the fbl and segmented trackers'), or the
    tracker with its own parameters."""
    from control.fbl import uses_fbl_gains

    if uses_fbl_gains(tracker):
        return f"gains Kp={gains.kp:g} Kd={gains.kd:g}"
    return f"tracker {tracker} (its own parameters)"


def job_case(args: argparse.Namespace) -> tuple[Any, str]:
    """The case one ``simulate`` job runs, and the source that names its outputs (the planner, the
    reference, or the file's name).

    Raises:
        NhsimError: Bad options, a bad trajectory file or scenario.
    """
    from sim.pipeline.case import Case

    fields = _case_fields(args, *gains_and_perturbation(args))
    if file_given(args):
        from sim.cli.trajectory_files import file_source, file_world

        trajectory = file_source(args)
        scenario, robot, name = file_world(args, trajectory)
        return Case(scenario, robot=robot, trajectory_file=trajectory, **fields), name
    scenario, source = job_source(args.scenario, args.planner, args.reference)
    case = Case(scenario, robot=args.robot, planner=source.get("planner"), reference=source.get("reference"), **fields)
    return case, next(iter(source.values()))


def _track_job(args: argparse.Namespace, case: Any, source: str) -> int:
    """Track a job's case: outputs planned (named after ``source``), the case prepared and tracked, the
    summary and table printed, the files written, judged."""
    from planning.scenario import load_scenario
    from sim.cli.job_outputs import changed_settings, plan_outputs, retired_files, write_outputs
    from sim.cli.progress import JobBars
    from sim.pipeline.case import load_case_scenario
    from sim.pipeline.simulate import simulate
    from sim.pipeline.sweep import missed_targets

    runs = parse_runs(args.runs) if args.runs is not None else run_choices()[args.tracker]
    loaded = load_case_scenario(case)  # a robot the scenario does not list stops here
    settings = changed_settings(args, case, loaded, runs)  # so do bad sensor settings and a bad supply
    check_scan_beams(case, loaded, runs)
    own = None  # the scenario's own robot names the outputs apart from --robot (a file scenario's too)
    if args.robot is not None:
        own = (case.scenario if not isinstance(case.scenario, str) else load_scenario(case.scenario)).robot
    outputs = plan_outputs(args, scenario=loaded.name, source=source, changed=settings, own_robot=own)
    with JobBars(outputs.progress) as bars:
        result = simulate(case, runs, progress=bars)
    record = result.record()
    gains, perturbation = result.gains, case.perturbation
    if not args.quiet:
        print(
            f"scenario {result.scenario.name} | robot {result.robot.name} | {result.source} | "
            f"{duration_text(result)} | control {args.control_rate:g} Hz | "
            + _law_text(case.feedback_tracker, gains)
            + (f" | perturbed {perturbation.label()}" if perturbation else "")
        )
        print(f"{_build_line(record)} | {_sensor_line(record)}")
        for line in _latency_note(result, perturbation):
            print(f"nhsim simulate: {line}", file=sys.stderr)
        if "import" in record:
            print("\n".join(format_import(record["import"])))
    print(format_table(record))
    closed = record.get(str(RunKind.CLOSED_LOOP), {})
    line = localiser_line(closed.get("estimation") or {}, str(closed.get("status", "ok")))
    if line and not args.quiet:
        print(line)
    files = write_outputs(result, outputs, record)
    if not args.quiet:
        print("\n".join(f"wrote {path}" for path in files.values()))
        for path in retired_files(outputs, files):
            print(f"removed {path} (of the set --overwrite replaced: this run writes no such file)")
    failures, notes = run_verdicts(result.runs, collisions_judged=not getattr(args, "allow_collisions", False))
    for line in notes:
        print(line, file=sys.stderr)
    closed = result.runs.get(RunKind.CLOSED_LOOP)
    if closed is not None:
        planned = result.source.startswith(("planner:", "file:"))  # a file is tracked and judged as a plan
        failures += missed_targets(closed.metrics, result.scenario, planned=planned)
    for line in failures:
        print(line, file=sys.stderr)
    clean = all(run.metrics.warnings == 0 for run in result.runs.values())
    return 0 if clean and not failures else 1


def run_verdicts(runs: Mapping[RunKind, Any], *, collisions_judged: bool = True) -> tuple[list[str], list[str]]:
    """The runs that ended early (a fall, a lost estimate) or touched an obstacle, as lines for stderr:
    (judged, reported).

    With a closed loop, the other runs (dead reckoning, open loop, ground truth) are comparisons: what
    they hit or where they ended early is reported, not judged. Without one, every run is judged.
    Collisions are only reported when not ``collisions_judged`` (a file run with --allow-collisions,
    which goes through an obstacle on purpose). (Targets are the closed loop's:
    :func:`sim.pipeline.sweep.missed_targets`.)
    """
    judged = [RunKind.CLOSED_LOOP] if RunKind.CLOSED_LOOP in runs else list(runs)
    failures: list[str] = []
    notes: list[str] = []
    for kind, run_ in runs.items():
        said = [] if run_.metrics.status == "ok" else [f"{kind}: {without_python(run_.metrics.status)}"]
        n = run_.metrics.collisions
        hit = [f"{kind} run touched an obstacle ({n} time{'s' if n != 1 else ''})"] if n > 0 else []
        if kind in judged:
            failures += said + (hit if collisions_judged else [])
            notes += [] if collisions_judged else [f"{line} (collisions allowed: reported, not judged)" for line in hit]
        else:
            notes += [f"{line} (a comparison run: reported, not judged)" for line in said + hit]
    return failures, notes


def duration_text(result: Any) -> str:
    """The simulated time of a job's runs for the header line: the main run's logged duration [s],
    which is the trajectory's plus the hold after it (final regulation of a planned job), e.g.
    ``"38.4 s simulated (trajectory 36.4 s + hold 2.0 s)"``."""
    main = result.runs.get(RunKind.CLOSED_LOOP) or next(iter(result.runs.values()))
    text = f"{main.metrics.duration_s:.1f} s simulated"
    hold = float(result.prepared.hold)
    if hold > 0.0:
        text += f" (trajectory {result.trajectory.duration:.1f} s + hold {hold:.1f} s)"
    return text
