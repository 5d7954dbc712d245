"""``nhsim tune``: tune a tracker's parameters (the FBL's gains by default) with Optuna over a set of cases."""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import logging
import math
import re
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from planning.errors import ConfigError, ScenarioError, without_python
from sim.cli.checks import add_robot_argument, case_list
from sim.cli.simulate import add_localiser_arguments, check_scan_beams, localiser_fields
from sim.tools.executor import JOBS_PER_CORE, check_workers
from sim.tools.tune import GRACE_PERIOD, UNRECORDED, check_draws

DESCRIPTION = f"""\
Tune the feedback-linearisation tracker's gains (Kp, Kd, xi_min) with Optuna (TPE by default) over
a set of cases on realistic robots. Each case runs its fused-estimate closed loop on --draws K draws
made from --seed: an as-built robot (build seed), sensor noise (noise seed) and, with --robust, a
perturbation from --perturb-range; every trial meets the same draws. Objective (lower is better),
averaged over cases and draws: RMS position error + final position error + W * saturation
fraction [m], plus 1 m for a run that collides, makes MuJoCo warn or fails. Errors are against the
true pose, so gains that chase the estimate's noise pay for it.

Cases (--scenarios, comma-separated): SCENARIO:REFERENCE tracks an analytic reference at the
scenario's start (e.g. open:figure8, open:circle, open:line); SCENARIO:PLANNER or a bare SCENARIO
tracks a plan (needs the planners).

The study is kept in an SQLAlchemy storage (default sqlite:///renders/tune-<study>.db). Rerunning
the same command resumes it: completed trials count toward --trials and are never repeated, a trial
a killed worker left running is failed once its heartbeat has been silent for {GRACE_PERIOD} s and its gains
are evaluated afresh, and the outputs the study wrote before are updated (an existing output that
names another study, or none, is replaced only with --overwrite); a trial stopped by Ctrl-C or SIGTERM
is run again, so the resumed study ends as one never interrupted; a rerun with other cases, draws
(--draws, --seed, --robust, --perturb-range), weights or localiser, or after a case's scenario file was
edited or on other code (the study keeps digests of the scenarios as read and of nhsim's code, models and
plugins, as montecarlo's key does: trials of another world are not mixed in), is refused, unless every
trial of the study failed (nothing to resume: it is made anew). Left out, --localiser is
the robots' own (amcl for the TurtleBot3) and --robot each scenario's own (open's TurtleBot3), and the
study is the one that names them. Any
SQLAlchemy URL works (e.g. postgresql://user:pass@host/db), so workers on several machines can run
the same command against one study; --jobs runs local worker processes (Ctrl-C or SIGTERM stops them
with the command, their trials as --jobs 1 leaves its own). The URL's password is shown and written as
*** (messages, gains file, record, plots), and the outputs are the study's whatever spelling of its URL
reaches the same database (another driver, another password, localhost or 127.0.0.1, an SQLite file's path
relative or absolute; the outputs record an SQLite file by its absolute path). --sampler may change on resume, as
Optuna allows (the new sampler learns from every trial): the provenance names each sampler that
proposed trials (sampler = "tpe + random", with sampler_trials counting them). The default gains are
always the study's first trial proposed (with --jobs 2 or more, or after an interruption, another may end first).

At the end the tuned and the default gains are run on --eval-runs held-out draws per case (other
build and noise seeds than any trial's), a table compares them and a sentence says which are better
and by how much. The best gains go to a gains file (for 'nhsim simulate --gains FILE') with that
comparison in its provenance, the record of the study and the comparison (every held-out run's seeds
and costs) to a JSON file, and plots of the optimisation history and the parameter importance are
saved.

--tracker T tunes another registered tracker (mpc, rpp, kanayama, segmented) with the same objective
and draws: its parameters over the ranges its dataclass declares, log-uniformly (for mpc the weights,
not the horizon; a tracker that declares none is refused); its defaults are the first trial, the
record carries "tracker" and "params" (read by 'nhsim compare --params'), and a gains file is written
only for trackers tuned by their FBL gains (e.g. fbl, segmented): for the others --out is refused and
--json names the record.

When the tuned gains score worse than the defaults on the held-out draws, the command says so, writes
the DEFAULT gains to the gains file (the DEFAULT parameters to the record, for a tracker without a
gains file; the provenance's objective and trial are the defaults', and it names the tuned gains that
lost, their trial and objective as tuned_trial and tuned_objective, and their held-out numbers) and exits 1.
When no trial beat the defaults, the held-out draws run them once and the provenance says
recommended = "default" (the defaults were best).

Exit status: 0 done, 1 the tuned gains lost to the defaults on held-out draws (the defaults were
written), or the study could not go on for a cause that is not the input: the connection to its
storage was lost once open (a database server stopped) or a worker process died (killed); one line
says which, nothing is written, and the study keeps every completed trial: rerun the same command to
resume it. 2 bad input (nothing written; a storage that cannot be opened at the start among it), 130
interrupted (the study keeps every completed trial; rerun the command to resume: the interrupted
trials' gains run again)."""


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``tune`` subcommand."""
    from sim.tools.tune import SAMPLERS

    p: argparse.ArgumentParser = sub.add_parser(
        "tune",
        help="tune tracker gains with Optuna (resumable study, gains file, plots)",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--scenarios", required=True, metavar="CASE,...", help="cases to tune on, e.g. open:figure8,open:circle"
    )
    p.add_argument(
        "--tracker",
        default="fbl",
        metavar="NAME",
        help="tracker whose parameters are tuned (default: fbl, its gains); e.g. mpc, rpp, kanayama: their "
        "parameters over the ranges they declare, the record's 'params' read by 'nhsim compare --params'",
    )
    p.add_argument(
        "--trials", type=int, default=30, metavar="N", help="completed trials wanted in the study (default: 30)"
    )
    p.add_argument(
        "--jobs",
        type=int,
        default=1,
        metavar="J",
        help=f"local worker processes, at most {JOBS_PER_CORE} per core (default: 1)",
    )
    p.add_argument(
        "--storage",
        default=None,
        metavar="URL",
        help="SQLAlchemy URL of the study storage, a database file or server (not in memory: the workers share "
        "the study and a rerun resumes it) (default: sqlite:///renders/tune-<study>.db)",
    )
    p.add_argument("--study", default=None, metavar="NAME", help="study name (default: derived from the cases)")
    p.add_argument(
        "--sampler",
        choices=list(SAMPLERS),
        default="tpe",
        help="Optuna sampler (default: tpe; a resumed study may take another)",
    )
    add_robot_argument(p, "robot (default: each scenario's)")
    p.add_argument("--control-rate", type=float, default=50.0, metavar="HZ", help="tracker rate (default: 50)")
    add_localiser_arguments(p)
    p.add_argument(
        "--draws", type=int, default=4, metavar="K", help="robots (build and noise seeds) per case (default: 4)"
    )
    p.add_argument("--robust", action="store_true", help="give each draw a perturbation from --perturb-range")
    p.add_argument(
        "--perturb-range",
        default=None,
        metavar="KEY=LO:HI,...",
        help="perturbation ranges of --robust, e.g. friction=0.5:1.5,latency=0:0.04 "
        "(keys: friction, mass, radius, noise, heading_noise, latency; unspecified keys keep their defaults)",
    )
    p.add_argument(
        "--eval-runs",
        type=int,
        default=8,
        metavar="M",
        help="held-out draws per case comparing tuned and default gains at the end (default: 8; 0 skips)",
    )
    p.add_argument(
        "--saturation-weight",
        type=float,
        default=0.05,
        metavar="W",
        help="cost of a saturated command, per unit saturation fraction [m] (default: 0.05)",
    )
    p.add_argument(
        "--seed", type=int, default=0, metavar="N", help="seed of the sampler, the draws and the plans (default: 0)"
    )
    _add_output_arguments(p)
    return p


def _add_output_arguments(p: argparse.ArgumentParser) -> None:
    """The options naming the files ``tune`` writes."""
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="PATH",
        help="gains file to write, for trackers tuned by their FBL gains (e.g. fbl, segmented) (default: "
        "renders/tune-<study>.toml)",
    )
    p.add_argument(
        "--json",
        type=Path,
        default=None,
        metavar="PATH",
        help="record of the study and the held-out comparison (default: the gains file with .json)",
    )
    p.add_argument(
        "--plots",
        type=Path,
        default=Path("renders"),
        metavar="DIR",
        help="directory of the plots tune-<study>-history.png, -importance.png (default: renders)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress display")


#: The characters of a study's name (it names the study's files).
STUDY_CHARS = "A-Za-z0-9_.-"


def default_study_name(
    tokens: list[str], robot: str | None, robust: bool, tracker: str = "fbl", localiser: str | None = None
) -> str:
    """A study name derived from the tracker, the cases and the settings given (the same command gives the
    same name)."""
    base = f"{tracker}-" + "_".join(tokens) + (f"-{robot}" if robot else "") + ("-robust" if robust else "")
    base += f"-{localiser}" if localiser else ""
    name = re.sub(f"[^{STUDY_CHARS}]+", "-", base)
    if len(name) > 60:
        name = name[:50] + "-" + hashlib.sha1(name.encode()).hexdigest()[:8]
    return name


class _Progress:
    """A tqdm bar on a terminal, nothing otherwise."""

    def __init__(self, total: int, initial: int, enabled: bool) -> None:
        self.bar = None
        if enabled:
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=initial, desc="trials", unit="trial", file=sys.stderr)

    def set(self, done: int, best: float | None) -> None:
        if self.bar is not None:
            self.bar.n = done
            if best is not None:
                self.bar.set_postfix_str(f"best {best:.5f} m", refresh=False)
            self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _best_value(study: Any) -> float | None:
    from sim.tools.tune import completed

    values = [t.value for t in completed(study)]
    return min(values) if values else None


def writes_gains_file(tracker: str) -> bool:
    """Whether tuning ``tracker`` ("": the FBL's default study) writes a gains file: only FBL gains have
    one (``nhsim simulate --gains``); every tracker's parameters go to the JSON record."""
    from control.gains import FBLGains
    from sim.tools.tune import tuned_space

    return tuned_space(tracker)[0] is FBLGains


def _workers_know(tracker: str, trials: int) -> bool:
    """Whether worker processes (``--jobs``) know ``tracker``: a built-in tracker or a plugin's, which a fresh
    process loads too. One registered by the calling program's own code is not (a worker does not run
    that code): then this says so and the trials run in this process."""
    from control.base import PLUGIN_GROUP, PLUGIN_VARIABLE, in_every_process, tracker_origin

    if in_every_process(tracker):
        return True
    print(
        f"tune: tracker {tracker!r} is {tracker_origin(tracker)}, which --jobs worker processes do not run: "
        f"running the {trials} trials in this process. To tune it on workers, make its registration a plugin: "
        f"an entry point of group {PLUGIN_GROUP} in an installed package, or {PLUGIN_VARIABLE}=your.module "
        "(docs/how-to/new-tracker.md)",
        file=sys.stderr,
    )
    return False


#: Exit statuses of a worker process (``--jobs``) that an interrupt stopped (SIGTERM from the command: its trial
#: is recorded as interrupted, as with --jobs 1), or that lost the connection to the study's storage.
WORKER_INTERRUPTED = 130
WORKER_LOST_STORAGE = 75  # EX_TEMPFAIL
#: How long the command waits for its stopped workers to record their interrupted trials and end [s]; one still
#: running then is killed (its trial, silent, is failed and its gains enqueued again on resume).
STOP_WAIT_S = 10.0


def _run_parallel(spec: Any, shares: list[int], study: Any, progress: _Progress) -> None:
    """Run the trials on worker processes, one per share, until every worker has ended.

    The workers start with SIGINT blocked, so a terminal's Ctrl-C, which reaches every process of the
    command, reaches only this one; an interrupt (Ctrl-C or SIGTERM) or an error here stops them
    (:func:`_stop_workers`) before it goes on.

    Raises:
        TuneFailure: A worker lost the connection to the study's storage, or ended early otherwise (killed).
    """
    import multiprocessing as mp
    from multiprocessing import resource_tracker

    from planning.signals import sigint_blocked
    from sim.tools.tune import completed

    ctx = mp.get_context("spawn")
    resource_tracker.ensure_running()  # started first: starting it unblocks SIGINT in the thread that starts it
    procs: list[Any] = []
    try:
        with sigint_blocked():  # inherited by the workers: Ctrl-C is this process's to act on
            for i, n in enumerate(shares):
                procs.append(ctx.Process(target=_worker, args=(spec, n, i + 1)))
                procs[-1].start()
        while any(proc.is_alive() for proc in procs):
            time.sleep(0.5)
            progress.set(len(completed(study)), _best_value(study))
    except BaseException:
        _stop_workers(procs)
        raise
    for proc in procs:
        proc.join()
    _check_workers_ended(spec, [proc.exitcode for proc in procs])


def _check_workers_ended(spec: Any, codes: list[int | None]) -> None:
    """Raise :class:`sim.tools.tune.TuneFailure` when a worker did not end well, naming how it ended."""
    from sim.tools.tune import TuneFailure, lost_storage_message

    if WORKER_LOST_STORAGE in codes:
        raise TuneFailure(lost_storage_message(spec.storage))
    bad = [code for code in codes if code != 0]
    if not bad:
        return
    raise TuneFailure(
        f"{len(bad)} of {len(codes)} tuning worker processes ended early ({'; '.join(map(_ended, bad))}); the "
        "study keeps its completed trials: rerun the same command to resume it"
    )


def _ended(code: int | None) -> str:
    """How a worker process that ended with exit code ``code`` (multiprocessing's: -N killed by signal N) ended."""
    import signal

    if code is not None and code < 0 and -code in signal.valid_signals():
        return f"killed by {signal.Signals(-code).name}"
    return "interrupted by SIGTERM" if code == WORKER_INTERRUPTED else f"exit status {code}"


def _stop_workers(procs: list[Any]) -> None:
    """Stop the workers still running: each takes SIGTERM as an interrupt (its trial being evaluated is recorded
    as interrupted and run again on resume, as with --jobs 1) and ends; one still running after
    :data:`STOP_WAIT_S` is killed. A further Ctrl-C or SIGTERM meanwhile is acted on once they are stopped."""
    from planning.signals import signals_held

    with signals_held():
        for proc in procs:
            if proc.is_alive():
                proc.terminate()
        deadline = time.monotonic() + STOP_WAIT_S
        for proc in procs:
            proc.join(max(0.0, deadline - time.monotonic()))
            if proc.is_alive():
                proc.kill()
                proc.join()


def _worker(spec: Any, n_trials: int, worker: int) -> None:
    """Entry point of a worker process (``--jobs``, :func:`sim.tools.tune.worker_process`). SIGTERM (the command
    stopping it) is taken as an interrupt, as the command takes it (:func:`sim.cli.interrupt.sigterm_as_interrupt`):
    the trial being evaluated is recorded as interrupted and the worker ends with :data:`WORKER_INTERRUPTED`,
    saying nothing (the command says "interrupted"); a lost connection to the study's storage ends it with
    :data:`WORKER_LOST_STORAGE`, saying nothing either (the command says it, once)."""
    from sim.cli.interrupt import sigterm_as_interrupt
    from sim.tools.tune import TuneFailure, worker_process

    _quiet_optuna()
    with sigterm_as_interrupt():
        try:
            with _storage_kept(spec.storage):
                worker_process(spec, n_trials, worker)
        except KeyboardInterrupt:
            sys.exit(WORKER_INTERRUPTED)
        except TuneFailure:
            sys.exit(WORKER_LOST_STORAGE)


@contextlib.contextmanager
def _storage_kept(storage: str) -> Iterator[None]:
    """Within the block, an error of the study's storage (its database server stopped, the network to it lost) is
    a :class:`sim.tools.tune.TuneFailure` saying so in one line, the URL's password hidden; the report of Optuna's
    heartbeat thread, which dies of it too, is not shown."""
    from sim.tools.tune import TuneFailure, lost_connection, lost_storage_message

    previous = threading.excepthook

    def hook(args: Any) -> None:
        if args.exc_value is None or lost_connection(args.exc_value) is None:
            previous(args)

    threading.excepthook = hook
    try:
        yield
    except TuneFailure:
        raise
    except Exception as exc:
        reason = lost_connection(exc)
        if reason is None:
            raise
        raise TuneFailure(lost_storage_message(storage, reason)) from exc
    finally:
        threading.excepthook = previous


def _quiet_optuna() -> None:
    """Optuna says only warnings, without its report of a trial an interrupt stopped (:class:`_NotInterrupted`),
    its retry of a query on a lost database connection (:func:`_not_lost_connection`) and its experimental-feature
    warnings."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    for handler in logging.getLogger("optuna").handlers:  # its trials' loggers pass records up to these
        for quiet in (_not_interrupted, _not_lost_connection):
            if quiet not in handler.filters:
                handler.addFilter(quiet)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)


def _not_lost_connection(record: logging.LogRecord) -> bool:
    """False for Optuna's "Caught an error from sqlalchemy: ... Falling back to a slower alternative." when the
    error is the database's connection (a server stopped): Optuna takes any OperationalError for a query with too
    many variables and retries it, the retry fails on the same connection, and the command says the lost
    connection once (:func:`sim.tools.tune.lost_storage_message`). Its other retries are still said."""
    message = record.getMessage()
    return not (message.startswith("Caught an error from sqlalchemy") and "connection" in message)


def _save_figure(plt: Any, ax: Any, path: Path, files: TuneFiles, stage: Any) -> None:
    fig = ax.get_figure(root=True)
    fig.savefig(stage.path(path), dpi=120, bbox_inches="tight", format="png", metadata=files.stamp())
    plt.close(fig)


def _save_plots(study: Any, files: TuneFiles, stage: Any) -> tuple[list[str], list[str]]:
    """Write both plots into ``stage`` (:class:`sim.outputs.StagedOutputs`); returns the paths written and notes
    on plots that could not be drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from optuna.importance import PedAnovaImportanceEvaluator
    from optuna.visualization.matplotlib import plot_optimization_history, plot_param_importances

    notes: list[str] = []
    written = [str(files.history)]
    ax = plot_optimization_history(study)
    ax.set_ylabel("objective [m]")
    ax.set_yscale("log")
    _save_figure(plt, ax, files.history, files, stage)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UserWarning)
            ax = plot_param_importances(study, evaluator=PedAnovaImportanceEvaluator())
        notes += [f"importance plot: {w.message}" for w in caught if issubclass(w.category, UserWarning)]
    except Exception as exc:  # too few or identical trials
        notes.append(f"no importance plot: {exc}")
    else:
        _save_figure(plt, ax, files.importance, files, stage)
        written.append(str(files.importance))
    return written, notes


