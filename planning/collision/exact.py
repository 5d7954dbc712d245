"""The collision model every planner shares: the robot's shape against the world's obstacles and walls.

Two shapes:

* ``"disc"``: the robot as the disc of radius ``robot.radius`` (circumscribing its footprint) about
  the base origin; exact: free iff the world's signed distance at the centre exceeds the radius
  plus the clearance.
* ``"footprint"``: the robot's convex footprint polygon. Its boundary is sampled every
  ``tolerance`` metres; because a signed distance is 1-Lipschitz, requiring every sample to be at
  least ``tolerance / 2`` from everything proves the whole boundary free. An obstacle small enough
  to sit wholly inside the footprint is caught by testing one point of each obstacle against the
  footprint polygon. So the test never accepts a colliding pose, and rejects a free one only when
  its true clearance is below ``tolerance / 2`` (the stated tolerance; 2.5 mm by default).

Motions are checked by sampling poses so that no point of the robot moves more than
``resolution`` between samples; ``resolution`` is finer than the smallest obstacle (a quarter of
its smallest extent, and at most 2 cm). All checks are vectorised over all poses at once.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.core.geometry import densify_path
from planning.core.robot import RobotSpec
from planning.core.world import Box, Circle, Ellipse, Polygon, World

FloatArray = NDArray[np.float64]
Shape = Literal["disc", "footprint"]


def _obstacle_anchor(obs: Circle | Ellipse | Box | Polygon) -> FloatArray:
    if isinstance(obs, Polygon):
        return np.asarray(obs.array[0])
    return np.asarray(obs.center, dtype=float)


def _sample_polygon(poly: FloatArray, spacing: float) -> FloatArray:
    """Points along a closed polygon's boundary, no two consecutive more than ``spacing`` apart."""
    pts = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        n = max(1, int(np.ceil(np.hypot(*(b - a)) / spacing)))
        s = np.arange(n)[:, None] / n
        pts.append(a + s * (b - a))
    return np.vstack(pts)


