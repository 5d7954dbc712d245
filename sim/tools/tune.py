r"""Tuning the FBL tracker's gains with Optuna over a set of cases, on realistic robots.

Objective of a gain set (lower is better), averaged over every case and draw:

    J = rms_position_error + final_position_error + w_sat * saturation_fraction   [m]

plus ``FAILURE_COST`` for a run that touched an obstacle, made MuJoCo warn or produced a
non-finite command. ``w_sat`` (default 0.05 m) prices a command sitting on the speed or yaw-rate
limit: saturating all the time costs as much as 5 cm of error.

Each case is run in its own kind (the fused-estimate closed loop for the FBL tracker) over K
:class:`Draw`\ s: an as-built robot (build seed, :mod:`sim.physics.asbuilt`), a sensor noise seed
(:mod:`sim.robot.sensing`) and, in a robust study, a perturbation. :func:`make_draws` makes them
from the study's seed, and every trial meets the same draws (common random numbers), so two gain
sets differ only by their gains. High gains follow a perfect pose tightly but chase the estimate's
noise; the objective, measured against the true pose, prices both.

The gains found are judged on held-out draws (:func:`make_draws` with ``held_out=True``): other
robots and other noise, never seen by a trial (training seeds are even, held-out seeds odd).
:func:`compare` runs the tuned and the default gains on the same held-out draws and
:class:`Comparison` says which is better and by how much.

Search space (log-uniform): Kp in [0.5, 100] 1/s^2, Kd in [0.5, 40] 1/s, xi_min in
[0.002, 0.2] m/s -- the whole parameter set the tracker exposes (:class:`FBLGains`).

The study lives in an SQLAlchemy storage; its settings (cases, draws, weights, and digests of the
cases' scenarios and of the code: :attr:`TuneSpec.content`) are stored with it, and a rerun with the
same settings resumes it: completed trials count toward the requested number, the default gains are
evaluated once so every study holds an honest "no worse than the defaults" comparison. A running
trial beats every ``HEARTBEAT_INTERVAL`` seconds; one silent for ``GRACE_PERIOD`` seconds belongs to
a killed worker: it is failed and its gains are enqueued again (:func:`open_storage`, Optuna's
``RetryHeartbeatStaleTrialCallback``), and a resumed study waits for such trials before it counts
what is left to run (:func:`settle_running`). A trial an interrupt stopped is marked
:data:`INTERRUPTED` and its gains are enqueued again on resume (:func:`requeue_interrupted`); each
trial's proposals are seeded by the number it would have had in a study never interrupted
(:func:`sampling_number`), so an interrupted and resumed study ends with the trials of one run at
once.

Workers in several processes (or machines) share the study through the storage. Every SQLite
transaction begins ``IMMEDIATE`` (:func:`open_storage`): Optuna reads a trial's state and then
writes it ("take the waiting trial", "fail the stale trial"), and under Python's default SQLite
mode the read runs outside the write's transaction, so two workers could both take one waiting
trial and the second would die telling a trial the first had completed.
"""

from __future__ import annotations

import contextlib
import importlib
import json
import math
import os
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from control.base import search_space, tuned_option
from control.gains import FBLGains, UnstableGainsError
from planning.core.checks import check_number
from planning.errors import ConfigError, NhsimError, option
from planning.signals import signals_held, signals_released

if TYPE_CHECKING:  # the command line reads SAMPLERS while building its parser, before mujoco may load
    from planning.scenario import Scenario
    from sim.physics.metrics import TrackingMetrics
    from sim.physics.perturb import Perturbation, PerturbationRange
    from sim.pipeline.case import Case
    from sim.pipeline.simulate import PreparedCase

#: Name -> (low, high) of each tuned parameter, sampled log-uniformly.
SEARCH_SPACE: dict[str, tuple[float, float]] = {"kp": (0.5, 100.0), "kd": (0.5, 40.0), "xi_min": (0.002, 0.2)}


def tuned_space(tracker: str = "") -> tuple[type, dict[str, tuple[float, float]]]:
    """The parameter dataclass tuned for a tracker and its search space (log-uniform ranges).

    "" (the default study) and the trackers whose tuned option is their FBL gains tune
    :class:`FBLGains` over ``SEARCH_SPACE``; any other registered tracker its ``TUNED`` dataclass over
    the ranges its fields declare (:func:`control.base.ranged`).

    Raises:
        ConfigError: An unknown tracker (lists the registered ones), one with nothing to tune (no ``TUNED``, or
            a ``TUNED`` dataclass without a tuned field), or a search range that cannot be searched (names the
            field: :func:`control.base.search_space`).
    """
    cls = tuned_option(tracker)[1] if tracker else FBLGains
    try:
        space = SEARCH_SPACE if cls is FBLGains else search_space(cls)
    except ConfigError as exc:
        raise ConfigError(f"tracker {tracker!r}: {exc}") from exc
    if not space:
        raise ConfigError(
            f"tracker {tracker!r} has nothing to tune: no field of its {getattr(cls, '__name__', cls)} declares a "
            "search range; declare one on each field to tune, ranged(default, low, high, unit, tune=(a, b)) with "
            "0 < a < b (searched log-uniformly, docs/how-to/new-tracker.md)"
        )
    return cls, space


def make_params(tracker: str, values: dict[str, float]) -> Any:
    """The tracker's tuned dataclass with ``values`` (the other fields at their defaults)."""
    return tuned_space(tracker)[0](**values)


#: Cost added for a failed run (collision, MuJoCo warning, non-finite command) [m].
FAILURE_COST = 1.0
#: Sampler name -> "module:class"; each takes ``seed=``.
SAMPLERS: dict[str, str] = {"tpe": "optuna.samplers:TPESampler", "random": "optuna.samplers:RandomSampler"}
#: Heartbeat of running trials [s] and the silence after which a trial is declared dead [s]
#: (read when a storage is opened).
HEARTBEAT_INTERVAL = 2
GRACE_PERIOD = 10
#: How many times the gains of a trial killed while running are enqueued again.
MAX_RETRY = 2
#: User attribute naming the sampler (a key of ``SAMPLERS``) that proposed a trial's gains (:func:`samplers_of`).
SAMPLER = "sampler"
#: What :func:`samplers_of` counts a trial under whose sampler was not recorded (an earlier nhsim's).
UNRECORDED = "unrecorded"
#: User attribute marking a trial an interrupt stopped (:func:`requeue_interrupted` runs its gains again).
INTERRUPTED = "interrupted"
#: Attempts to open a storage whose tables another worker is creating at the same moment.
SCHEMA_ATTEMPTS = 4
#: Seconds a worker waits for the settings of a study another worker has just created.
SETTINGS_WAIT_S = 30.0
#: Seeds of draws are below this; training seeds are even, held-out seeds odd.
SEED_SPACE = 2**31
#: Most draws of one set: a quarter of the seeds of one parity, so that drawing them stays linear in time.
MAX_DRAWS = SEED_SPACE // 8
#: Cases to tune on, as messages suggest them (:func:`planning.errors.option`).
EXAMPLE_CASES = option(
    "scenarios", "open:figure8,open:circle", python='cases=[Case.parse("open:figure8"), Case.parse("open:circle")]'
)


