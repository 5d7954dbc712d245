"""The tracker interface, the registry of trackers by name, and checks for their option dataclasses."""

from __future__ import annotations

import copy
import dataclasses
import difflib
import inspect
import math
import re
import typing
from collections.abc import Callable
from typing import Any, Protocol, TypeVar

from planning.core.checks import check_fields, check_number, is_number
from planning.core.plugins import BUILT_IN as BUILT_IN  # re-exported: who registered a tracker
from planning.core.plugins import BY_CODE as BY_CODE
from planning.core.plugins import PLUGIN_VARIABLE as PLUGIN_VARIABLE
from planning.core.plugins import RegistrationError, Registry, check_registration
from planning.core.robot import RobotSpec
from planning.errors import ConfigError, SimulationError
from planning.trajectory.trajectory import Trajectory

T = TypeVar("T")


class Tracker(Protocol):
    """A feedback (or feed-forward) law with explicit state.

    The simulator calls ``reset`` once, then ``command`` at the control rate with the measured
    pose, and holds the returned (v, omega) until the next call. A tracker is built as
    ``factory(robot, **options)`` with keyword-only options (see :func:`make_tracker`).
    """

    @property
    def name(self) -> str:
        """The tracker's registered name, e.g. ``"fbl"``. Read-only here, so a class attribute
        (``name = "p-pose"``, as the built-in trackers set it), an instance attribute or a property
        all satisfy the protocol under ``mypy --strict``."""
        ...

    def reset(self, trajectory: Trajectory, dt: float) -> None:
        """Start tracking ``trajectory`` with control period ``dt`` [s], in (0, 1] (seconds, not milliseconds:
        0.02 for 50 Hz; :func:`check_period`)."""
        ...

    def command(self, t: float, x: float, y: float, theta: float) -> tuple[float, float]:
        """Body command (v [m/s], omega [rad/s]) at time ``t`` [s] for the measured pose."""
        ...


#: The entry-point group of tracker plugins. An installed package declares in it a tracker,
#: ``p-pose = "mypkg.pose_p:PoseP"`` (registered by that name, its module imported when first used), or a
#: module whose import registers its trackers, ``mypkg = "mypkg.trackers"`` (imported when the plugins load).
PLUGIN_GROUP = "nhsim.trackers"

#: The registry of trackers by name; the factory is called as factory(robot, **keyword-only options). The CLI
#: (compare, bench track, tune), the registry-wide tests and the fuzz suite enumerate it: registering a
#: tracker is all it takes to appear there. Its plugins (:mod:`planning.core.plugins`) load at its first
#: lookup of a name, listing or count, so a command that resolves none (``nhsim --version``) imports none.
TRACKERS: Registry[Tracker] = Registry(
    "tracker",
    PLUGIN_GROUP,
    {
        "fbl": "control.fbl:DynamicFBL",
        "kanayama": "control.kanayama:KanayamaTracker",
        "mpc": "control.mpc:MPCTracker",
        "open-loop": "control.open_loop:OpenLoop",
        "rpp": "control.rpp:RegulatedPurePursuit",
        "segmented": "control.segmented:SegmentedTracker",
    },
)

#: Registered names without feedback (baselines): not compared by default, not held to the robot's limits.
BASELINES: set[str] = {"open-loop"}


def register_tracker(
    name: str, target: str | Callable[..., Tracker], *, baseline: bool = False, replace: bool = False
) -> None:
    """Register a tracker by name: its factory (a class), or its import path, e.g. ``"control.fbl:DynamicFBL"``.

    Args:
        name: The tracker's name (``--trackers``, ``--tracker``, the run records): non-empty text without
            commas or whitespace.
        target: The factory, called as ``factory(robot, **keyword-only options)``, or "module:attr"
            (imported when first used).
        baseline: A player without feedback (like "open-loop"): left out of ``compare``'s default set
            and not held to the robot's limits by the tests.
        replace: Replace a tracker already registered under ``name`` (a built-in one too). Not needed for a
            redefinition of the registered class (the same module and qualified name: a notebook cell that
            defines and registers it, run again), which replaces it (:func:`planning.core.plugins.redefines`).

    Raises:
        ConfigError: A bad name or target, a factory whose ``TUNED`` names an option it does not take
            (:func:`check_tuned`), or a name taken by another target without ``replace``.
    """
    check_registration(
        "register_tracker",
        name,
        target,
        kind="tracker",
        flag="--trackers A,B",
        examples=("p-pose", "mypackage.pose_p:PoseP"),
    )
    if not isinstance(baseline, bool):
        raise RegistrationError(f"register_tracker({name!r}): baseline must be True or False", "tracker")
    if not isinstance(target, str):
        check_tuned(f"register_tracker({name!r})", target)
    TRACKERS.add("register_tracker", name, target, replace)
    if baseline:
        BASELINES.add(name)
    else:
        BASELINES.discard(name)


