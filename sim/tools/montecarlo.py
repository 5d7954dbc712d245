"""Monte Carlo of one case: many as-built robots and noise draws, the statistics, a file that loses nothing.

Run ``i`` of a study drives the case's trajectory (planned once from the study's seed, or per run with
``replan``) on its own :class:`~sim.tools.tune.Draw`: an as-built robot (build seed), a sensor noise
seed and, with ranges, a perturbation drawn from them (:func:`sim.tools.tune.make_draws`, its held-out set:
never a training draw of ``nhsim tune``; the first N draws of a larger study are those of a smaller one).
Each run drives every run kind (:data:`sim.pipeline.runs.DEFAULT_RUNS`: fused feedback, odometry feedback,
open loop) and is kept as one JSON record, keyed by its index and seeds, appended to the results file the
moment it finishes (:class:`ResultsFile`). The statistics (:func:`statistics`) are computed from the records sorted by
index, so a study killed and resumed (the same command: done runs are skipped) ends with exactly the
statistics of one never interrupted, on any number of workers.

A run is replayed bit for bit by ``nhsim simulate`` with its seeds (:func:`replay_options`):
``--seed`` the plan's, ``--noise-seed`` the noise's (the perturbation's pose noise too),
``--build-seed`` the robot's, and ``--perturb`` the drawn values written exactly.
"""

from __future__ import annotations

import collections
import hashlib
import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from planning.core.checks import check_flag, check_number, is_number
from planning.core.files import read_input
from planning.errors import ConfigError, NhsimError, option
from planning.scenario import Scenario, load_scenario
from planning.trajectory.importer import TrajectoryFile
from sim.physics.perturb import LIMITS, PerturbationRange
from sim.pipeline.case import Case, PreparedTrajectory, load_case_scenario, prepare_trajectory
from sim.pipeline.runs import DEFAULT_RUNS
from sim.pipeline.simulate import track
from sim.pipeline.sweep import missed_targets
from sim.tools.digests import code_digest, world_digest
from sim.tools.executor import Executor
from sim.tools.tune import Draw, make_draws, robot_localiser

#: Format version of the results file's header.
RESULTS_VERSION = 1
#: Spacing of the path samples kept per run (for the fan plot) [s].
PATH_SPACING_S = 0.2
#: Percentiles reported.
PERCENTILES = (50, 90, 99)
#: Metrics whose percentiles are reported.
METRICS = ("final_position_error_m", "final_heading_error_rad", "rms_position_error_m", "max_position_error_m")
#: Modules a worker imports before its first run (MuJoCo, the compiled kernels): see
#: :meth:`sim.tools.executor.Executor.preload`.
WORKER_MODULES = ("sim.tools.montecarlo", "sim.physics.simulator", "control.estimation.kernels")
#: Worst runs listed per run kind (by final position error).
WORST = 3
#: What a run record holds for each run kind (:func:`run_one`), read by :func:`statistics` and the plots.
_ENTRY_KEYS = (*METRICS, "collisions", "warnings", "status", "success", "path")


#: Most runs a study takes: its runs' draws are made up front (a million take about 0.7 GB; 268 million, the seeds'
#: own bound, took 18.5 GB and had not started after three minutes).
MAX_RUNS = 1_000_000


