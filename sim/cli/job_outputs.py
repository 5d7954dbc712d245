"""Files a simulate job leaves behind: the MP4, the PNG plots and the JSON run record.

Default names, for scenario ``S`` tracked along reference (or planner) ``R`` by the scenario's own
robot with every run setting at its default::

    renders/S-R.mp4            video (H.264, yuv420p)
    renders/S-R-world.png      world, reference and every run's path
    renders/S-R-errors.png     position and heading error against time
    renders/S-R-commands.png   v, omega and wheel speeds against their limits
    renders/S-R-estimation.png estimates against the true pose (a job that gives its estimates)
    renders/S-R-pitch.png      pitch, its estimate and set-point (a balancing robot given by --robot)
    renders/S-R.json           run record; its "files" names every file written

The stem names everything that makes a job different (:func:`output_stem`): ``S-R``, then
``-ROBOT`` when ``--robot`` is not the scenario's own robot, then ``-TAG`` when the job's runs
differ from the default job's (:func:`changed_settings`: the settings as the runs use them, so a
default said again tags nothing): TAG is the first 6 hex digits of the SHA-1 of the settings that
differ as canonical JSON (keys sorted). ``--video PATH`` moves all of them beside ``PATH`` (named after
its stem); ``--json PATH`` moves the record. Existing files are never replaced without
``--overwrite``: every target (and whether its folder exists or can be created, and takes new
files, and whether an existing one is a regular file that can be replaced) is checked before any
physics runs, and the command stops with an error naming the file (no numbered names). No output may be
(or lie inside) a file the command reads (:func:`check_apart_from_inputs`: a scenario's file and its map
image among them).

The outputs are written as one set (:func:`sim.outputs.staged_outputs`): each under a temporary name
beside its target, then all moved into place together. An interrupt before that (Ctrl-C, or SIGTERM,
which ``nhsim`` turns into the same KeyboardInterrupt: :mod:`sim.cli.interrupt`) removes every new file
and leaves every old one as it was; the command exits 130.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import stat
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any

from planning.errors import ConfigError, OutputExistsError
from sim.cli.checks import case_list, comma_list

DEFAULT_DIR = Path("renders")
#: Options of ``simulate`` that change the runs, with their defaults (the names tag what they resolve to:
#: :func:`changed_settings`).
RUN_SETTINGS: dict[str, Any] = {
    "tracker": "both",
    "runs": None,
    "gains": None,
    "perturb": None,
    "build": "as-built",
    "build_seed": None,
    "sensors": None,
    "motors": None,
    "localiser": None,
    "lidar": None,
    "amcl": None,
    "initial_pose": "known",
    "control_rate": 50.0,
    "seed": 0,
    "noise_seed": None,
    "time_limit": 30.0,
    "columns": None,
    "scale": None,
    "time_scale": None,
    "offset": None,
    "allow_collisions": False,
    "topic": None,
    "message": None,
}


def unused_time_limit(planned: bool, time_limit: float) -> list[str]:
    """The note for a ``--time-limit`` given to a job that plans nothing (a reference, a file), as a
    list of at most one line (``simulate`` and ``compare`` print it on stderr)."""
    if planned or time_limit == RUN_SETTINGS["time_limit"]:
        return []
    return ["--time-limit ignored: it is the planner's budget, and this job plans nothing"]


def tracker_notes(on_reference: bool, trackers: Sequence[str]) -> list[str]:
    """Notes for trackers given a trajectory they are not made for (``simulate`` and ``compare`` print them on
    stderr): the reference's tracker on a plan or a file, which regulates no heading at its stops and end, and
    a tracker that follows the path, not the clock (a tracker class's ``FOLLOWS_CLOCK = False``: rpp), on a
    timed reference, which has no hold of final regulation to catch up in."""
    from control.base import TRACKERS
    from sim.pipeline.runs import PLAN_TRACKER, REFERENCE_TRACKER

    notes = []
    if not on_reference and REFERENCE_TRACKER in trackers:
        notes.append(
            f"{REFERENCE_TRACKER} tracks the position along a smooth reference; at a plan's stops and its end it "
            f"regulates no heading (its end heading shows it): {PLAN_TRACKER} is the tracker made for plans"
        )
    lagging = [t for t in trackers if t in TRACKERS and not getattr(TRACKERS.factory(t), "FOLLOWS_CLOCK", True)]
    if on_reference and lagging:
        notes.append(
            f"{', '.join(lagging)} follows the reference's path, not its clock: it trails a timed reference and is "
            "still short where the reference ends (2-5 cm on the built-in references), which the 2 cm target "
            "counts; a plan gets a hold of final regulation to arrive in"
        )
    return notes


def add_case_arguments(p: argparse.ArgumentParser) -> None:
    """``--scenario``, ``--robot`` and ``--planner`` / ``--reference``, decided by simulate's rule
    (:func:`sim.cli.simulate.job_source`) for commands that run one case (compare, montecarlo)."""
    from planning.trajectory.references import REFERENCES
    from sim.cli.checks import add_robot_argument

    p.add_argument(
        "--scenario",
        default=None,
        metavar="NAME|PATH",
        help="scenario (default: as simulate's: edumip_map; open with --reference)",
    )
    add_robot_argument(p, "robot (default: the scenario's)")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--planner", default=None, metavar="P", help="plan with P (default: the scenario's planner)")
    src.add_argument("--reference", choices=list(REFERENCES), default=None, help="track an analytic reference")


def add_executor_arguments(p: argparse.ArgumentParser, *, what: str, default_jobs: str) -> None:
    """``--jobs J`` / ``--scheduler ADDRESS``: where ``what`` runs (see :mod:`sim.tools.executor`)."""
    from sim.tools.executor import JOBS_PER_CORE

    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--jobs",
        type=int,
        default=None,
        metavar="J",
        help=f"run {what} on J local worker processes (Dask; 1: in this process; at most {JOBS_PER_CORE} per core) "
        f"(default: {default_jobs})",
    )
    where.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help=f"run {what} on the Dask cluster whose scheduler is at ADDRESS, e.g. tcp://host:8786 "
        "(default: none, run here)",
    )


#: The video options and their defaults (set otherwise with --no-video, they are named as ignored).
VIDEO_DEFAULTS: dict[str, Any] = {"fps": 30.0, "size": "640x480", "camera": "overview", "quality": "fast"}


class SaidSwitch(argparse.BooleanOptionalAction):
    """``--NAME`` / ``--no-NAME`` that also sets ``NAME_said`` when either is given: an option whose default is on
    cannot tell an explicit ``--plots`` from none by its value (``simulate --all``, which writes no plots, refuses it
    where it was given)."""

    def __call__(
        self, parser: Any, namespace: argparse.Namespace, values: Any, option_string: str | None = None
    ) -> None:
        super().__call__(parser, namespace, values, option_string)
        setattr(namespace, f"{self.dest}_said", True)


def add_output_arguments(p: argparse.ArgumentParser) -> None:
    """Add the video, plot and GL options to a command's parser (no mujoco import)."""
    g = p.add_argument_group(
        "outputs",
        "By default the video, plots and run record go to renders/<scenario>-<planner or reference>.* , "
        "with -<robot> added for a robot other than the scenario's and -<6 hex> for non-default run settings. "
        "An existing file is never replaced unless --overwrite is given: the command checks every target "
        "first and stops with an error (exit 2) before running anything.",
    )
    g.add_argument(
        "--video",
        type=Path,
        default=None,
        metavar="PATH",
        help="MP4 to write (default: renders/<scenario>-<planner or reference>[-<robot>][-<tag>].mp4); plots and "
        "record go beside it (with --no-video, the plots go beside --json when it is given)",
    )
    g.add_argument("--no-video", action="store_true", help="skip the video (no OpenGL needed)")
    g.add_argument(
        "--bag",
        type=Path,
        default=None,
        metavar="DIR",
        help="also write the runs as a ROS 2 bag: a rosbag2 folder DIR with MCAP storage, for Foxglove, RViz "
        "(ros2 bag play) or PlotJuggler (default: none)",
    )
    g.add_argument("--plots", action=SaidSwitch, default=True, help="write the PNG plots (default: on)")
    g.add_argument(
        "--fps",
        type=float,
        default=VIDEO_DEFAULTS["fps"],
        metavar="N",
        help="video frames per second (default: %(default)g)",
    )
    g.add_argument(
        "--size",
        default=VIDEO_DEFAULTS["size"],
        metavar="WxH",
        help="video size in pixels, even, within H.264 level 5.2: at most 4096 a side and 36864 macroblocks of 16x16 "
        "a frame (4096x2304, 2304x4096, 3840x2160), 2073600 a second with --fps (default: %(default)s)",
    )
    g.add_argument(
        "--camera",
        choices=["overview", "chase"],
        default=VIDEO_DEFAULTS["camera"],
        help=(
            "top-down overview of the whole world, or a chase camera (default: %(default)s); "
            "the close-up inset beside it follows the main robot either way"
        ),
    )
    g.add_argument(
        "--quality",
        choices=["fast", "high"],
        default=VIDEO_DEFAULTS["quality"],
        help="fast: no shadows or reflections; high: shadows and reflections (about 4x slower) (default: %(default)s)",
    )
    g.add_argument(
        "--gl",
        choices=["osmesa", "egl", "glfw"],
        default=None,
        help="OpenGL backend (default: MUJOCO_GL, else glfw with a display, else osmesa, else egl)",
    )


@dataclass(frozen=True)
class OutputPlan:
    """Where a job's outputs go, decided and checked before anything runs.

    Attributes:
        stem: ``<scenario>-<planner or reference>[-<robot>][-<tag>]`` (:func:`output_stem`).
        video: MP4 path, or None.
        plots: Plot name -> PNG path (empty with --no-plots); the estimation plot's is written only
            when the job gives its estimates.
        json: Run record path.
        settings: Render settings (None without video).
        overwrite: Replace existing files.
        progress: Show progress bars.
        bag: ROS 2 bag folder to write (``--bag``), or None.
    """

    stem: str
    video: Path | None
    plots: dict[str, Path]
    json: Path
    settings: Any
    overwrite: bool
    progress: bool
    extra: dict[str, Any] = field(default_factory=dict)
    bag: Path | None = None
    #: The plots and video of the record ``json`` replaces (``--overwrite``: :func:`replaced_files`); those this job
    #: does not write again are removed with its commit (a TurtleBot3's localiser plot beside an EduMIP's record, the
    #: video beside a record a --no-video job replaces).
    replaced_files: list[Path] = field(default_factory=list)

    def targets(self) -> list[Path]:
        """Every file the job will write."""
        return list(self.named_targets().values())

    def named_targets(self) -> dict[str, Path]:
        """Every file the job will write, by what it is as a message names it: the option that sets it (the video
        and the record by ``--video`` and ``--json``, given or by default; a plot beside the record)."""
        named = {} if self.video is None else {"--video (the video)": self.video}
        beside = "beside the video" if self.video is not None else "beside the record"
        named |= {f"the {name} plot ({beside})": p for name, p in self.plots.items()}
        return named | {"--json (the record)": self.json}


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars only on a terminal and without --quiet (silent in CI logs)."""
    return not getattr(args, "quiet", False) and sys.stdout.isatty() and sys.stderr.isatty()


def changed_settings(args: argparse.Namespace, case: Any, scenario: Any, runs: Sequence[Any]) -> dict[str, Any]:
    """The job's settings that differ from those of the default job on the same scenario, robot and path
    source, as resolved (:meth:`sim.pipeline.case.Case.run_settings`, and the runs as a set): a default said
    again (``--seed 0``, ``--runs`` listing the default runs, a gains file of the default gains,
    ``--localiser amcl`` on the TurtleBot3, ``--amcl max_particles=2000``) changes nothing, and two files of
    the same gains are the same setting.

    Args:
        args: Parsed options (``allow_collisions`` is read; ``--gains`` is ignored by the open loop alone).
        case: The job's case.
        scenario: Its loaded scenario.
        runs: The run kinds it runs.

    Raises:
        ConfigError: As :meth:`sim.pipeline.case.Case.run_settings`.
    """
    from dataclasses import replace

    from planning.trajectory.importer import TrajectoryFile
    from sim.pipeline.case import Case, PlanOptions
    from sim.pipeline.runs import DEFAULT_RUNS, RunKind

    file = case.trajectory_file
    default = replace(
        case,
        **{f.name: f.default for f in fields(Case) if f.name in _CASE_SETTINGS and f.default is not MISSING},
        planning=PlanOptions(),
        trajectory_file=None if file is None else TrajectoryFile(file.path, timed=file.timed),
    )
    mine, base = case.run_settings(scenario), default.run_settings(scenario)
    changed = {k: v for k, v in mine.items() if v != base[k]}
    if set(runs) != set(DEFAULT_RUNS):
        changed["runs"] = sorted(str(k) for k in runs)
        if set(runs) == {RunKind.OPEN_LOOP}:
            changed.pop("gains", None)  # nothing is fed back
    if getattr(args, "allow_collisions", False) and file is None:
        changed["allow_collisions"] = True
    return changed


#: The :class:`sim.pipeline.case.Case` fields a job's options set (the rest name the job: scenario, robot, source).
_CASE_SETTINGS = (
    "tracker", "seed", "control_rate", "gains", "params", "perturbation", "build_seed", "sensors", "noise_seed",
    "localiser", "lidar", "amcl", "initial_pose", "motors",
)  # fmt: skip


def settings_tag(changed: Mapping[str, Any]) -> str:
    """6 hex digits naming a job's non-default settings (:func:`changed_settings`; "" when there are none):
    the start of the SHA-1 of them as JSON with sorted keys."""
    if not changed:
        return ""
    return hashlib.sha1(json.dumps(changed, sort_keys=True).encode()).hexdigest()[:6]


def file_safe(name: str) -> str:
    """``name`` as one file name's part: letters (any script), digits and ``._+-`` kept, anything else (a
    path separator, a space, a control character) as ``_``, no leading dot; so a scenario named
    ``../../x`` writes ``_.._x-...`` in the output folder, not two folders up."""
    safe = "".join(c if c.isalnum() or c in "._+-" else "_" for c in name).lstrip(".")
    return safe or "_"


def output_stem(
    args: argparse.Namespace, *, scenario: str, source: str, changed: Mapping[str, Any], own_robot: str | None = None
) -> str:
    """``<scenario>-<source>[-<robot>][-<tag>]``: the robot when it is not the scenario's own (``own_robot``,
    else the robot of the built-in scenario of that name), the tag (:func:`settings_tag`) of the job's
    settings that differ from the default job's (``changed``, :func:`changed_settings`) when there are any."""
    from planning.scenario import load_scenario

    stem = f"{file_safe(scenario)}-{file_safe(source)}"
    robot = getattr(args, "robot", None)
    if robot is not None and robot != (own_robot or load_scenario(scenario).robot):
        stem += f"-{robot}"
    tag = settings_tag(changed)
    return f"{stem}-{tag}" if tag else stem


