"""The Python API's values and arguments: the simulator's checks, its settings' flags, the video writer's pipes,
the run log's arrays and repr, gains files that read back what they wrote, and registrations run again."""

from __future__ import annotations

import copy
import datetime
import gc
import pickle
import re
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from control import base
from control.base import BASELINES, TRACKERS, make_tracker, register_tracker
from control.gains import FBLGains, GainsFile, dump_gains_toml, parse_gains_toml
from planning.core.geometry import Pose2D
from planning.core.plugins import BY_CODE, PLUGIN_VARIABLE
from planning.core.robot import RobotSpec, load_robot
from planning.core.world import Circle, World
from planning.errors import ConfigError
from planning.planners.registry import PLANNERS, register_planner
from planning.trajectory.references import make_reference
from planning.trajectory.trajectory import Trajectory
from sim.physics.runlog import EstimationLog, RunLog
from sim.physics.simulator import SimConfig, Simulator
from sim.viz.video import VideoWriter

WORLD = World((0.0, 4.0, 0.0, 4.0), (Circle((2.0, 2.0), 0.3),))


@pytest.fixture(scope="module")
def robot() -> RobotSpec:
    return load_robot("turtlebot3")


@pytest.fixture(scope="module")
def simulator(robot: RobotSpec) -> Simulator:
    return Simulator(robot, WORLD)


@pytest.fixture(scope="module")
def line(robot: RobotSpec) -> Trajectory:
    """A free line along y = 1 from (0.5, 1)."""
    return make_reference("line", robot, Pose2D(0.5, 1.0, 0.0))


@pytest.fixture(scope="module")
def line_log(simulator: Simulator, robot: RobotSpec, line: Trajectory) -> RunLog:
    return simulator.run(line, make_tracker("fbl", robot))


# ---- the simulator checks its arguments -----------------------------------------------------------------
@pytest.mark.parametrize(
    ("call", "said"),
    [
        pytest.param(
            lambda r, s, t: Simulator(r, None, 3),  # type: ignore[arg-type]
            r"^Simulator: build must be an AsBuilt or None \(the robot as drawn\): pass "
            r"AsBuilt\.draw\('turtlebot3', 3\) for the build of seed 3, got int 3$",
            id="build-int",
        ),
        pytest.param(
            lambda r, s, t: Simulator("turtlebot3"),  # type: ignore[arg-type]
            r"^Simulator: robot must be a RobotSpec \(load_robot\('turtlebot3'\)\), got 'turtlebot3'$",
            id="robot-name",
        ),
        pytest.param(
            lambda r, s, t: Simulator(r, (0, 4, 0, 4)),  # type: ignore[arg-type]
            r"^Simulator: world must be a World or None \(an empty floor\): pass World\(\(0, 4, 0, 4\)\) for bounds",
            id="world-tuple",
        ),
        pytest.param(
            lambda r, s, t: s.run(t, "fbl"),
            r"^Simulator\.run: tracker must be a Tracker .*: pass make_tracker\('fbl', robot\), got str 'fbl'$",
            id="tracker-name",
        ),
        pytest.param(
            lambda r, s, t: s.run(None, make_tracker("fbl", r)),
            r"^Simulator\.run: trajectory must be a Trajectory: pass make_reference\(name, robot, start\), .*"
            r"got NoneType None$",
            id="trajectory-none",
        ),
        pytest.param(
            lambda r, s, t: s.run(t, make_tracker("fbl", r), {"control_rate": 25}),
            r"^Simulator\.run: config must be a SimConfig or None \(the defaults\): pass SimConfig\(control_rate=25\), "
            r"got dict \{'control_rate': 25\}$",
            id="config-dict",
        ),
        pytest.param(
            lambda r, s, t: s.run(t, make_tracker("fbl", r), start=(1, 1, 0)),
            r"^Simulator\.run: start must be a Pose2D or None: pass Pose2D\(1, 1, 0\), got tuple \(1, 1, 0\)$",
            id="start-tuple",
        ),
        pytest.param(
            lambda r, s, t: s.run(t, make_tracker("fbl", r), perturbation="mass=1.3"),
            r"^Simulator\.run: perturbation must be a Perturbation or None: pass .*Perturbation\.parse",
            id="perturbation-text",
        ),
        pytest.param(
            lambda r, s, t: s.run(t, make_tracker("fbl", r), source="gps"),
            r"^Simulator\.run: source must be a PoseSource: pass one of PoseSource\.FUSED \('fused'\), .*got str "
            r"'gps'$",
            id="source-unknown",
        ),
        pytest.param(
            lambda r, s, t: s.run(t, make_tracker("fbl", r), progress=5),
            r"^Simulator\.run: progress must be a callable or None",
            id="progress-int",
        ),
    ],
)
def test_the_simulator_refuses_an_argument_of_the_wrong_type_naming_it_what_was_given_and_the_fix(
    robot: RobotSpec, simulator: Simulator, line: Trajectory, call: Callable[..., Any], said: str
) -> None:
    """Each of these was an AttributeError from deep inside ('int' object has no attribute 'compile', 'str'
    object has no attribute 'name', ...)."""
    with pytest.raises(ConfigError, match=said):
        call(robot, simulator, line)