@dataclass(frozen=True)
class MonteCarloSpec:
    """A Monte Carlo study of one case.

    Attributes:
        case: The case; its ``seed`` is the study's (plan and draws).
        runs: Number of runs (>= 1).
        ranges: Perturbation ranges each run draws from; None for none.
        replan: Plan each run anew with its own seed instead of once.
    """

    case: Case
    runs: int
    ranges: PerturbationRange | None = None
    replan: bool = False

    def __post_init__(self) -> None:
        fix = "a study makes each run's draws up front (about 350 bytes a run); split a larger one into studies"
        runs = check_number(option("runs"), self.runs, integer=True, at_least=1)
        runs = check_number(option("runs"), runs, integer=True, at_most=MAX_RUNS, fix=fix)
        object.__setattr__(self, "runs", int(runs))

    @cached_property
    def defaults(self) -> dict[str, str]:
        """What the case leaves to its scenario and robot, resolved: ``robot`` the robot it runs (the
        scenario's own when not given), ``own_robot`` the scenario's own, ``localiser`` the localiser it
        runs on (the robot's default when not given), ``robot_localiser`` the robot's default, and ``world`` a
        digest of the scenario as read (:func:`world_digest`).

        Raises:
            ScenarioError, ConfigError: As :func:`sim.pipeline.case.load_case_scenario` and
                :meth:`sim.pipeline.case.Case.localiser_setup`.
        """
        c = self.case
        scenario = load_case_scenario(c)
        own = (c.scenario if isinstance(c.scenario, Scenario) else load_scenario(c.scenario)).robot
        default = robot_localiser(c, scenario)
        return {
            "robot": scenario.robot,
            "own_robot": own,
            "localiser": c.localiser or default,
            "robot_localiser": default,
            "world": world_digest(scenario),
        }

    def key(self) -> dict[str, Any]:
        """What makes the study's runs what they are (everything but their number), the defaults resolved
        (:attr:`defaults`: a study that leaves the robot or the localiser to the scenario is the one that
        names them): a results file holds the runs of one key."""
        c = self.case
        return {
            "scenario": str(c.scenario_name),
            "robot": self.defaults["robot"],
            "source": _source(c),
            "file": None if c.trajectory_file is None else _file_key(c.trajectory_file),
            "world": self.defaults["world"],
            "tracker": c.feedback_tracker,
            "seed": c.seed,
            "control_rate": c.control_rate,
            "gains": None if c.gains is None else asdict(c.gains),
            "sensors": c.sensors,
            "build": "nominal" if c.build_seed is None else "as-built",
            "time_limit": c.planning.time_limit,
            "ranges": None if self.ranges is None else {k: list(v) for k, v in asdict(self.ranges).items()},
            "replan": self.replan,
            "draws": "held-out",
            **self.case.localiser_options(),
            "localiser": self.defaults["localiser"],
        }

    def earlier_keys(self) -> list[dict[str, Any]]:
        """The keys an nhsim that did not resolve the defaults wrote for this same study (results version 1):
        the robot None when it is the scenario's own, no localiser when it is the robot's default."""
        key, d = self.key(), self.defaults
        robots = [key["robot"], *([None] if d["robot"] == d["own_robot"] else [])]
        localisers = [key["localiser"], *([None] if d["localiser"] == d["robot_localiser"] else [])]
        out = []
        for robot in robots:
            for localiser in localisers:
                earlier = {k: v for k, v in key.items() if k != "localiser"} | {"robot": robot}
                out.append(earlier | ({"localiser": localiser} if localiser is not None else {}))
        return [k for k in out if k != key]

    def draws(self) -> tuple[Draw, ...]:
        """The runs' draws (build seed, noise seed, perturbation): the held-out draws of the study's seed, as
        ``compare --runs`` takes them, so that a study of tuned gains never runs a robot or a noise sequence the
        gains were tuned on (``nhsim tune`` trains on the other set; an earlier nhsim took this one, hence the
        key's ``draws``)."""
        return make_draws(self.runs, self.case.seed, held_out=True, perturbations=self.ranges)

    def record_seeds(self) -> list[dict[str, Any]]:
        """What the record of each run (by index) names of it besides its metrics, as read back from a results
        file: its plan, noise and build seeds and its perturbation (:func:`run_one`'s fields)."""
        return [json.loads(json.dumps(_run_fields(self.case_of(d), d))) for d in self.draws()]

    def case_of(self, draw: Draw) -> Case:
        """The case a run drives: the study's, on the draw's robot, noise and perturbation."""
        pert = None if draw.perturbation is None else replace(draw.perturbation, seed=draw.seed)
        build = None if self.case.build_seed is None else draw.build_seed
        if self.replan:
            return replace(self.case, seed=draw.seed, build_seed=build, perturbation=pert)
        return replace(self.case, noise_seed=draw.seed, build_seed=build, perturbation=pert)


def _source(case: Case) -> str:
    """``reference:NAME``, ``planner:NAME`` or ``file:PATH``."""
    if case.trajectory_file is not None:
        return f"file:{case.trajectory_file.path}"
    return f"reference:{case.reference}" if case.reference is not None else f"planner:{case.planner}"