def plan_outputs(
    args: argparse.Namespace,
    *,
    scenario: str,
    source: str,
    changed: Mapping[str, Any],
    own_robot: str | None = None,
) -> OutputPlan:
    """Decide every output path and check that none exists (unless --overwrite), before any work.

    Call after :func:`sim.viz.gl.configure`: with a video it opens and closes a tiny OpenGL context so
    a missing GL library fails now, not after the physics.

    Args:
        args: Parsed options (see :func:`add_output_arguments`; also ``json``, ``overwrite``).
        scenario: Scenario name.
        source: Planner or reference name.
        changed: The job's settings that differ from the default job's (:func:`changed_settings`): they
            tag the names.
        own_robot: The scenario's own robot (default: that of the built-in scenario named ``scenario``;
            give it for a scenario read from a file or built in memory).

    Raises:
        ConfigError: Bad --size, --fps or --video name, two outputs with the same path, or an output
            whose folder cannot hold it (a file in the way, a folder that cannot be created or written).
        OutputExistsError: A target exists and --overwrite was not given.
        DependencyError: A video was asked for and no OpenGL backend can load.
    """
    from sim.outputs import check_video_name
    from sim.viz.plots.run import ESTIMATION_PLOT, LOCALISER_PLOT, PITCH_PLOT, PLOTS
    from sim.viz.replay import RenderSettings, parse_size

    stem = output_stem(args, scenario=scenario, source=source, changed=changed, own_robot=own_robot)
    video: Path | None = None
    settings = None
    w, h = parse_size(args.size)  # checked with --no-video too: a bad value is refused, not passed over
    asked = RenderSettings(width=w, height=h, fps=args.fps, camera=args.camera, quality=args.quality)
    if not args.no_video:
        settings = asked
        video = args.video if args.video is not None else DEFAULT_DIR / f"{stem}.mp4"
        check_video_name(video, "--video")
    elif args.video is not None:
        raise ConfigError("--video and --no-video contradict each other; drop one")
    else:
        given = {**{k: getattr(args, k, v) for k, v in VIDEO_DEFAULTS.items()}, "size": (w, h)}  # 640X480 is 640x480
        default = {**VIDEO_DEFAULTS, "size": parse_size(VIDEO_DEFAULTS["size"])}
        unused = [f"--{k}" for k, v in default.items() if given[k] != v]
        if unused:
            they = "they set" if len(unused) > 1 else "it sets"
            print(
                f"nhsim {args.command}: {', '.join(unused)} ignored: {they} the video, and --no-video writes none",
                file=sys.stderr,
            )
    base_dir, base = _plots_beside(args, stem)
    plots = {name: base_dir / f"{base}-{name}.png" for name in _plot_names(args, own_robot)} if args.plots else {}
    json_path = args.json if args.json is not None else base_dir / f"{base}.json"
    bag = getattr(args, "bag", None)
    every = (*PLOTS, ESTIMATION_PLOT, LOCALISER_PLOT, PITCH_PLOT)  # of the set --overwrite replaces: its plots, video
    candidates = [base_dir / f"{base}-{name}.png" for name in every] + [base_dir / f"{base}.mp4"]
    replaced = replaced_files(json_path, candidates) if args.overwrite else []
    plan = OutputPlan(
        stem, video, plots, json_path, settings, args.overwrite, show_progress(args), bag=bag, replaced_files=replaced
    )
    targets = plan.targets()
    check_apart_from_inputs(args, targets, bag)
    if bag is not None:
        from sim.io.bag import check_bag_apart, check_bag_target

        check_bag_target(bag, overwrite=args.overwrite)
        check_bag_apart(bag, targets)
    _check_targets(plan, args)
    if video is not None:
        from planning.errors import DependencyError
        from sim.viz.renderer import probe_renderer

        reason = probe_renderer()
        if reason is not None:
            raise DependencyError(reason)
    return plan


