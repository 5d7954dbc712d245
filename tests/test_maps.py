"""Map images to obstacles: the shipped EduMIP map, placement, thresholds, polygons, errors."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from planning.core.maps import (
    EDUMIP_MAP_OBSTACLES,
    MAP_BYTES_PER_PIXEL,
    MAX_MAP_PIXELS,
    edumip_map_image,
    load_image_obstacles,
    load_map_table,
    obstacles_from_mask,
    read_grey,
)
from planning.core.robot import MODELS_DIR
from planning.core.world import Box, Polygon, polygon_area
from planning.errors import ScenarioError
from planning.scenario import MAP_LOADERS, load_scenario_file

MAP_PNG = MODELS_DIR / "maps" / "edumip_map.png"
PX = 0.01


def test_shipped_png_is_the_generator_output():
    img = np.asarray(Image.open(MAP_PNG))
    assert img.shape == (500, 500) and img.dtype == np.uint8
    np.testing.assert_array_equal(img, edumip_map_image())


def test_edumip_map_boxes_match_drawn_rectangles():
    obstacles = load_image_obstacles(MAP_PNG, PX, (0.0, 0.0), 0.5, "box")
    assert len(obstacles) == 4
    assert all(isinstance(o, Box) and o.angle == 0.0 for o in obstacles)
    found = sorted((o.bounding_box() for o in obstacles), key=lambda b: (b[0], -b[2]))
    drawn = sorted(EDUMIP_MAP_OBSTACLES.values(), key=lambda b: (b[0], -b[2]))
    for (x0, x1, y0, y1), (a0, a1, b0, b1) in zip(found, drawn, strict=True):
        assert max(abs(x0 - a0), abs(x1 - a1), abs(y0 - b0), abs(y1 - b1)) <= PX + 1e-9
    # the EduMIP planning report's numbering: O1 leftmost, O2..O4 on the right from top to bottom
    o = EDUMIP_MAP_OBSTACLES
    assert o["O1"][1] < min(o[k][0] for k in ("O2", "O3", "O4"))
    assert o["O2"][2] > o["O3"][3] and o["O3"][2] > o["O4"][3]


def test_placement_origin_and_y_up(tmp_path):
    img = np.full((3, 4), 255, dtype=np.uint8)
    img[0, 0] = 0  # top-left pixel
    img[2, 3] = 0  # bottom-right pixel
    path = tmp_path / "m.png"
    Image.fromarray(img).save(path)
    obs = load_image_obstacles(path, 0.5, (10.0, -2.0))
    boxes = sorted(o.bounding_box() for o in obs)
    assert boxes[0] == pytest.approx((10.0, 10.5, -1.0, -0.5))  # top-left: the top row, highest y
    assert boxes[1] == pytest.approx((11.5, 12.0, -2.0, -1.5))  # bottom-right: at the origin's y


def test_threshold_and_transparency(tmp_path):
    rgba = np.zeros((4, 4, 4), dtype=np.uint8)
    rgba[..., :3] = 255
    rgba[..., 3] = 255
    rgba[0, 0, :3] = 102  # grey 0.4
    rgba[3, 3, :3] = 0
    rgba[3, 3, 3] = 0  # fully transparent black counts as white
    path = tmp_path / "m.png"
    Image.fromarray(rgba, mode="RGBA").save(path)
    assert read_grey(path)[3, 3] == 1.0
    assert len(load_image_obstacles(path, 1.0, threshold=0.5)) == 1
    assert len(load_image_obstacles(path, 1.0, threshold=0.3)) == 0


def test_four_connectivity_and_jpeg(tmp_path):
    mask = np.zeros((5, 5), dtype=bool)
    mask[1, 1] = mask[2, 2] = True  # touching only diagonally: two regions
    assert len(obstacles_from_mask(mask, 1.0)) == 2
    # JPEG: compression blurs edges; boxes still within one pixel of the drawn ones
    img = edumip_map_image()
    path = tmp_path / "map.jpg"
    Image.fromarray(img).save(path, quality=85)
    obs = load_image_obstacles(path, PX)
    assert len(obs) == 4
    found = sorted(o.bounding_box() for o in obs)
    drawn = sorted(EDUMIP_MAP_OBSTACLES.values())
    assert np.max(np.abs(np.array(found) - np.array(drawn))) <= PX + 1e-9


def test_polygon_outline_is_exact():
    # an L shape with a hole: the outline follows pixel edges, the hole is filled
    mask = np.zeros((8, 9), dtype=bool)
    mask[1:7, 1:4] = True
    mask[5:7, 1:8] = True
    mask[3, 2] = False  # hole
    (poly,) = obstacles_from_mask(mask, 0.1, (1.0, 2.0), "polygon")
    assert isinstance(poly, Polygon)
    assert len(poly.array) == 6
    filled = mask.copy()
    filled[3, 2] = True
    assert abs(polygon_area(poly.array)) == pytest.approx(filled.sum() * 0.01, abs=1e-12)
    # every pixel centre is inside exactly when its pixel belongs to the (filled) region
    rows, cols = np.indices(mask.shape)
    centres = np.column_stack([1.0 + (cols.ravel() + 0.5) * 0.1, 2.0 + (mask.shape[0] - rows.ravel() - 0.5) * 0.1])
    inside = poly.signed_distance(centres) < 0
    np.testing.assert_array_equal(inside, filled.ravel())
    # box mode gives the bounding rectangle of the same region
    (box,) = obstacles_from_mask(mask, 0.1, (1.0, 2.0), "box")
    assert box.bounding_box() == pytest.approx(poly.bounding_box(), abs=1e-12)


def test_polygon_mode_on_shipped_map_equals_boxes():
    boxes = load_image_obstacles(MAP_PNG, PX, shape="box")
    polys = load_image_obstacles(MAP_PNG, PX, shape="polygon")
    pts = np.random.default_rng(0).uniform(-0.5, 5.5, size=(2000, 2))
    for b, p in zip(boxes, polys, strict=True):
        assert len(p.array) == 4
        np.testing.assert_allclose(p.signed_distance(pts), b.signed_distance(pts), atol=1e-9)


def _scenario(tmp_path: Path, map_table: str) -> Path:
    text = f"""
