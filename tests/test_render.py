"""Replay rendering: frame timing, projection, ghost, one renderer per process, GL errors."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from planning.errors import ConfigError, DependencyError
from sim.physics.runlog import RunLog
from sim.viz import gl
from sim.viz.renderer import SceneRenderer
from sim.viz.replay import (
    ListSink,
    RenderSettings,
    Replay,
    decimate_path,
    frame_times,
    nearest_samples,
    parse_size,
    render_frames,
)
from sim.viz.scene import (
    FALLBACK_RGBA,
    GHOST_ALPHA,
    RUN_STYLES,
    Projection,
    geom_box_corners,
    ghost_rgb,
    light_gain,
    rgb255,
    run_styles,
)
from tests.render_helpers import require_gl, short_job, spread_runs

# ---- pure numerics ------------------------------------------------------------------------------


def test_frame_times_follow_simulation_time() -> None:
    t = frame_times(0.0, 20.0, 30.0)
    assert t.size == 601  # a 20 s run at 30 frames/s, and its end
    np.testing.assert_allclose(np.diff(t), 1 / 30, rtol=0, atol=1e-12)
    assert t[0] == 0.0 and t[-1] == 20.0  # the last frame shows the end (it showed 20 - 1/30 s)
    assert frame_times(2.5, 2.5, 30.0).tolist() == [2.5]
    odd = frame_times(1.0, 4.32, 10.0)
    assert odd.size == 34 and odd[-1] == 4.32 and np.all(np.diff(odd) > 0)


def test_nearest_samples_matches_brute_force() -> None:
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.01, 0.05, 200))
    q = rng.uniform(t[0] - 1, t[-1] + 1, 500)
    brute = np.abs(q[:, None] - t[None, :]).argmin(axis=1)
    got = nearest_samples(t, q)
    # ties may go either way: compare the distances, exactly
    np.testing.assert_array_equal(np.abs(t[got] - q), np.abs(t[brute] - q))


def test_decimate_path_spacing_and_ends() -> None:
    s = np.linspace(0, 2 * np.pi, 3000)
    xy = np.column_stack([np.cos(s), np.sin(s)])
    keep = decimate_path(xy, 0.05)
    assert keep[0] == 0 and keep[-1] == len(xy) - 1
    gaps = np.hypot(*np.diff(xy[keep], axis=0).T)
    assert np.all(gaps[:-1] >= 0.05)
    assert np.all(gaps <= 0.05 + 2 * np.hypot(*(xy[1] - xy[0])))  # never skips more than needed
    assert abs(len(keep) - 2 * np.pi / 0.05) < 3


def test_parse_size_and_settings() -> None:
    assert parse_size("640x480") == (640, 480)
    assert parse_size("320X240") == (320, 240)
    for bad in ("640", "640x", "axb", "1x2x3"):
        with pytest.raises(ConfigError, match="WIDTHxHEIGHT"):
            parse_size(bad)
    with pytest.raises(ConfigError, match="even"):
        RenderSettings(width=641)
    with pytest.raises(ConfigError, match="fps"):
        RenderSettings(fps=0.0)
    with pytest.raises(ConfigError, match="camera"):
        RenderSettings(camera="drone")
    with pytest.raises(ConfigError, match="quality"):
        RenderSettings(quality="ultra")


# ---- GL backend choice --------------------------------------------------------------------------


def test_configure_rejects_unknown_backend() -> None:
    with pytest.raises(ConfigError, match="osmesa, egl, glfw"):
        gl.configure("vulkan")


def test_missing_library_names_the_package(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(gl.ctypes.util, "find_library", lambda name: None)
    with pytest.raises(DependencyError, match="apt-get install libosmesa6"):
        gl.configure("osmesa")
    with pytest.raises(DependencyError, match="apt-get install libegl1"):
        gl.configure("egl")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(gl.sys, "platform", "linux")
    assert gl.default_backend() == gl.DISABLED


def test_no_backend_is_one_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    import mujoco

    monkeypatch.setattr(gl, "loaded_backend", lambda: gl.DISABLED)
    monkeypatch.setattr(gl, "default_backend", lambda: gl.DISABLED)
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(DependencyError, match="apt-get install libosmesa6") as err:
        SceneRenderer(m, 16, 16)
    assert "--no-video (no write_video call from Python)" in str(err.value)
    assert SceneRenderer._open == 0


def test_mujoco_imported_with_an_unusable_backend(monkeypatch: pytest.MonkeyPatch) -> None:
    """GLFW by default without a display draws headless; asked for by name, or disabled: one error."""
    monkeypatch.setattr(gl, "loaded_backend", lambda: "glfw")
    monkeypatch.setattr(gl, "display_available", lambda: False)
    monkeypatch.setattr(gl, "osmesa_available", lambda: True)
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    assert gl.render_backend() == gl.current_backend() == "osmesa"
    monkeypatch.setattr(gl, "osmesa_available", lambda: False)
    monkeypatch.setattr(gl, "egl_available", lambda: True)
    assert gl.render_backend() == "egl"
    monkeypatch.setenv("MUJOCO_GL", "glfw")  # asked for by name: not replaced
    with pytest.raises(DependencyError, match=r"no display.*MUJOCO_GL=osmesa"):
        gl.render_backend()
    monkeypatch.setattr(gl, "loaded_backend", lambda: gl.DISABLED)
    monkeypatch.setenv("MUJOCO_GL", "disable")
    with pytest.raises(DependencyError, match=r"MUJOCO_GL=disable \(rendering disabled\); set MUJOCO_GL=osmesa"):
        gl.render_backend()
    monkeypatch.setattr(gl, "loaded_backend", lambda: "osmesa")
    assert gl.render_backend() == "osmesa"


#: Run in a fresh interpreter without MUJOCO_GL or a display, as a notebook would.
NOTEBOOK = """
import os, sys
import sim, sim.viz, sim.viz.gl, sim.cli.main
assert "MUJOCO_GL" not in os.environ and "mujoco" not in sys.modules, "importing sim had a side effect"
import sim.physics.simulator  # imports mujoco, which picks GLFW
import mujoco
from planning.errors import DependencyError
from sim.physics.runlog import RunLog
from sim.viz import gl
from sim.viz.renderer import SceneRenderer
xml = '<mujoco><worldbody><light pos="0 0 3"/><geom type="box" size=".2 .2 .2" rgba="1 0 0 1"/></worldbody></mujoco>'
m = mujoco.MjModel.from_xml_string(xml)
d = mujoco.MjData(m)
mujoco.mj_forward(m, d)
try:
    with SceneRenderer(m, 64, 64) as r:
        r.renderer.update_scene(d)
        img = r.render()
    print(r.backend, gl.loaded_backend(), *img[32, 32])
