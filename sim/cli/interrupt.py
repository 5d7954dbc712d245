"""SIGTERM handled as Ctrl-C for the whole of a command.

``timeout``, job schedulers, ``kill`` and container runtimes stop a process with SIGTERM; Python's
default for it ends the process at once (exit status 143), skipping the cleanup a Ctrl-C gets:
removing a file being written, closing worker processes, keeping the runs already finished and
saying so. :func:`sigterm_as_interrupt` makes SIGTERM raise KeyboardInterrupt, as SIGINT does, so
both take the same path and ``nhsim`` exits 130 with its "interrupted" message (the README's
exit-status contract). :func:`sim.cli.main.main` holds it around every command.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block SIGTERM raises KeyboardInterrupt, as SIGINT does; the previous handler is
    restored on leaving. Outside the main thread (where no handler can be set) it does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