def check_draws(where: str, count: object, *, at_least: int = 0) -> int:
    """``count`` of draws (robots and noise draws of one set) as an int in [``at_least``, :data:`MAX_DRAWS`].

    Raises:
        ConfigError: Not such an integer; the message names ``where`` (the option or field) and the bound.
    """
    count = check_number(where, count, integer=True, at_least=at_least)
    fix = "a set draws at most that many distinct robots and noise draws (a quarter of the seeds of one parity)"
    return int(check_number(where, count, integer=True, at_most=MAX_DRAWS, fix=fix))


@dataclass(frozen=True)
class Draw:
    """One realistic robot and its sensors' noise, which a case is run on.

    Attributes:
        build_seed: Seed of the as-built robot (:meth:`sim.pipeline.case.Case.as_built`).
        seed: Seed of the sensor noise (:meth:`sim.pipeline.case.Case.sensing`).
        perturbation: Perturbation of a robust study; None for none.
    """

    build_seed: int
    seed: int
    perturbation: Perturbation | None = None

    def as_dict(self) -> dict[str, Any]:
        """Plain-dict view (study settings, records)."""
        pert = None if self.perturbation is None else self.perturbation.as_dict()
        return {"build_seed": self.build_seed, "seed": self.seed, "perturbation": pert}


def make_draws(
    count: int, seed: int, *, held_out: bool = False, perturbations: PerturbationRange | None = None
) -> tuple[Draw, ...]:
    """``count`` draws made from a study's seed; the same arguments give the same draws.

    The build seeds of one set are distinct, and so are its noise seeds; each comes from its own
    stream, so a larger ``count`` keeps the smaller set's draws and adds to them. Training draws
    have even seeds and held-out draws odd ones, so a held-out draw never repeats a robot or a
    noise sequence of any training draw of any size.

    Args:
        count: Number of draws (>= 0).
        seed: The study's seed.
        held_out: Draw the held-out set instead of the training set.
        perturbations: Range each draw's perturbation is sampled from (robust study); None for none.

    Raises:
        ConfigError: Negative count, or more than :data:`MAX_DRAWS`.
    """
    count = check_draws("number of draws", count)
    parity = int(held_out)
    build_rng, noise_rng, pert_rng = (np.random.default_rng([seed, parity, stream]) for stream in range(3))
    builds, noises = _distinct_seeds(build_rng, count, parity), _distinct_seeds(noise_rng, count, parity)
    perts: list[Perturbation | None] = [None] * count
    if perturbations is not None:
        perts = list(perturbations.sample(count, int(pert_rng.integers(SEED_SPACE))))
    return tuple(Draw(b, n, p) for b, n, p in zip(builds, noises, perts, strict=True))