def check_tuned(what: str, factory: Callable[..., Any]) -> None:
    """A tracker factory's ``TUNED = (option, dataclass)`` (what ``nhsim tune --tracker`` tunes), checked: a pair
    whose option is one of the factory's keyword options. None (or no ``TUNED``): nothing to tune.

    Args:
        what: Who is checked, for the message ("register_tracker('p-pose')").
        factory: The tracker's factory (class).

    Raises:
        RegistrationError: ``TUNED`` is not a pair (option name, dataclass), or names an option the factory does
            not take (the message names it, the options it takes and the likeliest one).
    """
    tuned = getattr(factory, "TUNED", None)
    if tuned is None:
        return
    if not (isinstance(tuned, tuple) and len(tuned) == 2 and isinstance(tuned[0], str)):
        raise RegistrationError(
            f"{what}: TUNED must be the pair (option, dataclass) that nhsim tune tunes, e.g. ('gains', PoseGains); got "
            f"{tuned!r:.80}",
            "tracker",
        )
    try:
        params = inspect.signature(factory).parameters.values()
    except (TypeError, ValueError):  # a factory whose signature cannot be read: checked when made
        return
    options = [p.name for p in params if p.kind is inspect.Parameter.KEYWORD_ONLY]
    option, cls = tuned
    if option not in options:
        shown = getattr(cls, "__name__", repr(cls))
        near = difflib.get_close_matches(option, options, n=1) or options[:1]
        fix = f"name the option it is given as, e.g. TUNED = ({near[0]!r}, {shown})" if near else "give it one"
        raise RegistrationError(
            f"{what}: TUNED = ({option!r}, {shown}) names option {option!r}, which "
            f"{getattr(factory, '__qualname__', factory)!s} does not take (its keyword options: "
            f"{', '.join(options) or 'none'}); {fix}",
            "tracker",
        )


def tracker_origin(name: str) -> str:
    """Who registered tracker ``name``: :data:`BUILT_IN`, :data:`BY_CODE` (also a name set in
    :data:`TRACKERS` directly), or "from " the plugin (entry point or :data:`PLUGIN_VARIABLE`'s module)."""
    return TRACKERS.origin(name)


def in_every_process(name: str) -> bool:
    """Whether a fresh Python process (a worker of ``nhsim tune --jobs``) knows tracker ``name`` too: a
    built-in tracker or a plugin's; not one registered by a call of the program's own code."""
    return TRACKERS.in_every_process(name)


def load_plugins() -> None:
    """Load the tracker plugins, once per process (:meth:`planning.core.plugins.Registry.load_plugins`).

    Raises:
        ConfigError: A plugin failed to import or to register.
    """
    TRACKERS.load_plugins()


def feedback_trackers() -> tuple[str, ...]:
    """The registered trackers with feedback (every one but the baselines), in registration order."""
    return tuple(name for name in TRACKERS if name not in BASELINES)


def tracker_factory(name: str) -> Callable[..., Tracker]:
    """The factory (class) of a registered tracker.

    Raises:
        ConfigError: Unknown name (lists the valid ones).
    """
    return TRACKERS.factory(name)


def tracker_options(name: str) -> tuple[str, ...]:
    """The keyword options a registered tracker takes (besides the robot), in signature order.

    Raises:
        ConfigError: Unknown name (lists the valid ones).
    """
    params = inspect.signature(TRACKERS.factory(name)).parameters.values()
    return tuple(p.name for p in params if p.kind is inspect.Parameter.KEYWORD_ONLY)


def option_takes(name: str, option: str, kind: type) -> bool:
    """Whether a registered tracker takes keyword option ``option`` declared to hold a ``kind``: its
    annotation is ``kind`` or a union with it (``gains: FBLGains | None``). An option without an
    annotation, or one that cannot be resolved, is compared by the names it spells.

    Raises:
        ConfigError: Unknown name (lists the valid ones).
    """
    factory = TRACKERS.factory(name)
    param = inspect.signature(factory).parameters.get(option)
    if param is None or param.kind is not inspect.Parameter.KEYWORD_ONLY:
        return False
    try:
        declared = typing.get_type_hints(factory.__init__ if inspect.isclass(factory) else factory)[option]
    except Exception:  # an annotation naming what its module does not define at run time
        return kind.__name__ in re.findall(r"\w+", str(param.annotation))
    return declared is kind or kind in typing.get_args(declared)


