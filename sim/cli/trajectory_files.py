"""``nhsim simulate --trajectory FILE`` / ``--path FILE``: the options, the case's source and the
printed summary of what was read and repaired (the reading itself is
:mod:`planning.trajectory.importer`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from planning.errors import ConfigError

if TYPE_CHECKING:
    from planning.scenario import Scenario
    from planning.trajectory.importer import TrajectoryFile

HELP = (
    "Track your own trajectory (timed) or path (untimed) from a file: CSV, TSV or whitespace-separated text with "
    'a header row naming the columns (or --columns), JSON ({"t": [...], "x": [...]}, a list of records, or the '
    "record nhsim plan --json writes, as a path), or a ROS nav_msgs/Path as YAML. Columns: t, x, y, theta (or "
    "an orientation quaternion qx, qy, qz, qw: its yaw), v, omega, vx, vy, ax, ay (_ skips one); --columns tum "
    "reads a TUM trajectory (timestamp tx ty tz qx qy qz qw, as evo writes it). Repeated stamps at one position "
    "merge, headings are unwrapped, given "
    "derivatives that disagree with the positions are replaced, and a timed file keeps its clock when it is "
    "within the robot's limits (else it is re-timed): the summary and the record's 'import' say what was done. "
    "The world is --scenario's (the file must stay clear of its obstacles and walls) or, without one, an empty "
    "arena around the file."
)


def add_file_arguments(p: argparse.ArgumentParser) -> None:
    """Add ``--trajectory``, ``--path`` and the options that read them to ``simulate``'s parser."""
    g = p.add_argument_group("trajectory and path files", HELP)
    which = g.add_mutually_exclusive_group()
    which.add_argument(
        "--trajectory",
        type=Path,
        default=None,
        metavar="FILE",
        help="track a timed file (default: none, a planner or reference)",
    )
    which.add_argument(
        "--path", type=Path, default=None, metavar="FILE", help="time an untimed file and track it (default: none)"
    )
    g.add_argument(
        "--columns",
        default=None,
        metavar="NAME,...",
        help=(
            "names of a text file's columns, e.g. t,x,y,_,theta, or tum for t,x,y,_,qx,qy,qz,qw (default: the "
            "header row)"
        ),
    )
    g.add_argument(
        "--scale",
        type=float,
        default=None,
        metavar="S",
        help="metres per file unit, e.g. 0.01: 1 cm per pixel (default: 1)",
    )
    g.add_argument(
        "--time-scale", type=float, default=None, metavar="T", help="seconds per file time unit (default: 1)"
    )
    g.add_argument(
        "--offset",
        default=None,
        metavar="X,Y,THETA",
        help="move the file into the world: rotate by THETA [rad], then shift by X, Y [m] (write --offset=-1,0,0) "
        "(default: 0,0,0)",
    )
    g.add_argument(
        "--topic",
        default=None,
        metavar="NAME",
        help="read this topic of a bag (.mcap, rosbag2 folder, ROS 1 .bag): a nav_msgs/Path (e.g. /plan), or for "
        "--trajectory also nav_msgs/Odometry or geometry_msgs/PoseStamped (e.g. /odom), stamps as the clock "
        "(default: none; a bag without it lists its topics)",
    )
    g.add_argument(
        "--message",
        type=int,
        default=None,
        metavar="N",
        help="which nav_msgs/Path on --topic: 0 the first, -1 the last (default: the last)",
    )
    g.add_argument(
        "--allow-collisions",
        action="store_true",
        help="run a file that enters an obstacle or leaves the world anyway (the record says so; the runs' "
        "collisions are then reported, not judged)",
    )
    p.set_defaults(_scenario_default=p.get_default("scenario"))


def file_given(args: argparse.Namespace) -> bool:
    """Whether the options name a trajectory or path file."""
    return getattr(args, "trajectory", None) is not None or getattr(args, "path", None) is not None


#: The options that say how to read a file, with their attribute names.
READING_OPTIONS = (
    ("--columns", "columns"),
    ("--scale", "scale"),
    ("--time-scale", "time_scale"),
    ("--offset", "offset"),
    ("--topic", "topic"),
    ("--message", "message"),
    ("--allow-collisions", "allow_collisions"),
)


