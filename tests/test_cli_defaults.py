"""``nhsim simulate``'s defaults: one rule decides what runs, and ``--help`` states every default it uses."""

from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Any

import pytest

from control.gains import FBLGains
from planning.errors import ConfigError
from sim.cli import simulate
from sim.cli.job_outputs import RUN_SETTINGS
from sim.cli.main import main
from sim.cli.simulate import job_source
from sim.physics.asbuilt import DEFAULT_BUILD_SEED
from sim.pipeline import simulate as pipeline

# (argv, scenario, source) as the scenario files define them: edumip_map names c-rrt-star, farm
# names birrt, open names no planner.
JOBS = [
    ([], "edumip_map", {"planner": "c-rrt-star"}),
    (["--scenario", "farm"], "farm", {"planner": "birrt"}),
    (["--planner", "rrt-star"], "edumip_map", {"planner": "rrt-star"}),
    (["--reference", "circle"], "open", {"reference": "circle"}),
    (["--scenario", "open"], "open", {"reference": "figure8"}),
    (["--scenario", "farm", "--reference", "line"], "farm", {"reference": "line"}),
]


def _parser() -> argparse.ArgumentParser:
    return simulate.add_parser(argparse.ArgumentParser(prog="nhsim").add_subparsers())


def _option_help(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Each option's paragraph of ``--help`` (unwrapped: COLUMNS is set wide), by its first flag."""
    blocks = re.split(r"\n  (?=-)", parser.format_help())
    return {block.split()[0].rstrip(","): " ".join(block.split()) for block in blocks[1:]}


def _shown(default: Any) -> str:
    if default is True:
        return "on"
    return f"{default:g}" if isinstance(default, float) else str(default)


def test_help_states_each_options_real_default(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "1000")
    parser = _parser()
    helps = _option_help(parser)
    checked = 0
    for action in parser._actions:
        if not action.option_strings or isinstance(action, (argparse._HelpAction, argparse._StoreTrueAction)):
            continue
        text = helps[action.option_strings[0]]
        assert "(default: " in text, f"{action.option_strings[0]} does not say what it does when not given"
        if action.default is not None:
            assert f"(default: {_shown(action.default)}" in text, text
            checked += 1
    assert checked >= 10
    for key, value in RUN_SETTINGS.items():  # output names tag the settings that differ from these
        assert parser.get_default(key) == value
    assert f"(default: {DEFAULT_BUILD_SEED})" in helps["--build-seed"]
    assert f"(default: {FBLGains().kp:g},{FBLGains().kd:g})" in helps["--gains"]
    # The rule of what runs, as the help states it, is what job_source does.
    plan_scenario, reference_scenario = job_source(None, None, None)[0], job_source(None, None, "circle")[0]
    assert f"(default: {plan_scenario}; {reference_scenario} with --reference)" in helps["--scenario"]
    fallback = job_source(reference_scenario, None, None)[1]["reference"]
    assert f"{fallback} when the scenario names no planner" in helps["--reference"]
    assert "(default: the scenario's planner)" in helps["--planner"]


@pytest.mark.parametrize(("argv", "scenario", "source"), JOBS)
def test_one_rule_decides_the_job(argv: list[str], scenario: str, source: dict[str, str]) -> None:
    args = _parser().parse_args(argv)
    assert job_source(args.scenario, args.planner, args.reference) == (scenario, source)


def test_a_planner_and_a_reference_exclude_each_other() -> None:
    with pytest.raises(ConfigError, match="--reference and --planner exclude each other"):
        job_source(None, "rrt", "circle")


@pytest.mark.parametrize(("argv", "scenario", "source"), JOBS[:4])
def test_simulate_runs_the_job_the_rule_names(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, argv: list[str], scenario: str, source: dict[str, str]
) -> None:
    monkeypatch.chdir(tmp_path)
    seen: list[Any] = []

    def caught(case: Any, *args: Any, **kwargs: Any) -> None:
        seen.append(case)
        raise ConfigError("stopped before the physics")

    monkeypatch.setattr(pipeline, "simulate", caught)
    assert main(["simulate", *argv, "--no-video", "--no-plots", "--quiet"]) == 2
    (case,) = seen
    assert (case.scenario, case.planner, case.reference) == (scenario, source.get("planner"), source.get("reference"))
