"""What a video frame is made of, shared by the full render (:mod:`sim.viz.replay`) and the
fixed-view compositor (:mod:`sim.viz.compose`): colours, the runs' tracks, the camera's projection
of world points into the image, and the robot geometry both draw from.

This module imports neither of them: replay imports compose, and both import this module.
"""

from __future__ import annotations

import colorsys
from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Frame = NDArray[np.uint8]

#: Colours (RGBA in [0, 1]).
REFERENCE_RGBA = (0.10, 0.55, 0.25, 1.0)
CLOSED_RGBA = (0.10, 0.35, 0.95, 1.0)
OPEN_RGBA = (1.00, 0.50, 0.10, 1.0)
ODOMETRY_RGBA = (0.58, 0.22, 0.85, 1.0)
#: Feedback on the true pose: teal, apart from the reference path's green.
TRUTH_RGBA = (0.00, 0.72, 0.70, 1.0)
GHOST_ALPHA = 0.35


@dataclass(frozen=True)
class RunStyle:
    """How one run is drawn, in the video and in the report plots alike.

    Attributes:
        name: Name in the video's text and the plots' legends.
        rgba: Colour (RGBA in [0, 1]): the robot (the ghost's tint), its trail, its plot lines.
        linestyle: Matplotlib line style of its lines in the plots.
    """

    name: str
    rgba: tuple[float, float, float, float]
    linestyle: str = "-"


#: Run label -> style: the one table the video (:mod:`sim.viz.replay`, :mod:`sim.viz.compose`) and
#: the plots (:mod:`sim.viz.plots.run`) read. Labels not in it get :data:`FALLBACK_RGBA` colours.
RUN_STYLES: dict[str, RunStyle] = {
    "closed_loop": RunStyle("closed loop", CLOSED_RGBA, "-"),
    "open_loop": RunStyle("open loop", OPEN_RGBA, "--"),
    "closed_loop_odometry": RunStyle("odometry feedback", ODOMETRY_RGBA, "-."),
    "closed_loop_truth": RunStyle("true-pose feedback", TRUTH_RGBA, ":"),
}

#: Colours of runs whose label :data:`RUN_STYLES` does not know, taken in order (magenta, brown,
#: olive, slate, crimson, grey); past these, hues a golden angle apart.
FALLBACK_RGBA = (
    (0.89, 0.20, 0.64, 1.0),
    (0.55, 0.34, 0.16, 1.0),
    (0.56, 0.58, 0.08, 1.0),
    (0.30, 0.38, 0.50, 1.0),
    (0.78, 0.08, 0.20, 1.0),
    (0.40, 0.40, 0.40, 1.0),
)


def run_styles(labels: Iterable[str]) -> dict[str, RunStyle]:
    """The style of each run label, in the order given.

    A label of :data:`RUN_STYLES` gets its style; every other label gets the next colour of
    :data:`FALLBACK_RGBA` (then hues a golden angle apart), named by its label, dotted in plots, so
    the runs of one video or plot never share a colour.
    """
    out: dict[str, RunStyle] = {}
    n_unknown = 0
    for label in labels:
        if label in out:
            continue
        style = RUN_STYLES.get(label)
        if style is None:
            if n_unknown < len(FALLBACK_RGBA):
                rgba = FALLBACK_RGBA[n_unknown]
            else:
                hue = (0.13 + 0.381966 * (n_unknown - len(FALLBACK_RGBA))) % 1.0
                rgba = (*colorsys.hsv_to_rgb(hue, 0.75, 0.7), 1.0)
            style = RunStyle(label, rgba, ":")
            n_unknown += 1
        out[label] = style
    return out


@dataclass(frozen=True)
class Track:
    """One run as the video shows it.

    Attributes:
        label: Run label ("closed_loop", "open_loop", ...).
        idx: (n,) log sample shown in each frame.
        qpos: (N, nq) logged joint positions.
        xy: (N, 2) logged positions [m].
        err: (N,) position error against the reference [m].
        trail_keep: Decimated log indices the trail is drawn through.
        rgba: Colour of its trail (and of its ghost).
        name: Name in the video's text.
        ended: When the run ended early [s] (it fell, or its estimator diverged: its log's last sample), None for
            a run that went on to the end.
    """

    label: str
    idx: NDArray[np.int64]
    qpos: FloatArray
    xy: FloatArray
    err: FloatArray
    trail_keep: NDArray[np.int64]
    rgba: tuple[float, ...]
    name: str
    ended: float | None = None


