"""Scenario files: the format, and a clear error for every kind of bad input."""

import re
from pathlib import Path

import numpy as np
import pytest

from planning.core.world import OBSTACLE_HEIGHT, Box, Circle, Ellipse, Polygon
from planning.errors import ScenarioError
from planning.scenario import SCENARIOS_DIR, builtin_scenarios, load_scenario

GOOD = """
name = "farm"
robot = "turtlebot3"
[world]
bounds = [-3.0, 3.0, -3.0, 3.0]
[[world.obstacles]]
type = "circle"
center = [1.0, 0.5]
radius = 0.3
[[world.obstacles]]
type = "ellipse"
center = [-1.0, 1.0]
radii = [0.5, 0.25]
angle = 0.3
[[world.obstacles]]
type = "box"
center = [0.0, -1.5]
size = [1.0, 0.4]
angle = 0.0
[[world.obstacles]]
type = "polygon"
vertices = [[0.0, 0.0], [1.0, 0.0], [0.5, 1.0]]
[start]
pose = [-2.5, -2.5, 0.0]
[goal]
pose = [2.5, 2.5, 1.57]
position_tolerance = 0.05
heading_tolerance = 0.1
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


def test_the_documented_example_loads(tmp_path: Path) -> None:
    sc = load_scenario(_write(tmp_path, GOOD))
    assert sc.name == "farm" and sc.robot == "turtlebot3"
    kinds = [type(o) for o in sc.world.obstacles]
    assert kinds == [Circle, Ellipse, Box, Polygon]
    assert sc.goal.theta == pytest.approx(1.57) and sc.position_tolerance == 0.05
    assert sc.source is not None


def test_an_obstacle_states_its_height_or_stands_above_the_scan_plane(tmp_path: Path) -> None:
    low = GOOD.replace("angle = 0.0\n", "angle = 0.0\nheight = 0.08\n").replace(
        "[0.5, 1.0]]", "[0.5, 1.0]]\nheight = 2"
    )
    heights = [o.height for o in load_scenario(_write(tmp_path, low)).world.obstacles]
    assert heights == [OBSTACLE_HEIGHT, OBSTACLE_HEIGHT, 0.08, 2.0]


def test_name_defaults_to_the_file_stem(tmp_path: Path) -> None:
    sc = load_scenario(_write(tmp_path, GOOD.replace('name = "farm"\n', "")))
    assert sc.name == "s"


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (
            ('robot = "turtlebot3"', 'robot = "roomba"'),
            r"field 'robot': expected one of edumip, edumip-balancing, turtlebot3",
        ),
        (("[start]", "colour = 1\n[start]"), r"unknown key\(s\) 'colour'"),
        (("pose = [-2.5, -2.5, 0.0]", "pose = [-2.5, -2.5]"), r"'start.pose': expected a list of 3 finite numbers"),
        (
            ("pose = [-2.5, -2.5, 0.0]", "pose = [-9.0, 0.0, 0.0]"),
            r"'start.pose': expected a position inside .*, got \[-9.0, 0.0, 0.0\]$",  # plain numbers
        ),
        (
            ("pose = [-2.5, -2.5, 0.0]", "pose = [1.0, 0.5, 0.0]"),
            r"\[1.0, 0.5, 0.0\] lies inside world.obstacles\[0\] \(circle\)",
        ),
        (('type = "circle"', 'type = "star"'), r"'world.obstacles\[0\].type': expected one of"),
        (("radius = 0.3", "radius = -0.3"), r"'world.obstacles\[0\].radius': expected a number > 0"),
        (("radius = 0.3", "radius = 0.3\nheight = 0"), r"'world.obstacles\[0\].height': expected a height in metres"),
        (("size = [1.0, 0.4]", "size = [1.0, 0.4]\nheight = 30"), r"'world.obstacles\[2\].height': .*at most 10, got"),
        (("radius = 0.3", 'radius = 0.3\nheight = "low"'), r"'world.obstacles\[0\].height': expected a finite number"),
        (("radius = 0.3", 'radius = "big"'), r"expected a finite number"),
        # values echoed as the file spells them
        (("radius = 0.3", "radius = 0.3\nheight = true"), r"'world.obstacles\[0\].height': .*, got true$"),
        (("radius = 0.3", "radius = {r = 0.3}"), r"'world.obstacles\[0\].radius': .*, got a table$"),
        (("bounds = [-3.0, 3.0, -3.0, 3.0]", "bounds = [3.0, -3.0, -3.0, 3.0]"), "xmin < xmax"),
        (("bounds = [-3.0, 3.0, -3.0, 3.0]", "bounds = [-3.0, 1e6, -3.0, 3.0]"), "at most 1000 m a side"),
        (("position_tolerance = 0.05", "position_tolerance = 0"), "expected a number > 0"),
        (
            ("heading_tolerance = 0.1", "heading_tolerance = 10"),
            r"at most pi \(any heading\); 10 degrees would be 0.1745",
        ),
        (("[goal]\npose = [2.5, 2.5, 1.57]", "[goal]"), r"missing field\(s\) 'goal.pose'"),
        (("radius = 0.3", "radius = 0.3\nfoo = 2"), r"unknown key\(s\) 'foo' in \[world.obstacles\[0\]\]"),
        (("[0.5, 1.0]]", "[1.0, 0.0], [0.5, 1.0]]"), r"'world.obstacles\[3\].vertices'.*vertex 2 repeats vertex 1"),
        # a list or a table where a name belongs (these raised TypeError: unhashable type)
        (('type = "circle"', 'type = ["circle"]'), r"'world.obstacles\[0\].type': expected one of circle"),
        (
            ('robot = "turtlebot3"', 'robot = ["turtlebot3"]'),
            r"field 'robot': expected one of edumip, edumip-balancing, turtlebot3",
        ),
        (('robot = "turtlebot3"', 'robots = [{name = "edumip"}]'), r"field 'robots': expected a list of robot names"),
        # a scenario whose own robot is not among the robots it suits
        (
            ('robot = "turtlebot3"', 'robot = "turtlebot3"\nrobots = ["edumip"]'),
            r"field 'robots': expected a list that includes the scenario's own robot 'turtlebot3' \(field 'robot'\)",
        ),
        (("[0.5, 1.0]]", "[1.0, 1.0], [0.0, 1.5], [2.0, 0.2]]"), r"obstacles\[3\].vertices'.*edges 1 and 3 cross"),
        # an obstacle no pose can meet (a typo in its centre, or in the bounds)
        (
            ("center = [1.0, 0.5]", "center = [10.0, 10.0]"),
            r"'world.obstacles\[0\]': this circle lies wholly outside the world bounds .*move it inside",
        ),
        # a heading in degrees, or a typo: refused; one within 4 pi is a direction (below)
        (("pose = [-2.5, -2.5, 0.0]", "pose = [-2.5, -2.5, 90]"), r"'start.pose'.*4 pi; 90 degrees would be 1.571 rad"),
        (("pose = [2.5, 2.5, 1.57]", "pose = [2.5, 2.5, 1e12]"), r"'goal.pose'.*within \+-4 pi, got"),
        # an obstacle's rotation likewise (it was taken as radians: 45 turned a box by 2578 degrees)
        (("angle = 0.3", "angle = 45"), r"'world.obstacles\[1\].angle': .*rotation in radians .*45 degrees would be"),
        (("angle = 0.0", "angle = 1e300"), r"'world.obstacles\[2\].angle': expected the rotation in radians within"),
        # an obstacle thinner than the checker resolves: its step would be a quarter of it
        (
            ("radius = 0.3", "radius = 1e-9"),
            r"'world.obstacles\[0\]': this circle is 2e-09 m across, less than the 0.1 mm",
        ),
        # the format version is the integer 1: true and 1.0 equal 1 in Python, but are not it
        (('robot = "turtlebot3"', 'robot = "turtlebot3"\nversion = true'), r"field 'version': expected the integer 1"),
        (('robot = "turtlebot3"', 'robot = "turtlebot3"\nversion = 1.0'), r"field 'version': .*, got 1.0$"),
    ],
)
def test_bad_files_fail_with_file_field_and_expectation(tmp_path: Path, edit: tuple[str, str], match: str) -> None:
    path = _write(tmp_path, GOOD.replace(*edit, 1))
    with pytest.raises(ScenarioError, match=match) as err:
        load_scenario(path)
    assert str(path) in str(err.value)


def test_invalid_toml_and_missing_files(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(_write(tmp_path, "name = "))
    with pytest.raises(ScenarioError, match="does not exist"):
        load_scenario(tmp_path / "nope.toml")
    with pytest.raises(ScenarioError, match=r"unknown scenario 'nope'.*open"):
        load_scenario("nope")


def test_a_file_not_in_utf8_is_refused_and_a_byte_order_mark_dropped(tmp_path: Path) -> None:
    text = (SCENARIOS_DIR / "nav_map1.toml").read_text(encoding="utf-8")
    for name, data in (("latin1.toml", b'name = "caf\xe9"\n'), ("utf16.toml", text.encode("utf-16"))):
        (tmp_path / name).write_bytes(data)
        said = rf"{name} is not UTF-8 text \(line 1, byte \d+ of the file: .*save it as UTF-8"  # counted from 1
        with pytest.raises(ScenarioError, match=said):
            load_scenario(tmp_path / name)
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    assert load_scenario(tmp_path / "bom.toml").world == load_scenario("nav_map1").world


def test_builtin_scenarios_load() -> None:
    names = builtin_scenarios()
    assert "open" in names
    for name in names:
        sc = load_scenario(name)
        assert sc.name == name


def test_planner_options_tables_are_read_and_reach_the_planner(tmp_path: Path) -> None:
    from planning.planners.registry import make_planner

    text = GOOD + '[planners.birrt]\nsteering = "reeds_shepp"\ngoal_bias = 0.1\n[planners.optim]\nN = 30\n'
    sc = load_scenario(_write(tmp_path, text))
    assert sc.options_for("birrt") == {"steering": "reeds_shepp", "goal_bias": 0.1}
    assert sc.options_for("optim") == {"N": 30}
    assert sc.options_for("rrt") == {}
    assert sc.with_robot("edumip").options_for("birrt") == {"steering": "reeds_shepp", "goal_bias": 0.1}
    planner = make_planner("birrt", **sc.options_for("birrt"))
    assert planner.config.steering == "reeds_shepp" and planner.config.goal_bias == 0.1  # type: ignore[attr-defined]
    assert load_scenario("nav_map1").options_for("birrt") == {"steering": "reeds_shepp"}


@pytest.mark.parametrize(
    ("table", "match"),
    [
        (
            "[planners.birrt]\nwarp = 9\n",
            r"'planners.birrt': options rejected"
            r" by planner 'birrt': unknown option\(s\) warp",
        ),
        ("[planners.teleport]\nx = 1\n", r"'planners.teleport': expected a registered planner name"),
        ("[planners.birrt]\ngoal_bias = 2.0\n", r"'planners.birrt'.*goal_bias must be .* in \[0, 1\], got 2.0"),
        ("planners = 3\n", r"field 'planners': expected a table"),
        ("[planners]\nbirrt = 3\n", r"'planners.birrt': expected a table of keyword options"),
        ('[planners.birrt]\nsteering = "teleport"\n', r"'planners.birrt'.*unknown steering 'teleport': choose"),
        (  # it overrode --time-limit silently (a 3 s plan under --time-limit 0.3, the overrun blamed on the planner)
            "[planners.rrt-star]\ntime_limit = 4.0\n",
            r"field 'planners.rrt-star.time_limit': a scenario does not set the planning budget; remove it and give "
            r"the command --time-limit S",
        ),
        (
            'planner = "astar"\n',
            r"field 'planner': expected a registered planner name \(birrt, .*got 'astar'; a "
            r"plugin's planner is known once its plugin loads: name its module in NHSIM_PLUGINS",
        ),
        ("[planners.astar]\nx = 1\n", r"'planners.astar': expected .*got 'astar'; a plugin's planner is known once"),
    ],
)
def test_bad_planner_options_name_the_field(tmp_path: Path, table: str, match: str) -> None:
    text = (table + GOOD) if table.startswith(("planners =", "planner =")) else (GOOD + table)
    path = _write(tmp_path, text)
    with pytest.raises(ScenarioError, match=match) as err:
        load_scenario(path)
    assert str(path) in str(err.value)


def test_headings_are_brought_into_minus_pi_to_pi_and_kept_there_as_written(tmp_path: Path) -> None:
    sc = load_scenario(_write(tmp_path, GOOD.replace("pose = [-2.5, -2.5, 0.0]", "pose = [-2.5, -2.5, 7.0]")))
    assert sc.start.theta == pytest.approx(7.0 - 2 * np.pi)
    sc = load_scenario(_write(tmp_path, GOOD.replace("pose = [-2.5, -2.5, 0.0]", "pose = [-2.5, -2.5, -3.5]")))
    assert sc.start.theta == pytest.approx(2 * np.pi - 3.5)
    for written in (np.pi, -np.pi, 1.57, -3.0):  # in (-pi, pi] already, or -pi: pi
        text = GOOD.replace("pose = [2.5, 2.5, 1.57]", f"pose = [2.5, 2.5, {written!r}]")
        assert load_scenario(_write(tmp_path, text)).goal.theta == (np.pi if written == -np.pi else written)


def test_a_generated_world_loads_by_its_name_for_any_robot() -> None:
    """``random<N>`` is the generated world of seed N (``random_scenario``), wherever a scenario name is
    taken; every robot may drive it; Hybrid-A* plans it unless another planner is chosen (without one,
    ``nhsim simulate --scenario random7`` fell back to the figure-eight reference, which no random world
    has room for); a malformed name is an error that says how to write one."""
    from planning.scenario import random_scenario, scenario_with_robot

    loaded, drawn = load_scenario("random42"), random_scenario("turtlebot3", 42)
    assert loaded == drawn and loaded.name == "random42" and loaded.robot == "turtlebot3"
    assert loaded.planner == "hybrid-a-star"
    assert load_scenario("random43").world != loaded.world
    for robot in ("edumip", "edumip-balancing"):
        assert scenario_with_robot(loaded, robot).robot == robot
        assert scenario_with_robot(loaded, robot).world == random_scenario(robot, 42).world
    for bad in ("random", "random-1", "random4x", "Random4"):
        with pytest.raises(ScenarioError, match=r"random<N> for the generated world of seed N"):
            load_scenario(bad)


#: The example of docs/how-to/new-scenario.md.
YARD = """
name = "yard"
robot = "turtlebot3"
robots = ["turtlebot3", "edumip"]
planner = "rrt-star"
[world]
bounds = [0.0, 4.0, 0.0, 3.0]
[[world.obstacles]]
type = "box"
center = [2.0, 1.5]
size = [0.4, 1.2]
[start]
pose = [0.4, 0.4, 0.0]
[goal]
pose = [3.6, 2.6, 1.57]
"""


def test_a_start_or_goal_the_robots_footprint_overlaps_is_refused_naming_file_field_robot_and_fix(
    tmp_path: Path,
) -> None:
    from planning.planners.base import PlanProblem
    from planning.planners.registry import make_planner
    from planning.scenario import scenario_with_robot

    path = _write(tmp_path, YARD.replace("pose = [0.4, 0.4, 0.0]", "pose = [0.01, 0.4, 0.0]"))
    sc = load_scenario(path)  # its centre is free: the file itself is sound
    with pytest.raises(ScenarioError) as err:
        scenario_with_robot(sc, None)
    said = str(err.value)
    assert said.startswith(f"{path}: field 'start.pose': [0.01, 0.4, 0.0] is not free for robot 'turtlebot3'")
    said_overlap = "overlaps the wall x = 0 by 94.1 mm (the planners' check reads -0.097 m); move the start more than"
    assert f"{said_overlap} 0.097 m away from it" in said  # the exact overlap, and the planners' number
    # the planners' own clearance, the one number: the API's planner still answers with a status
    plan = make_planner("rrt").plan(PlanProblem.from_scenario(sc, time_limit=5.0))
    assert plan.status == "invalid_start" and "clearance -0.097 m" in plan.reason
    corner = load_scenario(_write(tmp_path, YARD.replace("pose = [3.6, 2.6, 1.57]", "pose = [3.99, 2.99, 1.57]")))
    with pytest.raises(ScenarioError, match=r"'goal.pose'.*overlaps the walls x = 4 and y = 3 .*away from them$"):
        scenario_with_robot(corner, None)
    # the footprint is the robot's: 8 cm from the wall the TurtleBot3's tail is in it, the EduMIP's is not
    near = load_scenario(_write(tmp_path, YARD.replace("pose = [0.4, 0.4, 0.0]", "pose = [0.08, 0.4, 0.0]")))
    with pytest.raises(ScenarioError, match=r"robot 'turtlebot3'.*by 24.1 mm \(the planners' check reads -0.026 m\)"):
        scenario_with_robot(near, None)
    assert scenario_with_robot(near, "edumip").robot == "edumip"
    assert scenario_with_robot(near, None, ends=False) is near  # ends replaced (a trajectory file's): not checked


def test_a_pose_clear_by_less_than_the_checks_error_is_refused_as_such_not_as_an_overlap(tmp_path: Path) -> None:
    """1.9 mm from the wall the footprint is clear, but the planners' check (erring up to 2.5 mm low) reads an
    overlap: it was refused as "overlaps ... (clearance -0.000 m)"."""
    from planning.scenario import scenario_with_robot

    sc = load_scenario(_write(tmp_path, YARD.replace("pose = [0.4, 0.4, 0.0]", "pose = [0.106, 0.4, 0.0]")))
    with pytest.raises(ScenarioError) as err:
        scenario_with_robot(sc, None)
    said = str(err.value)
    assert "comes within 1.9 mm of the wall x = 0, which the planners' collision check does not tell apart" in said
    assert "it reads -0.5 mm, erring up to 2.5 mm on the safe side" in said and "overlaps" not in said


def test_an_obstacle_inside_the_footprint_is_named_not_an_infinite_clearance(tmp_path: Path) -> None:
    """A speck (a noisy map's pixel) under the robot, its centre free: the pose is inside an obstacle."""
    from planning.planners.base import PlanProblem
    from planning.planners.registry import make_planner
    from planning.scenario import scenario_with_robot

    speck = '[[world.obstacles]]\ntype = "box"\ncenter = [0.43, 0.42]\nsize = [0.01, 0.01]\n[start]'
    sc = load_scenario(_write(tmp_path, YARD.replace("[start]", speck)))
    with pytest.raises(ScenarioError) as err:
        scenario_with_robot(sc, None)
    said = str(err.value)
    assert "'start.pose'" in said and "holds part of the box at x 0.425..0.435, y 0.415..0.425" in said
    assert "the pose is inside an obstacle for this robot" in said and "inf" not in said
    assert re.search(r"move the start more than 0\.\d{3} m away from it \(the turtlebot3 reaches 0.126 m", said)
    plan = make_planner("rrt").plan(PlanProblem.from_scenario(sc, time_limit=5.0))
    assert plan.status == "invalid_start" and "an obstacle lies inside the robot's footprint" in plan.reason
    assert "inf" not in plan.reason


def test_a_robot_a_scenario_file_does_not_list_is_refused_naming_the_robots_line_to_add(tmp_path: Path) -> None:
    """A file without ``robots`` suits its own robot only; ``--robot edumip`` on one said "scenario
    'w07_gap_just_wider''s robots (turtlebot3)" (a doubled quote) and not how to list the robot."""
    from planning.errors import ConfigError
    from planning.scenario import scenario_with_robot

    text = "[world]\nbounds = [0, 3, 0, 2]\n[start]\npose = [0.5, 1.0, 0.0]\n[goal]\npose = [2.5, 1.0, 0.0]\n"
    path = tmp_path / "w07_gap_just_wider.toml"
    path.write_text(text)
    sc = load_scenario(path)
    assert sc.robots == ("turtlebot3",)
    with pytest.raises(ConfigError) as err:
        scenario_with_robot(sc, "edumip")
    said = str(err.value)
    assert said.startswith(
        "robot 'edumip' is not among the robots (turtlebot3) that scenario 'w07_gap_just_wider' lists"
    )
    assert "(a scenario without a robots key lists its own robot only)" in said and "''s" not in said
    assert said.endswith(f'or add robots = ["turtlebot3", "edumip"] to the scenario file {path}')
    path.write_text('robots = ["turtlebot3", "edumip"]\n' + text)  # as it says
    assert scenario_with_robot(load_scenario(path), "edumip").robot == "edumip"
    with pytest.raises(ConfigError, match=r'add robots = \["turtlebot3", "edumip"\] to a copy of the scenario'):
        scenario_with_robot(load_scenario("three_point_turn"), "edumip")  # a built-in's file is not to be edited


def test_a_pose_in_a_slot_narrower_than_the_robot_names_both_sides(tmp_path: Path) -> None:
    """The advice named the nearer box alone ("move the goal more than 0.012 m away from it"), which put the
    footprint on the other one: the slot (0.16 m) is narrower than the TurtleBot3 (0.178 m across)."""
    from planning.scenario import scenario_with_robot

    text = """name = "slot"
[world]
bounds = [0.0, 3.5, 0.0, 2.0]
[[world.obstacles]]
type = "box"
center = [2.5, 0.46]
size = [1.0, 0.92]
[[world.obstacles]]
type = "box"
center = [2.5, 1.54]
size = [1.0, 0.92]
[start]
pose = [0.5, 1.0, 0.0]
[goal]
pose = [2.8, 1.0, 3.14159]
"""
    with pytest.raises(ScenarioError) as err:
        scenario_with_robot(load_scenario(_write(tmp_path, text)), None)
    said = str(err.value)
    assert "overlaps the box at x 2..3, y 0..0.92 by" in said
    assert "and overlaps the box at x 2..3, y 1.08..2 too" in said
    fix = "move the goal clear of all of them (the turtlebot3's footprint is 0.178 m across, 0.144 m long), or turn it"
    assert said.endswith(fix)


def test_a_built_in_name_is_the_built_in_scenario_whatever_the_working_directory_holds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A folder ``open`` (or an empty file ``farm``) in the working directory made ``--scenario open`` and the
    regression suite's own cases refuse "the folder 'open'" or read the empty file: a bare built-in name, or
    random<N>, is the built-in scenario; the local file is loaded when given as a path."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "open").mkdir()
    (tmp_path / "farm").write_text("")
    (tmp_path / "random4").write_text("")
    assert load_scenario("open") == load_scenario(SCENARIOS_DIR / "open.toml")
    assert load_scenario("farm") == load_scenario(SCENARIOS_DIR / "farm.toml")
    assert load_scenario("random4").name == "random4"
    with pytest.raises(ScenarioError, match="missing field"):
        load_scenario("./farm")  # a path: the file itself
    with pytest.raises(ScenarioError, match="the folder"):
        load_scenario("./open")
    with pytest.raises(ScenarioError, match="missing field"):
        load_scenario(Path("farm"))  # a Path is the file it names, when there is one
    assert load_scenario(Path("edumip_map")).name == "edumip_map"  # else the built-in (no such file here)
    assert load_scenario(Path("random12")).name == "random12"


@pytest.mark.parametrize("suffix", [".json", ".yaml"])
def test_a_scenario_in_json_or_yaml_is_told_scenario_files_are_toml(tmp_path: Path, suffix: str) -> None:
    """It said the TOML parser's first complaint ("not valid TOML: Invalid statement (at line 1, column 1)")."""
    path = tmp_path / f"yard{suffix}"
    path.write_text('{"name": "yard"}' if suffix == ".json" else "name: yard\n")
    with pytest.raises(ScenarioError, match=rf"yard{suffix}: a scenario file is TOML, not {suffix[1:].upper()}; write"):
        load_scenario(path)


def test_load_scenario_takes_a_name_or_a_path_only() -> None:
    """``load_scenario(None)`` said "unknown scenario 'None'" (str() made it a name)."""
    from pathlib import Path

    from planning.errors import ScenarioError
    from planning.scenario import load_scenario

    for bad in (None, 3, b"open"):
        with pytest.raises(ScenarioError, match="load_scenario takes a scenario's name or its file's path, got"):
            load_scenario(bad)  # type: ignore[arg-type]
    assert load_scenario(Path("open")).name == load_scenario("open").name == "open"
