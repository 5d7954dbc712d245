"""Writing outputs safely: to a temporary name beside the target, renamed when complete.

An existing file is never replaced unless ``overwrite`` is true; an interrupted write leaves no
partial file under the final name. Only a regular file is replaced (or a symbolic link: the link itself,
the file it names is left as it is): a folder, a FIFO, a socket or a device is refused, as is a file that
cannot be renamed over (immutable, append-only, another user's in a sticky folder). A command that writes
several outputs stages them (:class:`StagedOutputs`): every one written under a temporary name, then all
moved into place in one step, so an interrupt or a failure leaves the old set whole.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import re
import shutil
import stat
import sys
import tempfile
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from planning.core.checks import check_flag
from planning.errors import ConfigError, NhsimError, OutputExistsError, option
from planning.signals import signals_held

#: The check of an output that is a folder (a bag: :func:`sim.io.bag.check_bag_target`): raises when the
#: folder at the path cannot be written or replaced.
FolderCheck = Callable[..., None]

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
            true), ``path`` is among the files every run reads (:func:`check_not_read_by_runs`), a folder or
            anything else that is not a regular file (a FIFO, a socket, a device, or a symbolic link to one:
            :func:`check_regular`), it exists and cannot be renamed over (:func:`unreplaceable`), a file stands
            where one of its folders should be, its folder (or the nearest existing one above it) does not accept
            new files, or its name, its temporary name (:func:`atomic_path`) or either's whole path is longer than
            the file system takes (NAME_MAX, PATH_MAX).
    """
    overwrite = check_flag("overwrite", overwrite)
    path = Path(path)
    check_length(path)
    check_not_read_by_runs(path)
    if path.is_dir():
        raise ConfigError(f"cannot write {path}: it is a folder; give a file name")
    check_regular(path)
    _check_absent(path, overwrite=overwrite)
    if os.path.lexists(path):
        why = unreplaceable(path)
        if why:
            raise ConfigError(f"cannot replace {path}: {why}; fix that, or choose another path")
    check_folder_for(path)


def check_not_read_by_runs(path: Path) -> None:
    """Refuse an output among the files nhsim's runs read whatever the command names: its models folder (the
    robots' models and sensor settings, the scenarios and their maps, the balance profiles: a run reads the
    default scenario, or ``open`` for a reference, without naming it) and the files of the robots registered
    besides (a plugin's), with ``--overwrite`` too: written over, every later run fails or runs other physics.
    Its folders' symbolic links are resolved, not a link at the path itself (an output replaces the link, not
    the file it names: :func:`check_regular`).

    Raises:
        ConfigError: Naming what the path is and the fix.
    """
    from planning.core.robot import MODELS_DIR, ROBOTS, robot_files

    target = Path(os.path.normpath(resolved(Path(path).parent) / Path(path).name))  # "x/.." is x's folder
    models = MODELS_DIR.resolve()
    what = f"inside nhsim's models folder {models}" if target == models or models in target.parents else ""
    for name in sorted(set(ROBOTS) - set(ROBOTS.built_in())) if not what else ():
        try:
            files = robot_files(name)
        except ConfigError:  # a plugin's robot registered wrongly: its own use says so, not every output
            continue
        if target in {resolved(f) for f in (files.mjcf, files.scene, files.sensors)}:
            what = f"one of robot {name}'s files"
    if what:
        raise ConfigError(
            f"cannot write {path}: it is {what}, which the runs read (robots, sensor settings, scenarios, maps); "
            "choose a path outside it"
        )


#: What a file that is not a regular one is, by its type (:mod:`stat`).
_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
)


