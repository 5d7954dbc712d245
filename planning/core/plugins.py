"""Registries of named factories (the planners, the trackers) and the plugins that add to them.

A registry maps a name (``--planner``, ``--trackers``, a scenario's ``planner``, the run records) to a factory,
or to its import path "package.module:Attribute", imported when first made. Code adds to it with
``register_planner`` / ``register_tracker``; an installed package or a module on ``sys.path`` adds to it as a
plugin, so that the ``nhsim`` command and fresh worker processes know its names too:

* an entry point of the registry's group (``nhsim.planners``, ``nhsim.trackers``) in an installed package:
  ``ttt = "mypkg.ttt:TurnDriveTurn"`` registers that factory under the entry point's name (imported when first
  made), ``mypkg = "mypkg.plugins"`` imports a module whose import registers what it will;
* a module named by the environment variable :data:`PLUGIN_VARIABLE` (``NHSIM_PLUGINS=mypkg.plugins``,
  comma-separated), imported after the entry points; one module may register planners and trackers.

A registry loads its plugins at the first lookup of a name, listing or count, once per process: a command that
looks up no name (``nhsim --version``) imports none.
"""

from __future__ import annotations

import functools
import importlib
import os
import re
from collections.abc import Callable, Iterator, MutableMapping
from typing import Any, Generic, TypeVar

from planning.errors import ConfigError

F = TypeVar("F")

#: Environment variable naming modules (comma-separated) whose import registers planners or trackers, e.g.
#: ``NHSIM_PLUGINS=mypkg.plugins``; imported after a registry's entry points.
PLUGIN_VARIABLE = "NHSIM_PLUGINS"
#: Who registered a name, when no plugin did: nhsim itself, or a call in the running program's own code.
BUILT_IN, BY_CODE = "built in", "registered by this program's own code"
#: A factory given as text: "package.module:attribute" (imported when first made).
FACTORY_TARGET = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")

#: The plugins being loaded, innermost last (a plugin's import may look up another registry, which then
#: loads its own): a name registered meanwhile is said to come from the innermost one.
_loading: list[str] = []


def check_registration(
    caller: str, name: object, target: object, *, kind: str, flag: str, examples: tuple[str, str]
) -> None:
    """What ``register_tracker`` and ``register_planner`` take: a name the command line can give (non-empty text
    without commas or whitespace) and a factory, or its import path "package.module:Attribute".

    Args:
        caller: The function, for the messages ("register_tracker").
        name, target: What it was given.
        kind: "tracker" or "planner".
        flag: How the command line gives the name ("--trackers A,B").
        examples: An example name and module path ("p-pose", "mypackage.pose_p:PoseP").

    Raises:
        ConfigError: A bad name or target (naming the form and an example).
    """
    if not isinstance(name, str) or not name or re.search(r"[,\s]", name):
        raise ConfigError(
            f"{caller}: name must be non-empty text without commas or whitespace (it is given as {flag}), e.g. "
            f"{examples[0]!r}; got {name!r}"
        )
    if isinstance(target, str) and not FACTORY_TARGET.fullmatch(target):
        raise ConfigError(
            f"{caller}({name!r}): target {target!r} is not 'package.module:Attribute' (the module path, a colon, the "
            f"factory), e.g. {examples[1]!r}; or pass the class itself"
        )
    if not isinstance(target, str) and not callable(target):
        raise ConfigError(
            f"{caller}({name!r}): target must be a {kind} class (or factory) or 'module:attr', got "
            f"{type(target).__name__}"
        )


def target_text(target: object) -> str:
    """A registered target as text: the import path given, or a factory's "module:qualname"."""
    if isinstance(target, str):
        return target
    return f"{getattr(target, '__module__', '?')}:{getattr(target, '__qualname__', repr(target))}"


class PluginLoadError(ConfigError):
    """A plugin failed to import or to register: the message names it, where it was declared and the exception."""


