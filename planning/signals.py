"""SIGINT and SIGTERM held across code that would lose them or be left half done by them.

Two kinds of code must not take a ``KeyboardInterrupt`` in the middle:

- C code that runs the Python signal handlers and swallows what they raise: CasADi polls for signals
  inside a solve, catches the ``KeyboardInterrupt`` and ends the solve as failed, so the interrupt is
  lost (:mod:`control.mpc`);
- bookkeeping that must finish once begun: Optuna's ``study.optimize`` writes a trial's result to its
  storage after the objective returns, and an interrupt landing there leaves the trial ``RUNNING``
  and Optuna's own state inconsistent (it fails with ``AssertionError: Should not reach``).

:func:`signals_held` notes the signals for the block's duration and acts on them as it ends;
:func:`signals_released`, inside a held block, lets them act at once (the objective of a study, where
the time is spent) and delivers those noted so far as it begins. A solve too long to hold (the
``optim`` planner's IPOPT solve takes seconds) runs in :func:`signals_end_early`: a signal ends it at
CasADi's next poll, as CasADi means it to, and is acted on again as the solve returns, so it is not
lost.

A third kind takes them late: a compiled kernel runs no Python code, so the thread that calls it runs
no signal handler until it returns (Hybrid-A*'s search, one call up to the plan's time limit, took a
Ctrl-C 2.8 s late on a 2000-obstacle world, and up to the whole limit on a world whose goal it
cannot reach). :func:`stoppable` runs such a kernel in a helper thread and tells it to stop when the
calling thread takes the interrupt.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from typing import Any

#: The signals held.
HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)

#: The held blocks open in the main thread, innermost last: (the handlers they replaced, signals noted).
_HELD: list[tuple[dict[signal.Signals, Any], list[int]]] = []


def _noting(noted: list[int]) -> Callable[[int, Any], None]:
    def note(signum: int, frame: Any) -> None:
        noted.append(signum)

    note.nhsim_noting = True  # type: ignore[attr-defined]
    return note


def _deliver(noted: list[int]) -> None:
    """Raise each signal noted once more (to the handlers in place now), and forget them."""
    pending = list(dict.fromkeys(noted))
    noted.clear()
    for signum in pending:
        signal.raise_signal(signum)


def _replaceable() -> dict[signal.Signals, Any] | None:
    """The handlers of the signals in place, when this thread may replace and restore them (it is the main
    thread, and every handler was set from Python); else None."""
    if threading.current_thread() is not threading.main_thread():
        return None
    previous: dict[signal.Signals, Any] = {sig: signal.getsignal(sig) for sig in HELD_SIGNALS}
    return None if any(h is None for h in previous.values()) else previous


def _set(handlers: dict[signal.Signals, Any]) -> None:
    for sig, handler in handlers.items():
        signal.signal(sig, handler)


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Within the block SIGINT and SIGTERM are only noted; on leaving, the previous handlers are back
    and each signal noted is raised again, so they act on it (e.g. raise KeyboardInterrupt) then.

    Outside the main thread (where no handler can be set), or when a handler was not set from Python
    (it could not be restored), the block runs as it is.
    """
    previous = _replaceable()
    if previous is None:
        yield
        return
    noted: list[int] = []
    _set(dict.fromkeys(HELD_SIGNALS, _noting(noted)))
    _HELD.append((previous, noted))
    try:
        yield
    finally:
        _HELD.pop()
        _set(previous)
        _deliver(noted)


@contextlib.contextmanager
def sigint_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread within the block (threads and processes started here inherit it): a
    terminal's Ctrl-C, which reaches every process of a command, is then the command's alone to act on. One that
    came meanwhile is delivered as the block ends. Outside the main thread it does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextlib.contextmanager
def signals_released() -> Iterator[None]:
    """Inside :func:`signals_held`: the handlers it replaced act again within this block, and the
    signals it noted so far are delivered to them as the block begins; on leaving, they are held
    again. Outside a held block (or outside the main thread) the block runs as it is."""
    if not _HELD or threading.current_thread() is not threading.main_thread():
        yield
        return
    previous, noted = _HELD[-1]
    _set(previous)
    try:
        _deliver(noted)
        yield
    finally:
        _set(dict.fromkeys(HELD_SIGNALS, _noting(noted)))


