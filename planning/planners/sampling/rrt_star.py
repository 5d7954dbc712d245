"""RRT* with exact steering (seed 002): choose-parent and rewire along Reeds–Shepp (or Dubins) curves.

Every edge is the exact shortest curve from its parent's pose to its node's pose, stored densely.
A node's pose never changes; rewiring replaces only the rewired node's own edge by the exact curve
from its new parent, so its children's edges (which start at the unchanged pose) stay exact and
no infeasible corner can appear. Costs are curve lengths; the best goal cost never rises.
Neighbours are the k nearest nodes (k = ceil(k_rrt log n), k_rrt = e (1 + 1/3)), pre-selected by
the (x, y, cos, sin) metric and ranked by exact curve length, all in vectorised calls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.errors import ConfigError
from planning.planners.base import PlanProblem, PlanResult, PlanStatus
from planning.planners.sampling.extend import LocalPlanner
from planning.planners.sampling.rrt import TreeConfig, _TreePlanner
from planning.planners.sampling.tree import Budget, Tree, in_goal

FloatArray = NDArray[np.float64]

K_RRT = np.e * (1.0 + 1.0 / 3.0)


@dataclass(frozen=True)
class RRTStarConfig(TreeConfig):
    """:class:`TreeConfig` for RRT*: Reeds–Shepp steering by default; runs the whole budget."""

    steering: str = "reeds_shepp"
    max_iterations: int = 5000
    stop_on_first: bool = False


class RRTStar(_TreePlanner[RRTStarConfig]):
    """Asymptotically optimal RRT* (see the module doc)."""

    name = "rrt-star"
    config_class = RRTStarConfig

    def _search(
        self, problem: PlanProblem, local: LocalPlanner, budget: Budget, rng: np.random.Generator
    ) -> PlanResult:
        """Grow and rewire until the budget is spent (or the first solution with stop_on_first)."""
        cfg = self.config
        if not local.exact:
            raise ConfigError(f"rrt-star needs exact steering ('reeds_shepp' or 'dubins'), got {cfg.steering!r}")
        tree = Tree(problem.start.as_array())
        goal_nodes: list[int] = []
        history: list[tuple[int, float, float]] = []  # (iteration, time, best cost)
        best_cost, ttfs = np.inf, None
        it = 0
        while not budget.spent(it):
            it += 1
            step = self._extend_toward_sample(rng, tree, local, problem)
            j = None if step is None else _insert(tree, local, step[1][0])
            if j is None:
                continue
            if in_goal(tree.nodes[j], problem):
                goal_nodes.append(j)
            if goal_nodes:
                g = min(goal_nodes, key=lambda x: (tree.costs[x], x))
                if tree.costs[g] < best_cost:
                    best_cost = float(tree.costs[g])
                    ttfs = budget.elapsed() if ttfs is None else ttfs
                    history.append((it, budget.elapsed(), best_cost))
                    if cfg.stop_on_first:
                        break
        stats: dict[str, object] = {
            **self._stats(budget, it, tree.n),
            "first_solution_s": ttfs,
            "cost_history": history,
        }
        if goal_nodes:
            g = min(goal_nodes, key=lambda x: (tree.costs[x], x))
            path, dirs = tree.branch(g)
            stats["cost_m"] = float(tree.costs[g])
            return self._result(PlanStatus.SUCCESS, path, dirs, "", stats, tree.plan_tree())
        path, dirs, _ = self._partial(tree, problem)
        reason = f"{budget.why(it)} without reaching the goal; partial path to the node nearest the goal"
        return self._result(PlanStatus.TIMEOUT, path, dirs, reason, stats, tree.plan_tree())


def _insert(tree: Tree, local: LocalPlanner, q_new: FloatArray) -> int | None:
    """Add ``q_new`` through its cheapest collision-free neighbour and rewire the neighbours through it.

    Neighbours are the k = ceil(K_RRT log(n + 1)) nearest nodes by the local metric, ranked by exact
    curve length. Returns the new node's index, or None when ``q_new`` is already in the tree or no
    neighbour reaches it.
    """
    n = tree.n
    k = min(n, int(np.ceil(K_RRT * np.log(n + 1))))
    d = local.tree_distances(tree, q_new)
    nbrs = np.argpartition(d, k - 1)[:k] if k < n else np.arange(n)
    if d[nbrs].min() < 1e-9:
        return None  # already in the tree
    to_new = local.curves.lengths(tree.nodes[nbrs], q_new)
    parent, motion, c_new = -1, None, 0.0
    for o in np.argsort(tree.costs[nbrs] + to_new, kind="stable"):
        motion = local.connect(tree.nodes[nbrs[o]], q_new)
        if motion is not None:
            parent, c_new = int(nbrs[o]), float(tree.costs[nbrs[o]] + to_new[o])
            break
    if motion is None:
        return None
    j = tree.add(q_new, parent, motion[0], motion[1], c_new)
    # Rewire: reparent neighbours through the new node when that is shorter. No curve is shorter than
    # the straight line (bound lowered by 1e-12 against rounding), so only neighbours the line could
    # improve get a curve solved: the same rewiring, in the same order, for fewer solves.
    line = np.hypot(tree.nodes[nbrs, 0] - q_new[0], tree.nodes[nbrs, 1] - q_new[1]) * (1.0 - 1e-12) - 1e-12
    cand = nbrs[(c_new + line < tree.costs[nbrs] - 1e-9) & (nbrs != parent)]
    if cand.size == 0:
        return j
    from_new = local.curves.lengths(q_new, tree.nodes[cand])
    for o in np.argsort(from_new, kind="stable"):
        nb = int(cand[o])
        if c_new + from_new[o] >= tree.costs[nb] - 1e-9:
            continue
        m = local.connect(q_new, tree.nodes[nb])
        if m is not None:
            tree.reparent(nb, j, m[0], m[1], c_new + float(from_new[o]))
    return j
