"""Replay logged runs as video frames: world, reference path, the main robot solid, the others ghosts.

Physics runs first and is logged; this module replays the logs afterwards at the video frame rate.
Frame ``k`` shows simulation time ``t_start + k / fps`` and each robot at its log sample nearest to
that time, so a 20 s run at 30 frames/s has 600 frames whatever the log rate.

Drawing:

- MuJoCo draws the Simulator's compiled model (floor, obstacles, walls) and the main robot
  ("closed_loop" when logged, else the first run) from one ``MjData``, and every other run as a
  translucent ghost in its own colour (:data:`sim.viz.scene.RUN_STYLES`) from its own ``MjData``
  (``mjv_addGeoms`` of the dynamic geoms only, recoloured): a ghost is never simulated against
  anything, only drawn;
- the reference path and a trail behind each robot are lines on the floor, projected through the
  scene's camera and drawn into the image with PIL (as ``mjGEOM_LINE`` geoms, the few hundred
  segments a smooth path needs cost more than the whole scene under OSMesa), hidden where the solid
  robot stands;
- beside the world picture, never over it (:class:`sim.viz.panel.FrameLayout`): a close-up inset
  that follows the main robot (the overview camera magnified, seen through a moving window) and the
  text (the frame's own time, each run's current position error, in the run's colour).

With a camera that stays put (the overview) and no shadows or reflections (the fast look), the
world is drawn once per video and only the robots each frame, each through a small viewport,
composited by depth
(:mod:`sim.viz.compose`); the chase camera and the high look draw the whole scene every frame.

The process holds one OpenGL renderer at a time (:class:`sim.viz.renderer.SceneRenderer`), closed
explicitly. Modules import one way: this one imports :mod:`sim.viz.compose`, and both import
:mod:`sim.viz.scene` (colours, tracks, projection) and :mod:`sim.viz.renderer`.
"""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import mujoco
import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw

from planning.core.checks import check_number
from planning.errors import ConfigError, option
from planning.trajectory.trajectory import Trajectory
from sim.physics.metrics import position_errors
from sim.physics.runlog import RunLog
from sim.viz.compose import FixedViewCompositor, eye_frusta, narrow_frustum
from sim.viz.panel import FrameLayout, Rect, TextPanel, region
from sim.viz.renderer import QUALITIES, SceneRenderer
from sim.viz.scan_overlay import ScanOverlay
from sim.viz.scene import (
    GHOST_ALPHA,
    REFERENCE_RGBA,
    FloatArray,
    Frame,
    Projection,
    RunStyle,
    Track,
    aabb_corners,
    enclosed_geoms,
    geom_box_corners,
    ghost_rgb,
    light_gain,
    polylines,
    rgb255,
    run_styles,
    trail_width,
)

CAMERAS = ("overview", "chase")

#: The close-up inset spans about this many robot lengths: the robot is a sixth of its width.
INSET_ROBOTS = 6.0

#: Largest side [px] of the magnified view the inset looks through.
MAX_MAGNIFIED = 4096

#: Margin of the overview around the world, a share of the world picture's size on each side.
OVERVIEW_MARGIN = 0.02

#: Corner indices (of the 8 sign combinations, x slowest) of the 6 faces of a box.
_BOX_FACES = np.array([[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]])


