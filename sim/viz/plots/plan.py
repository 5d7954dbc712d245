"""Plan figures: the world, the search tree and the path, and optionally the states and inputs in time.

Obstacles are filled grey (walls as the frame), the tree is thin blue edges (each node joined to its
parent, or the planner's dense edge curves when it gives them), the path a thick red line with
heading ticks (and, for a simplified plan, the search's raw path as a thin faded line under it),
start a green and goal a red marker with the goal tolerance circle. With
``timeline``, a path timed by its planner (sinusoidal, optim) gets a column of panels beside it:
x, y; theta (and phi); the inputs v, omega against time. Built with matplotlib's object API on the
Agg canvas: no display, no global pyplot state.
"""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.gridspec import GridSpec
from matplotlib.patches import Circle as CirclePatch
from numpy.typing import NDArray

from planning.core.geometry import path_length
from planning.core.world import World
from planning.planners.base import PlanProblem, PlanResult, PlanTree
from sim.viz.plots.draw import PLAN_WORLD, draw_world, frame_world, tight


def plan_figure(
    problem: PlanProblem, result: PlanResult, *, timeline: bool = False, title: str | None = None
) -> Figure:
    """A figure of a planning result.

    Args:
        problem: The problem planned (world, start, goal, tolerance).
        result: The planner's result (tree and path, either may be empty; times, controls and
            states when the planner timed the path).
        timeline: Add the states and inputs against time beside the path (when the path is timed).
        title: Figure title; default names planner, status and scenario.

    Returns:
        The matplotlib figure (Agg canvas attached): the path panel first, then x-y, angles and
        inputs against time with ``timeline``.
    """
    timed = timeline and result.times is not None and result.path.shape[0] > 1
    fig = Figure(figsize=(12.0, 6.0) if timed else (7.0, 7.0), dpi=110)
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(3, 2, width_ratios=[1.2, 1]) if timed else None
    ax = fig.add_subplot(grid[:, 0]) if grid is not None else fig.add_subplot(1, 1, 1)
    world = problem.world
    draw_world(ax, world, PLAN_WORLD)
    if result.tree is not None and result.tree.nodes.shape[0] > 0:
        _draw_tree(ax, result.tree)
    if result.raw_path is not None and result.raw_path.shape[0] > 0:
        raw = result.raw_path
        ax.plot(raw[:, 0], raw[:, 1], "-", color="tab:orange", linewidth=0.9, alpha=0.55, zorder=3, label="raw path")
    if result.path.shape[0] > 0:
        _draw_path(ax, result.path, world)
    _draw_ends(ax, problem)
    frame_world(ax, world, [result.path[:, :2]] if result.path.shape[0] > 0 else [])
    ax.grid(True, linewidth=0.3, alpha=0.5)
    ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
    length = result.length()
    was = f" (raw {path_length(result.raw_path):.2f} m)" if result.raw_path is not None else ""
    ax.set_title(title or f"{result.planner} on {problem.name}: {result.status.value}, path {length:.2f} m{was}")
    if grid is not None:
        _draw_timeline(fig, grid, result)
    tight(fig)
    return fig


def _draw_tree(ax: Axes, tree: PlanTree) -> None:
    """The search tree: its dense edge curves, or each node joined to its parent."""
    if tree.edges:
        segs = [np.asarray(e)[:, :2] for e in tree.edges]
    else:
        child = np.flatnonzero(tree.parents >= 0)
        segs = list(np.stack([tree.nodes[tree.parents[child], :2], tree.nodes[child, :2]], axis=1))
    ax.add_collection(LineCollection(segs, colors="tab:blue", linewidths=0.6, alpha=0.6, zorder=2))
    ax.plot(tree.nodes[:, 0], tree.nodes[:, 1], ".", color="tab:blue", markersize=2.0, zorder=2)


def _draw_path(ax: Axes, path: NDArray[np.float64], world: World) -> None:
    """The path (N, 3) as a thick line with about 40 heading ticks (2 % of the arena long)."""
    ax.plot(path[:, 0], path[:, 1], "-", color="tab:red", linewidth=2.2, zorder=4, label="path")
    sub = path[:: max(1, path.shape[0] // 40)]
    arrow = 0.02 * max(world.width, world.height)
    u, v = arrow * np.cos(sub[:, 2]), arrow * np.sin(sub[:, 2])
    ax.quiver(
        sub[:, 0], sub[:, 1], u, v, color="darkred", angles="xy", scale_units="xy", scale=1.0, width=0.0025, zorder=5
    )


def _draw_ends(ax: Axes, problem: PlanProblem) -> None:
    """Start and goal markers with heading arrows, and the goal tolerance circle."""
    s, g = problem.start, problem.goal
    ax.add_patch(CirclePatch((g.x, g.y), problem.position_tolerance, fill=False, edgecolor="tab:red", zorder=5))
    ax.plot([s.x], [s.y], "o", color="tab:green", markersize=9, zorder=6, label="start")
    ax.plot([g.x], [g.y], "*", color="tab:red", markersize=14, zorder=6, label="goal")
    for pose, color in ((s, "tab:green"), (g, "tab:red")):
        tip = (pose.x + 0.3 * np.cos(pose.theta), pose.y + 0.3 * np.sin(pose.theta))
        props = {"arrowstyle": "->", "color": color, "lw": 1.5}
        ax.annotate("", xy=tip, xytext=(pose.x, pose.y), arrowprops=props, zorder=6)


def _draw_timeline(fig: Figure, grid: GridSpec, result: PlanResult) -> None:
    """x, y; theta (and phi); v, omega of a timed plan against time, in the grid's right column."""
    assert result.times is not None
    t, path = result.times, result.path
    ax1 = fig.add_subplot(grid[0, 1])
    ax1.plot(t, path[:, 0], label="x [m]")
    ax1.plot(t, path[:, 1], label="y [m]")
    ax2 = fig.add_subplot(grid[1, 1], sharex=ax1)
    ax2.plot(t, path[:, 2], label="theta [rad]")
    if result.states is not None and result.states.shape[1] > 3:
        ax2.plot(t, result.states[:, 3], label="phi [rad]")
    ax3 = fig.add_subplot(grid[2, 1], sharex=ax1)
    if result.controls is not None:
        ax3.plot(t, result.controls[:, 0], label="v [m/s]")
        ax3.plot(t, result.controls[:, 1], label="omega [rad/s]")
    ax3.set_xlabel("t [s]")
    for a in (ax1, ax2, ax3):
        a.legend(fontsize=8)
        a.grid(True, alpha=0.3)
