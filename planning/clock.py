"""A planner's clock: its time limit counts planning, not numba compiling the planner's kernels.

A fresh install compiles each compiled kernel on its first call (the collision field's, BiRRT's
search loop, Hybrid-A*'s search: tens of seconds of CPU in all) and caches it on disk; every later
process loads it in milliseconds. A time limit that counted the compiling would time out a fresh
install's first plans (BiRRT on 'nav_map1' ran 16 iterations in its 30 s), so the same problem would
get another answer on a first run than on any other. :class:`PlanClock` leaves the compiling out of
the time it holds against the limit; the time a planner reports (``stats["time_s"]``) still includes
it, and ``stats["compile_s"]`` says how much of it that was.

Compiling is timed by numba's own ``numba:compile`` events (the outermost of nested compiles, per
thread: a planner's compiles happen in the thread that calls its kernels). Loading a kernel from the
disk cache is not compiling and counts.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from numba.core import event


class _CompileTimer(event.Listener):  # type: ignore[misc]
    """Seconds each thread spent in numba compiles (nested ones counted once)."""

    def __init__(self) -> None:
        self.local = threading.local()

    def on_start(self, ev: Any) -> None:
        depth = getattr(self.local, "depth", 0)
        if depth == 0:
            self.local.since = time.perf_counter()
        self.local.depth = depth + 1

    def on_end(self, ev: Any) -> None:
        self.local.depth -= 1
        if self.local.depth == 0:
            self.local.total = self.seconds()
            del self.local.since

    def seconds(self) -> float:
        since = getattr(self.local, "since", None)
        return getattr(self.local, "total", 0.0) + (0.0 if since is None else time.perf_counter() - since)


_TIMER = _CompileTimer()
event.register("numba:compile", _TIMER)


def compile_seconds() -> float:
    """Seconds this thread has spent compiling numba kernels (one that is compiling now included)."""
    return _TIMER.seconds()


class PlanClock:
    """Wall time since a planner started, and the part of it that counts against its time limit.

    Args:
        limit: The time limit [s].
    """

    def __init__(self, limit: float) -> None:
        self.limit = float(limit)
        self.t0 = time.perf_counter()
        self._c0 = compile_seconds()

    def elapsed(self) -> float:
        """Seconds since the start (what the planner reports)."""
        return time.perf_counter() - self.t0

    def compiling(self) -> float:
        """Seconds of :meth:`elapsed` numba spent compiling kernels."""
        return compile_seconds() - self._c0

    def working(self) -> float:
        """Seconds since the start less the compiling: what the time limit counts."""
        return self.elapsed() - self.compiling()

    def expired(self) -> bool:
        """Whether the time limit is spent."""
        return self.working() > self.limit

    def remaining(self) -> float:
        """Seconds of the time limit left (0 when spent)."""
        return max(0.0, self.limit - self.working())

    def deadline(self) -> float:
        """``time.perf_counter()`` value at which the limit is spent, were nothing compiled from now on."""
        return time.perf_counter() + self.remaining()
