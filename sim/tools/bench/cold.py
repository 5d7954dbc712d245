"""A never-seen world, cold: ``nhsim plan`` in a fresh process on new seeded worlds against the same
plans in a warm process (``nhsim bench cold``).

Per world (a TOML scenario written for it, never planned before): the fresh process's wall and
CPU time (``resource``'s children accounting) from start to exit, the plan time it reports (the
collision grid included, and its part ``grid_s``; numba readying the code, ``code_s``: loading the
cached kernels, which the time limit does not count (numba's one-time set-up in a process comes
before any plan's clock, :func:`planning.clock.ready`; the process's wall time holds it); the path's
simplification after the plan, ``simplify_time_s``, which every planner reports beside its plan time, not in it; its CPU
time ``cpu_s`` where the planner reports one: on a loaded machine the wall times grow with the load,
the CPU times hardly), and the same plan warm in this process: first with the code loaded but the
world new (its grid built inside the timed plan), then fully warm (grid cached), the median of
``repeats`` runs. Targets:
the cold process reports at most :data:`REPORTED_TARGET_S` on worlds up to 8 x 8 m with up to 20
obstacles, and ends within :data:`PROCESS_TARGET_S` of wall time for a plan taking at most 0.1 s
warm; a crowded world (2000 obstacles) plans within its ``--time-limit``, grid included (the time the
limit counts: the reported time less the code's), or times out on it.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planning.errors import NhsimError

#: Largest plan time a fresh process may report on worlds up to 8 x 8 m with up to 20 obstacles [s].
REPORTED_TARGET_S = 0.2
#: Largest wall time of a whole ``nhsim plan`` process for a plan taking at most 0.1 s warm [s].
PROCESS_TARGET_S = 1.5
#: The warm plan time up to which the process target applies [s].
QUICK_PLAN_S = 0.1


@dataclass(frozen=True)
class ColdRow:
    """One world's figures (times in s)."""

    world: str
    obstacles: int
    size_m: float
    status: str
    time_limit_s: float
    process_wall_s: float
    process_cpu_s: float
    reported_s: float
    reported_cpu_s: float
    grid_s: float
    code_s: float
    new_world_s: float
    warm_s: float
    simplify_s: float = float("nan")

    @property
    def working_s(self) -> float:
        """The reported time less numba readying the code: what the planner's time limit counts."""
        return self.reported_s - self.code_s

    @property
    def reported_ratio(self) -> float:
        """Cold reported plan time over the fully warm plan's."""
        return self.reported_s / self.warm_s

    @property
    def process_ratio(self) -> float:
        """Cold process wall time over the fully warm plan's."""
        return self.process_wall_s / self.warm_s

    @property
    def targets(self) -> list[str]:
        """The targets this row is held to, each with "met" or "MISSED"."""
        out = []
        if self.status != "success" and self.obstacles <= 20:  # a world to plan: its time is a plan's only with a plan
            out.append(f"a plan ({self.status}) MISSED")
        if self.obstacles <= 20 and self.size_m <= 8.0:
            ok = self.reported_s <= REPORTED_TARGET_S
            out.append(f"reported <= {REPORTED_TARGET_S:g} s {'met' if ok else 'MISSED'}")
        if self.warm_s <= QUICK_PLAN_S:
            ok = self.process_wall_s <= PROCESS_TARGET_S
            out.append(f"process <= {PROCESS_TARGET_S:g} s {'met' if ok else 'MISSED'}")
        if self.obstacles > 20:
            ok = self.working_s <= self.time_limit_s * LIMIT_SLACK and self.status in ("success", "timeout")
            said = f"within the {self.time_limit_s:g} s limit (+{LIMIT_SLACK - 1:.0%}: the last step's check)"
            out.append(f"{said} {'met' if ok else 'MISSED'}")
        return out


#: How far past its time limit a crowded world's plan may end and count as within it: a planner checks its clock
#: between steps, so it stops after the step that passes the limit (2.023 s of a 2 s limit measured).
LIMIT_SLACK = 1.05


