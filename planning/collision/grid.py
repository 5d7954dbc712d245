"""A fast front end to :class:`~planning.collision.exact.CollisionChecker` that returns its exact verdicts.

The world's signed distance ``sd`` (walls included) is tabulated once on a grid of spacing ``h``.
``sd`` is 1-Lipschitz, so at any point ``p`` whose nearest grid node holds ``g``,
``g - e <= sd(p) <= g + e`` with ``e = h / sqrt(2)`` (the farthest a point can be from its nearest
node). A compiled kernel uses these bounds to *prove* each pose's verdict:

* free, if the centre's lower bound exceeds ``radius + clearance + tolerance`` (the exact checker
  then answers "free" too, by its disc test or, a fortiori, by its footprint test), or if every
  footprint boundary sample's lower bound exceeds ``clearance + tolerance / 2`` and no obstacle
  anchor lies inside the footprint (exactly the exact checker's footprint criterion);
* not free, if some boundary sample's upper bound is at most ``clearance + tolerance / 2``, or an
  anchor lies inside the footprint, or (disc) the centre's upper bound is at most
  ``radius + clearance``.

Only poses within about ``2 e`` of the decision margin stay undecided; those go to the exact
checker's formulas, compiled (:mod:`planning.collision.compiled`). The verdict is therefore
*identical* to ``CollisionChecker.poses_free`` for every pose (tests compare them on random and
near-margin poses); the grid only saves time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.clock import PlanClock
from planning.collision.compiled import (
    FieldArrays,
    RobotArrays,
    WorldArrays,
    empty_field,
    exact_free_kernel,
    exact_pose_free,
    grid_lookup,
    world_arrays,
)
from planning.collision.exact import CollisionChecker
from planning.collision.field import DistanceField, distance_field

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: What the compiled classifier takes after the poses (see :meth:`FastChecker.proof_arguments`).
ProofArguments = tuple[FloatArray, float, float, float, FloatArray, FloatArray, FloatArray, float, float, float, bool]

#: (grid, x0, y0, h, boundary, footprint, anchors, radius, clearance, tolerance, disc, world, robot,
#: field): everything :func:`pose_free` decides with (:meth:`FastChecker.check_arrays`).
CheckArrays = tuple[
    FloatArray,
    float,
    float,
    float,
    FloatArray,
    FloatArray,
    FloatArray,
    float,
    float,
    float,
    bool,
    WorldArrays,
    RobotArrays,
    FieldArrays,
]

#: Most poses :meth:`FastChecker.poses_free` first tries to prove free in Python (its start and goal).
_FEW = 4

#: Largest number of grid nodes tabulated (the spacing grows beyond 1 cm to stay below it).
MAX_NODES = 4_000_000


@nb.njit(cache=True, inline="always")
def disc_margin(g: float, h: float, radius: float, clearance: float, tol: float, disc: bool) -> float:
    """How far [m] a pose whose tabulated distance (nearest node, spacing ``h``) is ``g`` clears the grid's first
    proof, the footprint's circle: ``g`` less the lookup's error ``h / sqrt 2`` beyond ``radius`` and the
    ``clearance`` (and, for a footprint, ``tol``). Above 0 the pose is proven free (:func:`classify_pose`), and so is
    every pose whose position is nearer than that, the signed distance being 1-Lipschitz."""
    return (g - h / np.sqrt(2.0) - radius) - (clearance if disc else clearance + tol)


@nb.njit(cache=True)
def classify_pose(
    px: float,
    py: float,
    th: float,
    grid: FloatArray,
    x0: float,
    y0: float,
    h: float,
    boundary: FloatArray,
    footprint: FloatArray,
    anchors: FloatArray,
    radius: float,
    clearance: float,
    tol: float,
    disc: bool,
) -> int:
    """One pose (x [m], y [m], heading [rad]): 1 proven free, 0 proven in collision, -1 undecided (ask
    the exact checker); the arguments after the pose as :func:`classify_kernel`'s."""
    g = grid_lookup(grid, x0, y0, h, px, py)
    if disc_margin(g, h, radius, clearance, tol, disc) > 0.0:
        return 1
    e = h / np.sqrt(2.0)
    if disc:
        if g + e - radius <= clearance:
            return 0
        return -1
    nf = footprint.shape[0]
    c, s = np.cos(th), np.sin(th)
    all_free = True
    for b in range(boundary.shape[0]):
        bx = px + c * boundary[b, 0] - s * boundary[b, 1]
        by = py + s * boundary[b, 0] + c * boundary[b, 1]
        gb = grid_lookup(grid, x0, y0, h, bx, by)
        if gb + e - 0.5 * tol <= clearance:
            return 0
        if gb - e - 0.5 * tol <= clearance:
            all_free = False
    for a in range(anchors.shape[0]):
        dx, dy = anchors[a, 0] - px, anchors[a, 1] - py
        if dx * dx + dy * dy > radius * radius:
            continue
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        inside = True
        for v in range(nf):
            ax, ay = footprint[v, 0], footprint[v, 1]
            bx2, by2 = footprint[(v + 1) % nf, 0], footprint[(v + 1) % nf, 1]
            if (bx2 - ax) * (ly - ay) - (by2 - ay) * (lx - ax) < 0.0:
                inside = False
                break
        if inside:
            return 0
    return 1 if all_free else -1


