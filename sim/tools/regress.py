"""Physics-level regression suite: declared cases, recorded baselines, compared metrics.

A suite file (the repository's is ``tests/regression_suite.toml``) lists cases, one line each, in a ``cases`` array of
inline tables with the fields of :class:`sim.pipeline.case.Case` (scenario, robot, reference or planner,
tracker, seed, control_rate; optional name, gains "KP,KD" or a gains file (as ``nhsim simulate --gains FILE``
reads it, :func:`control.gains.load_gains_file`; a relative path is relative to the suite file, as a scenario
file's is), perturb
"key=value,...", fast, build_seed, sensors, localiser), and a
``[tolerances]`` table ``metric = { abs = A, rel = R }``. A case's name (given, or made of its fields) is
its baseline's file name, so a plain one (:data:`NAME_FORM`). Loading checks every field, and what would
stop every run of a case short of planning (its scenario and robot, control rate, localiser, sensors):
bad input names the file, the case and the field, before any case runs.

Each case is run twice in one process; the two logs must be bitwise identical
(:meth:`RunLog.identical_to`) or the case fails as non-deterministic. Its metrics are compared
with ``<baseline dir>/<case>.json``, which records the case's definition (:func:`case_record`: a baseline
recorded for another definition fails, naming the fields that differ; an older baseline that records fewer
fields is compared on those), the robot's files it ran (:func:`case_model`: a baseline recorded on other files
fails, naming them, in every environment), the metrics and the environment (mujoco and
numpy versions, operating system and machine, and the CPU: vendor, family and model, and the SIMD
extensions numpy dispatches to -- floating-point results differ in their last bits between, say, an
AVX-512 and an AVX2 machine running the same wheels):

- same environment: every metric must be bit-for-bit equal (any change fails, better or worse);
- another environment: a metric fails when it is worse than the baseline by more than
  ``abs + rel * |baseline|`` (error metrics, collisions, warnings, saturation: higher is worse; the NEES
  in bound and a converged localisation: lower is worse; duration, NEES mean, counts: any change beyond the
  tolerance). Every number has a tolerance (:data:`DEFAULT_TOLERANCES`), which a suite's ``[tolerances]`` may
  change.

A planned case plans, smooths and times its scenario through :func:`sim.pipeline.case.prepare_trajectory`.
The suite file and the baseline directory are arguments: the command line passes the repository's.
A baseline that cannot be read, or holds no value (absent, or null) for a metric its case's run measures, is
its case's failure (:attr:`Status.UNREADABLE`), not the run's: the other cases are compared, and ``--update``
replaces it. A metric that is NaN on both sides (a baseline writes NaN as null) has not changed.

Every metric a baseline or the run records is compared, not only those of :data:`DIRECTIONS` (any other
number: any change is a change, within its tolerance); text (``status``,
``estimation_source``) must be equal in every environment. A value that is not finite (NaN, infinite) where the
other side has a value fails (``"not finite"``), and a baseline that holds one as a number (``NaN``,
``Infinity``: nhsim writes NaN as null) is unreadable.
"""

from __future__ import annotations

import fnmatch
import functools
import json
import math
import platform
import re
import tomllib
import zlib
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field, fields
from enum import StrEnum
from importlib import metadata
from pathlib import Path
from typing import Any, TypeGuard, get_type_hints

from control.base import TRACKERS, load_plugins, option_takes
from control.gains import FBLGains, UnstableGainsError, resolve_gains
from planning.core.checks import is_number
from planning.core.files import read_input_text
from planning.core.plugins import PLUGIN_VARIABLE
from planning.core.robot import ROBOTS
from planning.errors import ConfigError, NhsimError, SimulationError, option, without_python
from planning.planners.registry import PLANNERS
from planning.scenario import Scenario, is_builtin_name, load_scenario
from planning.trajectory.references import REFERENCES
from sim.physics.asbuilt import DEFAULT_BUILD_SEED
from sim.physics.lidar import load_lidar_profile
from sim.physics.metrics import EstimationMetrics, TrackingMetrics
from sim.physics.model import robot_timestep
from sim.physics.motors import control_steps
from sim.physics.perturb import Perturbation
from sim.pipeline.case import Case, case_name, load_case_scenario
from sim.pipeline.runs import PLAN_TRACKER, REFERENCE_TRACKER
from sim.pipeline.simulate import prepare_case
from sim.robot.scan_localiser import LOCALISERS

