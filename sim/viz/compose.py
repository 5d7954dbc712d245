"""Frames of a fixed camera composited from a cached floor layer and small passes for the robots.

With the overview camera nothing but the robots moves, and in the fast look (no shadows, no
reflections) a robot changes no pixel outside its own silhouette. So the world is drawn once:

1. **static pass** (once per video): MuJoCo draws the static geoms (floor, walls, obstacles, sky)
   and the colour and depth buffers are read back; the reference path is drawn onto the colour
   image with PIL. This image, the *floor layer*, also collects the trails: each frame adds only the
   segments its robots completed since the previous frame (a few pixels wide crops).
2. **robot passes** (each frame), each through a small viewport around the rectangle a robot's
   bounding box projects to: MuJoCo draws the solid robot's dynamic geoms and the rectangle is read
   back, colour and depth; a solid-robot pixel replaces the floor-layer pixel where it is nearer
   than the static depth. Each ghost is drawn twice, translucent as in the full render, behind the
   walls, obstacles and solid robot that overlap its rectangle drawn black (they hide what lies
   behind them, as in MuJoCo): once in its colour, which gives its premultiplied colour ``P``, once
   white and glowing, which gives its coverage ``1 - T``. MuJoCo's blend is linear in what lies
   behind, so the ghost over the frame is ``P + T * frame``: MuJoCo's own pixels, within the
   rounding of the two reads, with the trails under the tint. Ghosts whose rectangles overlap are
   drawn together, so their geoms are sorted by depth together as in MuJoCo's full render.
3. the unfinished segment of each trail.

The same camera drawn at a finer scale (a view larger than the renderer's buffer, its static pass
drawn in tiles) and shown through a window that follows a robot is the video's close-up inset.

The picture matches a full MuJoCo render of the scene pixel for pixel on the world and the solid
robot, and within the rounding of the reads on the ghosts. Trails pass under the ghosts' tints and
the solid robot, as they would lie on the floor. Trails are drawn in frame order, whatever order
the frames are asked in, so a frame's pixels do not depend on which frames were drawn before it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

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
    aabb_corners,
    geom_box_corners,
    ghost_rgb,
    light_gain,
    polylines,
    rgb255,
    trail_width,
)

Rect = tuple[int, int, int, int]  # x0, y0, x1, y1 [px], image coordinates, end exclusive
GhostLayer = tuple[NDArray[np.float32], NDArray[np.float32]]  # premultiplied colour, transmission

#: Pixels added around each robot's projected bounding box.
RECT_MARGIN = 2

#: Emission of the white pass of a ghost: its colour saturates to white whatever the lights.
WHITE_EMISSION = 10.0

_BLACK = np.array([0.0, 0.0, 0.0, 1.0], dtype=np.float32)

#: How far the occluders of a ghost pass are set back along the view [m]: where a ghost's face and
#: the solid robot's lie in one plane (two runs at the same pose) the ghost shows, in every frame
#: alike, rather than a pattern of depth rounding that changes with the pixel's place.
OCCLUDER_SETBACK = 1e-5


@dataclass(frozen=True)
class Occluder:
    """A static geom that can hide part of a ghost, as the ghost passes draw it (black).

    Attributes:
        type: Geom type (``mjtGeom``).
        size: (3,) its scene size.
        pos: (3,) position [m].
        mat: (9,) orientation, row major.
        dataid: Its scene ``dataid`` (the mesh drawn, for meshes).
        rect: The rectangle of the image its bounding box projects to.
    """

    type: int
    size: FloatArray
    pos: FloatArray
    mat: FloatArray
    dataid: int
    rect: Rect


def static_occluders(
    model: mujoco.MjModel, data: mujoco.MjData, scene: mujoco.MjvScene, proj: Projection
) -> list[Occluder]:
    """The static geoms of a scene (after ``mjv_updateScene`` of the static category) that can hide part
    of a robot: all but planes, on which the robots stand and which hide nothing above them.

    Args:
        model: The scene's model.
        data: A state of it (after kinematics: where the static geoms are).
        scene: The static scene.
        proj: Its view.
    """
    out = []
    for i in range(scene.ngeom):
        g = scene.geoms[i]
        if g.type == mujoco.mjtGeom.mjGEOM_PLANE or g.objtype != mujoco.mjtObj.mjOBJ_GEOM:
            continue
        ids = np.array([g.objid], dtype=np.int64)
        px, ok = proj.pixels(geom_box_corners(data, ids, aabb_corners(model, ids))[0])
        lo, hi = np.floor(px.min(axis=0)).astype(int) - 1, np.ceil(px.max(axis=0)).astype(int) + 2
        rect = (int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1])) if ok.all() else (0, 0, proj.width, proj.height)
        size, pos, mat = (np.array(v, dtype=float) for v in (g.size, g.pos, g.mat))
        out.append(Occluder(int(g.type), size, pos, mat.ravel(), int(g.dataid), rect))
    return out


class ComposedReplay(Protocol):
    """What the compositor reads from a replay (:class:`sim.viz.replay.Replay` is one).

    Attributes:
        model: The runs' model.
        ghost_model: The model with the robot's enclosed geoms left out (drawn for every robot pass).
        datas: One ``MjData`` per track, posed by :meth:`pose_frame`.
        tracks: The runs, the solid one first, then the ghosts.
        camera: The camera (the compositor's default).
        fixed_camera: Whether the camera stays put (required of a default camera).
        ref3: (M, 3) decimated reference path on the floor [m].
        trail3: Per track, (N, 3) logged path on the floor [m].
        line_width: Width of the reference line [px].
        required_geoms: Scene capacity.
        robot_geoms: (G,) visible geoms of the robot.
        robot_corners: (G, 8, 3) their bounding-box corners in their own frames [m].
        times: (F,) the frames' times [s].
    """

    model: mujoco.MjModel
    times: FloatArray
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


Frustum = tuple[float, float, float, float]  # centre, half width, bottom, top at the near plane [m]


def eye_frusta(scene: mujoco.MjvScene, size: tuple[int, int]) -> list[Frustum]:
    """Each eye's frustum (after ``mjv_updateScene``) as ``mjr_render`` draws it on a view of ``size``
    (width, height) [px]: its width fitted to the view's aspect."""
    w, h = size
    out = []
    for c in scene.camera:
        half_w = 0.5 * float(c.frustum_top - c.frustum_bottom) * w / h
        out.append((float(c.frustum_center), half_w, float(c.frustum_bottom), float(c.frustum_top)))
    return out


def narrow_frustum(scene: mujoco.MjvScene, frusta: Sequence[Frustum], size: tuple[int, int], rect: Rect) -> None:
    """Narrow each eye of ``scene`` to what a view of ``size`` (width, height) [px] with frusta ``frusta``
    (:func:`eye_frusta`) shows through ``rect``: drawn into a viewport of the rectangle's size, the
    picture is that rectangle of the view, pixel centre for pixel centre."""
    x0, y0, x1, y1 = rect
    w, h = size
    for eye, (center, half_w, bottom, top) in zip(scene.camera, frusta, strict=True):
        du = 2.0 * half_w / w
        dv = (top - bottom) / h
        eye.frustum_center = center - half_w + 0.5 * (x0 + x1) * du
        eye.frustum_top = top - y0 * dv
        eye.frustum_bottom = top - y1 * dv


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


def merge_rects(rects: Mapping[int, Rect]) -> list[tuple[Rect, list[int]]]:
    """Group rectangles that overlap, directly or through others, or through the rectangle that
    bounds a group: ghosts whose rectangles overlap are drawn together (their geoms sorted by
    depth together, as in the full render) and groups never overlap, so their order does not matter.

    Args:
        rects: Key (a track) -> rectangle.

    Returns:
        (bounding rectangle, keys in the given order) per group, in the order of each group's first key.
    """
    groups = [(rect, [key]) for key, rect in rects.items()]
    i = 0
    while i < len(groups):
        j = next((j for j in range(len(groups)) if j != i and _overlap(groups[i][0], groups[j][0])), None)
        if j is None:
            i += 1
            continue
        (a, ka), (b, kb) = groups[min(i, j)], groups[max(i, j)]
        del groups[max(i, j)]
        bound = (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))
        groups[min(i, j)] = (bound, ka + kb)
        i = 0  # the larger rectangle may now overlap one already passed
    order = list(rects)
    return [(rect, sorted(keys, key=order.index)) for rect, keys in groups]