except DependencyError as exc:
    print("error", exc)
"""


def test_import_has_no_side_effect_and_renders_by_default() -> None:
    env = {
        k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")
    }
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1])
    out = subprocess.run([sys.executable, "-c", NOTEBOOK], env=env, capture_output=True, text=True, check=True)
    words = out.stdout.split()
    if sys.platform.startswith("linux") and gl.default_backend() != gl.DISABLED:
        # the headless default drew the red box lit from above; mujoco's own choice is left as it was
        assert words[:2] == [gl.default_backend(), "glfw"], out.stdout + out.stderr
        r, g, b = map(int, words[2:])
        assert r > 50 and g == b == 0
    else:
        assert words[0] == "error" and "apt-get install" in out.stdout


def test_context_failure_becomes_dependency_error(monkeypatch: pytest.MonkeyPatch) -> None:
    import mujoco

    def broken(*a: object, **k: object) -> None:
        raise mujoco.FatalError("an OpenGL platform library has not been loaded")

    monkeypatch.setattr(mujoco, "Renderer", broken)
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(DependencyError, match="libosmesa6"):
        SceneRenderer(m, 16, 16)
    assert SceneRenderer._open == 0


# ---- rendering (needs GL) -----------------------------------------------------------------------


def test_one_renderer_per_process() -> None:
    require_gl()
    import mujoco

    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with SceneRenderer(m, 32, 32):
        with pytest.raises(RuntimeError, match="one renderer per process"):
            SceneRenderer(m, 32, 32)
    r = SceneRenderer(m, 32, 32)  # closed explicitly, a new one may open
    r.close()
    r.close()


def test_projection_matches_rendered_markers() -> None:
    """Projected centres of small spheres agree with the centroid of their pixels within 1.5 px."""
    require_gl()
    import mujoco

    xml = """<mujoco><visual><global offwidth="320" offheight="240"/></visual><worldbody>
      <light pos="0 0 3" dir="0 0 -1"/><geom type="plane" size="3 3 .1" rgba=".5 .5 .5 1"/>
      <geom type="sphere" size=".03" pos="0.5 0.3 0.03" rgba="1 0 0 1"/>
      <geom type="sphere" size=".03" pos="-0.4 -0.2 0.03" rgba="0 1 0 1"/></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    pts = np.array([[0.5, 0.3, 0.03], [-0.4, -0.2, 0.03]])
    with SceneRenderer(m, 320, 240) as r:
        for lookat, dist, az, el in [((0, 0, 0), 2.0, 90.0, -90.0), ((0.1, 0.0, 0.0), 2.0, 40.0, -60.0)]:
            cam = mujoco.MjvCamera()
            cam.type = mujoco.mjtCamera.mjCAMERA_FREE
            cam.lookat[:], cam.distance, cam.azimuth, cam.elevation = lookat, dist, az, el
            r.renderer.update_scene(d, camera=cam)
            img = r.render()
            px, ok = Projection.from_scene(r.scene, 320, 240).pixels(pts)
            assert ok.all()
            for i, chan in enumerate((0, 1)):
                other = 1 - chan
                sel = (img[..., chan] > 120) & (img[..., other] < 60) & (img[..., 2] < 60)
                centroid = np.argwhere(sel).mean(axis=0)[::-1]
                assert np.hypot(*(centroid - px[i])) < 1.5


