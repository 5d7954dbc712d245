"""BiRRT's search on exact curves (Reeds–Shepp or Dubins), compiled: the loop of
:func:`planning.planners.sampling.rrt._meet_python` in one call per chunk of iterations.

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

A tree node keeps its parent and its edge's dense poses (computed while they were checked), so the
trees come back as :class:`~.tree.Tree` objects without solving a curve again.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

from planning.clock import monotonic
from planning.collision.compiled import exact_pose_free, grid_lookup
from planning.collision.grid import CheckArrays, classify_pose, disc_margin
from planning.core.copy_kernels import copy_into, copy_rows_into
from planning.planners.base import PlanProblem, PlanTree
from planning.planners.sampling.fastcurve import CutWord, cut_word, word_pose, word_size
from planning.planners.sampling.tree import Side, Tree

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: A tree as the kernels grow it: poses (cap, 3), cos and sin of their headings (cap, 2), parents
#: (cap,), each node's rows [first, end) in the edge store (cap, 2), the edge store's dense poses
#: (E, 3) and directions (E,) (a node's edge runs from its parent to it, or from it to its parent in
#: a tree grown backwards, in driving order).
TreeArrays = tuple[FloatArray, FloatArray, IntArray, IntArray, FloatArray, FloatArray]

#: What a chunk ended on (:func:`search_chunk`'s first result).
CHUNK_DONE, JOINED, NEED_ROOM, NEED_UNIFORMS, BAD_CURVE, IN_REGION = 0, 1, 2, 3, 4, 5


@nb.njit(cache=True)
def _longest_piece(word: CutWord, rho: float) -> float:
    """The longest arc [m] between two consecutive dense poses of a cut word (a segment of arc L laid out in c
    pieces has pieces of L / c): no pose's position is further than that from the next one's."""
    _, _, seg, _, counts, _ = word
    longest = 0.0
    for k in range(seg.shape[0]):
        if counts[k] > 0:
            longest = max(longest, abs(seg[k]) * rho / counts[k])
    return longest


@nb.njit(cache=True)
def word_free(
    word: CutWord, rho: float, new_first: bool, chk: CheckArrays, spans: IntArray, out_p: FloatArray, out_d: FloatArray
) -> bool:
    """Whether every dense pose of a cut word (:mod:`.fastcurve`) is free, checked in OMPL's order
    (the new end, the first pose with ``new_first`` else the last, then the other end, then the
    interior by breadth-first bisection: :func:`planning.planners.sampling.extend.check_order`),
    each pose computed when it is checked (into ``out_p`` (>= n, 3) and its direction into ``out_d``
    (>= n,): all of them when the word is free) and proven by the grid
    (:func:`planning.collision.grid.classify_pose`) or, where it cannot decide, the exact formulas
    (the verdict of :func:`planning.collision.grid.pose_free`), stopping at the first that is not
    free. ``spans``: scratch space (replaced when shorter than 4 n + 8).

    A pose the grid proves free by its disc with a margin ``m`` (:func:`planning.collision.grid.disc_margin`)
    proves free every pose whose position is nearer than that, the signed distance being 1-Lipschitz: the poses within
    ``m / piece`` of it along the word (:func:`_longest_piece`) are computed but not classified. Their verdict
    is the one :func:`classify_pose` would give (its first test is that very disc), so the word's is too, and
    the poses checked before the first that is not free are fewer (about one in ten on the curves of a 6 x 6 m
    random world with seven obstacles)."""
    grid, x0, y0, h, boundary, footprint, anchors, radius, clearance, tol, disc, world, robot, field = chk
    n = word_size(word)
    if spans.shape[0] < 4 * n + 8:
        spans = np.empty(4 * n + 8, dtype=np.int64)
    piece = _longest_piece(word, rho) * (1.0 + 1e-9) + 1e-12  # the poses' rounding included
    proven = np.zeros(n, dtype=np.bool_)
    head, tail = 0, 1
    spans[0], spans[1] = 1, n - 2
    for k in range(n):
        if k == 0:
            j = 0 if new_first else n - 1
        elif k == 1:
            j = n - 1 if new_first else 0
        else:  # the next non-empty span's middle (breadth first)
            j = -1
            while head < tail and j < 0:
                lo, hi = spans[2 * head], spans[2 * head + 1]
                head += 1
                if lo <= hi:
                    j = (lo + hi) // 2
                    spans[2 * tail], spans[2 * tail + 1] = lo, j - 1
                    spans[2 * tail + 2], spans[2 * tail + 3] = j + 1, hi
                    tail += 2
        x, y, th, d = word_pose(word, j, rho)
        out_p[j, 0], out_p[j, 1], out_p[j, 2], out_d[j] = x, y, th, d
        if proven[j]:
            continue
        margin = disc_margin(grid_lookup(grid, x0, y0, h, x, y), h, radius, clearance, tol, disc)
        if margin > 0.0:  # classify_pose's first proof: free, and so are the poses nearer than the margin
            reach = int(np.ceil(margin / piece)) - 1  # reach * piece < margin
            for i in range(max(0, j - reach), min(n, j + reach + 1)):
                proven[i] = True
            continue
        c = classify_pose(x, y, th, grid, x0, y0, h, boundary, footprint, anchors, radius, clearance, tol, disc)
        if c == 0 or (c < 0 and not exact_pose_free(x, y, th, world, robot, field)):
            return False
    return True


@nb.njit(cache=True)
def steer_free(
    rs: bool,
    q0: FloatArray,
    q1: FloatArray,
    geometry: FloatArray,
    max_len: float,
    keep_end: bool,
    min_poses: int | np.int64,
    chk: CheckArrays,
    spans: IntArray,
    out_p: FloatArray,
    out_d: FloatArray,
) -> tuple[int, int, FloatArray, FloatArray]:
    """The cut word from ``q0`` to ``q1`` (:func:`.fastcurve.cut_word`; ``geometry``: rho, sample step)
    checked by :func:`word_free`.

    Returns:
        (n, verdict, poses, dirs): the word's number of dense poses; 1 every pose free (the new end,
        its first pose with ``keep_end``, checked first), 0 not (or fewer than ``min_poses`` poses),
        -1 no curve verifies (non-finite poses); ``out_p`` and ``out_d`` (or larger arrays when they
        hold fewer than n rows) whose first n rows are the dense poses and directions when free.
    """
    rho = geometry[0]
    word, ok = cut_word(rs, q0, q1, rho, geometry[1], max_len, keep_end)
    if not ok:
        return 0, -1, out_p, out_d
    n = word_size(word)
    if out_p.shape[0] < n:
        out_p, out_d = np.empty((n, 3)), np.empty(n)
    if n < min_poses or not word_free(word, rho, keep_end, chk, spans, out_p, out_d):
        return n, 0, out_p, out_d
    return n, 1, out_p, out_d


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
    tree: TreeArrays,
    n: int,
    fill: int,
    backwards: bool,
    i: int,
    target: FloatArray,
    geometry: FloatArray,
    rs: bool,
    chk: CheckArrays,
    scratch: tuple[IntArray, FloatArray, FloatArray],
) -> int:
    """Extend node ``i`` toward ``target`` (``LocalPlanner.extend`` on exact curves) and append the new
    node at index ``n``, its edge's dense poses at row ``fill`` of the tree's edge store: returns the
    edge's number of poses, -1 when the motion collides or is shorter than a step, -2 when no curve
    verifies (non-finite poses). ``geometry``: (rho, sample step, range)."""
    nodes, headings, parents, edge_rows, edge_p, edge_d = tree
    spans, buf_p, buf_d = scratch
    q0, q1 = (target, nodes[i]) if backwards else (nodes[i], target)
    # one call with keep_end a run-time bool: a literal True or False would have numba compile steer_free twice
    # and min_poses an int64, not the literal 2, for which it would compile a third specialisation
    m, verdict, p, d = steer_free(rs, q0, q1, geometry, geometry[2], backwards, np.int64(2), chk, spans, buf_p, buf_d)
    if verdict < 0:
        return -2
    if verdict == 0:
        return -1
    if fill + m > edge_p.shape[0]:
        raise ValueError("the edge store cannot take the motion (its room is checked before each iteration)")
    k = 0 if backwards else m - 1
    nodes[n, 0], nodes[n, 1], nodes[n, 2] = p[k, 0], p[k, 1], p[k, 2]
    headings[n, 0], headings[n, 1] = np.cos(nodes[n, 2]), np.sin(nodes[n, 2])
    parents[n] = i
    copy_rows_into(edge_p[fill : fill + m], p[:m])
    copy_into(edge_d[fill : fill + m], d[:m])
    edge_rows[n, 0], edge_rows[n, 1] = fill, fill + m
    return m


@nb.njit(cache=True)
def _room(tree: TreeArrays, n: int, fill: int, nodes: int, rows: int) -> bool:
    """Whether the tree's arrays can take ``nodes`` more nodes and ``rows`` more edge poses."""
    return n + nodes <= tree[0].shape[0] and fill + rows <= tree[4].shape[0]


