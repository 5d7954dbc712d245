"""Hand a planning problem to the C++ harness and read its answers.

:func:`write_problem` writes what :class:`~planning.collision.grid.FastChecker` decides with (the
world's obstacles and walls, the robot's footprint, boundary samples and obstacle anchors, the
clearance and tolerance, and the 1 cm signed-distance grid itself as raw float64) plus the start,
goal, curve space, turning radius and motion-check step. Floats are written with ``repr`` (exact
round trip), so the harness decides on the very numbers the Python checker uses.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.collision.grid import FastChecker
from planning.core.world import Box, Circle, Ellipse, Polygon
from planning.errors import DependencyError
from planning.planners.base import PlanProblem
from planning.planners.sampling.tree import goal_region_poses

FORMAT_VERSION = 3


def _points(key: str, pts: NDArray[np.float64]) -> str:
    flat = " ".join(repr(float(v)) for v in np.asarray(pts, dtype=float).reshape(-1))
    return f"{key} {pts.shape[0]} {flat}"


def _obstacle(o: object) -> str:
    if isinstance(o, Circle):
        return f"circle {o.center[0]!r} {o.center[1]!r} {float(o.radius)!r}"
    if isinstance(o, Ellipse):
        return f"ellipse {o.center[0]!r} {o.center[1]!r} {o.radii[0]!r} {o.radii[1]!r} {float(o.angle)!r}"
    if isinstance(o, Box):
        return f"box {o.center[0]!r} {o.center[1]!r} {o.size[0]!r} {o.size[1]!r} {float(o.angle)!r}"
    if isinstance(o, Polygon):
        return _points("polygon", o.array)
    raise TypeError(f"the OMPL harness knows circles, ellipses, boxes and polygons, not {type(o).__name__}")


def write_problem(
    directory: Path, problem: PlanProblem, checker: FastChecker, space: str, rho: float, step: float
) -> Path:
    """Write ``problem.txt`` and, next to it, ``grid.f64`` for the harness into ``directory``.

    Args:
        directory: An existing directory.
        problem: World, start, goal and goal region (position [m] and heading [rad] tolerances: the
            harness gives OMPL this region, sampled at the goal pose, as nhsim's planners use it, or at
            :func:`goal_region_poses`, written as the ``region`` line).
        checker: The checker whose verdicts the harness reproduces.
        space: "reeds_shepp" or "dubins".
        rho: Turning radius [m].
        step: Largest curve length between checked poses of a motion [m].

    Returns:
        The problem file's path.
    """
    c = checker.checker
    grid = np.ascontiguousarray(checker._grid, dtype=np.float64)
    grid.tofile(directory / "grid.f64")
    s, g = problem.start, problem.goal
    lines = [
        f"nhsim-ompl-problem {FORMAT_VERSION}",
        "bounds " + " ".join(repr(float(b)) for b in problem.world.bounds),
        f"walls {int(c.walls)}",
        f"disc {int(c.shape == 'disc')}",
        f"radius {float(c.robot.radius)!r}",
        f"clearance {float(c.clearance)!r}",
        f"tolerance {float(c.tolerance)!r}",
        _points("footprint", c.robot.footprint),
        _points("boundary", c._boundary),
        _points("anchors", c._anchors),
        f"grid {grid.shape[0]} {grid.shape[1] if grid.ndim == 2 else 0} {checker._h!r} grid.f64",
        f"space {space} {float(rho)!r} {float(step)!r}",
        f"start {float(s.x)!r} {float(s.y)!r} {float(s.theta)!r}",
        f"goal {float(g.x)!r} {float(g.y)!r} {float(g.theta)!r} {float(problem.position_tolerance)!r} "
        f"{float(problem.heading_tolerance)!r}",
        _points("region", goal_region_poses(problem)),
        *(_obstacle(o) for o in problem.world.obstacles),
    ]
    path = directory / "problem.txt"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _call(args: list[str]) -> str:
    run = subprocess.run(args, capture_output=True, text=True, check=False)
    if run.returncode != 0:
        raise DependencyError(f"the OMPL harness failed ({' '.join(args)}): {run.stderr.strip()}")
    return run.stdout


def check_poses(harness: Path, problem_file: Path, poses: ArrayLike) -> NDArray[np.bool_]:
    """(M,) the harness's verdicts (True = free) on (M, 3) poses [x, y, theta]."""
    p = np.ascontiguousarray(np.asarray(poses, dtype=np.float64).reshape(-1, 3))
    src, out = problem_file.with_name("poses.f64"), problem_file.with_name("verdicts.u8")
    p.tofile(src)
    _call([str(harness), "check", str(problem_file), str(src), str(out)])
    return np.fromfile(out, dtype=np.uint8).astype(bool)


