"""The real robot on worlds no scenario was tuned on: random obstacles from a seed, each robot as
built from its own build seed, planned, smoothed and tracked on its fused estimate."""

from __future__ import annotations

import pytest

from planning.scenario import random_scenario
from sim import PlanOptions, simulate_plan
from sim.pipeline.runs import RunKind
from sim.pipeline.sweep import TARGETS


@pytest.mark.parametrize("robot", ["turtlebot3", "edumip"])
@pytest.mark.parametrize("seed", range(4))
def test_the_fused_closed_loop_meets_its_targets_on_random_worlds(robot: str, seed: int) -> None:
    # on synthetic fixes (the EduMIP's default); the TurtleBot3's scan localiser: the test below
    job = simulate_plan(
        random_scenario(robot, seed),
        planner="birrt",
        seed=seed,
        build_seed=10 + seed,
        planning=PlanOptions(time_limit=5),
        localiser="fixes",
    )
    _meets_targets(job)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_the_closed_loop_on_amcl_meets_its_targets_on_random_worlds(seed: int) -> None:
    job = simulate_plan(
        random_scenario("turtlebot3", seed),
        planner="birrt",
        seed=seed,
        build_seed=10 + seed,
        planning=PlanOptions(time_limit=5),
        localiser="amcl",
    )
    _meets_targets(job)


def _meets_targets(job) -> None:  # type: ignore[no-untyped-def]
    m = job.metrics[RunKind.CLOSED_LOOP]
    for key, bound in TARGETS.items():
        assert getattr(m, key) <= bound, key
    assert m.collisions == 0 and m.warnings == 0 and m.status == "ok"
    assert m.wheel_contact_loss_fraction <= 0.001
    assert m.final_position_error_m < job.metrics[RunKind.OPEN_LOOP].final_position_error_m


def test_a_generated_worlds_name_is_one_name() -> None:
    """``random01`` and ``random\u0663`` (an Arabic-Indic 3) loaded as ``random1`` and ``random3`` and were recorded
    under those names; a name of the form refused names the one that is that world."""
    from planning.errors import ScenarioError
    from planning.scenario import is_builtin_name, load_scenario

    assert load_scenario("random0").name == "random0" and load_scenario("random70").name == "random70"
    for name, world in [("random01", "random1"), ("random\u0663", "random3"), ("random00", "random0")]:
        assert not is_builtin_name(name)
        with pytest.raises(ScenarioError, match=f"without leading zeros: {world} is that world"):
            load_scenario(name)


def test_the_benches_take_a_generated_worlds_name_as_the_commands_do() -> None:
    """``bench plan`` and ``bench simplify`` read ``random01`` as random1 and ``random\u00b2`` ended in a traceback
    (each parsed the name itself); a name too long for a file ended in ``OSError: File name too long``."""
    from planning.errors import ConfigError, ScenarioError
    from planning.scenario import load_scenario, random_seed
    from sim.tools.bench import plan_problems, simplify

    assert [random_seed(n) for n in ("random0", "random12", "random012", "random\u0663", "random", "x")] == [
        0,
        12,
        None,
        None,
        None,
        None,
    ]
    for problems in (plan_problems.problems, simplify.problems):
        assert problems(["random12"], 0)[0] is not None
        with pytest.raises(ConfigError, match="without leading zeros: random1 is that world"):
            problems(["random01"], 0)
        with pytest.raises(ConfigError):
            problems(["random\u00b2"], 0)
    with pytest.raises(ScenarioError, match=r"a name of 300 bytes .* at most 255"):
        load_scenario("x" * 300)
    assert load_scenario("random" + "1" * 300).name == "random" + "1" * 300  # a seed, however long
