"""The physics regression suite: one test per declared case, and the checks of the checker.

Fast cases run by default; the whole suite with ``-m slow`` or ``--all-cases``.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

import sim.tools.regress as regress
from planning.errors import ConfigError
from sim.cli.main import main
from sim.pipeline.case import Case
from sim.tools.regress import Tolerance, check_case, compare, load_suite

#: The repository's suite and baselines (the command line's defaults).
SUITE_PATH = Path(__file__).parent / "regression_suite.toml"
BASELINE_DIR = Path(__file__).parent / "baselines"
SUITE = load_suite(SUITE_PATH)


@pytest.mark.parametrize(
    "case", [pytest.param(c, id=c.name, marks=() if c.fast else pytest.mark.slow) for c in SUITE.cases]
)
def test_case_matches_baseline(case: Case) -> None:
    outcome = check_case(case, BASELINE_DIR, SUITE.tolerances)
    assert outcome.ok, outcome.message


def test_suite_has_a_fast_subset_and_every_baseline() -> None:
    fast = SUITE.select()
    assert 2 <= len(fast) < len(SUITE.cases)
    missing = [c.name for c in SUITE.cases if not regress.baseline_path(c, BASELINE_DIR).exists()]
    assert not missing, f"no baseline for {missing}: run nhsim regress --update --case NAME"


PLANTED = '{ name = "planted", scenario = "open", robot = "turtlebot3", reference = "circle", tracker = "fbl", seed = 0'


def _suite(tmp_path: Path, extra: str = "") -> Path:
    path = tmp_path / "suite.toml"
    path.write_text(f"cases = [\n  {PLANTED}{extra}, fast = true }},\n]\n")
    return path


@pytest.mark.parametrize("planted", [', gains = "0.5,0.5"', ', perturb = "radius=1.03"'])
def test_planted_regression_fails_naming_case_and_metric(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], planted: str
) -> None:
    base_dir = tmp_path / "baselines"
    args = ["regress", "--baselines", str(base_dir)]
    assert main([*args, "--suite", str(_suite(tmp_path)), "--update"]) == 0
    recorded = (base_dir / "planted.json").read_text()
    assert main([*args, "--suite", str(_suite(tmp_path))]) == 0  # unchanged: passes bit for bit
    capsys.readouterr()

    assert main([*args, "--suite", str(_suite(tmp_path, planted))]) == 1  # a wrong gain / a wrong model
    out, err = capsys.readouterr()
    assert "planted" in err and "rms_position_error_m regressed" in err
    assert "planted" in out and "rms_position_error_m" in out  # the table of what moved
    assert (base_dir / "planted.json").read_text() == recorded  # never rewritten unless asked

    assert main([*args, "--suite", str(_suite(tmp_path, planted)), "--update"]) == 0
    out = capsys.readouterr().out
    assert "updated" in out and "rms_position_error_m" in out  # what changed
    assert main([*args, "--suite", str(_suite(tmp_path, planted))]) == 0


@pytest.mark.parametrize(
    ("key", "elsewhere"),
    [("platform", "Elsewhere-arm64"), ("cpu", "GenuineIntel family 6 model 143; 40 SIMD features up to AVX512")],
)
def test_other_environment_compares_with_tolerances(tmp_path: Path, key: str, elsewhere: str) -> None:
    base_dir = tmp_path / "baselines"
    assert main(["regress", "--suite", str(_suite(tmp_path)), "--baselines", str(base_dir), "--update"]) == 0
    path = base_dir / "planted.json"
    doc = json.loads(path.read_text())
    case = load_suite(tmp_path / "suite.toml").cases[0]
    assert check_case(case, base_dir).exact  # same machine: bit for bit
    doc["environment"][key] = elsewhere  # another machine, or the same wheels on another CPU
    rms = doc["metrics"]["rms_position_error_m"]
    tol = regress.DEFAULT_TOLERANCES["rms_position_error_m"]
    for shift, ok in ((-0.5 * tol.allowed(rms), True), (-2.0 * tol.allowed(rms), False), (0.01, True)):
        doc["metrics"]["rms_position_error_m"] = rms + shift  # now - baseline = -shift
        path.write_text(json.dumps(doc))
        outcome = check_case(case, base_dir)
        assert not outcome.exact
        assert outcome.ok is ok, outcome.message
        if not ok:
            assert "rms_position_error_m regressed" in outcome.message and "with tolerances" in outcome.message


def test_compare_rules() -> None:
    tol = {"rms_position_error_m": Tolerance(0.1, 0.0), "duration_s": Tolerance(0.5, 0.0)}
    base = {k: 1.0 for k in regress.DIRECTIONS}
    assert compare("c", dict(base), base, tol, exact=True) == []
    better = dict(base, rms_position_error_m=0.5)
    [c] = compare("c", better, base, tol, exact=True)
    assert (c.status, c.failed) == ("improved", True)  # bit for bit: any change fails
    [c] = compare("c", better, base, tol, exact=False)
    assert (c.status, c.failed) == ("within", False)  # elsewhere: better is fine
    [c] = compare("c", dict(base, rms_position_error_m=1.05), base, tol, exact=False)
    assert not c.failed
    [c] = compare("c", dict(base, rms_position_error_m=1.2), base, tol, exact=False)
    assert (c.status, c.allowed) == ("regressed", 0.1)
    [c] = compare("c", dict(base, duration_s=0.2), base, tol, exact=False)
    assert c.status == "changed"  # duration: any move beyond tolerance, either way


def test_nondeterminism_fails_loudly(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    case = load_suite(_suite(tmp_path)).cases[0]
    real_prepare = regress.prepare_case
    calls = []

    def drifting(c: Case):  # type: ignore[no-untyped-def]
        calls.append(c)
        # the second run meets a 1e-9 m/s^2 different gain: a hidden state leaking between runs
        return real_prepare(c if len(calls) == 1 else dataclasses.replace(c, gains=regress.FBLGains(9.0 + 1e-9)))

    monkeypatch.setattr(regress, "prepare_case", drifting)
    outcome = check_case(case, tmp_path)
    assert outcome.status == "nondeterministic"
    assert "planted" in outcome.message and "not deterministic" in outcome.message and "pose" in outcome.message


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("cases = []\n", "non-empty 'cases'"),
        ('cases = [{ robot = "edumip", reference = "line" }]\n', "has no scenario"),
        ('cases = [{ scenario = "open", reference = "line", colour = 1 }]\n', "unknown case field"),
        ('cases = [{ scenario = "open", reference = "spiral" }]\n', "unknown reference"),
        (
            'cases = [{ scenario = "open", reference = "line" }, { scenario = "open", reference = "line" }]\n',
            "duplicate",
        ),
        ('cases = [{ scenario = "open", reference = "line" }]\n[tolerances]\nspeed = { abs = 1 }\n', "not a metric"),
        # a rate the robot's 2 ms physics cannot keep (the scenario's robot, and a balancing robot's 1 ms)
        ('cases = [{ scenario = "open", reference = "line", control_rate = 33 }]\n', r"case 1 .*33 Hz.*divides 500 Hz"),
        (
            'cases = [{ scenario = "open", reference = "line" },\n'
            '  { scenario = "open", robot = "edumip-balancing", reference = "line", control_rate = 3000 }]\n',
            r"case 2 .*3000 Hz is not a whole number of 1 ms",
        ),
    ],
)
def test_bad_suite_files(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "suite.toml"
    path.write_text(text)
    with pytest.raises(regress.ConfigError, match=match):
        load_suite(path)


def test_unknown_scenario_case_is_an_error_naming_it(tmp_path: Path) -> None:
    case = Case("nowhere", reference="line", name="lost")
    outcome = check_case(case, tmp_path)
    assert outcome.status == "error" and "lost" in outcome.message and "nowhere" in outcome.message


def test_a_baselines_folder_that_cannot_serve_is_refused_before_any_case_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def no_run(*args: object, **kwargs: object) -> None:
        raise AssertionError("a case ran")

    monkeypatch.setattr(regress, "check_task", no_run)
    case = ["--case", "open-turtlebot3-line-fbl-s0"]
    a_file = tmp_path / "baselines.txt"
    a_file.write_text("x")
    for args, message in [
        (["--baselines", str(tmp_path / "none")], "does not exist; give the folder that holds the baselines"),
        (["--baselines", str(a_file)], "is a file, not a folder"),
        (["--update", "--baselines", str(a_file / "sub")], "cannot write"),
    ]:
        assert main(["regress", *args, *case]) == 2
        assert message in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["baselines.txt"]  # nothing written


def test_a_suite_with_no_fast_case_refuses_the_default_run_that_would_check_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    suite = tmp_path / "suite.toml"
    suite.write_text(
        'cases = [ { scenario = "open", robot = "edumip", reference = "line", tracker = "fbl", seed = 0 } ]\n'
    )
    for extra in ([], ["--update"], ["--list"]):
        assert main(["regress", "--suite", str(suite), "--baselines", str(tmp_path / "bl"), *extra]) == 2
        assert "none of the suite's 1 case(s) is marked fast = true" in capsys.readouterr().err
    assert not (tmp_path / "bl").exists()
    assert len(load_suite(suite).select(all_cases=True)) == 1


def test_every_case_pattern_must_match_and_an_empty_one_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    good = SUITE.cases[0].name
    with pytest.raises(ConfigError, match=r"--case typo\* matches no case"):
        SUITE.select([good, "typo*"])  # the good one alone would have run, and passed
    assert [c.name for c in SUITE.select([good])] == [good]
    for empty in ("", ","):
        assert main(["regress", "--list", "--case", empty]) == 2
        assert "--case needs a pattern" in capsys.readouterr().err


def test_the_update_hint_names_the_baselines_folder_it_was_given(tmp_path: Path) -> None:
    from sim.cli.main import build_parser
    from sim.cli.regress import _with_files

    hint = "case x: no baseline b/x.json; record it with nhsim regress --update --case x"
    args = build_parser().parse_args(["regress", "--baselines", str(tmp_path), "--suite", "s.toml"])
    assert _with_files(hint, args).endswith(f"nhsim regress --update --suite s.toml --baselines {tmp_path} --case x")
    assert _with_files(hint, build_parser().parse_args(["regress"])) == hint
