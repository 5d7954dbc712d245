"""Report plots: the right content on each axis, non-trivial PNGs, written atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgba
from PIL import Image

from planning.core.geometry import wrap_angle
from planning.core.world import Box, Circle, Ellipse, Polygon, World
from planning.errors import ConfigError, OutputExistsError
from sim.physics.metrics import heading_errors, position_errors
from sim.viz.plots.draw import save_figure
from sim.viz.plots.estimation import EstimationSeries, estimation_figure
from sim.viz.plots.run import (
    ESTIMATION_PLOT,
    LOCALISER_PLOT,
    PLOTS,
    commands_figure,
    errors_figure,
    job_figures,
    world_figure,
)
from sim.viz.scene import FALLBACK_RGBA, RUN_STYLES, run_styles
from tests.render_helpers import short_job, spread_runs


def png_is_nontrivial(path: Path) -> None:
    img = np.asarray(Image.open(path).convert("RGB"))
    assert img.shape[0] > 300 and img.shape[1] > 300
    assert img.std() > 10.0
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 50


def test_job_figures_write_nontrivial_pngs(tmp_path: Path) -> None:
    job = short_job("amcl")
    figs = job_figures(job.scenario.world, job.robot, job.trajectory, job.logs, title="t")
    want = (*PLOTS, LOCALISER_PLOT)  # the TurtleBot3's closed loop runs on its scan localiser
    assert tuple(figs) == want
    for name, fig in figs.items():
        out = save_figure(fig, tmp_path / f"{name}.png")
        png_is_nontrivial(out)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"{n}.png" for n in want)


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


@pytest.mark.parametrize("name", ["parking_lot", "farm"])
def test_world_figure_frames_the_whole_arena(name: str) -> None:
    """Every obstacle's outline and the walls lie inside the axes, though the runs visit a corner only;
    the legend sits outside the axes."""
    from planning.scenario import load_scenario

    job = short_job()  # a 0.4 m line from the origin
    world = load_scenario(name).world
    fig = world_figure(world, job.trajectory, job.logs)
    ax = fig.axes[0]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    obstacles = [p for p in ax.patches[1:]]
    assert len(obstacles) == len(world.obstacles) > 10
    for patch in ax.patches:  # the walls' outline, then each obstacle's
        xy = patch.get_path().transformed(patch.get_patch_transform()).vertices
        assert np.all((xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)), patch
    bx0, bx1, by0, by1 = world.bounds
    assert x1 - x0 <= 1.1 * max(bx1 - bx0, by1 - by0)  # framed, not lost in a margin
    fig.canvas.draw()
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1  # beside the axes, over nothing


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


def test_world_and_error_figures_draw_every_run_in_its_colour() -> None:
    from sim.physics.simulator import Simulator

    job = short_job()
    logs = spread_runs(Simulator(job.robot, job.scenario.world).model)
    styles = run_styles(logs)
    ax_world = world_figure(job.scenario.world, job.trajectory, logs).axes[0]
    ax_p, ax_h = errors_figure(logs).axes
    for label, log in logs.items():
        st = styles[label]
        for ax, y in ((ax_world, log.pose[:, 1]), (ax_p, position_errors(log)), (ax_h, heading_errors(log))):
            line = next(ln for ln in ax.lines if ln.get_label() == st.name)
            assert to_rgba(line.get_color()) == pytest.approx(st.rgba)
            assert line.get_linestyle() == st.linestyle
            np.testing.assert_array_equal(line.get_ydata(), y)
    assert styles["closed_loop_odometry"].rgba == RUN_STYLES["closed_loop_odometry"].rgba
    assert styles["wobbly"].rgba == FALLBACK_RGBA[0]
    assert len({styles[k].rgba for k in logs}) == 4


# ---- estimation ---------------------------------------------------------------------------------

T = np.linspace(0.0, 10.0, 101)
#: A truth linear in time between samples (interpolation is exact); the heading wraps at t = pi / 0.7.
TRUTH = np.column_stack([0.2 * T, -0.1 * T, wrap_angle(0.7 * T)])


def _estimation() -> EstimationSeries:
    cl = TRUTH + np.column_stack([0.1 * np.sin(T), np.full_like(T, -0.05), np.full_like(T, 0.02)])
    cl[:, 2] = wrap_angle(cl[:, 2])  # across the wrap the stored heading jumps, its error does not
    odo = TRUTH + np.column_stack([0.01 * T, 0.02 * T, -0.003 * T])
    sig = np.column_stack([0.05 + 0.01 * T, 0.04 + 0.0 * T, 0.01 + 0.002 * T])
    cov = np.zeros((T.size, 3, 3))
    cov[:, [0, 1, 2], [0, 1, 2]] = sig**2
    cov[:, 0, 1] = cov[:, 1, 0] = 0.3 * sig[:, 0] * sig[:, 1]  # correlations do not change the bands
    tf = np.array([0.55, 3.3, 4.45, 7.05])  # 4.45 s: between samples either side of the wrap
    offsets = np.array([[0.03, -0.04, 0.1], [-0.02, 0.01, -0.05], [0.0, 0.02, 0.08], [0.05, 0.0, -0.1]])
    z = np.column_stack([0.2 * tf, -0.1 * tf, wrap_angle(0.7 * tf + offsets[:, 2])])
    z[:, :2] += offsets[:, :2]
    return EstimationSeries(
        T,
        TRUTH,
        {"closed_loop": cl, "closed_loop_odometry": odo},
        fixes={"closed_loop": (tf, z)},
        cov={"closed_loop": cov},
    )


def test_estimation_figure_draws_errors_bands_and_fixes() -> None:
    est = _estimation()
    axes = est.figure(title="e").axes
    assert len(axes) == 3
    expect = {
        "closed loop": np.column_stack([0.1 * np.sin(T), np.full_like(T, -0.05), np.full_like(T, 0.02)]),
        "odometry feedback": np.column_stack([0.01 * T, 0.02 * T, -0.003 * T]),
    }
    sig = np.column_stack([0.05 + 0.01 * T, 0.04 + 0.0 * T, 0.01 + 0.002 * T])
    fix_err = np.array([[0.03, -0.04, 0.1], [-0.02, 0.01, -0.05], [0.0, 0.02, 0.08], [0.05, 0.0, -0.1]])
    for i, ax in enumerate(axes):
        for name, err in expect.items():
            line = next(ln for ln in ax.lines if ln.get_label() == name)
            np.testing.assert_array_equal(line.get_xdata(), T)
            np.testing.assert_allclose(line.get_ydata(), err[:, i], rtol=0, atol=1e-12)
        dots = next(ln for ln in ax.lines if ln.get_label() == "closed loop fixes")
        assert dots.get_marker() == "o" and dots.get_linestyle() == "None"
        np.testing.assert_allclose(dots.get_ydata(), fix_err[:, i], rtol=0, atol=1e-12)
        assert to_rgba(dots.get_color()) == pytest.approx(RUN_STYLES["closed_loop"].rgba)
        # one band, the closed loop's: +-2 sigma of this coordinate at every time
        (band,) = [c for c in ax.collections if c.get_label() == "closed loop ±2σ"]
        assert len(ax.collections) == 1
        verts = band.get_paths()[0].vertices
        for sign in (1.0, -1.0):
            pts = np.column_stack([T, sign * 2.0 * sig[:, i]])
            dist = np.abs(verts[None, :, :] - pts[:, None, :]).max(axis=2).min(axis=1)
            assert dist.max() < 1e-12
        assert np.abs(verts[:, 1]).max() == pytest.approx(2.0 * sig[:, i].max())
    odo = next(ln for ln in axes[0].lines if ln.get_label() == "odometry feedback")
    assert to_rgba(odo.get_color()) == pytest.approx(RUN_STYLES["closed_loop_odometry"].rgba)


def test_estimation_figure_names_bad_input() -> None:
    est = _estimation()
    good = est.estimates["closed_loop"]
    cov = est.cov["closed_loop"] if est.cov else None
    with pytest.raises(ConfigError, match=r"estimates\['closed_loop'\] has shape \(101, 2\), expected \(101, 3\)"):
        estimation_figure(T, TRUTH, {"closed_loop": good[:, :2]})
    with pytest.raises(ConfigError, match=r"truth has shape"):
        estimation_figure(T, TRUTH[1:], {"closed_loop": good})
    with pytest.raises(ConfigError, match="t must be non-empty and strictly increasing"):
        estimation_figure(T[::-1], TRUTH, {"closed_loop": good})
    with pytest.raises(ConfigError, match="NaN"):
        estimation_figure(T, TRUTH, {"closed_loop": np.where(T[:, None] > 5, np.nan, good)})
    with pytest.raises(ConfigError, match=r"cov\['open_loop'\] has no estimate"):
        estimation_figure(T, TRUTH, {"closed_loop": good}, cov={"open_loop": cov})
    with pytest.raises(ConfigError, match="negative variance"):
        estimation_figure(T, TRUTH, {"closed_loop": good}, cov={"closed_loop": -np.asarray(cov)})
    with pytest.raises(ConfigError, match=r"fixes\['closed_loop'\] span \[9, 11\] s reaches outside"):
        estimation_figure(T, TRUTH, {"closed_loop": good}, fixes={"closed_loop": (np.array([9.0, 11.0]), TRUTH[:2])})
    with pytest.raises(ConfigError, match="must be a pair"):
        estimation_figure(T, TRUTH, {"closed_loop": good}, fixes={"closed_loop": T})  # type: ignore[dict-item]


def test_job_figures_add_the_estimation_figure_when_given(tmp_path: Path) -> None:
    job = short_job("amcl")
    figs = job_figures(job.scenario.world, job.robot, job.trajectory, job.logs, estimation=_estimation())
    assert tuple(figs) == (*PLOTS, ESTIMATION_PLOT, LOCALISER_PLOT)
    png_is_nontrivial(save_figure(figs[ESTIMATION_PLOT], tmp_path / "estimation.png"))


@pytest.mark.parametrize("bounds", [(0.0, 5.0, 0.0, 4.0), (0.0, 12.0, 0.0, 2.0), (0.0, 2.0, 0.0, 9.0)])
def test_a_saved_world_plot_cuts_nothing_at_its_edges(tmp_path: Path, bounds: tuple[float, ...]) -> None:
    """parking_lot's 5 x 4 m world: the y label was cut at the left edge and the legend at the right ("odometry
    feedbac"), the fixed figure size, the equal axes and the legend beside them not fitting together."""
    job = short_job()
    world = World(bounds, (Circle((1.0, 1.0), 0.2),))  # type: ignore[arg-type]
    out = save_figure(world_figure(world, job.trajectory, job.logs, title="a world"), tmp_path / "w.png")
    img = np.asarray(Image.open(out).convert("L"))
    edges = np.concatenate([img[0], img[-1], img[:, 0], img[:, -1]])
    assert edges.min() > 240  # white all round: every label, the legend and the title inside the image