def _check_targets(plan: OutputPlan, args: argparse.Namespace) -> None:
    """Every file of ``plan`` distinct and writable (:func:`sim.outputs.check_writable`); one that cannot be written
    at its default path (``renders/`` in a folder that cannot take it) says so and which option names another."""
    from sim.outputs import check_distinct, check_writable

    check_distinct(plan.named_targets())
    for name, path in plan.named_targets().items():
        # the plots go beside the video, or beside the record without one
        flag = "--json" if name.startswith("--json") or plan.video is None else "--video"
        try:
            check_writable(path, overwrite=args.overwrite)
        except OutputExistsError:
            raise
        except ConfigError as exc:
            if getattr(args, flag[2:], None) is not None:
                raise
            raise ConfigError(f"{exc} ({path} is the default of {name}: give another with {flag})") from exc


def _plot_names(args: argparse.Namespace, own_robot: str | None) -> tuple[str, ...]:
    """The plots a job may draw: every job's, the estimation plot (drawn where the job gives its estimates), the
    scan localiser's where a run may use one, the pitch's for a balancing robot given by --robot."""
    from control.design.balance_profile import is_balancing
    from sim.viz.plots.run import ESTIMATION_PLOT, LOCALISER_PLOT, PITCH_PLOT, PLOTS

    names: tuple[str, ...] = (*PLOTS, ESTIMATION_PLOT)
    robot = getattr(args, "robot", None)
    if _may_scan(args, robot or own_robot):
        names = (*names, LOCALISER_PLOT)
    if robot is not None and is_balancing(robot):
        names = (*names, PITCH_PLOT)
    return names