class RobotPass:
    """Draws robots' dynamic geoms through rectangles of the image, each into a small viewport.

    The frustum is narrowed to the rectangle and the viewport shrunk to its size, so MuJoCo clears
    and rasterises only those pixels (the same pixel centres as the full view). The passes of a
    frame are queued side by side in the off-screen buffer and read back at once (:meth:`read`).

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
        self._gain = light_gain(model)  # the lights it draws with
        self.size = (renderer.width, renderer.height)
        self._frustum: list[Frustum] = []
        self._queued: list[tuple[int, int, int, int]] = []  # x, y, width, height in the buffer [px]
        self._results: list[tuple[Frame, NDArray[np.float32]]] = []

    def view(self, data: mujoco.MjData, camera: mujoco.MjvCamera, size: tuple[int, int] | None = None) -> Projection:
        """Take the camera and lights of a frame (no geoms) for a view of ``size`` (width, height) [px],
        the renderer's size by default (a view may be larger: rectangles of it are drawn); returns the
        view's projection."""
        mujoco.mjv_updateScene(self.model, data, self.opt, self.pert, camera, 0, self.scene)
        self.size = size or (self.renderer.width, self.renderer.height)
        self._frustum = eye_frusta(self.scene, self.size)
        return Projection.from_scene(self.scene, *self.size)

    def rect(
        self,
        proj: Projection,
        data: mujoco.MjData,
        geoms: NDArray[np.int64],
        corners: FloatArray,
        bounds: Rect | None = None,
    ) -> Rect | None:
        """Pixel rectangle holding the projected bounding boxes of ``geoms``, or None when off screen.

        Args:
            proj: The view.
            data: The robot's state.
            geoms: (G,) geom ids.
            corners: (G, 8, 3) bounding-box corners of each geom in its own frame [m].
            bounds: The part of the view drawn (the rectangle is clipped to it); None for the whole view.
        """
        px, ok = proj.pixels(geom_box_corners(data, geoms, corners).reshape(-1, 3))
        bx0, by0, bx1, by1 = bounds or (0, 0, *self.size)
        if not ok.all():
            return (bx0, by0, bx1, by1)
        x0 = max(bx0, int(np.floor(px[:, 0].min())) - RECT_MARGIN)
        y0 = max(by0, int(np.floor(px[:, 1].min())) - RECT_MARGIN)
        x1 = min(bx1, int(np.ceil(px[:, 0].max())) + RECT_MARGIN + 1)
        y1 = min(by1, int(np.ceil(px[:, 1].max())) + RECT_MARGIN + 1)
        return (x0, y0, x1, y1) if x1 > x0 and y1 > y0 else None

    # ---- queued passes: drawn side by side into the off-screen buffer, read back at once -------------
    def queue(self, data: mujoco.MjData, rect: Rect) -> int:
        """Queue the robot of ``data``, opaque, as seen through ``rect`` (after :meth:`view`).

        Returns:
            Its slot in what :meth:`read` returns (colour and depth).
        """
        scn = self.scene
        scn.ngeom = 0
        mujoco.mjv_addGeoms(self.model, data, self.opt, self.pert, mujoco.mjtCatBit.mjCAT_DYNAMIC, scn)
        return self._draw(rect)

    def queue_ghosts(
        self,
        datas: Sequence[mujoco.MjData],
        rect: Rect,
        colors: Sequence[tuple[float, ...]],
        solid: mujoco.MjData | None = None,
        occluders: Sequence[Occluder] = (),
    ) -> tuple[int, int]:
        """Queue robots as translucent ghosts, one colour each (as the full render does: dimmed by
        :func:`sim.viz.scene.ghost_rgb`, alpha :data:`sim.viz.scene.GHOST_ALPHA`), through ``rect``,
        in front of the ``occluders`` and the ``solid`` robot drawn black (they hide the ghosts' parts
        behind them, as in the full render). Ghosts drawn together are sorted geom by geom, as in
        the full render. Two passes: in their colours, then white and glowing.

        Args:
            datas: The ghosts' states.
            rect: The rectangle.
            colors: RGB(A) in [0, 1] of each ghost.
            solid: The solid robot's state, or None where it cannot hide a ghost.
            occluders: Static geoms that can hide a ghost in ``rect``.

        Returns:
            The slots of the two passes in what :meth:`read` returns; :func:`ghost_layer` of their
            colours is the ghosts' premultiplied colour and transmission (see
            :meth:`FixedViewCompositor._ghost_pass`).
        """
        scn = self.scene
        scn.ngeom = 0
        add = mujoco.mjv_addGeoms
        for o in occluders:
            mujoco.mjv_initGeom(scn.geoms[scn.ngeom], o.type, o.size, o.pos, o.mat, _BLACK)
            scn.geoms[scn.ngeom].dataid = o.dataid
            scn.ngeom += 1
        if solid is not None:
            add(self.model, solid, self.opt, self.pert, mujoco.mjtCatBit.mjCAT_DYNAMIC, scn)
        back = OCCLUDER_SETBACK * np.asarray(scn.camera[0].forward, dtype=np.float32)
        for i in range(scn.ngeom):  # black: they hide the ghosts' parts behind them and add nothing
            g = scn.geoms[i]
            g.rgba, g.emission, g.specular, g.reflectance = _BLACK, 0.0, 0.0, 0.0
            g.pos[:] = g.pos + back
        ghosts = []
        for data, color in zip(datas, colors, strict=True):
            first = scn.ngeom
            add(self.model, data, self.opt, self.pert, mujoco.mjtCatBit.mjCAT_DYNAMIC, scn)
            tint = (*ghost_rgb(color, self._gain), GHOST_ALPHA)
            for i in range(first, scn.ngeom):
                scn.geoms[i].rgba = tint
                ghosts.append(scn.geoms[i])
        tinted = self._draw(rect)
        for g in ghosts:
            g.rgba, g.emission = (1.0, 1.0, 1.0, GHOST_ALPHA), WHITE_EMISSION
        lights, scn.nlight = scn.nlight, 0  # white whatever the light: no lighting to compute
        white = self._draw(rect)
        scn.nlight = lights
        return tinted, white

    def read(self) -> list[tuple[Frame, NDArray[np.float32]]]:
        """Colour and depth (row 0 at the top) of every pass queued since the last read, by slot."""
        self._flush()
        out, self._results = self._results, []
        return out

    def draw(self, data: mujoco.MjData, rect: Rect) -> tuple[Frame, NDArray[np.float32]]:
        """:meth:`queue` and :meth:`read` one robot: its colour and depth."""
        slot = self.queue(data, rect)
        return self.read()[slot]

    def _draw(self, rect: Rect) -> int:
        """Draw the scene's geoms as seen through ``rect`` into the next free place of the off-screen
        buffer (rows of places from its bottom-left corner; read back first when it is full)."""
        x0, y0, x1, y1 = rect
        w, h = self.renderer.width, self.renderer.height
        pw, ph = x1 - x0, y1 - y0
        if self._x + pw > w:  # a new row
            self._x, self._y, self._row = 0, self._y + self._row, 0
        if self._y + ph > h:
            self._flush()
        narrow_frustum(self.scene, self._frustum, self.size, rect)
        self.renderer.draw(self.scene, (pw, ph), origin=(self._x, self._y))
        self._queued.append((self._x, self._y, pw, ph))
        self._x += pw
        self._row = max(self._row, ph)
        return len(self._results) + len(self._queued) - 1

    def _flush(self) -> None:
        """Read back every queued place at once (one read costs far more than its pixels)."""
        if self._queued:
            h = self.renderer.height
            top = max(y + ph for _, y, _, ph in self._queued)
            right = max(x + pw for x, _, pw, _ in self._queued)
            rgb = np.empty((top, right, 3), np.uint8)
            depth = np.empty((top, right), np.float32)
            self.renderer.read((0, h - top, right, h), rgb, depth)  # rows flipped: row 0 is GL row top - 1
            for x, y, pw, ph in self._queued:
                rows = slice(top - y - ph, top - y)
                self._results.append((rgb[rows, x : x + pw], depth[rows, x : x + pw]))
        self._queued = []
        self._x = self._y = self._row = 0

    _x: int = 0
    _y: int = 0
    _row: int = 0


