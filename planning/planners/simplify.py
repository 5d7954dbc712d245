"""Path simplification for any planner that can steer exactly between two states (after OMPL's
``PathSimplifier``).

A sampling planner's first path wanders: motion primitives drive back and forth, trees grow around
obstacles before they meet. :func:`simplify_path` takes such a path, dense along the motion, and
makes it shorter with the planner's own steering, never touching anything but what it can prove:

1. **Loops**: stretches that return to a pose already visited are cut
   (:func:`planning.trajectory.smoothing.remove_loops`); what is left is made of the input's own steps.
2. **Greedy collapse** (back-and-forth, detours): from each vertex, in order, a shortcut to a later
   vertex is tried, largest estimated saving first (``greedy_tries`` of them), so a detour of many
   metres goes in one step. OMPL's ``collapseCloseVertices`` plays this part there.
3. **Cusps**: shortcuts across each cusp from points 5 cm to 1.6 m either side of it, and each
   stretch between cusps driven the other way round (same ground, heading turned by pi, entered
   and left by steered motions), which merges the cusps at both its ends when it passes.
4. **Shortcuts** (OMPL ``shortcutPath``): two points drawn at random along the path, the second
   within ``range_ratio`` of the path's length of the first, each snapped to a vertex when within
   ``snap_to_vertex`` of the length, otherwise a new vertex inside a piece; ``max_steps`` draws,
   stopping after ``max_empty_steps`` draws without a change (0: the number of vertices, as OMPL).
5. **Vertex reduction** (OMPL ``reduceVertices``): first the whole path as one motion, then random
   pairs of vertices at most ``1 + round(range_ratio * count)`` apart.

Steps 3 to 5 repeat, as OMPL's ``simplify`` does, for at most ``max_rounds`` rounds while they
change the path.

6. **Other ways round** (``routes``): shortcuts keep the way the path goes round each obstacle (a
   shortcut's motion stays near the stretch it replaces). So each route given, poses the caller
   took from a shorter way (the obstacle-aware 2-D route, :mod:`planning.planners.geodesic`), is
   joined by ``steer`` from the path's first pose to its last; when that path is collision-free it
   gets the greedy pass and one round, and, if it is then cheaper than the simplified path with no
   more cusps, the remaining rounds, and it becomes the result.

Every candidate replaces the stretch between two path states by the motion
``steer`` returns, and is kept only when all of these hold:

* its cost (``cost`` summed over the pieces between vertices) is lower by at least ``min_gain``
  (``distance``, a cheap lower bound, prunes hopeless candidates before steering);
* the path has no more cusps (direction reversals) than before;
* ``checker`` finds the new motion collision-free.

So the result is collision-free wherever the input was, starts and ends at the same poses, is never
costlier and never has more cusps (a route's path is checked whole and only taken when cheaper with
no more cusps than the simplified input). A motion found to collide is remembered by its end poses
and not steered or checked again. A cusp is merged whenever a shortcut across it passes the tests.
OMPL's B-spline smoothing is left out (it moves states off the steering's curves); smoothing for the
tracker happens later (:mod:`planning.trajectory.smoothing`).

The random draws come from ``seed``: the same path and seed give the same result, bit for bit.

With a ``deadline`` the simplification stops when it passes (looked at before every shortcut steered
and every vertex or cusp the passes consider; the time numba spends readying code is not counted,
as :mod:`planning.clock` does for the planners), and returns the path as far as it got: every
shortcut kept leaves a valid path, so what it returns is as good a result as any, only less
simplified. The routes are not asked for once it has passed; a ``routes`` callable that runs out of
time itself raises :class:`TimeoutError` (:class:`planning.collision.field.FieldTimeout`), and no
route is tried. ``SimplifiedPath.timed_out`` says whether the deadline cut it short.

Interface: ``steer(q_a, q_b)`` returns ``(poses (K, 3), directions (K,))`` dense enough for
``checker`` (the first pose ``q_a``, the last ``q_b``; directions of the motion arriving at each pose)
or None when it cannot join them; ``checker(poses)`` says whether dense poses are collision-free;
``cost(poses, directions)`` is the cost of one piece, >= 0 and additive over pieces (default: the
x-y length; :class:`DirectedLength` weights the backwards metres); ``distance(qs, q)`` (optional)
gives lower bounds of the steered motions' costs between (M, 3) and (3,) poses, broadcast either way,
no lower than the straight line between their positions (the greedy pass asks it only about the
vertices that line leaves among the best).
"""

from __future__ import annotations

import bisect
import itertools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.clock import PlanClock, code_seconds
from planning.core.checks import check_number
from planning.core.geometry import cumulative_length, path_length, path_steps
from planning.errors import ConfigError
from planning.trajectory.smoothing import remove_loops

FloatArray = NDArray[np.float64]
Motion = tuple[FloatArray, FloatArray]
#: ``steer(q_a, q_b)``: the exact motion from q_a to q_b, dense for the checker, or None.
Steer = Callable[[FloatArray, FloatArray], Motion | None]
#: ``checker(poses)``: whether (K, 3) dense poses are all collision-free.
Checker = Callable[[FloatArray], bool]
#: ``cost(poses, directions)``: the cost of one piece of path (additive over pieces).
PieceCost = Callable[[FloatArray, FloatArray], float]
#: ``distance(q0, q1)``: (M,) lower bounds of the steered motions' costs, q0 and q1 (M, 3) or (3,).
Distance = Callable[[FloatArray, FloatArray], FloatArray]