@dataclass(frozen=True)
class TuneFiles:
    """Where a tuning run keeps its study and writes its outputs.

    Attributes:
        study: Study name.
        storage: SQLAlchemy URL of the study.
        gains: Gains file to write.
        history: Optimisation history plot.
        importance: Parameter importance plot.
        record: JSON record of the study and the held-out comparison.
        own: The outputs that exist already and name this study and storage (an earlier run of the
            same study wrote them): a resumed study replaces them without --overwrite.
    """

    study: str
    storage: str
    gains: Path
    history: Path
    importance: Path
    record: Path
    own: frozenset[Path] = frozenset()

    def stamp(self) -> dict[str, str]:
        """The study and storage, as every output records them (provenance, record, PNG text): the storage's
        password, if any, masked (:func:`sim.tools.tune.shown_url`), an SQLite file by its absolute path (a relative
        one read from another folder would be another file: :func:`sim.tools.tune.absolute_storage`)."""
        from sim.tools.tune import absolute_storage, shown_url

        return {"study": self.study, "storage": shown_url(absolute_storage(self.storage))}

    def names_this_study(self, owner: dict[str, str] | None) -> bool:
        """Whether an output's ``owner`` (:meth:`owner`) is this study: the same name in the same database,
        however its URL was spelt (another driver, a password or none: :func:`sim.tools.tune.same_storage`)."""
        from sim.tools.tune import same_storage

        return owner is not None and owner["study"] == self.study and same_storage(owner["storage"], self.storage)

    def may_replace(self, path: Path, overwrite: bool) -> bool:
        """Whether ``path`` may be replaced: --overwrite, or an output of this study, when this run
        began or now (another worker of the same study, started together, wrote it meanwhile)."""
        return overwrite or path in self.own or (path.is_file() and self.names_this_study(self.owner(path)))

    def replaceable(self, overwrite: bool) -> Callable[[Path], bool]:
        """:meth:`may_replace` as the question :class:`sim.outputs.StagedOutputs` asks at each check:
        another worker of this study may write the same output while this one works."""
        return lambda path: self.may_replace(path, overwrite)

    def owner(self, path: Path) -> dict[str, str] | None:
        """The study and storage an existing output of this run's names, None when it names none
        (another program's file, or unreadable)."""
        import json
        import tomllib

        from PIL import Image

        try:
            if path == self.gains:
                stamp = tomllib.loads(path.read_text(encoding="utf-8")).get("provenance", {})
            elif path == self.record:
                stamp = json.loads(path.read_text(encoding="utf-8"))
            else:
                with Image.open(path) as image:
                    stamp = dict(getattr(image, "text", {}))
        except (OSError, ValueError):  # unreadable, or not TOML, JSON or an image
            return None
        if not isinstance(stamp, dict) or not all(isinstance(stamp.get(k), str) for k in ("study", "storage")):
            return None
        return {k: stamp[k] for k in ("study", "storage")}


