"""RRT (seed 000) and bidirectional RRT with a connect step (seed 001).

``rrt``: goal bias 0.05, nearest node by the (x, y, cos theta, sin theta) metric, extension by the
motion primitive whose end lands closest to the sample (the 60 bicycle primitives by default);
once a new node comes within ``goal_connect_radius`` of the goal, an exact Reeds–Shepp (or Dubins)
curve to the goal is tried as the final plan (seed 000, step 8).

``birrt``: two trees, one from the start and one grown backwards from the goal, alternately
extended toward uniform samples; after each extension the other tree runs a connect step toward
the new node (repeated extensions until reached or blocked). With exact curves the trees meet at
a shared pose; with primitives they join by an exact curve once within ``goal_connect_radius``.
Every joining curve runs from the start-tree node to the goal-tree node (never reversed), so a
Dubins join cannot turn into a reversed, infeasible U-turn. Seed 001's default: 5000 samples
with the unicycle primitives.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.core.geometry import path_length
from planning.errors import ConfigError
from planning.planners.base import PlanProblem, PlanResult, PlanStatus
from planning.planners.registry import config_from_options
from planning.planners.sampling.extend import LocalPlanner
from planning.planners.sampling.tree import (
    Budget,
    Tree,
    check_endpoints,
    goal_gap,
    in_goal,
    make_checker,
    merge_trees,
    sample_pose,
)

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class TreeConfig:
    """Options shared by the tree planners (keyword-only at the factories).

    Attributes:
        steering: "bicycle", "unicycle", "diffdrive", "reeds_shepp" or "dubins".
        goal_bias: Probability of sampling the goal pose.
        max_iterations: Iteration (sample) budget.
        time_limit: Wall-clock budget [s]; None takes the problem's.
        turning_radius: Radius of the exact curves [m]; None: wheelbase / tan(max_steering).
        step_range: Longest exact-curve extension [m]; None: 0.2 x the bounds' diagonal.
        goal_connect_radius: Try an exact curve to the goal (or the other tree) when this close in
            the (x, y, cos, sin) metric.
        n_speeds: Bicycle primitive speeds per steering class.
        primitive_duration: Bicycle primitive and diff-drive drive duration [s].
        shape: Collision model, "footprint" or "disc".
        clearance: Margin every pose must keep [m].
    """

    steering: str = "bicycle"
    goal_bias: float = 0.05
    max_iterations: int = 20000
    time_limit: float | None = None
    turning_radius: float | None = None
    step_range: float | None = None
    goal_connect_radius: float = 1.0
    n_speeds: int = 20
    primitive_duration: float = 1.0
    shape: str = "footprint"
    clearance: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.goal_bias <= 1.0:
            raise ConfigError(f"goal_bias must be in [0, 1], got {self.goal_bias}")
        if self.max_iterations < 1:
            raise ConfigError(f"max_iterations must be >= 1, got {self.max_iterations}")
        if self.shape not in ("footprint", "disc"):
            raise ConfigError(f"shape must be 'footprint' or 'disc', got {self.shape!r}")


class _TreePlanner:
    name = "tree"
    config_class: type[TreeConfig] = TreeConfig

    def __init__(self, **options: object) -> None:
        self.config = config_from_options(self.config_class, options)

    def _setup(self, problem: PlanProblem) -> tuple[LocalPlanner, Budget, PlanResult | None]:
        cfg = self.config
        checker = make_checker(problem, cfg.shape, cfg.clearance)  # type: ignore[arg-type]
        w = problem.world
        local = LocalPlanner(
            cfg.steering, problem.robot, checker, rho=cfg.turning_radius,
            step_range=cfg.step_range if cfg.step_range is not None else 0.2 * float(np.hypot(w.width, w.height)),
            n_speeds=cfg.n_speeds, primitive_duration=cfg.primitive_duration,
        )  # fmt: skip
        budget = Budget(cfg.max_iterations, cfg.time_limit if cfg.time_limit is not None else problem.time_limit)
        return local, budget, check_endpoints(problem, checker, self.name)

    def _result(
        self,
        status: PlanStatus,
        poses: FloatArray,
        dirs: FloatArray,
        reason: str,
        stats: Mapping[str, object],
        tree: object,
    ) -> PlanResult:
        stats = {**stats, "length_m": path_length(poses)}
        return PlanResult(status, self.name, path=poses, reason=reason, stats=stats, tree=tree, directions=dirs)  # type: ignore[arg-type]


class RRT(_TreePlanner):
    """Seed 000's goal-biased RRT with motion primitives (see the module doc)."""

    name = "rrt"

    def plan(self, problem: PlanProblem) -> PlanResult:
        """Grow a tree from the start until a node reaches the goal or the budget is spent."""
        local, budget, bad = self._setup(problem)
        if bad is not None:
            return bad
        cfg = self.config
        rng = np.random.default_rng(problem.seed)
        start, goal = problem.start.as_array(), problem.goal.as_array()
        tree = Tree(start)
        it = 0
        while not budget.spent(it):
            it += 1
            q_rand = goal if rng.random() < cfg.goal_bias else sample_pose(rng, problem.world.bounds)
            i = tree.nearest(q_rand, local.metric)
            ext = local.extend(tree.nodes[i], q_rand)
            if ext is None:
                continue
            q_new, poses, dirs = ext
            j = tree.add(q_new, i, poses, dirs)
            done = in_goal(q_new, problem)
            if not done and local.metric(q_new[None, :], goal)[0] <= cfg.goal_connect_radius:
                final = local.connect(q_new, goal)
                if final is not None:
                    j = tree.add(goal.copy(), j, *final)
                    done = True
            if done:
                path, d = tree.branch(j)
                stats = {"time_s": budget.elapsed(), "iterations": it, "nodes": tree.n}
                return self._result(PlanStatus.SUCCESS, path, d, "", stats, tree.plan_tree())
        best = int(np.argmin(goal_gap(tree.nodes[: tree.n], problem)))
        path, d = tree.branch(best)
        gap = float(goal_gap(tree.nodes[best : best + 1], problem)[0])
        reason = f"{budget.why(it)}; partial path to the node nearest the goal ({gap:.3f} m away)"
        stats = {"time_s": budget.elapsed(), "iterations": it, "nodes": tree.n}
        return self._result(PlanStatus.TIMEOUT, path, d, reason, stats, tree.plan_tree())


