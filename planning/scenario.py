"""Scenarios: a world, a robot, a start and a goal, loaded from TOML files.

Format version 1 (see docs/reference/scenario-format.md): top-level ``name``, ``robot``, ``description``, ``version``;
tables ``[world]`` (``bounds``, ``[[world.obstacles]]`` (each with an optional ``height``, below a laser scanner's
plane for an obstacle the scan passes over), ``[[world.unmapped]]``: obstacles shaped as
``[[world.obstacles]]`` that exist in physics and in the laser scan but not in the map the planner and the
localiser use, none within the robot's reach of the start), ``[start]`` (``pose``) and ``[goal]``
(``pose``, ``position_tolerance``, ``heading_tolerance``); optional ``[planners.<name>]`` tables of
keyword options for a registered planner in this scenario (e.g. ``[planners.birrt]`` with
``steering = "reeds_shepp"``), checked against that planner's options when the file is read; an
optional ``[sensors]`` table of numbers overriding the robot's sensor profile (checked by the
simulator, which knows the profile's keys). Every
problem is reported before anything runs, naming the file, the field and what is expected; a start or
goal where the robot's footprint overlaps an obstacle or wall is refused when the robot is chosen
(:func:`scenario_with_robot`: a command may run another robot than the scenario's own).
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planning.collision.overlap import footprint_overlaps
from planning.core.checks import check_number, degrees_hint, heading_beyond, is_number
from planning.core.files import descriptor_path, read_input_text, undecodable_at
from planning.core.geometry import Pose2D, heading_in_turn
from planning.core.maps import MapObstacles, load_map_table
from planning.core.nav2_map import load_map_yaml_table
from planning.core.robot import MODELS_DIR, ROBOTS, RobotSpec, check_robot_name, load_robot, robot_names
from planning.core.scenario_type import DEFAULT_HEADING_TOLERANCE, DEFAULT_POSITION_TOLERANCE
from planning.core.scenario_type import Scenario as Scenario  # re-exported (planning.Scenario): mypy --strict
from planning.core.tables import TableReader
from planning.core.world import (
    MAX_OBSTACLE_HEIGHT,
    MAX_WORLD_SIDE,
    MIN_FEATURE,
    OBSTACLE_HEIGHT,
    Box,
    Circle,
    Ellipse,
    Obstacle,
    Polygon,
    World,
    lies_outside,
    span,
    too_thin,
)
from planning.errors import ConfigError, ScenarioError, option

SCENARIOS_DIR = MODELS_DIR / "scenarios"
#: The name of a generated world (:func:`random_scenario`): ``random`` and its seed in ASCII digits, without
#: leading zeros (one name a world: ``random01`` and ``random\u0663``, an Arabic-Indic 3, were taken as
#: ``random1`` and ``random3``, and recorded under those names).
_RANDOM_NAME = re.compile(r"random(0|[1-9][0-9]*)")
#: The longest file name the file systems nhsim writes to take (bytes; POSIX NAME_MAX).
_NAME_MAX = 255

_TOP_KEYS = {
    "name", "robot", "description", "version", "world", "start", "goal", "planner", "robots", "planners", "sensors",
}  # fmt: skip
_WORLD_KEYS = {"bounds", "obstacles", "map", "unmapped"}
_OBSTACLE_KEYS: dict[str, tuple[set[str], set[str]]] = {
    # type: (required, optional)
    "circle": ({"center", "radius"}, {"height"}),
    "ellipse": ({"center", "radii"}, {"angle", "height"}),
    "box": ({"center", "size"}, {"angle", "height"}),
    "polygon": ({"vertices"}, {"height"}),
}

#: Hooks that turn a ``[world.map]`` table into obstacles: fn(table, scenario_dir, where) -> (obstacles, the
#: extent the map covers). "yaml" reads a table with a ``yaml`` field (a ROS map YAML), "image" any other.
MAP_LOADERS: dict[str, Callable[[Mapping[str, Any], Path, str], MapObstacles]] = {
    "image": load_map_table,
    "yaml": load_map_yaml_table,
}


def _unknown_planner(r: TableReader, field_name: str, got: Any) -> ScenarioError:
    """The error of a planner field naming no registered planner: the registered ones (a plugin's too) and how a
    plugin's planner is registered."""
    from planning.planners.registry import PLANNERS  # imported here: it loads on first use

    expected = f"a registered planner name ({', '.join(sorted(PLANNERS))})"
    return ScenarioError(f"{r.fail(field_name, expected, got)}; {PLANNERS.unknown_hint()}")


def _obstacle(r: TableReader, table: Mapping[str, Any], ctx: str) -> Obstacle:
    if not isinstance(table, Mapping) or "type" not in table:
        raise r.fail(f"{ctx}type", f"one of {', '.join(_OBSTACLE_KEYS)}")
    kind = table["type"]
    if not isinstance(kind, str) or kind not in _OBSTACLE_KEYS:
        raise r.fail(f"{ctx}type", f"one of {', '.join(_OBSTACLE_KEYS)}", kind)
    req, opt = _OBSTACLE_KEYS[kind]
    r.keys(table, ctx, req | {"type"}, opt)
    angle = r.number(table, "angle", ctx) if "angle" in table else 0.0
    if heading_beyond(angle):  # 45 was meant as degrees, 1e300 as nothing: refused as a pose's heading is
        raise r.fail(f"{ctx}angle", f"the rotation {heading_beyond(angle)}", angle)
    height = _height(r, table, ctx)
    cx, cy = r.vector(table, "center", ctx, 2) if "center" in table else (0.0, 0.0)
    if kind == "circle":
        return Circle((cx, cy), r.number(table, "radius", ctx, positive=True), height)
    if kind == "ellipse":
        a, b = r.vector(table, "radii", ctx, 2)
        if a <= 0 or b <= 0:
            raise r.fail(f"{ctx}radii", "two numbers > 0", [a, b])
        return Ellipse((cx, cy), (a, b), angle, height)
    if kind == "box":
        sx, sy = r.vector(table, "size", ctx, 2)
        if sx <= 0 or sy <= 0:
            raise r.fail(f"{ctx}size", "two numbers > 0 (full extents)", [sx, sy])
        return Box((cx, cy), (sx, sy), angle, height)
    verts = table["vertices"]
    if not isinstance(verts, list) or len(verts) < 3:
        raise r.fail(f"{ctx}vertices", "a list of at least 3 [x, y] pairs", verts)
    pts = tuple(r.vector({"v": v}, "v", f"{ctx}vertices[{i}].", 2) for i, v in enumerate(verts))
    try:
        return Polygon(pts, height)  # type: ignore[arg-type]
    except ValueError as exc:
        raise r.fail(f"{ctx}vertices", f"a simple polygon ({exc})", verts) from exc


def _height(r: TableReader, table: Mapping[str, Any], ctx: str) -> float:
    """An obstacle's ``height`` [m] (:data:`planning.core.world.OBSTACLE_HEIGHT` when not given): one below a laser
    scanner's plane is passed over by the scan."""
    expected = f"a height in metres, > 0 and at most {MAX_OBSTACLE_HEIGHT:g}"
    height = r.number(table, "height", ctx, positive=True, default=OBSTACLE_HEIGHT, expected=expected)
    if height > MAX_OBSTACLE_HEIGHT:
        raise r.fail(f"{ctx}height", expected, height)
    return height


def _planner_options(r: TableReader, table: Any) -> dict[str, dict[str, Any]]:
    """Validate ``[planners.<name>]`` tables: known planner names, options the planner accepts."""
    from planning.planners.registry import PLANNERS, make_planner  # imported here: it loads on first use

    if not isinstance(table, Mapping):
        raise r.fail("planners", "a table of [planners.<name>] tables of keyword options", table)
    out: dict[str, dict[str, Any]] = {}
    for name, opts in table.items():
        if name not in PLANNERS:
            raise _unknown_planner(r, f"planners.{name}", name)
        if not isinstance(opts, Mapping):
            raise r.fail(f"planners.{name}", "a table of keyword options", opts)
        if "time_limit" in opts:  # a plan's budget is the command's (--time-limit) or the problem's, said in its record
            raise ScenarioError(
                f"{r.where}: field 'planners.{name}.time_limit': a scenario does not set the planning budget; remove "
                "it and give the command --time-limit S (or PlanProblem's time_limit)"
            )
        try:
            make_planner(name, **opts)
        except (ConfigError, ValueError, TypeError) as exc:
            raise ScenarioError(
                f"{r.where}: field 'planners.{name}': options rejected by planner {name!r}: {exc}"
            ) from exc
        out[name] = dict(opts)
    return out


def _pose(r: TableReader, table: Mapping[str, Any], ctx: str) -> Pose2D:
    """A ``pose = [x, y, theta]`` field, its heading brought into (-pi, pi] (:func:`heading_in_turn`); one beyond
    :data:`MAX_HEADING` is refused."""
    x, y, theta = r.vector(table, "pose", ctx, 3)
    beyond = heading_beyond(theta)
    if beyond:
        raise r.fail(f"{ctx}pose", f"[x, y, theta] with theta {beyond}", table["pose"])
    return Pose2D(x, y, heading_in_turn(theta))


def parse_scenario(data: Mapping[str, Any], *, where: str, default_name: str, base_dir: Path) -> Scenario:
    """Build a scenario from a parsed TOML mapping.

    Args:
        data: The parsed document.
        where: How to name the source in errors (usually the file path).
        default_name: Name used when the document has none.
        base_dir: Directory that relative paths (map images) are resolved against.

    Returns:
        The validated scenario.

    Raises:
        ScenarioError: Naming the file, the field and what is expected.
    """
    r = TableReader(where)
    r.keys(data, "", {"world", "start", "goal"}, _TOP_KEYS)
    header = _header(r, data, default_name)
    world = _world(r, data["world"], base_dir)
    start_t, goal_t = data["start"], data["goal"]
    r.keys(start_t, "start.", {"pose"}, set())
    r.keys(goal_t, "goal.", {"pose"}, {"position_tolerance", "heading_tolerance"})
    start, goal = _pose(r, start_t, "start."), _pose(r, goal_t, "goal.")
    ptol = r.number(goal_t, "position_tolerance", "goal.", positive=True, default=DEFAULT_POSITION_TOLERANCE)
    htol = r.number(goal_t, "heading_tolerance", "goal.", positive=True, default=DEFAULT_HEADING_TOLERANCE)
    if htol > np.pi:  # pi takes any heading: more is degrees, or a typo
        said = f"a tolerance in radians, at most pi (any heading){degrees_hint(htol, 360.0)}"
        raise r.fail("goal.heading_tolerance", said, htol)
    for label, pose in (("start", start), ("goal", goal)):
        _check_free(r, world, label, pose, data["world"])
    unmapped = _unmapped(r, data["world"], start, header["robot"], world.bounds)
    return Scenario(
        world=world,
        start=start,
        goal=goal,
        position_tolerance=ptol,
        heading_tolerance=htol,
        unmapped=unmapped,
        **header,
    )


def _unmapped(
    r: TableReader, table: Mapping[str, Any], start: Pose2D, robot: str, bounds: tuple[float, float, float, float]
) -> tuple[Obstacle, ...]:
    """The ``[[world.unmapped]]`` obstacles (physics and the scan only), checked as ``[[world.obstacles]]`` are
    (:func:`_check_obstacles`), none touching the robot at its start."""
    items = table.get("unmapped", [])
    if not isinstance(items, list):
        raise r.fail("world.unmapped", "an array of tables ([[world.unmapped]], shaped as [[world.obstacles]])", items)
    out = tuple(_obstacle(r, ot, f"world.unmapped[{i}].") for i, ot in enumerate(items))
    _check_obstacles(r, out, "world.unmapped", bounds)
    _check_unmapped_clear(f"{r.where}: field 'world.unmapped", out, start, load_robot(robot))
    return out


def _check_unmapped_clear(where: str, unmapped: tuple[Obstacle, ...], start: Pose2D, robot: RobotSpec) -> None:
    """Refuse an unmapped obstacle within the robot's reach of its start: physics would start the run in a
    collision (the planners and the localiser do not know it is there). ``where`` leads the message, the
    obstacle's index and ``']'`` follow it (``"FILE: field 'world.unmapped"`` or ``"Scenario.unmapped"``).

    Raises:
        ScenarioError: Naming the obstacle, its distance from the start and the robot's reach.
    """
    for i, o in enumerate(unmapped):
        gap = float(o.signed_distance(start.xy)[0])
        if gap <= robot.radius:
            quote = "'" if where.endswith("'world.unmapped") else ""
            raise ScenarioError(
                f"{where}[{i}]{quote} ({o.kind}) overlaps the robot at its start ({gap:.3f} m from start.pose, "
                f"the {robot.name} reaches {robot.radius:.3f} m); move it away from the start"
            )


def _header(r: TableReader, data: Mapping[str, Any], default_name: str) -> dict[str, Any]:
    """The top-level fields: name, robot, robots, description, version, planner and planner options."""
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise r.fail("name", "a non-empty string", name)
    robot = data.get("robot", "turtlebot3")
    if not isinstance(robot, str) or robot not in ROBOTS:
        raise r.fail("robot", f"one of {robot_names()} ({ROBOTS.unknown_hint()})", robot)
    robots = data.get("robots", [robot])
    if not isinstance(robots, list) or not all(isinstance(x, str) and x in ROBOTS for x in robots) or not robots:
        raise r.fail("robots", f"a list of robot names from {robot_names()} ({ROBOTS.unknown_hint()})", robots)
    if robot not in robots:
        raise r.fail("robots", f"a list that includes the scenario's own robot {robot!r} (field 'robot')", robots)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise r.fail("description", "a string", description)
    version = data.get("version", 1)
    if type(version) is not int or version != 1:  # true == 1 and 1.0 == 1 in Python: neither is the integer 1
        raise r.fail("version", "the integer 1 (the only format version this nhsim reads)", version)
    planner = data.get("planner")
    if planner is not None:
        from planning.planners.registry import PLANNERS  # imported here: it loads on first use

        if not isinstance(planner, str) or planner not in PLANNERS:
            raise _unknown_planner(r, "planner", planner)
    planner_options = _planner_options(r, data["planners"]) if "planners" in data else {}
    sensors = data.get("sensors", {})
    if not isinstance(sensors, dict):
        raise r.fail("sensors", "a [sensors] table of numbers overriding the robot's sensor profile", sensors)
    for key, value in sensors.items():
        if not is_number(value):
            raise r.fail(f"sensors.{key}", 'a finite number (e.g. fix_rate = 5, not "5")', value)
    return {
        "sensors": {k: float(v) for k, v in sensors.items()},
        "name": name,
        "robot": robot,
        "robots": tuple(robots),
        "description": description,
        "planner": planner,
        "planner_options": planner_options,
    }


def _world(r: TableReader, table: Any, base_dir: Path) -> World:
    """The ``[world]`` table: bounds (the map's extent when a ``[world.map]`` is given without them), obstacles and
    the obstacles of a ``[world.map]``."""
    r.keys(table, "world.", set(), _WORLD_KEYS)
    mapped, extent = _map(r, table["map"], base_dir) if "map" in table else ([], None)
    if "bounds" in table:
        xmin, xmax, ymin, ymax = r.vector(table, "bounds", "world.", 4)
    elif extent is None:
        raise ScenarioError(f"{r.where}: missing field(s) 'world.bounds'")
    else:
        xmin, xmax, ymin, ymax = extent
    if not (xmin < xmax and ymin < ymax):
        raise r.fail("world.bounds", "[xmin, xmax, ymin, ymax] with xmin < xmax and ymin < ymax", table.get("bounds"))
    if max(xmax - xmin, ymax - ymin) > MAX_WORLD_SIDE:
        if "bounds" not in table:
            raise ScenarioError(
                f"{r.where}: table 'world.map': the map covers {xmax - xmin:g} x {ymax - ymin:g} m, more than "
                f"{MAX_WORLD_SIDE:g} m a side: give 'world.bounds' [xmin, xmax, ymin, ymax] of the part the robot uses"
            )
        raise r.fail(
            "world.bounds", f"[xmin, xmax, ymin, ymax] in metres, at most {MAX_WORLD_SIDE:g} m a side", table["bounds"]
        )
    obs_list = table.get("obstacles", [])
    if not isinstance(obs_list, list):
        raise r.fail("world.obstacles", "an array of tables ([[world.obstacles]])", obs_list)
    obstacles = [_obstacle(r, ot, f"world.obstacles[{i}].") for i, ot in enumerate(obs_list)]
    bounds = (xmin, xmax, ymin, ymax)
    _check_obstacles(r, obstacles, "world.obstacles", bounds)
    if mapped and all(_outside(ob, bounds) for ob in mapped):
        raise ScenarioError(
            f"{r.where}: table 'world.map': every obstacle of the map lies outside the world bounds "
            f"{list(bounds)} (the map's occupied pixels span x {min(o.bounding_box()[0] for o in mapped):g}.."
            f"{max(o.bounding_box()[1] for o in mapped):g}, y {min(o.bounding_box()[2] for o in mapped):g}.."
            f"{max(o.bounding_box()[3] for o in mapped):g}); check its origin and resolution"
        )
    mapped = [ob for ob in mapped if not _outside(ob, bounds)]  # the map's part beyond the walls: cropped
    for k, ob in enumerate(mapped):  # a pixel the collision checker cannot resolve: a resolution of 1e-5 m
        if ob.min_feature < MIN_FEATURE:
            raise ScenarioError(
                f"{r.where}: table 'world.map': obstacle {k} of the map ({ob.kind}) is {ob.min_feature:.3g} m across, "
                f"less than the {MIN_FEATURE * 1e3:g} mm the collision checker resolves: check the map's resolution "
                "(metres a pixel)"
            )
    return World(bounds, (*obstacles, *mapped))


def _map(r: TableReader, table: Any, base_dir: Path) -> MapObstacles:
    """A ``[world.map]`` table's obstacles and extent, by the loader of its kind: a map YAML's with ``yaml``, an
    image's otherwise."""
    kind = "yaml" if isinstance(table, Mapping) and "yaml" in table else "image"
    loader = MAP_LOADERS.get(kind)
    if loader is None:
        raise r.fail("world.map", f"a map of a kind this installation reads ({', '.join(sorted(MAP_LOADERS))})")
    return loader(table, base_dir, r.where)


def _check_obstacles(
    r: TableReader, obstacles: Sequence[Obstacle], field_name: str, bounds: tuple[float, float, float, float]
) -> None:
    """Refuse an obstacle of the array ``field_name`` (``world.obstacles``, ``world.unmapped``) that lies wholly
    outside ``bounds`` (it could never be met: a typo?) or is too thin to simulate."""
    for i, ob in enumerate(obstacles):
        if why := lies_outside(ob, bounds) or too_thin(ob):
            raise ScenarioError(f"{r.where}: field '{field_name}[{i}]': this {ob.kind} {why}")


def _outside(ob: Obstacle, bounds: tuple[float, float, float, float]) -> bool:
    """Whether obstacle ``ob`` lies wholly outside ``bounds`` (xmin, xmax, ymin, ymax): it could never be met."""
    return bool(lies_outside(ob, bounds))


def _check_free(r: TableReader, world: World, label: str, pose: Pose2D, table: Mapping[str, Any]) -> None:
    """The start or goal lies inside the bounds and outside every obstacle (of ``[[world.obstacles]]``, then of the
    ``[world.map]``, as ``table``, the ``[world]`` table, gives them)."""
    xmin, xmax, ymin, ymax = world.bounds
    if not (xmin < pose.x < xmax and ymin < pose.y < ymax):
        inside = f"a position inside the world bounds {list(world.bounds)}"
        raise r.fail(f"{label}.pose", inside, pose.as_array().tolist())
    if float(world.obstacle_distance(pose.xy)[0]) <= 0:
        idx = int(np.argmin([o.signed_distance(pose.xy)[0] for o in world.obstacles]))
        given = len(table.get("obstacles", []))
        what, fix = f"world.obstacles[{idx}] ({world.obstacles[idx].kind})", "move it into free space"
        if idx >= given:  # one of the map's
            what = f"obstacle {idx - given} of the map (table 'world.map', a {world.obstacles[idx].kind})"
            if world.obstacles[idx].kind == "box":
                what += (
                    ': with shape "box" a region of the map\'s occupied cells is its bounding box, which covers the '
                    "free cells around a wall that is not an upright rectangle"
                )
                fix = f'give the map shape = "polygon" (its exact cells), or {fix}'
        raise ScenarioError(f"{r.where}: field '{label}.pose': {pose.as_array().tolist()} lies inside {what}; {fix}")


#: The name of a scenario read from a pipe (bash's ``<(...)``: ``/dev/fd/N``) that gives none itself.
PIPED_NAME = "piped"


def load_scenario_file(path: str | Path) -> Scenario:
    """Load and validate a scenario TOML file."""
    p = Path(path)
    try:
        text = read_input_text(p)  # once (a pipe cannot be read again); a byte-order mark is dropped
    except OSError as exc:
        raise ScenarioError(f"cannot read scenario file {p}: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise ScenarioError(
            f"scenario file {p} is not UTF-8 text ({undecodable_at(exc)}); TOML is UTF-8: save it as UTF-8"
        ) from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        if p.suffix.lower() in (".json", ".yaml", ".yml"):  # said as such, not as the TOML parser's first complaint
            raise ScenarioError(
                f"{p}: a scenario file is TOML, not {p.suffix[1:].upper()}; write it as TOML (docs/how-to/"
                "new-scenario.md), or copy a built-in one from models/scenarios"
            ) from exc
        raise ScenarioError(f"{p}: not valid TOML: {exc}") from exc
    piped = descriptor_path(p)
    if piped:
        _refuse_relative_map(data, p)
    # a piped scenario without a name is not named by its descriptor's number (outputs renders/63-...)
    name = PIPED_NAME if piped else p.stem
    sc = parse_scenario(data, where=str(p), default_name=name, base_dir=p.parent)
    return dataclasses.replace(sc, source=p)


def map_files(data: Mapping[str, Any]) -> list[tuple[str, str, str]]:
    """The files a scenario's parsed TOML ``data`` names in its ``[world.map]`` table, as (key, what, path as
    written): its map image (``image``) or ROS map YAML (``yaml``); none where the table is absent or malformed
    (loading the scenario says what is wrong)."""
    world = data.get("world")
    table = world.get("map") if isinstance(world, Mapping) else None
    if not isinstance(table, Mapping):
        return []
    named = [(key, what, table.get(key)) for key, what in (("image", "map image"), ("yaml", "map YAML"))]
    return [(key, what, name) for key, what, name in named if isinstance(name, str) and name]


def _refuse_relative_map(data: Mapping[str, Any], p: Path) -> None:
    """Refuse a relative path in the ``[world.map]`` table of a scenario read from a pipe in ``/dev`` (bash's
    ``<(...)`` gives ``/dev/fd/N``): it would be looked for in ``/dev/fd``, not beside the scenario's file."""
    for key, what, name in map_files(data):
        if not Path(name).is_absolute():
            raise ScenarioError(
                f"{p}: field 'world.map.{key}': the {what} {name!r} is relative to the scenario file's folder, but "
                f"the scenario comes from a pipe ({p}, e.g. bash's <(...)), whose folder {p.parent} is not the "
                f"scenario's; give the scenario as a file (its path), or the {what}'s absolute path"
            )


def _built_in_source(name: str) -> Path | int | None:
    """Where the built-in scenario ``name`` comes from: its file in ``models/scenarios``, or the seed N of the
    generated world ``random<N>``; None when it is neither."""
    candidate = SCENARIOS_DIR / f"{name}.toml"
    if len(os.fsencode(candidate.name)) <= _NAME_MAX and candidate.exists():  # exists() raises on a name too long
        return candidate
    return random_seed(name)


def misspelt_random_name(name: str) -> str:
    """Why ``name`` is not the generated world it looks like (``random07``, ``random\u0663``: a seed with leading
    zeros or in other digits), naming the one it is; "" for any other name."""
    seed = re.fullmatch(r"random(\d+)", name)
    if seed is None or random_seed(name) is not None:
        return ""
    try:
        world = f"random{int(seed.group(1))} is that world"
    except ValueError:  # a digit int() does not read (a superscript)
        world = "e.g. random7"
    return f"unknown scenario {name!r}: random<N> takes its seed N in the digits 0-9 without leading zeros: {world}"


def random_seed(name: str) -> int | None:
    """The seed N of the generated world named ``random<N>`` (:func:`random_scenario`), or None when ``name`` is
    not such a name (``random07``, ``random\u0663`` are not: :func:`load_scenario` refuses them, naming the world
    they look like)."""
    generated = _RANDOM_NAME.fullmatch(name)
    return None if generated is None else int(generated.group(1))


def is_builtin_name(name: str) -> bool:
    """Whether ``name`` is a built-in scenario's name (:func:`builtin_scenarios`) or ``random<N>``: what
    :func:`load_scenario` loads as the built-in, whatever the working directory holds."""
    return bool(name) and Path(name).name == name and _built_in_source(name) is not None


def _built_in(name: str) -> Scenario | None:
    """The built-in scenario ``name`` (a file of ``models/scenarios``) or the generated world ``random<N>``; None
    when it is neither."""
    source = _built_in_source(name)
    if isinstance(source, Path):
        return load_scenario_file(source)
    return None if source is None else random_scenario("turtlebot3", source)


def builtin_scenarios() -> list[str]:
    """Names of the scenarios shipped in ``models/scenarios``."""
    return sorted(p.stem for p in SCENARIOS_DIR.glob("*.toml"))


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a built-in scenario by name, a scenario file by path, or a generated world by its name
    ``random<N>`` (:func:`random_scenario` of seed N, for the TurtleBot3 and every other robot).

    A bare name (no folder, no suffix) that is a built-in one or ``random<N>`` is that scenario wherever the command
    runs: a file or folder of that name in the working directory is not looked at (give it as ``./open`` to load it;
    a ``Path`` is the file it names when there is one, else the built-in of that name).

    Raises:
        ScenarioError: Unknown name (the message lists the built-in ones) or a bad file.
    """
    if not isinstance(name_or_path, (str, os.PathLike)):  # str() made None the name 'None'
        raise ScenarioError(
            f"load_scenario takes a scenario's name or its file's path, got {type(name_or_path).__name__} "
            f"{name_or_path!r:.60}; e.g. load_scenario('edumip_map')"
        )
    text = str(name_or_path)
    p = Path(text)
    longest = max((len(os.fsencode(part)) for part in p.parts), default=0)  # Path.exists() raises beyond NAME_MAX
    named = p.name == text and not p.suffix  # no folder, no suffix: a built-in's name, or a file's
    if named and (isinstance(name_or_path, str) or longest > _NAME_MAX or not p.exists()):  # a Path: its file if any
        built_in = _built_in(text)
        if built_in is not None:
            return built_in
    if longest > _NAME_MAX:
        raise ScenarioError(
            f"a scenario is a built-in name, random<N> or a .toml file, got a name of {longest} bytes (starting "
            f"{text[:24]!r}); a file or folder name holds at most {_NAME_MAX}: give the scenario's path"
        )
    if not text.strip() or p.is_dir():
        what = "an empty name" if not text.strip() else f"the folder {text!r}"
        raise ScenarioError(
            f"a scenario is a built-in name, random<N> or a .toml file, got {what}; e.g. "
            f"{option('scenario', 'edumip_map', python='load_scenario({})')}"
        )
    if p.suffix == ".toml" or p.exists():
        if not p.exists():
            raise ScenarioError(f"scenario file {p} does not exist")
        return load_scenario_file(p)
    misspelt = misspelt_random_name(text)
    if misspelt:
        raise ScenarioError(misspelt)
    raise ScenarioError(
        f"unknown scenario {text!r}: give a path to a .toml file, random<N> for the generated world of seed N "
        f"(e.g. random300), or one of: {', '.join(builtin_scenarios())}"
    )


def scenario_with_robot(scenario: Scenario, robot: str | None, *, ends: bool = True) -> Scenario:
    """The scenario with ``robot`` (None: its own robot), which must be one the scenario lists and, with
    ``ends``, fit at the start and at the goal (:func:`check_ends_fit`).

    Args:
        scenario: The scenario.
        robot: The robot to use; None for the scenario's own.
        ends: Check the start and goal poses (False when they are replaced, e.g. by a trajectory file's).

    Raises:
        ConfigError: The scenario's ``robots`` do not list the robot (the message names them), or its planner or
            a table of its ``planner_options`` names no registered planner.
        ScenarioError: The robot's footprint overlaps an obstacle or wall at the start or the goal.
    """
    if robot is not None and robot not in scenario.robots:
        listed = ", ".join(f'"{r}"' for r in (*scenario.robots, robot))
        src = scenario.source
        shipped = src is None or Path(src).resolve().parent == SCENARIOS_DIR.resolve()
        where = "a copy of the scenario's file (a built-in scenario)" if shipped else f"the scenario file {src}"
        raise ConfigError(
            f"robot {robot!r} is not among the robots ({', '.join(scenario.robots)}) that scenario {scenario.name!r} "
            f"lists (a scenario without a robots key lists its own robot only): choose one of them with "
            f"{option('robot')}, or add robots = [{listed}] to {where}"
        )
    chosen = scenario if robot is None else scenario.with_robot(robot)
    _check_planners(chosen.planner, chosen.planner_options)
    if ends:
        check_ends_fit(chosen)
    return chosen


def _check_planners(planner: str | None, planner_options: Mapping[str, object]) -> None:
    """The planner and the planners ``planner_options`` names are registered ones (a plugin's too), as a
    scenario file's must be (a :class:`Scenario` made in Python is checked here, where it is used: the scenario
    type is below the planners): a misspelt name would be ignored.

    Raises:
        ConfigError: Naming the field, the name and the registered planners.
    """
    names = [("Scenario.planner", planner)] if planner is not None else []
    names += [(f"Scenario.planner_options[{name!r}]", name) for name in planner_options]
    if not names:
        return
    from planning.planners.registry import PLANNERS  # imported here: it loads on first use

    for where, name in names:
        if name not in PLANNERS:
            raise ConfigError(
                f"{where}: {name!r} is not a registered planner ({', '.join(sorted(PLANNERS))}); "
                f"{PLANNERS.unknown_hint()}"
            )


def _exact_clearance(world: World, robot: RobotSpec, pose: Pose2D) -> float:
    """The footprint's clearance at ``pose`` to within 0.1 mm below the truth (a message's number; the
    planners' test, :func:`planning.collision.overlap.end_clearance`, errs up to half its checker's tolerance
    below it) [m]."""
    from planning.collision.exact import CollisionChecker  # imported here: compiled code, loaded on first use

    return CollisionChecker(world, robot, shape="footprint").least_clearance(pose.as_array()[None, :])


def scenario_source(scenario: Scenario) -> str:
    """How messages name where a scenario comes from: its file, else ``scenario 'NAME'`` (a generated world)."""
    return str(scenario.source) if scenario.source is not None else f"scenario {scenario.name!r}"


def check_ends_fit(scenario: Scenario) -> None:
    """Refuse a scenario whose robot's footprint overlaps an obstacle or wall at the start or the goal (a plan
    could only fail): the message names the file, the field, the robot, the clearance and how far to move it.

    Raises:
        ScenarioError: The footprint overlaps something at ``start.pose`` or ``goal.pose``, or one of them lies
            outside the world's bounds, or an unmapped obstacle is within the robot's reach of its start.
        ConfigError: The scenario's robot is not a robot's name (nor an MJCF file's path).
    """
    from planning.collision.exact import DEFAULT_TOLERANCE  # imported here: compiled code, loaded on first use

    robot = _scenario_robot(scenario)
    where = scenario_source(scenario)
    field = f"{where}: field 'world.unmapped" if scenario.source is not None else f"{where}: Scenario.unmapped"
    _check_unmapped_clear(field, scenario.unmapped, scenario.start, robot)
    for label, pose in (("start", scenario.start), ("goal", scenario.goal)):
        _check_inside(where, scenario.world, robot, label, pose)
        hits = footprint_overlaps(scenario.world, robot, pose)
        if not hits:
            continue
        clr, what, move = min(hits, key=lambda f: (f[0], -f[2]))
        exact = _exact_clearance(scenario.world, robot, pose) if clr > -np.inf else -np.inf
        if clr == -np.inf:
            said = f"holds part of {what} (the pose is inside an obstacle for this robot)"
        elif exact > 0:  # clear, but nearer than the planners' check tells apart from touching
            said = (
                f"comes within {1e3 * exact:.1f} mm of {what}, which the planners' collision check does not tell "
                f"apart from touching (it reads {1e3 * clr:.1f} mm, erring up to {500 * DEFAULT_TOLERANCE:g} mm on "
                "the safe side)"
            )
        else:
            said = f"overlaps {what} by {-1e3 * exact:.1f} mm (the planners' check reads {clr:.3f} m)"
        reach = f" (the {robot.name} reaches {robot.radius:.3f} m from its centre)" if clr == -np.inf else ""
        head = (
            f"{where}: field '{label}.pose': {[round(v, 6) for v in pose.as_array().tolist()]} is not free for "
            f"robot {robot.name!r}: its footprint there {said}"
        )
        if len(hits) > 1:  # moved away from one it may meet another (a slot narrower than the robot): no distance
            others = " and ".join(h[1] for h in hits if h[1] != what)
            raise ScenarioError(
                f"{head}, and overlaps {others} too; move the {label} clear of all of them (the {robot.name}'s "
                f"footprint is {_footprint_size(robot)}), or turn it"
            )
        raise ScenarioError(
            f"{head}; move the {label} more than {math.ceil(max(move, 0.001) * 1e3 - 1e-9) / 1e3:.3f} m away from "
            f"{'them' if what.startswith('the walls') else 'it'}{reach}"
        )


def _footprint_size(robot: RobotSpec) -> str:
    """The footprint's extent, as a message says it: "0.178 m across, 0.152 m long"."""
    (x0, y0), (x1, y1) = robot.footprint.min(axis=0), robot.footprint.max(axis=0)
    return f"{y1 - y0:.3f} m across, {x1 - x0:.3f} m long"


def _scenario_robot(scenario: Scenario) -> RobotSpec:
    """The scenario's robot, loaded.

    Raises:
        ConfigError: ``Scenario.robot`` is neither a robot's name nor the path of an MJCF file (the message lists
            the names).
    """
    name = scenario.robot
    if name not in ROBOTS and not (Path(name).suffix == ".xml" and Path(name).is_file()):
        check_robot_name(f"{scenario_source(scenario)}: Scenario.robot", name)
    return load_robot(name)


def _check_inside(where: str, world: World, robot: RobotSpec, label: str, pose: Pose2D) -> None:
    """Refuse a start or goal (``label``) whose position is not inside the world's bounds: the robot would stand
    outside its walls (beyond the map the planners search).

    Raises:
        ScenarioError: Naming the field, the pose, the bounds and how far inside to move it.
    """
    if float(world.wall_distance(pose.xy)[0]) > 0:
        return
    raise ScenarioError(
        f"{where}: field '{label}.pose': {[round(v, 6) for v in pose.as_array().tolist()]} lies outside the world "
        f"(the map), whose bounds are {span(*world.bounds)}: move the "
        f"{label} inside them, more than {robot.radius:.3f} m from every wall (the {robot.name} reaches that far "
        "from its centre), or widen the world's bounds"
    )


def random_scenario(robot: str, seed: int) -> Scenario:
    """A world no scenario was tuned on: a 6 x 6 m arena with seven circles and boxes (radius or
    half-width 0.2-0.5 m) drawn from ``seed``, kept clear of the start corner (-2.4, -2.4) and the
    goal corner (2.4, 2.4); start and goal headings drawn too. Named ``random<seed>`` (the name
    :func:`load_scenario` and the commands' ``--scenario`` take), any robot may drive it; planned by
    Hybrid-A* unless another planner is chosen (``nhsim simulate --scenario random7`` plans it).

    Args:
        robot: Robot name (a key of :data:`planning.core.robot.ROBOTS`).
        seed: Seed of the draw, an integer >= 0 (the one ``random<seed>`` names); same seed, same world.

    Raises:
        ConfigError: An unknown robot (the message lists the names), or a seed that is not an integer >= 0.
    """
    robot = check_robot_name("random_scenario", robot)
    fix = "the world random<N> is drawn from seed N, e.g. random_scenario('turtlebot3', 7) is random7"
    seed = check_number("random_scenario: seed", seed, integer=True, at_least=0, fix=fix)
    rng = np.random.default_rng(1000 + seed)
    obstacles: list[Obstacle] = []
    while len(obstacles) < 7:
        c = (float(rng.uniform(-2.2, 2.2)), float(rng.uniform(-2.2, 2.2)))
        r = float(rng.uniform(0.2, 0.5))
        if min(np.hypot(c[0] + 2.4, c[1] + 2.4), np.hypot(c[0] - 2.4, c[1] - 2.4)) > r + 0.6:
            kind = rng.random() < 0.6
            obstacles.append(Circle(c, r) if kind else Box(c, (2 * r, r), float(rng.uniform(0, 3))))
    start = Pose2D(-2.4, -2.4, float(rng.uniform(-3, 3)))
    goal = Pose2D(2.4, 2.4, float(rng.uniform(-3, 3)))
    return Scenario(
        name=f"random{seed}",
        robot=robot,
        world=World((-3, 3, -3, 3), tuple(obstacles)),
        start=start,
        goal=goal,
        robots=(robot, *(r for r in ROBOTS if r != robot)),
        planner="hybrid-a-star",
    )
