"""One meaning per exit code across the commands: 0 success, 1 a run or check failed, 2 bad input."""

from __future__ import annotations

import errno
import io
import json
import re
import sys
from pathlib import Path

import pytest

from sim.cli.main import main

TIGHT = (
    'robot = "edumip"\n[world]\nbounds = [0.0, 4.0, 0.0, 4.0]\n'
    '[[world.obstacles]]\ntype = "box"\ncenter = [2.0, 2.0]\nsize = [1.0, 1.0]\n'
    "[start]\npose = [2.0, 2.8, 0.0]\n[goal]\npose = [0.6, 0.6, 0.0]\n"
)


def test_a_failed_plan_exits_1_from_simulate_as_from_plan(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    scen = tmp_path / "tight.toml"
    scen.write_text(TIGHT)
    common = ["--scenario", str(scen), "--planner", "c-rrt-star", "--quiet"]
    assert main(["plan", *common]) == 1
    capsys.readouterr()
    assert main(["simulate", *common, "--no-video", "--no-plots"]) == 1
    err = capsys.readouterr().err
    assert "invalid_start" in err and "0.4000 m" in err and "error:" not in err


def test_a_closed_loop_off_its_reference_exits_1_naming_the_target(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    argv = ["simulate", "--reference", "circle", "--runs", "closed_loop", "--quiet", "--no-video", "--no-plots"]
    assert main([*argv, "--perturb", "latency=0.3"]) == 1  # a loop 0.3 s late (gains beyond stable are refused)
    err = capsys.readouterr().err
    assert "missed its target" in err and "final_position_error_m" in err and "> 0.02" in err
    assert main([*argv, "--overwrite"]) == 0  # the default gains meet every target
    assert "missed" not in capsys.readouterr().err


def test_a_plan_is_held_to_the_scenario_goal_tolerance() -> None:
    from types import SimpleNamespace

    from planning.scenario import load_scenario
    from sim.pipeline.sweep import TARGETS, missed_targets

    sc = load_scenario("edumip_map")
    assert sc.position_tolerance > TARGETS["final_position_error_m"]  # a plan is held to its goal, not 2 cm
    inside = {"final_position_error_m": 0.9 * sc.position_tolerance, "final_heading_error_rad": 0.0}
    metrics = SimpleNamespace(estimation=None, as_dict=lambda: {**inside, "rms_position_error_m": 1.0})
    assert missed_targets(metrics, sc, planned=True) == []  # type: ignore[arg-type]  # no RMS bound on a plan
    lines = missed_targets(metrics, sc, planned=False)  # type: ignore[arg-type]
    assert len(lines) == 2 and "final_position_error_m" in lines[0] and "rms_position_error_m" in lines[1]
    off = {"final_position_error_m": 1.1 * sc.position_tolerance, "final_heading_error_rad": 1.1 * sc.heading_tolerance}
    lines = missed_targets(SimpleNamespace(estimation=None, as_dict=lambda: off), sc, planned=True)  # type: ignore[arg-type]
    assert len(lines) == 2 and "final_heading_error_rad" in lines[1] and "goal tolerance" in lines[0]
    nan = {k: float("nan") for k in TARGETS}
    assert len(missed_targets(SimpleNamespace(estimation=None, as_dict=lambda: nan), sc, planned=False)) == 2  # type: ignore[arg-type]
    # a reference's heading is not regulated once it stops (the FBL's output is x, y): reported, not judged
    turned = SimpleNamespace(
        estimation=None, as_dict=lambda: {k: 0.0 for k in TARGETS} | {"final_heading_error_rad": 0.2}
    )
    assert missed_targets(turned, sc, planned=False) == []  # type: ignore[arg-type]


def test_a_balancing_robot_pitched_beyond_its_footprints_bound_misses_its_target() -> None:
    """A push that pitched the balancing EduMIP to 35.5 deg ended exit 0 without a word, where ``--all`` judges a
    20 deg bound (the planners' footprint holds the body pitched that far); the table did not show the pitch."""
    import math
    from types import SimpleNamespace

    from planning.scenario import load_scenario
    from sim.cli.simulate import format_table
    from sim.pipeline.sweep import BALANCING_TARGETS, missed_targets

    sc = load_scenario("edumip_map")
    on_goal = {"final_position_error_m": 0.0, "final_heading_error_rad": 0.0}
    for pitch, misses in ((0.619, True), (BALANCING_TARGETS["max_pitch_rad"], False), (None, False)):
        metrics = SimpleNamespace(estimation=None, as_dict=lambda p=pitch: {**on_goal, "max_pitch_rad": p})
        lines = missed_targets(metrics, sc, planned=True)  # type: ignore[arg-type]
        assert lines == (
            ["closed-loop run missed its target: max_pitch_rad = 0.619 > 0.3491 (20 deg: the planners' footprint "
             "holds the body pitched that far, not more)"] if misses else []
        )  # fmt: skip
    row = {"final_position_error_m": 0.0, "final_heading_error_rad": 0.0, "rms_position_error_m": 0.0,
           "max_position_error_m": 0.0, "collisions": 0, "warnings": 0}  # fmt: skip
    table = format_table({"closed_loop": {**row, "max_pitch_rad": math.radians(35.5)}, "open_loop": row})
    assert table.splitlines()[-1] == "max pitch: closed_loop 35.5 deg"
    assert "max pitch" not in format_table({"closed_loop": row})


def test_a_miss_of_a_run_whose_scan_localiser_was_starved_says_so_and_the_way_round() -> None:
    """An empty 8 x 9 m room, its walls beyond the LDS-01's 3.5 m most of the way: the TurtleBot3 ended 9.4 cm off
    its goal, and the failure said only that. Now a run whose scans had too few returns to match in more than a
    quarter of them says so, with --localiser fixes."""
    from types import SimpleNamespace

    from planning.scenario import load_scenario
    from sim.pipeline.sweep import STARVED_SHARE, missed_targets

    sc = load_scenario("edumip_map")
    off = {"final_position_error_m": 1.1 * sc.position_tolerance, "final_heading_error_rad": 0.0}
    for blind, said in ((int(STARVED_SHARE * 160) + 1, True), (int(STARVED_SHARE * 160), False)):
        est = SimpleNamespace(scans_without_returns=blind, scans_cast=160)
        lines = missed_targets(SimpleNamespace(estimation=est, as_dict=lambda: off), sc, planned=True)  # type: ignore[arg-type]
        assert len(lines) == 1 + said and "final_position_error_m" in lines[0]
        if said:
            assert lines[1].startswith(f"its scan localiser had too few returns to match in {blind} of its 160 scans")
            assert lines[1].endswith(
                "--localiser fixes runs on pose fixes instead, or give the world features within range"
            )
    met = {"final_position_error_m": 0.0, "final_heading_error_rad": 0.0}
    est = SimpleNamespace(scans_without_returns=150, scans_cast=160)
    assert missed_targets(SimpleNamespace(estimation=est, as_dict=lambda: met), sc, planned=True) == []  # type: ignore[arg-type]


@pytest.mark.parametrize("command", ["simulate", "plan"])
def test_a_robot_the_scenario_does_not_list_is_exit_2(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    extra = ["--no-video", "--no-plots"] if command == "simulate" else []
    assert main([command, "--scenario", "three_point_turn", "--robot", "edumip", "--quiet", *extra]) == 2
    err = capsys.readouterr().err
    assert "'three_point_turn'" in err and "robots (turtlebot3)" in err and "'edumip'" in err
    assert list(tmp_path.iterdir()) == []


#: docs/how-to/new-scenario.md's yard with its start 1 cm from the wall x = 0: its centre free, its footprint not.
START_AT_WALL = (
    'name = "yard"\nrobot = "turtlebot3"\nrobots = ["turtlebot3", "edumip"]\nplanner = "rrt-star"\n'
    '[world]\nbounds = [0.0, 4.0, 0.0, 3.0]\n[[world.obstacles]]\ntype = "box"\ncenter = [2.0, 1.5]\n'
    "size = [0.4, 1.2]\n[start]\npose = [0.01, 0.4, 0.0]\n[goal]\npose = [3.6, 2.6, 1.57]\n"
)


@pytest.mark.parametrize(
    "argv",
    [
        ["plan", "--time-limit", "10", "--json", "out.json"],
        ["simulate", "--no-video", "--json", "out.json"],
        ["simulate", "--reference", "line", "--no-video", "--json", "out.json"],
        ["compare", "--json", "out.json"],
        ["montecarlo", "--runs", "2"],
        ["tune", "--trials", "1"],
    ],
    ids=lambda argv: "-".join(a for a in argv if not a.endswith(".json"))[:30],
)
def test_a_start_the_robots_footprint_overlaps_is_bad_input_for_every_command_that_runs_it(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    scen = tmp_path / "start_wall.toml"
    scen.write_text(START_AT_WALL)
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    given = ["--scenarios", str(scen)] if argv[0] == "tune" else ["--scenario", str(scen)]
    assert main([argv[0], *given, *argv[1:], "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{scen}: field 'start.pose'" in err and "robot 'turtlebot3'" in err
    assert "by 94.1 mm (the planners' check reads -0.097 m)" in err
    assert "move the start more than 0.097 m away from it" in err and "Traceback" not in err
    assert list(work.iterdir()) == []  # nothing written
    if argv[0] == "plan":  # the robot chosen is the one checked: 8 cm from the wall the EduMIP fits, not the TurtleBot3
        scen.write_text(START_AT_WALL.replace("[0.01, 0.4, 0.0]", "[0.08, 0.4, 0.0]"))
        assert main(["plan", "--scenario", str(scen), "--planner", "birrt", "--quiet"]) == 2
        assert main(["plan", "--scenario", str(scen), "--robot", "edumip", "--planner", "birrt", "--quiet"]) == 0


def test_a_case_refuses_a_robot_its_scenario_does_not_list() -> None:
    from planning.errors import ConfigError
    from sim.pipeline.case import Case, load_case_scenario

    with pytest.raises(ConfigError, match=r"robots \(turtlebot3\)"):
        load_case_scenario(Case("three_point_turn", robot="edumip", planner=""))
    assert load_case_scenario(Case("three_point_turn", robot="turtlebot3", planner="")).robot == "turtlebot3"
    assert load_case_scenario(Case("open", robot="edumip", reference="line")).robot == "edumip"


def test_version_prints_the_package_version(capsys: pytest.CaptureFixture[str]) -> None:
    from importlib.metadata import version

    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"nhsim {version('nhsim')}"


def test_a_case_that_is_neither_reference_nor_planner_lists_both(capsys: pytest.CaptureFixture[str]) -> None:
    from planning.planners.registry import PLANNERS
    from planning.trajectory.references import REFERENCES

    assert main(["tune", "--scenarios", "open:figure9", "--trials", "1"]) == 2
    err = capsys.readouterr().err
    assert "'figure9'" in err and "reference" in err and "planner" in err
    for name in [*REFERENCES, *PLANNERS]:
        assert name in err


def test_help_and_check_agree_on_what_a_reference_must_reach(capsys: pytest.CaptureFixture[str]) -> None:
    """One rule for a reference's targets: ``closed_loop_targets`` (used by simulate's exit status and
    montecarlo's success count), and ``simulate --help`` says that rule."""
    import re

    from planning.scenario import load_scenario
    from sim.pipeline.sweep import closed_loop_targets

    targets = closed_loop_targets(load_scenario("open"), planned=False)
    assert targets == {"final_position_error_m": 0.02, "rms_position_error_m": 0.02}
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    said = re.search(r"a reference: ([^;]*?), the heading reported, not judged", text)
    assert said is not None, text
    assert said.group(1) == "final position 2 cm and RMS position 2 cm"
    assert "0.05 rad" not in text


def test_montecarlo_counts_success_by_the_reference_rule(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The run that ends 0.102 rad off in heading and 2 cm on its path: simulate exits 0, and the
    same draw counts as a success in montecarlo (a draw of the fix loop, where it was found)."""
    monkeypatch.chdir(tmp_path)
    argv = ["simulate", "--scenario", "open", "--reference", "line", "--seed", "0", "--noise-seed", "1647505296"]
    argv += ["--localiser", "fixes"]
    argv += ["--build-seed", "661058652", "--no-video", "--no-plots", "--quiet", "--json", "r.json"]
    assert main(argv) == 0
    import json

    closed = json.loads((tmp_path / "r.json").read_text())["closed_loop"]
    assert closed["final_heading_error_rad"] > 0.05  # reported, not judged
    from sim.pipeline.case import Case
    from sim.tools.montecarlo import MonteCarloSpec, run_one
    from sim.tools.tune import Draw

    spec = MonteCarloSpec(Case("open", reference="line", seed=0, localiser="fixes"), 1)
    rec = run_one((spec, None), (0, Draw(661058652, 1647505296)))
    entry = rec["runs"]["closed_loop"]
    assert entry["final_heading_error_rad"] == closed["final_heading_error_rad"]  # the same run
    assert entry["success"] is True


@pytest.mark.parametrize("robot", ["edumip", "edumip-balancing"])
def test_a_line_is_fitted_to_the_room_of_open_for_every_robot(
    robot: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The EduMIP's 10 s at top speed would run the line into open's wall: the line runs as far as
    the room allows, the robot's radius clear, and the run is judged as any other."""
    from planning.core.robot import load_robot
    from planning.scenario import load_scenario
    from planning.trajectory.references import make_reference
    from sim.pipeline.case import FIT_MARGIN_M, fitted_reference

    sc, spec = load_scenario("open").with_robot(robot), load_robot(robot)
    default = make_reference("line", spec, sc.start)
    assert float(sc.world.signed_distance(default.pose[:, :2]).min()) <= spec.radius  # would not fit
    fitted = fitted_reference("line", sc, spec)
    clearance = sc.world.signed_distance(fitted.pose[:, :2])
    assert spec.radius < float(clearance.min()) and float(clearance.min()) == pytest.approx(
        spec.radius + FIT_MARGIN_M, abs=0.01
    )
    monkeypatch.chdir(tmp_path)
    argv = ["simulate", "--reference", "line", "--robot", robot, "--runs", "closed_loop", "--quiet"]
    assert main([*argv, "--no-video", "--no-plots"]) == 0, capsys.readouterr().err
    tb = load_robot("turtlebot3")
    import numpy as np

    unchanged = fitted_reference("line", sc.with_robot("turtlebot3"), tb), make_reference("line", tb, sc.start)
    assert np.array_equal(unchanged[0].pose, unchanged[1].pose)  # a line that fits is left as it was


def test_only_the_closed_loop_ending_early_or_colliding_fails_the_command() -> None:
    """A balancing robot's open loop or dead reckoning that falls, or an open loop that hits something, is a
    comparison, reported on stderr; the closed loop falling or colliding, or any run without a closed loop,
    fails."""
    from types import SimpleNamespace

    from sim.cli.simulate import run_verdicts
    from sim.pipeline.runs import RunKind

    def run(status: str, collisions: int = 0) -> SimpleNamespace:
        return SimpleNamespace(metrics=SimpleNamespace(status=status, collisions=collisions))

    fell = "fell at t=12.960 s"
    runs = {RunKind.CLOSED_LOOP: run("ok"), RunKind.CLOSED_LOOP_ODOMETRY: run(fell), RunKind.OPEN_LOOP: run(fell)}
    failures, notes = run_verdicts(runs)
    assert failures == [] and len(notes) == 2 and all("reported, not judged" in n for n in notes)
    failures, notes = run_verdicts({**runs, RunKind.CLOSED_LOOP: run(fell)})
    assert failures == [f"{RunKind.CLOSED_LOOP}: {fell}"] and len(notes) == 2
    failures, notes = run_verdicts({RunKind.OPEN_LOOP: run(fell)})  # the only run: judged
    assert failures == [f"{RunKind.OPEN_LOOP}: {fell}"] and notes == []
    # a status naming an option (the localiser's advice) is printed in the command-line form only
    ambiguous = 'localisation ambiguous: give the start pose (--initial-pose known (initial_pose="known" from Python))'
    failures, _ = run_verdicts({RunKind.CLOSED_LOOP: run(ambiguous)})
    assert failures == [f"{RunKind.CLOSED_LOOP}: localisation ambiguous: give the start pose (--initial-pose known)"]
    # collisions: the closed loop's judged, the open loop's reported beside it and judged alone
    failures, notes = run_verdicts({RunKind.CLOSED_LOOP: run("ok", 1), RunKind.OPEN_LOOP: run("ok", 4)})
    assert failures == [f"{RunKind.CLOSED_LOOP} run touched an obstacle (1 time)"]
    assert notes == [f"{RunKind.OPEN_LOOP} run touched an obstacle (4 times) (a comparison run: reported, not judged)"]
    failures, notes = run_verdicts({RunKind.OPEN_LOOP: run("ok", 4)})
    assert failures == [f"{RunKind.OPEN_LOOP} run touched an obstacle (4 times)"] and notes == []
    # a file run with --allow-collisions: every run's collisions reported, none judged; a fall still is
    failures, notes = run_verdicts({RunKind.CLOSED_LOOP: run(fell, 2)}, collisions_judged=False)
    assert failures == [f"{RunKind.CLOSED_LOOP}: {fell}"]
    assert notes == [
        f"{RunKind.CLOSED_LOOP} run touched an obstacle (2 times) (collisions allowed: reported, not judged)"
    ]


def test_the_table_says_under_it_which_run_ended_early() -> None:
    """A run that lost its estimate at 32 s of a 232 s plan ended 1.7 cm from where the reference was
    then: its row alone read as a run on target. A line under the table says when and why it ended,
    and how far from the goal (runs that finished get none)."""
    from sim.cli.simulate import format_table

    def row(status: str, duration: float, goal: float) -> dict[str, object]:
        errors = dict.fromkeys(("final_position_error_m", "final_heading_error_rad", "rms_position_error_m"), 0.01)
        return {**errors, "max_position_error_m": 0.02, "collisions": 0, "warnings": 0, "status": status,
                "duration_s": duration, "final_goal_error_m": goal}  # fmt: skip

    lost = "localisation lost at t=32.000 s: the localiser's pose is 0.53 m from the truth"
    table = format_table({"closed_loop": row(lost, 32.12, 26.953), "open_loop": row("ok", 233.6, 0.4)})
    assert table.splitlines()[-1] == (
        "* closed_loop ended at 32.1 s: localisation lost at t=32.000 s; its errors are up to then, 26.953 m from the "
        "goal"
    )
    assert "open_loop ended" not in table


def test_an_empty_runs_list_is_refused_not_taken_as_the_default(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    record = tmp_path / "r.json"
    assert main(["simulate", "--reference", "line", "--no-video", "--json", str(record), "--runs", ","]) == 2
    assert "--runs ',': unknown run ''" in capsys.readouterr().err and not record.exists()
    with pytest.raises(SystemExit) as stop:  # an empty value is refused as every option's is
        main(["simulate", "--reference", "line", "--no-video", "--json", str(record), "--runs", ""])
    assert stop.value.code == 2 and "argument --runs: the value is empty" in capsys.readouterr().err
    assert not record.exists()


@pytest.mark.parametrize("tracker", ["mpc", "rpp", "kanayama", "segmented"])
def test_a_tracker_given_to_tracker_points_at_feedback(
    tracker: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--tracker`` picks the runs; a tracker's name there got argparse's "invalid choice: 'mpc' (choose from
    'both', 'fbl', 'open-loop')" without a word of ``--feedback mpc``, where the closed loops' tracker is given."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stop:
        main(["simulate", "--reference", "line", "--tracker", tracker, "--no-video"])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and list(tmp_path.iterdir()) == []
    assert f"argument --tracker: {tracker!r} is a tracker: --tracker picks the runs (fbl, open-loop, both: " in err
    assert err.rstrip().endswith(f"to close the loops with {tracker}, give --feedback {tracker}")
    with pytest.raises(SystemExit) as stop:
        main(["simulate", "--reference", "line", "--tracker", "mcp", "--no-video"])
    err = capsys.readouterr().err
    assert stop.value.code == 2
    assert "invalid choice: 'mcp' (choose from both, fbl, open-loop); the closed loops' tracker is --feedback T" in err
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    said = " ".join(capsys.readouterr().out.split())  # the help, unwrapped
    assert "--tracker {both,fbl,open-loop} the runs:" in said
    assert "the closed loops' tracker (mpc, rpp, kanayama, ...) is --feedback T --feedback T" in said


def test_options_the_job_does_not_use_are_named_and_jobs_without_all_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from sim.cli.main import build_parser
    from sim.cli.simulate import ignored_options

    def notes(*extra: str) -> list[str]:
        return ignored_options(build_parser().parse_args(["simulate", *extra]))

    assert notes() == [] and notes("--time-limit", "5", "--gains", "3,3") == []  # a plan, tracked closed loop
    assert notes("--reference", "line", "--time-limit", "5") == [
        "--time-limit ignored: it is the planner's budget, and this job plans nothing"
    ]
    assert notes("--path", "p.csv", "--time-scale", "2") == [
        "--time-scale ignored: a --path file has no clock (the speed profile times it)"
    ]
    assert notes("--tracker", "open-loop", "--gains", "3,3") == [
        "--gains ignored: the open loop alone feeds nothing back"
    ]
    record = tmp_path / "r.json"
    for where in (["--jobs", "2"], ["--scheduler", "tcp://127.0.0.1:1"]):
        assert main(["simulate", "--reference", "line", "--no-video", "--json", str(record), *where]) == 2
        assert "--jobs and --scheduler spread --all's sweep" in capsys.readouterr().err and not record.exists()


def test_a_fix_one_control_period_late_does_not_crash_the_consistency_measure(tmp_path: Path) -> None:
    # the first fix was fused while the start pose's covariance was still singular (the robot had not
    # moved): its NEES divided by zero, a traceback; now that sample judges nothing
    record = tmp_path / "r.json"
    argv = ["simulate", "--robot", "edumip", "--reference", "line", "--runs", "closed_loop", "--no-video"]
    argv += ["--no-plots", "--quiet", "--localiser", "fixes", "--sensors", "fix_latency=0.02", "--json", str(record)]
    assert main(argv) == 0
    est = json.loads(record.read_text())["closed_loop"]["estimation"]
    assert 0.0 < est["nees_in_bound_fraction"] <= 1.0 and est["fixes_used"] > 0


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--build-seed", "3"], "--build-seed"),
        (["--perturb", "mass=1.2", "--sensors", "fix_rate=5"], "--perturb, --sensors"),
        (["--reference", "circle"], "--reference"),
        (["--localiser", "fixes"], "--localiser"),
        (["--plots"], "--plots"),  # its default, but said: the sweep writes no plots (it was taken without a word)
        (["--plots", "--build-seed", "3"], "--build-seed, --plots"),
    ],
)
def test_simulate_all_refuses_the_options_its_sweep_would_drop(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], extra: list[str], named: str
) -> None:
    """``--all`` runs each case as built with its own sensors: an option it would not use is exit 2, named,
    before any case runs and with nothing written (it ran the whole sweep without it before)."""
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--all", *extra, "--no-video", "--json", "all.json"]) == 2
    err = capsys.readouterr().err
    assert f"it does not take {named}: drop {'them' if ',' in named else 'it'}" in err
    assert not any(tmp_path.iterdir())


def test_simulate_all_sweeps_the_scenarios_it_is_given(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--all --scenario A,B``: only those (a generated world among them); an unknown name, or one given
    twice (its cases would run twice), is exit 2."""
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--all", "--scenario", "nosuch", "--no-video"]) == 2
    assert "unknown scenario 'nosuch'" in capsys.readouterr().err
    assert main(["simulate", "--all", "--scenario", "farm, random4,farm,random4", "--no-video"]) == 2
    assert "--scenario with --all names farm, random4 twice; give each scenario once" in capsys.readouterr().err
    args = ["simulate", "--all", "--scenario", "random400,simple_motion", "--robot", "turtlebot3", "--planner", "birrt"]
    assert main([*args, "--quiet", "--no-video", "--json", "all.json"]) == 0
    rows = json.loads((tmp_path / "all.json").read_text())["rows"]
    assert sorted(r["scenario"] for r in rows) == ["random400", "simple_motion"]


def test_simulate_all_sweeps_a_scenario_file_as_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--all --scenario FILE``: the file's cases. Each case reloaded the scenario by its name: a file named as
    no built-in failed every case ("unknown scenario"), and one named as a built-in ran the built-in."""
    import re

    from planning.scenario import Scenario
    from sim.pipeline.sweep import sweep_cases

    monkeypatch.chdir(tmp_path)
    text = (Path(__file__).resolve().parents[1] / "models" / "scenarios" / "simple_motion.toml").read_text()
    (tmp_path / "mine.toml").write_text(re.sub(r"(?m)^name = .*$", 'name = "my_motion"', text))
    args = ["simulate", "--all", "--scenario", "mine.toml", "--robot", "turtlebot3", "--planner", "birrt"]
    assert main([*args, "--quiet", "--no-video", "--json", "all.json"]) == 0, capsys.readouterr()
    rows = json.loads((tmp_path / "all.json").read_text())["rows"]
    assert [(r["scenario"], r["planner"], r["outcome"]) for r in rows] == [("my_motion", "birrt", "ok")]
    goal = "[goal]\npose = [1.4, 0.7, 0.0]"
    assert goal in text
    (tmp_path / "copy.toml").write_text(text.replace(goal, "[goal]\npose = [1.2, 0.7, 0.0]"))  # the built-in's name
    case = sweep_cases(["copy.toml"])[0]
    assert isinstance(case.scenario, Scenario) and case.scenario.goal.x == 1.2 and case.scenario_name == "simple_motion"
    assert all(c.scenario == "simple_motion" for c in sweep_cases(["simple_motion"]))  # a name stays a name


def test_simulate_all_refuses_a_planner_it_would_not_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--all --planner P`` keeps P's cases: an unknown P, or one that applies to none of the swept scenarios,
    ran no case and passed (exit 0, "0/0 applicable"); now exit 2, saying why and what to do."""
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--all", "--scenario", "simple_motion", "--planner", "nosuch", "--no-video"]) == 2
    swept = capsys.readouterr().err
    assert swept.startswith("nhsim simulate: error: unknown planner 'nosuch': choose one of birrt, "), swept
    argv = ["simulate", "--all", "--scenario", "farm", "--planner", "sinusoidal", "--no-video", "--json", "a.json"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--all --planner sinusoidal: no case to run: sinusoidal does not apply to farm" in err
    assert "it runs birrt, c-rrt-star, hybrid-a-star, optim, rrt, rrt-star there" in err
    assert "(nhsim simulate --scenario farm --planner sinusoidal)" in err
    assert not any(tmp_path.iterdir())
    assert main(["simulate", "--planner", "nosuch", "--no-video"]) == 2  # the single job's message, the same
    assert capsys.readouterr().err == swept
    # a robot no swept scenario lists: it too ran no case and passed
    assert main(["simulate", "--all", "--scenario", "three_point_turn", "--robot", "edumip", "--no-video"]) == 2
    assert "--all --robot edumip: no case to run: no scenario swept lists edumip (they list turtlebot3)" in (
        capsys.readouterr().err
    )
    # a scenario with nothing to plan (its goal is its start): alone it passed "0/0", beside another it was dropped
    for named in ("open", "random5,open"):
        assert main(["simulate", "--all", "--scenario", named, "--no-video", "--json", "b.json"]) == 2
        err = capsys.readouterr().err
        assert "scenario open has nothing to plan: its goal is its start (0, 0, 0)" in err, err
        assert "drop it from --scenario of the sweep" in err and "--scenario open --reference figure8" in err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("argv", "instead"),
    [
        (["simulate", "--scenario", "open", "--planner", "rrt", "--no-video"], "--reference figure8"),
        (["compare", "--scenario", "open", "--planner", "rrt", "--trackers", "fbl,segmented"], "--reference figure8"),
        (["montecarlo", "--scenario", "open", "--planner", "rrt", "--runs", "2", "--jobs", "1"], "--reference figure8"),
        (["tune", "--scenarios", "open:rrt", "--trials", "2", "--draws", "1"], "SCENARIO:figure8 in --scenarios"),
    ],
)
def test_a_planner_on_a_scenario_whose_goal_is_its_start_is_refused_by_every_command_that_tracks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], argv: list[str], instead: str
) -> None:
    """``--all`` refused the ``open`` arena (nothing to plan), one job took it: its plan the start alone, its runs a
    stand-still, and tune wrote gains "tuned" on objectives of 0, montecarlo 100 % success at 0 m."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    said = "scenario 'open' has nothing to plan: its goal is its start (0, 0, 0), so planner 'rrt' would give a "
    assert said + "stand-still" in err and f"track an analytic reference there ({instead})" in err, err
    assert not any(tmp_path.iterdir())


def test_a_sweeps_record_over_the_scenario_it_reads_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--all --scenario my.toml --json my.toml --overwrite`` was taken: the sweep's record replaced its scenario."""
    from pathlib import Path as P

    monkeypatch.chdir(tmp_path)
    mine = tmp_path / "my.toml"
    text = (P(__file__).resolve().parents[1] / "models/scenarios/simple_motion.toml").read_text()
    mine.write_text(text)
    for swept in (str(mine), f"simple_motion,{mine}", f"{mine},farm"):  # one of a list of scenarios too
        assert main(["simulate", "--all", "--scenario", swept, "--json", str(mine), "--overwrite"]) == 2
        assert f"the output {mine} is the input --scenario {mine}" in capsys.readouterr().err
        assert mine.read_text() == text


def test_a_sweep_with_gains_says_so_and_records_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--all --gains`` ran every case with them, and neither the table nor the record said so."""
    monkeypatch.chdir(tmp_path)
    args = ["simulate", "--all", "--scenario", "simple_motion", "--robot", "turtlebot3", "--planner", "birrt"]
    assert main([*args, "--gains", "10,5", "--no-video", "--json", "all.json"]) == 0
    assert "gains Kp=10 Kd=5 xi_min=0.02 (--gains 10,5) on every case" in capsys.readouterr().out
    settings = json.loads((tmp_path / "all.json").read_text())["settings"]
    assert settings["gains"] == {"kp": 10.0, "kd": 5.0, "xi_min": 0.02} and settings["gains_from"] == "10,5"
    assert settings["seed"] == 0 and settings["control_rate_hz"] == 50 and settings["time_limit_s"] > 0


def _text_options() -> list[tuple[list[str], str]]:
    """(the command's words, option) for every option of every command that takes text."""
    import argparse

    from sim.cli.main import COMMANDS, build_parser

    def walk(parser: argparse.ArgumentParser, words: list[str]) -> list[tuple[list[str], str]]:
        found = []
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    found += walk(sub, [*words, name])
            elif action.option_strings and action.nargs != 0 and action.choices is None:
                if action.type not in (int, float):
                    found.append((words, action.option_strings[0]))
        return found

    return walk(build_parser(COMMANDS), [])


def test_an_empty_value_is_refused_by_every_text_option_of_every_command(capsys: pytest.CaptureFixture[str]) -> None:
    """An empty string was "not given" (``--gains ''``, ``--sensors ''``, ``plan --planner ''`` ran the defaults;
    ``compare --plots ''`` wrote nothing and said nothing) or the folder '.' (``--json ''``: "cannot write .: it is a
    folder"); now each is exit 2 naming the option and what to give, before anything runs."""
    from sim.cli.main import build_parser

    options = _text_options()
    commands = {words[0] for words, _ in options}
    assert commands == {"simulate", "compare", "bench", "plan", "tune", "regress", "montecarlo"}  # scenarios has none
    assert len(options) > 60
    parser = build_parser()
    for words, option in options:
        for value in ("", " "):
            with pytest.raises(SystemExit) as stop:
                parser.parse_args([*words, option, value])
            assert stop.value.code == 2, (words, option)
            err = capsys.readouterr().err
            assert f"argument {option}: the value is empty; give " in err, (words, option, err)
    with pytest.raises(SystemExit):
        parser.parse_args(["tune", "--scenarios", ""])
    assert capsys.readouterr().err.endswith("argument --scenarios: the value is empty; give CASE,...\n")  # required


EMPTY = "the value is empty"
FOLDER = "ends in a separator, a folder; give a file name in it"
DASH = "'-' is no file: the outputs are written to files"
DOT = "names a folder; give a file name in it"
MC = ["montecarlo", "--reference", "line", "--runs", "1", "--jobs", "1"]


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        pytest.param(["plan", "--scenario", "open", "--planner", ""], EMPTY, id="plan-planner"),
        pytest.param(["plan", "--scenario", "", "--json", "p.json"], EMPTY, id="plan-scenario"),
        pytest.param(["plan", "--scenario", "open", "--planner", "birrt", "--json", ""], EMPTY, id="plan-json"),
        pytest.param(
            ["simulate", "--reference", "line", "--gains", "", "--no-video", "--json", "s.json"], EMPTY, id="gains"
        ),
        pytest.param(
            ["simulate", "--reference", "line", "--sensors", "", "--no-video", "--json", "s.json"], EMPTY, id="sensors"
        ),
        pytest.param(["compare", "--reference", "line", "--plots", "", "--json", "c.json"], EMPTY, id="compare-plots"),
        pytest.param(["tune", "--scenarios", "open:line", "--storage", ""], EMPTY, id="tune-storage"),
        # ``plan --json out1/`` wrote a file named out1 (Path drops the separator) and exited 0
        pytest.param(
            ["plan", "--scenario", "open", "--planner", "sinusoidal", "--json", "out1/"], FOLDER, id="plan-folder"
        ),
        pytest.param(["simulate", "--reference", "line", "--no-video", "--json", "rec/"], FOLDER, id="simulate-folder"),
        pytest.param(["compare", "--reference", "line", "--json", "c/"], FOLDER, id="compare-folder"),
        # ``montecarlo --results .`` (or ``--json .``) ended in a traceback: PosixPath('.') has an empty name (its
        # summary and plots are named after it); ``--json rec/.`` wrote a file named rec (Path drops the ".")
        pytest.param([*MC, "--results", "."], DOT, id="montecarlo-results-dot"),
        pytest.param([*MC, "--json", "."], DOT, id="montecarlo-json-dot"),
        pytest.param([*MC, "--results", "runs/.."], DOT, id="montecarlo-results-dotdot"),
        pytest.param(["simulate", "--reference", "line", "--no-video", "--json", "rec/."], DOT, id="simulate-dot"),
        pytest.param(["tune", "--scenarios", "open:line", "--out", "."], DOT, id="tune-out-dot"),
        # ``tune --out sub/`` wrote its gains file as a file named sub, and its record as sub.json
        pytest.param(["tune", "--scenarios", "open:line", "--out", "sub/"], FOLDER, id="tune-folder"),
        pytest.param(["tune", "--scenarios", "open:line", "--json", "sub/"], FOLDER, id="tune-json-folder"),
        # ``plan --json -`` wrote a file named '-', where '-' commonly means the standard output
        pytest.param(["plan", "--scenario", "open", "--planner", "sinusoidal", "--json", "-"], DASH, id="plan-dash"),
        pytest.param(["simulate", "--reference", "line", "--no-video", "--json", "-"], DASH, id="simulate-dash"),
        pytest.param(["tune", "--scenarios", "open:line", "--out", "-"], DASH, id="tune-dash"),
    ],
)
def test_an_empty_value_or_a_folder_for_a_file_stops_the_command_before_it_writes(
    argv: list[str], said: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert said in err and "Traceback" not in err and "cannot write ." not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("given", ["folder/", "existing", "existing/", "."])
def test_compare_plots_takes_a_stem_not_a_folder(
    given: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--plots /tmp/`` wrote /tmp/-paths.png and /tmp/-errors.png and exited 0."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "existing").mkdir()
    argv = ["compare", "--reference", "line", "--trackers", "fbl", "--quiet", "--json", "c.json", "--plots", given]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"--plots {given} names a folder; --plots takes a file stem, e.g. renders/cmp" in err
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["existing"]


def test_regress_list_checks_its_options_as_a_run_does(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``regress --list`` skipped the option checks: --jobs 0 and --scheduler x listed the cases, exit 0."""
    import sim.tools.executor as executor

    monkeypatch.setattr(executor, "default_jobs", lambda: 2)  # a machine of two cores: at most 8 workers
    for extra, said in (
        (["--jobs", "0"], "--jobs must be an integer >= 1, got 0"),
        (["--jobs", "9"], "--jobs 9 would start 9 worker processes on the 2 cores this process "
         "may use; give at most 8 (4 per core), or run on a Dask cluster with --scheduler ADDRESS\n"),
        (["--scheduler", "x"], "--scheduler x is not a scheduler address"),
        (["--update"], "--list lists the cases and runs none, so --update would rewrite nothing: drop one of them"),
    ):  # fmt: skip
        assert main(["regress", "--list", *extra]) == 2
        captured = capsys.readouterr()
        assert said in captured.err and captured.out == ""
    assert main(["regress", "--list", "--jobs", "8", "--baselines", "/nonexistent-nhsim-baselines"]) == 0
    assert "(fast)" in capsys.readouterr().out  # listing reads no baseline


def test_more_local_workers_than_the_bound_are_refused_before_anything_starts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``montecarlo --runs 1 --jobs 1000`` started 1000 worker processes; a cluster decides its own."""
    import sim.tools.executor as executor
    from planning.errors import ConfigError

    monkeypatch.setattr(executor, "default_jobs", lambda: 2)
    monkeypatch.setattr(executor, "DaskExecutor", None)  # nothing may start
    monkeypatch.chdir(tmp_path)
    base = ["--reference", "line", "--no-video", "--json", "out.json"]
    for argv in (
        ["montecarlo", "--runs", "1", *base[:2], "--jobs", "9"],
        ["simulate", "--all", "--jobs", "9", *base[2:]],
    ):
        assert main(argv) == 2
        assert "--jobs 9 would start 9 worker processes" in (err := capsys.readouterr().err)
        assert "give at most 8 (4 per core)" in err
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ConfigError, match=r"--workers 9 \(workers=9 from Python\) would start 9 worker processes"):
        executor.check_workers(9, "workers")
    assert executor.worker_count(None, "tcp://127.0.0.1:8786") is None  # the cluster decides
    assert executor.worker_count(8) == 8 and executor.worker_count(None, default=1) == 1


class _Full(io.StringIO):
    """A standard output on a full disk: every write fails as ``>/dev/full`` does."""

    def write(self, text: str) -> int:
        raise OSError(errno.ENOSPC, "No space left on device")


def test_a_standard_output_that_cannot_be_written_loses_the_report_not_the_outputs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``nhsim plan ... >/dev/full`` ended in a traceback at its first print, before writing its outputs; with
    the standard output closed (``>&-``, sys.stdout None) it failed inside a library asking isatty()."""
    monkeypatch.chdir(tmp_path)
    argv = ["plan", "--scenario", "simple_motion", "--planner", "rrt", "--time-limit", "5"]
    for stdout, why in ((_Full(), r"could not be written \(No space left on device\)"), (None, r"was closed")):
        monkeypatch.setattr(sys, "stdout", stdout)
        name = f"p{len(list(tmp_path.iterdir()))}.json"
        assert main([*argv, "--json", name]) == 1
        err = capsys.readouterr().err
        assert re.fullmatch(
            rf"nhsim: (its standard output|there is no standard output).*{why}.*files were written.*\n", err
        )
        assert json.loads((tmp_path / name).read_text())["status"] == "success"


def test_text_the_standard_output_cannot_encode_is_escaped_not_a_closed_pipe(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With an ASCII standard output, printing a non-ASCII file name raised UnicodeEncodeError, taken for a
    closed pipe: the command exited 141 and dropped the rest of its report."""
    monkeypatch.chdir(tmp_path)
    raw = io.BytesIO()
    monkeypatch.setattr(sys, "stdout", io.TextIOWrapper(raw, encoding="ascii"))
    assert main(["plan", "--scenario", "simple_motion", "--planner", "rrt", "--json", "plän.json"]) == 0
    sys.stdout.flush()
    assert raw.getvalue().decode("ascii").splitlines()[-1] == r"wrote pl\xe4n.json"
    assert (tmp_path / "plän.json").is_file()


def test_a_full_disk_while_writing_is_one_line_exit_1(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import sim.cli.scenarios as command

    def full(args: object) -> int:
        raise OSError(errno.ENOSPC, "No space left on device", "renders/x.json")

    monkeypatch.setattr(command, "run", full)
    assert main(["scenarios"]) == 1
    assert capsys.readouterr().err == (
        "nhsim scenarios: failed: could not write renders/x.json: No space left on device; no output was written or "
        "replaced: free space (or give a path on another disk) and run it again\n"
    )
    monkeypatch.setattr(command, "run", lambda args: (_ for _ in ()).throw(OSError(errno.ENOENT, "gone", "y")))
    with pytest.raises(FileNotFoundError):  # not a full disk: a fault of the program, with its traceback
        main(["scenarios"])


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "--seed", "nan"],
        ["simulate", "--fps", "abc"],
        ["montecarlo", "--scenario", "open"],
        ["bogus"],
        ["plan", "--gains", "1"],
    ],
)
def test_a_usage_error_is_one_line(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    """argparse printed the whole usage (6-21 lines) before its error: a usage error is one line now, as every
    other refusal of bad input (``--help`` shows the usage)."""
    with pytest.raises(SystemExit) as stop:
        main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2 and len(err.splitlines()) == 1 and ": error: " in err, err
    if "--seed" in argv:  # argparse's type error names the type alone: the fix is said too, the default as example
        assert err.endswith("argument --seed: invalid int value: 'nan'; give a whole number, e.g. 0\n"), err
    if "--fps" in argv:  # an example the option takes (0.5 was said, and --fps takes 1 to 240)
        assert err.endswith("argument --fps: invalid float value: 'abc'; give a number, e.g. 30\n"), err


@pytest.mark.parametrize(
    ("name", "content", "says"),
    [
        ("bad.toml", b"name = \n", "not valid TOML"),
        ("latin1.toml", b'name = "caf\xe9"\n', "UTF-8"),
        ("gains.toml", None, "gains"),
    ],
)
def test_a_file_that_cannot_be_read_gets_no_traceback_hint(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, content: bytes | None, says: str
) -> None:
    """Reading a user's file failing (bad TOML, not UTF-8, a folder) is said in the line; the hint that
    NHSIM_TRACEBACK=1 prints a traceback is for exceptions of code nhsim runs (a plugin), not for those."""
    path = tmp_path / name
    if content is None:
        path.mkdir()
        argv = ["simulate", "--reference", "line", "--gains", str(path), "--no-video", "--no-plots"]
    else:
        path.write_bytes(content)
        argv = ["plan", "--scenario", str(path)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err and "NHSIM_TRACEBACK" not in err, err


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "--reference", "line", "--no-video", "--over"],
        ["plan", "--scenario", "farm", "--js", "p.json"],
        ["bench", "sim", "--rep", "1"],
    ],
)
def test_options_are_not_abbreviated(
    argv: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """argparse took --over for --overwrite (the one switch that lets a file be replaced), --js for --json: an
    option is given in full or refused, before anything runs."""
    monkeypatch.chdir(tmp_path)  # what a command taking them would write lands here
    with pytest.raises(SystemExit) as ended:
        main(argv)
    command = " ".join(argv[:2] if argv[0] == "bench" else argv[:1])  # said by the command's own parser
    assert ended.value.code == 2 and f"nhsim {command}: error: unrecognized arguments" in capsys.readouterr().err


def test_a_number_option_that_is_no_number_gets_no_traceback_hint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--perturb-range radius=1:2:3`` said "radius must be a number, got '2:3' (NHSIM_TRACEBACK=1 prints the
    ValueError's traceback)": float()'s error, which the line already says, is no exception of code nhsim runs."""
    monkeypatch.chdir(tmp_path)
    argv = ["montecarlo", "--scenario", "open", "--reference", "circle", "--runs", "1", "--no-plots"]
    assert main([*argv, "--perturb-range", "radius=1:2:3"]) == 2
    err = capsys.readouterr().err
    assert "radius must be a number, got '2:3'" in err and "NHSIM_TRACEBACK" not in err, err
    assert not list(tmp_path.iterdir())


def test_a_file_with_a_comma_in_its_name_is_one_item_of_a_comma_list(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``simulate --all --scenario a,b.toml`` with a file named ``a,b.toml`` read ``a`` and ``b.toml`` (split at
    every comma, as ``tune --scenarios`` and ``compare --params`` were): a run of items that names a file is it."""
    import argparse

    from sim.cli.checks import comma_list
    from sim.cli.sweep_table import sweep_scenarios
    from sim.cli.tune import _tokens
    from sim.pipeline.case import Case

    monkeypatch.chdir(tmp_path)
    Path("a,b.toml").write_text(TIGHT)
    Path("x,y,z.json").write_text("{}")
    assert comma_list("a,b.toml") == ["a,b.toml"]
    assert comma_list(" farm, a,b.toml ,open,") == ["farm", "a,b.toml", "open"]
    assert comma_list("a,b") == ["a", "b"]  # no file of that name: every comma splits
    assert comma_list("x,y,z.json,x,y") == ["x,y,z.json", "x", "y"]  # the longest run that names a file
    assert comma_list(f"{tmp_path}/a,b.toml,{tmp_path}/x,y,z.json") == [
        f"{tmp_path}/a,b.toml",
        f"{tmp_path}/x,y,z.json",
    ]
    case = lambda token: Case.split(token)[0]
    assert comma_list("a,b.toml:line,open:circle", case) == ["a,b.toml:line", "open:circle"]
    Path("b.toml").write_text(TIGHT)  # a file's case, then a name: the file part holds no comma of the run
    assert comma_list("b.toml:line,open", case) == ["b.toml:line", "open"]
    assert comma_list("b.toml:line,a,b.toml", case) == ["b.toml:line", "a,b.toml"]
    assert sweep_scenarios("a,b.toml,farm") == ["a,b.toml", "farm"]
    assert _tokens(argparse.Namespace(scenarios="open:line,a,b.toml:optim")) == ["open:line", "a,b.toml:optim"]
