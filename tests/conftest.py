"""Shared fixtures. MuJoCo's GL backend is chosen once, before any test module imports mujoco.

Tests marked ``slow`` are deselected by default (``-m "not slow"`` in pyproject); run them with
``-m slow``, or everything with ``--all-cases``.

On a fresh clone numba compiles every kernel on its first call (over a minute of CPU for the default
run) and caches it on disk. Two pytest-xdist workers that meet the same kernel at once would each
compile it; :func:`_compile_once` makes the second wait for the first and load its cache entry.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

#: Where the workers' per-kernel compile locks live (one file per kernel, shared by the workers).
LOCKS = Path(tempfile.gettempdir()) / f"nhsim-numba-compile-{os.getuid()}"


_HELD: set[str] = set()


@contextlib.contextmanager
def _kernel_lock(name: str) -> Iterator[None]:
    """An exclusive lock on ``name`` among the test processes (re-entered freely within one)."""
    if name in _HELD:
        yield
        return
    LOCKS.mkdir(exist_ok=True)
    with open(LOCKS / f"{name}.lock", "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        _HELD.add(name)
        try:
            yield
        finally:
            _HELD.discard(name)
            fcntl.flock(handle, fcntl.LOCK_UN)


def kernel_lock_name(func: Any) -> str:
    """The name of the lock the test processes compile ``func`` (a kernel's Python function) under."""
    return f"{func.__module__}.{func.__qualname__}".replace("<", "_").replace(">", "_")


def _compile_once() -> None:
    """Numba's ``Dispatcher.compile`` (which loads a cached kernel or compiles it) under a lock per kernel
    shared by the test processes: a worker that needs a kernel another is compiling loads the other's
    result when it is written, instead of compiling it too. Results are the same either way. The wait
    is numba's time as the kernel's own compile is (a ``numba:compiler_lock`` event, which
    :mod:`planning.clock` leaves out of a planner's time limit): a plan whose worker waited for
    another's cold compile timed out at its 10 s limit with 55 iterations of work to do."""
    from numba.core import event
    from numba.core.dispatcher import Dispatcher

    compile_ = Dispatcher.compile
    if getattr(compile_, "nhsim_once", False):
        return

    def compile_locked(self: Any, sig: Any) -> Any:
        func = self.py_func
        with event.trigger_event("numba:compiler_lock"), _kernel_lock(kernel_lock_name(func)):
            return compile_(self, sig)

    compile_locked.nhsim_once = True  # type: ignore[attr-defined]
    Dispatcher.compile = compile_locked  # type: ignore[method-assign]


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto``: a worker per core this process may use, and one more. On a cold kernel cache a worker that
    needs a kernel another is compiling waits for it (:func:`_compile_once`); the extra worker keeps the cores
    busy meanwhile (a fresh clone's default run on two cores, 2026-12-06: 4:41 with three workers, 4:58 with two)."""
    return len(os.sched_getaffinity(0)) + 1


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--all-cases", action="store_true", default=False, help="run every test, slow ones too")


def pytest_configure(config: pytest.Config) -> None:
    from sim.viz import gl

    _compile_once()
    gl.configure()  # MUJOCO_GL (the user's, or the default) before collection imports mujoco
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        # started in the background (``./run-tests &``): the shell ignores SIGINT for it, and the tests of
        # Ctrl-C need Python's own handler, as a command run in the foreground has it
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if config.getoption("--all-cases"):
        config.option.markexpr = ""


#: The longest modules of the default run (about 20-50 s each on two cores, numba's first compiles
#: included), started first: pytest-xdist hands out modules in collection order, and a long one handed
#: out last keeps one worker busy while the other idles.
LONGEST_FIRST = (
    "test_simplify.py", "test_peer_trackers.py", "test_models.py", "test_rrt.py", "test_tune.py",
    "test_collision_field.py", "test_cli_signals.py", "test_compare.py", "test_cli.py", "test_outputs_job.py",
    "test_regression.py", "test_montecarlo.py", "test_hybrid_astar.py",
)  # fmt: skip


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: the rest keep their order