#: Metric -> "lower" (higher is worse) or "equal" (any change is a change).
DIRECTIONS: dict[str, str] = {
    "final_position_error_m": "lower",
    "final_heading_error_rad": "lower",
    "rms_position_error_m": "lower",
    "max_position_error_m": "lower",
    "final_goal_error_m": "lower",
    "collisions": "lower",
    "warnings": "lower",
    "saturation_fraction": "lower",
    "duration_s": "equal",
    "wheel_contact_loss_fraction": "lower",
    "estimation_position_rmse_m": "lower",
    "estimation_heading_rmse_rad": "lower",
    "max_pitch_rad": "lower",  # a balancing robot's (absent for the others)
    "fell": "lower",  # a balancing robot's: True (1) where it stood (0) is a regression
    "estimation_final_position_error_m": "lower",
    "estimation_nees_in_bound_fraction": "higher",
    "estimation_localiser_rmse_m": "lower",
    "estimation_localiser_heading_rmse_rad": "lower",
    "estimation_localiser_nees_in_bound_fraction": "higher",
    "estimation_scans_without_returns": "lower",
    "estimation_localisation_lost": "lower",
    "estimation_global_localisation_scans": "lower",
    "estimation_global_localisation_converged": "higher",
}
#: Every metric a run records (:func:`flat_metrics`): :class:`TrackingMetrics`' fields, the estimator's as
#: ``estimation_<name>``.
METRICS: tuple[str, ...] = (
    *(f.name for f in fields(TrackingMetrics) if f.name != "estimation"),
    *(f"estimation_{f.name}" for f in fields(EstimationMetrics)),
)
#: The metrics that are text ("ok", "fused"): equal in every environment, no tolerance.
TEXT_METRICS: tuple[str, ...] = tuple(
    m
    for m, hint in (
        *get_type_hints(TrackingMetrics).items(),
        *((f"estimation_{k}", v) for k, v in get_type_hints(EstimationMetrics).items()),
    )
    if hint is str
)
#: The metrics that are true or false (a fall, a converged global localisation): any other numeric metric's baseline
#: value is a number, not a boolean.
BOOL_METRICS: frozenset[str] = frozenset(
    m
    for m, hint in (
        *get_type_hints(TrackingMetrics).items(),
        *((f"estimation_{k}", v) for k, v in get_type_hints(EstimationMetrics).items()),
    )
    if hint in (bool, bool | None)
)
#: Metrics whose null in a baseline is a value, not a hole: a statistic of nothing (NaN, written null: the
#: estimator's NEES without a fix compared, the scan localiser's without an update) or an event that did not
#: happen (None: no fall, never lost, start pose known). A run that now has a number there changed; for any
#: other metric the run measures, a null (or absent) value makes the baseline unreadable.
NULLABLE_METRICS = frozenset(
    {
        "fall_time_s",
        "estimation_nees_in_bound_fraction",
        "estimation_nees_mean",
        "estimation_localiser_rmse_m",
        "estimation_localiser_heading_rmse_rad",
        "estimation_localiser_nees_in_bound_fraction",
        "estimation_localiser_nees_mean",
        "estimation_mean_particles",
        "estimation_localisation_lost",
        "estimation_global_localisation_scans",
        "estimation_global_localisation_converged",
    }
)
#: Fields a suite's case table may have.
CASE_KEYS = {
    "scenario",
    "robot",
    "reference",
    "planner",
    "tracker",
    "seed",
    "control_rate",
    "name",
    "gains",
    "perturb",
    "fast",
    "build_seed",
    "sensors",
    "localiser",
}


class NondeterminismError(SimulationError):
    """Two runs of the same case in one process differ."""


@dataclass(frozen=True)
class Tolerance:
    """Allowed move of a metric across environments: ``abs + rel * |baseline|``."""

    abs: float = 0.0
    rel: float = 0.0

    def allowed(self, baseline: float) -> float:
        """The allowed move from ``baseline``."""
        return self.abs + self.rel * abs(baseline)


#: Tolerances of metrics the suite file leaves out.
#: Every number a run records has one: against another environment's baseline only its rounding may move, and a
#: metric left at 0 failed every case on every other machine. Measured by running the repository's suite as
#: another environment (numpy without its AVX-512 kernels, numba compiling for a generic x86-64: ``--all``, 35
#: cases): the TurtleBot3's and the skid EduMIP's metrics moved by 1e-12 of their values at most; the balancing
#: EduMIP's, an unstable plant, by up to 2.7e-4 m (final and max error), 8e-3 rad (heading), 0.013 (saturation,
#: NEES in bound), 0.0065 (NEES mean), 1.4e-3 rad (pitch). These bounds hold them with room, and are what a change
#: must exceed to be seen off the recording machine (there, every change is seen: the comparison is bit for bit).
DEFAULT_TOLERANCES: dict[str, Tolerance] = {
    "final_position_error_m": Tolerance(1e-3, 0.1),
    "final_heading_error_rad": Tolerance(5e-3, 0.1),
    "rms_position_error_m": Tolerance(5e-4, 0.1),
    "max_position_error_m": Tolerance(1e-3, 0.1),
    "final_goal_error_m": Tolerance(1e-3, 0.1),
    "collisions": Tolerance(0, 0),
    "warnings": Tolerance(0, 0),
    "saturation_fraction": Tolerance(0.01, 0.1),
    "duration_s": Tolerance(1e-9, 0),
    "wheel_contact_loss_fraction": Tolerance(1e-3, 0),
    "max_pitch_rad": Tolerance(0.01, 0.1),
    "fell": Tolerance(0, 0),
    "fall_time_s": Tolerance(0.05, 0),
    "estimation_position_rmse_m": Tolerance(5e-4, 0.1),
    "estimation_heading_rmse_rad": Tolerance(2e-3, 0.1),
    "estimation_final_position_error_m": Tolerance(1e-3, 0.1),
    "estimation_nees_in_bound_fraction": Tolerance(0.05, 0),
    "estimation_nees_mean": Tolerance(0.1, 0.1),
    "estimation_fixes_used": Tolerance(2, 0.02),
    "estimation_fixes_widened": Tolerance(2, 0.05),
    "estimation_relocalisations": Tolerance(1, 0),
    "estimation_localiser_rmse_m": Tolerance(5e-4, 0.1),
    "estimation_localiser_heading_rmse_rad": Tolerance(2e-3, 0.1),
    "estimation_localiser_nees_in_bound_fraction": Tolerance(0.05, 0),
    "estimation_localiser_nees_mean": Tolerance(0.1, 0.1),
    "estimation_mean_particles": Tolerance(0, 0.05),
    "estimation_scans_used": Tolerance(2, 0.02),
    "estimation_scans_without_returns": Tolerance(2, 0.02),
    "estimation_scans_cast": Tolerance(1, 0),
    "estimation_localisation_lost": Tolerance(0, 0),
    "estimation_global_localisation_scans": Tolerance(2, 0.1),
    "estimation_global_localisation_converged": Tolerance(0, 0),
}