@nb.njit(cache=True)
def _sample(
    uniforms: FloatArray, state: IntArray, bounds: FloatArray, goal_bias: float, root: FloatArray
) -> FloatArray:
    """The iteration's sample: the other tree's ``root`` with probability ``goal_bias``, else a uniform
    pose (:func:`.tree.sample_pose`), from the uniform numbers at ``state[3]`` (advanced)."""
    u = uniforms[state[3]]
    state[3] += 1
    if u < goal_bias:
        return root.copy()
    u0, u1, u2 = uniforms[state[3]], uniforms[state[3] + 1], uniforms[state[3] + 2]
    state[3] += 3
    x = bounds[0] + u0 * (bounds[1] - bounds[0])
    y = bounds[2] + u1 * (bounds[3] - bounds[2])
    return np.array([x, y, np.pi * (2 * u2 - 1)])


@nb.njit(cache=True)
def _in_region(q: FloatArray, goal: FloatArray, geometry: FloatArray) -> bool:
    """:func:`.tree.in_goal`'s test of pose ``q`` against the goal pose and the goal region's position [m] and
    heading [rad] tolerances, ``geometry[4:6]`` (-1, -1 where a start-tree node in the region does not end the
    search: nothing is in it)."""
    dth = (q[2] - goal[2] + np.pi) % (2 * np.pi) - np.pi
    return bool(np.hypot(q[0] - goal[0], q[1] - goal[1]) <= geometry[4] and abs(dth) <= geometry[5])