def _file_key(tfile: TrajectoryFile) -> dict[str, Any]:
    """How a file is read, and a hash of its content: a file edited since is another study (a rosbag2
    folder: its files' contents in name order)."""
    path = Path(tfile.path)
    files = sorted(f for f in path.rglob("*") if f.is_file()) if path.is_dir() else [path]
    digest = hashlib.sha1(b"".join(read_input(f) for f in files)).hexdigest()  # a pipe: the bytes it gave
    return {**tfile.as_dict(), "sha1": digest}


def _run_fields(case: Case, draw: Draw) -> dict[str, Any]:
    """A run's seeds and perturbation, as its record names them (``case``: :meth:`MonteCarloSpec.case_of` the draw)."""
    return {
        "plan_seed": case.seed,
        "noise_seed": draw.seed,
        "build_seed": case.build_seed,
        "perturbation": None if case.perturbation is None else case.perturbation.as_dict(),
    }


def run_one(shared: tuple[MonteCarloSpec, PreparedTrajectory | None], item: tuple[int, Draw]) -> dict[str, Any]:
    """Run ``i`` of a study (every run kind) as its record; the work of one executor task.

    Args:
        shared: The study and its trajectory (None with ``replan``: planned here).
        item: (index, draw).
    """
    spec, prepared = shared
    index, draw = item
    case = spec.case_of(draw)
    rec: dict[str, Any] = {"index": index, **_run_fields(case, draw)}
    try:
        prep = prepare_trajectory(case) if prepared is None else replace(prepared, case=case)
    except NhsimError as exc:  # a replanned run whose plan failed: every kind failed
        rec["failed"] = f"{type(exc).__name__}: {exc}"
        return rec
    job = track(prep, DEFAULT_RUNS, strict=False)
    planned = prep.source.startswith(("planner:", "file:"))  # a file is tracked and judged as a plan (simulate)
    every = max(1, round(PATH_SPACING_S / float(np.median(np.diff(job.logs[DEFAULT_RUNS[0]].t)))))
    runs: dict[str, Any] = {}
    for kind, run in job.runs.items():
        m = run.metrics
        missed = missed_targets(m, prep.scenario, planned=planned)
        ok = not missed and m.collisions == 0 and m.warnings == 0 and m.status == "ok"
        entry: dict[str, Any] = {name: float(getattr(m, name)) for name in METRICS}
        entry.update(collisions=m.collisions, warnings=m.warnings, status=m.status, success=ok)
        xy = run.log.pose[::every, :2]
        entry["path"] = np.round(np.vstack([xy, run.log.pose[-1:, :2]]), 4).tolist()
        runs[str(kind)] = entry
    rec["runs"] = runs
    return rec


#: Another results file, and replacing this one, as :class:`ResultsFile`'s messages name them.
_RESULTS = option("results", python="path")
_REPLACE = option("overwrite", True, python="delete it first")


#: What every run record has (besides ``runs``, or ``failed`` for a run whose replanning failed).
_RECORD_KEYS = ("index", "plan_seed", "noise_seed", "build_seed", "perturbation")


def _record_problem(rec: Any) -> str:
    """Why a results line's JSON is not a run record (:func:`run_one`'s); "" when it is one: every field there, of
    its type (:func:`_fields_problem`)."""
    if not isinstance(rec, dict):
        return f"a JSON {type(rec).__name__}, not a run record"
    missing = [k for k in _RECORD_KEYS if k not in rec]
    if missing:
        return f"a record without {', '.join(repr(k) for k in missing)}, not a run record"
    index = rec["index"]
    if not isinstance(index, int) or isinstance(index, bool) or index < 0:
        return f"its index {index!r} is not a run number (an integer >= 0)"
    runs = rec.get("runs")
    if "failed" in rec:
        return _fields_problem(rec, {})
    if not (isinstance(runs, dict) and all(isinstance(e, dict) and set(_ENTRY_KEYS) <= set(e) for e in runs.values())):
        return f"run {index} has neither 'failed' nor its runs' metrics ({', '.join(_ENTRY_KEYS)} per run kind)"
    kinds = [str(k) for k in DEFAULT_RUNS]
    missing, other = [k for k in kinds if k not in runs], [k for k in runs if k not in kinds]
    if missing or other:
        what = f"has no {', '.join(map(repr, missing))} run" if missing else f"has a run {', '.join(map(repr, other))}"
        return f"run {index} {what}, while every run of a study drives {', '.join(kinds)}"
    return _fields_problem(rec, runs)


