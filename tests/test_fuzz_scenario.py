"""Property-based tests of the scenario loader and of the CLI on broken scenario files.

Documents are drawn valid (worlds of circles, ellipses, boxes, star-shaped polygons and a small map
image, with a start and a goal inside the bounds) and then, most of the time, broken by one to three
mutations: a key removed, an unknown key added, a value replaced by one of the wrong type or a
non-finite number, a polygon made degenerate (a repeated vertex, collinear, crossing edges), the
start or goal moved outside the world, or the TOML text itself cut or garbled.

Properties: the loader returns a scenario or raises ScenarioError, nothing else; a loaded scenario
holds what the file says, only finite numbers, a start and a goal that are free, and obstacles whose
signed distance is finite everywhere; an untouched document is refused only for a start or goal that
lies inside an obstacle. The CLI (``plan``, ``simulate``) on a file the loader refuses exits 2 and
writes nothing.
"""

from __future__ import annotations

import atexit
import copy
import dataclasses
import io
import math
import shutil
import tempfile
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import event, find
from hypothesis import strategies as st
from PIL import Image

from planning.core.scenario_type import Scenario
from planning.errors import ScenarioError
from planning.scenario import load_scenario_file, scenario_with_robot
from tests.fuzz_helpers import (
    ANY_VALUE,
    FAST,
    NON_FINITE,
    TEXT,
    coordinate,
    expect_nhsim_errors,
    fast_and_slow,
    to_toml,
)

#: Where the drawn files go (one folder for the module, removed at exit; each example overwrites its own files).
_WORKDIR = Path(tempfile.mkdtemp(prefix="nhsim-fuzz-"))
atexit.register(shutil.rmtree, _WORKDIR, ignore_errors=True)
MAP_IMAGE = "map.png"


@dataclasses.dataclass
class Doc:
    """A drawn scenario document and whether it was broken on purpose."""

    data: dict[str, Any]
    mutations: list[str]
    garble: tuple[int, str] | None = None  # (cut position, inserted text) applied to the TOML text

    def text(self) -> str:
        text = to_toml(self.data)
        if self.garble is not None:
            at, insert = self.garble
            at %= len(text) + 1
            text = text[:at] + insert
        return text


# ------------------------------------------------------------------------------------- documents
@st.composite
def polygon_vertices(draw: st.DrawFn, cx: float, cy: float) -> list[list[float]]:
    """A star-shaped (hence simple) polygon about (cx, cy): k angles 2 pi i / k jittered by under a
    fifth of the spacing, radii in [0.1, 1] m."""
    k = draw(st.integers(3, 8))
    spacing = 2.0 * math.pi / k
    out = []
    for i in range(k):
        a = spacing * (i + draw(st.floats(-0.2, 0.2)))
        r = draw(st.floats(0.1, 1.0))
        out.append([cx + r * math.cos(a), cy + r * math.sin(a)])
    return out


@st.composite
def obstacle(draw: st.DrawFn, bounds: list[float]) -> dict[str, Any]:
    """A valid obstacle table inside ``bounds``."""
    cx, cy = draw(coordinate(bounds[0], bounds[1])), draw(coordinate(bounds[2], bounds[3]))
    kind = draw(st.sampled_from(["circle", "ellipse", "box", "polygon"]))
    size = st.floats(0.05, 1.5)
    table: dict[str, Any] = {"type": kind}
    if kind == "polygon":
        table["vertices"] = draw(polygon_vertices(cx, cy))
        return table
    table["center"] = [cx, cy]
    if kind == "circle":
        table["radius"] = draw(size)
    else:
        table["radii" if kind == "ellipse" else "size"] = [draw(size), draw(size)]
        if draw(st.booleans()):
            table["angle"] = draw(st.floats(-7.0, 7.0))
    return table


def _write_map_image(pixels: list[list[int]]) -> None:
    Image.fromarray(np.asarray(pixels, dtype=np.uint8), mode="L").save(_WORKDIR / MAP_IMAGE)


