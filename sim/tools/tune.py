"""Tuning the FBL tracker's gains with Optuna over a set of cases.

Objective of a gain set (lower is better), averaged over every case and perturbation:

    J = rms_position_error + final_position_error + w_sat * saturation_fraction   [m]

plus ``FAILURE_COST`` for a run that touched an obstacle, made MuJoCo warn or produced a
non-finite command. ``w_sat`` (default 0.05 m) prices a command sitting on the speed or yaw-rate
limit: saturating all the time costs as much as 5 cm of error.

Search space (log-uniform): Kp in [0.5, 100] 1/s^2, Kd in [0.5, 40] 1/s, xi_min in
[0.002, 0.2] m/s -- the whole parameter set the tracker exposes (:class:`FBLGains`).

The study lives in an SQLAlchemy storage; its settings (cases, perturbations, weights) are
stored with it, and a rerun with the same settings resumes it: completed trials count toward the
requested number, trials left running by a killed worker are marked failed by the heartbeat and
their gains are evaluated afresh by later trials, the default gains are evaluated once (as the
first trial) so every study holds an honest "no worse than the defaults" comparison.
"""

from __future__ import annotations

import importlib
import json
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from control.fbl import FBLGains
from planning.errors import ConfigError, NhsimError

if TYPE_CHECKING:  # the command line reads SAMPLERS while building its parser, before mujoco may load
    from sim.physics.perturb import Perturbation
    from sim.pipeline.case import Case
    from sim.pipeline.simulate import PreparedCase

#: Name -> (low, high) of each tuned parameter, sampled log-uniformly.
SEARCH_SPACE: dict[str, tuple[float, float]] = {"kp": (0.5, 100.0), "kd": (0.5, 40.0), "xi_min": (0.002, 0.2)}
#: Cost added for a failed run (collision, MuJoCo warning, non-finite command) [m].
FAILURE_COST = 1.0
#: Sampler name -> "module:class"; each takes ``seed=``.
SAMPLERS: dict[str, str] = {"tpe": "optuna.samplers:TPESampler", "random": "optuna.samplers:RandomSampler"}
#: Heartbeat of running trials [s] and the silence after which a trial is declared dead [s].
HEARTBEAT_INTERVAL = 2
GRACE_PERIOD = 10


@dataclass(frozen=True)
class Evaluation:
    """A gain set's score over cases × perturbations.

    Attributes:
        objective: Mean J [m].
        rms_m: Mean RMS position error [m].
        final_m: Mean final position error [m].
        saturation: Mean saturation fraction.
        failures: Number of failed runs.
        runs: Number of runs.
    """

    objective: float
    rms_m: float
    final_m: float
    saturation: float
    failures: int
    runs: int

    def as_dict(self) -> dict[str, float | int]:
        """Plain-dict view."""
        return asdict(self)


