"""The real robot on worlds no scenario was tuned on: random obstacles from a seed, each robot as
built from its own build seed, planned, smoothed and tracked on its fused estimate."""

from __future__ import annotations

import numpy as np
import pytest

from planning import Circle, Pose2D, Scenario, World
from planning.core.world import Box
from sim import PlanOptions, simulate_plan
from sim.pipeline.runs import RunKind
from sim.pipeline.sweep import TARGETS


def random_scenario(robot: str, seed: int) -> Scenario:
    """A 6 x 6 m arena with seven circles and boxes kept clear of the start and goal corners."""
    rng = np.random.default_rng(1000 + seed)
    obstacles: list[Circle | Box] = []
    while len(obstacles) < 7:
        c = (float(rng.uniform(-2.2, 2.2)), float(rng.uniform(-2.2, 2.2)))
        r = float(rng.uniform(0.2, 0.5))
        if min(np.hypot(c[0] + 2.4, c[1] + 2.4), np.hypot(c[0] - 2.4, c[1] - 2.4)) > r + 0.6:
            kind = rng.random() < 0.6
            obstacles.append(Circle(c, r) if kind else Box(c, (2 * r, r), float(rng.uniform(0, 3))))
    start = Pose2D(-2.4, -2.4, float(rng.uniform(-3, 3)))
    goal = Pose2D(2.4, 2.4, float(rng.uniform(-3, 3)))
    return Scenario(
        name=f"random{seed}", robot=robot, world=World((-3, 3, -3, 3), tuple(obstacles)), start=start, goal=goal
    )


@pytest.mark.parametrize("robot", ["turtlebot3", "edumip"])
@pytest.mark.parametrize("seed", range(4))
def test_the_fused_closed_loop_meets_its_targets_on_random_worlds(robot: str, seed: int) -> None:
    job = simulate_plan(
        random_scenario(robot, seed),
        planner="birrt",
        seed=seed,
        build_seed=10 + seed,
        planning=PlanOptions(time_limit=5),
    )
    m = job.metrics[RunKind.CLOSED_LOOP]
    for key, bound in TARGETS.items():
        assert getattr(m, key) <= bound, key
    assert m.collisions == 0 and m.warnings == 0 and m.status == "ok"
    assert m.wheel_contact_loss_fraction <= 0.001
    assert m.final_position_error_m < job.metrics[RunKind.OPEN_LOOP].final_position_error_m