def _default_study(
    args: argparse.Namespace, tokens: list[str], localiser: str | None, robot: str | None, own_robot: bool
) -> tuple[str, str]:
    """The default study name and storage: named by the cases and the settings, ``localiser`` and ``robot``
    the ones the cases run on (:func:`default_study_name`); or the name an nhsim that did not name the
    robots' default localiser or (``own_robot``) the scenarios' own robot gave the same study, when the
    storage holds a study of that name and none of this one (it is resumed where it is)."""

    def named(robot: str | None, localiser: str | None) -> tuple[str, str]:
        name = default_study_name(tokens, robot, args.robust, getattr(args, "tracker", "fbl"), localiser)
        return name, args.storage or f"sqlite:///renders/tune-{name}.db"

    now = named(robot, localiser)
    if _holds(*now):
        return now
    given = (getattr(args, "localiser", None), localiser)
    robots = (robot, None) if own_robot else (robot,)
    earlier = (named(r, loc) for r in robots for loc in given)
    return next((e for e in earlier if e != now and _holds(*e)), now)


def _holds(study: str, storage: str) -> bool:
    """Whether ``storage`` holds a study named ``study`` (an SQLite file that is not there is not opened:
    that would make it; nor is one refused as a storage, which opening would fill with Optuna's tables).

    Raises:
        ConfigError: A storage that cannot keep a study (:func:`sim.tools.tune.check_storage`).
    """
    import optuna

    from sim.tools.tune import check_storage, sqlite_file

    check_storage(storage)
    database = sqlite_file(storage)
    if database is not None and not database.is_file():
        return False
    try:
        return study in optuna.get_all_study_names(storage)
    except Exception:  # a storage that cannot be opened: load_study says why
        return False


