"""Report plots: the right content on each axis, non-trivial PNGs, written atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from planning.core.world import Box, Circle, Ellipse, Polygon, World
from planning.errors import OutputExistsError
from sim.viz.plots.draw import save_figure
from sim.viz.plots.run import PLOTS, commands_figure, errors_figure, job_figures, world_figure
from tests.render_helpers import short_job


def png_is_nontrivial(path: Path) -> None:
    img = np.asarray(Image.open(path).convert("RGB"))
    assert img.shape[0] > 300 and img.shape[1] > 300
    assert img.std() > 10.0
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 50


def test_job_figures_write_nontrivial_pngs(tmp_path: Path) -> None:
    job = short_job()
    figs = job_figures(job.scenario.world, job.robot, job.trajectory, job.logs, title="t")
    assert tuple(figs) == PLOTS
    for name, fig in figs.items():
        out = save_figure(fig, tmp_path / f"{name}.png")
        png_is_nontrivial(out)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"{n}.png" for n in PLOTS)


def test_world_figure_draws_every_obstacle_and_path() -> None:
    job = short_job()
    world = World(
        (-3.0, 3.0, -3.0, 3.0),
        (Circle((1.0, 1.0), 0.2), Box((-1.0, 1.0), (0.4, 0.2), 0.3), Ellipse((1.0, -1.0), (0.3, 0.1), 0.5),
         Polygon(((-1.0, -1.0), (-0.6, -1.0), (-0.8, -0.6)))),
    )  # fmt: skip
    ax = world_figure(world, job.trajectory, job.logs).axes[0]
    assert len(ax.patches) == 1 + 4  # arena outline + obstacles
    labels = [line.get_label() for line in ax.lines]
    assert {"reference", "closed loop", "open loop"} <= set(labels)
    ref = next(line for line in ax.lines if line.get_label() == "reference")
    np.testing.assert_array_equal(ref.get_xdata(), job.trajectory.pose[:, 0])


def test_errors_figure_plots_the_errors() -> None:
    job = short_job()
    ax_p, ax_h = errors_figure(job.logs).axes
    log = job.logs["open_loop"]
    line = next(ln for ln in ax_p.lines if ln.get_label() == "open loop")
    expect = np.hypot(*(log.pose[:, :2] - log.ref_pose[:, :2]).T)
    np.testing.assert_allclose(line.get_ydata(), expect, rtol=0, atol=1e-15)
    assert len(ax_h.lines) == 2


def test_commands_figure_shows_limits() -> None:
    job = short_job()
    r = job.robot
    axes = commands_figure(job.logs, r).axes
    for ax, lim in zip(axes, (r.max_speed, r.max_yaw_rate, r.max_wheel_speed), strict=True):
        ys = sorted({float(ln.get_ydata()[0]) for ln in ax.lines if ln.get_linestyle() == ":"})
        assert ys == pytest.approx([-lim, lim])


def test_save_figure_never_overwrites(tmp_path: Path) -> None:
    job = short_job()
    out = tmp_path / "e.png"
    out.write_bytes(b"x")
    with pytest.raises(OutputExistsError):
        save_figure(errors_figure(job.logs), out)
    assert out.read_bytes() == b"x"
    save_figure(errors_figure(job.logs), out, overwrite=True)
    png_is_nontrivial(out)