@nb.njit(cache=True)
def search_chunk(
    tree_a: TreeArrays,
    tree_b: TreeArrays,
    state: IntArray,
    uniforms: FloatArray,
    stop_it: int,
    deadline: float,
    bounds: FloatArray,
    geometry: FloatArray,
    rs: bool,
    connect_steps: int,
    max_motion: int,
    chk: CheckArrays,
) -> tuple[int, int, int]:
    """Run BiRRT's iterations until ``state[2]`` (the iteration count) reaches ``stop_it``, the trees join or the
    clock is past ``deadline`` before an iteration (one may take milliseconds among thousands of obstacles).

    Args:
        tree_a: The start tree (:data:`TreeArrays`), ``state[0]`` nodes and ``state[4]`` edge poses.
        tree_b: The goal tree (grown backwards), ``state[1]`` nodes and ``state[5]`` edge poses.
        state: (6,), updated: node counts of both trees, iterations, next unused ``uniforms``, both trees' edge poses.
        uniforms: Uniform numbers in [0, 1) of the run's generator, in order.
        stop_it, deadline: The iteration count, and the ``time.perf_counter()`` value, at which to return.
        bounds: (4,) world bounds (xmin, xmax, ymin, ymax) [m].
        geometry: (rho, sample step, range, goal bias, the region's two tolerances: :func:`_in_region`).
        rs: Reeds–Shepp curves, else Dubins.
        connect_steps: Longest connect step (extensions of the other tree).
        max_motion: Most dense poses of one extension (cut to the range).
        chk: The checker (:meth:`planning.collision.grid.FastChecker.check_arrays`).

    Returns:
        (what, a, b): ``what`` :data:`CHUNK_DONE`, :data:`JOINED`, :data:`NEED_ROOM` (``a``, ``b``: 1 where that
        tree's arrays cannot take another iteration's), :data:`NEED_UNIFORMS`, :data:`BAD_CURVE` or :data:`IN_REGION`;
        joined, the start-tree node ``a`` and the goal-tree node ``b`` (the same pose); in the region, its start-tree
        node ``a`` (``b`` 0).
    """
    scratch = (np.empty(4 * max_motion + 8, dtype=np.int64), np.empty((max_motion, 3)), np.empty(max_motion))
    goal_bias = geometry[3]
    most = connect_steps + 2
    while state[2] < stop_it and monotonic() <= deadline:
        room_a = _room(tree_a, state[0], state[4], most, most * max_motion)
        room_b = _room(tree_b, state[1], state[5], most, most * max_motion)
        if not (room_a and room_b):
            return NEED_ROOM, int(not room_a), int(not room_b)
        if state[3] + 4 > uniforms.shape[0]:
            return NEED_UNIFORMS, -1, -1
        state[2] += 1
        grow_a = state[2] % 2 == 1
        q = _sample(uniforms, state, bounds, goal_bias, tree_b[0][0] if grow_a else tree_a[0][0])
        grow, other = (tree_a, tree_b) if grow_a else (tree_b, tree_a)
        g, o = (0, 1) if grow_a else (1, 0)
        i = _nearest(grow[0], grow[1], state[g], q)
        m = _grow(grow, state[g], state[4 + g], not grow_a, i, q, geometry, rs, chk, scratch)
        if m == -2:
            return BAD_CURVE, -1, -1
        if m < 0:
            continue
        j = state[g]
        state[g] += 1
        state[4 + g] += m
        if grow_a and _in_region(tree_a[0][j], tree_b[0][0], geometry):
            return IN_REGION, j, 0
        target = grow[0][j].copy()
        k = _nearest(other[0], other[1], state[o], target)
        for _ in range(connect_steps):
            a, b = (j, k) if grow_a else (k, j)
            pa, pb = tree_a[0][a], tree_b[0][b]
            if pa[0] == pb[0] and pa[1] == pb[1] and pa[2] == pb[2]:
                return JOINED, a, b
            m = _grow(other, state[o], state[4 + o], grow_a, k, target, geometry, rs, chk, scratch)
            if m == -2:
                return BAD_CURVE, -1, -1
            if m < 0:
                break
            k = state[o]
            state[o] += 1
            state[4 + o] += m
            if not grow_a and _in_region(tree_a[0][k], tree_b[0][0], geometry):
                return IN_REGION, k, 0
    return CHUNK_DONE, -1, -1


