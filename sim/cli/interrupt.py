"""SIGTERM and SIGHUP handled as Ctrl-C for the whole of a command.

``timeout``, job schedulers, ``kill`` and container runtimes stop a process with SIGTERM; Python's
default for it ends the process at once (exit status 143), skipping the cleanup a Ctrl-C gets:
removing a file being written, closing worker processes, keeping the runs already finished and
saying so. :func:`sigterm_as_interrupt` makes SIGTERM raise KeyboardInterrupt, as SIGINT does, so
both take the same path and ``nhsim`` exits 130 with its "interrupted" message (the README's
exit-status contract). SIGHUP (a closed terminal, a dropped ssh connection) is handled as SIGTERM
(:func:`_hangup`): its default ended the command with 129 and left a half-written video in its hidden
staging folder. :func:`sim.cli.main.main` holds it around every command.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from types import FrameType
from typing import Any

#: Packages whose Python code an exception raised by a signal handler must not cross: C code calls it
#: back and drops what it raises (llvmlite's object-cache hooks, while numba compiles or loads a
#: kernel) or turns it into a SystemError (numba's helpers that compiled code calls, such as the
#: unpickling of a kernel's constants), and numba's compiler, interrupted in its passes or its imports,
#: leaves LLVM's objects half built (the command said "interrupted", then died at exit: ``free():
#: double free detected``, or by SIGINT). And the OpenGL calls made through ctypes (PyOpenGL, and
#: MuJoCo's OSMesa, EGL and GLFW contexts, which call it): ctypes turns an exception raised while it
#: converts a call's arguments into ``ctypes.ArgumentError``, so a SIGTERM during a render ended the
#: command with "ArgumentError: argument 2: KeyboardInterrupt: signal SIGTERM", exit status 1 (2 of 15
#: renders stopped at random moments under load).
SWALLOWING = (
    f"{os.sep}llvmlite{os.sep}",
    f"{os.sep}numba{os.sep}",
    f"{os.sep}OpenGL{os.sep}",
    *(f"{os.sep}mujoco{os.sep}{gl}{os.sep}" for gl in ("osmesa", "egl", "glfw")),
)
#: Finalizers: Python runs them when an object is freed, anywhere, and prints and drops what they raise
#: ("Exception ignored in: ... __del__"), so an interrupt raised in one was lost and the command ran on.
#: A ``__del__`` method (its name), or a ``weakref.finalize`` callback (called from the standard
#: library's ``weakref`` module).
FINALIZER = "__del__"
WEAKREF_FILE = f"{os.sep}weakref.py"
#: The import machinery (``importlib._bootstrap`` and ``_bootstrap_external``, frozen): an interrupt
#: raised while a module is imported left it half initialised, and a C extension's initialisation
#: turns it into an ImportError (a SIGTERM 1.4 s into ``nhsim simulate`` ended it with "ImportError:
#: initialization failed" from ``import mujoco``, exit status 1); importlib's module-lock callbacks
#: drop it. An interrupt waits for the import to finish (a few tenths of a second at most).
IMPORTING = "<frozen importlib._bootstrap"
#: How long an interrupt waits before it is tried again [s].
RETRY_S = 0.01


#: The frames that called the innermost :func:`sigterm_as_interrupt` block (where its interrupt is
#: caught): an interrupt never crosses them, so :func:`_deferred` looks only at the frames above.
_OUTSIDE: list[tuple[FrameType, ...]] = []


def _deferred(frame: FrameType | None) -> bool:
    """Whether an interrupt raised now would cross :data:`SWALLOWING` code, an import (:data:`IMPORTING`)
    or a finalizer (:data:`FINALIZER`), or leave an ``exec`` or ``eval`` of source text: a frame of any of them is on
    the stack above the block's callers (:data:`_OUTSIDE`; below them are, for instance, ``python -c``'s
    own source text and pytest-xdist's, which the interrupt, caught in the block, never leaves).

    CPython runs source text through ``PyRun_String`` and, when a KeyboardInterrupt leaves it, marks the
    interpreter as stopped by an unhandled Ctrl-C; ``python -m sim`` then ends by killing itself with
    SIGINT at exit (status -2), however the command handled the interrupt and whatever status it
    returned. Source text is run more often than it seems: ``dataclasses`` and ``namedtuple`` build
    their methods with it, numba its stubs, and a class of either is made whenever a module defining
    one is imported. Such code is module-level code named ``<string>``.
    """
    outside = _OUTSIDE[-1] if _OUTSIDE else ()
    while frame is not None and not any(frame is f for f in outside):
        code = frame.f_code
        if code.co_filename == "<string>" and code.co_name == "<module>":
            return True
        if any(part in code.co_filename for part in SWALLOWING) or code.co_filename.startswith(IMPORTING):
            return True
        if code.co_name == FINALIZER or code.co_filename.endswith(WEAKREF_FILE):
            return True
        frame = frame.f_back
    return False


#: After this long waiting [s], a waiting interrupt says why the command has not stopped yet.
NOTICE_S = 1.0
#: The interrupt waiting, if any: when it came ("since") and whether it has said why ("told").
_WAITING: dict[str, float] = {}


def _retry(signum: int) -> None:
    """Try a waiting interrupt again: the signal is raised anew, so that the handler in place now takes
    it (inside :func:`planning.signals.signals_held` it is noted and acted on as the block ends: a retry
    must not land in Optuna's bookkeeping either)."""
    _WAITING["retry"] = 1.0
    signal.raise_signal(signum)


def _interrupt(signum: int, frame: FrameType | None) -> None:
    """Raise KeyboardInterrupt; where that would be lost or break a compile (:func:`_deferred`), raise it
    a moment later, once the running code is past that point (:func:`_retry`). A second signal while one
    waits is raised at once (the user insists; a kernel being compiled is then lost and is compiled again
    next time)."""
    retry = bool(_WAITING.pop("retry", 0.0))
    if _deferred(frame) and (retry or not _WAITING):
        since = _WAITING.setdefault("since", time.monotonic())
        if retry and time.monotonic() - since > NOTICE_S and not _WAITING.get("told"):
            _WAITING["told"] = 1.0
            print("nhsim: stopping once the code running now can be left (numba compiling a kernel, a module being "
                  "imported); interrupt again to stop at once", file=sys.stderr, flush=True)  # fmt: skip
        _later(signum)
        return
    _WAITING.clear()
    signal.setitimer(signal.ITIMER_REAL, 0.0)
    raise _Interrupt(signum)


def _hangup(signum: int, frame: FrameType | None) -> None:
    """SIGHUP, handled as SIGTERM is: by :func:`_interrupt`, or, where a block has put another handler in
    SIGTERM's place (:func:`planning.signals.signals_held` notes SIGINT and SIGTERM only, to act on them as
    it ends), by that handler, as a SIGTERM. Ignored where SIGTERM is."""
    handler = signal.getsignal(signal.SIGTERM)
    if handler is _interrupt or not (callable(handler) or handler == signal.SIG_IGN):
        _interrupt(signum, frame)
    elif callable(handler):
        handler(signal.SIGTERM, frame)


#: The signals :func:`sigterm_as_interrupt` stops a command on, each with its handler.
STOPPING = ((signal.SIGINT, _interrupt), (signal.SIGTERM, _interrupt), (signal.SIGHUP, _hangup))


class _Interrupt(KeyboardInterrupt):
    """The KeyboardInterrupt a signal raised (its number kept, should Python drop it: :func:`_dropped`)."""

    def __init__(self, signum: int) -> None:
        super().__init__(f"signal {signal.Signals(signum).name}")
        self.signum = signum


def _later(signum: int) -> None:
    """Raise the signal's interrupt again in :data:`RETRY_S` (:func:`_retry`)."""
    signal.signal(signal.SIGALRM, lambda _s, _f: _retry(signum))
    signal.setitimer(signal.ITIMER_REAL, RETRY_S)


def _dropped(unraisable: Any) -> None:
    """``sys.unraisablehook`` within the block: an interrupt Python dropped is raised again a moment later.

    Python prints and drops what a finalizer or a weakref callback raises ("Exception ignored in"). The
    frames of ``__del__`` methods and ``weakref.finalize`` callbacks are known (:func:`_deferred`), but
    any weakref callback may run anywhere: a SIGTERM 0.42 s into ``nhsim simulate``, retried while
    importlib's module-lock callback ran (``_get_module_lock.<locals>.cb``), was dropped there, and the
    command ran on to its end and wrote every output (exit status 0)."""
    if isinstance(unraisable.exc_value, _Interrupt) and _OUTSIDE:
        _later(unraisable.exc_value.signum)
        return
    _HOOKS[-1](unraisable)


#: The ``sys.unraisablehook`` each open block replaced, innermost last.
_HOOKS: list[Any] = []


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block SIGTERM and SIGHUP (unless ignored, as ``nohup`` leaves it) raise KeyboardInterrupt,
    as SIGINT does, and none is lost inside a
    C callback that would drop it nor raised inside numba's compiler or its runtime helpers (it is
    raised when they have returned: :func:`_deferred`); the previous handlers are restored on leaving.
    Outside the main thread (where no handler can be set) it does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    callers: list[FrameType] = []
    frame: FrameType | None = sys._getframe(1)
    while frame is not None:
        callers.append(frame)
        frame = frame.f_back
    _OUTSIDE.append(tuple(callers))
    alarm = signal.getsignal(signal.SIGALRM)
    previous = {
        sig: signal.signal(sig, handler)
        for sig, handler in STOPPING
        if sig != signal.SIGHUP or signal.getsignal(sig) != signal.SIG_IGN  # ``nohup``: a hangup is ignored
    }
    _HOOKS.append(sys.unraisablehook)
    sys.unraisablehook = _dropped
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        _WAITING.clear()
        _OUTSIDE.pop()
        sys.unraisablehook = _HOOKS.pop()
        for sig, handler in (*previous.items(), (signal.SIGALRM, alarm)):
            signal.signal(sig, handler)