def check_motions(harness: Path, problem_file: Path, pairs: ArrayLike) -> NDArray[np.bool_]:
    """(M,) the harness's motion validator's verdicts (True = free) on the curves between (M, 6) pose
    pairs [x0, y0, theta0, x1, y1, theta1] (the first pose of each is not checked, as in OMPL)."""
    p = np.ascontiguousarray(np.asarray(pairs, dtype=np.float64).reshape(-1, 6))
    src, out = problem_file.with_name("pairs.f64"), problem_file.with_name("motions.u8")
    p.tofile(src)
    _call([str(harness), "motions", str(problem_file), str(src), str(out)])
    return np.fromfile(out, dtype=np.uint8).astype(bool)


@dataclass(frozen=True)
class Trials:
    """One OMPL planner's trials on one problem.

    Attributes:
        planner: "RRTConnect" or "RRTstar".
        solved: (N,) whether each trial found an exact path.
        time_s: (N,) wall time of ``SimpleSetup::solve`` [s] (RRTConnect: time to its first path).
        first_s: (N,) time to the first path [s] (nan: none).
        length_m: (N,) length of the path at the end [m] (nan: none).
        path: (K, 3) states [x, y, yaw] of the last path found (K = 0: none); consecutive states are
            joined by the space's shortest curve.
    """

    planner: str
    solved: NDArray[np.bool_]
    time_s: NDArray[np.float64]
    first_s: NDArray[np.float64]
    length_m: NDArray[np.float64]
    path: NDArray[np.float64]


def run_planner(harness: Path, problem_file: Path, planner: str, limit: float, trials: int, seed: int) -> Trials:
    """Run ``trials`` trials of an OMPL planner (``limit`` [s] each) seeded from ``seed``."""
    out = json.loads(_call([str(harness), "plan", str(problem_file), planner, repr(limit), str(trials), str(seed)]))
    rows = out["trials"]

    def col(key: str) -> NDArray[np.float64]:
        return np.array([np.nan if r[key] is None else r[key] for r in rows], dtype=float)

    solved = np.array([r["solved"] for r in rows], dtype=bool)
    path = np.asarray(out["path"], dtype=float).reshape(-1, 3)
    return Trials(planner, solved, col("time_s"), col("first_s"), col("length_m"), path)


class Session:
    """One warm harness process (``harness serve``) running trials on demand, so the bench can
    interleave OMPL's trials with its own in a process that is already loaded.

    Use as a context manager; :meth:`solve` runs one trial.
    """

    def __init__(self, harness: Path, problem_file: Path, seed: int) -> None:
        self._args = [str(harness), "serve", str(problem_file), str(seed)]
        self._proc: subprocess.Popen[str] | None = None

    def __enter__(self) -> Session:
        self._proc = subprocess.Popen(
            self._args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        return self

    def __exit__(self, *exc: object) -> None:
        if self._proc is not None:
            assert self._proc.stdin is not None
            self._proc.stdin.close()
            self._proc.wait()
            self._proc = None

    @property
    def pid(self) -> int:
        """The harness process's id."""
        assert self._proc is not None, "use Session as `with`"
        return self._proc.pid

    def solve(self, planner: str, limit: float, *flags: str) -> dict[str, float]:
        """One trial: {"solved": 0/1, "time_s", "first_s", "length_m", "last_check_s", "states", "motions",
        "nodes"} (nan where there is none). ``flags``: the harness's (``warm``: an untimed solve of at
        most 50 ms first; ``probe``; ``watchdog``; ``range=M``)."""
        proc = self._proc
        assert proc is not None and proc.stdin is not None and proc.stdout is not None, "use Session as `with`"
        proc.stdin.write(" ".join([planner, repr(limit), *flags]) + "\n")
        proc.stdin.flush()
        line = proc.stdout.readline()
        if not line:
            err = proc.stderr.read() if proc.stderr is not None else ""
            raise DependencyError(f"the OMPL harness stopped ({' '.join(self._args)}): {err.strip()}")
        row = json.loads(line)
        return {k: float(np.nan if v is None else v) for k, v in row.items()}
