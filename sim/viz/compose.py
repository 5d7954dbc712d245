"""Frames of a fixed camera composited from a cached floor layer and small passes for the robots.

With the overview camera nothing but the robots moves, and in the fast look (no shadows, no
reflections) a robot changes no pixel outside its own silhouette. So the world is drawn once:

1. **static pass** (once per video): MuJoCo draws the static geoms (floor, walls, obstacles, sky)
   and the colour and depth buffers are read back; the reference path is drawn onto the colour
   image with PIL. This image, the *floor layer*, also collects the trails: each frame adds only the
   segments its robots completed since the previous frame (a few pixels wide crops).
2. **robot passes** (each frame): one per robot, each through a small viewport: MuJoCo draws only
   that robot's dynamic geoms (a ghost opaque in its run's colour) for the rectangle its bounding
   box projects to, and that rectangle is read back, colour and depth. A solid-robot pixel replaces
   the floor-layer pixel where it is nearer than the static depth; a ghost pixel is blended over
   what is there with alpha :data:`sim.viz.scene.GHOST_ALPHA` where it is at least as near as the
   world and the solid robot. Ghosts are blended farthest first, as MuJoCo sorts translucent geoms,
   so where two ghosts overlap the nearer tint lies on top.
3. the unfinished segment of each trail and the text overlay.

The picture matches a full MuJoCo render of the scene pixel for pixel on the world and the solid
robot; a ghost differs only where its own parts overlap (one translucent layer here, several in
MuJoCo's blended draw) and where ghosts overlap (sorted per robot here, per geom in MuJoCo). Trails
pass under the ghosts' tints and the solid robot, as they would lie on the floor. Trails are drawn
in frame order, whatever order the frames are asked in, so a frame's pixels do not depend on which
frames were drawn before it.
"""

from __future__ import annotations

import math
from typing import Protocol

import mujoco
import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw

from sim.viz.renderer import SceneRenderer
from sim.viz.scene import (
    GHOST_ALPHA,
    REFERENCE_RGBA,
    FloatArray,
    Frame,
    Projection,
    Track,
    geom_box_corners,
    ghost_rgb,
    light_gain,
    polylines,
    rgb255,
    trail_width,
)

Rect = tuple[int, int, int, int]  # x0, y0, x1, y1 [px], image coordinates, end exclusive

#: Pixels added around each robot's projected bounding box.
RECT_MARGIN = 2

#: Opacity of the ghost's one composited layer: MuJoCo blends the back and the front faces of each
#: translucent part, each with :data:`sim.viz.scene.GHOST_ALPHA`, so a part over the floor shows
#: ``1 - (1 - GHOST_ALPHA) ** 2`` of its colour.
LAYER_ALPHA = 1.0 - (1.0 - GHOST_ALPHA) ** 2


class ComposedReplay(Protocol):
    """What the compositor reads from a replay (:class:`sim.viz.replay.Replay` is one).

    Attributes:
        model: The runs' model.
        ghost_model: The model with the robot's enclosed geoms left out (drawn for every robot pass).
        datas: One ``MjData`` per track, posed by :meth:`pose_frame`.
        tracks: The runs, the solid one first, then the ghosts.
        camera: The camera, the same in every frame.
        fixed_camera: Whether the camera stays put (required).
        ref3: (M, 3) decimated reference path on the floor [m].
        trail3: Per track, (N, 3) logged path on the floor [m].
        line_width: Width of the reference line [px].
        required_geoms: Scene capacity.
        robot_geoms: (G,) visible geoms of the robot.
        robot_corners: (G, 8, 3) their bounding-box corners in their own frames [m].
    """

    model: mujoco.MjModel
    ghost_model: mujoco.MjModel
    datas: list[mujoco.MjData]
    tracks: list[Track]
    camera: mujoco.MjvCamera
    fixed_camera: bool
    ref3: FloatArray
    trail3: list[FloatArray]
    line_width: int
    required_geoms: int
    robot_geoms: NDArray[np.int64]
    robot_corners: FloatArray

    def pose_frame(self, k: int) -> None:
        """Pose every run and the camera at frame ``k``."""
        ...

    def draw_overlay(self, k: int, frame: Frame) -> None:
        """Draw frame ``k``'s text overlay into ``frame``."""
        ...