@pytest.mark.parametrize(
    ("start", "said"),
    [
        (Pose2D(-3.0, -3.0, 0.0), r"start \(-3, -3, 0\) lies outside the world's walls \(x 0\.\.4, y 0\.\.4 m\)"),
        (Pose2D(4.5, 1.0, 0.0), r"start \(4\.5, 1, 0\) lies outside the world's walls"),
    ],
)
def test_a_run_from_a_start_outside_the_world_is_refused(
    robot: RobotSpec, simulator: Simulator, line: Trajectory, start: Pose2D, said: str
) -> None:
    """From (-3, -3) outside the 4 x 4 m world the run ended 'ok', with no contact and no warning."""
    with pytest.raises(ConfigError, match=rf"^Simulator\.run: {said}.*: give a start"):
        simulator.run(line, make_tracker("fbl", robot), start=start)


def test_a_trajectory_that_starts_outside_the_world_is_refused_when_no_start_is_given(
    robot: RobotSpec, simulator: Simulator
) -> None:
    outside = make_reference("line", robot, Pose2D(-1.0, 1.0, 0.0))
    with pytest.raises(ConfigError, match=r"^Simulator\.run: the trajectory's first pose \(-1, 1, 0\) lies outside"):
        simulator.run(outside, make_tracker("fbl", robot))


def test_a_run_from_a_free_start_still_runs(line_log: RunLog) -> None:
    assert line_log.status == "ok" and not line_log.contacts
    assert line_log.pose[0, 0] == pytest.approx(0.5, abs=0.01)


# ---- SimConfig's flag is True or False -------------------------------------------------------------------
@pytest.mark.parametrize("value", ["no", "false", 0, 1, None, "True"])
def test_sim_config_strict_refuses_what_is_not_true_or_false(value: object) -> None:
    """``SimConfig(strict="no").strict`` was "no", which a run reads as true."""
    hint = r" \(true or false, unquoted, in a TOML or JSON file or a KEY=VALUE option\)"
    toml = hint if isinstance(value, str) else ""
    said = rf"^SimConfig\.strict must be True or False, got {re.escape(repr(value))}{toml}$"
    with pytest.raises(ConfigError, match=said):
        SimConfig(strict=value)  # type: ignore[arg-type]


def test_sim_config_strict_takes_a_bool_and_a_numpy_bool() -> None:
    assert SimConfig(strict=False).strict is False
    assert SimConfig(strict=np.bool_(False)).strict is False  # type: ignore[arg-type]
    assert SimConfig().strict is True