def check_regular(path: Path) -> None:
    """Refuse an existing ``path`` that is no regular file: an output is written under a temporary name and
    renamed onto its target, which would put a regular file where a FIFO, a socket or a device (``/dev/null``)
    stood. A symbolic link is replaced by the output (the file it names is left as it is), unless it names
    such a file: then it is refused too. A path that does not exist, and a dangling link, pass.

    Raises:
        ConfigError: Naming the path, what it is and the fix.
    """
    try:
        info = os.lstat(path)
    except OSError:  # absent (or unreadable: the folder checks say why)
        return
    link = stat.S_ISLNK(info.st_mode)
    if link:
        try:
            info = os.stat(path)
        except OSError:  # a dangling link: the link itself is replaced
            return
    if stat.S_ISREG(info.st_mode) or stat.S_ISDIR(info.st_mode):
        stream = _process_stream(path)  # /dev/stdout to a file: a link to a regular file, which --overwrite replaced
        if stream:
            raise ConfigError(
                f"cannot write {path}: it is {stream}, not a file an output may replace (an output is written beside "
                "it and renamed onto it, which would replace it); give a file path"
            )
        return
    kind = next((name for test, name in _KINDS if test(info.st_mode)), "not a regular file")
    what = f"a symbolic link to {kind}" if link else kind
    raise ConfigError(
        f"cannot write {path}: it is {what}, and an output is a regular file written beside it and renamed "
        "onto it, which would replace it; choose another path (a regular file, or one that does not exist)"
    )


def _process_stream(path: Path) -> str:
    """What ``path`` is when it is, or links to, a file of the kernel's ``/proc`` or ``/dev`` (``/dev/stdout``,
    ``/dev/fd/1``, ``/proc/self/fd/1``: where stdout goes to a file they pass as links to a regular file, and
    ``--overwrite`` replaced the link ``/dev/stdout`` itself with the output); "" for any other path (``/dev/shm``,
    a memory file system for files, is one)."""

    def kernel(p: str) -> bool:
        return any(p == top or p.startswith(top + "/") for top in ("/proc", "/dev")) and not p.startswith("/dev/shm/")

    if kernel(os.path.abspath(path)):
        return "a file of the kernel's /proc or /dev"
    try:
        target = os.readlink(path)
    except OSError:  # not a link
        return ""
    return f"a link to {target}" if kernel(os.path.normpath(os.path.join(os.path.dirname(path), target))) else ""


#: ``FS_IOC_GETFLAGS`` (Linux) and its immutable and append-only flags (``chattr +i``, ``chattr +a``).
_GETFLAGS, IMMUTABLE, APPEND_ONLY = 0x80086601, 0x10, 0x20


def inode_flags(path: Path) -> int:
    """The inode flags of the file or folder ``path`` (Linux; 0 where they cannot be read)."""
    if not sys.platform.startswith("linux"):
        return 0
    import fcntl

    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return 0
    try:
        return int.from_bytes(fcntl.ioctl(fd, _GETFLAGS, bytes(8))[:4], sys.byteorder)
    except OSError:  # a file system without inode flags
        return 0
    finally:
        os.close(fd)


def unreplaceable(path: Path) -> str:
    """Why the existing file ``path`` cannot be renamed over (or moved aside), or "" when nothing shows it: an
    immutable or append-only file, or folder, and another user's file in a sticky folder (as in /tmp)."""
    parent = path.parent
    flags = inode_flags(parent)
    if flags & (IMMUTABLE | APPEND_ONLY):
        what = "immutable" if flags & IMMUTABLE else "append-only"
        return f"its folder {parent} is {what}, so no entry in it can be replaced (as root: chattr -i -a {parent})"
    try:
        info, folder = os.lstat(path), os.stat(parent)
    except OSError:
        return ""
    flags = 0 if stat.S_ISLNK(info.st_mode) else inode_flags(path)
    if flags & (IMMUTABLE | APPEND_ONLY):
        what = "immutable" if flags & IMMUTABLE else "append-only"
        return f"it is {what} (lsattr shows it; as root: chattr -i -a {path})"
    if folder.st_mode & stat.S_ISVTX and os.geteuid() not in (0, info.st_uid, folder.st_uid):
        return (
            f"its folder {parent} is sticky (as /tmp is) and neither it nor {path} is yours: only an owner replaces it"
        )
    return ""