@nb.njit(cache=True)
def classify_kernel(
    poses: FloatArray,
    grid: FloatArray,
    x0: float,
    y0: float,
    h: float,
    boundary: FloatArray,
    footprint: FloatArray,
    anchors: FloatArray,
    radius: float,
    clearance: float,
    tol: float,
    disc: bool,
    stop_on_collision: bool,
) -> NDArray[np.int8]:
    """Per pose: 1 proven free, 0 proven in collision, -1 undecided (ask the exact checker)."""
    n = poses.shape[0]
    out = np.full(n, -1, dtype=np.int8)
    for k in range(n):
        out[k] = classify_pose(
            poses[k, 0],
            poses[k, 1],
            poses[k, 2],
            grid,
            x0,
            y0,
            h,
            boundary,
            footprint,
            anchors,
            radius,
            clearance,
            tol,
            disc,
        )
        if stop_on_collision and out[k] == 0:
            return out[: k + 1]
    return out


@nb.njit(cache=True)
def pose_free(x: float, y: float, th: float, chk: CheckArrays) -> bool:
    """:meth:`FastChecker.poses_free` of one pose (x [m], y [m], heading [rad]), compiled: the grid's
    proof (:func:`classify_pose`), else the exact formulas (:func:`exact_pose_free`)."""
    grid, x0, y0, h, boundary, footprint, anchors, radius, clearance, tol, disc, world, robot, field = chk
    c = classify_pose(x, y, th, grid, x0, y0, h, boundary, footprint, anchors, radius, clearance, tol, disc)
    if c >= 0:
        return c == 1
    return exact_pose_free(x, y, th, world, robot, field)


@nb.njit(cache=True)
def poses_free_kernel(poses: FloatArray, chk: CheckArrays) -> BoolArray:
    """(M,) :func:`pose_free` of each (M, 3) pose."""
    out = np.empty(poses.shape[0], dtype=np.bool_)
    for k in range(poses.shape[0]):
        out[k] = pose_free(poses[k, 0], poses[k, 1], poses[k, 2], chk)
    return out


@nb.njit(cache=True)
def _summary(cls: NDArray[np.int8], m: int) -> int:
    """0 if fewer than ``m`` classes (stopped at a collision) or any proven collision, 1 if all proven
    free, -1 if some are undecided."""
    if cls.shape[0] < m:
        return 0
    out = 1
    for c in cls:
        if c == 0:
            return 0
        if c < 0:
            out = -1
    return out


