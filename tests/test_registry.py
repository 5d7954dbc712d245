"""The planner registry: names, options, errors that list the valid choices."""

import dataclasses

import pytest

from planning.errors import ConfigError
from planning.planners.registry import PLANNERS, config_from_options, make_planner, planner_options, register_planner
from planning.planners.sampling.crrt_star import CRRTStar, CRRTStarConfig
from planning.planners.sampling.rrt import BiRRTConfig, TreeConfig


def test_unknown_name_lists_every_registered_planner() -> None:
    with pytest.raises(ConfigError, match="unknown planner 'teleport'") as info:
        make_planner("teleport")
    for name in PLANNERS:
        assert name in str(info.value)


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_unknown_option_lists_the_valid_ones(name: str) -> None:
    match = f"unknown option\\(s\\) warp_speed for planner '{name}': valid options"
    with pytest.raises(ConfigError, match=match) as info:
        make_planner(name, warp_speed=9)
    valid = planner_options(name)
    assert valid and all(opt in str(info.value) for opt in valid)


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_every_listed_option_is_accepted(name: str) -> None:
    planner = make_planner(name)
    for opt in planner_options(name):
        if opt == "config":
            continue
        # the option as the planner holds it after construction, or the config field's default
        cfg = getattr(planner, "config", None)
        value = getattr(cfg, opt) if dataclasses.is_dataclass(cfg) else None
        if value is None:
            continue
        assert make_planner(name, **{opt: value}).name == name


def test_options_come_from_the_signature_or_the_config_class() -> None:
    assert set(planner_options("rrt")) == {f.name for f in dataclasses.fields(TreeConfig)}
    assert set(planner_options("birrt")) == {f.name for f in dataclasses.fields(BiRRTConfig)}
    assert set(planner_options("c-rrt-star")) == {"config"} | {f.name for f in dataclasses.fields(CRRTStarConfig)}
    assert {"N", "dt", "init", "margin"} <= set(planner_options("optim"))
    assert {"u1max", "u2max", "phimax", "tolerance"} <= set(planner_options("sinusoidal"))


def test_bad_values_are_config_errors() -> None:
    with pytest.raises(ConfigError, match="goal_bias"):
        make_planner("rrt", goal_bias=2.0)
    with pytest.raises(ConfigError, match="u2max"):
        make_planner("sinusoidal", u2max=-1.0)


def test_config_from_options() -> None:
    base = CRRTStarConfig(gamma=0.3)
    assert config_from_options(CRRTStarConfig, {"max_step": 0.1}, base) == CRRTStarConfig(gamma=0.3, max_step=0.1)
    assert config_from_options(CRRTStarConfig, {}) == CRRTStarConfig()
    with pytest.raises(ConfigError, match="unknown option\\(s\\) step: valid options are center_clearance, gamma"):
        config_from_options(CRRTStarConfig, {"step": 0.1})
    with pytest.raises(ConfigError, match="unknown option"):
        CRRTStar(step=0.1)
    # a config of another type (from the command line, a string) was a TypeError of dataclasses.replace's
    for wrong in ("x", {"gamma": 0.3}, TreeConfig()):
        with pytest.raises(ConfigError, match=r"config must be a CRRTStarConfig, got .*: give one, or give its fields"):
            make_planner("c-rrt-star", config=wrong)


def test_register_planner(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(PLANNERS, "crrt-alias", "")
    register_planner("crrt-alias", "planning.planners.sampling.crrt_star:CRRTStar")
    planner = make_planner("crrt-alias", gamma=0.2)
    assert isinstance(planner, CRRTStar) and planner.config.gamma == 0.2