@dataclass(frozen=True)
class DirectedLength:
    """A piece's x-y length [m], each backwards metre counted ``reverse_weight`` times (>= 1; turns in
    place cost nothing): additive at any pose, as the plain length is, so the simplifier keeps its
    running sums and turned stretches with it. :data:`length_cost` (weight 1) is the default; a
    planner whose search prices reversing (Hybrid-A*'s ``reverse_penalty``) simplifies with its weight,
    so its path does not trade forward driving for a slightly shorter way backwards."""

    reverse_weight: float = 1.0

    def __post_init__(self) -> None:
        # below 1 a curve's length would no longer bound its cost from below (the pruning's premise)
        check_number("DirectedLength.reverse_weight", self.reverse_weight, at_least=1.0)

    def __call__(self, poses: FloatArray, directions: FloatArray) -> float:
        """The cost of the piece ``poses`` (K, 3), ``directions`` (K,) of the motion arriving at each
        (at weight 1 path_length's sum, without its checks: it is asked once per shortcut steered)."""
        if poses.shape[0] < 2:
            return 0.0
        steps = np.hypot(poses[1:, 0] - poses[:-1, 0], poses[1:, 1] - poses[:-1, 1])
        return float(np.sum(self.weighted(steps, directions)))

    def weighted(self, steps: FloatArray, directions: FloatArray) -> FloatArray:
        """The (N - 1,) ``steps`` [m] between N poses, each backwards one (``directions`` (N,) < 0 at
        its end) times the weight."""
        return steps if self.reverse_weight == 1.0 else steps * np.where(directions[1:] < 0.0, self.reverse_weight, 1.0)


#: The default piece cost: the x-y length of the poses [m].
length_cost = DirectedLength()


def count_cusps(directions: FloatArray | None) -> int:
    """Number of reversals of the direction of travel along a path.

    Args:
        directions: (N,) +1/-1 direction of the motion arriving at each pose (directions[0] repeats
            the first step's), or None (no reversals known: 0).
    """
    if directions is None:
        return 0
    d = np.asarray(directions, dtype=float).reshape(-1)
    return int(np.count_nonzero(d[2:] != d[1:-1])) if d.size > 2 else 0


@dataclass(frozen=True)
class SimplifyConfig:
    """Parameters of :func:`simplify_path` (OMPL's defaults where OMPL has the parameter).

    Attributes:
        max_rounds: Rounds of shortcuts and vertex reduction (OMPL's ``simplify`` repeats its
            shortcuts up to 5 times; 3 here, after the greedy collapse has done the bulk, keeps the
            simplification within 50 ms on the benchmark's problems).
        max_steps: Draws per shortcut or reduction pass; 0: the number of vertices (OMPL), but at
            least ``min_steps``.
        max_empty_steps: Draws without a change that end a pass; 0: as ``max_steps``.
        min_steps: Fewest draws per pass when ``max_steps`` is 0: a short path of few vertices still
            gets enough tries (OMPL draws as many times as there are vertices).
        range_ratio: Largest distance between the two points of a draw, as a fraction of the path's
            length (shortcuts) or of its vertex count (reduction); OMPL: 0.33.
        snap_to_vertex: A drawn point within this fraction of the path's length of a vertex is
            that vertex (OMPL: 0.005).
        greedy_tries: Shortcuts tried from each vertex in the greedy collapse (0 skips it).
        cusp_tries: Shortcuts tried across each cusp, from points up to 1.6 m before it to points up
            to 1.6 m after it (0 skips them and the turned stretches).
        turn_stretches: Try driving each stretch between cusps the other way round; only for a robot
            that may drive any stretch in either direction (Reeds–Shepp cars, differential drives),
            not for forward-only steering.
        vertex_spacing: Without given vertices, the path's own are placed at its ends, its cusps and
            every ``vertex_spacing`` of x-y length [m], ...
        max_vertices: ... but no closer than the path's length over ``max_vertices``.
        min_gain: Smallest cost saving that makes a shortcut worth keeping.
    """

    max_rounds: int = 3
    max_steps: int = 0
    max_empty_steps: int = 0
    min_steps: int = 20
    range_ratio: float = 0.33
    snap_to_vertex: float = 0.005
    greedy_tries: int = 3
    cusp_tries: int = 6
    turn_stretches: bool = True
    vertex_spacing: float = 0.25
    max_vertices: int = 100
    min_gain: float = 1e-6

    def __post_init__(self) -> None:
        checks = [
            (self.max_rounds >= 0, "max_rounds must be >= 0"),
            (self.max_steps >= 0, "max_steps must be >= 0 (0: the number of vertices)"),
            (self.max_empty_steps >= 0, "max_empty_steps must be >= 0 (0: as max_steps)"),
            (self.min_steps >= 0, "min_steps must be >= 0"),
            (self.max_vertices >= 2, "max_vertices must be >= 2"),
            (0.0 < self.range_ratio <= 1.0, "range_ratio must be in (0, 1]"),
            (0.0 <= self.snap_to_vertex < 0.5, "snap_to_vertex must be in [0, 0.5)"),
            (self.greedy_tries >= 0, "greedy_tries must be >= 0"),
            (self.cusp_tries >= 0, "cusp_tries must be >= 0"),
            (self.vertex_spacing > 0.0, "vertex_spacing must be > 0 m"),
            (self.min_gain >= 0.0, "min_gain must be >= 0"),
        ]
        for ok, msg in checks:
            if not ok:
                raise ConfigError(f"SimplifyConfig: {msg}")


