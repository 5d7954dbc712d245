r"""Trackers side by side: the same trajectory, the same as-built robots and noise, one run each.

:func:`compare_trackers` prepares a case's trajectory once (a planned case plans once) and runs each
tracker on it in the real robot's loop (:attr:`sim.pipeline.runs.RunKind.CLOSED_LOOP`: as-built
robot, sensors, fused estimate); a player without feedback (``open-loop``) as the open loop
(:attr:`~sim.pipeline.runs.RunKind.OPEN_LOOP`: no estimator, whose divergence would end a run it never
reads). With ``runs = 1`` every tracker drives the case's own robot and
noise; with ``runs = N`` each tracker drives the same N held-out draws of robot and noise
(:func:`sim.tools.tune.make_draws` with ``held_out=True``, from the case's seed): never the draws
a tuning study trains on, so tuned parameters are judged on robots they have not seen.

Per run: the final, RMS and max position error [m], the final and RMS heading error [rad], the
effort :math:`\int (\dot v^2 + \dot\omega^2)\,dt` of the commands (finite differences over control
periods) [m^2/s^3 + rad^2/s^3], the saturation fraction, the control time per step (wall clock of
the tracker's ``command``, its mean and 95th percentile, and the 95th percentile of its thread's CPU
time) [ms] and the collisions; MPC's solver statistics (failures, overruns).
:class:`Comparison` averages them per tracker.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from control.base import TRACKERS, Tracker, make_tracker, tracker_options, tuned_option
from control.fbl import uses_fbl_gains
from control.gains import FBLGains, check_sampled_stability
from planning.core.checks import check_number
from planning.core.documents import GivenTwice, load_json
from planning.core.files import read_input
from planning.core.robot import RobotSpec
from planning.errors import ConfigError, SimulationError, option
from planning.scenario import Scenario
from planning.trajectory.trajectory import Trajectory
from sim.physics.metrics import heading_errors
from sim.physics.runlog import RunLog
from sim.physics.simulator import SimConfig
from sim.pipeline.case import Case, PreparedTrajectory, prepare_trajectory
from sim.pipeline.runs import RunKind
from sim.pipeline.simulate import PreparedCase, plain_params, run_tracker, simulator_for, tracker_params
from sim.tools.tune import Draw, make_draws

#: Per-run quantities of a comparison, in table order: key -> (column title, format).
COLUMNS: dict[str, tuple[str, str]] = {
    "final_m": ("final [m]", "{:.4f}"),
    "rms_m": ("RMS [m]", "{:.4f}"),
    "max_m": ("max [m]", "{:.4f}"),
    "final_heading_rad": ("hdg end [rad]", "{:.4f}"),
    "rms_heading_rad": ("hdg RMS [rad]", "{:.4f}"),
    "effort": ("effort", "{:.3f}"),
    "saturation": ("sat", "{:.3f}"),
    "step_ms": ("ms/step", "{:.3f}"),
    "step_p95_ms": ("p95 ms", "{:.3f}"),
    "step_cpu_p95_ms": ("CPU p95 ms", "{:.3f}"),
    "collisions": ("coll", "{:.0f}"),
}


class TimedTracker:
    """A tracker whose every ``command`` is timed and kept: by the wall clock, and by the CPU time of the
    calling thread (the wall clock less the time other processes held the core).

    Args:
        inner: The tracker to time.
    """

    def __init__(self, inner: Tracker) -> None:
        self.inner = inner
        self.name = inner.name
        self.times: list[float] = []
        self.cpu_times: list[float] = []
        self.commands: list[tuple[float, float]] = []
        self.dt = 0.02

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Reset the inner tracker (not timed) and the records."""
        self.inner.reset(trajectory, dt)
        self.dt = float(dt)
        self.times, self.cpu_times, self.commands = [], [], []

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """The inner tracker's command, timed."""
        start, cpu = time.perf_counter(), time.thread_time()
        out = self.inner.command(t, x, y, theta)
        self.times.append(time.perf_counter() - start)
        self.cpu_times.append(time.thread_time() - cpu)
        self.commands.append(out)
        return out

    def effort(self) -> float:
        """Integral of (dv/dt)^2 + (domega/dt)^2 over the run, by differences over control periods."""
        if len(self.commands) < 2:
            return 0.0
        du = np.diff(np.asarray(self.commands), axis=0)
        return float(np.sum(du**2) / self.dt)