@dataclass(frozen=True)
class FastChecker:
    """Same answers as ``checker``, much faster (see the module doc).

    Args:
        checker: The exact checker whose verdicts are reproduced.
        spacing: Grid spacing [m]; default 1 cm (coarser only for very large worlds).
        deadline: ``time.perf_counter()`` value by which the grid must be built (None: no limit).

    Raises:
        planning.collision.field.FieldTimeout: The grid was not built by ``deadline``.
    """

    checker: CollisionChecker
    spacing: float | None = None
    deadline: float | None = field(default=None, repr=False, compare=False)
    _grid: FloatArray = field(init=False, repr=False, compare=False)
    _h: float = field(init=False, repr=False, compare=False)
    _field: FieldArrays = field(init=False, repr=False, compare=False)
    _check: CheckArrays | None = field(init=False, repr=False, compare=False, default=None)
    grid_seconds: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        clock = PlanClock(float("inf"))  # only to time the grid less numba readying its kernels
        w = self.checker.world
        h = self.spacing if self.spacing is not None else w.grid_spacing(0.01, MAX_NODES)
        if not h > 0:
            raise ValueError(f"grid spacing must be > 0, got {h}")
        object.__setattr__(self, "_h", float(h))
        if self.checker.walls:
            built: DistanceField = distance_field(w, float(h), self.deadline)
            arrays = built.arrays()
        else:  # nothing tabulated: every pose goes to the exact formulas, over every obstacle
            arrays = empty_field(w)
        object.__setattr__(self, "_grid", arrays[0])
        object.__setattr__(self, "_field", arrays)
        #: Time this checker spent getting its grid [s] (building it, or ~0 when cached for the world), less
        #: numba readying the kernels that build it (:meth:`planning.clock.PlanClock.working`).
        object.__setattr__(self, "grid_seconds", clock.working())

    @property
    def resolution(self) -> float:
        """Largest motion of any robot point between checked samples [m] (the exact checker's)."""
        return self.checker.resolution

    def proof_arguments(self) -> ProofArguments:
        """The arguments after the poses of the compiled :func:`classify_kernel` (grid, its origin and
        spacing, footprint samples, footprint, anchors, radius, clearance, tolerance, disc), for
        compiled callers that prove poses free themselves (:mod:`planning.planners.lattice`).

        Raises:
            ValueError: The checker ignores the walls (no grid is tabulated).
        """
        c = self.checker
        if not c.walls:
            raise ValueError("proof_arguments needs a checker with walls (the grid assumes them)")
        x0, _, y0, _ = c.world.bounds
        return (self._grid, float(x0), float(y0), self._h, *c.robot_arrays())

    def kernel_args(self) -> ProofArguments | None:
        """:meth:`proof_arguments`, or None without walls (nothing is proven), for compiled callers that
        classify poses they generate (:func:`classify_kernel` after the poses, but ``stop_on_collision``)."""
        return self.proof_arguments() if self.checker.walls else None

    def check_arrays(self) -> CheckArrays | None:
        """What the compiled :func:`pose_free` takes: :meth:`kernel_args` and the exact fallback's
        world, robot and field arrays (built once per checker); None without walls (the grid
        assumes them)."""
        if self._check is None and self.checker.walls:
            object.__setattr__(self, "_check", self._check_arrays())
        return self._check

    def _check_arrays(self) -> CheckArrays | None:
        args = self.kernel_args()
        if args is None:
            return None
        c = self.checker
        return (*args, world_arrays(c.world, c.walls), c.robot_arrays(), self._field)

    def _classify(self, p: FloatArray, stop: bool) -> NDArray[np.int8]:
        args = self.kernel_args()
        if args is None:  # the grid assumes walls; without them every pose is left undecided
            return np.full(p.shape[0], -1, dtype=np.int8)
        return classify_kernel(p, *args, stop)  # type: ignore[no-any-return, call-arg]

    def _exact(self, poses: FloatArray) -> BoolArray:
        """``checker.poses_free`` of (M, 3) poses, compiled (:mod:`planning.collision.compiled`)."""
        c = self.checker
        world = world_arrays(c.world, c.walls)
        return exact_free_kernel(np.ascontiguousarray(poses), world, c.robot_arrays(), self._field)  # type: ignore[no-any-return]

    def settle_path(self, poses: FloatArray, cls: NDArray[np.int8]) -> bool:
        """:meth:`path_free`'s verdict from the (M, 3) poses and their ``classify_kernel`` classes
        (computed with ``stop_on_collision``: possibly fewer than M, ending at a proven collision)."""
        verdict = _summary(cls, poses.shape[0])
        if verdict >= 0:
            return bool(verdict)
        return bool(np.all(self._exact(poses[cls < 0])))

    def poses_free(self, poses: ArrayLike) -> BoolArray:
        """(M,) whether each (M, 3) pose keeps the clearance from everything (exact verdict)."""
        p = np.ascontiguousarray(np.atleast_2d(np.asarray(poses, dtype=float)))
        chk = self.check_arrays()
        if chk is not None:
            if p.shape[0] <= _FEW and self._disc_proves_free(p, chk):
                return np.ones(p.shape[0], dtype=bool)
            return poses_free_kernel(p, chk)  # type: ignore[no-any-return]
        cls = self._classify(p, False)
        out = cls == 1
        und = cls < 0
        if np.any(und):
            out[und] = self._exact(p[und])
        return out

    def free_around(self, pose: ArrayLike, reach: float) -> bool:
        """Whether every pose whose position is within ``reach`` [m] of ``pose``'s is proven free by the
        grid's first proof (:meth:`_disc_proves_free`), whatever its heading; False when it cannot tell."""
        chk = self.check_arrays()
        p = np.atleast_2d(np.asarray(pose, dtype=float))
        return chk is not None and self._disc_proves_free(p, chk, reach)

    @staticmethod
    def _disc_proves_free(p: FloatArray, chk: CheckArrays, reach: float = 0.0) -> bool:
        """Whether the grid's first proof (:func:`classify_pose`'s, the same arithmetic in Python floats:
        the centre's disc keeps the clearance) shows every one of a few poses free. Then they need no
        compiled call: a planner's start and goal mostly need none, and a new process does not load the
        compiled checker (10-14 ms) for them, nor a warm one pay numpy's set-up for two poses. With
        ``reach`` > 0, every pose within ``reach`` of one: its nearest grid node lies within ``reach + 2 e``
        of the one's, and the grid holds the signed distance, which is 1-Lipschitz."""
        grid, x0, y0, h = chk[0], chk[1], chk[2], chk[3]
        radius, clearance, tol, disc = chk[7], chk[8], chk[9], chk[10]
        e = h / math.sqrt(2.0)
        if reach > 0:
            radius += reach + 2.0 * e
        margin = clearance if disc else clearance + tol
        nx, ny = grid.shape
        for x, y, _ in p.tolist():
            i, j = math.floor((x - x0) / h + 0.5), math.floor((y - y0) / h + 0.5)
            if not (0 <= i < nx and 0 <= j < ny and float(grid[i, j]) - e - radius > margin):
                return False
        return True

    def path_free(self, poses: ArrayLike) -> bool:
        """Whether all (M, 3) poses are free; stops at the first proven collision. The poses must
        already be dense along the motion (use :meth:`motion_free` otherwise)."""
        p = np.ascontiguousarray(np.atleast_2d(np.asarray(poses, dtype=float)))
        return self.settle_path(p, self._classify(p, True))

    def first_collision(self, poses: ArrayLike) -> int | None:
        """Index of the first non-free pose among dense (M, 3) poses, or None."""
        p = np.ascontiguousarray(np.atleast_2d(np.asarray(poses, dtype=float)))
        free = self.poses_free(p)
        return None if free.all() else int(np.argmin(free))

    def densify(self, poses: ArrayLike) -> FloatArray:
        """The exact checker's densification (see ``CollisionChecker.densify``)."""
        return self.checker.densify(poses)

    def motion_free(self, poses: ArrayLike) -> bool:
        """Whether a motion (consecutive poses, densified here) is collision-free."""
        return self.path_free(self.densify(poses))

    def distance_bounds(self, points: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Lower and upper bounds [m] of the world's signed distance (walls included) at (M, 2) points,
        from the tabulated grid alone (``g -+ h / sqrt(2)``; -inf, -inf outside the bounds).

        Raises:
            ValueError: The checker ignores the walls (no grid is tabulated).
        """
        if not self.checker.walls:
            raise ValueError("distance_bounds needs a checker with walls (the grid assumes them)")
        p = np.atleast_2d(np.asarray(points, dtype=float))
        x0, _, y0, _ = self.checker.world.bounds
        i = np.floor((p[:, 0] - x0) / self._h + 0.5).astype(np.int64)
        j = np.floor((p[:, 1] - y0) / self._h + 0.5).astype(np.int64)
        inside = (i >= 0) & (j >= 0) & (i < self._grid.shape[0]) & (j < self._grid.shape[1])
        g = np.full(p.shape[0], -np.inf)
        g[inside] = self._grid[i[inside], j[inside]]
        e = self._h / np.sqrt(2.0)
        return g - e, g + e

    def clearance_of(self, poses: ArrayLike) -> FloatArray:
        """The exact checker's clearance lower bound [m] (compiled; against the world's cached field)."""
        return self.checker.clearance_of(poses)
