"""The regression suite's judgement of metrics: every metric a baseline records, values that are not finite,
what ``--update`` says it changes, and numbers shown with the digits that tell them apart."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

import sim.cli.regress as cli
import sim.tools.regress as regress
from planning.errors import ConfigError
from sim.cli.main import main
from sim.pipeline.case import Case
from sim.tools.regress import DEFAULT_TOLERANCES, Baseline, Change, Status, Tolerance, compare, judge, load_suite

#: A closed-loop run's metrics, as :func:`sim.tools.regress.flat_metrics` gives them.
RUN: dict[str, Any] = {
    "final_position_error_m": 0.0025518028283711375,
    "rms_position_error_m": 0.001757958973065803,
    "collisions": 0,
    "duration_s": 7.0599999999994445,
    "status": "ok",
    "estimation_source": "fused",
    "estimation_final_position_error_m": 0.0011228998241885604,
    "estimation_nees_in_bound_fraction": 0.8571428571428571,
    "estimation_nees_mean": 2.0141998305057003,
    "estimation_fixes_used": 70,
}
#: A baseline of that run edited: text, a number without a direction (the NEES mean), one better high (the NEES in
#: bound) and one better low, each beyond its tolerance.
EDITED = {
    "status": "diverged",
    "estimation_source": "odometry",
    "estimation_nees_mean": 99.0,
    "estimation_nees_in_bound_fraction": 0.99,
    "estimation_final_position_error_m": 0.00005,
}
#: How the run is judged against that baseline, in any environment.
JUDGED = {
    "status": "changed",
    "estimation_source": "changed",
    "estimation_nees_mean": "changed",
    "estimation_nees_in_bound_fraction": "regressed",
    "estimation_final_position_error_m": "regressed",
}


@pytest.mark.parametrize("exact", [True, False], ids=["same environment", "another environment"])
def test_every_metric_a_baseline_records_is_judged(exact: bool) -> None:
    """Text must be equal in every environment; every number is judged, by its direction and its tolerance."""
    changes = compare("c", RUN, {**RUN, **EDITED}, DEFAULT_TOLERANCES, exact=exact)
    assert {c.metric: (c.status, c.failed) for c in changes} == {m: (s, True) for m, s in JUDGED.items()}
    assert compare("c", RUN, dict(RUN), DEFAULT_TOLERANCES, exact=exact) == []
    recorded_only = compare("c", RUN, {**RUN, "max_pitch_rad": 0.1, "note": "x"}, {}, exact=exact)
    assert [(c.metric, c.baseline, c.value, c.failed) for c in recorded_only] == [
        ("max_pitch_rad", 0.1, None, True),
        ("note", "x", None, True),
    ]


def test_a_number_without_a_built_in_tolerance_takes_the_suites_elsewhere() -> None:
    base = {**RUN, "estimation_nees_mean": 2.0, "estimation_fixes_used": 71}
    tol = {"estimation_nees_mean": Tolerance(0.1, 0.0)}
    changes = {c.metric: c for c in compare("c", RUN, base, tol, exact=False)}
    assert (changes["estimation_nees_mean"].status, changes["estimation_nees_mean"].failed) == ("within", False)
    assert changes["estimation_fixes_used"].status == "changed"  # 0, 0: any move, either way
    assert {c.status for c in compare("c", RUN, base, tol, exact=True)} == {"changed"}  # bit for bit


def test_an_edited_baseline_fails_its_case(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"case": {}, "environment": regress.environment(), "metrics": {**RUN, **EDITED}}))
    result = judge(Case("open", reference="line", name="c"), RUN, Baseline.read(path), {})
    assert result.status is Status.FAIL and result.exact, result
    assert 'status changed ("diverged" -> "ok")' in result.message
    assert "estimation_nees_mean changed (99 -> 2.0142)" in result.message


def _suite_with(tmp_path: Path, tolerances: str) -> Path:
    path = tmp_path / "suite.toml"
    path.write_text(
        'cases = [{ scenario = "open", robot = "turtlebot3", reference = "line", tracker = "fbl", seed = 0 }]\n'
        f"[tolerances]\n{tolerances}\n"
    )
    return path


def test_tolerances_take_every_number_a_baseline_records_and_refuse_text(tmp_path: Path) -> None:
    unjudged = ("estimation_nees_mean", "estimation_fixes_used", "fall_time_s", "estimation_scans_cast")
    table = "\n".join(f"{m} = {{ abs = 0.5 }}" for m in unjudged)
    assert load_suite(_suite_with(tmp_path, table)).tolerances["estimation_nees_mean"] == Tolerance(0.5, 0.0)
    numbers = [m for m in regress.METRICS if m not in regress.TEXT_METRICS]
    assert load_suite(_suite_with(tmp_path, "\n".join(f"{m} = {{ rel = 1 }}" for m in numbers))).tolerances
    assert set(regress.TEXT_METRICS) == {"status", "estimation_source"}
    with pytest.raises(ConfigError, match=r"\[tolerances\] 'status' is text, which must be equal in every env"):
        load_suite(_suite_with(tmp_path, "status = { abs = 1 }"))
    assert regress.NULLABLE_METRICS <= set(regress.METRICS)


@pytest.mark.parametrize("exact", [True, False], ids=["same environment", "another environment"])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_value_that_is_not_finite_beside_one_fails_and_is_never_an_improvement(exact: bool, bad: float) -> None:
    base = {"final_position_error_m": 0.0025, "duration_s": 7.06, "estimation_nees_mean": 2.0}
    for metric in base:
        for now, then in ((dict(base, **{metric: bad}), base), (base, dict(base, **{metric: bad}))):
            [c] = compare("c", now, then, DEFAULT_TOLERANCES, exact=exact)
            assert (c.metric, c.status, c.failed) == (metric, "not finite", True)
    nan_both = {"rms_position_error_m": math.nan, "estimation_nees_mean": None}  # a baseline writes NaN as null
    assert compare("c", nan_both, {"rms_position_error_m": None, "estimation_nees_mean": None}, {}, exact=exact) == []


@pytest.mark.parametrize(
    ("literal", "metric"),
    [("NaN", "final_position_error_m"), ("Infinity", "max_position_error_m"), ("-Infinity", "estimation_nees_mean")],
)
def test_a_baseline_holding_a_number_that_is_not_finite_is_unreadable(
    tmp_path: Path, literal: str, metric: str
) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"metrics": {**RUN, metric: 1.5}}).replace("1.5", literal))
    read = Baseline.read(path)
    assert read.document is None and read.problem.startswith(f"metric(s) {metric} not finite (a baseline writes NaN")
    result = judge(Case("open", reference="line", name="c"), RUN, read, DEFAULT_TOLERANCES)
    assert result.status is Status.UNREADABLE and metric in result.message


def test_a_null_is_a_value_only_where_a_metric_may_have_none() -> None:
    """A fall where the baseline's robot stood, a NEES where there was none: a change, not an unreadable file;
    null for a metric that is always a number: a hole."""
    case, run = Case("open", reference="line", name="c"), {**RUN, "fall_time_s": 3.5}
    base = Baseline(Path("c.json"), {"metrics": {**run, "fall_time_s": None, "estimation_nees_mean": None}})
    result = judge(case, run, base, {})
    assert result.status is Status.FAIL and "fall_time_s changed (none -> 3.5)" in result.message, result
    assert "estimation_nees_mean changed (none -> 2.0142)" in result.message
    holed = Baseline(Path("c.json"), {"metrics": {**run, "status": None, "estimation_fixes_used": None}})
    result = judge(case, run, holed, {})
    assert result.status is Status.UNREADABLE, result
    assert "no value for metric(s) status, estimation_fixes_used: missing or null" in result.message


def test_two_different_numbers_are_never_shown_alike() -> None:
    old = 0.0025518028283711375
    new = old + 3.7e-17
    change = Change("c", "final_position_error_m", old, new, 0.0, "regressed")
    head, _, row = cli.format_changes([change]).splitlines()
    assert f" {old!r} {new!r} " in row and f"{new - old:+.3g}" in row and repr(old) != repr(new), row
    assert head.index("status") == row.index("regressed")
    result = judge(
        Case("open", reference="line", name="c"),
        {**RUN, "final_position_error_m": new},
        Baseline(Path("c.json"), {"metrics": RUN, "environment": regress.environment()}),
        {},
    )
    assert f"final_position_error_m regressed ({old!r} -> {new!r})" in result.message
    assert regress.show_values(0.5, 0.25) == ("0.5", "0.25")  # short where that tells them apart
    assert regress.show_values("ok", None) == ('"ok"', "none")


def _record(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[list[str], Path]:
    """A suite of one quick case recorded: the command's arguments, and its baseline file."""
    suite = tmp_path / "suite.toml"
    suite.write_text(
        'cases = [{ name = "c", scenario = "open", robot = "turtlebot3", reference = "line", tracker = "fbl", '
        "seed = 0, fast = true }]\n"
    )
    args = ["regress", "--suite", str(suite), "--baselines", str(tmp_path / "bl")]
    assert main([*args, "--update"]) == 0
    capsys.readouterr()
    return args, tmp_path / "bl" / "c.json"