# ---- the video writer closes ffmpeg's pipes --------------------------------------------------------------
def _frames(writer: VideoWriter, count: int) -> None:
    for k in range(count):
        writer.write(np.full((32, 32, 3), 10 * k, np.uint8))


def _pipes_closed(writer: VideoWriter) -> bool:
    proc = writer._proc
    assert proc is not None and proc.stdin is not None and proc.stderr is not None
    return bool(proc.stdin.closed and proc.stderr.closed)


def test_a_finished_video_leaves_no_pipe_open(tmp_path: Path) -> None:
    """write_video gave a ResourceWarning (unclosed file: ffmpeg's stderr) on every call."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ResourceWarning)
        with VideoWriter(tmp_path / "v.mp4", 32, 32, 5.0) as writer:
            _frames(writer, 3)
        assert _pipes_closed(writer)
        gc.collect()
    assert (tmp_path / "v.mp4").stat().st_size > 0
    assert not [w for w in caught if issubclass(w.category, ResourceWarning)], [str(w.message) for w in caught]


def test_a_failed_or_interrupted_video_leaves_no_pipe_open(tmp_path: Path) -> None:
    for error in (RuntimeError("drawing failed"), KeyboardInterrupt()):
        with pytest.raises(type(error)), VideoWriter(tmp_path / "v.mp4", 32, 32, 5.0) as writer:
            _frames(writer, 2)
            raise error
        assert _pipes_closed(writer) and not (tmp_path / "v.mp4").exists()


# ---- a run log's arrays are read-only and its repr short -------------------------------------------------
def _series(n: int) -> dict[str, Any]:
    rng = np.random.default_rng(0)
    return {
        "t": np.linspace(0.0, 0.02 * (n - 1), n),
        **{k: rng.random((n, 3)) for k in ("pose", "ref_pose")},
        "qpos": rng.random((n, 9)),
        **{k: rng.random((n, 2)) for k in ("command", "wheel_command", "wheel_speed")},
        "wheel_off_floor": np.zeros(n, dtype=bool),
    }


def test_a_run_logs_arrays_are_read_only_in_it_and_in_its_copies() -> None:
    """RunLog's arrays were writeable while a Trajectory's and a PlanResult's are not: an edit reached every record,
    plot and video made of the run."""
    series = _series(5)
    k = 3
    est = EstimationLog(
        "fused",
        np.arange(k, dtype=float),
        np.zeros((k, 3)),
        np.zeros((k, 3)),
        np.ones((k, 3)),
        np.zeros(0),
        np.zeros((0, 3)),
        np.zeros(0, dtype=bool),
        np.zeros(0),
        np.zeros(0),
        (0.2, 9.3),
    )
    log = RunLog(**series, estimation=est)
    for copied in (log, pickle.loads(pickle.dumps(log)), copy.deepcopy(log)):
        for name in [*copied.arrays(), "wheel_off_floor"]:
            with pytest.raises(ValueError, match="read-only"):
                getattr(copied, name)[0] = 1.0
        assert copied.estimation is not None
        with pytest.raises(ValueError, match="read-only"):
            copied.estimation.estimate[0, 0] = 1.0
        assert copied.identical_to(log)
    # read-only views of the arrays given, not copies, which stay as they were
    assert all(np.shares_memory(getattr(log, k), v) and v.flags.writeable for k, v in series.items())


def test_a_simulated_run_logs_arrays_are_read_only(line_log: RunLog) -> None:
    with pytest.raises(ValueError, match="read-only"):
        line_log.t[0] = 9.0
    assert not any(a.flags.writeable for a in line_log.arrays().values())


def test_a_run_logs_repr_is_one_short_line() -> None:
    """repr(RunLog) of a 10 s run was 23 KB (every series printed)."""
    meta = {"robot": "turtlebot3", "tracker": "fbl", "trajectory": "line"}
    long = RunLog(**_series(5000), meta=meta, status="collided with box 3 at t=2.000 s, then " + "fell " * 100)
    said = repr(long)
    assert said.startswith("RunLog('fbl on line', turtlebot3, 5000 samples, t 0..99.98 s, status='collided")
    assert len(said) < 300 and "\n" not in said and said.endswith("...')") and str(long) == said
    assert repr(RunLog(**_series(3))) == "RunLog('? on ?', 3 samples, t 0..0.04 s, status='ok')"


# ---- gains files are checked, and read back what they wrote ----------------------------------------------
HOSTILE = [
    "a\tb\x01c",
    "\x00\x08\x0b\x0e\x1f\x7f",
    'say "hi"',
    "back\\slash\\",
    "\\u0041 and \\n as text",
    "line\r\nbreak\x0c",
    "'''\"\"\"",
    "[gains]\nkp = 1",
    "# not a comment",
    "",
    "é ✓ \U0001f600 \u2028",
    "naïve",  # a key of letters, but not ASCII ones: quoted (a bare key is ASCII)
]


@pytest.mark.parametrize("text", HOSTILE)
def test_dump_then_parse_gives_back_every_string_and_key(text: str) -> None:
    """A control character of a provenance string was written raw: parse_gains_toml could not read its own output
    ("Illegal character '\\x01'")."""
    prov = {"note": text, "list": [text, 1], "table": {text: text, "x": {text: [text]}}, text: True}
    written = GainsFile(FBLGains(kp=14.2, kd=7.9), prov)
    assert parse_gains_toml(dump_gains_toml(written)) == written


def test_dump_then_parse_gives_back_numbers_dates_and_times() -> None:
    prov = {
        "objective": 1.0 / 3.0,
        "trials": 10**12,
        "seed": np.int64(7),
        "when": datetime.datetime(2024, 5, 6, 7, 8, 9, 123456, tzinfo=datetime.UTC),
        "day": datetime.date(2024, 5, 6),
        "at": datetime.time(7, 8, 9),
        "empty": {},
        "none": [],
    }
    assert parse_gains_toml(dump_gains_toml(GainsFile(FBLGains(), prov))).provenance == prov


@pytest.mark.parametrize(
    ("gains", "provenance", "said"),
    [
        ({"kp": 1}, {}, r"^GainsFile\.gains must be an FBLGains: pass FBLGains\(kp=1\), got dict \{'kp': 1\}$"),
        ("9,6", {}, r"^GainsFile\.gains must be an FBLGains: pass FBLGains\(kp=9\.0, kd=6\.0\), got str '9,6'$"),
        (FBLGains(), ["x"], r"^GainsFile\.provenance must be a dict .*got list \['x'\]$"),
        (FBLGains(), {("a",): 1}, r"^GainsFile\.provenance: the key \('a',\) must be text"),
        (FBLGains(), {"x": None}, r"^GainsFile\.provenance\['x'\] holds NoneType None; a gains file's provenance"),
        (FBLGains(), {"o": float("nan")}, r"^GainsFile\.provenance\['o'\] holds the non-finite number nan"),
        (FBLGains(), {"t": {"u": [1, object()]}}, r"^GainsFile\.provenance\['t'\]\['u'\]\[1\] holds object"),
        (FBLGains(), {"s": "\ud800"}, r"^GainsFile\.provenance\['s'\] holds text that is not Unicode"),
    ],
)
def test_a_gains_file_checks_its_fields_when_made(gains: object, provenance: object, said: str) -> None:
    """GainsFile({"kp": 1}) was accepted, and dump_gains_toml then raised AttributeError."""
    with pytest.raises(ConfigError, match=said):
        GainsFile(gains, provenance)  # type: ignore[arg-type]


def test_a_gains_files_provenance_that_no_file_holds_is_refused_naming_the_file() -> None:
    with pytest.raises(ConfigError, match=r"^g\.toml: provenance\['x'\] holds the non-finite number nan"):
        parse_gains_toml("[gains]\nkp = 1\nkd = 2\n[provenance]\nx = nan\n", where="g.toml")


# ---- a registration run again (a notebook cell) ----------------------------------------------------------
@pytest.fixture
def registries(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """The registries as they are now, restored after the test."""
    for registered in (TRACKERS, PLANNERS):
        registered.load_plugins()
        monkeypatch.setattr(registered, "_entries", dict(registered._entries))
        monkeypatch.setattr(registered, "origins", dict(registered.origins))
    monkeypatch.setattr(base, "BASELINES", set(BASELINES))
    monkeypatch.delenv(PLUGIN_VARIABLE, raising=False)
    yield


PLANNER_CELL = """
class Straight:
    name = "straight"

    def __init__(self, *, spacing: float = SPACING) -> None:
        self.spacing = spacing

    def plan(self, problem):
        raise NotImplementedError

