"""Shared fixtures. MuJoCo's GL backend is chosen once, before any test module imports mujoco.

Tests marked ``slow`` are deselected by default (``-m "not slow"`` in pyproject); run them with
``-m slow``, or everything with ``--all-cases``.

On a fresh clone numba compiles every kernel on its first call (over a minute of CPU for the default
run) and caches it on disk. Two pytest-xdist workers (or the commands the tests start) that meet the same
kernel at once would each compile it; :func:`planning.kernel_cache.compile_once` makes the second wait for the
first and load its cache entry (installed here for the tests' own kernels too).
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto``: a worker per core this process may use, and one more. On a cold kernel cache a worker that
    needs a kernel another is compiling waits for it (:func:`planning.kernel_cache.compile_once`); the extra worker
    keeps the cores busy meanwhile (a fresh clone's default run on two cores, 2026-12-06: 4:41 with three workers,
    4:58 with two)."""
    return len(os.sched_getaffinity(0)) + 1


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--all-cases", action="store_true", default=False, help="run every test, slow ones too")


def pytest_configure(config: pytest.Config) -> None:
    from planning.kernel_cache import compile_once
    from sim.viz import gl

    compile_once()
    gl.configure()  # MUJOCO_GL (the user's, or the default) before collection imports mujoco
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        # started in the background (``./run-tests &``): the shell ignores SIGINT for it, and the tests of
        # Ctrl-C need Python's own handler, as a command run in the foreground has it
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if config.getoption("--all-cases"):
        config.option.markexpr = ""


#: The longest modules of the default run, longest first (12-32 s of test time each, measured with
#: ``--durations=0`` in a warm checkout, 2026-12-07), started first: pytest-xdist hands out modules in collection
#: order, and a long one handed out last keeps one worker busy while the others idle.
LONGEST_FIRST = (
    "test_montecarlo.py", "test_tune.py", "test_cli_signals.py", "test_peer_trackers.py", "test_optim.py",
    "test_rrt.py", "test_bag.py", "test_outputs_job.py", "test_hybrid_astar.py", "test_regression.py",
    "test_scan_localiser.py", "test_cli_plan.py", "test_render.py", "test_plugins.py", "test_random_worlds.py",
)  # fmt: skip


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: the rest keep their order


#: The signals whose handlers the commands set (:mod:`sim.cli.interrupt`) and a test may change.
STOPPING_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGALRM)


@pytest.fixture(autouse=True)
def _signal_handlers_kept() -> Iterator[None]:
    """Fail a test that leaves a stopping signal's handler changed (restoring it first): the processes a worker
    starts later inherit an ignored signal, and a hangup test on the same worker saw its command ignore SIGHUP
    as under ``nohup`` and run to its end."""
    before = {sig: signal.getsignal(sig) for sig in STOPPING_SIGNALS}
    yield
    changed = [sig.name for sig in STOPPING_SIGNALS if signal.getsignal(sig) != before[sig]]
    for sig, handler in before.items():
        signal.signal(sig, handler)
    assert not changed, f"the test left the handlers of {', '.join(changed)} changed"


@pytest.fixture
def pipe() -> Iterator[Callable[[bytes], Path]]:
    """A factory of ``/dev/fd/N`` paths of pipes holding given bytes, their write ends closed: a second read of
    one finds it empty, as bash's ``<(...)`` after its first read."""
    opened: list[int] = []

    def make(data: bytes) -> Path:
        r, w = os.pipe()
        os.write(w, data)
        os.close(w)
        opened.append(r)
        return Path(f"/dev/fd/{r}")

    yield make
    for fd in opened:
        os.close(fd)


@pytest.fixture
def fifo(tmp_path: Path) -> Iterator[Callable[..., Path]]:
    """A factory of FIFOs (``mkfifo``; ``make(data, name=None)``, in ``tmp_path``) a writer thread fills once; a
    later reader finds it empty (the writer gone, as a used ``<(...)`` is) rather than waiting."""
    stop = threading.Event()
    threads: list[threading.Thread] = []

    def serve(path: Path, data: bytes) -> None:
        with open(path, "wb") as f:  # waits for the first reader
            f.write(data)
        while not stop.is_set():  # later readers: an empty pipe
            try:
                os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))
            except OSError:  # no reader now
                stop.wait(0.005)

    def make(data: bytes, name: str | None = None) -> Path:
        path = tmp_path / (name or f"fifo{len(threads)}")
        os.mkfifo(path)
        threads.append(threading.Thread(target=serve, args=(path, data), daemon=True))
        threads[-1].start()
        return path

    yield make
    stop.set()
    for t in threads:
        t.join(5)