@dataclass(frozen=True)
class Suite:
    """The declared cases and tolerances."""

    cases: tuple[Case, ...]
    tolerances: dict[str, Tolerance]
    source: Path | None = None
    #: The files the suite reads, each with what names it: the suite file, and each case's scenario and gains
    #: files (``--update`` may not write a baseline over one).
    reads: tuple[tuple[str, Path], ...] = ()

    def select(self, patterns: list[str] | None = None, *, all_cases: bool = False) -> list[Case]:
        """Cases to run: those matching any ``patterns`` (fnmatch on names), else all with
        ``all_cases``, else the fast subset.

        Raises:
            ConfigError: A pattern that matches no case, or (the default) no fast case: a run that
                would check less than asked, and pass.
        """
        if patterns:
            unmatched = [p for p in patterns if not any(fnmatch.fnmatchcase(c.name, p) for c in self.cases)]
            if unmatched:  # a typo beside a good pattern would have run less than asked, and passed
                names = ", ".join(c.name for c in self.cases)
                given = option("case", ",".join(unmatched), python=f"patterns={json.dumps(unmatched)}")
                raise ConfigError(f"{given} matches no case; the suite has: {names}")
            return [c for c in self.cases if any(fnmatch.fnmatchcase(c.name, p) for p in patterns)]
        out = list(self.cases) if all_cases else [c for c in self.cases if c.fast]
        if not out:
            raise ConfigError(
                f"none of the suite's {len(self.cases)} case(s) is marked fast = true, so the default run would check "
                f"nothing; run them all with {option('all', True, python='all_cases=True')}, some with "
                f"{option('case', 'PATTERN', python='patterns=[PATTERN]')}, or mark the quick ones fast = true"
            )
        return out


#: Top-level keys of a suite file.
SUITE_KEYS = ("cases", "tolerances")
#: Case fields whose value is a registry's name: field -> the registry (its names are the allowed values).
CHOICES: dict[str, Collection[str]] = {
    "robot": ROBOTS,
    "reference": REFERENCES,
    "planner": PLANNERS,  # or "" for the scenario's own planner
    "tracker": TRACKERS,
    "localiser": LOCALISERS,
}
#: Case fields that are text, with a valid value of each for messages.
TEXT_EXAMPLES = {
    "scenario": "open",
    "name": "open-turtlebot3-circle-fbl-s0",
    "gains": "9,6",
    "perturb": "mass=1.3",
    "sensors": "fix_rate=10",
}
#: A case name: its baseline is ``<name>.json`` in the baselines folder, so it must be a plain file name.
NAME_FORM = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,199}")
NAME_RULE = "a name may use letters, digits, '.', '_' and '-' (at most 200), starting with a letter or digit"


def _toml(value: Any) -> str:
    """A value as a suite file writes it (``"text"``, ``true``, ``1.5``, ``nan``)."""
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return json.dumps(value, default=str, ensure_ascii=False)


def _as_field(key: str, match: re.Match[str]) -> str:
    """An option's mention (``match``: its value, if any, in group 1) as ``key = value``, as a suite file
    writes it (``key = ...`` without a value)."""
    token = match[1]
    if token is None:
        return f"{key} = ..."
    try:
        float(token)
    except ValueError:
        return f"{key} = {json.dumps(token)}"
    return f"{key} = {token}"


def _suite_terms(message: str) -> str:
    """A message of a parser the command line shares, its options put as the suite's fields:
    ``e.g. --sensors fix_rate=5`` -> ``e.g. sensors = "fix_rate=5"``, ``with --robot`` -> ``with robot = ...``
    (the Python forms beside the options dropped, :func:`planning.errors.without_python`)."""
    message = without_python(message)
    for key in CASE_KEYS:
        flag = "--" + key.replace("_", "-")
        message = re.sub(rf"{flag}(?![\w-])(?: '?([\w.=+@-]+)'?)?", functools.partial(_as_field, key), message)
    return message


def _field_error(where: str, key: str, value: Any, problem: str) -> ConfigError:
    """The error of a case's bad field: the file, the case, the field as written, and what it must be."""
    problem = without_python(problem)
    if isinstance(value, str):  # a parser's echo of the text, said once
        problem = problem.removeprefix(without_python(option(key.replace("_", "-"), value)) + ": ")
    return ConfigError(f"{where}: {key} = {_toml(value)}: {_suite_terms(problem)}")


def _check_name(name: str) -> None:
    """Raise :class:`ConfigError` unless ``name`` is a plain file name (:data:`NAME_FORM`)."""
    if not NAME_FORM.fullmatch(name):
        raise ConfigError(f"not a plain file name for its baseline <name>.json in the baselines folder; {NAME_RULE}")


def _checked(key: str, value: Any, folder: Path = Path()) -> Any:
    """A case field's value as :class:`Case` takes it (``folder``: the suite file's, where a relative gains or
    scenario file is).

    Raises:
        ConfigError: What the field must be (the caller names the file, the case and the field).
    """
    if key in CHOICES:
        names = CHOICES[key]
        if not (isinstance(value, str) and (value in names or (key == "planner" and value == ""))):
            own = ' (or "" for the scenario\'s own planner)' if key == "planner" else ""
            plugin = f", or one a plugin registers ({PLUGIN_VARIABLE}=module)" if key in ("planner", "tracker") else ""
            raise ConfigError(f"unknown {key}; choose one of {', '.join(map(json.dumps, names))}{own}{plugin}")
        return value
    if key in ("seed", "build_seed"):
        if key == "build_seed" and value == "nominal":
            return None  # the robot as drawn
        if not (is_number(value, integer=True) and value >= 0):
            example = f'{DEFAULT_BUILD_SEED}, or "nominal" for the robot as drawn' if key == "build_seed" else "0"
            raise ConfigError(f"must be a whole number >= 0, e.g. {key} = {example}")
        return value
    if key == "control_rate":
        if not (is_number(value) and value > 0):
            raise ConfigError("must be a finite number of Hz > 0, e.g. control_rate = 50")
        return float(value)
    if key == "fast":
        if not isinstance(value, bool):
            raise ConfigError("must be true or false (without quotes)")
        return value
    if not isinstance(value, str):
        raise ConfigError(f"must be text in quotes, e.g. {key} = {json.dumps(TEXT_EXAMPLES[key])}")
    if key == "scenario" and not value.strip():
        raise ConfigError('must name a built-in scenario, random<N> or a scenario file, e.g. scenario = "open"')
    if key == "name":
        _check_name(value)
    if key == "scenario":
        return _scenario_in_suite(value, folder)
    return resolve_gains(value, folder) if key == "gains" else value