def draw_polyline(img: Frame, pts: NDArray[np.float64], rgb: tuple[int, int, int], width: int) -> None:
    """Draw a polyline into an image in place, through a PIL crop of just its bounding box.

    Args:
        img: (H, W, 3) uint8 image.
        pts: (M, 2) [column, row] pixel coordinates (M >= 2; fewer draws nothing).
        rgb: Colour.
        width: Line width [px].
    """
    if len(pts) < 2:
        return
    h, w = img.shape[:2]
    pad = width + 2
    x0 = max(0, math.floor(float(pts[:, 0].min())) - pad)
    y0 = max(0, math.floor(float(pts[:, 1].min())) - pad)
    x1 = min(w, math.ceil(float(pts[:, 0].max())) + pad + 1)
    y1 = min(h, math.ceil(float(pts[:, 1].max())) + pad + 1)
    if x1 <= x0 or y1 <= y0:
        return
    sub = img[y0:y1, x0:x1]
    pil = Image.fromarray(sub)
    ImageDraw.Draw(pil).line((pts - (x0, y0)).ravel().tolist(), fill=rgb, width=width)
    sub[...] = np.asarray(pil)


def _overlap(a: Rect, b: Rect) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


class RobotPass:
    """Draws one robot's dynamic geoms through a rectangle of the image, into a small viewport.

    The frustum is narrowed to the rectangle and the viewport shrunk to its size, so MuJoCo clears
    and rasterises only those pixels (the same pixel centres as the full view).

    Args:
        model: The model to draw (the replay's ``ghost_model``: geoms inside others left out).
        renderer: The open renderer.
        flags: Render flags to copy (the sky is turned off: nothing but the robot is drawn).
        maxgeom: Scene capacity.
    """

    def __init__(self, model: mujoco.MjModel, renderer: SceneRenderer, flags: NDArray[np.uint8], maxgeom: int) -> None:
        self.model = model
        self.renderer = renderer
        self.opt = mujoco.MjvOption()
        self.pert = mujoco.MjvPerturb()
        self.scene = mujoco.MjvScene(model, maxgeom=maxgeom)
        self.scene.flags[:] = flags
        self.scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
        self._gain = light_gain(renderer.model)
        self._frustum: list[tuple[float, float, float, float]] = []

    def view(self, data: mujoco.MjData, camera: mujoco.MjvCamera) -> Projection:
        """Take the camera and lights of a frame (no geoms); returns the full view's projection."""
        mujoco.mjv_updateScene(self.model, data, self.opt, self.pert, camera, 0, self.scene)
        w, h = self.renderer.width, self.renderer.height
        self._frustum = []
        for c in self.scene.camera:
            half_w = 0.5 * float(c.frustum_top - c.frustum_bottom) * w / h
            self._frustum.append((float(c.frustum_center), half_w, float(c.frustum_bottom), float(c.frustum_top)))
        return Projection.from_scene(self.scene, w, h)

    def rect(self, proj: Projection, data: mujoco.MjData, geoms: NDArray[np.int64], corners: FloatArray) -> Rect | None:
        """Pixel rectangle holding the projected bounding boxes of ``geoms``, or None when off screen.

        Args:
            proj: The view.
            data: The robot's state.
            geoms: (G,) geom ids.
            corners: (G, 8, 3) bounding-box corners of each geom in its own frame [m].
        """
        px, ok = proj.pixels(geom_box_corners(data, geoms, corners).reshape(-1, 3))
        w, h = self.renderer.width, self.renderer.height
        if not ok.all():
            return (0, 0, w, h)
        x0 = max(0, int(np.floor(px[:, 0].min())) - RECT_MARGIN)
        y0 = max(0, int(np.floor(px[:, 1].min())) - RECT_MARGIN)
        x1 = min(w, int(np.ceil(px[:, 0].max())) + RECT_MARGIN + 1)
        y1 = min(h, int(np.ceil(px[:, 1].max())) + RECT_MARGIN + 1)
        return (x0, y0, x1, y1) if x1 > x0 and y1 > y0 else None

    def draw(
        self, data: mujoco.MjData, rect: Rect, tint: tuple[float, ...] | None = None
    ) -> tuple[Frame, NDArray[np.float32]]:
        """Draw the robot of ``data`` opaque, in its model's colours or all in ``tint`` (RGB(A) in
        [0, 1], a ghost's colour, dimmed by :func:`sim.viz.scene.ghost_rgb`), as seen through
        ``rect`` (after :meth:`view`) and read back its colour and depth, row 0 at the top."""
        scn = self.scene
        scn.ngeom = 0
        mujoco.mjv_addGeoms(self.model, data, self.opt, self.pert, mujoco.mjtCatBit.mjCAT_DYNAMIC, scn)
        if tint is not None:
            color = (*ghost_rgb(tint, self._gain), 1.0)
            for i in range(scn.ngeom):
                scn.geoms[i].rgba = color
        x0, y0, x1, y1 = rect
        w, h = self.renderer.width, self.renderer.height
        for eye, (center, half_w, bottom, top) in zip(scn.camera, self._frustum, strict=True):
            du = 2.0 * half_w / w
            dv = (top - bottom) / h
            eye.frustum_center = center - half_w + 0.5 * (x0 + x1) * du
            eye.frustum_top = top - y0 * dv
            eye.frustum_bottom = top - y1 * dv
        self.renderer.draw(scn, (x1 - x0, y1 - y0))
        rgb = np.empty((y1 - y0, x1 - x0, 3), np.uint8)
        depth = np.empty((y1 - y0, x1 - x0), np.float32)
        self.renderer.read((0, h - (y1 - y0), x1 - x0, h), rgb, depth)  # the viewport's corner
        return rgb, depth