def tune_files(
    args: argparse.Namespace,
    tokens: list[str],
    localiser: str | None = None,
    robot: str | None = None,
    own_robot: bool = False,
) -> TuneFiles:
    """Decide the study name, its storage and the output files, and check none would be replaced
    unless it is an output of this same study (a resumed study updates its own outputs).

    Args:
        args: The command's options.
        tokens: The cases, as --scenarios gives them.
        localiser: The localiser every case runs on (given, or the robots' default); None: each its robot's.
        robot: The robot every case runs on (given, or the scenarios' own); None: each its scenario's.
        own_robot: Whether every case runs on its scenario's own robot (a study named without it is this one).

    Raises:
        OutputExistsError: An output exists, is not this study's, and --overwrite was not given.
        ConfigError: Two outputs are one file, an output (or the study's SQLite file) is or lies inside a
            file the command reads (a case's scenario, its map image: :func:`sim.cli.job_outputs.input_paths`),
            an output is the study's storage, or cannot be written (:func:`sim.outputs.check_writable`).
    """
    from planning.errors import OutputExistsError
    from sim.cli.job_outputs import check_apart_from_inputs
    from sim.outputs import check_distinct, check_folder_for, check_length, check_not_read_by_runs, check_writable
    from sim.tools.tune import check_storage, shown_url, sqlite_file

    study, storage = (
        (args.study, args.storage) if args.study else _default_study(args, tokens, localiser, robot, own_robot)
    )
    gains = args.out or Path("renders") / f"tune-{study}.toml"
    files = TuneFiles(
        study,
        storage or f"sqlite:///renders/tune-{study}.db",
        gains,
        args.plots / f"tune-{study}-history.png",
        args.plots / f"tune-{study}-importance.png",
        args.json or gains.with_suffix(".json"),
    )
    check_storage(files.storage)
    database = sqlite_file(files.storage)
    if database is not None:  # written as an output is: never among nhsim's models; its folder made
        check_not_read_by_runs(database)
        check_folder_for(database)
    written = (files.gains,) if writes_gains_file(getattr(args, "tracker", "fbl").strip()) else ()
    paths = (*written, files.history, files.importance, files.record)
    check_distinct(
        {
            **({"--out (the gains)": files.gains} if written else {}),
            "--plots (the history plot)": files.history,
            "--plots (the importance plot)": files.importance,
            "--json (the record)": files.record,
        }
    )
    check_apart_from_inputs(args, [*paths, *([database] if database is not None else [])])  # scenarios, maps
    if database is not None:
        _check_apart_from_storage(files.storage, database, paths)
    for path in paths:
        check_length(path)  # before is_file, which a name too long makes raise
    owners = {p: files.owner(p) for p in paths if p.is_file()}
    own = frozenset(p for p, owner in owners.items() if files.names_this_study(owner))
    for path in paths:
        owner = owners.get(path)
        if owner is not None and path not in own and not args.overwrite:
            raise OutputExistsError(
                f"{path} holds the outputs of study {owner['study']!r} in {shown_url(owner['storage'])!r}, not of "
                f"study {study!r} in {shown_url(files.storage)!r}; pass --overwrite to replace it, or choose other "
                "output paths (--out, --json, --plots)"
            )
        check_writable(path, overwrite=args.overwrite or path in own)
    return replace(files, own=own)


