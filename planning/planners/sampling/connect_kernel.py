"""BiRRT's search on exact curves (Reeds–Shepp or Dubins), compiled: the loop of
:meth:`planning.planners.sampling.rrt.BiRRT._search_python` in one call per chunk of iterations.

Per iteration the Python loop made a dozen calls into compiled code and numpy (sample, nearest node,
steer, check order, classify, settle, tree append, metric), each paying Python's and numba's call
cost: on the small problems of ``nhsim bench plan`` that cost was most of a plan's time. Here the
same steps run in one compiled loop, with the same arithmetic in the same order, so the trees, the
joint and the path are the same as the Python loop's for the same seed (tests compare them):

* the uniform numbers come from the run's generator, drawn ahead in blocks by the caller (the same
  stream: one number for the goal bias, three for a sample);
* nearest nodes by the (x, y, cos, sin) metric, first of equals (:func:`.tree._se2_distances`);
* extensions along the shortest curve cut to the range (:func:`.fastcurve.cut_word`), checked pose
  by pose in OMPL's order (the new end, the other end, then bisection: :func:`word_free`), each pose
  computed when it is checked, with the grid's proof and, where it cannot decide, the exact
  formulas (:func:`planning.collision.grid.pose_free`), stopping at the first pose not free (OMPL's
  motion validator interpolates the states it checks the same way; sampling every curve whole
  before checking it cost more than the checks on the problems where most extensions collide).

A tree node keeps its parent and the pose its extension steered toward (``targets``), so its edge's
dense motion can be solved again, identically, when the search has ended (:func:`edge_motions`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.collision.grid import CheckArrays, pose_free
from planning.planners.sampling.fastcurve import CutWord, cut_word, steer_kernel, word_pose, word_size
from planning.planners.sampling.tree import Tree

if TYPE_CHECKING:
    from planning.planners.base import PlanProblem
    from planning.planners.sampling.extend import LocalPlanner
    from planning.planners.sampling.rrt import BiRRTConfig

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: What a chunk ended on (:func:`search_chunk`'s first result).
CHUNK_DONE, JOINED, NEED_ROOM, NEED_UNIFORMS, BAD_CURVE = 0, 1, 2, 3, 4


@nb.njit(cache=True)
def word_free(word: CutWord, rho: float, new_first: bool, chk: CheckArrays, spans: IntArray) -> bool:
    """Whether every dense pose of a cut word (:mod:`.fastcurve`) is free, checked in OMPL's order
    (the new end, the first pose with ``new_first`` else the last, then the other end, then the
    interior by breadth-first bisection: :func:`planning.planners.sampling.extend.check_order`),
    each pose computed when it is checked, stopping at the first that is not free. ``spans``:
    scratch space (replaced when shorter than 4 n + 8)."""
    n = word_size(word)
    if spans.shape[0] < 4 * n + 8:
        spans = np.empty(4 * n + 8, dtype=np.int64)
    first, second = (0, n - 1) if new_first else (n - 1, 0)
    x, y, th, _ = word_pose(word, first, rho)
    if not pose_free(x, y, th, chk):
        return False
    if n == 1:
        return True
    x, y, th, _ = word_pose(word, second, rho)
    if not pose_free(x, y, th, chk):
        return False
    head, tail = 0, 1
    spans[0], spans[1] = 1, n - 2
    while head < tail:
        lo, hi = spans[2 * head], spans[2 * head + 1]
        head += 1
        if lo > hi:
            continue
        mid = (lo + hi) // 2
        x, y, th, _ = word_pose(word, mid, rho)
        if not pose_free(x, y, th, chk):
            return False
        spans[2 * tail], spans[2 * tail + 1] = lo, mid - 1
        spans[2 * tail + 2], spans[2 * tail + 3] = mid + 1, hi
        tail += 2
    return True


@nb.njit(cache=True)
def steer_free(
    rs: bool,
    q0: FloatArray,
    q1: FloatArray,
    geometry: FloatArray,
    max_len: float,
    keep_end: bool,
    min_poses: int,
    chk: CheckArrays,
    spans: IntArray,
) -> tuple[CutWord, int]:
    """The cut word from ``q0`` to ``q1`` (:func:`.fastcurve.cut_word`; ``geometry``: rho, sample step)
    and its verdict: 1 every pose free (the new end, its first pose with ``keep_end``, checked
    first), 0 not (or fewer than ``min_poses`` poses), -1 no curve verifies (non-finite poses)."""
    rho = geometry[0]
    word, ok = cut_word(rs, q0, q1, rho, geometry[1], max_len, keep_end)
    if not ok:
        return word, -1
    if word_size(word) < min_poses or not word_free(word, rho, keep_end, chk, spans):
        return word, 0
    return word, 1


@nb.njit(cache=True)
def _nearest(nodes: FloatArray, headings: FloatArray, n: int, q: FloatArray) -> int:
    """Index of the node nearest ``q`` by the (x, y, cos, sin) metric, first of equals (the numbers of
    :func:`planning.planners.sampling.tree._se2_distances`)."""
    cq, sq = np.cos(q[2]), np.sin(q[2])
    best, best_d = 0, np.inf
    for i in range(n):
        dx = nodes[i, 0] - q[0]
        dy = nodes[i, 1] - q[1]
        dc = headings[i, 0] - cq
        ds = headings[i, 1] - sq
        d = np.sqrt(dx * dx + dy * dy + dc * dc + ds * ds)
        if d < best_d:
            best, best_d = i, d
    return best


@nb.njit(cache=True)
def _grow(
    nodes: FloatArray,
    headings: FloatArray,
    parents: IntArray,
    targets: FloatArray,
    n: int,
    backwards: bool,
    i: int,
    target: FloatArray,
    geometry: FloatArray,
    rs: bool,
    chk: CheckArrays,
    spans: IntArray,
) -> int:
    """Extend node ``i`` toward ``target`` (``LocalPlanner.extend`` on exact curves) and append the new
    node at index ``n``: returns ``n``, -1 when the motion collides or is shorter than a step, -2 when
    no curve verifies (non-finite poses). ``geometry``: (rho, sample step, range)."""
    if backwards:
        word, verdict = steer_free(rs, target, nodes[i], geometry, geometry[2], True, 2, chk, spans)
    else:
        word, verdict = steer_free(rs, nodes[i], target, geometry, geometry[2], False, 2, chk, spans)
    if verdict < 0:
        return -2
    if verdict == 0:
        return -1
    x, y, th, _ = word_pose(word, 0 if backwards else word_size(word) - 1, geometry[0])
    nodes[n, 0], nodes[n, 1], nodes[n, 2] = x, y, th
    for c in range(3):
        targets[n, c] = target[c]
    headings[n, 0], headings[n, 1] = np.cos(nodes[n, 2]), np.sin(nodes[n, 2])
    parents[n] = i
    return n


@nb.njit(cache=True)
def search_chunk(
    nodes_a: FloatArray,
    head_a: FloatArray,
    par_a: IntArray,
    tgt_a: FloatArray,
    nodes_b: FloatArray,
    head_b: FloatArray,
    par_b: IntArray,
    tgt_b: FloatArray,
    state: IntArray,
    uniforms: FloatArray,
    stop_it: int,
    bounds: FloatArray,
    geometry: FloatArray,
    rs: bool,
    connect_steps: int,
    chk: CheckArrays,
) -> tuple[int, int, int]:
    """Run BiRRT's iterations until ``state[2]`` (the iteration count) reaches ``stop_it`` or the trees
    join.

    Args:
        nodes_a, head_a, par_a, tgt_a: The start tree: (cap, 3) poses, (cap, 2) cos and sin of their
            headings, (cap,) parents, (cap, 3) extension targets; filled up to ``state[0]`` nodes.
        nodes_b, head_b, par_b, tgt_b: The goal tree (grown backwards), ``state[1]`` nodes.
        state: (4,) node counts of the two trees, iterations done, next unused entry of ``uniforms``;
            updated in place.
        uniforms: Uniform numbers in [0, 1) of the run's generator, in order.
        stop_it: Iteration count at which to return.
        bounds: (4,) world bounds (xmin, xmax, ymin, ymax) [m].
        geometry: (rho, sample step, range, goal bias) [m, m, m, -].
        rs: Reeds–Shepp curves, else Dubins.
        connect_steps: Longest connect step (extensions of the other tree).
        chk: The checker (:meth:`planning.collision.grid.FastChecker.check_arrays`).

    Returns:
        (what, a, b): ``what`` one of :data:`CHUNK_DONE`, :data:`JOINED`, :data:`NEED_ROOM` (a tree's
        arrays cannot take another iteration's nodes), :data:`NEED_UNIFORMS`, :data:`BAD_CURVE`; when
        joined, the start-tree node ``a`` and the goal-tree node ``b`` (the same pose: an extension
        reached the other tree's node exactly).
    """
    spans = np.empty(4096, dtype=np.int64)
    goal_bias = geometry[3]
    while state[2] < stop_it:
        if state[0] + connect_steps + 2 > nodes_a.shape[0] or state[1] + connect_steps + 2 > nodes_b.shape[0]:
            return NEED_ROOM, -1, -1
        if state[3] + 4 > uniforms.shape[0]:
            return NEED_UNIFORMS, -1, -1
        state[2] += 1
        grow_a = state[2] % 2 == 1
        # the sample: the other tree's root with the goal bias, else a uniform pose (tree.sample_pose)
        u = uniforms[state[3]]
        state[3] += 1
        if u < goal_bias:
            q = nodes_b[0].copy() if grow_a else nodes_a[0].copy()
        else:
            u0, u1, u2 = uniforms[state[3]], uniforms[state[3] + 1], uniforms[state[3] + 2]
            state[3] += 3
            q = np.array(
                [
                    bounds[0] + u0 * (bounds[1] - bounds[0]),
                    bounds[2] + u1 * (bounds[3] - bounds[2]),
                    np.pi * (2 * u2 - 1),
                ]
            )
        gn, gh, gp, gt = (nodes_a, head_a, par_a, tgt_a) if grow_a else (nodes_b, head_b, par_b, tgt_b)
        on, oh, op, ot = (nodes_b, head_b, par_b, tgt_b) if grow_a else (nodes_a, head_a, par_a, tgt_a)
        g_idx, o_idx = (0, 1) if grow_a else (1, 0)
        i = _nearest(gn, gh, state[g_idx], q)
        j = _grow(gn, gh, gp, gt, state[g_idx], not grow_a, i, q, geometry, rs, chk, spans)
        if j == -2:
            return BAD_CURVE, -1, -1
        if j < 0:
            continue
        state[g_idx] += 1
        target = gn[j].copy()
        k = _nearest(on, oh, state[o_idx], target)
        for _ in range(connect_steps):
            a, b = (j, k) if grow_a else (k, j)
            pa, pb = nodes_a[a], nodes_b[b]
            if pa[0] == pb[0] and pa[1] == pb[1] and pa[2] == pb[2]:
                return JOINED, a, b
            k_new = _grow(on, oh, op, ot, state[o_idx], grow_a, k, target, geometry, rs, chk, spans)
            if k_new == -2:
                return BAD_CURVE, -1, -1
            if k_new < 0:
                break
            state[o_idx] += 1
            k = k_new
    return CHUNK_DONE, -1, -1


@nb.njit(cache=True)
def edge_motions(
    nodes: FloatArray,
    parents: IntArray,
    targets: FloatArray,
    n: int,
    backwards: bool,
    geometry: FloatArray,
    rs: bool,
) -> tuple[FloatArray, FloatArray, IntArray]:
    """The dense edge motions of nodes 1..n-1 of a tree grown by :func:`search_chunk`, solved again as
    they were when each node was added (the same curve, the same samples).

    Returns:
        Poses (K, 3) and directions (K,) of all edges in node order, and (n + 1,) offsets: node ``i``'s
        edge is rows ``offsets[i]:offsets[i + 1]`` (none for the root).
    """
    rho, step, rng = geometry[0], geometry[1], geometry[2]
    offsets = np.zeros(n + 1, dtype=np.int64)
    parts_p = []
    parts_d = []
    for i in range(1, n):
        p = parents[i]
        if backwards:
            poses, dirs, _ = steer_kernel(rs, targets[i], nodes[p], rho, step, rng, True)
        else:
            poses, dirs, _ = steer_kernel(rs, nodes[p], targets[i], rho, step, rng, False)
        parts_p.append(poses)
        parts_d.append(dirs)
        offsets[i + 1] = offsets[i] + poses.shape[0]
    offsets[1] = 0
    total = offsets[n]
    out_p = np.empty((total, 3))
    out_d = np.empty(total)
    for i in range(1, n):
        a, b = offsets[i], offsets[i + 1]
        out_p[a:b] = parts_p[i - 1]
        out_d[a:b] = parts_d[i - 1]
    return out_p, out_d, offsets


#: Uniform numbers drawn ahead per refill (more are drawn when a chunk runs out).
UNIFORM_BLOCK = 256


class CompiledSearch:
    """The state of one compiled BiRRT search (both trees, the uniform numbers drawn ahead) between
    chunks of :func:`search_chunk`.

    Args:
        local: The run's local planner (exact curves, a checker with walls).
        problem: The problem (start, goal, world bounds).
        config: The planner's options (goal bias, connect steps).
    """

    def __init__(self, local: LocalPlanner, problem: PlanProblem, config: BiRRTConfig) -> None:
        chk = local.check_arrays
        if not local.exact or chk is None or local.rho is None:
            raise ValueError("the compiled search needs exact curves and a checker with walls")
        self._local, self._chk = local, chk
        self._rs = local.curves.kind == "reeds_shepp"
        self._geometry = np.array([local.rho, local.sample_step, local.step_range, config.goal_bias])
        self._bounds = np.asarray(problem.world.bounds, dtype=float)
        self._steps = config.connect_steps
        cap = 4 * (config.connect_steps + 2)
        self._a = self._tree(problem.start.as_array(), cap)
        self._b = self._tree(problem.goal.as_array(), cap)
        self._state = np.array([1, 1, 0, 0], dtype=np.int64)
        self._uniforms = np.empty(0)

    @staticmethod
    def _tree(root: FloatArray, cap: int) -> list[FloatArray | IntArray]:
        nodes, heads = np.empty((cap, 3)), np.empty((cap, 2))
        nodes[0] = root
        heads[0] = np.cos(nodes[0, 2]), np.sin(nodes[0, 2])
        return [nodes, heads, np.full(cap, -1, dtype=np.int64), np.zeros((cap, 3))]

    @property
    def iterations(self) -> int:
        """Iterations run so far."""
        return int(self._state[2])

    def run(self, rng: np.random.Generator, stop_it: int) -> tuple[int, int, int]:
        """Iterate until ``stop_it`` iterations are done or the trees join (``search_chunk``'s results,
        never NEED_ROOM or NEED_UNIFORMS: the arrays grow and numbers are drawn here as needed).

        Raises:
            ValueError: A curve did not verify (non-finite poses).
        """
        while True:
            out = search_chunk(
                *self._a, *self._b, self._state, self._uniforms, stop_it, self._bounds, self._geometry,
                self._rs, self._steps, self._chk,
            )  # fmt: skip
            what = int(out[0])
            if what == NEED_ROOM:
                self._a, self._b = self._grown(self._a), self._grown(self._b)
            elif what == NEED_UNIFORMS:  # the unused ones, then the stream's next
                self._uniforms = np.concatenate([self._uniforms[self._state[3] :], rng.random(UNIFORM_BLOCK)])
                self._state[3] = 0
            elif what == BAD_CURVE:
                raise ValueError("a Reeds-Shepp or Dubins curve of the search did not verify (non-finite poses)")
            else:
                return what, int(out[1]), int(out[2])

    @staticmethod
    def _grown(tree: list[FloatArray | IntArray]) -> list[FloatArray | IntArray]:
        out = []
        for arr in tree:
            more = np.full_like(arr, -1) if arr.dtype == np.int64 else np.zeros_like(arr)
            out.append(np.concatenate([arr, more]))
        return out

    def trees(self) -> tuple[Tree, Tree]:
        """The start and goal trees as :class:`~.tree.Tree` objects, their edges solved again."""
        return self._as_tree(self._a, int(self._state[0]), False), self._as_tree(self._b, int(self._state[1]), True)

    def _as_tree(self, arrays: list[FloatArray | IntArray], n: int, backwards: bool) -> Tree:
        nodes, heads, parents, targets = arrays
        tree = Tree(nodes[0], backwards=backwards, capacity=max(n, 1))
        tree.nodes[:n], tree.headings[:n], tree.parents[:n] = nodes[:n], heads[:n], parents[:n]
        tree.n = n
        poses, dirs, offsets = edge_motions(nodes, parents, targets, n, backwards, self._geometry, self._rs)
        for i in range(1, n):
            a, b = offsets[i], offsets[i + 1]
            tree.edges.append((poses[a:b], dirs[a:b]))
            tree.children.append([])
            tree.children[int(parents[i])].append(i)
        return tree
