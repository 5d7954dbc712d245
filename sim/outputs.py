"""Writing outputs safely: to a temporary name beside the target, renamed when complete.

An existing file is never replaced unless ``overwrite`` is true; an interrupted write leaves no
partial file under the final name.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from planning.core.checks import check_flag
from planning.errors import ConfigError, OutputExistsError, option
from planning.signals import signals_held

#: Whether an existing file may be replaced: a flag, or a question asked of the path each time it is
#: checked (before the work and again just before the rename), for a file another process of the same
#: job may write meanwhile.
Overwrite = bool | Callable[[Path], bool]


#: The image formats a figure is written in, by the file's suffix (matplotlib's Agg canvas writes each).
IMAGE_FORMATS = ("png", "svg", "pdf", "jpg", "jpeg", "tif", "tiff", "webp", "eps")


def image_format(path: Path, option: str) -> str:
    """The format an image written to ``path`` takes, from its suffix.

    Raises:
        ConfigError: A suffix that is no image format (named with the choices), or none.
    """
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in IMAGE_FORMATS:
        given = f"suffix '{path.suffix}'" if path.suffix else "no suffix"
        raise ConfigError(
            f"{option} {path}: {given}, which names no image format; end the name in "
            + ", ".join(f".{f}" for f in IMAGE_FORMATS)
        )
    return fmt


def check_video_name(path: str | Path, what: str = "a video's path") -> None:
    """Refuse a video file name that does not end in .mp4: the writer (:mod:`sim.viz.video`) makes H.264 in
    an MP4 container whatever the name, so a ``.avi`` or ``.mkv`` would hold MP4 data under a false name.

    Args:
        path: The file name.
        what: What the message calls it (``"--video"`` on the command line).

    Raises:
        ConfigError: Another suffix, or none.
    """
    if Path(path).suffix.lower() != ".mp4":
        raise ConfigError(
            f"{what} must name an .mp4 file (the video is H.264 in MP4, the one container written), got {path}; "
            "end the name in .mp4"
        )


def check_writable(path: Path, *, overwrite: bool) -> None:
    """Check, before any work and without leaving anything behind, that ``path`` can be written.

    Raises:
        OutputExistsError: ``path`` exists and overwriting was not asked for.
        ConfigError: ``overwrite`` is not True or False (a string such as ``"no"`` is refused, not read as
            true), ``path`` is a folder, a file stands where one of its folders should be, its
            folder (or the nearest existing one above it) does not accept new files, or its name, its
            temporary name (:func:`atomic_path`) or either's whole path is longer than the file
            system takes (NAME_MAX, PATH_MAX).
    """
    overwrite = check_flag("overwrite", overwrite)
    path = Path(path)
    _check_length(path)
    if path.is_dir():
        raise ConfigError(f"cannot write {path}: it is a folder; give a file name")
    _check_absent(path, overwrite=overwrite)
    check_folder_for(path)


def check_distinct(paths: Iterable[Path]) -> None:
    """Check, before any work, that no two of a command's outputs are one file.

    Raises:
        ConfigError: Two of ``paths`` resolve to the same file (the message lists them all).
    """
    paths = [Path(p) for p in paths]
    if len({p.resolve() for p in paths}) != len(paths):
        raise ConfigError(f"two outputs share a path: {', '.join(map(str, paths))}; choose distinct names")


#: Characters ``tempfile.mkstemp`` puts between its prefix and suffix.
_RANDOM_CHARS = 8


def _temporary_affixes(target: Path) -> tuple[str, str]:
    """The prefix and suffix of :func:`atomic_path`'s temporary file beside ``target``."""
    return f".{target.stem}.", f".part{target.suffix}"


def _limits(path: Path) -> tuple[int, int]:
    """(NAME_MAX, PATH_MAX) [bytes] of the file system of ``path``'s nearest existing folder."""
    folder = path.parent
    while True:
        try:
            if folder.is_dir():
                return os.pathconf(folder, "PC_NAME_MAX"), os.pathconf(folder, "PC_PATH_MAX")
        except OSError:  # the folder's own name is too long: the file system's limits are above it
            pass
        if folder == folder.parent:
            return 255, 4096
        folder = folder.parent