def _check_apart_from_storage(storage: str, db: Path, paths: tuple[Path, ...]) -> None:
    """Refuse an output that is the study's SQLite file ``db`` (writing it would destroy the study), or that lies
    under it (its folder would be a file: ``--storage sqlite:///renders`` made the file renders, where the outputs'
    folder goes, and the outputs then failed after the trials).

    Raises:
        ConfigError: Naming the output, the storage and the fix.
    """
    from sim.outputs import resolved

    clash = [str(p) for p in paths if resolved(p) == resolved(db)]
    if clash:
        raise ConfigError(
            f"{clash[0]} is the study's own storage ({storage}); give --out, --json or --plots another path"
        )
    inside = [str(p) for p in paths if resolved(db) in resolved(p).parents]
    if inside:
        raise ConfigError(
            f"the study's storage {storage} is the file {db}, where the folder of {inside[0]} must be; give --storage "
            "a file apart from the outputs' folders (e.g. sqlite:///renders/tune.db), or --out, --json or --plots "
            "another path"
        )


#: Most completed trials a study may ask for.
MAX_TRIALS = 100_000


def _check_counts(args: argparse.Namespace) -> None:
    from planning.core.checks import check_number
    from sim.cli.checks import check_at_least, check_control_rate, check_seeds

    check_at_least({"--trials": (args.trials, 1), "--draws": (args.draws, 1), "--eval-runs": (args.eval_runs, 0)})
    check_number(
        "--trials",
        args.trials,
        integer=True,
        at_most=MAX_TRIALS,
        fix="a study of more would not end (each trial runs every case on every draw): give the completed trials "
        "wanted, e.g. --trials 200 (a resumed study counts those it holds)",
    )
    for flag, count in (("--draws", args.draws), ("--eval-runs", args.eval_runs)):  # the held-out ones drawn last
        check_draws(flag, count)
    check_workers(args.jobs)
    check_seeds(seed=args.seed)
    check_control_rate(args.control_rate)
    _check_pipes(args)


def _check_pipes(args: argparse.Namespace) -> None:
    """Refuse a scenario of ``--scenarios`` that is a pipe (bash's ``<(...)``) with ``--jobs`` above 1: this process
    reads it once, and the worker processes, which load their cases' scenarios themselves, cannot."""
    from planning.core.files import is_pipe
    from sim.pipeline.case import Case

    piped = [s for s in (Case.split(t)[0] for t in _tokens(args)) if is_pipe(s)]
    if piped and args.jobs > 1:
        raise ConfigError(
            f"--scenarios {piped[0]}: this is a pipe (e.g. bash's <(...)), which only this process can read, once; "
            f"the --jobs {args.jobs} worker processes load the scenario themselves: give the scenario as a file (its "
            "path), or --jobs 1"
        )


def _tokens(args: argparse.Namespace) -> list[str]:
    return case_list(args.scenarios)


def run(args: argparse.Namespace) -> int:
    """Execute ``tune``; a study that could not go on (its storage lost, a worker killed:
    :class:`sim.tools.tune.TuneFailure`) is said in one line, exit status 1."""
    from sim.tools.tune import TuneFailure

    try:
        return _run(args)
    except TuneFailure as exc:
        print(f"nhsim tune: failed: {exc}", file=sys.stderr)
        return 1