#: The obstacle kinds of a scenario TOML.
KINDS = ("circle", "ellipse", "box", "polygon")


def world_toml(seed: int, size: float, count: int, scale: float, kinds: tuple[str, ...] = KINDS) -> str:
    """A scenario TOML: a ``size`` x ``size`` m arena with ``count`` obstacles of ``kinds`` in turn
    (default all four: circles, ellipses, oriented boxes, polygons; about ``scale`` m across) from
    ``seed``, the start and goal corners kept clear, headings drawn too."""
    rng = np.random.default_rng(seed)
    h = size / 2
    ends = np.array([[-h + 0.5, -h + 0.5], [h - 0.5, h - 0.5]])
    lines = [f'name = "cold{seed}"', 'robot = "turtlebot3"', "", "[world]", f"bounds = [{-h}, {h}, {-h}, {h}]", ""]
    placed = 0
    while placed < count:
        c = [float(v) for v in rng.uniform(-h + 0.1, h - 0.1, 2)]
        r = float(rng.uniform(0.4, 1.0) * scale)
        if np.min(np.hypot(*(ends - np.asarray(c)).T)) < r + 0.45:
            continue
        kind = kinds[placed % len(kinds)]
        angle = float(rng.uniform(0, np.pi))
        lines += ["[[world.obstacles]]", f'type = "{kind}"']
        if kind == "circle":
            lines += [f"center = [{c[0]!r}, {c[1]!r}]", f"radius = {r!r}"]
        elif kind == "ellipse":
            lines += [f"center = [{c[0]!r}, {c[1]!r}]", f"radii = [{r!r}, {0.5 * r!r}]", f"angle = {angle!r}"]
        elif kind == "box":
            lines += [f"center = [{c[0]!r}, {c[1]!r}]", f"size = [{2 * r!r}, {r!r}]", f"angle = {angle!r}"]
        else:
            phi = 2 * np.pi * (np.arange(5) + rng.uniform(0, 0.8, 5)) / 5
            rr = r * rng.uniform(0.6, 1.0, 5)
            pts = [[float(c[0] + rr[i] * np.cos(phi[i])), float(c[1] + rr[i] * np.sin(phi[i]))] for i in range(5)]
            lines.append(f"vertices = {pts!r}")
        lines.append("")
        placed += 1
    th = [float(v) for v in rng.uniform(-np.pi, np.pi, 2)]
    (sx, sy), (gx, gy) = ends.tolist()
    lines += ["[start]", f"pose = [{sx!r}, {sy!r}, {th[0]!r}]", "", "[goal]", f"pose = [{gx!r}, {gy!r}, {th[1]!r}]"]
    return "\n".join(lines) + "\n"


def _fresh_process(scenario: Path, planner: str, time_limit: float, out: Path) -> tuple[float, float, dict]:  # type: ignore[type-arg]
    """Wall and CPU time [s] of one ``python -m sim plan`` process on ``scenario``, and its JSON record.

    Raises:
        NhsimError: The process wrote no record (bad input, a plugin that would not load, a crash: any exit
            status but 0 and 1, a failed plan's), naming the command, its exit status and the end of its error
            output.
    """
    root = Path(__file__).resolve().parents[3]  # the repository whose code this process runs, first on the path
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(root), os.environ.get("PYTHONPATH")) if p)}
    cmd = [sys.executable, "-m", "sim", "plan", "--scenario", str(scenario), "--planner", planner]
    cmd += ["--time-limit", repr(time_limit), "--json", str(out), "--overwrite", "--quiet"]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, cwd=root, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode not in (0, 1) or not out.is_file():
        said = done.stderr.decode(errors="replace").strip()[-1500:] or "no error output"
        raise NhsimError(
            f"the timed process failed (exit {done.returncode}) and wrote no record, so nothing was measured: "
            f"nhsim {' '.join(cmd[3:])}\n{said}\nrun that command alone to see why"
        )
    return wall, cpu, json.loads(out.read_text())