@st.composite
def valid_document(draw: st.DrawFn) -> dict[str, Any]:
    """A scenario document of valid shape (its start or goal may still lie inside an obstacle)."""
    x0, y0 = draw(coordinate(-10, 10)), draw(coordinate(-10, 10))
    bounds = [x0, x0 + draw(st.floats(0.5, 12.0)), y0, y0 + draw(st.floats(0.5, 12.0))]
    world: dict[str, Any] = {"bounds": bounds}
    if draw(st.booleans()):
        world["obstacles"] = draw(st.lists(obstacle(bounds), max_size=5))
    if draw(st.integers(0, 5)) == 0:
        side = draw(st.integers(1, 10))
        _write_map_image(
            draw(st.lists(st.lists(st.sampled_from([0, 255]), min_size=side, max_size=side), min_size=1, max_size=10))
        )
        world["map"] = {"image": MAP_IMAGE, "resolution": draw(st.floats(0.05, 0.5)), "origin": [x0, y0]}
        world["map"] |= draw(
            st.fixed_dictionaries(
                {}, optional={"threshold": st.floats(0.05, 1.0), "shape": st.sampled_from(["box", "polygon"])}
            )
        )

    def pose() -> list[float]:
        margin_x, margin_y = 1e-3 * (bounds[1] - bounds[0]), 1e-3 * (bounds[3] - bounds[2])
        return [
            draw(coordinate(bounds[0] + margin_x, bounds[1] - margin_x)),
            draw(coordinate(bounds[2] + margin_y, bounds[3] - margin_y)),
            draw(st.floats(-10.0, 10.0)),
        ]

    doc: dict[str, Any] = {"world": world, "start": {"pose": pose()}, "goal": {"pose": pose()}}
    goal_extra = {"position_tolerance": st.floats(1e-3, 1.0), "heading_tolerance": st.floats(1e-3, 3.0)}
    doc["goal"] |= draw(st.fixed_dictionaries({}, optional=goal_extra))
    header = {
        "name": TEXT.filter(bool),
        "robot": st.sampled_from(["turtlebot3", "edumip"]),
        "description": TEXT,
        "version": st.just(1),
        "planner": st.sampled_from(["rrt", "birrt", "optim"]),
        "planners": st.sampled_from([{}, {"birrt": {"steering": "reeds_shepp"}}, {"rrt-star": {"goal_bias": 0.1}}]),
        "sensors": st.sampled_from([{}, {"fix_rate": 5.0}]),
    }
    doc |= draw(st.fixed_dictionaries({}, optional=header))
    if "robot" in doc and draw(st.booleans()):
        doc["robots"] = [doc["robot"]]
    return doc