class Evaluator:
    """Scores gain sets on a fixed set of cases and perturbations (common random numbers: every
    gain set meets the same perturbations).

    Args:
        cases: The cases (built lazily, once).
        perturbations: Perturbations each case is run under; empty or None -> the nominal run.
        saturation_weight: ``w_sat`` [m].
    """

    def __init__(
        self,
        cases: Sequence[Case],
        perturbations: Sequence[Perturbation] | None = None,
        *,
        saturation_weight: float = 0.05,
    ) -> None:
        if not cases:
            raise ConfigError("no cases to tune on; give --scenarios, e.g. open:figure8,open:circle")
        if not (math.isfinite(saturation_weight) and saturation_weight >= 0):
            raise ConfigError(f"saturation weight must be >= 0, got {saturation_weight}")
        self.cases = tuple(cases)
        self.perturbations: tuple[Perturbation | None, ...] = tuple(perturbations) if perturbations else (None,)
        self.saturation_weight = float(saturation_weight)
        self._prepared: list[PreparedCase] | None = None

    def prepared(self) -> list[PreparedCase]:
        """The prepared cases (raises the cases' errors on first use)."""
        if self._prepared is None:
            from sim.pipeline.simulate import prepare_case

            self._prepared = [prepare_case(c) for c in self.cases]
        return self._prepared

    def with_perturbations(self, perturbations: Sequence[Perturbation]) -> Evaluator:
        """The same cases (shared, not rebuilt) under other perturbations."""
        other = Evaluator(self.cases, perturbations, saturation_weight=self.saturation_weight)
        other._prepared = self._prepared
        return other

    def evaluate(self, gains: FBLGains) -> Evaluation:
        """Run every case under every perturbation with ``gains`` and average."""
        costs, rms, final, sat, failures = [], [], [], [], 0
        for pc in self.prepared():
            for pert in self.perturbations:
                try:
                    m = pc.run(gains, pert).metrics
                except NhsimError:
                    failures += 1
                    costs.append(FAILURE_COST)
                    continue
                sat_cost = self.saturation_weight * m.saturation_fraction
                cost = m.rms_position_error_m + m.final_position_error_m + sat_cost
                failed = m.collisions > 0 or m.warnings > 0 or not math.isfinite(cost)
                failures += int(failed)
                costs.append((cost if math.isfinite(cost) else 0.0) + (FAILURE_COST if failed else 0.0))
                rms.append(m.rms_position_error_m)
                final.append(m.final_position_error_m)
                sat.append(m.saturation_fraction)
        return Evaluation(float(np.mean(costs)), _mean(rms), _mean(final), _mean(sat), failures, len(costs))


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else float("nan")


@dataclass(frozen=True)
class TuneSpec:
    """Everything a tuning worker needs (picklable, for worker processes).

    Attributes:
        cases: Cases tuned on.
        perturbations: Perturbations of a robust study (empty: nominal).
        storage: SQLAlchemy URL.
        study: Study name.
        trials: Completed trials wanted in the study.
        sampler: Key of ``SAMPLERS``.
        seed: Seed of the sampler (mixed with the trial count and the worker index).
        saturation_weight: ``w_sat`` [m].
    """

    cases: tuple[Case, ...]
    perturbations: tuple[Perturbation, ...] = ()
    storage: str = "sqlite:///renders/tune.db"
    study: str = "fbl"
    trials: int = 20
    sampler: str = "tpe"
    seed: int = 0
    saturation_weight: float = 0.05
    extra_settings: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.sampler not in SAMPLERS:
            raise ConfigError(f"unknown sampler {self.sampler!r}: choose one of {', '.join(SAMPLERS)}")
        if self.trials < 1:
            raise ConfigError(f"--trials must be >= 1, got {self.trials}")

    def settings(self) -> dict[str, Any]:
        """What defines the objective; stored with the study and checked on resume."""
        return {
            "cases": [c.name for c in self.cases],
            "perturbations": [p.as_dict() for p in self.perturbations],
            "saturation_weight": self.saturation_weight,
            "search_space": {k: list(v) for k, v in SEARCH_SPACE.items()},
            **self.extra_settings,
        }

    def evaluator(self) -> Evaluator:
        """An evaluator of this spec's objective."""
        return Evaluator(self.cases, self.perturbations, saturation_weight=self.saturation_weight)


def open_storage(url: str) -> Any:
    """An Optuna RDB storage with heartbeats, or a clear error.

    Raises:
        ConfigError: The URL is malformed, its driver is missing, or the database cannot be opened.
    """
    import optuna

    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    engine_kwargs: dict[str, Any] = {}
    if url.startswith("sqlite"):
        engine_kwargs["connect_args"] = {"timeout": 60}
    try:
        return optuna.storages.RDBStorage(
            url, engine_kwargs=engine_kwargs, heartbeat_interval=HEARTBEAT_INTERVAL, grace_period=GRACE_PERIOD
        )
    except Exception as exc:  # sqlalchemy raises many kinds; all mean "cannot open"
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ConfigError(
            f"cannot open storage {url!r}: {reason}. Give an SQLAlchemy URL that can be opened, e.g. "
            f"sqlite:///renders/tune.db (its directory must exist) or postgresql://user:pass@host/db "
            f"(with its driver installed and the server running)"
        ) from exc