def check_trackers(names: Sequence[str]) -> tuple[str, ...]:
    """The tracker names, checked: registered, none twice, at least one. A string is one name, or several
    comma-separated (as ``--trackers`` takes them): ``"fbl"`` was iterated as the trackers 'f', 'b' and 'l'.

    Raises:
        ConfigError: An empty list, an unknown name (lists the registered ones) or a repeated one.
    """
    if isinstance(names, str):
        names = names.split(",")
    names = tuple(n.strip() for n in names if n.strip())
    if not names:
        raise ConfigError(f"{option('trackers')} needs at least one tracker: choose from {', '.join(sorted(TRACKERS))}")
    for name in names:
        if name not in TRACKERS:
            raise ConfigError(
                f"unknown tracker {name!r}: choose from {', '.join(sorted(TRACKERS))}; {TRACKERS.unknown_hint()}"
            )
        if names.count(name) > 1:
            raise ConfigError(f"{option('trackers')} names {name!r} twice; give each tracker once")
    return names


def tracker_with(name: str, robot: Any, params: Any = None) -> Tracker:
    """A registered tracker with its tuned option set to ``params`` (None: its defaults).

    Raises:
        ConfigError: ``params`` given for a tracker with nothing to tune, or of the wrong type.
    """
    options: dict[str, Any] = {}
    if params is not None:
        options[tuned_option(name)[0]] = params
    elif "gains" in tracker_options(name):
        options["gains"] = None
    return make_tracker(name, robot, **options)


@dataclass(frozen=True)
class TrackerRun:
    """One tracker on one draw.

    Attributes:
        tracker: Tracker name.
        draw: Index of the draw.
        values: The per-run quantities by :data:`COLUMNS` key ({} for a run that failed).
        solver: The tracker's own statistics (MPC: solves, failures, overruns, times), or {}.
        log: The run's log (kept for the first draw only: plots and video).
        times: Wall-clock time of each ``command`` [s].
        status: "ok", why the run ended early (the robot fell, the estimate was lost), or "failed" (the tracker's
            command was not finite or raised, the physics failed: :class:`~planning.errors.SimulationError`).
        ending: What the record says of how it ended: ``warnings`` and, for a balancing robot, ``fell``,
            ``fall_time_s`` and ``max_pitch_rad``; ``error`` for a failed run.
        exception: A failed run's error (its ``__cause__`` the tracker's own exception, if any).
    """

    tracker: str
    draw: int
    values: dict[str, float]
    solver: dict[str, Any]
    log: RunLog | None = field(default=None, repr=False)
    times: tuple[float, ...] = field(default=(), repr=False)
    status: str = "ok"
    ending: dict[str, Any] = field(default_factory=dict)
    exception: SimulationError | None = field(default=None, repr=False, compare=False)


def _measure(name: str, draw: int, run: Any, timed: TimedTracker, keep: bool) -> TrackerRun:
    m = run.metrics
    times = np.asarray(timed.times) * 1e3
    values = {
        "final_m": m.final_position_error_m,
        "rms_m": m.rms_position_error_m,
        "max_m": m.max_position_error_m,
        "final_heading_rad": m.final_heading_error_rad,
        "rms_heading_rad": float(np.sqrt(np.mean(heading_errors(run.log) ** 2))),
        "effort": timed.effort(),
        "saturation": m.saturation_fraction,
        "step_ms": float(times.mean()) if times.size else 0.0,
        "step_p95_ms": float(np.percentile(times, 95)) if times.size else 0.0,
        "step_cpu_p95_ms": float(np.percentile(timed.cpu_times, 95)) * 1e3 if timed.cpu_times else 0.0,
        "collisions": float(m.collisions),
    }
    stats = getattr(timed.inner, "stats", None)
    solver = dict(stats()) if callable(stats) else {}
    ending = {k: v for k, v in m.as_dict().items() if k in ("warnings", "fell", "fall_time_s", "max_pitch_rad")}
    log = run.log if keep else None
    return TrackerRun(name, draw, values, solver, log, tuple(timed.times), m.status, ending)


