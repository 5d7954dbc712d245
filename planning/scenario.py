"""Scenarios: a world, a robot, a start and a goal, loaded from TOML files.

Format version 1 (see README.md): top-level ``name``, ``robot``, ``description``, ``version``;
tables ``[world]`` (``bounds``, ``[[world.obstacles]]``), ``[start]`` (``pose``) and ``[goal]``
(``pose``, ``position_tolerance``, ``heading_tolerance``); optional ``[planners.<name>]`` tables of
keyword options for a registered planner in this scenario (e.g. ``[planners.birrt]`` with
``steering = "reeds_shepp"``), checked against that planner's options when the file is read. Every
problem is reported before anything runs, naming the file, the field and what is expected.
"""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from planning.core.geometry import Pose2D
from planning.core.maps import load_map_table
from planning.core.robot import MODELS_DIR, ROBOT_FILES
from planning.core.world import Box, Circle, Ellipse, Obstacle, Polygon, World
from planning.errors import ConfigError, ScenarioError

SCENARIOS_DIR = MODELS_DIR / "scenarios"
DEFAULT_POSITION_TOLERANCE = 0.05
DEFAULT_HEADING_TOLERANCE = 0.1

_TOP_KEYS = {"name", "robot", "description", "version", "world", "start", "goal", "planner", "robots", "planners"}
_WORLD_KEYS = {"bounds", "obstacles", "map"}
_OBSTACLE_KEYS: dict[str, tuple[set[str], set[str]]] = {
    # type: (required, optional)
    "circle": ({"center", "radius"}, set()),
    "ellipse": ({"center", "radii"}, {"angle"}),
    "box": ({"center", "size"}, {"angle"}),
    "polygon": ({"vertices"}, set()),
}

#: Hooks that turn a ``[world.map]`` table into obstacles: fn(table, scenario_dir, where) -> obstacles.
MAP_LOADERS: dict[str, Callable[[Mapping[str, Any], Path, str], list[Obstacle]]] = {"image": load_map_table}


@dataclass(frozen=True)
class Scenario:
    """A planning and tracking problem.

    Attributes:
        name: Scenario name.
        robot: Robot registry name.
        world: Bounds and obstacles.
        start: Start pose.
        goal: Goal pose.
        position_tolerance: Goal region radius [m].
        heading_tolerance: Goal heading tolerance [rad].
        description: Free text.
        planner: The planner this scenario is meant for by default, if any.
        robots: Robots the scenario suits (defaults to ``(robot,)``).
        planner_options: Planner name -> keyword options for that planner in this scenario (the
            ``[planners.<name>]`` tables).
        source: The file it was loaded from, if any.
    """

    name: str
    robot: str
    world: World
    start: Pose2D
    goal: Pose2D
    position_tolerance: float = DEFAULT_POSITION_TOLERANCE
    heading_tolerance: float = DEFAULT_HEADING_TOLERANCE
    description: str = ""
    planner: str | None = None
    robots: tuple[str, ...] = ()
    planner_options: Mapping[str, Mapping[str, Any]] = field(default_factory=dict, hash=False)
    source: Path | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if not self.robots:
            object.__setattr__(self, "robots", (self.robot,))

    def with_robot(self, robot: str) -> Scenario:
        """The same scenario for another robot."""
        if robot not in ROBOT_FILES:
            raise ScenarioError(f"unknown robot {robot!r}: choose one of {', '.join(sorted(ROBOT_FILES))}")
        return dataclasses.replace(self, robot=robot)

    def options_for(self, planner: str) -> dict[str, Any]:
        """Keyword options this scenario gives ``planner`` (a copy; empty if none)."""
        return dict(self.planner_options.get(planner, {}))


