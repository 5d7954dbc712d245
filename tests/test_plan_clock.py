"""A planner's time limit counts planning, not numba readying its kernels (``planning.clock``): a fresh
install's first plan, and a new process's, is the plan every later run makes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
import pytest

from planning.clock import PlanClock, code_seconds, monotonic
from planning.planners.sampling.tree import Budget

ROOT = Path(__file__).resolve().parents[1]


def _fresh_kernel() -> object:
    """A kernel never compiled in this process (no disk cache): its first call compiles it."""

    @numba.njit(cache=False)
    def kernel(x: np.ndarray) -> float:
        total = 0.0
        for i in range(x.shape[0]):
            total += np.sin(x[i]) * np.cos(x[i])
        return total

    return kernel


def test_compiling_is_timed_and_left_out_of_the_time_limit() -> None:
    budget = Budget(100, time_limit=10.0)
    clock = budget.clock
    before = code_seconds()
    _fresh_kernel()(np.arange(3.0))  # type: ignore[operator]
    spent = code_seconds() - before
    assert spent > 0.005  # numba compiles for tens of milliseconds or more
    assert clock.code() == pytest.approx(spent, abs=1e-9)
    assert clock.working() == pytest.approx(clock.elapsed() - spent, abs=1e-3)
    # a limit the run has passed with its compiling counted, and not without it
    clock.limit = clock.working() + 0.5 * spent
    assert clock.elapsed() > clock.limit and not budget.spent(0) and clock.remaining() > 0
    while clock.working() <= clock.limit:  # then reached by time that is not compiling
        pass
    assert budget.spent(budget.next_check) and clock.remaining() == 0.0
    assert budget.why(16) == "time budget of 10 s spent after 16 iterations"


def test_waiting_for_another_test_process_compiling_a_kernel_is_code_time() -> None:
    """The processes sharing a kernel cache compile each kernel under a lock they share
    (``planning.kernel_cache.compile_once``): a process that waits while another compiles counts the wait as code
    time, not against its plan's limit."""
    from planning.kernel_cache import kernel_lock_name, lock_folder

    kernel = _fresh_kernel()
    LOCKS = lock_folder()
    LOCKS.mkdir(exist_ok=True)
    holder = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, sys, time; f = open(sys.argv[1], 'w'); fcntl.flock(f, fcntl.LOCK_EX); "
         "print('held', flush=True); time.sleep(1.0)", str(LOCKS / f"{kernel_lock_name(kernel.py_func)}.lock")],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        clock = PlanClock(10.0)
        kernel(np.arange(3.0))  # type: ignore[operator]
        assert clock.elapsed() > 0.5  # it waited for the other process
        assert clock.working() < 0.25  # and the wait is not held against the limit (it was all of it)
    finally:
        holder.wait(timeout=30)


def test_nested_compiles_count_once_and_each_thread_keeps_its_own() -> None:
    import threading

    @numba.njit(cache=False)
    def inner(x: float) -> float:
        return x * 2.0

    @numba.njit(cache=False)
    def outer(x: float) -> float:
        return inner(x) + 1.0  # compiling outer compiles inner inside it

    clock = PlanClock(1.0)
    wall = clock.elapsed()
    outer(1.0)
    assert 0 < clock.code() <= clock.elapsed() - wall + 1e-3
    other: list[float] = []
    thread = threading.Thread(target=lambda: (_fresh_kernel()(np.ones(2)), other.append(code_seconds())))  # type: ignore[operator]
    mine = code_seconds()
    thread.start()
    thread.join()
    assert other and other[0] > 0 and code_seconds() == mine  # that thread's compiling is not this one's


_CACHED_KERNEL = """
import numba, numpy as np

@numba.njit(cache=True)
def kernel(x):
    total = 0.0
    for i in range(x.shape[0]):
        total += np.sin(x[i]) * np.cos(x[i])
    return total
"""