def _fields_problem(rec: Mapping[str, Any], runs: Mapping[str, Mapping[str, Any]]) -> str:
    """Why a run record's fields (all there) are not of the types :func:`run_one` writes, naming the first such
    field; "" when they are: seeds integers >= 0 (the build seed or null), the perturbation an object or null,
    ``failed`` text, and per run kind its metrics finite numbers >= 0 (a bool, null or NaN is none), its counts
    integers >= 0, its status text, its success true or false and its path [x, y] points (``runs``)."""
    index = rec["index"]
    try:
        for name in ("plan_seed", "noise_seed", "build_seed"):
            if rec[name] is not None or name != "build_seed":  # None: the nominal robot
                check_number(f"run {index}: {name}", rec[name], integer=True, at_least=0)
        for kind, entry in runs.items():
            for name in METRICS:
                check_number(f"run {index}: {kind} {name}", entry[name], at_least=0)
            for name in ("collisions", "warnings"):
                check_number(f"run {index}: {kind} {name}", entry[name], integer=True, at_least=0)
            check_flag(f"run {index}: {kind} success", entry["success"])
    except ConfigError as exc:
        return str(exc)
    texts = [("failed", rec["failed"])] if "failed" in rec else []
    texts += [(f"{kind} status", entry["status"]) for kind, entry in runs.items()]
    wrong = [f"run {index}: {name} must be text, got {v!r:.80}" for name, v in texts if not isinstance(v, str)]
    if rec["perturbation"] is not None and not isinstance(rec["perturbation"], dict):
        wrong.append(f"run {index}: perturbation must be an object or null, got {rec['perturbation']!r:.80}")
    for kind, entry in runs.items():
        path = entry["path"]
        if not (isinstance(path, list) and path and all(_is_point(p) for p in path)):
            wrong.append(f"run {index}: {kind} path must be a list of [x, y] points (finite numbers), got {path!r:.80}")
    return wrong[0] if wrong else ""


def _is_point(value: object) -> bool:
    """Whether ``value`` is a path's point as a record writes it: [x, y], two finite numbers."""
    return isinstance(value, list) and len(value) == 2 and all(is_number(v) for v in value)


def _seeds_problem(rec: Mapping[str, Any], seeds: Sequence[Mapping[str, Any]]) -> str:
    """Why a run record is not the run of this study its index names (``seeds``: :meth:`MonteCarloSpec.record_seeds`,
    by index); "" when it is, or when its index is beyond them (a larger study's run, checked when that one is run).
    Compared as JSON, of their types too: a perturbation's ``true`` is not its 1.0, nor a seed's 7.0 its 7."""
    index = rec["index"]
    if index >= len(seeds):
        return ""
    wrong = [k for k, v in seeds[index].items() if json.dumps(rec[k], sort_keys=True) != json.dumps(v, sort_keys=True)]
    said = ", ".join(f"{k} {rec[k]!r} (this study's is {seeds[index][k]!r})" for k in wrong)
    return f"run {index} is not this study's run {index}: its {said}" if wrong else ""