@dataclass(frozen=True)
class SimplifiedPath:
    """What :func:`simplify_path` returns.

    Attributes:
        path: (N, 3) dense poses of the simplified path.
        directions: (N,) +1/-1 direction of the motion arriving at each pose.
        vertices: (V,) indices into ``path`` of its vertices (the ends of its pieces).
        raw_length: x-y length of the input [m].
        length: x-y length of the result [m].
        raw_cusps: Cusps of the input.
        cusps: Cusps of the result.
        raw_cost: Cost of the input (``cost`` summed over its pieces).
        cost: Cost of the result.
        shortcuts: Shortcuts kept.
        attempts: Shortcuts steered (after the ``distance`` pruning), on every route tried.
        route: Which way the result goes: -1 the input's, k the k-th of ``routes``.
        time_s: Wall time of the simplification [s].
        cpu_s: CPU time of the simplification's thread [s] (what the wall time is on an idle machine).
        code_s: Of ``time_s``, the time numba spent readying the kernels the simplification calls
            (loading them from its disk cache in a new process; 0 once loaded) [s].
        timed_out: Whether the deadline stopped it before it had done all it would have.
    """

    path: FloatArray
    directions: FloatArray
    vertices: NDArray[np.int64]
    raw_length: float
    length: float
    raw_cusps: int
    cusps: int
    raw_cost: float
    cost: float
    shortcuts: int
    attempts: int
    route: int
    time_s: float
    cpu_s: float
    code_s: float
    timed_out: bool = False

    def stats(self) -> dict[str, float | int | bool]:
        """The numbers a plan reports: raw and simplified length, cusps and cost, the shortcuts kept
        and the time (wall, CPU, and the wall time numba spent readying code) [m, s], and whether the
        deadline cut it short."""
        return {
            "raw_length_m": self.raw_length,
            "length_m": self.length,
            "raw_cusps": self.raw_cusps,
            "cusps": self.cusps,
            "raw_cost": self.raw_cost,
            "simplified_cost": self.cost,
            "shortcuts": self.shortcuts,
            "simplify_route": self.route,
            "simplify_time_s": self.time_s,
            "simplify_cpu_s": self.cpu_s,
            "simplify_code_s": self.code_s,
            "simplify_time_limit_reached": self.timed_out,
        }


def default_vertices(
    path: FloatArray, directions: FloatArray, cfg: SimplifyConfig, arc: FloatArray | None = None
) -> list[int]:
    """Vertices of a dense path: its ends, the poses at its cusps, and one every ``vertex_spacing``
    (or every ``1 / max_vertices`` of the length if that is longer) [m]; ``arc``: the path's
    :func:`planning.core.geometry.cumulative_length` if already known."""
    n = path.shape[0]
    arc = cumulative_length(path) if arc is None else arc
    spacing = max(cfg.vertex_spacing, float(arc[-1]) / cfg.max_vertices)
    marks = np.searchsorted(arc, np.arange(spacing, arc[-1], spacing))
    cusp = np.flatnonzero(directions[2:] != directions[1:-1]) + 1
    return sorted({0, n - 1, *marks.tolist(), *cusp.tolist()} - {n})


class _OutOfTime(TimeoutError):
    """The simplification's deadline passed (raised between shortcuts: the path is whole)."""