def resolved(path: Path | str) -> Path:
    """``Path(path).resolve()``, a loop of symbolic links said as bad input (Python 3.11 raises a RuntimeError, 3.13
    an OSError: either ended a command with a traceback and status 1).

    Raises:
        ConfigError: ``path`` leads into a loop of symbolic links.
    """
    try:
        return Path(path).resolve()
    except (RuntimeError, OSError) as exc:
        raise ConfigError(
            f"{path}: a loop of symbolic links ({exc}); choose another path, or point the link at a file"
        ) from None


def check_distinct(paths: Iterable[Path] | Mapping[str, Path]) -> None:
    """Check, before any work, that no two of a command's outputs are one file.

    Args:
        paths: The outputs' paths, or each output's name (its option: ``"--json"``, ``"--video"``) -> its path,
            so that the message names the two outputs.

    Raises:
        ConfigError: Two of ``paths`` resolve to the same file (the message names those two).
    """
    named = list(paths.items()) if isinstance(paths, Mapping) else [("", p) for p in paths]
    seen: dict[Path, tuple[str, Path]] = {}
    for name, path in ((n, Path(p)) for n, p in named):
        first_name, first = seen.setdefault(resolved(path), (name, path))
        if first is path:
            continue
        if name and first_name:
            both = f"{first_name} and {name} both name {first}" + (f" (as {path})" if str(path) != str(first) else "")
        elif str(path) != str(first):
            both = f"{first} and {path} are one file"
        else:
            both = f"{path} is given for two of them"
        raise ConfigError(f"two outputs share a path: {both}; choose distinct names")


#: Characters ``tempfile.mkstemp`` puts between its prefix and suffix.
_RANDOM_CHARS = 8
#: The outputs this process has moved into place (:meth:`StagedOutputs.commit`), in order: an interrupt acted on
#: after a commit (held through it) says what was written, so a command saying "interrupted" is not taken to have
#: written nothing (``regress --update`` had replaced every baseline).
PLACED: list[Path] = []
#: The folder beside a staged output that holds it until every output of the command is written
#: (:class:`StagedOutputs`): ``.nhsim-outputs-XXXXXXXX.part``, the new outputs in its ``new`` folder.
_STAGE_PREFIX, _STAGE_SUFFIX = ".nhsim-outputs-", ".part"
#: Bytes a staged output's path adds to its target's: the staging folder, ``/new/``.
_STAGE_CHARS = len(_STAGE_PREFIX) + _RANDOM_CHARS + len(_STAGE_SUFFIX) + len("/new/")


def shown(path: str | Path) -> str:
    """``path`` as a message shows it: a staged output's path (in a hidden staging folder,
    :class:`StagedOutputs`) as its target's, which is what the user named."""
    sep = re.escape(os.sep)
    staged = rf"(^|{sep}){re.escape(_STAGE_PREFIX)}[^{sep}]+{re.escape(_STAGE_SUFFIX)}{sep}new{sep}"
    return re.sub(staged, r"\1", str(path))


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