class ResultsFile:
    """The runs of one study, one JSON line each after a header line naming the study's key.

    Opening an existing file checks its key (a file of another study is refused, naming what
    differs) and reads its runs; a last line cut short by a kill (no newline after it) is dropped, said on
    stderr, and any other line that is not a run record of this study (not JSON, a field or a run kind
    missing, a field of another type, seeds other than those the study derives for its index) is refused, naming
    it (the file is left as it is). A run on two lines is read once when they are the same record (said on stderr),
    refused when they differ.
    Each new record is appended, flushed and synced to disk before the next is taken. A new file is made with the first
    finished run, so a study refused before any run (bad input, an unreachable scheduler) leaves none. A file of
    another study it replaces (``replacing``: ``--overwrite``) stays as it was, with its summary and plots, until
    the study is done: the runs go to :attr:`file`, the sibling ``NAME.partial`` (:func:`partial_path`), resumed
    from there by the same command, and moved over ``path`` with the new summary and plots as one set
    (``sim.cli.montecarlo``). An interrupt or a failure before then leaves every old file as it was.

    Args:
        path: The file (JSON lines).
        key: The study's key (:meth:`MonteCarloSpec.key`).
        earlier: Keys an earlier nhsim wrote for the same study (:meth:`MonteCarloSpec.earlier_keys`): a file
            headed by one is this study's too.
        replacing: The file at ``path`` (another study's, or no results file: ``--overwrite``) is not read; this
            study's runs go to (and resume from) :func:`partial_path` of it until the study is written.
        seeds: What the study's runs' records name of them, by index (:meth:`MonteCarloSpec.record_seeds`, called
            only when there is a file to read): a record whose seeds or perturbation differ from its index's, a
            failed plan's included, is refused (none given: unchecked).

    Raises:
        ConfigError: The file holds another study, is not a results file, or holds a line that is not a run
            record (other than a last line cut short).
    """

    def __init__(
        self,
        path: Path,
        key: Mapping[str, Any],
        earlier: Sequence[Mapping[str, Any]] = (),
        code: str | None = None,
        *,
        replacing: bool = False,
        seeds: Callable[[], Sequence[Mapping[str, Any]]] | None = None,
    ) -> None:
        self.path, self.key = Path(path), dict(key)
        self._seeds = seeds
        self.earlier = [dict(k) for k in earlier]
        self.code = code_digest() if code is None else code
        self.records: dict[int, dict[str, Any]] = {}
        #: What reading the file did that the user should hear of (a last line cut short, dropped).
        self.notes: list[str] = []
        self.replacing = replacing and self.path.exists()
        #: The file the runs are read from and appended to: ``path``, or its partial sibling while it replaces it.
        self.file = partial_path(self.path) if self.replacing else self.path
        if self.file.exists():
            try:
                self._read()
            except ConfigError:
                if not self.replacing:
                    raise
                runs = _runs_in(self.file)
                self.file.unlink()  # another study's partial runs, or none: --overwrite replaces them too
                self.records.clear()
                self.notes[:] = [f"replaced {self.file}: its {runs} run(s), of another interrupted study, are dropped"]
        partial = partial_path(self.path)
        if not self.replacing and partial.exists():
            self.notes.append(
                f"{partial} holds {_runs_in(partial)} run(s) of an interrupted study that was replacing {self.path}: "
                "rerun that study (its command, --overwrite included) to resume them, or delete the file"
            )

    def _read(self) -> None:
        raw = self.file.read_bytes()
        lines = raw.split(b"\n")
        try:
            header = json.loads(lines[0])
            theirs = dict(header["key"])  # an object, or no results file's header
        except (ValueError, KeyError, TypeError) as exc:
            raise ConfigError(
                f"{self.file} is not an nhsim montecarlo results file; choose another {_RESULTS}, or {_REPLACE} to "
                "replace it"
            ) from exc
        if theirs != self.key and theirs not in self.earlier:
            raise _another_study(self.file, theirs, self.key)
        if header.get("code") != self.code:  # the same settings, other code: its runs are not this code's
            made = f"by other code (digest {header['code']})" if header.get("code") else "before runs named their code"
            raise ConfigError(
                f"{self.file} holds runs of this study made {made}, not this nhsim's (digest {self.code}: its "
                f"planners, trackers, physics and models); runs of both would be mixed: give {_REPLACE} to run the "
                f"study again, or another {_RESULTS}"
            )
        self._read_records(raw, lines)

    def _read_records(self, raw: bytes, lines: list[bytes]) -> None:
        """The run records after the header. Only the last line may be unreadable, and only when it is cut short
        (no newline after it: a run killed while appending it): it is dropped (said on stderr) and its run done
        again. Any other unreadable line is refused, naming it: nothing is dropped or cut from the file. A run
        on two lines (two commands of the study run at once each append every run) is read once, said on stderr,
        when the lines are the same record; two records of one run that differ are refused, naming both lines."""
        torn = not raw.endswith(b"\n")
        seeds = [] if self._seeds is None else self._seeds()
        first: dict[int, int] = {}  # the line of each run read
        repeats: list[int] = []
        for number, line in enumerate(lines[1:], start=2):
            if not line.strip():
                continue
            last = number == len(lines)
            try:
                rec = json.loads(line)
            except ValueError:
                if last and torn:
                    self._drop_torn_line(raw, len(raw) - len(line), number)
                    torn = False  # the file ends with the newline before that line now
                    break
                raise self._bad_line(number, "not a JSON record") from None
            problem = _record_problem(rec) or _seeds_problem(rec, seeds)
            if problem:
                raise self._bad_line(number, problem)
            index = int(rec["index"])
            if index in first and rec != self.records[index]:
                raise self._bad_line(number, f"run {index} is on line {first[index]} already, with other values")
            if index in first:
                repeats.append(number)
                continue
            first[index] = number
            self.records[index] = rec
        if repeats:
            said = ", ".join(map(str, repeats[:5])) + (", ..." if len(repeats) > 5 else "")
            self.notes.append(
                f"{self.file}: {len(repeats)} line{'s' * (len(repeats) > 1)} ({said}) repeat runs of earlier lines, "
                "the same records (as two commands of this study run at once write them); each run is read once"
            )
        if torn:  # a whole last record without its newline: ended, so that the next record starts a line
            with self.file.open("ab") as f:
                f.write(b"\n")

    def _drop_torn_line(self, raw: bytes, start: int, number: int) -> None:
        with self.file.open("r+b") as f:
            f.truncate(start)
        self.notes.append(
            f"{self.file}: dropped its last line (line {number}, {len(raw) - start} bytes cut short: a run "
            "interrupted while it was written, or a write that failed, a full disk say); that run is done again"
        )

    def _bad_line(self, number: int, problem: str) -> ConfigError:
        return ConfigError(
            f"{self.file}, line {number}: {problem}; the file was changed by something other than nhsim (an "
            "interrupted write can only cut its last line short), and nothing was removed from it: repair or "
            f"delete that line (its run is then done again), give another {_RESULTS}, or {_REPLACE} to run the "
            "whole study again"
        )

    def _append(self, obj: Mapping[str, Any]) -> None:
        try:
            with self.file.open("a", encoding="utf-8") as f:
                f.write(json.dumps(obj, allow_nan=False) + "\n")
                f.flush()
                os.fsync(f.fileno())
        except OSError as exc:  # a write's error names no file: this one is named (could not write FILE)
            if exc.filename is not None:
                raise
            raise OSError(exc.errno, exc.strerror, str(self.file)) from exc

    def add(self, record: dict[str, Any]) -> None:
        """Store a finished run (the file and its header made with the first)."""
        if not self.file.exists():
            self.file.parent.mkdir(parents=True, exist_ok=True)
            self._append({"nhsim_montecarlo": RESULTS_VERSION, "key": self.key, "code": self.code})
        self._append(record)
        self.records[int(record["index"])] = record