class _Work:
    """The path being simplified: dense poses, directions, vertices and the cost of each piece."""

    def __init__(
        self,
        poses: FloatArray,
        dirs: FloatArray,
        verts: list[int],
        fns: tuple[Steer, Checker, PieceCost],
        arc: FloatArray | None = None,
        clock: PlanClock | None = None,
    ) -> None:
        self.poses, self.dirs, self.verts = poses, dirs, verts
        self.steer, self.checker, self.cost = fns
        #: The deadline's clock (None: no deadline), see :meth:`check_time`.
        self.clock = clock
        self.arc = cumulative_length(poses) if arc is None else arc
        self.carc = self._running_cost()
        self.pcost = [self.piece(a, b) for a, b in itertools.pairwise(verts)]
        self.kept = 0
        self.attempts = 0
        #: Pose pairs (their bytes) whose steered motion collides: refused again without steering or
        #: checking (the motion between the same two poses is always the same).
        self.collides: set[bytes] = set()

    def _running_cost(self) -> FloatArray | None:
        """The cost from the first pose to each, for a :class:`DirectedLength` cost (the x-y length's
        running sums themselves at weight 1); None for other costs."""
        if not isinstance(self.cost, DirectedLength):
            return None
        if self.cost.reverse_weight == 1.0:
            return self.arc
        return np.concatenate([[0.0], np.cumsum(self.cost.weighted(np.diff(self.arc), self.dirs))])

    def check_time(self) -> None:
        """Raise :class:`_OutOfTime` once the deadline has passed."""
        if self.clock is not None and self.clock.expired():
            raise _OutOfTime

    def piece(self, a: int, b: int) -> float:
        """Cost of poses a..b (straight from the running sums for a :class:`DirectedLength` cost)."""
        if self.carc is not None:
            return float(self.carc[b] - self.carc[a])
        return self.cost(self.poses[a : b + 1], self.dirs[a : b + 1])

    def total(self) -> float:
        """The path's cost."""
        return float(sum(self.pcost))

    @staticmethod
    def _cusps(before: float | None, mid: FloatArray, after: float | None) -> int:
        """Reversals along the directions ``before``, ``mid`` (M,), ``after`` (None: no such end)."""
        if mid.size == 0:
            return int(before is not None and after is not None and before != after)
        n = int(np.count_nonzero(mid[1:] != mid[:-1]))
        return n + int(before is not None and before != mid[0]) + int(after is not None and after != mid[-1])

    def _motion(self, qa: FloatArray, qb: FloatArray, turn: tuple[int, int] | None) -> Motion | None:
        """The steered motion from qa to qb; with ``turn = (m1, m2)``: steered to pose m1 turned by pi,
        then poses m1..m2 driven the other way round (same ground, heading turned by pi, opposite
        direction), then steered from pose m2 turned to qb."""
        if turn is None:
            return self.steer(qa, qb)
        m1, m2 = turn
        mid = self.poses[m1 : m2 + 1] + np.array([0.0, 0.0, np.pi])
        first, last = self.steer(qa, mid[0]), self.steer(mid[-1], qb)
        if first is None or last is None:
            return None
        poses = np.vstack([first[0], mid[1:], last[0][1:]])
        return poses, np.concatenate([first[1], -self.dirs[m1 + 1 : m2 + 1], last[1][1:]])

    def _estimate(
        self, a: int, b: int, distance: Distance | None, turn: tuple[int, int] | None, known: float | None
    ) -> float:
        """A lower bound of the cost of the motion from pose a to pose b (0 without ``distance``):
        ``distance`` between them, or with ``turn = (m1, m2)`` that of its two steered ends plus the
        turned stretch's length. ``known``: the bound between a and b (or the two ends' sum) that
        the caller already asked ``distance`` for (the same number, not asked again)."""
        if distance is None:
            return 0.0
        p = self.poses
        if turn is None:
            return known if known is not None else float(distance(p[a], p[b])[0])
        m1, m2 = turn
        if known is None:
            flip = np.array([0.0, 0.0, np.pi])
            known = float(np.sum(distance(np.vstack([p[a], p[m2] + flip]), np.vstack([p[m1] + flip, p[b]]))))
        return float(known + self.arc[m2] - self.arc[m1])

    def shortcut(
        self,
        a: int,
        b: int,
        distance: Distance | None,
        min_gain: float,
        turn: tuple[int, int] | None = None,
        known: float | None = None,
    ) -> bool:
        """Replace poses a..b (a < b, dense indices) by the steered motion (driving poses m1..m2 the
        other way round with ``turn = (m1, m2)``, a < m1 < m2 < b) if it passes every test;
        ``known``: the ``distance`` bound already measured (see :meth:`_estimate`)."""
        self.check_time()
        if b - a < 2:
            return False
        p, verts = self.poses, self.verts
        k_lo = bisect.bisect_right(verts, a) - 1
        k_hi = bisect.bisect_left(verts, b)
        v_lo, v_hi = verts[k_lo], verts[k_hi]
        old = float(sum(self.pcost[k_lo:k_hi]))
        est = self._estimate(a, b, distance, turn, known)
        if not est < old - min_gain:  # costs are >= 0: the pieces kept around it only add
            return False
        pre = self.piece(v_lo, a) if a > v_lo else 0.0
        post = self.piece(b, v_hi) if b < v_hi else 0.0
        budget = old - pre - post - min_gain
        if not est < budget:
            return False
        key = p[a].tobytes() + p[b].tobytes() if turn is None else None
        if key in self.collides:
            return False
        self.attempts += 1
        motion = self._motion(p[a], p[b], turn)
        if motion is None:
            return False
        m_poses, m_dirs = motion
        c_new = self.cost(m_poses, m_dirs)
        if not c_new < budget:
            return False
        n = p.shape[0]
        before = float(self.dirs[a]) if a > 0 else None
        after = float(self.dirs[b + 1]) if b + 1 < n else None
        if self._cusps(before, m_dirs[1:], after) > self._cusps(before, self.dirs[a + 1 : b + 1], after):
            return False
        if not self.checker(m_poses):
            if key is not None:
                self.collides.add(key)
            return False
        self._apply(a, b, m_poses, m_dirs, (k_lo, k_hi, pre, c_new, post))
        return True

    def _apply(
        self, a: int, b: int, m_poses: FloatArray, m_dirs: FloatArray, piece: tuple[int, int, float, float, float]
    ) -> None:
        """Splice the motion in for poses a..b; ``piece``: the first and last piece replaced, and the
        costs of the kept part before a, of the motion and of the kept part after b."""
        k_lo, k_hi, pre, c_new, post = piece
        verts, k = self.verts, m_poses.shape[0]
        first_dir = self.dirs[a] if a > 0 else m_dirs[0]
        mid = m_poses.copy()
        mid[0], mid[-1] = self.poses[a], self.poses[b]
        self.poses = np.vstack([self.poses[:a], mid, self.poses[b + 1 :]])
        self.dirs = np.concatenate([self.dirs[:a], [first_dir], m_dirs[1:], self.dirs[b + 1 :]])
        delta = a + k - 1 - b
        head = verts[: k_lo + 1] + ([a] if a > verts[k_lo] else [])
        tail = verts[k_hi:] if b < verts[k_hi] else verts[k_hi + 1 :]
        self.verts = [*head, a + k - 1, *(v + delta for v in tail)]
        costs = ([pre] if a > verts[k_lo] else []) + [c_new] + ([post] if b < verts[k_hi] else [])
        self.pcost = self.pcost[:k_lo] + costs + self.pcost[k_hi:]
        self.arc = cumulative_length(self.poses)
        self.carc = self._running_cost()
        self.kept += 1