class _Reader:
    """Typed access to a TOML table that names the file and field in every error."""

    def __init__(self, where: str) -> None:
        self.where = where

    def fail(self, field_name: str, expected: str, got: Any = None) -> ScenarioError:
        got_txt = "" if got is None else f", got {got!r}"
        return ScenarioError(f"{self.where}: field '{field_name}': expected {expected}{got_txt}")

    def number(self, table: Mapping[str, Any], key: str, ctx: str, *, positive: bool = False) -> float:
        val = table[key]
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not np.isfinite(val):
            raise self.fail(f"{ctx}{key}", "a finite number", val)
        if positive and val <= 0:
            raise self.fail(f"{ctx}{key}", "a number > 0", val)
        return float(val)

    def vector(self, table: Mapping[str, Any], key: str, ctx: str, n: int) -> tuple[float, ...]:
        val = table[key]
        if (
            not isinstance(val, list)
            or len(val) != n
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in val)
            or not all(np.isfinite(v) for v in val)
        ):
            raise self.fail(f"{ctx}{key}", f"a list of {n} finite numbers", val)
        return tuple(float(v) for v in val)

    def keys(self, table: Mapping[str, Any], ctx: str, required: set[str], optional: set[str]) -> None:
        if not isinstance(table, Mapping):
            raise self.fail(ctx.rstrip("."), "a table", table)
        unknown = set(table) - required - optional
        if unknown:
            raise ScenarioError(
                f"{self.where}: unknown key(s) {', '.join(sorted(repr(k) for k in unknown))} in "
                f"[{ctx.rstrip('.') or 'top level'}]; allowed: {', '.join(sorted(required | optional))}"
            )
        missing = required - set(table)
        if missing:
            raise ScenarioError(f"{self.where}: missing field(s) {', '.join(sorted(repr(ctx + k) for k in missing))}")


def _obstacle(r: _Reader, table: Mapping[str, Any], ctx: str) -> Obstacle:
    if not isinstance(table, Mapping) or "type" not in table:
        raise r.fail(f"{ctx}type", f"one of {', '.join(_OBSTACLE_KEYS)}")
    kind = table["type"]
    if kind not in _OBSTACLE_KEYS:
        raise r.fail(f"{ctx}type", f"one of {', '.join(_OBSTACLE_KEYS)}", kind)
    req, opt = _OBSTACLE_KEYS[kind]
    r.keys(table, ctx, req | {"type"}, opt)
    angle = r.number(table, "angle", ctx) if "angle" in table else 0.0
    cx, cy = r.vector(table, "center", ctx, 2) if "center" in table else (0.0, 0.0)
    if kind == "circle":
        return Circle((cx, cy), r.number(table, "radius", ctx, positive=True))
    if kind == "ellipse":
        a, b = r.vector(table, "radii", ctx, 2)
        if a <= 0 or b <= 0:
            raise r.fail(f"{ctx}radii", "two numbers > 0", [a, b])
        return Ellipse((cx, cy), (a, b), angle)
    if kind == "box":
        sx, sy = r.vector(table, "size", ctx, 2)
        if sx <= 0 or sy <= 0:
            raise r.fail(f"{ctx}size", "two numbers > 0 (full extents)", [sx, sy])
        return Box((cx, cy), (sx, sy), angle)
    verts = table["vertices"]
    if not isinstance(verts, list) or len(verts) < 3:
        raise r.fail(f"{ctx}vertices", "a list of at least 3 [x, y] pairs", verts)
    pts = tuple(r.vector({"v": v}, "v", f"{ctx}vertices[{i}].", 2) for i, v in enumerate(verts))
    try:
        return Polygon(pts)  # type: ignore[arg-type]
    except ValueError as exc:
        raise r.fail(f"{ctx}vertices", f"a simple polygon ({exc})", verts) from exc


def _planner_options(r: _Reader, table: Any) -> dict[str, dict[str, Any]]:
    """Validate ``[planners.<name>]`` tables: known planner names, options the planner accepts."""
    from planning.planners.registry import PLANNERS, make_planner  # imported here: it loads on first use

    if not isinstance(table, Mapping):
        raise r.fail("planners", "a table of [planners.<name>] tables of keyword options", table)
    out: dict[str, dict[str, Any]] = {}
    for name, opts in table.items():
        if name not in PLANNERS:
            raise r.fail(f"planners.{name}", f"a registered planner name ({', '.join(sorted(PLANNERS))})", name)
        if not isinstance(opts, Mapping):
            raise r.fail(f"planners.{name}", "a table of keyword options", opts)
        try:
            make_planner(name, **opts)
        except (ConfigError, ValueError, TypeError) as exc:
            raise ScenarioError(
                f"{r.where}: field 'planners.{name}': options rejected by planner {name!r}: {exc}"
            ) from exc
        out[name] = dict(opts)
    return out


