"""Fixed-view compositing against MuJoCo's full render of the same frame; trails; hidden geoms."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from PIL import Image, ImageDraw

import sim.viz.compose as compose
from sim.viz.compose import FixedViewCompositor, draw_polyline
from sim.viz.renderer import SceneRenderer
from sim.viz.replay import RenderSettings, Replay
from sim.viz.scene import enclosed_geoms
from tests.render_helpers import require_gl, short_job, spread_runs

W, H = 320, 240


def _replay(camera: str = "overview", *, runs: int = 2) -> tuple[mujoco.MjModel, Replay]:
    """The short job's two runs, or four (:func:`spread_runs` with two ghosts overlapping)."""
    from sim.physics.simulator import Simulator

    job = short_job()
    model = Simulator(job.robot, job.scenario.world).model
    logs = job.logs if runs == 2 else spread_runs(model, overlap=True)
    replay = Replay(model, job.trajectory, logs, RenderSettings(width=W, height=H, fps=10.0, camera=camera))
    if camera == "overview":
        close_overview(replay)
    return model, replay


def close_overview(replay: Replay) -> None:
    """Point the replay's fixed camera straight down at the runs, framing them alone on the renderer's
    whole image (the robots then cover enough pixels to compare at this size)."""
    xy = np.vstack([tr.xy for tr in replay.tracks])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    tan_half = np.tan(np.radians(replay.model.vis.global_.fovy) / 2.0)
    half = (hi - lo) / 2 + 0.35
    dist = max(half[1] / tan_half, half[0] / (tan_half * W / H)) + 0.25
    replay._cam_params[:] = (*((lo + hi) / 2), 0.0, dist, 90.0, -90.0)


def test_draw_polyline_in_a_crop_equals_drawing_on_the_whole_image() -> None:
    rng = np.random.default_rng(3)
    img = rng.integers(0, 255, (60, 80, 3), dtype=np.uint8)
    for width in (1, 3, 4):
        pts = rng.uniform(-5, 85, (5, 2))  # partly outside the image
        got = img.copy()
        draw_polyline(got, pts, (10, 200, 30), width)
        ref = Image.fromarray(img)
        ImageDraw.Draw(ref).line(pts.ravel().tolist(), fill=(10, 200, 30), width=width)
        changed = np.any(np.asarray(ref) != img, axis=2)
        assert changed.sum() > 20
        # identical but for pixels where PIL rounds a coordinate shifted by the crop differently
        assert np.count_nonzero(np.any(got != np.asarray(ref), axis=2)) <= 0.02 * changed.sum()
    one = img.copy()
    draw_polyline(one, np.array([[5.0, 5.0]]), (0, 0, 0), 3)  # a single point draws nothing
    np.testing.assert_array_equal(one, img)


def test_enclosed_geoms_are_the_collision_tyres() -> None:
    _, replay = _replay()
    m = replay.model
    hidden = enclosed_geoms(m, replay.robot_geoms)
    assert sorted(m.geom(int(g)).name for g in hidden) == ["wheel_left_geom", "wheel_right_geom"]
    xml = """<mujoco><worldbody><body><freejoint/>
      <geom name="a" type="box" size=".1 .1 .1"/><geom name="b" type="box" size=".05 .1 .1"/>
      <geom name="c" type="box" size=".05 .1 .1" pos=".01 0 0"/><geom name="d" type="sphere" size=".2"/>
      </body></worldbody></mujoco>"""
    m2 = mujoco.MjModel.from_xml_string(xml)
    ids = np.arange(m2.ngeom)
    # b sits inside a (same frame, smaller); c is shifted; a box inside a sphere is not checked
    assert [m2.geom(int(g)).name for g in enclosed_geoms(m2, ids)] == ["b"]