def ghost_layer(tinted: Frame, white: Frame) -> GhostLayer:
    """A ghost pass pair as premultiplied colour ``P`` ((h, w, 3), [0, 255]) and transmission ``T``
    ((h, w), in [0, 1], 1 where no ghost is): the ghosts over an image ``I`` are ``P + T * I``.

    Args:
        tinted: (h, w, 3) the ghosts in their colours over black.
        white: (h, w, 3) the ghosts white and glowing over black (their coverage ``1 - T``).
    """
    return tinted.astype(np.float32), 1.0 - white[..., 0].astype(np.float32) / 255.0


def blend_ghost(out: Frame, rect: Rect, premult: NDArray[np.float32], transmission: NDArray[np.float32]) -> None:
    """Lay ghosts over ``out`` in place: ``P + T * out`` in their rectangle (see :func:`ghost_layer`).

    Args:
        out: (H, W, 3) image.
        rect: The ghost's rectangle (x0, y0, x1, y1).
        premult: (h, w, 3) its premultiplied colour ``P`` [0, 255].
        transmission: (h, w) its transmission ``T`` in [0, 1].
    """
    x0, y0, x1, y1 = rect
    dst = out[y0:y1, x0:x1]
    mixed = premult + transmission[..., None] * dst
    np.copyto(dst, np.clip(np.rint(mixed), 0, 255).astype(np.uint8))