def check_length(path: Path, *, temporary: tuple[str, str] | None = None, inner: int = 0) -> None:
    """The name, the temporary name, each folder's name and the whole paths fit the file system's limits (a command
    looking at a path before :func:`check_writable` does: a name too long makes ``is_file`` raise).

    Args:
        path: The output.
        temporary: The prefix and suffix of its temporary name (default :func:`atomic_path`'s; 8 random characters
            go between them).
        inner: Bytes the longest path inside the output adds to its temporary's (a folder's files, e.g. a bag's
            ``/NAME/NAME.mcap``).

    Raises:
        ConfigError: Naming the length, the limit and the fix.
    """
    name_max, path_max = _limits(path)
    prefix, suffix = temporary or _temporary_affixes(path)
    name = len(os.fsencode(path.name))
    temp = len(os.fsencode(prefix + suffix)) + _RANDOM_CHARS
    whole = len(os.fsencode(str(path)))
    fix = "give this output a shorter name (the option that names it takes a path)"
    folder = next((part for part in path.parts[:-1] if len(os.fsencode(part)) > name_max), None)
    if folder is not None:
        raise ConfigError(
            f"cannot write {path}: its folder name {folder[:40]}... is {len(os.fsencode(folder))} bytes long; at "
            f"most {name_max} fit in a name; give a shorter folder"
        )
    if name > name_max:
        raise ConfigError(f"cannot write {path}: its name is {name} bytes long; at most {name_max} fit; {fix}")
    if temp > name_max:
        raise ConfigError(
            f"cannot write {path}: its temporary name ({prefix}XXXXXXXX{suffix}, written first and renamed) "
            f"would be {temp} bytes long; at most {name_max} fit; {fix} ({temp - name_max} bytes shorter)"
        )
    longest = whole - name + _STAGE_CHARS + temp + inner  # a staged output's temporary file (StagedOutputs)
    if max(whole, longest) >= path_max:
        raise ConfigError(
            f"cannot write {path}: its path is {whole} bytes long ({longest} for its temporary files); at most "
            f"{path_max - 1} fit; {fix}, or a shorter folder"
        )


def _check_absent(path: Path, *, overwrite: bool) -> None:
    if os.path.lexists(path) and not overwrite:  # a dangling link too: replacing it is replacing a file
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
    # a flag is not read for its truth ("no" is true): True or False, else a ConfigError
    allowed = overwrite if callable(overwrite) else _flag(overwrite)
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
            with naming(target):
                yield tmp
            _check_absent(target, overwrite=allowed(target))
            check_regular(target)
            try:
                os.replace(tmp, target)
            except OSError as exc:
                kept = f"{target} is unchanged and the new file was removed"
                raise OutputsNotPlacedError(_not_placed(target, exc, kept)) from exc
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


class OutputsNotPlacedError(NhsimError, OSError):
    """Finished outputs could not be moved into place: every target keeps its old file (or stays absent),
    the new ones are removed; the message says why and the fix."""


def _not_placed(target: Path, exc: OSError, kept: str) -> str:
    """What :class:`OutputsNotPlacedError` says of ``target``, whose move failed with ``exc``: why, what is
    ``kept``, and the fix."""
    reason = exc.strerror or str(exc)
    why = unreplaceable(target) if os.path.lexists(target) else ""
    fix = f"{target}: {why}" if why else f"check that {target} and its folder can be renamed (permissions, lsattr -d)"
    return (
        f"could not put {target} in place: {reason}; {kept}; fix it ({fix}), then run the command again, or "
        "choose another path"
    )


#: How old [s] a staging folder left beside the outputs must be before a later command removes it: a command's
#: staging folder lives from its first output written to its commit (seconds, minutes for a long video).
STALE_STAGE_S = 24 * 3600.0


def _sweep_stale_stages(folder: Path) -> None:
    """Remove the staging folders a killed command left in ``folder`` (SIGKILL, a power loss: no cleanup ran;
    SIGHUP is an interrupt, :mod:`sim.cli.interrupt`): those untouched for :data:`STALE_STAGE_S` whose ``old``
    folder is empty. One holding an old output (a commit killed midway: the only copy of a replaced file) is
    kept, as is anything that is not one."""
    now = time.time()
    try:
        found = [p for p in folder.iterdir() if p.name.startswith(_STAGE_PREFIX) and p.name.endswith(_STAGE_SUFFIX)]
    except OSError:
        return
    for stage in found:
        parts = [stage, stage / "new", stage / "old"]
        try:
            if any(now - p.lstat().st_mtime < STALE_STAGE_S for p in parts if os.path.lexists(p)):
                continue
            old = stage / "old"
            if stage.is_symlink() or not stage.is_dir():
                continue
            if os.path.lexists(old) and (old.is_symlink() or not old.is_dir() or any(old.iterdir())):
                continue
        except OSError:
            continue
        shutil.rmtree(stage, ignore_errors=True)