register_planner("straight", Straight)
"""

TRACKER_CELL = """
class Still:
    name = "still"

    def __init__(self, robot, *, speed: float = SPEED) -> None:
        self.speed = speed

    def reset(self, trajectory, dt):
        pass

    def command(self, t, x, y, theta):
        return self.speed, 0.0

register_tracker("still", Still)
"""


def _cell(code: str, module: str = "__main__", **names: Any) -> dict[str, Any]:
    """Run a notebook cell's code as module ``module`` would; its names."""
    ns: dict[str, Any] = {"__name__": module, **names}
    exec(code, ns)
    return ns


def test_a_notebook_cell_that_registers_a_planner_runs_again(registries: None) -> None:
    """Re-running the unchanged cell raised RegistrationError ("pass replace=True"): the class it defines again is
    a new object."""
    names = {"register_planner": register_planner}
    first = _cell(PLANNER_CELL, SPACING=0.02, **names)["Straight"]
    again = _cell(PLANNER_CELL, SPACING=0.02, **names)["Straight"]
    edited = _cell(PLANNER_CELL, SPACING=0.05, **names)["Straight"]
    assert first is not again is not edited and PLANNERS["straight"] is edited
    assert PLANNERS.origin("straight") == BY_CODE
    other = _cell(PLANNER_CELL.replace("Straight", "Other").split("register_planner")[0], SPACING=0.02)["Other"]
    with pytest.raises(ConfigError, match=r"planner 'straight' is already registered .* as __main__:Straight; choose"):
        register_planner("straight", other)  # another class under the name
    with pytest.raises(ConfigError, match=r"planner 'straight' is already registered .* as __main__:Straight; choose"):
        _cell(PLANNER_CELL, "mymodule", SPACING=0.02, **names)  # the same name in another module: another class
    with pytest.raises(ConfigError, match=r"planner 'rrt' is already registered \(built in\)"):
        _cell(PLANNER_CELL.replace('"straight", Straight', '"rrt", Straight'), SPACING=0.02, **names)
    assert PLANNERS["straight"] is edited


def test_a_notebook_cell_that_registers_a_tracker_runs_again(registries: None, robot: RobotSpec) -> None:
    names = {"register_tracker": register_tracker}
    _cell(TRACKER_CELL, SPEED=0.0, **names)
    _cell(TRACKER_CELL, SPEED=0.0, **names)
    edited = _cell(TRACKER_CELL, SPEED=0.1, **names)["Still"]
    assert TRACKERS["still"] is edited and make_tracker("still", robot).command(0.0, 0.0, 0.0, 0.0) == (0.1, 0.0)
    with pytest.raises(ConfigError, match=r"tracker 'still' is already registered .* as __main__:Still; choose"):
        _cell(TRACKER_CELL, "mymodule", SPEED=0.0, **names)
    with pytest.raises(ConfigError, match=r"tracker 'fbl' is already registered \(built in\)"):
        _cell(TRACKER_CELL.replace('"still", Still', '"fbl", Still'), SPEED=0.0, **names)
