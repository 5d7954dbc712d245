"""Maps as ROS reads them: a map YAML file (written by Nav2's or ROS 1's ``map_saver``, SLAM Toolbox, Cartographer's
exporter) and the image it names, turned into obstacles.

The YAML's fields are read as Nav2's ``nav2_map_server`` reads them (``map_io.cpp``, ``loadMapYaml`` and
``loadMapFromFile``):

* ``image``: the image file, relative to the YAML file's folder; ``resolution`` [m/px];
* ``origin: [x, y, yaw]``: the pose of the image's bottom-left corner in the world [m, m, rad]; a yaw other than 0
  turns the map about that corner (Nav2's costmaps ignore it; here the obstacles turn with it);
* ``negate`` (0 or 1, default 0), ``occupied_thresh`` and ``free_thresh`` (0 <= free < occupied <= 1), ``mode``
  (``trinary``, the default; ``scale``; ``raw``).

A pixel's shade is the mean of its red, green and blue levels in [0, 1] (and, in trinary mode, of its alpha too),
its occupancy ``1 - shade`` (``shade`` when negated). In trinary mode a pixel of occupancy above ``occupied_thresh``
is occupied (100), below ``free_thresh`` free (0), else unknown (-1), as Humble's map_server compares them (Jazzy's
and later ones, since Nav2 #5071, take a pixel exactly at a threshold as past it: the same cells but for such
pixels; ``occupied_thresh: 1``, where the two differ wholly, is refused naming 0.99); scale mode makes a pixel that
is not opaque unknown and maps occupancies between the thresholds to 1..99; raw mode takes ``round(255 shade)`` as
the cell's value (0..100, else unknown). :func:`occupancy_grid` gives these cells as map_server serves them on
``/map``.

The obstacles are the cells Nav2's costmap takes as lethal with its default ``lethal_cost_threshold`` (100), and,
with ``unknown = "obstacle"``, the unknown cells as well (Nav2's planners plan through unknown space by default,
``allow_unknown: true``, hence ``unknown = "free"`` by default). Each 4-connected region of them becomes an
obstacle as an image map's dark region does (:func:`planning.core.maps.obstacles_from_mask`).

A scenario reads such a map with ``[world.map] yaml = "house.yaml"`` (relative to the scenario file), and may
leave out ``[world] bounds``: the world is then the map's extent.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import NDArray

from planning.core.checks import heading_beyond, is_number
from planning.core.documents import GivenTwice, yaml_loader
from planning.core.files import undecodable_at
from planning.core.maps import (
    MapObstacles,
    MapShape,
    decoded_image,
    has_alpha,
    is_sixteen_bit,
    map_shape,
    obstacles_from_mask,
    sixteen_bit,
)
from planning.core.tables import TableReader, toml_value
from planning.core.world import Box, Obstacle, Polygon
from planning.errors import ScenarioError

FloatArray = NDArray[np.float64]
MapMode = Literal["trinary", "scale", "raw"]
Unknown = Literal["free", "obstacle"]

#: Occupancy grid cells as ``nav_msgs/OccupancyGrid`` holds them.
OCCUPIED, FREE, UNKNOWN = 100, 0, -1
_MODES = ("trinary", "scale", "raw")
_REQUIRED = ("image", "resolution", "origin", "occupied_thresh", "free_thresh")
#: The fields of an image map's table that a map YAML gives itself.
_IMAGE_FIELDS = {"image", "resolution", "origin", "threshold"}


@dataclass(frozen=True)
class MapYaml:
    """A map YAML file's fields (see the module docstring). image: the image's path, resolved against the YAML's
    folder; origin: (x [m], y [m], yaw [rad]) of the image's bottom-left corner."""

    path: Path
    image: Path
    resolution: float
    origin: tuple[float, float, float]
    occupied_thresh: float
    free_thresh: float
    negate: bool = False
    mode: MapMode = "trinary"