@dataclass(frozen=True)
class RecordedRuns:
    """Runs to draw in one video (the :class:`sim.viz.job_video.RecordedJob` protocol).

    Attributes:
        robot: The robot.
        scenario: The scenario (its world).
        trajectory: The reference drawn on the floor.
        logs: Label -> log.
        model: The compiled model the runs stepped.
    """

    robot: RobotSpec
    scenario: Scenario
    trajectory: Trajectory
    logs: Mapping[str, RunLog]
    model: mujoco.MjModel


@dataclass(frozen=True)
class Comparison:
    """Every tracker's runs on the same trajectory and draws.

    Attributes:
        prepared: The case and the trajectory all trackers followed.
        trackers: Tracker names, in the order given.
        draws: The draws (empty: the case's own robot and noise, one run per tracker).
        runs: Every run, trackers outer, draws inner.
        params: Each tracker's tuned parameters as it ran (as plain dicts): those given, else its defaults for the
            robot (the value of its tuned option the tracker holds, ``TUNED``); empty for a tracker with none.
        model: The compiled model the first draw's runs stepped (what the video draws).
    """

    prepared: PreparedTrajectory
    trackers: tuple[str, ...]
    draws: tuple[Draw, ...]
    runs: tuple[TrackerRun, ...]
    params: Mapping[str, dict[str, Any]]
    model: mujoco.MjModel = field(compare=False, repr=False)

    def __repr__(self) -> str:
        """One line: the case and, per tracker, its runs and mean RMS error (``record()`` holds everything)."""
        p = self.prepared
        rms = ", ".join(
            f"{t}: {self.summary(t)['rms_m'] * 1e3:.2f} mm" if "rms_m" in self.summary(t) else f"{t}: failed"
            for t in self.trackers
        )
        return (
            f"Comparison({p.scenario.name}, {p.robot.name}, {p.trajectory.name}, "
            f"{max(len(self.draws), 1)} run(s) per tracker; RMS {rms})"
        )

    def of(self, tracker: str) -> list[TrackerRun]:
        """The runs of one tracker, by draw."""
        return [r for r in self.runs if r.tracker == tracker]

    def summary(self, tracker: str) -> dict[str, float]:
        """Mean of each quantity over the tracker's runs that did not fail (collisions summed), the RMS error's
        standard deviation, the solver's failures and overruns summed, and ``failed_runs`` when some failed
        (only that when every one did)."""
        runs = [r for r in self.of(tracker) if r.values]
        failed = len(self.of(tracker)) - len(runs)
        if not runs:
            return {"failed_runs": float(failed)}
        out = {k: float(np.mean([r.values[k] for r in runs])) for k in COLUMNS}
        if failed:
            out["failed_runs"] = float(failed)
        out["collisions"] = float(sum(r.values["collisions"] for r in runs))
        out["rms_m_std"] = float(np.std([r.values["rms_m"] for r in runs], ddof=1)) if len(runs) > 1 else 0.0
        for key in ("failures", "overruns"):
            if any(key in r.solver for r in runs):
                out[key] = float(sum(r.solver.get(key, 0) for r in runs))
        if any("p95_ms" in r.solver for r in runs):
            out["solve_p95_ms"] = float(max(r.solver.get("p95_ms", 0.0) for r in runs))
        return out

    def ended_early(self) -> list[TrackerRun]:
        """The runs that ended before the trajectory did (a fall, a lost estimate) or failed."""
        return [r for r in self.runs if r.status != "ok"]

    def logs(self) -> dict[str, RunLog]:
        """Tracker -> log of the first draw (for plots and the video)."""
        return {r.tracker: r.log for r in self.runs if r.log is not None}

    def recorded(self) -> RecordedRuns:
        """What :func:`sim.viz.job_video.write_video` draws: the first draw's run of every tracker, each
        labelled by its tracker (so each gets its own colour; the first tracker is drawn solid)."""
        p = self.prepared
        return RecordedRuns(p.robot, p.scenario, p.trajectory, self.logs(), self.model)

    def record(self) -> dict[str, Any]:
        """The JSON record: the case, the draws, each tracker's parameters, summary and runs."""
        p = self.prepared
        return {
            "scenario": p.scenario.name,
            "robot": p.robot.name,
            "source": p.source,
            "trajectory": {"name": p.trajectory.name, "duration_s": p.trajectory.duration},
            **p.extra,  # what the trajectory came from: the plan, the file's import, the smoothing
            "seed": p.case.seed,
            "build_seed": p.case.build_seed,
            "runs_per_tracker": max(len(self.draws), 1),
            "draws": [d.as_dict() for d in self.draws],
            "trackers": {
                name: {
                    "params": self.params.get(name, {}),
                    "summary": self.summary(name),
                    "runs": [
                        {"draw": r.draw, **r.values, "status": r.status, **r.ending, "solver": r.solver}
                        for r in self.of(name)
                    ],
                }
                for name in self.trackers
            },
        }