def test_replay_frames_and_ghost() -> None:
    require_gl()
    job = short_job()
    from sim.physics.simulator import Simulator

    model = Simulator(job.robot, job.scenario.world).model
    settings = RenderSettings(width=160, height=120, fps=10.0)
    replay = Replay(model, job.trajectory, job.logs, settings)
    duration = job.logs["closed_loop"].t[-1] - job.logs["closed_loop"].t[0]
    assert replay.n_frames == round(duration * 10.0) + 1
    sink = ListSink(160, 120)
    with SceneRenderer(model, 160, 120, max_geom=replay.required_geoms) as r:
        assert render_frames(replay, r, sink) == replay.n_frames
        assert replay.composited(r)  # the overview camera in the fast look: see test_compose
        # frame k shows the log sample nearest to t0 + k/fps
        k = replay.n_frames // 2
        tr = replay.tracks[0]
        t_log = job.logs["closed_loop"].t
        assert abs(t_log[tr.idx[k]] - replay.times[k]) <= 0.5 * (t_log[1] - t_log[0]) + 1e-12
        # redrawing a frame gives the same pixels (deterministic replay)
        again = replay.render_frame(r, replay.n_frames - 1)
    frames = np.stack(sink.frames)
    assert frames.shape == (replay.n_frames, 120, 160, 3)
    assert frames.std() > 5.0
    np.testing.assert_array_equal(again, frames[-1])


def test_chase_camera_keeps_robot_near_centre() -> None:
    require_gl()
    job = short_job()
    from sim.physics.simulator import Simulator

    model = Simulator(job.robot, job.scenario.world).model
    settings = RenderSettings(width=160, height=120, fps=5.0, camera="chase")
    replay = Replay(model, job.trajectory, job.logs, settings)
    with SceneRenderer(model, 160, 120, max_geom=replay.required_geoms) as r:
        assert not replay.composited(r)  # a moving camera: the whole scene every frame
        for k in (0, replay.n_frames - 1):
            replay.render_frame(r, k)
            # the ghost: a translucent copy of each visible robot geom, after the model's own; the
            # collision tyres inside the visual ones are left out
            scene = r.scene
            alphas = np.array([scene.geoms[i].rgba[3] for i in range(scene.ngeom)])
            n_ghost = int(np.sum(np.isclose(alphas, GHOST_ALPHA)))
            assert n_ghost == len(replay.robot_geoms) - 2
            assert np.all(np.isclose(alphas[-n_ghost:], GHOST_ALPHA))
            proj = Projection.from_scene(r.scene, 160, 120)
            tr = replay.tracks[0]
            px, ok = proj.pixels(np.array([[*tr.xy[tr.idx[k]], 0.05]]))
            assert ok.all()
            assert abs(px[0, 0] - 80) < 40 and abs(px[0, 1] - 60) < 45


# ---- several runs -------------------------------------------------------------------------------


def test_run_styles_known_labels_and_distinct_fallbacks() -> None:
    known = list(RUN_STYLES)
    unknown = [f"run_{i}" for i in range(12)]
    styles = run_styles([*known, *unknown, "run_0"])
    assert list(styles) == known + unknown  # in the order given, a repeated label once
    for label in known:
        assert styles[label] == RUN_STYLES[label]
    assert styles["closed_loop"].name == "closed loop" and styles["open_loop"].name == "open loop"
    assert styles["run_3"].name == "run_3"
    rgb = np.array([s.rgba[:3] for s in styles.values()])
    gaps = np.abs(rgb[:, None, :] - rgb[None, :, :]).max(axis=2) + np.eye(len(rgb))
    assert gaps.min() > 0.08  # no two runs share a colour (8-bit levels 20 apart at least)
    assert np.all((rgb >= 0.0) & (rgb <= 1.0))
    assert run_styles(["x", "y"])["x"].rgba == FALLBACK_RGBA[0]  # the first unknown label, whatever it is
    assert run_styles(["closed_loop", "y"])["y"].rgba == FALLBACK_RGBA[0]


