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
its smallest extent, and at most 2 cm). The clearance every verdict comes from is computed in
compiled code, pose by pose (:meth:`CollisionChecker.clearance_of`); ``tests/reference_checker.py``
keeps it in plain numpy, and the tests compare the two bit for bit.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.collision.compiled import (
    FieldArrays,
    Groups,
    RobotArrays,
    WorldArrays,
    boundary_groups,
    clearances_kernel,
    empty_field,
    least_distance,
    world_arrays,
)
from planning.collision.field import cached_field
from planning.core.arrays import kernel_input
from planning.core.geometry import densify_path
from planning.core.robot import RobotSpec
from planning.core.world import Box, Circle, Ellipse, Polygon, World

FloatArray = NDArray[np.float64]
Shape = Literal["disc", "footprint"]

#: Footprint boundary sample spacing of :meth:`CollisionChecker.least_clearance`'s refinement [m]: its
#: value is at most half of it (0.1 mm) below the exact least distance.
REFINED_TOLERANCE = 2e-4
#: The boundary spacing [m] :meth:`CollisionChecker.least_clearance` measures the poses near the least at when they
#: are more than :data:`MIDDLE_POSES`, before the few left are refined: an optim plan along a maze's walls (6701 poses
#: a millimetre apart, thousands within the coarse tolerance of the least) took 3.7 s refining them one by one.
MIDDLE_TOLERANCE = 1e-3
MIDDLE_POSES = 64
#: The footprint boundary's sample spacing of a checker that states none [m]: its clearances err up to half
#: of it below the truth.
DEFAULT_TOLERANCE = 0.005


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


@functools.lru_cache(maxsize=16)
def _groups(raw: bytes, spacing: float) -> Groups:
    """:func:`boundary_groups` of :func:`_boundary_samples` ``(raw, spacing)``, once per footprint and spacing."""
    groups = boundary_groups(_boundary_samples(raw, spacing))
    for arr in groups:
        arr.setflags(write=False)
    return groups