@pytest.mark.parametrize("runs", [2, 4])
def test_composited_frames_match_the_full_render(monkeypatch: pytest.MonkeyPatch, runs: int) -> None:
    """World and solid robot: MuJoCo's own pixels (within 2 levels); ghosts: MuJoCo's own blend, within
    3 levels clear of the solid robot. Two runs: the ghost lies on the solid robot at nearly one pose;
    where their faces coincide (depths within 1e-6) MuJoCo's draw is depth-rounding noise and the
    composite shows the ghost: those pixels are left out. Four runs: the open-loop ghost alone, two
    ghosts side by side, overlapping."""
    require_gl()
    model, replay = _replay(runs=runs)
    monkeypatch.setattr(compose, "draw_polyline", lambda *a, **k: None)  # no trails
    with SceneRenderer(model, W, H, max_geom=replay.required_geoms) as r:
        comp = FixedViewCompositor(replay, r)  # the renderer's whole image, as r.render() draws it
        # the floor layer without the reference path: MuJoCo's static pass with the sky
        scn = comp._scene
        scn.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = True
        static = mujoco.mjtCatBit.mjCAT_STATIC
        mujoco.mjv_updateScene(model, replay.datas[0], comp._opt, comp._pert, replay.camera, static, scn)
        r.draw(scn)
        r.read((0, 0, W, H), comp._base, np.empty((H, W), np.float32))
        scn.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
        comp._reset_trails()
        compared = 0
        for k in (0, replay.n_frames // 2, replay.n_frames - 1):
            got = comp.frame(k, np.empty((H, W, 3), np.uint8)).astype(int)
            replay._update(r, k)  # the full scene: world, robot, translucent ghosts
            ref = r.render().astype(int)
            diff = np.abs(got - ref).max(axis=2)
            robot = np.zeros((H, W), bool)
            solid_depth = np.zeros((H, W), np.float32)
            solid_rect = comp._rect(replay.datas[0])
            assert solid_rect is not None
            sx0, sy0, sx1, sy1 = solid_rect
            robot[sy0:sy1, sx0:sx1] = True
            solid_depth[sy0:sy1, sx0:sx1] = comp._pass(solid_rect)[1]
            ghosts = []
            for ti in range(1, runs):
                rect = comp._rect(replay.datas[ti])
                assert rect is not None
                _, transmission = comp._ghost_pass([ti], rect, None)
                mask = np.zeros((H, W), bool)
                x0, y0, x1, y1 = rect
                mask[y0:y1, x0:x1] = transmission < 1.0
                ghost_depth = comp.passes.draw(replay.datas[ti], rect)[1]
                coincide = np.zeros((H, W), bool)
                coincide[y0:y1, x0:x1] = np.abs(ghost_depth - solid_depth[y0:y1, x0:x1]) < 1e-6
                seen = mask & ~coincide  # none in frame 0 of two runs: both start at one pose
                assert mask.sum() > 50 and (not seen.any() or diff[seen].mean() < 25.0), (k, ti)
                compared += int(seen.sum())
                if runs == 4:  # clear of the solid robot
                    assert np.count_nonzero(mask & ~robot) > 300 and diff[mask & ~robot].max() <= 3, (k, ti)
                ghosts.append(mask)
            ghost = np.any(ghosts, axis=0)
            if runs == 4:
                assert np.count_nonzero(ghosts[1] & ghosts[2]) > 100  # the side-by-side ghosts overlap
            assert np.count_nonzero(robot & ~ghost) > 100  # the solid robot is in the comparison
            assert np.count_nonzero(diff[~ghost] > 2) <= 3, k
    assert compared > 100 * (runs - 1)


def test_merge_rects_groups_overlapping_rectangles() -> None:
    rects = {
        1: (0, 0, 10, 10),
        2: (50, 50, 60, 60),
        3: (8, 8, 20, 12),  # overlaps 1
        4: (18, 0, 30, 5),  # overlaps 3 only
        5: (25, 11, 40, 20),  # overlaps none of 1, 3, 4 but the rectangle bounding them (0, 0, 30, 12)
        6: (100, 0, 110, 10),
    }
    groups = compose.merge_rects(rects)
    assert groups == [((0, 0, 40, 20), [1, 3, 4, 5]), ((50, 50, 60, 60), [2]), ((100, 0, 110, 10), [6])]
    assert compose.merge_rects({}) == []
    assert compose.merge_rects({7: (0, 0, 5, 5), 8: (5, 0, 9, 5)}) == [((0, 0, 5, 5), [7]), ((5, 0, 9, 5), [8])]


def test_frames_do_not_depend_on_the_order_they_are_drawn_in() -> None:
    require_gl()
    model, replay = _replay()
    n = replay.n_frames
    with SceneRenderer(model, W, H, max_geom=replay.required_geoms) as r:
        in_order = [replay.render_frame(r, k).copy() for k in range(n)]
        again = replay.render_frame(r, n // 2)  # backwards: the trails are redrawn from the start
        np.testing.assert_array_equal(again, in_order[n // 2])
        np.testing.assert_array_equal(replay.render_frame(r, n - 1), in_order[-1])
    # the trails: the logged path behind the robot in the last frame is in a trail colour (the ghost's
    # thinner trail lies on the closed-loop one where the runs agree), and not in the first frame
    comp = replay._compositor
    tr = replay.tracks[0]
    px = comp.proj.pixels(replay.trail3[0][tr.trail_keep[: len(tr.trail_keep) // 2]])[0][len(tr.trail_keep) // 8 :]
    colours = np.array([[round(255 * c) for c in t.rgba[:3]] for t in replay.tracks])

    def on_trail(frame: np.ndarray) -> float:
        pix = frame.astype(int)[np.rint(px[:, 1]).astype(int), np.rint(px[:, 0]).astype(int)]
        return float(np.mean(np.abs(pix[:, None, :] - colours[None]).max(axis=2).min(axis=1) <= 2))

    assert len(px) > 10
    assert on_trail(in_order[-1]) > 0.8
    assert on_trail(in_order[0]) < 0.2


def test_moving_camera_or_shadows_use_the_full_render() -> None:
    require_gl()
    model, replay = _replay("chase")
    with SceneRenderer(model, W, H, max_geom=replay.required_geoms) as r:
        assert not replay.fixed_camera and not replay.composited(r)
        with pytest.raises(ValueError, match="camera that stays put"):
            FixedViewCompositor(replay, r)
    model, replay = _replay()
    with SceneRenderer(model, W, H, quality="high", max_geom=replay.required_geoms) as r:
        assert replay.fixed_camera and not replay.composited(r)
        with pytest.raises(ValueError, match="shadows or reflections"):
            FixedViewCompositor(replay, r)


def test_a_wall_hides_the_part_of_a_ghost_inside_it(monkeypatch: pytest.MonkeyPatch) -> None:
    """A ghost straddling the north wall (0.15 m high): the wall's top hides its lower half, as in the
    full render; the floor plane is no occluder."""
    require_gl()
    monkeypatch.setattr(compose, "draw_polyline", lambda *a, **k: None)  # no trails
    from render_helpers import moved_log

    from sim.physics.simulator import Simulator

    job = short_job()
    model = Simulator(job.robot, job.scenario.world).model
    logs = {"closed_loop": job.logs["closed_loop"], "open_loop": moved_log(model, job.logs["open_loop"], (0.0, 3.0))}
    replay = Replay(model, job.trajectory, logs, RenderSettings(width=W, height=H, fps=10.0))
    close_overview(replay)
    with SceneRenderer(model, W, H, max_geom=replay.required_geoms) as r:
        k = replay.n_frames - 1
        comp = FixedViewCompositor(replay, r)  # the renderer's whole image, as r.render() draws it
        got = comp.frame(k, np.empty((H, W, 3), np.uint8)).astype(int)
        walls = [o for o in comp.occluders if o.type == mujoco.mjtGeom.mjGEOM_BOX]
        assert len(comp.occluders) == len(walls) == 4  # the walls; the floor plane is left out
        replay._update(r, k)
        ref = r.render().astype(int)
        rect = comp._rect(replay.datas[1])
        assert rect is not None
        _, seen = comp._ghost_pass([1], rect, None)
        tinted, white = comp.passes.queue_ghosts([replay.datas[1]], rect, [replay.tracks[1].rgba])  # no occluder
        res = comp.passes.read()
        _, unhidden = compose.ghost_layer(res[tinted][0], res[white][0])
    assert np.count_nonzero(unhidden < seen - 0.05) > 20  # the wall hides part of the ghost
    x0, y0, x1, y1 = rect
    diff = np.abs(got - ref).max(axis=2)[y0:y1, x0:x1]
    body = seen < 1.0
    assert body.sum() > 30 and diff[body].max() <= 3


def test_passes_read_back_at_once_equal_passes_read_alone() -> None:
    """Queued passes sit side by side in the off-screen buffer, in rows, read back once (or when the
    buffer is full): each equals the same pass drawn and read alone (depth to 1e-6: where a pass sits
    in the buffer changes the rasteriser's depth rounding, not the pixels)."""
    require_gl()
    model, replay = _replay(runs=4)
    with SceneRenderer(model, W, H, max_geom=replay.required_geoms) as r:
        comp = FixedViewCompositor(replay, r)
        comp.frame(replay.n_frames // 2, np.empty((H, W, 3), np.uint8))  # poses the runs, takes the view
        solid = comp._rect(replay.datas[0])
        rects = [comp._rect(d) for d in replay.datas[1:]]
        assert solid is not None and all(rc is not None for rc in rects)
        alone_solid = comp._pass(solid)
        alone = [comp._ghost_pass([t], rc, solid) for t, rc in enumerate(rects, start=1)]  # type: ignore[arg-type]
        per_round = 1 + 2 * len(rects)
        rounds = 1 + (W * H) // (per_round * (solid[2] - solid[0]) * (solid[3] - solid[1]))  # past one buffer
        slots = []
        for _ in range(rounds):
            s = comp.passes.queue(replay.datas[0], solid)
            slots.append((s, [comp._queue_ghosts([t], rc, solid) for t, rc in enumerate(rects, start=1)]))  # type: ignore[arg-type]
        res = comp.passes.read()
    assert len(res) == rounds * per_round
    for s, ghost_slots in slots:
        np.testing.assert_array_equal(res[s][0], alone_solid[0])
        np.testing.assert_allclose(res[s][1], alone_solid[1], rtol=0, atol=1e-6)  # depth: rasterisation rounding
        for (tinted, white), (p, t) in zip(ghost_slots, alone, strict=True):
            got_p, got_t = compose.ghost_layer(res[tinted][0], res[white][0])
            np.testing.assert_array_equal(got_p, p)
            np.testing.assert_array_equal(got_t, t)