def _scenario_in_suite(value: str, folder: Path) -> str | Scenario:
    """A case's scenario: a scenario file (a path ending in ``.toml``, or one naming a file) is read from the
    suite file's ``folder`` when relative (as a gains file is, so a suite and its files move together and run
    from any folder), and the case holds it as read, so its default name and its baseline's record name it
    by the scenario's name, not by where it was found; a built-in name or ``random<N>`` stays as written.

    Raises:
        ConfigError: The file does not exist or is not a scenario (the loader's message).
    """
    p = Path(value)
    if is_builtin_name(value) or not (p.suffix == ".toml" or (folder / p).exists()):
        return value  # a built-in's name is the built-in, whatever lies beside the suite (as load_scenario has it)
    return load_scenario(p if p.is_absolute() else folder / p)


#: The fields a case's default name is made of (:meth:`Case._derived_name`).
NAME_FIELDS = ("scenario", "robot", "reference", "planner", "tracker", "seed", "control_rate")


def _label(entry: Any) -> str:
    """A case as messages name it before it is built: its name (given, or the one its fields make, as
    :class:`Case` makes it), else, when those fields are bad, the fields in short."""
    if not isinstance(entry, dict):
        return "not a table"
    if entry.get("name") and isinstance(entry["name"], str):
        return str(entry["name"])
    try:
        return Case(**{k: _checked(k, entry[k]) for k in NAME_FIELDS if k in entry}).name
    except (ConfigError, TypeError):  # a bad field (an unregistered tracker): the name as the fields make it
        reference, planner = entry.get("reference"), entry.get("planner")
        tracker = entry.get("tracker") or (REFERENCE_TRACKER if reference is not None else PLAN_TRACKER)
        fields = (entry.get("robot"), reference, planner, str(tracker), entry.get("seed", 0))
        return case_name(str(entry.get("scenario", "")), *fields, None, entry.get("control_rate", 50.0))


def _case_from_table(entry: Any, where: str, folder: Path) -> Case:
    """A suite's case table as a :class:`Case`, every field checked (``where`` names the file and the case;
    ``folder`` is the suite file's, where a relative gains or scenario file is).

    Raises:
        ConfigError: A field that is unknown, missing, of the wrong type or not one of its values, naming
            it and what it must be.
    """
    if not isinstance(entry, dict):
        raise ConfigError(f"{where}: a case must be an inline table {{ scenario = ..., ... }}, got {_toml(entry)}")
    unknown = set(entry) - CASE_KEYS
    if unknown:
        raise ConfigError(f"{where}: unknown case field(s) {', '.join(sorted(unknown))}; allowed: {sorted(CASE_KEYS)}")
    if "scenario" not in entry:
        raise ConfigError(f'{where}: the case has no scenario; add scenario = "..." (e.g. scenario = "open")')
    if ("reference" in entry) == ("planner" in entry):
        raise ConfigError(
            f'{where}: give exactly one of reference = "..." (an analytic path: {", ".join(REFERENCES)}) or '
            f'planner = "..." (a plan of the scenario: {", ".join(PLANNERS)})'
        )
    fields_: dict[str, Any] = {}
    for key, value in entry.items():
        try:
            fields_[key] = _checked(key, value, folder)
        except ConfigError as exc:
            raise _field_error(where, key, value, str(exc)) from exc
    if "perturb" in fields_:
        try:
            fields_["perturbation"] = Perturbation.parse(fields_.pop("perturb"), seed=fields_.get("seed", 0))
        except ConfigError as exc:
            raise _field_error(where, "perturb", entry["perturb"], str(exc)) from exc
    fields_.setdefault("localiser", "fixes")  # the suite's cases run on synthetic fixes unless they name amcl
    try:
        case = Case(**fields_)
    except UnstableGainsError as exc:
        raise _field_error(where, "gains", entry.get("gains"), exc.problem) from exc
    except (ConfigError, TypeError) as exc:
        raise ConfigError(f"{where}: {_suite_terms(str(exc))}") from exc
    try:
        _check_name(case.name)  # the default one, made of the fields (a scenario's name may not be plain)
    except ConfigError as exc:
        raise ConfigError(f'{where}: its default name {case.name!r} is {exc}; give the case a name = "..."') from exc
    return case


def _check_case_runs(case: Case, entry: dict[str, Any], where: str) -> None:
    """Refuse, as the suite loads, what would stop every run of a case: the run's own checks
    (:func:`sim.pipeline.simulate.prepare_case`) short of planning.

    Raises:
        ConfigError: An unknown scenario or one without the robot, no planner, a control rate the robot's
            physics cannot keep, amcl for a robot without a laser scanner, bad sensor overrides.
    """
    try:
        scenario = load_case_scenario(case)
    except NhsimError as exc:
        raise _field_error(where, "scenario", entry["scenario"], str(exc)) from exc
    if case.gains is not None and case.tracker is not None and not option_takes(case.tracker, "gains", FBLGains):
        problem = f"tracker {case.tracker!r} takes no FBL gains: they would change nothing in its runs"
        raise _field_error(where, "gains", entry["gains"], f"{problem}; drop gains, or use a tracker that takes them")
    if case.planner == "" and scenario.planner is None:
        names = ", ".join(map(json.dumps, PLANNERS))
        raise _field_error(where, "planner", "", f"scenario {scenario.name!r} names no planner; choose one of {names}")
    try:  # a rate the robot's physics cannot keep is bad input, found before any case runs
        control_steps(case.control_rate, robot_timestep(scenario.robot))
    except ConfigError as exc:
        raise _field_error(where, "control_rate", entry.get("control_rate", case.control_rate), str(exc)) from exc
    if case.localiser == "amcl" and load_lidar_profile(scenario.robot) is None:
        scanned = ", ".join(r for r in ROBOTS if load_lidar_profile(r) is not None)
        problem = f'robot {scenario.robot!r} has no laser scanner to localise with; use localiser = "fixes"'
        raise _field_error(where, "localiser", "amcl", f"{problem}, or a robot with a scanner ({scanned})")
    try:
        case.sensing(scenario)  # the sensor overrides over the robot's profile and the scenario's [sensors]
    except ConfigError as exc:
        if not case.sensors:
            raise ConfigError(f"{where}: {_suite_terms(str(exc))}") from exc
        raise _field_error(where, "sensors", case.sensors, str(exc)) from exc


