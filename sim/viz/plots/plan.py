"""Plots of a planned path: the x-y path with headings over the world, and states and inputs in time.

The figures follow the layout of the sinusoidal and optimisation planners' usual plots: one panel
with the path, heading arrows, obstacles (inflated outline by the robot's radius dashed) and the
start and goal, and a column of panels with x, y, theta, phi and the inputs v, omega against time.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from planning.core.world import Box, Circle, Ellipse, Polygon, World
from planning.planners.base import PlanProblem, PlanResult
from sim.outputs import atomic_path

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def _draw_world(ax: Axes, world: World) -> None:
    xmin, xmax, ymin, ymax = world.bounds
    ax.plot([xmin, xmax, xmax, xmin, xmin], [ymin, ymin, ymax, ymax, ymin], color="k", lw=1.5)
    for ob in world.obstacles:
        style = {"facecolor": "0.6", "edgecolor": "0.2"}
        if isinstance(ob, Circle):
            ax.add_patch(matplotlib.patches.Circle(ob.center, ob.radius, **style))
        elif isinstance(ob, Ellipse):
            ax.add_patch(
                matplotlib.patches.Ellipse(
                    ob.center, 2 * ob.radii[0], 2 * ob.radii[1], angle=np.degrees(ob.angle), **style
                )
            )
        elif isinstance(ob, Box):
            ax.add_patch(matplotlib.patches.Polygon(ob.corners(), closed=True, **style))
        elif isinstance(ob, Polygon):
            ax.add_patch(matplotlib.patches.Polygon(ob.array, closed=True, **style))


def plan_figure(problem: PlanProblem, result: PlanResult, *, arrows: int = 25, title: str | None = None) -> Figure:
    """A figure of a plan: x-y path with heading arrows, and states / inputs against time.

    Args:
        problem: The problem that was planned (world, robot, start, goal).
        result: The planner's result (path (N, 3); times, controls, states when the planner timed the path).
        arrows: Number of heading arrows along the path.
        title: Figure title (default: planner, scenario and status).

    Returns:
        The matplotlib figure (close it with ``plt.close(fig)``).
    """
    timed = result.times is not None and result.path.shape[0] > 1
    fig = plt.figure(figsize=(12, 6) if timed else (6, 6), layout="constrained")
    grid = fig.add_gridspec(3, 2, width_ratios=[1.2, 1]) if timed else fig.add_gridspec(1, 1)
    ax = fig.add_subplot(grid[:, 0])
    _draw_world(ax, problem.world)
    path = result.path
    if path.shape[0]:
        ax.plot(path[:, 0], path[:, 1], color="tab:blue", lw=1.5, label="path")
        idx = np.unique(np.linspace(0, path.shape[0] - 1, max(2, arrows)).round().astype(int))
        span = max(problem.world.width, problem.world.height)
        ax.quiver(
            path[idx, 0], path[idx, 1], np.cos(path[idx, 2]), np.sin(path[idx, 2]), color="tab:blue",
            angles="xy", scale_units="xy", scale=1.0 / (0.04 * span), width=0.004,
        )  # fmt: skip
        r = problem.robot.radius
        ang = np.linspace(0, 2 * np.pi, 60)
        for pose, color in ((path[0], "tab:green"), (path[-1], "tab:red")):
            ax.plot(pose[0] + r * np.cos(ang), pose[1] + r * np.sin(ang), color=color, lw=0.8)
    for pose, color, label in ((problem.start, "tab:green", "start"), (problem.goal, "tab:red", "goal")):
        ax.plot(pose.x, pose.y, "o", color=color, label=label)
        ax.arrow(pose.x, pose.y, 0.08 * np.cos(pose.theta), 0.08 * np.sin(pose.theta), color=color, width=0.004)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or f"{result.planner} on {problem.name}: {result.status.value}")
    if timed:
        assert result.times is not None
        t = result.times
        ax1 = fig.add_subplot(grid[0, 1])
        ax1.plot(t, path[:, 0], label="x [m]")
        ax1.plot(t, path[:, 1], label="y [m]")
        ax1.legend(fontsize=8)
        ax2 = fig.add_subplot(grid[1, 1], sharex=ax1)
        ax2.plot(t, path[:, 2], label="theta [rad]")
        if result.states is not None and result.states.shape[1] > 3:
            ax2.plot(t, result.states[:, 3], label="phi [rad]")
        ax2.legend(fontsize=8)
        ax3 = fig.add_subplot(grid[2, 1], sharex=ax1)
        if result.controls is not None:
            ax3.plot(t, result.controls[:, 0], label="v [m/s]")
            ax3.plot(t, result.controls[:, 1], label="omega [rad/s]")
        ax3.set_xlabel("t [s]")
        ax3.legend(fontsize=8)
        for a in (ax1, ax2, ax3):
            a.grid(True, alpha=0.3)
    return fig


def write_plan_figure(
    path: str | Path, problem: PlanProblem, result: PlanResult, *, overwrite: bool = False, dpi: int = 110
) -> Path:
    """Draw :func:`plan_figure` and write it as a PNG atomically.

    Args:
        path: Target file (.png).
        problem: The planned problem.
        result: The plan.
        overwrite: Replace an existing file.
        dpi: Resolution.

    Returns:
        The written path.
    """
    fig = plan_figure(problem, result)
    try:
        with atomic_path(path, overwrite=overwrite) as tmp:
            fig.savefig(tmp, dpi=dpi, format="png")
    finally:
        plt.close(fig)
    return Path(path)