def replaced_files(record: Path, candidates: Sequence[Path]) -> list[Path]:
    """The ``candidates`` (the plots and the video a job of this record's name may write) that the nhsim record at
    ``record`` lists among its files and that exist: the plots and video of the set a job with ``--overwrite``
    replaces. A file that is not such a record, or one written from another folder (its relative paths name other
    files), gives none."""
    if not record.is_file():  # none, or no regular file (a FIFO would block the read: refused later)
        return []
    try:
        files = json.loads(record.read_text(encoding="utf-8")).get("files", {})
        listed = {
            os.path.abspath(path) for kind, path in files.items() if str(kind).startswith("plot_") or kind == "video"
        }
    except (OSError, ValueError, AttributeError, TypeError):
        return []
    return [p for p in candidates if os.path.abspath(p) in listed and p.is_file()]


def _plots_beside(args: argparse.Namespace, stem: str) -> tuple[Path, str]:
    """The folder and stem the plots (and a record without --json) are named by: the video's; with no
    video, --json's when given; else renders/ and the job's ``stem``."""
    if args.video is not None:
        return args.video.parent, args.video.stem
    if args.no_video and args.json is not None:
        return args.json.parent, args.json.stem
    return DEFAULT_DIR, stem


#: Options whose value may name a file or folder the command reads (``--params``: files, comma-separated).
INPUT_OPTIONS = ("trajectory", "path", "scenario", "gains", "sensors", "lidar", "amcl", "params")


