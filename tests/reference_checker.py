"""The collision checker's clearance in plain numpy: the reference :meth:`CollisionChecker.clearance_of`
(compiled, :func:`planning.collision.compiled.clearances_kernel`) is checked against.

The same rule (the centre's signed distance less the radius; for the footprint near something, the
nearest boundary sample's distance less ``tolerance / 2``, or -inf with an obstacle's anchor inside the
footprint or the centre more than ``radius + tolerance`` inside an obstacle or beyond a wall) with every
obstacle measured by :mod:`planning.core.world`'s formulas, vectorised over the poses.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from planning.collision.exact import CollisionChecker

FloatArray = NDArray[np.float64]


def reference_clearance(checker: CollisionChecker, poses: FloatArray) -> FloatArray:
    """(M,) clearance lower bounds [m] of (M, 3) poses, as the checker defines them."""
    p = np.atleast_2d(np.asarray(poses, dtype=float))
    world, robot = checker.world, checker.robot
    centre = world.signed_distance(p[:, :2], walls=checker.walls)
    out = centre - robot.radius
    if checker.shape == "disc":
        return out
    deep = centre < -(robot.radius + checker.tolerance)  # the whole footprint in collision
    band = (centre <= robot.radius + checker.clearance + checker.tolerance) & ~deep
    if np.any(band):
        out[band] = _footprint_clearance(checker, p[band])
    out[deep] = -np.inf
    return out


def _footprint_clearance(checker: CollisionChecker, p: FloatArray) -> FloatArray:
    world = checker.world
    c, s = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
    bx, by = checker._boundary[None, :, 0], checker._boundary[None, :, 1]
    pts = np.stack([p[:, :1] + c * bx - s * by, p[:, 1:2] + s * bx + c * by], axis=-1).reshape(-1, 2)
    sd = world.wall_distance(pts) if checker.walls else np.full(pts.shape[0], np.inf)
    for obstacle in world.obstacles:
        sd = np.minimum(sd, obstacle.signed_distance(pts))
    out = sd.reshape(p.shape[0], -1).min(axis=1) - 0.5 * checker.tolerance
    if checker._anchors.size:
        out = np.where(_anchor_inside(checker, p), -np.inf, out)
    return out


def _anchor_inside(checker: CollisionChecker, p: FloatArray) -> NDArray[np.bool_]:
    """(M,) whether any obstacle's anchor point lies inside the footprint at each pose."""
    c, s = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
    dx = checker._anchors[None, :, 0] - p[:, :1]
    dy = checker._anchors[None, :, 1] - p[:, 1:2]
    lx, ly = c * dx + s * dy, -s * dx + c * dy  # anchors in the body frame, (M, n_obs)
    fp = checker.robot.footprint
    a, b = fp, np.roll(fp, -1, axis=0)
    ex, ey = (b[:, 0] - a[:, 0])[None, None, :], (b[:, 1] - a[:, 1])[None, None, :]
    cross = ex * (ly[..., None] - a[None, None, :, 1]) - ey * (lx[..., None] - a[None, None, :, 0])
    return np.any(np.all(cross >= 0.0, axis=-1), axis=-1)
