"""ROS map YAML files (map_saver, SLAM Toolbox) read as Nav2's map_server reads them, and scenarios built on them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from planning.core.nav2_map import MapYaml, map_yaml_obstacles, occupancy_grid, read_map_yaml
from planning.errors import ScenarioError
from planning.scenario import load_scenario_file
from tests.cli_helpers import nhsim_here

YAML = """image: {image}
mode: {mode}
resolution: {resolution}
origin: [{ox}, {oy}, {yaw}]
negate: {negate}
occupied_thresh: 0.65
free_thresh: {free}
"""


def _write_map(folder: Path, pixels: np.ndarray, *, name: str = "map", suffix: str = ".pgm", **fields: object) -> Path:
    """A map as map_saver writes one: the image and a YAML naming it (relative), fields over the defaults (a
    TurtleBot3 map's: free_thresh 0.196 reads map_saver's unknown grey, 205, as unknown; Nav2's default 0.25 reads it
    as free, in Nav2 as here)."""
    Image.fromarray(pixels).save(folder / f"{name}{suffix}")
    values = {"image": f"{name}{suffix}", "mode": "trinary", "resolution": 0.05, "ox": 0.0, "oy": 0.0, "yaw": 0.0}
    values |= {"negate": 0, "free": 0.196} | fields
    path = folder / f"{name}.yaml"
    path.write_text(YAML.format(**values))
    return path


def _map_server_cell(rgba: tuple[int, ...], alpha: bool, m: MapYaml) -> int:
    """One cell as nav2_map_server's loadMapFromFile computes it from a pixel's 8-bit levels (a plain
    transcription, pixel by pixel)."""
    channels = list(rgba[:3]) + ([rgba[3]] if alpha and m.mode == "trinary" else [])
    shade = sum(channels) / len(channels) / 255.0
    occ = shade if m.negate else 1.0 - shade
    if m.mode == "trinary":
        return 100 if m.occupied_thresh < occ else 0 if occ < m.free_thresh else -1
    if m.mode == "scale":
        if alpha and rgba[3] != 255:
            return -1
        if m.occupied_thresh < occ:
            return 100
        if occ < m.free_thresh:
            return 0
        return int(np.rint((occ - m.free_thresh) / (m.occupied_thresh - m.free_thresh) * 100.0))
    value = round(shade * 255)
    return value if 0 <= value <= 100 else -1


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
@pytest.mark.parametrize("negate", [0, 1])
@pytest.mark.parametrize("colour", ["L", "RGB", "RGBA"])
def test_cells_are_map_servers(tmp_path: Path, mode: str, negate: int, colour: str) -> None:
    rng = np.random.default_rng(len(mode) * 7 + negate * 3 + len(colour))
    channels = {"L": 1, "RGB": 3, "RGBA": 4}[colour]
    pixels = rng.integers(0, 256, (9, 13, channels), dtype=np.uint8)
    if colour == "RGBA":
        pixels[..., 3] = np.where(rng.random((9, 13)) < 0.5, 255, pixels[..., 3])  # half of them opaque
    image = pixels[..., 0] if colour == "L" else pixels
    m = read_map_yaml(_write_map(tmp_path, image, suffix=".png", mode=mode, negate=negate))
    grid = occupancy_grid(m)
    rgba = np.concatenate([np.repeat(pixels, 3, axis=2) if colour == "L" else pixels[..., :3], pixels[..., 3:]], 2)
    cells = [[_map_server_cell(tuple(int(v) for v in px), colour == "RGBA", m) for px in row] for row in rgba]
    np.testing.assert_array_equal(grid, np.array(cells))


def _room(unknown_border: int = 6) -> np.ndarray:
    """A SLAM map: a room 3 x 2 m inside 0.1 m walls (0), free inside (254), unknown (205) around it, and a
    crate (0) in the room; 0.05 m a pixel."""
    h, w = 40 + 2 * unknown_border + 4, 60 + 2 * unknown_border + 4
    img = np.full((h, w), 205, dtype=np.uint8)
    b = unknown_border
    img[b : h - b, b : w - b] = 0
    img[b + 2 : h - b - 2, b + 2 : w - b - 2] = 254
    img[b + 16 : b + 24, b + 30 : b + 36] = 0
    return img


def test_a_slam_maps_walls_and_unknown_space(tmp_path: Path) -> None:
    path = _write_map(tmp_path, _room(), ox=-1.0, oy=-0.5)
    m = read_map_yaml(path)
    assert m.image == tmp_path / "map.pgm" and m.origin == (-1.0, -0.5, 0.0)
    obstacles, extent = map_yaml_obstacles(m)
    h, w = _room().shape
    assert extent == pytest.approx((-1.0, -1.0 + 0.05 * w, -0.5, -0.5 + 0.05 * h))

    def occupied_at(points: np.ndarray, obs: list) -> np.ndarray:
        return np.any([ob.signed_distance(points) < 0 for ob in obs], axis=0)

    # pixel centres: row i from the top, column j
    i, j = np.mgrid[0:h, 0:w]
    centres = np.stack([-1.0 + (j + 0.5) * 0.05, -0.5 + (h - i - 0.5) * 0.05], axis=-1).reshape(-1, 2)
    img = _room().ravel()
    np.testing.assert_array_equal(occupied_at(centres, obstacles), img == 0)
    closed, _ = map_yaml_obstacles(m, unknown="obstacle")
    np.testing.assert_array_equal(occupied_at(centres, closed), img != 254)


def test_a_negated_map_is_the_same_world(tmp_path: Path) -> None:
    room = _room()
    plain, _ = map_yaml_obstacles(read_map_yaml(_write_map(tmp_path, room, name="plain")))
    negated, _ = map_yaml_obstacles(read_map_yaml(_write_map(tmp_path, 255 - room, name="negated", negate=1)))
    assert negated == plain


@pytest.mark.parametrize("shape", ["box", "polygon"])
def test_an_origin_yaw_turns_the_map_about_its_corner(tmp_path: Path, shape: str) -> None:
    yaw = 0.4
    room = _room()
    m = read_map_yaml(_write_map(tmp_path, room, ox=2.0, oy=1.0, yaw=yaw))
    obstacles, extent = map_yaml_obstacles(m, shape=shape)  # type: ignore[arg-type]
    h, w = room.shape
    i, j = np.mgrid[0:h, 0:w]
    local = np.stack([(j + 0.5) * 0.05, (h - i - 0.5) * 0.05], axis=-1).reshape(-1, 2)
    c, s = math.cos(yaw), math.sin(yaw)
    world = local @ np.array([[c, s], [-s, c]]) + np.array([2.0, 1.0])
    inside = np.any([ob.signed_distance(world) < 0 for ob in obstacles], axis=0)
    np.testing.assert_array_equal(inside, room.ravel() == 0)
    corners = np.array([(0, 0), (w, 0), (w, h), (0, h)]) * 0.05 @ np.array([[c, s], [-s, c]]) + np.array([2.0, 1.0])
    assert extent == pytest.approx((corners[:, 0].min(), corners[:, 0].max(), corners[:, 1].min(), corners[:, 1].max()))


def _scenario(folder: Path, map_table: str, *, bounds: str = "", goal: str = "[2.4, 1.4, 0.0]") -> Path:
    path = folder / "house.toml"
    path.write_text(
        f'name = "house"\nrobot = "turtlebot3"\n[world]\n{bounds}\n[world.map]\n{map_table}\n'
        f"[start]\npose = [0.5, 0.5, 0.0]\n[goal]\npose = {goal}\n"
    )
    return path


def test_a_scenario_on_a_map_yaml_takes_the_maps_extent_and_plans(tmp_path: Path) -> None:
    _write_map(tmp_path, _room(), ox=-0.5, oy=-0.5)
    path = _scenario(tmp_path, 'yaml = "map.yaml"\nunknown = "obstacle"')
    scenario = load_scenario_file(path)
    h, w = _room().shape
    assert scenario.world.bounds == pytest.approx((-0.5, -0.5 + 0.05 * w, -0.5, -0.5 + 0.05 * h))
    out = tmp_path / "plan.json"
    done = nhsim_here("plan", "--scenario", str(path), "--planner", "hybrid-a-star", "--json", str(out))
    assert done.returncode == 0, done.stderr
    assert "success" in done.stdout
    # the goal in the unknown space outside the room: free by default, an obstacle when unknown space is one
    outside = _scenario(tmp_path, 'yaml = "map.yaml"\nunknown = "obstacle"', goal="[-0.35, -0.35, 0.0]")
    with pytest.raises(ScenarioError, match="goal"):
        load_scenario_file(outside)


@pytest.mark.parametrize(
    ("table", "yaml_text", "message"),
    [
        ('yaml = "nowhere.yaml"', None, "map YAML .*nowhere.yaml does not exist"),
        ('yaml = "map.yaml"\nresolution = 0.05', None, "gives 'yaml' and 'resolution': a map YAML names its image"),
        ('yaml = "map.yaml"\nunknown = "lethal"', None, "'world.map.unknown': expected 'free'"),
        ('yaml = "map.yaml"', "image: map.pgm\nresolution: [0.05\n", "is not valid YAML"),
        ('yaml = "map.yaml"', "- a\n- b\n", "holds list, not a map's fields"),
        ('yaml = "map.yaml"', "image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "missing.*occupied_thresh"),
        (
            'yaml = "map.yaml"',
            "image: map.pgm\nresolution: 0.05\norigin: [0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.25\n",
            "'origin': expected \\[x, y, yaw\\]",
        ),
        (
            'yaml = "map.yaml"',
            "image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.25\nfree_thresh: 0.65\n",
            "0 <= free_thresh < occupied_thresh <= 1",
        ),
        (
            'yaml = "map.yaml"',
            "image: map.pgm\nresolution: -1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.25\n",
            "'resolution': expected a pixel size > 0",
        ),
        (
            'yaml = "map.yaml"',
            "image: gone.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
            "free_thresh: 0.25\nmode: trinary\n",
            "map image .*gone.pgm does not exist; check the path \\(relative to the map YAML .*map.yaml\\)",
        ),
        (
            'yaml = "map.yaml"',
            "image: map.pgm\nresolution: 0.05\nresolution: 0.5\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
            "free_thresh: 0.25\n",
            "field 'resolution' is given twice \\(again on line 3\\); YAML keys are unique",
        ),
        (
            'yaml = "map.yaml"',
            "image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 1.0\nfree_thresh: 0.25\n",
            "'occupied_thresh' 1: no pixel's occupancy is above it.*give 0.99 for black walls",
        ),
        (
            'yaml = "map.yaml"',
            "image: map.pgm\nresolution: 0.00001\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.25\n",
            "table 'world.map': obstacle 1 of the map \\(polygon\\) is 6e-05 m across.*check the map's resolution",
        ),
        (
            'yaml = "map.yaml"',
            "image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
            "free_thresh: 0.25\nmode: binary\n",
            "'mode': expected 'trinary' or 'scale' or 'raw'",
        ),
        (
            'yaml = "map.yaml"',
            "image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
            "free_thresh: 0.25\nnegate: 2\n",
            "'negate': expected 0 or 1",
        ),
    ],
)
def test_bad_map_yamls_are_named(tmp_path: Path, table: str, yaml_text: str | None, message: str) -> None:
    _write_map(tmp_path, _room())
    if yaml_text is not None:
        (tmp_path / "map.yaml").write_text(yaml_text)
    with pytest.raises(ScenarioError, match=message):
        load_scenario_file(_scenario(tmp_path, table))


def test_a_map_too_large_for_a_world_asks_for_bounds(tmp_path: Path) -> None:
    _write_map(tmp_path, _room(), resolution=20.0)
    with pytest.raises(ScenarioError, match=r"the map covers .* give 'world.bounds'"):
        load_scenario_file(_scenario(tmp_path, 'yaml = "map.yaml"'))
    path = _scenario(tmp_path, 'yaml = "map.yaml"', bounds="bounds = [0, 3, 0, 3]")
    with pytest.raises(ScenarioError, match="outside the world bounds"):  # the walls lie beyond 3 m
        load_scenario_file(path)


def test_a_map_mode_is_read_whatever_its_case(tmp_path: Path) -> None:
    """map_server lower-cases ``mode`` (map_mode_from_string): "Trinary" was refused."""
    path = _write_map(tmp_path, _room(), mode="Trinary")
    assert read_map_yaml(path).mode == "trinary"


def test_a_number_with_an_exponent_is_read_as_map_server_reads_it(tmp_path: Path) -> None:
    """``resolution: 1e-2`` (a float to YAML 1.2 and to map_server's yaml-cpp) was refused as "expected a finite
    number, got '1e-2'": PyYAML's YAML 1.1 rules read an exponent without a decimal point as text."""
    path = _write_map(tmp_path, _room(), resolution="5e-2", free="196e-3")
    m = read_map_yaml(path)
    assert (m.resolution, m.free_thresh) == (0.05, 0.196)
    assert yaml.safe_load("a: 1e-2") == {"a": "1e-2"}  # PyYAML's own loader left as it is


def test_a_room_whose_walls_have_a_door_gap_is_its_cells_by_default(tmp_path: Path) -> None:
    """A ROS map's walls with a gap are one region that encloses nothing: its bounding box, the image default, was
    the whole room, and a start inside it was refused as "inside world.obstacles[0] (box)". A map YAML's obstacles
    are its exact cells by default; asked for boxes, the refusal says why and names the polygon shape."""
    room = _room()
    room[6 + 20 : 6 + 24, 6 : 6 + 2] = 254  # a door in the west wall
    _write_map(tmp_path, room, ox=-0.5, oy=-0.5)
    scenario = load_scenario_file(_scenario(tmp_path, 'yaml = "map.yaml"'))
    assert all(ob.kind == "polygon" for ob in scenario.world.obstacles)
    with pytest.raises(ScenarioError) as refused:
        load_scenario_file(_scenario(tmp_path, 'yaml = "map.yaml"\nshape = "box"'))
    said = str(refused.value)
    assert "lies inside obstacle 0 of the map (table 'world.map', a box): with shape \"box\" a region" in said
    assert said.endswith('give the map shape = "polygon" (its exact cells), or move it into free space')