def light_gain(model: mujoco.MjModel) -> FloatArray:
    """(3,) factor by which the lights scale the colour of a face turned up to them and to the camera:
    the headlight's ambient and diffuse (straight on, as in the overview) plus every active light's
    ambient and its diffuse times the cosine between its direction and the vertical."""
    head = model.vis.headlight
    gain = np.array(head.ambient, dtype=float) + (np.array(head.diffuse, dtype=float) if head.active else 0.0)
    for i in range(model.nlight):
        if model.light_active[i]:
            d = np.asarray(model.light_dir[i], dtype=float)
            cos = max(0.0, -float(d[2]) / max(float(np.linalg.norm(d)), 1e-12))
            gain += np.asarray(model.light_ambient[i], dtype=float) + cos * np.asarray(model.light_diffuse[i])
    return gain


def ghost_rgb(rgba: tuple[float, ...], gain: FloatArray) -> tuple[float, float, float]:
    """The colour to draw a ghost in so that its faces lit straight on show ``rgba`` (RGB(A) in
    [0, 1]) rather than a washed-out brighter one: ``rgba`` divided by :func:`light_gain`, at most 1."""
    r, g, b = (min(1.0, float(c) / max(float(k), 1e-6)) for c, k in zip(rgba[:3], gain, strict=True))
    return (r, g, b)


def rgb255(rgba: tuple[float, ...]) -> tuple[int, int, int]:
    """An RGBA colour in [0, 1] as 8-bit RGB."""
    return (round(255 * rgba[0]), round(255 * rgba[1]), round(255 * rgba[2]))


def trail_width(track: int, line_width: int) -> int:
    """Width [px] of a track's trail: the primary run's wider, the ghosts' thinner (drawn on top)."""
    return line_width + 1 if track == 0 else max(1, line_width - 1)