def tuned_or_none(name: str) -> tuple[str, type] | None:
    """The option of a registered tracker that ``nhsim tune --tracker`` tunes, and its dataclass; None for a
    tracker with nothing to tune.

    A tracker declares it as the class attribute ``TUNED = (option, dataclass)``, e.g.
    ``("params", MPCParams)``.

    Raises:
        ConfigError: Unknown name (lists the valid ones), or a ``TUNED`` naming an option the tracker does not take
            (:func:`check_tuned`).
    """
    factory = TRACKERS.factory(name)
    tuned = getattr(factory, "TUNED", None)
    if tuned is not None:  # registered by its import path (or set directly): checked as register_tracker does
        check_tuned(f"tracker {name!r} ({TRACKERS.origin(name)})", factory)
    return tuned  # type: ignore[no-any-return]


def tuned_option(name: str) -> tuple[str, type]:
    """:func:`tuned_or_none` of a tracker that has parameters to tune.

    Raises:
        ConfigError: As :func:`tuned_or_none`, and a tracker with nothing to tune (naming those that have).
    """
    tuned = tuned_or_none(name)
    if tuned is None:
        with_params = [n for n in sorted(TRACKERS) if getattr(TRACKERS.factory(n), "TUNED", None) is not None]
        raise ConfigError(f"tracker {name!r} has no parameters to tune; choose one of {', '.join(with_params)}")
    return tuned


def make_tracker(name: str, robot: RobotSpec, **options: Any) -> Tracker:
    """Instantiate a registered tracker for a robot.

    Args:
        name: A key of :data:`TRACKERS`.
        robot: The robot whose limits the commands respect.
        **options: The tracker's keyword options (see :func:`tracker_options`).

    Raises:
        ConfigError: Unknown name (lists the valid ones), an option the tracker does not take (names
            it and lists the valid ones) or a bad option value (a parameter dataclass's :func:`ranged` field out of
            its range too: :func:`check_option_ranges`).
    """
    factory = TRACKERS.factory(name)
    if not isinstance(robot, RobotSpec):
        raise ConfigError(f"tracker {name!r}: robot must be a RobotSpec (load_robot('turtlebot3')), got {robot!r}")
    valid = tracker_options(name)
    unknown = [key for key in options if key not in valid]
    if unknown:
        raise ConfigError(
            f"tracker {name!r}: unknown option(s) {', '.join(map(repr, unknown))}; "
            f"valid options: {', '.join(valid) or '(none)'}"
        )
    for option, value in options.items():
        check_option_ranges(name, option, value)
    return factory(robot, **options)


def option_value(tracker: str, option: str, value: T | None, default: T) -> T:
    """A tracker option checked to be of its default's type; None gives the default.

    Raises:
        ConfigError: ``value`` is neither None nor of the default's type, or is a parameter dataclass with a
            :func:`ranged` field out of its range (:func:`check_option_ranges`).
    """
    if value is None:
        return default
    kind = type(default)
    if not isinstance(value, kind):
        raise ConfigError(
            f"tracker {tracker!r}: option {option} must be an instance of {kind.__name__} (e.g. {default!r}), "
            f"or None for that default; got {type(value).__name__}"
        )
    check_option_ranges(tracker, option, value)
    return value


def check_option_ranges(tracker: str, option: str, value: object) -> None:
    """Check a tracker option's :func:`ranged` fields (a parameter dataclass's) against their ranges, whether or
    not its ``__post_init__`` calls :func:`check_ranges` (a misspelt ``__post_init__`` is never called). The
    value itself is left as it is (checked on a copy). Anything else passes.

    Raises:
        ConfigError: A ranged field is not a number, not finite or out of its range (names the tracker, the option
            and the field, e.g. ``tracker 'p-pose': option gains: PoseGains.k_along must be ...``).
    """
    if not dataclasses.is_dataclass(value) or isinstance(value, type):
        return
    if not any("range" in f.metadata for f in dataclasses.fields(value)):
        return
    try:
        check_ranges(copy.copy(value))
    except ConfigError as exc:
        raise ConfigError(f"tracker {tracker!r}: option {option}: {exc}") from exc


