"""Where numba keeps nhsim's compiled kernels: a cache directory named by the kernels' sources.

numba caches each compiled function keyed on its own file's time stamp, yet a kernel compiles in the
kernels it calls, and the constants it reads, from other files. After an update that changes a
callee's file but not the caller's, a warm cache would run the old callee: when the EKF's state grew
from 7 to 8 (``control/estimation/kernels.py``), ``sim/robot/sensing.py``'s cached ``predict_period``
kept the old block layout and failed. So the cache directory is named by a hash of every source file
of ``planning``, ``control`` and ``sim`` that imports numba: a change to any of them starts a new
directory (every kernel compiles afresh once, about a minute of CPU over a test run), and a checkout
left as it is keeps its cache. The directory is ``$XDG_CACHE_HOME/nhsim/numba/<hash>`` (``~/.cache``
without XDG_CACHE_HOME); the two most recent others are kept, older ones removed when a new one is
started. A ``NUMBA_CACHE_DIR`` given in the environment is used as it is. Within it, nhsim's kernel files are
kept by their folder in the project (numba names a file's folder by its absolute path), so a second clone or
worktree of the same sources loads the kernels the first compiled.

A kernel that reads a constant from a module that does not import numba is not covered: such a
module's change keeps the cache. nhsim's kernels read their constants from their own modules or
from other kernel modules.

:func:`configure` runs when ``planning``, ``control`` or ``sim`` is imported (reading them takes
about 8 ms), before any of their kernels is defined. It only names the directory: the directory is
made, checked and pruned when numba caches the first kernel (:func:`ready_cache_dir`, through the
cache locator nhsim installs), so ``nhsim --version`` never touches it. A directory that cannot be
made or written is said once on stderr with the fix (``XDG_CACHE_HOME``), and that process compiles its
kernels into a temporary folder instead.
"""

from __future__ import annotations

import atexit
import contextlib
import fcntl
import functools
import hashlib
import importlib
import logging
import os
import re
import shutil
import sys
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

#: The packages whose kernel sources name the cache.
PACKAGES = ("planning", "control", "sim")
#: Cache directories kept besides the current one.
KEEP = 2
#: A module that imports numba (at the start of a line, as every kernel module does).
_IMPORTS_NUMBA = re.compile(rb"^\s*(?:import numba|from numba)\b", re.MULTILINE)
_ROOT = Path(__file__).resolve().parents[1]
_DONE = False
#: The directory :func:`configure` named (None: it named none, or it was given).
_OURS: str | None = None


def _kernel_texts() -> list[tuple[Path, bytes]]:
    """(path, contents) of the source files of :data:`PACKAGES` that import numba, sorted by path."""
    found = []
    for package in PACKAGES:
        for path in sorted((_ROOT / package).rglob("*.py")):
            text = path.read_bytes()
            if b"numba" in text and _IMPORTS_NUMBA.search(text):
                found.append((path, text))
    return found


def kernel_sources() -> list[Path]:
    """The source files of :data:`PACKAGES` that import numba, sorted."""
    return [path for path, _ in _kernel_texts()]


def files_digest(files: Iterable[tuple[Path, bytes]], size: int) -> str:
    """A ``2 size``-hex-digit hash of ``(path, contents)`` pairs of the project's files, by their paths within
    the project and their contents, in the order given."""
    digest = hashlib.blake2b(digest_size=size)
    for path, text in files:
        digest.update(path.relative_to(_ROOT).as_posix().encode())
        digest.update(b"\0")
        digest.update(text)
    return digest.hexdigest()


def source_key() -> str:
    """A 16-hex-digit hash of the kernel sources (their paths within the project and contents)."""
    return files_digest(_kernel_texts(), 8)