#: Uniform numbers drawn ahead per refill (more are drawn when a chunk runs out).
UNIFORM_BLOCK = 256


@nb.njit(cache=True)
def _edge_poses(tree: TreeArrays, i: int) -> int:
    """Poses the edges from the root out to node ``i`` add after the root (each edge's first pose is its parent's)."""
    n = 0
    while i > 0:
        n += tree[3][i, 1] - tree[3][i, 0] - 1
        i = tree[2][i]
    return n


@nb.njit(cache=True)
def gather_path(tree_a: TreeArrays, tree_b: TreeArrays, a: int, b: int) -> tuple[FloatArray, FloatArray]:
    """Poses (K, 3) and directions (K,) from the start through start-tree node ``a`` and goal-tree node ``b`` (the
    same pose) to the goal: the start, then each edge's poses after its first, the start tree's from the root out
    and the goal tree's (grown backwards, each edge from its node to its parent) from ``b`` in; the first direction
    is the first edge's (1 when ``a`` is the start)."""
    na = 1 + _edge_poses(tree_a, a)
    n = na + _edge_poses(tree_b, b)
    poses, dirs = np.empty((n, 3)), np.empty(n)
    k, i, first = na, a, 1.0
    while i > 0:  # the start tree, filled from node a back to the root
        lo, hi = tree_a[3][i, 0] + 1, tree_a[3][i, 1]
        k -= hi - lo
        copy_rows_into(poses[k : k + hi - lo], tree_a[4][lo:hi])
        copy_into(dirs[k : k + hi - lo], tree_a[5][lo:hi])
        first = tree_a[5][lo - 1]
        i = tree_a[2][i]
    poses[0] = tree_a[0][0]
    dirs[0] = first
    k, i = na, b
    while i > 0:  # the goal tree, from node b in
        lo, hi = tree_b[3][i, 0] + 1, tree_b[3][i, 1]
        copy_rows_into(poses[k : k + hi - lo], tree_b[4][lo:hi])
        copy_into(dirs[k : k + hi - lo], tree_b[5][lo:hi])
        k += hi - lo
        i = tree_b[2][i]
    return poses, dirs