name = "m"
robot = "edumip"
[world]
bounds = [-1.0, 6.0, -1.0, 6.0]
[world.map]
{map_table}
[start]
pose = [0.0, 0.0, 0.0]
[goal]
pose = [5.0, 5.0, 0.0]
"""
    sub = tmp_path / "scen"
    sub.mkdir(exist_ok=True)
    path = sub / "m.toml"
    path.write_text(text)
    return path


def test_scenario_map_table(tmp_path):
    assert MAP_LOADERS["image"] is load_map_table
    Image.fromarray(edumip_map_image()).save(tmp_path / "map.png")
    sc = load_scenario_file(_scenario(tmp_path, 'image = "../map.png"\nresolution = 0.01\nshape = "polygon"'))
    assert len(sc.world.obstacles) == 4 and all(isinstance(o, Polygon) for o in sc.world.obstacles)
    sc = load_scenario_file(_scenario(tmp_path, 'image = "../map.png"\nresolution = 0.01\norigin = [-1.0, -0.5]'))
    assert max(o.bounding_box()[1] for o in sc.world.obstacles) == pytest.approx(-1.0 + 4.4)
    assert max(o.bounding_box()[3] for o in sc.world.obstacles) == pytest.approx(-0.5 + 4.5)


def test_a_map_whose_obstacles_all_lie_outside_the_bounds_is_refused(tmp_path):
    # an origin or resolution typo: the map's boxes would be silently left out of the world
    Image.fromarray(edumip_map_image()).save(tmp_path / "map.png")
    with pytest.raises(ScenarioError, match=r"table 'world.map': every obstacle of the map lies outside") as err:
        load_scenario_file(_scenario(tmp_path, 'image = "../map.png"\nresolution = 0.01\norigin = [10.0, 10.0]'))
    assert "check its origin and resolution" in str(err.value)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ('image = "../nope.png"\nresolution = 0.01', "does not exist"),
        ('image = "../bad.png"\nresolution = 0.01', r"not a readable image \(PNG, JPEG or PGM\)"),
        ('image = "../map.png"\nresolution = -0.01', "world.map.resolution"),
        ('image = "../map.png"\nresolution = 0.01\nthreshold = 2.0', "world.map.threshold"),
        ('image = "../map.png"\nresolution = 0.01\norigin = [1.0]', "world.map.origin"),
        ('image = "../map.png"\nresolution = 0.01\nshape = "circle"', "world.map.shape"),
        ('image = "../map.png"\nresolution = 0.01\nscale = 2', "unknown key"),
        ('image = "../map.png"', "world.map.resolution"),
        ("image = 3\nresolution = 0.01", "world.map.image"),
    ],
)
def test_map_table_errors(tmp_path, table, message):
    Image.fromarray(edumip_map_image()).save(tmp_path / "map.png")
    (tmp_path / "bad.png").write_text("not an image")
    with pytest.raises(ScenarioError, match=message) as info:
        load_scenario_file(_scenario(tmp_path, table))
    assert "m.toml" in str(info.value)


def _png_header(path: Path, width: int, height: int) -> Path:
    """A PNG whose header claims width x height 8-bit grey pixels and whose pixel data is empty."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", b"") + chunk(b"IEND", b""))
    return path