class Registry(MutableMapping[str, "str | Callable[..., F]"], Generic[F]):
    """Name -> factory, or "module:attr" imported when first made; its plugins load at the first lookup.

    Args:
        kind: What it holds, for the messages: "planner" or "tracker".
        group: The entry-point group of its plugins ("nhsim.planners").
        built_in: nhsim's own entries.
    """

    def __init__(self, kind: str, group: str, built_in: dict[str, str | Callable[..., F]]) -> None:
        self.kind = kind
        self.group = group
        self._entries = dict(built_in)
        #: Name -> who registered it (:meth:`origin`).
        self.origins: dict[str, str] = dict.fromkeys(built_in, BUILT_IN)
        #: The plugins: "unloaded", "loading" (a plugin registering: no second load) or "loaded".
        self.plugins = "unloaded"

    def _load(self) -> None:
        if self.plugins == "unloaded":
            self.load_plugins()

    def __getitem__(self, name: str) -> str | Callable[..., F]:
        self._load()
        return self._entries[name]

    def __contains__(self, name: object) -> bool:
        self._load()
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        self._load()
        return iter(self._entries)

    def __len__(self) -> int:
        self._load()
        return len(self._entries)

    def __setitem__(self, name: str, target: str | Callable[..., F]) -> None:
        self._entries[name] = target

    def __delitem__(self, name: str) -> None:
        del self._entries[name]
        self.origins.pop(name, None)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {self._entries!r})"

    def add(self, caller: str, name: str, target: str | Callable[..., F], replace: bool, fix: str = "") -> None:
        """Register ``target`` under ``name`` (checked already by :func:`check_registration`), noting who did.

        Args:
            fix: What to do about a taken name (default: choose another, or pass replace=True).

        Raises:
            ConfigError: ``name`` is taken by another target and ``replace`` is not True.
        """
        if not isinstance(replace, bool):
            raise ConfigError(f"{caller}({name!r}): replace must be True or False")
        taken = self.get(name)  # an empty entry is a placeholder (a test's monkeypatch), no factory
        named = isinstance(taken, str) != isinstance(target, str) and target_text(taken) == target_text(target)
        if taken and (taken == target or named):
            return  # no change (nor of who registered it): the same target, or the class its import path names
        if taken and not replace:
            fix = fix or "choose another name, or pass replace=True to replace it"
            raise ConfigError(
                f"{caller}: {self.kind} {name!r} is already registered ({self.origin(name)}) as {target_text(taken)}; "
                f"{fix}"
            )
        self._entries[name] = target
        self.origins[name] = f"from {_loading[-1]}" if _loading else BY_CODE

    def built_in(self) -> list[str]:
        """nhsim's own names, sorted, without loading the plugins (for help texts, which import no user code)."""
        return sorted(name for name, origin in self.origins.items() if origin == BUILT_IN)

    def origin(self, name: str) -> str:
        """Who registered ``name``: :data:`BUILT_IN`, :data:`BY_CODE` (also a name set in the registry directly),
        or "from " the plugin (entry point or :data:`PLUGIN_VARIABLE`'s module); the plugins are loaded first."""
        self._load()
        return self.origins.get(name, BY_CODE)

    def in_every_process(self, name: str) -> bool:
        """Whether a fresh Python process (a worker) knows ``name`` too: a built-in entry or a plugin's; not one
        registered by a call of the program's own code, which such a process does not make."""
        return self.origin(name) != BY_CODE

    def load_plugins(self) -> None:
        """Load the plugins, once per process: first the entry points of :attr:`group` of the installed
        packages, then the modules named by :data:`PLUGIN_VARIABLE` (a module another registry imported already
        is not imported again: its registrations stand).

        Called by the first lookup; a later call does nothing. A plugin that fails leaves the plugins unloaded
        (the next lookup tries again, and fails the same way).

        Raises:
            ConfigError: A plugin failed to import or to register (names the plugin, where it was declared and
                the exception).
        """
        if self.plugins != "unloaded":
            return
        self.plugins = "loading"
        try:
            for source, load in self._plugins():
                _loading.append(source)
                try:
                    load()
                except PluginLoadError:  # another registry's plugin, loaded by this one's import: named there
                    raise
                except Exception as exc:
                    failed = f"{self.kind} plugin failed to load: {source}: {type(exc).__name__}: {exc}"
                    raise PluginLoadError(failed) from exc
                finally:
                    _loading.pop()
        except BaseException:
            self.plugins = "unloaded"
            raise
        self.plugins = "loaded"

    def _plugins(self) -> list[tuple[str, Callable[[], Any]]]:
        """Every plugin: (its description, what loads it)."""
        from importlib.metadata import entry_points

        found: list[tuple[str, Callable[[], Any]]] = []
        for ep in entry_points(group=self.group):
            package = f"{ep.dist.name} {ep.dist.version}" if ep.dist is not None else "an installed package"
            source = f"entry point '{ep.name} = {ep.value}' of group {self.group} in {package}"
            if ep.attr:  # a factory: registered by the entry point's name, imported when first made
                register = functools.partial(self._register_entry_point, ep.name, f"{ep.module}:{ep.attr}")
                found.append((source, register))
            else:  # a module whose import registers what it will
                found.append((source, functools.partial(importlib.import_module, ep.module)))
        text = os.environ.get(PLUGIN_VARIABLE, "")
        for module in filter(None, (m.strip() for m in text.split(","))):
            source = f"module {module!r} named by {PLUGIN_VARIABLE}={text}"
            found.append((source, functools.partial(importlib.import_module, module)))
        return found

    def _register_entry_point(self, name: str, target: str) -> None:
        caller = f"entry point of group {self.group}"
        check_registration(caller, name, target, kind=self.kind, flag="its name", examples=("name", "module:Attr"))
        self.add(caller, name, target, replace=False, fix="give the entry point another name in the package's metadata")

    def factory(self, name: str) -> Callable[..., F]:
        """The factory registered under ``name``, imported if given as text.

        Raises:
            ConfigError: Unknown name (lists the valid ones), or a target that cannot be imported or is not
                callable (names the entry, who registered it and the exception).
        """
        if name not in self:
            raise ConfigError(f"unknown {self.kind} {name!r}: choose one of {', '.join(sorted(self)) or '(none)'}")
        target = self[name]
        if not isinstance(target, str):
            return target
        where = f"{self.kind} {name!r} ({self.origin(name)})"
        if not FACTORY_TARGET.fullmatch(target):  # set in the registry directly, not through register_*
            raise ConfigError(
                f"{where}: its factory {target!r} is not 'package.module:Attribute'; register it with "
                f"register_{self.kind}(name, 'mypackage.module:Class') or register_{self.kind}(name, Class)"
            )
        module_name, attr = target.split(":")
        try:
            factory: Any = functools.reduce(getattr, attr.split("."), importlib.import_module(module_name))
        except Exception as exc:  # whatever importing the module raised
            raise ConfigError(f"{where}: cannot load its factory {target!r}: {type(exc).__name__}: {exc}") from exc
        if not callable(factory):
            raise ConfigError(f"{where}: its factory {target!r} is not callable (a class or a function)")
        return factory  # type: ignore[no-any-return]