def _another_study(file: Path, theirs: Mapping[str, Any], key: Mapping[str, Any]) -> ConfigError:
    """The refusal of results file ``file``, whose header names the key ``theirs``, for the study of ``key``:
    naming what differs."""
    diff = ", ".join(
        f"{k}: {theirs.get(k)!r} there, {key.get(k)!r} here"
        for k in sorted(set(theirs) | set(key))
        if theirs.get(k) != key.get(k)
    )
    return ConfigError(
        f"{file} holds the runs of another study ({diff}); give another {_RESULTS}, the same settings, or "
        f"{_REPLACE} to replace it"
    )


def check_study(path: Path, key: Mapping[str, Any], earlier: Sequence[Mapping[str, Any]] = ()) -> None:
    """Refuse a results file of another study (:class:`ResultsFile`'s refusal, naming what differs) from its header
    line alone, before anything is read, checked or written: a command's other refusals (its summary, which is
    then the other study's too) say less. Nothing when ``path`` is no regular file or no results file (what
    :class:`ResultsFile` says when it opens it).

    Raises:
        ConfigError: The file's header names another study's key.
    """
    if not path.is_file():
        return
    try:
        with path.open("rb") as f:
            theirs = json.loads(f.readline())["key"]
    except (OSError, ValueError, KeyError, TypeError):
        return
    if isinstance(theirs, dict) and theirs != key and theirs not in earlier:
        raise _another_study(path, theirs, key)


def _runs_in(file: Path) -> int:
    """The run lines of a results file (those after its header)."""
    return max(len(file.read_bytes().splitlines()) - 1, 0)


def partial_path(path: Path) -> Path:
    """Where a study that replaces another's results file ``path`` keeps its runs until it is written: ``NAME.partial``
    beside it."""
    return path.with_name(path.name + ".partial")