@dataclass(frozen=True)
class RenderSettings:
    """How a video looks.

    Attributes:
        width: Frame width [px], even (H.264 with yuv420p needs even sizes).
        height: Frame height [px], even.
        fps: Frames per second of video (and of simulation time shown) [1/s].
        camera: "overview" (top-down, fixed, frames every run and the reference) or "chase".
        quality: "fast" (no shadows, reflections or multisampling) or "high" (shadows, reflections
            and the model's multisampling, about 4x slower under OSMesa).
    """

    width: int = 640
    height: int = 480
    fps: float = 30.0
    camera: str = "overview"
    quality: str = "fast"

    def __post_init__(self) -> None:
        even = "give an even number (H.264 with yuv420p needs even sizes)"
        for name in ("width", "height"):
            where = f"video {name} ({option('size', 'WIDTHxHEIGHT', python=f'RenderSettings.{name}')})"
            v = check_number(where, getattr(self, name), integer=True, at_least=16, at_most=4096, unit="pixels")
            if v % 2:
                raise ConfigError(f"{where} must be even, got {v}; {even}")
            object.__setattr__(self, name, v)  # a numpy integer as a plain one
        fps = check_number(option("fps"), self.fps, at_least=1.0, at_most=240.0, unit="frames/s")
        object.__setattr__(self, "fps", fps)
        self._check_level()
        if self.camera not in CAMERAS:
            raise ConfigError(f"unknown camera {self.camera!r}: choose one of {', '.join(CAMERAS)}")
        if self.quality not in QUALITIES:
            raise ConfigError(f"unknown quality {self.quality!r}: choose one of {', '.join(QUALITIES)}")

    def _check_level(self) -> None:
        """Refuse a size and frame rate beyond H.264 level 5.2 (:data:`LEVEL_52_FRAME_MBS`, :data:`LEVEL_52_MBS_PER_S`),
        naming the largest that fit."""
        mbs = math.ceil(self.width / 16) * math.ceil(self.height / 16)
        if mbs > LEVEL_52_FRAME_MBS:
            raise ConfigError(
                f"video size {self.width}x{self.height} is {mbs} macroblocks of 16x16 pixels a frame, more than H.264 "
                f"level 5.2's {LEVEL_52_FRAME_MBS} (4096x2304, 2304x4096, 3840x2160), above which players may refuse "
                f"the MP4; give a smaller {option('size', 'WIDTHxHEIGHT', python='RenderSettings.width, .height')}"
            )
        if mbs * self.fps > LEVEL_52_MBS_PER_S:
            most = LEVEL_52_MBS_PER_S // mbs
            raise ConfigError(
                f"{self.fps:g} frames/s at {self.width}x{self.height} is {mbs * self.fps:.0f} macroblocks a second, "
                f"more than H.264 level 5.2's {LEVEL_52_MBS_PER_S}, above which players may refuse the MP4; give "
                f"{option('fps', most)} or fewer, or a smaller {option('size', 'WIDTHxHEIGHT')}"
            )


#: H.264 level 5.2's limits (ITU-T H.264 Table A-1): macroblocks of 16 x 16 pixels a frame, and a second. Above
#: them x264 writes level 6.x (4096x2304 at 60 frames/s, 4096x4096 at 30: measured), which hardware decoders and
#: some browsers refuse; the MP4 is meant to play anywhere.
LEVEL_52_FRAME_MBS, LEVEL_52_MBS_PER_S = 36_864, 2_073_600


def set_camera(camera: mujoco.MjvCamera, params: FloatArray) -> None:
    """Set a free camera from (6,) lookat x, y, z [m], distance [m], azimuth, elevation [deg]."""
    lx, ly, lz, dist, az, el = (float(v) for v in params)
    camera.lookat[:] = (lx, ly, lz)
    camera.distance = dist
    camera.azimuth = az
    camera.elevation = el


def parse_size(text: str) -> tuple[int, int]:
    """Parse ``"WxH"`` (e.g. ``"640x480"``) into (width, height) [px].

    Raises:
        ConfigError: Not two positive integers separated by ``x``.
    """
    found = re.fullmatch(r"([0-9]+)\s*[x×]\s*([0-9]+)", text.strip().lower())  # int() also read 6_40, +640 and ６４０
    if found is None:
        raise ConfigError(f"--size must look like WIDTHxHEIGHT (e.g. 640x480), got {text!r}")
    return int(found.group(1)), int(found.group(2))


def frame_times(t_start: float, t_end: float, fps: float) -> FloatArray:
    """Simulation times shown by the frames of a video of ``[t_start, t_end]``.

    Frame ``k`` shows ``t_start + k / fps`` and is on screen for ``1 / fps``, and the last frame shows the run's
    end, ``t_end`` (where its final errors are measured): ``round((t_end - t_start) * fps) + 1`` frames, so the
    video lasts as long as the run and one frame more.

    Returns:
        (n,) times [s], increasing (one time, ``t_start``, for an empty run).
    """
    n = round((t_end - t_start) * fps)
    if n <= 0:
        return np.array([t_start])
    times = t_start + np.arange(n + 1) / fps
    times[-1] = t_end
    return times


def nearest_samples(t: FloatArray, times: FloatArray) -> NDArray[np.int64]:
    """Index of the sample of ``t`` (increasing, (N,)) nearest to each of ``times`` ((M,)), clamped."""
    j = np.clip(np.searchsorted(t, times), 1, len(t) - 1)
    left_closer = (times - t[j - 1]) <= (t[j] - times)
    return np.where(left_closer, j - 1, j).astype(np.int64) if len(t) > 1 else np.zeros(len(times), np.int64)