def _best_gains(
    saved: FloatArray, lower: FloatArray, qa: FloatArray, qs: FloatArray, distance: Distance, k: int
) -> tuple[FloatArray, FloatArray]:
    """The gains ``saved - distance(qa, qs)`` of the candidates (rows of ``qs``) that can be among the
    ``k`` largest, -inf for the others, asking ``distance`` about as few as it can: candidates in
    order of their largest possible gain ``saved - lower`` (``lower`` <= ``distance``), in batches,
    until the k-th largest gain found exceeds every gain not yet asked about. The ``k`` largest
    (ties included) are those of asking about all of them. Also the distances asked (inf for the
    others)."""
    n = saved.size
    gain, dist = np.full(n, -np.inf), np.full(n, np.inf)
    upper = saved - lower + 1e-9  # rounding: a bound may come out below ``lower`` by an ulp
    order = np.argsort(-upper, kind="stable")
    batch, done = max(4 * k, 16), 0
    while done < n:
        idx = order[done : done + batch]
        dist[idx] = distance(qa, qs[idx])
        gain[idx] = saved[idx] - dist[idx]
        done += idx.size
        if done >= k and done < n and np.sort(gain[order[:done]])[-k] > upper[order[done]]:
            break
    return gain, dist


def _greedy(w: _Work, cfg: SimplifyConfig, distance: Distance | None) -> None:
    """From each vertex in turn, shortcuts to later vertices, largest estimated saving first (the
    straight line between two vertices, a lower bound of any motion's cost, spares ``distance`` the
    later vertices that cannot be among the best)."""
    i = 0
    while i < len(w.verts) - 2 and cfg.greedy_tries > 0:
        w.check_time()
        a = w.verts[i]
        later = np.asarray(w.verts[i + 2 :])
        saved = np.cumsum(w.pcost[i:])[1:]  # cost from vertex i to each later vertex
        line = np.hypot(*(w.poses[later, :2] - w.poses[a, :2]).T)
        if distance is not None:
            gain, dist = _best_gains(saved, line, w.poses[a], w.poses[later], distance, cfg.greedy_tries)
        else:
            gain, dist = saved - line, line
        order = np.argsort(-gain, kind="stable")[: cfg.greedy_tries]
        for o in order:
            if gain[o] > cfg.min_gain and w.shortcut(a, int(later[o]), distance, cfg.min_gain, None, float(dist[o])):
                break
        i += 1


#: Arc lengths [m] before and after a cusp from which the cusp pass tries to cut across it.
CUSP_SPANS = (0.05, 0.1, 0.2, 0.35, 0.6, 1.0, 1.6)


def _cusp_pass(w: _Work, cfg: SimplifyConfig, distance: Distance | None) -> bool:
    """Shortcuts across each cusp, from points 5 cm to 1.6 m before it to points as far after it,
    largest estimated saving first (``cusp_tries`` per cusp)."""
    changed, c = False, 0
    while cfg.cusp_tries > 0:
        w.check_time()
        flips = np.flatnonzero(w.dirs[2:] != w.dirs[1:-1]) + 1
        flips = flips[flips > c]
        if flips.size == 0:
            return changed
        c = int(flips[0])
        span = np.asarray(CUSP_SPANS)
        a = np.unique(np.searchsorted(w.arc, w.arc[c] - span[span <= w.arc[c]]))
        b = np.unique(np.minimum(np.searchsorted(w.arc, w.arc[c] + span), w.arc.size - 1))
        aa, bb = (g.ravel() for g in np.meshgrid(a, b))
        if distance is not None:
            est = distance(w.poses[aa], w.poses[bb])
        else:
            est = np.hypot(*(w.poses[bb, :2] - w.poses[aa, :2]).T)
        gain = w.arc[bb] - w.arc[aa] - est
        for o in np.argsort(-gain, kind="stable")[: cfg.cusp_tries]:
            a_o, b_o, e_o = int(aa[o]), int(bb[o]), float(est[o])
            if gain[o] > cfg.min_gain and w.shortcut(a_o, b_o, distance, cfg.min_gain, None, e_o):
                changed, c = True, int(aa[o])
                break
    return changed