class StagedOutputs:
    """A command's outputs, written under temporary names and moved into place together: all or none.

    Each output is written to :meth:`path`, a path of the target's name in a hidden folder beside it
    (``.nhsim-outputs-XXXXXXXX.part/new/``); :meth:`commit` then moves every output written into place in one
    step that SIGINT and SIGTERM wait for, each old file first moved aside into that folder. When a move
    fails, those done are undone (every old file back under its name) and :class:`OutputsNotPlacedError` says
    why. :meth:`discard` removes the staging folders (the new outputs when not committed, the old ones when
    committed) and, when not committed, the folders made for them. Use :func:`staged_outputs`.

    Args:
        overwrite: Whether an existing target may be replaced (:data:`Overwrite`: asked again at the commit).
        folders: The targets that are folders (a rosbag2 bag), each with the check made again as it moves in
            (``check(path, overwrite=...)``: :func:`sim.io.bag.check_bag_target`); the others are files
            (:func:`check_writable`).
    """

    def __init__(self, *, overwrite: Overwrite = False, folders: Mapping[Path, FolderCheck] | None = None) -> None:
        self._allowed = overwrite if callable(overwrite) else _flag(overwrite)
        self._folders = {Path(os.path.abspath(f)): check for f, check in (folders or {}).items()}
        self._stages: dict[Path, Path] = {}  # a target's folder (absolute) -> its staging folder
        self._staged: list[tuple[Path, Path]] = []  # (target, staged path)
        self._made: list[Path] = []  # folders made for the targets
        self._kept: set[Path] = set()  # staging folders holding an old output that could not be moved back
        self.committed = False
        #: The target :meth:`path` was last asked for: the output being written (None before the first).
        self.latest: Path | None = None
        self._retired: list[tuple[Path, Path]] = []  # (target, its never-written staged name): :meth:`retire`

    def path(self, target: str | Path) -> Path:
        """Where to write ``target``: its name in the staging folder beside it (made, with the target's
        folders, on first use)."""
        target = Path(target)
        staged = self._stage_for(target) / "new" / target.name
        self.latest = target
        if any(s == staged for _, s in self._staged):
            raise ConfigError(f"two outputs share a path: {target} is given for two of them; choose distinct names")
        self._staged.append((target, staged))
        return staged

    def retire(self, target: str | Path) -> None:
        """Remove ``target`` with the commit: an output of the set being replaced that the new set does not write
        again (a plot of a run kind it has not). It is moved aside as a replaced output is, and put back if the
        commit is undone; nothing happens to it if the outputs are not committed."""
        target = Path(target)
        staged = self._stage_for(target) / "new" / target.name  # never written: the commit only moves it aside
        if any(s == staged for _, s in self._staged):
            raise ConfigError(f"{target} is both written and removed by this command; choose distinct names")
        self._retired.append((target, staged))

    def _stage_for(self, target: Path) -> Path:
        """The staging folder beside ``target`` (made, with the target's folders, on first use)."""
        folder = Path(os.path.abspath(target.parent))
        stage = self._stages.get(folder)
        if stage is None:
            self._made += [p for p in (target.parent, *target.parent.parents) if not p.exists()]
            target.parent.mkdir(parents=True, exist_ok=True)
            _sweep_stale_stages(target.parent)
            with signals_held():  # an interrupt landing as the folder is made waits until it is named
                stage = Path(tempfile.mkdtemp(prefix=_STAGE_PREFIX, suffix=_STAGE_SUFFIX, dir=target.parent))
                self._stages[folder] = stage
            (stage / "new").mkdir()
            (stage / "old").mkdir()
        return stage

    def _check(self, target: Path) -> None:
        """The target checks made again as the outputs move in (another program may have written meanwhile: the
        refusal then says so, as the command had checked the target before it ran)."""
        check = self._folders.get(Path(os.path.abspath(target)), check_writable)
        try:
            check(target, overwrite=self._allowed(target))
        except OutputExistsError as exc:
            raise OutputExistsError(
                f"{exc} (it was written while this command ran, by another one writing the same outputs?); this "
                "command's outputs were not placed"
            ) from None

    def commit(self) -> list[Path]:
        """Move every output written into place, in one step SIGINT and SIGTERM wait for; returns the targets.

        Raises:
            OutputExistsError, ConfigError: A target changed since it was checked (nothing is moved).
            OutputsNotPlacedError: A move failed: every move done is undone, the old outputs kept.
        """
        ready = [(t, s) for t, s in self._staged if os.path.lexists(s)]
        gone = [t for t, s in self._staged if not s.parent.is_dir()]  # its staging folder removed while we ran
        if gone:
            raise OutputsNotPlacedError(
                f"{gone[0]}: its folder was removed (or moved) while the command ran, with the output written into "
                "it; no output was replaced, every old file is kept: run the command again"
            )
        with signals_held():
            for target, _ in ready:
                self._check(target)
            done: list[tuple[Path, Path, Path | None]] = []
            current = ready[0][0] if ready else Path()
            try:
                for target, staged in ready:
                    current = target
                    aside = staged.parent.parent / "old" / staged.name if os.path.lexists(target) else None
                    if aside is not None:
                        os.replace(target, aside)
                    done.append((target, staged, aside))
                    os.replace(staged, target)
                for target, staged in self._retired:
                    current = target
                    if os.path.lexists(target):
                        aside = staged.parent.parent / "old" / staged.name
                        os.replace(target, aside)
                        done.append((target, staged, aside))
            except OSError as exc:
                kept = self._undo(done)
                raise OutputsNotPlacedError(_not_placed(current, exc, kept)) from exc
            self.committed = True
            PLACED.extend(t for t, _ in ready)
        return [t for t, _ in ready]

    def _undo(self, done: list[tuple[Path, Path, Path | None]]) -> str:
        """Put back the old outputs of the moves ``done`` (the new ones back into their staging folders); says
        what is kept where."""
        lost: list[str] = []
        for target, staged, aside in reversed(done):
            try:
                if not os.path.lexists(staged) and os.path.lexists(target):  # the new one is in place
                    os.replace(target, staged)
                if aside is not None:
                    os.replace(aside, target)
            except OSError:
                lost.append(f"the old {target} could not be moved back: it is at {aside}, move it back to {target}")
                self._kept.add(staged.parent.parent)
        if lost:
            return "the other moves were undone, but " + "; ".join(lost)
        return "no output was replaced: every old file is kept and the new ones were removed"

    def discard(self) -> None:
        """Remove the staging folders (but one holding an old output that could not be moved back) and, unless
        committed, the folders made for the outputs that are still empty."""
        with signals_held():
            for stage in self._stages.values():
                if stage not in self._kept:
                    shutil.rmtree(stage, ignore_errors=True)
            if not self.committed:
                for folder in sorted(self._made, key=lambda p: len(p.absolute().parts), reverse=True):
                    with contextlib.suppress(OSError):
                        folder.rmdir()