def _fail(path: Path, field: str, expected: str, got: Any) -> ScenarioError:
    return ScenarioError(f"map YAML {path}: field '{field}': expected {expected}, got {toml_value(got)}")


def _number(path: Path, doc: dict[str, Any], key: str) -> float:
    value = doc[key]
    if not is_number(value):
        raise _fail(path, key, "a finite number", value)
    return float(value)


def _parse(path: Path) -> dict[str, Any]:
    """The YAML file's top-level mapping (map_server's own error cases named as such)."""
    import yaml  # loaded when a map YAML is read

    if path.is_dir() or not path.is_file():
        what = "is a folder" if path.is_dir() else "does not exist"
        raise ScenarioError(f"map YAML {path} {what}; give the map's .yaml file (relative to the scenario file)")
    try:
        doc = yaml.load(path.read_text(encoding="utf-8"), Loader=yaml_loader())
    except UnicodeDecodeError as exc:
        raise ScenarioError(
            f"map YAML {path} is not text ({undecodable_at(exc)}): give the map's .yaml file, which names "
            "its image (an image itself goes in the scenario's [world.map] table as image = ...)"
        ) from exc
    except OSError as exc:
        raise ScenarioError(f"map YAML {path} cannot be read: {exc}") from exc
    except yaml.YAMLError as exc:
        raise ScenarioError(f"map YAML {path} is not valid YAML: {exc}") from exc
    except GivenTwice as exc:
        raise ScenarioError(f"map YAML {path}: {exc}; YAML keys are unique: keep the one meant") from None
    if not isinstance(doc, dict):
        raise ScenarioError(
            f"map YAML {path} holds {type(doc).__name__}, not a map's fields (image, resolution, origin, negate, "
            "occupied_thresh, free_thresh): is it the map's .yaml file?"
        )
    missing = [key for key in _REQUIRED if key not in doc]
    if missing:
        raise ScenarioError(
            f"map YAML {path}: missing field(s) {', '.join(repr(k) for k in missing)} (a map YAML names its image, "
            "resolution, origin [x, y, yaw], occupied_thresh and free_thresh, as map_saver writes them)"
        )
    return doc


def read_map_yaml(path: str | Path) -> MapYaml:
    """A map YAML file's fields, checked (fields nhsim does not use, such as a 3-D map's, are ignored as
    map_server ignores them).

    Raises:
        ScenarioError: The file is missing or is not valid YAML; a field is missing or out of range.
    """
    p = Path(path)
    doc = _parse(p)
    image = doc["image"]
    if not isinstance(image, str) or not image:
        raise _fail(p, "image", "the image file's path (relative to the YAML file)", image)
    resolution = _number(p, doc, "resolution")
    if resolution <= 0:
        raise _fail(p, "resolution", "a pixel size > 0 [m/px]", resolution)
    origin = doc["origin"]
    if not (isinstance(origin, list) and len(origin) == 3 and all(is_number(v) for v in origin)):
        raise _fail(p, "origin", "[x, y, yaw] of the image's bottom-left corner [m, m, rad]", origin)
    if heading_beyond(float(origin[2])):  # 100 rad, or 90 meant as degrees: refused as a scenario's heading is
        raise _fail(p, "origin", f"[x, y, yaw], the yaw {heading_beyond(float(origin[2]))}", origin)
    occupied, free = _number(p, doc, "occupied_thresh"), _number(p, doc, "free_thresh")
    if not 0.0 <= free < occupied <= 1.0:
        raise ScenarioError(
            f"map YAML {p}: fields 'free_thresh' {free:g} and 'occupied_thresh' {occupied:g}: expected "
            "0 <= free_thresh < occupied_thresh <= 1 (map_saver writes 0.25 and 0.65)"
        )
    negate = doc.get("negate", 0)
    if negate not in (0, 1):  # True and False are 1 and 0
        raise _fail(p, "negate", "0 or 1", negate)
    if occupied >= 1.0 and doc.get("mode", "trinary") != "raw":  # no shade's occupancy is above 1
        raise ScenarioError(
            f"map YAML {p}: field 'occupied_thresh' 1: no pixel's occupancy is above it, so Humble's map_server reads "
            "no cell as occupied (as here), while Jazzy's and later ones (>=) read black ones: give 0.99 for "
            "black walls"
        )
    given = doc.get("mode", "trinary")
    mode = given.lower() if isinstance(given, str) else given  # map_server's map_mode_from_string lower-cases it
    if mode not in _MODES:
        raise _fail(p, "mode", " or ".join(repr(m) for m in _MODES), given)
    image_path = Path(image) if Path(image).is_absolute() else p.parent / image
    x, y, yaw = (float(v) for v in origin)
    return MapYaml(p, image_path, resolution, (x, y, yaw), occupied, free, bool(negate), cast(MapMode, mode))