def make_sampler(name: str, seed: int, n_existing: int, worker: int) -> Any:
    """A seeded sampler; the seed mixes ``seed``, the number of trials already in the study and the
    worker index, so a resumed or parallel worker does not repeat another's proposals."""
    module, attr = SAMPLERS[name].split(":")
    cls = getattr(importlib.import_module(module), attr)
    mixed = int(np.random.SeedSequence([seed, n_existing, worker]).generate_state(1)[0])
    return cls(seed=mixed)


def load_study(spec: TuneSpec, *, worker: int = 0, create: bool = False) -> Any:
    """Open (or create) the spec's study with a sampler for this worker.

    Raises:
        ConfigError: The storage cannot be opened, or the study exists with other settings.
    """
    import optuna

    storage = open_storage(spec.storage)
    try:
        study = optuna.create_study(storage=storage, study_name=spec.study, direction="minimize", load_if_exists=True)
    except Exception as exc:
        raise ConfigError(f"cannot open study {spec.study!r} in {spec.storage!r}: {exc}") from exc
    settings = json.loads(json.dumps(spec.settings()))
    stored = study.user_attrs.get("settings")
    if stored is None:
        if not create:
            raise ConfigError(f"study {spec.study!r} in {spec.storage!r} has no settings; create it with nhsim tune")
        study.set_user_attr("settings", settings)
    elif stored != settings:
        diff = sorted(k for k in set(stored) | set(settings) if stored.get(k) != settings.get(k))
        raise ConfigError(
            f"study {spec.study!r} in {spec.storage!r} was created with other settings ({', '.join(diff)} differ); "
            f"rerun with the same options to resume it, or choose another --study name"
        )
    study.sampler = make_sampler(spec.sampler, spec.seed, len(study.trials), worker)
    return study


def default_params() -> dict[str, float]:
    """The tracker's default gains as study parameters."""
    g = FBLGains()
    return {"kp": g.kp, "kd": g.kd, "xi_min": g.xi_min}


def ensure_default_trial(study: Any) -> None:
    """Enqueue the default gains unless a completed or waiting trial already holds them."""
    from optuna.trial import TrialState

    params = default_params()
    for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.WAITING)):
        p = t.system_attrs.get("fixed_params", t.params)
        if p == params:
            return
    study.enqueue_trial(params, user_attrs={"default_gains": True})


def completed(study: Any) -> list[Any]:
    """The study's completed trials."""
    from optuna.trial import TrialState

    return list(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)))


def objective_fn(evaluator: Evaluator) -> Any:
    """The Optuna objective: suggest gains, evaluate, record the parts as user attributes."""

    def objective(trial: Any) -> float:
        values = {k: trial.suggest_float(k, lo, hi, log=True) for k, (lo, hi) in SEARCH_SPACE.items()}
        ev = evaluator.evaluate(FBLGains(**values))
        for k, v in ev.as_dict().items():
            trial.set_user_attr(k, v)
        return ev.objective

    return objective


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
        study.optimize(objective_fn(evaluator), n_trials=n_trials, callbacks=[stop, *callbacks])
    return len(study.trials) - before


def gains_of(trial: Any) -> FBLGains:
    """The gains a trial evaluated."""
    return FBLGains(**{k: float(trial.params[k]) for k in SEARCH_SPACE})


def default_trial(study: Any) -> Any | None:
    """The completed trial of the default gains, if any."""
    params = default_params()
    for t in completed(study):
        if {k: t.params.get(k) for k in params} == params:
            return t
    return None


def worker_process(spec: TuneSpec, n_trials: int, worker: int, retries: int = 5) -> None:
    """Entry point of a worker process (``--jobs``): its own storage connection and sampler.

    A storage error (SQLite refuses one of two concurrent writers outright rather than wait) is
    retried up to ``retries`` times with the trials this worker has not finished yet.
    """
    import sqlalchemy.exc
    from optuna.exceptions import StorageInternalError

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