def _run(args: argparse.Namespace) -> int:
    from sim.physics.perturb import PerturbationRange
    from sim.tools.tune import TuneSpec, make_draws, sqlite_file

    tokens = _tokens(args)
    if not tokens:
        raise ConfigError("--scenarios is empty; give cases such as open:figure8,open:circle")
    twice = sorted({t for t in tokens if tokens.count(t) > 1})
    if twice:  # the same case twice would weigh it twice in the objective
        raise ConfigError(f"--scenarios names {', '.join(twice)} twice; give each case once")
    if args.study is not None and not re.fullmatch(f"[A-Za-z0-9][{STUDY_CHARS}]*", args.study):
        raise ConfigError(
            f"--study {args.study!r}: a study name is letters, digits and . _ - (it names the study's files)"
        )
    _check_counts(args)
    from sim.tools.compare import check_trackers
    from sim.tools.tune import tuned_space

    tracker = check_trackers([args.tracker])[0]
    cls = tuned_space(tracker)[0]  # a tracker with nothing to tune stops here
    if args.out is not None and not writes_gains_file(tracker):
        raise ConfigError(
            f"--out names the gains file, which holds FBL gains (for 'nhsim simulate --gains'); tracker {tracker!r} "
            f"is tuned by its {cls.__name__}, which go to the JSON record only: leave --out out and give "
            "--json FILE (read by 'nhsim compare --params FILE')"
        )
    cases, default, unnamed = _cases(args, tokens, tracker)
    robots = {c.robot for c in cases}
    robot = robots.pop() if len(robots) == 1 else None  # every case's robot is named in its name
    prange = PerturbationRange.parse(args.perturb_range) if args.perturb_range else PerturbationRange()
    if args.perturb_range and not args.robust:
        raise ConfigError("--perturb-range is used by --robust only; add --robust, or leave --perturb-range out")
    files = tune_files(args, tokens, cases[0].localiser, robot, unnamed is not None)
    perturbations = prange if args.robust else None
    spec = TuneSpec(
        cases,
        make_draws(args.draws, args.seed, perturbations=perturbations),  # every case on every draw
        files.storage,
        files.study,
        args.trials,
        args.sampler,
        args.seed,
        args.saturation_weight,
        extra_settings={"robust": args.robust, "control_rate": args.control_rate, "robot": robot}
        | cases[0].localiser_options(),  # every case has the same
        tracker="" if tracker == "fbl" else tracker,  # the FBL's studies keep their settings (resumable)
        defaulted=("localiser",) if default is not None and cases[0].localiser == default else (),
        recorded={} if unnamed is None else {"cases": unnamed, "robot": None},  # the scenarios' robots left out
    )
    evaluator = spec.evaluator()
    try:
        evaluator.prepared()  # cases are built (and checked) before anything is written
    except ConfigError as exc:  # said as --scenarios takes a case (a scenario's error stays one)
        kind = ScenarioError if isinstance(exc, ScenarioError) else ConfigError
        raise kind(in_case_tokens(without_python(str(exc)))) from exc
    database = sqlite_file(spec.storage)
    if database is not None:  # its folder made, as every output's is (renders/ for the default; checked)
        database.parent.mkdir(parents=True, exist_ok=True)
    study = _optimise(args, spec)
    with _storage_kept(spec.storage):  # the best trial and the plots read the study
        best, default_obj = _report_best(study, spec, evaluator)
        held_out = make_draws(args.eval_runs, args.seed, held_out=True, perturbations=perturbations)
        comparison = _held_out(evaluator, held_out, best)
        lost = _write_outputs(args, files, spec, study, best, default_obj, comparison)
    return 1 if lost else 0


def in_case_tokens(message: str) -> str:
    """A case's error as ``--scenarios`` takes the case: its planner and reference are written into the token
    (``SCENARIO:PLANNER``, ``open:figure8``), and tune has no ``--planner``, ``--reference`` or ``--scenario``."""
    message = re.sub(r"--scenario (\S+?)(?=[,;:]|$| )", r"\1:figure8 in --scenarios", message)
    message = re.sub(r"--reference (\w+)", r"SCENARIO:\1 in --scenarios", message)
    return re.sub(r"--planner\b", "SCENARIO:PLANNER in --scenarios", message)


def _cases(
    args: argparse.Namespace, tokens: list[str], tracker: str
) -> tuple[tuple[Any, ...], str | None, list[str] | None]:
    """The cases, the localiser their robots run on by default (None when the robots' defaults differ), and
    the cases' names with the robot left out, as an earlier nhsim named them (None when a case's robot is
    not its scenario's own: that study named it).

    Each case runs on the robot given or, with none given, on its scenario's, named; and on the localiser
    given or, with none given, on that default, named: a study left to the scenario's robot or the robots'
    localiser is the study that names it (its name, its settings). Cases whose robots' defaults differ
    each keep their robot's.
    """
    from dataclasses import replace

    from planning.scenario import load_scenario
    from sim.pipeline.case import Case, load_case_scenario
    from sim.pipeline.runs import RunKind
    from sim.tools.tune import robot_localiser

    fields_ = {"robot": args.robot, "seed": args.seed, "control_rate": args.control_rate, "tracker": tracker}
    given = tuple(Case.parse(t, **fields_ | localiser_fields(args)) for t in tokens)
    scenarios = [load_case_scenario(c) for c in given]  # the case as given checked first: its errors are named
    cases = tuple(replace(c, robot=sc.robot, name="") for c, sc in zip(given, scenarios, strict=True))
    defaults = {robot_localiser(c, sc) for c, sc in zip(cases, scenarios, strict=True)}
    default = defaults.pop() if len(defaults) == 1 else None
    localiser = args.localiser or default
    named = tuple(replace(c, localiser=localiser) for c in cases) if localiser else cases
    for case, scenario in zip(named, scenarios, strict=True):  # trials run closed loops on the fused estimate
        check_scan_beams(case, scenario, (RunKind.CLOSED_LOOP,))
    own = args.robot is None or all(load_scenario(c.scenario_name).robot == args.robot for c in given)
    return named, default, [replace(c, robot=None, name="").name for c in given] if own else None


def _optimise(args: argparse.Namespace, spec: Any) -> Any:
    """Open (or create) the study and run the trials it still lacks, on one or more workers."""
    from sim.tools.tune import load_study

    _quiet_optuna()
    study = load_study(spec, create=True)  # a storage that cannot be opened is bad input (exit 2), said here
    with _storage_kept(spec.storage):  # lost once open: a failure (exit 1), the study resumed by a rerun
        _run_trials(args, spec, study)
    return study


