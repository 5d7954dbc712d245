"""A job's case takes each setting once and as what it is, and its record says what ran: the FBL gains given as
gains or as the tracker's params, a tracker's own parameters, flags, the control rate."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from control.gains import FBLGains
from control.kanayama import KanayamaParams
from planning.errors import ConfigError
from planning.trajectory.importer import TrajectoryFile
from sim.pipeline.case import Case
from sim.pipeline.simulate import simulate_reference

SHORT = {"reference": "line", "runs": ["closed_loop"]}


def test_the_fbls_gains_given_as_its_params_are_the_gains_it_ran_and_recorded() -> None:
    """params=FBLGains(kp=30) ran kp=30 while job.gains and the record said kp=9 (the defaults); with gains=kp 5
    beside it, kp 30 ran and the record said 5."""
    as_params = simulate_reference("open", tracker="fbl", params=FBLGains(kp=30.0), **SHORT)  # type: ignore[arg-type]
    as_gains = simulate_reference("open", tracker="fbl", gains=FBLGains(kp=30.0), **SHORT)  # type: ignore[arg-type]
    default = simulate_reference("open", tracker="fbl", **SHORT)  # type: ignore[arg-type]
    metric = "rms_position_error_m"
    assert as_params.metrics["closed_loop"].as_dict()[metric] == as_gains.metrics["closed_loop"].as_dict()[metric]
    assert as_params.metrics["closed_loop"].as_dict()[metric] != default.metrics["closed_loop"].as_dict()[metric]
    for job in (as_params, as_gains):
        record = job.record()
        assert job.gains == FBLGains(kp=30.0) and record["gains"]["kp"] == 30.0 and record["params"]["kp"] == 30.0
    assert default.record()["params"] == {"kp": 9.0, "kd": 6.0, "xi_min": 0.02}
    with pytest.raises(ConfigError, match=r"two sets of FBL gains.*give them once"):
        Case("open", reference="line", tracker="fbl", params=FBLGains(kp=30.0), gains=FBLGains(kp=5.0))
    same = Case("open", reference="line", tracker="fbl", params=FBLGains(kp=30.0), gains=FBLGains(kp=30.0))
    assert same.fbl_gains == FBLGains(kp=30.0)


def test_a_trackers_own_parameters_are_recorded_and_fbl_gains_it_ignores_are_refused() -> None:
    """kanayama's params left no trace in the record (a run that could not be reproduced from it); FBL gains given
    to mpc, rpp or kanayama were dropped without a word."""
    params = KanayamaParams(kx=1.0, ky=5.0, ktheta=2.0)
    job = simulate_reference("open", tracker="kanayama", params=params, **SHORT)  # type: ignore[arg-type]
    assert job.record()["params"] == {"kx": 1.0, "ky": 5.0, "ktheta": 2.0} and job.record()["gains"] is None
    assert job.runs["closed_loop"].params == {"kx": 1.0, "ky": 5.0, "ktheta": 2.0}
    for tracker, own in (("mpc", "MPCParams"), ("rpp", "RPPParams"), ("kanayama", "KanayamaParams")):
        with pytest.raises(ConfigError, match=rf"does not use the FBL's gains.*params={own}\(\.\.\.\)"):
            Case("open", reference="line", tracker=tracker, gains=FBLGains(kp=30.0, kd=2.0))
        assert Case("open", reference="line", tracker=tracker, gains=FBLGains()).fbl_gains is None  # the defaults
    open_loop = simulate_reference("open", reference="line", runs=["open_loop"])
    assert open_loop.record()["params"] is None


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"fast": "no"}, "Case.fast must be True or False, got 'no'"),
        ({"control_rate": "50"}, r"Case.control_rate must be a finite number > 0 \(Hz\), got '50'"),
        ({"control_rate": [50]}, "Case.control_rate must be a finite number"),
        ({"control_rate": True}, "Case.control_rate must be a finite number"),
        ({"control_rate": 0.0}, "Case.control_rate must be a finite number > 0"),
        ({"gains": (9.0, 6.0)}, r"gains must be FBLGains\(kp=..., kd=...\) or None"),
    ],
)
def test_case_fields_of_the_wrong_kind_are_refused_naming_them(fields: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        Case("open", reference="line", **fields)  # type: ignore[arg-type]


@pytest.mark.parametrize("field", ["allow_collisions", "timed"])
def test_a_trajectory_files_flags_take_no_text(field: str) -> None:
    """allow_collisions="no" ran a file through an obstacle: text read as true."""
    with pytest.raises(ConfigError, match=f"TrajectoryFile.{field} must be True or False, got 'no'"):
        TrajectoryFile(Path("path.csv"), **{field: "no"})  # type: ignore[arg-type]


def test_a_jobs_runs_are_read_only_its_repr_short_and_it_pickles() -> None:
    job = simulate_reference("open", **SHORT)  # type: ignore[arg-type]
    with pytest.raises((TypeError, AttributeError)):
        job.runs.pop("closed_loop")  # type: ignore[attr-defined]
    assert len(repr(job)) < 200 and "closed_loop" in repr(job)
    again = pickle.loads(pickle.dumps(job))
    assert again.record()["closed_loop"] == job.record()["closed_loop"]


@pytest.mark.parametrize(
    ("name", "value", "said"),
    [
        (
            "sensors",
            {"fix_rate": 5},
            r"sensors must be text of key=value pairs, e\.g\. sensors='fix_rate=5' or a sensor",
        ),
        ("lidar", {"beams": 180, "range_max": 3.5}, r"lidar must be text .*lidar='beams=180,range_max=3\.5', got dict"),
        ("amcl", ["particles=500"], r"amcl must be text of key=value pairs, e\.g\. amcl='key=value,\.\.\.', got list"),
        ("motors", None, r"motors must be text of key=value pairs.*got NoneType None"),
    ],
)
def test_settings_given_as_a_mapping_are_refused_naming_their_text(name: str, value: object, said: str) -> None:
    """``sensors={'fix_rate': 5}`` was taken, then failed after the plan with "'dict' object has no attribute
    'split'" deep in the parser."""
    with pytest.raises(ConfigError, match=said):
        Case("open", reference="line", **{name: value})  # type: ignore[arg-type]


