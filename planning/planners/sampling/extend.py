"""One interface over every steering method the tree planners use (primitives and exact curves).

``extend(q_from, q_to, backwards)`` returns a collision-free motion that starts at ``q_from`` and
heads for ``q_to`` (forward trees), or, with ``backwards=True``, a motion that *ends* at ``q_from``
and starts as near ``q_to`` as possible (trees grown from the goal). Exact curves are always
computed from the start side to the goal side, so a backwards extension steers from the target to
the tree node and keeps the suffix: the asymmetric Dubins distance is never used the wrong way
round.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from planning.collision.grid import CheckArrays, FastChecker
from planning.core.arrays import kernel_input
from planning.core.robot import RobotSpec
from planning.curves.words import Word
from planning.errors import ConfigError
from planning.planners.sampling.connect_kernel import steer_free
from planning.planners.sampling.fastcurve import steer_kernel
from planning.planners.sampling.steering import (
    SAMPLE_STEP,
    CurveSteering,
    bicycle_primitives,
    default_turning_radius,
    diffdrive_metric,
    diffdrive_steer,
    place,
    se2_metric,
    unicycle_primitives,
)
from planning.planners.sampling.tree import Tree

FloatArray = NDArray[np.float64]
Steering = Literal["bicycle", "unicycle", "diffdrive", "reeds_shepp", "dubins"]
STEERINGS: tuple[str, ...] = ("bicycle", "unicycle", "diffdrive", "reeds_shepp", "dubins")

Motion = tuple[FloatArray, FloatArray, FloatArray]  # (q_new (3,), poses (K, 3), directions (K,))

_ORDERS: dict[tuple[int, bool], NDArray[np.int64]] = {}


def check_steering(name: object) -> None:
    """Raise a ``ConfigError`` naming the choices unless ``name`` is one of :data:`STEERINGS`."""
    if not isinstance(name, str) or name not in STEERINGS:
        raise ConfigError(f"unknown steering {name!r}: choose one of {', '.join(STEERINGS)}")


def check_order(n: int, new_first: bool) -> NDArray[np.int64]:
    """The order in which a motion's ``n`` dense poses are checked, OMPL's: the new end first (the last
    pose, or with ``new_first`` the first), then the other end, then the interior by repeated
    bisection (breadth first), so a blocked motion is usually refuted after a few poses, not after
    its whole free stretch. The verdict is the same as in any order (all poses are free or not).

    Returns:
        (n,) a permutation of 0..n-1 (cached per ``n``; do not modify).
    """
    key = (n, new_first)
    order = _ORDERS.get(key)
    if order is None:
        out = [0, n - 1] if new_first else [n - 1, 0]
        spans = [(1, n - 2)]
        for lo, hi in spans:  # grows while iterated: breadth first
            if lo > hi:
                continue
            mid = (lo + hi) // 2
            out.append(mid)
            spans += [(lo, mid - 1), (mid + 1, hi)]
        order = np.array(out[:n] if n > 1 else [0], dtype=np.int64)
        _ORDERS[key] = order
    return order


#: Nearest-node distance within which a primitive's end is a node its tree has: a primitive and its reverse land on
#: the node they left, and added again such copies filled a tree (2502 nodes, 5 poses; a partial path of 581 m in a
#: 4 x 4 m world, every pose repeated).
SAME_NODE = 1e-9


@dataclass
class LocalPlanner:
    """Steering plus collision checking for one planning run.

    Args:
        steering: "bicycle" (the TurtleBot planning report), "unicycle" (the fruit-farm report),
            "diffdrive" (the parking-lot report), "reeds_shepp" or "dubins".
        robot: The robot.
        checker: Collision checker.
        rho: Turning radius of the exact curves [m] (default: the virtual bicycle's).
        step_range: Longest exact-curve extension [m].
        n_speeds: Bicycle primitive speeds.
        primitive_duration: Bicycle primitive / diff-drive drive duration [s].
    """

    steering: str
    robot: RobotSpec
    checker: FastChecker
    rho: float | None = None
    step_range: float = 1.0
    n_speeds: int = 20
    primitive_duration: float = 1.0
    curves: CurveSteering = field(init=False)
    sample_step: float = field(init=False)
    _dense: list[FloatArray] = field(init=False, default_factory=list)
    _dirs: FloatArray = field(init=False)
    _ends: FloatArray = field(init=False)
    _check: CheckArrays | None = field(init=False, default=None)
    _spans: NDArray[np.int64] = field(init=False, default_factory=lambda: np.empty(4096, dtype=np.int64))
    _buf_p: FloatArray = field(init=False, default_factory=lambda: np.empty((1024, 3)))
    _buf_d: FloatArray = field(init=False, default_factory=lambda: np.empty(1024))

    def __post_init__(self) -> None:
        check_steering(self.steering)
        rho = self.rho if self.rho is not None else default_turning_radius(self.robot)
        if not rho > 0:
            raise ConfigError(f"turning_radius must be > 0 m, got {rho}")
        self.rho = rho
        kind: Literal["dubins", "reeds_shepp"] = "dubins" if self.steering == "dubins" else "reeds_shepp"
        self.curves = CurveSteering(kind, rho)
        # Robot points move at most step * (1 + R / rho) between curve samples.
        self.sample_step = min(SAMPLE_STEP, self.checker.resolution / (1.0 + self.robot.radius / rho))
        self._check = self.checker.check_arrays()
        if self.steering in ("bicycle", "unicycle"):
            prims = (
                bicycle_primitives(self.robot, n_speeds=self.n_speeds, duration=self.primitive_duration)
                if self.steering == "bicycle"
                else unicycle_primitives()
            )
            self._dense = [self.checker.densify(p) for p in prims.poses]
            self._dirs = prims.directions
            self._ends = prims.poses[:, -1]

    @property
    def exact(self) -> bool:
        """Whether extensions reach their target exactly when it is near enough."""
        return self.steering in ("reeds_shepp", "dubins")

    def metric(self, nodes: FloatArray, q: FloatArray) -> FloatArray:
        """Nearest-node distance for this steering (the parking-lot report's for diffdrive, the TurtleBot
        planning report's otherwise)."""
        return diffdrive_metric(nodes, q) if self.steering == "diffdrive" else se2_metric(nodes, q)

    def nearest(self, tree: Tree, q: FloatArray) -> int:
        """Index of ``tree``'s node nearest to ``q`` under :meth:`metric` (first of equals)."""
        return tree.nearest(q, self.metric) if self.steering == "diffdrive" else tree.se2_nearest(q)

    def tree_distances(self, tree: Tree, q: FloatArray) -> FloatArray:
        """(n,) :meth:`metric` of every node of ``tree`` to ``q``."""
        return self.metric(tree.nodes[: tree.n], q) if self.steering == "diffdrive" else tree.se2_distances(q)

    def word_motion(self, word: Word) -> tuple[FloatArray, FloatArray]:
        """Dense samples (K, 3) and directions (K,) of a curve at the checking step."""
        return word.sample(self.sample_step)

    def steer(self, q_a: FloatArray, q_b: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The exact curve from ``q_a`` to ``q_b``, unchecked: dense poses (K, 3) and directions (K,),
        ending exactly on ``q_b`` (path simplification's steering)."""
        return self._steer(q_a, q_b, np.inf, False)

    def _steer(self, q0: FloatArray, q1: FloatArray, max_len: float, keep_end: bool) -> tuple[FloatArray, FloatArray]:
        """Samples of the exact curve ``q0`` -> ``q1`` at the checking step, end pose pinned, cut to
        ``max_len`` of chords from the start (or, ``keep_end``, from the end); see :mod:`.fastcurve`."""
        a, b = kernel_input(q0), kernel_input(q1)
        assert self.rho is not None  # set in __post_init__
        poses, dirs, ok = steer_kernel(
            self.curves.kind == "reeds_shepp", a, b, self.rho, self.sample_step, max_len, keep_end
        )
        if not ok:
            self.curves.curve(a, b)  # raises the solver's error (non-finite poses)
        return poses, dirs

    @property
    def check_arrays(self) -> CheckArrays | None:
        """The checker as compiled callers take it (:meth:`FastChecker.check_arrays`; None: no walls)."""
        return self._check

    def _checked(
        self, q0: FloatArray, q1: FloatArray, max_len: float, keep_end: bool, min_poses: int = 1
    ) -> tuple[FloatArray, FloatArray] | None:
        """The samples of :meth:`_steer` if there are ``min_poses`` or more and all are free (checked in
        :func:`check_order`, the new end first: ``poses[0]`` with ``keep_end``, else ``poses[-1]``;
        :func:`.connect_kernel.steer_free`), else None."""
        a, b = kernel_input(q0), kernel_input(q1)
        if self._check is None:
            poses, dirs = self._steer(a, b, max_len, keep_end)
            return (poses, dirs) if poses.shape[0] >= min_poses and self.checker.path_free(poses) else None
        assert self.rho is not None  # set in __post_init__
        geometry = np.array([self.rho, self.sample_step])
        rs = self.curves.kind == "reeds_shepp"
        n, verdict, p, d = steer_free(
            rs, a, b, geometry, max_len, keep_end, min_poses, self._check, self._spans, self._buf_p, self._buf_d
        )
        if verdict < 0:
            self.curves.curve(a, b)  # raises the solver's error (non-finite poses)
        self._buf_p, self._buf_d = p, d  # grown when a curve needed more room
        return (p[:n].copy(), d[:n].copy()) if verdict == 1 else None

    def connect(self, q_a: FloatArray, q_b: FloatArray) -> tuple[FloatArray, FloatArray] | None:
        """The exact curve from ``q_a`` (start side) to ``q_b`` (goal side) if collision-free."""
        return self._checked(q_a, q_b, np.inf, False)  # ends exactly on q_b

    def extend(
        self, q_from: FloatArray, q_to: FloatArray, backwards: bool = False, tree: Tree | None = None
    ) -> Motion | None:
        """A collision-free motion from ``q_from`` toward ``q_to`` (see the module doc), or None. With ``tree``,
        a primitive that ends on one of its nodes is passed over for the next (:data:`SAME_NODE`)."""
        if self.exact:
            return self._extend_curve(q_from, q_to, backwards)
        if self.steering == "diffdrive":
            if backwards:
                raise ConfigError(
                    "diffdrive steering grows forward trees only: use it with 'rrt' (rrt-star rewires along exact "
                    "curves: steering 'reeds_shepp' or 'dubins')"
                )
            poses = diffdrive_steer(q_from, q_to, self.robot, duration=self.primitive_duration)
            dense = self.checker.densify(poses)
            if not self.checker.path_free(dense):
                return None
            v_sign = 1.0 if np.dot(poses[-1, :2] - poses[0, :2], [np.cos(q_from[2]), np.sin(q_from[2])]) >= 0 else -1.0
            return dense[-1].copy(), dense, np.full(dense.shape[0], v_sign)
        return self._extend_primitive(q_from, q_to, backwards, tree)

    @property
    def primitives(self) -> int:
        """How many motion primitives steer (0 for exact curves and diffdrive steering)."""
        return len(self._dense) if self.steering in ("bicycle", "unicycle") else 0

    def boxed_in(self, q: FloatArray, backwards: bool = False) -> bool:
        """Whether every motion primitive from ``q`` (into it, ``backwards``) collides: a tree rooted there
        cannot grow, whatever it samples (False for other steering)."""
        return bool(self.primitives) and self._extend_primitive(q, q, backwards, None) is None

    def _extend_primitive(
        self, q_from: FloatArray, q_to: FloatArray, backwards: bool, tree: Tree | None
    ) -> Motion | None:
        c, s = np.cos(q_from[2]), np.sin(q_from[2])
        ends = np.empty_like(self._ends)
        if backwards:
            # Primitive p placed at S = q_from (+) E_p^-1 ends exactly at q_from; S is the new node.
            e = self._ends
            eth = -e[:, 2]
            ce, se = np.cos(eth), np.sin(eth)
            bx, by = -(ce * e[:, 0] - se * e[:, 1]), -(se * e[:, 0] + ce * e[:, 1])
            ends[:, 0] = q_from[0] + c * bx - s * by
            ends[:, 1] = q_from[1] + s * bx + c * by
            ends[:, 2] = q_from[2] + eth
        else:
            ends[:, 0] = q_from[0] + c * self._ends[:, 0] - s * self._ends[:, 1]
            ends[:, 1] = q_from[1] + s * self._ends[:, 0] + c * self._ends[:, 1]
            ends[:, 2] = q_from[2] + self._ends[:, 2]
        for p in np.argsort(self.metric(ends, q_to), kind="stable"):
            body = self._dense[p]
            if backwards:
                poses = place(body, ends[p])
                poses[-1] = q_from
            else:
                poses = place(body, q_from)
            d = self._dirs[p]
            if self.checker.path_free(poses):
                q_new = poses[0].copy() if backwards else poses[-1].copy()
                if tree is not None and self.tree_distances(tree, q_new).min() <= SAME_NODE:
                    continue  # back where the tree has been (a primitive and its reverse): no new node
                return q_new, poses, np.full(poses.shape[0], d)
        return None

    def _extend_curve(self, q_from: FloatArray, q_to: FloatArray, backwards: bool) -> Motion | None:
        if backwards:  # the curve from the target to the node, its last step_range of arc
            motion = self._checked(q_to, q_from, self.step_range, True, 2)
        else:
            motion = self._checked(q_from, q_to, self.step_range, False, 2)
        if motion is None:
            return None
        poses, dirs = motion
        q_new = poses[0].copy() if backwards else poses[-1].copy()
        return q_new, poses, dirs
