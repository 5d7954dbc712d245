"""``nhsim bench plan``: our tree planners against OMPL's C++ planners on the same problems and checker.

Races: OMPL ``RRTConnect`` against ``birrt`` (time to first path, success), and ``rrt-star``'s path
length after a wall-clock budget (1 s by default) against every asymptotically optimal OMPL planner
that runs on the Reeds–Shepp space (:data:`OPTIMAL`: ``RRTstar`` plain and with its informed-sampling
or sample-rejection options and new-state rejection, ``InformedRRTstar``, ``SORRTstar``, ``BITstar``,
``ABITstar``, ``AITstar``, ``RRTXstatic``, ``RRTsharp``); per problem the best of them (shortest
median) is the anchor. Both sides plan on a Reeds–Shepp (or Dubins) space with the same turning
radius and the same goal region: OMPL is given ours (position within the problem's position
tolerance and heading within its heading tolerance). For first paths it is sampled at the goal pose,
where birrt roots its goal tree; for lengths (``goal="region"``, the default) at the poses of
:func:`~planning.planners.sampling.tree.goal_region_poses`, which rrt-star's ``region_goal`` aims its
goal connections at, so both sides may end anywhere in the region (``goal="pose"``: both at the goal
pose, rrt-star's default).

OMPL runs natively: a C++ harness (``ompl_native/harness.cpp``) compiled against the system's OMPL
(Debian's ``libompl-dev``, OMPL 1.5) whose validity checker returns :class:`FastChecker`'s verdict for
every pose (same grid, same exact fallback), and whose motion checks sample the exact curve every
``LocalPlanner.sample_step`` (1 cm, finer near small obstacles), as ours do, in OMPL's bisection order
with each curve solved once. OMPL's Python wheel (``pip install ompl``), when installed, runs as a
second column through a Python validity callback (slower per check; it flatters us).
``hybrid-a-star``, when registered, adds its time and length.

Times are wall-clock, per trial, interleaved ours / OMPL per seed (OMPL's in one warm harness
process per problem), both processes on one CPU while the trials run (:func:`one_core`). Each
timed first path is preceded, on its side, by an untimed solve of at most 50 ms (ours on another
seed): interleaving makes each side wait for the other, and a trial started straight from that wait
runs with cold caches, which costs a Python interpreter more than the harness (birrt's median on
simple_motion 0.58 ms straight from the wait, 0.18 ms otherwise). Ours around ``Planner.plan`` (its
setup included, the world's distance grid built once before timing), OMPL's around
``SimpleSetup::solve(timedPlannerTerminationCondition(limit))`` (its setup included; no watchdog
thread, as OMPL's C++ users run it). Lengths: a failed trial counts as infinitely long, so a median
is finite only when more than half the trials found a path. Targets over the problems: median of
the per-problem birrt / RRTConnect median-time ratios <= 1.0 and none above 1.5, median of the
rrt-star / anchor median-length ratios <= 0.99, and on every problem our success rates not below
RRTConnect's and the anchor's.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import tempfile
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from planning.planners.base import PlanProblem
from sim.tools.bench.plan_problems import problems

__all__ = [
    "LENGTH_TARGET",
    "OPTIMAL",
    "TTFS_CAP",
    "TTFS_TARGET",
    "PlanBench",
    "measure",
    "problems",
    "summary",
    "wheel_available",
]

TTFS_TARGET = 1.0
#: No problem's birrt / RRTConnect time ratio above this.
TTFS_CAP = 1.5
LENGTH_TARGET = 0.99
#: OMPL's asymptotically optimal planners raced on length (names the C++ harness knows).
OPTIMAL = (
    "RRTstar",
    "RRTstar+informed",
    "RRTstar+rejection",
    "InformedRRTstar",
    "SORRTstar",
    "BITstar",
    "ABITstar",
    "AITstar",
    "RRTXstatic",
    "RRTsharp",
)
#: Longest untimed solve before each timed first-path trial, on each side [s], and the seed offset of ours.
WARM_UP = 0.05
WARM_SEED = 1_000_000
#: Name of the planner whose time and length are reported when it is registered.
HYBRID = "hybrid-a-star"


def wheel_available() -> bool:
    """Whether OMPL's Python bindings (the wheel) import."""
    try:
        import ompl  # noqa: F401
    except ImportError:
        return False
    return True