def cache_root() -> Path:
    """The folder holding one cache directory per kernel-source hash."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "nhsim" / "numba"


def configure() -> None:
    """Point numba's cache at the directory of the current kernel sources (see the module doc), once
    per process; an explicit ``NUMBA_CACHE_DIR`` is used as it is (through the same locator).

    Only names the directory (``NUMBA_CACHE_DIR``) and installs :data:`LOCATOR` (``NUMBA_CACHE_LOCATOR_CLASSES``);
    the directory itself is first touched when numba caches the first kernel (:func:`ready_cache_dir`), so a
    command that compiles nothing (``nhsim --version``, ``--help``) never reads or makes it.
    """
    global _DONE, _OURS
    if _DONE:
        return
    _DONE = True
    config = sys.modules.get("numba.core.config")  # numba already imported: it read the environment then
    if not os.environ.get("NUMBA_CACHE_DIR"):
        try:
            path = str(cache_root() / source_key())
        except (RuntimeError, KeyError):  # no home folder to be found: ready_cache_dir says so
            path = ""
        _OURS = path or None
        if path:
            os.environ["NUMBA_CACHE_DIR"] = path
            if config is not None:
                config.CACHE_DIR = path  # type: ignore[attr-defined]
    # a directory given is used as it is, through the same locator: the compile-once lock (:func:`compile_once`), the
    # directory checked before use and the kernel files kept by their place in the project (without it, a process
    # with NUMBA_CACHE_DIR set compiled every kernel beside the others on a cold cache)
    if not os.environ.get("NUMBA_CACHE_LOCATOR_CLASSES"):
        os.environ["NUMBA_CACHE_LOCATOR_CLASSES"] = LOCATOR
        if config is not None:
            config.CACHE_LOCATOR_CLASSES = LOCATOR  # type: ignore[attr-defined]


def _unusable(path: Path) -> str | None:
    """Why numba cannot keep kernels in ``path`` (made when missing), or None when it can."""
    try:
        new = not path.is_dir()
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()  # writable: numba's own test
    except OSError as exc:
        why = str(exc.strerror or exc)
        return f"{why}: {exc.filename}" if exc.filename and str(exc.filename) != str(path) else why
    if new and _OURS is not None and str(path) == _OURS:
        _prune(path.parent, current=path)
    return None


@functools.cache
def ready_cache_dir() -> str:
    """The directory numba keeps kernels in, checked once per process before the first kernel is cached.

    A directory that cannot be made or written (a read-only or another user's home, ``XDG_CACHE_HOME`` naming a
    file) is said once on stderr, with the fix, and the process compiles its kernels into a temporary folder,
    removed at exit: the command runs, its kernels compiled afresh. The directory in use goes into
    ``NUMBA_CACHE_DIR``, so worker processes started later use it as it is.
    """
    given = os.environ.get("NUMBA_CACHE_DIR", "")
    why = _unusable(Path(given)) if given else "no home folder to keep them in"
    if why is None:
        return given
    where = "XDG_CACHE_HOME" if os.environ.get("XDG_CACHE_HOME") else "HOME"
    if given and given != _OURS:
        where = "NUMBA_CACHE_DIR"
    fix = (
        "set XDG_CACHE_HOME to a folder you can write (nhsim keeps its kernels in $XDG_CACHE_HOME/nhsim/numba), "
        "or NUMBA_CACHE_DIR to one"
    )
    try:
        temporary = tempfile.mkdtemp(prefix="nhsim-kernels-")
    except OSError:
        temporary = ""
    if temporary:
        atexit.register(shutil.rmtree, temporary, ignore_errors=True)
        os.environ["NUMBA_CACHE_DIR"] = temporary
    used = "compiles them into a temporary folder, removed at exit" if temporary else "cannot cache them at all"
    # a library's warning: without logging set up, Python's last-resort handler writes the message to stderr
    logging.getLogger("nhsim").warning(
        f"nhsim: cannot keep compiled kernels in {given or 'a cache folder'} ({why}; from {where}); this run {used}, "
        f"so every kernel is compiled afresh (about a minute of CPU): {fix}"
    )
    return temporary or given


#: The numba cache locator nhsim installs (``NUMBA_CACHE_LOCATOR_CLASSES``): numba's for ``NUMBA_CACHE_DIR``,
#: whose directory :func:`ready_cache_dir` checks first.
LOCATOR = f"{__name__}.KernelCacheLocator"


def __getattr__(name: str) -> Any:
    """``KernelCacheLocator``, made on first use (numba imports this module's name when it caches the first
    kernel; defining the class needs numba, which ``nhsim --version`` does not import)."""
    if name == "KernelCacheLocator":
        return _locator_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@functools.cache
def _locator_class() -> type:
    caching: Any = importlib.import_module("numba.core.caching")  # no import line: this module is no kernel source
    config: Any = importlib.import_module("numba.core.config")
    base: type = caching.UserProvidedCacheLocator

    class KernelCacheLocator(base):
        """numba's locator for ``NUMBA_CACHE_DIR``, its directory made ready (:func:`ready_cache_dir`) first."""

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            config.CACHE_DIR = ready_cache_dir()
            compile_once()  # before the kernel's first compile
            found = super().from_function(py_func, py_file)
            if found is not None:
                return found
            impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
            for other in impl._locator_classes:  # none usable: numba's own choice, as without nhsim
                if other is not caching.UserProvidedCacheLocator:
                    found = other.from_function(py_func, py_file)
                    if found is not None:
                        return found
            return None

        @classmethod
        def get_suitable_cache_subpath(cls, py_file: str) -> str:
            """nhsim's own kernel files by their place in the project (numba names a file's folder by its absolute
            path): the directory is named by the kernel sources, so every checkout of them shares its kernels."""
            return _project_subpath(py_file) or super().get_suitable_cache_subpath(py_file)

    return KernelCacheLocator