def input_paths(args: argparse.Namespace) -> list[tuple[str, Path]]:
    """The files and folders a command reads, each with the option that names it: every value of
    :data:`INPUT_OPTIONS` that names an existing path (as the commands read it: a scenario, gains or
    sensor value that names a file is read from it), a scenario's file (a built-in's too) and the map image
    it reads (:func:`scenario_inputs`), and the scenarios of ``tune``'s cases (``--scenarios``)."""
    found: list[tuple[str, Path]] = []
    for name in INPUT_OPTIONS:
        value = getattr(args, name, None)
        if not isinstance(value, (str, Path)):
            continue
        if name == "scenario":  # with --all, a comma list of them (simulate's sweep)
            for scenario in comma_list(str(value)) if getattr(args, "all", False) else [str(value)]:
                found += scenario_inputs(f"--scenario {scenario}", scenario)
            continue
        for part in comma_list(str(value)) if name == "params" else [str(value)]:
            if part and os.path.lexists(part):
                found.append((f"--{name} {part}", Path(part)))
    cases = getattr(args, "scenarios", None)
    if isinstance(cases, str):  # tune's SCENARIO[:SOURCE],...
        from sim.pipeline.case import Case

        for token in case_list(cases):
            scenario = Case.split(token)[0]
            if scenario:
                found += scenario_inputs(f"--scenarios {scenario}", scenario)
    return found