def compare_trackers(
    case: Case,
    trackers: Sequence[str],
    *,
    runs: int = 1,
    params: Mapping[str, Any] | None = None,
    progress: Callable[[str, int, int], Any] | None = None,
) -> Comparison:
    """Run each tracker on the case's trajectory, on the same robots and noise (see the module doc).

    Args:
        case: The case (scenario, robot, reference or planner, seed, build seed, control rate).
        trackers: Registered tracker names (a string: one, or several comma-separated).
        runs: Runs per tracker (1: the case's own draw; N > 1: N held-out draws).
        params: Tracker -> its tuned parameters (the dataclass of its tuned option); others default.
        progress: Told (tracker, runs done, runs total) after each run.

    Raises:
        ConfigError: Unknown or repeated trackers, runs < 1, parameters of the wrong type, FBL gains the control
            rate cannot keep stable (:func:`control.gains.check_sampled_stability`).
        NhsimError: From preparing the trajectory (planning, smoothing); a tracker's run that fails
            (:class:`~planning.errors.SimulationError`) is kept as ``failed`` and the others run on.
    """
    names = check_trackers(trackers)
    runs = check_number(option("runs"), runs, integer=True, at_least=1)
    params = dict(params or {})
    for name in names:  # as a case's gains are checked (Case), before any work; the rate is the case's
        given = params.get(name)
        if isinstance(given, FBLGains):
            where = f"the {name} gains of {option('params', python='params')}"
            check_sampled_stability(given, case.control_rate, where, rate_given=False)
        elif given is None and uses_fbl_gains(name):  # its defaults: refused at reset, after the others had run
            check_sampled_stability(FBLGains(), case.control_rate, f"the default gains of tracker {name!r}")
    prepared = prepare_trajectory(case)
    base = PreparedCase(prepared, simulator_for(prepared))
    draws = make_draws(runs, case.seed, held_out=True) if runs > 1 else ()
    done: list[TrackerRun] = []
    ran: dict[str, dict[str, Any]] = {}  # each tracker's parameters as it ran
    model = None  # the first draw's, for the video
    for index, draw in enumerate(draws or (None,)):
        pc = base if draw is None else base.with_build(draw.build_seed)
        model = model if model is not None else pc.simulator.run_model(case.perturbation)
        this = pc.trajectory.case if draw is None else replace(pc.trajectory.case, seed=draw.seed)
        prepared_i = replace(pc.trajectory, case=this)
        config = SimConfig(control_rate=this.control_rate, hold=prepared.hold, strict=False)
        sensing = this.sensing(prepared.scenario)
        for name in names:
            tracker = tracker_with(name, prepared.robot, params.get(name))
            if name not in ran:  # as the first draw's tracker holds them, else those given
                ran[name] = tracker_params(name, tracker) or plain_params(params.get(name))
            timed = TimedTracker(tracker)
            try:
                kind = RunKind.of_tracker(name)  # a player without feedback runs as the open loop: on no estimate
                run = run_tracker(prepared_i, kind, timed, pc.simulator, config, sensing)
            except SimulationError as exc:  # this tracker's run: the others are still compared
                done.append(TrackerRun(name, index, {}, {}, status="failed", ending={"error": str(exc)}, exception=exc))
            else:
                done.append(_measure(name, index, run, timed, keep=index == 0))
            if progress is not None:
                progress(name, index + 1, max(runs, 1))
    ordered = tuple(r for name in names for r in done if r.tracker == name)
    assert model is not None  # there is at least one draw
    return Comparison(prepared, names, tuple(draws), ordered, ran, model)