@dataclass(frozen=True)
class BiRRTConfig(TreeConfig):
    """:class:`TreeConfig` with seed 001's defaults: unicycle primitives, 5000 samples, no goal bias."""

    steering: str = "unicycle"
    goal_bias: float = 0.0
    max_iterations: int = 5000
    connect_steps: int = 50


class BiRRT(_TreePlanner):
    """Bidirectional RRT with a connect step (see the module doc)."""

    name = "birrt"
    config_class = BiRRTConfig

    def _grow(self, local: LocalPlanner, tree: Tree, i: int, target: FloatArray) -> int | None:
        ext = local.extend(tree.nodes[i], target, backwards=tree.backwards)
        if ext is None:
            return None
        return tree.add(ext[0], i, ext[1], ext[2])

    def plan(self, problem: PlanProblem) -> PlanResult:
        """Grow both trees until they join or the budget is spent."""
        local, budget, bad = self._setup(problem)
        if bad is not None:
            return bad
        cfg = self.config
        assert isinstance(cfg, BiRRTConfig)
        rng = np.random.default_rng(problem.seed)
        start, goal = problem.start.as_array(), problem.goal.as_array()
        ta, tb = Tree(start), Tree(goal, backwards=True)
        # The trees may already be joined by one exact curve.
        direct = local.connect(start, goal)
        if direct is not None:
            stats = {"time_s": budget.elapsed(), "iterations": 0, "nodes": 2}
            return self._result(PlanStatus.SUCCESS, direct[0], direct[1], "", stats, merge_trees(ta, tb))
        it = 0
        while not budget.spent(it):
            it += 1
            grow, other = (ta, tb) if it % 2 else (tb, ta)
            q_rand = (
                (goal if grow is ta else start)
                if rng.random() < cfg.goal_bias
                else sample_pose(rng, problem.world.bounds)
            )
            j = self._grow(local, grow, grow.nearest(q_rand, local.metric), q_rand)
            if j is None:
                continue
            target = grow.nodes[j]
            k = other.nearest(target, local.metric)
            for _ in range(cfg.connect_steps):
                a, b = (j, k) if grow is ta else (k, j)
                if local.exact and np.array_equal(ta.nodes[a], tb.nodes[b]):
                    return self._joined(ta, tb, a, b, None, budget, it)
                if local.metric(ta.nodes[a][None, :], tb.nodes[b])[0] <= cfg.goal_connect_radius:
                    bridge = local.connect(ta.nodes[a], tb.nodes[b])
                    if bridge is not None:
                        return self._joined(ta, tb, a, b, bridge, budget, it)
                k_new = self._grow(local, other, k, target)
                if k_new is None:
                    break
                k = k_new
        stats = {"time_s": budget.elapsed(), "iterations": it, "nodes": ta.n + tb.n}
        best = int(np.argmin(goal_gap(ta.nodes[: ta.n], problem)))
        path, d = ta.branch(best)
        reason = f"{budget.why(it)}; the trees did not meet (partial path from the start tree)"
        return self._result(PlanStatus.TIMEOUT, path, d, reason, stats, merge_trees(ta, tb))

    def _joined(
        self, ta: Tree, tb: Tree, a: int, b: int, bridge: tuple[FloatArray, FloatArray] | None, budget: Budget, it: int
    ) -> PlanResult:
        pa, da = ta.branch(a)
        pb, db = tb.branch(b)
        parts_p, parts_d = [pa], [da]
        if bridge is not None:
            parts_p.append(bridge[0][1:])
            parts_d.append(bridge[1][1:])
        parts_p.append(pb[1:])
        parts_d.append(db[1:])
        stats = {"time_s": budget.elapsed(), "iterations": it, "nodes": ta.n + tb.n}
        path, dirs = np.vstack(parts_p), np.concatenate(parts_d)
        return self._result(PlanStatus.SUCCESS, path, dirs, "", stats, merge_trees(ta, tb))