@contextlib.contextmanager
def signals_end_early() -> Iterator[None]:
    """For C code that runs the Python signal handlers while it works, ends its work early when one
    raises, and swallows the ``KeyboardInterrupt`` (a CasADi solve ends as failed and returns). Within
    the block SIGINT and SIGTERM are noted and raise ``KeyboardInterrupt``, so such a solve stops at its
    next poll; on leaving, the previous handlers are back and each signal noted is raised again, so they
    act on it (e.g. raise ``KeyboardInterrupt``) then. One that left the block as an exception is not
    raised again.

    Inside :func:`signals_held` (and not released) the signals stay held: the block runs as it is.
    Outside the main thread, or when a handler was not set from Python, it runs as it is too.
    """
    previous = _replaceable()
    if previous is None or any(getattr(h, "nhsim_noting", False) for h in previous.values()):
        yield
        return
    noted: list[int] = []

    def note_and_raise(signum: int, frame: Any) -> None:
        noted.append(signum)
        raise KeyboardInterrupt(signal.Signals(signum).name)

    _set(dict.fromkeys(HELD_SIGNALS, note_and_raise))
    try:
        yield
    except KeyboardInterrupt:
        noted.clear()  # it left the block: acted on already
        raise
    finally:
        _set(previous)
        _deliver(noted)


class KernelRun:
    """A kernel running in a helper thread (:func:`stoppable`): ``done`` is set when it has ended, with its
    result in ``out`` or what it raised in ``error``."""

    def __init__(self, kernel: Any, full: tuple[Any, ...]) -> None:
        import numba

        kernel.compile(tuple(numba.typeof(a) for a in full))  # readied in the calling thread (see stoppable)
        self.done = threading.Event()  # not Thread.join: a join the interrupt lands in may mark a running
        # thread ended (CPython 3.11's _wait_for_tstate_lock releases the lock it waited on), and a join
        # after it returns at once
        self.out: Any = None
        self.error: BaseException | None = None

        def run() -> None:
            try:
                self.out = kernel(*full)
            except BaseException as exc:  # handed to the calling thread
                self.error = exc
            finally:
                self.done.set()

        threading.Thread(target=run, name=f"nhsim-{getattr(kernel, '__name__', 'kernel')}", daemon=True).start()


def stoppable(
    kernel: Any, *args: Any, watch: Callable[[KernelRun, Callable[..., KernelRun]], None] | None = None
) -> Any:
    """``kernel(*args, stop)`` run in a helper thread while this one waits, so that this thread takes
    SIGINT and SIGTERM at once: the handler's exception sets ``stop[0]``, the kernel ends at its next
    look at it, and the exception is raised here once the kernel has returned.

    ``kernel`` is a numba dispatcher compiled with ``nogil=True`` whose last argument is ``stop``, a (1,)
    bool array it reads often (every millisecond or so). numba readies the kernel in this thread first
    (:meth:`compile` on the arguments' types, which the call then finds), so the time a plan's clock
    leaves out as readying code is timed where the clock looks (:mod:`planning.clock`). What the kernel
    raises is raised here.

    ``watch``, when given, is called from this thread about every millisecond, and once more after every
    kernel started has ended, with the first kernel's :class:`KernelRun` and ``spawn(kernel, *args)``,
    which starts another kernel in its own helper thread with the same ``stop`` and returns its run.
    Returns the first kernel's result, once every kernel started (by then) has ended. When one raises, the
    others are told to stop, the watch is not called again, and what it raised is raised here.
    """
    import numpy as np

    stop = np.zeros(1, dtype=np.bool_)
    runs = [KernelRun(kernel, (*args, stop))]

    def spawn(other: Any, *other_args: Any) -> KernelRun:
        runs.append(KernelRun(other, (*other_args, stop)))
        return runs[-1]

    try:
        while True:
            pending = [r for r in runs if not r.done.is_set()]
            if pending:
                pending[0].done.wait(0.1 if watch is None else 0.001)
            if any(r.error is not None for r in runs):  # the others stop at their next look; it is raised below
                stop[0] = True  # (a watch would read a result the failed kernel never gave)
                for r in runs:
                    r.done.wait()
                break
            if watch is not None:  # called once more after the last has ended: it may start another
                watch(runs[0], spawn)
            if all(r.done.is_set() for r in runs):
                break
    except BaseException:
        stop[0] = True
        for r in runs:
            r.done.wait()
        raise
    for r in runs:
        if r.error is not None:
            raise r.error
    return runs[0].out
