"""Plan figures: drawn headless, written atomically, never overwriting without asking."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import pytest

from planning.errors import OutputExistsError
from planning.planners.base import PlanProblem
from planning.planners.registry import make_planner
from planning.scenario import load_scenario
from sim.viz.plots.plan import plan_figure, write_plan_figure


def test_plan_figure_and_png(tmp_path: Path) -> None:
    problem = PlanProblem.from_scenario(load_scenario("parallel_park"))
    result = make_planner("sinusoidal").plan(problem)
    fig = plan_figure(problem, result)
    assert len(fig.axes) == 4  # path + three time panels
    path_ax = fig.axes[0]
    (line,) = [ln for ln in path_ax.lines if ln.get_label() == "path"]
    assert line.get_xydata().shape == (result.path.shape[0], 2)
    plt.close(fig)
    out = write_plan_figure(tmp_path / "plan.png", problem, result)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(OutputExistsError):
        write_plan_figure(out, problem, result)
    write_plan_figure(out, problem, result, overwrite=True)
    assert [p.name for p in tmp_path.iterdir()] == ["plan.png"]
