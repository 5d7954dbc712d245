"""The registry of planners by name: what the CLI, the scenario files and the tests enumerate.

A planner is registered as ``"module:factory"``; the module is imported only when the planner is made,
so listing the planners costs nothing. A factory takes keyword-only options: either named keyword
parameters, or ``**options`` checked against the fields of the dataclass in its ``config_class``
attribute.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from planning.errors import ConfigError
from planning.planners.base import Planner

ConfigT = TypeVar("ConfigT")

#: Planner name -> "module:factory". The factory takes keyword-only options and returns a Planner.
PLANNERS: dict[str, str] = {
    "rrt": "planning.planners.sampling.rrt:RRT",
    "birrt": "planning.planners.sampling.rrt:BiRRT",
    "rrt-star": "planning.planners.sampling.rrt_star:RRTStar",
    "c-rrt-star": "planning.planners.sampling.crrt_star:CRRTStar",
    "sinusoidal": "planning.planners.sinusoidal:Sinusoidal",
    "optim": "planning.planners.optim:Optim",
    "hybrid-a-star": "planning.planners.hybrid_astar:HybridAStar",
}


def register_planner(name: str, target: str) -> None:
    """Register a planner factory by import path, e.g. ``"planning.planners.sampling.rrt:RRT"``."""
    PLANNERS[name] = target


def _factory(name: str) -> Callable[..., Planner]:
    if name not in PLANNERS:
        raise ConfigError(f"unknown planner {name!r}: choose one of {', '.join(sorted(PLANNERS)) or '(none)'}")
    module_name, attr = PLANNERS[name].split(":")
    return getattr(importlib.import_module(module_name), attr)  # type: ignore[no-any-return]


def planner_options(name: str) -> tuple[str, ...]:
    """The keyword options a registered planner accepts, sorted.

    They are the factory's named keyword parameters and, when it also takes ``**options``, the
    fields of its ``config_class`` dataclass.

    Raises:
        ConfigError: Unknown planner name (the message lists the valid ones).
    """
    factory = _factory(name)
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
        ConfigError: An option that is not a field (the message lists the valid ones), or a value the
            dataclass rejects.
    """
    names = [f.name for f in dataclasses.fields(config_class) if f.init]  # type: ignore[arg-type]
    unknown = sorted(set(options) - set(names))
    if unknown:
        raise ConfigError(f"unknown option(s) {', '.join(unknown)}: valid options are {', '.join(sorted(names))}")
    if base is None:
        return config_class(**options)
    return dataclasses.replace(base, **options)  # type: ignore[type-var]


def make_planner(name: str, **options: Any) -> Planner:
    """Instantiate a registered planner.

    Args:
        name: A key of :data:`PLANNERS`.
        **options: The planner's keyword options (see :func:`planner_options`).

    Raises:
        ConfigError: Unknown name (the message lists the valid ones), unknown options (the message
            lists the valid ones) or option values the planner rejects.
    """
    valid = planner_options(name)
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ConfigError(
            f"unknown option(s) {', '.join(unknown)} for planner {name!r}: valid options are {', '.join(valid)}"
        )
    try:
        return _factory(name)(**options)
    except TypeError as exc:
        raise ConfigError(f"planner {name!r}: {exc}") from exc