def scenario_inputs(given: str, scenario: str) -> list[tuple[str, Path]]:
    """The files a scenario value reads, as :func:`planning.scenario.load_scenario` finds them: its TOML file
    (a path, or a built-in scenario's file) and what its ``[world.map]`` table reads (relative to the file's
    folder): the map image it names, or the ROS map YAML it names and the image that YAML names (relative to
    the YAML's folder); ``given`` names the option in messages. A file that cannot be read gives only itself
    (loading it says what is wrong); a pipe is read once (:func:`planning.core.files.read_input`); a generated
    world (``random<N>``) reads none."""
    import tomllib

    from planning.core.files import read_input_text
    from planning.scenario import SCENARIOS_DIR, map_files

    path = Path(scenario)
    if not (path.suffix == ".toml" or os.path.lexists(path)):
        path = SCENARIOS_DIR / f"{scenario}.toml"
        given = f"{given} (the file {path})"
    if not os.path.lexists(path):
        return []
    found = [(given, path)]
    try:
        data = tomllib.loads(read_input_text(path))  # a pipe: the loader gets these bytes again
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return found
    for key, what, name in map_files(data):
        read = path.parent / name  # an absolute path stays absolute
        found.append((f"{given} (its {what} {os.path.normpath(read)})", read))
        if key == "yaml":
            found += _map_yaml_image(f"{given} (the image its map YAML {os.path.normpath(read)} names", read)
    return found


