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
started. A ``NUMBA_CACHE_DIR`` given in the environment is used as it is.

A kernel that reads a constant from a module that does not import numba is not covered: such a
module's change keeps the cache. nhsim's kernels read their constants from their own modules or
from other kernel modules.

:func:`configure` runs when ``planning``, ``control`` or ``sim`` is imported (reading them takes
about 8 ms), before any of their kernels is defined.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import sys
from collections.abc import Iterable
from pathlib import Path

#: The packages whose kernel sources name the cache.
PACKAGES = ("planning", "control", "sim")
#: Cache directories kept besides the current one.
KEEP = 2
#: A module that imports numba (at the start of a line, as every kernel module does).
_IMPORTS_NUMBA = re.compile(rb"^\s*(?:import numba|from numba)\b", re.MULTILINE)
_ROOT = Path(__file__).resolve().parents[1]
_DONE = False


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
    per process; an explicit ``NUMBA_CACHE_DIR`` is left alone."""
    global _DONE
    if _DONE:
        return
    _DONE = True
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    root = cache_root()
    path = root / source_key()
    if not path.exists():
        _prune(root)
    os.environ["NUMBA_CACHE_DIR"] = str(path)
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba already imported: it read the environment then
        config.CACHE_DIR = str(path)  # type: ignore[attr-defined]


def _prune(root: Path) -> None:
    """Remove all but the :data:`KEEP` most recently used cache directories under ``root``."""
    try:
        others = sorted((p for p in root.iterdir() if p.is_dir()), key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:  # no folder yet
        return
    for old in others[KEEP:]:
        shutil.rmtree(old, ignore_errors=True)