def test_ghost_colour_is_divided_by_the_light_on_a_face_turned_up() -> None:
    import mujoco

    xml = """<mujoco><visual><headlight ambient=".1 .1 .1" diffuse=".4 .4 .4" specular="0 0 0"/></visual>
      <worldbody><light dir="0 0 -1" ambient=".05 .05 .05" diffuse=".5 .5 .5"/>
      <light dir="0 -1 -1" diffuse=".2 .2 .2"/><light dir="0 0 1" diffuse=".9 .9 .9"/></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    # headlight .1 + .4, lights .05 + .5 straight down, .2 at 45 degrees, none from below
    expect = 0.1 + 0.4 + 0.05 + 0.5 + 0.2 / np.sqrt(2.0)
    np.testing.assert_allclose(light_gain(m), [expect] * 3, rtol=1e-6)
    assert ghost_rgb((1.0, 0.5, 0.1, 1.0), np.full(3, 1.6)) == pytest.approx((0.625, 0.3125, 0.0625))
    assert ghost_rgb((1.0, 0.5, 0.1), np.full(3, 0.5)) == pytest.approx((1.0, 1.0, 0.2))  # at most 1


def _replay_of(logs: dict, width: int, height: int, **settings: object) -> tuple[object, Replay]:
    from sim.physics.simulator import Simulator

    job = short_job()
    model = Simulator(job.robot, job.scenario.world).model
    return model, Replay(model, job.trajectory, logs, RenderSettings(width=width, height=height, **settings))


@pytest.mark.parametrize("quality", ["fast", "high"])
def test_every_ghost_in_its_colour_where_its_robot_is(quality: str) -> None:
    """Four runs: each ghost's pixels at its robot's projected centre have its colour's hue, its trail
    has its colour; fast: composited, high: the full scene."""
    require_gl()
    from sim.physics.simulator import Simulator

    job = short_job()
    logs = spread_runs(Simulator(job.robot, job.scenario.world).model)
    model, replay = _replay_of(logs, 640, 480, fps=10.0, quality=quality)
    assert [t.label for t in replay.tracks] == list(logs)  # closed loop first, solid
    assert replay.required_geoms == 4 * model.ngeom + 64
    cols = np.array([rgb255(t.rgba) for t in replay.tracks], dtype=float)
    chroma = cols - cols.mean(axis=1, keepdims=True)  # what grey floor and white light leave of a colour
    with SceneRenderer(model, 640, 480, quality=quality, max_geom=replay.required_geoms) as r:
        assert replay.composited(r) == (quality == "fast")
        for k in (0, replay.n_frames // 2, replay.n_frames - 1):
            frame = replay.render_frame(r, k).astype(float)
            r.renderer.update_scene(replay.datas[0], camera=replay.camera)
            proj = Projection.from_scene(r.scene, *replay.world_size)
            for ti in range(1, 4):
                centre = geom_box_corners(replay.datas[ti], replay.robot_geoms, replay.robot_corners)
                x, y = np.rint(proj.pixels(centre.reshape(-1, 3).mean(axis=0, keepdims=True))[0][0]).astype(int)
                assert 3 <= x < replay.world_size[0] - 3 and 3 <= y < replay.world_size[1] - 3  # in the world picture
                patch = frame[y - 2 : y + 3, x - 2 : x + 3].reshape(-1, 3).mean(axis=0)
                ch = patch - patch.mean()
                cos = chroma @ ch / (np.linalg.norm(chroma, axis=1) * np.linalg.norm(ch))
                assert np.linalg.norm(ch) > 30.0, (k, ti)  # tinted, not grey
                assert cos[ti] > 0.95 and np.delete(cos, ti).max() < 0.8, (k, ti, cos)
        last = replay.render_frame(r, replay.n_frames - 1)
    # each ghost's trail (1 px wide here), the first half of its path, in its colour (within 2 levels)
    # at the point or a pixel next to it
    near = np.array([(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
    for ti, tr in enumerate(replay.tracks[1:], start=1):
        px = proj.pixels(replay.trail3[ti][tr.trail_keep[: len(tr.trail_keep) // 2]])[0][3:]
        rows = np.rint(px[:, 1]).astype(int)[:, None] + near[:, 0]
        cols_ = np.rint(px[:, 0]).astype(int)[:, None] + near[:, 1]
        pix = last.astype(int)[rows, cols_]  # (points, 9, 3)
        assert len(px) > 10
        assert np.mean((np.abs(pix - cols[ti]).max(axis=2) <= 2).any(axis=1)) > 0.8, tr.label
    names = replay.panel.labels[2::2]
    assert names == ["closed loop", "open loop (ghost)", "odometry feedback (ghost)", "wobbly (ghost)"]


def test_chase_camera_keeps_every_run_in_view() -> None:
    require_gl()
    from sim.physics.simulator import Simulator

    job = short_job()
    logs = spread_runs(Simulator(job.robot, job.scenario.world).model)
    model, replay = _replay_of(logs, 160, 120, fps=5.0, camera="chase")
    with SceneRenderer(model, 160, 120, max_geom=replay.required_geoms) as r:
        assert not replay.composited(r)
        for k in range(replay.n_frames):
            replay.render_frame(r, k)
            alphas = np.array([r.scene.geoms[i].rgba[3] for i in range(r.scene.ngeom)])
            assert int(np.sum(np.isclose(alphas, GHOST_ALPHA))) == 3 * (len(replay.robot_geoms) - 2)
            proj = Projection.from_scene(r.scene, 160, 120)
            for ti, d in enumerate(replay.datas):
                corners = geom_box_corners(d, replay.robot_geoms, replay.robot_corners).reshape(-1, 3)
                px, ok = proj.pixels(corners)
                assert ok.all() and np.all((px >= 0) & (px <= (160, 120))), (k, replay.tracks[ti].label)


# ---- the picture: the whole world, the close-up, the text beside them ----------------------------


def _outline(obstacle: object) -> np.ndarray:
    """(M, 2) points [m] enclosing an obstacle: its corners, or its bounding box's."""
    from planning.core.world import Box, Polygon

    if isinstance(obstacle, Box):
        return obstacle.corners()
    if isinstance(obstacle, Polygon):
        return obstacle.array
    x0, x1, y0, y1 = obstacle.bounding_box()  # type: ignore[attr-defined]
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