def length_median(lengths: tuple[float, ...]) -> float:
    """Median path length [m] over trials, a failed trial (nan) counted as infinitely long (inf when
    more than half failed, nan when there are no trials)."""
    if not lengths:
        return float("nan")
    return float(np.median(np.where(np.isfinite(lengths), lengths, np.inf)))


@dataclass(frozen=True)
class PlanBench:
    """Our planners against OMPL's on one problem over many seeds (times [s], lengths [m]; nan: no path).

    Attributes:
        problem: Problem name.
        ttfs_ours / ok_ours: birrt's time to first path and success (1.0 / 0.0), one per seed.
        len_ours / star_ok_ours: rrt-star's path length after the budget and success.
        ttfs_cpp, ok_cpp: the same for OMPL C++ RRTConnect (empty when the harness could not be built).
        len_cpp: Each raced OMPL C++ optimal planner's path lengths after the budget (nan: no path).
        ttfs_wheel, len_wheel: OMPL's Python wheel RRTConnect / RRTstar (empty when not installed).
        hybrid_time, hybrid_length: hybrid-a-star's time and length (nan when absent or failed).
    """

    problem: str
    ttfs_ours: tuple[float, ...]
    ok_ours: tuple[float, ...]
    len_ours: tuple[float, ...]
    star_ok_ours: tuple[float, ...]
    ttfs_cpp: tuple[float, ...] = ()
    ok_cpp: tuple[float, ...] = ()
    len_cpp: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    ttfs_wheel: tuple[float, ...] = ()
    len_wheel: tuple[float, ...] = ()
    hybrid_time: float = float("nan")
    hybrid_length: float = float("nan")

    @staticmethod
    def _solved(times: tuple[float, ...], ok: tuple[float, ...]) -> tuple[float, ...]:
        return tuple(t if o else float("nan") for t, o in zip(times, ok, strict=True))

    @staticmethod
    def _median(v: tuple[float, ...]) -> float:
        return float(np.nanmedian(v)) if np.any(np.isfinite(v)) else float("nan")

    @property
    def ttfs_ratio(self) -> float:
        """Median time to first path (successful trials), birrt over OMPL C++ RRTConnect (nan: none)."""
        if not self.ttfs_cpp:
            return float("nan")
        return self._median(self._solved(self.ttfs_ours, self.ok_ours)) / self._median(
            self._solved(self.ttfs_cpp, self.ok_cpp)
        )

    @property
    def anchor(self) -> str | None:
        """The OMPL planner of shortest median length (failures infinitely long; first of equals), or
        None when none was raced or none found a path in more than half its trials."""
        meds = {k: length_median(v) for k, v in self.len_cpp.items()}
        finite = {k: m for k, m in meds.items() if np.isfinite(m)}
        return min(finite, key=lambda k: finite[k]) if finite else None

    @property
    def length_ratio(self) -> float:
        """rrt-star's median length over the anchor's (nan: no anchor; inf: ours failed in most trials)."""
        a = self.anchor
        return float("nan") if a is None else length_median(self.len_ours) / length_median(self.len_cpp[a])

    def success(self, planner: str) -> float:
        """Share of the trials in which OMPL's ``planner`` found a path after the budget."""
        return float(np.mean(np.isfinite(self.len_cpp[planner])))

    @property
    def success_missed(self) -> bool:
        """Whether a success rate of ours is below OMPL C++'s (birrt vs RRTConnect, rrt-star vs the anchor)."""
        if not self.ok_cpp:
            return False
        a = self.anchor
        star = a is not None and np.mean(self.star_ok_ours) < self.success(a)
        return bool(np.mean(self.ok_ours) < np.mean(self.ok_cpp) or star)