def format_table(comparison: Comparison) -> str:
    """The comparison as a text table: one row per tracker, the means over its runs."""
    head = f"{'tracker':<10}" + "".join(f"{title:>14}" for title, _ in COLUMNS.values()) + f"{'solver':>22}"
    lines = [head, "-" * len(head)]
    for name in comparison.trackers:
        s = comparison.summary(name)
        row = f"{name:<10}" + "".join(
            f"{fmt.format(s[k]) if k in s else 'failed':>14}" for k, (_, fmt) in COLUMNS.items()
        )
        if "failures" in s:
            row += f"{'fail ' + str(int(s['failures'])) + ', over ' + str(int(s['overruns'])):>22}"
        lines.append(row)
    if comparison.draws:
        lines.append(f"(mean of {len(comparison.draws)} held-out draws per tracker; collisions summed)")
    else:
        case = comparison.prepared.case
        lines.append(
            f"(one run per tracker, on the case's own robot and noise: build seed {case.build_seed}, seed {case.seed})"
        )
    for r in comparison.ended_early():
        if r.status == "failed":
            lines.append(f"{r.tracker} run {r.draw}: failed: {r.ending['error']}")
        else:
            lines.append(f"{r.tracker} run {r.draw}: ended early: {r.status} (its errors are up to then)")
    return "\n".join(lines)


def load_params(paths: Sequence[str | Path]) -> dict[str, Any]:
    """Tuned parameters by tracker from JSON files, as each tracker's tuned dataclass.

    A file is either what ``nhsim tune --tracker T`` writes (``{"tracker": T, "params": {...}}``)
    or a mapping ``{tracker: {field: value, ...}, ...}``; a later file's field overrides an earlier one's,
    field by field (``{"fbl": {"kp": 4}}`` then ``{"fbl": {"kd": 2}}`` gives both).

    Raises:
        ConfigError: An unreadable file, an unknown tracker, a tracker with nothing to tune, or an
            unknown or out-of-range field (the message names the valid ones or the range).
    """
    fields_by: dict[str, dict[str, Any]] = {}
    out: dict[str, Any] = {}
    for path in paths:
        given = option("params", str(path), python="load_params([{}])")
        try:
            raw = read_input(path)  # once: a pipe cannot be read again (a gains file is told from these bytes)
        except OSError as exc:
            raise ConfigError(f"{given}: cannot read it ({exc.strerror or exc}); check the path") from exc
        try:
            data = load_json(raw)
        except GivenTwice as exc:  # a second table of a tracker replaced the first's fields
            raise ConfigError(f"{given}: {exc}; keep the one meant (or merge the two)") from None
        except ValueError as exc:
            raise ConfigError(f"{given}: {_gains_file(Path(path), raw) or f'cannot read it as JSON ({exc})'}") from exc
        if isinstance(data, dict) and "tracker" in data and isinstance(data.get("params"), dict):
            data = {data["tracker"]: data["params"]}
        if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
            raise ConfigError(f"{given}: expected {{tracker: {{field: value}}}} or a 'nhsim tune' record")
        for name, fields_ in data.items():
            try:
                check_trackers([name])
            except ConfigError as exc:  # said of the file that names it (it named no file)
                raise ConfigError(f"{given}: {exc}") from exc
            cls = tuned_option(name)[1]
            valid = list(getattr(cls, "__dataclass_fields__", {}))
            unknown = [k for k in fields_ if k not in valid]
            if unknown:
                raise ConfigError(f"{given}: {name} has no parameter(s) {unknown}; valid: {', '.join(valid)}")
            fields_by[name] = {**fields_by.get(name, {}), **fields_}
            try:
                out[name] = cls(**fields_by[name])
            except ConfigError as exc:  # an out-of-range or ill-typed value: say which file holds it
                raise ConfigError(f"{given}: {exc}") from exc
    return out


def _gains_file(path: Path, raw: bytes) -> str | None:
    """Why the --params file ``path`` (its bytes ``raw``), not JSON, is refused when it is a gains file (TOML
    with a ``[gains]`` table, as ``nhsim tune`` writes), naming the file --params takes; None for any other file."""
    import tomllib

    try:
        table = tomllib.loads(raw.decode("utf-8")).get("gains")
    except (UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    if not isinstance(table, dict):
        return None
    record = path.with_suffix(".json")
    where = f": {record}, next to it" if record.is_file() else " (its --json; by default this file's name with .json)"
    return (
        f"this is a gains file (FBL gains, for --gains: 'nhsim simulate --gains {path}'), not JSON; --params takes "
        f"the JSON record 'nhsim tune' writes with it{where}"
    )
