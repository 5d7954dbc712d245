"""Registries of named factories (the planners, the trackers, the robots) and the plugins that add to them.

A registry maps a name (``--planner``, ``--trackers``, a scenario's ``planner``, the run records) to a factory,
or to its import path "package.module:Attribute", imported when first made. Code adds to it with
``register_planner`` / ``register_tracker``; an installed package or a module on ``sys.path`` adds to it as a
plugin, so that the ``nhsim`` command and fresh worker processes know its names too:

* an entry point of the registry's group (``nhsim.planners``, ``nhsim.trackers``, ``nhsim.robots``) in an
  installed package:
  ``ttt = "mypkg.ttt:TurnDriveTurn"`` registers that factory under the entry point's name (imported when first
  made), ``mypkg = "mypkg.plugins"`` imports a module whose import registers what it will;
* a module named by the environment variable :data:`PLUGIN_VARIABLE` (``NHSIM_PLUGINS=mypkg.plugins``,
  comma-separated), imported after the entry points; one module may register planners and trackers.

A registry loads its plugins at the first lookup of a name, listing or count, once per process: a command that
looks up no name (``nhsim --version``) imports none. The modules named by :data:`PLUGIN_VARIABLE` serve every
registry and are imported one after the other, in the order named, once: a registry looked up while one of them
is being imported (it registers a tracker) joins that pass instead of importing the others in the middle of it,
so of two plugins registering one name the later one named is refused, naming the earlier.

A registry is edited through ``register_planner`` / ``register_tracker`` (which refuse a taken name). Set
directly (``PLANNERS["rrt"] = X``, ``del``), it refuses to replace or remove a built-in entry or a plugin's.
"""

from __future__ import annotations

import functools
import importlib
import os
import re
import weakref
from collections.abc import Callable, Iterator, MutableMapping
from pathlib import Path
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
#: loads its entry points): a name registered meanwhile is said to come from the innermost one.
_loading: list[str] = []
#: Every registry made (:func:`plugin_modules` reads their entries).
_registries: list[weakref.ref[Registry[Any]]] = []
#: The registries waiting for the pass over :data:`PLUGIN_VARIABLE`'s modules in progress (None: none is).
_variable_pass: list[Registry[Any]] | None = None
#: The plugin modules loaded, in order (an entry point's module, a module named by :data:`PLUGIN_VARIABLE`).
_loaded_modules: dict[str, None] = {}


class RegistrationError(ConfigError):
    """``register_planner`` / ``register_tracker`` (or an entry point) refused what it was given.

    Args:
        message: What was wrong and the fix.
        kind: The registry that refused it, "planner" or "tracker" (a plugin's failure names it).
    """

    def __init__(self, message: str, kind: str) -> None:
        super().__init__(message)
        self.kind = kind


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
        raise RegistrationError(
            f"{caller}: name must be non-empty text without commas or whitespace (it is given as {flag}), e.g. "
            f"{examples[0]!r}; got {name!r}",
            kind,
        )
    if isinstance(target, str) and not FACTORY_TARGET.fullmatch(target):
        raise RegistrationError(
            f"{caller}({name!r}): target {target!r} is not 'package.module:Attribute' (the module path, a colon, the "
            f"factory), e.g. {examples[1]!r}; or pass the class itself",
            kind,
        )
    if not isinstance(target, str) and not callable(target):
        raise RegistrationError(
            f"{caller}({name!r}): target must be a {kind} class (or factory) or 'module:attr', got "
            f"{type(target).__name__}",
            kind,
        )


def target_text(target: object) -> str:
    """A registered target as text: the import path given, or a factory's "module:qualname"."""
    if isinstance(target, str):
        return target
    if isinstance(getattr(target, "registry_text", None), str):  # a value that says what it is (a robot's files)
        return str(target.registry_text)  # type: ignore[attr-defined]
    return f"{getattr(target, '__module__', '?')}:{getattr(target, '__qualname__', repr(target))}"


def redefines(taken: object, target: object) -> bool:
    """Whether factory ``target`` is a redefinition of the registered factory ``taken``: another object of the same
    module and qualified name, as a notebook cell run again (unchanged or edited) or a module reloaded makes of a
    class. Registering it under the name replaces the old one without ``replace=True``: that is the one
    definition the name stands for. Import paths (text) are compared as they are, never as redefinitions."""
    if isinstance(taken, str) or isinstance(target, str) or taken is target:
        return False
    old, new = ((getattr(f, "__module__", None), getattr(f, "__qualname__", None)) for f in (taken, target))
    return None not in old and old == new


class PluginLoadError(ConfigError):
    """A plugin failed to import or to register: the message names it, where it was declared and the exception."""


