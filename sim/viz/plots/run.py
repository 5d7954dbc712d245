"""Report plots of a simulate job (matplotlib, Agg backend): figures in, PNG files out.

Three figures, every run in its colour and line style from the video's table
(:data:`sim.viz.scene.RUN_STYLES`, :func:`sim.viz.scene.run_styles`):

- ``world``: the arena, its obstacles, the reference path and each run's path;
- ``errors``: position and heading error of each run against time;
- ``commands``: commanded v, omega and wheel speeds of each run against the robot's limits;

and, when the job's estimates are given, ``estimation`` (:mod:`sim.viz.plots.estimation`); for a
balancing robot, ``pitch``: its true pitch, the balance loop's estimate and its set-point.

Figures are built without pyplot on the Agg canvas (no display, no global state). The figure
builders return :class:`matplotlib.figure.Figure` objects and never touch the disk;
:func:`sim.viz.plots.draw.save_figure` writes one atomically (used by the CLI).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from planning.core.robot import RobotSpec
from planning.core.world import World
from planning.trajectory.trajectory import Trajectory
from sim.physics.metrics import heading_errors, position_errors
from sim.physics.model import body_pitch
from sim.physics.runlog import RunLog
from sim.viz.plots.draw import RUN_WORLD, draw_world, frame_world, tight
from sim.viz.plots.estimation import EstimationSeries, estimation_figure
from sim.viz.scene import run_styles

REFERENCE_COLOR = "#1a8c40"

#: Plot names (file suffixes) of every job, in the order they are written.
PLOTS = ("world", "errors", "commands")
#: Plot name of the estimates against the truth, written when the job gives its estimates.
ESTIMATION_PLOT = "estimation"
#: Plot name of a balancing robot's pitch, written when its runs logged their balance loop.
PITCH_PLOT = "pitch"
#: Plot name of the scan localiser's error against time with its 2-sigma band (runs on AMCL).
LOCALISER_PLOT = "localiser"


def _styles(logs: Mapping[str, RunLog]) -> dict[str, tuple[str, tuple[float, ...], str]]:
    """Run label -> (legend name, colour, line style) of every run of ``logs``."""
    return {label: (st.name, st.rgba, st.linestyle) for label, st in run_styles(logs).items()}


def world_figure(world: World, trajectory: Trajectory, logs: Mapping[str, RunLog], *, title: str = "") -> Figure:
    """The arena with obstacles, the reference path and each run's path (top view, equal axes).

    The axes frame the whole arena (its walls and every obstacle) and every path, whichever is larger,
    the legend beside them.

    Args:
        world: Bounds and obstacles.
        trajectory: The reference.
        logs: Run label -> log.
        title: Figure title.
    """
    fig = Figure(figsize=(8.6, 6.4), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    draw_world(ax, world, RUN_WORLD)
    ref = trajectory.pose
    ax.plot(ref[:, 0], ref[:, 1], color=REFERENCE_COLOR, lw=2.2, label="reference")
    styles = _styles(logs)
    for label, log in logs.items():
        name, color, ls = styles[label]
        ax.plot(log.pose[:, 0], log.pose[:, 1], color=color, ls=ls, lw=1.4, label=name)
        if log.status != "ok":  # where the run ended early (it fell, its estimator diverged)
            ended = f"{name} ended at t = {log.t[-1] - log.t[0]:.2f} s"
            ax.plot(*log.pose[-1, :2], "X", color=color, mec="k", mew=0.6, ms=9, ls="none", label=ended)
    ax.plot(*ref[0, :2], "o", color="k", ms=6, label="start")
    ax.plot(*ref[-1, :2], "*", color="k", ms=10, label="end of reference")
    frame_world(ax, world, [ref[:, :2]] + [log.pose[:, :2] for log in logs.values()])
    ax.grid(True, alpha=0.3)
    # the legend beside the arena, so it covers none of it
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=8)
    ax.set_title(title or "paths")
    tight(fig)
    return fig


def _finish(fig: Figure, ax: Any, labels: tuple[str, str], title: str, fontsize: int) -> Figure:
    """Label a one-axes figure (x, y), grid, legend and title it, and lay it out."""
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=fontsize)
    ax.set_title(title)
    tight(fig)
    return fig


def errors_figure(logs: Mapping[str, RunLog], *, title: str = "") -> Figure:
    """Position error [m] and wrapped heading error [rad] of each run against time [s]."""
    fig = Figure(figsize=(8.0, 5.6), dpi=110)
    FigureCanvasAgg(fig)
    ax_p, ax_h = fig.subplots(2, 1, sharex=True)
    styles = _styles(logs)
    for label, log in logs.items():
        name, color, ls = styles[label]
        ax_p.plot(log.t, position_errors(log), color=color, ls=ls, label=name)
        ax_h.plot(log.t, heading_errors(log), color=color, ls=ls, label=name)
    ax_p.set_ylabel("position error [m]")
    ax_h.set_ylabel("heading error [rad]")
    ax_h.set_xlabel("time [s]")
    for ax in (ax_p, ax_h):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    ax_p.set_title(title or "tracking errors")
    tight(fig)
    return fig


def commands_figure(logs: Mapping[str, RunLog], robot: RobotSpec, *, title: str = "") -> Figure:
    """Commanded v [m/s], omega [rad/s] and wheel speeds [rad/s] of each run against their limits.

    Wheel speeds show the command (solid or dashed per run) and the measured speed (thin).
    """
    fig = Figure(figsize=(8.0, 8.0), dpi=110)
    FigureCanvasAgg(fig)
    ax_v, ax_w, ax_wh = fig.subplots(3, 1, sharex=True)
    styles = _styles(logs)
    for label, log in logs.items():
        name, color, ls = styles[label]
        ax_v.step(log.t, log.command[:, 0], where="post", color=color, ls=ls, label=name)
        ax_w.step(log.t, log.command[:, 1], where="post", color=color, ls=ls, label=name)
        wheel = {"where": "post", "color": color, "ls": ls}
        ax_wh.step(log.t, log.wheel_command[:, 0], label=f"{name} left cmd", **wheel)
        ax_wh.step(log.t, log.wheel_command[:, 1], alpha=0.55, label=f"{name} right cmd", **wheel)
        ax_wh.plot(log.t, log.wheel_speed[:, 0], color=color, lw=0.6, alpha=0.8)
        ax_wh.plot(log.t, log.wheel_speed[:, 1], color=color, lw=0.6, alpha=0.5)
    limits = (
        (ax_v, robot.max_speed, "v [m/s]"),
        (ax_w, robot.max_yaw_rate, "ω [rad/s]"),
        (ax_wh, robot.max_wheel_speed, "wheel speed [rad/s]"),
    )
    for ax, lim, ylabel in limits:
        ax.axhline(lim, color="#c0392b", lw=1.0, ls=":", label="limit")
        ax.axhline(-lim, color="#c0392b", lw=1.0, ls=":")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=7)
    ax_wh.set_xlabel("time [s]")
    ax_v.set_title(title or "commands against limits")
    tight(fig)
    return fig


def pitch_figure(logs: Mapping[str, RunLog], *, title: str = "") -> Figure | None:
    """A balancing robot's pitch [rad] against time [s]: the truth (from the base's orientation), the
    balance loop's estimate (thin) and its set-point (dotted), one colour per run; None when no run
    logged a balance loop."""
    runs = {label: log for label, log in logs.items() if log.balance is not None}
    if not runs:
        return None
    fig = Figure(figsize=(8.0, 4.2), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    styles = _styles(runs)
    for label, log in runs.items():
        name, color, ls = styles[label]
        bal = log.balance
        assert bal is not None
        ax.plot(log.t, body_pitch(log.qpos[:, 3:7]), color=color, ls=ls, label=f"{name} pitch")
        ax.plot(bal.t, bal.pitch_estimate, color=color, lw=0.6, alpha=0.7, label=f"{name} estimate")
        ax.plot(bal.t, bal.pitch_setpoint, color=color, lw=0.8, ls=":", label=f"{name} set-point")
        if bal.fell_at is not None:
            ax.axvline(bal.fell_at, color="#c0392b", lw=1.0, label=f"{name} fell")
    return _finish(fig, ax, ("time [s]", "pitch [rad]"), title or "pitch and its set-point", 7)


def job_figures(
    world: World,
    robot: RobotSpec,
    trajectory: Trajectory,
    logs: Mapping[str, RunLog],
    *,
    title: str = "",
    estimation: EstimationSeries | None = None,
) -> dict[str, Figure]:
    """Every report figure of a job, by name: :data:`PLOTS`, then :data:`ESTIMATION_PLOT` when
    ``estimation`` (the estimates against the truth) is given, :data:`PITCH_PLOT` for a balancing
    robot and :data:`LOCALISER_PLOT` for a run fed by a scan localiser."""
    figs = {
        "world": world_figure(world, trajectory, logs, title=title),
        "errors": errors_figure(logs, title=title),
        "commands": commands_figure(logs, robot, title=title),
    }
    if estimation is not None:
        figs[ESTIMATION_PLOT] = estimation.figure(title=title)
    pitch = pitch_figure(logs, title=title)
    if pitch is not None:
        figs[PITCH_PLOT] = pitch
    for log in logs.values():
        loc = log.estimation.localiser if log.estimation is not None else None
        if loc is not None and loc.t.size >= 2:  # the first run fed by a scan localiser
            heading = np.column_stack([loc.truth[:, :2], np.unwrap(loc.truth[:, 2])])
            what = title or "scan localiser (AMCL) against the true pose"
            figs[LOCALISER_PLOT] = estimation_figure(
                loc.t, heading, {"localiser": loc.pose}, cov={"localiser": loc.cov}, title=what
            )
            break
    return figs