@pytest.mark.parametrize(("name", "robot"), [("parking_lot", "turtlebot3"), ("farm", "edumip")])
def test_overview_frames_every_obstacle_and_wall(name: str, robot: str) -> None:
    """Every obstacle's corners, at the floor and at their top (0.3 m), and the walls' outer corners
    (0.05 m thick, 0.15 m high) project into the world picture, though the runs visit one corner;
    the world fills the picture within its margins (not lost in a wide one)."""
    from tests.render_helpers import scenario_replay

    _, replay, world = scenario_replay(name, robot)
    proj = replay.projection(replay.overview_camera, replay.world_size)
    w, h = replay.world_size
    pts = [
        np.column_stack([np.repeat(_outline(o), 2, axis=0), np.tile([0.0, 0.3], len(_outline(o)))])
        for o in world.obstacles
    ]
    x0, x1, y0, y1 = world.bounds
    t = 0.05
    walls = [(x, y, z) for x in (x0 - t, x1 + t) for y in (y0 - t, y1 + t) for z in (0.0, 0.15)]
    px, ok = proj.pixels(np.vstack([*pts, walls]))
    assert ok.all() and len(px) == 8 * 0 + sum(len(p) for p in pts) + 8
    assert np.all((px >= 0) & (px <= (w, h))), px[~np.all((px >= 0) & (px <= (w, h)), axis=1)]
    span = px.max(axis=0) - px.min(axis=0)
    assert max(span[0] / w, span[1] / h) > 0.9


#: The robots' longer sides [m] (TurtleBot3 Burger 0.178 m with its wheels, EduMIP 0.112 m).
LENGTH = {"turtlebot3": 0.178, "edumip": 0.112}


@pytest.mark.parametrize(("name", "robot"), [("parking_lot", "turtlebot3"), ("farm", "edumip"), ("open", "turtlebot3")])
def test_inset_follows_the_robot_at_a_sixth_of_its_width(name: str, robot: str) -> None:
    """In every frame the close-up holds the whole closed-loop robot, its longer side a sixth of the
    inset's width (32 px of the default 192 px inset; more when it turns, at most 1.3 times), and the
    middle of the open-loop ghost two robot lengths to its side."""
    from sim.viz.replay import INSET_ROBOTS
    from tests.render_helpers import scenario_replay

    _, replay, _ = scenario_replay(name, robot, spacing=2 * LENGTH[robot])
    iw, ih = replay.layout.inset[2] - replay.layout.inset[0], replay.layout.inset[3] - replay.layout.inset[1]
    assert (iw, ih) == (192, 192) and replay.magnification > 1.5
    proj = replay.projection(replay.overview_camera, replay.inset_view)
    sizes = []
    for k in range(0, replay.n_frames, 3):
        replay.pose_frame(k)
        win = replay.inset_windows[k]
        for ti in (0, 1):  # the robot, the open-loop ghost
            corners = geom_box_corners(replay.datas[ti], replay.robot_geoms, replay.robot_corners).reshape(-1, 3)
            px = proj.pixels(corners)[0] - win[:2]
            if ti == 0:  # all of it
                assert np.all((px >= 0) & (px <= (iw, ih))), k
                sizes.append(float(np.ptp(px, axis=0).max()))
            else:  # its middle, well inside
                assert np.all((px.mean(axis=0) >= 8) & (px.mean(axis=0) <= (iw - 8, ih - 8))), k
    assert min(sizes) >= iw / INSET_ROBOTS - 1.0 and max(sizes) <= 1.3 * iw / INSET_ROBOTS, (min(sizes), max(sizes))


