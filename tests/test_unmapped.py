"""``[[world.unmapped]]`` obstacles: in physics and in the scan, not in the map the planner and localiser use."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from planning.core.robot import load_robot
from planning.core.world import Box
from planning.errors import ScenarioError
from planning.scenario import load_scenario
from sim.physics.lidar import LidarProfile, LidarScanner
from sim.physics.model import build_model

TEXT = """
name = "unmapped"
[world]
bounds = [-2.0, 2.0, -2.0, 2.0]
[[world.obstacles]]
type = "circle"
center = [1.0, 1.0]
radius = 0.3
[[world.unmapped]]
type = "box"
center = [0.0, 0.8]
size = [0.3, 0.3]
[start]
pose = [0.0, 0.0, 0.0]
[goal]
pose = [1.5, -1.5, 0.0]
"""


def _load(tmp_path: Path, text: str = TEXT):  # type: ignore[no-untyped-def]
    p = tmp_path / "u.toml"
    p.write_text(text)
    return load_scenario(p)


def test_unmapped_obstacles_are_in_physics_and_the_scan_not_in_the_map(tmp_path: Path) -> None:
    sc = _load(tmp_path)
    assert sc.unmapped == (Box((0.0, 0.8), (0.3, 0.3)),)
    assert len(sc.world.obstacles) == 1 and len(sc.physical_world.obstacles) == 2
    assert sc.world.signed_distance([[0.0, 0.8]])[0] > 0.5  # the map: free
    model = build_model(load_robot("turtlebot3"), sc.physical_world).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    exact = LidarProfile(accuracy_near=0, accuracy_far=0, precision_near=0, precision_far=0)
    scan = LidarScanner(model, exact, seed=0).scan(data, 0.0, np.zeros((360, 3)))
    # beam 90 points along +y from the scanner at (-0.032, 0): the box's face at y = 0.65
    assert scan.ranges[90] == pytest.approx(0.65, abs=1e-9)


def test_unmapped_obstacles_overlapping_the_start_or_badly_shaped_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match=r"world\.unmapped\[0\]' \(box\) overlaps the robot at its start"):
        _load(tmp_path, TEXT.replace("center = [0.0, 0.8]", "center = [0.0, 0.2]"))
    with pytest.raises(ScenarioError, match=r"world\.unmapped\[0\]"):
        _load(tmp_path, TEXT.replace("size = [0.3, 0.3]", "size = [0.3, -0.3]"))
    with pytest.raises(ScenarioError, match=r"world\.unmapped"):
        _load(tmp_path, TEXT.replace("[[world.unmapped]]", "[world.unmapped]"))


def test_unmapped_obstacles_get_the_checks_mapped_ones_get(tmp_path: Path) -> None:
    """One no pose can meet (a typo?) and one thinner than the checker resolves are refused when the file is
    read, naming the file and ``world.unmapped[i]``, as a ``[[world.obstacles]]`` one is."""
    path = tmp_path / "u.toml"
    with pytest.raises(ScenarioError) as err:
        _load(tmp_path, TEXT.replace("center = [0.0, 0.8]", "center = [10.0, 10.0]"))
    said = str(err.value)
    assert said.startswith(f"{path}: field 'world.unmapped[0]': this box lies wholly outside the world bounds")
    assert "move it inside, or remove it" in said
    with pytest.raises(ScenarioError) as err:
        _load(tmp_path, TEXT.replace("size = [0.3, 0.3]", "size = [1e-5, 1e-5]"))
    said = str(err.value)
    assert said.startswith(f"{path}: field 'world.unmapped[0]': this box is 1e-05 m across, less than the 0.1 mm")