def test_update_names_what_it_drops_from_a_baseline(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args, path = _record(tmp_path, capsys)
    doc = json.loads(path.read_text())
    recorded = json.loads(path.read_text())
    doc["metrics"].update(max_pitch_rad=0.1, custom_note="by hand")
    doc["note"] = "kept?"
    path.write_text(json.dumps(doc))
    assert main(args) == 1
    out = capsys.readouterr().out
    assert "FAIL             c (moved: max_pitch_rad, custom_note)" in out, out
    assert main([*args, "--update"]) == 0
    out = capsys.readouterr().out
    said = (
        f'updated {path}: no longer records metric(s) max_pitch_rad (0.1), custom_note ("by hand"); removed field note'
    )
    assert said in out and "no change" not in out, out
    assert json.loads(path.read_text()) == recorded
    assert main([*args, "--update"]) == 0
    assert "0 baseline(s) written" in capsys.readouterr().out  # nothing left to change


def test_update_of_a_baseline_without_a_metric_replaces_an_unreadable_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args, path = _record(tmp_path, capsys)
    doc = json.loads(path.read_text())
    del doc["metrics"]["rms_position_error_m"]
    path.write_text(json.dumps(doc))
    assert main(args) == 1
    assert "UNREADABLE       c" in capsys.readouterr().out
    assert main([*args, "--update"]) == 0
    out = capsys.readouterr().out
    hole = "no value for metric(s) rms_position_error_m: missing or null"
    assert f"replaced unreadable baseline {path} ({hole})" in out and "None ->" not in out, out
    assert main(args) == 0