def _run_trials(args: argparse.Namespace, spec: Any, study: Any) -> None:
    """Run the trials the study still lacks, on one or more workers."""
    from sim.tools.tune import completed, ensure_default_trial, run_worker, shown_url, split_trials

    _settle(study, args.quiet)
    done = len(completed(study))
    remaining = max(args.trials - done, 0)
    if remaining:
        ensure_default_trial(study, spec.tracker)
    if not args.quiet:
        workers = f" on {args.jobs} workers" if args.jobs > 1 and remaining > 1 else ""
        print(
            f"study {spec.study} in {shown_url(spec.storage)}: {done} of {args.trials} trials complete, running "
            f"{remaining}{workers}",
            file=sys.stderr,
        )
    progress = _Progress(args.trials, done, not args.quiet and sys.stderr.isatty())
    shares = split_trials(remaining, args.jobs)
    if len(shares) > 1 and not _workers_know(spec.tracker or "fbl", remaining):
        shares = [remaining]
    try:
        if len(shares) == 1:
            run_worker(spec, shares[0], 0, callbacks=[lambda s, t: progress.set(len(completed(s)), _best_value(s))])
        elif shares:
            _run_parallel(spec, shares, study, progress)
    except KeyboardInterrupt as exc:  # what is kept, and how to go on, said with the command's "interrupted"
        with contextlib.suppress(Exception):  # a storage that cannot answer now: "interrupted" alone
            kept = len(completed(study))
            exc.nhsim_note = (  # type: ignore[attr-defined]
                f": the study keeps its {kept} completed trial{'s' if kept != 1 else ''} of {args.trials} in "
                f"{shown_url(spec.storage)}; the same command resumes it"
            )
        raise
    finally:
        progress.close()


class _NotInterrupted(logging.Filter):
    """Drops Optuna's report of a trial stopped by Ctrl-C or SIGTERM: its "Trial N failed with parameters
    ... KeyboardInterrupt()" (with the traceback) and the "Trial N failed with value None." that follows
    it. The command says "interrupted", and a resumed study runs the trial's gains again."""

    def __init__(self) -> None:
        super().__init__()
        self.stopped: set[str] = set()  # numbers of the trials whose first report was dropped

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        number = re.match(r"Trial (\d+) failed with", message)
        exc = record.exc_info[1] if record.exc_info else None
        if isinstance(exc, KeyboardInterrupt) or "KeyboardInterrupt" in message:
            if number:
                self.stopped.add(number.group(1))
            return False
        return not (number and number.group(1) in self.stopped and message.startswith(f"{number.group(0)} value"))


_not_interrupted = _NotInterrupted()


def _settle(study: Any, quiet: bool) -> None:
    """Before counting what is left: enqueue again the gains of the trials an interrupt stopped, fail the
    trials a killed worker left running (their gains are enqueued again) and say so; a live worker's
    running trials are left to it."""
    from optuna.trial import TrialState

    from sim.tools import tune

    requeued = tune.requeue_interrupted(study)
    if requeued and not quiet:
        again = ("was interrupted: its gains are enqueued again", "were interrupted: their gains are enqueued again")
        print(_trials(requeued, *again), file=sys.stderr)
    running = [t.number for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))]
    if not running:
        return
    if not quiet:
        wait = tune.GRACE_PERIOD + tune.HEARTBEAT_INTERVAL + 1
        waiting = (
            f"is running: waiting up to {wait} s for its heartbeat",
            f"are running: waiting up to {wait} s for their heartbeats",
        )
        print(
            f"{_trials(running, *waiting)} (a killed worker's trial is failed and its gains evaluated afresh)",
            file=sys.stderr,
        )
    failed, alive = tune.settle_running(study)
    if not quiet and failed:
        left = (
            "was left by a killed worker: failed, its gains enqueued again",
            "were left by a killed worker: failed, gains enqueued again",
        )
        print(_trials(failed, *left), file=sys.stderr)
    if not quiet and alive:
        beating = ("is still beating: left to its worker", "are still beating: left to their workers")
        print(_trials(alive, *beating), file=sys.stderr)


def _trials(numbers: list[int], one: str, many: str) -> str:
    """``trial #3 ONE``, or ``trials #3, #5 MANY``: the trials ``numbers`` and what is said of them, in the
    singular for one."""
    if len(numbers) == 1:
        return f"trial #{numbers[0]} {one}"
    return f"trials {', '.join(f'#{n}' for n in numbers)} {many}"


def _report_best(study: Any, spec: Any, evaluator: Any) -> tuple[Any, float]:
    """Print the best trial against the default gains; returns it and the defaults' objective."""
    from sim.tools.tune import completed, default_trial, gains_of, shown_url, tuned_space

    trials = completed(study)
    best = min(trials, key=lambda t: (t.value, t.number))
    tuned = gains_of(best, spec.tracker)
    cls, space = tuned_space(spec.tracker)
    dtrial = default_trial(study, spec.tracker)
    default_obj = dtrial.value if dtrial is not None else evaluator.evaluate(cls()).objective
    print(
        f"study {spec.study}: {len(trials)} completed trials ({shown_url(spec.storage)}), each on {len(spec.draws)} "
        f"draw{'s' if len(spec.draws) != 1 else ''} per case"
    )
    print(
        f"best trial #{best.number}: {' '.join(f'{k}={getattr(tuned, k):.4g}' for k in space)} "
        f"objective {best.value:.6f} m; default gains objective {default_obj:.6f} m on the same draws "
        f"(ratio {best.value / default_obj:.3f})"
    )
    return best, float(default_obj)


def _held_out(evaluator: Any, draws: tuple[Any, ...], best: Any) -> Any:
    """Compare tuned and default gains on the held-out draws (none: skipped, None); print the
    table and the verdict."""
    from sim.tools.tune import compare, gains_of

    if not draws:
        return None
    c = compare(evaluator, gains_of(best, evaluator.tracker), draws)
    ratio = c.ratios()
    per_case = f"{len(draws)} draw{'' if len(draws) == 1 else 's'} per case"
    print(f"held-out runs: {c.tuned.runs} ({per_case}: builds and sensor noise no trial met)")
    print(f"{'gains':<14} {'objective [m]':>14} {'rms [m]':>10} {'final [m]':>10} {'saturation':>11} {'failed':>7}")
    rows = [("default", c.default)] if c.defaults_best else [("default", c.default), ("tuned", c.tuned)]
    for label, r in rows:  # the defaults were best: they ran once, nothing to set them against
        print(
            f"{label:<14} {r.objective:>14.6f} {r.rms_m:>10.6f} {r.final_m:>10.6f} {r.saturation:>11.4f} "
            f"{r.failures:>7d}"
        )
    cells = [
        f"{ratio[k]:.3f}x" if math.isfinite(ratio[k]) else "-" for k in ("objective", "rms", "final", "saturation")
    ]
    if not c.defaults_best:
        print(
            f"{'tuned/default':<14} {cells[0]:>14} {cells[1]:>10} {cells[2]:>10} {cells[3]:>11} "
            f"{c.tuned.failures - c.default.failures:>+7d}"
        )
    print(c.verdict())
    return c