def test_a_name_the_font_lacks_is_drawn_without_a_warning_per_glyph(tmp_path: Path) -> None:
    """A scenario named in characters DejaVu Sans lacks (CJK): the plan figure is laid out and saved (a box per
    missing glyph) without matplotlib's warning per glyph on stderr, which a user saw six lines of."""
    import dataclasses
    import warnings

    from planning.planners.base import PlanProblem
    from planning.planners.registry import make_planner
    from planning.scenario import load_scenario
    from sim.viz.plots.plan import plan_figure

    scenario = dataclasses.replace(load_scenario("simple_motion"), name="停车场 \U00018089")
    problem = PlanProblem.from_scenario(scenario)
    result = make_planner("birrt").plan(problem)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        save_figure(plan_figure(problem, result), tmp_path / "plan.png")
    assert not [w for w in seen if "missing from font" in str(w.message)], [str(w.message) for w in seen]
    png_is_nontrivial(tmp_path / "plan.png")


def test_an_eps_figure_is_written_without_the_postscript_backends_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """``nhsim plan --plot x.eps`` printed matplotlib's "The PostScript backend does not support transparency" on
    stderr: the figures' translucent bands are drawn opaque there, as PostScript has no transparency."""
    import logging

    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.fill_between([0, 1], [0, 1], alpha=0.3)
    with caplog.at_level(logging.WARNING, logger="matplotlib"):
        out = save_figure(fig, tmp_path / "x.eps")
    plt.close(fig)
    assert out.read_bytes().startswith(b"%!PS") and not [r for r in caplog.records if "PostScript" in r.message]
    assert logging.getLogger("matplotlib.backends.backend_ps").level == logging.NOTSET  # given back