@pytest.mark.parametrize("quality", ["fast", "high"])
def test_inset_shows_each_near_ghost_in_its_colour(quality: str) -> None:
    """Rendered: at the close-up's projection of the open-loop ghost the inset has its hue; the
    close-up (composited, unlit in either look) equals MuJoCo's render of the same window of the
    magnified view with the lines drawn on it, within 3 levels on 97 % of its pixels (fast look)."""
    require_gl()
    import mujoco

    from tests.render_helpers import scenario_replay

    model, replay, _ = scenario_replay("parking_lot", "turtlebot3", fps=10.0, quality=quality)
    replay.tracks = replay.tracks[:2]  # the robot and the open-loop ghost 0.3 m off
    replay.datas = replay.datas[:2]
    x0, y0, x1, y1 = replay.layout.inset
    col = np.array(rgb255(replay.tracks[1].rgba), dtype=float)
    with SceneRenderer(model, 640, 480, quality=quality, max_geom=replay.required_geoms) as r:
        proj = replay.projection(replay.overview_camera, replay.inset_view)
        scene = mujoco.MjvScene(model, maxgeom=replay.required_geoms)
        scene.flags[:] = r.scene.flags
        for k in (0, replay.n_frames - 1):
            frame = replay.render_frame(r, k)
            inset = frame[y0:y1, x0:x1].astype(float)
            win = tuple(int(v) for v in replay.inset_windows[k])
            corners = geom_box_corners(replay.datas[1], replay.robot_geoms, replay.robot_corners).reshape(-1, 3)
            cx, cy = np.rint(proj.pixels(corners.mean(axis=0, keepdims=True))[0][0] - win[:2]).astype(int)
            patch = inset[cy - 3 : cy + 4, cx - 3 : cx + 4].reshape(-1, 3).mean(axis=0)
            ch, want = patch - patch.mean(), col - col.mean()
            assert float(ch @ want / (np.linalg.norm(ch) * np.linalg.norm(want))) > 0.95, (k, patch)
            if quality == "high":
                continue
            # MuJoCo's render of the window: world, robot and translucent ghost, then the lines
            every = mujoco.mjtCatBit.mjCAT_ALL
            mujoco.mjv_updateScene(
                model, replay.datas[0], replay.option, replay.perturb, replay.overview_camera, every, scene
            )
            replay._add_ghosts(r, scene)
            whole = np.empty((y1 - y0, x1 - x0, 3), np.uint8)
            replay._draw_view(r, scene, replay.inset_view, win, whole)  # type: ignore[arg-type]
            replay._decorate(Projection.from_scene(scene, *replay.inset_view), k, whole, win, replay.inset_line_width)  # type: ignore[arg-type]
            diff = np.abs(whole.astype(int) - inset.astype(int)).max(axis=2)
            assert np.mean(diff <= 3) > 0.97, (k, np.mean(diff <= 3))


def test_panel_covers_no_world_pixel() -> None:
    """The world picture, the inset and the text tile the frame without overlap, and the frame's world
    picture is the world drawn alone, pixel for pixel: nothing of the inset or the text lies over it
    (overview composited, chase drawn whole)."""
    require_gl()
    from sim.viz.compose import FixedViewCompositor
    from tests.render_helpers import scenario_replay

    for camera in ("overview", "chase"):
        model, replay, _ = scenario_replay("farm", "turtlebot3", (320, 240), fps=10.0, camera=camera)
        lay = replay.layout
        cover = np.zeros((240, 320), int)
        for x0, y0, x1, y1 in (lay.world, lay.inset, lay.text):
            cover[y0:y1, x0:x1] += 1
        assert np.all(cover == 1)
        wx0, wy0, wx1, wy1 = lay.world
        assert (wx0, wy0, wy1) == (0, 0, 240) and wx1 == replay.world_size[0] == 320 - 96
        alone = np.zeros((240, wx1, 3), np.uint8)
        with SceneRenderer(model, 320, 240, max_geom=replay.required_geoms) as r:
            k = replay.n_frames // 2
            # a context's first frame can differ from later ones by one level in a few pixels (GL state
            # set up on first use; seen on the farm since its walls rose to 0.3 m): compare settled frames
            replay.render_frame(r, k)
            full = replay.render_frame(r, k).copy()
            if camera == "overview":
                FixedViewCompositor(replay, r, size=replay.world_size).frame(k, alone)
            else:
                replay._update(r, k)
                replay._draw_view(r, r.scene, replay.world_size, lay.world, alone)
                proj = Projection.from_scene(r.scene, *replay.world_size)
                replay._decorate(proj, k, alone, lay.world, replay.line_width)
        assert alone.std() > 10.0
        np.testing.assert_array_equal(full[wy0:wy1, wx0:wx1], alone)
        assert full[:, wx1:].std() > 10.0


