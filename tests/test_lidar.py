"""The LDS-01 scan model: datasheet checks, ranges against analytic distances, skew, REP 117, seeds."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from planning.core.robot import load_robot
from planning.core.world import Box, Circle, World
from planning.errors import ConfigError
from sim.physics.lidar import LDS01_PLANE, LidarProfile, LidarScanner, beam_poses, load_lidar_profile, unit_errors
from sim.physics.model import build_model
from sim.pipeline.runs import RunKind

WORLD = World((-2.0, 2.0, -1.5, 1.5), (Box((1.0, 0.5), (0.4, 0.3), 0.3), Circle((-1.0, -0.5), 0.3)))
EXACT = LidarProfile(accuracy_near=0, accuracy_far=0, precision_near=0, precision_far=0)


def _ray_box(o: np.ndarray, d: np.ndarray, box: Box) -> float:
    c, s = math.cos(box.angle), math.sin(box.angle)
    rot = np.array([[c, s], [-s, c]])
    lo_, do = rot @ (o - np.asarray(box.center)), rot @ d
    h = 0.5 * np.asarray(box.size)
    t0, t1 = -math.inf, math.inf
    for k in range(2):
        if abs(do[k]) < 1e-15:
            if abs(lo_[k]) > h[k]:
                return math.inf
            continue
        a, b = (-h[k] - lo_[k]) / do[k], (h[k] - lo_[k]) / do[k]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
    return t0 if t0 <= t1 and t0 > 0 else math.inf


def _ray_circle(o: np.ndarray, d: np.ndarray, circ: Circle) -> float:
    f = o - np.asarray(circ.center)
    b = float(f @ d)
    disc = b * b - (float(f @ f) - circ.radius**2)
    if disc < 0:
        return math.inf
    t = -b - math.sqrt(disc)
    return t if t > 0 else math.inf


def _ray_walls(o: np.ndarray, d: np.ndarray, bounds: tuple[float, ...]) -> float:
    ts = []
    for k, (lo, hi) in enumerate(((bounds[0], bounds[1]), (bounds[2], bounds[3]))):
        if d[k] > 0:
            ts.append((hi - o[k]) / d[k])
        elif d[k] < 0:
            ts.append((lo - o[k]) / d[k])
    return min(ts)


def analytic(origin: np.ndarray, heading: float) -> float:
    """Distance along a horizontal ray to WORLD's walls and obstacles (plain Python)."""
    d = np.array([math.cos(heading), math.sin(heading)])
    o = origin[:2]
    return min(
        _ray_walls(o, d, WORLD.bounds), _ray_box(o, d, WORLD.obstacles[0]), _ray_circle(o, d, WORLD.obstacles[1])
    )


@pytest.fixture(scope="module")
def scene() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = build_model(load_robot("turtlebot3"), WORLD).model
    return model, mujoco.MjData(model)


def _place(model: mujoco.MjModel, data: mujoco.MjData, pose: tuple[float, float, float]) -> None:
    data.qpos[:3] = [pose[0], pose[1], 0.033]
    data.qpos[3:7] = [math.cos(pose[2] / 2), 0, 0, math.sin(pose[2] / 2)]
    mujoco.mj_forward(model, data)


def test_profile_is_the_datasheet_and_refuses_values_outside_it() -> None:
    p = load_lidar_profile("turtlebot3")
    assert p is not None and (p.beams, p.rate, p.range_min, p.range_max) == (360, 5.0, 0.12, 3.5)
    for text, field in [
        ("beams=720", "beams"),
        ("rate=10", "rate"),
        ("range_max=8", "range_max"),
        ("range_min=0.05", "range_min"),
        ("beams=90.5", "beams"),
    ]:
        with pytest.raises(ConfigError, match=field):
            p.parse(text)
    with pytest.raises(ConfigError, match="range_min"):
        p.parse("range_min=2,range_max=1")
    with pytest.raises(ConfigError, match="unknown key 'fov'"):
        p.override({"fov": 1.0})
    assert load_lidar_profile("edumip") is None
    with pytest.raises(ConfigError, match="no laser scanner"):
        load_lidar_profile("edumip", text="beams=90")