def _pose(r: _Reader, table: Mapping[str, Any], ctx: str) -> Pose2D:
    return Pose2D(*r.vector(table, "pose", ctx, 3))


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
    r = _Reader(where)
    r.keys(data, "", {"world", "start", "goal"}, _TOP_KEYS)
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise r.fail("name", "a non-empty string", name)
    robot = data.get("robot", "turtlebot3")
    if robot not in ROBOT_FILES:
        raise r.fail("robot", f"one of {', '.join(sorted(ROBOT_FILES))}", robot)
    robots = data.get("robots", [robot])
    if not isinstance(robots, list) or not all(x in ROBOT_FILES for x in robots) or not robots:
        raise r.fail("robots", f"a list of robot names from {', '.join(sorted(ROBOT_FILES))}", robots)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise r.fail("description", "a string", description)
    version = data.get("version", 1)
    if version != 1:
        raise r.fail("version", "1 (the only format version this nhsim reads)", version)
    planner = data.get("planner")
    if planner is not None and not isinstance(planner, str):
        raise r.fail("planner", "a planner name", planner)
    planner_options = _planner_options(r, data["planners"]) if "planners" in data else {}

    world_t = data["world"]
    r.keys(world_t, "world.", {"bounds"}, _WORLD_KEYS)
    xmin, xmax, ymin, ymax = r.vector(world_t, "bounds", "world.", 4)
    if not (xmin < xmax and ymin < ymax):
        raise r.fail("world.bounds", "[xmin, xmax, ymin, ymax] with xmin < xmax and ymin < ymax", world_t["bounds"])
    obstacles: list[Obstacle] = []
    obs_list = world_t.get("obstacles", [])
    if not isinstance(obs_list, list):
        raise r.fail("world.obstacles", "an array of tables ([[world.obstacles]])", obs_list)
    for i, ot in enumerate(obs_list):
        obstacles.append(_obstacle(r, ot, f"world.obstacles[{i}]."))
    if "map" in world_t:
        loader = MAP_LOADERS.get("image")
        if loader is None:
            raise r.fail("world.map", "no map loader is available in this installation")
        obstacles.extend(loader(world_t["map"], base_dir, where))
    world = World((xmin, xmax, ymin, ymax), tuple(obstacles))

    start_t, goal_t = data["start"], data["goal"]
    r.keys(start_t, "start.", {"pose"}, set())
    r.keys(goal_t, "goal.", {"pose"}, {"position_tolerance", "heading_tolerance"})
    start = _pose(r, start_t, "start.")
    goal = _pose(r, goal_t, "goal.")
    ptol = (
        r.number(goal_t, "position_tolerance", "goal.", positive=True)
        if "position_tolerance" in goal_t
        else DEFAULT_POSITION_TOLERANCE
    )
    htol = (
        r.number(goal_t, "heading_tolerance", "goal.", positive=True)
        if "heading_tolerance" in goal_t
        else DEFAULT_HEADING_TOLERANCE
    )
    for label, pose in (("start", start), ("goal", goal)):
        if not (xmin < pose.x < xmax and ymin < pose.y < ymax):
            raise r.fail(
                f"{label}.pose", f"a position inside the world bounds {list(world.bounds)}", list(pose.as_array())
            )
        d = float(world.obstacle_distance(pose.xy)[0])
        if d <= 0:
            idx = int(np.argmin([o.signed_distance(pose.xy)[0] for o in world.obstacles]))
            raise ScenarioError(
                f"{where}: field '{label}.pose': {list(pose.as_array())} lies inside "
                f"world.obstacles[{idx}] ({world.obstacles[idx].kind}); move it into free space"
            )
    return Scenario(
        name=name, robot=robot, world=world, start=start, goal=goal, position_tolerance=ptol,
        heading_tolerance=htol, description=description, planner=planner, robots=tuple(robots),
        planner_options=planner_options,
    )  # fmt: skip


def load_scenario_file(path: str | Path) -> Scenario:
    """Load and validate a scenario TOML file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(f"cannot read scenario file {p}: {exc.strerror or exc}") from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{p}: not valid TOML: {exc}") from exc
    sc = parse_scenario(data, where=str(p), default_name=p.stem, base_dir=p.parent)
    return dataclasses.replace(sc, source=p)


def builtin_scenarios() -> list[str]:
    """Names of the scenarios shipped in ``models/scenarios``."""
    return sorted(p.stem for p in SCENARIOS_DIR.glob("*.toml"))


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a built-in scenario by name, or a scenario file by path.

    Raises:
        ScenarioError: Unknown name (the message lists the built-in ones) or a bad file.
    """
    text = str(name_or_path)
    p = Path(text)
    if p.suffix == ".toml" or p.exists():
        if not p.exists():
            raise ScenarioError(f"scenario file {p} does not exist")
        return load_scenario_file(p)
    candidate = SCENARIOS_DIR / f"{text}.toml"
    if candidate.exists():
        return load_scenario_file(candidate)
    raise ScenarioError(
        f"unknown scenario {text!r}: give a path to a .toml file or one of: {', '.join(builtin_scenarios())}"
    )