def check_positive_fields(obj: object, names: tuple[str, ...], why: str) -> None:
    """Check that the named fields of a frozen dataclass are finite numbers > 0; store them as floats.

    Args:
        obj: The dataclass instance (from its ``__post_init__``).
        names: The fields to check.
        why: What needs them positive, appended to the message.

    Raises:
        ConfigError: A field is not a number (a bool is not), not finite, or not > 0; the message
            names it, e.g. ``FBLGains.kp``.
    """
    check_fields(obj, {name: {"above": 0.0, "fix": why} for name in names}, f"{type(obj).__name__}.")


#: Most control periods a tracker pre-samples its reference at (a day at 10 Hz, 5.6 h at 50 Hz).
MAX_CONTROL_PERIODS = 1_000_000
#: Longest control period [s] a tracker's ``reset`` takes: that of the slowest control rate the simulator runs,
#: 1 Hz (``sim.physics.motors.MIN_CONTROL_RATE``; nhsim itself uses 0.005 to 0.1 s). A longer one is most likely
#: milliseconds given as seconds (``dt=20`` for 20 ms).
MAX_CONTROL_PERIOD = 1.0


def check_period(tracker: str, dt: float, trajectory: Trajectory) -> float:
    """The control period ``dt`` [s] given to a tracker's ``reset``, as a float.

    Args:
        tracker: The tracker's name, for the message.
        dt: The control period [s].
        trajectory: The reference the tracker pre-samples at every control instant of its span.

    Raises:
        ConfigError: ``dt`` is not a finite number > 0, is longer than ``MAX_CONTROL_PERIOD`` (1 s: likely
            milliseconds given as seconds), or is so small that the trajectory would span more than
            ``MAX_CONTROL_PERIODS`` control periods (names the tracker).
    """
    fix = "pass 1 / control rate, e.g. 0.02 for 50 Hz"
    dt = check_number(f"tracker {tracker!r}: reset(dt)'s control period dt", dt, above=0.0, unit="s", fix=fix)
    if dt > MAX_CONTROL_PERIOD:
        raise ConfigError(
            f"tracker {tracker!r}: reset(dt)'s control period dt must be at most {MAX_CONTROL_PERIOD:g} s (a control "
            f"rate of 1 Hz or more), got {dt:g} s; dt is in seconds, not milliseconds: {fix} (not 20)"
        )
    periods = trajectory.duration / dt
    if not periods <= MAX_CONTROL_PERIODS:
        raise ConfigError(
            f"tracker {tracker!r}: reset(dt={dt:g} s) over the trajectory's {trajectory.duration:.6g} s makes "
            f"{periods:.3g} control periods (at most {MAX_CONTROL_PERIODS}); pass a longer period, e.g. 0.02 for 50 Hz"
        )
    return float(dt)


def check_measured_pose(tracker: str, t: float, x: float, y: float, theta: float) -> None:
    """Refuse a non-finite time or measured pose given to a tracker's ``command``.

    Every tracker calls this first (the open-loop player too, which ignores the pose), so a NaN from a
    sensor or an estimator stops the run with the same error in every tracker, never a silent stop, a
    non-finite command or a Python error.

    Raises:
        SimulationError: ``t``, ``x``, ``y`` or ``theta`` is NaN or infinite (names the tracker and t).
    """
    if not math.isfinite(t + x + y + theta):
        raise SimulationError(
            f"tracker {tracker!r} was given a non-finite pose (x={x}, y={y}, theta={theta}) at t={t:.3f} s: "
            "the measured or estimated pose diverged"
        )


def ranged(default: float, low: float, high: float, unit: str, *, tune: tuple[float, float] | None = None) -> Any:
    """A parameter field with its valid range [low, high] and, if tuned, its search range.

    Use in a frozen parameter dataclass checked by :func:`check_ranges`; an int default makes an
    integer parameter (e.g. a horizon length).

    Args:
        default: Default value.
        low: Smallest valid value.
        high: Largest valid value.
        unit: Unit for messages, e.g. "1/s" ("" for a pure number).
        tune: (a, b) searched log-uniformly by ``nhsim tune --tracker``; None: not tuned. The search is
            log-uniform, so 0 < a < b; the range lies within [low, high] and holds the default (the
            defaults are the study's first trial); an integer parameter is not tuned.

    Raises:
        ConfigError: A ``tune`` range that cannot be searched (:func:`check_search_range`); the message
            names the call, as the field's name is not known here (:func:`search_space` names it).
    """
    if tune is not None:
        call = f"ranged({default!r}, {low!r}, {high!r}, {unit!r}, tune={tune!r})"
        tune = check_search_range(call, default, (low, high), tune)
    return dataclasses.field(default=default, metadata={"range": (low, high), "unit": unit, "tune": tune})