def test_clock_prints_each_frames_own_time() -> None:
    """Each frame prints its simulation time to 0.01 s (at 30 frames/s no two frames share a reading;
    the clock stepped every 0.1 s before) and each run's error at its sample; the stamped numbers
    change the text's pixels exactly when the printed text changes."""
    from sim.viz.panel import TextPanel

    _, replay = _replay_of(short_job().logs, 640, 480, fps=30.0)
    panel: TextPanel = replay.panel
    clocks = [panel.texts(k)[0] for k in range(replay.n_frames)]
    assert clocks[:5] == ["0.00", "0.03", "0.07", "0.10", "0.13"]
    end = replay.times[-1]  # the run's end (test_frame_times_follow_simulation_time)
    for k, text in enumerate(clocks):
        assert text == f"{k / 30.0 if k < replay.n_frames - 1 else end:.2f}"  # the last frame: the run's end
        for tr, err in zip(replay.tracks, panel.texts(k)[1:], strict=True):
            assert err == f"{tr.err[tr.idx[k]]:.3f}"
    frames = []
    for k in range(12):
        img = np.zeros((480, 640, 3), np.uint8)
        panel.draw(k, img)
        frames.append(img)
    x0, y0 = replay.layout.text[:2]
    field = panel.fields[0][0]
    for k in range(1, 12):
        a, b = (f[y0 + field[1] : y0 + field[3], x0 + field[0] : x0 + field[2]] for f in (frames[k - 1], frames[k]))
        assert np.any(a != b), k  # a new reading every frame
    again = np.zeros((480, 640, 3), np.uint8)
    panel.draw(5, again)
    np.testing.assert_array_equal(again, frames[5])
    assert not np.any(frames[5][:, : replay.layout.world[2]])  # nothing outside the text


def test_inset_points_at_a_ghost_beyond_it() -> None:
    """A ghost out of the close-up (four robot lengths off; the inset spans six) gets an arrowhead in
    its colour on the inset's edge towards it (straight down: it is to the robot's right, south); one
    in view (two lengths off) gets none."""
    require_gl()
    from tests.render_helpers import scenario_replay

    model, replay, _ = scenario_replay("open", "turtlebot3", spacing=2 * LENGTH["turtlebot3"], fps=10.0)
    replay.tracks = replay.tracks[:3]  # the robot, a ghost two robot lengths off (in view), one four off
    replay.datas = replay.datas[:3]
    x0, y0, x1, y1 = replay.layout.inset
    purple = np.array(rgb255(replay.tracks[2].rgba))
    orange = np.array(rgb255(replay.tracks[1].rgba))
    with SceneRenderer(model, 640, 480, max_geom=replay.required_geoms) as r:
        inset = replay.render_frame(r, 0)[y0:y1, x0:x1].astype(int)
    near = lambda rgb, rows: int(np.sum(np.abs(inset[rows] - rgb).max(axis=2) <= 2))
    bottom, top = slice(y1 - y0 - 16, y1 - y0), slice(0, y1 - y0 - 16)
    assert near(purple, bottom) > 20  # the arrowhead
    assert near(purple, top) == 0  # nothing else of it
    assert near(orange, bottom) == 0  # the ghost in view gets none


