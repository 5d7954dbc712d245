"""The exit-status contract under SIGTERM and SIGINT: every long command, stopped mid-work, exits 130
with "interrupted" on stderr, no traceback, no partial file, and keeps what it had finished.

Each test starts ``python -m sim`` in a subprocess, waits for a sign that the command is at work (a
line it prints, a file it keeps, or ``-X importtime``'s line for a module only the command's run
imports), sends the signal and reads the exit status.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from sim.cli.tune import STOP_WAIT_S

ROOT = Path(__file__).resolve().parents[1]
SIGNALS = [signal.SIGTERM, pytest.param(signal.SIGINT, marks=pytest.mark.slow)]


@dataclass
class Stopped:
    """What a stopped command left: exit status, stdout, stderr."""

    returncode: int
    out: str
    err: str


def _read(stream: object, into: list[str]) -> None:
    for line in stream:  # type: ignore[attr-defined]
        into.append(line)


def stop_when(
    args: list[str],
    cwd: Path,
    ready: Callable[[str, str], bool],
    sig: signal.Signals,
    timeout: float = 300,
    *,
    group: bool = False,
) -> Stopped:
    """Run ``nhsim ARGS`` in ``cwd``, send ``sig`` once ``ready(stdout, stderr)`` holds, and wait. With
    ``group``, the command runs in a process group of its own and every process of it gets the signal, as
    a terminal's Ctrl-C reaches every process of the command in the foreground."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1", "MUJOCO_GL": "egl"}
    proc = subprocess.Popen(
        [sys.executable, "-X", "importtime", "-m", "sim", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=group,
    )
    out: list[str] = []
    err: list[str] = []
    readers = [
        threading.Thread(target=_read, args=(s, b), daemon=True) for s, b in ((proc.stdout, out), (proc.stderr, err))
    ]
    for r in readers:
        r.start()

    def send(what: signal.Signals) -> None:
        if group:
            os.killpg(proc.pid, what)
        else:
            proc.send_signal(what)

    try:
        deadline = time.monotonic() + timeout
        while True:
            while not ready("".join(out), "".join(err)):
                assert proc.poll() is None, (
                    f"the command ended before it could be stopped:\n{''.join(out)}{''.join(err)}"
                )
                assert time.monotonic() < deadline, "the command never got to work"
                time.sleep(0.05)
            # frozen while the state is looked at again, so the signal lands in the state seen (a loaded machine
            # could let the command run on, even to its end, between a look and the signal)
            send(signal.SIGSTOP)
            assert proc.poll() is None, f"the command ended before it could be stopped:\n{''.join(out)}{''.join(err)}"
            if ready("".join(out), "".join(err)):
                break
            send(signal.SIGCONT)
        send(sig)
        send(signal.SIGCONT)
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if group:  # what the command left of its group (nothing, when it closed its workers)
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
    for r in readers:
        r.join(timeout=10)
    errors = "".join(line for line in err if not line.startswith("import time:"))
    return Stopped(proc.returncode, "".join(out), errors)


def imported(module: str) -> Callable[[str, str], bool]:
    """Ready once ``module`` has been imported (``-X importtime`` prints its line then)."""
    return lambda out, err: any(
        line.startswith("import time:") and line.rsplit("|", 1)[-1].strip() == module for line in err.splitlines()
    )


def imported_then(module: str, seconds: float) -> Callable[[str, str], bool]:
    """Ready ``seconds`` after ``module`` was imported (well inside the work that follows it)."""
    seen: list[float] = []

    def ready(out: str, err: str) -> bool:
        if not seen and imported(module)(out, err):
            seen.append(time.monotonic())
        return bool(seen) and time.monotonic() - seen[0] >= seconds

    return ready


def assert_interrupted(stopped: Stopped, command: str, cwd: Path) -> None:
    assert stopped.returncode == 130, stopped.err
    assert f"nhsim {command}: interrupted" in stopped.err
    assert "Traceback" not in stopped.err
    assert not [p for p in cwd.rglob("*") if ".part" in p.name or p.name.startswith(".")], "a partial file was left"


@pytest.mark.parametrize("sig", SIGNALS)
def test_montecarlo_keeps_its_finished_runs(tmp_path: Path, sig: signal.Signals) -> None:
    results = tmp_path / "renders"

    def two_runs_kept(out: str, err: str) -> bool:
        files = list(results.glob("*.jsonl")) if results.is_dir() else []
        return bool(files) and len(files[0].read_text().splitlines()) >= 3

    args = ["montecarlo", "--reference", "circle", "--runs", "400", "--jobs", "1", "--quiet", "--no-plots"]
    stopped = stop_when(args, tmp_path, two_runs_kept, sig)
    assert_interrupted(stopped, "montecarlo", tmp_path)
    (kept,) = results.glob("*.jsonl")
    lines = kept.read_text().splitlines()
    assert len(lines) >= 3 and all(json.loads(line) for line in lines)  # every line whole
    assert not list(results.glob("*.json"))  # no summary of an unfinished study


def _processes_in(cwd: Path, marker: str) -> list[int]:
    """The processes working in ``cwd`` whose command line holds ``marker``."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and Path(os.readlink(entry / "cwd")) == cwd:
                if marker in (entry / "cmdline").read_bytes().decode(errors="replace"):
                    found.append(int(entry.name))
        except OSError:  # ended meanwhile, or not ours to read
            continue
    return found


@pytest.mark.slow  # a Dask local cluster started and interrupted: 7.5 s, kept out of the default run
def test_montecarlo_on_local_workers_says_only_that_it_was_interrupted(tmp_path: Path) -> None:
    """Ctrl-C reaches every process of the command. Its Dask workers, taking it too, printed their
    KeyboardInterrupt tracebacks, and Dask logged what the close broke (CommClosedError under a heartbeat
    or a broadcast, a CancelledError in a nanny, Tornado's "Exception in callback" of an interrupted
    wait), beside "interrupted": stopped as its workers start and again once they are at work, the
    command says only that it was interrupted, exits 130 and leaves no worker behind."""
    workers = tmp_path / "starting"
    workers.mkdir()
    args = ["montecarlo", "--scenario", "open", "--reference", "line", "--jobs", "2", "--runs", "8", "--quiet"]
    args += ["--no-plots", "--results", "r.jsonl", "--json", "s.json"]
    starting = stop_when(args, workers, lambda out, err: bool(_processes_in(workers, "spawn_main")), signal.SIGINT,
                         group=True)  # fmt: skip
    at_work = tmp_path / "at_work"
    at_work.mkdir()
    results = at_work / "r.jsonl"
    a_run_kept = lambda out, err: results.exists() and results.read_text().count("\n") >= 2  # header, a run
    at_work_stopped = stop_when(args, at_work, a_run_kept, signal.SIGINT, group=True)
    for stopped, cwd in ((starting, workers), (at_work_stopped, at_work)):
        assert stopped.returncode == 130, stopped.err
        assert stopped.err == "nhsim montecarlo: interrupted\n"
        assert _processes_in(cwd, "spawn_main") == []
        assert not (cwd / "s.json").exists()


@pytest.mark.parametrize("sig", SIGNALS)
def test_simulate_all_stops_without_a_record(tmp_path: Path, sig: signal.Signals) -> None:
    args = ["simulate", "--all", "--jobs", "1", "--no-video", "--no-plots", "--json", "sweep.json"]
    stopped = stop_when(args, tmp_path, lambda out, err: "scenario" in out, sig)
    assert_interrupted(stopped, "simulate", tmp_path)
    assert not (tmp_path / "sweep.json").exists()


@pytest.mark.parametrize("sig", SIGNALS)
def test_compare_stops_without_a_record(tmp_path: Path, sig: signal.Signals) -> None:
    # mpc too: its solves hold the signal and deliver it as they return (CasADi would swallow it)
    args = ["compare", "--reference", "figure8", "--runs", "20", "--trackers", "mpc,fbl,segmented,rpp,kanayama"]
    args += ["--quiet", "--json", "cmp.json"]
    stopped = stop_when(args, tmp_path, imported_then("sim.tools.compare", 2.0), sig)  # its runs under way
    assert_interrupted(stopped, "compare", tmp_path)
    assert not (tmp_path / "cmp.json").exists()


@pytest.mark.parametrize("sig", SIGNALS)
def test_tune_keeps_its_completed_trials(tmp_path: Path, sig: signal.Signals) -> None:
    db = tmp_path / "study.db"

    def a_trial_done(out: str, err: str) -> bool:
        if not db.exists():
            return False
        try:
            with sqlite3.connect(db) as con:
                return con.execute("SELECT count(*) FROM trials WHERE state = 'COMPLETE'").fetchone()[0] >= 1
        except sqlite3.Error:
            return False

    args = ["tune", "--scenarios", "open:circle", "--draws", "1", "--trials", "200", "--eval-runs", "1"]
    args += ["--storage", f"sqlite:///{db}", "--study", "s", "--quiet"]
    stopped = stop_when(args, tmp_path, a_trial_done, sig)
    assert_interrupted(stopped, "tune", tmp_path)
    with sqlite3.connect(db) as con:
        kept = con.execute("SELECT count(*) FROM trials WHERE state = 'COMPLETE'").fetchone()[0]
    assert kept >= 1
    assert f"interrupted: the study keeps its {kept} completed trial" in stopped.err
    assert f"of 200 in sqlite:///{db}; the same command resumes it" in stopped.err
    assert not (tmp_path / "renders").exists() or not list((tmp_path / "renders").iterdir())


#: Each signal to the command alone; Ctrl-C to every process of the command (a terminal's), as ``group``.
TUNE_WORKER_STOPS = [  # all slow (worker processes; tune alone stops by test_tune_keeps_its_completed_trials)
    pytest.param(signal.SIGTERM, False, marks=pytest.mark.slow),
    pytest.param(signal.SIGINT, False, marks=pytest.mark.slow),
    pytest.param(signal.SIGINT, True, marks=pytest.mark.slow),
]


@pytest.mark.parametrize(("sig", "group"), TUNE_WORKER_STOPS)
def test_tune_on_workers_stops_them_as_it_stops_alone(tmp_path: Path, sig: signal.Signals, group: bool) -> None:
    """``tune --jobs 2``: SIGINT or SIGTERM to the command left its workers running every remaining trial (then
    exit 130, nothing written), and a terminal's Ctrl-C (to every process of the command) printed the workers'
    KeyboardInterrupt tracebacks. The workers stop within about a second, their trials recorded as interrupted
    (as --jobs 1 records its own: a rerun runs their gains again), the command says only "interrupted"."""
    db = tmp_path / "study.db"

    def complete(state: str) -> int:
        try:
            with contextlib.closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=1.0)) as con:
                return int(con.execute("SELECT count(*) FROM trials WHERE state = ?", (state,)).fetchone()[0])
        except sqlite3.Error:
            return 0

    signalled: list[float] = []

    def at_work(out: str, err: str) -> bool:
        ready = db.exists() and complete("COMPLETE") >= 2 and len(_processes_in(tmp_path, "spawn_main")) == 2
        signalled.extend([time.monotonic()] if ready else [])
        return ready

    args = ["tune", "--scenarios", "open:circle", "--draws", "1", "--trials", "30", "--eval-runs", "1", "--jobs", "2"]
    args += ["--storage", f"sqlite:///{db}", "--study", "s", "--quiet", "--out", "g.toml", "--plots", "."]
    stopped = stop_when(args, tmp_path, at_work, sig, group=group)
    took = time.monotonic() - signalled[0]
    assert_interrupted(stopped, "tune", tmp_path)
    kept = complete("COMPLETE")
    assert stopped.err == (  # said what is kept and how to go on ("interrupted" alone left the user to guess)
        f"nhsim tune: interrupted: the study keeps its {kept} completed trials of 30 in sqlite:///{db}; the same "
        "command resumes it\n"
    )
    # stopped, not run to their end: a worker still running STOP_WAIT_S after the command's SIGTERM is killed
    # (their own stop takes about a second; the 28 trials left would take a minute)
    assert took < STOP_WAIT_S + 5.0, f"the command took {took:.1f} s to stop"
    assert _processes_in(tmp_path, "spawn_main") == []
    assert complete("RUNNING") == 0 and complete("COMPLETE") < 30
    with contextlib.closing(sqlite3.connect(db)) as con:
        interrupted = con.execute("SELECT count(*) FROM trial_user_attributes WHERE key = 'interrupted'").fetchone()[0]
    assert interrupted >= 1  # the trials the workers were evaluating
    assert not (tmp_path / "g.toml").exists() and not (tmp_path / "g.json").exists()


@pytest.mark.parametrize("sig", SIGNALS)
def test_regress_update_leaves_the_baselines(tmp_path: Path, sig: signal.Signals) -> None:
    import shutil

    baselines = tmp_path / "baselines"
    shutil.copytree(ROOT / "tests" / "baselines", baselines)
    before = {p.name: p.read_bytes() for p in baselines.iterdir()}
    suite = str(ROOT / "tests" / "regression_suite.toml")
    args = ["regress", "--all", "--jobs", "1", "--update", "--baselines", str(baselines), "--suite", suite]
    stopped = stop_when(args, tmp_path, imported_then("mujoco", 1.5), sig)
    assert_interrupted(stopped, "regress", tmp_path)
    assert {p.name: p.read_bytes() for p in baselines.iterdir()} == before


@pytest.mark.parametrize("sig", SIGNALS)
def test_plan_stops_without_a_record(tmp_path: Path, sig: signal.Signals) -> None:
    walled = tmp_path / "walled.toml"  # the goal walled in: the search runs to its time limit
    walls = "".join(
        f'[[world.obstacles]]\ntype = "box"\ncenter = [{x}, {y}]\nsize = [{w}, {h}]\n'
        for x, y, w, h in ((4.5, 3.5, 2.2, 0.2), (4.5, 5.5, 2.2, 0.2), (3.5, 4.5, 0.2, 2.2), (5.5, 4.5, 0.2, 2.2))
    )
    walled.write_text(
        'robot = "turtlebot3"\n[world]\nbounds = [0.0, 6.0, 0.0, 6.0]\n'
        + walls
        + "[start]\npose = [1.0, 1.0, 0.0]\n[goal]\npose = [4.5, 4.5, 0.0]\n"
    )
    args = ["plan", "--scenario", str(walled), "--planner", "rrt-star", "--time-limit", "120", "--json", "plan.json"]
    stopped = stop_when(args, tmp_path, lambda out, err: "scenario walled" in out, sig)
    assert_interrupted(stopped, "plan", tmp_path)
    assert not (tmp_path / "plan.json").exists()


@pytest.mark.parametrize("sig", SIGNALS)
def test_plan_stops_inside_an_ipopt_solve(tmp_path: Path, sig: signal.Signals) -> None:
    """The optim planner's solve runs for seconds inside CasADi, which ends it at a signal and swallows
    the interrupt: the command printed "status failed" and exited 1. Sent once IPOPT prints its
    iterations, the signal now stops the command with 130 and no record."""
    scenario = tmp_path / "lot.toml"
    scenario.write_text(
        (ROOT / "models" / "scenarios" / "parking_lot.toml").read_text() + "\n[planners.optim]\nverbose = true\n"
    )
    args = ["plan", "--scenario", str(scenario), "--planner", "optim", "--json", "plan.json"]
    stopped = stop_when(args, tmp_path, lambda out, err: "iter    objective" in out, sig)
    assert_interrupted(stopped, "plan", tmp_path)
    assert not (tmp_path / "plan.json").exists()


@pytest.mark.parametrize("sig", SIGNALS)
def test_bench_stops(tmp_path: Path, sig: signal.Signals) -> None:
    stopped = stop_when(["bench", "sim", "--repeats", "50"], tmp_path, imported_then("mujoco", 1.5), sig)
    assert_interrupted(stopped, "bench sim", tmp_path)  # the benchmark named, as its errors name it


@pytest.mark.parametrize("mode", ["bare", "held", "end_early"])
def test_a_signal_inside_a_casadi_solve_is_delivered_after_it(mode: str) -> None:
    """CasADi runs the Python signal handlers inside a solve and swallows the KeyboardInterrupt they raise
    (the solve ends failed, the interrupt is lost); held (as the mpc tracker holds its solves), the
    signal stops the program as the solve returns; under ``signals_end_early`` (the optim planner's
    long solves) the solve ends at the signal and the signal stops the program as it returns. Here the
    signal is sent from inside the solve."""
    import contextlib

    import casadi as ca

    from planning.signals import signals_end_early, signals_held

    class Kick(ca.Callback):  # type: ignore[misc]
        """f(x) = x^2, sending SIGINT to this process at its third evaluation."""

        def __init__(self) -> None:
            ca.Callback.__init__(self)
            self.calls = 0
            self.construct("kick", {"enable_fd": True})

        def get_n_in(self) -> int:
            return 1

        def get_n_out(self) -> int:
            return 1

        def eval(self, arg: list[object]) -> list[object]:
            self.calls += 1
            if self.calls == 3:
                os.kill(os.getpid(), signal.SIGINT)
            return [arg[0] ** 2]  # type: ignore[operator]

    kick = Kick()
    x = ca.MX.sym("x")
    ipopt = {"print_level": 0, "sb": "yes", "hessian_approximation": "limited-memory"}
    solver = ca.nlpsol(
        "s", "ipopt", {"x": x, "f": kick(x - 1.0)}, {"print_time": False, "error_on_fail": False, "ipopt": ipopt}
    )
    if mode == "held":
        with pytest.raises(KeyboardInterrupt), signals_held():
            solver(x0=5.0)
        assert solver.stats()["success"] and kick.calls > 3  # the solve ran to its end, then the signal acted
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    elif mode == "end_early":
        returned = False
        with pytest.raises(KeyboardInterrupt), signals_end_early():
            solver(x0=5.0)
            returned = True
        assert returned and not solver.stats()["success"] and kick.calls == 3  # ended at the signal, then raised
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    else:
        with contextlib.nullcontext():
            solver(x0=5.0)  # no KeyboardInterrupt: CasADi caught it
        assert not solver.stats()["success"] and kick.calls == 3


def test_an_interrupt_landing_in_a_callback_that_drops_it_is_raised_after_it() -> None:
    """A signal whose handler runs inside a Python function that C code calls back and whose exception
    it prints and drops (llvmlite's object-cache hook while numba compiles: a SIGTERM was lost there) is
    raised again a moment later, outside it."""
    import time
    from types import SimpleNamespace

    from sim.cli.interrupt import RETRY_S, _interrupt, sigterm_as_interrupt

    code = SimpleNamespace(co_filename="/venv/site-packages/llvmlite/binding/ee.py")
    callback = SimpleNamespace(f_code=code, f_back=None)
    with sigterm_as_interrupt():
        _interrupt(signal.SIGTERM, callback)  # type: ignore[arg-type]  # nothing raised inside the callback
        start = time.monotonic()
        with pytest.raises(KeyboardInterrupt, match="SIGTERM"):  # RETRY_S later; a loaded machine may take longer
            while time.monotonic() - start < 3000 * RETRY_S:
                time.sleep(RETRY_S / 10)
    with pytest.raises(KeyboardInterrupt, match="SIGINT"), sigterm_as_interrupt():
        _interrupt(signal.SIGINT, None)


def test_an_interrupt_during_a_numba_compile_is_raised_when_the_compile_is_done() -> None:
    """SIGTERM arriving while numba compiles a kernel (cold caches: the first seconds of most commands)
    waits for the compile: raised inside numba's compiler passes, it left LLVM's objects half built,
    and the command printed "interrupted" then died at exit (``free(): double free detected``)."""
    import threading
    import time

    import numba
    import numpy as np

    from sim.cli.interrupt import sigterm_as_interrupt

    @numba.njit(cache=False)
    def kernel(x: np.ndarray) -> float:  # never compiled before: the first call compiles it
        total = 0.0
        for i in range(x.shape[0]):
            total += np.sin(x[i]) * np.cos(x[i]) + np.sqrt(abs(x[i])) - np.tanh(x[i])
        return total

    compiling = threading.Event()

    def kick() -> None:
        compiling.wait(5.0)
        time.sleep(0.02)  # well inside the compile (a tenth of a second or more)
        os.kill(os.getpid(), signal.SIGTERM)

    thread = threading.Thread(target=kick)
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"), sigterm_as_interrupt():
        thread.start()
        compiling.set()
        kernel(np.ones(3))
        while True:
            time.sleep(0.001)
    thread.join()
    assert len(kernel.signatures) == 1  # the compile finished, then the interrupt came
    expected = 3 * (np.sin(1.0) * np.cos(1.0) + 1.0 - np.tanh(1.0))
    assert kernel(np.ones(3)) == pytest.approx(expected, rel=1e-12)  # and the kernel works


def test_a_second_interrupt_while_one_waits_is_raised_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C inside numba's compiler waits for the kernel (seconds on a fresh install); a second one
    stops the command at once."""
    from types import SimpleNamespace

    import sim.cli.interrupt as interrupt

    monkeypatch.setattr(interrupt, "RETRY_S", 60.0)  # the first would be tried again only in a minute
    compiler = SimpleNamespace(co_filename="/venv/site-packages/numba/core/compiler.py", co_name="compile_extra")
    plan = SimpleNamespace(co_filename="/src/planning/planners/rrt.py", co_name="plan")
    ours = SimpleNamespace(f_code=plan, f_back=None)
    inside = SimpleNamespace(f_code=compiler, f_back=ours)  # numba's frame called from ours
    with pytest.raises(KeyboardInterrupt, match="SIGINT"), interrupt.sigterm_as_interrupt():
        interrupt._interrupt(signal.SIGINT, inside)  # type: ignore[arg-type]  # waits
        assert interrupt._WAITING and signal.getitimer(signal.ITIMER_REAL)[0] > 0
        interrupt._interrupt(signal.SIGINT, inside)  # type: ignore[arg-type]  # the user insists
    assert not interrupt._WAITING and signal.getitimer(signal.ITIMER_REAL)[0] == 0


_EXEC_PROBE = """
import os, signal, sys, time
from sim.cli.interrupt import sigterm_as_interrupt

def body() -> int:
    with sigterm_as_interrupt():
        steps = {"n": 0, "kill": os.kill, "pid": os.getpid(), "SIGTERM": signal.SIGTERM}
        try:  # source text (run by PyRun_String) that sends SIGTERM at its thousandth step
            exec("for _ in range(3_000_000):\\n    n += 1\\n    if n == 1000:\\n        kill(pid, SIGTERM)", steps)
            time.sleep(30)
        except KeyboardInterrupt:
            print(f"interrupted after {steps['n']} steps", file=sys.stderr)
            return 130
    return 0

raise SystemExit(body())
"""


def test_an_interrupt_inside_exec_of_source_text_waits_for_it_and_the_exit_status_is_130(tmp_path: Path) -> None:
    """A KeyboardInterrupt that leaves exec of a string (dataclasses, namedtuple and numba run source
    text) marks CPython as stopped by an unhandled Ctrl-C: ``python -m`` then killed itself with SIGINT
    at exit (status -2) though the command printed "interrupted" and returned 130. The interrupt now
    waits for the exec to end."""
    (tmp_path / "probe").mkdir()
    (tmp_path / "probe" / "__main__.py").write_text(_EXEC_PROBE)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    done = subprocess.run([sys.executable, "-m", "probe"], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 130, (done.returncode, done.stderr)
    # raised once the exec was done; the wait said when it passed NOTICE_S (a loaded machine's exec is slower)
    *told, last = done.stderr.splitlines()
    assert last == "interrupted after 3000000 steps" and all(t.startswith("nhsim: stopping once") for t in told)


_UNDER_EXEC = """
import os, signal, sys, threading, time
from sim.cli.interrupt import sigterm_as_interrupt

with sigterm_as_interrupt():
    try:
        threading.Timer(0.05, lambda: os.kill(os.getpid(), signal.SIGTERM)).start()
        time.sleep(30)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
"""


def test_a_command_run_from_source_text_is_interrupted_at_once() -> None:
    """``python -c`` (and pytest-xdist's workers) run the whole program as source text: an interrupt the
    block catches never leaves that text, so it is not held back for it (it was held forever)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", _UNDER_EXEC], env=env, capture_output=True, text=True, timeout=20)
    assert (done.returncode, done.stderr) == (130, "interrupted\n")


def test_a_waiting_interrupt_tried_again_inside_a_held_block_waits_for_its_end(monkeypatch: pytest.MonkeyPatch) -> None:
    """An interrupt that waited for numba and is tried again while ``tune`` holds the signals (Optuna
    recording a trial) is noted there and raised as the hold ends: raised inside, it would leave the
    trial RUNNING and the command waiting out Optuna's heartbeat."""
    from types import SimpleNamespace

    import sim.cli.interrupt as interrupt
    from planning.signals import signals_held

    monkeypatch.setattr(interrupt, "RETRY_S", 60.0)  # tried again only when this test says
    compiler = SimpleNamespace(co_filename="/venv/site-packages/numba/core/compiler.py", co_name="compile_extra")
    inside = SimpleNamespace(f_code=compiler, f_back=None)
    reached = []
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"), interrupt.sigterm_as_interrupt():
        interrupt._interrupt(signal.SIGTERM, inside)  # type: ignore[arg-type]  # waits for numba
        try_again = signal.getsignal(signal.SIGALRM)
        with signals_held():
            try_again(signal.SIGALRM, None)  # type: ignore[operator]  # the timer fires in the held block
            reached.append("held block done")
        reached.append("not raised")
    assert reached == ["held block done"]


def test_a_signal_ending_a_block_early_is_raised_once_and_a_hold_around_it_keeps_it() -> None:
    """``signals_end_early``: a signal raises at once inside the block; one that leaves the block as an
    exception is not raised a second time; inside ``signals_held`` the signal stays held."""
    from planning.signals import signals_end_early, signals_held

    with pytest.raises(KeyboardInterrupt) as raised, signals_end_early():
        signal.raise_signal(signal.SIGINT)
    assert raised.value.__context__ is None  # not raised again as the block ended
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    reached = []
    with pytest.raises(KeyboardInterrupt), signals_held():
        with signals_end_early():
            signal.raise_signal(signal.SIGINT)
            reached.append("inside")  # noted by the hold, not raised
        reached.append("after")
    assert reached == ["inside", "after"]


@pytest.mark.parametrize("finalizer", ["__del__", "weakref.finalize"])
def test_an_interrupt_landing_in_a_finalizer_is_raised_after_it(finalizer: str) -> None:
    """Python prints and drops what a finalizer raises ("Exception ignored in ... __del__"): a SIGTERM
    arriving as an object was freed was lost (``tune`` ran on to its last trial). It is raised a moment
    later, outside the finalizer."""
    import time
    import weakref

    from sim.cli.interrupt import RETRY_S, sigterm_as_interrupt

    def kick() -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):  # the handler runs here, inside the finalizer
            pass

    class Freed:
        def __del__(self) -> None:
            kick()

    class Plain:
        pass

    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"), sigterm_as_interrupt():
        if finalizer == "__del__":
            Freed()  # freed at once
        else:
            obj = Plain()
            weakref.finalize(obj, kick)
            del obj
        while time.monotonic() - start < 100 * RETRY_S:
            time.sleep(RETRY_S / 10)
    assert time.monotonic() - start < 100 * RETRY_S


def _spin_kernels() -> tuple[object, object]:
    """Two kernels that take a stop flag last: one loops for its seconds unless told to stop, one fails."""
    import numba

    from planning.clock import monotonic

    @numba.njit(nogil=True)
    def spin(seconds: float, stop: object) -> int:
        start = monotonic()
        n = 0
        while not stop[0] and monotonic() - start < seconds:  # type: ignore[index]
            n += 1
        return n

    @numba.njit(nogil=True)
    def fails(x: float, stop: object) -> float:
        if x < 0:
            raise ValueError("x must be >= 0")
        return x

    return spin, fails


def _helpers() -> list[str]:
    """The helper threads of ``stoppable`` still running a second on (a returned kernel's thread ends at once)."""
    for _ in range(100):
        left = [t.name for t in threading.enumerate() if t.name.startswith("nhsim-")]
        if not left:
            break
        time.sleep(0.01)
    return left


def test_a_kernel_run_stoppable_takes_an_interrupt_at_once_and_returns_or_raises_as_called() -> None:
    """A compiled kernel holds its thread's signal handlers until it returns: run by ``stoppable`` the
    interrupt is raised at once, the kernel told to stop, and its helper thread ended."""
    import _thread

    import numpy as np

    from planning.signals import stoppable

    spin, fails = _spin_kernels()
    assert stoppable(spin, 0.01) > 0  # compiled (in this thread), run, and its result returned
    with pytest.raises(ValueError, match="x must be >= 0"):
        stoppable(fails, -1.0)
    timer = threading.Timer(0.2, _thread.interrupt_main)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        start = time.monotonic()
        stoppable(spin, 60.0)
    assert time.monotonic() - start < 5.0  # not the kernel's 60 s
    assert _helpers() == []
    assert spin(0.0, np.zeros(1, dtype=np.bool_)) >= 0


def test_kernels_a_watch_spawns_run_beside_the_first_and_stop_with_it() -> None:
    """``stoppable``'s watch is called while the kernels run and may start more; the call returns the
    first kernel's result once all have ended, raises what any raised, and an interrupt stops them all."""
    import _thread

    import numpy as np

    from planning.signals import stoppable

    spin, fails = _spin_kernels()
    spin(0.0, np.zeros(1, dtype=np.bool_))
    runs: list[object] = []

    def spawn_one(kernel: object, args: tuple[float, ...]) -> object:
        def watch(first: object, spawn: object) -> None:
            if not runs:
                runs.append(spawn(kernel, *args))  # type: ignore[operator]

        return watch

    assert stoppable(spin, 0.05, watch=spawn_one(spin, (0.2,))) > 0
    assert runs[0].done.is_set() and runs[0].out > 0  # type: ignore[attr-defined]  # waited for, though longer
    runs.clear()
    with pytest.raises(ValueError, match="x must be >= 0"):
        stoppable(spin, 0.01, watch=spawn_one(fails, (-1.0,)))
    runs.clear()
    # the first kernel fails while one it spawned runs on: the watch, which reads the first's result as
    # Hybrid-A*'s does, is not called on a result never given (it raised TypeError in place of a MemoryError)
    # and the other is stopped
    seen: list[object] = []

    def reads_the_result(first: object, spawn: object) -> None:
        if first.done.is_set():  # type: ignore[attr-defined]
            seen.append(first.out[0])  # type: ignore[attr-defined]
        elif not runs:
            runs.append(spawn(spin, 60.0))  # type: ignore[operator]

    start = time.monotonic()
    with pytest.raises(ValueError, match="x must be >= 0"):
        stoppable(fails, -1.0, watch=reads_the_result)
    assert time.monotonic() - start < 5.0 and seen == []
    assert not runs or runs[0].done.is_set()  # type: ignore[attr-defined]
    runs.clear()
    threading.Timer(0.2, _thread.interrupt_main).start()
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        stoppable(spin, 60.0, watch=spawn_one(spin, (60.0,)))
    assert time.monotonic() - start < 5.0 and runs[0].done.is_set()  # type: ignore[attr-defined]
    assert _helpers() == []


def test_hybrid_a_stars_search_takes_an_interrupt_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Hybrid-A*'s search is one compiled call up to the plan's time limit: interrupted 0.3 s into a
    search that expands every reachable state of a 10 x 10 m world (about 4 s: the goal's room has a
    door the inscribed disc passes and the footprint does not), the plan raises within the second."""
    import _thread

    from planning.core.geometry import Pose2D
    from planning.core.robot import load_robot
    from planning.core.world import Box, World
    from planning.planners import hybrid_astar
    from planning.planners.base import PlanProblem
    from planning.planners.registry import make_planner
    from planning.scenario import load_scenario

    planner = make_planner("hybrid-a-star")  # its search from the goal runs out of the room's states at once
    planner.plan(PlanProblem.from_scenario(load_scenario("nav_map1")))  # the search kernel ready here
    room = (((8.5, 8.95), (0.9, 0.1)), ((8.5, 8.05), (0.9, 0.1)), ((8.95, 8.5), (0.1, 0.9)),
            ((8.05, 8.75), (0.1, 0.4)), ((8.05, 8.25), (0.1, 0.4)))  # fmt: skip
    world = World((0.0, 10.0, 0.0, 10.0), tuple(Box(c, s, 0.0) for c, s in room))
    problem = PlanProblem(world, load_robot("turtlebot3"), Pose2D(1.0, 1.0, 0.0), Pose2D(8.5, 8.5, 0.0), time_limit=60)
    real = hybrid_astar.stoppable
    sent: list[float] = []

    def interrupted_later(*args: object, **kwargs: object) -> object:
        def send() -> None:
            sent.append(time.monotonic())
            _thread.interrupt_main()

        threading.Timer(0.3, send).start()
        return real(*args, **kwargs)

    monkeypatch.setattr(hybrid_astar, "stoppable", interrupted_later)
    with pytest.raises(KeyboardInterrupt):
        planner.plan(problem)
    assert sent and time.monotonic() - sent[0] < 1.0  # the search alone would run on for seconds
    assert _helpers() == []


_GL_CONVERSION = """
import signal


class Buffer:
    @classmethod
    def from_param(cls, value):  # Python code ctypes runs while it converts a call's argument
        signal.raise_signal(signal.SIGTERM)
        return 0
"""


def test_an_interrupt_in_a_ctypes_argument_conversion_of_opengl_is_raised_after_the_call() -> None:
    """ctypes turns an exception raised while it converts a call's arguments into ``ctypes.ArgumentError``:
    a SIGTERM landing in PyOpenGL's conversion of MuJoCo's OSMesa buffer ended a render with exit status
    1 and "ArgumentError: argument 2: KeyboardInterrupt". In OpenGL's code it waits for the call."""
    import ctypes
    import os

    from sim.cli.interrupt import sigterm_as_interrupt

    space: dict[str, object] = {}
    exec(compile(_GL_CONVERSION, f"{os.sep}site-packages{os.sep}OpenGL{os.sep}arrays.py", "exec"), space)
    labs = ctypes.CDLL(None).labs
    labs.argtypes, labs.restype = [space["Buffer"]], ctypes.c_long
    returned: list[int] = []
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"), sigterm_as_interrupt():
        returned.append(labs(None))
        while True:
            time.sleep(0.001)
    assert returned == [0]  # the call completed, then the interrupt came


def test_an_interrupt_python_drops_in_a_weakref_callback_is_raised_again() -> None:
    """Python prints and drops what a weakref callback raises; any callback may run anywhere (a SIGTERM
    landing in importlib's module-lock callback was lost, and ``nhsim simulate`` ran on to its end). The
    dropped interrupt is raised again a moment later."""
    import weakref

    from sim.cli.interrupt import sigterm_as_interrupt

    class Thing:
        pass

    fired: list[float] = []

    def callback(_ref: object) -> None:  # neither a __del__ nor weakref.finalize's: no frame marks it
        fired.append(time.monotonic())
        signal.raise_signal(signal.SIGTERM)

    thing = Thing()
    ref = weakref.ref(thing, callback)
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"), sigterm_as_interrupt():
        del thing  # the last reference: the callback runs here, takes the signal and raises; Python drops that
        while time.monotonic() - start < 5.0:
            time.sleep(0.001)
    # raised again within the second of the drop, not lost (timed from the callback; a gc.collect() here made the
    # retry wait for a loaded worker's collection of everything: 1.01 s once, in a fresh clone's default run)
    assert ref() is None and len(fired) == 1 and time.monotonic() - fired[0] < 1.0


def test_an_interrupt_during_an_import_waits_for_the_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An interrupt raised while a module is imported left it half initialised, and a C extension's
    initialisation turned it into an ImportError (``import mujoco`` in ``nhsim simulate``: "ImportError:
    initialization failed", exit status 1). It now waits for the import, then is raised."""
    import importlib
    import sys

    from sim.cli.interrupt import sigterm_as_interrupt

    (tmp_path / "slowmodule.py").write_text(
        "import signal\nsignal.raise_signal(signal.SIGTERM)\nimport time\ntime.sleep(0.05)\nDONE = True\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "slowmodule", raising=False)
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"), sigterm_as_interrupt():
        importlib.import_module("slowmodule")
        while True:
            time.sleep(0.001)
    assert sys.modules["slowmodule"].DONE  # the module was imported whole, then the interrupt came


def test_a_closed_output_pipe_ends_the_command_quietly_with_141():
    # `nhsim plan ... | head -1`: the reader goes away before the command has printed all its lines
    cmd = [sys.executable, "-m", "sim", "plan", "--scenario", "farm", "--planner", "hybrid-a-star"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()  # the header line: the command is at work
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert first.startswith(b"scenario farm") and "Traceback" not in err and "BrokenPipe" not in err


def test_a_reader_of_both_outputs_that_goes_away_ends_the_command_with_141(tmp_path):
    """``nhsim simulate 2>&1 | head -1``: the note simulate prints on stderr after its table (the open loop touched
    an obstacle) met the closed pipe, its BrokenPipeError's traceback went into the same pipe, and the command
    ended with status 1 without a word. Its record is written and it exits 141, as with stdout alone."""
    cmd = [sys.executable, "-m", "sim", "simulate", "--no-video", "--no-plots", "--json", str(tmp_path / "r.json")]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    assert proc.stdout is not None
    first = proc.stdout.readline()
    proc.stdout.close()
    assert proc.wait(timeout=120) == 141 and first.startswith(b"scenario edumip_map")
    assert json.loads((tmp_path / "r.json").read_text())["open_loop"]["collisions"] > 0  # the note was due


@pytest.mark.slow  # whole commands in subprocesses; 4 s
def test_a_reader_that_goes_away_leaves_the_commands_outputs_written(tmp_path):
    """`nhsim simulate ... | head -1`: the command stopped at its next print, and the record and plots it had
    not written yet were lost (or kept, by the timing of the reader). It now prints nothing more, writes them,
    and exits 141."""
    cmd = [sys.executable, "-m", "sim", "simulate", "--scenario", "open", "--reference", "line", "--robot", "edumip"]
    cmd += ["--runs", "closed_loop", "--json", str(tmp_path / "r.json")]  # and its video and plots in renders/
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()  # the first line: the command is at work, its table still to come
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert first and "Traceback" not in err and "BrokenPipe" not in err
    assert json.loads((tmp_path / "r.json").read_text())["closed_loop"]["status"] == "ok"
    assert sorted(p.suffix for p in (tmp_path / "renders").iterdir()) == [".mp4", ".png", ".png", ".png", ".png"]


def test_an_interrupted_command_ignores_further_signals_while_it_exits(monkeypatch: pytest.MonkeyPatch) -> None:
    """A second SIGTERM 0.1-0.3 s after the first, while an interrupted command removed what it left (the slow
    exit, partly in Python's finalisation, which restores SIGTERM's default), ended it with 143, not 130."""
    import signal

    import sim.cli.main as cli

    before = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        monkeypatch.setattr(cli, "main", lambda: 130)
        assert cli.console() == 130
        assert all(signal.getsignal(sig) == signal.SIG_IGN for sig in before)
        monkeypatch.setattr(cli, "main", lambda: 0)
        for sig, handler in before.items():
            signal.signal(sig, handler)
        monkeypatch.setattr(cli.gc, "freeze", lambda: None)
        assert cli.console() == 0 and all(signal.getsignal(sig) == before[sig] for sig in before)
    finally:
        for sig, handler in before.items():
            signal.signal(sig, handler)


@pytest.mark.slow  # a simulation with its video, stopped while it encodes: 6 s
def test_a_hangup_while_encoding_is_an_interrupt_leaving_no_staging_folder(tmp_path: Path) -> None:
    """SIGHUP (a closed terminal, a dropped ssh connection) ended the command with 129, saying nothing, and left
    ``.nhsim-outputs-XXXX.part/new/.v.XXXX.part.mp4`` for a later command to sweep a day later."""

    def encoding(out: str, err: str) -> bool:
        return bool(list(tmp_path.glob(".nhsim-outputs-*.part/new/.v.*.part.mp4")))

    args = ["simulate", "--reference", "line", "--video", "v.mp4", "--overwrite", "--no-plots", "--json", "r.json"]
    args += ["--gl", os.environ["MUJOCO_GL"]]  # the tests' backend (stop_when sets MUJOCO_GL, not PyOpenGL's)
    stopped = stop_when(args, tmp_path, encoding, signal.SIGHUP)
    assert_interrupted(stopped, "simulate", tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_an_interrupt_after_the_outputs_are_placed_says_what_was_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """An interrupt held through the placing of the outputs acts after it: ``regress --update`` then said
    "interrupted" (exit 130) of baselines it had all replaced, and printed none of its "updated" lines."""
    from sim.cli.main import main
    from sim.outputs import StagedOutputs

    real = StagedOutputs.commit

    def then_interrupted(self: StagedOutputs) -> list[Path]:
        real(self)
        raise KeyboardInterrupt  # the Ctrl-C that came during the placing, delivered as it ends

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(StagedOutputs, "commit", then_interrupted)
    assert main(["plan", "--scenario", "simple_motion", "--planner", "rrt", "--json", "p.json"]) == 130
    assert capsys.readouterr().err.strip() == "nhsim plan: interrupted, after writing p.json"
    assert (tmp_path / "p.json").is_file()
    import sim.cli.plan

    def interrupted(args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(sim.cli.plan, "run", interrupted)  # the next command writes nothing: nothing said of it
    assert main(["plan", "--scenario", "simple_motion", "--planner", "rrt"]) == 130
    assert capsys.readouterr().err.strip() == "nhsim plan: interrupted"


def test_an_interrupt_while_the_scene_is_built_waits_for_the_model(monkeypatch: pytest.MonkeyPatch) -> None:
    """A SIGINT landing inside a MuJoCo binding's argument conversion (``spec.stat.center = [...]``, pybind11 trying
    each overload) was taken for a failed conversion: "TypeError: incompatible function arguments", a traceback and
    exit 1 instead of 130. The scene is built with the signals held; the interrupt acts once the model is made."""
    from planning.core.robot import load_robot
    from planning.scenario import load_scenario
    from sim.physics import model

    added: list[str] = []
    walls = model._add_walls

    def interrupted_walls(*args: object) -> list[str]:
        signal.raise_signal(signal.SIGINT)  # with the default handler: KeyboardInterrupt here, mid-build
        added.extend(walls(*args))
        return added

    monkeypatch.setattr(model, "_add_walls", interrupted_walls)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with pytest.raises(KeyboardInterrupt):
        model.build_model(load_robot("turtlebot3"), load_scenario("farm").world)
    assert len(added) == 4  # the walls were all added: the interrupt waited for the block's end