class CompiledSearch:
    """The state of one compiled BiRRT search (both trees, the uniform numbers drawn ahead) between
    chunks of :func:`search_chunk`.

    Args:
        chk: The checker (:meth:`planning.collision.grid.FastChecker.check_arrays`).
        reeds_shepp: Reeds–Shepp curves, else Dubins.
        geometry: (turning radius, sample step, range) [m] (``LocalPlanner``'s ``rho``,
            ``sample_step`` and ``step_range``).
        problem: The problem (start, goal, world bounds).
        goal_bias: Probability of sampling the other tree's root.
        connect_steps: Longest connect step.
        region: End the search when a start-tree node lands in the goal region (:data:`IN_REGION`).
    """

    def __init__(
        self,
        chk: CheckArrays,
        reeds_shepp: bool,
        geometry: tuple[float, float, float],
        problem: PlanProblem,
        goal_bias: float,
        connect_steps: int,
        region: bool = False,
    ) -> None:
        rho, step, reach = geometry
        self._chk = chk
        self._rs = reeds_shepp
        tolerances = (problem.position_tolerance, problem.heading_tolerance) if region else (-1.0, -1.0)
        self._geometry = np.array([rho, step, reach, goal_bias, *tolerances])
        self._bounds = np.asarray(problem.world.bounds, dtype=float)
        self._steps = connect_steps
        # an extension cut to the range: ceil(piece / step) poses per segment, rounding included
        self._max_motion = int(np.ceil(reach / step)) + 16
        cap = 2 * (connect_steps + 2)
        self._a = self._tree(problem.start.as_array(), cap, cap * self._max_motion)
        self._b = self._tree(problem.goal.as_array(), cap, cap * self._max_motion)
        self._state = np.array([1, 1, 0, 0, 0, 0], dtype=np.int64)
        self._uniforms = np.empty(0)

    @staticmethod
    def _tree(root: FloatArray, cap: int, rows: int) -> TreeArrays:
        nodes, heads = np.empty((cap, 3)), np.empty((cap, 2))
        nodes[0] = root
        heads[0] = np.cos(nodes[0, 2]), np.sin(nodes[0, 2])
        edges = np.zeros((cap, 2), dtype=np.int64)
        return nodes, heads, np.full(cap, -1, dtype=np.int64), edges, np.empty((rows, 3)), np.empty(rows)

    @property
    def iterations(self) -> int:
        """Iterations run so far."""
        return int(self._state[2])

    @property
    def nodes(self) -> int:
        """Nodes in both trees."""
        return int(self._state[0] + self._state[1])

    def run(self, rng: np.random.Generator, stop_it: int, deadline: float = np.inf) -> tuple[int, int, int]:
        """Iterate until ``stop_it`` iterations are done, the trees join or ``time.perf_counter()`` passes
        ``deadline`` (``search_chunk``'s results, never NEED_ROOM or NEED_UNIFORMS: the arrays grow and numbers are
        drawn here as needed).

        Raises:
            ValueError: A curve did not verify (non-finite poses).
        """
        if not self._uniforms.size:  # the first block now, not after a kernel call that asks for it
            self._draw(rng)
        while True:
            problem = (self._state, self._uniforms, stop_it, float(deadline), self._bounds, self._geometry)
            out = search_chunk(self._a, self._b, *problem, self._rs, self._steps, self._max_motion, self._chk)
            what = int(out[0])
            if what == NEED_ROOM:  # the tree that needs it (a growth touches fresh memory: milliseconds a MB)
                self._a = self._grown(self._a) if out[1] else self._a
                self._b = self._grown(self._b) if out[2] else self._b
            elif what == NEED_UNIFORMS:
                self._draw(rng)
            elif what == BAD_CURVE:
                raise ValueError("a Reeds-Shepp or Dubins curve of the search did not verify (non-finite poses)")
            else:
                return what, int(out[1]), int(out[2])

    def _draw(self, rng: np.random.Generator) -> None:
        """Keep the unused uniform numbers and append the stream's next block."""
        self._uniforms = np.concatenate([self._uniforms[self._state[3] :], rng.random(UNIFORM_BLOCK)])
        self._state[3] = 0

    @staticmethod
    def _grown(tree: TreeArrays) -> TreeArrays:
        """The tree's arrays, each twice as long."""
        nodes, heads, parents, rows, edge_p, edge_d = (np.concatenate([a, np.empty_like(a)]) for a in tree)
        return nodes, heads, parents, rows, edge_p, edge_d

    def path(self, a: int, b: int) -> tuple[FloatArray, FloatArray]:
        """Poses (K, 3) and directions (K,) from the start through start-tree node ``a`` and goal-tree node ``b`` to
        the goal (:func:`gather_path`)."""
        return gather_path(self._a, self._b, a, b)

    def plan_tree(self) -> PlanTree:
        """Both trees as one :class:`~planning.planners.base.PlanTree` (:func:`.tree.merge_trees`'s), built when
        first read (:meth:`PlanTree.deferred`: the search is over, its arrays no longer change)."""
        na, nb, a, b = int(self._state[0]), int(self._state[1]), self._a, self._b

        def build() -> tuple[FloatArray, IntArray, tuple[FloatArray, ...]]:
            par_b = b[2][:nb].copy()
            par_b[par_b >= 0] += na
            edges = []
            for tree, n in ((a, na), (b, nb)):
                edge_p = tree[4]
                edges += [edge_p[i:j, :2] for i, j in tree[3][1:n].tolist()]
            return np.concatenate([a[0][:na], b[0][:nb]]), np.concatenate([a[2][:na], par_b]), tuple(edges)

        return PlanTree.deferred(build)

    def sides(self) -> tuple[Side, Side]:
        """The start and goal trees as :func:`.tree.met_chain` reads them (views of the stores)."""
        return self._side(self._a), self._side(self._b)

    @staticmethod
    def _side(arrays: TreeArrays) -> Side:
        nodes, _, parents, rows, edge_p, edge_d = arrays
        return nodes, parents, lambda i: (edge_p[rows[i, 0] : rows[i, 1]], edge_d[rows[i, 0] : rows[i, 1]])

    def trees(self) -> tuple[Tree, Tree]:
        """The start and goal trees as :class:`~.tree.Tree` objects (their edges views of the stores)."""
        return self._as_tree(self._a, int(self._state[0]), False), self._as_tree(self._b, int(self._state[1]), True)

    @staticmethod
    def _as_tree(arrays: TreeArrays, n: int, backwards: bool) -> Tree:
        nodes, heads, parents = arrays[:3]
        edge = CompiledSearch._side(arrays)[2]
        tree = Tree(nodes[0], backwards=backwards, capacity=max(n, 1))
        tree.nodes[:n], tree.headings[:n], tree.parents[:n] = nodes[:n], heads[:n], parents[:n]
        tree.n = n
        for i in range(1, n):
            tree.edges.append(edge(i))
            tree.children.append([])
            tree.children[int(parents[i])].append(i)
        return tree