@pytest.mark.parametrize(("width", "height"), [(20000, 20000), (8000, 6251)])
def test_a_huge_map_is_refused_before_decoding(tmp_path, width, height):
    assert width * height > MAX_MAP_PIXELS
    path = _png_header(tmp_path / "huge.png", width, height)
    gb = width * height * MAP_BYTES_PER_PIXEL / 1e9
    with pytest.raises(ScenarioError, match=rf"{width} x {height} px.*{gb:.1f} GB.*lower resolution.*crop"):
        read_grey(path)


def test_a_huge_map_in_a_scenario_is_exit_2(tmp_path, capsys):
    from sim.cli.main import main

    _png_header(tmp_path / "huge.png", 20000, 20000)
    scenario = _scenario(tmp_path, 'image = "../huge.png"\nresolution = 0.01')
    assert main(["plan", "--scenario", str(scenario), "--planner", "c-rrt-star", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "world.map.image" in err and "20000 x 20000 px" in err and "Traceback" not in err


def _inside(obstacles: list, mask_shape: tuple[int, int], res: float, origin: tuple[float, float]) -> np.ndarray:
    """Which pixel centres of an image of ``mask_shape`` lie inside any of ``obstacles`` (row 0 at the top)."""
    rows, cols = np.indices(mask_shape)
    x = origin[0] + (cols.ravel() + 0.5) * res
    y = origin[1] + (mask_shape[0] - rows.ravel() - 0.5) * res
    centres = np.column_stack([x, y])
    inside = np.zeros(len(centres), dtype=bool)
    for obstacle in obstacles:
        inside |= obstacle.signed_distance(centres) < 0
    return inside.reshape(mask_shape)


@pytest.mark.parametrize("shape", ["polygon", "box"])
def test_the_walls_around_a_room_leave_the_room_free(shape: str) -> None:
    """A map saved by a SLAM tool: walls all round and inside. The ring of walls is one region; its holes were
    filled (and box mode took its bounding box), so the whole room became one obstacle and no start was free."""
    mask = np.zeros((80, 120), dtype=bool)
    mask[:2], mask[-2:], mask[:, :2], mask[:, -2:] = True, True, True, True  # the walls all round
    mask[20:60, 60:62] = True  # an inner wall joined to nothing
    mask[40:80, 30:32] = True  # a wall from the south wall, part of the ring
    obstacles = obstacles_from_mask(mask, 0.05, (0.0, 0.0), shape)  # type: ignore[arg-type]
    np.testing.assert_array_equal(_inside(obstacles, mask.shape, 0.05, (0.0, 0.0)), mask)
    assert len(obstacles) <= 8  # a few pieces, not a piece per pixel row


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("shape", ["polygon", "box"])
def test_obstacles_cover_a_masks_pixels_exactly_but_holes_no_robot_fits_in(seed: int, shape: str) -> None:
    """Random masks (blobs, rings, rooms within rooms): every pixel centre is inside a polygon exactly when its
    pixel is occupied, or lies in an enclosed hole of at most MAX_FILLED_HOLE_M2 (filled, unless a cut through a
    larger hole opened it); boxes cover every occupied pixel (a region's bounding box, but a region enclosing a
    larger hole: its rows' runs, exact)."""
    from scipy import ndimage

    from planning.core.maps import MAX_FILLED_HOLE_M2

    rng = np.random.default_rng(seed)
    res = 0.02
    mask = ndimage.binary_opening(rng.random((60, 70)) < 0.45, iterations=1)
    for _ in range(3):  # rectangular rings of walls, some nested, some crossing
        r0, c0 = rng.integers(0, 40), rng.integers(0, 50)
        r1, c1 = r0 + rng.integers(8, 20), c0 + rng.integers(8, 20)
        mask[r0:r1, [c0, c1 - 1]] = True
        mask[[r0, r1 - 1], c0:c1] = True
    filled = ndimage.binary_fill_holes(mask)
    holes, n = ndimage.label(filled & ~mask)
    sizes = np.bincount(holes.ravel(), minlength=n + 1)
    small = np.isin(holes, np.flatnonzero(sizes * res**2 <= MAX_FILLED_HOLE_M2)) & (holes > 0)
    assert (~small & filled & ~mask).any()  # some hole a robot fits in, kept free
    obstacles = obstacles_from_mask(mask, res, (1.0, -2.0), shape)  # type: ignore[arg-type]
    inside = _inside(obstacles, mask.shape, res, (1.0, -2.0))
    if shape == "polygon":  # a small hole that a cut opened may stay free: a robot fits in neither
        np.testing.assert_array_equal(inside & ~small, mask)
    else:
        assert inside[mask].all()


@pytest.mark.parametrize("suffix", [".png", ".pgm"])
def test_a_16_bit_maps_grey_walls_are_walls(tmp_path: Path, suffix: str) -> None:
    """16-bit PNG and PGM maps: Pillow's conversion to 8 bits clipped every value above 255 of 65535 to white, so a
    wall drawn in dark grey (12000) vanished, and plans drove through it."""
    grey = np.full((40, 60), 65535, dtype=np.uint16)
    grey[:, 28:32] = 12000  # a wall at 18 % grey
    grey[5:10, 5:10] = 40000  # 61 %: free at the default threshold (0.5)
    path = tmp_path / f"wall16{suffix}"
    Image.fromarray(grey).save(path)
    levels = read_grey(path)
    np.testing.assert_allclose(levels, grey / 65535.0)
    (wall,) = load_image_obstacles(path, 0.05)
    assert wall.bounding_box() == pytest.approx((1.4, 1.6, 0.0, 2.0))  # x from 28 to 32 px, the whole height


#: An obstacle of ROBOTIS's turtlebot3_navigation2 map (its pixels, 1 occupied): its outline's staircase corners lie
#: three at a time on a diagonal, where ear clipping emitted a triangle of no area ("qhull error") and the
#: published map could not be simulated.
_TB3_OBSTACLE = """
0000000110000
0000000011000
0001000001000
0001100011000
0001110111000
0000111110000
"""


def _staircase_mask() -> np.ndarray:
    rows = [[c == "1" for c in line] for line in _TB3_OBSTACLE.split()]
    return np.pad(np.array(rows, dtype=bool), 3)


def test_a_pixel_outline_is_triangulated_whole_and_built_in_physics() -> None:
    """Every triangle of a staircase outline has area, they cover the polygon exactly, and MuJoCo builds the
    world (a zero-area triangle was "qhull error", a partial triangulation left walls out of physics)."""
    from planning.core.robot import load_robot
    from planning.core.world import World
    from sim.physics.model import build_model, triangulate

    obstacles = obstacles_from_mask(_staircase_mask(), 0.05, (0.0, 0.0), "polygon")
    assert obstacles and all(isinstance(o, Polygon) for o in obstacles)
    for ob in obstacles:
        tris = triangulate(ob.array)  # type: ignore[union-attr]
        areas = [abs(polygon_area(t)) for t in tris]
        assert min(areas) > 1e-9 and sum(areas) == pytest.approx(abs(polygon_area(ob.array)), rel=1e-12)  # type: ignore[union-attr]
    world = World((-1.0, 3.0, -1.0, 3.0), tuple(obstacles))
    built = build_model(load_robot("turtlebot3"), world)
    assert len(built.obstacle_geoms) >= sum(len(o.array) - 2 for o in obstacles) // 2  # type: ignore[union-attr]