def _check_length(path: Path) -> None:
    """The name, the temporary name and both whole paths fit the file system's limits."""
    name_max, path_max = _limits(path)
    prefix, suffix = _temporary_affixes(path)
    name = len(os.fsencode(path.name))
    temporary = len(os.fsencode(prefix + suffix)) + _RANDOM_CHARS
    whole = len(os.fsencode(str(path)))
    fix = "choose a shorter name (--video, --json, --plots ... take a path)"
    if name > name_max:
        raise ConfigError(f"cannot write {path}: its name is {name} bytes long; at most {name_max} fit; {fix}")
    if temporary > name_max:
        raise ConfigError(
            f"cannot write {path}: its temporary name ({prefix}XXXXXXXX{suffix}, written first and renamed) "
            f"would be {temporary} bytes long; at most {name_max} fit; {fix} ({temporary - name_max} bytes shorter)"
        )
    longest = whole - name + temporary
    if max(whole, longest) >= path_max:
        raise ConfigError(
            f"cannot write {path}: its path is {whole} bytes long ({longest} for its temporary file); at most "
            f"{path_max - 1} fit; {fix}, or a shorter folder"
        )


def _check_absent(path: Path, *, overwrite: bool) -> None:
    if path.exists() and not overwrite:
        raise OutputExistsError(
            f"{path} exists already; pass {option('overwrite', True)} to replace it, or choose another path"
        )


def check_folder_for(path: Path) -> None:
    """``path``'s folder exists and takes new files, or the nearest existing folder above it can hold it.

    The test creates and at once removes an empty temporary folder there (permissions alone do not
    tell: the superuser passes every permission check, and /proc or a read-only mount refuse anyway).
    """
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise ConfigError(
            f"cannot write {path}: {folder} is a file, not a folder; remove or rename it, or choose another path"
        )
    try:
        with signals_held():  # made and removed at once: an interrupt waits until the probe is gone
            os.rmdir(tempfile.mkdtemp(prefix=".nhsim-probe-", dir=folder))
    except OSError as exc:
        problem = (
            f"its folder {folder} does not accept new files"
            if folder == path.parent
            else f"its folder {path.parent} does not exist and cannot be created in {folder}"
        )
        raise ConfigError(f"cannot write {path}: {problem} ({exc.strerror or exc}); choose another path") from exc


@contextlib.contextmanager
def atomic_path(path: str | Path, *, overwrite: Overwrite = False) -> Iterator[Path]:
    """Yield a temporary path in the target's directory; rename it onto ``path`` on success.

    On any exception (including KeyboardInterrupt) the temporary file is removed and ``path`` is
    untouched. ``overwrite`` is asked before the work and again before the rename (:data:`Overwrite`).
    """
    target = Path(path)
    allowed: Callable[[Path], bool]
    if callable(overwrite):
        allowed = overwrite
    else:  # a flag, not read for its truth ("no" is true): True or False, else a ConfigError
        flag = check_flag("overwrite", overwrite)
        allowed = lambda _: flag
    check_writable(target, overwrite=allowed(target))
    prefix, suffix = _temporary_affixes(target)
    tmp: Path | None = None
    with folder_for(target):
        try:  # from the file's creation on: an interrupt while it is being set up removes it too
            with signals_held():  # one landing between the file's creation and ``tmp`` naming it waits
                fd, tmp_name = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=target.parent)
                tmp = Path(tmp_name)
                os.close(fd)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the permissions open() would
            yield tmp
            _check_absent(target, overwrite=allowed(target))
            os.replace(tmp, target)
        finally:
            if tmp is not None and tmp.exists():
                tmp.unlink()


@contextlib.contextmanager
def folder_for(path: Path) -> Iterator[None]:
    """Make ``path``'s folder (and the ones above it) where missing; when the block fails (an error, an
    interrupt), remove again those it made that are still empty (another writer may have put something
    in one meanwhile), so an unfinished output leaves no folder behind either."""
    made = [p for p in (path.parent, *path.parent.parents) if not p.exists()]  # deepest first
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        yield
    except BaseException:
        for folder in made:
            try:
                folder.rmdir()
            except OSError:
                break
        raise


def write_json(path: str | Path, data: Any, *, overwrite: Overwrite = False) -> Path:
    """Write standard JSON atomically (indent 2, sorted keys); a NaN or infinite number is written as null."""
    text = json.dumps(json_safe(data), indent=2, sort_keys=True, allow_nan=False, default=_default)
    with atomic_path(path, overwrite=overwrite) as tmp:
        tmp.write_text(text + "\n", encoding="utf-8")
    return Path(path)


def json_safe(data: Any) -> Any:
    """``data`` with arrays as lists and every non-finite float (NaN, +-inf) as None (JSON null)."""
    if hasattr(data, "tolist") and not isinstance(data, (str, bytes)):
        data = data.tolist()
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: json_safe(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [json_safe(v) for v in data]
    return data


def _default(obj: Any) -> Any:
    if hasattr(obj, "tolist"):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__}")