#: Errors of a write that only a write gives (a full disk or quota, a file too large): one raised without a file
#: name (by ``write()`` or ``close()``: matplotlib's, ``Path.write_text``) is given the output's (:func:`naming`).
UNNAMED_WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


@contextlib.contextmanager
def naming(path: Path) -> Iterator[None]:
    """Within the block, ``path`` is being written: an OSError of :data:`UNNAMED_WRITE_ERRNOS` that names no
    file is given ``path`` as its file name, so the error says which output the disk could not take (as
    :func:`shown`: a staged output's path is its target's for the user)."""
    try:
        yield
    except OSError as exc:
        name_unnamed(exc, path)
        raise


def name_unnamed(exc: OSError, path: Path) -> None:
    """Give ``exc`` the file name ``path`` when it names none and is a write's error (:data:`UNNAMED_WRITE_ERRNOS`)."""
    if exc.filename is None and exc.errno in UNNAMED_WRITE_ERRNOS and not isinstance(exc, NhsimError):
        exc.filename = str(path)


def _flag(overwrite: Any) -> Callable[[Path], bool]:
    flag = check_flag("overwrite", overwrite)
    return lambda _: flag


@contextlib.contextmanager
def staged_outputs(
    *, overwrite: Overwrite = False, folders: Mapping[Path, FolderCheck] | None = None
) -> Iterator[StagedOutputs]:
    """A :class:`StagedOutputs` committed when the block ends without an error; its staging folders removed
    either way (on an error or an interrupt, with the new outputs: every old file is left as it was)."""
    stage = StagedOutputs(overwrite=overwrite, folders=folders)
    try:
        try:
            yield stage
        except OSError as exc:  # a full disk met writing the output last asked for: the error names it
            if stage.latest is not None:
                name_unnamed(exc, stage.latest)
            raise
        stage.commit()
    finally:
        stage.discard()