def blend_ghost(out: Frame, rect: Rect, rgb: Frame, depth: NDArray[np.float32], behind: NDArray[np.float32]) -> None:
    """Blend a ghost pass over ``out`` where it is at least as near as ``behind``.

    Args:
        out: (H, W, 3) image, changed in place.
        rect: The pass's rectangle (x0, y0, x1, y1).
        rgb: (h, w, 3) the ghost drawn opaque.
        depth: (h, w) its depth (reversed: larger is nearer, 0 where nothing was drawn).
        behind: (h, w) depth of what is already in ``out`` there.
    """
    x0, y0, x1, y1 = rect
    near = (depth >= behind) & (depth > 0.0)  # ties to the ghost, drawn last in MuJoCo too
    dst = out[y0:y1, x0:x1]
    mixed = LAYER_ALPHA * rgb[near].astype(np.float32) + (1.0 - LAYER_ALPHA) * dst[near]
    dst[near] = np.rint(mixed).astype(np.uint8)


class FixedViewCompositor:
    """Draws a replay's frames for a camera that does not move (see the module docstring).

    Args:
        replay: The replay; its camera must be the same in every frame.
        renderer: The open renderer, without shadows or reflections.

    Raises:
        ValueError: The camera moves, or the renderer draws shadows or reflections.
    """

    def __init__(self, replay: ComposedReplay, renderer: SceneRenderer) -> None:
        if not replay.fixed_camera:
            raise ValueError("the compositor needs a camera that stays put (the overview camera)")
        flags = renderer.scene.flags
        if flags[mujoco.mjtRndFlag.mjRND_SHADOW] or flags[mujoco.mjtRndFlag.mjRND_REFLECTION]:
            raise ValueError("the compositor cannot draw shadows or reflections: use the full render")
        self.replay = replay
        self.renderer = renderer
        m = replay.model
        w, h = renderer.width, renderer.height
        self._opt = mujoco.MjvOption()
        self._pert = mujoco.MjvPerturb()
        self._scene = mujoco.MjvScene(m, maxgeom=replay.required_geoms)
        self._scene.flags[:] = flags
        replay.pose_frame(0)
        # static pass: the world, read back whole, colour and depth
        static = mujoco.mjtCatBit.mjCAT_STATIC
        mujoco.mjv_updateScene(m, replay.datas[0], self._opt, self._pert, replay.camera, static, self._scene)
        self.proj = Projection.from_scene(self._scene, w, h)
        rgb = np.empty((h, w, 3), np.uint8)
        depth = np.empty((h, w), np.float32)
        renderer.draw(self._scene)
        renderer.read((0, 0, w, h), rgb, depth)
        self.depth = depth
        base = Image.fromarray(rgb)
        draw = ImageDraw.Draw(base)
        for line in polylines(*self.proj.pixels(replay.ref3)):
            draw.line(line, fill=rgb255(REFERENCE_RGBA), width=replay.line_width)
        self._base: Frame = np.asarray(base).copy()
        # robots alone from here on, drawn through small rectangles
        self.passes = RobotPass(replay.ghost_model, renderer, flags, replay.required_geoms)
        self._trail_px = [self.proj.pixels(t3)[0] for t3 in replay.trail3]
        self._reset_trails()

    # ---- trails ---------------------------------------------------------------------------------
    def _reset_trails(self) -> None:
        self.layer: Frame = self._base.copy()
        self._drawn = [0] * len(self.replay.tracks)  # kept trail points joined on the layer, per track
        self._trail_k = -1  # last frame whose trail segments are on the layer

    def _advance_trails(self, k: int) -> None:
        """Put the trail segments completed by frame ``k`` on the layer, frame by frame."""
        if k < self._trail_k:
            self._reset_trails()
        for kk in range(self._trail_k + 1, k + 1):
            for ti, tr in enumerate(self.replay.tracks):
                upto = int(np.searchsorted(tr.trail_keep, tr.idx[kk], side="right"))
                done = self._drawn[ti]
                if upto > done:
                    pts = self._trail_px[ti][tr.trail_keep[max(done - 1, 0) : upto]]
                    draw_polyline(self.layer, pts, rgb255(tr.rgba), trail_width(ti, self.replay.line_width))
                    self._drawn[ti] = upto
        self._trail_k = max(self._trail_k, k)

    # ---- robots ---------------------------------------------------------------------------------
    def _rect(self, data: mujoco.MjData) -> Rect | None:
        return self.passes.rect(self.proj, data, self.replay.robot_geoms, self.replay.robot_corners)

    def _pass(self, track: int, rect: Rect) -> tuple[Frame, NDArray[np.float32]]:
        """Draw track ``track``'s robot through ``rect``: the solid one (track 0) in its model's
        colours, a ghost in its run's colour."""
        r = self.replay
        return self.passes.draw(r.datas[track], rect, None if track == 0 else r.tracks[track].rgba)

    def _robots(self, out: Frame) -> None:
        r = self.replay
        proj = self.passes.view(r.datas[0], r.camera)  # lights and eyes of this frame
        solid = self._rect(r.datas[0])
        solid_depth = None
        if solid is not None:
            x0, y0, x1, y1 = solid
            rgb, solid_depth = self._pass(0, solid)
            # reversed depth (MuJoCo's default): larger is nearer, 0 where nothing was drawn
            near = solid_depth > self.depth[y0:y1, x0:x1]
            out[y0:y1, x0:x1][near] = rgb[near]
        for ti in self._ghost_order(proj):
            ghost = self._rect(r.datas[ti])
            if ghost is None:
                continue
            x0, y0, x1, y1 = ghost
            rgb, depth = self._pass(ti, ghost)
            behind = self.depth[y0:y1, x0:x1]
            if solid is not None and solid_depth is not None and _overlap(solid, ghost):
                behind = self._depth_with_solid(ghost, solid, solid_depth)
            blend_ghost(out, ghost, rgb, depth, behind)

    def _ghost_order(self, proj: Projection) -> list[int]:
        """Ghost tracks (1, 2, ...) farthest from the camera first (by their root body's position), so
        nearer tints are blended over farther ones; ties keep the tracks' order."""
        r = self.replay
        dist = [float((d.geom_xpos[r.robot_geoms].mean(axis=0) - proj.pos) @ proj.forward) for d in r.datas[1:]]
        return [1 + int(i) for i in np.argsort(-np.asarray(dist), kind="stable")]

    def _depth_with_solid(self, ghost: Rect, solid: Rect, solid_depth: NDArray[np.float32]) -> NDArray[np.float32]:
        """Static depth under the ghost's rectangle with the solid robot's nearer pixels in it."""
        gx0, gy0, gx1, gy1 = ghost
        sx0, sy0 = solid[0], solid[1]
        behind = self.depth[gy0:gy1, gx0:gx1].copy()
        ix0, iy0 = max(gx0, sx0), max(gy0, sy0)
        ix1, iy1 = min(gx1, solid[2]), min(gy1, solid[3])
        sub = behind[iy0 - gy0 : iy1 - gy0, ix0 - gx0 : ix1 - gx0]
        np.maximum(sub, solid_depth[iy0 - sy0 : iy1 - sy0, ix0 - sx0 : ix1 - sx0], out=sub)
        return behind

    # ---- frames ---------------------------------------------------------------------------------
    def frame(self, k: int, out: Frame) -> Frame:
        """Draw frame ``k`` into ``out`` ((H, W, 3) uint8) and return it."""
        r = self.replay
        r.pose_frame(k)
        self._advance_trails(k)
        np.copyto(out, self.layer)
        for ti, tr in enumerate(r.tracks):  # the unfinished segment: last kept point to the robot
            j = int(tr.idx[k])
            upto = int(np.searchsorted(tr.trail_keep, j, side="right"))
            if upto and tr.trail_keep[upto - 1] != j:
                pts = self._trail_px[ti][[int(tr.trail_keep[upto - 1]), j]]
                draw_polyline(out, pts, rgb255(tr.rgba), trail_width(ti, self.replay.line_width))
        self._robots(out)
        r.draw_overlay(k, out)
        return out