def _map_yaml_image(given: str, yaml_path: Path) -> list[tuple[str, Path]]:
    """The image a ROS map YAML names (as the scenario's loader reads it), or nothing where the YAML cannot
    be read or is not a regular file (loading the scenario says what is wrong)."""
    from planning.core.nav2_map import read_map_yaml
    from planning.errors import ScenarioError

    try:
        if not stat.S_ISREG(yaml_path.stat().st_mode):
            return []
        image = read_map_yaml(yaml_path).image
    except (OSError, ScenarioError):
        return []
    return [(f"{given}, {os.path.normpath(image)})", image)]


def refuse_inside_a_bag(out: Path, target: Path) -> None:
    """Refuse a file output ``out`` (``target``, its symlinks resolved) inside a rosbag2 bag folder: a bag holds its
    own files only (one of nhsim's holding a record and plots written into it later was refused by ``--bag
    --overwrite`` as holding files "nhsim did not write"). The bag module is imported only where a folder above holds
    a metadata.yaml (os.path.isfile: False for a name too long)."""
    if not any(os.path.isfile(p / "metadata.yaml") for p in target.parents):
        return
    from sim.io.bag import bag_holding

    holder = bag_holding(target)
    if holder is not None:
        raise ConfigError(
            f"cannot write {out}: it lies inside the bag {holder} (a folder with a rosbag2 metadata.yaml), which "
            "holds its own files only; choose a path outside it"
        )


def check_apart_from_inputs(args: argparse.Namespace, files: Iterable[Path], bag: Path | None = None) -> None:
    """Check, before any work, that no output overwrites what the command reads (symlinks resolved): a file
    output is not an input nor inside an input folder (a rosbag2 bag), nor inside any bag; and the bag folder
    ``bag`` neither is, contains nor lies inside an input.

    Raises:
        ConfigError: Naming the output, the input (or the bag) and the fix.
    """
    from sim.outputs import resolved

    inputs = [(given, resolved(path)) for given, path in input_paths(args)]
    for out in files:
        target = resolved(out)
        for given, source in inputs:
            if target == source or source in target.parents:
                where = "is" if target == source else "lies inside"
                raise ConfigError(
                    f"the output {out} {where} the input {given}: writing it would change what the command reads; "
                    "choose another output path"
                )
        refuse_inside_a_bag(out, target)
    if bag is None:
        return
    folder = resolved(bag)
    for given, source in inputs:
        if folder == source or folder in source.parents or source in folder.parents:
            where = "is" if folder == source else "contains" if folder in source.parents else "lies inside"
            raise ConfigError(
                f"--bag {bag} {where} the input {given}: writing the bag would replace or change what the command "
                "reads; choose another --bag folder (or copy the input elsewhere first)"
            )