def _read_suite(p: Path) -> dict[str, Any]:
    """A suite file's TOML (UTF-8; a byte-order mark is dropped).

    Raises:
        ConfigError: Unreadable, not UTF-8, not TOML, or a key beside ``cases`` and ``[tolerances]``.
    """
    try:
        text = read_input_text(p)  # one read (a pipe; a device refused); a byte-order mark (Windows editors) is dropped
    except OSError as exc:
        raise ConfigError(f"cannot read regression suite {p}: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{p}: not UTF-8 text (byte offset {exc.start} is {exc.object[exc.start]:#04x}); "
            "save the suite file as UTF-8"
        ) from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML: {exc}") from exc
    unknown = sorted(set(data) - set(SUITE_KEYS))
    if unknown:
        raise ConfigError(
            f"{p}: unknown key(s) {', '.join(unknown)}; a suite file has a 'cases' array and a [tolerances] table"
        )
    return data


def _tolerances(p: Path, table: Any) -> dict[str, Tolerance]:
    """The default tolerances with a suite's ``[tolerances]`` table over them.

    Raises:
        ConfigError: Not a table, an unknown metric, or a bound that is not a finite number >= 0.
    """
    form = "{ abs = A, rel = R }"
    if not isinstance(table, dict):
        raise ConfigError(f"{p}: tolerances = {_toml(table)}: must be a [tolerances] table of metric = {form}")
    tolerances = dict(DEFAULT_TOLERANCES)
    numeric = [m for m in METRICS if m not in TEXT_METRICS]
    for metric, spec in table.items():
        if metric in TEXT_METRICS:
            raise ConfigError(
                f"{p}: [tolerances] {metric!r} is text, which must be equal in every environment: a tolerance bounds "
                f"a number's move; drop the entry"
            )
        if metric not in numeric:
            raise ConfigError(f"{p}: [tolerances] {metric!r} is not a metric; choose from {', '.join(numeric)}")
        if not (isinstance(spec, dict) and set(spec) <= {"abs", "rel"}):
            raise ConfigError(f"{p}: [tolerances] {metric} = {_toml(spec)}: must be {form}")
        for key, bound in spec.items():
            if not (is_number(bound) and bound >= 0):
                raise ConfigError(
                    f"{p}: [tolerances] {metric} {key} = {_toml(bound)}: must be a finite number >= 0, e.g. "
                    f"{metric} = {{ abs = 1e-3, rel = 0.1 }}"
                )
        tolerances[metric] = Tolerance(float(spec.get("abs", 0.0)), float(spec.get("rel", 0.0)))
    return tolerances


def load_suite(path: str | Path) -> Suite:
    """Read a suite file, checking every case as far as can be without running it.

    Args:
        path: The suite's TOML file.

    Raises:
        ConfigError: Unreadable or malformed file, a bad case (naming the file, the case's number and
            name, the field and what it must be), duplicate case names, bad tolerances.
    """
    p = Path(path)
    data = _read_suite(p)
    load_plugins()  # a plugin that fails is its own error, not the first case's (whose tracker would load it)
    entries = data.get("cases")
    if not isinstance(entries, list) or not entries:
        raise ConfigError(f"{p}: needs a non-empty 'cases' array of inline tables (before any [table])")
    cases = []
    reads = [(f"the suite file {p}", p)]
    for i, entry in enumerate(entries):
        case = _case_from_table(entry, f"{p} case {i + 1} ({_label(entry)})", p.parent)
        _check_case_runs(case, entry, f"{p} case {i + 1} ({case.name})")
        cases.append(case)
        for key in ("scenario", "gains"):  # a value naming a file, read relative to the suite's folder
            value = entry.get(key)
            file = p.parent / value if isinstance(value, str) and value else None
            if file is not None and file.is_file():
                reads.append((f"case {case.name}'s {key} file {value}", file))
    folded = [c.name.lower() for c in cases]  # names differing only in case share a file where case is folded
    dup = sorted({c.name for c in cases if folded.count(c.name.lower()) > 1})
    if dup:
        raise ConfigError(
            f"{p}: duplicate case name(s) {', '.join(dup)}; give each a distinct name = '...' (names differing only "
            "in letter case would share a baseline file where the file system ignores case)"
        )
    return Suite(tuple(cases), _tolerances(p, data.get("tolerances", {})), p, tuple(reads))


@functools.cache
def cpu() -> str:
    """The CPU as far as floating-point results depend on it: vendor, family, model, numpy's SIMD set.

    Read from ``/proc/cpuinfo`` where there is one (Linux), else from :func:`platform.processor`.
    """
    ident = platform.processor() or platform.machine()
    try:
        info: dict[str, str] = {}
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if not line.strip():
                break  # the first processor is enough
            info.setdefault(key.strip(), value.strip())
        if "vendor_id" in info:
            ident = f"{info['vendor_id']} family {info.get('cpu family', '?')} model {info.get('model', '?')}"
    except OSError:
        pass
    try:
        import numpy as np

        features = np._core._multiarray_umath.__cpu_features__  # type: ignore[attr-defined]
        simd = sorted(k for k, on in features.items() if on)
        widest = next((k for k in ("AVX512F", "AVX2", "AVX", "SVE", "ASIMD", "NEON") if k in simd), None)
        ident += f"; {len(simd)} SIMD features" + (f" up to {widest}" if widest else "")
        ident += f" ({zlib.crc32(' '.join(simd).encode()):08x})"
    except (AttributeError, ImportError):
        pass
    return ident


def environment() -> dict[str, str]:
    """What bit-for-bit reproducibility depends on: mujoco and numpy versions, OS, machine and CPU."""
    return {
        "mujoco": metadata.version("mujoco"),
        "numpy": metadata.version("numpy"),
        "platform": f"{platform.system()}-{platform.machine()}",
        "cpu": cpu(),
        "python": platform.python_version(),
    }


def same_environment(a: dict[str, str], b: dict[str, str]) -> bool:
    """True when bit-for-bit equality can be expected (same mujoco, numpy, platform and CPU)."""
    return all(a.get(k) == b.get(k) for k in ("mujoco", "numpy", "platform", "cpu"))