def test_ranges_match_analytic_distances_to_walls_boxes_and_circles(scene: tuple) -> None:
    model, data = scene
    pose = (0.1, -0.2, 0.4)
    _place(model, data, pose)
    lidar = LidarScanner(model, EXACT, seed=1)
    assert lidar.height == pytest.approx(LDS01_PLANE, abs=1e-6) == pytest.approx(0.182, abs=1e-6)
    poses = np.tile(pose, (360, 1))
    got = lidar.cast(data, poses)
    origin = lidar.origins(poses[:1])[0]
    assert np.allclose(origin[:2], [0.1 - 0.032 * math.cos(0.4), -0.2 - 0.032 * math.sin(0.4)])
    want = np.array([analytic(origin, pose[2] + math.radians(i)) for i in range(360)])
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, want, atol=1e-9)
    # the robot's own chassis and scanner housing are not seen
    assert got.min() > 0.3


def test_rep117_out_of_range_returns() -> None:
    big = World((-5.0, 5.0, -0.5, 0.5))
    m2 = build_model(load_robot("turtlebot3"), big).model
    d2 = mujoco.MjData(m2)
    pose = (0.0, 0.4, 0.0)  # the lidar 0.1 m from the north wall, 4.96 m from the east one
    _place(m2, d2, pose)
    lidar = LidarScanner(m2, EXACT, seed=1)
    scan = lidar.scan(d2, 0.0, np.tile(pose, (360, 1)))
    assert scan.ranges[90] == -np.inf  # 0.1 m < range_min
    assert scan.ranges[0] == np.inf  # 4.97 m > range_max
    assert scan.ranges[270] == pytest.approx(0.9)
    assert not np.any(np.isnan(scan.ranges))


def test_a_turning_robot_sees_a_skewed_scan(scene: tuple) -> None:
    model, data = scene
    _place(model, data, (0.0, 0.0, 0.0))
    lidar = LidarScanner(model, EXACT, seed=1)
    one = LidarScanner(model, EXACT, seed=1, batch_time=0.0)  # one beam a call: each from its own origin
    assert (lidar.batch, one.batch) == (18, 1)
    # turning in place at 2 rad/s while driving 0.2 m/s: the pose logged every 20 ms
    t = np.arange(0.0, 0.2001, 0.02)
    log = np.column_stack([0.2 * t, 0.05 * t, 2.0 * t])
    times = lidar.profile.time_increment * np.arange(360)
    poses = beam_poses(t, log, times)
    got = lidar.cast(data, poses)
    origins = lidar.origins(poses)
    want = np.array([analytic(origins[i], poses[i, 2] + math.radians(i)) for i in range(360)])
    np.testing.assert_allclose(one.cast(data, poses), want, atol=1e-9)
    # 18 beams share the origin of the middle one (<= 1 mm apart): grazing beams aside, as close
    assert np.mean(np.abs(got - want) < 2e-3) > 0.98  # (a shifted origin moves a range by up to twice as much)
    still = lidar.cast(data, np.tile(log[0], (360, 1)))
    assert np.max(np.abs(got - still)) > 0.05


def test_noise_is_seeded_and_has_the_datasheet_statistics(scene: tuple) -> None:
    model, data = scene
    pose = (0.0, 0.0, 0.0)
    _place(model, data, pose)
    p = LidarProfile()
    poses = np.tile(pose, (360, 1))
    a, b, c = (LidarScanner(model, p, seed=s) for s in (7, 7, 8))
    ra = [a.scan(data, 0.2 * k, poses).ranges for k in range(3)]
    rb = [b.scan(data, 0.2 * k, poses).ranges for k in range(3)]
    assert all(np.array_equal(x, y) for x, y in zip(ra, rb, strict=True))
    assert not np.array_equal(ra[0], ra[1])  # white noise differs between revolutions
    assert not np.array_equal(ra[0], c.scan(data, 0.0, poses).ranges)
    truth = a.cast(data, poses)
    errs = np.array([a.measure(truth) - truth for _ in range(400)])  # (400, 360)
    far = truth >= p.accuracy_split
    rel = errs[:, far] / truth[far]
    assert abs(a.bias_far) <= 1.0
    assert rel.mean() == pytest.approx(a.bias_far * p.accuracy_far, abs=0.002)
    assert rel.std() == pytest.approx(p.precision_far, rel=0.02)
    # the run record's lidar_unit is this unit's draw (the far scale measured above, the near offset as drawn)
    assert unit_errors(p, 7) == {
        "offset_near_m": a.bias_near * p.accuracy_near,
        "scale_far": a.bias_far * p.accuracy_far,
    }
    assert unit_errors(p, 8) != unit_errors(p, 7)