_LOAD_IT = """
import json, time
import numba.core.event as ev
from planning.clock import PlanClock
import numpy as np
compiles = ev.RecordingListener()
ev.register("numba:compile", compiles)
import cachedkernel
clock = PlanClock(1.0)
cachedkernel.kernel(np.arange(3.0))
hits = sum(cachedkernel.kernel.stats.cache_hits.values())
again = PlanClock(1.0)
print(json.dumps({"code": clock.code(), "compiles": len(compiles.buffer), "hits": hits, "setup": clock.setup_s,
                  "setup_again": again.setup_s}))
"""


def test_loading_a_cached_kernel_is_code_time_too(tmp_path: Path) -> None:
    """A new process loads a kernel from the disk cache: no compiling, and yet time the clock leaves out of
    the limit (a 2000-obstacle plan overshot its limit by it). numba's one-time set-up is done before the
    process's first clock starts, and in none of the clock's time."""
    (tmp_path / "cachedkernel.py").write_text(_CACHED_KERNEL)
    path = os.pathsep.join([str(tmp_path), str(ROOT)])
    env = {**os.environ, "PYTHONPATH": path, "NUMBA_CACHE_DIR": str(tmp_path / "c")}
    runs = [subprocess.run([sys.executable, "-c", _LOAD_IT], env=env, capture_output=True, text=True) for _ in range(2)]
    first, second = (json.loads(r.stdout) if r.returncode == 0 else pytest.fail(r.stderr) for r in runs)
    assert first["compiles"] >= 1 and first["hits"] == 0  # compiled, and cached
    assert second["compiles"] == 0 and second["hits"] == 1  # loaded from the cache
    assert second["setup"] > 0.05 and second["setup_again"] == 0.0  # numba's set-up, once: about 0.3 s
    assert 0.0 < second["code"] < second["setup"]  # the load alone is timed


@pytest.mark.slow  # compiles every kernel of the planner (about 40 s of CPU)
def test_a_fresh_installs_first_plan_is_the_plan_of_every_later_run(tmp_path: Path) -> None:
    """BiRRT on 'nav_map1' with an empty numba cache: it compiles for longer than its 30 s time limit and
    still makes the plan a warm run makes (it ran 16 iterations and timed out before)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    cmd = [sys.executable, "-m", "sim", "plan", "--scenario", "nav_map1", "--planner", "birrt", "--seed", "0"]
    records = []
    for k in range(2):
        out = tmp_path / f"plan{k}.json"
        done = subprocess.run([*cmd, "--json", str(out)], env=env, cwd=tmp_path, capture_output=True, text=True)
        assert done.returncode == 0, done.stdout + done.stderr
        records.append(json.loads(out.read_text()))
    cold, warm = records
    assert cold["stats"]["code_s"] > 1.0 and warm["stats"]["code_s"] < 0.5 * cold["stats"]["code_s"]
    assert cold["status"] == warm["status"] == "success"
    assert cold["iterations"] == warm["iterations"] and cold["path"] == warm["path"]


def test_the_compiled_clock_is_perf_counters_clock() -> None:
    monotonic()  # ready the kernel first
    for _ in range(5):
        before = time.perf_counter()
        now = monotonic()
        after = time.perf_counter()
        assert before <= now <= after
    start = monotonic()
    time.sleep(0.05)
    assert 0.05 <= monotonic() - start < 1.0


_COMPILES = """
import sys
from numba.core import event

compiled = []


class Compiles(event.Listener):
    def on_start(self, ev):
        compiled.append(str(ev.data.get("dispatcher")))

    def on_end(self, ev):
        pass


event.register("numba:compile", Compiles())
from sim.cli.main import main