def case_record(case: Case) -> dict[str, Any]:
    """The case's definition as its baseline records it, as JSON reads it back: every field of a suite's case
    that defines the run (not ``fast``), the gains as their values (a gains file's too, so an edit of the file
    is a change of the case; ``xi_min`` beside ``gains``, which older baselines record as ``[kp, kd]``).

    Baselines recorded before ``build_seed``, ``sensors``, ``localiser`` and ``xi_min`` were lack them:
    :func:`definition_changes` compares the fields a baseline records.
    """
    record = {
        "name": case.name,
        "scenario": case.scenario_name,
        "robot": case.robot,
        "reference": case.reference,
        "planner": case.planner,
        "tracker": case.tracker,
        "seed": case.seed,
        "control_rate": case.control_rate,
        "gains": None if case.gains is None else [case.gains.kp, case.gains.kd],
        "xi_min": None if case.gains is None else case.gains.xi_min,
        "perturb": None if case.perturbation is None else case.perturbation.label(),
        "build_seed": case.build_seed,
        "sensors": case.sensors,
        "localiser": case.localiser,
    }
    return dict(json.loads(json.dumps(record)))


def definition_changes(recorded: Mapping[str, Any], case: Case) -> list[str]:
    """How ``case`` differs from the definition its baseline ``recorded`` (:func:`case_record`), as
    ``field old -> new``, on the fields the baseline records."""
    now = case_record(case)
    return [f"{k} {_toml(recorded[k])} -> {_toml(v)}" for k, v in now.items() if k in recorded and recorded[k] != v]


def case_model(case: Case) -> dict[str, Any]:
    """The robot a case runs (its own, else its scenario's) and the digests of the files it is made of
    (:func:`sim.tools.digests.model_digest`: ``digest`` of them all, ``files`` by role), as its baseline records
    them: another machine compares metrics within tolerances, which a change of the robot's model can stay within
    (its base's mass doubled moved the open loop's final error by 0.4 mm of the 5.4 mm allowed), so the baseline
    says which files it was recorded on."""
    from sim.tools.digests import model_digest

    robot = case.robot or load_case_scenario(case).robot
    digests = model_digest(robot)
    return {"robot": robot, "digest": digests["all"], "files": {k: v for k, v in digests.items() if k != "all"}}


def model_change(recorded: object, case: Case) -> str:
    """How the robot's files differ from those the baseline was recorded on (``recorded``: its ``model``), or ""
    (the same, or a baseline that records none): the files edited, by path, where the baseline names them by role."""
    from sim.tools.digests import model_files

    if not isinstance(recorded, dict) or "digest" not in recorded:
        return ""
    now = case_model(case)
    if recorded.get("robot") != now["robot"]:
        return f"robot {recorded.get('robot')} -> {now['robot']}"
    if recorded["digest"] == now["digest"]:
        return ""
    before = recorded.get("files") if isinstance(recorded.get("files"), dict) else {}
    paths = model_files(now["robot"])
    edited = [str(paths[role]) for role, digest in now["files"].items() if before and before.get(role) != digest]
    which = ", ".join(edited) if edited else "its model, scene, sensor settings or balance profile"
    return f"robot {now['robot']}'s files {recorded['digest']} -> {now['digest']} ({which} edited)"


def measure_case(case: Case) -> TrackingMetrics:
    """Prepare and run a case twice from scratch and return its metrics.

    Raises:
        NondeterminismError: The two runs' logs are not bitwise identical.
    """
    run1 = prepare_case(case).run()
    run2 = prepare_case(case).run()
    log1, log2, m1 = run1.log, run2.log, run1.metrics
    if not log1.identical_to(log2) or m1 != run2.metrics:
        a, b = log1.arrays(), log2.arrays()
        differ = [k for k in a if a[k].shape != b[k].shape or a[k].tobytes() != b[k].tobytes()]
        raise NondeterminismError(
            f"case {case.name}: two runs in one process differ (series {', '.join(differ) or 'contacts/warnings'}); "
            f"the simulation is not deterministic -- look for unseeded randomness or state shared between runs"
        )
    return m1


def flat_metrics(m: TrackingMetrics) -> dict[str, Any]:
    """A run's metrics as one flat mapping: the estimator's as ``estimation_<name>``."""
    out = m.as_dict()
    for key, value in (out.pop("estimation", None) or {}).items():
        out[f"estimation_{key}"] = value
    return out


@dataclass(frozen=True)
class Change:
    """One metric that moved.

    Attributes:
        case: Case name.
        metric: Metric name.
        baseline: Baseline value (None: none recorded, or null).
        value: New value (None: none measured).
        allowed: Allowed move (0 in the same environment, and for text).
        status: "regressed", "improved", "changed", "not finite" (failures) or "within" (moved inside tolerance).
    """

    case: str
    metric: str
    baseline: Any
    value: Any
    allowed: float
    status: str

    @property
    def failed(self) -> bool:
        """Whether this change fails the case."""
        return self.status != "within"

    @property
    def delta(self) -> float | None:
        """Now minus baseline, for two numbers (None otherwise)."""
        if _is_number(self.value) and _is_number(self.baseline):
            return float(self.value - self.baseline)
        return None

    @property
    def shown(self) -> tuple[str, str]:
        """The baseline and the new value as text, with as many digits as tell them apart (:func:`show_values`)."""
        return show_values(self.baseline, self.value)


def _show(value: Any, digits: int | None = 6) -> str:
    """A metric's value as text: a number to ``digits`` significant digits (None: Python's shortest form that
    reads back as the same number), text quoted, true or false, none."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if digits is None else f"{value:.{digits}g}"
    return json.dumps(value, default=str, ensure_ascii=False)


def show_values(old: Any, new: Any) -> tuple[str, str]:
    """Two values of a metric as text, short (6 significant digits) unless that shows two different numbers
    alike: then each as Python's shortest form that reads back as itself (up to 17 significant digits)."""
    short = _show(old), _show(new)
    if short[0] == short[1] and old != new:
        return _show(old, None), _show(new, None)
    return short


def _is_number(value: Any) -> TypeGuard[float]:
    """Whether a metric's value is a number (an int, a float or a bool, which compares as 0 or 1)."""
    return isinstance(value, (bool, int, float))