@dataclass(frozen=True)
class Pending:
    """The robots' passes of one frame of a view, queued and waiting to be read back.

    Attributes:
        window: The part of the view drawn.
        solid: The solid robot's rectangle (view pixels), or None when it is out of the window.
        solid_slot: Its pass's slot in what :meth:`RobotPass.read` returns.
        ghost_rects: The rectangle of each group of ghosts.
        ghost_slots: The slots of each group's two passes (tinted, white).
    """

    window: Rect
    solid: Rect | None
    solid_slot: int
    ghost_rects: list[Rect]
    ghost_slots: list[tuple[int, int]]


class FixedViewCompositor:
    """Draws a replay's frames for a camera that does not move (see the module docstring), whole or
    through a window.

    Args:
        replay: The replay.
        renderer: The open renderer, without shadows or reflections.
        camera: The fixed camera; None for the replay's, which must then stay put.
        size: (width, height) [px] of the view; None for the renderer's. A view larger than the
            renderer's buffer is drawn in tiles (its static pass) and shown through windows
            (:meth:`frame`): the same camera at a finer scale, a magnifying glass.
        line_width: Width of the reference line [px]; None for the replay's.
        flags: Render flags (``mjtRndFlag``); None for the renderer's.
        passes: A :class:`RobotPass` to share with another compositor of the same renderer and
            flags (their passes are then read back at once); None for its own.

    Raises:
        ValueError: No camera given and the replay's moves, or the flags draw shadows or reflections.
    """

    def __init__(
        self,
        replay: ComposedReplay,
        renderer: SceneRenderer,
        camera: mujoco.MjvCamera | None = None,
        size: tuple[int, int] | None = None,
        line_width: int | None = None,
        flags: NDArray[np.uint8] | None = None,
        passes: RobotPass | None = None,
    ) -> None:
        if camera is None and not replay.fixed_camera:
            raise ValueError("the compositor needs a camera that stays put (the overview camera)")
        flags = renderer.scene.flags if flags is None else flags
        if flags[mujoco.mjtRndFlag.mjRND_SHADOW] or flags[mujoco.mjtRndFlag.mjRND_REFLECTION]:
            raise ValueError("the compositor cannot draw shadows or reflections: use the full render")
        self.replay = replay
        self.renderer = renderer
        self.camera = camera if camera is not None else replay.camera
        self.size = size or (renderer.width, renderer.height)
        self.line_width = line_width or replay.line_width
        #: What the close-up draws over its frames (:class:`sim.viz.scan_overlay.ScanOverlay`), set by the replay.
        self.scan_overlay: Any = None
        self._opt = mujoco.MjvOption()
        self._pert = mujoco.MjvPerturb()
        self._scene = mujoco.MjvScene(replay.model, maxgeom=replay.required_geoms)
        self._scene.flags[:] = flags
        replay.pose_frame(0)
        # static pass: the world, read back whole, colour and depth
        static = mujoco.mjtCatBit.mjCAT_STATIC
        mujoco.mjv_updateScene(replay.model, replay.datas[0], self._opt, self._pert, self.camera, static, self._scene)
        self.proj = Projection.from_scene(self._scene, *self.size)
        self.occluders = static_occluders(replay.model, replay.datas[0], self._scene, self.proj)
        rgb, self.depth = self._static_pass()
        base = Image.fromarray(rgb)
        draw = ImageDraw.Draw(base)
        for line in polylines(*self.proj.pixels(replay.ref3)):
            draw.line(line, fill=rgb255(REFERENCE_RGBA), width=self.line_width)
        self._base: Frame = np.asarray(base).copy()
        # robots alone from here on, drawn through small rectangles
        self.passes = passes or RobotPass(replay.ghost_model, renderer, flags, replay.required_geoms)
        self._trail_px = [self.proj.pixels(t3)[0] for t3 in replay.trail3]
        self._reset_trails()

    def _static_pass(self) -> tuple[Frame, NDArray[np.float32]]:
        """Colour and depth of the static scene over the whole view, drawn in tiles of the renderer's size."""
        w, h = self.size
        bw, bh = self.renderer.width, self.renderer.height
        rgb = np.empty((h, w, 3), np.uint8)
        depth = np.empty((h, w), np.float32)
        frusta = eye_frusta(self._scene, self.size)
        for y0 in range(0, h, bh):
            for x0 in range(0, w, bw):
                rect = (x0, y0, min(w, x0 + bw), min(h, y0 + bh))
                tw, th = rect[2] - x0, rect[3] - y0
                narrow_frustum(self._scene, frusta, self.size, rect)
                self.renderer.draw(self._scene, (tw, th))
                tile_rgb, tile_depth = np.empty((th, tw, 3), np.uint8), np.empty((th, tw), np.float32)
                self.renderer.read((0, bh - th, tw, bh), tile_rgb, tile_depth)
                rgb[y0 : rect[3], x0 : rect[2]] = tile_rgb
                depth[y0 : rect[3], x0 : rect[2]] = tile_depth
        return rgb, depth

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
                    draw_polyline(self.layer, pts, rgb255(tr.rgba), trail_width(ti, self.line_width))
                    self._drawn[ti] = upto
        self._trail_k = max(self._trail_k, k)

    # ---- robots ---------------------------------------------------------------------------------
    def _rect(self, data: mujoco.MjData, bounds: Rect | None = None) -> Rect | None:
        return self.passes.rect(self.proj, data, self.replay.robot_geoms, self.replay.robot_corners, bounds)

    def _pass(self, rect: Rect) -> tuple[Frame, NDArray[np.float32]]:
        """Draw the solid robot through ``rect``: colour and depth."""
        return self.passes.draw(self.replay.datas[0], rect)

    def _ghost_pass(self, tracks: Sequence[int], rect: Rect, solid: Rect | None) -> GhostLayer:
        """Draw the ghosts of ``tracks`` through ``rect`` (the solid robot hiding them where ``solid``
        overlaps): their premultiplied colour and transmission."""
        tinted, white = self._queue_ghosts(tracks, rect, solid)
        res = self.passes.read()
        return ghost_layer(res[tinted][0], res[white][0])

    def _queue_ghosts(self, tracks: Sequence[int], rect: Rect, solid: Rect | None) -> tuple[int, int]:
        r = self.replay
        occluder = r.datas[0] if solid is not None and _overlap(solid, rect) else None
        statics = [o for o in self.occluders if _overlap(o.rect, rect)]
        datas = [r.datas[t] for t in tracks]
        return self.passes.queue_ghosts(datas, rect, [r.tracks[t].rgba for t in tracks], occluder, statics)

    def _queue_robots(self, window: Rect) -> Pending:
        """Queue the passes of every robot in ``window`` of the view (read back later, at once)."""
        r = self.replay
        self.passes.view(r.datas[0], self.camera, self.size)  # lights and eyes of this frame
        solid = self._rect(r.datas[0], window)
        solid_slot = self.passes.queue(r.datas[0], solid) if solid is not None else -1
        rects = {t: self._rect(r.datas[t], window) for t in range(1, len(r.datas))}
        groups = merge_rects({t: rc for t, rc in rects.items() if rc is not None})
        slots = [self._queue_ghosts(tracks, rect, solid) for rect, tracks in groups]
        return Pending(window, solid, solid_slot, [rect for rect, _ in groups], slots)

    def _lay_robots(self, out: Frame, pending: Pending, res: Sequence[tuple[Frame, NDArray[np.float32]]]) -> None:
        """Lay the passes of ``pending`` (read back into ``res``) over ``out``, the window's pixels."""
        ox, oy = pending.window[:2]
        if pending.solid is not None:
            x0, y0, x1, y1 = pending.solid
            rgb, solid_depth = res[pending.solid_slot]
            # reversed depth (MuJoCo's default): larger is nearer, 0 where nothing was drawn
            near = solid_depth > self.depth[y0:y1, x0:x1]
            out[y0 - oy : y1 - oy, x0 - ox : x1 - ox][near] = rgb[near]
        for rect, (tinted, white) in zip(pending.ghost_rects, pending.ghost_slots, strict=True):
            shifted = (rect[0] - ox, rect[1] - oy, rect[2] - ox, rect[3] - oy)
            blend_ghost(out, shifted, *ghost_layer(res[tinted][0], res[white][0]))

    # ---- frames ---------------------------------------------------------------------------------
    def frame(self, k: int, out: Frame, window: Rect | None = None) -> Frame:
        """Draw frame ``k`` of the view, or of its rectangle ``window``, into ``out`` ((h, w, 3) uint8,
        the window's size; it may be a view into a larger image) and return it."""
        pending = self.begin(k, out, window)
        self.finish(out, pending, self.passes.read())
        return out

    def begin(self, k: int, out: Frame, window: Rect | None = None) -> Pending:
        """The first half of :meth:`frame`: the world and trails into ``out``, the robots' passes
        queued. Compositors that share one :class:`RobotPass` read their passes back at once
        (``passes.read()``), then each calls :meth:`finish`."""
        r = self.replay
        win = window or (0, 0, *self.size)
        r.pose_frame(k)
        self._advance_trails(k)
        np.copyto(out, self.layer[win[1] : win[3], win[0] : win[2]])
        for ti, tr in enumerate(r.tracks):  # the unfinished segment: last kept point to the robot
            j = int(tr.idx[k])
            upto = int(np.searchsorted(tr.trail_keep, j, side="right"))
            if upto and tr.trail_keep[upto - 1] != j:
                pts = self._trail_px[ti][[int(tr.trail_keep[upto - 1]), j]] - win[:2]
                draw_polyline(out, pts, rgb255(tr.rgba), trail_width(ti, self.line_width))
        if self.scan_overlay is not None:  # the close-up's scan and particles (sim.viz.scan_overlay)
            self.scan_overlay.draw(out, self.proj, np.array(win[:2], dtype=float), float(r.times[k]), self.line_width)
        return self._queue_robots(win)

    def finish(self, out: Frame, pending: Pending, res: Sequence[tuple[Frame, NDArray[np.float32]]]) -> None:
        """The second half of :meth:`frame`: lay the robots read back into ``res`` over ``out``."""
        self._lay_robots(out, pending, res)