def decimate_path(xy: FloatArray, spacing: float) -> NDArray[np.int64]:
    """Indices of the points of a polyline kept so consecutive kept points are >= ``spacing`` apart.

    The first point is always kept (and the last, for a path of two or more points).

    Args:
        xy: (N, 2) points [m].
        spacing: Minimum distance between kept points [m].
    """
    keep = [0]
    last = xy[0]
    for i in range(1, len(xy)):
        if math.hypot(xy[i, 0] - last[0], xy[i, 1] - last[1]) >= spacing:
            keep.append(i)
            last = xy[i]
    if len(xy) > 1 and keep[-1] != len(xy) - 1:
        keep.append(len(xy) - 1)
    return np.asarray(keep, dtype=np.int64)


class Replay:
    """Draws the frames of a video of logged runs.

    The world, obstacles and robots are drawn by MuJoCo; the reference path and the trails are
    lines on the floor drawn into the image through the camera's projection (hundreds of line geoms
    would cost more than the whole scene), hidden where the solid robot stands. The world picture
    takes the left of the frame; the close-up and the text the panel on its right.

    Args:
        model: The runs' model (the Simulator's compiled model).
        trajectory: The reference (drawn on the floor).
        logs: Run label -> log, any number of runs: the main run ("closed_loop" when present,
            else the first) is drawn solid, every other run as a translucent ghost in its own
            colour (:func:`sim.viz.scene.run_styles`).
        settings: Size, frame rate, camera, quality.

    Attributes:
        times: (n,) simulation time of each frame [s].
        tracks: The runs as drawn, the main run first, then the others in the order given.
        required_geoms: Scene capacity needed (the model once per run, for the ghosts); open the
            :class:`SceneRenderer` with at least this ``max_geom``.
    """

    def __init__(
        self, model: mujoco.MjModel, trajectory: Trajectory, logs: Mapping[str, RunLog], settings: RenderSettings
    ) -> None:
        if not logs:
            raise ConfigError("nothing to render: no run logs were given")
        self.model = model
        self.settings = settings
        m = model
        for label, log in logs.items():
            if log.qpos.shape[1] != m.nq:
                raise ConfigError(f"log {label!r} has qpos of width {log.qpos.shape[1]} but the model has nq={m.nq}")
        main = "closed_loop" if "closed_loop" in logs else next(iter(logs))
        labels = [main] + [k for k in logs if k != main]
        t0 = min(float(logs[k].t[0]) for k in labels)
        t1 = max(float(logs[k].t[-1]) for k in labels)
        self.times = frame_times(t0, t1, settings.fps)

        self.layout = FrameLayout.of(settings.width, settings.height)
        #: (width, height) [px] of the world picture.
        self.world_size = FrameLayout.size(self.layout.world)
        # what the runs and the reference visit
        pts = np.vstack([trajectory.pose[:, :2]] + [logs[k].pose[:, :2] for k in labels])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        self._span = float(max(hi[0] - lo[0], hi[1] - lo[1], 0.5))
        spacing = self._span / 400.0
        styles = run_styles(labels)
        self.tracks = [self._track(k, logs[k], spacing, styles[k]) for k in labels]
        self.datas = [mujoco.MjData(m) for _ in self.tracks]
        for d, tr in zip(self.datas, self.tracks, strict=True):
            d.qpos[:] = tr.qpos[0]
            mujoco.mj_forward(m, d)
        self._robot_extent = self._robot_size(self.datas[0])
        self.robot_geoms, self.robot_corners = self._robot_boxes()
        #: The model with the robot's geoms that lie inside others left out (alpha 0), for the ghost
        #: (drawn translucent, a collision tyre inside the visual one would show through).
        self.ghost_model = copy.deepcopy(m)
        self.ghost_model.geom_rgba[enclosed_geoms(m, self.robot_geoms), 3] = 0.0
        self.option = mujoco.MjvOption()
        self.perturb = mujoco.MjvPerturb()
        ref_xy = trajectory.pose[:, :2]
        ref = ref_xy[decimate_path(ref_xy, spacing)]
        self.ref3 = np.column_stack([ref, np.zeros(len(ref))])
        self.trail3 = [np.column_stack([tr.xy, np.zeros(len(tr.xy))]) for tr in self.tracks]
        self.line_width = max(2, round(settings.height / 200))
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        #: The overview: top-down, fixed, framing the whole world and every run.
        self.overview_camera = mujoco.MjvCamera()
        self.overview_camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        overview = self._overview_params(lo, hi)
        set_camera(self.overview_camera, overview)
        self._cam_params = np.tile(overview, (self.n_frames, 1))
        if settings.camera == "chase":
            self._cam_params = self._chase_path(logs)
        #: The camera stays put: frames are composited from a cached world (:mod:`sim.viz.compose`).
        self.fixed_camera = bool(np.all(self._cam_params == self._cam_params[0]))
        self.required_geoms = int(len(self.tracks) * m.ngeom + 64)
        self.magnification, self.inset_view, self.inset_windows = self._inset_setup(logs[main])
        #: The main run's scan localiser, drawn in the close-up (None without one).
        self.scan_overlay = ScanOverlay.of(logs[main])
        self.inset_line_width = max(self.line_width, round(self.line_width * self.magnification / 2))
        self.panel = TextPanel(self.layout, self.tracks, self.times, self.magnification)

    def _track(self, label: str, log: RunLog, spacing: float, style: RunStyle) -> Track:
        """A run's log as the frames show it; its trail keeps points ``spacing`` [m] apart."""
        xy = log.pose[:, :2]
        return Track(
            label=label,
            idx=nearest_samples(log.t, self.times),
            qpos=log.qpos,
            xy=xy,
            err=position_errors(log),
            trail_keep=decimate_path(xy, spacing),
            rgba=style.rgba,
            name=style.name,
            ended=float(log.t[-1]) if log.status != "ok" else None,
        )

    @property
    def n_frames(self) -> int:
        """Number of frames."""
        return int(self.times.size)

    def _robot_size(self, d: mujoco.MjData) -> tuple[float, float]:
        """(footprint radius, height) of the robot's geoms around its root body [m]."""
        m = self.model
        base = self._base_body()
        rootpos = d.xpos[base]
        rad, top = 0.05, 0.1
        for g in range(m.ngeom):
            if not self._in_subtree(int(m.geom_bodyid[g]), base):
                continue
            r = float(m.geom_rbound[g])
            rad = max(rad, float(np.hypot(*(d.geom_xpos[g, :2] - rootpos[:2]))) + r)
            top = max(top, float(d.geom_xpos[g, 2]) + r)
        return rad, top

    def _robot_boxes(self) -> tuple[NDArray[np.int64], FloatArray]:
        """Visible geoms of the robot and the 8 corners of each one's bounding box in its frame."""
        m = self.model
        base = self._base_body()
        in_robot = [g for g in range(m.ngeom) if self._in_subtree(int(m.geom_bodyid[g]), base)]
        ids = np.asarray([g for g in in_robot if m.geom_group[g] < 3 and m.geom_rgba[g, 3] > 0], dtype=np.int64)
        return ids, aabb_corners(m, ids)

    def _base_body(self) -> int:
        m = self.model
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "base")
        if b < 0:  # the first body with a free joint
            b = next((int(m.jnt_bodyid[j]) for j in range(m.njnt) if m.jnt_type[j] == 0), 1)
        return int(b)

    def _in_subtree(self, body: int, root: int) -> bool:
        while body > 0 and body != root:
            body = int(self.model.body_parentid[body])
        return body == root

    # ---- cameras ---------------------------------------------------------------------------------
    def world_points(self, lo: FloatArray, hi: FloatArray) -> FloatArray:
        """(M, 3) points [m] the overview must show: the bounding-box corners of every static geom but
        the floor planes (walls, obstacles) and of the box the runs and the reference visit, widened by
        the robot's footprint and as high as the robot."""
        m, d = self.model, self.datas[0]
        static = [
            g
            for g in range(m.ngeom)
            if m.body_weldid[m.geom_bodyid[g]] == 0 and m.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE
        ]
        ids = np.asarray(static, dtype=np.int64)
        pts = [geom_box_corners(d, ids, aabb_corners(m, ids)).reshape(-1, 3)] if ids.size else []
        rad, top = self._robot_extent
        runs = np.array(
            [[x, y, z] for x in (lo[0] - rad, hi[0] + rad) for y in (lo[1] - rad, hi[1] + rad) for z in (0.0, top)]
        )
        return np.vstack([*pts, runs])

    def _overview_params(self, lo: FloatArray, hi: FloatArray) -> FloatArray:
        """(6,) lookat x, y, z, distance, azimuth, elevation of the overview: straight down, north up,
        high enough that every point of :meth:`world_points` lies inside the world picture with a
        margin of :data:`OVERVIEW_MARGIN` of its size on each side (a point at height z and horizontal
        offset r from the axis is seen at angle r / (distance - z))."""
        pts = self.world_points(lo, hi)
        w, h = self.world_size
        tan_half = math.tan(math.radians(self.model.vis.global_.fovy) / 2.0) * (1.0 - 2.0 * OVERVIEW_MARGIN)
        c = (pts[:, :2].min(axis=0) + pts[:, :2].max(axis=0)) / 2
        off = np.abs(pts[:, :2] - c)
        dist = float(np.max(pts[:, 2] + np.maximum(off[:, 0] / (tan_half * w / h), off[:, 1] / tan_half)))
        return np.array([c[0], c[1], 0.0, dist, 90.0, -90.0])

    def _chase_path(self, logs: Mapping[str, RunLog]) -> FloatArray:
        """(n, 6) per frame: lookat x, y, z, distance, azimuth, elevation of the chase camera.

        Behind the main robot, smoothed, looking at the middle of the runs' bounding box and pulled
        back by its diagonal so every ghost stays in view (two runs: their midpoint, their separation).
        """
        n = self.n_frames
        tan_half = math.tan(math.radians(self.model.vis.global_.fovy) / 2.0)
        out = np.empty((n, 6))
        main = self.tracks[0]
        p = main.xy[main.idx]
        th = logs[main.label].pose[main.idx, 2]
        xy = np.stack([tr.xy[tr.idx] for tr in self.tracks])  # (runs, n, 2)
        lo_k, hi_k = xy.min(axis=0), xy.max(axis=0)
        centre = (lo_k + hi_k) / 2
        spread = np.hypot(*(hi_k - lo_k).T)
        # exponential smoothing per frame: position 0.15 s, heading 0.3 s, spread 0.5 s
        alpha = 1.0 - np.exp(-1.0 / (self.settings.fps * np.array([0.15, 0.15, 0.3, 0.5])))
        state = np.array([p[0, 0], p[0, 1], th[0], 0.0])
        for k in range(n):
            target = np.array([centre[k, 0], centre[k, 1], th[k], spread[k]])
            state = target if k == 0 else state + alpha * (target - state)
            dist = max(6.0 * self._robot_extent[0], (state[3] / 2 + 3.0 * self._robot_extent[0]) / tan_half)
            out[k] = (state[0], state[1], 0.5 * self._robot_extent[1], dist, math.degrees(state[2]), -30.0)
        return out

    def projection(self, camera: mujoco.MjvCamera, size: tuple[int, int]) -> Projection:
        """The projection of ``camera`` onto a view of ``size`` (width, height) [px] (no GL needed)."""
        scene = mujoco.MjvScene(self.model, maxgeom=0)
        mujoco.mjv_updateScene(self.model, self.datas[0], self.option, self.perturb, camera, 0, scene)
        return Projection.from_scene(scene, *size)

    def _inset_setup(self, main: RunLog) -> tuple[float, tuple[int, int], NDArray[np.int64]]:
        """The close-up: the overview camera at ``m`` times the world picture's scale (a view ``m``
        times its size; the inset shows a window of it that follows the main robot), ``m`` such that
        the robot's longer side is :data:`INSET_ROBOTS` times smaller than the inset, at least 1 (at
        most :data:`MAX_MAGNIFIED` pixels a side).

        Returns:
            ``m``, the magnified view's (width, height) [px], (n, 4) the inset's window
            (x0, y0, x1, y1) in it per frame.
        """
        corners = geom_box_corners(self.datas[0], self.robot_geoms, self.robot_corners).reshape(-1, 3)
        x, y, yaw = main.pose[0]
        c, s = math.cos(yaw), math.sin(yaw)
        rel = corners[:, :2] - (x, y)
        body = np.column_stack([rel @ (c, s), rel @ (-s, c)])  # in the robot's frame
        length = float(np.ptp(body, axis=0).max())  # [m]
        px_per_m = self.projection(self.overview_camera, self.world_size).scale(np.array([x, y, 0.0]))
        iw, ih = FrameLayout.size(self.layout.inset)
        want = iw / INSET_ROBOTS / (length * px_per_m)
        mag = min(MAX_MAGNIFIED / max(self.world_size), max(1.0, want))
        view = (round(mag * self.world_size[0]), round(mag * self.world_size[1]))
        proj = self.projection(self.overview_camera, view)
        mid = 0.5 * self._robot_extent[1]
        #: (runs, n, 2) each robot's middle in the magnified view per frame [px].
        self.inset_centres = np.stack(
            [proj.pixels(np.column_stack([t.xy[t.idx], np.full(t.idx.size, mid)]))[0] for t in self.tracks]
        )
        px = self.inset_centres[0]
        x0 = np.clip(np.rint(px[:, 0] - iw / 2), 0, max(0, view[0] - iw)).astype(np.int64)
        y0 = np.clip(np.rint(px[:, 1] - ih / 2), 0, max(0, view[1] - ih)).astype(np.int64)
        return mag, view, np.column_stack([x0, y0, x0 + iw, y0 + ih])

    # ---- scene ----------------------------------------------------------------------------------
    def pose_frame(self, k: int) -> None:
        """Put each run's ``MjData`` at its log sample of frame ``k`` (kinematics) and the camera on it."""
        m = self.model
        for d, tr in zip(self.datas, self.tracks, strict=True):
            d.qpos[:] = tr.qpos[tr.idx[k]]
            mujoco.mj_kinematics(m, d)
            mujoco.mj_camlight(m, d)
        set_camera(self.camera, self._cam_params[k])

    def _update(self, r: SceneRenderer, k: int) -> None:
        """Pose frame ``k`` and fill the renderer's scene: the world and the solid robot seen by this
        frame's camera, and the ghosts."""
        self.pose_frame(k)
        r.renderer.update_scene(self.datas[0], camera=self.camera, scene_option=self.option)
        self._add_ghosts(r, r.scene)

    def _add_ghosts(self, r: SceneRenderer, scene: mujoco.MjvScene) -> None:
        """Add every run but the main one to ``scene`` as a translucent ghost in its colour."""
        dynamic = mujoco.mjtCatBit.mjCAT_DYNAMIC
        gain = light_gain(r.model)  # the renderer's lights (the high look dims them)
        for d, tr in zip(self.datas[1:], self.tracks[1:], strict=True):
            first = scene.ngeom
            mujoco.mjv_addGeoms(self.ghost_model, d, self.option, self.perturb, dynamic, scene)
            ghost = (*ghost_rgb(tr.rgba, gain), GHOST_ALPHA)
            for i in range(first, scene.ngeom):
                scene.geoms[i].rgba = ghost

    # ---- lines ----------------------------------------------------------------------------------
    def _decorate(self, proj: Projection, k: int, img: Frame, origin: Rect, line_width: int) -> None:
        """Draw the reference path and each run's trail of frame ``k`` into ``img``, the rectangle
        ``origin`` of the view ``proj`` projects onto, hidden where the solid robot stands."""
        shift = np.array(origin[:2], dtype=float)
        keep = self._robot_mask(proj, img, shift)
        pil = Image.fromarray(img)
        draw = ImageDraw.Draw(pil)
        px, ok = proj.pixels(self.ref3)
        for line in polylines(px - shift, ok):
            draw.line(line, fill=rgb255(REFERENCE_RGBA), width=line_width)
        for ti, tr in enumerate(self.tracks):
            j = int(tr.idx[k])
            upto = int(np.searchsorted(tr.trail_keep, j, side="right"))
            pts = np.vstack([self.trail3[ti][tr.trail_keep[:upto]], self.trail3[ti][j : j + 1]])
            px, ok = proj.pixels(pts)
            for line in polylines(px - shift, ok):
                draw.line(line, fill=rgb255(tr.rgba), width=trail_width(ti, line_width))
        img[:] = np.asarray(pil)
        if keep is not None:  # the solid robot hides the lines under it
            ys, xs, mask, saved = keep
            img[ys, xs][mask] = saved[mask]

    def _robot_mask(
        self, proj: Projection, frame: Frame, shift: FloatArray
    ) -> tuple[slice, slice, NDArray[np.bool_], Frame] | None:
        """The solid robot's silhouette (union of its geoms' projected bounding boxes, shifted by
        ``-shift`` [px]) and its pixels in ``frame``."""
        g = self.robot_geoms
        px, ok = proj.pixels(geom_box_corners(self.datas[0], g, self.robot_corners).reshape(-1, 3))
        if not ok.all():
            return None
        px = px - shift
        h, w = frame.shape[:2]
        x0, y0 = np.floor(px.min(axis=0)).astype(int) - 1
        x1, y1 = np.ceil(px.max(axis=0)).astype(int) + 2
        x0, y0, x1, y1 = max(0, x0), max(0, y0), min(w, x1), min(h, y1)
        if x1 <= x0 or y1 <= y0:
            return None
        mask_img = Image.new("L", (x1 - x0, y1 - y0), 0)
        draw = ImageDraw.Draw(mask_img)
        quads = (px.reshape(len(g), 8, 2) - (x0, y0))[:, _BOX_FACES]  # (G, 6, 4, 2)
        for quad in quads.reshape(-1, 4, 2).tolist():
            draw.polygon([tuple(q) for q in quad], fill=255)
        mask = np.asarray(mask_img) > 0
        return slice(y0, y1), slice(x0, x1), mask, frame[y0:y1, x0:x1].copy()

    # ---- frames ---------------------------------------------------------------------------------
    def composited(self, renderer: SceneRenderer) -> bool:
        """Whether the world picture is composited from a world drawn once (:mod:`sim.viz.compose`):
        with a camera that stays put and a renderer without shadows or reflections (robots change no
        other pixel). The close-up is always composited."""
        return self.fixed_camera and not lit(renderer)

    def render_frame(self, renderer: SceneRenderer, k: int, out: Frame | None = None) -> Frame:
        """Draw frame ``k``: the world picture, the close-up inset and the text (:class:`FrameLayout`).

        Args:
            renderer: The open renderer, made for this replay's model and size with
                ``max_geom >= required_geoms``.
            k: Frame index in [0, n_frames).
            out: (height, width, 3) uint8 buffer to draw into, or None for a new one.

        Returns:
            The frame.
        """
        if not 0 <= k < self.n_frames:
            raise IndexError(f"frame {k} out of range [0, {self.n_frames})")
        if (renderer.width, renderer.height) != (self.settings.width, self.settings.height):
            raise ConfigError("the renderer's size differs from the render settings")
        if renderer.scene.maxgeom < self.required_geoms:
            raise ConfigError(
                f"the renderer holds {renderer.scene.maxgeom} geoms, the replay needs {self.required_geoms}"
            )
        if out is None:
            out = np.empty((self.settings.height, self.settings.width, 3), dtype=np.uint8)
        world, inset = region(out, self.layout.world), region(out, self.layout.inset)
        main, close = self._compositors(renderer)
        x0, y0, x1, y1 = (int(v) for v in self.inset_windows[k])
        if main is not None:  # both composited, their passes read back at once
            pending = main.begin(k, world)
            pending_inset = close.begin(k, inset, (x0, y0, x1, y1))
            res = main.passes.read()
            main.finish(world, pending, res)
            close.finish(inset, pending_inset, res)
        else:
            self._update(renderer, k)
            self._draw_view(renderer, renderer.scene, self.world_size, (0, 0, *self.world_size), world)
            proj = Projection.from_scene(renderer.scene, *self.world_size)
            self._decorate(proj, k, world, (0, 0, *self.world_size), self.line_width)
            close.frame(k, inset, (x0, y0, x1, y1))
        self._point_to_far_ghosts(k, inset)
        self.panel.draw(k, out)
        return out

    def _compositors(self, renderer: SceneRenderer) -> tuple[FixedViewCompositor | None, FixedViewCompositor]:
        """The world picture's compositor (None when it is drawn whole) and the close-up's, made for
        ``renderer`` on first use. The close-up is composited in the fast look whatever the
        renderer's (shadows and reflections would cost a whole render a frame for a picture of the
        robots), sharing the world picture's robot passes when it has them."""
        if self._inset is not None and self._inset.renderer is renderer:
            return self._compositor, self._inset
        self._compositor = None
        if self.composited(renderer):
            self._compositor = FixedViewCompositor(self, renderer, size=self.world_size)
        flags = np.array(renderer.scene.flags)
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        view, width = self.inset_view, self.inset_line_width
        passes = self._compositor.passes if self._compositor is not None else None
        self._inset = FixedViewCompositor(self, renderer, self.overview_camera, view, width, flags, passes)
        self._inset.scan_overlay = self.scan_overlay
        return self._compositor, self._inset

    def _point_to_far_ghosts(self, k: int, out: Frame) -> None:
        """Draw, for each ghost whose middle is outside frame ``k``'s close-up, an arrowhead in its
        colour on the close-up's edge, pointing at it from the middle of the close-up."""
        h, w = out.shape[:2]
        half = np.array([w / 2.0, h / 2.0])
        size = max(6.0, w / 14.0)  # arrowhead length [px]
        heads = []
        for ti in range(1, len(self.tracks)):
            d = self.inset_centres[ti, k] - self.inset_windows[k, :2] - half
            if np.all(np.abs(d) <= half) or not np.all(np.isfinite(d)):
                continue
            u = d / float(np.hypot(*d))
            tip = half + d * float(np.min((half - 2.0) / np.maximum(np.abs(d), 1e-9)))
            side = np.array([-u[1], u[0]]) * 0.6 * size
            base = tip - u * size
            heads.append(([tuple(tip), tuple(base + side), tuple(base - side)], rgb255(self.tracks[ti].rgba)))
        if heads:
            img = Image.fromarray(out)
            draw = ImageDraw.Draw(img)
            for points, rgb in heads:
                draw.polygon(points, fill=rgb, outline=(20, 20, 20))
            out[:] = np.asarray(img)

    @staticmethod
    def _draw_view(r: SceneRenderer, scene: mujoco.MjvScene, view: tuple[int, int], window: Rect, out: Frame) -> None:
        """Draw the rectangle ``window`` of a view of ``scene`` of size ``view`` (width, height) [px]
        into ``out`` (the window's size), through a viewport at the buffer's bottom-left corner."""
        narrow_frustum(scene, eye_frusta(scene, view), view, window)
        w, h = window[2] - window[0], window[3] - window[1]
        r.draw(scene, (w, h))
        rgb = np.empty((h, w, 3), np.uint8)
        r.read((0, r.height - h, w, r.height), rgb, None)
        np.copyto(out, rgb)

    _compositor: FixedViewCompositor | None = None
    _inset: FixedViewCompositor | None = None