@functools.lru_cache(maxsize=16)
def _boundary_samples(raw: bytes, spacing: float) -> FloatArray:
    """:func:`_sample_polygon` of the polygon whose float64 (K, 2) vertices are ``raw``, computed once
    per footprint and spacing (every planning run builds a checker); read-only."""
    out = _sample_polygon(np.frombuffer(raw, dtype=np.float64).reshape(-1, 2), spacing)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class CollisionChecker:
    """Robot-versus-world collision tests.

    Args:
        world: Bounds and obstacles.
        robot: The robot (footprint and radius).
        shape: "disc" or "footprint".
        clearance: Extra margin every pose must keep [m] (e.g. 0.4 for seed 003's EduMIP).
        tolerance: Footprint boundary sample spacing [m]; see the module doc.
        walls: Whether the world's bounds count as walls.
    """

    world: World
    robot: RobotSpec
    shape: Shape = "footprint"
    clearance: float = 0.0
    tolerance: float = 0.005
    walls: bool = True
    _boundary: FloatArray = field(init=False, repr=False, compare=False)
    _anchors: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.shape not in ("disc", "footprint"):
            raise ValueError(f"shape must be 'disc' or 'footprint', got {self.shape!r}")
        if not self.tolerance > 0:
            raise ValueError(f"tolerance must be > 0, got {self.tolerance}")
        if self.clearance < 0:
            raise ValueError(f"clearance must be >= 0, got {self.clearance}")
        fp = np.ascontiguousarray(self.robot.footprint, dtype=np.float64)
        object.__setattr__(self, "_boundary", _boundary_samples(fp.tobytes(), float(self.tolerance)))
        anchors = [_obstacle_anchor(o) for o in self.world.obstacles]
        object.__setattr__(self, "_anchors", np.array(anchors).reshape(-1, 2))

    @property
    def resolution(self) -> float:
        """Largest distance any robot point may move between two checked samples of a motion [m]."""
        return float(min(0.02, self.world.min_feature() / 4.0))

    def clearance_of(self, poses: ArrayLike) -> FloatArray:
        """Lower bound on the distance between the robot and the nearest obstacle or wall [m].

        Exact for "disc"; within ``tolerance / 2`` below the truth for "footprint".
        Negative means overlap.

        Args:
            poses: (M, 3) poses [x, y, theta].

        Returns:
            (M,) clearances.
        """
        p = np.atleast_2d(np.asarray(poses, dtype=float))
        if self.shape == "disc":
            return self.world.signed_distance(p[:, :2], walls=self.walls) - self.robot.radius
        # Broad phase: the footprint lies between its inscribed and circumscribed discs about the
        # base origin, so poses far from everything (or deep inside something) need no exact test.
        centre = self.world.signed_distance(p[:, :2], walls=self.walls)
        out = centre - self.robot.radius
        band = centre <= self.robot.radius + self.clearance + self.tolerance
        if np.any(band):
            out[band] = self._footprint_clearance(p[band])
        return out

    def _footprint_clearance(self, p: FloatArray) -> FloatArray:
        c, s = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
        bx, by = self._boundary[None, :, 0], self._boundary[None, :, 1]
        pts = np.stack([p[:, :1] + c * bx - s * by, p[:, 1:2] + s * bx + c * by], axis=-1).reshape(-1, 2)
        reach = self.robot.radius + self.clearance + self.tolerance
        sd = self.world.wall_distance(pts) if self.walls else np.full(pts.shape[0], np.inf)
        lo, hi = p[:, :2].min(axis=0) - reach, p[:, :2].max(axis=0) + reach
        bb = self._boxes
        far = (bb[:, 1] < lo[0]) | (bb[:, 0] > hi[0]) | (bb[:, 3] < lo[1]) | (bb[:, 2] > hi[1])
        for k in np.flatnonzero(~far):  # the others are too far from every pose in this batch to matter
            sd = np.minimum(sd, self.world.obstacles[k].signed_distance(pts))
        out = sd.reshape(p.shape[0], -1).min(axis=1) - 0.5 * self.tolerance
        if self._anchors.size:
            out = np.where(self._anchor_inside(p), -np.inf, out)
        return out

    @functools.cached_property
    def _boxes(self) -> FloatArray:
        """(n_obstacles, 4) bounding boxes (xmin, xmax, ymin, ymax) [m], computed on first use."""
        return np.array([o.bounding_box() for o in self.world.obstacles], dtype=float).reshape(-1, 4)

    def _anchor_inside(self, p: FloatArray) -> NDArray[np.bool_]:
        """(M,) whether any obstacle's anchor point lies inside the footprint at each pose."""
        c, s = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
        dx = self._anchors[None, :, 0] - p[:, :1]
        dy = self._anchors[None, :, 1] - p[:, 1:2]
        lx, ly = c * dx + s * dy, -s * dx + c * dy  # anchors in the body frame, (M, n_obs)
        fp = self.robot.footprint
        a, b = fp, np.roll(fp, -1, axis=0)
        cross = (b[:, 0] - a[:, 0])[None, None, :] * (ly[..., None] - a[None, None, :, 1]) - (b[:, 1] - a[:, 1])[
            None, None, :
        ] * (lx[..., None] - a[None, None, :, 0])
        return np.any(np.all(cross >= 0.0, axis=-1), axis=-1)

    def poses_free(self, poses: ArrayLike) -> NDArray[np.bool_]:
        """(M,) whether each pose keeps ``clearance`` from every obstacle and wall."""
        return self.clearance_of(poses) > self.clearance

    def densify(self, poses: ArrayLike) -> FloatArray:
        """Insert poses so that no robot point moves more than ``resolution`` between samples.

        :func:`planning.core.geometry.densify_path` with the robot's radius (a turn counts radius
        times the angle): positions and unwrapped headings are interpolated linearly between the
        given samples, which must themselves follow the motion (e.g. the states of a primitive).

        Args:
            poses: (K, 3) consecutive poses along a motion.

        Returns:
            (K', 3) poses, K' >= K, starting and ending with the given ones.
        """
        return densify_path(poses, self.resolution, radius=self.robot.radius)

    def motion_free(self, poses: ArrayLike) -> bool:
        """Whether a whole motion (consecutive poses, densified here) is collision-free."""
        return bool(np.all(self.poses_free(self.densify(poses))))

    def first_collision(self, poses: ArrayLike) -> int | None:
        """Index into the densified motion of the first colliding sample, or None if free."""
        bad = ~self.poses_free(self.densify(poses))
        return int(np.argmax(bad)) if bad.any() else None