def _shade(m: MapYaml) -> tuple[FloatArray, NDArray[np.bool_] | None]:
    """(H, W) shades in [0, 1] of the map's image as map_server computes them (row 0 at the top): the sum of a
    pixel's red, green and blue levels (and its alpha in trinary mode) over their count, over the largest level;
    and where the image is opaque (None: it has no alpha channel)."""
    with decoded_image(m.image, f"the map YAML {m.path}") as (p, im):
        if is_sixteen_bit(im):
            return sixteen_bit(p, np.asarray(im, dtype=float)), None
        if im.mode in ("1", "L"):
            return np.asarray(im.convert("L"), dtype=float) / 255.0, None
        alpha = has_alpha(im)
        levels = np.asarray(im.convert("RGBA" if alpha else "RGB"))
    used = levels if alpha and m.mode == "trinary" else levels[..., :3]
    shade = used.sum(axis=2, dtype=np.int32) / used.shape[2] / 255.0
    return shade, (levels[..., 3] == 255 if alpha else None)


def occupancy_grid(m: MapYaml) -> NDArray[np.int8]:
    """The map's cells as map_server serves them: (H, W) int8, row 0 at the image's top; 100 occupied, 0 free,
    -1 unknown, 1..99 partly occupied (scale mode) or the raw values (raw mode)."""
    shade, opaque = _shade(m)
    if m.mode == "raw":
        value = np.rint(shade * 255.0)
        return np.where((value >= FREE) & (value <= OCCUPIED), value, UNKNOWN).astype(np.int8)
    occ = shade if m.negate else 1.0 - shade
    grid = np.full(occ.shape, UNKNOWN, dtype=np.int8)
    if m.mode == "scale":
        between = (occ - m.free_thresh) / (m.occupied_thresh - m.free_thresh) * 100.0
        grid[:] = np.rint(np.clip(between, 0.0, 100.0)).astype(np.int8)
    grid[occ < m.free_thresh] = FREE
    grid[m.occupied_thresh < occ] = OCCUPIED
    if m.mode == "scale" and opaque is not None:
        grid[~opaque] = UNKNOWN
    return grid


def map_extent(m: MapYaml, size: tuple[int, int]) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) [m] the map's image covers in the world; size: (height, width) [px]."""
    h, w = size
    corners = np.array([(0.0, 0.0), (w, 0.0), (w, h), (0.0, h)]) * m.resolution
    xy = _turned(corners, m.origin)
    return float(xy[:, 0].min()), float(xy[:, 0].max()), float(xy[:, 1].min()), float(xy[:, 1].max())


def _turned(points: FloatArray, origin: tuple[float, float, float]) -> FloatArray:
    """``points`` (N, 2) of the map's frame (its bottom-left corner at 0) in the world."""
    c, s = math.cos(origin[2]), math.sin(origin[2])
    return points @ np.array([[c, s], [-s, c]]) + np.array(origin[:2])