def test_the_scan_passes_over_an_obstacle_below_its_plane_and_the_robot_does_not() -> None:
    """An obstacle's height: one below the LDS-01's plane (0.182 m) is in physics (the robot hits it) but not in
    the scan, nor in the map the localiser matches scans to (``World.seen_at``); every obstacle was 0.3 m."""
    low, tall = Box((1.0, 0.0), (0.2, 0.6), height=0.1), Circle((-1.0, 0.0), 0.2, height=0.25)
    world = World((-2.0, 2.0, -1.5, 1.5), (low, tall))
    model = build_model(load_robot("turtlebot3"), world).model
    data = mujoco.MjData(model)
    box, disc = model.geom("obstacle_0"), model.geom("obstacle_1")
    tops = [box.pos[2] + box.size[2], disc.pos[2] + disc.size[1]]  # a box's half height, a cylinder's
    np.testing.assert_allclose(tops, [0.1, 0.25])
    _place(model, data, (0.0, 0.0, 0.0))
    lidar = LidarScanner(model, EXACT, seed=1)
    got = lidar.cast(data, np.zeros((360, 3)))
    origin = lidar.origins(np.zeros((1, 3)))[0]
    ahead, behind = got[0], got[180]  # toward the low box (and the east wall past it), toward the disc
    assert ahead == pytest.approx(2.0 - origin[0], abs=1e-9)  # the wall, over the box
    assert behind == pytest.approx(origin[0] - (-1.0 + 0.2), abs=1e-9)  # the disc, above the plane
    assert world.seen_at(lidar.height).obstacles == (tall,) and world.seen_at(0.05) is world
    _place(model, data, (0.95, 0.0, 0.0))  # the robot on the low box: in contact with it
    obstacle = model.geom("obstacle_0").id
    assert any(obstacle in (c.geom1, c.geom2) for c in data.contact[: data.ncon])


def test_the_localisers_map_is_what_its_scanner_sees() -> None:
    """The particles are weighed against a map without the obstacles the scan passes over: with them, every
    beam that flies over a low box toward the wall behind it would be scored as a miss."""
    from control.estimation.amcl import AmclConfig, likelihood_field
    from sim.robot.scan_localiser import LocaliserSetup, ScanLocaliser

    low, tall = Box((1.0, 0.0), (0.2, 0.6), height=0.1), Box((-1.0, 0.0), (0.2, 0.6))
    world = World((-2.0, 2.0, -1.5, 1.5), (low, tall))
    robot = load_robot("turtlebot3")
    model = build_model(robot, world).model
    config = AmclConfig(max_particles=500)
    setup = LocaliserSetup("amcl", world, load_lidar_profile("turtlebot3"), config)
    loc = ScanLocaliser(model, robot, setup, 0, t0=0.0, dt=0.02, rad_per_count=2 * math.pi / 4096)
    args = (config.map_resolution, config.laser_likelihood_max_dist)
    seen, full = likelihood_field(World(world.bounds, (tall,)), *args), likelihood_field(world, *args)
    np.testing.assert_array_equal(loc.amcl.field.capped, seen.capped)
    assert not np.array_equal(seen.capped, full.capped)


# ------------------------------------------------------------------------ the command line's checks
ROOM_TOML = """name = "room"
robot = "turtlebot3"
[world]
bounds = [0.0, 3.0, 0.0, 2.0]
[[world.obstacles]]
type = "box"
center = [2.4, 1.5]
size = [0.4, 0.3]
[start]
pose = [1.0, 0.8, 0.3]
[goal]
pose = [2.0, 0.6, 0.0]
"""


