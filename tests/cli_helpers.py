"""Running ``nhsim`` in the test's own process: its exit status and what it printed, as a subprocess would
give them, without a new interpreter's start and imports (a second or more a call on two cores). For what a
subprocess alone shows (signals, the console's handling of stdout, the default outputs' folder), run
``python -m sim`` (``tests.test_cli.nhsim``); for something done to a command while it runs (a worker killed, a
server stopped), :func:`nhsim_meanwhile`."""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def nhsim_here(*args: str) -> subprocess.CompletedProcess[str]:
    """``nhsim ARGS`` run in this process (its exit status and what it printed)."""
    from sim.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:  # a usage error (argparse exits 2)
            code = int(exc.code or 0)
    return subprocess.CompletedProcess(["nhsim", *args], code, out.getvalue(), err.getvalue())


def nhsim_meanwhile(
    args: list[str],
    ready: Callable[[subprocess.Popen[str]], bool],
    act: Callable[[subprocess.Popen[str]], object],
    *,
    cwd: Path | None = None,
    timeout: float = 120.0,
) -> subprocess.CompletedProcess[str]:
    """``python -m sim ARGS`` in a process of its own; once ``ready(process)`` holds, ``act(process)``; then its
    exit status and what it printed. The command still running at the end is killed.

    Raises:
        AssertionError: It ended before it was ready, or was not ready within ``timeout`` seconds.
    """
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    pipe = subprocess.PIPE
    proc = subprocess.Popen([sys.executable, "-m", "sim", *args], cwd=cwd, env=env, stdout=pipe, stderr=pipe, text=True)
    deadline = time.monotonic() + timeout
    try:
        while not ready(proc):
            assert proc.poll() is None, f"the command ended before it was ready: {proc.communicate()[1]}"
            assert time.monotonic() < deadline, "the command was not ready in time"
            time.sleep(0.05)
        act(proc)
        out, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return subprocess.CompletedProcess(["nhsim", *args], proc.returncode, out, err)