def check_file_options(args: argparse.Namespace) -> None:
    """Refuse options that read a file when no file is named: they would be ignored without a word.

    Raises:
        ConfigError: --columns, --scale, --time-scale, --offset, --topic, --message or --allow-collisions
            without --trajectory or --path.
    """
    if file_given(args):
        return
    values = ((opt, getattr(args, attr, None)) for opt, attr in READING_OPTIONS)
    given = [opt for opt, value in values if value is not None and value is not False]  # --message 0 is given
    if given:
        raise ConfigError(
            f"{', '.join(given)} {'says' if len(given) == 1 else 'say'} how to read a --trajectory or --path "
            "file, and none is named: name the file, or drop "
            f"{'it' if len(given) == 1 else 'them'}"
        )


def file_options(args: argparse.Namespace) -> list[str]:
    """The options that read the same file the same way again (e.g. in a replay command)."""
    argv = ["--trajectory", str(args.trajectory)] if args.trajectory is not None else ["--path", str(args.path)]
    for opt, value in (("--columns", args.columns), ("--scale", args.scale), ("--time-scale", args.time_scale)):
        if value is not None:
            argv += [opt, str(value)]
    if args.offset:
        argv.append(f"--offset={args.offset}")
    for opt, value in (("--topic", getattr(args, "topic", None)), ("--message", getattr(args, "message", None))):
        if value is not None:
            argv += [opt, str(value)]
    return [*argv, "--allow-collisions"] if args.allow_collisions else argv


def file_source(args: argparse.Namespace) -> TrajectoryFile:
    """The file the options name, with how to read it.

    Raises:
        ConfigError: --planner, --reference or --all with a file; bad --columns or --offset.
    """
    from planning.trajectory.importer import TrajectoryFile, parse_columns, parse_offset

    if args.planner is not None or args.reference is not None or getattr(args, "all", False):
        raise ConfigError("--trajectory and --path track a file: drop --planner, --reference and --all")
    timed = args.trajectory is not None
    return TrajectoryFile(
        args.trajectory if timed else args.path,
        timed=timed,
        columns=parse_columns(args.columns) if args.columns else None,
        scale=args.scale,
        time_scale=args.time_scale,
        offset=parse_offset(args.offset) if args.offset else (0.0, 0.0, 0.0),
        allow_collisions=args.allow_collisions,
        topic=getattr(args, "topic", None),
        message=getattr(args, "message", None),
    )


def file_world(args: argparse.Namespace, source: TrajectoryFile) -> tuple[str | Scenario, str | None, str]:
    """The scenario a file runs in, the robot to ask for, and the source name of the outputs.

    --scenario gives the world (without it, an arena is sized around the file: its extent plus the
    robot's radius and 0.25 m); the arena is built for --robot (or
    TurtleBot3), whose name then joins the outputs' source when it is not the default.
    """
    if args.scenario != getattr(args, "_scenario_default", None):
        return args.scenario, args.robot, source.name
    from planning.core.robot import load_robot
    from planning.trajectory.file_trajectory import ARENA_ROBOT, arena_scenario
    from planning.trajectory.importer import read_trajectory_file

    robot = args.robot or ARENA_ROBOT
    arena = arena_scenario(read_trajectory_file(source), load_robot(robot))
    return arena, None, source.name if robot == ARENA_ROBOT else f"{source.name}-{robot}"


def format_import(rec: dict[str, Any]) -> list[str]:
    """The printed summary of a record's ``import``: rows read and merged, the timing, every note."""
    head = f"import {rec['file']} ({rec['format']}, {rec['kind']}): {rec['rows_read']} rows read, "
    head += f"{rec['rows_merged']} merged"
    if rec["retimed"] is not None:
        head += f"; {'re-timed' if rec['retimed'] else 'timing kept'}: {rec['timing']}"
    elif rec["timing"]:
        head += f"; {rec['timing']}"
    lines = [head, *(f"  {note}" for note in rec["notes"])]
    largest = rec.get("largest_correction")
    if largest:
        lines.append(
            f"  largest correction: {largest['what']} at {largest['row']}, {largest['difference']:.4g} "
            f"{largest['unit']}"
        )
    if rec["world"]:
        lines.append(f"  {rec['world']}")
    if rec["arena"]:
        lines.append("  world: an empty arena around the file (give --scenario for another)")
    return lines