def _distinct_seeds(rng: np.random.Generator, count: int, parity: int) -> list[int]:
    """``count`` distinct seeds of one parity, each drawn uniformly and a repeat drawn again: the first ``count``
    distinct values of the generator's stream of draws, in the order drawn.

    The stream is drawn in blocks (a block of draws is the same stream as the draws one at a time) and its
    repeats dropped as a whole (the first time each value came kept), so a million seeds take a fraction of a
    second (one at a time, with a set of those seen, they took 8.7 s and 260 MB); at most a quarter of the seeds
    of a parity are ever taken (:data:`MAX_DRAWS`), so a block is short of ``count`` by less than a third.
    """
    drawn = np.empty(0, dtype=np.int64)
    while True:
        unique, first = np.unique(drawn, return_index=True)
        if unique.size >= count:
            return [int(v) for v in drawn[np.sort(first)[:count]]]
        block = 2 * rng.integers(SEED_SPACE // 2, size=count - unique.size + 16) + parity
        drawn = np.concatenate([drawn, block])


@dataclass(frozen=True)
class Evaluation:
    """A gain set's score over cases × draws.

    Attributes:
        objective: Mean J [m].
        rms_m: Mean RMS position error [m] (of the runs that ran).
        final_m: Mean final position error [m].
        saturation: Mean saturation fraction.
        failures: Number of failed runs.
        runs: Number of runs.
        costs: J of each run [m], cases outer, draws inner.
    """

    objective: float
    rms_m: float
    final_m: float
    saturation: float
    failures: int
    runs: int
    costs: tuple[float, ...] = field(default=(), repr=False)

    def as_dict(self) -> dict[str, float | int]:
        """Plain-dict view of the means and counts (not the per-run costs)."""
        return {
            "objective": self.objective,
            "rms_m": self.rms_m,
            "final_m": self.final_m,
            "saturation": self.saturation,
            "failures": self.failures,
            "runs": self.runs,
        }


class Evaluator:
    """Scores gain sets on a fixed set of cases and draws (common random numbers: every gain set
    meets the same robots, noise and perturbations).

    Each case's trajectory is prepared once, and a simulator is compiled once per (case, build
    seed) and kept, so a trial only runs physics.

    Args:
        cases: The cases (built lazily, once).
        draws: Draws each case is run on; empty or None -> the case as it is (its own build seed,
            seed and perturbation).
        saturation_weight: ``w_sat`` [m].
        tracker: The tracker whose parameters are scored ("": the FBL gains of each case's tracker).
    """

    def __init__(
        self,
        cases: Sequence[Case],
        draws: Sequence[Draw] | None = None,
        *,
        saturation_weight: float = 0.05,
        tracker: str = "",
    ) -> None:
        if not cases:
            raise ConfigError(f"no cases to tune on; give some, e.g. {EXAMPLE_CASES}")
        self.cases = tuple(cases)
        self.draws: tuple[Draw | None, ...] = tuple(draws) if draws else (None,)
        self.saturation_weight = check_number("saturation weight", saturation_weight, at_least=0.0)
        self.tracker = tracker
        self._prepared: list[PreparedCase] | None = None
        self._builds: dict[tuple[int, int | None], PreparedCase] = {}

    def prepared(self) -> list[PreparedCase]:
        """The prepared cases (raises the cases' errors on first use)."""
        if self._prepared is None:
            from sim.pipeline.simulate import prepare_case

            self._prepared = [prepare_case(c) for c in self.cases]
        return self._prepared

    def built(self, index: int, build_seed: int | None) -> PreparedCase:
        """Case ``index`` on the robot of ``build_seed``, compiled on first use and kept."""
        key = (index, build_seed)
        if key not in self._builds:
            self._builds[key] = self.prepared()[index].with_build(build_seed)
        return self._builds[key]

    def with_draws(self, draws: Sequence[Draw]) -> Evaluator:
        """The same cases (shared, not rebuilt, and sharing the compiled builds) on other draws."""
        other = Evaluator(self.cases, draws, saturation_weight=self.saturation_weight, tracker=self.tracker)
        other._prepared, other._builds = self.prepared(), self._builds
        return other

    def score(self, pc: PreparedCase, gains: Any, draw: Draw | None) -> tuple[float, TrackingMetrics | None, bool]:
        """One run with FBL ``gains`` or a tracker's parameters: its J [m], its metrics (None when the
        run raised) and whether it failed."""
        fbl, params = (gains, None) if isinstance(gains, FBLGains) else (None, gains)
        try:
            pert, seed = (draw.perturbation, draw.seed) if draw is not None else (None, None)
            run = pc.run(fbl, pert, seed=seed, params=params)
        except UnstableGainsError:  # a trial's gains the control rate cannot keep stable: they fail, the study goes on
            return FAILURE_COST, None, True
        except ConfigError:  # bad input, not a failed run (prepare_case refuses what it can foresee)
            raise
        except NhsimError:
            return FAILURE_COST, None, True
        m = run.metrics
        cost = m.rms_position_error_m + m.final_position_error_m + self.saturation_weight * m.saturation_fraction
        # a run that ended early (a fall, a lost estimate) scored only its errors up to the end: a failure
        failed = m.collisions > 0 or m.warnings > 0 or m.status != "ok" or not math.isfinite(cost)
        return (cost if math.isfinite(cost) else 0.0) + (FAILURE_COST if failed else 0.0), m, failed

    def evaluate(self, gains: Any) -> Evaluation:
        """Run every case on every draw with ``gains`` (FBL gains or the tuned tracker's parameters)
        and average."""
        costs: list[float] = []
        rms, final, sat, failures = [], [], [], 0
        for i, base in enumerate(self.prepared()):
            for draw in self.draws:
                cost, m, failed = self.score(base if draw is None else self.built(i, draw.build_seed), gains, draw)
                costs.append(cost)
                failures += int(failed)
                if m is not None:
                    rms.append(m.rms_position_error_m)
                    final.append(m.final_position_error_m)
                    sat.append(m.saturation_fraction)
        mean = float(np.mean(costs))
        return Evaluation(mean, _mean(rms), _mean(final), _mean(sat), failures, len(costs), tuple(costs))


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else float("nan")


@dataclass(frozen=True)
class TuneSpec:
    """Everything a tuning worker needs (picklable, for worker processes).

    Attributes:
        cases: Cases tuned on.
        draws: Draws every case is run on in every trial (:func:`make_draws`; empty: each case as
            it is).
        storage: SQLAlchemy URL.
        study: Study name.
        trials: Completed trials wanted in the study.
        sampler: Key of ``SAMPLERS``.
        seed: Seed of the sampler (mixed with the trial count and the worker index).
        saturation_weight: ``w_sat`` [m].
        extra_settings: More settings that define the objective (stored with the others).
        tracker: Tracker whose parameters are tuned ("": the FBL gains, the default study).
        defaulted: Keys of ``extra_settings`` holding a default an earlier nhsim did not record (the robots'
            localiser): a study stored without them is this one (:func:`load_study`).
        recorded: Settings as an earlier nhsim recorded them where this one names a default (the cases
            named without their scenario's robot, ``robot`` None): a study stored so is this one.
    """

    cases: tuple[Case, ...]
    draws: tuple[Draw, ...] = ()
    storage: str = "sqlite:///renders/tune.db"
    study: str = "fbl"
    trials: int = 20
    sampler: str = "tpe"
    seed: int = 0
    saturation_weight: float = 0.05
    extra_settings: dict[str, Any] = field(default_factory=dict)
    tracker: str = ""
    defaulted: tuple[str, ...] = ()
    recorded: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.sampler not in SAMPLERS:
            raise ConfigError(f"unknown sampler {self.sampler!r}: choose one of {', '.join(SAMPLERS)}")
        check_number(option("trials"), self.trials, integer=True, at_least=1)

    @cached_property
    def content(self) -> dict[str, Any]:
        """What the settings name and the objective reads besides them, as digests (those of a Monte Carlo study's
        key): ``worlds`` each case's scenario as read (:func:`sim.tools.digests.world_digest`: a scenario file
        edited since is another study) and ``code`` the code and models the runs run, the robots' and the
        plugins' among them (:func:`sim.tools.digests.code_digest`). Taken once, on first use."""
        from sim.pipeline.case import load_case_scenario
        from sim.tools.digests import code_digest, world_digest

        return {"worlds": [world_digest(load_case_scenario(c)) for c in self.cases], "code": code_digest()}

    def settings(self) -> dict[str, Any]:
        """What defines the objective; stored with the study and checked on resume."""
        return {
            "cases": [c.name for c in self.cases],
            **self.content,
            "draws": [d.as_dict() for d in self.draws],
            "saturation_weight": self.saturation_weight,
            "search_space": {k: list(v) for k, v in tuned_space(self.tracker)[1].items()},
            **({"tracker": self.tracker} if self.tracker else {}),
            **self.extra_settings,
        }

    def evaluator(self) -> Evaluator:
        """An evaluator of this spec's objective."""
        return Evaluator(self.cases, self.draws, saturation_weight=self.saturation_weight, tracker=self.tracker)


def check_storage(url: str) -> None:
    """Refuse a storage that cannot keep a study: an in-memory SQLite database (``sqlite://``,
    ``sqlite:///:memory:``, ``mode=memory``) lives in one connection and dies with it, so the study's
    workers would not share it, its own second connection would not find it, and no rerun could resume it;
    and an SQLite file of another program's tables, which a study would fill with its own.
    (A URL that cannot be read is left to :func:`open_storage`, which names why.)

    Raises:
        ConfigError: An in-memory database, with a file URL to give instead, or another program's file.
    """
    database, backend = _sqlite_database(url)
    if backend == "sqlite" and database is None:
        raise ConfigError(
            f"{option('storage', url)}: an in-memory SQLite database cannot hold a study: the workers share the "
            "study and a rerun resumes it, and each connection to memory sees a database of its own that is gone "
            "when it closes; give a file URL, e.g. sqlite:///renders/tune.db"
        )
    others = _other_tables(database)
    if others:
        raise ConfigError(
            f"{option('storage', url)}: the file holds another program's tables ({', '.join(others[:5])}"
            f"{', ...' if len(others) > 5 else ''}) and no Optuna study; tuning would add its own tables beside "
            "them: give a database file of its own, e.g. sqlite:///renders/tune.db"
        )


def sqlite_file(url: str) -> Path | None:
    """The file of an SQLite URL (``sqlite:///path``), or None (another database, memory, a URL that cannot be
    read)."""
    return _sqlite_database(url)[0]


def _sqlite_database(url: str) -> tuple[Path | None, str]:
    """The file of an SQLite URL (None for memory and other databases) and the URL's backend ("" for a URL that
    cannot be read)."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        parsed = make_url(url)
    except ArgumentError:
        return None, ""
    name, backend = parsed.database, parsed.get_backend_name()
    if backend != "sqlite" or name in (None, "", ":memory:") or parsed.query.get("mode") == "memory":
        return None, backend
    return Path(name.removeprefix("file:")), backend


def _other_tables(file: Path | None) -> list[str]:
    """The tables of an existing SQLite file that holds no Optuna storage (no ``studies`` table), sorted; [] for
    none, an Optuna storage, or a file SQLite cannot read (:func:`open_storage` says why)."""
    import sqlite3

    if file is None or not file.is_file():
        return []
    try:
        with contextlib.closing(sqlite3.connect(f"{file.resolve().as_uri()}?mode=ro", uri=True)) as db:
            tables = sorted(row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'"))
    except sqlite3.Error:
        return []
    return [] if "studies" in tables else tables


def with_driver(url: str) -> str:
    """``url`` with a PostgreSQL driver that is installed: a bare ``postgresql://`` is SQLAlchemy's default
    driver, psycopg 3 from SQLAlchemy 2.1 on, psycopg2 before; where that one is missing and the other
    installed (nhsim's ``dev`` extra brings psycopg2), the installed one is named. Any other URL, or one
    naming its driver (``postgresql+psycopg2://``), is returned as given."""
    import importlib.util

    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        parsed = make_url(url)
    except ArgumentError:
        return url
    if parsed.drivername != "postgresql":
        return url
    default = parsed.get_dialect().driver  # the module SQLAlchemy would import for the bare name
    installed = [d for d in ("psycopg", "psycopg2") if importlib.util.find_spec(d) is not None]
    if default in installed or not installed:
        return url
    return parsed.set(drivername=f"postgresql+{installed[0]}").render_as_string(hide_password=False)


def shown_url(url: str) -> str:
    """``url`` as it is shown and written (messages, outputs): its password, if any, masked ``***`` by SQLAlchemy
    (``make_url(url).render_as_string(hide_password=True)``). A URL without a password, or one SQLAlchemy cannot
    read, is returned as given. The study is still opened with the URL itself."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        parsed = make_url(url)
    except ArgumentError:
        return url
    return url if parsed.password is None else parsed.render_as_string(hide_password=True)


#: The port a server listens on when its URL names none, by backend.
DEFAULT_PORTS = {"postgresql": 5432, "mysql": 3306, "mariadb": 3306, "mssql": 1433, "oracle": 1521}


#: Names of this machine's loopback interface: one server, however a URL spells it.
LOOPBACK = frozenset({"localhost", "127.0.0.1", "::1", "[::1]"})


def absolute_storage(url: str) -> str:
    """``url`` with an SQLite database file's path made absolute and normal (``sqlite:///renders/x.db`` from
    ``/home/me`` is ``sqlite:////home/me/renders/x.db``): what outputs record, so that the storage they name is the
    same file whatever folder reads them. Other URLs (and those SQLAlchemy cannot read) are returned as given."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        u = make_url(url)
    except ArgumentError:
        return url
    if u.get_backend_name() != "sqlite" or not u.database or u.database == ":memory:" or u.database.startswith("file:"):
        return url
    return u.set(database=os.path.realpath(u.database)).render_as_string(hide_password=False)


def same_storage(a: str, b: str) -> bool:
    """Whether two storage URLs (as given, or as :func:`shown_url` shows them) reach the same database: the same
    backend (whatever the driver: ``postgresql`` is ``postgresql+psycopg2``), host (``localhost``, ``127.0.0.1`` and
    ``::1`` are one), port (left out: the backend's default), database (an SQLite file by its absolute path, a
    relative one from the working folder: :func:`absolute_storage`) and user; the password and the query options
    are not compared. URLs SQLAlchemy cannot read are the same when they are equal."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    def where(url: str) -> tuple[Any, ...]:
        u = make_url(absolute_storage(url))
        backend = u.get_backend_name()
        host = "localhost" if u.host in LOOPBACK else u.host
        return backend, host, u.port or DEFAULT_PORTS.get(backend), u.database, u.username

    try:
        return a == b or where(a) == where(b)
    except ArgumentError:
        return False


class TuneFailure(NhsimError):
    """The study could not go on for a cause that is not the command's input: the connection to its storage's
    database was lost (a server stopped), or a worker process died. The study keeps its completed trials: the
    same command, rerun, resumes it."""


def lost_connection(exc: BaseException) -> str | None:
    """Why the storage's database failed under ``exc``, when it did: the first line of the database error found
    in ``exc`` or what it was raised from or while handling (SQLAlchemy's ``OperationalError`` or
    ``InterfaceError``, Optuna's ``StorageInternalError``; Optuna itself fails with an ``UnboundLocalError``
    when it cannot record a trial); None when none is there."""
    import sqlalchemy.exc
    from optuna.exceptions import StorageInternalError

    found: BaseException | None = None
    seen: set[int] = set()
    todo: list[BaseException | None] = [exc]
    while todo:
        e = todo.pop()
        if e is None or id(e) in seen:
            continue
        seen.add(id(e))
        if isinstance(e, (sqlalchemy.exc.OperationalError, sqlalchemy.exc.InterfaceError)):
            found = e.orig if isinstance(e.orig, BaseException) else e
            break
        if isinstance(e, StorageInternalError) and found is None:
            found = e
        todo += [e.__context__, e.__cause__]
    if found is None:
        return None
    lines = [line.strip() for line in str(found).splitlines() if line.strip()]
    return lines[0] if lines else type(found).__name__


def lost_storage_message(url: str, reason: str | None = None) -> str:
    """The one line saying the connection to the study's storage ``url`` (shown: :func:`shown_url`) was lost and
    that rerunning the same command resumes the study."""
    why = f" ({reason})" if reason else ""
    return (
        f"lost the connection to the study's storage {shown_url(url)}{why}; the study keeps its completed trials: "
        "once the database is reachable again, rerun the same command to resume it"
    )


def open_storage(url: str) -> Any:
    """An Optuna RDB storage with heartbeats that re-enqueues a dead trial's gains, or a clear error.

    A trial silent for ``GRACE_PERIOD`` seconds is failed by the next worker that looks (Optuna
    does at the start of every trial, :func:`settle_running` on resume) and its gains are
    enqueued again, up to ``MAX_RETRY`` times. An SQLite storage begins every transaction
    ``IMMEDIATE`` (see the module's docstring), so one state change never overwrites another.

    Raises:
        ConfigError: The URL is malformed, its driver is missing, the database cannot be opened, or it is an
            in-memory database (:func:`check_storage`).
    """
    import optuna

    check_storage(url)
    given, url = url, with_driver(url)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    sqlite = url.startswith("sqlite")
    engine_kwargs: dict[str, Any] = {}
    if sqlite:  # no implicit BEGIN from Python's sqlite3: _begin_immediate emits the BEGIN
        engine_kwargs["connect_args"] = {"timeout": 60, "isolation_level": None}
    callback = optuna.storages.RetryHeartbeatStaleTrialCallback(max_retry=MAX_RETRY)
    for attempt in range(SCHEMA_ATTEMPTS):
        try:
            storage = optuna.storages.RDBStorage(
                url,
                engine_kwargs=engine_kwargs,
                heartbeat_interval=HEARTBEAT_INTERVAL,
                grace_period=GRACE_PERIOD,
                heartbeat_stale_trial_callback=callback,
            )
            break
        except Exception as exc:  # sqlalchemy raises many kinds; all mean "cannot open"
            # Workers starting together on a new database race to create Optuna's tables (on
            # PostgreSQL the loser gets a unique violation): the next attempt finds them made.
            if attempt + 1 < SCHEMA_ATTEMPTS and _schema_race(exc):
                time.sleep(0.5 * (attempt + 1))
                continue
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ConfigError(
                f"cannot open storage {shown_url(given)!r}: {reason}. Give an SQLAlchemy URL that can be opened, e.g. "
                f"sqlite:///renders/tune.db or postgresql+psycopg2://user:pass@host/db "
                f"(psycopg2 installed: pip install psycopg2-binary; the server running)"
            ) from exc
    if sqlite:
        _begin_immediate(storage.engine)
    return storage


def _schema_race(exc: BaseException) -> bool:
    """Whether opening a storage failed because another worker was creating the same tables."""
    text = str(exc).lower()
    # PostgreSQL: "duplicate key", "UniqueViolation"; SQLite: "UNIQUE constraint failed" (alembic_version)
    return any(s in text for s in ("already exists", "duplicate key", "uniqueviolation", "unique constraint failed"))


def _begin_immediate(engine: Any) -> None:
    """Make every transaction on ``engine`` (SQLite, opened without implicit BEGIN) take the write
    lock when it begins, so the reads it makes before writing see what it overwrites (the
    SQLAlchemy recipe for SQLite transactions; other workers wait up to the connection timeout)."""
    from sqlalchemy import event

    def begin(conn: Any) -> None:
        conn.exec_driver_sql("BEGIN IMMEDIATE")

    event.listen(engine, "begin", begin)


def make_sampler(name: str, seed: int, n_existing: int, worker: int) -> Any:
    """A seeded sampler; the seed mixes ``seed``, the number of trials already in the study (or a
    trial's number, see :func:`objective_fn`) and the worker index, so a resumed or parallel worker
    does not repeat another's proposals."""
    module, attr = SAMPLERS[name].split(":")
    cls = getattr(importlib.import_module(module), attr)
    mixed = int(np.random.SeedSequence([seed, n_existing, worker]).generate_state(1)[0])
    return cls(seed=mixed)


def load_study(spec: TuneSpec, *, worker: int = 0, create: bool = False) -> Any:
    """Open (or create) the spec's study with a sampler for this worker.

    With ``create``, a study stored with other settings that holds nothing a resume would keep (its every
    trial failed: e.g. an earlier nhsim's study whose search range Optuna refused in its first trial) is
    deleted and created anew, so rerunning with the fixed settings does not find it in the way
    (:func:`_holds_nothing`). With ``create``, the worker whose creation of the study succeeds (the storage
    refuses a second study of one name, so one worker does, whichever the database) enqueues the default gains
    and then stores the settings; a worker that finds the study made waits for its settings, so it
    never sees a new study without its default trial (:func:`ensure_default_trial`).

    Raises:
        ConfigError: The storage cannot be opened, or the study exists with other settings.
    """
    import optuna

    storage = open_storage(spec.storage)
    settings = json.loads(json.dumps(spec.settings()))
    try:
        if create:
            try:
                study = optuna.create_study(storage=storage, study_name=spec.study, direction="minimize")
            except optuna.exceptions.DuplicatedStudyError:
                study = optuna.load_study(storage=storage, study_name=spec.study)
            else:
                ensure_default_trial(study, spec.tracker)
                study.set_user_attr("settings", settings)
        else:
            study = optuna.load_study(storage=storage, study_name=spec.study)
    except ConfigError:
        raise
    except Exception as exc:
        raise ConfigError(f"cannot open study {spec.study!r} in {shown_url(spec.storage)!r}: {exc}") from exc
    stored = _stored_settings(study, wait=SETTINGS_WAIT_S if create else 0.0)
    if stored is None:
        if not create:
            raise ConfigError(
                f"study {spec.study!r} in {shown_url(spec.storage)!r} has no settings; create it with nhsim tune"
            )
        study.set_user_attr("settings", settings)  # a study left without settings by an older version
    elif stored != settings and stored in _earlier_settings(spec, settings):  # the defaults now recorded
        study.set_user_attr("settings", settings)
    elif stored != settings and create and _holds_nothing(study):  # never usable: made anew, with these settings
        with contextlib.suppress(KeyError):  # another worker replaced it first
            optuna.delete_study(study_name=spec.study, storage=storage)
        return load_study(spec, worker=worker, create=True)
    elif stored != settings:
        raise ConfigError(_other_settings(spec, stored, settings))
    study.sampler = make_sampler(spec.sampler, spec.seed, len(study.trials), worker)
    return study


def _other_settings(spec: TuneSpec, stored: dict[str, Any], settings: dict[str, Any]) -> str:
    """Why a study stored with ``stored`` settings is not resumed with ``settings``: the settings that differ and
    what sets each (:data:`SETTING_OPTIONS`), a case whose scenario was edited by its name, and the fix."""
    diff = sorted(k for k in set(stored) | set(settings) if stored.get(k) != settings.get(k))
    diff = [k for k in diff if not (k == "worlds" and "cases" in diff)]  # other cases: other scenarios
    said = []
    for k in diff:
        if k not in stored and k not in UNSTORED_DEFAULTS:
            said.append(f"{k} (not recorded by the nhsim that made the study)")
        elif k == "worlds" and len(stored[k]) == len(spec.cases):
            edited = [c.token for c, a, b in zip(spec.cases, stored[k], settings[k], strict=True) if a != b]
            said.append(f"worlds (the scenario of {', '.join(edited)}: its file was edited since the study was made)")
        else:
            values = _values_differ(stored.get(k, UNSTORED_DEFAULTS.get(k)), settings.get(k, UNSTORED_DEFAULTS.get(k)))
            said.append(f"{k}{values} (set by {SETTING_OPTIONS[k]})" if k in SETTING_OPTIONS else f"{k}{values}")
    files = " and scenario files (as they were)" if "worlds" in diff else ""
    if set(diff) - set(stored) - set(UNSTORED_DEFAULTS):  # a study an older nhsim made: what it did not record
        fix = f"this nhsim cannot resume it: choose another study name, {option('study')}"
    else:
        fix = f"rerun with the same options{files} to resume it, or choose another study name, {option('study')}"
    return (
        f"study {spec.study!r} in {shown_url(spec.storage)!r} was created with other settings: {', '.join(said)} "
        f"differ; {fix}"
    )


#: Settings a study stores only when they are not their default (:meth:`TuneSpec.settings`), and how a refused
#: resume names the default.
UNSTORED_DEFAULTS = {"tracker": "the default (each case's tracker's FBL gains)"}


def _values_differ(there: Any, here: Any) -> str:
    """``": A there, B here"`` for a setting's two values when they are short to say: numbers, names, the names
    on one side only of two lists of names (the cases'), or lists of other lengths (their lengths: the draws); ""
    when only the name says it (the draws' seeds, digests)."""
    if isinstance(there, list) and isinstance(here, list):
        if all(isinstance(v, str) for v in there + here):  # names (the cases'): those on one side only
            gone, new = [v for v in there if v not in here], [v for v in here if v not in there]
            text = f": {', '.join(gone) or 'none'} there, {', '.join(new) or 'none'} here"
            return text if len(text) <= 160 else ""
        if len(there) == len(here):
            return ""
        there, here = len(there), len(here)
    if isinstance(there, (list, dict)) or isinstance(here, (list, dict)):
        return ""
    text = f": {there} there, {here} here"
    return text if len(text) <= 80 else ""


#: The options that set each of a study's stored settings (:meth:`TuneSpec.settings`), as a refused resume
#: names them: the user changed an option, not "draws".
SETTING_OPTIONS = {
    "cases": "--scenarios, --robot, --seed and the case options",
    "draws": "--draws, --seed, --perturb-range",
    "saturation_weight": "--saturation-weight",
    "search_space": "the tracker's search space, in this nhsim version",
    "tracker": "--tracker",
    "robust": "--robust",
    "control_rate": "--control-rate",
    "robot": "--robot",
    "localiser": "--localiser",
    "worlds": "the content of the cases' scenario files",
    "code": "nhsim's code and models, the robots' and the plugins' among them: another nhsim version or an edited file",
}


def _holds_nothing(study: Any) -> bool:
    """Whether a study holds trials and every one failed: none completed (nothing to resume), none running
    or waiting (no worker at work in it; a new study holds its waiting default trial)."""
    from optuna.trial import TrialState

    trials = study.get_trials(deepcopy=False)
    return bool(trials) and all(t.state == TrialState.FAIL for t in trials)


def _earlier_settings(spec: TuneSpec, settings: dict[str, Any]) -> list[dict[str, Any]]:
    """The settings an earlier nhsim stored for the spec's study: without the ``defaulted`` keys, with the
    ``recorded`` values, or both."""
    forms = [settings, json.loads(json.dumps(settings | spec.recorded))]
    return forms + [{k: v for k, v in form.items() if k not in spec.defaulted} for form in forms]


def _stored_settings(study: Any, wait: float) -> Any:
    """The study's stored settings, waiting up to ``wait`` seconds for the worker creating it."""
    deadline = time.monotonic() + wait
    while (stored := study.user_attrs.get("settings")) is None and time.monotonic() < deadline:
        time.sleep(0.1)
    return stored


def robot_localiser(case: Case, scenario: Scenario | None = None) -> str:
    """The localiser the case's robot runs on when the case names none: amcl for a robot with a laser
    scanner, fixes otherwise (:meth:`~sim.pipeline.case.Case.localiser_setup`).

    Args:
        case: The case.
        scenario: Its scenario with its robot; None: loaded (:func:`sim.pipeline.case.load_case_scenario`).

    Raises:
        ScenarioError, ConfigError: The case's own errors (its scenario, its localiser settings).
    """
    from sim.pipeline.case import load_case_scenario

    scenario = load_case_scenario(case) if scenario is None else scenario
    kind = case.localiser_setup(scenario).kind  # the case as given checked first: its errors are named
    return kind if case.localiser is None else replace(case, localiser=None).localiser_setup(scenario).kind


def default_params(tracker: str = "") -> dict[str, float]:
    """The tracker's default gains (or tuned parameters) as study parameters."""
    cls, space = tuned_space(tracker)
    default = cls()
    return {k: getattr(default, k) for k in space}


def ensure_default_trial(study: Any, tracker: str = "") -> None:
    """Enqueue the default gains unless a completed, running or waiting trial already holds them."""
    from optuna.trial import TrialState

    params = default_params(tracker)
    held = (TrialState.COMPLETE, TrialState.RUNNING, TrialState.WAITING)
    for t in study.get_trials(deepcopy=False, states=held):
        p = t.system_attrs.get("fixed_params", t.params)
        if p == params:
            return
    study.enqueue_trial(params, user_attrs={"default_gains": True})


def settle_running(study: Any, poll: float = 0.2) -> tuple[list[int], list[int]]:
    """Wait until each trial running when called has finished, been failed as dead, or proven alive.

    A trial killed with its worker stops beating; once it has been silent for ``GRACE_PERIOD``
    seconds it is failed and its gains enqueued again (:func:`open_storage`). This waits for
    that instead of leaving the trial running (and its gains never evaluated) when a killed study
    is resumed at once: it returns as soon as no such trial is left running, and at the latest
    after ``GRACE_PERIOD`` + ``HEARTBEAT_INTERVAL`` + 1 s (the storage's clock counts whole
    seconds), when a trial still running has beaten within the grace period: a live worker's.

    Args:
        study: The study (on a storage from :func:`open_storage`).
        poll: Time between looks [s].

    Returns:
        (numbers of those trials that ended failed, numbers of those still running: live workers').
    """
    from optuna.storages import fail_stale_trials
    from optuna.trial import TrialState

    def states() -> dict[int, Any]:
        return {t.number: t.state for t in study.get_trials(deepcopy=False) if t.number in running}

    running = {t.number for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))}
    beat_unbeaten(study, running)
    deadline = time.monotonic() + GRACE_PERIOD + HEARTBEAT_INTERVAL + 1.0
    while True:
        fail_stale_trials(study)
        now = states()
        left = sorted(n for n, state in now.items() if state == TrialState.RUNNING)
        if not left or time.monotonic() > deadline:
            return sorted(n for n, state in now.items() if state == TrialState.FAIL), left
        time.sleep(poll)


def beat_unbeaten(study: Any, numbers: set[int]) -> None:
    """Give a heartbeat to each of the running trials ``numbers`` that has none.

    A worker lost between starting a trial and its first beat (its connection to the storage lost, or it was
    killed) leaves the trial running without a heartbeat, and Optuna fails only a trial whose beat is old
    (``fail_stale_trials`` skips one that never beat): it stayed running for ever, counted as a live worker's,
    and a resumed study ended with one trial fewer than asked, saying nothing. Beaten now, it is failed after the
    grace period as any silent trial is (a live worker's trial that has not beaten yet beats itself within its
    interval). Optuna keeps the beats in its RDB storage's own table; a storage without it is left as it is."""
    storage = getattr(study._storage, "_backend", study._storage)  # the RDB storage behind Optuna's cache
    try:
        from optuna.storages._rdb import models
        from optuna.storages._rdb.storage import _create_scoped_session
    except ImportError:  # pragma: no cover - another Optuna layout: the trial stays as Optuna leaves it
        return
    ids = {t._trial_id for t in study.get_trials(deepcopy=False) if t.number in numbers}
    if not ids or not hasattr(storage, "scoped_session"):
        return
    with _create_scoped_session(storage.scoped_session) as session:
        beaten = session.query(models.TrialHeartbeatModel.trial_id).filter(models.TrialHeartbeatModel.trial_id.in_(ids))
        unbeaten = ids - {trial_id for (trial_id,) in beaten}
    for trial_id in sorted(unbeaten):
        storage.record_heartbeat(trial_id)


def retried_trials(study: Any) -> set[int]:
    """Numbers of the trials whose gains another trial runs again: a killed worker's (failed by its
    silence and enqueued again by :func:`open_storage`'s callback) or an interrupted one's
    (:func:`requeue_interrupted`). Optuna's retry records the trial it repeats last in ``retry_history``."""
    history = (t.system_attrs.get("retry_history") for t in study.get_trials(deepcopy=False))
    return {int(h[-1]) for h in history if h}


def sampling_number(study: Any, number: int) -> int:
    """The number trial ``number`` would have in a study never interrupted nor killed: its number less the
    retried trials before it (:func:`retried_trials`), each of which added a trial (its retry) to the
    study. It seeds the trial's proposals (:func:`objective_fn`), so a study interrupted and resumed
    proposes the same gains as one run at once."""
    return number - sum(n < number for n in retried_trials(study))


def requeue_interrupted(study: Any) -> list[int]:
    """Enqueue again the gains of each trial an interrupt stopped (Ctrl-C or SIGTERM in its evaluation:
    failed, with user attribute :data:`INTERRUPTED`) that no trial runs again yet, as the heartbeat's
    callback does for a killed worker's trial (:func:`open_storage`): the retry names the trial it
    repeats, so each is enqueued once. Returns the numbers of the trials enqueued again."""
    import copy

    import optuna
    from optuna.trial import TrialState

    retried = retried_trials(study)
    stopped = [
        t
        for t in study.get_trials(deepcopy=False, states=(TrialState.FAIL,))
        if t.user_attrs.get(INTERRUPTED) and t.number not in retried
    ]
    retry = optuna.storages.RetryHeartbeatStaleTrialCallback()  # no limit: an interrupt is no fault of the gains
    for t in stopped:
        again = copy.deepcopy(t)
        again.user_attrs = {k: v for k, v in t.user_attrs.items() if k != INTERRUPTED}
        retry(study, again)
    return [t.number for t in stopped]


def samplers_of(trials: Sequence[Any]) -> dict[str, int]:
    """How many of ``trials`` each sampler proposed (their :data:`SAMPLER` attribute), in the order the samplers
    were first used; a study resumed with another ``--sampler`` holds trials of each. The default gains' trial
    (given, proposed by none) is left out; a trial an nhsim that did not record its sampler proposed counts as
    :data:`UNRECORDED`."""
    counts: dict[str, int] = {}
    for t in sorted(trials, key=lambda t: t.number):
        if not t.user_attrs.get("default_gains"):
            name = str(t.user_attrs.get(SAMPLER, UNRECORDED))
            counts[name] = counts.get(name, 0) + 1
    return counts


def completed(study: Any) -> list[Any]:
    """The study's completed trials."""
    from optuna.trial import TrialState

    return list(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)))


def objective_fn(evaluator: Evaluator, spec: TuneSpec | None = None) -> Any:
    """The Optuna objective: suggest gains, evaluate, record the parts as user attributes.

    With ``spec``, each trial's proposals are drawn by a sampler seeded from the study's seed and the
    trial's number, which the storage hands out once per study: workers in other processes or on
    other machines (each its own ``nhsim tune``, with the same seed) never propose the same gains,
    and one worker alone proposes the same sequence every time.
    """

    def objective(trial: Any) -> float:
        if spec is not None:
            _claim(trial, spec.trials)
            trial.study.sampler = make_sampler(spec.sampler, spec.seed, sampling_number(trial.study, trial.number), 0)
        space = tuned_space(evaluator.tracker)[1]
        values = {k: trial.suggest_float(k, lo, hi, log=True) for k, (lo, hi) in space.items()}
        if spec is not None and not {SAMPLER, "default_gains"} & set(trial.user_attrs):  # proposed here, not given
            trial.set_user_attr(SAMPLER, spec.sampler)  # a retry keeps the attributes of the trial it repeats
        # Within run_worker's held block an interrupt acts in the evaluation only (where the time goes), not
        # in the trial's storage calls around it: one raised inside SQLAlchemy's transaction left the
        # database locked, and Optuna's record of the failed trial then waited out the lock's timeout and
        # failed ("database is locked", then "Should not reach"). Outside a held block this runs as it is.
        try:
            with signals_released():
                ev = evaluator.evaluate(make_params(evaluator.tracker, values))
        except KeyboardInterrupt:  # Optuna fails the trial; a resumed study runs its gains again
            trial.set_user_attr(INTERRUPTED, True)
            raise
        for k, v in ev.as_dict().items():
            trial.set_user_attr(k, v)
        return ev.objective

    return objective


def _claim(trial: Any, wanted: int) -> None:
    """Prune ``trial`` before it runs when the trials completed and those running ahead of it (lower
    numbers: the storage numbers trials once, in the order workers take them) already make the
    ``wanted`` count, and stop this worker: workers that each finish the trial they took would
    otherwise end the study with more completed trials than asked for."""
    import optuna
    from optuna.trial import TrialState

    ahead = 0
    for t in trial.study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.RUNNING)):
        ahead += t.state == TrialState.COMPLETE or t.number < trial.number
    if ahead >= wanted:
        trial.study.stop()
        raise optuna.TrialPruned(f"the study holds or is running its {wanted} trials")