def _finite(value: Any, *, drop: bool) -> Any:
    """``value`` with every non-finite float replaced by None (JSON) or its entry dropped (TOML)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        items = {k: _finite(v, drop=drop) for k, v in value.items()}
        return {k: v for k, v in items.items() if not (drop and v is None)}
    if isinstance(value, (list, tuple)):
        return [_finite(v, drop=drop) for v in value]
    return value


def _write_outputs(
    args: argparse.Namespace,
    files: TuneFiles,
    spec: Any,
    study: Any,
    best: Any,
    default_obj: float,
    comparison: Any,
) -> bool:
    """Write the gains file with its provenance, the JSON record and the plots, as one set (each under a
    temporary name, then all moved into place together: an error or an interrupt leaves every old file as it
    was); print what was written.

    Returns:
        Whether the tuned gains lost to the defaults on the held-out draws (the gains file then
        holds the default gains; see :func:`recommendation`).
    """
    from control.gains import GainsFile, dump_gains_toml
    from sim.outputs import staged_outputs, write_json
    from sim.tools.tune import completed, samplers_of

    made = samplers_of(completed(study))  # a study resumed with another --sampler holds trials of each
    gains, verdict = recommendation(best, comparison, spec.tracker)
    provenance: dict[str, Any] = {
        **files.stamp(),
        "tracker": args.tracker,  # the gains file says which tracker its gains were tuned on
        **_scored(study, spec.tracker, best, default_obj, verdict),
        "default_objective": default_obj,
        "scenarios": _tokens(args),
        "robot": spec.extra_settings["robot"] or "each scenario's",
        "trials": len(completed(study)),
        "sampler": " + ".join(made) if set(made) - {UNRECORDED} else args.sampler,
        **({"sampler_trials": made} if len(made) > 1 else {}),
        "seed": args.seed,
        "draws": args.draws,
        "robust": args.robust,
        "saturation_weight": args.saturation_weight,
        "control_rate_hz": args.control_rate,
        "localiser": spec.cases[0].localiser or "each robot's default",
        **{k: v for k, v in spec.cases[0].localiser_options().items() if k != "localiser"},
    }
    held_out = None if comparison is None else comparison.as_dict()
    if held_out is not None:
        summary = {k: held_out[k] for k in ("better", "verdict", "ratios", "default", "tuned")}
        provenance["held_out"] = _finite({"draws": args.eval_runs, **summary}, drop=True)
    provenance.update(verdict)
    written = [files.record]
    record = {
        **provenance,
        "params": asdict(gains),
        "gains": asdict(gains),
        "settings": spec.settings(),
        "held_out": held_out,
    }
    with staged_outputs(overwrite=files.replaceable(args.overwrite)) as stage:  # all or none, as simulate's
        if writes_gains_file(spec.tracker):  # a gains file for 'simulate --gains'; the record serves every tracker
            stage.path(files.gains).write_text(dump_gains_toml(GainsFile(gains, provenance)), encoding="utf-8")
            written.insert(0, files.gains)
        write_json(stage.path(files.record), _finite(record, drop=False))
        plots, notes = _save_plots(study, files, stage)
    for note in notes:
        print(note, file=sys.stderr)
    print("wrote " + ", ".join([*map(str, written), *plots]))
    if verdict["recommended"] == "default":  # in the gains file, or else in the record's "params"
        print(f"{verdict['note']}: wrote the default {type(gains).__name__} to {written[0]}", file=sys.stderr)
    return "tuned_gains" in verdict  # the tuned gains lost on held-out robots (not: no trial beat the defaults)


def _scored(study: Any, tracker: str, best: Any, default_obj: float, verdict: dict[str, Any]) -> dict[str, Any]:
    """The provenance's ``objective`` and ``trial``: those of the gains written, the best trial's, or when the
    tuned gains lost on the held-out draws the defaults' (their trial, the study's first; none when their
    trial did not complete and they were scored afresh): the trial that lost is ``tuned_trial``."""
    from sim.tools.tune import default_trial

    if "tuned_gains" not in verdict:
        return {"objective": float(best.value), "trial": best.number}
    dtrial = default_trial(study, tracker)
    return {"objective": default_obj, **({"trial": dtrial.number} if dtrial is not None else {})}


def recommendation(best: Any, comparison: Any, tracker: str = "") -> tuple[Any, dict[str, Any]]:
    """The gains to write, and provenance saying which gains they are and why.

    The tuned gains are recommended unless they are the defaults (no trial beat them) or the held-out
    comparison finds the defaults better; then the default gains are, and in the second case the
    provenance keeps the tuned gains that lost, their trial and its objective on the trial draws, and their
    held-out objective against the defaults'.

    Args:
        best: The study's best trial.
        comparison: The held-out :class:`sim.tools.tune.Comparison`, or None when skipped.
        tracker: The tuned tracker ("": the FBL gains).

    Returns:
        (gains, provenance entries: ``recommended`` "tuned" or "default", with a ``note`` when "default",
        and when the tuned gains lost also ``tuned_gains``, ``tuned_trial``, ``tuned_objective`` (on the trial
        draws), ``tuned_held_out_objective`` and ``default_held_out_objective`` [m]).
    """
    from sim.tools.tune import gains_of, tuned_space

    tuned = gains_of(best, tracker)
    if comparison is None or comparison.better != "default":
        if tuned == tuned_space(tracker)[0]():
            note = f"the defaults were best (trial #{best.number}): no trial beat them on the trial draws"
            return tuned, {"recommended": "default", "note": note}
        return tuned, {"recommended": "tuned"}
    t, d = comparison.tuned.objective, comparison.default.objective
    note = (
        f"tuned gains (trial #{best.number}) are worse than the defaults on held-out robots: objective "
        f"{t:.6f} m against {d:.6f} m ({comparison.ratios()['objective']:.2f}x)"
    )
    return tuned_space(tracker)[0](), {
        "recommended": "default",
        "tuned_gains": asdict(tuned),
        "tuned_trial": best.number,
        "tuned_objective": float(best.value),
        "tuned_held_out_objective": t,
        "default_held_out_objective": d,
        "note": note,
    }
