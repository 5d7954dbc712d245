"""Digests of what makes a study's runs what they are besides its settings: the scenario as read
(:func:`world_digest`) and the code and models that run (:func:`code_digest`). A Monte Carlo study keys its
results file by them and a tuning study stores them with its settings, so neither resumes into runs made on
another world or by other code."""

from __future__ import annotations

import functools
import hashlib
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from planning.scenario import Scenario


def world_digest(scenario: Scenario) -> str:
    """A digest of a scenario as read: its world, ends, tolerances and tables, not where it was read from (a
    scenario file edited since is another study, as an edited trajectory file is)."""
    return hashlib.sha1(repr(replace(scenario, source=None)).encode()).hexdigest()


#: What makes a run what it is besides its settings: the project's code and models (:func:`code_digest`).
_CODE_ROOTS = ("planning", "control", "sim", "models")


def code_digest() -> str:
    """A 12-hex-digit hash of the code the runs run: the project's code and models (every file under
    :data:`_CODE_ROOTS` but caches, by path and content), the source of the planners and trackers added to the
    registries (:func:`plugin_files`: the plugins, loaded first, and what the program's own code registered) and
    the files of the robots added (:func:`robot_model_files`): two
    runs of one study's settings are comparable when it is the same. The project's part is hashed once per
    process, the others once per set of files."""
    from control.base import TRACKERS
    from planning.planners.registry import PLANNERS

    PLANNERS.load_plugins()  # what the runs may run: the plugins registered by the time the digest is taken
    TRACKERS.load_plugins()
    return _digest(_project_digest(), tuple(plugin_files() + robot_model_files()))


@functools.cache
def _project_digest() -> str:
    from planning.kernel_cache import files_digest

    root = Path(__file__).resolve().parents[2]
    files = (f for top in _CODE_ROOTS for f in sorted((root / top).rglob("*")))
    return files_digest(((f, f.read_bytes()) for f in files if f.is_file() and "__pycache__" not in f.parts), 6)


@functools.cache
def _digest(project: str, files: tuple[tuple[Path, str], ...]) -> str:
    """The project's digest alone when no file is added; else a hash of it and the files (by their path within
    their package's folder, and their contents)."""
    if not files:
        return project
    digest = hashlib.blake2b(project.encode(), digest_size=6)
    for path, name in files:
        digest.update(f"\0{name}\0".encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def plugin_files() -> list[tuple[Path, str]]:
    """The source files of the planners and trackers that are not nhsim's own
    (:func:`planning.core.plugins.plugin_modules`), as (file, its name within its package's folder), sorted: the
    whole top-level package of each module (a package of the user's: any file of it may be what runs), or only the
    module's file when it is installed in a ``site-packages`` folder. nhsim's own modules are left out (hashed
    with the project) and so are modules without a file."""
    from planning.core.plugins import plugin_modules

    found: dict[Path, str] = {}
    for module in plugin_modules():
        top = module.split(".")[0]
        if top in _CODE_ROOTS:
            continue
        origin, folders = _located(top)
        if any(part in ("site-packages", "dist-packages") for part in Path(origin or "").parts):
            origin, folders = _located(module)[0], []
        for folder in folders:
            for f in sorted(Path(folder).rglob("*")):
                if f.is_file() and "__pycache__" not in f.parts:
                    found[f] = f.relative_to(Path(folder).parent).as_posix()
        if origin and not folders and Path(origin).is_file():
            found[Path(origin)] = Path(origin).name if module == top else module
    return sorted(found.items(), key=lambda item: item[1])


def robot_model_files() -> list[tuple[Path, str]]:
    """The files of the robots registered besides nhsim's own (:func:`planning.core.robot.register_robot`: a
    plugin's, or the program's own code's): each one's model, scene and sensor settings, as (file, a name that
    says whose), sorted by name. A changed model or profile makes other runs."""
    from planning.core.robot import ROBOTS, robot_files

    found: dict[str, Path] = {}
    for name in sorted(set(ROBOTS) - set(ROBOTS.built_in())):
        files = robot_files(name)
        for kind, path in (("model", files.mjcf), ("scene", files.scene), ("sensors", files.sensors)):
            found[f"robot {name} {kind}"] = path
    return [(path, label) for label, path in sorted(found.items()) if path.is_file()]


def model_files(robot: str) -> dict[str, Path]:
    """The files a robot is made of, by role (:func:`planning.core.robot.robot_files`: its model, scene and sensor
    settings) and, for a balancing robot, its balance profile: a run's physics changes with any of them."""
    from control.design.balance_profile import balance_profile_path, is_balancing
    from planning.core.robot import robot_files

    files = robot_files(robot)
    roles = {"model": files.mjcf, "scene": files.scene, "sensors": files.sensors}
    if is_balancing(robot):
        roles["balance"] = balance_profile_path(robot)
    return roles


def model_digest(robot: str) -> dict[str, str]:
    """12-hex-digit hashes of the contents of the files a robot is made of (:func:`model_files`), by role, and of
    all of them together (``"all"``)."""
    digests = {
        role: hashlib.blake2b(path.read_bytes(), digest_size=6).hexdigest() for role, path in model_files(robot).items()
    }
    together = hashlib.blake2b(digest_size=6)
    for role, digest in digests.items():
        together.update(f"\0{role}\0{digest}".encode())
    return {"all": together.hexdigest(), **digests}


def _located(module: str) -> tuple[str | None, list[str]]:
    """Where a module's code is: (its file, its package's folders), without importing it when it is not yet."""
    import importlib.util
    import sys

    loaded = sys.modules.get(module)
    try:
        spec = loaded.__spec__ if loaded is not None else importlib.util.find_spec(module)
    except (ImportError, ValueError):  # a module that cannot be found: nothing of it can run either
        spec = None
    if spec is None:
        main = getattr(loaded, "__file__", None) if module == "__main__" else None
        return main, []
    return spec.origin if spec.has_location else None, list(spec.submodule_search_locations or [])