def render_job_video(result: Any, plan: OutputPlan, path: Path | None = None) -> dict[str, Any]:
    """Replay a job's logs into ``path`` (default: ``plan.video``; a staged name for it) with a progress
    bar; returns facts for the record."""
    from sim.viz.job_video import write_video
    from sim.viz.replay import frame_times

    assert plan.video is not None and plan.settings is not None
    logs = result.logs.values()
    t0, t1 = min(float(log.t[0]) for log in logs), max(float(log.t[-1]) for log in logs)
    frames = frame_times(t0, t1, plan.settings.fps).size
    bar = _progress_bar(frames, f"render {plan.video.name}", plan.progress)
    try:
        return write_video(
            result,
            plan.video if path is None else path,
            plan.settings,
            overwrite=plan.overwrite if path is None else False,
            progress=bar.update if bar is not None else None,
        )
    finally:
        if bar is not None:
            bar.close()


def _progress_bar(total: int, desc: str, enabled: bool) -> Any:
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="frame", leave=False, dynamic_ncols=True)


def write_outputs(result: Any, plan: OutputPlan, record: dict[str, Any]) -> dict[str, str]:
    """Write the video, the plots, the bag and the JSON record of a job as one set
    (:func:`sim.outputs.staged_outputs`): each under a temporary name beside its target, then all moved into
    place in one step. A KeyboardInterrupt (which ``nhsim`` also raises on SIGTERM) or an error before that
    removes every new file and leaves every old one as it was.

    Args:
        result: The :class:`sim.pipeline.simulate.JobResult`.
        plan: From :func:`plan_outputs`.
        record: The run record; gains "files" (every file written) and "video" (render facts).

    Returns:
        Output kind ("video", "plot_world", ..., "json") -> path written.

    Raises:
        OutputsNotPlacedError: An output could not be moved into place (:class:`sim.outputs.StagedOutputs`:
            no output is replaced, every old one kept).
    """
    from sim.io.bag import check_bag_target
    from sim.outputs import staged_outputs, write_json
    from sim.viz.plots.draw import save_figure
    from sim.viz.plots.estimation import series_of_runs
    from sim.viz.plots.run import job_figures

    files: dict[str, str] = {}
    bag = {plan.bag: check_bag_target} if plan.bag is not None else {}
    with staged_outputs(overwrite=plan.overwrite, folders=bag) as stage:
        if plan.video is not None:
            record["video"] = render_job_video(result, plan, stage.path(plan.video))
            files["video"] = str(plan.video)
        if plan.plots:
            title = f"{result.scenario.name} | {result.robot.name} | {result.source}"
            figs = job_figures(
                result.scenario.world, result.robot, result.trajectory, result.logs, title=title,
                estimation=series_of_runs(result.logs),
            )  # fmt: skip
            for name, path in plan.plots.items():
                if name not in figs:  # planned (and checked) but not drawn: the job gave no estimates
                    continue
                save_figure(figs[name], stage.path(path))
                files[f"plot_{name}"] = str(path)
        if plan.bag is not None:
            from sim.io.bag import write_job_bag

            record["bag"] = {**write_job_bag(result, stage.path(plan.bag)).as_dict(), "path": str(plan.bag)}
            files["bag"] = str(plan.bag)
        files["json"] = str(plan.json)
        record["files"] = dict(files)
        write_json(stage.path(plan.json), record)
        for path in retired_files(plan, files):
            stage.retire(path)
    return files


def retired_files(plan: OutputPlan, files: Mapping[str, str]) -> list[Path]:
    """The files of the set ``--overwrite`` replaces that the new set, ``files`` (kind -> path), does not write
    again (its video with --no-video, its plots with --no-plots, a localiser plot the new robot has not): removed
    with the commit, so that no old file stands beside a record that does not list it."""
    return [path for path in plan.replaced_files if str(path) not in files.values()]


def _may_scan(args: argparse.Namespace, robot: str | None) -> bool:
    """Whether the job may run a scan localiser: not told ``--localiser fixes``, and its robot (when known
    here) has a laser scanner."""
    from sim.physics.lidar import load_lidar_profile

    if getattr(args, "localiser", None) == "fixes":
        return False
    return robot is None or load_lidar_profile(robot) is not None