def _simulate(tmp_path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, str]:
    """``nhsim simulate`` on a small room (a line reference), outputs in ``tmp_path``: (exit, stderr)."""
    from sim.cli.main import main

    scenario = tmp_path / "room.toml"
    scenario.write_text(ROOM_TOML)
    argv = ["simulate", "--scenario", str(scenario), "--reference", "line", "--no-video", "--no-plots", "--quiet"]
    try:
        code = main([*argv, "--json", str(tmp_path / "r.json"), *extra])
    except SystemExit as exc:  # argparse's refusal of an option's value
        code = int(exc.code or 0)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("accuracy_far=0.2", "lidar accuracy_far must be a finite number in [0, 0.05] (fraction of the range; "),
        ("accuracy_near=0.05", "lidar accuracy_near must be a finite number in [0, 0.015] (m; "),
        ("precision_far=0.1", "lidar precision_far must be a finite number in [0, 0.035] (fraction of the range; "),
        ("precision_near=0.02", "lidar precision_near must be a finite number in [0, 0.01] (m; "),
        # the near figures out to 3.5 m: a unit five times as precise as the datasheet's
        ("accuracy_split=3.5", "lidar accuracy_split must be a finite number in [0.5, 0.5] (m; the LDS-01's figures"),
    ],
)
def test_accuracy_and_precision_beyond_the_datasheet_are_refused(text: str, said: str) -> None:
    """``accuracy_far=0.2`` (20 % where the datasheet says 5 %) was accepted; the figures are bounds a unit within
    its datasheet meets, so 0 (calibrated, noise-free) up to the datasheet's figure, as the other fields are."""
    with pytest.raises(ConfigError) as err:
        LidarProfile().parse(text)
    assert str(err.value).startswith(said) and "give a value in [0" in str(err.value)
    p = LidarProfile().parse("accuracy_far=0.05,accuracy_near=0.015,precision_far=0.035,precision_near=0.01")
    assert p == LidarProfile() and EXACT.accuracy_far == 0.0


def test_fewer_beams_than_the_localiser_matches_are_refused_when_it_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--lidar beams=9`` ran the closed loop on dead reckoning (no revolution reaches MIN_BEAMS returns) and said
    "the scanner saw nothing: all 57 scans without returns"; it is refused before the run now, naming the minimum.
    The scanner itself may have fewer beams (a Python caller's profile, a run that takes no scan)."""
    from control.estimation.amcl import MIN_BEAMS
    from sim.cli.simulate import check_scan_beams
    from sim.pipeline.case import Case, load_case_scenario

    code, err = _simulate(tmp_path, capsys, "--runs", "closed_loop", "--lidar", f"beams={MIN_BEAMS - 1}")
    assert code == 2, err
    assert f"lidar beams={MIN_BEAMS - 1} (--lidar, or a --sensors file's [lidar] table): the scan localiser " in err
    assert f"at least {MIN_BEAMS} returns (control.estimation.amcl.MIN_BEAMS)" in err
    assert f"give --lidar beams={MIN_BEAMS} or more" in err and list(tmp_path.iterdir()) == [tmp_path / "room.toml"]
    assert LidarProfile(beams=3).beams == 3
    case = Case(str(tmp_path / "room.toml"), reference="line", lidar="beams=9")
    scenario = load_case_scenario(case)
    check_scan_beams(case, scenario, (RunKind.CLOSED_LOOP_ODOMETRY, RunKind.OPEN_LOOP))  # no scan taken: fine
    check_scan_beams(dataclasses.replace(case, lidar=f"beams={MIN_BEAMS}"), scenario, (RunKind.CLOSED_LOOP,))


def test_the_localiser_line_counts_revolutions_below_the_minimum_honestly() -> None:
    """A revolution that delivers no fix has fewer than MIN_BEAMS returns, not necessarily none: the line says
    that; and one scan is "1 scan"."""
    from control.estimation.amcl import MIN_BEAMS
    from sim.cli.simulate import localiser_line

    est = {"scans_used": 0, "scans_without_returns": 57, "scans_cast": 57}
    line = localiser_line(est)
    assert f"all 57 scans with fewer than {MIN_BEAMS} returns, the fewest the localiser matches (no fix)" in line
    assert "saw nothing" not in line and "without returns" not in line
    est = {"scans_used": 1, "scans_without_returns": 1, "scans_cast": 5, "global_localisation_scans": 1}
    est |= {"global_localisation_converged": True, "localiser_rmse_m": 0.01, "localiser_heading_rmse_rad": 0.01}
    line = localiser_line(est)
    assert line.startswith("localiser: 1 scan used, RMSE 1.0 cm")
    assert f"; 1 scan with fewer than {MIN_BEAMS} returns" in line and line.endswith("converged after 1 scan")
    assert "1 scans" not in line


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("nan,0,0", "--initial-pose nan,0,0: expected three finite numbers; give X,Y,THETA in metres and radians"),
        (
            "1,0.8,100",
            "--initial-pose 1,0.8,100: THETA is in radians within +-4 pi; 100 degrees would be 1.745 rad; give "
            "X,Y,THETA in metres and radians, e.g. --initial-pose 1.2,0.5,0.3",
        ),
        ("1,0.8,-1000", "--initial-pose 1,0.8,-1000: THETA is in radians within +-4 pi; give X,Y,THETA"),
        ("unkown", "--initial-pose unkown: not three numbers; give X,Y,THETA"),
    ],
)
def test_a_bad_initial_pose_is_said_in_the_command_lines_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, said: str
) -> None:
    """The errors quoted the Python API ("(initial_pose=... from Python)"), and a heading of 100 rad was accepted
    where a scenario file refuses beyond +-4 pi (planning.core.checks.MAX_HEADING)."""
    code, err = _simulate(tmp_path, capsys, f"--initial-pose={text}")
    assert code == 2 and said in err, err
    assert "from Python" not in err and not (tmp_path / "r.json").exists()


