"""Plan figures: the world, the search tree and the path, drawn as the seeds' figures are.

Obstacles are filled grey (walls as the frame), the tree is thin blue edges (each node joined to its
parent, or the planner's dense edge curves when it gives them), the path a thick red line with
heading ticks, start a green and goal a red marker with the goal tolerance circle. Built with
matplotlib's object API on the Agg canvas: no display, no global pyplot state.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Ellipse as EllipsePatch
from matplotlib.patches import Patch, Rectangle
from matplotlib.patches import Polygon as PolygonPatch

from planning.core.world import Box, Circle, Ellipse, Polygon, World
from planning.planners.base import PlanProblem, PlanResult
from sim.outputs import atomic_path


def _draw_world(ax: object, world: World) -> None:
    style = {"facecolor": "0.55", "edgecolor": "0.25", "linewidth": 0.8, "zorder": 1}
    for obs in world.obstacles:
        patch: Patch
        if isinstance(obs, Circle):
            patch = CirclePatch(obs.center, obs.radius, **style)
        elif isinstance(obs, Ellipse):
            patch = EllipsePatch(obs.center, 2 * obs.radii[0], 2 * obs.radii[1], angle=np.degrees(obs.angle), **style)
        elif isinstance(obs, Box):
            patch = PolygonPatch(obs.corners(), closed=True, **style)
        elif isinstance(obs, Polygon):
            patch = PolygonPatch(obs.array, closed=True, **style)
        else:  # pragma: no cover - every obstacle kind is drawn above
            raise TypeError(f"cannot draw obstacle {obs!r}")
        ax.add_patch(patch)  # type: ignore[attr-defined]
    xmin, xmax, ymin, ymax = world.bounds
    ax.add_patch(  # type: ignore[attr-defined]
        Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False, edgecolor="black", linewidth=2.0, zorder=1)
    )


def plan_figure(problem: PlanProblem, result: PlanResult, *, title: str | None = None) -> Figure:
    """A figure of a planning result.

    Args:
        problem: The problem planned (world, start, goal, tolerance).
        result: The planner's result (tree and path, either may be empty).
        title: Figure title; default names planner, status and scenario.

    Returns:
        The matplotlib figure (Agg canvas attached).
    """
    fig = Figure(figsize=(7.0, 7.0), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    world = problem.world
    _draw_world(ax, world)
    tree = result.tree
    if tree is not None and tree.nodes.shape[0] > 0:
        if tree.edges:
            segs = [np.asarray(e)[:, :2] for e in tree.edges]
        else:
            child = np.flatnonzero(tree.parents >= 0)
            segs = list(np.stack([tree.nodes[tree.parents[child], :2], tree.nodes[child, :2]], axis=1))
        ax.add_collection(LineCollection(segs, colors="tab:blue", linewidths=0.6, alpha=0.6, zorder=2))
        ax.plot(tree.nodes[:, 0], tree.nodes[:, 1], ".", color="tab:blue", markersize=2.0, zorder=2)
    path = result.path
    if path.shape[0] > 0:
        ax.plot(path[:, 0], path[:, 1], "-", color="tab:red", linewidth=2.2, zorder=4, label="path")
        step = max(1, path.shape[0] // 40)
        sub = path[::step]
        arrow = 0.02 * max(world.width, world.height)
        ax.quiver(sub[:, 0], sub[:, 1], arrow * np.cos(sub[:, 2]), arrow * np.sin(sub[:, 2]), color="darkred",
                  angles="xy", scale_units="xy", scale=1.0, width=0.0025, zorder=5)  # fmt: skip
    s, g = problem.start, problem.goal
    ax.add_patch(CirclePatch((g.x, g.y), problem.position_tolerance, fill=False, edgecolor="tab:red", zorder=5))
    ax.plot([s.x], [s.y], "o", color="tab:green", markersize=9, zorder=6, label="start")
    ax.plot([g.x], [g.y], "*", color="tab:red", markersize=14, zorder=6, label="goal")
    for pose, color in ((s, "tab:green"), (g, "tab:red")):
        tip = (pose.x + 0.3 * np.cos(pose.theta), pose.y + 0.3 * np.sin(pose.theta))
        props = {"arrowstyle": "->", "color": color, "lw": 1.5}
        ax.annotate("", xy=tip, xytext=(pose.x, pose.y), arrowprops=props, zorder=6)
    xmin, xmax, ymin, ymax = world.bounds
    pad = 0.03 * max(xmax - xmin, ymax - ymin)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, linewidth=0.3, alpha=0.5)
    ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
    length = result.length()
    ax.set_title(title or f"{result.planner} on {problem.name}: {result.status.value}, path {length:.2f} m")
    fig.tight_layout()
    return fig


def save_plan_figure(fig: Figure, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write a figure as PNG atomically (never replacing a file unless ``overwrite``)."""
    with atomic_path(path, overwrite=overwrite) as tmp:
        fig.savefig(tmp, format="png")
    return Path(path)