def _places(node: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Paths (keys and list indices) of every value inside ``node``."""
    out: list[tuple[Any, ...]] = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else []
    for key, child in items:
        out.append((*path, key))
        out.extend(_places(child, (*path, key)))
    return out


def _parent(doc: dict[str, Any], path: tuple[Any, ...]) -> Any:
    node: Any = doc
    for key in path[:-1]:
        node = node[key]
    return node


@st.composite
def mutate(draw: st.DrawFn, doc: dict[str, Any]) -> str:
    """Break ``doc`` in place in one way; returns what was done."""
    kind = draw(st.sampled_from(["drop", "unknown", "replace", "non_finite", "polygon", "outside", "list"]))
    places = _places(doc)
    world, start, goal = doc.get("world"), doc.get("start"), doc.get("goal")
    intact = isinstance(world, dict) and isinstance(world.get("bounds"), list) and len(world["bounds"]) == 4
    intact = intact and all(type(v) in (int, float) and math.isfinite(v) for v in world["bounds"])
    intact = intact and all(isinstance(t, dict) and isinstance(t.get("pose"), list) for t in (start, goal))
    intact = intact and isinstance(world.get("obstacles", []), list)
    if kind in ("polygon", "outside") and not intact:
        kind = "unknown"
    if not places:
        kind = "unknown"
    if kind == "polygon":
        cx, cy = draw(coordinate(-10, 10)), 0.0
        verts = draw(polygon_vertices(cx, cy))
        how = draw(st.sampled_from(["repeat", "collinear", "bowtie", "two", "zero"]))
        if how == "repeat":
            i = draw(st.integers(0, len(verts) - 1))
            verts.insert(draw(st.integers(0, len(verts))), list(verts[i]))
        elif how == "collinear":
            verts = [[cx + t, 2.0 * t] for t in draw(st.lists(st.floats(-1, 1), min_size=3, max_size=5, unique=True))]
        elif how == "bowtie":
            verts = [[cx, 0.0], [cx + 1.0, 1.0], [cx + 1.0, 0.0], [cx, 1.0]]
        elif how == "two":
            verts = verts[:2]
        else:
            verts = [[cx, cy]] * 3
        doc["world"].setdefault("obstacles", []).append({"type": "polygon", "vertices": verts})
        return f"polygon:{how}"
    if kind == "outside":
        which = draw(st.sampled_from(["start", "goal"]))
        b = doc["world"]["bounds"]
        x = draw(st.sampled_from([b[0], b[1], b[0] - 1.0, b[1] + 5.0, 1e9]))
        doc[which]["pose"] = [x, 0.0, 0.0]
        return f"outside:{which}"
    if kind == "unknown":
        tables = [doc] + [_parent(doc, p)[p[-1]] for p in places if isinstance(_parent(doc, p)[p[-1]], dict)]
        table = draw(st.sampled_from(tables))
        key = draw(TEXT.filter(lambda k: k not in table))
        table[key] = draw(ANY_VALUE)
        return f"unknown:{key}"
    path = draw(st.sampled_from(places))
    parent = _parent(doc, path)
    if kind == "drop":
        del parent[path[-1]]
    elif kind == "list":
        parent[path[-1]] = draw(st.lists(ANY_VALUE, max_size=5))
    else:
        parent[path[-1]] = draw(NON_FINITE if kind == "non_finite" else ANY_VALUE)
    return f"{kind}:{path}"


@st.composite
def documents(draw: st.DrawFn, broken_only: bool = False) -> Doc:
    """A document, untouched about one time in four (never with ``broken_only``), else broken."""
    data = draw(valid_document())
    if not broken_only and draw(st.integers(0, 3)) == 0:
        return Doc(data, [])
    data = copy.deepcopy(data)
    mutations = [draw(mutate(data)) for _ in range(draw(st.integers(1, 3)))]
    garble = None
    if draw(st.integers(0, 5)) == 0:
        garble = (draw(st.integers(0, 10**6)), draw(st.sampled_from(["", "[", "= 1", '"', "x = [1,", "]]"])))
    return Doc(data, mutations, garble)


# ----------------------------------------------------------------------------------- properties
def _check_loaded(sc: Scenario, doc: Doc) -> None:
    """What a loaded scenario must hold."""
    data = doc.data
    if doc.garble is None:  # a garbled text may still parse, but to a document other than ``data``
        assert list(sc.world.bounds) == data["world"]["bounds"]
        for pose, written in ((sc.start, data["start"]["pose"]), (sc.goal, data["goal"]["pose"])):
            assert [pose.x, pose.y] == written[:2]
            # the heading's direction, in (-pi, pi]: as written when it was in it already
            assert -math.pi < pose.theta <= math.pi
            if -math.pi < written[2] <= math.pi:
                assert pose.theta == written[2]
            assert abs(math.remainder(pose.theta - written[2], 2 * math.pi)) < 1e-9
        assert len(sc.world.obstacles) >= len(data["world"].get("obstacles", []))
    numbers = [*sc.world.bounds, *sc.start.as_array(), *sc.goal.as_array(), sc.position_tolerance, sc.heading_tolerance]
    assert all(math.isfinite(v) for v in numbers), numbers
    assert sc.position_tolerance > 0 and sc.heading_tolerance > 0
    xmin, xmax, ymin, ymax = sc.world.bounds
    for pose in (sc.start, sc.goal):
        assert xmin < pose.x < xmax and ymin < pose.y < ymax
        assert float(sc.world.obstacle_distance(pose.xy)[0]) > 0
    grid = np.stack(np.meshgrid(np.linspace(xmin, xmax, 9), np.linspace(ymin, ymax, 9)), axis=-1).reshape(-1, 2)
    for i, obs in enumerate(sc.world.obstacles):
        d = obs.signed_distance(grid)
        assert np.all(np.isfinite(d)), f"obstacle {i} ({obs.kind}) has a non-finite signed distance"
        assert all(math.isfinite(v) for v in obs.bounding_box()) and obs.min_feature > 0


def loader_property(doc: Doc) -> None:
    """The loader returns a scenario that holds what the file says, or raises ScenarioError."""
    path = _WORKDIR / "scenario.toml"
    path.write_text(doc.text(), encoding="utf-8")
    sc, err = expect_nhsim_errors(lambda: load_scenario_file(path))
    event("untouched" if not doc.mutations else "broken", "refused" if err is not None else "loaded")
    if err is not None:
        assert isinstance(err, ScenarioError), f"{type(err).__name__}: {err}"
        assert str(path) in str(err), f"the message does not name the file: {err}"
        if not doc.mutations:
            assert "lies inside" in str(err), f"an untouched document was refused: {err}"
        return
    _check_loaded(sc, doc)


def _run_cli(argv: list[str]) -> int:
    from sim.cli.main import main

    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
        return main(argv)


def cli_property(doc: Doc) -> None:
    """``plan`` and ``simulate`` on a file the loader refuses, or whose start or goal its robot does not
    fit (:func:`scenario_with_robot`, as the commands check it once the robot is known), exit 2 and write
    nothing."""
    path = _WORKDIR / "cli.toml"
    path.write_text(doc.text(), encoding="utf-8")
    _, err = expect_nhsim_errors(lambda: scenario_with_robot(load_scenario_file(path), None))
    out = Path(tempfile.mkdtemp(dir=_WORKDIR))
    plan = ["plan", "--scenario", str(path), "--planner", "rrt", "--time-limit", "0.05", "--quiet"]
    code = _run_cli([*plan, "--json", str(out / "plan.json"), "--plot", str(out / "plan.png")])
    if err is None:
        assert code in (0, 1)
        return
    assert code == 2 and not any(out.iterdir()), (code, sorted(out.iterdir()))
    code = _run_cli(["simulate", "--scenario", str(path), "--reference", "line", "--video", str(out / "x.mp4")])
    assert code == 2 and not any(out.iterdir()), (code, sorted(out.iterdir()))


test_loader_fast, test_loader_slow = fast_and_slow(documents(), loader_property, fast=60)
test_cli_fast, test_cli_slow = fast_and_slow(documents(broken_only=True), cli_property, fast=10)


def test_the_strategies_draw_loadable_scenarios() -> None:
    """The untouched documents load often enough for the properties of a loaded scenario to be tested."""
    doc = find(documents(), lambda d: not d.mutations and _loads(d), settings=FAST)
    assert not doc.mutations and _loads(doc)


def _loads(doc: Doc) -> bool:
    path = _WORKDIR / "probe.toml"
    path.write_text(doc.text(), encoding="utf-8")
    try:
        load_scenario_file(path)
    except ScenarioError:
        return False
    return True