main(sys.argv[1:])
print("COMPILED", len(compiled), compiled)
"""


@pytest.mark.slow  # two processes, the first compiling Hybrid-A*'s kernels on a fresh clone
def test_a_new_process_compiles_nothing_the_disk_cache_holds() -> None:
    """A plan's second process loads every kernel from numba's cache and compiles none: a kernel with an
    object-mode block (``numba.objmode``) is cached without it, and numba compiled that block afresh in
    every process (about 40 ms of each cold Hybrid-A* plan)."""
    argv = ["plan", "--scenario", "nav_map1", "--planner", "hybrid-a-star", "--quiet", "--time-limit", "30"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for _ in range(2):  # the first fills the cache where it is empty (a fresh clone)
        out = subprocess.run([sys.executable, "-c", _COMPILES, *argv], capture_output=True, text=True, env=env,
                             cwd=ROOT, check=True)  # fmt: skip
    assert out.stdout.splitlines()[-1] == "COMPILED 0 []"


def test_an_iteration_budget_spent_early_says_what_more_time_would_take() -> None:
    early = Budget(5, time_limit=10.0, planner="birrt")
    assert early.why(5).startswith("iteration budget of 5 spent in ")
    assert "of the 10 s time limit (a larger max_iterations in a [planners.birrt] table of the scenario" in early.why(5)
    assert early.why(3) == "time budget of 10 s spent after 3 iterations"
    late = Budget(5, time_limit=1e-3, planner="birrt")
    while late.clock.remaining() > 0:  # the time limit spent too: nothing more to advise
        pass
    assert late.why(5) == "iteration budget of 5 spent"


class _FakeTime:
    """``time.perf_counter`` for :mod:`planning.clock`, advanced by hand; counts its readings."""

    def __init__(self) -> None:
        self.now, self.reads = 1000.0, 0

    def perf_counter(self) -> float:
        self.reads += 1
        return self.now

    def thread_time(self) -> float:  # read once, when a clock starts (PlanClock.slowdown)
        return 0.0


@pytest.mark.parametrize(("step", "limit"), [(5e-3, 0.05), (2e-3, 0.25), (1e-6, 1.0), (2e-5, 0.1)])
def test_a_tree_planners_budget_stops_within_one_iteration_and_a_half_percent_of_its_limit(
    step: float, limit: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Slow iterations (thousands of obstacles) are checked one by one, fast ones in bulk: the loop stops
    at most :data:`CHECK_SHARE` of the limit and one iteration late, reading the clock about 1 / CHECK_SHARE
    times (or every 256 iterations). Every 16 iterations, 5 ms ones overran a 0.05 s limit by 60 %."""
    from planning import clock as clock_module
    from planning.planners.sampling.tree import CHECK_SHARE

    fake = _FakeTime()
    monkeypatch.setattr(clock_module, "time", fake)
    budget = Budget(10**9, time_limit=limit)
    it = 0
    while not budget.spent(it):
        it += 1
        fake.now += step  # one iteration's work
    overrun = it * step - limit
    assert 0.0 < overrun <= CHECK_SHARE * limit + step + 1e-12
    assert fake.reads <= 2 * (1 / CHECK_SHARE + it / 256 + 16)  # two readings a check, at most every 256


def test_the_slowdown_is_wall_seconds_per_cpu_second_or_the_load_per_cpu_before_it_can_tell(monkeypatch) -> None:
    """A step that cannot be stopped midway (optim's set-up of a new NLP shape) is predicted in CPU seconds
    and scaled by how much other processes slow the plan now: measured on the plan's own thread once it has
    run long enough to tell, before that the load average per usable CPU."""
    import planning.clock as clock_module

    monkeypatch.setattr(clock_module.os, "getloadavg", lambda: (6.0, 1.0, 1.0))
    monkeypatch.setattr(clock_module.os, "sched_getaffinity", lambda pid: {0, 1})
    clock = PlanClock(10.0)
    assert clock.slowdown() == pytest.approx(3.0)  # 6 runnable on 2 CPUs, nothing run yet
    monkeypatch.setattr(clock_module.os, "getloadavg", lambda: (0.2, 1.0, 1.0))
    assert clock.slowdown() == 1.0  # never below 1
    cpu0 = time.thread_time()
    while time.thread_time() - cpu0 < 0.06:  # 60 ms of this thread's CPU
        pass
    time.sleep(0.12)  # wall time without CPU, as a thread waiting for a busy core
    ratio = clock.elapsed() / (time.thread_time() - clock._cpu0)
    assert 2.0 < ratio and clock.slowdown() == pytest.approx(min(4.0, ratio), rel=0.05)
    time.sleep(0.3)
    assert clock.slowdown() == 4.0  # at most