def _project_subpath(py_file: str) -> str | None:
    """``py_file``'s folder within the project, as one folder name (``control_estimation``), for a file of
    :data:`PACKAGES`; None for any other file (a plugin's kernels keep numba's folder, named by their absolute path)."""
    try:
        relative = Path(py_file).resolve().relative_to(_ROOT)
    except (OSError, ValueError):
        return None
    if len(relative.parts) < 2 or relative.parts[0] not in PACKAGES:
        return None
    return "_".join(relative.parent.parts)


def _prune(root: Path, current: Path | None = None) -> None:
    """Remove all but the :data:`KEEP` most recently used cache directories under ``root`` (besides ``current``)."""
    try:
        others = sorted(
            (p for p in root.iterdir() if p.is_dir() and p != current), key=lambda p: p.stat().st_mtime, reverse=True
        )
    except OSError:  # no folder yet
        return
    for old in others[KEEP:]:
        shutil.rmtree(old, ignore_errors=True)


#: The kernels this thread holds the compile lock of (a kernel compiles the kernels it calls inside its own compile).
_HELD = threading.local()


def lock_folder() -> Path:
    """Where the processes sharing a kernel cache keep its kernels' compile locks: ``compile-locks`` in the cache
    directory (``NUMBA_CACHE_DIR``, which worker and child processes inherit), else in the temporary folder."""
    return Path(os.environ.get("NUMBA_CACHE_DIR") or tempfile.gettempdir()) / "compile-locks"


def kernel_lock_name(func: Any) -> str:
    """The name of the lock kernel ``func`` (its Python function) compiles under."""
    return f"{func.__module__}.{func.__qualname__}".replace("<", "_").replace(">", "_")


@contextlib.contextmanager
def kernel_lock(name: str) -> Iterator[None]:
    """An exclusive lock on kernel ``name`` among the processes sharing the kernel cache (re-entered freely by the
    thread holding it); none where no lock file can be made (each process then compiles on its own, as numba does)."""
    held: set[str] = _HELD.__dict__.setdefault("names", set())
    if name in held:
        yield
        return
    try:
        folder = lock_folder()
        folder.mkdir(exist_ok=True)
        handle = open(folder / f"{name}.lock", "a")
    except OSError:
        yield
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        held.add(name)
        try:
            yield
        finally:
            held.discard(name)
            fcntl.flock(handle, fcntl.LOCK_UN)


def compile_once() -> None:
    """numba's ``Dispatcher.compile`` (which loads a cached kernel or compiles it) under a lock per kernel shared by
    the processes that use one kernel cache: a process that needs a kernel another is compiling loads the other's
    result once it is written instead of compiling it too. A cold cache met by several processes at once (the
    workers of ``montecarlo --jobs`` or ``tune --jobs``, commands run side by side, the test workers and the
    commands they start) compiled each kernel in each of them. The results are the same either way. The wait is
    numba's time, as the compile itself is (a ``numba:compiler_lock`` event, which :mod:`planning.clock` leaves out
    of a planner's time limit). Installed once per process, when the first cached kernel is defined."""
    event: Any = importlib.import_module("numba.core.event")  # no import line: this module is no kernel source
    Dispatcher: Any = importlib.import_module("numba.core.dispatcher").Dispatcher

    compile_ = Dispatcher.compile
    if getattr(compile_, "nhsim_once", False):
        return

    def compile_locked(self: Any, sig: Any) -> Any:
        with event.trigger_event("numba:compiler_lock"), kernel_lock(kernel_lock_name(self.py_func)):
            return compile_(self, sig)

    compile_locked.nhsim_once = True  # type: ignore[attr-defined]
    Dispatcher.compile = compile_locked