def _failure(kind: str, source: str, module: str, exc: Exception) -> PluginLoadError:
    """The error of a plugin that failed: named by the registry whose registration refused it (else by its entry
    point's group; a module named by :data:`PLUGIN_VARIABLE` serves every registry), and by itself; a module named
    by the variable whose own package Python did not find, with where Python looks (the ``nhsim`` command, unlike
    ``python -m``, not in the working directory)."""
    kind = exc.kind if isinstance(exc, RegistrationError) else kind
    what = type(exc).__name__ if not isinstance(exc, RegistrationError) else "ConfigError"
    label = f"{kind} plugin" if kind else "plugin"
    hint = ""
    top = module.partition(".")[0]
    named = PLUGIN_VARIABLE in source  # an entry point's missing package is a broken install, not a path
    if named and isinstance(exc, ModuleNotFoundError) and exc.name == top:
        here = any(Path(top + end).exists() for end in ("", ".py"))
        hint = (
            f"; Python looks for it in the folders of sys.path (the nhsim command: not in the working directory): "
            f"run it with PYTHONPATH={'.' if here else f'<the folder holding {top}>'}"
            f"{' (the working directory holds it)' if here else ''}"
        )
    return PluginLoadError(f"{label} failed to load: {source}: {what}: {exc}{hint}")


def _load_one(kind: str, source: str, module: str, load: Callable[[], Any]) -> None:
    """Load one plugin (``module``: its module, recorded when loaded), naming it if it fails."""
    _loading.append(source)
    try:
        load()
    except PluginLoadError:  # another registry's plugin, loaded by this one's import: named there
        raise
    except Exception as exc:
        raise _failure(kind, source, module, exc) from exc
    finally:
        _loading.pop()
    _loaded_modules[module] = None


def _variable_modules() -> list[tuple[str, str]]:
    """The modules named by :data:`PLUGIN_VARIABLE`: (module, its description)."""
    text = os.environ.get(PLUGIN_VARIABLE, "")
    modules = filter(None, (m.strip() for m in text.split(",")))
    return [(module, f"module {module!r} named by {PLUGIN_VARIABLE}={text}") for module in modules]


def _load_variable_modules(registry: Registry[Any]) -> None:
    """Import the modules named by :data:`PLUGIN_VARIABLE` in order, then mark ``registry`` (and every registry
    that joined the pass meanwhile) loaded; while a pass is in progress (a module's import looked ``registry``
    up), ``registry`` joins it instead. A module imported already is not imported again (its registrations
    stand). A failure leaves every registry of the pass unloaded."""
    global _variable_pass
    if _variable_pass is not None:
        _variable_pass.append(registry)
        return
    _variable_pass = waiting = [registry]
    try:
        for module, source in _variable_modules():
            _load_one("", source, module, functools.partial(importlib.import_module, module))
    except BaseException:
        for each in waiting:
            each.plugins = "unloaded"
        raise
    finally:
        _variable_pass = None
    for each in waiting:
        each.plugins = "loaded"


def module_of(target: object) -> str:
    """The module of a registered target: that of its import path, or the factory's ``__module__``."""
    return target.split(":")[0] if isinstance(target, str) else str(getattr(target, "__module__", "?"))


def plugin_modules() -> list[str]:
    """The modules whose code the registries run besides nhsim's own, sorted: every plugin module loaded (an
    entry point's, one named by :data:`PLUGIN_VARIABLE`) and the module of every factory not built in (a
    plugin's, or one the program's own code registered). Loads no plugin."""
    names = set(_loaded_modules)
    for ref in _registries:
        registry = ref()
        if registry is not None:
            added = (t for n, t in registry._entries.items() if t and registry.origins.get(n) != BUILT_IN)
            names.update(module_of(target) for target in added)
    return sorted(names - {"?"})