@dataclass
class _Ours:
    """birrt and rrt-star with the bench's budgets (unsimplified paths when the planners simplify)."""

    space: str
    ttfs_limit: float
    budget: float
    region_goal: bool = False
    birrt: Any = field(init=False)
    rstar: Any = field(init=False)

    def __post_init__(self) -> None:
        from planning.planners.registry import make_planner, planner_options

        def make(name: str, **opts: Any) -> Any:
            raw = {"simplify": False} if "simplify" in planner_options(name) else {}
            return make_planner(name, steering=self.space, **opts, **raw)

        self.birrt = make("birrt", max_iterations=10**7, time_limit=self.ttfs_limit)
        self.warm_birrt = make("birrt", max_iterations=10**7, time_limit=WARM_UP)
        # as OMPL runs RRT*: the whole budget (no anytime early stop)
        whole = {"improvement_tol": 0.0} if "improvement_tol" in planner_options("rrt-star") else {}
        region = {"region_goal": self.region_goal} if self.region_goal else {}
        self.rstar = make("rrt-star", max_iterations=10**8, time_limit=self.budget, **whole, **region)

    def first_path(self, problem: PlanProblem) -> tuple[float, float]:
        """(wall time [s], 1.0 if solved else 0.0) of one birrt run, after an untimed one of at most
        :data:`WARM_UP` on another seed (so the timed run does not start cold from the wait on OMPL's
        harness, as OMPL's does not start cold from its wait on ours)."""
        from planning.planners.base import PlanStatus

        self.warm_birrt.plan(dataclasses.replace(problem, seed=problem.seed + WARM_SEED))
        t0 = time.perf_counter()
        r = self.birrt.plan(problem)
        return time.perf_counter() - t0, float(r.status is PlanStatus.SUCCESS)

    def length(self, problem: PlanProblem) -> float:
        """Length [m] of rrt-star's path after the budget (nan: none)."""
        return float(self.rstar.plan(problem).stats.get("cost_m", np.nan))


@contextlib.contextmanager
def one_core(other: int | None) -> Iterator[int | None]:
    """Run this process, and the process ``other`` when given, on one CPU (the highest this process
    may use) until the block ends, when this process gets its CPUs back; yields that CPU (None where
    the system cannot pin processes).

    Both sides' trials run on it (the first paths and the runs to a budget): on a virtual machine each
    virtual CPU's speed moves on its own (a host's other guests share its cores), so with the two
    processes on different CPUs one side could be timed on a slowed CPU while the other was not. Both
    sides are single-threaded and take turns (each waits on the other's pipe), so neither waits for
    the CPU. Only the calling thread is pinned (and the threads it starts meanwhile: a distance field
    built in the block uses one)."""
    if not hasattr(os, "sched_setaffinity"):
        yield None
        return
    mine = os.sched_getaffinity(0)
    cpu = max(mine)
    os.sched_setaffinity(0, {cpu})
    try:
        if other is not None:
            with contextlib.suppress(ProcessLookupError):  # it has ended: its first trial says why
                os.sched_setaffinity(other, {cpu})
        yield cpu
    finally:
        os.sched_setaffinity(0, mine)


def _hybrid(problem: PlanProblem, repeats: int = 3) -> tuple[float, float]:
    """hybrid-a-star's median wall time [s] and path length [m] (nan, nan when unregistered or failed)."""
    from planning.errors import NhsimError
    from planning.planners.base import PlanStatus
    from planning.planners.registry import PLANNERS, make_planner

    if HYBRID not in PLANNERS:
        return float("nan"), float("nan")
    try:
        planner = make_planner(HYBRID)
        times, result = [], None
        for _ in range(repeats):  # deterministic: repeats only steady the time
            t0 = time.perf_counter()
            result = planner.plan(problem)
            times.append(time.perf_counter() - t0)
    except NhsimError:
        return float("nan"), float("nan")
    if result is None or result.status is not PlanStatus.SUCCESS:
        return float(np.median(times)), float("nan")
    return float(np.median(times)), float(result.stats.get("length_m", np.nan))


