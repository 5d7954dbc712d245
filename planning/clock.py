"""A planner's clock: its time limit counts planning, not numba getting the planner's code ready.

A process runs a compiled kernel only once numba has it: compiled on its first call after an install
(tens of seconds of CPU for BiRRT's search loop, the collision field, Hybrid-A*'s search) and cached on
disk, or loaded from that cache in every later process (milliseconds a kernel, after numba's own
set-up on the first compiled call of a process, about 0.3 s: its typing and lowering registries, and
SciPy's linear algebra, which it imports to find BLAS). A time limit that counted this would
give the same problem another answer in a fresh process than in a warm one: a fresh install's first
BiRRT plan on 'nav_map1' ran 16 iterations in its 30 s, and a 2000-obstacle Hybrid-A* plan in a new
process overshot its 2 s limit by the loading. :class:`PlanClock` leaves the code's time out of the
time it holds against the limit; the time a planner reports (``stats["time_s"]``) still includes it,
and ``stats["code_s"]`` says how much of it that was.

numba's set-up is the process's, not any plan's: a :class:`PlanClock` starts once it is done
(:func:`ready`), so no plan's time holds it. Before, the first plan of a process held it or not by
accident: loading a scenario with an ellipse measures the start's distance to it in compiled code,
which set numba up first (a cold Hybrid-A* plan on an 8 x 8 m world reported 0.17 s); with circles,
boxes and polygons only, the plan did (0.52-0.62 s, the same plan).

The code's time is timed by numba's own ``numba:compiler_lock`` events: numba holds its compiler lock
while it compiles a kernel, loads one from the cache, or sets itself up, and at no other time (the
outermost of nested holds, per thread: a planner's kernels are readied in the thread that calls them).

:func:`monotonic` is the clock a compiled loop reads for its own deadline: ``time.perf_counter``'s
clock (POSIX ``CLOCK_MONOTONIC``), read by calling ``clock_gettime`` from the kernel. A kernel that
read the time through ``numba.objmode`` instead would be cached without its object-mode block, which
numba compiles afresh in every process (about 40 ms of each cold Hybrid-A* plan).
"""

from __future__ import annotations

import os
import threading
import time
from typing import Any

from llvmlite import ir
from numba import njit, types
from numba.core import cgutils, event
from numba.extending import intrinsic


class _CodeTimer(event.Listener):  # type: ignore[misc]
    """Seconds each thread spent holding (or waiting for) numba's compiler lock (nested holds counted once)."""

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


_TIMER = _CodeTimer()
event.register("numba:compiler_lock", _TIMER)


@intrinsic
def _clock_gettime(typingctx: Any) -> tuple[Any, Any]:
    """``clock_gettime(CLOCK_MONOTONIC)`` in seconds, as a float64 (a call by symbol name, which the
    disk cache keeps: the symbol is resolved in the loading process)."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        i32, i64, f64 = ir.IntType(32), ir.IntType(64), ir.DoubleType()
        timespec = ir.LiteralStructType([i64, i64])  # time_t tv_sec, long tv_nsec (LP64)
        fnty = ir.FunctionType(i32, [i32, timespec.as_pointer()])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "clock_gettime")
        ts = cgutils.alloca_once(builder, timespec)
        builder.call(fn, [ir.Constant(i32, time.CLOCK_MONOTONIC), ts])
        sec = builder.sitofp(builder.load(cgutils.gep_inbounds(builder, ts, 0, 0)), f64)
        nsec = builder.sitofp(builder.load(cgutils.gep_inbounds(builder, ts, 0, 1)), f64)
        return builder.fadd(sec, builder.fmul(nsec, ir.Constant(f64, 1e-9)))

    return types.float64(), codegen


@njit(cache=True)  # type: ignore[untyped-decorator]
def monotonic() -> float:
    """Seconds on ``time.perf_counter``'s clock, for compiled code (see the module doc)."""
    return _clock_gettime()  # type: ignore[call-arg,no-any-return]


_READY = False


def ready() -> float:
    """Set numba up in this process if it is not yet (its one-time set-up, by a call of the smallest
    cached kernel, :func:`monotonic`); the seconds that took (0.0 once done)."""
    global _READY
    if _READY:
        return 0.0
    t0 = time.perf_counter()
    monotonic()
    _READY = True
    return time.perf_counter() - t0


def code_seconds() -> float:
    """Seconds this thread has spent getting numba code ready: compiling kernels, loading them from the
    disk cache, numba's own set-up (the one under way now included)."""
    return _TIMER.seconds()


class PlanClock:
    """Wall time since a planner started, and the part of it that counts against its time limit.

    Args:
        limit: The time limit [s].
    """

    def __init__(self, limit: float) -> None:
        self.limit = float(limit)
        #: Seconds numba's set-up took before the clock started (:func:`ready`; 0.0 but in a process's
        #: first clock that found numba not yet set up).
        self.setup_s = ready()
        self.t0 = time.perf_counter()
        self._cpu0 = time.thread_time()
        self._c0 = code_seconds()
        self._code_seen = 0.0  # :meth:`code` when last read (it only grows)

    def elapsed(self) -> float:
        """Seconds since the start (what the planner reports)."""
        return time.perf_counter() - self.t0

    def code(self) -> float:
        """Seconds of :meth:`elapsed` numba spent getting code ready (:func:`code_seconds`)."""
        return code_seconds() - self._c0

    def working(self) -> float:
        """Seconds since the start less the code's: what the time limit counts."""
        return self.elapsed() - self.code()

    def expired(self) -> bool:
        """Whether the time limit is spent. The code's seconds only grow, so the elapsed time less those
        last read bounds the working time from above: while that bound is within the limit the answer
        needs one reading of the clock (about 0.1 us), and the code's timer (about 1 us) is read only after."""
        if time.perf_counter() - self.t0 - self._code_seen <= self.limit:
            return False
        self._code_seen = self.code()
        return time.perf_counter() - self.t0 - self._code_seen > self.limit

    def slowdown(self, least_cpu: float = 0.05, most: float = 4.0) -> float:
        """How much other processes slow this plan now, as wall seconds per second of CPU (1.0 on a quiet
        machine; 2-3 with two or three times as many busy threads as cores), at most ``most``. Measured on
        this thread since the start once it has run ``least_cpu`` seconds; before that, the one-minute load
        average per CPU this process may use. For predicting how long a step that cannot be stopped midway
        will take on the wall clock."""
        cpu = time.thread_time() - self._cpu0
        if cpu >= least_cpu:
            ratio = self.elapsed() / cpu
        else:
            ratio = os.getloadavg()[0] / len(os.sched_getaffinity(0))
        return min(most, max(1.0, ratio))

    def remaining(self) -> float:
        """Seconds of the time limit left (0 when spent)."""
        return max(0.0, self.limit - self.working())

    def deadline(self) -> float:
        """``time.perf_counter()`` value at which the limit is spent, were no code readied from now on."""
        return time.perf_counter() + self.remaining()