#: Where a stretch between cusps is entered and left when it is driven the other way round
#: (fractions of its poses from either end).
TURN_AT = np.array([0.02, 0.05, 0.1, 0.2])


def _turned_pass(w: _Work, cfg: SimplifyConfig, distance: Distance | None) -> bool:
    """Cusps merged by driving a stretch the other way round: the stretch between two cusps (or a
    cusp and an end) is driven over the same ground in the opposite direction, heading turned by
    pi, entered from a point up to 0.35 m before it and left to a point up to 0.35 m after it by
    steered motions (2 ``cusp_tries`` per stretch, largest estimated saving first). Only for the
    default length cost (or a :class:`DirectedLength`), which is additive at any pose, so the joints
    need no vertices."""
    if w.carc is None or cfg.cusp_tries == 0 or not cfg.turn_stretches:
        return False
    spans = np.array([0.0, 0.35])
    changed, k = False, 0
    while True:
        w.check_time()
        flips = (np.flatnonzero(w.dirs[2:] != w.dirs[1:-1]) + 1).tolist()
        ends = [0, *flips, w.poses.shape[0] - 1]
        if not flips or k >= len(ends) - 1:
            return changed
        lo, hi = ends[k], ends[k + 1]
        k += 1
        a = np.unique(np.searchsorted(w.arc, w.arc[lo] - spans).clip(0, lo))
        b = np.unique(np.minimum(np.searchsorted(w.arc, w.arc[hi] + spans), w.arc.size - 1))
        for a_i, b_j, turn, bound in _turn_candidates(w, lo, hi, a, b, distance)[: 2 * cfg.cusp_tries]:
            if w.shortcut(a_i, b_j, distance, cfg.min_gain, turn, bound):
                changed, k = True, 0
                break


def _turn_candidates(
    w: _Work, lo: int, hi: int, a: NDArray[np.int64], b: NDArray[np.int64], distance: Distance | None
) -> list[tuple[int, int, tuple[int, int], float]]:
    """(a, b, (m1, m2), ends) for every start a, end b and entry m1 / exit m2 of the stretch lo..hi,
    largest estimated saving first (only those estimated to save anything); ``ends``: the bound of
    the two steered ends' costs (0 without ``distance``)."""
    n = hi - lo
    m1s = np.unique(np.round(lo + TURN_AT * n).astype(np.int64))
    m2s = np.unique(np.round(hi - TURN_AT * n).astype(np.int64))
    flip = np.array([0.0, 0.0, np.pi])
    combos = [
        (ai, m1, m2, bj)
        for ai, m1, m2, bj in itertools.product(a.tolist(), m1s.tolist(), m2s.tolist(), b.tolist())
        if ai < m1 < m2 < bj
    ]
    if not combos:
        return []
    c = np.array(combos, dtype=np.int64)
    ends = np.zeros(len(combos))
    if distance is not None:  # both steered ends of every candidate in one call
        starts = np.stack([w.poses[c[:, 0]], w.poses[c[:, 2]] + flip], axis=1).reshape(-1, 3)
        stops = np.stack([w.poses[c[:, 1]] + flip, w.poses[c[:, 3]]], axis=1).reshape(-1, 3)
        d = distance(starts, stops)
        ends = d[0::2] + d[1::2]
    out = []
    for (ai, m1, m2, bj), e in zip(combos, ends.tolist(), strict=True):
        gain = float(w.arc[bj] - w.arc[ai]) - e - float(w.arc[m2] - w.arc[m1])
        if gain > 0.0:
            out.append((gain, ai, bj, (m1, m2), e))
    out.sort(key=lambda c: -c[0])
    return [(ai, bj, turn, e) for _, ai, bj, turn, e in out]


def _draw(w: _Work, p: float, threshold: float) -> int:
    """The dense index at arc length ``p``, snapped to a vertex within ``threshold``."""
    idx = min(int(np.searchsorted(w.arc, p)), w.arc.size - 1)
    k = bisect.bisect_left(w.verts, idx)
    for v in w.verts[max(0, k - 1) : k + 1]:
        if abs(w.arc[v] - p) < threshold:
            return v
    return idx


def _steps(w: _Work, cfg: SimplifyConfig) -> tuple[int, int]:
    """Draws of one pass and draws without a change that end it."""
    steps = cfg.max_steps or max(len(w.verts), cfg.min_steps)
    return steps, cfg.max_empty_steps or steps


def _shortcut_pass(w: _Work, cfg: SimplifyConfig, rng: np.random.Generator, distance: Distance | None) -> bool:
    """OMPL's ``shortcutPath``: random pairs of points along the path (see the module doc)."""
    steps, empty = _steps(w, cfg)
    changed, nochange = False, 0
    for _ in range(steps):
        if nochange >= empty:
            break
        nochange += 1
        total = float(w.arc[-1])
        rd, threshold = cfg.range_ratio * total, cfg.snap_to_vertex * total
        p0 = rng.uniform(0.0, total)
        p1 = rng.uniform(max(0.0, p0 - rd), min(total, p0 + rd))
        i0, i1 = sorted((_draw(w, p0, threshold), _draw(w, p1, threshold)))
        if w.shortcut(i0, i1, distance, cfg.min_gain):
            changed, nochange = True, 0
    return changed


