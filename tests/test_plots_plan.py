"""Plan figures and the shared world drawer: drawn headless, written atomically, never overwriting."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Ellipse as EllipsePatch
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.patches import Rectangle

from planning.core.world import Box, Circle, Ellipse, Polygon, World
from planning.errors import OutputExistsError
from planning.planners.base import PlanProblem, PlanResult, PlanStatus, PlanTree
from planning.planners.registry import make_planner
from planning.scenario import load_scenario
from sim.viz.plots.draw import PLAN_WORLD, RUN_WORLD, WorldStyle, draw_world, save_figure
from sim.viz.plots.plan import plan_figure

WORLD = World(
    (-2.0, 2.0, -1.0, 1.0),
    (
        Circle((1.0, 0.5), 0.2),
        Ellipse((-1.0, -0.5), (0.3, 0.1), 0.5),
        Box((0.0, 0.0), (0.4, 0.2), 0.3),
        Polygon(((-1.0, 0.2), (-0.6, 0.2), (-0.8, 0.6))),
    ),
)


@pytest.mark.parametrize("style", [PLAN_WORLD, RUN_WORLD], ids=["plan", "run"])
def test_draw_world_draws_each_obstacle_exactly(style: WorldStyle) -> None:
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    draw_world(ax, WORLD, style)
    patches = list(ax.patches)
    assert len(patches) == 1 + len(WORLD.obstacles)
    frame = patches[-1] if style.frame_on_top else patches[0]  # the walls over the obstacles, or under
    assert isinstance(frame, Rectangle) and not frame.get_fill()
    assert (frame.get_x(), frame.get_y(), frame.get_width(), frame.get_height()) == (-2.0, -1.0, 4.0, 2.0)
    circle, ellipse, box, polygon = (p for p in patches if p is not frame)
    assert isinstance(circle, CirclePatch) and tuple(circle.center) == (1.0, 0.5) and circle.radius == 0.2
    assert isinstance(ellipse, EllipsePatch) and (ellipse.width, ellipse.height) == (0.6, 0.2)
    assert ellipse.angle == pytest.approx(np.degrees(0.5), abs=1e-12)
    assert isinstance(box, PolygonPatch) and isinstance(polygon, PolygonPatch)
    corners = WORLD.obstacles[2].corners()  # type: ignore[union-attr]
    np.testing.assert_allclose(box.get_xy()[:4], corners, rtol=0, atol=1e-15)
    np.testing.assert_allclose(polygon.get_xy()[:3], WORLD.obstacles[3].array, rtol=0, atol=1e-15)  # type: ignore[union-attr]


def test_plan_figure_with_timeline_and_png(tmp_path: Path) -> None:
    problem = PlanProblem.from_scenario(load_scenario("parallel_park"))
    result = make_planner("sinusoidal").plan(problem)
    assert len(plan_figure(problem, result).axes) == 1  # the path alone by default (the CLI's plot)
    fig = plan_figure(problem, result, timeline=True)
    assert len(fig.axes) == 4  # path + three time panels
    path_ax, xy_ax = fig.axes[:2]
    (line,) = [ln for ln in path_ax.lines if ln.get_label() == "path"]
    assert line.get_xydata().shape == (result.path.shape[0], 2)
    assert result.times is not None
    (x_line,) = [ln for ln in xy_ax.lines if ln.get_label() == "x [m]"]
    np.testing.assert_array_equal(x_line.get_xdata(), result.times)
    np.testing.assert_array_equal(x_line.get_ydata(), result.path[:, 0])
    out = save_figure(fig, tmp_path / "plan.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(OutputExistsError):
        save_figure(fig, out)
    save_figure(fig, out, overwrite=True)
    assert [p.name for p in tmp_path.iterdir()] == ["plan.png"]


def test_plan_figure_draws_the_tree() -> None:
    problem = PlanProblem.from_scenario(load_scenario("parallel_park"))
    nodes = np.array([[0.0, 0.0, 0.0], [0.5, 0.1, 0.0], [0.4, -0.3, 0.0], [0.9, 0.2, 0.0]])
    tree = PlanTree(nodes=nodes, parents=np.array([-1, 0, 0, 1]))
    result = PlanResult(PlanStatus.TIMEOUT, "rrt", tree=tree)
    fig = plan_figure(problem, result, timeline=True)
    assert len(fig.axes) == 1  # untimed: no time panels
    ax = fig.axes[0]
    (edges,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    segs = sorted(map(tuple, (np.asarray(s).ravel() for s in edges.get_segments())))
    assert segs == sorted([(0.0, 0.0, 0.5, 0.1), (0.0, 0.0, 0.4, -0.3), (0.5, 0.1, 0.9, 0.2)])


def test_plan_figure_draws_the_raw_path_faded_under_the_simplified_one() -> None:
    problem = PlanProblem.from_scenario(load_scenario("parking_lot"))
    result = make_planner("birrt").plan(problem)
    assert result.raw_path is not None
    ax = plan_figure(problem, result).axes[0]
    (raw,) = [ln for ln in ax.lines if ln.get_label() == "raw path"]
    (path,) = [ln for ln in ax.lines if ln.get_label() == "path"]
    np.testing.assert_array_equal(raw.get_xydata(), result.raw_path[:, :2])
    np.testing.assert_array_equal(path.get_xydata(), result.path[:, :2])
    assert raw.get_linewidth() < path.get_linewidth() and raw.get_alpha() < 1.0 and raw.get_zorder() < path.get_zorder()
    assert "raw" in ax.get_title()
    plain = make_planner("birrt", simplify=False).plan(problem)
    assert not [ln for ln in plan_figure(problem, plain).axes[0].lines if ln.get_label() == "raw path"]
