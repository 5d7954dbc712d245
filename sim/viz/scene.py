"""What a video frame is made of, shared by the full render (:mod:`sim.viz.replay`) and the
fixed-view compositor (:mod:`sim.viz.compose`): colours, the runs' tracks, the camera's projection
of world points into the image, and the robot geometry both draw from.

This module imports neither of them: replay imports compose, and both import this module.
"""

from __future__ import annotations

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
GHOST_ALPHA = 0.35

#: Run label -> (overlay name, trail colour).
RUN_STYLE = {"closed_loop": ("closed loop", CLOSED_RGBA), "open_loop": ("open loop (ghost)", OPEN_RGBA)}


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
        rgba: Trail colour.
    """

    label: str
    idx: NDArray[np.int64]
    qpos: FloatArray
    xy: FloatArray
    err: FloatArray
    trail_keep: NDArray[np.int64]
    rgba: tuple[float, ...]


def rgb255(rgba: tuple[float, ...]) -> tuple[int, int, int]:
    """An RGBA colour in [0, 1] as 8-bit RGB."""
    return (round(255 * rgba[0]), round(255 * rgba[1]), round(255 * rgba[2]))


def trail_width(track: int, line_width: int) -> int:
    """Width [px] of a track's trail: the primary run's wider, the ghost's thinner (drawn on top)."""
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