def test_a_sensor_settings_file_is_taken_from_python_as_on_the_command_line(tmp_path: Path) -> None:
    """``Case(sensors=PATH)`` reads the file as ``--sensors FILE`` does (the error said to pass it so, and then
    refused it as text without '='): its [sensors] table is the case's sensors, its [lidar] table the scanner's
    settings under the case's own ``lidar``; the case records the numbers, not the path."""
    f = tmp_path / "mine.toml"
    f.write_text("[sensors]\nfix_rate = 10\n\n[lidar]\nbeams = 180\nrange_max = 3.0\n")
    case = Case("open", reference="line", robot="turtlebot3", sensors=f, lidar="beams=90")  # type: ignore[arg-type]
    assert (case.sensors, case.lidar) == ("fix_rate=10", "beams=90,range_max=3.0")
    assert Case("open", reference="line", robot="turtlebot3", sensors=str(f)).lidar == "beams=180,range_max=3.0"
    with pytest.raises(ConfigError, match=r"--localiser fixes takes no scan"):
        Case("open", reference="line", robot="turtlebot3", sensors=str(f), localiser="fixes")
    with pytest.raises(ConfigError, match=r"cannot read sensor settings from .*missing\.toml"):
        Case("open", reference="line", sensors=str(tmp_path / "missing.toml"))


def test_track_refuses_a_simulator_that_is_not_the_cases() -> None:
    """A simulator of another world ran on silently (and its run was recorded as the case's), a nominal one
    replaced the case's as-built robot, and one of another robot failed naming a missing 'lidar' site."""
    from planning.core.robot import load_robot
    from planning.core.world import Box, World
    from sim.physics.asbuilt import AsBuilt
    from sim.physics.simulator import Simulator
    from sim.pipeline.case import prepare_trajectory
    from sim.pipeline.simulate import simulator_for, track

    prepared = prepare_trajectory(Case("open", reference="line", robot="edumip"))
    world = prepared.scenario.physical_world
    edumip = prepared.robot
    other = World(world.bounds, (Box((2.0, 1.5), (0.4, 0.4)),))
    cases = [
        (Simulator(edumip, other, prepared.case.as_built("edumip")), r"its world \(not the scenario's"),
        (Simulator(edumip, world, AsBuilt.nominal()), r"its build \(the robot as built"),
        (Simulator(load_robot("turtlebot3"), world), r"its robot \(turtlebot3, not the case's edumip\); its build"),
    ]
    for simulator, said in cases:
        with pytest.raises(ConfigError, match=rf"track: the simulator given is not the case's: {said}.*simulator_for"):
            track(prepared, ["closed_loop"], simulator=simulator)
    with pytest.raises(ConfigError, match=r"simulator must be a Simulator or None"):
        track(prepared, ["closed_loop"], simulator="sim")  # type: ignore[arg-type]
    job = track(prepared, ["closed_loop"], simulator=simulator_for(prepared))
    assert job.runs["closed_loop"].metrics.final_position_error_m < 0.05