def measure(
    problem: PlanProblem,
    space: str,
    seeds: int,
    budget: float,
    ttfs_limit: float,
    harness: Path | None,
    wheel: bool,
    optimal: tuple[str, ...] = OPTIMAL,
    goal: str = "region",
) -> PlanBench:
    """Race birrt against RRTConnect (first path within ``ttfs_limit`` [s]) and rrt-star against each of
    ``optimal`` (length after ``budget`` [s]) on one problem for ``seeds`` seeds.

    Args:
        harness: The compiled OMPL C++ harness (None: no C++ columns).
        wheel: Also race OMPL's Python wheel.
        optimal: OMPL's optimal planners to race (names from :data:`OPTIMAL`).
        goal: The length race's goal samples: "region" (rrt-star's ``region_goal`` and OMPL's goal sampled
            at the same :func:`~planning.planners.sampling.tree.goal_region_poses`) or "pose" (both at
            the goal pose). The first-path race always samples the goal pose (birrt roots its goal tree
            there).
    """
    from planning.planners.sampling.extend import LocalPlanner
    from planning.planners.sampling.tree import make_checker
    from sim.tools.bench.ompl_native.problem import Session, write_problem

    checker = make_checker(problem, "footprint", 0.0)  # builds the distance grid (not timed)
    local = LocalPlanner(space, problem.robot, checker)
    rho = float(local.rho if local.rho is not None else np.nan)
    if goal not in ("region", "pose"):
        raise ValueError(f"goal must be 'region' or 'pose', got {goal!r}")
    ours = _Ours(space, ttfs_limit, budget, goal == "region")
    ours.first_path(problem)  # warm-up (compiled kernels loaded)
    rows: dict[str, list[float]] = {k: [] for k in ("t", "ok", "len", "t_c", "ok_c")}
    lens: dict[str, list[float]] = {k: [] for k in optimal} if harness is not None else {}
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="nhsim-ompl-")))
        cpp = None
        if harness is not None:
            pf = write_problem(tmp, problem, checker, space, rho, local.sample_step)
            cpp = stack.enter_context(Session(harness, pf, 1))
        seeded = [type(problem)(**{**problem.__dict__, "seed": seed}) for seed in range(seeds)]
        # interleaved on one CPU, so a change in the machine's load or in that CPU's speed hits both sides
        with one_core(None if cpp is None else cpp.pid):
            for p in seeded:
                t, ok = ours.first_path(p)
                rows["t"].append(t)
                rows["ok"].append(ok)
                if cpp is not None:
                    rc = cpp.solve("RRTConnect", ttfs_limit, "warm")
                    rows["t_c"].append(rc["time_s"])
                    rows["ok_c"].append(rc["solved"])
            for p in seeded:  # after the first paths: a 1 s run would leave both sides' caches cold
                rows["len"].append(ours.length(p))
                for name in lens:
                    assert cpp is not None
                    lens[name].append(cpp.solve(name, budget, *(("region",) if goal == "region" else ()))["length_m"])
    out: dict[str, Any] = {
        "ttfs_ours": tuple(rows["t"]),
        "ok_ours": tuple(rows["ok"]),
        "len_ours": tuple(rows["len"]),
        "star_ok_ours": tuple(float(np.isfinite(v)) for v in rows["len"]),
        "ttfs_cpp": tuple(rows["t_c"]),
        "ok_cpp": tuple(rows["ok_c"]),
        "len_cpp": {k: tuple(v) for k, v in lens.items()},
    }
    if wheel:
        out |= _wheel(problem, space, checker, rho, local.sample_step, seeds, budget, ttfs_limit)
    h_time, h_len = _hybrid(problem)
    return PlanBench(problem.name, **out, hybrid_time=h_time, hybrid_length=h_len)


def _wheel(
    problem: PlanProblem, space: str, checker: Any, rho: float, step: float, seeds: int, budget: float, limit: float
) -> dict[str, tuple[float, ...]]:
    """OMPL's Python wheel: RRTConnect times and RRT* lengths, one per seed."""
    from sim.tools.bench.ompl_wheel import WheelOmpl

    run = WheelOmpl(problem, space, checker, rho, step)
    t = [run.solve("RRTConnect", s, limit) for s in range(seeds)]
    ln = [run.solve("RRTstar", s, budget) for s in range(seeds)]
    return {
        "ttfs_wheel": tuple(dt if ok else float("nan") for ok, dt, _ in t),
        "len_wheel": tuple(length for _, _, length in ln),
    }


def summary(rows: list[PlanBench]) -> dict[str, float]:
    """Median over the problems of the per-problem ratios (nan where no problem has one), and the
    largest time ratio (``ttfs_worst``)."""

    def med(vals: list[float]) -> float:
        v = [x for x in vals if not np.isnan(x)]  # an infinite ratio (ours failed) counts
        return float(np.median(v)) if v else float("nan")

    ttfs = [r.ttfs_ratio for r in rows]
    finite = [x for x in ttfs if np.isfinite(x)]
    return {
        "ttfs_ratio": med(ttfs),
        "ttfs_worst": max(finite) if finite else float("nan"),
        "length_ratio": med([r.length_ratio for r in rows]),
    }