class Registry(MutableMapping[str, "str | Callable[..., F]"], Generic[F]):
    """Name -> factory, or "module:attr" imported when first made; its plugins load at the first lookup.

    Edited through :meth:`add` (``register_planner`` / ``register_tracker``); set directly (``registry[name] =
    target``, ``del registry[name]``: a test's monkeypatch), it takes a new name, a placeholder "" and the built-in
    target restored, and replaces or removes an entry the program's own code registered, but refuses to replace or
    remove a built-in entry or a plugin's (the duplicate-name check ``register_*`` makes).

    Args:
        kind: What it holds, for the messages: "planner" or "tracker".
        group: The entry-point group of its plugins ("nhsim.planners").
        built_in: nhsim's own entries.
    """

    def __init__(self, kind: str, group: str, built_in: dict[str, str | Callable[..., F]]) -> None:
        self.kind = kind
        self.group = group
        self._built_in = dict(built_in)
        self._entries = dict(built_in)
        #: Name -> who registered it (:meth:`origin`).
        self.origins: dict[str, str] = dict.fromkeys(built_in, BUILT_IN)
        #: The plugins: "unloaded", "loading" (a plugin registering: no second load) or "loaded".
        self.plugins = "unloaded"
        _registries.append(weakref.ref(self))

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

    def _refuse_direct(self, name: str, what: str) -> None:
        """Refuse setting or removing ``name`` directly when it is a built-in entry or a plugin's."""
        origin = self.origins.get(name, BY_CODE)
        if self._entries.get(name) and origin != BY_CODE:
            raise RegistrationError(
                f"{self.kind} {name!r} is registered ({origin}) as {target_text(self._entries[name])} and cannot be "
                f"{what} directly in the registry; register_{self.kind}({name!r}, target, replace=True) replaces it",
                self.kind,
            )

    def __setitem__(self, name: str, target: str | Callable[..., F]) -> None:
        built_in = name in self._built_in and target_text(target) == target_text(self._built_in[name])
        if target and not built_in and self._entries.get(name) != target:
            self._refuse_direct(name, "replaced")
        same = self._entries.get(name) == target and name in self.origins
        self._entries[name] = target
        if not same:  # the same target again keeps who registered it
            self.origins[name] = BUILT_IN if built_in else f"from {_loading[-1]}" if _loading else BY_CODE

    def __delitem__(self, name: str) -> None:
        self._refuse_direct(name, "removed")
        del self._entries[name]
        self.origins.pop(name, None)

    def clear(self) -> None:
        """Refused when the registry holds a built-in entry or a plugin's (:meth:`__delitem__`)."""
        for name in list(self._entries):
            self._refuse_direct(name, "removed")
        self._entries.clear()
        self.origins.clear()

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {self._entries!r})"

    def add(self, caller: str, name: str, target: str | Callable[..., F], replace: bool, fix: str = "") -> None:
        """Register ``target`` under ``name`` (checked already by :func:`check_registration`), noting who did.

        The same target again changes nothing; a redefinition of the registered factory (:func:`redefines`: a
        notebook cell or a module run again) replaces it, keeping who registered it.

        Args:
            fix: What to do about a taken name (default: choose another, or pass replace=True).

        Raises:
            RegistrationError: ``name`` is taken by another target and ``replace`` is not True.
        """
        if not isinstance(replace, bool):
            raise RegistrationError(f"{caller}({name!r}): replace must be True or False", self.kind)
        taken = self.get(name)  # an empty entry is a placeholder (a test's monkeypatch), no factory
        named = isinstance(taken, str) != isinstance(target, str) and target_text(taken) == target_text(target)
        if taken and (taken == target or named):
            return  # no change (nor of who registered it): the same target, or the class its import path names
        if taken and redefines(taken, target):
            self._entries[name] = target
            return
        if taken and not replace:
            fix = fix or "choose another name, or pass replace=True to replace it"
            raise RegistrationError(
                f"{caller}: {self.kind} {name!r} is already registered ({self.origin(name)}) as {target_text(taken)}; "
                f"{fix}",
                self.kind,
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
        packages, then the modules named by :data:`PLUGIN_VARIABLE` (:func:`_load_variable_modules`: shared by
        the registries, imported once, in order).

        Called by the first lookup; a later call does nothing. A plugin that fails leaves the plugins unloaded
        (the next lookup tries again, and fails the same way).

        Raises:
            PluginLoadError: A plugin failed to import or to register (names the plugin, where it was declared,
                the registry that refused it and the exception).
        """
        if self.plugins != "unloaded":
            return
        self.plugins = "loading"
        try:
            for source, module, load in self._entry_points():
                _load_one(self.kind, source, module, load)
        except BaseException:
            self.plugins = "unloaded"
            raise
        _load_variable_modules(self)

    def _entry_points(self) -> list[tuple[str, str, Callable[[], Any]]]:
        """The entry points of :attr:`group`: (its description, its module, what loads it)."""
        from importlib.metadata import entry_points

        found: list[tuple[str, str, Callable[[], Any]]] = []
        for ep in entry_points(group=self.group):
            package = f"{ep.dist.name} {ep.dist.version}" if ep.dist is not None else "an installed package"
            source = f"entry point '{ep.name} = {ep.value}' of group {self.group} in {package}"
            if ep.attr:  # a factory: registered by the entry point's name, imported when first made
                register = functools.partial(self._register_entry_point, ep.name, f"{ep.module}:{ep.attr}")
                found.append((source, ep.module, register))
            else:  # a module whose import registers what it will
                found.append((source, ep.module, functools.partial(importlib.import_module, ep.module)))
        return found

    def _register_entry_point(self, name: str, target: str) -> None:
        caller = f"entry point of group {self.group}"
        check_registration(caller, name, target, kind=self.kind, flag="its name", examples=("name", "module:Attr"))
        self.add(caller, name, target, replace=False, fix="give the entry point another name in the package's metadata")

    def unknown_hint(self) -> str:
        """What to say of a name that is not registered, after the valid ones: a plugin's is registered only once
        the plugin is found (for the messages that refuse an unknown name)."""
        return (
            f"a plugin's {self.kind} is known once its plugin loads: name its module in {PLUGIN_VARIABLE} (e.g. "
            f"{PLUGIN_VARIABLE}=mypackage.{self.kind}s), or install its package with an entry point of group "
            f"{self.group}"
        )

    def factory(self, name: str) -> Callable[..., F]:
        """The factory registered under ``name``, imported if given as text.

        Raises:
            ConfigError: Unknown name (lists the valid ones and how a plugin's is registered), or a target that
                cannot be imported or is not
                callable (names the entry, who registered it and the exception).
        """
        if name not in self:
            choose = f"choose one of {', '.join(sorted(self)) or '(none)'}"
            raise ConfigError(f"unknown {self.kind} {name!r}: {choose}; {self.unknown_hint()}")
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