def check_search_range(name: str, default: Any, valid: tuple[float, float], tune: Any) -> tuple[float, float]:
    """A tuned parameter's search range ``tune``, checked: ``nhsim tune`` samples it log-uniformly and runs
    the default first, so Optuna would refuse (with a traceback, in the study's first trial) a low end of 0
    or a default outside it.

    Args:
        name: What the message names, e.g. ``"PoseGains.k_along"``.
        default: The parameter's default (an int: an integer parameter, which is not tuned).
        valid: Its valid range [low, high].
        tune: The search range, (a, b).

    Returns:
        (a, b) as floats.

    Raises:
        ConfigError: ``tune`` is not two finite numbers with 0 < a < b within ``valid``, ``default`` is not in
            [a, b], or the parameter is an integer; the message names ``name`` and the fix.
    """
    fix = "the search is log-uniform: give tune=(a, b) with 0 < a < b"
    pair = tuple(tune) if isinstance(tune, (tuple, list)) else ()
    if len(pair) != 2 or not all(is_number(v) for v in pair):
        raise ConfigError(f"{name}: tune must be two finite numbers (a, b), got {tune!r}; {fix}")
    a, b = float(pair[0]), float(pair[1])
    if not 0.0 < a < b:
        example = f", e.g. tune=({b / 100:g}, {b:g})" if b > 0 else ""
        raise ConfigError(f"{name}: cannot search tune=({a:g}, {b:g}); {fix}{example}")
    low, high = valid
    if a < low or b > high:
        inside = (max(a, low), min(b, high))
        example = f", e.g. tune=({inside[0]:g}, {inside[1]:g})" if inside[0] < inside[1] else ""
        raise ConfigError(
            f"{name}: tune=({a:g}, {b:g}) reaches outside the valid range [{low:g}, {high:g}]; give a search range "
            f"within it{example} ({fix})"
        )
    if isinstance(default, int) and not isinstance(default, bool):
        raise ConfigError(
            f"{name}: an integer parameter cannot be tuned (the search draws real numbers); leave tune= out, or "
            "make it a float parameter with a float default"
        )
    first = "nhsim tune runs the defaults as its first trial"
    if not (is_number(default) and default > 0):
        raise ConfigError(
            f"{name}: the default {default!r} lies outside every search range and {first}; the search is "
            "log-uniform (tune=(a, b) with 0 < a < b), so give a default > 0 inside tune=(a, b), or leave tune= out"
        )
    if not a <= default <= b:
        raise ConfigError(
            f"{name}: the default {default!r} lies outside tune=({a:g}, {b:g}) and {first}; widen the search range "
            f"to hold it, e.g. tune=({min(a, default):g}, {max(b, default):g}), or change the default"
        )
    return a, b


def check_ranges(obj: object) -> None:
    """Check every :func:`ranged` field of a frozen dataclass; store floats as floats.

    Raises:
        ConfigError: A field is not a number (a bool is not; an integer parameter needs an int), not
            finite, or outside its range; the message names it (``MPCParams.horizon``), the range and
            the unit.
    """
    limits: dict[str, dict[str, Any]] = {}
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        if "range" in f.metadata:
            (low, high), unit, integer = f.metadata["range"], f.metadata["unit"], isinstance(f.default, int)
            limits[f.name] = dict(at_least=low, at_most=high, unit=unit, integer=integer, fix="choose a value in range")
    check_fields(obj, limits, f"{type(obj).__name__}.")


def search_space(cls: type) -> dict[str, tuple[float, float]]:
    """The tuned fields of a parameter dataclass and their search ranges (see :func:`ranged`), each checked
    (:func:`check_search_range`, naming the field); {} when no field is tuned.

    Raises:
        ConfigError: ``cls`` is not a dataclass, or a tuned field's search range cannot be searched.
    """
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        raise ConfigError(
            f"the parameters to tune must be a dataclass whose tuned fields are ranged(..., tune=(a, b)), got {cls!r}"
        )
    space: dict[str, tuple[float, float]] = {}
    for f in dataclasses.fields(cls):
        if f.metadata.get("tune") is not None:
            valid = f.metadata.get("range", (-math.inf, math.inf))
            space[f.name] = check_search_range(f"{cls.__name__}.{f.name}", f.default, valid, f.metadata["tune"])
    return space