def _placed(ob: Obstacle, origin: tuple[float, float, float]) -> Obstacle:
    """An obstacle made in the map's frame, placed in the world."""
    if isinstance(ob, Box):
        (center,) = _turned(np.array([ob.center], dtype=float), origin)
        return Box((float(center[0]), float(center[1])), ob.size, origin[2], ob.height)
    assert isinstance(ob, Polygon)
    return Polygon(tuple((float(x), float(y)) for x, y in _turned(ob.array, origin)), ob.height)


#: A ROS map's obstacles by default: the exact outlines of its occupied cells, the cells map_server serves as
#: occupied (a region's bounding box, an image's default, would cover the free cells around every wall that is not
#: an upright rectangle: a room's walls with a door gap are one region whose box is the room).
YAML_SHAPE: MapShape = "polygon"


def map_yaml_obstacles(m: MapYaml, *, unknown: Unknown = "free", shape: MapShape = YAML_SHAPE) -> MapObstacles:
    """The map's obstacles (see the module docstring) and the extent its image covers in the world
    (:func:`map_extent`).

    Args:
        m: The map (:func:`read_map_yaml`).
        unknown: "free" (Nav2's planners' default) or "obstacle": what unknown cells are.
        shape: "polygon" (the default, :data:`YAML_SHAPE`) or "box", as for an image map
            (:func:`planning.core.maps.obstacles_from_mask`).
    """
    if unknown not in ("free", "obstacle"):
        raise ValueError(f"unknown must be 'free' or 'obstacle', got {unknown!r}")
    grid = occupancy_grid(m)
    mask = grid >= OCCUPIED
    if unknown == "obstacle":
        mask |= grid == UNKNOWN
    if m.origin[2] == 0.0:
        obstacles = obstacles_from_mask(mask, m.resolution, m.origin[:2], shape)
    else:
        obstacles = [_placed(ob, m.origin) for ob in obstacles_from_mask(mask, m.resolution, (0.0, 0.0), shape)]
    return obstacles, map_extent(m, grid.shape)  # type: ignore[arg-type]


def load_map_yaml_table(table: Mapping[str, Any], base_dir: Path, where: str) -> MapObstacles:
    """The ``[world.map]`` loader of a map YAML, ``MAP_LOADERS["yaml"]``: ``yaml`` (the file, relative to the
    scenario file), ``unknown`` ("free" or "obstacle") and ``shape`` ("polygon", the default, or "box").

    Raises:
        ScenarioError: Unknown, missing or bad fields; fields the YAML gives itself; a bad YAML or image.
    """
    r, ctx = TableReader(where), "world.map."
    if given := sorted(set(table) & _IMAGE_FIELDS):
        raise ScenarioError(
            f"{where}: table 'world.map' gives 'yaml' and {', '.join(repr(k) for k in given)}: a map YAML names its "
            "image, resolution, origin and thresholds itself; give 'yaml' (with 'unknown' and 'shape'), or an "
            "image's 'image' and 'resolution' without 'yaml'"
        )
    r.keys(table, ctx, {"yaml"}, {"unknown", "shape"})
    name = table["yaml"]
    if not isinstance(name, str) or not name:
        raise r.fail(f"{ctx}yaml", "a path to a map's .yaml file (relative to the scenario file)", name)
    unknown = table.get("unknown", "free")
    if unknown not in ("free", "obstacle"):
        raise r.fail(f"{ctx}unknown", "'free' (plan through unknown cells, as Nav2 does) or 'obstacle'", unknown)
    shape = map_shape(r, table, ctx, YAML_SHAPE)
    path = Path(name) if Path(name).is_absolute() else base_dir / name
    try:
        return map_yaml_obstacles(read_map_yaml(path), unknown=unknown, shape=shape)
    except ScenarioError as exc:
        raise ScenarioError(f"{where}: field 'world.map.yaml': {exc}") from exc