def _is_nan(value: Any) -> bool:
    """Whether a metric's value is NaN (a float NaN, or null: how a baseline writes one)."""
    return value is None or (isinstance(value, float) and math.isnan(value))


def _not_finite(value: Any) -> bool:
    """Whether a metric's value is a number that is not finite (NaN, infinite)."""
    return isinstance(value, float) and not math.isfinite(value)


def _compared(metrics: Mapping[str, Any], baseline: Mapping[str, Any]) -> list[str]:
    """The metrics to compare: every one the run measures, then every other one the baseline records."""
    return [*metrics, *(m for m in baseline if m not in metrics)]


def compare(
    case: str,
    metrics: Mapping[str, Any],
    baseline: Mapping[str, Any],
    tolerances: Mapping[str, Tolerance],
    *,
    exact: bool,
) -> list[Change]:
    """Metrics that differ from the baseline (see the module docstring for the rules): every metric the run
    measures or the baseline records, absent as None."""
    out = []
    for metric in _compared(metrics, baseline):
        new, old = metrics.get(metric), baseline.get(metric)
        if _is_nan(new) and _is_nan(old):  # nothing on either side, or NaN on both: a baseline writes NaN as null
            continue
        if _not_finite(new) or _not_finite(old):  # beside a value: never within a tolerance, nor an improvement
            out.append(Change(case, metric, old, new, 0.0, "not finite"))
            continue
        if new == old and type(new) is type(old):
            continue
        if not (_is_number(new) and _is_number(old)):  # text, or a value on one side only: equal everywhere
            out.append(Change(case, metric, old, new, 0.0, "changed"))
            continue
        if new == old:  # 1 and 1.0, or true and 1: the same number
            continue
        out.append(_moved(case, metric, new, old, tolerances.get(metric, Tolerance()), exact=exact))
    return out


def _moved(case: str, metric: str, new: float, old: float, tolerance: Tolerance, *, exact: bool) -> Change:
    """The change of a number that moved: against the same environment's baseline any move fails; against
    another's, within ``tolerance`` (a metric of :data:`DIRECTIONS` "lower" may fall any amount, one "higher"
    rise any amount)."""
    delta = float(new - old)
    direction = DIRECTIONS.get(metric, "equal")
    worse = delta if direction == "lower" else -delta  # "higher": a fall is the regression
    if exact:
        status = "changed" if direction == "equal" else ("regressed" if worse > 0 else "improved")
        return Change(case, metric, old, new, 0.0, status)
    allowed = tolerance.allowed(old)
    if direction == "equal":
        status = "changed" if abs(delta) > allowed else "within"
    else:
        status = "regressed" if worse > allowed else "within"
    return Change(case, metric, old, new, allowed, status)


class Status(StrEnum):
    """How a case's check ended."""

    PASS = "pass"
    FAIL = "fail"
    MISSING = "missing"  # no baseline
    UNREADABLE = "unreadable"  # a baseline file that is not one
    ERROR = "error"
    NONDETERMINISTIC = "nondeterministic"


@dataclass(frozen=True)
class CheckResult:
    """The result of checking one case against its baseline.

    Attributes:
        case: The case.
        status: How the check ended.
        message: Why (for everything but a clean pass).
        metrics: The metrics measured (empty when not run).
        changes: Metrics that moved against the baseline.
        exact: Compared bit for bit (same environment).
        differs: How the case's definition differs from its baseline's (``field old -> new``).
    """

    case: Case
    status: Status
    message: str = ""
    metrics: Mapping[str, Any] = field(default_factory=dict)
    changes: tuple[Change, ...] = ()
    exact: bool = True
    differs: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """Passed."""
        return self.status is Status.PASS

    @property
    def compared(self) -> bool:
        """Its metrics were compared with a baseline (it passed or failed)."""
        return self.status in (Status.PASS, Status.FAIL)

    @property
    def summary(self) -> str:
        """What the comparison found, for the case's line: how it passed, or what failed it ("" when the case
        was not compared: its message says why)."""
        if self.status is Status.PASS:
            return "bit for bit" if self.exact else "within tolerances"
        if self.status is not Status.FAIL:
            return ""
        parts = [f"case differs: {', '.join(self.differs)}"] if self.differs else []
        moved = [c.metric for c in self.changes if c.failed]
        if moved:
            parts.append(("moved: " if self.exact else "beyond tolerances: ") + ", ".join(moved))
        return "; ".join(parts)


def baseline_path(case: Case, baseline_dir: Path) -> Path:
    """Where a case's baseline lives."""
    return Path(baseline_dir) / f"{case.name}.json"


def _metric_kind(metric: str, value: Any) -> str:
    """What a baseline's metric ``value`` should be and is not ("" when it is one :func:`compare` takes): true or
    false, or null, for a boolean metric (:data:`BOOL_METRICS`); a number, not a boolean, or null, for another
    number; text, or null, for text; a finite number (NaN is written null)."""
    if value is None:
        return ""
    if metric in TEXT_METRICS:
        return "" if isinstance(value, str) else "not text"
    if metric in BOOL_METRICS:
        return "" if isinstance(value, bool) else "not true or false"
    if metric in METRICS:
        if not _is_number(value) or isinstance(value, bool):
            return "not a number"
    elif not isinstance(value, (bool, int, float, str)):
        return "not a number or text"
    return "not finite (a baseline writes NaN as null, and holds no infinity)" if _not_finite(value) else ""


def _baseline_problem(data: Any) -> str:
    """Why a baseline file's JSON is not a baseline ("" when it is one)."""
    if not isinstance(data, dict):
        return f"a JSON {type(data).__name__}, not an object"
    if not isinstance(data.get("metrics"), dict):
        return "no metrics table"
    bad = [key for key in ("case", "environment") if not isinstance(data.get(key, {}), dict)]
    if bad:
        return f"its {', '.join(bad)} not a table"
    kinds: dict[str, list[str]] = {}
    for metric, value in data["metrics"].items():
        kind = _metric_kind(metric, value)
        if kind:
            kinds.setdefault(kind, []).append(metric)
    return "; ".join(f"metric(s) {', '.join(names)} {kind}" for kind, names in kinds.items())