def test_a_python_callers_initial_pose_heading_is_judged_as_the_command_lines() -> None:
    from planning.errors import ConfigError
    from sim.pipeline.case import Case

    with pytest.raises(ConfigError, match=r"THETA is in radians within \+-4 pi; 100 degrees would be 1.745 rad"):
        Case("open", robot="turtlebot3", reference="line", initial_pose="1,0.8,100")
    assert Case("open", robot="turtlebot3", reference="line", initial_pose="1,0.8,-7").initial_pose == "1,0.8,-7"


def test_the_initial_pose_keywords_are_taken_in_any_case_and_an_unused_one_is_said() -> None:
    from sim.cli.main import build_parser
    from sim.cli.simulate import ignored_options, initial_pose_option

    assert [initial_pose_option(t) for t in ("UNKNOWN", "Known", " unknown ")] == ["unknown", "known", "unknown"]
    assert initial_pose_option("1,0.8,12.5") == "1,0.8,12.5"  # within 4 pi

    def notes(*extra: str) -> list[str]:
        return ignored_options(build_parser().parse_args(["simulate", "--reference", "line", *extra]))

    assert notes("--runs", "closed_loop_odometry", "--initial-pose", "UNKNOWN") == [
        "--initial-pose unknown ignored: no run of closed_loop_odometry localises with scans (only closed_loop, "
        "on the fused estimate, does)"
    ]
    assert notes("--initial-pose", "unknown") == [] and notes("--runs", "closed_loop_odometry") == []


def test_a_scan_rate_between_control_ticks_is_refused_with_the_rates_that_fit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--lidar rate=4.9`` was refused as "fix_rate must equal the scan rate: set --sensors fix_rate=4.9", which
    was then refused as not a whole number of control periods: no fix rate could equal it."""
    code, err = _simulate(tmp_path, capsys, "--runs", "closed_loop", "--lidar", "rate=4.9")
    assert code == 2 and "lidar rate=4.9 Hz: a revolution is 10.2 control periods at 50 Hz, not a whole number" in err
    assert err.rstrip().endswith("at a control tick; give --lidar rate=5") and "fix_rate" not in err
    code, err = _simulate(tmp_path, capsys, "--runs", "closed_loop", "--lidar", "rate=4.9", "--control-rate", "250")
    assert code == 2 and "give --lidar rate=5.10204 (or 5, 4.90196 Hz)" in err


@pytest.mark.parametrize(
    "argv",
    [
        ["montecarlo", "--reference", "line", "--robot", "turtlebot3", "--runs", "2"],
        ["tune", "--scenarios", "open:line", "--robot", "turtlebot3", "--trials", "1"],
    ],
)
def test_montecarlo_and_tune_refuse_fewer_beams_than_the_localiser_matches_as_simulate_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, argv: list[str]
) -> None:
    from control.estimation.amcl import MIN_BEAMS
    from sim.cli.main import main

    monkeypatch.chdir(tmp_path)
    assert main([*argv, "--lidar", f"beams={MIN_BEAMS - 1}"]) == 2
    assert f"lidar beams={MIN_BEAMS - 1} (--lidar, or a --sensors file's [lidar] table)" in capsys.readouterr().err
    assert not list(tmp_path.rglob("*.*"))  # nothing written