def _reduce_pass(w: _Work, cfg: SimplifyConfig, rng: np.random.Generator, distance: Distance | None) -> bool:
    """OMPL's ``reduceVertices``: the whole path as one motion, else random pairs of vertices."""
    if len(w.verts) < 3:
        return False
    if w.shortcut(0, w.poses.shape[0] - 1, distance, cfg.min_gain):
        return True
    steps, empty = _steps(w, cfg)
    changed, nochange = False, 0
    for _ in range(steps):
        count = len(w.verts)
        if nochange >= empty or count < 3:
            break
        nochange += 1
        reach = 1 + int(np.floor(0.5 + count * cfg.range_ratio))
        p1 = int(rng.integers(0, count))
        p2 = int(rng.integers(max(p1 - reach, 0), min(count - 1, p1 + reach) + 1))
        if abs(p1 - p2) < 2:
            p2 = p1 + 2 if p1 < count - 2 else p1 - 2
            if not 0 <= p2 < count:
                continue
        lo, hi = sorted((p1, p2))
        if w.shortcut(w.verts[lo], w.verts[hi], distance, cfg.min_gain):
            changed, nochange = True, 0
    return changed


def _rounds(w: _Work, cfg: SimplifyConfig, distance: Distance | None, rng: np.random.Generator, rounds: int) -> bool:
    """Up to ``rounds`` rounds of steps 3 to 5 of the module doc on ``w``, while they change it;
    returns whether the last one run still changed it (more rounds might)."""
    for _ in range(rounds):
        changed = _cusp_pass(w, cfg, distance)
        changed |= _turned_pass(w, cfg, distance)
        changed |= _shortcut_pass(w, cfg, rng, distance)
        changed |= _reduce_pass(w, cfg, rng, distance)
        if not changed:
            return False
    return True


def _route_work(w: _Work, route: FloatArray) -> _Work | None:
    """The path steered from ``w``'s first pose through the (W, 3) ``route`` poses to its last, if
    every piece steers and the whole is collision-free (else None). Its vertices are the route's
    poses: each steered piece is one of the cost's pieces, and few vertices keep the greedy pass
    short on a path that has no detour to collapse."""
    qs = [w.poses[0], *np.asarray(route, dtype=float).reshape(-1, 3), w.poses[-1]]
    parts = [w.steer(a, b) for a, b in itertools.pairwise(qs)]
    if any(m is None for m in parts):
        return None
    motions = [m for m in parts if m is not None]
    poses = np.vstack([motions[0][0], *(m[0][1:] for m in motions[1:])])
    dirs = np.concatenate([motions[0][1], *(m[1][1:] for m in motions[1:])])
    poses[0], poses[-1] = w.poses[0], w.poses[-1]
    if not w.checker(poses):
        return None
    joints = np.cumsum([0, *(m[0].shape[0] - 1 for m in motions)]).tolist()
    return _Work(poses, dirs, joints, (w.steer, w.checker, w.cost), clock=w.clock)


def _best_route(
    w: _Work, routes: Sequence[FloatArray], cfg: SimplifyConfig, distance: Distance | None, seed: int
) -> tuple[_Work, int, int, bool]:
    """The cheapest of the simplified path ``w`` and the paths steered through ``routes`` and
    simplified the same way, among those with no more cusps than ``w``; which one it is (-1: ``w``),
    the shortcuts steered on all of them, and whether the deadline stopped it. A route gets one round
    first and the rest only if it beats the best so far (more rounds only make it cheaper); a route
    the deadline cut short competes as far as it got (every shortcut kept leaves it whole)."""
    best, chosen, attempts = w, -1, w.attempts
    for k, r in enumerate(routes):
        if w.clock is not None and w.clock.expired():
            return best, chosen, attempts, True
        alt = _route_work(w, r)
        if alt is None:
            continue
        rng = np.random.default_rng(seed)
        late = False
        try:
            _greedy(alt, cfg, distance)
            more = _rounds(alt, cfg, distance, rng, min(1, cfg.max_rounds))
        except _OutOfTime:
            more, late = False, True
        if alt.total() < best.total() - cfg.min_gain and count_cusps(alt.dirs) <= count_cusps(best.dirs):
            try:
                if more:
                    _rounds(alt, cfg, distance, rng, cfg.max_rounds - 1)
            except _OutOfTime:
                late = True
            best, chosen = alt, k
        attempts += alt.attempts
        if late:
            return best, chosen, attempts, True
    return best, chosen, attempts, False