@dataclass(frozen=True)
class Baseline:
    """A case's baseline file as read (:meth:`read`).

    Attributes:
        path: The file.
        document: Its content; None when there is no file or it is not a baseline.
        problem: Why the file is not a baseline ("" when it is one, or there is none).
    """

    path: Path
    document: dict[str, Any] | None = None
    problem: str = ""

    @classmethod
    def read(cls, path: Path) -> Baseline:
        """Read a baseline file: its document, no file, or why it is not a baseline (never raises)."""
        path = Path(path)
        if not path.exists():
            return cls(path)
        if path.is_dir():  # --update cannot write a file over it either: the fix is the user's
            return cls(path, problem=f"it is a folder, where the case's baseline file goes; move or remove {path}")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as exc:
            return cls(path, problem=f"not JSON: {exc}")
        except (OSError, UnicodeDecodeError) as exc:
            return cls(path, problem=f"cannot be read: {getattr(exc, 'strerror', None) or exc}")
        problem = _baseline_problem(data)
        return cls(path, None if problem else data, problem)


def read_baselines(cases: list[Case], baseline_dir: Path) -> dict[str, Baseline]:
    """The cases' baselines by case name, read before any case runs (where the runs are handed out)."""
    return {case.name: Baseline.read(baseline_path(case, baseline_dir)) for case in cases}


def update_hint(case: Case) -> str:
    """The command that records a case's baseline (the command line adds the suite and baselines it was given)."""
    return f"nhsim regress --update --case {case.name}"


def _unrecorded(metrics: Mapping[str, Any], recorded: Mapping[str, Any]) -> list[str]:
    """The metrics a run measured (a finite number, true or false, text) that its baseline does not hold: absent
    there, or null where null is not one of the metric's values (:data:`NULLABLE_METRICS`). An nhsim's baseline
    holds every metric its run measured (null only for a value that was not finite, NaN), so a baseline without
    one was edited, damaged or written by something else: it cannot be compared with."""
    measured = [m for m, v in metrics.items() if v is not None and not _not_finite(v)]
    return [m for m in measured if m not in recorded or (recorded[m] is None and m not in NULLABLE_METRICS)]


def baseline_problem(base: Baseline, metrics: Mapping[str, Any]) -> str:
    """Why ``base`` cannot be compared with a run that measured ``metrics`` ("" when it can, or there is none):
    it is not a baseline (:attr:`Baseline.problem`), or it holds no value for a metric the run measured."""
    if base.problem or base.document is None:
        return base.problem
    holes = _unrecorded(metrics, base.document["metrics"])
    return f"no value for metric(s) {', '.join(holes)}: missing or null" if holes else ""


def judge(case: Case, metrics: dict[str, Any], base: Baseline, tolerances: dict[str, Tolerance]) -> CheckResult:
    """A measured case's result against its baseline (see the module docstring for the rules)."""
    problem = baseline_problem(base, metrics)
    if problem:
        fix = "then record it" if base.path.is_dir() else "rewrite it"
        problem = f"baseline {base.path} is unreadable ({problem}); {fix} with {update_hint(case)}"
        return CheckResult(case, Status.UNREADABLE, f"case {case.name}: {problem}", metrics)
    if base.document is None:
        hint = f"record it with {update_hint(case)}"
        return CheckResult(case, Status.MISSING, f"case {case.name}: no baseline {base.path}; {hint}", metrics)
    exact = same_environment(base.document.get("environment", {}), environment())
    model = model_change(base.document.get("model"), case)
    differs = tuple(definition_changes(base.document.get("case", {}), case)) + ((model,) if model else ())
    changes = tuple(compare(case.name, metrics, base.document["metrics"], tolerances, exact=exact))
    failed = [c for c in changes if c.failed]
    if not (failed or differs):
        return CheckResult(case, Status.PASS, "", metrics, changes, exact)
    what = [f"its definition differs from its baseline's: {', '.join(differs)}"] if differs else []
    if failed:
        moved = ", ".join(f"{c.metric} {c.status} ({' -> '.join(c.shown)})" for c in failed)
        what.append(f"{moved} [{'bit for bit' if exact else 'with tolerances'}]")
    message = f"case {case.name}: {'; '.join(what)}; if intended, record it with {update_hint(case)}"
    return CheckResult(case, Status.FAIL, message, metrics, changes, exact, differs)


def check_case(
    case: Case,
    baseline_dir: Path,
    tolerances: dict[str, Tolerance] | None = None,
    baseline: Baseline | None = None,
) -> CheckResult:
    """Run a case (twice, for determinism) and compare it with its baseline.

    Args:
        case: The case.
        baseline_dir: Directory of the baselines (``<case name>.json``).
        tolerances: Metric -> tolerance against a baseline of another environment (default:
            ``DEFAULT_TOLERANCES``).
        baseline: The case's baseline as read already (:func:`read_baselines`); None: read it here.
    """
    tolerances = tolerances if tolerances is not None else DEFAULT_TOLERANCES
    try:
        metrics = flat_metrics(measure_case(case))
    except NondeterminismError as exc:
        return CheckResult(case, Status.NONDETERMINISTIC, str(exc))
    except NhsimError as exc:
        msg = str(exc) if case.name in str(exc) else f"case {case.name}: {exc}"
        return CheckResult(case, Status.ERROR, msg)
    base = baseline if baseline is not None else Baseline.read(baseline_path(case, baseline_dir))
    return judge(case, metrics, base, tolerances)


def check_task(shared: tuple[Path, dict[str, Tolerance] | None, Mapping[str, Baseline]], case: Case) -> CheckResult:
    """:func:`check_case` as an executor's task: ``shared`` is (baseline folder, tolerances, the baselines
    read by case name), so that a task reads no file."""
    baseline_dir, tolerances, baselines = shared
    return check_case(case, baseline_dir, tolerances, baselines[case.name])


def baseline_document(case: Case, metrics: dict[str, Any]) -> dict[str, Any]:
    """The JSON content of a baseline."""
    return {"case": case_record(case), "model": case_model(case), "metrics": metrics, "environment": environment()}