def lit(renderer: SceneRenderer) -> bool:
    """Whether the renderer draws shadows or reflections (a robot then changes pixels outside itself)."""
    flags = renderer.scene.flags
    return bool(flags[mujoco.mjtRndFlag.mjRND_SHADOW] or flags[mujoco.mjtRndFlag.mjRND_REFLECTION])


class FrameSink(Protocol):
    """Where frames go: a buffer to draw into, then hand it over (see :class:`sim.viz.video.VideoWriter`)."""

    def frame_buffer(self) -> Frame:
        """A (height, width, 3) uint8 buffer to draw the next frame into."""
        ...

    def submit(self, frame: Frame) -> None:
        """Take a drawn frame (the buffer from :meth:`frame_buffer`)."""
        ...


def render_frames(
    replay: Replay, renderer: SceneRenderer, sink: FrameSink, progress: Callable[[int], Any] | None = None
) -> int:
    """Draw every frame of a replay into a sink, in order.

    Args:
        replay: The replay.
        renderer: The open renderer (see :meth:`Replay.render_frame`).
        sink: Receives each frame as soon as it is drawn (an encoder runs alongside).
        progress: Called with 1 after each frame (e.g. ``tqdm.update``).

    Returns:
        Number of frames drawn.
    """
    for k in range(replay.n_frames):
        buf = sink.frame_buffer()
        replay.render_frame(renderer, k, buf)
        sink.submit(buf)
        if progress is not None:
            progress(1)
    return replay.n_frames


class ListSink:
    """A :class:`FrameSink` that keeps copies of the frames in memory (for tests and notebooks)."""

    def __init__(self, width: int, height: int) -> None:
        self.frames: list[Frame] = []
        self._shape = (height, width, 3)

    def frame_buffer(self) -> Frame:
        """A new buffer."""
        return np.empty(self._shape, dtype=np.uint8)

    def submit(self, frame: Frame) -> None:
        """Keep the frame."""
        self.frames.append(frame)