def _simplify(
    w: _Work,
    cfg: SimplifyConfig,
    distance: Distance | None,
    seed: int,
    routes: Sequence[FloatArray] | Callable[[], Sequence[FloatArray]],
) -> tuple[Sequence[FloatArray], bool]:
    """Steps 2 to 5 of the module doc on ``w``, then the routes to try: those given, or asked of the
    callable; and whether the deadline passed first (then ``w`` is as far as it got and no route is
    tried: the deadline, here or in the routes callable)."""
    try:
        if w.poses.shape[0] >= 3:
            _greedy(w, cfg, distance)
            _rounds(w, cfg, distance, np.random.default_rng(seed), cfg.max_rounds)
        w.check_time()
        return ((routes() if callable(routes) else routes) if w.poses.shape[0] >= 3 else ()), False
    except TimeoutError:
        return (), True


def _inputs(
    path: FloatArray, directions: FloatArray | None, vertices: Sequence[int] | None, cfg: SimplifyConfig
) -> tuple[FloatArray, FloatArray, list[int] | None, FloatArray]:
    """:func:`simplify_path`'s path (N, 3), directions (N,), vertices (with the ends; None: not given) and
    the path's steps (N - 1,) [m], checked.

    Raises:
        ValueError: A path that is not (N, 3) finite poses, or directions of another length.
    """
    p = np.asarray(path, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 1 or not np.all(np.isfinite(p)):
        raise ValueError(f"simplify_path: path must be (N, 3) finite poses with N >= 1, got shape {p.shape}")
    d = np.ones(p.shape[0]) if directions is None else np.asarray(directions, dtype=float).reshape(-1)
    if d.size != p.shape[0]:
        raise ValueError(f"simplify_path: directions must have one entry per pose ({p.shape[0]}), got {d.size}")
    verts = sorted({0, p.shape[0] - 1, *(int(v) for v in vertices)}) if vertices is not None else None
    return p, d, verts, path_steps(p)


def simplify_path(
    path: FloatArray,
    directions: FloatArray | None,
    steer: Steer,
    checker: Checker,
    *,
    cost: PieceCost = length_cost,
    distance: Distance | None = None,
    vertices: Sequence[int] | None = None,
    routes: Sequence[FloatArray] | Callable[[], Sequence[FloatArray]] = (),
    config: SimplifyConfig | None = None,
    seed: int = 0,
    deadline: float | None = None,
) -> SimplifiedPath:
    """Simplify a dense path with exact steering (see the module doc).

    Args:
        path: (N, 3) poses [x, y, theta] densely along the motion, N >= 1.
        directions: (N,) +1/-1 direction of the motion arriving at each pose; None: all forwards.
        steer: Exact steering between two poses (dense motion or None).
        checker: Whether dense poses are collision-free.
        cost: Cost of one piece (additive over pieces); default the x-y length.
        distance: Lower bounds of steered costs, for pruning (optional).
        vertices: Indices of the path's vertices (increasing; the ends are added); None: the ends,
            the cusps and one every ``config.vertex_spacing`` metres. A cost that is not additive
            at every pose (a per-edge term, like C-RRT*'s) needs its own edges' ends here.
        routes: Other ways to go, each (W, 3) poses that ``steer`` joins from the path's first pose
            to its last (e.g. along the obstacle-aware 2-D route, :mod:`planning.planners.geodesic`):
            each one that steers and is collision-free is simplified the same way, and the result is
            the cheapest of all whose cusps are no more than the simplified path's. A callable is
            asked for them once the input is simplified (its time is counted in the result's); one
            that runs out of time raises :class:`TimeoutError`.
        config: Parameters (default :class:`SimplifyConfig`).
        seed: Seed of the random draws.
        deadline: ``time.perf_counter()`` value at which to stop with the path as far as it got (see the
            module doc); None: no limit.

    Returns:
        The simplified path with its lengths, cusps, costs and the time taken.

    Raises:
        ValueError: A path that is not (N, 3) finite poses, or directions of another length.
    """
    t0, c0, k0 = time.perf_counter(), time.thread_time(), code_seconds()
    clock = None if deadline is None else PlanClock(deadline - t0)
    cfg = config if config is not None else SimplifyConfig()
    p, d, verts, steps = _inputs(path, directions, vertices, cfg)
    arc = np.concatenate([[0.0], np.cumsum(steps)])  # cumulative_length(p), from the same steps
    raw = _Work(p, d, verts or default_vertices(p, d, cfg, arc), (steer, checker, cost), arc, clock)
    raw_cost, raw_len, raw_cusps = raw.total(), float(np.sum(steps)), count_cusps(d)
    w = raw
    if vertices is None:  # loops are cut only where the cost is the path's own (no per-edge terms)
        cut, cut_d = remove_loops(p, d)
        assert cut_d is not None
        if cut.shape[0] < p.shape[0]:
            w = _Work(cut, cut_d, default_vertices(cut, cut_d, cfg), (steer, checker, cost), clock=clock)
    ways, late = _simplify(w, cfg, distance, seed, routes)
    best, chosen, attempts, later = _best_route(w, ways, cfg, distance, seed)
    return SimplifiedPath(
        best.poses,
        best.dirs,
        np.asarray(best.verts, dtype=np.int64),
        raw_len,
        path_length(best.poses),
        raw_cusps,
        count_cusps(best.dirs),
        raw_cost,
        best.total(),
        best.kept,
        attempts,
        chosen,
        time.perf_counter() - t0,
        time.thread_time() - c0,
        code_seconds() - k0,
        late or later,
    )