def run_worker(spec: TuneSpec, n_trials: int, worker: int = 0, callbacks: Sequence[Any] = ()) -> int:
    """Run up to ``n_trials`` trials of the spec's study (stops once the study holds
    ``spec.trials`` completed trials). Returns the number of trials this worker ran.

    Args:
        spec: The study and objective.
        n_trials: Most trials to run here.
        worker: Worker index (mixed into the sampler seed).
        callbacks: Extra Optuna callbacks ``f(study, trial)`` (progress).
    """
    import optuna
    from optuna.study import MaxTrialsCallback
    from optuna.trial import TrialState

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = load_study(spec, worker=worker)
    evaluator = spec.evaluator()
    before = len(study.trials)
    if n_trials > 0:
        stop = MaxTrialsCallback(spec.trials, states=(TrialState.COMPLETE,))
        objective = objective_fn(evaluator, spec)  # signals released in each trial's evaluation

        def between(study: Any, trial: Any) -> None:  # a trial recorded: act on a signal held meanwhile
            with signals_released():
                pass

        # an interrupt acts inside a trial's evaluation (Optuna records the trial as failed and stops) or
        # between trials, never inside Optuna's own bookkeeping around them nor in the trial's storage
        # calls (see planning.signals)
        with signals_held():
            study.optimize(objective, n_trials=n_trials, callbacks=[stop, *callbacks, between])
    return len(study.trials) - before