def measure(
    seed: int,
    size: float,
    count: int,
    scale: float,
    planner: str,
    time_limit: float,
    repeats: int,
    kinds: tuple[str, ...] = KINDS,
) -> ColdRow:
    """One new world (obstacles of ``kinds``): the cold process, then the same plan warm here (see the
    module doc)."""
    from planning.planners.base import PlanProblem
    from planning.planners.registry import make_planner
    from planning.scenario import load_scenario

    with tempfile.TemporaryDirectory(prefix="nhsim-cold-") as tmp:
        path = Path(tmp) / f"cold{seed}.toml"
        path.write_text(world_toml(seed, size, count, scale, kinds))
        wall, cpu, record = _fresh_process(path, planner, time_limit, Path(tmp) / "plan.json")
        scenario = load_scenario(path)
    problem = PlanProblem.from_scenario(scenario, seed=0, time_limit=time_limit)
    plan = make_planner(planner)
    new_world = float(plan.plan(problem).stats["time_s"])
    warm = float(np.median([plan.plan(problem).stats["time_s"] for _ in range(repeats)]))
    return ColdRow(
        world=scenario.name,
        obstacles=count,
        size_m=size,
        status=str(record["status"]),
        time_limit_s=time_limit,
        process_wall_s=wall,
        process_cpu_s=cpu,
        reported_s=float(record["time_s"]),
        reported_cpu_s=float(record["stats"].get("cpu_s", float("nan"))),
        grid_s=float(record["stats"].get("grid_s", float("nan"))),
        code_s=float(record["stats"].get("code_s", 0.0)),
        new_world_s=new_world,
        warm_s=warm,
        simplify_s=float("nan") if record.get("simplify_time_s") is None else float(record["simplify_time_s"]),
    )


def warm_up(planner: str) -> None:
    """Load the planner's compiled code in this process (a plan of a small world, not measured)."""
    from planning.planners.base import PlanProblem
    from planning.planners.registry import make_planner
    from planning.scenario import load_scenario

    make_planner(planner).plan(PlanProblem.from_scenario(load_scenario("nav_map1"), time_limit=30.0))


def format_rows(rows: list[ColdRow]) -> list[str]:
    """A header line and one line per row."""
    cols = ("world", "obst", "size", "status", "proc wall", "proc cpu", "reported", "rep cpu", "code", "less code")
    widths = (10, 5, 5, 8, 9, 8, 8, 7, 6, 9, 7, 8, 8, 7, 8, 9)
    names = (*cols, "grid", "simplify", "new warm", "warm", "rep/warm", "proc/warm")
    out = [" ".join(f"{n:>{w}}" for n, w in zip(names, widths, strict=True)) + "  targets"]
    for r in rows:
        times = (r.process_wall_s, r.process_cpu_s, r.reported_s, r.reported_cpu_s, r.code_s, r.working_s, r.grid_s,
                 r.simplify_s, r.new_world_s, r.warm_s)  # fmt: skip
        cells = [f"{r.world:>10}", f"{r.obstacles:>5d}", f"{r.size_m:>5g}", f"{r.status:>8}"]
        cells += [f"{t:>{w}.3f}" for t, w in zip(times, widths[4:14], strict=True)]
        cells += [f"{r.reported_ratio:>8.1f}", f"{r.process_ratio:>9.1f}"]
        out.append(" ".join(cells) + "  " + "; ".join(r.targets))
    return out


def load_note() -> str:
    """The machine's load averages and the cores this process may use, to print beside the figures."""
    from sim.tools.executor import default_jobs

    one, five, _ = os.getloadavg()
    return f"load average {one:.1f} (1 min), {five:.1f} (5 min) on {default_jobs()} cores"


def passed(rows: list[ColdRow]) -> bool:
    """Whether every row meets every target it is held to."""
    return all("MISSED" not in t for r in rows for t in r.targets)