@dataclass(frozen=True)
class CollisionChecker:
    """Robot-versus-world collision tests.

    Args:
        world: Bounds and obstacles.
        robot: The robot (footprint and radius).
        shape: "disc" or "footprint".
        clearance: Extra margin every pose must keep [m] (e.g. 0.4 for the EduMIP of the EduMIP planning report).
        tolerance: Footprint boundary sample spacing [m]; see the module doc.
        walls: Whether the world's bounds count as walls.
    """

    world: World
    robot: RobotSpec
    shape: Shape = "footprint"
    clearance: float = 0.0
    tolerance: float = DEFAULT_TOLERANCE
    walls: bool = True
    _boundary: FloatArray = field(init=False, repr=False, compare=False)
    _footprint: FloatArray = field(init=False, repr=False, compare=False)
    _anchors: FloatArray = field(init=False, repr=False, compare=False)
    _world: WorldArrays = field(init=False, repr=False, compare=False)
    _resolution: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.shape not in ("disc", "footprint"):
            raise ValueError(f"shape must be 'disc' or 'footprint', got {self.shape!r}")
        if not self.tolerance > 0:
            raise ValueError(f"tolerance must be > 0, got {self.tolerance}")
        if self.clearance < 0:
            raise ValueError(f"clearance must be >= 0, got {self.clearance}")
        # a writable copy whether or not the spec's is read-only (load_robot's are): the kernels see one
        # array type, and compile once
        fp = np.array(self.robot.footprint, dtype=np.float64, order="C")
        object.__setattr__(self, "_footprint", fp)
        object.__setattr__(self, "_boundary", _boundary_samples(fp.tobytes(), float(self.tolerance)))
        anchors = [_obstacle_anchor(o) for o in self.world.obstacles]
        object.__setattr__(self, "_anchors", np.array(anchors).reshape(-1, 2))
        # once per checker: finding the packed world hashes it (9 us for 60 obstacles, 0.44 ms for 3000),
        # and the smallest feature is a scan of every obstacle; both are asked for every motion checked
        object.__setattr__(self, "_world", world_arrays(self.world, self.walls))
        object.__setattr__(self, "_resolution", float(min(0.02, self.world.min_feature() / 4.0)))

    @property
    def resolution(self) -> float:
        """Largest distance any robot point may move between two checked samples of a motion [m]."""
        return self._resolution

    def clearance_of(self, poses: ArrayLike) -> FloatArray:
        """Lower bound on the distance between the robot and the nearest obstacle or wall [m].

        Exact for "disc"; within ``tolerance / 2`` below the truth for "footprint" where the robot's
        centre is within ``radius + clearance + tolerance`` of something (elsewhere the centre's
        distance less the radius: the footprint lies inside that disc). Negative means overlap; -inf an
        obstacle's anchor inside the footprint, or the whole footprint in collision (its centre more than
        ``radius + tolerance`` inside an obstacle or beyond a wall).
        Compiled (:func:`planning.collision.compiled.clearances_kernel`); measured against the
        candidates of the world's distance field when one is cached (the same values as a scan of every
        obstacle: a 2000-obstacle world's path in milliseconds).

        Args:
            poses: (M, 3) poses [x, y, theta].

        Returns:
            (M,) clearances.
        """
        p = kernel_input(np.atleast_2d(np.asarray(poses, dtype=float)))
        groups = _groups(self._footprint.tobytes(), float(self.tolerance))
        return clearances_kernel(p, self._world, self.robot_arrays(), self._field(), groups)  # type: ignore[no-any-return]

    def least_clearance(self, poses: ArrayLike) -> float:
        """The least clearance of the footprint over (M, 3) poses [m], refined: a lower bound at most
        ``REFINED_TOLERANCE / 2`` (0.1 mm) below the exact least distance to an obstacle or wall over them.

        :meth:`clearance_of` is within ``tolerance / 2`` (2.5 mm by default) of the truth near
        something and the bounding disc's distance elsewhere (centimetres less). Here the poses are taken
        in the order of their :meth:`clearance_of` and each is measured again with the boundary sampled
        every ``REFINED_TOLERANCE`` m, wherever it is, until the next one's (lower) bound cannot be the
        least: a handful of poses for a planned path, milliseconds. Only the poses whose bound is below the
        least pose's refined clearance can be the least; when they are more than :data:`MIDDLE_POSES` (a dense
        path along a wall), their bounds are first tightened to ``MIDDLE_TOLERANCE / 2``. For the "disc" shape
        (exact), for no poses (inf) and for an overlap the checker calls -inf, :meth:`clearance_of`'s least as it
        is.
        """
        p = np.atleast_2d(np.asarray(poses, dtype=float))
        coarse = self.clearance_of(p)
        if coarse.size == 0 or self.shape == "disc" or not np.isfinite(coarse.min()):
            return float(coarse.min()) if coarse.size else math.inf
        fine = self._refined()
        first = int(np.argmin(coarse))
        best = max(float(coarse[first]), float(fine.clearance_of(p[first])[0]))
        near = np.flatnonzero(coarse < best)  # no other pose can be below the least found
        bound = coarse[near]
        if near.size > MIDDLE_POSES:  # a path along a wall: thousands of poses within the coarse tolerance of it
            middle = dataclasses.replace(self, tolerance=MIDDLE_TOLERANCE, clearance=math.inf)
            bound = np.maximum(bound, middle.clearance_of(p[near]))
        for k in np.argsort(bound, kind="stable"):
            if bound[k] >= best:  # its bound, and every later one's, is no less than the least found
                break
            best = min(best, max(float(bound[k]), float(fine.clearance_of(p[near[k]])[0])))
        return best

    def first_overlap(self, poses: ArrayLike) -> tuple[int, float] | None:
        """The first of (M, 3) ``poses`` whose footprint overlaps an obstacle or wall, and its clearance [m] (-inf:
        an obstacle inside the footprint, or the footprint wholly in collision); None when every one is clear.

        :meth:`clearance_of` picks the suspects (its bound is below the truth); each is measured again as
        :meth:`least_clearance` measures, in the poses' order, a few at a time, until one overlaps: a pose
        that only grazes within the coarse tolerance is not taken for an overlap.
        """
        p = np.atleast_2d(np.asarray(poses, dtype=float))
        coarse = self.clearance_of(p)
        suspects = np.flatnonzero(coarse < 0)
        fine = self._refined() if self.shape != "disc" else None
        for at in range(0, suspects.size, 16):
            chunk = suspects[at : at + 16]
            clearance = coarse[chunk].copy()
            near = np.isfinite(clearance)
            if fine is not None and near.any():
                clearance[near] = np.maximum(clearance[near], fine.clearance_of(p[chunk[near]]))
            hits = np.flatnonzero(clearance < 0)
            if hits.size:
                return int(chunk[hits[0]]), float(clearance[hits[0]])
        return None

    def _refined(self) -> CollisionChecker:
        """This checker measuring every pose by its footprint (an infinite margin), the boundary sampled every
        ``REFINED_TOLERANCE`` m."""
        return dataclasses.replace(self, tolerance=min(REFINED_TOLERANCE, self.tolerance), clearance=math.inf)

    def least_distance(self, points: ArrayLike) -> float:
        """The world's least signed distance [m] (walls as the checker has them; inf for no points) over
        (M, 2) points along a polyline: the minimum of the distances at every point, from as few of them
        as prove it (compiled, :func:`planning.collision.compiled.least_distance`; against the cached
        distance field's block candidates when there is one)."""
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))
        return float(least_distance(p, self._world, self._field()))

    def robot_arrays(self) -> RobotArrays:
        """The robot and margins as the compiled kernels take them (boundary samples, footprint, obstacle
        anchors, radius, clearance, tolerance, disc shape)."""
        margins = (float(self.robot.radius), float(self.clearance), float(self.tolerance), self.shape == "disc")
        return (self._boundary, self._footprint, self._anchors, *margins)

    def _field(self) -> FieldArrays:
        """The world's cached distance field (its block candidates speed the scan), else none; never
        without walls (the field's candidates assume them)."""
        built = cached_field(self.world) if self.walls else None
        return built.arrays() if built is not None else empty_field(self.world)

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