def gains_of(trial: Any, tracker: str = "") -> Any:
    """The gains (or the tracker's parameters) a trial evaluated."""
    return make_params(tracker, {k: float(trial.params[k]) for k in tuned_space(tracker)[1]})


def default_trial(study: Any, tracker: str = "") -> Any | None:
    """The completed trial of the default gains, if any."""
    params = default_params(tracker)
    for t in completed(study):
        if {k: t.params.get(k) for k in params} == params:
            return t
    return None


def worker_process(spec: TuneSpec, n_trials: int, worker: int, retries: int = 5) -> None:
    """Entry point of a worker process (``--jobs``): its own storage connection and sampler.

    It loads the tracker plugins first (:func:`control.base.load_plugins`: the same entry points and
    ``NHSIM_PLUGINS`` modules as the command that started it), so it knows the trackers they register.
    A storage error (SQLite refuses one of two concurrent writers outright rather than wait) is
    retried up to ``retries`` times with the trials this worker has not finished yet.
    """
    import sqlalchemy.exc
    from optuna.exceptions import StorageInternalError

    from control.base import load_plugins

    load_plugins()

    finished = [0]

    def count(study: Any, trial: Any) -> None:
        finished[0] += 1

    for attempt in range(retries + 1):
        try:
            run_worker(spec, n_trials - finished[0], worker, callbacks=[count])
            return
        except (StorageInternalError, sqlalchemy.exc.OperationalError):
            if attempt == retries:
                raise
            time.sleep(0.5 * (attempt + 1))