@dataclass(frozen=True)
class Projection:
    """Pinhole projection of the scene's camera after ``mjv_updateScene`` (as ``mjr_render`` draws it).

    Attributes:
        pos: (3,) camera position [m].
        right: (3,) unit right vector.
        up: (3,) unit up vector.
        forward: (3,) unit viewing direction.
        near: Near-plane distance [m].
        left_edge: Frustum left edge at the near plane [m].
        half_width: Frustum half width at the near plane [m].
        bottom: Frustum bottom at the near plane [m].
        top: Frustum top at the near plane [m].
        width: Image width [px].
        height: Image height [px].
    """

    pos: FloatArray
    right: FloatArray
    up: FloatArray
    forward: FloatArray
    near: float
    left_edge: float
    half_width: float
    bottom: float
    top: float
    width: int
    height: int

    @staticmethod
    def from_scene(scene: mujoco.MjvScene, width: int, height: int) -> Projection:
        """The projection ``mjr_render`` uses on a ``width`` x ``height`` viewport (mono: the average
        of the scene's two eye cameras, which sit half the inter-pupillary distance either side)."""
        cam = scene.camera[0]
        pos = 0.5 * (np.array(cam.pos, dtype=float) + np.array(scene.camera[1].pos, dtype=float))
        fwd = np.array(cam.forward, dtype=float)
        up = np.array(cam.up, dtype=float)
        bottom, top = float(cam.frustum_bottom), float(cam.frustum_top)
        half_w = 0.5 * (top - bottom) * width / height  # mjr_render fits the frustum width to the viewport
        left = float(cam.frustum_center) - half_w
        near = float(cam.frustum_near)
        return Projection(pos, np.cross(fwd, up), up, fwd, near, left, half_w, bottom, top, width, height)

    def pixels(self, points: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Image coordinates of world points.

        Args:
            points: (M, 3) world points [m].

        Returns:
            (M, 2) [column, row] in pixels (row 0 at the top) and (M,) whether each point is in
            front of the near plane.
        """
        rel = points - self.pos
        z = rel @ self.forward
        ok = z > self.near
        zs = np.where(ok, z, 1.0)
        u = self.near * (rel @ self.right) / zs
        v = self.near * (rel @ self.up) / zs
        col = (u - self.left_edge) / (2.0 * self.half_width) * self.width
        row = (self.top - v) / (self.top - self.bottom) * self.height
        return np.column_stack([col, row]), ok

    def scale(self, point: FloatArray) -> float:
        """Pixels per metre at a world point (3,) (for sizes seen face on)."""
        z = float((point - self.pos) @ self.forward)
        return self.near / max(z, 1e-9) * self.height / (self.top - self.bottom)


def polylines(px: FloatArray, ok: NDArray[np.bool_]) -> list[list[float]]:
    """Split projected points into runs in front of the camera, each as a flat [x0, y0, x1, y1, ...]."""
    if ok.all():
        return [px.ravel().tolist()]
    runs: list[list[float]] = []
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return runs
    breaks = np.flatnonzero(np.diff(idx) > 1) + 1
    for seg in np.split(idx, breaks):
        if seg.size > 1:
            runs.append(px[seg].ravel().tolist())
    return runs


#: The 8 sign combinations of a box's corners, x slowest.
_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def aabb_corners(model: mujoco.MjModel, geoms: NDArray[np.int64]) -> FloatArray:
    """(G, 8, 3) corners of the bounding box of each of ``geoms`` in its own frame [m] (``geom_aabb``)."""
    aabb = model.geom_aabb[geoms].reshape(-1, 2, 3)  # centre, half sizes
    return np.asarray(aabb[:, None, 0, :] + _SIGNS[None] * aabb[:, None, 1, :])


def geom_box_corners(data: mujoco.MjData, geoms: NDArray[np.int64], corners: FloatArray) -> FloatArray:
    """World positions of the bounding-box corners of ``geoms``.

    Args:
        data: The state (after kinematics).
        geoms: (G,) geom ids.
        corners: (G, 8, 3) corners of each geom's box in its own frame [m].

    Returns:
        (G, 8, 3) corners in the world [m].
    """
    rot = data.geom_xmat[geoms].reshape(-1, 3, 3)
    return np.asarray(data.geom_xpos[geoms][:, None, :] + np.einsum("gij,gkj->gki", rot, corners))


#: Geom types :func:`enclosed_geoms` compares.
_PRIMITIVES = frozenset(
    int(t)
    for t in (
        mujoco.mjtGeom.mjGEOM_SPHERE,
        mujoco.mjtGeom.mjGEOM_CAPSULE,
        mujoco.mjtGeom.mjGEOM_ELLIPSOID,
        mujoco.mjtGeom.mjGEOM_CYLINDER,
        mujoco.mjtGeom.mjGEOM_BOX,
    )
)


def enclosed_geoms(model: mujoco.MjModel, ids: NDArray[np.int64]) -> NDArray[np.int64]:
    """Geoms of ``ids`` that lie inside another geom of ``ids`` and can never be seen.

    A geom is enclosed when another geom of the same body has the same primitive type, the same
    frame and sizes at least as large (a 1 mm collision tyre inside the 18 mm visual one).
    """
    hidden = []
    for a in ids:
        for b in ids:
            if a == b or model.geom_bodyid[a] != model.geom_bodyid[b] or model.geom_type[a] != model.geom_type[b]:
                continue
            if int(model.geom_type[a]) not in _PRIMITIVES or model.geom_rgba[b, 3] < 1.0:
                continue
            same_frame = np.allclose(model.geom_pos[a], model.geom_pos[b]) and np.allclose(
                model.geom_quat[a], model.geom_quat[b]
            )
            sa, sb = model.geom_size[a], model.geom_size[b]
            larger = bool(np.all(sb >= sa) and np.any(sb > sa))
            if same_frame and larger:
                hidden.append(int(a))
                break
    return np.asarray(hidden, dtype=np.int64)
