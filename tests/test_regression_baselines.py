"""The regression suite's baselines: unreadable ones, the case definition they record, gains files, the report."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

import sim.cli.regress as cli
import sim.tools.regress as regress
from control.gains import FBLGains
from planning.errors import ConfigError
from sim.cli.main import main
from sim.pipeline.case import Case
from sim.tools.regress import Change, CheckResult, Status, load_suite

#: Two quick cases (a planted one and another) and their common fields.
FIELDS = 'scenario = "open", robot = "turtlebot3", tracker = "fbl", seed = 0, fast = true'


def _suite(folder: Path, planted: str = "", *, other: bool = True) -> Path:
    """A suite of the case "planted" (``planted``: more fields) and, with ``other``, the case "other"."""
    lines = [f'  {{ name = "planted", reference = "circle", {FIELDS}{planted} }},']
    if other:
        lines.append(f'  {{ name = "other", reference = "line", {FIELDS} }},')
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "suite.toml"
    path.write_text("cases = [\n" + "\n".join(lines) + "\n]\n")
    return path


def _regress(suite: Path, baselines: Path, *extra: str) -> int:
    return main(["regress", "--suite", str(suite), "--baselines", str(baselines), *extra])


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ('{"metrics": ', "not JSON"),
        ("{}", "no metrics table"),
        ("[1]", "a JSON list, not an object"),
        ('{"metrics": {"collisions": "none"}}', "metric(s) collisions not a number"),
        # a boolean for a number passed (false compared as 0 collisions), or read "improved (true -> 0.0028)"
        ('{"metrics": {"collisions": false}}', "metric(s) collisions not a number"),
        ('{"metrics": {"final_position_error_m": true}}', "metric(s) final_position_error_m not a number"),
        ('{"metrics": {"fell": 0}}', "metric(s) fell not true or false"),
        ('{"metrics": {}, "case": 3}', "its case not a table"),
    ],
)
def test_a_file_that_is_not_a_baseline_is_read_as_its_problem(tmp_path: Path, text: str, problem: str) -> None:
    path = tmp_path / "x.json"
    path.write_text(text)
    read = regress.Baseline.read(path)
    assert read.document is None and read.problem.startswith(problem)
    assert regress.Baseline.read(tmp_path / "none.json") == regress.Baseline(tmp_path / "none.json")


def test_a_folder_where_a_baseline_goes_is_refused_naming_the_folder_as_the_fix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A folder under a case's baseline name fails its case, and --update refuses it before any run: the
    fix is moving the folder (no option names the file), then recording the baseline."""
    suite, bl = _suite(tmp_path, other=False), tmp_path / "bl"
    (bl / "planted.json").mkdir(parents=True)
    assert _regress(suite, bl) == 1
    err = capsys.readouterr().err
    assert f"(it is a folder, where the case's baseline file goes; move or remove {bl / 'planted.json'}); " in err
    assert err.rstrip().endswith(
        f"then record it with nhsim regress --update --suite {suite} --baselines {bl} --case planted"
    )
    assert _regress(suite, bl, "--update") == 2
    assert f"case planted's baseline {bl / 'planted.json'} is a folder; move or remove it" in capsys.readouterr().err
    assert (bl / "planted.json").is_dir()