@dataclass(frozen=True)
class MonteCarloResult:
    """A finished study.

    Attributes:
        spec: The study.
        prepared: Its trajectory (the study's plan; with ``replan``, the plan of the study's seed).
        records: Run records by index, 0 .. runs - 1.
        stats: :func:`statistics` of the records.
        ran: Runs executed by this call (the others were read from the results file).
        retries: Runs executed again because their worker died.
    """

    spec: MonteCarloSpec
    prepared: PreparedTrajectory
    records: list[dict[str, Any]]
    stats: dict[str, Any]
    ran: int
    retries: int


def run_montecarlo(
    spec: MonteCarloSpec,
    executor: Executor,
    results: ResultsFile,
    *,
    progress: Callable[[int, int], Any] | None = None,
) -> MonteCarloResult:
    """Run the study's missing runs on the executor, storing each as it finishes, and compute the statistics.

    Raises:
        NhsimError: The plan failed (planned once), or a bad case.
    """
    prepared = prepare_trajectory(spec.case)
    todo = [(i, d) for i, d in enumerate(spec.draws()) if i not in results.records]
    done = spec.runs - len(todo)
    if progress is not None:
        progress(done, spec.runs)
    shared = (spec, None if spec.replan else prepared)
    executor.preload(*WORKER_MODULES)
    for _, record in executor.map_unordered(run_one, todo, shared=shared):
        results.add(record)
        done += 1
        if progress is not None:
            progress(done, spec.runs)
    records = [results.records[i] for i in range(spec.runs)]
    return MonteCarloResult(spec, prepared, records, statistics(records), len(todo), executor.retries)


def statistics(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Per run kind: percentiles of each metric, success and collision rates, the worst runs, and the runs that
    ended early by why (``ended_early``: status -> count; their errors are where they stopped).

    A run whose replanning failed counts as a failure of every kind (no metrics).
    """
    out: dict[str, Any] = {}
    for kind in (str(k) for k in DEFAULT_RUNS):
        have = [r for r in records if "runs" in r and kind in r["runs"]]
        entries = [r["runs"][kind] for r in have]
        n = len(records)
        stat: dict[str, Any] = {"runs": n, "measured": len(entries)}
        for name in METRICS:
            values = np.array([e[name] for e in entries], dtype=float)
            stat[name] = {f"p{p}": float(np.percentile(values, p)) if len(values) else math.nan for p in PERCENTILES}
        causes = collections.Counter(_cause(str(e["status"])) for e in entries if e["status"] != "ok")
        stat["ended_early"] = dict(sorted(causes.items()))  # why runs stopped before their end, and how many
        stat["success_rate"] = sum(bool(e["success"]) for e in entries) / n if n else math.nan
        stat["collision_rate"] = sum(e["collisions"] > 0 for e in entries) / n if n else math.nan
        order = sorted(have, key=lambda r: (-r["runs"][kind]["final_position_error_m"], r["index"]))
        stat["worst"] = [
            {
                "index": r["index"],
                "plan_seed": r["plan_seed"],
                "noise_seed": r["noise_seed"],
                "build_seed": r["build_seed"],
                "perturbation": r["perturbation"],
                "final_position_error_m": r["runs"][kind]["final_position_error_m"],
            }
            for r in order[:WORST]
        ]
        out[kind] = stat
    out["plan_failures"] = sum("failed" in r for r in records)
    return out


def _cause(status: str) -> str:
    """Why a run ended early, as its status begins, without its times: "estimator diverged", "fell", "collided with
    'wall_east'" (a run's status says when, and what followed)."""
    return status.split(" at t=")[0].split(" (")[0].strip() or status


def replay_options(record: Mapping[str, Any]) -> list[str]:
    """The ``nhsim simulate`` options that replay a run bit for bit, besides the study's own options
    (scenario, robot, source, gains, ...): its seeds and its perturbation, written exactly."""
    opts = ["--seed", str(record["plan_seed"]), "--noise-seed", str(record["noise_seed"])]
    opts += ["--build", "nominal"] if record["build_seed"] is None else ["--build-seed", str(record["build_seed"])]
    pert = record.get("perturbation")
    if pert:
        changed = [f"{k}={pert[k]!r}" for k in LIMITS if pert[k] != LIMITS[k][2]]
        if changed:
            opts += ["--perturb", ",".join(changed)]
    return opts
