"""The registry of planners by name: what the CLI, the scenario files and the tests enumerate.

A built-in planner is registered as ``"module:factory"``; the module is imported only when the planner is
made, so listing the planners imports none of them. A factory takes keyword-only options: either named keyword
parameters, or ``**options`` checked against the fields of the dataclass in its ``config_class``
attribute. A planner of your own is registered with :func:`register_planner`, or by a plugin
(:mod:`planning.core.plugins`; docs/how-to/new-planner.md).
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from planning.core.plugins import Registry, check_registration
from planning.errors import ConfigError
from planning.planners.base import Planner

ConfigT = TypeVar("ConfigT")


#: The entry-point group of planner plugins. An installed package declares in it a planner,
#: ``ttt = "mypkg.ttt:TurnDriveTurn"`` (registered by that name, its module imported when first made), or a module
#: whose import registers its planners, ``mypkg = "mypkg.planners"`` (imported when the plugins load).
PLUGIN_GROUP = "nhsim.planners"

#: Planner name -> its factory, or "module:factory" imported when the planner is first made. The factory takes
#: keyword-only options and returns a Planner. Its plugins (:mod:`planning.core.plugins`) load at its first
#: lookup of a name, listing or count.
PLANNERS: Registry[Planner] = Registry(
    "planner",
    PLUGIN_GROUP,
    {
        "rrt": "planning.planners.sampling.rrt:RRT",
        "birrt": "planning.planners.sampling.rrt:BiRRT",
        "rrt-star": "planning.planners.sampling.rrt_star:RRTStar",
        "c-rrt-star": "planning.planners.sampling.crrt_star:CRRTStar",
        "sinusoidal": "planning.planners.sinusoidal:Sinusoidal",
        "optim": "planning.planners.optim:Optim",
        "hybrid-a-star": "planning.planners.hybrid_astar:HybridAStar",
    },
)


def register_planner(name: str, target: str | Callable[..., Planner], *, replace: bool = False) -> None:
    """Register a planner by name: its factory (a class), or its import path, e.g. ``"mypackage.ttt:TurnDriveTurn"``.

    A call registers it in the running process: :func:`make_planner`, ``simulate_plan(planner=...)`` and
    ``sim.cli.main.main([...])`` called from it see the planner. For the ``nhsim`` command (and fresh worker
    processes) to see it, make the registration a plugin: an entry point of group ``nhsim.planners``
    (:data:`PLUGIN_GROUP`) in an installed package, or a module named by ``NHSIM_PLUGINS``
    (docs/how-to/new-planner.md).

    Args:
        name: The planner's name (``--planner``, a scenario's ``planner``, the run records): non-empty
            text without commas or whitespace.
        target: The factory, called as ``factory(**keyword-only options)`` and returning a
            :class:`~planning.planners.base.Planner`, or "module:attr" (imported when first made).
        replace: Replace a planner already registered under ``name`` (a built-in one too). Not needed for a
            redefinition of the registered class (the same module and qualified name: a notebook cell that
            defines and registers it, run again), which replaces it (:func:`planning.core.plugins.redefines`).

    Raises:
        ConfigError: A bad name or target, or a name taken by another target without ``replace``.
    """
    check_registration(
        "register_planner",
        name,
        target,
        kind="planner",
        flag="--planner NAME",
        examples=("ttt", "mypackage.ttt:TurnDriveTurn"),
    )
    PLANNERS.add("register_planner", name, target, replace)


def planner_options(name: str) -> tuple[str, ...]:
    """The keyword options a registered planner accepts, sorted.

    They are the factory's named keyword parameters and, when it also takes ``**options``, the
    fields of its ``config_class`` dataclass.

    Raises:
        ConfigError: Unknown planner name (the message lists the valid ones).
    """
    factory = PLANNERS.factory(name)
    params = inspect.signature(factory).parameters.values()
    names = {p.name for p in params if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)}
    config_class = getattr(factory, "config_class", None)
    if any(p.kind is p.VAR_KEYWORD for p in params) and dataclasses.is_dataclass(config_class):
        names |= {f.name for f in dataclasses.fields(config_class) if f.init}
    return tuple(sorted(names))


def config_from_options(
    config_class: type[ConfigT], options: Mapping[str, Any], base: ConfigT | None = None
) -> ConfigT:
    """A planner's configuration dataclass from keyword options.

    Args:
        config_class: The dataclass.
        options: Field values; the others keep their defaults (or ``base``'s values).
        base: A configuration to start from (default: ``config_class()``).

    Raises:
        ConfigError: An option that is not a field (the message lists the valid ones), a value the
            dataclass rejects, or a ``base`` that is not a ``config_class``.
    """
    names = [f.name for f in dataclasses.fields(config_class) if f.init]  # type: ignore[arg-type]
    unknown = sorted(set(options) - set(names))
    if unknown:
        raise ConfigError(f"unknown option(s) {', '.join(unknown)}: valid options are {', '.join(sorted(names))}")
    if base is None:
        return config_class(**options)
    if not isinstance(base, config_class):
        raise ConfigError(
            f"config must be a {config_class.__name__}, got {type(base).__name__}: give one, or give its fields as "
            "options of their own"
        )
    return dataclasses.replace(base, **options)  # type: ignore[type-var]


def make_planner(name: str, **options: Any) -> Planner:
    """Instantiate a registered planner.

    Args:
        name: A key of :data:`PLANNERS`.
        **options: The planner's keyword options (see :func:`planner_options`).

    Raises:
        ConfigError: Unknown name (the message lists the valid ones), unknown options (the message
            lists the valid ones), option values the planner rejects, a factory that cannot be imported
            or made, or one that makes no planner.
    """
    valid = planner_options(name)
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ConfigError(
            f"unknown option(s) {', '.join(unknown)} for planner {name!r}: valid options are {', '.join(valid)}"
        )
    try:
        planner = PLANNERS.factory(name)(**options)
    except TypeError as exc:
        raise ConfigError(f"planner {name!r}: {exc}") from exc
    if not callable(getattr(planner, "plan", None)):
        raise ConfigError(
            f"planner {name!r}: its factory returned {planner!r:.60} ({type(planner).__name__}), which has no "
            "plan(problem) method; a planner has a name and plan(problem) -> PlanResult (planning.Planner)"
        )
    return planner