def split_trials(remaining: int, jobs: int) -> list[int]:
    """Trials per worker: ``remaining`` split as evenly as possible over ``jobs`` (no zeros)."""
    jobs = max(1, min(jobs, remaining))
    return [remaining // jobs + (1 if i < remaining % jobs else 0) for i in range(jobs)] if remaining > 0 else []


@dataclass(frozen=True)
class Comparison:
    """Tuned against default gains on the same held-out draws.

    Attributes:
        default: The default gains' evaluation.
        tuned: The tuned gains' evaluation.
        draws: The held-out draws (each case ran on each).
        cases: Names of the cases, in the order of the evaluations' per-run costs.
        defaults_best: The tuned gains are the defaults (no trial beat them): one evaluation stands for both.
    """

    default: Evaluation
    tuned: Evaluation
    draws: tuple[Draw, ...]
    cases: tuple[str, ...]
    defaults_best: bool = False

    def ratios(self) -> dict[str, float]:
        """Tuned / default of the objective, RMS, final error and saturation (nan for 0 / 0)."""
        pairs = {
            "objective": (self.tuned.objective, self.default.objective),
            "rms": (self.tuned.rms_m, self.default.rms_m),
            "final": (self.tuned.final_m, self.default.final_m),
            "saturation": (self.tuned.saturation, self.default.saturation),
        }
        return {k: _ratio(t, d) for k, (t, d) in pairs.items()}

    def paired_difference(self) -> tuple[float, float]:
        """Mean and standard error of the per-run difference tuned - default of J [m] (the runs
        pair up: same case, same draw); the standard error is nan with one run (nothing measures the spread)."""
        diff = np.asarray(self.tuned.costs) - np.asarray(self.default.costs)
        sem = float(diff.std(ddof=1) / math.sqrt(diff.size)) if diff.size > 1 else math.nan
        return float(diff.mean()), sem

    @property
    def better(self) -> str:
        """ "tuned", "default", or "neither" (equal held-out objectives)."""
        if self.tuned.objective < self.default.objective:
            return "tuned"
        return "default" if self.tuned.objective > self.default.objective else "neither"

    def verdict(self) -> str:
        """Which gains are better on the held-out robots and by how much, in words."""
        ratio = self.ratios()["objective"]
        mean, sem = self.paired_difference()
        runs = f"{self.tuned.runs} run{'' if self.tuned.runs == 1 else 's'}"
        if self.defaults_best:
            return f"the defaults were best: no trial beat them; held-out robots ran them alone ({runs})"
        if self.better == "neither":
            return f"tuned and default gains score the same on held-out robots ({runs})"
        said = f"{self.better} gains are better on held-out robots: objective {ratio:.2f}x default; "
        if math.isnan(sem):
            return (
                said + f"per-run difference {mean * 1e3:+.3f} mm (one run: no standard error, not a clear difference)"
            )
        spread = f"per-run difference {mean * 1e3:+.3f} ± {sem * 1e3:.3f} mm (mean ± standard error, {runs})"
        return (
            said
            + spread
            + ("" if abs(mean) > 2.0 * sem else ", within twice its standard error: not a clear difference")
        )

    def as_dict(self) -> dict[str, Any]:
        """Record view: both evaluations, ratios, verdict, and every run's draw and costs."""
        mean, sem = self.paired_difference()
        keys = [(case, draw) for case in self.cases for draw in self.draws]
        per_run = [
            {"case": case, **draw.as_dict(), "default": d, "tuned": t}
            for (case, draw), d, t in zip(keys, self.default.costs, self.tuned.costs, strict=True)
        ]
        return {
            "default": self.default.as_dict(),
            "tuned": self.tuned.as_dict(),
            "ratios": self.ratios(),
            "better": self.better,
            "verdict": self.verdict(),
            "difference_m": {"mean": mean, "standard_error": None if math.isnan(sem) else sem},
            "runs": per_run,
        }


def _ratio(num: float, den: float) -> float:
    return num / den if den != 0 else (float("nan") if num == 0 else math.copysign(math.inf, num))


def compare(evaluator: Evaluator, tuned: Any, draws: Sequence[Draw]) -> Comparison:
    """Run the default and the tuned gains on the evaluator's cases over held-out ``draws``; when the
    tuned gains are the defaults (no trial beat them) they run once and stand for both.

    Raises:
        ConfigError: No draws.
    """
    if not draws:
        raise ConfigError(
            "no held-out draws to compare on; give at least one: "
            + option("eval-runs", 1, python="draws=make_draws(1, seed, held_out=True)")
        )
    held_out = evaluator.with_draws(draws)
    default = held_out.evaluate(tuned_space(evaluator.tracker)[0]())
    same = tuned == tuned_space(evaluator.tracker)[0]()
    return Comparison(
        default,
        default if same else held_out.evaluate(tuned),
        tuple(draws),
        tuple(c.name for c in evaluator.cases),
        defaults_best=same,
    )