def write_json(path: str | Path, data: Any, *, overwrite: Overwrite = False) -> Path:
    """Write standard JSON atomically (indent 2, sorted keys); a NaN or infinite number is written as null.

    A numeric NumPy array is written compactly: a vector on one line, a matrix one row per line (a plan's
    855,000 poses take 2 s so, where one number per line took 7).
    """
    arrays: list[tuple[int, Any]] = []
    token = f"nhsim-array-{uuid.uuid4().hex}-"
    text = json.dumps(_with_slots(data, arrays, token), indent=2, sort_keys=True, allow_nan=False, default=_default)
    if arrays:
        text = re.sub(rf'^( *)(.*)"{token}(\d+)"', lambda m: _array_text(m, arrays), text, flags=re.MULTILINE)
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


def _with_slots(data: Any, arrays: list[tuple[int, Any]], token: str) -> Any:
    """``json_safe(data)`` with each numeric array replaced by a placeholder string naming its place in
    ``arrays`` (its dimensions, and the array as nested lists with non-finite numbers as None)."""
    if getattr(getattr(data, "dtype", None), "kind", "") in ("b", "i", "u", "f") and getattr(data, "ndim", 0) > 0:
        arrays.append((data.ndim, _finite_list(data)))
        return f"{token}{len(arrays) - 1}"
    if isinstance(data, dict):
        return {k: _with_slots(v, arrays, token) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [_with_slots(v, arrays, token) for v in data]
    return json_safe(data)


def _finite_list(array: Any) -> Any:
    """A NumPy array's ``tolist()`` with every NaN and infinity as None."""
    import numpy as np

    if array.dtype.kind == "f":
        bad = ~np.isfinite(array)
        if bad.any():
            array = array.astype(object)
            array[bad] = None
    return array.tolist()


def _array_text(match: re.Match[str], arrays: list[tuple[int, Any]]) -> str:
    """The placeholder's line with its array written in: a matrix of two or more rows a row per line."""
    indent, head = match.group(1), match.group(2)
    ndim, values = arrays[int(match.group(3))]
    text = json.dumps(values, allow_nan=False)
    if ndim == 2 and len(values) > 1:
        rows = text[1:-1].replace("], [", f"],\n{indent}  [")
        text = f"[\n{indent}  {rows}\n{indent}]"
    return f"{indent}{head}{text}"


def _default(obj: Any) -> Any:
    if hasattr(obj, "tolist"):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__}")