def test_update_writes_no_baseline_over_a_file_the_suite_reads(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--update replaced a case's gains file named <case>.json in the baselines folder (exit 0, "replaced unreadable
    baseline"), and the suite file itself when the baselines folder held it under a case's name: refused before any
    run now, the file kept."""
    from planning.scenario import SCENARIOS_DIR

    gains = tmp_path / "gg.json"  # a gains file (TOML) under the case's baseline name
    gains.write_text("[gains]\nkp = 9.0\nkd = 6.0\n")
    suite = tmp_path / "s.toml"
    suite.write_text('cases = [{ name = "gg", scenario = "open", reference = "line", gains = "gg.json", fast = true }]')
    assert _regress(suite, tmp_path, "--update") == 2
    err = capsys.readouterr().err
    assert f"case gg's baseline {gains} is case gg's gains file gg.json, which the suite reads: --update would" in err
    assert gains.read_text() == "[gains]\nkp = 9.0\nkd = 6.0\n"
    own = tmp_path / "s4.json"  # the suite file, named as its case's baseline
    own.write_text('cases = [{ name = "s4", scenario = "open", reference = "line", fast = true }]\n')
    assert _regress(own, tmp_path, "--update") == 2
    assert f"case s4's baseline {own} is the suite file {own}, which the suite reads" in capsys.readouterr().err
    yard = tmp_path / "yard.json"  # a scenario file of the suite's, the same
    yard.write_text((SCENARIOS_DIR / "open.toml").read_text(encoding="utf-8"))
    suite.write_text('cases = [{ name = "yard", scenario = "yard.json", reference = "line", fast = true }]\n')
    assert _regress(suite, tmp_path, "--update") == 2
    assert "case yard's baseline" in capsys.readouterr().err and yard.read_text().startswith("#")


def test_an_unreadable_baseline_fails_its_case_alone_and_update_replaces_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    suite, bl = _suite(tmp_path), tmp_path / "bl"
    assert _regress(suite, bl, "--update") == 0
    (bl / "planted.json").write_text('{"metrics": ')
    capsys.readouterr()

    assert _regress(suite, bl) == 1  # the case's failure, not the run's (exit 2)
    out, err = capsys.readouterr()
    assert "UNREADABLE       planted\n" in out and "PASS             other (bit for bit)" in out
    assert "1 passed, 1 failed of 2 case(s)" in out
    hint = f"rewrite it with nhsim regress --update --suite {suite} --baselines {bl} --case planted"
    assert f"baseline {bl / 'planted.json'} is unreadable (not JSON: " in err and err.rstrip().endswith(hint)
    assert "Traceback" not in err

    assert _regress(suite, bl, "--update", "--case", "planted") == 0  # the command the hint gives
    out = capsys.readouterr().out
    assert f"replaced unreadable baseline {bl / 'planted.json'} (not JSON: " in out
    assert _regress(suite, bl) == 0


@pytest.mark.slow  # a local cluster; 3 s
def test_an_unreadable_baseline_is_read_before_the_workers_run(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    suite, bl = _suite(tmp_path, other=False), tmp_path / "bl"
    bl.mkdir()
    (bl / "planted.json").write_text("{}")
    code = _regress(suite, bl, "--jobs", "2")
    out, err = capfd.readouterr()
    assert code == 1, (out, err)
    assert "UNREADABLE       planted" in out and "is unreadable (no metrics table)" in err, (out, err)
    assert "Compute Failed" not in err and "ConfigError" not in err, err


def test_the_baseline_records_the_case_definition_and_a_change_of_it_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    suite, bl = _suite(tmp_path, other=False), tmp_path / "bl"
    assert _regress(suite, bl, "--update") == 0
    recorded = json.loads((bl / "planted.json").read_text())["case"]
    assert {k: recorded[k] for k in ("build_seed", "sensors", "localiser", "xi_min")} == {
        "build_seed": 1,
        "sensors": "",
        "localiser": "fixes",
        "xi_min": None,
    }
    capsys.readouterr()

    moved = _suite(tmp_path, ", build_seed = 5", other=False)
    assert _regress(moved, bl) == 1
    out, err = capsys.readouterr()
    assert "FAIL             planted (case differs: build_seed 1 -> 5; moved: " in out
    assert "its definition differs from its baseline's: build_seed 1 -> 5;" in err
    assert _regress(moved, bl, "--update") == 0
    assert "case build_seed 1 -> 5" in capsys.readouterr().out


def test_an_older_baseline_is_compared_on_the_fields_it_records(tmp_path: Path) -> None:
    suite, bl = _suite(tmp_path, ', build_seed = 5, sensors = "fix_rate=10"', other=False), tmp_path / "bl"
    assert _regress(suite, bl, "--update") == 0
    path = bl / "planted.json"
    doc = json.loads(path.read_text())
    for key in ("build_seed", "sensors", "localiser", "xi_min"):  # as recorded before these were
        del doc["case"][key]
    path.write_text(json.dumps(doc))
    outcome = regress.check_case(load_suite(suite).cases[0], bl)
    assert outcome.ok and outcome.differs == (), outcome.message
    case = load_suite(_suite(tmp_path, other=False)).cases[0]
    assert regress.definition_changes(doc["case"], case) == []  # what it does not record, it cannot tell


def _gains_file(folder: Path, xi_min: float) -> Path:
    path = folder / "gains" / "tuned.toml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"[gains]\nkp = 8.5\nkd = 2.25\nxi_min = {xi_min}\n[provenance]\nstudy = 'x'\n")
    return path


def test_a_case_takes_a_gains_file_relative_to_the_suite_and_records_its_values(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    gains = _gains_file(tmp_path, 0.0175)
    suite, bl = _suite(tmp_path, ', gains = "gains/tuned.toml"', other=False), tmp_path / "bl"
    assert load_suite(suite).cases[0].gains == FBLGains(8.5, 2.25, 0.0175)
    absolute = _suite(tmp_path / "elsewhere", f", gains = {json.dumps(str(gains))}", other=False)
    assert load_suite(absolute).cases[0].gains == FBLGains(8.5, 2.25, 0.0175)
    assert _regress(suite, bl, "--update") == 0
    recorded = json.loads((bl / "planted.json").read_text())["case"]
    assert (recorded["gains"], recorded["xi_min"]) == ([8.5, 2.25], 0.0175)
    capsys.readouterr()

    _gains_file(tmp_path, 0.5)  # the file edited: the case changed
    assert _regress(suite, bl) == 1
    assert "case differs: xi_min 0.0175 -> 0.5" in capsys.readouterr().out


def test_a_cases_scenario_file_is_relative_to_the_suite_as_its_gains_file_is(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A suite that keeps its own scenario files beside it runs from any folder: a relative scenario path is
    the suite file's, as a gains file's is; a built-in name stays one; the baseline records the scenario's
    name, not where it was found."""
    from planning.scenario import SCENARIOS_DIR, Scenario

    folder = tmp_path / "rs" / "sub"
    folder.mkdir(parents=True)
    (folder / "yard.toml").write_text(
        (SCENARIOS_DIR / "open.toml").read_text(encoding="utf-8").replace('name = "open"', 'name = "yard"')
    )
    _gains_file(folder, 0.0175)
    suite = folder / "suite.toml"
    suite.write_text(
        'cases = [{ name = "mine", scenario = "yard.toml", robot = "turtlebot3", reference = "line", '
        'tracker = "fbl", seed = 0, control_rate = 50, gains = "gains/tuned.toml" },\n'
        '  { name = "builtin", scenario = "open", robot = "turtlebot3", reference = "line", tracker = "fbl", '
        "seed = 0, control_rate = 50 }]\n"
    )
    for cwd in (tmp_path, folder, tmp_path / "rs"):
        monkeypatch.chdir(cwd)
        mine, builtin = load_suite(os.path.relpath(suite, cwd)).cases
        assert isinstance(mine.scenario, Scenario) and mine.scenario.source is not None
        assert mine.scenario.source.resolve() == (folder / "yard.toml").resolve()
        assert mine.gains == FBLGains(8.5, 2.25, 0.0175)
        assert regress.case_record(mine)["scenario"] == "yard"
        assert builtin.scenario == "open"
    bad = tmp_path / "bad.toml"
    bad.write_text(suite.read_text().replace('"yard.toml"', '"nowhere/yard.toml"'))
    with pytest.raises(ConfigError, match=f"scenario file {tmp_path}/nowhere/yard.toml does not exist"):
        load_suite(bad)


@pytest.mark.parametrize(
    ("bad", "says"),
    [
        ('gains = "9"', "neither 'KP,KD' (e.g. 9,6) nor an existing gains file"),
        ('gains = "none.toml"', "cannot read gains file {folder}/none.toml"),
        ('perturb = "mas=1"', "unknown key 'mas'"),
    ],
)
def test_a_bad_field_names_the_case_by_its_name(tmp_path: Path, bad: str, says: str) -> None:
    path = tmp_path / "suite.toml"
    path.write_text(
        f'cases = [{{ scenario = "open", robot = "edumip", planner = "sinusoidal", tracker = "segmented", '
        f"seed = 977, control_rate = 50, {bad} }}]\n"
    )
    with pytest.raises(ConfigError) as err:
        load_suite(path)
    name = "open-edumip-plan-sinusoidal-segmented-s977"  # not open-edumip-sinusoidal-segmented
    assert str(err.value).startswith(f"{path} case 1 ({name}): {bad}: {says.format(folder=tmp_path)}"), err.value


def _change(case: str, metric: str, failed: bool = True) -> Change:
    return Change(case, metric, 1.0, 2.0, 0.0, "regressed" if failed else "within")


def test_the_report_says_what_was_compared_and_what_moved() -> None:
    case = Case("open", reference="line", name="c")
    missing = [CheckResult(case, Status.MISSING, "no baseline"), CheckResult(case, Status.UNREADABLE, "bad")]
    assert cli.nothing_moved(missing) == "no metric compared: none of the 2 case(s) has a baseline it was compared with"
    passed = CheckResult(case, Status.PASS)
    assert cli.nothing_moved([passed, *missing]) == "no metric moved in the 1 case(s) compared; 2 not compared"
    assert passed.summary == "bit for bit"
    assert CheckResult(case, Status.PASS, exact=False).summary == "within tolerances"
    changes = (_change("c", "rms_position_error_m"), _change("c", "collisions", failed=False))
    assert CheckResult(case, Status.FAIL, changes=changes).summary == "moved: rms_position_error_m"
    fail = CheckResult(case, Status.FAIL, changes=changes, exact=False, differs=("seed 0 -> 1",))
    assert fail.summary == "case differs: seed 0 -> 1; beyond tolerances: rms_position_error_m"
    assert missing[0].summary == ""


def test_the_table_of_moves_stays_aligned_with_long_names() -> None:
    long = "random977-edumip-balancing-plan-hybrid-a-star-segmented-s977"  # longer than 40
    lines = cli.format_changes([_change(long, "estimation_heading_rmse_rad"), _change("c", "fell")]).splitlines()
    head, rows = lines[0], lines[2:]
    assert rows[0].index("estimation_heading_rmse_rad") == rows[1].index("fell") == head.index("metric")
    assert rows[0].index("regressed") == rows[1].index("regressed") == head.index("status")


def test_gains_for_a_tracker_that_takes_none_are_refused(tmp_path: Path) -> None:
    """FBL gains go only to trackers that take them: on any other they would change nothing, and a
    changed gains file would still fail the case as a changed definition."""
    path = tmp_path / "suite.toml"
    path.write_text(
        'cases = [{ scenario = "open", robot = "edumip", reference = "line", tracker = "kanayama", seed = 0, '
        'control_rate = 50, gains = "9,6" }]\n'
    )
    with pytest.raises(ConfigError, match=r"gains = \"9,6\": tracker 'kanayama' takes no FBL gains"):
        load_suite(path)
    path.write_text(path.read_text().replace("kanayama", "fbl"))
    assert load_suite(path).cases[0].gains == FBLGains(9.0, 6.0)


def test_a_baseline_records_its_robots_files_and_an_edit_of_them_fails_everywhere(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Off the recording machine metrics are compared within tolerances, which the TurtleBot3's base at twice its
    mass stayed within (the open loop's final error moved 0.4 mm of 5.4 mm): the baseline now names the digests of
    the robot's files, and a case run on other files fails on any machine, naming the file edited; one recorded
    before is compared without."""
    import sim.tools.digests as digests
    from planning.core.robot import robot_files

    suite, bl = _suite(tmp_path, other=False), tmp_path / "bl"
    assert _regress(suite, bl, "--update") == 0
    path = bl / "planted.json"
    recorded = json.loads(path.read_text())["model"]
    now = digests.model_digest("turtlebot3")
    assert recorded == {
        "robot": "turtlebot3",
        "digest": now["all"],
        "files": {k: v for k, v in now.items() if k != "all"},
    }
    assert sorted(recorded["files"]) == ["model", "scene", "sensors"]
    capsys.readouterr()

    real = digests.model_digest
    edited = {**now, "all": "0123456789ab", "model": "ffffffffffff"}  # the MJCF edited, as off the machine
    monkeypatch.setattr(digests, "model_digest", lambda robot: edited if robot == "turtlebot3" else real(robot))
    assert _regress(suite, bl) == 1  # the same metrics (a digest is all that moved)
    out, err = capsys.readouterr()
    change = f"robot turtlebot3's files {recorded['digest']} -> 0123456789ab ({robot_files('turtlebot3').mjcf} edited)"
    assert "FAIL             planted (case differs: " + change in out, out
    assert "its definition differs from its baseline's: " + change in err and "--update" in err
    doc = json.loads(path.read_text())
    del doc["model"]  # as recorded before baselines named their robot's files
    path.write_text(json.dumps(doc))
    assert _regress(suite, bl) == 0
    assert _regress(suite, bl, "--update") == 0
    assert 'now records model = {"robot": "turtlebot3", "digest": "0123456789ab", "files": {' in capsys.readouterr().out


def test_the_model_digest_follows_the_robots_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The digest reads the files the robot is made of: an edited mass in a registered robot's model changes the
    model's and the whole digest, not the others'."""
    from planning.core.robot import ROBOTS, register_robot
    from sim.tools.digests import model_digest
    from tests.registry_helpers import isolated
    from tests.test_robot_plugins import _robot

    with isolated(monkeypatch, (ROBOTS,), "loaded"):
        model, sensors = _robot(tmp_path, "heavybot")
        register_robot("heavybot", model, sensors=sensors)
        before = model_digest("heavybot")
        assert before == model_digest("heavybot") and before["all"] != model_digest("turtlebot3")["all"]
        text = model.read_text()
        assert 'mass="0.82573504"' in text, "the Burger's base mass"
        model.write_text(text.replace('mass="0.82573504"', 'mass="1.6"'))
        after = model_digest("heavybot")
        assert [k for k in before if before[k] != after[k]] == ["all", "model"]
        assert len({model_digest(r)["all"] for r in ("turtlebot3", "edumip", "edumip-balancing")}) == 3
        assert sorted(model_digest("edumip-balancing")) == ["all", "balance", "model", "scene", "sensors"]
