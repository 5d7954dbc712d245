"""Plots of a Monte Carlo study: every run's path over the world (a fan per run kind), and the CDF of
the final position error per run kind. Figures in, never the disk (see :mod:`sim.viz.plots.run`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from planning.core.world import World
from planning.trajectory.trajectory import Trajectory
from sim.viz.plots.draw import RUN_WORLD, draw_world, tight
from sim.viz.plots.run import REFERENCE_COLOR
from sim.viz.scene import run_styles

#: Plot names (file suffixes) of a study.
MONTECARLO_PLOTS = ("fan", "cdf")


def _kinds(records: Sequence[Mapping[str, Any]]) -> list[str]:
    return list(dict.fromkeys(k for r in records for k in r.get("runs", {})))


def fan_figure(
    world: World, trajectory: Trajectory, records: Sequence[Mapping[str, Any]], *, title: str = ""
) -> Figure:
    """One panel per run kind: the world, the reference and every run's path (thin, translucent)."""
    kinds = _kinds(records)
    styles = run_styles(kinds)
    fig = Figure(figsize=(5.2 * max(len(kinds), 1), 5.4), dpi=100)
    FigureCanvasAgg(fig)
    ref = trajectory.pose
    xmin, xmax, ymin, ymax = world.bounds
    alpha = float(np.clip(6.0 / max(len(records), 1), 0.05, 0.6))
    for i, kind in enumerate(kinds):
        ax = fig.add_subplot(1, len(kinds), i + 1)
        draw_world(ax, world, RUN_WORLD)
        style = styles[kind]
        for rec in records:
            entry = rec.get("runs", {}).get(kind)
            if entry is None:
                continue
            path = np.asarray(entry["path"], dtype=float)
            ax.plot(path[:, 0], path[:, 1], color=style.rgba[:3], alpha=alpha, lw=0.8)
        ax.plot(ref[:, 0], ref[:, 1], color=REFERENCE_COLOR, lw=1.6, ls="--", label="reference")
        ax.plot(*ref[-1, :2], "*", color="k", ms=9)
        ax.set_xlim(xmin - 0.1, xmax + 0.1)
        ax.set_ylim(ymin - 0.1, ymax + 0.1)
        ax.set_aspect("equal")
        ax.set_title(f"{style.name} ({len(records)} runs)", fontsize=10)
        ax.set_xlabel("x [m]")
        if i == 0:
            ax.set_ylabel("y [m]")
        ax.grid(True, alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=11)
    tight(fig)
    return fig


def cdf_figure(records: Sequence[Mapping[str, Any]], *, title: str = "") -> Figure:
    """The empirical CDF of the final position error of each run kind (log x axis)."""
    fig = Figure(figsize=(7.0, 4.4), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    kinds = _kinds(records)
    for kind, style in run_styles(kinds).items():
        values = np.sort([r["runs"][kind]["final_position_error_m"] for r in records if kind in r.get("runs", {})])
        if not len(values):
            continue
        frac = np.arange(1, len(values) + 1) / len(values)
        ax.step(np.maximum(values, 1e-5), frac, where="post", color=style.rgba, ls=style.linestyle, label=style.name)
    ax.set_xscale("log")
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("final position error [m]")
    ax.set_ylabel("fraction of runs")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(title or "final position error, CDF")
    tight(fig)
    return fig


def montecarlo_figures(
    world: World, trajectory: Trajectory, records: Sequence[Mapping[str, Any]], *, title: str = ""
) -> dict[str, Figure]:
    """Plot name (:data:`MONTECARLO_PLOTS`) -> figure."""
    return {"fan": fan_figure(world, trajectory, records, title=title), "cdf": cdf_figure(records, title=title)}