def test_a_bad_video_size_names_the_option_and_only_the_fix_that_applies(capsys: pytest.CaptureFixture[str]) -> None:
    """--size 10x10 said "video width must be an integer in [16, 4096] (pixels), got 10; give an even number":
    10 is even, and the command line's error had lost the option's name with the Python form."""
    from sim.cli.main import main

    assert main(["simulate", "--reference", "line", "--size", "10x10", "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert "video width (--size WIDTHxHEIGHT) must be an integer in [16, 4096] (pixels), got 10\n" in err
    assert main(["simulate", "--reference", "line", "--size", "641x480", "--no-plots"]) == 2
    assert "video width (--size WIDTHxHEIGHT) must be even, got 641; give an even number" in capsys.readouterr().err


@pytest.mark.parametrize("size", [(320, 240), (480, 360), (480, 480), (640, 640), (640, 480), (1280, 160)])
def test_the_panels_text_fits_its_panel(size: tuple[int, int]) -> None:
    """At 320 x 240 and 480 x 360 "odometry feedback (ghost)" ran past the frame's right edge (the font followed
    the height, the panel the width); at 1280 x 160 the close-up took the whole panel and no text was shown."""
    from sim.physics.simulator import Simulator
    from sim.viz.panel import MIN_FONT_PX

    width, height = size
    job = short_job()
    logs = spread_runs(Simulator(job.robot, job.scenario.world).model)  # four runs: the panel's longest names
    _, replay = _replay_of(logs, width, height, fps=10.0)
    panel = replay.panel
    x0, y0, x1, y1 = replay.layout.text
    assert len(panel.labels) == 2 + 2 * len(replay.tracks) >= 8
    frame = np.zeros((height, width, 3), np.uint8)
    panel.draw(replay.n_frames - 1, frame)
    text = frame[y0:y1, x0:x1].astype(int)
    ink = np.abs(text - text[0, 0]).sum(axis=2) > 60  # anything but the panel's background
    if size == (1280, 160):  # too low for every line at the smallest font: the lines that fit are shown
        assert panel.font.size == MIN_FONT_PX and ink[: y1 - y0 - 3].any()
        return
    assert ink.any() and not ink[:, -4:].any() and not ink[-3:].any()  # inside, clear of the right and the bottom


def _ended_early(log: RunLog, keep: int) -> RunLog:
    """``log`` cut after its first ``keep`` samples, as a run that fell there logs it."""
    from dataclasses import replace

    cut = {name: array[:keep] for name, array in log.arrays().items()}
    t_end = float(log.t[keep - 1])
    return replace(log, **cut, estimation=None, wheel_off_floor=None, status=f"fell at t={t_end:.3f} s")


def test_a_run_that_ended_early_is_said_in_the_video_and_the_plot() -> None:
    """A ghost whose run fell stood still while the panel went on printing its error, with no word that the run
    was over; its path in the world plot just stopped."""
    from sim.viz.plots.run import world_figure

    job = short_job()
    logs = dict(job.logs)
    ended = _ended_early(logs["open_loop"], len(logs["open_loop"]) // 2)
    logs["open_loop"] = ended
    _, replay = _replay_of(logs, 640, 480, fps=10.0)
    panel = replay.panel
    ((rect, t_end, _),) = panel.endings
    assert t_end == ended.t[-1]
    shown = []
    for k in range(replay.n_frames):
        frame = np.zeros((480, 640, 3), np.uint8)
        panel.draw(k, frame)
        x0, y0 = replay.layout.text[:2]
        line = frame[y0 + rect[1] : y0 + rect[3], x0 + rect[0] : x0 + rect[2]].astype(int)
        shown.append(bool((np.abs(line - line[0, 0]).sum(axis=2) > 60).any()))
    assert shown == [bool(t >= t_end) for t in replay.times] and any(shown) and not all(shown)
    ax = world_figure(job.scenario.world, job.trajectory, logs).axes[0]
    (mark,) = [ln for ln in ax.lines if "ended at" in ln.get_label()]
    assert mark.get_label() == f"open loop ended at t = {ended.t[-1] - ended.t[0]:.2f} s"
    np.testing.assert_array_equal(np.ravel(mark.get_xydata()), ended.pose[-1, :2])


#: A suite environment rendered after ``from sim import ...``, in a fresh interpreter without MUJOCO_GL or a display.
SUITE_AFTER_SIM = """
from sim import simulate_plan  # loads MuJoCo: before, it picked GLFW, which dm_control then kept
from sim import suite
env = suite.load("open", "edumip", "circle", seed=0)
env.reset()
print(*env.physics.render(48, 64).shape)
env.physics.free()
"""


def test_a_suite_environment_renders_headless_after_sims_own_names_were_loaded() -> None:
    """``from sim import simulate_plan`` before ``sim.suite`` left dm_control on GLFW: rendering failed with "an
    OpenGL platform library has not been loaded" where ``sim.suite`` alone renders headless."""
    if not sys.platform.startswith("linux") or gl.default_backend() == gl.DISABLED:
        pytest.skip("no headless OpenGL here")
    env = {
        k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")
    }
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1])
    out = subprocess.run([sys.executable, "-c", SUITE_AFTER_SIM], env=env, capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.split() == ["48", "64", "3"], out.stdout + out.stderr


def test_a_display_that_cannot_be_opened_is_told_to_render_headless(monkeypatch: pytest.MonkeyPatch) -> None:
    """A stale DISPLAY (ssh, a container) chose GLFW, which failed, and the message said to install libosmesa6,
    installed already; it now names the headless backends that can load."""
    from sim.viz import gl

    usable = [b for b in ("osmesa", "egl") if gl.backend_missing(b) is None]
    if not usable:
        pytest.skip("no headless OpenGL library on this machine")
    monkeypatch.setenv("DISPLAY", ":99")
    said = gl.unavailable_message("glfw", RuntimeError("no display"))
    assert "the display (:99) cannot be used; render without it: --gl " + usable[0] in said
    assert "apt-get install" not in said
    assert "apt-get install libosmesa6" in gl.unavailable_message("osmesa", RuntimeError("no library"))


STALE_DISPLAY = """
import mujoco
from sim.viz.renderer import SceneRenderer
from planning.errors import DependencyError
try:
    SceneRenderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 64, 48)
except DependencyError as exc:
    print("refused:", str(exc)[:60])
"""


def test_a_display_that_cannot_be_opened_is_said_once_without_glfws_warnings() -> None:
    """GLFW's warnings ("GLFWError: (65550) b'X11: Failed to open display :99'", with Python's file and line) came
    before the one message that says the display cannot be used; only that message is left."""
    if not sys.platform.startswith("linux"):
        pytest.skip("GLFW on X11 is Linux's")
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "WAYLAND_DISPLAY")}
    env.update(DISPLAY=":99", MUJOCO_GL="glfw", PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    out = subprocess.run([sys.executable, "-c", STALE_DISPLAY], env=env, capture_output=True, text=True)
    assert out.stdout.startswith("refused: cannot create an OpenGL context with the glfw backend"), out
    assert "GLFWError" not in out.stderr and "warnings.warn" not in out.stderr, out.stderr
