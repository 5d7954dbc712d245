"""Reading the files a user gives (scenarios, gains, sensor settings, parameters): each in one read, parsed
from memory.

A path need not name a regular file: ``<(printf ...)`` in bash gives ``/dev/fd/N``, a pipe, and a FIFO made
with ``mkfifo`` is one too. A pipe can be read once: a second read finds it empty (or waits for a new
writer). A command reads some of its inputs more than once (it checks its options, then runs the job), so
the bytes of a file that is not a regular file are kept, and every later read of the same path in this
process gives them again. A regular file is read anew each time (an edited file is read as it is now).
"""

from __future__ import annotations

import errno
import os
import stat
import threading
from pathlib import Path

#: The bytes of the pipes read so far, by (absolute path, device, inode) of what the path names.
_PIPES: dict[tuple[str, int, int], bytes] = {}
_LOCK = threading.Lock()

#: The folders of the paths that name a process's open files (bash's ``<(...)``, ``/dev/stdin``): not the
#: folder the file's content was written in.
_DESCRIPTOR_FOLDERS = ("/dev", "/proc")


def is_pipe(path: str | Path) -> bool:
    """Whether ``path`` names an existing file that is neither a regular file nor a folder (a pipe, a FIFO, a
    device): one that can be read only once. False for a path that cannot be looked at (reading it says why)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return False
    return not (stat.S_ISREG(mode) or stat.S_ISDIR(mode))


def descriptor_path(path: str | Path) -> bool:
    """Whether ``path`` names a pipe in ``/dev`` or ``/proc`` (``/dev/fd/N`` of bash's ``<(...)``,
    ``/dev/stdin``): its folder is not where its content came from, so paths in it cannot be relative to it."""
    folder = os.path.abspath(os.path.dirname(os.path.abspath(path)))
    return is_pipe(path) and any(folder == top or folder.startswith(top + "/") for top in _DESCRIPTOR_FOLDERS)


def read_input(path: str | Path) -> bytes:
    """The bytes of the user's file ``path``, read in one go: a regular file anew each call, a pipe (or FIFO)
    once, its later reads in this process given the same bytes (see the module's text).

    Raises:
        OSError: The file cannot be read (missing, a folder, no permission), or is a device (``/dev/zero`` gave
            bytes without end: a suite or a study read it until the machine ran out of memory).
    """
    name = os.fspath(path)
    info = os.stat(name)
    if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode):
        raise OSError(errno.EINVAL, "a device, not a file: give a file, or a pipe such as <(command)", name)
    if stat.S_ISREG(info.st_mode) or stat.S_ISDIR(info.st_mode):  # a folder: open() says it is one
        with open(name, "rb") as f:
            return f.read()
    key = (os.path.abspath(name), info.st_dev, info.st_ino)
    with _LOCK:
        if key not in _PIPES:
            with open(name, "rb") as f:
                _PIPES[key] = f.read()
        return _PIPES[key]


def read_input_text(path: str | Path, encoding: str = "utf-8-sig") -> str:
    """The text of the user's file ``path`` (:func:`read_input`), decoded; by default UTF-8 with a byte-order
    mark (Windows editors write one) dropped.

    Raises:
        OSError: The file cannot be read.
        UnicodeDecodeError: It is not text in ``encoding``.
    """
    return read_input(path).decode(encoding)


def undecodable_at(exc: UnicodeDecodeError) -> str:
    """Where a file's text would not decode, as a message says it: its line and the byte's place in the file,
    counted from 1 (``line 4, byte 24 of the file: invalid continuation byte``)."""
    data = bytes(exc.object)
    line = data[: exc.start].count(b"\n") + 1
    return f"line {line}, byte {exc.start + 1} of the file: {exc.reason}"
