"""Packages whose public names load their modules on first use (PEP 562).

A package lists its public names and the module defining each, and takes its module-level
``__getattr__`` and ``__dir__`` from :func:`lazy_exports`, so importing the package imports none of
its modules and a command loads only what it runs (``nhsim --version`` loads no numerics)::

    _EXPORTS = {"Trajectory": "planning.trajectory.trajectory", ...}
    __all__ = sorted(_EXPORTS)
    __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(
    package: str,
    exports: Mapping[str, str],
    namespace: dict[str, Any],
    before: Callable[[], object] | None = None,
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of a package whose public names load lazily.

    Args:
        package: The package's name (``__name__``), for messages.
        exports: Public name -> the module that defines it.
        namespace: The package's ``globals()``: a loaded name is kept there, so it loads once.
        before: Called before a public name's module is first imported (``sim`` chooses MuJoCo's GL backend,
            which MuJoCo and dm_control read once, when first imported).

    Returns:
        ``(__getattr__, __dir__)``; ``__getattr__`` raises AttributeError naming the public names for
        any other name.
    """
    public = ", ".join(sorted(exports))

    def __getattr__(name: str) -> Any:
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}; its public names are {public}")
        if before is not None:
            before()
        value = getattr(importlib.import_module(exports[name]), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return __getattr__, __dir__
